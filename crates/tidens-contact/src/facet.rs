//! The geometry of a master facet of either kind (bilinear quad or flat
//! triangle), behind one set of functions: a facet is four node
//! positions, a triangle repeating its third node in the fourth place.

use crate::gap::{project_from, project_triangle, shape, triangle_shape};
use crate::penetration::{
    Penetration, PenetrationHessian, penetration_gradient, penetration_hessian,
    triangle_penetration_gradient, triangle_penetration_hessian,
};
use crate::surface::FacetKind;

fn corners(x: &[[f64; 3]; 4]) -> [[f64; 3]; 3] {
    [x[0], x[1], x[2]]
}

/// Parameters of the projection of `s` on the facet (quads: Newton from the
/// centre; triangles: the foot on their plane).
pub fn project_on(kind: FacetKind, s: &[f64; 3], x: &[[f64; 3]; 4]) -> [f64; 2] {
    match kind {
        FacetKind::Quad => project_from(s, x, [0.0, 0.0]),
        FacetKind::Triangle => project_triangle(s, &corners(x)),
    }
}

/// Parameters of the projection of `s` on the facet, Newton from `xi` for
/// quads (to follow a root of the closest-point conditions known nearby).
pub fn project_from_on(kind: FacetKind, s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> [f64; 2] {
    match kind {
        FacetKind::Quad => project_from(s, x, xi),
        FacetKind::Triangle => project_triangle(s, &corners(x)),
    }
}

/// Penetration and its gradient, `xi` the projection.
pub fn gradient_on(kind: FacetKind, s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> Penetration {
    match kind {
        FacetKind::Quad => penetration_gradient(s, x, xi),
        FacetKind::Triangle => triangle_penetration_gradient(s, &corners(x), xi),
    }
}

/// Penetration, gradient and Hessian, `xi` the projection.
pub fn hessian_on(
    kind: FacetKind,
    s: &[f64; 3],
    x: &[[f64; 3]; 4],
    xi: [f64; 2],
) -> PenetrationHessian {
    match kind {
        FacetKind::Quad => penetration_hessian(s, x, xi),
        FacetKind::Triangle => triangle_penetration_hessian(s, &corners(x), xi),
    }
}

/// Penetration \[mm\], `xi` the projection.
pub fn penetration_on(kind: FacetKind, s: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> f64 {
    gradient_on(kind, s, x, xi).value
}

/// Shape functions of the four slots at `xi` (a triangle's fourth is zero).
pub fn shape_on(kind: FacetKind, xi: [f64; 2]) -> [f64; 4] {
    match kind {
        FacetKind::Quad => shape(xi),
        FacetKind::Triangle => {
            let n = triangle_shape(xi);
            [n[0], n[1], n[2], 0.0]
        }
    }
}

/// How far `xi` lies outside the facet: at most 1 inside, 1 on its edge,
/// growing by 1 per half parameter range beyond it (quads: max |xi|;
/// triangles: 1 + 2 max(-xi, -eta, xi + eta - 1)).
pub fn outside(kind: FacetKind, xi: [f64; 2]) -> f64 {
    match kind {
        FacetKind::Quad => xi[0].abs().max(xi[1].abs()),
        FacetKind::Triangle => 1.0 + 2.0 * (-xi[0]).max(-xi[1]).max(xi[0] + xi[1] - 1.0),
    }
}

/// Gap vector of a tied node: slave point minus the material point of the
/// facet at `xi` \[mm\].
pub fn tie_gap_on(kind: FacetKind, slave: &[f64; 3], x: &[[f64; 3]; 4], xi: [f64; 2]) -> [f64; 3] {
    let n = shape_on(kind, xi);
    [0, 1, 2].map(|i| slave[i] - (0..4).map(|a| n[a] * x[a][i]).sum::<f64>())
}
