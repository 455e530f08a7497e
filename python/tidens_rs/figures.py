"""The paper's studies as figures: ``tidens figures --out DIR``.

The paper is "Finite-Element Modeling of Titanium Powder Densification".
:func:`make` runs the cases its figures need (at one mesh level of the
accuracy ladder, default 2, with its tolerance 0.02 * 2^(3 - level), each
with its coarse companion for the error estimate; in parallel worker
processes, each into a folder of its own under ``DIR/runs``; a second call
into the same folder runs only what is missing) and draws, as PNG and PDF:

- ``ti64_cells``: Ti-6Al-4V, creep at 1293 K and thermal cycling
  1133-1293 K, at 5, 10, 15 and 20 MPa, for the sc, sc-2, bcc and fcc cells,
  beside the continuum model;
- ``cpti``: CP-Ti, alpha at 1003, 1073 and 1143 K at 25 and 50 MPa (and
  34 MPa at 1143 K) with the knock-down f = 0.17, beta at 1253 K at 1 MPa
  (f = 1) and 3 MPa (f = 0.6), on the bcc cell;
- ``aspect_ratio``: spheroids c/a = 0.8, 1, 1.2 at 15 MPa on the sc cell,
  with frictionless mirror planes (the model) and with particles tied to
  the planes (the sensitivity option that blocks their spreading);
- ``master_curve``: log densification rate against density at 5 to 40 MPa
  (sc with mirror and with tied planes, bcc, fcc), and the same divided by
  sigma^n;
- ``contours``: von Mises stress on the deformed particles of each cell at
  rho = 0.8, 0.9 and 0.95;
- ``mesh_study``: sc and bcc at mesh levels 1, 2 and 3, with the estimated
  error against the run time;
- ``random_packings``: random jammed packings of 32 whole spheres in a
  periodic box, of one size and of two (radius ratio 1.566, half of them
  small), Ti-6Al-4V creep at 10 MPa, beside the sc, bcc and fcc cells and
  the continuum model, and their coordination number against density
  (mesh level 1, the coarsest, whatever the level asked for). Its runs take
  hours, so it is made only when asked for by name (not one of
  :data:`DEFAULT_FIGURES`).

Every curve carries its estimated error as a band: a computed curve the
estimate of its run (coarse companion and time control, see
:mod:`tidens_rs.estimate`), a curve mapped by Norton similarity (the same
material at another stress or temperature, :mod:`tidens_rs.similarity`)
that of its source plus the mapping's, measured against a second computed
stress. ``captions.md`` says what each figure shows and which parameters
made it; ``findings.md`` checks the paper's findings against the curves,
each with the numbers that decide it. The paper's experimental curves are
not available: the figures show finite elements and the continuum model.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from . import cells as cells_module
from . import io
from . import materials as presets
from . import sweep
from .case import FINISHED, Case, SolverSettings, accuracy_ladder_tolerance, load
from .continuum import ContinuumModel
from .result import MARK_DENSITIES, Result, interpolate_time
from .similarity import MappedCurve, map_curve

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

FloatArray = npt.NDArray[np.float64]

FIGURES: tuple[str, ...] = ("ti64_cells", "cpti", "aspect_ratio", "master_curve", "contours", "mesh_study",
                            "random_packings")
# What ``tidens figures`` makes unless told: all but the random packings,
# whose runs take hours (``--only random_packings``).
DEFAULT_FIGURES: tuple[str, ...] = FIGURES[:-1]
CELLS: tuple[str, ...] = ("sc", "sc2", "bcc", "fcc")
CELL_LABELS = {"sc": "sc", "sc2": "sc-2", "bcc": "bcc", "fcc": "fcc"}
# Every run stops at this density (or at the time limit below).
UNTIL_DENSITY = 0.95
# Densities of the von Mises snapshots (the last one is the run's end).
CONTOUR_DENSITIES: tuple[float, ...] = (0.8, 0.9)
TI64_STRESSES_MPA: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0)
# Computed Ti-6Al-4V stresses; the others are mapped from the nearer one.
TI64_COMPUTED_MPA: tuple[float, float] = (5.0, 20.0)
MASTER_STRESSES_MPA: tuple[float, ...] = (5.0, 10.0, 20.0, 40.0)
# (cell, particle tied to the planes): sc also with the paper's walls.
MASTER_ROWS: tuple[tuple[str, bool], ...] = (("sc", False), ("sc", True), ("bcc", False), ("fcc", False))
ASPECT_RATIOS: tuple[float, ...] = (0.8, 1.0, 1.2)
ASPECT_STRESS_MPA = 15.0
STUDY_CELLS: tuple[str, ...] = ("sc", "bcc")
STUDY_LEVELS: tuple[int, ...] = (1, 2, 3)
STUDY_STRESS_MPA = 10.0
# The random packings: whole spheres in a periodic box, jammed by the
# packing generator from this seed; of one size, and bimodal (radius ratio,
# fraction of small particles by number).
RANDOM_PARTICLES = 32
RANDOM_SEED = 0
RANDOM_BIMODAL: tuple[float, float] = (1.566, 0.5)
# Their mesh level, whatever the figures' level (32 particles at level 1
# are 144094 unknowns), and the lattice cells drawn beside them.
RANDOM_LEVEL = 1
# Steps between their checkpoints: a step of 32 spheres takes a minute or
# more, so that a run stopped between two checkpoints loses at most ten
# (a run interrupted under another interval goes on with this one).
RANDOM_CHECKPOINT_EVERY = 10
# Seconds between the lines that tell how far each run under way has got.
POINT_EVERY_S = 600.0
RANDOM_LATTICES: tuple[str, ...] = ("sc", "bcc", "fcc")
CPTI_ALPHA_KNOCKDOWN = 0.17
# (preset, stress [MPa], knock-down, computed): the paper's CP-Ti conditions.
CPTI_CASES: tuple[tuple[str, float, float, bool], ...] = (
    ("cpti-alpha-1143k", 50.0, CPTI_ALPHA_KNOCKDOWN, True),
    ("cpti-alpha-1143k", 25.0, CPTI_ALPHA_KNOCKDOWN, True),
    ("cpti-alpha-1143k", 34.0, CPTI_ALPHA_KNOCKDOWN, False),
    ("cpti-alpha-1073k", 50.0, CPTI_ALPHA_KNOCKDOWN, False),
    ("cpti-alpha-1073k", 25.0, CPTI_ALPHA_KNOCKDOWN, False),
    ("cpti-alpha-1003k", 50.0, CPTI_ALPHA_KNOCKDOWN, False),
    ("cpti-alpha-1003k", 25.0, CPTI_ALPHA_KNOCKDOWN, False),
    ("cpti-beta-1253k", 3.0, 0.6, True),
    ("cpti-beta-1253k", 1.0, 1.0, True),
)
CPTI_CELL = "bcc"
CREEP, CYCLING = "ti64-creep-1293k", "ti64-tmp-1133-1293k"
MATERIAL_LABELS = {CREEP: "creep 1293 K", CYCLING: "thermal cycling 1133-1293 K"}
# Densities over which the paper sees log rate linear in density.
RATE_WINDOW: tuple[float, float] = (0.6, 0.9)
RUNS = "runs"
CAPTIONS = "captions.md"
FINDINGS = "findings.md"


@dataclass(frozen=True)
class Job:
    """One computed run of the figures: its folder name and case."""

    name: str
    case: Case
    snapshot_densities: tuple[float, ...] = ()

    def point(self) -> sweep.Point:
        c = self.case
        aspect = cells_module.aspect_ratio_of(c.cell)
        return sweep.Point(
            name=self.name,
            cell=c.cell.name,
            material=presets.name_of(c.material) or "custom",
            stress_mpa=c.stress_mpa,
            aspect_ratio=1.0 if aspect is None else aspect,
            case=c.as_dict(),
            snapshot_densities=self.snapshot_densities,
        )


@dataclass
class Curve:
    """A curve of a figure: times [s] and densities, the estimated relative
    error of t at each density (None: not known), how it was obtained."""

    time_s: FloatArray
    rel_density: FloatArray
    error: FloatArray | None
    source: str

    def time_to_density(self, rho: float) -> float | None:
        return interpolate_time(self.time_s, self.rel_density, rho)


@dataclass
class Made:
    """What :func:`make` produced: figure files, the run table, wall time."""

    files: list[Path]
    runs: list[dict[str, Any]]
    wall_seconds: float
    findings: list[dict[str, Any]] = field(default_factory=list)


def job_name(cell: str, material: str, stress_mpa: float, *, knockdown: float = 1.0, aspect: float = 1.0,
             tied_planes: bool = False, level: int) -> str:
    """The folder name of a run of the figures."""
    name = f"{cell}-{material}-{stress_mpa:g}MPa"
    if knockdown != 1.0:
        name += f"-f{knockdown:g}"
    if aspect != 1.0:
        name += f"-ca{aspect:g}"
    if tied_planes:
        name += "-tied"
    return name + f"-L{level}"


class Runs:
    """The runs the figures need, by name, and their results once run."""

    def __init__(self, level: int) -> None:
        self.level = level
        self.jobs: dict[str, Job] = {}
        self.results: dict[str, Result] = {}

    def want(self, cell: str, material: str, stress_mpa: float, *, knockdown: float = 1.0, aspect: float = 1.0,
             tied_planes: bool = False, level: int | None = None, snapshots: Sequence[float] = ()) -> str:
        lvl = self.level if level is None else level
        name = job_name(cell, material, stress_mpa, knockdown=knockdown, aspect=aspect, tied_planes=tied_planes, level=lvl)
        case = Case(
            cell=cells_module.by_name(cell, cells_module.DEFAULT_RADIUS_MM, aspect),
            material=presets.by_name(material),
            stress_mpa=stress_mpa,
            knockdown=knockdown,
            tied_planes=tied_planes,
            solver=SolverSettings(mesh_level=lvl, tolerance=accuracy_ladder_tolerance(lvl)),
        )
        old = self.jobs.get(name)
        shots = tuple(sorted(set(snapshots) | set(old.snapshot_densities if old else ())))
        self.jobs[name] = Job(name, case, shots)
        return name

    def want_random(self, bimodal: tuple[float, float] | None) -> str:
        """The random packing of the ``random_packings`` figure: of one
        size, or bimodal (radius ratio, fraction of small particles)."""
        name = random_job_name(bimodal)
        size_ratio, small_fraction = (None, 0.5) if bimodal is None else bimodal
        case = Case(
            cell=cells_module.random(RANDOM_PARTICLES, seed=RANDOM_SEED, size_ratio=size_ratio, small_fraction=small_fraction),
            material=presets.by_name(CREEP),
            stress_mpa=STUDY_STRESS_MPA,
            solver=SolverSettings(
                mesh_level=RANDOM_LEVEL,
                tolerance=accuracy_ladder_tolerance(RANDOM_LEVEL),
                checkpoint_every=RANDOM_CHECKPOINT_EVERY,
            ),
        )
        self.jobs[name] = Job(name, case)
        return name

    def result(self, name: str) -> Result | None:
        return self.results.get(name)


def point_line(name: str, point: dict[str, float]) -> str:
    """The line ``tidens figures`` prints every ``POINT_EVERY_S`` for a run
    under way: its last converged step."""
    return f"  {name}: step {point['step']:.0f}, t = {point['time_s']:.4g} s, rho = {point['rel_density']:.4f}"


def row_line(row: dict[str, Any]) -> str:
    """The line ``tidens figures`` prints for a finished run of its sweep:
    name, status and wall time, and why it stopped where the run says."""
    line = f"  {row['name']}: {row['status']} ({_seconds(row.get('wall_seconds'))})"
    return f"{line}: {row['reason']}" if row.get("reason") else line


def random_job_name(bimodal: tuple[float, float] | None) -> str:
    """The folder name of a random packing of the figures."""
    sizes = "" if bimodal is None else f"-bimodal{bimodal[0]:g}x{bimodal[1]:g}"
    return f"random{RANDOM_PARTICLES}-s{RANDOM_SEED}{sizes}-{CREEP}-{STUDY_STRESS_MPA:g}MPa-L{RANDOM_LEVEL}"


def levels_said(jobs: Sequence[Job], level: int) -> str:
    """The mesh levels ``jobs`` run at, for the log: "mesh level 1", or
    "mesh levels 1, 2" (the random packings run at ``RANDOM_LEVEL``
    whatever the figures' ``level``, which is said when there are no jobs)."""
    levels = sorted({j.case.solver.mesh_level for j in jobs}) or [level]
    return f"mesh level{'s' if len(levels) > 1 else ''} {', '.join(map(str, levels))}"


def plan(level: int = 2, figures: Sequence[str] = DEFAULT_FIGURES) -> Runs:
    """The runs that ``figures`` need at mesh ``level``."""
    runs = Runs(level)
    for fig in figures:
        if fig == "ti64_cells" or fig == "contours":
            for cell in CELLS:
                for material in (CREEP, CYCLING):
                    for s in TI64_COMPUTED_MPA:
                        shots = CONTOUR_DENSITIES if (fig == "contours" and material == CREEP and s == TI64_COMPUTED_MPA[1]) else ()
                        if fig == "contours" and not shots:
                            continue
                        runs.want(cell, material, s, snapshots=shots)
        elif fig == "cpti":
            for material, s, f, computed in CPTI_CASES:
                if computed:
                    runs.want(CPTI_CELL, material, s, knockdown=f)
        elif fig == "aspect_ratio":
            for k in ASPECT_RATIOS:
                for tied in (False, True):
                    runs.want("sc", CREEP, ASPECT_STRESS_MPA, aspect=k, tied_planes=tied)
        elif fig == "master_curve":
            for cell, tied in MASTER_ROWS:
                for s in MASTER_STRESSES_MPA:
                    runs.want(cell, CREEP, s, tied_planes=tied)
        elif fig == "mesh_study":
            for cell in STUDY_CELLS:
                for lvl in STUDY_LEVELS:
                    runs.want(cell, CREEP, STUDY_STRESS_MPA, level=lvl)
        elif fig == "random_packings":
            for bimodal in (None, RANDOM_BIMODAL):
                runs.want_random(bimodal)
            for cell in RANDOM_LATTICES:
                runs.want(cell, CREEP, STUDY_STRESS_MPA, level=RANDOM_LEVEL)
        else:
            raise ValueError(f"figures: {fig!r} is not one of {', '.join(FIGURES)}")
    return runs


# Relative cost of one run at a level, to start the longest first.
_CELL_COST = {"sc": 1.0, "bcc": 6.0, "fcc": 12.0, "sc2": 30.0}


def _cost(job: Job) -> float:
    c = job.case
    # A whole particle's contacts cost as much as several levels of mesh.
    cell = 1e4 * len(c.cell.particles) if c.cell.is_periodic else _CELL_COST.get(c.cell.name, 10.0)
    return cell * 4.0 ** c.solver.mesh_level * (1.0 if c.material.creep_n > 1.0 else 0.6)


def _run_jobs(runs: Runs, jobs: Sequence[Job], out: Path, *, workers: int | None, progress: bool,
              say: Callable[[str], None], from_last_step: bool = False) -> list[dict[str, Any]]:
    """Runs ``jobs`` into ``out/runs`` (those finished there earlier are
    skipped) and loads their results into ``runs``; the sweep's table."""
    table = sweep.execute(
        [j.point() for j in jobs],
        out / RUNS,
        until_density=UNTIL_DENSITY,
        workers=workers,
        progress=progress,
        on_row=lambda row: say(row_line(row)),
        on_point=lambda name, p: say(point_line(name, p)),
        point_every_s=POINT_EVERY_S,
        from_last_step=from_last_step,
    )
    for row in table:
        folder = Path(row["folder"])
        if not (folder / "summary.json").exists():
            # A worker that died wrote no summary: its curve is drawn nowhere.
            say(f"  {row['name']}: no result ({folder} holds no summary.json)")
            continue
        try:
            runs.results[row["name"]] = load(folder)
        except (FileNotFoundError, ValueError) as e:
            say(f"  {row['name']}: no result ({e})")
    return table


def _as_found(runs: Runs, name: str, folder: Path, say: Callable[[str], None]) -> dict[str, Any]:
    """The run ``name`` as its folder holds it (finished, going or
    stopped), loaded into ``runs``; its row: name, folder, status (``missing``
    where nothing was run), final density, run time."""
    row: dict[str, Any] = {"name": name, "folder": str(folder), "status": "missing", "final_density": None,
                           "wall_seconds": None, "reason": None}
    if not (folder / "run.json").exists():
        return row
    try:
        r = load(folder)
    except (FileNotFoundError, ValueError) as e:
        row["reason"] = str(e)
        say(f"  {name}: no result ({e})")
        return row
    runs.results[name] = r
    row.update(status=r.status, final_density=float(r.rel_density[-1]), wall_seconds=r.run_seconds)
    say(f"  {name}: {r.status}, rho = {r.rel_density[-1]:.4f} at t = {r.time_s[-1]:.4g} s")
    return row


def _check_figures_folder(out: Path, draw_only: bool) -> None:
    """The figures' folder: a folder (new, or one of earlier figures), not a
    file or a run's own folder; with ``draw_only`` one holding runs to draw
    from. NotADirectoryError, FileExistsError or FileNotFoundError naming
    it otherwise."""
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"{out} is a file, not a folder: give a folder for the figures and their runs")
    if (out / "run.json").exists():
        raise FileExistsError(f"{out} is the folder of one run (it holds run.json): give the folder of the figures, which holds their runs in {RUNS}/")
    if draw_only and not (out / RUNS).is_dir():
        raise FileNotFoundError(f"{out} holds no runs to draw from (no {out / RUNS}): run tidens figures --out {out} without --draw-only first")


