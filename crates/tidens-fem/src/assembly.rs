//! Global assembly of element matrices and vectors over the body's dofs.
//!
//! The sparsity pattern of the body's dofs is fixed by the mesh: every dof of
//! an element is coupled with every other dof of that element.
//! [`ElementAssembler`] builds it once, with a gather plan: for every dof (a
//! column of the matrix, an entry of a vector), the elements that touch it
//! in element order, and for every entry of every element matrix the slot of
//! the global matrix it adds to. Assembly then runs in parallel over columns,
//! each column owned by one task: every global entry is the sum of its
//! element contributions taken in element order, whatever the number of
//! threads, so results are the same bit for bit with one thread or many, and
//! no locks are needed.

use rayon::prelude::*;
use std::ops::Range;

/// Columns below which a task assembles serially rather than splitting.
const SERIAL_COLUMNS: usize = 256;

/// The dof-level sparsity pattern of a mesh and the plan that gathers
/// element matrices and vectors into it.
#[derive(Clone, Debug)]
pub struct ElementAssembler {
    /// Number of dofs (rows and columns).
    n: usize,
    /// Dofs per element.
    ndof: usize,
    /// Compressed columns, rows sorted within each column (both triangles).
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For dof `c`, `touch[touch_ptr[c]..touch_ptr[c + 1]]` lists the
    /// elements containing it with its local index there, in element order.
    touch_ptr: Vec<usize>,
    touch: Vec<(u32, u32)>,
    /// For element `e` and local entry `(p, q)` (row-major), the offset of
    /// its slot from the start of global column `dofs[e][q]`.
    offsets: Vec<u32>,
}

impl ElementAssembler {
    /// The plan for `n` dofs and elements of `ndof` dofs each, whose dofs are
    /// `element_dofs` (`ndof` per element, in element order, each `< n`,
    /// distinct within an element).
    pub fn new(n: usize, ndof: usize, element_dofs: &[usize]) -> Self {
        let count = element_dofs.len() / ndof.max(1);
        let mut touch_ptr = vec![0usize; n + 1];
        for &d in element_dofs {
            touch_ptr[d + 1] += 1;
        }
        for c in 0..n {
            touch_ptr[c + 1] += touch_ptr[c];
        }
        let mut fill = touch_ptr.clone();
        let mut touch = vec![(0u32, 0u32); element_dofs.len()];
        for (e, dofs) in element_dofs.chunks_exact(ndof).enumerate() {
            for (q, &d) in dofs.iter().enumerate() {
                touch[fill[d]] = (e as u32, q as u32);
                fill[d] += 1;
            }
        }
        // Rows of column c: the dofs of every element touching c.
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        let mut rows = Vec::new();
        for c in 0..n {
            rows.clear();
            for &(e, _) in &touch[touch_ptr[c]..touch_ptr[c + 1]] {
                let e = e as usize;
                rows.extend_from_slice(&element_dofs[ndof * e..ndof * (e + 1)]);
            }
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend_from_slice(&rows);
            col_ptr.push(row_idx.len());
        }
        let mut offsets = vec![0u32; count * ndof * ndof];
        for (e, dofs) in element_dofs.chunks_exact(ndof).enumerate() {
            for q in 0..ndof {
                let column = &row_idx[col_ptr[dofs[q]]..col_ptr[dofs[q] + 1]];
                for p in 0..ndof {
                    // Every element dof is in the column by construction.
                    let k = column.binary_search(&dofs[p]).unwrap_or_default();
                    offsets[(e * ndof + p) * ndof + q] = k as u32;
                }
            }
        }
        Self {
            n,
            ndof,
            col_ptr,
            row_idx,
            touch_ptr,
            touch,
            offsets,
        }
    }

    /// Number of dofs.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Dofs per element.
    pub fn element_dofs(&self) -> usize {
        self.ndof
    }

