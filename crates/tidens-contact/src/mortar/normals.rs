//! Nodal normals of a surface and their derivatives with respect to the
//! nodes around.
//!
//! The normal at node `j` is the normalised sum over the facets `e` around
//! it of the area vector `x_xi x x_eta` of `e` at `j`'s corner:
//!
//! ```text
//! m_j = sum_{e at j} k_e (x_next - x_j) x (x_prev - x_j),   n_j = m_j / |m_j|
//! ```
//!
//! with `next`, `prev` the corners after and before `j` in `e` (counter-
//! clockwise about the outward normal), `k_e = 1` on a triangle (where
//! `x_xi x x_eta` is this product at every point, twice the area) and
//! `k_e = 1/4` on a bilinear quad (where it is `x_xi x x_eta` at the
//! corner). Larger facets weigh more; on a flat surface every weighting
//! gives the plane's normal.
//!
//! Derivatives: `dn_j = (I - n_j n_j^T) dm_j / |m_j|`, and `m_j` depends on
//! the nodes of the facets around `j` (its ring). [`normal_derivatives`]
//! takes them exactly, first and (if asked) second, by forward-mode
//! automatic differentiation over the ring's coordinates (`num-dual`'s
//! dynamically sized numbers: a ring has from 4 to about 13 nodes).

use nalgebra::{DMatrix, DVector, Dyn, Matrix3xX, OVector, U3, Vector3};
use num_dual::{Dual2DVec64, DualDVec64, DualNum};

use crate::mortar::trace::Trace;
use crate::surface::ContactSurface;

/// The facets around each node of a surface, each with the node's corner
/// in it.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeRing {
    /// `around[i]`: (facet, corner) pairs of node `surface.nodes[i]`.
    around: Vec<Vec<(usize, usize)>>,
}

impl NodeRing {
    /// The rings of `surface`'s nodes.
    pub fn new(surface: &ContactSurface) -> Self {
        let trace = Trace::of_kind(surface.kind);
        let mut around = vec![Vec::new(); surface.nodes.len()];
        for (f, facet) in surface.facets.iter().enumerate() {
            for (c, n) in facet[..trace.node_count()].iter().enumerate() {
                if let Ok(i) = surface.nodes.binary_search(n) {
                    around[i].push((f, c));
                }
            }
        }
        Self { around }
    }

    /// The (facet, corner) pairs of the node of index `i` in
    /// `surface.nodes`.
    pub fn facets(&self, i: usize) -> &[(usize, usize)] {
        &self.around[i]
    }
}

/// The area vector `k (x_next - x_j) x (x_prev - x_j)` that a facet of
/// `trace` brings to the normal of its corner at `this`, for any
/// `num-dual` scalar (see the module docs).
pub fn corner_area_normal<T>(
    trace: Trace,
    this: &Vector3<T>,
    next: &Vector3<T>,
    prev: &Vector3<T>,
) -> Vector3<T>
where
    T: DualNum<Primitive = f64> + nalgebra::Scalar,
{
    let k = match trace {
        Trace::Tri3 => 1.0,
        Trace::Quad4 => 0.25,
    };
    (next - this).cross(&(prev - this)) * T::from(k)
}

/// The corners after and before corner `c` of a facet of `trace`.
fn neighbours(trace: Trace, c: usize) -> (usize, usize) {
    let n = trace.node_count();
    ((c + 1) % n, (c + n - 1) % n)
}

/// The unit normal of the node of index `i` in `surface.nodes` with the
/// node coordinates `at(global node)`, for any `num-dual` scalar (the
/// coordinates as dual numbers give the normal's derivatives).
pub fn normal_with<T>(
    surface: &ContactSurface,
    ring: &NodeRing,
    i: usize,
    at: impl Fn(usize) -> Vector3<T>,
) -> Vector3<T>
where
    T: DualNum<Primitive = f64> + nalgebra::Scalar,
{
    let trace = Trace::of_kind(surface.kind);
    let mut m = Vector3::from_element(T::from(0.0));
    for &(f, c) in ring.facets(i) {
        let facet = &surface.facets[f];
        let (a, b) = neighbours(trace, c);
        m += corner_area_normal(trace, &at(facet[c]), &at(facet[a]), &at(facet[b]));
    }
    let l = m.dot(&m).sqrt();
    m / l
}

