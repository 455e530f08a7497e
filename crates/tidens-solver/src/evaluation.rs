//! The body and particle contact evaluated at one configuration: element
//! forces and tangents (in parallel), contact terms, and their sum, the
//! internal force.

use crate::simulation::Simulation;
use std::time::Instant;
use tidens_contact::ContactEvaluation;
use tidens_fem::{BodyEvaluation, FemError};

/// Element and contact contributions at one configuration.
pub struct Evaluation {
    pub body: BodyEvaluation,
    pub contact: ContactEvaluation,
    /// Internal force of the body plus the contact forces \[N\] (and, in a
    /// periodic cell, the stabilising drag).
    pub f_int: Vec<f64>,
    /// The drag's stiffness on each dof's diagonal \[N/mm\] (empty without
    /// stabilisation; see [`Stabilisation`]).
    pub drag_diagonal: Vec<f64>,
    /// Sum of the magnitudes of the drag forces \[N\].
    pub drag_force: f64,
}

/// A weak drag on every particle node against its motion, over a step,
/// relative to the cell's affine (uniaxial) motion, for periodic cells.
///
/// Nothing else holds a particle's rigid motions there: a sphere pressed
/// by frictionless contacts can turn about its centre at no cost, and a
/// particle that touches none (a rattler) can move freely. Over a step the
/// drag on a node of volume share `V_i` is `k V_i (u_i - u_ref,i)`, with
/// `u_ref` the node's displacement at the step's start plus the affine
/// motion the step's predictor expects (the piston's displacement
/// extrapolated, so that the drag couples no dof to the piston), and
/// `k = beta f sigma / (R^2 de)`: `f sigma` the stress the cell feels at
/// the step's end, `R` the largest particle radius, `de` the strain
/// increment the predictor expects (at least the load increment's elastic
/// strain). A particle moving off the affine motion by `de R` over the
/// step, as rearranging particles do, then feels about `4 beta` of the load
/// it carries, whatever the creep rate. [`crate::RunStats`] reports the
/// largest drag, summed over the nodes, against the piston force.
#[derive(Clone, Debug)]
pub(crate) struct Stabilisation {
    /// Volume share of each dof's node \[mm^3\] (zero on image and pinned
    /// dofs).
    pub volume: Vec<f64>,
    /// Reference coordinate of each dof along z over the cell's height \[-\]
    /// (the affine motion's weight).
    pub height_fraction: Vec<f64>,
    /// `beta / R^2` \[1/mm^2\].
    pub scale: f64,
    /// `k` of the current step \[MPa/mm^2 = N/mm^4\].
    pub stiffness: f64,
    /// The displacement the drag is measured from in the current step: the
    /// start's plus the predictor's affine motion \[mm\].
    pub reference: Vec<f64>,
}

/// The drag's share `beta` of the load (see [`Stabilisation`]).
pub(crate) const STABILISATION: f64 = 1e-3;

impl Evaluation {
    /// True when the element and contact tangents were computed.
    pub fn has_tangent(&self) -> bool {
        self.body.has_tangent()
    }
}

impl Simulation {
    /// Current node coordinates (flat, `3 * node + i`) for displacement `u`.
    pub(crate) fn current_coordinates(&self, u: &[f64]) -> Vec<f64> {
        self.body
            .nodes()
            .iter()
            .flatten()
            .zip(u)
            .map(|(x, du)| x + du)
            .collect()
    }

    /// Elements and particle contact at displacement `u` after a step `dt`
    /// \[s\], with tangents if asked. The time taken is booked into the run's
    /// totals.
    pub(crate) fn evaluate(
        &mut self,
        u: &[f64],
        dt: f64,
        tangent: bool,
    ) -> Result<Evaluation, FemError> {
        let t0 = Instant::now();
        let body = self.body.evaluate(u, dt, tangent)?;
        let mut f_int = self.assembler.internal_force(&body);
        let t1 = Instant::now();
        self.stats.evaluation_seconds += (t1 - t0).as_secs_f64();
        self.stats.evaluations += 1;
        self.stats.tangent_evaluations += usize::from(tangent);
        let contact = match &self.contact {
            Some(c) => {
                let ev = c.evaluate(&self.current_coordinates(u), tangent);
                for t in &ev.terms {
                    for (d, f) in t.dofs.iter().zip(&t.force) {
                        f_int[*d] += f;
                    }
                }
                ev
            }
            None => ContactEvaluation::default(),
        };
        self.stats.contact_seconds += t1.elapsed().as_secs_f64();
        let (mut drag_diagonal, mut drag_force) = (Vec::new(), 0.0);
        if let Some(st) = &self.stabilisation {
            for (d, f) in f_int.iter_mut().enumerate() {
                let drag = st.stiffness * st.volume[d] * (u[d] - st.reference[d]);
                *f += drag;
                drag_force += drag.abs();
            }
            if tangent {
                drag_diagonal = st.volume.iter().map(|v| st.stiffness * v).collect();
            }
        }
        Ok(Evaluation {
            body,
            contact,
            f_int,
            drag_diagonal,
            drag_force,
        })
    }
}
