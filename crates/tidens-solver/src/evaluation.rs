//! The body and particle contact evaluated at one configuration: element
//! forces and tangents (in parallel), contact terms, and their sum, the
//! internal force.

use crate::simulation::Simulation;
use std::time::Instant;
use tidens_contact::ContactEvaluation;
use tidens_fem::{BodyEvaluation, FemError};

/// Element and contact contributions at one configuration.
#[derive(Clone)]
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
    /// The rotation holds' tangents: per particle, its frame's dofs and
    /// the dense block over them (row-major) \[N/mm\] (empty without
    /// stabilisation or without tangents).
    pub rotation_tangents: Vec<(Vec<usize>, Vec<f64>)>,
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
    /// Each particle's rotation frame (see [`RotationFrame`]).
    pub frames: Vec<RotationFrame>,
    /// The rotation hold's stiffness over the drag's, `beta_rot / beta`.
    pub rotation_factor: f64,
}

/// A hold on a particle's rigid rotation over a step, for periodic cells.
///
/// The drag holds a particle's rotation only as weakly as its other
/// motions, and a sphere pressed by frictionless contacts turns at no cost
/// in the tangent, while its faceted surface resists the turn: Newton's
/// directions are then rotations many times larger than the deformation,
/// which the line search cuts to a few per cent. The hold charges the
/// particle's rotation alone, fitted over a few nodes of its core (the
/// frame), and leaves its deformation and translation to the drag. With
/// `v_i` the frame nodes' motion over the step relative to the drag's
/// reference and `r_i` their arms from the frame's centroid, the fitted
/// rotation is `w = J^-1 sum r_i x v_i`, `J = sum (|r_i|^2 I - r_i r_i^T)`
/// (exact for a rigid turn, blind to a translation); its energy is
/// `k_rot W w^T J w / 2` and the force on a frame node `k_rot W (w x r_i)`,
/// with `W` the particle's polar moment of volume over the frame's
/// (`tr J_particle / tr J`), so that `k_rot = k` charges a rotation as the
/// drag charges it on the whole particle. Its tangent couples the frame's
/// nodes densely (a few per particle).
#[derive(Clone, Debug)]
pub(crate) struct RotationFrame {
    /// The frame nodes (free: not pinned, not images).
    pub nodes: Vec<usize>,
    /// `W`: the particle's polar moment of volume over the frame's
    /// \[mm^3\].
    pub weight: f64,
    /// Arms `r_i` from the frame's centroid at the step's reference \[mm\].
    pub arms: Vec<nalgebra::Vector3<f64>>,
    /// `J^-1` \[1/mm^2\].
    pub j_inv: nalgebra::Matrix3<f64>,
    /// The largest `k_rot` \[N/mm^4\]: `ROTATION_HOLD_CAP E h / W`, `h` the
    /// particle's mean element size (see [`ROTATION_HOLD_CAP`]).
    pub max_stiffness: f64,
}

impl RotationFrame {
    /// Arms and `J^-1` at the reference configuration `x` (flat node
    /// coordinates, `3 * node + i`) \[mm\].
    pub fn place(&mut self, x: impl Fn(usize) -> nalgebra::Vector3<f64>) {
        let points: Vec<_> = self.nodes.iter().map(|&n| x(n)).collect();
        let centroid = points.iter().sum::<nalgebra::Vector3<f64>>() / points.len() as f64;
        self.arms = points.iter().map(|p| p - centroid).collect();
        let j = moment(&self.arms);
        self.j_inv = j.try_inverse().unwrap_or_else(nalgebra::Matrix3::zeros);
    }

    /// The fitted rotation of motions `v` (flat over all dofs) \[rad\].
    pub fn rotation(&self, v: impl Fn(usize) -> f64) -> nalgebra::Vector3<f64> {
        let turn: nalgebra::Vector3<f64> = self
            .nodes
            .iter()
            .zip(&self.arms)
            .map(|(&n, r)| {
                r.cross(&nalgebra::Vector3::new(
                    v(3 * n),
                    v(3 * n + 1),
                    v(3 * n + 2),
                ))
            })
            .sum();
        self.j_inv * turn
    }

    /// The hold's force on each frame node \[N\] for motions `v` (flat over
    /// all dofs) \[mm\] at stiffness `k` \[N/mm^4\]: `k W (w x r_i)`, the
    /// gradient of `k W w^T J w / 2`.
    pub fn forces(&self, v: impl Fn(usize) -> f64, k: f64) -> Vec<nalgebra::Vector3<f64>> {
        let w = self.rotation(v);
        self.arms
            .iter()
            .map(|r| w.cross(r) * (k * self.weight))
            .collect()
    }

