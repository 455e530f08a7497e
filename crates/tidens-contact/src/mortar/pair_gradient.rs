//! A pair's gap vectors `v_j` ([`integrate_pair`](crate::mortar::integrate_pair))
//! with their exact first derivatives with respect to the pair's node
//! coordinates, by the chain rule in `f64`.
//!
//! The variables are those of [`pair_derivatives`](super::pair_derivatives):
//! slave node `k`'s coordinate `c` is variable `3 k + c`, master node `l`'s
//! is `3 n_s + 3 l + c`, `N = 3 (n_s + n_m)` of them. The gradients of the
//! auxiliary plane's normal `n0`, the projected nodes `p_k = P(x_k)`, `p_l =
//! P(y_l)` and the clip polygons' vertices and centroids come from
//! [`clip_gradients`]. Each quadrature point `g` of a cell with vertices
//! `q_a` (barycentric coordinates `l_a`, weight `w_g`, area `|T|`) chains
//! them in `f64`:
//!
//! ```text
//! dz    = sum_a l_a dq_a
//! dxi   = J_P^-1 (dz - sum_k N_k(xi) dp_k)        (z(xi) = sum_k N_k(xi) p_k = z, J_P = dz/dxi)
//! deta  = likewise on the master
//! dx_s  = sum_k N_k(xi) dx_k + x_xi dxi_1 + x_eta dxi_2          (x_m likewise)
//! r     = |a| / (a . n0),   a = x_xi x x_eta   (the slave's measure over the plane's)
//! dr    = w . da - r (a . dn0) / (a . n0),      w = (a / |a| - r n0) / (a . n0)
//! da    = sum_k (dN_k/dxi dx_k x x_eta + x_xi x dN_k/deta dx_k) + (x_xi x d) dxi_1 + (d x x_eta) dxi_2
//! dA_g  = w_g |T| r,    d(dA_g) = w_g (r d|T| + |T| dr)
//! du_k  = sum_g N_k (dA_g d(x_m - x_s) + (x_m - x_s) d(dA_g)) + (x_m - x_s) dA_g dN_k
//! dv_j  = sum_k A_jk du_k
//! ```
//!
//! (`d` the facet's bilinear term, [`Expansion`]; zero on a triangle.) The
//! node coordinates enter the points' positions and the area normal
//! linearly with the shape functions as coefficients, so a point costs a
//! few dozen `N`-long vector updates instead of several hundred dual
//! operations. The numbers are those of forward-mode dual numbers
//! ([`pair_derivatives`](super::pair_derivatives::pair_derivatives)) to
//! round-off.

use nalgebra::Vector3;

use crate::mortar::MortarError;
use crate::mortar::clip::clip;
use crate::mortar::clip_gradient::{Grad, axpy, clip_gradients};
use crate::mortar::dual::TestFunctions;
use crate::mortar::pair_derivatives::{Gradients, PairDerivatives};
use crate::mortar::quadrature::{TRIANGLE_7, inverse_maps};
use crate::mortar::segment::PairIntegrals;
use crate::mortar::trace::{Expansion, Facet, Trace};

/// The gradients of `xi` at a point `z` (gradient `dz`) of a facet's
/// planar map through the projected nodes `p` (gradients `dp`): `dxi =
/// J_P^-1 (dz - sum_k N_k(xi) dp_k)`.
fn parameter_gradient<const N: usize>(
    trace: Trace,
    xi: [f64; 2],
    p: &[[f64; 2]; 4],
    dp: &[[Grad<N>; 2]; 4],
    dz: &[Grad<N>; 2],
) -> [Grad<N>; 2] {
    let n = trace.shape(xi);
    let g = trace.shape_derivatives(xi);
    let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
    let mut r = *dz;
    for k in 0..trace.node_count() {
        for c in 0..2 {
            a[c] += g[k][0] * p[k][c];
            b[c] += g[k][1] * p[k][c];
            axpy(&mut r[c], -n[k], &dp[k][c]);
        }
    }
    let det = a[0] * b[1] - a[1] * b[0];
    let mut out = [[0.0; N]; 2];
    for i in 0..N {
        out[0][i] = (r[0][i] * b[1] - r[1][i] * b[0]) / det;
        out[1][i] = (a[0] * r[1][i] - a[1] * r[0][i]) / det;
    }
    out
}

