//! The weight of a contact term across a fold between two flat facets (see
//! [`crate::FULL_FOLD`]) and what its dependence on the facets' corners
//! adds to the term's force and tangent.
//!
//! The weight `w` is a smooth step of the fold's sine, the sine of the
//! angle between the two triangles' normals, and, for triangles that
//! share one corner only, of each far corner's elevation above the other
//! triangle's plane (see [`weight_of`]). The term's energy is
//! `a w phi(g)`, `phi = max(lambda + eps g, 0)^2 / (2 eps)` the augmented
//! Lagrangian's (`g` the node's penetration of the neighbour's plane, `a`
//! its tributary area, `eps` the penalty \[MPa/mm\], `lambda` the
//! multiplier \[MPa\], `phi' = max(lambda + eps g, 0)` the pressure):
//!
//! - force `a w phi' grad g + a phi grad w`;
//! - tangent `a w (eps grad g grad g^T + phi' grad^2 g)
//!   + a phi' (grad g grad w^T + grad w grad g^T) + a phi grad^2 w`.
//!
//! The first parts are the plain term's, scaled by `w`; this module adds
//! the rest. The solver's tangent leaves out `grad^2 g` (see
//! [`crate::ContactSettings::curvature_stiffness`]) and keeps the positive
//! semi-definite part of `a phi grad^2 w` (its eigenvalues below zero set
//! to zero, over the corners' dofs), and then of the term's whole tangent:
//! the coupling `a phi' (grad g grad w^T + grad w grad g^T)` is indefinite
//! too. With the coupling kept whole, 20 of the 49 factorisations of the
//! 32 spheres' study run from its step-200 checkpoint (level 1, rho =
//! 0.818) were indefinite (LBL^T), and there the line search took the
//! full Newton step in 7 of 20 iterations (median 0.13 of it), against
//! 21 of 29 after a Cholesky factorisation; the run took 79 Newton
//! iterations to t = 83.0 s and 103 to t = 88.2 s. With the whole term's
//! positive part, none of the next 64 factorisations was indefinite, and
//! it took 49 iterations to t = 83.1 s and 64 to t = 86.9 s; the octant
//! cells at 15 MPa to rho = 0.9 (level 1) took bcc 346, fcc 225, sc2 371
//! and sc 259 iterations against 351, 223, 381 and 259, t(0.9) within
//! 0.05 %. (The whole sphere in a periodic cube failed with it until the
//! weight of a pair sharing a corner took its far corners' elevations,
//! see [`weight_of`].) Where a fold is slight the weight is
//! small, the node presses far into the neighbour's plane before the term
//! holds it, and `phi`, which grows with the square of the pressure before
//! the weight, makes `a phi grad^2 w` the term's largest part: in a random
//! packing of 32 spheres (level 1, rho = 0.675), terms of weights 1e-3 to
//! 4e-2 pressed at about 2e3 MPa before the weight, and without `grad^2 w`
//! the change of such a term's force on a corner along Newton's direction
//! was of the opposite sign to the tangent's prediction and up to 50 times
//! as large: the line search cut step after step to a tenth. All of `a phi
//! grad^2 w` (indefinite) served the random packing as well, but the whole
//! sphere in a periodic cube (level 1, to rho = 0.8) took 1194 Newton
//! iterations and 22 failed attempts, against 922 and 3 without it and
//! 719 and 10 with its positive part.
//! The derivatives of the weight are taken by automatic differentiation
//! (`num-dual`), over the six corners of the two triangles.

use nalgebra::{DMatrix, SVector};
use num_dual::{Dual2SVec64, DualNum, DualSVec64};

use crate::{ContactTerm, FULL_FOLD, TERM_DOFS};

/// Coordinates the weight depends on: three corners of each triangle (a
/// corner the two share appears twice).
const CORNER_DOFS: usize = 18;

