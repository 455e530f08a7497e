//! Finite elements and assembly for tidens (units: mm, N, MPa, s).
//!
//! - [`Body`] (the entry type): a meshed deformable body made of mean-dilatation
//!   Q1/P0 hexahedra (Simo, Taylor and Pister 1985) of one [`Material`]. It
//!   evaluates element residuals and consistent tangents in parallel and keeps
//!   the material state of the last converged step.
//! - [`SparseSystem`]: a fixed sparsity pattern (compressed columns, both
//!   triangles) and the serial, deterministic scatter of element matrices into
//!   it through a dof-to-equation map. The assembler knows nothing of the
//!   physics; the element knows nothing of the global system.
//!
//! [`Material`]: tidens_material::Material

mod body;
mod error;
mod mean_dilatation;
mod sparse;

pub use body::{Body, BodyEvaluation, ElementFields};
pub use error::FemError;
pub use mean_dilatation::{ElementGeometry, ElementOutput};
pub use sparse::{DOF_DROPPED, SparseSystem};
