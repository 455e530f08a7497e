//! The time-stepping driver: implicit backward-Euler steps solved by Newton
//! with line search, adaptive step size, and the densification curve.

use crate::constraints::Constraints;
use crate::error::SolverError;
use crate::linear::{FactorizationCounts, LinearSolver};
use crate::scene::Scene;
use crate::settings::Settings;
use serde::{Deserialize, Serialize};
use tidens_contact::{ContactEvaluation, ContactSettings, ContactSurface, ParticleContact};
use tidens_fem::{Body, BodyEvaluation, DOF_DROPPED, ElementFields, SparseSystem};
use tidens_material::Material;

/// One converged step of the densification curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Time [s].
    pub time: f64,
    /// Relative density: particle volume over current cell volume.
    pub rel_density: f64,
    /// Piston displacement U [mm] (negative in compression).
    pub piston_displacement: f64,
    /// Applied nominal stress sigma(t) [MPa].
    pub applied_stress: f64,
    /// Stress acting on the cell, f sigma(t) [MPa].
    pub cell_stress: f64,
    /// Step number (0 for the initial state).
    pub step: usize,
    /// Newton iterations of this step (cut-back attempts included).
    pub newton_iterations: usize,
    /// Newton iterations since the start.
    pub newton_total: usize,
    /// Time step [s].
    pub dt: f64,
    /// Largest equivalent plastic strain increment at a Gauss point.
    pub max_strain_increment: f64,
    /// Current particle volume [mm^3].
    pub particle_volume: f64,
    /// Estimated error of `time` from the time discretisation [s]: the sum of
    /// the per-step backward-Euler errors (positive when `time` is late).
    pub time_error: f64,
    /// Surface dofs in contact with a rigid plane.
    pub contacts: usize,
    /// Surface nodes pressed against another particle (each contact pass
    /// counts its slave nodes that carry pressure; tied: nodes tied).
    pub particle_contacts: usize,
    /// Largest penetration of a surface node into a rigid plane or into
    /// another particle [mm].
    pub max_penetration: f64,
}

/// Why a run stopped, or that it goes on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Status {
    Running,
    ReachedDensity,
    ReachedTime,
}

