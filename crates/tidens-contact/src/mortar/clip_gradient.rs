//! The gradients of a pair's overlap ([`clip`](super::clip::clip)) with
//! respect to the pair's node coordinates: the auxiliary plane's normal,
//! the projected nodes, the clip polygons' vertices and centroids.
//!
//! The variables are those of [`pair_derivatives`](super::pair_derivatives):
//! slave node `k`'s coordinate `c` is variable `3 k + c`, master node `l`'s
//! is `3 n_s + 3 l + c`, `N = 3 (n_s + n_m)` of them. The clipping's
//! choices are taken as made in `f64` ([`Clip::made`]); their results are
//! differentiated by the chain rule, step by step as computed:
//!
//! ```text
//! plane at the slave centre xi_c:  a = x_xi, b = x_eta, m = a x b,
//!   dn0 = (dm - n0 (n0 . dm)) / |m|,          dm = da x b + a x db
//!   t = a - n0 (a . n0),  dt = da - dn0 (a . n0) - n0 (da . n0 + a . dn0)
//!   dt1 = (dt - t1 (t1 . dt)) / |t|,          dt2 = dn0 x t1 + n0 x dt1
//! projection  P(p) = ((p - c0) . t1, (p - c0) . t2):
//!   dP_i = (dp - dc0) . t_i + (p - c0) . dt_i,   dc0 = sum_k N_k(xi_c) dx_k
//! cut  r = p + (q - p) t,  t = s_p / (s_p - s_q),  s_. = e x (. - a),  e = b - a:
//!   dr = dp + (dq - dp) t + (q - p) dt,   dt = (s_p ds_q - s_q ds_p) / (s_p - s_q)^2
//! centroid  q_c = q_0 + C / (3 A2),  A2 = sum_i w_i,  C = sum_i (u_i + u_i+1) w_i,
//!   w_i = u_i x u_i+1,  u_i = q_i - q_0
//! ```
//!
//! The node positions enter linearly (`da = sum_k dN_k/dxi(xi_c) dx_k`, and
//! so on), so the gradients are `N`-long vectors of `f64`.

use nalgebra::Vector3;

use crate::mortar::clip::{Clip, Origin, Point};
use crate::mortar::trace::Facet;

/// A gradient over the pair's `N` variables.
pub(crate) type Grad<const N: usize> = [f64; N];

/// `y += a x`.
#[inline(always)]
pub(crate) fn axpy<const N: usize>(y: &mut Grad<N>, a: f64, x: &Grad<N>) {
    for i in 0..N {
        y[i] += a * x[i];
    }
}

/// A point of the auxiliary plane with the gradients of its coordinates.
#[derive(Clone, Copy)]
pub(crate) struct PointGrad<const N: usize> {
    pub(crate) z: Point<f64>,
    pub(crate) dz: [Grad<N>; 2],
}

/// A clip polygon with the gradients of its vertices and centroid.
pub(crate) struct PieceGrad<const N: usize> {
    pub(crate) centroid: PointGrad<N>,
    pub(crate) vertices: Vec<PointGrad<N>>,
}

/// The gradients of an overlap (module docs).
pub(crate) struct ClipGradients<const N: usize> {
    /// `dn0`, by component.
    pub(crate) normal: [Grad<N>; 3],
    /// `dP(x_k)` of the slave nodes.
    pub(crate) slave: [[Grad<N>; 2]; 4],
    /// `dP(y_l)` of the master nodes.
    pub(crate) master: [[Grad<N>; 2]; 4],
    pub(crate) pieces: Vec<PieceGrad<N>>,
}

/// A 3-vector's gradients, by component.
type Grad3<const N: usize> = [Grad<N>; 3];

/// `u . dv` over the components.
fn dot_grad<const N: usize>(u: &Vector3<f64>, dv: &Grad3<N>) -> Grad<N> {
    let mut g = [0.0; N];
    for c in 0..3 {
        axpy(&mut g, u[c], &dv[c]);
    }
    g
}

