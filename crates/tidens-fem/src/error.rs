use thiserror::Error;

/// Errors of element evaluation and assembly.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum FemError {
    /// An element of the reference mesh has a non-positive Jacobian.
    #[error(
        "element {element}: reference Jacobian determinant {det:e} <= 0 (inverted or degenerate mesh element)"
    )]
    InvertedReference { element: usize, det: f64 },
    /// An element turned inside out during the deformation.
    #[error(
        "element {element}: det F = {det_f:e} <= 0 at a Gauss point (element inverted; the step is too large)"
    )]
    Inverted { element: usize, det_f: f64 },
    /// Mesh arrays that do not fit together.
    #[error("invalid mesh: {0}")]
    Mesh(String),
}
