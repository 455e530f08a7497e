//! Kernel benchmarks: `cargo bench -p tidens-benches`.
//!
//! - the material point (exponential-map return, with and without tangent),
//! - one evaluation of all elements of the sc cell (mesh level 3),
//! - the numeric factorisation of the real tangent of the sc cell pressed to
//!   rho = 0.7: Cholesky (what the symmetric mean-dilatation element allows)
//!   against LU (what a non-symmetric F-bar tangent would need) on the same
//!   matrix and sparsity pattern, the measurement behind the element choice.

use criterion::{Criterion, criterion_group, criterion_main};
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use nalgebra::Matrix3;
use std::hint::black_box;
use tidens_material::{Material, PointState};
use tidens_solver::linear::LinearSolver;

fn material_point(c: &mut Criterion) {
    let f = Matrix3::new(1.02, 0.01, 0.0, -0.005, 0.99, 0.003, 0.0, 0.002, 0.985);
    let state = PointState::default();
    for n in [2.8, 15.0] {
        let m = Material::new(4.35e4, 0.3, 4.8e-7, n).expect("valid material");
        for tangent in [false, true] {
            c.bench_function(&format!("material_point/n={n}/tangent={tangent}"), |b| {
                b.iter(|| black_box(m.update_deviatoric(black_box(&f), &state, 10.0, tangent)))
            });
        }
    }
}

fn element_evaluation(c: &mut Criterion) {
    let sim = tidens_benches::sc_pressed_to(3, 0.7).expect("sc run");
    let body = sim.body();
    let u: Vec<f64> = sim
        .fields()
        .displacement
        .iter()
        .flatten()
        .copied()
        .collect();
    let mut g = c.benchmark_group("evaluate_sc_level3");
    g.sample_size(20);
    for tangent in [false, true] {
        g.bench_function(
            format!("{} elements, tangent={tangent}", body.elements().len()),
            |b| b.iter(|| black_box(body.evaluate(&u, 10.0, tangent))),
        );
    }
    g.finish();
}

fn factorization(c: &mut Criterion) {
    let mut g = c.benchmark_group("factorize_sc_tangent");
    g.sample_size(10);
    for level in [2, 3, 4] {
        let mut sim = tidens_benches::sc_pressed_to(level, 0.7).expect("sc run");
        let sys = sim.assemble_tangent(10.0).expect("tangent").clone();
        let n = sys.dim();
        let label = format!("level {level}, {n} equations, nnz {}", sys.nnz());
        let mut chol = LinearSolver::default();
        chol.factorize(&sys).expect("factorisation");
        g.bench_function(format!("cholesky/{label}"), |b| {
            b.iter(|| black_box(chol.factorize(&sys).expect("factorisation")))
        });
        let sym = SymbolicSparseColMatRef::new_checked(n, n, sys.col_ptr(), None, sys.row_idx());
        let mat = SparseColMatRef::new(sym, sys.values());
        let symbolic = SymbolicLu::try_new(sym).expect("symbolic LU");
        g.bench_function(format!("lu/{label}"), |b| {
            b.iter(|| black_box(Lu::try_new_with_symbolic(symbolic.clone(), mat).expect("LU")))
        });
    }
    g.finish();
}

criterion_group!(benches, material_point, element_evaluation, factorization);
criterion_main!(benches);