/// The unit normal of the node of index `i` in `surface.nodes`, node
/// coordinates `x` \[mm\].
pub fn nodal_normal(
    surface: &ContactSurface,
    ring: &NodeRing,
    i: usize,
    x: &[[f64; 3]],
) -> Vector3<f64> {
    normal_with(surface, ring, i, |n| Vector3::from(x[n]))
}

/// The unit nodal normals of all of `surface`'s nodes (in the order of
/// `surface.nodes`) with the node coordinates `x` \[mm\].
pub fn nodal_normals(
    surface: &ContactSurface,
    ring: &NodeRing,
    x: &[[f64; 3]],
) -> Vec<Vector3<f64>> {
    (0..surface.nodes.len())
        .map(|i| nodal_normal(surface, ring, i, x))
        .collect()
}

/// A nodal normal with its derivatives with respect to the coordinates of
/// the nodes of its ring.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalDerivatives {
    /// The unit normal.
    pub normal: Vector3<f64>,
    /// The ring's nodes (global ids, increasing); dof `3 r + c` below is
    /// coordinate `c` of `nodes[r]`.
    pub nodes: Vec<usize>,
    /// `dn_i / dx_dof` \[1/mm\], 3 x `3 nodes.len()`.
    pub jacobian: Matrix3xX<f64>,
    /// `d2 n_i / dx_dof dx_dof'` \[1/mm^2\] for `i = 0, 1, 2`, if asked.
    pub hessian: Option<[DMatrix<f64>; 3]>,
}

impl NormalDerivatives {
    /// The global dof (`3 node + component`) of local dof `d`.
    pub fn dof(&self, d: usize) -> usize {
        3 * self.nodes[d / 3] + d % 3
    }
}

