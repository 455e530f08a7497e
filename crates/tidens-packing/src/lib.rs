//! Random dense packings of spheres and spheroids: the initial geometry of a
//! random-packing cell for tidens. Units: mm.
//!
//! [`Packing`] (the entry type) holds the box (`lengths`, mm), its
//! [`Boundary`] (periodic in x, y, z, or a die: periodic in x and y between
//! rigid walls `z = 0` and `z = Lz`) and the [`Particle`]s: spheroids with
//! equatorial semi-axis `a`, semi-axis `c` along a unit `axis` (spheres:
//! `c = a`). [`Packing::generate`] makes one from a [`PackingSpec`] (count,
//! [`SizeDistribution`] of the volume-equivalent radius `(a^2 c)^(1/3)` with
//! number mean `mean_radius`, aspect ratio `c / a`, target relative density
//! `rho0`, box shape, seed); [`Packing::from_text`] reads one.
//!
//! # Method
//! Overlap relaxation with box compression, the zero-temperature jamming
//! protocol of O'Hern, Silbert, Liu and Nagel (Phys. Rev. E 68 (2003)
//! 011306):
//!
//! 1. the box is sized for `rho0` (so the density is exact) and the particles
//!    are placed uniformly at random (uniform random axes for spheroids) with
//!    their sizes scaled down to a relative density of 0.25 (growing the
//!    particles in the final box is the same geometry as shrinking the box
//!    around them);
//! 2. the overlap energy `U = 1/2 sum h^2` over the overlapping pairs (gap
//!    `h < 0`, every periodic image) and, in a die, over the particles
//!    crossing a wall, is minimised by FIRE (Bitzek et al., Phys. Rev. Lett.
//!    97 (2006) 170201) over the centres and, for spheroids, the axes
//!    (torques from the gradient of `U`), down to a largest overlap of
//!    `1e-7 x mean_radius`;
//! 3. the particles grow by a density step (at most 0.05) and are relaxed
//!    again. A step that ends force-balanced with overlaps left (jammed) is
//!    undone and halved; the jammed state, shrunk until no overlap is left,
//!    replaces the last good state when it is denser. Below a
//!    step of 1e-3 the packing is decompressed by 0.03, shaken (random
//!    displacements up to one mean radius per component, rotations up to 0.3
//!    rad) and compressed again, 20 times at most (the repeated shakes anneal
//!    the packing towards denser states), before
//!    [`PackingError::Rho0Unreachable`] reports the densest overlap-free
//!    density found. The last step lands exactly on `rho0`.
//!
//! The gap between two spheroids is the distance by which their centres
//! must approach along the centre line for them to touch, from the
//! Perram-Wertheim contact function `F` (J. W. Perram, M. S. Wertheim, J.
//! Comput. Phys. 58 (1985) 409): `h = |d| (1 - 1/sqrt(F))`, exact at contact,
//! `|d| - r1 - r2` for spheres (see [`Particle::gap`]).
//!
//! The same seed gives a bit-identical packing: the random streams are
//! ChaCha8 (platform independent, radii and placement on separate streams)
//! and the arithmetic is sequential. Other platforms agree bit for bit as
//! long as their `cbrt`, `sin`/`cos`, `exp` and `ln` round alike (used for
//! the box size, the rotations and the lognormal radii).
//!
//! # Limits
//! Measured with `examples/pack_timing.rs` (release build, one core of a
//! shared 2-core machine, 3 seeds each); "densest" is the density reported by
//! [`PackingError::Rho0Unreachable`] when asking for 0.74.
//! - Monodisperse spheres in a periodic cube reach rho0 = 0.62 for 8 to 64
//!   particles in 0.002-0.13 s (1000 spheres: 0.3-0.6 s, 10000: 3.8 s). Densest:
//!   0.635-0.664 for 64 spheres (0.639 for 256); 16 spheres order into a
//!   crystal near 0.692 (the shakes let small systems order). A target above
//!   what the protocol reaches (0.70 for 40 spheres, say) is refused with
//!   [`PackingError::Rho0Unreachable`] after the shakes.
//! - Bimodal spheres (size ratio 1.566, half small): densest 0.631-0.645 for
//!   16, 0.646-0.653 for 64.
//! - Prolate spheroids c/a = 2 (axes relaxed): 0.62 in 0.02-0.13 s; densest
//!   0.700-0.702 (16, about 10 s) and 0.699-0.701 (64, about 75 s).
//! - Die walls lower the density a random packing reaches (the layers at the
//!   walls are looser than the bulk): densest 0.559 for 16 spheres in a
//!   cube, 0.594-0.597 for 64, 0.633 for 256, 0.631 for 64 in a box three
//!   times as tall; spheroids c/a = 2 in a die: 0.649-0.656 (16), 0.666-0.668
//!   (64). rho0 = 0.62 is out of reach for small die cells of spheres.
//! - Every box side must be at least the largest particle diameter
//!   `2 max(a, c)` ([`PackingError::BoxTooSmall`]).
//! - Contacts and overlaps consider every periodic image (not only the
//!   nearest), so small boxes and lattice unit cells are handled.
//! - The cost grows with the particle count (cell list above 64 particles)
//!   and much more with a target near jamming (a refused target costs the
//!   20 shakes); spheroids cost about ten times as much as spheres
//!   (Perram-Wertheim per contact).

mod compress;
mod distribution;
mod error;
pub mod io;
mod neighbours;
mod overlap;
mod packing;
mod particle;
mod relax;
mod spec;

pub use error::PackingError;
pub use packing::{Contact, OVERLAP_TOLERANCE, Packing, Wall, WallContact};
pub use particle::Particle;
pub use spec::{
    ASPECT_MAX, ASPECT_MIN, Boundary, MAX_PARTICLES, PackingSpec, RHO0_MAX, RHO0_MIN, SIGMA_MAX,
    SIZE_RATIO_MAX, SizeDistribution,
};
