//! Spheroid-octant meshes whose volume is exactly pi a^2 c / 6.
//!
//! Why. The surface nodes of [`crate::HexMesh::spheroid_octant`] lie on the
//! spheroid, so every bilinear surface facet lies inside the convex particle
//! and the mesh misses a volume of relative size O(h^2) (about -0.75 % for the
//! sc cell at 6 divisions). Near full density the density curve rho(t) is so
//! flat that this deficit alone shifts the time to reach a given density by
//! several per cent. Moving the surface nodes outward by O(h^2) removes it.
//!
//! Offset rule. Write L(x) = (x^2 + y^2)/a^2 + z^2/c^2 for the spheroid's level
//! function. The centre point `c_f` (mean of the four nodes) of a curved
//! facet `f` lies on the ray from the particle centre at the fraction
//! `sqrt(L(c_f))` of the way to the surface, so
//!
//! ```text
//! sigma_f = 1 - sqrt(L(c_f))
//! ```
//!
//! is the facet's sagitta measured along that ray, relative to the ray's
//! length to the surface (on the unit sphere it is the sagitta itself). Each
//! surface node gets the mean `w_i` of `sigma_f` over its curved facets, and
//! `w_i = 0` at the seven special points: the poles (a,0,0), (0,a,0),
//! (0,0,c), the diagonal point and the three face-diagonal points, where a
//! particle touches a rigid plane or its neighbour at the start and any
//! offset would create an initial overlap. With one scalar factor `lambda`,
//!
//! ```text
//! P_i  ->  (1 + lambda w_i) P_i                   (surface node)
//! x    ->  x + t lambda w_i P_i                   (shell node at radial parameter t
//!                                                   on the ray of surface node P_i)
//! ```
//!
//! and the inner block (t = 0) stays. Shell nodes move in proportion to their
//! radial parameter, so the radial columns stay straight segments from the
//! inner block to the moved surface point and no element is squashed.
//!
//! Tangent-plane cap. Next to a special point a long, thin facet (graded
//! meshes are anisotropic near the face-diagonal points) can have a sagitta
//! larger than the drop of the spheroid below the tangent plane at that
//! point, and its node would cross the plane, into the neighbour touching
//! there. So the relative offset is `min(lambda w_i, e_i / 2)`, with `e_i`
//! the radial scaling that would bring node i onto the nearest tangent plane
//! at a special point ([`tangent_allowance`]): every node stays at most
//! halfway from the spheroid to each of those planes. Two particles touching
//! at a special point share its tangent plane, so their meshes cannot
//! overlap, and a particle touching a rigid plane at a pole stays behind it.
//! Like the sagitta, `e_i` grows quadratically with the distance from the
//! special point; the cap binds only next to the special points.
//!
//! Direction: along the construction ray, i.e. a radial scaling of the
//! surface point about the particle centre, rather than along the spheroid's
//! normal. (1) A node on a symmetry plane x = 0, y = 0 or z = 0 has that
//! coordinate exactly zero and keeps it, bit for bit, because it is only
//! scaled; the special points do not move at all. (2) Radial scaling commutes
//! with diag(a, a, c), and `sigma_f` is defined through L, so the moved mesh
//! is the affine image of the moved unit-sphere mesh, where the ray is the
//! surface normal: the offset is normal in the frame where the layout is
//! built, the volume ratio is the same in both frames, and c/a enters only
//! through the layout. (3) The surface nodes do not slide tangentially, so the
//! surface element shapes and the tangential grading are unchanged. The
//! spheroid normal differs from the ray by at most ~20 degrees for c/a in
//! 0.5..2, so a normal offset would add only a small tangential slide.
//!
//! Factor. The gap between a bilinear facet and a smooth surface is, to
//! leading order, the bilinear interpolation error of a quadratic,
//! `q_uu u(1-u)/2 + q_vv v(1-v)/2` on the unit square (the `uv` term is
//! interpolated exactly): its mean over the facet is 2/3 of its value at the
//! centre. So `lambda` tends to 2/3 as h -> 0, and the largest surface offset
//! is about (2/3) of the largest sagitta, O(h^2): a fraction O(h / R) of the
//! element size. Between the kinks of the cap the meshed volume `V(lambda)`
//! is a cubic polynomial in `lambda` (each coordinate is affine in `lambda`,
//! a trilinear element's volume is cubic in its coordinates); it is
//! continuous and increasing for the small offsets here, and
//! [`solve_increasing`] finds `V(lambda) = pi a^2 c / 6` by the Illinois
//! variant of the secant method on a bracket (6 to 8 volume evaluations).
//! On the coarsest graded layouts (2 divisions, grading > 1) almost every
//! surface node is a special point or capped, the target cannot be reached,
//! and the fit fails with [`MeshError::VolumeFit`].

