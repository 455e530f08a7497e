//! Mortar particle contact: the augmented Lagrangian on weighted gaps.
//!
//! Each pair of particle surfaces is measured both ways (two passes, each
//! with weight `w = 1/2`, so that identical particles are treated alike).
//! For a slave node `j` of one surface against another surface, its
//! weighted gap `g_j` and the integral `A_j` of its test function
//! ([`super::weighted_gaps`]) give its mean penetration
//!
//! ```text
//! p_hat_j = -g_j / A_j + o_j                       [mm]   (> 0 penetrating)
//! ```
//!
//! (`o_j` a gap closed at the start, see [`MortarContact::close_initial_gaps`]),
//! its pressure `p_j = <lambda_j + eps p_hat_j>` \[MPa\] (`lambda_j` the
//! multiplier, `eps` the penalty, `<x> = max(x, 0)`) and the energy
//!
//! ```text
//! Pi_j = w A_j / (2 eps) <lambda_j + eps p_hat_j>^2        [N mm]
//! ```
//!
//! with `A_j` frozen for the step (at its start). Its gradient is the contact force
//! `f = -w p_j dg_j/du` and its Hessian where `p_j > 0`
//!
//! ```text
//! K = w (eps / A_j) dg_j/du (x) dg_j/du  -  w p_j d2g_j/du2
//! ```
//!
//! The first part is symmetric and positive semi-definite; the second,
//! the curvature of the gap, is indefinite and left out by default
//! ([`crate::ContactSettings::curvature_stiffness`]): on flat contact it
//! vanishes, and it scales with the pressure over the penalty.
//!
//! Which nodes press is read off `lambda_j + eps p_hat_j` at every
//! evaluation: the active set is decided inside Newton (a semi-smooth
//! Newton on the penalised problem), and the multipliers move to the
//! pressures between solves (Uzawa, [`MortarContact::augment`]). The gap is
//! a continuous, piecewise smooth function of the nodes' positions: a
//! master facet enters a node's support with zero overlap, so no node
//! ever switches from one facet to another. Nothing is paired: the
//! candidate facet pairs (a broad phase grown by the search distance) are
//! remade at the start of each step and at convergence, and a pair that
//! does not overlap brings nothing.

use std::collections::{BTreeMap, BTreeSet};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{
    Derivatives, MortarError, SurfaceTestFunctions, TestBasis, WeightedGap, candidate_pairs,
    weighted_gaps, weighted_gaps_of,
};
use crate::{ContactEvaluation, ContactMode, ContactSettings, ContactSurface, ContactTerm};

/// A slave node's weighted gap read against its state
/// ([`MortarContact::reading`]).
struct Reading {
    /// The node's index in its surface.
    k: usize,
    /// `A_j` \[mm^2\].
    area: f64,
    /// `p_hat_j` \[mm\].
    penetration: f64,
    /// `p_j` \[MPa\].
    pressure: f64,
}

/// The weight of each of the two passes over a pair of surfaces.
const PASS_WEIGHT: f64 = 0.5;

/// A node open by more than this fraction of the search distance, without
/// pressure, has no term (it is clearly apart).
const NEAR_BAND: f64 = crate::NEAR_BAND;

/// The master surface of a mortar term: its facet is not one facet.
pub const ANY_FACET: usize = usize::MAX;

/// The state of one slave node against one master surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
struct NodeState {
    /// Pressure multiplier \[MPa\].
    lambda: f64,
    /// Gap closed at the start \[mm\] (added to the penetration).
    offset: f64,
}

impl NodeState {
    fn carries(&self) -> bool {
        self.lambda != 0.0 || self.offset != 0.0
    }
}

/// The key of a node state: slave surface, node index in it, master surface.
type Key = (usize, usize, usize);

/// The state of a [`MortarContact`] that a run carries from step to step.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MortarCheckpoint {
    state: Vec<(Key, NodeState)>,
}

impl MortarCheckpoint {
    /// How many node-surface pairs carry a multiplier or an offset.
    pub fn len(&self) -> usize {
        self.state.len()
    }

    pub fn is_empty(&self) -> bool {
        self.state.is_empty()
    }
}

/// The candidate facet pairs of one pass: slave surface, master surface.
#[derive(Clone, Debug, PartialEq)]
struct Pass {
    slave: usize,
    master: usize,
    pairs: Vec<(usize, usize)>,
}

