//! What a run will need, known before it is set up: its nodes, elements,
//! unknowns and peak memory.
//!
//! A random packing of 10000 particles at mesh level 1 has some 45 million
//! unknowns and would need hundreds of GB; setting it up only to fail (or
//! to bring the machine down) takes long, so a caller asks first.
//!
//! - A cell of octants (at most eight) is meshed as the run would mesh it
//!   ([`Scene::from_cell`], then [`Scene::with_element`]) and its rigid
//!   planes classified ([`Constraints::new`]): the counts are the run's. It
//!   is meshed without `exact_volume`, which moves nodes but keeps their
//!   number and every contact point (the poles, the diagonal points) on the
//!   spheroid, so the same dofs meet the planes.
//! - A periodic cell of many whole particles is not meshed: a particle's
//!   mesh depends only on the level and, through its layout's radial layers
//!   ([`radial_divisions`]), on its aspect ratio, so one particle of each
//!   layout is meshed and the images are counted as
//!   [`Scene::periodic`] makes them (`periodic::image_periods`). Every
//!   particle node has three unknowns but the first particle's first node,
//!   pinned; image nodes follow their originals; the piston adds one.
//!
//! The peak memory is [`BASE_BYTES`] plus a measured number of bytes per
//! unknown ([`HEX8_BYTES_PER_DOF`], [`TET10_BYTES_PER_DOF`]). Measured as
//! the peak resident set of `tidens run --cell ... --until-time 0.05
//! --no-error-estimate --stress 10` (`/usr/bin/time -v`, release build, one
//! thread of a shared 2-core machine, 2026-12; kB = 1024 bytes): the Python
//! process with tidens loaded (`python -c "import tidens_rs.cli"`) peaks at
//! 39156 kB; the runs, over their unknowns,
//!
//! | cell | element | level | unknowns | peak RSS | kB per unknown above 39156 kB |
//! |---|---|---|---|---|---|
//! | `random --particles 8` | hex8 | 1 | 36022 | 477752 kB | 12.2 |
//! | `random --particles 16` | hex8 | 1 | 72046 | 947552 kB | 12.6 |
//! | bcc | hex8 | 3 | 8689 | 143068 kB | 12.0 |
//! | fcc | hex8 | 3 | 17377 | 245548 kB | 11.9 |
//! | sc | hex8 | 5 | 32684 | 459096 kB | 12.9 |
//! | bcc | tet10 | 3 | 65377 | 1048356 kB | 15.4 |
//!
//! The memory grows in proportion to the unknowns over
//! this range; a sparse Cholesky factor of a 3-D mesh grows faster (its
//! fill as `n^(4/3)` under nested dissection), so for cells far larger than
//! these the estimate is a lower bound, which is what refusing a run that
//! cannot fit needs.

use crate::cell::Cell;
use crate::constraints::Constraints;
use crate::error::SolverError;
use crate::periodic::{self, PlacedSpheroid};
use crate::scene::{MeshOptions, Scene};
use std::collections::BTreeMap;
use tidens_fem::ElementKind;
use tidens_mesh::{HexMesh, OctantShape, OctantSpec, divisions_for_level, radial_divisions};

/// The peak resident set of the Python process with tidens loaded, before
/// any run (measured: 39156 kB).
pub const BASE_BYTES: u64 = 40 << 20;

/// Peak bytes per unknown of a hexahedral run: the largest of the hex8
/// measurements in the module docs (12.9 kB; the others 11.9-12.6).
pub const HEX8_BYTES_PER_DOF: u64 = 13_200;

/// Peak bytes per unknown of a 10-node tetrahedral run (measured 15.4 kB).
pub const TET10_BYTES_PER_DOF: u64 = 15_800;

/// The size of a run: what its simulation will report
/// (`Simulation::body().nodes().len()`, the elements,
/// [`crate::Simulation::degrees_of_freedom`] at the start) and its estimated
/// peak memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SizeEstimate {
    /// Mesh nodes, periodic image nodes included.
    pub nodes: usize,
    /// Elements (hexahedra, or 10-node tetrahedra).
    pub elements: usize,
    /// Unknowns at the start: free displacement components plus the piston.
    pub degrees_of_freedom: usize,
    /// Estimated peak memory of the process running it \[bytes\].
    pub peak_memory_bytes: u64,
}

