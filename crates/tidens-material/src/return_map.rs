use crate::params::Material;

/// Result of the scalar backward-Euler return of the Norton law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReturnMap {
    /// von Mises stress at the end of the step \[MPa\].
    pub q: f64,
    /// Equivalent plastic strain increment over the step [-].
    pub dp: f64,
    /// Derivative dq / dq_trial [-] (the consistent tangent's scalar part).
    pub dq_dtrial: f64,
    /// Newton iterations taken.
    pub iterations: u32,
}

impl Material {
    /// Backward-Euler return of `eps_dot = C q^n` from the elastic trial state.
    ///
    /// Solves `q + 3 G C dt q^n = q_trial` for `0 <= q <= q_trial`, the
    /// backward-Euler step written in a form that stays stable for stiff `n`.
    /// The left side is increasing and convex in `q`, so Newton from any upper
    /// bound of the root decreases monotonically onto it. The start
    /// `q0 = min(q_trial, (q_trial / (3 G C dt))^(1/n))` is such a bound and is
    /// already close to the root when the viscous term dominates, which keeps
    /// the iteration count small for any `n` and `C dt`. Powers are taken in log
    /// form so `q^n` cannot overflow for large `n`; each iteration costs one
    /// `ln` and one `exp`, and the tangent `dq/dq_trial` none.
    pub fn return_map(&self, q_trial: f64, dt: f64) -> ReturnMap {
        let n = self.creep_n;
        let k = 3.0 * self.shear_modulus() * self.creep_c * dt;
        if !(q_trial > 0.0) || !(k > 0.0) {
            return ReturnMap {
                q: q_trial.max(0.0),
                dp: 0.0,
                dq_dtrial: 1.0,
                iterations: 0,
            };
        }
        if n == 1.0 {
            let q = q_trial / (1.0 + k);
            return ReturnMap {
                q,
                dp: (q_trial - q) / (3.0 * self.shear_modulus()),
                dq_dtrial: 1.0 / (1.0 + k),
                iterations: 0,
            };
        }
        let ln_k = k.ln();
        let ln_qt = q_trial.ln();
        // Start at q0 = min(q_trial, (q_trial / k)^(1/n)), in logs, together
        // with k q0^(n-1): at the viscous bound k q0^n = q_trial, so it costs a
        // division only.
        let ln_qv = (ln_qt - ln_k) / n;
        let (mut q, mut kqn1) = if ln_qv < ln_qt {
            let qv = ln_qv.exp();
            (qv, q_trial / qv)
        } else {
            (q_trial, (ln_k + (n - 1.0) * ln_qt).exp())
        };
        // Newton from above on the convex, increasing left side: the error
        // left after a step `s` is at most (n - 1) s^2 / (2 q) (the ratio
        // f'' / f' is below (n - 1) / q), so once (n - 1) s^2 <= eps q^2 the
        // iterate is within half an ulp of the root and the confirming
        // iteration is skipped. k q^(n-1) stays in log form so q^n cannot
        // overflow for large n; q > 0 throughout because Newton from above
        // never passes the (positive) root.
        let converged_within = f64::EPSILON / (n - 1.0);
        let mut iterations = 0;
        for _ in 0..100 {
            iterations += 1;
            let f = q + kqn1 * q - q_trial;
            let df = 1.0 + n * kqn1;
            let step = f / df;
            q -= step;
            if step.abs() <= 1e-15 * q_trial || step * step <= converged_within * q * q || q <= 0.0
            {
                break;
            }
            kqn1 = (ln_k + (n - 1.0) * q.ln()).exp();
        }
        let q = q.clamp(0.0, q_trial);
        // At the root k q^(n-1) = (q_trial - q) / q, so the derivative of the
        // scalar equation needs no further power.
        let dq_dtrial = if q > 0.0 {
            q / (q + n * (q_trial - q))
        } else {
            0.0
        };
        ReturnMap {
            q,
            dp: (q_trial - q) / (3.0 * self.shear_modulus()),
            dq_dtrial,
            iterations,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat(c: f64, n: f64) -> Material {
        Material::new(4.35e4, 0.3, c, n).unwrap()
    }

    #[test]
    fn root_satisfies_the_scalar_equation_over_extreme_ranges() {
        for &n in &[1.0, 2.8, 4.3, 8.0, 15.0, 30.0] {
            for &c in &[1e-12, 1e-7, 1e-3] {
                for &dt in &[1e-6, 1e-2, 1e3, 1e6] {
                    for &qt in &[1e-3, 1.0, 100.0, 1e4] {
                        let m = mat(c, n);
                        let r = m.return_map(qt, dt);
                        let k = 3.0 * m.shear_modulus() * c * dt;
                        let res = r.q + k * r.q.powf(n) - qt;
                        assert!(r.q >= 0.0 && r.q <= qt);
                        assert!(
                            res.abs() <= 1e-11 * qt,
                            "n={n} c={c} dt={dt} qt={qt}: residual {res}"
                        );
                        assert!(
                            r.iterations <= 12,
                            "n={n} c={c} dt={dt} qt={qt}: {} iterations",
                            r.iterations
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn scalar_tangent_matches_finite_difference() {
        for &n in &[1.0, 2.8, 8.0, 15.0] {
            let m = mat(4.8e-7, n);
            for &dt in &[1e-3, 1.0, 1e3] {
                let qt = 50.0;
                let h = 1e-6 * qt;
                let fd = (m.return_map(qt + h, dt).q - m.return_map(qt - h, dt).q) / (2.0 * h);
                let an = m.return_map(qt, dt).dq_dtrial;
                assert!(
                    (fd - an).abs() <= 1e-6 * an.abs().max(1e-12),
                    "n={n} dt={dt}: fd {fd} vs {an}"
                );
            }
        }
    }
}
