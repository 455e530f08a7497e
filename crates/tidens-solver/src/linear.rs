//! Sparse linear solves with faer, reusing the symbolic factorisation.
//!
//! The tangent of the mean-dilatation element with frictionless rigid planes
//! is symmetric, so the default is a supernodal Cholesky (LL^T) factorisation
//! whose symbolic part is computed once for the fixed sparsity pattern. If the
//! matrix is not numerically positive definite (which the consistent tangent
//! of a large viscoplastic step may be), the same symbolic structure serves a
//! Bunch-Kaufman LBL^T factorisation, which handles indefinite symmetric
//! matrices; indefinite tangents come in runs, so after a failed Cholesky
//! the next three factorisations use LBL^T directly (exact on positive-definite
//! matrices too).
//!
//! A large Cholesky factorisation (from [`PARALLEL_FACTOR_ENTRIES`] entries
//! on) runs on the threads of the current rayon pool (`RAYON_NUM_THREADS`;
//! all cores by default). faer still visits the supernodes in order and
//! splits each dense update among the threads by blocks of its output; on
//! one thread and on two the factor and the solution came out the same to
//! the last bit in the test below (1.2e7 factor entries), and the solution
//! did on blocks of hexahedra with 3.8e7 and 1.3e8 entries, so results do
//! not depend on the thread count. Smaller factors stay on one thread, where a second
//! one costs more than it gains. LBL^T and the triangular solves stay
//! sequential: faer's LBL^T on two threads gave a factor that differed in
//! its last bits.
//!
//! The fill-reducing ordering is nested dissection (METIS on the graph of
//! the nodes, see `ordering`), not faer's AMD: on these 3D meshes it halves
//! the floating-point work from mesh level 3 on. Numeric LL^T of the real
//! tangent of each cell pressed to rho = 0.75 (sc: 0.7) at 15 MPa, one core,
//! median CPU time, AMD -> nested dissection:
//!
//! | cell | level | equations | factor entries (10^6) | LL^T (ms) | change |
//! |---|---|---|---|---|---|
//! | sc  | 1 |   742 |  0.12 -> 0.11 |   0.90 -> 0.95 |  +6 % |
//! | bcc | 1 |  1483 |  0.28 -> 0.29 |   2.46 -> 2.81 | +14 % |
//! | fcc | 1 |  2965 |  0.53 -> 0.43 |   4.87 -> 4.88 |   0 % |
//! | sc2 | 1 |  5929 |  1.17 -> 1.06 |   12.9 -> 13.0 |  +1 % |
//! | sc  | 2 |  2173 |  0.71 -> 0.51 |   7.30 -> 5.65 | -23 % |
//! | bcc | 2 |  4345 |  1.40 -> 1.21 |   15.9 -> 15.3 |  -4 % |
//! | fcc | 2 |  8689 |  3.02 -> 2.17 |   38.0 -> 28.3 | -26 % |
//! | sc2 | 2 | 17377 |  5.75 -> 4.81 |   73.0 -> 64.5 | -12 % |
//! | sc  | 3 |  4792 |  2.35 -> 1.63 |   35.3 -> 21.5 | -39 % |
//! | bcc | 3 |  9583 |  5.49 -> 3.65 |   94.2 -> 55.4 | -41 % |
//! | fcc | 3 | 19165 | 10.11 -> 6.95 |  164 -> 93.6   | -43 % |
//! | sc2 | 3 | 38329 | 19.80 -> 14.66 | 358 -> 226    | -37 % |
//! | sc  | 4 | 11140 |  8.12 -> 5.31 |  184 -> 87.6   | -52 % |
//!
//! Bunch-Kaufman LBL^T gains as much (-36 % to -52 % at levels 3 and 4), the
//! solutions agree to 1e-12, and a whole run to that density takes 16 % to
//! 26 % less CPU time at level 3 (bcc, sc, fcc), 11 % less for fcc at level 2,
//! the same for bcc at level 2. The ordering costs 0.5 to 100 ms once per
//! pattern, about what AMD costs. Measured and not kept: AMD on the node
//! graph (the same factor: AMD already merges the three dofs of a node),
//! other supernode relaxations (-4 % to +20 %), a simplicial factor (4 to 8
//! times slower), and METIS options (separators tried, balance, seed: within
//! 3 %).

use crate::error::LinearError;
use crate::ordering::nested_dissection;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, IntranodeLbltRef, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use tidens_fem::SparseSystem;

/// The fill-reducing ordering of the symbolic factorisation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FillOrdering {
    /// Nested dissection (METIS) of the graph of the nodes (runs of equations
    /// with one pattern); AMD if METIS fails.
    #[default]
    NestedDissection,
    /// faer's approximate minimum degree on the equations.
    Amd,
}

