//! Newton's method for one backward-Euler step, with the contact active set
//! of the rigid planes, the particle-contact pairing and multipliers, and a
//! factor of the tangent reused while it serves (modified Newton).
//!
//! The unknowns are the free body dofs and the piston displacement U. The
//! residual is the internal force (elements and particle contact) gathered
//! into equations, plus the piston's load `F(t)` in its equation (the load
//! potential is `F U`). A step has converged when every entry is below
//! `residual_tolerance` times the piston force, no node lies inside a
//! plane, every node that touches another particle is paired, and the
//! particle penetration is below its tolerance.

use crate::error::{LinearError, StepFailure};
use crate::evaluation::Evaluation;
use crate::line_search::{self, Trial};
use crate::simulation::Simulation;
use tidens_contact::ContactEvaluation;
use tidens_fem::DOF_DROPPED;

/// Active-set updates of the rigid planes allowed in one step.
const MAX_ACTIVE_SET_UPDATES: usize = 50;

/// Augmented-Lagrangian updates of the particle-contact multipliers allowed
/// in one step. Each update starts a Newton solve with its own
/// `max_iterations`: the updates converge linearly, and a step that needs
/// several of them needs them at any step size (they correct the
/// multipliers, not the creep of the step). Counted together, eight updates
/// of three or four iterations each exceeded the limit of one solve, and
/// bcc at E/sigma = 1e2 (level 3, during the ramp) cut its step from 2e-2
/// to 2e-14 s and failed.
const MAX_AUGMENTATIONS: usize = 30;

/// A factor computed for a step this many times longer or shorter than the
/// coming one is replaced by the tangent at the predictor: with the viscous
/// stiffness scaling with the step, an older factor contracts too slowly
/// (measured on the sc cell: a quarter fewer Newton iterations and
/// evaluations than reusing it until Newton slows down).
const FRESH_TANGENT_STEP_RATIO: f64 = 1.25;

/// The pressure in the elements' volumetric initial-stress stiffness is
/// limited to this many times the stress the cell feels (f sigma) in the
/// factorised tangent (`Body::set_tangent_pressure_cap`). At a solution the
/// pressures are a few times f sigma, so the tangent there is exact; but
/// the extrapolated predictor of a stiff material (E/sigma = 1e7) carries
/// transient pressures of 1e3-1e4 f sigma, with which the tangent is
/// indefinite and Newton crawls (sc at level 1, E/sigma = 1e7: 1708 Newton
/// iterations, 620 of 1232 factorisations indefinite and 16 failed attempts;
/// with the cap 928, none and 1; the base case 367 against 370).
pub(crate) const TANGENT_PRESSURE_CAP: f64 = 10.0;

/// The weights of the last three states (`[now, one step back, two steps
/// back]`) in the value at `h` after the last, on the parabola through
/// them, `h1` and `h2` the last two steps' lengths (Lagrange extrapolation;
/// the weights sum to one).
fn quadratic_weights(h: f64, h1: f64, h2: f64) -> [f64; 3] {
    [
        (h + h1) * (h + h1 + h2) / (h1 * (h1 + h2)),
        -h * (h + h1 + h2) / (h1 * h2),
        h * (h + h1) / ((h1 + h2) * h2),
    ]
}

/// A converged Newton solve of one step.
pub(crate) struct Solved {
    pub u: Vec<f64>,
    pub piston: f64,
    pub eval: Evaluation,
    pub iterations: usize,
}

/// A failed Newton solve.
pub(crate) struct Failed {
    pub reason: StepFailure,
    pub iterations: usize,
}

/// A slave node of one surface pressed onto a facet of another: the
/// tangent of a factor reused across iterations must have every such link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ContactLink {
    /// Slave surface and node index in it.
    slave: (usize, usize),
    /// Master surface and facet.
    master: (usize, usize),
}

/// What the current factor of the tangent was computed for: the equation
/// map (the contact state of the planes) and the pressed particle-contact
/// links. The factor may be reused while both are unchanged.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FactorKey {
    map: Vec<usize>,
    links: Vec<ContactLink>,
    /// The time step of the tangent \[s\].
    dt: f64,
}

