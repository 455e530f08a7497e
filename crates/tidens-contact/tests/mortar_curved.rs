//! The mortar gap between two non-matching meshes of concentric spheres:
//! a slave cap of the unit sphere (a cubed-sphere face patch, `n x n`
//! cells over the gnomonic angles |u|, |v| <= 0.35) and a master cap of
//! radius `1 + delta` (`m x m` cells over |u|, |v| <= 0.5, turned by 0.3
//! rad about the axis, facing in), which covers the slave. The facets are
//! chords of the spheres, off them by O(h^2), so the mean gap `g_j / A_j`
//! tends to `delta` as O(h^2): halving both meshes' cells divides the
//! largest error by about four.

#[path = "support/mortar_meshes.rs"]
mod meshes;

use meshes::{gaps, patch};
use tidens_contact::mortar::{Derivatives, TestBasis};

const DELTA: f64 = 0.01;

/// The point of the sphere of radius `r` on the cube-face direction of
/// gnomonic angles `(u, v)` in `[-a, a]^2` (from the unit parameters),
/// turned by `turn` about z.
fn cubed(r: f64, a: f64, turn: f64) -> impl Fn(f64, f64) -> [f64; 3] {
    move |s, t| {
        let (u, v) = (a * (2.0 * s - 1.0), a * (2.0 * t - 1.0));
        let d = [u.tan(), v.tan(), 1.0];
        let l = (d[0] * d[0] + d[1] * d[1] + 1.0).sqrt();
        let (c, sn) = (turn.cos(), turn.sin());
        [
            r * (c * d[0] - sn * d[1]) / l,
            r * (sn * d[0] + c * d[1]) / l,
            r / l,
        ]
    }
}

/// The errors `|g_j / A_j - delta|` over the slave nodes at `n` slave and
/// `m` master cells a side: the largest over the inner nodes, the largest
/// over the boundary nodes, and the root mean square over all.
fn errors(n: usize, m: usize, triangles: bool, basis: TestBasis) -> [f64; 3] {
    let mut x = Vec::new();
    let slave = patch(&mut x, n, n, cubed(1.0, 0.35, 0.0), false, triangles);
    let master = patch(&mut x, m, m, cubed(1.0 + DELTA, 0.5, 0.3), true, triangles);
    let g = gaps(&slave, &master, &x, basis, 0.05, Derivatives::Value);
    assert_eq!(g.len(), slave.nodes.len());
    let (mut inner, mut boundary, mut sum) = (0.0f64, 0.0f64, 0.0);
    for w in &g {
        let e = (w.gap / w.area - DELTA).abs();
        // The slave's nodes come first, row by row.
        let (i, j) = (w.node % (n + 1), w.node / (n + 1));
        if i == 0 || j == 0 || i == n || j == n {
            boundary = boundary.max(e);
        } else {
            inner = inner.max(e);
        }
        sum += e * e;
    }
    [inner, boundary, (sum / g.len() as f64).sqrt()]
}

#[test]
fn the_mean_gap_between_concentric_spheres_converges_at_second_order() {
    for triangles in [false, true] {
        for basis in [TestBasis::Standard, TestBasis::Dual] {
            let e: Vec<[f64; 3]> = [(6, 9), (12, 18), (24, 36), (48, 72)]
                .iter()
                .map(|&(n, m)| errors(n, m, triangles, basis))
                .collect();
            let order = |k: usize, level: usize| (e[level - 1][k] / e[level][k]).log2();
            for (k, name) in ["inner max", "boundary max", "rms"].iter().enumerate() {
                println!(
                    "triangles {triangles}, {basis:?}, {name}: errors/delta {}; orders {:.2} {:.2} {:.2}",
                    e.iter()
                        .map(|v| format!("{:.2e}", v[k] / DELTA))
                        .collect::<Vec<_>>()
                        .join(" "),
                    order(k, 1),
                    order(k, 2),
                    order(k, 3)
                );
            }
            // The inner nodes' largest error and the mean square over all
            // nodes, between the two finest meshes. (A largest error is
            // noisy before the asymptotic range: the finer mesh samples
            // more relative positions of the two grids.)
            assert!(order(0, 3) >= 1.8, "inner order {:.2}", order(0, 3));
            assert!(order(2, 3) >= 1.8, "rms order {:.2}", order(2, 3));
            assert!(e[3][1] < 0.01 * DELTA);
        }
    }
}
