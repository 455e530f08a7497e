//! The linear algebra of a Newton iteration: `cargo bench -p tidens-solver`.
//!
//! On the real consistent tangent of the sc Ti-6Al-4V cell pressed to
//! rho = 0.7 (10 MPa), at mesh levels 2, 3 and 4:
//! - evaluation and assembly of the tangent (elements evaluated in parallel,
//!   gathered into the equation system), in equations per second;
//! - the numeric Cholesky factorisation (the symbolic one is reused) with the
//!   default nested-dissection ordering and with AMD, and the LU
//!   factorisation of the same matrix that a non-symmetric element (F-bar)
//!   would need, in equations per second;
//! - one forward/backward solve with the factor, in equations per second.
//!
//! On the tangent of the bcc cell pressed to rho = 0.75 (15 MPa), at mesh
//! levels 2 and 3: the numeric Cholesky factorisation with either ordering.
//!
//! On the sc tangent at levels 3 and 4: the numeric Cholesky factorisation
//! in a rayon pool of one thread and of two (faer splits each dense update
//! among the pool's threads; the factor is the same bits).

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use std::hint::black_box;
use tidens_fem::SparseSystem;
use tidens_solver::linear::{FillOrdering, LinearSolver};
use tidens_solver::{
    Cell, LoadHistory, MeshOptions, Preset, Scene, Settings, Simulation, SolverError,
};

/// `cell` at `stress` \[MPa\], advanced until its density reaches `rho`.
fn pressed_to(cell: &Cell, level: u32, stress: f64, rho: f64) -> Result<Simulation, SolverError> {
    let scene = Scene::from_cell(
        cell,
        &MeshOptions {
            level,
            ..MeshOptions::default()
        },
    )?;
    let mut settings = Settings::new(LoadHistory {
        stress,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(rho);
    settings.tolerance = 0.05;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings)?;
    sim.run(|_| true)?;
    Ok(sim)
}

/// The numeric Cholesky factorisation of `sys` with each ordering.
fn cholesky_by_ordering(g: &mut BenchmarkGroup<'_, WallTime>, sys: &SparseSystem, label: &str) {
    for (name, ordering) in [
        ("cholesky", FillOrdering::NestedDissection),
        ("cholesky_amd", FillOrdering::Amd),
    ] {
        let mut chol = LinearSolver::with_ordering(ordering);
        chol.factorize(sys).expect("factorisation");
        let entries = chol.factor_entries();
        g.bench_function(format!("{name}/{label}, factor {entries}"), |b| {
            b.iter(|| black_box(chol.factorize(sys).expect("factorisation")))
        });
    }
}

/// The numeric Cholesky factorisation of `sys` in a pool of one thread and
/// in one of two.
fn cholesky_by_threads(g: &mut BenchmarkGroup<'_, WallTime>, sys: &SparseSystem, label: &str) {
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        let mut chol = LinearSolver::default();
        pool.install(|| chol.factorize(sys).expect("factorisation"));
        g.bench_function(format!("cholesky_threads_{threads}/{label}"), |b| {
            b.iter(|| pool.install(|| black_box(chol.factorize(sys).expect("factorisation"))))
        });
    }
}

fn linear_algebra(c: &mut Criterion) {
    let mut g = c.benchmark_group("sc_tangent");
    g.sample_size(10);
    let sc = Cell::sc(0.05, 1.0).expect("sc cell");
    for level in [2, 3, 4] {
        let mut sim = pressed_to(&sc, level, 10.0, 0.7).expect("sc run");
        let sys = sim.assemble_tangent(10.0).expect("tangent").clone();
        let n = sys.dim();
        let label = format!("level {level}, {n} equations, nnz {}", sys.nnz());
        g.throughput(Throughput::Elements(n as u64));
        g.bench_function(format!("evaluate_and_assemble/{label}"), |b| {
            b.iter(|| black_box(sim.assemble_tangent(10.0).expect("tangent").nnz()))
        });
        cholesky_by_ordering(&mut g, &sys, &label);
        if level >= 3 {
            cholesky_by_threads(&mut g, &sys, &label);
        }
        let mut chol = LinearSolver::default();
        chol.factorize(&sys).expect("factorisation");
        let rhs: Vec<f64> = (0..n).map(|k| (k as f64 * 0.1).sin()).collect();
        g.bench_function(format!("solve/{label}"), |b| {
            b.iter(|| {
                let mut x = rhs.clone();
                chol.solve(&mut x).expect("solve");
                black_box(x)
            })
        });
        let sym = SymbolicSparseColMatRef::new_checked(n, n, sys.col_ptr(), None, sys.row_idx());
        let mat = SparseColMatRef::new(sym, sys.values());
        let symbolic = SymbolicLu::try_new(sym).expect("symbolic LU");
        g.bench_function(format!("lu/{label}"), |b| {
            b.iter(|| black_box(Lu::try_new_with_symbolic(symbolic.clone(), mat).expect("LU")))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("bcc_tangent");
    g.sample_size(10);
    let bcc = Cell::bcc(0.05, 1.0).expect("bcc cell");
    for level in [2, 3] {
        let mut sim = pressed_to(&bcc, level, 15.0, 0.75).expect("bcc run");
        let sys = sim.assemble_tangent(10.0).expect("tangent").clone();
        let n = sys.dim();
        g.throughput(Throughput::Elements(n as u64));
        let label = format!("level {level}, {n} equations, nnz {}", sys.nnz());
        cholesky_by_ordering(&mut g, &sys, &label);
    }
    g.finish();
}

criterion_group!(benches, linear_algebra);
criterion_main!(benches);
