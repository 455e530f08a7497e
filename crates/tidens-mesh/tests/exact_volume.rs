//! Exact-volume octant meshes: the volume is pi a^2 c / 6; only node
//! positions change; the special points stay on the spheroid and flat faces
//! on their planes; no node crosses the tangent plane at a special point; the
//! surface offsets are a small fraction of the element size and fall at
//! second order.

mod common;

use common::{
    ASPECTS, LEVEL_DIVISIONS, assert_conforming, assert_watertight, exact_octant, face_normal,
    octant,
};
use std::f64::consts::PI;
use tidens_mesh::{FaceKind, HexMesh};

const GRADINGS: [f64; 3] = [1.0, 2.0, 4.0];

/// Unit-sphere directions of the special points: poles, diagonal, face diagonals.
const SPECIAL: [[f64; 3]; 7] = [
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [1.0, 1.0, 0.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
];

fn unit(d: [f64; 3]) -> [f64; 3] {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|v| v / len)
}

/// The spheroid's level function: 1 on the surface.
fn level(a: f64, c: f64, p: [f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1]) / (a * a) + p[2] * p[2] / (c * c)
}

fn distance(p: [f64; 3], q: [f64; 3]) -> f64 {
    (0..3).map(|r| (p[r] - q[r]).powi(2)).sum::<f64>().sqrt()
}

fn exact_volume(a: f64, c: f64) -> f64 {
    PI * a * a * c / 6.0
}

/// Per node, the distance it moved between the two meshes, and the shortest
/// curved-surface edge at it in the on-surface mesh (infinity off the surface).
fn offsets_and_edges(on_surface: &HexMesh, fitted: &HexMesh) -> Vec<(f64, f64)> {
    let mut edge = vec![f64::INFINITY; on_surface.node_count()];
    for f in on_surface
        .boundary
        .iter()
        .filter(|f| f.kind == FaceKind::Curved)
    {
        for k in 0..4 {
            let (i, j) = (f.nodes[k], f.nodes[(k + 1) % 4]);
            let d = distance(on_surface.nodes[i], on_surface.nodes[j]);
            edge[i] = edge[i].min(d);
            edge[j] = edge[j].min(d);
        }
    }
    on_surface
        .nodes
        .iter()
        .zip(&fitted.nodes)
        .zip(edge)
        .map(|((&p, &q), e)| (distance(p, q), e))
        .collect()
}

#[test]
fn volume_is_exact_for_every_level_aspect_and_grading() {
    let a = 0.05;
    for ratio in ASPECTS {
        let c = ratio * a;
        let exact = exact_volume(a, c);
        for grading in GRADINGS {
            for n in LEVEL_DIVISIONS {
                let err = (exact_octant(a, c, n, grading).volume() - exact).abs() / exact;
                assert!(
                    err < 1e-10,
                    "c/a {ratio} grading {grading} n {n}: relative error {err}"
                );
                // The on-surface mesh misses far more (O(h^2), 5e-4 at 23 divisions).
                let deficit = 1.0 - octant(a, c, n, grading).volume() / exact;
                assert!(deficit > 1e-4, "c/a {ratio} n {n}: deficit {deficit}");
            }
        }
    }
}

#[test]
fn only_node_positions_change_and_the_surface_moves_outward() {
    let (a, c) = (1.0, 1.0);
    for ratio in ASPECTS {
        let c = c * ratio;
        for (n, grading) in [(4, 1.0), (6, 2.0), (11, 4.0)] {
            let on_surface = octant(a, c, n, grading);
            let fitted = exact_octant(a, c, n, grading);
            assert_eq!(fitted.elements, on_surface.elements);
            assert_eq!(fitted.boundary, on_surface.boundary);
            assert_eq!(fitted.node_count(), on_surface.node_count());
            assert_conforming(&fitted);
            assert_watertight(&fitted);
            let mut moved = 0;
            for f in fitted
                .boundary
                .iter()
                .filter(|f| f.kind == FaceKind::Curved)
            {
                for &k in &f.nodes {
                    let (before, after) = (
                        level(a, c, on_surface.nodes[k]),
                        level(a, c, fitted.nodes[k]),
                    );
                    assert!(after >= before, "node {k} moved inward");
                    if after > before {
                        moved += 1;
                    }
                }
                // Still outward-facing: the normal agrees with the spheroid's gradient.
                let ctr: [f64; 3] = std::array::from_fn(|r| {
                    f.nodes.iter().map(|&k| fitted.nodes[k][r]).sum::<f64>() / 4.0
                });
                let grad = [ctr[0] / (a * a), ctr[1] / (a * a), ctr[2] / (c * c)];
                let nrm = face_normal(&fitted, f.nodes);
                assert!((0..3).map(|r| nrm[r] * grad[r]).sum::<f64>() > 0.0);
            }
            assert!(moved > 0, "c/a {ratio} n {n}: no surface node moved");
            // The nodes nearest the centre (the inner block) do not move.
            let centre = fitted
                .nodes
                .iter()
                .position(|p| *p == [0.0; 3])
                .expect("centre node");
            assert_eq!(on_surface.nodes[centre], fitted.nodes[centre]);
        }
    }
}

