//! Box compression: random placement in a dilute box, then alternating
//! small density increments with overlap relaxation (see [`crate::relax`]),
//! in the manner of the zero-temperature jamming protocol of C. S. O'Hern,
//! L. E. Silbert, A. J. Liu, S. R. Nagel, Phys. Rev. E 68 (2003) 011306.
//!
//! The box keeps its final size and the particles grow (by the factor
//! `s = (rho / rho0)^(1/3)`), which is the same geometry as a box shrinking
//! around particles of fixed size. A step that cannot be relaxed is undone
//! and halved; when the step falls below [`STEP_MIN`] the packing is jammed
//! below the target. To reach the target all the same it is then
//! decompressed by [`SHAKE_DECOMPRESSION`], shaken (random displacements
//! and rotations) and compressed again, at most [`MAX_SHAKES`] times: the
//! shakes anneal it towards denser, more ordered states. A jammed packing
//! (`refine`) is not shaken: the state at its first jam is refined, its
//! jamming point located with steps down to [`REFINE_STEP_MIN`] and
//! overlaps relaxed to [`REFINE_TOLERANCE`] times the tolerance, and the
//! last jammed state, shrunk until no overlap is left, is kept. Shaken, 8
//! and 16 spheres in a cube jammed in one ordered state whatever the seed,
//! and 32 crystallised into fcc for 6 seeds of 20.
//!
//! Every relaxation asks the caller's `stop` before each FIRE iteration
//! (see [`crate::progress`]); a stop unwinds the whole compression.

use nalgebra::{UnitVector3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::neighbours::Cell;
use crate::progress::{Progress, Stage, Stopped};
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
/// Smallest density increment of the refinement of a jammed packing.
const REFINE_STEP_MIN: f64 = 1e-8;
/// Largest overlap accepted in the refinement, relative to
/// [`Problem::tolerance`].
const REFINE_TOLERANCE: f64 = 1e-3;
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

/// What [`compress`] found: the state at `rho0`, or the densest overlap-free
/// state below it (refined: the last jammed state, shrunk).
pub(crate) struct Compressed {
    /// Its centres \[mm\] and axes, in the box of the problem.
    pub(crate) state: Snapshot,
    /// Its particle scale `s = (density / rho0)^(1/3)`: 1 when `rho0` was
    /// reached.
    pub(crate) scale: f64,
    /// Its relative density in the box of the problem, at most `rho0`.
    pub(crate) density: f64,
    /// The densest relative density below `rho0` at which a state was
    /// accepted (`density` itself when `rho0` was not reached).
    pub(crate) below: f64,
}

/// Particle scale at the relative density `phi` in the box sized for `rho0`
/// (1 from `rho0` on).
fn scale_at(phi: f64, rho0: f64) -> f64 {
    if phi >= rho0 {
        1.0
    } else {
        (phi / rho0).cbrt()
    }
}

/// The state of a compression: the relaxer, the last good (relaxed) state
/// and the densest one, and what the caller is told.
struct Compressor<'a> {
    problem: &'a Problem,
    relaxer: Relaxer,
    /// Relative density of `good`.
    phi_good: f64,
    /// The last state accepted.
    good: Snapshot,
    /// Relative density of `best`.
    phi_best: f64,
    /// The densest state accepted.
    best: Snapshot,
    /// The densest relative density below `rho0` accepted.
    below: f64,
    /// The last jammed state, shrunk until no overlap is left: its relative
    /// density and (unrelaxed) centres and axes.
    jammed: Option<(f64, Snapshot)>,
    /// Shakes done.
    shakes: usize,
    /// Where the compression is, as the caller sees it.
    progress: Progress,
    /// The caller's stop, asked before every FIRE iteration.
    stop: &'a mut dyn FnMut(&Progress) -> bool,
}

