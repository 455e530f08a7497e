//! The finite-strain material point: `F = Fe Fp`, Hencky elasticity, J2 Norton
//! flow integrated by backward Euler with the exponential map (a radial return
//! in the principal logarithmic strains of the elastic trial state).
//!
//! Only the deviatoric (isochoric) response is computed here. The volumetric
//! response of Hencky elasticity, `p = K ln J`, is purely elastic and is
//! evaluated by the element with its mean dilatation.
//!
//! Tangent. With `b = F Cp^-1 F^T` the elastic trial left Cauchy-Green tensor
//! and `tau = tau(b)` an isotropic function of it, the linearisation of the
//! virtual work `tau : grad_x(w)` (per unit reference volume) in the direction
//! `du` is `g : a : l`, `g = grad_x(w)`, `l = grad_x(du)`. In the principal frame
//! of `b` (eigenvalues `b_A`, principal log strains `eps_A = ln(b_A)/2`):
//!
//! ```text
//! a[AA,BB] = d tau_A / d eps_B - tau_A delta_AB
//! a[AB,AB] = theta_AB b_B                    (A != B)
//! a[AB,BA] = theta_AB b_A - tau_A            (A != B)
//! theta_AB = (tau_A - tau_B) / (b_A - b_B)
//! ```
//!
//! The first two lines come from `d tau = D tau(b)[l b + b l^T]`, the `- tau`
//! terms from the variation of the spatial gradient of `w`. The tangent is
//! symmetric (`theta_AB (b_A - b_B) = tau_A - tau_B`), as it must be: the
//! exponential-map return of an associative J2 law is the minimiser of an
//! incremental potential. For the radial return `tau_A - tau_B = 2 G beta
//! (eps_A - eps_B)`, so `theta_AB` is `2 G beta` times a divided difference of
//! `ln(b)/2`, which is evaluated without cancellation; repeated eigenvalues need
//! no special case.

use crate::eigen3::symmetric_eigen;
use crate::error::MaterialError;
use crate::params::Material;
use crate::state::PointState;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// Spatial tangent `a` as a 9x9 matrix, row `3 i + j` for `g_ij`, column
/// `3 k + l` for `l_kl`: the linearised virtual work is `g : a : l` per unit
/// reference volume \[MPa\].
pub type SpatialTangent = SMatrix<f64, 9, 9>;

/// Deviatoric response of one material point over one time step.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviatoricResponse {
    /// Deviatoric Kirchhoff stress at the end of the step \[MPa\].
    pub tau_dev: Matrix3<f64>,
    /// Consistent spatial tangent of the deviatoric response (see module
    /// docs), when requested.
    pub tangent: Option<SpatialTangent>,
    /// State at the end of the step.
    pub state: PointState,
    /// von Mises (Kirchhoff) stress at the end of the step \[MPa\].
    pub q: f64,
    /// Equivalent plastic strain increment over the step [-].
    pub dp: f64,
}

pub(crate) fn sym_from6(v: &[f64; 6]) -> Matrix3<f64> {
    Matrix3::new(v[0], v[3], v[5], v[3], v[1], v[4], v[5], v[4], v[2])
}

fn sym_to6(m: &Matrix3<f64>) -> [f64; 6] {
    [
        m[(0, 0)],
        m[(1, 1)],
        m[(2, 2)],
        0.5 * (m[(0, 1)] + m[(1, 0)]),
        0.5 * (m[(1, 2)] + m[(2, 1)]),
        0.5 * (m[(0, 2)] + m[(2, 0)]),
    ]
}

/// `sum_A d_A v_A v_A^T` for the columns `v_A` of `v`, exactly symmetric.
fn spectral_sum(v: &Matrix3<f64>, d: &Vector3<f64>) -> Matrix3<f64> {
    let mut out = Matrix3::zeros();
    for i in 0..3 {
        for j in i..3 {
            let x = d[0] * v[(i, 0)] * v[(j, 0)]
                + d[1] * v[(i, 1)] * v[(j, 1)]
                + d[2] * v[(i, 2)] * v[(j, 2)];
            out[(i, j)] = x;
            out[(j, i)] = x;
        }
    }
    out
}

