//! Frictionless rigid planes, handled analytically (docs/model.md sections
//! 2 and 5).
//!
//! Every box face is a rigid mirror plane normal to a coordinate axis, so a
//! node touches it through one dof only: the dof along that axis. A dof on a
//! face that cuts a particle (a flat mesh face) is tied to its plane
//! (bilateral); a dof of the curved surface may touch the planes of its axis
//! (unilateral, with an active set). A constrained dof is eliminated from the
//! system: on a fixed plane its value is prescribed, on the piston plane it
//! follows the piston, `u = Lz - Z + U`, and shares the piston's equation.
//! Tangential motion is free on every plane (no friction).

use crate::error::SolverError;
use serde::{Deserialize, Serialize};
use tidens_fem::DOF_DROPPED;
use tidens_mesh::FaceKind;

/// How one dof may meet the two planes normal to its axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
enum Rule {
    Free,
    /// Always on the plane at the low (`high = false`) or high end.
    Bilateral {
        high: bool,
    },
    /// May come into contact with the low and/or the high plane.
    Unilateral {
        low: bool,
        high: bool,
    },
    /// A dof of a periodic image node: the original dof's displacement,
    /// plus `periods` times the piston's along z (the image lies `periods`
    /// cell heights Lz + U away).
    Image {
        original: usize,
        periods: i8,
    },
    /// Held at zero (a periodic cell's rigid translation).
    Pinned,
}

/// The rigid planes of a scene and the contact state of every dof.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Constraints {
    lengths: [f64; 3],
    /// Reference coordinate of each dof's node along the dof's axis \[mm\].
    x0: Vec<f64>,
    rules: Vec<Rule>,
    /// For unilateral dofs: `Some(high)` while in contact with that plane.
    contact: Vec<Option<bool>>,
    /// Sensitivity option: the tangential dofs of nodes in contact with a
    /// rigid plane are held at the value they had when the contact closed.
    tied_planes: bool,
    ties: Vec<Option<f64>>,
    /// Active-set changes of each dof in the current step.
    flips: Vec<u8>,
    unilateral: Vec<usize>,
}

/// The contact state of the rigid planes, saved to redo a step from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaneContactState {
    /// For each dof: `Some(high)` while in contact with that plane.
    contact: Vec<Option<bool>>,
    /// For each dof: the value it is tied at (tied planes only).
    ties: Vec<Option<f64>>,
}

/// After this many active-set changes in one step a dof may still come into
/// contact but is no longer released in that step: this ends chattering
/// between contact and release on the safe side (a small tensile contact
/// force rather than a penetration).
const MAX_FLIPS: u8 = 4;

impl Constraints {
    /// Classifies the dofs of a mesh with node coordinates `nodes` and
    /// boundary faces `faces` (node lists with their kind) in the box
    /// `lengths` \[mm\]. Nodes start in contact where they touch a plane (gap
    /// below `1e-9` of the box size). With `tied_planes`, nodes in contact
    /// with a plane are also tied to it tangentially (a sensitivity option).
    pub fn new<'a>(
        nodes: &[[f64; 3]],
        faces: impl IntoIterator<Item = (&'a [usize], FaceKind)>,
        lengths: [f64; 3],
        lateral_walls: bool,
        tied_planes: bool,
    ) -> Result<Self, SolverError> {
        let n_dof = 3 * nodes.len();
        let scale = lengths.iter().cloned().fold(0.0, f64::max);
        let tol = 1e-9 * scale;
        let plane_exists = |axis: usize, high: bool| !high || axis == 2 || lateral_walls;
        let mut on_plane: Vec<[Option<bool>; 3]> = vec![[None; 3]; nodes.len()];
        let mut curved = vec![false; nodes.len()];
        for (face, kind) in faces {
            match kind {
                FaceKind::Plane { axis, high } => {
                    for &n in face {
                        on_plane[n][axis] = Some(high);
                    }
                }
                FaceKind::Curved => {
                    for &n in face {
                        curved[n] = true;
                    }
                }
            }
        }
        let mut x0 = vec![0.0; n_dof];
        let mut rules = vec![Rule::Free; n_dof];
        for (node, p) in nodes.iter().enumerate() {
            for axis in 0..3 {
                let d = 3 * node + axis;
                x0[d] = p[axis];
                rules[d] = match on_plane[node][axis] {
                    Some(high) if plane_exists(axis, high) => {
                        let pos = if high { lengths[axis] } else { 0.0 };
                        if (p[axis] - pos).abs() > tol {
                            return Err(SolverError::Unsupported(format!(
                                "mesh node {node} lies on a flat face at x{axis} = {} but the box plane is at {pos}",
                                p[axis]
                            )));
                        }
                        Rule::Bilateral { high }
                    }
                    Some(_) => Rule::Free,
                    None if curved[node] => Rule::Unilateral {
                        low: true,
                        high: plane_exists(axis, true),
                    },
                    None => Rule::Free,
                };
            }
        }
        let unilateral: Vec<usize> = (0..n_dof)
            .filter(|&d| matches!(rules[d], Rule::Unilateral { .. }))
            .collect();
        let mut c = Self {
            lengths,
            x0,
            rules,
            contact: vec![None; n_dof],
            tied_planes,
            ties: vec![None; n_dof],
            flips: vec![0; n_dof],
            unilateral,
        };
        // Initial contacts: nodes touching a plane in the reference state.
        for &d in &c.unilateral {
            if let Rule::Unilateral { low, high } = c.rules[d] {
                let axis = d % 3;
                if high && (c.x0[d] - lengths[axis]).abs() <= tol {
                    c.contact[d] = Some(true);
                } else if low && c.x0[d].abs() <= tol {
                    c.contact[d] = Some(false);
                }
            }
        }
        Ok(c)
    }

