//! What is simulated: a cell meshed into a scene (one mesh of all its
//! particles, with the curved surface of each), and the plain blocks of the
//! verification ladder.

use crate::cell::{Cell, FIT_TOLERANCE};
use crate::error::SolverError;
use serde::{Deserialize, Serialize};
use tidens_fem::ElementKind;
use tidens_mesh::{
    BoundaryFace, FaceKind, HexMesh, OctantSpec, TetBoundaryFace, TetMesh, divisions_for_level,
    project_to_spheroid,
};

/// Finest mesh level: level 6 needs about 2.5 GB for the sparse factor of the
/// sc cell, level 7 about four times that.
pub const MAX_MESH_LEVEL: u32 = 6;

/// Mesh resolution of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshOptions {
    /// Mesh level, 1 (coarsest usable) upward; each level refines the element
    /// size by about sqrt(2) (inner-cube divisions 4, 6, 8, 11, 16, ...).
    pub level: u32,
    /// Element-size ratio toward the contact points (1 = uniform).
    pub grading: f64,
    /// Give every particle's hexahedral mesh its exact volume pi a^2 c / 6.
    ///
    /// With surface nodes on the spheroid the bilinear facets lie inside the
    /// particle, and the mesh misses O(h^2) of its volume (rho0 = 0.5197
    /// instead of pi/6 = 0.5236 for the sc cell at level 2). Near full
    /// density the curve rho(t) is so flat that this deficit alone shifts the
    /// time to reach rho = 0.95 by several per cent. When set, the curved
    /// surface nodes are moved outward by O(h^2), along their rays from the
    /// particle centre ([`HexMesh::spheroid_octant_exact_volume`]): the mesh
    /// has the exact particle volume, so rho0 is exact; the contact points
    /// (poles, diagonal and face-diagonal points) stay on the spheroid, and no
    /// node crosses the tangent plane there, so touching particles still
    /// touch without overlap. Hexahedra only: 10-node tetrahedra keep their
    /// corners on the spheroid (their curved faces make the volume exact to
    /// O(h^4)).
    ///
    /// On by default: measured on bcc and fcc at 15 MPa, the times to 0.9
    /// and 0.95 change about half as much from level 2 to level 3 with it
    /// as without it (level 2 with it lies where level 3 without it lies);
    /// on sc the two mesh families converge alike.
    #[serde(default = "exact_volume_default")]
    pub exact_volume: bool,
}

fn exact_volume_default() -> bool {
    true
}

impl MeshOptions {
    /// Checks the level and the grading against their ranges.
    pub fn validate(&self) -> Result<(), SolverError> {
        if !(self.grading >= 1.0 && self.grading <= 10.0) {
            return Err(SolverError::parameter(
                "grading",
                self.grading,
                "in [1, 10]",
            ));
        }
        if !(1..=MAX_MESH_LEVEL).contains(&self.level) {
            return Err(SolverError::parameter(
                "mesh_level",
                self.level as f64,
                format!("an integer in [1, {MAX_MESH_LEVEL}]"),
            ));
        }
        Ok(())
    }
}

impl Default for MeshOptions {
    fn default() -> Self {
        Self {
            level: 3,
            grading: 1.0,
            exact_volume: exact_volume_default(),
        }
    }
}

/// One particle piece of a scene: its nodes and elements are contiguous
/// ranges of the scene's mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Particle {
    /// Index of the octant in the cell.
    pub octant: usize,
    /// First node and number of nodes.
    pub nodes: (usize, usize),
    /// First element and number of elements.
    pub elements: (usize, usize),
    /// Curved boundary quads of the hexahedra (scene node ids, outward
    /// right-hand normal).
    pub surface: Vec<[usize; 4]>,
    /// In a tet10 scene, the curved boundary as flat triangles (each 6-node
    /// face split into its three corner triangles and its middle one;
    /// nodes of the tetrahedral mesh, outward right-hand normal); empty in a
    /// hex8 scene. `nodes` and `elements` then count in the tetrahedral mesh.
    pub triangles: Vec<[usize; 3]>,
}

