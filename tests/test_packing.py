"""Random packings and packing files, from Python and the command line."""

from __future__ import annotations

import math
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np
import pytest

import tidens_rs as td
from tidens_rs import packing as pk

R = 0.05  # mm


def lattice(name: str, stretch: float = 1.0) -> tuple[str, tuple[float, float, float], float, float]:
    """One periodic cell of touching spheres of radius R (the lattice
    stretched by ``stretch``): the text, the box, the closed-form density and
    coordination number of the touching lattice."""
    sites: list[tuple[float, float, float]]
    if name == "sc":
        a, sites = 2 * R, [(0, 0, 0)]
        rho, z = math.pi / 6, 6.0
    elif name == "bcc":
        a, sites = 4 * R / math.sqrt(3), [(0, 0, 0), (0.5, 0.5, 0.5)]
        rho, z = math.pi * math.sqrt(3) / 8, 8.0
    else:
        a, sites = 2 * math.sqrt(2) * R, [(0, 0, 0), (0.5, 0.5, 0), (0.5, 0, 0.5), (0, 0.5, 0.5)]
        rho, z = math.pi / (3 * math.sqrt(2)), 12.0
    a *= stretch
    text = "".join(f"{(x + 0.25) * a!r}, {(y + 0.25) * a!r}, {(w + 0.25) * a!r}, {R!r}\n" for x, y, w in sites)
    return text, (a, a, a), rho, z


@pytest.mark.parametrize("name", ["sc", "bcc", "fcc"])
def test_lattices_read_from_text_have_their_density_and_coordination(name: str) -> None:
    text, box, rho, z = lattice(name)
    p = td.Packing.from_text(text, box)
    assert p.rel_density == pytest.approx(rho, rel=1e-12)
    assert pk.coordination_number(p) == z
    # Pulled apart by 1 %, nothing touches at the default tolerance.
    text, box, _, _ = lattice(name, stretch=1.01)
    far = td.Packing.from_text(text, box)
    assert pk.coordination_number(far) == 0.0


@pytest.mark.parametrize(
    "kw",
    [
        {"rho0": 0.6},
        {"rho0": 0.62, "seed": 7},
        {"rho0": 0.6, "size_ratio": 1.566, "small_fraction": 0.5},
        {"rho0": 0.55, "sigma": 0.2},
        {"rho0": 0.55, "aspect_ratio": 2.0},
        {"rho0": 0.55, "boundary": "die"},
    ],
)
def test_a_generated_packing_has_its_density_and_no_overlap(kw: dict[str, object]) -> None:
    n = 16
    p = td.Packing.generate(n, **kw)  # type: ignore[arg-type]
    assert len(p) == n and p.centres_mm.shape == (n, 3) and p.semi_axes_mm.shape == (n, 2)
    assert p.rel_density == pytest.approx(kw["rho0"], rel=1e-12)
    assert p.max_overlap_mm <= 1e-6 * R  # the generator's guarantee
    assert pk.mean_radius_mm(p) == pytest.approx(0.05, rel=1e-12)
    a, c = p.semi_axes_mm.T
    assert np.allclose(c / a, float(kw.get("aspect_ratio", 1.0)), rtol=1e-12)  # type: ignore[arg-type]
    assert np.allclose(np.linalg.norm(p.axes, axis=1), 1.0, rtol=1e-12)
    if "size_ratio" in kw:
        r = np.cbrt(a * a * c)
        assert r.max() / r.min() == pytest.approx(1.566, rel=1e-12)
        assert np.count_nonzero(np.isclose(r, r.min())) == 8
    if kw.get("boundary") == "die":
        lz = p.lengths_mm[2]
        z = p.centres_mm[:, 2]
        assert np.all(z - c >= -1e-6 * R) and np.all(z + c <= lz + 1e-6 * R)


def test_the_seed_makes_the_packing() -> None:
    one = td.Packing.generate(12, rho0=0.6, seed=3).to_text()
    assert td.Packing.generate(12, rho0=0.6, seed=3).to_text() == one
    assert td.Packing.generate(12, rho0=0.6, seed=4).to_text() != one


def test_a_packing_file_round_trips_with_its_box(tmp_path: Path) -> None:
    p = td.Packing.generate(10, rho0=0.5, aspect_ratio=0.5, boundary="die", seed=1)
    path = pk.write(p, tmp_path / "p.txt")
    q = pk.read(path)
    assert (q.lengths_mm, q.boundary) == (p.lengths_mm, "die")
    assert np.array_equal(q.centres_mm, p.centres_mm) and np.array_equal(q.semi_axes_mm, p.semi_axes_mm)
    assert np.allclose(q.axes, p.axes, rtol=0, atol=1e-15)
    assert q.rel_density == pytest.approx(p.rel_density, rel=1e-14)


