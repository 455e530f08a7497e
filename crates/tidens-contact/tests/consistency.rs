//! The contact force is the gradient of the contact energy and the tangent
//! its Hessian: both checked against finite differences on two curved
//! patches pressed into each other, meshed with bilinear quads and with flat
//! triangles.

use tidens_contact::{ContactMode, ContactSettings, ContactSurface, ParticleContact};

/// Two 3x3-quad patches: a dome bulging up (outward normal +z), a dome
/// bulging down above it (outward normal -z), overlapping by `overlap`.
/// Nodes, and the quads of the lower and of the upper patch.
type Patches = (Vec<[f64; 3]>, Vec<[usize; 4]>, Vec<[usize; 4]>);

fn patches(overlap: f64) -> Patches {
    let mut nodes = Vec::new();
    let n = 4;
    for (sheet, z0, sign) in [(0, 0.0, 1.0), (1, 0.0, -1.0)] {
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (
                    i as f64 / 3.0 - 0.5 + 0.07 * sheet as f64,
                    j as f64 / 3.0 - 0.5 - 0.05 * sheet as f64,
                );
                let dome = 0.2 * (1.0 - x * x - y * y);
                nodes.push([
                    x,
                    y,
                    z0 + sign * (dome - 0.2) + if sheet == 1 { 0.2 - overlap } else { 0.2 },
                ]);
            }
        }
    }
    let id = |sheet: usize, i: usize, j: usize| sheet * n * n + j * n + i;
    let mut lower = Vec::new();
    let mut upper = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            lower.push([
                id(0, i, j),
                id(0, i + 1, j),
                id(0, i + 1, j + 1),
                id(0, i, j + 1),
            ]);
            upper.push([
                id(1, i, j),
                id(1, i, j + 1),
                id(1, i + 1, j + 1),
                id(1, i + 1, j),
            ]);
        }
    }
    (nodes, lower, upper)
}

fn total_force(c: &ParticleContact, x: &[f64]) -> Vec<f64> {
    let mut f = vec![0.0; x.len()];
    for t in c.evaluate(x, false).terms {
        for (d, v) in t.dofs.iter().zip(&t.force) {
            f[*d] += v;
        }
    }
    f
}

/// Each quad split into two triangles, counter-clockwise like it.
fn split(quads: &[[usize; 4]]) -> Vec<[usize; 3]> {
    quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect()
}

#[test]
fn contact_tangent_equals_finite_differences_of_the_force() {
    let (nodes, lower, upper) = patches(0.06);
    check_tangent(
        vec![
            ContactSurface::from_quads(&lower, &nodes).unwrap(),
            ContactSurface::from_quads(&upper, &nodes).unwrap(),
        ],
        &nodes,
    );
}

#[test]
fn triangle_contact_tangent_equals_finite_differences_of_the_force() {
    let (nodes, lower, upper) = patches(0.06);
    check_tangent(
        vec![
            ContactSurface::from_triangles(&split(&lower), &nodes).unwrap(),
            ContactSurface::from_triangles(&split(&upper), &nodes).unwrap(),
        ],
        &nodes,
    );
}

/// A small quad pressed 2e-5 mm into a valley between two flat triangles
/// (a unit quad split along its diagonal, its other corners raised so that
/// the fold's sine is half of `FULL_FOLD`), across the fold's line: each
/// node has its link's term and a term across the fold, whose weight
/// depends on the corners of both triangles: the terms' dofs take in the
/// far corner, the force is the gradient of the weighted energy and the
/// tangent its Hessian. Without the coupling the weight brings, the
/// tangent's entry of the slave node's normal was 0.2 % off its
/// differences (7.493e-5 against 7.477e-5 N/mm), and this test failed.
#[test]
fn a_term_across_a_slight_fold_has_the_weights_derivative_in_its_tangent() {
    let nodes = quad_over_a_fold(0.5 * tidens_contact::FULL_FOLD, 2e-5);
    let contact = paired(fold_surfaces(&nodes), &nodes);
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let eval = contact.evaluate(&x, true);
    let across = eval
        .terms
        .iter()
        .filter(|t| t.pressure > 0.0 && t.fold.is_some_and(|(_, w)| w > 0.1 && w < 0.9))
        .count();
    let coupled = eval
        .terms
        .iter()
        .filter(|t| t.dofs.len() > tidens_contact::TERM_DOFS)
        .count();
    assert_eq!((across, coupled), (4, 4));
    check_tangent_of(&contact, &nodes);
}

