//! A particle's contact surface: its nodes, their tributary areas, its
//! bilinear quad facets, and the triangles parry searches (two per quad).

use crate::error::ContactError;
use parry3d_f64::math::Vector as PVector;
use parry3d_f64::shape::TriMesh;
use serde::{Deserialize, Serialize};

/// The curved surface of one particle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactSurface {
    /// Global node ids of the surface nodes.
    pub nodes: Vec<usize>,
    /// Tributary area of each surface node in the reference state \[mm^2\].
    pub areas: Vec<f64>,
    /// Quad facets by global node id (counter-clockwise about the outward
    /// normal).
    pub quads: Vec<[usize; 4]>,
    /// Triangles for the search, by index into `nodes`: triangles `2 q` and
    /// `2 q + 1` cover quad `q`.
    triangles: Vec<[u32; 3]>,
    /// The quads around each quad (sharing a node with it, itself included).
    ring: Vec<Vec<usize>>,
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
        for q in quads {
            // Half the cross product of the diagonals: the area of the quad,
            // the same whichever diagonal splits it; a quarter to each node.
            let p = q.map(|n| nodes0[n]);
            let area = 0.5 * norm(&cross(&sub(&p[2], &p[0]), &sub(&p[3], &p[1])));
            for &n in q {
                areas[index(n)] += 0.25 * area;
            }
            for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                triangles.push(t.map(|n| index(n) as u32));
            }
        }
        let mut around: Vec<Vec<usize>> = vec![Vec::new(); nodes.len()];
        for (qi, q) in quads.iter().enumerate() {
            for &n in q {
                around[index(n)].push(qi);
            }
        }
        let ring = quads
            .iter()
            .map(|q| {
                let mut r: Vec<usize> = q
                    .iter()
                    .flat_map(|&n| around[index(n)].iter().copied())
                    .collect();
                r.sort_unstable();
                r.dedup();
                r
            })
            .collect();
        Ok(Self {
            nodes,
            areas,
            quads: quads.to_vec(),
            triangles,
            ring,
        })
    }

    /// The quads sharing a node with quad `q` (itself included).
    pub fn ring(&self, q: usize) -> &[usize] {
        &self.ring[q]
    }

    /// Axis-aligned bounding box in the configuration `x` \[mm\].
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

    /// The surface as a parry `TriMesh` in the configuration `x`; triangle
    /// `t` lies on quad `t / 2`.
    pub fn trimesh(&self, x: &[f64]) -> Option<TriMesh> {
        let vertices = self
            .nodes
            .iter()
            .map(|&n| PVector::new(x[3 * n], x[3 * n + 1], x[3 * n + 2]))
            .collect();
        TriMesh::new(vertices, self.triangles.clone()).ok()
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
