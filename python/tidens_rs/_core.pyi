"""Native core of tidens (Rust, PyO3). Units: mm, N, MPa, s.

Private module: use the public API of :mod:`tidens_rs`.
"""

from collections.abc import Callable
from typing import Any, TypeAlias, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "CheckpointError",
    "ConvergenceError",
    "Cell",
    "Material",
    "Packing",
    "Simulation",
    "TidensError",
    "UnsupportedError",
    "tmp_creep_coefficient",
    "solver_threads",
    "check_parameters",
    "estimate_size",
    "__version__",
    "PRESET_NAMES",
    "CONTACT_MODES",
    "CONTACT_FACETS",
    "DEFAULT_SIZE_RATIO",
    "SOLVER_DEFAULTS",
    "ELEMENTS",
    "LEVEL_DIVISIONS",
]

__version__: str
PRESET_NAMES: list[str]
CONTACT_MODES: list[str]
CONTACT_FACETS: list[str]
DEFAULT_SIZE_RATIO: float
SOLVER_DEFAULTS: dict[str, Any]
ELEMENTS: list[str]
LEVEL_DIVISIONS: dict[int, int]

_Octant: TypeAlias = tuple[tuple[bool, bool, bool], float, float]
_Particle: TypeAlias = tuple[tuple[float, float, float], float, float, tuple[float, float, float]]

class TidensError(Exception):
    """Base class of the errors raised by the solver."""

class ConvergenceError(TidensError):
    """Newton failed at the smallest allowed time step, the step limit was
    reached, or a linear solve failed. The simulation keeps its last
    converged state, so its curve up to the failure is still available.
    Attributes: time_s and step (where it happened), dt_s (the last step
    size tried), reason (element, linear_algebra, non_finite_residual,
    plane_penetration, contact_penetration, newton_iterations, line_search,
    step_limit, material), result (the partial result, from Case.run)."""

    time_s: float | None
    step: int | None
    dt_s: float | None
    reason: str | None
    result: Any

class CheckpointError(ValueError):
    """A checkpoint that cannot be resumed: empty, truncated, not a
    checkpoint, of another format, damaged (a hash does not match), or
    taken with another case. A ValueError; tidens_rs.resume puts the
    checkpoint file's path in front of the message."""

class UnsupportedError(TidensError):
    """A scene this version cannot simulate."""

def solver_threads() -> int:
    """Threads the solver's parallel parts (assembly, large Cholesky
    factorisations) run on in this process: ``RAYON_NUM_THREADS`` if set
    when the first solve started, else the machine's cores. The results do
    not depend on it; the wall time does."""

def tmp_creep_coefficient(dv_over_v: float, cycle_s: float, sigma0_mpa: float, n: float) -> float:
    """Norton coefficient C [MPa^-1 s^-1] of transformation mismatch plasticity."""

def check_parameters(
    *,
    stress_mpa: float = 1.0,
    knockdown: float = 1.0,
    ramp_time_s: float = 1.0,
    until_density: float | None = None,
    until_time_s: float | None = None,
    mesh_level: int | None = None,
    grading: float | None = None,
    exact_volume: bool | None = None,
    element: str | None = None,
    tolerance: float | None = None,
    max_strain_increment: float | None = None,
    dt_initial_s: float | None = None,
    dt_max_s: float | None = None,
    max_steps: int | None = None,
    time_targets_s: list[float] = ...,
    newton_max_iterations: int | None = None,
    newton_residual_tolerance: float | None = None,
    contact: str = "frictionless",
    tied_planes: bool = False,
    contact_penalty_factor: float | None = None,
    penetration_tolerance: float | None = None,
    contact_facets: str | None = None,
    checkpoint_every: int | None = None,
    material: Material | None = None,
) -> None:
    """Checks load and solver knobs against their ranges without building a run."""

