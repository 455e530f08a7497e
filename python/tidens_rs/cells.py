"""Cells: periodic packings reduced by their mirror symmetries to a box
[0,Lx]x[0,Ly]x[0,Lz] holding particle octants at its corners (docs/model.md
section 2).

The four packings of the paper are presets (:func:`sc`, :func:`bcc`,
:func:`fcc`, :func:`sc2`); any other arrangement of octants is a
:func:`custom` cell, in code or from a cell file (:func:`from_file`).

Periodic cells hold whole particles in a box periodic along x, y and z
(:func:`periodic`): a random packing (:func:`random`, :func:`from_packing`)
or a lattice of whole particles (:func:`as_periodic` of a preset). Nothing
bounds them: the box's height shortens as the piston moves, its width and
depth stay (the die's uniaxial strain), and particles touch the periodic
images of the others across the box faces.

The creep law has no length scale, so the densification curve does not
depend on the particle radius; it only sets the units of the fields.

Cell files
----------
JSON or TOML (by the file's suffix, ``.json`` or ``.toml``), one cell::

    name = "my-cell"                 # optional, default: the file name's stem
    lengths_mm = [0.1, 0.1, 0.1]     # box edges Lx, Ly, Lz [mm]; z is the load

    [[octants]]                      # one table per particle piece
    corner = [false, false, false]   # or "000": the box corner at the centre,
                                     # true / "1" = the high end L_i of that axis
    a = 0.05                         # semi-axis along x and y [mm]
    c = 0.05                         # semi-axis along z [mm]

    [[octants]]
    corner = "111"
    a = 0.05
    c = 0.05

A periodic cell lists whole particles instead of octants (``centre`` in the
box [mm], semi-axes ``a`` across and ``c`` along ``axis``)::

    name = "random-16"
    lengths_mm = [0.2, 0.2, 0.2]
    periodic = true

    [[particles]]
    centre = [0.05, 0.05, 0.05]
    a = 0.05
    c = 0.05
    axis = [0.0, 0.0, 1.0]

or the same as JSON: ``{"name": ..., "lengths_mm": [...], "octants": [{"corner":
[false, false, false], "a": 0.05, "c": 0.05}, ...]}``. Any other key is an
error (a misspelt key would otherwise be ignored silently). Ranges, checked by
the core: lengths and semi-axes in [1e-6, 1e3] mm, c/a in [0.2, 5], each
octant inside the box (a <= Lx, Ly; c <= Lz). Errors name the field, e.g.
``octants[1].a``. Two octants at one corner, or particles that overlap, are
refused naming both (``octants[0] and octants[1] are both at corner 000``,
``octants[0] and octants[2] overlap``, ``particles[1] and particles[4]
overlap``). Octants may touch, to a relative 1e-6 of the spheroid's level
function (about 5e-7 of a distance), so lengths of a
cell whose particles touch need seven significant digits (the bcc box edge
2R/sqrt(3) as 0.05773503 for R = 0.05, not 0.057735), or round them up;
whole particles of a periodic cell to 1e-6 of the smaller radius. Reading TOML needs Python >= 3.11
(``tomllib``); on 3.10 use JSON.
"""

from __future__ import annotations

import json
import math
import numbers
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import _checks
from ._core import DEFAULT_SIZE_RATIO, Cell, Packing

DEFAULT_RADIUS_MM = 0.05
CELL_NAMES = ("sc", "bcc", "fcc", "sc2")


class CellFileError(ValueError):
    """A cell file that cannot be read or does not describe a cell. The
    message names the file and the field as the file writes it
    (``octants[1].a``, ``particles``), never a command-line option."""


Corner = tuple[bool, bool, bool]
Octant = tuple[Corner, float, float]
"""One particle piece: (corner, a_mm, c_mm), see :func:`custom`."""

_FILE_KEYS = ("name", "lengths_mm", "octants", "periodic", "particles")
_OCTANT_KEYS = ("corner", "a", "c")
_PARTICLE_KEYS = ("centre", "a", "c", "axis")

