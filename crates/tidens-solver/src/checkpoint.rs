//! Checkpoints: the state a run hands from one step to the next, written
//! out so that a stopped run can go on.
//!
//! A run keeps some things only for speed: the factor of the tangent
//! (reused across steps while the contact set holds) and the sparsity
//! pattern grown for particle contacts. Every `Settings::checkpoint_every`
//! steps it forgets them, so that at those steps its whole state is what a
//! [`Checkpoint`] holds; a simulation resumed from one then takes the same
//! steps, to the bit, as the run that wrote it.
//!
//! # The file
//! A checkpoint lives for days in a run's folder, where a full disk, a
//! killed copy or a flipped bit can spoil it, and a spoilt checkpoint must
//! be refused by what is wrong with it, not resumed into a wrong run nor
//! refused with a decoder's debug text. So the CBOR of the state
//! (`ciborium`: every f64 bit for bit) is framed, all integers little
//! endian:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | [`MAGIC`], `tidensCK` |
//! | 4 | the format [`VERSION`] |
//! | 8 | `n`, the length of the CBOR |
//! | 4 | the low 32 bits of the FNV-1a hash of the 20 bytes before |
//! | `n` | the CBOR of the [`Checkpoint`] |
//! | 8 | the FNV-1a hash (64 bits) of the CBOR |
//!
//! The frame stays the same from one format to the next, so that any
//! later format is refused by its version. Reading checks, in this order:
//! that there are bytes at all ([`CheckpointError::Empty`]), the mark
//! ([`CheckpointError::NotACheckpoint`], or damaged when it differs from
//! [`MAGIC`] by a bit or two), the length
//! ([`CheckpointError::Truncated`]), the header's hash, the version, the
//! CBOR's hash ([`CheckpointError::Damaged`]), and only then decodes.
//! FNV-1a catches every change within one byte (each step of the hash is a
//! bijection of its state) and a change of several bytes but with a
//! chance of 2^-64. Format 3, the CBOR alone without the frame, is still
//! read (runs stopped before the frame came can go on), without the hash
//! checks.

use crate::constraints::PlaneContactState;
use crate::error::{CheckpointError, SolverError};
use crate::output::{CurvePoint, RunStats, Status};
use crate::scene::Scene;
use crate::settings::Settings;
use crate::simulation::{ConvergedState, Simulation};
use crate::step_control::StepController;
use serde::{Deserialize, Serialize};
use tidens_contact::ContactCheckpoint;
use tidens_material::{Material, PointState};

/// The format version written into each checkpoint. Raised whenever what a
/// checkpoint holds changes shape or meaning (2: each contact link keeps
/// where its node last projected; 3: hexahedral surfaces' master facets are
/// triangles by default, and a link names a triangle; 4: the frame of the
/// module docs, with its length and hashes).
pub(crate) const VERSION: u32 = 4;

/// The last format without the frame, still read.
const UNFRAMED_VERSION: u32 = 3;

/// The first bytes of every framed checkpoint.
pub(crate) const MAGIC: [u8; 8] = *b"tidensCK";

/// Bytes of the frame before the CBOR: the mark, the version, the length
/// and the header's hash.
const HEADER_LEN: usize = 24;

/// Bytes of the frame after the CBOR: its hash.
const TRAILER_LEN: usize = 8;

/// The first field of every checkpoint of format 3 and before, read alone
/// so that one written by another version of tidens is refused by its
/// version, not by whichever field first fails to parse.
#[derive(Deserialize)]
struct Header {
    version: u32,
}

/// FNV-1a, 64 bits (offset basis and prime of the FNV reference).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The little-endian integer in `bytes[at..at + N]` (the caller checked
/// the length).
fn le_bytes<const N: usize>(bytes: &[u8], at: usize) -> [u8; N] {
    let mut out = [0; N];
    out.copy_from_slice(&bytes[at..at + N]);
    out
}

/// What a CBOR decoder's error means, in words (its own `Display` is its
/// `Debug`: "Syntax(97)", "Io(Error { kind: UnexpectedEof, .. })").
fn describe_decoding(e: ciborium::de::Error<std::io::Error>) -> String {
    use ciborium::de::Error;
    match e {
        Error::Io(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            "it ends in the middle of a value".into()
        }
        Error::Io(e) => format!("it cannot be read: {e}"),
        Error::Syntax(at) => format!("its bytes stop making sense at byte {at}"),
        Error::Semantic(Some(at), what) => format!("{what}, at byte {at}"),
        Error::Semantic(None, what) => what,
        Error::RecursionLimitExceeded => "its values nest too deeply".into(),
    }
}

