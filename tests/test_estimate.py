"""The error estimate: Richardson's mesh part on curves with a known error,
the time part, and a run with its coarse companion end to end."""

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs.estimate import DENSITY_WINDOW, MESH_ORDER, estimate_error, richardson_factor

MARKS = (0.6, 0.7, 0.8, 0.9)


def exact_curve() -> tuple[np.ndarray, np.ndarray]:
    """A smooth densification curve t(rho) from rho0 = 0.52 to 0.92."""
    rho = np.linspace(0.52, 0.92, 400)
    t = 50.0 * (np.exp(4.0 * (rho - 0.52)) - 1.0)
    return t, rho


def curve(t: np.ndarray, rho: np.ndarray, time_error: np.ndarray | None = None) -> dict[str, np.ndarray]:
    return {"time_s": t, "rel_density": rho, "time_error_s": np.zeros_like(t) if time_error is None else time_error}


def test_mesh_part_is_the_true_error_when_it_goes_as_h_to_the_order() -> None:
    # t_h = T (1 + c h^p) at levels 3 and 2: Richardson recovers |t_h - T| / t_h exactly.
    t, rho = exact_curve()
    c, p = 30.0, MESH_ORDER
    h3, h2 = 1 / 8, 1 / 6
    est = estimate_error(curve(t * (1 + c * h3**p), rho), curve(t * (1 + c * h2**p), rho), MARKS, level=3, companion_level=2)
    true = c * h3**p / (1 + c * h3**p)
    for k in ("0.6", "0.7", "0.8", "0.9"):
        assert est.mesh[k] == pytest.approx(true, rel=1e-9)
        assert est.relative[k] == pytest.approx(true, rel=1e-9)
        # The extrapolation is the exact curve.
        tk = float(np.interp(float(k), rho, t))
        assert est.extrapolated_s[k] == pytest.approx(tk, rel=1e-6)
    assert richardson_factor(3, 2) == pytest.approx(h3**p / (h2**p - h3**p))
    assert richardson_factor(3, 2, order=2.0) == pytest.approx(h3**2 / (h2**2 - h3**2))


def test_mesh_part_survives_curves_that_cross_at_a_mark() -> None:
    # Level curves that cross exactly at rho = 0.8: the pointwise difference
    # vanishes there, its root mean square over the window does not.
    t, rho = exact_curve()
    wiggle = 1 + 0.01 * np.sin((rho - 0.8) / DENSITY_WINDOW * np.pi / 2)
    est = estimate_error(curve(t, rho), curve(t * wiggle, rho), MARKS, level=3, companion_level=2)
    mesh = est.mesh["0.8"]
    assert mesh is not None
    g = richardson_factor(3, 2)
    # sin over a half period has the root mean square 1/sqrt(2).
    assert mesh == pytest.approx(g * 0.01 / np.sqrt(2), rel=0.03)


def test_time_part_is_the_accumulated_estimate_by_magnitude() -> None:
    t, rho = exact_curve()
    err = -0.002 * t  # a negative accumulated estimate (early)
    est = estimate_error(curve(t, rho, err), None, MARKS, companion_note="because")
    for k in ("0.6", "0.7", "0.8", "0.9"):
        assert est.time[k] == pytest.approx(0.002, rel=1e-6)
        assert est.mesh[k] is None and est.relative[k] is None
    assert est.curve == {"relative": None, "time": pytest.approx(0.002, rel=1e-6), "mesh": None}
    assert est.method["mesh"] == "not estimated: because"


def test_marks_not_reached_are_left_out() -> None:
    t, rho = exact_curve()
    keep = rho <= 0.85
    est = estimate_error(curve(t[keep], rho[keep]), curve(t[keep], rho[keep]), MARKS)
    assert sorted(est.relative) == ["0.6", "0.7", "0.8"]


def read_curve(path: Path) -> dict[str, np.ndarray]:
    with path.open() as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in ("time_s", "rel_density", "time_error_s")}


