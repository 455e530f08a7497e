//! Whole-spheroid meshes (eight glued octants) and their rigid placement.

mod common;

use common::{assert_conforming, assert_watertight, face_map, min_node_spacing};
use std::collections::HashMap;
use std::f64::consts::PI;
use tidens_mesh::hex::{quad_area_vector, quad_position_flux};
use tidens_mesh::{FaceKind, HexMesh, MeshError, OctantShape, OctantSpec, radial_divisions};

/// Aspect ratios c/a checked: a sphere, the required range and the extremes.
const RATIOS: [f64; 5] = [1.0, 0.5, 2.0, 0.2, 5.0];

fn spec(c_over_a: f64, divisions: usize, grading: f64) -> OctantSpec {
    OctantSpec {
        a: 0.05,
        c: 0.05 * c_over_a,
        divisions,
        grading,
    }
}

/// The octant and the whole mesh glued from it, plain or exact-volume.
fn octant_and_whole(s: &OctantSpec, exact: bool) -> (HexMesh, HexMesh) {
    let (octant, whole) = if exact {
        (
            HexMesh::spheroid_octant_exact_volume(s),
            HexMesh::spheroid_whole_exact_volume(s),
        )
    } else {
        (HexMesh::spheroid_octant(s), HexMesh::spheroid_whole(s))
    };
    (octant.expect("valid spec"), whole.expect("valid spec"))
}

fn spheroid_volume(s: &OctantSpec) -> f64 {
    4.0 / 3.0 * PI * s.a * s.a * s.c
}