/// A meshed problem: the box, whether the lateral die walls exist, and the
/// body mesh. All six box faces are frictionless rigid mirror planes, except
/// the lateral high faces (x = Lx, y = Ly) when `lateral_walls` is false.
/// The top face z = Lz is the piston.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub lengths: [f64; 3],
    pub lateral_walls: bool,
    /// All particles in one mesh (no shared nodes between particles).
    pub mesh: HexMesh,
    /// When set, the body is meshed with these 10-node tetrahedra, cut from
    /// `mesh` (6 per hexahedron) with mid-edge nodes on the true surface.
    pub tet_mesh: Option<TetMesh>,
    /// The particle pieces (empty for the verification blocks).
    pub particles: Vec<Particle>,
    /// Exact initial relative density of the geometry (not of the mesh), if known.
    pub rho0_exact: Option<f64>,
    /// Length scale R of tolerances: the largest particle semi-axis, or the
    /// largest box edge for blocks \[mm\].
    pub radius: f64,
    /// The cell the scene was meshed from (none for the blocks).
    pub cell: Option<Cell>,
    /// The options the cell was meshed with (none for the blocks).
    pub mesh_options: Option<MeshOptions>,
    /// Set for a periodic cell ([`Scene::periodic`]): no rigid planes, and
    /// the particles' periodic images, whose nodes follow the particles'.
    pub periodic: Option<crate::periodic::Periodic>,
}

impl Scene {
    /// Meshes a cell: one spheroid octant mesh per particle, mirrored into
    /// its corner, all in one mesh. Particles must not overlap (touching is
    /// fine): no node of one may lie inside another's spheroid.
    pub fn from_cell(cell: &Cell, options: &MeshOptions) -> Result<Scene, SolverError> {
        options.validate()?;
        let divisions = divisions_for_level(options.level)?;
        let mut mesh = HexMesh {
            nodes: Vec::new(),
            elements: Vec::new(),
            boundary: Vec::new(),
        };
        let mut particles = Vec::with_capacity(cell.octants.len());
        for (k, octant) in cell.octants.iter().enumerate() {
            let spec = OctantSpec {
                a: octant.a,
                c: octant.c,
                divisions,
                grading: options.grading,
            };
            let piece = if options.exact_volume {
                HexMesh::spheroid_octant_exact_volume(&spec)?
            } else {
                HexMesh::spheroid_octant(&spec)?
            };
            let piece = if octant.corner.iter().any(|&h| h) {
                piece
                    .mirrored(octant.corner)
                    .translated(octant.centre(cell.lengths))
            } else {
                piece
            };
            particles.push(append_piece(&mut mesh, &piece, k));
        }
        check_no_overlap(cell, &mesh, &particles)?;
        Ok(Scene {
            lengths: cell.lengths,
            lateral_walls: true,
            mesh,
            particles,
            rho0_exact: Some(cell.rho0()),
            radius: cell.largest_radius(),
            tet_mesh: None,
            cell: Some(cell.clone()),
            mesh_options: Some(*options),
            periodic: None,
        })
    }