/// Mortar contact among particle surfaces (module docs).
#[derive(Clone, Debug)]
pub struct MortarContact {
    surfaces: Vec<ContactSurface>,
    settings: ContactSettings,
    basis: TestBasis,
    state: BTreeMap<Key, NodeState>,
    /// The passes of the step, from [`MortarContact::pair`].
    passes: Vec<Pass>,
    /// Test functions of each slave surface, frozen at the step's start.
    tests: Vec<Option<SurfaceTestFunctions>>,
    /// The (slave, master) surfaces that pressed when the step started.
    pressed_at_start: BTreeSet<(usize, usize)>,
    /// The covered part of each node's support when the step started, the
    /// `A_j` of the module docs \[mm^2\]: frozen, so that the force is the
    /// gradient of the energy and the tangent its Hessian (read afresh,
    /// a node closed at the start, whose gap `g_j / A_j` is its offset,
    /// had a force 6 % off the gradient on bcc at level 1).
    areas: BTreeMap<Key, f64>,
}

/// The part of a node's support the master surface covers, `sum_k D_jk =
/// int_covered Phi_j dA` \[mm^2\]: its mean gap is `g_j` over it (MOOSE's
/// normalisation), not over the whole support, whose uncovered part would
/// read as closed (a far facet overlapping a corner of the support read
/// 1.7e-5 mm "open" on bcc, 4 % of its true gap).
fn covered(g: &WeightedGap) -> f64 {
    g.d.iter().map(|&(_, v)| v).sum()
}

fn points(x: &[f64]) -> Vec<[f64; 3]> {
    x.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()
}

impl MortarContact {
    /// Mortar contact among `surfaces` (one per particle, then their
    /// periodic images, which are masters only), with test functions
    /// `basis`. Tied contact is not offered.
    pub fn new(
        surfaces: Vec<ContactSurface>,
        settings: ContactSettings,
        basis: TestBasis,
    ) -> Result<Self, crate::ContactError> {
        if settings.mode != ContactMode::Frictionless {
            return Err(crate::ContactError::Surface(
                "mortar contact is frictionless only: tied contact is node to facet".into(),
            ));
        }
        let n = surfaces.len();
        Ok(Self {
            surfaces,
            settings,
            basis,
            state: BTreeMap::new(),
            passes: Vec::new(),
            tests: vec![None; n],
            pressed_at_start: BTreeSet::new(),
            areas: BTreeMap::new(),
        })
    }

    pub fn surfaces(&self) -> &[ContactSurface] {
        &self.surfaces
    }

    pub fn settings(&self) -> &ContactSettings {
        &self.settings
    }

    /// Whether two surfaces' boxes come within the search distance.
    fn near(&self, a: usize, b: usize, x: &[[f64; 3]]) -> bool {
        let bounds = |s: &ContactSurface| {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &n in &s.nodes {
                for c in 0..3 {
                    lo[c] = lo[c].min(x[n][c]);
                    hi[c] = hi[c].max(x[n][c]);
                }
            }
            (lo, hi)
        };
        let ((la, ha), (lb, hb)) = (bounds(&self.surfaces[a]), bounds(&self.surfaces[b]));
        let d = self.settings.search_distance;
        (0..3).all(|c| la[c] <= hb[c] + d && lb[c] <= ha[c] + d)
    }

    /// The passes and their candidate facet pairs in the configuration `x`.
    fn passes_at(&self, x: &[[f64; 3]]) -> Vec<Pass> {
        let n = self.surfaces.len();
        let work: Vec<(usize, usize)> = (0..n)
            .filter(|&s| !self.surfaces[s].master_only)
            .flat_map(|s| (0..n).filter(move |&m| m != s).map(move |m| (s, m)))
            .filter(|&(s, m)| self.near(s, m, x))
            .collect();
        work.par_iter()
            .map(|&(s, m)| Pass {
                slave: s,
                master: m,
                pairs: candidate_pairs(
                    &self.surfaces[s],
                    &self.surfaces[m],
                    x,
                    self.settings.search_distance,
                ),
            })
            .filter(|p| !p.pairs.is_empty())
            .collect()
    }

