//! Facet traces: the linear triangle (Tri3) and the bilinear quadrilateral
//! (Quad4) that a surface facet is on the parent element's boundary, as
//! functions of its parametric coordinates `xi = (xi, eta)`.
//!
//! Tri3, on the reference triangle `xi, eta >= 0, xi + eta <= 1`, corners
//! `(0, 0), (1, 0), (0, 1)`:
//!
//! ```text
//! N = (1 - xi - eta, xi, eta),     centre (1/3, 1/3)
//! ```
//!
//! Quad4, on `[-1, 1]^2`, corners `(-1, -1), (1, -1), (1, 1), (-1, 1)`:
//!
//! ```text
//! N_a = (1 + xi xi_a)(1 + eta eta_a) / 4,     centre (0, 0)
//! ```
//!
//! With the node positions `x_a` \[mm\]:
//!
//! ```text
//! x(xi) = sum_a N_a(xi) x_a,       x_xi = sum_a dN_a/dxi x_a,  x_eta likewise
//! J_s(xi) = |x_xi x x_eta|         (surface measure: dA = J_s dxi deta)
//! n(xi) = (x_xi x x_eta) / J_s     (outward: the nodes run counter-clockwise
//!                                    about the outward normal)
//! ```
//!
//! Everything is generic over the scalar ([`AdScalar`]: `f64` or a
//! `num-dual` number), so that derivatives with respect to the node
//! positions flow through. A triangle keeps four position slots like the
//! [`ContactSurface`] facets (the fourth repeats the third and is never
//! read); its fourth shape function is zero.

use nalgebra::Vector3;
use num_dual::DualNum;

use crate::surface::{ContactSurface, FacetKind};

/// The scalars the mortar kernels compute with: `f64`, or a forward-mode
/// dual number of `num-dual` (`DualSVec64<N>`, `Dual2SVec64<N>`) whose real
/// part is an `f64`.
pub trait AdScalar: DualNum<Primitive = f64> + nalgebra::Scalar + Copy {}

impl<T: DualNum<Primitive = f64> + nalgebra::Scalar + Copy> AdScalar for T {}

/// The interpolation of a facet: its shape functions on its reference
/// domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Trace {
    /// The linear triangle (three nodes).
    Tri3,
    /// The bilinear quadrilateral (four nodes).
    Quad4,
}

