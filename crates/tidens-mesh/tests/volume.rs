//! Volume of the octant mesh converges to pi a^2 c / 6 at second order; block
//! volumes and face areas are exact.

mod common;

use common::{ASPECTS, octant};
use std::f64::consts::PI;
use tidens_mesh::hex::quad_area_vector;
use tidens_mesh::{FaceKind, HexMesh};

fn relative_volume_error(a: f64, c: f64, n: usize) -> f64 {
    let exact = PI * a * a * c / 6.0;
    (octant(a, c, n, 1.0).volume() - exact) / exact
}

#[test]
fn octant_volume_converges_at_second_order() {
    let a = 0.05; // 50 um particle radius [mm]
    for ratio in [0.8, 1.0, 1.2, 2.0] {
        let c = ratio * a;
        let e8 = relative_volume_error(a, c, 8);
        let e16 = relative_volume_error(a, c, 16);
        // Bilinear facets lie inside the convex surface: the mesh is too small.
        assert!(
            e8 < 0.0 && e16 < 0.0,
            "c/a {ratio}: errors {e8} {e16} should be negative"
        );
        assert!(
            e8.abs() < 0.01,
            "c/a {ratio}: relative error {e8} at divisions 8"
        );
        let order = (e8 / e16).ln() / 2f64.ln();
        assert!(
            (1.7..=2.3).contains(&order),
            "c/a {ratio}: observed order {order}"
        );
    }
}

#[test]
fn octant_volume_error_decreases_monotonically() {
    for ratio in ASPECTS {
        let errs: Vec<f64> = [2, 4, 8, 16]
            .iter()
            .map(|&n| relative_volume_error(1.0, ratio, n).abs())
            .collect();
        assert!(
            errs.windows(2).all(|w| w[1] < w[0]),
            "c/a {ratio}: {errs:?}"
        );
    }
}

#[test]
fn graded_octant_volume_is_close() {
    for grading in [2.0, 4.0] {
        let err = relative_volume_error(1.0, 1.2, 8);
        let m = octant(1.0, 1.2, 8, grading);
        let exact = PI * 1.2 / 6.0;
        let graded = (m.volume() - exact) / exact;
        assert!(
            graded.abs() < 0.02,
            "grading {grading}: {graded} (uniform {err})"
        );
    }
}

#[test]
fn block_volume_is_exact() {
    let m = HexMesh::block([1.5, 0.7, 2.3], [3, 5, 4]).expect("valid block");
    assert_eq!(m.element_count(), 60);
    assert_eq!(m.node_count(), 4 * 6 * 5);
    let exact = 1.5 * 0.7 * 2.3;
    assert!((m.volume() - exact).abs() < 1e-14 * exact);
    for e in 0..m.element_count() {
        assert!((m.element_volume(e) - exact / 60.0).abs() < 1e-14 * exact);
    }
    assert!((m.min_scaled_jacobian() - 1.0).abs() < 1e-14);
}

#[test]
fn block_faces_cover_each_plane_once() {
    let l = [1.5, 0.7, 2.3];
    let div = [3, 5, 4];
    let m = HexMesh::block(l, div).expect("valid block");
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for high in [false, true] {
            let faces: Vec<_> = m
                .boundary
                .iter()
                .filter(|f| f.kind == FaceKind::Plane { axis, high })
                .collect();
            assert_eq!(faces.len(), div[u] * div[v], "axis {axis} high {high}");
            let mut area = [0.0; 3];
            let value = if high { l[axis] } else { 0.0 };
            for f in &faces {
                let p = f.nodes.map(|n| m.nodes[n]);
                assert!(p.iter().all(|x| x[axis] == value), "face off its plane");
                let a = quad_area_vector(&p);
                for r in 0..3 {
                    area[r] += a[r];
                }
            }
            let sign = if high { 1.0 } else { -1.0 };
            assert!(
                (area[axis] - sign * l[u] * l[v]).abs() < 1e-14,
                "axis {axis} high {high}: {area:?}"
            );
            assert!(area[u].abs() < 1e-14 && area[v].abs() < 1e-14);
        }
    }
    assert_eq!(m.boundary.len(), 2 * (3 * 5 + 5 * 4 + 4 * 3));
    assert!(m.boundary.iter().all(|f| f.kind != FaceKind::Curved));
}
