//! What a generation is doing, as [`Packing::generate_unless`] and
//! [`Packing::jam_unless`] report it to their `stop` callback.
//!
//! A packing of thousands of particles near jamming takes minutes (10000
//! spheres jammed: several), so its caller must be able to stop it (Ctrl-C,
//! a batch system's SIGTERM) and to say how far it got. The callback is
//! asked before every FIRE iteration of the relaxation, the only part whose
//! cost grows with the count and the density. Measured on 10000 spheres
//! (`tests/interrupt.rs`, release build, one core of a shared 2-core
//! machine): an iteration takes about 3.5 ms, the longest wait between two
//! calls was 22 ms (the random start's placement and first neighbour list),
//! and the generation returned 1 ms after the stop, far below the 0.2 s a
//! user notices.
//!
//! [`Packing::generate_unless`]: crate::Packing::generate_unless
//! [`Packing::jam_unless`]: crate::Packing::jam_unless

/// The stage of the protocol (see the crate documentation, Method).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Relaxing the random start at a relative density of 0.25.
    Start,
    /// Growing the particles by density steps toward `rho0`.
    Compress,
    /// Relaxing a decompressed and shaken packing after a jam.
    Shake,
    /// Locating the jamming point of a jammed packing
    /// ([`crate::Packing::jam`] only).
    Refine,
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Stage {
    /// A short lowercase name: `start`, `compress`, `shake`, `refine`.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Start => "start",
            Stage::Compress => "compress",
            Stage::Shake => "shake",
            Stage::Refine => "refine",
        }
    }
}

/// How far a generation got.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// What it is doing.
    pub stage: Stage,
    /// The relative density the particles are being relaxed at.
    pub rel_density: f64,
    /// The densest overlap-free relative density accepted so far (0 before
    /// the random start is relaxed).
    pub densest: f64,
    /// The compression round: 0 the first, `k` after the `k`-th shake (at
    /// most 20, see [`crate::PackingError::Rho0Unreachable`]).
    pub round: usize,
    /// FIRE iterations so far, every stage counted.
    pub iterations: u64,
}

impl Progress {
    pub(crate) fn new() -> Self {
        Progress {
            stage: Stage::Start,
            rel_density: 0.0,
            densest: 0.0,
            round: 0,
            iterations: 0,
        }
    }
}

/// The generation was stopped by its caller (the callback answered true).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Stopped;
