//! Adaptive time steps for backward Euler, driven by an estimate of each
//! step's error in time.
//!
//! Backward Euler evaluates the densification rate at the end of a step, so
//! the time it takes to reach a density is off by about half the step times
//! the change of the log of the rate over it. During the ramp a time shift
//! counts at the reduced load, so the change is weighted by the load factor
//! to the n (`(sigma/sigma_max)^n`). Steps are sized so that this error per
//! unit time stays below the tolerance; the sum of the signed per-step
//! errors is the run's estimate of its time error.
//!
//! The rate also jumps when a node touches a plane: such a jump is in the
//! past once seen, so the step is steered by the trend of the rate over the
//! last few steps ([`RATE_WINDOW`]) rather than by the last change alone.
//! Only the plastic-strain-increment limit (a robustness bound for Newton)
//! rejects a step.
//!
//! A step too short to measure the rate against the contact noise (see
//! [`rate_noise_threshold`]) is judged by the change of the rate that the
//! load alone makes over it, n ln(f1/f0) for load factors f0 and f1 at its
//! ends (zero once the load is held): during the ramp the particle
//! contacts' noise is largest (the pressures grow every step) and the rate
//! could otherwise not be measured at all, so the steps doubled unchecked.
//! Measured on fcc at level 2: steps of 0.16 and 0.38 s across the ramp of
//! 1 s, t(0.8) 3 % short at tolerance 0.01 and 8 % short at 0.0025 (the
//! tighter tolerance raising the noise threshold), once Newton stopped
//! failing on such steps.

use std::collections::VecDeque;

/// Steps over which the trend of the densification rate is measured.
pub const RATE_WINDOW: usize = 4;

/// A step of less than this piston strain says nothing reliable of the rate
/// (the Newton tolerance leaves noise of 1e-10 or so, and contact events
/// make it jumpy): it lets the step grow, and what it could get wrong is
/// bounded by its own tiny strain.
const MOVED_STRAIN: f64 = 1e-6;

/// A step's rate is measured only when its piston strain is at least the
/// strain the particle-contact multipliers may move the cell by on their own
/// (`noise`: the largest contact violation over the cell's height) over the
/// tolerance: the multipliers are updated once per step, so each step also
/// pushes the last step's penetrations out, and the rate it measures is off
/// by about noise / strain, which must stay below the accuracy the steps are
/// sized for. Shorter steps let the step grow; what they could get wrong is
/// bounded by their own tiny strain. Measured on bcc at level 2 to rho =
/// 0.95: with 10 times the noise as the threshold (an earlier rule), a hard
/// contact step could leave the run for hundreds of steps near dt = 1e-5 s,
/// each rate off by 10 % (359 steps, and 591 after a round-off perturbation
/// of the run); with noise / tolerance, 294 and 292, the times to density
/// within 0.5 %; fcc 272 -> 240 steps, within 0.5 %.
fn rate_noise_threshold(noise: f64, tolerance: f64) -> f64 {
    MOVED_STRAIN.max(noise / tolerance)
}

/// One accepted step's contribution to the windowed rate trend.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
struct RateSample {
    /// Step \[s\].
    dt: f64,
    /// Weighted |change of ln rate| over the step.
    change: f64,
}

/// What the controller makes of a converged step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepAssessment {
    /// Step \[s\].
    pub dt: f64,
    /// Piston log-strain rate over the step \[1/s\].
    rate: f64,
    /// True when the step moved enough to measure the rate.
    moved: bool,
    /// True when `dln` is a sample of the rate's change (measured, or the
    /// load's share of it on a step too short to measure).
    sampled: bool,
    /// Weighted change of ln rate since the last measured step (or over the
    /// step, from the load alone, when it did not move enough).
    dln: f64,
    /// Largest plastic strain increment over the allowed one.
    psi_dp: f64,
    /// Estimated signed error of the step in time \[s\] (positive: late).
    pub error: f64,
}

/// The step-size controller and its memory of the rate.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepController {
    tolerance: f64,
    max_strain_increment: f64,
    dt_min: f64,
    /// Rate of the last step that moved \[1/s\].
    last_rate: Option<f64>,
    history: VecDeque<RateSample>,
    /// The step to try next \[s\].
    dt_next: f64,
    /// Sum of the signed per-step error estimates \[s\].
    time_error: f64,
}