/// The pressed contact links of `contact`.
fn links(contact: &ContactEvaluation) -> Vec<ContactLink> {
    contact
        .terms
        .iter()
        .filter(|t| t.pressure > 0.0)
        .map(|t| ContactLink {
            slave: t.slave,
            master: t.master,
        })
        .collect()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Prints the pressed contact links that appeared or went since the last
/// call (debugging output, `TIDENS_DEBUG`).
fn debug_link_changes(
    prev: &mut Vec<(ContactLink, f64, f64, [f64; 2])>,
    contact: &ContactEvaluation,
    measure: impl Fn(ContactLink) -> ([f64; 2], f64),
) {
    let all: Vec<(ContactLink, f64, f64, [f64; 2])> = contact
        .terms
        .iter()
        .map(|t| {
            (
                ContactLink {
                    slave: t.slave,
                    master: t.master,
                },
                t.pressure,
                t.penetration,
                t.location,
            )
        })
        .collect();
    let now: Vec<(ContactLink, f64, f64, [f64; 2])> =
        all.iter().filter(|a| a.1 > 0.0).cloned().collect();
    for n in &now {
        if !prev.iter().any(|p| p.0 == n.0) {
            eprintln!(
                "      + pressed {:?} p {:.3e} pen {:.3e} xi {:?}",
                n.0, n.1, n.2, n.3
            );
        }
    }
    for p in prev.iter() {
        if !now.iter().any(|n| n.0 == p.0) {
            let there = all.iter().find(|a| a.0.slave == p.0.slave);
            eprintln!(
                "      - released {:?} (was p {:.3e}) now {:?}, measured on the facet {:?}",
                p.0,
                p.1,
                there.map(|a| (a.0.master, a.1, a.2, a.3)),
                measure(p.0)
            );
        }
    }
    *prev = now;
}

pub(crate) fn debug_enabled() -> bool {
    std::env::var_os("TIDENS_DEBUG").is_some()
}

/// Displacements and the evaluation at a trial point of the line search.
struct TrialPoint {
    u: Vec<f64>,
    piston: f64,
    eval: Evaluation,
}

/// Where along a Newton direction the first particle contact closes that
/// the direction does not see.
///
/// A contact open at the iterate brings no stiffness to the tangent, and
/// the direction can carry it deep into the other particle; the full step's
/// residual then rises, the quadratic model cuts the step to a tenth, and
/// the next direction, from the same contact set, aims at the same point
/// again: Newton creeps towards it by tenths until the contact closes. On
/// eight random spheres at level 1 (seed 1, t = 0.807 s), nodes open by
/// 5e-5 to 1.1e-4 mm at the iterate lay up to 1.1e-4 mm deep at the full
/// step, eleven iterations in a row took a tenth of their direction, and
/// the residual fell by a tenth each. The step is cut instead to where the
/// first such contact reaches the penetration tolerance (each term's
/// penetration taken linear along the direction), so that the next
/// tangent holds it.
struct Closing<'a> {
    /// The contact terms at the iterate.
    at_iterate: &'a tidens_contact::ContactEvaluation,
    /// The penetration of a term not evaluated at the iterate (its node
    /// farther from the facet than the contact band) \[mm\]: the band's
    /// edge, which makes its closing step come early rather than late.
    unknown: f64,
    /// The penetration at which a contact counts as closed \[mm\].
    allowed: f64,
}

impl Closing<'_> {
    /// The fraction of the direction at which the first term deeper than
    /// `allowed` at its end (`at_end`, the full step's contact) and not
    /// at the iterate reaches `allowed` (asked only where the full step
    /// failed, so the iterate's terms are looked up only then).
    fn first_closure(&self, at_end: &tidens_contact::ContactEvaluation) -> Option<f64> {
        let key = |t: &tidens_contact::ContactTerm| (t.slave, t.master, t.fold.map(|f| f.0));
        let start: std::collections::HashMap<_, f64> = self
            .at_iterate
            .terms
            .iter()
            .map(|t| (key(t), t.penetration))
            .collect();
        at_end
            .terms
            .iter()
            .filter(|t| t.penetration > self.allowed)
            .filter_map(|t| {
                let start = start.get(&key(t)).copied().unwrap_or(self.unknown);
                (start < self.allowed).then(|| (self.allowed - start) / (t.penetration - start))
            })
            .min_by(f64::total_cmp)
    }
}

impl Simulation {
    /// Global residual: internal forces gathered into equations, plus the
    /// piston's load term `force` \[N\].
    fn residual(&self, f_int: &[f64], map: &[usize], force: f64) -> Vec<f64> {
        let n = self.constraints.dof_count();
        let mut r = vec![0.0; n + 1];
        for (d, &m) in map.iter().enumerate() {
            if m != DOF_DROPPED {
                r[m] += f_int[d];
            }
        }
        // The z force on a periodic image above or below the cell also
        // pulls on the cell's height.
        if self.constraints.has_piston_coupling() {
            for (d, f) in f_int.iter().enumerate() {
                r[n] += self.constraints.piston_coupling(d) * f;
            }
        }
        r[n] += force;
        r
    }

    /// The first guess of a step of `dt` \[s\]: the displacement extrapolated
    /// linearly from the last two states (the last state until there are
    /// two). On creep flow it is far closer to the solution than the last
    /// state (even where stiff elasticity makes its residual larger).
    fn predict(&self, dt: f64) -> (Vec<f64>, f64) {
        let state = &self.state;
        let mut u = state.u.clone();
        let mut piston = state.piston;
        if self.settings.newton.extrapolate
            && let Some(prev) = &state.previous
        {
            let ratio = dt / prev.dt;
            for (x, x1) in u.iter_mut().zip(&prev.u) {
                *x += ratio * (*x - x1);
            }
            piston += ratio * (piston - prev.piston);
        }
        self.constraints.enforce(&mut u, piston);
        (u, piston)
    }

