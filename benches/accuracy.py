"""Error against run time: a ladder of mesh levels and tolerances per cell
and element, each run's true error against the references, the Pareto front,
and how each run's own error estimate compares with its true error.

    python benches/accuracy.py [--cases sc10 sc bcc fcc sc2] [--elements hex8]
                               [--levels 2 3] [--tolerances 0.02 0.01]
                               [--out benches/accuracy.json] [--plot accuracy.png]
                               [--report-only]
    python benches/accuracy.py --pointwise [--cases sc bcc] [--ladder-levels 1 2 3 4 5]
                               [--plot-pointwise errors.png]

Every run is a default run but for its level, tolerance and element (Ti-6Al-4V
at 1293 K, the cases of ``speed_cases.py``); each run studied (``--levels``
x ``--tolerances``) also runs its companion (one level down at twice the
tolerance). Its true error is the largest
relative error of t(0.8), t(0.9), t(0.95) against ``references.json``; its
cost is its wall time plus that of its coarse companion (the run one level
down at twice the tolerance, whose difference gives the error estimate; see
``tidens_rs.estimate``), since a result with an error estimate costs both. Runs are stored in
the output file as they finish, with their curves, and are not repeated:
the command can be stopped and resumed, and ``--report-only`` reprints the
tables from the file (the estimates are recomputed from the stored curves,
so a change of the estimator needs no new runs).

``--pointwise`` looks at every density instead of three: per case a mesh
ladder at tolerance 0.005 (``--ladder-levels``, stored with its curves under
``ladders`` in the output file), the finest level taken as the truth. For
each level below it, over the densities from rho0 + 0.04 to the end, it
prints the root mean square of the true relative error of t(rho), how often
the run's estimate (from the level below as its companion) brackets it
(est/3 <= |true| <= est), falls below it or is more than 3 times above it,
the median and largest ratio of the true error to the estimate, and the
ceiling of any estimate that knows the error's distribution near a
density but not its phase (for each density, the best share of the true
errors within rho +- 0.025 that one number brackets). On the contact cells
the error of t(rho) oscillates about the converged curve, one swing per
ring of nodes meeting a plane or a facet, so its sign and size at one
density are a matter of phase; ``--plot-pointwise`` draws the errors.

The tables: per case, the observed mesh and time orders of its reference
ladders; per run, wall time, cost with the companion, true error per
density and overall, the estimate (marked when it does not bracket), and
whether the run is on the Pareto front (no other run of the same case and
element is both cheaper, counting its companion, and more accurate). An
estimate brackets the true error when est/3 <= |true| <= est, either side
allowed the reference's own uncertainty; runs at the finest level of their
reference's mesh ladder (sc2 at level 3) are listed but not counted, since
the reference is such a run. The observed orders come from
``references.json`` (``benches/references.py``).
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
from speed_cases import CASES, MARKS, case_of
from tidens_rs.estimate import COMPANION_TOLERANCE_FACTOR, ErrorEstimate, estimate_error, richardson_factor

HERE = Path(__file__).resolve().parent
# Levels of the runs studied (each also runs its companion one level down).
ELEMENT_LEVELS = {"hex8": (2, 3), "tet10": (2,)}
# The pointwise study: the ladders' tolerance, the density grid, and the
# half-width of the window whose error distribution the ceiling knows.
LADDER_TOLERANCE = 0.005
POINTWISE_SAMPLES = 1201
CEILING_WINDOW = 0.025


def key(case: str, element: str, level: int, tol: float) -> str:
    return f"{case}/{element}/level{level}/tol{tol:g}"


def run(case: str, element: str, level: int, tolerance: float) -> dict[str, Any]:
    _, _, until = CASES[case]
    c = case_of(case, mesh_level=level, tolerance=tolerance, element=element)
    t0 = time.perf_counter()
    r = c.run(until_density=until, error_estimate=False)
    wall = time.perf_counter() - t0
    return {
        "case": case,
        "element": element,
        "level": level,
        "tolerance": tolerance,
        "dofs": r.degrees_of_freedom,
        "wall_s": wall,
        "steps": int(r.curve["step"][-1]),
        "time_s": r.time_s.tolist(),
        "rel_density": r.rel_density.tolist(),
        "time_error_s": r.curve["time_error_s"].tolist(),
    }


def as_result_arrays(r: dict[str, Any]) -> dict[str, np.ndarray]:
    return {k: np.asarray(r[k]) for k in ("time_s", "rel_density", "time_error_s")}


def companion_of(runs: dict[str, Any], r: dict[str, Any]) -> dict[str, Any] | None:
    """The run's coarse companion: one level down at twice the tolerance."""
    return runs.get(key(r["case"], r["element"], r["level"] - 1, COMPANION_TOLERANCE_FACTOR * r["tolerance"]))


