//! `Simulation`: one hot-pressing run, stepped with the GIL released.
//!
//! The core simulation sits behind a mutex so that the object can be shared
//! between Python threads: one thread steps it (the GIL released for the whole
//! step) while others keep running Python. A copy of the progress (status,
//! curve, totals) is refreshed after every step, so that the status, the
//! curve and the totals can be read from another thread without waiting for
//! the step in progress. Every wait for a lock happens with the GIL released
//! and no lock is held while waiting for the GIL, so the two cannot deadlock.

use crate::arguments::optional_integer;
use crate::cell::{CellKind, PyCell};
use crate::convert::{
    columns_dict, curve_columns, fields_dict, point_dict, stats_dict, status_name,
};
use crate::errors::{Number, Phase, StepError, parameter_error, poisoned, solver_error};
use crate::material::PyMaterial;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};
use std::sync::{Mutex, MutexGuard, PoisonError};
use tidens_solver::{
    Checkpoint, ContactFormulation, ContactMode, ContactOptions, CurvePoint, ElementKind,
    HexFacets, LoadHistory, MAX_MESH_LEVEL, MAX_NEWTON_ITERATIONS, MeshOptions, NewtonSettings,
    RunStats, Scene, Settings, Simulation, SolverError, Status,
};

/// The Python names of the contact modes, in the order of `CONTACT_MODES`.
pub(crate) const CONTACT_MODES: [(&str, ContactMode); 2] = [
    ("frictionless", ContactMode::Frictionless),
    ("tied", ContactMode::Tied),
];

/// The entry of `table` called `name`, or a ValueError naming the
/// parameter and listing the choices.
pub(crate) fn named<T: Copy>(parameter: &str, name: &str, table: &[(&str, T)]) -> PyResult<T> {
    table
        .iter()
        .find(|(n, _)| *n == name)
        .map(|&(_, value)| value)
        .ok_or_else(|| {
            let choices: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
            PyValueError::new_err(format!(
                "{parameter} = '{name}': must be one of {}",
                choices.join(", ")
            ))
        })
}

/// The Python names of the particle-contact discretisations, the core's
/// default first: node to facet on each hexahedral face's two triangles or
/// on its bilinear patch, or mortar (weighted gaps, segment to segment).
pub(crate) const CONTACT_FACETS: [(&str, (HexFacets, ContactFormulation)); 3] = [
    (
        "triangles",
        (HexFacets::Triangles, ContactFormulation::NodeToFacet),
    ),
    (
        "bilinear",
        (HexFacets::Bilinear, ContactFormulation::NodeToFacet),
    ),
    ("mortar", (HexFacets::Triangles, ContactFormulation::Mortar)),
];

/// The particle index of every element of a scene (-1 for an element of no
/// particle, as in the verification blocks).
fn element_particles(scene: &Scene) -> Vec<i64> {
    let count = match &scene.tet_mesh {
        Some(t) => t.elements.len(),
        None => scene.mesh.elements.len(),
    };
    let mut owner = vec![-1; count];
    // The particles' element ranges count in the scene's body mesh.
    for (k, p) in scene.particles.iter().enumerate() {
        let (first, count) = p.elements;
        // Particle counts are tiny: the cast cannot wrap.
        owner[first..first + count].fill(k as i64);
    }
    owner
}

/// The Python names of the elements, the default first.
pub(crate) const ELEMENTS: [(&str, ElementKind); 2] =
    [("hex8", ElementKind::Hex8), ("tet10", ElementKind::Tet10)];