impl StepController {
    /// A controller aiming at `tolerance` error per unit time, rejecting
    /// steps whose plastic strain increment exceeds twice
    /// `max_strain_increment`, starting with `dt0` \[s\].
    pub fn new(tolerance: f64, max_strain_increment: f64, dt0: f64, dt_min: f64) -> Self {
        Self {
            tolerance,
            max_strain_increment,
            dt_min,
            last_rate: None,
            history: VecDeque::with_capacity(RATE_WINDOW),
            dt_next: dt0,
            time_error: 0.0,
        }
    }

    /// The controller's proposal for the next step \[s\].
    pub fn dt_next(&self) -> f64 {
        self.dt_next
    }

    /// Smallest step before giving up \[s\].
    pub fn dt_min(&self) -> f64 {
        self.dt_min
    }

    /// Estimated time error accumulated so far \[s\].
    pub fn time_error(&self) -> f64 {
        self.time_error
    }

    /// Judges a converged step of `dt` \[s\] whose piston log-strain rate was
    /// `rate` \[1/s\], at load factor to the n `weight`, over which the load
    /// alone changes ln rate by `load_dln` (n ln(f1/f0)), with largest
    /// plastic strain increment `max_dp` and contact noise `noise` (the
    /// strain the contact multipliers may move the cell by regardless of the
    /// flow, see [`rate_noise_threshold`]): the assessment to accept it
    /// with, or the shorter step to retry it with.
    pub fn assess(
        &self,
        dt: f64,
        rate: f64,
        weight: f64,
        load_dln: f64,
        max_dp: f64,
        noise: f64,
    ) -> Result<StepAssessment, f64> {
        let moved = (rate * dt).abs() > rate_noise_threshold(noise, self.tolerance);
        // The load's share of the change: the rate rises with it, a
        // negative change (early).
        let from_load = -load_dln * weight;
        let (dln, sampled) = match self.last_rate {
            Some(r0) if moved && r0 > 0.0 && rate > 0.0 => {
                let measured = (r0 / rate).ln() * weight;
                if from_load.abs() > measured.abs() {
                    (from_load, true)
                } else {
                    (measured, true)
                }
            }
            _ if load_dln > 0.0 => (from_load, true),
            _ => (0.0, false),
        };
        let psi_dp = max_dp / self.max_strain_increment;
        if psi_dp > 2.0 && dt > 4.0 * self.dt_min {
            return Err(dt * (0.8 / psi_dp).max(0.1));
        }
        Ok(StepAssessment {
            dt,
            rate,
            moved,
            sampled,
            dln,
            psi_dp,
            error: 0.5 * dt * dln,
        })
    }

