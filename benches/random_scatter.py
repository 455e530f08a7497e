"""How much a random packing's densification curve depends on the
generator's seed, against its number of particles.

    python benches/random_scatter.py [--particles 8 16] [--seeds 0 1 2 3]
                                     [--until 0.75] [--level 1]
                                     [--save scatter.json] [--report-only JSON]

For each particle count and seed, a jammed random packing of that many
spheres (``cells.random(n, seed=...)``, Ti-6Al-4V creep at 1293 K, 10 MPa,
1 s ramp, default solver settings at ``--level``) is pressed until the
time ``--until`` [s]. Printed per run: the spheres' rho0 and mean
coordination number, the meshed particles' density at the start and at a
few times, its rise by the last one, the Newton iterations and failed
attempts, and the wall time. Then, per particle count: how many distinct
packings the seeds gave (a small periodic box jams in few states, and
seeds that jam in the same state, shifted, give it again), and the mean,
standard deviation and range over the seeds of the density at each time
all of them reached and of its rise from the start, and the largest
spread among seeds that gave one packing. Such seeds differ only by where
the packing lies in the box (and so by the mesh's placement and the
particles' order): their spread is the solver's, the rest is the
packings'.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from typing import Any

import numpy as np
import tidens_rs as td

import saved_rows

# Times [s] at which each run's density is read (those up to --until).
MARKS = (0.25, 0.5, 0.75, 1.0, 2.0)

# Two packings whose spheres' densities agree to this are taken as one
# jammed state (the generator's round-off is far below it).
SAME_STATE = 1e-9


def one(particles: int, seed: int, level: int, until: float) -> dict[str, Any]:
    """The row of one packing pressed to ``until`` [s]."""
    started = time.perf_counter()
    cell = td.cells.random(particles, seed=seed)
    case = td.Case(cell, td.materials.TI64_CREEP_1293K, 10.0, solver=td.SolverSettings(mesh_level=level))
    row: dict[str, Any] = {"particles": particles, "seed": seed, "level": level, "until_s": until}
    try:
        r = case.run(None, until, error_estimate=False)
        row["status"] = r.status
    except td.ConvergenceError as e:
        r = e.result
        row["status"] = f"failed ({e.reason})"
    t = np.asarray(r.curve["time_s"])
    rho = np.asarray(r.curve["rel_density"])
    s = r.stats
    row.update(
        rho0_spheres=cell.rho0,
        coordination_number=r.summary().get("coordination_number"),
        rho_start=float(rho[0]),
        t_end_s=float(t[-1]),
        rho_end=float(rho[-1]),
        rho_at={str(m): float(np.interp(m, t, rho)) for m in MARKS if m <= t[-1]},
        newton=int(s["newton_iterations"]),
        failed_attempts=int(s["failed_attempts"]),
        wall_s=time.perf_counter() - started,
    )
    return row


def report(rows: list[dict[str, Any]]) -> None:
    marks = sorted({m for r in rows for m in r.get("rho_at", {})}, key=float)
    head = "".join(f" rho({m} s) |" for m in marks)
    print(f"| particles | seed | rho0 | Z | rho at start |{head} rise to the end | Newton | failed | wall [s] |")
    print("|" + "---|" * (9 + len(marks)))
    for r in rows:
        cells = "".join(f" {r['rho_at'][m]:.4f} |" if m in r["rho_at"] else " - |" for m in marks)
        z = "-" if r["coordination_number"] is None else f"{r['coordination_number']:.2f}"
        print(
            f"| {r['particles']} | {r['seed']} | {r['rho0_spheres']:.4f} | {z} | {r['rho_start']:.4f} |{cells} "
            f"{r['rho_end'] - r['rho_start']:.4f} | {r['newton']} | {r['failed_attempts']} | {r['wall_s']:.0f} |"
        )
    print()
    print(
        "| particles | time [s] | seeds | distinct packings | density: mean, std, range "
        "| rise: mean, std, range | largest spread within one packing |"
    )
    print("|" + "---|" * 7)
    for n in sorted({r["particles"] for r in rows}):
        group = [r for r in rows if r["particles"] == n and r["status"] == "reached_time"]
        states: list[list[dict[str, Any]]] = []
        for r in group:
            same = [g for g in states if abs(g[0]["rho0_spheres"] - r["rho0_spheres"]) <= SAME_STATE]
            if same:
                same[0].append(r)
            else:
                states.append([r])
        for m in marks:
            if not group or any(m not in r["rho_at"] for r in group):
                continue
            at = [r["rho_at"][m] for r in group]
            rise = [r["rho_at"][m] - r["rho_start"] for r in group]
            spreads = [max(r["rho_at"][m] for r in g) - min(r["rho_at"][m] for r in g) for g in states if len(g) > 1]
            within = f"{max(spreads):.4f}" if spreads else "-"
            print(f"| {n} | {m} | {len(group)} | {len(states)} | {_spread(at)} | {_spread(rise)} | {within} |")


def _spread(v: list[float]) -> str:
    """Mean, standard deviation and range of ``v``."""
    sd = f"{statistics.stdev(v):.4f}" if len(v) > 1 else "-"
    return f"{statistics.fmean(v):.4f}, {sd}, {min(v):.4f}-{max(v):.4f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--particles", type=int, nargs="+", default=[8, 16])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--until", type=float, default=0.75, help="the time each packing is pressed to [s]")
    ap.add_argument("--level", type=int, default=1)
    saved_rows.add_options(ap)
    args = ap.parse_args()
    if saved_rows.report_only(args, report):
        return
    rows: list[dict[str, Any]] = []
    for n in args.particles:
        for seed in args.seeds:
            rows.append(one(n, seed, args.level, args.until))
            print(f"{n} particles, seed {seed}: {rows[-1]}", flush=True)
            saved_rows.save(args, rows)
    report(rows)


if __name__ == "__main__":
    main()