/// The defaults of every solver knob, keyed by the Python argument names
/// (None where the core picks the value from the case, as the first step).
pub(crate) fn solver_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let s = Settings::new(LoadHistory {
        stress: 1.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    let m = MeshOptions::default();
    let d = PyDict::new(py);
    d.set_item("mesh_level", m.level)?;
    d.set_item("tolerance", s.tolerance)?;
    d.set_item("grading", m.grading)?;
    d.set_item("exact_volume", m.exact_volume)?;
    d.set_item("element", ELEMENTS[0].0)?;
    d.set_item("max_strain_increment", s.max_strain_increment)?;
    d.set_item("dt_initial_s", s.dt_initial)?;
    d.set_item("dt_max_s", s.dt_max)?;
    d.set_item("max_steps", s.max_steps)?;
    d.set_item("newton_max_iterations", s.newton.max_iterations)?;
    d.set_item("newton_residual_tolerance", s.newton.residual_tolerance)?;
    d.set_item("contact_penalty_factor", s.contact.penalty_factor)?;
    d.set_item("penetration_tolerance", s.contact.penetration_tolerance)?;
    let facets = CONTACT_FACETS.iter().find(|(_, (f, formulation))| {
        *formulation == s.contact.formulation
            && (*formulation == ContactFormulation::Mortar || *f == s.contact.hex_facets)
    });
    d.set_item("contact_facets", facets.map(|(name, _)| *name))?;
    d.set_item("checkpoint_every", s.checkpoint_every)?;
    Ok(d)
}

/// The `mesh_level` argument: None or an integer in [1, 6].
pub(crate) fn mesh_level_argument(value: &Bound<'_, PyAny>) -> PyResult<Option<u32>> {
    optional_integer("mesh_level", value, 1..=MAX_MESH_LEVEL)
}

/// The `max_steps` argument: None or an integer >= 1.
fn max_steps_argument(value: &Bound<'_, PyAny>) -> PyResult<Option<usize>> {
    optional_integer("max_steps", value, 1..=usize::MAX)
}

/// The `newton_max_iterations` argument: None or an integer in [1, 1000].
fn newton_max_iterations_argument(value: &Bound<'_, PyAny>) -> PyResult<Option<usize>> {
    optional_integer("newton_max_iterations", value, 1..=MAX_NEWTON_ITERATIONS)
}

/// The `checkpoint_every` argument: None or an integer >= 0 (0: the caller checkpoints every 50 steps and at any stop; the core then never drops its caches).
fn checkpoint_every_argument(value: &Bound<'_, PyAny>) -> PyResult<Option<usize>> {
    optional_integer("checkpoint_every", value, 0..=usize::MAX)
}

/// The load, stop and solver knobs of a run as the Python keyword arguments
/// give them (None: the core's default), the integers already checked.
struct Knobs<'a> {
    stress_mpa: f64,
    knockdown: f64,
    ramp_time_s: f64,
    until_density: Option<f64>,
    until_time_s: Option<f64>,
    mesh_level: Option<u32>,
    grading: Option<f64>,
    exact_volume: Option<bool>,
    element: Option<&'a str>,
    tolerance: Option<f64>,
    max_strain_increment: Option<f64>,
    dt_initial_s: Option<f64>,
    dt_max_s: Option<f64>,
    max_steps: Option<usize>,
    time_targets_s: Vec<f64>,
    newton_max_iterations: Option<usize>,
    newton_residual_tolerance: Option<f64>,
    contact: &'a str,
    tied_planes: bool,
    contact_penalty_factor: Option<f64>,
    penetration_tolerance: Option<f64>,
    contact_facets: Option<&'a str>,
    checkpoint_every: Option<usize>,
}

