"""Sweeps: every point run once, in parallel worker processes or on a Dask
cluster, into its own folder and one table; a restarted sweep skips the
finished points and resumes an interrupted one."""

import json
import math
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs import sweep
from tidens_rs.cli import main

QUICK = td.SolverSettings(mesh_level=1, tolerance=0.05, checkpoint_every=10)
# Past rho = 0.7, whose time the tables compare (sc 51 steps, bcc 12 at 10
# MPa; to 0.75, 55 and 20).
UNTIL = 0.72


def base() -> td.Case:
    return td.Case(cell=td.cells.sc(), material=td.materials.TI64_CREEP_1293K, stress_mpa=10.0, solver=QUICK)


def times(rows: list[dict[str, Any]]) -> dict[str, float]:
    return {r["name"]: r["t_0.7_s"] for r in rows}


# The sweep of two stresses on two cells, run on two worker processes.
POINTS: dict[str, Any] = dict(until_density=UNTIL, stresses_mpa=[5.0, 10.0], cells=["sc", "bcc"], error_estimate=False)


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict[str, Any]]]:
    """The sweep of ``POINTS`` on two local workers, run once for the tests
    that check it and compare another scheduler's with it: its folder and
    its rows."""
    folder = tmp_path_factory.mktemp("local")
    return folder, sweep.run(base(), folder, workers=2, **POINTS)


