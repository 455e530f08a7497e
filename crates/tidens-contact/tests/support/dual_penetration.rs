//! Reference derivatives of the penetration by automatic differentiation:
//! the penetration written once for any `num-dual` scalar, with two Newton
//! iterations of the projection in dual arithmetic carrying the exact first
//! and second derivatives of the projection point into the result. Slow
//! (hyper-dual numbers over 15 variables) but independent of the closed
//! form it checks.

use nalgebra::SVector;
use num_dual::{Dual2SVec64, DualNum, DualSVec64};

const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Patch point, tangents and twist at (xi, eta) for a generic scalar.
fn patch<D: DualNum<Primitive = f64> + Copy>(x: &[[D; 3]; 4], xi: D, eta: D) -> [[D; 3]; 4] {
    let one = D::one();
    let quarter = D::from(0.25);
    let mut out = [[D::zero(); 3]; 4];
    for (a, c) in CORNERS.iter().enumerate() {
        let (cx, cy) = (D::from(c[0]), D::from(c[1]));
        let w = [
            quarter * (one + cx * xi) * (one + cy * eta),
            quarter * cx * (one + cy * eta),
            quarter * (one + cx * xi) * cy,
            quarter * cx * cy,
        ];
        for k in 0..4 {
            for i in 0..3 {
                out[k][i] += w[k] * x[a][i];
            }
        }
    }
    out
}

fn dot<D: DualNum<Primitive = f64> + Copy>(a: &[D; 3], b: &[D; 3]) -> D {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// One Newton iteration of the projection conditions from (xi, eta).
fn newton_step<D: DualNum<Primitive = f64> + Copy>(
    s: &[D; 3],
    x: &[[D; 3]; 4],
    xi: D,
    eta: D,
) -> (D, D) {
    let [p, dxi, deta, dxieta] = patch(x, xi, eta);
    let d = [s[0] - p[0], s[1] - p[1], s[2] - p[2]];
    let f1 = dot(&d, &dxi);
    let f2 = dot(&d, &deta);
    let j11 = -dot(&dxi, &dxi);
    let j12 = dot(&d, &dxieta) - dot(&dxi, &deta);
    let j22 = -dot(&deta, &deta);
    let det = j11 * j22 - j12 * j12;
    (
        xi - (j22 * f1 - j12 * f2) / det,
        eta - (j11 * f2 - j12 * f1) / det,
    )
}

/// Penetration of the slave point `w[0..3]` into the bilinear patch of
/// nodes `w[3..6], ..., w[12..15]` \[mm\]; `xi0` is the converged projection.
pub fn penetration<D: DualNum<Primitive = f64> + Copy>(w: &SVector<D, 15>, xi0: [f64; 2]) -> D {
    let s = [w[0], w[1], w[2]];
    let x: [[D; 3]; 4] = std::array::from_fn(|a| [w[3 + 3 * a], w[4 + 3 * a], w[5 + 3 * a]]);
    let (mut xi, mut eta) = (D::from(xi0[0]), D::from(xi0[1]));
    for _ in 0..2 {
        (xi, eta) = newton_step(&s, &x, xi, eta);
    }
    let [p, dxi, deta, _] = patch(&x, xi, eta);
    let m = [
        dxi[1] * deta[2] - dxi[2] * deta[1],
        dxi[2] * deta[0] - dxi[0] * deta[2],
        dxi[0] * deta[1] - dxi[1] * deta[0],
    ];
    let d = [s[0] - p[0], s[1] - p[1], s[2] - p[2]];
    -dot(&d, &m) / dot(&m, &m).sqrt()
}

/// The 15 term coordinates: slave xyz, then the facet nodes' xyz.
pub fn pack(s: &[f64; 3], x: &[[f64; 3]; 4]) -> SVector<f64, 15> {
    SVector::from_fn(|k, _| {
        if k < 3 {
            s[k]
        } else {
            x[(k - 3) / 3][(k - 3) % 3]
        }
    })
}

/// Penetration and gradient by dual numbers.
pub fn gradient(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> (f64, [f64; 15]) {
    let (p, g) = num_dual::gradient(
        |w: SVector<DualSVec64<15>, 15>| penetration(&w, xi),
        &pack(s, x),
    );
    (p, g.into())
}

/// Penetration, gradient and Hessian (row-major) by hyper-dual numbers.
pub fn hessian(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> (f64, [f64; 15], [[f64; 15]; 15]) {
    let (p, g, h) = num_dual::hessian(
        |w: SVector<Dual2SVec64<15>, 15>| penetration(&w, xi),
        &pack(s, x),
    );
    (
        p,
        g.into(),
        std::array::from_fn(|i| std::array::from_fn(|j| h[(i, j)])),
    )
}
