//! Hertz oracle for particle contact (issue 53, deliverable 2(b)): two
//! elastic spheres (no creep) pressed together, the force against the
//! approach within 3 % of Hertz's law at the default mesh level, with
//! hexahedra and with 10-node tetrahedra.
//!
//! # The law
//!
//! Two equal spheres of radius R, Young's modulus E and Poisson's ratio nu
//! pressed together by a force F touch on a disc of radius
//!
//! ```text
//! a = (3 F R* / (4 E*))^(1/3),   R* = R / 2,   1/E* = 2 (1 - nu^2) / E,
//! ```
//!
//! under the pressure p0 sqrt(1 - r^2/a^2), p0 = 3 F / (2 pi a^2), and
//! points far from the contact approach each other by d = a^2 / R*:
//!
//! ```text
//! F = (4/3) E* sqrt(R*) d^(3/2)          (Hertz's law)
//! ```
//!
//! Hertz takes each body as a half-space, so d is the approach of points
//! at a distance large against a and small against R; the law holds while
//! a << R (the strains are of order a/R too: p0 = 0.13 E* at a/R = 0.1).
//!
//! # What is simulated
//!
//! The stacked pair of `tests/contact.rs`: two sphere octants stacked along
//! z, touching at their poles. Its mirror planes make it a column of whole
//! spheres, each pressed at both poles by its neighbours: the bottom plane
//! z = 0 and the piston are the centre planes of the two spheres. The
//! lateral walls are removed (`Scene::lateral_walls`): the spheres would
//! touch them at their equators, which the Poisson expansion presses
//! against them. The material is the Ti64 preset's elasticity (Hencky, E =
//! 43.5 GPa, nu = 0.3) with the creep coefficient at its floor, 1e-30
//! MPa^-n/s: the plastic strain stays below 1e-12 (checked). Each load is
//! applied at once and solved in one step: the response is elastic and the
//! contact frictionless, so it does not depend on the path (a ramp of 30
//! steps to the same load gave the same approach to 1e-4).
//!
//! # What is measured, and why
//!
//! The piston displacement -U is the approach of the two sphere *centres*,
//! not Hertz's d: besides the indentation at the contact it carries the
//! compression of each sphere between its contact and its centre, which is
//! not a half-space's. That part is computed here exactly for linear
//! elasticity: Lame's solution of the solid sphere under an axisymmetric
//! normal traction, in Legendre series ([`sphere_pole_compression`]), loaded
//! by Hertz's pressure at both poles. The centre approach is `2 w(F) = d(F)
//! + D(F)`; the correction D is of relative size (a/R) ln(R/a): -1.75,
//! -2.29 and -2.85 % of d at a/R = 0.08, 0.1 and 0.12 (the half-space below
//! depth R, which the sphere does not have, is -0.73 a/R of d; the
//! sphere's own compression and the curvature of its surface give part of
//! it back). The pressure on the spheres keeps Hertz's shape to a relative
//! O((a/R)^3): where it acts, the sphere's surface departs from the
//! half-space's by a smooth displacement of order (F / (E R)) (r/R)^2,
//! against the gap r^2 / R. The approach the simulation gives in Hertz's
//! sense is then `d_FE = -U - D(F)`, and each test asserts
//!
//! ```text
//! | F / F_Hertz(d_FE) - 1 | < 3 %
//! ```
//!
//! with F the force through the contact (four times the piston force of
//! the quarter column, which the contact force on the top particle is
//! checked to equal).
//!
//! The pointwise measures suggested for this oracle are much less accurate
//! at the default level, since they read single nodes: the approach of
//! the two axis nodes at depth z, against `2 (w(0) - w(z))` from
//! Boussinesq's solution under Hertz's pressure (closed form on the axis,
//! [`half_space_axis_compression`], the bulk error there O(z a / R^2)),
//! was 4.4 % above Hertz at z = 4a (a/R = 0.1, hexahedra, mortar) at level
//! 3, 2.3 % at level 4 and 1.5 % at level 5; the contact radius is read
//! to a ring of surface nodes (0.02 R apart at the contact here, a fifth
//! of a).
//!
//! # The mesh
//!
//! The default level (3), graded toward the poles as far as the mesher
//! allows for hexahedra (grading 10: surface nodes 0.024 R apart at the
//! contact) and by 4 for tetrahedra, whose 6-node faces are contact
//! surfaces of four flat triangles each, so that their contact nodes are as
//! far apart as the hexahedra's (0.022 R). The meshes keep their surface
//! nodes on the sphere (`exact_volume: false`): the exact-volume fit moves
//! the nodes next to the poles outward, by up to half the drop of the
//! sphere below the tangent plane there, which flattens the contact
//! region and makes it stiffer than Hertz's spheres (level 3, mortar,
//! hexahedra: F / F_Hertz(d_FE) - 1 = +6.4, +5.2, +4.7, +2.7 % at a/R =
//! 0.05, 0.08, 0.1, 0.12).
//!
//! # Loads, and why not smaller
//!
//! The contact disc must span a few surface elements for the contact
//! pressure to take Hertz's shape. At level 3 that holds from a/R = 0.08
//! (3.4 elements); the loads a/R = 0.08, 0.1, 0.12 (piston stress 8 to 28
//! MPa, forces a factor 3.4 apart, so the 3/2 power is tested) are the
//! smallest at which the level meets 3 %. Measured F / F_Hertz(d_FE) - 1,
//! hexahedra graded by 10, a/R = 0.05 / 0.08 / 0.1 / 0.12:
//!
//! ```text
//! level  mortar                      node to facet
//! 1      +21.8  -10.9   +1.1  +0.6   +13.4  +24.0   +8.1   -1.0
//! 2      -11.3   -2.0   -6.9  +0.0    +6.1   +3.5   +4.7   +4.0
//! 3       -5.0   -1.1   +0.0  -1.5    -6.2   +1.7   +1.1   +3.9
//! 4       -3.9   -0.3   +1.6  +1.3    +0.5   +2.4   +1.6   +2.9
//! 5       -1.0   +1.2   +1.7  +1.7    +1.1   +0.7   +1.6   +2.4
//! ```
//!
//! The finer levels approach a force about 1.5 % above the linear theory
//! at a/R = 0.1 to 0.12, of the order of the strains there (the Hencky
//! material and the kinematics are nonlinear; the linear theory is the
//! limit a/R -> 0); at level 3 this partly offsets the discretisation
//! error, which has the other sign. Below a/R = 0.08 the level-3 error is
//! the resolution of the contact disc: -5 % at a/R = 0.05 (2 elements
//! across a), -3.9 % at level 4, -1.0 % at level 5. Tetrahedra, level 3
//! graded by 4, a/R = 0.1: mortar +0.0 %, node to facet +1.0 % (107 s on
//! two cores: not in the test); at level 3 one load takes them 46 s on one
//! core, so their test has one load.
//!
//! The ladder is `hertz_ladder` (ignored, 12 minutes).

