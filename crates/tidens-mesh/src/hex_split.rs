//! Conforming split of a hexahedral mesh into 10-node tetrahedra.
//!
//! Rule. Every quadrilateral face is cut along the diagonal through its node
//! of smallest global index. Every hexahedron is then split into six
//! tetrahedra by joining its node of smallest global index `v0` (its "apex")
//! to the two triangles of each of the three faces that do not contain `v0`.
//!
//! Why this is a tetrahedralisation of the hexahedron: for a convex hexahedron
//! it is the "pulling" triangulation from the vertex `v0` (a cone from `v0`
//! over a triangulation of the faces not containing it), which is valid for
//! any convex polytope; for the mildly curved hexahedra of the tidens meshes
//! the tests check every tetrahedron's Jacobian.
//!
//! Why it is conforming: the faces of the hexahedron that contain `v0` come
//! out cut along the diagonal through `v0`, which is their node of smallest
//! index (it is the smallest of the whole hexahedron); the other three faces
//! are cut explicitly by the same rule. So every quadrilateral face is cut by
//! a rule that depends only on its own four global node indices, and the two
//! hexahedra sharing it produce the same two triangles.
//!
//! Then one node is added per unique edge, at the edge midpoint; midpoints of
//! edges of `Curved` boundary triangles are moved by a caller-supplied map
//! onto the true surface.

use crate::hex::FACES;
use crate::tet10::EDGES;
use crate::{FaceKind, HexMesh, MeshError, TetBoundaryFace, TetMesh};
use std::collections::HashMap;

/// Tetrahedra per hexahedron; tetrahedron `6 e + k` comes from hexahedron `e`.
pub(crate) const TETS_PER_HEX: usize = 6;

/// The two triangles of quad `q` (nodes in cyclic order) cut along the
/// diagonal through its node of smallest index, in the cyclic orientation of `q`.
pub(crate) fn split_quad(q: [usize; 4]) -> [[usize; 3]; 2] {
    let k = (0..4).min_by_key(|&i| q[i]).unwrap_or(0);
    let r = |i: usize| q[(k + i) % 4];
    [[r(0), r(1), r(2)], [r(0), r(2), r(3)]]
}

/// The six corner quadruples of hexahedron `el` (VTK order, right-handed),
/// each right-handed (VTK tetra order: the right-hand normal of 0-1-2 points
/// toward 3).
fn split_hex(el: &[usize; 8]) -> [[usize; 4]; TETS_PER_HEX] {
    let apex_local = (0..8).min_by_key(|&i| el[i]).unwrap_or(0);
    let apex = el[apex_local];
    let mut tets = [[0; 4]; TETS_PER_HEX];
    let mut n = 0;
    for face in FACES.iter().filter(|f| !f.contains(&apex_local)) {
        // The face's outward normal points away from the apex, so the
        // tetrahedron (apex, t0, t1, t2) is right-handed.
        for t in split_quad(face.map(|i| el[i])) {
            tets[n] = [apex, t[0], t[1], t[2]];
            n += 1;
        }
    }
    tets
}

fn edge_key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

