"""A hot-pressing case: cell, material, load, solver settings; and its run."""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, TypeVar

from . import _checks, _core, cells, io
from ._core import CONTACT_FACETS, CONTACT_MODES, ELEMENTS, SOLVER_DEFAULTS, Cell, ConvergenceError, Material
from .estimate import COMPANION_TOLERANCE_FACTOR, ErrorEstimate, estimate_error
from .result import MARK_DENSITIES, Result
from .signals import Terminated
from .snapshot import Snapshot

T = TypeVar("T")

# Curve columns the error estimate reads.
ESTIMATE_COLUMNS = ("time_s", "rel_density", "time_error_s")

# What a run with an output folder writes there to be resumed.
RUN_FILE = "run.json"
CHECKPOINT_FILE = "checkpoint.bin"
# The state at a stop between two checkpoints (see resume's from_last_step).
STOP_CHECKPOINT_FILE = "checkpoint_stop.bin"
# A snapshot of density r is taken at the first step past r - this: steps
# aimed at r end within Newton's and the contact's noise in the density
# around it, sometimes just short (the rate falls during the step).
SNAPSHOT_DENSITY_SLACK = 5e-4
# Steps between checkpoints when SolverSettings.checkpoint_every is 0.
CHECKPOINT_INTERVAL = 50