const QUAD_CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
const TRI_CORNERS: [[f64; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

impl Trace {
    /// The trace of a surface's facets.
    pub const fn of_kind(kind: FacetKind) -> Self {
        match kind {
            FacetKind::Quad => Trace::Quad4,
            FacetKind::Triangle => Trace::Tri3,
        }
    }

    /// The number of nodes.
    pub const fn node_count(self) -> usize {
        match self {
            Trace::Tri3 => 3,
            Trace::Quad4 => 4,
        }
    }

    /// The parametric coordinates of node `a`.
    pub const fn corner(self, a: usize) -> [f64; 2] {
        match self {
            Trace::Tri3 => TRI_CORNERS[a],
            Trace::Quad4 => QUAD_CORNERS[a],
        }
    }

    /// The parametric centre: `(1/3, 1/3)` or `(0, 0)`.
    pub const fn centre(self) -> [f64; 2] {
        match self {
            Trace::Tri3 => [1.0 / 3.0, 1.0 / 3.0],
            Trace::Quad4 => [0.0, 0.0],
        }
    }

    /// The area of the reference domain: `1/2` or `4`.
    pub const fn reference_area(self) -> f64 {
        match self {
            Trace::Tri3 => 0.5,
            Trace::Quad4 => 4.0,
        }
    }

    /// The shape functions `N_a(xi)` (a triangle's fourth is zero).
    pub fn shape<T: AdScalar>(self, xi: [T; 2]) -> [T; 4] {
        let [s, t] = xi;
        match self {
            Trace::Tri3 => [T::from(1.0) - s - t, s, t, T::from(0.0)],
            Trace::Quad4 => QUAD_CORNERS.map(|[a, b]| (s * a + 1.0) * (t * b + 1.0) * 0.25),
        }
    }

    /// The parametric derivatives `[dN_a/dxi, dN_a/deta]` of the shape
    /// functions.
    pub fn shape_derivatives<T: AdScalar>(self, xi: [T; 2]) -> [[T; 2]; 4] {
        let [s, t] = xi;
        match self {
            Trace::Tri3 => {
                let c = |v: f64| T::from(v);
                [
                    [c(-1.0), c(-1.0)],
                    [c(1.0), c(0.0)],
                    [c(0.0), c(1.0)],
                    [c(0.0), c(0.0)],
                ]
            }
            Trace::Quad4 => {
                QUAD_CORNERS.map(|[a, b]| [(t * b + 1.0) * (0.25 * a), (s * a + 1.0) * (0.25 * b)])
            }
        }
    }
}

/// One facet: its trace and its node positions \[mm\] (a triangle's fourth
/// slot is not read).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facet<T: AdScalar> {
    pub trace: Trace,
    pub x: [Vector3<T>; 4],
}

impl Facet<f64> {
    /// Facet `f` of `surface` with the node coordinates `x` (global, \[mm\]).
    pub fn of_surface(surface: &ContactSurface, f: usize, x: &[[f64; 3]]) -> Self {
        Facet {
            trace: Trace::of_kind(surface.kind),
            x: surface.facets[f].map(|n| Vector3::from(x[n])),
        }
    }

    /// Facet `f` of `surface` as a master: continued past the surface's
    /// open edges ([`ContactSurface::continue_open_edges`]).
    pub fn of_master(surface: &ContactSurface, f: usize, x: &[[f64; 3]]) -> Self {
        let facet = Self::of_surface(surface, f, x);
        match surface.continuation(f) {
            None => facet,
            Some(t) => Facet {
                trace: facet.trace,
                x: std::array::from_fn(|a| {
                    (0..4).fold(Vector3::zeros(), |c, l| c + facet.x[l] * t[a][l])
                }),
            },
        }
    }
}

impl<T: AdScalar> Facet<T> {
    /// The facet with its positions converted by `f` (e.g. into dual
    /// numbers).
    pub fn map<U: AdScalar>(&self, f: impl Fn(&Vector3<T>) -> Vector3<U>) -> Facet<U> {
        Facet {
            trace: self.trace,
            x: std::array::from_fn(|a| f(&self.x[a])),
        }
    }

    /// The number of nodes.
    pub fn node_count(&self) -> usize {
        self.trace.node_count()
    }

    /// `sum_a w_a x_a` over the facet's nodes (with `w` the shape
    /// functions at a point, its position; with their derivatives, a
    /// tangent).
    pub fn interpolate(&self, w: &[T; 4]) -> Vector3<T> {
        let mut p = Vector3::from_element(T::from(0.0));
        for a in 0..self.node_count() {
            p += self.x[a] * w[a];
        }
        p
    }

    /// The position `x(xi)`.
    pub fn position(&self, xi: [T; 2]) -> Vector3<T> {
        self.interpolate(&self.trace.shape(xi))
    }

    /// The parametric tangents `[x_xi, x_eta]`.
    pub fn tangents(&self, xi: [T; 2]) -> [Vector3<T>; 2] {
        let dn = self.trace.shape_derivatives(xi);
        [0, 1].map(|d| self.interpolate(&dn.map(|g| g[d])))
    }

    /// The area vector `x_xi x x_eta`: along the outward normal, of length
    /// the surface Jacobian.
    pub fn area_normal(&self, xi: [T; 2]) -> Vector3<T> {
        let [a, b] = self.tangents(xi);
        a.cross(&b)
    }

    /// The surface Jacobian `J_s = |x_xi x x_eta|` (`dA = J_s dxi deta`).
    pub fn jacobian(&self, xi: [T; 2]) -> T {
        let m = self.area_normal(xi);
        m.dot(&m).sqrt()
    }

    /// The unit outward normal at `xi`.
    pub fn normal(&self, xi: [T; 2]) -> Vector3<T> {
        let m = self.area_normal(xi);
        let l = m.dot(&m).sqrt();
        m / l
    }

    /// The parametric centre as scalars.
    pub fn centre(&self) -> [T; 2] {
        self.trace.centre().map(T::from)
    }
}

/// A facet's map written as a polynomial in `xi`, for evaluating it at
/// many points:
///
/// ```text
/// x(xi, eta) = c + xi a + eta b + xi eta d
/// ```
///
/// (Quad4: `c = sum x_k / 4`, `a = sum xi_k x_k / 4`, `b = sum eta_k x_k /
/// 4`, `d = sum xi_k eta_k x_k / 4`; Tri3: `c = x_0`, `a = x_1 - x_0`, `b =
/// x_2 - x_0`, `d = 0`.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Expansion<T: AdScalar> {
    pub trace: Trace,
    pub c: Vector3<T>,
    pub a: Vector3<T>,
    pub b: Vector3<T>,
    pub d: Vector3<T>,
}

impl<T: AdScalar> Expansion<T> {
    /// The expansion of `facet`'s map.
    pub fn of(facet: &Facet<T>) -> Self {
        let x = &facet.x;
        match facet.trace {
            Trace::Tri3 => Self {
                trace: Trace::Tri3,
                c: x[0],
                a: x[1] - x[0],
                b: x[2] - x[0],
                d: Vector3::from_element(T::from(0.0)),
            },
            Trace::Quad4 => {
                let sum = |w: [f64; 4]| {
                    let mut v = Vector3::from_element(T::from(0.0));
                    for k in 0..4 {
                        v += x[k].map(|c| c * (0.25 * w[k]));
                    }
                    v
                };
                Self {
                    trace: Trace::Quad4,
                    c: sum([1.0; 4]),
                    a: sum([-1.0, 1.0, 1.0, -1.0]),
                    b: sum([-1.0, -1.0, 1.0, 1.0]),
                    d: sum([1.0, -1.0, 1.0, -1.0]),
                }
            }
        }
    }

