//! What a run reports: the densification curve (one point per converged
//! step), the node and element fields of the last converged state, and the
//! run's totals.

use crate::linear::FactorizationCounts;
use crate::simulation::Simulation;
use serde::{Deserialize, Serialize};
use tidens_fem::ElementFields;

/// One converged step of the densification curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Time \[s\].
    pub time: f64,
    /// Relative density: particle volume over current cell volume.
    pub rel_density: f64,
    /// Piston displacement U \[mm\] (negative in compression).
    pub piston_displacement: f64,
    /// Applied nominal stress sigma(t) \[MPa\].
    pub applied_stress: f64,
    /// Stress acting on the cell, f sigma(t) \[MPa\].
    pub cell_stress: f64,
    /// Step number (0 for the initial state).
    pub step: usize,
    /// Newton iterations of this step (cut-back attempts included).
    pub newton_iterations: usize,
    /// Newton iterations since the start.
    pub newton_total: usize,
    /// Time step \[s\].
    pub dt: f64,
    /// Largest equivalent plastic strain increment at a Gauss point.
    pub max_strain_increment: f64,
    /// Current particle volume \[mm^3\].
    pub particle_volume: f64,
    /// Estimated error of `time` from the time discretisation \[s\]: the sum of
    /// the per-step backward-Euler errors (positive when `time` is late).
    pub time_error: f64,
    /// Surface dofs in contact with a rigid plane.
    pub contacts: usize,
    /// Surface nodes pressed against another particle (each contact pass
    /// counts its slave nodes that carry pressure; tied: nodes tied).
    pub particle_contacts: usize,
    /// Largest penetration of a surface node into a rigid plane or, through
    /// its link to a facet, into another particle \[mm\].
    pub max_penetration: f64,
    /// Largest depth of a surface node inside another particle, paired
    /// with one of its facets or not \[mm\]: parry's distance to the
    /// nearest point, on the inner side of its pseudo-normal (see
    /// `ParticleContact::max_depth`). Above `max_penetration` where a node
    /// that no link measures has gone in.
    #[serde(default)]
    pub max_depth: f64,
    /// Periodic cells: the mean number of contacts of a particle (the
    /// coordination number Z), twice the number of contacts over the
    /// number of particles. A contact is a pair of particles, or of a
    /// particle and a periodic image of one (so a particle touching the
    /// same neighbour across two box faces has two), with at least one
    /// node of either pressed on the other. None for other cells, whose
    /// particles are parts of spheroids.
    #[serde(default)]
    pub coordination_number: Option<f64>,
}

/// The contacts of a periodic cell's whole particles that the surface
/// pairs `pairs` (slave, master surface) make, surface `k` being
/// `surface_particles[k]`'s particle moved by its periods: the distinct
/// pairs of particles, each as (particle, particle, periods of the second
/// relative to the first) with the first particle not after the second
/// (and, for a particle and its own image, the periods not negative).
pub(crate) fn contact_pairs(
    pairs: impl IntoIterator<Item = (usize, usize)>,
    surface_particles: &[(usize, [i8; 3])],
) -> std::collections::BTreeSet<(usize, usize, [i8; 3])> {
    pairs
        .into_iter()
        .map(|(s, m)| {
            let ((a, pa), (b, pb)) = (surface_particles[s], surface_particles[m]);
            let periods: [i8; 3] = std::array::from_fn(|i| pb[i] - pa[i]);
            let back = periods.map(|p| -p);
            if a < b || (a == b && periods >= back) {
                (a, b, periods)
            } else {
                (b, a, back)
            }
        })
        .collect()
}

/// Why a run stopped, or that it goes on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Status {
    Running,
    ReachedDensity,
    ReachedTime,
    /// The pores have closed: a packing that started below [`FULL_DENSITY`]
    /// reached it before its target (a long hold). Nothing more can densify, and going on would only
    /// press the faceted surfaces of touching particles into each other.
    FullDensity,
}

/// The relative density at which a run ends with [`Status::FullDensity`].
/// (On bcc at level 1, a hold to 1e6 s reached 1.0000 at 1.5e4 s, then
/// 1.008 at 4.7e4 s with the particle volume unchanged, the facets of
/// touching particles overlapping between their nodes, and failed.)
pub const FULL_DENSITY: f64 = 0.9999;

/// Node and element fields of the last converged state, for output.
#[derive(Clone, Debug, PartialEq)]
pub struct Fields {
    /// Current node coordinates \[mm\].
    pub points: Vec<[f64; 3]>,
    /// Node displacements \[mm\].
    pub displacement: Vec<[f64; 3]>,
    /// Force exerted by the rigid planes on each node \[N\].
    pub contact_force: Vec<[f64; 3]>,
    /// Particle-particle contact pressure at each node \[MPa\] (0 where none).
    pub contact_pressure: Vec<f64>,
    /// Hexahedra (VTK order).
    pub cells: Vec<[usize; 8]>,
    /// Element nodes (VTK order) of every element, whatever its kind.
    pub connectivity: Vec<Vec<usize>>,
    /// The cell type name in VTK/meshio (`hexahedron` or `tetra10`).
    pub cell_type: &'static str,
    /// Element fields (von Mises, mean stress, equivalent plastic strain).
    pub element: ElementFields,
}