/// A small quad (nodes 4..8) pressed `depth` mm into a valley between two
/// flat triangles (a unit quad, nodes 0..4, split along its diagonal, its
/// other corners raised so that the fold's sine is `sine`), across the
/// fold's line.
fn quad_over_a_fold(sine: f64, depth: f64) -> Vec<[f64; 3]> {
    // Each half's normal is (-+rise, +-rise, 1): the sine between them is
    // 2 sqrt(2) rise / (1 + 2 rise^2).
    let rise = (1.0 - (1.0 - sine * sine).sqrt()) / (2f64.sqrt() * sine);
    let surface = |x: f64, y: f64| rise * (x - y).abs();
    let mut nodes = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, rise],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, rise],
    ];
    // Across the fold (u) and along it (v), 1e-3 mm from its line; the
    // quad faces -z (clockwise seen from +z).
    let (u, v) = (
        [1.0, -1.0].map(|c| c * 1e-3 / 2f64.sqrt()),
        [1.0, 1.0].map(|c| c * 1e-3 / 2f64.sqrt()),
    );
    for (a, b) in [(1.0, -1.0), (-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let (x, y) = (0.5 + a * u[0] + b * v[0], 0.5 + a * u[1] + b * v[1]);
        nodes.push([x, y, surface(x, y) - depth]);
    }
    nodes
}

/// The two triangles of [`quad_over_a_fold`] and the small quad.
fn fold_surfaces(nodes: &[[f64; 3]]) -> Vec<ContactSurface> {
    vec![
        ContactSurface::from_quads_as_triangles(&[[0, 1, 2, 3]], nodes).unwrap(),
        ContactSurface::from_quads(&[[4, 5, 6, 7]], nodes).unwrap(),
    ]
}

/// A fold term's tangent carries the derivatives of its weight: the
/// coupling `a phi' (dg/du dw/du^T + dw/du dg/du^T)` and `a phi d2w/du2`.
/// On the far corner of the link's triangle, which the weight depends on
/// and the penetration does not, the consistent tangent's column is the
/// derivative of the force. The tangent the solver factorises
/// (`curvature_stiffness: false`) keeps the term's positive semi-definite
/// part: no term makes it indefinite. The quad pressed 1e-3 mm into a fold
/// of a tenth of `FULL_FOLD` (weights of 2.7e-3; where Newton crawled in a
/// random packing, such terms had weights of 1e-3 to 4e-2 and pressures
/// before the weight of about 2e3 MPa). Measured: the consistent columns
/// are off their differences by 1.2e-15 N/mm, their largest entry being
/// 3.6e-7 N/mm; the solver's by 2.8e-8 N/mm (by 3.4e-7 without the
/// weight's Hessian).
#[test]
fn a_fold_terms_tangent_holds_its_weights_derivatives_and_the_solvers_is_positive() {
    let nodes = quad_over_a_fold(0.1 * tidens_contact::FULL_FOLD, 1e-3);
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    for consistent in [true, false] {
        let contact = paired_with(fold_surfaces(&nodes), &nodes, consistent);
        let eval = contact.evaluate(&x, true);
        let coupled: Vec<_> = eval
            .terms
            .iter()
            .filter(|t| t.dofs.len() > tidens_contact::TERM_DOFS)
            .collect();
        assert!(!coupled.is_empty());
        let (mut worst, mut scale) = (0.0_f64, 0.0_f64);
        for t in &coupled {
            let (_, w) = t.fold.unwrap();
            assert!(w > 1e-4 && w < 1e-2, "weight {w}");
            let m = t.dofs.len();
            // Each coupled term's column of a far corner (an appended dof)
            // against the differences of that term's force (the terms keep
            // their links).
            for q in tidens_contact::TERM_DOFS..m {
                let j = t.dofs[q];
                assert!(j < 12, "a far corner of the triangles");
                let force = |dx: f64| {
                    let mut xs = x.clone();
                    xs[j] += dx;
                    let e = contact.evaluate(&xs, false);
                    let same = e
                        .terms
                        .into_iter()
                        .find(|u| u.slave == t.slave && u.master == t.master)
                        .unwrap();
                    assert_eq!(same.dofs, t.dofs);
                    same.force
                };
                let h = 1e-7;
                let (fp, fm) = (force(h), force(-h));
                for p in 0..m {
                    let fd = (fp[p] - fm[p]) / (2.0 * h);
                    worst = worst.max((fd - t.tangent[p * m + q]).abs());
                    scale = scale.max(fd.abs());
                }
            }
            let k = nalgebra::DMatrix::from_row_slice(m, m, &t.tangent);
            let eigen = k.clone().symmetric_eigen().eigenvalues;
            let largest = eigen.amax();
            if consistent {
                // The coupling makes the whole term indefinite.
                assert!(eigen.min() < -1e-6 * largest, "{eigen}");
            } else {
                assert!(eigen.min() > -1e-12 * largest, "{eigen}");
            }
        }
        assert!(scale > 0.0);
        eprintln!(
            "consistent {consistent}: far corners' columns off by {worst:e} N/mm, largest entry {scale:e} N/mm"
        );
        if consistent {
            assert!(
                worst < 1e-3 * scale,
                "the far corners' columns are off by {worst:e} of {scale:e}"
            );
        }
    }
}