/// The smooth step `35 t^4 - 84 t^5 + 70 t^6 - 20 t^7` of `t = sine /
/// FULL_FOLD`, one from `t = 1` on: its first three derivatives vanish at
/// both ends. At a flat fold, where round-off decides whether the two
/// facets form a valley (with a term) or a ridge (without), the term's
/// force `a phi grad w` then grows with the cube of the fold and is twice
/// differentiable: with the step of degree five (`10 t^3 - 15 t^4 + 6
/// t^5`) it grew with the square, and central differences of the force
/// across a flat fold of two patches pressed 0.06 mm into each other
/// (penalty 100 MPa/mm) read a derivative of 8.6e-5 N/mm where it is 0.
fn step<D: DualNum<Primitive = f64> + Copy>(sine: D) -> D {
    let t = sine / FULL_FOLD;
    if t.re() >= 1.0 {
        return D::one();
    }
    let t2 = t * t;
    t2 * t2 * (t * (t * (t * -20.0 + 70.0) - 84.0) + 35.0)
}

/// The place of the one corner two triangles share in each (the first's
/// three corners, the second's), if they share exactly one: a pair
/// sharing an edge has none.
fn shared_corner(nodes: &[usize; 6]) -> Option<[usize; 2]> {
    let mut shared = (0..3).filter_map(|i| Some([i, (3..6).find(|&j| nodes[j] == nodes[i])? - 3]));
    let one = shared.next()?;
    shared.next().is_none().then_some(one)
}

/// The weight of the fold between the triangles of corners `nodes` at
/// `corners` \[mm\] (the first's three, then the second's).
pub(crate) fn weight(nodes: [usize; 6], corners: [[f64; 3]; 6]) -> f64 {
    let w = SVector::<f64, CORNER_DOFS>::from_fn(|k, _| corners[k / 3][k % 3]);
    weight_of(&w, shared_corner(&nodes))
}