def estimate_of(runs: dict[str, Any], r: dict[str, Any]) -> ErrorEstimate | None:
    """The estimate the run reports with its companion; None without one."""
    below = companion_of(runs, r)
    if below is None:
        return None
    _, _, until = CASES[r["case"]]
    marks = [x for x in MARKS if x <= until]
    return estimate_error(as_result_arrays(r), as_result_arrays(below), marks, level=r["level"], companion_level=r["level"] - 1)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--elements", nargs="+", choices=list(ELEMENT_LEVELS), default=["hex8"])
    ap.add_argument("--levels", type=int, nargs="+", help="mesh levels studied (default 2 3 for hex8, 2 for tet10)")
    ap.add_argument("--tolerances", type=float, nargs="+", default=[0.02, 0.01])
    ap.add_argument("--out", type=Path, default=HERE / "accuracy.json")
    ap.add_argument("--references", type=Path, default=HERE / "references.json")
    ap.add_argument("--plot", type=Path, help="error against cost, one panel per case")
    ap.add_argument("--report-only", action="store_true", help="no new runs: tables from the stored ones")
    ap.add_argument("--pointwise", action="store_true", help="the estimate at every density against a mesh ladder's finest curve")
    ap.add_argument("--ladder-levels", type=int, nargs="+", default=[1, 2, 3, 4, 5], help="levels of the pointwise ladders")
    ap.add_argument("--plot-pointwise", type=Path, help="the pointwise true errors, one panel per case")
    args = ap.parse_args(argv)
    data: dict[str, Any] = json.loads(args.out.read_text()) if args.out.exists() else {}
    runs: dict[str, Any] = data.setdefault("runs", {})
    refs = json.loads(args.references.read_text())["cases"]

    if args.pointwise:
        ladders: dict[str, Any] = data.setdefault("ladders", {})
        cases = args.cases if args.cases != list(CASES) else ["sc", "bcc"]
        for case in cases:
            for level in args.ladder_levels:
                k = key(case, "hex8", level, LADDER_TOLERANCE)
                if k in ladders or args.report_only:
                    continue
                print(f"# ladder run {k}", file=sys.stderr, flush=True)
                ladders[k] = run(case, "hex8", level, LADDER_TOLERANCE)
                args.out.write_text(json.dumps(data) + "\n")
        pointwise(ladders, cases, args.plot_pointwise)
        return

    if not args.report_only:
        for case in args.cases:
            for element in args.elements:
                for level in args.levels or ELEMENT_LEVELS[element]:
                    for tol in args.tolerances:
                        # The companion first, then the run.
                        for lv, tl in ((level - 1, COMPANION_TOLERANCE_FACTOR * tol), (level, tol)):
                            k = key(case, element, lv, tl)
                            if lv < 1 or k in runs:
                                continue
                            print(f"# run {k}", file=sys.stderr, flush=True)
                            runs[k] = run(case, element, lv, tl)
                            args.out.write_text(json.dumps(data) + "\n")

    rows = report(runs, refs, args.cases, args.elements)
    if args.plot is not None:
        plot(rows, args.plot)


