//! `Cell`: the unit cell of a particle packing that a simulation presses.

use crate::errors::{Number, Phase, parameter_error, solver_error};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use tidens_packing::{Boundary, OVERLAP_TOLERANCE, Packing, Particle};
use tidens_solver::{ASPECT_RANGE, Cell, Octant, PlacedSpheroid, RADIUS_RANGE, SolverError};

/// An octant as Python passes it: ((high_x, high_y, high_z), a_mm, c_mm).
pub(crate) type OctantTuple = ((bool, bool, bool), f64, f64);

/// A box [0,Lx]x[0,Ly]x[0,Lz] of mirror planes with particle octants at its corners.
///
/// Cell(name, lengths_mm, octants): lengths_mm = (Lx, Ly, Lz) [mm]; each
/// octant is ((high_x, high_y, high_z), a_mm, c_mm), the box corner at the
/// spheroid's centre (True = the high end L_i of that axis) and its semi-axes
/// along x, y (a) and z (c) [mm]. z is the pressing direction (the piston is
/// the face z = Lz). Checked here: lengths and semi-axes in [1e-6, 1e3] mm,
/// c/a in [0.2, 5], every octant inside the box (ValueError naming the field,
/// e.g. octants[1].a), one octant per corner and no two overlapping
/// (ValueError naming both, e.g. "octants[0] and octants[2] overlap";
/// touching is allowed, to a relative 1e-6 of the level function, about
/// 5e-7 of a distance). Presets: Cell.sc, Cell.bcc, Cell.fcc, Cell.sc2.
#[pyclass(name = "Cell", module = "tidens_rs._core", frozen)]
#[derive(Clone, Debug)]
pub struct PyCell {
    pub(crate) inner: CellKind,
}

/// What a cell holds.
#[derive(Clone, Debug)]
pub(crate) enum CellKind {
    /// A box of mirror planes with particle octants at its corners.
    Octants(Cell),
    /// Whole particles in a box periodic along x, y and z.
    Periodic {
        name: String,
        lengths: [f64; 3],
        particles: Vec<PlacedSpheroid>,
    },
}

impl CellKind {
    pub(crate) fn lengths(&self) -> [f64; 3] {
        match self {
            Self::Octants(c) => c.lengths,
            Self::Periodic { lengths, .. } => *lengths,
        }
    }

    fn name(&self) -> &str {
        match self {
            Self::Octants(c) => &c.name,
            Self::Periodic { name, .. } => name,
        }
    }

    fn rho0(&self) -> f64 {
        match self {
            Self::Octants(c) => c.rho0(),
            Self::Periodic {
                lengths, particles, ..
            } => {
                let v: f64 = particles
                    .iter()
                    .map(|p| 4.0 / 3.0 * std::f64::consts::PI * p.a * p.a * p.c)
                    .sum();
                v / lengths.iter().product::<f64>()
            }
        }
    }
}

/// A particle of a periodic cell as Python passes it: (centre_mm, a_mm,
/// c_mm, axis).
pub(crate) type ParticleTuple = ((f64, f64, f64), f64, f64, (f64, f64, f64));

impl PyCell {
    fn preset(cell: Result<Cell, SolverError>) -> PyResult<Self> {
        let inner = cell.map_err(|e| solver_error(e, Phase::Setup))?;
        Ok(Self {
            inner: CellKind::Octants(inner),
        })
    }
}

