//! Penetration of a slave node into a bilinear master facet, with its exact
//! first and second derivatives in closed form (units mm).
//!
//! The derivatives are those of the classical node-to-surface linearisation
//! of the normal gap (Wriggers, *Computational Contact Mechanics*, 2nd ed.,
//! Springer 2006), written out here for the bilinear patch and for a
//! projection that need not lie on the surface (`g != 0`: the node is in
//! front of the facet or has pressed into it).
//!
//! # Energy
//!
//! A slave node of tributary area `A` \[mm^2\] pressing with multiplier
//! `lambda` \[MPa\] and penalty `eps` \[MPa/mm\] stores (per pass, see the crate
//! docs) `W = A / (4 eps) <lambda + eps p>^2` \[N mm\]; its force is
//! `dW/du = A/2 <lambda + eps p> dp/du` \[N\] and its tangent
//! `d2W/du2 = A/2 (eps dp/du (x) dp/du + <lambda + eps p> d2p/du2)` \[N/mm\]
//! while it presses. Everything below is about `p` and its two derivatives.
//!
//! # Geometry
//!
//! The facet is the patch `x(xi) = sum_a N_a(xi) x_a`, `xi = (xi^1, xi^2)`
//! (see [`crate::gap`]), with tangents `a_al = x_,al = sum_a N_a,al x_a`,
//! metric `m_ab = a_a . a_b` (inverse `m^ab`, dual basis
//! `a^al = m^ab a_b`), unit normal `n = a_1 x a_2 / |a_1 x a_2|` and
//! curvature `kappa_ab = n . x_,ab`. On a bilinear patch
//! `x_,11 = x_,22 = 0`, so only `kappa_12 = kappa_21 = n . x_,12` remains
//! (the twist of the patch).
//!
//! # Gap
//!
//! The slave point `s` projects at `xi*`, where `(s - x(xi*)) . a_al = 0`.
//! There `s - x = g n` with `g = (s - x) . n` the signed gap (positive in
//! front of the facet), and the penetration is
//!
//! ```text
//! p(u) = -(s - x(xi*)) . n(xi*) = -g,    u = (s, x_1, x_2, x_3, x_4) in R^15.
//! ```
//!
//! # First variation
//!
//! With `dw = ds - sum_a N_a dx_a` the motion of the slave relative to the
//! material point under it, `d(s - x) = dw - a_al dxi^al`. The tangents are
//! normal to `n`, and `(s - x) . dn = g n . dn = 0` since `n` is a unit
//! vector; so the projection's motion drops out:
//!
//! ```text
//! dp = -n . dw,    dp/ds = -n,    dp/dx_a = N_a n.
//! ```
//!
//! # Variations of the projection and of the normal
//!
//! Write `da_al^0 = sum_a N_a,al dx_a` for the change of a tangent at fixed
//! `xi`. Varying the projection conditions,
//! `(dw - a_be dxi^be) . a_al + g n . (da_al^0 + x_,al,be dxi^be) = 0`, i.e.
//!
//! ```text
//! A_ab dxi^b = a_a . dw + g n . da_a^0,    A_ab = m_ab - g kappa_ab,
//! ```
//!
//! the projection's Newton matrix (the metric alone only when `g = 0`).
//! From `n . a_al = 0` and `n . n = 1`, `dn . a_al = -n . da_al` and
//! `dn . n = 0`, so
//!
//! ```text
//! dn = -a^al (n . da_al),    n . da_al = n . da_al^0 + kappa_ab dxi^b.
//! ```
//!
//! # Second variation
//!
//! Varying `dp = -n . dw` (with `N_a` taken at the moving projection) along
//! a second direction `D`:
//! `D(dp) = -Dn . dw + Dxi^al n . da_al^0`. With the linear forms
//! `V_al(du) = a_al . dw` and `T_al(du) = n . da_al^0`, and the identity
//! `m^-1 + g m^-1 kappa A^-1 = A^-1` (from `A + g kappa = m`), it is the
//! symmetric form
//!
//! ```text
//! D(dp) = V_a(du) M^ab V_b(Du) + V_a(du) A^ab T_b(Du)
//!       + T_a(du) A^ab V_b(Du) + g T_a(du) A^ab T_b(Du),
//! M = m^-1 kappa A^-1  (= (A^-1 - m^-1) / g, symmetric),
//! ```
//!
//! `A^ab` the inverse of `A`. In 3x3 blocks of the 15x15 Hessian, for the
//! term's five nodes `P, Q` (the slave with weight `w = 1` and tangent
//! weights `t = 0`; facet node `a` with `w = -N_a`, `t_al = N_a,al`):
//!
//! ```text
//! H_PQ = w_P w_Q M^ab a_a (x) a_b + w_P c_Q (x) n + w_Q n (x) c_P
//!      + g (t_P . A^-1 t_Q) n (x) n,    c_P = A^ab t_P,b a_a.
//! ```
//!
//! A flat facet (`kappa = 0`) touched at `g = 0` keeps only the two middle
//! terms: its Hessian couples the slave to the facet through the sliding of
//! the projection point and the rotation of the normal.
//!
//! # Flat triangles
//!
//! A 3-node triangle is the patch `x = sum_a N_a x_a` with
//! `N = (1 - xi - eta, xi, eta)`: constant tangents `a_1 = x_2 - x_1`,
//! `a_2 = x_3 - x_1`, no curvature (`kappa = 0`, so `A = m` and `M = 0`).
//! The formulas above hold as they are; the term keeps its 15-dof layout,
//! the fourth facet slot carrying zero weights (`w = t = 0`), so its rows
//! and columns are zero ([`triangle_penetration_hessian`]).

