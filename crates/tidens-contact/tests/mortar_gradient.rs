//! The exact derivatives of the weighted gaps against central
//! differences: a warped slave grid (3 x 3 quads, every node moved at
//! random by up to a tenth of a cell in each direction, or the quads'
//! triangles) under a warped, turned master grid (4 x 4) that presses
//! into it in places and stands off elsewhere. The pairs and the dual
//! functions' coefficients are those of the unperturbed configuration.
//!
//! - gradient: `(g_j(x + h d) - g_j(x - h d)) / 2h` against `grad g_j . d`
//!   for random directions `d` moving every node, rel. 1e-7;
//! - with the master's facets continued past its open edges, the same;
//! - Hessian: `(grad g_j(x + h d) - grad g_j(x - h d)) / 2h` against
//!   `H_j d`, rel. 1e-6; `H_j` symmetric, its gradient the gradient path's.

#[path = "support/mortar_meshes.rs"]
mod meshes;

use std::collections::{BTreeMap, BTreeSet};

use meshes::{Lcg, patch, polar};
use tidens_contact::ContactSurface;
use tidens_contact::mortar::{
    Derivatives, SurfaceTestFunctions, TestBasis, WeightedGap, candidate_pairs, weighted_gaps,
    weighted_gaps_of,
};

struct Scene {
    x: Vec<[f64; 3]>,
    slave: ContactSurface,
    master: ContactSurface,
    pairs: Vec<(usize, usize)>,
    test: SurfaceTestFunctions,
}

impl Scene {
    /// With `continued`, the master's facets continued past its open
    /// edges (triangles only).
    fn new(triangles: bool, basis: TestBasis, master_cells: usize, continued: bool) -> Self {
        let mut x = Vec::new();
        let slave = patch(
            &mut x,
            3,
            3,
            |u, v| {
                [
                    1.2 * u,
                    1.2 * v,
                    0.1 * (2.0 * u).sin() * (1.0 + v) - 0.05 * v * v,
                ]
            },
            false,
            triangles,
        );
        let mut rng = Lcg(7);
        for p in x.iter_mut() {
            for c in 0..3 {
                p[c] += 0.04 * rng.next();
            }
        }
        let (a, b) = (
            polar(1.6, 0.3),
            polar(1.6, 0.3 + std::f64::consts::FRAC_PI_2),
        );
        let c = [0.6 - 0.5 * (a[0] + b[0]), 0.6 - 0.5 * (a[1] + b[1])];
        let first = x.len();
        let mut master = patch(
            &mut x,
            master_cells,
            master_cells,
            |u, v| {
                [
                    c[0] + u * a[0] + v * b[0],
                    c[1] + u * a[1] + v * b[1],
                    0.01 + 0.06 * (3.0 * u - 1.5 * v).cos(),
                ]
            },
            true,
            triangles,
        );
        for p in x[first..].iter_mut() {
            for c in 0..3 {
                p[c] += 0.03 * rng.next();
            }
        }
        if continued {
            master.continue_open_edges(0.5);
        }
        let pairs = candidate_pairs(&slave, &master, &x, 0.3);
        let test = SurfaceTestFunctions::new(&slave, &x, basis);
        Scene {
            x,
            slave,
            master,
            pairs,
            test,
        }
    }

    fn gaps(&self, x: &[[f64; 3]], d: Derivatives) -> BTreeMap<usize, WeightedGap> {
        weighted_gaps(&self.slave, &self.master, x, &self.pairs, &self.test, d)
            .unwrap()
            .into_iter()
            .map(|w| (w.node, w))
            .collect()
    }

    /// The coordinates moved by `e` times the direction `d`.
    fn moved(&self, d: &[[f64; 3]], e: f64) -> Vec<[f64; 3]> {
        self.x
            .iter()
            .zip(d)
            .map(|(p, q)| std::array::from_fn(|c| p[c] + e * q[c]))
            .collect()
    }

    fn direction(&self, seed: u64) -> Vec<[f64; 3]> {
        let mut rng = Lcg(seed);
        self.x
            .iter()
            .map(|_| [rng.next(), rng.next(), rng.next()])
            .collect()
    }
}

fn along(grad: &[(usize, f64)], d: &[[f64; 3]]) -> (f64, f64) {
    grad.iter().fold((0.0, 0.0), |(s, a), &(dof, v)| {
        let t = v * d[dof / 3][dof % 3];
        (s + t, a + t.abs())
    })
}

