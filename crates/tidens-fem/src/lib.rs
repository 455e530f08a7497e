//! Finite elements and assembly for tidens (units: mm, N, MPa, s).
//!
//! - [`Body`] (the entry type): a meshed deformable body made of mean-dilatation
//!   Q1/P0 hexahedra (Simo, Taylor and Pister 1985) of one [`Material`]. It
//!   evaluates element residuals and consistent tangents in parallel and keeps
//!   the material state of the last converged step.
//! - [`mean_dilatation::evaluate`]: the element kernel, generic over the
//!   [`ReferenceElement`]: [`Hex8`] (Q1/P0) and [`Tet10`] (the quadratic
//!   tetrahedron with one pressure, P2/P0; [`Tet10Degree3`] is the same
//!   element on a 10-point rule), with reference data
//!   [`MeanDilatationGeometry`] ([`ElementGeometry`] / [`Tet10Geometry`]).
//! - [`SparseSystem`]: a fixed sparsity pattern (compressed columns, both
//!   triangles) and the serial, deterministic scatter of element matrices into
//!   it through a dof-to-equation map. The assembler knows nothing of the
//!   physics; the element knows nothing of the global system.
//!
//! [`Material`]: tidens_material::Material

mod assembly;
mod body;
mod error;
pub mod mean_dilatation;
mod reference;
mod sparse;

pub use assembly::ElementAssembler;
pub use body::{Body, BodyEvaluation, ElementFields, ElementKind};
pub use error::FemError;
pub use mean_dilatation::{
    ElementGeometry, ElementOutput, ElementSummary, Hex8Geometry, Hex8Output,
    MeanDilatationGeometry, MeanDilatationOutput, Tet10Degree3Geometry, Tet10Degree3Output,
    Tet10Geometry, Tet10Output,
};
pub use reference::{Hex8, ReferenceElement, Tet10, Tet10Degree3};
pub use sparse::{DOF_DROPPED, SparseSystem};