def test_a_jammed_packing_is_isostatic_without_its_rattlers() -> None:
    # Frictionless spheres jam isostatic: 3(N' - 1) + 1 contacts among the
    # N' particles held by 4 or more, about 6 per particle.
    p = td.Packing.generate(32, rho0=0.74, seed=0, jam=True)
    assert 0.62 <= p.rel_density <= 0.67
    assert p.max_overlap_mm <= 1e-6 * R
    assert pk.mean_radius_mm(p) == pytest.approx(R, rel=1e-12)
    z_all = pk.coordination_number(p)
    z = pk.coordination_number(p, without_rattlers=True)
    assert 5.75 <= z <= 6.1 and z >= z_all
    # The contacts are separated from the other neighbours by decades.
    assert pk.coordination_number(p, relative_tolerance=1e-6, without_rattlers=True) == z
    # A packing below jamming barely touches.
    assert pk.coordination_number(td.Packing.generate(32, rho0=0.6, seed=0), without_rattlers=True) < 1.0


def test_densities_beyond_jamming_are_refused_with_the_density_reached() -> None:
    with pytest.raises(ValueError, match=r"rho0 = 0.7: not reached, the packing jammed at a relative density of 0\.6"):
        td.Packing.generate(8, rho0=0.7, seed=0)


@pytest.mark.parametrize(
    ("kw", "kind", "message"),
    [
        ({"rho0": 0.8}, ValueError, r"rho0 = 0.8: must be in \[0.3, 0.74\]"),
        ({"particles": 0}, ValueError, r"^particles = 0: must be an integer in \[1, 10000\]"),
        ({"particles": -3}, ValueError, r"^particles = -3: must be an integer in \[1, 10000\]"),
        ({"particles": 2**70}, ValueError, r"^particles = 1180591620717411303424: must be an integer in \[1, 10000\]"),
        ({"particles": 8.0}, TypeError, r"^particles = 8.0: must be an integer, not float"),
        ({"mean_radius_mm": -1.0}, ValueError, r"mean_radius_mm = -1"),
        ({"aspect_ratio": 9.0}, ValueError, r"aspect_ratio = 9: must be in \[0.2, 5\]"),
        ({"size_ratio": 0.5}, ValueError, r"size_ratio = 0.5: must be in \(1, 10\]"),
        ({"size_ratio": 2.0, "sigma": 0.1}, ValueError, r"size_ratio and sigma are both given"),
        ({"boundary": "box"}, ValueError, r"boundary = 'box': must be one of periodic, die"),
        ({"rho0": "0.6"}, TypeError, r"rho0"),
        ({"seed": -1}, ValueError, r"^seed = -1: must be an integer in \[0, 18446744073709551615\]"),
        ({"seed": 2**70}, ValueError, r"^seed = 1180591620717411303424: must be an integer in \[0, 18446744073709551615\]"),
        ({"seed": 2**64}, ValueError, r"^seed = 18446744073709551616: must be an integer in \[0, 18446744073709551615\]"),
        ({"seed": 1.5}, TypeError, r"^seed = 1.5: must be an integer, not float"),
        ({"seed": "a"}, TypeError, r"^seed = 'a': must be an integer, not str"),
        ({"seed": True}, TypeError, r"^seed = True: must be an integer, not bool"),
        ({"seed": None}, TypeError, r"^seed = None: must be an integer, not NoneType"),
        ({"progress": "yes"}, TypeError, r"^progress = 'yes': must be a callable"),
    ],
)
def test_bad_packing_arguments_name_themselves(kw: dict[str, object], kind: type[Exception], message: str) -> None:
    args: dict[str, object] = {"particles": 8, **kw}
    n = args.pop("particles")
    with pytest.raises(kind, match=message):
        td.Packing.generate(n, **args)  # type: ignore[arg-type]


def test_seeds_take_any_64_bit_integer_and_numpy_integers() -> None:
    assert td.Packing.generate(8, seed=2**64 - 1).to_text() != td.Packing.generate(8, seed=0).to_text()
    assert td.Packing.generate(8, seed=np.uint64(5)).to_text() == td.Packing.generate(8, seed=5).to_text()  # type: ignore[arg-type]
    assert len(td.Packing.generate(np.int32(12))) == 12  # type: ignore[arg-type]


