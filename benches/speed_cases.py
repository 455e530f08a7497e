"""The cases of the speed targets, shared by ``speed.py`` (which times them)
and ``references.py`` (which gives their converged times to density)."""

from __future__ import annotations

from typing import Any

import tidens_rs as td

# Densities whose times are compared with the references.
MARKS = (0.8, 0.9, 0.95)

# name: (cell, stress [MPa], target density); Ti-6Al-4V at 1293 K, 1 s ramp.
CASES: dict[str, tuple[str, float, float]] = {
    "sc10": ("sc", 10.0, 0.9),
    "sc": ("sc", 15.0, 0.95),
    "bcc": ("bcc", 15.0, 0.95),
    "fcc": ("fcc", 15.0, 0.95),
    "sc2": ("sc2", 15.0, 0.95),
}


def case_of(name: str, **solver: Any) -> td.Case:
    """The case ``name`` with the solver settings ``solver`` (the rest default)."""
    cell, stress, _ = CASES[name]
    return td.Case(
        cell=td.cells.by_name(cell),
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=stress,
        solver=td.SolverSettings(**solver),
    )
