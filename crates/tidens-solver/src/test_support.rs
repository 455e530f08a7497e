//! Set-ups shared by the unit tests of the solver's modules.

use crate::{Cell, LoadHistory, MeshOptions, Preset, Scene, Settings, Simulation};

/// The bcc cell at level 1.
pub(crate) fn bcc_level1_scene() -> Scene {
    let options = MeshOptions {
        level: 1,
        ..MeshOptions::default()
    };
    Scene::from_cell(&Cell::bcc(0.05, 1.0).unwrap(), &options).unwrap()
}

/// The bcc cell at level 1, Ti-6Al-4V at 1293 K, 15 MPa ramped over 1 s,
/// with `adjust` applied to the settings (stop conditions and the like).
pub(crate) fn bcc_level1(adjust: impl FnOnce(&mut Settings)) -> Simulation {
    ti64_creep(&bcc_level1_scene(), 15.0, adjust)
}

/// The settings of [`bcc_level1`]: 15 MPa ramped over 1 s, with `adjust`
/// applied.
pub(crate) fn bcc_level1_settings(adjust: impl FnOnce(&mut Settings)) -> Settings {
    ti64_settings(15.0, adjust)
}

fn ti64_settings(stress: f64, adjust: impl FnOnce(&mut Settings)) -> Settings {
    let mut settings = Settings::new(LoadHistory {
        stress,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    adjust(&mut settings);
    settings
}

/// `scene` pressed at `stress` \[MPa\] ramped over 1 s, Ti-6Al-4V at
/// 1293 K, with `adjust` applied to the settings.
fn ti64_creep(scene: &Scene, stress: f64, adjust: impl FnOnce(&mut Settings)) -> Simulation {
    let settings = ti64_settings(stress, adjust);
    Simulation::new(scene, Preset::Ti64Creep1293K.material(), settings).unwrap()
}

/// One sphere (radius 0.05 mm, its axis tilted off z) in a periodic cube
/// of twice its radius, touching its six images: the sc lattice as a
/// periodic cell at level 1, Ti-6Al-4V at 1293 K, 10 MPa ramped over 1 s,
/// with `adjust` applied to the settings.
pub(crate) fn periodic_sphere_level1(adjust: impl FnOnce(&mut Settings)) -> Simulation {
    let r = 0.05;
    let sphere = crate::PlacedSpheroid {
        centre: [r; 3],
        a: r,
        c: r,
        axis: [0.31, 0.17, 1.0],
    };
    let options = MeshOptions {
        level: 1,
        grading: 1.0,
        exact_volume: false,
    };
    let scene = Scene::periodic([2.0 * r; 3], &[sphere], &options).unwrap();
    ti64_creep(&scene, 10.0, adjust)
}

/// Asserts that systems `a` and `b` act alike: `a w = b w` to 1e-12 of
/// `b w`'s size for two smooth vectors `w`; `what` names `a` in the message.
pub(crate) fn assert_same_system(
    a: &tidens_fem::SparseSystem,
    b: &tidens_fem::SparseSystem,
    what: &str,
) {
    for seed in [0.37, 1.3] {
        let w: Vec<f64> = (0..b.dim()).map(|e| (seed * e as f64).cos()).collect();
        let (aw, bw) = (a.mul_vec(&w), b.mul_vec(&w));
        let diff = aw
            .iter()
            .zip(&bw)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        let size = bw.iter().fold(0.0f64, |m, y| m.max(y.abs()));
        assert!(diff <= 1e-12 * size, "{what} off by {diff:e}");
    }
}
