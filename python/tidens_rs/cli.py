"""The ``tidens`` command.

``tidens run`` presses one cell (a preset, ``--cell``, or a cell file,
``--cell-file``) and writes DIR/curve.csv (streamed),
DIR/summary.json, DIR/fields_*.vtu with DIR/fields.pvd, and DIR/density.png;
``tidens demo`` runs the README's case (sc, Ti-6Al-4V at 1293 K, 10 MPa, to
rho = 0.9); ``tidens continuum`` writes the closed-form continuum model's
curve (DIR/curve.csv) for a material, stress and initial density;
``tidens sweep`` runs one case over lists of stresses, materials, cells and
aspect ratios (``tidens_rs.sweep``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import re
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from . import _core, cells, continuum, materials, sweep
from ._core import CONTACT_FACETS, CONTACT_MODES, ELEMENTS, Cell, ConvergenceError, Material, Packing, TidensError, UnsupportedError, __version__
from .case import CHECKPOINT_FILE, DEFAULT_MESH_LEVEL, DEFAULT_TOLERANCE, FINISHED, RUN_FILE, STOP_CHECKPOINT_FILE, Case, SolverSettings, load, resume
from .io import FolderLock, check_output_dir
from .result import MARK_DENSITIES, Result
from .signals import EXIT_TERMINATED, Terminated, sigterm_stops

# The solver defaults, as the Python API has them (the core's), and the case's.
_DEFAULTS = SolverSettings()
_CASE_DEFAULTS = {f.name: f.default for f in dataclasses.fields(Case)}

# The option of each Python argument, so that errors name what was typed.
_OPTION_OF = {
    "stress_mpa": "--stress",
    "knockdown": "--knockdown",
    "ramp_time_s": "--ramp-time",
    "until_density": "--until-density",
    "until_time_s": "--until-time",
    "mesh_level": "--mesh-level",
    "tolerance": "--tolerance",
    "grading": "--grading",
    "element": "--element",
    "max_steps": "--max-steps",
    "accuracy": "--accuracy",
    "snapshot_densities": "--vtu-densities",
    "snapshot_times_s": "--vtu-times",
    "time_targets_s": "--vtu-times",
    "young_mpa (E)": "--E",
    "poisson (nu)": "--nu",
    "creep_c (C)": "--C",
    "creep_n (n)": "--n",
    "radius_mm": "--radius",
    "radius": "--radius",
    "aspect_ratio": "--aspect-ratio",
    "size_ratio": "--size-ratio",
    "small_fraction": "--small-fraction",
    "sigma": "--sigma",
    "particles": "--particles",
    "mean_radius_mm": "--radius",
    "packing_seed": "--packing-seed",
    "contact": "--contact",
    "contact_facets": "--contact-facets",
    "tied_planes": "--tied-planes",
    "out_dir": "--out",
    "checkpoint_every": "--checkpoint-every",
    "points": "--points",
    "young_mpa/stress": "--E/(--knockdown x --stress)",
}
_NAMED = re.compile(
    r"(?<![\w-])(" + "|".join(re.escape(k) for k in sorted(_OPTION_OF, key=len, reverse=True)) + r")(?=(\[\d+\])? = )"
)
# A negative number in any notation (argparse takes "-4.8e-7" for an option).
_NEGATIVE = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$", re.IGNORECASE)


def option_names(message: str) -> str:
    """``message`` with the Python argument names (``stress_mpa = 0``) as
    the options that set them (``--stress = 0``)."""
    message = _NAMED.sub(lambda m: _OPTION_OF[m.group(1)], message)
    return message.replace("overwrite=True", "--overwrite")


def _glue_negative_numbers(argv: Sequence[str]) -> list[str]:
    """``--C -4.8e-7`` as ``--C=-4.8e-7``, so that a negative value reaches
    the range check instead of argparse's "expected one argument"."""
    out: list[str] = []
    for arg in argv:
        if out and _NEGATIVE.match(arg) and out[-1].startswith("--") and "=" not in out[-1]:
            out[-1] = f"{out[-1]}={arg}"
        else:
            out.append(arg)
    return out


class _Parser(argparse.ArgumentParser):
    """Bad input in one line (and exit status 2), without the usage block."""

    def error(self, message: str, options: bool = True) -> NoReturn:
        """``options``: write the Python argument names in the message as
        the options that set them; False for what a file says (a cell
        file's ``particles`` is its field, not ``--particles``)."""
        said = option_names(message) if options else message
        self.exit(2, f"{self.prog}: error: {said} (see {self.prog} --help)\n")


def _folder(text: str) -> Path:
    if not text.strip():
        raise argparse.ArgumentTypeError("'': must name a folder (use . for the current one)")
    return Path(text)


def _float_list(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"{text!r}: expected comma-separated numbers") from e


def _some_floats(text: str) -> list[float]:
    """One number or more, comma-separated (a swept list cannot be empty)."""
    values = _float_list(text)
    if not values:
        raise argparse.ArgumentTypeError(f"{text!r}: expected one or more comma-separated numbers")
    return values


# The seeds the packing generator takes (64-bit).
_MAX_SEED = 2**64 - 1


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number in [0, 2^64 - 1]") from None
    if not 0 <= value <= _MAX_SEED:
        raise argparse.ArgumentTypeError(f"{value}: must be in [0, 2^64 - 1 = {_MAX_SEED}]")
    return value


