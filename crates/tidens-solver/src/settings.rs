//! Every solver knob in one place, with documented defaults.

use crate::error::SolverError;
use crate::load::LoadHistory;
use serde::{Deserialize, Serialize};
use tidens_contact::ContactMode;

/// Largest [`NewtonSettings::max_iterations`] accepted: a solve that needs
/// more has lost its way (the default is 25).
pub const MAX_NEWTON_ITERATIONS: usize = 1000;

/// Newton iteration settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NewtonSettings {
    /// Iterations of one Newton solve before a step is cut back (default
    /// 25); each update of the contact multipliers starts a new solve.
    pub max_iterations: usize,
    /// Converged when every residual entry (nodal force, and the piston's
    /// force balance) is below this fraction of the applied piston force
    /// (default 1e-4). During the ramp the force is floored at 1e-3 of its
    /// final value, so the unloaded start has an absolute tolerance. The
    /// default was measured against 1e-6 and 1e-7: the times to density of
    /// the sc cell (levels 1 and 3) and of bcc (level 1) move by less than
    /// 0.15 %, with 25 to 40 % fewer Newton iterations.
    pub residual_tolerance: f64,
    /// Start each step from the displacement extrapolated from the previous
    /// two steps (default true).
    pub extrapolate: bool,
    /// Factorise the consistent tangent (true) or, by default, a positive
    /// definite one that leaves out the indefinite initial-stress parts
    /// where they would dominate: the particle contacts' curvature part
    /// (`ContactSettings::curvature_stiffness`) and the elements'
    /// volumetric initial-stress term beyond a pressure of 10 f sigma
    /// (`Body::set_tangent_pressure_cap`). The residual, and so the
    /// solution, is the same either way; the consistent tangent is for tests
    /// of the derivatives.
    pub consistent_tangent: bool,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            max_iterations: 25,
            residual_tolerance: 1e-4,
            extrapolate: true,
            consistent_tangent: false,
        }
    }
}

/// Contact settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactOptions {
    /// Between particles: frictionless sliding (default) or tied once closed.
    pub mode: ContactMode,
    /// Sensitivity option, not the default: tie surface nodes that touch a
    /// rigid plane of the die (no tangential sliding on the wall).
    pub tied_planes: bool,
    /// Penalty stiffness as a multiple of E / h, h the mean surface element
    /// size (default 10), at most 1e6 f sigma / h (which a stiff material,
    /// E/sigma above 1e5, reaches); the augmented Lagrangian removes its
    /// effect on the result down to the penetration tolerance.
    pub penalty_factor: f64,
    /// Largest penetration allowed in a converged step, as a fraction of the
    /// largest particle radius R (default 1e-4 as required; solved to 0.5e-4).
    pub penetration_tolerance: f64,
    /// The master facets of hexahedral particles' surfaces: flat triangles
    /// (default) or bilinear patches.
    #[serde(default)]
    pub hex_facets: HexFacets,
    /// How particle contact is enforced: node to facet, or mortar.
    #[serde(default)]
    pub formulation: ContactFormulation,
}

/// The discretisation of particle contact.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ContactFormulation {
    /// Each slave node against the master facet it projects on (penalty
    /// and augmented Lagrangian on its penetration; see `tidens_contact`).
    #[default]
    NodeToFacet,
    /// Weighted gaps integrated over the slave surface against the master
    /// surface, segment by segment (`tidens_contact::mortar`): forces
    /// vary smoothly as nodes slide, and the contact patch test is passed.
    /// Frictionless only. The facets of a hexahedral particle follow
    /// `hex_facets`: on the flat triangles (the default) the segments'
    /// integrals are exact and Newton converges to round-off; on bilinear
    /// faces the quadrature of each segment is not, and its error changes
    /// where segments change shape (at coinciding nodes of symmetric
    /// meshes): bcc at level 1 stalled at 1.7e-6 of the piston force.
    Mortar,
}