/// Sum of the boundary quads' areas \[mm^2\] (of their area vectors).
fn surface_area(mesh: &HexMesh) -> f64 {
    mesh.boundary
        .iter()
        .map(|f| {
            let a = quad_area_vector(&f.nodes.map(|k| mesh.nodes[k]));
            (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
        })
        .sum()
}

/// Asserts the boundary quads form a closed, consistently oriented surface:
/// every directed edge of a quad is run once, and backward by exactly one
/// other quad, so each edge is shared by exactly two boundary quads.
fn assert_closed_surface(mesh: &HexMesh) {
    let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
    for f in &mesh.boundary {
        for i in 0..4 {
            *edges.entry((f.nodes[i], f.nodes[(i + 1) % 4])).or_default() += 1;
        }
    }
    for (&(p, q), &count) in &edges {
        assert_eq!(count, 1, "edge {p}-{q} run {count} times in one direction");
        assert_eq!(edges.get(&(q, p)), Some(&1), "edge {p}-{q} open");
    }
    assert_eq!(edges.len(), 4 * mesh.boundary.len());
}

#[test]
fn node_count_is_eight_octants_minus_the_shared_plane_nodes() {
    for ratio in RATIOS {
        for (n, grading) in [(2, 1.0), (3, 3.0), (4, 1.0), (8, 2.0)] {
            let s = spec(ratio, n, grading);
            let (octant, whole) = octant_and_whole(&s, false);
            // Octant nodes on exactly 1, 2 and 3 of the planes x, y, z = 0: a
            // node on q planes is shared by 2^q of the 8 images.
            let mut on = [0; 4];
            for p in &octant.nodes {
                on[p.iter().filter(|&&v| v == 0.0).count()] += 1;
            }
            assert_eq!(on[3], 1, "only the centre is on all three planes");
            let shared = 8 * octant.node_count() - 4 * on[1] - 6 * on[2] - 7 * on[3];
            assert_eq!(whole.node_count(), shared, "c/a {ratio} n {n}");
            // Independently, from the layout: the inner cube of 2n divisions
            // and m shells of the cubed sphere with 2n divisions per face edge.
            let m = radial_divisions(n, &OctantShape::for_aspect(ratio));
            let closed_form = (2 * n + 1).pow(3) + m * (24 * n * n + 2);
            assert_eq!(whole.node_count(), closed_form, "c/a {ratio} n {n}");
            assert_eq!(whole.element_count(), 8 * octant.element_count());
            assert_eq!(whole.element_count(), 8 * (n * n * n + 3 * n * n * m));
            assert_eq!(whole.boundary.len(), 24 * n * n);
            // The octant comes first, with its numbering.
            assert_eq!(&whole.nodes[..octant.node_count()], &octant.nodes[..]);
            assert_eq!(
                &whole.elements[..octant.element_count()],
                &octant.elements[..]
            );
        }
    }
}

#[test]
fn whole_mesh_is_conforming_closed_and_right_handed() {
    for ratio in RATIOS {
        for exact in [false, true] {
            for (n, grading) in [(3, 1.0), (6, 3.0)] {
                let s = spec(ratio, n, grading);
                let (octant, whole) = octant_and_whole(&s, exact);
                let label = format!("c/a {ratio} n {n} grading {grading} exact {exact}");
                // Faces: shared by two elements inside, one on the listed boundary,
                // listed outward; nodes distinct and all used.
                assert_conforming(&whole);
                let owners = face_map(&whole);
                let single = owners.values().filter(|o| o.len() == 1).count();
                assert_eq!(single, whole.boundary.len(), "{label}");
                assert!(owners.values().all(|o| (1..=2).contains(&o.len())));
                assert_closed_surface(&whole);
                // Area vectors sum to zero; divergence theorem gives the volume.
                assert_watertight(&whole);
                // No cut plane left, the boundary is the curved surface, and
                // every quad faces away from the (star-shaped) particle's centre.
                for f in &whole.boundary {
                    assert_eq!(f.kind, FaceKind::Curved, "{label}");
                    let p = f.nodes.map(|k| whole.nodes[k]);
                    let area = quad_area_vector(&p);
                    let out: f64 = (0..3)
                        .map(|r| area[r] * (p[0][r] + p[1][r] + p[2][r] + p[3][r]))
                        .sum();
                    assert!(out > 0.0, "{label}: inward face {f:?}");
                }
                // Right-handed with the octant's quality.
                assert!(whole.min_relative_det() > 0.0, "{label}");
                let (sj, sj8) = (octant.min_scaled_jacobian(), whole.min_scaled_jacobian());
                assert!(
                    sj8 > 0.0 && (sj8 - sj).abs() < 1e-12,
                    "{label}: {sj8} vs {sj}"
                );
                // No near-duplicate left from a missed merge: the closest two
                // nodes are as far apart as in the octant.
                let cell = 0.05 * s.a.min(s.c);
                let (d1, d8) = (
                    min_node_spacing(&octant, cell),
                    min_node_spacing(&whole, cell),
                );
                assert!(d8 >= 0.999 * d1, "{label}: spacing {d8} vs {d1}");
            }
        }
    }
}

#[test]
fn exact_volume_whole_mesh_has_the_spheroid_volume() {
    for ratio in RATIOS {
        for (n, grading) in [(2, 1.0), (4, 1.0), (8, 1.0), (6, 3.0), (11, 2.0)] {
            let s = spec(ratio, n, grading);
            let (_, whole) = octant_and_whole(&s, true);
            let exact = spheroid_volume(&s);
            let err = (whole.volume() - exact) / exact;
            assert!(err.abs() < 1e-12, "c/a {ratio} n {n}: {err:e}");
        }
    }
}

#[test]
fn plain_whole_mesh_has_the_octant_volume_error() {
    for ratio in RATIOS {
        for (n, grading) in [(2, 1.0), (4, 1.0), (8, 1.0), (6, 3.0)] {
            let s = spec(ratio, n, grading);
            let (octant, whole) = octant_and_whole(&s, false);
            let exact = spheroid_volume(&s);
            let octant_err = (octant.volume() - exact / 8.0) / (exact / 8.0);
            let err = (whole.volume() - exact) / exact;
            assert!(
                err < 0.0 && (err - octant_err).abs() < 1e-12,
                "c/a {ratio} n {n}: {err:e} vs octant {octant_err:e}"
            );
        }
    }
}

/// Rotation by `angle` about the unit vector along `axis` (Rodrigues).
fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let u = axis.map(|v| v / len);
    let (s, c) = angle.sin_cos();
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let cross = match (i, j) {
                (0, 1) => -u[2],
                (0, 2) => u[1],
                (1, 0) => u[2],
                (1, 2) => -u[0],
                (2, 0) => -u[1],
                (2, 1) => u[0],
                _ => 0.0,
            };
            let identity = if i == j { c } else { 0.0 };
            identity + s * cross + (1.0 - c) * u[i] * u[j]
        })
    })
}

