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
//! `rho0`, box shape, seed); [`Packing::jam`] makes a jammed one, as dense
//! as the protocol gets, whose particles touch (see [Jammed
//! packings](#jammed-packings)); [`Packing::from_text`] reads one.
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
//! 4. [`Packing::jam`] then (instead of the error) refines the densest state:
//!    the same steps, from a density step of 1e-3 halved down to 1e-8, with
//!    the overlaps relaxed to 1e-10 mean radii, locate its jamming point;
//!    the last jammed state (force-balanced with overlaps of about 1e-8 mean
//!    radii) is shrunk until no overlap is left and, with the box scaled so
//!    that the particles have their full size, returned.
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
//! # Jammed packings
//! Below its jamming density a packing from [`Packing::generate`] hardly has
//! contacts (the growth stops once the overlaps are gone: 16 spheres at
//! 0.62 have a coordination number of 0.25-1.75 at a gap of 1e-3 mean
//! radii). [`Packing::jam`] with `rho0 = `[`RHO0_MAX`] returns the densest
//! state the protocol reaches, jammed: its contacts close to gaps of at most
//! 1e-6 mean radii (1.6e-7 for 32 spheres over 20 seeds), the next gaps are
//! at least 3e-6 (2.7e-5 for 32 spheres), so a contact tolerance of 1e-5
//! mean radii counts the contacts. [`Packing::rattlers`] finds the particles
//! held by fewer than 4 contacts (removed round after round),
//! [`Packing::backbone_coordination_number`] the coordination number of the
//! rest.
//!
//! The jamming density is that of this protocol (compression rate, shakes,
//! tolerances) and of the system size, not a material constant. Measured
//! with `examples/jamming.rs` (release build, one core of a shared 2-core
//! machine, periodic cube, seeds 0-4, contacts at 1e-5 mean radii; mean and
//! range; `Z` all particles, `Z'` without rattlers):
//!
//! | spheres | jamming density | `Z` | `Z'` | rattlers | time per packing |
//! |---|---|---|---|---|---|
//! | 8 | 0.6443 (every seed) | 8.25 | 8.25 | 0 | 0.01-0.04 s |
//! | 16 | 0.6917 (every seed) | 7.00 | 7.00 | 0 | 0.03-0.05 s |
//! | 32 | 0.6494 (0.6444-0.6507) | 5.70 (5.50-5.88) | 5.87 (5.87-5.88) | 0-2 | 0.29-0.43 s |
//! | 64 | 0.6518 (0.6353-0.6748) | 5.89 (5.75-6.00) | 5.96 (5.94-6.00) | 0-2 | 0.77-1.65 s |
//! | 32 bimodal 1.566 / 0.5 | 0.6522 (0.6480-0.6583) | 5.46 (5.12-5.81) | 5.84 (5.77-5.87) | 1-6 | 0.27-0.73 s |
//!
//! - Random packings of 32 and more spheres jam isostatic without their
//!   rattlers: `3 (N' - 1) + 1` contacts among `N'` particles (the
//!   frictionless count, `Z' -> 6`): every one of the 14 jammed seeds of 20
//!   measured for 32 spheres, 6 of 10 for 64 (three, at 0.664-0.675, partly
//!   ordered with two contacts more; one with a pair at a gap of 8e-7 mean
//!   radii, isostatic at a tolerance of 1e-7) and 9 of 10 bimodal 32 (one a
//!   contact short).
//! - 8 and 16 spheres order (hyperstatic, `Z` 8.25 and 7, the same state for
//!   every seed); 32 spheres in a cube crystallise into fcc (2 x 2 x 2 cells)
//!   in 6 of 20 seeds (6, 7, 9, 15, 16, 17) and reach 0.74 itself: then
//!   [`Packing::jam`] returns [`Packing::generate`]'s packing at 0.74, whose
//!   particles hardly touch (`Z` 0.2-0.7 at 1e-5 mean radii, 12 at 1e-2).
//!   Check the coordination number.
//! - 256 spheres: 0.6391 (2 seeds), `Z'` 5.97-5.98, 14-17 s.
//! - In a die the walls loosen the packing: 32 spheres jam at 0.568-0.627
//!   (seeds 0-4) in 0.1-0.7 s. Spheroids c/a = 2: 16 jam at 0.701-0.702,
//!   `Z` 9.75 (isostatic: 10), in 7-8 s (2 seeds).
//! - [`PackingError::Rho0Unreachable`] from [`Packing::generate`] reports
//!   the density before the refinement, 2e-5 to 1.1e-3 below that of
//!   [`Packing::jam`].
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
pub use packing::{Contact, HOLDING_CONTACTS, OVERLAP_TOLERANCE, Packing, Wall, WallContact};
pub use particle::Particle;
pub use spec::{
    ASPECT_MAX, ASPECT_MIN, Boundary, MAX_PARTICLES, PackingSpec, RHO0_MAX, RHO0_MIN, SIGMA_MAX,
    SIZE_RATIO_MAX, SizeDistribution,
};