def _add_run_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("cell")
    g.add_argument("--cell", choices=(*cells.CELL_NAMES, "random"), help="packing (default sc): sc, bcc, fcc, sc2 (rock salt of two sizes), or random (a random jammed packing of whole particles in a periodic cube, see --particles)")
    g.add_argument("--periodic", action="store_true", help="the lattice of --cell as whole particles in a periodic box twice the cell's size (sc: one sphere; bcc two, fcc four, sc2 eight), instead of the cell of octants between mirror planes")
    g.add_argument("--particles", type=int, help="--cell random: number of particles, in [2, 10000] (default 16)")
    g.add_argument("--packing-seed", type=_seed, help="--cell random: seed of the packing, in [0, 2^64 - 1] (default 0): the same options and seed give the same packing")
    g.add_argument("--rho0", type=float, help="--cell random: grow the packing toward this relative density and stop where it jams below it (default: where it first jams, about 0.60-0.65 for 32 or more spheres of one size)")
    g.add_argument("--small-fraction", type=float, help="--cell random with --size-ratio: number fraction of the small particles, in [0, 1] (default 0.5)")
    g.add_argument("--cell-file", type=Path, metavar="PATH", help="a cell described in a JSON or TOML file, instead of --cell (schema: python -c 'import tidens_rs.cells as c; help(c)')")
    g.add_argument("--aspect-ratio", type=float, help="spheroid c/a, c along the load (default 1)")
    g.add_argument("--radius", type=float, help="particle radius a [mm], the large one for sc2 (default 0.05; the curve does not depend on it)")
    g.add_argument("--size-ratio", type=float, help=f"sc2 and random only: radius of the large particles over the small ones, sc2 in [1, 1 + sqrt 2 = 2.414] (default {cells.DEFAULT_SIZE_RATIO:g}); random: a bimodal packing (default one size)")
    g = p.add_argument_group("contact")
    g.add_argument("--contact", choices=CONTACT_MODES, default=_CASE_DEFAULTS["contact"], help="between particles: frictionless sliding (default) or tied once closed (no sliding)")
    g.add_argument("--tied-planes", action="store_true", help="sensitivity option, not the default: tie particle surface nodes to the rigid die planes they touch (rough walls); by default the planes are frictionless mirror planes, as the symmetry of the packing requires")
    g = p.add_argument_group("material")
    g.add_argument("--material", choices=materials.PRESET_NAMES, help="preset (default ti64-creep-1293k)")
    g.add_argument("--C", dest="creep_c", type=float, help="Norton coefficient C [MPa^-n s^-1] (with --n, instead of --material)")
    g.add_argument("--n", dest="creep_n", type=float, help="Norton exponent n (with --C)")
    g.add_argument("--E", dest="young", type=float, help=f"Young's modulus [MPa] (default {materials.DEFAULT_YOUNG_MPA:g})")
    g.add_argument("--nu", dest="poisson", type=float, help=f"Poisson's ratio (default {materials.DEFAULT_POISSON:g})")
    g = p.add_argument_group("load")
    g.add_argument("--stress", type=float, help="applied piston stress sigma [MPa] (required but with --resume)")
    g.add_argument("--knockdown", type=float, default=_CASE_DEFAULTS["knockdown"], help=f"die-wall knock-down factor f, the cell feels f*sigma (default {_CASE_DEFAULTS['knockdown']:g})")
    g.add_argument("--ramp-time", type=float, default=_CASE_DEFAULTS["ramp_time_s"], help=f"linear ramp of the stress [s] (default {_CASE_DEFAULTS['ramp_time_s']:g})")
    g = p.add_argument_group("stop")
    g.add_argument("--until-density", type=float, help="stop at this relative density")
    g.add_argument("--until-time", type=float, help="stop at this time [s]")
    g = p.add_argument_group("numerics")
    g.add_argument("--accuracy", type=float, help="ask for an accuracy instead of a mesh: the relative error of t(rho) wanted, in [0.001, 0.5]; climbs mesh levels 1, 2, 3, ... (tolerance 0.08, 0.04, 0.02, ...) until the estimated error is within it (excludes --mesh-level and --tolerance)")
    g.add_argument("--mesh-level", type=int, help=f"mesh level, 1 (coarsest) to 6; each level refines the elements by about sqrt(2) (default {DEFAULT_MESH_LEVEL})")
    g.add_argument("--tolerance", type=float, help=f"time-integration accuracy, relative error of t(rho) (default {DEFAULT_TOLERANCE:g})")
    g.add_argument("--grading", type=float, default=_DEFAULTS.grading, help=f"element-size ratio toward the contact points (default {_DEFAULTS.grading:g})")
    g.add_argument("--exact-volume", action=argparse.BooleanOptionalAction, default=_DEFAULTS.exact_volume, help=f"move each particle's surface nodes outward (contact points kept on the surface) so that its mesh has the exact spheroid volume (default {'on' if _DEFAULTS.exact_volume else 'off'})")
    g.add_argument("--element", choices=ELEMENTS, default=_DEFAULTS.element, help=f"hex8: mean-dilatation hexahedra; tet10: quadratic tetrahedra with one pressure, cut from the same blocks; default {_DEFAULTS.element}")
    g.add_argument("--contact-facets", choices=CONTACT_FACETS, default=_DEFAULTS.contact_facets, help=f"how particle contact is measured: node to facet on each hex8 face's two flat triangles or on its bilinear patch, or mortar (weighted gaps, segment to segment; frictionless only); running them shows how much the contact discretisation moves a result; default {_DEFAULTS.contact_facets}")
    g.add_argument("--no-error-estimate", dest="error_estimate", action="store_false", help="skip the coarse companion run (one mesh level down at twice the tolerance, a fifth to a third of the cost) that gives the error estimate")
    g.add_argument("--max-steps", type=int, default=_DEFAULTS.max_steps, help=f"step limit (default {_DEFAULTS.max_steps})")
    g = p.add_argument_group("output")
    g.add_argument("--out", type=_folder, help="output folder, new or empty (see --overwrite); required but with --resume")
    g.add_argument("--resume", type=_folder, metavar="DIR", help="go on with the run in DIR from its last checkpoint (written at the start and every --checkpoint-every steps), with the case it recorded: no other case option")
    g.add_argument("--from-last-step", action="store_true", help="with --resume: go on from the last step of a run stopped between two checkpoints (saved as DIR/checkpoint_stop.bin), within the Newton tolerance of the uninterrupted run, rather than recompute the steps since the checkpoint before")
    g.add_argument("--checkpoint-every", type=int, default=None, help=f"steps between checkpoints in --out, from which --resume goes on bit for bit (the solver drops its cached factor there; default {_DEFAULTS.checkpoint_every}); 0: checkpoints every 50 steps and at any stop, resumed within the Newton tolerance; with --resume, from the checkpoint on (default: the run's)")
    g.add_argument("--overwrite", action="store_true", help="first delete the outputs of an earlier run in --out (curve, summary, fields, plot; nothing else)")
    g.add_argument("--vtu-densities", type=_float_list, help="comma-separated densities for VTU snapshots (default those of 0.6,0.7,0.8,0.9 above the cell's rho0)")
    g.add_argument("--vtu-times", type=_float_list, default=[], help="comma-separated times [s] for VTU snapshots")
    g.add_argument("--no-plot", action="store_true", help="do not write density.png")
    g.add_argument("--quiet", action="store_true", help="no progress bar")


