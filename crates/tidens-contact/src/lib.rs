//! Contact between particle surfaces, units mm, N, MPa.
//!
//! [`ParticleContact`] (the entry type) holds the surfaces of the particles
//! of a scene and enforces frictionless (or tied) contact between them:
//!
//! - detection with parry (`parry3d-f64`): each surface is triangulated in its
//!   current configuration and the nodes of one surface are projected onto the
//!   other's `TriMesh` (oriented: its pseudo-normals give the side of the
//!   surface the node is on), only for pairs of surfaces whose bounding
//!   boxes meet; the triangle found names the facet around which the node
//!   is paired, with the facet whose reading agrees with the node's signed
//!   distance, one on each other surface within the search distance (a node in the pocket
//!   where two particles meet is held off both), each pair with its own
//!   multiplier;
//! - enforcement node to surface, both ways (two-pass, each pass carrying half
//!   the tributary area so that identical particles are treated alike), on
//!   facets (flat triangles, each hexahedral face's two by
//!   [`ContactSurface::from_quads_as_triangles`] or a tetrahedral face's
//!   four, or bilinear quads), by an augmented Lagrangian: the energy of a slave
//!   node of tributary area `A` is `A / (4 eps) <lambda + eps p>^2` (half of
//!   `A / (2 eps) <.>^2` per pass) with `p` its penetration into the facet,
//!   `lambda` its contact pressure multiplier and `<x> = max(x, 0)`. Its
//!   gradient is the contact force `A/2 <lambda + eps p> dp/du`, its Hessian
//!   (where the pressure is positive) the consistent tangent
//!   `A/2 (eps dp/du (x) dp/du + (lambda + eps p) d2p/du2)`, symmetric, both
//!   exact: the derivatives of the penetration are written in closed form in
//!   [`mod@penetration`]. The curvature part `(lambda + eps p) d2p/du2` is
//!   indefinite; [`ContactSettings::curvature_stiffness`] says whether the
//!   tangent carries it (the consistent tangent) or leaves it out (each
//!   term's tangent positive semi-definite, that of a term across a partly
//!   weighted fold by its eigenvalues below zero set to zero, see
//!   [`FULL_FOLD`]; the solver leaves it out). Between Newton solves,
//!   [`ParticleContact::augment`] updates the multipliers (Uzawa) until the
//!   penetration is below its tolerance.
//! - within a step each node keeps the facets it was paired with at the
//!   step's start ([`ParticleContact::pair`]) while it stays on them (to
//!   a margin), and its projection on each starts where it projected then
//!   (one root of the closest-point conditions followed), so the residual
//!   stays smooth while Newton iterates; between Newton iterations
//!   ([`ParticleContact::relink`]) and at convergence
//!   ([`ParticleContact::repair`]) the nodes that slid off their facet or
//!   came near another surface are paired afresh, and at convergence
//!   Newton goes on if one touches.
//!
//! [`mod@mortar`] holds the kernels of mortar (segment-to-segment) contact:
//! weighted gaps of a slave surface's nodes against a master surface,
//! their mortar integrals and exact derivatives. [`ParticleContact`] does
//! not use them yet.

mod error;
pub mod facet;
mod fold;
pub mod gap;
pub mod mortar;
pub mod penetration;
mod surface;

pub use error::ContactError;
pub use gap::{project, project_from, project_triangle, shape, tie_gap, triangle_shape};
pub use penetration::{
    Penetration, PenetrationHessian, penetration, penetration_gradient, penetration_hessian,
    triangle_penetration_gradient, triangle_penetration_hessian,
};
pub use surface::{ContactSurface, Continuation, FacetKind};

use fold::FoldWeight;
use parry3d_f64::math::Vector as PVector;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::TriMesh;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Fraction of the penalty stiffness that a slave node near a facet without
/// pressure brings to the tangent while its pair of surfaces presses nowhere
/// (at most [`ContactSettings::touch_stiffness_cap`]).
pub const TOUCH_STIFFNESS: f64 = 1e-3;

/// A paired node keeps its facet from step to step while its projection
/// stays within the facet grown by this factor (see [`ParticleContact::pair`]).
const KEEP_FACET_MARGIN: f64 = 1.1;

/// A node is paired afresh with a facet only while its projection lies
/// within the facet grown by this factor, half of [`KEEP_FACET_MARGIN`]'s
/// growth: a link made just inside the margin it is dropped at could be
/// dropped and made again, at one converged state, for ever (see
/// [`ParticleContact::nearest`]).
const MAKE_FACET_MARGIN: f64 = 1.05;

/// A link whose node has slid past its triangle's edge gives way to a
/// triangle of its ring that holds the node within its edges and reads it
/// deeper by more than this fraction of the search distance (see
/// [`ParticleContact::held_deeper_nearby`]). The cells' search distance is
/// the spacing of their surface nodes, at most a tenth of the radius, so
/// this is at most a fifth of the penetration the solver leaves (0.5e-4 of
/// the radius), and well above round-off.
const DEEPER_NEIGHBOUR: f64 = 1e-4;

/// How far past its edges (as a fraction of the facet) a neighbour may
/// hold a node's foot and still take the node from a link it has slid off
/// (see [`ParticleContact::held_deeper_nearby`]): the foot of a node that
/// slides along a mirror plane of the cell lies on the edge of a triangle
/// in that plane, within round-off and the creep of a step of it. On the
/// sc2 cell at level 1 (n = 15, rho = 0.82) one lay 6e-5 to 2e-4 of a
/// facet past such an edge and 1e-2 past its own triangle's corner, and
/// went on 8.6e-4 of the radius into the other particle over the next
/// sixty steps while both triangles' planes read it open.
const NEIGHBOUR_EDGE_SLACK: f64 = 1e-3;

/// A node is paired only with a facet whose penetration reading differs
/// by at most this fraction of the search distance from the node's signed
/// depth below the surface (see [`ParticleContact::nearest`]); the bilinear
/// patches of a curved surface's quads stand off their triangles by a few
/// hundredths.
const NEAR_FACET_SLACK: f64 = 0.1;

/// The fold (the sine of the angle between two neighbouring facets'
/// planes, inward) from which the term across it has its full weight:
/// below it the term's energy scales with a smooth step of the fold,
/// `w = 35 t^4 - 84 t^5 + 70 t^6 - 20 t^7` with `t` the fold over this,
/// so that the term vanishes as the two facets come into one plane (where
/// it would measure the node as the link's own term does and double its
/// force) and does not switch on at once where a fold turns inward.
///
/// The weight depends on the corners of both facets, so the term's force
/// has a part on them and its tangent a coupling to them (see the `fold`
/// module: the term is the weight times the augmented Lagrangian's
/// energy, and its tangent stays symmetric). With the weight taken as a
/// constant in the tangent (and the step of degree five, `10 t^3 -
/// 15 t^4 + 6 t^5`), Newton stalled where a pressed face flattened and
/// its triangles folded by less than this: a whole sphere in a periodic
/// cube (the sc lattice at level 1) stopped at rho = 0.7000, its residual
/// stuck at 5 times the tolerance. With the coupling it reaches 0.8 as
/// its octant cell does (`benches/periodic.py`). The step's first three
/// derivatives vanish at both ends, so the force's part on the corners
/// grows with the cube of the fold from a flat one, where round-off
/// decides between a valley (a term) and a ridge (none): with the step of
/// degree five it grew with the square, and central differences of the
/// force across such a fold read a derivative where there is none.
///
/// Tried and not kept: the weight constant in the tangent (the force
/// `w phi' grad g` alone) with this step also reached 0.8, with 10 %
/// fewer Newton iterations on sc and fcc and 21 % fewer on bcc (the
/// coupling is indefinite: on sc 264 of 1204 factorisations needed
/// LBL^T, against 4), but its consistent tangent was off the residual's
/// differences by 1.5e-3 of its size (bcc in the ramp); a Gauss-Newton
/// form of the coupling (positive semi-definite) failed at rho = 0.79 on
/// sc. The solver's tangent now keeps the positive semi-definite part of
/// each such term's whole tangent (see the `fold` module), which fails on
/// sc too unless a pair of facets sharing one corner only has its weight
/// go to zero where it stops being a valley (the `fold` module's
/// `weight_of`).
pub const FULL_FOLD: f64 = 0.02;

/// A fold below this (the sine of its angle) is flat: round-off decides
/// its sign (two triangles of a plane quad).
const ROUND_OFF_FOLD: f64 = 1e-8;

/// The facets of a link's facet's ring that can hold its node across a
/// fold: the first this many (the rings of the cells' hexahedral meshes,
/// split into triangles, hold at most 13, the facet itself included, at
/// levels 1 to 4).
const FOLD_SLOTS: usize = 24;

