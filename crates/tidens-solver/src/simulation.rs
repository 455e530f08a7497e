//! The time-stepping driver: one hot-pressing run of a scene, advanced by
//! implicit backward-Euler steps ([`crate::newton`]) whose size the step
//! controller sets ([`crate::step_control`]), recording the densification
//! curve ([`crate::output`]).

use crate::assembler::Assembler;
use crate::constraints::{Constraints, PlaneContactState};
use crate::error::{LinearError, SolverError, StepFailure};
use crate::evaluation::Evaluation;
use crate::linear::LinearSolver;
use crate::newton::{FactorKey, Solved};
use crate::output::{CurvePoint, RunStats, Status};
use crate::scene::Scene;
use crate::settings::{ContactFormulation, HexFacets, Settings};
use crate::step_control::StepController;
use tidens_contact::{ContactEvaluation, ContactSettings, ContactSurface, ParticleContact};
use tidens_fem::ElementKind;
use tidens_fem::{Body, ElementFields, SparseSystem};
use tidens_material::Material;

/// The last accepted step, for the predictor of the next one.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub(crate) struct PreviousStep {
    /// Displacement at its start \[mm\].
    pub u: Vec<f64>,
    /// Piston displacement at its start \[mm\].
    pub piston: f64,
    /// Its length \[s\].
    pub dt: f64,
}

/// The state at the last converged step: what a rejected or failed step
/// returns to.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub(crate) struct ConvergedState {
    /// Time \[s\].
    pub time: f64,
    /// Node displacements \[mm\].
    pub u: Vec<f64>,
    /// Piston displacement \[mm\].
    pub piston: f64,
    /// Internal force (body and contact) \[N\]; on a held dof, the force the
    /// plane exerts.
    pub f_int: Vec<f64>,
    /// Element output fields.
    pub fields: ElementFields,
    /// Particle-contact terms.
    pub contact: ContactEvaluation,
    /// The step that led here.
    pub previous: Option<PreviousStep>,
    /// The step before it (for the quadratic predictor).
    #[serde(default)]
    pub earlier: Option<PreviousStep>,
}

/// The contact state of the planes and of the particles, saved before a
/// step is tried so that a rejected or failed attempt can be undone.
#[derive(Clone, Debug, PartialEq)]
struct ContactSnapshot {
    planes: PlaneContactState,
    particles: Option<tidens_contact::StateSnapshot>,
}

/// A step shortened to land on the target density is not shortened below
/// the proposed step over this: a converged state's density is known only
/// to Newton's tolerance and the contact penalty's give, so a step aimed at
/// a target a hair away can fall short of it, time after time. 32 random
/// spheres (level 1) ended a step 1.7e-8 short of rho = 0.95, and their
/// next steps, each aimed at the target at the last step's rate (3e-4 to
/// 1.4e-3 s against the 23 s before), moved the density by -2.5e-8 to
/// +3e-8: four more steps to get there. The bcc cell at level 1 in its
/// ramp fell by 1e-5 in a step of 1.7e-5 s aimed at 1e-6 past a target
/// 1e-9 ahead.
const TARGET_DENSITY_STEP_FLOOR: f64 = 8.0;

/// A hot-pressing simulation of one scene.
pub struct Simulation {
    pub(crate) lengths: [f64; 3],
    pub(crate) body: Body,
    pub(crate) constraints: Constraints,
    pub(crate) assembler: Assembler,
    pub(crate) linear: LinearSolver,
    /// What the current factor of the tangent was computed for.
    pub(crate) factor: Option<FactorKey>,
    pub(crate) settings: Settings,
    /// Piston force at full load \[N\].
    pub(crate) full_force: f64,
    pub(crate) control: StepController,
    pub(crate) state: ConvergedState,
    pub(crate) curve: Vec<CurvePoint>,
    pub(crate) stats: RunStats,
    pub(crate) status: Status,
    /// Contact between particles (scenes with more than one particle).
    pub(crate) contact: Option<ParticleContact>,
    /// Largest particle-contact penetration accepted in a step \[mm\].
    pub(crate) penetration_tol: f64,
    /// The drag that holds the particles of a periodic cell.
    pub(crate) stabilisation: Option<crate::evaluation::Stabilisation>,
    /// Periodic cells: the particle of each contact surface and the periods
    /// it is moved by (the particles first, unmoved, then their images);
    /// empty for other cells.
    pub(crate) surface_particles: Vec<(usize, [i8; 3])>,
    /// Densities a step should end just past, as the stop density does (the
    /// snapshots' densities): set by the caller, not part of the case or of
    /// a checkpoint, sorted.
    pub(crate) density_targets: Vec<f64>,
}