def report(runs: dict[str, Any], refs: dict[str, Any], cases: list[str], elements: list[str]) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for r in runs.values():
        if r["case"] not in cases or r["element"] not in elements:
            continue
        ref = refs[r["case"]]
        marks = [k for k in ref["times_s"]]
        t = {f"{m:g}": td.result.interpolate_time(np.asarray(r["time_s"]), np.asarray(r["rel_density"]), m) for m in MARKS}
        true = {k: (t[k] - ref["times_s"][k]) / ref["times_s"][k] for k in marks if t.get(k) is not None}
        unc = {k: ref["uncertainty_s"][k] / ref["times_s"][k] for k in marks}
        estimate = estimate_of(runs, r)
        below = companion_of(runs, r)
        cost = r["wall_s"] + (below["wall_s"] if below else float("nan"))
        # The reference's finest level: a run there is compared with itself.
        finest = max(ref["mesh"][marks[0]]["levels"])
        rows.append(
            {
                **{k: r[k] for k in ("case", "element", "level", "tolerance", "dofs", "wall_s", "steps")},
                "cost_s": cost,
                "true": true,
                "unc": unc,
                "estimate": estimate,
                "reference_level": finest,
            }
        )
    rows.sort(key=lambda x: (x["case"], x["element"], x["level"], -x["tolerance"]))
    counts = {"in": 0, "over": 0, "under": 0}
    for case in cases:
        for element in elements:
            group = [x for x in rows if x["case"] == case and x["element"] == element]
            if not group:
                continue
            for x in group:
                worst = max(abs(v) for v in x["true"].values())
                x["worst"] = worst
            # The front among results with an error estimate (those with a companion).
            priced = [x for x in group if x["estimate"] is not None]
            for x in group:
                x["pareto"] = x["estimate"] is not None and not any(
                    y is not x and y["cost_s"] <= x["cost_s"] and y["worst"] < x["worst"] for y in priced
                )
            marks = list(group[0]["true"])
            print(f"\n{case}, {element} (errors against references.json, the reference's own uncertainty in brackets)")
            print("observed orders of the reference ladders: " + "; ".join(orders(refs[case], k) for k in marks))
            print(
                "| level | tol | dofs | wall [s] | with companion [s] | steps | "
                + " | ".join(f"true t({k}) | est t({k})" for k in marks)
                + " | worst true | Pareto |"
            )
            print("|" + "---|" * (8 + 2 * len(marks)))
            for x in group:
                est: ErrorEstimate | None = x["estimate"]
                cells = []
                for k in marks:
                    tv = x["true"].get(k)
                    ev = est.relative.get(k) if est is not None else None
                    cells.append("-" if tv is None else f"{100 * tv:+.2f} % (±{100 * x['unc'][k]:.1f})")
                    mark = ""
                    if tv is not None and ev is not None and x["level"] < x["reference_level"]:
                        verdict = bracket(abs(tv), x["unc"][k], ev)
                        counts[verdict] += 1
                        mark = {"in": "", "over": " (over)", "under": " (UNDER)"}[verdict]
                    cells.append("-" if ev is None else f"{100 * ev:.2f} %{mark}")
                print(
                    f"| {x['level']} | {x['tolerance']:g} | {x['dofs']} | {x['wall_s']:.1f} | {'-' if x['estimate'] is None else format(x['cost_s'], '.1f')} | {x['steps']} | "
                    + " | ".join(cells)
                    + f" | {100 * x['worst']:.2f} % | {'yes' if x['pareto'] else ('' if x['estimate'] is not None else '-')} |"
                )
    convergence(runs, refs, rows, cases, elements)
    n = sum(counts.values())
    print(
        f"\nestimates against true errors: {n} (run, density) pairs; {counts['in']} bracketed "
        f"(est/3 <= |true| <= est), {counts['over']} more than 3 times the true error, "
        f"{counts['under']} below it (each allowed the reference's uncertainty; runs at the reference's finest level not counted)"
    )
    return rows