/// `du x v + u x dv`.
fn cross_grad<const N: usize>(
    u: &Vector3<f64>,
    du: &Grad3<N>,
    v: &Vector3<f64>,
    dv: &Grad3<N>,
) -> Grad3<N> {
    let mut g = [[0.0; N]; 3];
    for c in 0..3 {
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        for i in 0..N {
            g[c][i] = du[c1][i] * v[c2] - du[c2][i] * v[c1] + u[c1] * dv[c2][i] - u[c2] * dv[c1][i];
        }
    }
    g
}

/// `d(v / |v|) = (dv - e (e . dv)) / |v|`, `e = v / |v|`.
fn unit_grad<const N: usize>(v: &Vector3<f64>, dv: &Grad3<N>) -> Grad3<N> {
    let l = v.norm();
    let e = v / l;
    let along = dot_grad(&e, dv);
    std::array::from_fn(|c| std::array::from_fn(|i| (dv[c][i] - e[c] * along[i]) / l))
}

/// The gradients of `clip`, the overlap of `slave` and `master` in `f64`
/// (module docs).
pub(crate) fn clip_gradients<const N: usize>(
    slave: &Facet<f64>,
    master: &Facet<f64>,
    clip: &Clip<f64>,
) -> ClipGradients<N> {
    let (ns, nm) = (slave.node_count(), master.node_count());
    let trace = slave.trace;
    let xc = trace.centre();
    let shape = trace.shape(xc);
    let g = trace.shape_derivatives(xc);
    // The slave's centre and tangents there, linear in its nodes.
    let (mut dc0, mut da, mut db) = ([[0.0; N]; 3], [[0.0; N]; 3], [[0.0; N]; 3]);
    for k in 0..ns {
        for c in 0..3 {
            dc0[c][3 * k + c] = shape[k];
            da[c][3 * k + c] = g[k][0];
            db[c][3 * k + c] = g[k][1];
        }
    }
    let [a, b] = slave.tangents(xc);
    let plane = &clip.plane;
    let (n0, [t1, t2], c0) = (plane.normal, plane.basis, plane.centre);
    let dm = cross_grad(&a, &da, &b, &db);
    let dn0 = unit_grad(&a.cross(&b), &dm);
    let an = a.dot(&n0);
    let (da_n, a_dn) = (dot_grad(&n0, &da), dot_grad(&a, &dn0));
    let dt: Grad3<N> = std::array::from_fn(|c| {
        std::array::from_fn(|i| da[c][i] - dn0[c][i] * an - n0[c] * (da_n[i] + a_dn[i]))
    });
    let t = a - n0 * an;
    let dt1 = unit_grad(&t, &dt);
    let dt2 = cross_grad(&n0, &dn0, &t1, &dt1);
    let basis = [(t1, dt1), (t2, dt2)];
    // P(x) of a node at `x` whose coordinates are variables `first..first + 3`.
    let project = |x: &Vector3<f64>, first: usize| -> [Grad<N>; 2] {
        let d = x - c0;
        basis.map(|(t, dt)| {
            let mut p = dot_grad(&d, &dt);
            axpy(&mut p, -1.0, &dot_grad(&t, &dc0));
            for c in 0..3 {
                p[first + c] += t[c];
            }
            p
        })
    };
    let mut dslave = [[[0.0; N]; 2]; 4];
    for k in 0..ns {
        dslave[k] = project(&slave.x[k], 3 * k);
    }
    let mut dmaster = [[[0.0; N]; 2]; 4];
    for l in 0..nm {
        dmaster[l] = project(&master.x[l], 3 * ns + 3 * l);
    }
    // The made vertices, in order.
    let mut made: Vec<[Grad<N>; 2]> = Vec::with_capacity(clip.made.len());
    for (_, origin) in &clip.made {
        let dr = match *origin {
            Origin::Master(l) => dmaster[l],
            Origin::Cut { p, q, a, b } => {
                let (pa, pb) = (clip.slave[a], clip.slave[b]);
                let (dpa, dpb) = (&dslave[a], &dslave[b]);
                let (vp, vq) = (clip.made[p].0, clip.made[q].0);
                let (dp, dq) = (&made[p], &made[q]);
                let e = [pb[0] - pa[0], pb[1] - pa[1]];
                // s_x = e x (x - a) and its gradient.
                let side = |x: &Point<f64>, dx: &[Grad<N>; 2]| {
                    let u = [x[0] - pa[0], x[1] - pa[1]];
                    let s = e[0] * u[1] - e[1] * u[0];
                    let ds: Grad<N> = std::array::from_fn(|i| {
                        (dpb[0][i] - dpa[0][i]) * u[1] + e[0] * (dx[1][i] - dpa[1][i])
                            - (dpb[1][i] - dpa[1][i]) * u[0]
                            - e[1] * (dx[0][i] - dpa[0][i])
                    });
                    (s, ds)
                };
                let ((sp, dsp), (sq, dsq)) = (side(&vp, dp), side(&vq, dq));
                let den = sp - sq;
                let t = sp / den;
                let dt: Grad<N> =
                    std::array::from_fn(|i| (sp * dsq[i] - sq * dsp[i]) / (den * den));
                std::array::from_fn(|c| {
                    std::array::from_fn(|i| {
                        dp[c][i] + (dq[c][i] - dp[c][i]) * t + (vq[c] - vp[c]) * dt[i]
                    })
                })
            }
        };
        made.push(dr);
    }
    let pieces = clip
        .pieces
        .iter()
        .map(|piece| {
            let vertices: Vec<PointGrad<N>> = piece
                .made
                .iter()
                .map(|&i| PointGrad {
                    z: clip.made[i].0,
                    dz: made[i],
                })
                .collect();
            PieceGrad {
                centroid: centroid_grad(&vertices, piece.centroid),
                vertices,
            }
        })
        .collect();
    ClipGradients {
        normal: dn0,
        slave: dslave,
        master: dmaster,
        pieces,
    }
}

