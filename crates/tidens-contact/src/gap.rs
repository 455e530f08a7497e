//! Gap functions of node-to-surface contact against bilinear quadrilateral
//! facets, written once for real and dual numbers so that their exact
//! gradients and Hessians come from `num-dual`.
//!
//! A master facet is the bilinear patch `x(xi, eta) = sum_a N_a x_a` over
//! `[-1, 1]^2` (nodes counter-clockwise about its outward normal). The slave
//! point `s` projects on it where `(s - x) . x_xi = (s - x) . x_eta = 0`; its
//! penetration is `p = -(s - x) . n` with `n = x_xi x x_eta / |...|`. The
//! bilinear patch treats both diagonals of a quad alike, so mirror-symmetric
//! meshes give mirror-symmetric contact.

use nalgebra::SVector;
use num_dual::DualNum;

/// Reference coordinates of the four facet nodes.
const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Bilinear shape functions at (xi, eta).
pub fn shape(xi: [f64; 2]) -> [f64; 4] {
    CORNERS.map(|c| 0.25 * (1.0 + c[0] * xi[0]) * (1.0 + c[1] * xi[1]))
}

/// Patch point and tangents at (xi, eta) for a generic scalar.
fn patch<D: DualNum<Primitive = f64> + Copy>(
    x: &[[D; 3]; 4],
    xi: D,
    eta: D,
) -> ([D; 3], [D; 3], [D; 3], [D; 3]) {
    let one = D::one();
    let quarter = D::from(0.25);
    let mut p = [D::zero(); 3];
    let mut dxi = [D::zero(); 3];
    let mut deta = [D::zero(); 3];
    let mut dxieta = [D::zero(); 3];
    for (a, c) in CORNERS.iter().enumerate() {
        let (cx, cy) = (D::from(c[0]), D::from(c[1]));
        let n = quarter * (one + cx * xi) * (one + cy * eta);
        let nxi = quarter * cx * (one + cy * eta);
        let neta = quarter * (one + cx * xi) * cy;
        let nxieta = quarter * cx * cy;
        for i in 0..3 {
            p[i] += n * x[a][i];
            dxi[i] += nxi * x[a][i];
            deta[i] += neta * x[a][i];
            dxieta[i] += nxieta * x[a][i];
        }
    }
    (p, dxi, deta, dxieta)
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
    let (p, dxi, deta, dxieta) = patch(x, xi, eta);
    let d = [s[0] - p[0], s[1] - p[1], s[2] - p[2]];
    let f1 = dot(&d, &dxi);
    let f2 = dot(&d, &deta);
    // d x_xi / d xi = d x_eta / d eta = 0 for a bilinear patch.
    let j11 = -dot(&dxi, &dxi);
    let j12 = dot(&d, &dxieta) - dot(&dxi, &deta);
    let j22 = -dot(&deta, &deta);
    let det = j11 * j22 - j12 * j12;
    let dxi_step = (j22 * f1 - j12 * f2) / det;
    let deta_step = (j11 * f2 - j12 * f1) / det;
    (xi - dxi_step, eta - deta_step)
}

/// Parameters (xi, eta) of the projection of `s` on the bilinear patch `x`
/// (Newton from the patch centre; may lie outside [-1, 1]^2 when `s` is
/// beyond an edge).
pub fn project(s: &[f64; 3], x: &[[f64; 3]; 4]) -> [f64; 2] {
    let (mut xi, mut eta) = (0.0, 0.0);
    for _ in 0..30 {
        let (a, b) = newton_step(s, x, xi, eta);
        let moved = (a - xi).abs().max((b - eta).abs());
        (xi, eta) = (a, b);
        if !(moved > 1e-15) {
            break;
        }
    }
    [xi, eta]
}

/// Penetration of the slave point `w[0..3]` into the bilinear patch of
/// nodes `w[3..6], ..., w[12..15]` [mm], positive inside. `xi0` is the
/// converged projection in real numbers; two more Newton iterations in the
/// scalar type carry the exact first and second derivatives of the
/// projection point into the result.
pub fn penetration<D: DualNum<Primitive = f64> + Copy>(w: &SVector<D, 15>, xi0: [f64; 2]) -> D {
    let s = [w[0], w[1], w[2]];
    let x: [[D; 3]; 4] = std::array::from_fn(|a| [w[3 + 3 * a], w[4 + 3 * a], w[5 + 3 * a]]);
    let (mut xi, mut eta) = (D::from(xi0[0]), D::from(xi0[1]));
    for _ in 0..2 {
        (xi, eta) = newton_step(&s, &x, xi, eta);
    }
    let (p, dxi, deta, _) = patch(&x, xi, eta);
    let m = [
        dxi[1] * deta[2] - dxi[2] * deta[1],
        dxi[2] * deta[0] - dxi[0] * deta[2],
        dxi[0] * deta[1] - dxi[1] * deta[0],
    ];
    let norm = dot(&m, &m).sqrt();
    let d = [s[0] - p[0], s[1] - p[1], s[2] - p[2]];
    -dot(&d, &m) / norm
}

