//! Quadratic 10-node tetrahedron: reference nodes, edges and faces, shape
//! functions, quadrature rules and Jacobian-determinant bounds.
//!
//! Node order is VTK_QUADRATIC_TETRA: corners 0-3, then one node per edge,
//! 4:(0,1), 5:(1,2), 6:(0,2), 7:(0,3), 8:(1,3), 9:(2,3). The reference element
//! is the unit tetrahedron with corners (0,0,0), (1,0,0), (0,1,0), (0,0,1)
//! (volume 1/6); its barycentric coordinates are `l0 = 1 - xi - eta - zeta`,
//! `l1 = xi`, `l2 = eta`, `l3 = zeta`. An element is right-handed when the
//! right-hand normal of corners 0-1-2 points toward corner 3, i.e. when
//! `det J > 0`.
//!
//! With quadratic geometry the Jacobian `J(xi)` is affine in `xi`, so its
//! determinant is a cubic polynomial: the element volume needs a rule exact
//! to degree 3 ([`volume_rule`]), and [`det_bernstein`] gives a certified
//! lower bound of `det J` over the whole element.

use crate::hex::det3;

/// Reference coordinates (xi, eta, zeta) of the 4 corners.
pub const CORNERS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

/// Corner pairs of the 6 edges; edge `k` carries node `4 + k`.
pub const EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]];

/// The 4 faces as 6-node triangles (VTK_QUADRATIC_TRIANGLE order: corners,
/// then the mid-edge nodes of edges 0-1, 1-2, 2-0), each ordered so that the
/// right-hand normal of its corners points out of a right-handed element.
/// `FACES[i]` is the face opposite corner `i`.
pub const FACES: [[usize; 6]; 4] = [
    [1, 2, 3, 5, 9, 8],
    [0, 3, 2, 7, 9, 6],
    [0, 1, 3, 4, 8, 7],
    [0, 2, 1, 6, 5, 4],
];

/// Local index (4..=9) of the mid-edge node between corners `a` and `b`
/// (in either order), or `None` when `a == b` or a corner index is > 3.
pub fn mid_edge_node(a: usize, b: usize) -> Option<usize> {
    let key = [a.min(b), a.max(b)];
    EDGES.iter().position(|e| *e == key).map(|k| 4 + k)
}

/// Reference coordinates of all 10 nodes: corners, then edge midpoints.
pub fn nodes() -> [[f64; 3]; 10] {
    std::array::from_fn(|a| {
        if a < 4 {
            CORNERS[a]
        } else {
            let [i, j] = EDGES[a - 4];
            std::array::from_fn(|r| 0.5 * (CORNERS[i][r] + CORNERS[j][r]))
        }
    })
}

/// Barycentric coordinates `(l0, l1, l2, l3)` of the reference point `xi`.
pub fn barycentric(xi: [f64; 3]) -> [f64; 4] {
    [1.0 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]]
}

