"""Hostile input at the boundary: every argument checked for kind, finiteness
and range when a case is written, errors naming the argument (the option on
the command line), random input thrown at the API and the cell-file reader."""

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tidens_rs as td
from tidens_rs import _core
from tidens_rs.cli import _glue_negative_numbers, main, option_names

SC = td.cells.sc()
TI64 = td.materials.TI64_CREEP_1293K


def case(**kw: Any) -> td.Case:
    args: dict[str, Any] = {"cell": SC, "material": TI64, "stress_mpa": 10.0} | kw
    return td.Case(**args)


@pytest.mark.parametrize(
    ("kw", "kind", "named"),
    [
        ({"stress_mpa": "10"}, TypeError, "stress_mpa = '10'"),
        ({"stress_mpa": None}, TypeError, "stress_mpa = None"),
        ({"stress_mpa": [10.0]}, TypeError, "stress_mpa = [10.0]"),
        ({"stress_mpa": 10 + 0j}, TypeError, "stress_mpa = (10+0j)"),
        ({"stress_mpa": True}, TypeError, "stress_mpa = True"),
        ({"stress_mpa": math.nan}, ValueError, "stress_mpa = nan"),
        ({"stress_mpa": 0.0}, ValueError, "stress_mpa = 0"),
        ({"knockdown": 1.5}, ValueError, "knockdown = 1.5"),
        ({"ramp_time_s": -1.0}, ValueError, "ramp_time_s = -1"),
        ({"contact": "sticky"}, ValueError, "frictionless, tied"),
        ({"tied_planes": 1}, TypeError, "tied_planes = 1"),
        ({"solver": None}, TypeError, "solver = None"),
        ({"cell": "sc"}, TypeError, "cell = 'sc'"),
        ({"material": "ti64"}, TypeError, "material = 'ti64'"),
    ],
)
def test_a_bad_case_is_refused_when_written(kw: dict[str, Any], kind: type[Exception], named: str) -> None:
    with pytest.raises(kind) as e:
        case(**kw)
    assert named in str(e.value)


@pytest.mark.parametrize(
    ("kw", "kind", "named"),
    [
        ({"mesh_level": 2.5}, TypeError, "mesh_level = 2.5"),
        ({"mesh_level": 0}, ValueError, "mesh_level = 0: must be an integer in [1, 6]"),
        ({"tolerance": 0.0}, ValueError, "tolerance = 0"),
        ({"tolerance": "0.01"}, TypeError, "tolerance = '0.01'"),
        ({"element": "hex20"}, ValueError, "hex8, tet10"),
        ({"grading": math.inf}, ValueError, "grading = inf"),
        ({"exact_volume": "yes"}, TypeError, "exact_volume = 'yes'"),
        ({"max_steps": 0}, ValueError, "max_steps = 0"),
        ({"dt_max_s": -1.0}, ValueError, "dt_max_s = -1"),
        ({"penetration_tolerance": 0.5}, ValueError, "penetration_tolerance = 0.5"),
        ({"contact_facets": "quads"}, ValueError, "triangles, bilinear"),
        ({"contact_facets": 3}, TypeError, "contact_facets = 3"),
    ],
)
def test_bad_solver_settings_are_refused_when_written(kw: dict[str, Any], kind: type[Exception], named: str) -> None:
    with pytest.raises(kind) as e:
        td.SolverSettings(**kw)
    assert named in str(e.value)


def test_run_arguments_are_checked_before_the_run(quick_case: td.Case, tmp_path: Path) -> None:
    rho0 = SC.rho0
    bad: list[tuple[dict[str, Any], type[Exception], str]] = [
        ({"until_density": 0.3}, ValueError, f"until_density = 0.3: must be in (rho0 = {rho0:.4f}, 1)"),
        ({"until_density": "0.8"}, TypeError, "until_density = '0.8'"),
        ({"until_time_s": -3.0}, ValueError, "until_time_s = -3"),
        ({"until_density": 0.8, "snapshot_densities": [0.7, -1.0]}, ValueError, "snapshot_densities[1] = -1"),
        ({"until_density": 0.8, "snapshot_densities": "0.7"}, TypeError, "snapshot_densities = '0.7'"),
        ({"until_density": 0.8, "snapshot_times_s": [0.0]}, ValueError, "snapshot_times_s[0] = 0"),
        ({"until_density": 0.8, "callback": 3}, TypeError, "callback = 3"),
        ({"until_density": 0.8, "out_dir": ""}, ValueError, "out_dir = ''"),
        ({"until_density": 0.8, "out_dir": 3}, TypeError, "out_dir = 3"),
        ({"until_density": 0.8, "error_estimate": 1}, TypeError, "error_estimate = 1"),
    ]
    for kw, kind, named in bad:
        with pytest.raises(kind) as e:
            quick_case.run(**kw)
        assert named in str(e.value), (kw, str(e.value))
    assert list(tmp_path.iterdir()) == []