/// A node open from its facet by more than this fraction of the search
/// distance, without pressure, has no contact term (it is clearly apart).
pub const NEAR_BAND: f64 = 0.1;

/// Dofs of one contact term: a slave node and the four nodes of a facet.
pub const TERM_DOFS: usize = 15;

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
    /// Penalty stiffness eps \[MPa/mm\].
    pub penalty: f64,
    /// Search distance: nodes farther than this from the other surface are
    /// not candidates \[mm\].
    pub search_distance: f64,
    /// Whether a frictionless term's tangent holds the curvature part
    /// `a p d2g/du2` (the consistent tangent) beside the penalty part
    /// `a eps dg/du dg/du^T`. A term across a partly weighted fold carries
    /// the derivatives of its weight `w` either way: the coupling `a phi'
    /// (dg/du dw/du^T + dw/du dg/du^T)` and `a phi d2w/du2`, of which the
    /// tangent without curvature keeps the term's positive semi-definite part (see
    /// [`FULL_FOLD`] and the `fold` module). The curvature part is
    /// indefinite; without it
    /// each term's tangent is positive semi-definite, Newton converges
    /// linearly near the contact edge instead of quadratically, but every
    /// iteration's direction is one of descent: on the bcc and fcc cells at
    /// level 2 the runs take 29 and 34 % fewer Newton iterations and 43 and
    /// 50 % less linear-algebra time, with no indefinite factorisation
    /// (there were 14 and 36 %). Tied terms always have their consistent tangent.
    pub curvature_stiffness: bool,
    /// Largest stiffness \[MPa/mm\] that a node near a facet without
    /// pressure brings to the tangent ([`TOUCH_STIFFNESS`] of the penalty
    /// otherwise), so that the load can close the gap in a Newton step: the
    /// touch stiffness holds a body that hangs on a contact about to close,
    /// but Newton moves the body by the force over it each iteration, and
    /// where it scales with a stiff material's E (E/sigma = 1e7) a gap of
    /// 4e-3 element sizes took hundreds of iterations to close (bcc during
    /// the ramp: Newton stalled at any step length). Infinite: no cap.
    pub touch_stiffness_cap: f64,
}

/// One slave node's link to a master facet, with its contribution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactTerm {
    /// Body dofs: the slave node's three, then the facet nodes' twelve
    /// ([`TERM_DOFS`] in all); a term across a fold whose weight is below
    /// one appends those of the link's facet's corners that are not the
    /// facet's (the weight depends on them, see [`FULL_FOLD`]).
    pub dofs: Vec<usize>,
    /// Contribution to the internal force \[N\], by dof.
    pub force: Vec<f64>,
    /// Tangent, row-major, `dofs.len()` square \[N/mm\] (empty if not
    /// requested): the consistent one, or without its curvature part (see
    /// [`ContactSettings::curvature_stiffness`]).
    pub tangent: Vec<f64>,
    /// Contact pressure (tied: traction magnitude) at the slave node \[MPa\].
    pub pressure: f64,
    /// Penetration of the slave node (negative: a gap; tied: gap length) \[mm\].
    pub penetration: f64,
    /// Slave surface and index of the node in it.
    pub slave: (usize, usize),
    /// Master surface and facet.
    pub master: (usize, usize),
    /// Facet parameters (xi, eta) of the slave's projection.
    pub location: [f64; 2],
    /// The term holds the node off a facet around its link's facet (the
    /// `j`-th of its ring), where the surface folds inward between them
    /// (with its own multiplier), and its weight in (0, 1] (see
    /// [`FULL_FOLD`]): `(j, weight)`; None for the link's own term.
    #[serde(default)]
    pub fold: Option<(usize, f64)>,
}

impl ContactTerm {
    /// The term's weight: that of its fold for a term across a fold (see
    /// [`ContactTerm::fold`]), one otherwise. The augmented Lagrangian
    /// enforces the term's penetration times it.
    pub fn weight(&self) -> f64 {
        self.fold.map_or(1.0, |(_, w)| w)
    }
}

/// A term across a fold: its place in the ring of the link's facet
/// `from`, and its weight (see [`FULL_FOLD`]).
#[derive(Clone, Copy, Debug)]
struct Across {
    slot: usize,
    weight: f64,
    from: usize,
}

/// Saved contact state (every slave node's multipliers and ties against
/// each master surface, and the facets it is paired with), to redo a step
/// from: a failed attempt pairs nodes afresh at its intermediate states,
/// and the links it made must not outlive it.
#[derive(Clone, Debug, PartialEq)]
pub struct StateSnapshot {
    state: Vec<Vec<NodeStates>>,
    pairing: Vec<Vec<NodePairing>>,
    mortar: Option<mortar::MortarCheckpoint>,
}

impl StateSnapshot {
    /// How many slave-master pairs carry a multiplier or a tie.
    pub fn len(&self) -> usize {
        self.state.iter().flatten().map(Vec::len).sum::<usize>()
            + self
                .mortar
                .as_ref()
                .map_or(0, mortar::MortarCheckpoint::len)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The multiplier states of one slave node of one pass, one per master
/// surface it has a multiplier or a tie against, in master order.
type NodeStates = Vec<(usize, NodeState)>;

/// A slave node's link to a master facet for the step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Link {
    /// Master surface.
    master: usize,
    /// Facet of the master surface.
    facet: usize,
    /// Facet parameters of the node's projection when the link was made or
    /// last kept: Newton on the projection starts there, so that it follows
    /// one root of the closest-point conditions while the node moves. Off
    /// a strongly warped facet they have several; from the facet's centre,
    /// Newton went to one or another as the node moved by 1e-8 mm, and the
    /// node read 4.1e-3 mm deep at one and 1e-4 mm at the other (sc2 of
    /// c/a = 5 at level 3, where Newton then failed at every step length).
    start: [f64; 2],
    /// The node's penetration \[mm\] when the step started (the touch
    /// force's reference, see [`ParticleContact::set_touch_force`]).
    #[serde(default)]
    reference: f64,
}

/// The facets one slave node is paired with for the step, at most one per
/// master surface, in master order.
type NodePairing = Vec<Link>;

/// Multiplier state of one slave node of one pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
struct NodeState {
    /// Normal pressure multiplier \[MPa\] (frictionless).
    lambda: f64,
    /// Pressure multipliers \[MPa\] on the facets around the link's facet
    /// (by their place in its ring, [`ContactSurface::ring`]) where the
    /// surface folds inward between them (see [`ParticleContact::fold`]).
    #[serde(default)]
    fold_lambda: [f64; FOLD_SLOTS],
    /// Tied: the master surface, facet and parameters, and the vector
    /// multiplier \[MPa\].
    tie: Option<(usize, usize, [f64; 2])>,
    tie_lambda: [f64; 3],
    /// The node's gap to this master surface closed at the start \[mm\]
    /// (see [`ParticleContact::close_initial_gaps`]): added to every
    /// penetration measured against it.
    #[serde(default)]
    offset: f64,
}

/// The state of a [`ParticleContact`] that a run carries from step to step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactCheckpoint {
    state: Vec<Vec<NodeStates>>,
    pairing: Vec<Vec<NodePairing>>,
    #[serde(default)]
    mortar: Option<mortar::MortarCheckpoint>,
}

/// Contact between the surfaces of a scene's particles.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ParticleContact {
    surfaces: Vec<ContactSurface>,
    settings: ContactSettings,
    /// Per surface, per node: the state of its pass as slave, against each
    /// master surface.
    state: Vec<Vec<NodeStates>>,
    /// Per surface, per node: the master (surface, facet) pairs it is paired
    /// with for the current step, one per master surface within the search
    /// distance (see [`ParticleContact::pair`]).
    #[serde(skip)]
    pairing: Vec<Vec<NodePairing>>,
    /// Stiffness \[MPa/mm\] of the touch force, if any (see
    /// [`ParticleContact::set_touch_force`]).
    #[serde(skip)]
    touch_force: Option<f64>,
    /// The (slave, master) pairs of surfaces that pressed somewhere (a
    /// node with a multiplier, or tied) when the step started
    /// ([`ParticleContact::pair`]): the touch force leaves them out.
    #[serde(skip)]
    pressed_at_start: std::collections::HashSet<(usize, usize)>,
    /// The mortar formulation ([`ParticleContact::mortar`]), which then
    /// does all the work: the node-to-facet state above stays empty.
    #[serde(skip)]
    mortar: Option<Box<mortar::MortarContact>>,
}

/// The contact contributions at one configuration.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ContactEvaluation {
    pub terms: Vec<ContactTerm>,
}