    /// The scene meshed with elements of `kind`: hexahedra as built, or
    /// 10-node tetrahedra cut from them (6 per hexahedron), particle by
    /// particle, with the mid-edge nodes of curved faces on the particle's
    /// spheroid. In a tet10 scene each particle's `nodes` and `elements`
    /// count in the tetrahedral mesh and its `triangles` are its contact
    /// surface.
    ///
    /// Tetrahedra are always cut from hexahedra with their surface nodes on
    /// the spheroid: a cell meshed with `exact_volume` is meshed again
    /// without it, and `mesh` and `mesh_options` then describe those
    /// hexahedra. A tet10 scene of a cell can be turned back into hexahedra
    /// (or tetrahedra again): it is meshed afresh from the cell.
    pub fn with_element(mut self, kind: ElementKind) -> Result<Scene, SolverError> {
        // The particles of a tet10 scene count in its tetrahedra: start again
        // from the cell's hexahedra.
        if self.tet_mesh.is_some()
            && let (Some(cell), Some(options)) = (self.cell.clone(), self.mesh_options)
        {
            self = Scene::from_cell(&cell, &options)?;
        }
        if kind == ElementKind::Hex8 {
            self.tet_mesh = None;
            return Ok(self);
        }
        if let Some(options) = self.mesh_options.filter(|o| o.exact_volume)
            && let Some(cell) = self.cell.take()
        {
            let on_surface = MeshOptions {
                exact_volume: false,
                ..options
            };
            self = Scene::from_cell(&cell, &on_surface)?;
        }
        let Some(cell) = self.cell.clone() else {
            self.tet_mesh = Some(TetMesh::from_hex(&self.mesh)?);
            return Ok(self);
        };
        let mut tet = TetMesh {
            nodes: Vec::new(),
            elements: Vec::new(),
            boundary: Vec::new(),
        };
        for particle in &mut self.particles {
            let octant = &cell.octants[particle.octant];
            let centre = octant.centre(cell.lengths);
            let piece = TetMesh::from_hex_with_surface(&hex_piece(&self.mesh, particle), |p| {
                let q = project_to_spheroid(
                    [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]],
                    octant.a,
                    octant.c,
                );
                [q[0] + centre[0], q[1] + centre[1], q[2] + centre[2]]
            })?;
            let (n0, e0) = (tet.nodes.len(), tet.elements.len());
            tet.nodes.extend_from_slice(&piece.nodes);
            tet.elements
                .extend(piece.elements.iter().map(|el| el.map(|n| n + n0)));
            particle.triangles.clear();
            for f in &piece.boundary {
                let nodes = f.nodes.map(|n| n + n0);
                if f.kind == FaceKind::Curved {
                    let [c0, c1, c2, m01, m12, m20] = nodes;
                    particle.triangles.extend([
                        [c0, m01, m20],
                        [m01, c1, m12],
                        [m20, m12, c2],
                        [m01, m12, m20],
                    ]);
                }
                tet.boundary.push(TetBoundaryFace {
                    nodes,
                    element: f.element + e0,
                    kind: f.kind,
                });
            }
            particle.nodes = (n0, piece.nodes.len());
            particle.elements = (e0, piece.elements.len());
        }
        self.tet_mesh = Some(tet);
        Ok(self)
    }

    /// The element the body is meshed with.
    pub fn element(&self) -> ElementKind {
        if self.tet_mesh.is_some() {
            ElementKind::Tet10
        } else {
            ElementKind::Hex8
        }
    }

    /// Node coordinates of the body mesh \[mm\].
    pub fn nodes(&self) -> &[[f64; 3]] {
        match &self.tet_mesh {
            Some(t) => &t.nodes,
            None => &self.mesh.nodes,
        }
    }

    /// Boundary faces of the body mesh: node lists (4 for quads, 6 for
    /// quadratic triangles) and kinds.
    pub fn boundary_faces(&self) -> Vec<(&[usize], FaceKind)> {
        match &self.tet_mesh {
            Some(t) => t.boundary.iter().map(|f| (&f.nodes[..], f.kind)).collect(),
            None => self
                .mesh
                .boundary
                .iter()
                .map(|f| (&f.nodes[..], f.kind))
                .collect(),
        }
    }

    /// A fully dense block filling the die (verification ladder item 3):
    /// mirror planes x = 0, y = 0, z = 0, die walls x = Lx, y = Ly, piston on top.
    pub fn die_block(lengths: [f64; 3], divisions: [usize; 3]) -> Result<Scene, SolverError> {
        Ok(Scene {
            lengths,
            lateral_walls: true,
            mesh: HexMesh::block(lengths, divisions)?,
            particles: Vec::new(),
            rho0_exact: Some(1.0),
            radius: lengths.iter().cloned().fold(0.0, f64::max),
            tet_mesh: None,
            cell: None,
            mesh_options: None,
            periodic: None,
        })
    }

    /// One octant of a block squeezed between frictionless platens with free
    /// sides (verification ladder item 2): mirror planes x = 0, y = 0, z = 0,
    /// piston on top, no walls at x = Lx, y = Ly.
    pub fn free_block(lengths: [f64; 3], divisions: [usize; 3]) -> Result<Scene, SolverError> {
        Ok(Scene {
            lengths,
            lateral_walls: false,
            mesh: HexMesh::block(lengths, divisions)?,
            particles: Vec::new(),
            rho0_exact: Some(1.0),
            radius: lengths.iter().cloned().fold(0.0, f64::max),
            tet_mesh: None,
            cell: None,
            mesh_options: None,
            periodic: None,
        })
    }
}

