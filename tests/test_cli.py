"""The command line: files it writes, their consistency, its errors."""

import csv
import json
from pathlib import Path

import meshio
import numpy as np
import pytest

from tidens_rs.cli import main
from tidens_rs.result import interpolate_time

QUICK = ["--mesh-level", "1", "--tolerance", "0.05", "--quiet"]


def test_run_writes_consistent_curve_summary_fields_and_plot(tmp_path: Path) -> None:
    out = tmp_path / "run"
    code = main(
        ["run", "--cell", "sc", "--material", "ti64-creep-1293k", "--stress", "10",
         "--until-density", "0.65", "--out", str(out), *QUICK]
    )
    assert code == 0
    with (out / "curve.csv").open() as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["time_s"]) for r in rows])
    rho = np.array([float(r["rel_density"]) for r in rows])
    s = json.loads((out / "summary.json").read_text())
    for key in ("rho0", "final_density", "times_to_density_s", "wall_seconds", "steps",
                "newton_iterations", "degrees_of_freedom", "solver"):
        assert key in s
    assert s["solver"]["mesh_level"] == 1 and s["solver"]["tolerance"] == 0.05
    assert s["steps"] == len(rows) - 1
    assert s["final_density"] == pytest.approx(rho[-1], rel=1e-12)
    assert s["rho0"] == pytest.approx(rho[0], rel=1e-12)
    # The summary's time to 0.6 is the CSV curve's, and 0.7 was not reached.
    assert s["times_to_density_s"]["0.6"] == pytest.approx(interpolate_time(t, rho, 0.6), rel=1e-12)
    assert "0.7" not in s["times_to_density_s"]
    assert (out / "density.png").stat().st_size > 0
    # Fields: the final configuration stays inside the die and under the piston.
    lx, ly, lz = s["cell"]["lengths_mm"]
    piston = float(rows[-1]["piston_displacement_mm"])
    mesh = meshio.read(out / "fields_final.vtu")
    assert len(mesh.cells[0].data) == s["elements"]
    x = mesh.points
    tol = 1e-9 * lz
    assert x[:, 0].max() <= lx + tol and x[:, 1].max() <= ly + tol and x[:, 2].max() <= lz + piston + tol
    assert x.min() >= -tol
    vm = mesh.cell_data["von_mises_mpa"][0]
    assert np.all(np.isfinite(vm)) and vm.max() > 10.0  # contact stresses exceed the applied one
    assert (out / "fields_rho0.600.vtu").exists() and (out / "fields.pvd").exists()


