//! The global tangent system: element tangents gathered over the body's dofs,
//! mapped to equations through the contact state of the rigid planes, plus
//! the particle-contact terms.
//!
//! Two stages. The element tangents are gathered in parallel into the
//! dof-level pattern of the mesh ([`ElementAssembler`]: each entry summed
//! over its elements in element order, the same bits with any thread count).
//! The dof-level values are then mapped to equations serially, in dof order:
//! a dof held on a fixed plane is eliminated (its row and column dropped, a
//! unit diagonal kept), a dof held on the piston plane shares the piston's
//! equation (its row and column summed into the piston's), a free dof keeps
//! its own. The equation pattern covers every contact state (each element's
//! dofs plus the piston's equation where a dof may follow the piston) and
//! grows only for new particle-contact couplings, so its symbolic
//! factorisation is reused across steps.

use crate::constraints::Constraints;
use crate::evaluation::Evaluation;
use std::collections::BTreeSet;
use tidens_contact::{ContactEvaluation, ParticleContact};
use tidens_fem::{Body, DOF_DROPPED, ElementAssembler, SparseSystem};

/// No slot: the entry is not in the pattern.
const NO_SLOT: usize = usize::MAX;

/// The equation system of a scene and the plan that fills it.
pub struct Assembler {
    /// Dof-level pattern and gather plan of the element tangents.
    elements: ElementAssembler,
    /// Dof-level values of the last gathered element tangents.
    dof_values: Vec<f64>,
    /// Equation cliques of the elements (their dofs, plus the piston's
    /// equation where a dof may follow it).
    element_cliques: Vec<Vec<usize>>,
    /// Equation cliques of the couplings that hold for the whole run (the
    /// rotation frames of a periodic cell, [`Assembler::add_couplings`]).
    coupling_cliques: BTreeSet<Vec<usize>>,
    /// Equation cliques of the particle-contact couplings added so far.
    contact_cliques: BTreeSet<Vec<usize>>,
    /// The equation-level system (body dofs, then the piston's equation).
    system: SparseSystem,
    /// For each dof-level slot `(r, c)`, the slot of `(r, c)` in `system`.
    own_slot: Vec<usize>,
    /// For each column `c`, the slot of `(piston, c)` in `system`.
    piston_row: Vec<usize>,
    /// For each row `r`, the slot of `(r, piston)` in `system`.
    piston_column: Vec<usize>,
    /// The slot of `(piston, piston)`.
    piston_diagonal: usize,
    /// Times the pattern grew for new particle-contact couplings.
    pattern_rebuilds: usize,
    /// For each dof, how many times the piston's displacement adds to it
    /// (z dofs of periodic images above or below the cell; see
    /// [`Constraints::piston_coupling`]); empty when none does.
    piston_coupling: Vec<f64>,
}

impl Assembler {
    /// The system of `body` under the plane constraints `constraints`.
    pub fn new(body: &Body, constraints: &Constraints) -> Self {
        let dofs: Vec<usize> = (0..body.element_count())
            .flat_map(|e| body.element_dofs(e))
            .collect();
        let elements = ElementAssembler::new(body.dof_count(), 3 * body.kind().nodes(), &dofs);
        let element_cliques = constraints.element_cliques(body);
        let piston_coupling = if constraints.has_piston_coupling() {
            (0..body.dof_count())
                .map(|d| constraints.piston_coupling(d))
                .collect()
        } else {
            Vec::new()
        };
        let mut a = Self {
            piston_coupling,
            dof_values: vec![0.0; elements.nnz()],
            elements,
            element_cliques,
            coupling_cliques: BTreeSet::new(),
            contact_cliques: BTreeSet::new(),
            system: SparseSystem::from_cliques(0, std::iter::empty()),
            own_slot: Vec::new(),
            piston_row: Vec::new(),
            piston_column: Vec::new(),
            piston_diagonal: NO_SLOT,
            pattern_rebuilds: 0,
        };
        a.rebuild();
        a
    }

    /// The equation-level system last assembled.
    pub fn system(&self) -> &SparseSystem {
        &self.system
    }

    /// Times the pattern grew for new particle contacts.
    pub fn pattern_rebuilds(&self) -> usize {
        self.pattern_rebuilds
    }

    /// Internal force of the body (length `3 * nodes`) \[N\]: the element
    /// forces gathered in parallel, each entry in element order.
    pub fn internal_force(&self, body: &tidens_fem::BodyEvaluation) -> Vec<f64> {
        let mut f = vec![0.0; self.elements.dim()];
        self.elements.assemble_vector(body.residuals(), &mut f);
        f
    }

