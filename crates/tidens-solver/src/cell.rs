//! Cells as data: a box [0,Lx]x[0,Ly]x[0,Lz] whose faces are mirror planes,
//! holding octants of spheroids centred at its corners (docs/model.md section 2),
//! and the paper's packings built from them.

use crate::error::SolverError;
use crate::load_path::closest_level;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// One octant of a spheroid with semi-axes (a, a, c), c along z (the loading
/// direction), centred at a corner of the cell box and pointing into it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Octant {
    /// For each axis, whether the centre sits at the high end (L_i) of the box.
    pub corner: [bool; 3],
    /// Semi-axis along x and y \[mm\].
    pub a: f64,
    /// Semi-axis along z \[mm\].
    pub c: f64,
}

impl Octant {
    /// Centre of the spheroid in a box of edge lengths `lengths` \[mm\].
    pub fn centre(&self, lengths: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| if self.corner[i] { lengths[i] } else { 0.0 })
    }

    /// Implicit function of the spheroid: < 1 inside, 1 on the surface.
    pub fn level(&self, lengths: [f64; 3], p: [f64; 3]) -> f64 {
        let c = self.centre(lengths);
        let d = [
            (p[0] - c[0]) / self.a,
            (p[1] - c[1]) / self.a,
            (p[2] - c[2]) / self.c,
        ];
        d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    }
}

/// A periodic packing reduced by its mirror symmetries to the box
/// [0, Lx] x [0, Ly] x [0, Lz] holding particle octants at its corners.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// Short name, e.g. "sc".
    pub name: String,
    /// Box edge lengths Lx, Ly, Lz \[mm\].
    pub lengths: [f64; 3],
    /// The particle pieces.
    pub octants: Vec<Octant>,
}

/// Allowed range of the spheroid aspect ratio c/a.
pub const ASPECT_RANGE: (f64, f64) = (0.2, 5.0);
/// Allowed range of the particle radius \[mm\].
pub const RADIUS_RANGE: (f64, f64) = (1e-6, 1e3);
/// Relative slack allowed when an octant must fit its box or stay outside
/// another particle (level function, about twice the relative distance), so
/// cells written with 7 significant digits still fit.
pub const FIT_TOLERANCE: f64 = 1e-6;
/// Allowed range of the sc-2 radius ratio R_large / R_small: above 1 + sqrt 2
/// the large particles would overlap across the face diagonals.
pub const SIZE_RATIO_RANGE: (f64, f64) = (1.0, 1.0 + std::f64::consts::SQRT_2);
/// The paper's sc-2 radius ratio.
pub const DEFAULT_SIZE_RATIO: f64 = 1.566;

fn check(
    name: &'static str,
    value: f64,
    (lo, hi): (f64, f64),
    allowed: &str,
) -> Result<(), SolverError> {
    if value >= lo && value <= hi {
        Ok(())
    } else {
        Err(SolverError::parameter(name, value, allowed))
    }
}

fn check_radius_aspect(radius: f64, aspect: f64) -> Result<(), SolverError> {
    check("radius", radius, RADIUS_RANGE, "in [1e-6, 1e3] mm")?;
    check("aspect_ratio", aspect, ASPECT_RANGE, "in [0.2, 5] (c/a)")
}

/// Refuses two octants at one corner and two octants that overlap.
///
/// Two octants at different corners overlap exactly when the surface of
/// one reaches inside the other (each octant fits its box, so its piece is
/// the whole octant of its spheroid, and of two overlapping convex pieces
/// either one holds the other or their curved surfaces cross). So the
/// smallest level function of each over the other's surface
/// ([`closest_level`], exact to its search's 1e-11 rad) decides, with the
/// mesh check's slack [`FIT_TOLERANCE`]: cells whose particles touch,
/// written to seven significant digits, pass (the level function of a
/// touching pair is 1).
fn check_apart(cell: &Cell) -> Result<(), SolverError> {
    let octants = &cell.octants;
    for (first, p) in octants.iter().enumerate() {
        for (second, q) in octants.iter().enumerate().skip(first + 1) {
            if p.corner == q.corner {
                return Err(SolverError::SameCorner {
                    cell: cell.name.clone(),
                    first,
                    second,
                    corner: p.corner,
                });
            }
        }
    }
    for (first, p) in octants.iter().enumerate() {
        for (second, q) in octants.iter().enumerate().skip(first + 1) {
            let into_q = closest_level(p, q, cell.lengths);
            let into_p = closest_level(q, p, cell.lengths);
            let (inner, outer, level) = if into_q <= into_p {
                (first, second, into_q)
            } else {
                (second, first, into_p)
            };
            if level < 1.0 - FIT_TOLERANCE {
                return Err(SolverError::Overlap {
                    cell: cell.name.clone(),
                    first,
                    second,
                    inner,
                    outer,
                    level,
                });
            }
        }
    }
    Ok(())
}

