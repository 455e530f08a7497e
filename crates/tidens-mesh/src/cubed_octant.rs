//! "Cubed octant": hexahedral mesh of one octant of a spheroid.
//!
//! The unit-sphere octant is split into an inner block around the centre and
//! three outer blocks, one per cubed-sphere patch (patch `p` is the part of the
//! surface where coordinate `p` is the largest). The mesh of the spheroid
//! (semi-axes a, a, c) is the image of the unit-sphere mesh under
//! diag(a, a, c); an affine map keeps the mesh conforming and surface nodes
//! exactly on the spheroid.
//!
//! Construction on the unit sphere:
//! * Directions. The surface of patch `p` is the equiangular cubed-sphere grid
//!   `normalize(D)` with `D[p] = 1`, `D[p+1] = tan(alpha)`, `D[p+2] = tan(beta)`,
//!   `alpha, beta` in `[0, pi/4]` on the same (possibly graded) angle grid `T_i`.
//! * Inner block. The tensor grid `h * (T_i, T_j, T_k)` on the cube `[0, h]^3`,
//!   then "inflated" radially (see [`inflate`]) so that its three outer faces
//!   bulge toward the sphere. Its outer-face node in direction `D` lies on the
//!   ray through `D`, so the outer blocks are built along straight rays.
//! * Outer blocks. Along each ray, `m` radial layers from the inflated inner
//!   face to the sphere, on a radial parameter grid refined toward the surface.
//!
//! Nodes are merged by construction: every node has one canonical logical key
//! (inner grid index, or shell level plus canonical patch direction index), so
//! nodes shared by two blocks are created once.

use crate::grading::{refined_toward_one, refined_toward_zero};
use crate::hex::{FACE_ETA_MIN, FACE_XI_MIN, FACE_ZETA_MAX, FACE_ZETA_MIN, FACES};
use crate::{BoundaryFace, FaceKind, HexMesh, MeshError};

/// Shape of the unit-sphere octant layout: inner-cube half-size, inflation of
/// the inner block and its stretch along z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctantShape {
    /// Half-size `h` of the flat inner cube `[0, h]^3` before inflation (unit sphere).
    pub h: f64,
    /// Inflation `gamma0` in [0, 1) of the inner block's outer faces: 0 keeps
    /// the flat cube, 1 would make them a sphere of radius `h`.
    pub inflation: f64,
    /// Factor applied to z of the inner block (unit sphere), so that after the
    /// affine map diag(a, a, c) its extent along z is `c * h * z_stretch`.
    pub z_stretch: f64,
}

impl OctantShape {
    /// The layout used by [`crate::HexMesh::spheroid_octant`] for the aspect
    /// ratio `c / a` (> 0).
    ///
    /// Why these values. Where the inner block meets the three outer blocks
    /// (on the diagonal), four hexahedra share four edges. With a flat cube the
    /// three cube edges are orthogonal and the ray to the surface makes 54.7
    /// degrees with each cube face: the outer elements' corner scaled Jacobian
    /// is 1/sqrt(3) = 0.58 at best, and only 0.33 (c/a = 0.5) or 0.41 (c/a = 2)
    /// once stretched by diag(a, a, c). Inflating tilts the cube edges toward the
    /// tetrahedral configuration (four edges ~109.5 degrees apart, corner scaled
    /// Jacobian 0.77 in each of the four hexahedra), and stretching the inner
    /// block along z by `sqrt(c / a)` (in unit-sphere coordinates) undoes about
    /// half of the shear that the affine map puts on that corner.
    ///
    /// The numbers come from a sweep of `h` in 0.45..0.63, `inflation` in
    /// 0.35..0.65 and `z_stretch = (c/a)^beta`, beta in 0.1..1, over c/a in
    /// 0.25..4, divisions 2..24 and grading 1..4, maximising the worst scaled
    /// Jacobian. `h` hardly matters for that (it sets how much of the radius
    /// the inner block takes): 0.6 gives an outer shell 0.4 thick at the poles
    /// and ~0.25 on the diagonal, and inner and outer elements of similar size.
    /// It is reduced for elongated particles so that the stretched inner block
    /// stays clear of the pole (`h * z_stretch <= 0.66`), beyond which the
    /// elements near the top diagonal flatten. The best inflation falls from
    /// 0.65 at c/a = 1 toward 0.35 (flat) and 0.45 (elongated) particles.
    pub fn for_aspect(c_over_a: f64) -> OctantShape {
        let z_stretch = c_over_a.sqrt();
        let h = (0.66 / z_stretch).min(0.6);
        let octaves = c_over_a.log2();
        let slope = if octaves < 0.0 { 0.2 } else { 0.1 };
        let inflation = (0.65 - slope * octaves.abs()).clamp(0.35, 0.65);
        OctantShape {
            h,
            inflation,
            z_stretch,
        }
    }

