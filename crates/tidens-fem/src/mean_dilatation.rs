//! The mean-dilatation Q1/P0 hexahedron for finite strain (Simo, Taylor and
//! Pister 1985), in its displacement-only (statically condensed) form.
//!
//! The element energy is split into a deviatoric part integrated with the full
//! 2x2x2 rule and a volumetric part evaluated once per element with the mean
//! dilatation `theta = v / V` (current over reference element volume):
//!
//! ```text
//! Pi_e(u) = sum_gp w0 W_dev(F_gp) + V U(theta),   U(theta) = K/2 (ln theta)^2
//! ```
//!
//! With Hencky elasticity this is exactly the energy of the F-bar gradient
//! `(theta / J)^(1/3) F`: scaling `F` changes only the volumetric log strain.
//! Plastic flow is isochoric, so the element imposes one incompressibility
//! constraint per element and does not lock; and since it is the second
//! variation of one (incremental) potential, its tangent is symmetric, which
//! lets the global system be factorised by Cholesky.
//!
//! Residual, with `g_a = grad_x N_a` at the Gauss point, `J = det F`:
//!
//! ```text
//! f_a = sum_gp w0 [ tau_dev g_a + U'(theta) J g_a ]
//! K_ab = sum_gp w0 [ G_a^T a_dev G_b + U'(theta) J (g_a g_b^T - g_b g_a^T) ]
//!        + U''(theta) / V  dv_a dv_b^T,      dv_a = sum_gp w0 J g_a
//! ```
//!
//! `a_dev` is the deviatoric spatial tangent of `tidens-material`; the middle
//! term is the second variation of the current volume.

use crate::error::FemError;
use nalgebra::Matrix3;
use tidens_material::{Material, PointState};
use tidens_mesh::hex;

/// Reference-configuration data of one element, computed once.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementGeometry {
    /// Gradients of the shape functions with respect to the reference
    /// coordinates, `grad[gp][a][J]` [1/mm].
    pub grad: [[[f64; 3]; 8]; 8],
    /// Gauss weight times reference Jacobian determinant [mm^3].
    pub weight: [f64; 8],
    /// Reference volume [mm^3].
    pub volume: f64,
}

impl ElementGeometry {
    /// Reference data of the element with node coordinates `x0`; the error
    /// carries the smallest Jacobian determinant when it is not positive.
    pub fn new(x0: &[[f64; 3]; 8]) -> Result<Self, f64> {
        let mut grad = [[[0.0; 3]; 8]; 8];
        let mut weight = [0.0; 8];
        for (gp, xi) in hex::gauss_points().iter().enumerate() {
            let dn = hex::shape_derivatives(*xi);
            let mut jac = Matrix3::zeros();
            for a in 0..8 {
                for i in 0..3 {
                    for k in 0..3 {
                        jac[(i, k)] += x0[a][i] * dn[a][k];
                    }
                }
            }
            let det = jac.determinant();
            if !(det > 0.0) {
                return Err(det);
            }
            let jinv = jac.try_inverse().ok_or(det)?;
            for a in 0..8 {
                for j in 0..3 {
                    grad[gp][a][j] = (0..3).map(|k| dn[a][k] * jinv[(k, j)]).sum();
                }
            }
            weight[gp] = det;
        }
        Ok(Self {
            grad,
            weight,
            volume: weight.iter().sum(),
        })
    }
}

/// What one element evaluation returns.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementOutput {
    /// Internal force, `residual[3 a + i]` [N].
    pub residual: [f64; 24],
    /// Consistent tangent, row-major 24x24, entry `(3a+i, 3b+k)` [N/mm]; empty
    /// when not requested.
    pub tangent: Vec<f64>,
    /// Material states at the end of the step.
    pub states: [PointState; 8],
    /// Current volume [mm^3].
    pub volume: f64,
    /// Largest equivalent plastic strain increment over the Gauss points.
    pub max_dp: f64,
    /// Volume-weighted mean von Mises Cauchy stress [MPa].
    pub von_mises: f64,
    /// Mean (Cauchy) stress, tension positive [MPa].
    pub mean_stress: f64,
    /// Volume-weighted mean equivalent plastic strain.
    pub eqps: f64,
}

