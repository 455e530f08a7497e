"""The error estimate of a run: how far its times to density are from the
converged ones.

The total comes from a coarse companion: the same case one mesh level down
*and* at twice the time tolerance, so that it refines space and time
together. With element sizes h (the run) and H (the companion), both errors
shrink by about (H/h)^2 from the companion to the run (the mesh error goes
as h^2; the time error as the tolerance, which halves, and (H/h)^2 is 1.8
to 2.3 between levels). How the difference d = |t_run - t_companion| / t_run
splits between the two levels depends on how the element converges, which
the accuracy study measured (README, "How far from converged"):

hex8, alternating
    Its times to density move up and down from level to level (nodes meet
    the planes and the other particles one at a time, and whether a level
    is early or late at a density is the phase of those events): the signs
    of the changes alternated in 13 of the 17 three-level sequences of the
    study, and where they did not, the observed order was near 4. With
    errors of alternating sign that shrink by rho = (h/H)^2 a level, the
    converged time lies between the two runs and the run's error is
    g d with g = h^2 / (H^2 + h^2) (0.31 from level 1 to 2, 0.36 from 2 to
    3, 0.35 from 3 to 4); the study measured 0.09 to 0.32 wherever the true
    error stands clear of the reference's own uncertainty. No extrapolated
    time is given: neither this model's nor the monotone one's moved the
    times closer to the references.
tet10, monotone
    The quadratic tetrahedra converge from one side (from below: faster
    densification on coarse meshes, on sc, bcc and sc2): Richardson's
    g = h^2 / (H^2 - h^2) (0.8, 1.29, 1.12) and the extrapolated time
    t_run + g (t_run - t_companion).

Mesh convergence on contact cells is not smooth, and the two curves can
cross at a density by chance: d is taken as its root mean square over
rho +- 0.01.

Parts, each a non-negative relative error:

relative
    The total, as above; None when there is no companion (a level-1 run,
    ``error_estimate=False``, a failed or interrupted companion).
mesh
    The same number: the companion refines mesh and tolerance together and
    cannot tell them apart. It bounds the mesh part.
time
    The step controller's own accumulated estimate (``time_error_s`` of the
    curve, by magnitude): backward Euler's leading term, exact on smooth
    creep (a Norton cube) and an upper bound on the cells, measured 3 to 7
    times the true time error on sc and bcc (see the README). Tightening the
    tolerance alone cannot gain more than this.

The curve as a whole gets the largest of each over the reported densities.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

# The core's inner-cube divisions of each mesh level (element size ~ 1 / divisions).
from ._core import LEVEL_DIVISIONS

# Order assumed for the Richardson factor of the mesh part.
MESH_ORDER = 2.0
# How each element's times to density converge with the mesh level (see the
# module docstring): "alternating" or "monotone".
CONVERGENCE: dict[str, str] = {"hex8": "alternating", "tet10": "monotone"}
# Half-width in rho of the window over which the level difference is taken.
DENSITY_WINDOW = 0.01
# The companion's time tolerance over the run's.
COMPANION_TOLERANCE_FACTOR = 2.0
# Points per window at which the two curves are compared.
_SAMPLES = 41


@dataclass(frozen=True)
class ErrorEstimate:
    """Estimated relative errors of a run's times to density (keys as in
    ``times_to_density_s``: ``"0.8"`` etc.), never negative.

    ``relative`` is the total from the coarse companion (None without one),
    ``mesh`` the same number (the companion refines mesh and tolerance
    together), ``time`` the step controller's bound on the time part alone,
    ``curve`` the largest of each over the reported densities,
    ``extrapolated_s`` the Richardson extrapolation of each t(rho) (for an
    element that converges from one side; empty for hex8), and
    ``method`` says how each was obtained (see :mod:`tidens_rs.estimate`).
    """

    relative: dict[str, float | None]
    time: dict[str, float]
    mesh: dict[str, float | None]
    curve: dict[str, float | None]
    extrapolated_s: dict[str, float]
    method: dict[str, str]
    companion_level: int | None = None
    companion_wall_seconds: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "relative": self.relative,
            "time": self.time,
            "mesh": self.mesh,
            "curve": self.curve,
            "extrapolated_s": self.extrapolated_s,
            "method": self.method,
            "companion_level": self.companion_level,
            "companion_wall_seconds": self.companion_wall_seconds,
        }


def richardson_factor(level: int, coarse_level: int, order: float | None = None, convergence: str = "monotone") -> float:
    """The share g of the relative difference of the two levels' times that
    is the finer run's error, for the element sizes h and H of the levels
    (p: ``order``, default :data:`MESH_ORDER`): h^p / (H^p - h^p) when the
    errors keep their sign (``convergence="monotone"``), h^p / (H^p + h^p)
    when they alternate (``"alternating"``)."""
    order = MESH_ORDER if order is None else order
    h = (1.0 / LEVEL_DIVISIONS[level]) ** order
    big = (1.0 / LEVEL_DIVISIONS[coarse_level]) ** order
    if convergence == "monotone":
        return float(h / (big - h))
    if convergence == "alternating":
        return float(h / (big + h))
    raise ValueError(f"convergence = {convergence!r}: must be 'monotone' or 'alternating'")


def _time_at(time_s: np.ndarray, rho: np.ndarray, target: np.ndarray) -> np.ndarray:
    """t(rho) at each target (rho non-decreasing along the curve), linear
    between steps; the first time the density reaches each target."""
    # np.interp needs increasing abscissae: keep the first of equal densities.
    keep = np.concatenate([[True], np.diff(rho) > 0])
    return np.asarray(np.interp(target, rho[keep], time_s[keep]))


def estimate_error(
    curve: Mapping[str, np.ndarray],
    companion: Mapping[str, np.ndarray] | None,
    marks: Sequence[float],
    *,
    level: int | None = None,
    companion_level: int | None = None,
    element: str = "hex8",
    companion_wall_seconds: float | None = None,
    companion_note: str | None = None,
) -> ErrorEstimate:
    """The estimate of a run's errors at the densities ``marks`` it reached.

    ``curve`` and ``companion`` hold ``time_s``, ``rel_density`` and (the
    run's) ``time_error_s`` arrays; ``companion`` is the coarse run (None:
    no mesh part, ``companion_note`` says why). ``level`` and
    ``companion_level`` (default: consecutive levels 3 and 2) and the
    ``element``'s convergence (:data:`CONVERGENCE`) set the Richardson factor.
    """
    if element not in CONVERGENCE:
        raise ValueError(f"element = {element!r}: must be one of {sorted(CONVERGENCE)}")
    convergence = CONVERGENCE[element]
    t, rho = np.asarray(curve["time_s"], float), np.asarray(curve["rel_density"], float)
    terr = np.asarray(curve["time_error_s"], float)
    reached = [m for m in marks if rho[-1] >= m > rho[0]]
    keys = [f"{m:g}" for m in reached]
    times = {k: float(_time_at(t, rho, np.array([m]))[0]) for k, m in zip(keys, reached)}
    time_part = {k: abs(float(np.interp(times[k], t, terr))) / times[k] if times[k] > 0 else 0.0 for k in keys}

    mesh: dict[str, float | None] = {k: None for k in keys}
    extrapolated: dict[str, float] = {}
    method = {
        "time": "the step controller's accumulated backward-Euler estimate (time_error_s), by magnitude: a bound on the time part alone",
    }
    if companion is None:
        method["mesh"] = "not estimated: " + (companion_note or "no coarse companion run")
    else:
        lv = level if level is not None else 3
        lc = companion_level if companion_level is not None else lv - 1
        g = richardson_factor(lv, lc, convergence=convergence)
        tc, rc = np.asarray(companion["time_s"], float), np.asarray(companion["rel_density"], float)
        lo, hi = max(rho[0], rc[0]), min(rho[-1], rc[-1])
        for k, m in zip(keys, reached):
            a, b = max(m - DENSITY_WINDOW, lo), min(m + DENSITY_WINDOW, hi)
            if not (b >= a and lo < m <= hi):
                continue
            grid = np.linspace(a, b, _SAMPLES if b > a else 1)
            fine, coarse = _time_at(t, rho, grid), _time_at(tc, rc, grid)
            ok = fine > 0
            diff = float(np.sqrt(np.mean(((fine[ok] - coarse[ok]) / fine[ok]) ** 2))) if ok.any() else 0.0
            mesh[k] = g * diff
            if convergence == "monotone":
                tc_m = float(_time_at(tc, rc, np.array([m]))[0])
                extrapolated[k] = times[k] + g * (times[k] - tc_m)
        signs = "errors of alternating sign" if convergence == "alternating" else "errors of one sign"
        method["mesh"] = (
            f"Richardson from a companion run at mesh level {lc} and {COMPANION_TOLERANCE_FACTOR:g} times the "
            f"tolerance (this run: level {lv}), {element}: {signs} of order {MESH_ORDER:g} in the element size "
            f"(factor {g:.3g}), the difference taken as its root mean square over rho +-{DENSITY_WINDOW:g}"
        )
        if convergence == "alternating":
            method["mesh"] += "; no extrapolated times (the converged time lies between the two runs)"
        if any(v is None for v in mesh.values()):
            method["mesh"] += "; None where the companion did not reach the density"
    # The companion refines mesh and tolerance together: its estimate is the total.
    total: dict[str, float | None] = dict(mesh)
    method["relative"] = "the companion's estimate (mesh and tolerance refined together)"

    def worst(d: Mapping[str, float | None]) -> float | None:
        vals = list(d.values())
        if not vals or any(v is None for v in vals):
            return None
        return max(float(v) for v in vals if v is not None)

    return ErrorEstimate(
        relative=total,
        time=time_part,
        mesh=mesh,
        curve={"relative": worst(total), "time": worst(time_part), "mesh": worst(mesh)},
        extrapolated_s=extrapolated,
        method=method,
        companion_level=companion_level if companion is not None else None,
        companion_wall_seconds=companion_wall_seconds,
    )
