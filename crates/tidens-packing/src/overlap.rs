//! Contact distance between two spheroids: the directional (centre-line)
//! gap from the Perram-Wertheim contact function, with its derivatives.
//!
//! For two ellipsoids `A`, `B` with centres `r_A`, `r_B` and shape matrices
//! whose inverses are `Ā = a² I + (c² - a²) u uᵀ` (a spheroid with equatorial
//! semi-axis `a`, semi-axis `c` along the unit axis `u`), Perram and Wertheim
//! (J. W. Perram, M. S. Wertheim, *J. Comput. Phys.* 58 (1985) 409-416)
//! define, with `d = r_B - r_A`,
//!
//! ```text
//! F = max over λ in [0, 1] of  λ (1 - λ) dᵀ C(λ)⁻¹ d,   C(λ) = (1 - λ) Ā + λ B̄.
//! ```
//!
//! `F < 1` when the ellipsoids overlap, `F = 1` when they touch, `F > 1`
//! when they are apart; both ellipsoids scaled by `sqrt(F)` about their
//! centres just touch. Equivalently, with the shapes kept and the centre
//! distance scaled by `1 / sqrt(F)` along `d`, they touch: the contact
//! distance along the centre line is `|d| / sqrt(F)`. The gap used throughout
//! this crate is the difference
//!
//! ```text
//! h = |d| - |d| / sqrt(F)   [mm],
//! ```
//!
//! the distance by which the centres must approach (`h > 0`) or separate
//! (`h < 0`: an overlap of depth `-h`) along their centre line for the
//! particles to touch. It is exact (zero exactly at contact) and for two
//! spheres it is `|d| - r_A - r_B`. `F` is found by a safeguarded Newton
//! iteration on `dF/dλ = 0` (the function is concave in λ); the derivatives
//! of `h` with respect to `d` and the two axes follow from the envelope
//! theorem (`∂F/∂p` at the optimal λ).

use nalgebra::{Matrix3, Vector3};

/// A spheroid as seen by the contact functions: equatorial semi-axis `a`,
/// semi-axis `c` along the unit vector `axis` \[mm\]. The derivatives in
/// [`GapGradient`] treat `axis` as a free vector.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shape {
    pub(crate) a: f64,
    pub(crate) c: f64,
    pub(crate) axis: Vector3<f64>,
}

impl Shape {
    pub(crate) fn is_sphere(&self) -> bool {
        self.a == self.c
    }

    /// `Ā = a² I + (c² - a²) u uᵀ` \[mm²\], the inverse of the shape matrix.
    fn inverse_matrix(&self) -> Matrix3<f64> {
        let (a2, c2) = (self.a * self.a, self.c * self.c);
        Matrix3::from_diagonal_element(a2) + self.axis * self.axis.transpose() * (c2 - a2)
    }

    /// Half-width along the unit vector `n` (support function) \[mm\].
    pub(crate) fn support(&self, n: &Vector3<f64>) -> f64 {
        let un = self.axis.dot(n);
        (self.a * self.a + (self.c * self.c - self.a * self.a) * un * un).sqrt()
    }
}

/// Maximiser of the Perram-Wertheim function.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PwMax {
    /// `F` (dimensionless).
    pub(crate) f: f64,
    /// The optimal `λ`.
    pub(crate) lambda: f64,
    /// `x = C(λ)⁻¹ d` \[1/mm\].
    pub(crate) x: Vector3<f64>,
}