/// What a CBOR encoder's error means, in words.
fn describe_encoding(e: ciborium::ser::Error<std::io::Error>) -> String {
    match e {
        ciborium::ser::Error::Io(e) => e.to_string(),
        ciborium::ser::Error::Value(what) => what,
    }
}

/// Everything of a run at a step: converged state, material history,
/// contact sets and multipliers, the step controller, the curve and the
/// totals, and the settings it ran with.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Checkpoint {
    version: u32,
    settings: Settings,
    material: Material,
    state: ConvergedState,
    points: Vec<PointState>,
    planes: PlaneContactState,
    contact: Option<ContactCheckpoint>,
    control: StepController,
    curve: Vec<CurvePoint>,
    stats: RunStats,
    counts: crate::linear::FactorizationCounts,
    status: Status,
}

impl Checkpoint {
    /// The step it was taken at.
    pub fn step(&self) -> usize {
        self.stats.steps
    }

    /// Whether it was taken where the run had just forgotten its caches, so
    /// that a resumed run goes on bit for bit (see the module docs).
    pub fn exact(&self) -> bool {
        let every = self.settings.checkpoint_every;
        every > 0 && self.stats.steps.is_multiple_of(every)
    }

    /// The settings of the run.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The checkpoint as bytes: its CBOR (every number bit for bit) in the
    /// frame of the module docs.
    pub fn to_bytes(&self) -> Result<Vec<u8>, SolverError> {
        let mut cbor = Vec::new();
        ciborium::into_writer(self, &mut cbor).map_err(|e| CheckpointError::Unwritable {
            detail: describe_encoding(e),
        })?;
        let mut out = Vec::with_capacity(HEADER_LEN + cbor.len() + TRAILER_LEN);
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(cbor.len() as u64).to_le_bytes());
        // The low half of the hash: the header's check is 32 bits.
        let header_hash = fnv1a(&out) as u32;
        out.extend_from_slice(&header_hash.to_le_bytes());
        out.extend_from_slice(&cbor);
        out.extend_from_slice(&fnv1a(&cbor).to_le_bytes());
        Ok(out)
    }

    /// A checkpoint from [`Checkpoint::to_bytes`] (or of format 3).
    ///
    /// # Errors
    /// [`SolverError::Checkpoint`] with the [`CheckpointError`] that says
    /// what is wrong with the bytes: none, cut short, not a checkpoint,
    /// another format, or damaged.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, SolverError> {
        Ok(Self::decode(bytes)?)
    }

    fn decode(bytes: &[u8]) -> Result<Self, CheckpointError> {
        if bytes.is_empty() {
            return Err(CheckpointError::Empty);
        }
        let mark = &bytes[..bytes.len().min(MAGIC.len())];
        if mark != &MAGIC[..mark.len()] {
            return Self::decode_unframed(bytes);
        }
        if bytes.len() < HEADER_LEN {
            return Err(CheckpointError::Truncated {
                length: bytes.len(),
                needed: None,
            });
        }
        let stored_hash = u32::from_le_bytes(le_bytes(bytes, 20));
        if fnv1a(&bytes[..20]) as u32 != stored_hash {
            return Err(CheckpointError::Damaged {
                detail: "its header (format and length) does not match its hash".into(),
            });
        }
        let version = u32::from_le_bytes(le_bytes(bytes, 8));
        if version != VERSION {
            return Err(CheckpointError::Version {
                found: version,
                expected: VERSION,
            });
        }
        let n = u64::from_le_bytes(le_bytes(bytes, 12));
        let needed = usize::try_from(n)
            .ok()
            .and_then(|n| n.checked_add(HEADER_LEN + TRAILER_LEN));
        let Some(needed) = needed.filter(|&needed| needed <= bytes.len()) else {
            return Err(CheckpointError::Truncated {
                length: bytes.len(),
                needed: Some(needed.unwrap_or(usize::MAX)),
            });
        };
        if needed < bytes.len() {
            return Err(CheckpointError::Damaged {
                detail: format!(
                    "{} bytes follow the end of the checkpoint",
                    bytes.len() - needed
                ),
            });
        }
        let cbor = &bytes[HEADER_LEN..needed - TRAILER_LEN];
        let stored_hash = u64::from_le_bytes(le_bytes(bytes, needed - TRAILER_LEN));
        if fnv1a(cbor) != stored_hash {
            return Err(CheckpointError::Damaged {
                detail: "its contents do not match their hash".into(),
            });
        }
        // The hash matched: bytes that do not decode were written so.
        ciborium::from_reader(cbor).map_err(|e| CheckpointError::Damaged {
            detail: describe_decoding(e),
        })
    }

    /// Bytes without the frame's mark: the CBOR of format 3 (or before,
    /// refused by its version), a mark a bit or two off, or no checkpoint.
    fn decode_unframed(bytes: &[u8]) -> Result<Self, CheckpointError> {
        if bytes.len() >= MAGIC.len() {
            let flipped: u32 = bytes[..MAGIC.len()]
                .iter()
                .zip(&MAGIC)
                .map(|(a, b)| (a ^ b).count_ones())
                .sum();
            if flipped <= 2 {
                return Err(CheckpointError::Damaged {
                    detail: format!(
                        "its first bytes, a checkpoint's mark, have {flipped} bits changed"
                    ),
                });
            }
        }
        // Formats 1 to 3 are a CBOR map whose first key is "version" (a map
        // of up to 23 entries, then the key as a text of 7 bytes).
        let unframed = matches!(bytes.first(), Some(0xa0..=0xb7))
            && bytes.get(1..9) == Some(b"\x67version".as_slice());
        if !unframed {
            return Err(CheckpointError::NotACheckpoint);
        }
        let unreadable = |e: ciborium::de::Error<std::io::Error>| match e {
            ciborium::de::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
                CheckpointError::Truncated {
                    length: bytes.len(),
                    needed: None,
                }
            }
            e => CheckpointError::Damaged {
                detail: describe_decoding(e),
            },
        };
        let header: Header = ciborium::from_reader(bytes).map_err(unreadable)?;
        if header.version != UNFRAMED_VERSION {
            return Err(CheckpointError::Version {
                found: header.version,
                expected: VERSION,
            });
        }
        ciborium::from_reader(bytes).map_err(unreadable)
    }
}

