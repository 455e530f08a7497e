//! Geometry of node-to-surface contact against bilinear quadrilateral
//! facets: the patch, the closest-point projection on it, and the gap of a
//! tied node (units mm).
//!
//! A master facet is the bilinear patch `x(xi, eta) = sum_a N_a x_a` over
//! `[-1, 1]^2` (nodes counter-clockwise about its outward normal). The slave
//! point `s` projects on it where `(s - x) . x_xi = (s - x) . x_eta = 0`.
//! The bilinear patch treats both diagonals of a quad alike, so
//! mirror-symmetric meshes give mirror-symmetric contact. The penetration
//! and its derivatives are in [`mod@crate::penetration`].

/// Reference coordinates of the four facet nodes.
pub(crate) const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Bilinear shape functions at (xi, eta).
pub fn shape(xi: [f64; 2]) -> [f64; 4] {
    CORNERS.map(|c| 0.25 * (1.0 + c[0] * xi[0]) * (1.0 + c[1] * xi[1]))
}

/// The patch at one parameter point: the shape functions and their
/// derivatives, the point, its tangents and its twist.
#[derive(Clone, Copy, Debug, Default)]
pub struct PatchPoint {
    /// `N_a` \[-\].
    pub shape: [f64; 4],
    /// `N_a,xi` and `N_a,eta` \[-\].
    pub shape_derivatives: [[f64; 2]; 4],
    /// `x` \[mm\].
    pub point: [f64; 3],
    /// `x_xi` and `x_eta` \[mm\].
    pub tangents: [[f64; 3]; 2],
    /// `x_xi,eta` \[mm\] (`x_xi,xi = x_eta,eta = 0` on a bilinear patch).
    pub twist: [f64; 3],
}

/// The patch of nodes `x` at (xi, eta).
pub fn patch(x: &[[f64; 3]; 4], xi: [f64; 2]) -> PatchPoint {
    let mut p = PatchPoint::default();
    for (a, c) in CORNERS.iter().enumerate() {
        let n = 0.25 * (1.0 + c[0] * xi[0]) * (1.0 + c[1] * xi[1]);
        let n_xi = 0.25 * c[0] * (1.0 + c[1] * xi[1]);
        let n_eta = 0.25 * (1.0 + c[0] * xi[0]) * c[1];
        let n_xieta = 0.25 * c[0] * c[1];
        p.shape[a] = n;
        p.shape_derivatives[a] = [n_xi, n_eta];
        for i in 0..3 {
            p.point[i] += n * x[a][i];
            p.tangents[0][i] += n_xi * x[a][i];
            p.tangents[1][i] += n_eta * x[a][i];
            p.twist[i] += n_xieta * x[a][i];
        }
    }
    p
}

