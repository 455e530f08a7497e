"""The Python API: runs, results, errors, partial results, threads."""

import dataclasses
import math
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import tidens_rs as td


def test_run_gives_a_consistent_curve(quick_case: td.Case) -> None:
    r = quick_case.run(until_density=0.6)
    assert r.status == "reached_density"
    c = r.curve
    n = len(r.time_s)
    assert all(len(v) == n for v in c.values())
    assert np.all(np.diff(r.time_s) > 0)
    assert np.all(np.diff(r.rel_density) >= -1e-12)
    assert r.rel_density[-1] >= 0.6
    # The coarse mesh's volume is within 2 % of the sphere octant's.
    assert r.rho0 == pytest.approx(math.pi / 6, rel=0.02)
    # Density is particle volume over the current cell volume.
    lx, ly, lz = quick_case.cell.lengths_mm
    rho = c["particle_volume_mm3"] / (lx * ly * (lz + c["piston_displacement_mm"]))
    assert np.allclose(rho, r.rel_density, rtol=1e-12)
    # Stage 1 ramps the stress linearly over 1 s, stage 2 holds it.
    assert np.allclose(r.applied_stress_mpa, 10.0 * np.minimum(r.time_s / 1.0, 1.0), rtol=1e-12)
    # The ramp end is a step end.
    assert np.any(np.isclose(r.time_s, 1.0, rtol=0, atol=1e-12))
    t6 = r.time_to_density(0.6)
    assert t6 is not None and r.time_s[-2] <= t6 <= r.time_s[-1]


def test_snapshots_land_on_requested_times(quick_case: td.Case) -> None:
    r = quick_case.run(until_density=0.58, snapshot_times_s=[0.37, 2.5], snapshot_densities=[0.55])
    labels = [s.label for s in r.snapshots]
    assert labels == ["t0.37s", "rho0.550", "t2.5s", "final"] or labels == ["t0.37s", "t2.5s", "rho0.550", "final"]
    for s in r.snapshots:
        if s.label.startswith("t"):
            assert s.time_s == pytest.approx(float(s.label[1:-1]), abs=1e-12)
        if s.label.startswith("rho"):
            assert s.rel_density >= 0.55
        f = s.fields
        assert f["points"].shape == (r.nodes, 3) and f["cells"].shape == (r.elements, 8)


def test_callback_stops_the_run(quick_case: td.Case) -> None:
    seen: list[int] = []

    def cb(p: dict[str, float]) -> bool:
        seen.append(int(p["step"]))
        return len(seen) < 5

    r = quick_case.run(until_density=0.9, callback=cb)
    assert r.status == "stopped"
    assert seen == [1, 2, 3, 4, 5] and len(r.time_s) == 6


def test_solver_failure_keeps_the_partial_result(quick_case: td.Case, tmp_path: Path) -> None:
    case = dataclasses.replace(quick_case, solver=td.SolverSettings(mesh_level=1, max_steps=3))
    with pytest.raises(td.ConvergenceError, match="step limit 3") as info:
        case.run(until_density=0.9, out_dir=tmp_path)
    partial = info.value.result
    assert partial.status == "failed" and len(partial.time_s) == 4
    # Where and why, as attributes.
    assert info.value.reason == "step_limit" and info.value.step == 3 and info.value.dt_s is None
    assert info.value.time_s == pytest.approx(partial.time_s[-1], rel=1e-12)
    rows = (tmp_path / "curve.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + 4
    assert (tmp_path / "summary.json").exists() and (tmp_path / "fields_final.vtu").exists()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"stress_mpa": -1.0}, "stress_mpa = -1"),
        ({"knockdown": 1.5}, "knockdown = 1.5"),
        ({"ramp_time_s": -1.0}, "ramp_time_s = -1"),
        ({"mesh_level": 0}, "mesh_level = 0"),
        ({"tolerance": 2.0}, "tolerance = 2"),
    ],
)
def test_the_core_names_the_parameter_too(kwargs: dict[str, float], name: str) -> None:
    # The native Simulation, behind the Python checks, refuses the same input.
    args: dict[str, float] = {"stress_mpa": 10.0} | kwargs
    with pytest.raises(ValueError, match=name):
        td.Simulation(td.cells.sc(), td.materials.TI64_CREEP_1293K, until_density=0.6, **args)  # type: ignore[arg-type]


def test_bad_cells_and_materials_name_the_parameter() -> None:
    with pytest.raises(ValueError, match="aspect_ratio"):
        td.cells.sc(aspect_ratio=9.0)
    with pytest.raises(ValueError, match="radius"):
        td.cells.sc(radius_mm=-1.0)
    with pytest.raises(ValueError, match="nu"):
        td.materials.custom(1e-5, 1.0, poisson=0.6)
    with pytest.raises(ValueError, match="ti64-creep-1293k"):
        td.materials.by_name("titanium")