/// The pair's `v_j` with gradients over its `N` variables (module docs).
fn gradient_n<const N: usize>(
    s: &Facet<f64>,
    m: &Facet<f64>,
    normals: &[Vector3<f64>; 4],
    test: &TestFunctions,
) -> Result<Option<(PairIntegrals<f64>, Gradients)>, MortarError> {
    let Some(overlap) = clip(s, m) else {
        return Ok(None);
    };
    let (ns, nm) = (s.node_count(), m.node_count());
    let grads = clip_gradients::<N>(s, m, &overlap);
    let n0 = overlap.plane.normal;
    let dn0 = &grads.normal;
    let (ps, dps) = (overlap.slave, &grads.slave);
    let (pm, dpm) = (overlap.master, &grads.master);
    let (xs, xm) = (Expansion::of(s), Expansion::of(m));
    // u_k = sum_g N_k(xi_g) (x_m - x_s) dA_g and its gradient.
    let mut u = [Vector3::zeros(); 4];
    let mut du = [[[0.0; N]; 3]; 4];
    let mut d = [[0.0; 4]; 4];
    let mut mm = [[0.0; 4]; 4];
    let mut area = 0.0;
    for piece in &grads.pieces {
        let count = piece.vertices.len();
        for i in 0..count {
            let cell = [
                &piece.centroid,
                &piece.vertices[i],
                &piece.vertices[(i + 1) % count],
            ];
            let (e1, e2) = (
                [cell[1].z[0] - cell[0].z[0], cell[1].z[1] - cell[0].z[1]],
                [cell[2].z[0] - cell[0].z[0], cell[2].z[1] - cell[0].z[1]],
            );
            let cell_area = (e1[0] * e2[1] - e1[1] * e2[0]) * 0.5;
            // d|T| = (de1 x e2 + e1 x de2) / 2, de_i = dq_i - dq_0.
            let mut d_area = [0.0; N];
            axpy(&mut d_area, 0.5 * e2[1], &cell[1].dz[0]);
            axpy(&mut d_area, -0.5 * e2[0], &cell[1].dz[1]);
            axpy(&mut d_area, -0.5 * e1[1], &cell[2].dz[0]);
            axpy(&mut d_area, 0.5 * e1[0], &cell[2].dz[1]);
            axpy(&mut d_area, 0.5 * (e1[1] - e2[1]), &cell[0].dz[0]);
            axpy(&mut d_area, 0.5 * (e2[0] - e1[0]), &cell[0].dz[1]);
            let zs: [[f64; 2]; 7] = TRIANGLE_7.map(|(l, _)| {
                [0, 1].map(|c| cell[0].z[c] * l[0] + cell[1].z[c] * l[1] + cell[2].z[c] * l[2])
            });
            let xis = inverse_maps(s.trace, &ps, &zs)?;
            let etas = inverse_maps(m.trace, &pm, &zs)?;
            for (g, (l, w)) in TRIANGLE_7.iter().enumerate() {
                let (xi, eta) = (xis[g], etas[g]);
                let mut dz = [[0.0; N]; 2];
                for c in 0..2 {
                    for a in 0..3 {
                        axpy(&mut dz[c], l[a], &cell[a].dz[c]);
                    }
                }
                let dxi = parameter_gradient(s.trace, xi, &ps, dps, &dz);
                let deta = parameter_gradient(m.trace, eta, &pm, dpm, &dz);
                // The slave's measure over the plane's, r = |a| / (a . n0).
                let [tx, te] = xs.tangents(xi);
                let an = tx.cross(&te);
                let (norm, along) = (an.norm(), an.dot(&n0));
                let r = norm / along;
                let wv = (an / norm - n0 * r) / along;
                let gs = s.trace.shape_derivatives(xi);
                let mut dr = [0.0; N];
                let (dxi_a, dxi_b) = (wv.dot(&tx.cross(&xs.d)), wv.dot(&xs.d.cross(&te)));
                axpy(&mut dr, dxi_a, &dxi[0]);
                axpy(&mut dr, dxi_b, &dxi[1]);
                for c in 0..3 {
                    axpy(&mut dr, -r / along * an[c], &dn0[c]);
                }
                let (te_w, w_tx) = (te.cross(&wv), wv.cross(&tx));
                for k in 0..ns {
                    for c in 0..3 {
                        dr[3 * k + c] += gs[k][0] * te_w[c] + gs[k][1] * w_tx[c];
                    }
                }
                let da = cell_area * r * *w;
                let mut d_da = [0.0; N];
                axpy(&mut d_da, *w * r, &d_area);
                axpy(&mut d_da, *w * cell_area, &dr);
                // The gap vector x_m - x_s and its gradient.
                let gap = xm.position(eta) - xs.position(xi);
                let [mx, me] = xm.tangents(eta);
                let nsh = s.trace.shape(xi);
                let nmh = m.trace.shape(eta);
                let mut e: [Grad<N>; 3] = [[0.0; N]; 3];
                for c in 0..3 {
                    let ec = &mut e[c];
                    for i in 0..N {
                        ec[i] = da
                            * (mx[c] * deta[0][i] + me[c] * deta[1][i]
                                - tx[c] * dxi[0][i]
                                - te[c] * dxi[1][i])
                            + gap[c] * d_da[i];
                    }
                    for k in 0..ns {
                        ec[3 * k + c] -= da * nsh[k];
                    }
                    for l in 0..nm {
                        ec[3 * ns + 3 * l + c] += da * nmh[l];
                    }
                }
                let weighted = gap * da;
                for k in 0..ns {
                    u[k] += weighted * nsh[k];
                    let (ga, gb) = (gs[k][0], gs[k][1]);
                    for c in 0..3 {
                        let (nk, wc) = (nsh[k], weighted[c]);
                        let (y, ec) = (&mut du[k][c], &e[c]);
                        for i in 0..N {
                            y[i] += nk * ec[i] + wc * (ga * dxi[0][i] + gb * dxi[1][i]);
                        }
                    }
                }
                // D and M.
                area += da;
                let phi = test.eval(&nsh);
                for j in 0..ns {
                    let pj = phi[j] * da;
                    for k in 0..ns {
                        d[j][k] += pj * nsh[k];
                    }
                    for l in 0..nm {
                        mm[j][l] += pj * nmh[l];
                    }
                }
            }
        }
    }
    let mut v = [Vector3::zeros(); 4];
    let mut gradient: Gradients = vec![0.0; 12 * N];
    // One row of N entries per (node, component).
    let (rows, _) = gradient.as_chunks_mut::<N>();
    for j in 0..4 {
        for c in 0..3 {
            let g: &mut Grad<N> = &mut rows[3 * j + c];
            for k in 0..ns {
                let a = test.coefficients[j][k];
                v[j][c] += u[k][c] * a;
                axpy(g, a, &du[k][c]);
            }
        }
    }
    let gap = std::array::from_fn(|j| if j < ns { normals[j].dot(&v[j]) } else { 0.0 });
    Ok(Some((
        PairIntegrals {
            gap,
            gap_vector: v,
            d,
            m: mm,
            area,
        },
        gradient,
    )))
}

