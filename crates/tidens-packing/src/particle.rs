//! One spheroidal particle.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::overlap::{self, Shape};

/// A spheroid: centre, equatorial semi-axis `a`, semi-axis `c` along the unit
/// symmetry axis `axis`. All lengths in mm. A sphere has `c == a` (its axis is
/// then irrelevant and is `[0, 0, 1]` in generated packings). `c > a` is
/// prolate, `c < a` oblate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Particle {
    /// Centre \[mm\].
    pub centre: [f64; 3],
    /// Equatorial semi-axis \[mm\].
    pub a: f64,
    /// Semi-axis along `axis` \[mm\].
    pub c: f64,
    /// Unit symmetry axis.
    pub axis: [f64; 3],
}

impl Particle {
    /// Volume `4/3 pi a^2 c` \[mm^3\].
    pub fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.a * self.a * self.c
    }

    /// Volume-equivalent radius `(a^2 c)^(1/3)` \[mm\].
    pub fn equivalent_radius(&self) -> f64 {
        (self.a * self.a * self.c).cbrt()
    }

    /// Radius of the smallest sphere about the centre holding the particle,
    /// `max(a, c)` \[mm\].
    pub fn bounding_radius(&self) -> f64 {
        self.a.max(self.c)
    }

    /// Half-width of the particle along the unit vector `n` (its support
    /// function `sqrt(a^2 + (c^2 - a^2) (axis . n)^2)`) \[mm\]: the particle
    /// lies between the planes `n . (x - centre) = ±support(n)`.
    pub fn support(&self, n: [f64; 3]) -> f64 {
        self.shape().support(&Vector3::from(n))
    }

    /// Gap between the surfaces of `self` and `other` (no periodic images)
    /// \[mm\]: the distance by which the centres must approach along their
    /// centre line for the particles to touch; negative for an overlap of that
    /// depth. Computed from the Perram-Wertheim contact function `F` as
    /// `|d| (1 - 1/sqrt(F))`, `d` the centre distance vector; for two spheres
    /// it is exactly `|d| - r1 - r2`. For coincident centres it is minus the
    /// smallest possible contact distance `min(a1, c1) + min(a2, c2)`.
    pub fn gap(&self, other: &Particle) -> f64 {
        overlap::gap(
            Vector3::from(other.centre) - Vector3::from(self.centre),
            &self.shape(),
            &other.shape(),
        )
    }

    pub(crate) fn shape(&self) -> Shape {
        Shape {
            a: self.a,
            c: self.c,
            axis: Vector3::from(self.axis),
        }
    }
}
