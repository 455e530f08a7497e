//! Material-point benchmarks: `cargo bench -p tidens-material`.
//!
//! Each benchmark runs a batch of material points that differ slightly (so
//! branch prediction sees varied inputs, as in an element loop) and reports
//! material points per second.
//!
//! - `update_deviatoric`: the exponential-map return, with and without the
//!   consistent tangent, for n = 2.8 and n = 15 in two regimes:
//!   `near_identity` (elastic strains ~3e-4 on top of a 10 % plastic stretch:
//!   the typical state of a hot-pressing run, stresses ~15 MPa) and
//!   `large_strain` (a trial state with stretches of 0.7-1.5, as in the first
//!   Newton iteration of a large step).
//! - `eigen`: the 3x3 symmetric eigen-decomposition of the trial left
//!   Cauchy-Green tensor alone, in the same two regimes.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Matrix3, Rotation3, SymmetricEigen, Vector3};
use std::hint::black_box;
use tidens_material::{Material, PointState, symmetric_eigen};

const BATCH: usize = 64;

/// A small deterministic generator, so every run benchmarks the same points.
struct Lcg(u64);

impl Lcg {
    /// Uniform in [-1, 1).
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    fn sym(&mut self, amplitude: f64) -> Matrix3<f64> {
        let m = Matrix3::from_fn(|_, _| self.next() * amplitude);
        (m + m.transpose()) * 0.5
    }

    fn rotation(&mut self) -> Matrix3<f64> {
        Rotation3::from_euler_angles(self.next() * 3.0, self.next() * 1.5, self.next() * 3.0)
            .into_inner()
    }
}

/// Inverse plastic right Cauchy-Green tensor of an isochoric plastic
/// deformation `fp`, in the state's storage order.
fn state_of(fp: &Matrix3<f64>, eqps: f64) -> PointState {
    let fp = fp / fp.determinant().cbrt();
    let fpi = fp.try_inverse().unwrap_or_else(Matrix3::identity);
    let c = fpi * fpi.transpose();
    PointState {
        cp_inv: [
            c[(0, 0)],
            c[(1, 1)],
            c[(2, 2)],
            c[(0, 1)],
            c[(1, 2)],
            c[(0, 2)],
        ],
        eqps,
    }
}

/// `(F, state)` pairs: `F = R (I + eps_e) Fp` with elastic strains of size
/// `elastic` on top of the plastic deformation `Fp` stored in the state.
fn points(elastic: f64, plastic: f64, seed: u64) -> Vec<(Matrix3<f64>, PointState)> {
    let mut rng = Lcg(seed);
    (0..BATCH)
        .map(|_| {
            let fp = Matrix3::identity()
                + Matrix3::from_diagonal(&Vector3::new(1.0, -0.5, -0.5)) * plastic
                + rng.sym(0.3 * plastic);
            let state = state_of(&fp, plastic);
            let fp = fp / fp.determinant().cbrt();
            let fe = rng.rotation() * (Matrix3::identity() + rng.sym(elastic));
            (fe * fp, state)
        })
        .collect()
}

/// The regimes: name, elastic strain, plastic stretch.
const REGIMES: [(&str, f64, f64); 2] = [("near_identity", 3e-4, 0.1), ("large_strain", 0.3, 0.5)];

fn update_deviatoric(c: &mut Criterion) {
    let mut g = c.benchmark_group("update_deviatoric");
    g.throughput(Throughput::Elements(BATCH as u64));
    for n in [2.8, 15.0] {
        // Same creep rate (1e-3 /s) at 15 MPa for both exponents, and a step
        // of 1 s: the return relaxes the trial stress by a sizeable fraction.
        let m = Material::new(4.35e4, 0.3, 1e-3 / 15.0_f64.powf(n), n).expect("valid material");
        for (regime, elastic, plastic) in REGIMES {
            let pts = points(elastic, plastic, 7);
            for tangent in [false, true] {
                let id = BenchmarkId::new(format!("{regime}/tangent={tangent}"), format!("n={n}"));
                g.bench_with_input(id, &pts, |b, pts| {
                    b.iter(|| {
                        for (f, s) in pts {
                            let _ = black_box(m.update_deviatoric(black_box(f), s, 1.0, tangent));
                        }
                    })
                });
            }
        }
    }
    g.finish();
}

fn eigen(c: &mut Criterion) {
    let mut g = c.benchmark_group("eigen");
    g.throughput(Throughput::Elements(BATCH as u64));
    for (regime, elastic, plastic) in REGIMES {
        // The trial left Cauchy-Green tensors b = F Cp^-1 F^T of the batch.
        let bs: Vec<Matrix3<f64>> = points(elastic, plastic, 7)
            .iter()
            .map(|(f, s)| {
                let [xx, yy, zz, xy, yz, xz] = s.cp_inv;
                let cp_inv = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
                f * cp_inv * f.transpose()
            })
            .collect();
        g.bench_with_input(BenchmarkId::new("symmetric_eigen", regime), &bs, |b, bs| {
            b.iter(|| {
                for m in bs {
                    black_box(symmetric_eigen(black_box(m)));
                }
            })
        });
        g.bench_with_input(BenchmarkId::new("nalgebra", regime), &bs, |b, bs| {
            b.iter(|| {
                for m in bs {
                    black_box(SymmetricEigen::new(black_box(*m)));
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, update_deviatoric, eigen);
criterion_main!(benches);