/// Which factorisation holds the current factor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Factorization {
    /// Cholesky LL^T (symmetric positive definite).
    Llt,
    /// Bunch-Kaufman LBL^T (symmetric indefinite).
    Lblt,
}

/// Counts of factorisations and solves done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FactorizationCounts {
    pub llt: usize,
    pub lblt: usize,
    /// Solves, including those reusing an earlier factor.
    pub solves: usize,
}

/// After an indefinite matrix, Cholesky is tried on every this-many-th
/// factorisation only (LBL^T directly on the others).
const LLT_RETRY: usize = 4;

/// Factor entries from which the Cholesky factorisation uses every thread
/// of the rayon pool. Median on one thread against two, the 2-core machine
/// otherwise idle: on blocks of 8-node hexahedra (3 dofs a node, a scratch
/// probe) 2.4e6 factor entries 0.035 against 0.037 s, 1.2e7 0.23 against
/// 0.20 s, 3.8e7 0.99 against 0.75 s, 1.3e8 5.6 against 3.8 s, 1.9e8 9.6
/// against 6.6 s; on real tangents, sc at level 3 (1.6e6 entries, `cargo
/// bench -p tidens-solver --bench linear`) 19.4 against 24.7 ms, and 32
/// random spheres pressed to rho = 0.894 (mesh level 1, 361 801 equations,
/// 1.84e8 entries, a scratch resume of a study run) 10.6 against 7.4 s.
pub const PARALLEL_FACTOR_ENTRIES: usize = 10_000_000;

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
    ordering: FillOrdering,
    symbolic: Option<SymbolicCholesky<usize>>,
    values: Vec<f64>,
    numeric: Numeric,
    pub counts: FactorizationCounts,
    /// Factorisations since the last Cholesky one that succeeded, all LBL^T.
    indefinite_run: usize,
}

impl Default for LinearSolver {
    fn default() -> Self {
        Self::with_ordering(FillOrdering::default())
    }
}

/// The symbolic Cholesky factorisation of the pattern `sym` (both triangles,
/// rows sorted) with `ordering`.
fn symbolic_cholesky(
    sym: SymbolicSparseColMatRef<'_, usize>,
    ordering: FillOrdering,
) -> Result<SymbolicCholesky<usize>, LinearError> {
    let fwd = match ordering {
        FillOrdering::NestedDissection => nested_dissection(sym.col_ptr(), sym.row_idx()),
        FillOrdering::Amd => None,
    };
    let inv = fwd.as_ref().map(|fwd| {
        let mut inv = vec![0; fwd.len()];
        for (k, &i) in fwd.iter().enumerate() {
            inv[i] = k;
        }
        inv
    });
    let perm = match (&fwd, &inv) {
        (Some(fwd), Some(inv)) => {
            SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, sym.nrows()))
        }
        _ => SymmetricOrdering::Amd,
    };
    factorize_symbolic_cholesky(sym, Side::Lower, perm, CholeskySymbolicParams::default())
        .map_err(|e| LinearError::Symbolic(format!("{e:?}")))
}

fn out_of_memory(what: &'static str, bytes: usize) -> LinearError {
    LinearError::OutOfMemory {
        what,
        gigabytes: bytes as f64 / 1e9,
    }
}

fn buffer(req: StackReq, what: &'static str) -> Result<MemBuffer, LinearError> {
    MemBuffer::try_new(req).map_err(|_| out_of_memory(what, req.size_bytes()))
}

impl LinearSolver {
    /// A solver whose symbolic factorisations use `ordering`.
    pub fn with_ordering(ordering: FillOrdering) -> Self {
        Self {
            ordering,
            symbolic: None,
            values: Vec::new(),
            numeric: Numeric::None,
            counts: FactorizationCounts::default(),
            indefinite_run: 0,
        }
    }

    /// Stored entries of the factor of the current pattern (its supernodal
    /// blocks, explicit zeros included); 0 before the first factorisation.
    pub fn factor_entries(&self) -> usize {
        self.values.len()
    }

    /// True when a numeric factor is available for [`LinearSolver::solve`].
    pub fn has_factor(&self) -> bool {
        !matches!(self.numeric, Numeric::None)
    }

    /// Forgets the numeric factor.
    pub fn invalidate(&mut self) {
        self.numeric = Numeric::None;
    }

    /// Forgets the factor, its pattern and the memory of indefinite
    /// tangents: the solver is as new (but for its counts).
    pub fn forget(&mut self) {
        self.reset_pattern();
        self.indefinite_run = 0;
    }