def test_a_signal_handler_interrupts_a_long_generation() -> None:
    # 3000 spheres jammed at 0.74 take minutes; the generation runs the
    # handlers ten times a second, and SIGALRM's raises after 0.3 s.
    class Alarm(Exception):
        pass

    def ring(signum: int, frame: FrameType | None) -> None:
        raise Alarm

    before = signal.signal(signal.SIGALRM, ring)
    start = time.perf_counter()
    signal.setitimer(signal.ITIMER_REAL, 0.3)
    try:
        with pytest.raises(Alarm):
            td.Packing.generate(3000, rho0=0.74, jam=True)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)
    assert time.perf_counter() - start < 1.0


def test_progress_is_reported_a_few_times_a_second_and_what_it_raises_stops() -> None:
    class Enough(Exception):
        pass

    seen: list[tuple[float, dict[str, Any]]] = []

    def progress(p: dict[str, Any]) -> None:
        seen.append((time.perf_counter(), p))
        if len(seen) == 3:
            raise Enough

    start = time.perf_counter()
    with pytest.raises(Enough):
        td.Packing.generate(3000, rho0=0.74, jam=True, progress=progress)
    times = [start] + [t for t, _ in seen]
    assert all(b - a >= 0.25 for a, b in zip(times, times[1:])), times
    assert times[-1] - start < 1.5
    for _, p in seen:
        assert set(p) == {"stage", "rel_density", "densest", "round", "iterations"}
        assert p["stage"] in ("start", "compress", "shake", "refine")
        assert 0.25 <= p["rel_density"] <= 0.74 and 0.0 <= p["densest"] <= 0.74 and p["round"] == 0
    iterations = [p["iterations"] for _, p in seen]
    assert iterations == sorted(iterations) and iterations[0] > 0
    # A quick generation reports nothing and is the same packing.
    quiet: list[dict[str, Any]] = []
    assert td.Packing.generate(16, seed=1, progress=quiet.append).to_text() == td.Packing.generate(16, seed=1).to_text()
    assert quiet == []


def test_bad_packing_files_name_the_file_line_and_field(tmp_path: Path) -> None:
    bad = tmp_path / "bad.txt"
    bad.write_text("# comment\n0 0 0 0.05\n0.1 0.1 x 0.05\n")
    with pytest.raises(ValueError, match=r"bad.txt: line 3: z: `x` is not a number"):
        pk.read(bad, (1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match=r"bad.txt: no 'tidens packing' header: give lengths_mm"):
        pk.read(bad)
    overlap = tmp_path / "overlap.txt"
    overlap.write_text("0.1 0.1 0.1 0.05\n0.15 0.1 0.1 0.05\n")
    with pytest.raises(ValueError, match=r"overlap.txt: .*line"):
        pk.read(overlap, (1.0, 1.0, 1.0))
    binary = tmp_path / "binary.txt"
    binary.write_bytes(bytes(range(256)))
    with pytest.raises(ValueError, match=r"binary.txt: not a text file"):
        pk.read(binary, (1.0, 1.0, 1.0))


def test_the_pack_command_writes_the_packing_it_reports(tmp_path: Path) -> None:
    out = tmp_path / "p.txt"
    cmd = [sys.executable, "-m", "tidens_rs.cli", "pack", "--particles", "8", "--rho0", "0.55", "--packing-seed", "2", "--out", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True, check=True)
    p = pk.read(out)
    assert len(p) == 8
    assert f"rho0 = {p.rel_density:.6f}" in done.stdout
    assert f"coordination number {pk.coordination_number(p):.3f}" in done.stdout
    bad = subprocess.run([*cmd[:5], "0", "--out", str(out)], capture_output=True, text=True)
    assert bad.returncode == 2 and "--particles = 0: must be an integer in [1, 10000]" in bad.stderr and bad.stderr.count("\n") == 1
    dense = subprocess.run([*cmd[:7], "0.8", "--out", str(out)], capture_output=True, text=True)
    assert dense.returncode == 2 and "--rho0 = 0.8: must be in [0.3, 0.74]" in dense.stderr
    jammed = subprocess.run([*cmd[:6], "--jam", "--out", str(out)], capture_output=True, text=True, check=True)
    p = pk.read(out)
    assert f"rho0 = {p.rel_density:.6f}" in jammed.stdout and p.rel_density > 0.6
    assert f"({pk.coordination_number(p, without_rattlers=True):.3f} without rattlers" in jammed.stdout