def test_time_to_density_below_rho0_is_an_error(quick_case: td.Case) -> None:
    r = quick_case.run(until_density=0.56, error_estimate=False)
    assert r.time_to_density(r.rho0) == 0.0
    with pytest.raises(ValueError, match=r"rho = 0.3: must be in \[rho0"):
        r.time_to_density(0.3)


@pytest.mark.parametrize(
    ("kw", "kind", "message"),
    [
        ({"mesh_level": 2**70}, ValueError, "mesh_level = 1180591620717411303424: must be an integer in [1, 6]"),
        ({"mesh_level": 2.0}, TypeError, "mesh_level = 2.0: must be an integer, not float"),
        ({"mesh_level": True}, TypeError, "mesh_level = True: must be an integer, not bool"),
        ({"max_steps": 0}, ValueError, "max_steps = 0: must be an integer in [1, 18446744073709551615]"),
        ({"max_steps": 2**64}, ValueError, "max_steps = 18446744073709551616: must be an integer in [1, 18446744073709551615]"),
        ({"max_steps": "10"}, TypeError, "max_steps = '10': must be an integer, not str"),
        ({"checkpoint_every": -1}, ValueError, "checkpoint_every = -1: must be an integer in [0, 18446744073709551615]"),
        ({"checkpoint_every": 1.5}, TypeError, "checkpoint_every = 1.5: must be an integer, not float"),
        ({"newton_max_iterations": 1001}, ValueError, "newton_max_iterations = 1001: must be an integer in [1, 1000]"),
        ({"newton_max_iterations": [3]}, TypeError, "newton_max_iterations = [3]: must be an integer, not list"),
    ],
)
def test_the_cores_integer_arguments_name_themselves(kw: dict[str, Any], kind: type[Exception], message: str) -> None:
    # The native module's own checks (the Python layer checks before it).
    with pytest.raises(kind) as e:
        _core.check_parameters(**kw)
    assert str(e.value) == message
    with pytest.raises(kind) as e:
        _core.Simulation(SC, TI64, stress_mpa=10.0, until_density=0.8, **kw)
    assert str(e.value) == message


def test_the_cores_integer_arguments_take_numpy_integers_and_none() -> None:
    _core.check_parameters(mesh_level=np.int64(2), max_steps=np.uint32(10), checkpoint_every=None)  # type: ignore[arg-type]
    sim = _core.Simulation(SC, TI64, stress_mpa=10.0, until_density=0.8, mesh_level=np.int8(1))  # type: ignore[arg-type]
    assert sim.node_count == _core.Simulation(SC, TI64, stress_mpa=10.0, until_density=0.8, mesh_level=1).node_count


# Anything a script could pass by mistake, besides plausible numbers.
anything = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**20), max_value=10**20),
    st.floats(allow_nan=True, allow_infinity=True),
    st.complex_numbers(max_magnitude=1e3),
    st.text(max_size=5),
    st.lists(st.floats(allow_nan=False), max_size=3),
    st.just(np.float64(2.0)),
    st.just(np.int64(3)),
)

CASE_FIELDS = ("stress_mpa", "knockdown", "ramp_time_s", "contact", "tied_planes")
SETTINGS_FIELDS = tuple(td.SolverSettings().as_dict())