Particle = tuple[tuple[float, float, float], float, float, tuple[float, float, float]]
"""One whole particle of a periodic cell: (centre_mm, a_mm, c_mm, axis), see :func:`periodic`."""


def sc(radius_mm: float = DEFAULT_RADIUS_MM, aspect_ratio: float = 1.0) -> Cell:
    """Simple cubic: one spheroid octant (semi-axes a, a, c = aspect_ratio a)
    in an a x a x c box; rho0 = pi/6 for any aspect ratio."""
    return Cell.sc(*_sizes(radius_mm=radius_mm, aspect_ratio=aspect_ratio))


def bcc(radius_mm: float = DEFAULT_RADIUS_MM, aspect_ratio: float = 1.0) -> Cell:
    """Body-centred cubic: box s x s x (aspect_ratio s), s = 2R/sqrt(3), with
    octants at (0,0,0) and (s,s,s) touching along the body diagonal;
    rho0 = pi sqrt(3)/8 = 0.6802."""
    return Cell.bcc(*_sizes(radius_mm=radius_mm, aspect_ratio=aspect_ratio))


def fcc(radius_mm: float = DEFAULT_RADIUS_MM, aspect_ratio: float = 1.0) -> Cell:
    """Face-centred cubic: box s x s x (aspect_ratio s), s = sqrt(2) R, with
    octants at (0,0,0), (s,s,0), (s,0,s), (0,s,s) touching along the face
    diagonals; rho0 = pi/(3 sqrt(2)) = 0.7405."""
    return Cell.fcc(*_sizes(radius_mm=radius_mm, aspect_ratio=aspect_ratio))


def sc2(
    radius_mm: float = DEFAULT_RADIUS_MM,
    size_ratio: float = DEFAULT_SIZE_RATIO,
    aspect_ratio: float = 1.0,
) -> Cell:
    """Two-size simple cubic (rock salt): large particles of radius R =
    ``radius_mm`` and small ones of R/r, r = ``size_ratio`` in
    [1, 1 + sqrt(2) = 2.414] (default the paper's 1.566), alternating over the
    eight corners of a box of edge R + R/r; rho0 = (2 pi/3)(1 + r^3)/(1 + r)^3
    = 0.60002 at r = 1.566. Above 1 + sqrt(2) the large particles would overlap
    across the face diagonals, so such a ratio is a ValueError."""
    return Cell.sc2(*_sizes(radius_mm=radius_mm, size_ratio=size_ratio, aspect_ratio=aspect_ratio))


def _sizes(**sizes: Any) -> list[float]:
    """The arguments' values, in order, each a finite real number
    (TypeError or ValueError naming it otherwise; the core checks ranges)."""
    return [_checks.real(name, value) for name, value in sizes.items()]


def custom(name: str, lengths_mm: Sequence[float], octants: Sequence[Sequence[Any]]) -> Cell:
    """A cell from its box and particle pieces.

    ``lengths_mm`` = (Lx, Ly, Lz) [mm], z the pressing direction. Each octant
    is ``(corner, a, c)``: ``corner`` says at which box corner the spheroid's
    centre sits, three booleans (True = the high end L_i of that axis) or a
    string of three 0/1 digits ("011" = (0, Ly, Lz)); ``a`` and ``c`` [mm] are
    its semi-axes along x, y and along z. Raises ValueError naming the bad
    field (e.g. ``octants[1].corner``), two octants at one corner
    (``octants[0] and octants[1] are both at corner 000``) or two that
    overlap (``octants[0] and octants[2] overlap``); touching is allowed.
    """
    if not isinstance(name, str):
        raise ValueError(f"name = {name!r}: must be a string")
    lengths = _numbers("lengths_mm", lengths_mm, 3, "three box edge lengths Lx, Ly, Lz [mm]")
    pieces: list[Octant] = []
    for k, (corner, a, c) in enumerate(_tuples("octants", octants, ("corner", "a", "c"))):
        pieces.append(
            (
                _corner(f"octants[{k}].corner", corner),
                _number(f"octants[{k}].a", a),
                _number(f"octants[{k}].c", c),
            )
        )
    return Cell(name, (lengths[0], lengths[1], lengths[2]), pieces)


