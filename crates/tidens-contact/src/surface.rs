//! A particle's contact surface: its nodes, their tributary areas, its
//! facets (bilinear quads, or flat triangles), and the triangles parry
//! searches (two per quad, the facet itself for a triangle).

use std::collections::BTreeMap;

use crate::error::ContactError;
use parry3d_f64::math::Vector as PVector;
use parry3d_f64::shape::{TriMesh, TriMeshFlags};
use serde::{Deserialize, Serialize};

/// The shape of a surface's facets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FacetKind {
    /// Bilinear quadrilaterals (the faces of hexahedra).
    #[default]
    Quad,
    /// Flat 3-node triangles (the 6-node faces of quadratic tetrahedra,
    /// each split into its four corner and middle triangles).
    Triangle,
}

/// The curved surface of one particle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactSurface {
    /// Global node ids of the surface nodes.
    pub nodes: Vec<usize>,
    /// Tributary area of each surface node in the reference state \[mm^2\].
    pub areas: Vec<f64>,
    /// Facets by global node id (counter-clockwise about the outward
    /// normal); a triangle repeats its third node in the fourth place.
    pub facets: Vec<[usize; 4]>,
    /// The shape of the facets.
    #[serde(default)]
    pub kind: FacetKind,
    /// Triangles for the search, by index into `nodes`: triangles `2 q` and
    /// `2 q + 1` cover quad `q`; triangle `t` is triangle facet `t`.
    triangles: Vec<[u32; 3]>,
    /// The facets around each facet (sharing a node with it, itself included).
    ring: Vec<Vec<usize>>,
    /// A periodic image of another particle's surface (see
    /// [`ContactSurface::image`]): a master only, its nodes never slaves.
    #[serde(default)]
    pub master_only: bool,
    /// The facets continued past the surface's open edges, as a master
    /// (see [`ContactSurface::continue_open_edges`]): by facet, each corner
    /// of the continued facet as weights of the facet's nodes.
    #[serde(default)]
    continued: BTreeMap<usize, Continuation>,
}

/// The corners of a continued facet: row `a` holds the weights of the
/// facet's nodes in corner `a` (the same in every coordinate).
pub type Continuation = [[f64; 4]; 4];

impl ContactSurface {
    /// The surface made of boundary quads `quads` (global node ids, outward
    /// right-hand normal) of a mesh with reference coordinates `nodes0`.
    pub fn from_quads(quads: &[[usize; 4]], nodes0: &[[f64; 3]]) -> Result<Self, ContactError> {
        Self::build(quads.to_vec(), FacetKind::Quad, nodes0)
    }

    /// The surface of boundary quads `quads` (as [`Self::from_quads`]) with
    /// each quad's facet its two flat triangles, split along the quad's
    /// shorter diagonal in the reference configuration (corners 0-2 when the
    /// two agree within 1e-9; a mirror image of a mesh reverses its quads as
    /// 0-3-2-1 and so keeps that diagonal). The tributary areas are the
    /// quads', a quarter of each quad to each of its corners, as with
    /// bilinear facets.
    ///
    /// A flat triangle has one closest point to a node; a bilinear patch
    /// warped by the deformation has several, and near the slender tips of
    /// particles of c/a = 5 (the sc2 cell at mesh levels 2 and 3) the patch
    /// and its triangles parted by 2e-3 mm in a cell 0.082 mm wide: a node
    /// 1.8e-5 mm from the triangles that parry searches read 2.1e-3 mm deep
    /// on the patch, was pushed out at once and the density fell. On the
    /// triangles the contact measures the node on the surface it searches.
    pub fn from_quads_as_triangles(
        quads: &[[usize; 4]],
        nodes0: &[[f64; 3]],
    ) -> Result<Self, ContactError> {
        if let Some(&n) = quads.iter().flatten().find(|&&n| n >= nodes0.len()) {
            return Err(ContactError::Surface(format!(
                "node {n} is not in the mesh"
            )));
        }
        let d2 = |a: usize, b: usize| norm(&sub(&nodes0[a], &nodes0[b]));
        let facets = quads
            .iter()
            .flat_map(|q| {
                let (d02, d13) = (d2(q[0], q[2]), d2(q[1], q[3]));
                let [a, b] = if d02 <= d13 * (1.0 + 1e-9) {
                    [[q[0], q[1], q[2], q[2]], [q[0], q[2], q[3], q[3]]]
                } else {
                    [[q[1], q[2], q[3], q[3]], [q[1], q[3], q[0], q[0]]]
                };
                // The triangle of the lower-numbered corner off the diagonal
                // first: reversed (0-3-2-1), a mirror image keeps the order,
                // and facets that measure a node alike are chosen by index.
                let off = |t: &[usize; 4]| t.iter().copied().find(|&n| n != t[0] && n != t[2]);
                if off(&b) < off(&a) { [b, a] } else { [a, b] }
            })
            .collect();
        let mut surface = Self::build(facets, FacetKind::Triangle, nodes0)?;
        surface.areas = Self::build(quads.to_vec(), FacetKind::Quad, nodes0)?.areas;
        Ok(surface)
    }

