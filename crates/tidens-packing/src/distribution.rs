//! Particle sizes: drawing the volume-equivalent radii, and the seeded
//! random streams.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, LogNormal};

use crate::error::PackingError;
use crate::spec::{PackingSpec, SizeDistribution};

/// ChaCha8 stream of the radii.
const RADII_STREAM: u64 = 0;
/// ChaCha8 stream of the placement, orientations and shakes.
pub(crate) const PLACEMENT_STREAM: u64 = 1;

/// The ChaCha8 generator of `seed` on `stream` (ChaCha8 and its seeding from
/// a `u64` are specified bit for bit, so the stream is the same on every
/// platform).
pub(crate) fn stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

impl PackingSpec {
    /// The volume-equivalent radii `(a^2 c)^(1/3)` \[mm\] of the particles of
    /// the packing that [`crate::Packing::generate`] makes from this spec, in
    /// particle order, without generating the packing. Their number mean is
    /// `mean_radius` (to rounding). Bimodal: the first
    /// `round(small_fraction * particles)` are the small ones.
    pub fn radii(&self) -> Result<Vec<f64>, PackingError> {
        self.validate()?;
        draw_radii(
            &self.distribution,
            self.particles,
            self.mean_radius,
            &mut stream(self.seed, RADII_STREAM),
        )
    }
}

/// `n` radii of `distribution` scaled to the number mean `mean` \[mm\].
fn draw_radii(
    distribution: &SizeDistribution,
    n: usize,
    mean: f64,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<f64>, PackingError> {
    let raw: Vec<f64> = match *distribution {
        SizeDistribution::Monodisperse => return Ok(vec![mean; n]),
        SizeDistribution::Bimodal {
            size_ratio,
            small_fraction,
        } => {
            let small = ((small_fraction * n as f64).round() as usize).min(n);
            (0..n)
                .map(|i| if i < small { 1.0 } else { size_ratio })
                .collect()
        }
        SizeDistribution::Lognormal { sigma } => {
            let dist = LogNormal::new(0.0, sigma).map_err(|_| PackingError::Parameter {
                name: "sigma",
                value: sigma,
                allowed: "in (0, 1]",
            })?;
            (0..n).map(|_| dist.sample(rng)).collect()
        }
    };
    let sample_mean = raw.iter().sum::<f64>() / n as f64;
    let factor = mean / sample_mean;
    Ok(raw.into_iter().map(|r| r * factor).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(distribution: SizeDistribution, particles: usize) -> PackingSpec {
        PackingSpec {
            particles,
            distribution,
            mean_radius: 0.05,
            ..PackingSpec::default()
        }
    }

    #[test]
    fn lognormal_sample_has_sigma_as_ln_radius_deviation() {
        for sigma in [0.1, 0.3, 0.8] {
            let s = spec(SizeDistribution::Lognormal { sigma }, 2000);
            let r = s.radii().unwrap();
            assert_eq!(r.len(), 2000);
            let mean = r.iter().sum::<f64>() / 2000.0;
            assert!((mean - 0.05).abs() < 1e-15, "{mean}");
            let ln: Vec<f64> = r.iter().map(|x| x.ln()).collect();
            let m = ln.iter().sum::<f64>() / 2000.0;
            let var = ln.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / 1999.0;
            let sd = var.sqrt();
            // Standard error of a sample deviation: sigma / sqrt(2 (n - 1)) ~ 1.6 %.
            assert!(
                (sd / sigma - 1.0).abs() < 0.06,
                "sigma {sigma}: sample {sd}"
            );
        }
    }

    #[test]
    fn radii_are_reproducible_and_seed_dependent() {
        let s = spec(SizeDistribution::Lognormal { sigma: 0.4 }, 50);
        assert_eq!(s.radii().unwrap(), s.radii().unwrap());
        let t = PackingSpec { seed: 1, ..s };
        assert_ne!(s.radii().unwrap(), t.radii().unwrap());
    }

    #[test]
    fn bimodal_counts_round_and_mean_is_kept() {
        // 0.5 * 7 = 3.5 rounds to 4 small ones.
        let s = spec(
            SizeDistribution::Bimodal {
                size_ratio: 1.566,
                small_fraction: 0.5,
            },
            7,
        );
        let r = s.radii().unwrap();
        let small = r[0];
        assert_eq!(r.iter().filter(|&&x| x == small).count(), 4);
        assert!((r[6] / small - 1.566).abs() < 1e-14);
        assert!((r.iter().sum::<f64>() / 7.0 - 0.05).abs() < 1e-15);
        let mono = spec(SizeDistribution::Monodisperse, 3).radii().unwrap();
        assert_eq!(mono, vec![0.05; 3]);
    }
}
