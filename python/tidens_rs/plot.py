"""Figures (matplotlib)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import cells

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .result import Result


def plot_density(result: Result) -> Figure:
    """Relative density versus time, FE beside the continuum model, on a
    linear and a logarithmic time axis."""
    # A bare Figure renders with Agg and needs neither pyplot nor a GUI
    # backend (whose import and set-up cost more than the plot).
    from matplotlib.figure import Figure

    c = result.case
    fig = Figure(figsize=(10, 4))
    # Fixed margins: a layout engine would draw the figure twice.
    fig.subplots_adjust(left=0.07, right=0.99, bottom=0.12, top=0.92, wspace=0.22)
    axes = fig.subplots(1, 2)
    t, rho = result.time_s, result.rel_density
    rho_end = float(max(rho[-1], c.cell.rho0 + 1e-3))
    tc, rc = result.continuum().curve(min(rho_end, 0.999))
    label = f"FE, {c.cell.name}, level {c.solver.mesh_level}"
    if cells.has_particle_contact(c.cell):
        label += f", {c.contact} contact"
    if c.tied_planes:
        label += ", tied planes"
    band = _error_band(result)
    for ax, log in zip(axes, (False, True)):
        keep = t > 0 if log else np.ones_like(t, dtype=bool)
        ax.plot(t[keep], rho[keep], "-", color="C0", label=label)
        if band is not None:
            ax.fill_betweenx(rho[keep], (t * (1 - band))[keep], (t * (1 + band))[keep], color="C0", alpha=0.2, lw=0, label="estimated error")
        keep_c = tc > 0 if log else np.ones_like(tc, dtype=bool)
        ax.plot(tc[keep_c], rc[keep_c], "--", color="C3", label="continuum model (Eqs. 2, 3 of the paper)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("relative density")
        ax.grid(True, alpha=0.3)
        if log:
            ax.set_xscale("log")
    m = c.material
    axes[0].set_title(
        f"{c.stress_mpa:g} MPa (f = {c.knockdown:g}), C = {m.creep_c:.3g}, n = {m.creep_n:g}"
    )
    axes[0].legend(loc="lower right")
    return fig


def _error_band(result: Result) -> np.ndarray | None:
    """The estimated relative error of t at each curve point: the estimate
    at the reported densities, linear in rho between them and constant
    beyond; None when no total estimate is known."""
    est = result.estimate().relative
    pts = sorted((float(k), v) for k, v in est.items() if v is not None)
    if not pts or len(pts) < len(est):
        return None
    rs, es = zip(*pts)
    return np.asarray(np.interp(result.rel_density, np.array(rs), np.array(es)))