impl Knobs<'_> {
    /// The core's settings, mesh options and element, every value checked
    /// against its range (a ValueError naming the Python argument).
    fn checked(self) -> PyResult<(Settings, MeshOptions, ElementKind)> {
        // A knob left at None takes the core's default (the one source of
        // the defaults, also published as SOLVER_DEFAULTS).
        let load = LoadHistory {
            stress: self.stress_mpa,
            knockdown: self.knockdown,
            ramp_time: self.ramp_time_s,
        };
        let defaults = Settings::new(load);
        let mesh_defaults = MeshOptions::default();
        let level = self.mesh_level.unwrap_or(mesh_defaults.level);
        let newton = &defaults.newton;
        let contact_defaults = &defaults.contact;
        let facets = match self.contact_facets {
            Some(name) => named("contact_facets", name, &CONTACT_FACETS)?,
            None => (contact_defaults.hex_facets, contact_defaults.formulation),
        };
        let settings = Settings {
            until_density: self.until_density,
            until_time: self.until_time_s,
            tolerance: self.tolerance.unwrap_or(defaults.tolerance),
            max_strain_increment: self
                .max_strain_increment
                .unwrap_or(defaults.max_strain_increment),
            dt_initial: self.dt_initial_s,
            dt_max: self.dt_max_s.unwrap_or(defaults.dt_max),
            max_steps: self.max_steps.unwrap_or(defaults.max_steps),
            checkpoint_every: self.checkpoint_every.unwrap_or(defaults.checkpoint_every),
            time_targets: self.time_targets_s,
            newton: NewtonSettings {
                max_iterations: self.newton_max_iterations.unwrap_or(newton.max_iterations),
                residual_tolerance: self
                    .newton_residual_tolerance
                    .unwrap_or(newton.residual_tolerance),
                ..newton.clone()
            },
            contact: ContactOptions {
                mode: named("contact", self.contact, &CONTACT_MODES)?,
                tied_planes: self.tied_planes,
                penalty_factor: self
                    .contact_penalty_factor
                    .unwrap_or(contact_defaults.penalty_factor),
                penetration_tolerance: self
                    .penetration_tolerance
                    .unwrap_or(contact_defaults.penetration_tolerance),
                hex_facets: facets.0,
                formulation: facets.1,
            },
            ..defaults.clone()
        };
        settings
            .validate()
            .map_err(|e| solver_error(e, Phase::Setup))?;
        let options = MeshOptions {
            level,
            grading: self.grading.unwrap_or(mesh_defaults.grading),
            exact_volume: self.exact_volume.unwrap_or(mesh_defaults.exact_volume),
        };
        options
            .validate()
            .map_err(|e| solver_error(e, Phase::Setup))?;
        let kind = named("element", self.element.unwrap_or(ELEMENTS[0].0), &ELEMENTS)?;
        Ok((settings, options, kind))
    }
}

/// Checks load and solver knobs against their ranges without building a
/// run: the keyword arguments of Simulation but the cell and the material,
/// all optional (a knob not given is not checked; the stop condition only
/// when given); with `material`, also E over the stress the cell feels.
/// Raises ValueError naming the first argument out of range.
#[pyfunction]
#[pyo3(signature = (
    *,
    stress_mpa = 1.0,
    knockdown = 1.0,
    ramp_time_s = 1.0,
    until_density = None,
    until_time_s = None,
    mesh_level = None,
    grading = None,
    exact_volume = None,
    element = None,
    tolerance = None,
    max_strain_increment = None,
    dt_initial_s = None,
    dt_max_s = None,
    max_steps = None,
    time_targets_s = Vec::new(),
    newton_max_iterations = None,
    newton_residual_tolerance = None,
    contact = "frictionless",
    tied_planes = false,
    contact_penalty_factor = None,
    penetration_tolerance = None,
    contact_facets = None,
    checkpoint_every = None,
    material = None,
))]
// The Python keyword arguments: one per solver knob.
#[allow(clippy::too_many_arguments)]
pub fn check_parameters(
    stress_mpa: f64,
    knockdown: f64,
    ramp_time_s: f64,
    until_density: Option<f64>,
    until_time_s: Option<f64>,
    #[pyo3(from_py_with = mesh_level_argument)] mesh_level: Option<u32>,
    grading: Option<f64>,
    exact_volume: Option<bool>,
    element: Option<&str>,
    tolerance: Option<f64>,
    max_strain_increment: Option<f64>,
    dt_initial_s: Option<f64>,
    dt_max_s: Option<f64>,
    #[pyo3(from_py_with = max_steps_argument)] max_steps: Option<usize>,
    time_targets_s: Vec<f64>,
    #[pyo3(from_py_with = newton_max_iterations_argument)] newton_max_iterations: Option<usize>,
    newton_residual_tolerance: Option<f64>,
    contact: &str,
    tied_planes: bool,
    contact_penalty_factor: Option<f64>,
    penetration_tolerance: Option<f64>,
    contact_facets: Option<&str>,
    #[pyo3(from_py_with = checkpoint_every_argument)] checkpoint_every: Option<usize>,
    material: Option<PyRef<'_, PyMaterial>>,
) -> PyResult<()> {
    // The core wants a stop condition; a placeholder stands in when none is
    // given, so that only the knobs given are judged.
    let until_time_s = match (until_density, until_time_s) {
        (None, None) => Some(1.0),
        (_, t) => t,
    };
    let (settings, _, _) = Knobs {
        stress_mpa,
        knockdown,
        ramp_time_s,
        until_density,
        until_time_s,
        mesh_level,
        grading,
        exact_volume,
        element,
        tolerance,
        max_strain_increment,
        dt_initial_s,
        dt_max_s,
        max_steps,
        time_targets_s,
        newton_max_iterations,
        newton_residual_tolerance,
        contact,
        tied_planes,
        contact_penalty_factor,
        penetration_tolerance,
        contact_facets,
        checkpoint_every,
    }
    .checked()?;
    if let Some(m) = material {
        settings
            .validate_for(&m.inner)
            .map_err(|e| solver_error(e, Phase::Setup))?;
    }
    Ok(())
}

