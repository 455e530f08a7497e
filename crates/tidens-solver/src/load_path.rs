//! Whether a cell can carry the piston's load: a chain of touching particle
//! pieces from the piston (z = Lz) to the bottom plane (z = 0).
//!
//! The side faces of the box are frictionless mirror planes and carry no
//! vertical force, so without such a chain the piston meets no resistance
//! and the first steps move it without bound (a singular problem, not a
//! slow densification). A piece touches the piston when its spheroid is
//! centred on the piston plane (the plane cuts it) or its pole reaches it,
//! and the bottom likewise. Two pieces touch when the closest point of one
//! piece's surface to the other spheroid lies on it, to a relative
//! `TOUCH_TOLERANCE` of the level function (about half that of a distance
//! over the radius).

use crate::cell::{Cell, Octant};
use crate::error::SolverError;
use std::f64::consts::FRAC_PI_2;

/// Relative slack of the level function within which two particles, or a
/// particle and a plane, count as touching (a gap of about 5e-6 of the radius).
pub const TOUCH_TOLERANCE: f64 = 1e-5;

/// Grid of the first search for the closest point, per angle.
const GRID: usize = 24;
/// The search stops refining below this angle step \[rad\].
const ANGLE_RESOLUTION: f64 = 1e-11;

/// The smallest level function of spheroid `q` over the surface of the piece
/// `p` inside the box: 1 where they touch, below 1 where they overlap.
///
/// The piece's surface is the octant of directions pointing into the box,
/// parametrised by polar angles (theta, phi) in [0, pi/2]^2; a grid search
/// finds the basin (the level function of a convex body over a convex
/// patch has one), a compass search refines it to `ANGLE_RESOLUTION`.
pub fn closest_level(p: &Octant, q: &Octant, lengths: [f64; 3]) -> f64 {
    let centre = p.centre(lengths);
    let sign = p.corner.map(|high| if high { -1.0 } else { 1.0 });
    let level = |theta: f64, phi: f64| {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let x = [
            centre[0] + sign[0] * p.a * st * cp,
            centre[1] + sign[1] * p.a * st * sp,
            centre[2] + sign[2] * p.c * ct,
        ];
        q.level(lengths, x)
    };
    let h = FRAC_PI_2 / GRID as f64;
    let mut best = (0.0, 0.0, f64::INFINITY);
    for i in 0..=GRID {
        for j in 0..=GRID {
            let (t, f) = (i as f64 * h, j as f64 * h);
            let v = level(t, f);
            if v < best.2 {
                best = (t, f, v);
            }
        }
    }
    let mut step = h;
    while step > ANGLE_RESOLUTION {
        let (t0, f0, v0) = best;
        let moves = [(step, 0.0), (-step, 0.0), (0.0, step), (0.0, -step)];
        for (dt, df) in moves {
            let (t, f) = (
                (t0 + dt).clamp(0.0, FRAC_PI_2),
                (f0 + df).clamp(0.0, FRAC_PI_2),
            );
            let v = level(t, f);
            if v < best.2 {
                best = (t, f, v);
            }
        }
        if best.2 >= v0 {
            step *= 0.5;
        }
    }
    best.2
}