use crate::TERM_DOFS;
use crate::gap::{cross, dot, patch, sub, triangle_shape};

/// The penetration of a slave node and its gradient.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Penetration {
    /// Penetration `p` \[mm\], positive when the slave is behind the facet.
    pub value: f64,
    /// `dp/du` \[-\], in term order: slave xyz, then the facet nodes' xyz.
    pub gradient: [f64; TERM_DOFS],
}

/// The penetration of a slave node, its gradient and its Hessian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PenetrationHessian {
    /// Penetration `p` \[mm\], positive when the slave is behind the facet.
    pub value: f64,
    /// `dp/du` \[-\], in term order: slave xyz, then the facet nodes' xyz.
    pub gradient: [f64; TERM_DOFS],
    /// `d2p/du2` \[1/mm\], row-major, symmetric.
    pub hessian: [[f64; TERM_DOFS]; TERM_DOFS],
}

/// The patch at the projection of the slave point, with its unit normal and
/// the signed gap.
struct Frame {
    shape: [f64; 4],
    shape_derivatives: [[f64; 2]; 4],
    tangents: [[f64; 3]; 2],
    twist: [f64; 3],
    /// Unit normal `n`.
    normal: [f64; 3],
    /// `(s - x) . n` \[mm\], `-p`.
    gap: f64,
}

