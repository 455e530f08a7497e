"""What a run gives back: the densification curve as numpy arrays, the field
snapshots, run statistics, and the continuum model for comparison."""

from __future__ import annotations

import errno

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _checks, cells, io
from ._core import Cell, __version__
from .continuum import ContinuumModel
from .estimate import ErrorEstimate, estimate_error
from .materials import name_of
from .snapshot import Snapshot

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .case import Case

MARK_DENSITIES = (0.6, 0.7, 0.8, 0.9, 0.95)


# The timed parts of a step in ``Result.stats`` [s].
_TIMED_PARTS = ("evaluation_seconds", "contact_seconds", "assembly_seconds", "linear_seconds")


def interpolate_time(time_s: np.ndarray, rho: np.ndarray, target: float) -> float | None:
    """Time [s] at which the (non-decreasing) density first reaches
    ``target``, linearly interpolated between steps; None if never reached."""
    above = np.nonzero(rho >= target)[0]
    if len(above) == 0:
        return None
    k = int(above[0])
    if k == 0:
        return float(time_s[0])
    r0, r1 = rho[k - 1], rho[k]
    w = (target - r0) / (r1 - r0) if r1 > r0 else 1.0
    return float(time_s[k - 1] + w * (time_s[k] - time_s[k - 1]))


def _cell_summary(cell: Cell) -> dict[str, Any]:
    """The cell block of the summary: the cell-file schema (name, lengths_mm,
    octants with corner, a, c), plus aspect_ratio (the particles' common c/a,
    None if they differ), size_ratio (largest over smallest particle, for
    cells of more than one size and for sc2) and rho0_exact."""
    out = cells.to_dict(cell)
    out["aspect_ratio"] = cells.aspect_ratio_of(cell)
    r = cells.size_ratio_of(cell)
    if cell.name == "sc2" or r > 1.0 + 1e-12:
        out["size_ratio"] = r
    out["rho0_exact"] = cell.rho0
    return out


def _particles_summary(cell: Cell) -> dict[str, Any]:
    """For a periodic cell, its number of whole particles and their mean
    coordination number at the start (contacts within
    :data:`tidens_rs.packing.COORDINATION_TOLERANCE` of the mean radius);
    None for a cell of octants."""
    if not cell.is_periodic:
        return {"particles": None, "coordination_number": None}
    from . import packing

    return {
        "particles": len(cell.particles),
        "coordination_number": packing.coordination_number(cells.to_packing(cell)),
    }


