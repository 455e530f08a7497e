use thiserror::Error;

/// Everything that can go wrong in setting up or running a simulation.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum SolverError {
    /// A setting outside its allowed range.
    #[error("{name} = {value}: must be {allowed}")]
    Parameter {
        name: &'static str,
        value: f64,
        allowed: String,
    },
    /// A cell whose particles cannot carry the piston's load to the bottom.
    #[error("cell '{cell}': {reason}")]
    NoLoadPath { cell: String, reason: String },
    /// A scene that this version cannot build.
    #[error("unsupported scene: {0}")]
    Unsupported(String),
    #[error(transparent)]
    Mesh(#[from] tidens_mesh::MeshError),
    #[error(transparent)]
    Material(#[from] tidens_material::MaterialError),
    #[error(transparent)]
    Fem(#[from] tidens_fem::FemError),
    /// The sparse factorisation failed (singular system).
    #[error("linear solve failed: {0}")]
    Linear(String),
    /// Newton failed even at the smallest allowed time step.
    #[error(
        "no convergence at t = {time:.6e} s (step {step}): time step cut to {dt:.3e} s without Newton converging ({reason})"
    )]
    NoConvergence {
        time: f64,
        step: usize,
        dt: f64,
        reason: String,
    },
    /// The step limit was reached before the stop condition.
    #[error("step limit {max_steps} reached at t = {time:.6e} s, density {density:.5}")]
    StepLimit {
        max_steps: usize,
        time: f64,
        density: f64,
    },
}

impl SolverError {
    pub(crate) fn parameter(name: &'static str, value: f64, allowed: impl Into<String>) -> Self {
        SolverError::Parameter {
            name,
            value,
            allowed: allowed.into(),
        }
    }
}