impl Simulation {
    /// The run's state now; exact for a resume when taken right after a
    /// step that is a multiple of `checkpoint_every` ([`Checkpoint::exact`]).
    pub fn checkpoint(&self) -> Checkpoint {
        Checkpoint {
            version: VERSION,
            settings: self.settings.clone(),
            material: *self.body.material(),
            state: self.state.clone(),
            points: self.body.states().to_vec(),
            planes: self.constraints.contact_state(),
            contact: self.contact.as_ref().map(|c| c.checkpoint()),
            control: self.control.clone(),
            curve: self.curve.clone(),
            stats: RunStats {
                pattern_rebuilds: self.stats.pattern_rebuilds + self.assembler.pattern_rebuilds(),
                ..self.stats
            },
            counts: self.linear.counts,
            status: self.status,
        }
    }

    /// A simulation of `scene` that goes on from `checkpoint`. The stop
    /// conditions, the step limit and the checkpoint interval are
    /// `settings`' (a run can be extended, and checkpointed more or less
    /// often from here on: the interval only says where the run forgets what
    /// it keeps for speed); everything else must be what the checkpoint was
    /// taken with.
    pub fn resume(
        scene: &Scene,
        material: Material,
        settings: Settings,
        checkpoint: &Checkpoint,
    ) -> Result<Self, SolverError> {
        let comparable = |s: &Settings| Settings {
            until_density: None,
            until_time: None,
            max_steps: 0,
            checkpoint_every: 0,
            ..s.clone()
        };
        let other = |what: String| SolverError::from(CheckpointError::OtherCase { what });
        if comparable(&settings) != comparable(&checkpoint.settings) {
            return Err(other("other solver settings or another load".into()));
        }
        if material != checkpoint.material {
            return Err(other("another material".into()));
        }
        let mut sim = Simulation::new(scene, material, settings)?;
        if sim.constraints.dof_count() != checkpoint.state.u.len() {
            return Err(other(format!(
                "a mesh of {} dofs, not this one of {}",
                checkpoint.state.u.len(),
                sim.constraints.dof_count()
            )));
        }
        sim.body
            .restore_states(&checkpoint.points)
            .map_err(|e| other(format!("another mesh ({e})")))?;
        sim.constraints.set_contact_state(checkpoint.planes.clone());
        match (sim.contact.as_mut(), &checkpoint.contact) {
            (Some(c), Some(saved)) => c
                .restore_checkpoint(saved)
                .map_err(|e| other(format!("other particles ({e})")))?,
            (None, None) => {}
            _ => return Err(other("a cell with other particle contacts".into())),
        }
        sim.state = checkpoint.state.clone();
        sim.control = checkpoint.control.clone();
        sim.curve = checkpoint.curve.clone();
        sim.stats = checkpoint.stats;
        sim.linear.counts = checkpoint.counts;
        sim.status = checkpoint.status;
        // The stop conditions may differ from the checkpoint's run.
        if sim.status != Status::Running {
            sim.status = Status::Running;
        }
        sim.check_stop();
        Ok(sim)
    }

