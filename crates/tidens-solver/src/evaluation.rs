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
    /// Internal force of the body plus the contact forces \[N\].
    pub f_int: Vec<f64>,
}

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
        Ok(Evaluation {
            body,
            contact,
            f_int,
        })
    }
}
