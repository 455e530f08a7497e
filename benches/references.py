"""Converged reference times to density for the speed benchmark.

    python benches/references.py [--cases sc10 sc bcc fcc sc2]
                                 [--levels 1 2 3] [--level-tolerance 0.005]
                                 [--time-level 2] [--tolerances 0.04 0.02 0.01 0.005]
                                 [--out benches/references.json]

For each case (the sc Ti-6Al-4V cell at 10 MPa to rho = 0.9, and sc, bcc,
fcc and sc2 at 15 MPa to rho = 0.95) it estimates the converged t(0.8),
t(0.9) and t(0.95) from two ladders, by Richardson extrapolation:

- a mesh ladder (three or more mesh levels at one tight tolerance): with
  element sizes h_i ~ 1/divisions_i, t(h) = t_h + a h^p; the observed order
  p comes from the last three levels (the ratios of the levels differ, so p
  is the root of (t1 - t2)/(t2 - t3) = (h1^p - h2^p)/(h2^p - h3^p)) and the
  extrapolation from the last two;
- a tolerance ladder (three or more tolerances at one level): t(tau) =
  t_0 + b tau^q the same way, giving the time-discretisation error of the
  mesh ladder's tolerance, which is added as a correction.

The reference is the mesh-extrapolated value plus that time correction.
An extrapolation is trusted only where the observed order is plausible
(mesh: 1 to 4, time: 0.5 to 2): convergence in contact problems is often
not monotone (nodes meet the planes one by one), and then the finest value
is kept and the last change is its uncertainty. The uncertainty reported is
the sum of the mesh and time parts. Every run is stored in the output file as
it finishes, and runs already there are not repeated, so the command can
be stopped and resumed.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import tidens_rs as td
from speed_cases import CASES, MARKS, case_of
from tidens_rs._core import LEVEL_DIVISIONS as DIVISIONS

HERE = Path(__file__).resolve().parent


def run(case: str, level: int, tolerance: float, exact_volume: bool, until: float | None = None) -> dict[str, Any]:
    """One run of the ladder, to the case's final density or to ``until``."""
    until = CASES[case][2] if until is None else until
    # Newton converged tighter than the default, as a reference should be.
    c = case_of(case, mesh_level=level, tolerance=tolerance, exact_volume=exact_volume, newton_residual_tolerance=1e-6)
    t0 = time.perf_counter()
    # A reference needs no error estimate of its own (its companion would
    # add a third to the cost, and to the wall time stored).
    r = c.run(until_density=until, error_estimate=False)
    wall = time.perf_counter() - t0
    s = r.summary()
    return {
        "level": level,
        "tolerance": tolerance,
        "exact_volume": exact_volume,
        "dofs": r.degrees_of_freedom,
        "rho0": r.rho0,
        "wall_s": wall,
        "steps": s["steps"],
        "until_density": until,
        "times_s": {f"{x:g}": r.time_to_density(x) for x in MARKS if x <= until},
    }


def observed_order(h: list[float], t: list[float]) -> float | None:
    """Order p with (t1 - t2)/(t2 - t3) = (h1^p - h2^p)/(h2^p - h3^p), by
    bisection on p in (0.2, 8); None when the differences change sign (no
    monotone convergence) or no root lies there."""
    d1, d2 = t[0] - t[1], t[1] - t[2]
    if d1 == 0.0 or d2 == 0.0 or (d1 > 0) != (d2 > 0):
        return None
    ratio = d1 / d2

    def f(p: float) -> float:
        return float((h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p) - ratio)

    lo, hi = 0.2, 8.0
    if f(lo) * f(hi) > 0:
        return None
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if f(lo) * f(mid) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def extrapolate(h: list[float], t: list[float], p: float) -> float:
    """Richardson from the last two points with order p."""
    (h1, h2), (t1, t2) = h[-2:], t[-2:]
    return float(t2 + (t2 - t1) * h2**p / (h1**p - h2**p))