impl Compressor<'_> {
    fn scale_at(&self, phi: f64) -> f64 {
        scale_at(phi, self.problem.rho0)
    }

    /// FIRE from the current configuration down to a largest overlap of
    /// `tol` (see [`Relaxer::relax`]), each iteration counted and the
    /// caller asked whether to stop.
    fn relax(&mut self, tol: f64) -> Result<Outcome, Stopped> {
        let Self {
            relaxer,
            progress,
            stop,
            ..
        } = self;
        relaxer.relax(tol, MAX_ITERATIONS, &mut || {
            progress.iterations += 1;
            stop(progress)
        })
    }

    /// Relaxes the current configuration at `phi` down to a largest overlap
    /// of `tol`; when it relaxes, it becomes the good state (and the best one
    /// when denser).
    fn accept(&mut self, phi: f64, tol: f64) -> Result<bool, Stopped> {
        self.relaxer.set_scale(self.scale_at(phi));
        self.progress.rel_density = phi;
        if self.relax(tol)? != Outcome::Relaxed {
            return Ok(false);
        }
        self.phi_good = phi;
        self.good = self.relaxer.snapshot();
        if phi > self.phi_best {
            self.phi_best = phi;
            self.best.clone_from(&self.good);
            self.progress.densest = phi;
        }
        if phi < self.problem.rho0 {
            self.below = self.below.max(phi);
        }
        Ok(true)
    }

    /// Grows the particles from the good state by density steps of `step`
    /// (at most [`STEP_MAX`], growing after each success) toward `rho0`,
    /// relaxing to `tol`. A step that jams is undone and halved; the jammed
    /// state shrunk until no overlap is left is accepted when it is denser
    /// than the good state. True when `rho0` is reached, false once the step
    /// falls below `step_min`.
    fn climb(&mut self, mut step: f64, step_min: f64, tol: f64) -> Result<bool, Stopped> {
        let rho0 = self.problem.rho0;
        loop {
            let phi = (self.phi_good + step).min(rho0);
            if self.accept(phi, tol)? {
                if phi >= rho0 {
                    return Ok(true);
                }
                step = (step * 1.5).min(STEP_MAX);
                continue;
            }
            // Jammed at phi: shrinking the particles until no overlap is
            // left gives an overlap-free packing just below the jamming
            // density.
            let s_free = self.relaxer.overlap_free_scale() * (1.0 - 1e-12);
            let phi_free = rho0 * s_free * s_free * s_free;
            self.jammed = Some((phi_free, self.relaxer.snapshot()));
            if phi_free > self.phi_good {
                self.accept(phi_free, tol)?;
            }
            self.relaxer.restore(&self.good);
            step = 0.5 * (phi - self.phi_good).min(step);
            if step < step_min {
                return Ok(false);
            }
        }
    }

    /// Decompresses the good state by [`SHAKE_DECOMPRESSION`], shakes it and
    /// relaxes it. A shaken state that cannot be relaxed counts as a shake
    /// and the next one starts again from the good state. False once
    /// [`MAX_SHAKES`] are used up.
    fn shake(&mut self, rng: &mut ChaCha8Rng) -> Result<bool, Stopped> {
        let problem = self.problem;
        loop {
            self.shakes += 1;
            if self.shakes > MAX_SHAKES {
                return Ok(false);
            }
            self.progress.stage = Stage::Shake;
            self.progress.round = self.shakes;
            self.relaxer.restore(&self.good);
            let phi_shaken =
                (self.phi_good - SHAKE_DECOMPRESSION).max(START_DENSITY.min(problem.rho0));
            let s = self.scale_at(phi_shaken);
            self.relaxer.set_scale(s);
            let kick = SHAKE_DISPLACEMENT * problem.mean_radius * s;
            let relaxer = &mut self.relaxer;
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
            if self.accept(phi_shaken, problem.tolerance)? {
                return Ok(true);
            }
        }
    }

    fn result(self) -> Compressed {
        Compressed {
            scale: self.scale_at(self.phi_best),
            density: self.phi_best,
            below: self.below,
            state: self.best,
        }
    }
}

/// Compresses the particles toward `rho0`: the relaxed centres and axes at
/// `rho0`, or, when the packing jams below it, the densest overlap-free
/// state found after the shakes; with `refine`, the state at the first jam
/// (not shaken), its jamming point located to a density step of
/// [`REFINE_STEP_MIN`]. None when the random start cannot be relaxed;
/// `Err(Stopped)` as soon as `stop`, asked before every FIRE iteration,
/// answers true.
pub(crate) fn compress(
    problem: &Problem,
    rng: &mut ChaCha8Rng,
    refine: bool,
    stop: &mut dyn FnMut(&Progress) -> bool,
) -> Result<Option<Compressed>, Stopped> {
    let rho0 = problem.rho0;
    let l = problem.cell.lengths;
    let phi_start = START_DENSITY.min(rho0);
    let s0 = scale_at(phi_start, rho0);
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
    let relaxer = Relaxer::new(
        problem.cell,
        problem.die,
        problem.semi_axes.clone(),
        pos,
        axis,
    );
    let start = relaxer.snapshot();
    let mut c = Compressor {
        problem,
        relaxer,
        phi_good: 0.0,
        good: start.clone(),
        phi_best: 0.0,
        best: start,
        below: 0.0,
        jammed: None,
        shakes: 0,
        progress: Progress::new(),
        stop,
    };
    if !c.accept(phi_start, problem.tolerance)? {
        return Ok(None);
    }
    if phi_start >= rho0 {
        return Ok(Some(c.result()));
    }
    let mut step = STEP_MAX;
    loop {
        c.progress.stage = Stage::Compress;
        if c.climb(step, STEP_MIN, problem.tolerance)? {
            return Ok(Some(c.result()));
        }
        // Jammed below rho0: a jammed packing is refined as it is; to
        // reach rho0, decompress, shake, compress again.
        if refine || !c.shake(rng)? {
            break;
        }
        step = 0.1 * STEP_MAX;
    }
    if refine {
        // Locate the jamming point of the first jam's state (the densest
        // accepted, not shaken) with finer steps and a tighter tolerance,
        // and keep the last jammed state (shrunk until no overlap is left):
        // its contacts are closed to the final step.
        let tol = REFINE_TOLERANCE * problem.tolerance;
        c.progress.stage = Stage::Refine;
        c.relaxer.restore(&c.best);
        c.good.clone_from(&c.best);
        c.phi_good = c.phi_best;
        c.jammed = None;
        if !c.climb(STEP_MIN, REFINE_STEP_MIN, tol)?
            && let Some((phi, state)) = c.jammed.take()
        {
            c.relaxer.restore(&state);
            c.relaxer.set_scale(c.scale_at(phi));
            c.progress.rel_density = phi;
            if c.relax(tol)? == Outcome::Relaxed {
                c.phi_best = phi;
                c.best = c.relaxer.snapshot();
            }
        }
    }
    Ok(Some(c.result()))
}