/// Node and element fields of the last converged state, for output.
#[derive(Clone, Debug, PartialEq)]
pub struct Fields {
    /// Current node coordinates [mm].
    pub points: Vec<[f64; 3]>,
    /// Node displacements [mm].
    pub displacement: Vec<[f64; 3]>,
    /// Force exerted by the rigid planes on each node [N].
    pub contact_force: Vec<[f64; 3]>,
    /// Particle-particle contact pressure at each node [MPa] (0 where none).
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
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunStats {
    pub steps: usize,
    pub newton_iterations: usize,
    pub rejected_steps: usize,
    pub failed_attempts: usize,
    pub factorizations: FactorizationCounts,
    /// Wall time in element evaluations (residual and tangent) [s].
    pub evaluation_seconds: f64,
    /// Wall time scattering element matrices into the sparse system [s].
    pub assembly_seconds: f64,
    /// Wall time in sparse factorisations and solves [s].
    pub linear_seconds: f64,
    /// Times the sparsity pattern grew for new particle contacts.
    pub pattern_rebuilds: usize,
}

/// Steps over which the trend of the densification rate is measured.
const RATE_WINDOW: usize = 4;

/// A converged Newton solve of one step.
struct Solved {
    u: Vec<f64>,
    piston: f64,
    eval: Evaluation,
    iterations: usize,
}

/// A trial point of the line search.
struct LineSearchPoint {
    norm_sq: f64,
    norm: f64,
    u: Vec<f64>,
    piston: f64,
    eval: Evaluation,
    step: f64,
}

/// A failed Newton solve.
struct Failed {
    reason: String,
    iterations: usize,
}

/// A hot-pressing simulation of one scene.
pub struct Simulation {
    lengths: [f64; 3],
    body: Body,
    constraints: Constraints,
    system: SparseSystem,
    linear: LinearSolver,
    /// The equation map the current factor was computed with.
    factor_map: Option<Vec<usize>>,
    settings: Settings,
    dt_min: f64,
    full_force: f64,
    // State at the last converged step.
    time: f64,
    u: Vec<f64>,
    piston: f64,
    previous: Option<(Vec<f64>, f64, f64)>,
    last_rate: Option<f64>,
    /// (step, |change of ln rate| weighted) of the last accepted steps.
    rate_history: std::collections::VecDeque<(f64, f64)>,
    dt_next: f64,
    time_error: f64,
    f_int: Vec<f64>,
    fields: ElementFields,
    curve: Vec<CurvePoint>,
    stats: RunStats,
    status: Status,
    /// Contact between particles (scenes with more than one particle).
    contact: Option<ParticleContact>,
    /// Largest particle-contact penetration accepted in a step [mm].
    penetration_tol: f64,
    /// Element cliques and the contact cliques added to the pattern so far.
    element_cliques: Vec<Vec<usize>>,
    contact_cliques: std::collections::BTreeSet<Vec<usize>>,
    /// The contact links (slave surface, node, master surface, triangle) the
    /// current factor was computed with.
    factor_links: Vec<[usize; 4]>,
    /// Contact terms of the last converged step.
    contact_eval: ContactEvaluation,
    /// Time spent in evaluations not yet booked into `stats` [s].
    eval_seconds: std::cell::Cell<f64>,
}

/// Element and contact contributions at one configuration.
struct Evaluation {
    body: BodyEvaluation,
    contact: ContactEvaluation,
    /// Internal force of the body plus the contact forces [N].
    f_int: Vec<f64>,
    has_tangent: bool,
}

type ContactState = (
    (Vec<Option<bool>>, Vec<Option<f64>>),
    Option<tidens_contact::StateSnapshot>,
);

/// The pressed contact links of `c` (slave surface, node, master surface,
/// facet): the tangent of a factor reused across iterations must have them.
fn links(c: &ContactEvaluation) -> Vec<[usize; 4]> {
    c.terms
        .iter()
        .filter(|t| t.pressure > 0.0)
        .map(|t| [t.slave.0, t.slave.1, t.master.0, t.master.1])
        .collect()
}

/// Contact between the particles of `scene`, when it has more than one: the
/// penalty is `penalty_factor * E / h` with `h` the mean edge of the
/// surface quads, and the search reaches one such edge from a surface.
fn particle_contact(
    scene: &Scene,
    material: &Material,
    settings: &Settings,
) -> Result<Option<ParticleContact>, SolverError> {
    if scene.particles.len() < 2 {
        return Ok(None);
    }
    let surfaces = scene
        .particles
        .iter()
        .map(|p| ContactSurface::from_quads(&p.surface, &scene.mesh.nodes))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| SolverError::Unsupported(e.to_string()))?;
    let (count, area) = surfaces
        .iter()
        .flat_map(|s| s.areas.iter())
        .fold((0usize, 0.0), |(n, a), x| (n + 1, a + x));
    let h = (area / count.max(1) as f64).sqrt();
    let c = &settings.contact;
    let contact = ParticleContact::new(
        surfaces,
        ContactSettings {
            mode: c.mode,
            penalty: c.penalty_factor * material.young / h,
            search_distance: h,
        },
    )
    .map_err(|e| SolverError::Unsupported(e.to_string()))?;
    Ok(Some(contact))
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

impl Simulation {
    /// Sets up a simulation of `scene` made of `material`.
    pub fn new(scene: &Scene, material: Material, settings: Settings) -> Result<Self, SolverError> {
        settings.validate()?;
        let material = Material::new(
            material.young,
            material.poisson,
            material.creep_c,
            material.creep_n,
        )?;
        let body = match &scene.tet_mesh {
            Some(t) => Body::new_tet10(t.nodes.clone(), t.elements.clone(), material)?,
            None => Body::new(
                scene.mesh.nodes.clone(),
                scene.mesh.elements.clone(),
                material,
            )?,
        };
        let constraints = Constraints::new(
            scene.nodes(),
            scene.boundary_faces(),
            scene.lengths,
            scene.lateral_walls,
            settings.contact.tied_planes,
        )?;
        let element_cliques = constraints.element_cliques(&body);
        let n_eq = constraints.dof_count() + 1;
        let system = SparseSystem::from_cliques(n_eq, element_cliques.iter().map(|c| c.as_slice()));
        let contact = particle_contact(scene, &material, &settings)?;
        let [lx, ly, lz] = scene.lengths;
        let full_force = settings.load.knockdown * settings.load.stress * lx * ly;
        let rho = body.reference_volume() / (lx * ly * lz);
        if let Some(target) = settings.until_density
            && target <= rho
        {
            return Err(SolverError::parameter(
                "until_density",
                target,
                format!("in ({rho:.5}, 1): above the initial density of the mesh"),
            ));
        }
        let creep_time = 1.0 / material.creep_rate(settings.load.knockdown * settings.load.stress);
        let dt0 = settings.dt_initial.unwrap_or_else(|| {
            let ramp = settings.load.ramp_time;
            let guess = 1e-4 * creep_time;
            if ramp > 0.0 {
                guess.min(ramp / 50.0)
            } else {
                guess
            }
        });
        let dt_min = settings.dt_min.unwrap_or(1e-12 * dt0);
        let penetration_tol = 0.5 * settings.contact.penetration_tolerance * scene.radius;
        let n_dof = constraints.dof_count();
        let eval = body.evaluate(&vec![0.0; n_dof], 0.0, false)?;
        let mut sim = Self {
            lengths: scene.lengths,
            body,
            constraints,
            system,
            linear: LinearSolver::default(),
            factor_map: None,
            settings,
            dt_min,
            full_force,
            time: 0.0,
            u: vec![0.0; n_dof],
            piston: 0.0,
            previous: None,
            last_rate: None,
            rate_history: std::collections::VecDeque::new(),
            dt_next: dt0,
            time_error: 0.0,
            f_int: vec![0.0; n_dof],
            fields: eval.fields(),
            curve: Vec::new(),
            stats: RunStats::default(),
            status: Status::Running,
            contact,
            penetration_tol,
            element_cliques,
            contact_cliques: std::collections::BTreeSet::new(),
            factor_links: Vec::new(),
            contact_eval: ContactEvaluation::default(),
            eval_seconds: std::cell::Cell::new(0.0),
        };
        let point = sim.curve_point(eval.volume(), 0, 0, 0.0, 0.0);
        sim.curve.push(point);
        Ok(sim)
    }

