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

/// Newton iterations of the projection conditions tried before the
/// safeguarded descent of [`project_from`].
const NEWTON_ITERATIONS: usize = 30;

/// Iterations of the safeguarded descent: it moves at least by a
/// Gauss-Newton step cut in half a few times and ends quadratically.
const DESCENT_ITERATIONS: usize = 200;

/// Like [`project`], Newton starting from `xi`: to follow a projection that
/// is known nearby (far outside a strongly twisted patch, Newton from the
/// centre can wander to another stationary point of the distance).
///
/// The result is a root of the closest-point conditions. Off a strongly
/// warped patch they have several, and Newton can jump among them without
/// settling: on a deformed facet of the sc2 cell of c/a = 5, 30 iterations
/// ended on a point 0.016 mm from a node whose nearest point on the patch
/// was 0.0092 mm off, and the node read 2.2e-3 mm deep in a particle it did
/// not touch. Where Newton does not settle, the distance is minimised from
/// `xi` instead, by a descent that takes the Newton step where the
/// distance's Hessian is positive definite and the Gauss-Newton one (the
/// metric's) elsewhere, halved until the distance falls. (Where Newton
/// settles on a saddle of the distance, far beyond a twisted facet's edge,
/// its root is kept: replacing it by the descent's minimum stalled the sc2
/// cell at n = 15, level 1: 4958 Newton iterations in 300 s to rho = 0.869,
/// against 1373 to 0.9.)
pub fn project_from(s: &[f64; 3], x: &[[f64; 3]; 4], xi0: [f64; 2]) -> [f64; 2] {
    let mut xi = xi0;
    for _ in 0..NEWTON_ITERATIONS {
        let next = newton_step(s, x, xi);
        let moved = (next[0] - xi[0]).abs().max((next[1] - xi[1]).abs());
        xi = next;
        if !(moved > 1e-15) {
            if xi[0].is_finite() && xi[1].is_finite() {
                return xi;
            }
            break;
        }
    }
    descend(s, x, xi0)
}

