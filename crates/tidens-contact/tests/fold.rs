//! A node linked to one half of a quad split into two triangles, carried
//! across the quad's diagonal where the halves fold inward (a valley): a
//! second term, on the other half's plane, holds it off that half, so
//! that the deeper of the node's terms is its true depth below the two
//! halves; its link's plane alone, extended past the fold under the other
//! half, read it shallower.

#[path = "support/frictionless.rs"]
mod support;

use support::frictionless;
use tidens_contact::{ContactEvaluation, ContactSurface, ParticleContact};

/// Rise of each half's off-diagonal corner above the diagonal [mm].
const RISE: f64 = 0.1;

/// Depth of the slave node below the fold's line [mm].
const DEPTH: f64 = 0.02;

/// Half-width of the slave quad [mm].
const SLAVE: f64 = 0.01;

/// The master: the unit quad whose diagonal from (0, 0) to (1, 1) lies on
/// z = 0 and whose other corners rise by `rise` (the surface z = rise |x -
/// y|, a valley along x = y for a positive rise, a ridge for a negative
/// one), outward normal +z. The slave: a small quad facing -z, centred at
/// `centre`, its first node the one measured. Nodes and the two surfaces.
fn fold(rise: f64, centre: [f64; 3]) -> (Vec<[f64; 3]>, Vec<ContactSurface>) {
    let mut nodes = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, rise],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, rise],
    ];
    let [cx, cy, cz] = centre;
    for (dx, dy) in [(0.0, 0.0), (-SLAVE, 0.0), (-SLAVE, SLAVE), (0.0, SLAVE)] {
        nodes.push([cx + dx, cy + dy, cz]);
    }
    let master = ContactSurface::from_quads_as_triangles(&[[0, 1, 2, 3]], &nodes).unwrap();
    // Clockwise seen from +z: the outward normal is -z.
    let slave = ContactSurface::from_quads(&[[4, 5, 6, 7]], &nodes).unwrap();
    (nodes, vec![master, slave])
}

fn contact(surfaces: Vec<ContactSurface>) -> ParticleContact {
    frictionless(surfaces, 0.1)
}