    /// Forgets the symbolic structure too (the sparsity pattern changed).
    pub fn reset_pattern(&mut self) {
        self.numeric = Numeric::None;
        self.symbolic = None;
        self.values = Vec::new();
    }

    /// Factorises `A` (its lower triangle is read): Cholesky, or LBL^T when
    /// Cholesky fails; after a failed Cholesky the next three factorisations
    /// use LBL^T directly.
    pub fn factorize(&mut self, sys: &SparseSystem) -> Result<Factorization, LinearError> {
        self.numeric = Numeric::None;
        let n = sys.dim();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, sys.col_ptr(), None, sys.row_idx());
        let mat = SparseColMatRef::new(sym, sys.values());
        if self.symbolic.as_ref().is_none_or(|s| s.nrows() != n) {
            let s = symbolic_cholesky(sym, self.ordering)?;
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
            .ok_or(LinearError::NotFactorized("a numeric factorisation"))?;
        let threads = rayon::current_num_threads();
        let par = if threads > 1 && self.values.len() >= PARALLEL_FACTOR_ENTRIES {
            Par::rayon(threads)
        } else {
            Par::Seq
        };
        // Indefinite tangents come in runs (the iterates of a hard step, with
        // large plastic increments): a failed Cholesky costs up to a whole
        // factorisation, so after an indefinite one the next goes straight
        // to LBL^T, Cholesky being tried again every LLT_RETRY-th time
        // (measured on bcc and fcc at level 2: 5 % less time in linear
        // algebra, same results).
        let try_llt = self.indefinite_run.is_multiple_of(LLT_RETRY);
        let llt_ok = try_llt && {
            let mut scratch = buffer(
                symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
                "factorisation workspace",
            )?;
            symbolic
                .factorize_numeric_llt::<f64>(
                    &mut self.values,
                    mat,
                    Side::Lower,
                    Default::default(),
                    par,
                    MemStack::new(&mut scratch),
                    Default::default(),
                )
                .is_ok()
        };
        if llt_ok {
            self.indefinite_run = 0;
            self.counts.llt += 1;
            self.numeric = Numeric::Llt;
            return Ok(Factorization::Llt);
        }
        // Not positive definite: symmetric indefinite factorisation.
        let mut subdiag = vec![0.0; n];
        let mut fwd = vec![0usize; n];
        let mut bwd = vec![0usize; n];
        // Sequential: faer's LBL^T on two threads gave another factor (the
        // test below, at 1.2e7 entries).
        let par = Par::Seq;
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
        self.indefinite_run += 1;
        self.numeric = Numeric::Lblt { subdiag, fwd, bwd };
        Ok(Factorization::Lblt)
    }

