//! What to generate: [`PackingSpec`] and its parts, with their checks.

use serde::{Deserialize, Serialize};

use crate::error::{PackingError, check_closed, check_positive};

/// Largest particle count accepted by [`crate::Packing::generate`].
pub const MAX_PARTICLES: usize = 10_000;
/// Smallest target relative density.
pub const RHO0_MIN: f64 = 0.3;
/// Largest target relative density (that of the densest sphere packings).
pub const RHO0_MAX: f64 = 0.74;
/// Smallest aspect ratio `c / a`.
pub const ASPECT_MIN: f64 = 0.2;
/// Largest aspect ratio `c / a`.
pub const ASPECT_MAX: f64 = 5.0;
/// Largest bimodal size ratio.
pub const SIZE_RATIO_MAX: f64 = 10.0;
/// Largest lognormal sigma.
pub const SIGMA_MAX: f64 = 1.0;

/// Boundary of the packing cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Boundary {
    /// Periodic in x and y; rigid walls at z = 0 and z = Lz (a die). Every
    /// particle lies between the walls.
    Die,
    /// Periodic in x, y and z.
    Periodic,
}

impl Boundary {
    /// Whether the cell is periodic along axis `k` (0, 1, 2 = x, y, z).
    pub fn is_periodic(self, k: usize) -> bool {
        match self {
            Boundary::Periodic => true,
            Boundary::Die => k < 2,
        }
    }
}

/// Distribution of the volume-equivalent radius `(a^2 c)^(1/3)`. Every
/// distribution is scaled so that the number mean of the radii drawn is
/// exactly [`PackingSpec::mean_radius`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum SizeDistribution {
    /// All particles of the mean radius.
    Monodisperse,
    /// Two sizes.
    Bimodal {
        /// Large radius / small radius, in (1, 10].
        size_ratio: f64,
        /// Number fraction of small particles, in [0, 1]. The count of small
        /// particles is `round(small_fraction * particles)` (halves rounded
        /// away from zero); they are the first particles of the packing.
        small_fraction: f64,
    },
    /// `ln(radius)` normal with standard deviation `sigma`, in (0, 1]; the
    /// radii drawn are then scaled to the mean radius.
    Lognormal {
        /// Standard deviation of `ln(radius)`.
        sigma: f64,
    },
}

impl SizeDistribution {
    /// Checks the parameters of the distribution.
    pub fn validate(&self) -> Result<(), PackingError> {
        match *self {
            SizeDistribution::Monodisperse => Ok(()),
            SizeDistribution::Bimodal {
                size_ratio,
                small_fraction,
            } => {
                if !(size_ratio.is_finite() && size_ratio > 1.0 && size_ratio <= SIZE_RATIO_MAX) {
                    return Err(PackingError::Parameter {
                        name: "size_ratio",
                        value: size_ratio,
                        allowed: "in (1, 10]",
                    });
                }
                check_closed("small_fraction", small_fraction, 0.0, 1.0, "in [0, 1]")
            }
            SizeDistribution::Lognormal { sigma } => {
                if sigma.is_finite() && sigma > 0.0 && sigma <= SIGMA_MAX {
                    Ok(())
                } else {
                    Err(PackingError::Parameter {
                        name: "sigma",
                        value: sigma,
                        allowed: "in (0, 1]",
                    })
                }
            }
        }
    }
}

/// Specification of a random packing. Lengths in mm.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PackingSpec {
    /// Number of particles, in [1, 10000].
    pub particles: usize,
    /// Distribution of the volume-equivalent radius.
    pub distribution: SizeDistribution,
    /// Aspect ratio `c / a` of every particle, in [0.2, 5]; 1 gives spheres,
    /// > 1 prolate spheroids, < 1 oblate ones.
    pub aspect_ratio: f64,
    /// Number mean of the volume-equivalent radius `(a^2 c)^(1/3)` \[mm\],
    /// finite and > 0.
    pub mean_radius: f64,
    /// Target relative density (particle volume / box volume), in
    /// [0.3, 0.74]. The box is sized so that the packing has exactly this
    /// density.
    pub rho0: f64,
    /// Boundary of the cell.
    pub boundary: Boundary,
    /// Relative box side lengths (x, y, z), each finite and > 0; the box is
    /// `box_aspect * t` with `t` set by `rho0`.
    pub box_aspect: [f64; 3],
    /// Seed of the random streams (ChaCha8): the same spec gives the same
    /// packing.
    pub seed: u64,
}

impl Default for PackingSpec {
    /// 64 monodisperse spheres of radius 1 mm at rho0 = 0.6 in a periodic
    /// cube, seed 0.
    fn default() -> Self {
        PackingSpec {
            particles: 64,
            distribution: SizeDistribution::Monodisperse,
            aspect_ratio: 1.0,
            mean_radius: 1.0,
            rho0: 0.6,
            boundary: Boundary::Periodic,
            box_aspect: [1.0, 1.0, 1.0],
            seed: 0,
        }
    }
}

impl PackingSpec {
    /// Checks every parameter; the error names the first bad one, its value
    /// and the allowed range.
    pub fn validate(&self) -> Result<(), PackingError> {
        if !(1..=MAX_PARTICLES).contains(&self.particles) {
            return Err(PackingError::Parameter {
                name: "particles",
                value: self.particles as f64,
                allowed: "in [1, 10000]",
            });
        }
        check_closed("rho0", self.rho0, RHO0_MIN, RHO0_MAX, "in [0.3, 0.74]")?;
        check_closed(
            "aspect_ratio",
            self.aspect_ratio,
            ASPECT_MIN,
            ASPECT_MAX,
            "in [0.2, 5]",
        )?;
        check_positive("mean_radius", self.mean_radius)?;
        const NAMES: [&str; 3] = ["box_aspect[0]", "box_aspect[1]", "box_aspect[2]"];
        for (k, &b) in self.box_aspect.iter().enumerate() {
            check_positive(NAMES[k], b)?;
        }
        self.distribution.validate()
    }

    /// Semi-axes `(a, c)` \[mm\] of a particle of volume-equivalent radius
    /// `r`: `a = r q^(-1/3)`, `c = q a` with `q` the aspect ratio.
    pub(crate) fn semi_axes(&self, r: f64) -> (f64, f64) {
        if self.aspect_ratio == 1.0 {
            return (r, r);
        }
        let a = r / self.aspect_ratio.cbrt();
        (a, self.aspect_ratio * a)
    }
}