def convergence(runs: dict[str, Any], refs: dict[str, Any], rows: list[dict[str, Any]], cases: list[str], elements: list[str]) -> None:
    """What the estimator's convergence model rests on, per element: the
    signs of the changes along each three-level sequence of the study
    (levels 1, 2, 3 at tolerances 4 tau, 2 tau, tau), and the share e/d of
    the run-companion difference d (as the estimate takes it: its root mean
    square over the density window) that is the run's true error e, where e
    stands clear of the reference's uncertainty (|e| > 2 u). The estimate
    takes h^p / (H^p - h^p) with p = ``MESH_ORDER`` (1.5: 1.20 at level 2,
    1.85 at level 3)."""
    for element in elements:
        alternating = monotone = 0
        for case in cases:
            for tol in sorted({r["tolerance"] for r in runs.values()}):
                found = [runs.get(key(case, element, lv, tol * COMPANION_TOLERANCE_FACTOR ** (3 - lv))) for lv in (3, 2, 1)]
                chain = [c for c in found if c is not None]
                if len(chain) < 3:
                    continue
                for m in MARKS:
                    at = [td.result.interpolate_time(np.asarray(c["time_s"]), np.asarray(c["rel_density"]), m) for c in chain]
                    t = [v for v in at if v is not None]
                    if len(t) < 3 or f"{m:g}" not in refs[case]["times_s"]:
                        continue
                    if (t[0] - t[1]) * (t[1] - t[2]) < 0:
                        alternating += 1
                    else:
                        monotone += 1
        shares = []
        for x in rows:
            if x["element"] != element or x["case"] not in cases or x["estimate"] is None or x["level"] >= x["reference_level"]:
                continue
            # The difference d the estimate is made of: its root mean square
            # over the density window, the estimate over the Richardson factor.
            g = richardson_factor(x["level"], x["level"] - 1)
            for k, e in x["true"].items():
                est = x["estimate"].relative.get(k)
                if abs(e) <= 2 * x["unc"][k] or not est:
                    continue
                shares.append((e / (est / g), f"{x['case']} L{x['level']} tol {x['tolerance']:g} t({k})"))
        print(f"\n{element}: the changes along the three-level sequences alternate in sign in {alternating} of {alternating + monotone}")
        if shares:
            print(f"{element}: |e|/d where the true error stands clear of the reference's uncertainty ({len(shares)} pairs): "
                  + ", ".join(f"{abs(v):.2f} ({w})" for v, w in sorted(shares, key=lambda p: abs(p[0]))))


def pointwise(ladders: dict[str, Any], cases: list[str], plot_path: Path | None) -> None:
    """The estimate at every density of each ladder level against the
    ladder's finest curve (see the module docstring)."""
    panels = []
    print(
        f"\npointwise, against each ladder's finest level (tolerance {LADDER_TOLERANCE:g}; densities from rho0 + 0.04 to the end; "
        f"estimate: the run's own, from the level below; ceiling: the best any estimate can do that knows the error's "
        f"distribution within rho +-{CEILING_WINDOW:g} but not its phase)"
    )
    print("| case | level | truth | rms true error | bracketed | below | over 3x | true/est median, largest | ceiling |")
    print("|---|---|---|---|---|---|---|---|---|")
    for case in cases:
        levels = sorted(r["level"] for r in ladders.values() if r["case"] == case)
        if len(levels) < 3:
            continue
        top = levels[-1]
        curves = {lv: ladders[key(case, "hex8", lv, LADDER_TOLERANCE)] for lv in levels}
        lo = max(c["rel_density"][0] for c in curves.values()) + 0.04
        hi = min(c["rel_density"][-1] for c in curves.values())
        grid = np.linspace(lo, hi, POINTWISE_SAMPLES)
        step = grid[1] - grid[0]
        truth = _times(curves[top], grid)
        errors = {}
        for lv in levels[1:-1]:
            t = _times(curves[lv], grid)
            true = np.abs(t - truth) / truth
            errors[lv] = (t - truth) / truth
            est = estimate_error(as_result_arrays(curves[lv]), as_result_arrays(curves[lv - 1]), list(grid), level=lv, companion_level=lv - 1)
            e = np.array([est.relative[f"{m:g}"] or np.nan for m in grid])
            ok = np.isfinite(e)
            inside = np.mean((true[ok] >= e[ok] / 3) & (true[ok] <= e[ok]))
            below = np.mean(true[ok] > e[ok])
            over = np.mean(true[ok] < e[ok] / 3)
            ratio = true[ok] / e[ok]
            half = int(round(CEILING_WINDOW / step))
            best = []
            for i in range(len(grid)):
                near = true[max(0, i - half) : i + half + 1]
                candidates = np.quantile(near, np.linspace(0.05, 1.0, 40))
                best.append(max(float(np.mean((near >= x / 3) & (near <= x))) for x in candidates))
            print(
                f"| {case} | {lv} | level {top}{' (one up)' if top - lv == 1 else ''} | {100 * np.sqrt(np.mean(errors[lv] ** 2)):.2f} % | "
                f"{100 * inside:.0f} % | {100 * below:.0f} % | {100 * over:.0f} % | {np.median(ratio):.2f}, {ratio.max():.2f} | {100 * np.mean(best):.0f} % |"
            )
        panels.append((case, top, grid, errors))
    if plot_path is None or not panels:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 3.8), squeeze=False)
    for ax, (case, top, grid, errors) in zip(axes.flat, panels):
        for lv, e in errors.items():
            ax.plot(grid, 100 * e, lw=1.0, label=f"level {lv}")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylim(-12, 12)
        ax.set_title(f"{case}: t(rho) against level {top}")
        ax.set_xlabel("relative density")
        ax.set_ylabel("relative error of t(rho) [%]")
        ax.legend(fontsize=7)
    _save(fig, plot_path)


