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
//! [`Packing::generate_unless`] and [`Packing::jam_unless`] report their
//! [`Progress`] to a callback that can stop them
//! ([`PackingError::Interrupted`]): thousands of particles near jamming
//! take minutes, and Ctrl-C must stop them at once.
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
//!    step of 1e-3 the packing is jammed. [`Packing::generate`] then
//!    decompresses it by 0.03, shakes it (random displacements up to one
//!    mean radius per component, rotations up to 0.3 rad) and compresses
//!    it again, 20 times at most (the repeated shakes anneal the packing
//!    towards denser, more ordered states), before
//!    [`PackingError::Rho0Unreachable`] reports the densest overlap-free
//!    density found. The last step lands exactly on `rho0`.
//! 4. [`Packing::jam`] does not shake: it refines the state of the first
//!    jam. The same steps, from a density step of 1e-3 halved down to
//!    1e-8, with the overlaps relaxed to 1e-10 mean radii, locate its
//!    jamming point; the last jammed state (force-balanced with overlaps
//!    of about 1e-8 mean radii) is shrunk until no overlap is left and,
//!    with the box scaled so that the particles have their full size,
//!    returned. (Shaken first, 8 and 16 spheres in a cube jammed in one
//!    ordered state whatever the seed, at 0.6443 and 0.6917, and 32
//!    crystallised into fcc for 6 seeds of 20.)
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
//! radii). [`Packing::jam`] with `rho0 = `[`RHO0_MAX`] returns the state
//! of the protocol's first jam: its contacts close to gaps of at most
//! 1e-6 mean radii and the next gaps are mostly beyond 1e-5, so a contact
//! tolerance of 1e-5 mean radii counts the contacts (32 spheres, the 19
//! jammed seeds of 0-19: contacts below 1e-7 for 18 seeds, below 1e-6 for
//! the 19th; the next gaps beyond 1e-5 for 17, but seeds 6 and 8 have
//! one or two pairs at 1e-6 to 1e-5). [`Packing::rattlers`] finds the particles
//! held by fewer than 4 contacts (removed round after round),
//! [`Packing::backbone_coordination_number`] the coordination number of the
//! rest.
//!
//! The jamming density is that of this protocol (compression rate,
//! tolerances) and of the system size, not a material constant. Measured
//! with `examples/jamming.rs` (release build, one core of a shared 2-core
//! machine, periodic cube, seeds 0-4, contacts at 1e-5 mean radii; mean and
//! range; `Z` all particles, `Z'` without rattlers):
//!
//! | spheres | jamming density | `Z` | `Z'` | rattlers | time per packing |
//! |---|---|---|---|---|---|
//! | 8 | 0.6427 (0.6423-0.6443) | 7.25 (7.00-8.25) | 7.25 (7.00-8.25) | 0 | below 0.01 s |
//! | 16 | 0.6070 (0.5757-0.6843) | 5.62 (5.38-5.75) | 5.70 (5.50-5.75) | 0-1 | below 0.01 s |
//! | 32 | 0.6400 (0.6325-0.6502) | 5.80 (5.50-5.88) | 5.87 (5.87-5.88) | 0-2 | 0.03-0.09 s |
//! | 64 | 0.6297 (0.6229-0.6354) | 5.90 (5.75-5.94) | 5.94 (5.94-5.94) | 0-2 | 0.09-0.20 s |
//! | 32 bimodal 1.566 / 0.5 | 0.6374 (0.6170-0.6508) | 5.51 (5.25-5.88) | 5.86 (5.85-5.88) | 0-5 | 0.02-0.07 s |
//!
//! Over seeds 0-19 the spread narrows with the count: 8 spheres
//! 0.6165-0.6443 (five states in all), 16 0.5757-0.6917, 32
//! 0.5983-0.6507 (19 seeds; the 20th at 0.74, below), 64 0.6154-0.6397.
//!
//! - Random packings of 32 and more spheres jam isostatic without their
//!   rattlers: `3 (N' - 1) + 1` contacts among `N'` particles (the
//!   frictionless count, `Z' -> 6`): 18 of the 19 jammed seeds of 20 for 32
//!   spheres (seed 6 a contact short), 17 of 20 for 64 (three a contact
//!   short).
//! - Small boxes still order at times: 8 spheres jam in one of five
//!   states (`Z` 6 to 8.25), 16 in a partly ordered one at 0.68-0.69 for 8
//!   seeds of 20, and 32 spheres crystallise into fcc (2 x 2 x 2 cells)
//!   for seed 15 of 20 and reach 0.74 itself: then [`Packing::jam`]
//!   returns [`Packing::generate`]'s packing at 0.74, whose particles
//!   hardly touch (`Z` 0.7 at 1e-5 mean radii). Check the coordination
//!   number.
//! - 256 spheres: 0.6391 (2 seeds), `Z'` 5.97-5.98, 14-17 s.
//! - In a die the walls loosen the packing: 32 spheres jam at 0.541-0.627
//!   (seeds 0-4) in 0.02-0.5 s. Spheroids c/a = 2: 16 jam at 0.684-0.702
//!   (seeds 0-4), `Z` 9.75 (isostatic: 10), in 0.7-1.8 s.
//! - [`PackingError::Rho0Unreachable`] from [`Packing::generate`] reports
//!   the densest state after the shakes, before any refinement; it is
//!   not that of [`Packing::jam`], which does not shake.
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
pub mod progress;
mod relax;
mod spec;

pub use error::PackingError;
pub use packing::{Contact, HOLDING_CONTACTS, OVERLAP_TOLERANCE, Packing, Wall, WallContact};
pub use particle::Particle;
pub use progress::{Progress, Stage};
pub use spec::{
    ASPECT_MAX, ASPECT_MIN, Boundary, MAX_PARTICLES, PackingSpec, RHO0_MAX, RHO0_MIN, SIGMA_MAX,
    SIZE_RATIO_MAX, SizeDistribution,
};