/// Tied contact: the nodes pressed in are tied where they touch, then the
/// patches slide against each other (the upper one moved along x and y), so
/// each tie carries a tangential and a normal gap. The vector penalty's
/// tangent must be the Hessian of its energy too.
#[test]
fn tied_contact_tangent_equals_finite_differences_of_the_force() {
    for triangles in [false, true] {
        let (nodes, lower, upper) = patches(0.06);
        let surface = |faces: &[[usize; 4]], nodes: &[[f64; 3]]| {
            if triangles {
                ContactSurface::from_triangles(&split(faces), nodes).unwrap()
            } else {
                ContactSurface::from_quads(faces, nodes).unwrap()
            }
        };
        let surfaces = vec![surface(&lower, &nodes), surface(&upper, &nodes)];
        let mut contact = ParticleContact::new(
            surfaces,
            ContactSettings {
                mode: ContactMode::Tied,
                penalty: 100.0,
                search_distance: 0.3,
                curvature_stiffness: true,
                touch_stiffness_cap: f64::INFINITY,
            },
        )
        .unwrap();
        let x: Vec<f64> = nodes.iter().flatten().copied().collect();
        contact.pair(&x);
        let closed = contact.evaluate(&x, false);
        contact.tie_closed(&closed);
        // Slide the upper patch (nodes 16..32) by (0.03, -0.02, 0.01).
        let mut slid = nodes.clone();
        for p in &mut slid[16..] {
            p[0] += 0.03;
            p[1] -= 0.02;
            p[2] += 0.01;
        }
        check_tangent_of(&contact, &slid);
    }
}

fn check_tangent(surfaces: Vec<ContactSurface>, nodes: &[[f64; 3]]) {
    check_tangent_of(&paired(surfaces, nodes), nodes);
}

/// Frictionless contact among `surfaces` (penalty 100 MPa/mm, the
/// consistent tangent), its nodes paired at `nodes`.
fn paired(surfaces: Vec<ContactSurface>, nodes: &[[f64; 3]]) -> ParticleContact {
    paired_with(surfaces, nodes, true)
}

/// [`paired`], with the tangent's curvature part or without it.
fn paired_with(
    surfaces: Vec<ContactSurface>,
    nodes: &[[f64; 3]],
    curvature_stiffness: bool,
) -> ParticleContact {
    let mut contact = ParticleContact::new(
        surfaces,
        ContactSettings {
            mode: ContactMode::Frictionless,
            penalty: 100.0,
            search_distance: 0.3,
            curvature_stiffness,
            touch_stiffness_cap: f64::INFINITY,
        },
    )
    .unwrap();
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    contact.pair(&x);
    contact
}

/// The assembled tangent of the terms carrying force against central
/// differences of the total contact force at `nodes`.
fn check_tangent_of(contact: &ParticleContact, nodes: &[[f64; 3]]) {
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let eval = contact.evaluate(&x, true);
    assert!(eval.terms.iter().filter(|t| t.pressure > 0.0).count() >= 4);
    // Nodes near but not in contact carry stiffness without force (the
    // predictive part of the tangent): leave them out of the comparison.
    check_tangent_of_terms(contact, &x, |t| t.pressure > 0.0);
}

/// The assembled tangent of the terms `include` takes against central
/// differences of the total contact force at `x`.
fn check_tangent_of_terms(
    contact: &ParticleContact,
    x: &[f64],
    include: impl Fn(&tidens_contact::ContactTerm) -> bool,
) {
    let eval = contact.evaluate(x, true);
    let n = x.len();
    let mut k = vec![0.0; n * n];
    for t in eval.terms.iter().filter(|t| include(t)) {
        let m = t.dofs.len();
        for p in 0..m {
            for q in 0..m {
                k[t.dofs[p] * n + t.dofs[q]] += t.tangent[p * m + q];
            }
        }
    }
    let scale = k.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let h = 1e-7;
    for j in 0..n {
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[j] += h;
        xm[j] -= h;
        let (fp, fm) = (total_force(contact, &xp), total_force(contact, &xm));
        for i in 0..n {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            let an = k[i * n + j];
            assert!(
                (fd - an).abs() < 1e-5 * scale,
                "K[{i},{j}]: analytic {an}, fd {fd}"
            );
        }
    }
}

