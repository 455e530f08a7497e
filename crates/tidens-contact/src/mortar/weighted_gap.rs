//! The weighted gaps of a slave surface's nodes against a master surface,
//! with their exact derivatives.
//!
//! Summed over the candidate pairs `(s, m)` whose slave facet `s` holds
//! node `j` ([`integrate_pair`]):
//!
//! ```text
//! V_j = sum_(s,m) v_j^(s,m),     g_j = n_j . V_j,     A_j = sum_{e at j} int_e Phi_j dA
//! ```
//!
//! `A_j` over the node's whole support by each facet's own rule (not only
//! where a master overlaps), in the current geometry, without
//! derivatives (the caller freezes it per step). `V_j` depends on the
//! nodes of the pairs' facets, `n_j` on the nodes of `j`'s ring
//! ([`normals`](crate::mortar::normals)); the chain rule gives
//!
//! ```text
//! dg_j = n_j . dV_j + V_j . dn_j
//! d2g_j = sum_c (n_jc d2V_jc + V_jc d2n_jc + dn_jc (x) dV_jc + dV_jc (x) dn_jc)
//! ```
//!
//! `dV_j`, pair by pair over the pair's node coordinates (`N = 3 (n_s +
//! n_m)`: 18 to 24) with the normals held constant, by the chain rule in
//! `f64` (`pair_gradient`); `d2V_j` by forward-mode automatic
//! differentiation (`Dual2SVec64<N>`, `pair_derivatives`); `dn_j` and
//! `d2n_j` by [`normal_derivatives`]. The Hessian is for exact tangents in tests:
//! every dual number then carries an `N x N` matrix, and the pairs are
//! integrated one after another on a thread with a large stack; values
//! and gradients pair by pair in parallel (rayon), summed in the pairs'
//! order.

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::{DMatrix, Vector3};
use rayon::prelude::*;

use crate::mortar::MortarError;
use crate::mortar::clip::clip;
use crate::mortar::dual::SurfaceTestFunctions;
use crate::mortar::normals::{NodeRing, nodal_normal, normal_derivatives};
use crate::mortar::pair_derivatives::{PairDerivatives, pair_derivatives};
use crate::mortar::pair_gradient::pair_gradient;
use crate::mortar::quadrature::element_rule;
use crate::mortar::segment::integrate_pair;
use crate::mortar::trace::{Facet, Trace};
use crate::surface::{ContactSurface, Continuation};

/// The stack of the thread that integrates the pairs for Hessians.
const HESSIAN_STACK: usize = 256 << 20;

/// What to differentiate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Derivatives {
    /// Values only (`f64` throughout).
    #[default]
    Value,
    /// Values and gradients.
    Gradient,
    /// Values and the mortar gradient: `dg_j/dx_l = M_jl n_j` on the
    /// master nodes, `-D_jk n_j` on the slave nodes and the nodal normal's
    /// variation `V_j . dn_j`, without the variation of the segments
    /// (their cells, test functions and Jacobians), whose terms are
    /// proportional to the local gap (of the order of the penetration at
    /// a pressed node). As cheap as the values, and exact for a uniform
    /// gap between flat surfaces (the patch test).
    Mortar,
    /// Values, gradients and Hessians.
    Hessian,
}

/// A dense symmetric block over some dofs.
#[derive(Clone, Debug, PartialEq)]
pub struct HessianBlock {
    /// Global dofs (`3 node + component`), increasing.
    pub dofs: Vec<usize>,
    /// Row-major, `dofs.len()^2` entries \[mm\].
    pub values: Vec<f64>,
}

impl HessianBlock {
    /// The entry of dofs `a`, `b` (zero if either is not in the block).
    pub fn get(&self, a: usize, b: usize) -> f64 {
        match (self.dofs.binary_search(&a), self.dofs.binary_search(&b)) {
            (Ok(i), Ok(k)) => self.values[i * self.dofs.len() + k],
            _ => 0.0,
        }
    }
}