def _material(args: argparse.Namespace) -> Material:
    if (args.creep_c is None) != (args.creep_n is None):
        raise ValueError("--C and --n go together: give both, or neither and --material")
    if args.creep_c is not None:
        if args.material is not None:
            raise ValueError("--material and --C/--n exclude each other")
        m = materials.custom(args.creep_c, args.creep_n)
    else:
        m = materials.by_name(args.material or "ti64-creep-1293k")
    if args.young is not None or args.poisson is not None:
        m = m.with_elastic(
            args.young if args.young is not None else m.young_mpa,
            args.poisson if args.poisson is not None else m.poisson,
        )
    return m


_RANDOM_OPTIONS = (("--particles", "particles"), ("--packing-seed", "packing_seed"), ("--rho0", "rho0"), ("--small-fraction", "small_fraction"))


def _cell(args: argparse.Namespace) -> Cell:
    if args.cell != "random":
        for option, name in _RANDOM_OPTIONS:
            if getattr(args, name) is not None:
                raise ValueError(f"{option} applies to --cell random only")
    if args.cell_file is not None:
        if args.cell is not None:
            raise ValueError("--cell and --cell-file exclude each other: give one")
        for option, value in (("--radius", args.radius), ("--aspect-ratio", args.aspect_ratio), ("--size-ratio", args.size_ratio)):
            if value is not None:
                raise ValueError(f"{option} does not apply to --cell-file: the file gives the sizes")
        cell = cells.from_file(args.cell_file)
        return cells.as_periodic(cell) if args.periodic else cell
    name = args.cell or "sc"
    radius = args.radius if args.radius is not None else cells.DEFAULT_RADIUS_MM
    aspect = args.aspect_ratio if args.aspect_ratio is not None else 1.0
    if name == "random":
        if args.periodic:
            raise ValueError("--periodic does not apply to --cell random: it is periodic already")
        if args.small_fraction is not None and args.size_ratio is None:
            raise ValueError("--small-fraction goes with --size-ratio (a bimodal packing)")
        particles = 16 if args.particles is None else args.particles
        if isinstance(particles, int) and particles >= 2:
            _check_random_size(particles, args)
        with _PackingProgress(quiet=getattr(args, "quiet", False)) as show:
            return cells.random(
                particles,
                seed=0 if args.packing_seed is None else args.packing_seed,
                rho0=args.rho0,
                radius_mm=radius,
                aspect_ratio=aspect,
                size_ratio=args.size_ratio,
                small_fraction=0.5 if args.small_fraction is None else args.small_fraction,
                progress=show,
            )
    if args.size_ratio is not None and name != "sc2":
        raise ValueError(f"--size-ratio applies to --cell sc2 and random only, not --cell {name}")
    cell = cells.by_name(name, radius, aspect, args.size_ratio)
    return cells.as_periodic(cell) if args.periodic else cell


def _check_random_size(particles: int, args: argparse.Namespace) -> None:
    """Refuses, before the packing is made, a random cell whose run would
    not fit in memory: the size of one and of two whole spheres at the run's
    mesh level, extrapolated to ``particles``."""
    from .case import check_memory

    level = args.mesh_level if args.mesh_level is not None else DEFAULT_MESH_LEVEL
    one, two = (_core.estimate_size(cells.as_periodic(c), level, "hex8") for c in (cells.sc(), cells.bcc()))
    size = {k: one[k] + (particles - 1) * (two[k] - one[k]) for k in ("degrees_of_freedom", "peak_memory_bytes")}
    check_memory(size, f"--cell random with --particles = {particles}", level)


def _fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.2f} %"


def _error(est: dict[str, Any], key: str) -> str:
    """The estimated relative error of t(rho) at mark ``key``, or, where the
    mesh's part was not estimated (no coarser companion), the time
    control's part marked "t"."""
    total = est["relative"].get(key)
    if total is not None:
        return _pct(total)
    time_part = (est.get("time") or {}).get(key)
    return "-" if time_part is None else f"{_pct(time_part)} t"


