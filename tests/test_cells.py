"""Every cell of the paper, cells from files, and the contact options."""

import dataclasses
import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import tidens_rs as td

R = 0.05
SQ3 = math.sqrt(3.0)


def sc2_rho0(r: float) -> float:
    return 2 * math.pi / 3 * (1 + r**3) / (1 + r) ** 3


PRESETS: dict[str, tuple[Callable[[], td.Cell], float]] = {
    "sc": (td.cells.sc, math.pi / 6),
    "bcc": (td.cells.bcc, math.pi * SQ3 / 8),
    "fcc": (td.cells.fcc, math.pi / (3 * math.sqrt(2))),
    "sc2": (td.cells.sc2, sc2_rho0(1.566)),
    "sc2 r=2.2": (lambda: td.cells.sc2(size_ratio=2.2), sc2_rho0(2.2)),
    "bcc c/a=1.3": (lambda: td.cells.bcc(aspect_ratio=1.3), math.pi * SQ3 / 8),
}


def quick(cell: td.Cell, **kwargs: object) -> td.Case:
    kwargs.setdefault("solver", td.SolverSettings(mesh_level=1, tolerance=0.05))
    return td.Case(
        cell=cell,
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=10.0,
        **kwargs,  # type: ignore[arg-type]
    )


@pytest.mark.parametrize("name", PRESETS)
def test_presets_have_the_closed_form_density_and_mesh_it_within_2_percent(name: str) -> None:
    make, exact = PRESETS[name]
    cell = make()
    assert cell.rho0 == pytest.approx(exact, rel=1e-13)
    assert td.cells.by_name(cell.name).name == cell.name
    sim = quick(cell).simulation(until_density=0.95)
    rho_mesh = float(sim.curve()["rel_density"][0])
    # Exact-volume meshes (the default) start at the packing's density.
    assert rho_mesh == pytest.approx(exact, rel=1e-10)
    # With the surface nodes on the particles, the mesh is inscribed in the
    # (convex) particles: a little less volume.
    plain = td.Case(
        cell=cell,
        material=td.materials.TI64_CREEP_1293K,
        stress_mpa=10.0,
        solver=td.SolverSettings(mesh_level=1, exact_volume=False),
    ).simulation(until_density=0.95)
    rho_plain = float(plain.curve()["rel_density"][0])
    assert 0.98 * exact < rho_plain < exact
    f = sim.fields()
    assert f["particle"].dtype == np.int64 and f["particle"].shape == (sim.element_count,)
    assert set(f["particle"].tolist()) == set(range(len(cell.octants)))
    assert f["contact_pressure"].shape == (sim.node_count,)
    assert not np.any(f["contact_pressure"])  # nothing pressed yet


def test_sc2_closed_form_at_the_paper_ratio() -> None:
    assert td.cells.sc2().rho0 == pytest.approx(0.60002, abs=5e-6)
    # Large particles at the even corners, small (R / 1.566) at the odd ones.
    for corner, a, _ in td.cells.sc2().octants:
        assert a == pytest.approx(R if sum(corner) % 2 == 0 else R / 1.566, rel=1e-15)


BCC_S = 2 * R / SQ3
BCC_TOML = f"""\
# The bcc cell written out by hand: box s^3, s = 2R/sqrt(3).
name = "bcc-by-hand"
lengths_mm = [{BCC_S!r}, {BCC_S!r}, {BCC_S!r}]

[[octants]]
corner = [false, false, false]
a = 0.05
c = 0.05

[[octants]]
corner = "111"
a = 0.05
c = 0.05
"""
BCC_JSON = f"""{{
  "name": "bcc-by-hand",
  "lengths_mm": [{BCC_S!r}, {BCC_S!r}, {BCC_S!r}],
  "octants": [
    {{"corner": "000", "a": 0.05, "c": 0.05}},
    {{"corner": [true, true, true], "a": 0.05, "c": 0.05}}
  ]
}}
"""