    /// The surface made of flat boundary triangles `triangles` (global node
    /// ids, outward right-hand normal) of a mesh with reference coordinates
    /// `nodes0`.
    pub fn from_triangles(
        triangles: &[[usize; 3]],
        nodes0: &[[f64; 3]],
    ) -> Result<Self, ContactError> {
        let facets = triangles.iter().map(|t| [t[0], t[1], t[2], t[2]]).collect();
        Self::build(facets, FacetKind::Triangle, nodes0)
    }

    fn build(
        facets: Vec<[usize; 4]>,
        kind: FacetKind,
        nodes0: &[[f64; 3]],
    ) -> Result<Self, ContactError> {
        let mut nodes: Vec<usize> = facets.iter().flatten().copied().collect();
        nodes.sort_unstable();
        nodes.dedup();
        if let Some(&n) = nodes.iter().find(|&&n| n >= nodes0.len()) {
            return Err(ContactError::Surface(format!(
                "node {n} is not in the mesh"
            )));
        }
        let index = |n: usize| nodes.binary_search(&n).unwrap_or(0);
        let mut areas = vec![0.0; nodes.len()];
        let mut triangles = Vec::with_capacity(2 * facets.len());
        for q in &facets {
            let p = q.map(|n| nodes0[n]);
            match kind {
                FacetKind::Quad => {
                    // Half the cross product of the diagonals: the area of
                    // the quad, the same whichever diagonal splits it; a
                    // quarter to each node.
                    let area = 0.5 * norm(&cross(&sub(&p[2], &p[0]), &sub(&p[3], &p[1])));
                    for &n in q {
                        areas[index(n)] += 0.25 * area;
                    }
                    for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                        triangles.push(t.map(|n| index(n) as u32));
                    }
                }
                FacetKind::Triangle => {
                    let area = 0.5 * norm(&cross(&sub(&p[1], &p[0]), &sub(&p[2], &p[0])));
                    for &n in &q[..3] {
                        areas[index(n)] += area / 3.0;
                    }
                    triangles.push([q[0], q[1], q[2]].map(|n| index(n) as u32));
                }
            }
        }
        let mut around: Vec<Vec<usize>> = vec![Vec::new(); nodes.len()];
        for (qi, q) in facets.iter().enumerate() {
            for &n in q {
                around[index(n)].push(qi);
            }
        }
        let ring = facets
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
            facets,
            kind,
            triangles,
            ring,
            master_only: false,
            continued: BTreeMap::new(),
        })
    }

    /// The surface's periodic image: the same facets on the image nodes
    /// `renumber(n)` of its nodes `n` (copies translated by a period of the
    /// cell, whose displacements are the originals'), a master only.
    ///
    /// Contact between a particle and an image of another is the contact
    /// of the two across the cell's boundary. Its two passes are each
    /// particle's nodes on the other's image: the image's nodes are never
    /// slaves, so that every image of a particle that another can touch must
    /// be there (the images by both `t` and `-t` for a period `t`) for each
    /// contact to have both passes once.
    ///
    /// `renumber` must be increasing (image nodes in the order of their
    /// originals), so that the search triangles and facet rings carry over.
    pub fn image(&self, renumber: impl Fn(usize) -> usize) -> Result<Self, ContactError> {
        let nodes: Vec<usize> = self.nodes.iter().map(|&n| renumber(n)).collect();
        if nodes.windows(2).any(|w| w[0] >= w[1]) {
            return Err(ContactError::Surface(
                "the image's node numbering must increase with the original's".into(),
            ));
        }
        Ok(Self {
            nodes,
            areas: self.areas.clone(),
            facets: self.facets.iter().map(|f| f.map(&renumber)).collect(),
            kind: self.kind,
            triangles: self.triangles.clone(),
            ring: self.ring.clone(),
            master_only: true,
            continued: self.continued.clone(),
        })
    }

    /// Continues the facets along the surface's open edges (edges of one
    /// facet only) past those edges by `reach` times their height, for
    /// the surface's role as a master in mortar contact: a triangle with
    /// one open edge is scaled by `1 + reach` about its opposite corner,
    /// one with two open edges has their common corner moved `reach` times
    /// its distance from the middle of the third edge further out. Each
    /// corner of a continued facet is a fixed combination of the facet's
    /// nodes, so the facet stays flat and its derivatives go to its nodes.
    ///
    /// A particle cut by a plane of symmetry of its cell (an octant) has
    /// its open edges on that plane, and so has its neighbour. The two
    /// surfaces end on the same plane: projected onto a slave facet that
    /// meets the plane at a right angle, the master's last edge lies along
    /// the slave's own, and which of the two bounds their overlap flips
    /// with round-off; the weighted gaps then have a kink there (a jump in
    /// the contact force) that Newton cannot converge across (sc2 at mesh
    /// level 1 with rho = 0.82: a jump of 1e-3 N in one node's force where
    /// the residual tolerance is 1e-5 N). Past the plane the mirror image
    /// continues the particle; the continued facet stands in for it, so
    /// that the slave's edge alone bounds the overlap there.
    ///
    /// Bilinear quad facets are left as they are.
    pub fn continue_open_edges(&mut self, reach: f64) {
        self.continued.clear();
        if self.kind != FacetKind::Triangle || !(reach > 0.0) {
            return;
        }
        let edge = |a: usize, b: usize| (a.min(b), a.max(b));
        let mut uses: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        for f in &self.facets {
            for i in 0..3 {
                *uses.entry(edge(f[i], f[(i + 1) % 3])).or_default() += 1;
            }
        }
        for (fi, f) in self.facets.iter().enumerate() {
            // Local edges (i, i + 1) that are open.
            let open: Vec<usize> = (0..3)
                .filter(|&i| uses[&edge(f[i], f[(i + 1) % 3])] == 1)
                .collect();
            let mut t: Continuation =
                std::array::from_fn(|a| std::array::from_fn(|l| if a == l { 1.0 } else { 0.0 }));
            match open[..] {
                [i] => {
                    let k = (i + 2) % 3;
                    for a in [i, (i + 1) % 3] {
                        t[a][a] = 1.0 + reach;
                        t[a][k] = -reach;
                    }
                }
                [i, j] => {
                    // The common corner of edges (i, i+1) and (j, j+1).
                    let c = if (i + 1) % 3 == j { j } else { i };
                    let (p, q) = ((c + 1) % 3, (c + 2) % 3);
                    t[c][c] = 1.0 + reach;
                    t[c][p] = -0.5 * reach;
                    t[c][q] = -0.5 * reach;
                }
                _ => continue,
            }
            t[3] = t[2];
            self.continued.insert(fi, t);
        }
    }

    /// The corners of facet `f` continued past the surface's open edges
    /// ([`ContactSurface::continue_open_edges`]), if it has any.
    pub fn continuation(&self, f: usize) -> Option<&Continuation> {
        self.continued.get(&f)
    }

    /// The facet that search triangle `t` lies on.
    pub fn facet_of_triangle(&self, t: usize) -> usize {
        match self.kind {
            FacetKind::Quad => t / 2,
            FacetKind::Triangle => t,
        }
    }

    /// The facets sharing a node with facet `q` (itself included).
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
    /// `t` lies on facet [`Self::facet_of_triangle`]`(t)`. The mesh is
    /// oriented (outward normals), so parry keeps the pseudo-normals of its
    /// edges and vertices and tells on which side of the surface a point
    /// lies, also where its nearest point is on an edge or a corner.
    pub fn trimesh(&self, x: &[f64]) -> Option<TriMesh> {
        let vertices = self
            .nodes
            .iter()
            .map(|&n| PVector::new(x[3 * n], x[3 * n + 1], x[3 * n + 2]))
            .collect();
        TriMesh::with_flags(vertices, self.triangles.clone(), TriMeshFlags::ORIENTED).ok()
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
