//! Shared set-up of the criterion benchmarks: the sc Ti-6Al-4V cell pressed
//! part of the way, so that kernels run on realistic states.

use tidens_solver::{
    Cell, LoadHistory, MeshOptions, Preset, Scene, Settings, Simulation, SolverError,
};

/// The sc cell at 10 MPa, advanced until its density reaches `rho`.
pub fn sc_pressed_to(level: u32, rho: f64) -> Result<Simulation, SolverError> {
    let cell = Cell::sc(0.05, 1.0)?;
    let scene = Scene::from_cell(
        &cell,
        &MeshOptions {
            level,
            grading: 1.0,
            ..MeshOptions::default()
        },
    )?;
    let mut settings = Settings::new(LoadHistory {
        stress: 10.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(rho);
    settings.tolerance = 0.05;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings)?;
    sim.run(|_| true)?;
    Ok(sim)
}