@settings(max_examples=300, deadline=None)
@given(field=st.sampled_from(SETTINGS_FIELDS), value=anything)
def test_random_solver_settings_are_accepted_in_range_or_refused_by_name(field: str, value: Any) -> None:
    try:
        s = td.SolverSettings(**{field: value})
    except (TypeError, ValueError) as e:
        assert str(e).startswith(f"{field} = "), str(e)
        return
    # Accepted: a plain Python value of the declared kind that the core accepts too.
    kept = getattr(s, field)
    assert not isinstance(kept, (str, complex, list)) or field == "element"
    _core.check_parameters(**{field: kept})


@settings(max_examples=300, deadline=None)
@given(field=st.sampled_from(CASE_FIELDS), value=anything)
def test_random_cases_are_accepted_in_range_or_refused_by_name(field: str, value: Any) -> None:
    try:
        c = case(**{field: value})
    except (TypeError, ValueError) as e:
        # The load also meets the material: E over f sigma has its range.
        assert str(e).startswith(f"{field} = ") or str(e).startswith("young_mpa/stress = "), str(e)
        return
    kept = getattr(c, field)
    if field in ("stress_mpa", "knockdown", "ramp_time_s"):
        assert type(kept) is float and math.isfinite(kept)


json_values = st.recursive(
    st.one_of(st.none(), st.booleans(), st.floats(), st.integers(), st.text(max_size=4)),
    lambda children: st.one_of(st.lists(children, max_size=4), st.dictionaries(st.text(max_size=8), children, max_size=4)),
    max_leaves=12,
)
octant = st.fixed_dictionaries(
    {"corner": st.one_of(st.sampled_from(["000", "111", "101"]), json_values), "a": json_values, "c": json_values}
)
cell_like = st.one_of(
    json_values,
    st.fixed_dictionaries({"lengths_mm": json_values, "octants": st.lists(octant, max_size=3)}),
    st.fixed_dictionaries(
        {
            "lengths_mm": st.lists(st.floats(1e-7, 2e3), min_size=3, max_size=3),
            "octants": st.lists(
                st.fixed_dictionaries({"corner": st.sampled_from(["000", "111", "011"]), "a": st.floats(1e-7, 2e3), "c": st.floats(1e-7, 2e3)}),
                min_size=1,
                max_size=3,
            ),
        }
    ),
)


@settings(max_examples=300, deadline=None)
@given(data=cell_like)
def test_random_cell_files_are_read_or_refused_with_a_value_error(tmp_path_factory: pytest.TempPathFactory, data: Any) -> None:
    path = tmp_path_factory.mktemp("cells") / "cell.json"
    path.write_text(json.dumps(data))
    try:
        cell = td.cells.from_file(path)
    except ValueError as e:
        assert str(e).startswith(f"cell file {path}: "), str(e)
        return
    # Read: what the core holds is what the file says.
    assert td.cells.from_dict(td.cells.to_dict(cell)).octants == cell.octants
    assert all(0 < x <= 1e3 for x in cell.lengths_mm)


@settings(max_examples=100, deadline=None)
@given(blob=st.binary(min_size=1, max_size=200), suffix=st.sampled_from([".json", ".toml"]))
def test_binary_cell_files_are_refused_naming_the_file(tmp_path_factory: pytest.TempPathFactory, blob: bytes, suffix: str) -> None:
    path = tmp_path_factory.mktemp("cells") / f"cell{suffix}"
    path.write_bytes(blob)
    try:
        td.cells.from_file(path)
    except ValueError as e:
        assert str(e).startswith(f"cell file {path}: ")


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--C", "-4.8e-7", "--n", "3"], "--C = -4.8e-7: must be in [1e-30, 1e6]"),
        (["--stress", "-5"], "--stress = -5: must be in (0, 1e4] MPa"),
        (["--until-density", "0.3"], "--until-density = 0.3: must be in (rho0"),
        (["--vtu-densities", "0.7,-1"], "--vtu-densities[1] = -1.0"),
        (["--E", "1e-9"], "--E = 1e-9: must be"),
        (["--E", "500"], "--E/(--knockdown x --stress) = 50: must be in [1e2, 1e9]"),
        (["--stress", "1e-6"], "--E/(--knockdown x --stress) = 43500000000"),
        (["--nu", "0.6"], "--nu = 0.6"),
        (["--knockdown", "2"], "--knockdown = 2"),
        (["--ramp-time", "nan"], "--ramp-time = nan: must be finite"),
        (["--max-steps", "0"], "--max-steps = 0"),
        (["--mesh-level", "9"], "--mesh-level = 9: must be an integer in [1, 6]"),
        (["--radius", "-1"], "--radius = -1"),
        (["--cell-file", "/bin/sh"], "not a text file"),
        (["--material", "foo"], "invalid choice: 'foo'"),
        (["--out", ""], "must name a folder"),
    ],
)
def test_the_command_line_refuses_bad_input_in_one_line_naming_the_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], options: list[str], message: str
) -> None:
    base = {"--stress": "10", "--until-density": "0.6", "--out": str(tmp_path / "o"), "--mesh-level": "1"}
    for k in range(0, len(options), 2):
        base[options[k]] = options[k + 1]
    argv = ["run", "--quiet"] + [x for kv in base.items() for x in kv]
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err, err
    assert not (tmp_path / "o").exists()