/// Contact between the particles of `scene`, when it has more than one: the
/// penalty is `penalty_factor * E / h` with `h` the mean edge of the
/// surface quads, and the search reaches one such edge from a surface.
/// The cap of the particle contacts' touch stiffness, in units of the
/// stress the cell feels over the mean surface element size (f sigma / h)
/// (`ContactSettings::touch_stiffness_cap`).
pub(crate) const TOUCH_STIFFNESS_CAP: f64 = 50.0;

/// Periodic cells: slave nodes open from their paired facet by less than
/// this fraction of the search distance (the mean surface element size) at
/// the start read that gap as closed
/// ([`tidens_contact::ParticleContact::close_initial_gaps`]). The particles
/// of a jammed packing touch at points, between the meshes' nodes, and
/// their faceted surfaces lie inside the spheroids by up to the facets'
/// sagitta (about 5e-4 mm at level 1 for R = 0.05 mm), so every contact
/// started open: on 8 jammed spheres at level 1 the first Newton direction
/// moved the piston by 1.4e-2 mm, the line search took 1 % of it, and ten
/// steps took more than ten minutes. Closed, the first three steps took 6,
/// 3 and 7 Newton iterations.
pub(crate) const INITIAL_GAP_CLOSURE: f64 = 0.1;

/// Mortar contact in a cell of octants: nodes open at the start by a mean
/// gap below this many times the penetration tolerance read closed (see
/// where it is used). The next nodes out on bcc are open by 1.2e-2 R at
/// level 1 and 1.8e-3 R at level 3.
const MORTAR_TOUCH_CLOSURE: f64 = 10.0;

/// The largest contact penalty, in units of f sigma / h: the penalty factor
/// times E / h unless that is larger (E/sigma above 1e5 at the default
/// factor). A penalty that scales with a stiff material's E makes contact
/// switch on and off over displacements far below what the load moves (on
/// bcc at 1e-3 MPa, E/sigma = 4e7: 1817 Newton iterations and 14 failed
/// attempts, the contact state flipping between iterations); capped, 938 and
/// none, the times to density within 0.1 % and the penetration still below
/// 1e-5 R (the augmented Lagrangian takes the rest).
const PENALTY_CAP: f64 = 1e6;

/// How far a particle's contact surface is continued past the plane of
/// symmetry that cuts it, as a master in mortar contact, in heights of
/// the facets there (see `ContactSurface::continue_open_edges`): past the
/// sliver by which the neighbour's projected edge can stray from the
/// slave's own.
const CONTINUATION_REACH: f64 = 0.5;

