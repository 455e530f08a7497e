//! A particle's contact surface: its nodes, their tributary areas and its
//! triangles (each boundary quad split in two, outward right-hand normals).

use crate::error::ContactError;
use parry3d_f64::math::Vector as PVector;
use parry3d_f64::shape::TriMesh;
use serde::{Deserialize, Serialize};

/// The curved surface of one particle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactSurface {
    /// Global node ids of the surface nodes.
    pub nodes: Vec<usize>,
    /// Tributary area of each surface node in the reference state [mm^2].
    pub areas: Vec<f64>,
    /// Triangles by global node id (outward right-hand normal).
    pub triangles: Vec<[usize; 3]>,
    /// Triangles by index into `nodes` (for the parry mesh).
    local: Vec<[u32; 3]>,
}

impl ContactSurface {
    /// The surface made of boundary quads `quads` (global node ids, outward
    /// right-hand normal) of a mesh with reference coordinates `nodes0`.
    pub fn from_quads(quads: &[[usize; 4]], nodes0: &[[f64; 3]]) -> Result<Self, ContactError> {
        let mut nodes: Vec<usize> = quads.iter().flatten().copied().collect();
        nodes.sort_unstable();
        nodes.dedup();
        if let Some(&n) = nodes.iter().find(|&&n| n >= nodes0.len()) {
            return Err(ContactError::Surface(format!(
                "node {n} is not in the mesh"
            )));
        }
        let index = |n: usize| nodes.binary_search(&n).unwrap_or(0);
        let mut areas = vec![0.0; nodes.len()];
        let mut triangles = Vec::with_capacity(2 * quads.len());
        let mut local = Vec::with_capacity(2 * quads.len());
        for q in quads {
            for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                let p = t.map(|n| nodes0[n]);
                let area = 0.5 * norm(&cross(&sub(&p[1], &p[0]), &sub(&p[2], &p[0])));
                for &n in &t {
                    areas[index(n)] += area / 3.0;
                }
                triangles.push(t);
                local.push(t.map(|n| index(n) as u32));
            }
        }
        Ok(Self {
            nodes,
            areas,
            triangles,
            local,
        })
    }

    /// Axis-aligned bounding box in the configuration `x` [mm].
    pub fn bounding_box(&self, x: &[f64]) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &n in &self.nodes {
            for i in 0..3 {
                lo[i] = lo[i].min(x[3 * n + i]);
                hi[i] = hi[i].max(x[3 * n + i]);
            }
        }
        (lo, hi)
    }

    /// The surface as a parry `TriMesh` in the configuration `x`.
    pub fn trimesh(&self, x: &[f64]) -> Option<TriMesh> {
        let vertices = self
            .nodes
            .iter()
            .map(|&n| PVector::new(x[3 * n], x[3 * n + 1], x[3 * n + 2]))
            .collect();
        TriMesh::new(vertices, self.local.clone()).ok()
    }
}

fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: &[f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}