/// The periodic cell's particles, checked: each `particles[k].field`
/// named in the error.
fn placed(lengths: [f64; 3], particles: &[ParticleTuple]) -> PyResult<Vec<PlacedSpheroid>> {
    let (lo, hi) = RADIUS_RANGE;
    let (alo, ahi) = ASPECT_RANGE;
    if particles.is_empty() {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "particles = []: a periodic cell needs at least one particle",
        ));
    }
    particles
        .iter()
        .enumerate()
        .map(|(k, &((x, y, z), a, c, (ax, ay, az)))| {
            let at = |field: &str| format!("particles[{k}].{field}");
            for (field, v) in [("a", a), ("c", c)] {
                if !(lo..=hi).contains(&v) {
                    return Err(parameter_error(
                        &at(field),
                        Number(v),
                        &format!("in [{lo:e}, {hi:e}] mm"),
                    ));
                }
            }
            if !(alo..=ahi).contains(&(c / a)) {
                return Err(parameter_error(
                    &at("c"),
                    Number(c),
                    &format!("in [{alo}, {ahi}] times a = {a} mm (c/a)"),
                ));
            }
            let centre = [x, y, z];
            for i in 0..3 {
                if !(centre[i] >= 0.0 && centre[i] < lengths[i]) {
                    return Err(parameter_error(
                        &format!("{}[{i}]", at("centre")),
                        Number(centre[i]),
                        &format!("in [0, {}) mm (the box)", lengths[i]),
                    ));
                }
            }
            let axis = [ax, ay, az];
            let norm = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !(norm > 0.0 && norm.is_finite()) {
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "{} = ({ax}, {ay}, {az}): must be a non-zero finite vector",
                    at("axis")
                )));
            }
            Ok(PlacedSpheroid { centre, a, c, axis })
        })
        .collect()
}

/// Refuses particles of a periodic cell that overlap one another, or an
/// image of one another or of themselves, by more than [`OVERLAP_TOLERANCE`]
/// of the smaller volume-equivalent radius: the test of a packing file
/// (`Packing.from_text`, exact for spheroids: Perram-Wertheim), here naming
/// the particles as given, `particles[k]`.
fn check_apart(lengths: [f64; 3], particles: &[PlacedSpheroid]) -> PyResult<()> {
    let packing = Packing {
        lengths,
        boundary: Boundary::Periodic,
        particles: particles
            .iter()
            .map(|p| {
                let norm = p.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
                Particle {
                    centre: p.centre,
                    a: p.a,
                    c: p.c,
                    axis: p.axis.map(|v| v / norm),
                }
            })
            .collect(),
    };
    for contact in packing.contacts(0.0) {
        let (i, j) = (contact.i, contact.j);
        let (p, q) = (&packing.particles[i], &packing.particles[j]);
        let allowed = OVERLAP_TOLERANCE * p.equivalent_radius().min(q.equivalent_radius());
        let depth = -contact.gap;
        if depth <= allowed {
            continue;
        }
        let which = if i == j {
            format!(
                "particles[{i}] overlaps its own periodic image by {} mm: the box is too \
                 small for it",
                Number(depth)
            )
        } else {
            format!(
                "particles[{i}] and particles[{j}] overlap by {} mm",
                Number(depth)
            )
        };
        return Err(PyValueError::new_err(format!(
            "{which} (touching is allowed, to 1e-6 of the smaller radius: {} mm)",
            Number(allowed)
        )));
    }
    Ok(())
}

/// The core checks the octants in order but does not say which one failed:
/// find the first octant that fails alone and name it, `octants[k].a`.
fn octant_error(err: SolverError, name: &str, lengths: [f64; 3], octants: &[Octant]) -> PyErr {
    let located = octants.iter().enumerate().find_map(|(k, o)| {
        match Cell::new(name, lengths, vec![o.clone()]) {
            Err(SolverError::Parameter {
                name,
                value,
                allowed,
            }) => Some(parameter_error(
                &format!("octants[{k}].{name}"),
                Number(value),
                &allowed,
            )),
            _ => None,
        }
    });
    located.unwrap_or_else(|| solver_error(err, Phase::Setup))
}