def make(
    out_dir: str | Path,
    *,
    level: int = 2,
    figures: Sequence[str] = DEFAULT_FIGURES,
    workers: int | None = None,
    progress: bool = False,
    log: Callable[[str], None] | None = None,
    draw_only: bool = False,
    from_last_step: bool = False,
) -> Made:
    """Runs what ``figures`` need at mesh ``level`` into ``out_dir/runs``
    (skipping runs finished there earlier), then draws the figures into
    ``out_dir`` (PNG and PDF), ``captions.md`` and ``findings.md``.
    ``workers``: worker processes (default: the machine's cores).

    ``draw_only`` runs nothing: it draws from the run folders as they are
    (while the runs go on in another process, say). A run still going or
    stopped (no summary) is drawn to where its curve got, and
    ``captions.md`` names it; a run never started is missing from its
    figure. Its rows in ``Made.runs`` give each run's status (``missing``
    for one never started). An interrupted run goes on from its last
    checkpoint, or with ``from_last_step`` from the last step it saved at
    its stop (see :func:`tidens_rs.resume`)."""
    start = time.perf_counter()
    say = log or (lambda _m: None)
    for fig in figures:
        if fig not in FIGURES:
            raise ValueError(f"figures: {fig!r} is not one of {', '.join(FIGURES)}")
    if isinstance(level, bool) or not isinstance(level, int) or not 1 <= level:
        raise ValueError(f"level = {level!r}: must be a whole number >= 1")
    for name, flag in (("draw_only", draw_only), ("from_last_step", from_last_step)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} = {flag!r}: must be True or False")
    out = Path(out_dir)
    _check_figures_folder(out, draw_only)
    runs = plan(level, figures)
    jobs = sorted(runs.jobs.values(), key=_cost, reverse=True)
    if draw_only:
        say(f"drawing from the folders of {len(jobs)} runs at {levels_said(jobs, level)} in {out / RUNS}, running none")
        table = [_as_found(runs, job.name, out / RUNS / job.name, say) for job in jobs]
    else:
        say(f"{len(jobs)} runs at {levels_said(jobs, level)} into {out / RUNS}")
        table = _run_jobs(runs, jobs, out, workers=workers, progress=progress, say=say, from_last_step=from_last_step)
    made = Made(files=[], runs=table, wall_seconds=0.0)
    captions: list[str] = []
    findings: list[dict[str, Any]] = []
    drawers: dict[str, Callable[[Runs, Path], tuple[list[Path], str, list[dict[str, Any]]]]] = {
        "ti64_cells": _ti64_cells,
        "cpti": _cpti,
        "aspect_ratio": _aspect_ratio,
        "master_curve": _master_curve,
        "contours": _contours,
        "mesh_study": _mesh_study,
        "random_packings": _random_packings,
    }
    for fig in figures:
        files, caption, found = drawers[fig](runs, out)
        made.files += files
        captions.append(caption)
        findings += found
        say(f"  {fig}: {', '.join(p.name for p in files)}")
    made.findings = findings
    made.wall_seconds = time.perf_counter() - start
    if draw_only:
        unfinished = [f"`{r['name']}` ({r['status']})" for r in table if r["status"] not in FINISHED]
        made_by = (
            f"Drawn by `tidens figures --draw-only` from the folders of {len(jobs)} runs at {levels_said(jobs, level)} "
            f"under `{RUNS}/`, as they were, running none"
            + (f"; not finished, drawn to where they got or missing: {', '.join(unfinished)}" if unfinished else "")
        )
    else:
        made_by = (
            f"Made by `tidens figures` at {levels_said(jobs, level)} in {made.wall_seconds:.0f} s ({len(jobs)} runs; "
            f"each run's folder is under `{RUNS}/`, its table `{RUNS}/sweep.csv`)"
        )
    head = (
        f"# Figures of tidens {_version()}\n\n{made_by}. Every FE curve carries its estimated error as a band. "
        "The paper's experimental curves are not available: the figures show finite elements and the continuum "
        "model of the paper (Eqs. 2 and 3).\n"
    )
    made.files.append(io.atomic_write(out / CAPTIONS, lambda tmp: tmp.write_text(head + "\n" + "\n".join(captions))))
    made.files.append(io.atomic_write(out / FINDINGS, lambda tmp: tmp.write_text(_findings_text(findings))))
    return made


