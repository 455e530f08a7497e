use serde::{Deserialize, Serialize};

/// Internal state of one material point, saved at every converged step.
///
/// `cp_inv` is the inverse plastic right Cauchy-Green tensor `Cp^-1 = Fp^-1 Fp^-T`
/// (symmetric, stored as xx, yy, zz, xy, yz, xz; `det = 1` because plastic flow is
/// isochoric). The elastic left Cauchy-Green tensor is recovered as
/// `be = F Cp^-1 F^T`. `eqps` is the equivalent (von Mises) plastic strain.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointState {
    pub cp_inv: [f64; 6],
    pub eqps: f64,
}

impl Default for PointState {
    /// The virgin state: no plastic deformation.
    fn default() -> Self {
        Self {
            cp_inv: [1.0, 1.0, 1.0, 0.0, 0.0, 0.0],
            eqps: 0.0,
        }
    }
}
