//! The contact patch test on the mortar kernels: a flat slave grid (3 x 4
//! quads on 1.5 x 2 mm, or their triangles) and a flat master grid facing
//! it (5 x 5 quads or triangles, 2.6 mm wide, turned by 17 degrees about
//! the normal: no node or edge matches) a uniform gap `delta` away along
//! the normal. The master covers the slave, so every slave node's support
//! is covered and its mean gap `g_j / A_j` is `delta` to round-off, for
//! either test basis; `sum_j D_jk = int N_k dA`, `sum_j M_jl = int_overlap
//! N^m_l dA`, and a uniform pressure `p` applied as the nodal forces `f =
//! p grad(sum_j g_j)` is transmitted exactly.

#[path = "support/mortar_meshes.rs"]
mod meshes;

use std::collections::BTreeMap;

use meshes::{gaps, patch, plane, polar};
use tidens_contact::ContactSurface;
use tidens_contact::mortar::{Derivatives, TestBasis, WeightedGap};

const LX: f64 = 1.5;
const LY: f64 = 2.0;
const TURN: f64 = 17.0 * std::f64::consts::PI / 180.0;

/// The slave grid at z = 0 (normal +z) and a master square of side `side`
/// centred over the slave's centre at z = `delta`, facing down.
fn scene(
    delta: f64,
    side: f64,
    slave_tris: bool,
    master_tris: bool,
) -> (Vec<[f64; 3]>, ContactSurface, ContactSurface) {
    let mut x = Vec::new();
    let slave = patch(
        &mut x,
        3,
        4,
        plane([0.0; 3], [LX, 0.0, 0.0], [0.0, LY, 0.0]),
        false,
        slave_tris,
    );
    let (a, b) = (
        polar(side, TURN),
        polar(side, TURN + std::f64::consts::FRAC_PI_2),
    );
    let c = [
        0.5 * LX - 0.5 * (a[0] + b[0]),
        0.5 * LY - 0.5 * (a[1] + b[1]),
        delta,
    ];
    let master = patch(&mut x, 5, 5, plane(c, a, b), true, master_tris);
    (x, slave, master)
}

fn run(
    delta: f64,
    side: f64,
    st: bool,
    mt: bool,
    basis: TestBasis,
) -> (
    Vec<[f64; 3]>,
    ContactSurface,
    ContactSurface,
    Vec<WeightedGap>,
) {
    let (x, s, m) = scene(delta, side, st, mt);
    let g = gaps(&s, &m, &x, basis, 0.05, Derivatives::Gradient);
    (x, s, m, g)
}

