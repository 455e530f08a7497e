//! Meshes for tidens: one octant of a spheroidal powder particle (semi-axes
//! a, a, c; c along z, the loading direction) centred at the origin, the
//! whole particle, and plain boxes for verification tests. Lengths are in mm.
//!
//! - [`HexMesh`]: trilinear hexahedra ("cubed octant", [`hex`]).
//!   [`HexMesh::spheroid_octant_exact_volume`] moves the curved-surface
//!   nodes outward by O(h^2) so that the mesh has the octant's exact volume.
//! - Whole particles, for random packings: [`HexMesh::spheroid_whole`] and
//!   [`HexMesh::spheroid_whole_exact_volume`] glue the eight mirror images of
//!   the octant into one conforming mesh whose boundary is the closed curved
//!   surface; [`HexMesh::placed`] rotates it (its axis c along the rotation's
//!   third column) and moves its centre anywhere.
//! - [`TetMesh`]: quadratic 10-node tetrahedra ([`tet10`]) cut conformingly
//!   from the hexahedra, with mid-edge nodes on the true curved surface.
//!
//! ```
//! use tidens_mesh::{HexMesh, OctantSpec};
//! let spec = OctantSpec { a: 0.05, c: 0.04, divisions: 8, grading: 1.0 };
//! let mesh = HexMesh::spheroid_octant(&spec)?;
//! let exact = std::f64::consts::PI * 0.05 * 0.05 * 0.04 / 6.0;
//! assert!((mesh.volume() - exact).abs() < 0.01 * exact);
//! assert!(mesh.min_scaled_jacobian() > 0.2);
//!
//! // Same nodes and elements, surface moved outward: the exact volume.
//! let fitted = HexMesh::spheroid_octant_exact_volume(&spec)?;
//! assert_eq!(fitted.elements, mesh.elements);
//! assert!((fitted.volume() - exact).abs() < 1e-12 * exact);
//!
//! // The same octant in quadratic tetrahedra: 6 per hexahedron, curved faces
//! // on the true spheroid, volume error O(h^4).
//! let tets = tidens_mesh::TetMesh::spheroid_octant(&spec)?;
//! assert_eq!(tets.element_count(), 6 * mesh.element_count());
//! assert!((tets.volume() - exact).abs() < 1e-5 * exact);
//! assert!(tets.min_relative_det_bound() > 0.0);
//!
//! // The whole particle, with its axis c along (0, 1, 0), centred at
//! // (1, 2, 3) mm: the exact volume 4/3 pi a^2 c, a closed curved boundary.
//! let whole = HexMesh::spheroid_whole_exact_volume(&spec)?;
//! assert_eq!(whole.element_count(), 8 * mesh.element_count());
//! assert!(whole.boundary.iter().all(|f| f.kind == tidens_mesh::FaceKind::Curved));
//! let quarter_turn_about_x = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
//! let placed = whole.placed(quarter_turn_about_x, [1.0, 2.0, 3.0])?;
//! assert!((placed.volume() - 8.0 * exact).abs() < 1e-12 * 8.0 * exact);
//! # Ok::<(), tidens_mesh::MeshError>(())
//! ```

mod block;
mod cubed_octant;
mod error;
mod exact_volume;
mod grading;
pub mod hex;
mod hex_split;
mod quality;
pub mod tet10;
mod tet_mesh;
mod tet_quality;
mod transform;
mod whole;

pub use cubed_octant::{OctantShape, radial_divisions};
pub use error::{
    MAX_BLOCK_DIVISIONS, MAX_LEVEL, MAX_OCTANT_DIVISIONS, MeshError, ROTATION_TOLERANCE,
};
pub use exact_volume::EXACT_VOLUME_TOLERANCE;
pub use tet_mesh::{TetBoundaryFace, TetMesh, project_to_spheroid};

use error::is_positive_length;

/// Hexahedral meshes of spheroid octants and boxes.
#[derive(Clone, Debug, PartialEq)]
pub struct HexMesh {
    /// Node coordinates \[mm\].
    pub nodes: Vec<[f64; 3]>,
    /// 8-node hexahedra in VTK_HEXAHEDRON node order (bottom quad 0-1-2-3
    /// counter-clockwise seen from the top, then 4-7 above 0-3), right-handed:
    /// the trilinear Jacobian determinant is > 0 at every corner and Gauss point.
    pub elements: Vec<[usize; 8]>,
    /// Boundary quads, nodes ordered so the right-hand normal points out of the body.
    pub boundary: Vec<BoundaryFace>,
}

/// One boundary quad of a [`HexMesh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundaryFace {
    /// Node indices, ordered so that the right-hand normal points out of the body.
    pub nodes: [usize; 4],
    /// The element this face belongs to.
    pub element: usize,
    /// Which part of the boundary the face lies on.
    pub kind: FaceKind,
}