#[pymethods]
impl PyCell {
    #[new]
    fn new(name: String, lengths_mm: (f64, f64, f64), octants: Vec<OctantTuple>) -> PyResult<Self> {
        let lengths = [lengths_mm.0, lengths_mm.1, lengths_mm.2];
        let octants: Vec<Octant> = octants
            .into_iter()
            .map(|((x, y, z), a, c)| Octant {
                corner: [x, y, z],
                a,
                c,
            })
            .collect();
        match Cell::new(name.as_str(), lengths, octants.clone()) {
            Ok(inner) => Ok(Self {
                inner: CellKind::Octants(inner),
            }),
            // The per-octant checks: say which octant.
            Err(
                err @ SolverError::Parameter {
                    name: "a" | "c" | "c/a",
                    ..
                },
            ) => Err(octant_error(err, &name, lengths, &octants)),
            Err(err) => Err(solver_error(err, Phase::Setup)),
        }
    }

    /// Simple cubic cell: one octant of a spheroid with semi-axes (radius_mm,
    /// radius_mm, aspect_ratio * radius_mm) in a box of the same size, so
    /// rho0 = pi/6. radius_mm in [1e-6, 1e3] [mm]; aspect_ratio = c/a in [0.2, 5].
    #[staticmethod]
    #[pyo3(signature = (radius_mm = 0.05, aspect_ratio = 1.0))]
    fn sc(radius_mm: f64, aspect_ratio: f64) -> PyResult<Self> {
        Self::preset(Cell::sc(radius_mm, aspect_ratio))
    }

    /// Body-centred cubic cell: box s x s x (aspect_ratio s), s = 2 R/sqrt(3),
    /// octants at (0,0,0) and (s,s,s) touching along the body diagonal;
    /// rho0 = pi sqrt(3)/8. R = radius_mm [mm], aspect_ratio = c/a.
    #[staticmethod]
    #[pyo3(signature = (radius_mm = 0.05, aspect_ratio = 1.0))]
    fn bcc(radius_mm: f64, aspect_ratio: f64) -> PyResult<Self> {
        Self::preset(Cell::bcc(radius_mm, aspect_ratio))
    }

    /// Face-centred cubic cell: box s x s x (aspect_ratio s), s = sqrt(2) R,
    /// octants at (0,0,0), (s,s,0), (s,0,s), (0,s,s) touching along the face
    /// diagonals; rho0 = pi/(3 sqrt(2)). R = radius_mm [mm].
    #[staticmethod]
    #[pyo3(signature = (radius_mm = 0.05, aspect_ratio = 1.0))]
    fn fcc(radius_mm: f64, aspect_ratio: f64) -> PyResult<Self> {
        Self::preset(Cell::fcc(radius_mm, aspect_ratio))
    }

    /// Two-size simple cubic cell in rock-salt order: large particles of
    /// radius R = radius_mm [mm] and small ones of R/r, r = size_ratio in
    /// [1, 1 + sqrt 2] (beyond it the large particles overlap), alternating over the eight corners of a box of edge R + R/r
    /// (z scaled by aspect_ratio); rho0 = (2 pi/3)(1 + r^3)/(1 + r)^3
    /// (0.60002 at the paper's r = 1.566).
    #[staticmethod]
    #[pyo3(signature = (radius_mm = 0.05, size_ratio = 1.566, aspect_ratio = 1.0))]
    fn sc2(radius_mm: f64, size_ratio: f64, aspect_ratio: f64) -> PyResult<Self> {
        Self::preset(Cell::sc2(radius_mm, size_ratio, aspect_ratio))
    }