def _version() -> str:
    from . import __version__

    return __version__


def _seconds(x: Any) -> str:
    return f"{x:.1f} s" if isinstance(x, (int, float)) else "-"


# ---------------------------------------------------------------- curves


def computed(result: Result) -> Curve:
    """A computed run's curve with its estimated error band."""
    return Curve(result.time_s, result.rel_density, error_band(result.rel_density, result.estimate().relative), "computed")


def error_band(rho: FloatArray, relative: dict[str, float | None]) -> FloatArray | None:
    """The relative error at each density: the estimates at the mark
    densities, linear in rho between them and constant beyond; None when
    any is unknown."""
    pts = sorted((float(k), v) for k, v in relative.items() if v is not None)
    if not pts or len(pts) < len(relative):
        return None
    rs, es = zip(*pts)
    return np.asarray(np.interp(rho, np.array(rs), np.array(es)), dtype=float)


def mapped(source: Result, calibration: Result | None, stress_mpa: float, *, knockdown: float | None = None,
           creep_c: float | None = None) -> tuple[Curve, MappedCurve]:
    """``source`` mapped by Norton similarity to ``stress_mpa`` (and
    ``knockdown``, ``creep_c``); its error band is the source's plus the
    mapping's (measured against ``calibration``)."""
    m = map_curve(source, stress_mpa, knockdown=knockdown, creep_c=creep_c, calibration=calibration)
    own = error_band(source.rel_density, source.estimate().relative)
    mapping = error_band(source.rel_density, dict(m.relative_error)) if m.relative_error else None
    band = None if own is None or mapping is None else own + mapping
    return Curve(m.time_s, m.rel_density, band, f"mapped from {source.case.stress_mpa:g} MPa"), m


