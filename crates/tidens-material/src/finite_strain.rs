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
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Spatial tangent `a` as a 9x9 matrix, row `3 i + j` for `g_ij`, column
/// `3 k + l` for `l_kl`: the linearised virtual work is `g : a : l` per unit
/// reference volume [MPa].
pub type SpatialTangent = SMatrix<f64, 9, 9>;

/// Deviatoric response of one material point over one time step.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviatoricResponse {
    /// Deviatoric Kirchhoff stress at the end of the step [MPa].
    pub tau_dev: Matrix3<f64>,
    /// Consistent spatial tangent of the deviatoric response (see module
    /// docs), when requested.
    pub tangent: Option<SpatialTangent>,
    /// State at the end of the step.
    pub state: PointState,
    /// von Mises (Kirchhoff) stress at the end of the step [MPa].
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

/// `(ln(b_a) - ln(b_b)) / (2 (b_a - b_b))`, the divided difference of `ln(b)/2`,
/// accurate when `b_a` and `b_b` are equal or nearly so.
fn half_log_divided_difference(ba: f64, bb: f64) -> f64 {
    let x = ba / bb - 1.0;
    let ln1p_over_x = if x.abs() < 1e-4 {
        1.0 - x / 2.0 + x * x / 3.0 - x * x * x / 4.0
    } else {
        x.ln_1p() / x
    };
    0.5 * ln1p_over_x / bb
}

/// The consistent spatial tangent (module docs), assembled in the global
/// frame from the eigenvectors `n_A` (columns of `q`) as a sum of outer
/// products of `vec(n_A n_B^T)`: the principal-frame tangent has only the
/// (AA, BB), (AB, AB) and (AB, BA) entries.
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
    // m[A][B] = vec(n_A n_B^T), index 3 i + j.
    let mut m = [[SVector::<f64, 9>::zeros(); 3]; 3];
    for aa in 0..3 {
        for bb in 0..3 {
            for i in 0..3 {
                for j in 0..3 {
                    m[aa][bb][3 * i + j] = q[(i, aa)] * q[(j, bb)];
                }
            }
        }
    }
    let two_g = 2.0 * g_mod;
    let gamma = two_g * (dq_dtrial - beta);
    let mut a = SpatialTangent::zeros();
    for aa in 0..3 {
        // sum_B a[AA,BB] m_BB, then one outer product per A.
        let mut col = SVector::<f64, 9>::zeros();
        for bb in 0..3 {
            let delta = if aa == bb { 1.0 } else { 0.0 };
            let d_ab =
                two_g * beta * (delta - 1.0 / 3.0) + gamma * nvec[aa] * nvec[bb] - tau[aa] * delta;
            col += m[bb][bb] * d_ab;
        }
        a += m[aa][aa] * col.transpose();
    }
    for aa in 0..3 {
        for bb in 0..3 {
            if aa == bb {
                continue;
            }
            let theta = two_g * beta * half_log_divided_difference(b[aa], b[bb]);
            let col = m[aa][bb] * (theta * b[bb]) + m[bb][aa] * (theta * b[aa] - tau[aa]);
            a += m[aa][bb] * col.transpose();
        }
    }
    a
}

impl Material {
    /// Integrates the deviatoric response of one material point from the state
    /// `state` at the start of the step to the deformation gradient `f` at its
    /// end, over the time step `dt` [s].
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
        let b_trial = f * sym_from6(&state.cp_inv) * f.transpose();
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
        let tau_dev = q_mat * Matrix3::from_diagonal(&tau) * q_mat.transpose();
        // Elastic log strain after the return: deviator scaled by beta, volume kept.
        let b_new_diag = Vector3::from_fn(|a, _| (2.0 * (beta * e[a] + eps_vol / 3.0)).exp());
        let b_new = q_mat * Matrix3::from_diagonal(&b_new_diag) * q_mat.transpose();
        let f_inv = f.try_inverse().ok_or(MaterialError::Inverted { det_f })?;
        let cp_inv = f_inv * b_new * f_inv.transpose();
        Ok(DeviatoricResponse {
            tau_dev,
            tangent,
            state: PointState {
                cp_inv: sym_to6(&cp_inv),
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
    fn inverted_deformation_is_an_error() {
        let m = mat(2.8);
        let f = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -0.5));
        assert!(matches!(
            m.update_deviatoric(&f, &PointState::default(), 1.0, false),
            Err(MaterialError::Inverted { .. })
        ));
    }
}