    /// The densification curve so far (the initial state first).
    pub fn curve(&self) -> &[CurvePoint] {
        &self.curve
    }

    pub fn status(&self) -> Status {
        self.status
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    pub fn stats(&self) -> RunStats {
        let mut s = self.stats;
        s.factorizations = self.linear.counts;
        s
    }

    /// The particle-contact terms of the last converged step (one per slave
    /// node in contact or about to touch).
    pub fn contact_terms(&self) -> &[tidens_contact::ContactTerm] {
        &self.contact_eval.terms
    }

    /// Per particle: the total force the other particles exert on it through
    /// contact, and the total force the rigid planes exert on it, at the last
    /// converged step [N]. For each particle the two balance (to the Newton
    /// tolerance); the plane forces include the piston's.
    pub fn particle_forces(&self, scene: &Scene) -> Vec<([f64; 3], [f64; 3])> {
        let owner = |node: usize| {
            scene
                .particles
                .iter()
                .position(|p| node >= p.nodes.0 && node < p.nodes.0 + p.nodes.1)
        };
        let mut out = vec![([0.0; 3], [0.0; 3]); scene.particles.len()];
        for t in &self.contact_eval.terms {
            for (d, f) in t.dofs.iter().zip(&t.force) {
                if let Some(p) = owner(d / 3) {
                    // The force on the body is minus the internal force term.
                    out[p].0[d % 3] -= f;
                }
            }
        }
        for (d, f) in self.f_int.iter().enumerate() {
            if self.constraints.is_held(d)
                && let Some(p) = owner(d / 3)
            {
                // A held dof's internal force is what the plane exerts on it.
                out[p].1[d % 3] += f;
            }
        }
        out
    }

    /// Degrees of freedom: free displacement components plus the piston, at
    /// the current contact state.
    pub fn degrees_of_freedom(&self) -> usize {
        self.constraints
            .equation_map()
            .iter()
            .enumerate()
            .filter(|&(d, &m)| m == d)
            .count()
            + 1
    }

    /// Box edge lengths [mm].
    pub fn lengths(&self) -> [f64; 3] {
        self.lengths
    }

    pub fn body(&self) -> &Body {
        &self.body
    }

    /// Current relative density.
    pub fn rel_density(&self) -> f64 {
        self.curve.last().map_or(0.0, |p| p.rel_density)
    }

    fn density_of(&self, volume: f64, piston: f64) -> f64 {
        let [lx, ly, lz] = self.lengths;
        volume / (lx * ly * (lz + piston))
    }

    fn curve_point(
        &self,
        volume: f64,
        step: usize,
        iterations: usize,
        dt: f64,
        max_dp: f64,
    ) -> CurvePoint {
        let load = &self.settings.load;
        CurvePoint {
            time: self.time,
            rel_density: self.density_of(volume, self.piston),
            piston_displacement: self.piston,
            applied_stress: load.applied_stress(self.time),
            cell_stress: load.cell_stress(self.time),
            step,
            newton_iterations: iterations,
            newton_total: self.stats.newton_iterations,
            dt,
            max_strain_increment: max_dp,
            particle_volume: volume,
            time_error: self.time_error,
            contacts: self.constraints.contact_counts().iter().sum(),
            particle_contacts: self
                .contact_eval
                .terms
                .iter()
                .filter(|t| t.pressure > 0.0)
                .count(),
            max_penetration: self
                .constraints
                .max_penetration(&self.u, self.piston)
                .max(self.contact_eval.max_penetration()),
        }
    }

    /// Fields of the last converged state.
    pub fn fields(&self) -> Fields {
        let nodes = self.body.nodes();
        let mut points = Vec::with_capacity(nodes.len());
        let mut displacement = Vec::with_capacity(nodes.len());
        let mut contact_force = Vec::with_capacity(nodes.len());
        for (a, p) in nodes.iter().enumerate() {
            let u = [self.u[3 * a], self.u[3 * a + 1], self.u[3 * a + 2]];
            points.push([p[0] + u[0], p[1] + u[1], p[2] + u[2]]);
            displacement.push(u);
            contact_force.push([0, 1, 2].map(|i| {
                let d = 3 * a + i;
                if self.constraints.is_held(d) {
                    self.f_int[d]
                } else {
                    0.0
                }
            }));
        }
        let mut contact_pressure = vec![0.0; nodes.len()];
        if let Some(c) = &self.contact {
            for t in &self.contact_eval.terms {
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
            element: self.fields.clone(),
        }
    }

    /// The stop condition, if met by the last converged state.
    fn check_stop(&mut self) {
        let rho = self.rel_density();
        if self.settings.until_density.is_some_and(|r| rho >= r) {
            self.status = Status::ReachedDensity;
        } else if self
            .settings
            .until_time
            .is_some_and(|t| self.time >= t * (1.0 - 1e-12))
        {
            self.status = Status::ReachedTime;
        }
    }

    /// The next time a step must end on: the end of the ramp, a requested
    /// time, or the stop time.
    fn next_time_target(&self) -> Option<f64> {
        let ramp = self.settings.load.ramp_time;
        let eps = 1e-12 * self.time.max(1e-300);
        std::iter::once(ramp)
            .chain(self.settings.time_targets.iter().copied())
            .chain(self.settings.until_time)
            .filter(|&t| t > self.time + eps)
            .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.min(t))))
    }

