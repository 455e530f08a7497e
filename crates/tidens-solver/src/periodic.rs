//! Periodic cells: whole particles at given places in a box periodic along
//! x, y and z, with the periodic images of the particles that the others
//! can touch across the box faces.
//!
//! Nothing bounds such a cell: no rigid plane, no die wall. Its height is
//! Lz + U, U the piston's displacement; its width and depth stay Lx and Ly,
//! so its mean strain is the die's uniaxial one. A particle touches another
//! across a box face through an image of the other: a copy of its curved
//! surface moved by whole periods (a Lx, b Ly, c (Lz + U)) whose nodes move
//! with their originals ([`crate::constraints::Constraints::set_images`]).
//! Each contact across the boundary is enforced by its two passes, each
//! particle's nodes on the other's image (an image is a master only).
//! Nothing holds a particle's rigid motions but its contacts, so a weak
//! drag does (`crate::evaluation::Stabilisation`), and one node is pinned.
//!
//! Python builds them with `tidens_rs.cells.periodic` (`as_periodic` of
//! a lattice cell, `random` for a random jammed packing). Measured on one
//! whole sphere in a cube
//! of side 2R (Ti-6Al-4V creep, 10 MPa, mesh level 1, plain mesh), against
//! the sc octant cell meshed alike: t(0.6) = 13.03 s against 13.64 s,
//! t(0.7) = 78.5 against 82.0, t(0.8) = 267.0 against 254.4 (the drag at
//! most 5.1 % of the piston force); but in 867 steps and 8206 Newton
//! iterations (165 failed attempts) against 119 and 239. Every contact there
//! is node on node (the image's mesh is the sphere's, moved), and Newton
//! stalls with directions that grow at nodes away from the contacts; a
//! drag a thousand times stronger converges in 242 iterations but moves
//! t(0.7) to 89 s, and ties holding each particle's core rotation, or the
//! consistent contact tangent, did not cure it.
//!
//! Turned off the cube's axes (mesh axis (0.31, 0.17, 1)), the sphere
//! touches its images facet to facet, every contact open at the start by
//! the faceting (4.8e-4 mm). With the touch stiffness in the tangent only,
//! the residual stayed the whole piston force at every iterate (nothing
//! carried it until a contact closed), the line search took 2 to 10 % of
//! each direction, and the run failed at its fifteenth step (t = 1e-7 s);
//! so did a 2 x 2 x 2 block of such spheres, each turned its own way. In a
//! periodic cell the touch stiffness is therefore a force too
//! ([`tidens_contact::ParticleContact::set_touch_force`]): the turned
//! sphere then passes the start, but Newton stays as slow as on the
//! aligned mesh (to t = 6.6 s, rho = 0.578: 600 steps, 6159 Newton
//! iterations, 136 failed attempts), so matching nodes are not what slows
//! it. What does, measured on the aligned sphere with TIDENS_DEBUG and the
//! rigid part of each Newton direction fitted over the sphere's nodes (a
//! scratch print): in a step of t = 0.937 s that took 25 iterations and
//! failed, each direction was a rotation about (1, -1, 1) moving the
//! surface by 3e-5 to 3.5e-4 mm, 30 to 200 times its deformation (at most
//! 1.7e-6 mm); the line search took 0.5 to 10 % of it, and the residual
//! grew from 6e-5 to 2e-4 N. Only the drag holds the rotation (at 1e-3
//! of the load). Turning the sphere turns its images with it, so at each
//! contact the two surfaces slide against each other; that faceted
//! surfaces resist this sliding where the tangent, linked to one facet,
//! does not see it is a guess, not checked. Holding the sphere's core (the
//! nodes within 0.45 R of its centre) by a drag 1e4 times stronger takes
//! it to rho = 0.7 in 119 steps and 631 Newton iterations (7 failed
//! attempts), but t(0.7) = 89.8 s against the octant's 82.0, and the drag
//! carried up to 1.03 times the load: that drag holds the core to the
//! cell's affine motion, which a core does not follow.
//!
//! So each particle's rigid rotation alone is held, by a drag on the
//! rotation fitted over six nodes of its core
//! (`crate::evaluation::RotationFrame`), charged as a drag of the load's
//! share `beta_rot = 1` would charge it on the whole particle. The aligned
//! sphere then reaches rho = 0.7 in 108 steps and 660 Newton iterations
//! (4 failed attempts), t(0.6) = 13.61 s and t(0.7) = 81.7 s against the
//! octant's 13.64 s and 82.0 s; the turned sphere in 142 steps and 1214
//! Newton iterations (t(0.6) = 12.71 s, t(0.7) = 79.8 s: its mesh is not
//! the octant's). `beta_rot` = 0.1 failed at rho = 0.567 (t = 3.8 s, steps
//! cut to 1e-14 s, the residual stalled at 1.2 times the tolerance), and
//! so did 10, at t = 35.4 s (rho about 0.645). The hold, like the drag,
//! stiffens as 1/de over short steps; capped at 0.7 E h (about the
//! elements' stiffness around a frame node; `ROTATION_HOLD_CAP`), the two
//! spheres of the bcc lattice reach rho = 0.8 (126 steps, 839 Newton
//! iterations) within 1.4 % of the bcc octant cell's times, where uncapped
//! they stalled at 0.774 with the residual largest at two frame nodes.
//!
//! Particles placed to touch at points between the meshes' nodes (a
//! jammed random packing) start with every contact open by the faceting;
//! those gaps are closed at the start without strain
//! (`crate::simulation::INITIAL_GAP_CLOSURE`). The lattices' contacts fall
//! on mesh nodes (poles, body diagonals), with no gap to close.

