//! Sparse linear solves with faer, reusing the symbolic factorisation.
//!
//! The tangent of the mean-dilatation element with frictionless rigid planes
//! is symmetric, so the default is a supernodal Cholesky (LL^T) factorisation
//! with AMD ordering, whose symbolic part is computed once for the fixed
//! sparsity pattern. If the matrix is not numerically positive definite (which
//! the consistent tangent of a large viscoplastic step may be), the same
//! symbolic structure serves a Bunch-Kaufman LBL^T factorisation, which handles
//! indefinite symmetric matrices. Sequential kernels keep the result identical
//! for any thread count.

use crate::error::SolverError;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, IntranodeLbltRef, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use tidens_fem::SparseSystem;

/// Which factorisation holds the current factor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Factorization {
    /// Cholesky LL^T (symmetric positive definite).
    Llt,
    /// Bunch-Kaufman LBL^T (symmetric indefinite).
    Lblt,
}

/// Counts of factorisations and solves done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FactorizationCounts {
    pub llt: usize,
    pub lblt: usize,
    /// Solves, including those reusing an earlier factor.
    pub solves: usize,
}

/// The numeric factor of the last factorised matrix.
enum Numeric {
    None,
    Llt,
    Lblt {
        subdiag: Vec<f64>,
        fwd: Vec<usize>,
        bwd: Vec<usize>,
    },
}

/// A reusable sparse symmetric solver for one sparsity pattern: the symbolic
/// structure is computed once, the numeric factor is kept until the next
/// [`LinearSolver::factorize`], so that several right-hand sides (modified
/// Newton iterations) can be solved with one factor.
pub struct LinearSolver {
    symbolic: Option<SymbolicCholesky<usize>>,
    values: Vec<f64>,
    numeric: Numeric,
    pub counts: FactorizationCounts,
}

impl Default for LinearSolver {
    fn default() -> Self {
        Self {
            symbolic: None,
            values: Vec::new(),
            numeric: Numeric::None,
            counts: FactorizationCounts::default(),
        }
    }
}

fn out_of_memory(what: &str, bytes: usize) -> SolverError {
    SolverError::Linear(format!(
        "out of memory: the {what} needs {:.2} GB; use a coarser mesh level",
        bytes as f64 / 1e9
    ))
}

fn buffer(req: StackReq, what: &str) -> Result<MemBuffer, SolverError> {
    MemBuffer::try_new(req).map_err(|_| out_of_memory(what, req.size_bytes()))
}

impl LinearSolver {
    /// True when a numeric factor is available for [`LinearSolver::solve`].
    pub fn has_factor(&self) -> bool {
        !matches!(self.numeric, Numeric::None)
    }

    /// Forgets the numeric factor.
    pub fn invalidate(&mut self) {
        self.numeric = Numeric::None;
    }

    /// Forgets the symbolic structure too (the sparsity pattern changed).
    pub fn reset_pattern(&mut self) {
        self.numeric = Numeric::None;
        self.symbolic = None;
        self.values = Vec::new();
    }