    /// At the start of a step, in the configuration `x`: the candidate
    /// facet pairs and the test functions for the step.
    pub fn pair(&mut self, x: &[f64]) {
        let x = points(x);
        self.passes = self.passes_at(&x);
        for pass in &self.passes {
            if self.tests[pass.slave].is_none() || self.basis == TestBasis::Dual {
                self.tests[pass.slave] = Some(SurfaceTestFunctions::new(
                    &self.surfaces[pass.slave],
                    &x,
                    self.basis,
                ));
            }
        }
        self.pressed_at_start = self
            .state
            .iter()
            .filter(|(_, st)| st.lambda > 0.0)
            .map(|(&(s, _, m), _)| (s, m))
            .collect();
        self.areas = self
            .gaps(&x, Derivatives::Value)
            .into_iter()
            .filter_map(|(s, m, g)| {
                let k = self.surfaces[s].nodes.binary_search(&g.node).ok()?;
                Some(((s, k, m), covered(&g)))
            })
            .collect();
    }

    /// The `A_j` of the node `key` whose weighted gap is `g`: the one
    /// frozen at the step's start, or (a node with no candidate pair then)
    /// its covered area now.
    fn area(&self, key: Key, g: &WeightedGap) -> f64 {
        self.areas.get(&key).copied().unwrap_or_else(|| covered(g))
    }

    /// At a converged state `x`: the candidate pairs remade; returns how
    /// many node-surface pairs press that had no term before (Newton must
    /// go on if any).
    pub fn repair(&mut self, x: &[f64]) -> usize {
        let before: BTreeSet<(usize, usize)> = self
            .passes
            .iter()
            .flat_map(|p| p.pairs.iter().map(move |&(sf, _)| (p.slave, sf)))
            .collect();
        let old = self.passes.clone();
        self.pair(x);
        if self.passes == old {
            return 0;
        }
        // Only slave facets new to the candidates can bring new pressure.
        let eval = self.evaluate(x, false);
        eval.terms
            .iter()
            .filter(|t| t.pressure > 0.0)
            .filter(|t| {
                let s = t.slave.0;
                let node = self.surfaces[s].nodes[t.slave.1];
                self.surfaces[s]
                    .facets
                    .iter()
                    .enumerate()
                    .filter(|(_, f)| f.contains(&node))
                    .all(|(sf, _)| !before.contains(&(s, sf)))
            })
            .count()
    }

    /// Between Newton iterations: nothing to pair afresh (the weighted gaps
    /// need no links); never a change.
    pub fn relink(&mut self, _x: &[f64]) -> bool {
        false
    }

    /// What the weighted gap `g` of a node of slave surface `s` on master
    /// surface `m` reads as: the node's index in `s`, its area `A_j`, mean
    /// penetration and pressure (module docs); None where it covers
    /// nothing.
    fn reading(&self, s: usize, m: usize, g: &WeightedGap) -> Option<Reading> {
        let k = self.surfaces[s].nodes.binary_search(&g.node).ok()?;
        let area = self.area((s, k, m), g);
        if !(area > 0.0) {
            return None;
        }
        let st = self.node_state((s, k, m));
        let penetration = -g.gap / area + st.offset;
        Some(Reading {
            k,
            area,
            penetration,
            pressure: (st.lambda + self.settings.penalty * penetration).max(0.0),
        })
    }

    fn node_state(&self, key: Key) -> NodeState {
        self.state.get(&key).copied().unwrap_or_default()
    }

    /// The weighted gaps of every pass in the configuration `x`.
    fn gaps(&self, x: &[[f64; 3]], derivatives: Derivatives) -> Vec<(usize, usize, WeightedGap)> {
        self.passes
            .par_iter()
            .filter_map(|pass| {
                let test = self.tests[pass.slave].as_ref()?;
                let gaps = weighted_gaps(
                    &self.surfaces[pass.slave],
                    &self.surfaces[pass.master],
                    x,
                    &pass.pairs,
                    test,
                    derivatives,
                );
                Some(gaps.map(|g| (pass.slave, pass.master, g)))
            })
            .collect::<Vec<Result<_, MortarError>>>()
            .into_iter()
            .filter_map(Result::ok)
            .flat_map(|(s, m, gaps)| gaps.into_iter().map(move |g| (s, m, g)))
            .collect()
    }