def test_option_names_and_negative_numbers() -> None:
    assert option_names("young_mpa (E) = 0.001: must be in [1e-3, 1e9] MPa") == "--E = 0.001: must be in [1e-3, 1e9] MPa"
    assert option_names("snapshot_times_s[2] = 0.0: must be") == "--vtu-times[2] = 0.0: must be"
    # Words in the text are left alone; only "name = " is a name.
    assert option_names("particle contact failed: tolerance too tight") == "particle contact failed: tolerance too tight"
    assert _glue_negative_numbers(["--C", "-4.8e-7", "--n", "-.5", "-q"]) == ["--C=-4.8e-7", "--n=-.5", "-q"]
    assert _glue_negative_numbers(["--quiet", "--out", "-x"]) == ["--quiet", "--out", "-x"]


def test_a_cell_that_cannot_carry_the_load_is_refused_when_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # bcc's two spheres with the box 1 % taller: neither touches the other,
    # so nothing carries the piston's load to the bottom.
    s = 2 * 0.05 / 3**0.5
    with pytest.raises(ValueError, match="no chain of touching particles carries the piston's load"):
        td.cells.custom("apart", (s, s, 1.01 * s), [("000", 0.05, 0.05), ("111", 0.05, 0.05)])
    # The touching original is a cell.
    assert td.cells.custom("bcc", (s, s, s), [("000", 0.05, 0.05), ("111", 0.05, 0.05)]).rho0 == pytest.approx(td.cells.bcc().rho0)
    path = tmp_path / "short.toml"
    path.write_text('lengths_mm = [0.1, 0.1, 0.101]\n[[octants]]\ncorner = "000"\na = 0.1\nc = 0.1\n')
    with pytest.raises(SystemExit) as e:
        main(["run", "--cell-file", str(path), "--stress", "10", "--until-density", "0.6", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and str(path) in err and "piston" in err and err.count("\n") == 1, err


def test_every_default_has_one_source() -> None:
    # The core's Settings, published as SOLVER_DEFAULTS, is what SolverSettings,
    # the command line and the native Simulation (None = the core's) use.
    import dataclasses
    import inspect

    from tidens_rs.cli import build_parser

    assert td.SolverSettings().as_dict() == _core.SOLVER_DEFAULTS
    args = build_parser().parse_args(["run", "--stress", "10", "--until-density", "0.8", "--out", "o"])
    d = _core.SOLVER_DEFAULTS
    assert (args.grading, args.exact_volume, args.element, args.contact_facets, args.max_steps) == (
        d["grading"], d["exact_volume"], d["element"], d["contact_facets"], d["max_steps"])
    assert d["contact_facets"] == td.CONTACT_FACETS[0]  # the choices list the default first
    assert (td.DEFAULT_MESH_LEVEL, td.DEFAULT_TOLERANCE) == (d["mesh_level"], d["tolerance"])
    case_defaults = {f.name: f.default for f in dataclasses.fields(td.Case)}
    assert (args.knockdown, args.ramp_time, args.contact) == (
        case_defaults["knockdown"], case_defaults["ramp_time_s"], case_defaults["contact"])
    native = inspect.signature(td.Simulation).parameters
    for name in ("knockdown", "ramp_time_s", "contact", "tied_planes"):
        assert native[name].default == case_defaults[name], name
    for name in d:
        assert native[name].default is None, name  # the core's own default
