//! The Python exceptions of tidens and the mapping of the core errors onto them.
//!
//! Bad input (a parameter out of range, an unknown preset, a mesh that cannot
//! be built) raises `ValueError` naming the Python argument and its allowed
//! range. Everything that goes wrong while stepping raises
//! `ConvergenceError`; the simulation then keeps its last converged state.

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use tidens_material::MaterialError;
use tidens_mesh::MeshError;
use tidens_solver::MAX_MESH_LEVEL;
use tidens_solver::SolverError;

create_exception!(
    tidens_rs._core,
    TidensError,
    PyException,
    "Base class of the errors raised by the solver."
);
create_exception!(
    tidens_rs._core,
    ConvergenceError,
    TidensError,
    "Newton failed at the smallest allowed time step, the step limit was\n\
     reached, or a linear solve failed. The simulation keeps its last\n\
     converged state, so its curve up to the failure is still available.\n\
     Attributes: time_s and step (where it happened), dt_s (the last step\n\
     size tried), reason (element, linear_algebra, non_finite_residual,\n\
     plane_penetration, contact_penetration, newton_iterations, line_search,\n\
     step_limit, material), result (the partial result, from Case.run)."
);
create_exception!(
    tidens_rs._core,
    CheckpointError,
    PyValueError,
    "A checkpoint that cannot be resumed: empty, truncated, not a\n\
     checkpoint, of another format, damaged (a hash does not match), or\n\
     taken with another case. A ValueError; tidens_rs.resume puts the\n\
     checkpoint file's path in front of the message."
);
create_exception!(
    tidens_rs._core,
    UnsupportedError,
    TidensError,
    "A scene this version cannot simulate."
);

/// When an error happened: an element or material failure while setting up
/// means bad input, while stepping it means the step could not be solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Phase {
    Setup,
    Run,
}

/// The Python argument that sets a core parameter, so that the message names
/// what the user typed, and for the material constants also the symbol of the
/// formulas (E, nu, C, n). Names without an entry are already the same.
fn python_name(core_name: &str) -> (&str, Option<&str>) {
    let python = match core_name {
        "stress" => "stress_mpa",
        "ramp_time" => "ramp_time_s",
        "until_time" => "until_time_s",
        "dt_initial" => "dt_initial_s",
        "dt_max" => "dt_max_s",
        "time_targets" => "time_targets_s",
        "newton.max_iterations" => "newton_max_iterations",
        "newton.residual_tolerance" => "newton_residual_tolerance",
        "radius" => "radius_mm",
        "lengths[0]" => "lengths_mm[0]",
        "lengths[1]" => "lengths_mm[1]",
        "lengths[2]" => "lengths_mm[2]",
        "contact.penalty_factor" => "contact_penalty_factor",
        "contact.penetration_tolerance" => "penetration_tolerance",
        "E" => return ("young_mpa", Some(core_name)),
        "nu" => return ("poisson", Some(core_name)),
        "C" => return ("creep_c", Some(core_name)),
        "n" => return ("creep_n", Some(core_name)),
        other => other,
    };
    (python, None)
}

/// `ValueError("<argument> = <value>: must be <allowed>")`, the core's own
/// message with the Python argument name, e.g. `poisson (nu) = 0.6: must be
/// in [-0.99, 0.4999]`.
pub(crate) fn parameter_error(
    core_name: &str,
    value: impl std::fmt::Display,
    allowed: &str,
) -> PyErr {
    let message = match python_name(core_name) {
        (name, Some(symbol)) => format!("{name} ({symbol}) = {value}: must be {allowed}"),
        (name, None) => format!("{name} = {value}: must be {allowed}"),
    };
    PyValueError::new_err(message)
}

/// A real number as Python's `repr` writes it: the shortest digits that
/// read back to it, in exponent form below 1e-4 and from 1e16 on (plain
/// `{}` would write C = 3e-54 with 53 zeros).
pub(crate) struct Number(pub f64);

