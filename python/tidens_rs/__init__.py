"""tidens: powder-level finite elements of hot pressing of titanium powders.

Units everywhere: mm, N, MPa, s. A run in a few lines::

    import tidens_rs as td
    case = td.Case(cell=td.cells.sc(), material=td.materials.TI64_CREEP_1293K, stress_mpa=10.0)
    result = case.run(until_density=0.9)
    result.time_s, result.rel_density      # numpy arrays
    result.plot("density.png"); result.write_vtu("out/")
"""

from . import cells, continuum, materials, packing, signals, similarity, sweep
from ._core import (
    CONTACT_FACETS,
    CONTACT_MODES,
    Cell,
    ConvergenceError,
    Material,
    Packing,
    Simulation,
    TidensError,
    UnsupportedError,
    __version__,
)
from .case import DEFAULT_MESH_LEVEL, DEFAULT_TOLERANCE, Case, SolverSettings, load, resume
from .continuum import ContinuumModel
from .io import OutputError
from .result import Result
from .snapshot import Snapshot

__all__ = [
    "CONTACT_FACETS",
    "CONTACT_MODES",
    "DEFAULT_MESH_LEVEL",
    "DEFAULT_TOLERANCE",
    "Case",
    "Cell",
    "ContinuumModel",
    "ConvergenceError",
    "Material",
    "OutputError",
    "Packing",
    "Result",
    "Simulation",
    "Snapshot",
    "SolverSettings",
    "TidensError",
    "UnsupportedError",
    "__version__",
    "cells",
    "continuum",
    "load",
    "materials",
    "packing",
    "resume",
    "signals",
    "similarity",
    "sweep",
]