    /// The step to try next: the controller's proposal, shortened to land on
    /// time targets and not to overshoot the target density by much.
    fn propose_dt(&self) -> f64 {
        let mut dt = self.dt_next.min(self.settings.dt_max);
        if let (Some(target), Some(rate)) = (self.settings.until_density, self.density_rate()) {
            let rho = self.rel_density();
            if rate > 0.0 && rho + rate * dt > target {
                dt = dt.min(1.02 * (target - rho) / rate).max(self.dt_min);
            }
        }
        if let Some(t) = self.next_time_target() {
            let left = t - self.time;
            if dt >= left * (1.0 - 1e-9) {
                dt = left;
            } else if dt > 0.6 * left {
                dt = 0.5 * left;
            }
        }
        dt
    }

    /// Densification rate over the last step [1/s].
    fn density_rate(&self) -> Option<f64> {
        let n = self.curve.len();
        if n < 2 {
            return None;
        }
        let (a, b) = (&self.curve[n - 2], &self.curve[n - 1]);
        Some((b.rel_density - a.rel_density) / (b.time - a.time))
    }

    /// Runs until the stop condition, calling `on_step` after every converged
    /// step; `on_step` returning false stops the run early (status stays
    /// `Running`).
    pub fn run(
        &mut self,
        mut on_step: impl FnMut(&CurvePoint) -> bool,
    ) -> Result<Status, SolverError> {
        while self.status == Status::Running {
            let p = self.advance()?.clone();
            if !on_step(&p) {
                break;
            }
        }
        Ok(self.status)
    }

    /// Advances by one converged step (cutting the step back as needed) and
    /// returns its curve point. On failure the state stays at the last
    /// converged step, so the curve so far is kept.
    pub fn advance(&mut self) -> Result<&CurvePoint, SolverError> {
        if self.status != Status::Running {
            return self
                .curve
                .last()
                .ok_or_else(|| SolverError::Linear("empty curve".into()));
        }
        if self.stats.steps >= self.settings.max_steps {
            return Err(SolverError::StepLimit {
                max_steps: self.settings.max_steps,
                time: self.time,
                density: self.rel_density(),
            });
        }
        let mut dt = self.propose_dt();
        let mut iterations = 0;
        loop {
            let saved = self.contact_state();
            match self.solve_step(dt) {
                Ok(solved) => {
                    iterations += solved.iterations;
                    match self.accept_or_reject(solved, dt, iterations) {
                        Ok(()) => break,
                        Err(shorter) => {
                            self.stats.rejected_steps += 1;
                            self.restore_contact_state(saved);
                            dt = shorter;
                        }
                    }
                }
                Err(f) => {
                    iterations += f.iterations;
                    self.stats.failed_attempts += 1;
                    self.restore_contact_state(saved);
                    dt *= 0.25;
                    if dt < self.dt_min {
                        self.stats.newton_iterations += iterations;
                        return Err(SolverError::NoConvergence {
                            time: self.time,
                            step: self.stats.steps + 1,
                            dt,
                            reason: f.reason,
                        });
                    }
                }
            }
        }
        self.check_stop();
        self.curve
            .last()
            .ok_or_else(|| SolverError::Linear("empty curve".into()))
    }

