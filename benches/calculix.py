"""tidens against CalculiX on the same hot-pressing cells, side by side.

    python benches/calculix.py [--cases sc bcc] [--levels 1 2] [--penalties 1 10 100]
                               [--cetol 0.1] [--save benches/calculix.json]
                               [--report-only] [--keep-dir DIR] [--check-norton]

The problem (units mm, N, MPa, s): one periodic cell of Ti-6Al-4V octants at
1293 K (Norton creep eps_dot = C q^n, C = 4.8e-7, n = 2.8; E = 43500 MPa,
nu = 0.3; finite strain) hot pressed by a rigid piston under a stress ramped
from 0 over 1 s and then held: ``sc`` (one octant, 10 MPa) and ``bcc`` (two
octants touching on the body diagonal, 15 MPa), both to rho = 0.9. Octant
faces on the box faces are mirror planes (the top ones move with the
piston); the curved surfaces meet the rigid box faces and each other in
frictionless contact. rho(t) = V_particles(t) / (Lx Ly (Lz + U(t))).

CalculiX (``ccx``, Debian package ``calculix-ccx``, installed with apt-get
when missing) runs the tidens mesh of level L (``exact_volume=False``: the
surface nodes on the sphere) turned into 20-node C3D20R hexes, their
mid-edge nodes on the curved surface projected onto the sphere. The mirror
planes are *BOUNDARY (or, on the top face, an *EQUATION tying u_z to the
piston); each rigid box face is one C3D8 slab, clamped (a fixed wall) or
moving in z only, its nodes tied by *EQUATION to a reference node loaded
through an *AMPLITUDE ramp with F = sigma Lx Ly (the piston). Contact is
surface-to-surface, frictionless, with the linear pressure-overclosure
penalty K = k E / h (h the mean element size, k from ``--penalties``). A
first step of no time pushes the piston by h^2 / (4 R) so that contact
exists (a free piston out of contact leaves the system singular); then
*VISCO, NLGEOM steps over [0, 1], [1, 2], [2, 4], ... s release it under the
ramped force, with CETOL (``--cetol``, the creep strain allowed per
increment; 0.1 by default, as smaller values make CalculiX cut the
increments without end at the initial point contacts) and at least 20
increments per step. The deck is in micrometres and micronewtons (stresses
in MPa), as in mm and N the forces are too small for CalculiX's convergence
checks. *NODE PRINT gives the piston displacement U and *EL PRINT EVOL the
particle volume at every increment (CalculiX prints the same volume at
every increment: the elastic change, 2e-4 at rho = 0.9 in tidens, is left
out), from which rho(t) and t(0.6) .. t(0.9) follow by linear
interpolation. ccx is stopped as soon as the density it prints reaches 0.9.

tidens runs as its command, ``tidens run --cell C --stress S --until-density
0.9 --mesh-level L --tolerance TOL --no-error-estimate --no-plot --quiet
--out DIR``, over levels 1..4 and tolerances 0.01, 0.02, in a second thread
at the same time as the CalculiX runs. Every run has one thread
(OMP_NUM_THREADS, RAYON_NUM_THREADS and CalculiX's CCX_NPROC_* set to 1) and
is timed as the wall time of its process.

The numbers: t(rho) [s] of both codes beside the converged references of
``benches/references.json`` (made by ``benches/references.py``); the error
of a run is the largest relative error of its t(0.8) and t(0.9) against
them; ``wall`` is the process wall time [s]. For each CalculiX run, the
speed ratio at equal error is wall(CalculiX) / wall(tidens) for the
cheapest tidens run whose error is no larger.

Runs are stored in the ``--save`` file as they finish and are not repeated
(stop and resume at will); ``--report-only`` reprints the tables.
``--check-norton`` runs one C3D20R cube squeezed between frictionless
platens (sides free) against the closed form L^-n = L0^-n + n C (F/(A0
L0))^n t, the check of CalculiX's creep law, units and piston tie.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import tidens_rs as td
from tidens_rs.result import interpolate_time

HERE = Path(__file__).resolve().parent
REFERENCES = HERE / "references.json"
MATERIAL = td.materials.TI64_CREEP_1293K
UNTIL_DENSITY = 0.9
MARKS = ("0.6", "0.7", "0.8", "0.9")
ERROR_MARKS = ("0.8", "0.9")
TIDENS_LEVELS = (1, 2, 3, 4)
TIDENS_TOLERANCES = (0.01, 0.02)
UM = 1e3  # micrometres per mm, the length unit of the CalculiX decks
# Increments per doubling of the time, at least (see visco_steps).
STEP_INCREMENTS = 20
# Simulated time allowed to CalculiX, as a multiple of the reference t(0.9).
TIME_FACTOR = 1.5
ONE_THREAD = {
    "OMP_NUM_THREADS": "1",
    "RAYON_NUM_THREADS": "1",
    "CCX_NPROC_EQUATION_SOLVER": "1",
    "CCX_NPROC_STIFFNESS": "1",
    "CCX_NPROC_RESULTS": "1",
    "NUMBER_OF_CPUS": "1",
}
MODEL_DIFFERENCES = (
    "CalculiX model vs tidens: C3D20R (quadratic, reduced integration, curved faces) instead of "
    "mean-dilatation hex8; rigid planes and particle contact by a surface-to-surface penalty "
    "(K = k E/h) instead of exact plane contact and augmented Lagrangian; time steps by CETOL "
    "instead of tidens' tolerance; mesh with surface nodes on the sphere (tidens' default moves "
    "them out to the exact volume); the piston first pushed by h^2/(4R) in a step of no time; "
    "the particle volume without its elastic change (2e-4)."
)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

# C3D20 mid-edge nodes 9..20 as corner pairs (0-based), in CalculiX's order.
EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7))
# Corners of the faces S1..S6 of C3D8/C3D20 (0-based).
FACES = ((0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0))


@dataclass(frozen=True)
class CaseSpec:
    cell: str
    stress_mpa: float
    reference: str  # key in references.json "cases"


CASES = {"sc": CaseSpec("sc", 10.0, "sc10"), "bcc": CaseSpec("bcc", 15.0, "bcc")}


# --- mesh ---------------------------------------------------------------------


@dataclass
class Mesh:
    """Particles as C3D20R hexes, 0-based; the box is [0, box]."""

    nodes: FloatArray  # (N, 3)
    elements: IntArray  # (E, 20)
    particle: IntArray  # (E,)
    curved_faces: list[tuple[int, int]]  # (element, face 0..5) on a particle's sphere
    centres: FloatArray  # (P, 3)
    radius: float
    box: FloatArray  # (3,)

    def element_size(self) -> float:
        corners = self.nodes[self.elements[:, :8]]
        volume = float(np.sum(hex_volumes(corners)))
        return float((volume / len(self.elements)) ** (1.0 / 3.0))


def hex_volumes(corners: FloatArray) -> FloatArray:
    """Volumes of straight-sided hexes from their 8 corners (E, 8, 3), by
    splitting each into the 6 tetrahedra around the diagonal 0-6."""
    tets = ((0, 1, 2), (0, 2, 3), (0, 3, 7), (0, 7, 4), (0, 4, 5), (0, 5, 1))
    total = np.zeros(len(corners))
    for a, b, c in tets:
        d0 = corners[:, a] - corners[:, 6]
        d1 = corners[:, b] - corners[:, 6]
        d2 = corners[:, c] - corners[:, 6]
        total += np.einsum("ij,ij->i", np.cross(d0, d1), d2) / 6.0
    return np.abs(total)


def tidens_hex_mesh(cell: str, level: int) -> tuple[FloatArray, IntArray, IntArray]:
    """tidens' hex8 mesh of level ``level``, surface nodes on the sphere."""
    case = td.Case(
        cell=td.cells.by_name(cell),
        material=MATERIAL,
        stress_mpa=1.0,
        solver=td.SolverSettings(mesh_level=level, exact_volume=False),
    )
    fields = case.simulation(until_density=UNTIL_DENSITY).fields()
    points = np.asarray(fields["points"], dtype=np.float64)
    cells = np.asarray(fields["cells"], dtype=np.int64)
    particle = np.asarray(fields["particle"], dtype=np.int64)
    return points, cells, particle


