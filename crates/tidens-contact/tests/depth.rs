//! The depth of a node inside another particle ([`ParticleContact::max_depth`])
//! where the other particle's surface has turned over.
//!
//! Parry tells inside from outside by the pseudo-normal of the face, edge
//! or corner nearest to the node. Where a coarse mesh is crushed until
//! some of its surface triangles turn over, that pseudo-normal can point
//! out of the particle: on the sc2 cell of c/a = 5 at mesh level 2, nodes
//! of a large particle 8.6e-3 mm above the highest node of a small particle
//! read 9.3e-3 mm inside it (0.19 of the radius), through an edge at that
//! top one of whose two triangles faced down. A node outside the particle's
//! bounding box is outside whatever its faces say.

#[path = "support/frictionless.rs"]
mod support;

use support::frictionless;
use tidens_contact::{ContactSurface, ParticleContact};

fn contact(surfaces: Vec<ContactSurface>) -> ParticleContact {
    frictionless(surfaces, 0.1)
}

/// A master: the tetrahedron of corners 0, x, y and z of the unit box,
/// its faces oriented outward, or all turned over (`turned`); and a slave
/// triangle whose first node is `p`, the other two 0.01 mm beside it.
fn tetrahedron_and_node(turned: bool, p: [f64; 3]) -> (Vec<f64>, ParticleContact) {
    let nodes = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        p,
        [p[0] + 0.01, p[1], p[2]],
        [p[0], p[1] + 0.01, p[2]],
    ];
    let faces: Vec<[usize; 3]> = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
        .into_iter()
        .map(|[a, b, c]| if turned { [a, c, b] } else { [a, b, c] })
        .collect();
    let surfaces = vec![
        ContactSurface::from_triangles(&faces, &nodes).unwrap(),
        ContactSurface::from_triangles(&[[4, 5, 6]], &nodes).unwrap(),
    ];
    let x = nodes.iter().flatten().copied().collect();
    (x, contact(surfaces))
}

#[test]
fn a_node_inside_reads_its_distance_to_the_surface() {
    // At the centroid, nearest to the slanted face x + y + z = 1.
    let (x, c) = tetrahedron_and_node(false, [0.25; 3]);
    let depth = c.max_depth(&x);
    assert!((depth - 0.25 / 3f64.sqrt()).abs() < 1e-12, "{depth}");
    // Outside, beside the slanted face and within the bounding box.
    let (x, c) = tetrahedron_and_node(false, [0.4, 0.4, 0.4]);
    assert_eq!(c.max_depth(&x), 0.0);
}

#[test]
fn a_node_beyond_a_surface_turned_over_is_not_inside_it() {
    // With every face turned over, parry puts the outside in: beside the
    // slanted face, within the bounding box, the slave's nodes read inside
    // (the farthest, at (0.41, 0.4, 0.4), 0.21 / sqrt 3 from the face).
    let (x, c) = tetrahedron_and_node(true, [0.4, 0.4, 0.4]);
    let beside = c.max_depth(&x);
    assert!((beside - 0.21 / 3f64.sqrt()).abs() < 1e-12, "{beside}");
    // Above the top corner, beyond the bounding box, it does not.
    let (x, c) = tetrahedron_and_node(true, [0.02, 0.02, 1.05]);
    assert_eq!(c.max_depth(&x), 0.0);
}
