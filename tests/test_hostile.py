"""What a hostile or careless user meets: nothing lost or corrupted (two
writers into one folder, the demo into another run's folder, unbounded
inputs, a damaged curve), and every refusal in one line naming the option
or the file and field."""

import json
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs import io
from tidens_rs.cli import main

QUICK = ["--mesh-level", "1", "--tolerance", "0.05", "--quiet", "--no-plot"]
SC_RUN = ["run", "--cell", "sc", "--stress", "10", "--until-density", "0.7", *QUICK]


def tidens(*args: str, cwd: Path | None = None) -> subprocess.Popen[str]:
    """``tidens ARGS`` in a process of its own."""
    return subprocess.Popen(
        [sys.executable, "-m", "tidens_rs.cli", *args],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def run_cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Exit status and stderr of ``tidens ARGS`` run in this process."""
    try:
        code = main(args)
    except SystemExit as e:
        code = int(e.code or 0)
    return code, capsys.readouterr().err


# -- Bad: two writers -------------------------------------------------------


def test_two_runs_started_together_into_one_folder_let_one_in(tmp_path: Path) -> None:
    """The second run into a folder held by the first is refused in one
    line; the curve holds the first run's rows only, in order."""
    out = tmp_path / "run"
    # The bcc cell at level 1 runs for a few seconds: long enough to overlap.
    args = ["run", "--cell", "bcc", "--stress", "10", "--until-density", "0.75", "--out", str(out), *QUICK]
    first, second = tidens(*args), tidens(*args)
    results = [(p.wait(timeout=300), p.stderr.read() if p.stderr else "") for p in (first, second)]
    codes = sorted(code for code, _ in results)
    assert codes == [0, 2], results
    refused = next(err for code, err in results if code == 2)
    # Refused by the lock, or (if the first had begun writing before the
    # second looked) by the folder's contents.
    assert "being written by another tidens process" in refused or "holds files" in refused, refused
    assert refused.count("\n") == 1, refused
    curve = io.read_curve(out / "curve.csv")
    assert np.array_equal(curve["step"], np.arange(len(curve["step"])))
    assert np.all(np.diff(curve["time_s"]) > 0)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == int(curve["step"][-1])


def test_a_folder_held_by_another_writer_is_refused_even_with_overwrite(
    tmp_path: Path, quick_case: td.Case
) -> None:
    out = tmp_path / "run"
    quick_case.run(until_density=0.6, out_dir=out, error_estimate=False)
    before = (out / "run.json").read_text()
    # A lock held through another open file, as another process holds it.
    with io.FolderLock(out), pytest.raises(io.FolderBusyError, match=f"pid {os.getpid()}"):
        td.Case(cell=td.cells.sc(), material=td.materials.TI64_CREEP_1293K, stress_mpa=20.0,
                solver=quick_case.solver).run(until_density=0.6, out_dir=out, overwrite=True)
    assert (out / "run.json").read_text() == before
    with io.FolderLock(out), pytest.raises(io.FolderBusyError):
        td.resume(out)
    # Released: the same overwrite goes ahead, and records its own case.
    td.Case(cell=td.cells.sc(), material=td.materials.TI64_CREEP_1293K, stress_mpa=20.0,
            solver=quick_case.solver).run(until_density=0.6, out_dir=out, overwrite=True, error_estimate=False)
    assert json.loads((out / "run.json").read_text())["case"]["stress_mpa"] == 20.0
    assert json.loads((out / "summary.json").read_text())["load"]["stress_mpa"] == 20.0


def test_bad_input_found_under_the_lock_leaves_no_folder(tmp_path: Path, quick_case: td.Case) -> None:
    out = tmp_path / "new"
    with pytest.raises(ValueError, match="accuracy"):
        quick_case.run(until_density=0.6, out_dir=out, accuracy=0.9)
    assert not out.exists()
    with io.FolderLock(out):
        assert (out / io.LOCK_FILE).exists()
    assert not out.exists()  # made by the lock, nothing written: removed again


# -- Bad: the demo ----------------------------------------------------------


def test_demo_refuses_a_folder_holding_another_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "bcc"
    assert main(["run", "--cell", "bcc", "--stress", "10", "--until-density", "0.7", "--out", str(out), *QUICK]) == 0
    capsys.readouterr()
    files = {p.name: p.read_bytes() for p in out.iterdir()}
    code, err = run_cli(["demo", "--out", str(out), "--quiet"], capsys)
    assert code == 2
    assert "holds another run (cell bcc, 10 MPa" in err and err.count("\n") == 1, err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == files


# -- Bad: unbounded inputs ----------------------------------------------------


def test_continuum_points_are_bounded_and_memory_stays_small(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err = run_cli(["continuum", "--cell", "sc", "--stress", "10", "--until-density", "0.95",
                         "--points", "1000000000", "--out", str(tmp_path / "a")], capsys)
    assert code == 2 and "--points = 1000000000: must be in [2, 100000]" in err
    assert not (tmp_path / "a").exists()
    # The most points allowed, in a process of its own: its peak memory.
    p = tidens("continuum", "--cell", "sc", "--stress", "10", "--until-density", "0.95",
               "--points", "100000", "--out", str(tmp_path / "b"))
    assert p.wait(timeout=300) == 0
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    assert peak_mb < 600, peak_mb
    rows = (tmp_path / "b" / "curve.csv").read_text().splitlines()
    assert len(rows) == 100_001


def test_chunked_model_times_equal_the_whole_block() -> None:
    model = td.continuum.for_material(td.materials.TI64_CREEP_1293K, 10.0, 0.5236)
    rho = np.linspace(0.53, 0.99, 3000)
    chunked = model.effective_time(rho)
    whole = np.concatenate([model.effective_time(rho[k : k + 500]) for k in range(0, 3000, 500)])
    assert np.array_equal(chunked, whole)


# -- Bad: a damaged curve -------------------------------------------------------


def test_show_refuses_a_curve_cut_after_the_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert main([*SC_RUN, "--out", str(out)]) == 0
    capsys.readouterr()
    assert run_cli(["show", str(out)], capsys)[0] == 0
    lines = (out / "curve.csv").read_text().splitlines(keepends=True)
    (out / "curve.csv").write_text("".join(lines[: len(lines) // 2]))
    code, err = run_cli(["show", str(out)], capsys)
    assert code == 2
    assert "curve.csv does not match summary.json: the curve ends at step" in err and err.count("\n") == 1, err


# -- Weak: one line naming the option, the file or the field -------------------


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("args", "code", "said"),
    [
        (["run", "--cell", "random", "--packing-seed", "99999999999999999999999", "--stress", "10", "--until-density", "0.7", "--out", "OUT"],
         2, "--packing-seed: 99999999999999999999999: must be in [0, 2^64 - 1"),
        (["pack", "--particles", "8", "--packing-seed", "-1", "--out", "OUT/p.txt"], 2, "--packing-seed: -1: must be in [0, 2^64 - 1"),
        (["sweep", "--stress", "", "--until-density", "0.7", "--out", "OUT"], 2, "--stress: '': expected one or more"),
        (["run", "--cell", "random", "--particles", "1", "--stress", "10", "--until-density", "0.7", "--out", "OUT"],
         2, "--particles = 1: must be in [2, 10000]"),
        (["run", "--cell", "random", "--particles", "8", "--tied-planes", "--stress", "10", "--until-density", "0.7", "--out", "OUT"],
         2, "--tied-planes = True: cell 'random' is periodic"),
        (["run", "--element", "tet10", "--contact-facets", "bilinear", "--stress", "10", "--until-density", "0.7", "--out", "OUT"],
         2, "--contact-facets = 'bilinear': applies to hex8 elements only"),
        (["run", "--checkpoint-every", "-1", "--stress", "10", "--until-density", "0.7", "--out", "OUT"],
         2, "--checkpoint-every = -1: must be an integer in [0, 18446744073709551615]"),
        (["run", "--C", "1e-7", "--n", "51", "--stress", "10", "--until-density", "0.7", "--out", "OUT"], 2, "--n = 51: must be in [1, 50]"),
        (["run", "--stress", "10", "--until-density", "0.7", "--out", "AFILE/sub"], 2, "AFILE (in AFILE/sub) is a file, not a folder"),
        (["run", "--stress", "10", "--until-density", "0.7", "--out", "DANGLING"], 2, "DANGLING is a symbolic link to"),
        (["show", "LISTSUMMARY"], 2, "summary.json: not a run's file (a JSON list, expected an object)"),
        (["show", "BADCHECKPOINT"], 2, "checkpoint.bin"),
        (["figures", "--out", "AFILE", "--only", "cpti"], 2, "AFILE is a file, not a folder"),
        (["figures", "--out", "OUT", "--draw-only", "--only", "cpti"], 1, "holds no runs to draw from"),
        (["figures", "--out", "RUN", "--draw-only", "--only", "cpti"], 2, "is the folder of one run"),
        (["run", "--stress", "-1", "--until-density", "0.7", "--out", "OUT"], 2, "(see tidens run --help)"),
    ],
)
def test_weak_inputs_get_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], code: int, said: str
) -> None:
    afile = _write(tmp_path / "afile", "x")
    dangling = tmp_path / "dangling"
    dangling.symlink_to(tmp_path / "nowhere")
    listed = _finished_run(tmp_path, "listed")
    _write(listed / "summary.json", "[1, 2]")
    run = tmp_path / "run"
    run.mkdir()
    _write(run / "run.json", "{}")
    names = {"OUT": tmp_path / "out", "AFILE": afile, "DANGLING": dangling, "LISTSUMMARY": listed, "RUN": run,
             "BADCHECKPOINT": _unfinished_with_damaged_checkpoint(tmp_path)}
    argv = [_fill(a, names) for a in args]
    capsys.readouterr()
    got, err = run_cli(argv, capsys)
    assert got == code, err
    assert _fill(said, names) in err, err
    assert err.count("\n") == 1, err
    assert "Traceback" not in err


def _fill(text: str, names: dict[str, Path]) -> str:
    for key, path in names.items():
        text = text.replace(key, str(path))
    return text


def _finished_run(tmp_path: Path, name: str) -> Path:
    """A copy of a finished quick sc run (made once per session)."""
    src = tmp_path.parent / "finished-sc-run"
    if not (src / "summary.json").exists():
        shutil.rmtree(src, ignore_errors=True)
        code = main([*SC_RUN, "--out", str(src)])
        assert code == 0
    out = tmp_path / name
    shutil.copytree(src, out)
    return out


def _unfinished_with_damaged_checkpoint(tmp_path: Path) -> Path:
    """A run folder with its record and curve but no summary, whose
    checkpoint was cut in half."""
    out = _finished_run(tmp_path, "damaged")
    (out / "summary.json").unlink()
    data = (out / "checkpoint.bin").read_bytes()
    (out / "checkpoint.bin").write_bytes(data[: len(data) // 2])
    return out


@pytest.mark.parametrize(
    ("call", "kind", "said"),
    [
        (lambda: td.cells.sc(aspect_ratio="1"), TypeError, "aspect_ratio = '1'"),  # type: ignore[arg-type]
        (lambda: td.cells.sc2(size_ratio=None), TypeError, "size_ratio = None"),  # type: ignore[arg-type]
        (lambda: td.materials.custom(1e-7, "3"), TypeError, "creep_n = '3'"),  # type: ignore[arg-type]
        (lambda: td.cells.random(8, seed=2**70), ValueError, "seed = 1180591620717411303424"),
        (lambda: td.cells.random(8, seed=1.5), TypeError, "seed = 1.5"),  # type: ignore[arg-type]
        (lambda: td.Packing.generate(8, seed="a"), TypeError, "seed = 'a'"),  # type: ignore[arg-type]
        (lambda: td.similarity.map_curve(None, 20), TypeError, "source = None"),  # type: ignore[arg-type]
        (lambda: td.sweep.run(None, "x", until_density=0.7), TypeError, "base = None"),  # type: ignore[arg-type]
        (lambda: td.cells.custom("two", (0.05, 0.05, 0.05), [("000", 0.05, 0.05), ("000", 0.05, 0.05)]),
         ValueError, "octants[0] and octants[1]"),
        (lambda: td.SolverSettings(element="tet10", contact_facets="bilinear"), ValueError, "contact_facets = 'bilinear': applies to hex8"),
    ],
)
def test_weak_python_inputs_name_the_argument(call: Any, kind: type[Exception], said: str) -> None:
    with pytest.raises(kind) as e:
        call()
    assert said in str(e.value)


def test_write_vtu_into_a_file_is_an_output_error(tmp_path: Path, quick_case: td.Case) -> None:
    r = quick_case.run(until_density=0.6, error_estimate=False)
    afile = _write(tmp_path / "afile", "x")
    with pytest.raises(td.OutputError, match="afile"):
        r.write_vtu(afile)


# -- Friction --------------------------------------------------------------------


def test_snapshots_are_taken_at_their_densities_and_listed_once(tmp_path: Path, quick_case: td.Case) -> None:
    """Steps end just past each snapshot density (not up to a step later),
    and the collection lists no time twice."""
    out = tmp_path / "run"
    r = quick_case.run(until_density=0.8, out_dir=out, snapshot_densities=[0.6, 0.7, 0.8], error_estimate=False)
    for snap in r.snapshots[:-1]:
        target = float(snap.label[3:])
        # Without the targets the step past 0.6 ended at 0.608 here.
        assert abs(snap.rel_density - target) < 2e-3, (snap.label, snap.rel_density)
    times = [t for t, _ in io.read_pvd(out / "fields.pvd")]
    assert len(times) == len(set(times))
    assert [name for _, name in io.read_pvd(out / "fields.pvd")][-1] == "fields_final.vtu"


def test_summary_and_curve_carry_no_duplicates_or_empty_columns(tmp_path: Path, quick_case: td.Case) -> None:
    out = tmp_path / "run"
    quick_case.run(until_density=0.7, out_dir=out, error_estimate=False)
    s = json.loads((out / "summary.json").read_text())
    assert "mesh_level" not in s and "tolerance" not in s and s["solver"]["mesh_level"] == 1
    assert set(s["continuum_times_to_density_s"]) == {"0.6", "0.7"}  # not beyond the run's end
    header = (out / "curve.csv").read_text().splitlines()[0].split(",")
    assert "coordination_number" not in header and "rel_density" in header


def test_a_result_prints_in_one_line(quick_case: td.Case) -> None:
    r = quick_case.run(until_density=0.6, error_estimate=False)
    text = repr(r)
    assert "\n" not in text and len(text) < 200 and "sc, 10 MPa: reached_density" in text


def test_every_command_has_a_description() -> None:
    from tidens_rs.cli import build_parser

    parser = build_parser()
    for action in parser._actions:
        if hasattr(action, "choices") and isinstance(action.choices, dict):
            for name, sub in action.choices.items():
                assert sub.description and len(sub.description) > 40, name


def test_sigterm_during_the_companion_exits_143(tmp_path: Path) -> None:
    """A SIGTERM while the error estimate's companion runs stops the command
    with status 143 (not 0), the main run's summary written."""
    out = tmp_path / "run"
    p = tidens("run", "--cell", "bcc", "--stress", "10", "--until-density", "0.9", "--mesh-level", "2",
               "--tolerance", "0.04", "--out", str(out))
    deadline = time.monotonic() + 300
    while not (out / "companion_curve.csv").exists():
        assert p.poll() is None and time.monotonic() < deadline, "the run ended before its companion began"
        time.sleep(0.05)
    p.terminate()
    assert p.wait(timeout=60) == 143
    err = p.stderr.read() if p.stderr else ""
    assert "terminated by SIGTERM" in err, err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "reached_density"
    assert "interrupted" in summary["error_estimate"]["method"]["mesh"] or "SIGTERM" in summary["error_estimate"]["method"]["mesh"]


def test_a_run_too_large_for_the_memory_is_refused_before_the_packing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """10000 random spheres at the default level need hundreds of GB: refused
    in one line within seconds, before the packing is made."""
    t0 = time.perf_counter()
    code, err = run_cli(["run", "--cell", "random", "--particles", "10000", "--stress", "10",
                         "--until-density", "0.7", "--out", str(tmp_path / "big"), "--quiet"], capsys)
    assert code == 2 and "needs about" in err and "GB of memory" in err and err.count("\n") == 1, err
    assert time.perf_counter() - t0 < 30
    assert not (tmp_path / "big").exists()


def test_a_run_is_refused_when_its_estimate_exceeds_the_available_memory(
    monkeypatch: pytest.MonkeyPatch, quick_case: td.Case
) -> None:
    from tidens_rs import case as case_module

    cell = td.cells.as_periodic(td.cells.bcc())
    c = td.Case(cell=cell, material=quick_case.material, stress_mpa=10.0, solver=quick_case.solver)
    size = c.size()
    monkeypatch.setattr(case_module, "available_memory_bytes", lambda: size["peak_memory_bytes"] - 1)
    with pytest.raises(ValueError, match=f"mesh_level = 1: needs about .* GB of memory \\({size['degrees_of_freedom']} unknowns\\)"):
        c.run(until_density=0.75)
    monkeypatch.setattr(case_module, "available_memory_bytes", lambda: size["peak_memory_bytes"])
    assert c.simulation(until_density=0.75).degrees_of_freedom == size["degrees_of_freedom"]
