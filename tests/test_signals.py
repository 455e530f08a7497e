"""Stopping a run from outside: a signal in the middle of a step abandons
the step within one Newton iteration, the state left at the last converged
step; ``tidens run`` and sweeps stop on SIGTERM as on Ctrl-C, their
summaries written."""

import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import FrameType

import pytest

import tidens_rs as td

COMMAND = [sys.executable, "-m", "tidens_rs.cli"]
# The sc cell at level 3 to rho = 0.8: about 140 steps of under a tenth of a second.
SC_RUN = ["--cell", "sc", "--until-density", "0.8", "--mesh-level", "3", "--no-error-estimate", "--quiet"]
# At level 2 to rho = 0.6, for a run that is resumed to its end: about 80
# steps of a few hundredths of a second.
SHORT_RUN = ["--cell", "sc", "--until-density", "0.6", "--mesh-level", "2", "--no-error-estimate", "--quiet", "--no-plot"]


def rows(curve: Path) -> int:
    """Data rows of a curve file (0 if it is not there yet)."""
    try:
        with curve.open() as f:
            return sum(1 for _ in csv.reader(f)) - 1
    except FileNotFoundError:
        return 0


def wait_for_rows(curves: list[Path], n: int, process: subprocess.Popen[str]) -> None:
    """Waits until every curve has ``n`` rows (the runs under way)."""
    while not all(rows(c) >= n for c in curves):
        assert process.poll() is None, process.communicate()
        time.sleep(0.05)


def test_a_signal_in_the_middle_of_a_step_abandons_it_and_the_run_goes_on() -> None:
    # The sc lattice as a periodic cell (one whole sphere): its first step
    # takes 6 Newton iterations of about a tenth of a second here, each far
    # longer than the 10 ms between the alarms (the fcc lattice's 4 of a
    # third of a second made the test take four times as long).
    case = td.Case(td.cells.as_periodic(td.cells.sc()), td.materials.TI64_CREEP_1293K, 10.0,
                   solver=td.SolverSettings(mesh_level=1, tolerance=0.08))
    through, sim = case.simulation(0.8, None, (), None), case.simulation(0.8, None, (), None)
    first = through.advance()
    calls = 0

    def second_call_raises(signum: int, frame: FrameType | None) -> None:
        nonlocal calls
        calls += 1
        if calls == 2:
            raise KeyboardInterrupt

    # SIGALRM every 10 ms: the solver runs the handler before each Newton
    # iteration, and the second call raises.
    before = signal.signal(signal.SIGALRM, second_call_raises)
    signal.setitimer(signal.ITIMER_REAL, 0.01, 0.01)
    try:
        with pytest.raises(KeyboardInterrupt):
            sim.advance()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)
    stats = sim.stats()
    # Stopped in the middle of the step: some of its iterations done, none
    # of it kept, and not counted as a failed attempt.
    assert 1 <= stats["newton_iterations"] < first["newton_iterations"], (stats, first)
    assert stats["steps"] == 0 and stats["failed_attempts"] == 0
    assert len(sim.curve()["time_s"]) == 1 and sim.status == "running"
    again = sim.advance()
    assert (again["step"], again["time_s"], again["dt_s"]) == (first["step"], first["time_s"], first["dt_s"])
    assert again["rel_density"] == pytest.approx(first["rel_density"], rel=1e-9)


def test_sigterm_stops_a_run_as_ctrl_c_does(tmp_path: Path) -> None:
    out = tmp_path / "run"
    process = subprocess.Popen([*COMMAND, "run", *SHORT_RUN, "--stress", "10", "--out", str(out)], stderr=subprocess.PIPE, text=True)
    wait_for_rows([out / "curve.csv"], 5, process)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signal.SIGTERM, err
    said = err.strip().splitlines()
    assert f"tidens: terminated by SIGTERM; partial results in {out}" in said, err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["message"] == "terminated by SIGTERM"
    assert rows(out / "curve.csv") == summary["steps"] + 1 and summary["final_density"] < 0.6
    # Stopped between two checkpoints (every 50 steps): its last step is
    # saved too, and the message says how to go on from either.
    assert summary["steps"] % 50 != 0 and (out / "checkpoint_stop.bin").exists()
    assert said[-1].startswith(f"tidens: go on with tidens run --resume {out} ") and "--from-last-step" in said[-1]
    resumed = subprocess.run([*COMMAND, "run", "--resume", str(out), "--from-last-step", "--quiet", "--no-plot"], capture_output=True, text=True, check=False)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((out / "summary.json").read_text())["status"] == "reached_density"