    /// The guess of a step of `dt` \[s\] on the parabola through the last
    /// three states; None until there are three (or without extrapolation).
    fn predict_quadratic(&self, dt: f64) -> Option<(Vec<f64>, f64)> {
        let state = &self.state;
        let (Some(prev), Some(earlier)) = (&state.previous, &state.earlier) else {
            return None;
        };
        if !self.settings.newton.extrapolate {
            return None;
        }
        let [w0, w1, w2] = quadratic_weights(dt, prev.dt, earlier.dt);
        let mut u: Vec<f64> = state
            .u
            .iter()
            .zip(&prev.u)
            .zip(&earlier.u)
            .map(|((x, x1), x2)| w0 * x + w1 * x1 + w2 * x2)
            .collect();
        let piston = w0 * state.piston + w1 * prev.piston + w2 * earlier.piston;
        self.constraints.enforce(&mut u, piston);
        Some((u, piston))
    }

    /// The predictor of a step of `dt` \[s\]: the linear extrapolation, or,
    /// in a scene without particle contact, the quadratic one where its
    /// residual is the smaller.
    ///
    /// Creep flow is isochoric, but the linear extrapolation of its node
    /// displacements is not: it changes each element's volume at second order
    /// in the step's strain, and a stiff material (E/sigma = 1e7, or 4e7 at
    /// 1e-3 MPa) turns that into transient pressures of 1e3-1e4 f sigma at the
    /// predictor. Measured on sc at level 1 and 1e-3 MPa: the predictor's
    /// residual was 600 times the piston force, the full Newton step from it
    /// raised the pressure to 4e5 f sigma, and Newton crawled on tenth steps of
    /// the line search for three or four iterations of each creep step (6-15
    /// iterations a step against 2 in the base case). The parabola through the
    /// last three states follows the flow to third order, and its residual was
    /// mostly ten times smaller; but where a step's length or the plane
    /// contacts change it can be the worse guess, so the step starts from
    /// whichever of the two has the smaller residual (both are evaluated,
    /// and the chosen one's evaluation starts Newton: one more evaluation a
    /// step, two where the step needs a fresh tangent at its guess). Newton
    /// iterations to rho = 0.9 with the choice, against the linear predictor
    /// alone, sc at level 3: 1e-3 MPa 1051 against 1357, E/sigma = 1e7 952
    /// against 1189, the base 372 against 398. Where particles touch,
    /// the residual of a guess says little of its distance to the solution
    /// (a penetration is a large force, a gap none), and the same choice cost
    /// sc2's base case at level 1 562 Newton iterations against 383 (551
    /// with the contact forces left out of the comparison): those scenes
    /// keep the linear predictor (as do periodic cells, whose drag is set up
    /// from the guess after it is chosen).
    ///
    /// Returns the guess, and its evaluation (without tangent) where one
    /// was made for the choice, for the Newton solve to start from.
    fn choose_predictor(&mut self, dt: f64, force: f64) -> (Vec<f64>, f64, Option<Evaluation>) {
        let linear = self.predict(dt);
        if self.contact.is_some() || self.stabilisation.is_some() {
            return (linear.0, linear.1, None);
        }
        let Some(quadratic) = self.predict_quadratic(dt) else {
            return (linear.0, linear.1, None);
        };
        let map = self.constraints.equation_map();
        let mut judge = |u: &[f64]| match self.evaluate(u, dt, false) {
            Ok(e) => (max_abs(&self.residual(&e.f_int, &map, force)), Some(e)),
            Err(_) => (f64::INFINITY, None),
        };
        let (r_linear, e_linear) = judge(&linear.0);
        let (r_quadratic, e_quadratic) = judge(&quadratic.0);
        if debug_enabled() {
            eprintln!("    predictors: |R| linear {r_linear:.3e}, quadratic {r_quadratic:.3e}");
        }
        if r_quadratic < r_linear {
            (quadratic.0, quadratic.1, e_quadratic)
        } else {
            (linear.0, linear.1, e_linear)
        }
    }

    /// Prints the largest body entry of a Newton direction `du`, its node's
    /// position at `u`, and the piston's entry (debugging output,
    /// `TIDENS_DEBUG`).
    fn debug_direction(&self, u: &[f64], du: &[f64], map: &[usize]) {
        let n = self.constraints.dof_count();
        let (big, at) = (0..n)
            .filter(|&d| map[d] == d)
            .map(|d| (du[d].abs(), d))
            .fold((0.0, 0), |b, c| if c.0 > b.0 { c } else { b });
        let x = self.current_coordinates(u);
        let node = at / 3;
        eprintln!(
            "      direction: max |du| {big:.3e} at dof {at} (node {node} at {:?}), piston {:.3e}",
            &x[3 * node..3 * node + 3],
            du[n]
        );
    }

