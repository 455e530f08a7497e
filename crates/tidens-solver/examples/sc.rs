//! Presses the sc Ti-6Al-4V cell: `cargo run --release --example sc -- LEVEL STRESS TARGET TOL`.
use std::time::Instant;
use tidens_solver::*;

fn main() -> Result<(), SolverError> {
    let args: Vec<String> = std::env::args().collect();
    let level: u32 = args.get(1).map_or(2, |s| s.parse().unwrap());
    let stress: f64 = args.get(2).map_or(10.0, |s| s.parse().unwrap());
    let target: f64 = args.get(3).map_or(0.9, |s| s.parse().unwrap());
    let tol: f64 = args.get(4).map_or(0.005, |s| s.parse().unwrap());
    let cell = Cell::sc(0.05, 1.0)?;
    let scene = Scene::from_cell(
        &cell,
        &MeshOptions {
            level,
            grading: 1.0,
        },
    )?;
    let mut settings = Settings::new(LoadHistory {
        stress,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(target);
    settings.tolerance = tol;
    settings.max_steps = 20000;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings)?;
    println!(
        "dofs {} elements {}",
        sim.degrees_of_freedom(),
        scene.mesh.elements.len()
    );
    let t0 = Instant::now();
    let mut marks = vec![0.6, 0.7, 0.8, 0.9, 0.95];
    let mut prev = sim.curve()[0].clone();
    let res = sim.run(|p| {
        if p.step % 50 == 0 {
            println!("step {:5} t {:10.4e} dt {:9.3e} rho {:.5} it {:2} dp {:.3e} contacts {} pen {:.1e} err {:.2e}", p.step, p.time, p.dt, p.rel_density, p.newton_iterations, p.max_strain_increment, p.contacts, p.max_penetration, p.time_error);
        }
        while let Some(&m) = marks.first() {
            if p.rel_density >= m {
                let t = prev.time + (m - prev.rel_density) / (p.rel_density - prev.rel_density) * (p.time - prev.time);
                println!("  t({m}) = {t:.4} s  (err est {:.3e} s)  step {}", p.time_error, p.step);
                marks.remove(0);
            } else { break; }
        }
        prev = p.clone();
        true
    });
    let mut out = String::from("t,rho,U,dt,it,dp,contacts,err\n");
    for p in sim.curve() {
        out += &format!(
            "{},{},{},{},{},{},{},{}\n",
            p.time,
            p.rel_density,
            p.piston_displacement,
            p.dt,
            p.newton_iterations,
            p.max_strain_increment,
            p.contacts,
            p.time_error
        );
    }
    std::fs::write(format!("/tmp/sc_L{level}_tol{tol}.csv"), out).unwrap();
    let st = sim.stats();
    println!(
        "eval {:.2} s assembly {:.2} s linear {:.2} s",
        st.evaluation_seconds, st.assembly_seconds, st.linear_seconds
    );
    println!(
        "{res:?} wall {:.2} s steps {} newton {} rejected {} failed {} fact {:?}",
        t0.elapsed().as_secs_f64(),
        st.steps,
        st.newton_iterations,
        st.rejected_steps,
        st.failed_attempts,
        st.factorizations
    );
    Ok(())
}
