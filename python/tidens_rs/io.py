"""Files a run writes: the densification curve as CSV (streamed while the run
goes, so nothing computed is lost), the summary as JSON, and the fields as
VTU (through meshio) with a ParaView collection (.pvd) tying them in time."""

from __future__ import annotations

import contextlib
import csv
import fnmatch
import json
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import IO, Any

import meshio
import numpy as np

from .snapshot import Snapshot

CURVE_COLUMNS = (
    "time_s",
    "rel_density",
    "piston_displacement_mm",
    "applied_stress_mpa",
    "cell_stress_mpa",
    "step",
    "newton_iterations",
    "newton_total",
    "dt_s",
    "max_strain_increment",
    "particle_volume_mm3",
    "time_error_s",
    "contacts",
    "particle_contacts",
    "max_penetration_mm",
    "max_depth_mm",
    "coordination_number",
)




def curve_columns(periodic: bool) -> tuple[str, ...]:
    """The columns of a cell's curve file: the coordination number only for
    periodic cells of whole particles (a cell of octants has none)."""
    return CURVE_COLUMNS if periodic else tuple(c for c in CURVE_COLUMNS if c != "coordination_number")


# The lock file a writing process holds in its output folder (see FolderLock).
LOCK_FILE = ".tidens.lock"

# What a run writes into its output folder (``--overwrite`` clears these and
# nothing else); temporary files of interrupted atomic writes end in ".part".
OUTPUT_PATTERNS = (
    "curve.csv",
    "companion_curve.csv",
    "summary.json",
    "fields_*.vtu",
    "fields.pvd",
    "density.png",
    "run.json",
    "checkpoint.bin",
    "checkpoint_stop.bin",
    "*.part",
)

# Files that may lie in a folder that is otherwise new: the lock file stays
# after its writer ends (deleting it would race with the next writer).
_IGNORED = (LOCK_FILE,)


# The columns that count things (written as integers).
COUNT_COLUMNS = frozenset(("step", "newton_iterations", "newton_total", "contacts", "particle_contacts"))


class OutputError(OSError):
    """A file of the run could not be written: ``filename`` is its path.
    What was written before it is kept; the run's result, if any, is in the
    ``result`` attribute."""

    result: Any = None

    def __str__(self) -> str:
        return f"cannot write {self.filename}: {self.strerror}"


def output_error(path: Path, e: OSError) -> OutputError:
    """``e`` as an OutputError naming ``path``."""
    return OutputError(e.errno or 0, e.strerror or str(e), str(path))


def atomic_write(path: Path, write: Callable[[Path], object]) -> Path:
    """Writes ``path`` through ``write(tmp)`` into a temporary file beside it,
    renamed over ``path`` only once complete: a stop or a full disk never
    leaves a truncated file under the final name. Raises OutputError."""
    tmp = path.with_name(path.name + ".part")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write(tmp)
        os.replace(tmp, path)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        raise output_error(path, e) from e
    return path


def check_output_dir(path: Path, overwrite: bool) -> None:
    """Checks that a run may write into ``path`` (without touching it): a
    folder that does not exist yet or holds nothing; with ``overwrite``, one
    that holds nothing but an earlier run's outputs (:data:`OUTPUT_PATTERNS`).
    Raises FileExistsError saying what is in the way, NotADirectoryError
    when ``path`` or a folder above it is a file or a broken link."""
    _check_folder_path(path)
    if not path.exists():
        return
    try:
        names = sorted(p.name for p in path.iterdir() if p.name not in _IGNORED)
    except OSError as e:
        raise output_error(path, e) from e
    if overwrite:
        names = [n for n in names if not any(fnmatch.fnmatch(n, pattern) for pattern in OUTPUT_PATTERNS)]
    if names:
        shown = ", ".join(names[:5]) + (", ..." if len(names) > 5 else "")
        what = "files that are not outputs of a run" if overwrite else "files"
        raise FileExistsError(
            f"{path} holds {what} ({shown}): give an empty or new folder"
            + ("" if overwrite else ", or overwrite=True to replace an earlier run's outputs")
        )


def _check_folder_path(path: Path) -> None:
    """NotADirectoryError, in one line, when ``path`` cannot be a folder: it
    is a file, a broken symbolic link, or a folder above it is a file."""
    if path.is_symlink() and not path.exists():
        raise NotADirectoryError(f"{path} is a symbolic link to {os.readlink(path)}, which does not exist: give a folder")
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(f"{path} is a file, not a folder: give a folder for the outputs")
    for parent in path.absolute().parents:
        if parent.is_symlink() and not parent.exists():
            raise NotADirectoryError(f"{parent} (in {path}) is a symbolic link to {os.readlink(parent)}, which does not exist")
        if parent.exists():
            if not parent.is_dir():
                raise NotADirectoryError(f"{parent} (in {path}) is a file, not a folder")
            return


class FolderBusyError(FileExistsError):
    """Another process is writing into the output folder (it holds its lock)."""


def locked(folder: Path | None) -> contextlib.AbstractContextManager[object]:
    """The :class:`FolderLock` of ``folder``, or nothing when there is none."""
    return contextlib.nullcontext() if folder is None else FolderLock(folder)