/// What readers on other threads see: refreshed after every step.
struct Progress {
    status: Status,
    curve: Vec<CurvePoint>,
    stats: RunStats,
    degrees_of_freedom: usize,
}

impl Progress {
    fn of(sim: &Simulation) -> Self {
        Self {
            status: sim.status(),
            curve: sim.curve().to_vec(),
            stats: sim.stats(),
            degrees_of_freedom: sim.degrees_of_freedom(),
        }
    }

    /// Catches up with `sim`: appends its new curve points.
    fn refresh(&mut self, sim: &Simulation) {
        let curve = sim.curve();
        if let Some(new) = curve.get(self.curve.len()..) {
            self.curve.extend_from_slice(new);
        }
        self.status = sim.status();
        self.stats = sim.stats();
        self.degrees_of_freedom = sim.degrees_of_freedom();
    }
}

/// One hot-pressing run of a cell; advance it step by step or run it.
///
/// Simulation(cell, material, *, stress_mpa, ...) meshes the cell and sets up
/// the run. Load: applied stress stress_mpa [MPa] in (0, 1e4], ramped
/// linearly from 0 over ramp_time_s [s] then held; the cell feels
/// knockdown * stress (die-wall friction, knockdown in (0, 1]). Stop: at
/// relative density until_density and/or time until_time_s [s] (at least one).
/// Mesh: mesh_level (1 coarsest; each level refines by ~sqrt(2)) and grading
/// (element-size ratio toward the contacts, in [1, 10]) and exact_volume
/// (surface nodes moved outward so that each particle's mesh has its exact
/// volume, contact points kept on the surface). Contact between
/// particles: contact = "frictionless" (sliding, the default) or "tied" (no
/// sliding once closed); tied_planes = True ties surface nodes that touch a
/// rigid die plane (a sensitivity option, not the default: the mirror planes
/// are frictionless); contact_penalty_factor in [0.01, 1e4] (penalty
/// stiffness over E/h, h the mean surface element size); penetration_tolerance
/// in [1e-8, 1e-2], the largest penetration of a converged step as a fraction
/// of the largest particle radius. Steps: tolerance is
/// the target relative time error in [1e-6, 0.5]; max_strain_increment the
/// largest plastic strain increment per step in (0, 2]; dt_initial_s, dt_max_s
/// [s]; max_steps; time_targets_s [s], times a step must end on; Newton:
/// newton_max_iterations per Newton solve (each update of the contact
/// multipliers starts one), newton_residual_tolerance relative to
/// the piston force; checkpoint_every, the steps at which the solver drops
/// its cached factor so that a checkpoint taken there resumes bit for bit.
/// resume_from (bytes of Simulation.checkpoint()) goes on from a checkpoint
/// of the same case. A value out of range raises ValueError naming it.
///
/// Thread-safe: the step runs with the GIL released, and status, curve() and
/// stats() can be read from another thread while it runs.
#[pyclass(name = "Simulation", module = "tidens_rs._core", frozen)]
pub struct PySimulation {
    sim: Mutex<Simulation>,
    progress: Mutex<Progress>,
    lengths: [f64; 3],
    node_count: usize,
    element_count: usize,
    /// The particle index of each element (the scene's particles).
    element_particle: Vec<i64>,
}

