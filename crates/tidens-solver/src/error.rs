use thiserror::Error;

/// Everything that can go wrong in setting up or running a simulation.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum SolverError {
    /// A setting outside its allowed range.
    #[error("{name} = {value}: must be {allowed}")]
    Parameter {
        name: &'static str,
        value: f64,
        allowed: String,
    },
    /// A cell whose particles cannot carry the piston's load to the bottom.
    #[error("cell '{cell}': {reason}")]
    NoLoadPath { cell: String, reason: String },
    /// Two octants of a cell at one corner: one spheroid's piece twice, or
    /// two spheroids centred at one point (a line of a cell file written
    /// twice, say). Indices as the octants were given.
    #[error(
        "cell '{cell}': octants[{first}] and octants[{second}] are both at corner {}: \
         each corner holds one particle",
        corner_digits(.corner)
    )]
    SameCorner {
        cell: String,
        first: usize,
        second: usize,
        /// The corner (true: the high end of that axis).
        corner: [bool; 3],
    },
    /// Two octants of a cell that overlap (touching is allowed). Indices
    /// as the octants were given.
    #[error(
        "cell '{cell}': octants[{first}] and octants[{second}] overlap (a point of the \
         surface of octants[{inner}] lies inside octants[{outer}], {:.3} % of its radius \
         deep along that direction; touching is allowed, to about 5e-5 %)",
        100.0 * (1.0 - .level.sqrt())
    )]
    Overlap {
        cell: String,
        first: usize,
        second: usize,
        /// The octant whose surface reaches into the other.
        inner: usize,
        /// The octant it reaches into.
        outer: usize,
        /// The smallest level function of `outer` on the surface of
        /// `inner` (1 on `outer`'s surface, 0 at its centre).
        level: f64,
    },
    /// A scene that this version cannot build.
    #[error("unsupported scene: {0}")]
    Unsupported(String),
    #[error(transparent)]
    Mesh(#[from] tidens_mesh::MeshError),
    #[error(transparent)]
    Material(#[from] tidens_material::MaterialError),
    #[error(transparent)]
    Fem(#[from] tidens_fem::FemError),
    /// The sparse linear algebra failed.
    #[error("linear solve failed: {0}")]
    Linear(#[from] LinearError),
    /// Newton failed even at the smallest allowed time step.
    #[error(
        "no convergence at t = {time:.6e} s (step {step}): time step cut to {dt:.3e} s without Newton converging ({reason})"
    )]
    NoConvergence {
        time: f64,
        step: usize,
        dt: f64,
        reason: StepFailure,
    },
    /// A checkpoint that cannot be read or does not belong to this run.
    #[error("checkpoint: {0}")]
    Checkpoint(#[from] CheckpointError),
    /// A broken invariant of the solver (a bug: please report it).
    #[error("internal error: {0}")]
    Internal(&'static str),
    /// The caller asked the run to stop in the middle of a step (see
    /// [`crate::Simulation::advance_unless`]); the state is the last
    /// converged step's.
    #[error("interrupted at t = {time:.6e} s, in step {step}")]
    Interrupted { time: f64, step: usize },
    /// The step limit was reached before the stop condition.
    #[error("step limit {max_steps} reached at t = {time:.6e} s, density {density:.5}")]
    StepLimit {
        max_steps: usize,
        time: f64,
        density: f64,
    },
}

/// What is wrong with the bytes given as a checkpoint, or with the run it
/// is resumed into (see `crate::checkpoint` for the file's frame). The
/// messages say what happened to the file and what to do; the caller that
/// knows the file's path puts it in front.
#[derive(Error, Debug, Clone, PartialEq, Eq)]
pub enum CheckpointError {
    /// No bytes at all.
    #[error(
        "empty (0 bytes): the run was stopped while it wrote its first checkpoint, \
         or the disk was full; run the case again from the start"
    )]
    Empty,
    /// Fewer bytes than the checkpoint needs: the file was cut short (a
    /// full disk, a copy that did not finish).
    #[error(
        "truncated (ends after {length} of the {} bytes a checkpoint needs): the file \
         is damaged; resume from a copy of it, or run the case again from the start",
        needed_bytes(.needed)
    )]
    Truncated {
        /// Bytes there are.
        length: usize,
        /// Bytes the checkpoint's header says it has, when its header is
        /// whole.
        needed: Option<usize>,
    },
    /// Not the bytes of a tidens checkpoint (no mark, no format).
    #[error(
        "not a tidens checkpoint (it starts neither with a checkpoint's mark nor with \
         the format of an older one)"
    )]
    NotACheckpoint,
    /// A checkpoint of another format.
    #[error(
        "written by another version of tidens (checkpoint format {found}, this tidens \
         reads format {expected}); run the case again from the start"
    )]
    Version {
        /// Its format.
        found: u32,
        /// The format this tidens writes.
        expected: u32,
    },
    /// Bytes changed since they were written (a bit flipped on the disk or
    /// in a copy), found by the hashes of the frame.
    #[error(
        "damaged ({detail}): the file changed after it was written; resume from a \
         copy of it, or run the case again from the start"
    )]
    Damaged {
        /// What gave it away.
        detail: String,
    },
    /// A whole checkpoint of another case.
    #[error("taken with {what}: resume it with the case it was taken with")]
    OtherCase {
        /// What differs, e.g. "another material".
        what: String,
    },
    /// The state could not be encoded (a bug: please report it).
    #[error("cannot be written: {detail}")]
    Unwritable {
        /// The encoder's reason.
        detail: String,
    },
}