    /// Step control on a converged step: accepts it (and proposes the next
    /// step) or rejects it, returning the shorter step to retry.
    fn accept_or_reject(&mut self, s: Solved, dt: f64, iterations: usize) -> Result<(), f64> {
        let volume = s.eval.body.volume();
        let max_dp = s.eval.body.max_dp();
        let lz = self.lengths[2];
        // Piston log-strain rate: the densification rate whatever the scene.
        let rate = ((lz + self.piston) / (lz + s.piston)).ln() / dt;
        let n = self.body.material().creep_n;
        let t1 = self.time + dt;
        let weight = self.settings.load.factor(t1).powf(n);
        let tol = self.settings.tolerance;
        // Per-step time error of backward Euler: it evaluates the rate at the
        // end of the step, so the time it takes is off by half the step times
        // the change of the log of the rate over it, weighted by
        // (sigma/sigma_max)^n (during the ramp a time shift counts at the
        // reduced load). A step of less than 1e-6 strain says nothing
        // reliable of the rate (the Newton tolerance leaves noise of 1e-10 or
        // so, and contact events make it jumpy): it lets the step grow, and
        // what it could get wrong is bounded by its own tiny strain.
        let moved = (rate * dt).abs() > 1e-6;
        let dln = match self.last_rate {
            Some(r0) if moved && r0 > 0.0 && rate > 0.0 => (r0 / rate).ln() * weight,
            _ => 0.0,
        };
        let signed_error = 0.5 * dt * dln;
        // Only the strain-increment limit rejects a step. The rate also jumps
        // when a node touches a plane: such a jump is in the past once seen, so
        // the step is steered by the trend of the rate over the last few steps
        // rather than by the last change alone.
        let psi_dp = max_dp / self.settings.max_strain_increment;
        if psi_dp > 2.0 && dt > 4.0 * self.dt_min {
            return Err(dt * (0.8 / psi_dp).max(0.1));
        }
        // Accept.
        self.stats.steps += 1;
        self.stats.newton_iterations += iterations;
        self.body.commit(&s.eval.body);
        self.previous = Some((std::mem::take(&mut self.u), self.piston, dt));
        self.u = s.u;
        self.piston = s.piston;
        self.time = t1;
        self.time_error += signed_error;
        self.f_int = s.eval.f_int;
        self.fields = s.eval.body.fields();
        if let Some(c) = self.contact.as_mut() {
            // Uzawa update once per step: the next step starts from this
            // step's pressures, which keeps penetrations small and the
            // contact law smooth in time.
            let x: Vec<f64> = self
                .body
                .nodes()
                .iter()
                .flatten()
                .zip(&self.u)
                .map(|(p, du)| p + du)
                .collect();
            c.augment(&x, &s.eval.contact);
            c.tie_closed(&s.eval.contact);
        }
        self.contact_eval = s.eval.contact;
        let had_rate = self.last_rate.is_some();
        if moved && rate > 0.0 {
            self.last_rate = Some(rate);
        }
        if moved && had_rate {
            if self.rate_history.len() == RATE_WINDOW {
                self.rate_history.pop_front();
            }
            self.rate_history.push_back((dt, dln.abs()));
        }
        // Newton effort limits the growth only when it is large (modified
        // Newton takes a few more, cheaper, iterations than full Newton).
        let newton_factor: f64 = match iterations {
            0..=8 => 2.0,
            9..=15 => 1.2,
            _ => 0.7,
        };
        // Step for which half the windowed rate-change speed times the step
        // equals the tolerance: the error per unit step is `tol`.
        let (span, change) = self
            .rate_history
            .iter()
            .fold((0.0, 0.0), |(a, b), (d, c)| (a + d, b + c));
        // A step too small to show the rate lets the step grow.
        let accuracy_dt = if moved && change > 0.0 {
            0.9 * 2.0 * tol * span / change
        } else {
            f64::INFINITY
        };
        let dp_dt = if psi_dp > 0.0 {
            0.9 * dt / psi_dp
        } else {
            f64::INFINITY
        };
        self.dt_next = (newton_factor * dt)
            .min(accuracy_dt)
            .min(dp_dt)
            .clamp(0.25 * dt, 2.0 * dt);
        let point = self.curve_point(volume, self.stats.steps, iterations, dt, max_dp);
        self.curve.push(point);
        Ok(())
    }

