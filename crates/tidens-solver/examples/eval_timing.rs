use std::time::Instant;
use tidens_fem::Body;
use tidens_solver::*;
fn main() {
    let cell = Cell::sc(0.05, 1.0).unwrap();
    let scene = Scene::from_cell(
        &cell,
        &MeshOptions {
            level: 3,
            grading: 1.0,
        },
    )
    .unwrap();
    let body = Body::new(
        scene.mesh.nodes.clone(),
        scene.mesh.elements.clone(),
        Preset::Ti64Creep1293K.material(),
    )
    .unwrap();
    let u: Vec<f64> = (0..body.dof_count())
        .map(|k| 1e-4 * ((k as f64) * 0.37).sin())
        .collect();
    for tangent in [false, true] {
        let t0 = Instant::now();
        for _ in 0..50 {
            let e = body.evaluate(&u, 1.0, tangent).unwrap();
            std::hint::black_box(e);
        }
        println!(
            "tangent {tangent}: {:.2} ms per evaluation ({} elements)",
            t0.elapsed().as_secs_f64() * 1e3 / 50.0,
            body.elements().len()
        );
    }
}
