//! Nested-dissection ordering of the tangent for its sparse Cholesky factor.
//!
//! The equations of the tangent come in runs with one sparsity pattern: the
//! three dofs of a node are coupled to the same equations (every element and
//! contact clique takes a node whole). Each run becomes one vertex of a
//! quotient graph, weighted by its number of equations, and METIS
//! (`METIS_NodeND`: multilevel vertex separators, minimum degree on the small
//! parts) orders that graph; the runs are expanded back in that order, so the
//! dofs of a node stay together in the factor's supernodes. Equations of a
//! dense row (the piston's, coupled to the whole top face) need no special
//! case: a separator vertex is always ordered after both of its halves.
//!
//! METIS is deterministic for a given graph (fixed seed) and serial, so the
//! permutation does not depend on the number of threads.

use metis_sys::{
    METIS_NOPTIONS, METIS_NodeND, METIS_SetDefaultOptions, idx_t,
    moptions_et_METIS_OPTION_NUMBERING, rstatus_et_METIS_ERROR, rstatus_et_METIS_OK,
};
use std::sync::{Mutex, PoisonError};

/// METIS draws from one process-wide random generator (GKlib's), re-seeded
/// on each call: two calls at once from different threads would interleave
/// their draws (a data race, and orderings that depend on timing).
static METIS_LOCK: Mutex<()> = Mutex::new(());

/// The process's handlers of SIGTERM and SIGABRT, saved around a METIS call.
///
/// GKlib (METIS's support library) takes both signals over for the length of
/// every METIS call (a SIGTERM then ends the call with `METIS_ERROR`) and
/// puts the old handlers back with `signal()`, which in this build makes
/// them one-shot (`SA_RESETHAND`): after the first ordering, the handler
/// Python installs for SIGTERM (`tidens_rs.signals.sigterm_stops`) ran once
/// and the next SIGTERM killed the process mid-way through writing its
/// summary (a sweep's worker whose parent died). [`SignalHandlers::restore`]
/// puts them back exactly as they were.
#[cfg(unix)]
struct SignalHandlers([(libc::c_int, libc::sigaction); 2]);

#[cfg(unix)]
impl SignalHandlers {
    fn save() -> Self {
        Self([libc::SIGTERM, libc::SIGABRT].map(|signal| {
            // SAFETY: a zeroed sigaction is a valid value for sigaction() to
            // overwrite; a null new action only reads the current one.
            let mut old: libc::sigaction = unsafe { std::mem::zeroed() };
            unsafe { libc::sigaction(signal, std::ptr::null(), &mut old) };
            (signal, old)
        }))
    }

    /// Puts the saved handlers back; with `resend_term` (METIS ended with
    /// `METIS_ERROR`, as a SIGTERM caught by GKlib makes it), sends this
    /// thread SIGTERM again, so that the process's own handler (or the
    /// default action, or none if ignored) sees the signal METIS swallowed.
    fn restore(&self, resend_term: bool) {
        for (signal, old) in &self.0 {
            // SAFETY: `old` is what sigaction() returned for `signal`.
            unsafe { libc::sigaction(*signal, old, std::ptr::null_mut()) };
        }
        let term = &self.0[0].1;
        if resend_term && term.sa_sigaction != libc::SIG_IGN {
            // SAFETY: raise() only sends a signal to the calling thread.
            unsafe { libc::raise(libc::SIGTERM) };
        }
    }
}

/// Runs of consecutive equations with identical columns in the symmetric
/// pattern (`col_ptr`, `row_idx`: compressed columns, both triangles, rows
/// sorted): `starts[g]..starts[g + 1]` are the equations of run `g`.
fn runs(col_ptr: &[usize], row_idx: &[usize]) -> Vec<usize> {
    let n = col_ptr.len() - 1;
    let col = |c: usize| &row_idx[col_ptr[c]..col_ptr[c + 1]];
    let mut starts: Vec<usize> = (0..n).filter(|&c| c == 0 || col(c) != col(c - 1)).collect();
    starts.push(n);
    starts
}