/// Appends the mesh `piece` of particle `index` to `mesh` (its nodes,
/// elements and boundary faces renumbered after those there), and returns
/// the particle: its ranges and its curved boundary quads.
pub(crate) fn append_piece(mesh: &mut HexMesh, piece: &HexMesh, index: usize) -> Particle {
    let (n0, e0) = (mesh.nodes.len(), mesh.elements.len());
    mesh.nodes.extend_from_slice(&piece.nodes);
    mesh.elements
        .extend(piece.elements.iter().map(|el| el.map(|n| n + n0)));
    let mut surface = Vec::new();
    for f in &piece.boundary {
        let face = BoundaryFace {
            nodes: f.nodes.map(|n| n + n0),
            element: f.element + e0,
            kind: f.kind,
        };
        if face.kind == FaceKind::Curved {
            surface.push(face.nodes);
        }
        mesh.boundary.push(face);
    }
    Particle {
        octant: index,
        nodes: (n0, piece.nodes.len()),
        elements: (e0, piece.elements.len()),
        surface,
        triangles: Vec::new(),
    }
}

/// The hexahedra of one particle as a mesh of their own (node and element
/// numbers from 0).
pub(crate) fn hex_piece(mesh: &HexMesh, particle: &Particle) -> HexMesh {
    let (n0, nc) = particle.nodes;
    let (e0, ec) = particle.elements;
    HexMesh {
        nodes: mesh.nodes[n0..n0 + nc].to_vec(),
        elements: mesh.elements[e0..e0 + ec]
            .iter()
            .map(|el| el.map(|n| n - n0))
            .collect(),
        boundary: mesh
            .boundary
            .iter()
            .filter(|f| (e0..e0 + ec).contains(&f.element))
            .map(|f| BoundaryFace {
                nodes: f.nodes.map(|n| n - n0),
                element: f.element - e0,
                kind: f.kind,
            })
            .collect(),
    }
}