#[test]
fn gradients_match_central_differences() {
    let h = 1e-6;
    for (triangles, continued) in [(false, false), (true, false), (true, true)] {
        for basis in [TestBasis::Standard, TestBasis::Dual] {
            let scene = Scene::new(triangles, basis, 4, continued);
            let g0 = scene.gaps(&scene.x, Derivatives::Gradient);
            let (open, closed) = (
                g0.values().filter(|w| w.gap > 0.0).count(),
                g0.values().filter(|w| w.gap < 0.0).count(),
            );
            assert!(
                open > 0 && closed > 0 && g0.len() >= 12,
                "{open} open, {closed} closed"
            );
            let mut worst = 0.0f64;
            for seed in 1..=4 {
                let d = scene.direction(seed);
                let (gp, gm) = (
                    scene.gaps(&scene.moved(&d, h), Derivatives::Value),
                    scene.gaps(&scene.moved(&d, -h), Derivatives::Value),
                );
                for (n, w) in &g0 {
                    let fd = (gp[n].gap - gm[n].gap) / (2.0 * h);
                    let (an, scale) = along(&w.gradient, &d);
                    let err = (fd - an).abs() / scale;
                    worst = worst.max(err);
                    assert!(err < 1e-7, "node {n}: {fd} against {an}");
                }
            }
            println!(
                "triangles {triangles}, continued {continued}, {basis:?}: {} nodes, largest relative difference {worst:.1e}",
                g0.len()
            );
        }
    }
}

#[test]
fn hessians_match_central_differences_of_the_gradients() {
    let h = 1e-6;
    for (triangles, continued) in [(false, false), (true, false), (true, true)] {
        let scene = Scene::new(triangles, TestBasis::Dual, 3, continued);
        let g0 = scene.gaps(&scene.x, Derivatives::Hessian);
        let plain = scene.gaps(&scene.x, Derivatives::Gradient);
        let mut worst = 0.0f64;
        for (n, w) in &g0 {
            // The Hessian path's gradient is the gradient path's.
            assert_eq!(w.gradient.len(), plain[n].gradient.len());
            for ((da, va), (db, vb)) in w.gradient.iter().zip(&plain[n].gradient) {
                assert!(da == db && (va - vb).abs() <= 1e-12 * va.abs().max(1e-3));
            }
            let hb = w.hessian.as_ref().unwrap();
            let k = hb.dofs.len();
            let big = hb.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for a in 0..k {
                for b in 0..a {
                    assert!((hb.values[a * k + b] - hb.values[b * k + a]).abs() < 1e-12 * big);
                }
            }
        }
        for seed in 11..=12 {
            let d = scene.direction(seed);
            let (gp, gm) = (
                scene.gaps(&scene.moved(&d, h), Derivatives::Gradient),
                scene.gaps(&scene.moved(&d, -h), Derivatives::Gradient),
            );
            for (n, w) in &g0 {
                let hb = w.hessian.as_ref().unwrap();
                let fd: BTreeMap<usize, f64> = {
                    let mut m: BTreeMap<usize, f64> = BTreeMap::new();
                    for &(dof, v) in &gp[n].gradient {
                        *m.entry(dof).or_default() += v / (2.0 * h);
                    }
                    for &(dof, v) in &gm[n].gradient {
                        *m.entry(dof).or_default() -= v / (2.0 * h);
                    }
                    m
                };
                let k = hb.dofs.len();
                let hd: Vec<f64> = (0..k)
                    .map(|a| {
                        (0..k)
                            .map(|b| hb.values[a * k + b] * d[hb.dofs[b] / 3][hb.dofs[b] % 3])
                            .sum()
                    })
                    .collect();
                let scale = hd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (a, &dof) in hb.dofs.iter().enumerate() {
                    let err = (fd.get(&dof).copied().unwrap_or(0.0) - hd[a]).abs() / scale;
                    worst = worst.max(err);
                    assert!(
                        err < 1e-6,
                        "node {n} dof {dof}: {} against {}",
                        fd.get(&dof).copied().unwrap_or(0.0),
                        hd[a]
                    );
                }
                assert!(fd.keys().all(|dof| hb.dofs.binary_search(dof).is_ok()));
            }
        }
        println!(
            "triangles {triangles}, continued {continued}: Hessians of {} nodes, largest relative difference {worst:.1e}",
            g0.len()
        );
    }
}

#[test]
fn the_gaps_of_some_nodes_are_those_of_all() {
    for triangles in [false, true] {
        let scene = Scene::new(triangles, TestBasis::Dual, 4, triangles);
        for d in [Derivatives::Value, Derivatives::Gradient] {
            let all = scene.gaps(&scene.x, d);
            // Every third node with a gap, and a node that has none.
            let mut nodes: BTreeSet<usize> = all.keys().copied().step_by(3).collect();
            nodes.insert(usize::MAX);
            let some = weighted_gaps_of(
                &scene.slave,
                &scene.master,
                &scene.x,
                &scene.pairs,
                &scene.test,
                d,
                &nodes,
            )
            .unwrap();
            assert_eq!(some.len(), nodes.len() - 1);
            for g in &some {
                assert!(!g.gradient.is_empty() || d == Derivatives::Value);
                assert_eq!(g, &all[&g.node]);
            }
        }
    }
}
