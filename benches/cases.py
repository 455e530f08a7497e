"""Whole-case measurements of the sc Ti-6Al-4V cell at 10 MPa (to rho = 0.9).

    python benches/cases.py levels [--levels 1 2 3 4] [--tolerance 0.01]
    python benches/cases.py tolerance [--level 2] [--tolerances 0.04 0.02 0.01 0.005] [--reference 0.001]

``levels`` prints, per mesh level, the times to 0.6/0.7/0.8/0.9 beside the
continuum model's, the change from the previous level, wall time, steps,
Newton iterations and factorisations. ``tolerance`` prints the error of
t(0.8) and t(0.9) against a run with a much tighter tolerance, beside the
run's own error estimate and its wall time (error against run time).
Figures are medians of ``--repeat`` runs for wall time (default 1).
"""

from __future__ import annotations

import argparse
import statistics
import time

import tidens_rs as td

MARKS = (0.6, 0.7, 0.8, 0.9)


def reached(result: td.Result, rho: float) -> float:
    """Time to ``rho`` [s]; every run here goes to 0.9."""
    t = result.time_to_density(rho)
    if t is None:
        raise RuntimeError(f"the run did not reach rho = {rho}")
    return t


def run(level: int, tolerance: float, repeat: int = 1) -> tuple[td.Result, float]:
    case = td.Case(
        cell=td.cells.sc(),
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=10.0,
        solver=td.SolverSettings(mesh_level=level, tolerance=tolerance),
    )
    walls = []
    result = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = case.run(until_density=0.9)
        walls.append(time.perf_counter() - t0)
    assert result is not None
    return result, statistics.median(walls)


def levels(args: argparse.Namespace) -> None:
    print(f"sc, Ti-6Al-4V 1293 K, 10 MPa, tolerance {args.tolerance}")
    header = "| level | dofs | " + " | ".join(f"t({r}) [s]" for r in MARKS) + " | wall [s] | steps | Newton | factorisations |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    cont = None
    prev: list[float] | None = None
    for level in args.levels:
        r, wall = run(level, args.tolerance, args.repeat)
        times = [reached(r, x) for x in MARKS]
        cont = r.continuum().time_to_density(list(MARKS))
        cells = []
        for k, t in enumerate(times):
            change = "" if prev is None else f" ({100 * (t / prev[k] - 1):+.2f} %)"
            cells.append(f"{t:.4g}{change}")
        s = r.summary()
        fact = int(s["stats"]["llt_factorizations"] + s["stats"]["lblt_factorizations"])
        print(f"| {level} | {r.degrees_of_freedom} | " + " | ".join(cells) + f" | {wall:.1f} | {s['steps']} | {s['newton_iterations']} | {fact} |")
        prev = times
    if cont is not None:
        print("| continuum | | " + " | ".join(f"{t:.4g}" for t in cont) + " | | | | |")


def tolerance(args: argparse.Namespace) -> None:
    ref, ref_wall = run(args.level, args.reference)
    t_ref = {r: reached(ref, r) for r in (0.8, 0.9)}
    print(f"sc, level {args.level}; reference tolerance {args.reference}: t(0.8) = {t_ref[0.8]:.4f} s, t(0.9) = {t_ref[0.9]:.4f} s, wall {ref_wall:.1f} s")
    print("| tolerance | error t(0.8) | estimate | error t(0.9) | estimate | wall [s] | steps |")
    print("|---|---|---|---|---|---|---|")
    for tol in args.tolerances:
        r, wall = run(args.level, tol, args.repeat)
        cells = []
        for rho in (0.8, 0.9):
            t = reached(r, rho)
            e = r.time_error_at_density(rho) or 0.0
            cells += [f"{100 * (t / t_ref[rho] - 1):+.2f} %", f"{100 * e / t:.2f} %"]
        print(f"| {tol} | " + " | ".join(cells) + f" | {wall:.1f} | {r.summary()['steps']} |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="what", required=True)
    a = sub.add_parser("levels")
    a.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3, 4])
    a.add_argument("--tolerance", type=float, default=td.DEFAULT_TOLERANCE)
    a.add_argument("--repeat", type=int, default=1)
    b = sub.add_parser("tolerance")
    b.add_argument("--level", type=int, default=2)
    b.add_argument("--tolerances", type=float, nargs="+", default=[0.04, 0.02, 0.01, 0.005])
    b.add_argument("--reference", type=float, default=0.001)
    b.add_argument("--repeat", type=int, default=1)
    args = p.parse_args()
    levels(args) if args.what == "levels" else tolerance(args)


if __name__ == "__main__":
    main()
