"""Field snapshots taken during a run."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Snapshot:
    """Fields at one converged step: ``points`` (N,3) current coordinates [mm],
    ``displacement`` (N,3) [mm], ``contact_force`` (N,3) force of the rigid
    planes [N], ``contact_pressure`` (N,) particle-particle contact pressure
    [MPa], ``cells`` (E,8) hexahedra, ``particle`` (E,) the particle (octant
    index) of each element, ``von_mises`` and ``mean_stress`` (E,) [MPa],
    ``eqps`` (E,)."""

    label: str
    time_s: float
    rel_density: float
    fields: dict[str, np.ndarray]
