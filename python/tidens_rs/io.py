"""Files a run writes: the densification curve as CSV (streamed while the run
goes, so nothing computed is lost), the summary as JSON, and the fields as
VTU (through meshio) with a ParaView collection (.pvd) tying them in time."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
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
)


class CurveWriter:
    """Appends curve points to a CSV file (header row first), flushing each
    row so the file is complete up to the last converged step at any time."""

    def __init__(self, path: Path) -> None:
        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file: IO[str] = path.open("w", newline="")
        self._csv = csv.writer(self._file)
        self._csv.writerow(CURVE_COLUMNS)

    def write(self, point: dict[str, float]) -> None:
        self._csv.writerow([_format(point[k]) for k in CURVE_COLUMNS])
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> CurveWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _format(value: float) -> str:
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def read_curve(path: Path) -> dict[str, np.ndarray]:
    """Reads a curve CSV back into numpy arrays keyed by column."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: np.atleast_1d(data[name]) for name in data.dtype.names or ()}


def write_curve(path: Path, curve: dict[str, np.ndarray]) -> None:
    """Writes a whole curve at once."""
    with CurveWriter(path) as w:
        for k in range(len(curve["time_s"])):
            w.write({c: curve[c][k] for c in CURVE_COLUMNS})


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
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(_json_safe(summary), indent=2) + "\n")


def write_vtu(path: Path, snapshot: Snapshot) -> Path:
    """Writes one snapshot: hexahedra in the current configuration with
    displacement, contact force (of the rigid planes) and particle-particle
    contact pressure at the nodes; von Mises stress, mean stress, equivalent
    plastic strain and the particle index per element."""
    path.parent.mkdir(parents=True, exist_ok=True)
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
    meshio.write(path, mesh, file_format="vtu")
    return path


def write_pvd(path: Path, entries: list[tuple[float, Path]]) -> Path:
    """A ParaView collection listing VTU files with their times [s]."""
    rows = "\n".join(
        f'    <DataSet timestep="{t!r}" part="0" file="{p.name}"/>' for t, p in entries
    )
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        f"{rows}\n  </Collection>\n</VTKFile>\n"
    )
    return path
