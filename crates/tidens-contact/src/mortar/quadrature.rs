//! Quadrature on the integration cells and facets, and the in-plane
//! inverse maps that carry a cell's points back to the facets' parametric
//! coordinates.
//!
//! Cells: the 7-point rule of degree 5 on a triangle (Radon's, Dunavant's
//! rule 5), in barycentric coordinates with weights that sum to one
//! (`a = (6 - sqrt 15)/21`, `b = (6 + sqrt 15)/21`):
//!
//! ```text
//! int_T f dA ~ |T| sum_g w_g f(z_g),
//! (1/3, 1/3, 1/3)              w = 9/40
//! (a, a, 1 - 2a) and cyclic    w = (155 - sqrt 15)/1200
//! (b, b, 1 - 2b) and cyclic    w = (155 + sqrt 15)/1200
//! ```
//!
//! Facets (the supports' integrals `A_j = int Phi_j dA` and the dual
//! basis' matrices): 3 x 3 Gauss on a quad's `[-1, 1]^2` (exact for the
//! bilinear `N_j N_k J` of a flat quad), the 7-point rule on a triangle.
//!
//! Inverse maps. A facet's nodes projected on the auxiliary plane, `p_k =
//! P(x_k)`, span the planar map `z(xi) = sum_k N_k(xi) p_k`; since `P` is
//! affine, `z(xi) = P(x(xi))`. For a point `z` of the plane the inverse
//! map finds `xi` with `z(xi) = z`:
//!
//! - Tri3: `z = p_0 + xi (p_1 - p_0) + eta (p_2 - p_0)`, a 2 x 2 linear
//!   solve;
//! - Quad4: Newton on the bilinear map from the inverse of its affine
//!   part at the centre, `xi <- xi - (dz/dxi)^-1 (z(xi) - z)`, in `f64`
//!   until the step, or the one that would follow it (the residual after
//!   a step `h` is `d h_1 h_2` exactly), is below [`INVERSE_TOLERANCE`];
//!   a cell's seven points side by side. Then `T::NDERIV` more steps in
//!   the scalar `T`: from a converged real part each step makes one more
//!   order of the dual parts exact (the derivatives of the implicit
//!   function `xi(z, p)`). The first of them keeps the shape functions
//!   and the Jacobian in `f64` (xi has no dual part yet): `xi = xi_0 -
//!   J(xi_0)^-1 (sum_k N_k(xi_0) p_k - z)`, the implicit function
//!   theorem's first derivative at a fifth of the cost of a step all in
//!   `T`.

use crate::mortar::MortarError;
use crate::mortar::trace::{AdScalar, Trace};

/// `(6 - sqrt 15) / 21`.
const A: f64 = 0.101_286_507_323_456_34;
/// `(6 + sqrt 15) / 21`.
const B: f64 = 0.470_142_064_105_115_1;
/// `(155 - sqrt 15) / 1200`.
const WA: f64 = 0.125_939_180_544_827_15;
/// `(155 + sqrt 15) / 1200`.
const WB: f64 = 0.132_394_152_788_506_2;

/// The 7-point degree-5 triangle rule: barycentric coordinates and
/// weights (summing to one: multiply by the triangle's area).
pub const TRIANGLE_7: [([f64; 3], f64); 7] = [
    ([1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0], 9.0 / 40.0),
    ([A, A, 1.0 - 2.0 * A], WA),
    ([A, 1.0 - 2.0 * A, A], WA),
    ([1.0 - 2.0 * A, A, A], WA),
    ([B, B, 1.0 - 2.0 * B], WB),
    ([B, 1.0 - 2.0 * B, B], WB),
    ([1.0 - 2.0 * B, B, B], WB),
];

/// `sqrt(3/5)`.
const G3: f64 = 0.774_596_669_241_483_4;