    /// Factorises `A` (its lower triangle is read).
    pub fn factorize(&mut self, sys: &SparseSystem) -> Result<Factorization, SolverError> {
        self.numeric = Numeric::None;
        let n = sys.dim();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, sys.col_ptr(), None, sys.row_idx());
        let mat = SparseColMatRef::new(sym, sys.values());
        if self.symbolic.as_ref().is_none_or(|s| s.nrows() != n) {
            let s = factorize_symbolic_cholesky(
                sym,
                Side::Lower,
                SymmetricOrdering::Amd,
                CholeskySymbolicParams::default(),
            )
            .map_err(|e| SolverError::Linear(format!("symbolic factorisation: {e:?}")))?;
            let len = s.len_val();
            let mut values = Vec::new();
            values
                .try_reserve_exact(len)
                .map_err(|_| out_of_memory("sparse factor", 8 * len))?;
            values.resize(len, 0.0);
            self.values = values;
            self.symbolic = Some(s);
        }
        let symbolic = self
            .symbolic
            .as_ref()
            .ok_or_else(|| SolverError::Linear("no symbolic factorisation".into()))?;
        let par = Par::Seq;
        let mut scratch = buffer(
            symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
            "factorisation workspace",
        )?;
        let llt = symbolic.factorize_numeric_llt::<f64>(
            &mut self.values,
            mat,
            Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut scratch),
            Default::default(),
        );
        if llt.is_ok() {
            self.counts.llt += 1;
            self.numeric = Numeric::Llt;
            return Ok(Factorization::Llt);
        }
        // Not positive definite: symmetric indefinite factorisation.
        let mut subdiag = vec![0.0; n];
        let mut fwd = vec![0usize; n];
        let mut bwd = vec![0usize; n];
        let mut scratch = buffer(
            symbolic.factorize_numeric_intranode_lblt_scratch::<f64>(par, Default::default()),
            "factorisation workspace",
        )?;
        symbolic.factorize_numeric_intranode_lblt::<f64>(
            &mut self.values,
            &mut subdiag,
            &mut fwd,
            &mut bwd,
            mat,
            Side::Lower,
            par,
            MemStack::new(&mut scratch),
            Default::default(),
        );
        self.counts.lblt += 1;
        self.numeric = Numeric::Lblt { subdiag, fwd, bwd };
        Ok(Factorization::Lblt)
    }

    /// Solves `A x = b` in place with the current factor (`rhs` holds `b` on
    /// entry, `x` on exit).
    pub fn solve(&mut self, rhs: &mut [f64]) -> Result<(), SolverError> {
        let symbolic = self
            .symbolic
            .as_ref()
            .ok_or_else(|| SolverError::Linear("solve before factorisation".into()))?;
        let n = symbolic.nrows();
        if rhs.len() != n {
            return Err(SolverError::Linear(format!(
                "right-hand side of length {} for a system of size {n}",
                rhs.len()
            )));
        }
        let par = Par::Seq;
        let mut scratch = buffer(
            symbolic.solve_in_place_scratch::<f64>(1, par),
            "solve workspace",
        )?;
        let stack = MemStack::new(&mut scratch);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        match &self.numeric {
            Numeric::None => return Err(SolverError::Linear("no numeric factor".into())),
            Numeric::Llt => LltRef::new(symbolic, &self.values).solve_in_place_with_conj(
                Conj::No,
                rhs_mat,
                par,
                stack,
            ),
            Numeric::Lblt { subdiag, fwd, bwd } => {
                let perm = PermRef::new_checked(fwd, bwd, n);
                IntranodeLbltRef::new(symbolic, &self.values, subdiag, perm)
                    .solve_in_place_with_conj(Conj::No, rhs_mat, par, stack)
            }
        }
        self.counts.solves += 1;
        if rhs.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(SolverError::Linear(
                "the solve gave a non-finite solution (singular tangent)".into(),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1D Laplacian-like chain (SPD) and a shifted indefinite version.
    fn chain(n: usize, shift: f64) -> SparseSystem {
        let cliques: Vec<[usize; 2]> = (0..n - 1).map(|i| [i, i + 1]).collect();
        let mut s = SparseSystem::from_cliques(n, cliques.iter().map(|c| &c[..]));
        for i in 0..n - 1 {
            s.add_block(
                &[i, i + 1],
                &[1.0, -1.0, -1.0, 1.0],
                &(0..n).collect::<Vec<_>>(),
            );
        }
        for i in 0..n {
            s.add(i, i, 0.5 - shift);
        }
        s
    }

    #[test]
    fn solves_spd_and_indefinite_systems_with_one_symbolic_structure() {
        let n = 50;
        let mut solver = LinearSolver::default();
        for (shift, kind) in [
            (0.0, Factorization::Llt),
            (1.3, Factorization::Lblt),
            (0.0, Factorization::Llt),
        ] {
            let a = chain(n, shift);
            let x_true: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
            let mut b = a.mul_vec(&x_true);
            assert_eq!(solver.factorize(&a).unwrap(), kind);
            solver.solve(&mut b).unwrap();
            let err = b
                .iter()
                .zip(&x_true)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-10, "shift {shift}: error {err}");
        }
        assert_eq!(
            solver.counts,
            FactorizationCounts {
                llt: 2,
                lblt: 1,
                solves: 3
            }
        );
    }
}