def _times(r: dict[str, Any], grid: np.ndarray) -> np.ndarray:
    """t(rho) of a stored run on a density grid (first arrival, linear between steps)."""
    rho = np.asarray(r["rel_density"], float)
    keep = np.concatenate([[True], np.diff(rho) > 0])
    return np.asarray(np.interp(grid, rho[keep], np.asarray(r["time_s"], float)[keep]))


def orders(ref: dict[str, Any], mark: str) -> str:
    """The observed mesh and time orders of a reference at one density."""

    def fmt(x: float | None) -> str:
        return "none (not monotone)" if x is None else f"{x:.2f}"

    return f"t({mark}): mesh {fmt(ref['mesh'][mark]['order'])}, time {fmt(ref['time'][mark]['order'])}"


def bracket(true: float, uncertainty: float, est: float) -> str:
    """Whether ``est`` brackets the true relative error as est/3 <= true <=
    est, either side allowed the reference's ``uncertainty``."""
    if true > est + uncertainty:
        return "under"
    if true + uncertainty < est / 3:
        return "over"
    return "in"


def plot(rows: list[dict[str, Any]], path: Path) -> None:
    """Largest true error (filled) and largest estimate (open, joined to it)
    against the wall time with the companion, per case; the line is the
    Pareto front."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = sorted({x["case"] for x in rows})
    ncol = 3
    nrow = (len(cases) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), squeeze=False)
    for ax in axes.flat[len(cases) :]:
        ax.set_visible(False)
    for ax, case in zip(axes.flat, cases):
        for element, color in (("hex8", "C0"), ("tet10", "C1")):
            group = [x for x in rows if x["case"] == case and x["element"] == element and x["estimate"] is not None]
            if not group:
                continue
            cost = [x["cost_s"] for x in group]
            true = [100 * x["worst"] for x in group]
            est = [100 * max(v for v in x["estimate"].relative.values() if v is not None) for x in group]
            ax.scatter(cost, true, color=color, label=f"{element}: true error")
            ax.scatter(cost, est, facecolors="none", edgecolors=color, label=f"{element}: estimate")
            for c, t, e in zip(cost, true, est):
                ax.plot([c, c], [t, e], color=color, lw=0.6, alpha=0.5)
            front = sorted((x for x in group if x["pareto"]), key=lambda x: x["cost_s"])
            ax.plot([x["cost_s"] for x in front], [100 * x["worst"] for x in front], "-", color=color, alpha=0.6)
            for x in group:
                ax.annotate(f"L{x['level']}/{x['tolerance']:g}", (x["cost_s"], 100 * x["worst"]), fontsize=6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(case)
        ax.set_xlabel("wall time with the companion [s]")
        ax.set_ylabel("largest error of t(rho) [%]")
        ax.legend(fontsize=6)
    _save(fig, path)


def _save(fig: Any, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