def particle_centres(points: FloatArray, cells: IntArray, particle: IntArray, box: FloatArray) -> FloatArray:
    """Each octant's centre: the box corner nearest to its centroid."""
    centres = []
    for p in range(int(particle.max()) + 1):
        centroid = points[np.unique(cells[particle == p])].mean(axis=0)
        centres.append(np.where(centroid > box / 2, box, 0.0))
    return np.array(centres)


def cut_axis(corners: FloatArray, centre: FloatArray, tol: float) -> int | None:
    """Axis of the plane through the particle centre holding all the face's
    corners (a cut through the particle, i.e. a mirror plane), or None."""
    for k in range(3):
        if np.all(np.abs(corners[:, k] - centre[k]) < tol):
            return k
    return None


def boundary_faces(cells: IntArray) -> list[tuple[int, int]]:
    """(element, face) of the faces that belong to one element only."""
    count = Counter(tuple(sorted(cells[e, list(f)])) for e in range(len(cells)) for f in FACES)
    return [(e, i) for e in range(len(cells)) for i, f in enumerate(FACES) if count[tuple(sorted(cells[e, list(f)]))] == 1]


def sphere_faces(points: FloatArray, cells: IntArray, particle: IntArray, centres: FloatArray, tol: float) -> list[tuple[int, int]]:
    """Boundary faces not on a cut plane: the particles' curved surfaces."""
    return [
        (e, i)
        for e, i in boundary_faces(cells)
        if cut_axis(points[cells[e, list(FACES[i])]], centres[particle[e]], tol) is None
    ]


