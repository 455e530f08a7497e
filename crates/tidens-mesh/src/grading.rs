//! One-dimensional node distributions on the unit interval.

/// `n + 1` increasing points from exactly 0 to exactly 1 whose spacings grow
/// geometrically away from 0, the largest spacing being `ratio` times the
/// smallest (`ratio = 1` gives uniform spacing). `n >= 1`, `ratio >= 1`.
pub(crate) fn refined_toward_zero(n: usize, ratio: f64) -> Vec<f64> {
    if n <= 1 || ratio <= 1.0 {
        return (0..=n).map(|i| i as f64 / n.max(1) as f64).collect();
    }
    let q = ratio.powf(1.0 / (n - 1) as f64);
    let mut t = Vec::with_capacity(n + 1);
    let mut sum = 0.0;
    let mut size = 1.0;
    t.push(0.0);
    for _ in 0..n {
        sum += size;
        t.push(sum);
        size *= q;
    }
    for v in &mut t {
        *v /= sum;
    }
    // Pin the end: the far end must be exactly 1 (it is a block corner).
    t[n] = 1.0;
    t
}

/// Like [`refined_toward_zero`] but refined toward 1: `t_i = 1 - s_(n-i)`.
pub(crate) fn refined_toward_one(n: usize, ratio: f64) -> Vec<f64> {
    let s = refined_toward_zero(n, ratio);
    let mut t: Vec<f64> = s.iter().rev().map(|v| 1.0 - v).collect();
    t[0] = 0.0;
    t[n] = 1.0;
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_when_ratio_is_one() {
        let t = refined_toward_zero(4, 1.0);
        assert_eq!(t, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
    }

    #[test]
    fn spacing_ratio_is_the_requested_one() {
        for (n, r) in [(2, 4.0), (5, 2.0), (17, 4.0)] {
            for t in [refined_toward_zero(n, r), refined_toward_one(n, r)] {
                assert_eq!(t[0], 0.0);
                assert_eq!(t[n], 1.0);
                let d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
                assert!(d.iter().all(|&v| v > 0.0));
                let (lo, hi) = d.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
                    (lo.min(v), hi.max(v))
                });
                assert!((hi / lo - r).abs() < 1e-9 * r, "n {n} ratio {}", hi / lo);
            }
            let t = refined_toward_one(n, r);
            assert!(t[n] - t[n - 1] < t[1] - t[0], "finest spacing must be at 1");
        }
    }
}