def periodic(particles: Sequence[Sequence[Any]], lengths_mm: Sequence[float], name: str = "periodic") -> Cell:
    """A periodic cell of whole particles (see the module docstring).

    ``lengths_mm`` = (Lx, Ly, Lz) [mm], z the pressing direction. Each
    particle is ``(centre, a, c, axis)``: its centre in the box [0, L) [mm],
    its semi-axes [mm] (``a`` across, ``c`` along ``axis``, c/a in [0.2, 5])
    and its symmetry axis (any non-zero vector). Particles may reach across
    the box faces. Raises ValueError naming the bad field (e.g.
    ``particles[3].centre[0]``) or the particles that overlap (one another,
    or an image: ``particles[0] and particles[2] overlap by ... mm``; by
    more than 1e-6 of the smaller radius, touching is allowed). Periodic
    cells are meshed with hex8 elements.
    """
    if not isinstance(name, str):
        raise ValueError(f"name = {name!r}: must be a string")
    lengths = _numbers("lengths_mm", lengths_mm, 3, "three box edge lengths Lx, Ly, Lz [mm]")
    pieces: list[Particle] = []
    for k, (centre, a, c, axis) in enumerate(_tuples("particles", particles, ("centre", "a", "c", "axis"))):
        x = _numbers(f"particles[{k}].centre", centre, 3, "the centre (x, y, z) [mm]")
        n = _numbers(f"particles[{k}].axis", axis, 3, "the symmetry axis (x, y, z)")
        pieces.append(
            ((x[0], x[1], x[2]), _number(f"particles[{k}].a", a), _number(f"particles[{k}].c", c), (n[0], n[1], n[2]))
        )
    return Cell.periodic(name, (lengths[0], lengths[1], lengths[2]), pieces)


def _wrap(x: float, length: float) -> float:
    """x moved by whole periods into [0, length)."""
    w = x % length
    return 0.0 if w >= length else w


def from_packing(packing: Packing, name: str = "random") -> Cell:
    """The periodic cell of a packing (``Packing.generate`` or a packing
    file, see :mod:`tidens_rs.packing`) whose boundary is periodic; a die
    packing (walls at z = 0 and Lz) is refused: the solver presses periodic
    cells only."""
    if not isinstance(packing, Packing):
        raise TypeError(f"packing = {packing!r}: must be a Packing, not {type(packing).__name__}")
    if packing.boundary != "periodic":
        raise ValueError(
            f"packing boundary = {packing.boundary!r}: must be 'periodic' (the solver presses cells periodic "
            "along x, y and z; generate the packing with boundary='periodic')"
        )
    centres = packing.centres_mm
    lengths = packing.lengths_mm
    wrapped = [[_wrap(float(x), lengths[i]) for i, x in enumerate(c)] for c in centres]
    parts = [
        (tuple(c), float(ac[0]), float(ac[1]), tuple(float(v) for v in ax))
        for c, ac, ax in zip(wrapped, packing.semi_axes_mm, packing.axes)
    ]
    return periodic(parts, lengths, name)