def quadratic_mesh(cell: str, level: int) -> Mesh:
    """The tidens mesh with a mid-edge node on every edge (shared between
    elements), those on the curved surface projected onto the sphere."""
    points, cells, particle = tidens_hex_mesh(cell, level)
    box = np.array(td.cells.by_name(cell).lengths_mm, dtype=np.float64)
    tol = 1e-9 * float(box.max())
    centres = particle_centres(points, cells, particle, box)
    radius = float(max(np.linalg.norm(points[cells[particle == p]] - c, axis=-1).max() for p, c in enumerate(centres)))
    curved = sphere_faces(points, cells, particle, centres, tol)
    curved_edges = {
        tuple(sorted((cells[e, f[j]], cells[e, f[(j + 1) % 4]]))) for e, i in curved for f in [FACES[i]] for j in range(4)
    }
    nodes = list(points)
    mid: dict[tuple[int, int], int] = {}
    elements = np.zeros((len(cells), 20), dtype=np.int64)
    elements[:, :8] = cells
    for e in range(len(cells)):
        for j, (a, b) in enumerate(EDGES):
            key = (min(cells[e, a], cells[e, b]), max(cells[e, a], cells[e, b]))
            if key not in mid:
                x = (points[key[0]] + points[key[1]]) / 2
                if key in curved_edges:
                    c = centres[particle[e]]
                    x = c + radius * (x - c) / np.linalg.norm(x - c)
                mid[key] = len(nodes)
                nodes.append(x)
            elements[e, 8 + j] = mid[key]
    return Mesh(np.array(nodes), elements, particle, curved, centres, radius, box)


# --- CalculiX input -------------------------------------------------------------


@dataclass(frozen=True)
class Wall:
    """A rigid box face z_axis = value met by a particle it does not cut."""

    axis: int
    value: float
    particle: int

    def is_piston(self, box: FloatArray) -> bool:
        return self.axis == 2 and self.value > box[2] / 2

    def name(self) -> str:
        return f"WALL{'XYZ'[self.axis]}{'HI' if self.value > 0 else 'LO'}"


def walls(mesh: Mesh) -> list[Wall]:
    """For each octant, the three box faces opposite its centre."""
    return [
        Wall(k, float(mesh.box[k]) if c[k] == 0.0 else 0.0, p) for p, c in enumerate(mesh.centres) for k in range(3)
    ]


def slab_corners(wall: Wall, box: FloatArray) -> FloatArray:
    """The 8 corners (C3D8 order) of a slab outside the box whose face on
    the wall's plane covers the box face with a margin."""
    lo, hi = -0.1 * box, 1.1 * box
    thickness = 0.25 * float(box[wall.axis])
    lo[wall.axis], hi[wall.axis] = (wall.value - thickness, wall.value) if wall.value == 0.0 else (wall.value, wall.value + thickness)
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return np.array(
        [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0], [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]
    )


def face_on_plane(corners: FloatArray, axis: int, value: float) -> int:
    """Index 0..5 of the hex face lying on the plane x_axis = value."""
    for i, f in enumerate(FACES):
        if np.allclose(corners[list(f), axis], value):
            return i
    raise ValueError("no face on the plane")


def particle_pairs(mesh: Mesh) -> list[tuple[int, int]]:
    """Octant pairs whose spheres touch or overlap (slave, master)."""
    n = len(mesh.centres)
    return [
        (q, p)
        for p in range(n)
        for q in range(p + 1, n)
        if np.linalg.norm(mesh.centres[p] - mesh.centres[q]) <= 2 * mesh.radius * (1 + 1e-9)
    ]


def cut_plane_nodes(mesh: Mesh, p: int) -> Iterator[tuple[int, int]]:
    """(node, axis) of octant p's nodes on its mirror planes."""
    ids = np.unique(mesh.elements[mesh.particle == p])
    tol = 1e-9 * float(mesh.box.max())
    for k in range(3):
        for n in ids[np.abs(mesh.nodes[ids, k] - mesh.centres[p][k]) < tol]:
            yield int(n), k


def number_lines(rows: list[list[float]]) -> list[str]:
    return [", ".join(f"{v:.12g}" for v in row) for row in rows]


