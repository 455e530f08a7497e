"""Cells: periodic packings reduced by their mirror symmetries to a box
[0,Lx]x[0,Ly]x[0,Lz] holding particle octants at its corners (DESIGN.md
section 2).

The creep law has no length scale, so the densification curve does not
depend on the particle radius; it only sets the units of the fields.
"""

from __future__ import annotations

from ._core import Cell

DEFAULT_RADIUS_MM = 0.05
CELL_NAMES = ("sc",)


def sc(radius_mm: float = DEFAULT_RADIUS_MM, aspect_ratio: float = 1.0) -> Cell:
    """Simple cubic: one spheroid octant (semi-axes a, a, c = aspect_ratio a)
    in an a x a x c box; rho0 = pi/6 for any aspect ratio."""
    return Cell.sc(radius_mm, aspect_ratio)


def by_name(name: str, radius_mm: float = DEFAULT_RADIUS_MM, aspect_ratio: float = 1.0) -> Cell:
    """The cell called ``name`` (one of :data:`CELL_NAMES`)."""
    if name == "sc":
        return sc(radius_mm, aspect_ratio)
    raise ValueError(f"cell = {name!r}: must be one of {', '.join(CELL_NAMES)}")


__all__ = ["CELL_NAMES", "DEFAULT_RADIUS_MM", "Cell", "by_name", "sc"]