/// Gradients of the barycentric coordinates with respect to (xi, eta, zeta).
const BARYCENTRIC_GRAD: [[f64; 3]; 4] = [
    [-1.0, -1.0, -1.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

/// Values of the 10 quadratic shape functions at `xi`: `l_i (2 l_i - 1)` at
/// the corners, `4 l_i l_j` at the mid-edge nodes.
pub fn shape(xi: [f64; 3]) -> [f64; 10] {
    let l = barycentric(xi);
    std::array::from_fn(|a| {
        if a < 4 {
            l[a] * (2.0 * l[a] - 1.0)
        } else {
            let [i, j] = EDGES[a - 4];
            4.0 * l[i] * l[j]
        }
    })
}

/// Derivatives dN_a/d(xi, eta, zeta) of the 10 shape functions at `xi`.
pub fn shape_derivatives(xi: [f64; 3]) -> [[f64; 3]; 10] {
    let l = barycentric(xi);
    let g = &BARYCENTRIC_GRAD;
    std::array::from_fn(|a| {
        if a < 4 {
            let s = 4.0 * l[a] - 1.0;
            g[a].map(|v| s * v)
        } else {
            let [i, j] = EDGES[a - 4];
            std::array::from_fn(|k| 4.0 * (l[i] * g[j][k] + l[j] * g[i][k]))
        }
    })
}

/// Jacobian of the quadratic map at `xi`: `j[r][c] = d x_r / d xi_c` \[mm\].
pub fn jacobian(x: &[[f64; 3]; 10], xi: [f64; 3]) -> [[f64; 3]; 3] {
    let dn = shape_derivatives(xi);
    let mut j = [[0.0; 3]; 3];
    for a in 0..10 {
        for r in 0..3 {
            for c in 0..3 {
                j[r][c] += x[a][r] * dn[a][c];
            }
        }
    }
    j
}

/// Barycentric offset `a1 = (5 - sqrt 5) / 20` of the 4-point rule.
const A4: f64 = 0.138_196_601_125_010_5;
/// Barycentric coordinate `b1 = 1 - 3 a1 = (5 + 3 sqrt 5) / 20` of the 4-point rule.
const B4: f64 = 0.585_410_196_624_968_4;
/// Barycentric coordinate `a2 = (1 - sqrt(3/5)) / 4` of the edge orbit.
const A6: f64 = 0.056_350_832_689_629_156;
/// Barycentric coordinate `b2 = 1/2 - a2 = (1 + sqrt(3/5)) / 4` of the edge orbit.
const B6: f64 = 0.443_649_167_310_370_85;
/// Weight `sqrt 5 / 72` of the 4-point orbit in the degree-3 rule.
const W4_IN_VOLUME_RULE: f64 = 0.031_056_499_687_497_078;
/// Weight `1/36 - sqrt 5 / 108` of the edge orbit in the degree-3 rule.
const W6_IN_VOLUME_RULE: f64 = 0.007_073_444_652_779_725;

/// Points (reference coordinates) of the symmetric 4-point rule: point `i`
/// has barycentric coordinate `b1` at corner `i` and `a1` at the others.
pub fn gauss_points() -> [[f64; 3]; 4] {
    std::array::from_fn(|i| {
        let mut l = [A4; 4];
        l[i] = B4;
        [l[1], l[2], l[3]]
    })
}

/// Weights of [`gauss_points`], 1/24 each (they sum to the reference volume
/// 1/6). The rule is exact for polynomials of degree 2: for a straight-sided
/// element it integrates the linearised deviatoric energy (the square of a
/// strain that is linear in `xi`) exactly.
pub const GAUSS_WEIGHTS: [f64; 4] = [1.0 / 24.0; 4];

/// Points of the 6-point edge orbit of [`volume_rule`]: point `k` has
/// barycentric coordinate `b2` at both corners of edge `k` and `a2` at the others.
pub fn edge_orbit_points() -> [[f64; 3]; 6] {
    std::array::from_fn(|k| {
        let mut l = [A6; 4];
        let [i, j] = EDGES[k];
        l[i] = B6;
        l[j] = B6;
        [l[1], l[2], l[3]]
    })
}

/// Weights of the degree-3 rule at the 4 [`gauss_points`] (`sqrt 5 / 72`).
pub const VOLUME_WEIGHTS_AT_GAUSS_POINTS: [f64; 4] = [W4_IN_VOLUME_RULE; 4];

/// Weights of the degree-3 rule at the 6 [`edge_orbit_points`] (`1/36 - sqrt 5 / 108`).
pub const VOLUME_WEIGHTS_AT_EDGE_POINTS: [f64; 6] = [W6_IN_VOLUME_RULE; 6];

/// The 10-point rule with positive weights exact for polynomials of degree 3:
/// the 4 [`gauss_points`] and the 6 [`edge_orbit_points`], in that order.
///
/// It integrates `det J` of a quadratic tetrahedron (a cubic) exactly, hence
/// the element volume. Derivation: fully symmetric rules need only match the
/// moments of 1, sum l_i^2 and sum l_i^3; the 4-point orbit already matches
/// sum l_i^2 = 2/5 on average, the edge orbit with `a2 = (1 - sqrt(3/5))/4` has
/// the same value, and the two weights then follow from the other two moments.
/// Containing the 4-point rule lets an element evaluate material points only
/// at the 4 Gauss points and still compute its volume exactly.
pub fn volume_rule() -> [([f64; 3], f64); 10] {
    let g = gauss_points();
    let e = edge_orbit_points();
    std::array::from_fn(|k| {
        if k < 4 {
            (g[k], W4_IN_VOLUME_RULE)
        } else {
            (e[k - 4], W6_IN_VOLUME_RULE)
        }
    })
}

/// The multisets {v1, v2, v3} of corners (with repetition) indexing the 20
/// Bernstein coefficients of a cubic on the tetrahedron.
pub const BERNSTEIN_INDEX: [[usize; 3]; 20] = {
    let mut out = [[0; 3]; 20];
    let mut n = 0;
    let mut a = 0;
    while a < 4 {
        let mut b = a;
        while b < 4 {
            let mut c = b;
            while c < 4 {
                out[n] = [a, b, c];
                n += 1;
                c += 1;
            }
            b += 1;
        }
        a += 1;
    }
    out
};

/// Bernstein coefficients [mm^3 per unit reference volume] of the cubic
/// `det J` of the quadratic tetrahedron with node coordinates `x`, indexed as
/// [`BERNSTEIN_INDEX`].
///
/// `J` is affine in `xi`, so `J = sum_v l_v J_v` with `J_v` the Jacobian at
/// corner `v`, and by multilinearity of the determinant in the columns
/// `det J = sum_(u,v,w) l_u l_v l_w det[J_u e1, J_v e2, J_w e3]`. The
/// coefficient of the multiset {u, v, w} is the mean of `det[J_u e1, J_v e2,
/// J_w e3]` over its distinct orderings. Since the Bernstein polynomials are
/// non-negative and sum to 1, `det J` lies between the smallest and the largest
/// coefficient everywhere in the element; the corner coefficients are the
/// corner values, and the mean of all 20 is the mean of `det J` (6 times the
/// element volume).
pub fn det_bernstein(x: &[[f64; 3]; 10]) -> [f64; 20] {
    let jv = CORNERS.map(|c| jacobian(x, c));
    let mixed = |u: usize, v: usize, w: usize| {
        let m = [
            [jv[u][0][0], jv[v][0][1], jv[w][0][2]],
            [jv[u][1][0], jv[v][1][1], jv[w][1][2]],
            [jv[u][2][0], jv[v][2][1], jv[w][2][2]],
        ];
        det3(&m)
    };
    BERNSTEIN_INDEX.map(|[a, b, c]| {
        // Distinct orderings of the multiset {a, b, c} (a <= b <= c).
        if a == c {
            mixed(a, a, a)
        } else if a == b || b == c {
            let (single, double) = if a == b { (c, a) } else { (a, b) };
            (mixed(single, double, double)
                + mixed(double, single, double)
                + mixed(double, double, single))
                / 3.0
        } else {
            (mixed(a, b, c)
                + mixed(a, c, b)
                + mixed(b, a, c)
                + mixed(b, c, a)
                + mixed(c, a, b)
                + mixed(c, b, a))
                / 6.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A curved element: the unit tetrahedron scaled, sheared and with its
    /// mid-edge nodes moved off the straight edges.
    fn curved() -> [[f64; 3]; 10] {
        let mut x = nodes().map(|p| {
            [
                2.0 * p[0] + 0.3 * p[1],
                1.5 * p[1] - 0.2 * p[2],
                p[2] + 0.1 * p[0],
            ]
        });
        for (k, p) in x.iter_mut().enumerate().skip(4) {
            let s = k as f64;
            p[0] += 0.06 * (1.3 * s).sin();
            p[1] += 0.05 * (0.7 * s).cos();
            p[2] -= 0.04 * (2.1 * s).sin();
        }
        x
    }

    #[test]
    fn shape_functions_are_kronecker_and_sum_to_one() {
        for (a, p) in nodes().iter().enumerate() {
            for (b, v) in shape(*p).iter().enumerate() {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-15, "N_{b} at node {a}: {v}");
            }
        }
        for p in gauss_points().iter().chain(edge_orbit_points().iter()) {
            assert!((shape(*p).iter().sum::<f64>() - 1.0).abs() < 1e-15);
            for k in 0..3 {
                assert!(
                    shape_derivatives(*p)
                        .iter()
                        .map(|d| d[k])
                        .sum::<f64>()
                        .abs()
                        < 1e-14
                );
            }
        }
    }

    #[test]
    fn shape_derivatives_match_finite_differences() {
        let xi = [0.21, 0.33, 0.17];
        let g = shape_derivatives(xi);
        let h = 1e-6;
        for k in 0..3 {
            let (mut xp, mut xm) = (xi, xi);
            xp[k] += h;
            xm[k] -= h;
            let (np, nm) = (shape(xp), shape(xm));
            for a in 0..10 {
                assert!(((np[a] - nm[a]) / (2.0 * h) - g[a][k]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn edges_and_faces_are_consistent() {
        for (k, [i, j]) in EDGES.iter().enumerate() {
            assert_eq!(mid_edge_node(*i, *j), Some(4 + k));
            assert_eq!(mid_edge_node(*j, *i), Some(4 + k));
        }
        assert_eq!(mid_edge_node(2, 2), None);
        let x = nodes();
        let centre = [0.25; 3];
        for (i, f) in FACES.iter().enumerate() {
            assert!(
                !f[..3].contains(&i),
                "face {i} contains its opposite corner"
            );
            for e in 0..3 {
                assert_eq!(mid_edge_node(f[e], f[(e + 1) % 3]), Some(f[3 + e]));
            }
            let p = f.map(|a| x[a]);
            let d1: [f64; 3] = std::array::from_fn(|r| p[1][r] - p[0][r]);
            let d2: [f64; 3] = std::array::from_fn(|r| p[2][r] - p[0][r]);
            let n = [
                d1[1] * d2[2] - d1[2] * d2[1],
                d1[2] * d2[0] - d1[0] * d2[2],
                d1[0] * d2[1] - d1[1] * d2[0],
            ];
            let out: f64 = (0..3).map(|r| n[r] * (p[0][r] - centre[r])).sum();
            assert!(out > 0.0, "face {i} points inward");
        }
    }

    /// Exact integral over the reference tetrahedron of xi^p eta^q zeta^r.
    fn monomial_integral(p: u32, q: u32, r: u32) -> f64 {
        let f = |n: u32| (1..=n).map(f64::from).product::<f64>();
        f(p) * f(q) * f(r) / f(p + q + r + 3)
    }

    fn check_rule(rule: &[([f64; 3], f64)], degree: u32) -> f64 {
        let mut worst: f64 = 0.0;
        for p in 0..=degree {
            for q in 0..=degree - p {
                for r in 0..=degree - p - q {
                    let got: f64 = rule
                        .iter()
                        .map(|(x, w)| {
                            w * x[0].powi(p as i32) * x[1].powi(q as i32) * x[2].powi(r as i32)
                        })
                        .sum();
                    let want = monomial_integral(p, q, r);
                    worst = worst.max((got - want).abs() / want);
                }
            }
        }
        worst
    }

    #[test]
    fn quadrature_rules_have_their_degree() {
        let g: Vec<_> = gauss_points()
            .into_iter()
            .zip(GAUSS_WEIGHTS)
            .collect::<Vec<_>>();
        assert!(check_rule(&g, 2) < 1e-14);
        assert!(
            check_rule(&g, 3) > 1e-3,
            "the 4-point rule is only degree 2"
        );
        let v = volume_rule();
        assert!(check_rule(&v, 3) < 1e-14);
        assert!(
            check_rule(&v, 4) > 1e-4,
            "the 10-point rule is only degree 3"
        );
        assert!(v.iter().all(|(_, w)| *w > 0.0));
        for (i, p) in gauss_points().iter().enumerate() {
            assert_eq!(v[i].0, *p, "volume rule must contain the Gauss points");
        }
    }

    #[test]
    fn bernstein_coefficients_bound_and_reproduce_det_j() {
        let x = curved();
        let c = det_bernstein(&x);
        // Corner coefficients are the corner values.
        for (k, idx) in BERNSTEIN_INDEX.iter().enumerate() {
            if idx[0] == idx[2] {
                let want = det3(&jacobian(&x, CORNERS[idx[0]]));
                assert!((c[k] - want).abs() < 1e-13);
            }
        }
        // The Bernstein form reproduces det J at arbitrary points.
        let fact = |n: usize| (1..=n).map(|v| v as f64).product::<f64>();
        for xi in [[0.1, 0.2, 0.3], [0.6, 0.1, 0.05], [0.0, 0.5, 0.5]] {
            let l = barycentric(xi);
            let mut value = 0.0;
            for (k, idx) in BERNSTEIN_INDEX.iter().enumerate() {
                let mut mult = [0usize; 4];
                for &v in idx {
                    mult[v] += 1;
                }
                let mut b = 6.0;
                for v in 0..4 {
                    b *= l[v].powi(mult[v] as i32) / fact(mult[v]);
                }
                value += c[k] * b;
            }
            let want = det3(&jacobian(&x, xi));
            assert!((value - want).abs() < 1e-13, "{value} vs {want}");
        }
        // Mean of the coefficients = mean of det J = volume / (1/6).
        let volume: f64 = volume_rule()
            .iter()
            .map(|(p, w)| w * det3(&jacobian(&x, *p)))
            .sum();
        let mean = c.iter().sum::<f64>() / 20.0;
        assert!((mean / 6.0 - volume).abs() < 1e-14);
    }
}