use crate::cubed_octant::{OctantMesh, RayPlace};
use crate::{FaceKind, HexMesh, MeshError};

/// Relative volume error at which the fit stops.
const TARGET_TOLERANCE: f64 = 1e-13;

/// Largest relative volume error accepted when rounding stops the fit
/// before `TARGET_TOLERANCE` (the volume is a sum of up to ~10^5 element
/// volumes).
pub const EXACT_VOLUME_TOLERANCE: f64 = 1e-12;

/// Fraction of the way from the spheroid to the tangent plane at a special
/// point that a surface node may move (see [`tangent_allowance`]).
const TANGENT_FRACTION: f64 = 0.5;

/// Evaluations of the volume allowed to bracket the factor, and to refine it.
const MAX_DOUBLINGS: usize = 20;
const MAX_ITERATIONS: usize = 60;

/// Unit-sphere directions of the seven special points: the poles, the
/// diagonal point and the face-diagonal points.
const SPECIAL_DIRECTIONS: [[f64; 3]; 7] = {
    const D: f64 = 0.577_350_269_189_625_8; // 1 / sqrt 3
    const F: f64 = std::f64::consts::FRAC_1_SQRT_2;
    [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [D, D, D],
        [F, F, 0.0],
        [F, 0.0, F],
        [0.0, F, F],
    ]
};

/// The octant mesh with its curved-surface nodes moved outward so that its
/// volume is `pi a^2 c / 6` \[mm^3\] (see the module docs).
pub(crate) fn fit(octant: OctantMesh, a: f64, c: f64) -> Result<HexMesh, MeshError> {
    let OctantMesh {
        mesh,
        rays,
        special,
    } = octant;
    let target = std::f64::consts::PI * a * a * c / 6.0;
    let weights = surface_weights(&mesh, &special, a, c);
    let caps: Vec<f64> = mesh
        .nodes
        .iter()
        .zip(&weights)
        .map(|(&p, &w)| {
            if w > 0.0 {
                TANGENT_FRACTION * tangent_allowance(p, a, c)
            } else {
                0.0
            }
        })
        .collect();
    let mut scale = vec![0.0; mesh.nodes.len()];
    let mut trial = mesh.clone();
    let mut place = |lambda: f64, nodes: &mut [[f64; 3]]| {
        for ((e, &w), &cap) in scale.iter_mut().zip(&weights).zip(&caps) {
            *e = (lambda * w).min(cap);
        }
        for ((q, p), ray) in nodes.iter_mut().zip(&mesh.nodes).zip(&rays) {
            *q = match *ray {
                Some(RayPlace { surface, t }) => {
                    let (e, s) = (t * scale[surface], mesh.nodes[surface]);
                    std::array::from_fn(|r| p[r] + e * s[r])
                }
                None => *p,
            };
        }
    };
    let root = solve_increasing(|lambda| {
        place(lambda, &mut trial.nodes);
        trial.volume() / target - 1.0
    });
    match root {
        Ok(lambda) => {
            place(lambda, &mut trial.nodes);
            Ok(trial)
        }
        Err(best) => {
            place(best.x, &mut trial.nodes);
            Err(MeshError::VolumeFit {
                volume: trial.volume(),
                target,
                tolerance: EXACT_VOLUME_TOLERANCE,
            })
        }
    }
}

/// Per node, the mean relative sagitta `sigma_f = 1 - sqrt(L(c_f))` of the
/// curved facets around it; zero off the curved surface and at `special`.
fn surface_weights(mesh: &HexMesh, special: &[usize], a: f64, c: f64) -> Vec<f64> {
    let level = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1]) / (a * a) + p[2] * p[2] / (c * c);
    let mut sum = vec![0.0; mesh.nodes.len()];
    let mut count = vec![0u32; mesh.nodes.len()];
    for face in mesh.boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
        let centre: [f64; 3] = std::array::from_fn(|r| {
            0.25 * face.nodes.iter().map(|&k| mesh.nodes[k][r]).sum::<f64>()
        });
        let sagitta = 1.0 - level(centre).sqrt();
        for &k in &face.nodes {
            sum[k] += sagitta;
            count[k] += 1;
        }
    }
    let mut weights: Vec<f64> = sum
        .iter()
        .zip(&count)
        .map(|(&s, &n)| if n > 0 { s / f64::from(n) } else { 0.0 })
        .collect();
    for &k in special {
        weights[k] = 0.0;
    }
    weights
}

