//! The weighted gaps change continuously while a master surface slides
//! over a slave: a wavy slave grid (3 x 4 quads, or their triangles) and
//! a wavy master grid (5 x 5, turned by 17 degrees, covering part of the
//! slave) slid by one master facet width in 200 sub-steps. Between
//! sub-steps each `g_j` changes by no more than its largest slope along
//! the slide times the step (the exact gradient gives the slope); and
//! wherever the clip polygons change (a vertex appears or goes, a pair
//! starts or stops overlapping) the step is bisected down to 1e-12 of the
//! facet width, across which no `g_j` may change by more than 1e-10 of its
//! scale (its largest magnitude along the slide).

#[path = "support/mortar_meshes.rs"]
mod meshes;

use std::collections::BTreeMap;

use meshes::{patch, polar};
use tidens_contact::ContactSurface;
use tidens_contact::mortar::clip::clip;
use tidens_contact::mortar::{
    Derivatives, Facet, SurfaceTestFunctions, TestBasis, candidate_pairs, weighted_gaps,
};

const TURN: f64 = 17.0 * std::f64::consts::PI / 180.0;
const SIDE: f64 = 2.0;
/// The master's facet width: the length of the slide.
const WIDTH: f64 = SIDE / 5.0;
const STEPS: usize = 200;
const SEARCH: f64 = 0.3;

struct Slide {
    x0: Vec<[f64; 3]>,
    slave: ContactSurface,
    master: ContactSurface,
    /// The slide's direction.
    dir: [f64; 3],
}

impl Slide {
    fn new(triangles: bool) -> Self {
        let mut x = Vec::new();
        let slave = patch(
            &mut x,
            3,
            4,
            |u, v| {
                [
                    1.5 * u,
                    2.0 * v,
                    0.04 * (3.0 * u + 1.0).sin() * (2.0 * v).cos(),
                ]
            },
            false,
            triangles,
        );
        let (a, b) = (
            polar(SIDE, TURN),
            polar(SIDE, TURN + std::f64::consts::FRAC_PI_2),
        );
        let c = [0.2, -0.1];
        let master = patch(
            &mut x,
            5,
            5,
            |u, v| {
                [
                    c[0] + u * a[0] + v * b[0],
                    c[1] + u * a[1] + v * b[1],
                    0.02 + 0.03 * (2.3 * u * SIDE + 0.7 * v * SIDE).cos(),
                ]
            },
            true,
            triangles,
        );
        Slide {
            x0: x,
            slave,
            master,
            dir: polar(1.0, 0.4),
        }
    }

    /// The coordinates with the master moved by `s` along the slide.
    fn at(&self, s: f64) -> Vec<[f64; 3]> {
        let mut x = self.x0.clone();
        for &n in &self.master.nodes {
            for c in 0..3 {
                x[n][c] += s * self.dir[c];
            }
        }
        x
    }

    /// `g_j` by node and, with `slope`, `dg_j/ds`.
    fn gaps(&self, s: f64, basis: TestBasis, slope: bool) -> BTreeMap<usize, (f64, f64)> {
        let x = self.at(s);
        let pairs = candidate_pairs(&self.slave, &self.master, &x, SEARCH);
        let test = SurfaceTestFunctions::new(&self.slave, &self.x0, basis);
        let d = if slope {
            Derivatives::Gradient
        } else {
            Derivatives::Value
        };
        let g = weighted_gaps(&self.slave, &self.master, &x, &pairs, &test, d).unwrap();
        let moving: std::collections::BTreeSet<usize> = self.master.nodes.iter().copied().collect();
        g.iter()
            .map(|w| {
                let ds = w
                    .gradient
                    .iter()
                    .filter(|(dof, _)| moving.contains(&(dof / 3)))
                    .map(|(dof, v)| v * self.dir[dof % 3])
                    .sum();
                (w.node, (w.gap, ds))
            })
            .collect()
    }

    /// The vertex counts of the clip polygons of the overlapping pairs.
    fn signature(&self, s: f64) -> Vec<(usize, usize, Vec<usize>)> {
        let x = self.at(s);
        candidate_pairs(&self.slave, &self.master, &x, SEARCH)
            .into_iter()
            .filter_map(|(a, b)| {
                let c = clip(
                    &Facet::of_surface(&self.slave, a, &x),
                    &Facet::of_surface(&self.master, b, &x),
                )?;
                Some((a, b, c.pieces.iter().map(|p| p.vertices.len()).collect()))
            })
            .collect()
    }
}

