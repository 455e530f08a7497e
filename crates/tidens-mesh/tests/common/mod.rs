//! Helpers shared by the integration tests: independent checks of a mesh's
//! topology and boundary, written without the crate's construction logic.
#![allow(dead_code)]

use std::collections::HashMap;
use tidens_mesh::hex::{FACES, quad_area_vector, quad_position_flux};
use tidens_mesh::{FaceKind, HexMesh, OctantSpec};

/// The aspect ratios c/a required by the mesh specification.
pub const ASPECTS: [f64; 5] = [0.5, 0.8, 1.0, 1.2, 2.0];

pub fn octant(a: f64, c: f64, divisions: usize, grading: f64) -> HexMesh {
    HexMesh::spheroid_octant(&OctantSpec {
        a,
        c,
        divisions,
        grading,
    })
    .expect("valid spec")
}

/// Inner-cube divisions of mesh levels 1 to 6.
pub const LEVEL_DIVISIONS: [usize; 6] = [4, 6, 8, 11, 16, 23];

/// Like [`octant`], built with [`HexMesh::spheroid_octant_exact_volume`].
pub fn exact_octant(a: f64, c: f64, divisions: usize, grading: f64) -> HexMesh {
    HexMesh::spheroid_octant_exact_volume(&OctantSpec {
        a,
        c,
        divisions,
        grading,
    })
    .expect("valid spec")
}

fn sorted(mut q: [usize; 4]) -> [usize; 4] {
    q.sort_unstable();
    q
}

/// Element faces keyed by their sorted node quad -> list of (element, local face).
pub fn face_map(mesh: &HexMesh) -> HashMap<[usize; 4], Vec<(usize, usize)>> {
    let mut map: HashMap<[usize; 4], Vec<(usize, usize)>> = HashMap::new();
    for (e, el) in mesh.elements.iter().enumerate() {
        for (f, local) in FACES.iter().enumerate() {
            map.entry(sorted(local.map(|i| el[i])))
                .or_default()
                .push((e, f));
        }
    }
    map
}

/// Asserts: every face is shared by one or two elements; the faces with one
/// element are exactly the listed boundary quads, each listed once, with the
/// listed element and with the same cyclic orientation as the element's
/// outward face; no two nodes have the same coordinates; every node is used.
pub fn assert_conforming(mesh: &HexMesh) {
    let map = face_map(mesh);
    let mut listed: HashMap<[usize; 4], usize> = HashMap::new();
    for (i, f) in mesh.boundary.iter().enumerate() {
        assert!(
            listed.insert(sorted(f.nodes), i).is_none(),
            "boundary face {i} listed twice"
        );
    }
    let mut boundary_count = 0;
    for (key, owners) in &map {
        assert!(
            owners.len() <= 2,
            "face {key:?} shared by {} elements",
            owners.len()
        );
        if owners.len() == 1 {
            boundary_count += 1;
            let i = *listed
                .get(key)
                .unwrap_or_else(|| panic!("boundary face {key:?} not listed"));
            let f = &mesh.boundary[i];
            let (e, local) = owners[0];
            assert_eq!(f.element, e, "boundary face {i} names the wrong element");
            let outward = FACES[local].map(|k| mesh.elements[e][k]);
            let start = outward
                .iter()
                .position(|&n| n == f.nodes[0])
                .expect("same nodes");
            let rotated: [usize; 4] = std::array::from_fn(|k| outward[(start + k) % 4]);
            assert_eq!(
                rotated, f.nodes,
                "boundary face {i} is not oriented outward"
            );
        } else {
            assert!(
                !listed.contains_key(key),
                "interior face {key:?} listed as boundary"
            );
        }
    }
    assert_eq!(boundary_count, mesh.boundary.len());

    let mut seen: HashMap<[u64; 3], usize> = HashMap::new();
    for (i, p) in mesh.nodes.iter().enumerate() {
        // + 0.0 folds -0.0 into +0.0.
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

/// Minimum distance between distinct nodes, relative to `scale` (catches
/// near-duplicates that an exact-bit comparison misses). O(n log n) via a grid.
pub fn min_node_spacing(mesh: &HexMesh, cell: f64) -> f64 {
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, p) in mesh.nodes.iter().enumerate() {
        grid.entry(p.map(|v| (v / cell).floor() as i64))
            .or_default()
            .push(i);
    }
    let mut best = f64::INFINITY;
    for (key, list) in &grid {
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(other) = grid.get(&[key[0] + dx, key[1] + dy, key[2] + dz]) {
                        for &i in list {
                            for &j in other {
                                if i < j {
                                    let d: f64 = (0..3)
                                        .map(|r| (mesh.nodes[i][r] - mesh.nodes[j][r]).powi(2))
                                        .sum();
                                    best = best.min(d.sqrt());
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    best
}

/// Sum over the boundary of the outward area vectors \[mm^2\] (zero for a closed surface).
pub fn boundary_area_sum(mesh: &HexMesh) -> [f64; 3] {
    let mut s = [0.0; 3];
    for f in &mesh.boundary {
        let a = quad_area_vector(&f.nodes.map(|n| mesh.nodes[n]));
        for r in 0..3 {
            s[r] += a[r];
        }
    }
    s
}

/// Volume \[mm^3\] from the divergence theorem, (1/3) sum over the boundary of x.n dA.
pub fn divergence_volume(mesh: &HexMesh) -> f64 {
    mesh.boundary
        .iter()
        .map(|f| quad_position_flux(&f.nodes.map(|n| mesh.nodes[n])))
        .sum::<f64>()
        / 3.0
}

/// Asserts the boundary is closed and encloses `mesh.volume()` (1e-10 relative).
pub fn assert_watertight(mesh: &HexMesh) {
    let vol = mesh.volume();
    let scale = vol.abs().powf(2.0 / 3.0);
    let s = boundary_area_sum(mesh);
    assert!(
        s.iter().all(|v| v.abs() < 1e-12 * scale),
        "boundary not closed: {s:?}"
    );
    let div = divergence_volume(mesh);
    assert!(
        (div - vol).abs() < 1e-10 * vol.abs(),
        "divergence volume {div} vs {vol}"
    );
}

/// Outward unit normal of a boundary quad (from its area vector).
pub fn face_normal(mesh: &HexMesh, nodes: [usize; 4]) -> [f64; 3] {
    let a = quad_area_vector(&nodes.map(|n| mesh.nodes[n]));
    let len = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|v| v / len)
}

pub fn is_plane(kind: FaceKind, axis: usize, high: bool) -> bool {
    kind == FaceKind::Plane { axis, high }
}
