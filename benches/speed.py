"""Whole-case speed: every cell at its default settings, as a user runs it.

    python benches/speed.py [--cases sc10 sc bcc fcc sc2] [--repeat 3]
                            [--save speed.json] [--compare before.json]
                            [--tidens PATH] [--threads N]

Each case is one ``tidens run`` process (start-up, solve, VTU fields and the
plot included), as in the speed targets: the sc Ti-6Al-4V cell at 10 MPa to
rho = 0.9 (``sc10``), and sc, bcc, fcc and sc2 at 15 MPa to rho = 0.95. For
each it prints the median wall time of the process over ``--repeat`` runs,
its peak memory (largest resident set), the steps, Newton iterations and
factorisations, the split of the solver's time between element evaluation,
particle contact, assembly and linear algebra, and the error of t(0.8),
t(0.9) and t(0.95) against the converged references of
``benches/references.json`` (made by ``benches/references.py``), with the
reference's own uncertainty in brackets.

The wall time includes the coarse companion run of the error estimate
(its share is the ``companion [s]`` column); ``-- --no-error-estimate``
times the run alone, as the figures measured before the estimate existed.

``--save`` writes the figures as JSON and ``--compare`` prints a ratio
column against such a file (before/after tables from one script).
``--tidens`` runs another installation's command (e.g. an older version in
its own virtual environment); ``--threads`` sets RAYON_NUM_THREADS.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from speed_cases import CASES, MARKS
from tidens_rs.io import read_curve
from tidens_rs.result import interpolate_time

HERE = Path(__file__).resolve().parent
REFERENCES = HERE / "references.json"


def run_once(tidens: str, name: str, out: Path, extra: list[str], env: dict[str, str]) -> dict[str, Any]:
    cell, stress, until = CASES[name]
    cmd = [tidens, "run", "--cell", cell, "--stress", f"{stress:g}", "--until-density", f"{until:g}", "--out", str(out), "--quiet", *extra]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    stderr = proc.stderr.read().decode() if proc.stderr else ""
    if status != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{stderr}")
    summary = json.loads((out / "summary.json").read_text())
    curve = read_curve(out / "curve.csv")
    stats = summary["stats"]
    return {
        "wall_s": wall,
        "peak_rss_mb": usage.ru_maxrss / 1024.0,  # Linux reports kB
        "solver_s": summary["wall_seconds"],
        "companion_s": (summary.get("error_estimate") or {}).get("companion_wall_seconds"),
        "steps": summary["steps"],
        "newton": summary["newton_iterations"],
        "factorizations": int(stats.get("llt_factorizations", 0) + stats.get("lblt_factorizations", 0)),
        "evaluation_s": stats.get("evaluation_seconds"),
        "contact_s": stats.get("contact_seconds"),
        "assembly_s": stats.get("assembly_seconds"),
        "linear_s": stats.get("linear_seconds"),
        "dofs": summary["degrees_of_freedom"],
        "mesh_level": summary["solver"]["mesh_level"],
        "tolerance": summary["solver"]["tolerance"],
        "times": {f"{r:g}": interpolate_time(curve["time_s"], curve["rel_density"], r) for r in MARKS},
    }


def measure(tidens: str, name: str, repeat: int, extra: list[str], env: dict[str, str]) -> dict[str, Any]:
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(repeat):
            runs.append(run_once(tidens, name, Path(tmp) / f"{name}-{k}", extra, env))
    # The medians of the timings; the rest is the same in every run.
    out = dict(runs[0])
    for key in ("wall_s", "solver_s", "companion_s", "evaluation_s", "contact_s", "assembly_s", "linear_s", "peak_rss_mb"):
        values = [r[key] for r in runs if r.get(key) is not None]
        out[key] = statistics.median(values) if values else None
    out["walls_s"] = [r["wall_s"] for r in runs]
    return out


def fmt(x: float | None, spec: str = ".1f") -> str:
    return "-" if x is None else format(x, spec)


def errors(name: str, result: dict[str, Any], refs: dict[str, Any]) -> list[str]:
    """The relative error of each time against the reference, with the
    reference's own uncertainty in brackets: an error smaller than that
    uncertainty says only that the run lies within it."""
    case = refs.get("cases", {}).get(name, {})
    ref, unc = case.get("times_s", {}), case.get("uncertainty_s", {})
    cells = []
    for r in MARKS:
        k = f"{r:g}"
        t, tr = result["times"].get(k), ref.get(k)
        if t is None or tr is None:
            cells.append("-")
        else:
            cells.append(f"{100 * (t / tr - 1):+.2f} % (±{100 * unc.get(k, 0.0) / tr:.1f} %)")
    return cells


COLUMNS = ["case", "level", "dofs", "wall [s]", "peak MB", "solver [s]", "companion [s]", "steps", "Newton", "factorisations", "evaluation [s]", "contact [s]", "assembly [s]", "linear [s]"]


def header(before: bool) -> None:
    cols = COLUMNS[:4] + (["before/after"] if before else []) + COLUMNS[4:] + [f"error t({r:g})" for r in MARKS]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols), flush=True)


def row(name: str, r: dict[str, Any], refs: dict[str, Any], before: dict[str, Any] | None) -> None:
    cells = [name, str(r["mesh_level"]), str(r["dofs"]), fmt(r["wall_s"], ".2f")]
    if before is not None:
        b = before.get(name)
        cells.append(f"{b['wall_s'] / r['wall_s']:.1f}x" if b else "-")
    cells += [
        fmt(r["peak_rss_mb"], ".0f"),
        fmt(r["solver_s"], ".2f"),
        fmt(r.get("companion_s"), ".2f"),
        str(r["steps"]),
        str(r["newton"]),
        str(r["factorizations"]),
        fmt(r["evaluation_s"], ".2f"),
        fmt(r["contact_s"], ".2f"),
        fmt(r["assembly_s"], ".2f"),
        fmt(r["linear_s"], ".2f"),
    ]
    cells += errors(name, r, refs)
    print("| " + " | ".join(cells) + " |", flush=True)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    p.add_argument("--repeat", type=int, default=1, help="runs per case; wall times are medians (default 1)")
    p.add_argument("--tidens", default=None, help="the tidens command to run (default: this Python's)")
    p.add_argument("--threads", type=int, default=None, help="RAYON_NUM_THREADS for the runs (default: all cores)")
    p.add_argument("--save", type=Path, default=None, help="write the figures to this JSON file")
    p.add_argument("--compare", type=Path, default=None, help="a --save file to print wall-time ratios against")
    p.add_argument("--from", dest="load", type=Path, default=None, help="print the table of a --save file, run nothing")
    p.add_argument("run_args", nargs="*", help="extra options for tidens run, after --")
    args = p.parse_args(argv)
    refs = json.loads(REFERENCES.read_text()) if REFERENCES.exists() else {}
    before = json.loads(args.compare.read_text())["results"] if args.compare else None
    if args.load is not None:
        saved = json.loads(args.load.read_text())
        header(before is not None)
        for name, r in saved["results"].items():
            row(name, r, refs, before)
        return
    tidens = args.tidens or str(Path(sys.executable).with_name("tidens"))
    env = dict(os.environ)
    if args.threads is not None:
        env["RAYON_NUM_THREADS"] = str(args.threads)
    results: dict[str, dict[str, Any]] = {}
    header(before is not None)
    for name in args.cases:
        cell, stress, until = CASES[name]
        print(f"# {name}: {cell} at {stress:g} MPa to rho = {until:g}", file=sys.stderr, flush=True)
        results[name] = measure(tidens, name, args.repeat, list(args.run_args), env)
        row(name, results[name], refs, before)
        if args.save is not None:
            # Saved after every case, so that a long run loses nothing.
            args.save.write_text(json.dumps({"command": " ".join(sys.argv), "results": results}, indent=1) + "\n")
    if args.save is not None:
        print(f"wrote {args.save}")


if __name__ == "__main__":
    main()