def _report(result: Result) -> None:
    s = result.summary()
    cell, contact = s["cell"], s["contact"]
    planes = ", tied planes (sensitivity option)" if contact["tied_planes"] else ""
    if cell.get("periodic"):
        pieces = f"{len(cell['particles'])} whole particle(s), periodic, coordination number {s['coordination_number']:.2f}"
    else:
        pieces = f"{len(cell['octants'])} octant(s)"
    print(f"cell {cell['name']} ({pieces}, rho0 {cell['rho0_exact']:.5f}), {contact['mode']} contact{planes}")
    z_end = s.get("final_coordination_number")
    contacts = f", {z_end:.2f} contacts per particle pressed" if cell.get("periodic") and z_end is not None else ""
    print(f"status: {s['status']}   final density {s['final_density']:.4f} at t = {s['final_time_s']:.4g} s{contacts}")
    est = s["error_estimate"]
    print(f"{'rho':>5} {'t FE [s]':>12} {'error est':>10} {'t continuum [s]':>16}")
    for r in MARK_DENSITIES:
        k = f"{r:g}"
        fe = s["times_to_density_s"].get(k)
        if fe is None and not result.rho0 < r <= s["final_density"]:
            continue  # not on the run's curve
        cm = s["continuum_times_to_density_s"].get(k)
        print(f"{r:5.2f} {_fmt(fe):>12} {_error(est, k):>10} {_fmt(cm):>16}")
    print(f"error estimate: {est['method']['mesh']}")
    if any(est["relative"].get(k) is None and (est.get("time") or {}).get(k) is not None for k in est["relative"]):
        print("  (t: the time control's error alone, where the mesh's was not estimated)")
    search = s["accuracy"]
    if search is not None:
        rungs = ", ".join(
            f"level {r['mesh_level']} ({'-' if r['estimated_error'] is None else _pct(r['estimated_error'])})" for r in search["rungs"]
        )
        verdict = "reached" if search["reached"] else "NOT reached (the last rung was not accurate enough)"
        print(f"accuracy {_pct(search['target'])} {verdict}: {rungs}; {search['wall_seconds']:.1f} s in all")
    companion = est["companion_wall_seconds"]
    # A run loaded without its summary has its totals from its last checkpoint.
    counted = int(result.stats.get("steps", s["steps"]))
    upto = f" to step {counted}" if counted < s["steps"] else ""
    print(
        f"wall {s['wall_seconds']:.1f} s{upto}" + ("" if companion is None else f" (+ {companion:.1f} s for the companion)") + f", {s['steps']} steps, {s['newton_iterations']} Newton iterations, "
        f"{s['degrees_of_freedom']} dofs (mesh level {s['solver']['mesh_level']}, tolerance {s['solver']['tolerance']:g})"
    )


def _import_matplotlib() -> None:
    """Imports what the plot needs; run in a thread while the solver (which
    releases the GIL) computes, so that the plot does not wait for it."""
    try:
        import matplotlib.backends.backend_agg  # noqa: F401
        import matplotlib.figure  # noqa: F401
    except ImportError:
        pass  # reported where the plot is made


# Options that describe the case, which --resume takes from the run's folder.
_CASE_OPTIONS = (
    "cell", "cell_file", "aspect_ratio", "radius", "size_ratio", "particles", "packing_seed", "rho0",
    "small_fraction", "material", "creep_c", "creep_n", "young",
    "poisson", "stress", "until_density", "until_time", "accuracy", "mesh_level", "tolerance", "out",
    "vtu_densities",
)


def _resume(args: argparse.Namespace) -> int:
    given = [name for name in _CASE_OPTIONS if getattr(args, name) is not None]
    if args.periodic:
        given.insert(0, "periodic")
    if given:
        option = "--" + given[0].replace("_", "-")
        raise ValueError(f"--resume takes the case from DIR/run.json: leave out {option}")
    out: Path = args.resume
    if not args.no_plot:
        threading.Thread(target=_import_matplotlib, daemon=True).start()
    try:
        result = resume(out, progress=not args.quiet, checkpoint_every=args.checkpoint_every, from_last_step=args.from_last_step)
    except ConvergenceError as e:
        print(f"tidens: solver failure: {e} (partial results in {out})", file=sys.stderr)
        return 3
    if not args.no_plot:
        result.plot(out / "density.png")
    _report(result)
    print(f"resumed {out}: wrote {out / 'curve.csv'}, {out / 'summary.json'}")
    return 0


def _run(args: argparse.Namespace) -> int:
    if args.resume is not None:
        return _resume(args)
    if args.from_last_step:
        raise ValueError("--from-last-step goes with --resume DIR")
    for option, value in (("--stress", args.stress), ("--out", args.out)):
        if value is None:
            raise ValueError(f"{option} is required (unless --resume DIR)")
    if args.until_density is None and args.until_time is None:
        raise ValueError("give --until-density, --until-time or both")
    if args.accuracy is not None:
        if args.mesh_level is not None or args.tolerance is not None:
            raise ValueError("--accuracy chooses the mesh level and the tolerance: it excludes --mesh-level and --tolerance")
        if not args.error_estimate:
            raise ValueError("--accuracy needs the error estimate: it excludes --no-error-estimate")
    if not args.no_plot:
        threading.Thread(target=_import_matplotlib, daemon=True).start()
    case = Case(
        cell=_cell(args),
        material=_material(args),
        stress_mpa=args.stress,
        knockdown=args.knockdown,
        ramp_time_s=args.ramp_time,
        contact=args.contact,
        tied_planes=args.tied_planes,
        solver=SolverSettings(
            mesh_level=args.mesh_level if args.mesh_level is not None else DEFAULT_MESH_LEVEL,
            tolerance=args.tolerance if args.tolerance is not None else DEFAULT_TOLERANCE,
            grading=args.grading,
            exact_volume=args.exact_volume,
            element=args.element,
            contact_facets=args.contact_facets,
            max_steps=args.max_steps,
            checkpoint_every=args.checkpoint_every if args.checkpoint_every is not None else _DEFAULTS.checkpoint_every,
        ),
    )
    # The default snapshot densities start at 0.6, below rho0 of the denser packings.
    densities = args.vtu_densities
    if densities is None:
        densities = [r for r in MARK_DENSITIES if r > case.cell.rho0 and (args.until_density is None or r <= args.until_density)]
    out: Path = args.out
    try:
        result = case.run(
            args.until_density,
            args.until_time,
            out_dir=out,
            snapshot_densities=densities,
            snapshot_times_s=args.vtu_times,
            progress=not args.quiet,
            error_estimate=args.error_estimate,
            accuracy=args.accuracy,
            overwrite=args.overwrite,
        )
    except ConvergenceError as e:
        print(f"tidens: solver failure: {e} (partial results in {out})", file=sys.stderr)
        partial = getattr(e, "result", None)
        if partial is not None and not args.no_plot:
            partial.plot(out / "density.png")
        return 3
    if not args.no_plot:
        result.plot(out / "density.png")
    _report(result)
    print(f"wrote {out / 'curve.csv'}, {out / 'summary.json'}, {len(result.snapshots)} VTU file(s)" + ("" if args.no_plot else f", {out / 'density.png'}"))
    return 0


