use std::time::Instant;
use tidens_solver::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("bcc", |s| s.as_str());
    let level: u32 = args.get(2).map_or(1, |s| s.parse().unwrap());
    let target: f64 = args.get(3).map_or(0.9, |s| s.parse().unwrap());
    let steps: usize = args.get(4).map_or(100000, |s| s.parse().unwrap());
    let cell = match name {
        "bcc" => Cell::bcc(0.05, 1.0),
        "fcc" => Cell::fcc(0.05, 1.0),
        "sc2" => Cell::sc2(0.05, DEFAULT_SIZE_RATIO, 1.0),
        _ => Cell::sc(0.05, 1.0),
    }
    .unwrap();
    let scene = Scene::from_cell(
        &cell,
        &MeshOptions {
            level,
            grading: 1.0,
        },
    )
    .unwrap();
    let mut settings = Settings::new(LoadHistory {
        stress: 15.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(target);
    settings.tolerance = 0.02;
    settings.max_steps = steps;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    println!(
        "{} rho0 {:.5} (exact {:.5}) dofs {}",
        cell.name,
        sim.curve()[0].rel_density,
        cell.rho0(),
        sim.degrees_of_freedom()
    );
    let t0 = Instant::now();
    let r = sim.run(|p| {
        if p.step % 50 == 0 {
            println!(
                "step {} t {:.4e} dt {:.2e} rho {:.5} it {} pen {:.2e} contacts {}",
                p.step,
                p.time,
                p.dt,
                p.rel_density,
                p.newton_iterations,
                p.max_penetration,
                p.contacts
            );
        }
        true
    });
    let forces = sim.particle_forces(&scene);
    println!(
        "{r:?} wall {:.1}s stats {:?}",
        t0.elapsed().as_secs_f64(),
        sim.stats()
    );
    for (k, (c, p)) in forces.iter().enumerate() {
        println!("particle {k}: contact {c:?} planes {p:?}");
    }
}