impl PySimulation {
    /// The progress copy. It is only ever locked to copy plain data (no code
    /// that can panic half-way), so a poisoned lock still holds whole data.
    fn progress(&self) -> MutexGuard<'_, Progress> {
        self.progress.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// One step of the core simulation; to be called with the GIL released.
    ///
    /// Before each Newton iteration it takes the GIL for a moment to run
    /// Python's signal handlers (in the main thread; elsewhere that does
    /// nothing): Ctrl-C, or a handler raising on SIGTERM, abandons the step
    /// within one iteration, the state left at the last converged step. No
    /// Simulation method locks `sim` while holding the GIL, so taking the
    /// GIL here cannot deadlock.
    fn step(&self) -> Result<CurvePoint, StepError> {
        let mut sim = self.sim.lock().map_err(|_| StepError::Poisoned)?;
        let mut raised: Option<PyErr> = None;
        let point = sim
            .advance_unless(&mut || match Python::attach(|py| py.check_signals()) {
                Ok(()) => false,
                Err(e) => {
                    raised = Some(e);
                    true
                }
            })
            .cloned();
        // Failed steps change the totals too (failed attempts).
        self.progress().refresh(&sim);
        match (point, raised) {
            (Err(SolverError::Interrupted { .. }), Some(e)) => Err(StepError::Signal(e)),
            (point, _) => point.map_err(StepError::Solver),
        }
    }
}