def node_lines(first: int, points: FloatArray) -> list[str]:
    """*NODE data, numbered from ``first``, in micrometres."""
    return number_lines([[first + i, *(float(v) * UM for v in x)] for i, x in enumerate(points)])


def element_lines(first: int, connectivity: IntArray) -> list[str]:
    """*ELEMENT data of 0-based connectivity, at most 16 entries a line."""
    out = []
    for e, row in enumerate(connectivity):
        entries = [str(first + e), *(str(int(n) + 1) for n in row)]
        out += [", ".join(entries[i : i + 16]) + ("," if i + 16 < len(entries) else "") for i in range(0, len(entries), 16)]
    return out


def material_lines() -> list[str]:
    elastic = ["*ELASTIC", f"{MATERIAL.young_mpa}, {MATERIAL.poisson}"]
    return [
        "*MATERIAL, NAME=TI64",
        *elastic,
        "*CREEP, LAW=NORTON",  # eps_dot = A q^n t^m, here m = 0
        f"{MATERIAL.creep_c:.12g}, {MATERIAL.creep_n}, 0.",
        "*MATERIAL, NAME=WALL",
        *elastic,
    ]


@dataclass(frozen=True)
class Slab:
    nodes: list[int]  # 1-based
    element: int
    face: int  # 0..5, the face on the wall's plane


def slab_decks(mesh: Mesh) -> tuple[list[str], dict[Wall, Slab]]:
    """One C3D8 element per rigid wall, numbered after the particles."""
    out: list[str] = []
    slabs: dict[Wall, Slab] = {}
    for w in walls(mesh):
        corners = slab_corners(w, mesh.box)
        first = len(mesh.nodes) + 8 * len(slabs) + 1
        element = len(mesh.elements) + len(slabs) + 1
        out += ["*NODE, NSET=NALL", *node_lines(first, corners)]
        out += ["*ELEMENT, TYPE=C3D8, ELSET=WALLS", *element_lines(element, np.arange(first - 1, first + 7)[None, :])]
        slabs[w] = Slab(list(range(first, first + 8)), element, face_on_plane(corners, w.axis, w.value))
    return out, slabs


def supports_and_ties(mesh: Mesh, slabs: dict[Wall, Slab], piston: Wall) -> tuple[list[str], list[int]]:
    """*BOUNDARY lines (fixed walls clamped, the piston moving in z only,
    mirror planes) and the nodes whose u_z is the piston's."""
    supports = [f"{n}, 1, {2 if w == piston else 3}" for w, s in slabs.items() for n in s.nodes]
    tied = slabs[piston].nodes[1:]
    for p in range(len(mesh.centres)):
        for n, k in cut_plane_nodes(mesh, p):
            if k == 2 and mesh.centres[p][2] > mesh.box[2] / 2:
                tied.append(n + 1)
            else:
                supports.append(f"{n + 1}, {k + 1}, {k + 1}")
    return supports, tied


def tie_lines(tied: list[int], ref: int) -> list[str]:
    return ["*EQUATION"] + [f"2\n{n}, 3, 1., {ref}, 3, -1." for n in tied]