/// A fill-reducing permutation `fwd` of the symmetric pattern (`col_ptr`,
/// `row_idx`: compressed columns, both triangles, rows sorted): equation
/// `fwd[k]` is eliminated `k`-th. `None` when METIS fails or the pattern is
/// too large for its 32-bit indices (the caller then falls back to AMD).
pub(crate) fn nested_dissection(col_ptr: &[usize], row_idx: &[usize]) -> Option<Vec<usize>> {
    let n = col_ptr.len().checked_sub(1)?;
    if n <= 1 {
        return Some((0..n).collect());
    }
    let starts = runs(col_ptr, row_idx);
    let m = starts.len() - 1;
    let mut run_of = vec![0usize; n];
    for g in 0..m {
        run_of[starts[g]..starts[g + 1]].fill(g);
    }
    // Quotient graph without self-loops; rows are sorted and runs are
    // consecutive, so equal neighbours are adjacent in each column.
    let mut xadj: Vec<idx_t> = Vec::with_capacity(m + 1);
    let mut adjncy: Vec<idx_t> = Vec::new();
    xadj.push(0);
    for g in 0..m {
        let mut last = g;
        for &r in &row_idx[col_ptr[starts[g]]..col_ptr[starts[g] + 1]] {
            let h = run_of[r];
            if h != g && h != last {
                adjncy.push(idx_t::try_from(h).ok()?);
                last = h;
            }
        }
        xadj.push(idx_t::try_from(adjncy.len()).ok()?);
    }
    let mut vwgt: Vec<idx_t> = (0..m)
        .map(|g| idx_t::try_from(starts[g + 1] - starts[g]))
        .collect::<Result<_, _>>()
        .ok()?;
    let mut nvtxs = idx_t::try_from(m).ok()?;
    let mut options = [0 as idx_t; METIS_NOPTIONS as usize];
    let mut perm = vec![0 as idx_t; m];
    let mut iperm = vec![0 as idx_t; m];
    let status = {
        let _lock = METIS_LOCK.lock().unwrap_or_else(PoisonError::into_inner);
        #[cfg(unix)]
        let handlers = SignalHandlers::save();
        // SAFETY: `options` has METIS_NOPTIONS entries; `xadj` has nvtxs + 1
        // entries indexing into `adjncy`; `vwgt`, `perm` and `iperm` have
        // nvtxs entries; METIS reads the graph and writes only the two
        // permutations.
        let status = unsafe {
            METIS_SetDefaultOptions(options.as_mut_ptr());
            options[moptions_et_METIS_OPTION_NUMBERING as usize] = 0;
            METIS_NodeND(
                &mut nvtxs,
                xadj.as_mut_ptr(),
                adjncy.as_mut_ptr(),
                vwgt.as_mut_ptr(),
                options.as_mut_ptr(),
                perm.as_mut_ptr(),
                iperm.as_mut_ptr(),
            )
        };
        #[cfg(unix)]
        handlers.restore(status == rstatus_et_METIS_ERROR);
        status
    };
    if status != rstatus_et_METIS_OK {
        return None;
    }
    // `perm[k]` is the run eliminated k-th; check it is a permutation.
    let mut seen = vec![false; m];
    let mut fwd = Vec::with_capacity(n);
    for &p in &perm {
        let g = usize::try_from(p).ok().filter(|&g| g < m && !seen[g])?;
        seen[g] = true;
        fwd.extend(starts[g]..starts[g + 1]);
    }
    Some(fwd)
}

#[cfg(test)]
mod tests {
    use super::*;

    extern "C" fn on_term(_: libc::c_int) {}

