//! `estimate_size`: the nodes, unknowns and peak memory of a run, known
//! before it is set up (see `tidens_solver::SizeEstimate`).

use crate::cell::{CellKind, PyCell};
use crate::errors::{Phase, solver_error};
use crate::simulation::{ELEMENTS, mesh_level_argument, named};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tidens_solver::{ElementKind, MeshOptions, SizeEstimate};

/// The size of a run of `cell` at `mesh_level` (None: the default) in
/// elements `element` ("hex8", the default, or "tet10"), before it is set
/// up: a dict of nodes (periodic images included), elements,
/// degrees_of_freedom (the unknowns at the start, as
/// Simulation.degrees_of_freedom reports them) and peak_memory_bytes (the
/// process's estimated peak: about 13 kB per unknown for hex8 and 16 kB
/// for tet10 above 40 MB, measured on runs of 9000 to 72000 unknowns; a
/// lower bound for far larger runs, whose sparse factor grows faster).
///
/// A cell of octants is meshed (as long as setting the run up takes before
/// its first step); a periodic cell is not: one particle of each layout
/// is, so that 10000 particles take milliseconds. ValueError for a
/// mesh_level out of range, or tet10 for a periodic cell.
#[pyfunction]
#[pyo3(signature = (cell, mesh_level = None, element = None))]
pub fn estimate_size<'py>(
    py: Python<'py>,
    cell: &Bound<'py, PyCell>,
    #[pyo3(from_py_with = mesh_level_argument)] mesh_level: Option<u32>,
    element: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let kind = named("element", element.unwrap_or(ELEMENTS[0].0), &ELEMENTS)?;
    let defaults = MeshOptions::default();
    let options = MeshOptions {
        level: mesh_level.unwrap_or(defaults.level),
        ..defaults
    };
    let cell = cell.get().inner.clone();
    let estimate = match &cell {
        CellKind::Periodic { .. } if kind != ElementKind::Hex8 => {
            return Err(PyValueError::new_err(
                "element = tet10: a periodic cell is meshed with hex8 elements only",
            ));
        }
        CellKind::Octants(c) => py.detach(|| SizeEstimate::of_cell(c, &options, kind)),
        CellKind::Periodic {
            lengths, particles, ..
        } => py.detach(|| SizeEstimate::of_periodic(*lengths, particles, &options)),
    }
    .map_err(|e| solver_error(e, Phase::Setup))?;
    let d = PyDict::new(py);
    d.set_item("nodes", estimate.nodes)?;
    d.set_item("elements", estimate.elements)?;
    d.set_item("degrees_of_freedom", estimate.degrees_of_freedom)?;
    d.set_item("peak_memory_bytes", estimate.peak_memory_bytes)?;
    Ok(d)
}