    /// The Newton direction for residual `r` with the factorised tangent of
    /// `eval`: nodes just caught by a plane (`offsets`) go onto it.
    fn direction(
        &mut self,
        eval: &Evaluation,
        r: &[f64],
        map: &[usize],
        offsets: &[(usize, f64)],
    ) -> Result<Vec<f64>, LinearError> {
        let mut du: Vec<f64> = r.iter().map(|x| -x).collect();
        if !offsets.is_empty() {
            // The linearised effect of the offsets: minus the tangent
            // times them, gathered like the residual.
            let lift = self.assembler.tangent_times(eval, offsets);
            for (d, &m) in map.iter().enumerate() {
                if m != DOF_DROPPED {
                    du[m] -= lift[d];
                }
            }
        }
        let t0 = std::time::Instant::now();
        let solved = self.linear.solve(&mut du);
        self.stats.linear_seconds += t0.elapsed().as_secs_f64();
        solved.map(|_| du)
    }

    /// The displacement and piston `s` of the way along the direction `du`
    /// (over the free equations and the piston, `du[n]`) from `(u, piston)`,
    /// with the planes' constraints enforced.
    fn point_along(
        &self,
        u: &[f64],
        piston: f64,
        du: &[f64],
        map: &[usize],
        s: f64,
    ) -> (Vec<f64>, f64) {
        let n = self.constraints.dof_count();
        let mut ut = u.to_vec();
        for d in 0..n {
            if map[d] == d {
                ut[d] += s * du[d];
            }
        }
        let pt = piston + s * du[n];
        self.constraints.enforce(&mut ut, pt);
        (ut, pt)
    }

    /// The point `s` of the way along the direction `du` from `(u, piston)`
    /// (planes enforced), evaluated: its squared residual norm, largest
    /// residual entry, and the point; None where it cannot be evaluated.
    #[allow(clippy::too_many_arguments)]
    fn try_step(
        &mut self,
        u: &[f64],
        piston: f64,
        du: &[f64],
        map: &[usize],
        offsets: &[(usize, f64)],
        dt: f64,
        force: f64,
        s: f64,
    ) -> Option<(f64, f64, TrialPoint)> {
        let (mut ut, pt) = self.point_along(u, piston, du, map, s);
        // A node just caught by a plane goes the same fraction of its way
        // onto it as the rest of the step: putting it right on the plane
        // while its neighbours move part of the way would strain the
        // elements around it out of all proportion.
        for &(d, _) in offsets {
            ut[d] = u[d] + s * (ut[d] - u[d]);
        }
        let ev = self.evaluate(&ut, dt, false).ok()?;
        let rt = self.residual(&ev.f_int, map, force);
        let norm_sq = rt.iter().map(|x| x * x).sum();
        if debug_enabled() {
            let f = ev.body.fields();
            let p = f.mean_stress.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let q = f.von_mises.iter().fold(0.0f64, |a, b| a.max(*b));
            let worst = (0..rt.len()).max_by(|&a, &b| rt[a].abs().total_cmp(&rt[b].abs()));
            let pressed = ev.contact.terms.iter().filter(|t| t.pressure > 0.0).count();
            let deep = ev
                .contact
                .terms
                .iter()
                .filter(|t| t.penetration > 1e-5)
                .count();
            let fmax = ev
                .contact
                .terms
                .iter()
                .map(|t| t.pressure)
                .fold(0.0f64, f64::max);
            eprintln!(
                "        trial {s:.3}: |R| {:.3e} at {worst:?}, largest plastic strain increment {:.3e}, |p| up to {p:.3e} MPa, q up to {q:.3e} MPa; contact terms pressed {pressed}, deeper than 1e-5 mm {deep}, largest pressure {fmax:.3e} MPa, max penetration {:.3e}",
                max_abs(&rt),
                ev.body.max_dp(),
                ev.contact.max_penetration()
            );
        }
        Some((
            norm_sq,
            max_abs(&rt),
            TrialPoint {
                u: ut,
                piston: pt,
                eval: ev,
            },
        ))
    }

    /// Assembles the tangent of `eval` (growing the pattern for new contact
    /// couplings) and factorises it.
    fn refactor(&mut self, eval: &Evaluation, map: &[usize], dt: f64) -> Result<(), LinearError> {
        let t0 = std::time::Instant::now();
        self.assemble_grown(eval, map)?;
        let t1 = std::time::Instant::now();
        self.stats.assembly_seconds += (t1 - t0).as_secs_f64();
        let factorized = self.linear.factorize(self.assembler.system());
        self.stats.linear_seconds += t1.elapsed().as_secs_f64();
        match factorized {
            Ok(_) => {
                self.factor = Some(FactorKey {
                    map: map.to_vec(),
                    links: links(&eval.contact),
                    dt,
                });
                Ok(())
            }
            Err(e) => {
                self.factor = None;
                Err(e)
            }
        }
    }

