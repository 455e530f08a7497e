"""The cases of the speed targets, shared by ``speed.py`` (which times them)
and ``references.py`` (which gives their converged times to density)."""

from __future__ import annotations

# Densities whose times are compared with the references.
MARKS = (0.8, 0.9, 0.95)

# name: (cell, stress [MPa], target density); Ti-6Al-4V at 1293 K, 1 s ramp.
CASES: dict[str, tuple[str, float, float]] = {
    "sc10": ("sc", 10.0, 0.9),
    "sc": ("sc", 15.0, 0.95),
    "bcc": ("bcc", 15.0, 0.95),
    "fcc": ("fcc", 15.0, 0.95),
    "sc2": ("sc2", 15.0, 0.95),
}
