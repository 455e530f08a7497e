"""The closed-form continuum model of die pressing (docs/model.md section 8).

Densification rates of Eqs. 2 and 3 of the paper (Norton creep ``C q^n``, stress
acting on the powder ``s = f sigma`` [MPa], rates in 1/s):

* initial stage (rho < 0.9)::

    rho_dot = 3.06 C ((1-rho0)/(rho-rho0))^(n-1/2) rho0^(1/3) / rho^(2n-2/3) (Bi s/3)^n

* final stage (rho >= 0.9)::

    rho_dot = 1.5 C rho (1-rho) / (1-(1-rho)^(1/n))^n (3 Bf s/(2n))^n

with Bi = 1.1, Bf = 1.8 for die pressing. Both rates are ``s^n`` times a
function of rho, so under a ramp ``s(t)`` the density depends on time only
through the effective time ``t_eff = integral (s(t)/s)^n dt``;
``t(rho)`` is the integral of ``1/rho_dot`` from rho0 (the integrand vanishes
at rho0), mapped back from ``t_eff`` to ``t``.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Protocol

import numpy as np
import numpy.typing as npt

from .io import atomic_write

B_INITIAL = 1.1
B_FINAL = 1.8
STAGE_SWITCH = 0.9

FloatArray = npt.NDArray[np.float64]


class NortonLaw(Protocol):
    """What the model needs of a material: ``eps_dot = creep_c q^creep_n``."""

    @property
    def creep_c(self) -> float: ...

    @property
    def creep_n(self) -> float: ...


@lru_cache(maxsize=4)
def _gauss_legendre(points: int) -> tuple[FloatArray, FloatArray]:
    """Gauss-Legendre nodes and weights on [0, 1] (computed once: numpy
    finds them from an eigenvalue problem)."""
    u, w = np.polynomial.legendre.leggauss(points)
    return 0.5 * (u + 1.0), 0.5 * w


@dataclass(frozen=True)
class ContinuumModel:
    """Continuum densification model for one material and load.

    Parameters: ``creep_c`` [MPa^-n s^-1], ``creep_n``, ``stress_mpa`` (applied
    nominal stress), ``knockdown`` (die-wall factor f), ``rho0`` (initial
    relative density), ``ramp_time_s`` (linear ramp of the stress).
    """

    creep_c: float
    creep_n: float
    stress_mpa: float
    rho0: float
    knockdown: float = 1.0
    ramp_time_s: float = 0.0

    def __post_init__(self) -> None:
        checks = [
            ("creep_c", self.creep_c, self.creep_c > 0, "> 0 MPa^-n s^-1"),
            ("creep_n", self.creep_n, self.creep_n >= 1, ">= 1"),
            ("stress_mpa", self.stress_mpa, self.stress_mpa > 0, "> 0 MPa"),
            ("rho0", self.rho0, 0 < self.rho0 < STAGE_SWITCH, "in (0, 0.9)"),
            ("knockdown", self.knockdown, 0 < self.knockdown <= 1, "in (0, 1]"),
            ("ramp_time_s", self.ramp_time_s, self.ramp_time_s >= 0, ">= 0 s"),
        ]
        for name, value, ok, allowed in checks:
            if not (ok and np.isfinite(value)):
                raise ValueError(f"{name} = {value}: must be {allowed}")

    @property
    def cell_stress_mpa(self) -> float:
        """Stress acting on the powder, f sigma [MPa]."""
        return self.knockdown * self.stress_mpa

    def rate(self, rho: npt.ArrayLike) -> FloatArray:
        """Densification rate at full load [1/s], Eqs. 2 (rho < 0.9) and 3 of
        the paper; ``inf`` where it exceeds the largest float (rho0, or n
        near 50 at a high stress)."""
        with np.errstate(over="ignore"):
            return np.exp(self.log_rate(rho))

    def log_rate(self, rho: npt.ArrayLike) -> FloatArray:
        """Natural log of :meth:`rate`, evaluated as a sum of logs so that no
        power overflows for any n the core accepts (``+inf`` at rho0)."""
        r = np.asarray(rho, dtype=float)
        c, n, s, r0 = self.creep_c, self.creep_n, self.cell_stress_mpa, self.rho0
        out = np.empty_like(r)
        ini = r < STAGE_SWITCH
        x = np.maximum(r[ini] - r0, 0.0)
        with np.errstate(divide="ignore"):
            out[ini] = (
                np.log(3.06 * c) + (n - 0.5) * (np.log(1.0 - r0) - np.log(x)) + np.log(r0) / 3.0
                - (2.0 * n - 2.0 / 3.0) * np.log(r[ini]) + n * np.log(B_INITIAL * s / 3.0)
            )
        rf = r[~ini]
        out[~ini] = (
            np.log(1.5 * c) + np.log(rf) + np.log1p(-rf) - n * np.log(-np.expm1(np.log1p(-rf) / n))
            + n * np.log(3.0 * B_FINAL * s / (2.0 * n))
        )
        return out

    def effective_time(self, rho: npt.ArrayLike, points: int = 400) -> FloatArray:
        """Effective time at full load to reach each density [s]: the integral
        of 1/rho_dot from rho0, for all densities at once (Gauss-Legendre on
        each stage, with ``rho = rho0 + (rho_1 - rho0) u^2`` to smooth the
        start and ``rho = 1 - 0.1 ((1 - rho)/0.1)^u`` in the final stage,
        where 1/rate grows as 1/(1 - rho))."""
        targets = np.asarray(rho, dtype=float)
        flat = np.atleast_1d(targets).ravel()
        if np.any(~np.isfinite(flat)) or np.any(flat < self.rho0) or np.any(flat >= 1.0):
            raise ValueError(f"rho must be in [rho0 = {self.rho0:.5f}, 1)")
        if flat.size > _CHUNK:
            # Row by row of nodes: a block of all targets at once would take
            # targets x points floats several times over.
            parts = [self.effective_time(flat[k : k + _CHUNK], points) for k in range(0, flat.size, _CHUNK)]
            whole: FloatArray = np.concatenate(parts).reshape(np.shape(np.atleast_1d(targets)))
            return whole
        u, w = _gauss_legendre(points)
        # Initial stage, rho0 to min(target, 0.9): one row of nodes per target.
        span = np.minimum(flat, STAGE_SWITCH) - self.rho0
        rr = self.rho0 + span[:, None] * u[None, :] ** 2
        t = (self._slowness(rr) * (w * 2.0 * u)[None, :]).sum(axis=1) * span
        # Final stage, 0.9 to the target, for the targets beyond it.
        late = flat > STAGE_SWITCH
        if np.any(late):
            a, b = 1.0 - STAGE_SWITCH, 1.0 - flat[late]
            log_ratio = np.log(b / a)
            rr = 1.0 - a * np.exp(u[None, :] * log_ratio[:, None])
            drdu = -(1.0 - rr) * log_ratio[:, None]
            t[late] += (w[None, :] * drdu * self._slowness(rr)).sum(axis=1)
        out: FloatArray = t.reshape(np.shape(np.atleast_1d(targets)))
        return out

    def _slowness(self, rho: FloatArray) -> FloatArray:
        """1 / rate [s], from the log of the rate (0 at rho0; ``inf`` only
        where the time itself passes the largest float)."""
        with np.errstate(over="ignore"):
            return np.exp(-self.log_rate(rho))

    def time_from_effective(self, t_eff: npt.ArrayLike) -> FloatArray:
        """Real time [s] for an effective time [s], inverting the ramp."""
        te = np.asarray(t_eff, dtype=float)
        n, tr = self.creep_n, self.ramp_time_s
        if tr <= 0:
            return te.copy()
        in_ramp = te < tr / (n + 1.0)
        # Within the ramp t = ((n + 1) tr^n t_eff)^(1/(n+1)), in logs (tr^n overflows for large n).
        with np.errstate(divide="ignore"):
            log_t = (np.log(n + 1.0) + n * np.log(tr) + np.log(np.maximum(te, 0.0))) / (n + 1.0)
        return np.where(in_ramp, np.exp(log_t), te + n * tr / (n + 1.0))

    def time_to_density(self, rho: npt.ArrayLike) -> FloatArray:
        """Time [s] to reach each density under the ramp and hold."""
        return self.time_from_effective(self.effective_time(rho))

    def curve(self, rho_end: float, points: int = 200) -> tuple[FloatArray, FloatArray]:
        """(time [s], density) from rho0 to ``rho_end``."""
        rho = self.rho0 + (rho_end - self.rho0) * np.linspace(0.0, 1.0, points) ** 2
        return self.time_to_density(rho), rho


# Targets of effective_time evaluated at once (bounds its memory to a few MB).
_CHUNK = 1024
# The most rows write_curve writes: far more than a plot or a table needs.
MAX_CURVE_POINTS = 100_000


def for_material(
    material: NortonLaw,
    stress_mpa: float,
    rho0: float,
    *,
    knockdown: float = 1.0,
    ramp_time_s: float = 0.0,
) -> ContinuumModel:
    """The continuum model for a material's Norton law (``creep_c``
    [MPa^-n s^-1], ``creep_n``) under the piston stress ``stress_mpa``
    [MPa], from the relative density ``rho0``; the stress acts in full from
    t = 0 unless ``ramp_time_s`` [s] gives a linear ramp."""
    return ContinuumModel(
        creep_c=material.creep_c,
        creep_n=material.creep_n,
        stress_mpa=stress_mpa,
        rho0=rho0,
        knockdown=knockdown,
        ramp_time_s=ramp_time_s,
    )


def write_curve(model: ContinuumModel, until_density: float, path: Path, points: int = 200) -> Path:
    """Writes the model's curve from rho0 to ``until_density`` as CSV
    (``time_s``, ``rel_density``; ``points`` rows, closer together near
    rho0) to ``path``, through a temporary file renamed once complete;
    returns ``path``."""
    if not (model.rho0 < until_density < 1.0):
        raise ValueError(f"until_density = {until_density}: must be in (rho0 = {model.rho0:.5f}, 1)")
    if isinstance(points, bool) or not isinstance(points, int):
        raise TypeError(f"points = {points!r}: must be an integer in [2, {MAX_CURVE_POINTS}]")
    if not 2 <= points <= MAX_CURVE_POINTS:
        raise ValueError(f"points = {points!r}: must be an integer in [2, {MAX_CURVE_POINTS}]")
    time_s, rho = model.curve(until_density, points)

    def write(tmp: Path) -> None:
        with tmp.open("w", newline="") as f:
            out = csv.writer(f)
            out.writerow(["time_s", "rel_density"])
            out.writerows((repr(float(t)), repr(float(r))) for t, r in zip(time_s, rho))

    return atomic_write(path, write)