    /// Records an accepted step that took `iterations` Newton iterations and
    /// proposes the next step.
    pub fn accept(&mut self, a: &StepAssessment, iterations: usize) {
        self.time_error += a.error;
        if a.moved && a.rate > 0.0 {
            self.last_rate = Some(a.rate);
        }
        if a.sampled {
            if self.history.len() == RATE_WINDOW {
                self.history.pop_front();
            }
            self.history.push_back(RateSample {
                dt: a.dt,
                change: a.dln.abs(),
            });
        }
        // Newton effort limits the growth only when it is large (modified
        // Newton takes a few more, cheaper, iterations than full Newton).
        let newton_factor: f64 = match iterations {
            0..=8 => 2.0,
            9..=15 => 1.2,
            _ => 0.7,
        };
        // The step for which half the windowed rate-change speed times the
        // step equals the tolerance: the error per unit step is `tolerance`.
        let (span, change) = self
            .history
            .iter()
            .fold((0.0, 0.0), |(s, c), r| (s + r.dt, c + r.change));
        let accuracy_dt = if a.sampled && change > 0.0 {
            0.9 * 2.0 * self.tolerance * span / change
        } else {
            f64::INFINITY
        };
        let dp_dt = if a.psi_dp > 0.0 {
            0.9 * a.dt / a.psi_dp
        } else {
            f64::INFINITY
        };
        self.dt_next = (newton_factor * a.dt)
            .min(accuracy_dt)
            .min(dp_dt)
            .clamp(0.25 * a.dt, 2.0 * a.dt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs the controller on a flow of constant rate `rate` \[1/s\] whose
    /// measured rate carries an alternating error of `noise` strain per
    /// step (the contact multipliers' correction), and returns the step it
    /// proposes after `steps` steps.
    fn drive(rate: f64, noise: f64, told_noise: f64, steps: usize) -> f64 {
        let mut c = StepController::new(0.01, 0.2, 1e-5, 1e-12);
        for k in 0..steps {
            let dt = c.dt_next();
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let measured = rate + sign * noise / dt;
            let a = c.assess(dt, measured, 1.0, 0.0, 0.0, told_noise).unwrap();
            c.accept(&a, 1);
        }
        c.dt_next()
    }

    /// A constant rate needs no resolution: without noise the step doubles
    /// every step up to any length.
    #[test]
    fn steps_grow_on_a_constant_rate() {
        assert!(drive(0.05, 0.0, 0.0, 20) > 1e-5 * 2f64.powi(19));
    }

    /// With contact noise of 1e-6 strain per step on a rate of 0.05 /s, a
    /// controller that is not told of the noise keeps the steps near 2e-5 s
    /// (at the noise's own strain the noise looks like a rate change of
    /// order one); told of it, it lets the steps grow until they move the
    /// cell the noise over the tolerance, a hundred times longer.
    #[test]
    fn contact_noise_does_not_hold_the_step_short() {
        let (rate, noise) = (0.05, 1e-6);
        let blind = drive(rate, noise, 0.0, 60);
        let told = drive(rate, noise, noise, 60);
        let floor = rate_noise_threshold(noise, 0.01) / rate;
        assert!(blind < 0.2 * floor, "blind controller: dt = {blind:e}");
        assert!(
            told > 0.2 * floor,
            "controller told of the noise: dt = {told:e}"
        );
        assert!(told > 5.0 * blind, "blind {blind:e}, told {told:e}");
    }

    /// Steps across a linear ramp of 1 s (n = 2.8) whose rate cannot be
    /// measured for contact noise: the steps until the load is full, and the
    /// time error the controller accumulated over them \[s\].
    fn ramp_blind(tolerance: f64) -> (usize, f64) {
        let n = 2.8;
        let mut c = StepController::new(tolerance, 0.2, 0.02, 1e-12);
        let (mut t, mut steps) = (0.0f64, 0);
        while t < 1.0 {
            let dt = c.dt_next().min(1.0 - t);
            let (f0, f1) = (t, t + dt);
            let load_dln = if f0 > 0.0 { n * (f1 / f0).ln() } else { 0.0 };
            // Noise far above the step's strain: the rate says nothing.
            let a = c.assess(dt, 0.05, f1.powf(n), load_dln, 0.0, 1.0).unwrap();
            assert!(!a.moved);
            c.accept(&a, 1);
            t += dt;
            steps += 1;
        }
        (steps, c.time_error())
    }

    /// The load alone changes the rate by n ln(f1/f0) over a step of the
    /// ramp: steps the rate cannot judge are sized by that change, so that
    /// the ramp's time error, the sum of half of each step times its
    /// weighted change, stays near the tolerance times the ramp's length,
    /// and the ramp takes about 1 / (2 tolerance) steps, twice as many at
    /// half the tolerance. (Blind, the steps doubled from 0.02 s and crossed
    /// the ramp in 6.)
    #[test]
    fn a_ramp_is_resolved_even_where_the_rate_cannot_be_measured() {
        for tolerance in [0.01, 0.005] {
            let (steps, error) = ramp_blind(tolerance);
            eprintln!("tolerance {tolerance}: {steps} steps, time error {error:.3e} s");
            let expected = 0.5 / tolerance;
            assert!(
                steps as f64 > 0.7 * expected && (steps as f64) < 1.5 * expected,
                "{steps} steps at tolerance {tolerance}"
            );
            assert!(
                error < 0.0 && -error < 1.5 * tolerance,
                "time error {error:e} s at {tolerance}"
            );
        }
    }
}
