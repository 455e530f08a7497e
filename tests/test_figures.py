"""The studies behind `tidens figures`: the rate read off a curve, the
surface drawn, Norton similarity in C, results loaded back from their
folders, and one figure made end to end on a coarse mesh."""

import json
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs import figures

BASE = td.materials.TI64_CREEP_1293K


def test_the_rate_read_off_a_curve_is_the_rate_that_made_it() -> None:
    # rho_dot = A exp(b rho): t(rho) = (exp(-b rho0) - exp(-b rho)) / (A b).
    a, b, rho0 = 2e-3, 9.0, 0.52
    rho = np.linspace(rho0, 0.97, 4001)
    t = (np.exp(-b * rho0) - np.exp(-b * rho)) / (a * b)
    grid = np.linspace(0.55, 0.95, 161)
    rate = figures.densification_rate(t, rho, grid)
    # Second-order differences on a grid of h = 0.0025: relative error
    # (b h)^2 / 6 = 8.4e-5 inside, (b h)^2 / 3 = 1.7e-4 at the two ends.
    err = np.abs(rate / (a * np.exp(b * grid)) - 1.0)
    assert np.max(err[1:-1]) < 1e-4 and np.max(err) < 2e-4
    slope, intercept, deviation = figures.log_rate_fit(grid, rate)
    assert slope == pytest.approx(b / math.log(10.0), rel=1e-5)
    assert intercept == pytest.approx(math.log10(a), abs=1e-4)  # the 8.4e-5 relative error: 3.7e-5 decades
    assert deviation < 1e-4
    # Outside the curve there is no rate.
    assert np.isnan(figures.densification_rate(t, rho, np.array([0.5, 0.51, 0.98, 0.99]))).all()


def _block(nx: int, ny: int, nz: int) -> tuple[np.ndarray, np.ndarray]:
    def node(i: int, j: int, k: int) -> int:
        return i + (nx + 1) * (j + (ny + 1) * k)

    points = np.array([[i, j, k] for k in range(nz + 1) for j in range(ny + 1) for i in range(nx + 1)], dtype=float)
    cells = [
        [node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
         node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)]
        for k in range(nz) for j in range(ny) for i in range(nx)
    ]
    return points, np.array(cells)


def test_the_surface_drawn_is_the_boundary_facing_out() -> None:
    points, cells = _block(2, 3, 4)
    faces, owner = figures.boundary_faces(cells)
    assert len(faces) == 2 * (2 * 3 + 3 * 4 + 4 * 2)
    for f, e in zip(faces, owner):
        p = points[f]
        normal = np.cross(p[2] - p[0], p[3] - p[1])
        assert np.dot(normal, p.mean(axis=0) - points[cells[e]].mean(axis=0)) > 0
        # Every boundary face lies on a side of the block's box.
        flat = [axis for axis in range(3) if np.all(p[:, axis] == p[0, axis]) and p[0, axis] in (0.0, (2, 3, 4)[axis])]
        assert len(flat) == 1
    # A closed surface: the outward area vectors sum to zero.
    total = sum(np.cross(points[f][2] - points[f][0], points[f][3] - points[f][1]) for f in faces)
    assert np.allclose(total, 0.0)


def press(material: td.Material, stress: float = 10.0, out: Path | None = None) -> td.Result:
    case = td.Case(cell=td.cells.sc(), material=material, stress_mpa=stress,
                   solver=td.SolverSettings(mesh_level=1, tolerance=0.01))
    return case.run(0.9, out_dir=out, error_estimate=False)


def test_norton_similarity_in_c_maps_one_temperature_to_another() -> None:
    # The same n at another temperature: C 30 times larger is a time unit
    # 30 times shorter (but for the 1 s ramp, which t_eff accounts for).
    hot = td.materials.custom(30.0 * BASE.creep_c, BASE.creep_n)
    src, truth = press(BASE), press(hot)
    m = td.similarity.map_curve(src, 10.0, creep_c=hot.creep_c)
    assert m.creep_c == hot.creep_c
    for rho in (0.7, 0.8, 0.9):
        mapped, computed = m.time_to_density(rho), truth.time_to_density(rho)
        assert mapped is not None and computed is not None
        # Observed: 3e-4 at most (the two runs step differently).
        assert abs(mapped / computed - 1.0) < 5e-3, (rho, mapped, computed)
    # Mapping C and stress together composes: C x 30 at 10 MPa equals
    # C x 1 at 10 * 30^(1/n) MPa.
    s_eq = 10.0 * 30.0 ** (1.0 / BASE.creep_n)
    by_stress = td.similarity.map_curve(src, s_eq, ramp_time_s=1.0)
    by_c = td.similarity.map_curve(src, 10.0, creep_c=hot.creep_c)
    late = src.time_s > 2.0
    assert np.allclose(by_stress.time_s[late], by_c.time_s[late], rtol=1e-12)
    with pytest.raises(ValueError, match="creep_c"):
        td.similarity.map_curve(src, 10.0, creep_c=-1.0)


