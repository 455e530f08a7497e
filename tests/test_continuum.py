"""The continuum model (docs/model.md section 8) against properties it must have."""

import csv
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs.cli import main
from tidens_rs.continuum import ContinuumModel

RHO0 = math.pi / 6


def model(**kw: float) -> ContinuumModel:
    base = dict(creep_c=4.8e-7, creep_n=2.8, stress_mpa=10.0, rho0=RHO0)
    base.update(kw)
    return ContinuumModel(**base)


@pytest.mark.parametrize("n", [1.0, 2.8, 4.3])
def test_time_integral_has_the_closed_form_rate_as_derivative(n: float) -> None:
    m = model(creep_n=n, creep_c=1e-4 / 10**n)
    for rho in (0.6, 0.75, 0.85, 0.93, 0.97):
        h = 1e-5
        dtdrho = (m.effective_time(rho + h)[0] - m.effective_time(rho - h)[0]) / (2 * h)
        assert dtdrho * float(m.rate(rho)) == pytest.approx(1.0, rel=1e-6)


def test_integral_converges_with_quadrature_points() -> None:
    # Four times the default 400 points changes the times by 4e-13 (numpy
    # finds the nodes from a dense eigenvalue problem: 4000 took half a
    # minute on a loaded machine, 1600 a second).
    m = model()
    t = m.effective_time([0.7, 0.9, 0.95], points=1600)
    assert np.allclose(m.effective_time([0.7, 0.9, 0.95]), t, rtol=1e-9)


def test_times_scale_as_stress_to_the_minus_n() -> None:
    m1, m2 = model(), model(stress_mpa=20.0)
    r = [0.6, 0.8, 0.95]
    assert np.allclose(m1.time_to_density(r) / m2.time_to_density(r), 2**2.8, rtol=1e-12)
    # The knock-down factor acts on the stress.
    assert np.allclose(model(knockdown=0.5, stress_mpa=20.0).time_to_density(r), m1.time_to_density(r))


def test_ramp_delays_the_hold_by_n_over_n_plus_one_of_the_ramp() -> None:
    n, tr = 2.8, 5.0
    plain, ramped = model(), model(ramp_time_s=tr)
    r = [0.8, 0.9]
    assert np.allclose(ramped.time_to_density(r) - plain.time_to_density(r), n * tr / (n + 1))
    # Inside the ramp: t_eff = t^(n+1) / ((n+1) tr^n).
    t = np.array([0.5, 2.0, 4.9])
    te = t ** (n + 1) / ((n + 1) * tr**n)
    assert np.allclose(ramped.time_from_effective(te), t)


def test_rate_falls_with_density_and_the_curve_is_monotone() -> None:
    m = model()
    t, rho = m.curve(0.98)
    assert np.all(np.diff(t) > 0) and np.all(np.diff(rho) > 0)
    assert t[0] == 0.0 and rho[0] == pytest.approx(RHO0)


@pytest.mark.parametrize(
    ("name", "value"),
    [("creep_c", -1.0), ("creep_n", 0.5), ("stress_mpa", 0.0), ("rho0", 0.95), ("knockdown", 1.5)],
)
def test_bad_parameters_name_themselves(name: str, value: float) -> None:
    with pytest.raises(ValueError, match=name):
        model(**{name: value})


def test_rates_in_log_form_equal_the_closed_form() -> None:
    # The rates are evaluated as sums of logs; here against the formulas as
    # written (Eqs. 2 and 3 of the paper), where they do not overflow.
    m = model(knockdown=0.6)
    c, n, s, r0 = m.creep_c, m.creep_n, m.cell_stress_mpa, RHO0
    for rho in (0.55, 0.7, 0.89):
        direct = 3.06 * c * ((1 - r0) / (rho - r0)) ** (n - 0.5) * r0 ** (1 / 3) / rho ** (2 * n - 2 / 3) * (1.1 * s / 3) ** n
        assert float(m.rate(rho)) == pytest.approx(direct, rel=1e-12)
    for rho in (0.9, 0.95, 0.999):
        direct = 1.5 * c * rho * (1 - rho) / (1 - (1 - rho) ** (1 / n)) ** n * (3 * 1.8 * s / (2 * n)) ** n
        assert float(m.rate(rho)) == pytest.approx(direct, rel=1e-12)