# The largest time tolerance the core accepts.
MAX_TOLERANCE = 0.5
# The statuses of a run that ended as asked (or at full density, before a
# later target): its result is complete, and it gets an error estimate.
FINISHED = ("reached_density", "reached_time", "full_density")
# The range of Case.run(accuracy=...), and the ladder it climbs.
MIN_ACCURACY, MAX_ACCURACY = 1e-3, 0.5
LADDER_TOLERANCE_AT_LEVEL_3 = 0.02
LADDER_LAST_LEVEL = 5

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
        rate jumps each time a node touches a plane. At the default 0.02 the
        time part of the error of t(0.8), t(0.9) and t(0.95) on the sc cell
        is 0.2 to 0.7 % (against a tolerance ladder), below the mesh error of
        the default level; 0.01 costs 10 to 35 % more for no gain there
        (the accuracy study in the README).
    grading
        Element-size ratio toward the contact points (1 = uniform).
    exact_volume
        Move the curved-surface nodes of each particle outward by O(h^2)
        (the contact points stay on the true surface) so that its mesh has
        the exact volume of the spheroid, and the curve starts at the
        packing's exact rho0 (the default). False puts the surface nodes on
        the spheroid: the flat facets between them leave each particle a
        little short of its volume (0.75 % at level 2). Periodic cells
        (whole particles) are always meshed so, whatever this says: their
        particles touch, and the exact volume's outward bulge would make
        them overlap.
    element
        ``hex8``: the 8-node mean-dilatation hexahedron (default); ``tet10``:
        the 10-node tetrahedron with one pressure, 6 per hexahedron of the
        same level with mid-edge nodes on the true surface (level L in tet10
        has as many dofs as level L + 2 in hex8; particles touch on the flat
        triangles of their 6-node faces).
    max_strain_increment
        Largest equivalent plastic strain increment per step at any Gauss
        point (a robustness limit).
    dt_initial_s, dt_max_s
        First and largest time step [s]; None picks the first step from the
        ramp and the creep time scale.
    max_steps
        Step limit; reaching it raises :class:`ConvergenceError`.
    newton_max_iterations, newton_residual_tolerance
        Newton iterations of one solve before a step is cut back (each
        update of the contact multipliers starts a new solve), and the
        converged residual as a fraction of the applied piston force.
    contact_penalty_factor
        Penalty stiffness of particle-particle contact as a multiple of E/h,
        h the mean surface element size, in [0.01, 1e4], at most
        1e6 f sigma / h (reached on stiff materials, E/sigma above 1e5,
        where a penalty scaling with E makes the contact state flip on
        displacements far below what the load moves). The augmented
        Lagrangian iterates the contact pressures until the penetration is
        below ``penetration_tolerance``, so the factor changes the cost of a
        step, not its result.
    penetration_tolerance
        Largest particle-particle penetration allowed in a converged step, as
        a fraction of the largest particle radius, in [1e-8, 1e-2]; the
        solver aims at half of it. The curve reports the penetration reached
        (``max_penetration_mm``).
    contact_facets
        The master surface of a hex8 particle, on which the nodes of the
        other particles are measured: ``"triangles"`` (default; each
        boundary face's two flat triangles, split along its shorter
        diagonal) or ``"bilinear"`` (each face's bilinear patch, the
        element's own face). Both converge to the particle's surface as the
        mesh is refined; the difference between them is part of the mesh
        error, and running both shows how much the contact discretisation
        moves a result. The bilinear patches of strongly warped faces (the
        slender tips of elongated particles) have several closest points
        and can read a node as deep inside that their triangles put outside.
        The tet10 mesh always uses its faces' flat corner triangles.
        ``"mortar"`` measures the contact segment to segment instead of
        node to facet: each slave node's gap is the mean over its support
        of the distance to the other surface (a weighted gap, integrated
        facet pair by facet pair on the same flat triangles), so
        that the forces vary smoothly as nodes slide over the other
        surface's facets and a uniform pressure passes between non-matching
        meshes exactly (the contact patch test). Frictionless contact only.
    checkpoint_every
        Steps between checkpoints (``checkpoint.bin`` in the output folder,
        also written at the start; default 50): at those steps the solver drops what it keeps only for
        speed (the factor of the tangent, the pattern grown for particle
        contacts), so that :func:`resume` goes on bit for bit like an
        uninterrupted run. 0: no such steps; checkpoints are then written
        every ``CHECKPOINT_INTERVAL`` steps and at any stop, and a resumed
        run agrees with the uninterrupted one within the Newton tolerance.

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
    contact_facets: str = SOLVER_DEFAULTS["contact_facets"]
    checkpoint_every: int = SOLVER_DEFAULTS["checkpoint_every"]

    def __post_init__(self) -> None:
        # Checked when written, not when run: the kinds here, the ranges by
        # the core (the one source of both ranges and defaults).
        c = _checks
        fixed: dict[str, Any] = {
            "mesh_level": c.integer("mesh_level", self.mesh_level),
            "tolerance": c.real("tolerance", self.tolerance),
            "grading": c.real("grading", self.grading),
            "exact_volume": c.flag("exact_volume", self.exact_volume),
            "element": c.choice("element", self.element, ELEMENTS),
            "max_strain_increment": c.real("max_strain_increment", self.max_strain_increment),
            "dt_initial_s": c.optional_real("dt_initial_s", self.dt_initial_s, "s"),
            "dt_max_s": self.dt_max_s if self.dt_max_s == math.inf else c.real("dt_max_s", self.dt_max_s, "s"),
            "max_steps": c.integer("max_steps", self.max_steps),
            "newton_max_iterations": c.integer("newton_max_iterations", self.newton_max_iterations),
            "newton_residual_tolerance": c.real("newton_residual_tolerance", self.newton_residual_tolerance),
            "contact_penalty_factor": c.real("contact_penalty_factor", self.contact_penalty_factor),
            "penetration_tolerance": c.real("penetration_tolerance", self.penetration_tolerance),
            "contact_facets": c.choice("contact_facets", self.contact_facets, CONTACT_FACETS),
            "checkpoint_every": c.integer("checkpoint_every", self.checkpoint_every),
        }
        _core.check_parameters(**fixed)
        if fixed["element"] == "tet10" and fixed["contact_facets"] == "bilinear":
            raise ValueError(
                f"contact_facets = {fixed['contact_facets']!r}: applies to hex8 elements only "
                "(tet10 particles touch on the flat corner triangles of their faces)"
            )
        for name, value in fixed.items():
            object.__setattr__(self, name, value)

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
        c = _checks
        for name, kind in (("cell", Cell), ("material", Material), ("solver", SolverSettings)):
            value = getattr(self, name)
            if not isinstance(value, kind):
                raise TypeError(f"{name} = {value!r}: must be a {kind.__name__}, not {type(value).__name__}")
        fixed: dict[str, Any] = {
            "stress_mpa": c.real("stress_mpa", self.stress_mpa, "MPa"),
            "knockdown": c.real("knockdown", self.knockdown),
            "ramp_time_s": c.real("ramp_time_s", self.ramp_time_s, "s"),
            "contact": c.choice("contact", self.contact, CONTACT_MODES),
            "tied_planes": c.flag("tied_planes", self.tied_planes),
        }
        _core.check_parameters(**fixed, material=self.material)
        if fixed["contact"] == "tied" and self.solver.contact_facets == "mortar":
            raise ValueError("contact = 'tied': mortar contact (contact_facets = 'mortar') is frictionless only")
        if self.cell.is_periodic:
            if fixed["tied_planes"]:
                raise ValueError(
                    f"tied_planes = True: cell {self.cell.name!r} is periodic, with no die plane to tie particles to"
                )
            _check_load_bearing(self.cell)
        for name, value in fixed.items():
            object.__setattr__(self, name, value)

    def simulation(
        self,
        until_density: float | None = None,
        until_time_s: float | None = None,
        time_targets_s: Sequence[float] = (),
        resume_from: bytes | None = None,
    ) -> _core.Simulation:
        """The native simulation object of this case (advance it yourself);
        with ``resume_from`` (a checkpoint's bytes), it goes on from there."""
        s = self.solver
        if self.cell.is_periodic:
            check_memory(self.size(), f"cell {self.cell.name!r} ({len(self.cell.particles)} particles)", s.mesh_level)
        return _interruptible(lambda: _core.Simulation(
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
            contact_facets=s.contact_facets,
            checkpoint_every=s.checkpoint_every,
            resume_from=resume_from,
        ))

    def size(self) -> dict[str, int]:
        """The run's size before it is set up: nodes, elements, unknowns
        (``degrees_of_freedom``) and the estimated peak memory
        (``peak_memory_bytes``), see :func:`tidens_rs._core.estimate_size`."""
        return _core.estimate_size(self.cell, self.solver.mesh_level, self.solver.element)

    def as_dict(self) -> dict[str, Any]:
        """The case as plain data (``Case.from_dict`` rebuilds it)."""
        m = self.material
        return {
            "cell": cells.to_dict(self.cell),
            "material": {"young_mpa": m.young_mpa, "poisson": m.poisson, "creep_c": m.creep_c, "creep_n": m.creep_n},
            "stress_mpa": self.stress_mpa,
            "knockdown": self.knockdown,
            "ramp_time_s": self.ramp_time_s,
            "solver": self.solver.as_dict(),
            "contact": self.contact,
            "tied_planes": self.tied_planes,
        }

    @staticmethod
    def from_dict(data: dict[str, Any]) -> Case:
        """The case of :meth:`as_dict`."""
        m = data["material"]
        solver = dict(data["solver"])
        if solver.get("dt_max_s") is None:
            solver["dt_max_s"] = math.inf  # JSON has no infinity
        return Case(
            cell=cells.from_dict(data["cell"]),
            material=Material(m["young_mpa"], m["poisson"], m["creep_c"], m["creep_n"]),
            stress_mpa=data["stress_mpa"],
            knockdown=data["knockdown"],
            ramp_time_s=data["ramp_time_s"],
            solver=SolverSettings(**solver),
            contact=data["contact"],
            tied_planes=data["tied_planes"],
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
        error_estimate: bool = True,
        accuracy: float | None = None,
        overwrite: bool = False,
    ) -> Result:
        """Presses until ``until_density`` or ``until_time_s`` (whichever first).

        With ``out_dir``, ``curve.csv`` is written row by row as the run goes,
        and ``summary.json`` and the VTU snapshots at the end (also when the
        run fails or is interrupted; each file through a temporary one
        renamed when complete, so none is ever left truncated). The folder
        must be new or empty: ``overwrite=True`` first deletes the outputs
        of an earlier run in it (and only those). A file that cannot be
        written raises :class:`tidens_rs.OutputError` naming it, with the
        result in its ``result`` attribute; what was written stays. Snapshots are taken at the first step
        reaching each of ``snapshot_densities`` (steps end just past each, as
        on ``until_density``), exactly at ``snapshot_times_s``, and at the
        end. While it writes, the run holds a lock on ``out_dir``: another run
        started into it meanwhile raises :class:`tidens_rs.io.FolderBusyError`
        (a FileExistsError) naming this one's process id. ``callback(point)`` is called
        after every converged step with the curve point; returning False stops
        the run. ``progress`` shows a progress bar on stderr.

        With ``error_estimate`` (the default), a run that reaches its target
        is followed by a coarse companion run (the same case one mesh level
        down at twice the tolerance, a fifth to a third of the cost) whose
        difference gives :attr:`Result.error_estimate` (see
        :mod:`tidens_rs.estimate`); its curve goes to
        ``companion_curve.csv``. False skips it: the estimate then has the
        step controller's time bound only. A failure or an interruption (Ctrl-C) of the companion
        leaves the result as it is, the mesh part None and the reason in
        ``error_estimate.method``.

        ``accuracy`` (a relative error of t(rho), in [0.001, 0.5]) asks for
        an accuracy instead of a mesh: the run climbs the ladder of mesh
        level L at tolerance 0.02 * 2^(3 - L) (level 1 at 0.08, 2 at 0.04, 3
        at 0.02, 4 at 0.01, ...), each rung the companion of the next, and stops at the
        first rung (from level 2) whose estimated error, the largest over
        the densities reached, is at most ``accuracy``; it replaces
        ``solver.mesh_level`` and ``solver.tolerance`` and keeps the other
        settings (the element included). The result is that rung's, its
        case carries the level and tolerance chosen, and
        ``Result.accuracy_search`` lists the rungs. Level 5 is the last
        rung: if it is not accurate enough, its result is returned with
        ``accuracy_search["reached"]`` False.

        A solver failure raises :class:`ConvergenceError` with the partial
        result in its ``result`` attribute.
        """
        until_density, until_time_s = self._check_stop(until_density, until_time_s)
        snapshot_densities = self._check_densities("snapshot_densities", snapshot_densities)
        snapshot_times_s = [_checks.in_open_range(f"snapshot_times_s[{k}]", t, 0.0, math.inf, "(0, inf) s") for k, t in enumerate(_checks.reals("snapshot_times_s", snapshot_times_s, "s"))]
        _checks.flag("error_estimate", error_estimate)
        _checks.flag("progress", progress)
        if callback is not None and not callable(callback):
            raise TypeError(f"callback = {callback!r}: must be callable (a function of the curve point) or None")
        out = _out_dir(out_dir)
        clear = _checks.flag("overwrite", overwrite)
        if out is not None:
            io.check_output_dir(out, clear)
        if accuracy is not None:
            if isinstance(accuracy, bool) or not isinstance(accuracy, (int, float)):
                raise TypeError(f"accuracy = {accuracy!r}: must be a number")
            if not MIN_ACCURACY <= accuracy <= MAX_ACCURACY:
                raise ValueError(f"accuracy = {accuracy!r}: must be in [{MIN_ACCURACY:g}, {MAX_ACCURACY:g}] (a relative error of t(rho))")
            if not error_estimate:
                raise ValueError("accuracy needs the error estimate: error_estimate=False excludes it")
            with io.locked(out):
                if out is not None:
                    io.check_output_dir(out, clear)  # again, now that no other run can start
                return self._run_to_accuracy(
                    float(accuracy),
                    until_density,
                    until_time_s,
                    out,
                    snapshot_densities=snapshot_densities,
                    snapshot_times_s=snapshot_times_s,
                    progress=progress,
                    callback=callback,
                    clear_outputs=clear,
                )
        # Built first: bad input (an overlapping cell) fails before any file.
        sim = self.simulation(until_density, until_time_s, snapshot_times_s)
        with io.locked(out):
            return self._run_locked(
                sim, until_density, until_time_s, out, clear,
                snapshot_densities=snapshot_densities,
                snapshot_times_s=snapshot_times_s,
                progress=progress,
                callback=callback,
                error_estimate=error_estimate,
            )

    def _run_locked(
        self,
        sim: _core.Simulation,
        until_density: float | None,
        until_time_s: float | None,
        out: Path | None,
        clear: bool,
        *,
        snapshot_densities: Sequence[float],
        snapshot_times_s: Sequence[float],
        progress: bool,
        callback: ProgressCallback | None,
        error_estimate: bool,
    ) -> Result:
        """:meth:`run` on its simulation ``sim``, holding the lock of ``out``."""
        if out is not None:
            # Again, now that no other run can start: one that ended since the
            # first check has left its outputs.
            io.check_output_dir(out, clear)
            if clear:
                io.clear_outputs(out)
            io.write_json(
                out / RUN_FILE,
                {
                    "tidens_version": _core.__version__,
                    "case": self.as_dict(),
                    "run": {
                        "until_density": until_density,
                        "until_time_s": until_time_s,
                        "snapshot_densities": list(snapshot_densities),
                        "snapshot_times_s": list(snapshot_times_s),
                        "error_estimate": error_estimate,
                    },
                },
            )
        result, error = self._press(
            until_density,
            until_time_s,
            curve_path=out / "curve.csv" if out is not None else None,
            snapshot_densities=snapshot_densities,
            snapshot_times_s=snapshot_times_s,
            progress=progress,
            callback=callback,
            checkpoint_path=out / CHECKPOINT_FILE if out is not None else None,
            sim=sim,
        )
        why: str | None = None
        if error is not None or result.status not in FINISHED:
            why = f"the run ended with status {result.status}"
        elif not error_estimate:
            why = "not asked for (error_estimate=False)"
        result.error_estimate, stopped = self._estimate(result, until_density, until_time_s, out, progress, why)
        return _finish(result, error or stopped, out)

    def _check_stop(self, until_density: Any, until_time_s: Any) -> tuple[float | None, float | None]:
        """The stop condition, checked: a density in (rho0, 1), a time > 0."""
        if until_density is None and until_time_s is None:
            raise ValueError("until_density = None and until_time_s = None: give at least one")
        rho = _checks.optional_real("until_density", until_density)
        if rho is not None:
            self._check_densities("until_density", [rho], single=True)
        t = _checks.optional_real("until_time_s", until_time_s, "s")
        if t is not None:
            _checks.in_open_range("until_time_s", t, 0.0, math.inf, "(0, inf) s")
        return rho, t

    def _check_densities(self, name: str, values: Any, single: bool = False) -> list[float]:
        """Relative densities, each in (rho0, 1) of the cell."""
        rho0 = self.cell.rho0
        checked = [values[0]] if single else _checks.reals(name, values)
        for k, r in enumerate(checked):
            where = name if single else f"{name}[{k}]"
            _checks.in_open_range(where, r, rho0, 1.0, f"(rho0 = {rho0:.4f}, 1): the cell starts at rho0")
        return checked

    def _run_to_accuracy(
        self,
        accuracy: float,
        until_density: float | None,
        until_time_s: float | None,
        out: Path | None,
        *,
        snapshot_densities: Sequence[float],
        snapshot_times_s: Sequence[float],
        progress: bool,
        callback: ProgressCallback | None,
        clear_outputs: bool,
    ) -> Result:
        """Climbs the accuracy ladder (see :meth:`run`)."""
        rungs: list[dict[str, Any]] = []
        previous: Result | None = None
        curve_path = out / "curve.csv" if out is not None else None
        for level in range(1, LADDER_LAST_LEVEL + 1):
            tolerance = accuracy_ladder_tolerance(level)
            rung = replace(self, solver=replace(self.solver, mesh_level=level, tolerance=tolerance))
            if progress:
                print(f"tidens: accuracy ladder, mesh level {level}, tolerance {tolerance:g}", file=sys.stderr)
            if curve_path is not None and previous is not None:
                # The last rung becomes this one's companion.
                curve_path.replace(curve_path.with_name("companion_curve.csv"))
            result, error = rung._press(
                until_density,
                until_time_s,
                curve_path=curve_path,
                snapshot_densities=snapshot_densities,
                snapshot_times_s=snapshot_times_s,
                progress=progress,
                callback=callback,
                clear_outputs=clear_outputs and previous is None,
            )
            done = error is not None or result.status not in FINISHED
            if done:
                why = f"the run ended with status {result.status}"
                result.error_estimate = rung._estimate(result, None, None, None, False, why)[0]
            elif previous is None:
                result.error_estimate = rung._estimate(result, None, None, None, False, None)[0]
            else:
                result.error_estimate = _estimate_with(result, previous, None)
            worst = result.error_estimate.curve["relative"]
            rungs.append(
                {
                    "mesh_level": level,
                    "tolerance": tolerance,
                    "estimated_error": worst,
                    "wall_seconds": result.wall_seconds,
                    "status": result.status,
                }
            )
            reached = worst is not None and worst <= accuracy
            if done or reached or level == LADDER_LAST_LEVEL:
                result.accuracy_search = {
                    "target": accuracy,
                    "reached": reached,
                    "rungs": rungs,
                    "wall_seconds": sum(r["wall_seconds"] for r in rungs),
                }
                if progress and not reached and not done:
                    print(f"tidens: level {level} is the last rung: estimated error {worst:.3g} > {accuracy:g}", file=sys.stderr)
                return _finish(result, error, out)
            previous = result
        raise AssertionError("unreachable: the ladder returns at its last rung")

    def _press(
        self,
        until_density: float | None,
        until_time_s: float | None,
        *,
        curve_path: Path | None,
        snapshot_densities: Sequence[float] = (),
        snapshot_times_s: Sequence[float] = (),
        progress: bool = False,
        callback: ProgressCallback | None = None,
        fields: bool = True,
        clear_outputs: bool = False,
        checkpoint_path: Path | None = None,
        resume_from: bytes | None = None,
        sim: _core.Simulation | None = None,
    ) -> tuple[Result, BaseException | None]:
        """One run of the solver, streaming its curve to ``curve_path``: the
        result and the exception that ended it (None if none did). With
        ``clear_outputs``, an earlier run's outputs beside ``curve_path`` are
        deleted once the simulation is set up (bad input leaves them)."""
        if sim is None:
            sim = self.simulation(until_density, until_time_s, snapshot_times_s, resume_from)
        if clear_outputs and curve_path is not None:
            io.clear_outputs(curve_path.parent)
        every = self.solver.checkpoint_every or CHECKPOINT_INTERVAL
        # A resumed run has passed some of them already.
        pending_rho = sorted(r for r in snapshot_densities if r > sim.rel_density)
        # Steps end on them, so that each snapshot is taken at its density.
        sim.set_density_targets(pending_rho)
        pending_t = sorted(t for t in snapshot_times_s if t > sim.time_s * (1 + 1e-9))
        snapshots: list[Snapshot] = []
        columns = io.curve_columns(self.cell.is_periodic)
        writer: io.CurveWriter | None = None
        bar: Callable[[dict[str, float] | None], None] | None = None
        status = "failed"
        message: str | None = None
        error: BaseException | None = None
        start = time.perf_counter()
        # Everything from the curve file's creation on is inside the try: a
        # Ctrl-C or SIGTERM at any point still leaves a result and a summary.
        try:
            if curve_path is not None:
                writer = io.CurveWriter(curve_path, columns)
            if progress:
                print(f"tidens: {sim.degrees_of_freedom} unknowns at mesh level {self.solver.mesh_level}, {self.solver.element}", file=sys.stderr)
                bar = _progress_bar(sim.rel_density, until_density, until_time_s)
            if writer is not None:
                # The initial point, or the whole curve of a resumed run.
                restored = sim.curve()
                for k in range(len(restored["time_s"])):
                    writer.write({c: v[k] for c, v in restored.items()})
            if checkpoint_path is not None and len(sim.curve()["time_s"]) == 1:
                # The initial state: a run stopped before its first periodic
                # checkpoint resumes from the start (exactly: nothing cached yet).
                io.atomic_write(checkpoint_path, lambda tmp: tmp.write_bytes(sim.checkpoint()))
            while sim.status == "running":
                p = sim.advance()
                if writer is not None:
                    writer.write(p)
                if checkpoint_path is not None and every > 0 and int(p["step"]) % every == 0:
                    io.atomic_write(checkpoint_path, lambda tmp: tmp.write_bytes(sim.checkpoint()))
                    # An earlier stop's state is behind this one now.
                    _unlink(checkpoint_path.with_name(STOP_CHECKPOINT_FILE))
                while pending_rho and p["rel_density"] >= pending_rho[0] - SNAPSHOT_DENSITY_SLACK:
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
            # Ctrl-C, or SIGTERM inside signals.sigterm_stops.
            status, error = "interrupted", e
            message = str(e) if isinstance(e, Terminated) else "interrupted by the user"
        except io.OutputError as e:
            status, message, error = "output_failed", str(e), e
        # The columns of the cell's curve file (no coordination number for
        # cells of octants), so that a result and its loaded copy agree.
        curve = {k: v for k, v in sim.curve().items() if k in columns}
        if writer is None and curve_path is not None:
            # Stopped before the file was open.
            try:
                writer = io.CurveWriter(curve_path, columns)
            except io.OutputError as e:
                error = error or e
        if writer is not None:
            error = _complete_curve(writer, curve, error)
        # Whatever stopped the run, it can go on from here. With
        # checkpoint_every, the last checkpoint at a multiple of it stays (a
        # resume from there is exact, recomputing the steps since), and a
        # stop between two of them is saved beside it (resume's
        # from_last_step goes on from there).
        stop_path = None
        if checkpoint_path is not None and self.solver.checkpoint_every == 0:
            stop_path = checkpoint_path
        elif checkpoint_path is not None and status not in FINISHED and int(curve["step"][-1]) % every != 0:
            stop_path = checkpoint_path.with_name(STOP_CHECKPOINT_FILE)
        if stop_path is not None:
            try:
                io.atomic_write(stop_path, lambda tmp: tmp.write_bytes(sim.checkpoint()))
            except io.OutputError as e:
                error = error or e
        last = {k: v[-1] for k, v in curve.items()}
        if fields:
            snapshots.append(_snapshot(sim, "final", last))
        result = Result(
            case=self,
            curve=curve,
            status=status,
            wall_seconds=time.perf_counter() - start,
            # The wall time's threads (this call's, when resumed).
            stats={**sim.stats(), "solver_threads": float(_core.solver_threads())},
            degrees_of_freedom=sim.degrees_of_freedom,
            nodes=sim.node_count,
            elements=sim.element_count,
            snapshots=snapshots,
            message=message,
        )
        if bar is not None:
            bar(None)
        return result, error

    def _estimate(
        self,
        result: Result,
        until_density: float | None,
        until_time_s: float | None,
        out: Path | None,
        progress: bool,
        why_not: str | None,
    ) -> tuple[ErrorEstimate, KeyboardInterrupt | None]:
        """The error estimate of ``result``; runs the coarse companion unless
        ``why_not`` says why not, or the level is the coarsest. Second: the
        Ctrl-C or SIGTERM that stopped the companion, for the caller to raise
        once the result is written (the estimate then says it was
        interrupted)."""
        level = self.solver.mesh_level
        arrays = {k: result.curve[k] for k in ESTIMATE_COLUMNS}
        if why_not is None and level <= 1:
            why_not = f"mesh level {level} is the coarsest: there is no coarser companion"
        if why_not is not None:
            return estimate_error(arrays, None, MARK_DENSITIES, level=level, companion_note=why_not), None
        tolerance = companion_tolerance(self.solver.tolerance)
        companion = replace(self, solver=replace(self.solver, mesh_level=level - 1, tolerance=tolerance))
        if progress:
            print(f"tidens: coarse companion run at mesh level {level - 1}, tolerance {tolerance:g} (for the error estimate)", file=sys.stderr)
        try:
            other, error = companion._press(
                until_density,
                until_time_s,
                curve_path=out / "companion_curve.csv" if out is not None else None,
                progress=progress,
                fields=False,
            )
        except KeyboardInterrupt as e:
            # Stopped while the companion was set up: no curve of it yet.
            note = "the companion was interrupted before its first step"
            return estimate_error(arrays, None, MARK_DENSITIES, level=level, companion_note=note), e
        stopped = error if isinstance(error, KeyboardInterrupt) else None
        return _estimate_with(result, other, error), stopped


def available_memory_bytes() -> int | None:
    """The memory the machine can give a new run now (Linux: MemAvailable of
    /proc/meminfo), None where that is not known."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def check_memory(size: dict[str, int], what: str, mesh_level: int) -> None:
    """ValueError, before anything is meshed, when the estimated peak
    memory of a run (``size`` as :meth:`Case.size` gives it) exceeds what
    the machine has available."""
    need, have = size["peak_memory_bytes"], available_memory_bytes()
    if have is not None and need > have:
        raise ValueError(
            f"{what} at mesh_level = {mesh_level}: needs about {need / 1e9:.1f} GB of memory "
            f"({size['degrees_of_freedom']} unknowns), more than the {have / 1e9:.1f} GB available: "
            "give fewer particles or a coarser mesh"
        )


def _interruptible(call: Callable[[], T]) -> T:
    """``call()`` (a native call that releases the GIL but does not look
    at signals, such as meshing a cell of many particles) in a thread of its
    own, while this one waits in short slices: Ctrl-C or SIGTERM raises here
    within a tenth of a second. The abandoned call finishes in the
    background, its result dropped."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return call()  # signal handlers run in the main thread only
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = call()
        except BaseException as e:  # handed to the waiting thread
            box["error"] = e

    worker = threading.Thread(target=target, name="tidens-native", daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(0.1)
    if "error" in box:
        raise box["error"]
    value: T = box["value"]
    return value


def _check_load_bearing(cell: Cell) -> None:
    """A periodic cell must hold its load by particles in contact: nothing
    else bounds it. Refused when no particle has the 4 contacts that hold a
    frictionless sphere (rattlers removed round after round): such a cell
    would be carried by the solver's stabilising drag alone."""
    from . import packing

    pack = cells.to_packing(cell)
    if packing.coordination_number(pack, without_rattlers=True) > 0.0:
        return
    z = packing.coordination_number(pack)
    raise ValueError(
        f"cell {cell.name!r}: its particles form no network that can carry the load (coordination number "
        f"{z:.2f}, none held by 4 contacts): a periodic cell must start jammed (for a random packing, leave rho0 "
        "out or give one at or above the density where it jams, about 0.64 for one size)"
    )


def _out_dir(out_dir: Any) -> Path | None:
    """The output folder, checked: a path (str or os.PathLike), not empty."""
    if out_dir is None:
        return None
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir = {out_dir!r}: must be a path (str or pathlib.Path) or None")
    if str(out_dir).strip() == "":
        raise ValueError("out_dir = '': must name a folder (use '.' for the current one)")
    return Path(out_dir)


def resume(
    out_dir: str | Path,
    *,
    progress: bool = False,
    callback: ProgressCallback | None = None,
    checkpoint_every: int | None = None,
    from_last_step: bool = False,
) -> Result:
    """Goes on with the run whose outputs are in ``out_dir``, from its last
    checkpoint (``checkpoint.bin``, written at the start and every
    ``SolverSettings.checkpoint_every`` steps; with ``checkpoint_every = 0``
    every ``CHECKPOINT_INTERVAL`` steps and at any stop: Ctrl-C, a failure,
    the step limit, the end), with the case and the run's
    arguments it recorded (``run.json``). The curve, the summary and the
    fields are those the uninterrupted run would have written: to the bit
    when the checkpoint was taken at a multiple of
    ``SolverSettings.checkpoint_every`` steps, within the Newton tolerance
    otherwise. A run stopped between two such checkpoints also saves its
    last converged step (``checkpoint_stop.bin``); ``from_last_step=True``
    goes on from there instead of recomputing the steps since the
    checkpoint before (within the Newton tolerance of the uninterrupted
    run, not to the bit: on a cell of many particles those steps can take
    hours). Without that file (the stop fell on a checkpoint, or a later
    checkpoint replaced it) it resumes from ``checkpoint.bin`` as without
    the flag. ``checkpoint_every`` (default: the recorded one) sets the
    steps between checkpoints from here on, for a run whose steps turned
    out longer or shorter than expected; ``run.json`` then records it. The
    run goes on as one with that interval would from the checkpoint (the
    interval says only where the solver drops its cached factor, which
    moves a curve at round-off level, see ``SolverSettings``). Raises
    FileNotFoundError when the folder holds no run to resume, ValueError
    for a checkpoint of another case or version, TypeError or ValueError
    for a ``checkpoint_every`` that is not a whole number >= 0, TypeError
    for a ``from_last_step`` that is not a bool."""
    out = _out_dir(out_dir)
    if out is None:
        raise TypeError("out_dir = None: give the folder of the run to resume")
    run_file, checkpoint = out / RUN_FILE, out / CHECKPOINT_FILE
    missing = [p.name for p in (run_file, checkpoint) if not p.exists()]
    if missing:
        raise FileNotFoundError(
            f"{out}: no run to resume ({' and '.join(missing)} missing): a run writes them when it has an output folder"
        )
    if not isinstance(from_last_step, bool):
        raise TypeError(f"from_last_step = {from_last_step!r}: must be True or False")
    with io.FolderLock(out):
        return _resume_locked(out, progress, callback, checkpoint_every, from_last_step)


def _resume_locked(
    out: Path,
    progress: bool,
    callback: ProgressCallback | None,
    checkpoint_every: int | None,
    from_last_step: bool,
) -> Result:
    """:func:`resume`, holding the lock of ``out``."""
    run_file, checkpoint = out / RUN_FILE, out / CHECKPOINT_FILE
    try:
        data = json.loads(run_file.read_text())
        case = Case.from_dict(data["case"])
        args = data["run"]
        until_density, until_time_s = args["until_density"], args["until_time_s"]
    except (ValueError, TypeError, KeyError) as e:
        raise ValueError(f"{run_file}: not the record of a run ({type(e).__name__}: {e})") from e
    interval_changed = checkpoint_every is not None and checkpoint_every != case.solver.checkpoint_every
    if checkpoint_every is not None:
        case = replace(case, solver=replace(case.solver, checkpoint_every=checkpoint_every))
    earlier = [(t, name) for t, name in io.read_pvd(out / "fields.pvd") if name != "fields_final.vtu"]
    stop = out / STOP_CHECKPOINT_FILE
    start = stop if from_last_step and stop.exists() else checkpoint
    with _naming(start):
        sim = case.simulation(until_density, until_time_s, args["snapshot_times_s"], resume_from=start.read_bytes())
    if interval_changed:
        io.write_json(run_file, {**data, "case": case.as_dict()})
    result, error = case._press(
        until_density,
        until_time_s,
        curve_path=out / "curve.csv",
        snapshot_densities=args["snapshot_densities"],
        snapshot_times_s=args["snapshot_times_s"],
        progress=progress,
        callback=callback,
        checkpoint_path=checkpoint,
        sim=sim,
    )
    result.earlier_snapshots = earlier
    why: str | None = None
    if error is not None or result.status not in FINISHED:
        why = f"the run ended with status {result.status}"
    elif not args["error_estimate"]:
        why = "not asked for (error_estimate=False)"
    result.error_estimate, stopped = case._estimate(result, until_density, until_time_s, out, progress, why)
    return _finish(result, error or stopped, out)


def load(out_dir: str | Path) -> Result:
    """The result of the run whose outputs are in ``out_dir`` (its record
    ``run.json``, ``curve.csv`` and ``summary.json``): the case, the curve,
    the status, the cost and the error estimate, without the fields (read
    those from the VTU files).

    A run that has written no summary yet (still going, or killed) loads
    as what it has written: its curve to the last converged step, status
    ``interrupted``, its totals (``stats``) as of its last checkpoint, the
    mesh sizes from its case; ``message`` says so. Raises
    FileNotFoundError when the folder holds no run, ValueError when its
    files are not a run's."""
    out = _out_dir(out_dir)
    if out is None:
        raise TypeError("out_dir = None: give the folder of a run")
    files = [out / RUN_FILE, out / "curve.csv", out / "summary.json"]
    if files[0].exists() and files[1].exists() and not files[2].exists():
        return _load_unfinished(out)
    missing = [p.name for p in files if not p.exists()]
    if missing:
        raise FileNotFoundError(f"{out}: no run to load ({' and '.join(missing)} missing)")
    case = _read_case(files[0])
    curve = _read_curve(files[1])
    summary = _read_json_object(files[2])
    try:
        estimate = summary.get("error_estimate")
        result = Result(
            case=case,
            curve=curve,
            status=summary["status"],
            wall_seconds=float(summary["wall_seconds"]),
            stats=dict(summary.get("stats") or {}),
            degrees_of_freedom=int(summary["degrees_of_freedom"]),
            nodes=int(summary["nodes"]),
            elements=int(summary["elements"]),
            message=summary.get("message"),
            error_estimate=ErrorEstimate(**estimate) if isinstance(estimate, dict) else None,
            accuracy_search=summary.get("accuracy"),
        )
        steps, density = int(summary["steps"]), float(summary["final_density"])
    except (ValueError, TypeError, KeyError) as e:
        raise ValueError(f"{files[2]}: not the summary of a run ({type(e).__name__}: {e})") from e
    last_step, last_density = int(curve["step"][-1]), float(curve["rel_density"][-1])
    if last_step != steps or abs(last_density - density) > 1e-12 * max(1.0, abs(density)):
        raise ValueError(
            f"{files[1]} does not match {files[2].name}: the curve ends at step {last_step} (rho = {last_density:.4f}), "
            f"the summary at step {steps} (rho = {density:.4f}); the curve file was cut or changed after the run"
        )
    return result


def _read_json_object(path: Path) -> dict[str, Any]:
    """The JSON object in ``path``; ValueError naming the file otherwise."""
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ValueError(f"{path}: cannot be read as JSON ({e})") from e
    if not isinstance(data, dict):
        raise ValueError(f"{path}: not a run's file (a JSON {type(data).__name__}, expected an object)")
    return data


def _read_case(path: Path) -> Case:
    """The case recorded in a run's ``run.json``; ValueError naming the file."""
    data = _read_json_object(path)
    try:
        return Case.from_dict(data["case"])
    except (ValueError, TypeError, KeyError, AttributeError) as e:
        raise ValueError(f"{path}: not the record of a run ({type(e).__name__}: {e})") from e


def _read_curve(path: Path) -> dict[str, Any]:
    """A run's curve file; ValueError naming the file when it is not one."""
    try:
        curve = io.read_curve(path)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ValueError(f"{path}: cannot be read as a curve ({e})") from e
    missing = [c for c in ("time_s", "rel_density", "step") if c not in curve]
    if missing or len(curve["time_s"]) == 0:
        raise ValueError(f"{path}: not a run's curve (no rows, or no column {', '.join(missing) or 'time_s'})")
    return curve


@contextmanager
def _naming(checkpoint: Path) -> Iterator[None]:
    """Puts the path of ``checkpoint`` in front of the message of a
    CheckpointError raised in the block (the core knows only the bytes):
    "run/checkpoint.bin: truncated (...)"."""
    try:
        yield
    except _core.CheckpointError as e:
        e.args = (f"{checkpoint}: {e}",)
        raise


def _load_unfinished(out: Path) -> Result:
    """The run in ``out`` that wrote no summary (see :func:`load`)."""
    record = out / RUN_FILE
    data = _read_json_object(record)
    case = _read_case(record)
    curve = _read_curve(out / "curve.csv")
    try:
        args = data["run"]
        until = (args["until_density"], args["until_time_s"], args["snapshot_times_s"])
    except (TypeError, KeyError) as e:
        raise ValueError(f"{record}: not the record of a run ({type(e).__name__}: {e})") from e
    checkpoint = out / CHECKPOINT_FILE
    saved = checkpoint.read_bytes() if checkpoint.exists() else None
    with _naming(checkpoint):
        sim = case.simulation(*until, resume_from=saved)
    steps = len(curve["time_s"]) - 1
    at = f"its last checkpoint (step {len(sim.curve()['time_s']) - 1})" if saved is not None else "its start (no checkpoint)"
    return Result(
        case=case,
        curve=curve,
        status="interrupted",
        wall_seconds=float(sim.stats().get("wall_seconds", 0.0)),
        stats=sim.stats(),
        degrees_of_freedom=sim.degrees_of_freedom,
        nodes=sim.node_count,
        elements=sim.element_count,
        message=f"no summary.json: the run is still going or was killed; its curve to step {steps}, its totals as of {at}",
    )


def _complete_curve(writer: io.CurveWriter, curve: dict[str, Any], error: BaseException | None) -> BaseException | None:
    """Writes the rows of ``curve`` the streamed file lacks (a step that
    converged while Ctrl-C arrived, before its row was written) and closes
    it, so that the file and the summary end at the same step; returns the
    error that ended the run, or the write failure if there was none."""
    try:
        for k in range(writer.rows, len(curve["time_s"])):
            writer.write({c: v[k] for c, v in curve.items()})
    except io.OutputError as e:
        error = error or e
    finally:
        try:
            writer.close()
        except io.OutputError as e:
            error = error or e
    return error


def _unlink(path: Path) -> None:
    """Deletes ``path`` if it is there; OutputError naming it if it cannot."""
    try:
        path.unlink(missing_ok=True)
    except OSError as e:
        raise io.output_error(path, e) from e


def _finish(result: Result, error: BaseException | None, out: Path | None) -> Result:
    """Writes the summary and the fields of a finished run to ``out``, and
    re-raises the error that ended it (or the first write failure),
    carrying the result."""
    if out is not None:
        try:
            result.write_summary(out / "summary.json")
            result.write_vtu(out)
        except io.OutputError as e:
            error = error or e
    if error is not None:
        error.result = result  # type: ignore[attr-defined]
        raise error
    return result


def companion_tolerance(tolerance: float) -> float:
    """The tolerance of a run's coarse companion."""
    return min(COMPANION_TOLERANCE_FACTOR * tolerance, MAX_TOLERANCE)


def accuracy_ladder_tolerance(level: int) -> float:
    """The tolerance of mesh level ``level`` on the accuracy ladder: each
    rung is the coarse companion of the next."""
    return float(LADDER_TOLERANCE_AT_LEVEL_3 * COMPANION_TOLERANCE_FACTOR ** (3 - level))


def _estimate_with(result: Result, companion: Result, error: BaseException | None) -> ErrorEstimate:
    """The estimate of ``result`` from its coarse ``companion`` (which ended
    with ``error``, if any)."""
    level = result.case.solver.mesh_level
    arrays = {k: result.curve[k] for k in ESTIMATE_COLUMNS}
    if error is not None or companion.status not in FINISHED:
        note = f"the companion at mesh level {companion.case.solver.mesh_level} ended with status {companion.status}"
        if companion.message:
            note += f" ({companion.message})"
        return estimate_error(arrays, None, MARK_DENSITIES, level=level, companion_note=note)
    return estimate_error(
        arrays,
        {k: companion.curve[k] for k in ESTIMATE_COLUMNS},
        MARK_DENSITIES,
        level=level,
        companion_level=companion.case.solver.mesh_level,
        companion_wall_seconds=companion.wall_seconds,
    )


def _snapshot(sim: _core.Simulation, label: str, point: dict[str, float]) -> Snapshot:
    return Snapshot(label, float(point["time_s"]), float(point["rel_density"]), sim.fields())


def _progress_bar(
    rho0: float, until_density: float | None, until_time_s: float | None
) -> Callable[[dict[str, float] | None], None]:
    """A tqdm bar on stderr: the per cent done (of the way from rho0 to the
    target density, or of the time), the density and time reached."""
    from tqdm import tqdm

    target = f"{until_density:g}" if until_density is not None else f"t = {until_time_s:g} s"
    bar = tqdm(
        total=100.0,
        file=None,
        dynamic_ncols=True,
        leave=True,
        bar_format="{percentage:3.0f} %|{bar}| {desc} [{elapsed}, {remaining} left]",
    )

    def update(p: dict[str, float] | None) -> None:
        if p is None:
            bar.close()
            return
        frac = 0.0
        if until_density is not None:
            frac = (p["rel_density"] - rho0) / (until_density - rho0)
        if until_time_s is not None:
            frac = max(frac, p["time_s"] / until_time_s)
        bar.n = round(100.0 * min(max(frac, 0.0), 1.0), 2)
        bar.set_description_str(f"rho {p['rel_density']:.4f} of {target}, t = {p['time_s']:.4g} s, step {int(p['step'])}", refresh=False)
        bar.refresh()

    return update
