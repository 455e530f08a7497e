//! The size estimate of a run is the run's own count: nodes, elements and
//! unknowns of the simulation set up for the same cell, mesh and element.

use tidens_solver::{
    Cell, ElementKind, LoadHistory, MeshOptions, PlacedSpheroid, Preset, Scene, Settings,
    Simulation, SizeEstimate,
};

fn settings() -> Settings {
    let mut s = Settings::new(LoadHistory {
        stress: 10.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    s.until_density = Some(0.9);
    s
}

/// What the simulation of `scene` reports: nodes, elements, unknowns.
fn counted(scene: &Scene) -> (usize, usize, usize) {
    let sim = Simulation::new(scene, Preset::Ti64Creep1293K.material(), settings()).unwrap();
    let elements = match &scene.tet_mesh {
        Some(t) => t.elements.len(),
        None => scene.mesh.elements.len(),
    };
    (sim.body().nodes().len(), elements, sim.degrees_of_freedom())
}

fn estimated(e: &SizeEstimate) -> (usize, usize, usize) {
    (e.nodes, e.elements, e.degrees_of_freedom)
}

#[test]
fn cells_of_octants_are_estimated_to_their_counts() {
    let cells = [
        Cell::sc(0.05, 1.0).unwrap(),
        Cell::bcc(0.05, 1.0).unwrap(),
        Cell::sc2(0.05, 1.566, 1.2).unwrap(),
    ];
    for cell in &cells {
        for level in [1, 2] {
            for kind in [ElementKind::Hex8, ElementKind::Tet10] {
                // The run's own options: exact volume, as by default.
                let options = MeshOptions {
                    level,
                    ..MeshOptions::default()
                };
                let scene = Scene::from_cell(cell, &options)
                    .unwrap()
                    .with_element(kind)
                    .unwrap();
                let estimate = SizeEstimate::of_cell(cell, &options, kind).unwrap();
                assert_eq!(
                    estimated(&estimate),
                    counted(&scene),
                    "{} level {level} {kind:?}",
                    cell.name
                );
                let per_dof = match kind {
                    ElementKind::Hex8 => tidens_solver::HEX8_BYTES_PER_DOF,
                    ElementKind::Tet10 => tidens_solver::TET10_BYTES_PER_DOF,
                };
                assert_eq!(
                    estimate.peak_memory_bytes,
                    tidens_solver::BASE_BYTES + per_dof * estimate.degrees_of_freedom as u64
                );
            }
        }
    }
}

/// Particles of two layouts (a sphere and prolate spheroids, turned), near
/// the box faces and in the middle, so that they have different numbers of
/// images.
#[test]
fn periodic_cells_are_estimated_to_their_counts_without_meshing_them() {
    let spheroid = |centre, a, c, axis| PlacedSpheroid { centre, a, c, axis };
    let particles = [
        spheroid([0.02, 0.03, 0.28], 0.05, 0.05, [0.0, 0.0, 1.0]),
        spheroid([0.15, 0.15, 0.15], 0.04, 0.07, [1.0, 1.0, 0.0]),
        spheroid([0.25, 0.06, 0.1], 0.035, 0.06, [0.2, -1.0, 0.4]),
    ];
    let lengths = [0.3, 0.3, 0.32];
    for level in [1, 2] {
        let options = MeshOptions {
            level,
            grading: 1.0,
            exact_volume: false,
        };
        let scene = Scene::periodic(lengths, &particles, &options).unwrap();
        let estimate = SizeEstimate::of_periodic(lengths, &particles, &options).unwrap();
        assert_eq!(estimated(&estimate), counted(&scene), "level {level}");
    }
}

/// 10000 particles are estimated in well under a second (their mesh would
/// hold some 15 million nodes).
#[test]
fn ten_thousand_particles_are_estimated_at_once() {
    let n = 22; // 22^3 = 10648 spheres on a loose grid
    let spacing = 0.12;
    let particles: Vec<PlacedSpheroid> = (0..n * n * n)
        .map(|k| PlacedSpheroid {
            centre: [k % n, k / n % n, k / (n * n)].map(|i| (i as f64 + 0.5) * spacing),
            a: 0.05,
            c: 0.05,
            axis: [0.0, 0.0, 1.0],
        })
        .collect();
    let start = std::time::Instant::now();
    let estimate = SizeEstimate::of_periodic(
        [n as f64 * spacing; 3],
        &particles,
        &MeshOptions {
            level: 1,
            ..MeshOptions::default()
        },
    )
    .unwrap();
    let seconds = start.elapsed().as_secs_f64();
    assert!(seconds < 0.2, "{seconds} s");
    // 1501 nodes a particle at level 1: 3 x 1501 unknowns each.
    assert_eq!(estimate.degrees_of_freedom, 3 * 1501 * particles.len() - 2);
    assert!(estimate.peak_memory_bytes > 100 << 30, "{estimate:?}");
}
