//! Tetrahedral meshes: the hexahedron split conforms, boundaries are complete
//! and outward, counts match, bad input is rejected.

mod tet_common;

use std::collections::HashSet;
use tet_common::{ASPECTS, assert_conforming, assert_watertight, octant};
use tidens_mesh::{BoundaryFace, FaceKind, HexMesh, MeshError, OctantSpec, TetMesh};

/// Number of distinct edges of the tetrahedra, counted independently.
fn edge_count(mesh: &TetMesh) -> usize {
    let mut edges = HashSet::new();
    for el in &mesh.elements {
        for i in 0..4 {
            for j in i + 1..4 {
                edges.insert((el[i].min(el[j]), el[i].max(el[j])));
            }
        }
    }
    edges.len()
}

fn check_counts(hex: &HexMesh, tet: &TetMesh) {
    assert_eq!(tet.element_count(), 6 * hex.element_count());
    assert_eq!(tet.node_count(), hex.node_count() + edge_count(tet));
    assert_eq!(tet.boundary.len(), 2 * hex.boundary.len());
    // The corner nodes are the hexahedral nodes, in their numbering.
    assert_eq!(&tet.nodes[..hex.node_count()], &hex.nodes[..]);
    for (k, el) in tet.elements.iter().enumerate() {
        let parent = &hex.elements[k / 6];
        assert!(el[..4].iter().all(|n| parent.contains(n)), "element {k}");
        assert!(
            el[4..].iter().all(|&n| n >= hex.node_count()),
            "element {k}"
        );
    }
    for kind in [
        FaceKind::Curved,
        FaceKind::Plane {
            axis: 0,
            high: false,
        },
        FaceKind::Plane {
            axis: 2,
            high: true,
        },
    ] {
        let quads = hex.boundary.iter().filter(|f| f.kind == kind).count();
        let tris = tet.boundary.iter().filter(|f| f.kind == kind).count();
        assert_eq!(tris, 2 * quads, "{kind:?}");
    }
}

#[test]
fn octant_split_is_conforming_and_watertight() {
    for ratio in ASPECTS {
        for (n, grading) in [(2, 1.0), (3, 4.0), (6, 1.0), (9, 2.0)] {
            let spec = OctantSpec {
                a: 0.05,
                c: 0.05 * ratio,
                divisions: n,
                grading,
            };
            let hex = HexMesh::spheroid_octant(&spec).expect("valid spec");
            let tet = TetMesh::spheroid_octant(&spec).expect("valid spec");
            check_counts(&hex, &tet);
            assert_conforming(&tet);
            assert_watertight(&tet);
        }
    }
}

#[test]
fn block_split_is_conforming_and_watertight() {
    for div in [[1, 1, 1], [3, 2, 4], [5, 1, 2]] {
        let hex = HexMesh::block([0.3, 0.2, 0.5], div).expect("valid block");
        let tet = TetMesh::block([0.3, 0.2, 0.5], div).expect("valid block");
        check_counts(&hex, &tet);
        assert_conforming(&tet);
        assert_watertight(&tet);
    }
}

#[test]
fn shared_quads_are_cut_the_same_way_from_both_sides() {
    // Renumber the nodes of a block at random: the cut of every face depends
    // on the numbering, and must still match between the two hexahedra.
    let hex = HexMesh::block([1.0, 1.0, 1.0], [3, 3, 3]).expect("valid block");
    let n = hex.node_count();
    let mut perm: Vec<usize> = (0..n).collect();
    let mut seed: u64 = 12345;
    for i in (1..n).rev() {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        perm.swap(i, (seed >> 33) as usize % (i + 1));
    }
    let mut nodes = vec![[0.0; 3]; n];
    for (old, &new) in perm.iter().enumerate() {
        nodes[new] = hex.nodes[old];
    }
    let shuffled = HexMesh {
        nodes,
        elements: hex.elements.iter().map(|el| el.map(|i| perm[i])).collect(),
        boundary: hex
            .boundary
            .iter()
            .map(|f| BoundaryFace {
                nodes: f.nodes.map(|i| perm[i]),
                ..*f
            })
            .collect(),
    };
    let tet = TetMesh::from_hex(&shuffled).expect("valid mesh");
    assert_conforming(&tet);
    assert_watertight(&tet);
    assert!(tet.min_relative_det_bound() > 0.999_999);
    assert!((tet.volume() - 1.0).abs() < 1e-14);
}