    /// The constraints of a periodic cell of `nodes` nodes and lengths
    /// `lengths` \[mm\] (reference coordinates `coordinates`): no rigid
    /// plane, every dof free until made an image ([`Constraints::set_images`])
    /// or pinned ([`Constraints::pin`]).
    pub fn without_planes(coordinates: &[[f64; 3]], lengths: [f64; 3]) -> Self {
        let n_dof = 3 * coordinates.len();
        Self {
            lengths,
            x0: coordinates.iter().flatten().copied().collect(),
            rules: vec![Rule::Free; n_dof],
            contact: vec![None; n_dof],
            tied_planes: false,
            ties: vec![None; n_dof],
            flips: vec![0; n_dof],
            unilateral: Vec::new(),
        }
    }

    /// Number of body dofs; the piston's equation is numbered after them.
    pub fn dof_count(&self) -> usize {
        self.rules.len()
    }

    /// Equation index of the piston displacement U.
    pub fn piston_equation(&self) -> usize {
        self.rules.len()
    }

    /// Position of the plane normal to `axis` at its `high` or low end \[mm\].
    pub fn plane_position(&self, axis: usize, high: bool, piston: f64) -> f64 {
        match (high, axis) {
            (false, _) => 0.0,
            (true, 2) => self.lengths[2] + piston,
            (true, _) => self.lengths[axis],
        }
    }

    /// The plane dof `d` is held on, if any.
    fn held_on(&self, d: usize) -> Option<bool> {
        match self.rules[d] {
            Rule::Bilateral { high } => Some(high),
            Rule::Unilateral { .. } => self.contact[d],
            Rule::Free | Rule::Image { .. } | Rule::Pinned => None,
        }
    }

    /// Equation of each body dof: its own, the piston's (dofs held on the
    /// piston plane), the original's (dofs of periodic images) or
    /// [`DOF_DROPPED`] (dofs held on a fixed plane, or pinned).
    pub fn equation_map(&self) -> Vec<usize> {
        (0..self.rules.len())
            .map(|d| match self.rules[d] {
                Rule::Image { original, .. } => self.own_equation(original),
                _ => self.own_equation(d),
            })
            .collect()
    }

    /// The unknowns at the current contact state: the body dofs that have
    /// an equation of their own (free, or in contact with no plane), plus
    /// the piston's displacement.
    pub fn unknowns(&self) -> usize {
        self.equation_map()
            .iter()
            .enumerate()
            .filter(|&(d, &m)| m == d)
            .count()
            + 1
    }

    /// The equation of dof `d` that is not an image.
    fn own_equation(&self, d: usize) -> usize {
        if self.rules[d] == Rule::Pinned {
            return DOF_DROPPED;
        }
        match self.held_on(d) {
            None if self.ties[d].is_some() => DOF_DROPPED,
            None => d,
            Some(true) if d % 3 == 2 => self.piston_equation(),
            Some(_) => DOF_DROPPED,
        }
    }