    /// Checks that the inner block lies strictly inside the unit sphere and the
    /// inflation keeps the radial map monotone.
    pub fn validate(&self) -> Result<(), MeshError> {
        if !(self.h > 0.0 && self.h < 1.0) {
            return Err(MeshError::ShapeHalfSize(self.h));
        }
        if !(0.0..1.0).contains(&self.inflation) {
            return Err(MeshError::ShapeInflation(self.inflation));
        }
        if !(self.z_stretch > 0.0 && self.h * self.z_stretch < 1.0) {
            return Err(MeshError::ShapeZStretch {
                value: self.z_stretch,
                h: self.h,
            });
        }
        Ok(())
    }
}

/// Radial layers of the outer blocks for `n` inner-cube divisions and the
/// layout `shape`: the radial element size equals the tangential size at
/// mid-shell, averaged between the pole ray (shell thickness `1 - h`) and the
/// diagonal ray (unit sphere).
pub fn radial_divisions(n: usize, shape: &OctantShape) -> usize {
    let h = shape.h;
    let gamma0 = shape.inflation;
    let pole_gap = 1.0 - h;
    let diag_inner = h * ((1.0 - gamma0) * 3f64.sqrt() + gamma0);
    let diag_gap = 1.0 - diag_inner;
    let gap = 0.5 * (pole_gap + diag_gap);
    // Tangential size at the mid-radius of the shell, for an angle step pi / (4 n).
    let mid_radius = 0.5 * (1.0 + 0.5 * (h + diag_inner));
    let tangential = mid_radius * std::f64::consts::FRAC_PI_4 / n as f64;
    ((gap / tangential).round() as usize).max(1)
}

/// Radial map of the flat inner cube onto the inflated inner block.
///
/// A point `q` of the cube `[0, h]^3` lies on the face of the sub-cube
/// `[0, mu]^3`, `mu = max(q)`. It is moved along its ray to radius
/// `(1 - g) |q| + g mu`, i.e. blended between the flat sub-cube face and the
/// sphere of radius `mu`, with `g = gamma0 * mu / h`: the blend vanishes toward
/// the centre so that the central elements stay boxes, and it is `gamma0` on
/// the outer faces. Rays are preserved, so points on a coordinate plane stay
/// exactly on it.
fn inflate(q: [f64; 3], h: f64, gamma0: f64) -> [f64; 3] {
    let len = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
    if len == 0.0 {
        return q;
    }
    let mu = q[0].max(q[1]).max(q[2]);
    let g = gamma0 * mu / h;
    let factor = (1.0 - g) + g * mu / len;
    q.map(|v| v * factor)
}

/// Geometry and resolution parameters of one octant mesh (unit sphere).
#[derive(Clone, Copy, Debug)]
pub(crate) struct OctantLayout {
    pub a: f64,
    pub c: f64,
    pub n: usize,
    /// Radial layers of the outer blocks.
    pub m: usize,
    pub grading: f64,
    pub shape: OctantShape,
}

impl OctantLayout {
    /// Layout of a validated spec with the given shape.
    pub(crate) fn new(a: f64, c: f64, n: usize, grading: f64, shape: OctantShape) -> Self {
        OctantLayout {
            a,
            c,
            n,
            m: radial_divisions(n, &shape),
            grading,
            shape,
        }
    }
}

