//! Tetrahedral meshes: quadratic geometry on the true surface, volume
//! convergence, element validity, mirror images and translations.

mod tet_common;

use std::f64::consts::PI;
use tet_common::{ASPECTS, assert_conforming, assert_watertight, face_normal, octant};
use tidens_mesh::{FaceKind, TetMesh};

fn relative_volume_error(c_over_a: f64, n: usize) -> f64 {
    let exact = PI * c_over_a / 6.0;
    (octant(1.0, c_over_a, n, 1.0).volume() - exact) / exact
}

#[test]
fn octant_volume_converges_at_fourth_order() {
    // Quadratic surface triangles: the surface is interpolated to O(h^3) and
    // the volume error, an integral of that error, converges at O(h^4).
    for ratio in [0.5, 1.0, 2.0] {
        let errs: Vec<f64> = [4, 8, 16]
            .iter()
            .map(|&n| relative_volume_error(ratio, n))
            .collect();
        assert!(
            errs[1].abs() < 5e-6,
            "c/a {ratio}: error {} at n = 8",
            errs[1]
        );
        for w in errs.windows(2) {
            let order = (w[0] / w[1]).abs().ln() / 2f64.ln();
            assert!(
                order > 3.7,
                "c/a {ratio}: observed order {order} ({errs:?})"
            );
        }
    }
}

#[test]
fn curved_mid_edge_nodes_lie_on_the_spheroid() {
    for ratio in ASPECTS {
        let (a, c) = (0.05, 0.05 * ratio);
        for (n, grading) in [(2, 1.0), (5, 2.0), (9, 4.0)] {
            let m = octant(a, c, n, grading);
            let on =
                |p: [f64; 3]| (p[0] / a).powi(2) + (p[1] / a).powi(2) + (p[2] / c).powi(2) - 1.0;
            let mut curved = 0;
            for f in m.boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
                curved += 1;
                for &k in &f.nodes {
                    let r = on(m.nodes[k]);
                    assert!(
                        r.abs() < 1e-12,
                        "c/a {ratio}: node {k} off the surface by {r}"
                    );
                }
                // Outward: away from the centre.
                let nrm = face_normal(&m, &f.nodes);
                let p = m.nodes[f.nodes[0]];
                assert!((0..3).map(|r| nrm[r] * p[r]).sum::<f64>() > 0.0);
            }
            assert!(curved > 0);
        }
    }
}

#[test]
fn other_mid_edge_nodes_are_midpoints_and_planes_stay_flat() {
    let m = octant(1.0, 1.4, 5, 2.0);
    let mut on_curve = std::collections::HashSet::new();
    for f in m.boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
        on_curve.extend(f.nodes[3..].iter().copied());
    }
    for el in &m.elements {
        for (k, [i, j]) in tidens_mesh::tet10::EDGES.iter().enumerate() {
            let mid = el[4 + k];
            if on_curve.contains(&mid) {
                continue;
            }
            let (p, q) = (m.nodes[el[*i]], m.nodes[el[*j]]);
            let want: [f64; 3] = std::array::from_fn(|r| 0.5 * (p[r] + q[r]));
            assert_eq!(m.nodes[mid], want);
        }
    }
    for f in &m.boundary {
        if let FaceKind::Plane { axis, high } = f.kind {
            assert!(!high);
            assert!(
                f.nodes.iter().all(|&k| m.nodes[k][axis] == 0.0),
                "node off plane {axis}"
            );
            let nrm = face_normal(&m, &f.nodes);
            assert!(
                (nrm[axis] + 1.0).abs() < 1e-12,
                "normal {nrm:?} on plane {axis}"
            );
        }
    }
}

#[test]
fn block_volume_is_exact() {
    let m = TetMesh::block([1.5, 0.7, 2.3], [3, 5, 4]).expect("valid block");
    let exact = 1.5 * 0.7 * 2.3;
    assert!((m.volume() - exact).abs() < 1e-14 * exact);
    // Each hexahedron is cut into six tetrahedra of equal volume.
    for e in 0..m.element_count() {
        assert!((m.element_volume(e) - exact / 360.0).abs() < 1e-14 * exact);
    }
    assert!((m.min_relative_det() - 1.0).abs() < 1e-12);
    // Cubes split into tetrahedra of mean ratio 12 (1/2)^(2/3) / 10 (the
    // path tetrahedron, edges 1, 1, 1, sqrt 2, sqrt 2, sqrt 3) or 12 (1/2)^(2/3) / 9.
    let cubes = TetMesh::block([2.0; 3], [2, 2, 2]).expect("valid block");
    let path = 1.2 * 0.5f64.powf(2.0 / 3.0);
    for e in 0..cubes.element_count() {
        let q = cubes.element_mean_ratio(e);
        assert!(
            (q - path).abs() < 1e-12 || (q - path * 10.0 / 9.0).abs() < 1e-12,
            "mean ratio {q}"
        );
    }
}

/// Worst validity measures over divisions 2..=16 (uniform grading).
fn sweep(ratio: f64) -> (f64, f64, f64) {
    let mut det = f64::INFINITY;
    let mut bound = f64::INFINITY;
    let mut shape = f64::INFINITY;
    for n in 2..=16 {
        let m = octant(1.0, ratio, n, 1.0);
        det = det.min(m.min_relative_det());
        bound = bound.min(m.min_relative_det_bound());
        shape = shape.min(m.min_mean_ratio());
    }
    (det, bound, shape)
}

