//! `Cell`: the unit cell of a particle packing that a simulation presses.

use crate::errors::{Number, Phase, parameter_error, solver_error};
use pyo3::prelude::*;
use tidens_solver::{Cell, Octant, SolverError};

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
/// e.g. octants[1].a). Overlapping particles are found when the cell is
/// meshed: Simulation raises UnsupportedError. Presets: Cell.sc, Cell.bcc,
/// Cell.fcc, Cell.sc2.
#[pyclass(name = "Cell", module = "tidens_rs._core", frozen)]
#[derive(Clone, Debug)]
pub struct PyCell {
    pub(crate) inner: Cell,
}

impl PyCell {
    fn preset(cell: Result<Cell, SolverError>) -> PyResult<Self> {
        let inner = cell.map_err(|e| solver_error(e, Phase::Setup))?;
        Ok(Self { inner })
    }
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
            Ok(inner) => Ok(Self { inner }),
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

    /// Short name of the packing, e.g. "sc".
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Box edge lengths (Lx, Ly, Lz) [mm].
    #[getter]
    fn lengths_mm(&self) -> (f64, f64, f64) {
        let [x, y, z] = self.inner.lengths;
        (x, y, z)
    }

    /// Initial relative density from the exact particle volumes [-].
    #[getter]
    fn rho0(&self) -> f64 {
        self.inner.rho0()
    }

    /// The particle pieces as ((high_x, high_y, high_z), a_mm, c_mm): the box
    /// corner at the octant's centre (True = the high end L_i of that axis),
    /// and the spheroid semi-axes along x, y (a) and z (c) [mm].
    #[getter]
    fn octants(&self) -> Vec<OctantTuple> {
        self.inner
            .octants
            .iter()
            .map(|o| {
                let [x, y, z] = o.corner;
                ((x, y, z), o.a, o.c)
            })
            .collect()
    }

    fn __repr__(&self) -> String {
        let [x, y, z] = self.inner.lengths;
        format!(
            "Cell(name='{}', lengths_mm=({x:?}, {y:?}, {z:?}), octants={}, rho0={:?})",
            self.inner.name,
            self.inner.octants.len(),
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