@pytest.mark.parametrize(("suffix", "text"), [(".toml", BCC_TOML), (".json", BCC_JSON)])
def test_a_cell_file_of_the_bcc_cell_runs_like_the_preset(tmp_path: Path, suffix: str, text: str) -> None:
    path = tmp_path / f"bcc{suffix}"
    path.write_text(text)
    cell, preset = td.cells.from_file(path), td.cells.bcc()
    assert cell.name == "bcc-by-hand"
    assert cell.rho0 == preset.rho0
    assert cell.lengths_mm == preset.lengths_mm and cell.octants == preset.octants
    sims = [quick(c).simulation(until_density=0.75) for c in (cell, preset)]
    for _ in range(3):
        points = [s.advance() for s in sims]
        assert points[0] == pytest.approx(points[1], rel=1e-9, abs=1e-300, nan_ok=True)
    assert points[0]["rel_density"] > sims[0].curve()["rel_density"][0]


def test_a_cell_round_trips_through_the_file_schema(tmp_path: Path) -> None:
    path = tmp_path / "fcc.json"
    path.write_text(json.dumps(td.cells.to_dict(td.cells.fcc())))
    cell = td.cells.from_file(path)
    assert cell.octants == td.cells.fcc().octants and cell.lengths_mm == td.cells.fcc().lengths_mm


GOOD = {"name": "x", "lengths_mm": [0.1, 0.1, 0.1], "octants": [{"corner": "000", "a": 0.05, "c": 0.05}]}


def with_octant(**changes: object) -> dict[str, object]:
    return {**GOOD, "octants": [{**GOOD["octants"][0], **changes}]}  # type: ignore[dict-item]


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({k: v for k, v in GOOD.items() if k != "lengths_mm"}, r"lengths_mm: missing"),
        ({**GOOD, "lengths_mm": [0.1, 0.1]}, r"lengths_mm = \[0\.1, 0\.1\]: must be three"),
        ({**GOOD, "lengths_mm": [0.1, -0.1, 0.1]}, r"lengths_mm\[1\] = -0\.1: must be in \[1e-6, 1e3\] mm"),
        ({**GOOD, "octants": []}, r"octants = \[\]: must be a non-empty list"),
        ({**GOOD, "lenghts_mm": [0.1, 0.1, 0.1]}, r"lenghts_mm: unknown key"),
        (with_octant(corner=[True, False]), r"octants\[0\]\.corner = \[True, False\]: must be three booleans"),
        (with_octant(corner=[1, 0, 0]), r"octants\[0\]\.corner = \[1, 0, 0\]: must be three booleans"),
        (with_octant(corner="012"), r"octants\[0\]\.corner = '012'"),
        (with_octant(a=-0.05), r"octants\[0\]\.a = -0\.05: must be in \[1e-6, 1e3\] mm"),
        (with_octant(a="0.05"), r"octants\[0\]\.a = '0\.05': must be a number"),
        (with_octant(c=0.2), r"octants\[0\]\.c = 0\.2: must be at most the box edge Lz"),
        ({**GOOD, "octants": [{"corner": "000", "a": 0.05}]}, r"octants\[0\]\.c: missing"),
    ],
)
def test_bad_cell_files_name_the_field(tmp_path: Path, data: dict[str, object], message: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=message) as info:
        td.cells.from_file(path)
    assert str(path) in str(info.value)