/// The pair's `v_j` with their gradients over its dofs (module docs), the
/// same numbers as [`pair_derivatives`](super::pair_derivatives::pair_derivatives)
/// without the Hessian.
pub(crate) fn pair_gradient(
    s: &Facet<f64>,
    m: &Facet<f64>,
    normals: &[Vector3<f64>; 4],
    test: &TestFunctions,
) -> Result<Option<PairDerivatives>, MortarError> {
    let r = match s.node_count() + m.node_count() {
        6 => gradient_n::<18>(s, m, normals, test)?,
        7 => gradient_n::<21>(s, m, normals, test)?,
        _ => gradient_n::<24>(s, m, normals, test)?,
    };
    Ok(r.map(|(integrals, gradient)| PairDerivatives {
        integrals,
        dofs: Vec::new(),
        gradient,
        hessian: None,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mortar::pair_derivatives::pair_derivatives;

    /// Uniform numbers in `[-1, 1)` (a linear congruential generator).
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    /// A unit facet of `trace` near the plane `z = height`, every node moved
    /// by up to `jitter` (a third of it out of the plane), shifted by
    /// `shift` in the plane, turned by `turn`; facing down with `flip`.
    fn facet(
        rng: &mut Lcg,
        trace: Trace,
        height: f64,
        shift: [f64; 2],
        turn: f64,
        flip: bool,
    ) -> Facet<f64> {
        let corners: Vec<[f64; 2]> = match trace {
            Trace::Quad4 => vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            Trace::Tri3 => vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        };
        let order: Vec<usize> = if flip {
            (0..corners.len()).rev().collect()
        } else {
            (0..corners.len()).collect()
        };
        let (c, s) = (turn.cos(), turn.sin());
        let mut x = [Vector3::zeros(); 4];
        for (slot, &k) in order.iter().enumerate() {
            let [u, v] = corners[k];
            let (u, v) = (u + 0.2 * rng.next(), v + 0.2 * rng.next());
            x[slot] = Vector3::new(
                shift[0] + c * u - s * v,
                shift[1] + s * u + c * v,
                height + 0.07 * rng.next(),
            );
        }
        if trace == Trace::Tri3 {
            x[3] = x[2];
        }
        Facet { trace, x }
    }

    #[test]
    fn the_chain_rule_gives_the_dual_numbers_gradients() {
        let mut rng = Lcg(2024);
        let (mut overlapping, mut darts) = (0, 0);
        let mut worst = 0.0f64;
        for case in 0..400 {
            let st = if case % 2 == 0 {
                Trace::Quad4
            } else {
                Trace::Tri3
            };
            let mt = if case % 4 < 2 {
                Trace::Quad4
            } else {
                Trace::Tri3
            };
            let mut s = facet(&mut rng, st, 0.0, [0.0, 0.0], 0.0, false);
            if st == Trace::Quad4 && case % 10 == 8 {
                // A dart: corner 3 reflex, clipped as two triangles.
                s.x[3] = Vector3::new(0.6, 0.45, 0.0);
            }
            let shift = [0.6 * rng.next() + 0.3, 0.6 * rng.next() + 0.3];
            let (height, turn) = (0.02 * rng.next(), rng.next());
            let m = facet(&mut rng, mt, height, shift, turn, true);
            let normals: [Vector3<f64>; 4] = std::array::from_fn(|_| {
                Vector3::new(0.1 * rng.next(), 0.1 * rng.next(), 1.0).normalize()
            });
            let test = if case % 8 < 4 {
                TestFunctions::dual(&s)
            } else {
                TestFunctions::standard(st)
            };
            let fast = pair_gradient(&s, &m, &normals, &test).unwrap();
            let reference = pair_derivatives(&s, &m, &normals, &test, false).unwrap();
            let (Some(fast), Some(reference)) = (fast, reference) else {
                continue;
            };
            overlapping += 1;
            if crate::mortar::clip::clip(&s, &m).is_some_and(|c| c.pieces.len() == 2) {
                darts += 1;
            }
            let (a, b) = (&fast.integrals, &reference.integrals);
            let scale = b.gap_vector.iter().map(|v| v.norm()).fold(0.0, f64::max);
            for j in 0..4 {
                assert!((a.gap_vector[j] - b.gap_vector[j]).norm() <= 1e-12 * scale);
                assert!((a.gap[j] - b.gap[j]).abs() <= 1e-12 * scale);
                for k in 0..4 {
                    assert!((a.d[j][k] - b.d[j][k]).abs() <= 1e-12 * b.area.abs());
                    assert!((a.m[j][k] - b.m[j][k]).abs() <= 1e-12 * b.area.abs());
                }
            }
            assert!((a.area - b.area).abs() <= 1e-12 * b.area.abs());
            let big = reference
                .gradient
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            for j in 0..4 {
                for c in 0..3 {
                    let (g, h) = (fast.gradient(j, c), reference.gradient(j, c));
                    assert_eq!(g.len(), h.len());
                    for (x, y) in g.iter().zip(h) {
                        let err = (x - y).abs() / big;
                        worst = worst.max(err);
                        assert!(err <= 1e-12, "case {case}, v_{j}{c}: {x} against {y}");
                    }
                }
            }
        }
        println!(
            "{overlapping} overlapping pairs ({darts} in two pieces), largest difference {worst:.1e} of the largest entry"
        );
        assert!(overlapping > 200 && darts > 5, "{overlapping}, {darts}");
    }
}
