//! Sparse linear solves with faer, reusing the symbolic factorisation.
//!
//! The tangent of the mean-dilatation element with frictionless rigid planes
//! is symmetric, so the default is a supernodal Cholesky (LL^T) factorisation
//! with AMD ordering, whose symbolic part is computed once for the fixed
//! sparsity pattern. If the matrix is not numerically positive definite (which
//! the consistent tangent of a large viscoplastic step may be), the same
//! symbolic structure serves a Bunch-Kaufman LBL^T factorisation, which handles
//! indefinite symmetric matrices. Sequential kernels keep the result identical
//! for any thread count (DESIGN.md measured no gain from two threads at these
//! sizes).

use crate::error::SolverError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use tidens_fem::SparseSystem;

/// Which factorisation solved the last system.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Factorization {
    /// Cholesky LL^T (symmetric positive definite).
    Llt,
    /// Bunch-Kaufman LBL^T (symmetric indefinite).
    Lblt,
}

/// Counts of factorisations done, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FactorizationCounts {
    pub llt: usize,
    pub lblt: usize,
}

/// A reusable sparse symmetric solver for one sparsity pattern.
#[derive(Default)]
pub struct LinearSolver {
    symbolic: Option<SymbolicCholesky<usize>>,
    values: Vec<f64>,
    pub counts: FactorizationCounts,
}

impl LinearSolver {
    /// Solves `A x = b` in place (`rhs` holds `b` on entry, `x` on exit),
    /// reading the lower triangle of `A`.
    pub fn solve(
        &mut self,
        sys: &SparseSystem,
        rhs: &mut [f64],
    ) -> Result<Factorization, SolverError> {
        let n = sys.dim();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, sys.col_ptr(), None, sys.row_idx());
        let mat = SparseColMatRef::new(sym, sys.values());
        if self.symbolic.is_none() {
            let s = factorize_symbolic_cholesky(
                sym,
                Side::Lower,
                SymmetricOrdering::Amd,
                CholeskySymbolicParams::default(),
            )
            .map_err(|e| SolverError::Linear(format!("symbolic factorisation: {e:?}")))?;
            self.values = vec![0.0; s.len_val()];
            self.symbolic = Some(s);
        }
        let symbolic = self
            .symbolic
            .as_ref()
            .ok_or_else(|| SolverError::Linear("no symbolic factorisation".into()))?;
        if symbolic.nrows() != n {
            return Err(SolverError::Linear(format!(
                "system of size {n} does not match the symbolic factorisation ({})",
                symbolic.nrows()
            )));
        }
        let par = Par::Seq;
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        let llt = symbolic.factorize_numeric_llt::<f64>(
            &mut self.values,
            mat,
            Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut MemBuffer::new(
                symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
            )),
            Default::default(),
        );
        if let Ok(llt) = llt {
            self.counts.llt += 1;
            llt.solve_in_place_with_conj(
                Conj::No,
                rhs_mat,
                par,
                MemStack::new(&mut MemBuffer::new(
                    symbolic.solve_in_place_scratch::<f64>(1, par),
                )),
            );
            return check_finite(rhs, Factorization::Llt);
        }
        // Not positive definite: symmetric indefinite factorisation.
        let mut subdiag = vec![0.0; n];
        let mut fwd = vec![0usize; n];
        let mut bwd = vec![0usize; n];
        let lblt = symbolic.factorize_numeric_intranode_lblt::<f64>(
            &mut self.values,
            &mut subdiag,
            &mut fwd,
            &mut bwd,
            mat,
            Side::Lower,
            par,
            MemStack::new(&mut MemBuffer::new(
                symbolic.factorize_numeric_intranode_lblt_scratch::<f64>(par, Default::default()),
            )),
            Default::default(),
        );
        self.counts.lblt += 1;
        lblt.solve_in_place_with_conj(
            Conj::No,
            rhs_mat,
            par,
            MemStack::new(&mut MemBuffer::new(
                symbolic.solve_in_place_scratch::<f64>(1, par),
            )),
        );
        check_finite(rhs, Factorization::Lblt)
    }
}

fn check_finite(x: &[f64], kind: Factorization) -> Result<Factorization, SolverError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(kind)
    } else {
        Err(SolverError::Linear(format!(
            "{kind:?} solve gave a non-finite solution (singular tangent)"
        )))
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
            assert_eq!(solver.solve(&a, &mut b).unwrap(), kind);
            let err = b
                .iter()
                .zip(&x_true)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-10, "shift {shift}: error {err}");
        }
        assert_eq!(solver.counts, FactorizationCounts { llt: 2, lblt: 1 });
    }
}
