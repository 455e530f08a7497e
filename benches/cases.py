"""Whole-case measurements: the sc Ti-6Al-4V cell at 10 MPa (to rho = 0.9),
every cell of the paper at 15 MPa (to 0.95), and the two elements.

    python benches/cases.py levels [--levels 1 2 3 4] [--tolerance 0.01]
    python benches/cases.py tolerance [--level 2] [--tolerances 0.04 0.02 0.01 0.005] [--reference 0.001]
    python benches/cases.py cells [--level 2] [--cells sc-0.8 sc sc-1.2 bcc fcc sc2] [--plot cells.png]
    python benches/cases.py elements [--hex-level 3] [--tet-levels 1 2]

``levels`` prints, per mesh level, the times to 0.6/0.7/0.8/0.9 beside the
continuum model's, the change from the previous level, wall time, steps,
Newton iterations and factorisations. ``tolerance`` prints the error of
t(0.8) and t(0.9) against a run with a much tighter tolerance, beside the
run's own error estimate and its wall time (error against run time).
``cells`` presses each cell (sc at c/a 0.8, 1, 1.2; bcc; fcc; sc2) at
15 MPa to rho = 0.95 and prints rho0 (mesh and exact), t(0.9) and t(0.95)
beside the continuum model's, wall time, steps, Newton iterations, whether
the curve is monotone, the largest penetration over R, and per particle the
mean equivalent plastic strain at the end (a plain mean over its elements).
``elements`` runs the sc cell at 15 MPa to 0.95 with the 8-node hex and the
10-node tet and prints the times to density at each mesh's dofs.
Figures are medians of ``--repeat`` runs for wall time (default 1).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import tidens_rs as td

MARKS = (0.6, 0.7, 0.8, 0.9)


def reached(result: td.Result, rho: float) -> float:
    """Time to ``rho`` [s]; every run here goes at least that far."""
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


CELL_STRESS_MPA = 15.0
CELL_MARKS = (0.9, 0.95)


def cell_of(spec: str) -> td.Cell:
    """``sc``, ``sc-0.8`` (sc with c/a = 0.8), ``bcc``, ``fcc`` or ``sc2``."""
    name, _, aspect = spec.partition("-")
    return td.cells.by_name(name, aspect_ratio=float(aspect) if aspect else 1.0)


def press(cell: td.Cell, level: int, element: str = "hex8", until: float = 0.95) -> tuple[td.Result, float]:
    case = td.Case(
        cell=cell,
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=CELL_STRESS_MPA,
        solver=td.SolverSettings(mesh_level=level, element=element),
    )
    t0 = time.perf_counter()
    result = case.run(until_density=until)
    return result, time.perf_counter() - t0


def particle_strains(cell: td.Cell, result: td.Result) -> list[tuple[float, float]]:
    """(radius a [mm], mean eqps over its elements) per particle, at the end."""
    f = result.snapshots[-1].fields
    return [(a, float(np.mean(f["eqps"][f["particle"] == k]))) for k, (_, a, _) in enumerate(cell.octants)]


def cells(args: argparse.Namespace) -> None:
    print(f"Ti-6Al-4V 1293 K, {CELL_STRESS_MPA} MPa (1 s ramp), level {args.level}, tolerance {td.DEFAULT_TOLERANCE}, to rho = 0.95")
    header = "| cell | dofs | rho0 mesh (exact) | t(0.9) [s] | t(0.95) [s] | continuum t(0.9), t(0.95) [s] | wall [s] | steps | Newton | monotone | max penetration / R |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    strains = {}
    curves = {}
    for spec in args.cells:
        cell = cell_of(spec)
        r, wall = press(cell, args.level)
        times = [reached(r, x) for x in CELL_MARKS]
        cont = r.continuum().time_to_density(list(CELL_MARKS))
        s = r.summary()
        radius = max(a for _, a, _ in cell.octants)
        monotone = bool(np.all(np.diff(r.rel_density) >= 0.0))
        pen = float(np.max(r.curve["max_penetration_mm"])) / radius
        print(
            f"| {spec} | {r.degrees_of_freedom} | {r.rel_density[0]:.5f} ({cell.rho0:.5f}) | "
            + " | ".join(f"{t:.1f}" for t in times)
            + f" | {cont[0]:.1f}, {cont[1]:.1f} | {wall:.1f} | {s['steps']} | {s['newton_iterations']} | {monotone} | {pen:.1e} |"
        )
        strains[spec] = particle_strains(cell, r)
        curves[spec] = r
    print("\nMean equivalent plastic strain per particle at rho = 0.95 (radius [mm]: values); spread = max/min - 1 among particles of one size")
    print("(octants of one size are meshed as mirror images, so the spread shows how far the solution keeps the packing's symmetry)")
    for spec, values in strains.items():
        sizes = sorted({round(a, 12) for a, _ in values}, reverse=True)
        parts = []
        for size in sizes:
            e = [v for a, v in values if round(a, 12) == size]
            parts.append(f"R = {size:.4f}: " + ", ".join(f"{v:.4f}" for v in e) + f" (spread {max(e) / min(e) - 1:.1e})")
        print(f"- {spec}: " + "; ".join(parts))
    if args.plot:
        plot_cells(curves, args.plot)


def plot_cells(curves: dict[str, td.Result], path: str) -> None:
    """Density against time of every cell (solid) beside its continuum model
    (dashed, same colour); sc at other aspect ratios share sc's model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k, (spec, r) in enumerate(curves.items()):
        colour = f"C{k}"
        ax.plot(r.time_s, r.rel_density, color=colour, label=f"{spec} (FE)")
        if "-" not in spec:
            t, rho = r.continuum().curve(0.95)
            ax.plot(t, rho, "--", color=colour, lw=1, label=f"{spec} (continuum)")
    ax.set_xscale("log")
    ax.set_xlim(left=0.5)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("relative density")
    ax.set_title(f"Ti-6Al-4V, 1293 K, {CELL_STRESS_MPA:g} MPa")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def elements(args: argparse.Namespace) -> None:
    marks = (0.6, 0.7, 0.8, 0.9, 0.95)
    print(f"sc, Ti-6Al-4V 1293 K, {CELL_STRESS_MPA} MPa, tolerance {td.DEFAULT_TOLERANCE}")
    header = "| element | level | dofs | rho0 | " + " | ".join(f"t({x}) [s]" for x in marks) + " | wall [s] | steps | Newton |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    runs = [("hex8", level) for level in args.hex_levels] + [("tet10", level) for level in args.tet_levels]
    for element, level in runs:
        r, wall = press(td.cells.sc(), level, element)
        s = r.summary()
        print(
            f"| {element} | {level} | {r.degrees_of_freedom} | {r.rel_density[0]:.5f} | "
            + " | ".join(f"{reached(r, x):.2f}" for x in marks)
            + f" | {wall:.1f} | {s['steps']} | {s['newton_iterations']} |"
        )


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
    c = sub.add_parser("cells")
    c.add_argument("--level", type=int, default=2)
    c.add_argument("--cells", nargs="+", default=["sc-0.8", "sc", "sc-1.2", "bcc", "fcc", "sc2"])
    c.add_argument("--plot", default=None, help="write density against time of every cell to this PNG")
    e = sub.add_parser("elements")
    e.add_argument("--hex-levels", type=int, nargs="+", default=[3])
    e.add_argument("--tet-levels", type=int, nargs="+", default=[1, 2])
    args = p.parse_args()
    {"levels": levels, "tolerance": tolerance, "cells": cells, "elements": elements}[args.what](args)


if __name__ == "__main__":
    main()
