use tidens_solver::*;
fn main() {
    let r = 0.05;
    let level: u32 = std::env::args().nth(1).map_or(1, |s| s.parse().unwrap());
    let target: f64 = std::env::args().nth(2).map_or(0.62, |s| s.parse().unwrap());
    let oct = |top| Octant {
        corner: [false, false, top],
        a: r,
        c: r,
    };
    let cell = Cell::new("pair", [r, r, 2.0 * r], vec![oct(false), oct(true)]).unwrap();
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
    settings.tolerance = 0.05;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    let mut k = 0;
    sim.run(|p| {
        k += 1;
        if k % 5 == 0 {
            println!(
                "t {:.3e} rho {:.4} pen {:.2e}",
                p.time, p.rel_density, p.max_penetration
            );
        }
        true
    })
    .unwrap();
    let f = sim.fields();
    let lz = scene.lengths[2] + sim.curve().last().unwrap().piston_displacement;
    let (b, t) = (&scene.particles[0], &scene.particles[1]);
    let mut v: Vec<(f64, usize)> = (0..b.nodes.1)
        .map(|k| {
            let (p, q) = (f.points[b.nodes.0 + k], f.points[t.nodes.0 + k]);
            let d = (p[0] - q[0])
                .abs()
                .max((p[1] - q[1]).abs())
                .max((p[2] + q[2] - lz).abs());
            (d, k)
        })
        .collect();
    v.sort_by(|a, b| b.0.total_cmp(&a.0));
    for &(d, k) in v.iter().take(8) {
        let (p, q) = (f.points[b.nodes.0 + k], f.points[t.nodes.0 + k]);
        println!(
            "node {k}: asym {d:.2e}  bottom {:?}  top-mirrored {:?}  ref {:?}",
            p,
            [q[0], q[1], lz - q[2]],
            scene.mesh.nodes[b.nodes.0 + k]
        );
    }
    let pressed: Vec<_> = sim
        .contact_terms()
        .iter()
        .filter(|t| t.pressure > 0.0)
        .map(|t| (t.slave, t.pressure))
        .collect();
    println!(
        "pressed {}: {:?}",
        pressed.len(),
        &pressed[..pressed.len().min(12)]
    );
}
