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
    linear and a logarithmic time axis; the estimated error of t(rho) as
    error bars at the marked densities, with its value."""
    # A bare Figure renders with Agg and needs neither pyplot nor a GUI
    # backend (whose import and set-up cost more than the plot).
    from matplotlib.figure import Figure

    from .materials import describe, name_of

    c = result.case
    m = c.material
    fig = Figure(figsize=(10, 4.4))
    # Fixed margins: a layout engine would draw the figure twice.
    fig.subplots_adjust(left=0.07, right=0.99, bottom=0.12, top=0.84, wspace=0.22)
    axes = fig.subplots(1, 2)
    t, rho = result.time_s, result.rel_density
    rho_end = float(max(rho[-1], c.cell.rho0 + 1e-3))
    tc, rc = result.continuum().curve(min(rho_end, 0.999))
    label = f"FE, {c.cell.name}, level {c.solver.mesh_level}"
    if cells.has_particle_contact(c.cell):
        label += f", {c.contact} contact"
    if c.tied_planes:
        label += ", tied planes"
    marks = _marked_errors(result)
    for ax, log in zip(axes, (False, True)):
        keep = t > 0 if log else np.ones_like(t, dtype=bool)
        ax.plot(t[keep], rho[keep], "-", color="C0", label=label)
        if marks:
            tm = np.array([x[1] for x in marks])
            ax.errorbar(tm, [x[0] for x in marks], xerr=tm * np.array([x[2] for x in marks]), fmt="o", ms=3, color="C0",
                        capsize=4, lw=1.2, label="t(rho) and its estimated error" + ("" if any(x[3] for x in marks) else " (time steps only)"))
        keep_c = tc > 0 if log else np.ones_like(tc, dtype=bool)
        ax.plot(tc[keep_c], rc[keep_c], "--", color="C3", label="continuum model (Eqs. 2, 3 of the paper)")
        ax.set_xlabel("time [s]" + (" (log scale)" if log else ""))
        ax.set_ylabel("relative density")
        ax.grid(True, alpha=0.3)
        if log:
            ax.set_xscale("log")
    for rho_k, t_k, err, _ in marks:
        axes[0].annotate(f"\u00b1{100 * err:.2g} %", (t_k, rho_k), textcoords="offset points", xytext=(6, -10), fontsize=7, color="C0")
    material = describe(m) if name_of(m) is not None else f"custom material, C = {m.creep_c:.3g} MPa^-n s^-1, n = {m.creep_n:g}"
    fig.suptitle(f"{material}: {c.cell.name} cell at {c.stress_mpa:g} MPa (knock-down f = {c.knockdown:g}, ramp {c.ramp_time_s:g} s)", fontsize=11)
    axes[0].set_title("linear time", fontsize=9)
    axes[1].set_title("logarithmic time: the early densification", fontsize=9)
    axes[0].legend(loc="lower right", fontsize=8)
    return fig


def _marked_errors(result: Result) -> list[tuple[float, float, float, bool]]:
    """(rho, t(rho) [s], estimated relative error of t, whether it is the
    total) at the marked densities the run reached with an estimate: the
    total (time and mesh) where there is one, else the time control's part
    alone."""
    est = result.estimate()
    out = []
    for key, total in est.relative.items():
        err = total if total is not None else (est.time or {}).get(key)
        t = result.time_to_density(float(key))
        if err is not None and t is not None:
            out.append((float(key), t, float(err), total is not None))
    return sorted(out)
