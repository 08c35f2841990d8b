//! Symmetric matrices on a mesh's vertex-adjacency pattern, and their sparse Cholesky factors.
//!
//! Every matrix the heat method needs (M + tL with free or fixed boundary, L with pinned sources)
//! has the same pattern: the diagonal plus one entry per edge each side. So the symbolic
//! factorisation (ordering, elimination tree, supernodes) is computed once per mesh and shared;
//! a new matrix costs one numeric factorisation. This is faer's factor-once API.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky, factorize_symbolic_cholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use std::sync::Arc;

/// The pattern: full symmetric CSC (both triangles) with the slots of the diagonal and the edges.
#[derive(Debug, Clone)]
pub struct Pattern {
    n: usize,
    col_ptr: Vec<u32>,
    row_idx: Vec<u32>,
    /// Slot of (v, v).
    diag: Vec<u32>,
    /// Slots of (i, j) and (j, i) for edge [i, j].
    edge_slots: Vec<[u32; 2]>,
    /// Per vertex, the edges touching it.
    vertex_edges: Vec<Vec<u32>>,
}

impl Pattern {
    pub fn from_edges(n: usize, edges: &[[u32; 2]]) -> Pattern {
        let mut cols: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n]; // (row, edge or MAX for diagonal)
        let mut vertex_edges = vec![Vec::new(); n];
        for (v, col) in cols.iter_mut().enumerate() {
            col.push((v as u32, u32::MAX));
        }
        for (e, &[i, j]) in edges.iter().enumerate() {
            cols[j as usize].push((i, e as u32));
            cols[i as usize].push((j, e as u32));
            vertex_edges[i as usize].push(e as u32);
            vertex_edges[j as usize].push(e as u32);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::with_capacity(n + 2 * edges.len());
        let mut diag = vec![0; n];
        let mut edge_slots = vec![[0u32; 2]; edges.len()];
        col_ptr.push(0);
        for (c, col) in cols.iter_mut().enumerate() {
            col.sort_unstable();
            for &(r, e) in col.iter() {
                let slot = row_idx.len() as u32;
                if e == u32::MAX {
                    diag[c] = slot;
                } else {
                    // Slot (r, c): the edge's first slot is (i, j) in column j.
                    let [i, _] = edges[e as usize];
                    edge_slots[e as usize][usize::from(r != i)] = slot;
                }
                row_idx.push(r);
            }
            col_ptr.push(row_idx.len() as u32);
        }
        Pattern {
            n,
            col_ptr,
            row_idx,
            diag,
            edge_slots,
            vertex_edges,
        }
    }

    pub fn n(&self) -> usize {
        self.n
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    pub fn diag_slot(&self, v: usize) -> usize {
        self.diag[v] as usize
    }

    pub fn edge_slots(&self, e: usize) -> [usize; 2] {
        self.edge_slots[e].map(|s| s as usize)
    }

    pub fn symbolic(&self) -> SymbolicSparseColMatRef<'_, u32> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }

    /// y = A x for a matrix on this pattern.
    pub fn mul(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        for (c, yc) in y.iter_mut().enumerate() {
            let (a, b) = (self.col_ptr[c] as usize, self.col_ptr[c + 1] as usize);
            // Symmetric: row c of A equals column c.
            *yc = (a..b)
                .map(|s| values[s] * x[self.row_idx[s] as usize])
                .sum();
        }
    }

    /// Replace the rows and columns of `pinned` vertices by the identity, keeping the pattern.
    pub fn pin(&self, values: &mut [f64], pinned: &[u32]) {
        for &v in pinned {
            for &e in &self.vertex_edges[v as usize] {
                for s in self.edge_slots[e as usize] {
                    values[s as usize] = 0.0;
                }
            }
            values[self.diag[v as usize] as usize] = 1.0;
        }
    }

    /// Column `c`'s (row, slot) pairs.
    pub fn column(&self, c: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        (self.col_ptr[c] as usize..self.col_ptr[c + 1] as usize)
            .map(|s| (self.row_idx[s] as usize, s))
    }
}

/// Why a factorisation failed: a numerical breakdown (the matrix is not positive definite) or a
/// resource failure.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FactorError {
    /// Non-positive pivot at this (permuted) index.
    NotPositiveDefinite {
        pivot: usize,
    },
    Resource(String),
}

impl std::fmt::Display for FactorError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FactorError::NotPositiveDefinite { pivot } => {
                write!(
                    f,
                    "matrix is not positive definite (pivot {pivot}); a degenerate mesh?"
                )
            }
            FactorError::Resource(m) => write!(f, "sparse factorisation failed: {m}"),
        }
    }
}

impl std::error::Error for FactorError {}

/// The symbolic Cholesky factorisation of a pattern (AMD ordering), shared by its numeric factors.
#[derive(Clone)]
pub struct Symbolic {
    inner: Arc<SymbolicCholesky<u32>>,
    pattern: Arc<Pattern>,
}

impl Symbolic {
    pub fn new(pattern: Arc<Pattern>) -> Result<Symbolic, FactorError> {
        let inner = factorize_symbolic_cholesky(
            pattern.symbolic(),
            Side::Lower,
            Default::default(),
            Default::default(),
        )
        .map_err(|e| FactorError::Resource(format!("{e:?}")))?;
        Ok(Symbolic {
            inner: Arc::new(inner),
            pattern,
        })
    }

    pub fn pattern(&self) -> &Pattern {
        &self.pattern
    }

    /// Numeric factorisation of the matrix with `values` on the shared pattern.
    pub fn factor(&self, values: &[f64]) -> Result<Factor, FactorError> {
        let mut l = vec![0.0; self.inner.len_val()];
        let par = Par::rayon(0);
        let mut mem = MemBuffer::new(
            self.inner
                .factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        );
        let a = SparseColMatRef::new(self.pattern.symbolic(), values);
        self.inner
            .factorize_numeric_llt(
                &mut l,
                a,
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| {
                let faer::linalg::solvers::LltError::NonPositivePivot { index } = e;
                FactorError::NotPositiveDefinite { pivot: index }
            })?;
        Ok(Factor {
            symbolic: self.inner.clone(),
            values: l,
        })
    }
}

/// A numeric Cholesky factor; solves in place.
pub struct Factor {
    symbolic: Arc<SymbolicCholesky<u32>>,
    values: Vec<f64>,
}

impl Factor {
    /// Solve A x = b for every column of `rhs` (n × k, column-major), in place. Sequential, so the
    /// result does not depend on the thread count.
    pub fn solve_in_place(&self, rhs: &mut [f64], k: usize) {
        let n = self.symbolic.nrows();
        let par = Par::Seq;
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(k, par));
        let m = MatMut::from_column_major_slice_mut(rhs, n, k);
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            m,
            par,
            MemStack::new(&mut mem),
        );
    }
}