@pytest.mark.parametrize("c", [4.8e-7, 1e-30])
def test_large_exponents_raise_no_overflow(c: float) -> None:
    # n = 50: (B s / 3)^n, rho^(2n) and the ramp's tr^n pass the float range
    # in the formulas as written; in log form the times stay finite and
    # ordered, and numpy warns of nothing.
    m = model(creep_n=50.0, creep_c=c, ramp_time_s=100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        t = m.time_to_density([0.6, 0.8, 0.9, 0.95])
        rates = m.rate([0.6, 0.95])
    assert np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)
    assert np.all(rates > 0)


@pytest.mark.parametrize("n", [1.0, 2.8, 4.3])
def test_times_equal_an_independent_quadrature(n: float) -> None:
    # The trapezoidal rule on 400001 points, graded toward the ends where
    # 1/rate varies fastest (rho0, where it vanishes as (rho - rho0)^(n - 1/2),
    # and rho -> 1, where it grows as 1/(1 - rho)), against the model's
    # Gauss-Legendre quadrature with its own substitutions.
    m = model(creep_n=n, creep_c=1e-4 / 10**n)
    for target in (0.6, 0.85, 0.9, 0.95, 0.99):
        v = np.linspace(0.0, 1.0, 400001)
        first = min(target, 0.9)
        # The initial stage's formula up to its end (it switches at 0.9 itself).
        rho = np.minimum(RHO0 + (first - RHO0) * v**3, np.nextafter(0.9, 0.0))
        t = np.trapezoid(1.0 / m.rate(rho[1:]), rho[1:])
        if target > 0.9:
            gap = np.geomspace(0.1, 1.0 - target, 400001)
            rho = 1.0 - gap
            t += np.trapezoid(1.0 / m.rate(rho), rho)
        assert float(m.effective_time(target)[0]) == pytest.approx(t, rel=1e-6)


def test_the_command_writes_the_curve_of_the_model(tmp_path: Path) -> None:
    out = tmp_path / "model"
    args = ["continuum", "--material", "cpti-alpha-1143k", "--stress", "50", "--knockdown", "0.17", "--cell", "bcc", "--until-density", "0.97"]
    assert main([*args, "--out", str(out), "--points", "120"]) == 0
    with (out / "curve.csv").open() as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["time_s"]) for r in rows])
    rho = np.array([float(r["rel_density"]) for r in rows])
    assert len(rows) == 120 and t[0] == 0.0 and rho[-1] == pytest.approx(0.97)
    assert np.all(np.diff(t) > 0) and np.all(np.diff(rho) > 0)
    law = td.materials.CPTI_ALPHA_1143K
    m = ContinuumModel(creep_c=law.creep_c, creep_n=law.creep_n, stress_mpa=50.0, knockdown=0.17, rho0=td.cells.bcc().rho0)
    assert np.allclose(t[1:], m.time_to_density(rho[1:]), rtol=1e-12)
    # The stress acts in full from t = 0 unless a ramp is given: a ramp of
    # T delays the hold by n T / (n + 1).
    ramped = tmp_path / "ramped"
    assert main([*args, "--ramp-time", "30", "--out", str(ramped), "--points", "120"]) == 0
    with (ramped / "curve.csv").open() as f:
        t_ramp = np.array([float(r["time_s"]) for r in csv.DictReader(f)])
    late = t_ramp > 30.0
    assert np.allclose(t_ramp[late] - t[late], law.creep_n * 30.0 / (law.creep_n + 1), rtol=1e-9)
    # A second curve into the same folder needs --overwrite.
    with pytest.raises(SystemExit) as e:
        main([*args, "--out", str(out)])
    assert e.value.code == 2
    assert main([*args, "--out", str(out), "--overwrite"]) == 0


@pytest.mark.parametrize(
    ("extra", "named"),
    [(["--rho0", "0.95"], "--rho0"), (["--rho0", "0.6", "--cell", "sc"], "--rho0 or --cell"), (["--rho0", "0.6", "--stress", "-2"], "--stress"),
     (["--rho0", "0.6", "--C", "1e-5"], "--C and --n"), (["--rho0", "0.6", "--until-density", "0.5"], "--until-density")],
)
def test_the_command_names_bad_input(tmp_path: Path, extra: list[str], named: str, capsys: pytest.CaptureFixture[str]) -> None:
    base = {"--stress": "10", "--until-density": "0.9"}
    for k in ("--stress", "--until-density"):
        if k in extra:
            base.pop(k)
    argv = ["continuum", *[x for kv in base.items() for x in kv], *extra, "--out", str(tmp_path / "x")]
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    assert named in capsys.readouterr().err
