//! [`Packing`]: generation, density, contacts and overlaps.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::compress::{Problem, compress};
use crate::distribution::{PLACEMENT_STREAM, stream};
use crate::error::PackingError;
use crate::neighbours::{self, Cell};
use crate::overlap;
use crate::particle::Particle;
use crate::spec::{Boundary, PackingSpec};

/// Largest overlap left in a generated packing, relative to the mean
/// volume-equivalent radius: [`Packing::max_overlap`] of a generated packing
/// is at most `OVERLAP_TOLERANCE * mean_radius` (the relaxation itself stops
/// at a tenth of it). [`Packing::from_text`] refuses overlaps above
/// `OVERLAP_TOLERANCE` times the smaller radius of the pair.
pub const OVERLAP_TOLERANCE: f64 = 1e-6;

/// A random packing of spheroids in a box `[0, Lx) x [0, Ly) x [0, Lz)`
/// (mm). Centres lie in the box: wrapped into `[0, L)` along the periodic
/// sides; in a die each particle lies between the walls `z = 0` and
/// `z = Lz`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Packing {
    /// Box side lengths `[Lx, Ly, Lz]` \[mm\].
    pub lengths: [f64; 3],
    /// Boundary of the box.
    pub boundary: Boundary,
    /// The particles.
    pub particles: Vec<Particle>,
}

/// A contact (or near contact) between particle `i` and the image of
/// particle `j` shifted by `image` box lengths (`j`'s centre seen from `i`
/// is `centre_j + image * lengths`). `i <= j`; a particle touching its own
/// image has `i == j` and is listed once per pair of opposite images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// First particle.
    pub i: usize,
    /// Second particle.
    pub j: usize,
    /// Periodic image of `j`, in box lengths along x, y, z.
    pub image: [i32; 3],
    /// Surface gap \[mm\] (negative: overlap), see [`Particle::gap`].
    pub gap: f64,
}

/// A die wall.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wall {
    /// `z = 0`.
    Bottom,
    /// `z = Lz`.
    Top,
}

/// A particle at (or within a tolerance of) a die wall.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallContact {
    /// The particle.
    pub particle: usize,
    /// The wall.
    pub wall: Wall,
    /// Distance from the wall to the particle surface \[mm\] (negative: the
    /// particle crosses the wall).
    pub gap: f64,
}

impl Packing {
    /// Generates a random packing of `spec.particles` spheroids at the
    /// relative density `spec.rho0` (see the crate documentation for the
    /// method). The box is `spec.box_aspect * t`, with `t` chosen so that
    /// [`Packing::rel_density`] is `rho0` (to rounding). The largest overlap
    /// left is below [`OVERLAP_TOLERANCE`] times the mean radius.
    ///
    /// # Errors
    /// [`PackingError::Parameter`] for a spec out of range,
    /// [`PackingError::BoxTooSmall`] when a box side is shorter than the
    /// largest particle diameter `2 max(a, c)`, and
    /// [`PackingError::Rho0Unreachable`] when the relaxation jams below
    /// `rho0`.
    pub fn generate(spec: &PackingSpec) -> Result<Packing, PackingError> {
        let radii = spec.radii()?;
        let semi_axes: Vec<(f64, f64)> = radii.iter().map(|&r| spec.semi_axes(r)).collect();
        let shapes: Vec<Particle> = semi_axes
            .iter()
            .map(|&(a, c)| Particle {
                centre: [0.0; 3],
                a,
                c,
                axis: [0.0, 0.0, 1.0],
            })
            .collect();
        let volume: f64 = shapes.iter().map(Particle::volume).sum();
        let [bx, by, bz] = spec.box_aspect;
        let t = (volume / spec.rho0 / (bx * by * bz)).cbrt();
        let lengths = [bx * t, by * t, bz * t];
        let extent = 2.0
            * shapes
                .iter()
                .fold(0.0_f64, |m, p| m.max(p.bounding_radius()));
        for (axis, &length) in lengths.iter().enumerate() {
            if length < extent {
                return Err(PackingError::BoxTooSmall {
                    axis,
                    length,
                    extent,
                });
            }
        }
        let cell = Cell::new(lengths.into(), spec.boundary);
        let problem = Problem {
            cell,
            die: spec.boundary == Boundary::Die,
            semi_axes,
            rho0: spec.rho0,
            mean_radius: spec.mean_radius,
            tolerance: 0.1 * OVERLAP_TOLERANCE * spec.mean_radius,
        };
        let mut rng = stream(spec.seed, PLACEMENT_STREAM);
        let (state, below) =
            compress(&problem, &mut rng).map_err(|reached| PackingError::Rho0Unreachable {
                requested: spec.rho0,
                reached,
            })?;
        let lz = lengths[2];
        let particles = shapes
            .iter()
            .zip(state.pos.iter().zip(&state.axis))
            .map(|(shape, (x, u))| {
                let axis = if shape.a == shape.c {
                    [0.0, 0.0, 1.0]
                } else {
                    u.into_inner().into()
                };
                let mut p = Particle {
                    centre: cell.wrap(*x).into(),
                    axis,
                    ..*shape
                };
                if problem.die {
                    // Exactly between the walls (the relaxation leaves at most
                    // its tolerance); lz >= 2 max(a, c) >= 2 e by the box check.
                    let e = p.support([0.0, 0.0, 1.0]).min(0.5 * lz);
                    p.centre[2] = p.centre[2].clamp(e, lz - e);
                }
                p
            })
            .collect();
        let packing = Packing {
            lengths,
            boundary: spec.boundary,
            particles,
        };
        // Guard: never hand out a packing with a larger overlap than stated.
        if !(packing.max_overlap() <= OVERLAP_TOLERANCE * spec.mean_radius) {
            return Err(PackingError::Rho0Unreachable {
                requested: spec.rho0,
                reached: below,
            });
        }
        Ok(packing)
    }

