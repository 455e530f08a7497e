//! The tidens solver driver (units: mm, N, MPa, s).
//!
//! [`Simulation`] (the entry type) presses a [`Scene`] (a meshed [`Cell`], a
//! verification block, or a periodic cell of whole particles, see
//! `periodic`) in a rigid die: frictionless rigid planes handled
//! analytically ([`constraints`]), the piston displacement as one extra
//! unknown loaded by `f sigma(t) Lx Ly` ([`LoadHistory`]), implicit
//! backward-Euler steps solved by Newton with line search (`newton`,
//! `line_search`) on a system gathered in parallel (`assembler`) and
//! factorised by faer's sparse Cholesky ([`linear`]), and an adaptive step
//! size with a per-step estimate of the time-discretisation error
//! (`step_control`, [`Settings::tolerance`]). The curve, fields and totals
//! a run reports are in `output`.

mod assembler;
mod cell;
mod checkpoint;
pub mod constraints;
mod error;
mod evaluation;
mod line_search;
pub mod linear;
mod load;
mod load_path;
mod newton;
mod ordering;
mod output;
mod periodic;
mod scene;
mod settings;
mod simulation;
mod size_estimate;
mod step_control;
#[cfg(test)]
mod test_support;

pub use cell::{ASPECT_RANGE, Cell, DEFAULT_SIZE_RATIO, Octant, RADIUS_RANGE, SIZE_RATIO_RANGE};
pub use checkpoint::Checkpoint;
pub use error::{CheckpointError, LinearError, SolverError, StepFailure};
pub use load::LoadHistory;
pub use load_path::TOUCH_TOLERANCE;
pub use output::{CurvePoint, FULL_DENSITY, Fields, RunStats, Status};
pub use periodic::{ParticleImage, Periodic, PlacedSpheroid};
pub use scene::{MAX_MESH_LEVEL, MeshOptions, Particle, Scene};
pub use settings::{
    ContactFormulation, ContactOptions, HexFacets, MAX_NEWTON_ITERATIONS, NewtonSettings, Settings,
};
pub use simulation::Simulation;
pub use size_estimate::{BASE_BYTES, HEX8_BYTES_PER_DOF, SizeEstimate, TET10_BYTES_PER_DOF};
pub use tidens_contact::ContactMode;
pub use tidens_fem::ElementKind;
pub use tidens_material::{Material, Preset};

/// Threads the solver's parallel parts (assembly, large Cholesky
/// factorisations) run on: the current rayon pool's, by default the global
/// one (`RAYON_NUM_THREADS`, else the machine's cores). The results do not
/// depend on it; the wall time does.
pub fn solver_threads() -> usize {
    rayon::current_num_threads()
}
