"""Periodic cells of whole particles against the octant cells of the same
lattice: does the lattice as whole spheres in a periodic box (``tidens run
--cell bcc --periodic``) densify as its octant cell, and at what cost?

    python benches/periodic.py [--cells sc bcc fcc] [--level 1] [--until 0.8]
                               [--timeout 1800] [--save periodic.json] [--report-only JSON]

Each lattice (Ti-6Al-4V creep at 1293 K, 10 MPa, 1 s ramp, default solver
settings) is pressed twice to ``--until``: as its cell of octants between
mirror planes and as ``cells.as_periodic`` of it, both meshed without the
exact volume (a periodic cell's particles keep their surface nodes on the
spheroid), so that the two meshes hold the same particles. Per run it
prints status, steps, Newton iterations, failed attempts, wall time and
the times to density; per lattice, the periodic run's times against the
octant cell's. ``--timeout`` stops a run after that many seconds.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import tidens_rs as td

import saved_rows

MARKS = (0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95)


def run(cell_name: str, periodic: bool, level: int, until: float, timeout: float) -> dict[str, Any]:
    cell = td.cells.by_name(cell_name)
    if periodic:
        cell = td.cells.as_periodic(cell)
    case = td.Case(
        cell, td.materials.TI64_CREEP_1293K, 10.0, solver=td.SolverSettings(mesh_level=level, exact_volume=False)
    )
    start = time.perf_counter()
    row: dict[str, Any] = {"cell": cell_name, "periodic": periodic}
    try:
        r = case.run(until, error_estimate=False, callback=lambda _: time.perf_counter() - start < timeout)
        row["status"] = r.status if r.status != "stopped" else "timeout"
    except td.ConvergenceError as e:
        r = e.result
        row["status"] = f"failed ({e.reason}) at rho = {r.rel_density[-1]:.4f}"
    row.update(
        wall_s=time.perf_counter() - start,
        dofs=r.degrees_of_freedom,
        steps=r.stats["steps"],
        newton=r.stats["newton_iterations"],
        failed_attempts=r.stats["failed_attempts"],
        rho0=float(r.rel_density[0]),
        times={f"{m:g}": r.time_to_density(m) for m in MARKS if r.rel_density[0] < m <= r.rel_density[-1]},
        max_depth_over_radius=r.checks()["max_depth_over_radius"],
    )
    return row


def report(rows: list[dict[str, Any]]) -> None:
    print("| cell | cell kind | status | unknowns | steps | Newton | failed | wall [s] | depth / R |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        kind = "periodic" if r["periodic"] else "octants"
        depth = "-" if r["max_depth_over_radius"] is None else f"{r['max_depth_over_radius']:.1e}"
        print(
            f"| {r['cell']} | {kind} | {r['status']} | {r['dofs']} | {r['steps']} | {r['newton']} | "
            f"{r['failed_attempts']} | {r['wall_s']:.1f} | {depth} |"
        )
    print()
    print("| cell | rho | t octants [s] | t periodic [s] | periodic / octants - 1 |")
    print("|---|---|---|---|---|")
    for cell in dict.fromkeys(r["cell"] for r in rows):
        pair = {r["periodic"]: r for r in rows if r["cell"] == cell}
        if len(pair) < 2:
            continue
        for m in MARKS:
            a, b = pair[False]["times"].get(f"{m:g}"), pair[True]["times"].get(f"{m:g}")
            if a is not None and b is not None:
                print(f"| {cell} | {m:g} | {a:.4g} | {b:.4g} | {100 * (b / a - 1):+.2f} % |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", nargs="+", default=["sc", "bcc", "fcc"], choices=td.cells.CELL_NAMES)
    ap.add_argument("--level", type=int, default=1)
    ap.add_argument("--until", type=float, default=0.8)
    ap.add_argument("--timeout", type=float, default=1800.0)
    saved_rows.add_options(ap)
    args = ap.parse_args()
    if saved_rows.report_only(args, report):
        return
    rows: list[dict[str, Any]] = []
    for cell in args.cells:
        for periodic in (False, True):
            rows.append(run(cell, periodic, args.level, args.until, args.timeout))
            r = rows[-1]
            print(f"{cell} {'periodic' if periodic else 'octants'}: {r['status']}, {r['steps']} steps, "
                  f"{r['newton']} Newton, {r['wall_s']:.1f} s", flush=True)
            saved_rows.save(args, rows)
    report(rows)


if __name__ == "__main__":
    main()