/// The weighted gap of one slave node.
#[derive(Clone, Debug, PartialEq)]
pub struct WeightedGap {
    /// The node (global id).
    pub node: usize,
    /// `g_j` \[mm^3\]: > 0 open, < 0 penetrating.
    pub gap: f64,
    /// `A_j = int Phi_j dA` over the node's support \[mm^2\].
    pub area: f64,
    /// The nodal normal `n_j`.
    pub normal: [f64; 3],
    /// `(slave node k, D_jk)` \[mm^2\], by node.
    pub d: Vec<(usize, f64)>,
    /// `(master node l, M_jl)` \[mm^2\], by node.
    pub m: Vec<(usize, f64)>,
    /// `(dof, dg_j/dx_dof)` \[mm^2\], by dof (empty for values only).
    pub gradient: Vec<(usize, f64)>,
    /// `d2g_j/dx dx` \[mm\], if asked.
    pub hessian: Option<HessianBlock>,
}

/// What the pairs bring to one slave node.
#[derive(Default)]
struct Sum {
    v: Vector3<f64>,
    /// dof -> `dV/dx_dof`.
    dv: BTreeMap<usize, [f64; 3]>,
    /// (dof, dof) -> `d2V/dx dx`.
    hv: BTreeMap<(usize, usize), [f64; 3]>,
    d: BTreeMap<usize, f64>,
    m: BTreeMap<usize, f64>,
}

/// The pair (`sf`, `mf`) integrated, with its global dofs, if it overlaps.
#[allow(clippy::too_many_arguments)]
fn pair_contribution(
    slave: &ContactSurface,
    master: &ContactSurface,
    x: &[[f64; 3]],
    (sf, mf): (usize, usize),
    normals: &BTreeMap<usize, Vector3<f64>>,
    test: &SurfaceTestFunctions,
    derivatives: Derivatives,
) -> Result<Option<PairDerivatives>, MortarError> {
    let s = Facet::of_surface(slave, sf, x);
    let m = Facet::of_master(master, mf, x);
    let snodes = slave.facets[sf];
    let n: [Vector3<f64>; 4] = snodes.map(|k| normals[&k]);
    let t = &test.facets[sf];
    let result = match derivatives {
        Derivatives::Value | Derivatives::Mortar => {
            integrate_pair(&s, &m, &n, t)?.map(PairDerivatives::values)
        }
        // Most candidates do not overlap: find out in f64 before any dual
        // number is made.
        _ if clip(&s, &m).is_none() => None,
        Derivatives::Gradient => pair_gradient(&s, &m, &n, t)?,
        Derivatives::Hessian => pair_derivatives(&s, &m, &n, t, true)?,
    };
    Ok(result.map(|mut p| {
        let (ns, nm) = (s.node_count(), m.node_count());
        if let Some(t) = master.continuation(mf) {
            to_master_nodes(&mut p, t, ns, nm);
        }
        let mnodes = master.facets[mf];
        p.dofs = (0..3 * (ns + nm))
            .map(|i| {
                let node = if i < 3 * ns {
                    snodes[i / 3]
                } else {
                    mnodes[(i - 3 * ns) / 3]
                };
                3 * node + i % 3
            })
            .collect();
        p
    }))
}

/// The pair's integrals and derivatives over the corners of a continued
/// master facet (corner `a` = `sum_l t[a][l] y_l`) taken over the facet's
/// nodes `y_l` instead: `M_jl = sum_a M'_ja t[a][l]`, and the derivatives
/// by the chain rule (the Jacobian `J` is the identity on the slave's
/// variables and `t` in each coordinate on the master's).
fn to_master_nodes(p: &mut PairDerivatives, t: &Continuation, ns: usize, nm: usize) {
    let m = p.integrals.m;
    for j in 0..4 {
        for l in 0..4 {
            p.integrals.m[j][l] = (0..nm).map(|a| m[j][a] * t[a][l]).sum();
        }
    }
    let jacobian = |i: usize, k: usize| -> f64 {
        match (i.checked_sub(3 * ns), k.checked_sub(3 * ns)) {
            (None, None) => f64::from(u8::from(i == k)),
            (Some(a), Some(l)) if a % 3 == l % 3 => t[a / 3][l / 3],
            _ => 0.0,
        }
    };
    let n = p.gradient.len() / 12;
    for block in p.gradient.chunks_mut(n.max(1)) {
        let old = block.to_vec();
        for (k, g) in block.iter_mut().enumerate().skip(3 * ns) {
            *g = (3 * ns..3 * (ns + nm))
                .map(|i| old[i] * jacobian(i, k))
                .sum();
        }
    }
    if let Some(h) = p.hessian.as_mut() {
        for row in h.iter_mut() {
            for block in row.iter_mut() {
                let jm = DMatrix::from_fn(block.nrows(), block.ncols(), jacobian);
                *block = jm.transpose() * &*block * &jm;
            }
        }
    }
}