    /// The weighted gaps of every node with a term (module docs): values
    /// for all of them, and exact gradients (forward-mode differentiation
    /// of the segments) for those that bring a force or a stiffness (the
    /// pressed nodes, and the nodes near a pair of surfaces that presses
    /// nowhere yet), which are a few of those within the band.
    fn gaps_for_terms(&self, x: &[[f64; 3]]) -> Vec<(usize, usize, WeightedGap)> {
        let band = -NEAR_BAND * self.settings.search_distance;
        let values = self.gaps(x, Derivatives::Value);
        let pressed: BTreeSet<(usize, usize)> = values
            .iter()
            .filter(|(s, m, g)| self.reading(*s, *m, g).is_some_and(|r| r.pressure > 0.0))
            .map(|(s, m, _)| (*s, *m))
            .collect();
        // The nodes (global ids) whose gradient is needed, by pass.
        let mut needed: BTreeMap<(usize, usize), BTreeSet<usize>> = BTreeMap::new();
        for (s, m, g) in &values {
            if let Some(r) = self.reading(*s, *m, g)
                && (r.pressure > 0.0 || (r.penetration > band && !pressed.contains(&(*s, *m))))
            {
                needed.entry((*s, *m)).or_default().insert(g.node);
            }
        }
        let exact: BTreeMap<(usize, usize, usize), WeightedGap> = self
            .passes
            .par_iter()
            .filter_map(|pass| {
                let nodes = needed.get(&(pass.slave, pass.master))?;
                let test = self.tests[pass.slave].as_ref()?;
                let slave = &self.surfaces[pass.slave];
                let pairs: Vec<(usize, usize)> = pass
                    .pairs
                    .iter()
                    .copied()
                    .filter(|&(sf, _)| slave.facets[sf].iter().any(|n| nodes.contains(n)))
                    .collect();
                let gaps = weighted_gaps_of(
                    slave,
                    &self.surfaces[pass.master],
                    x,
                    &pairs,
                    test,
                    Derivatives::Gradient,
                    nodes,
                )
                .ok()?;
                Some(
                    gaps.into_iter()
                        .filter(|g| nodes.contains(&g.node))
                        .map(|g| ((pass.slave, pass.master, g.node), g))
                        .collect::<Vec<_>>(),
                )
            })
            .flatten()
            .collect();
        values
            .into_iter()
            .map(|(s, m, g)| match exact.get(&(s, m, g.node)) {
                Some(e) => (s, m, e.clone()),
                None => (s, m, g),
            })
            .collect()
    }

    /// The contact terms in the configuration `x` \[mm\], with tangents if
    /// asked (module docs).
    pub fn evaluate(&self, x: &[f64], with_tangent: bool) -> ContactEvaluation {
        let x = points(x);
        let eps = self.settings.penalty;
        let band = -NEAR_BAND * self.settings.search_distance;
        let gaps = self.gaps_for_terms(&x);
        let mut terms: Vec<ContactTerm> = gaps
            .into_par_iter()
            .filter_map(|(s, m, g)| {
                let Reading {
                    k,
                    area,
                    penetration,
                    pressure,
                } = self.reading(s, m, &g)?;
                if pressure <= 0.0 && penetration <= band {
                    return None;
                }
                let dofs: Vec<usize> = g.gradient.iter().map(|&(d, _)| d).collect();
                let force = g
                    .gradient
                    .iter()
                    .map(|&(_, dg)| -PASS_WEIGHT * pressure * dg)
                    .collect();
                let stiffness = if pressure > 0.0 {
                    eps
                } else {
                    self.touch_stiffness(s, m)
                };
                let tangent = if with_tangent {
                    let c = PASS_WEIGHT * stiffness / area;
                    g.gradient
                        .iter()
                        .flat_map(|&(_, a)| g.gradient.iter().map(move |&(_, b)| c * a * b))
                        .collect()
                } else {
                    Vec::new()
                };
                Some(ContactTerm {
                    dofs,
                    force,
                    tangent,
                    pressure,
                    penetration,
                    slave: (s, k),
                    master: (m, ANY_FACET),
                    location: [0.0; 2],
                    fold: None,
                })
            })
            .collect();
        // Once a pair of surfaces presses somewhere it holds itself: the
        // touch stiffness (which the force does not have) would only slow
        // Newton near the edge of the contact patch.
        let pressed: BTreeSet<(usize, usize)> = terms
            .iter()
            .filter(|t| t.pressure > 0.0)
            .map(|t| (t.slave.0, t.master.0))
            .collect();
        for t in &mut terms {
            if t.pressure <= 0.0 && pressed.contains(&(t.slave.0, t.master.0)) {
                t.tangent.fill(0.0);
            }
        }
        if with_tangent && self.settings.curvature_stiffness {
            self.curvature_terms(&x, &mut terms);
        }
        ContactEvaluation { terms }
    }

    /// The stiffness \[MPa/mm\] an unpressed node near the other surface
    /// brings to the tangent while its pair of surfaces presses nowhere:
    /// it holds a body that hangs on a contact about to close.
    fn touch_stiffness(&self, _s: usize, _m: usize) -> f64 {
        (crate::TOUCH_STIFFNESS * self.settings.penalty).min(self.settings.touch_stiffness_cap)
    }