#[path = "support/cells.rs"]
mod cells;

use cells::stacked_pair;
use std::f64::consts::PI;
use std::time::Instant;
use tidens_solver::{
    ContactFormulation, ElementKind, LoadHistory, Material, MeshOptions, Preset, Scene, Settings,
    Simulation,
};

/// Sphere radius R \[mm\].
const R: f64 = 0.05;

/// The Ti64 preset's elasticity with creep switched off: Young's modulus
/// \[MPa\] and Poisson's ratio of the preset, the Norton coefficient at the
/// floor the material accepts (1e-30 MPa^-n/s: at 4 GPa, above the peak
/// pressure of the largest load, a creep rate of 1e-20 /s).
fn elastic_ti64() -> Material {
    let ti64 = Preset::Ti64Creep1293K.material();
    Material::new(ti64.young, ti64.poisson, 1e-30, ti64.creep_n).unwrap()
}

/// The contact modulus E* = E / (2 (1 - nu^2)) of two equal spheres \[MPa\].
fn contact_modulus() -> f64 {
    let m = elastic_ti64();
    m.young / (2.0 * (1.0 - m.poisson * m.poisson))
}

/// The effective radius R* = R / 2 of two equal spheres \[mm\].
const R_STAR: f64 = R / 2.0;

/// Hertz's contact radius a \[mm\] under the force `f` \[N\].
fn hertz_radius(f: f64) -> f64 {
    (3.0 * f * R_STAR / (4.0 * contact_modulus())).cbrt()
}

