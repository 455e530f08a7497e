"""Stiff and extreme cases: does every case run, converge and stay physical,
and what does it cost against the base case on the same mesh?

    python benches/extremes.py [--cells sc bcc sc2] [--level 3] [--only n stress ...]
                               [--timeout 600] [--save extremes.json]

Each case changes one thing of the base case (Ti-6Al-4V creep at 1293 K,
10 MPa, ramp 1 s, to rho = 0.9, default solver settings): the creep exponent
n (with C scaled so that the creep rate at 10 MPa stays the base's), the
coefficient C, the stress, E/sigma, nu, the aspect ratio c/a, the final
density, a long hold. Per case it prints the status (or the refusal, with
its reason), wall time and its ratio to the base case's, steps, Newton
iterations (and their ratio to the base case's, steadier than the wall
time's when other jobs share the machine), failed attempts, t(0.9), and
the physical checks of
``Result.checks()``: rho(t) monotone (to what Newton's tolerance leaves), no
NaN, particle volume kept to the elastic part (|dV/V| against
2 f sigma / (rho0 K), K the bulk modulus), the largest penetration within
the contact tolerance (1e-4 of the radius). ``--timeout`` stops a case after that many
seconds (reported as "timeout").
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any


import tidens_rs as td

import saved_rows

BASE_MATERIAL = td.materials.TI64_CREEP_1293K
BASE_STRESS = 10.0
BASE_DENSITY = 0.9


@dataclass
class Variant:
    """One case of the matrix: a group, a label, and what it changes."""

    group: str
    label: str
    stress: float = BASE_STRESS
    material: Callable[[], td.Material] = lambda: BASE_MATERIAL
    aspect: float = 1.0
    until_density: float | None = BASE_DENSITY
    until_time: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)


def norton(n: float, c: float | None = None) -> td.Material:
    """The base material with exponent n; C keeps the base's rate at 10 MPa
    unless given."""
    m = BASE_MATERIAL
    if c is None:
        c = m.creep_c * BASE_STRESS ** (m.creep_n - n)
    return td.Material(m.young_mpa, m.poisson, c, n)


def _with_n(n: float) -> Callable[[], td.Material]:
    return lambda: norton(n)


def _with_c(c: float) -> Callable[[], td.Material]:
    return lambda: norton(BASE_MATERIAL.creep_n, c)


def _with_elastic(young: float, nu: float) -> Callable[[], td.Material]:
    return lambda: BASE_MATERIAL.with_elastic(young, nu)


def variants() -> list[Variant]:
    m = BASE_MATERIAL
    out = [Variant("base", "base")]
    out += [Variant("n", f"n = {n:g}", material=_with_n(n)) for n in (1.0, 2.8, 8.0, 15.0, 50.0)]
    out += [Variant("C", f"C = {c:g}", material=_with_c(c)) for c in (1e-12, 1e-9, 1e-3)]
    out += [Variant("stress", f"stress = {s:g} MPa", stress=s) for s in (1e-3, 0.1, 1.0, 100.0, 200.0)]
    out += [
        Variant("E/sigma", f"E/sigma = {r:g}", material=_with_elastic(r * BASE_STRESS, m.poisson))
        for r in (1e2, 1e3, 1e5, 1e7)
    ]
    out += [Variant("nu", f"nu = {nu:g}", material=_with_elastic(m.young_mpa, nu)) for nu in (0.45, 0.49, 0.499)]
    out += [Variant("c/a", f"c/a = {k:g}", aspect=k) for k in (0.2, 0.5, 2.0, 5.0)]
    out += [Variant("density", "to rho = 0.99", until_density=0.99)]
    out += [Variant("hold", "hold to 1e6 s", until_density=None, until_time=1e6)]
    return out


def cell_of(name: str, aspect: float) -> td.Cell:
    return td.cells.by_name(name, aspect_ratio=aspect)


def run_one(cell_name: str, v: Variant, level: int, timeout: float) -> dict[str, Any]:
    row: dict[str, Any] = {"cell": cell_name, "group": v.group, "case": v.label}
    try:
        material = v.material()
        case = td.Case(
            cell=cell_of(cell_name, v.aspect),
            material=material,
            stress_mpa=v.stress,
            solver=td.SolverSettings(mesh_level=level, **v.extra),
        )
    except (ValueError, TypeError, td.TidensError) as e:
        row.update(status="refused", reason=str(e))
        return row
    start = time.perf_counter()

    def stop_after(_: dict[str, float]) -> bool:
        return time.perf_counter() - start < timeout

    try:
        r = case.run(v.until_density, v.until_time, error_estimate=False, callback=stop_after)
        status = r.status if r.status != "stopped" else "timeout"
    except td.ConvergenceError as e:
        r = e.result
        status = f"failed ({e.reason})"
    except (ValueError, td.TidensError) as e:
        row.update(status="refused", reason=str(e))
        return row
    wall = time.perf_counter() - start
    rho, t = r.rel_density, r.time_s
    checks = r.checks()
    row.update(
        status=status,
        wall_s=wall,
        steps=r.stats["steps"],
        newton=r.stats["newton_iterations"],
        failed_attempts=r.stats["failed_attempts"],
        final_density=float(rho[-1]),
        final_time_s=float(t[-1]),
        t09_s=r.time_to_density(0.9) if rho[-1] >= 0.9 else None,
        monotone=checks["monotone"],
        finite=checks["finite"],
        volume_change=checks["volume_change"],
        volume_bound=checks["volume_change_bound"],
        penetration_over_radius=checks["max_penetration_over_radius"],
        depth_over_radius=checks.get("max_depth_over_radius"),
        physical=checks["ok"],
        stats=dict(r.stats),
        dofs=case.simulation(v.until_density, v.until_time, []).degrees_of_freedom,
    )
    return row


def fmt(x: Any, spec: str = ".3g") -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "NO"
    if isinstance(x, float):
        return format(x, spec)
    return str(x)


def report(rows: list[dict[str, Any]]) -> None:
    by_cell: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        by_cell.setdefault(r["cell"], []).append(r)
    for cell, rs in by_cell.items():
        base = next((r for r in rs if r["case"] == "base" and "wall_s" in r), None)
        print(f"\n{cell}")
        print("| case | status | wall [s] | / base | steps | Newton | / base | failed attempts | final rho | t(0.9) [s] | monotone | finite | |dV/V| (bound) | pen / R | depth / R | physical |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for r in rs:
            if r["status"] == "refused":
                print(f"| {r['case']} | refused: {r['reason']} |" + " |" * 14)
                continue
            ratio = r["wall_s"] / base["wall_s"] if base else None
            newton_ratio = r["newton"] / base["newton"] if base else None
            print(
                f"| {r['case']} | {r['status']} | {fmt(r['wall_s'], '.1f')} | {fmt(ratio, '.2f')} | {r['steps']} | {r['newton']} | {fmt(newton_ratio, '.2f')} | "
                f"{r['failed_attempts']} | {fmt(r['final_density'], '.4f')} | {fmt(r['t09_s'])} | {fmt(r['monotone'])} | {fmt(r['finite'])} | "
                f"{fmt(r['volume_change'], '.2e')} ({fmt(r['volume_bound'], '.1e')}) | {fmt(r['penetration_over_radius'], '.1e')} | {fmt(r.get('depth_over_radius'), '.1e')} | {fmt(r['physical'])} |"
            )
        costs(rs)


def costs(rows: list[dict[str, Any]]) -> None:
    """Where each run's time went: the unknowns (a cell of other particles,
    c/a != 1, has another mesh), residual evaluations (the line search's
    included), tangents, factorisations, and the seconds in elements,
    particle contact, assembly and the linear solves."""
    rows = [r for r in rows if r.get("stats")]
    if not rows:
        return
    print("\n| case | unknowns | evaluations | tangents | factorisations (LBL^T) | elements [s] | contact [s] | assembly [s] | linear [s] | other [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        st = r["stats"]
        parts = [st["evaluation_seconds"], st["contact_seconds"], st["assembly_seconds"], st["linear_seconds"]]
        print(
            f"| {r['case']} | {r.get('dofs', '-')} | {st['evaluations']} | {st['tangent_evaluations']} | "
            f"{st['llt_factorizations'] + st['lblt_factorizations']} ({st['lblt_factorizations']}) | "
            + " | ".join(f"{x:.1f}" for x in parts)
            + f" | {r['wall_s'] - sum(parts):.1f} |"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", nargs="+", default=["sc", "bcc", "sc2"], choices=td.cells.CELL_NAMES)
    ap.add_argument("--level", type=int, default=td.DEFAULT_MESH_LEVEL)
    ap.add_argument("--only", nargs="+", help="groups to run (base, n, C, stress, E/sigma, nu, c/a, density, hold)")
    ap.add_argument("--timeout", type=float, default=600.0)
    saved_rows.add_options(ap)
    args = ap.parse_args()
    if saved_rows.report_only(args, report):
        return
    rows = []
    for cell in args.cells:
        for v in variants():
            if args.only and v.group not in args.only and v.group != "base":
                continue
            row = run_one(cell, v, args.level, args.timeout)
            rows.append(row)
            print(f"# {cell} {v.label}: {row['status']} {fmt(row.get('wall_s'), '.1f')} s", flush=True)
            saved_rows.save(args, rows)
    report(rows)


if __name__ == "__main__":
    main()
