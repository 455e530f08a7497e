//! [`Packing`]: generation, density, contacts and overlaps.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::compress::{Compressed, Problem, compress};
use crate::distribution::{PLACEMENT_STREAM, stream};
use crate::error::PackingError;
use crate::neighbours::{self, Cell};
use crate::overlap;
use crate::particle::Particle;
use crate::progress::{Progress, Stopped};
use crate::spec::{Boundary, PackingSpec};

/// Largest overlap left in a generated packing, relative to the mean
/// volume-equivalent radius: [`Packing::max_overlap`] of a generated packing
/// is at most `OVERLAP_TOLERANCE * mean_radius` (the relaxation itself stops
/// at a tenth of it). [`Packing::from_text`] refuses overlaps above
/// `OVERLAP_TOLERANCE` times the smaller radius of the pair.
pub const OVERLAP_TOLERANCE: f64 = 1e-6;

/// Fewest contacts that hold a particle in place in [`Packing::rattlers`]:
/// `d + 1 = 4`, the fewest that can hold a frictionless sphere against every
/// direction of motion.
pub const HOLDING_CONTACTS: usize = 4;

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
    /// Below the jamming density the particles hardly touch (the growth stops
    /// once the overlaps are gone): see [`Packing::jam`] for a packing whose
    /// particles touch.
    ///
    /// # Errors
    /// [`PackingError::Parameter`] for a spec out of range,
    /// [`PackingError::BoxTooSmall`] when a box side is shorter than the
    /// largest particle diameter `2 max(a, c)`, and
    /// [`PackingError::Rho0Unreachable`] when the relaxation jams below
    /// `rho0`.
    pub fn generate(spec: &PackingSpec) -> Result<Packing, PackingError> {
        Self::generate_unless(spec, &mut |_| false)
    }

    /// [`Packing::generate`], telling `stop` how far it got before every
    /// FIRE iteration of the relaxation and stopping as soon as it answers
    /// true (see [`crate::progress`]: within milliseconds even for 10000
    /// particles). `stop` runs on the generating thread and is called
    /// thousands of times a second: keep it cheap, and rate-limit anything
    /// costly (a progress display, taking a lock) by the clock.
    ///
    /// With a `stop` that never answers true the packing is bit for bit
    /// that of [`Packing::generate`].
    ///
    /// # Errors
    /// As [`Packing::generate`], and [`PackingError::Interrupted`] when
    /// `stop` answered true.
    pub fn generate_unless(
        spec: &PackingSpec,
        stop: &mut dyn FnMut(&Progress) -> bool,
    ) -> Result<Packing, PackingError> {
        let (shapes, problem, found) = compressed(spec, false, stop)?;
        if found.density < spec.rho0 {
            return Err(PackingError::Rho0Unreachable {
                requested: spec.rho0,
                reached: found.density,
            });
        }
        assemble(spec, &shapes, &problem, &found)
    }

    /// A jammed packing: the protocol of [`Packing::generate`] run toward
    /// `spec.rho0` (typically [`crate::RHO0_MAX`], "as far as it goes"),
    /// returning the state where it first jams instead of shaking it
    /// (which anneals small boxes into ordered states) or reporting
    /// [`PackingError::Rho0Unreachable`]. That state is refined first: its
    /// jamming point is located by halving the density step down to 1e-8,
    /// relaxing to overlaps of 1e-10 times the mean radius, and the jammed
    /// state is shrunk until no overlap is left, so that the particles of
    /// its rigid backbone touch (gaps of at most 1e-6 times the mean radius,
    /// mostly 1e-9 to 1e-7; see the crate documentation for the measured
    /// densities and contact numbers, and [`Packing::rattlers`]).
    ///
    /// The particles are those of [`Packing::generate`] for the same spec
    /// (the same radii, semi-axes and aspect ratio, so the same mean radius);
    /// the state found, with the particles scaled down by `s` in the box
    /// `L` sized for `rho0`, has its centres and box scaled by `1 / s`, so
    /// that [`Packing::rel_density`] is the density reached, `rho0 s^3`. In a
    /// die every particle lies between the walls. When `rho0` itself is
    /// reached the packing is that of [`Packing::generate`], whose particles
    /// hardly touch (below the jamming density, or a crystal that reaches
    /// 0.74: 32 spheres in a cube form fcc for some seeds). The largest
    /// overlap is below
    /// [`OVERLAP_TOLERANCE`] times the mean radius; the same spec gives the
    /// same packing.
    ///
    /// # Errors
    /// [`PackingError::Parameter`] and [`PackingError::BoxTooSmall`] as for
    /// [`Packing::generate`] (the box sized for `rho0`);
    /// [`PackingError::Rho0Unreachable`] only when the random start cannot be
    /// relaxed or the packing fails the final overlap check (neither
    /// observed).
    pub fn jam(spec: &PackingSpec) -> Result<Packing, PackingError> {
        Self::jam_unless(spec, &mut |_| false)
    }

    /// [`Packing::jam`], asking `stop` before every FIRE iteration as
    /// [`Packing::generate_unless`] does.
    ///
    /// # Errors
    /// As [`Packing::jam`], and [`PackingError::Interrupted`] when `stop`
    /// answered true.
    pub fn jam_unless(
        spec: &PackingSpec,
        stop: &mut dyn FnMut(&Progress) -> bool,
    ) -> Result<Packing, PackingError> {
        let (shapes, problem, found) = compressed(spec, true, stop)?;
        assemble(spec, &shapes, &problem, &found)
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

    /// The rattlers at the contact tolerance `tolerance` \[mm\]: `true` for
    /// each particle left with fewer than [`HOLDING_CONTACTS`] contacts
    /// (gap at most `tolerance`) when such particles are removed, with their
    /// contacts, round after round until every particle left has at least
    /// that many. Die walls count as contacts; a contact with the particle's
    /// own periodic image counts twice (as in
    /// [`Packing::coordination_number`]).
    pub fn rattlers(&self, tolerance: f64) -> Vec<bool> {
        self.backbone(tolerance).1
    }

    /// Mean number of particle-particle contacts per particle (gap at most
    /// `tolerance` \[mm\]) among the particles that are not rattlers (see
    /// [`Packing::rattlers`]), counting only the contacts between two of
    /// them: `2 x contacts / particles` of the rigid backbone. Wall contacts
    /// are not counted. 0 when every particle is a rattler.
    pub fn backbone_coordination_number(&self, tolerance: f64) -> f64 {
        let (contacts, rattler) = self.backbone(tolerance);
        let held = rattler.iter().filter(|&&r| !r).count();
        if held == 0 {
            return 0.0;
        }
        let kept = contacts
            .iter()
            .filter(|c| !rattler[c.i] && !rattler[c.j])
            .count();
        2.0 * kept as f64 / held as f64
    }

    /// The contacts within `tolerance` and the rattler flags.
    fn backbone(&self, tolerance: f64) -> (Vec<Contact>, Vec<bool>) {
        let contacts = self.contacts(tolerance);
        let mut count = vec![0usize; self.particles.len()];
        for c in &contacts {
            count[c.i] += 1;
            count[c.j] += 1;
        }
        for w in self.wall_contacts(tolerance) {
            count[w.particle] += 1;
        }
        let mut rattler = vec![false; self.particles.len()];
        loop {
            // The particles newly found held by too few contacts.
            let fresh: Vec<bool> = (0..count.len())
                .map(|k| !rattler[k] && count[k] < HOLDING_CONTACTS)
                .collect();
            if !fresh.contains(&true) {
                return (contacts, rattler);
            }
            for c in &contacts {
                // A contact with a particle removed in this round no longer
                // holds the other one.
                if fresh[c.i] || fresh[c.j] {
                    count[c.i] = count[c.i].saturating_sub(1);
                    count[c.j] = count[c.j].saturating_sub(1);
                }
            }
            for (r, f) in rattler.iter_mut().zip(fresh) {
                *r |= f;
            }
        }
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

/// The full-size particles of `spec` (centres at the origin), the problem in
/// the box sized for `spec.rho0`, and what [`compress`] finds (refining a
/// jammed state with `refine`, asking `stop` before every FIRE iteration).
fn compressed(
    spec: &PackingSpec,
    refine: bool,
    stop: &mut dyn FnMut(&Progress) -> bool,
) -> Result<(Vec<Particle>, Problem, Compressed), PackingError> {
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
    let problem = Problem {
        cell: Cell::new(lengths.into(), spec.boundary),
        die: spec.boundary == Boundary::Die,
        semi_axes,
        rho0: spec.rho0,
        mean_radius: spec.mean_radius,
        tolerance: 0.1 * OVERLAP_TOLERANCE * spec.mean_radius,
    };
    let mut rng = stream(spec.seed, PLACEMENT_STREAM);
    // The last progress reported, for the error of a stop.
    let mut last = Progress::new();
    let found = compress(&problem, &mut rng, refine, &mut |p| {
        last = *p;
        stop(p)
    });
    let found = found
        .map_err(|Stopped| PackingError::Interrupted {
            stage: last.stage,
            rel_density: last.rel_density,
            densest: last.densest,
        })?
        .ok_or(PackingError::Rho0Unreachable {
            requested: spec.rho0,
            reached: 0.0,
        })?;
    Ok((shapes, problem, found))
}

/// The packing of the full-size `shapes` in the state `found`: its centres
/// and the box of `problem` scaled by `1 / found.scale`, the centres wrapped
/// into the box and, in a die, put between the walls. Checked against
/// [`OVERLAP_TOLERANCE`].
fn assemble(
    spec: &PackingSpec,
    shapes: &[Particle],
    problem: &Problem,
    found: &Compressed,
) -> Result<Packing, PackingError> {
    let s = found.scale;
    let lengths: [f64; 3] = problem.cell.lengths.map(|l| l / s).into();
    let cell = Cell::new(lengths.into(), spec.boundary);
    let lz = lengths[2];
    let particles = shapes
        .iter()
        .zip(found.state.pos.iter().zip(&found.state.axis))
        .map(|(shape, (x, u))| {
            let axis = if shape.a == shape.c {
                [0.0, 0.0, 1.0]
            } else {
                u.into_inner().into()
            };
            let mut p = Particle {
                centre: cell.wrap(x / s).into(),
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
            reached: found.below,
        });
    }
    Ok(packing)
}