    /// Uzawa: every evaluated node's multiplier takes its pressure; nodes
    /// not evaluated lose theirs. Returns the largest penetration.
    pub fn augment(&mut self, eval: &ContactEvaluation) -> f64 {
        let evaluated: BTreeSet<Key> = eval
            .terms
            .iter()
            .map(|t| (t.slave.0, t.slave.1, t.master.0))
            .collect();
        for t in &eval.terms {
            let key = (t.slave.0, t.slave.1, t.master.0);
            if t.pressure > 0.0 || self.node_state(key).lambda > 0.0 {
                self.state.entry(key).or_default().lambda = t.pressure;
            }
        }
        for (key, st) in self.state.iter_mut() {
            if !evaluated.contains(key) {
                st.lambda = 0.0;
            }
        }
        self.state.retain(|_, st| st.carries());
        eval.max_penetration()
    }

    /// The mean gap `g_j / A_j` \[mm\] (> 0 open) of every slave node with
    /// a candidate pair in the configuration `x`: (slave surface, node
    /// index, master surface, gap), after [`MortarContact::pair`].
    pub fn mean_gaps(&self, x: &[f64]) -> Vec<(usize, usize, usize, f64)> {
        self.gaps(&points(x), Derivatives::Value)
            .into_iter()
            .filter(|(_, _, g)| covered(g) > 0.0)
            .filter_map(|(s, m, g)| {
                let k = self.surfaces[s].nodes.binary_search(&g.node).ok()?;
                Some((s, k, m, g.gap / covered(&g)))
            })
            .collect()
    }

    /// Closes, in the configuration `x`, the mean gaps of the nodes
    /// `touching` (slave surface, node index, master surface): each reads
    /// its gap as closed from then on (an offset added to its
    /// penetration). Returns how many it closed.
    pub fn close_touching(&mut self, x: &[f64], touching: &BTreeSet<Key>) -> usize {
        self.pair(x);
        let gaps = self.gaps(&points(x), Derivatives::Value);
        let mut closed = 0;
        for (s, m, g) in gaps {
            let Ok(k) = self.surfaces[s].nodes.binary_search(&g.node) else {
                continue;
            };
            let area = covered(&g);
            if area > 0.0 && g.gap > 0.0 && touching.contains(&(s, k, m)) {
                self.state.entry((s, k, m)).or_default().offset += g.gap / area;
                closed += 1;
            }
        }
        closed
    }

    /// The dofs a term couples in the tangent over the step: its own and
    /// those of every master facet that is a candidate of its slave
    /// node's facets (so that sliding within the step needs no new
    /// sparsity pattern).
    pub fn coupling_dofs(&self, term: &ContactTerm) -> Vec<usize> {
        let (s, k) = term.slave;
        let m = term.master.0;
        let node = self.surfaces[s].nodes[k];
        let mut dofs = term.dofs.clone();
        for pass in self.passes.iter().filter(|p| p.slave == s && p.master == m) {
            for &(sf, mf) in &pass.pairs {
                if self.surfaces[s].facets[sf].contains(&node) {
                    for &n in &self.surfaces[m].facets[mf] {
                        dofs.extend([3 * n, 3 * n + 1, 3 * n + 2]);
                    }
                }
            }
        }
        dofs.sort_unstable();
        dofs.dedup();
        dofs
    }

    pub fn checkpoint(&self) -> MortarCheckpoint {
        MortarCheckpoint {
            state: self.state.iter().map(|(&k, &v)| (k, v)).collect(),
        }
    }

    /// Takes the state of a checkpoint of the same surfaces.
    pub fn restore_checkpoint(&mut self, c: &MortarCheckpoint) -> Result<(), crate::ContactError> {
        let fits = c.state.iter().all(|&((s, k, m), _)| {
            s < self.surfaces.len() && m < self.surfaces.len() && k < self.surfaces[s].nodes.len()
        });
        if !fits {
            return Err(crate::ContactError::Surface(
                "a checkpoint of other contact surfaces".into(),
            ));
        }
        self.state = c.state.iter().copied().collect();
        Ok(())
    }
}

