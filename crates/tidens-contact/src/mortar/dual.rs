//! Test functions `Phi_j` of a slave facet: the standard ones (`Phi_j =
//! N_j`) or the dual ones, biorthogonal to the shape functions (Wohlmuth
//! 2000; Popp, Gee and Wall 2009):
//!
//! ```text
//! int_e Phi_j N_k dA = delta_jk int_e N_j dA,      sum_j Phi_j = 1
//! ```
//!
//! Both are `Phi_j = sum_k A_jk N_k` with a matrix of coefficients `A_e`
//! per facet:
//!
//! - standard: `A_e = I`;
//! - dual, Tri3: `Phi_j = 4 N_j - 1`, `A_e = 4 I - 1 1^T`, whatever the
//!   triangle (`M_e = |e|/12 (I + 1 1^T)`, `D_e = |e|/3 I`);
//! - dual, Quad4: `A_e = D_e M_e^-1` with `D_e = diag(int_e N_j dA)` and
//!   the mass matrix `M_e = int_e N_j N_k dA`, both by 3 x 3 Gauss on the
//!   facet's geometry (exact on a flat quad). Then `int Phi_j N_k = (A_e
//!   M_e)_jk = (D_e)_jk`, and `sum_j A_jk = 1` since `1^T M_e = 1^T D_e`
//!   (`sum_j N_j = 1`).
//!
//! A quad's `A_e` depends on its geometry; it is computed in `f64` from
//! whatever geometry the caller gives (the caller freezes it per step, so
//! the weighted gaps do not differentiate it).

use nalgebra::Matrix4;

use crate::mortar::quadrature::element_rule;
use crate::mortar::trace::{AdScalar, Facet, Trace};
use crate::surface::ContactSurface;

/// Which test functions weigh the gap.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TestBasis {
    /// `Phi_j = N_j`: positive, the wider (coupled) stencil.
    Standard,
    /// Biorthogonal to the `N_j`: the mortar matrix `D` is diagonal.
    #[default]
    Dual,
}

/// The test functions of one slave facet, `Phi_j = sum_k A_jk N_k`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestFunctions {
    pub trace: Trace,
    /// `A_jk` (a triangle's fourth row and column are zero).
    pub coefficients: [[f64; 4]; 4],
}

impl TestFunctions {
    /// `Phi_j = N_j`.
    pub fn standard(trace: Trace) -> Self {
        let mut a = [[0.0; 4]; 4];
        for j in 0..trace.node_count() {
            a[j][j] = 1.0;
        }
        Self {
            trace,
            coefficients: a,
        }
    }

    /// The dual functions of `facet` (its geometry used only for a quad).
    pub fn dual(facet: &Facet<f64>) -> Self {
        let trace = facet.trace;
        let mut a = [[0.0; 4]; 4];
        match trace {
            Trace::Tri3 => {
                for j in 0..3 {
                    for k in 0..3 {
                        a[j][k] = if j == k { 3.0 } else { -1.0 };
                    }
                }
            }
            Trace::Quad4 => {
                let (d, m) = mass_matrices(facet);
                // A = D M^-1 = (M^-1 D)^T, M symmetric positive definite.
                let m = Matrix4::from_fn(|j, k| m[j][k]);
                let inv = m
                    .cholesky()
                    .map(|c| c.inverse())
                    .unwrap_or_else(|| m.try_inverse().unwrap_or(Matrix4::identity()));
                for j in 0..4 {
                    for k in 0..4 {
                        a[j][k] = d[j] * inv[(j, k)];
                    }
                }
            }
        }
        Self {
            trace,
            coefficients: a,
        }
    }

    /// The test functions of `basis` for `facet`.
    pub fn new(basis: TestBasis, facet: &Facet<f64>) -> Self {
        match basis {
            TestBasis::Standard => Self::standard(facet.trace),
            TestBasis::Dual => Self::dual(facet),
        }
    }

    /// `Phi_j` from the shape function values `n`.
    pub fn eval<T: AdScalar>(&self, n: &[T; 4]) -> [T; 4] {
        let count = self.trace.node_count();
        std::array::from_fn(|j| {
            let mut phi = T::from(0.0);
            for k in 0..count {
                phi += n[k] * self.coefficients[j][k];
            }
            phi
        })
    }
}

/// `D_e = diag(int_e N_j dA)` and `M_e = int_e N_j N_k dA` \[mm^2\] by the
/// facet rule of `facet`'s trace.
pub fn mass_matrices(facet: &Facet<f64>) -> ([f64; 4], [[f64; 4]; 4]) {
    let mut d = [0.0; 4];
    let mut m = [[0.0; 4]; 4];
    for (xi, w) in element_rule(facet.trace) {
        let da = w * facet.jacobian(xi);
        let n = facet.trace.shape(xi);
        for j in 0..4 {
            d[j] += n[j] * da;
            for k in 0..4 {
                m[j][k] += n[j] * n[k] * da;
            }
        }
    }
    (d, m)
}

/// The test functions of every facet of a slave surface.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceTestFunctions {
    pub basis: TestBasis,
    /// Per facet, in the order of `surface.facets`.
    pub facets: Vec<TestFunctions>,
}

