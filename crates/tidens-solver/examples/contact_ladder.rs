//! Both particle-contact formulations on the same ladder of mesh levels:
//! Ti-6Al-4V at 1293 K, 15 MPa (1 s ramp), pressed to rho = 0.95.
//!
//!     cargo run --release -p tidens-solver --example contact_ladder -- CELL FORMULATION LEVEL [TOLERANCE] [UNTIL]
//!
//! CELL: bcc, fcc, sc2; FORMULATION: node-to-facet, mortar. Prints each
//! step's Newton iterations and the run's totals, and t(0.8), t(0.9),
//! t(0.95).
//!
//! Environment: `LADDER_VERBOSE` prints every step; `LADDER_RTOL`,
//! `LADDER_PENALTY_FACTOR` set Newton's residual tolerance and the
//! penalty factor; `LADDER_GAPS` prints the smallest mean gaps at the
//! start; `LADDER_FD=shift` (and `LADDER_FD_H`) checks the mortar tangent
//! against finite differences with the second particle moved by `shift`
//! mm; `LADDER_DEEP=t` runs to the time `t` \[s\] and prints the node
//! deepest inside another particle, the facet it is under and the mean
//! gaps of the nodes around it.
use std::time::Instant;
use tidens_solver::{
    Cell, ContactFormulation, LoadHistory, MeshOptions, Preset, Scene, Settings, Simulation,
};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cell = match args.get(1).map(String::as_str).unwrap_or("bcc") {
        "fcc" => Cell::fcc(0.05, 1.0).unwrap(),
        "sc2" => Cell::sc2(0.05, 1.566, 1.0).unwrap(),
        _ => Cell::bcc(0.05, 1.0).unwrap(),
    };
    let formulation = match args.get(2).map(String::as_str).unwrap_or("mortar") {
        "node-to-facet" => ContactFormulation::NodeToFacet,
        _ => ContactFormulation::Mortar,
    };
    let level: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(2);
    let tolerance: f64 = args
        .get(4)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.02 * 2f64.powi(3 - level as i32));
    let until: f64 = args.get(5).and_then(|s| s.parse().ok()).unwrap_or(0.95);
    let verbose = std::env::var("LADDER_VERBOSE").is_ok();
    let options = MeshOptions {
        level,
        ..MeshOptions::default()
    };
    let scene = Scene::from_cell(&cell, &options).unwrap();
    let mut settings = Settings::new(LoadHistory {
        stress: 15.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(until);
    settings.tolerance = tolerance;
    settings.contact.formulation = formulation;
    if let Some(r) = std::env::var("LADDER_RTOL")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        settings.newton.residual_tolerance = r;
    }
    if let Some(f) = std::env::var("LADDER_PENALTY_FACTOR")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        settings.contact.penalty_factor = f;
    }
    let t0 = Instant::now();
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    if std::env::var("LADDER_GAPS").is_ok() {
        let c = sim.particle_contact().unwrap();
        let x = sim.coordinates();
        let mut m = c.as_mortar().unwrap().clone();
        m.pair(&x);
        let mut gaps = m.mean_gaps(&x);
        gaps.sort_by(|a, b| a.3.total_cmp(&b.3));
        for g in gaps.iter().take(40).step_by(3) {
            println!("gap {:?}", g);
        }
        println!("search distance h = {}", c.settings().search_distance);
        return;
    }
    if std::env::var("LADDER_FD").is_ok() {
        let c = sim.particle_contact().unwrap();
        let mut x = sim.coordinates();
        let mut m = c.as_mortar().unwrap().clone();
        m.pair(&x);
        // The second particle's nodes moved toward the first along the diagonal.
        let shift: f64 = std::env::var("LADDER_FD").unwrap().parse().unwrap_or(2e-5);
        let s1 = &m.surfaces()[1];
        let first = *s1.nodes.iter().min().unwrap();
        let n = x.len() / 3;
        for (i, sf) in m.surfaces().iter().enumerate() {
            let c: [f64; 3] = std::array::from_fn(|c| {
                sf.nodes.iter().map(|&k| x[3 * k + c]).sum::<f64>() / sf.nodes.len() as f64
            });
            let f = sf.facets[0];
            let p: Vec<[f64; 3]> = f
                .iter()
                .map(|&k| [x[3 * k], x[3 * k + 1], x[3 * k + 2]])
                .collect();
            let a: [f64; 3] = std::array::from_fn(|c| p[2][c] - p[0][c]);
            let b: [f64; 3] = std::array::from_fn(|c| p[3][c] - p[1][c]);
            let nrm = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            println!("surface {i} facet 0 at {:?} normal {:?}", p[0], nrm);
            println!(
                "surface {i}: nodes {}..{} centroid {:?}",
                sf.nodes.iter().min().unwrap(),
                sf.nodes.iter().max().unwrap(),
                c
            );
        }
        for k in first..n {
            for c in 0..3 {
                x[3 * k + c] -= shift / 3f64.sqrt();
            }
        }
        let ev = m.evaluate(&x, true);
        let pressed: Vec<_> = ev.terms.iter().filter(|t| t.pressure > 0.0).collect();
        println!("{} terms, {} pressed", ev.terms.len(), pressed.len());
        let mut pens: Vec<f64> = ev.terms.iter().map(|t| t.penetration).collect();
        pens.sort_by(f64::total_cmp);
        println!("penetrations {:?}", pens);
        let mut gaps = m.mean_gaps(&x);
        gaps.sort_by(|a, b| a.3.total_cmp(&b.3));
        println!(
            "mean gaps {:?}",
            gaps.iter().take(6).map(|g| g.3).collect::<Vec<_>>()
        );
        for g in gaps.iter().take(8) {
            let node = m.surfaces()[g.0].nodes[g.1];
            println!(
                "  slave {} node {} at {:?} gap {:e}",
                g.0,
                node,
                &x[3 * node..3 * node + 3],
                g.3
            );
        }
        // Global force and tangent as maps.
        let force = |x: &[f64]| {
            let e = m.evaluate(x, false);
            let mut f = std::collections::BTreeMap::new();
            for t in &e.terms {
                for (d, v) in t.dofs.iter().zip(&t.force) {
                    *f.entry(*d).or_insert(0.0) += v;
                }
            }
            f
        };
        let mut k = std::collections::BTreeMap::new();
        for t in &ev.terms {
            let nd = t.dofs.len();
            for a in 0..nd {
                for b in 0..nd {
                    *k.entry((t.dofs[a], t.dofs[b])).or_insert(0.0) += t.tangent[a * nd + b];
                }
            }
        }
        let f0 = force(&x);
        let sum: [f64; 3] =
            std::array::from_fn(|c| f0.iter().filter(|(d, _)| *d % 3 == c).map(|(_, v)| v).sum());
        println!(
            "force sum {:?}, max |f| {:e}",
            sum,
            f0.values().fold(0.0f64, |a, b| a.max(b.abs()))
        );
        let dofs: Vec<usize> = f0.keys().copied().collect();
        let h: f64 = std::env::var("LADDER_FD_H")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(1e-9);
        let mut worst = 0.0f64;
        let mut scale = 0.0f64;
        for &d in dofs.iter().step_by(7) {
            let mut xp = x.clone();
            xp[d] += h;
            let mut xm = x.clone();
            xm[d] -= h;
            let (fp, fm) = (force(&xp), force(&xm));
            for &e in &dofs {
                let fd = (fp.get(&e).unwrap_or(&0.0) - fm.get(&e).unwrap_or(&0.0)) / (2.0 * h);
                let kk = *k.get(&(e, d)).unwrap_or(&0.0);
                if (fd - kk).abs() > worst {
                    println!("  worse: row {e} col {d}: fd {fd:e} tangent {kk:e}");
                }
                worst = worst.max((fd - kk).abs());
                scale = scale.max(fd.abs());
            }
        }
        println!("tangent vs FD: worst {worst:e} of {scale:e}");
        return;
    }
    if let Some(t_deep) = std::env::var("LADDER_DEEP")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
    {
        while sim.curve().last().is_none_or(|p| p.time < t_deep) {
            sim.advance().unwrap();
        }
        let c = sim.particle_contact().unwrap();
        let x = sim.coordinates();
        let d = c.deepest(&x).unwrap();
        println!("{d:?}");
        let sf = &c.surfaces()[d.slave];
        let n = sf.nodes[d.node];
        println!("node {n} at {:?}", &x[3 * n..3 * n + 3]);
        let mf = &c.surfaces()[d.master];
        for &k in &mf.facets[d.facet] {
            println!("  master facet node {k} at {:?}", &x[3 * k..3 * k + 3]);
        }
        let mut m = c.as_mortar().unwrap().clone();
        m.pair(&x);
        let ring: std::collections::BTreeSet<usize> = sf
            .facets
            .iter()
            .filter(|f| f.contains(&n))
            .flatten()
            .copied()
            .collect();
        for g in m.mean_gaps(&x) {
            let node = sf.nodes[g.1];
            if g.0 == d.slave && ring.contains(&node) && g.2 == d.master {
                println!(
                    "  ring node {node} at {:?}: mean gap {:e}",
                    &x[3 * node..3 * node + 3],
                    g.3
                );
            }
            if g.0 == d.slave && g.1 == d.node {
                println!("mean gap of the node on {}: {:e}", g.2, g.3);
            }
        }
        let ev = m.evaluate(&x, false);
        for t in &ev.terms {
            if t.slave == (d.slave, d.node) {
                println!(
                    "term: pressure {} penetration {:e}",
                    t.pressure, t.penetration
                );
            }
        }
        // Neighbours: slave facets holding the node.
        for (fi, f) in sf.facets.iter().enumerate() {
            if f.contains(&n) {
                println!("  slave facet {fi}: {:?}", f);
            }
        }
        return;
    }
    let mut marks = vec![0.8, 0.9, 0.95];
    let mut times = Vec::new();
    let mut last = (0.0, sim.rel_density());
    loop {
        match sim.advance() {
            Ok(p) => {
                let p = p.clone();
                if verbose {
                    println!(
                        "step {} t {:.4e} rho {:.5} it {} pen {:.2e} depth {:.2e}",
                        p.step,
                        p.time,
                        p.rel_density,
                        p.newton_iterations,
                        p.max_penetration,
                        p.max_depth
                    );
                }
                while !marks.is_empty() && p.rel_density >= marks[0] {
                    let r = marks.remove(0);
                    let t = last.0 + (r - last.1) / (p.rel_density - last.1) * (p.time - last.0);
                    times.push((r, t));
                }
                last = (p.time, p.rel_density);
            }
            Err(e) => {
                println!("FAILED: {e}");
                break;
            }
        }
        if sim.status() != tidens_solver::Status::Running {
            break;
        }
    }
    let s = sim.stats();
    println!(
        "{} {:?} level {level} tol {tolerance}: dofs {} steps {} newton {} ({:.2}/step) factorizations {} ({:.2}/step) failed {} pattern rebuilds {} wall {:.1} s (linear {:.1}, elements {:.1}, contact {:.1}) times {:?} max pen {:.2e}",
        args.get(1).map(String::as_str).unwrap_or("bcc"),
        formulation,
        sim.degrees_of_freedom(),
        s.steps,
        s.newton_iterations,
        s.newton_iterations as f64 / s.steps.max(1) as f64,
        s.factorizations.llt + s.factorizations.lblt,
        (s.factorizations.llt + s.factorizations.lblt) as f64 / s.steps.max(1) as f64,
        s.failed_attempts,
        s.pattern_rebuilds,
        t0.elapsed().as_secs_f64(),
        s.linear_seconds,
        s.evaluation_seconds,
        s.contact_seconds,
        times,
        sim.curve()
            .iter()
            .map(|p| p.max_penetration)
            .fold(0.0, f64::max),
    );
}