    /// Builds the equation pattern and the slot maps from the cliques.
    fn rebuild(&mut self) {
        let n = self.elements.dim();
        let cliques = self
            .element_cliques
            .iter()
            .chain(self.coupling_cliques.iter())
            .chain(self.contact_cliques.iter());
        self.system = SparseSystem::from_cliques(n + 1, cliques.map(|c| c.as_slice()));
        let (col_ptr, row_idx) = (self.elements.col_ptr(), self.elements.row_idx());
        self.own_slot = (0..n)
            .flat_map(|c| (col_ptr[c]..col_ptr[c + 1]).map(move |k| (row_idx[k], c)))
            .map(|(r, c)| self.system.position(r, c).unwrap_or(NO_SLOT))
            .collect();
        self.piston_row = (0..n)
            .map(|c| self.system.position(n, c).unwrap_or(NO_SLOT))
            .collect();
        self.piston_column = (0..n)
            .map(|r| self.system.position(r, n).unwrap_or(NO_SLOT))
            .collect();
        self.piston_diagonal = self.system.position(n, n).unwrap_or(NO_SLOT);
    }

    /// Fills the system with the tangents of `eval` through the equation
    /// map `map` (see [`Constraints::equation_map`]); eliminated dofs keep a
    /// unit diagonal. False when a contact term fell outside the pattern
    /// (grow it with [`Assembler::grow`] and assemble again); the entries
    /// outside are left out.
    pub fn assemble(&mut self, eval: &Evaluation, map: &[usize]) -> bool {
        self.assemble_counting(eval, map) == 0
    }

    /// [`Assembler::assemble`], returning how many entries fell outside
    /// the pattern.
    pub fn assemble_counting(&mut self, eval: &Evaluation, map: &[usize]) -> usize {
        self.elements
            .assemble_matrix(eval.body.tangents(), &mut self.dof_values);
        self.system.clear();
        let n = self.elements.dim();
        let (col_ptr, row_idx) = (self.elements.col_ptr(), self.elements.row_idx());
        let mut outside = 0;
        for c in 0..n {
            let mc = map[c];
            if mc == DOF_DROPPED {
                continue;
            }
            for k in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[k];
                let mr = map[r];
                let slot = match (mr == r, mc == c) {
                    _ if mr == DOF_DROPPED => continue,
                    (true, true) => self.own_slot[k],
                    // A free row in the piston's column, and conversely.
                    (true, false) => self.piston_column[r],
                    (false, true) => self.piston_row[c],
                    (false, false) => self.piston_diagonal,
                };
                if slot == NO_SLOT {
                    outside += 1;
                } else {
                    self.system.add_at(slot, self.dof_values[k]);
                }
            }
        }
        let coupled = |t: &tidens_contact::ContactTerm| {
            !self.piston_coupling.is_empty()
                && t.dofs.iter().any(|&d| self.piston_coupling[d] != 0.0)
        };
        // The piston as one more dof after the body's, on its equation.
        let map_with_piston: Vec<usize> = if eval.contact.terms.iter().any(coupled) {
            map.iter().copied().chain([n]).collect()
        } else {
            Vec::new()
        };
        for t in &eval.contact.terms {
            outside += if coupled(t) {
                let (dofs, tangent) =
                    with_piston(&t.dofs, &t.tangent, |d| self.piston_coupling[d], n);
                self.system.add_block(&dofs, &tangent, &map_with_piston)
            } else {
                self.system.add_block(&t.dofs, &t.tangent, map)
            };
        }
        for (dofs, tangent) in &eval.rotation_tangents {
            outside += self.system.add_block(dofs, tangent, map);
        }
        for (d, &k) in eval.drag_diagonal.iter().enumerate() {
            if k != 0.0 && map[d] == d {
                self.system.add(d, d, k);
            }
        }
        for (d, &m) in map.iter().enumerate() {
            if m != d {
                self.system.add(d, d, 1.0);
            }
        }
        outside
    }

    /// Adds the couplings of the contact terms of `contact` to the pattern
    /// (which only grows): each slave node with every facet around its
    /// master facet, so that sliding onto a neighbouring facet needs no new
    /// pattern. The symbolic factorisation must be redone after it.
    pub fn grow(
        &mut self,
        contact: &ContactEvaluation,
        particles: &ParticleContact,
        constraints: &Constraints,
    ) {
        for t in &contact.terms {
            let dofs = particles.coupling_dofs(t);
            let mut clique = constraints.clique(&dofs);
            clique.sort_unstable();
            self.contact_cliques.insert(clique);
        }
        self.rebuild();
        self.pattern_rebuilds += 1;
    }

    /// Adds dense couplings among each set of `dofs` to the pattern for
    /// the whole run (the particles' rotation frames of a periodic cell):
    /// [`Assembler::forget_contacts`] keeps them.
    pub fn add_couplings(
        &mut self,
        sets: impl IntoIterator<Item = Vec<usize>>,
        constraints: &Constraints,
    ) {
        for dofs in sets {
            let mut clique = constraints.clique(&dofs);
            clique.sort_unstable();
            self.coupling_cliques.insert(clique);
        }
        self.rebuild();
    }

    /// Drops the couplings grown for particle contacts (and their count),
    /// keeping the elements' and those of [`Assembler::add_couplings`]: the
    /// pattern is then the one the run started with.
    pub fn forget_contacts(&mut self) {
        self.contact_cliques.clear();
        self.pattern_rebuilds = 0;
        self.rebuild();
    }

    /// `K v` over the body dofs, for `v` given by its non-zero entries, from
    /// the element tangents last gathered (by [`Assembler::assemble`] of
    /// `eval`) and the contact tangents of `eval`.
    pub fn tangent_times(&self, eval: &Evaluation, entries: &[(usize, f64)]) -> Vec<f64> {
        let n = self.elements.dim();
        let mut v = vec![0.0; n];
        for &(d, x) in entries {
            v[d] = x;
        }
        let mut out = vec![0.0; n];
        let (col_ptr, row_idx) = (self.elements.col_ptr(), self.elements.row_idx());
        for &(c, x) in entries {
            for k in col_ptr[c]..col_ptr[c + 1] {
                out[row_idx[k]] += self.dof_values[k] * x;
            }
        }
        let blocks = eval
            .contact
            .terms
            .iter()
            .map(|t| (t.dofs.as_slice(), t.tangent.as_slice()))
            .chain(
                eval.rotation_tangents
                    .iter()
                    .map(|(d, k)| (d.as_slice(), k.as_slice())),
            );
        for (dofs, tangent) in blocks {
            if dofs.iter().all(|&d| v[d] == 0.0) {
                continue;
            }
            let m = dofs.len();
            for (p, &dp) in dofs.iter().enumerate() {
                out[dp] += (0..m).map(|q| tangent[p * m + q] * v[dofs[q]]).sum::<f64>();
            }
        }
        out
    }
}