/// The centroid `centroid` of the polygon `v` with its gradient (module
/// docs).
fn centroid_grad<const N: usize>(v: &[PointGrad<N>], centroid: Point<f64>) -> PointGrad<N> {
    let q0 = &v[0];
    let (mut area2, mut c) = (0.0, [0.0; 2]);
    let (mut darea2, mut dc) = ([0.0; N], [[0.0; N]; 2]);
    for i in 1..v.len() - 1 {
        let (p, q) = (&v[i], &v[i + 1]);
        let a = [p.z[0] - q0.z[0], p.z[1] - q0.z[1]];
        let b = [q.z[0] - q0.z[0], q.z[1] - q0.z[1]];
        let w = a[0] * b[1] - a[1] * b[0];
        let ad: [Grad<N>; 2] =
            std::array::from_fn(|c| std::array::from_fn(|k| p.dz[c][k] - q0.dz[c][k]));
        let bd: [Grad<N>; 2] =
            std::array::from_fn(|c| std::array::from_fn(|k| q.dz[c][k] - q0.dz[c][k]));
        let dw: Grad<N> = std::array::from_fn(|k| {
            ad[0][k] * b[1] + a[0] * bd[1][k] - ad[1][k] * b[0] - a[1] * bd[0][k]
        });
        area2 += w;
        axpy(&mut darea2, 1.0, &dw);
        for j in 0..2 {
            c[j] += (a[j] + b[j]) * w;
            for k in 0..N {
                dc[j][k] += (ad[j][k] + bd[j][k]) * w + (a[j] + b[j]) * dw[k];
            }
        }
    }
    let dz = std::array::from_fn(|j| {
        std::array::from_fn(|k| {
            q0.dz[j][k] + dc[j][k] / (3.0 * area2) - c[j] * darea2[k] / (3.0 * area2 * area2)
        })
    });
    PointGrad { z: centroid, dz }
}