def test_bad_toml_cell_files_name_the_field(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(BCC_TOML.replace('corner = "111"', "corner = [true, true]"))
    with pytest.raises(ValueError, match=r"octants\[1\]\.corner = \[True, True\]"):
        td.cells.from_file(path)
    path.write_text(BCC_TOML.replace("a = 0.05\nc = 0.05\n\n[[octants]]", "a = -0.05\nc = 0.05\n\n[[octants]]"))
    with pytest.raises(ValueError, match=r"octants\[0\]\.a = -0\.05"):
        td.cells.from_file(path)
    path.write_text(BCC_TOML.replace("lengths_mm", "# lengths_mm"))
    with pytest.raises(ValueError, match="lengths_mm: missing"):
        td.cells.from_file(path)
    path.write_text("lengths_mm = [0.1, 0.1")
    with pytest.raises(ValueError, match="not valid TOML"):
        td.cells.from_file(path)
    (tmp_path / "cell.yaml").write_text("")
    with pytest.raises(ValueError, match=r"must be \.json or \.toml"):
        td.cells.from_file(tmp_path / "cell.yaml")


def test_the_native_constructor_names_the_octant() -> None:
    octants = [((False, False, False), 0.05, 0.05), ((True, True, True), 0.05, 0.4)]
    with pytest.raises(ValueError, match=r"octants\[1\]\.c/a = 8: must be in \[0\.2, 5\]"):
        td.Cell("x", (0.1, 0.1, 0.1), octants)
    with pytest.raises(ValueError, match=r"octants = 0: must be at least one octant"):
        td.Cell("x", (0.1, 0.1, 0.1), [])


@pytest.mark.parametrize("aspect_ratio", [0.8, 1.0, 1.3])
def test_the_presets_build(aspect_ratio: float) -> None:
    # Their particles touch: the overlap check lets them through.
    for cell in (td.cells.sc(aspect_ratio=aspect_ratio), td.cells.bcc(aspect_ratio=aspect_ratio),
                 td.cells.fcc(aspect_ratio=aspect_ratio), td.cells.sc2(aspect_ratio=aspect_ratio),
                 td.cells.sc2(size_ratio=1.0 + math.sqrt(2.0), aspect_ratio=aspect_ratio)):
        assert 0.5 < cell.rho0 < 0.8
        assert td.cells.as_periodic(cell).is_periodic


def test_two_octants_at_one_corner_are_refused_when_the_cell_is_built() -> None:
    # Once 1.047 = 2 pi/6 of density, and an error blaming --until-density later.
    with pytest.raises(ValueError, match=r"octants\[0\] and octants\[1\] are both at corner 000"):
        td.cells.custom("dup", (0.05, 0.05, 0.05), [("000", 0.05, 0.05), ("000", 0.05, 0.05)])
    with pytest.raises(ValueError, match=r"octants\[1\] and octants\[2\] are both at corner 111"):
        td.cells.custom("dup", (0.1, 0.1, 0.1), [("000", 0.05, 0.05), ("111", 0.05, 0.05), ((True, True, True), 0.02, 0.02)])


def test_overlapping_octants_are_refused_when_the_cell_is_built() -> None:
    # Two spheres of radius 0.06 centred 0.1 apart along x; between them a
    # small one at another corner, apart from both.
    with pytest.raises(ValueError, match=r"cell 'overlap': octants\[0\] and octants\[2\] overlap \(") as e:
        td.cells.custom("overlap", (0.1, 0.1, 0.06), [("000", 0.06, 0.06), ("011", 0.02, 0.02), ("100", 0.06, 0.06)])
    assert "33.333 % of its radius deep" in str(e.value)
    # Spheroids too: a flat octant under a tall one above it.
    with pytest.raises(ValueError, match=r"octants\[0\] and octants\[1\] overlap"):
        td.cells.custom("flat", (0.1, 0.1, 0.1), [("000", 0.08, 0.04), ("001", 0.03, 0.065)])
    # Touching, written to seven digits, is not overlapping.
    assert td.cells.custom("bcc7", (0.05773502,) * 3, [("000", 0.05, 0.05), ("111", 0.05, 0.05)]).rho0 > 0.68


def test_overlapping_particles_of_a_periodic_cell_are_refused_when_it_is_built() -> None:
    sphere = ((0.05, 0.05, 0.05), 0.05, 0.05, (0.0, 0.0, 1.0))
    near = ((0.12, 0.05, 0.05), 0.05, 0.05, (0.0, 0.0, 1.0))
    far = ((0.15, 0.15, 0.15), 0.02, 0.02, (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match=r"particles\[1\] and particles\[2\] overlap by 0.03"):
        td.cells.periodic([far, sphere, near], (0.2, 0.2, 0.2))
    # Across a face: the image of the particle at x = 0.19 reaches x = 0.02 + 0.05.
    across = ((0.17, 0.05, 0.05), 0.05, 0.05, (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match=r"particles\[0\] and particles\[1\] overlap by 0.0[23]"):
        td.cells.periodic([sphere, across], (0.2, 0.2, 0.2))
    with pytest.raises(ValueError, match=r"particles\[0\] overlaps its own periodic image .* the box is too small"):
        td.cells.periodic([sphere], (0.08, 0.2, 0.2))
    # Touching images (the sc lattice) are not overlapping.
    assert td.cells.periodic([sphere], (0.1, 0.1, 0.1)).rho0 == pytest.approx(math.pi / 6)


def test_a_cell_file_with_duplicate_octants_is_refused_naming_them(tmp_path: Path) -> None:
    f = tmp_path / "dup.toml"
    f.write_text('lengths_mm = [0.05, 0.05, 0.05]\n'
                 '[[octants]]\ncorner = "000"\na = 0.05\nc = 0.05\n'
                 '[[octants]]\ncorner = [false, false, false]\na = 0.05\nc = 0.05\n')
    with pytest.raises(ValueError, match=r"octants\[0\] and octants\[1\] are both at corner 000"):
        td.cells.from_file(f)


Press = Callable[..., td.Result]


@pytest.fixture(scope="module")
def pressed() -> Press:
    """Runs a preset (by name) to a density, each distinct run once per module."""
    runs: dict[tuple[object, ...], td.Result] = {}

    def press(name: str, until: float, **kwargs: object) -> td.Result:
        key = (name, until, *sorted(kwargs.items()))
        if key not in runs:
            runs[key] = quick(td.cells.by_name(name), **kwargs).run(until_density=until)
        return runs[key]

    return press


@pytest.mark.parametrize(
    ("name", "until", "element"), [("bcc", 0.72, "hex8"), ("fcc", 0.75, "hex8"), ("sc2", 0.62, "hex8"), ("bcc", 0.69, "tet10")]
)
def test_every_packing_densifies_with_contact_pressure_and_no_penetration(
    pressed: Press, name: str, until: float, element: str
) -> None:
    cell = td.cells.by_name(name)
    r = pressed(name, until) if element == "hex8" else pressed(name, until, solver=td.SolverSettings(mesh_level=1, tolerance=0.05, element=element))
    assert r.status == "reached_density"
    assert np.all(np.diff(r.rel_density) >= -1e-12)
    assert r.curve["max_penetration_mm"].max() < 1e-4 * R
    f = r.snapshots[-1].fields
    assert f["contact_pressure"].max() > 10.0  # MPa: the necks carry more than the applied stress
    # Every particle carries contact pressure on some of its nodes.
    cells_of = [f["cells"][f["particle"] == k] for k in range(len(cell.octants))]
    assert all(f["contact_pressure"][np.unique(c)].max() > 0.0 for c in cells_of)
    # The curve counts the pressed nodes (a node pressed on two particles
    # counts twice, the field shows its larger pressure once).
    pressed_nodes = np.count_nonzero(f["contact_pressure"] > 0.0)
    assert pressed_nodes > 0 and r.curve["particle_contacts"][-1] >= pressed_nodes
    s = r.summary()
    assert len(s["cell"]["octants"]) == len(cell.octants)
    assert s["contact"]["mode"] == "frictionless" and s["contact"]["tied_planes"] is False
    assert ("size_ratio" in s["cell"]) == (name == "sc2")
    if name == "sc2":
        assert s["cell"]["size_ratio"] == pytest.approx(1.566, rel=1e-12)


def test_tied_particle_contact_slows_the_bcc_cell(pressed: Press) -> None:
    free = pressed("bcc", 0.72)
    tied = pressed("bcc", 0.72, contact="tied")
    assert tied.summary()["contact"]["mode"] == "tied"
    t_free, t_tied = free.time_to_density(0.715), tied.time_to_density(0.715)
    assert t_free is not None and t_tied is not None
    # Shear carried across the neck stiffens it.
    assert t_tied > 1.1 * t_free


def test_tied_planes_slow_the_sc_cell() -> None:
    free = quick(td.cells.sc()).run(until_density=0.85)
    tied = quick(td.cells.sc(), tied_planes=True).run(until_density=0.85)
    assert tied.summary()["contact"]["tied_planes"] is True
    t_free, t_tied = free.time_to_density(0.85), tied.time_to_density(0.85)
    assert t_free is not None and t_tied is not None
    # Rough walls block the lateral spreading the mirror symmetry needs.
    assert t_tied > 1.07 * t_free


def test_the_contact_facets_reach_the_core() -> None:
    # Both choices run, each is recorded, and they give other curves (at
    # level 1 to rho = 0.75: t(0.75) 1.680 and 1.681 s).
    runs = {}
    for facets in td.CONTACT_FACETS:
        case = td.Case(td.cells.bcc(), td.materials.TI64_CREEP_1293K, stress_mpa=10.0,
                       solver=td.SolverSettings(mesh_level=1, contact_facets=facets))
        runs[facets] = case.run(until_density=0.75, error_estimate=False)
        assert runs[facets].status == "reached_density"
        assert runs[facets].summary()["contact"]["facets"] == facets
    t_tri, t_bil = (runs[f].time_to_density(0.75) for f in ("triangles", "bilinear"))
    assert t_tri is not None and t_bil is not None and t_tri != t_bil


@pytest.mark.slow
def test_the_contact_facets_move_bcc_within_its_error_estimate() -> None:
    # Flat triangles and bilinear patches are two discretisations of one
    # surface: what the choice moves is within the run's estimate of its
    # time-stepping error (level 2: t(0.85) 69.39 and 69.54 s, estimate
    # 2.8 s). Slow (a minute): at level 1, or before rho = 0.8, the choice
    # moves the times by more than that (level 1: t(0.8) 6.79 and 7.32 s,
    # estimate 0.26 s; level 2: t(0.75) 1.466 and 1.500 s, estimate 0.015 s).
    runs = {}
    for facets in td.CONTACT_FACETS:
        case = td.Case(td.cells.bcc(), td.materials.TI64_CREEP_1293K, stress_mpa=10.0,
                       solver=td.SolverSettings(mesh_level=2, contact_facets=facets))
        runs[facets] = case.run(until_density=0.85)
        assert runs[facets].summary()["contact"]["facets"] == facets
    tri, bil = runs["triangles"], runs["bilinear"]
    for rho in (0.8, 0.85):
        t_tri, t_bil, err = tri.time_to_density(rho), bil.time_to_density(rho), tri.time_error_at_density(rho)
        assert t_tri is not None and t_bil is not None and err is not None
        assert t_tri != t_bil  # the choice reaches the core
        assert abs(t_tri - t_bil) < abs(err), (rho, t_tri, t_bil, err)


def test_bad_contact_options_name_themselves() -> None:
    with pytest.raises(ValueError, match="contact = 'sticky': must be one of frictionless, tied"):
        quick(td.cells.bcc(), contact="sticky")
    with pytest.raises(ValueError, match="contact = 'sticky': must be one of frictionless, tied"):
        td.Simulation(td.cells.bcc(), td.materials.TI64_CREEP_1293K, stress_mpa=10.0, until_density=0.9, contact="sticky")
    for knobs, name in [
        ({"contact_penalty_factor": 0.0}, r"contact_penalty_factor = 0: must be in \[0\.01, 1e4\]"),
        ({"penetration_tolerance": 0.5}, r"penetration_tolerance = 0\.5: must be in \[1e-8, 1e-2\]"),
    ]:
        # Refused when the settings are written, and by the core's Simulation.
        with pytest.raises(ValueError, match=name):
            td.SolverSettings(mesh_level=1, **knobs)  # type: ignore[arg-type]
        with pytest.raises(ValueError, match=name):
            td.Simulation(td.cells.bcc(), td.materials.TI64_CREEP_1293K, stress_mpa=10.0, until_density=0.9, **knobs)  # type: ignore[arg-type]


def test_sc2_large_particles_overlap_beyond_the_geometric_limit() -> None:
    # Large particles 2R apart across the face diagonal sqrt(2) (R + R/r):
    # they overlap for r > 1 + sqrt(2).
    with pytest.raises((ValueError, td.UnsupportedError), match="overlap|size_ratio"):
        quick(td.cells.sc2(size_ratio=2.5)).simulation(until_density=0.9)


def test_size_ratio_is_for_sc2_only() -> None:
    with pytest.raises(ValueError, match="size_ratio = 2: applies to the sc2 cell only"):
        td.cells.by_name("fcc", size_ratio=2.0)
    assert td.cells.by_name("sc2", size_ratio=2.0).rho0 == pytest.approx(sc2_rho0(2.0), rel=1e-13)
    with pytest.raises(ValueError, match="size_ratio"):
        td.cells.sc2(size_ratio=0.5)


def test_the_sc2_default_size_ratio_is_the_papers_everywhere() -> None:
    # The paper's 1.566: the core's constant, the native and the Python
    # signatures' defaults, and what a default sc2 cell is built with.
    import inspect

    assert td.cells.DEFAULT_SIZE_RATIO == 1.566
    assert inspect.signature(td.cells.sc2).parameters["size_ratio"].default == td.cells.DEFAULT_SIZE_RATIO
    assert inspect.signature(td.Cell.sc2).parameters["size_ratio"].default == td.cells.DEFAULT_SIZE_RATIO
    assert td.cells.size_ratio_of(td.cells.sc2()) == pytest.approx(1.566, rel=1e-14)
    assert td.cells.size_ratio_of(td.cells.by_name("sc2")) == pytest.approx(1.566, rel=1e-14)
