//! The closed-form gradient and Hessian of the penetration against
//! automatic differentiation (hyper-dual numbers) and against finite
//! differences of the gradient, on flat, warped, strongly skewed and
//! spherical facets, with the slave in front of the facet, on it and behind
//! it, projecting inside the facet and beyond its edges.

#[path = "support/dual_penetration.rs"]
mod dual_penetration;

use tidens_contact::gap::patch;
use tidens_contact::{
    penetration_gradient, penetration_hessian, project, project_from, project_triangle,
    triangle_penetration_hessian, triangle_shape,
};

type Facet = [[f64; 3]; 4];

/// A planar trapezoid in a tilted plane.
fn flat() -> Facet {
    let (e1, e2) = ([0.8, 0.6, 0.0], [-0.36, 0.48, 0.8]);
    let p = |u: f64, v: f64| [0, 1, 2].map(|i| 0.2 + u * e1[i] + v * e2[i]);
    [p(0.0, 0.0), p(1.3, 0.0), p(1.0, 0.9), p(0.2, 1.0)]
}

/// A nearly square facet with its corners moved out of plane.
fn warped() -> Facet {
    [
        [0.0, 0.02, 1.0],
        [1.05, -0.03, 1.08],
        [0.97, 1.0, 0.95],
        [0.03, 0.96, 1.04],
    ]
}

/// A skewed, strongly twisted facet.
fn skewed() -> Facet {
    [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.3],
        [1.6, 0.8, -0.2],
        [0.4, 1.0, 0.5],
    ]
}

/// A facet of a particle surface at the solver's scale: corners on a sphere
/// of radius 0.05 mm, about 0.006 mm across.
fn spherical() -> Facet {
    let r = 0.05;
    let on_sphere = |theta: f64, phi: f64| {
        [
            r * theta.sin() * phi.cos(),
            r * theta.sin() * phi.sin(),
            r * theta.cos(),
        ]
    };
    [
        on_sphere(0.60, 0.70),
        on_sphere(0.60, 0.84),
        on_sphere(0.72, 0.86),
        on_sphere(0.73, 0.69),
    ]
}

