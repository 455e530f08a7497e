"""Periodic cells: whole particles in a box periodic along x, y and z, as
lattices of the presets (``cells.as_periodic``), random jammed packings
(``cells.random``) and cell files; the command line's ``--periodic`` and
``--cell random``."""

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs.cli import main
from tidens_rs.io import read_curve

# Each lattice: whole particles in the doubled box, and its coordination
# number (sc 6 neighbours, bcc 8, fcc 12; rock salt: each sphere touches
# the 6 of the other size around it).
LATTICES = {"sc": (1, 6.0), "bcc": (2, 8.0), "fcc": (4, 12.0), "sc2": (8, 6.0)}


@pytest.mark.parametrize("name", sorted(LATTICES))
def test_a_lattice_as_whole_particles_keeps_its_density_and_contacts(name: str) -> None:
    cell = td.cells.by_name(name)
    lattice = td.cells.as_periodic(cell)
    count, z = LATTICES[name]
    assert lattice.is_periodic and not cell.is_periodic
    assert len(lattice.particles) == count and lattice.octants == []
    assert lattice.lengths_mm == pytest.approx([2 * x for x in cell.lengths_mm], rel=1e-15)
    # The same packing, so the same density: the exact particle volume
    # over the box, computed for whole particles here and for octants there.
    assert lattice.rho0 == pytest.approx(cell.rho0, rel=1e-12)
    assert td.packing.coordination_number(td.cells.to_packing(lattice)) == pytest.approx(z, abs=1e-12)


def test_a_periodic_cell_survives_its_file(tmp_path: Path) -> None:
    cell = td.cells.random(8, seed=2)
    path = tmp_path / "cell.json"
    path.write_text(json.dumps(td.cells.to_dict(cell)))
    back = td.cells.from_file(path)
    assert back.is_periodic and back.name == "random"
    assert back.particles == cell.particles and back.lengths_mm == cell.lengths_mm


def test_a_random_cell_is_jammed_and_reproducible() -> None:
    a, b = td.cells.random(8, seed=5), td.cells.random(8, seed=5)
    assert a.particles == b.particles
    # Jammed: every particle of the backbone held by at least 4 contacts,
    # and no particle overlaps another by more than round-off.
    pack = td.cells.to_packing(a)
    assert td.packing.coordination_number(pack, without_rattlers=True) >= 4.0
    assert pack.max_overlap_mm < 1e-9 * td.cells.DEFAULT_RADIUS_MM
    assert 0.55 < a.rho0 < 0.74


@pytest.mark.parametrize(
    ("particles", "field"),
    [
        ([((0.1, 0.0, 0.0), 0.05, 0.05, (0, 0, 1))], "particles[0].centre[0] = 0.1"),
        ([((0.0, 0.0, -1e-3), 0.05, 0.05, (0, 0, 1))], "particles[0].centre[2] = -0.001"),
        ([((0.0, 0.0, 0.0), 0.05, 0.3, (0, 0, 1))], "particles[0].c = 0.3"),
        ([((0.0, 0.0, 0.0), -0.05, 0.05, (0, 0, 1))], "particles[0].a = -0.05"),
        ([((0.0, 0.0, 0.0), 0.05, 0.05, (0, 0, 0))], "particles[0].axis = (0"),
        ([((0.0, 0.0, 0.0), 0.05, 0.05)], "particles[0] = "),
        ([], "particles = []"),
    ],
)
def test_bad_particles_are_named(particles: list[tuple[Any, ...]], field: str) -> None:
    with pytest.raises(ValueError, match=re.escape(field)):
        td.cells.periodic(particles, (0.1, 0.1, 0.1))


def test_cells_that_cannot_carry_the_load_are_refused_before_they_run() -> None:
    # Grown to 0.55 the spheres do not jam (16 spheres jam at 0.576 to 0.692
    # over seeds 0-19): nothing but the solver's drag would hold the piston.
    loose = td.cells.random(16, rho0=0.55)
    assert td.packing.coordination_number(td.cells.to_packing(loose), without_rattlers=True) == 0.0
    with pytest.raises(ValueError, match="no network that can carry the load"):
        td.Case(loose, td.materials.TI64_CREEP_1293K, 10.0)
    # A packing with walls in z is not a periodic cell.
    die = td.Packing.generate(8, rho0=0.5, boundary="die")
    with pytest.raises(ValueError, match="boundary = 'die'"):
        td.cells.from_packing(die)
    # Periodic cells are meshed with hexahedra only.
    case = td.Case(td.cells.as_periodic(td.cells.sc()), td.materials.TI64_CREEP_1293K, 10.0,
                   solver=td.SolverSettings(element="tet10", mesh_level=1))
    with pytest.raises(ValueError, match="element = tet10"):
        case.run(0.6, error_estimate=False)