    /// `x(xi)`.
    pub fn position(&self, xi: [T; 2]) -> Vector3<T> {
        let [s, t] = xi;
        match self.trace {
            Trace::Tri3 => self.c + self.a * s + self.b * t,
            Trace::Quad4 => self.c + self.a * s + self.b * t + self.d * (s * t),
        }
    }

    /// `[x_xi, x_eta]`.
    pub fn tangents(&self, xi: [T; 2]) -> [Vector3<T>; 2] {
        let [s, t] = xi;
        match self.trace {
            Trace::Tri3 => [self.a, self.b],
            Trace::Quad4 => [self.a + self.d * t, self.b + self.d * s],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warped() -> Facet<f64> {
        Facet {
            trace: Trace::Quad4,
            x: [
                Vector3::new(0.0, 0.0, 0.0),
                Vector3::new(1.3, 0.1, 0.2),
                Vector3::new(1.1, 0.9, -0.1),
                Vector3::new(-0.2, 1.2, 0.3),
            ],
        }
    }

    #[test]
    fn the_expansion_is_the_map() {
        let tri = Facet {
            trace: Trace::Tri3,
            x: warped().x,
        };
        for f in [warped(), tri] {
            let e = Expansion::of(&f);
            for xi in [[0.3, -0.2], [0.1, 0.6], [-0.9, 0.4]] {
                assert!((e.position(xi) - f.position(xi)).norm() < 1e-15);
                let (t, u) = (e.tangents(xi), f.tangents(xi));
                assert!((t[0] - u[0]).norm() < 1e-15 && (t[1] - u[1]).norm() < 1e-15);
            }
        }
    }

    #[test]
    fn shape_functions_interpolate_the_nodes_and_sum_to_one() {
        for trace in [Trace::Tri3, Trace::Quad4] {
            for a in 0..trace.node_count() {
                let n = trace.shape(trace.corner(a));
                for b in 0..4 {
                    assert_eq!(n[b], if a == b { 1.0 } else { 0.0 });
                }
            }
            let xi: [f64; 2] = [0.23, 0.31];
            assert!((trace.shape(xi).iter().sum::<f64>() - 1.0).abs() < 1e-15);
            let dn = trace.shape_derivatives(xi);
            for d in 0..2 {
                assert!(dn.iter().map(|g| g[d]).sum::<f64>().abs() < 1e-15);
            }
        }
    }

    #[test]
    fn derivatives_are_those_of_the_shape_functions() {
        let h = 1e-6;
        for trace in [Trace::Tri3, Trace::Quad4] {
            let xi: [f64; 2] = [0.21, 0.37];
            let dn = trace.shape_derivatives(xi);
            for d in 0..2 {
                let mut p = xi;
                let mut m = xi;
                p[d] += h;
                m[d] -= h;
                let (np, nm) = (trace.shape(p), trace.shape(m));
                for a in 0..4 {
                    assert!(((np[a] - nm[a]) / (2.0 * h) - dn[a][d]).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn the_normal_follows_the_right_hand_rule_and_the_jacobian_gives_the_area() {
        // The unit square counter-clockwise about +z: normal +z, J = 1/4.
        let square = Facet {
            trace: Trace::Quad4,
            x: [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ]
            .map(Vector3::from),
        };
        let n = square.normal([0.3f64, -0.2]);
        assert!((n - Vector3::z()).norm() < 1e-15);
        assert!((square.jacobian([0.5f64, 0.1]) - 0.25).abs() < 1e-15);
        // A triangle: J is twice its area.
        let tri = Facet {
            trace: Trace::Tri3,
            x: [
                [0.0, 0.0, 1.0],
                [0.0, 2.0, 1.0],
                [0.0, 0.0, 3.0],
                [0.0, 0.0, 3.0],
            ]
            .map(Vector3::from),
        };
        assert!((tri.normal(tri.centre()) - Vector3::x()).norm() < 1e-15);
        assert!((tri.jacobian([0.1f64, 0.2]) - 4.0).abs() < 1e-15);
        // The warped quad's centre and tangents against the nodes.
        let w = warped();
        let c = (w.x[0] + w.x[1] + w.x[2] + w.x[3]) / 4.0;
        assert!((w.position(w.centre()) - c).norm() < 1e-15);
        let [a, b] = w.tangents([0.0f64, 0.0]);
        assert!((a - (w.x[1] + w.x[2] - w.x[0] - w.x[3]) / 4.0).norm() < 1e-15);
        assert!((b - (w.x[2] + w.x[3] - w.x[0] - w.x[1]) / 4.0).norm() < 1e-15);
    }
}