    /// How many times the piston's displacement dof `d` adds to its
    /// original's (a z dof of a periodic image `periods` cells above, or
    /// below when negative); zero for every other dof. The image's force
    /// acts on its original and, that many times, on the piston.
    pub fn piston_coupling(&self, d: usize) -> f64 {
        match self.rules[d] {
            Rule::Image { periods, .. } => f64::from(periods),
            _ => 0.0,
        }
    }

    /// True when some dof is a periodic image whose z displacement follows
    /// the piston (the cell is periodic along z).
    pub fn has_piston_coupling(&self) -> bool {
        self.rules
            .iter()
            .any(|r| matches!(r, Rule::Image { periods, .. } if *periods != 0))
    }

    /// Makes nodes periodic images: `(image, original, periods)` says node
    /// `image` is node `original` moved by `periods` = (a, b, c) periods of
    /// the cell (a Lx, b Ly, c (Lz + U)). An image's displacement is its
    /// original's, plus c U along z: it has no equation of its own. Image
    /// nodes must be free (on no plane) and originals must not be images.
    pub fn set_images(&mut self, images: &[(usize, usize, [i8; 3])]) -> Result<(), SolverError> {
        let nodes = self.rules.len() / 3;
        for &(image, original, periods) in images {
            if image >= nodes || original >= nodes || image == original {
                return Err(SolverError::Unsupported(format!(
                    "periodic image node {image} of node {original}: not two nodes of the mesh ({nodes})"
                )));
            }
            for axis in 0..3 {
                let (di, d) = (3 * image + axis, 3 * original + axis);
                if self.rules[di] != Rule::Free || matches!(self.rules[d], Rule::Image { .. }) {
                    return Err(SolverError::Unsupported(format!(
                        "periodic image node {image} of node {original}: an image must be free and its original no image"
                    )));
                }
                let periods = if axis == 2 { periods[2] } else { 0 };
                self.rules[di] = Rule::Image {
                    original: d,
                    periods,
                };
            }
        }
        // An original set after its image was made one.
        for d in 0..self.rules.len() {
            if let Rule::Image { original, .. } = self.rules[d]
                && matches!(self.rules[original], Rule::Image { .. })
            {
                return Err(SolverError::Unsupported(format!(
                    "periodic image node {}: its original {} is an image",
                    d / 3,
                    original / 3
                )));
            }
        }
        Ok(())
    }

    /// Holds the free dofs `dofs` at zero displacement (the rigid
    /// translation of a periodic cell, which nothing else fixes).
    pub fn pin(&mut self, dofs: &[usize]) -> Result<(), SolverError> {
        for &d in dofs {
            if self.rules.get(d) != Some(&Rule::Free) {
                return Err(SolverError::Unsupported(format!(
                    "dof {d} cannot be pinned: it is not a free dof of the mesh"
                )));
            }
        }
        for &d in dofs {
            self.rules[d] = Rule::Pinned;
        }
        Ok(())
    }

    /// Could dof `d` ever be held on the piston plane?
    fn may_follow_piston(&self, d: usize) -> bool {
        d % 3 == 2
            && matches!(
                self.rules[d],
                Rule::Bilateral { high: true } | Rule::Unilateral { high: true, .. }
            )
    }

    /// Equation cliques of the elements of `body` for every possible contact
    /// state: the element's own dofs, plus the piston equation when any of
    /// its dofs may follow the piston. The sparsity pattern built from them
    /// never changes during a run.
    pub fn element_cliques(&self, body: &tidens_fem::Body) -> Vec<Vec<usize>> {
        (0..body.element_count())
            .map(|e| self.clique(&body.element_dofs(e)))
            .collect()
    }

    /// The equations a coupling of body dofs `dofs` may touch in any contact
    /// state: their own, and the piston's if any of them may follow it.
    pub fn clique(&self, dofs: &[usize]) -> Vec<usize> {
        // An image couples through its original (and the piston, along z).
        let own = |d: usize| match self.rules[d] {
            Rule::Image { original, .. } => original,
            _ => d,
        };
        let mut eqs: Vec<usize> = dofs.iter().map(|&d| own(d)).collect();
        if dofs
            .iter()
            .any(|&d| self.may_follow_piston(own(d)) || self.piston_coupling(d) != 0.0)
        {
            eqs.push(self.piston_equation());
        }
        eqs.sort_unstable();
        eqs.dedup();
        eqs
    }