/// Perram-Wertheim contact function of `a` (centre at the origin) and `b`
/// (centre at `d`), the Newton iteration started at `start` when it is in
/// (0, 1) (the optimum of a nearby configuration). `None` for coincident
/// centres. Each Newton step inverts the 3x3 matrix `C(λ)` once (symmetric
/// positive definite for λ in [0, 1], a convex combination of two such
/// matrices) for both of its right-hand sides.
pub(crate) fn perram_wertheim(d: Vector3<f64>, a: &Shape, b: &Shape, start: f64) -> Option<PwMax> {
    let dist = d.norm();
    if !(dist > 0.0) {
        return None;
    }
    let abar = a.inverse_matrix();
    let bbar = b.inverse_matrix();
    let cprime = bbar - abar;
    let c_at = |lambda: f64| abar * (1.0 - lambda) + bbar * lambda;
    let dh = d / dist;
    let ra = dh.dot(&(abar * dh)).sqrt();
    let rb = dh.dot(&(bbar * dh)).sqrt();
    // Exact optimum for two spheres; a close start otherwise.
    let mut lambda = if start > 0.0 && start < 1.0 {
        start
    } else {
        ra / (ra + rb)
    };
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    for _ in 0..100 {
        let c = c_at(lambda).try_inverse()?;
        let x = c * d;
        let g = d.dot(&x);
        let y = cprime * x;
        let g1 = -x.dot(&y);
        let z = c * y;
        let g2 = 2.0 * y.dot(&z);
        let w = lambda * (1.0 - lambda);
        let f1 = (1.0 - 2.0 * lambda) * g + w * g1;
        let f2 = -2.0 * g + 2.0 * (1.0 - 2.0 * lambda) * g1 + w * g2;
        if f1 > 0.0 {
            lo = lambda;
        } else {
            hi = lambda;
        }
        let mut next = lambda - f1 / f2;
        let newton_inside = f2 < 0.0 && next > lo && next < hi;
        if !newton_inside {
            next = 0.5 * (lo + hi);
        }
        let step = (next - lambda).abs();
        lambda = next;
        // Newton converges quadratically: after a step below 1e-12 the error
        // in λ is at rounding level (and F is stationary in λ).
        if step <= 1e-12 || hi - lo <= 1e-15 {
            break;
        }
    }
    let x = c_at(lambda).try_inverse()? * d;
    Some(PwMax {
        f: lambda * (1.0 - lambda) * d.dot(&x),
        lambda,
        x,
    })
}

/// Gap for coincident centres: minus the smallest possible contact distance.
fn coincident_gap(a: &Shape, b: &Shape) -> f64 {
    -(a.a.min(a.c) + b.a.min(b.c))
}

/// Centre-line gap `h` \[mm\] between `a` (centre at the origin) and `b`
/// (centre at `d`); negative when they overlap.
pub(crate) fn gap(d: Vector3<f64>, a: &Shape, b: &Shape) -> f64 {
    let dist = d.norm();
    if a.is_sphere() && b.is_sphere() {
        return dist - a.a - b.a;
    }
    match perram_wertheim(d, a, b, f64::NAN) {
        Some(pw) if pw.f > 0.0 => dist * (1.0 - 1.0 / pw.f.sqrt()),
        _ => coincident_gap(a, b),
    }
}

/// Gap and its derivatives.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GapGradient {
    /// Gap `h` \[mm\].
    pub(crate) h: f64,
    /// `∂h/∂d` (dimensionless).
    pub(crate) d_d: Vector3<f64>,
    /// `∂h/∂u_A` \[mm\] (unconstrained; project with `u × ·` for a torque).
    pub(crate) d_ua: Vector3<f64>,
    /// `∂h/∂u_B` \[mm\].
    pub(crate) d_ub: Vector3<f64>,
    /// The optimal λ of the Perram-Wertheim function (NaN for two spheres
    /// or coincident centres).
    pub(crate) lambda: f64,
}

impl GapGradient {
    /// Gap `h` \[mm\] with `∂h/∂d` and no axis derivatives (two spheres, or
    /// coincident centres).
    fn without_axes(h: f64, d_d: Vector3<f64>) -> GapGradient {
        GapGradient {
            h,
            d_d,
            d_ua: Vector3::zeros(),
            d_ub: Vector3::zeros(),
            lambda: f64::NAN,
        }
    }
}

