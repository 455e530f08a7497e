//! Checkpoints: the state a run hands from one step to the next, written
//! out so that a stopped run can go on.
//!
//! A run keeps some things only for speed: the factor of the tangent
//! (reused across steps while the contact set holds) and the sparsity
//! pattern grown for particle contacts. Every `Settings::checkpoint_every`
//! steps it forgets them, so that at those steps its whole state is what a
//! [`Checkpoint`] holds; a simulation resumed from one then takes the same
//! steps, to the bit, as the run that wrote it.

use crate::constraints::PlaneContactState;
use crate::error::SolverError;
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
/// triangles by default, and a link names a triangle).
const VERSION: u32 = 3;

/// The first field of every checkpoint, read alone so that one written by
/// another version of tidens is refused by its version, not by whichever
/// field first fails to parse.
#[derive(Deserialize)]
struct Header {
    version: u32,
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

    /// The checkpoint as bytes (CBOR: every number bit for bit).
    pub fn to_bytes(&self) -> Result<Vec<u8>, SolverError> {
        let mut out = Vec::new();
        ciborium::into_writer(self, &mut out)
            .map_err(|e| SolverError::Checkpoint(format!("cannot be written ({e})")))?;
        Ok(out)
    }

    /// A checkpoint from [`Checkpoint::to_bytes`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, SolverError> {
        let unreadable = |e| SolverError::Checkpoint(format!("cannot be read ({e})"));
        let header: Header = ciborium::from_reader(bytes).map_err(unreadable)?;
        if header.version != VERSION {
            return Err(SolverError::Checkpoint(format!(
                "written by another version of tidens (checkpoint format {}, \
                 this tidens reads format {VERSION}); run the case again from the start",
                header.version
            )));
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
        if comparable(&settings) != comparable(&checkpoint.settings) {
            return Err(SolverError::Checkpoint(
                "taken with other solver settings or another load".into(),
            ));
        }
        if material != checkpoint.material {
            return Err(SolverError::Checkpoint(
                "taken with another material".into(),
            ));
        }
        let mut sim = Simulation::new(scene, material, settings)?;
        if sim.constraints.dof_count() != checkpoint.state.u.len() {
            return Err(SolverError::Checkpoint(format!(
                "taken on a mesh of {} dofs, not this one of {}",
                checkpoint.state.u.len(),
                sim.constraints.dof_count()
            )));
        }
        sim.body
            .restore_states(&checkpoint.points)
            .map_err(|e| SolverError::Checkpoint(e.to_string()))?;
        sim.constraints.set_contact_state(checkpoint.planes.clone());
        match (sim.contact.as_mut(), &checkpoint.contact) {
            (Some(c), Some(saved)) => c
                .restore_checkpoint(saved)
                .map_err(|e| SolverError::Checkpoint(e.to_string()))?,
            (None, None) => {}
            _ => {
                return Err(SolverError::Checkpoint(
                    "taken on a cell with other particle contacts".into(),
                ));
            }
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
        let Err(SolverError::Checkpoint(message)) = Checkpoint::from_bytes(&written_with(1)) else {
            panic!("a format-1 checkpoint was read");
        };
        assert!(
            message.contains("another version of tidens") && message.contains("format 1"),
            "{message}"
        );
        // The right version with the wrong content is unreadable, not
        // another version's.
        let Err(SolverError::Checkpoint(message)) = Checkpoint::from_bytes(&written_with(VERSION))
        else {
            panic!("a checkpoint without its fields was read");
        };
        assert!(message.starts_with("cannot be read"), "{message}");
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
