"""Random dense packings of spheres and spheroids, and packing files.

:class:`Packing` (the native type) generates a random dense packing at a
target relative density rho0 (``Packing.generate``) or reads one from text
(``Packing.from_text``), for example a packing from a DEM code. This module
adds files and the packing's report: :func:`write` puts the box and the
boundary in a header comment, which :func:`read` takes back (a file without
one, a DEM export, needs ``lengths_mm`` and ``boundary``), and
:func:`coordination_number` counts contacts at a gap tolerance relative to
the particle size.

A periodic packing is a cell :class:`tidens_rs.Case` can press through
:func:`tidens_rs.cells.from_packing` (or :func:`tidens_rs.cells.random`),
once it is jammed: nothing but its contacts holds it.

Units: mm.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from . import _checks, io
from ._core import Packing

__all__ = ["COORDINATION_TOLERANCE", "Packing", "coordination_number", "mean_radius_mm", "read", "write"]

#: Default gap tolerance of a contact, as a fraction of the mean
#: volume-equivalent radius. In jammed packings (``Packing.generate(..., jam=True)``) touching
#: particles are apart by at most 1e-6 of it and the next neighbours mostly
#: by more than 1e-5 (32 spheres, 19 jammed seeds of 20: two have one or two
#: pairs between).
COORDINATION_TOLERANCE = 1e-5

_HEADER = re.compile(
    r"^#\s*tidens packing:\s*lengths_mm\s*=\s*(\S+)\s+(\S+)\s+(\S+)\s*;\s*boundary\s*=\s*(\w+)", re.MULTILINE
)


def mean_radius_mm(packing: Packing) -> float:
    """Number mean of the volume-equivalent radii (a^2 c)^(1/3) [mm]."""
    ac = packing.semi_axes_mm
    if len(ac) == 0:
        return 0.0
    return float(np.mean(np.cbrt(ac[:, 0] ** 2 * ac[:, 1])))


def coordination_number(
    packing: Packing, relative_tolerance: float = COORDINATION_TOLERANCE, without_rattlers: bool = False
) -> float:
    """Mean contacts per particle, a contact being a surface gap of at most
    ``relative_tolerance`` times the mean volume-equivalent radius (die
    walls not counted). ``without_rattlers``: over the particles held by at
    least 4 contacts, removed round after round (a die wall counts)."""
    tol = _checks.real("relative_tolerance", relative_tolerance)
    if tol < 0.0:
        raise ValueError(f"relative_tolerance = {relative_tolerance!r}: must be >= 0")
    if _checks.flag("without_rattlers", without_rattlers):
        return packing.backbone_coordination_number(tol * mean_radius_mm(packing))
    return packing.coordination_number(tol * mean_radius_mm(packing))


def write(packing: Packing, path: str | Path) -> Path:
    """Writes ``packing`` to ``path`` (through a temporary file), its box and
    boundary in a header comment that :func:`read` takes back."""
    p = Path(path)
    lx, ly, lz = packing.lengths_mm
    header = (
        f"# tidens packing: lengths_mm = {lx!r} {ly!r} {lz!r}; boundary = {packing.boundary}\n"
        f"# {len(packing)} particles, relative density {packing.rel_density!r}\n"
        "# x y z a c ax ay az [mm]: centre, semi-axes across and along the axis, unit axis\n"
    )
    return io.atomic_write(p, lambda tmp: tmp.write_text(header + packing.to_text()))


def read(
    path: str | Path,
    lengths_mm: tuple[float, float, float] | None = None,
    boundary: str | None = None,
) -> Packing:
    """Reads a packing file: one particle per line, ``x y z a [c [ax ay
    az]]`` (mm; ``c`` defaults to ``a``, the axis to z; ``#`` starts a
    comment). The box and the boundary come from the header :func:`write`
    puts there, or from ``lengths_mm`` and ``boundary``, which override it.
    A ValueError names the file, and the line and field at fault."""
    p = Path(path)
    try:
        text = p.read_text()
    except UnicodeDecodeError as e:
        raise ValueError(f"{p}: not a text file of particles ({e.reason} at byte {e.start})") from e
    header = _HEADER.search(text)
    if lengths_mm is None:
        if header is None:
            raise ValueError(f"{p}: no 'tidens packing' header: give lengths_mm (Lx, Ly, Lz) [mm] and boundary")
        lengths_mm = (float(header[1]), float(header[2]), float(header[3]))
    if boundary is None:
        boundary = header[4] if header is not None else "periodic"
    lengths = _checks.reals("lengths_mm", list(lengths_mm) if isinstance(lengths_mm, tuple) else lengths_mm, "mm")
    if len(lengths) != 3:
        raise ValueError(f"lengths_mm = {lengths_mm!r}: must be three box side lengths (Lx, Ly, Lz) [mm]")
    try:
        return Packing.from_text(text, (lengths[0], lengths[1], lengths[2]), boundary)
    except ValueError as e:
        raise ValueError(f"{p}: {e}") from e