def test_the_periodic_sc_lattice_runs_from_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    code = main(["run", "--cell", "sc", "--periodic", "--stress", "10", "--until-density", "0.53",
                 "--mesh-level", "1", "--no-plot", "--out", str(out)])
    assert code == 0
    assert ", 6.00 contacts per particle pressed" in capsys.readouterr().out
    s = json.loads((out / "summary.json").read_text())
    assert s["particles"] == 1 and s["coordination_number"] == pytest.approx(6.0, abs=1e-12)
    assert s["cell"]["periodic"] is True
    # The drag and the rotation hold carry a part of the load (most in the
    # first step, whose contacts are barely closed), never all of it.
    assert 0.0 < s["stats"]["max_drag_share"] < 1.0
    # The whole sphere's mesh has the octant's volume deficit (surface nodes
    # on the sphere), eight times over: rho0 below pi/6.
    assert s["rho0"] < math.pi / 6 and s["final_density"] >= 0.53
    # Pressed, the sphere touches its six images, as the geometry said; the
    # curve follows the count from 0 at the start, written as a column.
    assert s["final_coordination_number"] == 6.0
    curve = read_curve(out / "curve.csv")
    assert curve["coordination_number"][0] == 0.0 and curve["coordination_number"][-1] == 6.0


def test_cells_of_octants_have_no_coordination_number(quick_case: td.Case) -> None:
    r = quick_case.run(0.53, error_estimate=False)
    assert "coordination_number" not in r.curve
    assert r.summary()["final_coordination_number"] is None


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--cell", "sc", "--particles", "8"], "--particles applies to --cell random only"),
        (["--cell", "random", "--periodic"], "--periodic does not apply to --cell random"),
        (["--cell", "random", "--packing-seed", "-1"], "--packing-seed: -1: must be in [0, 2^64 - 1"),
        (["--cell", "random", "--small-fraction", "0.3"], "--small-fraction goes with --size-ratio"),
        (["--cell", "random", "--particles", "16", "--rho0", "0.55"], "no network that can carry the load"),
    ],
)
def test_random_cell_options_are_checked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    with pytest.raises(SystemExit) as e:
        main(["run", *args, "--stress", "10", "--until-density", "0.9", "--quiet", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("periodic = true\n[[particles]]\ncentre = [0, 0, 0]\na = 0.05\nc = 0.05\n", "particles[0].axis: missing"),
        ("periodic = true\nparticles = []\n", "particles = []: must be a non-empty list"),
        ("periodic = 1\n", "periodic = 1: must be true or false"),
        ("[[particles]]\ncentre = [0, 0, 0]\na = 0.05\nc = 0.05\naxis = [0, 0, 1]\n", "needs periodic = true"),
        ("periodic = true\n[[octants]]\ncorner = '000'\na = 0.05\nc = 0.05\n", "lists particles, not octants"),
    ],
)
def test_periodic_cell_files_name_what_is_wrong(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "cell.toml"
    path.write_text("lengths_mm = [0.1, 0.1, 0.1]\n" + text)
    with pytest.raises(ValueError, match=re.escape(message)):
        td.cells.from_file(path)


def test_a_periodic_toml_cell_file_is_the_cell_it_describes(tmp_path: Path) -> None:
    path = tmp_path / "one.toml"
    path.write_text(
        'name = "one"\nlengths_mm = [0.1, 0.1, 0.1]\nperiodic = true\n'
        "[[particles]]\ncentre = [0.05, 0.05, 0.05]\na = 0.05\nc = 0.05\naxis = [0, 0, 2]\n"
    )
    cell = td.cells.from_file(path)
    assert cell.name == "one" and cell.is_periodic
    # The axis is normalised; the density is the sphere's over the cube.
    assert cell.particles == [((0.05, 0.05, 0.05), 0.05, 0.05, (0.0, 0.0, 1.0))]
    assert cell.rho0 == pytest.approx(math.pi / 6, rel=1e-14)