impl ContactEvaluation {
    /// Largest penetration of any slave node into a master surface \[mm\]
    /// as the augmented Lagrangian enforces it (frictionless terms; a term
    /// across a fold counts its reading times its weight, see
    /// [`FULL_FOLD`]; tied terms report their gap length). A term across a
    /// slight fold, or across one whose far corner nears the other
    /// facet's plane, weighs little: it holds its node with that fraction
    /// of the penalty, and its plane, carried past the neighbour's edges,
    /// need not be the surface there. On eight random spheres (level 1,
    /// rho = 0.935-0.95) every step's largest reading above 4e-6 mm (up to
    /// 1.5e-5 mm) was of such a term, of weight 7.8e-7 to 1.6e-3, while no link's
    /// own term read more than 6.6e-7 mm and no node lay deeper than
    /// 3.2e-6 mm inside another particle by its distance to that
    /// particle's surface ([`ParticleContact::max_depth`]); their readings
    /// alone had failed the run's penetration check.
    pub fn max_penetration(&self) -> f64 {
        self.terms
            .iter()
            .map(|t| t.weight() * t.penetration)
            .fold(0.0, f64::max)
    }

    /// Largest violation of the contact conditions \[mm\]: a penetration, or
    /// a gap at a node that still carries pressure (a multiplier left from
    /// an earlier state). The augmented Lagrangian iterates until it is small.
    pub fn max_violation(&self) -> f64 {
        self.terms
            .iter()
            .map(|t| {
                t.weight()
                    * if t.pressure > 0.0 {
                        t.penetration.abs()
                    } else {
                        t.penetration
                    }
            })
            .fold(0.0, f64::max)
    }
}

/// A slave node inside another surface (see [`ParticleContact::deepest`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Depth {
    /// The node's surface and its place in that surface's nodes.
    pub slave: usize,
    pub node: usize,
    /// The surface it is inside, and the facet nearest to it there.
    pub master: usize,
    pub facet: usize,
    /// Distance \[mm\] to the nearest point of that surface.
    pub depth: f64,
}

