//! Line searches along a Newton direction: on the slope of the energy
//! whose gradient the residual is ([`along_energy`], the solver's), and
//! backtracking on the squared residual norm ([`backtrack`], its fallback
//! where the direction is not one of descent).

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
pub fn backtrack<T>(
    r0_sq: f64,
    tol: f64,
    mut evaluate: impl FnMut(f64) -> Option<(f64, f64, T)>,
) -> Option<Trial<T>> {
    let mut s = 1.0;
    let mut best: Option<Trial<T>> = None;
    for _ in 0..MAX_TRIALS {
        let Some((norm_sq, norm, point)) = evaluate(s) else {
            s *= 0.25;
            continue;
        };
        let done = norm_sq <= (1.0 - 1e-4 * s) * r0_sq || norm <= tol;
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
        s *= (r0_sq / (norm_sq + r0_sq)).clamp(0.1, 0.5);
    }
    best
}

/// Most points tried along one direction by [`along_energy`].
const MAX_SLOPE_TRIALS: usize = 6;

/// [`along_energy`] accepts a point where the slope of the energy along the
/// direction has fallen to this fraction of its value at the start.
const SLOPE_RATIO: f64 = 0.5;

/// [`along_energy`] treats a point whose residual norm exceeds the start's
/// this many times as unusable, whatever its slope: the energy jumps where
/// a contact term appears (a node that comes within reach of a facet
/// already deep inside it), and the slope beyond the jump says nothing
/// about it (measured on the sc2 cell of c/a = 5: a full step accepted on
/// its slope raised the residual from 4e-5 to 7e2 N).
const MAX_RESIDUAL_GROWTH: f64 = 10.0;

/// A point tried by [`along_energy`]: squared residual norm, largest
/// residual entry, the energy's slope along the direction (the residual
/// dotted with the direction) and whatever the caller computed there.
pub type SlopePoint<T> = (f64, f64, f64, T);

