"""What a step of a random periodic packing costs against its number of
particles.

    python benches/random_cost.py [--particles 8 16 32 64] [--seed 0] [--level 1]
                                  [--steps 5] [--save cost.json] [--report-only JSON]

For each particle count, a jammed random packing of that many spheres
(``cells.random(n, seed=...)``, Ti-6Al-4V creep at 1293 K, 10 MPa, 1 s ramp,
default solver settings at ``--level``) is pressed for ``--steps``
accepted steps, each count in its own process (so that its peak memory is
its own). Printed per count: the packing's rho0 and mean coordination
number, the time to build the packing and the case's meshes (the first
point), the unknowns, the steps and Newton iterations taken, the wall time
per step (the run's wall time less the setup, over its steps), the time
per Newton iteration spent in element evaluations, particle contact,
assembly, and factorisations and solves (and their sum), and the peak
resident memory. The ratio columns compare
each count with the smallest: a cost per iteration that grows as the
unknowns do is linear in the particle count.

The first steps of a packing are the ramp, where its contacts first press;
their cost per Newton iteration is that of any step of the run (the same
system, the same pairing), their number of iterations is not.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from typing import Any

import tidens_rs as td

import saved_rows


def one(particles: int, seed: int, level: int, steps: int) -> dict[str, Any]:
    start = time.perf_counter()
    cell = td.cells.random(particles, seed=seed)
    packed = time.perf_counter() - start
    case = td.Case(cell, td.materials.TI64_CREEP_1293K, 10.0, solver=td.SolverSettings(mesh_level=level))
    built = time.perf_counter()
    case.simulation(0.95, None, [])
    setup = time.perf_counter() - built

    def stop_after(p: dict[str, float]) -> bool:
        return int(p["step"]) < steps

    row: dict[str, Any] = {"particles": particles, "seed": seed, "level": level, "pack_s": packed}
    started = time.perf_counter()
    try:
        r = case.run(0.95, error_estimate=False, callback=stop_after)
        row["status"] = r.status
    except td.ConvergenceError as e:
        r = e.result
        row["status"] = f"failed ({e.reason})"
    stepping = time.perf_counter() - started - setup
    s = r.stats
    newton = max(int(s["newton_iterations"]), 1)
    parts = ("evaluation", "contact", "assembly", "linear")
    summary = r.summary()
    row.update(
        rho0=float(r.rel_density[0]),
        coordination_number=summary.get("coordination_number"),
        setup_s=setup,
        dofs=r.degrees_of_freedom,
        steps=int(s["steps"]),
        newton=int(s["newton_iterations"]),
        failed_attempts=int(s["failed_attempts"]),
        per_step_s=stepping / max(int(s["steps"]), 1),
        per_newton_s=sum(float(s[f"{k}_seconds"]) for k in parts) / newton,
        **{f"{k}_per_newton_s": float(s[f"{k}_seconds"]) / newton for k in parts},
        peak_rss_gb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
    )
    return row


def report(rows: list[dict[str, Any]]) -> None:
    print(
        "| particles | rho0 | Z | unknowns | pack + mesh [s] | steps | Newton | s / step | s / Newton "
        "| elements | contact | assembly | linear | peak RSS [GB] | s / Newton vs first | unknowns vs first |"
    )
    print("|" + "---|" * 16)
    base = rows[0] if rows else None
    for r in rows:
        if "error" in r:
            print(f"| {r['particles']} | {r['error']} |")
            continue
        z = "-" if r["coordination_number"] is None else f"{r['coordination_number']:.2f}"
        ratio = r["per_newton_s"] / base["per_newton_s"] if base else float("nan")
        dofs = r["dofs"] / base["dofs"] if base else float("nan")
        print(
            f"| {r['particles']} | {r['rho0']:.4f} | {z} | {r['dofs']} | {r['pack_s'] + r['setup_s']:.1f} | "
            f"{r['steps']} | {r['newton']} | {r['per_step_s']:.2f} | {r['per_newton_s']:.2f} | "
            f"{r['evaluation_per_newton_s']:.2f} | {r['contact_per_newton_s']:.2f} | "
            f"{r['assembly_per_newton_s']:.2f} | {r['linear_per_newton_s']:.2f} | {r['peak_rss_gb']:.2f} | "
            f"{ratio:.2f} | {dofs:.2f} |"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--particles", type=int, nargs="+", default=[8, 16, 32, 64])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--level", type=int, default=1)
    ap.add_argument("--steps", type=int, default=5)
    saved_rows.add_options(ap)
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if saved_rows.report_only(args, report):
        return
    if args.one:
        print(json.dumps(one(args.particles[0], args.seed, args.level, args.steps)))
        return
    rows: list[dict[str, Any]] = []
    for n in args.particles:
        cmd = [sys.executable, __file__, "--one", "--particles", str(n), "--seed", str(args.seed)]
        cmd += ["--level", str(args.level), "--steps", str(args.steps)]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            rows.append({"particles": n, "error": done.stderr.strip().splitlines()[-1] if done.stderr else "failed"})
        else:
            rows.append(json.loads(done.stdout.strip().splitlines()[-1]))
        print(f"{n} particles: {rows[-1]}", flush=True)
        saved_rows.save(args, rows)
    report(rows)


if __name__ == "__main__":
    main()
