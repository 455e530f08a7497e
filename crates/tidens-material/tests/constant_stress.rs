//! Verification ladder item 1: a material point held at constant uniaxial
//! (Kirchhoff) stress creeps at exactly `C sigma^n`.
//!
//! With Hencky elasticity the axial log strain is `sigma/E + p`, and backward
//! Euler at constant stress gives `dp = C sigma^n dt` exactly, so the axial log
//! strain must be `sigma/E + C sigma^n t` for any step size.

use nalgebra::{Matrix3, Vector3};
use tidens_material::{Material, PointState};

/// Kirchhoff stress of the full law: deviator from the material, pressure K ln J.
fn kirchhoff(
    m: &Material,
    f: &Matrix3<f64>,
    s: &PointState,
    dt: f64,
) -> (Matrix3<f64>, PointState) {
    let r = m.update_deviatoric(f, s, dt, false).unwrap();
    let p = m.bulk_modulus() * f.determinant().ln();
    (r.tau_dev + Matrix3::identity() * p, r.state)
}

/// Finds F = diag(l1, l2, l2) with tau_11 = sigma, tau_22 = tau_33 = 0 (Newton,
/// finite-difference Jacobian on the two log stretches).
fn solve_uniaxial(
    m: &Material,
    sigma: f64,
    s: &PointState,
    dt: f64,
    guess: [f64; 2],
) -> ([f64; 2], PointState) {
    let resid = |x: [f64; 2]| {
        let f = Matrix3::from_diagonal(&Vector3::new(x[0].exp(), x[1].exp(), x[1].exp()));
        let (t, st) = kirchhoff(m, &f, s, dt);
        ([t[(0, 0)] - sigma, t[(1, 1)]], st)
    };
    let mut x = guess;
    for _ in 0..50 {
        let (r, _) = resid(x);
        if r[0].abs().max(r[1].abs()) < 1e-12 * sigma.max(1.0) {
            break;
        }
        let h = 1e-8;
        let (r0, _) = resid([x[0] + h, x[1]]);
        let (r1, _) = resid([x[0], x[1] + h]);
        let j = [
            [(r0[0] - r[0]) / h, (r1[0] - r[0]) / h],
            [(r0[1] - r[1]) / h, (r1[1] - r[1]) / h],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        x[0] -= (j[1][1] * r[0] - j[0][1] * r[1]) / det;
        x[1] -= (-j[1][0] * r[0] + j[0][0] * r[1]) / det;
    }
    let (_, st) = resid(x);
    (x, st)
}

#[test]
fn strain_rate_equals_c_sigma_to_the_n() {
    for &n in &[1.0, 2.8, 4.3, 8.0] {
        let sigma: f64 = 20.0;
        let c = 1e-4 / sigma.powf(n); // 1e-4 /s whatever n
        let m = Material::new(4.35e4, 0.3, c, n).unwrap();
        for &dt in &[0.5, 50.0, 300.0] {
            let mut s = PointState::default();
            let mut x = [0.0, 0.0];
            let mut t = 0.0;
            while t < 1000.0 - 1e-9 {
                let (xn, sn) = solve_uniaxial(&m, sigma, &s, dt, x);
                x = xn;
                s = sn;
                t += dt;
            }
            let expected = sigma / m.young + c * sigma.powf(n) * t;
            assert!(
                (x[0] / expected - 1.0).abs() < 1e-7,
                "n={n} dt={dt}: axial log strain {} vs {expected}",
                x[0]
            );
            // Plastic flow is isochoric: lateral plastic strain is -1/2 axial.
            let lateral = -m.poisson * sigma / m.young - 0.5 * c * sigma.powf(n) * t;
            assert!(
                (x[1] / lateral - 1.0).abs() < 1e-7,
                "n={n} dt={dt}: lateral {} vs {lateral}",
                x[1]
            );
            assert!((s.eqps / (c * sigma.powf(n) * t) - 1.0).abs() < 1e-9);
        }
    }
}
