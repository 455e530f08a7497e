//! The piston load history: a linear ramp to the full stress, then a hold.

use serde::{Deserialize, Serialize};

/// Stage 1 ramps the applied stress linearly from 0 to `stress` over
/// `ramp_time`; stage 2 holds it. The die-wall knock-down `knockdown` (f)
/// multiplies the stress acting on the cell (docs/model.md section 1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoadHistory {
    /// Applied (nominal) stress in the hold \[MPa\].
    pub stress: f64,
    /// Knock-down factor f for die-wall friction [-].
    pub knockdown: f64,
    /// Duration of the linear ramp \[s\]; 0 applies the full load at once.
    pub ramp_time: f64,
}

impl LoadHistory {
    /// Applied nominal stress sigma(t) \[MPa\].
    pub fn applied_stress(&self, t: f64) -> f64 {
        if self.ramp_time > 0.0 && t < self.ramp_time {
            self.stress * (t / self.ramp_time).max(0.0)
        } else {
            self.stress
        }
    }

    /// Stress acting on the cell, f sigma(t) \[MPa\].
    pub fn cell_stress(&self, t: f64) -> f64 {
        self.knockdown * self.applied_stress(t)
    }

    /// The load factor sigma(t) / sigma in [0, 1].
    pub fn factor(&self, t: f64) -> f64 {
        self.applied_stress(t) / self.stress
    }

    /// Effective time at full load for a Norton exponent `n`:
    /// `t_eff = integral of (sigma(t)/sigma)^n dt`, which is `t^(n+1) / ((n+1)
    /// t_r^n)` during the ramp and `t - n t_r / (n + 1)` after it (docs/model.md
    /// section 7, item 2). For a rigid-viscoplastic body the densification
    /// state depends on time only through `t_eff`.
    pub fn effective_time(&self, t: f64, n: f64) -> f64 {
        let tr = self.ramp_time;
        if tr <= 0.0 {
            t.max(0.0)
        } else if t < tr {
            t.max(0.0).powf(n + 1.0) / ((n + 1.0) * tr.powf(n))
        } else {
            t - n * tr / (n + 1.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effective_time_is_the_integral_of_the_load_factor_to_the_n() {
        let l = LoadHistory {
            stress: 10.0,
            knockdown: 0.6,
            ramp_time: 2.0,
        };
        let n = 2.8;
        for &t in &[0.5, 2.0, 7.0] {
            // Midpoint rule with many intervals.
            let m = 200_000;
            let h = t / m as f64;
            let integral: f64 = (0..m)
                .map(|k| l.factor((k as f64 + 0.5) * h).powf(n) * h)
                .sum();
            assert!((integral - l.effective_time(t, n)).abs() < 1e-6 * t);
        }
        assert_eq!(l.cell_stress(1.0), 3.0);
    }
}