def contact_lines(mesh: Mesh, slabs: dict[Wall, Slab], penalty: float) -> list[str]:
    """Frictionless surface-to-surface penalty contact: the octants (slaves)
    against the walls they face and against each other."""
    out = []
    for p in range(len(mesh.centres)):
        out += [f"*SURFACE, NAME=OCTANT{p}, TYPE=ELEMENT"]
        out += [f"{e + 1}, S{i + 1}" for e, i in mesh.curved_faces if mesh.particle[e] == p]
    for w, s in slabs.items():
        out += [f"*SURFACE, NAME={w.name()}, TYPE=ELEMENT", f"{s.element}, S{s.face + 1}"]
    out += ["*SURFACE INTERACTION, NAME=FRICTIONLESS", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR"]
    out += [f"{penalty / UM:.6g}", "*CONTACT PAIR, INTERACTION=FRICTIONLESS, TYPE=SURFACE TO SURFACE"]
    out += [f"OCTANT{w.particle}, {w.name()}" for w in slabs]
    out += [f"OCTANT{q}, OCTANT{p}" for q, p in particle_pairs(mesh)]
    return out


def visco_steps(t_end: float, cetol: float, loads: list[str]) -> list[str]:
    """*VISCO steps over [0, 1], [1, 2], [2, 4], ... up to t_end, each with
    the time increment at most 1/STEP_INCREMENTS of its end time (longer
    increments let a particle cross a wall within one, and Newton fails);
    ``loads`` start in the first."""
    out: list[str] = []
    start, end = 0.0, 1.0
    while start < t_end:
        out += ["*STEP, NLGEOM, INC=100000", f"*VISCO, CETOL={cetol:.6g}"]
        out += [f"{min(0.01, end / STEP_INCREMENTS):.6g}, {end - start:.6g}, 1e-9, {end / STEP_INCREMENTS:.6g}"]
        if start == 0.0:
            out += loads
        out += ["*NODE PRINT, NSET=PISTON", "U", "*EL PRINT, ELSET=PARTICLES, TOTALS=ONLY", "EVOL", "*END STEP"]
        start, end = end, 2 * end
    return out


def step_lines(supports: list[str], ref: int, force: float, push: float, t_end: float, cetol: float) -> list[str]:
    """Step 1 takes no time: the piston pushed by ``push`` [mm] so that
    contact exists (a free piston out of contact makes the system
    singular). The *VISCO steps release it under the ramped force."""
    loads = ["*BOUNDARY, OP=NEW", *supports, "*CLOAD, AMPLITUDE=RAMP", f"{ref}, 3, {-force * UM * UM:.12g}"]
    return [
        "*AMPLITUDE, NAME=RAMP, TIME=TOTAL TIME",
        f"0., 0., 1., 1., {1e3 * t_end:.6g}, 1.",
        "*STEP, NLGEOM",
        "*STATIC, TIME RESET",
        "1e-6, 1e-6",
        "*BOUNDARY",
        *supports,
        f"{ref}, 3, 3, {-push * UM:.6g}",
        "*END STEP",
        *visco_steps(t_end, cetol, loads),
    ]


def write_inp(path: Path, mesh: Mesh, stress_mpa: float, penalty: float, t_end: float, cetol: float) -> None:
    """The CalculiX deck of the cell, 1-based numbers. Lengths are written in
    micrometres and forces in micronewtons (stresses stay in MPa): in mm and
    N the forces are ~1e-4 and CalculiX's convergence checks fail."""
    slab_deck, slabs = slab_decks(mesh)
    piston = next(w for w in slabs if w.is_piston(mesh.box))
    ref = slabs[piston].nodes[0]
    supports, tied = supports_and_ties(mesh, slabs, piston)
    h = mesh.element_size()
    out = ["*HEADING", f"tidens cell vs CalculiX: {len(mesh.elements)} C3D20R, penalty {penalty:.4g} MPa/mm"]
    out += ["*NODE, NSET=NALL", *node_lines(1, mesh.nodes)]
    out += ["*ELEMENT, TYPE=C3D20R, ELSET=PARTICLES", *element_lines(1, mesh.elements)]
    out += [*slab_deck, "*NSET, NSET=PISTON", str(ref), *material_lines()]
    out += ["*SOLID SECTION, ELSET=PARTICLES, MATERIAL=TI64", "*SOLID SECTION, ELSET=WALLS, MATERIAL=WALL"]
    out += [*tie_lines(tied, ref), *contact_lines(mesh, slabs, penalty)]
    force = stress_mpa * float(mesh.box[0] * mesh.box[1])
    out += step_lines(supports, ref, force, 0.25 * h * h / mesh.radius, t_end, cetol)
    path.write_text("\n".join(out) + "\n")


# --- running CalculiX -------------------------------------------------------------


def ensure_ccx() -> str:
    """The ccx command, installed from Debian's calculix-ccx when missing."""
    found = shutil.which("ccx")
    if found:
        return found
    if os.geteuid() != 0:
        sys.exit("ccx not found; install it as root: apt-get update && apt-get install -y calculix-ccx")
    for cmd in (["apt-get", "update"], ["apt-get", "install", "-y", "calculix-ccx"]):
        print("running", " ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)
    found = shutil.which("ccx")
    if not found:
        sys.exit("apt-get installed calculix-ccx but no ccx command is on PATH")
    return found


def ccx_version(ccx: str) -> str:
    out = subprocess.run([ccx, "-v"], capture_output=True, text=True).stdout
    match = re.search(r"Version\s+(\S+)", out)
    return match.group(1) if match else "unknown"


def one_thread_env() -> dict[str, str]:
    return {**os.environ, **ONE_THREAD}


def read_piston(dat: Path) -> tuple[FloatArray, FloatArray]:
    """Times [s] and piston displacements u_z [mm] printed in the .dat file."""
    rows = re.findall(r"displacements \(vx,vy,vz\) for set PISTON and time\s+(\S+)\s*\n\s*\n\s*\d+\s+\S+\s+\S+\s+(\S+)", dat.read_text())
    return np.array([float(t) for t, _ in rows]), np.array([float(u) / UM for _, u in rows])


def read_volume(dat: Path) -> FloatArray:
    """Particle volumes [mm^3] printed in the .dat file."""
    rows = re.findall(r"total volume for set PARTICLES and time\s+\S+\s*\n\s*\n\s*(\S+)", dat.read_text())
    return np.array([float(v) / UM**3 for v in rows])


def density_curve(dat: Path, box: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(t, rho) at the increments whose piston and volume are both printed."""
    t, u = read_piston(dat)
    volume = read_volume(dat)
    n = min(len(t), len(volume))
    return t[:n], volume[:n] / (box[0] * box[1] * (box[2] + u[:n]))


def run_ccx(ccx: str, inp: Path, box: FloatArray | None) -> tuple[float, str]:
    """Runs ccx on ``inp`` in its folder; with a box, stops it as soon as the
    density printed reaches UNTIL_DENSITY. Returns the wall time [s] and the
    end of its output."""
    dat = inp.with_suffix(".dat")
    log = inp.with_suffix(".log")
    t0 = time.perf_counter()
    with log.open("w") as out:
        proc = subprocess.Popen([ccx, "-i", inp.stem], cwd=inp.parent, stdout=out, stderr=subprocess.STDOUT, env=one_thread_env())
        while proc.poll() is None:
            time.sleep(0.2)
            if box is not None and dat.exists() and density_curve(dat, box)[1].max(initial=0.0) >= UNTIL_DENSITY:
                proc.terminate()
                proc.wait()
    wall = time.perf_counter() - t0
    return wall, "\n".join(log.read_text().strip().splitlines()[-4:])


# --- the runs ------------------------------------------------------------------


def reference_times(case: str) -> dict[str, float]:
    refs: dict[str, Any] = json.loads(REFERENCES.read_text())["cases"][CASES[case].reference]
    return {k: float(v) for k, v in refs["times_s"].items() if k in ERROR_MARKS}


def times_to_marks(t: FloatArray, rho: FloatArray) -> dict[str, float | None]:
    """t(rho) at the marks; None for marks below the initial density."""
    return {m: interpolate_time(t, rho, float(m)) if len(rho) and rho[0] < float(m) else None for m in MARKS}


def run_calculix(ccx: str, case: str, level: int, penalty: float, cetol: float, work: Path) -> dict[str, Any]:
    spec = CASES[case]
    mesh = quadratic_mesh(spec.cell, level)
    k = penalty * MATERIAL.young_mpa / mesh.element_size()
    inp = work / f"ccx_{case}_L{level}_K{penalty:g}.inp"
    write_inp(inp, mesh, spec.stress_mpa, k, TIME_FACTOR * reference_times(case)["0.9"], cetol)
    wall, tail = run_ccx(ccx, inp, mesh.box)
    t, rho = density_curve(inp.with_suffix(".dat"), mesh.box)
    return {
        "code": "calculix",
        "case": case,
        "level": level,
        "penalty": penalty,
        "cetol": cetol,
        "elements": len(mesh.elements),
        "nodes": len(mesh.nodes),
        "wall_s": wall,
        "increments": len(t),
        "rho0": float(rho[0]) if len(rho) else None,
        "final_time_s": float(t[-1]) if len(t) else None,
        "final_density": float(rho[-1]) if len(rho) else None,
        "times_s": times_to_marks(t, rho),
        "log_tail": tail if rho.max(initial=0.0) < UNTIL_DENSITY else "",
    }


def run_tidens(case: str, level: int, tolerance: float, work: Path) -> dict[str, Any]:
    spec = CASES[case]
    out = work / f"tidens_{case}_L{level}_tol{tolerance:g}"
    cmd = ["tidens", "run", "--cell", spec.cell, "--stress", f"{spec.stress_mpa:g}", "--until-density", f"{UNTIL_DENSITY:g}"]
    cmd += ["--mesh-level", str(level), "--tolerance", f"{tolerance:g}", "--no-error-estimate", "--no-plot", "--quiet", "--overwrite", "--out", str(out)]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, env=one_thread_env())
    wall = time.perf_counter() - t0
    summary = json.loads((out / "summary.json").read_text())
    return {
        "code": "tidens",
        "case": case,
        "level": level,
        "tolerance": tolerance,
        "wall_s": wall,
        "solver_wall_s": summary["wall_seconds"],
        "times_s": {m: summary["times_to_density_s"].get(m) for m in MARKS},
    }


def ccx_key(case: str, level: int, penalty: float, cetol: float) -> str:
    return f"calculix/{case}/L{level}/K{penalty:g}/cetol{cetol:g}"


def tidens_key(case: str, level: int, tolerance: float) -> str:
    return f"tidens/{case}/L{level}/tol{tolerance:g}"


class Store:
    """Runs by key in a JSON file, written after every run."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.lock = threading.Lock()
        self.runs: dict[str, dict[str, Any]] = json.loads(path.read_text())["runs"] if path.exists() else {}

    def add(self, key: str, run: dict[str, Any]) -> None:
        with self.lock:
            self.runs[key] = run
            self.path.write_text(json.dumps({"runs": self.runs}, indent=1) + "\n")


def run_tidens_ladder(store: Store, cases: list[str], work: Path) -> None:
    for case in cases:
        for level in TIDENS_LEVELS:
            for tol in TIDENS_TOLERANCES:
                key = tidens_key(case, level, tol)
                if key not in store.runs:
                    store.add(key, run_tidens(case, level, tol, work))
                    print(f"done {key}: {store.runs[key]['wall_s']:.1f} s", flush=True)


def run_all(args: argparse.Namespace, store: Store, work: Path) -> None:
    """The tidens ladder in a second thread while CalculiX runs here."""
    ccx = ensure_ccx()
    print(f"CalculiX {ccx_version(ccx)} ({ccx})", flush=True)
    tidens = threading.Thread(target=run_tidens_ladder, args=(store, args.cases, work))
    tidens.start()
    for case in args.cases:
        for level in args.levels:
            for penalty in args.penalties:
                key = ccx_key(case, level, penalty, args.cetol)
                if key not in store.runs:
                    print(f"running {key}", flush=True)
                    store.add(key, run_calculix(ccx, case, level, penalty, args.cetol, work))
                    print(f"done {key}: {store.runs[key]['wall_s']:.1f} s", flush=True)
    tidens.join()


# --- report --------------------------------------------------------------------


def error_of(run: dict[str, Any], refs: dict[str, float]) -> float:
    """Largest relative error of t(0.8), t(0.9); infinite if one is missing."""
    errors = [abs(run["times_s"][m] - t) / t if run["times_s"].get(m) is not None else float("inf") for m, t in refs.items()]
    return max(errors)


def label(run: dict[str, Any]) -> str:
    if run["code"] == "calculix":
        return f"CalculiX L{run['level']} K={run['penalty']:g}E/h"
    return f"tidens L{run['level']} tol {run['tolerance']:g}"


def fmt(v: float | None, spec: str = "8.2f") -> str:
    return f"{v:{spec}}" if v is not None else f"{'-':>{spec.split('.')[0]}}"


def case_table(case: str, runs: list[dict[str, Any]]) -> list[str]:
    refs = reference_times(case)
    unc = json.loads(REFERENCES.read_text())["cases"][CASES[case].reference]["uncertainty_s"]
    head = f"{'run':28s}" + "".join(f"{'t(' + m + ')':>10s}" for m in MARKS) + f"{'error':>9s}{'wall [s]':>10s}"
    out = [head, f"{'reference':28s}" + "".join(fmt(refs.get(m), "10.2f") for m in MARKS)]
    out.append(f"{'  +-':28s}" + "".join(fmt(unc.get(m) if m in refs else None, "10.2f") for m in MARKS))
    for run in runs:
        err = error_of(run, refs)
        cells = "".join(fmt(run["times_s"].get(m), "10.2f") for m in MARKS)
        out.append(f"{label(run):28s}{cells}{100 * err:8.2f}%{run['wall_s']:10.2f}")
    return out


def speed_lines(case: str, ccx_runs: list[dict[str, Any]], tidens_runs: list[dict[str, Any]]) -> list[str]:
    """For each CalculiX run, the cheapest tidens run with no larger error."""
    refs = reference_times(case)
    out = []
    for c in ccx_runs:
        err = error_of(c, refs)
        fits = [t for t in tidens_runs if error_of(t, refs) <= err]
        if err == float("inf"):
            out.append(f"  {label(c)}: did not reach rho = {UNTIL_DENSITY}, no error to match")
        elif not fits:
            out.append(f"  {label(c)}: error {100 * err:.2f}%: no tidens run (levels {TIDENS_LEVELS}) is as accurate")
        else:
            best = min(fits, key=lambda t: float(t["wall_s"]))
            out.append(
                f"  {label(c)}: error {100 * err:.2f}%, wall {c['wall_s']:.1f} s; {label(best)}: error "
                f"{100 * error_of(best, refs):.2f}%, wall {best['wall_s']:.2f} s -> {c['wall_s'] / best['wall_s']:.0f}x"
            )
    return out


def report(store: Store, cases: list[str]) -> None:
    for case in cases:
        spec = CASES[case]
        runs = [r for r in store.runs.values() if r["case"] == case]
        ccx_runs = sorted((r for r in runs if r["code"] == "calculix"), key=lambda r: (r["level"], r["penalty"], r["cetol"]))
        tidens_runs = sorted((r for r in runs if r["code"] == "tidens"), key=lambda r: (r["level"], r["tolerance"]))
        print(f"\n== {case}: {spec.cell} at {spec.stress_mpa:g} MPa to rho = {UNTIL_DENSITY} (reference {spec.reference}) ==")
        print("\n".join(case_table(case, ccx_runs + tidens_runs)))
        for r in ccx_runs:
            if r["log_tail"]:
                print(f"{label(r)} stopped at t = {fmt(r['final_time_s'], '.2f')} s, rho = {fmt(r['final_density'], '.4f')}: {r['log_tail'].splitlines()[0].strip()}")
        cetols = sorted({f"{r['cetol']:g}" for r in ccx_runs})
        print(f"CalculiX CETOL: {', '.join(cetols) or '-'}")
        print("speed at equal error, wall(CalculiX) / wall(tidens):")
        print("\n".join(speed_lines(case, ccx_runs, tidens_runs)))
    print("\n" + MODEL_DIFFERENCES)


# --- Norton check -------------------------------------------------------------------


def write_norton_cube(path: Path, side: float, stress_mpa: float, t_end: float) -> None:
    """One C3D20R cube [0, side]^3 [mm]: mirror planes x = 0, y = 0, z = 0,
    the top face's u_z tied to node 5, which carries the force (step load),
    sides free."""
    corners = side * np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=np.float64)
    points = np.vstack([corners, [(corners[a] + corners[b]) / 2 for a, b in EDGES]])
    supports = [f"{i + 1}, {k + 1}, {k + 1}" for i, x in enumerate(points) for k in range(3) if x[k] == 0.0]
    top = [i + 1 for i, x in enumerate(points) if x[2] == side]
    out = ["*HEADING", "Norton creep of one C3D20R cube", "*NODE, NSET=NALL", *node_lines(1, points)]
    out += ["*ELEMENT, TYPE=C3D20R, ELSET=PARTICLES", *element_lines(1, np.arange(20)[None, :]), *material_lines()]
    out += ["*SOLID SECTION, ELSET=PARTICLES, MATERIAL=TI64", "*NSET, NSET=PISTON", str(top[0]), *tie_lines(top[1:], top[0])]
    out += ["*BOUNDARY", *supports, "*STEP, NLGEOM, INC=100000", "*VISCO, CETOL=1e-4", f"0.01, {t_end:g}, 1e-9, {t_end / 100:g}"]
    out += ["*CLOAD", f"{top[0]}, 3, {-stress_mpa * side * side * UM * UM:.12g}", "*NODE PRINT, NSET=PISTON", "U", "*END STEP"]
    path.write_text("\n".join(out) + "\n")


def check_norton(work: Path) -> None:
    """CalculiX's cube height against L^-n = L0^-n + n C (F/(A0 L0))^n t."""
    ccx = ensure_ccx()
    side, stress, t_end = 0.05, 10.0, 500.0
    inp = work / "norton_cube.inp"
    write_norton_cube(inp, side, stress, t_end)
    wall, _ = run_ccx(ccx, inp, None)
    t, u = read_piston(inp.with_suffix(".dat"))
    n, c = MATERIAL.creep_n, MATERIAL.creep_c
    exact = (side**-n + n * c * (stress / side) ** n * t) ** (-1 / n)
    creep = side + u  # minus the elastic shortening, F/A/E of the current height
    creep = creep / (1 - stress * side / creep / MATERIAL.young_mpa)
    print(f"Norton cube (CalculiX {ccx_version(ccx)}, {len(t)} increments, {wall:.1f} s): L/L0 at t = {t[-1]:g} s is {creep[-1] / side:.5f}, closed form {exact[-1] / side:.5f}")
    print(f"largest relative error of the height over the run: {np.max(np.abs(creep / exact - 1)):.2e}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", choices=sorted(CASES), default=["sc", "bcc"])
    ap.add_argument("--levels", nargs="+", type=int, default=[1, 2], help="CalculiX mesh levels (tidens' hex layouts)")
    ap.add_argument("--penalties", nargs="+", type=float, default=[1.0, 10.0, 100.0], help="contact slopes K in units of E/h")
    ap.add_argument("--cetol", type=float, default=0.1, help="CalculiX's allowed creep strain increment")
    ap.add_argument("--save", type=Path, default=HERE / "calculix.json")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--keep-dir", type=Path, help="keep the CalculiX decks and outputs and the tidens outputs here")
    ap.add_argument("--check-norton", action="store_true", help="only run the one-element Norton creep check")
    args = ap.parse_args()
    store = Store(args.save)
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep_dir or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        if args.check_norton:
            check_norton(work)
            return
        if not args.report_only:
            run_all(args, store, work)
    report(store, args.cases)


if __name__ == "__main__":
    main()