#[test]
fn special_points_are_nodes_exactly_on_the_spheroid() {
    let a = 0.05;
    for ratio in ASPECTS {
        let c = ratio * a;
        for grading in GRADINGS {
            for n in LEVEL_DIVISIONS {
                let m = exact_octant(a, c, n, grading);
                for d in SPECIAL {
                    let u = unit(d);
                    let p = [a * u[0], a * u[1], c * u[2]];
                    let node = m
                        .nodes
                        .iter()
                        .find(|&&q| distance(p, q) <= 1e-14 * a)
                        .unwrap_or_else(|| panic!("{d:?} is not a node (c/a {ratio}, n {n})"));
                    let l = level(a, c, *node);
                    assert!(
                        (l - 1.0).abs() <= 1e-14,
                        "{d:?} off the spheroid: level {l} (c/a {ratio}, n {n})"
                    );
                }
                for pole in [[a, 0.0, 0.0], [0.0, a, 0.0], [0.0, 0.0, c]] {
                    assert!(m.nodes.contains(&pole), "pole {pole:?} moved");
                }
            }
        }
    }
}

#[test]
fn flat_face_nodes_stay_on_their_planes() {
    for ratio in ASPECTS {
        for (n, grading) in [(4, 1.0), (8, 2.0), (11, 4.0)] {
            let on_surface = octant(1.0, ratio, n, grading);
            let m = exact_octant(1.0, ratio, n, grading);
            let mut checked = 0;
            for f in &m.boundary {
                if let FaceKind::Plane { axis, .. } = f.kind {
                    for &k in &f.nodes {
                        assert_eq!(m.nodes[k][axis], 0.0, "node {k} left plane {axis}");
                        checked += 1;
                    }
                    let nrm = face_normal(&m, f.nodes);
                    assert!((nrm[axis] + 1.0).abs() < 1e-12, "normal {nrm:?}");
                }
            }
            assert!(checked > 0);
            // Every zero coordinate stays exactly zero.
            for (p, q) in on_surface.nodes.iter().zip(&m.nodes) {
                for r in 0..3 {
                    assert!(p[r] != 0.0 || q[r] == 0.0, "{p:?} -> {q:?}");
                }
            }
        }
    }
}

/// Particles touch rigid planes and each other at the special points, and
/// two particles touching there share its tangent plane: no node may cross
/// it. On graded meshes the facets next to the face-diagonal points are long
/// and thin, and sagitta-proportional offsets alone would cross it there.
#[test]
fn no_node_crosses_the_tangent_plane_at_a_special_point() {
    for ratio in ASPECTS {
        let (a, c) = (1.0, ratio);
        for grading in GRADINGS {
            for n in LEVEL_DIVISIONS {
                let m = exact_octant(a, c, n, grading);
                for p in &m.nodes {
                    let u = [p[0] / a, p[1] / a, p[2] / c];
                    for d in SPECIAL {
                        let s = unit(d);
                        let height = u[0] * s[0] + u[1] * s[1] + u[2] * s[2];
                        assert!(
                            height <= 1.0 + 1e-14,
                            "c/a {ratio} grading {grading} n {n}: node {p:?} beyond \
                             the tangent plane at {d:?} by {}",
                            height - 1.0
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn offsets_fall_at_second_order_with_the_element_size() {
    let a = 1.0;
    for ratio in ASPECTS {
        let c = ratio * a;
        for grading in [1.0, 2.0] {
            let largest: Vec<f64> = [4, 8, 16]
                .iter()
                .map(|&n| {
                    offsets_and_edges(&octant(a, c, n, grading), &exact_octant(a, c, n, grading))
                        .iter()
                        .map(|&(d, _)| d)
                        .fold(0.0, f64::max)
                })
                .collect();
            for w in largest.windows(2) {
                let r = w[0] / w[1];
                assert!(
                    (3.5..=4.6).contains(&r),
                    "c/a {ratio} grading {grading}: offsets {largest:?}, ratio {r}"
                );
            }
        }
    }
}

#[test]
fn offsets_are_a_small_fraction_of_the_element_size() {
    let a = 1.0;
    for ratio in ASPECTS {
        let c = ratio * a;
        for grading in GRADINGS {
            // Graded elements are anisotropic: measure against their shortest edge.
            let bound = if grading == 1.0 { 0.1 } else { 0.3 };
            for n in LEVEL_DIVISIONS {
                let worst =
                    offsets_and_edges(&octant(a, c, n, grading), &exact_octant(a, c, n, grading))
                        .iter()
                        .filter(|&&(d, _)| d > 0.0)
                        .map(|&(d, e)| d / e)
                        .fold(0.0, f64::max);
                assert!(
                    worst < bound,
                    "c/a {ratio} grading {grading} n {n}: offset / edge {worst}"
                );
            }
        }
    }
}
