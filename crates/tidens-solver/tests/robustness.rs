//! Failed Newton attempts: cut back, restore, go on; checkpoints.

use std::sync::OnceLock;
use tidens_solver::{
    Cell, CurvePoint, LoadHistory, Material, MeshOptions, Preset, RunStats, Scene, Settings,
    Simulation, SolverError, Status, StepFailure,
};

/// `cell` meshed at level 1.
fn level1(cell: Cell) -> Scene {
    let options = MeshOptions {
        level: 1,
        ..MeshOptions::default()
    };
    Scene::from_cell(&cell, &options).unwrap()
}

/// Settings for `stress` \[MPa\] ramped over 1 s, to density `until`.
fn pressed(stress: f64, until: f64) -> Settings {
    let mut settings = Settings::new(LoadHistory {
        stress,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(until);
    settings
}

/// The bcc cell at level 1 pressed to `until` with a Newton iteration limit;
/// the curve, the totals, and the worst relative gap between the contact
/// force on the top particle and the piston force over the steps.
fn bcc(max_iterations: usize, until: f64) -> (Vec<CurvePoint>, RunStats, f64) {
    let scene = level1(Cell::bcc(0.05, 1.0).unwrap());
    let mut settings = pressed(15.0, until);
    settings.tolerance = 0.02;
    settings.newton.max_iterations = max_iterations;
    settings.newton.residual_tolerance = 1e-7;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    let area = scene.lengths[0] * scene.lengths[1];
    let mut worst: f64 = 0.0;
    while sim.status() == Status::Running {
        let p = sim.advance().unwrap().clone();
        let piston = p.cell_stress * area;
        let (contact, _) = sim.particle_forces(&scene)[1];
        worst = worst.max((contact[2] - piston).abs() / piston);
    }
    (sim.curve().to_vec(), sim.stats(), worst)
}

fn time_at(curve: &[CurvePoint], rho: f64) -> f64 {
    let k = curve.iter().position(|p| p.rel_density >= rho).unwrap();
    let (a, b) = (&curve[k - 1], &curve[k]);
    a.time + (rho - a.rel_density) / (b.rel_density - a.rel_density) * (b.time - a.time)
}

/// With an iteration limit far below what the contact steps need, many
/// attempts fail: each is cut back from the last converged state, with the
/// body, the rigid-plane contact set and the particle contact multipliers
/// as they were. The run goes on, keeps the contact force equal to the
/// piston force at every step, and ends where the unhindered run ends,
/// within the time tolerance. (Were the state not restored, the failed
/// attempts' contact multipliers or plastic strains would leak into the
/// next attempt and the balance or the times would drift.)
#[test]
fn failed_newton_attempts_cut_back_restore_the_state_and_go_on() {
    let (free, free_stats, _) = bcc(25, 0.75);
    // At 8 or 9 iterations the run fails (step 33 to 37, at any step
    // size): on triangular facets a node held by a facet's plane carried
    // just past a convex ridge is released when it leaves the margin, the
    // particle drops onto the next facet (3.8e-5 mm), and at the tolerance
    // of 1e-7 closing that takes 10 iterations.
    let (hindered, stats, worst) = bcc(10, 0.75);
    eprintln!(
        "failed attempts {} (free {}), steps {} (free {})",
        stats.failed_attempts, free_stats.failed_attempts, stats.steps, free_stats.steps
    );
    assert!(
        stats.failed_attempts >= 5 && stats.failed_attempts > 3 * free_stats.failed_attempts,
        "failed attempts: {} hindered, {} free",
        stats.failed_attempts,
        free_stats.failed_attempts
    );
    assert!(worst < 1e-5, "contact force off the piston's by {worst:e}");
    for rho in [0.72, 0.75] {
        let (a, b) = (time_at(&free, rho), time_at(&hindered, rho));
        assert!((a - b).abs() < 0.02 * a, "t({rho}): {a} free, {b} hindered");
    }
}

/// An attempt that cannot succeed at any step size fails with the typed
/// reason, where and when it happened, and leaves the last converged state.
#[test]
fn a_step_that_fails_at_every_size_reports_a_typed_reason() {
    let scene = level1(Cell::sc(0.05, 1.0).unwrap());
    let mut settings = pressed(10.0, 0.8);
    // One iteration to a residual near round-off: creep makes the first
    // step nonlinear, so one Newton iteration cannot get there.
    settings.newton.max_iterations = 1;
    settings.newton.residual_tolerance = 1e-14;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    let err = sim.advance().unwrap_err();
    match &err {
        SolverError::NoConvergence {
            time, step, reason, ..
        } => {
            assert_eq!((*time, *step), (0.0, 1));
            // The last attempt's reason, typed (at the smallest steps the
            // iteration limit, or the solve of a tangent stiffened by 1/dt).
            assert!(
                matches!(
                    reason,
                    StepFailure::Iterations { iterations: 1, .. } | StepFailure::Linear(_)
                ),
                "{reason:?}"
            );
            assert!(err.to_string().contains(&reason.to_string()));
        }
        other => panic!("{other}"),
    }
    // The state is the initial one, still.
    assert_eq!(sim.curve().len(), 1);
    assert_eq!(sim.curve()[0].time, 0.0);
}

/// A run stopped at a checkpoint step, written to bytes, read back and
/// resumed, ends with the same curve, bit for bit, as the run that went
/// through: bcc (particle contact, plane contact, contact multipliers,
/// step-size memory), stopped in the middle.
#[test]
fn a_run_resumed_from_a_checkpoint_goes_on_bit_for_bit() {
    use tidens_solver::Checkpoint;
    let scene = level1(Cell::bcc(0.05, 1.0).unwrap());
    let material = Preset::Ti64Creep1293K.material();
    let mut settings = pressed(15.0, 0.8);
    settings.tolerance = 0.02;
    settings.checkpoint_every = 20;
    // Stopped at step 40, in the middle: the checkpoint is taken from the
    // run that goes through (taking it only reads the state, so it is the
    // one a run stopped there writes; a run pressed to step 40 to take it
    // cost a fifth of the test).
    let mut through = Simulation::new(&scene, material, settings.clone()).unwrap();
    let mut saved = None;
    while through.status() == Status::Running {
        through.advance().unwrap();
        if through.curve().len() - 1 == 40 {
            saved = Some((through.checkpoint(), through.stats().wall_seconds));
        }
    }
    let steps = through.curve().len() - 1;
    assert!(steps > 60, "{steps} steps");
    let (saved, spent) = saved.unwrap();
    assert!(saved.exact() && saved.step() == 40);
    assert!(spent > 0.0);
    let read = Checkpoint::from_bytes(&saved.to_bytes().unwrap()).unwrap();
    let mut resumed = Simulation::resume(&scene, material, settings.clone(), &read).unwrap();
    // The time the first 40 steps took goes on with them.
    assert_eq!(resumed.stats().wall_seconds, spent);
    while resumed.status() == Status::Running {
        resumed.advance().unwrap();
    }
    assert_eq!(resumed.curve(), through.curve());
    assert_eq!(
        resumed.stats().newton_iterations,
        through.stats().newton_iterations
    );
    assert_eq!(
        resumed.stats().factorizations,
        through.stats().factorizations
    );
    assert!(resumed.stats().wall_seconds > spent);
    // Resumed with checkpoints every 10 steps from there on, the run
    // forgets its factor at steps 50 and 70 too: its path parts from the
    // through run's after step 50, and its curve stays within a tenth of
    // the time tolerance of it.
    let mut often = settings.clone();
    often.checkpoint_every = 10;
    let mut resumed = Simulation::resume(&scene, material, often, &read).unwrap();
    while resumed.status() == Status::Running {
        resumed.advance().unwrap();
        if resumed.curve().len() - 1 == 50 {
            assert!(resumed.checkpoint().exact());
        }
    }
    assert_eq!(resumed.curve()[..=50], through.curve()[..=50]);
    assert_ne!(resumed.curve(), through.curve());
    // The time to rho = 0.8, interpolated between the steps about it.
    let t_at = |c: &[tidens_solver::CurvePoint]| {
        let i = c.iter().position(|p| p.rel_density >= 0.8).unwrap();
        let (a, b) = (&c[i - 1], &c[i]);
        a.time + (b.time - a.time) * (0.8 - a.rel_density) / (b.rel_density - a.rel_density)
    };
    let (t_resumed, t_through) = (t_at(resumed.curve()), t_at(through.curve()));
    assert!(
        (t_resumed / t_through - 1.0).abs() < 0.1 * settings.tolerance,
        "{t_resumed} s against {t_through} s"
    );
    // Another material, or other settings, are refused.
    let mut other = settings.clone();
    other.tolerance = 0.01;
    assert!(matches!(
        Simulation::resume(&scene, material, other, &read),
        Err(SolverError::Checkpoint(_))
    ));
    assert!(matches!(
        Checkpoint::from_bytes(b"not a checkpoint"),
        Err(SolverError::Checkpoint(_))
    ));
}

/// The base bcc run of the two tests below (Ti-6Al-4V at 10 MPa to rho =
/// 0.75, the default tangent), run once for both.
fn bcc_base() -> &'static (Vec<CurvePoint>, RunStats) {
    static BASE: OnceLock<(Vec<CurvePoint>, RunStats)> = OnceLock::new();
    BASE.get_or_init(|| {
        let ti64 = Preset::Ti64Creep1293K.material();
        with_tangent(Cell::bcc(0.05, 1.0).unwrap(), ti64, 10.0, 0.75, false)
    })
}

/// Newton's totals and the curve of a level-1 run of `cell` (made of
/// `material`) at `stress` \[MPa\] to `until`, with the consistent tangent
/// or the solver's positive definite one.
fn with_tangent(
    cell: Cell,
    material: Material,
    stress: f64,
    until: f64,
    consistent: bool,
) -> (Vec<CurvePoint>, RunStats) {
    let scene = level1(cell);
    let mut settings = pressed(stress, until);
    settings.newton.consistent_tangent = consistent;
    let mut sim = Simulation::new(&scene, material, settings).unwrap();
    sim.run(|_| true).unwrap();
    (sim.curve().to_vec(), sim.stats())
}

/// The consistent tangent is indefinite in some Newton iterates: the
/// particle contacts' curvature part (bcc), and the elements' volumetric
/// initial-stress term at the transient pressures of a stiff material's
/// predictor (sc at E/sigma = 1e7). The tangent the solver factorises by
/// default leaves those parts out where they would dominate: it is
/// positive definite (every factorisation a Cholesky), Newton needs no
/// more iterations (bcc at 10 MPa to rho = 0.75: 125 against 140; at 15
/// MPa to 0.8, 214 with either, since nodes that slide off their facet are
/// paired afresh between iterations, 215 against 227 before; sc at E/sigma
/// = 1e7: 304 against 660), and since the residual is the same, so is the
/// curve, within what the step control and the contact events leave (1 %).
/// The bcc run with the default tangent is the base run of the stiff cases
/// below.
#[test]
fn the_default_tangent_is_positive_definite_where_the_consistent_one_is_not() {
    let ti64 = Preset::Ti64Creep1293K.material();
    let stiff = Material::new(1e8, ti64.poisson, ti64.creep_c, ti64.creep_n).unwrap();
    let cases = [
        (
            "bcc",
            Cell::bcc(0.05, 1.0).unwrap(),
            ti64,
            10.0,
            0.75,
            [0.72, 0.75],
        ),
        (
            "sc, E/sigma = 1e7",
            Cell::sc(0.05, 1.0).unwrap(),
            stiff,
            10.0,
            0.7,
            [0.6, 0.68],
        ),
    ];
    for (name, cell, material, stress, until, marks) in cases {
        let (exact, e) = with_tangent(cell.clone(), material, stress, until, true);
        let (spd, d) = if name == "bcc" {
            bcc_base().clone()
        } else {
            with_tangent(cell, material, stress, until, false)
        };
        eprintln!(
            "{name}: consistent {} Newton, {:?}; default {} Newton, {:?}",
            e.newton_iterations, e.factorizations, d.newton_iterations, d.factorizations
        );
        assert!(
            e.factorizations.lblt > 0,
            "{name}: the consistent tangent was never indefinite"
        );
        assert_eq!(
            d.factorizations.lblt, 0,
            "{name}: an indefinite default tangent"
        );
        assert!(
            d.newton_iterations <= e.newton_iterations,
            "{name}: {} against {}",
            d.newton_iterations,
            e.newton_iterations
        );
        for rho in marks {
            let (a, b) = (time_at(&exact, rho), time_at(&spd, rho));
            assert!(
                (a - b).abs() < 0.01 * a,
                "{name}: t({rho}) {a} consistent, {b} default"
            );
        }
    }
}

/// Stiff cases on bcc. A stiff material (E/sigma = 1e7): the touch stiffness that holds
/// the top particle on the contact about to close scaled with E, so Newton
/// moved the particle by a fraction of the gap each iteration and stalled
/// at every step length at rho = 0.687 during the ramp. Capped at
/// 50 f sigma / h, the run goes on, and its curve is the base material's
/// but for the base's elastic head start during the ramp (the contacts'
/// elastic compression, gone at E/sigma = 1e7): a delay of 0.045 to 0.06 s
/// at every density from 0.7 to 0.75.
#[test]
fn stiff_cases_on_bcc_close_their_contacts_and_densify_like_the_base_one() {
    let ti64 = Preset::Ti64Creep1293K.material();
    let stiff = Material::new(1e8, ti64.poisson, ti64.creep_c, ti64.creep_n).unwrap();
    let cell = || Cell::bcc(0.05, 1.0).unwrap();
    let (base, _) = bcc_base();
    let (hard, stats) = with_tangent(cell(), stiff, 10.0, 0.75, false);
    eprintln!("E/sigma = 1e7 on bcc: {stats:?}");
    assert!(
        stats.failed_attempts <= 3,
        "{} failed attempts",
        stats.failed_attempts
    );
    for rho in [0.7, 0.72, 0.74, 0.75] {
        let (a, b) = (time_at(base, rho), time_at(&hard, rho));
        assert!(b > a && b - a < 0.1, "t({rho}): {a} s base, {b} s stiff");
    }
    // The same stiffness from the other side: the base material at 1e-3
    // MPa (E/sigma = 4e7). The contact penalty, 10 E/h, made the contact
    // state flip between Newton iterations (14 failed attempts to rho =
    // 0.9); capped at 1e6 f sigma / h, none. With the ramp a vanishing part
    // of the run, Norton similarity maps it onto the stiff run at 10 MPa:
    // t sigma^n equal, after the ramp's t_eff = t - n t_r / (n + 1).
    let (slow, stats) = with_tangent(cell(), ti64, 1e-3, 0.75, false);
    eprintln!("1e-3 MPa on bcc: {stats:?}");
    assert!(
        stats.failed_attempts <= 2,
        "{} failed attempts",
        stats.failed_attempts
    );
    let n = ti64.creep_n;
    for rho in [0.74, 0.75] {
        let fast = (time_at(&hard, rho) - n / (n + 1.0)) * 10f64.powf(n);
        let slow = time_at(&slow, rho) * 1e-3f64.powf(n);
        eprintln!("t sigma^n at {rho}: {fast:e} (10 MPa), {slow:e} (1e-3 MPa)");
        assert!(
            (fast - slow).abs() < 0.03 * slow,
            "t sigma^n at {rho}: {fast:e} at 10 MPa, {slow:e} at 1e-3 MPa"
        );
    }
}

/// Each update of the contact multipliers poses a new equilibrium, and
/// its Newton solve has the whole iteration limit: on the bcc cell at
/// E/sigma = 1e2 during the ramp (a soft particle, contact pressures that
/// the multipliers reach over several updates), steps take more iterations
/// in all than one solve is allowed, and the run goes on. (Counted
/// together, a step needing its updates at any step size was cut back to
/// nothing: at level 3 from 2e-2 to 2e-14 s.)
#[test]
fn each_multiplier_update_has_its_own_newton_iterations() {
    let scene = level1(Cell::bcc(0.05, 1.0).unwrap());
    let material = Material {
        young: 1e3,
        ..Preset::Ti64Creep1293K.material()
    };
    let mut settings = pressed(10.0, 0.75);
    let limit = 6;
    settings.newton.max_iterations = limit;
    let mut sim = Simulation::new(&scene, material, settings).unwrap();
    // Steps that took more iterations than the limit at their first attempt.
    let mut beyond = Vec::new();
    while sim.status() == Status::Running {
        let failed = sim.stats().failed_attempts;
        let p = sim.advance().unwrap().clone();
        if p.newton_iterations > limit && sim.stats().failed_attempts == failed {
            beyond.push((p.step, p.newton_iterations));
        }
    }
    assert!(
        !beyond.is_empty(),
        "no step went past {limit} iterations in one attempt"
    );
    assert!(sim.curve().last().unwrap().rel_density >= 0.75);
}
