//! Rigid transformations of a [`HexMesh`] and a [`TetMesh`]: reflections
//! and translations.

use crate::{BoundaryFace, FaceKind, HexMesh, TetBoundaryFace, TetMesh};

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
        HexMesh {
            nodes: translated_nodes(&self.nodes, offset),
            elements: self.elements.clone(),
            boundary: self.boundary.clone(),
        }
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
