//! Core results to plain Python values: dicts of numbers and numpy arrays.
//! The key names carry the units (mm, MPa, s).

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tidens_solver::{CurvePoint, Fields, RunStats, Status};

/// A number of a result: a count stays an `int` in a point dict.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Value {
    Float(f64),
    Count(usize),
}

impl Value {
    fn as_f64(self) -> f64 {
        match self {
            Value::Float(x) => x,
            Value::Count(n) => n as f64,
        }
    }
}

/// Number of entries of a curve point.
const POINT_LEN: usize = 17;

/// The entries of a curve point, in one place for `advance()` and `curve()`.
fn point_entries(p: &CurvePoint) -> [(&'static str, Value); POINT_LEN] {
    use Value::{Count, Float};
    [
        ("time_s", Float(p.time)),
        ("rel_density", Float(p.rel_density)),
        ("piston_displacement_mm", Float(p.piston_displacement)),
        ("applied_stress_mpa", Float(p.applied_stress)),
        ("cell_stress_mpa", Float(p.cell_stress)),
        ("step", Count(p.step)),
        ("newton_iterations", Count(p.newton_iterations)),
        ("newton_total", Count(p.newton_total)),
        ("dt_s", Float(p.dt)),
        ("max_strain_increment", Float(p.max_strain_increment)),
        ("particle_volume_mm3", Float(p.particle_volume)),
        ("time_error_s", Float(p.time_error)),
        ("contacts", Count(p.contacts)),
        ("particle_contacts", Count(p.particle_contacts)),
        ("max_penetration_mm", Float(p.max_penetration)),
        ("max_depth_mm", Float(p.max_depth)),
        // NaN for cells of octants (None).
        (
            "coordination_number",
            Float(p.coordination_number.unwrap_or(f64::NAN)),
        ),
    ]
}

/// The Python name of a run status.
pub(crate) fn status_name(status: Status) -> &'static str {
    match status {
        Status::Running => "running",
        Status::ReachedDensity => "reached_density",
        Status::ReachedTime => "reached_time",
        Status::FullDensity => "full_density",
    }
}

/// One curve point as a dict (counts as int, the rest as float).
pub(crate) fn point_dict<'py>(py: Python<'py>, p: &CurvePoint) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (key, value) in point_entries(p) {
        match value {
            Value::Float(x) => dict.set_item(key, x)?,
            Value::Count(n) => dict.set_item(key, n)?,
        }
    }
    Ok(dict)
}

/// The curve as columns: one float64 vector per key of the point dict.
pub(crate) fn curve_columns(curve: &[CurvePoint]) -> Vec<(&'static str, Vec<f64>)> {
    let mut columns: Vec<(&'static str, Vec<f64>)> = match curve.first() {
        Some(p) => point_entries(p)
            .iter()
            .map(|&(key, _)| (key, Vec::with_capacity(curve.len())))
            .collect(),
        None => Vec::new(),
    };
    for p in curve {
        for (column, (_, value)) in columns.iter_mut().zip(point_entries(p)) {
            column.1.push(value.as_f64());
        }
    }
    columns
}

/// Columns as a dict of 1-D float64 arrays.
pub(crate) fn columns_dict<'py>(
    py: Python<'py>,
    columns: Vec<(&'static str, Vec<f64>)>,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (key, column) in columns {
        dict.set_item(key, PyArray1::from_vec(py, column))?;
    }
    Ok(dict)
}

/// Rows of `N` numbers as an (rows, N) array.
fn rows_array<'py, T: numpy::Element, const N: usize>(
    py: Python<'py>,
    rows: Vec<[T; N]>,
) -> PyResult<Bound<'py, PyAny>> {
    let n = rows.len();
    let flat: Vec<T> = rows.into_iter().flatten().collect();
    Ok(PyArray1::from_vec(py, flat).reshape([n, N])?.into_any())
}

/// The fields of the last converged state as a dict of numpy arrays.
/// `particle` is the particle index of each element.
pub(crate) fn fields_dict<'py>(
    py: Python<'py>,
    fields: Fields,
    particle: Vec<i64>,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("points", rows_array(py, fields.points)?)?;
    dict.set_item("displacement", rows_array(py, fields.displacement)?)?;
    dict.set_item("contact_force", rows_array(py, fields.contact_force)?)?;
    dict.set_item(
        "contact_pressure",
        PyArray1::from_vec(py, fields.contact_pressure),
    )?;
    // Node indices never come near i64::MAX: the cast cannot wrap.
    let per_cell = fields.connectivity.first().map_or(8, |c| c.len());
    let flat: Vec<i64> = fields
        .connectivity
        .iter()
        .flatten()
        .map(|&n| n as i64)
        .collect();
    let count = fields.connectivity.len();
    dict.set_item(
        "cells",
        PyArray1::from_vec(py, flat).reshape([count, per_cell])?,
    )?;
    dict.set_item("cell_type", fields.cell_type)?;
    dict.set_item("particle", PyArray1::from_vec(py, particle))?;
    let element = fields.element;
    dict.set_item("von_mises", PyArray1::from_vec(py, element.von_mises))?;
    dict.set_item("mean_stress", PyArray1::from_vec(py, element.mean_stress))?;
    dict.set_item("eqps", PyArray1::from_vec(py, element.eqps))?;
    Ok(dict)
}

/// Run totals as a dict (counts as int, wall times [s] as float).
pub(crate) fn stats_dict<'py>(py: Python<'py>, s: &RunStats) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("steps", s.steps)?;
    dict.set_item("newton_iterations", s.newton_iterations)?;
    dict.set_item("rejected_steps", s.rejected_steps)?;
    dict.set_item("failed_attempts", s.failed_attempts)?;
    dict.set_item("llt_factorizations", s.factorizations.llt)?;
    dict.set_item("lblt_factorizations", s.factorizations.lblt)?;
    dict.set_item("single_precision_factorizations", s.factorizations.single)?;
    dict.set_item("pattern_rebuilds", s.pattern_rebuilds)?;
    dict.set_item("evaluation_seconds", s.evaluation_seconds)?;
    dict.set_item("contact_seconds", s.contact_seconds)?;
    dict.set_item("evaluations", s.evaluations)?;
    dict.set_item("tangent_evaluations", s.tangent_evaluations)?;
    dict.set_item("assembly_seconds", s.assembly_seconds)?;
    dict.set_item("linear_seconds", s.linear_seconds)?;
    dict.set_item("max_drag_share", s.max_drag_share)?;
    dict.set_item("wall_seconds", s.wall_seconds)?;
    Ok(dict)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(step: usize) -> CurvePoint {
        CurvePoint {
            time: step as f64,
            rel_density: 0.5,
            piston_displacement: -0.1,
            applied_stress: 10.0,
            cell_stress: 6.0,
            step,
            newton_iterations: 3,
            newton_total: 3 * step,
            dt: 1.0,
            max_strain_increment: 0.01,
            particle_volume: 1e-4,
            time_error: 0.0,
            contacts: 7,
            particle_contacts: 0,
            max_penetration: 0.0,
            max_depth: 0.0,
            coordination_number: None,
        }
    }

    #[test]
    fn curve_columns_have_one_entry_per_point_under_unique_keys() {
        let columns = curve_columns(&[point(0), point(1), point(2)]);
        assert_eq!(columns.len(), POINT_LEN);
        let mut keys: Vec<_> = columns.iter().map(|c| c.0).collect();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), POINT_LEN);
        let step = columns.iter().find(|c| c.0 == "step").map(|c| c.1.clone());
        assert_eq!(step, Some(vec![0.0, 1.0, 2.0]));
    }
}
