use crate::error::MaterialError;
use serde::{Deserialize, Serialize};

/// Hencky elasticity + J2 Norton viscoplasticity, `eps_dot = C q^n`.
///
/// Units: `young` \[MPa\], `creep_c` [MPa^-n s^-1], `creep_n` [-]. The equivalent
/// plastic strain rate is `C q^n` with `q` the von Mises (Kirchhoff) stress;
/// there is no yield stress, so this is the "rate-dependent perfectly plastic"
/// form of the steady creep law `sigma = (eps_dot / C)^(1/n)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Young's modulus E \[MPa\].
    pub young: f64,
    /// Poisson's ratio nu [-].
    pub poisson: f64,
    /// Norton coefficient C [MPa^-n s^-1].
    pub creep_c: f64,
    /// Norton exponent n [-].
    pub creep_n: f64,
}

/// Allowed ranges, stated once so errors and docs agree.
const YOUNG_RANGE: (f64, f64) = (1e-3, 1e9);
const POISSON_RANGE: (f64, f64) = (-0.99, 0.4999);
const C_RANGE: (f64, f64) = (1e-30, 1e6);
const N_RANGE: (f64, f64) = (1.0, 50.0);

fn check(
    name: &'static str,
    value: f64,
    (lo, hi): (f64, f64),
    allowed: &'static str,
) -> Result<(), MaterialError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(MaterialError::Parameter {
            name,
            value,
            allowed,
        })
    }
}

impl Material {
    /// A validated material. Ranges: `1e-3 <= E <= 1e9` MPa,
    /// `-0.99 <= nu <= 0.4999`, `1e-30 <= C <= 1e6` MPa^-n s^-1, `1 <= n <= 50`.
    pub fn new(
        young: f64,
        poisson: f64,
        creep_c: f64,
        creep_n: f64,
    ) -> Result<Self, MaterialError> {
        check("E", young, YOUNG_RANGE, "in [1e-3, 1e9] MPa")?;
        check("nu", poisson, POISSON_RANGE, "in [-0.99, 0.4999]")?;
        check("C", creep_c, C_RANGE, "in [1e-30, 1e6] MPa^-n s^-1")?;
        check("n", creep_n, N_RANGE, "in [1, 50]")?;
        Ok(Self {
            young,
            poisson,
            creep_c,
            creep_n,
        })
    }

    /// Shear modulus G = E / (2 (1 + nu)) \[MPa\].
    pub fn shear_modulus(&self) -> f64 {
        self.young / (2.0 * (1.0 + self.poisson))
    }

    /// Bulk modulus K = E / (3 (1 - 2 nu)) \[MPa\].
    pub fn bulk_modulus(&self) -> f64 {
        self.young / (3.0 * (1.0 - 2.0 * self.poisson))
    }

    /// Constrained (P-wave) modulus M = K + 4 G / 3 \[MPa\]: the uniaxial-strain
    /// stiffness of the elastic solid.
    pub fn constrained_modulus(&self) -> f64 {
        self.bulk_modulus() + 4.0 / 3.0 * self.shear_modulus()
    }

    /// Steady creep rate at von Mises stress `q` \[MPa\]: `C q^n` \[1/s\].
    pub fn creep_rate(&self, q: f64) -> f64 {
        self.creep_c * q.powf(self.creep_n)
    }
}