fn check_quality(ratio: f64) {
    let (det, bound, shape) = sweep(ratio);
    // Measured: det J / mean >= 0.69 at the nodes and quadrature points, and the
    // Bernstein bound (valid over the whole element) equal to it: the minimum
    // sits at a corner. 0.5 leaves a margin.
    assert!(det > 0.5, "c/a {ratio}: min relative det {det}");
    assert!(bound > 0.5, "c/a {ratio}: det J bound {bound}");
    assert!(
        bound <= det + 1e-12,
        "the bound must not exceed a sampled value"
    );
    assert!(shape > 0.1, "c/a {ratio}: mean ratio {shape}");
}

#[test]
fn quality_oblate_0_5() {
    check_quality(ASPECTS[0]);
}

#[test]
fn quality_oblate_0_8() {
    check_quality(ASPECTS[1]);
}

#[test]
fn quality_sphere() {
    check_quality(ASPECTS[2]);
}

#[test]
fn quality_prolate_1_2() {
    check_quality(ASPECTS[3]);
}

#[test]
fn quality_prolate_2() {
    check_quality(ASPECTS[4]);
}

#[test]
fn graded_meshes_are_valid() {
    for ratio in [0.5, 2.0] {
        for grading in [2.0, 4.0] {
            for n in [2, 4, 8] {
                let m = octant(1.0, ratio, n, grading);
                assert!(
                    m.min_relative_det_bound() > 0.2,
                    "c/a {ratio} grading {grading} n {n}"
                );
            }
        }
    }
}

#[test]
fn inverted_element_is_detected() {
    let mut m = TetMesh::block([1.0; 3], [1, 1, 1]).expect("valid block");
    // Push one mid-edge node far across its element.
    let el = m.elements[0];
    let (p, q) = (m.nodes[el[0]], m.nodes[el[3]]);
    let centre: [f64; 3] =
        std::array::from_fn(|r| 0.25 * (0..4).map(|k| m.nodes[el[k]][r]).sum::<f64>());
    m.nodes[el[7]] =
        std::array::from_fn(|r| 0.5 * (p[r] + q[r]) + 1.5 * (centre[r] - 0.5 * (p[r] + q[r])));
    assert!(m.element_relative_det_bound(0) < 0.0);
    assert!(m.element_min_relative_det(0) < 0.0);
}

const FLIPS: [[bool; 3]; 8] = [
    [false, false, false],
    [true, false, false],
    [false, true, false],
    [false, false, true],
    [true, true, false],
    [true, false, true],
    [false, true, true],
    [true, true, true],
];

fn check_mirror(m: &TetMesh) {
    let vol = m.volume();
    let det = m.min_relative_det();
    for flip in FLIPS {
        let r = m.mirrored(flip);
        assert!(
            (r.volume() - vol).abs() < 1e-12 * vol,
            "flip {flip:?}: volume"
        );
        assert!(
            (r.min_relative_det() - det).abs() < 1e-12,
            "flip {flip:?}: quality"
        );
        assert!(r.min_relative_det_bound() > 0.0, "flip {flip:?}: inverted");
        for e in 0..m.element_count() {
            assert!((r.element_volume(e) - m.element_volume(e)).abs() < 1e-12 * vol);
        }
        assert_eq!(r.boundary.len(), m.boundary.len());
        for (f, g) in m.boundary.iter().zip(&r.boundary) {
            assert_eq!(f.element, g.element);
            match (f.kind, g.kind) {
                (FaceKind::Plane { axis, high }, FaceKind::Plane { axis: a2, high: h2 }) => {
                    assert_eq!(axis, a2);
                    assert_eq!(h2, high ^ flip[axis]);
                    let nrm = face_normal(&r, &g.nodes);
                    let want = if h2 { 1.0 } else { -1.0 };
                    assert!(
                        (nrm[axis] - want).abs() < 1e-12,
                        "flip {flip:?}: normal {nrm:?}"
                    );
                }
                (FaceKind::Curved, FaceKind::Curved) => {}
                (a, b) => panic!("face kind changed from {a:?} to {b:?}"),
            }
        }
        assert_conforming(&r);
        assert_watertight(&r);
    }
}

#[test]
fn mirrored_octant() {
    check_mirror(&octant(0.05, 0.06, 4, 2.0));
}

#[test]
fn mirrored_block() {
    check_mirror(&TetMesh::block([0.4, 0.2, 0.1], [2, 3, 1]).expect("valid block"));
}

#[test]
fn eight_mirrored_octants_make_a_closed_spheroid() {
    let m = octant(1.0, 0.7, 5, 1.0);
    let mut area = [0.0; 3];
    let mut flux = 0.0;
    for flip in FLIPS {
        let r = m.mirrored(flip);
        for f in r.boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
            let p = tet_common::face_points(&r, &f.nodes);
            let a = tet_common::area_vector(&p);
            for k in 0..3 {
                area[k] += a[k];
            }
            flux += tet_common::position_flux(&p);
        }
    }
    assert!(area.iter().all(|v| v.abs() < 1e-12), "{area:?}");
    assert!((flux / 3.0 - 8.0 * m.volume()).abs() < 1e-10);
}

#[test]
fn translation_moves_nodes_only() {
    let m = octant(1.0, 1.0, 3, 1.0);
    let t = m.translated([1.0, -2.0, 0.5]);
    assert_eq!(t.elements, m.elements);
    assert_eq!(t.boundary, m.boundary);
    for (p, q) in m.nodes.iter().zip(&t.nodes) {
        assert_eq!([p[0] + 1.0, p[1] - 2.0, p[2] + 0.5], *q);
    }
    assert!((t.volume() - m.volume()).abs() < 1e-12);
    assert!((t.min_relative_det() - m.min_relative_det()).abs() < 1e-9);
}