def ladder(xs: list[float], ts: list[float], expected: float, plausible: tuple[float, float]) -> dict[str, Any]:
    """The limit of a ladder (xs decreasing toward 0).

    With an observed order (last three points) in the ``plausible`` range,
    the convergence is taken as asymptotic: Richardson from the last two
    points with that order, the uncertainty being the size of the
    correction. Otherwise (no monotone convergence, or an order far from the
    ``expected`` one) no extrapolation is trusted: the limit is the last
    point, and the uncertainty is the last change (or the correction with
    the expected order, if larger)."""
    p = observed_order(xs[-3:], ts[-3:]) if len(xs) >= 3 else None
    if p is not None and plausible[0] <= p <= plausible[1]:
        limit = extrapolate(xs, ts, p)
        return {"order": p, "extrapolated": True, "limit": limit, "correction": limit - ts[-1], "uncertainty": abs(limit - ts[-1])}
    guess = extrapolate(xs, ts, expected) - ts[-1]
    spread = abs(ts[-1] - ts[-2]) if len(ts) >= 2 else abs(guess)
    return {"order": p, "extrapolated": False, "limit": ts[-1], "correction": 0.0, "uncertainty": max(spread, abs(guess))}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--level-tolerance", type=float, default=0.005, help="tolerance of the mesh ladder")
    ap.add_argument("--time-level", type=int, default=2, help="mesh level of the tolerance ladder")
    ap.add_argument("--tolerances", type=float, nargs="+", default=[0.04, 0.02, 0.01, 0.005])
    ap.add_argument("--out", type=Path, default=HERE / "references.json")
    ap.add_argument(
        "--partial",
        nargs="+",
        default=[],
        metavar="LEVEL:RHO",
        help="mesh levels run only to density RHO (e.g. 5:0.8): the densities beyond take their ladder from the other levels",
    )
    ap.add_argument(
        "--exact-volume",
        action=argparse.BooleanOptionalAction,
        default=td.SolverSettings().exact_volume,
        help="mesh family of the ladders (default: the solver's default)",
    )
    args = ap.parse_args(argv)
    data: dict[str, Any] = json.loads(args.out.read_text()) if args.out.exists() else {}
    data.setdefault("runs", {})
    data["command"] = "python benches/references.py " + " ".join(sys.argv[1:] if argv is None else argv)
    data.setdefault("cases", {})

    family = "exact-volume" if args.exact_volume else "on-surface"
    partial = {int(a): float(b) for a, b in (x.split(":") for x in args.partial)}

    def get(case: str, level: int, tol: float) -> dict[str, Any]:
        key = f"{case}/{family}/level{level}/tol{tol:g}"
        if key not in data["runs"]:
            print(f"# run {key}", file=sys.stderr, flush=True)
            data["runs"][key] = run(case, level, tol, args.exact_volume, partial.get(level))
            args.out.write_text(json.dumps(data, indent=1) + "\n")
        found: dict[str, Any] = data["runs"][key]
        return found

    for case in args.cases:
        _, _, until = CASES[case]
        marks = [x for x in MARKS if x <= until]
        levels = sorted(args.levels)
        tols = sorted(args.tolerances, reverse=True)
        mesh_runs = [get(case, lv, args.level_tolerance) for lv in levels]
        time_runs = [get(case, args.time_level, tol) for tol in tols]
        if args.level_tolerance not in tols:
            time_runs.append(get(case, args.time_level, args.level_tolerance))
            tols.append(args.level_tolerance)
        h = [1.0 / DIVISIONS[lv] for lv in levels]
        out: dict[str, Any] = {"mesh_family": family, "times_s": {}, "uncertainty_s": {}, "mesh": {}, "time": {}}
        for x in marks:
            k = f"{x:g}"
            # The levels whose runs reached this density.
            reached = [i for i, r in enumerate(mesh_runs) if k in r["times_s"]]
            tm = [mesh_runs[i]["times_s"][k] for i in reached]
            mesh = ladder([h[i] for i in reached], tm, 2.0, (1.0, 4.0))
            tt = [r["times_s"][k] for r in time_runs]
            # The tolerance ladder sorted by tolerance, the mesh ladder's last.
            order = sorted(range(len(tols)), key=lambda i: -tols[i])
            xs = [tols[i] for i in order]
            ys = [tt[i] for i in order]
            tl = ladder(xs, ys, 1.0, (0.5, 2.0))
            # Time correction of the mesh ladder's tolerance at the time level.
            at_tol = ys[xs.index(args.level_tolerance)]
            time_corr = tl["limit"] - at_tol
            ref = mesh["limit"] + time_corr
            out["times_s"][k] = ref
            out["uncertainty_s"][k] = mesh["uncertainty"] + tl["uncertainty"]
            out["mesh"][k] = {"levels": [levels[i] for i in reached], "times_s": tm, **mesh}
            out["time"][k] = {"level": args.time_level, "tolerances": xs, "times_s": ys, **tl, "correction_at_level_tolerance": time_corr}
        data["cases"][case] = out
        args.out.write_text(json.dumps(data, indent=1) + "\n")
        print(f"\n{case}: {family} meshes, mesh ladder at tolerance {args.level_tolerance:g} (levels {levels}, dofs {[r['dofs'] for r in mesh_runs]}), time ladder at level {args.time_level}")
        print("| rho | " + " | ".join(f"level {lv}" for lv in levels) + " | mesh order | mesh limit | time order | time correction | reference | uncertainty |")
        print("|" + "---|" * (len(levels) + 7))
        for x in marks:
            k = f"{x:g}"
            m, t = out["mesh"][k], out["time"][k]
            cells = {lv: v for lv, v in zip(m["levels"], m["times_s"])}
            po = ("-" if m["order"] is None else f"{m['order']:.2f}") + ("" if m["extrapolated"] else " (not used)")
            qo = ("-" if t["order"] is None else f"{t['order']:.2f}") + ("" if t["extrapolated"] else " (not used)")
            print(
                f"| {k} | " + " | ".join(f"{cells[lv]:.2f}" if lv in cells else "-" for lv in levels) + f" | {po} | {m['limit']:.2f} | {qo} | {t['correction_at_level_tolerance']:+.3f} | {out['times_s'][k]:.2f} | {100 * out['uncertainty_s'][k] / out['times_s'][k]:.2f} % |"
            )
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
