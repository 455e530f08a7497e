//! Element kernels: `cargo bench -p tidens-fem`.
//!
//! - one evaluation of every element of a spheroid-octant body (the sc
//!   particle at mesh level 3, hexahedra; the same blocks cut into 10-node
//!   tetrahedra at level 1), with and without the consistent tangent, in
//!   elements per second;
//! - the gather of all element tangents into the global dof-level matrix
//!   (one assembly per Newton iteration that refactorises), in elements per
//!   second.
//!
//! The displacement is a uniform compression of 1 % along z with a smooth
//! perturbation, after a step of 10 s: plastic flow at every point, as in a
//! pressed particle.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use tidens_fem::{Body, ElementAssembler};
use tidens_material::Preset;
use tidens_mesh::{HexMesh, OctantSpec, TetMesh};

fn octant(divisions: usize) -> OctantSpec {
    OctantSpec {
        a: 0.05,
        c: 0.05,
        divisions,
        grading: 1.0,
    }
}

/// A smooth displacement field over `nodes` \[mm\].
fn displacement(nodes: &[[f64; 3]]) -> Vec<f64> {
    nodes
        .iter()
        .flat_map(|p| {
            [
                2e-4 * p[0] + 1e-5 * (40.0 * p[1]).sin(),
                2e-4 * p[1] + 1e-5 * (40.0 * p[2]).cos(),
                -1e-2 * p[2] + 1e-5 * (40.0 * p[0]).sin(),
            ]
        })
        .collect()
}

fn bodies() -> Vec<(String, Body)> {
    let material = Preset::Ti64Creep1293K.material();
    let hex = HexMesh::spheroid_octant(&octant(8)).expect("hex mesh");
    let tet = TetMesh::spheroid_octant(&octant(4)).expect("tet mesh");
    vec![
        (
            "hex8, sc level 3".into(),
            Body::new(hex.nodes, hex.elements, material).expect("hex body"),
        ),
        (
            "tet10, sc level 1".into(),
            Body::new_tet10(tet.nodes, tet.elements, material).expect("tet body"),
        ),
    ]
}

fn evaluation(c: &mut Criterion) {
    let mut g = c.benchmark_group("body_evaluate");
    g.sample_size(20);
    for (name, body) in bodies() {
        let u = displacement(body.nodes());
        g.throughput(Throughput::Elements(body.element_count() as u64));
        for tangent in [false, true] {
            g.bench_function(
                format!(
                    "{name}, {} elements, tangent={tangent}",
                    body.element_count()
                ),
                |b| b.iter(|| black_box(body.evaluate(black_box(&u), 10.0, tangent))),
            );
        }
    }
    g.finish();
}

fn gather(c: &mut Criterion) {
    let mut g = c.benchmark_group("gather_tangents");
    g.sample_size(20);
    for (name, body) in bodies() {
        let u = displacement(body.nodes());
        let eval = body.evaluate(&u, 10.0, true).expect("evaluation");
        let dofs: Vec<usize> = (0..body.element_count())
            .flat_map(|e| body.element_dofs(e))
            .collect();
        let plan = ElementAssembler::new(body.dof_count(), 3 * body.kind().nodes(), &dofs);
        let mut values = vec![0.0; plan.nnz()];
        g.throughput(Throughput::Elements(body.element_count() as u64));
        g.bench_function(
            format!("{name}, {} dofs, nnz {}", plan.dim(), plan.nnz()),
            |b| b.iter(|| plan.assemble_matrix(black_box(eval.tangents()), &mut values)),
        );
    }
    g.finish();
}

criterion_group!(benches, evaluation, gather);
criterion_main!(benches);