    /// Scatters the element and contact tangents of `eval` through the
    /// equation map into the sparse system; eliminated dofs keep a unit
    /// diagonal. False when a contact term fell outside the pattern.
    fn assemble(&mut self, eval: &Evaluation, map: &[usize]) -> bool {
        self.system.clear();
        for (e, out) in eval.body.elements.iter().enumerate() {
            self.system
                .add_block(&self.body.element_dofs(e), &out.tangent, map);
        }
        let mut missed = 0;
        for t in &eval.contact.terms {
            missed += self.system.add_block(&t.dofs, &t.tangent, map);
        }
        for (d, &m) in map.iter().enumerate() {
            if m != d {
                self.system.add(d, d, 1.0);
            }
        }
        missed == 0
    }

    /// `K v` over the body dofs for a vector `v` given by its non-zero
    /// entries, from the element and contact tangents of `eval`.
    fn tangent_times(&self, eval: &Evaluation, entries: &[(usize, f64)]) -> Vec<f64> {
        let mut v = vec![0.0; self.constraints.dof_count()];
        for &(d, x) in entries {
            v[d] = x;
        }
        let mut out = vec![0.0; v.len()];
        let blocks = eval
            .body
            .elements
            .iter()
            .enumerate()
            .map(|(e, el)| (self.body.element_dofs(e).to_vec(), &el.tangent))
            .chain(
                eval.contact
                    .terms
                    .iter()
                    .map(|t| (t.dofs.to_vec(), &t.tangent)),
            );
        for (dofs, tangent) in blocks {
            if dofs.iter().all(|&d| v[d] == 0.0) {
                continue;
            }
            let m = dofs.len();
            for (p, &dp) in dofs.iter().enumerate() {
                out[dp] += (0..m).map(|q| tangent[p * m + q] * v[dofs[q]]).sum::<f64>();
            }
        }
        out
    }

    /// The consistent tangent at the current state for a step `dt` [s]: the
    /// symmetric system Newton factorises (for diagnostics and benchmarks).
    pub fn assemble_tangent(&mut self, dt: f64) -> Result<&SparseSystem, SolverError> {
        let u = self.u.clone();
        let eval = self
            .evaluate_state(&u, dt, true)
            .map_err(SolverError::Linear)?;
        let map = self.constraints.equation_map();
        if !self.assemble(&eval, &map) {
            self.grow_pattern(&eval.contact);
            self.assemble(&eval, &map);
        }
        Ok(&self.system)
    }

    /// Global residual: internal forces gathered into equations, plus the
    /// piston's load term `F` (the load potential is `F U`).
    fn residual(&self, f_int: &[f64], map: &[usize], force: f64) -> Vec<f64> {
        let n = self.constraints.dof_count();
        let mut r = vec![0.0; n + 1];
        for (d, &m) in map.iter().enumerate() {
            if m != DOF_DROPPED {
                r[m] += f_int[d];
            }
        }
        r[n] += force;
        r
    }