def test_sigterm_to_a_sweep_stops_its_workers_runs(tmp_path: Path) -> None:
    process = subprocess.Popen(
        [*COMMAND, "sweep", *SC_RUN, "--stress", "5,10", "--workers", "2", "--out", str(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    names = ["sc-ti64-creep-1293k-5MPa-ca1", "sc-ti64-creep-1293k-10MPa-ca1"]
    curves = [tmp_path / n / "curve.csv" for n in names]
    wait_for_rows(curves, 5, process)
    process.send_signal(signal.SIGTERM)  # to the sweep only, not its workers
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signal.SIGTERM, err
    # The sweep passed it on: each worker stopped its run as Ctrl-C would.
    for name in names:
        summary = json.loads((tmp_path / name / "summary.json").read_text())
        assert summary["status"] == "interrupted" and summary["message"] == "terminated by SIGTERM", name
    # And no worker runs on.
    counts = [rows(c) for c in curves]
    time.sleep(1.0)
    assert [rows(c) for c in curves] == counts


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent's death signal is Linux's")
def test_a_sweep_killed_outright_leaves_no_worker_running(tmp_path: Path) -> None:
    script = (
        "import tidens_rs as td\n"
        "from tidens_rs import sweep\n"
        "base = td.Case(cell=td.cells.sc(), material=td.materials.TI64_CREEP_1293K, stress_mpa=10.0,\n"
        "               solver=td.SolverSettings(mesh_level=3))\n"
        f"sweep.run(base, {str(tmp_path)!r}, until_density=0.8, stresses_mpa=[5.0, 10.0], workers=2, error_estimate=False)\n"
    )
    process = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    names = ["sc-ti64-creep-1293k-5MPa-ca1", "sc-ti64-creep-1293k-10MPa-ca1"]
    curves = [tmp_path / n / "curve.csv" for n in names]
    wait_for_rows(curves, 5, process)
    process.kill()  # SIGKILL: nothing runs in the sweep's process
    process.communicate(timeout=60)
    # Its workers got SIGTERM from the kernel and stopped their runs as
    # Ctrl-C would.
    summaries = [tmp_path / n / "summary.json" for n in names]
    deadline = time.monotonic() + 60
    while not all(s.exists() for s in summaries) and time.monotonic() < deadline:
        time.sleep(0.05)
    for summary in summaries:
        s = json.loads(summary.read_text())
        assert s["status"] == "interrupted" and s["message"] == "terminated by SIGTERM", summary
    counts = [rows(c) for c in curves]
    time.sleep(1.0)
    assert [rows(c) for c in curves] == counts


@pytest.mark.parametrize(
    "command",
    [
        ["pack", "--particles", "2000", "--jam"],
        # 300 spheres at level 1 fit in memory (about 18 GB estimated), so the
        # run starts and packs; 10000 would be refused before the packing.
        ["run", "--cell", "random", "--particles", "300", "--mesh-level", "1", "--stress", "10", "--until-density", "0.9",
         "--quiet", "--no-error-estimate"],
    ],
    ids=["pack", "run"],
)
def test_sigterm_stops_a_packing_under_way(command: list[str], tmp_path: Path) -> None:
    # Jamming 2000 spheres takes minutes, 300 several seconds; the signal
    # lands in it (the command's imports take well under the 2 s waited).
    out = tmp_path / ("p.txt" if command[0] == "pack" else "run")
    process = subprocess.Popen([*COMMAND, *command, "--out", str(out)], stderr=subprocess.PIPE, text=True)
    time.sleep(2.0)
    assert process.poll() is None, process.communicate()
    sent = time.monotonic()
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert time.monotonic() - sent < 1.0
    assert process.returncode == 128 + signal.SIGTERM, err
    assert "tidens: terminated by SIGTERM" in err