def random(
    particles: int,
    *,
    seed: int = 0,
    rho0: float | None = None,
    radius_mm: float = DEFAULT_RADIUS_MM,
    aspect_ratio: float = 1.0,
    size_ratio: float | None = None,
    small_fraction: float = 0.5,
    progress: Callable[[dict[str, Any]], object] | None = None,
) -> Cell:
    """A random jammed packing of ``particles`` spheres (or spheroids of
    ``aspect_ratio`` c/a, each along a random axis) in a cube periodic along
    x, y and z, as a periodic cell named ``random``: the particles grow
    toward ``rho0`` and stop where they first jam (None: as far as they go,
    the jammed density, about 0.60-0.65 for 32 or more spheres of one size;
    small boxes spread more and can order). A packing that reaches
    ``rho0`` unjammed holds no load (``Case`` refuses it). ``radius_mm`` is
    the mean volume-equivalent radius; ``size_ratio`` (with
    ``small_fraction``, the small particles' share of the number) makes it
    bimodal. The same arguments give the same packing. See
    ``Packing.generate`` for the ranges (ValueError naming the argument),
    for ``progress`` (called a few times a second with how far the
    packing got) and for stopping it (Ctrl-C, SIGTERM)."""
    _sizes(radius_mm=radius_mm, aspect_ratio=aspect_ratio, small_fraction=small_fraction)
    if isinstance(particles, int) and not isinstance(particles, bool) and particles == 1:
        raise ValueError(
            "particles = 1: must be in [2, 10000] (one particle in a periodic box touches only its own images, "
            "and jams only where it fills the box's width)"
        )
    pack = Packing.generate(
        particles,
        rho0=0.74 if rho0 is None else rho0,
        jam=True,
        mean_radius_mm=radius_mm,
        aspect_ratio=aspect_ratio,
        size_ratio=size_ratio,
        small_fraction=small_fraction,
        boundary="periodic",
        seed=seed,
        progress=progress,
    )
    return from_packing(pack, "random")


def as_periodic(cell: Cell) -> Cell:
    """The lattice of a cell of octants as whole particles in a periodic
    box: the cell mirrored about its low faces, twice its size along each
    axis, each octant a whole particle at its corner (the sc cell: one
    sphere in a cube of edge 2R; bcc two, fcc four, sc2 eight)."""
    if not isinstance(cell, Cell):
        raise TypeError(f"cell = {cell!r}: must be a Cell, not {type(cell).__name__}")
    if cell.is_periodic:
        return cell
    lx, ly, lz = cell.lengths_mm
    parts = [
        ((lx if hx else 0.0, ly if hy else 0.0, lz if hz else 0.0), a, c, (0.0, 0.0, 1.0))
        for (hx, hy, hz), a, c in cell.octants
    ]
    return periodic(parts, (2 * lx, 2 * ly, 2 * lz), cell.name)


def from_dict(data: Mapping[str, Any], default_name: str = "custom") -> Cell:
    """A cell from the parsed content of a cell file (see the module docstring)."""
    if not isinstance(data, Mapping):
        raise ValueError(f"a cell must be a table (JSON object) with keys {', '.join(_FILE_KEYS)}")
    _no_unknown_keys("", data, _FILE_KEYS)
    if data.get("periodic", False) is not False:
        if data["periodic"] is not True:
            raise ValueError(f"periodic = {data['periodic']!r}: must be true or false")
        return _periodic_from_dict(data, default_name)
    if "particles" in data:
        raise ValueError("particles: a cell of whole particles needs periodic = true (otherwise it lists octants)")
    pieces = [tuple(o[key] for key in _OCTANT_KEYS) for o in _tables(data, "octants", _OCTANT_KEYS)]
    return custom(data.get("name", default_name), data["lengths_mm"], pieces)


def _tables(data: Mapping[str, Any], list_key: str, keys: tuple[str, ...]) -> list[Mapping[str, Any]]:
    """``data[list_key]``, checked: a non-empty list of tables, each with
    exactly ``keys`` (``lengths_mm`` must be there too)."""
    for key in ("lengths_mm", list_key):
        if key not in data:
            raise ValueError(f"{key}: missing")
    items = data[list_key]
    what = f"tables with keys {', '.join(keys)}"
    if not isinstance(items, list) or not items:
        raise ValueError(f"{list_key} = {items!r}: must be a non-empty list of {what}")
    for k, item in enumerate(items):
        where = f"{list_key}[{k}]"
        if not isinstance(item, Mapping):
            raise ValueError(f"{where} = {item!r}: must be a table with keys {', '.join(keys)}")
        _no_unknown_keys(where + ".", item, keys)
        missing = [key for key in keys if key not in item]
        if missing:
            raise ValueError(f"{where}.{missing[0]}: missing")
    return items