pub(crate) fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// One Newton iteration of the projection conditions from `xi`. Their
/// Jacobian is `-(m - g kappa)` (metric, gap times curvature; see
/// [`mod@crate::penetration`]): `x_xi,xi = x_eta,eta = 0` on a bilinear patch.
fn newton_step(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> [f64; 2] {
    let p = patch(x, xi);
    let [dxi, deta] = &p.tangents;
    let d = sub(s, &p.point);
    let f1 = dot(&d, dxi);
    let f2 = dot(&d, deta);
    let j11 = -dot(dxi, dxi);
    let j12 = dot(&d, &p.twist) - dot(dxi, deta);
    let j22 = -dot(deta, deta);
    let det = j11 * j22 - j12 * j12;
    let dxi_step = (j22 * f1 - j12 * f2) / det;
    let deta_step = (j11 * f2 - j12 * f1) / det;
    [xi[0] - dxi_step, xi[1] - deta_step]
}

/// Parameters (xi, eta) of the projection of `s` on the bilinear patch `x`
/// (Newton from the patch centre; may lie outside [-1, 1]^2 when `s` is
/// beyond an edge).
pub fn project(s: &[f64; 3], x: &[[f64; 3]; 4]) -> [f64; 2] {
    project_from(s, x, [0.0, 0.0])
}

/// Like [`project`], Newton starting from `xi`: to follow a projection that
/// is known nearby (far outside a strongly twisted patch, Newton from the
/// centre can wander to another stationary point of the distance).
pub fn project_from(s: &[f64; 3], x: &[[f64; 3]; 4], mut xi: [f64; 2]) -> [f64; 2] {
    for _ in 0..30 {
        let next = newton_step(s, x, xi);
        let moved = (next[0] - xi[0]).abs().max((next[1] - xi[1]).abs());
        xi = next;
        if !(moved > 1e-15) {
            break;
        }
    }
    xi
}

/// Linear shape functions of a 3-node triangle at (xi, eta).
pub fn triangle_shape(xi: [f64; 2]) -> [f64; 3] {
    [1.0 - xi[0] - xi[1], xi[0], xi[1]]
}

/// Parameters (xi, eta) of the foot of `s` on the plane of the triangle `x`
/// (`x = x_1 + xi (x_2 - x_1) + eta (x_3 - x_1)`; outside the triangle when
/// `s` is beyond an edge): the closest-point conditions are linear there.
pub fn project_triangle(s: &[f64; 3], x: &[[f64; 3]; 3]) -> [f64; 2] {
    let (a1, a2) = (sub(&x[1], &x[0]), sub(&x[2], &x[0]));
    let d = sub(s, &x[0]);
    let (m11, m12, m22) = (dot(&a1, &a1), dot(&a1, &a2), dot(&a2, &a2));
    let (r1, r2) = (dot(&d, &a1), dot(&d, &a2));
    let det = m11 * m22 - m12 * m12;
    [(m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det]
}

/// Gap vector of a tied node: slave point minus the material point of the
/// master patch at (xi, eta) \[mm\].
pub fn tie_gap(slave: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> [f64; 3] {
    let n = shape(xi);
    [0, 1, 2].map(|i| slave[i] - (0..4).map(|a| n[a] * x[a][i]).sum::<f64>())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_of_a_point_above_a_flat_patch_is_its_foot() {
        // Unit square in z = 1; the foot of (0.3, 0.6, z) is (-0.4, 0.2).
        let x = [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ];
        let xi = project(&[0.3, 0.6, 0.9], &x);
        assert!((xi[0] + 0.4).abs() < 1e-14 && (xi[1] - 0.2).abs() < 1e-14);
    }

    #[test]
    fn projection_satisfies_the_closest_point_conditions_on_a_warped_patch() {
        let x = [
            [0.0, 0.02, 1.0],
            [1.05, -0.03, 1.08],
            [0.97, 1.0, 0.95],
            [0.03, 0.96, 1.04],
        ];
        for s in [[0.41, 0.37, 0.93], [1.1, -0.05, 1.2], [-0.1, 1.08, 0.9]] {
            let xi = project(&s, &x);
            let p = patch(&x, xi);
            let d = sub(&s, &p.point);
            for t in &p.tangents {
                assert!(dot(&d, t).abs() < 1e-14, "{s:?}: {}", dot(&d, t));
            }
        }
    }

    #[test]
    fn shape_functions_and_their_derivatives_reproduce_the_patch() {
        let x = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.3],
            [1.6, 0.8, -0.2],
            [0.4, 1.0, 0.5],
        ];
        let xi = [0.3, -0.7];
        let p = patch(&x, xi);
        assert_eq!(p.shape, shape(xi));
        let h = 1e-6;
        for k in 0..2 {
            let (mut up, mut down) = (xi, xi);
            up[k] += h;
            down[k] -= h;
            let (pu, pd) = (patch(&x, up), patch(&x, down));
            for i in 0..3 {
                let fd = (pu.point[i] - pd.point[i]) / (2.0 * h);
                assert!((fd - p.tangents[k][i]).abs() < 1e-9);
            }
            // The twist is the derivative of x_xi along eta.
            if k == 1 {
                for i in 0..3 {
                    let fd = (pu.tangents[0][i] - pd.tangents[0][i]) / (2.0 * h);
                    assert!((fd - p.twist[i]).abs() < 1e-9);
                }
            }
        }
    }
}