impl SizeEstimate {
    fn new(nodes: usize, elements: usize, dofs: usize, kind: ElementKind) -> Self {
        let per_dof = match kind {
            ElementKind::Hex8 => HEX8_BYTES_PER_DOF,
            ElementKind::Tet10 => TET10_BYTES_PER_DOF,
        };
        SizeEstimate {
            nodes,
            elements,
            degrees_of_freedom: dofs,
            peak_memory_bytes: BASE_BYTES.saturating_add(per_dof.saturating_mul(dofs as u64)),
        }
    }

    /// The size of a run of the cell of octants `cell` meshed with
    /// `options` (its level; grading and `exact_volume` do not change the
    /// counts) in elements of `kind`. Meshes the cell: about as long as
    /// setting the run up takes before its first step.
    ///
    /// # Errors
    /// As [`Scene::from_cell`] and [`Scene::with_element`]: a level or
    /// grading out of range, a mesh that cannot be built.
    pub fn of_cell(
        cell: &Cell,
        options: &MeshOptions,
        kind: ElementKind,
    ) -> Result<Self, SolverError> {
        let plain = MeshOptions {
            exact_volume: false,
            ..*options
        };
        let scene = Scene::from_cell(cell, &plain)?.with_element(kind)?;
        let constraints = Constraints::new(
            scene.nodes(),
            scene.boundary_faces(),
            scene.lengths,
            scene.lateral_walls,
            false,
        )?;
        let elements = match &scene.tet_mesh {
            Some(t) => t.elements.len(),
            None => scene.mesh.elements.len(),
        };
        Ok(Self::new(
            scene.nodes().len(),
            elements,
            constraints.unknowns(),
            kind,
        ))
    }

    /// The size of a run of the periodic cell of whole `spheroids` in the
    /// box `lengths` \[mm\] meshed with `options` (hexahedra only, as
    /// [`Scene::periodic`]), without meshing it: one particle of each
    /// layout is meshed (see the module docs). Milliseconds for 10000
    /// particles.
    ///
    /// # Errors
    /// As [`Scene::periodic`] for the box, the spheroids and the options;
    /// overlaps are not looked for.
    pub fn of_periodic(
        lengths: [f64; 3],
        spheroids: &[PlacedSpheroid],
        options: &MeshOptions,
    ) -> Result<Self, SolverError> {
        options.validate()?;
        let spheroids = periodic::check(lengths, spheroids)?;
        let divisions = divisions_for_level(options.level)?;
        // Nodes, elements and curved-surface nodes of one whole particle,
        // by the radial layers of its layout.
        let mut meshed: BTreeMap<usize, (usize, usize, usize)> = BTreeMap::new();
        let reach = periodic::image_reach(&spheroids);
        let (mut particle_nodes, mut image_nodes, mut elements) = (0, 0, 0);
        for s in &spheroids {
            let layers = radial_divisions(divisions, &OctantShape::for_aspect(s.c / s.a));
            let (nodes, cells, surface) = match meshed.get(&layers) {
                Some(&counts) => counts,
                None => {
                    let spec = OctantSpec {
                        a: s.a,
                        c: s.c,
                        divisions,
                        grading: options.grading,
                    };
                    let counts = whole_particle_counts(&HexMesh::spheroid_whole(&spec)?);
                    meshed.insert(layers, counts);
                    counts
                }
            };
            particle_nodes += nodes;
            elements += cells;
            image_nodes += surface * periodic::image_periods(s, lengths, reach).count();
        }
        // Three unknowns a particle node, but the pinned node's, and the
        // piston's.
        let dofs = 3 * particle_nodes - 3 + 1;
        Ok(Self::new(
            particle_nodes + image_nodes,
            elements,
            dofs,
            ElementKind::Hex8,
        ))
    }
}

/// Nodes, elements and nodes of the (all curved) boundary of a particle's
/// mesh.
fn whole_particle_counts(mesh: &HexMesh) -> (usize, usize, usize) {
    let mut on_surface = vec![false; mesh.nodes.len()];
    for face in &mesh.boundary {
        for &n in &face.nodes {
            on_surface[n] = true;
        }
    }
    let surface = on_surface.iter().filter(|&&s| s).count();
    (mesh.nodes.len(), mesh.elements.len(), surface)
}