    /// Solves `A x = b` in place with the current factor (`rhs` holds `b` on
    /// entry, `x` on exit).
    pub fn solve(&mut self, rhs: &mut [f64]) -> Result<(), LinearError> {
        let symbolic = self
            .symbolic
            .as_ref()
            .ok_or(LinearError::NotFactorized("a solve"))?;
        let n = symbolic.nrows();
        if rhs.len() != n {
            return Err(LinearError::Size {
                got: rhs.len(),
                size: n,
            });
        }
        let par = Par::Seq;
        let mut scratch = buffer(
            symbolic.solve_in_place_scratch::<f64>(1, par),
            "solve workspace",
        )?;
        let stack = MemStack::new(&mut scratch);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        match &self.numeric {
            Numeric::None => return Err(LinearError::NotFactorized("a solve")),
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
            Err(LinearError::Singular)
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

    /// The pattern of a block of `m^3` 8-node hexahedra (3 dofs a node) and a
    /// piston equation coupled to the z dofs of the top face, as assembled
    /// by the solver; values: a graph Laplacian of each element's nodes
    /// coupling all dof directions, springs from the top z dofs to the
    /// piston, and `diagonal` added to every equation.
    fn hex_block(m: usize, diagonal: f64) -> SparseSystem {
        let nodes = m + 1;
        let node = |i: usize, j: usize, k: usize| (k * nodes + j) * nodes + i;
        let piston = 3 * nodes * nodes * nodes;
        let mut cliques = Vec::new();
        for k in 0..m {
            for j in 0..m {
                for i in 0..m {
                    let mut dofs: Vec<usize> = (0..8)
                        .map(|c| node(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)))
                        .flat_map(|a| [3 * a, 3 * a + 1, 3 * a + 2])
                        .collect();
                    if k + 1 == m {
                        dofs.push(piston);
                    }
                    cliques.push(dofs);
                }
            }
        }
        let mut s = SparseSystem::from_cliques(piston + 1, cliques.iter().map(|c| &c[..]));
        let all: Vec<usize> = (0..=piston).collect();
        let mut ke = vec![0.0; 24 * 24];
        for a in 0..8 {
            for b in 0..8 {
                for p in 0..3 {
                    for q in 0..3 {
                        let l = if a == b { 7.0 } else { -1.0 };
                        let c = if p == q { 1.1 } else { 0.1 };
                        ke[(3 * a + p) * 24 + 3 * b + q] = l * c;
                    }
                }
            }
        }
        for clique in &cliques {
            s.add_block(&clique[..24], &ke, &all);
        }
        for j in 0..nodes {
            for i in 0..nodes {
                let z = 3 * node(i, j, m) + 2;
                s.add_block(&[z, piston], &[1.0, -1.0, -1.0, 1.0], &all);
            }
        }
        for d in 0..=piston {
            s.add(d, d, diagonal);
        }
        s
    }

    /// The factor and the solution are the same to the last bit on one
    /// thread and on two, Cholesky and LBL^T, on a system large enough for
    /// the Cholesky factorisation to use both.
    #[test]
    fn the_factor_is_the_same_on_one_thread_and_on_two() {
        let factor_on = |threads: usize, diagonal: f64| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let a = hex_block(18, diagonal);
                let mut solver = LinearSolver::default();
                let kind = solver.factorize(&a).unwrap();
                assert!(solver.factor_entries() >= PARALLEL_FACTOR_ENTRIES);
                let mut x: Vec<f64> = (0..a.dim()).map(|i| (i as f64 * 0.37).sin()).collect();
                solver.solve(&mut x).unwrap();
                (kind, solver.values.clone(), x)
            })
        };
        for (diagonal, kind) in [(0.1, Factorization::Llt), (-0.3, Factorization::Lblt)] {
            let one = factor_on(1, diagonal);
            let two = factor_on(2, diagonal);
            assert_eq!(one.0, kind);
            assert_eq!(two.0, kind);
            assert!(one.1 == two.1, "{kind:?}: the factors differ");
            assert!(one.2 == two.2, "{kind:?}: the solutions differ");
        }
    }

    #[test]
    fn nested_dissection_solves_as_amd_does_with_a_smaller_factor() {
        let x_true: Vec<f64> = (0..3 * 11 * 11 * 11 + 1)
            .map(|i| (i as f64 * 0.37).sin())
            .collect();
        for (diagonal, kind) in [(0.1, Factorization::Llt), (-0.3, Factorization::Lblt)] {
            let a = hex_block(10, diagonal);
            let b = a.mul_vec(&x_true);
            let mut nd = LinearSolver::with_ordering(FillOrdering::NestedDissection);
            let mut amd = LinearSolver::with_ordering(FillOrdering::Amd);
            let (mut x_nd, mut x_amd) = (b.clone(), b.clone());
            assert_eq!(nd.factorize(&a).unwrap(), kind);
            assert_eq!(amd.factorize(&a).unwrap(), kind);
            nd.solve(&mut x_nd).unwrap();
            amd.solve(&mut x_amd).unwrap();
            let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let diff: Vec<f64> = x_nd.iter().zip(&x_amd).map(|(p, q)| p - q).collect();
            let err: Vec<f64> = x_nd.iter().zip(&x_true).map(|(p, q)| p - q).collect();
            assert!(
                norm(&diff) < 1e-10 * norm(&x_amd),
                "{kind:?}: {:e}",
                norm(&diff) / norm(&x_amd)
            );
            assert!(
                norm(&err) < 1e-10 * norm(&x_true),
                "{kind:?}: {:e}",
                norm(&err) / norm(&x_true)
            );
            // A 3D mesh is where nested dissection beats minimum degree
            // (here 1.13 million entries against 1.76 million).
            assert!(
                (nd.factor_entries() as f64) < 0.8 * amd.factor_entries() as f64,
                "factor entries: {} with nested dissection, {} with AMD",
                nd.factor_entries(),
                amd.factor_entries()
            );
        }
    }

    #[test]
    fn solves_spd_and_indefinite_systems_with_one_symbolic_structure() {
        let n = 50;
        let mut solver = LinearSolver::default();
        // After the indefinite matrix, LBL^T (exact on the positive-definite
        // ones too) until Cholesky is tried again on the fourth.
        use Factorization::{Lblt, Llt};
        for (shift, kind) in [
            (0.0, Llt),
            (1.3, Lblt),
            (0.0, Lblt),
            (0.0, Lblt),
            (0.0, Lblt),
            (0.0, Llt),
            (0.0, Llt),
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
                llt: 3,
                lblt: 4,
                solves: 7
            }
        );
    }
}