def continuum_curve(result: Result, *, stress_mpa: float | None = None, knockdown: float | None = None,
                    creep_c: float | None = None, until: float = UNTIL_DENSITY) -> tuple[FloatArray, FloatArray]:
    """The continuum model's t(rho) for the result's cell and material, at
    another load or C if given."""
    c = result.case
    model = ContinuumModel(
        creep_c=c.material.creep_c if creep_c is None else creep_c,
        creep_n=c.material.creep_n,
        stress_mpa=c.stress_mpa if stress_mpa is None else stress_mpa,
        knockdown=c.knockdown if knockdown is None else knockdown,
        ramp_time_s=c.ramp_time_s,
        rho0=c.cell.rho0,
    )
    t, rho = model.curve(until)
    return np.asarray(t, dtype=float), np.asarray(rho, dtype=float)


def densification_rate(time_s: FloatArray, rho: FloatArray, grid: FloatArray) -> FloatArray:
    """d rho / dt [1/s] at the densities ``grid``, from the curve's t(rho)
    differentiated by central differences on the grid (second order, also
    at its ends; points where the density does not rise are skipped); NaN
    outside the curve."""
    keep = np.concatenate([np.diff(rho) > 0.0, [True]])
    r, t = rho[keep], time_s[keep]
    inside = (grid >= r[0]) & (grid <= r[-1])
    tg = np.full(grid.shape, np.nan)
    tg[inside] = np.interp(grid[inside], r, t)
    if len(grid) < 3:
        return np.full(grid.shape, np.nan)
    dt = np.gradient(tg, grid, edge_order=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.where(dt > 0.0, 1.0 / dt, np.nan)
    return np.asarray(rate, dtype=float)


def applied_stress_at(result: Result, grid: FloatArray) -> FloatArray:
    """The piston stress [MPa] applied when the run's density passed each
    of ``grid`` (NaN outside the curve)."""
    rho, sigma = result.rel_density, result.applied_stress_mpa
    keep = np.concatenate([np.diff(rho) > 0.0, [True]])
    inside = (grid >= rho[keep][0]) & (grid <= rho[keep][-1])
    out = np.full(grid.shape, np.nan)
    out[inside] = np.interp(grid[inside], rho[keep], sigma[keep])
    return out


def log_rate_fit(grid: FloatArray, rate: FloatArray, window: tuple[float, float] = RATE_WINDOW) -> tuple[float, float, float]:
    """Least-squares line log10(rate) = a + b rho over ``window``: (b, a,
    largest deviation of the points from the line in log10)."""
    sel = (grid >= window[0]) & (grid <= window[1]) & np.isfinite(rate) & (rate > 0.0)
    if sel.sum() < 3:
        return math.nan, math.nan, math.nan
    y = np.log10(rate[sel])
    b, a = np.polyfit(grid[sel], y, 1)
    dev = float(np.max(np.abs(y - (a + b * grid[sel]))))
    return float(b), float(a), dev


# ---------------------------------------------------------------- drawing


def _figure(rows: int, cols: int, width: float = 4.0, height: float = 3.3) -> tuple[Figure, Any]:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width * cols, height * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes


def _save(fig: Figure, out: Path, name: str) -> list[Path]:
    paths = []
    for ext in ("png", "pdf"):

        def write(tmp: Path, fmt: str = ext) -> None:
            fig.savefig(tmp, format=fmt, dpi=130)

        paths.append(io.atomic_write(out / f"{name}.{ext}", write))
    return paths


def _plot(ax: Axes, curve: Curve, color: str, label: str, style: str = "-") -> None:
    t, rho = curve.time_s, curve.rel_density
    keep = t > 0
    ax.plot(t[keep], rho[keep], style, color=color, label=label, lw=1.4)
    if curve.error is not None:
        # t / (1 + e) to t (1 + e): symmetric on the logarithmic time axis.
        e = curve.error[keep]
        ax.fill_betweenx(rho[keep], t[keep] / (1 + e), t[keep] * (1 + e), color=color, alpha=0.18, lw=0)


def _legend(ax: Axes, **kw: Any) -> None:
    """The legend of ``ax``, where it has labelled curves (a figure drawn
    from runs not there yet may have none)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kw)


def _density_axes(ax: Axes, title: str) -> None:
    ax.set_xscale("log")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("relative density")
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)


def _missing(ax: Axes, what: str) -> None:
    ax.text(0.5, 0.5, f"{what}:\nno result", ha="center", va="center", transform=ax.transAxes)


def _ti64_cells(runs: Runs, out: Path) -> tuple[list[Path], str, list[dict[str, Any]]]:
    fig, axes = _figure(2, len(CELLS))
    lo, hi = TI64_COMPUTED_MPA
    times: dict[tuple[str, str, float], dict[float, float | None]] = {}
    computed_runs: dict[tuple[str, str, float], Result] = {}
    errors: list[float] = []
    for i, material in enumerate((CREEP, CYCLING)):
        for j, cell in enumerate(CELLS):
            ax = axes[i][j]
            res = {s: runs.result(job_name(cell, material, s, level=runs.level)) for s in TI64_COMPUTED_MPA}
            if res[lo] is None or res[hi] is None:
                _missing(ax, f"{cell} {material}")
                continue
            for k, s in enumerate(TI64_STRESSES_MPA):
                color = f"C{k}"
                if s in res:
                    r = res[s]
                    assert r is not None
                    curve = computed(r)
                    computed_runs[(cell, material, s)] = r
                    label = f"{s:g} MPa"
                else:
                    src, cal = (res[lo], res[hi]) if abs(s - lo) <= abs(s - hi) else (res[hi], res[lo])
                    assert src is not None
                    curve, m = mapped(src, cal, s)
                    if m.error is not None:
                        errors.append(m.error)
                    label = f"{s:g} MPa (mapped)"
                _plot(ax, curve, color, label)
                base = res[lo]
                assert base is not None
                tc, rc = continuum_curve(base, stress_mpa=s)
                ax.plot(tc[tc > 0], rc[tc > 0], ":", color=color, lw=1.0)
                times[(cell, material, s)] = {m_: curve.time_to_density(m_) for m_ in MARK_DENSITIES}
            _density_axes(ax, f"{CELL_LABELS[cell]}, Ti-6Al-4V {MATERIAL_LABELS[material]}")
            if j == 0:
                _legend(ax, fontsize=7, loc="upper left")
    files = _save(fig, out, "ti64_cells")
    caption = (
        "## ti64_cells\n\nRelative density against time (log scale) for Ti-6Al-4V, creep at 1293 K "
        "(C = 4.8e-7 MPa^-n/s, n = 2.8; top) and thermal cycling 1133-1293 K (transformation-mismatch "
        "plasticity as a linear law, C = 1.045e-5 MPa^-1/s; bottom), at 5, 10, 15 and 20 MPa (1 s ramp), "
        f"on the sc, sc-2, bcc and fcc cells, mesh level {runs.level}, to rho = {UNTIL_DENSITY}. 5 and 20 MPa "
        "are computed; 10 and 15 MPa are mapped by Norton similarity from the nearer computed stress, "
        "their error measured against the other (largest mapping error "
        f"{_pct(max(errors) if errors else None)}). Bands: estimated error of t(rho). Dotted: the "
        "continuum model (Eqs. 2 and 3 of the paper, f = 1) at the same stress and rho0.\n"
    )
    return files, caption, _ti64_findings(times, computed_runs)


def _pct(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{100 * x:.2g} %"


def _ti64_findings(times: dict[tuple[str, str, float], dict[float, float | None]],
                   computed_runs: dict[tuple[str, str, float], Result]) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []

    def t(cell: str, material: str, s: float, rho: float) -> float | None:
        return times.get((cell, material, s), {}).get(rho)

    # Stress matters more under creep than under thermal cycling.
    ratios: dict[str, list[float]] = {}
    for material in (CREEP, CYCLING):
        ratios[material] = [r for c in CELLS if (r := _ratio_value(t(c, material, 5.0, 0.9), t(c, material, 20.0, 0.9))) is not None]
    if ratios[CREEP] and ratios[CYCLING]:
        out.append(_finding(
            "Stress matters more under creep than under thermal cycling",
            min(ratios[CREEP]) > max(ratios[CYCLING]),
            f"t(0.9) at 5 MPa over t(0.9) at 20 MPa: creep {_range(ratios[CREEP])}, thermal cycling "
            f"{_range(ratios[CYCLING])} (cells sc, sc-2, bcc, fcc; for a uniform stress 4^2.8 = 48.5 and 4^1 = 4)",
        ))
    # Thermal cycling beats creep at 5 MPa at high density (for a uniform
    # stress the presets' rates cross at 5.54 MPa; in the necks the stress
    # is higher, which favours creep until the necks have grown).
    grid = np.linspace(0.5, UNTIL_DENSITY, 181)
    over: list[tuple[str, float | None, float]] = []
    for c in CELLS:
        tc, cr = computed_runs.get((c, CYCLING, 5.0)), computed_runs.get((c, CREEP, 5.0))
        if tc is None or cr is None:
            continue
        ahead = densification_rate(tc.time_s, tc.rel_density, grid) > densification_rate(cr.time_s, cr.rel_density, grid)
        # The density from which on cycling densifies faster.
        behind = np.flatnonzero(~ahead[:-1])
        since = None if not ahead[-2] else float(grid[behind[-1] + 1]) if behind.size else float(grid[0])
        over.append((c, since, _ratio_value(t(c, CYCLING, 5.0, 0.95), t(c, CREEP, 5.0, 0.95)) or math.nan))
    if over:
        out.append(_finding(
            "At 5 MPa thermal cycling beats creep at high density",
            all(since is not None for _, since, _r in over),
            "cycling densifies faster than creep: "
            + ", ".join(f"{CELL_LABELS[c]} from rho = {since:.3f} on" if since is not None else f"{CELL_LABELS[c]} not at rho = 0.95"
                        for c, since, _r in over)
            + "; t(0.95) cycling/creep: "
            + ", ".join(f"{CELL_LABELS[c]} {r:.2f}" for c, _s, r in over)
            + "; at lower densities creep is faster, the necks' stresses being above the 5.54 MPa where the laws cross",
        ))
    # Thermal cycling's advantage grows with density (creep flattens).
    late = []
    for c in CELLS:
        a, b = _ratio_value(t(c, CREEP, 20.0, 0.95), t(c, CREEP, 20.0, 0.8)), _ratio_value(t(c, CYCLING, 20.0, 0.95), t(c, CYCLING, 20.0, 0.8))
        if a is not None and b is not None:
            late.append((c, a, b))
    if late:
        out.append(_finding(
            "Creep slows towards a plateau at high density while thermal cycling keeps rising",
            all(a > b for _, a, b in late),
            "t(0.95)/t(0.8) at 20 MPa, creep against cycling: " + ", ".join(f"{CELL_LABELS[c]} {a:.2f} vs {b:.2f}" for c, a, b in late),
        ))
    # sc slower than bcc and fcc.
    t9 = {c: t(c, CREEP, 20.0, 0.9) for c in CELLS}
    if all(t9[c] is not None for c in ("sc", "bcc", "fcc")):
        out.append(_finding(
            "sc densifies more slowly than bcc and fcc",
            t9["sc"] > t9["bcc"] and t9["sc"] > t9["fcc"],  # type: ignore[operator]
            "t(0.9), creep at 20 MPa: " + ", ".join(f"{CELL_LABELS[c]} {t9[c]:.3g} s" for c in CELLS if t9[c] is not None),
        ))
        b_run, f_run = computed_runs.get(("bcc", CREEP, 20.0)), computed_runs.get(("fcc", CREEP, 20.0))
        model_ratio = rate_ratio = "-"
        if b_run is not None and f_run is not None:
            tm = [continuum_curve(x, until=0.9) for x in (b_run, f_run)]
            model_ratio = f"{tm[0][0][-1] / tm[1][0][-1]:.2f}"
            g = np.array([0.85, 0.9])
            rr = densification_rate(f_run.time_s, f_run.rel_density, np.array([0.84, 0.85, 0.86, 0.89, 0.9, 0.91]))
            rb = densification_rate(b_run.time_s, b_run.rel_density, np.array([0.84, 0.85, 0.86, 0.89, 0.9, 0.91]))
            rate_ratio = ", ".join(f"{x:.2f} at rho = {d:g}" for x, d in zip((rr / rb)[[1, 4]], g))
        out.append(_finding(
            "The bcc-fcc difference is small",
            abs(t9["bcc"] / t9["fcc"] - 1.0) < 0.25,  # type: ignore[operator]
            f"t(0.9) bcc/fcc = {t9['bcc'] / t9['fcc']:.2f} (creep, 20 MPa), the continuum model's {model_ratio} "  # type: ignore[operator]
            f"(it sees only rho0: 0.680 against 0.740). Both reach rho = 0.8 in about the same time (bcc "
            f"{_seconds(t('bcc', CREEP, 20.0, 0.8))}, fcc {_seconds(t('fcc', CREEP, 20.0, 0.8))}); beyond, at equal density "
            f"fcc densifies faster: its rate over bcc's {rate_ratio}. fcc carries the load on 12 necks per "
            "particle (4 of them in the plane normal to the load), bcc on 8 along the body diagonals, "
            "joined by its second neighbours across the cell faces only near rho = 0.78",
        ))
    return out


def _range(xs: list[float]) -> str:
    return f"{min(xs):.3g}-{max(xs):.3g}"


def _ratio_value(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None or b <= 0 else a / b


def _ratio(a: float | None, b: float | None) -> str:
    r = _ratio_value(a, b)
    return "-" if r is None else f"{r:.2f}"


def _finding(claim: str, holds: bool, evidence: str) -> dict[str, Any]:
    return {"claim": claim, "verdict": "holds" if holds else "does not hold", "evidence": evidence}


def _cpti(runs: Runs, out: Path) -> tuple[list[Path], str, list[dict[str, Any]]]:
    fig, axes = _figure(1, 2, width=5.0)
    by = {(m, s, f): runs.result(job_name(CPTI_CELL, m, s, knockdown=f, level=runs.level)) for m, s, f, c in CPTI_CASES if c}
    src_hi = by.get(("cpti-alpha-1143k", 50.0, CPTI_ALPHA_KNOCKDOWN))
    src_lo = by.get(("cpti-alpha-1143k", 25.0, CPTI_ALPHA_KNOCKDOWN))
    k = 0
    errors = []
    for material, s, f, is_computed in CPTI_CASES:
        alpha = "alpha" in material
        ax = axes[0][0 if alpha else 1]
        r = by.get((material, s, f)) if is_computed else None
        label = f"{material.split('-')[-1].upper()[:-1]} K, {s:g} MPa, f = {f:g}"
        if is_computed:
            if r is None:
                continue
            curve = computed(r)
            tc, rc = continuum_curve(r)
        else:
            if src_hi is None or src_lo is None:
                continue
            src, cal = (src_hi, src_lo) if abs(s - 50.0) <= abs(s - 25.0) else (src_lo, src_hi)
            c2 = presets.by_name(material).creep_c
            curve, m = mapped(src, cal, s, creep_c=c2)
            if m.error is not None:
                errors.append(m.error)
            label += " (mapped)"
            tc, rc = continuum_curve(src, stress_mpa=s, creep_c=c2)
        color = f"C{k % 10}"
        k += 1
        _plot(ax, curve, color, label)
        ax.plot(tc[tc > 0], rc[tc > 0], ":", color=color, lw=1.0)
    _density_axes(axes[0][0], f"CP-Ti alpha, {CPTI_CELL}, f = {CPTI_ALPHA_KNOCKDOWN}")
    _density_axes(axes[0][1], f"CP-Ti beta 1253 K, {CPTI_CELL}")
    for ax in axes[0]:
        _legend(ax, fontsize=7, loc="upper left")
    files = _save(fig, out, "cpti")
    caption = (
        "## cpti\n\nCP-Ti (n = 4.3) on the bcc cell, mesh level "
        f"{runs.level}: alpha at 1003, 1073 and 1143 K (C = 1.29e-10, 7.72e-10, 3.86e-9 MPa^-n/s) under "
        "25 and 50 MPa and 34 MPa at 1143 K, with the knock-down f = 0.17 for die-wall friction (the cell "
        "feels f sigma); beta at 1253 K (C = 6.74e-6) under 1 MPa (f = 1) and 3 MPa (f = 0.6). Computed: "
        "alpha 1143 K at 25 and 50 MPa and both beta cases; the others mapped by Norton similarity in "
        "stress and C (a change of temperature at the same n is a change of the time unit), with the "
        f"mapping error measured between the two computed alpha stresses (largest {_pct(max(errors) if errors else None)}). "
        "Bands: estimated error. Dotted: the continuum model at the same f sigma and rho0.\n"
    )
    return files, caption, []


def _aspect_ratio(runs: Runs, out: Path) -> tuple[list[Path], str, list[dict[str, Any]]]:
    fig, axes = _figure(1, 2, width=5.0)
    t9: dict[tuple[float, bool], float | None] = {}
    err9: dict[tuple[float, bool], float | None] = {}
    for j, tied in enumerate((False, True)):
        ax = axes[0][j]
        for k, ratio in enumerate(ASPECT_RATIOS):
            r = runs.result(job_name("sc", CREEP, ASPECT_STRESS_MPA, aspect=ratio, tied_planes=tied, level=runs.level))
            if r is None:
                continue
            _plot(ax, computed(r), f"C{k}", f"c/a = {ratio:g}")
            t9[(ratio, tied)] = r.time_to_density(0.9)
            err9[(ratio, tied)] = r.estimate().relative.get("0.9")
        _density_axes(ax, "sc, Ti-6Al-4V creep, 15 MPa, " + ("particle tied to the planes" if tied else "frictionless mirror planes"))
        _legend(ax, fontsize=8, loc="upper left")
    files = _save(fig, out, "aspect_ratio")
    caption = (
        "## aspect_ratio\n\nSpheroidal particles, c/a = 0.8, 1 and 1.2 (c along the pressing direction), sc "
        f"cell, Ti-6Al-4V creep at 15 MPa, mesh level {runs.level}. Left: the model, frictionless mirror "
        "planes (the box faces are planes of symmetry of the packing, so neighbours do not slide against "
        "each other and the particle spreads freely along them). Right: the particle tied to the planes "
        "where it touches them (a sensitivity option: rough walls that block the spreading). Bands: "
        "estimated error.\n"
    )
    found = []
    vals = {key: v for key, v in t9.items() if v is not None}
    if len(vals) == 2 * len(ASPECT_RATIOS):
        def slowest(tied: bool) -> float:
            return max(ASPECT_RATIOS, key=lambda k_: vals[(k_, tied)])

        evidence = "t(0.9) [s], mirror / tied: " + ", ".join(
            f"c/a {k_:g} {vals[(k_, False)]:.4g} / {vals[(k_, True)]:.4g}" for k_ in ASPECT_RATIOS) + (
            " (their estimated errors " + ", ".join(f"{_pct(err9.get((k_, False)))} / {_pct(err9.get((k_, True)))}" for k_ in ASPECT_RATIOS)
            + ")")
        found.append(_finding("c/a = 0.8 is clearly slower than 1 and 1.2 (frictionless mirror planes)", slowest(False) == 0.8, evidence))
        found.append(_finding("c/a = 0.8 is clearly slower than 1 and 1.2 (particle tied to the planes)", slowest(True) == 0.8, evidence))
    return files, caption, found


def _master_curve(runs: Runs, out: Path) -> tuple[list[Path], str, list[dict[str, Any]]]:
    fig, axes = _figure(len(MASTER_ROWS), 2, width=5.0)
    # Rates over 0.02 of density (central differences on a grid of 0.01):
    # finer, they resolve the single steps of the time integration.
    grid = np.round(np.arange(0.5, UNTIL_DENSITY + 1e-9, 0.01), 10)
    found = []
    notes = []
    for i, (cell, tied) in enumerate(MASTER_ROWS):
        label = CELL_LABELS[cell] + (", tied planes" if tied else "")
        slopes, normalised = {}, {}
        after_ramp = RATE_WINDOW[0]
        n = presets.by_name(CREEP).creep_n
        for k, s in enumerate(MASTER_STRESSES_MPA):
            r = runs.result(job_name(cell, CREEP, s, tied_planes=tied, level=runs.level))
            if r is None:
                continue
            rate = densification_rate(r.time_s, r.rel_density, grid)
            # The first 0.02 above rho0 is the ramp's elastic and contact transient.
            rate[grid < r.rho0 + 0.02] = np.nan
            axes[i][0].semilogy(grid, rate, color=f"C{k}", label=f"{s:g} MPa")
            # Divided by the stress applied when the density passed (the ramp's, early on).
            norm = rate / applied_stress_at(r, grid) ** n
            axes[i][1].semilogy(grid, norm, color=f"C{k}", label=f"{s:g} MPa")
            slopes[s] = log_rate_fit(grid, norm * s**n)
            normalised[s] = norm
            after_ramp = max(after_ramp, float(np.interp(r.case.ramp_time_s, r.time_s, r.rel_density)) + 0.01)
        for ax, ylabel in zip(axes[i], ("d rho / dt [1/s]", "(d rho / dt) / sigma^n [1/(s MPa^n)]")):
            ax.set_xlabel("relative density")
            ax.set_ylabel(ylabel)
            ax.grid(True, alpha=0.3, which="both")
            ax.axvspan(*RATE_WINDOW, color="0.9", zorder=0)
            _legend(ax, fontsize=8)
        axes[i][0].set_title(f"{label}, Ti-6Al-4V creep (n = {n:g})", fontsize=10)
        axes[i][1].set_title(f"{label}: master curve", fontsize=10)
        if len(normalised) < 2:
            continue
        stack = np.log(np.vstack(list(normalised.values())))
        sel = (grid >= after_ramp) & (grid <= RATE_WINDOW[1]) & np.all(np.isfinite(stack), axis=0)
        if not sel.any():
            continue
        dev = stack[:, sel] - stack[:, sel].mean(axis=0)
        rms, worst = float(np.expm1(np.sqrt(np.mean(dev**2)))), float(np.expm1(np.max(np.abs(dev))))
        lo, hi = float(grid[sel][0]), float(grid[sel][-1])
        notes.append(f"{label}: the normalised rates scatter by {_pct(rms)} rms ({_pct(worst)} at most) over rho = {lo:.2f}-{hi:.2f}")
        b = [v[0] for v in slopes.values()]
        dev_line = max(v[2] for v in slopes.values())
        start = max(RATE_WINDOW[0], min(float(grid[np.isfinite(v)][0]) for v in normalised.values()))
        span = abs(float(np.mean(b))) * (RATE_WINDOW[1] - start)
        found.append(_finding(
            f"Log rate is linear in density from about 0.6 to 0.9 with one slope for 5-40 MPa ({label})",
            dev_line < 0.1 * span and (max(b) - min(b)) < 0.1 * abs(float(np.mean(b))),
            f"slopes d log10(rate)/d rho over {start:.2f}-{RATE_WINDOW[1]} (rate at the full stress, the ramp's "
            "divided out): "
            + ", ".join(f"{s:g} MPa {v[0]:.2f}" for s, v in slopes.items())
            + f"; largest deviation from the line {dev_line:.3f} decades against the {span:.2f} decades the line falls "
            "(linear: within a tenth of it, slopes within a tenth of their mean)",
        ))
        found.append(_finding(
            f"Rate over sigma^n collapses onto one curve ({label})",
            rms <= 0.05,
            f"the normalised rates of {', '.join(f'{s:g}' for s in normalised)} MPa scatter about their mean by "
            f"{_pct(rms)} rms, {_pct(worst)} at most, over rho = {lo:.2f}-{hi:.2f} (the densities every run passes "
            "after its 1 s ramp; collapsed: within 5 % rms)",
        ))
    files = _save(fig, out, "master_curve")
    caption = (
        "## master_curve\n\nDensification rate d rho/dt against density (log scale) for Ti-6Al-4V creep at "
        f"{', '.join(f'{s:g}' for s in MASTER_STRESSES_MPA)} MPa on the sc cell (with mirror planes and with the particle tied to them), bcc and fcc (computed, mesh level "
        f"{runs.level}); right, the same divided by sigma^n (n = 2.8), sigma the stress applied when the "
        "density was passed (during the 1 s ramp, less than the nominal one): the master curve. The rate is "
        "the slope of t(rho) over 0.02 of density; the first 0.02 above rho0 (the ramp's elastic and "
        f"contact transient) is left out. Shaded: rho = {RATE_WINDOW[0]}-{RATE_WINDOW[1]}, where the paper sees "
        f"log rate linear in density. {'; '.join(notes)}.\n"
    )
    return files, caption, found


def boundary_faces(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The faces (k, 4) of a hexahedral mesh's cells (E, 8) that belong to
    one cell only (the surface, outward for a positively oriented mesh),
    and the cell each belongs to."""
    local = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])
    faces = cells[:, local].reshape(-1, 4)
    owner = np.repeat(np.arange(len(cells)), len(local))
    _, index, counts = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    keep = np.sort(index[counts == 1])
    return np.asarray(faces[keep]), np.asarray(owner[keep])