    /// The frame's dofs, three per node.
    pub fn dofs(&self) -> Vec<usize> {
        self.nodes
            .iter()
            .flat_map(|&n| [3 * n, 3 * n + 1, 3 * n + 2])
            .collect()
    }

    /// The hold's tangent over [`RotationFrame::dofs`] at stiffness `k`:
    /// `k W [r_i]x^T J^-1 [r_j]x` (row-major).
    pub fn tangent(&self, k: f64) -> Vec<f64> {
        let m = 3 * self.nodes.len();
        let mut out = vec![0.0; m * m];
        let skew: Vec<nalgebra::Matrix3<f64>> =
            self.arms.iter().map(|r| r.cross_matrix()).collect();
        for (i, si) in skew.iter().enumerate() {
            for (j, sj) in skew.iter().enumerate() {
                let b = si.transpose() * self.j_inv * sj * (k * self.weight);
                for p in 0..3 {
                    for q in 0..3 {
                        out[(3 * i + p) * m + 3 * j + q] = b[(p, q)];
                    }
                }
            }
        }
        out
    }
}

/// `sum (|r|^2 I - r r^T)` of the arms `r` \[mm^2\].
pub(crate) fn moment<'a>(
    arms: impl IntoIterator<Item = &'a nalgebra::Vector3<f64>>,
) -> nalgebra::Matrix3<f64> {
    arms.into_iter()
        .map(|r| nalgebra::Matrix3::identity() * r.norm_squared() - r * r.transpose())
        .sum()
}

/// The drag's share `beta` of the load (see [`Stabilisation`]).
pub(crate) const STABILISATION: f64 = 1e-3;

/// The rotation hold's `beta_rot`: a particle's rotation is charged as a
/// drag of this share of the load would charge it (see [`RotationFrame`]).
/// Measured on one whole sphere in a periodic cube at mesh level 1, to
/// rho = 0.7 against the sc octant cell's t(0.6) = 13.64 s and t(0.7) =
/// 82.0 s: without the hold (the drag's 1e-3 alone) 867 steps and 8206
/// Newton iterations to 0.8, t(0.6) = 13.03 s, t(0.7) = 78.5 s; 0.1 failed
/// at rho = 0.567; 1 took 108 steps and 660 Newton iterations, t(0.6) =
/// 13.61 s, t(0.7) = 81.7 s. The sphere's mesh turned off the axes took 142
/// steps and 1214 Newton iterations (before: 6159 iterations to 0.578).
pub(crate) const ROTATION_HOLD: f64 = 1.0;