/// Logical address of a node, before numbering.
#[derive(Clone, Copy)]
enum Key {
    /// Inner-block grid index `(i, j, k)`, each in `0..=n`.
    Inner([usize; 3]),
    /// Outer-shell layer `s` in `0..=m` (0 = inner block's outer face, m = sphere)
    /// on the ray of direction index `dir` (each in `0..=n`, at least one equal to n).
    Shell(usize, [usize; 3]),
}

struct Builder {
    layout: OctantLayout,
    /// Graded angle grid mapped to tangents: `tan(pi/4 * g_i)`, exactly 0 and 1 at the ends.
    tan: Vec<f64>,
    /// Radial parameter grid of the shell, 0 at the inner block, 1 on the sphere.
    radial: Vec<f64>,
    slots: Vec<usize>,
    nodes: Vec<[f64; 3]>,
    /// Canonical key of each node, in node order.
    keys: Vec<Key>,
}

const NONE: usize = usize::MAX;

impl Builder {
    fn new(layout: OctantLayout) -> Self {
        let n = layout.n;
        let angles = refined_toward_zero(n, layout.grading);
        let mut tan: Vec<f64> = angles
            .iter()
            .map(|g| (std::f64::consts::FRAC_PI_4 * g).tan())
            .collect();
        // tan(pi/4) rounds to 0.9999999999999999; the patch corners must be exact
        // so that the diagonal and face-diagonal points are exact nodes.
        tan[0] = 0.0;
        tan[n] = 1.0;
        let radial = refined_toward_one(layout.m, layout.grading);
        let n1 = n + 1;
        let slot_count = n1 * n1 * n1 + (layout.m + 1) * 3 * n1 * n1;
        Builder {
            layout,
            tan,
            radial,
            slots: vec![NONE; slot_count],
            nodes: Vec::new(),
            keys: Vec::new(),
        }
    }

    /// Canonical key: inner nodes on the inner block's outer faces are shell layer 0.
    fn canonical(&self, key: Key) -> Key {
        match key {
            Key::Inner(ijk) if ijk.contains(&self.layout.n) => Key::Shell(0, ijk),
            k => k,
        }
    }

    fn slot(&self, key: Key) -> usize {
        let n1 = self.layout.n + 1;
        match key {
            Key::Inner([i, j, k]) => (i * n1 + j) * n1 + k,
            Key::Shell(s, dir) => {
                // Canonical patch of a direction: the first axis whose index is n.
                let p = dir.iter().position(|&d| d == self.layout.n).unwrap_or(0);
                let (u, v) = (dir[(p + 1) % 3], dir[(p + 2) % 3]);
                n1 * n1 * n1 + s * 3 * n1 * n1 + (p * n1 + u) * n1 + v
            }
        }
    }

    fn position(&self, key: Key) -> [f64; 3] {
        let l = &self.layout;
        let unit = match key {
            Key::Inner(ijk) => self.inner(ijk.map(|i| self.tan[i])),
            Key::Shell(s, dir) => {
                let d = dir.map(|i| self.tan[i]);
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let surface = d.map(|v| v / len);
                let inner = self.inner(d);
                let t = self.radial[s];
                // At t = 1 this is exactly `surface` (0 * inner adds exact zeros).
                std::array::from_fn(|r| (1.0 - t) * inner[r] + t * surface[r])
            }
        };
        [l.a * unit[0], l.a * unit[1], l.c * unit[2]]
    }

    /// Inner-block point of the flat-cube grid point `h * d`.
    fn inner(&self, d: [f64; 3]) -> [f64; 3] {
        let s = &self.layout.shape;
        let p = inflate(d.map(|v| s.h * v), s.h, s.inflation);
        [p[0], p[1], s.z_stretch * p[2]]
    }

    fn node(&mut self, key: Key) -> usize {
        let key = self.canonical(key);
        let slot = self.slot(key);
        if self.slots[slot] == NONE {
            self.slots[slot] = self.nodes.len();
            let p = self.position(key);
            self.nodes.push(p);
            self.keys.push(key);
        }
        self.slots[slot]
    }
}

