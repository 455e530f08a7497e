//! Reading and writing packings as text.
//!
//! One particle per line: `x y z a [c [ax ay az]]` (mm), fields separated by
//! whitespace and/or commas; `c` defaults to `a` (a sphere), the axis to
//! `[0, 0, 1]`. Everything after a `#` is a comment; blank lines are skipped.
//! The box is not in the text: it is passed to [`Packing::from_text`].

use std::fmt::Write as _;

use nalgebra::{Unit, Vector3};

use crate::error::{PackingError, check_positive};
use crate::packing::{OVERLAP_TOLERANCE, Packing};
use crate::particle::Particle;
use crate::spec::Boundary;

const FIELDS: [&str; 8] = ["x", "y", "z", "a", "c", "ax", "ay", "az"];
const LENGTH_NAMES: [&str; 3] = ["lengths[0]", "lengths[1]", "lengths[2]"];

fn parse_error(line: usize, field: &'static str, message: String) -> PackingError {
    PackingError::Parse {
        line,
        field,
        message,
    }
}

/// The particle of one data line (1-based `line` for the messages).
fn parse_line(line: usize, data: &str) -> Result<Option<Particle>, PackingError> {
    let tokens: Vec<&str> = data
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .collect();
    if tokens.is_empty() {
        return Ok(None);
    }
    if !matches!(tokens.len(), 4 | 5 | 8) {
        return Err(parse_error(
            line,
            "fields",
            format!(
                "expected 4, 5 or 8 fields (x y z a [c [ax ay az]]), found {}",
                tokens.len()
            ),
        ));
    }
    let mut v = [0.0; 8];
    for (k, tok) in tokens.iter().enumerate() {
        let x: f64 = tok
            .parse()
            .map_err(|_| parse_error(line, FIELDS[k], format!("`{tok}` is not a number")))?;
        if !x.is_finite() {
            return Err(parse_error(line, FIELDS[k], format!("{x} is not finite")));
        }
        v[k] = x;
    }
    let a = v[3];
    let c = if tokens.len() >= 5 { v[4] } else { a };
    for (k, s) in [(3, a), (4, c)] {
        if !(s > 0.0) {
            return Err(parse_error(line, FIELDS[k], format!("{s} mm: must be > 0")));
        }
    }
    let axis = if tokens.len() == 8 {
        let u = Vector3::new(v[5], v[6], v[7]);
        match Unit::try_new_and_get(u, 0.0) {
            Some((axis, n)) if n.is_finite() => axis.into_inner().into(),
            _ => {
                return Err(parse_error(
                    line,
                    "ax",
                    format!("axis ({}, {}, {}) cannot be normalised", u[0], u[1], u[2]),
                ));
            }
        }
    } else {
        [0.0, 0.0, 1.0]
    };
    Ok(Some(Particle {
        centre: [v[0], v[1], v[2]],
        a,
        c,
        axis,
    }))
}

impl Packing {
    /// Reads a packing in the box `lengths` \[mm\] with the given boundary
    /// from text (format in [`mod@crate::io`]; [`Packing::to_text`] writes
    /// it). Axes are normalised; centres are wrapped into `[0, L)` along the
    /// periodic sides.
    ///
    /// # Errors
    /// [`PackingError::Parameter`] for a box side that is not finite and
    /// positive or a text without particles; [`PackingError::Parse`] naming
    /// the line and the field for an unreadable line, a non-finite value, a
    /// semi-axis that is not positive or a zero axis;
    /// [`PackingError::OutsideWalls`] for a particle crossing a die wall
    /// (z = 0 or z = Lz, the only non-periodic side) by more than
    /// [`OVERLAP_TOLERANCE`] times its volume-equivalent radius;
    /// [`PackingError::Overlap`] naming both lines for two particles (or a
    /// particle and its own periodic image) that overlap by more than
    /// [`OVERLAP_TOLERANCE`] times the smaller volume-equivalent radius.
    pub fn from_text(
        text: &str,
        lengths: [f64; 3],
        boundary: Boundary,
    ) -> Result<Packing, PackingError> {
        for (k, &l) in lengths.iter().enumerate() {
            check_positive(LENGTH_NAMES[k], l)?;
        }
        let mut particles = Vec::new();
        let mut lines = Vec::new();
        for (k, raw) in text.lines().enumerate() {
            let data = raw.split('#').next().unwrap_or("");
            if let Some(p) = parse_line(k + 1, data)? {
                particles.push(p);
                lines.push(k + 1);
            }
        }
        if particles.is_empty() {
            return Err(PackingError::Parameter {
                name: "particles",
                value: 0.0,
                allowed: "at least 1 (the text holds no particle line)",
            });
        }
        let mut packing = Packing {
            lengths,
            boundary,
            particles,
        };
        let cell = packing.cell();
        let lz = lengths[2];
        for (p, &line) in packing.particles.iter_mut().zip(&lines) {
            p.centre = cell.wrap(p.centre.into()).into();
            if boundary == Boundary::Die {
                let allowed = OVERLAP_TOLERANCE * p.equivalent_radius();
                let e = p.support([0.0, 0.0, 1.0]);
                for (wall, depth) in [(0.0, e - p.centre[2]), (lz, p.centre[2] + e - lz)] {
                    if depth > allowed {
                        return Err(PackingError::OutsideWalls {
                            line,
                            wall,
                            overlap: depth,
                        });
                    }
                }
            }
        }
        for c in packing.contacts(0.0) {
            let (pi, pj) = (&packing.particles[c.i], &packing.particles[c.j]);
            let allowed = OVERLAP_TOLERANCE * pi.equivalent_radius().min(pj.equivalent_radius());
            if -c.gap > allowed {
                return Err(PackingError::Overlap {
                    first: lines[c.i],
                    second: lines[c.j],
                    overlap: -c.gap,
                    allowed,
                });
            }
        }
        Ok(packing)
    }

    /// The packing as text that [`Packing::from_text`] reads back: a comment
    /// header with the boundary and the box, then `x y z a c ax ay az` per
    /// particle, every number written in the shortest form that reads back
    /// to the same `f64`.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let [lx, ly, lz] = self.lengths;
        // Writing to a String cannot fail.
        let _ = writeln!(s, "# tidens-packing: boundary {:?}", self.boundary);
        let _ = writeln!(s, "# lengths (mm): {lx} {ly} {lz}");
        let _ = writeln!(s, "# x y z a c ax ay az (mm)");
        for p in &self.particles {
            let [x, y, z] = p.centre;
            let [ux, uy, uz] = p.axis;
            let _ = writeln!(s, "{x} {y} {z} {} {} {ux} {uy} {uz}", p.a, p.c);
        }
        s
    }
}