    /// Stored entries (both triangles).
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Column pointers of the compressed-column pattern.
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// Row indices of the pattern, sorted within each column.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// Sums the element matrices `matrices` (row-major `ndof x ndof` each,
    /// in element order) into `values` (length [`ElementAssembler::nnz`], in
    /// the pattern's order), overwriting it.
    pub fn assemble_matrix(&self, matrices: &[f64], values: &mut [f64]) {
        debug_assert_eq!(values.len(), self.nnz());
        self.gather_columns(0..self.n, values, matrices);
    }

    /// Sums the element vectors `vectors` (`ndof` each, in element order)
    /// into `out` (length [`ElementAssembler::dim`]), overwriting it.
    pub fn assemble_vector(&self, vectors: &[f64], out: &mut [f64]) {
        let ndof = self.ndof;
        out.par_iter_mut().enumerate().for_each(|(c, v)| {
            *v = self.touch[self.touch_ptr[c]..self.touch_ptr[c + 1]]
                .iter()
                .fold(0.0, |s, &(e, q)| {
                    s + vectors[e as usize * ndof + q as usize]
                });
        });
    }

    /// Gathers the columns `cols`, whose values are `values`, splitting the
    /// range between tasks at column boundaries.
    fn gather_columns(&self, cols: Range<usize>, values: &mut [f64], matrices: &[f64]) {
        if cols.len() <= SERIAL_COLUMNS {
            let base = self.col_ptr[cols.start];
            for c in cols {
                let column = &mut values[self.col_ptr[c] - base..self.col_ptr[c + 1] - base];
                self.gather_column(c, column, matrices);
            }
            return;
        }
        let mid = cols.start + cols.len() / 2;
        let (left, right) = values.split_at_mut(self.col_ptr[mid] - self.col_ptr[cols.start]);
        rayon::join(
            || self.gather_columns(cols.start..mid, left, matrices),
            || self.gather_columns(mid..cols.end, right, matrices),
        );
    }

    /// Column `c`: every element touching it adds its column `q` of entries,
    /// element by element in element order.
    fn gather_column(&self, c: usize, column: &mut [f64], matrices: &[f64]) {
        column.fill(0.0);
        let m = self.ndof * self.ndof;
        for &(e, q) in &self.touch[self.touch_ptr[c]..self.touch_ptr[c + 1]] {
            let (e, q) = (e as usize, q as usize);
            let mat = &matrices[m * e..m * (e + 1)];
            let off = &self.offsets[m * e..m * (e + 1)];
            for p in 0..self.ndof {
                column[off[p * self.ndof + q] as usize] += mat[p * self.ndof + q];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three 2-dof "elements" in a chain sharing dofs, and a dense reference.
    #[test]
    fn gathers_element_matrices_and_vectors_like_a_dense_sum() {
        let dofs = [0usize, 2, 2, 1, 1, 3, 3, 0];
        let asm = ElementAssembler::new(4, 2, &dofs);
        let mats: Vec<f64> = (0..16).map(|k| 1.0 + k as f64 * 0.37).collect();
        let vecs: Vec<f64> = (0..8).map(|k| 2.0 - k as f64 * 0.11).collect();
        let mut dense = [[0.0; 4]; 4];
        let mut f = [0.0; 4];
        for (e, d) in dofs.chunks(2).enumerate() {
            for p in 0..2 {
                f[d[p]] += vecs[2 * e + p];
                for q in 0..2 {
                    dense[d[p]][d[q]] += mats[4 * e + 2 * p + q];
                }
            }
        }
        let mut values = vec![f64::NAN; asm.nnz()];
        asm.assemble_matrix(&mats, &mut values);
        for c in 0..4 {
            for k in asm.col_ptr()[c]..asm.col_ptr()[c + 1] {
                assert_eq!(values[k], dense[asm.row_idx()[k]][c]);
            }
        }
        // Every non-zero of the dense sum is in the pattern.
        let stored: f64 = values.iter().sum();
        let total: f64 = dense.iter().flatten().sum();
        assert!((stored - total).abs() < 1e-12);
        let mut out = vec![f64::NAN; 4];
        asm.assemble_vector(&vecs, &mut out);
        assert_eq!(out, f.to_vec());
    }
}