/// The part of the boundary a [`BoundaryFace`] lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaceKind {
    /// A flat face lying in the coordinate plane `x[axis] = const` (a cut through
    /// the particle centre, or a box face); `high` is true when the outward
    /// normal is +e_axis.
    Plane {
        /// Coordinate axis 0, 1 or 2 (x, y, z) normal to the plane.
        axis: usize,
        /// True when the outward normal is +e_axis.
        high: bool,
    },
    /// The curved free surface of a particle.
    Curved,
}

/// Parameters of a spheroid-octant mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct OctantSpec {
    /// Semi-axis along x and y \[mm\], > 0.
    pub a: f64,
    /// Semi-axis along z \[mm\], > 0.
    pub c: f64,
    /// Elements along each edge of the inner cube, in 2..=[`MAX_OCTANT_DIVISIONS`].
    pub divisions: usize,
    /// At least 1; 1 = uniform; otherwise the ratio of largest to smallest element
    /// size (of the parameter grids), refining toward the three poles
    /// (a,0,0), (0,a,0), (0,0,c) and toward the curved surface.
    pub grading: f64,
}

impl OctantSpec {
    /// Checks every parameter against its allowed range.
    pub fn validate(&self) -> Result<(), MeshError> {
        if !is_positive_length(self.a) {
            return Err(MeshError::SemiAxisA(self.a));
        }
        if !is_positive_length(self.c) {
            return Err(MeshError::SemiAxisC(self.c));
        }
        if !(2..=MAX_OCTANT_DIVISIONS).contains(&self.divisions) {
            return Err(MeshError::OctantDivisions(self.divisions));
        }
        if !(self.grading.is_finite() && self.grading >= 1.0) {
            return Err(MeshError::Grading(self.grading));
        }
        Ok(())
    }
}

impl HexMesh {
    /// Mesh of the spheroid octant {x, y, z >= 0, (x^2 + y^2)/a^2 + z^2/c^2 <= 1} \[mm\].
    ///
    /// Boundary: `Plane { axis, high: false }` on x = 0, y = 0, z = 0 and
    /// `Curved` on the spheroid surface. The poles, the diagonal surface point
    /// (direction (1,1,1) before scaling by diag(a, a, c)) and the three
    /// face-diagonal surface points are nodes; surface nodes lie on the spheroid
    /// to rounding. The layout is [`OctantShape::for_aspect`]`(c / a)` with
    /// [`radial_divisions`] radial layers.
    ///
    /// The bilinear surface facets lie inside the convex spheroid, so the
    /// mesh volume falls short of pi a^2 c / 6 by O(h^2);
    /// [`HexMesh::spheroid_octant_exact_volume`] removes that deficit.
    pub fn spheroid_octant(spec: &OctantSpec) -> Result<HexMesh, MeshError> {
        spec.validate()?;
        Self::spheroid_octant_with_shape(spec, &OctantShape::for_aspect(spec.c / spec.a))
    }

    /// Like [`HexMesh::spheroid_octant`] with an explicit layout, for layout
    /// studies. [`OctantShape::validate`] only rules out shapes that cannot be
    /// built; a valid shape far from [`OctantShape::for_aspect`] can still give
    /// poor or inverted elements.
    pub fn spheroid_octant_with_shape(
        spec: &OctantSpec,
        shape: &OctantShape,
    ) -> Result<HexMesh, MeshError> {
        Ok(octant(spec, shape)?.mesh)
    }

    /// Like [`HexMesh::spheroid_octant`] (same nodes, elements and boundary,
    /// in the same order), with the curved-surface nodes moved slightly
    /// outward so that the mesh volume is the octant's exact volume
    /// pi a^2 c / 6 \[mm^3\] (to a relative [`EXACT_VOLUME_TOLERANCE`]).
    ///
    /// Each surface node moves along its ray from the particle centre by an
    /// amount proportional to the sagitta of the bilinear facets around it,
    /// one common factor (about 2/3) making the volume exact; the shell nodes
    /// beneath it move in proportion to their radial position, the inner
    /// block stays. The offsets are O(h^2), a small fraction of the element
    /// size. The poles, the diagonal point and the three face-diagonal points
    /// do not move (they stay exactly on the spheroid, where particles touch
    /// rigid planes and each other at the start), every node stays at most
    /// halfway from the spheroid to the tangent plane at each of them (so
    /// particles touching there cannot overlap), and nodes on the planes
    /// x = 0, y = 0, z = 0 stay exactly on them. Other surface nodes lie
    /// outside the spheroid by O(h^2).
    ///
    /// Errors as [`HexMesh::spheroid_octant`], or [`MeshError::VolumeFit`]
    /// when the exact volume cannot be reached (2 divisions with grading > 1).
    pub fn spheroid_octant_exact_volume(spec: &OctantSpec) -> Result<HexMesh, MeshError> {
        spec.validate()?;
        Self::spheroid_octant_exact_volume_with_shape(
            spec,
            &OctantShape::for_aspect(spec.c / spec.a),
        )
    }