def _add_continuum_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("material")
    g.add_argument("--material", choices=materials.PRESET_NAMES, help="preset (default ti64-creep-1293k)")
    g.add_argument("--C", dest="creep_c", type=float, help="Norton coefficient C [MPa^-n s^-1] (with --n, instead of --material)")
    g.add_argument("--n", dest="creep_n", type=float, help="Norton exponent n (with --C)")
    g = p.add_argument_group("packing and load")
    g.add_argument("--rho0", type=float, help="initial relative density, in (0, 0.9) (or --cell)")
    g.add_argument("--cell", choices=cells.CELL_NAMES, help="take rho0 from this packing of spheres instead of --rho0")
    g.add_argument("--stress", type=float, required=True, help="applied piston stress sigma [MPa]")
    g.add_argument("--knockdown", type=float, default=1.0, help="die-wall knock-down factor f, the powder feels f*sigma (default 1)")
    g.add_argument("--ramp-time", type=float, default=0.0, help="linear ramp of the stress [s] (default 0: the stress acts in full from t = 0)")
    g = p.add_argument_group("output")
    g.add_argument("--until-density", type=float, required=True, help="end of the curve, a relative density in (rho0, 1)")
    g.add_argument("--points", type=int, default=200, help=f"rows of the curve, in [2, {continuum.MAX_CURVE_POINTS}] (default 200)")
    g.add_argument("--out", type=_folder, required=True, help="output folder, new or empty (see --overwrite)")
    g.add_argument("--overwrite", action="store_true", help="replace an earlier curve.csv in --out")


def _continuum(args: argparse.Namespace) -> int:
    args.young = args.poisson = None
    law = _material(args)
    if (args.rho0 is None) == (args.cell is None):
        raise ValueError("give --rho0 or --cell (one of them)")
    rho0 = args.rho0 if args.rho0 is not None else cells.by_name(args.cell).rho0
    if not (0.0 < rho0 < continuum.STAGE_SWITCH):
        raise ValueError(f"--rho0 = {rho0}: must be in (0, {continuum.STAGE_SWITCH:g})")
    model = continuum.for_material(law, args.stress, rho0, knockdown=args.knockdown, ramp_time_s=args.ramp_time)
    if not 2 <= args.points <= continuum.MAX_CURVE_POINTS:
        raise ValueError(f"--points = {args.points}: must be in [2, {continuum.MAX_CURVE_POINTS}]")
    out: Path = args.out
    check_output_dir(out, args.overwrite)
    with FolderLock(out):
        check_output_dir(out, args.overwrite)
        path = continuum.write_curve(model, args.until_density, out / "curve.csv", args.points)
    marks = [r for r in MARK_DENSITIES if rho0 < r <= args.until_density]
    times = [float(t) for t in model.time_to_density(marks)] if marks else []
    print(f"continuum model (Eqs. 2 and 3 of the paper), C = {law.creep_c:.4g} MPa^-n s^-1, n = {law.creep_n:g}, "
          f"f sigma = {model.cell_stress_mpa:g} MPa, rho0 = {rho0:.5f}, ramp {args.ramp_time:g} s")
    for r, t in zip(marks, times):
        print(f"  t({r:g}) = {t:.4g} s")
    print(f"wrote {path}")
    return 0


def _name_list(choices: Sequence[str]) -> Callable[[str], list[str]]:
    def parse(text: str) -> list[str]:
        names = [x.strip() for x in text.split(",") if x.strip()]
        bad = [x for x in names if x not in choices]
        if bad or not names:
            raise argparse.ArgumentTypeError(f"{text!r}: expected comma-separated names among {', '.join(choices)}")
        return names

    return parse


def _add_sweep_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("what is swept (comma-separated lists; every combination is a point)")
    g.add_argument("--stress", type=_some_floats, required=True, help="applied piston stresses sigma [MPa], e.g. 5,10,15")
    g.add_argument("--material", type=_name_list(materials.PRESET_NAMES), default=["ti64-creep-1293k"], help="material presets (default ti64-creep-1293k)")
    g.add_argument("--cell", type=_name_list(cells.CELL_NAMES), default=["sc"], help="packings (default sc)")
    g.add_argument("--aspect-ratio", type=_some_floats, default=[1.0], help="spheroid c/a, c along the load (default 1)")
    g = p.add_argument_group("the rest of each case")
    g.add_argument("--knockdown", type=float, default=_CASE_DEFAULTS["knockdown"], help=f"die-wall knock-down factor f (default {_CASE_DEFAULTS['knockdown']:g})")
    g.add_argument("--ramp-time", type=float, default=_CASE_DEFAULTS["ramp_time_s"], help=f"linear ramp of the stress [s] (default {_CASE_DEFAULTS['ramp_time_s']:g})")
    g.add_argument("--until-density", type=float, help="stop each run at this relative density")
    g.add_argument("--until-time", type=float, help="stop each run at this time [s]")
    g.add_argument("--mesh-level", type=int, default=DEFAULT_MESH_LEVEL, help=f"mesh level (default {DEFAULT_MESH_LEVEL})")
    g.add_argument("--tolerance", type=float, default=DEFAULT_TOLERANCE, help=f"time-integration accuracy (default {DEFAULT_TOLERANCE:g})")
    g.add_argument("--element", choices=ELEMENTS, default=_DEFAULTS.element, help=f"element (default {_DEFAULTS.element})")
    g.add_argument("--no-error-estimate", dest="error_estimate", action="store_false", help="skip each run's coarse companion")
    g = p.add_argument_group("where and how")
    g.add_argument("--out", type=_folder, required=True, help="the sweep's folder: one folder per point and the table sweep.csv / sweep.parquet; a restarted sweep skips finished points and resumes interrupted ones")
    g.add_argument("--workers", type=int, help="worker processes on this machine, one point each, the cores shared among those running (default: the cores)")
    g.add_argument("--scheduler", metavar="ADDRESS", help="run the points on this Dask scheduler instead (tcp://host:port; its workers need tidens and see --out at the same path)")
    g.add_argument("--from-last-step", action="store_true", help="an interrupted point goes on from the last step it saved at its stop, not from its last checkpoint (see tidens run --from-last-step)")
    g.add_argument("--quiet", action="store_true", help="no progress bar")


