"""The size of a run before it is set up (``_core.estimate_size``): its
counts are the simulation's own, its memory estimate near a measured peak,
and a cell of 10000 particles is sized at once."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

import tidens_rs as td
from tidens_rs import _core

TI64 = td.materials.TI64_CREEP_1293K


def simulated(cell: td.Cell, level: int, element: str) -> dict[str, int]:
    sim = _core.Simulation(cell, TI64, stress_mpa=10.0, until_density=0.95, mesh_level=level, element=element)
    return {"nodes": sim.node_count, "elements": sim.element_count, "degrees_of_freedom": sim.degrees_of_freedom}


@pytest.mark.parametrize("level", [1, 2])
@pytest.mark.parametrize("element", ["hex8", "tet10"])
@pytest.mark.parametrize("name", ["sc", "bcc"])
def test_cells_of_octants_are_sized_as_their_simulations(name: str, element: str, level: int) -> None:
    cell = td.cells.by_name(name)
    estimate = _core.estimate_size(cell, level, element)
    assert {k: estimate[k] for k in ("nodes", "elements", "degrees_of_freedom")} == simulated(cell, level, element)


@pytest.mark.parametrize("level", [1, 2])
def test_a_random_packing_is_sized_as_its_simulation(level: int) -> None:
    cell = td.cells.random(8, seed=2)
    estimate = _core.estimate_size(cell, level)
    assert {k: estimate[k] for k in ("nodes", "elements", "degrees_of_freedom")} == simulated(cell, level, "hex8")


def test_ten_thousand_particles_are_sized_at_once() -> None:
    # 22^3 = 10648 spheres on a grid (a random packing of as many takes minutes).
    n, spacing = 22, 0.12
    grid = [(((i + 0.5) * spacing, (j + 0.5) * spacing, (k + 0.5) * spacing), 0.05, 0.05, (0.0, 0.0, 1.0))
            for i in range(n) for j in range(n) for k in range(n)]
    cell = td.cells.periodic(grid, (n * spacing,) * 3)
    start = time.perf_counter()
    estimate = _core.estimate_size(cell, 1)
    assert time.perf_counter() - start < 0.5
    # Hundreds of GB: what a run must be refused for.
    assert estimate["degrees_of_freedom"] == 3 * 1501 * n**3 - 2
    assert estimate["peak_memory_bytes"] > 400e9


def test_bad_arguments_are_refused_by_name() -> None:
    with pytest.raises(ValueError, match=r"element = tet10: a periodic cell is meshed with hex8 elements only"):
        _core.estimate_size(td.cells.as_periodic(td.cells.sc()), 1, "tet10")
    with pytest.raises(ValueError, match=r"mesh_level = 7: must be an integer in \[1, 6\]"):
        _core.estimate_size(td.cells.sc(), 7)
    with pytest.raises(TypeError, match=r"mesh_level = 1.5: must be an integer, not float"):
        _core.estimate_size(td.cells.sc(), 1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"element = 'hex20': must be one of hex8, tet10"):
        _core.estimate_size(td.cells.sc(), 1, "hex20")
    # The defaults: the core's mesh level, hex8.
    assert _core.estimate_size(td.cells.sc()) == _core.estimate_size(td.cells.sc(), _core.SOLVER_DEFAULTS["mesh_level"], "hex8")


@pytest.mark.skipif(sys.platform != "linux", reason="ru_maxrss is in kB on Linux")
def test_the_memory_estimate_is_within_a_factor_two_of_a_measured_peak(tmp_path: Path) -> None:
    # The bcc cell at level 3 for two steps (a few seconds), run by the
    # command in a fresh process whose only child it is.
    run = [sys.executable, "-m", "tidens_rs.cli", "run", "--cell", "bcc", "--mesh-level", "3", "--stress", "10",
           "--until-time", "0.05", "--no-error-estimate", "--quiet", "--no-plot", "--out", str(tmp_path / "run")]
    measure = f"import resource, subprocess; subprocess.run({run!r}, check=True); print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
    done = subprocess.run([sys.executable, "-c", measure], capture_output=True, text=True, check=True)
    peak = 1024 * int(done.stdout.split()[-1])
    estimate = _core.estimate_size(td.cells.bcc(), 3)["peak_memory_bytes"]
    assert 0.5 < estimate / peak < 2.0, (estimate, peak)