    /// Like [`HexMesh::spheroid_octant_exact_volume`] with an explicit
    /// layout (see [`HexMesh::spheroid_octant_with_shape`]).
    pub fn spheroid_octant_exact_volume_with_shape(
        spec: &OctantSpec,
        shape: &OctantShape,
    ) -> Result<HexMesh, MeshError> {
        exact_volume::fit(octant(spec, shape)?, spec.a, spec.c)
    }

    /// Mesh of the whole spheroid {(x^2 + y^2)/a^2 + z^2/c^2 <= 1} \[mm\],
    /// centred at the origin with its axis c along z: the eight mirror images
    /// ([`HexMesh::mirrored`]) of [`HexMesh::spheroid_octant`] glued into one
    /// conforming mesh along the planes x = 0, y = 0, z = 0.
    ///
    /// Nodes on those planes are shared by the images meeting there (created
    /// once, from the octant's structure), so the mesh has
    /// 8 N - 4 N1 - 6 N2 - 7 nodes for an octant of N nodes with N1 on exactly
    /// one plane and N2 on exactly two (the centre is the last term), and
    /// 8 times the octant's elements, all right-handed with the octant's
    /// quality. Element `g * E + e` is element `e` of the octant (E elements)
    /// mirrored about the axes `i` whose bit `1 << i` is set in `g`; the first
    /// E elements and the first N nodes are the octant's. The boundary is the
    /// closed curved surface only, every face `FaceKind::Curved` with its
    /// normal outward; no `FaceKind::Plane` face remains. The volume falls
    /// short of 4/3 pi a^2 c \[mm^3\] by the octant's relative error.
    ///
    /// Place it in a packing with [`HexMesh::placed`].
    pub fn spheroid_whole(spec: &OctantSpec) -> Result<HexMesh, MeshError> {
        Ok(whole::glued_mirror_images(&Self::spheroid_octant(spec)?))
    }

    /// Like [`HexMesh::spheroid_whole`], glued from
    /// [`HexMesh::spheroid_octant_exact_volume`]: the mesh volume is the
    /// spheroid's exact volume 4/3 pi a^2 c \[mm^3\] (to a relative
    /// [`EXACT_VOLUME_TOLERANCE`]). The poles, the points on the diagonals
    /// (+-1, +-1, +-1) and the face diagonals (before scaling by diag(a, a, c))
    /// lie exactly on the spheroid.
    ///
    /// Errors as [`HexMesh::spheroid_octant_exact_volume`].
    pub fn spheroid_whole_exact_volume(spec: &OctantSpec) -> Result<HexMesh, MeshError> {
        Ok(whole::glued_mirror_images(
            &Self::spheroid_octant_exact_volume(spec)?,
        ))
    }

    /// Uniform mesh of the box [0, Lx] x [0, Ly] x [0, Lz] \[mm\] with
    /// `divisions[i]` elements along axis i; all six faces are
    /// `FaceKind::Plane` (`high` on x = Lx, y = Ly, z = Lz).
    pub fn block(lengths: [f64; 3], divisions: [usize; 3]) -> Result<HexMesh, MeshError> {
        for axis in 0..3 {
            if !is_positive_length(lengths[axis]) {
                return Err(MeshError::BlockLength {
                    axis,
                    value: lengths[axis],
                });
            }
            if !(1..=MAX_BLOCK_DIVISIONS).contains(&divisions[axis]) {
                return Err(MeshError::BlockDivisions {
                    axis,
                    value: divisions[axis],
                });
            }
        }
        Ok(block::build(lengths, divisions))
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of elements.
    pub fn element_count(&self) -> usize {
        self.elements.len()
    }
}

/// Mesh level -> inner-cube divisions: level 1 is the coarsest usable mesh;
/// each level refines the element size by a factor of about sqrt(2):
/// divisions = round(4 * 2^((level - 1) / 2)) -> 4, 6, 8, 11, 16, 23, 32, 45.
pub fn divisions_for_level(level: u32) -> Result<usize, MeshError> {
    if !(1..=MAX_LEVEL).contains(&level) {
        return Err(MeshError::Level(level));
    }
    Ok((4.0 * 2f64.powf(f64::from(level - 1) / 2.0)).round() as usize)
}

/// The cubed-octant mesh of a checked spec and shape, surface nodes on the
/// spheroid.
fn octant(spec: &OctantSpec, shape: &OctantShape) -> Result<cubed_octant::OctantMesh, MeshError> {
    spec.validate()?;
    shape.validate()?;
    let layout =
        cubed_octant::OctantLayout::new(spec.a, spec.c, spec.divisions, spec.grading, *shape);
    Ok(cubed_octant::build(layout))
}