/// Fails unless touching pieces chain the piston to the bottom plane.
pub fn check(cell: &Cell) -> Result<(), SolverError> {
    let lz = cell.lengths[2];
    let reaches_top = |o: &Octant| o.corner[2] || o.c >= lz * (1.0 - TOUCH_TOLERANCE);
    let reaches_bottom = |o: &Octant| !o.corner[2] || o.c >= lz * (1.0 - TOUCH_TOLERANCE);
    let n = cell.octants.len();
    let touch = |i: usize, j: usize| {
        let (p, q) = (&cell.octants[i], &cell.octants[j]);
        closest_level(p, q, cell.lengths) <= 1.0 + TOUCH_TOLERANCE
    };
    // Breadth-first from the pieces the piston presses.
    let mut reached: Vec<bool> = cell.octants.iter().map(reaches_top).collect();
    let mut front: Vec<usize> = (0..n).filter(|&i| reached[i]).collect();
    while let Some(i) = front.pop() {
        if reaches_bottom(&cell.octants[i]) {
            return Ok(());
        }
        for j in 0..n {
            if !reached[j] && touch(i, j) {
                reached[j] = true;
                front.push(j);
            }
        }
    }
    let list = |ids: Vec<usize>| {
        if ids.is_empty() {
            "none".to_string()
        } else {
            ids.iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let top = list((0..n).filter(|&i| reaches_top(&cell.octants[i])).collect());
    let bottom = list(
        (0..n)
            .filter(|&i| reaches_bottom(&cell.octants[i]))
            .collect(),
    );
    Err(SolverError::NoLoadPath {
        cell: cell.name.clone(),
        reason: format!(
            "no chain of touching particles carries the piston's load (z = Lz) to the \
             bottom plane (z = 0), so the piston would meet no resistance; octants at or \
             reaching the piston: {top}; at or reaching the bottom: {bottom} (octants \
             touch when their gap is below {TOUCH_TOLERANCE:e} of the level function, \
             about 5e-6 of the radius)"
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn octant(corner: [bool; 3], a: f64, c: f64) -> Octant {
        Octant { corner, a, c }
    }

    #[test]
    fn closest_level_of_two_spheres_is_the_closed_form() {
        // Spheres of radii a and b centred d apart along the body diagonal:
        // the closest point of the first is at distance d - a from the
        // second's centre, so the level is ((d - a) / b)^2.
        let lengths = [0.1, 0.1, 0.1];
        let d = 0.1 * 3.0_f64.sqrt();
        for (a, b) in [(0.08, 0.09), (0.1, 0.07), (0.05, 0.05)] {
            let p = octant([false; 3], a, a);
            let q = octant([true; 3], b, b);
            let got = closest_level(&p, &q, lengths);
            let want = ((d - a) / b).powi(2);
            assert!((got - want).abs() < 1e-12, "{a} {b}: {got} vs {want}");
        }
    }

    #[test]
    fn closest_level_of_spheroids_matches_a_fine_sampling() {
        // Different shapes, centres on a face diagonal: the search must not
        // stop above the minimum of a dense sampling of the patch.
        let lengths = [0.1, 0.1, 0.12];
        let p = octant([false, false, false], 0.06, 0.1);
        let q = octant([true, false, true], 0.07, 0.05);
        let got = closest_level(&p, &q, lengths);
        let n = 2000;
        let mut sampled = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n / 10 {
                let (t, f) = (
                    i as f64 * FRAC_PI_2 / n as f64,
                    j as f64 * FRAC_PI_2 / (n / 10) as f64,
                );
                let x = [
                    0.06 * t.sin() * f.cos(),
                    0.06 * t.sin() * f.sin(),
                    0.1 * t.cos(),
                ];
                sampled = sampled.min(q.level(lengths, x));
            }
        }
        assert!(
            got <= sampled + 1e-12 && got > sampled - 1e-3,
            "{got} vs {sampled}"
        );
    }

    #[test]
    fn every_preset_carries_the_load() {
        for aspect in [0.2, 0.8, 1.0, 1.2, 5.0] {
            for cell in [
                Cell::sc(0.05, aspect),
                Cell::bcc(0.05, aspect),
                Cell::fcc(0.05, aspect),
                Cell::sc2(0.05, 1.566, aspect),
                Cell::sc2(0.05, 1.0 + std::f64::consts::SQRT_2, aspect),
            ] {
                let cell = cell.unwrap();
                assert!(check(&cell).is_ok(), "{} c/a {aspect}", cell.name);
            }
        }
    }

    #[test]
    fn a_cell_without_a_chain_is_refused() {
        // One sphere on the bottom, short of the piston by 1 %.
        let e = Cell::new(
            "short",
            [0.1, 0.1, 0.101],
            vec![octant([false; 3], 0.1, 0.1)],
        )
        .unwrap_err();
        assert!(matches!(e, SolverError::NoLoadPath { .. }), "{e}");
        // Two pieces, one at the piston and one on the bottom, apart: the
        // bcc box stretched by 1 % along z.
        let s = 2.0 * 0.05 / 3.0_f64.sqrt();
        let apart = Cell::new(
            "apart",
            [s, s, 1.01 * s],
            vec![
                octant([false; 3], 0.05, 0.05),
                octant([true; 3], 0.05, 0.05),
            ],
        );
        assert!(matches!(apart, Err(SolverError::NoLoadPath { .. })));
        // The same pieces touching (the bcc cell) form the chain.
        let touching = Cell::new(
            "bcc",
            [s, s, s],
            vec![
                octant([false; 3], 0.05, 0.05),
                octant([true; 3], 0.05, 0.05),
            ],
        );
        assert!(touching.is_ok());
    }
}