    /// Newton with line search for the step to `time + dt`.
    ///
    /// The factor of the tangent is kept across iterations and steps while
    /// the equation map (the contact state) is unchanged and Newton contracts
    /// the residual fast enough with it (modified Newton); otherwise the
    /// tangent is assembled and factorised afresh. The tangent is computed
    /// only in evaluations that may need it.
    fn solve_step(&mut self, dt: f64) -> Result<Solved, Failed> {
        let t1 = self.time + dt;
        let force = self.full_force * self.settings.load.factor(t1);
        let tol = self.settings.newton.residual_tolerance * force.max(1e-3 * self.full_force);
        let gap_tol = 1e-8 * self.lengths.iter().cloned().fold(0.0, f64::max);
        let n = self.constraints.dof_count();
        self.constraints.reset_flips();
        let fail = |reason: String, iterations: usize| Failed { reason, iterations };
        // Start from the displacement extrapolated from the last two steps:
        // on creep flow it is far closer to the solution than the last state
        // (even where stiff elasticity makes its residual larger).
        let mut u = self.u.clone();
        let mut piston = self.piston;
        if self.settings.newton.extrapolate
            && let Some((u_prev, p_prev, dt_prev)) = &self.previous
        {
            let ratio = dt / dt_prev;
            for (x, xp) in u.iter_mut().zip(u_prev) {
                *x += ratio * (*x - xp);
            }
            piston += ratio * (piston - p_prev);
        }
        self.constraints.enforce(&mut u, piston);
        // Particle contact keeps each node's master facet for the whole step.
        let x = self.current_coordinates(&u);
        if let Some(c) = self.contact.as_mut() {
            c.pair(&x);
        }
        let mut eval = self.evaluate_state(&u, dt, false).map_err(|e| fail(e, 0))?;
        let mut refactor = !self.linear.has_factor();
        let mut iterations = 0;
        let mut active_set_updates = 0;
        let mut augmentations = 0;
        let result = loop {
            // Contact: release tensile contacts, catch penetrating nodes.
            if active_set_updates < 50
                && self
                    .constraints
                    .update(&u, piston, &eval.f_int, tol, gap_tol)
                    > 0
            {
                active_set_updates += 1;
            }
            let map = self.constraints.equation_map();
            // Nodes that have just come into contact are still off their
            // plane: the next solve moves them onto it.
            let offsets = self.constraints.offsets(&u, piston);
            let r = self.residual(&eval.f_int, &map, force);
            let r_norm = max_abs(&r);
            if std::env::var_os("TIDENS_DEBUG").is_some() {
                eprintln!(
                    "    it {iterations} |R| {r_norm:.3e} tol {tol:.3e} refactor {refactor} planes {:?} particle contacts {} penetration {:.2e}",
                    self.constraints.contact_counts(),
                    eval.contact.terms.len(),
                    eval.contact.max_penetration()
                );
            }
            if !r_norm.is_finite() {
                break Err(fail("non-finite residual".into(), iterations));
            }
            if offsets.is_empty() && r_norm <= tol {
                let penetration = self.constraints.max_penetration(&u, piston);
                if penetration > gap_tol {
                    break Err(fail(
                        format!("converged with a node {penetration:.3e} mm inside a rigid plane"),
                        iterations,
                    ));
                }
                // Nodes that came near another particle during the step are
                // paired now; if any of them touches, Newton goes on.
                let x = self.current_coordinates(&u);
                let appeared = self.contact.as_mut().map_or(0, |c| c.pair_unpaired(&x));
                if appeared > 0 {
                    eval = self
                        .evaluate_state(&u, dt, false)
                        .map_err(|e| fail(e, iterations))?;
                    continue;
                }
                // The multipliers take each converged step's pressures (see
                // `accept_or_reject`), so the penetration of a step is only
                // the pressure change over it divided by the penalty; the
                // augmentation loop here is for steps where that is too much.
                let contact_penetration = eval.contact.max_violation();
                if contact_penetration <= self.penetration_tol {
                    break Ok(Solved {
                        u,
                        piston,
                        eval,
                        iterations,
                    });
                }
                // Augmented Lagrangian: the multipliers take the pressures
                // and the solve goes on until the penetration is small.
                if augmentations >= 30 {
                    break Err(fail(
                        format!(
                            "particle contact penetration {contact_penetration:.3e} mm after 30 augmentations"
                        ),
                        iterations,
                    ));
                }
                augmentations += 1;
                let x = self.current_coordinates(&u);
                if let Some(c) = self.contact.as_mut() {
                    c.augment(&x, &eval.contact);
                }
                eval = self
                    .evaluate_state(&u, dt, false)
                    .map_err(|e| fail(e, iterations))?;
                continue;
            }
            if iterations >= self.settings.newton.max_iterations {
                break Err(fail(
                    format!(
                        "{iterations} Newton iterations, residual {r_norm:.3e} N > {tol:.3e} N"
                    ),
                    iterations,
                ));
            }
            iterations += 1;
            let contact_links = links(&eval.contact);
            if self.factor_map.as_deref() != Some(map.as_slice())
                || self.factor_links != contact_links
                || !offsets.is_empty()
            {
                refactor = true;
            }
            if refactor {
                if !eval.has_tangent {
                    eval = self
                        .evaluate_state(&u, dt, true)
                        .map_err(|e| fail(e, iterations))?;
                }
                let t0 = std::time::Instant::now();
                if !self.assemble(&eval, &map) {
                    self.grow_pattern(&eval.contact);
                    self.assemble(&eval, &map);
                }
                let t1 = std::time::Instant::now();
                self.stats.assembly_seconds += (t1 - t0).as_secs_f64();
                let factorized = self.linear.factorize(&self.system);
                self.stats.linear_seconds += t1.elapsed().as_secs_f64();
                if let Err(e) = factorized {
                    self.factor_map = None;
                    break Err(fail(e.to_string(), iterations));
                }
                self.factor_map = Some(map.clone());
                self.factor_links = links(&eval.contact);
            }
            let mut du: Vec<f64> = r.iter().map(|x| -x).collect();
            if !offsets.is_empty() {
                // The linearised effect of the offsets: minus the tangent
                // times them, gathered like the residual.
                let lift = self.tangent_times(&eval, &offsets);
                for (d, &m) in map.iter().enumerate() {
                    if m != DOF_DROPPED {
                        du[m] -= lift[d];
                    }
                }
            }
            let t1 = std::time::Instant::now();
            let solved = self.linear.solve(&mut du);
            self.stats.linear_seconds += t1.elapsed().as_secs_f64();
            if let Err(e) = solved {
                break Err(fail(e.to_string(), iterations));
            }
            // Line search on the residual norm (backtracking with a quadratic
            // model of |R(s)|^2, at most three cuts).
            let r0_sq: f64 = r.iter().map(|x| x * x).sum();
            let mut s = 1.0;
            let mut best: Option<LineSearchPoint> = None;
            for _ in 0..4 {
                let mut ut = u.clone();
                for d in 0..n {
                    if map[d] == d {
                        ut[d] += s * du[d];
                    }
                }
                let pt = piston + s * du[n];
                self.constraints.enforce(&mut ut, pt);
                match self.evaluate_state(&ut, dt, false) {
                    Ok(ev) => {
                        let rt = self.residual(&ev.f_int, &map, force);
                        let rt_sq: f64 = rt.iter().map(|x| x * x).sum();
                        let norm = max_abs(&rt);
                        let better = best.as_ref().is_none_or(|b| rt_sq < b.norm_sq);
                        let done = rt_sq <= (1.0 - 1e-4 * s) * r0_sq || norm <= tol;
                        if better {
                            best = Some(LineSearchPoint {
                                norm_sq: rt_sq,
                                norm,
                                u: ut,
                                piston: pt,
                                eval: ev,
                                step: s,
                            });
                        }
                        if done {
                            break;
                        }
                        s *= (r0_sq / (rt_sq + r0_sq)).clamp(0.1, 0.5);
                    }
                    Err(_) => s *= 0.25,
                }
            }
            let Some(b) = best else {
                break Err(fail(
                    "every line-search point inverts an element".into(),
                    iterations,
                ));
            };
            if std::env::var_os("TIDENS_DEBUG").is_some() {
                eprintln!("      line search: step {} |R| {:.3e}", b.step, b.norm);
            }
            // Modified Newton pays only while it contracts fast: refactorise
            // after a slow or damped iteration.
            refactor = b.norm > 0.2 * r_norm || b.step < 1.0;
            u = b.u;
            piston = b.piston;
            eval = b.eval;
        };
        self.stats.evaluation_seconds += self.eval_seconds.replace(0.0);
        result
    }

