//! The mortar contact's force is the gradient of its energy and its
//! tangent the energy's Hessian, against central differences.
//!
//! The scene: two curved, non-matching patches pressed into each other, a
//! lower dome (4 x 4 cells on the unit square, bulging up) and an upper
//! one (3 x 3 cells, 0.9 mm a side, turned by 0.3 rad and off the lower
//! one's centre, bulging down), their tops 0.025 mm into each other: near
//! the tops the nodes of both surfaces press (9 of about 40 nodes with a
//! term), further out they are open; each surface is the slave of one
//! pass and the master of the other. Meshed with bilinear quads, with the
//! quads split into flat triangles (`from_quads_as_triangles`, as the
//! solver's hexahedral meshes are) and with triangles (diagonals
//! alternating like a chessboard).
//!
//! The contact is paired once, in the unperturbed configuration, as the
//! solver does at a step's start: the candidate pairs, the test functions
//! and the areas `A_j` stay as they were under the perturbations, which
//! is what makes the force the exact gradient of the energy `sum_j w A_j
//! / (2 eps) <lambda_j + eps p_hat_j>^2` and the consistent tangent its
//! Hessian. Each check runs without multipliers and after one Uzawa
//! update (every pressed node's multiplier its pressure), with standard
//! test functions (the solver's); the consistent tangent also with dual
//! ones.
//!
//! - With its curvature part (`curvature_stiffness: true`), the tangent
//!   assembled over the terms equals central differences of the total
//!   force (the terms' forces summed by dof), column by column, to 1e-8
//!   of its largest entry (measured: 2e-11 with standard test functions,
//!   1.1e-9 with dual ones on quads, where the differences' own error,
//!   proportional to `h^2`, is the larger); it is symmetric.
//! - Without it (`false`, the solver's choice) the tangent is the same
//!   differences less the curvature part `-w p_j d2g_j/du2`, computed here
//!   from the public kernels (`weighted_gaps_of` with
//!   [`Derivatives::Hessian`] on the candidate pairs and test functions
//!   that `pair` made): the Gauss-Newton part is exact, to 1e-8 (measured
//!   2e-11). It is symmetric positive semi-definite; the part it leaves
//!   out is indefinite, its eigenvalues 2 to 7 % of the tangent's
//!   largest (so a tangent without it, or with it of the wrong sign,
//!   fails the first check).
//! - The total force equals central differences of
//!   [`MortarContact::energy`], to 1e-9 of its largest entry (measured
//!   2e-11).
//!
//! Differences across a change of the active set are not derivatives. The
//! scene keeps every node with a term at least 9.8e-4 mm of penetration
//! from closing or opening (a pressure argument `lambda_j + eps p_hat_j`
//! at least 0.098 MPa from zero), while the step `h = 1e-6` mm moves a
//! node's `p_hat_j = -g_j / A_j` by about `h` (0.0001 MPa); every
//! perturbed evaluation is checked to press the same nodes. The step is
//! where the differences' truncation error (`h^2`) meets their round-off
//! (`1/h`): at 1e-5 and 1e-7 mm the consistent tangent on quads is off
//! by 1.4e-9 and 5.9e-11.

#[path = "support/mortar_meshes.rs"]
mod meshes;

use std::collections::{BTreeMap, BTreeSet};

use meshes::{chessboard, grid};
use nalgebra::DMatrix;
use tidens_contact::mortar::{
    Derivatives, MortarContact, SurfaceTestFunctions, TestBasis, WeightedGap, candidate_pairs,
    weighted_gaps_of,
};
use tidens_contact::{ContactEvaluation, ContactMode, ContactSettings, ContactSurface};

const PENALTY: f64 = 100.0;
const SEARCH: f64 = 0.3;
/// The weight `w` of each of the two passes (the module's own constant).
const PASS_WEIGHT: f64 = 0.5;
/// The finite-difference step \[mm\] (the patches are about 1 mm wide).
const H: f64 = 1e-6;
/// How far the domes' tops pass each other \[mm\].
const OVERLAP: f64 = 0.025;

#[derive(Clone, Copy, Debug)]
enum Mesh {
    Quads,
    QuadsAsTriangles,
    Triangles,
}

const MESHES: [Mesh; 3] = [Mesh::Quads, Mesh::QuadsAsTriangles, Mesh::Triangles];

