//! Particle-particle contact (issue: contact between particles, every cell).

#[path = "support/cells.rs"]
mod cells;

use cells::stacked_pair;
use tidens_fem::ElementKind;
use tidens_solver::{
    Cell, ContactFormulation, ContactMode, LoadHistory, MeshOptions, Preset, Scene, Settings,
    Simulation, Status,
};

fn press(cell: &Cell, level: u32, until_density: f64, mode: ContactMode) -> (Scene, Simulation) {
    press_with(cell, level, until_density, mode, ElementKind::Hex8)
}

fn press_with(
    cell: &Cell,
    level: u32,
    until_density: f64,
    mode: ContactMode,
    element: ElementKind,
) -> (Scene, Simulation) {
    let scene = Scene::from_cell(
        cell,
        &MeshOptions {
            level,
            grading: 1.0,
            ..MeshOptions::default()
        },
    )
    .unwrap()
    .with_element(element)
    .unwrap();
    let mut settings = Settings::new(LoadHistory {
        stress: 15.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(until_density);
    settings.tolerance = 0.05;
    settings.contact.mode = mode;
    let sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    (scene, sim)
}

/// Two identical octants pressed together along an axis deform
/// mirror-symmetrically, their contact surface stays a plane (the mid-plane
/// of the cell), and the pair densifies like the sc cell whose mirror plane
/// that contact replaces.
#[test]
fn identical_octants_pressed_along_an_axis_deform_mirror_symmetrically() {
    pair_deforms_mirror_symmetrically(ElementKind::Hex8, 0.62, 0.6);
}

/// The same with quadratic tetrahedra, in contact on the flat triangles of
/// their 6-node faces, pressed a shorter way (PAIR_UNTIL, default 0.56):
/// each of their steps that brings nodes into contact takes 15 to 25
/// Newton iterations on the pair's larger system (to 0.62, 40 s).
#[test]
fn identical_tet10_octants_pressed_along_an_axis_deform_mirror_symmetrically() {
    let until: f64 = std::env::var("PAIR_UNTIL").map_or(0.56, |v| v.parse().unwrap());
    pair_deforms_mirror_symmetrically(ElementKind::Tet10, until, until - 0.01);
}

/// Presses the stacked pair and the sc cell to `until` and compares them
/// at the density `mark`.
fn pair_deforms_mirror_symmetrically(element: ElementKind, until: f64, mark: f64) {
    let r = 0.05;
    let level: u32 = std::env::var("PAIR_LEVEL").map_or(1, |v| v.parse().unwrap());
    let (scene, mut pair) = press_with(
        &stacked_pair(r),
        level,
        until,
        ContactMode::Frictionless,
        element,
    );
    let mut worst_pen: f64 = 0.0;
    let status = pair
        .run(|p| {
            worst_pen = worst_pen.max(p.max_penetration);
            true
        })
        .unwrap();
    assert_eq!(status, Status::ReachedDensity);
    assert!(worst_pen < 1e-4 * r, "penetration {worst_pen:e} mm");
    let f = pair.fields();
    let lz = scene.lengths[2] + pair.curve().last().unwrap().piston_displacement;
    let (bottom, top) = (&scene.particles[0], &scene.particles[1]);
    // Each node of the bottom particle and the node of the top one at its
    // mirror image in the reference configuration stay mirror images.
    let x0 = scene.nodes();
    let lz0 = scene.lengths[2];
    // The node of the top particle nearest the mirror image of `n`, and
    // how far from the image it is.
    let image = |n: usize| {
        let p = x0[n];
        let d = |m: usize| {
            let q = x0[m];
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] + q[2] - lz0).powi(2)).sqrt()
        };
        let m = (top.nodes.0..top.nodes.0 + top.nodes.1)
            .min_by(|&a, &b| d(a).total_cmp(&d(b)))
            .unwrap();
        (m, d(m))
    };
    let mut asym: f64 = 0.0;
    for k in 0..bottom.nodes.1 {
        let n = bottom.nodes.0 + k;
        let (m, off) = image(n);
        assert!(off < 1e-12 * r, "node {n} has no mirror image");
        let (p, q) = (f.points[n], f.points[m]);
        asym = asym
            .max((p[0] - q[0]).abs())
            .max((p[1] - q[1]).abs())
            .max((p[2] + q[2] - lz).abs());
    }
    // Hexahedra: the two meshes are mirror images element by element, so
    // the deformation is symmetric to round-off (measured 1.7e-15 R at
    // level 1). Tetrahedra: the nodes are mirror images but the cut of each
    // hexahedron into six is not (the mirror image of its diagonal is the
    // other diagonal), so the discretisations differ by O(h^2): measured
    // 4.1e-3 R at level 1 and 6.2e-4 R at level 2 (PAIR_LEVEL=2). Before
    // the weight of a fold between facets sharing a corner took their far
    // corners' elevations (the `fold` module of `tidens-contact`), 2.6e-6
    // R at level 1 and 3.9e-4 R at level 2.
    // The tetrahedra's bounds are twice what they measure: to rho = 0.62,
    // 4.1e-3 R and 4.8e-4 R (below); to 0.56, 9.8e-4 R and 9.5e-5 R (the
    // asymmetry grows with the deformation).
    let (asym_tol, flat_tol) = match element {
        ElementKind::Hex8 => (1e-12 * r, 1e-6 * r),
        ElementKind::Tet10 if until <= 0.56 => (2e-3 * r, 2e-4 * r),
        ElementKind::Tet10 => (8e-3 * r, 1e-3 * r),
    };
    assert!(asym < asym_tol, "mirror asymmetry {asym:e} mm");
    eprintln!("mirror asymmetry {:.2e} R", asym / r);
    // Nodes in contact lie on the mid-plane.
    let mid = 0.5 * lz;
    let mut flat: f64 = 0.0;
    let mut pressed = 0;
    for t in pair.contact_terms().iter().filter(|t| t.pressure > 0.0) {
        flat = flat.max((f.points[t.dofs[0] / 3][2] - mid).abs());
        pressed += 1;
    }
    assert!(pressed >= 4, "only {pressed} nodes in contact");
    // Hexahedra: off by the penetration the penalty leaves (measured
    // 1.4e-7 R); tetrahedra: by their asymmetry (4.8e-4 R).
    assert!(
        flat < flat_tol,
        "contact surface off the mid-plane by {flat:e} mm"
    );
    // Against the sc cell on the same mesh: the contact replaces its mirror plane.
    let (_, mut sc) = press_with(
        &Cell::sc(r, 1.0).unwrap(),
        1,
        until,
        ContactMode::Frictionless,
        element,
    );
    sc.run(|_| true).unwrap();
    let t_at = |sim: &Simulation, rho: f64| {
        let c = sim.curve();
        let k = c.iter().position(|p| p.rel_density >= rho).unwrap();
        let (a, b) = (&c[k - 1], &c[k]);
        a.time + (rho - a.rel_density) / (b.rel_density - a.rel_density) * (b.time - a.time)
    };
    let (tp, ts) = (t_at(&pair, mark), t_at(&sc, mark));
    eprintln!(
        "t({mark}): pair {tp:.4} s, sc {ts:.4} s; contact surface off the mid-plane by {:.2e} R",
        flat / r
    );
    assert!(
        (tp / ts - 1.0).abs() < 0.05,
        "t({mark}): pair {tp:.3} s, sc {ts:.3} s"
    );
}

