//! Presses a preset cell of Ti-6Al-4V at 15 MPa and prints its curve summary:
//! `cargo run --release --example cells -- CELL LEVEL TARGET [MAX_STEPS] [ASPECT]`
//! (CELL: sc, bcc, fcc, sc2; environment TET=1 meshes with 10-node tetrahedra).
use std::time::Instant;
use tidens_solver::*;

fn main() -> Result<(), SolverError> {
    let args: Vec<String> = std::env::args().collect();
    let arg = |k: usize, default: &str| args.get(k).cloned().unwrap_or_else(|| default.to_string());
    let name = arg(1, "bcc");
    let level: u32 = arg(2, "1").parse().unwrap_or(1);
    let target: f64 = arg(3, "0.9").parse().unwrap_or(0.9);
    let max_steps: usize = arg(4, "100000").parse().unwrap_or(100_000);
    let aspect: f64 = arg(5, "1.0").parse().unwrap_or(1.0);
    let cell = match name.as_str() {
        "bcc" => Cell::bcc(0.05, aspect)?,
        "fcc" => Cell::fcc(0.05, aspect)?,
        "sc2" => Cell::sc2(0.05, DEFAULT_SIZE_RATIO, aspect)?,
        _ => Cell::sc(0.05, aspect)?,
    };
    let element = if std::env::var("TET").is_ok() {
        ElementKind::Tet10
    } else {
        ElementKind::Hex8
    };
    let scene = Scene::from_cell(
        &cell,
        &MeshOptions {
            level,
            grading: 1.0,
        },
    )?
    .with_element(element)?;
    let mut settings = Settings::new(LoadHistory {
        stress: 15.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(target);
    settings.max_steps = max_steps;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings)?;
    println!(
        "{} c/a {aspect} {element:?} level {level}: rho0 {:.5} (exact {:.5}), dofs {}",
        cell.name,
        sim.curve()[0].rel_density,
        cell.rho0(),
        sim.degrees_of_freedom()
    );
    let t0 = Instant::now();
    let status = sim.run(|p| {
        if p.step % 50 == 0 {
            println!(
                "  step {} t {:.4e} rho {:.5} pen {:.2e}",
                p.step, p.time, p.rel_density, p.max_penetration
            );
        }
        true
    });
    let st = sim.stats();
    println!(
        "  {status:?} wall {:.1} s, steps {}, Newton {}, factorisations {}",
        t0.elapsed().as_secs_f64(),
        st.steps,
        st.newton_iterations,
        st.factorizations.llt + st.factorizations.lblt
    );
    let c = sim.curve();
    for rho in [0.6, 0.7, 0.8, 0.9, 0.95] {
        if let Some(k) = c
            .iter()
            .position(|p| p.rel_density >= rho)
            .filter(|&k| k > 0)
        {
            let (a, b) = (&c[k - 1], &c[k]);
            let t = a.time
                + (rho - a.rel_density) / (b.rel_density - a.rel_density) * (b.time - a.time);
            println!("  t({rho}) = {t:.2} s");
        }
    }
    let pen = c.iter().map(|p| p.max_penetration).fold(0.0, f64::max);
    let monotone = c
        .windows(2)
        .all(|w| w[1].rel_density >= w[0].rel_density - 1e-9);
    for w in c
        .windows(2)
        .filter(|w| !(w[1].rel_density >= w[0].rel_density - 1e-9))
    {
        println!(
            "  density fell at step {}: t {:.4e} -> {:.4e}, rho {:.7} -> {:.7} (dt {:.2e}, volume {:.6e} -> {:.6e}, U {:.6e} -> {:.6e})",
            w[1].step,
            w[0].time,
            w[1].time,
            w[0].rel_density,
            w[1].rel_density,
            w[1].dt,
            w[0].particle_volume,
            w[1].particle_volume,
            w[0].piston_displacement,
            w[1].piston_displacement
        );
    }
    println!(
        "  max penetration {pen:.3e} mm = {:.2e} R, monotone {monotone}",
        pen / scene.radius
    );
    Ok(())
}
