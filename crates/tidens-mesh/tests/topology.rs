//! Conformity and watertightness of the meshes.

mod common;

use common::{ASPECTS, assert_conforming, assert_watertight, min_node_spacing, octant};
use tidens_mesh::{FaceKind, HexMesh, OctantShape, radial_divisions};

#[test]
fn octant_is_conforming_and_watertight() {
    for ratio in ASPECTS {
        for (n, grading) in [(2, 1.0), (3, 4.0), (8, 1.0), (11, 2.0)] {
            let m = octant(0.05, 0.05 * ratio, n, grading);
            assert_conforming(&m);
            assert_watertight(&m);
        }
    }
}

#[test]
fn octant_counts_match_the_layout() {
    for ratio in ASPECTS {
        for n in [2, 5, 8] {
            let m = octant(1.0, ratio, n, 1.0);
            let r = radial_divisions(n, &OctantShape::for_aspect(ratio));
            assert_eq!(m.element_count(), n * n * n + 3 * n * n * r);
            // Nodes: inner cube (n+1)^3 plus r shells over the 3 patches, whose
            // shared edges (3 of them, n+1 nodes, minus the doubly counted diagonal) merge.
            let shell = 3 * (n + 1) * (n + 1) - 3 * (n + 1) + 1;
            assert_eq!(m.node_count(), (n + 1).pow(3) + r * shell);
            // Boundary: 3 planes (n^2 + 2 n r each) plus 3 curved patches (n^2 each).
            assert_eq!(m.boundary.len(), 3 * (n * n + 2 * n * r) + 3 * n * n);
            let curved = m
                .boundary
                .iter()
                .filter(|f| f.kind == FaceKind::Curved)
                .count();
            assert_eq!(curved, 3 * n * n);
        }
    }
}

#[test]
fn octant_nodes_are_well_separated() {
    // No near-duplicates either: the closest two nodes are a sizeable fraction of
    // the coarsest spacing (grading 4 makes the finest spacing ~ 1/4 of it).
    for ratio in [0.5, 2.0] {
        let n = 8;
        let m = octant(1.0, ratio, n, 4.0);
        let d = min_node_spacing(&m, 0.1);
        assert!(
            d > 0.02 * ratio.min(1.0) / n as f64,
            "c/a {ratio}: min spacing {d}"
        );
    }
}

#[test]
fn block_is_conforming_and_watertight() {
    let m = HexMesh::block([0.3, 0.2, 0.5], [3, 2, 4]).expect("valid block");
    assert_conforming(&m);
    assert_watertight(&m);
    let one = HexMesh::block([1.0, 2.0, 3.0], [1, 1, 1]).expect("valid block");
    assert_conforming(&one);
    assert_watertight(&one);
    assert_eq!(one.boundary.len(), 6);
}

#[test]
fn elements_are_vtk_ordered_and_right_handed() {
    // Bottom quad counter-clockwise seen from the top face: the bottom face's
    // right-hand normal (0-1-2-3) points toward the top face (4-7).
    let m = octant(1.0, 1.3, 4, 2.0);
    for (e, el) in m.elements.iter().enumerate() {
        let x = el.map(|n| m.nodes[n]);
        let n = tidens_mesh::hex::quad_area_vector(&[x[0], x[1], x[2], x[3]]);
        let bottom: [f64; 3] =
            std::array::from_fn(|r| (x[0][r] + x[1][r] + x[2][r] + x[3][r]) / 4.0);
        let top: [f64; 3] = std::array::from_fn(|r| (x[4][r] + x[5][r] + x[6][r] + x[7][r]) / 4.0);
        let up: f64 = (0..3).map(|r| n[r] * (top[r] - bottom[r])).sum();
        assert!(up > 0.0, "element {e}");
        assert!(m.element_volume(e) > 0.0);
    }
}
