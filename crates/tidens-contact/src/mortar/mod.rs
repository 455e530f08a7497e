//! Kernels of mortar (segment-to-segment) contact: the weighted gaps of a
//! slave surface's nodes against a master surface, their mortar integrals
//! and their exact derivatives (design: `notes/mortar_design.md`, (b)).
//!
//! For a slave node `j` with test function `Phi_j` (standard or dual, see
//! [`dual`]) and nodal normal `n_j` ([`normals`]):
//!
//! ```text
//! g_j = int_{supp Phi_j} Phi_j n_j . (x_m(pi(x)) - x) dA     [mm^3]    (> 0 open)
//! A_j = int_{supp Phi_j} Phi_j dA                            [mm^2]
//! D_jk = int Phi_j N_k dA,      M_jl = int Phi_j N^m_l dA
//! ```
//!
//! `pi(x)` the master point facing `x` along the auxiliary plane's normal
//! of the slave facet, integrated segment by segment: for each candidate
//! pair (slave facet, master facet) ([`broad`]), the two facets
//! ([`trace`]) are projected on an auxiliary plane and their overlap
//! clipped and cut into triangles ([`clip`]), whose 7-point rules
//! ([`quadrature`]) give the pair's contributions ([`segment`]);
//! [`weighted_gap`] sums them over a node's facets and differentiates
//! them (gradients by the chain rule in `f64`, Hessians by forward-mode
//! automatic differentiation). `g_j / A_j` is the
//! node's mean gap \[mm\]: a uniform gap `delta` between flat surfaces
//! gives `delta` exactly (the contact patch test).
//!
//! These are the kernels only: the contact law, the state across steps
//! and the solver's terms come on top of them.

pub mod broad;
pub mod clip;
mod clip_gradient;
pub mod contact;
pub mod dual;
pub mod normals;
mod pair_derivatives;
mod pair_gradient;
pub mod quadrature;
pub mod segment;
pub mod trace;
pub mod weighted_gap;

pub use broad::candidate_pairs;
pub use contact::{ANY_FACET, MortarCheckpoint, MortarContact};
pub use dual::{SurfaceTestFunctions, TestBasis, TestFunctions};
pub use segment::{PairIntegrals, integrate_pair};
pub use trace::{AdScalar, Facet, Trace};
pub use weighted_gap::{Derivatives, HessianBlock, WeightedGap, weighted_gaps, weighted_gaps_of};

use thiserror::Error;

/// A failure of the mortar kernels.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum MortarError {
    /// Newton on a facet's in-plane inverse map did not converge: the
    /// facet is degenerate, or folded on the auxiliary plane.
    #[error(
        "the in-plane inverse map of a {trace:?} facet at z = ({}, {}) did not converge: last Newton step {step:e} after {iterations} iterations (must fall below {tol:e})",
        z[0], z[1], tol = quadrature::INVERSE_TOLERANCE
    )]
    InverseMap {
        trace: Trace,
        z: [f64; 2],
        iterations: usize,
        step: f64,
    },
    /// A candidate pair names a facet that is not there.
    #[error(
        "candidate pair (slave facet {slave}, master facet {master}): must be below ({slave_facets}, {master_facets})"
    )]
    Pair {
        slave: usize,
        master: usize,
        slave_facets: usize,
        master_facets: usize,
    },
    /// A surface names a node that the coordinates do not have.
    #[error("node {node}: the coordinates have {nodes} nodes")]
    Node { node: usize, nodes: usize },
}
