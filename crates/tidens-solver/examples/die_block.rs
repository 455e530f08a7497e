use tidens_solver::*;
fn main() {
    let material = Preset::Ti64Creep1293K.material();
    let scene = Scene::die_block([1.0; 3], [3, 3, 3]).unwrap();
    let mut settings = Settings::new(LoadHistory {
        stress: 10.0,
        knockdown: 1.0,
        ramp_time: 0.0,
    });
    settings.until_time = Some(2e6);
    settings.dt_initial = Some(1e-3);
    settings.tolerance = 0.02;
    settings.max_steps = 100000;
    let mut sim = Simulation::new(&scene, material, settings).unwrap();
    let r = sim.run(|p| {
        println!(
            "step {} t {:.4e} dt {:.3e} U {:.6e} it {} dp {:.2e}",
            p.step,
            p.time,
            p.dt,
            p.piston_displacement,
            p.newton_iterations,
            p.max_strain_increment
        );
        true
    });
    println!("{r:?} {:?}", sim.stats());
}