/// Without its curvature part (`curvature_stiffness: false`, the solver's
/// choice) each pressed term's tangent is the penalty part alone, positive
/// semi-definite; the part left out, the consistent tangent's curvature
/// `a p d2g/du2`, is indefinite (it is what made a tenth to a third of the
/// factorisations on the bcc and fcc cells indefinite).
#[test]
fn the_tangent_without_curvature_is_semidefinite_and_what_it_leaves_out_is_not() {
    let (nodes, lower, upper) = patches(0.06);
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    let contact_with = |curvature_stiffness: bool| {
        let surfaces = vec![
            ContactSurface::from_quads(&lower, &nodes).unwrap(),
            ContactSurface::from_quads(&upper, &nodes).unwrap(),
        ];
        let settings = ContactSettings {
            mode: ContactMode::Frictionless,
            penalty: 100.0,
            search_distance: 0.3,
            curvature_stiffness,
            touch_stiffness_cap: f64::INFINITY,
        };
        let mut c = ParticleContact::new(surfaces, settings).unwrap();
        c.pair(&x);
        c.evaluate(&x, true)
    };
    let (full, plain) = (contact_with(true), contact_with(false));
    assert_eq!(full.terms.len(), plain.terms.len());
    let (mut lowest, mut left_out_lowest, mut left_out_highest) = (f64::INFINITY, 0.0_f64, 0.0_f64);
    for (a, b) in full
        .terms
        .iter()
        .zip(&plain.terms)
        .filter(|(a, _)| a.pressure > 0.0)
    {
        assert_eq!(
            (&a.dofs, &a.force),
            (&b.dofs, &b.force),
            "the forces do not depend on the tangent"
        );
        let m = b.dofs.len();
        let kb = nalgebra::DMatrix::from_row_slice(m, m, &b.tangent);
        let scale = kb.amax();
        lowest = lowest.min(kb.clone().symmetric_eigen().eigenvalues.min() / scale);
        let diff = nalgebra::DMatrix::from_row_slice(m, m, &a.tangent) - kb;
        let ev = diff.symmetric_eigen().eigenvalues;
        left_out_lowest = left_out_lowest.min(ev.min() / scale);
        left_out_highest = left_out_highest.max(ev.max() / scale);
    }
    assert!(
        lowest > -1e-12,
        "a negative eigenvalue {lowest:e} (relative) without curvature"
    );
    assert!(
        left_out_lowest < -1e-3 && left_out_highest > 1e-3,
        "the curvature part is not indefinite: eigenvalues in [{left_out_lowest:e}, {left_out_highest:e}]"
    );
}

/// Two patches apart by 0.01 at the closest point, the nodes near the
/// middle within the touch band (a tenth of the search distance, 0.06),
/// meshed with quads or `triangles`, in contact with `penalty` and a touch
/// force of `stiffness`, paired there: the contact, the nodes and their
/// coordinates.
fn touching_patches(
    triangles: bool,
    penalty: f64,
    stiffness: f64,
) -> (ParticleContact, Vec<[f64; 3]>, Vec<f64>) {
    let (nodes, lower, upper) = patches(-0.01);
    let surface = |faces: &[[usize; 4]]| {
        if triangles {
            ContactSurface::from_triangles(&split(faces), &nodes).unwrap()
        } else {
            ContactSurface::from_quads(faces, &nodes).unwrap()
        }
    };
    let mut contact = ParticleContact::new(
        vec![surface(&lower), surface(&upper)],
        ContactSettings {
            mode: ContactMode::Frictionless,
            penalty,
            search_distance: 0.6,
            curvature_stiffness: true,
            touch_stiffness_cap: f64::INFINITY,
        },
    )
    .unwrap();
    contact.set_touch_force(Some(stiffness));
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    contact.pair(&x);
    (contact, nodes, x)
}

/// The flat coordinates of the patches of [`touching_patches`] with the
/// upper patch (nodes 16..32) moved down by `down` and sideways by 0.002.
fn upper_patch_moved(nodes: &[[f64; 3]], down: f64) -> Vec<f64> {
    let mut moved = nodes.to_vec();
    for p in &mut moved[16..] {
        p[0] += 0.002;
        p[2] -= down;
    }
    moved.iter().flatten().copied().collect()
}