#[test]
fn elements_are_right_handed_in_vtk_order() {
    let m = octant(1.0, 1.3, 4, 2.0);
    for (e, el) in m.elements.iter().enumerate() {
        let x = el.map(|n| m.nodes[n]);
        let d: [[f64; 3]; 3] =
            std::array::from_fn(|k| std::array::from_fn(|r| x[k + 1][r] - x[0][r]));
        // Right-hand normal of corners 0-1-2 points toward corner 3.
        let n = [
            d[0][1] * d[1][2] - d[0][2] * d[1][1],
            d[0][2] * d[1][0] - d[0][0] * d[1][2],
            d[0][0] * d[1][1] - d[0][1] * d[1][0],
        ];
        assert!(
            (0..3).map(|r| n[r] * d[2][r]).sum::<f64>() > 0.0,
            "element {e}"
        );
        assert!(m.element_volume(e) > 0.0);
    }
}

#[test]
fn invalid_input_is_rejected() {
    let spec = OctantSpec {
        a: 1.0,
        c: 1.0,
        divisions: 1,
        grading: 1.0,
    };
    assert_eq!(
        TetMesh::spheroid_octant(&spec),
        Err(MeshError::OctantDivisions(1))
    );
    assert!(matches!(
        TetMesh::block([1.0, -1.0, 1.0], [1, 1, 1]),
        Err(MeshError::BlockLength { axis: 1, .. })
    ));
    let mut hex = HexMesh::block([1.0; 3], [2, 1, 1]).expect("valid block");
    let good = hex.clone();
    hex.elements[1][6] = 99;
    assert_eq!(
        TetMesh::from_hex(&hex),
        Err(MeshError::NodeIndex {
            element: 1,
            node: 99,
            node_count: 12
        })
    );
    // A boundary face naming an element it does not belong to.
    let mut hex = good.clone();
    let i = hex
        .boundary
        .iter()
        .position(|f| f.element == 0)
        .expect("element 0 has boundary faces");
    hex.boundary[i].element = 1;
    let err = TetMesh::from_hex(&hex).expect_err("inconsistent boundary");
    assert!(matches!(err, MeshError::BoundaryFace { face, element: 1 } if face == i));
    let mut hex = good;
    hex.boundary[0].element = 7;
    assert!(matches!(
        TetMesh::from_hex(&hex),
        Err(MeshError::BoundaryFace { element: 7, .. })
    ));
}

#[test]
fn conformity_check_rejects_a_mismatched_cut() {
    // Two cubes side by side; the face x = 1 is a far face of the first cube
    // (its apex, node 0, is at the origin), cut into two triangles that are the
    // bases of two tetrahedra with that apex. Re-cut that pyramid along the
    // other diagonal: still a valid split of the first cube, but no longer
    // matching the second cube across x = 1.
    let good = TetMesh::block([2.0, 1.0, 1.0], [2, 1, 1]).expect("valid block");
    assert_conforming(&good);
    let on_face = |n: usize| good.nodes[n][0] == 1.0;
    let pyramid: Vec<usize> = (0..6)
        .filter(|&k| good.elements[k][1..4].iter().all(|&n| on_face(n)))
        .collect();
    assert_eq!(pyramid.len(), 2);
    let (t1, t2) = (good.elements[pyramid[0]], good.elements[pyramid[1]]);
    // The quad a-b-c-d, cut along a-c, from (v, a, b, c) and (v, a, c, d).
    let (v, a, b, c) = (t1[0], t1[1], t1[2], t1[3]);
    assert_eq!([t2[0], t2[1], t2[2]], [v, a, c]);
    let d = t2[3];
    let mut bad = good.clone();
    let (pb, pd) = (bad.nodes[b], bad.nodes[d]);
    bad.nodes
        .push(std::array::from_fn(|r| 0.5 * (pb[r] + pd[r])));
    let bd = bad.nodes.len() - 1;
    let mid = |p: usize, q: usize| -> usize {
        let key = (p.min(q), p.max(q));
        good.elements
            .iter()
            .find_map(|el| {
                tidens_mesh::tet10::EDGES
                    .iter()
                    .position(|&[i, j]| (el[i].min(el[j]), el[i].max(el[j])) == key)
                    .map(|k| el[4 + k])
            })
            .unwrap_or(bd)
    };
    let tet = |c: [usize; 4]| -> [usize; 10] {
        let mut el = [0; 10];
        el[..4].copy_from_slice(&c);
        for (k, [i, j]) in tidens_mesh::tet10::EDGES.iter().enumerate() {
            el[4 + k] = mid(c[*i], c[*j]);
        }
        el
    };
    bad.elements[pyramid[0]] = tet([v, a, b, d]);
    bad.elements[pyramid[1]] = tet([v, b, c, d]);
    assert!((bad.volume() - good.volume()).abs() < 1e-14);
    assert!(bad.min_relative_det_bound() > 0.0);
    let caught = std::panic::catch_unwind(|| assert_conforming(&bad));
    assert!(caught.is_err(), "a mismatched cut must be reported");
}