    /// Newton with line search for the step to `time + dt`.
    ///
    /// The factor of the tangent is kept across iterations and steps while
    /// the equation map (the contact state) and the pressed contact links
    /// are unchanged and Newton contracts the residual fast enough with it
    /// (modified Newton); otherwise the tangent is assembled and factorised
    /// afresh. The tangent is computed only in evaluations that may need it.
    ///
    /// `interrupted` is asked before each Newton iteration; when it answers
    /// true the solve ends with [`StepFailure::Interrupted`].
    pub(crate) fn solve_step(
        &mut self,
        dt: f64,
        interrupted: &mut dyn FnMut() -> bool,
    ) -> Result<Solved, Failed> {
        let t1 = self.state.time + dt;
        let force = self.full_force * self.settings.load.factor(t1);
        let tol = self.settings.newton.residual_tolerance * force.max(1e-3 * self.full_force);
        let gap_tol = 1e-8 * self.lengths.iter().cloned().fold(0.0, f64::max);
        let n = self.constraints.dof_count();
        self.constraints.reset_flips();
        let fail = |reason: StepFailure, iterations: usize| Failed { reason, iterations };
        let (mut u, mut piston, judged) = self.choose_predictor(dt, force);
        if let Some(st) = &mut self.stabilisation {
            // The drag of the step is measured from the affine motion the
            // predictor expects, and scaled by its strain increment.
            let lift = piston - self.state.piston;
            for (d, r) in st.reference.iter_mut().enumerate() {
                *r = self.state.u[d] + st.height_fraction[d] * lift;
            }
            let load = &self.settings.load;
            let stress = load.knockdown * load.stress * load.factor(t1);
            let elastic = load.knockdown
                * load.stress
                * (load.factor(t1) - load.factor(self.state.time)).abs()
                / self.body.material().young;
            let strain = (lift.abs() / (self.lengths[2] + self.state.piston)).max(elastic);
            st.stiffness = if strain > 0.0 {
                st.scale * stress / strain
            } else {
                0.0
            };
            let nodes = self.body.nodes();
            for frame in &mut st.frames {
                let reference = &st.reference;
                frame.place(|n| {
                    nalgebra::Vector3::from_fn(|i, _| nodes[n][i] + reference[3 * n + i])
                });
            }
            // Nothing holds a particle of a periodic cell off a contact
            // that has not closed yet: the touch stiffness is a force too,
            // so that the cell carries the load before its contacts close
            // (the step's spring moves a node a fiftieth of an element
            // against the stress the cell feels now).
            if let Some(c) = self.contact.as_mut() {
                let h = c.settings().search_distance;
                c.set_touch_force(Some(crate::simulation::TOUCH_STIFFNESS_CAP * stress / h));
            }
        }
        if debug_enabled() {
            eprintln!("  step from t = {:.6e} s, dt = {dt:.4e} s", self.state.time);
        }
        // Particle contact keeps each node's master facet for the whole step.
        self.pair_contacts(&u, false);
        if debug_enabled()
            && let Some(c) = &self.contact
        {
            let deepest = |x: &[f64]| {
                c.evaluate(x, false)
                    .terms
                    .into_iter()
                    .max_by(|a, b| a.penetration.total_cmp(&b.penetration))
                    .map(|t| (t.penetration, t.slave, t.master, t.location))
            };
            eprintln!(
                "    pairs: deepest at the last state {:?}, at the predictor {:?}",
                deepest(&self.current_coordinates(&self.state.u)),
                deepest(&self.current_coordinates(&u))
            );
        }
        // The viscous part of the tangent scales with the step: a factor
        // from a step of another size contracts slowly, so the tangent is
        // computed at the predictor right away.
        let stale = self
            .factor
            .as_ref()
            .is_none_or(|k| (dt / k.dt).ln().abs() > FRESH_TANGENT_STEP_RATIO.ln());
        // The predictor's choice evaluated the guess already; a stale factor
        // needs the tangent there, which that evaluation did not compute.
        let mut eval = match judged {
            Some(e) if !stale => e,
            _ => self
                .evaluate(&u, dt, stale)
                .map_err(|e| fail(e.into(), 0))?,
        };
        let mut refactor = stale || !self.linear.has_factor();
        let mut iterations = 0;
        // Iterations when the multipliers were last updated: each update
        // poses a new equilibrium, whose solve has its own iteration limit.
        let mut solve_start = 0;
        let mut active_set_updates = 0;
        let mut augmentations = 0;
        // Whether the iterate `u` was paired afresh after the line search
        // found it (the predictor was paired at the step's start).
        let mut relinked = false;
        let mut debug_pressed: Vec<(ContactLink, f64, f64, [f64; 2])> = Vec::new();
        loop {
            if interrupted() {
                return Err(fail(StepFailure::Interrupted, iterations));
            }
            let mut map = self.constraints.equation_map();
            let mut r = self.residual(&eval.f_int, &map, force);
            // Contact: catch penetrating nodes at once; release tensile
            // contacts only where the iterate is in equilibrium for the
            // present contact set. Away from it the reactions say little: on
            // stiff materials (E/sigma 1e7, nu 0.499) a node pushed through
            // the piston by one iteration reads as tensile at the next, is
            // released, goes through again, and the set chatters until the
            // step fails (measured: sc at E/sigma = 1e7, 66 failed attempts).
            let settled = max_abs(&r) <= tol;
            if active_set_updates < MAX_ACTIVE_SET_UPDATES
                && self
                    .constraints
                    .update(&u, piston, &eval.f_int, tol, gap_tol, settled)
                    > 0
            {
                active_set_updates += 1;
                map = self.constraints.equation_map();
                r = self.residual(&eval.f_int, &map, force);
            }
            // Nodes that have just come into contact are still off their
            // plane: the next solve moves them onto it.
            let offsets = self.constraints.offsets(&u, piston);
            let r_norm = max_abs(&r);
            if debug_enabled() {
                let x = self.current_coordinates(&u);
                let c = self.contact.as_ref();
                debug_link_changes(&mut debug_pressed, &eval.contact, |l| {
                    c.map_or(([0.0; 2], 0.0), |c| {
                        c.measure_on(&x, l.slave.0, l.slave.1, l.master.0, l.master.1)
                    })
                });
                let worst = (0..r.len()).max_by(|&a, &b| r[a].abs().total_cmp(&r[b].abs()));
                eprintln!(
                    "    it {iterations} |R| {r_norm:.3e} tol {tol:.3e} refactor {refactor} planes {:?} particle contacts {} penetration {:.2e}; largest at equation {worst:?} (the piston's is {n})",
                    self.constraints.contact_counts(),
                    eval.contact.terms.len(),
                    eval.contact.max_penetration()
                );
                if let Some(t) = eval
                    .contact
                    .terms
                    .iter()
                    .max_by(|a, b| a.penetration.total_cmp(&b.penetration))
                {
                    eprintln!(
                        "      deepest: {:?} on {:?} at xi {:?}",
                        t.slave, t.master, t.location
                    );
                }
            }
            if !r_norm.is_finite() {
                return Err(fail(StepFailure::NonFiniteResidual, iterations));
            }
            if offsets.is_empty() && r_norm <= tol {
                let penetration = self.constraints.max_penetration(&u, piston);
                if penetration > gap_tol {
                    return Err(fail(
                        StepFailure::PlanePenetration { depth: penetration },
                        iterations,
                    ));
                }
                // Nodes that came near another particle, or slid off their
                // facet, during the step are paired afresh now; if any of
                // them touches, Newton goes on. An iterate of the line
                // search was paired afresh already (`relink_contacts`).
                if !relinked && self.pair_contacts(&u, true) > 0 {
                    eval = self.evaluate_contact_again(eval, &u);
                    continue;
                }
                // The multipliers take each converged step's pressures (see
                // `accept_or_reject`), so the penetration of a step is only
                // the pressure change over it divided by the penalty; the
                // augmentation loop here is for steps where that is too much.
                let violation = eval.contact.max_violation();
                if violation <= self.penetration_tol {
                    return Ok(Solved {
                        u,
                        piston,
                        eval,
                        iterations,
                    });
                }
                if augmentations >= MAX_AUGMENTATIONS {
                    return Err(fail(
                        StepFailure::ContactPenetration {
                            penetration: violation,
                            augmentations: MAX_AUGMENTATIONS,
                        },
                        iterations,
                    ));
                }
                augmentations += 1;
                solve_start = iterations;
                let x = self.current_coordinates(&u);
                if let Some(c) = self.contact.as_mut() {
                    c.augment(&x, &eval.contact);
                }
                eval = self.evaluate_contact_again(eval, &u);
                continue;
            }
            if iterations - solve_start >= self.settings.newton.max_iterations {
                return Err(fail(
                    StepFailure::Iterations {
                        iterations,
                        residual: r_norm,
                        tolerance: tol,
                    },
                    iterations,
                ));
            }
            iterations += 1;
            let key_changed = self
                .factor
                .as_ref()
                .is_none_or(|k| k.map != map || k.links != links(&eval.contact));
            if refactor || key_changed || !offsets.is_empty() {
                if !eval.has_tangent() {
                    eval = self
                        .evaluate(&u, dt, true)
                        .map_err(|e| fail(e.into(), iterations))?;
                }
                self.refactor(&eval, &map, dt)
                    .map_err(|e| fail(e.into(), iterations))?;
            }
            let du = self
                .direction(&eval, &r, &map, &offsets)
                .map_err(|e| fail(e.into(), iterations))?;
            if debug_enabled() {
                self.debug_direction(&u, &du, &map);
            }
            let r0_sq: f64 = r.iter().map(|x| x * x).sum();
            let closing = self.contact.as_ref().map(|c| Closing {
                at_iterate: &eval.contact,
                unknown: -c.settings().search_distance * tidens_contact::NEAR_BAND,
                allowed: self.penetration_tol,
            });
            let best = line_search::backtrack(
                r0_sq,
                tol,
                |st| self.try_step(&u, piston, &du, &map, &offsets, dt, force, st),
                |p: &TrialPoint| closing.as_ref()?.first_closure(&p.eval.contact),
            );
            let Some(Trial {
                step, norm, point, ..
            }) = best
            else {
                return Err(fail(StepFailure::LineSearch, iterations));
            };
            if debug_enabled() {
                eprintln!("      line search: step {step} |R| {norm:.3e}");
            }
            // Modified Newton pays only while it contracts fast: refactorise
            // after a slow or damped iteration.
            refactor = norm > 0.2 * r_norm || step < 1.0;
            u = point.u;
            piston = point.piston;
            eval = point.eval;
            // A node that slid past its facet's edge is paired with the
            // facet it is over now, not at convergence: kept on its old
            // facet's plane it reads past a ridge off the surface, and
            // Newton would converge to a state that holds it there, then
            // go on from it. On eight random spheres at level 1, seed 1,
            // 40 steps: 276 Newton iterations to t = 0.829 s, against 361
            // to 0.808 s pairing at convergence only.
            relinked = true;
            if self.relink_contacts(&u) {
                eval = self.evaluate_contact_again(eval, &u);
            }
        }
    }

