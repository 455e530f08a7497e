//! Gap functions of node-to-surface contact, written once for real and dual
//! numbers so that their exact gradients and Hessians come from `num-dual`.

use nalgebra::SVector;
use num_dual::DualNum;

/// Penetration of a slave point into the plane of a master triangle [mm]:
/// minus the signed distance of `w[0..3]` from the plane through
/// `w[3..6], w[6..9], w[9..12]` along the triangle's right-hand normal (the
/// outward normal of the master surface). Positive when the point is inside.
pub fn penetration<D: DualNum + Copy>(w: &SVector<D, 12>) -> D {
    let s = [w[0], w[1], w[2]];
    let a = [w[3], w[4], w[5]];
    let b = [w[6], w[7], w[8]];
    let c = [w[9], w[10], w[11]];
    let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let m = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let norm = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    let d = [s[0] - a[0], s[1] - a[1], s[2] - a[2]];
    -(d[0] * m[0] + d[1] * m[1] + d[2] * m[2]) / norm
}

/// Gap vector of a tied node: slave point minus the material point of the
/// master triangle at barycentric coordinates `bary` [mm].
pub fn tie_gap(slave: &[f64; 3], tri: &[[f64; 3]; 3], bary: &[f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| slave[i] - (0..3).map(|c| bary[c] * tri[c][i]).sum::<f64>())
}

/// Barycentric coordinates of the projection of `p` onto the plane of `tri`.
pub fn barycentric(p: &[f64; 3], tri: &[[f64; 3]; 3]) -> [f64; 3] {
    let sub = |u: &[f64; 3], v: &[f64; 3]| [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
    let dot = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let (e1, e2, d) = (
        sub(&tri[1], &tri[0]),
        sub(&tri[2], &tri[0]),
        sub(p, &tri[0]),
    );
    let (a11, a12, a22) = (dot(&e1, &e1), dot(&e1, &e2), dot(&e2, &e2));
    let (b1, b2) = (dot(&d, &e1), dot(&d, &e2));
    let det = a11 * a22 - a12 * a12;
    let u = (a22 * b1 - a12 * b2) / det;
    let v = (a11 * b2 - a12 * b1) / det;
    [1.0 - u - v, u, v]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn penetration_is_minus_the_signed_distance_and_its_gradient_is_the_normal_split_by_barycentric_weights()
     {
        // Triangle in the plane z = 1 with normal +z; slave below it.
        let tri = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
        let s = [0.2, 0.3, 0.9];
        let mut v = SVector::<f64, 12>::zeros();
        for i in 0..3 {
            v[i] = s[i];
            for c in 0..3 {
                v[3 + 3 * c + i] = tri[c][i];
            }
        }
        let (p, g) = num_dual::gradient(
            |w: SVector<num_dual::DualSVec64<12>, 12>| penetration(&w),
            &v,
        );
        assert!((p - 0.1).abs() < 1e-15);
        let bary = barycentric(&s, &tri);
        assert!((bary[0] - 0.5).abs() < 1e-15 && (bary[1] - 0.2).abs() < 1e-15);
        // d p / d slave = -n; d p / d master node c = N_c n.
        assert!((g[2] + 1.0).abs() < 1e-14 && g[0].abs() < 1e-14);
        for c in 0..3 {
            assert!((g[3 + 3 * c + 2] - bary[c]).abs() < 1e-14);
        }
    }

    #[test]
    fn hessian_matches_finite_differences_of_the_gradient() {
        let v = SVector::<f64, 12>::from_column_slice(&[
            0.21, 0.33, 0.95, 0.0, 0.01, 1.0, 1.02, -0.03, 1.05, 0.04, 0.98, 0.97,
        ]);
        let (_, _, h) = num_dual::hessian(
            |w: SVector<num_dual::Dual2SVec64<12>, 12>| penetration(&w),
            &v,
        );
        let grad = |v: &SVector<f64, 12>| {
            num_dual::gradient(
                |w: SVector<num_dual::DualSVec64<12>, 12>| penetration(&w),
                v,
            )
            .1
        };
        let step = 1e-6;
        for j in 0..12 {
            let (mut vp, mut vm) = (v, v);
            vp[j] += step;
            vm[j] -= step;
            let fd = (grad(&vp) - grad(&vm)) / (2.0 * step);
            for i in 0..12 {
                assert!(
                    (fd[i] - h[(i, j)]).abs() < 1e-7,
                    "H[{i},{j}] {} vs {}",
                    h[(i, j)],
                    fd[i]
                );
            }
        }
    }
}