#[test]
fn placement_keeps_volume_area_and_puts_the_pole_on_the_rotated_axis() {
    let centre = [0.31, -0.27, 1.13];
    for ratio in RATIOS {
        for exact in [false, true] {
            let s = spec(ratio, 5, 2.0);
            let (_, whole) = octant_and_whole(&s, exact);
            for r in [
                rotation([1.0, 2.0, -0.5], 0.7),
                rotation([0.0, 0.0, 1.0], 2.0),
                rotation([-3.0, 0.2, 1.0], -2.9),
            ] {
                let placed = whole.placed(r, centre).expect("proper rotation");
                let label = format!("c/a {ratio} exact {exact} rotation {r:?}");
                assert_eq!(placed.elements, whole.elements);
                assert_eq!(placed.boundary, whole.boundary);
                let (v0, v1) = (whole.volume(), placed.volume());
                assert!((v1 - v0).abs() < 1e-12 * v0, "{label}: volume {v1} vs {v0}");
                let (a0, a1) = (surface_area(&whole), surface_area(&placed));
                assert!((a1 - a0).abs() < 1e-12 * a0, "{label}: area {a1} vs {a0}");
                assert!(placed.min_relative_det() > 0.0, "{label}");
                assert_closed_surface(&placed);
                // Outward normals: the placed boundary's flux about `centre`
                // is 3 V, as before placing.
                let flux: f64 = placed
                    .boundary
                    .iter()
                    .map(|f| quad_position_flux(&f.nodes.map(|k| sub(placed.nodes[k], centre))))
                    .sum();
                assert!((flux / 3.0 - v0).abs() < 1e-12 * v0, "{label}: flux");
                // The boundary node farthest along the particle axis (the
                // rotation's third column) is the pole, at distance c.
                let axis = [r[0][2], r[1][2], r[2][2]];
                let (along, pole) = placed
                    .boundary
                    .iter()
                    .flat_map(|f| f.nodes)
                    .map(|k| (dot(sub(placed.nodes[k], centre), axis), k))
                    .fold(
                        (f64::NEG_INFINITY, 0),
                        |best, x| {
                            if x.0 > best.0 { x } else { best }
                        },
                    );
                let d = sub(placed.nodes[pole], centre);
                assert!((along - s.c).abs() < 1e-12 * s.c, "{label}: {along}");
                assert!((dot(d, d).sqrt() - s.c).abs() < 1e-12 * s.c, "{label}");
            }
            // The identity with no shift changes nothing, bit for bit.
            let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            assert_eq!(whole.placed(identity, [0.0; 3]), Ok(whole.clone()));
        }
    }
}

#[test]
fn improper_rotations_and_bad_centres_are_rejected() {
    let whole = HexMesh::spheroid_whole(&spec(1.0, 2, 1.0)).expect("valid spec");
    let mirror = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
    let e = whole.placed(mirror, [0.0; 3]).unwrap_err();
    assert!(
        matches!(e, MeshError::Rotation { orthogonality, det, .. } if orthogonality == 0.0 && det == -1.0),
        "{e:?}"
    );
    assert!(
        e.to_string().starts_with("rotation = [[1.0, 0.0, 0.0]"),
        "{e}"
    );
    assert!(e.to_string().contains("det -1"), "{e}");
    let scaled = rotation([1.0, 1.0, 0.0], 0.3).map(|row| row.map(|v| 1.001 * v));
    assert!(matches!(
        whole.placed(scaled, [0.0; 3]),
        Err(MeshError::Rotation { .. })
    ));
    // Rounded to f32: off by ~1e-8, rejected; f64 rounding passes.
    let r = rotation([0.3, -1.0, 2.0], 1.1);
    assert!(whole.placed(r, [0.0; 3]).is_ok());
    let rounded = r.map(|row| row.map(|v| f64::from(v as f32)));
    assert!(whole.placed(rounded, [0.0; 3]).is_err());
    let mut nan = r;
    nan[1][2] = f64::NAN;
    assert!(matches!(
        whole.placed(nan, [0.0; 3]),
        Err(MeshError::Rotation { orthogonality, .. }) if orthogonality.is_nan()
    ));
    let e = whole.placed(r, [0.0, f64::INFINITY, 0.0]).unwrap_err();
    assert_eq!(e, MeshError::Centre([0.0, f64::INFINITY, 0.0]));
    assert_eq!(
        e.to_string(),
        "centre = [0.0, inf, 0.0] mm: every coordinate must be finite"
    );
    // Invalid specs are rejected before gluing.
    assert_eq!(
        HexMesh::spheroid_whole(&spec(1.0, 1, 1.0)),
        Err(MeshError::OctantDivisions(1))
    );
    assert!(matches!(
        HexMesh::spheroid_whole_exact_volume(&spec(1.0, 2, 4.0)),
        Err(MeshError::VolumeFit { .. })
    ));
}

fn sub(p: [f64; 3], q: [f64; 3]) -> [f64; 3] {
    [p[0] - q[0], p[1] - q[1], p[2] - q[2]]
}

fn dot(p: [f64; 3], q: [f64; 3]) -> f64 {
    p[0] * q[0] + p[1] * q[1] + p[2] * q[2]
}