impl Frame {
    fn new(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> Self {
        let p = patch(x, xi);
        Self::from_parts(
            s,
            p.point,
            p.shape,
            p.shape_derivatives,
            p.tangents,
            p.twist,
        )
    }

    /// The frame of the flat triangle `x` at `xi`, its fourth slot empty.
    fn triangle(s: &[f64; 3], x: &[[f64; 3]; 3], xi: [f64; 2]) -> Self {
        let n = triangle_shape(xi);
        let point = [0, 1, 2].map(|i| n[0] * x[0][i] + n[1] * x[1][i] + n[2] * x[2][i]);
        let tangents = [sub(&x[1], &x[0]), sub(&x[2], &x[0])];
        let shape = [n[0], n[1], n[2], 0.0];
        let shape_derivatives = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]];
        Self::from_parts(s, point, shape, shape_derivatives, tangents, [0.0; 3])
    }

    fn from_parts(
        s: &[f64; 3],
        point: [f64; 3],
        shape: [f64; 4],
        shape_derivatives: [[f64; 2]; 4],
        tangents: [[f64; 3]; 2],
        twist: [f64; 3],
    ) -> Self {
        let m = cross(&tangents[0], &tangents[1]);
        let norm = dot(&m, &m).sqrt();
        let d = sub(s, &point);
        Frame {
            shape,
            shape_derivatives,
            tangents,
            twist,
            normal: m.map(|v| v / norm),
            gap: dot(&d, &m) / norm,
        }
    }

    /// `dp/du`: `-n` for the slave, `N_a n` for facet node `a`.
    fn gradient(&self) -> [f64; TERM_DOFS] {
        let n = &self.normal;
        let mut g = [0.0; TERM_DOFS];
        for i in 0..3 {
            g[i] = -n[i];
            for a in 0..4 {
                g[3 + 3 * a + i] = self.shape[a] * n[i];
            }
        }
        g
    }
}