/// The facet parameters of the point of a triangle nearest `xi` along the
/// parameter axes (`xi` itself within the triangle): a point of the facet
/// near a foot slightly past its edges.
fn clamp_into_triangle(xi: [f64; 2]) -> [f64; 2] {
    let c = [xi[0].max(0.0), xi[1].max(0.0)];
    let sum = c[0] + c[1];
    if sum > 1.0 {
        [c[0] / sum, c[1] / sum]
    } else {
        c
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
            .map(|s| vec![Vec::new(); s.nodes.len()])
            .collect();
        let pairing = surfaces
            .iter()
            .map(|s| vec![Vec::new(); s.nodes.len()])
            .collect();
        Ok(Self {
            surfaces,
            settings,
            state,
            pairing,
            touch_force: None,
            pressed_at_start: Default::default(),
            mortar: None,
        })
    }

    /// Contact among `surfaces` by the mortar formulation (see
    /// [`mortar::MortarContact`]) with test functions `basis`: weighted
    /// gaps, no node-to-facet links. Frictionless only.
    pub fn mortar(
        surfaces: Vec<ContactSurface>,
        settings: ContactSettings,
        basis: mortar::TestBasis,
    ) -> Result<Self, ContactError> {
        let m = mortar::MortarContact::new(surfaces.clone(), settings, basis)?;
        let mut contact = Self::new(surfaces, settings)?;
        contact.mortar = Some(Box::new(m));
        Ok(contact)
    }

    /// Whether this is the mortar formulation.
    pub fn is_mortar(&self) -> bool {
        self.mortar.is_some()
    }

    /// The mortar formulation's state, if it is that one.
    pub fn as_mortar(&self) -> Option<&mortar::MortarContact> {
        self.mortar.as_deref()
    }

    /// The dofs a term couples in the tangent for the rest of the step: the
    /// slave node with every facet around its master facet, or (mortar)
    /// the term's dofs with every candidate master facet of its node.
    pub fn coupling_dofs(&self, t: &ContactTerm) -> Vec<usize> {
        if let Some(m) = &self.mortar {
            return m.coupling_dofs(t);
        }
        let master = &self.surfaces[t.master.0];
        let mut dofs: Vec<usize> = t.dofs[..3].to_vec();
        for &f in master.ring(t.master.1) {
            dofs.extend(
                master.facets[f]
                    .iter()
                    .flat_map(|&n| [3 * n, 3 * n + 1, 3 * n + 2]),
            );
        }
        dofs.sort_unstable();
        dofs.dedup();
        dofs
    }

    pub fn surfaces(&self) -> &[ContactSurface] {
        &self.surfaces
    }

    pub fn settings(&self) -> &ContactSettings {
        &self.settings
    }

    /// Ordered pairs (slave, master) of surfaces whose bounding boxes,
    /// grown by the search distance, overlap in the configuration `x`; a
    /// periodic image ([`ContactSurface::master_only`]) is never the slave.
    pub fn candidate_pairs(&self, x: &[f64]) -> Vec<(usize, usize)> {
        let boxes: Vec<([f64; 3], [f64; 3])> =
            self.surfaces.iter().map(|s| s.bounding_box(x)).collect();
        let d = self.settings.search_distance;
        let mut pairs = Vec::new();
        for i in 0..boxes.len() {
            for j in 0..boxes.len() {
                let (a, b) = (&boxes[i], &boxes[j]);
                let slave = !self.surfaces[i].master_only;
                if slave && i != j && (0..3).all(|k| a.0[k] - d <= b.1[k] && b.0[k] - d <= a.1[k]) {
                    pairs.push((i, j));
                }
            }
        }
        pairs
    }

    /// The search meshes of the master surfaces of `pairs` whose slave
    /// surface satisfies `needs`. Built afresh at every call: pairing runs
    /// twice a step, and a surface's mesh costs about one contact
    /// evaluation to build, a small share of a step next to the element
    /// work (see the detection benchmarks); keeping meshes between calls
    /// would not pay for the state it adds.
    fn search_meshes(
        &self,
        x: &[f64],
        pairs: &[(usize, usize)],
        needs: impl Fn(usize) -> bool,
    ) -> Vec<Option<TriMesh>> {
        let mut meshes: Vec<Option<TriMesh>> = vec![None; self.surfaces.len()];
        for &(s, m) in pairs {
            if meshes[m].is_none() && needs(s) {
                meshes[m] = self.surfaces[m].trimesh(x);
            }
        }
        meshes
    }

    /// The facet of surface `m` nearest to slave node `k` of surface `s`
    /// within the search distance, and the node's projection on it. Parry
    /// finds the nearest triangle; among the quads around its quad, the one
    /// whose bilinear projection lies deepest inside it is chosen: a
    /// geometric rule that mirror-symmetric meshes follow alike, so a node
    /// on an edge between two facets is not left to the order of a tree
    /// traversal.
    ///
    /// Only the facets whose penetration reading agrees with the node's
    /// signed depth below the surface (within [`NEAR_FACET_SLACK`] of the
    /// search distance) are candidates. The depth is parry's distance to
    /// the nearest point, positive where the pseudo-normal there (of the
    /// face, edge or corner it lies on) says the node is inside. Near the
    /// tip of a slender spheroid the facets around the pole also take in
    /// the far side, onto which the node projects well inside, and read as
    /// deep as the tip is thick (measured on the sc2 cell of c/a = 5 at
    /// level 2: paired afresh, a node in contact read 1.6e-2 mm deep on the
    /// far side's quad). And beside a fold of a tip's facets a node outside
    /// can lie behind one facet's plane, just past that facet's edge: on
    /// the same cell at level 3, on triangles, a node 4.8e-3 mm outside a
    /// tip read 4.8e-3 mm deep on such a facet, 0.015 of it past its edge.
    /// A filter on the distance alone let it through (the reading was as
    /// large as the distance, with the wrong sign); paired at each step's
    /// start, the node was pushed out at 3e5 MPa, and the run stalled at
    /// rho = 0.835 with steps of 1e-7 s. A bilinear quad that parry found
    /// is a candidate whatever it reads: its patch may stand off the
    /// triangles parry searched.
    ///
    /// None if even the chosen quad's projection lies beyond its edges (by
    /// more than [`MAKE_FACET_MARGIN`]): the node then faces a ridge or
    /// corner of the master, where no quad's patch measures it (carried past
    /// its edge, a patch read a node of the same cell 3.1e-3 mm deep at
    /// xi = (1.52, -1.20), and the step was cut to 2e-5 s). The
    /// ridge's own nodes are held off the node's surface by the other pass.
    /// A link is kept while the projection stays within the wider
    /// [`KEEP_FACET_MARGIN`]; were links made up to that margin, a node
    /// facing a corner could alternate between two facets without end: on
    /// the sc2 cell of c/a = 5 at level 3 (rho = 0.75), a node near a
    /// particle's slender tip was paired at convergence with a facet that
    /// read it 4.1e-4 mm deep at xi = (-1.098, 1.085); pushed out, it
    /// projected at xi = (-1.29, 1.01) (another root of the warped
    /// patch), was dropped and paired with the neighbouring facet, 4.8e-4
    /// mm off at xi = (1.01, -1.09); released, it came back 6e-5 mm, left
    /// that facet (xi = 1.105) and was paired with the first again, and
    /// Newton never ended (failures down to steps of 1e-5 s).
    fn nearest(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        m: usize,
        mesh: &TriMesh,
    ) -> Option<(usize, [f64; 2])> {
        let p = point(x, self.surfaces[s].nodes[k]);
        let q = PVector::new(p[0], p[1], p[2]);
        let (proj, (tri, _)) = mesh.project_local_point_and_get_location_with_max_dist(
            q,
            false,
            self.settings.search_distance,
        )?;
        let master = &self.surfaces[m];
        // The node's signed depth below the surface, from parry's nearest
        // point and the side its pseudo-normal gives.
        let distance = (proj.point - q).length();
        let depth = if proj.is_inside { distance } else { -distance };
        let slack = NEAR_FACET_SLACK * self.settings.search_distance;
        let found = master.facet_of_triangle(tri as usize);
        let best = master
            .ring(found)
            .iter()
            .filter_map(|&f| {
                let xf = master.facets[f].map(|n| point(x, n));
                let xi = facet::project_on(master.kind, &p, &xf);
                let far = (facet::penetration_on(master.kind, &p, &xf, xi) - depth).abs() > slack;
                // A quad's patch may stand off the triangles parry searched:
                // the quad parry found is taken whatever it reads.
                let found_quad = f == found && master.kind == FacetKind::Quad;
                (found_quad || !far).then(|| (f, xi, facet::outside(master.kind, xi)))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)))?;
        (best.2 <= MAKE_FACET_MARGIN).then_some((best.0, best.1))
    }

    /// Pairs every slave node with the facet nearest to it of each master
    /// surface within the search distance, in the configuration `x`, for the
    /// coming step. A node between two particles (in the pocket where they
    /// meet) is so held off both: paired with one only, it could press on
    /// that one and pass through the other unseen (measured on the sc2 cell
    /// of spheroids c/a = 2, whose small particles fill such pockets: a node
    /// held off one large particle went 2e-3 mm into the other, 4 % of the
    /// radius, and the run failed). Within a step a paired node keeps its
    /// facets (its penetration measured on each facet's bilinear patch,
    /// extended beyond its edges if need be), so the residual stays smooth
    /// while Newton iterates: switching facets between iterations would
    /// make it jump.
    ///
    /// A node keeps the facet of the previous step while its projection stays
    /// within that facet grown by a tenth of its size: choosing afresh every
    /// step would let a node on the edge between two facets hop between them
    /// from step to step (their patches differ slightly beyond their edges),
    /// and the two equilibria it hops between make the piston chatter.
    ///
    /// With a touch force ([`ParticleContact::set_touch_force`]) each
    /// link's reference is the node's penetration now, and the pairs of
    /// surfaces that press somewhere now (by their multipliers) are left
    /// out of it for the step.
    pub fn pair(&mut self, x: &[f64]) {
        if let Some(m) = &mut self.mortar {
            return m.pair(x);
        }
        self.drop_left(x, true);
        self.pair_unpaired(x);
        self.pressed_at_start = self
            .state
            .iter()
            .enumerate()
            .flat_map(|(s, nodes)| {
                nodes.iter().flatten().filter_map(move |(m, st)| {
                    let presses = st.lambda > 0.0
                        || st.fold_lambda.iter().any(|l| *l > 0.0)
                        || st.tie.is_some();
                    presses.then_some((s, *m))
                })
            })
            .collect();
    }

    /// Makes the touch stiffness a force too: a spring of `stiffness`
    /// \[MPa/mm\] per unit tributary area on the change of the node's
    /// penetration since the step started (since [`ParticleContact::pair`]),
    /// on every node of a pair of surfaces that pressed nowhere when the
    /// step started, pressed or not (added to its pressure), in place of
    /// the tangent-only touch stiffness. None (the default): the touch
    /// stiffness is in the tangent only.
    ///
    /// Which nodes carry the spring is fixed for the step, so that the
    /// residual stays continuous. Decided at each evaluation (the spring
    /// on open nodes of pairs that pressed nowhere then), the springs of a
    /// whole pair came or went when its first node pressed or let go: on 16
    /// random spheres at level 1 (seed 0), in the load's ramp, the piston's
    /// residual was 7.5e-5 N at 1e-3 of a Newton direction (115 terms
    /// pressed) and 3.9e-4 N from 1e-2 of it on (114), every longer step
    /// was refused, and the attempt failed after 34 iterations. With the
    /// springs fixed for the step the ramp (to t = 1 s, tolerance 0.08)
    /// took 41 steps and 608 Newton iterations, against 53 and 714.
    ///
    /// Tangent-only, the stiffness lets Newton move a body toward a contact
    /// that has not closed, but nothing in the residual carries the load
    /// until it closes: where a body's contacts all start open (whole
    /// spheres meshed alike touch facet to facet with a gap of the
    /// faceting, 4.8e-4 mm = 1e-2 R at mesh level 1, when the meshes are
    /// turned against each other), the residual stays the whole load and
    /// the line search takes 2 to 10 % of each direction (the body turns
    /// in it, held only by the drag), and the run failed in its first
    /// steps. With the spring the load is carried, across the gap, by the
    /// nodes about to touch, over the step in which they close it.
    pub fn set_touch_force(&mut self, stiffness: Option<f64>) {
        self.touch_force = stiffness;
    }

    /// Closes the gaps of the configuration `x` that are below `limit`
    /// \[mm\], without strain: each slave node paired with a facet it is
    /// open from by less than `limit` reads that gap as closed from then
    /// on (the gap is kept as an offset added to its penetration against
    /// that master surface). For particles that touch at points, as those
    /// of a jammed packing do: their faceted surfaces lie inside the
    /// spheroids by up to the facets' sagitta, so every contact would
    /// otherwise start open. Returns how many node-surface pairs it closed.
    pub fn close_initial_gaps(&mut self, x: &[f64], limit: f64) -> usize {
        if self.mortar.is_some() {
            // The nodes that touch the other surface pointwise (their
            // distance to its facets below `limit`) read closed: their mean
            // gap over their support is O(h^2 / R) open where two curved
            // surfaces touch at a point (bcc at level 1: 1.2e-2 R).
            self.pair_unpaired(x);
            let mut touching = std::collections::BTreeSet::new();
            for (s, nodes) in self.pairing.iter().enumerate() {
                for (k, links) in nodes.iter().enumerate() {
                    for l in links {
                        let gap = -self.measure(x, s, k, l).1;
                        if gap < limit {
                            touching.insert((s, k, l.master));
                        }
                    }
                }
            }
            for nodes in &mut self.pairing {
                nodes.iter_mut().for_each(Vec::clear);
            }
            return self
                .mortar
                .as_mut()
                .map_or(0, |m| m.close_touching(x, &touching));
        }
        self.pair_unpaired(x);
        let mut closed = Vec::new();
        for (s, nodes) in self.pairing.iter().enumerate() {
            for (k, links) in nodes.iter().enumerate() {
                for l in links {
                    let gap = -self.measure(x, s, k, l).1;
                    if gap > 0.0 && gap < limit {
                        closed.push((s, k, l.master, gap));
                    }
                }
            }
        }
        for &(s, k, m, gap) in &closed {
            self.node_state_mut(s, k, m).offset += gap;
        }
        closed.len()
    }

    /// At a converged state `x`, what [`ParticleContact::pair`] will do at
    /// the start of the next step: the links whose node has left its facet
    /// are made afresh, and every node is paired with the surfaces within
    /// reach it was not paired with. Returns how many of the new links
    /// touch or press: if any, the state was found with facets that no
    /// longer hold the node, and Newton must go on. A node that slides past
    /// its facet within a step is otherwise measured on that facet's patch
    /// carried beyond its edge, which past a convex ridge puts it deep
    /// inside (or far off) the surface it is really on; the step that
    /// follows would start from that state with the true penetration.
    pub fn repair(&mut self, x: &[f64]) -> usize {
        if let Some(m) = &mut self.mortar {
            return m.repair(x);
        }
        self.pair_afresh(x).0
    }

    /// Between two Newton iterations at `x`: the links whose node has left
    /// its facet are made afresh, and the nodes that came within reach of
    /// a surface are paired with it, as [`ParticleContact::repair`] does at
    /// convergence. Returns whether any link changed (then the contact
    /// terms at `x` are not those of the links they were evaluated with).
    pub fn relink(&mut self, x: &[f64]) -> bool {
        if let Some(m) = &mut self.mortar {
            return m.relink(x);
        }
        self.pair_afresh(x).1
    }

    /// Drops the links whose node left its facet and pairs the unpaired
    /// nodes at `x`; returns how many of the new links touch or press, and
    /// whether any link was dropped or made.
    fn pair_afresh(&mut self, x: &[f64]) -> (usize, bool) {
        let before = self.pairing.clone();
        self.drop_left(x, false);
        self.pair_unpaired(x);
        // Only a link to another facet is new: a node near a convex edge can
        // have its nearest facet's patch project it beyond the margin, and
        // paired again with the same facet it must not count (Newton would
        // go on at the same state for ever).
        let same = |a: &Link, b: &Link| (a.master, a.facet) == (b.master, b.facet);
        let mut touching = 0;
        let mut changed = false;
        for (s, nodes) in self.pairing.iter().enumerate() {
            for (k, links) in nodes.iter().enumerate() {
                let old = &before[s][k];
                changed |= old.iter().any(|b| !links.iter().any(|l| same(l, b)));
                for l in links {
                    if old.iter().any(|b| same(l, b)) {
                        continue;
                    }
                    changed = true;
                    if self.node_term(x, s, k, l, false).is_some() {
                        if std::env::var_os("TIDENS_DEBUG").is_some() {
                            let olds: Vec<_> = old
                                .iter()
                                .map(|b| ((b.master, b.facet), self.measure(x, s, k, b)))
                                .collect();
                            eprintln!(
                                "      repair: node {:?} at {:?} new facet {:?} measured {:?}; before {:?}",
                                (s, k),
                                point(x, self.surfaces[s].nodes[k]),
                                (l.master, l.facet),
                                self.measure(x, s, k, l),
                                olds
                            );
                        }
                        touching += 1;
                    }
                }
            }
        }
        (touching, changed)
    }

    /// Facet parameters and penetration \[mm\] of slave node `k` of surface
    /// `s` measured on facet `f` of surface `m` (its patch extended beyond
    /// its edges if need be; Newton on the projection from the facet's
    /// centre), in the configuration `x`.
    pub fn measure_on(&self, x: &[f64], s: usize, k: usize, m: usize, f: usize) -> ([f64; 2], f64) {
        if f == mortar::ANY_FACET {
            return ([0.0; 2], 0.0);
        }
        let link = Link {
            master: m,
            facet: f,
            start: [0.0; 2],
            reference: 0.0,
        };
        self.measure(x, s, k, &link)
    }

    /// Facet parameters and penetration \[mm\] of slave node `k` of surface
    /// `s` on the facet of `link`, Newton on the projection from the
    /// link's start.
    fn measure(&self, x: &[f64], s: usize, k: usize, link: &Link) -> ([f64; 2], f64) {
        let kind = self.surfaces[link.master].kind;
        let p = point(x, self.surfaces[s].nodes[k]);
        let q = self.surfaces[link.master].facets[link.facet].map(|n| point(x, n));
        let xi = facet::project_from_on(kind, &p, &q, link.start);
        let offset = self.node_state(s, k, link.master).offset;
        (xi, facet::penetration_on(kind, &p, &q, xi) + offset)
    }

    /// Drops the links whose node has left its facet grown by
    /// [`KEEP_FACET_MARGIN`] or gone beyond the search distance; the others
    /// start their projection where the node projects now, and with a
    /// touch force and `new_step` take the node's penetration now as their
    /// reference (new links do in [`ParticleContact::pair_unpaired`]).
    fn drop_left(&mut self, x: &[f64], new_step: bool) {
        let reset = new_step && self.touch_force.is_some();
        let keep = |s: usize, k: usize, l: &Link| {
            let (xi, penetration) = self.measure(x, s, k, l);
            let kept = facet::outside(self.surfaces[l.master].kind, xi) <= KEEP_FACET_MARGIN
                && penetration > -self.settings.search_distance
                && !self.held_deeper_nearby(x, s, k, l, xi, penetration);
            let reference = if reset { penetration } else { l.reference };
            kept.then_some(Link {
                start: xi,
                reference,
                ..*l
            })
        };
        let pairing: Vec<Vec<NodePairing>> = self
            .pairing
            .iter()
            .enumerate()
            .map(|(s, nodes)| {
                nodes
                    .iter()
                    .enumerate()
                    .map(|(k, links)| links.iter().filter_map(|l| keep(s, k, l)).collect())
                    .collect()
            })
            .collect();
        self.pairing = pairing;
    }

    /// Whether the node of `link`, read at `penetration` \[mm\] on its facet
    /// (facet parameters `xi`), has slid past that facet's edge onto a
    /// triangle of the facet's ring that holds it within its edges (to
    /// [`NEIGHBOUR_EDGE_SLACK`], and nearer to them than the link's own
    /// facet) and reads it deeper by more than [`DEEPER_NEIGHBOUR`] of the
    /// search distance, beyond the sag below that triangle's plane of the
    /// link's facet at the node (its point nearest the node's foot): a
    /// convex surface lies below every facet's plane, and on the sc2 cell
    /// at level 1 a node on the edge of two triangles near a mirror plane
    /// (1e-9 past one, 1e-4 past the other) read 1.2e-3 mm deep on the
    /// plane of a third triangle of their rings that holds its foot, while
    /// it lay on the surface; without the sag its link went from one
    /// triangle to the other at every convergence and the hold to 1e6 s
    /// failed at rho = 0.993. The link then gives way, and the node is
    /// paired afresh (with the deeper triangle). Only a neighbour without a
    /// term across a fold counts: where the surface folds inward that term
    /// holds the node.
    ///
    /// Within the margin a link is kept by ([`KEEP_FACET_MARGIN`]), its
    /// facet's plane carried past the edge holds the node off the
    /// neighbours where the surface folds outward (it lies above them
    /// there), and the terms across inward folds ([`ParticleContact::fold`])
    /// hold it where the surface folds inward. Where two triangles share a
    /// corner only and the surface is a saddle there (one of the
    /// neighbour's far corners above the facet's plane, one below), neither
    /// holds: on the sc2 cell at level 3 (rho = 0.91) a node 0.049 of a
    /// facet past such a corner read 8e-11 mm on its link's plane while it
    /// lay 7.4e-6 mm inside the neighbour (1.5e-4 of the radius), until it
    /// left the margin (four steps later the depth read 3.2e-7 mm); at n =
    /// 15, another one lay 9.8e-5 mm inside (2e-3 of the radius), 0.049 of
    /// its facet past a corner.
    ///
    /// Moving links so on every neighbour, across inward folds too (tried
    /// before those folds had terms of their own), cost bcc at level 1
    /// 2018 Newton iterations and 48 failed attempts to rho = 0.9, against
    /// 370 and none.
    fn held_deeper_nearby(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        link: &Link,
        xi: [f64; 2],
        penetration: f64,
    ) -> bool {
        let master = &self.surfaces[link.master];
        if master.kind != FacetKind::Triangle || facet::outside(master.kind, xi) <= 1.0 {
            return false;
        }
        let deeper = penetration + DEEPER_NEIGHBOUR * self.settings.search_distance;
        let own = facet::outside(master.kind, xi);
        // The point of the link's facet nearest the node's foot: the
        // surface at the node. A neighbour's plane counts only how far the
        // node lies below it beyond that point, which on a convex surface
        // lies below the plane too (by the surface's sag).
        let corners = master.facets[link.facet].map(|n| point(x, n));
        let n = facet::shape_on(master.kind, clamp_into_triangle(xi));
        let surface: [f64; 3] = std::array::from_fn(|i| (0..3).map(|a| n[a] * corners[a][i]).sum());
        master
            .ring(link.facet)
            .iter()
            .filter(|&&g| g != link.facet)
            .any(|&g| {
                let (xg, pg) = self.measure_on(x, s, k, link.master, g);
                let q = master.facets[g].map(|n| point(x, n));
                let foot = facet::project_on(master.kind, &surface, &q);
                let sag = facet::penetration_on(master.kind, &surface, &q, foot);
                let fired = facet::outside(master.kind, xg) < own.min(1.0 + NEIGHBOUR_EDGE_SLACK)
                    && pg - sag.max(0.0) > deeper
                    && self.fold(x, link.master, link.facet, g).is_none();
                if fired && std::env::var_os("TIDENS_DEBUG").is_some() {
                    eprintln!(
                        "      link of node {:?} to facet {:?} (xi {xi:?}, reading \
                         {penetration:.3e} mm) gives way to facet {g} (xi {xg:?}, \
                         reading {pg:.3e} mm, the surface's sag below it {sag:.3e} mm)",
                        (s, k),
                        (link.master, link.facet)
                    );
                }
                fired
            })
    }

    /// The largest depth \[mm\] of any slave node inside another surface in
    /// the configuration `x`, paired or not: parry's distance to the
    /// nearest point of the surface, for the nodes on its inner side (by
    /// the pseudo-normal there) within its bounding box; 0 if none is
    /// inside.
    ///
    /// The box is not grown: a particle's solid lies within the box of its
    /// surface's nodes, and outside it the pseudo-normal can be wrong. On
    /// the sc2 cell of c/a = 5 at level 2 (rho = 0.825) a small particle
    /// had triangles turned over at its top (normals pointing down), and
    /// nodes of a large particle 8.6e-3 mm above its highest node read
    /// 9.3e-3 mm inside it (0.19 of the radius) through an edge of those
    /// triangles.
    ///
    /// The contact terms measure each node on the facet it is paired
    /// with. A node left unpaired (its foot beyond every facet's margin)
    /// can go on into the other particle unseen: on the sc2 cell of
    /// c/a = 5 at level 3 one sat 3.2e-3 mm inside while the paired nodes
    /// read at most 1.1e-7 mm. So can a node kept on a triangle it has
    /// slid off, measured on that triangle's plane carried past an inward
    /// fold: on bcc at level 1 one read 8e-10 mm there and was 1.1e-4 mm
    /// inside (2.1e-3 of the radius) at rho = 0.9.
    pub fn max_depth(&self, x: &[f64]) -> f64 {
        self.deepest(x).map_or(0.0, |d| d.depth)
    }

    /// A line on slave node `k` of surface `s` in the configuration `x`, for
    /// debugging output: each link's facet, facet parameters, `outside`
    /// measure and penetration \[mm\], the same for every triangle of that
    /// facet's ring (and whether a term across a fold joins them), and the
    /// node's multipliers.
    pub fn describe_node(&self, x: &[f64], s: usize, k: usize) -> String {
        let mut out = String::new();
        for l in &self.pairing[s][k] {
            let kind = self.surfaces[l.master].kind;
            let (xi, pen) = self.measure(x, s, k, l);
            out += &format!(
                "link to surface {} facet {}: xi ({:.4}, {:.4}), outside {:.6}, penetration {pen:.3e}; ring:",
                l.master,
                l.facet,
                xi[0],
                xi[1],
                facet::outside(kind, xi)
            );
            for &g in self.surfaces[l.master].ring(l.facet) {
                let (xg, pg) = self.measure_on(x, s, k, l.master, g);
                let fold = self.fold(x, l.master, l.facet, g).is_some();
                out += &format!(
                    " {g} (outside {:.6}, penetration {pg:.3e}{})",
                    facet::outside(kind, xg),
                    if fold { ", fold" } else { "" }
                );
            }
            out += "; ";
        }
        out + &format!("state {:?}", self.state[s][k])
    }

    /// The slave node deepest inside another surface in the configuration
    /// `x` (as [`ParticleContact::max_depth`] measures it), or None if no
    /// node is inside one.
    pub fn deepest(&self, x: &[f64]) -> Option<Depth> {
        let pairs = self.candidate_pairs(x);
        let meshes = self.search_meshes(x, &pairs, |_| true);
        pairs
            .par_iter()
            .filter_map(|&(s, m)| {
                let mesh = meshes[m].as_ref()?;
                let (lo, hi) = self.surfaces[m].bounding_box(x);
                self.surfaces[s]
                    .nodes
                    .iter()
                    .enumerate()
                    .filter_map(|(k, &n)| {
                        let p = point(x, n);
                        if !(0..3).all(|i| p[i] >= lo[i] && p[i] <= hi[i]) {
                            return None;
                        }
                        let q = PVector::new(p[0], p[1], p[2]);
                        let (proj, (tri, _)) = mesh.project_local_point_and_get_location(q, false);
                        let depth = (proj.point - q).length();
                        (proj.is_inside && depth > 0.0).then(|| Depth {
                            slave: s,
                            node: k,
                            master: m,
                            facet: self.surfaces[m].facet_of_triangle(tri as usize),
                            depth,
                        })
                    })
                    .max_by(|a, b| a.depth.total_cmp(&b.depth))
            })
            .max_by(|a, b| a.depth.total_cmp(&b.depth))
    }

    /// Pairs the slave nodes with the master surfaces within the search
    /// distance that they are not paired with yet, in the configuration
    /// `x`; returns how many of the new pairs touch or press (so that a
    /// converged step can be checked for contacts that appeared during it).
    pub fn pair_unpaired(&mut self, x: &[f64]) -> usize {
        let pairs = self.candidate_pairs(x);
        let meshes = self.search_meshes(x, &pairs, |_| true);
        let mut masters: Vec<Vec<usize>> = vec![Vec::new(); self.surfaces.len()];
        for &(s, m) in &pairs {
            masters[s].push(m);
        }
        let mut touching = 0;
        for s in 0..self.surfaces.len() {
            let found: Vec<NodePairing> = (0..self.surfaces[s].nodes.len())
                .into_par_iter()
                .map(|k| {
                    masters[s]
                        .iter()
                        .filter(|&&m| !self.pairing[s][k].iter().any(|l| l.master == m))
                        .filter_map(|&m| {
                            let (facet, start) = self.nearest(x, s, k, m, meshes[m].as_ref()?)?;
                            let mut link = Link {
                                master: m,
                                facet,
                                start,
                                reference: 0.0,
                            };
                            if self.touch_force.is_some() {
                                link.reference = self.measure(x, s, k, &link).1;
                            }
                            Some(link)
                        })
                        .collect()
                })
                .collect();
            for (k, new) in found.into_iter().enumerate() {
                for link in new {
                    if self.node_term(x, s, k, &link, false).is_some() {
                        touching += 1;
                    }
                    let links = &mut self.pairing[s][k];
                    let at = links.partition_point(|l| l.master < link.master);
                    links.insert(at, link);
                }
            }
        }
        touching
    }

    /// The multiplier state of slave node `k` of surface `s` against master
    /// surface `m` (none yet: zero).
    fn node_state(&self, s: usize, k: usize, m: usize) -> NodeState {
        self.state[s][k]
            .iter()
            .find(|(sm, _)| *sm == m)
            .map_or_else(NodeState::default, |(_, st)| *st)
    }

    /// The multiplier state of slave node `k` of surface `s` against master
    /// surface `m`, made if it is not there yet.
    fn node_state_mut(&mut self, s: usize, k: usize, m: usize) -> &mut NodeState {
        let states = &mut self.state[s][k];
        let at = states.partition_point(|(sm, _)| *sm < m);
        if states.get(at).is_none_or(|(sm, _)| *sm != m) {
            states.insert(at, (m, NodeState::default()));
        }
        &mut states[at].1
    }

    /// Contact terms at the configuration `x` (current node coordinates,
    /// `3 * node + i`), with tangents if asked, for the paired and tied
    /// slave nodes.
    pub fn evaluate(&self, x: &[f64], with_tangent: bool) -> ContactEvaluation {
        if let Some(m) = &self.mortar {
            return m.evaluate(x, with_tangent);
        }
        let work: Vec<(usize, usize)> = self
            .surfaces
            .iter()
            .enumerate()
            .flat_map(|(s, surface)| (0..surface.nodes.len()).map(move |k| (s, k)))
            .collect();
        let terms = work
            .par_iter()
            .flat_map_iter(|&(s, k)| {
                let tied = self.state[s][k].iter().filter_map(move |&(m, st)| {
                    let (tm, facet, xi) = st.tie?;
                    debug_assert_eq!(tm, m);
                    Some(self.tied_term(x, s, k, m, facet, xi, st.tie_lambda, with_tangent))
                });
                let pressed = self.pairing[s][k].iter().filter_map(move |l| {
                    if self.node_state(s, k, l.master).tie.is_some() {
                        return None;
                    }
                    Some(self.node_terms(x, s, k, l, with_tangent))
                });
                tied.chain(pressed.flatten()).collect::<Vec<_>>()
            })
            .collect::<Vec<_>>();
        let mut terms = terms;
        // The touch stiffness of unpressed nodes keeps a body that hangs on
        // a contact about to close (the piston's particles on the others at
        // the start) from being free in a Newton iteration. Once a pair of
        // surfaces presses anywhere it is held, and the stiffness (which the
        // force does not have) would only slow Newton down near the edge of
        // the contact patch: it is dropped there. (Not the touch force's
        // spring, which is fixed for the step.)
        let pressed: std::collections::BTreeSet<(usize, usize)> = terms
            .iter()
            .filter(|t| t.pressure > 0.0)
            .map(|t| (t.slave.0, t.master.0))
            .collect();
        for t in &mut terms {
            let tied = self
                .node_state(t.slave.0, t.slave.1, t.master.0)
                .tie
                .is_some();
            let sprung = self.spring(t.slave.0, t.master.0, t.fold.is_some());
            if t.pressure <= 0.0
                && !tied
                && sprung.is_none()
                && pressed.contains(&(t.slave.0, t.master.0))
            {
                t.tangent.fill(0.0);
                t.force.fill(0.0);
            }
        }
        ContactEvaluation { terms }
    }

    /// The touch force's stiffness \[MPa/mm\] on the terms of slave surface
    /// `s` against master surface `m` this step, if they carry it (see
    /// [`ParticleContact::set_touch_force`]); never across a fold.
    fn spring(&self, s: usize, m: usize, across_fold: bool) -> Option<f64> {
        self.touch_force
            .filter(|_| !across_fold && !self.pressed_at_start.contains(&(s, m)))
    }

    /// Slave point, facet node coordinates, and the term's dofs.
    fn gather(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        m: usize,
        facet: usize,
    ) -> ([f64; 3], [[f64; 3]; 4], [usize; TERM_DOFS]) {
        let node = self.surfaces[s].nodes[k];
        let quad = self.surfaces[m].facets[facet];
        let mut dofs = [0; TERM_DOFS];
        for i in 0..3 {
            dofs[i] = 3 * node + i;
            for a in 0..4 {
                dofs[3 + 3 * a + i] = 3 * quad[a] + i;
            }
        }
        (point(x, node), quad.map(|n| point(x, n)), dofs)
    }

    /// The term of slave node `k` of surface `s` against facet `facet` of
    /// master surface `m`, if the node presses on it or nearly touches it.
    fn node_term(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        link: &Link,
        with_tangent: bool,
    ) -> Option<ContactTerm> {
        let lambda = self.node_state(s, k, link.master).lambda;
        self.plane_term(x, s, k, link, lambda, None, with_tangent)
    }

    /// The term of `link` ([`ParticleContact::node_term`]), and the terms
    /// that hold the node off the facets around its facet where the
    /// surface folds inward ([`ParticleContact::fold`]).
    fn node_terms(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        link: &Link,
        with_tangent: bool,
    ) -> impl Iterator<Item = ContactTerm> {
        let own = self.node_term(x, s, k, link, with_tangent);
        let lambdas = self.node_state(s, k, link.master).fold_lambda;
        let ring = self.surfaces[link.master].ring(link.facet);
        let folds = ring
            .iter()
            .take(FOLD_SLOTS)
            .enumerate()
            .filter_map(move |(j, &g)| {
                let weight = self.fold(x, link.master, link.facet, g)?;
                let neighbour = Link {
                    facet: g,
                    start: [0.0; 2],
                    ..*link
                };
                let across = Across {
                    slot: j,
                    weight,
                    from: link.facet,
                };
                self.plane_term(x, s, k, &neighbour, lambdas[j], Some(across), with_tangent)
            });
        own.into_iter().chain(folds)
    }

    /// The weight of the term on facet `g` for a node linked to facet `f`
    /// of surface `m`, both flat triangles sharing a corner or an edge,
    /// where the surface folds inward between them (a valley: each one's
    /// corners off the other lie outside the other's plane) in the
    /// configuration `x`; None elsewhere, and for quads.
    ///
    /// The solid below a valley is the union of the two facets' sides, and
    /// the space outside it the intersection of the two planes' outer
    /// sides: a node is held off both planes by a term on each, each
    /// smooth (a plane extended), each with its own multiplier. A link on
    /// one facet alone measured the node on that facet's plane, which past
    /// the fold runs under the neighbour: on the bcc cell at level 1 a node
    /// read 8e-10 mm on it while it lay 1.07e-4 mm inside the neighbour
    /// across an edge (2.1e-3 of the radius), and in a long hold to full
    /// density, with terms across the edges only, a node that had slid
    /// past a corner lay 7.5e-5 mm inside a facet that shared that corner
    /// only. A node pushed into a fold rests on both facets, which no
    /// single plane represents. Where the surface folds outward (a ridge)
    /// the link's plane extended lies above the neighbour: it reads a node
    /// there deeper than it is and alone holds it off both.
    ///
    /// The weight is a smooth step of the sine of the angle between the
    /// facets' normals (see [`FULL_FOLD`]), and, for facets that share a
    /// corner only, of each far corner's elevation above the other's
    /// plane, so that it goes to zero where the valley ends.
    fn fold(&self, x: &[f64], m: usize, f: usize, g: usize) -> Option<f64> {
        let master = &self.surfaces[m];
        if self.settings.mode != ContactMode::Frictionless
            || master.kind != surface::FacetKind::Triangle
            || g == f
        {
            return None;
        }
        let (tf, tg) = (master.facets[f], master.facets[g]);
        let (qf, qg) = (tf.map(|n| point(x, n)), tg.map(|n| point(x, n)));
        let (nf, ng) = (fold::unit_normal(&qf), fold::unit_normal(&qg));
        let cross = gap::cross(&nf, &ng);
        let sine = gap::dot(&cross, &cross).sqrt();
        if !(sine > ROUND_OFF_FOLD) {
            return None;
        }
        // Each facet's corners off the other outside the other's plane.
        let outside = |corners: &[usize; 4], q: &[[f64; 3]; 4], on: &[usize; 4], n: [f64; 3]| {
            corners[..3]
                .iter()
                .zip(q)
                .filter(|(c, _)| !on[..3].contains(c))
                .all(|(_, p)| gap::dot(&gap::sub(p, &point(x, on[0])), &n) > 0.0)
        };
        if !(outside(&tg, &qg, &tf, nf) && outside(&tf, &qf, &tg, ng)) {
            return None;
        }
        let nodes = [tf[0], tf[1], tf[2], tg[0], tg[1], tg[2]];
        let corners = [qf[0], qf[1], qf[2], qg[0], qg[1], qg[2]];
        Some(fold::weight(nodes, corners))
    }

    /// The weight of the term across the fold between facets `f` and `g`
    /// of surface `m` ([`ParticleContact::fold`], `weight` there) with its
    /// derivatives in the configuration `x`.
    fn fold_derivatives(
        &self,
        x: &[f64],
        m: usize,
        f: usize,
        g: usize,
        hessian: bool,
    ) -> FoldWeight {
        let facets = &self.surfaces[m].facets;
        let nodes: [usize; 6] = std::array::from_fn(|i| {
            if i < 3 {
                facets[f][i]
            } else {
                facets[g][i - 3]
            }
        });
        FoldWeight::at(nodes, nodes.map(|n| point(x, n)), hessian)
    }

    /// The term of the node against the plane (or patch) of `link`'s facet,
    /// with multiplier `lambda` \[MPa\]; `fold` marks a term across a fold
    /// (see [`ContactTerm::fold`]), with its weight.
    #[allow(clippy::too_many_arguments)]
    fn plane_term(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        link: &Link,
        lambda: f64,
        fold: Option<Across>,
        with_tangent: bool,
    ) -> Option<ContactTerm> {
        let (m, facet) = (link.master, link.facet);
        let (p, q, dofs) = self.gather(x, s, k, m, facet);
        let kind = self.surfaces[m].kind;
        let xi = facet::project_from_on(kind, &p, &q, link.start);
        // Nodes clearly apart from the facet need no derivatives.
        let band = -NEAR_BAND * self.settings.search_distance;
        let offset = self.node_state(s, k, m).offset;
        if lambda <= 0.0 && facet::penetration_on(kind, &p, &q, xi) + offset <= band {
            return None;
        }
        let area = 0.5 * self.surfaces[s].areas[k];
        let eps = self.settings.penalty;
        let (pen, grad, hess) = if with_tangent && self.settings.curvature_stiffness {
            let d = facet::hessian_on(kind, &p, &q, xi);
            (d.value + offset, d.gradient, Some(d.hessian))
        } else {
            let d = facet::gradient_on(kind, &p, &q, xi);
            (d.value + offset, d.gradient, None)
        };
        let pressure = (lambda + eps * pen).max(0.0);
        // A node near the surface without pressure (a gap below a tenth of
        // the search distance) brings [`TOUCH_STIFFNESS`] of the penalty to
        // the tangent (not to the force) while its pair of surfaces has no
        // pressed node yet (see `evaluate`), or, with a touch force, a
        // spring (see `set_touch_force`).
        let touching = pen > band;
        if pressure <= 0.0 && !touching {
            return None;
        }
        // A term across a fold acts with its weight: the augmented
        // Lagrangian of a penalty `w eps` and multiplier `w lambda`.
        let weight = fold.map_or(1.0, |a| a.weight);
        let spring = self.spring(s, link.master, fold.is_some());
        let traction = pressure + spring.map_or(0.0, |k| k * (pen - link.reference));
        let force: Vec<f64> = grad.iter().map(|g| area * weight * traction * g).collect();
        let stiffness = if let Some(k) = spring {
            k + if pressure > 0.0 { eps } else { 0.0 }
        } else if pressure > 0.0 {
            eps
        } else {
            (TOUCH_STIFFNESS * eps).min(self.settings.touch_stiffness_cap)
        };
        let (kg, kh) = (area * weight * stiffness, area * weight * traction);
        let curvature = hess.is_some();
        let tangent = match (with_tangent, hess) {
            (true, Some(h)) => {
                let mut k = Vec::with_capacity(TERM_DOFS * TERM_DOFS);
                for (gi, hi) in grad.iter().zip(&h) {
                    k.extend(grad.iter().zip(hi).map(|(gj, hij)| gi * gj * kg + hij * kh));
                }
                k
            }
            (true, None) => {
                let mut k = Vec::with_capacity(TERM_DOFS * TERM_DOFS);
                for gi in &grad {
                    k.extend(grad.iter().map(|gj| gi * gj * kg));
                }
                k
            }
            (false, _) => Vec::new(),
        };
        let mut term = ContactTerm {
            dofs: dofs.to_vec(),
            force,
            tangent,
            pressure: weight * pressure,
            penetration: pen,
            slave: (s, k),
            master: (m, facet),
            location: xi,
            fold: fold.map(|a| (a.slot, a.weight)),
        };
        // Below its full weight, the weight's dependence on the corners of
        // the two facets (see [`FULL_FOLD`]), its Hessian in any tangent
        // (all of it in the consistent one, see the `fold` module).
        if let Some(a) = fold
            && pressure > 0.0
            && a.weight < 1.0
        {
            self.fold_derivatives(x, m, a.from, facet, with_tangent)
                .add_to(&mut term, &grad, area, pressure, eps, curvature);
        }
        Some(term)
    }

    /// Term of a tied slave node: a vector penalty on the distance to its
    /// material point on the master facet.
    #[allow(clippy::too_many_arguments)]
    fn tied_term(
        &self,
        x: &[f64],
        s: usize,
        k: usize,
        m: usize,
        facet: usize,
        xi: [f64; 2],
        lambda: [f64; 3],
        with_tangent: bool,
    ) -> ContactTerm {
        let (p, q, dofs) = self.gather(x, s, k, m, facet);
        let area = 0.5 * self.surfaces[s].areas[k];
        let eps = self.settings.penalty;
        let kind = self.surfaces[m].kind;
        let gap = facet::tie_gap_on(kind, &p, &q, xi);
        let n = facet::shape_on(kind, xi);
        // d gap / d x: +1 for the slave, -N_a for facet node a.
        let weights = [1.0, -n[0], -n[1], -n[2], -n[3]];
        let traction: [f64; 3] = [0, 1, 2].map(|i| lambda[i] + eps * gap[i]);
        let mut force = vec![0.0; TERM_DOFS];
        for a in 0..5 {
            for i in 0..3 {
                force[3 * a + i] = area * traction[i] * weights[a];
            }
        }
        let tangent = if with_tangent {
            let mut kmat = vec![0.0; TERM_DOFS * TERM_DOFS];
            for a in 0..5 {
                for b in 0..5 {
                    for i in 0..3 {
                        kmat[(3 * a + i) * TERM_DOFS + 3 * b + i] =
                            area * eps * weights[a] * weights[b];
                    }
                }
            }
            kmat
        } else {
            Vec::new()
        };
        let length = (gap[0] * gap[0] + gap[1] * gap[1] + gap[2] * gap[2]).sqrt();
        ContactTerm {
            dofs: dofs.to_vec(),
            force,
            tangent,
            pressure: traction.iter().map(|v| v * v).sum::<f64>().sqrt(),
            penetration: length,
            slave: (s, k),
            master: (m, facet),
            location: xi,
            fold: None,
        }
    }

    /// Uzawa update after a converged solve: the multipliers take the
    /// pressures of `eval` (slave-master pairs not in it lose theirs); tied
    /// nodes add their gap times the penalty. Returns the largest
    /// penetration before the update \[mm\].
    pub fn augment(&mut self, x: &[f64], eval: &ContactEvaluation) -> f64 {
        if let Some(m) = &mut self.mortar {
            return m.augment(eval);
        }
        let eps = self.settings.penalty;
        let mut active: std::collections::BTreeSet<(usize, usize, usize)> = Default::default();
        let mut folds: std::collections::BTreeSet<(usize, usize, usize, usize)> =
            Default::default();
        for t in &eval.terms {
            let ((s, k), m) = (t.slave, t.master.0);
            if let Some((i, weight)) = t.fold {
                folds.insert((s, k, m, i));
                if t.pressure > 0.0 || self.node_state(s, k, m).fold_lambda[i] > 0.0 {
                    self.node_state_mut(s, k, m).fold_lambda[i] = t.pressure / weight;
                }
                continue;
            }
            active.insert((s, k, m));
            if let Some((_, facet, xi)) = self.node_state(s, k, m).tie {
                let (p, q, _) = self.gather(x, s, k, m, facet);
                let gap = facet::tie_gap_on(self.surfaces[m].kind, &p, &q, xi);
                let st = self.node_state_mut(s, k, m);
                for i in 0..3 {
                    st.tie_lambda[i] += eps * gap[i];
                }
            } else if t.pressure > 0.0 || self.node_state(s, k, m).lambda > 0.0 {
                self.node_state_mut(s, k, m).lambda = t.pressure;
            }
        }
        // Pairs not evaluated lose their multiplier; states that carry
        // nothing any more are dropped.
        for (s, nodes) in self.state.iter_mut().enumerate() {
            for (k, states) in nodes.iter_mut().enumerate() {
                for (m, st) in states.iter_mut() {
                    if st.tie.is_none() && !active.contains(&(s, k, *m)) {
                        st.lambda = 0.0;
                    }
                    for (i, l) in st.fold_lambda.iter_mut().enumerate() {
                        if !folds.contains(&(s, k, *m, i)) {
                            *l = 0.0;
                        }
                    }
                }
                states.retain(|(_, st)| {
                    st.tie.is_some()
                        || st.lambda != 0.0
                        || st.offset != 0.0
                        || st.fold_lambda.iter().any(|&l| l != 0.0)
                });
            }
        }
        eval.max_penetration()
    }

    /// Tied mode: makes every slave node now pressed into a facet tied to
    /// the material point of the facet it touches (call once per converged
    /// step).
    pub fn tie_closed(&mut self, eval: &ContactEvaluation) {
        if self.mortar.is_some() {
            return;
        }
        if self.settings.mode != ContactMode::Tied {
            return;
        }
        for t in &eval.terms {
            let ((s, k), m) = (t.slave, t.master.0);
            if self.node_state(s, k, m).tie.is_none() && t.pressure > 0.0 {
                let st = self.node_state_mut(s, k, m);
                st.tie = Some((m, t.master.1, t.location));
                st.tie_lambda = [0.0; 3];
            }
        }
    }

    /// Copy of the multiplier state, to redo a step from.
    /// Everything that carries over from one step to the next (the
    /// multipliers and ties, and each node's master facet), for a
    /// checkpoint.
    pub fn checkpoint(&self) -> ContactCheckpoint {
        ContactCheckpoint {
            state: self.state.clone(),
            pairing: self.pairing.clone(),
            mortar: self.mortar.as_ref().map(|m| m.checkpoint()),
        }
    }

    /// Takes the state of a checkpoint of the same surfaces.
    pub fn restore_checkpoint(&mut self, c: &ContactCheckpoint) -> Result<(), ContactError> {
        let fits = |n: &[usize]| {
            n.len() == self.surfaces.len()
                && n.iter()
                    .zip(&self.surfaces)
                    .all(|(k, s)| *k == s.nodes.len())
        };
        let state: Vec<usize> = c.state.iter().map(Vec::len).collect();
        let pairing: Vec<usize> = c.pairing.iter().map(Vec::len).collect();
        if !fits(&state) || !fits(&pairing) {
            return Err(ContactError::Surface(
                "a checkpoint of other contact surfaces".into(),
            ));
        }
        match (&mut self.mortar, &c.mortar) {
            (Some(m), Some(saved)) => m.restore_checkpoint(saved)?,
            (None, None) => {}
            _ => {
                return Err(ContactError::Surface(
                    "a checkpoint of the other contact formulation".into(),
                ));
            }
        }
        self.state = c.state.clone();
        self.pairing = c.pairing.clone();
        Ok(())
    }

    pub fn state_snapshot(&self) -> StateSnapshot {
        StateSnapshot {
            state: self.state.clone(),
            pairing: self.pairing.clone(),
            mortar: self.mortar.as_ref().map(|m| m.checkpoint()),
        }
    }

    pub fn restore(&mut self, snapshot: &StateSnapshot) {
        self.state.clone_from(&snapshot.state);
        self.pairing.clone_from(&snapshot.pairing);
        if let (Some(m), Some(saved)) = (&mut self.mortar, &snapshot.mortar) {
            // The same surfaces: it fits.
            let _ = m.restore_checkpoint(saved);
        }
    }
}