/// A contact term's dofs and tangent with the piston's displacement as
/// one more dof (numbered `n`, after the body's): the term's dofs `u`
/// depend on the body's and the piston's as `u = u_body + c U` (`c` the
/// coupling of each dof), so its tangent `K` becomes `T^T K T` with
/// `T = [I | c]`.
fn with_piston(
    dofs: &[usize],
    tangent: &[f64],
    coupling: impl Fn(usize) -> f64,
    n: usize,
) -> (Vec<usize>, Vec<f64>) {
    let m = dofs.len();
    let c: Vec<f64> = dofs.iter().map(|&d| coupling(d)).collect();
    let k = |p: usize, q: usize| tangent[p * m + q];
    let mut out = vec![0.0; (m + 1) * (m + 1)];
    let mut corner = 0.0;
    for p in 0..m {
        let (mut row, mut col) = (0.0, 0.0);
        for q in 0..m {
            out[p * (m + 1) + q] = k(p, q);
            row += k(p, q) * c[q];
            col += c[q] * k(q, p);
        }
        out[p * (m + 1) + m] = row;
        out[m * (m + 1) + p] = col;
        corner += c[p] * row;
    }
    out[m * (m + 1) + m] = corner;
    let dofs = dofs.iter().copied().chain([n]).collect();
    (dofs, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_term_on_periodic_images_is_the_term_on_their_originals_and_the_piston() {
        // Three dofs, the last an image's z one period above (coupling 1),
        // the second one period below (-1): for any body motion v and
        // piston motion w, the extended tangent's quadratic form equals
        // the term's at the dofs' motion v + c w.
        let dofs = [4, 7, 11];
        let k = [4.0, -1.0, 0.5, -1.0, 3.0, 0.25, 0.5, 0.25, 2.0];
        let coupling = |d: usize| match d {
            7 => -1.0,
            11 => 1.0,
            _ => 0.0,
        };
        let (ext, k16) = with_piston(&dofs, &k, coupling, 20);
        assert_eq!(ext, vec![4, 7, 11, 20]);
        for (v, w) in [
            ([1.0, 0.0, 0.0], 0.0),
            ([0.3, -0.7, 0.2], 0.0),
            ([0.3, -0.7, 0.2], 1.3),
            ([0.0; 3], 1.0),
        ] {
            let u: Vec<f64> = dofs
                .iter()
                .zip(&v)
                .map(|(&d, x)| x + coupling(d) * w)
                .collect();
            let direct: f64 = (0..3)
                .flat_map(|p| (0..3).map(move |q| (p, q)))
                .map(|(p, q)| u[p] * k[3 * p + q] * u[q])
                .sum();
            let x = [v[0], v[1], v[2], w];
            let extended: f64 = (0..4)
                .flat_map(|p| (0..4).map(move |q| (p, q)))
                .map(|(p, q)| x[p] * k16[4 * p + q] * x[q])
                .sum();
            assert!(
                (direct - extended).abs() < 1e-14,
                "{v:?} {w}: {direct} against {extended}"
            );
        }
        // Symmetric, as the term's.
        for p in 0..4 {
            for q in 0..4 {
                assert_eq!(k16[4 * p + q], k16[4 * q + p]);
            }
        }
    }
}
