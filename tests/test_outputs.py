"""Nothing lost or corrupted: output folders, atomic files, write failures,
and the curve file agreeing with the summary after any stop."""

import csv
import errno
import json
import re
import shutil
from pathlib import Path
from typing import Any

import meshio
import numpy as np
import pytest

import tidens_rs as td
from tidens_rs import io
from tidens_rs.cli import main
from tidens_rs.result import MARK_DENSITIES


def rows(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def test_a_run_into_a_folder_with_files_is_refused_unless_overwrite(quick_case: td.Case, tmp_path: Path) -> None:
    out = tmp_path / "run"
    quick_case.run(until_density=0.6, out_dir=out, snapshot_densities=[0.55], error_estimate=False)
    assert (out / "fields_rho0.550.vtu").exists()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        quick_case.run(until_density=0.58, out_dir=out, error_estimate=False)
    # Overwrite: the earlier run's outputs go (no stale snapshot stays), the new ones come.
    r = quick_case.run(until_density=0.58, out_dir=out, error_estimate=False, overwrite=True)
    assert not (out / "fields_rho0.550.vtu").exists()
    s = json.loads((out / "summary.json").read_text())
    assert s["final_density"] == pytest.approx(r.rel_density[-1], rel=1e-12)
    # A file that is not an output is never deleted: the folder is refused.
    (out / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="notes.txt"):
        quick_case.run(until_density=0.58, out_dir=out, overwrite=True)
    assert (out / "notes.txt").read_text() == "mine" and (out / "summary.json").exists()


def test_bad_input_leaves_an_earlier_run_untouched(quick_case: td.Case, tmp_path: Path) -> None:
    out = tmp_path / "run"
    quick_case.run(until_density=0.56, out_dir=out, error_estimate=False)
    before = sorted(p.name for p in out.iterdir())
    # Refused when the simulation is set up: a periodic cell meshed with tet10.
    tet10 = td.SolverSettings(mesh_level=1, element="tet10")
    bad = td.Case(cell=td.cells.as_periodic(td.cells.sc()), material=quick_case.material, stress_mpa=10.0, solver=tet10)
    with pytest.raises(ValueError, match="hex8 elements only"):
        bad.run(until_density=0.6, out_dir=out, overwrite=True)
    assert sorted(p.name for p in out.iterdir()) == before


def test_a_failed_write_names_the_file_keeps_what_was_written_and_leaves_no_truncated_file(
    quick_case: td.Case, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def full_disk(path: Any, *args: Any, **kwargs: Any) -> None:
        Path(path).write_bytes(b"<VTKFile trunc")  # a partial write, then the failure
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(meshio, "write", full_disk)
    out = tmp_path / "run"
    with pytest.raises(io.OutputError) as e:
        quick_case.run(until_density=0.6, out_dir=out, snapshot_densities=[0.55], error_estimate=False)
    assert e.value.filename == str(out / "fields_rho0.550.vtu") and e.value.errno == errno.ENOSPC
    assert "cannot write" in str(e.value) and "No space left" in str(e.value)
    # The result travels with the error; the curve and the summary were written and agree.
    result = e.value.result
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "reached_density" and s["steps"] == len(rows(out / "curve.csv")) - 1
    assert s["final_density"] == pytest.approx(result.rel_density[-1], rel=1e-12)
    # No VTU under its final name, no temporary file left.
    assert not list(out.glob("*.vtu")) and not list(out.glob("*.part"))


def test_the_curve_file_and_the_summary_agree_after_an_interrupt_between_step_and_row(
    quick_case: td.Case, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Ctrl-C arriving after a step converged but before its row was written.
    original = io.CurveWriter.write
    calls = {"n": 0}

    def interrupted(self: io.CurveWriter, point: dict[str, float]) -> None:
        calls["n"] += 1
        if calls["n"] == 6:
            raise KeyboardInterrupt
        original(self, point)

    monkeypatch.setattr(io.CurveWriter, "write", interrupted)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        quick_case.run(until_density=0.9, out_dir=out)
    s = json.loads((out / "summary.json").read_text())
    curve = rows(out / "curve.csv")
    assert s["status"] == "interrupted" and s["steps"] == 5
    assert len(curve) == s["steps"] + 1
    assert float(curve[-1]["rel_density"]) == pytest.approx(s["final_density"], rel=1e-12)


def test_the_command_line_reports_a_failed_write_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def full_disk(path: Any, *args: Any, **kwargs: Any) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(meshio, "write", full_disk)
    out = tmp_path / "run"
    code = main(["run", "--stress", "10", "--until-density", "0.58", "--mesh-level", "1", "--quiet", "--no-plot",
                 "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and str(out / "fields_final.vtu") in err, err
    assert (out / "summary.json").exists()
    # Into the same folder again: refused without --overwrite, run with it.
    with pytest.raises(SystemExit) as e:
        main(["run", "--stress", "10", "--until-density", "0.58", "--mesh-level", "1", "--quiet", "--no-plot",
              "--out", str(out)])
    assert e.value.code == 2 and "--overwrite" in capsys.readouterr().err
    monkeypatch.undo()
    assert main(["run", "--stress", "10", "--until-density", "0.58", "--mesh-level", "1", "--quiet", "--no-plot",
                 "--overwrite", "--out", str(out)]) == 0
    assert (out / "fields_final.vtu").exists()


def bcc_every_10() -> td.Case:
    """bcc at level 1 pressed at 15 MPa, checkpoints every 10 steps."""
    return td.Case(
        cell=td.cells.bcc(),
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=15.0,
        solver=td.SolverSettings(mesh_level=1, tolerance=0.02, checkpoint_every=10),
    )


# The runs below stop at rho = 0.77: 48 steps, four checkpoints (to 0.8,
# 72 steps).
UNTIL = 0.77


@pytest.fixture(scope="module")
def through(tmp_path_factory: pytest.TempPathFactory) -> td.Result:
    """``bcc_every_10`` run through to ``UNTIL`` (no companion), once for the
    tests that compare a stopped and resumed run with it."""
    return bcc_every_10().run(until_density=UNTIL, out_dir=tmp_path_factory.mktemp("through"), error_estimate=False)


def stopped_at(case: td.Case, step: int, out: Path) -> None:
    """Runs ``case`` to ``UNTIL`` into ``out`` and stops it (Ctrl-C) at ``step``."""

    def ctrl_c(point: dict[str, float]) -> None:
        if point["step"] >= step:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        case.run(until_density=UNTIL, out_dir=out, callback=ctrl_c, error_estimate=False)


def test_a_damaged_checkpoint_is_refused_naming_the_file(tmp_path: Path) -> None:
    out = tmp_path / "run"
    stopped_at(bcc_every_10(), 5, out)
    checkpoint = out / "checkpoint.bin"
    good = checkpoint.read_bytes()
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0x10
    damages = [
        (good[: len(good) // 3], rf"truncated \(ends after {len(good) // 3} of the {len(good)} bytes a checkpoint needs\): the file is damaged"),
        (b"", r"empty \(0 bytes\)"),
        (bytes(flipped), r"damaged \(its contents do not match their hash\)"),
        (b"run.json", r"not a tidens checkpoint"),
    ]
    for damaged, what in damages:
        checkpoint.write_bytes(damaged)
        with pytest.raises(ValueError, match=f"^{re.escape(str(checkpoint))}: {what}") as e:
            td.resume(out)
        assert "Error {" not in str(e.value) and "Syntax(" not in str(e.value)
    # A run that wrote no summary loads its totals from the checkpoint.
    (out / "summary.json").unlink()
    checkpoint.write_bytes(good[:100])
    with pytest.raises(ValueError, match=f"^{re.escape(str(checkpoint))}: truncated"):
        td.load(out)
    checkpoint.write_bytes(good)
    assert td.load(out).status == "interrupted"


def test_a_run_stopped_in_the_middle_resumes_to_the_same_curve_bit_for_bit(tmp_path: Path) -> None:
    case = bcc_every_10()
    through = case.run(until_density=UNTIL, out_dir=tmp_path / "through", snapshot_densities=[0.72, 0.75])
    steps = through.stats["steps"]
    assert steps > 30

    def ctrl_c(point: dict[str, float]) -> None:
        if point["step"] >= steps // 2 + 3:  # between two checkpoints
            raise KeyboardInterrupt

    out = tmp_path / "stopped"
    with pytest.raises(KeyboardInterrupt):
        case.run(until_density=UNTIL, out_dir=out, snapshot_densities=[0.72, 0.75], callback=ctrl_c)
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"
    resumed = td.resume(out)
    for column, values in through.curve.items():
        assert np.array_equal(values, resumed.curve[column], equal_nan=True), column
    assert (out / "curve.csv").read_text() == (tmp_path / "through" / "curve.csv").read_text()
    a = json.loads((tmp_path / "through" / "summary.json").read_text())
    b = json.loads((out / "summary.json").read_text())
    assert b["status"] == "reached_density" and b["times_to_density_s"] == a["times_to_density_s"]
    assert b["error_estimate"]["relative"] == a["error_estimate"]["relative"]
    # The run time counts the steps before the checkpoint too, which this
    # call did not take (its own wall time also holds writing the outputs).
    assert resumed.run_seconds > resumed.wall_seconds
    assert b["run_seconds"] == resumed.run_seconds
    # The snapshots of both parts are in the collection, once each.
    names = [name for _, name in io.read_pvd(out / "fields.pvd")]
    assert names == [name for _, name in io.read_pvd(tmp_path / "through" / "fields.pvd")]


def test_a_run_resumed_with_another_checkpoint_interval_records_and_keeps_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], through: td.Result
) -> None:
    case = bcc_every_10()
    out = tmp_path / "stopped"
    stopped_at(case, 23, out)
    record = (out / "run.json").read_text()
    with pytest.raises(ValueError, match="checkpoint_every"):
        td.resume(out, checkpoint_every=-1)
    assert (out / "run.json").read_text() == record
    # Checkpoints every 4 steps from step 20 on: the run records it, goes
    # on from step 20 as the through run did, parts from it where it first
    # drops its cached factor the through run kept (step 24), and reaches
    # UNTIL at the same time to round-off (9.0e-7 relative, measured; 5.6e-7
    # to rho = 0.8).
    assert main(["run", "--resume", str(out), "--checkpoint-every", "4", "--quiet", "--no-plot"]) == 0
    assert "resumed" in capsys.readouterr().out
    assert json.loads((out / "run.json").read_text())["case"]["solver"]["checkpoint_every"] == 4
    resumed = td.load(out)
    assert resumed.status == "reached_density"
    for column, values in through.curve.items():
        assert np.array_equal(values[:25], resumed.curve[column][:25], equal_nan=True), column
    assert not np.array_equal(through.time_s, resumed.time_s)
    t_through, t_resumed = through.time_to_density(UNTIL), resumed.time_to_density(UNTIL)
    assert t_resumed == pytest.approx(t_through, rel=1e-4)
    # The last checkpoint is the last step that is a multiple of 4.
    sim = case.simulation(UNTIL, None, [], resume_from=(out / "checkpoint.bin").read_bytes())
    steps = len(resumed.time_s) - 1
    assert len(sim.curve()["time_s"]) - 1 == steps - steps % 4


def test_a_run_stopped_between_checkpoints_goes_on_from_its_last_step_if_asked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], through: td.Result
) -> None:
    case = bcc_every_10()
    out = tmp_path / "stopped"
    stopped_at(case, 25, out)
    stop = out / "checkpoint_stop.bin"
    assert stop.exists()
    with pytest.raises(TypeError, match="from_last_step"):
        td.resume(out, from_last_step=1)  # type: ignore[arg-type]

    def first_step(**kwargs: Any) -> int:
        """The first step a resume into a copy of the stopped run takes."""
        copy = tmp_path / f"copy{len(list(tmp_path.iterdir()))}"
        shutil.copytree(out, copy)
        steps: list[int] = []
        td.resume(copy, callback=lambda p: steps.append(int(p["step"])), **kwargs)
        return steps[0]

    # By default from the checkpoint at step 20, to the bit; asked, from
    # step 25.
    assert first_step() == 21
    assert first_step(from_last_step=True) == 26
    # From the command line; the run ends at the time the through run
    # does, to round-off (the resumed run has no cached factor at step
    # 25), and the stop's state is gone once a checkpoint passed it.
    assert main(["run", "--resume", str(out), "--from-last-step", "--quiet", "--no-plot"]) == 0
    resumed = td.load(out)
    for column, values in through.curve.items():
        assert np.array_equal(values[:26], resumed.curve[column][:26], equal_nan=True), column
    assert resumed.time_to_density(UNTIL) == pytest.approx(through.time_to_density(UNTIL), rel=1e-4)
    assert not stop.exists()
    with pytest.raises(SystemExit) as e:
        main(["run", "--from-last-step", "--stress", "10", "--out", str(tmp_path / "new")])
    assert e.value.code == 2 and "--from-last-step goes with --resume" in capsys.readouterr().err


def test_a_run_without_a_summary_loads_as_far_as_it_got(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    stopped_at(bcc_every_10(), 15, out)
    stopped = td.load(out)
    # As a killed run leaves it: no summary, the next row begun.
    (out / "summary.json").unlink()
    with (out / "curve.csv").open("a") as f:
        f.write("0.51,0.7")
    partial = td.load(out)
    assert partial.status == "interrupted" and "no summary.json" in (partial.message or "")
    assert len(partial.time_s) == 16
    for column, values in stopped.curve.items():
        assert np.array_equal(values, partial.curve[column], equal_nan=True), column
    assert (partial.degrees_of_freedom, partial.nodes, partial.elements) == (
        stopped.degrees_of_freedom, stopped.nodes, stopped.elements)
    # Its totals are the last checkpoint's: step 10.
    assert partial.stats["steps"] == 10 and 0 < partial.stats["newton_iterations"] < stopped.stats["newton_iterations"]
    assert "step 15" in (partial.message or "") and "step 10" in (partial.message or "")
    # `tidens show` reports it so: the marks its curve has passed, with
    # their times; with --plot, its curve so far.
    capsys.readouterr()
    assert main(["show", str(out), "--plot", str(tmp_path / "so_far.png")]) == 0
    text = capsys.readouterr().out
    assert (partial.message or "") in text
    assert f"status: interrupted   final density {partial.rel_density[-1]:.4f}" in text
    assert f"wall {partial.wall_seconds:.1f} s to step 10, 15 steps, " in text
    printed = {float(line.split()[0]): line.split()[1] for line in text.splitlines() if re.match(r"^ 0\.\d\d ", line)}
    passed = [m for m in MARK_DENSITIES if partial.rho0 < m <= partial.rel_density[-1]]
    assert passed and sorted(printed) == passed
    time_error = partial.summary()["error_estimate"]["time"]
    for m in passed:
        assert printed[m] == f"{partial.time_to_density(m):.4g}"
        # No companion: the error column is the time control's part, marked.
        line = next(x for x in text.splitlines() if x.startswith(f"{m:5.2f} "))
        assert f" {100 * time_error[f'{m:g}']:.2f} % t " in line
    assert (tmp_path / "so_far.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["show", str(tmp_path / "nothing")]) == 1 and "no run to load" in capsys.readouterr().err
    # A folder of runs: one line each, from its curve's last complete row.
    assert main(["show", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"1 runs in {tmp_path}:" and lines[1].startswith(
        f"  run: no summary (going or stopped), step 15, t = {partial.time_s[-1]:.4g} s, rho = {partial.rel_density[-1]:.4f}, ")
    with pytest.raises(SystemExit) as e:
        main(["show", str(tmp_path), "--plot", str(tmp_path / "all.png")])
    assert e.value.code == 2 and "--plot draws one run" in capsys.readouterr().err


def test_resume_refuses_a_folder_without_a_run_and_case_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(FileNotFoundError, match="no run to resume"):
        td.resume(tmp_path)
    code = main(["run", "--resume", str(tmp_path), "--quiet"])
    assert code == 1 and "no run to resume" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["run", "--resume", str(tmp_path), "--stress", "10"])
    assert e.value.code == 2 and "leave out --stress" in capsys.readouterr().err


def test_a_damaged_run_record_or_checkpoint_is_refused_naming_it(quick_case: td.Case, tmp_path: Path) -> None:
    out = tmp_path / "run"
    quick_case.run(until_density=0.56, out_dir=out, error_estimate=False)
    checkpoint = (out / "checkpoint.bin").read_bytes()
    (out / "checkpoint.bin").write_bytes(checkpoint[: len(checkpoint) // 2])
    with pytest.raises(ValueError, match=r"checkpoint.bin: truncated \(ends after"):
        td.resume(out)
    (out / "checkpoint.bin").write_bytes(checkpoint)
    (out / "run.json").write_text("{\"case\": 3}")
    with pytest.raises(ValueError, match="run.json: not the record of a run"):
        td.resume(out)