/// Adds what pair `p` of slave facet nodes `snodes` and master facet nodes
/// `mnodes` brings to the sums of its slave nodes (of those in `only`, if
/// given).
fn accumulate(
    sums: &mut BTreeMap<usize, Sum>,
    p: &PairDerivatives,
    (snodes, mnodes): (&[usize], &[usize]),
    only: Option<&BTreeSet<usize>>,
) {
    for (j, &node) in snodes.iter().enumerate() {
        if only.is_some_and(|nodes| !nodes.contains(&node)) {
            continue;
        }
        let sum = sums.entry(node).or_default();
        sum.v += p.integrals.gap_vector[j];
        for (k, &n) in snodes.iter().enumerate() {
            *sum.d.entry(n).or_default() += p.integrals.d[j][k];
        }
        for (l, &n) in mnodes.iter().enumerate() {
            *sum.m.entry(n).or_default() += p.integrals.m[j][l];
        }
        if p.dofs.is_empty() || p.gradient.is_empty() {
            continue;
        }
        let g = [0, 1, 2].map(|c| p.gradient(j, c));
        for (i, &dof) in p.dofs.iter().enumerate() {
            let e = sum.dv.entry(dof).or_default();
            for c in 0..3 {
                e[c] += g[c][i];
            }
        }
        if let Some(h) = &p.hessian {
            for (a, &da) in p.dofs.iter().enumerate() {
                for (b, &db) in p.dofs.iter().enumerate() {
                    let e = sum.hv.entry((da, db)).or_default();
                    for c in 0..3 {
                        e[c] += h[j][c][(a, b)];
                    }
                }
            }
        }
    }
}

/// The weighted gaps of the nodes of `slave` that overlap `master` on the
/// candidate pairs `pairs` (slave facet, master facet), node coordinates
/// `x` \[mm\], the slave facets' test functions `test`, with the
/// derivatives asked (module docs). Sorted by node.
///
/// The pairs are integrated in parallel (rayon) and summed in their
/// order, so the result does not depend on the threads.
pub fn weighted_gaps(
    slave: &ContactSurface,
    master: &ContactSurface,
    x: &[[f64; 3]],
    pairs: &[(usize, usize)],
    test: &SurfaceTestFunctions,
    derivatives: Derivatives,
) -> Result<Vec<WeightedGap>, MortarError> {
    gaps_of(slave, master, x, pairs, test, derivatives, None)
}

/// The weighted gaps of the slave nodes `nodes` (global ids) only, those
/// of them that overlap `master`: the same as [`weighted_gaps`] gives
/// them, without the other nodes' sums and derivatives (a pair's facet
/// brings three or four nodes, of which a caller may need one).
pub fn weighted_gaps_of(
    slave: &ContactSurface,
    master: &ContactSurface,
    x: &[[f64; 3]],
    pairs: &[(usize, usize)],
    test: &SurfaceTestFunctions,
    derivatives: Derivatives,
    nodes: &BTreeSet<usize>,
) -> Result<Vec<WeightedGap>, MortarError> {
    gaps_of(slave, master, x, pairs, test, derivatives, Some(nodes))
}