def _contours(runs: Runs, out: Path) -> tuple[list[Path], str, list[dict[str, Any]]]:
    import meshio
    from matplotlib import colormaps
    from matplotlib.colors import Normalize
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # type: ignore[import-untyped]

    from matplotlib.figure import Figure

    labels = [f"rho{r:.3f}" for r in CONTOUR_DENSITIES] + ["final"]
    fig = Figure(figsize=(3.2 * len(labels) + 1.0, 3.0 * len(CELLS)))
    fig.subplots_adjust(left=0.0, right=0.9, bottom=0.0, top=0.97, wspace=0.0, hspace=0.08)
    cmap = colormaps["viridis"]
    found = []
    for i, cell in enumerate(CELLS):
        folder = out / RUNS / job_name(cell, CREEP, TI64_COMPUTED_MPA[1], level=runs.level)
        meshes = []
        for lab in labels:
            path = folder / f"fields_{lab}.vtu"
            meshes.append(meshio.read(path) if path.exists() else None)
        vm_max = max((float(np.max(m.cell_data["von_mises_mpa"][0])) for m in meshes if m is not None), default=1.0)
        norm = Normalize(0.0, vm_max)
        for j, (lab, mesh) in enumerate(zip(labels, meshes)):
            ax = fig.add_subplot(len(CELLS), len(labels), i * len(labels) + j + 1, projection="3d")
            ax.set_axis_off()
            if mesh is None or "hexahedron" not in mesh.cells_dict:
                ax.set_title(f"{CELL_LABELS[cell]}: no field", fontsize=8)
                continue
            faces, owner = boundary_faces(mesh.cells_dict["hexahedron"])
            vm = np.asarray(mesh.cell_data["von_mises_mpa"][0])
            coll = Poly3DCollection(mesh.points[faces], facecolors=cmap(norm(vm[owner])), edgecolors="none")
            ax.add_collection3d(coll)
            lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_zlim(lo[2], hi[2])
            ax.set_box_aspect(tuple(np.maximum(hi - lo, 1e-9)))
            ax.view_init(elev=22, azim=-58)
            rho = _density_of(folder, lab)
            ax.set_title(f"{CELL_LABELS[cell]}, rho = {rho:.3f}" if rho else CELL_LABELS[cell], fontsize=8)
            if cell == "sc2" and lab == "final":
                found += _sc2_small_particles(runs, mesh)
        sm = _scalar_mappable(cmap, norm)
        fig.colorbar(sm, ax=fig.axes[-len(labels):], shrink=0.7, label="von Mises [MPa]")
    files = _save(fig, out, "contours")
    caption = (
        "## contours\n\nVon Mises stress [MPa] on the deformed particles (the pieces in the unit cell) for "
        f"the sc, sc-2, bcc and fcc cells, Ti-6Al-4V creep at {TI64_COMPUTED_MPA[1]:g} MPa, mesh level "
        f"{runs.level}, at rho = {', '.join(f'{r:g}' for r in CONTOUR_DENSITIES)} and {UNTIL_DENSITY:g} "
        "(the run's end), one colour scale per cell. The highest stresses sit in the necks. Drawn from "
        "the runs' VTU files (open them in ParaView for the full fields).\n"
    )
    return files, caption, found


