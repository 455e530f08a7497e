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
//! A large Cholesky factorisation (from [`SINGLE_PRECISION_ENTRIES`]
//! entries on) is done in single precision: the factor takes half the
//! memory (the matrix is kept beside it) and less time. Each solve is then
//! conjugate gradients on the matrix in double precision, preconditioned
//! with that factor, until the residual is below 1e-6 of the right-hand
//! side (what a Newton direction needs); an iteration is one solve with the
//! factor and one product with the matrix. Where the factorisation fails
//! in single precision (the matrix is not positive definite to single
//! precision) or ten iterations do not get there, the matrix is factorised
//! in double precision, as it is for the next eight factorisations (sixteen
//! after a second failure in a row, and so on). The single-precision
//! factor, too, is the same to the bit on one thread and on two.
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
    /// Of the Cholesky factorisations, those in single precision (see
    /// [`SINGLE_PRECISION_ENTRIES`]).
    #[serde(default)]
    pub single: usize,
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

/// Factor entries from which the Cholesky factorisation is done in single
/// precision first, each solve then conjugate gradients in double precision
/// preconditioned with it (see [`LinearSolver::solve`]). The factor holds
/// half the bytes, and its dense updates do twice the work per instruction.
/// Measured on eight random spheres at mesh level 1 (155 299 equations,
/// 3.85e7 factor entries, one thread): the tangent at rho = 0.937
/// factorised in 2.78 s against 4.53 s (the machine busy); the run resumed
/// there to rho = 0.95 took 145.6 s against 204.2 s side by side: the same
/// 11 steps, 102 Newton iterations against 100, all 101 factorisations in
/// single precision, its times to density within 4.3e-8 of each other.
pub const SINGLE_PRECISION_ENTRIES: usize = 10_000_000;

/// After a single-precision Cholesky factorisation fails (not positive
/// definite in single precision), or a solve with it does not converge, this
/// many factorisations are done in double precision before it is tried
/// again; twice as many after each further failure in a row, up to
/// [`SINGLE_RETRY_MAX`]. A failed attempt costs about 0.6 of a
/// factorisation in double precision: on the tangent of 32 random spheres
/// in the load's ramp (mesh level 1, 361 801 equations, 5.3e7 factor
/// entries, one thread), 2.2 s to fail against 3.4 s to factorise.
const SINGLE_RETRY: usize = 8;

/// See [`SINGLE_RETRY`].
const SINGLE_RETRY_MAX: usize = 128;

/// Most conjugate-gradient iterations of a solve with the single-precision
/// factor as preconditioner (on the eight spheres above a solve with the
/// factor took 0.07 to 0.10 s, against 2.78 s for the factorisation).
const MAX_REFINEMENTS: usize = 10;

/// A solve with the single-precision factor stops when the residual's
/// Euclidean norm is below this fraction of the right-hand side's. A Newton
/// direction needs no more: the residual the next iterate is left with
/// from it is this fraction of the present one, against the 0.2 that a
/// reused factor is allowed (see `newton.rs`). Solving to 1e-12 took 4 to
/// 6 iterations a solve on 32 random spheres in the load's ramp, so that
/// their run took longer than in double precision.
const REFINED: f64 = 1e-6;