fn particle_contact(
    scene: &Scene,
    material: &Material,
    settings: &Settings,
) -> Result<Option<ParticleContact>, SolverError> {
    if scene.particles.len() < 2 && scene.periodic.is_none() {
        return Ok(None);
    }
    let mortar = settings.contact.formulation == ContactFormulation::Mortar;
    let surfaces = scene
        .particles
        .iter()
        .map(|p| match scene.element() {
            ElementKind::Hex8 => match settings.contact.hex_facets {
                HexFacets::Triangles => {
                    ContactSurface::from_quads_as_triangles(&p.surface, scene.nodes())
                }
                HexFacets::Bilinear => ContactSurface::from_quads(&p.surface, scene.nodes()),
            },
            ElementKind::Tet10 => ContactSurface::from_triangles(&p.triangles, scene.nodes()),
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| SolverError::Unsupported(e.to_string()))?;
    let mut surfaces = surfaces;
    if mortar {
        for s in &mut surfaces {
            s.continue_open_edges(CONTINUATION_REACH);
        }
    }
    // The element size and the search reach come from the particles' own
    // surfaces; their periodic images follow them.
    let images: Vec<ContactSurface> = match &scene.periodic {
        Some(periodic) => periodic
            .images
            .iter()
            .map(|im| surfaces[im.particle].image(|n| im.node_of(n).unwrap_or(usize::MAX)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| SolverError::Unsupported(e.to_string()))?,
        None => Vec::new(),
    };
    let (count, area) = surfaces
        .iter()
        .flat_map(|s| s.areas.iter())
        .fold((0usize, 0.0), |(n, a), x| (n + 1, a + x));
    let h = (area / count.max(1) as f64).sqrt();
    let c = &settings.contact;
    // The stress the cell feels [MPa].
    let stress = settings.load.knockdown * settings.load.stress;
    let all: Vec<ContactSurface> = surfaces.into_iter().chain(images).collect();
    let settings = ContactSettings {
        mode: c.mode,
        penalty: (c.penalty_factor * material.young / h).min(PENALTY_CAP * stress / h),
        search_distance: h,
        curvature_stiffness: settings.newton.consistent_tangent,
        // The applied stress moves a node by a fiftieth of an element
        // per Newton step against it; below the default touch stiffness
        // (1e-3 of the penalty) for E/sigma > 5e3 (the base case: 4e3).
        touch_stiffness_cap: TOUCH_STIFFNESS_CAP * stress / h,
    };
    let contact = if mortar {
        ParticleContact::mortar(all, settings, tidens_contact::mortar::TestBasis::Standard)
    } else {
        ParticleContact::new(all, settings)
    }
    .map_err(|e| SolverError::Unsupported(e.to_string()))?;
    Ok(Some(contact))
}

/// The drag of a periodic cell (see [`crate::evaluation::Stabilisation`]).
fn stabilisation(
    scene: &Scene,
    constraints: &Constraints,
    young: f64,
) -> crate::evaluation::Stabilisation {
    let n_dof = constraints.dof_count();
    let map = constraints.equation_map();
    let mut volume = vec![0.0; n_dof];
    for p in &scene.particles {
        let (first, count) = p.nodes;
        let share = crate::scene::hex_piece(&scene.mesh, p).volume() / count as f64;
        for d in 3 * first..3 * (first + count) {
            if map[d] == d {
                volume[d] = share;
            }
        }
    }
    let lz = scene.lengths[2];
    let height_fraction = (0..n_dof)
        .map(|d| {
            if d % 3 == 2 {
                scene.nodes()[d / 3][2] / lz
            } else {
                0.0
            }
        })
        .collect();
    let frames = scene
        .particles
        .iter()
        .map(|p| {
            let mut frame = rotation_frame(scene.nodes(), p.nodes, &volume, &map);
            let size =
                (crate::scene::hex_piece(&scene.mesh, p).volume() / p.elements.1 as f64).cbrt();
            frame.max_stiffness =
                crate::evaluation::ROTATION_HOLD_CAP * young * size / frame.weight;
            frame
        })
        .collect();
    crate::evaluation::Stabilisation {
        volume,
        height_fraction,
        scale: crate::evaluation::STABILISATION / (scene.radius * scene.radius),
        stiffness: 0.0,
        reference: vec![0.0; n_dof],
        frames,
        rotation_factor: crate::evaluation::ROTATION_HOLD / crate::evaluation::STABILISATION,
    }
}

/// The rotation frame of the particle of nodes `first..first + count`:
/// the free nodes nearest to the points half its radius from its centroid
/// along the three axes, both ways (see
/// [`crate::evaluation::RotationFrame`]); `volume` is each dof's volume
/// share, `map` the equation map (a node is free when its dofs map to
/// themselves).
fn rotation_frame(
    nodes: &[[f64; 3]],
    (first, count): (usize, usize),
    volume: &[f64],
    map: &[usize],
) -> crate::evaluation::RotationFrame {
    use nalgebra::Vector3;
    let at = |n: usize| Vector3::from(nodes[n]);
    let own = first..first + count;
    let centre = own.clone().map(at).sum::<Vector3<f64>>() / count as f64;
    let radius = own
        .clone()
        .map(|n| (at(n) - centre).norm())
        .fold(0.0, f64::max);
    let free = |n: &usize| (0..3).all(|i| map[3 * n + i] == 3 * n + i);
    let mut chosen: Vec<usize> = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let target = centre + Vector3::ith(axis, sign * 0.5 * radius);
            let best = own
                .clone()
                .filter(|n| free(n) && !chosen.contains(n))
                .min_by(|&a, &b| (at(a) - target).norm().total_cmp(&(at(b) - target).norm()));
            chosen.extend(best);
        }
    }
    let particle = crate::evaluation::moment(
        &own.clone()
            .map(|n| (at(n) - centre) * volume[3 * n].sqrt())
            .collect::<Vec<_>>(),
    );
    let mut frame = crate::evaluation::RotationFrame {
        nodes: chosen,
        weight: 0.0,
        arms: Vec::new(),
        j_inv: nalgebra::Matrix3::zeros(),
        max_stiffness: f64::INFINITY,
    };
    frame.place(at);
    frame.weight = particle.trace() / crate::evaluation::moment(&frame.arms).trace();
    frame
}

/// A periodic cell's constraints: its images follow their particles, and
/// the first node of the first particle is pinned (nothing else holds the
/// cell's rigid translation).
fn periodic_constraints(
    scene: &Scene,
    periodic: &crate::periodic::Periodic,
) -> Result<Constraints, SolverError> {
    let mut c = Constraints::without_planes(scene.nodes(), scene.lengths);
    let images: Vec<(usize, usize, [i8; 3])> = periodic
        .images
        .iter()
        .flat_map(|im| {
            im.originals
                .iter()
                .enumerate()
                .map(move |(k, &n)| (im.first + k, n, im.periods))
        })
        .collect();
    c.set_images(&images)?;
    let pinned = scene.particles.first().map_or(0, |p| p.nodes.0);
    c.pin(&[3 * pinned, 3 * pinned + 1, 3 * pinned + 2])?;
    Ok(c)
}