/// The master facets a node of another particle is measured against, on
/// the surface of a hexahedral mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum HexFacets {
    /// Each boundary quad's two flat triangles, split along its shorter
    /// diagonal (`ContactSurface::from_quads_as_triangles`): the surface
    /// parry searches, with one closest point per facet. The bilinear
    /// patches of the slender tips of the sc2 cell's particles of c/a = 5
    /// warp as they deform until they part from their triangles, and that
    /// case failed at mesh levels 2 and 3 (rho = 0.865 and 0.817); on the
    /// triangles it reaches 0.9 at level 2, with the density monotone (at
    /// level 3 it stalls at 0.835).
    #[default]
    Triangles,
    /// Each boundary quad's bilinear patch, the face of its element
    /// (`ContactSurface::from_quads`): Newton on the closest-point
    /// conditions, which a warped patch satisfies at several points.
    Bilinear,
}

impl Default for ContactOptions {
    fn default() -> Self {
        Self {
            mode: ContactMode::Frictionless,
            tied_planes: false,
            penalty_factor: 10.0,
            penetration_tolerance: 1e-4,
            hex_facets: HexFacets::Triangles,
            formulation: ContactFormulation::NodeToFacet,
        }
    }
}

/// Time stepping and stop conditions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    pub load: LoadHistory,
    /// Stop when the relative density reaches this value.
    pub until_density: Option<f64>,
    /// Stop at this time \[s\].
    pub until_time: Option<f64>,
    /// Time-integration accuracy: the target relative error of the times
    /// t(rho) from the backward-Euler steps (default 0.02). Each step's error
    /// estimate, half the step times the change of the log of the
    /// densification rate over it, weighted by the load factor to the n, is
    /// held below `tolerance` times the step (the change measured over the
    /// last few steps, so that the jumps of the rate when a node touches a
    /// plane steer the step by their trend).
    pub tolerance: f64,
    /// Largest equivalent plastic strain increment allowed at any Gauss point
    /// in one step (default 0.2): a robustness limit for Newton.
    pub max_strain_increment: f64,
    /// First time step \[s\]; by default 1/50 of the ramp, and at most 1e-4 of
    /// the time for unit creep strain at the applied stress.
    pub dt_initial: Option<f64>,
    /// Largest time step \[s\] (default unbounded).
    pub dt_max: f64,
    /// Smallest time step \[s\] before giving up (default 1e-12 of the initial).
    pub dt_min: Option<f64>,
    /// Step limit (default 100000).
    pub max_steps: usize,
    /// Every this many steps (default 50) the run forgets what it keeps
    /// only for speed (the factor of the tangent, the sparsity pattern grown
    /// for particle contacts), so that a run resumed from a checkpoint taken
    /// there goes on bit for bit like the run that wrote it; 0 never. It
    /// perturbs a run at round-off level (to rho = 0.95 at 15 MPa: sc level
    /// 3 281 steps either way, bcc level 2 292 against 294, fcc level 2 227
    /// against 240, the times within 0.2 %).
    #[serde(default = "checkpoint_every_default")]
    pub checkpoint_every: usize,
    /// Times at which a step must end (e.g. snapshot times) \[s\].
    pub time_targets: Vec<f64>,
    pub newton: NewtonSettings,
    pub contact: ContactOptions,
}

fn checkpoint_every_default() -> usize {
    50
}

/// The allowed range of E / (f sigma), see [`Settings::validate_for`].
pub const STIFFNESS_RATIO_RANGE: (f64, f64) = (1e2, 1e9);

impl Settings {
    /// Settings with defaults for a load history.
    pub fn new(load: LoadHistory) -> Self {
        Self {
            load,
            until_density: None,
            until_time: None,
            tolerance: 0.02,
            max_strain_increment: 0.2,
            dt_initial: None,
            dt_max: f64::INFINITY,
            dt_min: None,
            max_steps: 100_000,
            checkpoint_every: checkpoint_every_default(),
            time_targets: Vec::new(),
            newton: NewtonSettings::default(),
            contact: ContactOptions::default(),
        }
    }