/// [`weighted_gaps`] of the nodes `only`, or of all.
fn gaps_of(
    slave: &ContactSurface,
    master: &ContactSurface,
    x: &[[f64; 3]],
    pairs: &[(usize, usize)],
    test: &SurfaceTestFunctions,
    derivatives: Derivatives,
    only: Option<&BTreeSet<usize>>,
) -> Result<Vec<WeightedGap>, MortarError> {
    for &(s, m) in pairs {
        if s >= slave.facets.len() || m >= master.facets.len() || s >= test.facets.len() {
            return Err(MortarError::Pair {
                slave: s,
                master: m,
                slave_facets: slave.facets.len().min(test.facets.len()),
                master_facets: master.facets.len(),
            });
        }
    }
    let too_far =
        |surface: &ContactSurface| surface.nodes.last().copied().filter(|&n| n >= x.len());
    if let Some(node) = too_far(slave).or(too_far(master)) {
        return Err(MortarError::Node {
            node,
            nodes: x.len(),
        });
    }
    let ring = NodeRing::new(slave);
    let index = |n: usize| slave.nodes.binary_search(&n).unwrap_or(0);
    let strace = Trace::of_kind(slave.kind);
    // The normals (values) of the slave facets' nodes, by global node.
    let normals: BTreeMap<usize, Vector3<f64>> = pairs
        .iter()
        .flat_map(|&(sf, _)| slave.facets[sf])
        .collect::<BTreeSet<usize>>()
        .into_iter()
        .map(|n| (n, nodal_normal(slave, &ring, index(n), x)))
        .collect();
    let contribution = |&pair: &(usize, usize)| {
        pair_contribution(slave, master, x, pair, &normals, test, derivatives)
    };
    // Collected by index (no reallocation), the errors read in the pairs'
    // order.
    type Contribution = Result<Option<PairDerivatives>, MortarError>;
    let contributions: Vec<Contribution> = if derivatives == Derivatives::Hessian {
        // A second-order dual number carries an N x N matrix (4.6 kB at N =
        // 24): one pair's integration needs more than a thread's default
        // stack (2 MiB). The pairs go one after another on a thread with a
        // large one (or, if it cannot be made, on this one).
        let run = || pairs.iter().map(contribution).collect::<Vec<_>>();
        std::thread::scope(|scope| {
            match std::thread::Builder::new()
                .stack_size(HESSIAN_STACK)
                .spawn_scoped(scope, run)
            {
                Ok(handle) => handle
                    .join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
                Err(_) => run(),
            }
        })
    } else {
        pairs.par_iter().map(contribution).collect()
    };
    let mut sums: BTreeMap<usize, Sum> = BTreeMap::new();
    let (ns, nm) = (
        strace.node_count(),
        Trace::of_kind(master.kind).node_count(),
    );
    for (&(sf, mf), p) in pairs.iter().zip(&contributions) {
        if let Some(p) = p.as_ref().map_err(Clone::clone)? {
            let nodes = (&slave.facets[sf][..ns], &master.facets[mf][..nm]);
            accumulate(&mut sums, p, nodes, only);
        }
    }
    let sums: Vec<(usize, Sum)> = sums.into_iter().collect();
    // Each facet's integrals of its test functions, once for all its nodes.
    let facets: Vec<usize> = sums
        .iter()
        .flat_map(|&(node, _)| ring.facets(index(node)).iter().map(|&(f, _)| f))
        .collect::<BTreeSet<usize>>()
        .into_iter()
        .collect();
    let integrals: Vec<[f64; 4]> = facets
        .par_iter()
        .map(|&f| test_integrals(slave, test, x, f, strace))
        .collect();
    let support = |i: usize| -> f64 {
        ring.facets(i)
            .iter()
            .map(|&(f, c)| integrals[facets.binary_search(&f).unwrap_or(0)][c])
            .sum()
    };
    Ok(sums
        .into_par_iter()
        .map(|(node, sum)| {
            let i = index(node);
            let normal = normals.get(&node).copied();
            finish(
                slave,
                &ring,
                x,
                (node, i, normal),
                support(i),
                sum,
                derivatives,
            )
        })
        .collect())
}