impl Simulation {
    /// Sets up a simulation of `scene` made of `material`.
    pub fn new(scene: &Scene, material: Material, settings: Settings) -> Result<Self, SolverError> {
        settings.validate()?;
        settings.validate_for(&material)?;
        let material = Material::new(
            material.young,
            material.poisson,
            material.creep_c,
            material.creep_n,
        )?;
        let mut body = match &scene.tet_mesh {
            Some(t) => Body::new_tet10(t.nodes.clone(), t.elements.clone(), material)?,
            None => Body::new(
                scene.mesh.nodes.clone(),
                scene.mesh.elements.clone(),
                material,
            )?,
        };
        if !settings.newton.consistent_tangent {
            body.set_tangent_pressure_cap(
                crate::newton::TANGENT_PRESSURE_CAP
                    * settings.load.knockdown
                    * settings.load.stress,
            );
        }
        let constraints = match &scene.periodic {
            Some(periodic) => periodic_constraints(scene, periodic)?,
            None => Constraints::new(
                scene.nodes(),
                scene.boundary_faces(),
                scene.lengths,
                scene.lateral_walls,
                settings.contact.tied_planes,
            )?,
        };
        let mut assembler = Assembler::new(&body, &constraints);
        let mut contact = particle_contact(scene, &material, &settings)?;
        let touching_limit = match (&contact, &scene.periodic) {
            // Whole particles placed to touch meet at points, between the
            // meshes' nodes: their contacts are closed at the start.
            (Some(c), Some(_)) => Some(INITIAL_GAP_CLOSURE * c.settings().search_distance),
            // The weighted gap of a node at the point where two curved
            // surfaces touch is the mean gap over its support, open by
            // O(h^2 / R) (bcc at level 1: 3.4e-4 R; at level 3 7e-6 R);
            // read closed, the load passes there at once, as it does
            // through the touching node of node-to-facet contact.
            (Some(c), None) if c.is_mortar() => {
                Some(MORTAR_TOUCH_CLOSURE * settings.contact.penetration_tolerance * scene.radius)
            }
            _ => None,
        };
        if let (Some(c), Some(limit)) = (contact.as_mut(), touching_limit) {
            let x0: Vec<f64> = scene.nodes().iter().flatten().copied().collect();
            let closed = c.close_initial_gaps(&x0, limit);
            if crate::newton::debug_enabled() {
                eprintln!("closed {closed} initial gaps below {limit:.3e} mm");
            }
        }
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
        let control = StepController::new(
            settings.tolerance,
            settings.max_strain_increment,
            dt0,
            dt_min,
        );
        let penetration_tol = 0.5 * settings.contact.penetration_tolerance * scene.radius;
        let stabilisation = scene
            .periodic
            .as_ref()
            .map(|_| stabilisation(scene, &constraints, material.young));
        if let Some(st) = &stabilisation {
            assembler.add_couplings(st.frames.iter().map(|f| f.dofs()), &constraints);
        }
        let n_dof = constraints.dof_count();
        let eval = body.evaluate(&vec![0.0; n_dof], 0.0, false)?;
        let volume = eval.volume();
        let mut sim = Self {
            lengths: scene.lengths,
            body,
            constraints,
            assembler,
            linear: LinearSolver::default(),
            factor: None,
            settings,
            full_force,
            control,
            state: ConvergedState {
                time: 0.0,
                u: vec![0.0; n_dof],
                piston: 0.0,
                f_int: vec![0.0; n_dof],
                fields: eval.fields(),
                contact: ContactEvaluation::default(),
                previous: None,
                earlier: None,
            },
            curve: Vec::new(),
            stats: RunStats::default(),
            status: Status::Running,
            contact,
            penetration_tol,
            stabilisation,
            surface_particles: scene.periodic.as_ref().map_or(Vec::new(), |periodic| {
                (0..scene.particles.len())
                    .map(|k| (k, [0; 3]))
                    .chain(periodic.images.iter().map(|im| (im.particle, im.periods)))
                    .collect()
            }),
            density_targets: Vec::new(),
        };
        let point = sim.curve_point(volume, 0, 0, 0.0, 0.0);
        sim.curve.push(point);
        Ok(sim)
    }

    /// Densities a step should end on (just past, as it ends on the stop
    /// density), such as those of the snapshots a caller takes: without
    /// them the first step to pass a density can pass it far (a step of
    /// the sc cell went from rho = 0.58 to 0.61). They shorten steps, so
    /// they change the curve within its time tolerance; a run resumed from
    /// a checkpoint goes on as the run that wrote it only if it is given
    /// the same targets.
    pub fn set_density_targets(&mut self, targets: &[f64]) {
        let mut targets: Vec<f64> = targets.iter().copied().filter(|r| r.is_finite()).collect();
        targets.sort_by(f64::total_cmp);
        self.density_targets = targets;
    }

    /// The densification curve so far (the initial state first).
    pub fn curve(&self) -> &[CurvePoint] {
        &self.curve
    }