def test_a_result_loaded_from_its_folder_is_the_run(tmp_path: Path) -> None:
    case = td.Case(cell=td.cells.sc(), material=BASE, stress_mpa=10.0, solver=td.SolverSettings(mesh_level=2, tolerance=0.04))
    r = case.run(0.7, out_dir=tmp_path / "run")
    back = td.load(tmp_path / "run")
    assert back.case.as_dict() == r.case.as_dict() and back.status == r.status
    assert np.allclose(back.time_s, r.time_s, rtol=1e-12, atol=0) and np.array_equal(back.rel_density, r.rel_density)
    assert back.estimate() == r.estimate()
    assert back.summary()["times_to_density_s"] == pytest.approx(r.summary()["times_to_density_s"], rel=1e-12)
    with pytest.raises(FileNotFoundError, match="no run to load"):
        td.load(tmp_path)
    (tmp_path / "bad").mkdir()
    for name in ("run.json", "curve.csv", "summary.json"):
        (tmp_path / "bad" / name).write_text("{}")
    with pytest.raises(ValueError, match="bad/run.json: not the record of a run"):
        td.load(tmp_path / "bad")


def test_the_aspect_ratio_figure_end_to_end(tmp_path: Path) -> None:
    made = figures.make(tmp_path, level=1, figures=["aspect_ratio"], workers=1)
    names = {p.name for p in made.files}
    assert {"aspect_ratio.png", "aspect_ratio.pdf", "captions.md", "findings.md"} <= names
    assert (tmp_path / "aspect_ratio.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(made.runs) == 6 and all(r["status"] == "reached_density" for r in made.runs)
    # The findings quote the runs' own times to rho = 0.9, and tying the
    # particle to the planes slows it at every aspect ratio.
    t9 = {(round(r["aspect_ratio"], 9), r["name"].endswith("-tied-L1")): r["t_0.9_s"] for r in made.runs}
    for k in figures.ASPECT_RATIOS:
        assert t9[(k, True)] > t9[(k, False)]
    text = (tmp_path / "findings.md").read_text()
    for (k, tied), t in t9.items():
        assert f"{t:.4g}" in text
    # A second call runs nothing again.
    again = figures.make(tmp_path, level=1, figures=["aspect_ratio"], workers=1)
    stamps = {r["name"]: json.loads((Path(r["folder"]) / "summary.json").read_text())["wall_seconds"] for r in again.runs}
    assert stamps == {r["name"]: r["wall_seconds"] for r in made.runs}


def test_the_random_packings_figure_plans_its_packings_first_and_draws_their_contacts(tmp_path: Path) -> None:
    runs = figures.plan(level=2, figures=["random_packings"])
    mono, bimodal = figures.random_job_name(None), figures.random_job_name(figures.RANDOM_BIMODAL)
    lattices = [figures.job_name(c, figures.CREEP, 10.0, level=figures.RANDOM_LEVEL) for c in figures.RANDOM_LATTICES]
    assert set(runs.jobs) == {mono, bimodal, *lattices}
    for name in (mono, bimodal):
        cell = runs.jobs[name].case.cell
        assert cell.is_periodic and len(cell.particles) == figures.RANDOM_PARTICLES
        assert runs.jobs[name].case.solver.mesh_level == figures.RANDOM_LEVEL
        assert runs.jobs[name].case.solver.checkpoint_every == figures.RANDOM_CHECKPOINT_EVERY
    radii = {p[1] for p in runs.jobs[bimodal].case.cell.particles}
    assert max(radii) / min(radii) == pytest.approx(figures.RANDOM_BIMODAL[0], rel=1e-12)
    # The log names the level the runs use, not the one asked for.
    assert figures.levels_said(list(runs.jobs.values()), 2) == f"mesh level {figures.RANDOM_LEVEL}"
    both = figures.plan(level=2, figures=["random_packings", "aspect_ratio"])
    assert figures.levels_said(list(both.jobs.values()), 2) == f"mesh levels {figures.RANDOM_LEVEL}, 2"
    # The packings, hours long, start first.
    order = [j.name for j in sorted(runs.jobs.values(), key=figures._cost, reverse=True)]
    assert set(order[:2]) == {mono, bimodal}
    # Drawn with the periodic sc lattice (one whole sphere, six contacts)
    # standing in for a random packing: its contacts and the model's times.
    case = td.Case(cell=td.cells.as_periodic(td.cells.sc()), material=BASE, stress_mpa=10.0,
                   solver=td.SolverSettings(mesh_level=1))
    stand_in = case.run(0.53, error_estimate=False)
    runs.results[mono] = stand_in
    files, caption, _ = figures._random_packings(runs, tmp_path)
    assert (tmp_path / "random_packings.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and len(files) == 2
    row = next(line for line in caption.splitlines() if line.startswith("| random, one size"))
    s = stand_in.summary()
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1:6] == ["1", f"{stand_in.rho0:.4f}", "6.00", "6.00", "reached_density"]
    assert cells[10] == f"{float(stand_in.continuum().time_to_density(0.8)[0]):.1f} s"
    assert "0.8" not in s["continuum_times_to_density_s"]  # the run stopped at 0.53


def test_drawing_only_draws_the_runs_as_their_folders_hold_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from matplotlib.figure import Figure

    from tidens_rs.cli import main

    # The figures are drawn to PNG; their PDFs are written empty (the PDF
    # writer is the aspect-ratio test's): drawing the nine figures to PDF
    # too took 5 of this test's 20 s.
    savefig = Figure.savefig

    def png_only(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> None:
        if kwargs.get("format") == "pdf":
            Path(fname).write_bytes(b"")
        else:
            savefig(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", png_only)

    runs = figures.plan(level=1, figures=["random_packings"])
    mono = figures.random_job_name(None)
    sc = figures.job_name("sc", figures.CREEP, 10.0, level=figures.RANDOM_LEVEL)
    folder = tmp_path / figures.RUNS
    with pytest.raises(TypeError, match="draw_only"):
        figures.make(tmp_path, figures=["random_packings"], draw_only="yes")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="from_last_step"):
        figures.make(tmp_path, figures=["random_packings"], draw_only=True, from_last_step=1)  # type: ignore[arg-type]
    # A folder of no figures' runs at all: refused, nothing drawn.
    with pytest.raises(FileNotFoundError, match="holds no runs to draw from"):
        figures.make(tmp_path, level=1, figures=figures.FIGURES, draw_only=True)
    assert not list(tmp_path.glob("*.png"))
    # The runs' folder made, nothing run yet: every run missing, none
    # started, every figure drawn (without a warning: no empty legend).
    folder.mkdir()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        empty = figures.make(tmp_path, level=1, figures=figures.FIGURES, draw_only=True)
    assert {r["status"] for r in empty.runs} == {"missing"} and not any(folder.iterdir())
    assert all((tmp_path / f"{name}.png").exists() for name in figures.FIGURES)
    # The sc lattice finished; the one-size packing's folder holding a run
    # killed at step 12 (the periodic sc lattice standing in for it: a
    # summary deleted, as a killed run leaves none).
    runs.jobs[sc].case.run(figures.UNTIL_DENSITY, out_dir=folder / sc, error_estimate=False)
    stand_in = td.Case(cell=td.cells.as_periodic(td.cells.sc()), material=BASE, stress_mpa=10.0,
                       solver=td.SolverSettings(mesh_level=1))

    def stop(point: dict[str, float]) -> bool:
        return point["step"] < 12

    stand_in.run(0.6, out_dir=folder / mono, callback=stop, error_estimate=False)
    (folder / mono / "summary.json").unlink()
    partial = td.load(folder / mono)
    capsys.readouterr()
    assert main(["figures", "--out", str(tmp_path), "--only", "random_packings", "--draw-only", "--quiet"]) == 0
    assert "not finished: " + mono in capsys.readouterr().out
    captions = (tmp_path / figures.CAPTIONS).read_text()
    assert "Drawn by `tidens figures --draw-only`" in captions and f"`{mono}` (interrupted)" in captions
    assert f"`{sc}`" not in captions.split("\n\n")[1]  # finished: not named as unfinished
    row = next(line for line in captions.splitlines() if line.startswith("| random, one size"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[5:7] == ["interrupted", f"{partial.rel_density[-1]:.4f}"] and len(partial.time_s) == 13
    # Nothing was run: the folders are as they were.
    assert sorted(p.name for p in folder.iterdir()) == sorted([mono, sc])
    assert not (folder / mono / "summary.json").exists()


def test_a_run_that_failed_is_reported_with_its_reason() -> None:
    row: dict[str, Any] = {"name": "random32", "status": "failed", "wall_seconds": None,
           "reason": "worker exited with status 1: ValueError: checkpoint: taken with other solver settings"}
    assert figures.row_line(row).endswith(": failed (-): " + row["reason"])
    row.update(status="reached_density", wall_seconds=12.0, reason=None)
    assert figures.row_line(row) == f"  random32: reached_density ({figures._seconds(12.0)})"