    /// The contact state of the rigid planes and of the particles, to redo a
    /// step from.
    fn contact_state(&self) -> ContactState {
        (
            self.constraints.contact_state(),
            self.contact.as_ref().map(|c| c.state_snapshot()),
        )
    }

    fn restore_contact_state(&mut self, (planes, particles): ContactState) {
        self.constraints.set_contact_state(planes);
        if let (Some(c), Some(saved)) = (self.contact.as_mut(), particles) {
            c.restore(&saved);
        }
    }

    /// Current node coordinates (flat, `3 * node + i`) for displacement `u`.
    fn current_coordinates(&self, u: &[f64]) -> Vec<f64> {
        self.body
            .nodes()
            .iter()
            .flatten()
            .zip(u)
            .map(|(x, du)| x + du)
            .collect()
    }

    /// Elements (in parallel) and particle contact at displacement `u`.
    fn evaluate_state(&self, u: &[f64], dt: f64, tangent: bool) -> Result<Evaluation, String> {
        let t0 = std::time::Instant::now();
        let body = self
            .body
            .evaluate(u, dt, tangent)
            .map_err(|e| e.to_string())?;
        let mut f_int = body.internal_force(&self.body);
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
        self.eval_seconds
            .set(self.eval_seconds.get() + t0.elapsed().as_secs_f64());
        Ok(Evaluation {
            body,
            contact,
            f_int,
            has_tangent: tangent,
        })
    }

    /// Adds the cliques of the contact terms of `contact` to the sparsity
    /// pattern (which only grows) and starts a new symbolic factorisation.
    fn grow_pattern(&mut self, contact: &ContactEvaluation) {
        let Some(c) = &self.contact else { return };
        for t in &contact.terms {
            // The slave with every facet around its master facet, so that
            // sliding onto a neighbouring facet needs no new pattern.
            let master = &c.surfaces()[t.master.0];
            let mut dofs: Vec<usize> = t.dofs[..3].to_vec();
            for &f in master.ring(t.master.1) {
                dofs.extend(
                    master.quads[f]
                        .iter()
                        .flat_map(|&n| [3 * n, 3 * n + 1, 3 * n + 2]),
                );
            }
            dofs.sort_unstable();
            dofs.dedup();
            let mut clique = self.constraints.clique(&dofs);
            clique.sort_unstable();
            self.contact_cliques.insert(clique);
        }
        let n_eq = self.constraints.dof_count() + 1;
        let cliques = self
            .element_cliques
            .iter()
            .chain(self.contact_cliques.iter());
        self.system = SparseSystem::from_cliques(n_eq, cliques.map(|c| c.as_slice()));
        self.linear.reset_pattern();
        self.factor_map = None;
        self.stats.pattern_rebuilds += 1;
    }
}
