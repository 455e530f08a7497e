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
                "newton_iterations", "degrees_of_freedom", "mesh_level", "tolerance"):
        assert key in s
    assert s["mesh_level"] == 1 and s["tolerance"] == 0.05
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