use crate::error::SolverError;
use crate::scene::{MeshOptions, Particle, Scene};
use tidens_mesh::{HexMesh, OctantSpec, divisions_for_level};

/// One spheroid of a periodic cell: centre, semi-axes and orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacedSpheroid {
    /// Centre \[mm\], in the box (each coordinate in [0, L)).
    pub centre: [f64; 3],
    /// Equatorial semi-axis \[mm\].
    pub a: f64,
    /// Semi-axis along `axis` \[mm\].
    pub c: f64,
    /// Symmetry axis (normalised here; any non-zero vector).
    pub axis: [f64; 3],
}

/// A periodic image of a particle: a copy of its curved-surface nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleImage {
    /// The particle (index into [`Scene::particles`]).
    pub particle: usize,
    /// Periods (a, b, c) it is moved by: a Lx, b Ly, c (Lz + U).
    pub periods: [i8; 3],
    /// The particle's curved-surface nodes, increasing; image node
    /// `first + k` is the copy of `originals[k]`.
    pub originals: Vec<usize>,
    /// First image node.
    pub first: usize,
}

impl ParticleImage {
    /// The image node of the particle's surface node `node`.
    pub fn node_of(&self, node: usize) -> Option<usize> {
        self.originals
            .binary_search(&node)
            .ok()
            .map(|k| self.first + k)
    }
}

/// What makes a scene a periodic cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Periodic {
    /// The images, each a particle's surface moved by whole periods.
    pub images: Vec<ParticleImage>,
    /// Nodes of the particles: the image nodes follow them.
    pub particle_nodes: usize,
}

/// Relative tolerance of the overlap check: a node of one particle may lie
/// this far inside another's spheroid (in its level function, 1 on the
/// surface), as touching particles' nodes do to round-off.
const OVERLAP_TOLERANCE: f64 = 1e-9;

/// The rotation (rows) that takes the z axis to the unit vector `n`.
fn rotation_to(n: [f64; 3]) -> [[f64; 3]; 3] {
    // A helper axis far from n, then e1 = helper x n normalised, e2 = n x e1.
    let helper = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let e1 = cross(helper, n);
    let norm = (e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]).sqrt();
    let e1 = e1.map(|v| v / norm);
    let e2 = cross(n, e1);
    // Columns e1, e2, n.
    std::array::from_fn(|r| [e1[r], e2[r], n[r]])
}

/// Level function of the spheroid `s` at `x`: 1 on its surface, below 1
/// inside.
fn level(s: &PlacedSpheroid, x: &[f64; 3]) -> f64 {
    let d = [0, 1, 2].map(|i| x[i] - s.centre[i]);
    let along = d[0] * s.axis[0] + d[1] * s.axis[1] + d[2] * s.axis[2];
    let across = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - along * along;
    across / (s.a * s.a) + along * along / (s.c * s.c)
}