    /// Checks that `material` is stiff enough, and not too stiff, for the
    /// load: E over the stress the cell feels (f sigma) in
    /// [`STIFFNESS_RATIO_RANGE`]. Below it the elastic strains reach a
    /// per cent and more, and the curve measures an elastic collapse of the
    /// packing rather than its creep; above it the stress is so small next
    /// to E that densification would take longer than any process (and the
    /// elastic and creep time scales are too far apart for the steps).
    pub fn validate_for(&self, material: &tidens_material::Material) -> Result<(), SolverError> {
        let ratio = material.young / (self.load.stress * self.load.knockdown);
        let (lo, hi) = STIFFNESS_RATIO_RANGE;
        require(
            "young_mpa/stress",
            ratio,
            (lo..=hi).contains(&ratio),
            "in [1e2, 1e9] (E over the stress the cell feels, f sigma): below, the \
             elastic strains pass 1 % and the curve is an elastic collapse, not creep; \
             above, the stress is too small next to E for densification to matter",
        )
    }

    /// Checks every value against its allowed range.
    pub fn validate(&self) -> Result<(), SolverError> {
        let l = &self.load;
        require(
            "stress",
            l.stress,
            l.stress > 0.0 && l.stress <= 1e4,
            "in (0, 1e4] MPa",
        )?;
        require(
            "knockdown",
            l.knockdown,
            l.knockdown > 0.0 && l.knockdown <= 1.0,
            "in (0, 1]",
        )?;
        require(
            "ramp_time",
            l.ramp_time,
            l.ramp_time >= 0.0 && l.ramp_time.is_finite(),
            ">= 0 s",
        )?;
        if self.until_density.is_none() && self.until_time.is_none() {
            return Err(SolverError::parameter(
                "until_density",
                f64::NAN,
                "given (in (rho0, 1)), or until_time given (> 0 s)",
            ));
        }
        if let Some(r) = self.until_density {
            require("until_density", r, r > 0.0 && r < 1.0, "in (rho0, 1)")?;
        }
        if let Some(t) = self.until_time {
            require(
                "until_time",
                t,
                t > 0.0 && t.is_finite(),
                "> 0 s and finite",
            )?;
        }
        let tol = self.tolerance;
        require(
            "tolerance",
            tol,
            (1e-6..=0.5).contains(&tol),
            "in [1e-6, 0.5]",
        )?;
        let dp = self.max_strain_increment;
        require(
            "max_strain_increment",
            dp,
            dp > 0.0 && dp <= 2.0,
            "in (0, 2]",
        )?;
        if let Some(dt) = self.dt_initial {
            require("dt_initial", dt, dt > 0.0 && dt.is_finite(), "> 0 s")?;
        }
        require("dt_max", self.dt_max, self.dt_max > 0.0, "> 0 s")?;
        if let Some(dt) = self.dt_min {
            require("dt_min", dt, dt > 0.0 && dt.is_finite(), "> 0 s")?;
        }
        require(
            "max_steps",
            self.max_steps as f64,
            self.max_steps >= 1,
            ">= 1",
        )?;
        if let Some(t) = self
            .time_targets
            .iter()
            .find(|t| !(t.is_finite() && **t > 0.0))
        {
            return Err(SolverError::parameter(
                "time_targets",
                *t,
                "all > 0 s and finite",
            ));
        }
        let nw = &self.newton;
        let it = nw.max_iterations;
        require(
            "newton.max_iterations",
            it as f64,
            (1..=MAX_NEWTON_ITERATIONS).contains(&it),
            "in [1, 1000]",
        )?;
        let rt = nw.residual_tolerance;
        require(
            "newton.residual_tolerance",
            rt,
            (1e-14..=1e-2).contains(&rt),
            "in [1e-14, 1e-2]",
        )?;
        let c = &self.contact;
        let pf = c.penalty_factor;
        require(
            "contact.penalty_factor",
            pf,
            (0.01..=1e4).contains(&pf),
            "in [0.01, 1e4]",
        )?;
        let pt = c.penetration_tolerance;
        require(
            "contact.penetration_tolerance",
            pt,
            (1e-8..=1e-2).contains(&pt),
            "in [1e-8, 1e-2] (fraction of R)",
        )?;
        Ok(())
    }
}

/// `Ok` when `ok`, else the parameter error naming `name` and its range
/// (NaN fails every range check written as a comparison).
fn require(name: &'static str, value: f64, ok: bool, allowed: &str) -> Result<(), SolverError> {
    if ok {
        Ok(())
    } else {
        Err(SolverError::parameter(name, value, allowed))
    }
}