def _scalar_mappable(cmap: Any, norm: Any) -> Any:
    from matplotlib.cm import ScalarMappable

    return ScalarMappable(norm=norm, cmap=cmap)


def _density_of(folder: Path, label: str) -> float | None:
    if label.startswith("rho"):
        return float(label[3:])
    try:
        return float(json.loads((folder / "summary.json").read_text())["final_density"])
    except (OSError, ValueError, KeyError):
        return None


def _sc2_small_particles(runs: Runs, mesh: Any) -> list[dict[str, Any]]:
    """The paper's 'small particles of sc-2 deform more': mean equivalent
    plastic strain of each particle size at the run's end."""
    r = runs.result(job_name("sc2", CREEP, TI64_COMPUTED_MPA[1], level=runs.level))
    if r is None:
        return []
    sizes = np.array([a for _corner, a, _c in r.case.cell.octants])
    particle = np.asarray(mesh.cell_data["particle"][0]).astype(int)
    eqps = np.asarray(mesh.cell_data["eqps"][0])
    large, small = sizes.max(), sizes.min()
    mean = {}
    for name, size in (("large", large), ("small", small)):
        sel = np.isin(particle, np.flatnonzero(np.isclose(sizes, size)))
        mean[name] = float(eqps[sel].mean())
    return [_finding(
        "The small particles of sc-2 deform more",
        mean["small"] > mean["large"],
        f"mean equivalent plastic strain at rho = {UNTIL_DENSITY}: small {mean['small']:.3f}, large {mean['large']:.3f} "
        f"(element average, creep at {TI64_COMPUTED_MPA[1]:g} MPa)",
    )]