def test_every_point_runs_once_in_parallel_into_its_folder_and_the_table(local_sweep: tuple[Path, list[dict[str, Any]]]) -> None:
    tmp_path, rows = local_sweep
    names = [r["name"] for r in rows]
    assert names == ["sc-ti64-creep-1293k-5MPa-ca1", "sc-ti64-creep-1293k-10MPa-ca1", "bcc-ti64-creep-1293k-5MPa-ca1", "bcc-ti64-creep-1293k-10MPa-ca1"]
    assert all(r["status"] == "reached_density" for r in rows)
    for r in rows:
        summary = json.loads((tmp_path / r["name"] / "summary.json").read_text())
        assert summary["times_to_density_s"]["0.7"] == r["t_0.7_s"]
        assert (summary["cell"]["name"], summary["load"]["stress_mpa"]) == (r["cell"], r["stress_mpa"])
    # The table on disk, as CSV and as Parquet, is the one returned.
    assert times(sweep.read_table(tmp_path)) == times(rows)
    pq = pytest.importorskip("pyarrow.parquet")
    table = pq.read_table(tmp_path / sweep.TABLE_PARQUET).to_pylist()
    assert [r["name"] for r in table] == names and times(table) == times(rows)
    # A worker process (one thread) gives what a run in this process gives,
    # to the bit (results do not depend on the thread count).
    direct = td.Case(cell=td.cells.bcc(), material=td.materials.TI64_CREEP_1293K, stress_mpa=5.0, solver=QUICK).run(until_density=UNTIL, error_estimate=False)
    assert direct.time_to_density(0.7) == rows[2]["t_0.7_s"]
    # Norton similarity between the stresses on sc, which reaches 0.7 long
    # after the 1 s ramp: t_eff = t - n t_ramp / (n + 1) goes as sigma^-n, up
    # to the elastic and contact compliance (well below 1 % here).
    n = td.materials.TI64_CREEP_1293K.creep_n
    t5, t10 = (next(r["t_0.7_s"] - n / (n + 1) for r in rows if r["cell"] == "sc" and r["stress_mpa"] == s) for s in (5.0, 10.0))
    assert t5 / t10 == pytest.approx(2**n, rel=0.01)
    # The cores are shared among the workers that run at once: four points
    # on two workers, and then, the sweep called again for its one point
    # left, all the cores for that one, to the same curve.
    cores = os.cpu_count() or 1
    threads = {r["name"]: json.loads((tmp_path / r["name"] / "summary.json").read_text())["stats"]["solver_threads"] for r in rows}
    assert set(threads.values()) == {max(1, cores // 2)}
    last = tmp_path / names[-1]
    curve = (last / "curve.csv").read_text()
    shutil.rmtree(last)
    again = sweep.run(base(), tmp_path, workers=2, **POINTS)
    assert json.loads((last / "summary.json").read_text())["stats"]["solver_threads"] == cores
    assert (last / "curve.csv").read_text() == curve and times(again) == times(rows)
    assert [sweep.worker_threads(8, 4, k) for k in (0, 1, 2, 3, 4, 9)] == [8, 8, 4, 2, 2, 2]


def test_a_point_under_way_is_reported_with_its_last_converged_step(tmp_path: Path) -> None:
    seen: list[tuple[str, dict[str, float]]] = []
    [row] = sweep.run(base(), tmp_path, until_density=UNTIL, workers=1, error_estimate=False,
                      on_point=lambda name, p: seen.append((name, p)), point_every_s=0.02)
    assert len(seen) >= 2 and {name for name, _ in seen} == {row["name"]}
    # Each report is a row of the finished curve, the steps in order.
    curve = np.loadtxt(tmp_path / row["name"] / "curve.csv", delimiter=",", skiprows=1)
    header = (tmp_path / row["name"] / "curve.csv").read_text().splitlines()[0].split(",")
    steps = [int(p["step"]) for _, p in seen]
    assert steps == sorted(steps) and steps[-1] > steps[0]
    for _, p in seen:
        k = int(p["step"])
        assert [p[c] for c in header] == pytest.approx(curve[k], rel=0, abs=0, nan_ok=True)
    with pytest.raises(ValueError, match="point_every_s"):
        sweep.run(base(), tmp_path, until_density=UNTIL, workers=1, point_every_s=0)


def test_a_restarted_sweep_goes_on_from_a_points_last_step_if_asked(tmp_path: Path) -> None:
    first, second = sweep.plan(base(), stresses_mpa=[10.0, 5.0])
    folder = tmp_path / first.name
    # The first point was interrupted (Ctrl-C) at step 25: its last
    # checkpoint is step 20, and step 25 is saved beside it.
    def stop(p: dict[str, float]) -> None:
        if p["step"] == 25:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        base().run(until_density=UNTIL, out_dir=folder, callback=stop, error_estimate=False)
    stopped = np.loadtxt(folder / "curve.csv", delimiter=",", skiprows=1)
    assert len(stopped) == 26 and (folder / "checkpoint_stop.bin").exists()
    with pytest.raises(TypeError, match="from_last_step"):
        sweep.run(base(), tmp_path, until_density=UNTIL, stresses_mpa=[10.0, 5.0], from_last_step="yes")  # type: ignore[arg-type]
    # Step 20's checkpoint spoilt: a resume from it fails, one from the
    # last step does not read it. In a worker process (two points).
    (folder / "checkpoint.bin").write_bytes(b"spoilt")
    rows = sweep.run(base(), tmp_path, until_density=UNTIL, stresses_mpa=[10.0, 5.0], workers=2, error_estimate=False,
                     from_last_step=True)
    assert [r["status"] for r in rows] == ["reached_density"] * 2, rows
    resumed = np.loadtxt(folder / "curve.csv", delimiter=",", skiprows=1)
    assert np.array_equal(resumed[:26], stopped, equal_nan=True)
    whole = base().run(until_density=UNTIL, out_dir=tmp_path / "whole", error_estimate=False)
    assert rows[0]["t_0.7_s"] == pytest.approx(whole.time_to_density(0.7), rel=1e-4)
    assert not (folder / "checkpoint_stop.bin").exists()


def test_a_restarted_sweep_resumes_an_interrupted_point_and_skips_finished_ones(tmp_path: Path) -> None:
    point = sweep.plan(base())[0]
    folder = tmp_path / point.name
    # The point was interrupted (Ctrl-C) at step 25; its last checkpoint is step 20.
    steps = 0

    def stop(_: dict[str, float]) -> bool:
        nonlocal steps
        steps += 1
        if steps == 25:
            raise KeyboardInterrupt
        return True

    with pytest.raises(KeyboardInterrupt):
        base().run(until_density=UNTIL, out_dir=folder, callback=stop, error_estimate=False)
    assert json.loads((folder / "summary.json").read_text())["status"] == "interrupted"
    [row] = sweep.run(base(), tmp_path, until_density=UNTIL, workers=1, error_estimate=False)
    assert row["status"] == "reached_density"
    # The resumed curve is the uninterrupted one, to the bit.
    whole = base().run(until_density=UNTIL, out_dir=tmp_path / "whole", error_estimate=False)
    resumed = np.loadtxt(folder / "curve.csv", delimiter=",", skiprows=1)
    assert np.array_equal(resumed, np.loadtxt(tmp_path / "whole" / "curve.csv", delimiter=",", skiprows=1), equal_nan=True)
    assert row["t_0.7_s"] == whole.time_to_density(0.7)
    # Run again: the finished point is not run again.
    stamp = (folder / "summary.json").stat().st_mtime_ns
    [again] = sweep.run(base(), tmp_path, until_density=UNTIL, workers=1, error_estimate=False)
    assert (folder / "summary.json").stat().st_mtime_ns == stamp and again["t_0.7_s"] == row["t_0.7_s"]
    # A point whose checkpoint interval changed is the same point: an
    # interrupted run of it goes on with the new interval.
    (folder / "summary.json").unlink()
    often = td.Case.from_dict({**base().as_dict(), "solver": {**QUICK.as_dict(), "checkpoint_every": 7}})
    [row] = sweep.run(often, tmp_path, until_density=UNTIL, workers=1, error_estimate=False)
    assert row["status"] == "reached_density"
    assert json.loads((folder / "run.json").read_text())["case"]["solver"]["checkpoint_every"] == 7
    # A folder of another case is not taken for the point's.
    with pytest.raises(FileExistsError, match=point.name):
        sweep.run(base(), tmp_path, until_density=0.7, workers=1)


def test_a_dask_cluster_of_two_workers_runs_the_same_sweep(tmp_path: Path, local_sweep: tuple[Path, list[dict[str, Any]]]) -> None:
    distributed = pytest.importorskip("dask.distributed")
    # The two points on sc, one for each worker, against the local sweep's.
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, env={"RAYON_NUM_THREADS": "1"}) as cluster:
        on_dask = sweep.run(base(), tmp_path / "dask", scheduler=cluster.scheduler_address, **{**POINTS, "cells": ["sc"]})
    _, local = local_sweep
    assert len(on_dask) == 2 and times(on_dask) == {k: v for k, v in times(local).items() if k.startswith("sc-")}
    assert all(r["folder"].startswith(str(tmp_path / "dask")) for r in on_dask)


def test_the_command_sweeps_and_names_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cli"
    argv = ["sweep", "--stress", "5,10", "--cell", "sc", "--until-density", str(UNTIL), "--mesh-level", "1", "--tolerance", "0.05", "--no-error-estimate", "--quiet", "--out", str(out)]
    assert main(argv) == 0
    rows = sweep.read_table(out)
    assert [r["stress_mpa"] for r in rows] == [5.0, 10.0] and all(r["status"] == "reached_density" for r in rows)
    assert "sc-ti64-creep-1293k-10MPa-ca1" in capsys.readouterr().out
    for bad, named in ((["--stress", "5,-1"], "stresses_mpa[1]"), (["--cell", "hcp"], "--cell"), (["--workers", "0"], "workers")):
        args = list(argv)
        flag = bad[0]
        if flag in args:
            i = args.index(flag)
            args[i : i + 2] = bad
        else:
            args[1:1] = bad
        with pytest.raises(SystemExit) as e:
            main(args)
        assert e.value.code == 2
        assert named in capsys.readouterr().err


@pytest.mark.parametrize(
    ("kwargs", "error", "named"),
    [
        ({"stresses_mpa": [10.0, math.nan]}, ValueError, "stresses_mpa[1]"),
        ({"stresses_mpa": "10"}, TypeError, "stresses_mpa"),
        ({"cells": ["hcp"]}, ValueError, "cells"),
        ({"materials": [1.0]}, TypeError, "materials"),
        ({"stresses_mpa": [10.0, 10.0]}, ValueError, "repeated"),
        ({"workers": 0}, ValueError, "workers"),
        ({"workers": 2, "scheduler": "tcp://x:1"}, ValueError, "scheduler"),
    ],
)
def test_bad_sweeps_are_refused_before_any_point_runs(tmp_path: Path, kwargs: dict[str, Any], error: type[Exception], named: str) -> None:
    with pytest.raises(error, match=named.replace("[", r"\[").replace("]", r"\]")):
        sweep.run(base(), tmp_path / "x", until_density=UNTIL, **kwargs)
    assert not (tmp_path / "x").exists()
