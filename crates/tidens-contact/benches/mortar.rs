//! Mortar kernel benchmarks: `cargo bench -p tidens-contact --bench mortar`.
//!
//! Two 16 x 16 quad patches in contact: the slave a cap of a sphere of
//! radius 1 mm (gnomonic angles |u|, |v| <= 0.3), the master a cap of
//! radius 0.99 mm over the same angles turned by 0.3 rad about the axis,
//! facing in: 0.01 mm into the slave. The candidate pairs come from the broad phase with
//! a search distance of one cell. Timed, with the throughput in pairs:
//!
//! - `weighted_gaps/value`: the weighted gaps alone (`f64`);
//! - `weighted_gaps/gradient`: with their exact gradients (forward-mode
//!   dual numbers over each pair's 24 coordinates, and the nodal normals'
//!   chain rule);
//! - `candidate_pairs`: the broad phase.
//!
//! Before criterion's runs, one timing of each prints the nanoseconds per
//! pair.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Instant;
use tidens_contact::ContactSurface;
use tidens_contact::mortar::clip::clip;
use tidens_contact::mortar::{
    Derivatives, Facet, SurfaceTestFunctions, TestBasis, candidate_pairs, weighted_gaps,
};

const CELLS: usize = 16;

/// A cap of the sphere of radius `r` over the gnomonic angles in
/// `[-a, a]^2`, turned by `turn` about z, `CELLS x CELLS` quads, nodes
/// appended to `x`; facing in with `flip`.
fn cap(x: &mut Vec<[f64; 3]>, r: f64, a: f64, turn: f64, flip: bool) -> ContactSurface {
    let first = x.len();
    for j in 0..=CELLS {
        for i in 0..=CELLS {
            let (u, v) = (
                a * (2.0 * i as f64 / CELLS as f64 - 1.0),
                a * (2.0 * j as f64 / CELLS as f64 - 1.0),
            );
            let d = [u.tan(), v.tan(), 1.0];
            let l = (d[0] * d[0] + d[1] * d[1] + 1.0).sqrt();
            let (c, s) = (turn.cos(), turn.sin());
            x.push([
                r * (c * d[0] - s * d[1]) / l,
                r * (s * d[0] + c * d[1]) / l,
                r / l,
            ]);
        }
    }
    let id = |i: usize, j: usize| first + j * (CELLS + 1) + i;
    let quads: Vec<[usize; 4]> = (0..CELLS)
        .flat_map(|j| {
            (0..CELLS).map(move |i| {
                let q = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
                if flip { [q[0], q[3], q[2], q[1]] } else { q }
            })
        })
        .collect();
    ContactSurface::from_quads(&quads, x).expect("surface")
}

/// Coordinates, slave, master, candidate pairs.
type Scene = (
    Vec<[f64; 3]>,
    ContactSurface,
    ContactSurface,
    Vec<(usize, usize)>,
);

fn scene() -> Scene {
    let mut x = Vec::new();
    let slave = cap(&mut x, 1.0, 0.3, 0.0, false);
    let master = cap(&mut x, 1.0 - 0.01, 0.3, 0.3, true);
    let h = 0.6 / CELLS as f64;
    let pairs = candidate_pairs(&slave, &master, &x, h);
    (x, slave, master, pairs)
}

fn mortar(c: &mut Criterion) {
    let (x, slave, master, pairs) = scene();
    let test = SurfaceTestFunctions::new(&slave, &x, TestBasis::Dual);
    let overlapping = pairs
        .iter()
        .filter(|&&(a, b)| {
            clip(
                &Facet::of_surface(&slave, a, &x),
                &Facet::of_surface(&master, b, &x),
            )
            .is_some()
        })
        .count();
    let cells: usize = pairs
        .iter()
        .filter_map(|&(a, b)| {
            clip(
                &Facet::of_surface(&slave, a, &x),
                &Facet::of_surface(&master, b, &x),
            )
        })
        .map(|c| c.pieces.iter().map(|p| p.vertices.len()).sum::<usize>())
        .sum();
    println!(
        "{} candidate pairs, {overlapping} overlapping, {:.1} cells per overlapping pair",
        pairs.len(),
        cells as f64 / overlapping as f64
    );
    let run = |d: Derivatives| weighted_gaps(&slave, &master, &x, &pairs, &test, d).expect("gaps");
    for (name, d) in [
        ("value", Derivatives::Value),
        ("gradient", Derivatives::Gradient),
    ] {
        let reps = 3;
        let t = Instant::now();
        for _ in 0..reps {
            black_box(run(d));
        }
        let ns = t.elapsed().as_nanos() as f64 / (reps * pairs.len()) as f64;
        println!(
            "weighted_gaps/{name}: {ns:.0} ns per candidate pair, {:.0} ns per overlapping pair",
            ns * pairs.len() as f64 / overlapping as f64
        );
    }
    let mut g = c.benchmark_group("weighted_gaps");
    g.sample_size(10);
    g.throughput(Throughput::Elements(pairs.len() as u64));
    g.bench_function("value", |b| b.iter(|| black_box(run(Derivatives::Value))));
    g.bench_function("gradient", |b| {
        b.iter(|| black_box(run(Derivatives::Gradient)))
    });
    g.finish();
    let mut g = c.benchmark_group("candidate_pairs");
    g.throughput(Throughput::Elements(slave.facets.len() as u64));
    g.bench_function("16x16", |b| {
        b.iter(|| black_box(candidate_pairs(&slave, &master, &x, 0.6 / CELLS as f64)))
    });
    g.finish();
}

criterion_group!(benches, mortar);
criterion_main!(benches);
