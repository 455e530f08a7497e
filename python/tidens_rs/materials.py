"""Material presets of the paper (docs/model.md section 1) and custom materials.

Every preset has the default elastic constants E = 43.5 GPa and nu = 0.3,
which make the problem well posed and barely change densification. Creep:
``eps_dot = C q^n`` with C in MPa^-n s^-1.

The transformation-mismatch-plasticity preset (thermal cycling of Ti-6Al-4V,
n = 1) is linear in stress only while stresses stay near the internal stress
(7.4 MPa); the contact stresses of a powder exceed it, a limitation the paper
shares. :func:`tmp_creep_coefficient` gives C for another cycle.
"""

from __future__ import annotations

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
    """A Norton material ``eps_dot = creep_c q^creep_n`` (C in MPa^-n s^-1)."""
    return Material(young_mpa, poisson, creep_c, creep_n)


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
    "name_of",
    "tmp_creep_coefficient",
]