    /// Pairs afresh, between two Newton iterations at displacement `u`,
    /// the nodes that left their facet or came near another surface;
    /// returns whether any link changed.
    fn relink_contacts(&mut self, u: &[f64]) -> bool {
        if self.contact.is_none() {
            return false;
        }
        let t0 = std::time::Instant::now();
        let x = self.current_coordinates(u);
        let changed = self.contact.as_mut().is_some_and(|c| c.relink(&x));
        self.stats.contact_seconds += t0.elapsed().as_secs_f64();
        changed
    }

    /// Pairs the surface nodes with master facets at displacement `u`: all
    /// of them at the start of a step (keeping the facets of the last step
    /// where they still fit), or at convergence (`at_convergence`) those not
    /// paired yet and those that left their facet. Returns how many newly
    /// paired nodes touch.
    fn pair_contacts(&mut self, u: &[f64], at_convergence: bool) -> usize {
        if self.contact.is_none() {
            return 0;
        }
        let t0 = std::time::Instant::now();
        let x = self.current_coordinates(u);
        let touching = match self.contact.as_mut() {
            Some(c) if at_convergence => c.repair(&x),
            Some(c) => {
                c.pair(&x);
                0
            }
            None => 0,
        };
        self.stats.contact_seconds += t0.elapsed().as_secs_f64();
        touching
    }
}

