"""Shared fixtures: small, fast cases (coarse mesh, loose tolerance)."""

import pytest

import tidens_rs as td


@pytest.fixture
def quick_case() -> td.Case:
    """The sc Ti-6Al-4V case on the coarsest mesh with a loose tolerance."""
    return td.Case(
        cell=td.cells.sc(),
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=10.0,
        solver=td.SolverSettings(mesh_level=1, tolerance=0.05),
    )
