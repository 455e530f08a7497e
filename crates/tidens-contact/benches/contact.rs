//! Contact benchmarks: `cargo bench -p tidens-contact`.
//!
//! The configuration is the bcc contact at mesh level 3: two sphere
//! octants of radius 0.05 mm (8 divisions), one centred at the origin, the
//! other at the opposite corner of the cell, moved 6 % of the radius into
//! each other along the body diagonal. Penalty and search distance as the
//! solver sets them (10 E / h and h, h the mean surface edge).
//!
//! - `penetration_term`: one contact term's penetration, gradient and
//!   Hessian (and gradient alone), closed form against hyper-dual numbers,
//!   over the terms of that configuration (throughput: terms);
//! - `evaluate`: all contact terms, with and without tangent (throughput:
//!   terms);
//! - `detection`: what a step's pairing costs, and its parts: the candidate
//!   surface pairs, one search `TriMesh`, `pair` and `pair_unpaired`
//!   (throughput: slave nodes).

#[path = "../tests/support/dual_penetration.rs"]
mod dual_penetration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use tidens_contact::{
    ContactMode, ContactSettings, ContactSurface, ParticleContact, penetration_gradient,
    penetration_hessian,
};
use tidens_mesh::{FaceKind, HexMesh, OctantSpec};

const RADIUS: f64 = 0.05;
const YOUNG: f64 = 4.35e4;

/// The two pressed octants: coordinates `x` and the contact, paired.
fn pressed_octants() -> (Vec<f64>, ParticleContact) {
    let mesh = HexMesh::spheroid_octant(&OctantSpec {
        a: RADIUS,
        c: RADIUS,
        divisions: 8,
        grading: 1.0,
    })
    .expect("valid octant");
    let curved: Vec<[usize; 4]> = mesh
        .boundary
        .iter()
        .filter(|f| f.kind == FaceKind::Curved)
        .map(|f| f.nodes)
        .collect();
    // The second octant is the first inverted through the cell centre (its
    // quads reversed to keep their normals outward), its centre at
    // (s, s, s) with s the bcc cell edge less the overlap.
    let overlap = 0.06 * RADIUS;
    let s = (2.0 * RADIUS - overlap) / 3.0_f64.sqrt();
    let n = mesh.nodes.len();
    let mut nodes = mesh.nodes.clone();
    nodes.extend(mesh.nodes.iter().map(|p| p.map(|v| s - v)));
    let other: Vec<[usize; 4]> = curved
        .iter()
        .map(|q| [q[0] + n, q[3] + n, q[2] + n, q[1] + n])
        .collect();
    let surfaces = vec![
        ContactSurface::from_quads(&curved, &nodes).expect("surface"),
        ContactSurface::from_quads(&other, &nodes).expect("surface"),
    ];
    let (count, area) = surfaces
        .iter()
        .flat_map(|s| &s.areas)
        .fold((0usize, 0.0), |(c, a), x| (c + 1, a + x));
    let h = (area / count as f64).sqrt();
    let mut contact = ParticleContact::new(
        surfaces,
        ContactSettings {
            mode: ContactMode::Frictionless,
            penalty: 10.0 * YOUNG / h,
            search_distance: h,
            curvature_stiffness: true,
            touch_stiffness_cap: f64::INFINITY,
        },
    )
    .expect("contact settings");
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    contact.pair(&x);
    (x, contact)
}

/// What one term's penetration is computed from.
struct TermInput {
    slave: [f64; 3],
    facet: [[f64; 3]; 4],
    xi: [f64; 2],
}

/// The slave point, facet and projection of every term at `x`.
fn term_inputs(x: &[f64], contact: &ParticleContact) -> Vec<TermInput> {
    let at = |d: usize| [x[d], x[d + 1], x[d + 2]];
    contact
        .evaluate(x, false)
        .terms
        .iter()
        .map(|t| TermInput {
            slave: at(t.dofs[0]),
            facet: [0, 1, 2, 3].map(|a| at(t.dofs[3 + 3 * a])),
            xi: t.location,
        })
        .collect()
}

fn penetration_term(c: &mut Criterion) {
    let (x, contact) = pressed_octants();
    let inputs = term_inputs(&x, &contact);
    let mut g = c.benchmark_group("penetration_term");
    g.throughput(Throughput::Elements(inputs.len() as u64));
    g.bench_function("hessian/closed_form", |b| {
        b.iter(|| {
            for t in &inputs {
                black_box(penetration_hessian(black_box(&t.slave), &t.facet, t.xi));
            }
        })
    });
    g.bench_function("hessian/dual", |b| {
        b.iter(|| {
            for t in &inputs {
                black_box(dual_penetration::hessian(
                    black_box(&t.slave),
                    &t.facet,
                    t.xi,
                ));
            }
        })
    });
    g.bench_function("gradient/closed_form", |b| {
        b.iter(|| {
            for t in &inputs {
                black_box(penetration_gradient(black_box(&t.slave), &t.facet, t.xi));
            }
        })
    });
    g.bench_function("gradient/dual", |b| {
        b.iter(|| {
            for t in &inputs {
                black_box(dual_penetration::gradient(
                    black_box(&t.slave),
                    &t.facet,
                    t.xi,
                ));
            }
        })
    });
    g.finish();
}

fn evaluate(c: &mut Criterion) {
    let (x, contact) = pressed_octants();
    let eval = contact.evaluate(&x, true);
    let pressed = eval.terms.iter().filter(|t| t.pressure > 0.0).count();
    eprintln!(
        "evaluate: {} terms, {pressed} with pressure, max penetration {:.3e} mm",
        eval.terms.len(),
        eval.max_penetration()
    );
    let mut g = c.benchmark_group("evaluate");
    g.throughput(Throughput::Elements(eval.terms.len() as u64));
    for tangent in [false, true] {
        g.bench_function(format!("tangent={tangent}"), |b| {
            b.iter(|| black_box(contact.evaluate(black_box(&x), tangent)))
        });
    }
    g.finish();
}

fn detection(c: &mut Criterion) {
    let (x, mut contact) = pressed_octants();
    let slaves: usize = contact.surfaces().iter().map(|s| s.nodes.len()).sum();
    eprintln!(
        "detection: {slaves} slave nodes, {} triangles per search mesh",
        2 * contact.surfaces()[0].facets.len()
    );
    let mut g = c.benchmark_group("detection");
    g.throughput(Throughput::Elements(slaves as u64));
    g.bench_function("candidate_pairs", |b| {
        b.iter(|| black_box(contact.candidate_pairs(black_box(&x))))
    });
    g.bench_function("trimesh", |b| {
        b.iter(|| black_box(contact.surfaces()[1].trimesh(black_box(&x))))
    });
    g.bench_function("pair", |b| b.iter(|| contact.pair(black_box(&x))));
    g.bench_function("pair_unpaired", |b| {
        b.iter(|| black_box(contact.pair_unpaired(black_box(&x))))
    });
    g.finish();
}

criterion_group!(benches, penetration_term, evaluate, detection);
criterion_main!(benches);