#[cfg(test)]
mod tests {
    use tidens_fem::DOF_DROPPED;

    /// A contact term of slave node `k` of surface 0 on facet `f` of
    /// surface 1, `penetration` deep \[mm\].
    fn term(k: usize, f: usize, penetration: f64) -> tidens_contact::ContactTerm {
        tidens_contact::ContactTerm {
            dofs: vec![0; tidens_contact::TERM_DOFS],
            force: vec![0.0; tidens_contact::TERM_DOFS],
            tangent: Vec::new(),
            pressure: 0.0,
            penetration,
            slave: (0, k),
            master: (1, f),
            location: [0.0; 2],
            fold: None,
        }
    }

    /// Penetrations linear along the direction: a node open by 3e-5 mm at
    /// the iterate and 9e-5 mm deep at the full step reaches 1e-5 mm at
    /// a third of the step; one pressed at both ends, or open at its end,
    /// closes nothing; one not evaluated at the iterate starts at the band.
    #[test]
    fn the_first_contact_to_close_names_the_step() {
        use super::Closing;
        let at_iterate = tidens_contact::ContactEvaluation {
            terms: vec![term(0, 0, -3e-5), term(1, 0, 2e-5), term(2, 0, -1e-4)],
        };
        let closing = Closing {
            at_iterate: &at_iterate,
            unknown: -1e-3,
            allowed: 1e-5,
        };
        let end = |terms: Vec<tidens_contact::ContactTerm>| {
            closing.first_closure(&tidens_contact::ContactEvaluation { terms })
        };
        let s = end(vec![term(0, 0, 9e-5), term(1, 0, 4e-5), term(2, 0, -5e-5)]).unwrap();
        assert!((s - 1.0 / 3.0).abs() < 1e-12, "{s}");
        assert_eq!(end(vec![term(1, 0, 4e-5), term(2, 0, -5e-5)]), None);
        let s = end(vec![term(3, 0, 2e-5 + 1e-3)]).unwrap();
        assert!((s - 0.5).abs() < 1e-12, "{s}");
        // The earliest closure of several.
        let s = end(vec![term(0, 0, 9e-5), term(3, 0, 2e-5 + 1e-3)]).unwrap();
        assert!((s - 1.0 / 3.0).abs() < 1e-12, "{s}");
    }