fn size(x: &Facet) -> f64 {
    let d = [0, 1, 2].map(|i| x[2][i] - x[0][i]);
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Slave points at signed gap `g` along the normal from the patch points at
/// `xi` (so that `xi` is their projection), for gaps in front of the facet,
/// zero and behind it (relative to the facet size), and projections inside
/// the facet and up to 1.2 beyond its edges.
fn slaves(x: &Facet) -> Vec<([f64; 3], [f64; 2])> {
    let h = size(x);
    let mut out = Vec::new();
    for xi in [
        [0.1, -0.3],
        [0.9, 0.95],
        [1.2, -0.4],
        [-1.15, 1.2],
        [-0.6, -1.2],
    ] {
        for g in [0.12 * h, 0.0, -0.06 * h] {
            let p = patch(x, xi);
            let [t1, t2] = p.tangents;
            let m = [
                t1[1] * t2[2] - t1[2] * t2[1],
                t1[2] * t2[0] - t1[0] * t2[2],
                t1[0] * t2[1] - t1[1] * t2[0],
            ];
            let norm = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            out.push(([0, 1, 2].map(|i| p.point[i] + g * m[i] / norm), xi));
        }
    }
    out
}

fn facets() -> [(&'static str, Facet); 4] {
    [
        ("flat", flat()),
        ("warped", warped()),
        ("skewed", skewed()),
        ("spherical", spherical()),
    ]
}

fn largest(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn slave_points_project_where_they_were_placed() {
    for (name, x) in facets() {
        for (s, xi) in slaves(&x) {
            let found = project(&s, &x);
            assert!(
                (found[0] - xi[0]).abs() < 1e-10 && (found[1] - xi[1]).abs() < 1e-10,
                "{name}: placed at {xi:?}, projects at {found:?}"
            );
        }
    }
}

#[test]
fn closed_form_gradient_and_hessian_equal_the_dual_number_ones() {
    for (name, x) in facets() {
        let h = size(&x);
        for (s, _) in slaves(&x) {
            let xi = project(&s, &x);
            let closed = penetration_hessian(&s, &x, xi);
            let (p, g, hess) = dual_penetration::hessian(&s, &x, xi);
            assert!(
                (closed.value - p).abs() <= 1e-14 * h,
                "{name} {s:?}: p {} vs {p}",
                closed.value
            );
            let gmax = largest(g);
            for k in 0..15 {
                assert!(
                    (closed.gradient[k] - g[k]).abs() <= 1e-12 * gmax,
                    "{name} {s:?}: dp/du[{k}] {} vs {}",
                    closed.gradient[k],
                    g[k]
                );
            }
            let hmax = largest(hess.iter().flatten().copied());
            assert!(
                hmax > 0.1 / h,
                "{name} {s:?}: Hessian {hmax} too small to test"
            );
            for i in 0..15 {
                for j in 0..15 {
                    assert!(
                        (closed.hessian[i][j] - hess[i][j]).abs() <= 1e-12 * hmax,
                        "{name} {s:?}: H[{i}][{j}] {} vs {}",
                        closed.hessian[i][j],
                        hess[i][j]
                    );
                }
            }
            // The residual-only path gives the same value and gradient.
            let first = penetration_gradient(&s, &x, xi);
            assert_eq!(first.value, closed.value);
            assert_eq!(first.gradient, closed.gradient);
            let (pd, gd) = dual_penetration::gradient(&s, &x, xi);
            assert!((pd - p).abs() <= 1e-14 * h);
            assert!((0..15).all(|k| (gd[k] - g[k]).abs() <= 1e-12 * gmax));
        }
    }
}

#[test]
fn closed_form_hessian_is_symmetric() {
    for (name, x) in facets() {
        for (s, _) in slaves(&x) {
            let hess = penetration_hessian(&s, &x, project(&s, &x)).hessian;
            for i in 0..15 {
                for j in 0..i {
                    assert_eq!(hess[i][j], hess[j][i], "{name} {s:?}: H[{i}][{j}]");
                }
            }
        }
    }
}

#[test]
fn closed_form_hessian_equals_finite_differences_of_the_gradient() {
    // Central differences of the closed-form gradient, the slave projected
    // afresh at every perturbed configuration (Newton from the unperturbed
    // projection: from the patch centre it can wander to another stationary
    // point of the distance when the slave is far beyond a twisted facet's
    // edge).
    let gradient = |v: &[f64; 15], xi0: [f64; 2]| {
        let s = [v[0], v[1], v[2]];
        let x: Facet = std::array::from_fn(|a| [v[3 + 3 * a], v[4 + 3 * a], v[5 + 3 * a]]);
        penetration_gradient(&s, &x, project_from(&s, &x, xi0)).gradient
    };
    for (name, x) in facets() {
        let step = 1e-6 * size(&x);
        for (s, _) in slaves(&x) {
            let xi = project(&s, &x);
            let hess = penetration_hessian(&s, &x, xi).hessian;
            let hmax = largest(hess.iter().flatten().copied());
            let v: [f64; 15] = dual_penetration::pack(&s, &x).into();
            for j in 0..15 {
                let (mut up, mut down) = (v, v);
                up[j] += step;
                down[j] -= step;
                let (gu, gd) = (gradient(&up, xi), gradient(&down, xi));
                for i in 0..15 {
                    let fd = (gu[i] - gd[i]) / (2.0 * step);
                    assert!(
                        (fd - hess[i][j]).abs() <= 1e-7 * hmax,
                        "{name} {s:?}: H[{i}][{j}] {} vs finite differences {fd}",
                        hess[i][j]
                    );
                }
            }
        }
    }
}

/// Flat triangles: a tilted one, a skewed one, and one of a particle surface
/// at the solver's scale (corners on a sphere of radius 0.05 mm).
fn triangles() -> [(&'static str, [[f64; 3]; 3]); 3] {
    let r = 0.05;
    let on_sphere = |theta: f64, phi: f64| {
        [
            r * theta.sin() * phi.cos(),
            r * theta.sin() * phi.sin(),
            r * theta.cos(),
        ]
    };
    [
        (
            "tilted",
            [[0.2, 0.2, 0.2], [1.24, 0.98, 0.2], [-0.16, 0.68, 1.0]],
        ),
        (
            "skewed",
            [[0.0, 0.0, 0.0], [1.0, 0.1, 0.3], [1.6, 0.8, -0.2]],
        ),
        (
            "spherical",
            [
                on_sphere(0.60, 0.70),
                on_sphere(0.60, 0.84),
                on_sphere(0.72, 0.86),
            ],
        ),
    ]
}

/// Slave points in front of, on and behind the triangle, projecting inside
/// it and beyond its edges and corners, at the triangle's scale.
fn triangle_slaves(x: &[[f64; 3]; 3]) -> Vec<[f64; 3]> {
    let (a1, a2) = (
        [0, 1, 2].map(|i| x[1][i] - x[0][i]),
        [0, 1, 2].map(|i| x[2][i] - x[0][i]),
    );
    let n = [
        a1[1] * a2[2] - a1[2] * a2[1],
        a1[2] * a2[0] - a1[0] * a2[2],
        a1[0] * a2[1] - a1[1] * a2[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let h = largest(a1.iter().chain(a2.iter()).map(|v| v.abs()));
    let mut out = Vec::new();
    for (xi, eta) in [
        (0.2, 0.3),
        (0.6, 0.35),
        (-0.2, 0.5),
        (0.4, -0.3),
        (1.1, 0.2),
    ] {
        for g in [0.1, 0.0, -0.05] {
            out.push([0, 1, 2].map(|i| x[0][i] + xi * a1[i] + eta * a2[i] + g * h * n[i] / len));
        }
    }
    out
}

fn triangle_term(v: &[f64; 15]) -> ([f64; 3], [[f64; 3]; 3]) {
    (
        [v[0], v[1], v[2]],
        std::array::from_fn(|a| [v[3 + 3 * a], v[4 + 3 * a], v[5 + 3 * a]]),
    )
}

#[test]
fn triangle_penetration_is_the_signed_distance_to_its_plane() {
    for (name, x) in triangles() {
        for s in triangle_slaves(&x) {
            let xi = project_triangle(&s, &x);
            let p = triangle_penetration_hessian(&s, &x, xi);
            // The foot's offset is normal to both edges.
            let n = triangle_shape(xi);
            let foot = [0, 1, 2].map(|i| n[0] * x[0][i] + n[1] * x[1][i] + n[2] * x[2][i]);
            let d = [0, 1, 2].map(|i| s[i] - foot[i]);
            for e in [1, 2] {
                let t = [0, 1, 2].map(|i| x[e][i] - x[0][i]);
                let along = d[0] * t[0] + d[1] * t[1] + d[2] * t[2];
                assert!(
                    along.abs() < 1e-13,
                    "{name} {s:?}: offset along edge {along}"
                );
            }
            // -dp/ds is the unit normal; the penetration is minus the offset along it.
            let ns = [-p.gradient[0], -p.gradient[1], -p.gradient[2]];
            let gap = d[0] * ns[0] + d[1] * ns[1] + d[2] * ns[2];
            assert!(
                (p.value + gap).abs() < 1e-14,
                "{name}: {} vs {}",
                p.value,
                -gap
            );
            assert!((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - gap.abs() < 1e-14);
        }
    }
}

#[test]
fn triangle_gradient_and_hessian_equal_finite_differences() {
    // The fourth facet slot of the 15-dof term is empty: its rows and
    // columns are zero. The slave is projected afresh at every perturbed
    // configuration.
    let eval = |v: &[f64; 15]| {
        let (s, x) = triangle_term(v);
        triangle_penetration_hessian(&s, &x, project_triangle(&s, &x))
    };
    for (name, x) in triangles() {
        let step = 1e-6 * largest(x.iter().flatten().map(|v| v.abs()));
        for s in triangle_slaves(&x) {
            let mut v = [0.0; 15];
            v[..3].copy_from_slice(&s);
            for a in 0..3 {
                v[3 + 3 * a..6 + 3 * a].copy_from_slice(&x[a]);
            }
            let here = eval(&v);
            let hmax = largest(here.hessian.iter().flatten().copied());
            for j in 0..12 {
                let (mut up, mut down) = (v, v);
                up[j] += step;
                down[j] -= step;
                let (pu, pd) = (eval(&up), eval(&down));
                let fd = (pu.value - pd.value) / (2.0 * step);
                assert!(
                    (fd - here.gradient[j]).abs() < 1e-7,
                    "{name} {s:?}: dp/du[{j}] {} vs {fd}",
                    here.gradient[j]
                );
                for i in 0..15 {
                    let fd = (pu.gradient[i] - pd.gradient[i]) / (2.0 * step);
                    assert!(
                        (fd - here.hessian[i][j]).abs() <= 1e-7 * hmax,
                        "{name} {s:?}: H[{i}][{j}] {} vs finite differences {fd}",
                        here.hessian[i][j]
                    );
                    assert_eq!(here.hessian[i][j], here.hessian[j][i]);
                }
            }
            for k in 12..15 {
                assert_eq!(here.gradient[k], 0.0);
                assert!(here.hessian[k].iter().all(|&h| h == 0.0));
            }
        }
    }
}