/// The relative radial scaling `e` that brings the surface point `p`
/// \[mm\] onto the nearest of the tangent planes at the seven special points
/// (`(1 + e) p` lies on it), or infinity when no plane is ahead of it.
///
/// In the unit-sphere coordinates `u = (x/a, y/a, z/c)` the tangent plane at
/// the special direction `s` is `u . s = 1`, and tangent planes map to
/// tangent planes under diag(a, a, c), so `e = 1 / (u . s) - 1`, about
/// `|u - s|^2 / 2` near `s`: quadratic in the distance, like the sagitta.
fn tangent_allowance(p: [f64; 3], a: f64, c: f64) -> f64 {
    let u = [p[0] / a, p[1] / a, p[2] / c];
    SPECIAL_DIRECTIONS
        .iter()
        .map(|s| u[0] * s[0] + u[1] * s[1] + u[2] * s[2])
        .filter(|&dot| dot > 0.0)
        .map(|dot| (1.0 / dot - 1.0).max(0.0))
        .fold(f64::INFINITY, f64::min)
}

/// The best point of a root search that did not reach its tolerance.
#[derive(Clone, Copy, Debug)]
struct Unconverged {
    x: f64,
}

/// Root `x >= 0` of `f`, increasing with `f(0) <= 0`, to
/// `|f(x)| <= TARGET_TOLERANCE`: bracket it by doubling from 1, then narrow
/// the bracket by the Illinois variant of regula falsi (a secant step through
/// the bracket ends, halving the retained end's value when the same end is
/// kept twice), which converges superlinearly and can never leave the
/// bracket. Accepts a point within [`EXACT_VOLUME_TOLERANCE`] when the
/// bracket collapses to rounding first.
fn solve_increasing(mut f: impl FnMut(f64) -> f64) -> Result<f64, Unconverged> {
    let (mut lo, mut f_lo) = (0.0, f(0.0));
    let mut best = (lo, f_lo);
    if f_lo.abs() <= TARGET_TOLERANCE {
        return Ok(lo);
    }
    if !(f_lo < 0.0) {
        return Err(Unconverged { x: lo });
    }
    let (mut hi, mut f_hi) = (1.0, f(1.0));
    let mut doublings = 0;
    while f_hi < 0.0 {
        (lo, f_lo) = (hi, f_hi);
        doublings += 1;
        if doublings > MAX_DOUBLINGS || !f_hi.is_finite() {
            return Err(Unconverged { x: lo });
        }
        hi *= 2.0;
        f_hi = f(hi);
    }
    if f_lo.abs() < best.1.abs() {
        best = (lo, f_lo);
    }
    if f_hi.abs() < best.1.abs() {
        best = (hi, f_hi);
    }
    if !f_hi.is_finite() {
        return Err(Unconverged { x: best.0 });
    }
    // Which end was replaced last: -1 the low end, +1 the high end.
    let mut side = 0;
    for _ in 0..MAX_ITERATIONS {
        if best.1.abs() <= TARGET_TOLERANCE {
            return Ok(best.0);
        }
        let x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        if !(x > lo && x < hi) {
            break;
        }
        let fx = f(x);
        if fx.abs() < best.1.abs() {
            best = (x, fx);
        }
        if fx < 0.0 {
            (lo, f_lo) = (x, fx);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, f_hi) = (x, fx);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    if best.1.abs() <= EXACT_VOLUME_TOLERANCE {
        Ok(best.0)
    } else {
        Err(Unconverged { x: best.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solver_finds_the_root_of_a_cubic() {
        // Shaped like V(lambda) / V* - 1: small negative at 0, root near 2/3.
        let f = |x: f64| -0.0075 + 0.011 * x + 1e-4 * x * x - 3e-6 * x * x * x;
        let mut calls = 0;
        let x = solve_increasing(|x| {
            calls += 1;
            f(x)
        })
        .map_err(|u| u.x)
        .unwrap_or(f64::NAN);
        assert!(f(x).abs() <= TARGET_TOLERANCE, "f({x}) = {}", f(x));
        assert!(calls <= 10, "{calls} evaluations");
    }

    #[test]
    fn solver_brackets_far_roots_and_reports_impossible_ones() {
        let x = solve_increasing(|x| x - 100.0)
            .map_err(|u| u.x)
            .unwrap_or(f64::NAN);
        assert!((x - 100.0).abs() < 1e-11, "{x}");
        // Already above the target at 0: no root in [0, inf) for an increasing f.
        assert!(solve_increasing(|x| x + 1.0).is_err());
        // Never reaches the target.
        assert!(solve_increasing(|_| -1.0).is_err());
    }
}