    /// Whole particles in a box [0,Lx)x[0,Ly)x[0,Lz) periodic along x, y
    /// and z: lengths_mm = (Lx, Ly, Lz) [mm], z the pressing direction (the
    /// cell's height shortens, its width and depth stay: the die's uniaxial
    /// strain); each particle is (centre_mm, a_mm, c_mm, axis): its centre
    /// in the box, its semi-axes (a across, c along axis) in [1e-6, 1e3] mm
    /// with c/a in [0.2, 5], and its symmetry axis (any non-zero vector).
    /// Particles may reach across the box faces: they touch the periodic
    /// images of the others there. Meshed whole with hex8 elements.
    /// ValueError names the field (particles[2].centre[0]), or the
    /// particles that overlap one another or an image (by more than 1e-6
    /// of the smaller radius; touching is allowed).
    #[staticmethod]
    fn periodic(
        name: String,
        lengths_mm: (f64, f64, f64),
        particles: Vec<ParticleTuple>,
    ) -> PyResult<Self> {
        let lengths = [lengths_mm.0, lengths_mm.1, lengths_mm.2];
        let (lo, hi) = RADIUS_RANGE;
        for (i, &l) in lengths.iter().enumerate() {
            if !(lo..=hi).contains(&l) {
                return Err(parameter_error(
                    &format!("lengths_mm[{i}]"),
                    Number(l),
                    &format!("in [{lo:e}, {hi:e}] mm"),
                ));
            }
        }
        let particles = placed(lengths, &particles)?;
        check_apart(lengths, &particles)?;
        Ok(Self {
            inner: CellKind::Periodic {
                name,
                lengths,
                particles,
            },
        })
    }

    /// Short name of the packing, e.g. "sc".
    #[getter]
    fn name(&self) -> &str {
        self.inner.name()
    }

    /// Box edge lengths (Lx, Ly, Lz) [mm].
    #[getter]
    fn lengths_mm(&self) -> (f64, f64, f64) {
        let [x, y, z] = self.inner.lengths();
        (x, y, z)
    }

    /// Initial relative density from the exact particle volumes [-].
    #[getter]
    fn rho0(&self) -> f64 {
        self.inner.rho0()
    }

    /// True for a periodic cell of whole particles (Cell.periodic), False
    /// for a box of mirror planes with octants at its corners.
    #[getter]
    fn is_periodic(&self) -> bool {
        matches!(self.inner, CellKind::Periodic { .. })
    }

    /// The particle pieces as ((high_x, high_y, high_z), a_mm, c_mm): the box
    /// corner at the octant's centre (True = the high end L_i of that axis),
    /// and the spheroid semi-axes along x, y (a) and z (c) [mm]. Empty for a
    /// periodic cell (see particles).
    #[getter]
    fn octants(&self) -> Vec<OctantTuple> {
        match &self.inner {
            CellKind::Octants(c) => c
                .octants
                .iter()
                .map(|o| {
                    let [x, y, z] = o.corner;
                    ((x, y, z), o.a, o.c)
                })
                .collect(),
            CellKind::Periodic { .. } => Vec::new(),
        }
    }

    /// The whole particles of a periodic cell as (centre_mm, a_mm, c_mm,
    /// axis), the axis normalised; empty for a cell of octants.
    #[getter]
    fn particles(&self) -> Vec<ParticleTuple> {
        match &self.inner {
            CellKind::Octants(_) => Vec::new(),
            CellKind::Periodic { particles, .. } => particles
                .iter()
                .map(|p| {
                    let norm = p.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
                    let [x, y, z] = p.centre;
                    let [ax, ay, az] = p.axis.map(|v| v / norm);
                    ((x, y, z), p.a, p.c, (ax, ay, az))
                })
                .collect(),
        }
    }

    fn __repr__(&self) -> String {
        let [x, y, z] = self.inner.lengths();
        let pieces = match &self.inner {
            CellKind::Octants(c) => format!("octants={}", c.octants.len()),
            CellKind::Periodic { particles, .. } => {
                format!("periodic, particles={}", particles.len())
            }
        };
        format!(
            "Cell(name='{}', lengths_mm=({x:?}, {y:?}, {z:?}), {pieces}, rho0={:?})",
            self.inner.name(),
            self.inner.rho0()
        )
    }
}

#[cfg(test)]
mod tests {
    use tidens_solver::DEFAULT_SIZE_RATIO;

    /// The default of `Cell.sc2(size_ratio=...)` is written as a literal (so
    /// that it shows in the signature); it must stay the core's.
    #[test]
    fn sc2_default_size_ratio_is_the_core_default() {
        assert_eq!(1.566, DEFAULT_SIZE_RATIO);
    }
}