def _sweep(args: argparse.Namespace) -> int:
    if args.until_density is None and args.until_time is None:
        raise ValueError("give --until-density, --until-time or both")
    base = Case(
        cell=cells.by_name(args.cell[0], cells.DEFAULT_RADIUS_MM, args.aspect_ratio[0]),
        material=materials.by_name(args.material[0]),
        stress_mpa=args.stress[0],
        knockdown=args.knockdown,
        ramp_time_s=args.ramp_time,
        solver=SolverSettings(mesh_level=args.mesh_level, tolerance=args.tolerance, element=args.element),
    )
    rows = sweep.run(
        base,
        args.out,
        until_density=args.until_density,
        until_time_s=args.until_time,
        stresses_mpa=args.stress,
        materials=args.material,
        cells=args.cell,
        aspect_ratios=args.aspect_ratio,
        workers=args.workers,
        scheduler=args.scheduler,
        error_estimate=args.error_estimate,
        progress=not args.quiet,
        from_last_step=args.from_last_step,
    )
    marks = [f"{m:g}" for m in MARK_DENSITIES]
    print(f"{'point':<44} {'status':<16} " + " ".join(f"{'t(' + k + ') [s]':>13}" for k in marks))
    for r in rows:
        print(f"{r['name']:<44} {str(r['status']):<16} " + " ".join(f"{_fmt(r[f't_{k}_s']):>13}" for k in marks))
    failed = [r for r in rows if r["status"] not in FINISHED]
    print(f"wrote {args.out / sweep.TABLE_CSV}" + ("" if not (args.out / sweep.TABLE_PARQUET).exists() else f", {args.out / sweep.TABLE_PARQUET}"))
    return 3 if failed else 0


def _add_figures_options(p: argparse.ArgumentParser) -> None:
    from . import figures

    p.add_argument("--out", type=_folder, required=True, help="folder of the figures (PNG, PDF, captions.md, findings.md) and of their runs (runs/); a second call into it runs only what is missing")
    p.add_argument("--level", type=int, default=2, help="mesh level of the runs, each at its accuracy-ladder tolerance 0.02 * 2^(3 - level) (default 2; the mesh study adds levels 1 to 3)")
    p.add_argument("--only", type=_name_list(figures.FIGURES), default=list(figures.DEFAULT_FIGURES), help=f"comma-separated figures among {', '.join(figures.FIGURES)} (default all but random_packings, whose runs take hours)")
    p.add_argument("--workers", type=int, help="worker processes, one run each, the cores shared among those running (default: the cores)")
    p.add_argument("--quiet", action="store_true", help="no progress")
    p.add_argument("--draw-only", action="store_true",
                   help="run nothing: draw from the run folders in --out as they are (runs still going or stopped drawn to where they got, captions.md names them)")
    p.add_argument("--from-last-step", action="store_true", help="an interrupted run goes on from the last step it saved at its stop, not from its last checkpoint (see tidens run --from-last-step)")


def _figures(args: argparse.Namespace) -> int:
    from . import figures

    say = (lambda _m: None) if args.quiet else (lambda m: print(m, flush=True))
    made = figures.make(args.out, level=args.level, figures=args.only, workers=args.workers, log=say, draw_only=args.draw_only,
                        from_last_step=args.from_last_step)
    failed = [r["name"] for r in made.runs if r["status"] not in FINISHED]
    for f in made.findings:
        print(f"  {f['verdict']:>13}: {f['claim']}")
    if args.draw_only:
        print(f"drew {len(made.files)} files into {args.out}" + (f"; not finished: {', '.join(failed)}" if failed else ""))
        return 0
    print(f"wrote {len(made.files)} files to {args.out} in {made.wall_seconds:.0f} s" + (f"; runs that did not finish: {', '.join(failed)}" if failed else ""))
    return 3 if failed else 0


def _add_pack_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--particles", type=int, required=True, help="number of particles, in [1, 10000]")
    p.add_argument("--rho0", type=float, help="relative density, in [0.3, 0.74] (default 0.6, with --jam 0.74); shaken and compressed again where they jam, monodisperse spheres reach about 0.64-0.69 in a periodic box, less in a die")
    p.add_argument("--jam", action="store_true", help="grow toward --rho0 and, where the packing jams below it, keep the state where it first jams (touching particles, about 6 contacts per sphere; 32 or more spheres in a periodic box jam at about 0.60-0.65)")
    p.add_argument("--radius", type=float, default=0.05, help="number mean of the volume-equivalent radius [mm] (default 0.05)")
    p.add_argument("--aspect-ratio", type=float, default=1.0, help="spheroid c/a, in [0.2, 5], c along each particle's random axis (default 1)")
    p.add_argument("--size-ratio", type=float, help="bimodal: large over small radius, in (1, 10]")
    p.add_argument("--small-fraction", type=float, default=0.5, help="bimodal: number fraction of small particles, in [0, 1] (default 0.5)")
    p.add_argument("--sigma", type=float, help="lognormal: standard deviation of ln(radius), in (0, 1]")
    p.add_argument("--boundary", choices=("periodic", "die"), default="periodic", help="periodic in x, y and z (default), or a die: periodic in x and y, walls at z = 0 and Lz")
    p.add_argument("--packing-seed", type=_seed, default=0, help="seed, in [0, 2^64 - 1]: the same options and seed give the same packing (default 0)")
    p.add_argument("--out", type=Path, required=True, help="packing file to write (one particle per line, box and boundary in its header)")