/// VTK-ordered logical corner offsets (du, dv, dw) of a hexahedron.
const OFFSETS: [[usize; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [1, 1, 0],
    [0, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [1, 1, 1],
    [0, 1, 1],
];

fn face(element: &[usize; 8], local: usize, index: usize, kind: FaceKind) -> BoundaryFace {
    BoundaryFace {
        nodes: FACES[local].map(|i| element[i]),
        element: index,
        kind,
    }
}

/// Where a node sits on the construction ray of a surface node: the shell
/// node at radial parameter `t` on the ray of direction `D` is
/// `(1 - t) inner(D) + t surface(D)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RayPlace {
    /// Index of the surface node at the outer end of the ray.
    pub surface: usize,
    /// Radial parameter: 0 on the inner block's outer face, 1 on the surface.
    pub t: f64,
}

/// An octant mesh with the construction data that moving its surface needs.
pub(crate) struct OctantMesh {
    pub mesh: HexMesh,
    /// Per node, its place on a construction ray; `None` inside the inner block.
    pub rays: Vec<Option<RayPlace>>,
    /// The seven special surface nodes (directions whose indices are all 0 or
    /// n): the three poles, the diagonal point and the three face-diagonal
    /// points.
    pub special: Vec<usize>,
}

/// Builds the octant mesh for a validated layout.
pub(crate) fn build(layout: OctantLayout) -> OctantMesh {
    let (n, m) = (layout.n, layout.m);
    let mut b = Builder::new(layout);
    let mut elements = Vec::with_capacity(n * n * n + 3 * n * n * m);
    let mut boundary = Vec::new();
    let plane = |axis| FaceKind::Plane { axis, high: false };

    // Inner block: logical axes (i, j, k) = (x, y, z), right-handed.
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let el = OFFSETS.map(|o| b.node(Key::Inner([i + o[0], j + o[1], k + o[2]])));
                let e = elements.len();
                if i == 0 {
                    boundary.push(face(&el, FACE_XI_MIN, e, plane(0)));
                }
                if j == 0 {
                    boundary.push(face(&el, FACE_ETA_MIN, e, plane(1)));
                }
                if k == 0 {
                    boundary.push(face(&el, FACE_ZETA_MIN, e, plane(2)));
                }
                elements.push(el);
            }
        }
    }

    // Outer block of patch p: logical axes (u, v, s) along (e_(p+1), e_(p+2), e_p),
    // a cyclic permutation of (x, y, z), hence right-handed.
    for p in 0..3 {
        let (pu, pv) = ((p + 1) % 3, (p + 2) % 3);
        for u in 0..n {
            for v in 0..n {
                for s in 0..m {
                    let el = OFFSETS.map(|o| {
                        let mut dir = [0; 3];
                        dir[p] = n;
                        dir[pu] = u + o[0];
                        dir[pv] = v + o[1];
                        b.node(Key::Shell(s + o[2], dir))
                    });
                    let e = elements.len();
                    if u == 0 {
                        boundary.push(face(&el, FACE_XI_MIN, e, plane(pu)));
                    }
                    if v == 0 {
                        boundary.push(face(&el, FACE_ETA_MIN, e, plane(pv)));
                    }
                    if s + 1 == m {
                        boundary.push(face(&el, FACE_ZETA_MAX, e, FaceKind::Curved));
                    }
                    elements.push(el);
                }
            }
        }
    }

    let surface_node =
        |dir: [usize; 3]| Some(b.slots[b.slot(Key::Shell(m, dir))]).filter(|&i| i != NONE);
    let rays = b
        .keys
        .iter()
        .map(|key| match *key {
            Key::Inner(_) => None,
            Key::Shell(s, dir) => surface_node(dir).map(|surface| RayPlace {
                surface,
                t: b.radial[s],
            }),
        })
        .collect();
    let special = b
        .keys
        .iter()
        .enumerate()
        .filter(|(_, key)| match key {
            Key::Shell(s, dir) => *s == m && dir.iter().all(|&d| d == 0 || d == n),
            Key::Inner(_) => false,
        })
        .map(|(i, _)| i)
        .collect();
    OctantMesh {
        mesh: HexMesh {
            nodes: b.nodes,
            elements,
            boundary,
        },
        rays,
        special,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inflate_keeps_axes_planes_and_centre() {
        let (h, g) = (0.6, 0.65);
        assert_eq!(inflate([0.0; 3], h, g), [0.0; 3]);
        assert_eq!(inflate([h, 0.0, 0.0], h, g), [h, 0.0, 0.0]);
        let p = inflate([h, 0.3, 0.0], h, g);
        assert_eq!(p[2], 0.0);
        // The cube corner moves inward along the diagonal, to radius h((1-g)sqrt3 + g).
        let c = inflate([h; 3], h, g);
        let r = (3.0 * c[0] * c[0]).sqrt();
        assert!((r - h * ((1.0 - g) * 3f64.sqrt() + g)).abs() < 1e-14);
    }

    #[test]
    fn shape_rule_is_continuous_at_sphere() {
        let s = OctantShape::for_aspect(1.0);
        assert_eq!(
            s,
            OctantShape {
                h: 0.6,
                inflation: 0.65,
                z_stretch: 1.0
            }
        );
        for r in [0.25, 0.5, 2.0, 4.0] {
            let s = OctantShape::for_aspect(r);
            assert!(s.h * s.z_stretch <= 0.66 + 1e-12 && (0.35..=0.65).contains(&s.inflation));
        }
    }

    #[test]
    fn rays_end_on_their_surface_node_and_seven_nodes_are_special() {
        for (n, grading, c) in [(2, 1.0, 1.0), (5, 3.0, 0.5), (8, 1.0, 2.0)] {
            let shape = OctantShape::for_aspect(c);
            let built = build(OctantLayout::new(1.0, c, n, grading, shape));
            let mesh = &built.mesh;
            assert_eq!(built.rays.len(), mesh.nodes.len());
            for f in mesh.boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
                for &k in &f.nodes {
                    assert_eq!(built.rays[k], Some(RayPlace { surface: k, t: 1.0 }));
                }
            }
            for (k, ray) in built.rays.iter().enumerate() {
                if let Some(RayPlace { surface, t }) = *ray {
                    assert!((0.0..=1.0).contains(&t));
                    assert_eq!(t == 1.0, surface == k, "node {k}");
                }
            }
            // The centre is in the inner block.
            let centre = mesh.nodes.iter().position(|p| *p == [0.0; 3]);
            assert_eq!(centre.map(|k| built.rays[k]), Some(None));
            let mut special: Vec<[f64; 3]> = built.special.iter().map(|&k| mesh.nodes[k]).collect();
            special.sort_by(|p, q| p.partial_cmp(q).unwrap_or(std::cmp::Ordering::Equal));
            let s2 = std::f64::consts::FRAC_1_SQRT_2;
            let s3 = 1.0 / 3f64.sqrt();
            let mut want = [
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, c],
                [s3, s3, c * s3],
                [s2, s2, 0.0],
                [s2, 0.0, c * s2],
                [0.0, s2, c * s2],
            ];
            want.sort_by(|p, q| p.partial_cmp(q).unwrap_or(std::cmp::Ordering::Equal));
            assert_eq!(special.len(), 7);
            for (p, q) in special.iter().zip(&want) {
                assert!(
                    (0..3).all(|r| (p[r] - q[r]).abs() < 1e-15),
                    "{p:?} vs {q:?}"
                );
            }
        }
    }

    #[test]
    fn radial_divisions_grow_with_n() {
        let shape = OctantShape::for_aspect(1.0);
        let ms: Vec<usize> = [2, 4, 8, 16]
            .iter()
            .map(|&n| radial_divisions(n, &shape))
            .collect();
        assert!(ms.windows(2).all(|w| w[1] > w[0]), "{ms:?}");
        assert!(ms[0] >= 1);
    }
}