/// Penetration \[mm\] of the slave point `s` into the bilinear patch of nodes
/// `x`, whose closest point to `s` is at `xi` (from [`crate::project`]).
pub fn penetration(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> f64 {
    let p = patch(x, xi);
    let m = cross(&p.tangents[0], &p.tangents[1]);
    -dot(&sub(s, &p.point), &m) / dot(&m, &m).sqrt()
}

/// Penetration and its gradient (module docs, first variation); `xi` is the
/// projection of `s` on the patch.
pub fn penetration_gradient(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> Penetration {
    let f = Frame::new(s, x, xi);
    Penetration {
        value: -f.gap,
        gradient: f.gradient(),
    }
}

/// Penetration and its gradient against the flat triangle `x` (projected
/// at `xi`), in the 15-dof term layout with the fourth facet slot zero.
pub fn triangle_penetration_gradient(s: &[f64; 3], x: &[[f64; 3]; 3], xi: [f64; 2]) -> Penetration {
    let f = Frame::triangle(s, x, xi);
    Penetration {
        value: -f.gap,
        gradient: f.gradient(),
    }
}

/// Inverse of the symmetric 2x2 matrix `[[a, b], [b, c]]`.
fn inverse2(a: f64, b: f64, c: f64) -> [[f64; 2]; 2] {
    let det = a * c - b * b;
    [[c / det, -b / det], [-b / det, a / det]]
}

/// Penetration, gradient and Hessian (module docs, second variation); `xi`
/// is the projection of `s` on the patch. The Hessian is symmetric to the
/// bit: its upper triangle is computed and mirrored.
pub fn penetration_hessian(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> PenetrationHessian {
    hessian(&Frame::new(s, x, xi))
}

/// Penetration \[mm\], gradient and Hessian of the slave point `s` against
/// the flat triangle of nodes `x` (counter-clockwise about its outward
/// normal), projected at `xi` (from [`crate::gap::project_triangle`]); in the
/// 15-dof term layout, the fourth facet slot zero.
pub fn triangle_penetration_hessian(
    s: &[f64; 3],
    x: &[[f64; 3]; 3],
    xi: [f64; 2],
) -> PenetrationHessian {
    hessian(&Frame::triangle(s, x, xi))
}

/// The second variation at a frame (module docs).
fn hessian(f: &Frame) -> PenetrationHessian {
    let [a1, a2] = &f.tangents;
    let n = &f.normal;
    let g = f.gap;
    let (m11, m12, m22) = (dot(a1, a1), dot(a1, a2), dot(a2, a2));
    let kappa = dot(n, &f.twist);
    let m_inv = inverse2(m11, m12, m22);
    let a_inv = inverse2(m11, m12 - g * kappa, m22);
    // M = m^-1 kappa A^-1 with kappa = [[0, k], [k, 0]]; symmetric in exact
    // arithmetic, symmetrised against round-off.
    let mk = [
        [kappa * m_inv[0][1], kappa * m_inv[0][0]],
        [kappa * m_inv[1][1], kappa * m_inv[1][0]],
    ];
    let prod = |i: usize, j: usize| mk[i][0] * a_inv[0][j] + mk[i][1] * a_inv[1][j];
    let m01 = 0.5 * (prod(0, 1) + prod(1, 0));
    let (m00, m11_) = (prod(0, 0), prod(1, 1));
    // P = M^ab a_a (x) a_b.
    let mut pmat = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in i..3 {
            let v =
                m00 * a1[i] * a1[j] + m01 * (a1[i] * a2[j] + a2[i] * a1[j]) + m11_ * a2[i] * a2[j];
            pmat[i][j] = v;
            pmat[j][i] = v;
        }
    }
    // Per node of the term: weight w, tangent weights t, c = A^ab t_b a_a.
    let mut w = [1.0; 5];
    let mut t = [[0.0; 2]; 5];
    let mut u = [[0.0; 2]; 5];
    let mut c = [[0.0; 3]; 5];
    for a in 0..4 {
        let q = a + 1;
        w[q] = -f.shape[a];
        t[q] = f.shape_derivatives[a];
        u[q] = [
            a_inv[0][0] * t[q][0] + a_inv[0][1] * t[q][1],
            a_inv[1][0] * t[q][0] + a_inv[1][1] * t[q][1],
        ];
        for i in 0..3 {
            c[q][i] = u[q][0] * a1[i] + u[q][1] * a2[i];
        }
    }
    let mut h = [[0.0; TERM_DOFS]; TERM_DOFS];
    for p in 0..5 {
        for q in p..5 {
            let ww = w[p] * w[q];
            let e = g * (t[p][0] * u[q][0] + t[p][1] * u[q][1]);
            for i in 0..3 {
                let row = 3 * p + i;
                let j0 = if q == p { i } else { 0 };
                for j in j0..3 {
                    let col = 3 * q + j;
                    let v = ww * pmat[i][j]
                        + w[p] * c[q][i] * n[j]
                        + w[q] * n[i] * c[p][j]
                        + e * n[i] * n[j];
                    h[row][col] = v;
                    h[col][row] = v;
                }
            }
        }
    }
    PenetrationHessian {
        value: -g,
        gradient: f.gradient(),
        hessian: h,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::{project, shape};

    #[test]
    fn flat_patch_gives_the_signed_distance_and_bilinear_weights_in_the_gradient() {
        // Unit square in z = 1, normal +z; slave 0.1 below it.
        let x = [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ];
        let s = [0.3, 0.6, 0.9];
        let xi = project(&s, &x);
        let p = penetration_gradient(&s, &x, xi);
        assert!((p.value - 0.1).abs() < 1e-15);
        assert!((penetration(&s, &x, xi) - 0.1).abs() < 1e-15);
        let g = p.gradient;
        assert!((g[2] + 1.0).abs() < 1e-14 && g[0].abs() < 1e-14 && g[1].abs() < 1e-14);
        let n = shape(xi);
        for a in 0..4 {
            assert!((g[3 + 3 * a + 2] - n[a]).abs() < 1e-14, "node {a}");
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
                penetration(&s, &x, project(&s, &x)),
                penetration(&s, &y, project(&s, &y)),
            );
            assert!((px - py).abs() < 1e-14);
        }
    }

    #[test]
    fn all_three_forms_give_the_same_penetration_and_gradient() {
        let x = [
            [0.0, 0.02, 1.0],
            [1.05, -0.03, 1.08],
            [0.97, 1.0, 0.95],
            [0.03, 0.96, 1.04],
        ];
        let s = [0.41, 0.37, 0.93];
        let xi = project(&s, &x);
        let (p, g, h) = (
            penetration(&s, &x, xi),
            penetration_gradient(&s, &x, xi),
            penetration_hessian(&s, &x, xi),
        );
        assert_eq!(p, g.value);
        assert_eq!(g.value, h.value);
        assert_eq!(g.gradient, h.gradient);
    }
}
