//! Special points are nodes; surface nodes lie on the spheroid; Plane faces lie
//! on their planes; the boundary parts have the right normals.

mod common;

use common::{ASPECTS, face_normal, octant};
use tidens_mesh::{FaceKind, HexMesh};

fn has_node(mesh: &HexMesh, p: [f64; 3], tol: f64) -> bool {
    mesh.nodes
        .iter()
        .any(|q| (0..3).all(|r| (q[r] - p[r]).abs() <= tol))
}

/// Surface point of the unit-sphere direction `d` mapped by diag(a, a, c).
fn surface_point(a: f64, c: f64, d: [f64; 3]) -> [f64; 3] {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    [a * d[0] / len, a * d[1] / len, c * d[2] / len]
}

#[test]
fn poles_and_diagonals_are_nodes() {
    let a = 0.05;
    for ratio in ASPECTS {
        let c = ratio * a;
        for n in [2, 3, 4, 7, 8, 11, 16] {
            for grading in [1.0, 3.0] {
                let m = octant(a, c, n, grading);
                let tol = 1e-14 * a;
                // Poles exactly.
                for p in [[a, 0.0, 0.0], [0.0, a, 0.0], [0.0, 0.0, c]] {
                    assert!(
                        m.nodes.contains(&p),
                        "pole {p:?} missing (c/a {ratio}, n {n})"
                    );
                }
                for d in [
                    [1.0, 1.0, 1.0],
                    [1.0, 1.0, 0.0],
                    [1.0, 0.0, 1.0],
                    [0.0, 1.0, 1.0],
                ] {
                    let p = surface_point(a, c, d);
                    assert!(
                        has_node(&m, p, tol),
                        "surface point {d:?} missing (c/a {ratio}, n {n})"
                    );
                }
            }
        }
    }
}

#[test]
fn curved_faces_lie_on_the_spheroid_and_point_outward() {
    for ratio in ASPECTS {
        let (a, c) = (2.0, 2.0 * ratio);
        for (n, grading) in [(2, 1.0), (5, 2.0), (12, 4.0)] {
            let m = octant(a, c, n, grading);
            let mut curved = 0;
            for f in m.boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
                curved += 1;
                for &k in &f.nodes {
                    let [x, y, z] = m.nodes[k];
                    let level = (x * x + y * y) / (a * a) + z * z / (c * c);
                    assert!(
                        (level - 1.0).abs() < 1e-12,
                        "node {k} off the surface: {level}"
                    );
                    assert!(x >= 0.0 && y >= 0.0 && z >= 0.0);
                }
                // Outward: the normal agrees with the spheroid's gradient at the face centre.
                let ctr: [f64; 3] = std::array::from_fn(|r| {
                    f.nodes.iter().map(|&k| m.nodes[k][r]).sum::<f64>() / 4.0
                });
                let grad = [ctr[0] / (a * a), ctr[1] / (a * a), ctr[2] / (c * c)];
                let nrm = face_normal(&m, f.nodes);
                let dot: f64 = (0..3).map(|r| nrm[r] * grad[r]).sum();
                assert!(dot > 0.0, "curved face points inward");
            }
            assert_eq!(curved, 3 * n * n);
        }
    }
}

#[test]
fn plane_faces_lie_on_their_planes() {
    for ratio in ASPECTS {
        let m = octant(1.0, ratio, 6, 2.0);
        let mut per_axis = [0; 3];
        for f in &m.boundary {
            if let FaceKind::Plane { axis, high } = f.kind {
                assert!(!high, "octant cut faces face -e_axis");
                per_axis[axis] += 1;
                assert!(
                    f.nodes.iter().all(|&k| m.nodes[k][axis] == 0.0),
                    "face off plane {axis}"
                );
                let nrm = face_normal(&m, f.nodes);
                assert!(
                    (nrm[axis] + 1.0).abs() < 1e-12,
                    "normal {nrm:?} on plane {axis}"
                );
            }
        }
        // Every plane: the inner-cube face (n x n) plus two outer-block strips.
        let mm = (m.element_count() - 6 * 6 * 6) / (3 * 6 * 6);
        assert_eq!(per_axis, [6 * 6 + 2 * 6 * mm; 3]);
    }
}

#[test]
fn no_node_outside_the_octant() {
    for ratio in ASPECTS {
        let (a, c) = (1.0, ratio);
        let m = octant(a, c, 9, 4.0);
        for &[x, y, z] in &m.nodes {
            assert!(x >= 0.0 && y >= 0.0 && z >= 0.0);
            assert!((x * x + y * y) / (a * a) + z * z / (c * c) <= 1.0 + 1e-12);
        }
    }
}

#[test]
fn grading_refines_toward_pole_and_surface() {
    // Along the x axis (edge of planes y = 0, z = 0): the node spacing at the
    // pole must be finer than near the centre, and much finer with grading 4.
    let spacing_ratio = |grading: f64| {
        let m = octant(1.0, 1.0, 8, grading);
        let mut xs: Vec<f64> = m
            .nodes
            .iter()
            .filter(|p| p[1] == 0.0 && p[2] == 0.0)
            .map(|p| p[0])
            .collect();
        xs.sort_by(f64::total_cmp);
        let d: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        let max = d.iter().cloned().fold(0.0, f64::max);
        max / d[d.len() - 1]
    };
    let uniform = spacing_ratio(1.0);
    let graded = spacing_ratio(4.0);
    assert!(graded > 2.0 * uniform, "uniform {uniform}, graded {graded}");
    // On the surface, the first ring around the pole shrinks with grading.
    let pole_ring = |grading: f64| {
        let m = octant(1.0, 1.0, 8, grading);
        m.nodes
            .iter()
            .filter(|p| {
                ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 1.0).abs() < 1e-12
                    && p[2] == 0.0
                    && p[1] > 0.0
            })
            .map(|p| p[1])
            .fold(f64::INFINITY, f64::min)
    };
    assert!(pole_ring(4.0) < 0.6 * pole_ring(1.0));
}