class _PackingProgress:
    """A line on a terminal's stderr, rewritten as a packing grows (a
    large one takes minutes); nothing when stderr is not a terminal or
    with ``quiet``. ``with _PackingProgress() as show:`` gives the
    ``progress`` callable of ``Packing.generate`` (None when silent) and
    ends the line afterwards."""

    def __init__(self, quiet: bool = False) -> None:
        self.live = not quiet and sys.stderr.isatty()
        self.shown = False

    def __enter__(self) -> Callable[[dict[str, Any]], None] | None:
        return self.show if self.live else None

    def show(self, p: dict[str, Any]) -> None:
        self.shown = True
        print(f"\rpacking: {p['stage']}, rho = {p['rel_density']:.4f} (densest {p['densest']:.4f}), "
              f"round {p['round']}, {p['iterations']} iterations", end="", file=sys.stderr, flush=True)

    def __exit__(self, *exc: object) -> None:
        if self.shown:
            print(file=sys.stderr, flush=True)


def _generate(args: argparse.Namespace) -> Packing:
    with _PackingProgress() as show:
        return Packing.generate(
            args.particles,
            rho0=args.rho0 if args.rho0 is not None else (0.74 if args.jam else 0.6),
            mean_radius_mm=args.radius,
            aspect_ratio=args.aspect_ratio,
            size_ratio=args.size_ratio,
            small_fraction=args.small_fraction,
            sigma=args.sigma,
            boundary=args.boundary,
            seed=args.packing_seed,
            jam=args.jam,
            progress=show,
        )


def _pack(args: argparse.Namespace) -> int:
    import time

    from . import packing

    t0 = time.perf_counter()
    try:
        p = _generate(args)
    except ValueError as e:
        # rho0 is an option here (elsewhere it is the cell's density).
        raise ValueError(re.sub(r"^rho0 = ", "--rho0 = ", str(e))) from e
    wall = time.perf_counter() - t0
    packing.write(p, args.out)
    lx, ly, lz = p.lengths_mm
    z = packing.coordination_number(p)
    z_held = packing.coordination_number(p, without_rattlers=True)
    print(
        f"{len(p)} particles, {p.boundary} box {lx:.6g} x {ly:.6g} x {lz:.6g} mm: rho0 = {p.rel_density:.6f}, "
        f"coordination number {z:.3f} ({z_held:.3f} without rattlers; gap <= {packing.COORDINATION_TOLERANCE:g} x mean radius), "
        f"largest overlap {p.max_overlap_mm:.2e} mm, {wall:.2f} s; wrote {args.out}"
    )
    return 0


def _add_show_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("folder", type=Path, metavar="DIR",
                   help="a run's folder (tidens run --out, or one point of a sweep or of tidens figures), finished or still going; "
                        "or a folder of runs (a sweep's, DIR/runs of tidens figures): one line for each")
    p.add_argument("--plot", type=Path, metavar="FILE", default=None,
                   help="also draw its density curve so far beside the continuum model into FILE (PNG, PDF or SVG by its suffix)")


def _show_folder_of_runs(folder: Path, runs: list[Path]) -> int:
    """One line per run folder in ``folder`` (a sweep's, or the runs of
    `tidens figures`): its status and its curve's last complete row."""
    print(f"{len(runs)} runs in {folder}:")
    for run in runs:
        summary = sweep._read_summary(run)
        status = "no summary (going or stopped)" if summary is None else str(summary.get("status"))
        last = sweep._last_point(run / "curve.csv")
        if last is None:
            print(f"  {run.name}: {status}, no step yet")
            continue
        z = last.get("coordination_number", math.nan)
        contacts = "" if not math.isfinite(z) else f", Z = {z:.2f}"
        print(f"  {run.name}: {status}, step {last['step']:.0f}, t = {last['time_s']:.4g} s, rho = {last['rel_density']:.4f}"
              f"{contacts}, time error {last['time_error_s']:.3g} s")
    return 0


def _show(args: argparse.Namespace) -> int:
    """Reports a run from its folder as `tidens run` does at its end: a
    run still going (or killed) to its last complete row of the curve,
    its totals as of its last checkpoint. A folder of runs (a sweep's)
    gets one line per run."""
    folder: Path = args.folder
    runs = sorted(p for p in folder.iterdir() if (p / "run.json").exists()) if folder.is_dir() else []
    if not (folder / "run.json").exists() and runs:
        if args.plot is not None:
            raise ValueError("--plot draws one run: give its folder, not a folder of runs")
        return _show_folder_of_runs(folder, runs)
    result = load(folder)
    if result.message:
        print(result.message)
    _report(result)
    if args.plot is not None:
        result.plot(args.plot)
        print(f"wrote {args.plot}")
    return 0


# Each command: its one-line help (in `tidens --help`) and the description
# its own help page starts with.
_COMMANDS = {
    "run": (
        "press one cell and write curve, summary, fields and a plot",
        "Presses one cell (a preset, --cell, or a cell file, --cell-file) in the rigid die until a density or a time, "
        "and writes DIR/curve.csv (row by row as the run goes), DIR/summary.json, VTU fields (DIR/fields.pvd) and "
        "DIR/density.png; with the error estimate (a coarse companion run) unless --no-error-estimate. "
        "--resume DIR goes on with a stopped run.",
    ),
    "demo": (
        "the README case: sc Ti-6Al-4V at 10 MPa to rho = 0.9, with a plot",
        "Runs the README's case: the simple-cubic cell of Ti-6Al-4V spheres creeping at 1293 K, pressed at 10 MPa "
        "until rho = 0.9, into --out (default ./tidens-demo): curve, summary, VTU fields and density.png. It replaces "
        "an earlier demo's outputs there and refuses a folder that holds anything else.",
    ),
    "sweep": (
        "one case over lists of stresses, materials, cells and aspect ratios, in parallel, into one folder per point and a table",
        "Runs one case over every combination of the listed stresses, materials, cells and aspect ratios, in worker "
        "processes (or on a Dask cluster), one folder per point under --out and the table sweep.csv (and "
        "sweep.parquet); a second call into the same --out runs only the points not finished.",
    ),
    "continuum": (
        "the closed-form continuum model's curve (Eqs. 2 and 3 of the paper) for a material, stress and rho0",
        "Writes the closed-form continuum model's densification curve (Eqs. 2 and 3 of the paper, initial and final "
        "stage) for a material, a stress and an initial density to DIR/curve.csv, and prints t(rho) at the marks.",
    ),
    "figures": (
        "the paper's studies: run them and draw the figures with their errors, captions and the findings checked",
        "Runs the paper's studies (as sweeps) and draws their figures with error bands, captions.md and findings.md "
        "(each finding of the paper with a verdict and its numbers) into --out; a second call runs only what is missing.",
    ),
    "pack": (
        "a random dense packing of spheres or spheroids, written to a file with its rho0 and coordination number",
        "Generates a random dense packing of spheres or spheroids (overlap relaxation with box compression) and "
        "writes it to a text file, one particle per line; prints its density and coordination number. "
        "Ctrl-C or SIGTERM stops it.",
    ),
    "show": (
        "a run's densities, times and costs from its folder, finished or still going (with --plot, its curve)",
        "Reports a run from its folder as `tidens run` does at its end: finished, still going or stopped (to its last "
        "step); or one line per run for a folder of runs. Its curve is checked against its summary.",
    ),
}