/// Below this `|x|`, `ln(1 + x) / x` comes from its Taylor series. The
/// eigenvalue ratios of `b` in hot pressing (elastic strains of 1e-4 to 1e-3,
/// 1e-2 at the most) fall there, which spares the tangent a `ln_1p` per
/// eigenvalue pair at no cost in accuracy (truncation below 1e-19).
const SERIES_LIMIT: f64 = 1e-2;

/// `ln(1 + x) / x`, exact at `x = 0` and free of cancellation near it. The
/// series runs through `x^8`; its truncation error is below `x^9 / 10`.
fn ln1p_over_x(x: f64) -> f64 {
    if x.abs() < SERIES_LIMIT {
        const INV: [f64; 9] = [
            1.0,
            1.0 / 2.0,
            1.0 / 3.0,
            1.0 / 4.0,
            1.0 / 5.0,
            1.0 / 6.0,
            1.0 / 7.0,
            1.0 / 8.0,
            1.0 / 9.0,
        ];
        INV[..8].iter().rev().fold(INV[8], |s, c| c - x * s)
    } else {
        x.ln_1p() / x
    }
}

/// `(ln(b_a) - ln(b_b)) / (2 (b_a - b_b))`, the divided difference of `ln(b)/2`,
/// accurate when `b_a` and `b_b` are equal or nearly so.
fn half_log_divided_difference(ba: f64, bb: f64) -> f64 {
    0.5 * ln1p_over_x(ba / bb - 1.0) / bb
}

/// The consistent spatial tangent (module docs), assembled in the global
/// frame. With `m_AB = vec(n_A n_B^T)` (the eigenvectors `n_A` are the columns
/// of `q`), the nine `m_AB` are an orthonormal basis of the 9x9 index space and
///
/// ```text
/// a = sum_XY lambda_XY m_X m_Y^T,   X, Y in {AA, AB}
/// ```
///
/// where `lambda` has only the (AA, BB) block and, for each pair A != B, the
/// 2x2 block on (AB, BA). So `a = M^T W` with `W = lambda M` (rows `m_X`);
/// `M = Q (x) Q` makes the product two 3x3 rotations per column of `W`, about
/// 750 multiply-adds in all. `lambda` is symmetric, hence so is `a`.
#[allow(clippy::too_many_arguments)]
fn spatial_tangent(
    q: &Matrix3<f64>,
    b: &Vector3<f64>,
    tau: &Vector3<f64>,
    beta: f64,
    dq_dtrial: f64,
    nvec: &Vector3<f64>,
    g_mod: f64,
) -> SpatialTangent {
    // m[3 A + B][3 i + j] = n_Ai n_Bj.
    let mut m = [[0.0; 9]; 9];
    for aa in 0..3 {
        for bb in 0..3 {
            for i in 0..3 {
                for j in 0..3 {
                    m[3 * aa + bb][3 * i + j] = q[(i, aa)] * q[(j, bb)];
                }
            }
        }
    }
    let two_g_beta = 2.0 * g_mod * beta;
    let gamma = 2.0 * g_mod * (dq_dtrial - beta);
    // w[X] = sum_Y lambda_XY m[Y].
    let mut w = [[0.0; 9]; 9];
    for aa in 0..3 {
        let mut d = [0.0; 3];
        for bb in 0..3 {
            let delta = if aa == bb { 1.0 } else { 0.0 };
            d[bb] =
                two_g_beta * (delta - 1.0 / 3.0) + gamma * nvec[aa] * nvec[bb] - tau[aa] * delta;
        }
        let row = &mut w[4 * aa];
        for r in 0..9 {
            row[r] = d[0] * m[0][r] + d[1] * m[4][r] + d[2] * m[8][r];
        }
    }
    for (aa, bb) in [(0, 1), (0, 2), (1, 2)] {
        // theta_AB = theta_BA, and theta_AB b_A - tau_A = theta_AB b_B - tau_B
        // (module docs): one divided difference and one coupling per pair.
        let theta = two_g_beta * half_log_divided_difference(b[aa], b[bb]);
        let c = theta * b[aa] - tau[aa];
        let (x, y) = (3 * aa + bb, 3 * bb + aa);
        let (ab, ba) = (theta * b[bb], theta * b[aa]);
        for r in 0..9 {
            w[x][r] = ab * m[x][r] + c * m[y][r];
            w[y][r] = c * m[x][r] + ba * m[y][r];
        }
    }
    // a = M^T W column by column: column kl of W, read as the 3x3 matrix
    // T[A][B] = w[3 A + B][kl], maps to Q T Q^T (M = Q (x) Q), which takes 54
    // multiply-adds per column instead of 81.
    let mut out = [0.0; 81];
    for (kl, col) in out.chunks_exact_mut(9).enumerate() {
        let mut p = [[0.0; 3]; 3];
        for i in 0..3 {
            for bb in 0..3 {
                p[i][bb] =
                    q[(i, 0)] * w[bb][kl] + q[(i, 1)] * w[3 + bb][kl] + q[(i, 2)] * w[6 + bb][kl];
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                col[3 * i + j] = p[i][0] * q[(j, 0)] + p[i][1] * q[(j, 1)] + p[i][2] * q[(j, 2)];
            }
        }
    }
    SpatialTangent::from_column_slice(&out)
}

