//! The tidens solver driver (units: mm, N, MPa, s).
//!
//! [`Simulation`] (the entry type) presses a [`Scene`] (a meshed [`Cell`] or a
//! verification block) in a rigid die: frictionless rigid planes handled
//! analytically ([`constraints`]), the piston displacement as one extra
//! unknown loaded by `f sigma(t) Lx Ly` ([`LoadHistory`]), implicit
//! backward-Euler steps solved by Newton with line search and faer sparse
//! Cholesky ([`linear`]), and an adaptive step size with a per-step estimate
//! of the time-discretisation error ([`Settings::tolerance`]).

mod cell;
pub mod constraints;
mod error;
pub mod linear;
mod load;
mod scene;
mod settings;
mod simulation;

pub use cell::{ASPECT_RANGE, Cell, DEFAULT_SIZE_RATIO, Octant, RADIUS_RANGE, SIZE_RATIO_RANGE};
pub use error::SolverError;
pub use load::LoadHistory;
pub use scene::{MAX_MESH_LEVEL, MeshOptions, Particle, Scene};
pub use settings::{ContactOptions, NewtonSettings, Settings};
pub use simulation::{CurvePoint, Fields, RunStats, Simulation, Status};
pub use tidens_contact::ContactMode;
pub use tidens_fem::ElementKind;
pub use tidens_material::{Material, Preset};
