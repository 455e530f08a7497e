//! Contact between particle surfaces (DESIGN.md section 5), units mm, N, MPa.
//!
//! [`ParticleContact`] (the entry type) holds the surfaces of the particles
//! of a scene and enforces frictionless (or tied) contact between them:
//!
//! - detection with parry (`parry3d-f64`): each surface is triangulated in its
//!   current configuration and the nodes of one surface are projected onto the
//!   other's `TriMesh`, only for pairs of surfaces whose bounding boxes meet;
//! - enforcement node to surface, both ways (two-pass, each pass carrying half
//!   the tributary area so that identical particles are treated alike), by an
//!   augmented Lagrangian: the energy of a slave node of tributary area `A` is
//!   `w A / (2 eps) <lambda + eps p>^2` with `p` its penetration into the plane
//!   of the master triangle, `lambda` its contact pressure multiplier and
//!   `<x> = max(x, 0)`. Its gradient is the contact force, its Hessian the
//!   consistent tangent (symmetric), both exact: the penetration is written
//!   once, generic over dual numbers, and differentiated by `num-dual`.
//!   Between Newton solves, [`ParticleContact::augment`] updates the
//!   multipliers (Uzawa) until the penetration is below its tolerance.

mod error;
mod gap;
mod surface;

pub use error::ContactError;
pub use gap::{penetration, tie_gap};
pub use surface::ContactSurface;

use nalgebra::{SMatrix, SVector};
use num_dual::{Dual2SVec64, hessian};
use parry3d_f64::math::Vector as PVector;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::TriMesh;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How closed contacts behave.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ContactMode {
    /// Frictionless sliding; contacts open when the pressure would be tensile.
    Frictionless,
    /// No sliding once closed: a node that touches stays tied to the material
    /// point of the other surface it touched (it can carry tension and shear).
    Tied,
}

/// Settings of particle contact.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactSettings {
    pub mode: ContactMode,
    /// Penalty stiffness eps [MPa/mm].
    pub penalty: f64,
    /// Search distance: nodes farther than this from the other surface are
    /// not candidates [mm].
    pub search_distance: f64,
}

/// One slave node's link to a master triangle, with its contribution.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactTerm {
    /// Body dofs: the slave node's three, then the master triangle's nine.
    pub dofs: [usize; 12],
    /// Contribution to the internal force [N].
    pub force: [f64; 12],
    /// Consistent tangent, row-major 12x12 [N/mm] (empty if not requested).
    pub tangent: Vec<f64>,
    /// Contact pressure at the slave node [MPa].
    pub pressure: f64,
    /// Penetration of the slave node (negative: a gap) [mm].
    pub penetration: f64,
    /// Slave surface and index of the node in it.
    pub slave: (usize, usize),
    /// Master surface and triangle.
    pub master: (usize, usize),
    /// Barycentric coordinates of the slave's projection on the master
    /// triangle's plane.
    pub location: [f64; 3],
}

/// Saved multiplier state: per surface, per node (lambda, tie, tie lambda).
pub type StateSnapshot = Vec<Vec<(f64, Option<(usize, usize, [f64; 3])>, [f64; 3])>>;

/// Multiplier state of one slave node of one pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
struct NodeState {
    /// Normal pressure multiplier [MPa] (frictionless).
    lambda: f64,
    /// Tied: the master surface, triangle and barycentric point, and the
    /// vector multiplier [MPa].
    tie: Option<(usize, usize, [f64; 3])>,
    tie_lambda: [f64; 3],
}

/// Contact between the surfaces of a scene's particles.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ParticleContact {
    surfaces: Vec<ContactSurface>,
    settings: ContactSettings,
    /// Per surface, per node: the state of its pass as slave.
    state: Vec<Vec<NodeState>>,
    /// Per surface, per node: the master (surface, triangle) it is paired
    /// with for the current step (see [`ParticleContact::pair`]).
    #[serde(skip)]
    pairing: Vec<Vec<Option<(usize, usize)>>>,
}

/// The contact contributions at one configuration.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactEvaluation {
    pub terms: Vec<ContactTerm>,
}

impl ContactEvaluation {
    /// Largest penetration of any slave node into a master surface [mm].
    pub fn max_penetration(&self) -> f64 {
        self.terms.iter().map(|t| t.penetration).fold(0.0, f64::max)
    }
}

fn point(x: &[f64], node: usize) -> [f64; 3] {
    [x[3 * node], x[3 * node + 1], x[3 * node + 2]]
}

