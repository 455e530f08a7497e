use tidens_solver::*;
fn main() {
    let (n, sigma, l0): (f64, f64, f64) = (2.8, 10.0, 1.0);
    let c = 3e-4 / sigma.powf(n);
    for tol in [0.02, 0.01, 0.005] {
        let material = Material::new(4.35e4 * 100.0, 0.3, c, n).unwrap();
        let scene = Scene::free_block([l0; 3], [1, 1, 1]).unwrap();
        let load = LoadHistory {
            stress: sigma,
            knockdown: 1.0,
            ramp_time: 0.0,
        };
        let mut settings = Settings::new(load);
        settings.until_time = Some(1e9);
        settings.tolerance = tol;
        settings.dt_initial = Some(1.0);
        let mut sim = Simulation::new(&scene, material, settings).unwrap();
        let mut out = (0.0, 0.0, 0.0, 0);
        sim.run(|p| {
            let h = l0 + p.piston_displacement;
            // exact time to reach h (rigid-viscoplastic)
            let t_exact = ((h / l0).powf(-n) - 1.0) / (n * c * (sigma / l0).powf(n));
            out = (p.time, t_exact, p.time_error, p.step);
            h > 0.5 * l0
        })
        .unwrap();
        println!(
            "tol {tol}: t {:.3} exact {:.3} err {:.3} ({:.3}%) estimate {:.3} steps {}",
            out.0,
            out.1,
            out.0 - out.1,
            100.0 * (out.0 - out.1) / out.1,
            out.2,
            out.3
        );
    }
}