STUDY_DENSITIES: tuple[float, ...] = (0.8, 0.9, 0.95)


def _mesh_study(runs: Runs, out: Path) -> tuple[list[Path], str, list[dict[str, Any]]]:
    fig, axes = _figure(len(STUDY_CELLS), 2, width=5.0)
    rows = []
    markers = ("o", "s", "^")
    for i, cell in enumerate(STUDY_CELLS):
        for k, lvl in enumerate(STUDY_LEVELS):
            r = runs.result(job_name(cell, CREEP, STUDY_STRESS_MPA, level=lvl))
            if r is None:
                continue
            _plot(axes[i][0], computed(r), f"C{k}", f"level {lvl} ({r.degrees_of_freedom} dofs)")
            est = r.estimate()
            errs = [est.relative.get(f"{m:g}") for m in STUDY_DENSITIES]
            wall = r.wall_seconds + (est.companion_wall_seconds or 0.0)
            rows.append((cell, lvl, r.degrees_of_freedom, wall, errs))
            for m, e, mk in zip(STUDY_DENSITIES, errs, markers):
                if e is not None:
                    axes[i][1].loglog([wall], [100 * e], mk, color=f"C{k}", label=f"level {lvl}, t({m:g})")
        _density_axes(axes[i][0], f"{CELL_LABELS[cell]}, Ti-6Al-4V creep, {STUDY_STRESS_MPA:g} MPa")
        _legend(axes[i][0], fontsize=8, loc="upper left")
        ax = axes[i][1]
        ax.set_xlabel("wall time with companion [s], one thread")
        ax.set_ylabel("estimated error of t(rho) [%]")
        ax.set_title(f"{CELL_LABELS[cell]}: error against run time", fontsize=10)
        ax.grid(True, alpha=0.3, which="both")
        _legend(ax, fontsize=7)
    files = _save(fig, out, "mesh_study")
    table = "\n".join(
        f"| {c} | {lvl} | {d} | {w:.1f} | " + " | ".join(_pct(e) for e in errs) + " |" for c, lvl, d, w, errs in rows
    )
    caption = (
        "## mesh_study\n\nThe sc and bcc cells, Ti-6Al-4V creep at 10 MPa, at mesh levels 1, 2, 3 (each "
        "at its ladder tolerance 0.02 * 2^(3 - level)): left the curves with their estimated error; right "
        "the estimated relative error of t(0.8), t(0.9) and t(0.95) against the run's wall time (with its "
        "coarse companion; level 1 has none, so only its time error is known and it is not drawn).\n\n"
        "| cell | level | dofs | wall [s] | " + " | ".join(f"error t({m:g})" for m in STUDY_DENSITIES) + " |\n"
        "|---|---|---|---|" + "---|" * len(STUDY_DENSITIES) + "\n" + table + "\n"
    )
    return files, caption, []