fn sub<D: DualNum<Primitive = f64> + Copy>(a: &[D; 3], b: &[D; 3]) -> [D; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross<D: DualNum<Primitive = f64> + Copy>(a: &[D; 3], b: &[D; 3]) -> [D; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot<D: DualNum<Primitive = f64> + Copy>(a: &[D; 3], b: &[D; 3]) -> D {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The weight as a function of the corners `w` (the first triangle's
/// three, then the second's, xyz each), for any `num-dual` scalar, the
/// triangles sharing the corner of places `vertex` (see
/// [`shared_corner`]) or an edge (None).
///
/// Two triangles that share an edge turn from a valley (a term) into a
/// ridge (none) only through a flat fold, where the step of the sine
/// has taken the weight to zero. Two that share a corner only can stop
/// being a valley at any fold: where a far corner of one passes through
/// the other's plane. The step of each far corner's elevation above the
/// other's plane (the sine of the angle at the shared corner, over
/// [`FULL_FOLD`]) takes such a weight to zero there too. Without it, on
/// a whole sphere in a periodic cube (level 1, t = 38.8 s, with the
/// fold terms' tangents made positive semi-definite), a term of weight
/// 0.08 pressing at 390 MPa before the weight vanished at the full
/// Newton step, where a far corner went from 6.2e-7 mm outside its
/// neighbour's plane to 1.2e-7 mm inside: the full step's residual was
/// four times the iterate's, the line search took a tenth of every
/// direction, and the step failed at every length down to 8e-15 s.
fn weight_of<D: DualNum<Primitive = f64> + Copy>(
    w: &SVector<D, CORNER_DOFS>,
    vertex: Option<[usize; 2]>,
) -> D {
    let corner = |a: usize| [w[3 * a], w[3 * a + 1], w[3 * a + 2]];
    let normal = |a: usize| unit_normal(&[corner(a), corner(a + 1), corner(a + 2)]);
    let (n1, n2) = (normal(0), normal(3));
    let c = cross(&n1, &n2);
    let mut weight = step(dot(&c, &c).sqrt());
    if let Some([i, j]) = vertex {
        let origin = corner(i);
        let elevation = |a: usize, n: &[D; 3]| {
            let d = sub(&corner(a), &origin);
            let e = dot(&d, n) / dot(&d, &d).sqrt();
            if e.re() > 0.0 { step(e) } else { D::zero() }
        };
        for a in (0..3).filter(|&a| a != i) {
            weight *= elevation(a, &n2);
        }
        for b in (0..3).filter(|&b| b != j) {
            weight *= elevation(3 + b, &n1);
        }
    }
    weight
}

/// The unit normal of the flat triangle of the first three corners of `q`
/// (right-handed), for any `num-dual` scalar.
pub(crate) fn unit_normal<D: DualNum<Primitive = f64> + Copy>(q: &[[D; 3]]) -> [D; 3] {
    let c = cross(&sub(&q[1], &q[0]), &sub(&q[2], &q[0]));
    let l = dot(&c, &c).sqrt();
    c.map(|v| v / l)
}

/// The weight of a term across a fold with its gradient \[1/mm\] and, if
/// asked, its Hessian \[1/mm^2\], over the two triangles' corners.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FoldWeight {
    /// The corners' nodes: the first triangle's three, then the second's.
    nodes: [usize; 6],
    gradient: [f64; CORNER_DOFS],
    hessian: Option<Box<[[f64; CORNER_DOFS]; CORNER_DOFS]>>,
}

impl FoldWeight {
    /// The weight's derivatives with the corners `nodes` at `corners`
    /// \[mm\], and its Hessian if `hessian`.
    pub(crate) fn at(nodes: [usize; 6], corners: [[f64; 3]; 6], hessian: bool) -> Self {
        let w = SVector::<f64, CORNER_DOFS>::from_fn(|k, _| corners[k / 3][k % 3]);
        let vertex = shared_corner(&nodes);
        if hessian {
            let (_, g, h) = num_dual::hessian(
                |v: SVector<Dual2SVec64<CORNER_DOFS>, CORNER_DOFS>| weight_of(&v, vertex),
                &w,
            );
            Self {
                nodes,
                gradient: g.into(),
                hessian: Some(Box::new(std::array::from_fn(|i| {
                    std::array::from_fn(|j| h[(i, j)])
                }))),
            }
        } else {
            let (_, g) = num_dual::gradient(
                |v: SVector<DualSVec64<CORNER_DOFS>, CORNER_DOFS>| weight_of(&v, vertex),
                &w,
            );
            Self {
                nodes,
                gradient: g.into(),
                hessian: None,
            }
        }
    }

    /// Adds to `term`, a term across the fold of this weight whose slave
    /// node has tributary area `area` \[mm^2\] and presses at `pressure`
    /// \[MPa\] before the weight (`phi'`), with penalty `eps` \[MPa/mm\]:
    /// the force `a phi grad w` and, if the term has a tangent, `a phi'
    /// (grad g grad w^T + grad w grad g^T)` (`grad g` the penetration's
    /// gradient `grad` over the term's first [`TERM_DOFS`] dofs) and, with
    /// the Hessian, `a phi grad^2 w`: all of it if `consistent`, else the
    /// positive semi-definite part of the term's whole tangent, that of
    /// `a phi grad^2 w` first (module docs). The corners that are not
    /// among the term's nodes are appended to its dofs.
    pub(crate) fn add_to(
        &self,
        term: &mut ContactTerm,
        grad: &[f64; TERM_DOFS],
        area: f64,
        pressure: f64,
        eps: f64,
        consistent: bool,
    ) {
        let mut nodes: Vec<usize> = term.dofs.iter().step_by(3).map(|d| d / 3).collect();
        // Each corner's place among the term's nodes: the first slot of
        // its node (a triangle's fourth slot repeats its third corner, with
        // a zero gradient).
        let place = self
            .nodes
            .map(|node| match nodes.iter().position(|&m| m == node) {
                Some(at) => at,
                None => {
                    nodes.push(node);
                    nodes.len() - 1
                }
            });
        let n = 3 * nodes.len();
        let mut dw = vec![0.0; n];
        for (c, &at) in place.iter().enumerate() {
            for i in 0..3 {
                dw[3 * at + i] += self.gradient[3 * c + i];
            }
        }
        let phi = area * pressure * pressure / (2.0 * eps);
        let pressed = area * pressure;
        term.dofs = nodes
            .iter()
            .flat_map(|&m| [3 * m, 3 * m + 1, 3 * m + 2])
            .collect();
        term.force.resize(n, 0.0);
        for (f, d) in term.force.iter_mut().zip(&dw) {
            *f += phi * d;
        }
        if term.tangent.is_empty() {
            return;
        }
        let mut k = vec![0.0; n * n];
        for (i, row) in term.tangent.chunks(TERM_DOFS).enumerate() {
            k[i * n..i * n + TERM_DOFS].copy_from_slice(row);
        }
        let dg: Vec<f64> = grad
            .iter()
            .copied()
            .chain(std::iter::repeat(0.0))
            .take(n)
            .collect();
        for i in 0..n {
            for j in 0..n {
                k[i * n + j] += pressed * (dg[i] * dw[j] + dw[i] * dg[j]);
            }
        }
        if let Some(h) = &self.hessian {
            // `a phi grad^2 w` over the term's nodes that are corners (a
            // corner two triangles share sums its two entries).
            let mut corners: Vec<usize> = place.to_vec();
            corners.sort_unstable();
            corners.dedup();
            // (`corners` holds every place: the search always finds it.)
            let slot = |at: usize| corners.binary_search(&at).unwrap_or(0);
            let m = 3 * corners.len();
            let mut hw = DMatrix::<f64>::zeros(m, m);
            for (a, &pa) in place.iter().enumerate() {
                for (b, &pb) in place.iter().enumerate() {
                    for i in 0..3 {
                        for j in 0..3 {
                            hw[(3 * slot(pa) + i, 3 * slot(pb) + j)] +=
                                phi * h[3 * a + i][3 * b + j];
                        }
                    }
                }
            }
            if !consistent {
                hw = positive_part(hw);
            }
            for (r, &pr) in corners.iter().enumerate() {
                for (c, &pc) in corners.iter().enumerate() {
                    for i in 0..3 {
                        for j in 0..3 {
                            k[(3 * pr + i) * n + 3 * pc + j] += hw[(3 * r + i, 3 * c + j)];
                        }
                    }
                }
            }
        }
        if !consistent {
            // The coupling `a phi' (grad g grad w^T + grad w grad g^T)` is
            // indefinite whatever the weight's Hessian: the solver's
            // tangent keeps the term's positive semi-definite part.
            let m = positive_part(DMatrix::from_row_slice(n, n, &k));
            for i in 0..n {
                for j in 0..n {
                    k[i * n + j] = 0.5 * (m[(i, j)] + m[(j, i)]);
                }
            }
        }
        term.tangent = k;
    }
}

/// The positive semi-definite part of the symmetric `m`: its eigenvalues
/// below zero set to zero.
fn positive_part(m: DMatrix<f64>) -> DMatrix<f64> {
    let e = m.symmetric_eigen();
    let kept = e.eigenvalues.map(|v| v.max(0.0));
    &e.eigenvectors * DMatrix::from_diagonal(&kept) * e.eigenvectors.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The positive part of diag(3, -2, 0) turned by a rotation is 3 v v^T,
    /// `v` the turned first axis.
    #[test]
    fn the_positive_part_drops_the_negative_eigenvalues() {
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
        let m = r
            * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(3.0, -2.0, 0.0))
            * r.transpose();
        let v = r.column(0);
        let expected = v * v.transpose() * 3.0;
        let got = positive_part(DMatrix::from_iterator(3, 3, m.iter().copied()));
        for i in 0..3 {
            for j in 0..3 {
                assert!((got[(i, j)] - expected[(i, j)]).abs() < 1e-12, "{got}");
            }
        }
    }

    /// The weight of triangles of corners `nodes` at `c`.
    fn w(nodes: [usize; 6], c: &[[f64; 3]; 6]) -> f64 {
        weight(nodes, *c)
    }

    /// Asserts that the weight's gradient and Hessian from dual numbers
    /// equal central differences of the weight and of the gradient (to
    /// 1e-6 of their largest entries) for the triangles of corners `nodes`
    /// at `corners`.
    fn assert_derivatives(nodes: [usize; 6], corners: [[f64; 3]; 6]) {
        let at = FoldWeight::at(nodes, corners, true);
        let h = at.hessian.as_ref().unwrap();
        let d = 1e-6;
        let (mut worst_g, mut worst_h) = (0.0_f64, 0.0_f64);
        for k in 0..CORNER_DOFS {
            let (mut p, mut m) = (corners, corners);
            p[k / 3][k % 3] += d;
            m[k / 3][k % 3] -= d;
            worst_g =
                worst_g.max(((w(nodes, &p) - w(nodes, &m)) / (2.0 * d) - at.gradient[k]).abs());
            let (gp, gm) = (
                FoldWeight::at(nodes, p, false),
                FoldWeight::at(nodes, m, false),
            );
            for i in 0..CORNER_DOFS {
                worst_h =
                    worst_h.max(((gp.gradient[i] - gm.gradient[i]) / (2.0 * d) - h[i][k]).abs());
            }
        }
        let scale_g = at.gradient.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let scale_h = h.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(scale_g > 0.0 && scale_h > 0.0);
        assert!(worst_g < 1e-6 * scale_g, "{worst_g} of {scale_g}");
        assert!(worst_h < 1e-6 * scale_h, "{worst_h} of {scale_h}");
    }

    /// The step of `t` computed directly.
    fn step_of(t: f64) -> f64 {
        t.powi(4) * (35.0 - 84.0 * t + 70.0 * t * t - 20.0 * t.powi(3))
    }

    /// At a fold of half `FULL_FOLD` between two triangles sharing an
    /// edge, the weight is the step of the sine computed directly, and its
    /// derivatives from dual numbers are its differences'.
    #[test]
    fn the_weights_derivatives_are_those_of_the_weight() {
        let rise = 0.25 * FULL_FOLD / 2f64.sqrt();
        let q = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, rise],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, rise],
        ];
        let nodes = [0, 1, 2, 0, 2, 3];
        let corners = [q[0], q[1], q[2], q[0], q[2], q[3]];
        // Each triangle's normal is (-+rise, +-rise, 1) over its length.
        let sine = 2.0 * 2f64.sqrt() * rise / (1.0 + 2.0 * rise * rise);
        let expected = step_of(sine / FULL_FOLD);
        let got = w(nodes, &corners);
        assert!((got - expected).abs() < 1e-12, "{got} against {expected}");
        assert!(expected > 0.1 && expected < 0.9, "{expected}");
        assert_derivatives(nodes, corners);
    }

    /// Two triangles sharing only a corner, the first in the plane z = 0
    /// (normal +z), the second rising from it at slope `s` away from it
    /// (in -x), but for its far corner `b1`, at height `z1`.
    fn corner_pair(s: f64, z1: f64) -> [[f64; 3]; 6] {
        let o = [0.0, 0.0, 0.0];
        [
            o,
            [1.0, -0.5, 0.0],
            [1.0, 0.2, 0.0],
            o,
            [-0.5, 0.8, 0.5 * s],
            [-1.0, -0.3, z1],
        ]
    }

    /// Two triangles sharing a corner form a valley only while each one's
    /// far corners lie outside the other's plane. Well up (elevations of
    /// `FULL_FOLD` and more, at a fold of three times it) the weight is
    /// one, as a pair sharing an edge has it. As a far corner comes down
    /// onto the other's plane, the weight goes to zero with the fourth
    /// power of its elevation (the step's). Its derivatives are its
    /// differences' on the way down.
    #[test]
    fn a_corner_pairs_weight_vanishes_as_a_far_corner_reaches_the_other_plane() {
        let nodes = [0, 1, 2, 0, 3, 4];
        let s = 3.0 * FULL_FOLD;
        let up = corner_pair(s, s);
        assert!((w(nodes, &up) - 1.0).abs() < 1e-12, "{}", w(nodes, &up));
        let b1 = 1.09f64.sqrt();
        let at = |e: f64| w(nodes, &corner_pair(s, e * FULL_FOLD * b1));
        for e in [1e-3, 1e-4, 1e-5] {
            let ratio = at(0.1 * e) / at(e);
            assert!(
                (ratio / 1e-4 - 1.0).abs() < 0.05,
                "elevation {e}: ratio {ratio}"
            );
        }
        assert!(at(1e-6) < 1e-20 && at(1e-6) > 0.0, "{}", at(1e-6));
        assert_derivatives(nodes, corner_pair(s, 0.5 * FULL_FOLD * b1));
    }
}