/// The force through the contact balances the piston force at every
/// converged step (bcc: the top particle is pushed by the piston and held by
/// the bottom one; the die walls take no vertical force), and every
/// particle is in equilibrium under contact and plane forces.
#[test]
fn contact_force_balances_the_piston_force_at_every_step() {
    contact_force_balances(ElementKind::Hex8, ContactFormulation::NodeToFacet, 0.72, 10);
}

/// The same with mortar contact: its forces are the gradient of one energy
/// of the weighted gaps, so they balance as node-to-facet's do (7 steps to
/// 0.72, each converged to 1e-7).
#[test]
fn mortar_contact_force_balances_the_piston_force_at_every_step() {
    contact_force_balances(ElementKind::Hex8, ContactFormulation::Mortar, 0.72, 5);
}

/// The same with quadratic tetrahedra, to rho = 0.70 (the contact set
/// grows at every step, each converged to 1e-7: 10 steps, 14 s; to 0.72,
/// 13 steps and 20 s).
#[test]
fn tet10_contact_force_balances_the_piston_force_at_every_step() {
    contact_force_balances(ElementKind::Tet10, ContactFormulation::NodeToFacet, 0.70, 8);
}

/// Presses bcc to `until` and checks the balance at each of more than
/// `min_steps` steps.
fn contact_force_balances(
    element: ElementKind,
    formulation: ContactFormulation,
    until: f64,
    min_steps: usize,
) {
    let cell = Cell::bcc(0.05, 1.0).unwrap();
    let (scene, sim) = press_with(&cell, 1, until, ContactMode::Frictionless, element);
    // Balance holds to what Newton leaves: converge it well below the bound
    // checked (the default leaves 1e-4 of the piston force per equation).
    let mut settings = sim.settings().clone();
    settings.newton.residual_tolerance = 1e-7;
    settings.contact.formulation = formulation;
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    let area = scene.lengths[0] * scene.lengths[1];
    let mut steps = 0;
    let mut worst: f64 = 0.0;
    let mut last_rho = 0.0;
    while sim.status() == Status::Running {
        let p = sim.advance().unwrap().clone();
        assert!(
            p.rel_density >= last_rho - 1e-12,
            "density fell at t = {}",
            p.time
        );
        assert!(
            p.max_penetration < 1e-4 * 0.05,
            "penetration {:e} mm",
            p.max_penetration
        );
        last_rho = p.rel_density;
        let piston = p.cell_stress * area;
        let forces = sim.particle_forces(&scene);
        let (contact, planes) = forces[1];
        worst = worst.max((contact[2] - piston).abs() / piston);
        for (c, pl) in &forces {
            for i in 0..3 {
                assert!(
                    (c[i] + pl[i]).abs() <= 1e-5 * piston,
                    "particle out of equilibrium"
                );
            }
        }
        // The piston is the only vertical plane force on the top particle.
        assert!((planes[2] + piston).abs() <= 1e-5 * piston);
        steps += 1;
    }
    assert!(steps > min_steps, "{steps} steps");
    assert!(
        worst < 1e-5,
        "contact force off the piston force by {worst:e} (relative)"
    );
    assert_eq!(sim.status(), Status::ReachedDensity);
}