/// The touch force ([`ParticleContact::set_touch_force`]): nodes near the
/// other surface but apart from it carry a spring on the change of their
/// penetration since pairing. At the pairing configuration it is zero;
/// moved on, each node's force is the spring's on its own reading, and
/// the tangent, curvature included, is the force's derivative.
#[test]
fn the_touch_force_is_a_spring_on_the_change_of_penetration_since_pairing() {
    for triangles in [false, true] {
        let stiffness = 7.0;
        let (contact, nodes, x) = touching_patches(triangles, 100.0, stiffness);
        let at_pairing = contact.evaluate(&x, false);
        assert!(at_pairing.terms.len() >= 4);
        assert!(
            at_pairing
                .terms
                .iter()
                .all(|t| t.pressure == 0.0 && t.force.iter().all(|f| *f == 0.0))
        );
        // The upper patch (nodes 16..32) moved down by 0.004 and sideways:
        // still apart, each node closer by about 0.004.
        let xm = upper_patch_moved(&nodes, 0.004);
        let eval = contact.evaluate(&xm, true);
        for t in &eval.terms {
            assert_eq!(t.pressure, 0.0);
            let change = t.penetration - at_pairing_reading(&at_pairing, t);
            assert!(change > 0.003 && change < 0.005, "{change}");
            // The slave's force is the spring's along -n, |dp/ds| = 1.
            let slave = (t.force[0].powi(2) + t.force[1].powi(2) + t.force[2].powi(2)).sqrt();
            let area = 0.5 * contact.surfaces()[t.slave.0].areas[t.slave.1];
            assert!(
                (slave - area * stiffness * change).abs() < 1e-12,
                "{slave} against {}",
                area * stiffness * change
            );
        }
        check_tangent_of_terms(&contact, &xm, |_| true);
    }
}

/// The touch force is fixed for the step, so that the force stays
/// continuous: on a pair of surfaces that pressed nowhere when the step
/// started every node carries the spring, pressed or not (its pressure
/// added), and the tangent is the force's derivative; once the pair has
/// pressed (the multipliers updated, paired for the next step) no node of
/// it does.
#[test]
fn the_touch_force_stays_for_the_step_and_leaves_a_pair_that_pressed() {
    for triangles in [false, true] {
        let (penalty, stiffness) = (100.0, 7.0);
        let (mut contact, nodes, x) = touching_patches(triangles, penalty, stiffness);
        let at_pairing = contact.evaluate(&x, false);
        // The upper patch moved down by 0.04: the nodes nearest the middle
        // pressed, the rim's still open.
        let xm = upper_patch_moved(&nodes, 0.04);
        let eval = contact.evaluate(&xm, true);
        let slave_force = |t: &tidens_contact::ContactTerm| {
            (t.force[0].powi(2) + t.force[1].powi(2) + t.force[2].powi(2)).sqrt()
        };
        let (mut pressed, mut open) = (0, 0);
        // (Nodes in the band at pairing: their reference is known here.)
        for t in eval.terms.iter().filter(|t| {
            at_pairing
                .terms
                .iter()
                .any(|a| a.slave == t.slave && a.master == t.master)
        }) {
            let change = t.penetration - at_pairing_reading(&at_pairing, t);
            let pressure = (penalty * t.penetration).max(0.0);
            assert_eq!(t.pressure, pressure);
            let area = 0.5 * contact.surfaces()[t.slave.0].areas[t.slave.1];
            let expected = area * (pressure + stiffness * change);
            assert!(
                (slave_force(t) - expected).abs() < 1e-12,
                "{} against {expected}",
                slave_force(t)
            );
            if pressure > 0.0 {
                pressed += 1
            } else {
                open += 1
            }
        }
        assert!(pressed >= 2 && open >= 2, "{pressed} pressed, {open} open");
        check_tangent_of_terms(&contact, &xm, |_| true);
        // The pair pressed: the next step has no spring on it. Open nodes
        // carry nothing, pressed ones their pressure alone.
        contact.augment(&xm, &eval);
        contact.pair(&xm);
        let next = contact.evaluate(&xm, true);
        assert!(next.terms.iter().any(|t| t.pressure > 0.0));
        for t in &next.terms {
            let area = 0.5 * contact.surfaces()[t.slave.0].areas[t.slave.1];
            assert!((slave_force(t) - area * t.pressure).abs() < 1e-12);
        }
    }
}

/// The penetration the term of the same node and facet read at pairing.
fn at_pairing_reading(
    at_pairing: &tidens_contact::ContactEvaluation,
    t: &tidens_contact::ContactTerm,
) -> f64 {
    at_pairing
        .terms
        .iter()
        .find(|a| a.slave == t.slave && a.master == t.master)
        .map(|a| a.penetration)
        .unwrap()
}