def from_file(path: str | Path) -> Cell:
    """Reads a cell file, JSON (``.json``) or TOML (``.toml``); the schema is
    in the module docstring. Raises ValueError naming the file and the bad
    field as the file writes it (:class:`CellFileError`)."""
    p = Path(path)
    suffix = p.suffix.lower()
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise CellFileError(f"cell file {p}: cannot be read ({e.strerror or e})") from e
    except UnicodeDecodeError as e:
        raise CellFileError(f"cell file {p}: not a text file (byte {e.start} is not UTF-8): a cell file is JSON or TOML text") from e
    data: Any
    if suffix == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            raise CellFileError(f"cell file {p}: not valid JSON: {e}") from e
    elif suffix == ".toml":
        if sys.version_info < (3, 11):
            raise CellFileError(
                f"cell file {p}: reading TOML needs Python >= 3.11 (tomllib); "
                "this is Python 3.10: write the cell as JSON instead"
            )
        import tomllib

        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise CellFileError(f"cell file {p}: not valid TOML: {e}") from e
    else:
        raise CellFileError(f"cell file {p}: unknown suffix {p.suffix!r}: must be .json or .toml")
    try:
        return from_dict(data, default_name=p.stem)
    except ValueError as e:
        raise CellFileError(f"cell file {p}: {e}") from e


def _periodic_from_dict(data: Mapping[str, Any], default_name: str) -> Cell:
    if "octants" in data:
        raise ValueError("octants: a periodic cell lists particles, not octants")
    parts = [tuple(p[key] for key in _PARTICLE_KEYS) for p in _tables(data, "particles", _PARTICLE_KEYS)]
    return periodic(parts, data["lengths_mm"], data.get("name", default_name))


def to_packing(cell: Cell) -> Packing:
    """The particles of a periodic cell as a :class:`Packing` (for its
    contacts and coordination number)."""
    if not cell.is_periodic:
        raise ValueError(f"cell {cell.name!r}: a cell of octants, not whole particles (see as_periodic)")
    lines = [
        " ".join(repr(float(v)) for v in (*centre, a, c, *axis)) for centre, a, c, axis in cell.particles
    ]
    return Packing.from_text("\n".join(lines) + "\n", cell.lengths_mm, "periodic")


def to_dict(cell: Cell) -> dict[str, Any]:
    """The cell in the cell-file schema (``from_dict(to_dict(c))`` rebuilds it)."""
    if cell.is_periodic:
        return {
            "name": cell.name,
            "lengths_mm": list(cell.lengths_mm),
            "periodic": True,
            "particles": [
                {"centre": list(centre), "a": a, "c": c, "axis": list(axis)} for centre, a, c, axis in cell.particles
            ],
        }
    return {
        "name": cell.name,
        "lengths_mm": list(cell.lengths_mm),
        "octants": [{"corner": list(corner), "a": a, "c": c} for corner, a, c in cell.octants],
    }


def _semi_axes(cell: Cell) -> list[tuple[float, float]]:
    if cell.is_periodic:
        return [(a, c) for _, a, c, _ in cell.particles]
    return [(a, c) for _, a, c in cell.octants]


def largest_radius_of(cell: Cell) -> float:
    """The largest semi-axis of any particle [mm] (the R of tolerances)."""
    return max(max(a, c) for a, c in _semi_axes(cell))


def has_particle_contact(cell: Cell) -> bool:
    """True when particles touch particles: a cell of more than one octant,
    or any periodic cell (its particles touch their images)."""
    return cell.is_periodic or len(cell.octants) > 1


def size_ratio_of(cell: Cell) -> float:
    """Largest over smallest particle semi-axis a [-] (1 for one size)."""
    sizes = [a for a, _ in _semi_axes(cell)]
    return max(sizes) / min(sizes)


