//! Rigid transformations of a [`HexMesh`] and a [`TetMesh`]: reflections,
//! translations and (for a [`HexMesh`]) rotations.

use crate::hex::det3;
use crate::{
    BoundaryFace, FaceKind, HexMesh, MeshError, ROTATION_TOLERANCE, TetBoundaryFace, TetMesh,
};

/// Permutation that reverses a hexahedron's handedness while keeping VTK order:
/// it swaps the roles of xi and eta (corner 1 <-> 3, 5 <-> 7).
const REVERSE_HEX: [usize; 8] = [0, 3, 2, 1, 4, 7, 6, 5];

/// Reverses a quadrilateral: corners 0-3-2-1.
const REVERSE_QUAD: [usize; 4] = [0, 3, 2, 1];

impl HexMesh {
    /// Mirror image: `x_i -> -x_i` for each axis with `flip[i]`.
    ///
    /// After an odd number of flips each element's node order is permuted so that
    /// it stays right-handed, and each boundary quad is reversed so that its
    /// normal still points out of the body. `FaceKind::Plane::high` is toggled on
    /// flipped axes. Node and element numbering are unchanged.
    pub fn mirrored(&self, flip: [bool; 3]) -> HexMesh {
        let odd = is_odd(flip);
        HexMesh {
            nodes: mirrored_nodes(&self.nodes, flip),
            elements: permuted(&self.elements, REVERSE_HEX, odd),
            boundary: self
                .boundary
                .iter()
                .map(|f| BoundaryFace {
                    nodes: if odd {
                        REVERSE_QUAD.map(|i| f.nodes[i])
                    } else {
                        f.nodes
                    },
                    element: f.element,
                    kind: mirrored_kind(f.kind, flip),
                })
                .collect(),
        }
    }

    /// The mesh shifted by `offset` \[mm\].
    pub fn translated(&self, offset: [f64; 3]) -> HexMesh {
        self.with_nodes(translated_nodes(&self.nodes, offset))
    }

    /// The mesh rigidly placed: rotated about the origin by `rotation`, then
    /// shifted by `centre` \[mm\], i.e. node `x -> R x + centre` with
    /// `R[row][col] = rotation[row][col]`. The columns of `R` are the images
    /// of the mesh axes: a particle meshed by [`HexMesh::spheroid_whole`]
    /// (centred at the origin, semi-axis c along z) ends up centred at
    /// `centre` with its semi-axis c along the third column
    /// `(R[0][2], R[1][2], R[2][2])`.
    ///
    /// Element node order, boundary faces and their kinds are unchanged; a
    /// proper rotation keeps every element right-handed and every boundary
    /// normal outward. A `FaceKind::Plane` label keeps its axis, which after
    /// a general rotation no longer is the face's normal: place closed meshes
    /// (all faces `FaceKind::Curved`).
    ///
    /// Errors: [`MeshError::Rotation`] unless `rotation` is orthonormal with
    /// determinant +1 to [`ROTATION_TOLERANCE`] (a reflection, a scaling or a
    /// non-finite entry), [`MeshError::Centre`] unless `centre` is finite.
    pub fn placed(&self, rotation: [[f64; 3]; 3], centre: [f64; 3]) -> Result<HexMesh, MeshError> {
        check_rotation(rotation)?;
        if !centre.iter().all(|v| v.is_finite()) {
            return Err(MeshError::Centre(centre));
        }
        let nodes = self
            .nodes
            .iter()
            .map(|p| {
                std::array::from_fn(|r| {
                    let row = rotation[r];
                    row[0] * p[0] + row[1] * p[1] + row[2] * p[2] + centre[r]
                })
            })
            .collect();
        Ok(self.with_nodes(nodes))
    }

    /// The mesh with new node coordinates, same elements and boundary.
    fn with_nodes(&self, nodes: Vec<[f64; 3]>) -> HexMesh {
        HexMesh {
            nodes,
            elements: self.elements.clone(),
            boundary: self.boundary.clone(),
        }
    }
}