/// The meshes the second derivatives are checked on: the solver's (its
/// hexahedra's faces as triangles, the tetrahedra's triangles); on
/// bilinear quads the dual-number Hessian takes 1.5 s a scene.
const TRIANGLE_MESHES: [Mesh; 2] = [Mesh::QuadsAsTriangles, Mesh::Triangles];

fn surface(quads: &[[usize; 4]], n: usize, nodes: &[[f64; 3]], mesh: Mesh) -> ContactSurface {
    match mesh {
        Mesh::Quads => ContactSurface::from_quads(quads, nodes).unwrap(),
        Mesh::QuadsAsTriangles => ContactSurface::from_quads_as_triangles(quads, nodes).unwrap(),
        Mesh::Triangles => ContactSurface::from_triangles(&chessboard(quads, n), nodes).unwrap(),
    }
}

/// The two domes of the module docs: their nodes and surfaces (lower,
/// upper).
fn scene(mesh: Mesh) -> (Vec<[f64; 3]>, Vec<ContactSurface>) {
    let mut nodes = Vec::new();
    let lower = grid(
        &mut nodes,
        4,
        4,
        |u, v| {
            let (x, y) = (u - 0.5, v - 0.5);
            [x, y, -0.1 * (x * x + y * y)]
        },
        false,
    );
    let (turn, side, centre) = (0.3_f64, 0.9, [0.07, -0.05]);
    let (a, b) = (
        [side * turn.cos(), side * turn.sin()],
        [-side * turn.sin(), side * turn.cos()],
    );
    let upper = grid(
        &mut nodes,
        3,
        3,
        |u, v| {
            let (s, t) = (u - 0.5, v - 0.5);
            let (x, y) = (s * a[0] + t * b[0], s * a[1] + t * b[1]);
            [
                centre[0] + x,
                centre[1] + y,
                -OVERLAP + 0.08 * (x * x + y * y),
            ]
        },
        true,
    );
    let surfaces = vec![
        surface(&lower, 4, &nodes, mesh),
        surface(&upper, 3, &nodes, mesh),
    ];
    (nodes, surfaces)
}

/// Mortar contact on the scene, paired at its nodes; with `augmented`,
/// after one Uzawa update there.
fn contact(
    mesh: Mesh,
    basis: TestBasis,
    curvature: bool,
    augmented: bool,
) -> (MortarContact, Vec<f64>) {
    let (nodes, surfaces) = scene(mesh);
    let settings = ContactSettings {
        mode: ContactMode::Frictionless,
        penalty: PENALTY,
        search_distance: SEARCH,
        curvature_stiffness: curvature,
        touch_stiffness_cap: f64::INFINITY,
    };
    let mut c = MortarContact::new(surfaces, settings, basis).unwrap();
    let x: Vec<f64> = nodes.iter().flatten().copied().collect();
    c.pair(&x);
    if augmented {
        let eval = c.evaluate(&x, false);
        c.augment(&eval);
    }
    (c, x)
}

fn total_force(eval: &ContactEvaluation, n: usize) -> Vec<f64> {
    let mut f = vec![0.0; n];
    for t in &eval.terms {
        for (&d, &v) in t.dofs.iter().zip(&t.force) {
            f[d] += v;
        }
    }
    f
}

/// The terms' tangents summed by dof, `n x n` row-major.
fn assembled(eval: &ContactEvaluation, n: usize) -> Vec<f64> {
    let mut k = vec![0.0; n * n];
    for t in &eval.terms {
        let m = t.dofs.len();
        assert_eq!((t.force.len(), t.tangent.len()), (m, m * m));
        for p in 0..m {
            for q in 0..m {
                k[t.dofs[p] * n + t.dofs[q]] += t.tangent[p * m + q];
            }
        }
    }
    k
}

/// The pressed (slave surface, node index, master surface).
fn pressed(eval: &ContactEvaluation) -> BTreeSet<(usize, usize, usize)> {
    eval.terms
        .iter()
        .filter(|t| t.pressure > 0.0)
        .map(|t| (t.slave.0, t.slave.1, t.master.0))
        .collect()
}

