//! A strongly warped master quad, as the faces at the slender tips of
//! deformed spheroids become: measured on its two flat triangles, a node's
//! penetration is its signed distance to the triangles that parry
//! searches; on the bilinear patch it is not.

use parry3d_f64::math::Vector as PVector;
use parry3d_f64::query::PointQueryWithLocation;
use tidens_contact::{ContactMode, ContactSettings, ContactSurface, ParticleContact};

/// Height of two opposite corners of the master quad above the plane of
/// the other two \[mm\]: the bilinear patch stands 0.1 above the diagonal
/// the triangles share at the quad's centre.
const WARP: f64 = 0.2;

/// The master quad (corners counter-clockwise seen from +z: outward normal
/// up), its 0-2 diagonal the shorter (1.41 against 1.70), and a slave quad
/// of half-width 0.01 facing down, its centre at `at`.
fn warped(at: [f64; 3]) -> (Vec<[f64; 3]>, [usize; 4], [usize; 4]) {
    let mut nodes = vec![
        [0.0, 0.0, 0.0],
        [1.2, 0.0, WARP],
        [1.0, 1.0, 0.0],
        [0.0, 1.2, WARP],
    ];
    let h = 0.01;
    for (dx, dy) in [(-h, -h), (-h, h), (h, h), (h, -h)] {
        nodes.push([at[0] + dx, at[1] + dy, at[2]]);
    }
    (nodes, [0, 1, 2, 3], [4, 5, 6, 7])
}

/// Penetration of each slave node (by node id) measured by the contact.
fn measured(master: ContactSurface, slave: ContactSurface, x: &[f64]) -> Vec<(usize, f64)> {
    let slave_nodes = slave.nodes.clone();
    let mut c = ParticleContact::new(
        vec![master, slave],
        ContactSettings {
            mode: ContactMode::Frictionless,
            penalty: 100.0,
            search_distance: 0.2,
            curvature_stiffness: false,
            touch_stiffness_cap: f64::INFINITY,
        },
    )
    .unwrap();
    c.pair(x);
    let mut terms: Vec<(usize, f64)> = c
        .evaluate(x, false)
        .terms
        .iter()
        .filter(|t| t.slave.0 == 1)
        .map(|t| (slave_nodes[t.slave.1], t.penetration))
        .collect();
    terms.sort_by_key(|t| t.0);
    terms
}

#[test]
fn on_a_warped_quad_a_node_is_measured_on_the_triangles_parry_searches() {
    // Nodes over each triangle, deep below it, near it and just above it.
    for (cx, cy, z) in [
        (0.7, 0.3, -0.03),
        (0.7, 0.3, 0.0),
        (0.3, 0.7, 0.05),
        (0.3, 0.7, 0.081),
    ] {
        let (nodes, master, slave) = warped([cx, cy, z]);
        let x: Vec<f64> = nodes.iter().flatten().copied().collect();
        let triangles = ContactSurface::from_quads_as_triangles(&[master], &nodes).unwrap();
        let mesh = triangles.trimesh(&x).unwrap();
        let on_triangles = measured(
            triangles,
            ContactSurface::from_quads(&[slave], &nodes).unwrap(),
            &x,
        );
        assert_eq!(
            on_triangles.len(),
            4,
            "at ({cx}, {cy}, {z}): {on_triangles:?}"
        );
        for &(n, depth) in &on_triangles {
            let s = nodes[n];
            let q = PVector::new(s[0], s[1], s[2]);
            let (proj, _) = mesh.project_local_point_and_get_location(q, false);
            // The triangles face up: a node below them is inside.
            let signed = (proj.point - q).length().copysign(proj.point.z - q.z);
            assert!(
                (depth - signed).abs() < 1e-12,
                "at ({cx}, {cy}, {z}), node {n}: measured {depth}, parry's distance {signed}"
            );
        }
        // On the bilinear patch the same nodes read 0.03-0.04 mm deeper:
        // the patch bulges off the triangles (0.1 mm at the centre).
        let on_patch = measured(
            ContactSurface::from_quads(&[master], &nodes).unwrap(),
            ContactSurface::from_quads(&[slave], &nodes).unwrap(),
            &x,
        );
        for (a, b) in on_patch.iter().zip(&on_triangles) {
            assert!(
                a.1 - b.1 > 0.02,
                "at ({cx}, {cy}, {z}): patch {a:?}, triangles {b:?}"
            );
        }
    }
}

#[test]
fn a_quad_is_split_along_its_shorter_diagonal_and_keeps_its_areas() {
    let (nodes, master, _) = warped([0.5, 0.5, 0.0]);
    let split = ContactSurface::from_quads_as_triangles(&[master], &nodes).unwrap();
    let quad = ContactSurface::from_quads(&[master], &nodes).unwrap();
    assert_eq!(split.facets, vec![[0, 1, 2, 2], [0, 2, 3, 3]]);
    assert_eq!(split.areas, quad.areas);
    // Turned by one corner, the shorter diagonal is the quad's 1-3.
    let turned = [master[1], master[2], master[3], master[0]];
    let split = ContactSurface::from_quads_as_triangles(&[turned], &nodes).unwrap();
    assert_eq!(split.facets, vec![[2, 0, 1, 1], [2, 3, 0, 0]]);
    // A mirror image reverses the quad as 0-3-2-1 and splits it into the
    // mirror images of the triangles, in the same order (also where the
    // diagonals are equal).
    let square = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, WARP],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, WARP],
    ];
    for points in [nodes[..4].to_vec(), square] {
        let split = ContactSurface::from_quads_as_triangles(&[master], &points).unwrap();
        let mirrored: Vec<[f64; 3]> = points.iter().map(|p| [-p[0], p[1], p[2]]).collect();
        let reversed = [master[0], master[3], master[2], master[1]];
        let image = ContactSurface::from_quads_as_triangles(&[reversed], &mirrored).unwrap();
        let corners = |f: &[usize; 4]| {
            let mut c = f[..3].to_vec();
            c.sort_unstable();
            c
        };
        for (t, u) in split.facets.iter().zip(&image.facets) {
            assert_eq!(
                corners(t),
                corners(u),
                "{:?} against {:?}",
                split.facets,
                image.facets
            );
        }
    }
}