/// Hertz's approach d = a^2 / R* of distant points \[mm\] under the force
/// `f` \[N\].
fn hertz_approach(f: f64) -> f64 {
    hertz_radius(f).powi(2) / R_STAR
}

/// Hertz's law: the force \[N\] at the approach `d` \[mm\].
fn hertz_force(d: f64) -> f64 {
    4.0 / 3.0 * contact_modulus() * R_STAR.sqrt() * d.powf(1.5)
}

/// The force \[N\] whose Hertz contact radius is `a_over_r` R.
fn force_for_radius(a_over_r: f64) -> f64 {
    4.0 / 3.0 * contact_modulus() * (a_over_r * R).powi(3) / R_STAR
}

/// How much a half-space pressed by Hertz's pressure of force `f` \[N\]
/// shortens between its surface and the depth `z` \[mm\] on the axis,
/// `w(0) - w(z)` \[mm\]: Boussinesq's point-load solution integrated over
/// the pressure in closed form,
///
/// ```text
/// w(z) = (1 + nu) p0 / (E a) [z a - z^2 atan(a/z) + (1 - nu)((a^2 + z^2) atan(a/z) - a z)],
/// ```
///
/// which is `(1 - nu^2) pi p0 a / (2 E)` = d/2 at the surface and `(1 +
/// nu)(3 - 2 nu) F / (2 pi E z)` (Boussinesq's) far below.
fn half_space_axis_compression(f: f64, z: f64) -> f64 {
    let m = elastic_ti64();
    let (e, nu) = (m.young, m.poisson);
    let a = hertz_radius(f);
    let p0 = 3.0 * f / (2.0 * PI * a * a);
    let w = |z: f64| {
        let t = if z == 0.0 { PI / 2.0 } else { (a / z).atan() };
        (1.0 + nu) * p0 / (e * a) * (z * a - z * z * t + (1.0 - nu) * ((a * a + z * z) * t - a * z))
    };
    w(0.0) - w(z)
}