/// Central differences of the total force, `K[i n + j] = df_i/dx_j`;
/// every perturbed evaluation presses the nodes `active`.
fn differences(c: &MortarContact, x: &[f64], active: &BTreeSet<(usize, usize, usize)>) -> Vec<f64> {
    let n = x.len();
    let mut k = vec![0.0; n * n];
    for j in 0..n {
        let mut f = [Vec::new(), Vec::new()];
        for (side, e) in [H, -H].into_iter().enumerate() {
            let mut xs = x.to_vec();
            xs[j] += e;
            let eval = c.evaluate(&xs, false);
            assert_eq!(
                &pressed(&eval),
                active,
                "dof {j} moved by {e}: the active set changes"
            );
            f[side] = total_force(&eval, n);
        }
        for i in 0..n {
            k[i * n + j] = (f[0][i] - f[1][i]) / (2.0 * H);
        }
    }
    k
}

/// The curvature part `-w p_j d2g_j/du2` of the pressed terms of `eval`,
/// from the public kernels on the candidate pairs and test functions that
/// `pair` made at `x` (`n x n` row-major).
fn curvature_part(
    c: &MortarContact,
    x: &[f64],
    basis: TestBasis,
    eval: &ContactEvaluation,
) -> Vec<f64> {
    let n = x.len();
    let points: Vec<[f64; 3]> = x.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let surfaces = c.surfaces();
    let terms: Vec<_> = eval.terms.iter().filter(|t| t.pressure > 0.0).collect();
    let mut k = vec![0.0; n * n];
    for (s, m) in [(0, 1), (1, 0)] {
        let nodes: BTreeSet<usize> = terms
            .iter()
            .filter(|t| (t.slave.0, t.master.0) == (s, m))
            .map(|t| surfaces[s].nodes[t.slave.1])
            .collect();
        // The pairs that bring anything to these nodes' gaps (the
        // Hessians of the others' would take seconds).
        let pairs: Vec<(usize, usize)> =
            candidate_pairs(&surfaces[s], &surfaces[m], &points, SEARCH)
                .into_iter()
                .filter(|&(sf, _)| surfaces[s].facets[sf].iter().any(|v| nodes.contains(v)))
                .collect();
        let test = SurfaceTestFunctions::new(&surfaces[s], &points, basis);
        let gaps: BTreeMap<usize, WeightedGap> = weighted_gaps_of(
            &surfaces[s],
            &surfaces[m],
            &points,
            &pairs,
            &test,
            Derivatives::Hessian,
            &nodes,
        )
        .unwrap()
        .into_iter()
        .map(|g| (g.node, g))
        .collect();
        for t in terms.iter().filter(|t| (t.slave.0, t.master.0) == (s, m)) {
            let h = gaps[&surfaces[s].nodes[t.slave.1]]
                .hessian
                .as_ref()
                .unwrap();
            let size = h.dofs.len();
            for a in 0..size {
                for b in 0..size {
                    k[h.dofs[a] * n + h.dofs[b]] -=
                        PASS_WEIGHT * t.pressure * h.values[a * size + b];
                }
            }
        }
    }
    k
}

fn largest(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
}