/// A corner as three 0/1 digits, x first ("011": low x, high y, high z), as
/// cell files write it.
fn corner_digits(corner: &[bool; 3]) -> String {
    corner
        .iter()
        .map(|&high| if high { '1' } else { '0' })
        .collect()
}

/// The bytes a truncated checkpoint needs, in words.
fn needed_bytes(needed: &Option<usize>) -> String {
    needed.map_or_else(|| "more".into(), |n| n.to_string())
}

impl SolverError {
    pub(crate) fn parameter(name: &'static str, value: f64, allowed: impl Into<String>) -> Self {
        SolverError::Parameter {
            name,
            value,
            allowed: allowed.into(),
        }
    }
}

/// What went wrong in the sparse linear algebra.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum LinearError {
    /// A factor or workspace larger than the memory available.
    #[error("out of memory: the {what} needs {gigabytes:.2} GB; use a coarser mesh level")]
    OutOfMemory { what: &'static str, gigabytes: f64 },
    /// faer refused the symbolic factorisation (its message).
    #[error("symbolic factorisation: {0}")]
    Symbolic(String),
    /// The factor gave a non-finite solution: the tangent is singular.
    #[error("the solve gave a non-finite solution (singular tangent)")]
    Singular,
    /// A solve asked for before any factorisation (a bug of the caller).
    #[error("{0} before a factorisation")]
    NotFactorized(&'static str),
    /// A right-hand side of the wrong length (a bug of the caller).
    #[error("right-hand side of length {got} for a system of size {size}")]
    Size { got: usize, size: usize },
    /// Tangent entries that the grown sparsity pattern still lacks (a bug:
    /// a coupling the pattern was never told of).
    #[error("{entries} tangent entries fall outside the grown sparsity pattern")]
    OutsidePattern { entries: usize },
}

/// Why Newton gave up on one attempt of a step; the step is then cut back,
/// and the last reason is reported if even the smallest step fails.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum StepFailure {
    /// An element turned inside out (or another element failure).
    #[error(transparent)]
    Element(#[from] tidens_fem::FemError),
    /// The factorisation or a solve failed.
    #[error(transparent)]
    Linear(#[from] LinearError),
    /// The residual became NaN or infinite.
    #[error("non-finite residual")]
    NonFiniteResidual,
    /// Newton converged with a node inside a rigid plane.
    #[error("converged with a node {depth:.3e} mm inside a rigid plane")]
    PlanePenetration { depth: f64 },
    /// The augmented Lagrangian did not bring particle penetration within tolerance.
    #[error(
        "particle contact penetration {penetration:.3e} mm after {augmentations} augmentations"
    )]
    ContactPenetration {
        penetration: f64,
        augmentations: usize,
    },
    /// The iteration limit came first.
    #[error("{iterations} Newton iterations, residual {residual:.3e} N > {tolerance:.3e} N")]
    Iterations {
        iterations: usize,
        residual: f64,
        tolerance: f64,
    },
    /// Every point the line search tried inverted an element.
    #[error("every line-search point inverts an element")]
    LineSearch,
    /// The caller asked the run to stop (not a failure of the step: the
    /// step is abandoned, not cut back).
    #[error("interrupted")]
    Interrupted,
}

impl StepFailure {
    /// A short name of the kind of failure (for scripts: `ConvergenceError.reason`).
    pub fn kind(&self) -> &'static str {
        match self {
            StepFailure::Element(_) => "element",
            StepFailure::Linear(_) => "linear_algebra",
            StepFailure::NonFiniteResidual => "non_finite_residual",
            StepFailure::PlanePenetration { .. } => "plane_penetration",
            StepFailure::ContactPenetration { .. } => "contact_penetration",
            StepFailure::Iterations { .. } => "newton_iterations",
            StepFailure::LineSearch => "line_search",
            StepFailure::Interrupted => "interrupted",
        }
    }
}