class FolderLock:
    """An exclusive lock on an output folder, held by the process that
    writes into it from the check of the folder to the last file written.

    Two runs started together into one folder would both find it empty and
    interleave their rows; the lock (``flock`` on ``DIR/.tidens.lock``,
    released by the kernel when the process ends, however it ends) lets
    only one of them in. The second raises :class:`FolderBusyError` naming
    the holder's process id. The lock is advisory: it keeps out other
    tidens runs, resumes and sweeps, not other programs. Creates the folder
    (and those above it) when it does not exist. A context manager."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self._fd: int | None = None
        self._created = False

    def acquire(self) -> FolderLock:
        _check_folder_path(self.folder)
        path = self.folder / LOCK_FILE
        self._created = not self.folder.exists()
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise output_error(path, e) from e
        if sys.platform != "win32":
            import fcntl

            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
                os.close(fd)
                raise FolderBusyError(
                    f"{self.folder} is being written by another tidens process (pid {holder}): "
                    "wait for it to end, or give another folder"
                ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self._fd = fd
        return self

    def release(self) -> None:
        """Releases the lock; a folder this lock created and nothing was
        written into (bad input found after the lock) is removed again."""
        if self._fd is None:
            return
        if self._created:
            try:
                if [p.name for p in self.folder.iterdir()] == [LOCK_FILE]:
                    (self.folder / LOCK_FILE).unlink()
                    self.folder.rmdir()
            except OSError:
                pass  # best effort: the folder stays, with the lock file only
        os.close(self._fd)  # releases the flock
        self._fd = None

    def __enter__(self) -> FolderLock:
        return self.acquire()

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None) -> None:
        self.release()


def clear_outputs(path: Path) -> None:
    """Deletes the outputs of an earlier run in folder ``path`` (and nothing else)."""
    try:
        for pattern in OUTPUT_PATTERNS:
            for old in path.glob(pattern):
                old.unlink()
    except OSError as e:
        raise output_error(path, e) from e


class CurveWriter:
    """Appends curve points to a CSV file (header row first), flushing each
    row so the file is complete up to the last converged step at any time.
    Raises OutputError naming the file when it cannot be written."""

    def __init__(self, path: Path, columns: tuple[str, ...] = CURVE_COLUMNS) -> None:
        self.path = path
        self.columns = columns
        self.rows = 0
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._file: IO[str] = path.open("w", newline="")
            self._csv = csv.writer(self._file)
            self._csv.writerow(columns)
            self._file.flush()
        except OSError as e:
            raise output_error(path, e) from e

    def write(self, point: dict[str, float]) -> None:
        try:
            self._csv.writerow([_format(point[k], k in COUNT_COLUMNS) for k in self.columns])
            self._file.flush()
        except OSError as e:
            raise output_error(self.path, e) from e
        self.rows += 1

    def close(self) -> None:
        try:
            self._file.close()
        except OSError as e:
            raise output_error(self.path, e) from e

    def __enter__(self) -> CurveWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _format(value: float, count: bool) -> str:
    # Counts are integers whether they come as ints (a step's point) or as
    # floats (a column of the curve's arrays).
    if count or isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def read_curve(path: Path) -> dict[str, np.ndarray]:
    """Reads a curve CSV back into numpy arrays keyed by column: its
    complete rows (a run still writing it may have begun the next)."""
    text = path.read_text()
    lines = text.split("\n")[:-1] if "\n" in text else [text]
    data = np.genfromtxt(lines, delimiter=",", names=True)
    return {name: np.atleast_1d(data[name]) for name in data.dtype.names or ()}


def write_curve(path: Path, curve: dict[str, np.ndarray], columns: tuple[str, ...] = CURVE_COLUMNS) -> None:
    """Writes a whole curve at once."""
    with CurveWriter(path, columns) as w:
        for k in range(len(curve["time_s"])):
            w.write({c: curve[c][k] for c in columns})


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, (np.floating, float)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def write_summary(path: Path, summary: dict[str, Any]) -> None:
    text = json.dumps(_json_safe(summary), indent=2) + "\n"
    atomic_write(path, lambda tmp: tmp.write_text(text))


def write_json(path: Path, data: dict[str, Any]) -> None:
    """``data`` as indented JSON, written atomically."""
    text = json.dumps(_json_safe(data), indent=2) + "\n"
    atomic_write(path, lambda tmp: tmp.write_text(text))


def read_pvd(path: Path) -> list[tuple[float, str]]:
    """The (time, file name) entries of a ParaView collection written by
    :func:`write_pvd`; none if there is no such file."""
    if not path.exists():
        return []
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    return [(float(d.attrib["timestep"]), d.attrib["file"]) for d in root.iter("DataSet")]


def write_vtu(path: Path, snapshot: Snapshot) -> Path:
    """Writes one snapshot: hexahedra in the current configuration with
    displacement, contact force (of the rigid planes) and particle-particle
    contact pressure at the nodes; von Mises stress, mean stress, equivalent
    plastic strain and the particle index per element."""
    f = snapshot.fields
    mesh = meshio.Mesh(
        points=f["points"],
        cells=[(str(f["cell_type"]), f["cells"])],
        point_data={
            "displacement_mm": f["displacement"],
            "contact_force_N": f["contact_force"],
            "contact_pressure_mpa": f["contact_pressure"],
        },
        cell_data={
            "von_mises_mpa": [f["von_mises"]],
            "mean_stress_mpa": [f["mean_stress"]],
            "eqps": [f["eqps"]],
            "particle": [f["particle"]],
        },
    )
    return atomic_write(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))


def write_pvd(path: Path, entries: list[tuple[float, Path]]) -> Path:
    """A ParaView collection listing VTU files with their times [s], in time
    order; of files at the same time (a snapshot taken at the last step and
    the final one) only the later in ``entries``, so that ParaView shows no
    frame twice."""
    at: dict[float, Path] = {}
    for t, p in entries:
        at[t] = p
    rows = "\n".join(f'    <DataSet timestep="{t!r}" part="0" file="{p.name}"/>' for t, p in sorted(at.items()))
    text = (
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        f"{rows}\n  </Collection>\n</VTKFile>\n"
    )
    return atomic_write(path, lambda tmp: tmp.write_text(text))