/// Distance from `p` to the triangle `t` (brute force: its plane, edges
/// and corners).
fn distance_to_triangle(p: [f64; 3], t: [[f64; 3]; 3]) -> f64 {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (e1, e2) = (sub(t[1], t[0]), sub(t[2], t[0]));
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let nn = dot(n, n).sqrt();
    let d = sub(p, t[0]);
    let h = dot(d, n) / nn;
    let foot = [0, 1, 2].map(|i| p[i] - h * n[i] / nn);
    let inside = (0..3).all(|i| {
        let (a, b) = (t[i], t[(i + 1) % 3]);
        let e = sub(b, a);
        let c = [
            e[1] * (foot[2] - a[2]) - e[2] * (foot[1] - a[1]),
            e[2] * (foot[0] - a[0]) - e[0] * (foot[2] - a[2]),
            e[0] * (foot[1] - a[1]) - e[1] * (foot[0] - a[0]),
        ];
        dot(c, n) >= 0.0
    });
    if inside {
        return h.abs();
    }
    (0..3)
        .map(|i| {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let e = sub(b, a);
            let s = (dot(sub(p, a), e) / dot(e, e)).clamp(0.0, 1.0);
            let q = [0, 1, 2].map(|k| a[k] + s * e[k]);
            dot(sub(p, q), sub(p, q)).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The contact terms with the slave's links made with the measured node
/// at `start` and kept while the slave moves to put it at `at`.
fn evaluation(rise: f64, start: [f64; 3], at: [f64; 3]) -> ContactEvaluation {
    let (mut nodes, surfaces) = fold(rise, start);
    let mut c = contact(surfaces);
    let flat = |nodes: &[[f64; 3]]| nodes.iter().flatten().copied().collect::<Vec<f64>>();
    c.pair(&flat(&nodes));
    let shift = [at[0] - start[0], at[1] - start[1], at[2] - start[2]];
    for node in &mut nodes[4..] {
        for i in 0..3 {
            node[i] += shift[i];
        }
    }
    c.evaluate(&flat(&nodes), false)
}

/// The terms of the measured node (penetration, facet, fold weight), its
/// link made with the node at `start` and kept while it moves to `at`.
fn terms(rise: f64, start: [f64; 3], at: [f64; 3]) -> Vec<(f64, usize, Option<f64>)> {
    evaluation(rise, start, at)
        .terms
        .iter()
        .filter(|t| t.slave == (1, 0))
        .map(|t| (t.penetration, t.master.1, t.fold.map(|(_, w)| w)))
        .collect()
}

/// A point on the line across the fold through (0.5, 0.5), `s` along
/// (1, -1, 0) / sqrt 2 from it, `DEPTH` below z = 0.
fn across(s: f64) -> [f64; 3] {
    let r = s / 2f64.sqrt();
    [0.5 + r, 0.5 - r, -DEPTH]
}

/// The true depth of `p` below the two halves (inside: the distance to
/// the nearer half).
fn depth(rise: f64, p: [f64; 3]) -> f64 {
    let (nodes, _) = fold(rise, [0.0; 3]);
    let a = distance_to_triangle(p, [nodes[0], nodes[1], nodes[2]]);
    let b = distance_to_triangle(p, [nodes[0], nodes[2], nodes[3]]);
    a.min(b)
}

/// Linked on the first half's side and carried across a valley to the
/// other half's, the node has its link's term and a term on the other
/// half at its full weight (the fold's sine, 0.28, is above
/// `FULL_FOLD`), and the deeper of the two reads its true depth (the
/// distance to the nearer half) wherever it projects on one of the
/// halves; below the fold's line, where it projects on neither, both
/// read less than the distance to the line, as a node resting in a
/// corner is held by both walls. The link's plane alone read up to 0.011
/// mm less than the true depth (at s = -0.04, true depth 0.025 mm).
#[test]
fn across_a_valley_the_deeper_term_reads_the_true_depth() {
    let start = across(0.02);
    let wedge = DEPTH * (2.0f64.sqrt() * RISE).atan().tan();
    let mut largest_gap = 0.0f64;
    for i in 0..=40 {
        let s = 0.02 - 0.06 * f64::from(i) / 40.0;
        let p = across(s);
        let t = terms(RISE, start, p);
        assert_eq!(t.len(), 2, "s = {s}: {t:?}");
        assert_eq!(t[0].2, None);
        assert_eq!(t[1].2, Some(1.0));
        assert_ne!(t[0].1, t[1].1);
        let deepest = t[0].0.max(t[1].0);
        let truth = depth(RISE, p);
        if s.abs() > 1.01 * wedge {
            assert!(
                (deepest - truth).abs() <= 1e-12,
                "s = {s}: reads {deepest}, true depth {truth}"
            );
        } else {
            assert!(
                deepest <= truth + 1e-12 && deepest > 0.98 * truth,
                "s = {s}: {deepest} {truth}"
            );
        }
        largest_gap = largest_gap.max(truth - t[0].0);
    }
    assert!(
        largest_gap > 1e-2,
        "the link's plane under-read by {largest_gap}"
    );
}

/// Where the halves fold outward (a ridge) the link's plane extended lies
/// above the other half: the link alone holds the node, reading at least
/// its true depth.
#[test]
fn across_a_ridge_the_link_alone_holds_the_node() {
    let start = across(0.02);
    for i in 0..=20 {
        let s = 0.02 - 0.04 * f64::from(i) / 20.0;
        let mut p = across(s);
        p[2] -= 0.01;
        let t = terms(-RISE, start, p);
        assert_eq!(t.len(), 1, "s = {s}: {t:?}");
        assert!(t[0].0 >= depth(-RISE, p) - 1e-12);
    }
}

/// The term across a fold weighs in smoothly as the fold opens: a flat
/// quad has none, a fold of a tenth of `FULL_FOLD` weighs
/// 35 t^4 - 84 t^5 + 70 t^6 - 20 t^7 at t = 0.1 (0.00273), a fold
/// beyond it 1.
#[test]
fn the_term_across_a_fold_weighs_in_with_the_fold() {
    let p = across(-0.01);
    let start = across(0.02);
    let weight = |rise: f64| terms(rise, start, p).iter().find_map(|t| t.2);
    assert_eq!(weight(0.0), None);
    // The fold's sine: the other corner's height over the link's plane
    // over its distance from the diagonal, sqrt(2) rise / (1/2 + rise^2).
    let rise_for = |sine: f64| (2f64.sqrt() - (2.0 - 2.0 * sine * sine).sqrt()) / (2.0 * sine);
    let t = 0.1;
    let rise = rise_for(t * tidens_contact::FULL_FOLD);
    let w = weight(rise).unwrap();
    let expected = t.powi(4) * (35.0 - 84.0 * t + 70.0 * t * t - 20.0 * t.powi(3));
    assert!(
        (w - expected).abs() < 1e-9 * expected,
        "{w} against {expected}"
    );
    // The evaluation's largest penetration counts the term across the
    // fold at its weight, as the augmented Lagrangian enforces it: past
    // the fold the node reads deeper on the neighbour's plane than on its
    // link's, but that reading times the weight is the smaller, and the
    // largest penetration is not the unweighted reading.
    let eval = evaluation(rise, start, p);
    let mine: Vec<_> = eval.terms.iter().filter(|t| t.slave == (1, 0)).collect();
    let (own, across) = (mine[0].penetration, mine[1].penetration);
    assert!(across > own && w * across < own, "{own} {across}");
    let largest = eval.max_penetration();
    assert!(
        largest >= own && largest < across,
        "{largest}: {own} {across}"
    );
    assert_eq!(weight(rise_for(2.0 * tidens_contact::FULL_FOLD)), Some(1.0));
}
