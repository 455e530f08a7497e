//! The mortar integrals of one pair (slave facet `s`, master facet `m`).
//!
//! On each cell `T` of the overlap ([`clip`]) the 7-point rule gives
//! points `z_g` of the auxiliary plane with weights `w_g |T|`. The slave
//! and master parameters of `z_g` are found by the inverse maps
//! ([`inverse_map`](crate::mortar::quadrature::inverse_map)): `P(x_s(xi_g)) = z_g = P(x_m(eta_g))`. `P` projects
//! along `n0`, so `x_m(eta_g) - x_s(xi_g)` is parallel to `n0`: the two
//! points face each other across the gap.
//!
//! The slave's measure: with `J_s = |x_xi x x_eta|` and the planar
//! Jacobian of the projected slave map `J_P = det[P(x_xi), P(x_eta)] =
//! (x_xi x x_eta) . n0`, `dA = J_s dxi = (J_s / J_P) dz`, so
//!
//! ```text
//! dA_g = w_g |T| J_s(xi_g) / J_P(xi_g)
//! ```
//!
//! is the slave surface's own measure (`J_s / J_P = 1` on a flat slave;
//! on a warped one it is the cosine between the surface and the plane).
//! With the test functions `Phi_j` of the slave facet and the slave nodal
//! normals `n_j` (inputs, so that a caller can chain their derivatives):
//!
//! ```text
//! v_j  = sum_g Phi_j(xi_g) (x_m(eta_g) - x_s(xi_g)) dA_g        [mm^3]
//! g_j  = n_j . v_j       (weighted gap: > 0 open, < 0 penetrating)
//! D_jk = sum_g Phi_j(xi_g) N_k(xi_g) dA_g,   M_jl = sum_g Phi_j(xi_g) N^m_l(eta_g) dA_g
//! ```
//!
//! so that `g_j = n_j . (sum_l M_jl y_l - sum_k D_jk x_k)` (the form of
//! Popp's thesis and Kratos; MOOSE sums the first). With `Phi_j = sum_k
//! A_jk N_k` ([`TestFunctions`]) the sum is taken as `v_j = sum_k A_jk u_k`,
//! `u_k = sum_g N_k (x_m - x_s) dA_g`, and the facets' maps as polynomials
//! in the parameters ([`Expansion`]; a triangle's Jacobians are constant):
//! in dual numbers every product counts. The gap is generic
//! over the scalar: its derivatives with respect to the pair's node
//! positions (through the plane, the clip polygon, the cells, the
//! parameters, the Jacobians) and the normals are exact. `D` and `M` are
//! returned as values (`f64`): their derivatives are not needed for the
//! gaps' (the pair's `v_j` carries them) and would cost a third of the
//! work.

use nalgebra::Vector3;

use crate::mortar::MortarError;
use crate::mortar::clip::{Point, clip};
use crate::mortar::dual::TestFunctions;
use crate::mortar::quadrature::{TRIANGLE_7, inverse_maps};
use crate::mortar::trace::{AdScalar, Expansion, Facet, Trace};

/// The integrals of one pair (module docs), by the slave facet's nodes
/// `j`, `k` and the master's `l` (a triangle's fourth entries are zero).
#[derive(Clone, Debug, PartialEq)]
pub struct PairIntegrals<T: AdScalar> {
    /// `g_j = n_j . v_j` \[mm^3\].
    pub gap: [T; 4],
    /// `v_j` \[mm^3\].
    pub gap_vector: [Vector3<T>; 4],
    /// `D_jk` \[mm^2\].
    pub d: [[f64; 4]; 4],
    /// `M_jl` \[mm^2\].
    pub m: [[f64; 4]; 4],
    /// The overlap's area on the slave surface \[mm^2\].
    pub area: f64,
}

/// The point of barycentric coordinates `l` in the cell `c`.
fn cell_point<T: AdScalar>(c: &[Point<T>; 3], l: &[f64; 3]) -> Point<T> {
    std::array::from_fn(|i| c[0][i] * l[0] + c[1][i] * l[1] + c[2][i] * l[2])
}