    /// Forgets the factor of the tangent and the pattern grown for particle
    /// contacts (kept only for speed): the state is then all a checkpoint holds.
    pub(crate) fn forget_caches(&mut self) {
        self.stats.pattern_rebuilds += self.assembler.pattern_rebuilds();
        self.factor = None;
        self.linear.forget();
        self.assembler.forget_contacts();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error of `bytes` read as a checkpoint, checked to read as words:
    /// no decoder's debug text.
    fn refusal(bytes: &[u8]) -> CheckpointError {
        match Checkpoint::from_bytes(bytes) {
            Ok(_) => panic!("{} bytes were read as a checkpoint", bytes.len()),
            Err(SolverError::Checkpoint(e)) => {
                let message = SolverError::Checkpoint(e.clone()).to_string();
                for debug in ["Error {", "Syntax(", "Io(", "Semantic(", "kind:"] {
                    assert!(!message.contains(debug), "{message}");
                }
                e
            }
            Err(e) => panic!("not a checkpoint error: {e}"),
        }
    }

    /// A real checkpoint: the bcc cell (with its particle contact) after
    /// two steps.
    fn written() -> Vec<u8> {
        let mut sim = crate::test_support::bcc_level1(|s| s.until_time = Some(1.0));
        sim.advance().unwrap();
        sim.advance().unwrap();
        sim.checkpoint().to_bytes().unwrap()
    }

    /// Bytes of xorshift64 from `seed`.
    fn noise(len: usize, mut seed: u64) -> Vec<u8> {
        (0..len)
            .map(|_| {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                (seed >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn a_checkpoint_reads_back_to_the_bit() {
        let bytes = written();
        assert_eq!(&bytes[..8], b"tidensCK");
        let read = Checkpoint::from_bytes(&bytes).unwrap();
        assert_eq!(read.step(), 2);
        assert_eq!(read.to_bytes().unwrap(), bytes);
    }

    #[test]
    fn empty_truncated_and_foreign_bytes_are_refused_by_what_they_are() {
        let bytes = written();
        let n = bytes.len();
        assert_eq!(refusal(&[]), CheckpointError::Empty);
        // Cut inside the mark, inside the header, and anywhere in the rest.
        for cut in [1, 5, 8, 19, 23] {
            assert_eq!(
                refusal(&bytes[..cut]),
                CheckpointError::Truncated {
                    length: cut,
                    needed: None
                }
            );
        }
        for cut in [24, 25, 100, n / 3, n / 2, n - 9, n - 8, n - 1] {
            let e = refusal(&bytes[..cut]);
            assert_eq!(
                e,
                CheckpointError::Truncated {
                    length: cut,
                    needed: Some(n)
                }
            );
            assert!(
                e.to_string()
                    .starts_with(&format!("truncated (ends after {cut} of the {n} bytes")),
                "{e}"
            );
        }
        for (len, seed) in [(1, 1), (7, 2), (64, 3), (5000, 4), (n, 5)] {
            assert_eq!(refusal(&noise(len, seed)), CheckpointError::NotACheckpoint);
        }
        assert_eq!(refusal(b"{\"step\": 3}\n"), CheckpointError::NotACheckpoint);
        // Bytes after the end: another file appended, say.
        let mut longer = bytes.clone();
        longer.extend_from_slice(b"more");
        let CheckpointError::Damaged { detail } = refusal(&longer) else {
            panic!("bytes after the end were not found");
        };
        assert!(detail.contains("4 bytes follow"), "{detail}");
    }

    #[test]
    fn every_flipped_bit_is_found() {
        let bytes = written();
        let n = bytes.len();
        // Every byte of the header, the hash at the end, and bytes spread
        // over the CBOR; one bit of each, a different one each time.
        let positions = (0..24).chain(n - 8..n).chain((24..n - 8).step_by(n / 200));
        let mut flipped = 0;
        for at in positions {
            let mut bad = bytes.clone();
            bad[at] ^= 1 << (at % 8);
            let e = refusal(&bad);
            assert!(
                matches!(e, CheckpointError::Damaged { .. }),
                "bit {} of byte {at}: {e}",
                at % 8
            );
            assert!(e.to_string().starts_with("damaged ("), "{e}");
            flipped += 1;
        }
        assert!(flipped > 200, "{flipped}");
    }

    /// Bytes of a map holding `version` and a field of no checkpoint.
    fn written_with(version: u32) -> Vec<u8> {
        #[derive(Serialize)]
        struct Other {
            version: u32,
            links: Vec<(usize, usize)>,
        }
        let mut out = Vec::new();
        let other = Other {
            version,
            links: vec![(3, 4)],
        };
        ciborium::into_writer(&other, &mut out).unwrap();
        out
    }

    #[test]
    fn a_checkpoint_of_another_format_is_refused_by_its_version() {
        // The formats before the frame (1 and 2 refused, 3 still read).
        let e = refusal(&written_with(1));
        assert_eq!(
            e,
            CheckpointError::Version {
                found: 1,
                expected: VERSION
            }
        );
        assert!(
            e.to_string().contains("another version of tidens")
                && e.to_string().contains("format 1"),
            "{e}"
        );
        // Format 3 with the wrong content is damaged, not another version's.
        let CheckpointError::Damaged { detail } = refusal(&written_with(UNFRAMED_VERSION)) else {
            panic!("a checkpoint without its fields was read");
        };
        assert!(detail.contains("missing field"), "{detail}");
        // A later format, its header whole.
        let mut later = written();
        later[8..12].copy_from_slice(&7u32.to_le_bytes());
        let hash = fnv1a(&later[..20]) as u32;
        later[20..24].copy_from_slice(&hash.to_le_bytes());
        assert_eq!(
            refusal(&later),
            CheckpointError::Version {
                found: 7,
                expected: VERSION
            }
        );
    }

    /// A checkpoint of format 3 (the CBOR without the frame) is read; cut
    /// short, it is truncated.
    #[test]
    fn a_checkpoint_of_format_3_is_still_read() {
        let framed = written();
        let mut state = Checkpoint::from_bytes(&framed).unwrap();
        state.version = UNFRAMED_VERSION;
        let mut unframed = Vec::new();
        ciborium::into_writer(&state, &mut unframed).unwrap();
        let read = Checkpoint::from_bytes(&unframed).unwrap();
        assert_eq!(read.to_bytes().unwrap(), state.to_bytes().unwrap());
        let cut = unframed.len() / 2;
        assert_eq!(
            refusal(&unframed[..cut]),
            CheckpointError::Truncated {
                length: cut,
                needed: None
            }
        );
    }

    /// Forgetting the caches keeps the tangent whole: the periodic cell's
    /// rotation hold couples each particle's frame nodes for the whole run,
    /// and the pattern the run forgets is only the one grown for particle
    /// contacts. (A pattern rebuilt from the elements alone once lost those
    /// couplings after the 50th step: every factorisation then grew the
    /// pattern and redid the symbolic analysis, and the tangent left the
    /// hold's coupling out.)
    #[test]
    fn forgetting_the_caches_keeps_the_rotation_hold_in_the_tangent() {
        let mut sim = crate::test_support::periodic_sphere_level1(|s| s.until_time = Some(1.0));
        for _ in 0..3 {
            sim.advance().unwrap();
        }
        let dt = 1e-2;
        let u = sim.state.u.clone();
        let eval = sim.evaluate(&u, dt, true).unwrap();
        assert!(!eval.rotation_tangents.is_empty(), "the hold acts");
        let before = sim.assemble_tangent(dt).unwrap().clone();
        sim.forget_caches();
        let after = sim.assemble_tangent(dt).unwrap();
        crate::test_support::assert_same_system(after, &before, "tangent after forgetting");
    }
}
