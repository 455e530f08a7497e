"""The error estimate of a run: how far its times to density are from the
converged ones.

The total comes from a coarse companion: the same case one mesh level down
*and* at twice the time tolerance, so that it refines space and time
together. With element sizes h (the run) and H (the companion), the mesh
error shrinks by (H/h)^p from the companion to the run and the time error
by 2 (the tolerance halves), about the same factor (1.5 to 1.8 between
levels). Richardson's estimate of the run's relative error of t(rho) is
g |t_run - t_companion| / t_run with g = h^p / (H^p - h^p). The order p is
the one measured, 1.5, not the 2 of smooth problems: where the reference
ladders of the contact cells converge monotonically their observed orders
are 1.15 to 1.7 (sc at rho = 0.8, sc at 10 MPa at 0.8, sc2 at 0.9; the
edge of a contact patch moves by whole elements, an error of first order
in h that the growth of the patch partly averages out).

On the contact cells the error of t(rho) is also not a smooth function of
the density: the contact patches grow one ring of nodes at a time, the
densification rate drops at each ring's arrival and stays nearly flat
between, so a level's curve swings about the converged one, one swing per
ring (a period of 0.03 to 0.08 in rho at levels 1 to 3, swings of a few per
cent at level 2). Whether a level is early or late at a given density is a
matter of phase. The difference is therefore taken as its root mean square
over rho +- 0.025, about one swing of a level-2 companion, so that the
estimate measures the size of the error near a density rather than its
phase there. The true error at one density can be anywhere below that
size, crossing zero between swings, so no estimate that does not know the
phase brackets it within a factor of 3 at every density (see
``benches/accuracy.py --pointwise`` and the README for the measured rates).
The estimate errs on the high side: it is meant to be exceeded rarely.

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
``extrapolated_s`` is the Richardson value t_run + g (t_run - t_companion)
at each density.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

# The core's inner-cube divisions of each mesh level (element size ~ 1 / divisions).
from ._core import LEVEL_DIVISIONS

# Order of the mesh error in the element size, as measured on the contact
# cells (see the module docstring).
MESH_ORDER = 1.5
# Half-width in rho of the window over which the level difference is taken:
# about one swing of a level-2 companion's curve about the converged one.
DENSITY_WINDOW = 0.025
# The companion's time tolerance over the run's.
COMPANION_TOLERANCE_FACTOR = 2.0
# Points per window at which the two curves are compared.
_SAMPLES = 101


@dataclass(frozen=True)
class ErrorEstimate:
    """Estimated relative errors of a run's times to density (keys as in
    ``times_to_density_s``: ``"0.8"`` etc.), never negative.

    ``relative`` is the total from the coarse companion (None without one),
    ``mesh`` the same number (the companion refines mesh and tolerance
    together), ``time`` the step controller's bound on the time part alone,
    ``curve`` the largest of each over the reported densities,
    ``extrapolated_s`` the Richardson extrapolation of each t(rho), and
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


def richardson_factor(level: int, coarse_level: int, order: float | None = None) -> float:
    """g = h^p / (H^p - h^p) for the element sizes of the two levels (p:
    ``order``, default :data:`MESH_ORDER`)."""
    order = MESH_ORDER if order is None else order
    h = 1.0 / LEVEL_DIVISIONS[level]
    big = 1.0 / LEVEL_DIVISIONS[coarse_level]
    return float(h**order / (big**order - h**order))


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
    companion_wall_seconds: float | None = None,
    companion_note: str | None = None,
) -> ErrorEstimate:
    """The estimate of a run's errors at the densities ``marks`` it reached.

    ``curve`` and ``companion`` hold ``time_s``, ``rel_density`` and (the
    run's) ``time_error_s`` arrays; ``companion`` is the coarse run (None:
    no mesh part, ``companion_note`` says why). ``level`` and
    ``companion_level`` set the Richardson factor (default: consecutive
    levels 3 and 2).
    """
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
        g = richardson_factor(lv, lc)
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
            tc_m = float(_time_at(tc, rc, np.array([m]))[0])
            extrapolated[k] = times[k] + g * (times[k] - tc_m)
        method["mesh"] = (
            f"Richardson from a companion run at mesh level {lc} and {COMPANION_TOLERANCE_FACTOR:g} times the "
            f"tolerance (this run: level {lv}), order {MESH_ORDER:g} in the element size (as measured on the contact cells) "
            f"(factor {g:.3g}), the difference taken as its root mean square over rho +-{DENSITY_WINDOW:g}"
        )
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
