//! Errors of the packing generator and of the packing reader.

use crate::progress::Stage;

/// A bad packing specification, a packing file that cannot be read, a
/// target density that the relaxation could not reach, or a generation its
/// caller stopped. Each message names the parameter (or the line and
/// field), the value and what was allowed.
#[derive(thiserror::Error, Debug, Clone, PartialEq)]
pub enum PackingError {
    /// A parameter outside its allowed range, e.g.
    /// `rho0 = 0.8: must be in [0.3, 0.74]`.
    #[error("{name} = {value}: must be {allowed}")]
    Parameter {
        /// Name of the parameter, as spelled in [`crate::PackingSpec`] or in
        /// the argument list (`lengths[2]`, `box_aspect[0]`, ...).
        name: &'static str,
        /// The rejected value (counts converted to `f64`, exact below 2^53).
        value: f64,
        /// The allowed range, e.g. `in [0.3, 0.74]`.
        allowed: &'static str,
    },
    /// A side of the box is shorter than the largest particle extent (the
    /// largest particle diameter `2 max(a, c)`): the particle would overlap
    /// its own periodic image, or not fit between the die walls.
    #[error(
        "box side lengths[{axis}] = {length} mm: must be >= the largest particle \
         extent 2 max(a, c) = {extent} mm"
    )]
    BoxTooSmall {
        /// Axis index 0, 1 or 2 (x, y, z).
        axis: usize,
        /// The box side \[mm\].
        length: f64,
        /// The largest particle diameter \[mm\].
        extent: f64,
    },
    /// The overlap relaxation jammed below the target density: no overlap-free
    /// packing at `rho0` was found (e.g. rho0 = 0.70 for monodisperse spheres,
    /// above random close packing).
    #[error(
        "rho0 = {requested}: not reached, the packing jammed at a relative \
         density of {reached} (the densest overlap-free state found)"
    )]
    Rho0Unreachable {
        /// The requested relative density.
        requested: f64,
        /// The densest relative density at which an overlap-free packing was
        /// found.
        reached: f64,
    },
    /// The caller stopped the generation: the `stop` callback of
    /// [`crate::Packing::generate_unless`] or [`crate::Packing::jam_unless`]
    /// answered true. Nothing is returned: the state of an unfinished
    /// relaxation overlaps.
    #[error(
        "interrupted while relaxing at a relative density of {rel_density} (stage {stage}; \
         the densest overlap-free state so far: {densest})"
    )]
    Interrupted {
        /// The stage it was in.
        stage: Stage,
        /// The relative density it was relaxing at.
        rel_density: f64,
        /// The densest overlap-free relative density accepted so far.
        densest: f64,
    },
    /// A field of a packing file that cannot be read.
    #[error("line {line}: {field}: {message}")]
    Parse {
        /// 1-based line number in the text.
        line: usize,
        /// Name of the field (`x`, `y`, `z`, `a`, `c`, `ax`, `ay`, `az`, or
        /// `fields` for a wrong field count).
        field: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// A particle of a packing file that does not lie inside the die walls.
    #[error(
        "line {line}: particle crosses the die wall z = {wall} mm by {overlap} mm \
         (allowed 1e-6 x its radius)"
    )]
    OutsideWalls {
        /// 1-based line number of the particle.
        line: usize,
        /// z of the wall \[mm\].
        wall: f64,
        /// Depth by which the particle crosses it \[mm\].
        overlap: f64,
    },
    /// Two particles of a packing file (or a particle and its own periodic
    /// image, then `first == second`) overlap by more than 1e-6 times the
    /// smaller volume-equivalent radius.
    #[error(
        "lines {first} and {second}: particles overlap by {overlap} mm \
         (allowed 1e-6 x the smaller radius = {allowed} mm)"
    )]
    Overlap {
        /// 1-based line number of the first particle.
        first: usize,
        /// 1-based line number of the second particle.
        second: usize,
        /// Overlap depth \[mm\] (see [`crate::Particle::gap`]).
        overlap: f64,
        /// Largest overlap allowed \[mm\].
        allowed: f64,
    },
}

/// `Err(Parameter)` unless `lo <= v <= hi` (NaN refused).
pub(crate) fn check_closed(
    name: &'static str,
    v: f64,
    lo: f64,
    hi: f64,
    allowed: &'static str,
) -> Result<(), PackingError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(PackingError::Parameter {
            name,
            value: v,
            allowed,
        })
    }
}

/// `Err(Parameter)` unless `v` is finite and strictly positive.
pub(crate) fn check_positive(name: &'static str, v: f64) -> Result<(), PackingError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(PackingError::Parameter {
            name,
            value: v,
            allowed: "finite and > 0",
        })
    }
}