/// fcc: the four octants are equivalent by symmetry, so their plastic
/// strain agrees (to the contact's slave-master asymmetry); sc-2: the small particles deform more than the large ones.
///
/// fcc is pressed to 0.8: earlier the octants' plastic strains are small
/// and the asymmetry weighs more (spread 2.1e-3 at 0.77, 7.7e-3 at 0.76).
/// sc-2 from 0.600 to 0.61 shows the sizes as clearly as to 0.65 (small
/// over large 6.9 against 6.1, one size alike to 1e-13).
#[test]
fn plastic_strain_follows_the_symmetry_and_the_sizes() {
    let mean_eqps = |scene: &Scene, sim: &Simulation| -> Vec<(f64, f64)> {
        let f = sim.fields();
        scene
            .particles
            .iter()
            .map(|p| {
                let e = &f.element.eqps[p.elements.0..p.elements.0 + p.elements.1];
                let mean = e.iter().sum::<f64>() / e.len() as f64;
                let max = e.iter().cloned().fold(0.0, f64::max);
                (mean, max)
            })
            .collect()
    };
    let (scene, mut fcc) = press(
        &Cell::fcc(0.05, 1.0).unwrap(),
        1,
        0.8,
        ContactMode::Frictionless,
    );
    fcc.run(|_| true).unwrap();
    let e = mean_eqps(&scene, &fcc);
    let (lo, hi) = e.iter().fold((f64::INFINITY, 0.0_f64), |(a, b), x| {
        (a.min(x.0), b.max(x.0))
    });
    // Not to round-off: each touching pair has a slave and a master side,
    // and which side is which differs between the octants (measured 6.0e-4
    // at level 1).
    assert!(hi / lo - 1.0 < 1e-3, "fcc mean plastic strains {e:?}");
    let (scene, mut sc2) = press(
        &Cell::sc2(0.05, 1.566, 1.0).unwrap(),
        1,
        0.61,
        ContactMode::Frictionless,
    );
    sc2.run(|_| true).unwrap();
    let e = mean_eqps(&scene, &sc2);
    let cell = Cell::sc2(0.05, 1.566, 1.0).unwrap();
    let (mut large, mut small) = (Vec::new(), Vec::new());
    for (p, v) in scene.particles.iter().zip(&e) {
        if cell.octants[p.octant].a > 0.04 {
            large.push(v.0)
        } else {
            small.push(v.0)
        }
    }
    let (l, s) = (
        large.iter().cloned().fold(0.0, f64::max),
        small.iter().cloned().fold(f64::INFINITY, f64::min),
    );
    assert!(
        s > 1.2 * l,
        "sc-2: smallest mean eqps of small particles {s:.4} vs largest of large {l:.4}"
    );
    // Particles of one size deform alike, to the round-off accumulated over
    // the steps (measured 4e-12).
    for group in [&large, &small] {
        let (a, b) = group
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(a, b), x| (a.min(*x), b.max(*x)));
        assert!(b / a - 1.0 < 1e-9, "particles of one size: {group:?}");
    }
}

