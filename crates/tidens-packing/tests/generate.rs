//! Generated packings: reproducibility, density, overlaps, box, walls,
//! refusals.

use std::time::Instant;

use tidens_packing::{
    Boundary, OVERLAP_TOLERANCE, Packing, PackingError, PackingSpec, SizeDistribution,
};

fn spec(particles: usize, rho0: f64, seed: u64) -> PackingSpec {
    PackingSpec {
        particles,
        rho0,
        seed,
        ..PackingSpec::default()
    }
}

/// Largest sphere-sphere overlap by a brute-force loop over the images
/// -2..=2 along each periodic side (independent of the crate's pair search).
fn brute_force_sphere_overlap(p: &Packing) -> f64 {
    let l = p.lengths;
    let range = |k: usize| {
        if p.boundary.is_periodic(k) {
            -2..=2
        } else {
            0..=0
        }
    };
    let mut worst = 0.0_f64;
    for (i, a) in p.particles.iter().enumerate() {
        for (j, b) in p.particles.iter().enumerate() {
            for nx in range(0) {
                for ny in range(1) {
                    for nz in range(2) {
                        if i == j && (nx, ny, nz) == (0, 0, 0) {
                            continue;
                        }
                        let d = [
                            b.centre[0] + f64::from(nx) * l[0] - a.centre[0],
                            b.centre[1] + f64::from(ny) * l[1] - a.centre[1],
                            b.centre[2] + f64::from(nz) * l[2] - a.centre[2],
                        ];
                        let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        worst = worst.max(a.a + b.a - dist);
                    }
                }
            }
        }
    }
    worst
}

/// Checks a generated packing against its spec.
fn check(p: &Packing, s: &PackingSpec) {
    assert_eq!(p.particles.len(), s.particles);
    assert_eq!(p.boundary, s.boundary);
    let rel = (p.rel_density() - s.rho0).abs() / s.rho0;
    assert!(rel <= 1e-9, "rel_density {} vs {}", p.rel_density(), s.rho0);
    // Box shape follows box_aspect.
    for k in 1..3 {
        let ratio = p.lengths[k] / p.lengths[0];
        let want = s.box_aspect[k] / s.box_aspect[0];
        assert!((ratio / want - 1.0).abs() < 1e-12);
    }
    let overlap = p.max_overlap();
    assert!(
        overlap <= OVERLAP_TOLERANCE * s.mean_radius,
        "max overlap {overlap}"
    );
    // Mean volume-equivalent radius and aspect ratio.
    let mean = p
        .particles
        .iter()
        .map(|q| q.equivalent_radius())
        .sum::<f64>()
        / p.particles.len() as f64;
    assert!(
        (mean / s.mean_radius - 1.0).abs() < 1e-12,
        "mean radius {mean}"
    );
    for q in &p.particles {
        assert!((q.c / q.a / s.aspect_ratio - 1.0).abs() < 1e-12);
        let n = (q.axis[0] * q.axis[0] + q.axis[1] * q.axis[1] + q.axis[2] * q.axis[2]).sqrt();
        assert!((n - 1.0).abs() < 1e-12);
        for k in 0..3 {
            if p.boundary.is_periodic(k) {
                assert!(
                    q.centre[k] >= 0.0 && q.centre[k] < p.lengths[k],
                    "centre {:?} outside the box {:?}",
                    q.centre,
                    p.lengths
                );
            }
        }
        if p.boundary == Boundary::Die {
            let e = q.support([0.0, 0.0, 1.0]);
            assert!(q.centre[2] - e >= 0.0, "below the bottom wall: {q:?}");
            assert!(q.centre[2] + e <= p.lengths[2], "above the top wall: {q:?}");
        }
    }
    if s.aspect_ratio == 1.0 {
        let brute = brute_force_sphere_overlap(p);
        assert!(
            brute <= OVERLAP_TOLERANCE * s.mean_radius,
            "brute-force overlap {brute}"
        );
        assert!((brute - overlap).abs() < 1e-12, "{brute} vs {overlap}");
    }
}

#[test]
fn same_seed_gives_a_bit_identical_packing_another_seed_another() {
    for s in [
        spec(24, 0.6, 7),
        PackingSpec {
            aspect_ratio: 2.0,
            boundary: Boundary::Die,
            ..spec(12, 0.55, 7)
        },
    ] {
        let a = Packing::generate(&s).unwrap();
        let b = Packing::generate(&s).unwrap();
        let bits = |p: &Packing| -> Vec<u64> {
            p.particles
                .iter()
                .flat_map(|q| {
                    q.centre
                        .iter()
                        .chain(q.axis.iter())
                        .chain([q.a, q.c].iter())
                        .map(|v| v.to_bits())
                        .collect::<Vec<_>>()
                })
                .chain(p.lengths.iter().map(|v| v.to_bits()))
                .collect()
        };
        assert_eq!(bits(&a), bits(&b));
        let c = Packing::generate(&PackingSpec { seed: 8, ..s }).unwrap();
        assert_ne!(a.particles, c.particles);
        assert_eq!(a.lengths, c.lengths);
    }
}