    /// Puts every held dof on its plane, pinned dofs at zero and images
    /// where their originals (and the cell's height) put them.
    pub fn enforce(&self, u: &mut [f64], piston: f64) {
        for d in 0..self.rules.len() {
            if self.rules[d] == Rule::Pinned {
                u[d] = 0.0;
            } else if let Some(high) = self.held_on(d) {
                u[d] = self.plane_position(d % 3, high, piston) - self.x0[d];
            } else if let Some(value) = self.ties[d] {
                u[d] = value;
            }
        }
        for d in 0..self.rules.len() {
            if let Rule::Image { original, periods } = self.rules[d] {
                u[d] = u[original] + f64::from(periods) * piston;
            }
        }
    }

    /// Penetration of a free unilateral dof into a plane it may touch \[mm\]
    /// (positive when inside the plane), with that plane.
    fn penetration(&self, d: usize, u: &[f64], piston: f64) -> Option<(f64, bool)> {
        let Rule::Unilateral { low, high } = self.rules[d] else {
            return None;
        };
        let axis = d % 3;
        let x = self.x0[d] + u[d];
        let mut best: Option<(f64, bool)> = None;
        if high {
            best = Some((x - self.plane_position(axis, true, piston), true));
        }
        if low {
            let p = -x;
            if best.is_none_or(|(b, _)| p > b) {
                best = Some((p, false));
            }
        }
        best
    }

    /// Largest penetration of any free surface dof into a plane \[mm\].
    pub fn max_penetration(&self, u: &[f64], piston: f64) -> f64 {
        self.unilateral
            .iter()
            .filter(|&&d| self.contact[d].is_none())
            .filter_map(|&d| self.penetration(d, u, piston).map(|(p, _)| p))
            .fold(0.0, f64::max)
    }

    /// Updates the active set from the current state: free dofs that have
    /// penetrated a plane by more than `gap_tol` \[mm\] come into contact (they
    /// are left where they are: [`Constraints::offsets`] says how far they are
    /// off their plane, for the next linear solve to move them onto it), dofs
    /// in contact whose reaction has become tensile by
    /// more than `force_tol` \[N\] are released (only with `release`: the
    /// reactions mean something at an equilibrium of the present set, not
    /// half-way through Newton). `f_int` is the internal force of the body;
    /// on a held dof it is the force the plane exerts. Returns the number of
    /// changes.
    pub fn update(
        &mut self,
        u: &[f64],
        piston: f64,
        f_int: &[f64],
        force_tol: f64,
        gap_tol: f64,
        release: bool,
    ) -> usize {
        let mut changes = 0;
        for k in 0..self.unilateral.len() {
            let d = self.unilateral[k];
            match self.contact[d] {
                Some(_) if !release || self.flips[d] >= MAX_FLIPS => {}
                Some(high) => {
                    // The plane pushes toward the box interior: -e on the high
                    // plane, +e on the low one. Anything else is tension.
                    let tensile = if high {
                        f_int[d] > force_tol
                    } else {
                        f_int[d] < -force_tol
                    };
                    if tensile {
                        self.contact[d] = None;
                        self.flips[d] += 1;
                        changes += 1;
                    }
                }
                None => {
                    if let Some((p, high)) = self.penetration(d, u, piston)
                        && p > gap_tol
                    {
                        self.contact[d] = Some(high);
                        self.flips[d] += 1;
                        changes += 1;
                    }
                }
            }
        }
        if changes > 0 {
            self.update_ties(u);
        }
        changes
    }

    /// Held dofs that are off their plane, with the displacement that puts
    /// them on it \[mm\] (dofs that have just come into contact).
    pub fn offsets(&self, u: &[f64], piston: f64) -> Vec<(usize, f64)> {
        self.unilateral
            .iter()
            .filter_map(|&d| {
                let high = self.contact[d]?;
                let delta = self.plane_position(d % 3, high, piston) - self.x0[d] - u[d];
                (delta != 0.0).then_some((d, delta))
            })
            .collect()
    }

    /// Starts a new step: every dof may change its contact state again.
    pub fn reset_flips(&mut self) {
        self.flips.fill(0);
    }

    /// Contact state of the unilateral dofs (and ties), to save and restore
    /// around a step.
    pub fn contact_state(&self) -> PlaneContactState {
        PlaneContactState {
            contact: self.contact.clone(),
            ties: self.ties.clone(),
        }
    }

    /// Restores a state saved by [`Constraints::contact_state`].
    pub fn set_contact_state(&mut self, state: PlaneContactState) {
        self.contact = state.contact;
        self.ties = state.ties;
    }