    /// Box volume `Lx Ly Lz` \[mm^3\].
    pub fn box_volume(&self) -> f64 {
        self.lengths[0] * self.lengths[1] * self.lengths[2]
    }

    /// Total particle volume \[mm^3\] (each particle once, whatever its
    /// periodic images).
    pub fn particle_volume(&self) -> f64 {
        self.particles.iter().map(Particle::volume).sum()
    }

    /// Relative density: particle volume / box volume.
    pub fn rel_density(&self) -> f64 {
        self.particle_volume() / self.box_volume()
    }

    pub(crate) fn cell(&self) -> Cell {
        Cell::new(self.lengths.into(), self.boundary)
    }

    /// Every particle pair (periodic images included) whose gap is at most
    /// `extra` \[mm\], with its gap; centres wrapped first.
    fn pairs_within(&self, extra: f64) -> Vec<Contact> {
        let cell = self.cell();
        let centres: Vec<Vector3<f64>> = self
            .particles
            .iter()
            .map(|p| cell.wrap(p.centre.into()))
            .collect();
        let radii: Vec<f64> = self
            .particles
            .iter()
            .map(Particle::bounding_radius)
            .collect();
        neighbours::pairs(&cell, &centres, &radii, extra.max(0.0))
            .into_iter()
            .filter_map(|p| {
                let d = cell.separation(&centres[p.i], &centres[p.j], p.image);
                let gap = overlap::gap(
                    d,
                    &self.particles[p.i].shape(),
                    &self.particles[p.j].shape(),
                );
                (gap <= extra).then_some(Contact {
                    i: p.i,
                    j: p.j,
                    image: p.image,
                    gap,
                })
            })
            .collect()
    }

    /// Particle-particle contacts: every pair, over all periodic images (not
    /// only the nearest one, so boxes of any size are handled), whose gap is
    /// at most `tolerance` \[mm\] (overlaps included). Each contact is listed
    /// once, `i <= j`. Walls are not included: see
    /// [`Packing::wall_contacts`].
    pub fn contacts(&self, tolerance: f64) -> Vec<Contact> {
        self.pairs_within(tolerance)
    }

    /// Particles within `tolerance` \[mm\] of a die wall (or crossing it).
    /// Empty for a periodic box.
    pub fn wall_contacts(&self, tolerance: f64) -> Vec<WallContact> {
        if self.boundary != Boundary::Die {
            return Vec::new();
        }
        let lz = self.lengths[2];
        let mut out = Vec::new();
        for (k, p) in self.particles.iter().enumerate() {
            let e = p.support([0.0, 0.0, 1.0]);
            for (wall, gap) in [
                (Wall::Bottom, p.centre[2] - e),
                (Wall::Top, lz - p.centre[2] - e),
            ] {
                if gap <= tolerance {
                    out.push(WallContact {
                        particle: k,
                        wall,
                        gap,
                    });
                }
            }
        }
        out
    }

    /// Mean number of particle-particle contacts per particle (gap at most
    /// `tolerance` \[mm\]), `2 x contacts / particles`, periodic images
    /// included; wall contacts are not counted and rattlers are not removed.
    /// 0 for an empty packing.
    pub fn coordination_number(&self, tolerance: f64) -> f64 {
        if self.particles.is_empty() {
            return 0.0;
        }
        2.0 * self.contacts(tolerance).len() as f64 / self.particles.len() as f64
    }

    /// Largest overlap depth \[mm\] between two particles (periodic images
    /// included, see [`Particle::gap`]) or, in a die, of a particle across a
    /// wall; 0 when nothing overlaps.
    pub fn max_overlap(&self) -> f64 {
        let pairs = self
            .pairs_within(0.0)
            .iter()
            .fold(0.0_f64, |m, c| m.max(-c.gap));
        self.wall_contacts(0.0)
            .iter()
            .fold(pairs, |m, w| m.max(-w.gap))
    }
}
