//! Quadratic (10-node) tetrahedral meshes, made by splitting the hexahedral
//! meshes conformingly and adding one node per edge.

use crate::hex_split;
use crate::{FaceKind, HexMesh, MeshError, OctantShape, OctantSpec};

/// A mesh of quadratic tetrahedra, lengths in mm.
///
/// Made from a [`HexMesh`] by a conforming split: every quadrilateral face is
/// cut along the diagonal through its node of smallest global index, and every
/// hexahedron is split into 6 tetrahedra by joining its node of smallest index
/// to the two triangles of each of its three faces that do not contain that
/// node (a "pulling" triangulation; the faces through that node come out cut
/// through it, which is their smallest node too). The cut of a face depends
/// only on its four node indices, so neighbours agree.
///
/// Nodes `0..n` are the corner nodes, in the numbering of the hexahedral mesh
/// the tetrahedra were cut from (`n` its node count); the mid-edge nodes
/// follow. Element `6 e + k` (k in 0..6) is a piece of hexahedron `e`.
#[derive(Clone, Debug, PartialEq)]
pub struct TetMesh {
    /// Node coordinates \[mm\].
    pub nodes: Vec<[f64; 3]>,
    /// 10-node tetrahedra in VTK_QUADRATIC_TETRA order (corners 0-3, then the
    /// mid-edge nodes of edges 0-1, 1-2, 0-2, 0-3, 1-3, 2-3; see
    /// [`crate::tet10`]), right-handed: the right-hand normal of corners 0-1-2
    /// points toward corner 3.
    pub elements: Vec<[usize; 10]>,
    /// Boundary triangles.
    pub boundary: Vec<TetBoundaryFace>,
}

/// One boundary triangle of a [`TetMesh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetBoundaryFace {
    /// 6-node triangle (VTK_QUADRATIC_TRIANGLE order): corners, ordered so that
    /// their right-hand normal points out of the body, then the mid-edge nodes
    /// of edges 0-1, 1-2, 2-0.
    pub nodes: [usize; 6],
    /// The element this face belongs to.
    pub element: usize,
    /// Which part of the boundary the face lies on.
    pub kind: FaceKind,
}

/// The point of the spheroid `(x^2 + y^2)/a^2 + z^2/c^2 = 1` (centred at the
/// origin, semi-axes `a`, `a`, `c` \[mm\]) on the ray from the centre through
/// `p`, i.e. the radial projection in the coordinates scaled by (1/a, 1/a,
/// 1/c). Zero coordinates stay exactly zero, so a point on a symmetry plane
/// stays on it. Returns `p` unchanged for the centre itself.
pub fn project_to_spheroid(p: [f64; 3], a: f64, c: f64) -> [f64; 3] {
    let s = ((p[0] / a).powi(2) + (p[1] / a).powi(2) + (p[2] / c).powi(2)).sqrt();
    if s > 0.0 { p.map(|v| v / s) } else { p }
}

impl TetMesh {
    /// Splits every hexahedron of `hex` into 6 quadratic tetrahedra with
    /// straight edges (mid-edge nodes at the edge midpoints). Each boundary quad
    /// becomes two boundary triangles of the same [`FaceKind`].
    ///
    /// Errors when an element or boundary face refers to a missing node, or a
    /// boundary face is not a face of the element it names.
    pub fn from_hex(hex: &HexMesh) -> Result<TetMesh, MeshError> {
        hex_split::split(hex, None)
    }

    /// Like [`TetMesh::from_hex`], with the mid-edge node of every edge of a
    /// `Curved` boundary triangle moved from the edge midpoint `p` to
    /// `surface(p)`, a point of the true curved surface (for example
    /// [`project_to_spheroid`]). Mid-edge nodes on `Plane` faces stay at the
    /// midpoints, exactly on their plane.
    pub fn from_hex_with_surface(
        hex: &HexMesh,
        surface: impl Fn([f64; 3]) -> [f64; 3],
    ) -> Result<TetMesh, MeshError> {
        hex_split::split(hex, Some(&surface))
    }

    /// Quadratic tetrahedral mesh of the spheroid octant
    /// {x, y, z >= 0, (x^2 + y^2)/a^2 + z^2/c^2 <= 1} \[mm\], cut from
    /// [`HexMesh::spheroid_octant`]`(spec)` (same corner nodes, 6 tetrahedra
    /// per hexahedron). Mid-edge nodes of the curved surface lie on the spheroid
    /// ([`project_to_spheroid`] of the chord midpoint); those on the planes
    /// x = 0, y = 0, z = 0 lie exactly on them.
    pub fn spheroid_octant(spec: &OctantSpec) -> Result<TetMesh, MeshError> {
        spec.validate()?;
        Self::spheroid_octant_with_shape(spec, &OctantShape::for_aspect(spec.c / spec.a))
    }

    /// Like [`TetMesh::spheroid_octant`] with an explicit layout (see
    /// [`HexMesh::spheroid_octant_with_shape`]).
    pub fn spheroid_octant_with_shape(
        spec: &OctantSpec,
        shape: &OctantShape,
    ) -> Result<TetMesh, MeshError> {
        let hex = HexMesh::spheroid_octant_with_shape(spec, shape)?;
        let (a, c) = (spec.a, spec.c);
        Self::from_hex_with_surface(&hex, |p| project_to_spheroid(p, a, c))
    }

    /// Mesh of the box [0, Lx] x [0, Ly] x [0, Lz] \[mm\] cut from
    /// [`HexMesh::block`]`(lengths, divisions)`: `6 * divisions[0] *
    /// divisions[1] * divisions[2]` tetrahedra; all faces `FaceKind::Plane`.
    pub fn block(lengths: [f64; 3], divisions: [usize; 3]) -> Result<TetMesh, MeshError> {
        Self::from_hex(&HexMesh::block(lengths, divisions)?)
    }

    /// Number of nodes (corner and mid-edge).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of elements.
    pub fn element_count(&self) -> usize {
        self.elements.len()
    }
}