/// The numeric factor of the last factorised matrix.
enum Numeric {
    None,
    Llt,
    /// Cholesky in single precision, of `matrix`.
    SingleLlt {
        factor: Vec<f32>,
        matrix: SparseSystem,
    },
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
    /// Factorisations in double precision since a single-precision one
    /// failed, and how many to do before trying again (`None`: single
    /// precision has not failed since it last served).
    double_run: Option<(usize, usize)>,
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
            double_run: None,
        }
    }

    /// Stored entries of the factor of the current pattern (its supernodal
    /// blocks, explicit zeros included); 0 before the first factorisation.
    pub fn factor_entries(&self) -> usize {
        self.symbolic.as_ref().map_or(0, |s| s.len_val())
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
        self.double_run = None;
    }

    /// Forgets the symbolic structure too (the sparsity pattern changed).
    pub fn reset_pattern(&mut self) {
        self.numeric = Numeric::None;
        self.symbolic = None;
        self.values = Vec::new();
    }

    /// Counts a failure of single precision: double precision for the
    /// next [`SINGLE_RETRY`] factorisations, or twice as many as after the
    /// last failure where single precision has not served since.
    fn single_failed(double_run: &mut Option<(usize, usize)>) {
        let due = double_run.map_or(SINGLE_RETRY, |(_, due)| (2 * due).min(SINGLE_RETRY_MAX));
        *double_run = Some((0, due));
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
            self.values = Vec::new();
            self.symbolic = Some(symbolic_cholesky(sym, self.ordering)?);
        }
        let symbolic = self
            .symbolic
            .as_ref()
            .ok_or(LinearError::NotFactorized("a numeric factorisation"))?;
        let len = symbolic.len_val();
        let threads = rayon::current_num_threads();
        let par = if threads > 1 && len >= PARALLEL_FACTOR_ENTRIES {
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
        let try_single = try_llt
            && len >= SINGLE_PRECISION_ENTRIES
            && self.double_run.is_none_or(|(done, due)| done >= due);
        if try_single {
            let values: Vec<f32> = sys.values().iter().map(|&v| v as f32).collect();
            let single = SparseColMatRef::new(sym, &values);
            let mut factor = Vec::new();
            factor
                .try_reserve_exact(len)
                .map_err(|_| out_of_memory("sparse factor", 4 * len))?;
            factor.resize(len, 0.0f32);
            let mut scratch = buffer(
                symbolic.factorize_numeric_llt_scratch::<f32>(par, Default::default()),
                "factorisation workspace",
            )?;
            let ok = symbolic
                .factorize_numeric_llt::<f32>(
                    &mut factor,
                    single,
                    Side::Lower,
                    Default::default(),
                    par,
                    MemStack::new(&mut scratch),
                    Default::default(),
                )
                .is_ok();
            if ok {
                self.indefinite_run = 0;
                self.counts.llt += 1;
                self.counts.single += 1;
                // The double-precision factor's memory is given back.
                self.values = Vec::new();
                self.numeric = Numeric::SingleLlt {
                    factor,
                    matrix: sys.clone(),
                };
                return Ok(Factorization::Llt);
            }
            Self::single_failed(&mut self.double_run);
            if crate::newton::debug_enabled() {
                eprintln!("      single-precision Cholesky failed");
            }
        }
        if let Some((done, _)) = self.double_run.as_mut() {
            *done += 1;
        }
        if self.values.len() != len {
            let mut values = Vec::new();
            values
                .try_reserve_exact(len)
                .map_err(|_| out_of_memory("sparse factor", 8 * len))?;
            values.resize(len, 0.0);
            self.values = values;
        }
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
    ///
    /// With a single-precision factor the solve is conjugate gradients in
    /// double precision preconditioned with it, to a residual below 1e-6
    /// of `b`; where they do not get there (a tangent too ill-conditioned
    /// for single precision), the matrix is factorised in double precision
    /// and solved with that.
    pub fn solve(&mut self, rhs: &mut [f64]) -> Result<(), LinearError> {
        if matches!(self.numeric, Numeric::SingleLlt { .. }) {
            let iterations = self.refined_solve(rhs)?;
            if crate::newton::debug_enabled() {
                eprintln!(
                    "      single-precision solve: {iterations:?} conjugate-gradient iterations"
                );
            }
            if iterations.is_some() {
                self.double_run = None;
                self.counts.solves += 1;
                return Ok(());
            }
            let Numeric::SingleLlt { matrix, .. } =
                std::mem::replace(&mut self.numeric, Numeric::None)
            else {
                return Err(LinearError::NotFactorized("a solve"));
            };
            Self::single_failed(&mut self.double_run);
            self.factorize(&matrix)?;
        }
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
            Numeric::None | Numeric::SingleLlt { .. } => {
                return Err(LinearError::NotFactorized("a solve"));
            }
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

    /// Solves `A x = b` (`rhs` holds `b`) by conjugate gradients on `A`
    /// preconditioned with the single-precision factor (its first iterate
    /// is the factor's solve, each next one refines it). Returns the
    /// iterations taken; None, `rhs` untouched, where the residual does not
    /// fall below [`REFINED`] of `b` within [`MAX_REFINEMENTS`] iterations.
    fn refined_solve(&self, rhs: &mut [f64]) -> Result<Option<usize>, LinearError> {
        let (Some(symbolic), Numeric::SingleLlt { factor, matrix }) =
            (self.symbolic.as_ref(), &self.numeric)
        else {
            return Err(LinearError::NotFactorized("a solve"));
        };
        let n = symbolic.nrows();
        if rhs.len() != n {
            return Err(LinearError::Size {
                got: rhs.len(),
                size: n,
            });
        }
        let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        let mut r = rhs.to_vec();
        let b_norm = dot(&r, &r).sqrt();
        if b_norm == 0.0 {
            return Ok(Some(0));
        }
        let mut scratch = buffer(
            symbolic.solve_in_place_scratch::<f32>(1, Par::Seq),
            "solve workspace",
        )?;
        // The preconditioner: the single-precision factor's solve, of the
        // residual scaled to at most 1 in size (single precision neither
        // overflows nor underflows).
        let mut precondition = |r: &[f64]| -> Vec<f64> {
            let scale = r.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
            if scale == 0.0 {
                return vec![0.0; n];
            }
            let mut d: Vec<f32> = r.iter().map(|v| (v / scale) as f32).collect();
            LltRef::new(symbolic, factor).solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut d, n, 1),
                Par::Seq,
                MemStack::new(&mut scratch),
            );
            d.iter().map(|&v| f64::from(v) * scale).collect()
        };
        let mut x = vec![0.0; n];
        let mut z = precondition(&r);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        for iteration in 1..=MAX_REFINEMENTS {
            let ap = matrix.mul_vec(&p);
            let pap = dot(&p, &ap);
            if !(pap > 0.0 && rz.is_finite()) {
                return Ok(None);
            }
            let alpha = rz / pap;
            // The recursion's residual drifts from b - A x by rounding (to
            // 3e-13 of b against 4e-14 read, on the eight spheres at rho =
            // 0.937), far below the bound.
            for ((xi, ri), (pi, api)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(&ap)) {
                *xi += alpha * pi;
                *ri -= alpha * api;
            }
            let r_norm = dot(&r, &r).sqrt();
            if r_norm <= REFINED * b_norm {
                rhs.copy_from_slice(&x);
                return Ok(Some(iteration));
            }
            z = precondition(&r);
            let rz_next = dot(&r, &z);
            let beta = rz_next / rz;
            rz = rz_next;
            for (pi, zi) in p.iter_mut().zip(&z) {
                *pi = zi + beta * *pi;
            }
        }
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The numeric factor, widened to f64 where it is single precision.
    fn factor_values(solver: &LinearSolver) -> Vec<f64> {
        match &solver.numeric {
            Numeric::SingleLlt { factor, .. } => factor.iter().map(|&v| f64::from(v)).collect(),
            _ => solver.values.clone(),
        }
    }

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
                (kind, factor_values(&solver), x)
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

    /// From `SINGLE_PRECISION_ENTRIES` on, Cholesky is done in single
    /// precision, and the solve with it meets the residual bound `REFINED`
    /// (checked here against the matrix afresh). Where the matrix is
    /// too ill-conditioned for single precision (a diagonal of 1e-9 on a
    /// singular graph Laplacian), the solve comes from a factor in double
    /// precision, backward stable as ever.
    #[test]
    fn a_large_factor_is_single_precision_and_its_solves_double() {
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let a = hex_block(18, 0.1);
        let x_true: Vec<f64> = (0..a.dim()).map(|i| (i as f64 * 0.37).sin()).collect();
        let b = a.mul_vec(&x_true);
        let mut x = b.clone();
        let mut solver = LinearSolver::default();
        assert_eq!(solver.factorize(&a).unwrap(), Factorization::Llt);
        assert!(solver.factor_entries() >= SINGLE_PRECISION_ENTRIES);
        assert_eq!((solver.counts.llt, solver.counts.single), (1, 1));
        // No double-precision factor is held beside the single one.
        assert!(solver.values.is_empty());
        solver.solve(&mut x).unwrap();
        let ax = a.mul_vec(&x);
        let r: Vec<f64> = b.iter().zip(&ax).map(|(p, q)| p - q).collect();
        assert!(norm(&r) <= REFINED * norm(&b), "{:e}", norm(&r) / norm(&b));
        assert_eq!((solver.counts.llt, solver.counts.single), (1, 1));

        let a = hex_block(18, 1e-9);
        let b = a.mul_vec(&x_true);
        let mut x = b.clone();
        let mut solver = LinearSolver::default();
        assert_eq!(solver.factorize(&a).unwrap(), Factorization::Llt);
        solver.solve(&mut x).unwrap();
        assert!(
            solver.counts.llt > solver.counts.single,
            "no factor in double precision: {:?}",
            solver.counts
        );
        assert_eq!(solver.values.len(), solver.factor_entries());
        let ax = a.mul_vec(&x);
        let r: Vec<f64> = b.iter().zip(&ax).map(|(p, q)| p - q).collect();
        assert!(norm(&r) < 1e-13 * norm(&b), "{:e}", norm(&r) / norm(&b));
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
                solves: 7,
                single: 0
            }
        );
    }
}
