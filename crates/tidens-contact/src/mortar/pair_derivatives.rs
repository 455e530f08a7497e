//! A pair's gap vectors `v_j` ([`integrate_pair`]) with their exact first
//! (and second) derivatives with respect to the pair's node coordinates,
//! by forward-mode automatic differentiation.
//!
//! The variables: slave node `k`'s coordinate `c` is variable `3 k + c`,
//! master node `l`'s is `3 n_s + 3 l + c`, `N = 3 (n_s + n_m)` of them
//! (18, 21 or 24). The pair is integrated once in `DualSVec64<N>`
//! (gradients) or `Dual2SVec64<N>` (Hessians) with the nodal normals held
//! constant: their derivatives are chained by the caller, once per node
//! ([`crate::mortar::weighted_gap`]). `g_j = n_j . v_j` is linear in `n_j`,
//! so `v_j` is all the pair has to give for that.
//!
//! The weighted gaps' Hessians come from here; their gradients from the
//! chain rule in `f64` ([`crate::mortar::pair_gradient`]), several times
//! faster, of which this is the reference (the same numbers to
//! round-off).

use nalgebra::{Const, DMatrix, U1, Vector3};
use num_dual::{Dual2SVec64, DualSVec64};

use crate::mortar::MortarError;
use crate::mortar::dual::TestFunctions;
use crate::mortar::segment::{PairIntegrals, integrate_pair};
use crate::mortar::trace::{AdScalar, Facet};

/// By slot `j` and component `c`, the gradient of `v_jc` over the pair's
/// `N` variables: entry `(3 j + c) N + i` (empty for values only).
pub(crate) type Gradients = Vec<f64>;

/// A pair's `v_j` with derivatives: value, then by slot `j` and
/// component `c` the gradient (and Hessian) over the pair's dofs.
pub(crate) struct PairDerivatives {
    pub(crate) integrals: PairIntegrals<f64>,
    /// Global dofs of the variables (filled in by the caller).
    pub(crate) dofs: Vec<usize>,
    pub(crate) gradient: Gradients,
    pub(crate) hessian: Option<Box<[[DMatrix<f64>; 3]; 4]>>,
}

impl PairDerivatives {
    /// The values alone.
    pub(crate) fn values(integrals: PairIntegrals<f64>) -> Self {
        Self {
            integrals,
            dofs: Vec::new(),
            gradient: Vec::new(),
            hessian: None,
        }
    }

    /// The gradient of `v_jc` over the pair's variables (empty for values
    /// only).
    pub(crate) fn gradient(&self, j: usize, c: usize) -> &[f64] {
        let n = self.gradient.len() / 12;
        &self.gradient[(3 * j + c) * n..(3 * j + c + 1) * n]
    }
}

/// A dual number seeded as variable `i` of the pair.
trait Seeded: AdScalar {
    fn seed(v: f64, i: usize) -> Self;
}

impl<const N: usize> Seeded for DualSVec64<N> {
    fn seed(v: f64, i: usize) -> Self {
        Self::from_re(v).derivative(i)
    }
}

impl<const N: usize> Seeded for Dual2SVec64<N> {
    fn seed(v: f64, i: usize) -> Self {
        Self::from_re(v).derivative(i)
    }
}

/// The slave and master facets as variables: slave node `k`'s coordinate
/// `c` is variable `3 k + c`, master node `l`'s is `3 n_s + 3 l + c`.
fn seeded<T: Seeded>(s: &Facet<f64>, m: &Facet<f64>) -> (Facet<T>, Facet<T>) {
    let (ns, nm) = (s.node_count(), m.node_count());
    let lift = |f: &Facet<f64>, count: usize, offset: usize| Facet {
        trace: f.trace,
        x: std::array::from_fn(|k| {
            Vector3::from_fn(|c, _| {
                if k < count {
                    T::seed(f.x[k][c], offset + 3 * k + c)
                } else {
                    T::from(f.x[k][c])
                }
            })
        }),
    };
    (lift(s, ns, 0), lift(m, nm, 3 * ns))
}

fn values<T: AdScalar>(p: PairIntegrals<T>) -> PairIntegrals<f64> {
    PairIntegrals {
        gap: p.gap.map(|g| g.re()),
        gap_vector: p.gap_vector.map(|v| v.map(|c| c.re())),
        d: p.d,
        m: p.m,
        area: p.area,
    }
}

fn gradient_n<const N: usize>(
    s: &Facet<f64>,
    m: &Facet<f64>,
    normals: &[Vector3<f64>; 4],
    test: &TestFunctions,
) -> Result<Option<(PairIntegrals<f64>, Gradients)>, MortarError> {
    let (sd, md) = seeded::<DualSVec64<N>>(s, m);
    let n = normals.map(|v| v.map(DualSVec64::<N>::from));
    let Some(p) = integrate_pair(&sd, &md, &n, test)? else {
        return Ok(None);
    };
    let g = (0..12)
        .flat_map(|r| {
            p.gap_vector[r / 3][r % 3]
                .eps
                .unwrap_generic(Const::<N>, U1)
                .as_slice()
                .to_vec()
        })
        .collect();
    Ok(Some((values(p), g)))
}

fn hessian_n<const N: usize>(
    s: &Facet<f64>,
    m: &Facet<f64>,
    normals: &[Vector3<f64>; 4],
    test: &TestFunctions,
) -> Result<Option<PairDerivatives>, MortarError> {
    let (sd, md) = seeded::<Dual2SVec64<N>>(s, m);
    let n = normals.map(|v| v.map(Dual2SVec64::<N>::from));
    let Some(p) = integrate_pair(&sd, &md, &n, test)? else {
        return Ok(None);
    };
    let part = |j: usize, c: usize| &p.gap_vector[j][c];
    let gradient = (0..12)
        .flat_map(|r| {
            part(r / 3, r % 3)
                .v1
                .unwrap_generic(U1, Const::<N>)
                .as_slice()
                .to_vec()
        })
        .collect();
    let hessian = std::array::from_fn(|j| {
        std::array::from_fn(|c| {
            let h = part(j, c).v2.unwrap_generic(Const::<N>, Const::<N>);
            DMatrix::from_fn(N, N, |a, b| h[(a, b)])
        })
    });
    Ok(Some(PairDerivatives {
        integrals: values(p),
        dofs: Vec::new(),
        gradient,
        hessian: Some(Box::new(hessian)),
    }))
}

/// The pair's `v_j` with derivatives over its dofs (see [`seeded`]).
pub(crate) fn pair_derivatives(
    s: &Facet<f64>,
    m: &Facet<f64>,
    normals: &[Vector3<f64>; 4],
    test: &TestFunctions,
    hessian: bool,
) -> Result<Option<PairDerivatives>, MortarError> {
    let size = s.node_count() + m.node_count();
    if hessian {
        return match size {
            6 => hessian_n::<18>(s, m, normals, test),
            7 => hessian_n::<21>(s, m, normals, test),
            _ => hessian_n::<24>(s, m, normals, test),
        };
    }
    let r = match size {
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