impl SurfaceTestFunctions {
    /// The test functions of `basis` on `surface`, a quad's dual functions
    /// from the coordinates `x` \[mm\] (those frozen for the step).
    pub fn new(surface: &ContactSurface, x: &[[f64; 3]], basis: TestBasis) -> Self {
        let facets = (0..surface.facets.len())
            .map(|f| TestFunctions::new(basis, &Facet::of_surface(surface, f, x)))
            .collect();
        Self { basis, facets }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mortar::quadrature::GAUSS_3;
    use nalgebra::Vector3;

    fn facet(trace: Trace, x: [[f64; 3]; 4]) -> Facet<f64> {
        Facet {
            trace,
            x: x.map(Vector3::from),
        }
    }

    /// A flat, non-affine quad (no two sides parallel) and a warped one.
    fn quads() -> [Facet<f64>; 2] {
        [
            facet(
                Trace::Quad4,
                [
                    [0.0, 0.0, 0.0],
                    [2.0, 0.3, 0.0],
                    [1.7, 1.9, 0.0],
                    [-0.2, 1.1, 0.0],
                ],
            ),
            facet(
                Trace::Quad4,
                [
                    [0.0, 0.0, 0.0],
                    [2.0, 0.3, 0.4],
                    [1.7, 1.9, -0.1],
                    [-0.2, 1.1, 0.3],
                ],
            ),
        ]
    }

    /// `int Phi_j N_k dA` by the `n`-point Gauss rule per direction.
    fn cross_mass(phi: &TestFunctions, f: &Facet<f64>, rule: &[(f64, f64)]) -> [[f64; 4]; 4] {
        let mut r = [[0.0; 4]; 4];
        for &(s, ws) in rule {
            for &(t, wt) in rule {
                let n = f.trace.shape([s, t]);
                let p = phi.eval(&n);
                let da = ws * wt * f.jacobian([s, t]);
                for j in 0..4 {
                    for k in 0..4 {
                        r[j][k] += p[j] * n[k] * da;
                    }
                }
            }
        }
        r
    }

    #[test]
    fn quad_dual_functions_are_biorthogonal_and_sum_to_one() {
        // Gauss-Legendre 5 points (degree 9): independent of the 3 x 3 rule
        // the coefficients come from, exact on the flat quad.
        let g5: Vec<(f64, f64)> = {
            let (a, b) = (
                (5.0 - 2.0 * (10.0f64 / 7.0).sqrt()).sqrt() / 3.0,
                (5.0 + 2.0 * (10.0f64 / 7.0).sqrt()).sqrt() / 3.0,
            );
            let (wa, wb) = (
                (322.0 + 13.0 * 70f64.sqrt()) / 900.0,
                (322.0 - 13.0 * 70f64.sqrt()) / 900.0,
            );
            vec![(-b, wb), (-a, wa), (0.0, 128.0 / 225.0), (a, wa), (b, wb)]
        };
        for (i, q) in quads().iter().enumerate() {
            let phi = TestFunctions::dual(q);
            let (d, _) = mass_matrices(q);
            // The flat quad against the independent rule; the warped one
            // (J not polynomial) against the rule A_e is built with.
            let rule: &[(f64, f64)] = if i == 0 { &g5 } else { &GAUSS_3 };
            let r = cross_mass(&phi, q, rule);
            let scale = d.iter().sum::<f64>();
            for j in 0..4 {
                for k in 0..4 {
                    let want = if j == k { d[j] } else { 0.0 };
                    assert!(
                        (r[j][k] - want).abs() < 1e-13 * scale,
                        "{i} {j} {k}: {}",
                        r[j][k]
                    );
                }
            }
            for xi in [[0.3, -0.4], [-1.0, 1.0], [0.9, 0.2]] {
                let s: f64 = phi.eval(&q.trace.shape(xi)).iter().sum();
                assert!((s - 1.0).abs() < 1e-13);
            }
            // Not the standard functions: the coefficients are those of a
            // dual basis, with negative parts.
            assert!(phi.coefficients[0][1] < -1.0);
        }
    }

    #[test]
    fn the_square_has_the_textbook_coefficients() {
        let q = facet(
            Trace::Quad4,
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
        );
        let a = TestFunctions::dual(&q).coefficients;
        let row = [4.0, -2.0, 1.0, -2.0];
        for j in 0..4 {
            for k in 0..4 {
                assert!((a[j][k] - row[(k + 4 - j) % 4]).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn triangle_dual_functions_are_four_n_minus_one() {
        let t = facet(
            Trace::Tri3,
            [
                [0.1, 0.0, 0.3],
                [2.0, 0.5, 0.0],
                [0.3, 1.4, 0.2],
                [0.3, 1.4, 0.2],
            ],
        );
        let phi = TestFunctions::dual(&t);
        let (d, _) = mass_matrices(&t);
        for ([s, tt], _) in element_rule(Trace::Tri3) {
            let n = Trace::Tri3.shape([s, tt]);
            let p = phi.eval(&n);
            for j in 0..3 {
                assert!((p[j] - (4.0 * n[j] - 1.0)).abs() < 1e-15);
            }
        }
        // Biorthogonal by the (exact) 7-point rule.
        let mut r = [[0.0; 4]; 4];
        for (xi, w) in element_rule(Trace::Tri3) {
            let n = Trace::Tri3.shape(xi);
            let p = phi.eval(&n);
            for j in 0..3 {
                for k in 0..3 {
                    r[j][k] += p[j] * n[k] * w * t.jacobian(xi);
                }
            }
        }
        for j in 0..3 {
            for k in 0..3 {
                let want = if j == k { d[j] } else { 0.0 };
                assert!((r[j][k] - want).abs() < 1e-14);
            }
        }
    }
}