def test_bad_arguments_name_the_parameter(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as e:
        main(["run", "--stress", "-1", "--until-density", "0.9", "--out", str(tmp_path), *QUICK])
    assert e.value.code == 2
    assert "stress" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", "--stress", "10", "--C", "1e-5", "--until-density", "0.9", "--out", str(tmp_path), *QUICK])
    assert "--n" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", "--stress", "10", "--out", str(tmp_path), *QUICK])
    assert "--until-density" in capsys.readouterr().err


def test_custom_material_from_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "custom"
    assert main(["run", "--C", "1.045e-5", "--n", "1", "--E", "40000", "--nu", "0.32", "--stress", "5",
                 "--until-time", "3", "--no-plot", "--out", str(out), *QUICK]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["material"] == {"preset": None, "creep_c": 1.045e-5, "creep_n": 1.0, "young_mpa": 40000.0, "poisson": 0.32}
    assert s["status"] == "reached_time" and s["final_time_s"] == pytest.approx(3.0, rel=1e-12)


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and "tidens" in capsys.readouterr().out


def test_bcc_run_writes_contact_pressure_and_particles(tmp_path: Path) -> None:
    out = tmp_path / "bcc"
    code = main(["run", "--cell", "bcc", "--stress", "10", "--until-density", "0.72", "--no-plot",
                 "--out", str(out), *QUICK])
    assert code == 0
    mesh = meshio.read(out / "fields_final.vtu")
    pressure = mesh.point_data["contact_pressure_mpa"]
    assert pressure.shape == (len(mesh.points),) and pressure.max() > 0.0 and pressure.min() >= 0.0
    particle = mesh.cell_data["particle"][0]
    assert set(particle.tolist()) == {0, 1}
    # Identical octants: the same mesh each.
    assert np.count_nonzero(particle == 0) == np.count_nonzero(particle == 1)
    s = json.loads((out / "summary.json").read_text())
    radius = 0.05
    assert 0.0 < s["max_penetration_mm"] < 1e-4 * radius
    assert s["cell"]["name"] == "bcc" and len(s["cell"]["octants"]) == 2
    assert s["contact"] == {"mode": "frictionless", "tied_planes": False, "penalty_factor": 10.0,
                            "penetration_tolerance": 1e-4, "facets": "triangles"}
    # The default snapshot densities below the bcc cell's rho0 are skipped.
    assert not (out / "fields_rho0.600.vtu").exists()


def test_cell_file_from_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cell = tmp_path / "overlap.toml"
    cell.write_text('lengths_mm = [0.1, 0.1, 0.06]\n'
                    '[[octants]]\ncorner = "000"\na = 0.06\nc = 0.06\n'
                    '[[octants]]\ncorner = "100"\na = 0.06\nc = 0.06\n')
    args = ["run", "--cell-file", str(cell), "--stress", "10", "--until-density", "0.9", "--out", str(tmp_path / "o"), *QUICK]
    with pytest.raises(SystemExit) as e:
        main(args)
    assert e.value.code == 2
    assert "cell file " + str(cell) + ": cell 'overlap': octants[0] and octants[1] overlap" in capsys.readouterr().err
    cell.write_text('lengths_mm = [0.1, 0.1, 0.1]\n[[octants]]\ncorner = [true, false]\na = 0.06\nc = 0.06\n')
    with pytest.raises(SystemExit) as e:
        main(args)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert str(cell) in err and "octants[0].corner" in err


@pytest.mark.parametrize(
    ("particles", "said"),
    [
        ("[]", "particles = []: must be a non-empty list"),
        ('[{"centre": [0.05, 0.05, 0.05], "a": 0.05, "c": 0.05, "axis": [0, 0, 1]},'
         ' {"centre": [0.12, 0.05, 0.05], "a": 0.05, "c": 0.05, "axis": [0, 0, 1]}]',
         "particles[0] and particles[1] overlap by 0.03"),
        ('[{"centre": [0.05, 0.05, 0.05], "a": 0.2, "c": 0.2, "axis": [0, 0, 1]}]',
         "particles[0] overlaps its own periodic image"),
    ],
)
def test_a_periodic_cell_files_errors_name_its_fields(tmp_path: Path, capsys: pytest.CaptureFixture[str], particles: str, said: str) -> None:
    cell = tmp_path / "cell.json"
    cell.write_text(f'{{"lengths_mm": [0.2, 0.2, 0.2], "periodic": true, "particles": {particles}}}')
    with pytest.raises(SystemExit) as e:
        main(["run", "--cell-file", str(cell), "--stress", "10", "--until-density", "0.9", "--out", str(tmp_path / "o"), *QUICK])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert f"cell file {cell}: {said}" in err, err
    for option_or_line in ("--particles", "--radius", "line"):
        assert option_or_line not in err, err


@pytest.mark.parametrize(
    ("options", "named"),
    [
        (["--cell", "sc", "--size-ratio", "2"], ("--size-ratio", "sc2")),
        (["--size-ratio", "2"], ("--size-ratio", "sc2")),
        (["--cell", "bcc", "--cell-file", "cell.toml"], ("--cell", "--cell-file")),
        (["--cell-file", "cell.toml", "--radius", "0.1"], ("--radius", "--cell-file")),
        (["--cell-file", "cell.toml", "--size-ratio", "2"], ("--size-ratio", "--cell-file")),
        (["--contact", "sticky"], ("--contact", "frictionless", "tied")),
        (["--accuracy", "0.05"], ("--accuracy", "--mesh-level", "--tolerance")),
    ],
)
def test_conflicting_cell_options_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], options: list[str], named: tuple[str, ...]
) -> None:
    (tmp_path / "cell.toml").write_text(
        'lengths_mm = [0.1, 0.1, 0.1]\n[[octants]]\ncorner = "000"\na = 0.1\nc = 0.1\n'
    )
    options = [str(tmp_path / o) if o == "cell.toml" else o for o in options]
    with pytest.raises(SystemExit) as e:
        main(["run", *options, "--stress", "10", "--until-density", "0.9", "--out", str(tmp_path / "o"), *QUICK])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert all(n in err for n in named), err
    assert not (tmp_path / "o").exists()


def test_tied_planes_help_says_it_is_a_sensitivity_option(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as e:
        main(["run", "--help"])
    assert e.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    tied = text[text.rindex("--tied-planes"):]  # its description, after the usage line
    assert "sensitivity option, not the default" in tied[:200]
    for option in ("--cell {sc,bcc,fcc,sc2,random}", "--periodic", "--particles", "--packing-seed", "--cell-file PATH",
                   "--size-ratio", "--contact {frictionless,tied}"):
        assert option in text