/// Squared distance from `s` to the patch point at `xi` \[mm^2\].
fn distance_squared(s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> f64 {
    let d = sub(s, &patch(x, xi).point);
    dot(&d, &d)
}

/// The Hessian of half the squared distance at `xi`, `m - (s - x) . x_xi,eta`
/// off the diagonal, as (h11, h12, h22), and the gradient's negative
/// `((s - x) . x_xi, (s - x) . x_eta)`.
fn distance_derivatives(
    s: &[f64; 3],
    x: &[[f64; 3]; 4],
    xi: [f64; 2],
) -> ([f64; 3], [f64; 2], f64) {
    let p = patch(x, xi);
    let [a, b] = &p.tangents;
    let d = sub(s, &p.point);
    let m12 = dot(a, b);
    (
        [dot(a, a), m12 - dot(&d, &p.twist), dot(b, b)],
        [dot(&d, a), dot(&d, b)],
        m12,
    )
}

/// A local minimum of the distance from `s` to the patch, by descent from
/// `xi` (see [`project_from`]).
fn descend(s: &[f64; 3], x: &[[f64; 3]; 4], mut xi: [f64; 2]) -> [f64; 2] {
    let mut f = distance_squared(s, x, xi);
    for _ in 0..DESCENT_ITERATIONS {
        let ([h11, h12, h22], g, m12) = distance_derivatives(s, x, xi);
        let newton = h11 > 0.0 && h11 * h22 - h12 * h12 > 0.0;
        let off = if newton { h12 } else { m12 };
        let det = h11 * h22 - off * off;
        if !(det > 0.0) {
            return xi;
        }
        let step = [
            (h22 * g[0] - off * g[1]) / det,
            (h11 * g[1] - off * g[0]) / det,
        ];
        let size = step[0].abs().max(step[1].abs());
        // Near the minimum the fall of the distance is below its round-off:
        // Newton's steps, quadratic there, are taken as they are.
        if newton && size < 1e-6 {
            xi = [xi[0] + step[0], xi[1] + step[1]];
            f = distance_squared(s, x, xi);
            if size <= 1e-15 {
                return xi;
            }
            continue;
        }
        let mut alpha = 1.0;
        loop {
            let trial = [xi[0] + alpha * step[0], xi[1] + alpha * step[1]];
            let ft = distance_squared(s, x, trial);
            if ft < f {
                xi = trial;
                f = ft;
                break;
            }
            alpha *= 0.5;
            if alpha < 1e-12 {
                return xi;
            }
        }
        if alpha * size <= 1e-15 {
            return xi;
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

    /// A facet of the small particle of the sc2 cell of c/a = 5 at mesh
    /// level 1, deformed at rho = 0.797, and a node of the large particle
    /// beside it \[mm\].
    fn twisted_facet() -> ([[f64; 3]; 4], [f64; 3]) {
        (
            [
                [0.0, 0.056900652411706, 0.09638568961032778],
                [0.0, 0.05056456975288562, 0.09613066383510024],
                [0.00950667498492714, 0.05159260092242001, 0.0940812451983013],
                [
                    0.015097746102215755,
                    0.0523723961117837,
                    0.10048376861354477,
                ],
            ],
            [
                0.018323148943326487,
                0.044218276449339025,
                0.08814823896943574,
            ],
        )
    }

    /// The smallest distance from `s` to the patch over a grid of spacing
    /// 0.005 on [-4, 4]^2 \[mm\].
    fn grid_distance(s: &[f64; 3], x: &[[f64; 3]; 4]) -> f64 {
        let n = 1600;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n {
                let xi = [
                    -4.0 + 8.0 * i as f64 / n as f64,
                    -4.0 + 8.0 * j as f64 / n as f64,
                ];
                best = best.min(distance_squared(s, x, xi));
            }
        }
        best.sqrt()
    }

    #[test]
    fn projection_off_a_twisted_patch_is_its_nearest_point() {
        // Newton from the centre never settles here: after 30 iterations it
        // stood at xi = (-0.636, 0.484), 0.0158 mm from the node, which the
        // normal there read 2.2e-3 mm deep; the nearest point is 0.0092 mm
        // off, outside the facet.
        let (x, s) = twisted_facet();
        let xi = project(&s, &x);
        let d = distance_squared(&s, &x, xi).sqrt();
        let grid = grid_distance(&s, &x);
        assert!(
            d <= grid + 1e-12 && d > grid - 1e-6,
            "{xi:?}: {d} against {grid}"
        );
        assert!((d - 0.009_22).abs() < 1e-5, "{d}");
        assert!(xi[0] > 1.0 && xi[1] > 2.0, "{xi:?}");
        assert!(crate::penetration::penetration(&s, &x, xi) < -9e-3);
    }

    #[test]
    fn projection_is_a_stationary_point_of_the_distance_all_around_a_twisted_patch() {
        // Points on a lattice around the facet, out to twice its size: each
        // projects on a root of the closest-point conditions.
        let (x, _) = twisted_facet();
        let centre = patch(&x, [0.0, 0.0]).point;
        let size = 0.02;
        let mut inside = 0;
        for i in -4..=4 {
            for j in -4..=4 {
                for k in -4..=4 {
                    let s = [
                        centre[0] + 0.25 * size * i as f64,
                        centre[1] + 0.25 * size * j as f64,
                        centre[2] + 0.25 * size * k as f64,
                    ];
                    let xi = project(&s, &x);
                    let ([h11, _, h22], g, _) = distance_derivatives(&s, &x, xi);
                    let scale = (h11 + h22).sqrt() * distance_squared(&s, &x, xi).sqrt();
                    assert!(g[0].abs().max(g[1].abs()) <= 1e-12 * scale, "{s:?}: {g:?}");
                    if xi[0].abs() <= 1.0 && xi[1].abs() <= 1.0 {
                        inside += 1;
                    }
                }
            }
        }
        assert!(inside >= 5, "only {inside} points project inside the facet");
    }

    #[test]
    fn newton_from_a_known_root_follows_it_where_newton_from_the_centre_jumps() {
        // A saddle-shaped facet and a point above it moved by 1e-3: from the
        // centre, Newton lands on one root of the closest-point conditions
        // and then on another half the facet away; from the first root it
        // follows that root (contact links start there, see
        // `ParticleContact::pair`).
        let x = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.6],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.6],
        ];
        let before = [
            0.803_008_138_693_789_8,
            0.801_313_217_241_944,
            1.125_670_442_731_962_2,
        ];
        let after = [
            0.802_085_801_020_956_5,
            0.800_965_070_669_812_7,
            1.125_838_035_039_618_4,
        ];
        let first = project(&before, &x);
        let jumped = project(&after, &x);
        let followed = project_from(&after, &x, first);
        let gap = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs().max((a[1] - b[1]).abs());
        assert!(gap(first, jumped) > 0.5, "{first:?} {jumped:?}");
        assert!(gap(first, followed) < 0.02, "{first:?} {followed:?}");
        for xi in [jumped, followed] {
            let p = patch(&x, xi);
            let d = sub(&after, &p.point);
            assert!(p.tangents.iter().all(|t| dot(&d, t).abs() < 1e-14));
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