/// The largest change of any `g_j` between two evaluations (a node
/// missing from one has no overlap there: zero).
fn largest_change(a: &BTreeMap<usize, (f64, f64)>, b: &BTreeMap<usize, (f64, f64)>) -> f64 {
    a.keys()
        .chain(b.keys())
        .map(|n| (a.get(n).map_or(0.0, |v| v.0) - b.get(n).map_or(0.0, |v| v.0)).abs())
        .fold(0.0, f64::max)
}

#[test]
fn weighted_gaps_are_continuous_under_sliding() {
    for triangles in [false, true] {
        for basis in [TestBasis::Standard, TestBasis::Dual] {
            let slide = Slide::new(triangles);
            let h = WIDTH / STEPS as f64;
            let steps: Vec<_> = (0..=STEPS)
                .map(|i| slide.gaps(i as f64 * h, basis, true))
                .collect();
            let scale = steps
                .iter()
                .flat_map(|g| g.values().map(|v| v.0.abs()))
                .fold(0.0, f64::max);
            // Lipschitz: each g_j moves by at most (its largest slope) x h
            // (with a margin for the slope between the sub-steps).
            let mut slopes: BTreeMap<usize, f64> = BTreeMap::new();
            for g in &steps {
                for (&n, &(_, d)) in g {
                    let e = slopes.entry(n).or_default();
                    *e = e.max(d.abs());
                }
            }
            let mut worst_ratio = 0.0f64;
            for w in steps.windows(2) {
                for (&n, &l) in &slopes {
                    let change = (w[0].get(&n).map_or(0.0, |v| v.0)
                        - w[1].get(&n).map_or(0.0, |v| v.0))
                    .abs();
                    let bound = 1.5 * l * h + 1e-10 * scale;
                    worst_ratio = worst_ratio.max(change / bound);
                    assert!(
                        change <= bound,
                        "node {n}: {change:e} over a sub-step, bound {bound:e}"
                    );
                }
            }
            // Every change of the clip polygons, bisected.
            let (mut vertex_events, mut pair_events, mut worst_jump) = (0, 0, 0.0f64);
            let mut worst_own = 0.0f64;
            let mut node_scale: BTreeMap<usize, f64> = BTreeMap::new();
            for g in &steps {
                for (&n, &(v, _)) in g {
                    let e = node_scale.entry(n).or_default();
                    *e = e.max(v.abs());
                }
            }
            for i in 0..STEPS {
                let (mut a, mut b) = (i as f64 * h, (i + 1) as f64 * h);
                let (sa, sb) = (slide.signature(a), slide.signature(b));
                if sa == sb {
                    continue;
                }
                // A pair overlapping at both ends with other vertex counts,
                // or a pair that starts or stops overlapping.
                let changed = sa
                    .iter()
                    .any(|p| sb.iter().any(|q| (p.0, p.1) == (q.0, q.1) && p.2 != q.2));
                let keys = |s: &Vec<(usize, usize, Vec<usize>)>| {
                    s.iter().map(|t| (t.0, t.1)).collect::<Vec<_>>()
                };
                vertex_events += usize::from(changed);
                pair_events += usize::from(keys(&sa) != keys(&sb));
                while b - a > 1e-12 * WIDTH {
                    let mid = 0.5 * (a + b);
                    if slide.signature(mid) == sa {
                        a = mid;
                    } else {
                        b = mid;
                    }
                }
                let (ga, gb) = (slide.gaps(a, basis, false), slide.gaps(b, basis, false));
                worst_jump = worst_jump.max(largest_change(&ga, &gb) / scale);
                for (n, own) in &node_scale {
                    let jump =
                        (ga.get(n).map_or(0.0, |v| v.0) - gb.get(n).map_or(0.0, |v| v.0)).abs();
                    worst_own = worst_own.max(jump / own);
                    assert!(
                        jump <= 1e-10 * own,
                        "node {n}: a jump of {jump:e} (its scale {own:e}) at s = {a}"
                    );
                }
            }
            println!(
                "triangles {triangles}, {basis:?}: scale {scale:.3e} mm^3; largest sub-step change {worst_ratio:.2} of its bound; \
                 {vertex_events} sub-steps with vertex-count changes, {pair_events} with overlap changes, largest change across one {worst_jump:.1e} of the scale, {worst_own:.1e} of the node's own"
            );
            assert!(
                vertex_events >= 10,
                "only {vertex_events} vertex-count changes: the slide tests little"
            );
        }
    }
}