/// Nodes and weights of the `n`-point Gauss-Legendre rule on [0, 1].
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (1..=n)
        .map(|i| {
            let mut x = (PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 1..n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k + 1.0) * x * p1 - k * p0) / (k + 1.0));
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            (0.5 * (1.0 + x), 1.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// How much a linear-elastic sphere of radius R pressed at both poles by
/// Hertz's pressure of force `f` \[N\] shortens between a pole and its
/// centre \[mm\].
///
/// Lame's solution of the solid sphere under the normal surface traction
/// `-p(theta) = -sum p_n P_n(cos theta)` (no shear traction): for each even
/// degree n, the displacement `A grad(r^n P_n) + B (r^2 grad(r^n P_n) + c_n
/// x r^n P_n)`, `c_n = -2 (n (3 - 4 nu) + 1 - 2 nu) / (n + 5 - 4 nu)`
/// (Navier's equations), with A and B from the two traction conditions at r
/// = R; n = 0 is the uniform pressure, `u_r = -p_0 R / (3 K)`. The pressure is
/// Hertz's, `p0 sqrt(1 - rho^2/a^2)` at the distance rho = R sin(theta) from
/// the axis, scaled so that its resultant along the axis is `f`. Its
/// Legendre coefficients are Gauss integrals over the cap (in `s = sqrt(1 -
/// rho^2/a^2)`, smooth there, 1600 points); the series is summed to degree
/// 240 R/a (summed to 120 R/a it differs by 5e-5 of itself at a/R = 0.1).
fn sphere_pole_compression(f: f64) -> f64 {
    let m = elastic_ti64();
    let (e, nu) = (m.young, m.poisson);
    let mu = e / (2.0 * (1.0 + nu));
    let lambda = 2.0 * mu * nu / (1.0 - 2.0 * nu);
    let a = hertz_radius(f);
    let degree = (240.0 * R / a) as usize;
    // p_n of both caps per unit p0 (odd degrees cancel), and the axial
    // resultant of one cap.
    let mut p = vec![0.0; degree + 1];
    let mut legendre = vec![0.0; degree + 1];
    let mut resultant = 0.0;
    for (s, w) in gauss_legendre(1600) {
        let rho = a * (1.0 - s * s).sqrt();
        let cos = (1.0 - (rho / R).powi(2)).sqrt();
        // sin(theta) d(theta) = a^2 s ds / (R^2 cos(theta)).
        let weight = w * a * a * s / (R * R * cos);
        resultant += s * cos * 2.0 * PI * R * R * weight;
        legendre[0] = 1.0;
        legendre[1] = cos;
        for n in 1..degree {
            let n_ = n as f64;
            legendre[n + 1] =
                ((2.0 * n_ + 1.0) * cos * legendre[n] - n_ * legendre[n - 1]) / (n_ + 1.0);
        }
        for n in (0..=degree).step_by(2) {
            // (2n + 1)/2 times the integral over theta, twice (two caps).
            p[n] += (2.0 * n as f64 + 1.0) * s * legendre[n] * weight;
        }
    }
    let p0 = f / resultant;
    let mut u_r = 0.0;
    for n in (0..=degree).step_by(2) {
        let pn = p0 * p[n];
        if n == 0 {
            u_r -= pn * R / (3.0 * lambda + 2.0 * mu);
            continue;
        }
        let n = n as f64;
        let c = -2.0 * (n * (3.0 - 4.0 * nu) + 1.0 - 2.0 * nu) / (n + 5.0 - 4.0 * nu);
        let div = 2.0 * n + c * (n + 3.0);
        // Unknowns A R^(n-2) and B R^n: shear traction zero, normal -pn.
        let (m11, m12) = (2.0 * mu * (n - 1.0), mu * (2.0 * n + c));
        let (m21, m22) = (
            2.0 * mu * n * (n - 1.0),
            lambda * div + 2.0 * mu * (n + c) * (n + 1.0),
        );
        let det = m11 * m22 - m12 * m21;
        let (a_n, b_n) = (m12 * pn / det, -m11 * pn / det);
        u_r += (a_n * n + b_n * (n + c)) * R;
    }
    -u_r
}

/// The approach of the two sphere centres under the force `f` \[N\] less
/// Hertz's approach of distant points, D(f) \[mm\] (module docs).
fn centre_correction(f: f64) -> f64 {
    2.0 * sphere_pole_compression(f) - hertz_approach(f)
}

/// One elastic pressing of the stacked pair.
struct Pressed {
    /// The force through the contact of the whole spheres \[N\].
    force: f64,
    /// The approach of the two sphere centres, -U \[mm\].
    centre_approach: f64,
    /// The simulation's approach in Hertz's sense, `-U - D(F)` \[mm\].
    approach: f64,
    /// Wall time of the run \[s\].
    seconds: f64,
}

impl Pressed {
    /// F / F_Hertz(d_FE) - 1.
    fn error(&self) -> f64 {
        self.force / hertz_force(self.approach) - 1.0
    }
}

/// Presses the stacked pair, meshed at `level` graded by `grading` with
/// elements `kind`, by the force whose Hertz contact radius is `a_over_r`
/// R, in one step.
fn press(
    kind: ElementKind,
    formulation: ContactFormulation,
    (level, grading): (u32, f64),
    a_over_r: f64,
) -> Pressed {
    let start = Instant::now();
    let options = MeshOptions {
        level,
        grading,
        exact_volume: false,
    };
    let mut scene = Scene::from_cell(&stacked_pair(R), &options)
        .unwrap()
        .with_element(kind)
        .unwrap();
    scene.lateral_walls = false;
    let quarter = scene.lengths[0] * scene.lengths[1];
    // The piston presses a quarter of the column.
    let stress = force_for_radius(a_over_r) / 4.0 / quarter;
    let mut settings = Settings::new(LoadHistory {
        stress,
        knockdown: 1.0,
        ramp_time: 0.0,
    });
    // One step of 1 s at full load: elastic, so the time only scales the
    // (negligible) creep, and the time-error control has nothing to do.
    settings.until_time = Some(1.0);
    settings.dt_initial = Some(1.0);
    settings.tolerance = 0.5;
    settings.contact.formulation = formulation;
    // 5e-6 R of penetration is 2.5e-4 of the approach at a/R = 0.1; and
    // mortar reads closed at the start only the nodes within 10 times the
    // tolerance of the other surface: the poles alone (at the default 1e-4
    // the nodes within 0.03 R of the pole read closed, about a third of a).
    settings.contact.penetration_tolerance = 1e-5;
    let mut sim = Simulation::new(&scene, elastic_ti64(), settings).unwrap();
    let point = sim
        .advance()
        .unwrap_or_else(|e| panic!("{kind:?} {formulation:?} at a/R = {a_over_r}: {e}"))
        .clone();
    assert_eq!(point.step, 1);
    assert!((point.time - 1.0).abs() < 1e-12, "one step to t = 1 s");
    let piston = point.cell_stress * quarter;
    // The contact carries the piston force (to Newton's tolerance, 1e-4
    // of it per equation).
    let contact = sim.particle_forces(&scene)[1].0[2];
    assert!(
        (contact / piston - 1.0).abs() < 1e-3,
        "contact force {contact:e} N against the piston's {piston:e} N"
    );
    let eqps = sim
        .fields()
        .element
        .eqps
        .iter()
        .cloned()
        .fold(0.0, f64::max);
    assert!(eqps < 1e-12, "plastic strain {eqps:e}: not elastic");
    let force = 4.0 * piston;
    let centre_approach = -point.piston_displacement;
    Pressed {
        force,
        centre_approach,
        approach: centre_approach - centre_correction(force),
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Presses the pair meshed at the default level, graded by `grading`, at
/// each contact radius of `radii` (in R) and asserts Hertz's law within 3
/// % if `assert`; prints the comparison either way.
fn against_hertz(
    kind: ElementKind,
    formulation: ContactFormulation,
    grading: f64,
    radii: &[f64],
    assert: bool,
) {
    let level = MeshOptions::default().level;
    for &a_over_r in radii {
        let p = press(kind, formulation, (level, grading), a_over_r);
        let d = hertz_approach(p.force);
        let report = format!(
            "{kind:?} {formulation:?}, a/R = {a_over_r}: F = {:.4e} N; centre approach \
             {:.4e} mm against {:.4e} mm for elastic spheres (Hertz's d {d:.4e} mm); \
             approach {:.4e} mm, F / F_Hertz = {:.4} ({:.1} s)",
            p.force,
            p.centre_approach,
            2.0 * sphere_pole_compression(p.force),
            p.approach,
            1.0 + p.error(),
            p.seconds
        );
        eprintln!("{report}");
        if assert {
            assert!(
                p.error().abs() < 0.03,
                "off Hertz's law by more than 3 %: {report}"
            );
        }
    }
}

/// Hexahedra at the default level, graded by 10 toward the contact:
/// mortar contact follows Hertz's law within 3 % at a/R = 0.08, 0.1 and
/// 0.12 (measured -1.1, +0.0, -1.5 %). Node-to-facet contact at the same
/// loads is printed, not asserted (measured +1.7, +1.1, +3.9 %). 22 s on
/// one core, 9 of them mortar's.
#[test]
fn hex8_spheres_pressed_together_follow_hertz_law() {
    let radii = [0.08, 0.1, 0.12];
    against_hertz(
        ElementKind::Hex8,
        ContactFormulation::Mortar,
        10.0,
        &radii,
        true,
    );
    against_hertz(
        ElementKind::Hex8,
        ContactFormulation::NodeToFacet,
        10.0,
        &radii,
        false,
    );
}

/// 10-node tetrahedra at the default level, graded by 4: mortar contact
/// follows Hertz's law within 3 % at a/R = 0.1 (measured +0.0 %; 46 s on
/// one core, so one load only).
#[test]
fn tet10_spheres_pressed_together_follow_hertz_law() {
    against_hertz(
        ElementKind::Tet10,
        ContactFormulation::Mortar,
        4.0,
        &[0.1],
        true,
    );
}

/// The table of the module docs: F / F_Hertz(d_FE) - 1 \[%\] with
/// hexahedra graded by 10, at the levels `HERTZ_LEVELS` (default 1 to 5;
/// level 5 takes minutes).
#[test]
#[ignore = "slow: the mesh-level ladder of the module docs; run with --ignored --nocapture"]
fn hertz_ladder() {
    let levels = std::env::var("HERTZ_LEVELS").unwrap_or_else(|_| "1,2,3,4,5".into());
    let radii = [0.05, 0.08, 0.1, 0.12];
    eprintln!("level  mortar at a/R = {radii:?}; node to facet");
    for level in levels.split(',').map(|l| l.trim().parse::<u32>().unwrap()) {
        let row = |formulation| {
            radii
                .iter()
                .map(|&r| {
                    let p = press(ElementKind::Hex8, formulation, (level, 10.0), r);
                    format!("{:+6.1}", 100.0 * p.error())
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        let mortar = row(ContactFormulation::Mortar);
        let node_to_facet = row(ContactFormulation::NodeToFacet);
        eprintln!("{level}      {mortar}   {node_to_facet}");
    }
}

/// The oracle itself. The centre approach of the elastic spheres tends to
/// Hertz's approach as the contact shrinks: its correction D, the sphere's
/// compliance beyond the half-space's, is D / d = (a/R) (A + B ln(a/R)).
/// The logarithm comes from the curvature of the sphere's surface: its
/// compliance to a pressure of Legendre degree n departs from the
/// half-space's (at wavenumber (n + 1/2) / R) by a relative 0.11 / n, and
/// the degrees up to R/a carry the load. So D / (d a/R) is linear in
/// ln(a/R) (second difference over a/R = 0.02, 0.04, 0.08 within 5 % of
/// the first; measured 0.6 %), and D / d is below 0.3 % at a/R = 0.01. The
/// half-space under Hertz's pressure shortens by d/2 from its surface to
/// far below.
#[test]
fn the_elastic_sphere_tends_to_hertz_for_small_contacts() {
    let relative = |a_over_r: f64| {
        let f = force_for_radius(a_over_r);
        assert!((hertz_radius(f) / (a_over_r * R) - 1.0).abs() < 1e-12);
        centre_correction(f) / hertz_approach(f)
    };
    let small = relative(0.01);
    assert!(
        small < 0.0 && small.abs() < 3e-3,
        "D / d = {small:e} at a/R = 0.01"
    );
    let k = [0.02, 0.04, 0.08].map(|x| relative(x) / x);
    let (first, second) = (k[1] - k[0], k[2] - 2.0 * k[1] + k[0]);
    eprintln!("D / d = {small:.3e} at a/R = 0.01; D / (d a/R) = {k:.4?} at a/R = 0.02, 0.04, 0.08");
    assert!(
        first < 0.0 && second.abs() < 0.05 * first.abs(),
        "D / (d a/R) = {k:?}"
    );
    for a_over_r in [0.08, 0.1, 0.12] {
        eprintln!("a/R = {a_over_r}: D / d = {:.4}", relative(a_over_r));
    }
    let f = force_for_radius(0.1);
    let a = hertz_radius(f);
    let half = half_space_axis_compression(f, 1e4 * a) / (hertz_approach(f) / 2.0);
    assert!((half - 1.0).abs() < 1e-3, "{half}");
}