def test_target_density_must_exceed_rho0(quick_case: td.Case) -> None:
    with pytest.raises(ValueError, match="until_density"):
        quick_case.run(until_density=0.5)


def test_tmp_formula_agrees_with_the_preset() -> None:
    c = td.materials.tmp_creep_coefficient(0.0096, 191.0, 7.4, 2.8)
    assert c == pytest.approx(td.materials.TI64_TMP_1133_1293K.creep_c, rel=0.01)
    # From the physical parameters: (4/3) 5n/(4n+1) (dV/V) / dt / sigma0, linear.
    m = td.materials.thermal_cycling()
    assert (m.creep_n, m.young_mpa, m.poisson) == (1.0, 4.35e4, 0.3)
    assert m.creep_c == pytest.approx(4 / 3 * 5 * 2.8 / (4 * 2.8 + 1) * 0.0096 / 191.0 / 7.4, rel=1e-14)
    assert m.creep_c == pytest.approx(td.materials.TI64_TMP_1133_1293K.creep_c, rel=0.01)
    # A cycle twice as long, or an internal stress twice as large, halves the rate.
    assert td.materials.thermal_cycling(cycle_s=382.0).creep_c == pytest.approx(m.creep_c / 2, rel=1e-14)
    assert td.materials.thermal_cycling(internal_stress_mpa=14.8).creep_c == pytest.approx(m.creep_c / 2, rel=1e-14)
    with pytest.raises(ValueError, match="volume_mismatch"):
        td.materials.thermal_cycling(volume_mismatch=-0.01)
    with pytest.raises(ValueError, match="cycle_s"):
        td.materials.thermal_cycling(cycle_s=float("nan"))
    with pytest.raises(TypeError, match="creep_n"):
        td.materials.thermal_cycling(creep_n="2.8")  # type: ignore[arg-type]


def test_solves_release_the_gil(quick_case: td.Case) -> None:
    # One native call runs the whole solve in a second thread; this thread
    # ticks meanwhile. Had the solver held the GIL during its steps, no tick
    # could happen during one: the gaps between ticks of a step's duration
    # or longer would add up to about the whole solve. Released, the gaps
    # are the interpreter's hand-over time (the switch interval, shortened
    # here), far shorter than a step, but for the odd one where the system
    # took the core away (on a loaded 2-core machine, one gap of 0.044 s
    # against steps of 0.087 s): those add up to a small share.
    sim = dataclasses.replace(quick_case, solver=td.SolverSettings(mesh_level=2, tolerance=0.05)).simulation(until_density=0.58)
    old_interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)
    try:
        th = threading.Thread(target=sim.run)
        ticks = [time.perf_counter()]
        th.start()
        while th.is_alive():
            ticks.append(time.perf_counter())
        th.join()
    finally:
        sys.setswitchinterval(old_interval)
    solve = ticks[-1] - ticks[0]
    steps = sim.stats()["steps"]
    gaps = np.diff(ticks)
    assert sim.status == "reached_density" and steps > 10
    step_time = solve / steps
    long_gaps = gaps[gaps > 0.5 * step_time]
    assert long_gaps.sum() < 0.2 * solve, (long_gaps, step_time, solve)
    assert len(ticks) > 100 * steps


def test_tet10_meshes_the_sphere_octant_almost_exactly_and_runs(tmp_path: Path) -> None:
    case = td.Case(
        cell=td.cells.sc(),
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=10.0,
        solver=td.SolverSettings(mesh_level=1, tolerance=0.05, element="tet10"),
    )
    r = case.run(until_density=0.54, out_dir=tmp_path)
    # Quadratic geometry: the octant's volume is exact to 3e-5 even on
    # the coarsest mesh (the hex8 mesh is 1.7 % short).
    assert r.rho0 == pytest.approx(math.pi / 6, rel=1e-4)
    assert r.status == "reached_density" and np.all(np.diff(r.rel_density) >= -1e-12)
    f = r.snapshots[-1].fields
    assert f["cell_type"] == "tetra10" and f["cells"].shape == (r.elements, 10)
    import meshio

    mesh = meshio.read(tmp_path / "fields_final.vtu")
    assert mesh.cells[0].type == "tetra10" and len(mesh.cells[0].data) == r.elements


def test_an_unknown_element_names_the_parameter() -> None:
    case = td.Case(
        cell=td.cells.bcc(),
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=10.0,
        solver=td.SolverSettings(mesh_level=1, element="tet10"),
    )
    with pytest.raises(ValueError, match="element"):
        dataclasses.replace(case, solver=td.SolverSettings(element="quad4")).run(until_density=0.75)
