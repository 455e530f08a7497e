//! Frictionless contact of test surfaces: penalty 100 MPa/mm, the
//! solver's tangent (no curvature part), no cap on the touch stiffness.

use tidens_contact::{ContactMode, ContactSettings, ContactSurface, ParticleContact};

/// Frictionless contact among `surfaces`, searching `search_distance` \[mm\].
pub fn frictionless(surfaces: Vec<ContactSurface>, search_distance: f64) -> ParticleContact {
    ParticleContact::new(
        surfaces,
        ContactSettings {
            mode: ContactMode::Frictionless,
            penalty: 100.0,
            search_distance,
            curvature_stiffness: false,
            touch_stiffness_cap: f64::INFINITY,
        },
    )
    .unwrap()
}