@dataclass
class Result:
    """The outcome of :meth:`tidens_rs.Case.run`.

    ``curve`` holds one numpy array per column of ``curve.csv`` (see
    :data:`tidens_rs.io.CURVE_COLUMNS`); the most used ones are also
    attributes: ``time_s``, ``rel_density``, ``piston_displacement_mm``,
    ``applied_stress_mpa``. ``status`` is ``reached_density``,
    ``reached_time``, ``full_density`` (the pores closed, rho = 0.9999,
    before the target: a long hold), ``stopped`` (by a callback),
    ``interrupted`` or ``failed`` (then ``message`` says why). ``error_estimate`` is the
    estimated error of its times to density (see :mod:`tidens_rs.estimate`);
    ``accuracy_search`` the rungs a run with ``accuracy=`` climbed.
    """

    case: Case
    curve: dict[str, np.ndarray]
    status: str
    wall_seconds: float
    stats: dict[str, float]
    degrees_of_freedom: int
    nodes: int
    elements: int
    snapshots: list[Snapshot] = field(default_factory=list)
    message: str | None = None
    error_estimate: ErrorEstimate | None = None
    accuracy_search: dict[str, Any] | None = None
    # Snapshots an interrupted run wrote before this resumed one: (time, file).
    earlier_snapshots: list[tuple[float, str]] = field(default_factory=list)

    def __repr__(self) -> str:
        # Short: the dataclass's own repr prints every array of the curve.
        c = self.case
        worst = self.estimate().curve.get("relative") if self.error_estimate is not None else None
        error = "" if worst is None else f", estimated error {100 * worst:.2g} %"
        return (
            f"<Result {c.cell.name}, {c.stress_mpa:g} MPa: {self.status} at t = {float(self.time_s[-1]):.4g} s, "
            f"rho = {float(self.rel_density[-1]):.4f}, {len(self.time_s) - 1} steps, mesh level "
            f"{c.solver.mesh_level}{error}>"
        )

    @property
    def time_s(self) -> np.ndarray:
        return self.curve["time_s"]

    @property
    def rel_density(self) -> np.ndarray:
        return self.curve["rel_density"]

    @property
    def piston_displacement_mm(self) -> np.ndarray:
        return self.curve["piston_displacement_mm"]

    @property
    def applied_stress_mpa(self) -> np.ndarray:
        return self.curve["applied_stress_mpa"]

    @property
    def run_seconds(self) -> float:
        """Wall time the run's curve took to compute [s]: its steps' time
        summed across resumes from checkpoints (``wall_seconds`` is this
        call's alone). A checkpoint written before tidens kept that total
        starts it at zero; the timed parts of the steps (elements, contact,
        assembly, linear solves), which every checkpoint carries, then bound
        it from below."""
        parts = sum(float(self.stats.get(k, 0.0)) for k in _TIMED_PARTS)
        return max(float(self.stats.get("wall_seconds", 0.0)), parts)

    @property
    def rho0(self) -> float:
        """Initial relative density of the mesh."""
        return float(self.rel_density[0])

    def time_to_density(self, rho: float) -> float | None:
        """Time [s] to reach density ``rho`` in [rho0, 1), None if not
        reached. A density below the run's first one is an error (the
        packing never was that loose), not 0 s."""
        r = _checks.real("rho", rho)
        if not self.rho0 <= r < 1.0:
            raise ValueError(f"rho = {rho!r}: must be in [rho0 = {self.rho0:.4f}, 1): the run starts at rho0")
        return interpolate_time(self.time_s, self.rel_density, r)

    def time_error_at_density(self, rho: float) -> float | None:
        """Estimated time-discretisation error [s] of :meth:`time_to_density`."""
        t = self.time_to_density(rho)
        if t is None:
            return None
        return float(np.interp(t, self.time_s, self.curve["time_error_s"]))

    def estimate(self) -> ErrorEstimate:
        """The run's error estimate: the one :meth:`Case.run` made, or, for a
        result made otherwise, the time part alone."""
        if self.error_estimate is not None:
            return self.error_estimate
        arrays = {k: self.curve[k] for k in ("time_s", "rel_density", "time_error_s")}
        return estimate_error(arrays, None, MARK_DENSITIES, companion_note="no companion run")

    def continuum(self) -> ContinuumModel:
        """The continuum model for this run's material, load and exact rho0."""
        c = self.case
        return ContinuumModel(
            creep_c=c.material.creep_c,
            creep_n=c.material.creep_n,
            stress_mpa=c.stress_mpa,
            knockdown=c.knockdown,
            ramp_time_s=c.ramp_time_s,
            rho0=c.cell.rho0,
        )

    def checks(self) -> dict[str, Any]:
        """Physical checks of the run, each with the number it judges:
        ``monotone`` (the density never falls by more than the solver's
        tolerances can move it: ``density_drop_allowed`` = 10 x the Newton
        residual tolerance x f sigma / E, the strain its residual leaves on
        the elastic stiffness, plus, on cells with particle contact, twice
        the penetration tolerance over the cell height, the strain by which
        the contact multipliers' update pushes the last step's penetrations
        out; measured: 1.9e-6 on sc at E/sigma = 100 just after the ramp,
        2.0e-5 on bcc at C = 1e-12 during the elastic ramp), ``finite`` (no NaN
        or infinity in the curve, but for the coordination number of a cell
        of octants, NaN by definition), ``volume_kept`` (the particles' volume
        changes only elastically: ``volume_change``, the largest relative
        change, within ``volume_change_bound`` = 2 f sigma / (rho0 K), the
        mean pressure a solid fraction rho0 carries at the full load over
        the bulk modulus K, with a factor 2 for the lateral stresses),
        ``penetration_ok`` (the largest penetration over the largest
        particle semi-axis, ``max_penetration_over_radius``, within the
        contact's ``penetration_tolerance``; the penetration as the contact
        enforces it, a term across a fold between two facets counted at
        its weight), ``depth_ok`` (the largest
        depth of any surface node inside another particle, the curve's
        ``max_depth_mm`` over the same radius, ``max_depth_over_radius``,
        within the same tolerance: parry's signed distance, whether a
        contact term measures the node or not, so that a node left
        unlinked, or measured on a facet it has slid off, cannot hide; True
        for outputs written before it was measured, where it is ``None``);
        ``ok`` when all hold."""
        c = self.case
        m = c.material
        rho = self.rel_density
        volume = self.curve["particle_volume_mm3"]
        bulk = m.young_mpa / (3.0 * (1.0 - 2.0 * m.poisson))
        lz = c.cell.lengths_mm[2]
        radius = cells.largest_radius_of(c.cell)
        contact = 2.0 * c.solver.penetration_tolerance * radius / lz if cells.has_particle_contact(c.cell) else 0.0
        drop = max(1e-12, 10.0 * c.solver.newton_residual_tolerance * c.knockdown * c.stress_mpa / m.young_mpa) + contact
        out: dict[str, Any] = {
            "monotone": bool(np.all(np.diff(rho) >= -drop)),
            "density_drop_allowed": drop,
            "finite": bool(all(np.all(np.isfinite(v)) for k, v in self.curve.items()
                               if k != "coordination_number" or c.cell.is_periodic)),
            "volume_change": float(np.max(np.abs(volume / volume[0] - 1.0))),
            "volume_change_bound": 2.0 * c.knockdown * c.stress_mpa / (self.rho0 * bulk),
            "max_penetration_over_radius": float(np.max(self.curve["max_penetration_mm"])) / radius,
        }
        out["volume_kept"] = out["volume_change"] <= out["volume_change_bound"]
        out["penetration_ok"] = out["max_penetration_over_radius"] <= c.solver.penetration_tolerance
        depth = self.curve.get("max_depth_mm")
        out["max_depth_over_radius"] = float(np.max(depth)) / radius if depth is not None else None
        out["depth_ok"] = out["max_depth_over_radius"] is None or out["max_depth_over_radius"] <= c.solver.penetration_tolerance
        out["ok"] = (
            out["monotone"] and out["finite"] and out["volume_kept"] and out["penetration_ok"] and out["depth_ok"]
        )
        return out

    def summary(self) -> dict[str, Any]:
        """Everything ``summary.json`` holds."""
        c = self.case
        m = c.material
        marks = [r for r in MARK_DENSITIES if r > self.rho0]
        times = {f"{r:g}": self.time_to_density(r) for r in marks}
        reached = {k: v for k, v in times.items() if v is not None}
        errors = {f"{r:g}": self.time_error_at_density(r) for r in marks}
        model = self.continuum()
        # The mesh starts a little below the exact rho0 the model starts at.
        last = {k: float(v[-1]) for k, v in self.curve.items()}
        # The model at the marks the run reached, as the run's own times.
        continuum_times = {
            f"{r:g}": float(model.time_to_density(r)[0]) for r in marks if model.rho0 < r <= last["rel_density"]
        }
        return {
            "tidens_version": __version__,
            "status": self.status,
            "message": self.message,
            "cell": _cell_summary(c.cell),
            "material": {
                "preset": name_of(m),
                "creep_c": m.creep_c,
                "creep_n": m.creep_n,
                "young_mpa": m.young_mpa,
                "poisson": m.poisson,
            },
            "load": {
                "stress_mpa": c.stress_mpa,
                "knockdown": c.knockdown,
                "ramp_time_s": c.ramp_time_s,
            },
            "contact": {
                "mode": c.contact,
                "tied_planes": c.tied_planes,
                "penalty_factor": c.solver.contact_penalty_factor,
                "penetration_tolerance": c.solver.penetration_tolerance,
                "facets": c.solver.contact_facets,
            },
            "solver": c.solver.as_dict(),
            "rho0": self.rho0,
            **_particles_summary(c.cell),
            # (None for cells of octants, which have no such column.)
            "final_coordination_number": last.get("coordination_number") if c.cell.is_periodic else None,
            "final_density": last["rel_density"],
            "final_time_s": last["time_s"],
            "times_to_density_s": reached,
            "time_error_estimate_s": {k: v for k, v in errors.items() if k in reached},
            "error_estimate": self.estimate().as_dict(),
            "accuracy": self.accuracy_search,
            "continuum_times_to_density_s": continuum_times,
            "wall_seconds": self.wall_seconds,
            "run_seconds": self.run_seconds,
            "steps": int(last["step"]),
            "newton_iterations": int(last["newton_total"]),
            "degrees_of_freedom": self.degrees_of_freedom,
            "nodes": self.nodes,
            "elements": self.elements,
            "max_penetration_mm": float(np.max(self.curve["max_penetration_mm"])),
            "max_depth_mm": float(np.max(self.curve["max_depth_mm"])) if "max_depth_mm" in self.curve else None,
            "checks": self.checks(),
            "stats": self.stats,
        }

    def write_csv(self, path: str | Path) -> Path:
        """Writes the curve to ``path`` (CSV with a header row)."""
        p = Path(path)
        io.write_curve(p, self.curve, io.curve_columns(self.case.cell.is_periodic))
        return p

    def write_summary(self, path: str | Path) -> Path:
        p = Path(path)
        io.write_summary(p, self.summary())
        return p

    def write_vtu(self, out_dir: str | Path) -> list[Path]:
        """Writes every snapshot as ``fields_<label>.vtu`` plus ``fields.pvd``
        into the folder ``out_dir`` (made if missing); OutputError naming it
        when it is a file."""
        d = Path(out_dir)
        if d.exists() and not d.is_dir():
            raise io.OutputError(errno.ENOTDIR, "not a folder: give a folder for the VTU files", str(d))
        entries = [(s.time_s, io.write_vtu(d / f"fields_{s.label}.vtu", s)) for s in self.snapshots]
        written = {p.name for _, p in entries}
        earlier = [(t, d / name) for t, name in self.earlier_snapshots if name not in written]
        if entries or earlier:
            io.write_pvd(d / "fields.pvd", earlier + entries)
        return [p for _, p in entries]

    def plot(self, path: str | Path | None = None) -> Figure:
        """Density versus time beside the continuum model; saved to ``path`` if given."""
        from .plot import plot_density

        fig = plot_density(self)
        if path is not None:
            p = Path(path)
            kind = p.suffix[1:].lower() or "png"
            io.atomic_write(p, lambda tmp: fig.savefig(tmp, dpi=150, format=kind))
        return fig
