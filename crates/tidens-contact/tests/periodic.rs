//! Contact across a periodic boundary: a particle against the periodic
//! images ([`ContactSurface::image`]) of another gives the same forces as the
//! two touching directly.

use tidens_contact::{ContactMode, ContactSettings, ContactSurface, ParticleContact};

/// A 3 x 3 grid of nodes over [-0.1, 0.1]^2 at heights `z(x, y)`, its four
/// quads counter-clockwise about +z (`up`) or -z, numbered from `first`.
fn patch(nodes: &mut Vec<[f64; 3]>, z: impl Fn(f64, f64) -> f64, up: bool) -> Vec<[usize; 4]> {
    let first = nodes.len();
    for j in 0..3 {
        for i in 0..3 {
            let (x, y) = (-0.1 + 0.1 * i as f64, -0.1 + 0.1 * j as f64);
            // Off-centre and tilted, so that no two nodes read alike.
            nodes.push([x + 0.013 * y, y, z(x, y) + 0.004 * x]);
        }
    }
    let id = |i: usize, j: usize| first + 3 * j + i;
    let mut quads = Vec::new();
    for j in 0..2 {
        for i in 0..2 {
            let q = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            quads.push(if up { q } else { [q[0], q[3], q[2], q[1]] });
        }
    }
    quads
}

/// A bowl facing down (A, on top) and a dome facing up (B) that presses
/// 4.3e-3 mm into it at its centre; B shifted by `shift`.
fn bowl_and_dome(nodes: &mut Vec<[f64; 3]>, shift: [f64; 3]) -> [Vec<[usize; 4]>; 2] {
    let a = patch(nodes, |x, y| 0.1 * (x * x + y * y), false);
    let b_first = nodes.len();
    let b = patch(nodes, |x, y| 4.3e-3 - 0.1 * (x * x + y * y), true);
    for p in &mut nodes[b_first..] {
        for i in 0..3 {
            p[i] += shift[i];
        }
    }
    [a, b]
}

fn contact(surfaces: Vec<ContactSurface>) -> ParticleContact {
    ParticleContact::new(
        surfaces,
        ContactSettings {
            mode: ContactMode::Frictionless,
            penalty: 100.0,
            search_distance: 0.05,
            curvature_stiffness: true,
            touch_stiffness_cap: f64::INFINITY,
        },
    )
    .unwrap()
}

/// Force on each dof of `x` (length of `x`) and the sorted penetrations of
/// the pressed terms, after pairing.
fn forces(c: &mut ParticleContact, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    c.pair(x);
    let eval = c.evaluate(x, true);
    let mut f = vec![0.0; x.len()];
    let mut pens = Vec::new();
    for t in &eval.terms {
        for (d, v) in t.dofs.iter().zip(&t.force) {
            f[*d] += v;
        }
        if t.pressure > 0.0 {
            pens.push(t.penetration);
        }
    }
    pens.sort_by(f64::total_cmp);
    (f, pens)
}

