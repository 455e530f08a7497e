//! Closing the gaps of the start without strain
//! ([`ParticleContact::close_initial_gaps`]): particles that touch at
//! points (a jammed packing) have faceted surfaces that lie inside the
//! spheroids by up to the facets' sagitta, so every contact would start
//! open; gaps below a limit are read as closed from then on.

#[path = "support/frictionless.rs"]
mod support;

use support::frictionless;
use tidens_contact::{ContactSurface, ParticleContact};

/// A master square [0, 1]^2 at z = 0 facing up, and a slave triangle
/// facing down whose corners are 0.003, 0.003 and 0.05 mm above it.
fn square_and_triangle() -> (Vec<[f64; 3]>, ParticleContact) {
    let nodes = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.3, 0.3, 0.003],
        [0.6, 0.3, 0.003],
        [0.3, 0.6, 0.05],
    ];
    let surfaces = vec![
        ContactSurface::from_triangles(&[[0, 1, 2], [0, 2, 3]], &nodes).unwrap(),
        ContactSurface::from_triangles(&[[4, 6, 5]], &nodes).unwrap(),
    ];
    (nodes, frictionless(surfaces, 0.1))
}

/// The slave's nodes moved down by `drop` \[mm\], flat.
fn lowered(nodes: &[[f64; 3]], drop: f64) -> Vec<f64> {
    nodes
        .iter()
        .enumerate()
        .flat_map(|(n, p)| [p[0], p[1], if n >= 4 { p[2] - drop } else { p[2] }])
        .collect()
}

/// The penetration each slave node of the triangle reads (by node), if it
/// has a term.
fn penetrations(c: &ParticleContact, x: &[f64]) -> Vec<(usize, f64, f64)> {
    let mut out: Vec<(usize, f64, f64)> = c
        .evaluate(x, false)
        .terms
        .iter()
        .filter(|t| t.dofs[0] / 3 >= 4)
        .map(|t| (t.dofs[0] / 3, t.penetration, t.pressure))
        .collect();
    out.sort_by_key(|t| t.0);
    out
}

#[test]
fn gaps_below_the_limit_start_closed_and_press_as_the_nodes_move_in() {
    let (nodes, mut c) = square_and_triangle();
    let x0 = lowered(&nodes, 0.0);
    // The two low corners are closed, the high one (0.05 mm) is not. The
    // square's nodes, slaves of the other pass, project off the triangle.
    assert_eq!(c.close_initial_gaps(&x0, 0.01), 2);
    // At the start nothing presses: the closed gaps read zero.
    for (node, pen, pressure) in penetrations(&c, &x0) {
        assert!(
            pen.abs() < 1e-15 && pressure == 0.0,
            "node {node}: {pen} {pressure}"
        );
    }
    // Lowered by 1e-3 mm, the two press by that much, at the penalty
    // (100 MPa/mm); the high corner is still 0.049 mm off.
    let x = lowered(&nodes, 1e-3);
    let read = penetrations(&c, &x);
    let pressed: Vec<_> = read.iter().filter(|t| t.2 > 0.0).collect();
    assert_eq!(pressed.iter().map(|t| t.0).collect::<Vec<_>>(), vec![4, 5]);
    for &&(node, pen, pressure) in &pressed {
        assert!((pen - 1e-3).abs() < 1e-15, "node {node}: {pen}");
        assert!((pressure - 0.1).abs() < 1e-12, "node {node}: {pressure}");
    }
}

#[test]
fn without_closing_the_same_nodes_are_open_by_their_gap() {
    let (nodes, mut c) = square_and_triangle();
    c.pair_unpaired(&lowered(&nodes, 0.0));
    let x = lowered(&nodes, 1e-3);
    // 0.002 mm apart still (within the touch band: they have terms), no
    // pressure.
    let read = penetrations(&c, &x);
    assert_eq!(read.iter().map(|t| t.0).collect::<Vec<_>>(), vec![4, 5]);
    for (node, pen, pressure) in read {
        assert!(pressure == 0.0, "node {node}: {pen} {pressure}");
        if node < 6 {
            assert!((pen + 2e-3).abs() < 1e-15, "node {node}: {pen}");
        }
    }
}