    /// A METIS call leaves the SIGTERM handler as it found it, flags and
    /// all (GKlib's `signal()` put it back one-shot).
    ///
    /// The handler is process-wide and other tests of this binary order
    /// their tangents on other threads meanwhile: each such call saves the
    /// handler, lets GKlib replace it and puts back what it saved. So the
    /// handler is installed and read back under `METIS_LOCK`, as those
    /// calls save and restore it: no call is then half-way (one that saved
    /// the handler before this test installed its own would put the old one
    /// back after it).
    #[cfg(unix)]
    #[test]
    fn an_ordering_leaves_the_sigterm_handler_as_it_was() {
        let locked = || METIS_LOCK.lock().unwrap_or_else(PoisonError::into_inner);
        let read = || {
            // SAFETY: as in `SignalHandlers::save`.
            let mut now: libc::sigaction = unsafe { std::mem::zeroed() };
            unsafe { libc::sigaction(libc::SIGTERM, std::ptr::null(), &mut now) };
            (now.sa_sigaction, now.sa_flags)
        };
        // SAFETY: a handler that does nothing, installed for this test and
        // put back after it.
        let mut mine: libc::sigaction = unsafe { std::mem::zeroed() };
        mine.sa_sigaction = on_term as extern "C" fn(libc::c_int) as libc::sighandler_t;
        mine.sa_flags = libc::SA_ONSTACK;
        let mut before: libc::sigaction = unsafe { std::mem::zeroed() };
        let installed = {
            let _lock = locked();
            unsafe { libc::sigaction(libc::SIGTERM, &mine, &mut before) };
            read()
        };
        let (col_ptr, row_idx) = chain_of_runs(40, 3);
        let ordered = nested_dissection(&col_ptr, &row_idx);
        let after = {
            let _lock = locked();
            let after = read();
            unsafe { libc::sigaction(libc::SIGTERM, &before, std::ptr::null_mut()) };
            after
        };
        assert!(ordered.is_some());
        assert_eq!(after, installed);
    }

    /// Pattern of `groups` runs of `k` equations each, coupled along a chain
    /// of runs (both triangles, full diagonal).
    fn chain_of_runs(groups: usize, k: usize) -> (Vec<usize>, Vec<usize>) {
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for c in 0..groups * k {
            let g = c / k;
            let lo = g.saturating_sub(1) * k;
            let hi = ((g + 2) * k).min(groups * k);
            row_idx.extend(lo..hi);
            col_ptr.push(row_idx.len());
        }
        (col_ptr, row_idx)
    }

    #[test]
    fn runs_of_equal_columns_are_found() {
        let (col_ptr, row_idx) = chain_of_runs(5, 3);
        assert_eq!(runs(&col_ptr, &row_idx), vec![0, 3, 6, 9, 12, 15]);
    }

    #[test]
    fn nested_dissection_is_a_permutation_keeping_runs_together() {
        let (col_ptr, row_idx) = chain_of_runs(40, 3);
        let fwd = nested_dissection(&col_ptr, &row_idx).expect("METIS ordering");
        let mut sorted = fwd.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..120).collect::<Vec<_>>());
        for run in fwd.chunks(3) {
            assert_eq!(run[0] % 3, 0);
            assert_eq!(run, [run[0], run[0] + 1, run[0] + 2]);
        }
        // Deterministic.
        assert_eq!(nested_dissection(&col_ptr, &row_idx), Some(fwd));
    }

    #[test]
    fn concurrent_calls_give_the_same_ordering() {
        let (col_ptr, row_idx) = chain_of_runs(300, 3);
        let alone = nested_dissection(&col_ptr, &row_idx);
        let together: Vec<_> = std::thread::scope(|s| {
            let calls: Vec<_> = (0..4)
                .map(|_| s.spawn(|| nested_dissection(&col_ptr, &row_idx)))
                .collect();
            calls.into_iter().map(|c| c.join().ok().flatten()).collect()
        });
        for fwd in together {
            assert_eq!(fwd, alone);
        }
    }

    #[test]
    fn tiny_and_diagonal_patterns_are_ordered() {
        assert_eq!(nested_dissection(&[0], &[]), Some(vec![]));
        assert_eq!(nested_dissection(&[0, 1], &[0]), Some(vec![0]));
        let fwd = nested_dissection(&[0, 1, 2, 3, 4], &[0, 1, 2, 3]).expect("METIS ordering");
        let mut sorted = fwd.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, vec![0, 1, 2, 3]);
    }
}
