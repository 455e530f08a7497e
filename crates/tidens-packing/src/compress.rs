//! Box compression: random placement in a dilute box, then alternating
//! small density increments with overlap relaxation (see [`crate::relax`]),
//! in the manner of the zero-temperature jamming protocol of C. S. O'Hern,
//! L. E. Silbert, A. J. Liu, S. R. Nagel, Phys. Rev. E 68 (2003) 011306.
//!
//! The box keeps its final size and the particles grow (by the factor
//! `s = (rho / rho0)^(1/3)`), which is the same geometry as a box shrinking
//! around particles of fixed size. A step that cannot be relaxed is undone
//! and halved; when the step falls below [`STEP_MIN`] the packing is jammed
//! below the target: it is then decompressed by [`SHAKE_DECOMPRESSION`],
//! shaken (random displacements and rotations) and compressed again, at most
//! [`MAX_SHAKES`] times.

use nalgebra::{UnitVector3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::neighbours::Cell;
use crate::relax::{Outcome, Relaxer, Snapshot, turned};

/// Relative density of the random start.
const START_DENSITY: f64 = 0.25;
/// First and largest density increment.
const STEP_MAX: f64 = 0.05;
/// Smallest density increment before the packing counts as jammed.
const STEP_MIN: f64 = 1e-3;
/// Number of decompress-shake-recompress attempts after a jam.
const MAX_SHAKES: usize = 20;
/// Density given back before a shake.
const SHAKE_DECOMPRESSION: f64 = 0.03;
/// Largest random displacement of a shake, per component, in mean radii.
const SHAKE_DISPLACEMENT: f64 = 1.0;
/// Largest random rotation of a shake \[rad\].
const SHAKE_ROTATION: f64 = 0.3;
/// FIRE steps per stage, at most.
const MAX_ITERATIONS: usize = 20_000;

/// The packing problem handed to [`compress`].
pub(crate) struct Problem {
    pub(crate) cell: Cell,
    pub(crate) die: bool,
    /// Full-size semi-axes `(a, c)` \[mm\].
    pub(crate) semi_axes: Vec<(f64, f64)>,
    pub(crate) rho0: f64,
    pub(crate) mean_radius: f64,
    /// Largest overlap accepted at every stage \[mm\].
    pub(crate) tolerance: f64,
}

/// A uniformly distributed unit vector (rejection from the unit ball, no
/// trigonometry).
fn random_unit(rng: &mut ChaCha8Rng) -> UnitVector3<f64> {
    loop {
        let v = Vector3::new(
            2.0 * rng.random::<f64>() - 1.0,
            2.0 * rng.random::<f64>() - 1.0,
            2.0 * rng.random::<f64>() - 1.0,
        );
        let r2 = v.norm_squared();
        if r2 > 1e-6 && r2 <= 1.0 {
            return UnitVector3::new_normalize(v);
        }
    }
}

/// Compresses the particles to `rho0`: the relaxed centres and axes with the
/// densest relative density below `rho0` reached on the way, or (error) the
/// densest relative density at which an overlap-free packing was found.
pub(crate) fn compress(problem: &Problem, rng: &mut ChaCha8Rng) -> Result<(Snapshot, f64), f64> {
    let rho0 = problem.rho0;
    let scale_at = |phi: f64| {
        if phi >= rho0 {
            1.0
        } else {
            (phi / rho0).cbrt()
        }
    };
    let l = problem.cell.lengths;
    let mut phi_good = START_DENSITY.min(rho0);
    let s0 = scale_at(phi_good);
    let mut pos = Vec::with_capacity(problem.semi_axes.len());
    let mut axis = Vec::with_capacity(problem.semi_axes.len());
    for &(a, c) in &problem.semi_axes {
        let x = rng.random::<f64>() * l[0];
        let y = rng.random::<f64>() * l[1];
        let z = if problem.die {
            let lo = s0 * a.max(c);
            lo + (l[2] - 2.0 * lo) * rng.random::<f64>()
        } else {
            rng.random::<f64>() * l[2]
        };
        pos.push(Vector3::new(x, y, z));
        axis.push(if a == c {
            Vector3::z_axis()
        } else {
            random_unit(rng)
        });
    }
    let mut relaxer = Relaxer::new(
        problem.cell,
        problem.die,
        problem.semi_axes.clone(),
        pos,
        axis,
    );
    let tol = problem.tolerance;
    relaxer.set_scale(s0);
    if relaxer.relax(tol, MAX_ITERATIONS) != Outcome::Relaxed {
        return Err(0.0);
    }
    if phi_good >= rho0 {
        return Ok((relaxer.snapshot(), phi_good));
    }
    let mut good = relaxer.snapshot();
    let mut best = phi_good;
    let mut step = STEP_MAX;
    let mut shakes = 0;
    loop {
        let phi = (phi_good + step).min(rho0);
        relaxer.set_scale(scale_at(phi));
        if relaxer.relax(tol, MAX_ITERATIONS) == Outcome::Relaxed {
            if phi >= rho0 {
                return Ok((relaxer.snapshot(), best));
            }
            phi_good = phi;
            best = best.max(phi);
            good = relaxer.snapshot();
            step = (step * 1.5).min(STEP_MAX);
            continue;
        }
        // Jammed at phi: shrinking the particles until no overlap is left
        // gives an overlap-free packing just below the jamming density.
        let s_free = relaxer.overlap_free_scale() * (1.0 - 1e-12);
        let phi_free = rho0 * s_free * s_free * s_free;
        if phi_free > phi_good {
            relaxer.set_scale(scale_at(phi_free));
            if relaxer.relax(tol, MAX_ITERATIONS) == Outcome::Relaxed {
                phi_good = phi_free;
                best = best.max(phi_free);
                good = relaxer.snapshot();
            }
        }
        relaxer.restore(&good);
        step = 0.5 * (phi - phi_good).min(step);
        if step >= STEP_MIN {
            continue;
        }
        // Jammed below rho0: decompress, shake, compress again. A shaken
        // state that cannot be relaxed counts as a shake and the next one
        // starts again from the last good state.
        loop {
            shakes += 1;
            if shakes > MAX_SHAKES {
                return Err(best);
            }
            relaxer.restore(&good);
            let phi_shaken = (phi_good - SHAKE_DECOMPRESSION).max(START_DENSITY.min(rho0));
            let s = scale_at(phi_shaken);
            relaxer.set_scale(s);
            let kick = SHAKE_DISPLACEMENT * problem.mean_radius * s;
            for i in 0..relaxer.pos.len() {
                for k in 0..3 {
                    relaxer.pos[i][k] += kick * (2.0 * rng.random::<f64>() - 1.0);
                }
                let (a, c) = problem.semi_axes[i];
                if a != c {
                    let turn = random_unit(rng);
                    let angle = SHAKE_ROTATION * rng.random::<f64>();
                    relaxer.axis[i] = turned(&relaxer.axis[i], &(turn.into_inner() * angle));
                }
            }
            if relaxer.relax(tol, MAX_ITERATIONS) == Outcome::Relaxed {
                phi_good = phi_shaken;
                good = relaxer.snapshot();
                break;
            }
        }
        step = 0.1 * STEP_MAX;
    }
}