def build_parser() -> _Parser:
    parser = _Parser(prog="tidens", description="Powder-level FE of hot pressing of titanium powders (units: mm, N, MPa, s).")
    parser.add_argument("--version", action="version", version=f"tidens {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    adders: dict[str, Callable[[argparse.ArgumentParser], None]] = {
        "run": _add_run_options,
        "demo": _add_demo_options,
        "sweep": _add_sweep_options,
        "continuum": _add_continuum_options,
        "figures": _add_figures_options,
        "pack": _add_pack_options,
        "show": _add_show_options,
    }
    for name, (summary, description) in _COMMANDS.items():
        adders[name](sub.add_parser(name, help=summary, description=description))
    return parser


def _add_demo_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=_folder, default=Path(DEMO_FOLDER), help=f"output folder (default ./{DEMO_FOLDER}; an earlier demo's outputs there are replaced, anything else refused)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


# The demo's case, as `tidens run` options, and its default folder.
DEMO_FOLDER = "tidens-demo"
_DEMO_RUN = ("--cell", "sc", "--material", "ti64-creep-1293k", "--stress", "10", "--until-density", "0.9")


def _check_demo_folder(out: Path) -> None:
    """The demo replaces only an earlier demo: a folder holding another run
    (or anything but a run's outputs) is refused, naming what it holds."""
    record = out / RUN_FILE
    if not record.exists():
        return  # empty or new, or not a run's folder: tidens run's own check says
    try:
        data = json.loads(record.read_text())
        case = Case.from_dict(data["case"])
        until = data["run"]["until_density"]
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        raise FileExistsError(f"{out} holds another run ({record} is not a demo's): give another folder") from None
    demo = Case(cell=cells.sc(), material=materials.by_name("ti64-creep-1293k"), stress_mpa=10.0)
    same = (
        case.cell.name == demo.cell.name and case.material == demo.material and case.stress_mpa == demo.stress_mpa
        and until == 0.9 and case.knockdown == demo.knockdown and case.ramp_time_s == demo.ramp_time_s
    )
    if not same:
        raise FileExistsError(
            f"{out} holds another run (cell {case.cell.name}, {case.stress_mpa:g} MPa, until rho = {until}), not a demo: "
            "the demo replaces only an earlier demo's outputs; give another folder"
        )


def main(argv: Sequence[str] | None = None) -> int:
    """The command; returns its exit status: 0 done, 2 bad input (one line
    naming the option), 1 a file that cannot be read or written, 3 a solver
    failure (partial results written), 130 interrupted (Ctrl-C), 143
    terminated (SIGTERM; partial results written, as for Ctrl-C)."""
    parser = build_parser()
    args = parser.parse_args(_glue_negative_numbers(sys.argv[1:] if argv is None else argv))
    command = args.command
    subparser = _subparser(parser, command)
    try:
        with sigterm_stops():
            if command == "demo":
                _check_demo_folder(args.out)
                # The demo replaces its own earlier outputs.
                args = parser.parse_args(["run", *_DEMO_RUN, "--out", str(args.out), "--overwrite"] + (["--quiet"] if args.quiet else []))
            if command == "continuum":
                return _continuum(args)
            if command == "sweep":
                return _sweep(args)
            if command == "figures":
                return _figures(args)
            if command == "pack":
                return _pack(args)
            if command == "show":
                return _show(args)
            return _run(args)
    except cells.CellFileError as e:
        subparser.error(str(e), options=False)
    except (FileExistsError, UnsupportedError, NotADirectoryError) as e:
        # Not a typo: the help would not help.
        subparser.exit(2, f"{subparser.prog}: error: {option_names(str(e))}\n")
    except (ValueError, TypeError) as e:
        subparser.error(str(e))
    except OSError as e:
        print(f"tidens: {e}", file=sys.stderr)
        return 1
    except TidensError as e:
        print(f"tidens: {e}", file=sys.stderr)
        return 3
    except KeyboardInterrupt as e:
        out = getattr(args, "out", None) or getattr(args, "resume", None)
        said = str(e) if isinstance(e, Terminated) else "interrupted"
        print(f"tidens: {said}" + ("" if out is None else f"; partial results in {out}"), file=sys.stderr)
        if out is not None and command in ("run", "demo") and (out / CHECKPOINT_FILE).exists():
            hint = f"tidens: go on with tidens run --resume {out}"
            if (out / STOP_CHECKPOINT_FILE).exists():
                hint += " (from the last checkpoint, to the bit), or add --from-last-step (from the last step)"
            print(hint, file=sys.stderr)
        return EXIT_TERMINATED if isinstance(e, Terminated) else 130


def _subparser(parser: _Parser, command: str) -> _Parser:
    """The parser of ``command``, whose errors point to its own help."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            found = action.choices.get(command)
            if isinstance(found, _Parser):
                return found
    return parser


if __name__ == "__main__":
    sys.exit(main())