impl Material {
    /// Integrates the deviatoric response of one material point from the state
    /// `state` at the start of the step to the deformation gradient `f` at its
    /// end, over the time step `dt` \[s\].
    pub fn update_deviatoric(
        &self,
        f: &Matrix3<f64>,
        state: &PointState,
        dt: f64,
        with_tangent: bool,
    ) -> Result<DeviatoricResponse, MaterialError> {
        let det_f = f.determinant();
        if !(det_f > 0.0) {
            return Err(MaterialError::Inverted { det_f });
        }
        let g_mod = self.shear_modulus();
        // F Cp^-1 serves twice: for b_trial and for Cp^-1 at the end.
        let f_cp = f * sym_from6(&state.cp_inv);
        let b_trial = f_cp * f.transpose();
        let eig = symmetric_eigen(&b_trial);
        let q_mat = eig.eigenvectors;
        let b = eig.eigenvalues;
        if b.iter().any(|&x| !(x > 0.0)) {
            return Err(MaterialError::Inverted { det_f });
        }
        let eps = Vector3::new(0.5 * b[0].ln(), 0.5 * b[1].ln(), 0.5 * b[2].ln());
        let eps_vol = eps.sum();
        let e = eps.add_scalar(-eps_vol / 3.0);
        let e_norm = e.norm();
        let q_trial = 6.0_f64.sqrt() * g_mod * e_norm;
        let rm = self.return_map(q_trial, dt);
        let beta = if q_trial > 0.0 { rm.q / q_trial } else { 1.0 };
        let nvec = if e_norm > 0.0 {
            e / e_norm
        } else {
            Vector3::zeros()
        };
        let tau = e * (2.0 * g_mod * beta);

        let tangent = with_tangent
            .then(|| spatial_tangent(&q_mat, &b, &tau, beta, rm.dq_dtrial, &nvec, g_mod));
        let tau_dev = spectral_sum(&q_mat, &tau);
        // Cp^-1 at the end of the step. The return keeps the elastic volume and
        // scales the elastic log-strain deviator by beta, so b_new = F Cp^-1 F^T
        // has the eigenvectors n_A of b_trial and the eigenvalues b_A r_A,
        // r_A = exp(2 (beta - 1) e_A), whose product is 1 (isochoric flow).
        // From b_trial n_A = b_A n_A, F^-1 n_A = g_A / b_A with
        // g_A = Cp^-1 F^T n_A = (F Cp^-1)^T n_A, hence
        // Cp^-1 = F^-1 b_new F^-T = sum_A (r_A / b_A) g_A g_A^T: no inverse of F.
        // Without plastic flow the state is kept as it is, free of round-off.
        let cp_inv = if rm.dp > 0.0 {
            let r0 = (2.0 * (beta - 1.0) * e[0]).exp();
            let r1 = (2.0 * (beta - 1.0) * e[1]).exp();
            let r = Vector3::new(r0, r1, 1.0 / (r0 * r1));
            let g = f_cp.transpose() * q_mat;
            sym_to6(&spectral_sum(&g, &r.component_div(&b)))
        } else {
            state.cp_inv
        };
        Ok(DeviatoricResponse {
            tau_dev,
            tangent,
            state: PointState {
                cp_inv,
                eqps: state.eqps + rm.dp,
            },
            q: rm.q,
            dp: rm.dp,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat(n: f64) -> Material {
        Material::new(4.35e4, 0.3, 4.8e-7, n).unwrap()
    }

    /// First Piola stress of the deviatoric response, P = tau F^-T.
    fn piola(m: &Material, f: &Matrix3<f64>, s: &PointState, dt: f64) -> Matrix3<f64> {
        let r = m.update_deviatoric(f, s, dt, false).unwrap();
        r.tau_dev * f.try_inverse().unwrap().transpose()
    }

    /// A_iJkL = F^-1_Jj a_ijkl F^-1_Ll, the material tangent dP/dF.
    fn material_tangent(a: &SpatialTangent, f: &Matrix3<f64>) -> SpatialTangent {
        let fi = f.try_inverse().unwrap();
        let mut out = SpatialTangent::zeros();
        for i in 0..3 {
            for jj in 0..3 {
                for k in 0..3 {
                    for ll in 0..3 {
                        let mut s = 0.0;
                        for j in 0..3 {
                            for l in 0..3 {
                                s += fi[(jj, j)] * a[(3 * i + j, 3 * k + l)] * fi[(ll, l)];
                            }
                        }
                        out[(3 * i + jj, 3 * k + ll)] = s;
                    }
                }
            }
        }
        out
    }

    fn check_tangent(m: &Material, f: &Matrix3<f64>, s: &PointState, dt: f64) {
        let r = m.update_deviatoric(f, s, dt, true).unwrap();
        let tangent = r.tangent.unwrap();
        let a_mat = material_tangent(&tangent, f);
        let scale = a_mat.amax();
        let h = 1e-7;
        for k in 0..3 {
            for ll in 0..3 {
                let mut fp = *f;
                fp[(k, ll)] += h;
                let mut fm = *f;
                fm[(k, ll)] -= h;
                let dp = (piola(m, &fp, s, dt) - piola(m, &fm, s, dt)) / (2.0 * h);
                for i in 0..3 {
                    for jj in 0..3 {
                        let an = a_mat[(3 * i + jj, 3 * k + ll)];
                        let fd = dp[(i, jj)];
                        assert!(
                            (an - fd).abs() <= 2e-6 * scale,
                            "dP[{i}{jj}]/dF[{k}{ll}]: analytic {an}, fd {fd} (scale {scale})"
                        );
                    }
                }
            }
        }
        // Major symmetry of the spatial tangent.
        let asym = (tangent - tangent.transpose()).amax();
        assert!(asym <= 1e-9 * tangent.amax(), "asymmetry {asym}");
    }

    fn some_f(scale: f64) -> Matrix3<f64> {
        Matrix3::new(1.0, 0.3, -0.1, 0.05, 0.9, 0.2, -0.15, 0.1, 1.1).map(|x| x * scale)
            + Matrix3::identity() * (1.0 - scale)
    }

    #[test]
    fn tangent_equals_finite_differences_of_the_stress() {
        let prestrained = PointState {
            cp_inv: sym_to6(&{
                let fp: Matrix3<f64> = Matrix3::new(1.1, 0.05, 0.0, 0.0, 0.95, 0.02, 0.0, 0.0, 1.0);
                let fp = fp / fp.determinant().cbrt();
                let fpi = fp.try_inverse().unwrap();
                fpi * fpi.transpose()
            }),
            eqps: 0.1,
        };
        for &n in &[1.0, 2.8, 4.3, 8.0] {
            let m = mat(n);
            for &dt in &[1e-6, 1e-2, 10.0, 1e4] {
                for &scale in &[1e-3, 0.05, 1.0] {
                    check_tangent(&m, &some_f(scale), &PointState::default(), dt);
                    check_tangent(&m, &some_f(scale), &prestrained, dt);
                }
            }
        }
    }

    #[test]
    fn tangent_is_right_with_repeated_eigenvalues() {
        // Uniaxial stretch: two equal principal stretches; identity: three.
        let m = mat(2.8);
        let uni = Matrix3::from_diagonal(&Vector3::new(1.01, 0.995, 0.995));
        check_tangent(&m, &uni, &PointState::default(), 1.0);
        let rot = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.7).into_inner();
        check_tangent(&m, &(rot * uni), &PointState::default(), 1.0);
        check_tangent(&m, &(rot * 1.002), &PointState::default(), 1.0);
    }

    #[test]
    fn rigid_rotation_gives_no_stress_and_keeps_state() {
        let m = mat(4.3);
        let rot = nalgebra::Rotation3::from_euler_angles(0.4, 1.1, -0.3).into_inner();
        let r = m
            .update_deviatoric(&rot, &PointState::default(), 100.0, false)
            .unwrap();
        assert!(r.tau_dev.amax() < 1e-9);
        assert!(r.dp == 0.0);
    }

    #[test]
    fn plastic_flow_is_isochoric() {
        let m = mat(2.8);
        let f = some_f(1.0);
        let r = m
            .update_deviatoric(&f, &PointState::default(), 1e5, false)
            .unwrap();
        assert!(r.dp > 0.01);
        let det = sym_from6(&r.state.cp_inv).determinant();
        assert!((det - 1.0).abs() < 1e-12, "det Cp^-1 = {det}");
    }

    #[test]
    fn end_state_carries_the_returned_stress() {
        // Hencky elasticity at the end of the step: with b_new = F Cp^-1 F^T
        // from the returned state, tau_dev = G dev(ln b_new), and the elastic
        // volume is the trial one (det b_new = det b_trial).
        let m = mat(2.8);
        let g = m.shear_modulus();
        let prestrained = PointState {
            cp_inv: sym_to6(&{
                let fp: Matrix3<f64> = Matrix3::new(1.1, 0.05, 0.0, 0.0, 0.95, 0.02, 0.0, 0.0, 1.0);
                let fp = fp / fp.determinant().cbrt();
                let fpi = fp.try_inverse().unwrap();
                fpi * fpi.transpose()
            }),
            eqps: 0.1,
        };
        for &scale in &[1e-3, 0.05, 1.0] {
            for state in [PointState::default(), prestrained] {
                let f = some_f(scale);
                for &dt in &[1e-2, 10.0, 1e4] {
                    let r = m.update_deviatoric(&f, &state, dt, false).unwrap();
                    let b_trial = f * sym_from6(&state.cp_inv) * f.transpose();
                    let b_new = f * sym_from6(&r.state.cp_inv) * f.transpose();
                    let eig = nalgebra::SymmetricEigen::new(b_new);
                    let ln_b = eig.eigenvalues.map(f64::ln);
                    let dev = ln_b.add_scalar(-ln_b.sum() / 3.0);
                    let expected = eig.eigenvectors
                        * Matrix3::from_diagonal(&(dev * g))
                        * eig.eigenvectors.transpose();
                    let err = (r.tau_dev - expected).amax();
                    assert!(
                        err <= 1e-9 * r.tau_dev.amax().max(1e-3),
                        "scale {scale} dt {dt}: tau_dev off by {err:e}"
                    );
                    let dvol = b_new.determinant() / b_trial.determinant() - 1.0;
                    assert!(dvol.abs() < 1e-12, "elastic volume changed by {dvol:e}");
                }
            }
        }
    }

    #[test]
    fn step_without_flow_keeps_the_state_exactly() {
        // dt = 0: no creep, so Cp^-1 must come back bit for bit, not recomputed.
        let m = mat(4.3);
        let state = PointState {
            cp_inv: [1.01, 0.995, 0.9951, 0.003, -0.002, 0.001],
            eqps: 0.2,
        };
        let r = m
            .update_deviatoric(&some_f(0.05), &state, 0.0, false)
            .unwrap();
        assert_eq!(r.dp, 0.0);
        assert_eq!(r.state, state);
    }

    #[test]
    fn inverted_deformation_is_an_error() {
        let m = mat(2.8);
        let f = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -0.5));
        assert!(matches!(
            m.update_deviatoric(&f, &PointState::default(), 1.0, false),
            Err(MaterialError::Inverted { .. })
        ));
    }
}