/// Checks that `r` is a proper rotation to [`ROTATION_TOLERANCE`].
fn check_rotation(r: [[f64; 3]; 3]) -> Result<(), MeshError> {
    let mut orthogonality: f64 = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            let dot = r[0][i] * r[0][j] + r[1][i] * r[1][j] + r[2][i] * r[2][j];
            let identity = if i == j { 1.0 } else { 0.0 };
            let dev = (dot - identity).abs();
            // Unlike `f64::max`, keeps a NaN (non-finite entries) once seen.
            if dev.is_nan() || dev > orthogonality {
                orthogonality = dev;
            }
        }
    }
    let det = det3(&r);
    if orthogonality <= ROTATION_TOLERANCE && (det - 1.0).abs() <= ROTATION_TOLERANCE {
        Ok(())
    } else {
        Err(MeshError::Rotation {
            rotation: r,
            orthogonality,
            det,
        })
    }
}

/// Permutation that reverses a quadratic tetrahedron's handedness while
/// keeping VTK order: it swaps corners 1 and 2 and, with them, the mid-edge
/// nodes of edges 0-1 <-> 0-2 and 1-3 <-> 2-3 (edge 1-2 stays).
const REVERSE_TET: [usize; 10] = [0, 2, 1, 3, 6, 5, 4, 7, 9, 8];

/// Reverses a 6-node triangle: corners 0-2-1, then edges 0-2, 2-1, 1-0.
const REVERSE_TRIANGLE: [usize; 6] = [0, 2, 1, 5, 4, 3];

impl TetMesh {
    /// Mirror image: `x_i -> -x_i` for each axis with `flip[i]`.
    ///
    /// As for [`HexMesh::mirrored`]: after an odd number of flips every
    /// element is renumbered to stay right-handed and every boundary triangle
    /// reversed to keep its normal outward; `FaceKind::Plane::high` is toggled on
    /// flipped axes; node and element numbering are unchanged.
    pub fn mirrored(&self, flip: [bool; 3]) -> TetMesh {
        let odd = is_odd(flip);
        let nodes = mirrored_nodes(&self.nodes, flip);
        let elements = permuted(&self.elements, REVERSE_TET, odd);
        let boundary = self
            .boundary
            .iter()
            .map(|f| TetBoundaryFace {
                nodes: if odd {
                    REVERSE_TRIANGLE.map(|i| f.nodes[i])
                } else {
                    f.nodes
                },
                element: f.element,
                kind: mirrored_kind(f.kind, flip),
            })
            .collect();
        TetMesh {
            nodes,
            elements,
            boundary,
        }
    }

    /// The mesh shifted by `offset` \[mm\].
    pub fn translated(&self, offset: [f64; 3]) -> TetMesh {
        TetMesh {
            nodes: translated_nodes(&self.nodes, offset),
            elements: self.elements.clone(),
            boundary: self.boundary.clone(),
        }
    }
}

/// The face kind after mirroring the axes with `flip`.
fn mirrored_kind(kind: FaceKind, flip: [bool; 3]) -> FaceKind {
    match kind {
        FaceKind::Plane { axis, high } => FaceKind::Plane {
            axis,
            high: high ^ flip[axis],
        },
        FaceKind::Curved => FaceKind::Curved,
    }
}

/// Whether mirroring the axes with `flip` reverses handedness.
fn is_odd(flip: [bool; 3]) -> bool {
    flip.iter().filter(|&&f| f).count() % 2 == 1
}

/// Node coordinates with `x_i -> -x_i` on the flipped axes; `0.0 - v` rather
/// than `-v` keeps coordinate 0 as +0.0.
fn mirrored_nodes(nodes: &[[f64; 3]], flip: [bool; 3]) -> Vec<[f64; 3]> {
    nodes
        .iter()
        .map(|p| std::array::from_fn(|i| if flip[i] { 0.0 - p[i] } else { p[i] }))
        .collect()
}

/// Node coordinates shifted by `offset` \[mm\].
fn translated_nodes(nodes: &[[f64; 3]], offset: [f64; 3]) -> Vec<[f64; 3]> {
    nodes
        .iter()
        .map(|p| std::array::from_fn(|i| p[i] + offset[i]))
        .collect()
}

/// Element connectivity renumbered by `perm` when `odd`, else unchanged.
fn permuted<const N: usize>(
    elements: &[[usize; N]],
    perm: [usize; N],
    odd: bool,
) -> Vec<[usize; N]> {
    if odd {
        elements.iter().map(|el| perm.map(|i| el[i])).collect()
    } else {
        elements.to_vec()
    }
}