def estimate_size(cell: Cell, mesh_level: int | None = None, element: str | None = None) -> dict[str, int]:
    """The size of a run of ``cell`` at ``mesh_level`` (None: the default) in
    elements ``element`` ("hex8", the default, or "tet10"), before it is set
    up: ``nodes`` (periodic images included), ``elements``,
    ``degrees_of_freedom`` (the unknowns at the start, as
    ``Simulation.degrees_of_freedom`` reports them) and
    ``peak_memory_bytes`` (the process's estimated peak: about 13 kB per
    unknown for hex8 and 16 kB for tet10 above 40 MB, measured on runs of
    9000 to 72000 unknowns; a lower bound for far larger runs, whose sparse
    factor grows faster). A cell of octants is meshed; a periodic cell is
    not (one particle of each layout is), so 10000 particles take
    milliseconds. ValueError for a mesh_level out of range, or tet10 for a
    periodic cell."""

@final
class Material:
    """Hencky elasticity + J2 Norton viscoplasticity, eps_dot = C q^n."""

    def __new__(cls, young_mpa: float, poisson: float, creep_c: float, creep_n: float) -> Material: ...
    @staticmethod
    def preset(name: str) -> Material: ...
    @property
    def young_mpa(self) -> float: ...
    @property
    def poisson(self) -> float: ...
    @property
    def creep_c(self) -> float: ...
    @property
    def creep_n(self) -> float: ...
    @property
    def shear_modulus_mpa(self) -> float: ...
    @property
    def bulk_modulus_mpa(self) -> float: ...
    @property
    def constrained_modulus_mpa(self) -> float: ...
    def with_elastic(self, young_mpa: float, poisson: float) -> Material: ...
    def creep_rate(self, q_mpa: float) -> float: ...

@final
class Packing:
    """A packing of spheroids in a box [0, Lx) x [0, Ly) x [0, Lz) [mm]."""

    @staticmethod
    def generate(
        particles: int,
        *,
        rho0: float = 0.6,
        mean_radius_mm: float = 0.05,
        aspect_ratio: float = 1.0,
        size_ratio: float | None = None,
        small_fraction: float = 0.5,
        sigma: float | None = None,
        boundary: str = "periodic",
        box_aspect: tuple[float, float, float] = ...,
        seed: int = 0,
        jam: bool = False,
        progress: Callable[[dict[str, Any]], object] | None = None,
    ) -> Packing:
        """A random dense packing at relative density rho0 (ValueError naming the parameter);
        jam=True: where it first jams below rho0, that state.

        Runs with the GIL released and runs Python's signal handlers ten
        times a second: Ctrl-C raises KeyboardInterrupt (SIGTERM inside
        signals.sigterm_stops, Terminated) within about 0.1 s, and so does
        what any handler raises. progress, if given, is called at most four
        times a second with a dict: stage ("start", "compress", "shake",
        "refine"), rel_density (the density being relaxed at), densest (the
        densest overlap-free density so far), round (0, then the shakes
        done, at most 20) and iterations (relaxation iterations so far);
        what it raises stops the generation and propagates."""
    @staticmethod
    def from_text(text: str, lengths_mm: tuple[float, float, float], boundary: str = "periodic") -> Packing:
        """Reads `x y z a [c [ax ay az]]` lines (mm) in the box lengths_mm."""
    def to_text(self) -> str: ...
    @property
    def lengths_mm(self) -> tuple[float, float, float]: ...
    @property
    def boundary(self) -> str: ...
    @property
    def rel_density(self) -> float: ...
    @property
    def centres_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def semi_axes_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def axes(self) -> npt.NDArray[np.float64]: ...
    def contacts(self, tolerance_mm: float) -> list[tuple[int, int, tuple[int, int, int], float]]: ...
    def coordination_number(self, tolerance_mm: float) -> float: ...
    def backbone_coordination_number(self, tolerance_mm: float) -> float: ...
    @property
    def max_overlap_mm(self) -> float: ...
    def __len__(self) -> int: ...