impl ParticleContact {
    /// Contact among `surfaces` (one per particle).
    pub fn new(
        surfaces: Vec<ContactSurface>,
        settings: ContactSettings,
    ) -> Result<Self, ContactError> {
        if !(settings.penalty > 0.0 && settings.penalty.is_finite()) {
            return Err(ContactError::Parameter {
                name: "penalty",
                value: settings.penalty,
                allowed: "> 0 MPa/mm",
            });
        }
        if !(settings.search_distance > 0.0 && settings.search_distance.is_finite()) {
            return Err(ContactError::Parameter {
                name: "search_distance",
                value: settings.search_distance,
                allowed: "> 0 mm",
            });
        }
        let state = surfaces
            .iter()
            .map(|s| vec![NodeState::default(); s.nodes.len()])
            .collect();
        let pairing = surfaces.iter().map(|s| vec![None; s.nodes.len()]).collect();
        Ok(Self {
            surfaces,
            settings,
            state,
            pairing,
        })
    }

    pub fn surfaces(&self) -> &[ContactSurface] {
        &self.surfaces
    }

    pub fn settings(&self) -> &ContactSettings {
        &self.settings
    }

    /// Ordered pairs (slave, master) of surfaces whose bounding boxes,
    /// grown by the search distance, overlap in the configuration `x`.
    pub fn candidate_pairs(&self, x: &[f64]) -> Vec<(usize, usize)> {
        let boxes: Vec<([f64; 3], [f64; 3])> =
            self.surfaces.iter().map(|s| s.bounding_box(x)).collect();
        let d = self.settings.search_distance;
        let mut pairs = Vec::new();
        for i in 0..boxes.len() {
            for j in 0..boxes.len() {
                if i == j {
                    continue;
                }
                let (a, b) = (&boxes[i], &boxes[j]);
                let overlap = (0..3).all(|k| a.0[k] - d <= b.1[k] && b.0[k] - d <= a.1[k]);
                if overlap {
                    pairs.push((i, j));
                }
            }
        }
        pairs
    }

    /// Pairs every slave node with the master triangle nearest to it in the
    /// configuration `x` (within the search distance), for the coming step.
    /// Within a step a paired node keeps its triangle (its gap is measured to
    /// the triangle's plane), so the residual stays smooth while Newton
    /// iterates: switching facets between iterations would make it jump.
    pub fn pair(&mut self, x: &[f64]) {
        let pairs = self.candidate_pairs(x);
        let mut meshes: Vec<Option<TriMesh>> = vec![None; self.surfaces.len()];
        for &(_, m) in &pairs {
            if meshes[m].is_none() {
                meshes[m] = self.surfaces[m].trimesh(x);
            }
        }
        let mut best: Vec<Vec<Option<(usize, usize, f64)>>> = self
            .surfaces
            .iter()
            .map(|s| vec![None; s.nodes.len()])
            .collect();
        for &(s, m) in &pairs {
            let Some(mesh) = meshes[m].as_ref() else {
                continue;
            };
            let found: Vec<Option<(usize, f64)>> = (0..self.surfaces[s].nodes.len())
                .into_par_iter()
                .map(|k| self.nearest(x, s, k, mesh))
                .collect();
            for (k, f) in found.into_iter().enumerate() {
                if let Some((tri, dist)) = f
                    && best[s][k].is_none_or(|(_, _, d)| dist < d)
                {
                    best[s][k] = Some((m, tri, dist));
                }
            }
        }
        self.pairing = best
            .into_iter()
            .map(|v| {
                v.into_iter()
                    .map(|b| b.map(|(m, tri, _)| (m, tri)))
                    .collect()
            })
            .collect();
    }

    /// The triangle of `mesh` nearest to slave node `k` of surface `s`, and
    /// its distance, within the search distance.
    fn nearest(&self, x: &[f64], s: usize, k: usize, mesh: &TriMesh) -> Option<(usize, f64)> {
        let p = point(x, self.surfaces[s].nodes[k]);
        let q = PVector::new(p[0], p[1], p[2]);
        let (proj, (tri, _)) = mesh.project_local_point_and_get_location_with_max_dist(
            q,
            false,
            self.settings.search_distance,
        )?;
        Some((tri as usize, (proj.point - q).length()))
    }