/// The largest `|a - b|` entry.
fn off(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

fn asymmetry(k: &[f64], n: usize) -> f64 {
    let mut worst = 0.0_f64;
    for i in 0..n {
        for j in 0..i {
            worst = worst.max((k[i * n + j] - k[j * n + i]).abs());
        }
    }
    worst
}

/// The lowest and highest eigenvalues of the symmetric `k`.
fn eigen_range(k: &[f64], n: usize) -> (f64, f64) {
    let e = DMatrix::from_row_slice(n, n, k)
        .symmetric_eigen()
        .eigenvalues;
    (e.min(), e.max())
}

/// The scene's evaluation: some nodes of each pass press and some do not,
/// and every term's penetration stays clear of zero (module docs).
fn check_scene(eval: &ContactEvaluation) -> BTreeSet<(usize, usize, usize)> {
    let active = pressed(eval);
    for pass in [(0, 1), (1, 0)] {
        let of = |p: bool| {
            eval.terms
                .iter()
                .filter(|t| (t.slave.0, t.master.0) == pass && (t.pressure > 0.0) == p)
                .count()
        };
        assert!(
            of(true) >= 3 && of(false) >= 3,
            "pass {pass:?}: {} pressed, {} open",
            of(true),
            of(false)
        );
    }
    let margin = eval
        .terms
        .iter()
        .fold(f64::INFINITY, |m, t| m.min(t.penetration.abs()));
    assert!(margin > 5e2 * H, "a penetration of {margin:e} mm");
    active
}

#[test]
fn the_consistent_tangent_is_the_derivative_of_the_force() {
    for mesh in TRIANGLE_MESHES {
        for (basis, augmented) in [
            (TestBasis::Standard, false),
            (TestBasis::Standard, true),
            (TestBasis::Dual, false),
        ] {
            let (c, x) = contact(mesh, basis, true, augmented);
            let n = x.len();
            let eval = c.evaluate(&x, true);
            let active = check_scene(&eval);
            let k = assembled(&eval, n);
            let fd = differences(&c, &x, &active);
            let (scale, error) = (largest(&k), off(&k, &fd));
            println!(
                "{mesh:?}, {basis:?}, multipliers {augmented}: {} pressed of {} terms; consistent tangent off its differences by {:.1e} of its largest entry {scale:.3e} N/mm; asymmetry {:.1e}",
                active.len(),
                eval.terms.len(),
                error / scale,
                asymmetry(&k, n) / scale
            );
            assert!(
                error < 1e-8 * scale,
                "{mesh:?}: off by {error:e} of {scale:e}"
            );
            assert!(asymmetry(&k, n) < 1e-12 * scale);
        }
    }
}

#[test]
fn without_curvature_the_tangent_is_the_exact_gauss_newton_part_and_semidefinite() {
    for mesh in TRIANGLE_MESHES {
        for augmented in [false, true] {
            let basis = TestBasis::Standard;
            let (c, x) = contact(mesh, basis, false, augmented);
            let n = x.len();
            let eval = c.evaluate(&x, true);
            let active = check_scene(&eval);
            // The forces do not depend on the tangent.
            let (full, _) = contact(mesh, basis, true, augmented);
            assert_eq!(
                total_force(&full.evaluate(&x, true), n),
                total_force(&eval, n)
            );
            let k = assembled(&eval, n);
            let curvature = curvature_part(&c, &x, basis, &eval);
            let fd = differences(&c, &x, &active);
            let rest: Vec<f64> = fd.iter().zip(&curvature).map(|(a, b)| a - b).collect();
            let (scale, error) = (largest(&k), off(&k, &rest));
            let (lowest, highest) = eigen_range(&k, n);
            let (left_low, left_high) = eigen_range(&curvature, n);
            println!(
                "{mesh:?}, multipliers {augmented}: Gauss-Newton tangent off the differences less the curvature part by {:.1e} of its largest entry {scale:.3e} N/mm; eigenvalues {lowest:.1e} to {highest:.3e}; the curvature part's {left_low:.2e} to {left_high:.2e}",
                error / scale
            );
            assert!(
                error < 1e-8 * scale,
                "{mesh:?}: off by {error:e} of {scale:e}"
            );
            assert!(asymmetry(&k, n) < 1e-12 * scale);
            assert!(lowest > -1e-12 * highest, "{mesh:?}: eigenvalue {lowest:e}");
            assert!(left_low < -1e-3 * highest && left_high > 1e-3 * highest);
        }
    }
}

#[test]
fn the_force_is_the_gradient_of_the_energy() {
    for mesh in MESHES {
        for augmented in [false, true] {
            let (c, x) = contact(mesh, TestBasis::Standard, false, augmented);
            let n = x.len();
            let eval = c.evaluate(&x, false);
            check_scene(&eval);
            let f = total_force(&eval, n);
            let fd: Vec<f64> = (0..n)
                .map(|j| {
                    let (mut xp, mut xm) = (x.clone(), x.clone());
                    xp[j] += H;
                    xm[j] -= H;
                    (c.energy(&xp) - c.energy(&xm)) / (2.0 * H)
                })
                .collect();
            let (scale, error) = (largest(&f), off(&f, &fd));
            println!(
                "{mesh:?}, multipliers {augmented}: energy {:.4e} N mm; force off its differences by {:.1e} of its largest entry {scale:.3e} N",
                c.energy(&x),
                error / scale
            );
            assert!(
                error < 1e-9 * scale,
                "{mesh:?}: off by {error:e} of {scale:e}"
            );
        }
    }
}