/// The mortar integrals of the pair (`slave`, `master`) with the slave
/// nodal normals `normals` and the slave facet's test functions `test`;
/// None if the facets do not overlap (or do not face each other).
pub fn integrate_pair<T: AdScalar>(
    slave: &Facet<T>,
    master: &Facet<T>,
    normals: &[Vector3<T>; 4],
    test: &TestFunctions,
) -> Result<Option<PairIntegrals<T>>, MortarError> {
    let Some(overlap) = clip(slave, master) else {
        return Ok(None);
    };
    let zero = T::from(0.0);
    // u_k = sum_g N_k(xi_g) (x_m - x_s) dA_g; v_j = sum_k A_jk u_k at the end.
    let mut u = [Vector3::from_element(zero); 4];
    let mut d = [[0.0; 4]; 4];
    let mut m = [[0.0; 4]; 4];
    let mut area = 0.0;
    let (ns, nm) = (slave.node_count(), master.node_count());
    let n0 = overlap.plane.normal;
    let (xs, xm) = (Expansion::of(slave), Expansion::of(master));
    // A flat triangle's Jacobians are constant.
    let jacobians = |xi: [T; 2]| {
        let [ta, tb] = xs.tangents(xi);
        let a = ta.cross(&tb);
        a.dot(&a).sqrt() / a.dot(&n0)
    };
    let flat = (slave.trace == Trace::Tri3).then(|| jacobians([zero, zero]));
    for piece in &overlap.pieces {
        for cell in piece.cells() {
            let cell_area = (cell[1][0] - cell[0][0]) * (cell[2][1] - cell[0][1])
                - (cell[1][1] - cell[0][1]) * (cell[2][0] - cell[0][0]);
            let cell_area = cell_area * 0.5;
            let z: [Point<T>; 7] = TRIANGLE_7.map(|(l, _)| cell_point(&cell, &l));
            let xis = inverse_maps(slave.trace, &overlap.slave, &z)?;
            let etas = inverse_maps(master.trace, &overlap.master, &z)?;
            for (g, (_, w)) in TRIANGLE_7.iter().enumerate() {
                let (xi, eta) = (xis[g], etas[g]);
                let da = cell_area * flat.unwrap_or_else(|| jacobians(xi)) * *w;
                let weighted = (xm.position(eta) - xs.position(xi)) * da;
                let n = slave.trace.shape(xi);
                for k in 0..ns {
                    u[k] += weighted * n[k];
                }
                // D and M as values.
                let dar = da.re();
                area += dar;
                let nr = n.map(|v| v.re());
                let nmr = master.trace.shape(eta.map(|v| v.re()));
                let phi = test.eval(&nr);
                for j in 0..ns {
                    let pj = phi[j] * dar;
                    for k in 0..ns {
                        d[j][k] += pj * nr[k];
                    }
                    for k in 0..nm {
                        m[j][k] += pj * nmr[k];
                    }
                }
            }
        }
    }
    let v: [Vector3<T>; 4] = std::array::from_fn(|j| {
        let mut vj = Vector3::from_element(zero);
        for k in 0..ns {
            vj += u[k].map(|c| c * test.coefficients[j][k]);
        }
        vj
    });
    let gap = std::array::from_fn(|j| if j < ns { normals[j].dot(&v[j]) } else { zero });
    Ok(Some(PairIntegrals {
        gap,
        gap_vector: v,
        d,
        m,
        area,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mortar::trace::Trace;

    fn facet(trace: Trace, x: [[f64; 3]; 4]) -> Facet<f64> {
        Facet {
            trace,
            x: x.map(Vector3::from),
        }
    }

    #[test]
    fn a_slave_square_under_a_larger_tilted_master_plane_gets_its_wedge() {
        // Master plane z = 1 + 0.2 x facing down, covering the unit slave
        // square: g = int N_j (1 + 0.2 x) dA on the slave.
        let s = facet(
            Trace::Quad4,
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
        );
        let z = |x: f64| 1.0 + 0.2 * x;
        let mf = facet(
            Trace::Quad4,
            [
                [-1.0, -1.0, z(-1.0)],
                [-1.0, 2.0, z(-1.0)],
                [2.0, 2.0, z(2.0)],
                [2.0, -1.0, z(2.0)],
            ],
        );
        let normals = [Vector3::z(); 4];
        let r = integrate_pair(&s, &mf, &normals, &TestFunctions::standard(Trace::Quad4))
            .unwrap()
            .unwrap();
        // int_0^1 int_0^1 N_j (1 + 0.2 x): N_0 = (1-x)(1-y): 1/4 + 0.2/12.
        let want = [
            0.25 + 0.2 / 12.0,
            0.25 + 0.2 / 6.0,
            0.25 + 0.2 / 6.0,
            0.25 + 0.2 / 12.0,
        ];
        for j in 0..4 {
            assert!((r.gap[j] - want[j]).abs() < 1e-15, "{j}: {}", r.gap[j]);
            // The gap vectors are vertical.
            assert!(r.gap_vector[j].xy().norm() < 1e-15);
        }
        assert!((r.area - 1.0).abs() < 1e-15);
        // D is the slave's consistent mass matrix, M sums to the area.
        assert!((r.d[0][0] - 1.0 / 9.0).abs() < 1e-15 && (r.d[0][2] - 1.0 / 36.0).abs() < 1e-15);
        let msum: f64 = r.m.iter().flatten().sum();
        assert!((msum - 1.0).abs() < 1e-15);
    }

    #[test]
    fn a_warped_slave_is_measured_on_its_surface() {
        // The warped slave facet under a covering master: sum_k D_jk sums to
        // the slave's area by its own Gauss rule (the 3 x 3 rule is not
        // exact on a warped quad: 1e-6 relative).
        let s = facet(
            Trace::Quad4,
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.2],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.2],
            ],
        );
        let mf = facet(
            Trace::Quad4,
            [
                [-1.0, -1.0, 1.0],
                [-1.0, 2.0, 1.0],
                [2.0, 2.0, 1.0],
                [2.0, -1.0, 1.0],
            ],
        );
        let normals = [Vector3::z(); 4];
        let r = integrate_pair(&s, &mf, &normals, &TestFunctions::standard(Trace::Quad4))
            .unwrap()
            .unwrap();
        let mut exact = 0.0;
        let k = 40;
        let g: Vec<(f64, f64)> = (0..k)
            .map(|i| (-1.0 + (2 * i + 1) as f64 / k as f64, 2.0 / k as f64))
            .collect();
        for &(a, wa) in &g {
            for &(b, wb) in &g {
                exact += wa * wb * s.jacobian([a, b]);
            }
        }
        assert!((r.area - exact).abs() < 1e-3 * exact);
        assert!(
            r.area > 1.0 + 1e-3,
            "the warped facet is larger than its plane's square"
        );
    }
}