/// The weighted gap of `node` (of index `i` in `slave.nodes`, nodal
/// normal `normal` if known, support integral `area`) from its pairs'
/// sums: `g_j = n_j . V_j` and the chain rule of the module docs.
fn finish(
    slave: &ContactSurface,
    ring: &NodeRing,
    x: &[[f64; 3]],
    (node, i, normal): (usize, usize, Option<Vector3<f64>>),
    area: f64,
    sum: Sum,
    derivatives: Derivatives,
) -> WeightedGap {
    let mut gap = WeightedGap {
        node,
        gap: 0.0,
        area,
        normal: [0.0; 3],
        d: sum.d.iter().map(|(&k, &v)| (k, v)).collect(),
        m: sum.m.iter().map(|(&k, &v)| (k, v)).collect(),
        gradient: Vec::new(),
        hessian: None,
    };
    if derivatives == Derivatives::Value {
        let n = normal.unwrap_or_else(|| nodal_normal(slave, ring, i, x));
        gap.gap = n.dot(&sum.v);
        gap.normal = n.into();
        return gap;
    }
    if derivatives == Derivatives::Mortar {
        let nd = normal_derivatives(slave, ring, i, x, false);
        let n = nd.normal;
        gap.gap = n.dot(&sum.v);
        gap.normal = n.into();
        let mut grad: BTreeMap<usize, f64> = BTreeMap::new();
        for (&k, &dk) in &sum.d {
            for c in 0..3 {
                *grad.entry(3 * k + c).or_default() -= dk * n[c];
            }
        }
        for (&l, &ml) in &sum.m {
            for c in 0..3 {
                *grad.entry(3 * l + c).or_default() += ml * n[c];
            }
        }
        for r in 0..3 * nd.nodes.len() {
            *grad.entry(nd.dof(r)).or_default() +=
                (0..3).map(|c| sum.v[c] * nd.jacobian[(c, r)]).sum::<f64>();
        }
        gap.gradient = grad.into_iter().collect();
        return gap;
    }
    let nd = normal_derivatives(slave, ring, i, x, derivatives == Derivatives::Hessian);
    let n = nd.normal;
    gap.gap = n.dot(&sum.v);
    gap.normal = n.into();
    // dg = n . dV + V . dn over the union of the pairs' and the ring's dofs.
    let mut grad: BTreeMap<usize, f64> = sum
        .dv
        .iter()
        .map(|(&dof, dv)| (dof, (0..3).map(|c| n[c] * dv[c]).sum()))
        .collect();
    let ring_dofs: Vec<usize> = (0..3 * nd.nodes.len()).map(|d| nd.dof(d)).collect();
    for (r, &dof) in ring_dofs.iter().enumerate() {
        *grad.entry(dof).or_default() +=
            (0..3).map(|c| sum.v[c] * nd.jacobian[(c, r)]).sum::<f64>();
    }
    if let Some(hn) = &nd.hessian {
        let dofs: Vec<usize> = grad.keys().copied().collect();
        let size = dofs.len();
        let at = |dof: usize| dofs.binary_search(&dof).unwrap_or(0);
        let mut h = vec![0.0; size * size];
        for (&(a, b), hv) in &sum.hv {
            h[at(a) * size + at(b)] += (0..3).map(|c| n[c] * hv[c]).sum::<f64>();
        }
        for (r, &a) in ring_dofs.iter().enumerate() {
            for (q, &b) in ring_dofs.iter().enumerate() {
                h[at(a) * size + at(b)] += (0..3).map(|c| sum.v[c] * hn[c][(r, q)]).sum::<f64>();
            }
            for (&b, dv) in &sum.dv {
                let cross: f64 = (0..3).map(|c| nd.jacobian[(c, r)] * dv[c]).sum();
                h[at(a) * size + at(b)] += cross;
                h[at(b) * size + at(a)] += cross;
            }
        }
        gap.hessian = Some(HessianBlock { dofs, values: h });
    }
    gap.gradient = grad.into_iter().collect();
    gap
}

/// `int_e Phi_j dA` of facet `f`'s test functions by its rule in the
/// coordinates `x` (`A_j` sums them over the facets at `j`).
fn test_integrals(
    slave: &ContactSurface,
    test: &SurfaceTestFunctions,
    x: &[[f64; 3]],
    f: usize,
    trace: Trace,
) -> [f64; 4] {
    let facet = Facet::of_surface(slave, f, x);
    let rule = element_rule(trace);
    std::array::from_fn(|c| {
        rule.iter()
            .map(|&(xi, w)| w * test.facets[f].eval(&trace.shape(xi))[c] * facet.jacobian(xi))
            .sum::<f64>()
    })
}
