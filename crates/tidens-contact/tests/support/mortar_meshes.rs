//! Surface patches for the mortar tests: structured grids of quads (or
//! their triangles) on a parametric map, appended to one array of nodes.
#![allow(dead_code)]

use tidens_contact::ContactSurface;
use tidens_contact::mortar::{
    Derivatives, SurfaceTestFunctions, TestBasis, WeightedGap, weighted_gaps,
};

/// A patch of `nx x ny` cells of the map `(u, v) in [0, 1]^2 -> point`,
/// nodes appended to `x`; the quads counter-clockwise in `(u, v)` (normal
/// along `x_u x x_v`) or, with `flip`, the other way; with `triangles`,
/// each quad split in two (diagonals alternating like a chessboard).
pub fn patch(
    x: &mut Vec<[f64; 3]>,
    nx: usize,
    ny: usize,
    map: impl Fn(f64, f64) -> [f64; 3],
    flip: bool,
    triangles: bool,
) -> ContactSurface {
    let quads = grid(x, nx, ny, map, flip);
    if triangles {
        ContactSurface::from_triangles(&chessboard(&quads, nx), x).unwrap()
    } else {
        ContactSurface::from_quads(&quads, x).unwrap()
    }
}

/// The quads of the patch of [`patch`], its nodes appended to `x`.
pub fn grid(
    x: &mut Vec<[f64; 3]>,
    nx: usize,
    ny: usize,
    map: impl Fn(f64, f64) -> [f64; 3],
    flip: bool,
) -> Vec<[usize; 4]> {
    let first = x.len();
    for j in 0..=ny {
        for i in 0..=nx {
            x.push(map(i as f64 / nx as f64, j as f64 / ny as f64));
        }
    }
    let id = |i: usize, j: usize| first + j * (nx + 1) + i;
    let mut quads = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let q = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            quads.push(if flip { [q[0], q[3], q[2], q[1]] } else { q });
        }
    }
    quads
}

/// Each quad of a grid `nx` quads wide split in two, the diagonals
/// alternating like a chessboard.
pub fn chessboard(quads: &[[usize; 4]], nx: usize) -> Vec<[usize; 3]> {
    quads
        .iter()
        .enumerate()
        .flat_map(|(c, q)| {
            if (c / nx + c % nx).is_multiple_of(2) {
                [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
            } else {
                [[q[1], q[2], q[3]], [q[1], q[3], q[0]]]
            }
        })
        .collect()
}

/// The point `c + u a + v b`.
pub fn plane(c: [f64; 3], a: [f64; 3], b: [f64; 3]) -> impl Fn(f64, f64) -> [f64; 3] {
    move |u, v| std::array::from_fn(|k| c[k] + u * a[k] + v * b[k])
}

/// The vector of length `l` at angle `t` in the xy-plane.
pub fn polar(l: f64, t: f64) -> [f64; 3] {
    [l * t.cos(), l * t.sin(), 0.0]
}

/// The weighted gaps of `slave` on `master` over the candidate pairs
/// within `search` \[mm\].
pub fn gaps(
    slave: &ContactSurface,
    master: &ContactSurface,
    x: &[[f64; 3]],
    basis: TestBasis,
    search: f64,
    derivatives: Derivatives,
) -> Vec<WeightedGap> {
    let pairs = tidens_contact::mortar::candidate_pairs(slave, master, x, search);
    let test = SurfaceTestFunctions::new(slave, x, basis);
    weighted_gaps(slave, master, x, &pairs, &test, derivatives).unwrap()
}

/// A reproducible stream of numbers in [-1, 1] (64-bit LCG).
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}