    /// The quadratic predictor's weights reproduce any parabola in time
    /// exactly at uneven steps (a step twice the last, the last half the
    /// one before), and sum to one; a straight line too.
    #[test]
    fn quadratic_weights_extrapolate_a_parabola_exactly() {
        use super::quadratic_weights;
        let (h2, h1, h) = (0.3, 0.15, 0.3);
        let (t2, t1, t0, t) = (0.0, h2, h2 + h1, h2 + h1 + h);
        let w = quadratic_weights(h, h1, h2);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        for f in [|t: f64| 2.0 - 3.0 * t + 5.0 * t * t, |t: f64| 0.7 * t - 1.0] {
            let p = w[0] * f(t0) + w[1] * f(t1) + w[2] * f(t2);
            assert!((p - f(t)).abs() < 1e-13, "{p} against {}", f(t));
        }
        // A cubic is not followed: the weights are those of the parabola.
        let g = |t: f64| t * t * t;
        assert!((w[0] * g(t0) + w[1] * g(t1) + w[2] * g(t2) - g(t)).abs() > 1e-3);
    }

    /// Asserts that the assembled system at `sim`'s last state for a step
    /// `dt` is the derivative of the residual: `K v` equals central
    /// differences of the residual along a smooth `v` (over the free
    /// equations and the piston) to 1e-5 of `K v`'s size. Returns the
    /// evaluation, equation map and system it checked.
    fn assert_tangent_is_the_residuals_derivative(
        sim: &mut crate::Simulation,
        dt: f64,
    ) -> (
        crate::evaluation::Evaluation,
        Vec<usize>,
        tidens_fem::SparseSystem,
    ) {
        let force = sim.full_force * sim.settings.load.factor(sim.state.time + dt);
        let (u0, piston0) = (sim.state.u.clone(), sim.state.piston);
        let x = sim.current_coordinates(&u0);
        sim.contact.as_mut().unwrap().pair(&x);
        let map = sim.constraints.equation_map();
        let eval = sim.evaluate(&u0, dt, true).unwrap();
        assert!(eval.contact.terms.iter().any(|t| t.pressure > 0.0));
        sim.assemble_grown(&eval, &map).unwrap();
        let k = sim.assembler.system().clone();
        let n = sim.constraints.dof_count();
        let v: Vec<f64> = (0..=n)
            .map(|e| {
                if e == n || map.get(e) == Some(&e) {
                    1e-4 * (0.37 * e as f64).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let kv = k.mul_vec(&v);
        let mut residual_at = |s: f64| {
            let (u, _) = sim.point_along(&u0, piston0, &v, &map, s);
            let ev = sim.evaluate(&u, dt, false).unwrap();
            sim.residual(&ev.f_int, &map, force)
        };
        let h = 1e-4;
        let (rp, rm) = (residual_at(h), residual_at(-h));
        let scale = kv.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut worst = 0.0f64;
        for e in 0..=n {
            if e < n && map[e] == DOF_DROPPED {
                continue;
            }
            let fd = (rp[e] - rm[e]) / (2.0 * h);
            worst = worst.max((fd - kv[e]).abs());
        }
        assert!(
            worst < 1e-5 * scale,
            "K v off the differences by {worst:e} (scale {scale:e})"
        );
        (eval, map, k)
    }

    /// The assembled system is the derivative of the residual: for the bcc
    /// cell during the ramp (particle contact pressed, plastic flow near the
    /// contact), `K v` equals central differences of the residual along `v`
    /// over the free equations and the piston.
    #[test]
    fn assembled_tangent_equals_finite_differences_of_the_residual() {
        let mut sim = crate::test_support::bcc_level1(|s| {
            s.until_time = Some(0.2);
            s.newton.consistent_tangent = true;
        });
        sim.run(|_| true).unwrap();
        let (eval, map, k) = assert_tangent_is_the_residuals_derivative(&mut sim, 0.05);
        // Pattern growth: an assembler built afresh holds the elements'
        // couplings only, so the contact terms do not fit; grown, it gives
        // the same system as the one the run grew step by step.
        let mut fresh = crate::assembler::Assembler::new(&sim.body, &sim.constraints);
        assert!(!fresh.assemble(&eval, &map));
        fresh.grow(
            &eval.contact,
            sim.contact.as_ref().unwrap(),
            &sim.constraints,
        );
        assert_eq!(fresh.pattern_rebuilds(), 1);
        assert!(fresh.assemble(&eval, &map));
        crate::test_support::assert_same_system(fresh.system(), &k, "grown system");
    }

    /// The same for a periodic cell, whose residual also holds the drag on
    /// each node and the hold on each particle's rotation: one sphere
    /// touching its images, during the ramp.
    #[test]
    fn a_periodic_cells_tangent_with_its_drag_and_hold_equals_finite_differences() {
        let mut sim = crate::test_support::periodic_sphere_level1(|s| {
            s.until_time = Some(0.1);
            s.newton.consistent_tangent = true;
        });
        sim.run(|_| true).unwrap();
        let (eval, _, _) = assert_tangent_is_the_residuals_derivative(&mut sim, 0.05);
        assert!(!eval.rotation_tangents.is_empty(), "the hold acts");
    }
}
