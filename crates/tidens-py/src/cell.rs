//! `Cell`: the unit cell of a particle packing that a simulation presses.

use crate::errors::{Phase, solver_error};
use pyo3::prelude::*;
use tidens_solver::Cell;

/// A box [0,Lx]x[0,Ly]x[0,Lz] of mirror planes with particle octants at its corners.
///
/// Lengths in mm; z is the pressing direction (the piston is the face z = Lz).
/// Build one with Cell.sc(...).
#[pyclass(name = "Cell", module = "tidens_rs._core", frozen)]
#[derive(Clone, Debug)]
pub struct PyCell {
    pub(crate) inner: Cell,
}

#[pymethods]
impl PyCell {
    /// Simple cubic cell: one octant of a spheroid with semi-axes (radius_mm,
    /// radius_mm, aspect_ratio * radius_mm) in a box of the same size, so
    /// rho0 = pi/6. radius_mm > 0 [mm]; aspect_ratio = c/a in [0.2, 5].
    #[staticmethod]
    #[pyo3(signature = (radius_mm = 0.05, aspect_ratio = 1.0))]
    fn sc(radius_mm: f64, aspect_ratio: f64) -> PyResult<Self> {
        let inner = Cell::sc(radius_mm, aspect_ratio).map_err(|e| solver_error(e, Phase::Setup))?;
        Ok(Self { inner })
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
    fn octants(&self) -> Vec<((bool, bool, bool), f64, f64)> {
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
            "Cell(name='{}', lengths_mm=({x:?}, {y:?}, {z:?}), rho0={:?})",
            self.inner.name,
            self.inner.rho0()
        )
    }
}