#[test]
fn contact_with_the_images_of_a_particle_is_contact_with_the_particle() {
    for triangles in [true, false] {
        let build = |quads: &[[usize; 4]], nodes: &[[f64; 3]]| {
            if triangles {
                ContactSurface::from_quads_as_triangles(quads, nodes).unwrap()
            } else {
                ContactSurface::from_quads(quads, nodes).unwrap()
            }
        };
        // Directly: A and B touching.
        let mut nodes = Vec::new();
        let [a, b] = bowl_and_dome(&mut nodes, [0.0; 3]);
        let x: Vec<f64> = nodes.iter().flatten().copied().collect();
        let mut direct = contact(vec![build(&a, &nodes), build(&b, &nodes)]);
        let (f_direct, pens_direct) = forces(&mut direct, &x);
        assert!(pens_direct.len() >= 4, "{pens_direct:?}");

        // Periodically: B one period t = (1, 0, 0) away from A, which
        // touches B's image at +t; B touches A's image at -t.
        let period = [1.0, 0.0, 0.0];
        let mut nodes = Vec::new();
        let [a, b] = bowl_and_dome(&mut nodes, period.map(|t| -t));
        let n = nodes.len();
        let copy = |nodes: &mut Vec<[f64; 3]>, range: std::ops::Range<usize>, sign: f64| {
            for k in range {
                let p = nodes[k];
                nodes.push([0, 1, 2].map(|i| p[i] + sign * period[i]));
            }
        };
        let b_first = 9;
        copy(&mut nodes, b_first..n, 1.0); // B's image at +t: nodes n..n+9
        copy(&mut nodes, 0..b_first, -1.0); // A's image at -t: nodes n+9..n+18
        let (sa, sb) = (build(&a, &nodes), build(&b, &nodes));
        let b_image = sb.image(|k| k - b_first + n).unwrap();
        let a_image = sa.image(|k| k + n + 9).unwrap();
        let x: Vec<f64> = nodes.iter().flatten().copied().collect();
        let mut periodic = contact(vec![sa, sb, b_image, a_image]);
        let (f_periodic, pens_periodic) = forces(&mut periodic, &x);

        // Image forces act on their originals.
        let original = |node: usize| match node {
            k if k < n => k,
            k if k < n + 9 => k - n + b_first,
            k => k - n - 9,
        };
        let mut f_folded = vec![0.0; 3 * n];
        for (d, v) in f_periodic.iter().enumerate() {
            f_folded[3 * original(d / 3) + d % 3] += v;
        }
        let scale = f_direct.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 0.0);
        for (d, (p, q)) in f_folded.iter().zip(&f_direct).enumerate() {
            assert!(
                (p - q).abs() <= 1e-12 * scale,
                "triangles {triangles}, dof {d}: {p} against {q}"
            );
        }
        // Every pressed node of either pass once, as deep as directly.
        assert_eq!(
            pens_periodic.len(),
            pens_direct.len(),
            "{pens_periodic:?} {pens_direct:?}"
        );
        for (p, q) in pens_periodic.iter().zip(&pens_direct) {
            assert!((p - q).abs() <= 1e-15, "{p} against {q}");
        }
        // An image is never a slave.
        let eval = periodic.evaluate(&x, false);
        assert!(eval.terms.iter().all(|t| t.slave.0 < 2));
    }
}

#[test]
fn an_image_needs_its_nodes_in_the_originals_order() {
    let mut nodes = Vec::new();
    let [a, _] = bowl_and_dome(&mut nodes, [0.0; 3]);
    let s = ContactSurface::from_quads(&a, &nodes).unwrap();
    assert!(s.image(|k| 100 - k).is_err());
    let image = s.image(|k| k + 50).unwrap();
    assert!(image.master_only && !s.master_only);
    assert_eq!(image.areas, s.areas);
    assert!(image.nodes.iter().zip(&s.nodes).all(|(i, o)| *i == o + 50));
}

#[test]
fn the_depth_of_nodes_inside_is_seen_paired_or_not() {
    // The dome presses 4.3e-3 mm into the bowl at its centre. Before any
    // pairing no term measures it; the signed distance does, and once
    // paired the deepest term reads the same to the faceting (a term
    // measures on its facet's plane, the distance on the nearest facet).
    // The bowl is steeper than `bowl_and_dome`'s, so that the dome's
    // centre lies within the box of the bowl's nodes, as a particle's
    // solid lies within its surface's box (`max_depth` looks only there).
    let mut nodes = Vec::new();
    let a = patch(&mut nodes, |x, y| 0.25 * (x * x + y * y), false);
    let b = patch(&mut nodes, |x, y| 4.3e-3 - 0.1 * (x * x + y * y), true);
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let surfaces = vec![
        ContactSurface::from_quads_as_triangles(&a, &nodes).unwrap(),
        ContactSurface::from_quads_as_triangles(&b, &nodes).unwrap(),
    ];
    let mut c = contact(surfaces);
    assert!(c.evaluate(&x, false).terms.is_empty());
    let depth = c.max_depth(&x);
    assert!(depth > 4e-3 && depth < 4.4e-3, "{depth}");
    c.pair(&x);
    // The term reads the node on its facet's plane, the distance on the
    // faceted surface: they differ where the node's nearest point leaves
    // that facet, at most by the facets' tilt (about 0.05, so 1 - cos of
    // it, 1.3e-3).
    let deepest = c.evaluate(&x, false).max_penetration();
    assert!(
        deepest >= depth && deepest - depth < 1.3e-3 * depth,
        "{deepest} against {depth}"
    );
    // Apart, nothing is inside.
    let apart: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(d, v)| if d >= 27 && d % 3 == 2 { v - 0.01 } else { *v })
        .collect();
    assert_eq!(c.max_depth(&apart), 0.0);
}
