"""Norton similarity: the effective time of a ramp, the mapping of a curve to
another stress and ramp against full runs, and its error estimate."""

import dataclasses

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs.similarity import effective_time, map_curve, real_time

QUICK = td.SolverSettings(mesh_level=1, tolerance=0.02)


def sc(stress: float, young: float = 4.35e4, ramp: float = 1.0) -> td.Case:
    return td.Case(
        cell=td.cells.sc(),
        material=td.materials.TI64_CREEP_1293K.with_elastic(young, 0.3),
        stress_mpa=stress,
        ramp_time_s=ramp,
        solver=QUICK,
    )


def test_effective_time_of_a_ramp_and_its_inverse() -> None:
    n, tr = 2.8, 5.0
    t = np.array([0.0, 0.5, 2.0, 5.0, 7.5, 100.0])
    te = effective_time(t, n, tr)
    # t^(n+1) / ((n+1) tr^n) on the ramp, t - n tr / (n+1) after: continuous at tr.
    assert np.allclose(te[:4], t[:4] ** (n + 1) / ((n + 1) * tr**n), rtol=1e-13, atol=0.0)
    assert np.allclose(te[4:], t[4:] - n * tr / (n + 1), rtol=1e-13)
    assert np.allclose(real_time(te, n, tr), t, rtol=1e-12, atol=1e-12)
    # No ramp: the times are effective times.
    assert np.array_equal(effective_time(t, n, 0.0), t)


def test_a_rigid_viscoplastic_curve_maps_to_other_stresses_and_ramps() -> None:
    # E / sigma = 1e6 at 10 MPa: the elastic strains are negligible, and the
    # curve at 40 MPa with a 5 s ramp is the one at 10 MPa with a 1 s ramp,
    # mapped through tau = integral (f sigma)^n dt.
    # (Tolerance 0.005: during the 5 s ramp the full run's own time error
    # at tolerance 0.02 reaches 8 % at rho = 0.55, 2 % at 0.7; the mapped
    # curve, from a source that got there after its ramp, is the better one.)
    young, fine = 1e7, dataclasses.replace(QUICK, tolerance=0.005)
    source = dataclasses.replace(sc(10.0, young), solver=fine).run(until_density=0.8, error_estimate=False)
    target = dataclasses.replace(sc(40.0, young, ramp=5.0), solver=fine).run(until_density=0.8, error_estimate=False)
    mapped = map_curve(source, 40.0, ramp_time_s=5.0)
    assert mapped.error is None and mapped.relative_error == {}
    for rho in (0.7, 0.8):
        t_full, t_mapped = target.time_to_density(rho), mapped.time_to_density(rho)
        assert t_full is not None and t_mapped is not None
        assert t_full > 5.0  # after the ramp
        # Within the time discretisation of the two runs.
        assert t_mapped == pytest.approx(t_full, rel=0.01), rho


def test_the_calibrated_estimate_bounds_the_error_against_a_full_run() -> None:
    runs = {s: sc(s).run(until_density=0.95, error_estimate=False) for s in (2.5, 5.0, 40.0)}
    mapped = map_curve(runs[2.5], 5.0, calibration=runs[40.0])
    assert set(mapped.relative_error) == {"0.6", "0.7", "0.8", "0.9", "0.95"}
    for key, est in mapped.relative_error.items():
        rho = float(key)
        t_full, t_mapped = runs[5.0].time_to_density(rho), mapped.time_to_density(rho)
        assert t_full is not None and t_mapped is not None
        assert abs(t_mapped - t_full) / t_full <= est, key
    assert mapped.error == max(mapped.relative_error.values())
    # Asked for an accuracy the estimate does not reach, the mapping is refused.
    with pytest.raises(ValueError, match="run the case instead"):
        map_curve(runs[2.5], 5.0, calibration=runs[40.0], accuracy=0.5 * mapped.error)
    with pytest.raises(ValueError, match="calibration"):
        map_curve(runs[2.5], 5.0, accuracy=0.5)
    other = dataclasses.replace(runs[40.0], case=dataclasses.replace(runs[40.0].case, cell=td.cells.bcc()))
    with pytest.raises(ValueError, match="calibration"):
        map_curve(runs[2.5], 5.0, calibration=other)