/// Fails when a node of one particle lies inside another particle's
/// spheroid (by more than a relative `FIT_TOLERANCE` of its level function,
/// so cells written with rounded numbers still fit). [`Cell::new`] refuses
/// overlapping octants already; this guards a cell built field by field,
/// and the mesh itself.
fn check_no_overlap(
    cell: &Cell,
    mesh: &HexMesh,
    particles: &[Particle],
) -> Result<(), SolverError> {
    for p in particles {
        for q in particles {
            if p.octant == q.octant {
                continue;
            }
            let other = &cell.octants[q.octant];
            let (first, count) = p.nodes;
            if let Some(node) = mesh.nodes[first..first + count]
                .iter()
                .find(|x| other.level(cell.lengths, **x) < 1.0 - FIT_TOLERANCE)
            {
                return Err(SolverError::Unsupported(format!(
                    "cell '{}': octants[{}] and octants[{}] overlap (a node of octants[{}] at {node:?} is inside octants[{}])",
                    cell.name, p.octant, q.octant, p.octant, q.octant
                )));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::Octant;

    #[test]
    fn meshed_cells_have_the_exact_density_to_mesh_accuracy() {
        for cell in [
            Cell::sc(0.05, 1.0).unwrap(),
            Cell::bcc(0.05, 1.2).unwrap(),
            Cell::fcc(0.05, 0.8).unwrap(),
            Cell::sc2(0.05, 1.566, 1.0).unwrap(),
        ] {
            let mut errors = Vec::new();
            for level in [2, 4] {
                let scene = Scene::from_cell(
                    &cell,
                    &MeshOptions {
                        level,
                        grading: 1.0,
                        exact_volume: false,
                    },
                )
                .unwrap();
                let [lx, ly, lz] = scene.lengths;
                let rho = scene.mesh.volume() / (lx * ly * lz);
                errors.push((rho / cell.rho0() - 1.0).abs());
                assert_eq!(scene.particles.len(), cell.octants.len());
                assert!(scene.mesh.min_scaled_jacobian() > 0.5);
            }
            // Second order in the element size (a factor 2 between levels 2 and 4).
            assert!(
                errors[1] < 0.35 * errors[0] && errors[1] < 0.005,
                "{}: {errors:?}",
                cell.name
            );
        }
    }

    fn exact(level: u32, grading: f64) -> MeshOptions {
        MeshOptions {
            level,
            grading,
            exact_volume: exact_volume_default(),
        }
    }

    /// Every preset cell, including those whose particles touch each other
    /// (bcc, fcc, sc-2 up to 1 + sqrt 2) and the rigid planes (sc, sc-2),
    /// meshes without overlap and with its exact initial density.
    #[test]
    fn exact_volume_cells_have_the_exact_density_and_do_not_overlap() {
        let limit = crate::cell::SIZE_RATIO_RANGE.1;
        let mut cells = Vec::new();
        for aspect in [0.8, 1.0, 1.2] {
            cells.push(Cell::sc(0.05, aspect).unwrap());
            cells.push(Cell::bcc(0.05, aspect).unwrap());
            cells.push(Cell::fcc(0.05, aspect).unwrap());
        }
        for aspect in [0.8, 1.0] {
            cells.push(Cell::sc2(0.05, 1.566, aspect).unwrap());
            cells.push(Cell::sc2(0.05, limit, aspect).unwrap());
        }
        for cell in &cells {
            for (level, grading) in [(1, 1.0), (2, 1.0), (3, 2.0), (4, 4.0)] {
                let scene = Scene::from_cell(cell, &exact(level, grading))
                    .unwrap_or_else(|e| panic!("{} level {level}: {e}", cell.name));
                let [lx, ly, lz] = scene.lengths;
                let rho = scene.mesh.volume() / (lx * ly * lz);
                assert!(
                    (rho / cell.rho0() - 1.0).abs() < 1e-10,
                    "{} {:?} level {level} grading {grading}: rho0 {rho} vs {}",
                    cell.name,
                    cell.lengths,
                    cell.rho0()
                );
                assert!(scene.mesh.min_scaled_jacobian() > 0.5);
                // No node beyond a box face: the particles touch the die
                // walls and the piston only at their poles.
                for p in &scene.mesh.nodes {
                    for r in 0..3 {
                        assert!(p[r] >= 0.0 && p[r] <= scene.lengths[r], "{p:?}");
                    }
                }
            }
        }
    }

    /// A bcc scene turned into tetrahedra and back is the hexahedral scene
    /// again, and its particles' ranges tile the body mesh either way.
    #[test]
    fn element_changes_keep_the_particles_consistent() {
        let cell = Cell::bcc(0.05, 1.0).unwrap();
        let hex = Scene::from_cell(&cell, &exact(1, 1.0)).unwrap();
        let tet = hex.clone().with_element(ElementKind::Tet10).unwrap();
        let tiles = |scene: &Scene, nodes: usize, elements: usize| {
            let (mut n, mut e) = (0, 0);
            for p in &scene.particles {
                assert_eq!((p.nodes.0, p.elements.0), (n, e));
                n += p.nodes.1;
                e += p.elements.1;
            }
            assert_eq!((n, e), (nodes, elements));
        };
        let t = tet.tet_mesh.as_ref().unwrap();
        tiles(&tet, t.nodes.len(), t.elements.len());
        assert!(tet.particles.iter().all(|p| !p.triangles.is_empty()));
        let twice = tet.clone().with_element(ElementKind::Tet10).unwrap();
        assert_eq!(twice.tet_mesh, tet.tet_mesh);
        let back = tet.with_element(ElementKind::Hex8).unwrap();
        tiles(&back, back.mesh.nodes.len(), back.mesh.elements.len());
        assert_eq!(back.tet_mesh, None);
    }

    /// Tetrahedra keep their corners on the spheroid: `exact_volume` does
    /// not change a tet10 scene, though it changes the hexahedra.
    #[test]
    fn tet10_scenes_ignore_exact_volume() {
        let cell = Cell::sc(0.05, 1.2).unwrap();
        for level in [1, 2] {
            let on_surface = MeshOptions {
                exact_volume: false,
                ..exact(level, 1.0)
            };
            let plain = Scene::from_cell(&cell, &on_surface).unwrap();
            let fitted = Scene::from_cell(&cell, &exact(level, 1.0)).unwrap();
            assert_ne!(plain.mesh.nodes, fitted.mesh.nodes);
            assert_eq!(plain.mesh.elements, fitted.mesh.elements);
            let plain = plain.with_element(ElementKind::Tet10).unwrap();
            let fitted = fitted.with_element(ElementKind::Tet10).unwrap();
            assert!(fitted.tet_mesh.is_some());
            assert_eq!(plain.tet_mesh, fitted.tet_mesh);
            assert_eq!(plain.mesh, fitted.mesh);
            assert_eq!(fitted.mesh_options, Some(on_surface));
        }
    }

    #[test]
    fn default_meshes_start_at_the_exact_density() {
        for cell in [Cell::sc(0.05, 1.0).unwrap(), Cell::fcc(0.05, 1.2).unwrap()] {
            let scene = Scene::from_cell(&cell, &MeshOptions::default()).unwrap();
            let [lx, ly, lz] = scene.lengths;
            let rho = scene.mesh.volume() / (lx * ly * lz);
            assert!(
                (rho / cell.rho0() - 1.0).abs() < 1e-10,
                "{}: {rho}",
                cell.name
            );
        }
    }

    #[test]
    fn overlapping_octants_are_refused() {
        let o = |corner| Octant {
            corner,
            a: 0.6,
            c: 0.6,
        };
        // Both reach the piston (c = Lz): the load path is there. Refused
        // as a cell, and as a mesh when the cell is built field by field.
        let (lengths, octants) = (
            [1.0, 1.0, 0.6],
            vec![o([false; 3]), o([true, false, false])],
        );
        assert!(matches!(
            Cell::new("bad", lengths, octants.clone()),
            Err(SolverError::Overlap {
                first: 0,
                second: 1,
                ..
            })
        ));
        let cell = Cell {
            name: "bad".into(),
            lengths,
            octants,
        };
        let err = Scene::from_cell(&cell, &MeshOptions::default()).unwrap_err();
        assert!(err.to_string().contains("overlap"), "{err}");
    }

    #[test]
    fn touching_cells_with_rounded_lengths_fit_and_the_sc2_limit_meshes() {
        // bcc with the box edge 2R/sqrt3 rounded to 7 significant digits
        // (0.05773503 is 5e-8 above and 0.05773502 1.2e-7 below the exact edge).
        for s in [0.05773503, 0.05773502] {
            let o = |corner| Octant {
                corner,
                a: 0.05,
                c: 0.05,
            };
            let cell = Cell::new("bcc7", [s; 3], vec![o([false; 3]), o([true; 3])]);
            let cell = cell.unwrap();
            assert!(Scene::from_cell(&cell, &MeshOptions::default()).is_ok());
        }
        // sc-2 at r = 1 + sqrt 2: the large particles touch across the face
        // diagonals without overlapping; just above it the ratio is refused.
        let limit = crate::cell::SIZE_RATIO_RANGE.1;
        let cell = Cell::sc2(0.05, limit, 1.0).unwrap();
        assert!(Scene::from_cell(&cell, &MeshOptions::default()).is_ok());
        assert!(Cell::sc2(0.05, limit * (1.0 + 1e-3), 1.0).is_err());
        // a real overlap of 1e-4 is still caught
        let o = |corner| Octant {
            corner,
            a: 0.05,
            c: 0.05,
        };
        let s = 0.05 * 2.0 / 3f64.sqrt() * (1.0 - 1e-4);
        let octants = vec![o([false; 3]), o([true; 3])];
        assert!(matches!(
            Cell::new("bcc-", [s; 3], octants.clone()),
            Err(SolverError::Overlap { .. })
        ));
        let cell = Cell {
            name: "bcc-".into(),
            lengths: [s; 3],
            octants,
        };
        assert!(Scene::from_cell(&cell, &MeshOptions::default()).is_err());
    }
}