    pub fn status(&self) -> Status {
        self.status
    }

    pub fn time(&self) -> f64 {
        self.state.time
    }

    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    pub fn stats(&self) -> RunStats {
        let mut s = self.stats;
        s.factorizations = self.linear.counts;
        // Patterns of assemblers forgotten at checkpoint steps, and this one's.
        s.pattern_rebuilds = self.stats.pattern_rebuilds + self.assembler.pattern_rebuilds();
        s
    }

    /// The particle contact of the scene, if it has one.
    pub fn particle_contact(&self) -> Option<&ParticleContact> {
        self.contact.as_ref()
    }

    /// The current node coordinates \[mm\] (flat, three per node) at the
    /// last converged step, periodic images included.
    pub fn coordinates(&self) -> Vec<f64> {
        self.current_coordinates(&self.state.u)
    }

    /// The particle-contact terms of the last converged step (one per slave
    /// node in contact or about to touch).
    pub fn contact_terms(&self) -> &[tidens_contact::ContactTerm] {
        &self.state.contact.terms
    }

    /// Per particle: the total force the other particles exert on it through
    /// contact, and the total force the rigid planes exert on it, at the last
    /// converged step \[N\]. For each particle the two balance (to the Newton
    /// tolerance); the plane forces include the piston's.
    pub fn particle_forces(&self, scene: &Scene) -> Vec<([f64; 3], [f64; 3])> {
        let owner = |node: usize| {
            scene
                .particles
                .iter()
                .position(|p| node >= p.nodes.0 && node < p.nodes.0 + p.nodes.1)
        };
        let mut out = vec![([0.0; 3], [0.0; 3]); scene.particles.len()];
        for t in &self.state.contact.terms {
            for (d, f) in t.dofs.iter().zip(&t.force) {
                if let Some(p) = owner(d / 3) {
                    // The force on the body is minus the internal force term.
                    out[p].0[d % 3] -= f;
                }
            }
        }
        for (d, f) in self.state.f_int.iter().enumerate() {
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
        self.constraints.unknowns()
    }

    /// Box edge lengths \[mm\].
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

    pub(crate) fn density_of(&self, volume: f64, piston: f64) -> f64 {
        let [lx, ly, lz] = self.lengths;
        volume / (lx * ly * (lz + piston))
    }

    /// The stop condition, if met by the last converged state.
    pub(crate) fn check_stop(&mut self) {
        let rho = self.rel_density();
        if self.settings.until_density.is_some_and(|r| rho >= r) {
            self.status = Status::ReachedDensity;
        } else if rho >= crate::output::FULL_DENSITY
            && self
                .curve
                .first()
                .is_some_and(|p| p.rel_density < crate::output::FULL_DENSITY)
        {
            // A packing whose pores have closed (not a block that was dense
            // from the start).
            self.status = Status::FullDensity;
        } else if self
            .settings
            .until_time
            .is_some_and(|t| self.state.time >= t * (1.0 - 1e-12))
        {
            self.status = Status::ReachedTime;
        }
    }

    /// The next time a step must end on: the end of the ramp, a requested
    /// time, or the stop time.
    fn next_time_target(&self) -> Option<f64> {
        let time = self.state.time;
        let ramp = self.settings.load.ramp_time;
        let eps = 1e-12 * time.max(1e-300);
        std::iter::once(ramp)
            .chain(self.settings.time_targets.iter().copied())
            .chain(self.settings.until_time)
            .filter(|&t| t > time + eps)
            .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.min(t))))
    }

    /// The step to try next: the controller's proposal, shortened to land on
    /// time targets and not to overshoot the target density by much. Without
    /// a target density, a packing whose pores are closing aims between
    /// [`FULL_DENSITY`](crate::output::FULL_DENSITY) and 1: at the rate of
    /// the last step, where the faceted surfaces still press into each other
    /// at full density, a doubled step would end beyond 1 (bcc at level 1
    /// held at 10 MPa: from 0.99964 to 1.00018 in one step of 1800 s).
    fn propose_dt(&self) -> f64 {
        let mut dt = self.control.dt_next().min(self.settings.dt_max);
        let full = crate::output::FULL_DENSITY;
        let closing = self.curve.first().is_some_and(|p| p.rel_density < full);
        let rho = self.rel_density();
        let target = self
            .density_targets
            .iter()
            .copied()
            .find(|&r| r > rho)
            .into_iter()
            .chain(self.settings.until_density)
            .reduce(f64::min)
            .or_else(|| closing.then_some(0.5 * (full + 1.0)));
        if let (Some(target), Some(rate)) = (target, self.density_rate()) {
            if rate > 0.0 && rho + rate * dt > target {
                let aimed = (1.02 * (target - rho) / rate).max(dt / TARGET_DENSITY_STEP_FLOOR);
                dt = aimed.max(self.control.dt_min());
            }
        }
        if let Some(t) = self.next_time_target() {
            let left = t - self.state.time;
            if dt >= left * (1.0 - 1e-9) {
                dt = left;
            } else if dt > 0.6 * left {
                dt = 0.5 * left;
            }
        }
        dt
    }

    /// Densification rate over the last step \[1/s\].
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
    /// converged step, so the curve so far is kept. The time it takes is
    /// added to [`RunStats::wall_seconds`].
    pub fn advance(&mut self) -> Result<&CurvePoint, SolverError> {
        self.advance_unless(&mut || false)
    }

    /// [`Simulation::advance`], asking `interrupted` before each Newton
    /// iteration (a step of a large cell can take minutes; an iteration
    /// seconds). When it answers true, the step is abandoned: the state
    /// stays at the last converged step, as after a failure, and the error
    /// is [`SolverError::Interrupted`]. The abandoned iterations count in
    /// [`RunStats::newton_iterations`], not as a failed attempt.
    pub fn advance_unless(
        &mut self,
        interrupted: &mut dyn FnMut() -> bool,
    ) -> Result<&CurvePoint, SolverError> {
        let start = std::time::Instant::now();
        let outcome = self.step_once(interrupted);
        self.stats.wall_seconds += start.elapsed().as_secs_f64();
        outcome?;
        self.curve
            .last()
            .ok_or(SolverError::Internal("the curve lost its initial point"))
    }

    /// One converged step, or the reason there is none (see
    /// [`Simulation::advance`]).
    fn step_once(&mut self, interrupted: &mut dyn FnMut() -> bool) -> Result<(), SolverError> {
        if self.status != Status::Running {
            return Ok(());
        }
        if self.stats.steps >= self.settings.max_steps {
            return Err(SolverError::StepLimit {
                max_steps: self.settings.max_steps,
                time: self.state.time,
                density: self.rel_density(),
            });
        }
        let mut dt = self.propose_dt();
        let mut iterations = 0;
        loop {
            let saved = self.contact_snapshot();
            match self.solve_step(dt, interrupted) {
                Ok(solved) => {
                    iterations += solved.iterations;
                    match self.accept_or_reject(solved, dt, iterations) {
                        Ok(()) => break,
                        Err(shorter) => {
                            self.stats.rejected_steps += 1;
                            self.restore_contact(saved);
                            dt = shorter;
                        }
                    }
                }
                Err(f) if matches!(f.reason, StepFailure::Interrupted) => {
                    self.restore_contact(saved);
                    self.stats.newton_iterations += iterations + f.iterations;
                    return Err(SolverError::Interrupted {
                        time: self.state.time,
                        step: self.stats.steps + 1,
                    });
                }
                Err(f) => {
                    iterations += f.iterations;
                    self.stats.failed_attempts += 1;
                    self.restore_contact(saved);
                    dt *= 0.25;
                    if dt < self.control.dt_min() {
                        self.stats.newton_iterations += iterations;
                        return Err(SolverError::NoConvergence {
                            time: self.state.time,
                            step: self.stats.steps + 1,
                            dt,
                            reason: f.reason,
                        });
                    }
                }
            }
        }
        let every = self.settings.checkpoint_every;
        if every > 0 && self.stats.steps.is_multiple_of(every) {
            self.forget_caches();
        }
        self.check_stop();
        Ok(())
    }

    /// Step control on a converged step: accepts it (commits the material
    /// state, updates the contact multipliers, records the curve point and
    /// proposes the next step) or rejects it, returning the shorter step to
    /// retry.
    fn accept_or_reject(&mut self, s: Solved, dt: f64, iterations: usize) -> Result<(), f64> {
        let lz = self.lengths[2];
        // Piston log-strain rate: the densification rate whatever the scene.
        let rate = ((lz + self.state.piston) / (lz + s.piston)).ln() / dt;
        let t1 = self.state.time + dt;
        let n = self.body.material().creep_n;
        let (f0, f1) = (
            self.settings.load.factor(self.state.time),
            self.settings.load.factor(t1),
        );
        let weight = f1.powf(n);
        // The change of ln rate the load alone makes (the ramp), for steps
        // too short to measure the rate (see `step_control`).
        let load_dln = if f0 > 0.0 && f1 > f0 {
            n * (f1 / f0).ln()
        } else {
            0.0
        };
        let max_dp = s.eval.body.max_dp();
        let noise = s.eval.contact.max_violation() / lz;
        let assessment = self
            .control
            .assess(dt, rate, weight, load_dln, max_dp, noise)?;
        if std::env::var_os("TIDENS_DEBUG").is_some() {
            eprintln!(
                "  accepted: rate {rate:.4e} /s, load weight {weight:.3e}, contact noise {noise:.2e}, {assessment:?}"
            );
        }
        self.stats.steps += 1;
        self.stats.newton_iterations += iterations;
        if f1 > 0.0 {
            let share = s.eval.drag_force / (f1 * self.full_force);
            self.stats.max_drag_share = self.stats.max_drag_share.max(share);
        }
        self.body.commit(&s.eval.body);
        let volume = s.eval.body.volume();
        let state = &mut self.state;
        state.earlier = state.previous.take();
        state.previous = Some(PreviousStep {
            u: std::mem::take(&mut state.u),
            piston: state.piston,
            dt,
        });
        state.u = s.u;
        state.piston = s.piston;
        state.time = t1;
        state.f_int = s.eval.f_int;
        state.fields = s.eval.body.fields();
        if let Some(c) = self.contact.as_mut() {
            // Uzawa update once per step: the next step starts from this
            // step's pressures, which keeps penetrations small and the
            // contact law smooth in time.
            let x: Vec<f64> = self
                .body
                .nodes()
                .iter()
                .flatten()
                .zip(&state.u)
                .map(|(p, du)| p + du)
                .collect();
            c.augment(&x, &s.eval.contact);
            c.tie_closed(&s.eval.contact);
        }
        state.contact = s.eval.contact;
        self.control.accept(&assessment, iterations);
        let point = self.curve_point(volume, self.stats.steps, iterations, dt, max_dp);
        self.curve.push(point);
        Ok(())
    }

    fn contact_snapshot(&self) -> ContactSnapshot {
        ContactSnapshot {
            planes: self.constraints.contact_state(),
            particles: self.contact.as_ref().map(|c| c.state_snapshot()),
        }
    }

    fn restore_contact(&mut self, saved: ContactSnapshot) {
        self.constraints.set_contact_state(saved.planes);
        if let (Some(c), Some(particles)) = (self.contact.as_mut(), saved.particles) {
            c.restore(&particles);
        }
    }

    /// The consistent tangent at the current state for a step `dt` \[s\]: the
    /// symmetric system Newton factorises (for diagnostics and benchmarks).
    pub fn assemble_tangent(&mut self, dt: f64) -> Result<&SparseSystem, SolverError> {
        let u = self.state.u.clone();
        let eval = self.evaluate(&u, dt, true)?;
        let map = self.constraints.equation_map();
        self.assemble_grown(&eval, &map)?;
        Ok(self.assembler.system())
    }

    /// Assembles the tangent of `eval` through the equation map `map`,
    /// growing the pattern (and so forgetting the symbolic factorisation)
    /// for particle-contact couplings it lacks. An entry outside the grown
    /// pattern is an error, not left out: a tangent short of a coupling
    /// slows Newton down without a trace.
    pub(crate) fn assemble_grown(
        &mut self,
        eval: &Evaluation,
        map: &[usize],
    ) -> Result<(), LinearError> {
        if self.assembler.assemble(eval, map) {
            return Ok(());
        }
        if let Some(c) = &self.contact {
            self.assembler.grow(&eval.contact, c, &self.constraints);
        }
        self.linear.reset_pattern();
        match self.assembler.assemble_counting(eval, map) {
            0 => Ok(()),
            entries => Err(LinearError::OutsidePattern { entries }),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::test_support::{bcc_level1, bcc_level1_scene, bcc_level1_settings};
    use crate::{Checkpoint, NewtonSettings, Preset, Simulation};
    use std::sync::OnceLock;

    /// The bcc cell at level 1 (15 MPa, tolerance 0.05, to stop at rho =
    /// 0.9) pressed to rho = 0.72: pressed once for the tests below, each
    /// resuming from its checkpoint (a run of its own, without the caches
    /// the pressing run kept: the tests look at the state, not at them).
    fn bcc_pressed_to_072() -> Simulation {
        let adjust = |s: &mut crate::Settings| {
            s.until_density = Some(0.9);
            s.tolerance = 0.05;
        };
        static PRESSED: OnceLock<Checkpoint> = OnceLock::new();
        let saved = PRESSED.get_or_init(|| {
            let mut sim = bcc_level1(adjust);
            while sim.rel_density() < 0.72 {
                sim.advance().unwrap();
            }
            sim.checkpoint()
        });
        let material = Preset::Ti64Creep1293K.material();
        Simulation::resume(
            &bcc_level1_scene(),
            material,
            bcc_level1_settings(adjust),
            saved,
        )
        .unwrap()
    }

    /// A failed attempt changes the contact state (planes caught or
    /// released, particle contact pressures), and the cut back restores it
    /// exactly, so the retry starts from the last converged step.
    #[test]
    fn a_failed_attempt_is_undone_exactly() {
        let mut sim = bcc_pressed_to_072();
        let before = sim.contact_snapshot();
        assert!(before.particles.as_ref().is_some_and(|p| !p.is_empty()));
        let u = sim.state.u.clone();
        // A step 10 times the proposed one with two iterations: it fails
        // after the active sets moved.
        sim.settings.newton.max_iterations = 2;
        let dt = 10.0 * sim.propose_dt();
        let failed = sim.solve_step(dt, &mut || false);
        assert!(failed.is_err());
        assert!(
            sim.contact_snapshot() != before,
            "the attempt must have moved the contact state for this test to test anything"
        );
        sim.restore_contact(before.clone());
        assert_eq!(sim.contact_snapshot(), before);
        assert_eq!(
            sim.state.u, u,
            "the converged displacement is never touched"
        );
        // And the run goes on from there.
        sim.settings.newton.max_iterations = NewtonSettings::default().max_iterations;
        assert!(sim.advance().is_ok());
    }

    /// A step shortened to land on the target density aims 2 % past it, but
    /// is no shorter than an eighth of the proposed step, so that a target a
    /// hair away is reached in one step (here, in the ramp, a step of
    /// 1.7e-5 s aimed at 1e-6 past a target 1e-9 ahead lost 1e-5).
    #[test]
    fn a_step_aimed_at_the_target_density_lands_past_it() {
        let mut sim = bcc_pressed_to_072();
        let rate = sim.density_rate().unwrap();
        let free = sim.propose_dt();
        let floor = free / super::TARGET_DENSITY_STEP_FLOOR;
        for gap in [
            1e-9,
            0.3 * rate * floor,
            0.5 * rate * free,
            2.0 * rate * free,
        ] {
            sim.settings.until_density = Some(sim.rel_density() + gap);
            let dt = sim.propose_dt();
            // 2 % past the target at the last step's rate, within the
            // proposed step and not below its floor.
            let aimed = (1.02 * gap / rate).clamp(floor, free);
            assert!(
                (dt - aimed).abs() <= 1e-12 * aimed,
                "gap {gap:e}: {dt} against {aimed}"
            );
        }
        // A hair away, the run stops there in one step.
        sim.settings.until_density = Some(sim.rel_density() + 1e-9);
        let steps = sim.stats.steps;
        sim.advance().unwrap();
        assert_eq!(
            (sim.status, sim.stats.steps),
            (crate::Status::ReachedDensity, steps + 1)
        );
    }

    /// A step abandoned at the caller's request leaves the last converged
    /// step as it was: abandoned before its first Newton iteration, the run
    /// goes on bit for bit like one never interrupted; abandoned after one
    /// iteration (whose factor it keeps), it converges to the same step
    /// within Newton's tolerance.
    #[test]
    fn an_interrupted_step_leaves_the_last_converged_step() {
        // Both at rho = 0.72, from the one checkpoint.
        let (mut through, mut stopped) = (bcc_pressed_to_072(), bcc_pressed_to_072());
        let (u, contact, steps) = (
            stopped.state.u.clone(),
            stopped.contact_snapshot(),
            stopped.curve.len(),
        );
        let unchanged = |sim: &Simulation| {
            assert_eq!(sim.state.u, u, "the converged displacement");
            assert!(sim.contact_snapshot() == contact, "the contact state");
            assert_eq!(sim.curve.len(), steps, "the curve");
            assert_eq!(sim.stats.steps + 1, steps, "the step count");
        };
        let err = stopped.advance_unless(&mut || true).unwrap_err();
        assert!(
            matches!(err, crate::SolverError::Interrupted { step, .. } if step == steps),
            "{err}"
        );
        unchanged(&stopped);
        let point = through.advance().unwrap().clone();
        assert_eq!(stopped.advance().unwrap(), &point);

        let (u, contact, steps) = (
            stopped.state.u.clone(),
            stopped.contact_snapshot(),
            stopped.curve.len(),
        );
        let (iterations, failed) = (
            stopped.stats.newton_iterations,
            stopped.stats.failed_attempts,
        );
        let before = stopped.rel_density();
        let mut asked = 0;
        let err = stopped
            .advance_unless(&mut || {
                asked += 1;
                asked > 1
            })
            .unwrap_err();
        assert!(
            matches!(err, crate::SolverError::Interrupted { .. }),
            "{err}"
        );
        let unchanged = |sim: &Simulation| {
            assert_eq!(sim.state.u, u, "the converged displacement");
            assert!(sim.contact_snapshot() == contact, "the contact state");
            assert_eq!(sim.curve.len(), steps, "the curve");
        };
        unchanged(&stopped);
        assert_eq!(stopped.stats.newton_iterations, iterations + 1);
        assert_eq!(stopped.stats.failed_attempts, failed);
        let point = through.advance().unwrap().clone();
        let again = stopped.advance().unwrap();
        assert_eq!(again.time, point.time, "the same step");
        let rise = point.rel_density - before;
        assert!(
            (again.rel_density - point.rel_density).abs() < 1e-3 * rise,
            "{} against {} (the step's rise {rise:.3e})",
            again.rel_density,
            point.rel_density
        );
    }
}
