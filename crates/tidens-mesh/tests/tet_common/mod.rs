//! Helpers shared by the tetrahedral-mesh tests: independent checks of a
//! [`TetMesh`]'s topology, boundary and geometry, written without the crate's
//! construction logic.
#![allow(dead_code)]

use std::collections::HashMap;
use tidens_mesh::tet10::FACES;
use tidens_mesh::{OctantSpec, TetMesh};

/// The aspect ratios c/a required by the mesh specification.
pub const ASPECTS: [f64; 5] = [0.5, 0.8, 1.0, 1.2, 2.0];

pub fn octant(a: f64, c: f64, divisions: usize, grading: f64) -> TetMesh {
    TetMesh::spheroid_octant(&OctantSpec {
        a,
        c,
        divisions,
        grading,
    })
    .expect("valid spec")
}

fn sorted3(t: [usize; 3]) -> [usize; 3] {
    let mut t = t;
    t.sort_unstable();
    t
}

fn edge(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

/// Mid-edge nodes of a 6-node triangle keyed by their corner pair.
fn mids(f: &[usize; 6]) -> [((usize, usize), usize); 3] {
    [
        (edge(f[0], f[1]), f[3]),
        (edge(f[1], f[2]), f[4]),
        (edge(f[2], f[0]), f[5]),
    ]
}

/// True when `b` lists the corners of `a` in the same cyclic order.
fn same_cycle(a: &[usize; 6], b: &[usize; 6]) -> bool {
    (0..3).any(|k| (0..3).all(|i| a[i] == b[(i + k) % 3]))
}

/// Asserts: every triangular face is shared by one or two elements; two
/// sharers see it with the same 6 nodes (each mid-edge node on the same edge)
/// and opposite orientations; the faces with one element are exactly the
/// listed boundary triangles, each listed once, with the listed element, the
/// element's outward orientation and its mid-edge nodes; every edge has one
/// mid-edge node; no two nodes coincide; every node is used.
pub fn assert_conforming(mesh: &TetMesh) {
    let mut faces: HashMap<[usize; 3], Vec<(usize, [usize; 6])>> = HashMap::new();
    let mut edge_mid: HashMap<(usize, usize), usize> = HashMap::new();
    for (e, el) in mesh.elements.iter().enumerate() {
        for f in FACES {
            let g = f.map(|a| el[a]);
            faces
                .entry(sorted3([g[0], g[1], g[2]]))
                .or_default()
                .push((e, g));
            for (key, m) in mids(&g) {
                let old = *edge_mid.entry(key).or_insert(m);
                assert_eq!(old, m, "edge {key:?} has mid-edge nodes {old} and {m}");
            }
        }
    }
    let mut listed: HashMap<[usize; 3], usize> = HashMap::new();
    for (i, f) in mesh.boundary.iter().enumerate() {
        let key = sorted3([f.nodes[0], f.nodes[1], f.nodes[2]]);
        assert!(
            listed.insert(key, i).is_none(),
            "boundary face {i} listed twice"
        );
    }
    let mut boundary_count = 0;
    for (key, owners) in &faces {
        match owners.as_slice() {
            [(e, g)] => {
                boundary_count += 1;
                let i = *listed
                    .get(key)
                    .unwrap_or_else(|| panic!("boundary face {key:?} not listed"));
                let f = &mesh.boundary[i];
                assert_eq!(f.element, *e, "boundary face {i} names the wrong element");
                assert!(
                    same_cycle(g, &f.nodes),
                    "boundary face {i} is not oriented outward"
                );
                let mut want = mids(g);
                let mut got = mids(&f.nodes);
                want.sort_unstable();
                got.sort_unstable();
                assert_eq!(want, got, "boundary face {i}: mid-edge nodes differ");
            }
            [(e1, g1), (e2, g2)] => {
                assert!(
                    !listed.contains_key(key),
                    "interior face {key:?} listed as boundary"
                );
                let mut m1 = mids(g1);
                let mut m2 = mids(g2);
                m1.sort_unstable();
                m2.sort_unstable();
                assert_eq!(m1, m2, "elements {e1} and {e2} disagree on face {key:?}");
                let reversed = [g2[0], g2[2], g2[1], g2[5], g2[4], g2[3]];
                assert!(
                    same_cycle(g1, &reversed),
                    "elements {e1} and {e2} see face {key:?} with the same orientation"
                );
            }
            _ => panic!("face {key:?} shared by {} elements", owners.len()),
        }
    }
    assert_eq!(boundary_count, mesh.boundary.len());

    let mut seen: HashMap<[u64; 3], usize> = HashMap::new();
    for (i, p) in mesh.nodes.iter().enumerate() {
        let key = p.map(|v| (v + 0.0).to_bits());
        if let Some(j) = seen.insert(key, i) {
            panic!("nodes {j} and {i} coincide at {p:?}");
        }
    }
    let mut used = vec![false; mesh.node_count()];
    for el in &mesh.elements {
        for &n in el {
            used[n] = true;
        }
    }
    assert!(used.iter().all(|&u| u), "unused node");
}

/// Points (s, t) and weights of the 6-point degree-4 rule on the triangle
/// (0,0), (1,0), (0,1) (Dunavant 1985), weights summing to 1/2.
fn triangle_rule() -> [([f64; 2], f64); 6] {
    let (a1, w1) = (0.445_948_490_915_965, 0.223_381_589_678_011 / 2.0);
    let (a2, w2) = (0.091_576_213_509_771, 0.109_951_743_655_322 / 2.0);
    let b1 = 1.0 - 2.0 * a1;
    let b2 = 1.0 - 2.0 * a2;
    [
        ([a1, a1], w1),
        ([b1, a1], w1),
        ([a1, b1], w1),
        ([a2, a2], w2),
        ([b2, a2], w2),
        ([a2, b2], w2),
    ]
}

/// Position, and tangents along s and t, of the 6-node triangle `p` at (s, t).
fn triangle_map(p: &[[f64; 3]; 6], st: [f64; 2]) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let [s, t] = st;
    let l = [1.0 - s - t, s, t];
    let n = [
        l[0] * (2.0 * l[0] - 1.0),
        l[1] * (2.0 * l[1] - 1.0),
        l[2] * (2.0 * l[2] - 1.0),
        4.0 * l[0] * l[1],
        4.0 * l[1] * l[2],
        4.0 * l[2] * l[0],
    ];
    let ds = [
        -(4.0 * l[0] - 1.0),
        4.0 * l[1] - 1.0,
        0.0,
        4.0 * (l[0] - l[1]),
        4.0 * l[2],
        -4.0 * l[2],
    ];
    let dt = [
        -(4.0 * l[0] - 1.0),
        0.0,
        4.0 * l[2] - 1.0,
        -4.0 * l[1],
        4.0 * l[1],
        4.0 * (l[0] - l[2]),
    ];
    let mut x = [0.0; 3];
    let mut xs = [0.0; 3];
    let mut xt = [0.0; 3];
    for k in 0..6 {
        for r in 0..3 {
            x[r] += n[k] * p[k][r];
            xs[r] += ds[k] * p[k][r];
            xt[r] += dt[k] * p[k][r];
        }
    }
    (x, xs, xt)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Area vector (outward normal times area, exact) \[mm^2\] of a 6-node triangle.
pub fn area_vector(p: &[[f64; 3]; 6]) -> [f64; 3] {
    let mut a = [0.0; 3];
    for (st, w) in triangle_rule() {
        let (_, xs, xt) = triangle_map(p, st);
        let n = cross(xs, xt);
        for r in 0..3 {
            a[r] += w * n[r];
        }
    }
    a
}

/// Flux of the position field, integral of x . n dA (exact) \[mm^3\].
pub fn position_flux(p: &[[f64; 3]; 6]) -> f64 {
    triangle_rule()
        .iter()
        .map(|&(st, w)| {
            let (x, xs, xt) = triangle_map(p, st);
            let n = cross(xs, xt);
            w * (x[0] * n[0] + x[1] * n[1] + x[2] * n[2])
        })
        .sum()
}

pub fn face_points(mesh: &TetMesh, nodes: &[usize; 6]) -> [[f64; 3]; 6] {
    nodes.map(|n| mesh.nodes[n])
}

/// Asserts the boundary is closed and encloses `mesh.volume()` (1e-10 relative).
pub fn assert_watertight(mesh: &TetMesh) {
    let vol = mesh.volume();
    let scale = vol.abs().powf(2.0 / 3.0);
    let mut s = [0.0; 3];
    let mut flux = 0.0;
    for f in &mesh.boundary {
        let p = face_points(mesh, &f.nodes);
        let a = area_vector(&p);
        for r in 0..3 {
            s[r] += a[r];
        }
        flux += position_flux(&p);
    }
    assert!(
        s.iter().all(|v| v.abs() < 1e-12 * scale),
        "boundary not closed: {s:?}"
    );
    assert!(
        (flux / 3.0 - vol).abs() < 1e-10 * vol.abs(),
        "divergence volume {} vs {vol}",
        flux / 3.0
    );
}

/// Outward unit normal at the centre of a boundary triangle.
pub fn face_normal(mesh: &TetMesh, nodes: &[usize; 6]) -> [f64; 3] {
    let (_, xs, xt) = triangle_map(&face_points(mesh, nodes), [1.0 / 3.0, 1.0 / 3.0]);
    let n = cross(xs, xt);
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|v| v / len)
}