impl Cell {
    /// A cell from its box and octants, checked: positive finite lengths,
    /// every octant inside the box (its semi-axes at most the box edges), one
    /// octant per corner ([`SolverError::SameCorner`]), no two octants
    /// overlapping ([`SolverError::Overlap`], see [`check_apart`]), and a
    /// chain of touching particles from the piston to the bottom plane
    /// ([`crate::load_path`]). The mesh is checked for overlaps again
    /// when the cell is meshed (its nodes against the spheroids).
    pub fn new(
        name: impl Into<String>,
        lengths: [f64; 3],
        octants: Vec<Octant>,
    ) -> Result<Cell, SolverError> {
        for (i, &l) in lengths.iter().enumerate() {
            let name = ["lengths[0]", "lengths[1]", "lengths[2]"][i];
            check(name, l, RADIUS_RANGE, "in [1e-6, 1e3] mm")?;
        }
        if octants.is_empty() {
            return Err(SolverError::parameter(
                "octants",
                0.0,
                "at least one octant",
            ));
        }
        for o in &octants {
            check("a", o.a, RADIUS_RANGE, "in [1e-6, 1e3] mm")?;
            check("c", o.c, RADIUS_RANGE, "in [1e-6, 1e3] mm")?;
            check("c/a", o.c / o.a, ASPECT_RANGE, "in [0.2, 5]")?;
            let tol = FIT_TOLERANCE;
            if o.a > lengths[0] * (1.0 + tol) || o.a > lengths[1] * (1.0 + tol) {
                return Err(SolverError::parameter(
                    "a",
                    o.a,
                    "at most the box edges Lx and Ly",
                ));
            }
            if o.c > lengths[2] * (1.0 + tol) {
                return Err(SolverError::parameter("c", o.c, "at most the box edge Lz"));
            }
        }
        let cell = Cell {
            name: name.into(),
            lengths,
            octants,
        };
        check_apart(&cell)?;
        crate::load_path::check(&cell)?;
        Ok(cell)
    }

    /// Simple cubic: one octant of a spheroid of semi-axes (R, R, k R),
    /// k = `aspect`, in an R x R x kR box; rho0 = pi/6. The particle touches
    /// the planes x = Lx, y = Ly and the piston at its three poles.
    pub fn sc(radius: f64, aspect: f64) -> Result<Cell, SolverError> {
        check_radius_aspect(radius, aspect)?;
        let (a, c) = (radius, aspect * radius);
        Cell::new(
            "sc",
            [a, a, c],
            vec![Octant {
                corner: [false; 3],
                a,
                c,
            }],
        )
    }

    /// Body-centred cubic: box s^3, s = 2R/sqrt(3) (z scaled by the aspect
    /// ratio), octants at (0,0,0) and (s,s,s) touching along the body
    /// diagonal; rho0 = pi sqrt(3)/8.
    pub fn bcc(radius: f64, aspect: f64) -> Result<Cell, SolverError> {
        check_radius_aspect(radius, aspect)?;
        let s = 2.0 * radius / 3.0_f64.sqrt();
        let (a, c) = (radius, aspect * radius);
        let oct = |corner| Octant { corner, a, c };
        Cell::new(
            "bcc",
            [s, s, aspect * s],
            vec![oct([false; 3]), oct([true; 3])],
        )
    }

    /// Face-centred cubic: box s^3, s = sqrt(2) R (z scaled by the aspect
    /// ratio), octants at (0,0,0), (s,s,0), (s,0,s), (0,s,s) touching along
    /// the face diagonals; rho0 = pi/(3 sqrt(2)).
    pub fn fcc(radius: f64, aspect: f64) -> Result<Cell, SolverError> {
        check_radius_aspect(radius, aspect)?;
        let s = 2.0_f64.sqrt() * radius;
        let (a, c) = (radius, aspect * radius);
        let oct = |corner| Octant { corner, a, c };
        Cell::new(
            "fcc",
            [s, s, aspect * s],
            vec![
                oct([false, false, false]),
                oct([true, true, false]),
                oct([true, false, true]),
                oct([false, true, true]),
            ],
        )
    }