/// The rotation hold's spring on its frame, `k_rot W`, is at most this
/// times `E h` (`E` Young's modulus, `h` the particle's mean element
/// size, 0.148 R at mesh level 1), about the stiffness of the elements
/// around a frame node. Like the drag, the hold's `k_rot` grows as 1/de
/// over short steps, and past that stiffness Newton stalled: two whole
/// spheres of the bcc lattice in a periodic cell (level 1) failed at rho
/// = 0.77 in steps cut to 1e-14 s, the residual at twice its tolerance
/// and largest at two frame nodes. Capped at 0.7 E h they reach 0.8 in
/// 126 steps and 839 Newton iterations (6 failed attempts), t(0.7),
/// t(0.75), t(0.8) = 0.276, 1.616, 10.56 s against the bcc octant cell's
/// 0.273, 1.620, 10.41 s. Capped at E R = 6.7 E h they were at rho = 0.793
/// after 160 steps and 1613 iterations (stopped there); at 0.01 E R
/// (0.067 E h) 127 steps and 762 iterations, t(0.7) = 0.284 s (3.9 % off).
/// The single sphere (sc) to 0.8: 153 steps and 1157 iterations capped,
/// 150 and 1142 uncapped, the same times within 0.1 %.
pub(crate) const ROTATION_HOLD_CAP: f64 = 0.7;

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
        self.stats.evaluation_seconds += t0.elapsed().as_secs_f64();
        self.stats.evaluations += 1;
        self.stats.tangent_evaluations += usize::from(tangent);
        Ok(self.with_contact(body, u))
    }

    /// `eval` with its particle contact evaluated afresh at the same
    /// displacement `u` (after the contact's pairing or multipliers
    /// changed): the elements' results are kept, tangent included, so that
    /// the result is the one [`Simulation::evaluate`] would give at `u`,
    /// without evaluating the elements again.
    ///
    /// Pairing the nodes afresh (after a line search, or at convergence)
    /// and updating the multipliers each evaluated the elements again: on
    /// 16 random spheres at level 1 (seed 0, the load's ramp to t = 1 s,
    /// tolerance 0.08, 608 Newton iterations) 378 of the 2013 evaluations
    /// of the elements; the run's iterates are the same without them.
    pub(crate) fn evaluate_contact_again(&mut self, eval: Evaluation, u: &[f64]) -> Evaluation {
        self.with_contact(eval.body, u)
    }

    /// The evaluation of the elements' results `body` at displacement `u`
    /// completed with the particle contact and, in a periodic cell, the
    /// drag and the rotation holds (with tangents if `body` has them).
    fn with_contact(&mut self, body: BodyEvaluation, u: &[f64]) -> Evaluation {
        let tangent = body.has_tangent();
        let t0 = Instant::now();
        let mut f_int = self.assembler.internal_force(&body);
        let t1 = Instant::now();
        self.stats.evaluation_seconds += (t1 - t0).as_secs_f64();
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
        let mut rotation_tangents = Vec::new();
        if let Some(st) = &self.stabilisation {
            for (d, f) in f_int.iter_mut().enumerate() {
                let drag = st.stiffness * st.volume[d] * (u[d] - st.reference[d]);
                *f += drag;
                drag_force += drag.abs();
            }
            if tangent {
                drag_diagonal = st.volume.iter().map(|v| st.stiffness * v).collect();
            }
            let k = st.rotation_factor * st.stiffness;
            if k > 0.0 {
                for frame in &st.frames {
                    let k = k.min(frame.max_stiffness);
                    let forces = frame.forces(|d| u[d] - st.reference[d], k);
                    for (&n, f) in frame.nodes.iter().zip(&forces) {
                        for i in 0..3 {
                            f_int[3 * n + i] += f[i];
                            drag_force += f[i].abs();
                        }
                    }
                    if tangent {
                        rotation_tangents.push((frame.dofs(), frame.tangent(k)));
                    }
                }
            }
        }
        Evaluation {
            body,
            contact,
            f_int,
            drag_diagonal,
            drag_force,
            rotation_tangents,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// A frame of five nodes (numbered 2, 5, 6, 9, 11 among 12) at
    /// uneven places, with weight 1.7.
    fn frame() -> (RotationFrame, Vec<Vector3<f64>>) {
        let points = [
            [0.3, -0.1, 0.2],
            [-0.4, 0.25, 0.1],
            [0.05, 0.5, -0.3],
            [0.2, -0.35, -0.45],
            [-0.1, 0.0, 0.6],
        ];
        let nodes = vec![2, 5, 6, 9, 11];
        let mut all = vec![Vector3::zeros(); 12];
        for (&n, p) in nodes.iter().zip(&points) {
            all[n] = Vector3::from(*p);
        }
        let mut f = RotationFrame {
            nodes,
            weight: 1.7,
            arms: Vec::new(),
            j_inv: nalgebra::Matrix3::zeros(),
            max_stiffness: f64::INFINITY,
        };
        f.place(|n| all[n]);
        (f, all)
    }

    /// A deterministic motion of every dof in [-1, 1].
    fn motion(seed: f64) -> Vec<f64> {
        (0..36).map(|d| (seed * (d as f64 + 1.3)).sin()).collect()
    }

    #[test]
    fn the_fitted_rotation_of_a_rigid_motion_is_its_rotation() {
        let (f, all) = frame();
        let w = Vector3::new(0.3, -0.7, 0.45);
        let t = Vector3::new(2.0, -1.0, 0.5);
        let v: Vec<f64> = all
            .iter()
            .flat_map(|x| (w.cross(x) + t).data.0[0])
            .collect();
        let fitted = f.rotation(|d| v[d]);
        assert!(
            (fitted - w).norm() < 1e-13 * w.norm(),
            "{fitted} against {w}"
        );
        // A translation alone turns nothing, so the hold does not act on it.
        let forces = f.forces(|d| t[d % 3], 2.0);
        assert!(forces.iter().all(|g| g.norm() < 1e-13), "{forces:?}");
    }

    #[test]
    fn the_fitted_rotation_leaves_a_remainder_no_rotation_can_reduce() {
        // Least squares: sum r_i x (v_i - w x r_i) = 0 for any motion v.
        let (f, _) = frame();
        for seed in [0.37, 1.91, 4.4] {
            let v = motion(seed);
            let w = f.rotation(|d| v[d]);
            let moment: Vector3<f64> = f
                .nodes
                .iter()
                .zip(&f.arms)
                .map(|(&n, r)| {
                    r.cross(&(Vector3::new(v[3 * n], v[3 * n + 1], v[3 * n + 2]) - w.cross(r)))
                })
                .sum();
            assert!(moment.norm() < 1e-14, "seed {seed}: {moment}");
        }
    }

    #[test]
    fn the_hold_is_balanced_and_its_tangent_is_the_derivative_of_its_force() {
        let (f, _) = frame();
        let k = 3.5;
        let tangent = f.tangent(k);
        let dofs = f.dofs();
        let m = dofs.len();
        for seed in [0.37, 1.91] {
            let v = motion(seed);
            let forces = f.forces(|d| v[d], k);
            // No net force (sum r_i = 0): the hold moves no particle.
            let net: Vector3<f64> = forces.iter().sum();
            assert!(net.norm() < 1e-13, "net force {net}");
            // The force is linear in v: the tangent times v is the force.
            for (p, &dp) in dofs.iter().enumerate() {
                let kv: f64 = (0..m).map(|q| tangent[p * m + q] * v[dofs[q]]).sum();
                let force = forces[p / 3][p % 3];
                assert!(
                    (kv - force).abs() < 1e-13 * (1.0 + force.abs()),
                    "dof {dp}: {kv} against {force}"
                );
            }
            // And the energy k W w^T J w / 2 is half the work v . f.
            let w = f.rotation(|d| v[d]);
            let energy = 0.5 * k * f.weight * (w.transpose() * moment(&f.arms) * w)[(0, 0)];
            let work: f64 = dofs
                .iter()
                .enumerate()
                .map(|(p, &d)| v[d] * forces[p / 3][p % 3])
                .sum();
            assert!(
                (energy - 0.5 * work).abs() < 1e-13 * energy,
                "{energy} against {work}"
            );
        }
        for p in 0..m {
            for q in 0..m {
                assert!((tangent[p * m + q] - tangent[q * m + p]).abs() < 1e-14);
            }
        }
    }

    /// After the multipliers change, the contact evaluated again on an
    /// evaluation's elements is the evaluation made afresh: the same
    /// internal force to the bit, the same contact terms, drag and rotation
    /// holds, with and without tangents (a periodic sphere during the
    /// ramp, whose evaluation holds all of them).
    #[test]
    fn the_contact_evaluated_again_equals_a_fresh_evaluation() {
        let mut sim = crate::test_support::periodic_sphere_level1(|s| {
            s.until_time = Some(0.1);
        });
        sim.run(|_| true).unwrap();
        let (u, dt) = (sim.state.u.clone(), 0.05);
        let x = sim.current_coordinates(&u);
        sim.contact.as_mut().unwrap().pair(&x);
        for tangent in [false, true] {
            let before = sim.evaluate(&u, dt, tangent).unwrap();
            // Multipliers of half the pressures: the contact forces change.
            let mut halved = before.contact.clone();
            for t in &mut halved.terms {
                t.pressure *= 0.5;
            }
            sim.contact.as_mut().unwrap().augment(&x, &halved);
            let evaluations = sim.stats.evaluations;
            let again = sim.evaluate_contact_again(before.clone(), &u);
            assert_eq!(sim.stats.evaluations, evaluations, "no element evaluation");
            let fresh = sim.evaluate(&u, dt, tangent).unwrap();
            assert_ne!(fresh.f_int, before.f_int, "the contact forces changed");
            assert_eq!(again.f_int, fresh.f_int);
            assert_eq!(again.contact, fresh.contact);
            assert_eq!(again.body.residuals(), fresh.body.residuals());
            assert_eq!(again.has_tangent(), tangent);
            assert_eq!(again.drag_diagonal, fresh.drag_diagonal);
            assert_eq!(again.drag_force, fresh.drag_force);
            assert_eq!(again.rotation_tangents, fresh.rotation_tangents);
            // The hold's tangents come with the tangents alone.
            assert_eq!(again.rotation_tangents.is_empty(), !tangent);
        }
    }
}