/// Gap `h` between `a` (centre at the origin) and `b` (centre at `d`) and its
/// derivatives, the Perram-Wertheim iteration started at `start` (see
/// [`perram_wertheim`]). For coincident centres the derivatives are zero.
pub(crate) fn gap_gradient(d: Vector3<f64>, a: &Shape, b: &Shape, start: f64) -> GapGradient {
    let dist = d.norm();
    if a.is_sphere() && b.is_sphere() {
        let d_d = if dist > 0.0 {
            d * (1.0 / dist)
        } else {
            Vector3::zeros()
        };
        return GapGradient::without_axes(dist - a.a - b.a, d_d);
    }
    let pw = match perram_wertheim(d, a, b, start) {
        Some(pw) if pw.f > 0.0 => pw,
        _ => return GapGradient::without_axes(coincident_gap(a, b), Vector3::zeros()),
    };
    let l = pw.lambda;
    let x = pw.x;
    let rs = 1.0 / pw.f.sqrt();
    let k = 0.5 * dist * rs * rs * rs;
    // ∂F/∂d, ∂F/∂u_A, ∂F/∂u_B at the optimal λ.
    let f_d = x * (2.0 * l * (1.0 - l));
    let f_ua = x * (-2.0 * l * (1.0 - l) * (1.0 - l) * (a.c * a.c - a.a * a.a) * x.dot(&a.axis));
    let f_ub = x * (-2.0 * l * l * (1.0 - l) * (b.c * b.c - b.a * b.a) * x.dot(&b.axis));
    let radial = (1.0 - rs) / dist;
    GapGradient {
        h: dist * (1.0 - rs),
        d_d: d * radial + f_d * k,
        d_ua: f_ua * k,
        d_ub: f_ub * k,
        lambda: l,
    }
}