/// Line search on the energy whose gradient the residual is (the
/// incremental potential of the viscoplastic body, the load and the
/// contact penalties), by its slope `g(s) = R(s) . d` along the direction
/// `d` (Matthies and Strang 1979): the full step is taken where the slope
/// has fallen to [`SLOPE_RATIO`] of `g(0)` (or the residual is below
/// `tol`), otherwise the root of the slope is sought by regula falsi
/// (Illinois) between the last points of either sign, at most
/// [`MAX_SLOPE_TRIALS`] points. A step that still descends at its end is
/// taken whole. Points that cannot be evaluated (an inverted element) or
/// whose residual grew more than [`MAX_RESIDUAL_GROWTH`] times cut the step
/// by four.
///
/// Why not the residual's norm: where creep dominates, the stress grows
/// as the strain rate to the power 1/n, and a Newton step from an
/// overstressed iterate overshoots by a factor of about n; the norm of
/// the residual is then nearly flat up to the minimum and its quadratic
/// model cuts the step to the floor of [`backtrack`] (a tenth), so that
/// each iteration removes a tenth of the residual. The energy along the
/// step has its minimum near 1/n, where the slope changes sign, and
/// regula falsi finds it in a few residual evaluations.
///
/// `g0` must be negative (a descent direction: a positive definite
/// tangent); otherwise, or if no point is usable, the search falls back
/// to [`backtrack`]. The result is the accepted point, or the one of
/// smallest slope magnitude.
pub fn along_energy<T>(
    g0: f64,
    r0_sq: f64,
    tol: f64,
    mut evaluate: impl FnMut(f64) -> Option<SlopePoint<T>>,
) -> Option<Trial<T>> {
    if !(g0 < 0.0 && g0.is_finite()) {
        return backtrack(r0_sq, tol, |s| evaluate(s).map(|(q, m, _, p)| (q, m, p)));
    }
    // Bracket: the last point where the energy still descends (lo) and
    // the last where it rises again or the point is unusable (hi).
    let (mut lo, mut g_lo) = (0.0, g0);
    let mut hi: Option<(f64, f64)> = None;
    let mut kept_hi = 0;
    let mut s = 1.0;
    let mut best: Option<(f64, Trial<T>)> = None;
    for _ in 0..MAX_SLOPE_TRIALS {
        match evaluate(s) {
            Some((norm_sq, ..)) if !(norm_sq <= MAX_RESIDUAL_GROWTH.powi(2) * r0_sq) => {
                hi = Some((s, f64::INFINITY))
            }
            None => hi = Some((s, f64::INFINITY)),
            Some((norm_sq, norm, g, point)) => {
                let done =
                    norm <= tol || g.abs() <= SLOPE_RATIO * g0.abs() || (g < 0.0 && hi.is_none());
                if done || best.as_ref().is_none_or(|b| g.abs() < b.0) {
                    best = Some((
                        g.abs(),
                        Trial {
                            step: s,
                            norm_sq,
                            norm,
                            point,
                        },
                    ));
                }
                if done {
                    break;
                }
                if g < 0.0 {
                    (lo, g_lo) = (s, g);
                    kept_hi += 1;
                } else {
                    if hi.is_some() {
                        kept_hi = 0;
                    }
                    hi = Some((s, g));
                }
            }
        }
        let (s_hi, mut g_hi) = hi.expect("a point above the minimum or unusable");
        // Illinois: the end kept twice in a row counts half.
        if kept_hi >= 2 && g_hi.is_finite() {
            g_hi *= 0.5;
            hi = Some((s_hi, g_hi));
        }
        let w = s_hi - lo;
        s = if g_hi.is_finite() {
            (lo - g_lo * w / (g_hi - g_lo)).clamp(lo + 0.05 * w, s_hi - 0.05 * w)
        } else {
            lo + 0.25 * w
        };
    }
    match best {
        Some((_, trial)) => Some(trial),
        None => backtrack(r0_sq, tol, |s| evaluate(s).map(|(q, m, _, p)| (q, m, p))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn takes_the_full_step_when_it_decreases_and_cuts_an_overshoot() {
        // |R(s)|^2 of a linear residual along its exact Newton step.
        let full = backtrack(1.0, 0.0, |s| Some(((1.0 - s) * (1.0 - s), 1.0 - s, s))).unwrap();
        assert_eq!(full.step, 1.0);
        // A direction three times too long: R(s) = 1 - 3 s. The full step
        // raises |R|^2 to 4, the quadratic-model cut (1/5, within [0.1, 0.5])
        // decreases it.
        let cut = backtrack(1.0, 0.0, |s| {
            let r: f64 = 1.0 - 3.0 * s;
            Some((r * r, r.abs(), s))
        })
        .unwrap();
        assert!((cut.step - 0.2).abs() < 1e-15 && cut.norm_sq < 1.0);
        // Unusable points are skipped with a cut by 4.
        let mut tried = Vec::new();
        let r = backtrack(1.0, 0.0, |s| {
            tried.push(s);
            (s < 0.5).then_some((0.5, 0.7, s))
        })
        .unwrap();
        assert_eq!(tried, vec![1.0, 0.25]);
        assert_eq!(r.step, 0.25);
    }

    /// The residual of a power-law creep element, r(x) = x^(1/n): a Newton
    /// step from x overshoots to (1 - n) x. The energy along the step has
    /// its minimum at s = 1/n; the slope search lands there within its
    /// tolerance and leaves at most half the residual, where the
    /// residual-norm backtracking accepts the first point of sufficient
    /// decrease (s = 0.36 here) and removes an eighth of it.
    #[test]
    fn the_slope_search_finds_the_minimum_of_a_power_law_step() {
        let n: f64 = 4.3;
        let r = |x: f64| x.signum() * x.abs().powf(1.0 / n);
        let x0 = 1.0;
        let d = -n * x0; // -r / r'
        let at = |s: f64| {
            let rs = r(x0 + s * d);
            (rs * rs, rs.abs(), rs * d, s)
        };
        let r0 = r(x0);
        let slope = along_energy(r0 * d, r0 * r0, 0.0, |s| Some(at(s))).unwrap();
        let cut = backtrack(r0 * r0, 0.0, |s| {
            let (q, m, _, p) = at(s);
            Some((q, m, p))
        })
        .unwrap();
        // Accepted where |g(s)| <= |g(0)| / 2: |1 - n s|^(1/n) <= 1/2.
        let s_min = 1.0 / n;
        assert!(
            (slope.step - s_min).abs() <= 0.5f64.powf(n) / n,
            "step {} against 1/n = {s_min}",
            slope.step
        );
        assert!(slope.norm <= 0.5 * r0, "{}", slope.norm);
        assert!(cut.norm > 0.85 * r0, "{} {}", cut.step, cut.norm);
    }

    /// Where the direction is not one of descent (g(0) >= 0, an indefinite
    /// tangent), the slope says nothing and the residual-norm backtracking
    /// decides; a full step that still descends is taken whole.
    #[test]
    fn the_slope_search_falls_back_or_takes_a_descending_full_step() {
        let ascent = along_energy(1.0, 1.0, 0.0, |s| {
            let r: f64 = 1.0 - 3.0 * s;
            Some((r * r, r.abs(), 0.0, s))
        })
        .unwrap();
        assert!((ascent.step - 0.2).abs() < 1e-15);
        // A linear residual r(s) = 1 - s / 2 along a direction half too
        // short: still descending at s = 1, by half the start's slope.
        let mut tried = Vec::new();
        let short = along_energy(-1.0, 1.0, 0.0, |s| {
            tried.push(s);
            let r = 1.0 - 0.5 * s;
            Some((r * r, r, -r, s))
        })
        .unwrap();
        assert_eq!((short.step, tried), (1.0, vec![1.0]));
    }

    /// A contact term that appears at s = 0.9, its node already deep in the
    /// facet: the residual jumps a hundredfold while the slope beyond the
    /// jump still reads descent. The point is refused and the step cut
    /// short of the jump.
    #[test]
    fn the_slope_search_refuses_a_jump_of_the_residual() {
        let r = along_energy(-1.0, 1.0, 0.0, |s| {
            let (norm, g) = if s < 0.9 { (1.0 - s, -(1.0 - s)) } else { (100.0, -0.1) };
            Some((norm * norm, norm, g, s))
        })
        .unwrap();
        assert!(r.step < 0.9 && r.norm < 0.5, "step {} |R| {}", r.step, r.norm);
    }
}