    /// Number of surface dofs in contact with each plane, indexed `2 axis + high`.
    pub fn contact_counts(&self) -> [usize; 6] {
        let mut c = [0; 6];
        for &d in &self.unilateral {
            if let Some(high) = self.contact[d] {
                c[2 * (d % 3) + high as usize] += 1;
            }
        }
        c
    }

    /// True for dofs held on a plane (bilateral or in contact), or tied to
    /// one.
    pub fn is_held(&self, d: usize) -> bool {
        self.held_on(d).is_some() || self.ties[d].is_some()
    }

    /// With tied planes: ties the free tangential dofs of every node in
    /// contact with a plane where they are now, and frees those of nodes no
    /// longer in contact.
    fn update_ties(&mut self, u: &[f64]) {
        if !self.tied_planes {
            return;
        }
        for node in 0..self.rules.len() / 3 {
            let touching = (0..3).any(|i| self.contact[3 * node + i].is_some());
            for i in 0..3 {
                let d = 3 * node + i;
                if !touching {
                    self.ties[d] = None;
                } else if self.held_on(d).is_none() && self.ties[d].is_none() {
                    self.ties[d] = Some(u[d]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn periodic_images_follow_their_originals_and_the_cell_height() {
        // Node 0 free, node 1 on the piston, nodes 2 and 3 their images one
        // period along x and one cell height up and down; node 4 pinned.
        let nodes = [
            [0.5, 0.5, 0.5],
            [0.5, 0.5, 1.0],
            [1.5, 0.5, 1.5],
            [0.5, 1.5, 0.0],
            [0.2, 0.2, 0.2],
        ];
        let faces: [(&[usize], FaceKind); 1] = [(
            &[1],
            FaceKind::Plane {
                axis: 2,
                high: true,
            },
        )];
        let mut c = Constraints::new(&nodes, faces, [1.0; 3], true, false).unwrap();
        c.set_images(&[(2, 0, [1, 0, 1]), (3, 1, [0, 1, -1])])
            .unwrap();
        c.pin(&[12, 13, 14]).unwrap();
        let map = c.equation_map();
        let piston = c.piston_equation();
        assert_eq!(&map[0..3], &[0, 1, 2]);
        assert_eq!(&map[6..9], &[0, 1, 2]);
        assert_eq!(
            map[11], piston,
            "the image of a node on the piston follows it"
        );
        assert_eq!(&map[12..15], &[DOF_DROPPED; 3]);
        assert_eq!(c.piston_coupling(8), 1.0);
        assert_eq!(c.piston_coupling(11), -1.0);
        assert_eq!(c.piston_coupling(6), 0.0);
        assert!(c.has_piston_coupling());
        let mut u: Vec<f64> = (0..15).map(|d| 0.01 * d as f64).collect();
        c.enforce(&mut u, -0.1);
        assert_eq!(&u[6..8], &[u[0], u[1]]);
        assert!((u[8] - (u[2] - 0.1)).abs() < 1e-15);
        // Node 1 on the piston plane (Lz + U = 0.9): its image 0.9 below.
        assert!((u[5] + 0.1).abs() < 1e-15);
        assert!((u[11] - (u[5] + 0.1)).abs() < 1e-15);
        assert_eq!(&u[12..15], &[0.0; 3]);
        // An image couples through its original, and along z the piston.
        assert_eq!(c.clique(&[6, 7]), vec![0, 1]);
        assert_eq!(c.clique(&[8, 3]), vec![2, 3, piston]);
    }

    #[test]
    fn an_image_must_be_free_and_its_original_no_image() {
        let nodes = [[0.5; 3], [0.5, 0.5, 1.0], [1.5, 0.5, 0.5], [2.5, 0.5, 0.5]];
        let faces: [(&[usize], FaceKind); 1] = [(
            &[1],
            FaceKind::Plane {
                axis: 2,
                high: true,
            },
        )];
        let fresh = || Constraints::new(&nodes, faces, [1.0; 3], true, false).unwrap();
        assert!(
            fresh().set_images(&[(1, 0, [0, 0, 1])]).is_err(),
            "image on a plane"
        );
        assert!(
            fresh()
                .set_images(&[(2, 0, [1, 0, 0]), (3, 2, [1, 0, 0])])
                .is_err()
        );
        assert!(
            fresh()
                .set_images(&[(3, 2, [1, 0, 0]), (2, 0, [1, 0, 0])])
                .is_err()
        );
        assert!(fresh().set_images(&[(2, 9, [1, 0, 0])]).is_err());
        assert!(fresh().pin(&[5]).is_err(), "a dof on the piston");
    }

    /// One curved-surface node touching the piston (z = Lz) of a unit box,
    /// and one free curved node inside it: their z dofs are unilateral.
    fn two_nodes() -> Constraints {
        let nodes = [[0.5, 0.5, 1.0], [0.5, 0.5, 0.5]];
        let faces: [(&[usize], FaceKind); 1] = [(&[0, 1], FaceKind::Curved)];
        Constraints::new(&nodes, faces, [1.0; 3], true, false).unwrap()
    }

    const Z0: usize = 2; // z dof of the node on the piston
    const Z1: usize = 5; // z dof of the inner node

    #[test]
    fn contact_closes_on_penetration_and_opens_on_tension() {
        let mut c = two_nodes();
        let mut u = vec![0.0; 6];
        let mut f = vec![0.0; 6];
        // The node on the piston starts in contact, held on the piston's equation.
        assert_eq!(c.equation_map()[Z0], c.piston_equation());
        // Compression (the piston pushes it down: -z on the high plane) keeps it.
        f[Z0] = -1.0;
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, true), 0);
        // Tension releases it; a tensile force within the tolerance does not.
        f[Z0] = 1e-7;
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, true), 0);
        f[Z0] = 1e-3;
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, true), 1);
        assert_eq!(c.equation_map()[Z0], Z0);
        // The inner node moving up through the lowered piston is caught, and
        // the next solve is told how far it is off the plane.
        let piston = -0.4;
        u[Z0] = -0.45; // the released node stays below the piston (z = 0.55)
        u[Z1] = 0.2; // at z = 0.7 > 0.6
        f.fill(0.0);
        assert_eq!(c.update(&u, piston, &f, 1e-6, 1e-9, true), 1);
        assert_eq!(c.equation_map()[Z1], c.piston_equation());
        let offsets = c.offsets(&u, piston);
        assert!(
            offsets
                .iter()
                .any(|&(d, delta)| d == Z1 && (delta + 0.1).abs() < 1e-12)
        );
        // A penetration within the gap tolerance is not a contact.
        let mut c = two_nodes();
        let mut u = vec![0.0; 6];
        u[Z1] = 1e-10; // 1e-10 above the piston lowered to z = 0.5
        assert_eq!(c.update(&u, -0.5, &f, 1e-6, 1e-9, true), 0);
        u[Z1] = 1e-8;
        assert_eq!(c.update(&u, -0.5, &f, 1e-6, 1e-9, true), 1);
    }

    #[test]
    fn a_dof_that_chatters_stays_in_contact_until_the_next_step() {
        let mut c = two_nodes();
        let u = vec![0.0; 6];
        let mut f = vec![0.0; 6];
        let mut under = u.clone();
        under[Z0] = 1e-3; // pushed through the piston while free
        // Release (tension) and catch (penetration) alternately: each is a
        // flip, until MAX_FLIPS of them in this step.
        let mut flips = 0;
        for _ in 0..10 {
            let released = c.equation_map()[Z0] == Z0;
            f[Z0] = 1.0; // tensile on the high plane
            let changes = if released {
                c.update(&under, 0.0, &f, 1e-6, 1e-9, true)
            } else {
                c.update(&u, 0.0, &f, 1e-6, 1e-9, true)
            };
            flips += changes;
        }
        assert_eq!(flips, usize::from(MAX_FLIPS));
        // The last flip was a catch: it stays held, tension or not, ...
        assert_eq!(c.equation_map()[Z0], c.piston_equation());
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, true), 0);
        // ... until the next step lets it change again.
        c.reset_flips();
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, true), 1);
        assert_eq!(c.equation_map()[Z0], Z0);
    }

    #[test]
    fn contacts_are_released_only_when_asked_but_always_caught() {
        let mut c = two_nodes();
        let mut u = vec![0.0; 6];
        let mut f = vec![0.0; 6];
        f[Z0] = 1.0; // tensile on the piston
        // Away from equilibrium the tension is not trusted: no release.
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, false), 0);
        assert_eq!(c.equation_map()[Z0], c.piston_equation());
        // A penetrating node is caught all the same.
        u[Z1] = 0.6; // z = 1.1 > 1
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, false), 1);
        assert_eq!(c.equation_map()[Z1], c.piston_equation());
        // At equilibrium the tension releases it.
        assert_eq!(c.update(&u, 0.0, &f, 1e-6, 1e-9, true), 1);
        assert_eq!(c.equation_map()[Z0], Z0);
    }
}