def aspect_ratio_of(cell: Cell) -> float | None:
    """The particles' common c/a, None when they differ."""
    ratios = [c / a for a, c in _semi_axes(cell)]
    if all(math.isclose(r, ratios[0], rel_tol=1e-12) for r in ratios):
        return ratios[0]
    return None


def by_name(
    name: str,
    radius_mm: float = DEFAULT_RADIUS_MM,
    aspect_ratio: float = 1.0,
    size_ratio: float | None = None,
) -> Cell:
    """The preset called ``name`` (one of :data:`CELL_NAMES`). ``size_ratio``
    applies to sc2 only (None: the default 1.566); given for another cell it
    is an error."""
    if size_ratio is not None and name != "sc2":
        raise ValueError(f"size_ratio = {size_ratio:g}: applies to the sc2 cell only, not {name}")
    if name == "sc":
        return sc(radius_mm, aspect_ratio)
    if name == "bcc":
        return bcc(radius_mm, aspect_ratio)
    if name == "fcc":
        return fcc(radius_mm, aspect_ratio)
    if name == "sc2":
        r = DEFAULT_SIZE_RATIO if size_ratio is None else size_ratio
        return sc2(radius_mm, r, aspect_ratio)
    raise ValueError(f"cell = {name!r}: must be one of {', '.join(CELL_NAMES)}")


def _tuples(name: str, value: Any, fields: tuple[str, ...]) -> list[list[Any]]:
    """``value`` checked as a list of tuples of ``fields`` (numpy values as
    plain Python ones); ValueError naming ``name`` or ``name[k]``."""
    shape = f"({', '.join(fields)})"
    items = _plain(value)
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence):
        raise ValueError(f"{name} = {items!r}: must be a list of {shape}")
    out = []
    for k, item in enumerate(items):
        if isinstance(item, (str, bytes)) or not isinstance(item, Sequence) or len(item) != len(fields):
            raise ValueError(f"{name}[{k}] = {item!r}: must be {shape}")
        out.append([_plain(x) for x in item])
    return out


def _no_unknown_keys(where: str, data: Mapping[str, Any], known: tuple[str, ...]) -> None:
    unknown = [k for k in data if k not in known]
    if unknown:
        raise ValueError(f"{where}{unknown[0]}: unknown key (the keys are {', '.join(known)})")


def _plain(value: Any) -> Any:
    """numpy arrays and scalars as Python lists and numbers."""
    return value.tolist() if isinstance(value, (np.ndarray, np.generic)) else value


def _number(name: str, value: Any) -> float:
    # bool is an int in Python, but `a = true` is a mistake, not 1 mm.
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} = {value!r}: must be a number [mm]")
    return float(value)


def _numbers(name: str, value: Any, n: int, what: str) -> list[float]:
    value = _plain(value)
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != n:
        raise ValueError(f"{name} = {value!r}: must be {what}")
    return [_number(f"{name}[{i}]", v) for i, v in enumerate(value)]


def _corner(name: str, value: Any) -> Corner:
    if isinstance(value, str) and len(value) == 3 and set(value) <= {"0", "1"}:
        return (value[0] == "1", value[1] == "1", value[2] == "1")
    if (
        not isinstance(value, str)
        and isinstance(value, Sequence)
        and len(value) == 3
        and all(isinstance(v, bool) for v in value)
    ):
        return (value[0], value[1], value[2])
    raise ValueError(
        f"{name} = {value!r}: must be three booleans (true = the high end of that axis) "
        'or a string of three 0/1 digits such as "011"'
    )


__all__ = [
    "CELL_NAMES",
    "DEFAULT_RADIUS_MM",
    "DEFAULT_SIZE_RATIO",
    "Cell",
    "Octant",
    "aspect_ratio_of",
    "bcc",
    "by_name",
    "custom",
    "fcc",
    "from_dict",
    "from_file",
    "sc",
    "sc2",
    "size_ratio_of",
    "to_dict",
]
