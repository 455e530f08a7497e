//! A fixed sparsity pattern and the scatter of element matrices into it.

/// Marks a dof that maps to no equation (prescribed).
pub const DOF_DROPPED: usize = usize::MAX;

/// A square sparse matrix in compressed-column form (both triangles stored,
/// rows sorted within each column) with a pattern fixed at construction, so
/// that a symbolic factorisation can be reused for as long as it lives.
#[derive(Clone, Debug)]
pub struct SparseSystem {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
}

impl SparseSystem {
    /// The pattern of `n` equations in which every equation of each group is
    /// coupled with every other equation of that group, plus the full diagonal.
    pub fn from_cliques<'a>(n: usize, cliques: impl IntoIterator<Item = &'a [usize]>) -> Self {
        let mut cols: Vec<Vec<usize>> = (0..n).map(|c| vec![c]).collect();
        for clique in cliques {
            for &c in clique {
                cols[c].extend_from_slice(clique);
            }
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for mut rows in cols {
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend_from_slice(&rows);
            col_ptr.push(row_idx.len());
        }
        let nnz = row_idx.len();
        Self {
            n,
            col_ptr,
            row_idx,
            values: vec![0.0; nnz],
        }
    }

    pub fn dim(&self) -> usize {
        self.n
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Sets every stored value to zero.
    pub fn clear(&mut self) {
        self.values.fill(0.0);
    }

    /// Position of entry (`row`, `col`) in the value array, if in the pattern.
    pub fn position(&self, row: usize, col: usize) -> Option<usize> {
        let (lo, hi) = (self.col_ptr[col], self.col_ptr[col + 1]);
        self.row_idx[lo..hi]
            .binary_search(&row)
            .ok()
            .map(|k| lo + k)
    }

    /// Adds the dense row-major block `mat` over local dofs `dofs`, each local
    /// dof sent to equation `map[dof]` (entries mapped to [`DOF_DROPPED`] are
    /// skipped). Several dofs may map to one equation (tied dofs): their rows
    /// and columns are summed. Returns the number of entries that fell outside
    /// the pattern (0 when the pattern was built for `map`).
    pub fn add_block(&mut self, dofs: &[usize], mat: &[f64], map: &[usize]) -> usize {
        let m = dofs.len();
        debug_assert_eq!(mat.len(), m * m);
        let mut missed = 0;
        for (q, &dq) in dofs.iter().enumerate() {
            let col = map[dq];
            if col == DOF_DROPPED {
                continue;
            }
            let (lo, hi) = (self.col_ptr[col], self.col_ptr[col + 1]);
            let rows = &self.row_idx[lo..hi];
            for (p, &dp) in dofs.iter().enumerate() {
                let row = map[dp];
                if row == DOF_DROPPED {
                    continue;
                }
                match rows.binary_search(&row) {
                    Ok(k) => self.values[lo + k] += mat[p * m + q],
                    Err(_) => missed += 1,
                }
            }
        }
        missed
    }

    /// Adds `value` to the stored entry at `slot` (an index into
    /// [`SparseSystem::values`], e.g. from [`SparseSystem::position`]).
    pub fn add_at(&mut self, slot: usize, value: f64) {
        self.values[slot] += value;
    }

    /// Adds `value` to entry (`row`, `col`); false if it is not in the pattern.
    pub fn add(&mut self, row: usize, col: usize, value: f64) -> bool {
        match self.position(row, col) {
            Some(k) => {
                self.values[k] += value;
                true
            }
            None => false,
        }
    }

    /// `y = A x`.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        for c in 0..self.n {
            for k in self.col_ptr[c]..self.col_ptr[c + 1] {
                y[self.row_idx[k]] += self.values[k] * x[c];
            }
        }
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tied_dofs_sum_their_rows_and_columns() {
        // Two 2-dof "elements" sharing equation 1; dof 3 tied to equation 0.
        let mut s = SparseSystem::from_cliques(3, [&[0usize, 1][..], &[1, 2, 0][..]]);
        let map = [0, 1, 2, 0];
        let m = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(s.add_block(&[0, 1], &m, &map), 0);
        assert_eq!(s.add_block(&[3, 2], &m, &map), 0);
        // Dense reference.
        let mut d = [[0.0; 3]; 3];
        for (dofs, mm) in [([0usize, 1usize], m), ([0, 2], m)] {
            for p in 0..2 {
                for q in 0..2 {
                    d[dofs[p]][dofs[q]] += mm[p * 2 + q];
                }
            }
        }
        for r in 0..3 {
            for c in 0..3 {
                let v = s.position(r, c).map(|k| s.values()[k]).unwrap_or(0.0);
                assert_eq!(v, d[r][c], "({r},{c})");
            }
        }
        let mut dropped = [0, DOF_DROPPED, 2, 0];
        dropped[1] = DOF_DROPPED;
        s.clear();
        s.add_block(&[0, 1], &m, &dropped);
        assert_eq!(s.values().iter().sum::<f64>(), 1.0);
    }
}
