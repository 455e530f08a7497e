"""A hot-pressing case: cell, material, load, solver settings; and its run."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from . import _core, io
from ._core import CONTACT_MODES, SOLVER_DEFAULTS, Cell, ConvergenceError, Material
from .result import Result
from .snapshot import Snapshot

# The defaults are the core's (one source); these two are named because
# scripts and the command line quote them.
DEFAULT_MESH_LEVEL: int = SOLVER_DEFAULTS["mesh_level"]
DEFAULT_TOLERANCE: float = SOLVER_DEFAULTS["tolerance"]


@dataclass(frozen=True)
class SolverSettings:
    """Every solver knob, with its default.

    mesh_level
        1 (coarsest usable) to 6; each level refines the element size by
        about sqrt(2) (inner-cube divisions 4, 6, 8, 11, 16, 23). At the
        default, t(0.8) and t(0.9) of the sc case are within 1 % of the next
        finer level's (see README).
    tolerance
        Time-integration accuracy: target relative error of the times t(rho)
        from the backward-Euler steps. The run reports its own estimate of the
        accumulated error (``time_error_s``): exact on smooth creep (a Norton
        cube), conservative by a factor of 5 to 8 on the sc cell, where the
        rate jumps each time a node touches a plane. At 0.01 the measured
        error of t(0.8) and t(0.9) on the sc cell is about 0.3 %.
    grading
        Element-size ratio toward the contact points (1 = uniform).
    exact_volume
        Move the curved-surface nodes of each particle outward by O(h^2)
        (the contact points stay on the true surface) so that its mesh has
        the exact volume of the spheroid, and the curve starts at the
        packing's exact rho0 (the default). False puts the surface nodes on
        the spheroid: the flat facets between them leave each particle a
        little short of its volume (0.75 % at level 2).
    element
        ``hex8``: the 8-node mean-dilatation hexahedron (default); ``tet10``:
        the 10-node tetrahedron with one pressure, 6 per hexahedron of the
        same level with mid-edge nodes on the true surface (single-particle
        cells and blocks; level L in tet10 has as many dofs as level L + 2 in
        hex8).
    max_strain_increment
        Largest equivalent plastic strain increment per step at any Gauss
        point (a robustness limit).
    dt_initial_s, dt_max_s
        First and largest time step [s]; None picks the first step from the
        ramp and the creep time scale.
    max_steps
        Step limit; reaching it raises :class:`ConvergenceError`.
    newton_max_iterations, newton_residual_tolerance
        Newton iterations before a step is cut back, and the converged
        residual as a fraction of the applied piston force.
    contact_penalty_factor
        Penalty stiffness of particle-particle contact as a multiple of E/h,
        h the mean surface element size, in [0.01, 1e4]. The augmented
        Lagrangian iterates the contact pressures until the penetration is
        below ``penetration_tolerance``, so the factor changes the cost of a
        step, not its result.
    penetration_tolerance
        Largest particle-particle penetration allowed in a converged step, as
        a fraction of the largest particle radius, in [1e-8, 1e-2]; the
        solver aims at half of it. The curve reports the penetration reached
        (``max_penetration_mm``).

    The contact *model* (frictionless or tied particle contact, tied die
    walls) is physics, not a solver knob: it is :attr:`Case.contact` and
    :attr:`Case.tied_planes`.
    """

    mesh_level: int = DEFAULT_MESH_LEVEL
    tolerance: float = DEFAULT_TOLERANCE
    grading: float = SOLVER_DEFAULTS["grading"]
    exact_volume: bool = SOLVER_DEFAULTS["exact_volume"]
    element: str = SOLVER_DEFAULTS["element"]
    max_strain_increment: float = SOLVER_DEFAULTS["max_strain_increment"]
    dt_initial_s: float | None = SOLVER_DEFAULTS["dt_initial_s"]
    dt_max_s: float = SOLVER_DEFAULTS["dt_max_s"]
    max_steps: int = SOLVER_DEFAULTS["max_steps"]
    newton_max_iterations: int = SOLVER_DEFAULTS["newton_max_iterations"]
    newton_residual_tolerance: float = SOLVER_DEFAULTS["newton_residual_tolerance"]
    contact_penalty_factor: float = SOLVER_DEFAULTS["contact_penalty_factor"]
    penetration_tolerance: float = SOLVER_DEFAULTS["penetration_tolerance"]

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


ProgressCallback = Callable[[dict[str, float]], "bool | None"]


@dataclass(frozen=True)
class Case:
    """A cell of a material pressed in a rigid die.

    ``stress_mpa`` is the applied (nominal) piston stress sigma, reached by a
    linear ramp over ``ramp_time_s`` and then held; ``knockdown`` (f) models
    die-wall friction: the cell feels f sigma.

    ``contact`` is how touching particles interact: ``"frictionless"``
    (they slide freely; the default, an assumption the paper leaves open) or
    ``"tied"`` (no sliding once closed; the contact then carries shear and
    tension). It matters only for cells of more than one particle (bcc, fcc,
    sc2, custom cells): sc has no particle-particle contact.
    ``tied_planes=True`` ties particle surface nodes that touch a rigid plane
    of the die where they touch it. It is a sensitivity option, not the
    default: the box faces are mirror planes of the packing, on which the
    tangential traction must vanish, so the default frictionless planes are
    the model; tied planes act as rough walls that block the lateral
    spreading symmetry requires (the sc cell densifies more slowly).
    """

    cell: Cell
    material: Material
    stress_mpa: float
    knockdown: float = 1.0
    ramp_time_s: float = 1.0
    solver: SolverSettings = field(default_factory=SolverSettings)
    contact: str = "frictionless"
    tied_planes: bool = False

    def __post_init__(self) -> None:
        # Fail on a typo when the case is written, not when it is run.
        if self.contact not in CONTACT_MODES:
            raise ValueError(f"contact = {self.contact!r}: must be one of {', '.join(CONTACT_MODES)}")

    def simulation(
        self,
        until_density: float | None = None,
        until_time_s: float | None = None,
        time_targets_s: Sequence[float] = (),
    ) -> _core.Simulation:
        """The native simulation object of this case (advance it yourself)."""
        s = self.solver
        return _core.Simulation(
            self.cell,
            self.material,
            stress_mpa=self.stress_mpa,
            knockdown=self.knockdown,
            ramp_time_s=self.ramp_time_s,
            until_density=until_density,
            until_time_s=until_time_s,
            mesh_level=s.mesh_level,
            grading=s.grading,
            exact_volume=s.exact_volume,
            element=s.element,
            tolerance=s.tolerance,
            max_strain_increment=s.max_strain_increment,
            dt_initial_s=s.dt_initial_s,
            dt_max_s=s.dt_max_s,
            max_steps=s.max_steps,
            time_targets_s=list(time_targets_s),
            newton_max_iterations=s.newton_max_iterations,
            newton_residual_tolerance=s.newton_residual_tolerance,
            contact=self.contact,
            tied_planes=self.tied_planes,
            contact_penalty_factor=s.contact_penalty_factor,
            penetration_tolerance=s.penetration_tolerance,
        )

    def run(
        self,
        until_density: float | None = None,
        until_time_s: float | None = None,
        *,
        out_dir: str | Path | None = None,
        snapshot_densities: Sequence[float] = (),
        snapshot_times_s: Sequence[float] = (),
        progress: bool = False,
        callback: ProgressCallback | None = None,
    ) -> Result:
        """Presses until ``until_density`` or ``until_time_s`` (whichever first).

        With ``out_dir``, ``curve.csv`` is written row by row as the run goes,
        and ``summary.json`` and the VTU snapshots at the end (also when the
        run fails or is interrupted). Snapshots are taken at the first step
        reaching each of ``snapshot_densities``, exactly at
        ``snapshot_times_s``, and at the end. ``callback(point)`` is called
        after every converged step with the curve point; returning False stops
        the run. ``progress`` shows a progress bar on stderr.

        A solver failure raises :class:`ConvergenceError` with the partial
        result in its ``result`` attribute.
        """
        if until_density is None and until_time_s is None:
            raise ValueError("until_density = None and until_time_s = None: give at least one")
        sim = self.simulation(until_density, until_time_s, snapshot_times_s)
        out = Path(out_dir) if out_dir is not None else None
        writer = io.CurveWriter(out / "curve.csv") if out is not None else None
        pending_rho = sorted(r for r in snapshot_densities)
        pending_t = sorted(t for t in snapshot_times_s)
        snapshots: list[Snapshot] = []
        bar = _progress_bar(sim.rel_density, until_density, until_time_s) if progress else None
        status = "failed"
        message: str | None = None
        error: BaseException | None = None
        start = time.perf_counter()
        first = sim.curve()
        if writer is not None:
            writer.write({k: v[0] for k, v in first.items()})
        try:
            while sim.status == "running":
                p = sim.advance()
                if writer is not None:
                    writer.write(p)
                while pending_rho and p["rel_density"] >= pending_rho[0]:
                    snapshots.append(_snapshot(sim, f"rho{pending_rho.pop(0):.3f}", p))
                while pending_t and p["time_s"] >= pending_t[0] * (1 - 1e-9):
                    snapshots.append(_snapshot(sim, f"t{pending_t.pop(0):g}s", p))
                if bar is not None:
                    bar(p)
                if callback is not None and callback(p) is False:
                    break
            status = sim.status if sim.status != "running" else "stopped"
        except ConvergenceError as e:
            message = str(e)
            error = e
        except KeyboardInterrupt as e:
            status, message, error = "interrupted", "interrupted by the user", e
        finally:
            if writer is not None:
                writer.close()
        curve = sim.curve()
        last = {k: v[-1] for k, v in curve.items()}
        snapshots.append(_snapshot(sim, "final", last))
        result = Result(
            case=self,
            curve=curve,
            status=status,
            wall_seconds=time.perf_counter() - start,
            stats=sim.stats(),
            degrees_of_freedom=sim.degrees_of_freedom,
            nodes=sim.node_count,
            elements=sim.element_count,
            snapshots=snapshots,
            message=message,
        )
        if bar is not None:
            bar(None)
        if out is not None:
            result.write_summary(out / "summary.json")
            result.write_vtu(out)
        if error is not None:
            error.result = result  # type: ignore[attr-defined]
            raise error
        return result


def _snapshot(sim: _core.Simulation, label: str, point: dict[str, float]) -> Snapshot:
    return Snapshot(label, float(point["time_s"]), float(point["rel_density"]), sim.fields())


def _progress_bar(
    rho0: float, until_density: float | None, until_time_s: float | None
) -> Callable[[dict[str, float] | None], None]:
    """A tqdm bar on stderr showing the fraction done (by density or time)."""
    from tqdm import tqdm

    total = 1000
    bar = tqdm(total=total, unit="‰", file=None, dynamic_ncols=True, leave=True)

    def update(p: dict[str, float] | None) -> None:
        if p is None:
            bar.close()
            return
        frac = 0.0
        if until_density is not None:
            frac = (p["rel_density"] - rho0) / (until_density - rho0)
        if until_time_s is not None:
            frac = max(frac, p["time_s"] / until_time_s)
        bar.n = int(total * min(max(frac, 0.0), 1.0))
        bar.set_postfix_str(
            f"t={p['time_s']:.3g} s rho={p['rel_density']:.4f} step={int(p['step'])}", refresh=False
        )
        bar.refresh()

    return update