#[test]
fn monodisperse_spheres_reach_0_62_for_8_to_64_particles() {
    for n in [8, 16, 32, 64] {
        for seed in 0..3 {
            let s = spec(n, 0.62, seed);
            let start = Instant::now();
            let p = Packing::generate(&s).unwrap_or_else(|e| panic!("n {n} seed {seed}: {e}"));
            println!(
                "{n} spheres to rho0 = 0.62, seed {seed}: {:.3} s, max overlap {:.1e} mm",
                start.elapsed().as_secs_f64(),
                p.max_overlap()
            );
            check(&p, &s);
        }
    }
}

#[test]
fn die_packings_respect_the_walls() {
    for s in [
        // The walls lower the density a random packing can reach: small die
        // cells of spheres jam near 0.56-0.60 (see the crate docs).
        PackingSpec {
            boundary: Boundary::Die,
            ..spec(32, 0.55, 1)
        },
        PackingSpec {
            boundary: Boundary::Die,
            box_aspect: [1.0, 1.0, 2.0],
            mean_radius: 0.05,
            ..spec(48, 0.55, 2)
        },
        PackingSpec {
            boundary: Boundary::Die,
            aspect_ratio: 2.0,
            ..spec(16, 0.6, 3)
        },
    ] {
        let p = Packing::generate(&s).unwrap();
        check(&p, &s);
        // A dense die packing leans on its walls.
        assert!(!p.wall_contacts(1e-3 * s.mean_radius).is_empty());
    }
}