def _random_packings(runs: Runs, out: Path) -> tuple[list[Path], str, list[dict[str, Any]]]:
    fig, axes = _figure(1, 2, width=5.0, height=3.8)
    ax, zax = axes[0][0], axes[0][1]
    rows = []
    for k, bimodal in enumerate((None, RANDOM_BIMODAL)):
        r = runs.result(random_job_name(bimodal))
        if r is None:
            continue
        label = "random, one size" if bimodal is None else f"random, radii {bimodal[0]:g}:1"
        color = f"C{k}"
        so_far = "" if r.status in FINISHED else f" (not finished: to rho {r.rel_density[-1]:.3f})"
        _plot(ax, computed(r), color, f"{label}, rho0 {r.rho0:.3f}{so_far}")
        t_model, rho_model = continuum_curve(r)
        ax.plot(t_model, rho_model, ":", color=color, lw=1.0, label=f"continuum model from rho0 {r.case.cell.rho0:.3f}")
        z = r.curve.get("coordination_number")
        if z is not None:
            pressed = np.isfinite(z) & (z > 0.0)
            zax.plot(r.rel_density[pressed], z[pressed], color=color, label=label)
        rows.append((label, r))
    for k, cell in enumerate(RANDOM_LATTICES):
        r = runs.result(job_name(cell, CREEP, STUDY_STRESS_MPA, level=RANDOM_LEVEL))
        if r is not None:
            _plot(ax, computed(r), f"C{k + 2}", f"{CELL_LABELS[cell]} cell", style="--")
    if not rows:
        _missing(zax, "random packings")
    _density_axes(ax, f"Ti-6Al-4V creep, {STUDY_STRESS_MPA:g} MPa, mesh level {RANDOM_LEVEL}")
    # Below the panels: inside, it would hide the lattices' early curves.
    fig.legend(*ax.get_legend_handles_labels(), fontsize=7, loc="outside lower center", ncol=4)
    zax.set_xlabel("relative density")
    zax.set_ylabel("coordination number")
    zax.set_title("random packings: contacts pressed per particle", fontsize=10)
    zax.grid(True, alpha=0.3)
    if rows:
        _legend(zax, fontsize=8, loc="upper left")
    files = _save(fig, out, "random_packings")
    marks = (0.8, 0.9, 0.95)

    def row(label: str, r: Result) -> str:
        s = r.summary()
        times = " | ".join(_seconds(r.time_to_density(m)) for m in marks)
        # The model's times at every mark, also those the run has not reached yet.
        model = " | ".join(_seconds(float(r.continuum().time_to_density(m)[0])) for m in marks)
        z_end = s.get("final_coordination_number")
        return (
            f"| {label} | {s['particles']} | {r.rho0:.4f} | {s['coordination_number']:.2f} | "
            f"{'-' if z_end is None or not math.isfinite(z_end) else f'{z_end:.2f}'} | {r.status} | "
            f"{s['final_density']:.4f} | {times} | {model} | {_seconds(float(r.curve['time_error_s'][-1]))} | "
            f"{_seconds(r.run_seconds)} |"
        )

    caption = (
        "## random_packings\n\n"
        f"Random jammed packings of {RANDOM_PARTICLES} whole spheres in a box periodic along x, y and z "
        f"(`tidens_rs.cells.random`, seed {RANDOM_SEED}): of one size, and of two (radius ratio "
        f"{RANDOM_BIMODAL[0]:g}, a fraction {RANDOM_BIMODAL[1]:g} of them small), Ti-6Al-4V creep at "
        f"{STUDY_STRESS_MPA:g} MPa, mesh level {RANDOM_LEVEL} (the coarsest, so the bands are the time "
        "control's error only), beside the sc, bcc and fcc cells at the same level (dashed) and the "
        "continuum model from each packing's rho0 (dotted). Right: the coordination number as the "
        "contacts press (pairs of particles pressed together, a particle and a periodic image of one "
        "counting as a pair, twice over the particles). Run time: the wall time of each packing's steps, "
        "summed across resumes from checkpoints (`Result.run_seconds`).\n\n"
        "| packing | particles | rho0 | Z at the start (geometry) | Z at the end (pressed) | status | final rho | "
        + " | ".join(f"t({m:g})" for m in marks) + " | "
        + " | ".join(f"continuum t({m:g})" for m in marks)
        + " | time error at the end | run time |\n"
        "|---|---|---|---|---|---|---|" + "---|" * (2 * len(marks)) + "---|---|\n"
        + "\n".join(row(label, r) for label, r in rows) + "\n"
    )
    return files, caption, []


def _findings_text(findings: list[dict[str, Any]]) -> str:
    lines = [
        "# The paper's findings, checked",
        "",
        "Each claim of the paper with the verdict of these runs and the numbers that decide it.",
        "",
    ]
    for f in findings:
        lines.append(f"- **{f['claim']}**: {f['verdict']}. {f['evidence']}.")
    return "\n".join(lines) + "\n"