/// The consistent tangent's curvature part and the energy (module docs).
impl MortarContact {
    /// The candidate pairs of `pass` whose slave facet holds one of
    /// `nodes` (global ids): all that bring anything to their gaps.
    fn pairs_at(&self, pass: &Pass, nodes: &BTreeSet<usize>) -> Vec<(usize, usize)> {
        let slave = &self.surfaces[pass.slave];
        pass.pairs
            .iter()
            .copied()
            .filter(|&(sf, _)| slave.facets[sf].iter().any(|n| nodes.contains(n)))
            .collect()
    }

    /// Adds the curvature part `-w p_j d2g_j/du2` of the module docs to
    /// the tangent of every pressed term among `terms` (evaluated in `x`
    /// with tangents): the Hessians of their gaps by forward-mode
    /// differentiation ([`Derivatives::Hessian`]), the terms' dofs grown
    /// to the union of their gradients' and Hessians' dofs (their forces
    /// zero on the new ones). Costly: on the two domes of
    /// `tests/mortar_tangent.rs` (9 pressed nodes) an evaluation with
    /// tangents took 0.6 s on triangles and 1.5 s on quads with it, 5 ms
    /// without.
    fn curvature_terms(&self, x: &[[f64; 3]], terms: &mut [ContactTerm]) {
        let mut pressed: BTreeMap<(usize, usize), BTreeSet<usize>> = BTreeMap::new();
        for t in terms.iter().filter(|t| t.pressure > 0.0) {
            let (s, k) = t.slave;
            pressed
                .entry((s, t.master.0))
                .or_default()
                .insert(self.surfaces[s].nodes[k]);
        }
        let hessians: BTreeMap<(usize, usize, usize), super::HessianBlock> = self
            .passes
            .par_iter()
            .filter_map(|pass| {
                let nodes = pressed.get(&(pass.slave, pass.master))?;
                let test = self.tests[pass.slave].as_ref()?;
                let gaps = weighted_gaps_of(
                    &self.surfaces[pass.slave],
                    &self.surfaces[pass.master],
                    x,
                    &self.pairs_at(pass, nodes),
                    test,
                    Derivatives::Hessian,
                    nodes,
                )
                .ok()?;
                Some(
                    gaps.into_iter()
                        .filter_map(|g| Some(((pass.slave, pass.master, g.node), g.hessian?)))
                        .collect::<Vec<_>>(),
                )
            })
            .flatten()
            .collect();
        terms
            .par_iter_mut()
            .filter(|t| t.pressure > 0.0)
            .for_each(|t| {
                let (s, k) = t.slave;
                let key = (s, t.master.0, self.surfaces[s].nodes[k]);
                if let Some(h) = hessians.get(&key) {
                    add_curvature(t, h, -PASS_WEIGHT * t.pressure);
                }
            });
    }

    /// The contact energy `sum_j Pi_j` \[N mm\] (module docs) in the
    /// configuration `x` \[mm\], on the step's candidate pairs and frozen
    /// areas (after [`MortarContact::pair`]): the contact forces of
    /// [`MortarContact::evaluate`] are its gradient.
    pub fn energy(&self, x: &[f64]) -> f64 {
        let eps = self.settings.penalty;
        self.gaps(&points(x), Derivatives::Value)
            .into_iter()
            .filter_map(|(s, m, g)| {
                let r = self.reading(s, m, &g)?;
                Some(PASS_WEIGHT * r.area / (2.0 * eps) * r.pressure * r.pressure)
            })
            .sum()
    }
}

/// `c h` added to the tangent of the term `t`, its dofs grown to take in
/// those of `h`.
fn add_curvature(t: &mut ContactTerm, h: &super::HessianBlock, c: f64) {
    let mut dofs = t.dofs.clone();
    dofs.extend(&h.dofs);
    dofs.sort_unstable();
    dofs.dedup();
    let n = dofs.len();
    let at = |d: usize| dofs.binary_search(&d).unwrap_or(0);
    let old: Vec<usize> = t.dofs.iter().map(|&d| at(d)).collect();
    let mut tangent = vec![0.0; n * n];
    let mut force = vec![0.0; n];
    for (p, &i) in old.iter().enumerate() {
        force[i] = t.force[p];
        for (q, &j) in old.iter().enumerate() {
            tangent[i * n + j] = t.tangent[p * old.len() + q];
        }
    }
    let size = h.dofs.len();
    let new: Vec<usize> = h.dofs.iter().map(|&d| at(d)).collect();
    for (a, &i) in new.iter().enumerate() {
        for (b, &j) in new.iter().enumerate() {
            tangent[i * n + j] += c * h.values[a * size + b];
        }
    }
    t.dofs = dofs;
    t.force = force;
    t.tangent = tangent;
}