/// The normal of the node of index `i` in `surface.nodes` with its first
/// and (if `hessian`) second derivatives, coordinates `x` \[mm\].
pub fn normal_derivatives(
    surface: &ContactSurface,
    ring: &NodeRing,
    i: usize,
    x: &[[f64; 3]],
    hessian: bool,
) -> NormalDerivatives {
    let trace = Trace::of_kind(surface.kind);
    let mut nodes: Vec<usize> = ring
        .facets(i)
        .iter()
        .flat_map(|&(f, _)| surface.facets[f][..trace.node_count()].iter().copied())
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    let v = DVector::from_iterator(3 * nodes.len(), nodes.iter().flat_map(|&n| x[n]));
    let local = |n: usize| nodes.binary_search(&n).unwrap_or(0);
    let (value, jacobian) = num_dual::jacobian(
        |v: DVector<DualDVec64>| -> OVector<DualDVec64, U3> {
            normal_with(surface, ring, i, |n| {
                let r = local(n);
                Vector3::new(v[3 * r].clone(), v[3 * r + 1].clone(), v[3 * r + 2].clone())
            })
        },
        &v,
    );
    let hessian = hessian.then(|| {
        [0, 1, 2].map(|c| {
            let (_, _, h) = num_dual::hessian(
                |v: OVector<Dual2DVec64, Dyn>| {
                    let n = normal_with(surface, ring, i, |n| {
                        let r = local(n);
                        Vector3::new(v[3 * r].clone(), v[3 * r + 1].clone(), v[3 * r + 2].clone())
                    });
                    n[c].clone()
                },
                &v,
            );
            h
        })
    });
    NormalDerivatives {
        normal: value,
        nodes,
        jacobian,
        hessian,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mortar::trace::Facet;

    /// A 2 x 2 patch of quads on the paraboloid z = 0.3 x^2 - 0.2 y^2 + 0.1 x y,
    /// and the same split into triangles.
    fn patches() -> (Vec<[f64; 3]>, ContactSurface, ContactSurface) {
        let mut x = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                let (a, b) = (i as f64 - 1.0 + 0.05 * j as f64, j as f64 - 1.0);
                x.push([a, b, 0.3 * a * a - 0.2 * b * b + 0.1 * a * b]);
            }
        }
        let quads: Vec<[usize; 4]> = (0..2)
            .flat_map(|j| {
                (0..2).map(move |i| [3 * j + i, 3 * j + i + 1, 3 * j + i + 4, 3 * j + i + 3])
            })
            .collect();
        let tris: Vec<[usize; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        let qs = ContactSurface::from_quads(&quads, &x).unwrap();
        let ts = ContactSurface::from_triangles(&tris, &x).unwrap();
        (x, qs, ts)
    }

    #[test]
    fn corner_area_normals_are_the_traces_area_vectors_at_the_corners() {
        let (x, qs, ts) = patches();
        for s in [&qs, &ts] {
            let trace = Trace::of_kind(s.kind);
            for f in 0..s.facets.len() {
                let facet = Facet::of_surface(s, f, &x);
                for c in 0..trace.node_count() {
                    let (a, b) = neighbours(trace, c);
                    let m = corner_area_normal(trace, &facet.x[c], &facet.x[a], &facet.x[b]);
                    assert!((m - facet.area_normal(trace.corner(c))).norm() < 1e-15);
                }
            }
        }
    }

    #[test]
    fn derivatives_match_central_differences() {
        let (x, qs, ts) = patches();
        for s in [&qs, &ts] {
            let ring = NodeRing::new(s);
            // The middle node (global 4): all nine nodes around it on the
            // quads, seven on the triangles (split along 0-4-8).
            let i = s.nodes.binary_search(&4).unwrap();
            let d = normal_derivatives(s, &ring, i, &x, true);
            let want: Vec<usize> = match s.kind {
                crate::surface::FacetKind::Quad => (0..9).collect(),
                crate::surface::FacetKind::Triangle => vec![0, 1, 3, 4, 5, 7, 8],
            };
            assert_eq!(d.nodes, want);
            let h = 1e-6;
            for dof in 0..3 * d.nodes.len() {
                let moved = |e: f64| {
                    let mut y = x.clone();
                    y[d.nodes[dof / 3]][dof % 3] += e;
                    (
                        nodal_normals(s, &ring, &y)[i],
                        normal_derivatives(s, &ring, i, &y, false).jacobian,
                    )
                };
                let ((np, jp), (nm, jm)) = (moved(h), moved(-h));
                let fd = (np - nm) / (2.0 * h);
                for c in 0..3 {
                    assert!((fd[c] - d.jacobian[(c, dof)]).abs() < 1e-8, "{dof} {c}");
                    let hc = &d.hessian.as_ref().unwrap()[c];
                    for e in 0..3 * d.nodes.len() {
                        let fd2 = (jp[(c, e)] - jm[(c, e)]) / (2.0 * h);
                        assert!((fd2 - hc[(dof, e)]).abs() < 1e-7, "{dof} {e} {c}");
                    }
                }
            }
            assert!((d.normal.norm() - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn a_flat_surface_has_the_planes_normal_at_every_node() {
        let mut x: Vec<[f64; 3]> = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                // Irregular nodes in the plane through the origin with normal (1, 2, 2)/3.
                let (a, b) = (i as f64 + 0.2 * (j * i) as f64, j as f64 + 0.1 * i as f64);
                x.push([2.0 * a, -a + b, -b].map(|v: f64| v * 0.5));
            }
        }
        let n = Vector3::new(1.0, 2.0, 2.0) / 3.0;
        let quads: Vec<[usize; 4]> = (0..2)
            .flat_map(|j| {
                (0..2).map(move |i| [3 * j + i, 3 * j + i + 1, 3 * j + i + 4, 3 * j + i + 3])
            })
            .collect();
        let s = ContactSurface::from_quads(&quads, &x).unwrap();
        let ring = NodeRing::new(&s);
        for m in nodal_normals(&s, &ring, &x) {
            assert!((m - n).norm() < 1e-15 || (m + n).norm() < 1e-15);
            assert!((m - nodal_normals(&s, &ring, &x)[0]).norm() < 1e-15);
        }
    }
}
