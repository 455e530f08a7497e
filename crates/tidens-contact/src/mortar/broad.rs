//! Candidate pairs (slave facet, master facet) of two surfaces.
//!
//! Each slave facet's axis-aligned box, grown by the search distance `d`
//! on every side, is tested against the master facets' boxes held in a
//! parry bounding volume hierarchy (`Bvh::from_leaves`, `intersect_aabb`):
//! a pair is a candidate when the two boxes are at most `d` apart along
//! every axis. Then the orientation
//! filter of [`facing`]: the master's centre normal must point
//! against the slave's (`n_m . n0 < -FACING`), the test the clip makes
//! again, so that a pair it drops here would have no overlap there.
//!
//! `d` must cover the largest gap at which the weighted gaps are wanted
//! (the solver's search distance, a mesh size): a pair that is not a
//! candidate brings nothing to the gaps, and the pair list changes only
//! where it is re-made.

use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::Vector as PVector;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};

use crate::mortar::clip::{AuxPlane, facing};
use crate::mortar::trace::Facet;
use crate::surface::ContactSurface;

/// The box of `facet`'s nodes grown by `grow` \[mm\].
fn facet_box(facet: &Facet<f64>, grow: f64) -> Aabb {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &facet.x[..facet.node_count()] {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c] - grow);
            hi[c] = hi[c].max(p[c] + grow);
        }
    }
    Aabb::new(
        PVector::new(lo[0], lo[1], lo[2]),
        PVector::new(hi[0], hi[1], hi[2]),
    )
}

fn overlap(a: &Aabb, b: &Aabb) -> bool {
    (0..3).all(|c| a.mins[c] <= b.maxs[c] && b.mins[c] <= a.maxs[c])
}

/// The candidate pairs (slave facet, master facet) of `slave` and
/// `master` in the configuration `x` \[mm\] within the search distance
/// `search_distance` \[mm\] (module docs), sorted.
pub fn candidate_pairs(
    slave: &ContactSurface,
    master: &ContactSurface,
    x: &[[f64; 3]],
    search_distance: f64,
) -> Vec<(usize, usize)> {
    let masters: Vec<Facet<f64>> = (0..master.facets.len())
        .map(|f| Facet::of_master(master, f, x))
        .collect();
    let boxes: Vec<Aabb> = masters.iter().map(|f| facet_box(f, 0.0)).collect();
    if boxes.is_empty() {
        return Vec::new();
    }
    let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &boxes);
    let mut pairs = Vec::new();
    for s in 0..slave.facets.len() {
        let facet = Facet::of_surface(slave, s, x);
        let grown = facet_box(&facet, search_distance);
        let plane = AuxPlane::of(&facet);
        let first = pairs.len();
        for m in bvh.intersect_aabb(&grown) {
            let m = m as usize;
            if overlap(&grown, &boxes[m]) && facing(&plane, &masters[m]) {
                pairs.push((s, m));
            }
        }
        pairs[first..].sort_unstable();
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An `n x n` grid of unit quads at height `z`, facing up or down,
    /// shifted by `dx`.
    fn grid(n: usize, z: f64, up: bool, dx: f64, first: usize) -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
        let nodes: Vec<[f64; 3]> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| [i as f64 + dx, j as f64, z]))
            .collect();
        let quads = (0..n)
            .flat_map(|j| {
                (0..n).map(move |i| {
                    let a = first + j * (n + 1) + i;
                    let q = [a, a + 1, a + n + 2, a + n + 1];
                    if up { q } else { [q[0], q[3], q[2], q[1]] }
                })
            })
            .collect();
        (nodes, quads)
    }

    #[test]
    fn pairs_are_those_whose_boxes_meet_and_that_face_each_other() {
        let (mut x, sq) = grid(4, 0.0, true, 0.0, 0);
        let (xm, mq) = grid(4, 0.05, false, 0.5, x.len());
        x.extend(xm);
        let slave = ContactSurface::from_quads(&sq, &x).unwrap();
        let master = ContactSurface::from_quads(&mq, &x).unwrap();
        let pairs = candidate_pairs(&slave, &master, &x, 0.1);
        // Brute force: every pair whose grown boxes meet.
        let mut want = Vec::new();
        for s in 0..16 {
            let b = facet_box(&Facet::of_surface(&slave, s, &x), 0.1);
            for m in 0..16 {
                if overlap(&b, &facet_box(&Facet::of_surface(&master, m, &x), 0.0)) {
                    want.push((s, m));
                }
            }
        }
        assert_eq!(pairs, want);
        // Shifted by half a quad, each inner slave quad meets 2 x 3 or so.
        assert!(pairs.len() > 16);
        // Too far apart: none.
        assert!(candidate_pairs(&slave, &master, &x, 0.01).is_empty());
        // The same orientation: none face each other.
        let same = ContactSurface::from_quads(
            &mq.iter()
                .map(|q| [q[0], q[3], q[2], q[1]])
                .collect::<Vec<_>>(),
            &x,
        )
        .unwrap();
        assert!(candidate_pairs(&slave, &same, &x, 0.1).is_empty());
    }
}