/// Splits `hex` into quadratic tetrahedra; `surface` (if any) maps the
/// straight midpoint of every edge of a `Curved` boundary triangle onto the
/// true surface. Node `i < hex.node_count()` of the result is node `i` of `hex`.
pub(crate) fn split(
    hex: &HexMesh,
    surface: Option<&dyn Fn([f64; 3]) -> [f64; 3]>,
) -> Result<TetMesh, MeshError> {
    let node_count = hex.nodes.len();
    for (e, el) in hex.elements.iter().enumerate() {
        if let Some(&node) = el.iter().find(|&&n| n >= node_count) {
            return Err(MeshError::NodeIndex {
                element: e,
                node,
                node_count,
            });
        }
    }

    let corners: Vec<[usize; 4]> = hex.elements.iter().flat_map(split_hex).collect();

    let mut nodes = hex.nodes.clone();
    let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
    let mut elements = Vec::with_capacity(corners.len());
    for c in &corners {
        let mut el = [0; 10];
        el[..4].copy_from_slice(c);
        for (k, [i, j]) in EDGES.iter().enumerate() {
            let (a, b) = (c[*i], c[*j]);
            el[4 + k] = *mid.entry(edge_key(a, b)).or_insert_with(|| {
                let (p, q) = (hex.nodes[a], hex.nodes[b]);
                nodes.push(std::array::from_fn(|r| 0.5 * (p[r] + q[r])));
                nodes.len() - 1
            });
        }
        elements.push(el);
    }

    let mut boundary = Vec::with_capacity(2 * hex.boundary.len());
    for (i, f) in hex.boundary.iter().enumerate() {
        if let Some(&node) = f.nodes.iter().find(|&&n| n >= node_count) {
            return Err(MeshError::NodeIndex {
                element: f.element,
                node,
                node_count,
            });
        }
        let not_a_face = MeshError::BoundaryFace {
            face: i,
            element: f.element,
        };
        for t in split_quad(f.nodes) {
            let first = f.element.saturating_mul(TETS_PER_HEX);
            let element = (first..first.saturating_add(TETS_PER_HEX).min(elements.len()))
                .find(|&k| t.iter().all(|n| corners[k].contains(n)))
                .ok_or(not_a_face.clone())?;
            // The triangle's corners are corners of `element`, so its edges
            // are edges of `element` and have mid-edge nodes.
            let m = |a: usize, b: usize| mid.get(&edge_key(t[a], t[b])).copied();
            let (Some(m01), Some(m12), Some(m20)) = (m(0, 1), m(1, 2), m(2, 0)) else {
                return Err(not_a_face);
            };
            // The quad is ordered outward, and so is each of its triangles.
            boundary.push(TetBoundaryFace {
                nodes: [t[0], t[1], t[2], m01, m12, m20],
                element,
                kind: f.kind,
            });
        }
    }

    if let Some(project) = surface {
        let mut moved = vec![false; nodes.len()];
        for f in boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
            for &n in &f.nodes[3..] {
                if !moved[n] {
                    nodes[n] = project(nodes[n]);
                    moved[n] = true;
                }
            }
        }
    }

    Ok(TetMesh {
        nodes,
        elements,
        boundary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_is_cut_through_its_smallest_node() {
        assert_eq!(split_quad([5, 2, 7, 9]), [[2, 7, 9], [2, 9, 5]]);
        assert_eq!(split_quad([1, 2, 7, 9]), [[1, 2, 7], [1, 7, 9]]);
        // The cut of a shared face does not depend on where its cycle starts
        // or on its direction.
        let key = |t: [[usize; 3]; 2]| {
            let mut v: Vec<Vec<usize>> = t
                .iter()
                .map(|s| {
                    let mut s = s.to_vec();
                    s.sort_unstable();
                    s
                })
                .collect();
            v.sort();
            v
        };
        let q = [8, 3, 6, 4];
        for k in 0..4 {
            let rot: [usize; 4] = std::array::from_fn(|i| q[(k + i) % 4]);
            let rev: [usize; 4] = std::array::from_fn(|i| q[(k + 4 - i) % 4]);
            assert_eq!(key(split_quad(rot)), key(split_quad(q)));
            assert_eq!(key(split_quad(rev)), key(split_quad(q)));
        }
    }

    #[test]
    fn hex_split_fills_the_unit_cube_with_positive_tets() {
        let corners = crate::hex::CORNERS.map(|c| c.map(|v| 0.5 * (v + 1.0)));
        // Every choice of the smallest node (8 relabelings).
        for shift in 0..8 {
            let el: [usize; 8] = std::array::from_fn(|i| (i + 8 - shift) % 8);
            let mut total = 0.0;
            for t in split_hex(&el) {
                let p = t.map(|n| corners[el.iter().position(|&m| m == n).unwrap_or(0)]);
                let d: [[f64; 3]; 3] =
                    std::array::from_fn(|c| std::array::from_fn(|r| p[c + 1][r] - p[0][r]));
                let m = [
                    [d[0][0], d[1][0], d[2][0]],
                    [d[0][1], d[1][1], d[2][1]],
                    [d[0][2], d[1][2], d[2][2]],
                ];
                let vol = crate::hex::det3(&m) / 6.0;
                assert!(vol > 0.0, "shift {shift}: tet {t:?} volume {vol}");
                total += vol;
            }
            assert!((total - 1.0).abs() < 1e-15, "shift {shift}: volume {total}");
        }
    }
}