    /// Contact terms at the configuration `x` (current node coordinates,
    /// `3 * node + i`), with tangents if asked. A paired node uses its
    /// triangle; an unpaired one is searched for on every surface whose box
    /// meets its own, and takes the nearest triangle.
    pub fn evaluate(&self, x: &[f64], with_tangent: bool) -> ContactEvaluation {
        let pairs = self.candidate_pairs(x);
        let mut masters: Vec<Vec<usize>> = vec![Vec::new(); self.surfaces.len()];
        for &(s, m) in &pairs {
            masters[s].push(m);
        }
        let paired = |s: usize, k: usize| {
            self.pairing
                .get(s)
                .and_then(|v| v.get(k).copied().flatten())
        };
        let mut meshes: Vec<Option<TriMesh>> = vec![None; self.surfaces.len()];
        for (s, ms) in masters.iter().enumerate() {
            if (0..self.surfaces[s].nodes.len()).any(|k| paired(s, k).is_none()) {
                for &m in ms {
                    if meshes[m].is_none() {
                        meshes[m] = self.surfaces[m].trimesh(x);
                    }
                }
            }
        }
        let work: Vec<(usize, usize)> = self
            .surfaces
            .iter()
            .enumerate()
            .flat_map(|(s, surface)| (0..surface.nodes.len()).map(move |k| (s, k)))
            .collect();
        let terms: Vec<ContactTerm> = work
            .par_iter()
            .filter_map(|&(s, k)| {
                let st = &self.state[s][k];
                if let Some((m, tri, bary)) = st.tie {
                    return Some(self.tied_term(
                        x,
                        s,
                        k,
                        m,
                        tri,
                        bary,
                        st.tie_lambda,
                        with_tangent,
                    ));
                }
                let (m, tri) = match paired(s, k) {
                    Some(p) => p,
                    None => masters[s]
                        .iter()
                        .filter_map(|&m| {
                            let (tri, d) = self.nearest(x, s, k, meshes[m].as_ref()?)?;
                            Some((m, tri, d))
                        })
                        .min_by(|a, b| a.2.total_cmp(&b.2))
                        .map(|(m, tri, _)| (m, tri))?,
                };
                self.node_term(x, s, k, m, tri, with_tangent)
            })
            .collect();
        ContactEvaluation { terms }
    }

    /// The term of slave node `k` of surface `s` against triangle `tri` of
    /// master surface `m`, if the node presses on it or nearly touches it.
    fn node_term(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        m: usize,
        tri: usize,
        with_tangent: bool,
    ) -> Option<ContactTerm> {
        let st = &self.state[s][k];
        let node = self.surfaces[s].nodes[k];
        let p = point(x, node);
        let t = self.surfaces[m].triangles[tri];
        let mut v = SVector::<f64, 12>::zeros();
        for i in 0..3 {
            v[i] = p[i];
        }
        for (c, &n) in t.iter().enumerate() {
            let q = point(x, n);
            for i in 0..3 {
                v[3 + 3 * c + i] = q[i];
            }
        }
        let area = 0.5 * self.surfaces[s].areas[k];
        let eps = self.settings.penalty;
        let (pen, grad, hess) = if with_tangent {
            let (f, g, h) = hessian(|w: SVector<Dual2SVec64<12>, 12>| penetration(&w), &v);
            (f, g, Some(h))
        } else {
            let (f, g) = gradient_of_penetration(&v);
            (f, g, None)
        };
        let pressure = (st.lambda + eps * pen).max(0.0);
        // A node near the surface without pressure (a gap below a tenth of
        // the search distance) still brings a thousandth of the penalty
        // stiffness to the tangent (not to the force), so that a body held
        // only by contacts about to close (a particle resting on another at a
        // point) is never free in a Newton iteration, while Newton's tangent
        // stays nearly consistent.
        let touching = pen > -0.1 * self.settings.search_distance;
        if pressure <= 0.0 && !touching {
            return None;
        }
        let mut dofs = [0; 12];
        for i in 0..3 {
            dofs[i] = 3 * node + i;
            for c in 0..3 {
                dofs[3 + 3 * c + i] = 3 * t[c] + i;
            }
        }
        let mut force = [0.0; 12];
        for (f, g) in force.iter_mut().zip(grad.iter()) {
            *f = area * pressure * g;
        }
        let tangent = match hess {
            Some(h) => {
                let stiffness = if pressure > 0.0 { eps } else { 1e-3 * eps };
                let k: SMatrix<f64, 12, 12> =
                    (grad * grad.transpose()) * (area * stiffness) + h * (area * pressure);
                k.transpose().as_slice().to_vec()
            }
            None => Vec::new(),
        };
        let location = gap::barycentric(&p, &t.map(|n| point(x, n)));
        Some(ContactTerm {
            dofs,
            force,
            tangent,
            pressure,
            penetration: pen,
            slave: (s, k),
            master: (m, tri),
            location,
        })
    }