/// The spheroids of a periodic cell, checked (positive finite box and
/// semi-axes, centres in the box, non-zero axes), their axes normalised.
pub(crate) fn check(
    lengths: [f64; 3],
    spheroids: &[PlacedSpheroid],
) -> Result<Vec<PlacedSpheroid>, SolverError> {
    for (i, l) in lengths.iter().enumerate() {
        if !(*l > 0.0 && l.is_finite()) {
            return Err(SolverError::parameter(
                ["lx", "ly", "lz"][i],
                *l,
                "> 0 mm and finite",
            ));
        }
    }
    if spheroids.is_empty() {
        return Err(SolverError::Unsupported(
            "a periodic cell needs at least one particle".into(),
        ));
    }
    spheroids
        .iter()
        .map(|s| {
            for (name, v) in [("a", s.a), ("c", s.c)] {
                if !(v > 0.0 && v.is_finite()) {
                    return Err(SolverError::parameter(name, v, "> 0 mm and finite"));
                }
            }
            for i in 0..3 {
                if !(s.centre[i] >= 0.0 && s.centre[i] < lengths[i]) {
                    return Err(SolverError::parameter(
                        "centre",
                        s.centre[i],
                        format!("in [0, {}) mm along axis {i}", lengths[i]),
                    ));
                }
            }
            let norm = s.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !(norm > 0.0 && norm.is_finite()) {
                return Err(SolverError::parameter(
                    "axis",
                    norm,
                    "a non-zero finite vector (its length)",
                ));
            }
            Ok(PlacedSpheroid {
                axis: s.axis.map(|v| v / norm),
                ..*s
            })
        })
        .collect()
}

impl Scene {
    /// A periodic cell of lengths `lengths` \[mm\] holding the whole
    /// spheroids `spheroids`, each meshed as the eight mirror images of
    /// its octant mesh at `options.level` ([`HexMesh::spheroid_whole`])
    /// and placed with its symmetry axis along its `axis`.
    ///
    /// The particles are meshed with their surface nodes on the spheroid
    /// (not with the exact volume, whose surface bulges out between its
    /// special points by up to 7e-3 of the radius at level 1 and would make
    /// touching particles overlap): the mesh misses O(h^2) of the particle
    /// volume, as an octant cell meshed without `exact_volume`.
    ///
    /// Every image of a particle whose centre lies within its bounding
    /// radius plus twice the largest one of the box is made (a particle in
    /// the box can reach it). Particles may touch but not overlap: no node
    /// of one may lie inside another, or inside an image of another.
    /// Hexahedra only.
    pub fn periodic(
        lengths: [f64; 3],
        spheroids: &[PlacedSpheroid],
        options: &MeshOptions,
    ) -> Result<Scene, SolverError> {
        options.validate()?;
        let spheroids = check(lengths, spheroids)?;
        let divisions = divisions_for_level(options.level)?;
        let mut mesh = HexMesh {
            nodes: Vec::new(),
            elements: Vec::new(),
            boundary: Vec::new(),
        };
        let mut particles = Vec::with_capacity(spheroids.len());
        for (k, s) in spheroids.iter().enumerate() {
            let spec = OctantSpec {
                a: s.a,
                c: s.c,
                divisions,
                grading: options.grading,
            };
            let piece = HexMesh::spheroid_whole(&spec)?.placed(rotation_to(s.axis), s.centre)?;
            particles.push(crate::scene::append_piece(&mut mesh, &piece, k));
        }
        let particle_nodes = mesh.nodes.len();
        let reach = image_reach(&spheroids);
        let mut images = Vec::new();
        for (k, s) in spheroids.iter().enumerate() {
            let mut originals: Vec<usize> =
                particles[k].surface.iter().flatten().copied().collect();
            originals.sort_unstable();
            originals.dedup();
            for periods in image_periods(s, lengths, reach) {
                let first = mesh.nodes.len();
                let copies: Vec<[f64; 3]> = originals
                    .iter()
                    .map(|&n| {
                        let p = mesh.nodes[n];
                        std::array::from_fn(|i| p[i] + f64::from(periods[i]) * lengths[i])
                    })
                    .collect();
                mesh.nodes.extend(copies);
                images.push(ParticleImage {
                    particle: k,
                    periods,
                    originals: originals.clone(),
                    first,
                });
            }
        }
        check_no_overlap(&mesh, &particles, &spheroids, &images, lengths)?;
        let volume: f64 = spheroids
            .iter()
            .map(|s| 4.0 / 3.0 * std::f64::consts::PI * s.a * s.a * s.c)
            .sum();
        Ok(Scene {
            lengths,
            lateral_walls: false,
            mesh,
            tet_mesh: None,
            particles,
            rho0_exact: Some(volume / (lengths[0] * lengths[1] * lengths[2])),
            radius: spheroids.iter().map(|s| s.a.max(s.c)).fold(0.0, f64::max),
            cell: None,
            mesh_options: Some(MeshOptions {
                exact_volume: false,
                ..*options
            }),
            periodic: Some(Periodic {
                images,
                particle_nodes,
            }),
        })
    }
}

