//! Reference elements of the mean-dilatation kernel: shape-function
//! gradients and the two quadrature rules the kernel needs.
//!
//! The element energy `sum_gp w0 W_dev(F_gp) + V U(v / V)` uses
//! - the *material points* (`NGP`, with weights) for the deviatoric energy:
//!   the material state lives there, and each costs one return map;
//! - a *volume rule* for the current and reference volumes `v`, `V`, made of
//!   the material points (with their own volume weights) plus `NXP` extra
//!   points where only the kinematics (`det F`, `grad_x N`) is evaluated. It
//!   must integrate `det J` exactly, so that `theta = v / V` is the exact
//!   volume ratio of the discrete element and the volume constraint is the
//!   true one.

use tidens_mesh::{hex, tet10};

/// A reference element with `NEN` nodes, `NGP` material points and `NXP`
/// extra volume points.
pub trait ReferenceElement<const NEN: usize, const NGP: usize, const NXP: usize> {
    /// Derivatives `dN_a / d xi_k` of the `NEN` shape functions at the
    /// reference point `xi`.
    fn shape_derivatives(xi: [f64; 3]) -> [[f64; 3]; NEN];
    /// Reference coordinates of the material points.
    fn material_points() -> [[f64; 3]; NGP];
    /// Weights of the material points in the deviatoric energy (reference
    /// measure; multiplied by `det J0` in the element).
    fn material_weights() -> [f64; NGP];
    /// Weights of the material points in the volume rule.
    fn volume_weights() -> [f64; NGP];
    /// Reference coordinates of the extra points of the volume rule.
    fn extra_volume_points() -> [[f64; 3]; NXP];
    /// Weights of the extra points of the volume rule.
    fn extra_volume_weights() -> [f64; NXP];
}

/// Trilinear 8-node hexahedron (VTK_HEXAHEDRON) with the 2x2x2 Gauss rule
/// (weights 1) both for the deviatoric energy and for the volume: the rule
/// integrates `det J` of a trilinear map exactly, so no extra points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Hex8;

impl ReferenceElement<8, 8, 0> for Hex8 {
    fn shape_derivatives(xi: [f64; 3]) -> [[f64; 3]; 8] {
        hex::shape_derivatives(xi)
    }
    fn material_points() -> [[f64; 3]; 8] {
        hex::gauss_points()
    }
    fn material_weights() -> [f64; 8] {
        [1.0; 8]
    }
    fn volume_weights() -> [f64; 8] {
        [1.0; 8]
    }
    fn extra_volume_points() -> [[f64; 3]; 0] {
        []
    }
    fn extra_volume_weights() -> [f64; 0] {
        []
    }
}

/// Quadratic 10-node tetrahedron (VTK_QUADRATIC_TETRA, see
/// [`tidens_mesh::tet10`]).
///
/// Material points: the symmetric 4-point rule (degree 2). For a
/// straight-sided element the strain of a quadratic displacement is linear, so
/// the linearised deviatoric energy is quadratic and the rule integrates it
/// exactly; then the only displacement modes without deviatoric strain and
/// without mean dilatation are the 3 "special conformal" modes
/// `u = 2 (b.x) x - |x|^2 b` (pure dilatation, linear in x, zero mean), which a
/// more accurate rule would not remove either (they come from one pressure per
/// element). They do not survive assembly: continuity across a face forces
/// one such field on all elements, and its dilatation `3 lambda + 6 b.x`
/// cannot have zero mean on elements whose centroids are not coplanar.
/// A degree-3 rule ([`Tet10Degree3`]) costs 2.5x the return maps for no gain
/// in stability; its advantage, the exact patch test on elements with curved
/// reference edges, concerns the curved surface layer only (with interior
/// mid-edge nodes moved by 2% of the element size, the 4-point rule leaves
/// nodal residuals of 5e-5 of the element forces under a uniform stress).
///
/// Volume rule: the 10-point positive rule exact to degree 3
/// ([`tet10::volume_rule`]) that contains the 4 material points, so `v` and
/// `V` are exact (det J of a quadratic map is a cubic) at the cost of 6 extra
/// kinematic points and no extra return maps. With the 4-point rule alone the
/// volume of a curved element would be off by a relative O((h |grad F|)^3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tet10;

impl ReferenceElement<10, 4, 6> for Tet10 {
    fn shape_derivatives(xi: [f64; 3]) -> [[f64; 3]; 10] {
        tet10::shape_derivatives(xi)
    }
    fn material_points() -> [[f64; 3]; 4] {
        tet10::gauss_points()
    }
    fn material_weights() -> [f64; 4] {
        tet10::GAUSS_WEIGHTS
    }
    fn volume_weights() -> [f64; 4] {
        tet10::VOLUME_WEIGHTS_AT_GAUSS_POINTS
    }
    fn extra_volume_points() -> [[f64; 3]; 6] {
        tet10::edge_orbit_points()
    }
    fn extra_volume_weights() -> [f64; 6] {
        tet10::VOLUME_WEIGHTS_AT_EDGE_POINTS
    }
}

/// The quadratic tetrahedron with every integral on the 10-point degree-3
/// rule ([`tet10::volume_rule`]): 10 material points, no extra points.
///
/// It passes the patch test exactly also on elements with curved reference
/// edges (where `cof(J0) grad_xi N`, the integrand of a uniform stress, is a
/// cubic), which [`Tet10`]'s 4-point rule does only for straight-sided ones;
/// it costs 2.5 times the return maps. Offered so that the choice can be
/// made by measurement; [`Tet10`] is the default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tet10Degree3;

impl ReferenceElement<10, 10, 0> for Tet10Degree3 {
    fn shape_derivatives(xi: [f64; 3]) -> [[f64; 3]; 10] {
        tet10::shape_derivatives(xi)
    }
    fn material_points() -> [[f64; 3]; 10] {
        tet10::volume_rule().map(|(p, _)| p)
    }
    fn material_weights() -> [f64; 10] {
        tet10::volume_rule().map(|(_, w)| w)
    }
    fn volume_weights() -> [f64; 10] {
        tet10::volume_rule().map(|(_, w)| w)
    }
    fn extra_volume_points() -> [[f64; 3]; 0] {
        []
    }
    fn extra_volume_weights() -> [f64; 0] {
        []
    }
}
