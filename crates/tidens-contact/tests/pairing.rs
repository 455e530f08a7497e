//! Pairing: a slave node near two master surfaces (in the pocket where two
//! particles meet) is held off both, each with its own multiplier; a node
//! that slid off its facet is paired afresh; near a slender tip a node is
//! measured on its own side of it, and beyond the tip on no face.

#[path = "support/frictionless.rs"]
mod support;

use support::frictionless;
use tidens_contact::{ContactSurface, ParticleContact};

/// Penetration of the pocket's slave nodes into each wall [mm].
const DEPTH: f64 = 0.01;

/// Two walls meeting at a right angle along the y axis, the pocket x > 0,
/// z > 0 between them: wall A in the plane z = 0 (outward normal +z), wall
/// B in the plane x = 0 (outward normal +x), each 2 x 2 quads of size 0.5.
/// Slave C: one quad in the plane z = -DEPTH facing -z, from x = -DEPTH
/// (inside both walls) to x = 0.3 (inside A only). Nodes, and the surfaces
/// A, B, C.
fn pocket() -> (Vec<[f64; 3]>, Vec<ContactSurface>) {
    let mut nodes = Vec::new();
    let mut grid = |at: &dyn Fn(f64, f64) -> [f64; 3]| -> Vec<[usize; 4]> {
        let first = nodes.len();
        for j in 0..3 {
            for i in 0..3 {
                nodes.push(at(0.5 * i as f64, 0.5 * j as f64));
            }
        }
        let id = |i: usize, j: usize| first + 3 * j + i;
        let mut quads = Vec::new();
        for j in 0..2 {
            for i in 0..2 {
                quads.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        quads
    };
    // Counter-clockwise about the outward normal: (u, v) -> (x, y) for +z,
    // (u, v) -> (y, z) for +x.
    let a = grid(&|u, v| [u, v, 0.0]);
    let b = grid(&|u, v| [0.0, u, v]);
    let first = nodes.len();
    for p in [
        [-DEPTH, 0.4, -DEPTH],
        [-DEPTH, 0.6, -DEPTH],
        [0.3, 0.6, -DEPTH],
        [0.3, 0.4, -DEPTH],
    ] {
        nodes.push(p);
    }
    // Clockwise seen from +z: the outward normal is -z.
    let c = vec![[first, first + 1, first + 2, first + 3]];
    let surfaces = [a, b, c]
        .iter()
        .map(|quads| ContactSurface::from_quads(quads, &nodes).unwrap())
        .collect();
    (nodes, surfaces)
}

fn contact(surfaces: Vec<ContactSurface>) -> ParticleContact {
    contact_within(surfaces, 0.05)
}

fn contact_within(surfaces: Vec<ContactSurface>, search_distance: f64) -> ParticleContact {
    frictionless(surfaces, search_distance)
}

/// Adds a slave quad of half-width 0.01 facing down with its centre at
/// `at`, and returns the master `quads` and it as two surfaces.
fn with_slave_below(
    nodes: &mut Vec<[f64; 3]>,
    quads: Vec<[usize; 4]>,
    at: [f64; 3],
) -> Vec<ContactSurface> {
    with_slave_below_on(nodes, quads, at, false)
}

/// As [`with_slave_below`], the master's facets its quads' flat triangles
/// when `triangles`.
fn with_slave_below_on(
    nodes: &mut Vec<[f64; 3]>,
    quads: Vec<[usize; 4]>,
    at: [f64; 3],
    triangles: bool,
) -> Vec<ContactSurface> {
    let first = nodes.len();
    let h = 0.01;
    for (dx, dy) in [(-h, -h), (-h, h), (h, h), (h, -h)] {
        nodes.push([at[0] + dx, at[1] + dy, at[2]]);
    }
    // Clockwise seen from above: the outward normal is down.
    let slave = vec![[first, first + 1, first + 2, first + 3]];
    let master = if triangles {
        ContactSurface::from_quads_as_triangles(&quads, nodes).unwrap()
    } else {
        ContactSurface::from_quads(&quads, nodes).unwrap()
    };
    vec![master, ContactSurface::from_quads(&slave, nodes).unwrap()]
}

#[test]
fn a_node_in_the_pocket_between_two_surfaces_is_held_off_both() {
    let (nodes, surfaces) = pocket();
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let mut c = contact(surfaces);
    c.pair(&x);
    let eval = c.evaluate(&x, false);
    let slave_terms = |k: usize| {
        let mut masters: Vec<(usize, f64)> = eval
            .terms
            .iter()
            .filter(|t| t.slave == (2, k))
            .map(|t| (t.master.0, t.penetration))
            .collect();
        masters.sort_by_key(|m| m.0);
        masters
    };
    for k in 0..4 {
        let terms = slave_terms(k);
        let in_pocket = nodes[c.surfaces()[2].nodes[k]][0] < 0.0;
        // The nodes at x = -DEPTH press into both walls, each by DEPTH; the
        // others into A only (B is farther than the search distance).
        let expected: &[usize] = if in_pocket { &[0, 1] } else { &[0] };
        assert_eq!(
            terms.iter().map(|t| t.0).collect::<Vec<_>>(),
            expected,
            "node {k}: {terms:?}"
        );
        for (m, pen) in terms {
            assert!(
                (pen - DEPTH).abs() < 1e-12,
                "node {k} into surface {m}: {pen}"
            );
        }
    }
    // The force on a node in the pocket pushes it out of both walls: +x and +z.
    let node = c.surfaces()[2].nodes[0];
    let mut f = [0.0; 3];
    for t in eval.terms.iter().filter(|t| t.slave == (2, 0)) {
        for i in 0..3 {
            f[i] -= t.force[i];
        }
    }
    assert!(
        f[0] > 0.0 && f[2] > 0.0 && f[1].abs() < 1e-12 * f[0],
        "force on node {node}: {f:?}"
    );
    assert!(
        (f[0] - f[2]).abs() < 1e-12 * f[0],
        "equal depths, equal pushes: {f:?}"
    );
}

#[test]
fn each_surface_pair_keeps_its_own_multiplier() {
    let (nodes, surfaces) = pocket();
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let mut c = contact(surfaces);
    c.pair(&x);
    let eval = c.evaluate(&x, false);
    let before = c.state_snapshot();
    c.augment(&x, &eval);
    // After the update the multipliers are the pressures: with the same
    // penetration the pressure of each pair doubles (lambda + eps p with
    // lambda = eps p), against either wall.
    let again = c.evaluate(&x, false);
    for t in eval.terms.iter().filter(|t| t.pressure > 0.0) {
        let u = again
            .terms
            .iter()
            .find(|u| u.slave == t.slave && u.master == t.master)
            .expect("the pair is still evaluated");
        assert!(
            (u.pressure - 2.0 * t.pressure).abs() < 1e-12 * t.pressure,
            "{t:?} -> {u:?}"
        );
    }
    assert!(
        again
            .terms
            .iter()
            .filter(|t| t.slave == (2, 0) && t.pressure > 0.0)
            .count()
            == 2
    );
    // A step redone from the snapshot starts from the old multipliers.
    c.restore(&before);
    assert_eq!(c.evaluate(&x, false), eval);
}

/// A ridge: facet A over x in [-1, 0] on the plane z = x / 5, facet B over
/// x in [0, 1] on z = -x / 5 (outward normal up), y in [0, 1]; and a small
/// slave quad facing down with its centre at `at`. Nodes, and the
/// surfaces ridge, slave.
fn ridge(at: [f64; 3]) -> (Vec<[f64; 3]>, Vec<ContactSurface>) {
    let mut nodes = Vec::new();
    for y in [0.0, 1.0] {
        for x in [-1.0, 0.0, 1.0] {
            nodes.push([x, y, -0.2 * f64::abs(x)]);
        }
    }
    // Counter-clockwise seen from above: the outward normal is up.
    let ridge = vec![[0, 1, 4, 3], [1, 2, 5, 4]];
    let surfaces = with_slave_below(&mut nodes, ridge, at);
    (nodes, surfaces)
}

#[test]
fn a_node_that_slid_off_its_facet_is_paired_afresh_at_convergence() {
    // Paired on facet A just above it, the slave then slides over the
    // ridge and ends below facet B's plane z = -x / 5, where A's plane
    // carried on would have it deep inside (0.2 mm) and pressing hard.
    let (nodes, surfaces) = ridge([-0.5, 0.5, -0.099]);
    let x0: Vec<f64> = nodes.iter().flatten().copied().collect();
    let mut c = contact(surfaces);
    c.pair(&x0);
    let slave_terms = |eval: &tidens_contact::ContactEvaluation| -> Vec<(usize, usize, f64)> {
        eval.terms
            .iter()
            .filter(|t| t.slave.0 == 1)
            .map(|t| (t.slave.1, t.master.1, t.penetration))
            .collect()
    };
    let before = slave_terms(&c.evaluate(&x0, false));
    assert!(
        !before.is_empty() && before.iter().all(|&(_, f, _)| f == 0),
        "{before:?}"
    );
    let mut x = x0.clone();
    for k in 6..10 {
        x[3 * k] += 1.0;
        x[3 * k + 2] = -0.12;
    }
    // Kept on A, the nodes are measured on A's plane carried past the ridge.
    let kept = slave_terms(&c.evaluate(&x, false));
    assert!(kept.iter().all(|&(_, f, _)| f == 0), "{kept:?}");
    // Paired afresh: all four touch B, each inside it by (-x / 5 - z) cos(atan 0.2).
    assert!(kept.iter().all(|&(_, _, p)| p > 0.19), "{kept:?}");
    assert_eq!(c.repair(&x), 4);
    let after = slave_terms(&c.evaluate(&x, false));
    assert_eq!(after.len(), 4, "{after:?}");
    for (k, f, p) in after {
        let node = c.surfaces()[1].nodes[k];
        let depth = (-0.2 * x[3 * node] - x[3 * node + 2]) / 1.04f64.sqrt();
        assert_eq!(f, 1, "node {k} on facet {f}");
        assert!((p - depth).abs() < 1e-12, "node {k}: {p} against {depth}");
    }
    // Nothing left to pair afresh: the next repair finds no new link.
    assert_eq!(c.repair(&x), 0);
}

/// A thin wedge, the tip of a slender particle: its upper face A (one quad,
/// x in [0, 1], on z = 0, outward normal up) and its lower face B (two
/// quads, x in [0, 0.5] and [0.5, 1], on z = -0.1 (1 - x), outward normal
/// down) meet along the tip x = 1; y in [0, 1]. And a small slave quad
/// facing down with its centre at `at`. Nodes, and the surfaces wedge,
/// slave.
fn wedge(at: [f64; 3]) -> (Vec<[f64; 3]>, Vec<ContactSurface>) {
    wedge_on(at, false)
}

/// As [`wedge`], on flat triangle facets when `triangles`.
fn wedge_on(at: [f64; 3], triangles: bool) -> (Vec<[f64; 3]>, Vec<ContactSurface>) {
    let lower = |x: f64| -0.1 * (1.0 - x);
    let mut nodes = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    for x in [0.0, 0.5] {
        nodes.push([x, 0.0, lower(x)]);
        nodes.push([x, 1.0, lower(x)]);
    }
    // Counter-clockwise about the outward normal: A seen from above, B
    // from below.
    let wedge = vec![[0, 1, 2, 3], [4, 5, 7, 6], [6, 7, 2, 1]];
    let surfaces = with_slave_below_on(&mut nodes, wedge, at, triangles);
    (nodes, surfaces)
}

fn wedge_terms(at: [f64; 3], search_distance: f64) -> Vec<(usize, f64)> {
    let (nodes, surfaces) = wedge(at);
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let mut c = contact_within(surfaces, search_distance);
    c.pair(&x);
    c.evaluate(&x, false)
        .terms
        .iter()
        .filter(|t| t.slave.0 == 1)
        .map(|t| (t.master.1, t.penetration))
        .collect()
}

#[test]
fn a_node_near_a_slender_tip_is_measured_on_its_own_side() {
    // 1e-3 mm into the upper face, 0.75 along the wedge: the quad of the
    // lower face around x = 0.75, which shares the tip's nodes with A,
    // has the node's projection at its centre (A: at three quarters of
    // its half-width) but lies 0.024 mm away, on the other side of the
    // tip; measured on it, the node would be 0.024 mm deep.
    let terms = wedge_terms([0.75, 0.5, -1e-3], 0.05);
    assert_eq!(terms.len(), 4, "{terms:?}");
    for (facet, depth) in terms {
        assert_eq!(facet, 0, "paired across the tip");
        assert!((depth - 1e-3).abs() < 1e-12, "{depth}");
    }
}

#[test]
fn a_node_beyond_a_tip_is_not_measured_on_a_face_carried_past_it() {
    // Beyond the tip (x = 1.08) and below the upper face's plane: outside
    // the wedge, 0.08 mm from its tip. Upper face A carried past its edge
    // would read the node 0.01 mm deep; its projection falls 0.16 of the
    // half-width beyond A's edge (and 0.32 beyond the lower quad's).
    let terms = wedge_terms([1.08, 0.5, -0.01], 0.2);
    assert!(terms.is_empty(), "{terms:?}");
    // Just past the edge (within a twentieth of the half-width) and 1e-3
    // mm below the upper face's plane: the two nodes 0.002 mm past the tip
    // are paired with A (the surface's nearest point, on the tip, is
    // 0.0022 mm off, within a tenth of the search distance of what A
    // reads); the two 0.022 mm past it are 0.022 mm from the surface, which
    // A, reading them 1e-3 mm deep, contradicts, and they are not.
    let terms = wedge_terms([1.012, 0.5, -0.001], 0.2);
    assert_eq!(terms.len(), 2, "{terms:?}");
    assert!(
        terms
            .iter()
            .all(|&(f, d)| f == 0 && (d - 1e-3).abs() < 1e-12),
        "{terms:?}"
    );
}

#[test]
fn a_node_beside_a_sharp_tip_is_not_pressed_by_the_face_whose_plane_it_is_behind() {
    // Slave nodes 0.01 mm below the upper face's plane, 0.001 and 0.021 mm
    // past the tip (within the margin a link is made at): outside the
    // wedge, 0.01 and 0.023 mm from its tip, in front of the lower face.
    // Carried past its edge, A would read them 0.01 mm deep; the side of
    // the surface that parry's pseudo-normals give says they are outside,
    // and no facet presses them. (On the sc2 cell of c/a = 5 at level 3,
    // on triangles, a node 4.8e-3 mm from a particle's tip, beyond a fold
    // of its facets, was paired with the facet whose plane it was behind,
    // 0.015 of the facet past its edge, and read 4.8e-3 mm deep: pushed
    // out at every step's start at 3e5 MPa, it stalled the run at rho =
    // 0.835.)
    for triangles in [true, false] {
        let (nodes, surfaces) = wedge_on([1.011, 0.5, -0.01], triangles);
        let x: Vec<f64> = nodes.iter().flatten().copied().collect();
        let mut c = contact_within(surfaces, 0.05);
        c.pair(&x);
        let pressed: Vec<_> = c
            .evaluate(&x, false)
            .terms
            .iter()
            .filter(|t| t.slave.0 == 1 && t.penetration > 0.0)
            .map(|t| (t.slave.1, t.master.1, t.penetration))
            .collect();
        assert!(pressed.is_empty(), "triangles {triangles}: {pressed:?}");
    }
}

#[test]
fn a_link_is_made_within_a_narrower_margin_than_it_is_kept() {
    // Slave nodes 1e-3 mm into the upper face's plane, 0.03 and 0.05 mm
    // beyond the tip (0.06 and 0.1 of the half-width past A's edge): not
    // paired afresh.
    let terms = wedge_terms([1.04, 0.5, -0.001], 0.2);
    assert!(terms.is_empty(), "{terms:?}");
    // Paired 0.002 and 0.022 mm beyond the tip, then carried 0.02 mm
    // further (0.044 and 0.084 of the half-width past A's edge): the links
    // stay (dropped only beyond a tenth of the half-width), so a node
    // cannot be dropped and paired again at one state. (The search
    // distance 0.3 mm lets A pair the nodes 0.022 mm from the tip that it
    // reads 1e-3 mm deep: within a tenth of it, 0.03 mm.)
    let (nodes, surfaces) = wedge([1.012, 0.5, -0.001]);
    let mut x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let mut c = contact_within(surfaces, 0.3);
    c.pair(&x);
    let slave_terms = |c: &ParticleContact, x: &[f64]| -> Vec<(usize, f64)> {
        c.evaluate(x, false)
            .terms
            .iter()
            .filter(|t| t.slave.0 == 1)
            .map(|t| (t.master.1, t.penetration))
            .collect()
    };
    assert_eq!(slave_terms(&c, &x).len(), 4);
    let slave_nodes = c.surfaces()[1].nodes.clone();
    for &n in &slave_nodes {
        x[3 * n] += 0.02;
    }
    assert_eq!(c.repair(&x), 0);
    assert!(!c.relink(&x));
    let kept = slave_terms(&c, &x);
    assert_eq!(kept.len(), 4, "{kept:?}");
    assert!(
        kept.iter()
            .all(|&(f, d)| f == 0 && (d - 1e-3).abs() < 1e-12),
        "{kept:?}"
    );
    // Carried 0.03 mm further (0.104 and 0.144 of the half-width past the
    // edge): between two Newton iterations the links go, and no face
    // takes the nodes beyond the tip.
    for &n in &slave_nodes {
        x[3 * n] += 0.03;
    }
    assert!(c.relink(&x));
    assert!(!c.relink(&x));
    let left = slave_terms(&c, &x);
    assert!(left.is_empty(), "{left:?}");
}