/// The 26 non-zero periods (a, b, c), each in {-1, 0, 1}.
fn all_periods() -> impl Iterator<Item = [i8; 3]> {
    (0..27)
        .map(|k| [k % 3, k / 3 % 3, k / 9].map(|v| v as i8 - 1))
        .filter(|p| *p != [0, 0, 0])
}

/// How far outside the box an image's centre may lie and still be made:
/// twice the largest bounding radius (a particle in the box can reach it).
pub(crate) fn image_reach(spheroids: &[PlacedSpheroid]) -> f64 {
    2.0 * spheroids.iter().map(|s| s.a.max(s.c)).fold(0.0, f64::max)
}

/// The periods by which `s` is copied into images: those that leave its
/// centre within its bounding radius plus `reach` of the box.
pub(crate) fn image_periods(
    s: &PlacedSpheroid,
    lengths: [f64; 3],
    reach: f64,
) -> impl Iterator<Item = [i8; 3]> {
    all_periods().filter(move |periods| {
        let centre: [f64; 3] =
            std::array::from_fn(|i| s.centre[i] + f64::from(periods[i]) * lengths[i]);
        let outside: f64 = (0..3)
            .map(|i| (-centre[i]).max(centre[i] - lengths[i]).max(0.0).powi(2))
            .sum::<f64>()
            .sqrt();
        outside <= s.a.max(s.c) + reach
    })
}