#[test]
fn spheroids_and_size_distributions_are_packed() {
    let cases = [
        PackingSpec {
            aspect_ratio: 2.0,
            ..spec(16, 0.62, 0)
        },
        PackingSpec {
            aspect_ratio: 0.5,
            ..spec(16, 0.6, 1)
        },
        PackingSpec {
            distribution: SizeDistribution::Bimodal {
                size_ratio: 1.566,
                small_fraction: 0.5,
            },
            ..spec(32, 0.62, 2)
        },
        PackingSpec {
            distribution: SizeDistribution::Lognormal { sigma: 0.3 },
            mean_radius: 0.04,
            box_aspect: [1.0, 1.5, 1.0],
            ..spec(40, 0.6, 3)
        },
    ];
    for s in cases {
        let p = Packing::generate(&s).unwrap_or_else(|e| panic!("{s:?}: {e}"));
        check(&p, &s);
        // The radii are those that spec.radii() announces.
        let radii = s.radii().unwrap();
        for (q, r) in p.particles.iter().zip(&radii) {
            assert!((q.equivalent_radius() / r - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn a_larger_packing_uses_the_cell_list() {
    let s = PackingSpec {
        distribution: SizeDistribution::Lognormal { sigma: 0.2 },
        ..spec(500, 0.6, 4)
    };
    let start = Instant::now();
    let p = Packing::generate(&s).unwrap();
    println!(
        "500 lognormal spheres to 0.6: {:.2} s",
        start.elapsed().as_secs_f64()
    );
    check(&p, &s);
}

#[test]
fn rho0_above_random_close_packing_is_refused_with_the_density_reached() {
    let err = Packing::generate(&spec(40, 0.70, 0)).unwrap_err();
    match err {
        PackingError::Rho0Unreachable { requested, reached } => {
            assert_eq!(requested, 0.70);
            assert!(reached > 0.55 && reached < 0.70, "reached {reached}");
            let text = err.to_string();
            assert!(text.starts_with("rho0 = 0.7: not reached"), "{text}");
            assert!(text.contains(&reached.to_string()), "{text}");
        }
        other => panic!("unexpected {other:?}"),
    }
}

fn parameter_name(s: &PackingSpec) -> (&'static str, String) {
    match Packing::generate(s) {
        Err(e @ PackingError::Parameter { name, .. }) => (name, e.to_string()),
        other => panic!("expected a parameter error, got {other:?}"),
    }
}

#[test]
fn out_of_range_parameters_name_themselves() {
    let base = spec(10, 0.6, 0);
    let (name, text) = parameter_name(&PackingSpec { rho0: 0.8, ..base });
    assert_eq!(name, "rho0");
    assert_eq!(text, "rho0 = 0.8: must be in [0.3, 0.74]");
    let bad: Vec<(PackingSpec, &str, &str)> = vec![
        (PackingSpec { rho0: 0.2, ..base }, "rho0", "rho0 = 0.2"),
        (
            PackingSpec {
                rho0: f64::NAN,
                ..base
            },
            "rho0",
            "rho0 = NaN",
        ),
        (
            PackingSpec {
                particles: 0,
                ..base
            },
            "particles",
            "particles = 0: must be in [1, 10000]",
        ),
        (
            PackingSpec {
                particles: 10_001,
                ..base
            },
            "particles",
            "particles = 10001",
        ),
        (
            PackingSpec {
                aspect_ratio: 5.5,
                ..base
            },
            "aspect_ratio",
            "aspect_ratio = 5.5: must be in [0.2, 5]",
        ),
        (
            PackingSpec {
                aspect_ratio: 0.1,
                ..base
            },
            "aspect_ratio",
            "aspect_ratio = 0.1",
        ),
        (
            PackingSpec {
                mean_radius: 0.0,
                ..base
            },
            "mean_radius",
            "mean_radius = 0: must be finite and > 0",
        ),
        (
            PackingSpec {
                mean_radius: f64::INFINITY,
                ..base
            },
            "mean_radius",
            "mean_radius = inf",
        ),
        (
            PackingSpec {
                box_aspect: [1.0, -1.0, 1.0],
                ..base
            },
            "box_aspect[1]",
            "box_aspect[1] = -1",
        ),
        (
            PackingSpec {
                distribution: SizeDistribution::Bimodal {
                    size_ratio: 1.0,
                    small_fraction: 0.5,
                },
                ..base
            },
            "size_ratio",
            "size_ratio = 1: must be in (1, 10]",
        ),
        (
            PackingSpec {
                distribution: SizeDistribution::Bimodal {
                    size_ratio: 12.0,
                    small_fraction: 0.5,
                },
                ..base
            },
            "size_ratio",
            "size_ratio = 12",
        ),
        (
            PackingSpec {
                distribution: SizeDistribution::Bimodal {
                    size_ratio: 2.0,
                    small_fraction: 1.5,
                },
                ..base
            },
            "small_fraction",
            "small_fraction = 1.5: must be in [0, 1]",
        ),
        (
            PackingSpec {
                distribution: SizeDistribution::Lognormal { sigma: 0.0 },
                ..base
            },
            "sigma",
            "sigma = 0: must be in (0, 1]",
        ),
        (
            PackingSpec {
                distribution: SizeDistribution::Lognormal { sigma: 1.5 },
                ..base
            },
            "sigma",
            "sigma = 1.5",
        ),
    ];
    for (s, want_name, want_text) in bad {
        let (name, text) = parameter_name(&s);
        assert_eq!(name, want_name, "{text}");
        assert!(
            text.starts_with(want_text),
            "{text} does not start with {want_text}"
        );
        assert!(s.validate().is_err());
    }
    assert!(base.validate().is_ok());
}

#[test]
fn a_box_smaller_than_a_particle_is_refused() {
    // One sphere at 0.6: the cube side (1.91 r) is below its diameter.
    match Packing::generate(&spec(1, 0.6, 0)) {
        Err(PackingError::BoxTooSmall {
            axis,
            length,
            extent,
        }) => {
            assert_eq!(axis, 0);
            assert!(length < extent && extent == 2.0);
        }
        other => panic!("{other:?}"),
    }
    // ... but 0.5 fits (the sphere does not reach its images).
    let s = spec(1, 0.5, 0);
    check(&Packing::generate(&s).unwrap(), &s);
}

#[test]
fn a_packing_survives_text_and_serde_round_trips() {
    let s = PackingSpec {
        aspect_ratio: 1.5,
        boundary: Boundary::Die,
        ..spec(12, 0.5, 5)
    };
    let p = Packing::generate(&s).unwrap();
    let back = Packing::from_text(&p.to_text(), p.lengths, p.boundary).unwrap();
    assert_eq!(back.particles.len(), p.particles.len());
    for (a, b) in p.particles.iter().zip(&back.particles) {
        assert_eq!(a.centre, b.centre);
        assert_eq!((a.a, a.c), (b.a, b.c));
        for k in 0..3 {
            assert!((a.axis[k] - b.axis[k]).abs() < 1e-15);
        }
    }
    // serde_json without its `float_roundtrip` feature may parse an f64 1 ulp
    // off; the structure and the values must survive.
    let json = serde_json::to_string(&p).unwrap();
    let from_json: Packing = serde_json::from_str(&json).unwrap();
    assert_eq!(from_json.boundary, p.boundary);
    assert_eq!(from_json.lengths, p.lengths);
    let close = |x: f64, y: f64| (x - y).abs() <= 4.0 * f64::EPSILON * x.abs().max(1.0);
    for (a, b) in p.particles.iter().zip(&from_json.particles) {
        for k in 0..3 {
            assert!(close(a.centre[k], b.centre[k]) && close(a.axis[k], b.axis[k]));
        }
        assert!(close(a.a, b.a) && close(a.c, b.c));
    }
}