/// Totals of a run so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunStats {
    pub steps: usize,
    pub newton_iterations: usize,
    pub rejected_steps: usize,
    pub failed_attempts: usize,
    pub factorizations: FactorizationCounts,
    /// Evaluations of the body (and contact), and how many of them with
    /// tangents.
    pub evaluations: usize,
    pub tangent_evaluations: usize,
    /// Wall time in element evaluations (residual and tangent) \[s\].
    pub evaluation_seconds: f64,
    /// Wall time in particle contact: pairing nodes with facets (the parry
    /// search) and evaluating the contact terms \[s\].
    pub contact_seconds: f64,
    /// Wall time gathering element and contact tangents into the sparse
    /// system \[s\].
    pub assembly_seconds: f64,
    /// Wall time in sparse factorisations and solves \[s\].
    pub linear_seconds: f64,
    /// Times the sparsity pattern grew for new particle contacts.
    pub pattern_rebuilds: usize,
    /// Periodic cells: the largest stabilising drag of an accepted step,
    /// summed over the nodes, over the piston force then (0 elsewhere).
    #[serde(default)]
    pub max_drag_share: f64,
    /// Wall time in [`Simulation::advance`] over the steps of the curve,
    /// summed across resumes (steps recomputed after a resume count once;
    /// checkpoints written before this total existed start it at zero) \[s\].
    #[serde(default)]
    pub wall_seconds: f64,
}

impl Simulation {
    /// The curve point of the current (last converged) state.
    pub(crate) fn curve_point(
        &self,
        volume: f64,
        step: usize,
        iterations: usize,
        dt: f64,
        max_dp: f64,
    ) -> CurvePoint {
        let load = &self.settings.load;
        let state = &self.state;
        CurvePoint {
            time: state.time,
            rel_density: self.density_of(volume, state.piston),
            piston_displacement: state.piston,
            applied_stress: load.applied_stress(state.time),
            cell_stress: load.cell_stress(state.time),
            step,
            newton_iterations: iterations,
            newton_total: self.stats.newton_iterations,
            dt,
            max_strain_increment: max_dp,
            particle_volume: volume,
            time_error: self.control.time_error(),
            contacts: self.constraints.contact_counts().iter().sum(),
            // Nodes pressed on another particle, once each (a node in a
            // fold of the other's surface presses on two of its facets).
            particle_contacts: state
                .contact
                .terms
                .iter()
                .filter(|t| t.pressure > 0.0)
                .map(|t| (t.slave, t.master.0))
                .collect::<std::collections::BTreeSet<_>>()
                .len(),
            coordination_number: (!self.surface_particles.is_empty()).then(|| {
                let particles = self
                    .surface_particles
                    .iter()
                    .filter(|p| p.1 == [0; 3])
                    .count();
                let pressed = state
                    .contact
                    .terms
                    .iter()
                    .filter(|t| t.pressure > 0.0)
                    .map(|t| (t.slave.0, t.master.0));
                2.0 * contact_pairs(pressed, &self.surface_particles).len() as f64
                    / particles as f64
            }),
            max_penetration: self
                .constraints
                .max_penetration(&state.u, state.piston)
                .max(state.contact.max_penetration()),
            max_depth: self.contact.as_ref().map_or(0.0, |c| {
                let x = self.current_coordinates(&state.u);
                if std::env::var_os("TIDENS_DEBUG").is_some()
                    && let Some(d) = c.deepest(&x)
                {
                    eprintln!(
                        "  deepest node at t = {:.5e} s: {d:?}; {}",
                        state.time,
                        c.describe_node(&x, d.slave, d.node)
                    );
                }
                c.max_depth(&x)
            }),
        }
    }

    /// Fields of the last converged state.
    pub fn fields(&self) -> Fields {
        let nodes = self.body.nodes();
        let state = &self.state;
        let mut points = Vec::with_capacity(nodes.len());
        let mut displacement = Vec::with_capacity(nodes.len());
        let mut contact_force = Vec::with_capacity(nodes.len());
        for (a, p) in nodes.iter().enumerate() {
            let u = [state.u[3 * a], state.u[3 * a + 1], state.u[3 * a + 2]];
            points.push([p[0] + u[0], p[1] + u[1], p[2] + u[2]]);
            displacement.push(u);
            contact_force.push([0, 1, 2].map(|i| {
                let d = 3 * a + i;
                if self.constraints.is_held(d) {
                    state.f_int[d]
                } else {
                    0.0
                }
            }));
        }
        let mut contact_pressure = vec![0.0; nodes.len()];
        if let Some(c) = &self.contact {
            for t in &state.contact.terms {
                let node = c.surfaces()[t.slave.0].nodes[t.slave.1];
                contact_pressure[node] = f64::max(contact_pressure[node], t.pressure);
            }
        }
        Fields {
            points,
            displacement,
            contact_force,
            contact_pressure,
            cells: (0..self.body.element_count())
                .filter_map(|e| <[usize; 8]>::try_from(self.body.element_nodes(e)).ok())
                .collect(),
            connectivity: (0..self.body.element_count())
                .map(|e| self.body.element_nodes(e).to_vec())
                .collect(),
            cell_type: self.body.kind().vtk_name(),
            element: state.fields.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::contact_pairs;

    /// Both passes of a contact, and a particle's contacts with its own
    /// image seen from either side, are one contact each.
    #[test]
    fn a_contact_is_counted_once_whichever_side_presses() {
        // Surfaces: particles 0 and 1, then 1 moved by +x, 0 moved by +x
        // and by -x.
        let surfaces = [
            (0, [0, 0, 0]),
            (1, [0, 0, 0]),
            (1, [1, 0, 0]),
            (0, [1, 0, 0]),
            (0, [-1, 0, 0]),
        ];
        let pairs = contact_pairs(
            [
                (0, 1),
                (1, 0),
                (0, 2),
                // 1 on the image of 0 at -x is 0 on the image of 1 at +x.
                (1, 4),
                (0, 3),
                (0, 4),
            ],
            &surfaces,
        );
        let expected = [(0, 0, [1, 0, 0]), (0, 1, [0, 0, 0]), (0, 1, [1, 0, 0])];
        assert_eq!(pairs.into_iter().collect::<Vec<_>>(), expected);
    }
}