/// Fails when a node of a particle lies inside another particle or an
/// image of another (or of itself).
fn check_no_overlap(
    mesh: &HexMesh,
    particles: &[Particle],
    spheroids: &[PlacedSpheroid],
    images: &[ParticleImage],
    lengths: [f64; 3],
) -> Result<(), SolverError> {
    // Every copy of every spheroid that a particle can meet: the originals
    // and the images made.
    let copies: Vec<(usize, [i8; 3])> = (0..spheroids.len())
        .map(|k| (k, [0; 3]))
        .chain(images.iter().map(|im| (im.particle, im.periods)))
        .collect();
    for (p, particle) in particles.iter().enumerate() {
        let s = &spheroids[p];
        let (first, count) = particle.nodes;
        for &(q, periods) in &copies {
            if q == p && periods == [0; 3] {
                continue;
            }
            let other = PlacedSpheroid {
                centre: std::array::from_fn(|i| {
                    spheroids[q].centre[i] + f64::from(periods[i]) * lengths[i]
                }),
                ..spheroids[q]
            };
            let d: f64 = (0..3)
                .map(|i| (other.centre[i] - s.centre[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            if d > s.a.max(s.c) + other.a.max(other.c) {
                continue;
            }
            if let Some(node) = mesh.nodes[first..first + count]
                .iter()
                .find(|x| level(&other, x) < 1.0 - OVERLAP_TOLERANCE)
            {
                return Err(SolverError::Unsupported(format!(
                    "periodic cell: particles {p} and {q} (moved by periods {periods:?}) overlap (a node of {p} at {node:?} is inside {q})"
                )));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(centre: [f64; 3], r: f64) -> PlacedSpheroid {
        PlacedSpheroid {
            centre,
            a: r,
            c: r,
            axis: [0.0, 0.0, 1.0],
        }
    }

    fn level(l: u32) -> MeshOptions {
        MeshOptions {
            level: l,
            grading: 1.0,
            exact_volume: false,
        }
    }

    #[test]
    fn a_simple_cubic_cell_is_one_whole_sphere_and_its_six_touching_images_and_more() {
        let r = 0.05;
        let scene = Scene::periodic([2.0 * r; 3], &[sphere([r; 3], r)], &level(2)).unwrap();
        let periodic = scene.periodic.as_ref().unwrap();
        // Centred in its box, every one of the 26 images is within reach.
        assert_eq!(periodic.images.len(), 26);
        assert_eq!(periodic.particle_nodes, scene.particles[0].nodes.1);
        // Image nodes are their originals moved by whole periods.
        for im in &periodic.images {
            for (k, &n) in im.originals.iter().enumerate() {
                let (p, q) = (scene.mesh.nodes[n], scene.mesh.nodes[im.first + k]);
                for i in 0..3 {
                    let shift = f64::from(im.periods[i]) * 2.0 * r;
                    assert!((q[i] - p[i] - shift).abs() < 1e-15);
                }
            }
        }
        // The mesh volume is the octant's, eight times: rho0 to O(h^2).
        let rho = scene.mesh.volume() / (8.0 * r * r * r);
        let exact = std::f64::consts::PI / 6.0;
        assert!(rho < exact && rho > 0.98 * exact, "{rho}");
        assert!((scene.rho0_exact.unwrap() - exact).abs() < 1e-12);
    }

    #[test]
    fn a_prolate_spheroid_is_placed_along_its_axis() {
        let n = [1.0, 2.0, 2.0];
        let scene = Scene::periodic(
            [1.0; 3],
            &[PlacedSpheroid {
                centre: [0.5; 3],
                a: 0.1,
                c: 0.3,
                axis: n,
            }],
            &level(1),
        )
        .unwrap();
        // The farthest node from the centre is a pole, along n / 3.
        let far = scene.mesh.nodes[..scene.particles[0].nodes.1]
            .iter()
            .map(|p| [p[0] - 0.5, p[1] - 0.5, p[2] - 0.5])
            .max_by(|a, b| {
                let l = |v: &[f64; 3]| v.iter().map(|x| x * x).sum::<f64>();
                l(a).total_cmp(&l(b))
            })
            .unwrap();
        for i in 0..3 {
            assert!((far[i].abs() - 0.3 * n[i] / 3.0).abs() < 1e-12, "{far:?}");
        }
    }

    #[test]
    fn overlapping_particles_and_bad_cells_are_refused() {
        let r = 0.05;
        // Two spheres 1.9 r apart, and a sphere wider than its box (it
        // overlaps its own image).
        assert!(
            Scene::periodic(
                [1.0; 3],
                &[sphere([0.3; 3], r), sphere([0.3 + 1.9 * r, 0.3, 0.3], r)],
                &level(1)
            )
            .is_err()
        );
        assert!(
            Scene::periodic(
                [1.9 * r, 1.0, 1.0],
                &[sphere([0.05, 0.5, 0.5], r)],
                &level(1)
            )
            .is_err()
        );
        // Touching across the boundary is fine.
        assert!(
            Scene::periodic(
                [1.0; 3],
                &[sphere([r, 0.5, 0.5], r), sphere([1.0 - r, 0.5, 0.5], r)],
                &level(1)
            )
            .is_ok()
        );
        assert!(Scene::periodic([1.0; 3], &[], &level(1)).is_err());
        assert!(Scene::periodic([1.0; 3], &[sphere([1.0, 0.5, 0.5], r)], &level(1)).is_err());
        assert!(Scene::periodic([0.0, 1.0, 1.0], &[sphere([0.5; 3], r)], &level(1)).is_err());
        let mut bad = sphere([0.5; 3], r);
        bad.axis = [0.0; 3];
        assert!(Scene::periodic([1.0; 3], &[bad], &level(1)).is_err());
    }
}