/// Gap vector of a tied node: slave point minus the material point of the
/// master patch at (xi, eta) [mm].
pub fn tie_gap(slave: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> [f64; 3] {
    let n = shape(xi);
    [0, 1, 2].map(|i| slave[i] - (0..4).map(|a| n[a] * x[a][i]).sum::<f64>())
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{Dual2SVec64, DualSVec64};

    fn pack(s: [f64; 3], x: [[f64; 3]; 4]) -> SVector<f64, 15> {
        let mut v = SVector::<f64, 15>::zeros();
        for i in 0..3 {
            v[i] = s[i];
            for a in 0..4 {
                v[3 + 3 * a + i] = x[a][i];
            }
        }
        v
    }

    #[test]
    fn flat_patch_gives_the_signed_distance_and_bilinear_weights_in_the_gradient() {
        // Unit square in z = 1, normal +z; slave below it.
        let x = [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ];
        let s = [0.3, 0.6, 0.9];
        let xi = project(&s, &x);
        assert!((xi[0] + 0.4).abs() < 1e-14 && (xi[1] - 0.2).abs() < 1e-14);
        let (p, g) = num_dual::gradient(
            |w: SVector<DualSVec64<15>, 15>| penetration(&w, xi),
            &pack(s, x),
        );
        assert!((p - 0.1).abs() < 1e-15);
        let n = shape(xi);
        assert!((g[2] + 1.0).abs() < 1e-14 && g[0].abs() < 1e-14 && g[1].abs() < 1e-14);
        for a in 0..4 {
            assert!((g[3 + 3 * a + 2] - n[a]).abs() < 1e-14, "node {a}");
        }
    }

    #[test]
    fn hessian_of_the_penetration_matches_finite_differences_on_a_warped_patch() {
        let x = [
            [0.0, 0.02, 1.0],
            [1.05, -0.03, 1.08],
            [0.97, 1.0, 0.95],
            [0.03, 0.96, 1.04],
        ];
        let s = [0.41, 0.37, 0.93];
        let v = pack(s, x);
        let xi = project(&s, &x);
        let (_, _, h) =
            num_dual::hessian(|w: SVector<Dual2SVec64<15>, 15>| penetration(&w, xi), &v);
        // Gradient at a perturbed point, re-projecting each time.
        let grad = |v: &SVector<f64, 15>| {
            let s = [v[0], v[1], v[2]];
            let x: [[f64; 3]; 4] =
                std::array::from_fn(|a| [v[3 + 3 * a], v[4 + 3 * a], v[5 + 3 * a]]);
            let xi = project(&s, &x);
            num_dual::gradient(|w: SVector<DualSVec64<15>, 15>| penetration(&w, xi), v).1
        };
        let step = 1e-6;
        for j in 0..15 {
            let (mut vp, mut vm) = (v, v);
            vp[j] += step;
            vm[j] -= step;
            let fd = (grad(&vp) - grad(&vm)) / (2.0 * step);
            for i in 0..15 {
                assert!(
                    (fd[i] - h[(i, j)]).abs() < 1e-7,
                    "H[{i},{j}] {} vs {}",
                    h[(i, j)],
                    fd[i]
                );
            }
        }
    }

    #[test]
    fn both_diagonals_are_treated_alike() {
        // A patch and the same patch with its nodes renumbered from another
        // corner give the same penetration for any slave point.
        let x = [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.2],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 0.8],
        ];
        let y = [x[1], x[2], x[3], x[0]];
        for s in [[0.2, 0.7, 0.95], [0.6, 0.3, 1.1]] {
            let (px, py) = (
                penetration(&pack(s, x), project(&s, &x)),
                penetration(&pack(s, y), project(&s, &y)),
            );
            assert!((px - py).abs() < 1e-14);
        }
    }
}
