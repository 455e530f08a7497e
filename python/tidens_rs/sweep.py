"""Sweeps: one case over lists of stresses, materials, cells and aspect
ratios, each point in a worker process of its own, into one folder per
point and a combined table.

    import tidens_rs as td
    base = td.Case(cell=td.cells.sc(), material=td.materials.TI64_CREEP_1293K, stress_mpa=10.0)
    table = td.sweep.run(base, "out", until_density=0.9, stresses_mpa=[5, 10, 15], cells=["sc", "bcc"], workers=2)

Each point is the base case with the swept values put in; its outputs go to
``out/<name>/`` (a ``tidens run`` folder: curve, summary, fields, plot,
checkpoint), and one row per point to ``out/sweep.csv`` and
``out/sweep.parquet`` (the parameters, the status, the times to density and
their estimated errors, the continuum model's times, the cost), rewritten
as each point finishes. A restarted sweep does not run a finished point
again (its folder holds a summary with a finished status), nor one that
failed (the solver's reason is in the table; delete its folder to try it
again), and goes on with an interrupted one (stopped by Ctrl-C or killed)
from its last checkpoint (``tidens_rs.resume``).

Points run in parallel worker processes (``workers``; the cores shared
among those that run at once, so one thread each unless fewer points are
left to run than workers, see :func:`worker_threads`), or
on a Dask cluster (``scheduler``, the address of a ``dask.distributed``
scheduler; every worker must have tidens installed and see ``out`` at the
same path).
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from . import cells as cells_module
from . import io
from . import materials as presets
from ._core import ConvergenceError, Material
from .case import FINISHED, Case, resume
from .result import MARK_DENSITIES
from .signals import EXIT_TERMINATED, Terminated, sigterm_stops, stop_with_parent

TABLE_CSV = "sweep.csv"
TABLE_PARQUET = "sweep.parquet"

# The columns of the table, in order (times in s, errors relative).
COLUMNS: tuple[str, ...] = (
    "name",
    "cell",
    "material",
    "stress_mpa",
    "aspect_ratio",
    "status",
    "reason",
    "final_density",
    "final_time_s",
    *(f"t_{m:g}_s" for m in MARK_DENSITIES),
    *(f"error_{m:g}" for m in MARK_DENSITIES),
    *(f"continuum_t_{m:g}_s" for m in MARK_DENSITIES),
    "mesh_level",
    "tolerance",
    "element",
    "steps",
    "wall_seconds",
    "folder",
)


@dataclass(frozen=True)
class Point:
    """One point of a sweep: its folder name, the values swept, and the
    case (as :meth:`Case.as_dict`, so that it crosses to a worker)."""

    name: str
    cell: str
    material: str
    stress_mpa: float
    aspect_ratio: float
    case: dict[str, Any]
    # Densities at which the run writes its fields (VTU snapshots).
    snapshot_densities: tuple[float, ...] = ()


def plan(
    base: Case,
    *,
    stresses_mpa: Sequence[float] | None = None,
    materials: Sequence[str | Material] | None = None,
    cells: Sequence[str] | None = None,
    aspect_ratios: Sequence[float] | None = None,
) -> list[Point]:
    """The points of a sweep: every combination of the lists given (a list
    left out keeps the base case's value). Materials are preset names or
    :class:`Material` objects; cells are preset names (``sc``, ``bcc``,
    ``fcc``, ``sc2``; with a list of cells or aspect ratios the base case's
    cell must be one of them too, rebuilt with each aspect ratio at the
    default radius and size ratio)."""
    if not isinstance(base, Case):
        raise TypeError(f"base = {base!r}: must be a Case (the case every point varies)")
    base_aspect = cells_module.aspect_ratio_of(base.cell)
    base_name = base.cell.name
    stresses = _numbers("stresses_mpa", stresses_mpa, [base.stress_mpa])
    aspects = _numbers("aspect_ratios", aspect_ratios, [base_aspect if base_aspect is not None else 1.0])
    names = list(cells) if cells is not None else [base_name]
    for name in names:
        if name not in cells_module.CELL_NAMES:
            raise ValueError(f"cells: {name!r} is not a preset cell (one of {', '.join(cells_module.CELL_NAMES)})")
    if (cells is not None or aspect_ratios is not None) and base_name not in cells_module.CELL_NAMES and cells is None:
        raise ValueError(f"aspect_ratios: the base cell {base_name!r} is not a preset, so it cannot be rebuilt with other aspect ratios")
    laws: list[tuple[str, Material]] = []
    for m in materials if materials is not None else [base.material]:
        if isinstance(m, str):
            laws.append((m, presets.by_name(m)))
        elif isinstance(m, Material):
            laws.append((presets.name_of(m) or f"C{m.creep_c:.4g}-n{m.creep_n:g}", m))
        else:
            raise TypeError(f"materials: {m!r} is neither a preset name nor a Material")
    if not (stresses and aspects and names and laws):
        raise ValueError("a sweep needs at least one value of each list it is given")
    points = []
    for cell_name, (law_name, law), stress, aspect in itertools.product(names, laws, stresses, aspects):
        rebuild = cells is not None or aspect_ratios is not None
        cell = cells_module.by_name(cell_name, cells_module.DEFAULT_RADIUS_MM, aspect) if rebuild else base.cell
        case = replace(base, cell=cell, material=law, stress_mpa=stress)
        name = f"{cell_name}-{law_name}-{stress:g}MPa-ca{aspect:g}"
        points.append(Point(name, cell_name, law_name, float(stress), float(aspect), case.as_dict()))
    if len({p.name for p in points}) != len(points):
        raise ValueError("the sweep has repeated values: two points would share a folder")
    return points


def run(
    base: Case,
    out_dir: str | Path,
    *,
    until_density: float | None = None,
    until_time_s: float | None = None,
    stresses_mpa: Sequence[float] | None = None,
    materials: Sequence[str | Material] | None = None,
    cells: Sequence[str] | None = None,
    aspect_ratios: Sequence[float] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    error_estimate: bool = True,
    progress: bool = False,
    on_row: Callable[[dict[str, Any]], None] | None = None,
    on_point: Callable[[str, dict[str, float]], None] | None = None,
    point_every_s: float = 60.0,
    from_last_step: bool = False,
) -> list[dict[str, Any]]:
    """Runs the sweep of :func:`plan` into ``out_dir`` and returns the table
    (one row per point, keys :data:`COLUMNS`), also written to
    ``out_dir/sweep.csv`` and ``out_dir/sweep.parquet``. ``workers``: worker
    processes (default: the machine's cores, at most the number of points),
    each running one point at a time on one thread; ``scheduler``: the
    address of a Dask scheduler to run the points on instead. ``on_row`` is
    called with each row as its point finishes, ``on_point`` every
    ``point_every_s`` seconds with the last curve point of each point under
    way (see :func:`execute`). An interrupted point goes on from its last
    checkpoint (its curve to the bit), or with ``from_last_step`` from the
    last step it saved at its stop (see :func:`tidens_rs.resume`)."""
    points = plan(base, stresses_mpa=stresses_mpa, materials=materials, cells=cells, aspect_ratios=aspect_ratios)
    return execute(
        points,
        out_dir,
        until_density=until_density,
        until_time_s=until_time_s,
        workers=workers,
        scheduler=scheduler,
        error_estimate=error_estimate,
        progress=progress,
        on_row=on_row,
        on_point=on_point,
        point_every_s=point_every_s,
        from_last_step=from_last_step,
    )


def execute(
    points: Sequence[Point],
    out_dir: str | Path,
    *,
    until_density: float | None = None,
    until_time_s: float | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    error_estimate: bool = True,
    progress: bool = False,
    on_row: Callable[[dict[str, Any]], None] | None = None,
    on_point: Callable[[str, dict[str, float]], None] | None = None,
    point_every_s: float = 60.0,
    from_last_step: bool = False,
) -> list[dict[str, Any]]:
    """Runs ``points`` (from :func:`plan`, or made otherwise: any cases, each
    with a folder name of its own) into ``out_dir`` as :func:`run` does, in
    the order given (put the longest first to keep the workers busy).

    Every ``point_every_s`` seconds, ``on_point(name, point)`` is called
    with the last curve point (the columns of ``curve.csv``) of each point
    whose run is under way, as its worker has written it; with
    ``progress``, the bar shows their densities."""
    if until_density is None and until_time_s is None:
        raise ValueError("give until_density, until_time_s or both")
    if isinstance(point_every_s, bool) or not isinstance(point_every_s, (int, float)) or not point_every_s > 0:
        raise ValueError(f"point_every_s = {point_every_s!r}: must be a number of seconds > 0")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers = {workers!r}: must be a whole number >= 1")
    if not isinstance(from_last_step, bool):
        raise TypeError(f"from_last_step = {from_last_step!r}: must be True or False")
    if scheduler is not None and workers is not None:
        raise ValueError("workers and scheduler exclude each other: the scheduler's cluster has its workers")
    if len({p.name for p in points}) != len(points):
        raise ValueError("points: two points share a name, so they would share a folder")
    # Every point is checked in this process before any worker starts.
    for p in points:
        case = Case.from_dict(p.case)
        until_density, until_time_s = case._check_stop(until_density, until_time_s)
        case._check_densities("snapshot_densities", p.snapshot_densities)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"{out} is not a folder: give a folder for the sweep")
    for p in points:
        _check_folder(out / p.name, p, until_density, until_time_s)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise io.output_error(out, e) from e
    args = [(str(out), p, until_density, until_time_s, error_estimate, from_last_step) for p in points]
    rows: dict[str, dict[str, Any]] = {}
    bar = _progress(len(points)) if progress else None

    def done(row: dict[str, Any]) -> None:
        rows[row["name"]] = row
        write_table(out, [rows[p.name] for p in points if p.name in rows])
        if bar is not None:
            bar.set_postfix_str(f"{row['name']}: {row['status']}")
            bar.update(1)
        if on_row is not None:
            on_row(row)

    watching = bar is not None or on_point is not None
    stop = threading.Event()

    def watch() -> None:
        started = time.time()
        while not stop.wait(point_every_s):
            running = []
            for p in points:
                curve = out / p.name / "curve.csv"
                if p.name in rows or not _written_since(curve, started):
                    continue
                last = _last_point(curve)
                if last is None:
                    continue
                running.append(f"{p.name} rho {last['rel_density']:.4f}")
                if on_point is not None:
                    on_point(p.name, last)
            if bar is not None and running:
                bar.set_postfix_str("; ".join(running))

    watcher = threading.Thread(target=watch, daemon=True) if watching else None
    if watcher is not None:
        watcher.start()
    try:
        if scheduler is not None:
            _run_on_dask(scheduler, args, done)
        else:
            cores = os.cpu_count() or 1
            n = min(workers or cores, len(points))
            if n == 1:
                for a in args:
                    done(run_point(*a))
            else:
                threads = worker_threads(cores, n, sum(not _done_earlier(out / p.name) for p in points))
                group = _Workers(threads)
                with ThreadPoolExecutor(max_workers=n) as pool:
                    futures = [pool.submit(group.run, *a) for a in args]
                    try:
                        for f in as_completed(futures):
                            done(f.result())
                    except Terminated:
                        # This process got SIGTERM: so do the workers, which
                        # stop their runs as it does (summaries written,
                        # resumable); no worker starts after this.
                        group.stop()
                        raise
    finally:
        stop.set()
        if watcher is not None:
            watcher.join()
        if bar is not None:
            bar.close()
    return [rows[p.name] for p in points]


def worker_threads(cores: int, workers: int, to_run: int) -> int:
    """Solver threads of each of ``workers`` worker processes with
    ``to_run`` points left to run (the others finished in an earlier call)
    on ``cores`` cores: the cores shared among the workers that will run at
    once, at least one each. Fewer points than workers (a sweep resumed for
    its last long runs) get the idle cores; the results do not depend on
    the thread count."""
    return max(1, cores // max(1, min(workers, to_run)))


def _done_earlier(folder: Path) -> bool:
    """Whether ``folder`` holds a run that :func:`run_point` will not run
    again: finished, or failed (its summary says so)."""
    status = (_read_summary(folder) or {}).get("status")
    return status in FINISHED or status == "failed"


def _written_since(path: Path, since: float) -> bool:
    """Whether the file at ``path`` exists and was written after ``since``
    (a time.time() value)."""
    try:
        return path.stat().st_mtime >= since
    except OSError:
        return False


def _last_point(curve: Path) -> dict[str, float] | None:
    """The last complete row of a curve file being written (its header's
    columns, as numbers; empty cells as nan); None before the first."""
    try:
        with curve.open("rb") as f:
            header = f.readline().decode().strip().split(",")
            f.seek(0, os.SEEK_END)
            end = f.tell()
            f.seek(max(0, end - 8192))
            tail = f.read().decode(errors="replace")
    except OSError:
        return None
    lines = tail.split("\n")[:-1]  # the text after the last newline is not a whole row yet
    if not lines or lines[-1].strip().split(",") == header:
        return None
    values = lines[-1].strip().split(",")
    if len(values) != len(header):
        return None
    try:
        return {k: float(v) if v != "" else math.nan for k, v in zip(header, values, strict=True)}
    except ValueError:
        return None


def run_point(
    out_dir: str,
    point: Point,
    until_density: float | None,
    until_time_s: float | None,
    error_estimate: bool,
    from_last_step: bool = False,
) -> dict[str, Any]:
    """Runs one point into ``out_dir/point.name`` (in a worker): nothing if
    the folder holds a finished run, a resume if it holds an interrupted
    one (``from_last_step``: see :func:`tidens_rs.resume`), else the run
    afresh. Returns its row of the table."""
    folder = Path(out_dir) / point.name
    summary = _read_summary(folder)
    t0 = time.perf_counter()
    reason = ""
    status = None if summary is None else summary.get("status")
    started = (folder / "run.json").exists() and (folder / "checkpoint.bin").exists()
    try:
        if _done_earlier(folder):
            reason = (summary or {}).get("message") or ""  # done earlier
        elif started and status in (None, "interrupted"):
            every = Case.from_dict(point.case).solver.checkpoint_every
            resume(folder, checkpoint_every=every, from_last_step=from_last_step)
        else:
            Case.from_dict(point.case).run(
                until_density,
                until_time_s,
                out_dir=folder,
                snapshot_densities=point.snapshot_densities,
                error_estimate=error_estimate,
                overwrite=True,
            )
    except ConvergenceError as e:
        reason = str(e)
    return _summary_row(point, folder, reason, time.perf_counter() - t0)


def _summary_row(point: Point, folder: Path, reason: str, wall_seconds: float) -> dict[str, Any]:
    """The row of ``point`` from the summary in ``folder``; without one,
    status ``failed`` after ``wall_seconds``."""
    summary = _read_summary(folder)
    row = _point_row(point, folder, reason)
    if summary is None:
        row["status"] = "failed"
        row["wall_seconds"] = wall_seconds
        return row
    times = summary.get("times_to_density_s", {})
    errors = (summary.get("error_estimate") or {}).get("relative", {})
    model = summary.get("continuum_times_to_density_s", {})
    for m in MARK_DENSITIES:
        k = f"{m:g}"
        row[f"t_{k}_s"] = times.get(k)
        row[f"error_{k}"] = errors.get(k)
        row[f"continuum_t_{k}_s"] = model.get(k)
    for key in ("status", "final_density", "final_time_s", "steps", "wall_seconds"):
        row[key] = summary.get(key)
    solver = summary.get("solver") or {}
    for key in ("mesh_level", "tolerance", "element"):
        row[key] = solver.get(key)
    return row


def write_table(out_dir: Path, rows: Sequence[dict[str, Any]]) -> None:
    """Writes the rows to ``sweep.csv`` and, where pyarrow is installed,
    ``sweep.parquet`` in ``out_dir`` (each through a temporary file)."""

    def write_csv(tmp: Path) -> None:
        with tmp.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            w.writeheader()
            for r in rows:
                w.writerow({k: "" if r.get(k) is None else r[k] for k in COLUMNS})

    io.atomic_write(out_dir / TABLE_CSV, write_csv)
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return
    columns = {k: [r.get(k) for r in rows] for k in COLUMNS}
    table = pa.table(columns)
    io.atomic_write(out_dir / TABLE_PARQUET, lambda tmp: pq.write_table(table, tmp))


def read_table(out_dir: str | Path) -> list[dict[str, Any]]:
    """The rows of ``sweep.csv`` in ``out_dir``, numbers as floats (empty
    cells as None)."""
    with (Path(out_dir) / TABLE_CSV).open() as f:
        return [{k: _value(v) for k, v in r.items()} for r in csv.DictReader(f)]


def _value(text: str) -> Any:
    if text == "":
        return None
    try:
        return float(text)
    except ValueError:
        return text


def _check_folder(folder: Path, point: Point, until_density: float | None, until_time_s: float | None) -> None:
    """Refuses a point folder that holds a run of another case or stop (a
    restarted sweep must not take it for this point's)."""
    try:
        recorded = json.loads((folder / "run.json").read_text())
    except FileNotFoundError:
        return
    except (OSError, ValueError) as e:
        raise ValueError(f"{folder / 'run.json'}: not the record of a run ({e}); delete {folder} to run the point afresh") from e
    same_case = _without_interval(_plain(recorded.get("case"))) == _without_interval(_plain(point.case))
    args = recorded.get("run", {})
    same_stop = (args.get("until_density"), args.get("until_time_s")) == (until_density, until_time_s)
    if not (same_case and same_stop):
        what = "case" if not same_case else "stop (until_density, until_time_s)"
        raise FileExistsError(f"{folder} holds a run of another {what}: give another folder for the sweep, or delete {folder}")


def _without_interval(case: Any) -> Any:
    """A case's record without its checkpoint interval, which a resumed
    run may change (see :func:`tidens_rs.resume`)."""
    if isinstance(case, dict) and isinstance(case.get("solver"), dict):
        return {**case, "solver": {k: v for k, v in case["solver"].items() if k != "checkpoint_every"}}
    return case


def _plain(data: Any) -> Any:
    """``data`` as the run's record holds it (JSON, tuples as lists,
    non-finite numbers as the record writes them)."""
    return json.loads(json.dumps(io._json_safe(data)))


def _read_summary(folder: Path) -> dict[str, Any] | None:
    try:
        data = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _numbers(name: str, values: Sequence[float] | None, default: list[float]) -> list[float]:
    if values is None:
        return default
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise TypeError(f"{name} = {values!r}: must be a list of numbers")
    out = []
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise TypeError(f"{name}[{i}] = {v!r}: must be a real number")
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name}[{i}] = {v!r}: must be finite and > 0")
        out.append(float(v))
    return out


class _Workers:
    """Worker processes running points (``python -m tidens_rs.sweep``, each
    with ``threads`` solver threads: the workers share the machine's
    cores), so that the caller's script needs no ``__main__`` guard and a
    worker that dies takes no other point with it. :meth:`stop` sends
    SIGTERM to the workers running and starts no more; on Linux a worker
    also gets SIGTERM when this process dies
    (:func:`tidens_rs.signals.stop_with_parent`)."""

    def __init__(self, threads: int = 1) -> None:
        self.threads = threads
        self._lock = threading.Lock()
        self._running: set[subprocess.Popen[str]] = set()
        self._stopped = False

    def run(
        self,
        out_dir: str,
        point: Point,
        until_density: float | None,
        until_time_s: float | None,
        error_estimate: bool,
        from_last_step: bool,
    ) -> dict[str, Any]:
        """:func:`run_point` in a worker process of its own; its row."""
        job = {
            "out_dir": out_dir,
            "point": asdict(point),
            "until_density": until_density,
            "until_time_s": until_time_s,
            "error_estimate": error_estimate,
            "from_last_step": from_last_step,
            "parent_pid": os.getpid(),
        }
        env = dict(os.environ, RAYON_NUM_THREADS=str(self.threads))
        with self._lock:
            if self._stopped:
                return _point_row(point, Path(out_dir) / point.name, "not started: the sweep was terminated")
            worker = subprocess.Popen(
                [sys.executable, "-m", "tidens_rs.sweep"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                env=env,
            )
            self._running.add(worker)
        try:
            stdout, stderr = worker.communicate(json.dumps(io._json_safe(job)))
        finally:
            with self._lock:
                self._running.discard(worker)
        lines = stdout.strip().splitlines()
        if worker.returncode in (0, EXIT_TERMINATED) and lines:
            row: dict[str, Any] = json.loads(lines[-1])
            return row
        tail = " ".join(stderr.strip().splitlines()[-3:])
        row = _point_row(point, Path(out_dir) / point.name, f"worker exited with status {worker.returncode}: {tail}")
        row["status"] = "failed"
        return row

    def stop(self) -> None:
        """SIGTERM to the running workers; no worker starts after this."""
        with self._lock:
            self._stopped = True
            for worker in self._running:
                worker.terminate()


def _point_row(point: Point, folder: Path, reason: str) -> dict[str, Any]:
    """A table row holding what the point itself says (the rest None)."""
    row: dict[str, Any] = {c: None for c in COLUMNS}
    row.update(
        name=point.name,
        cell=point.cell,
        material=point.material,
        stress_mpa=point.stress_mpa,
        aspect_ratio=point.aspect_ratio,
        folder=str(folder),
        reason=reason,
    )
    return row


def _worker_main() -> None:
    """``python -m tidens_rs.sweep``: runs the point of the job read as JSON
    from standard input and writes its row as JSON to standard output."""
    job = json.loads(sys.stdin.read())
    fields = job["point"]
    point = Point(**{**fields, "snapshot_densities": tuple(fields.get("snapshot_densities", ()))})
    t0 = time.perf_counter()
    try:
        with sigterm_stops():
            stop_with_parent(job["parent_pid"])
            row = run_point(job["out_dir"], point, job["until_density"], job["until_time_s"], job["error_estimate"],
                            job["from_last_step"])
    except Terminated as e:
        # The run stopped as by Ctrl-C (its summary says "interrupted").
        row = _summary_row(point, Path(job["out_dir"]) / point.name, str(e), time.perf_counter() - t0)
        print(json.dumps(io._json_safe(row)))
        sys.exit(EXIT_TERMINATED)
    print(json.dumps(io._json_safe(row)))


def _run_on_dask(address: str, args: list[tuple[Any, ...]], done: Callable[[dict[str, Any]], None]) -> None:
    try:
        from dask.distributed import Client, as_completed as dask_completed
    except ImportError as e:
        raise ImportError("scheduler needs dask.distributed: pip install 'tidens[sweep]'") from e
    with Client(address) as client:  # type: ignore[no-untyped-call]
        futures = [client.submit(run_point, *a, pure=False) for a in args]
        for f in dask_completed(futures):  # type: ignore[no-untyped-call]
            done(f.result())


def _progress(total: int) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, unit="point", file=sys.stderr)


if __name__ == "__main__":
    _worker_main()
