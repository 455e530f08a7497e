"""Norton similarity against full runs: how far a curve mapped from another
stress is from the curve computed at that stress, and how well the
calibrated error estimate of ``tidens_rs.similarity`` brackets it.

    python benches/similarity.py [--cases sc bcc] [--stresses 2.5 5 10 20 40]
                                 [--level 2] [--tolerance 0.02] [--out benches/similarity.json]
                                 [--report-only]

Every case (Ti-6Al-4V at 1293 K, the cell at the default radius, a 1 s
ramp) is computed at every stress to rho = 0.95 (the runs are stored with
their curves in the output file and not repeated). Then:

- mapped from 10 MPa: the relative error of t(0.8), t(0.9), t(0.95) of the
  10 MPa curve mapped to each other stress, against the full run there;
- the sweep's scheme: the lowest and the highest stress computed, every
  stress between mapped from the nearer of the two with the other as the
  calibration; the true error against the full run beside the estimate.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import tidens_rs as td
from tidens_rs.result import Result, interpolate_time
from tidens_rs.similarity import map_curve

HERE = Path(__file__).resolve().parent
MARKS = (0.8, 0.9, 0.95)


def case(cell: str, stress: float, level: int, tolerance: float) -> td.Case:
    return td.Case(
        cell=td.cells.by_name(cell),
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=stress,
        solver=td.SolverSettings(mesh_level=level, tolerance=tolerance),
    )


def key(cell: str, stress: float, level: int, tolerance: float) -> str:
    return f"{cell}/{stress:g}MPa/level{level}/tol{tolerance:g}"


def as_result(stored: dict[str, Any], cell: str, level: int, tolerance: float) -> Result:
    """A stored run as a Result (the curve, and the case that made it)."""
    c = case(cell, stored["stress_mpa"], level, tolerance)
    curve = {k: np.asarray(v, float) for k, v in stored["curve"].items()}
    return Result(
        case=c,
        curve=curve,
        status="reached_density",
        wall_seconds=stored["wall_s"],
        stats={},
        degrees_of_freedom=0,
        nodes=0,
        elements=0,
        snapshots=[],
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=["sc", "bcc"], choices=td.cells.CELL_NAMES)
    ap.add_argument("--stresses", nargs="+", type=float, default=[2.5, 5.0, 10.0, 20.0, 40.0])
    ap.add_argument("--level", type=int, default=2)
    ap.add_argument("--tolerance", type=float, default=0.02)
    ap.add_argument("--out", type=Path, default=HERE / "similarity.json")
    ap.add_argument("--report-only", action="store_true")
    args = ap.parse_args(argv)
    data: dict[str, Any] = json.loads(args.out.read_text()) if args.out.exists() else {}
    runs: dict[str, Any] = data.setdefault("runs", {})
    stresses = sorted(args.stresses)
    for cell in args.cases:
        for s in stresses:
            k = key(cell, s, args.level, args.tolerance)
            if k in runs or args.report_only:
                continue
            print(f"# run {k}", file=sys.stderr, flush=True)
            t0 = time.perf_counter()
            r = case(cell, s, args.level, args.tolerance).run(until_density=0.95, error_estimate=False)
            runs[k] = {
                "stress_mpa": s,
                "wall_s": time.perf_counter() - t0,
                "curve": {c: r.curve[c].tolist() for c in ("time_s", "rel_density", "time_error_s")},
            }
            args.out.write_text(json.dumps(data) + "\n")
    for cell in args.cases:
        results = {s: as_result(runs[key(cell, s, args.level, args.tolerance)], cell, args.level, args.tolerance) for s in stresses}
        report(cell, results, args.level, args.tolerance)


def error_at(mapped_t: float | None, full: Result, rho: float) -> float | None:
    truth = interpolate_time(full.time_s, full.rel_density, rho)
    if mapped_t is None or truth is None:
        return None
    return (mapped_t - truth) / truth


def report(cell: str, results: dict[float, Result], level: int, tolerance: float) -> None:
    stresses = sorted(results)
    print(f"\n{cell}, level {level}, tolerance {tolerance:g}: mapped from 10 MPa, relative error of t(rho) against the full run")
    print("| stress [MPa] | " + " | ".join(f"t({m:g})" for m in MARKS) + " |")
    print("|---|" + "---|" * len(MARKS))
    if 10.0 in results:
        for s in stresses:
            if s == 10.0:
                continue
            m = map_curve(results[10.0], s)
            errors = [error_at(m.time_to_density(r), results[s], r) for r in MARKS]
            print(f"| {s:g} | " + " | ".join("-" if e is None else f"{100 * e:+.2f} %" for e in errors) + " |")
    lo, hi = stresses[0], stresses[-1]
    print(f"\n{cell}: the sweep's scheme, {lo:g} and {hi:g} MPa computed, the others mapped from the nearer with the other as calibration")
    print("| stress [MPa] | from | " + " | ".join(f"true t({m:g}) | est t({m:g})" for m in MARKS) + " | bracketed (|true| <= est) |")
    print("|---|---|" + "---|" * (2 * len(MARKS)) + "---|")
    for s in stresses[1:-1]:
        src, cal = (lo, hi) if abs(np.log(s / lo)) <= abs(np.log(hi / s)) else (hi, lo)
        m = map_curve(results[src], s, calibration=results[cal])
        cells, ok = [], 0
        counted = 0
        for r in MARKS:
            e = error_at(m.time_to_density(r), results[s], r)
            est = m.relative_error.get(f"{r:g}")
            cells += ["-" if e is None else f"{100 * e:+.2f} %", "-" if est is None else f"{100 * est:.2f} %"]
            if e is not None and est is not None:
                counted += 1
                ok += abs(e) <= est
        print(f"| {s:g} | {src:g} | " + " | ".join(cells) + f" | {ok}/{counted} |")


if __name__ == "__main__":
    main()