impl std::fmt::Display for Number {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        let a = v.abs();
        if v.is_finite() && a != 0.0 && !(1e-4..1e16).contains(&a) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// `ValueError` for an out-of-range mesh level.
pub(crate) fn mesh_level_error(level: impl std::fmt::Display) -> PyErr {
    parameter_error(
        "mesh_level",
        level,
        &format!("an integer in [1, {MAX_MESH_LEVEL}]"),
    )
}

/// Maps a material error: bad parameters and unknown presets are bad input;
/// an inverted material point while stepping is a failed step.
pub(crate) fn material_error(err: MaterialError, phase: Phase) -> PyErr {
    match err {
        MaterialError::Parameter {
            name,
            value,
            allowed,
        } => parameter_error(name, Number(value), allowed),
        MaterialError::UnknownPreset(..) => PyValueError::new_err(err.to_string()),
        MaterialError::Inverted { .. } => match phase {
            Phase::Setup => PyValueError::new_err(err.to_string()),
            Phase::Run => ConvergenceError::new_err(err.to_string()),
        },
    }
}

/// Maps a solver error onto the Python exception for it.
pub(crate) fn solver_error(err: SolverError, phase: Phase) -> PyErr {
    match err {
        SolverError::Parameter {
            name,
            value,
            ref allowed,
        } => parameter_error(name, Number(value), allowed),
        SolverError::Material(e) => material_error(e, phase),
        SolverError::Mesh(MeshError::Level(level)) => mesh_level_error(level),
        SolverError::Mesh(e) => PyValueError::new_err(e.to_string()),
        SolverError::NoLoadPath { .. }
        | SolverError::SameCorner { .. }
        | SolverError::Overlap { .. } => PyValueError::new_err(err.to_string()),
        // The checkpoint's own words: the caller puts the file in front.
        SolverError::Checkpoint(e @ tidens_solver::CheckpointError::Unwritable { .. }) => {
            TidensError::new_err(format!("checkpoint: {e}"))
        }
        SolverError::Checkpoint(e) => CheckpointError::new_err(e.to_string()),
        SolverError::Unsupported(_) => UnsupportedError::new_err(err.to_string()),
        SolverError::Fem(_) => match phase {
            Phase::Setup => PyValueError::new_err(err.to_string()),
            Phase::Run => ConvergenceError::new_err(err.to_string()),
        },
        SolverError::Linear(_)
        | SolverError::NoConvergence { .. }
        | SolverError::StepLimit { .. } => ConvergenceError::new_err(err.to_string()),
        SolverError::Internal(_) => TidensError::new_err(err.to_string()),
        // Only a signal handler's exception interrupts a step (see
        // `StepError::Signal`); this is the fallback.
        SolverError::Interrupted { .. } => PyKeyboardInterrupt::new_err(err.to_string()),
    }
}

/// The attributes of a ConvergenceError, None on the class: when it
/// happened (`time_s`, `step`), the last step size tried (`dt_s`), the kind
/// of failure (`reason`), and the partial result (`result`, set by the
/// Python layer).
pub(crate) const CONVERGENCE_ATTRIBUTES: [&str; 5] = ["time_s", "step", "dt_s", "reason", "result"];

/// A failed step of a running simulation, converted once the GIL is held
/// (the attributes of the exception need it).
pub(crate) enum StepError {
    Solver(SolverError),
    /// What a Python signal handler raised in the middle of the step (Ctrl-C:
    /// KeyboardInterrupt); the step was abandoned.
    Signal(PyErr),
    Poisoned,
}

impl StepError {
    pub(crate) fn into_py(self, py: Python<'_>) -> PyErr {
        let err = match self {
            StepError::Poisoned => return poisoned(),
            StepError::Signal(e) => return e,
            StepError::Solver(err) => err,
        };
        let (time, step, dt, reason): (Option<f64>, Option<usize>, Option<f64>, &str) = match &err {
            SolverError::NoConvergence {
                time,
                step,
                dt,
                reason,
            } => (Some(*time), Some(*step), Some(*dt), reason.kind()),
            SolverError::StepLimit {
                max_steps, time, ..
            } => (Some(*time), Some(*max_steps), None, "step_limit"),
            SolverError::Linear(_) => (None, None, None, "linear_algebra"),
            SolverError::Fem(_) => (None, None, None, "element"),
            SolverError::Material(_) => (None, None, None, "material"),
            _ => return solver_error(err, Phase::Run),
        };
        let py_err = solver_error(err, Phase::Run);
        let value = py_err.value(py);
        let set = || -> PyResult<()> {
            value.setattr("time_s", time)?;
            value.setattr("step", step)?;
            value.setattr("dt_s", dt)?;
            value.setattr("reason", reason)
        };
        match set() {
            Ok(()) => py_err,
            Err(e) => e,
        }
    }
}

/// The simulation's state was left half-updated by a panic in an earlier call.
pub(crate) fn poisoned() -> PyErr {
    TidensError::new_err(
        "this simulation is unusable: an earlier call panicked in the middle of a step",
    )
}