/// Contact point of two touching (or nearly touching) spheroids, on the
/// centre side of `a` (centre at the origin): `(1 - λ) Ā x`, used by tests.
#[cfg(test)]
pub(crate) fn contact_point(d: Vector3<f64>, a: &Shape, b: &Shape) -> Option<Vector3<f64>> {
    let pw = perram_wertheim(d, a, b, f64::NAN)?;
    let pa = a.inverse_matrix() * pw.x * (1.0 - pw.lambda);
    // The same point seen from b: d - λ B̄ x.
    let pb = d - b.inverse_matrix() * pw.x * pw.lambda;
    Some((pa + pb) * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(r: f64) -> Shape {
        Shape {
            a: r,
            c: r,
            axis: Vector3::z(),
        }
    }

    fn spheroid(a: f64, c: f64, axis: [f64; 3]) -> Shape {
        Shape {
            a,
            c,
            axis: Vector3::from(axis).normalize(),
        }
    }

    /// The Perram-Wertheim function itself (the gap of two spheres takes a
    /// shortcut) gives |d| - r1 - r2 for spheres.
    #[test]
    fn pw_of_spheres_is_centre_distance_minus_radii() {
        let a = sphere(0.7);
        let b = sphere(1.3);
        for d in [
            Vector3::new(2.5, 0.0, 0.0),
            Vector3::new(0.3, -1.1, 0.9),
            Vector3::new(1.0, 1.0, 1.0),
            Vector3::new(0.1, 0.2, -0.3),
        ] {
            let pw = perram_wertheim(d, &a, &b, f64::NAN).unwrap();
            let h = d.norm() * (1.0 - 1.0 / pw.f.sqrt());
            let expect = d.norm() - 2.0;
            assert!((h - expect).abs() < 1e-13, "d {d:?}: {h} vs {expect}");
            assert!((gap(d, &a, &b) - expect).abs() < 1e-15);
        }
    }

    #[test]
    fn prolate_spheroids_touch_tip_to_tip_and_side_by_side() {
        let a = 1.0;
        let c = 2.0 * a;
        let p = spheroid(a, c, [0.0, 0.0, 1.0]);
        let along = |k: usize, t: f64| Vector3::ith(k, t);
        // Tip to tip: contact at 2c on z.
        assert!(gap(along(2, 2.0 * c), &p, &p).abs() < 1e-13);
        assert!((gap(along(2, 2.0 * c + 0.1), &p, &p) - 0.1).abs() < 1e-13);
        assert!((gap(along(2, 2.0 * c - 0.1), &p, &p) + 0.1).abs() < 1e-13);
        // Side by side: contact at 2a on x.
        assert!(gap(along(0, 2.0 * a), &p, &p).abs() < 1e-13);
        assert!((gap(along(0, 2.0 * a - 0.05), &p, &p) + 0.05).abs() < 1e-13);
        // Crossed axes (z and x), apart on y: contact at 2a.
        let q = spheroid(a, c, [1.0, 0.0, 0.0]);
        assert!(gap(along(1, 2.0 * a), &p, &q).abs() < 1e-13);
        // Sphere against the tip: r + c.
        let s = sphere(0.6);
        assert!(gap(along(2, 0.6 + c), &p, &s).abs() < 1e-13);
        // Oblate.
        let o = spheroid(1.5, 0.5, [0.0, 1.0, 0.0]);
        assert!(gap(along(1, 1.0), &o, &o).abs() < 1e-13);
        assert!(gap(along(0, 3.0), &o, &o).abs() < 1e-13);
    }

    /// At the contact distance found along an arbitrary direction, the
    /// contact point lies on both surfaces and the outward normals are
    /// opposite: the spheroids touch.
    #[test]
    fn contact_point_lies_on_both_surfaces_with_opposite_normals() {
        let a = spheroid(0.8, 2.1, [0.3, -0.5, 0.8]);
        let b = spheroid(1.2, 0.4, [0.9, 0.1, -0.2]);
        for dir in [[1.0, 0.2, 0.3], [-0.4, 1.0, 0.1], [0.2, -0.3, -1.0]] {
            let n = Vector3::from(dir).normalize();
            let h = gap(n * 3.0, &a, &b);
            let d = n * (3.0 - h);
            assert!(gap(d, &a, &b).abs() < 1e-12);
            let p = contact_point(d, &a, &b).unwrap();
            let on_surface = |s: &Shape, centre: Vector3<f64>| {
                let r = p - centre;
                let ru = r.dot(&s.axis);
                let rperp2 = r.norm_squared() - ru * ru;
                rperp2 / (s.a * s.a) + ru * ru / (s.c * s.c)
            };
            assert!((on_surface(&a, Vector3::zeros()) - 1.0).abs() < 1e-10);
            assert!((on_surface(&b, d) - 1.0).abs() < 1e-10);
            let normal = |s: &Shape, centre: Vector3<f64>| {
                let r = p - centre;
                let ru = r.dot(&s.axis);
                let g = r / (s.a * s.a) + s.axis * (ru * (1.0 / (s.c * s.c) - 1.0 / (s.a * s.a)));
                g.normalize()
            };
            let na = normal(&a, Vector3::zeros());
            let nb = normal(&b, d);
            assert!((na.dot(&nb) + 1.0).abs() < 1e-10, "{}", na.dot(&nb));
        }
    }

    #[test]
    fn gap_is_symmetric() {
        let a = spheroid(0.8, 2.1, [0.3, -0.5, 0.8]);
        let b = spheroid(1.2, 0.4, [0.9, 0.1, -0.2]);
        let d = Vector3::new(0.8, 0.5, -0.3);
        let hab = gap(d, &a, &b);
        let hba = gap(-d, &b, &a);
        assert!((hab - hba).abs() < 1e-13);
        assert!(hab < 0.0);
    }

    /// `∂h/∂d`, `∂h/∂u_A` and `∂h/∂u_B` (the axes as free vectors) against
    /// central differences of the gap.
    #[test]
    fn gradient_matches_finite_differences() {
        let a = spheroid(0.8, 2.1, [0.3, -0.5, 0.8]);
        let b = spheroid(1.2, 0.4, [0.9, 0.1, -0.2]);
        let d = Vector3::new(1.1, 0.7, -0.4);
        let g = gap_gradient(d, &a, &b, f64::NAN);
        assert!((g.h - gap(d, &a, &b)).abs() < 1e-14);
        let eps = 1e-6;
        let central = |h: &dyn Fn(f64) -> f64| (h(eps) - h(-eps)) / (2.0 * eps);
        let tilted = |s: &Shape, e: Vector3<f64>| Shape {
            axis: s.axis + e,
            ..*s
        };
        for k in 0..3 {
            let e = |t: f64| Vector3::ith(k, t);
            let checks = [
                ("d", central(&|t| gap(d + e(t), &a, &b)), g.d_d[k]),
                ("ua", central(&|t| gap(d, &tilted(&a, e(t)), &b)), g.d_ua[k]),
                ("ub", central(&|t| gap(d, &a, &tilted(&b, e(t)))), g.d_ub[k]),
            ];
            for (name, fd, exact) in checks {
                assert!((fd - exact).abs() < 1e-7, "{name}[{k}]: {fd} vs {exact}");
            }
        }
    }
}