/// The counter-clockwise polygon `subject` clipped by the counter-clockwise
/// convex polygon `clipper` (in the xy-plane).
fn clip_xy(subject: Vec<[f64; 2]>, clipper: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut poly = subject;
    for i in 0..clipper.len() {
        let (a, b) = (clipper[i], clipper[(i + 1) % clipper.len()]);
        let side = |q: [f64; 2]| (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]);
        let mut out = Vec::new();
        for k in 0..poly.len() {
            let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
            let (sp, sq) = (side(p), side(q));
            if sq >= 0.0 {
                if sp < 0.0 {
                    let t = sp / (sp - sq);
                    out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
                }
                out.push(q);
            } else if sp >= 0.0 {
                let t = sp / (sp - sq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        poly = out;
        if poly.is_empty() {
            break;
        }
    }
    poly
}

/// `int_overlap N^m_l dA` of master node `l` over the slave rectangle,
/// facet by facet: the rectangle clipped by the (flat, affine) facet, fanned
/// from its first vertex, with the edge-midpoint rule (exact for the
/// quadratic `N_l`). Independent of the kernels' clip, cells and rule.
fn overlap_integral(x: &[[f64; 3]], m: &ContactSurface, l: usize) -> f64 {
    let tri = m.kind == tidens_contact::FacetKind::Triangle;
    let mut total = 0.0;
    for f in m.facets.iter().filter(|f| f.contains(&l)) {
        let count = if tri { 3 } else { 4 };
        let c: Vec<[f64; 2]> = f[..count]
            .iter()
            .rev()
            .map(|&n| [x[n][0], x[n][1]])
            .collect();
        let rect = vec![[0.0, 0.0], [LX, 0.0], [LX, LY], [0.0, LY]];
        let poly = clip_xy(rect, &c);
        if poly.len() < 3 {
            continue;
        }
        // The facet's affine map from its first node: x = y0 + s e1 + t e2.
        let y = |k: usize| [x[f[k]][0], x[f[k]][1]];
        let (e1, e2) = if tri {
            (
                [y(1)[0] - y(0)[0], y(1)[1] - y(0)[1]],
                [y(2)[0] - y(0)[0], y(2)[1] - y(0)[1]],
            )
        } else {
            (
                [y(1)[0] - y(0)[0], y(1)[1] - y(0)[1]],
                [y(3)[0] - y(0)[0], y(3)[1] - y(0)[1]],
            )
        };
        let det = e1[0] * e2[1] - e1[1] * e2[0];
        let corner = f.iter().position(|&n| n == l).unwrap();
        let shape = |p: [f64; 2]| {
            let d = [p[0] - y(0)[0], p[1] - y(0)[1]];
            let (s, t) = (
                (d[0] * e2[1] - d[1] * e2[0]) / det,
                (e1[0] * d[1] - e1[1] * d[0]) / det,
            );
            if tri {
                [1.0 - s - t, s, t][corner]
            } else {
                // (s, t) in [0, 1]^2: corners (0,0), (1,0), (1,1), (0,1).
                [(1.0 - s) * (1.0 - t), s * (1.0 - t), s * t, (1.0 - s) * t][corner]
            }
        };
        for k in 1..poly.len() - 1 {
            let (a, b, q) = (poly[0], poly[k], poly[k + 1]);
            let area = 0.5 * ((b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]));
            let mid = |u: [f64; 2], v: [f64; 2]| [0.5 * (u[0] + v[0]), 0.5 * (u[1] + v[1])];
            total += area / 3.0 * (shape(mid(a, b)) + shape(mid(b, q)) + shape(mid(q, a)));
        }
    }
    total
}

/// `d Area / d x_k` of the slave rectangle for its node at `p`.
fn area_gradient(p: [f64; 3]) -> [f64; 2] {
    let h = 0.5;
    let on = |v: f64, l: f64| {
        if (v - l).abs() < 1e-12 {
            1.0
        } else if v.abs() < 1e-12 {
            -1.0
        } else {
            0.0
        }
    };
    let half = |v: f64, l: f64| {
        (if v > 1e-12 { 0.5 * h } else { 0.0 }) + (if v < l - 1e-12 { 0.5 * h } else { 0.0 })
    };
    [on(p[0], LX) * half(p[1], LY), on(p[1], LY) * half(p[0], LX)]
}

#[test]
fn a_uniform_gap_is_measured_exactly_and_a_uniform_pressure_is_transmitted_exactly() {
    let p = 1.0;
    let mut worst = [0.0f64; 4];
    for st in [false, true] {
        for mt in [false, true] {
            for basis in [TestBasis::Standard, TestBasis::Dual] {
                for delta in [0.01, -0.013] {
                    let (x, s, m, g) = run(delta, 2.6, st, mt, basis);
                    let case =
                        format!("slave tris {st}, master tris {mt}, {basis:?}, delta {delta}");
                    // Every slave node, each with g_j / A_j = delta.
                    assert_eq!(g.len(), s.nodes.len(), "{case}");
                    for w in &g {
                        let err = (w.gap / w.area - delta).abs() / delta.abs();
                        worst[0] = worst[0].max(err);
                        assert!(
                            err < 1e-12,
                            "{case}: node {} reads {}",
                            w.node,
                            w.gap / w.area
                        );
                    }
                    // sum_j D_jk = int N_k dA (the tributary areas).
                    let mut dsum: BTreeMap<usize, f64> = BTreeMap::new();
                    let mut msum: BTreeMap<usize, f64> = BTreeMap::new();
                    for w in &g {
                        for &(k, v) in &w.d {
                            *dsum.entry(k).or_default() += v;
                        }
                        for &(l, v) in &w.m {
                            *msum.entry(l).or_default() += v;
                        }
                    }
                    for (i, &k) in s.nodes.iter().enumerate() {
                        let err = (dsum[&k] - s.areas[i]).abs() / s.areas[i];
                        worst[1] = worst[1].max(err);
                        assert!(err < 1e-12, "{case}: D column {k}");
                    }
                    // sum_j M_jl = int_overlap N^m_l, against an independent
                    // integration of each master facet's part over the slave.
                    for &l in &m.nodes {
                        let want = overlap_integral(&x, &m, l);
                        let got = msum.get(&l).copied().unwrap_or(0.0);
                        let err = (got - want).abs() / (LX * LY / 20.0);
                        worst[2] = worst[2].max(err);
                        assert!(err < 1e-12, "{case}: M column {l}: {got} against {want}");
                    }
                    let total: f64 = msum.values().sum();
                    let moment: [f64; 3] =
                        std::array::from_fn(|c| msum.iter().map(|(&l, &v)| v * x[l][c]).sum());
                    let area = LX * LY;
                    let want = [0.5 * LX * area, 0.5 * LY * area, delta * area];
                    assert!((total - area).abs() < 1e-12 * area, "{case}");
                    for c in 0..3 {
                        assert!(
                            (moment[c] - want[c]).abs() < 1e-12 * area,
                            "{case}: moment {c}"
                        );
                    }
                    // Forces f = p grad(sum_j g_j).
                    let mut f: BTreeMap<usize, f64> = BTreeMap::new();
                    for w in &g {
                        for &(dof, v) in &w.gradient {
                            *f.entry(dof).or_default() += p * v;
                        }
                    }
                    let force = |n: usize, c: usize| f.get(&(3 * n + c)).copied().unwrap_or(0.0);
                    let tol = 1e-12 * p * area;
                    for (i, &k) in s.nodes.iter().enumerate() {
                        // Normal: -p int N_k dA (away from the master);
                        // in-plane: p delta dArea/dx_k (zero inside).
                        let err = (force(k, 2) + p * s.areas[i]).abs();
                        let da = area_gradient(x[k]);
                        let err = err
                            .max((force(k, 0) - p * delta * da[0]).abs())
                            .max((force(k, 1) - p * delta * da[1]).abs());
                        worst[3] = worst[3].max(err / (p * area));
                        assert!(
                            err < tol,
                            "{case}: slave force at {k}: {:?}",
                            [0, 1, 2].map(|c| force(k, c))
                        );
                    }
                    for &l in &m.nodes {
                        let want = p * msum.get(&l).copied().unwrap_or(0.0);
                        let err = (force(l, 2) - want)
                            .abs()
                            .max(force(l, 0).abs())
                            .max(force(l, 1).abs());
                        worst[3] = worst[3].max(err / (p * area));
                        assert!(err < tol, "{case}: master force at {l}");
                    }
                    for c in 0..3 {
                        let sum: f64 = f.iter().filter(|(d, _)| *d % 3 == c).map(|(_, v)| v).sum();
                        assert!(sum.abs() < tol, "{case}: resultant {c} = {sum}");
                    }
                }
            }
        }
    }
    println!(
        "patch test, worst relative errors: g/A {:.1e}, sum D {:.1e}, sum M {:.1e}, forces {:.1e}",
        worst[0], worst[1], worst[2], worst[3]
    );
}

#[test]
fn where_the_master_covers_a_support_only_partly_the_node_reads_the_covered_share() {
    // A master square 1.8 wide: the supports of the middle nodes are
    // covered, the slave's corners are not.
    for st in [false, true] {
        let delta = 0.02;
        let (_, _, _, standard) = run(delta, 1.8, st, false, TestBasis::Standard);
        let (_, _, _, dual) = run(delta, 1.8, st, false, TestBasis::Dual);
        assert_eq!(
            standard.iter().map(|w| w.node).collect::<Vec<_>>(),
            dual.iter().map(|w| w.node).collect::<Vec<_>>()
        );
        let (mut full, mut part) = (0, 0);
        for (ws, wd) in standard.iter().zip(&dual) {
            // Between flat parallel surfaces g_j = delta int_overlap Phi_j
            // = delta sum_k D_jk, whatever the coverage.
            for w in [ws, wd] {
                let covered: f64 = w.d.iter().map(|(_, v)| v).sum();
                assert!((w.gap - delta * covered).abs() < 1e-12 * delta * w.area);
            }
            // Coverage by the standard (positive) functions.
            let covered: f64 = ws.d.iter().map(|(_, v)| v).sum();
            if (covered - ws.area).abs() < 1e-12 * ws.area {
                full += 1;
                for w in [ws, wd] {
                    assert!((w.gap / w.area - delta).abs() < 1e-12 * delta);
                }
            } else {
                part += 1;
                println!(
                    "slave tris {st}: node {} covered {:.3}: g/A/delta standard {:.4}, dual {:.4}",
                    ws.node,
                    covered / ws.area,
                    ws.gap / ws.area / delta,
                    wd.gap / wd.area / delta
                );
                assert!(ws.gap / ws.area < delta * (1.0 - 1e-6));
            }
        }
        assert!(full >= 2 && part >= 1, "{full} covered, {part} partly");
    }
}

/// The normal nodal forces of both passes of `contact` (each surface the
/// slave of one) on the patch with the master grid `delta` below the slave
/// (a uniform penetration `-delta`), against those of the uniform pressure
/// `p = penalty * (-delta)`: `p int_overlap N_k dA` on every node of either
/// surface. Returns the largest error over `p` times the largest nodal area
/// of the node's surface.
fn pipeline_error(contact: &mut tidens_contact::ParticleContact, x: &[[f64; 3]], p: f64) -> f64 {
    let flat: Vec<f64> = x.iter().flatten().copied().collect();
    contact.pair(&flat);
    let eval = contact.evaluate(&flat, false);
    let mut f: BTreeMap<usize, f64> = BTreeMap::new();
    for t in &eval.terms {
        for (&d, &v) in t.dofs.iter().zip(&t.force) {
            *f.entry(d).or_default() += v;
        }
    }
    let force = |n: usize, c: usize| f.get(&(3 * n + c)).copied().unwrap_or(0.0);
    let (slave, master) = (&contact.surfaces()[0], &contact.surfaces()[1]);
    let mut worst: f64 = 0.0;
    // The slave grid lies wholly under the master: its nodes are pushed
    // down by p A_k (`force` is the terms' part of the internal force, the
    // opposite of the contact force).
    let scale = slave.areas.iter().cloned().fold(0.0, f64::max) * p;
    for (i, &k) in slave.nodes.iter().enumerate() {
        worst = worst.max((force(k, 2) - p * slave.areas[i]).abs() / scale);
    }
    let scale = master.areas.iter().cloned().fold(0.0, f64::max) * p;
    for &l in &master.nodes {
        worst = worst.max((force(l, 2) + p * overlap_integral(x, master, l)).abs() / scale);
    }
    // Nothing is lost or made: the normal forces sum to zero.
    let sum: f64 = f.iter().filter(|(d, _)| *d % 3 == 2).map(|(_, v)| v).sum();
    assert!(sum.abs() < 1e-9 * p * LX * LY, "resultant {sum}");
    worst
}

/// The contact patch test through the whole contact (both passes, the
/// penalty's pressure, `ParticleContact`): a uniform penetration of two
/// non-matching flat grids gives a uniform pressure, each node's force the
/// consistent one, to 1e-6 of the pressure with mortar contact. The
/// penetration is that of a converged step (1e-6 mm): the exact gradient of
/// a weighted gap also holds the penetration times the move of the patch's
/// edge as the slave's normals turn: 3e-4 of a node's force at a
/// penetration of 1e-2 mm (2e-2 of the slave's element size), 3e-12 at
/// 1e-6 mm. Node to facet is printed beside it: its slave
/// nodes carry their tributary areas, but the forces they pass to the
/// master land where the slave nodes project, not spread as the pressure
/// is.
#[test]
fn the_whole_contact_transmits_a_uniform_pressure_uniformly_with_mortar() {
    use tidens_contact::{ContactMode, ContactSettings, ParticleContact};
    let (delta, penalty) = (-1e-6, 1e6);
    let p = -penalty * delta;
    let settings = ContactSettings {
        mode: ContactMode::Frictionless,
        penalty,
        search_distance: 0.05,
        curvature_stiffness: false,
        touch_stiffness_cap: f64::INFINITY,
    };
    for st in [false, true] {
        for mt in [false, true] {
            let (x, s, m) = scene(delta, 2.6, st, mt);
            let mut mortar =
                ParticleContact::mortar(vec![s.clone(), m.clone()], settings, TestBasis::Standard)
                    .unwrap();
            let mortar_error = pipeline_error(&mut mortar, &x, p);
            let mut node_to_facet = ParticleContact::new(vec![s, m], settings).unwrap();
            let ntf_error = pipeline_error(&mut node_to_facet, &x, p);
            println!(
                "patch test (slave tris {st}, master tris {mt}): largest nodal force error over p A: mortar {mortar_error:.1e}, node to facet {ntf_error:.1e}"
            );
            assert!(
                mortar_error < 1e-6,
                "slave tris {st}, master tris {mt}: {mortar_error:e}"
            );
        }
    }
}
