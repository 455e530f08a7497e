"""Norton similarity: one computed curve mapped to other stresses and ramps.

For a rigid-viscoplastic Norton body with frictionless or tied contact the
sequence of shapes does not depend on the load history: the density depends
on time only through ``tau = integral (f sigma(t))^n dt``. With a linear
ramp of length ``t_r`` to the full stress ``s = f sigma``,

    tau = s^n t_eff,   t_eff = t^(n+1) / ((n+1) t_r^n)  (t <= t_r),
                       t_eff = t - n t_r / (n+1)          (t >= t_r),

so a curve computed at ``s1`` (ramp ``t_r1``) gives the curve at ``s2``
(ramp ``t_r2``) by ``t_eff2 = t_eff1 (s1 / s2)^n``, at no cost. The creep
coefficient C enters only through ``C tau`` (the same material at another
temperature, C1 -> C2, with the same n): ``t_eff2 = t_eff1 (C1 s1^n) /
(C2 s2^n)``; with elasticity this is exact but for the ramp (a change of C
is a change of the time unit), and its error is estimated as that of the
change of stress with the same effect on the rate, ``s2 (C2 / C1)^(1/n)``,
which over-estimates it.

The mapping is exact but for what breaks the similarity: elasticity (the
elastic strains scale with s / E, not with tau) and the compliance of the
contacts. Its error is therefore measured, not assumed: a second computed
curve (the *calibration*, at another stress) is mapped from the source and
compared with itself. For a target between the two stresses that mismatch
bounds the similarity error (it grows with the change of the stress; beyond
the calibration it is scaled up by ``|s2 - s1| / |s_cal - s1|``). The
mapped curve also differs from a run at the target stress by the two runs'
time discretisations, whose step sequences differ: half the time tolerance
is added for it (the time errors measured at a tolerance after the ramp are
a third of it or less; during a long ramp they can be larger: sc at 40 MPa
with a 5 s ramp, tolerance 0.02, has t(0.55) 8 % short). ``benches/similarity.py``
measures the estimate against full runs. A mapping without calibration has
no error estimate (None).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .result import MARK_DENSITIES, Result, interpolate_time


FloatArray = npt.NDArray[np.float64]

# Densities whose errors make a mapped curve's error: from the first mark
# above the initial transient (the ramp's first elastic contact response,
# where the similarity does not hold and no density of interest lies).
ERROR_FROM_ABOVE_RHO0 = 0.05


def effective_time(time_s: npt.ArrayLike, n: float, ramp_time_s: float) -> FloatArray:
    """t_eff [s] at the times ``time_s`` [s] under a linear ramp of
    ``ramp_time_s`` [s] (0: none), for the Norton exponent ``n``."""
    t = np.asarray(time_s, dtype=float)
    if ramp_time_s <= 0.0:
        return t.copy()
    with np.errstate(divide="ignore"):
        ramp = np.exp((n + 1.0) * np.log(np.maximum(t, 0.0) / ramp_time_s)) * ramp_time_s / (n + 1.0)
    return np.where(t <= ramp_time_s, ramp, t - n * ramp_time_s / (n + 1.0))


def real_time(t_eff: npt.ArrayLike, n: float, ramp_time_s: float) -> FloatArray:
    """The time [s] of an effective time ``t_eff`` [s] (inverse of
    :func:`effective_time`)."""
    te = np.asarray(t_eff, dtype=float)
    if ramp_time_s <= 0.0:
        return te.copy()
    with np.errstate(divide="ignore"):
        ramp = ramp_time_s * np.exp(np.log((n + 1.0) * np.maximum(te, 0.0) / ramp_time_s) / (n + 1.0))
    return np.where(te < ramp_time_s / (n + 1.0), ramp, te + n * ramp_time_s / (n + 1.0))


@dataclass(frozen=True)
class MappedCurve:
    """A computed curve mapped to another load by Norton similarity.

    ``time_s`` and ``rel_density`` are the mapped curve; ``stress_mpa``,
    ``knockdown`` and ``ramp_time_s`` its load; ``source_stress_mpa`` the
    stress of the computed curve; ``creep_c`` the creep coefficient mapped
    to. ``relative_error`` is the estimated relative error of t(rho) at the
    mark densities reached (keys as in
    ``times_to_density_s``), ``error`` the largest of them (None without a
    calibration curve, see :mod:`tidens_rs.similarity`)."""

    time_s: FloatArray
    rel_density: FloatArray
    stress_mpa: float
    knockdown: float
    ramp_time_s: float
    source_stress_mpa: float
    creep_c: float
    relative_error: dict[str, float]
    error: float | None

    def time_to_density(self, rho: float) -> float | None:
        """Time [s] to reach ``rho`` on the mapped curve, None if the source
        never reached it."""
        return interpolate_time(self.time_s, self.rel_density, rho)


def map_curve(
    source: Result,
    stress_mpa: float,
    *,
    knockdown: float | None = None,
    ramp_time_s: float | None = None,
    creep_c: float | None = None,
    calibration: Result | None = None,
    accuracy: float | None = None,
) -> MappedCurve:
    """The curve of ``source`` mapped to the stress ``stress_mpa`` [MPa]
    (and ``knockdown``, ``ramp_time_s``, the creep coefficient ``creep_c``
    [MPa^-n s^-1] of the material at another temperature: default the
    source's). With
    ``calibration``, a run of the same case at another stress, the mapping's
    error is estimated (see the module docstring); with ``accuracy`` (a
    relative error of t(rho)) the mapping is refused (ValueError) where that
    estimate exceeds it, or where there is no calibration to estimate it."""
    if not isinstance(source, Result):
        raise TypeError(f"source = {source!r}: must be a Result (of Case.run or tidens_rs.load)")
    case = source.case
    n = case.material.creep_n
    s1 = case.knockdown * case.stress_mpa
    f2 = case.knockdown if knockdown is None else float(knockdown)
    tr2 = case.ramp_time_s if ramp_time_s is None else float(ramp_time_s)
    s2 = f2 * float(stress_mpa)
    if not (np.isfinite(s2) and s2 > 0.0):
        raise ValueError(f"stress_mpa = {stress_mpa!r}, knockdown = {knockdown!r}: the stress the cell feels must be > 0")
    if not (np.isfinite(tr2) and tr2 >= 0.0):
        raise ValueError(f"ramp_time_s = {ramp_time_s!r}: must be >= 0 s")
    c1 = case.material.creep_c
    c2 = c1 if creep_c is None else float(creep_c)
    if not (np.isfinite(c2) and c2 > 0.0):
        raise ValueError(f"creep_c = {creep_c!r}: must be > 0 MPa^-n s^-1")
    t_eff = effective_time(source.time_s, n, case.ramp_time_s) * np.exp(n * np.log(s1 / s2) + np.log(c1 / c2))
    time_s = real_time(t_eff, n, tr2)
    relative: dict[str, float] = {}
    error: float | None = None
    if calibration is not None:
        relative = _calibrated_error(source, calibration, s2 * (c2 / c1) ** (1.0 / n))
        error = max(relative.values()) if relative else None
    if accuracy is not None:
        if error is None:
            raise ValueError("accuracy: the mapping's error is not known without a calibration run (or the runs reach no mark density)")
        if error > accuracy:
            raise ValueError(
                f"accuracy = {accuracy:g}: the mapping from {case.stress_mpa:g} to {stress_mpa:g} MPa is estimated to "
                f"{error:.3g} (at rho = {max(relative, key=lambda k: relative[k])}); run the case instead"
            )
    return MappedCurve(
        time_s=time_s,
        rel_density=np.array(source.rel_density, dtype=float),
        stress_mpa=float(stress_mpa),
        knockdown=f2,
        ramp_time_s=tr2,
        source_stress_mpa=case.stress_mpa,
        creep_c=c2,
        relative_error=relative,
        error=error,
    )


def _calibrated_error(source: Result, calibration: Result, s2: float) -> dict[str, float]:
    """The relative error of each mark density's time when ``source`` is
    mapped to the stress ``s2`` [MPa, f sigma] (the equivalent stress of a
    change of C): the mismatch between
    ``calibration`` and ``source`` mapped to it, scaled by the change of
    the stress."""
    cal = calibration.case
    src = source.case
    if (cal.material.creep_c, cal.material.creep_n, cal.cell.name, cal.cell.rho0) != (src.material.creep_c, src.material.creep_n, src.cell.name, src.cell.rho0):
        raise ValueError("calibration: must be a run of the source's cell and material at another stress")
    s1, sc = src.knockdown * src.stress_mpa, cal.knockdown * cal.stress_mpa
    if abs(sc - s1) <= 1e-9 * s1:
        raise ValueError("calibration: its stress must differ from the source's")
    onto = map_curve(source, cal.stress_mpa, knockdown=cal.knockdown, ramp_time_s=cal.ramp_time_s)
    scale = max(1.0, abs(s2 - s1) / abs(sc - s1))
    floor = 0.5 * max(src.solver.tolerance, cal.solver.tolerance)
    out: dict[str, float] = {}
    for m in MARK_DENSITIES:
        if m < source.rho0 + ERROR_FROM_ABOVE_RHO0:
            continue
        mapped, truth = onto.time_to_density(m), interpolate_time(calibration.time_s, calibration.rel_density, m)
        if mapped is None or truth is None or truth <= 0.0:
            continue
        out[f"{m:g}"] = scale * abs(mapped - truth) / truth + floor
    return out
