//! Times `Packing::generate` and prints the densest reachable density.
//!
//! `cargo run --release -p tidens-packing --example pack_timing [seeds]`
//! `cargo run --release -p tidens-packing --example pack_timing large [n...]`
//!
//! `large`: monodisperse spheres at rho0 = 0.6 and 0.62 for the given
//! particle counts (default 1000 and 4000).
//!
//! For each case: the time to pack to rho0 = 0.62 (monodisperse spheres:
//! 8, 16, 32, 64 particles), then, per case and size, the density reached
//! when asking for 0.74 (the generator reports the densest overlap-free
//! density it found in the error).

use std::time::Instant;

use tidens_packing::{Boundary, Packing, PackingError, PackingSpec, SizeDistribution};

fn pack(spec: &PackingSpec) -> (Result<Packing, PackingError>, f64) {
    let start = Instant::now();
    let result = Packing::generate(spec);
    (result, start.elapsed().as_secs_f64())
}

fn large(counts: &[usize]) {
    for &n in counts {
        for rho0 in [0.6, 0.62] {
            let spec = PackingSpec {
                particles: n,
                rho0,
                ..PackingSpec::default()
            };
            match pack(&spec) {
                (Ok(p), t) => println!(
                    "n {n:>5} rho0 {rho0}: {t:.2} s, max overlap {:.1e} mm",
                    p.max_overlap()
                ),
                (Err(e), t) => println!("n {n:>5} rho0 {rho0}: {t:.2} s, FAILED: {e}"),
            }
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("large") {
        let counts: Vec<usize> = args[2..].iter().filter_map(|a| a.parse().ok()).collect();
        large(if counts.is_empty() {
            &[1000, 4000]
        } else {
            &counts
        });
        return;
    }
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    println!("# time to pack monodisperse spheres (periodic) to rho0 = 0.62");
    for n in [8, 16, 32, 64] {
        for seed in 0..seeds {
            let spec = PackingSpec {
                particles: n,
                rho0: 0.62,
                seed,
                ..PackingSpec::default()
            };
            match pack(&spec) {
                (Ok(p), t) => println!(
                    "n {n:>3} seed {seed}: {t:.3} s, rel_density {:.12}, max overlap {:.1e} mm",
                    p.rel_density(),
                    p.max_overlap()
                ),
                (Err(e), t) => println!("n {n:>3} seed {seed}: {t:.3} s, FAILED: {e}"),
            }
        }
    }
    let cases = [
        ("monodisperse spheres", SizeDistribution::Monodisperse, 1.0),
        (
            "bimodal 1.566 / 0.5 spheres",
            SizeDistribution::Bimodal {
                size_ratio: 1.566,
                small_fraction: 0.5,
            },
            1.0,
        ),
        (
            "monodisperse spheroids c/a = 2",
            SizeDistribution::Monodisperse,
            2.0,
        ),
    ];
    for boundary in [Boundary::Periodic, Boundary::Die] {
        println!("\n# {boundary:?}: rho0 = 0.62, then the density reached when asking for 0.74");
        for (label, distribution, aspect_ratio) in cases {
            for n in [16, 64] {
                for seed in 0..seeds {
                    let spec = PackingSpec {
                        particles: n,
                        distribution,
                        aspect_ratio,
                        rho0: 0.62,
                        boundary,
                        seed,
                        ..PackingSpec::default()
                    };
                    let (r62, t62) = pack(&spec);
                    let at62 = match r62 {
                        Ok(_) => "ok".to_string(),
                        Err(PackingError::Rho0Unreachable { reached, .. }) => {
                            format!("jammed at {reached:.4}")
                        }
                        Err(e) => format!("{e}"),
                    };
                    let (rmax, tmax) = pack(&PackingSpec { rho0: 0.74, ..spec });
                    let max = match rmax {
                        Ok(_) => "0.74 reached".to_string(),
                        Err(PackingError::Rho0Unreachable { reached, .. }) => {
                            format!("{reached:.4}")
                        }
                        Err(e) => format!("{e}"),
                    };
                    println!(
                        "{label:<32} n {n:>3} seed {seed}: 0.62 {at62} in {t62:.3} s; densest {max} in {tmax:.3} s"
                    );
                }
            }
        }
    }
}
