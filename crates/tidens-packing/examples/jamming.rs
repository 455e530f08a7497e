//! Jammed packings from `Packing::jam`: density, coordination numbers and
//! wall time.
//!
//! `cargo run --release -p tidens-packing --example jamming [seeds]`: for 8,
//! 16, 32 and 64 monodisperse spheres and 32 bimodal spheres (size ratio
//! 1.566, half small), periodic, `seeds` seeds each (default 5), a line per
//! packing and a summary per case: the jamming density, the coordination
//! number of all particles and of the rattler-free backbone (contacts: gap
//! at most 1e-5 mean radii) and the wall time.
//!
//! `cargo run --release -p tidens-packing --example jamming gaps [n] [seed]`:
//! the distribution of the pair gaps of one jammed packing of `n`
//! monodisperse spheres (default 32, seed 0), by decade of gap / mean radius,
//! to see where contacts end.

use std::time::Instant;

use tidens_packing::{Packing, PackingSpec, RHO0_MAX, SizeDistribution};

/// Contact tolerance relative to the mean radius.
const CONTACT: f64 = 1e-5;

fn spec(particles: usize, distribution: SizeDistribution, seed: u64) -> PackingSpec {
    PackingSpec {
        particles,
        distribution,
        rho0: RHO0_MAX,
        seed,
        ..PackingSpec::default()
    }
}

fn gaps(n: usize, seed: u64) {
    let s = spec(n, SizeDistribution::Monodisperse, seed);
    let p = Packing::jam(&s).expect("jam");
    println!(
        "# {n} spheres, seed {seed}: rel_density {:.6}, max overlap {:.1e} mean radii",
        p.rel_density(),
        p.max_overlap() / s.mean_radius
    );
    println!("# pairs by gap / mean radius (gap <= 0.1), per decade");
    let mut counts = [0usize; 17];
    for c in p.contacts(0.1 * s.mean_radius) {
        let g = c.gap / s.mean_radius;
        let k = if g <= 0.0 {
            0
        } else {
            ((g.log10().floor() + 17.0).max(1.0) as usize).min(16)
        };
        counts[k] += 1;
    }
    println!("{:>22} {:>5}", "<= 0", counts[0]);
    for (k, &c) in counts.iter().enumerate().skip(1) {
        let lo = 10f64.powi(k as i32 - 17);
        println!("[{lo:.0e}, {:.0e}) {c:>5}", 10.0 * lo);
    }
}

/// Mean, smallest and largest.
fn stats(v: &[f64]) -> (f64, f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (mean, lo, hi)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("gaps") {
        let n = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(32);
        let seed = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(0);
        gaps(n, seed);
        return;
    }
    let seeds: u64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(5);
    let bimodal = SizeDistribution::Bimodal {
        size_ratio: 1.566,
        small_fraction: 0.5,
    };
    let cases = [
        ("mono", 8, SizeDistribution::Monodisperse),
        ("mono", 16, SizeDistribution::Monodisperse),
        ("mono", 32, SizeDistribution::Monodisperse),
        ("mono", 64, SizeDistribution::Monodisperse),
        ("bimodal", 32, bimodal),
    ];
    println!(
        "# Packing::jam, rho0 = {RHO0_MAX}, periodic cube; contacts: gap <= {CONTACT:.0e} mean radii"
    );
    println!(
        "{:<8} {:>3} {:>4} {:>9} {:>6} {:>6} {:>8} {:>8} {:>9}",
        "case", "n", "seed", "rho_J", "Z", "Z_bb", "rattlers", "time_s", "overlap"
    );
    let mut summary = Vec::new();
    for (label, n, distribution) in cases {
        let (mut rho, mut z, mut zbb, mut time) = (vec![], vec![], vec![], vec![]);
        for seed in 0..seeds {
            let s = spec(n, distribution, seed);
            let start = Instant::now();
            let p = Packing::jam(&s).expect("jam");
            let t = start.elapsed().as_secs_f64();
            let tol = CONTACT * s.mean_radius;
            let rattlers = p.rattlers(tol).iter().filter(|&&r| r).count();
            println!(
                "{label:<8} {n:>3} {seed:>4} {:>9.6} {:>6.3} {:>6.3} {rattlers:>8} {t:>8.3} {:>9.1e}",
                p.rel_density(),
                p.coordination_number(tol),
                p.backbone_coordination_number(tol),
                p.max_overlap() / s.mean_radius
            );
            rho.push(p.rel_density());
            z.push(p.coordination_number(tol));
            zbb.push(p.backbone_coordination_number(tol));
            time.push(t);
        }
        summary.push((label, n, stats(&rho), stats(&z), stats(&zbb), stats(&time)));
    }
    println!("\n# mean (min-max) over {seeds} seeds");
    println!(
        "{:<8} {:>3} {:>26} {:>20} {:>20} {:>22}",
        "case", "n", "rho_J", "Z", "Z_bb", "time_s"
    );
    for (label, n, r, z, zb, t) in summary {
        println!(
            "{label:<8} {n:>3} {:>8.4} ({:.4}-{:.4}) {:>6.2} ({:.2}-{:.2}) {:>6.2} ({:.2}-{:.2}) {:>6.2} ({:.2}-{:.2})",
            r.0, r.1, r.2, z.0, z.1, z.2, zb.0, zb.1, zb.2, t.0, t.1, t.2
        );
    }
}