    /// Term of a tied slave node: a vector penalty on the distance to its
    /// material point on the master triangle.
    #[allow(clippy::too_many_arguments)]
    fn tied_term(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        m: usize,
        tri: usize,
        bary: [f64; 3],
        lambda: [f64; 3],
        with_tangent: bool,
    ) -> ContactTerm {
        let node = self.surfaces[s].nodes[k];
        let t = self.surfaces[m].triangles[tri];
        let area = 0.5 * self.surfaces[s].areas[k];
        let eps = self.settings.penalty;
        let gap = tie_gap(&point(x, node), &t.map(|n| point(x, n)), &bary);
        let mut dofs = [0; 12];
        // d gap_i / d u: +1 for the slave, -N_c for master node c.
        let weights = [1.0, -bary[0], -bary[1], -bary[2]];
        for i in 0..3 {
            dofs[i] = 3 * node + i;
            for c in 0..3 {
                dofs[3 + 3 * c + i] = 3 * t[c] + i;
            }
        }
        let traction: [f64; 3] = [0, 1, 2].map(|i| lambda[i] + eps * gap[i]);
        let mut force = [0.0; 12];
        for a in 0..4 {
            for i in 0..3 {
                force[3 * a + i] = area * traction[i] * weights[a];
            }
        }
        let tangent = if with_tangent {
            let mut kmat = vec![0.0; 144];
            for a in 0..4 {
                for b in 0..4 {
                    for i in 0..3 {
                        kmat[(3 * a + i) * 12 + 3 * b + i] = area * eps * weights[a] * weights[b];
                    }
                }
            }
            kmat
        } else {
            Vec::new()
        };
        let norm = (gap[0] * gap[0] + gap[1] * gap[1] + gap[2] * gap[2]).sqrt();
        ContactTerm {
            dofs,
            force,
            tangent,
            pressure: traction.iter().map(|v| v * v).sum::<f64>().sqrt(),
            penetration: norm,
            slave: (s, k),
            master: (m, tri),
            location: bary,
        }
    }

    /// Uzawa update after a converged solve: the multipliers take the
    /// pressures of `eval` (and slave nodes not in it lose theirs). In tied
    /// mode, nodes in contact become tied to where they touch. Returns the
    /// largest penetration before the update [mm].
    pub fn augment(&mut self, x: &[f64], eval: &ContactEvaluation) -> f64 {
        let eps = self.settings.penalty;
        let mut active = vec![Vec::<bool>::new(); self.surfaces.len()];
        for (s, a) in active.iter_mut().enumerate() {
            *a = vec![false; self.surfaces[s].nodes.len()];
        }
        for t in &eval.terms {
            let (s, k) = t.slave;
            active[s][k] = true;
            let st = &mut self.state[s][k];
            if let Some((m, tri, bary)) = st.tie {
                let node = self.surfaces[s].nodes[k];
                let tr = self.surfaces[m].triangles[tri];
                let gap = tie_gap(&point(x, node), &tr.map(|n| point(x, n)), &bary);
                for i in 0..3 {
                    st.tie_lambda[i] += eps * gap[i];
                }
            } else {
                st.lambda = t.pressure;
            }
        }
        for (s, states) in self.state.iter_mut().enumerate() {
            for (k, st) in states.iter_mut().enumerate() {
                if !active[s][k] && st.tie.is_none() {
                    st.lambda = 0.0;
                }
            }
        }
        eval.max_penetration()
    }

    /// Tied mode: makes every slave node now in contact tied to the material
    /// point of the master triangle it touches (call once per converged step).
    pub fn tie_closed(&mut self, eval: &ContactEvaluation) {
        if self.settings.mode != ContactMode::Tied {
            return;
        }
        for t in &eval.terms {
            let (s, k) = t.slave;
            if self.state[s][k].tie.is_some() || t.penetration < 0.0 {
                continue;
            }
            let st = &mut self.state[s][k];
            st.tie = Some((t.master.0, t.master.1, t.location));
            st.tie_lambda = [0.0; 3];
        }
    }

    /// Serialisable copy of the multiplier state (to save and restore
    /// around a step that may be cut back).
    pub fn state_snapshot(&self) -> StateSnapshot {
        self.state
            .iter()
            .map(|v| v.iter().map(|s| (s.lambda, s.tie, s.tie_lambda)).collect())
            .collect()
    }

    pub fn restore(&mut self, snapshot: &StateSnapshot) {
        for (states, saved) in self.state.iter_mut().zip(snapshot) {
            for (st, &(lambda, tie, tie_lambda)) in states.iter_mut().zip(saved) {
                *st = NodeState {
                    lambda,
                    tie,
                    tie_lambda,
                };
            }
        }
    }
}

/// Value and gradient of the penetration (first-order duals would do; the
/// Hessian path is reused for simplicity of one code path).
fn gradient_of_penetration(v: &SVector<f64, 12>) -> (f64, SVector<f64, 12>) {
    let (f, g) = num_dual::gradient(
        |w: SVector<num_dual::DualSVec64<12>, 12>| penetration(&w),
        v,
    );
    (f, g)
}