    /// Two-size simple cubic in rock-salt order: box s^3, s = R + R/r
    /// (`radius` R of the large particles, r = `size_ratio`), large octants
    /// where i+j+k is even and small ones where it is odd at the corners
    /// (i,j,k) in {0,1}^3, touching along the twelve edges;
    /// rho0 = (2 pi/3)(1+r^3)/(1+r)^3 (0.60002 for r = 1.566).
    pub fn sc2(radius: f64, size_ratio: f64, aspect: f64) -> Result<Cell, SolverError> {
        check_radius_aspect(radius, aspect)?;
        check(
            "size_ratio",
            size_ratio,
            SIZE_RATIO_RANGE,
            "in [1, 1 + sqrt 2 = 2.414] (R_large / R_small; beyond it the large particles overlap across the face diagonals)",
        )?;
        let small = radius / size_ratio;
        let s = radius + small;
        let mut octants = Vec::with_capacity(8);
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..2 {
                    let r = if (i + j + k) % 2 == 0 { radius } else { small };
                    octants.push(Octant {
                        corner: [i == 1, j == 1, k == 1],
                        a: r,
                        c: aspect * r,
                    });
                }
            }
        }
        Cell::new("sc2", [s, s, aspect * s], octants)
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

    /// The largest semi-axis of any particle \[mm\] (the R of tolerances).
    pub fn largest_radius(&self) -> f64 {
        self.octants
            .iter()
            .map(|o| o.a.max(o.c))
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preset_densities_match_their_closed_forms_for_any_aspect_ratio() {
        let r = DEFAULT_SIZE_RATIO;
        for aspect in [0.8, 1.0, 1.2] {
            let cases = [
                (Cell::sc(0.05, aspect).unwrap(), PI / 6.0),
                (Cell::bcc(0.05, aspect).unwrap(), PI * 3.0_f64.sqrt() / 8.0),
                (
                    Cell::fcc(0.05, aspect).unwrap(),
                    PI / (3.0 * 2.0_f64.sqrt()),
                ),
                (
                    Cell::sc2(0.05, r, aspect).unwrap(),
                    2.0 * PI / 3.0 * (1.0 + r.powi(3)) / (1.0 + r).powi(3),
                ),
            ];
            for (cell, exact) in cases {
                assert!(
                    (cell.rho0() / exact - 1.0).abs() < 1e-14,
                    "{}: {} vs {exact}",
                    cell.name,
                    cell.rho0()
                );
            }
        }
        assert!((Cell::sc2(0.05, r, 1.0).unwrap().rho0() - 0.60002).abs() < 5e-6);
    }

    #[test]
    fn presets_touch_without_overlap() {
        // Centre distances equal the sum of radii along the contact lines.
        let bcc = Cell::bcc(0.05, 1.0).unwrap();
        let [s, _, _] = bcc.lengths;
        assert!((3.0_f64.sqrt() * s - 0.1).abs() < 1e-15);
        let fcc = Cell::fcc(0.05, 1.0).unwrap();
        assert!((2.0_f64.sqrt() * fcc.lengths[0] - 0.1).abs() < 1e-15);
        let sc2 = Cell::sc2(0.05, 1.566, 1.0).unwrap();
        let (large, small) = (&sc2.octants[0], &sc2.octants[1]);
        assert!((large.a + small.a - sc2.lengths[0]).abs() < 1e-15);
    }

    fn octant(corner: [bool; 3], a: f64, c: f64) -> Octant {
        Octant { corner, a, c }
    }

    #[test]
    fn two_octants_at_one_corner_are_refused_by_their_indices() {
        let o = octant([false, true, true], 0.05, 0.05);
        let err = Cell::new("dup", [0.05; 3], vec![o.clone(), o.clone()]).unwrap_err();
        assert_eq!(
            err,
            SolverError::SameCorner {
                cell: "dup".into(),
                first: 0,
                second: 1,
                corner: [false, true, true]
            }
        );
        assert!(
            err.to_string()
                .contains("octants[0] and octants[1] are both at corner 011"),
            "{err}"
        );
        // Another size at the same corner too, after a good octant.
        let other = octant([false, true, true], 0.02, 0.03);
        let far = octant([true, false, false], 0.01, 0.01);
        assert!(matches!(
            Cell::new("dup", [0.05; 3], vec![far, o, other]),
            Err(SolverError::SameCorner {
                first: 1,
                second: 2,
                ..
            })
        ));
    }

    #[test]
    fn overlapping_octants_are_refused_by_their_indices() {
        // octants[0] and [2] overlap along x by 0.02 mm; [1] is far from both.
        let octants = vec![
            octant([false; 3], 0.06, 0.06),
            octant([false, true, true], 0.02, 0.02),
            octant([true, false, false], 0.06, 0.06),
        ];
        let err = Cell::new("x", [0.1; 3], octants).unwrap_err();
        let SolverError::Overlap {
            first: 0,
            second: 2,
            level,
            ..
        } = err
        else {
            panic!("{err}");
        };
        // The surface of one reaches 0.02 mm into the other, of radius 0.06.
        assert!((1.0 - level.sqrt() - 0.02 / 0.06).abs() < 1e-9, "{level}");
        let message = err.to_string();
        assert!(
            message.contains("octants[0] and octants[2] overlap") && message.contains("33.333 %"),
            "{message}"
        );
        // Spheroids: a flat octant under a tall one at the corner above it.
        let err = Cell::new(
            "y",
            [0.1, 0.1, 0.1],
            vec![
                octant([false; 3], 0.08, 0.04),
                octant([false, false, true], 0.03, 0.065),
            ],
        )
        .unwrap_err();
        assert!(matches!(err, SolverError::Overlap { .. }), "{err}");
    }

    /// Random cells of two or three octants, refused at construction
    /// exactly when some node of their level-2 mesh lies inside another
    /// octant (or, touching, never: the construction's test is the exact
    /// surface, which the nodes sample). Either check may refuse cells the
    /// other accepts only within a hair of touching.
    #[test]
    fn the_construction_check_agrees_with_the_mesh_check() {
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut uniform = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let options = crate::scene::MeshOptions {
            level: 2,
            ..crate::scene::MeshOptions::default()
        };
        let (mut refused, mut accepted) = (0, 0);
        for _ in 0..150 {
            let lengths = [0.1, 0.08 + 0.04 * uniform(), 0.06 + 0.06 * uniform()];
            let count = 2 + (uniform() * 2.0) as usize;
            let mut corners: Vec<[bool; 3]> = (0..8)
                .map(|k| [k & 1 == 1, k & 2 == 2, k & 4 == 4])
                .collect();
            let octants: Vec<Octant> = (0..count)
                .map(|_| {
                    let corner = corners.remove((uniform() * corners.len() as f64) as usize);
                    let a = lengths[0].min(lengths[1]) * (0.3 + 0.7 * uniform());
                    let c = (a * (0.5 + uniform())).min(lengths[2]);
                    octant(corner, a, c)
                })
                .collect();
            let cell = Cell {
                name: "random".into(),
                lengths,
                octants,
            };
            let apart = check_apart(&cell).is_ok();
            let meshed = crate::scene::Scene::from_cell(&cell, &options).is_ok();
            assert_eq!(apart, meshed, "{cell:?}");
            if apart {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        assert!(
            refused > 20 && accepted > 20,
            "{refused} refused, {accepted} accepted"
        );
    }

    #[test]
    fn bad_cells_name_the_parameter() {
        assert!(matches!(
            Cell::sc(-1.0, 1.0),
            Err(SolverError::Parameter { name: "radius", .. })
        ));
        assert!(matches!(
            Cell::bcc(1.0, 9.0),
            Err(SolverError::Parameter {
                name: "aspect_ratio",
                ..
            })
        ));
        assert!(matches!(
            Cell::sc2(1.0, 0.5, 1.0),
            Err(SolverError::Parameter {
                name: "size_ratio",
                ..
            })
        ));
        let big = Octant {
            corner: [false; 3],
            a: 2.0,
            c: 1.0,
        };
        assert!(matches!(
            Cell::new("x", [1.0; 3], vec![big]),
            Err(SolverError::Parameter { name: "a", .. })
        ));
    }
}
