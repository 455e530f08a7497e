"""Material presets of the paper (docs/model.md section 1) and custom materials.

Every preset has the default elastic constants E = 43.5 GPa and nu = 0.3,
which make the problem well posed and barely change densification. Creep:
``eps_dot = C q^n`` with C in MPa^-n s^-1.

The transformation-mismatch-plasticity preset (thermal cycling of Ti-6Al-4V,
n = 1) is linear in stress only while stresses stay near the internal stress
(7.4 MPa); the contact stresses of a powder exceed it, a limitation the paper
shares. :func:`thermal_cycling` builds the material of another cycle from
its physical parameters (:func:`tmp_creep_coefficient` gives its C).
"""

from __future__ import annotations

import math

from . import _checks
from ._core import PRESET_NAMES, Material, tmp_creep_coefficient

DEFAULT_YOUNG_MPA = 4.35e4
DEFAULT_POISSON = 0.3

TI64_CREEP_1293K = Material.preset("ti64-creep-1293k")
TI64_TMP_1133_1293K = Material.preset("ti64-tmp-1133-1293k")
CPTI_ALPHA_1003K = Material.preset("cpti-alpha-1003k")
CPTI_ALPHA_1073K = Material.preset("cpti-alpha-1073k")
CPTI_ALPHA_1143K = Material.preset("cpti-alpha-1143k")
CPTI_BETA_1253K = Material.preset("cpti-beta-1253k")

PRESETS: dict[str, Material] = {name: Material.preset(name) for name in PRESET_NAMES}


def by_name(name: str) -> Material:
    """The preset called ``name`` (one of :data:`PRESET_NAMES`)."""
    return Material.preset(name)


def custom(
    creep_c: float,
    creep_n: float,
    young_mpa: float = DEFAULT_YOUNG_MPA,
    poisson: float = DEFAULT_POISSON,
) -> Material:
    """A Norton material ``eps_dot = creep_c q^creep_n`` (C in MPa^-n s^-1;
    ``young_mpa`` E in MPa). TypeError naming the argument for a value that
    is not a real number, ValueError for one out of its range."""
    r = _checks.real
    return Material(r("young_mpa", young_mpa, "MPa"), r("poisson", poisson), r("creep_c", creep_c, "MPa^-n s^-1"), r("creep_n", creep_n))


def thermal_cycling(
    volume_mismatch: float = 0.0096,
    cycle_s: float = 191.0,
    internal_stress_mpa: float = 7.4,
    creep_n: float = 2.8,
    young_mpa: float = DEFAULT_YOUNG_MPA,
    poisson: float = DEFAULT_POISSON,
) -> Material:
    """Transformation-mismatch plasticity under thermal cycling through a
    phase change, averaged over a cycle as a linear (n = 1) Norton law
    (Greenwood and Johnson): ``eps_dot = (4/3) 5n/(4n+1) (dV/V) / dt_cycle
    * q / sigma0``, with ``volume_mismatch`` dV/V of the transformation,
    ``cycle_s`` the full period of the cycle [s], ``internal_stress_mpa``
    sigma0 [MPa] (the internal stress of the mismatch) and ``creep_n`` the
    creep exponent of the weaker phase. The defaults are the paper's
    Ti-6Al-4V cycle between 1133 and 1293 K: C = 1.039e-5, within 1 % of
    the preset's rounded 1.045e-5.

    The law is the first term of an expansion in q / sigma0: it holds while
    the stress stays small against the internal stress. Averaged over a
    packing the applied stresses of the paper (5 to 20 MPa) are of the
    order of sigma0 = 7.4 MPa, and in the necks between particles the
    stresses reach several times the applied one, so there the law is used
    beyond its range (as in the paper).
    """
    given = {"volume_mismatch": volume_mismatch, "cycle_s": cycle_s, "internal_stress_mpa": internal_stress_mpa, "creep_n": creep_n}
    for name, value in given.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"{name} = {value!r}: must be a real number")
    ranges = (
        ("volume_mismatch", volume_mismatch, "in (0, 0.2]", 0.0 < volume_mismatch <= 0.2),
        ("cycle_s", cycle_s, "> 0 s", cycle_s > 0.0),
        ("internal_stress_mpa", internal_stress_mpa, "> 0 MPa", internal_stress_mpa > 0.0),
        ("creep_n", creep_n, "in [1, 50]", 1.0 <= creep_n <= 50.0),
    )
    for name, value, allowed, ok in ranges:
        if not (math.isfinite(value) and ok):
            raise ValueError(f"{name} = {value!r}: must be {allowed}")
    c = tmp_creep_coefficient(volume_mismatch, cycle_s, internal_stress_mpa, creep_n)
    return Material(young_mpa, poisson, c, 1.0)


# What each preset is, as a figure's title says it.
DESCRIPTIONS: dict[str, str] = {
    "ti64-creep-1293k": "Ti-6Al-4V, creep at 1293 K (beta)",
    "ti64-tmp-1133-1293k": "Ti-6Al-4V, thermal cycling 1133-1293 K",
    "cpti-alpha-1003k": "CP-Ti, creep at 1003 K (alpha)",
    "cpti-alpha-1073k": "CP-Ti, creep at 1073 K (alpha)",
    "cpti-alpha-1143k": "CP-Ti, creep at 1143 K (alpha)",
    "cpti-beta-1253k": "CP-Ti, creep at 1253 K (beta)",
}


def describe(material: Material) -> str:
    """The material in words: the preset's metal and temperature, or its
    Norton constants for a custom one."""
    name = name_of(material)
    if name is not None and name in DESCRIPTIONS:
        return DESCRIPTIONS[name]
    return f"Norton C = {material.creep_c:.3g} MPa^-n s^-1, n = {material.creep_n:g}"


def name_of(material: Material) -> str | None:
    """The preset name of ``material`` if it equals a preset, else None."""
    for name, m in PRESETS.items():
        same = (m.creep_c, m.creep_n, m.young_mpa, m.poisson) == (
            material.creep_c,
            material.creep_n,
            material.young_mpa,
            material.poisson,
        )
        if same:
            return name
    return None


__all__ = [
    "CPTI_ALPHA_1003K",
    "CPTI_ALPHA_1073K",
    "CPTI_ALPHA_1143K",
    "CPTI_BETA_1253K",
    "DEFAULT_POISSON",
    "DEFAULT_YOUNG_MPA",
    "PRESETS",
    "PRESET_NAMES",
    "TI64_CREEP_1293K",
    "TI64_TMP_1133_1293K",
    "Material",
    "by_name",
    "custom",
    "describe",
    "name_of",
    "thermal_cycling",
    "tmp_creep_coefficient",
]
