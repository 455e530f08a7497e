//! Backtracking line search on the squared residual norm along a Newton
//! direction.

/// Most points tried along one direction (the full step, then three cuts).
const MAX_TRIALS: usize = 4;

/// A point tried along the direction.
pub struct Trial<T> {
    /// Fraction of the Newton step.
    pub step: f64,
    /// Squared Euclidean norm of the residual there.
    pub norm_sq: f64,
    /// Largest residual entry there (the convergence measure) \[N\].
    pub norm: f64,
    /// Whatever the caller computed there (displacements, evaluation).
    pub point: T,
}

/// Tries the full step first and accepts the first point with sufficient
/// decrease (`|R(s)|^2 <= (1 - 1e-4 s) |R(0)|^2`) or a residual below `tol`;
/// otherwise cuts the step by the minimiser of a quadratic model of
/// `|R(s)|^2`, within [0.1, 0.5] of the last step. `evaluate(s)` returns the
/// squared norm, the largest entry and the point at step `s`, or None where
/// the point is unusable (an inverted element: the step is cut by 4). The
/// result is the best point seen, None if every point was unusable.
///
/// A full step that fails may name the step to try next in place of the
/// model's cut: `event(point)` at the full step's point, where something
/// along the direction (a contact closing) bends the residual, kept within
/// [0.1, 1) (at 0.99 or more the model's cut is taken).
pub fn backtrack<T>(
    r0_sq: f64,
    tol: f64,
    mut evaluate: impl FnMut(f64) -> Option<(f64, f64, T)>,
    event: impl Fn(&T) -> Option<f64>,
) -> Option<Trial<T>> {
    let mut s = 1.0;
    let mut best: Option<Trial<T>> = None;
    for _ in 0..MAX_TRIALS {
        let Some((norm_sq, norm, point)) = evaluate(s) else {
            s *= 0.25;
            continue;
        };
        let done = norm_sq <= (1.0 - 1e-4 * s) * r0_sq || norm <= tol;
        let at_event = if !done && s == 1.0 {
            event(&point).filter(|e| *e < 0.99).map(|e| e.max(0.1))
        } else {
            None
        };
        if best.as_ref().is_none_or(|b| norm_sq < b.norm_sq) {
            best = Some(Trial {
                step: s,
                norm_sq,
                norm,
                point,
            });
        }
        if done {
            break;
        }
        s = at_event.unwrap_or_else(|| s * (r0_sq / (norm_sq + r0_sq)).clamp(0.1, 0.5));
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn takes_the_full_step_when_it_decreases_and_cuts_an_overshoot() {
        // |R(s)|^2 of a linear residual along its exact Newton step.
        let full = backtrack(
            1.0,
            0.0,
            |s| Some(((1.0 - s) * (1.0 - s), 1.0 - s, s)),
            |_| None,
        )
        .unwrap();
        assert_eq!(full.step, 1.0);
        // A direction three times too long: R(s) = 1 - 3 s. The full step
        // raises |R|^2 to 4, the quadratic-model cut (1/5, within [0.1, 0.5])
        // decreases it.
        let cut = backtrack(
            1.0,
            0.0,
            |s| {
                let r: f64 = 1.0 - 3.0 * s;
                Some((r * r, r.abs(), s))
            },
            |_| None,
        )
        .unwrap();
        assert!((cut.step - 0.2).abs() < 1e-15 && cut.norm_sq < 1.0);
        // Unusable points are skipped with a cut by 4.
        let mut tried = Vec::new();
        let r = backtrack(
            1.0,
            0.0,
            |s| {
                tried.push(s);
                (s < 0.5).then_some((0.5, 0.7, s))
            },
            |_| None,
        )
        .unwrap();
        assert_eq!(tried, vec![1.0, 0.25]);
        assert_eq!(r.step, 0.25);
    }

    /// A residual linear up to an event at s = 0.4 and steep past it
    /// (a contact closing along the direction): the quadratic model cuts
    /// the failed full step to a tenth, a decrease of a tenth; cut to the
    /// event the step takes four tenths. An event past 0.99 is ignored and
    /// one before 0.1 is taken at 0.1.
    #[test]
    fn a_full_step_past_an_event_is_cut_to_the_event() {
        let kinked = |s: f64| {
            let r = if s <= 0.4 {
                1.0 - s
            } else {
                0.6 + 30.0 * (s - 0.4)
            };
            Some((r * r, r, s))
        };
        let model = backtrack(1.0, 0.0, kinked, |_| None).unwrap();
        assert!((model.step - 0.1).abs() < 1e-15 && (model.norm - 0.9).abs() < 1e-12);
        let at_event = backtrack(1.0, 0.0, kinked, |_| Some(0.4)).unwrap();
        assert!((at_event.step - 0.4).abs() < 1e-15 && (at_event.norm - 0.6).abs() < 1e-12);
        let late = backtrack(1.0, 0.0, kinked, |_| Some(0.995)).unwrap();
        assert_eq!(late.step, model.step);
        let early = backtrack(1.0, 0.0, kinked, |_| Some(0.01)).unwrap();
        assert_eq!(early.step, 0.1);
    }
}