@final
class Cell:
    """A box [0,Lx]x[0,Ly]x[0,Lz] of mirror planes with particle octants at its
    corners, or (Cell.periodic) whole particles in a box periodic along x, y and z."""

    def __new__(
        cls, name: str, lengths_mm: tuple[float, float, float], octants: list[_Octant]
    ) -> Cell: ...
    @staticmethod
    def sc(radius_mm: float = 0.05, aspect_ratio: float = 1.0) -> Cell: ...
    @staticmethod
    def bcc(radius_mm: float = 0.05, aspect_ratio: float = 1.0) -> Cell: ...
    @staticmethod
    def fcc(radius_mm: float = 0.05, aspect_ratio: float = 1.0) -> Cell: ...
    @staticmethod
    def sc2(radius_mm: float = 0.05, size_ratio: float = 1.566, aspect_ratio: float = 1.0) -> Cell: ...
    @property
    def name(self) -> str: ...
    @property
    def lengths_mm(self) -> tuple[float, float, float]: ...
    @property
    def rho0(self) -> float: ...
    @staticmethod
    def periodic(name: str, lengths_mm: tuple[float, float, float], particles: list[_Particle]) -> Cell:
        """Whole particles (centre_mm, a_mm, c_mm, axis) in a periodic box (ValueError naming the field)."""
    @property
    def is_periodic(self) -> bool: ...
    @property
    def octants(self) -> list[_Octant]: ...
    @property
    def particles(self) -> list[_Particle]: ...

@final
class Simulation:
    """One hot-pressing run of a cell; advance it step by step or run it."""

    def __new__(
        cls,
        cell: Cell,
        material: Material,
        *,
        stress_mpa: float,
        knockdown: float = 1.0,
        ramp_time_s: float = 1.0,
        until_density: float | None = None,
        until_time_s: float | None = None,
        mesh_level: int | None = None,
        grading: float | None = None,
        exact_volume: bool | None = None,
        element: str | None = None,
        tolerance: float | None = None,
        max_strain_increment: float | None = None,
        dt_initial_s: float | None = None,
        dt_max_s: float | None = None,
        max_steps: int | None = None,
        time_targets_s: list[float] = ...,
        newton_max_iterations: int | None = None,
        newton_residual_tolerance: float | None = None,
        contact: str = "frictionless",
        tied_planes: bool = False,
        contact_penalty_factor: float | None = None,
        penetration_tolerance: float | None = None,
        contact_facets: str | None = None,
        checkpoint_every: int | None = None,
        resume_from: bytes | None = None,
    ) -> Simulation: ...
    def checkpoint(self) -> bytes:
        """The run's state as bytes (give them back as resume_from)."""
    def set_density_targets(self, targets: list[float]) -> None:
        """Densities that steps end on (just past each), as they end on
        until_density; not recorded in a checkpoint."""
    def advance(self) -> dict[str, float]:
        """One converged step (GIL released); returns its curve point.

        Python's signal handlers run before each Newton iteration: Ctrl-C
        (or any handler that raises) abandons the step within one
        iteration, raising what the handler raised, the state left at the
        last converged step. Raises ConvergenceError if the step fails."""
    def run(self, callback: Callable[[dict[str, float]], bool | None] | None = None) -> str:
        """Steps to the stop condition; `callback(point)` after each step, returning False stops."""
    @property
    def status(self) -> str: ...
    @property
    def time_s(self) -> float: ...
    @property
    def rel_density(self) -> float: ...
    @property
    def degrees_of_freedom(self) -> int: ...
    @property
    def node_count(self) -> int: ...
    @property
    def element_count(self) -> int: ...
    @property
    def lengths_mm(self) -> tuple[float, float, float]: ...
    def curve(self) -> dict[str, npt.NDArray[np.float64]]: ...
    def fields(self) -> dict[str, npt.NDArray[Any]]: ...
    def stats(self) -> dict[str, float]: ...