def test_a_run_estimates_its_mesh_error_from_a_coarse_companion(quick_case: td.Case, tmp_path: Path) -> None:
    case = dataclasses.replace(quick_case, solver=td.SolverSettings(mesh_level=2, tolerance=0.05))
    r = case.run(until_density=0.7, out_dir=tmp_path)
    est = r.estimate()
    assert est.companion_level == 1
    s = json.loads((tmp_path / "summary.json").read_text())["error_estimate"]
    assert set(s["relative"]) == {"0.6", "0.7"} == set(json.loads((tmp_path / "summary.json").read_text())["times_to_density_s"])
    # The summary's estimate is the one the two streamed curves give.
    again = estimate_error(read_curve(tmp_path / "curve.csv"), read_curve(tmp_path / "companion_curve.csv"), MARKS, level=2, companion_level=1)
    for k in ("0.6", "0.7"):
        assert s["mesh"][k] == pytest.approx(again.mesh[k], rel=1e-6)
        assert s["relative"][k] == s["mesh"][k]
        assert s["mesh"][k] > 0 and s["time"][k] >= 0
    # The companion ran one level down at twice the tolerance.
    assert est.method["mesh"].startswith("Richardson from a companion run at mesh level 1 and 2 times the tolerance")
    # How well the estimate brackets the true error is measured by
    # benches/accuracy.py against converged references, not here.


def test_without_companion_the_mesh_part_is_none_and_says_why(quick_case: td.Case, tmp_path: Path) -> None:
    case = dataclasses.replace(quick_case, solver=td.SolverSettings(mesh_level=2, tolerance=0.05))
    r = case.run(until_density=0.6, out_dir=tmp_path, error_estimate=False)
    assert not (tmp_path / "companion_curve.csv").exists()
    est = r.estimate()
    assert est.relative == {"0.6": None} and est.time["0.6"] >= 0
    assert "error_estimate=False" in est.method["mesh"]
    coarsest = quick_case.run(until_density=0.6).estimate()
    assert "coarsest" in coarsest.method["mesh"]
    with pytest.raises(TypeError, match="error_estimate"):
        case.run(until_density=0.6, error_estimate="yes")  # type: ignore[arg-type]


def test_accuracy_climbs_the_ladder_until_the_estimate_is_within_it(
    quick_case: td.Case, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Any estimate is within 50 %: the first rung with one (level 2) is kept.
    loose = quick_case.run(until_density=0.6, accuracy=0.5, out_dir=tmp_path / "loose")
    assert (loose.case.solver.mesh_level, loose.case.solver.tolerance) == (2, 0.04)
    search = loose.accuracy_search
    assert search is not None and search["reached"] is True
    assert [r["mesh_level"] for r in search["rungs"]] == [1, 2]
    s = json.loads((tmp_path / "loose" / "summary.json").read_text())
    assert (s["solver"]["mesh_level"], s["solver"]["tolerance"], s["solver"]["element"]) == (2, 0.04, "hex8")
    # The streamed companion is the rung below (level 1 at tolerance 0.08):
    # the summary's estimate is the one the two files give.
    again = estimate_error(
        read_curve(tmp_path / "loose" / "curve.csv"), read_curve(tmp_path / "loose" / "companion_curve.csv"), MARKS, level=2, companion_level=1
    )
    assert s["error_estimate"]["relative"]["0.6"] == pytest.approx(again.relative["0.6"], rel=1e-6)
    level2 = search["rungs"][1]["estimated_error"]
    assert level2 == loose.estimate().curve["relative"] and level2 > 0
    # Just below the level-2 estimate: level 2 no longer does, level 3 is
    # the last rung here and is kept whether or not it does.
    monkeypatch.setattr(td.case, "LADDER_LAST_LEVEL", 3)
    tight = quick_case.run(until_density=0.6, accuracy=0.999 * level2)
    search = tight.accuracy_search
    assert search is not None
    assert [r["mesh_level"] for r in search["rungs"]] == [1, 2, 3]
    assert search["rungs"][1]["estimated_error"] == pytest.approx(level2, rel=1e-12)
    assert tight.case.solver.mesh_level == 3 and tight.case.solver.tolerance == 0.02
    level3 = search["rungs"][2]["estimated_error"]
    assert search["reached"] is (level3 <= 0.999 * level2)


@pytest.mark.parametrize(("accuracy", "error"), [(0.0, ValueError), (0.9, ValueError), ("1 %", TypeError), (True, TypeError)])
def test_accuracy_out_of_range_names_the_parameter(quick_case: td.Case, accuracy: object, error: type[Exception]) -> None:
    with pytest.raises(error, match="accuracy"):
        quick_case.run(until_density=0.6, accuracy=accuracy)  # type: ignore[arg-type]
