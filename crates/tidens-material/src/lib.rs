//! Material laws of tidens (units: MPa, s).
//!
//! One law, in two layers:
//! - [`Material`]: Hencky (logarithmic) isotropic elasticity with von Mises (J2)
//!   Norton viscoplasticity, `eps_dot = C q^n`, zero yield stress, isochoric
//!   flow. Its scalar backward-Euler return is
//!   [`Material::return_map`].
//! - [`Material::update_deviatoric`]: the finite-strain material point, the
//!   multiplicative split `F = Fe Fp` integrated with the exponential map. It
//!   returns the deviatoric Kirchhoff stress and its consistent spatial tangent;
//!   the volumetric (purely elastic) part is left to the element, which uses the
//!   element's mean dilatation (see `tidens-fem`).
//!
//! Presets for the paper's six materials are in [`Preset`]; the 3x3 symmetric
//! eigen-solver behind the return is [`symmetric_eigen`].

mod eigen3;
mod error;
mod finite_strain;
mod params;
mod presets;
mod return_map;
mod state;

pub use eigen3::{SymmetricEigen3, symmetric_eigen};
pub use error::MaterialError;
pub use finite_strain::{DeviatoricResponse, SpatialTangent};
pub use params::Material;
pub use presets::{DEFAULT_POISSON, DEFAULT_YOUNG_MPA, Preset, tmp_creep_coefficient};
pub use return_map::ReturnMap;
pub use state::PointState;