/// Tied contact transmits shear, frictionless contact none: the force on a
/// frictionless slave node is along the normal of its master facet.
#[test]
fn tied_contact_transmits_shear_and_frictionless_contact_none() {
    let cell = Cell::bcc(0.05, 1.0).unwrap();
    let tangential_ratio = |mode| {
        let (_, mut sim) = press(&cell, 1, 0.74, mode);
        sim.run(|_| true).unwrap();
        let f = sim.fields();
        let mut worst: f64 = 0.0;
        for t in sim.contact_terms().iter().filter(|t| t.pressure > 0.0) {
            // Normal of the bilinear facet at the slave's projection.
            let q = [1, 2, 3, 4].map(|c| f.points[t.dofs[3 * c] / 3]);
            let [xi, eta] = t.location;
            let corners = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
            let (mut dxi, mut deta) = ([0.0; 3], [0.0; 3]);
            for (a, c) in corners.iter().enumerate() {
                for i in 0..3 {
                    dxi[i] += 0.25 * c[0] * (1.0 + c[1] * eta) * q[a][i];
                    deta[i] += 0.25 * (1.0 + c[0] * xi) * c[1] * q[a][i];
                }
            }
            let n = cross(dxi, deta);
            let nn = dot(n, n).sqrt();
            let force = [t.force[0], t.force[1], t.force[2]];
            let fn_ = dot(force, n) / nn;
            let ft = (dot(force, force) - fn_ * fn_).max(0.0).sqrt();
            worst = worst.max(ft / dot(force, force).sqrt());
        }
        worst
    };
    let frictionless = tangential_ratio(ContactMode::Frictionless);
    let tied = tangential_ratio(ContactMode::Tied);
    assert!(
        frictionless < 1e-6,
        "frictionless contact carries shear: {frictionless:e}"
    );
    assert!(tied > 0.05, "tied contact carries no shear: {tied:e}");
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Sensitivity option: tying the particle to the die walls where it touches
/// them blocks the lateral spreading that the mirror symmetry needs, so the
/// sc cell densifies more slowly.
#[test]
fn tying_the_particle_to_the_walls_slows_densification() {
    let run = |tied_planes: bool| {
        let cell = Cell::sc(0.05, 1.0).unwrap();
        let scene = Scene::from_cell(
            &cell,
            &MeshOptions {
                level: 1,
                grading: 1.0,
                ..MeshOptions::default()
            },
        )
        .unwrap();
        let mut settings = Settings::new(LoadHistory {
            stress: 15.0,
            knockdown: 1.0,
            ramp_time: 1.0,
        });
        settings.until_density = Some(0.9);
        settings.tolerance = 0.05;
        settings.contact.tied_planes = tied_planes;
        let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
        sim.run(|_| true).unwrap();
        sim.time()
    };
    let t_free = run(false);
    let t_tied = run(true);
    eprintln!("t(0.9): tied {t_tied:.2} s, frictionless {t_free:.2} s");
    assert!(
        t_tied > 1.1 * t_free,
        "t(0.9): tied {t_tied:.2} s, frictionless {t_free:.2} s"
    );
}

/// One whole sphere in a periodic cube of side 2R, its mesh turned off the
/// cube's axes: it touches its six images facet to facet, each contact
/// open by the faceting (4.8e-4 mm, 1e-2 R, at level 1). The touch force
/// carried the load until they closed; with the touch stiffness in the
/// tangent alone the run failed at its fifteenth step (t = 1e-7 s, the
/// residual the whole piston force at every iterate). Such gaps are now
/// closed at the start (`ParticleContact::close_initial_gaps`, below a
/// tenth of the search distance), and this run starts from closed
/// contacts.
#[test]
fn a_periodic_sphere_whose_contacts_start_open_carries_the_load() {
    use tidens_solver::PlacedSpheroid;
    let r = 0.05;
    let scene = Scene::periodic(
        [2.0 * r; 3],
        &[PlacedSpheroid {
            centre: [r; 3],
            a: r,
            c: r,
            axis: [0.31, 0.17, 1.0],
        }],
        &MeshOptions {
            level: 1,
            grading: 1.0,
            exact_volume: false,
        },
    )
    .unwrap();
    let mut settings = Settings::new(LoadHistory {
        stress: 10.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_time = Some(2e-3);
    let mut sim = Simulation::new(&scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    let rho0 = sim.curve()[0].rel_density;
    while sim.status() == Status::Running {
        sim.advance().unwrap();
    }
    let last = sim.curve().last().unwrap().clone();
    assert!((last.time - 2e-3).abs() < 1e-12, "{}", last.time);
    // The contacts closed and press, and no node went into an image. (The
    // drag takes 0.28 of the load in the first step (of 0.02 s), whose
    // reference motion has no affine part yet to follow, 0.20 down to 0.05
    // in the nine short steps after it, then 0.015 to 0.05 (once 0.10) to
    // t = 0.05 s.)
    assert!(last.particle_contacts > 0);
    assert!(last.max_depth < 1e-4 * r, "{}", last.max_depth);
    assert!(last.rel_density > rho0);
}

/// The density at which `curve` reaches `rho`, interpolated in time \[s\].
fn time_at_density(curve: &[tidens_solver::CurvePoint], rho: f64) -> f64 {
    let k = curve
        .iter()
        .position(|p| p.rel_density >= rho)
        .expect("the run reached the density");
    let (a, b) = (&curve[k - 1], &curve[k]);
    a.time + (rho - a.rel_density) / (b.rel_density - a.rel_density) * (b.time - a.time)
}

/// The cell's lattice as whole particles in a periodic box twice its size:
/// each octant a whole spheroid at its corner.
fn periodic_lattice(cell: &Cell, options: &MeshOptions) -> Scene {
    let spheroids: Vec<tidens_solver::PlacedSpheroid> = cell
        .octants
        .iter()
        .map(|o| tidens_solver::PlacedSpheroid {
            centre: o.centre(cell.lengths),
            a: o.a,
            c: o.c,
            axis: [0.0, 0.0, 1.0],
        })
        .collect();
    Scene::periodic(cell.lengths.map(|l| 2.0 * l), &spheroids, options).unwrap()
}

/// Presses `scene` at 10 MPa (1 s ramp) to `until` with the default
/// settings: its curve and statistics.
fn press_to(
    scene: &Scene,
    until: f64,
) -> (Vec<tidens_solver::CurvePoint>, tidens_solver::RunStats) {
    let mut settings = Settings::new(LoadHistory {
        stress: 10.0,
        knockdown: 1.0,
        ramp_time: 1.0,
    });
    settings.until_density = Some(until);
    let mut sim = Simulation::new(scene, Preset::Ti64Creep1293K.material(), settings).unwrap();
    while sim.status() == Status::Running {
        sim.advance().unwrap();
    }
    (sim.curve().to_vec(), sim.stats())
}

/// A whole sphere in a periodic cube is the sc lattice, as the octant cell
/// is; its mesh is the octant's mirrored eight times, so the two differ
/// only in how the contacts are held (the octant's on rigid mirror planes,
/// the sphere's on its periodic images by the penalty contact) and in the
/// steps taken. Measured at level 1: t(0.6) 13.63 s against 13.64 s (-0.03
/// %), and to rho = 0.8 in 133 steps and 551 Newton iterations
/// (`benches/periodic.py --cells sc --until 0.8`; 148 and 922 before the
/// fold terms' tangent was made positive semi-definite). Without the
/// hold on the sphere's rotation (the drag alone) t(0.6) was 13.11 s (3.8
/// % off); with the hold ten times weaker it failed at rho = 0.567.
///
/// Pressed to 0.6 here (25 s); on past rho = 0.7, where the sphere once
/// stalled, by the slow test below.
#[test]
fn a_whole_sphere_in_a_periodic_cube_densifies_as_the_sc_octant_cell() {
    whole_sphere_against_the_sc_octant_cell(0.6);
}

/// The same, pressed on to rho = 0.75 (a minute on one core): past rho =
/// 0.7, where the sphere once stalled (see `FULL_FOLD`), within the two
/// runs' estimates of their time-stepping errors.
#[test]
#[ignore = "slow: the periodic sphere pressed to rho = 0.75 takes a minute; run with --ignored"]
fn a_whole_sphere_in_a_periodic_cube_densifies_as_the_sc_octant_cell_past_0_7() {
    whole_sphere_against_the_sc_octant_cell(0.75);
}

fn whole_sphere_against_the_sc_octant_cell(until: f64) {
    let r = 0.05;
    let options = MeshOptions {
        level: 1,
        grading: 1.0,
        exact_volume: false,
    };
    let cell = Cell::sc(r, 1.0).unwrap();
    let octant = Scene::from_cell(&cell, &options).unwrap();
    let periodic = periodic_lattice(&cell, &options);
    let (octant_curve, _) = press_to(&octant, until);
    let (periodic_curve, stats) = press_to(&periodic, until);
    // The same initial density: the same mesh.
    let (rho_o, rho_p) = (octant_curve[0].rel_density, periodic_curve[0].rel_density);
    assert!(
        (rho_o - rho_p).abs() < 1e-12,
        "rho0 {rho_o} against {rho_p}"
    );
    let (t_o, t_p) = (
        time_at_density(&octant_curve, 0.6),
        time_at_density(&periodic_curve, 0.6),
    );
    // Within 1 %: the time steps' error (tolerance 2e-2 by default) and
    // the penalty's compliance.
    assert!((t_p / t_o - 1.0).abs() < 0.01, "t(0.6) {t_p} against {t_o}");
    // Past rho = 0.7, within the two runs' estimates of their
    // time-stepping errors. At level 1 (`benches/periodic.py`): t(0.7) =
    // 81.72 s against 82.05 s, t(0.75) = 146.2 s against 146.6 s.
    for rho in [0.65, 0.7, 0.75].into_iter().filter(|&rho| rho <= until) {
        let error = |c: &[tidens_solver::CurvePoint]| {
            c.iter()
                .find(|p| p.rel_density >= rho)
                .unwrap()
                .time_error
                .abs()
        };
        let (t_o, t_p) = (
            time_at_density(&octant_curve, rho),
            time_at_density(&periodic_curve, rho),
        );
        let bound = error(&octant_curve) + error(&periodic_curve);
        assert!(
            (t_p - t_o).abs() < bound,
            "t({rho}) {t_p} against {t_o}: beyond the error estimates' {bound}"
        );
    }
    let last = periodic_curve.last().unwrap();
    assert!(last.max_depth < 1e-4 * r, "{}", last.max_depth);
    // The sphere presses on its six neighbours (its images): the sc
    // lattice's coordination number.
    assert_eq!(last.coordination_number, Some(6.0));
    assert!(octant_curve.iter().all(|p| p.coordination_number.is_none()));
    eprintln!(
        "t(0.6) {t_p:.4} s against {t_o:.4} s; {} steps, {} Newton iterations, drag share {:.3e}",
        stats.steps, stats.newton_iterations, stats.max_drag_share
    );
}

/// Two whole spheres of the bcc lattice in a periodic cube touch on the
/// body diagonals, each the other's periodic images, where the octant
/// cell's particles touch each other through its mirror planes; the
/// curves agree within the contact discretisation. Measured at level 1 to
/// rho = 0.8 (hold capped at 0.1 E R): t(0.7), t(0.75), t(0.8) = 0.276,
/// 1.616, 10.56 s against the octant cell's 0.273, 1.620, 10.41 s. With the
/// hold uncapped this run failed at t = 2.61 s, rho = 0.774 (checked).
/// The coordination number went from 8 to 10 between rho = 0.7668 and
/// 0.7698, the height shrunk by 13.2 %.
///
/// Slow (a minute on one core, its first ten steps, closing the contacts,
/// a third of it) and the count of ten needs rho = 0.77: run with
/// `cargo test --release -- --ignored`. The periodic sphere above checks
/// the periodic cell against the octant cell in the default run.
#[test]
#[ignore = "slow: two periodic spheres pressed to rho = 0.78 take a minute; run with --ignored"]
fn two_whole_spheres_in_a_periodic_cube_densify_as_the_bcc_octant_cell() {
    let options = MeshOptions {
        level: 1,
        grading: 1.0,
        exact_volume: false,
    };
    let cell = Cell::bcc(0.05, 1.0).unwrap();
    let octant = Scene::from_cell(&cell, &options).unwrap();
    let periodic = periodic_lattice(&cell, &options);
    let until = 0.78;
    let (octant_curve, _) = press_to(&octant, until);
    let (periodic_curve, stats) = press_to(&periodic, until);
    for rho in [0.7, 0.75, 0.77] {
        let (t_o, t_p) = (
            time_at_density(&octant_curve, rho),
            time_at_density(&periodic_curve, rho),
        );
        // Within 3 %: observed 1.4 % at most to 0.8.
        assert!(
            (t_p / t_o - 1.0).abs() < 0.03,
            "t({rho}) {t_p} against {t_o}"
        );
    }
    let last = periodic_curve.last().unwrap();
    assert!(last.max_depth < 1e-4 * 0.05, "{}", last.max_depth);
    // Each sphere presses on its eight nearest neighbours (the other
    // sphere and its images): the bcc lattice's coordination number. Its
    // two next nearest along the pressing axis (its own images at +-z, a
    // cube edge away) touch it once the height has shrunk by the gap
    // between them, 1 - sqrt(3)/2 = 13.4 % of the edge (a little less:
    // the spheres bulge where they are pressed): then ten.
    let height = 2.0 * cell.lengths[2];
    let mut eight = 0;
    for p in periodic_curve
        .iter()
        .filter(|p| p.coordination_number != Some(0.0))
    {
        let strain = -p.piston_displacement / height;
        if p.coordination_number == Some(8.0) {
            eight += 1;
            assert!(strain < 1.0 - 0.75f64.sqrt(), "Z 8 at strain {strain}");
        } else {
            assert_eq!(p.coordination_number, Some(10.0));
            assert!(strain > 0.12, "Z 10 at strain {strain}");
        }
    }
    assert!(eight > 10, "{eight} points with Z = 8");
    assert_eq!(last.coordination_number, Some(10.0));
    eprintln!(
        "{} steps, {} Newton iterations, drag share {:.3e}",
        stats.steps, stats.newton_iterations, stats.max_drag_share
    );
}
