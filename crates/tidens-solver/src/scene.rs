//! What is simulated: a cell (a box whose faces are mirror planes, holding
//! octants of particles at its corners, DESIGN.md section 2), meshed into a
//! scene; and the plain blocks of the verification ladder.

use crate::error::SolverError;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use tidens_mesh::{HexMesh, OctantSpec, divisions_for_level};

/// One octant of a spheroid with semi-axes (a, a, c), c along z (the loading
/// direction), centred at a corner of the cell box and pointing into it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Octant {
    /// For each axis, whether the centre sits at the high end (L_i) of the box.
    pub corner: [bool; 3],
    /// Semi-axis along x and y [mm].
    pub a: f64,
    /// Semi-axis along z [mm].
    pub c: f64,
}

/// A periodic packing reduced by its mirror symmetries to the box
/// [0, Lx] x [0, Ly] x [0, Lz] holding particle octants at its corners.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// Short name, e.g. "sc".
    pub name: String,
    /// Box edge lengths Lx, Ly, Lz [mm].
    pub lengths: [f64; 3],
    /// The particle pieces.
    pub octants: Vec<Octant>,
}

/// Allowed range of the spheroid aspect ratio c/a.
pub const ASPECT_RANGE: (f64, f64) = (0.2, 5.0);
/// Allowed range of the particle radius [mm].
pub const RADIUS_RANGE: (f64, f64) = (1e-6, 1e3);
/// Finest mesh level: level 6 needs about 2.5 GB for the sparse factor of the
/// sc cell, level 7 about four times that.
pub const MAX_MESH_LEVEL: u32 = 6;

impl Cell {
    /// Simple cubic cell: one octant of a spheroid of semi-axes
    /// (radius, radius, aspect * radius) in an a x a x c box; rho0 = pi/6 for
    /// any aspect ratio. The particle touches the planes x = Lx, y = Ly and the
    /// piston z = Lz at its three poles.
    pub fn sc(radius: f64, aspect: f64) -> Result<Cell, SolverError> {
        if !(radius >= RADIUS_RANGE.0 && radius <= RADIUS_RANGE.1) {
            return Err(SolverError::parameter(
                "radius",
                radius,
                "in [1e-6, 1e3] mm",
            ));
        }
        if !(aspect >= ASPECT_RANGE.0 && aspect <= ASPECT_RANGE.1) {
            return Err(SolverError::parameter(
                "aspect_ratio",
                aspect,
                "in [0.2, 5] (c/a)",
            ));
        }
        let (a, c) = (radius, aspect * radius);
        Ok(Cell {
            name: "sc".into(),
            lengths: [a, a, c],
            octants: vec![Octant {
                corner: [false; 3],
                a,
                c,
            }],
        })
    }

    /// Initial relative density from the exact particle volumes (each octant
    /// is pi a^2 c / 6).
    pub fn rho0(&self) -> f64 {
        let v: f64 = self
            .octants
            .iter()
            .map(|o| PI * o.a * o.a * o.c / 6.0)
            .sum();
        v / (self.lengths[0] * self.lengths[1] * self.lengths[2])
    }
}

/// Mesh resolution of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshOptions {
    /// Mesh level, 1 (coarsest usable) upward; each level refines the element
    /// size by about sqrt(2) (inner-cube divisions 4, 6, 8, 11, 16, ...).
    pub level: u32,
    /// Element-size ratio toward the contact points (1 = uniform).
    pub grading: f64,
}

impl Default for MeshOptions {
    fn default() -> Self {
        Self {
            level: 3,
            grading: 1.0,
        }
    }
}

/// A meshed problem: the box, whether the lateral die walls exist, and the
/// body mesh. All six box faces are frictionless rigid mirror planes, except
/// the lateral high faces (x = Lx, y = Ly) when `lateral_walls` is false.
/// The top face z = Lz is the piston.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub lengths: [f64; 3],
    pub lateral_walls: bool,
    pub mesh: HexMesh,
    /// Exact initial relative density of the geometry (not of the mesh), if known.
    pub rho0_exact: Option<f64>,
}

impl Scene {
    /// Meshes a cell. Cells with more than one particle need particle-particle
    /// contact, which this version does not have.
    pub fn from_cell(cell: &Cell, options: &MeshOptions) -> Result<Scene, SolverError> {
        let [octant] = cell.octants.as_slice() else {
            return Err(SolverError::Unsupported(format!(
                "cell '{}' has {} particle pieces; only single-particle cells (sc) are supported until particle-particle contact exists",
                cell.name,
                cell.octants.len()
            )));
        };
        if !(options.grading >= 1.0 && options.grading <= 10.0) {
            return Err(SolverError::parameter(
                "grading",
                options.grading,
                "in [1, 10]",
            ));
        }
        if !(1..=MAX_MESH_LEVEL).contains(&options.level) {
            return Err(SolverError::parameter(
                "mesh_level",
                options.level as f64,
                format!("in 1..={MAX_MESH_LEVEL}"),
            ));
        }
        let divisions = divisions_for_level(options.level)?;
        let mesh = HexMesh::spheroid_octant(&OctantSpec {
            a: octant.a,
            c: octant.c,
            divisions,
            grading: options.grading,
        })?;
        let mesh = if octant.corner.iter().any(|&h| h) {
            let offset = [0, 1, 2].map(|i| {
                if octant.corner[i] {
                    cell.lengths[i]
                } else {
                    0.0
                }
            });
            mesh.mirrored(octant.corner).translated(offset)
        } else {
            mesh
        };
        Ok(Scene {
            lengths: cell.lengths,
            lateral_walls: true,
            mesh,
            rho0_exact: Some(cell.rho0()),
        })
    }

    /// A fully dense block filling the die (verification ladder item 3):
    /// mirror planes x = 0, y = 0, z = 0, die walls x = Lx, y = Ly, piston on top.
    pub fn die_block(lengths: [f64; 3], divisions: [usize; 3]) -> Result<Scene, SolverError> {
        Ok(Scene {
            lengths,
            lateral_walls: true,
            mesh: HexMesh::block(lengths, divisions)?,
            rho0_exact: Some(1.0),
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
            rho0_exact: Some(1.0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sc_density_is_pi_over_six_for_any_aspect_ratio() {
        for aspect in [0.5, 0.8, 1.0, 1.2, 2.0] {
            let cell = Cell::sc(0.05, aspect).unwrap();
            assert!((cell.rho0() - PI / 6.0).abs() < 1e-15);
        }
        assert!(matches!(
            Cell::sc(-1.0, 1.0),
            Err(SolverError::Parameter { name: "radius", .. })
        ));
        assert!(matches!(
            Cell::sc(1.0, 9.0),
            Err(SolverError::Parameter {
                name: "aspect_ratio",
                ..
            })
        ));
    }
}
