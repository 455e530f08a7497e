//! Parameter validation errors of the mesh generators.

/// Largest inner-cube division count accepted by [`crate::HexMesh::spheroid_octant`]:
/// beyond it the mesh has more than ~10^8 elements, which no caller can hold in memory.
pub const MAX_OCTANT_DIVISIONS: usize = 256;

/// Largest division count per axis accepted by [`crate::HexMesh::block`].
pub const MAX_BLOCK_DIVISIONS: usize = 1024;

/// Largest mesh level accepted by [`crate::divisions_for_level`].
pub const MAX_LEVEL: u32 = 8;

/// Largest deviation from a proper rotation accepted by
/// [`crate::HexMesh::placed`]: of each entry of R^T R from the identity's,
/// and of det R from 1. Any rotation computed in f64 passes; a matrix
/// rounded to f32 does not.
pub const ROTATION_TOLERANCE: f64 = 1e-10;

/// A mesh parameter outside its allowed range. The message names the parameter,
/// its value (with unit where it has one) and the allowed range.
#[derive(thiserror::Error, Debug, Clone, PartialEq)]
pub enum MeshError {
    /// Spheroid semi-axis along x and y.
    #[error("a = {0} mm: must be finite and > 0")]
    SemiAxisA(f64),
    /// Spheroid semi-axis along z.
    #[error("c = {0} mm: must be finite and > 0")]
    SemiAxisC(f64),
    /// Inner-cube division count of the octant mesh.
    #[error("divisions = {0}: must be in 2..={MAX_OCTANT_DIVISIONS}")]
    OctantDivisions(usize),
    /// Grading ratio of the octant mesh.
    #[error("grading = {0}: must be finite and >= 1")]
    Grading(f64),
    /// Edge length of a block along one axis.
    #[error("lengths[{axis}] = {value} mm: must be finite and > 0")]
    BlockLength {
        /// Axis index 0, 1 or 2 (x, y, z).
        axis: usize,
        /// The rejected length \[mm\].
        value: f64,
    },
    /// Division count of a block along one axis.
    #[error("divisions[{axis}] = {value}: must be an integer in [1, {MAX_BLOCK_DIVISIONS}]")]
    BlockDivisions {
        /// Axis index 0, 1 or 2 (x, y, z).
        axis: usize,
        /// The rejected division count.
        value: usize,
    },
    /// Inner-cube half-size of an explicit [`crate::OctantShape`].
    #[error("h = {0}: must be in (0, 1) (unit sphere)")]
    ShapeHalfSize(f64),
    /// Inflation of an explicit [`crate::OctantShape`].
    #[error("inflation = {0}: must be in [0, 1)")]
    ShapeInflation(f64),
    /// Inner-block z stretch of an explicit [`crate::OctantShape`].
    #[error("z_stretch = {value}: must be > 0 with h * z_stretch < 1 (h = {h})")]
    ShapeZStretch {
        /// The rejected stretch.
        value: f64,
        /// The shape's half-size h.
        h: f64,
    },
    /// An element or boundary face of a mesh handed to a converter refers to
    /// a node that does not exist.
    #[error("element {element} refers to node {node}, but the mesh has {node_count} nodes")]
    NodeIndex {
        /// The element (or the element named by the boundary face).
        element: usize,
        /// The out-of-range node index.
        node: usize,
        /// Number of nodes of the mesh.
        node_count: usize,
    },
    /// A boundary face of a mesh handed to a converter is not a face of the
    /// element it names.
    #[error("boundary face {face} is not a face of element {element}")]
    BoundaryFace {
        /// Index of the boundary face.
        face: usize,
        /// The element it names.
        element: usize,
    },
    /// Mesh refinement level.
    #[error("level = {0}: must be an integer in [1, {MAX_LEVEL}]")]
    Level(u32),
    /// The outward surface offset that gives an octant mesh its exact volume
    /// was not found: the volume could not be brought within the tolerance.
    /// It happens on the coarsest graded layouts (2 divisions, grading > 1),
    /// where the offsets are held back next to the contact points.
    #[error(
        "exact-volume octant mesh: volume {volume} mm^3, target {target} mm^3 \
         (relative tolerance {tolerance})"
    )]
    VolumeFit {
        /// Volume of the closest mesh found \[mm^3\].
        volume: f64,
        /// Exact volume pi a^2 c / 6 of the octant \[mm^3\].
        target: f64,
        /// Largest relative volume error accepted.
        tolerance: f64,
    },
    /// The rotation of a rigid placement ([`crate::HexMesh::placed`]) is not
    /// a proper rotation: not orthonormal (a scaling, a shear, a non-finite
    /// entry) or a reflection (det -1).
    #[error(
        "rotation = {rotation:?}: must be orthonormal with det +1 \
         (largest |R^T R - I| entry {orthogonality}, det {det}; tolerance {ROTATION_TOLERANCE})"
    )]
    Rotation {
        /// The rejected matrix, `rotation[row][col]`.
        rotation: [[f64; 3]; 3],
        /// Largest entry of |R^T R - I| (NaN for non-finite entries).
        orthogonality: f64,
        /// Determinant of the matrix.
        det: f64,
    },
    /// The centre of a rigid placement ([`crate::HexMesh::placed`]).
    #[error("centre = {0:?} mm: every coordinate must be finite")]
    Centre([f64; 3]),
}

/// True when `v` is a usable length: finite and strictly positive.
pub(crate) fn is_positive_length(v: f64) -> bool {
    v.is_finite() && v > 0.0
}