#[pymethods]
impl PySimulation {
    #[new]
    #[pyo3(signature = (
        cell,
        material,
        *,
        stress_mpa,
        knockdown = 1.0,
        ramp_time_s = 1.0,
        until_density = None,
        until_time_s = None,
        mesh_level = None,
        grading = None,
        exact_volume = None,
        element = None,
        tolerance = None,
        max_strain_increment = None,
        dt_initial_s = None,
        dt_max_s = None,
        max_steps = None,
        time_targets_s = Vec::new(),
        newton_max_iterations = None,
        newton_residual_tolerance = None,
        contact = "frictionless",
        tied_planes = false,
        contact_penalty_factor = None,
        penetration_tolerance = None,
        contact_facets = None,
        checkpoint_every = None,
        resume_from = None,
    ))]
    // The Python keyword arguments: one per solver knob.
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        cell: &Bound<'_, PyCell>,
        material: &Bound<'_, PyMaterial>,
        stress_mpa: f64,
        knockdown: f64,
        ramp_time_s: f64,
        until_density: Option<f64>,
        until_time_s: Option<f64>,
        #[pyo3(from_py_with = mesh_level_argument)] mesh_level: Option<u32>,
        grading: Option<f64>,
        exact_volume: Option<bool>,
        element: Option<&str>,
        tolerance: Option<f64>,
        max_strain_increment: Option<f64>,
        dt_initial_s: Option<f64>,
        dt_max_s: Option<f64>,
        #[pyo3(from_py_with = max_steps_argument)] max_steps: Option<usize>,
        time_targets_s: Vec<f64>,
        #[pyo3(from_py_with = newton_max_iterations_argument)] newton_max_iterations: Option<usize>,
        newton_residual_tolerance: Option<f64>,
        contact: &str,
        tied_planes: bool,
        contact_penalty_factor: Option<f64>,
        penetration_tolerance: Option<f64>,
        contact_facets: Option<&str>,
        #[pyo3(from_py_with = checkpoint_every_argument)] checkpoint_every: Option<usize>,
        resume_from: Option<&[u8]>,
    ) -> PyResult<Self> {
        if until_density.is_none() && until_time_s.is_none() {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "until_density and until_time_s are both None: give at least one stop \
                 condition (until_density in (rho0, 1), until_time_s > 0 s)",
            ));
        }
        let (settings, options, kind) = Knobs {
            stress_mpa,
            knockdown,
            ramp_time_s,
            until_density,
            until_time_s,
            mesh_level,
            grading,
            exact_volume,
            element,
            tolerance,
            max_strain_increment,
            dt_initial_s,
            dt_max_s,
            max_steps,
            time_targets_s,
            newton_max_iterations,
            newton_residual_tolerance,
            contact,
            tied_planes,
            contact_penalty_factor,
            penetration_tolerance,
            contact_facets,
            checkpoint_every,
        }
        .checked()?;
        let cell = cell.get().inner.clone();
        if matches!(cell, CellKind::Periodic { .. }) && kind != ElementKind::Hex8 {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "element = tet10: a periodic cell is meshed with hex8 elements only",
            ));
        }
        let material = material.get().inner;
        let checkpoint = resume_from
            .map(Checkpoint::from_bytes)
            .transpose()
            .map_err(|e| solver_error(e, Phase::Setup))?;
        let (sim, element_particle) = py
            .detach(move || {
                let scene = match &cell {
                    CellKind::Octants(c) => Scene::from_cell(c, &options)?.with_element(kind)?,
                    CellKind::Periodic {
                        lengths, particles, ..
                    } => Scene::periodic(*lengths, particles, &options)?,
                };
                let sim = match &checkpoint {
                    Some(c) => Simulation::resume(&scene, material, settings, c)?,
                    None => Simulation::new(&scene, material, settings)?,
                };
                Ok((sim, element_particles(&scene)))
            })
            .map_err(|e| solver_error(e, Phase::Setup))?;
        let (node_count, element_count) = (sim.body().nodes().len(), element_particle.len());
        Ok(Self {
            progress: Mutex::new(Progress::of(&sim)),
            lengths: sim.lengths(),
            node_count,
            element_count,
            element_particle,
            sim: Mutex::new(sim),
        })
    }

    /// The run's state as bytes, to write to a file and give back as
    /// `Simulation(..., resume_from=bytes)` with the same case. Taken right
    /// after a step that is a multiple of checkpoint_every, the resumed run
    /// goes on bit for bit like this one.
    fn checkpoint<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let bytes = py.detach(|| -> PyResult<Vec<u8>> {
            let sim = self.sim.lock().map_err(|_| poisoned())?;
            sim.checkpoint()
                .to_bytes()
                .map_err(|e| solver_error(e, Phase::Run))
        })?;
        Ok(pyo3::types::PyBytes::new(py, &bytes))
    }

    /// Densities that steps end on (just past each, by at most 2 % of the
    /// last step's rise), as they end on until_density: a snapshot taken at
    /// the first step reaching a density is then taken at that density,
    /// not up to a whole step later. They shorten steps, which changes the
    /// curve within its time tolerance: a run resumed from a checkpoint
    /// goes on to the bit only with the same targets. Not recorded in a
    /// checkpoint. Each must be finite.
    fn set_density_targets(&self, py: Python<'_>, targets: Vec<f64>) -> PyResult<()> {
        if let Some((k, r)) = targets.iter().enumerate().find(|(_, r)| !r.is_finite()) {
            return Err(parameter_error(
                &format!("targets[{k}]"),
                Number(*r),
                "finite",
            ));
        }
        py.detach(|| {
            let mut sim = self.sim.lock().map_err(|_| poisoned())?;
            sim.set_density_targets(&targets);
            Ok(())
        })
    }

    /// One converged step (GIL released); returns its curve point.
    ///
    /// The point is a dict: time_s, rel_density, piston_displacement_mm
    /// (negative in compression), applied_stress_mpa, cell_stress_mpa, step,
    /// newton_iterations, newton_total, dt_s, max_strain_increment,
    /// particle_volume_mm3, time_error_s, contacts (plane dofs in contact),
    /// particle_contacts (nodes pressed on another particle), max_penetration_mm
    /// (into a plane, or into a particle through a node's link to a facet),
    /// max_depth_mm (of any surface node inside another particle, linked or
    /// not), coordination_number (periodic cells: contacts per particle,
    /// twice the pairs of particles, or of a particle and another's or its
    /// own periodic image, pressed together, over the particles; NaN for
    /// cells of octants).
    /// Once stopped, returns the last point again. Raises ConvergenceError if
    /// the step fails; the state stays at the last converged step.
    /// Python's signal handlers run before each Newton iteration: Ctrl-C (or
    /// any handler that raises) abandons the step within one iteration,
    /// raising what the handler raised, the state at the last converged step.
    fn advance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let point = py.detach(|| self.step()).map_err(|e| e.into_py(py))?;
        point_dict(py, &point)
    }

    /// Steps to the stop condition; `callback(point)` after each step, returning False stops.
    ///
    /// Each step runs with the GIL released; Ctrl-C raises KeyboardInterrupt
    /// within one Newton iteration (see advance), leaving the state at the
    /// last converged step. Returns
    /// the status: "running" (stopped by the callback), "reached_density",
    /// "reached_time" or "full_density" (the pores closed: rho reached
    /// 0.9999 first). Raises ConvergenceError if a step fails.
    #[pyo3(signature = (callback = None))]
    fn run(&self, py: Python<'_>, callback: Option<Bound<'_, PyAny>>) -> PyResult<&'static str> {
        while self.progress().status == Status::Running {
            let point = py.detach(|| self.step()).map_err(|e| e.into_py(py))?;
            py.check_signals()?;
            if let Some(callback) = &callback {
                let answer = callback.call1((point_dict(py, &point)?,))?;
                // Exactly False stops: None (no return statement) goes on.
                if answer.cast::<PyBool>().is_ok_and(|b| !b.is_true()) {
                    break;
                }
            }
        }
        Ok(status_name(self.progress().status))
    }

    /// "running", "reached_density", "reached_time" or "full_density".
    #[getter]
    fn status(&self) -> &'static str {
        status_name(self.progress().status)
    }

    /// Time of the last converged step [s].
    #[getter]
    fn time_s(&self) -> f64 {
        self.progress().curve.last().map_or(0.0, |p| p.time)
    }

    /// Relative density of the last converged step [-].
    #[getter]
    fn rel_density(&self) -> f64 {
        self.progress().curve.last().map_or(0.0, |p| p.rel_density)
    }

    /// Unknowns at the current contact state: free displacement components plus the piston.
    #[getter]
    fn degrees_of_freedom(&self) -> usize {
        self.progress().degrees_of_freedom
    }

    /// Number of mesh nodes.
    #[getter]
    fn node_count(&self) -> usize {
        self.node_count
    }

    /// Number of hexahedral elements.
    #[getter]
    fn element_count(&self) -> usize {
        self.element_count
    }

    /// Cell box edge lengths (Lx, Ly, Lz) before pressing [mm].
    #[getter]
    fn lengths_mm(&self) -> (f64, f64, f64) {
        let [x, y, z] = self.lengths;
        (x, y, z)
    }

    /// The densification curve: a dict of 1-D float64 arrays with the keys of
    /// the point dict, one entry per converged step, the initial state first.
    fn curve<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let columns = curve_columns(&self.progress().curve);
        columns_dict(py, columns)
    }

    /// Fields of the last converged state, numpy arrays: points (N,3) current
    /// coordinates [mm], displacement (N,3) [mm], contact_force (N,3) force of
    /// the rigid planes on each node [N], contact_pressure (N,) particle-
    /// particle contact pressure [MPa] (0 where none), cells (E,8) or (E,10) int64
    /// node indices (VTK order), cell_type "hexahedron" or "tetra10", particle (E,) int64 the index of the
    /// particle (octant of the cell) each element belongs to, and per element
    /// von_mises [MPa], mean_stress (tension positive) [MPa] and eqps
    /// (equivalent plastic strain) [-].
    ///
    /// Waits (GIL released) for a step in progress on another thread to end.
    fn fields<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let fields = py.detach(|| {
            self.sim
                .lock()
                .map(|sim| sim.fields())
                .map_err(|_| poisoned())
        })?;
        fields_dict(py, fields, self.element_particle.clone())
    }

    /// Run totals: steps, newton_iterations, rejected_steps, failed_attempts,
    /// llt_factorizations, lblt_factorizations,
    /// single_precision_factorizations (of the llt ones, those in single
    /// precision, whose solves are refined in double), pattern_rebuilds (times the
    /// sparsity pattern grew for new particle contacts, each a symbolic
    /// factorisation), evaluations, tangent_evaluations (counts), the wall
    /// times evaluation_seconds, contact_seconds, assembly_seconds,
    /// linear_seconds [s], max_drag_share (periodic cells: the largest
    /// stabilising drag of a step over the piston force), and wall_seconds
    /// (the time spent advancing the steps of the curve, summed across
    /// resumes from checkpoints) [s].
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let stats = self.progress().stats;
        stats_dict(py, &stats)
    }

    fn __repr__(&self) -> String {
        let progress = self.progress();
        let (step, time, rho) = progress
            .curve
            .last()
            .map_or((0, 0.0, 0.0), |p| (p.step, p.time, p.rel_density));
        format!(
            "Simulation(status='{}', step={step}, time_s={time:.6e}, rel_density={rho:.5}, nodes={}, elements={})",
            status_name(progress.status),
            self.node_count,
            self.element_count
        )
    }
}