/// Evaluates one element at current node coordinates `x` after a time step
/// `dt` [s] from the states `states_n`.
pub fn evaluate(
    element: usize,
    geom: &ElementGeometry,
    x: &[[f64; 3]; 8],
    states_n: &[PointState; 8],
    material: &Material,
    dt: f64,
    with_tangent: bool,
) -> Result<ElementOutput, FemError> {
    let mut residual = [0.0; 24];
    let mut tangent = if with_tangent {
        vec![0.0; 576]
    } else {
        Vec::new()
    };
    let mut states = [PointState::default(); 8];
    let mut dv = [0.0; 24];
    let mut gx = [[[0.0; 3]; 8]; 8];
    let mut jdet = [0.0; 8];
    let mut volume = 0.0;
    let mut max_dp: f64 = 0.0;
    let mut q_sum = 0.0;
    let mut p_sum = 0.0;
    for gp in 0..8 {
        let g0 = &geom.grad[gp];
        let mut f = Matrix3::zeros();
        for a in 0..8 {
            for i in 0..3 {
                for jj in 0..3 {
                    f[(i, jj)] += x[a][i] * g0[a][jj];
                }
            }
        }
        let det_f = f.determinant();
        if !(det_f > 0.0) {
            return Err(FemError::Inverted { element, det_f });
        }
        let f_inv = f
            .try_inverse()
            .ok_or(FemError::Inverted { element, det_f })?;
        for a in 0..8 {
            for j in 0..3 {
                gx[gp][a][j] = (0..3).map(|jj| g0[a][jj] * f_inv[(jj, j)]).sum();
            }
        }
        jdet[gp] = det_f;
        let w = geom.weight[gp];
        volume += w * det_f;
        for a in 0..8 {
            for i in 0..3 {
                dv[3 * a + i] += w * det_f * gx[gp][a][i];
            }
        }
        let resp = material
            .update_deviatoric(&f, &states_n[gp], dt, with_tangent)
            .map_err(|_| FemError::Inverted { element, det_f })?;
        states[gp] = resp.state;
        max_dp = max_dp.max(resp.dp);
        q_sum += w * resp.q;
        p_sum += w * resp.state.eqps;
        let g = &gx[gp];
        for a in 0..8 {
            for i in 0..3 {
                residual[3 * a + i] +=
                    w * (0..3).map(|j| resp.tau_dev[(i, j)] * g[a][j]).sum::<f64>();
            }
        }
        if let Some(at) = &resp.tangent {
            // t[(ij), (b k)] = sum_l a[(ij),(kl)] g_b,l
            let mut t = [[0.0; 24]; 9];
            for (ij, row) in t.iter_mut().enumerate() {
                for b in 0..8 {
                    for k in 0..3 {
                        row[3 * b + k] = (0..3).map(|l| at[(ij, 3 * k + l)] * g[b][l]).sum();
                    }
                }
            }
            for a in 0..8 {
                for i in 0..3 {
                    let r = (3 * a + i) * 24;
                    for col in 0..24 {
                        let s: f64 = (0..3).map(|j| g[a][j] * t[3 * i + j][col]).sum();
                        tangent[r + col] += w * s;
                    }
                }
            }
        }
    }
    let v0 = geom.volume;
    let theta = volume / v0;
    let k_bulk = material.bulk_modulus();
    let ln_theta = theta.ln();
    let u1 = k_bulk * ln_theta / theta;
    let u2 = k_bulk * (1.0 - ln_theta) / (theta * theta);
    for (r, d) in residual.iter_mut().zip(dv.iter()) {
        *r += u1 * d;
    }
    if with_tangent {
        for gp in 0..8 {
            let c = u1 * geom.weight[gp] * jdet[gp];
            let g = &gx[gp];
            for a in 0..8 {
                for i in 0..3 {
                    let r = (3 * a + i) * 24;
                    for b in 0..8 {
                        for k in 0..3 {
                            tangent[r + 3 * b + k] += c * (g[a][i] * g[b][k] - g[a][k] * g[b][i]);
                        }
                    }
                }
            }
        }
        let c = u2 / v0;
        for p in 0..24 {
            for q in 0..24 {
                tangent[p * 24 + q] += c * dv[p] * dv[q];
            }
        }
    }
    Ok(ElementOutput {
        residual,
        tangent,
        states,
        volume,
        max_dp,
        von_mises: q_sum / v0 / theta,
        mean_stress: u1,
        eqps: p_sum / v0,
    })
}