/// The 3-point Gauss rule on `[-1, 1]` (degree 5).
pub const GAUSS_3: [(f64, f64); 3] = [(-G3, 5.0 / 9.0), (0.0, 8.0 / 9.0), (G3, 5.0 / 9.0)];

/// Newton on the bilinear inverse map stops when its step is below this
/// (in parametric units, the facet's half-width being 1).
pub const INVERSE_TOLERANCE: f64 = 1e-14;

/// Newton steps allowed before [`inverse_map`] gives up.
const MAX_NEWTON: usize = 30;

/// The facet rule of `trace`: parametric points and weights (summing to
/// the reference area).
pub fn element_rule(trace: Trace) -> Vec<([f64; 2], f64)> {
    match trace {
        Trace::Quad4 => GAUSS_3
            .iter()
            .flat_map(|&(s, ws)| GAUSS_3.iter().map(move |&(t, wt)| ([s, t], ws * wt)))
            .collect(),
        Trace::Tri3 => TRIANGLE_7
            .iter()
            .map(|&(l, w)| ([l[1], l[2]], 0.5 * w))
            .collect(),
    }
}

fn sub<T: AdScalar>(a: [T; 2], b: [T; 2]) -> [T; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// `[xi, eta]` solving `[u v] [xi, eta]^T = r` (None when singular).
fn solve2<T: AdScalar>(u: [T; 2], v: [T; 2], r: [T; 2]) -> Option<[T; 2]> {
    let det = u[0] * v[1] - u[1] * v[0];
    if !(det.re().abs() > 0.0) {
        return None;
    }
    Some([
        (r[0] * v[1] - r[1] * v[0]) / det,
        (u[0] * r[1] - u[1] * r[0]) / det,
    ])
}

/// The planar map's residual `z(xi) - z` and its columns `dz/dxi`,
/// `dz/deta`.
fn residual<T: AdScalar>(trace: Trace, p: &[[T; 2]; 4], z: [T; 2], xi: [T; 2]) -> [[T; 2]; 3] {
    let n = trace.shape(xi);
    let dn = trace.shape_derivatives(xi);
    let zero = T::from(0.0);
    let (mut f, mut a, mut b) = ([zero; 2], [zero; 2], [zero; 2]);
    for k in 0..trace.node_count() {
        for c in 0..2 {
            f[c] += n[k] * p[k][c];
            a[c] += dn[k][0] * p[k][c];
            b[c] += dn[k][1] * p[k][c];
        }
    }
    [sub(f, z), a, b]
}

/// Newton on the bilinear planar map of the projected quad nodes `p`,
/// written `z(xi) = c + xi a + eta b + xi eta d` (see
/// [`Expansion`](crate::mortar::trace::Expansion)), for each of the points
/// `z`, side by side (their iterations are independent: the processor
/// overlaps them). Each starts from the inverse of the map's affine part
/// at the centre (exact on a parallelogram; two or three steps then
/// converge). The parameters and the last steps, or the first point that
/// did not converge with the iterations done and its last step.
#[allow(clippy::type_complexity)]
fn bilinear_inverses<const K: usize>(
    p: &[[f64; 2]; 4],
    z: &[[f64; 2]; K],
) -> Result<([[f64; 2]; K], [f64; K]), (usize, usize, f64)> {
    let e = |w: [f64; 4]| {
        [0, 1].map(|c| 0.25 * (w[0] * p[0][c] + w[1] * p[1][c] + w[2] * p[2][c] + w[3] * p[3][c]))
    };
    let c = e([1.0, 1.0, 1.0, 1.0]);
    let a = e([-1.0, 1.0, 1.0, -1.0]);
    let b = e([-1.0, -1.0, 1.0, 1.0]);
    let d = e([1.0, -1.0, 1.0, -1.0]);
    let dmax = d[0].abs().max(d[1].abs());
    let r: [[f64; 2]; K] = std::array::from_fn(|g| sub(c, z[g]));
    let mut xi: [[f64; 2]; K] =
        std::array::from_fn(|g| solve2(a, b, r[g]).map_or([0.0, 0.0], |d| [-d[0], -d[1]]));
    let mut step = [f64::INFINITY; K];
    let mut done = [false; K];
    for it in 0..MAX_NEWTON {
        for g in 0..K {
            if done[g] {
                continue;
            }
            let [s, t] = xi[g];
            let f = [0, 1].map(|k| r[g][k] + a[k] * s + b[k] * t + d[k] * (s * t));
            let (ja, jb) = (
                [a[0] + d[0] * t, a[1] + d[1] * t],
                [b[0] + d[0] * s, b[1] + d[1] * s],
            );
            let det = ja[0] * jb[1] - ja[1] * jb[0];
            if !(det.abs() > 0.0) {
                return Err((g, it, step[g]));
            }
            let inv = 1.0 / det;
            let h = [
                (f[0] * jb[1] - f[1] * jb[0]) * inv,
                (ja[0] * f[1] - ja[1] * f[0]) * inv,
            ];
            xi[g] = sub(xi[g], h);
            step[g] = h[0].abs().max(h[1].abs());
            // The residual after the step is d h_1 h_2 exactly (the map is
            // bilinear): the step that would follow is about J^-1 d h_1
            // h_2, bounded with this step's Jacobian.
            let inverse_norm =
                (jb[0].abs() + jb[1].abs()).max(ja[0].abs() + ja[1].abs()) * inv.abs();
            let next = inverse_norm * dmax * (h[0] * h[1]).abs();
            done[g] = step[g] < INVERSE_TOLERANCE || next < 0.1 * INVERSE_TOLERANCE;
        }
        if done.iter().all(|&d| d) {
            return Ok((xi, step));
        }
    }
    let g = done.iter().position(|&d| !d).unwrap_or(0);
    Err((g, MAX_NEWTON, step[g]))
}

/// The parametric coordinates `xi` of the point `z` of the auxiliary
/// plane on the planar map of a facet of `trace` whose projected nodes are
/// `p` (see the module docs).
pub fn inverse_map<T: AdScalar>(
    trace: Trace,
    p: &[[T; 2]; 4],
    z: [T; 2],
) -> Result<[T; 2], MortarError> {
    inverse_maps(trace, p, &[z]).map(|[xi]| xi)
}

/// [`inverse_map`] of each of the points `z` (a quad's Newton iterations
/// side by side).
pub fn inverse_maps<T: AdScalar, const K: usize>(
    trace: Trace,
    p: &[[T; 2]; 4],
    z: &[[T; 2]; K],
) -> Result<[[T; 2]; K], MortarError> {
    let fail = |g: usize, iterations, step| MortarError::InverseMap {
        trace,
        z: [z[g][0].re(), z[g][1].re()],
        iterations,
        step,
    };
    match trace {
        Trace::Tri3 => {
            let (u, v) = (sub(p[1], p[0]), sub(p[2], p[0]));
            let mut xi = [[T::from(0.0); 2]; K];
            for g in 0..K {
                xi[g] = solve2(u, v, sub(z[g], p[0])).ok_or_else(|| fail(g, 0, f64::NAN))?;
            }
            Ok(xi)
        }
        Trace::Quad4 => {
            let pr: [[f64; 2]; 4] = [0, 1, 2, 3].map(|k| [p[k][0].re(), p[k][1].re()]);
            let zr: [[f64; 2]; K] = std::array::from_fn(|g| [z[g][0].re(), z[g][1].re()]);
            let (xr, steps) =
                bilinear_inverses(&pr, &zr).map_err(|(g, it, step)| fail(g, it, step))?;
            let mut out = [[T::from(0.0); 2]; K];
            for g in 0..K {
                out[g] = refine(&pr, p, zr[g], z[g], xr[g])
                    .ok_or_else(|| fail(g, MAX_NEWTON, steps[g]))?;
            }
            Ok(out)
        }
    }
}

/// A quad's inverse map in the scalar `T` from its converged real part
/// `xi` (projected nodes `p`, real parts `pr`; the point `z`, real part
/// `zr`): `T::NDERIV` Newton steps in `T`, each making one more order of
/// the dual parts exact (the derivatives of the implicit function `xi(z,
/// p)`). None if a step's Jacobian is singular.
fn refine<T: AdScalar>(
    pr: &[[f64; 2]; 4],
    p: &[[T; 2]; 4],
    zr: [f64; 2],
    z: [T; 2],
    xi: [f64; 2],
) -> Option<[T; 2]> {
    let trace = Trace::Quad4;
    if T::NDERIV == 0 {
        return Some(xi.map(T::from));
    }
    // The first step in the scalar T from the converged real part,
    // with the shape functions and the Jacobian there in f64 (the
    // dual parts of xi are zero): it makes the first derivatives
    // exact, at a fifth of the cost of a step all in T.
    let n = trace.shape(xi);
    let [_, a, b] = residual(trace, pr, zr, xi);
    let mut f = [-z[0], -z[1]];
    for k in 0..4 {
        for c in 0..2 {
            f[c] += p[k][c] * n[k];
        }
    }
    let det = a[0] * b[1] - a[1] * b[0];
    let mut xi = [
        T::from(xi[0]) - (f[0] * b[1] - f[1] * b[0]) / det,
        T::from(xi[1]) - (f[1] * a[0] - f[0] * a[1]) / det,
    ];
    // Each further step in T makes one more order exact.
    for _ in 1..T::NDERIV {
        let [f, a, b] = residual(trace, p, z, xi);
        xi = sub(xi, solve2(a, b, f)?);
    }
    Some(xi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SVector;
    use num_dual::{Dual2SVec64, DualSVec64};

    /// The square root of 15.
    const SQRT15: f64 = 3.872_983_346_207_417;

    #[test]
    fn the_triangle_rule_has_its_closed_form_and_degree_five() {
        assert_eq!(SQRT15, 15f64.sqrt());
        // Within the round-off of sqrt 15 (2e-16 relative).
        assert!((A - (6.0 - SQRT15) / 21.0).abs() < 1e-16);
        assert!((B - (6.0 + SQRT15) / 21.0).abs() < 1e-16);
        assert!((WA - (155.0 - SQRT15) / 1200.0).abs() < 1e-16);
        assert!((WB - (155.0 + SQRT15) / 1200.0).abs() < 1e-16);
        // int over the reference triangle of xi^p eta^q = p! q! / (p + q + 2)!.
        let fact = |n: u32| (1..=n).product::<u32>().max(1) as f64;
        for p in 0..=5 {
            for q in 0..=5 - p {
                let exact = fact(p) * fact(q) / fact(p + q + 2);
                let rule: f64 = element_rule(Trace::Tri3)
                    .iter()
                    .map(|([s, t], w)| w * s.powi(p as i32) * t.powi(q as i32))
                    .sum();
                assert!((rule - exact).abs() < 1e-16, "{p} {q}");
            }
        }
        // Degree six is not exact: the rule is the one claimed.
        let rule: f64 = element_rule(Trace::Tri3)
            .iter()
            .map(|([s, _], w)| w * s.powi(6))
            .sum();
        assert!((rule - fact(6) / fact(8)).abs() > 1e-8);
    }

    #[test]
    fn the_quad_rule_integrates_biquintics() {
        for p in 0..=5 {
            for q in 0..=5 {
                let mono = |k: i32| {
                    if k % 2 == 1 {
                        0.0
                    } else {
                        2.0 / (k + 1) as f64
                    }
                };
                let rule: f64 = element_rule(Trace::Quad4)
                    .iter()
                    .map(|([s, t], w)| w * s.powi(p) * t.powi(q))
                    .sum();
                assert!((rule - mono(p) * mono(q)).abs() < 1e-15);
            }
        }
    }

    /// A non-affine planar quad and a point inside it.
    fn quad() -> [[f64; 2]; 4] {
        [[0.0, 0.0], [2.0, 0.3], [1.7, 1.9], [-0.2, 1.1]]
    }

    #[test]
    fn inverse_maps_invert_the_planar_maps() {
        for (trace, p) in [
            (Trace::Quad4, quad()),
            (
                Trace::Tri3,
                [[0.1, 0.2], [2.0, 0.3], [0.4, 1.5], [0.4, 1.5]],
            ),
        ] {
            for xi in [[0.3, -0.7], [0.1, 0.2], [-0.99, 0.98], [0.0, 0.0]] {
                let [z, _, _] = residual(trace, &p, [0.0, 0.0], xi);
                let back = inverse_map(trace, &p, z).unwrap();
                assert!((back[0] - xi[0]).abs() < 1e-14 && (back[1] - xi[1]).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn dual_parts_are_the_implicit_functions_derivatives() {
        // xi(z, p) over the 10 inputs (z and the 4 corners), gradient and
        // Hessian against central differences of the f64 map.
        let p0 = quad();
        let z0 = [0.9, 0.7];
        let v =
            SVector::<f64, 10>::from_fn(|i, _| if i < 2 { z0[i] } else { p0[(i - 2) / 2][i % 2] });
        let split = |v: &SVector<f64, 10>| {
            let p: [[f64; 2]; 4] = std::array::from_fn(|k| [v[2 + 2 * k], v[3 + 2 * k]]);
            ([v[0], v[1]], p)
        };
        let xi_of = |v: &SVector<f64, 10>, c: usize| {
            let (z, p) = split(v);
            inverse_map(Trace::Quad4, &p, z).unwrap()[c]
        };
        for c in 0..2 {
            let (_, g) = num_dual::gradient(
                |v: SVector<DualSVec64<10>, 10>| {
                    let p = std::array::from_fn(|k| [v[2 + 2 * k], v[3 + 2 * k]]);
                    inverse_map(Trace::Quad4, &p, [v[0], v[1]]).unwrap()[c]
                },
                &v,
            );
            let (_, g2, h) = num_dual::hessian(
                |v: SVector<Dual2SVec64<10>, 10>| {
                    let p = std::array::from_fn(|k| [v[2 + 2 * k], v[3 + 2 * k]]);
                    inverse_map(Trace::Quad4, &p, [v[0], v[1]]).unwrap()[c]
                },
                &v,
            );
            let e = 1e-5;
            for i in 0..10 {
                let mut vp = v;
                let mut vm = v;
                vp[i] += e;
                vm[i] -= e;
                let fd = (xi_of(&vp, c) - xi_of(&vm, c)) / (2.0 * e);
                assert!((fd - g[i]).abs() < 1e-9 && (g2[i] - g[i]).abs() < 1e-14);
                for k in 0..10 {
                    let (_, gp) = num_dual::gradient(
                        |v: SVector<DualSVec64<10>, 10>| {
                            let p = std::array::from_fn(|k| [v[2 + 2 * k], v[3 + 2 * k]]);
                            inverse_map(Trace::Quad4, &p, [v[0], v[1]]).unwrap()[c]
                        },
                        &vp,
                    );
                    let (_, gm) = num_dual::gradient(
                        |v: SVector<DualSVec64<10>, 10>| {
                            let p = std::array::from_fn(|k| [v[2 + 2 * k], v[3 + 2 * k]]);
                            inverse_map(Trace::Quad4, &p, [v[0], v[1]]).unwrap()[c]
                        },
                        &vm,
                    );
                    let fd2 = (gp[k] - gm[k]) / (2.0 * e);
                    assert!(
                        (fd2 - h[(i, k)]).abs() < 1e-7,
                        "{i} {k}: {fd2} {}",
                        h[(i, k)]
                    );
                }
            }
        }
    }
}
