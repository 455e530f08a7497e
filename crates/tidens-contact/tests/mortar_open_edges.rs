//! Two contact surfaces that end on the same plane, as the surfaces of two
//! octant particles end on the plane of symmetry that cuts them both: a
//! slave strip standing on the plane `z = 0` at (nearly) a right angle, a
//! master strip 1e-3 mm into it, its last edge on the plane too.
//!
//! Projected onto the slave's facets, the master's last edge lies along
//! the slave's own; tilting the slave by `+-s` decides which of the two
//! bounds their overlap, so the weighted gaps have a kink at `s = 0` and
//! their gradients (the contact forces) jump there. With the master's
//! facets continued past its open edges
//! (`ContactSurface::continue_open_edges`), the slave's edge alone bounds
//! the overlap: the gradients on either side agree to the tilt's order.

#[path = "support/mortar_meshes.rs"]
mod meshes;

use std::collections::BTreeMap;

use meshes::{gaps, patch};
use tidens_contact::mortar::{Derivatives, TestBasis};

/// The slave nodes' weighted-gap gradients, by node, with the slave tilted
/// by the slope `s` (`y = -s z`) and the master continued by `reach`.
fn gradients(s: f64, reach: f64) -> BTreeMap<usize, BTreeMap<usize, f64>> {
    let mut x = Vec::new();
    // Normal +y (x_u x x_v with x_u = e_x, x_v = -e_z), from z = -1 up to
    // the plane z = 0.
    let slave = patch(
        &mut x,
        3,
        2,
        |u, v| [u, s * (1.0 - v), v - 1.0],
        false,
        true,
    );
    // Normal -y, from z = -0.97 up to z = 0, non-matching along x.
    let mut master = patch(
        &mut x,
        4,
        3,
        |u, v| [0.1 + 1.03 * u, -1e-3, 0.97 * (v - 1.0)],
        true,
        true,
    );
    master.continue_open_edges(reach);
    gaps(
        &slave,
        &master,
        &x,
        TestBasis::Standard,
        0.3,
        Derivatives::Gradient,
    )
    .into_iter()
    .map(|g| (g.node, g.gradient.into_iter().collect()))
    .collect()
}

/// The largest difference between the gradients at the tilts `+s` and
/// `-s`, and the largest gradient entry.
fn jump(s: f64, reach: f64) -> (f64, f64) {
    let (a, b) = (gradients(s, reach), gradients(-s, reach));
    assert_eq!(a.len(), b.len());
    let mut worst = 0.0f64;
    let mut scale = 0.0f64;
    for (node, ga) in &a {
        let gb = &b[node];
        for (dof, va) in ga {
            scale = scale.max(va.abs());
            worst = worst.max((va - gb.get(dof).copied().unwrap_or(0.0)).abs());
        }
        for (dof, vb) in gb {
            worst = worst.max((vb - ga.get(dof).copied().unwrap_or(0.0)).abs());
        }
    }
    (worst, scale)
}

#[test]
fn the_weighted_gaps_are_smooth_where_both_surfaces_end_on_one_plane() {
    let s = 1e-9;
    let (kink, scale) = jump(s, 0.0);
    let (smooth, _) = jump(s, 0.5);
    println!(
        "gradient jump across a tilt of +-{s:e}: {kink:.3e} without continuation, {smooth:.3e} with (largest entry {scale:.3e})"
    );
    // Without the continuation the jump is of the order of the penetration
    // times the edge: the test would see it.
    assert!(kink > 1e-5 * scale, "{kink:e} of {scale:e}");
    assert!(smooth < 1e-7 * scale, "{smooth:e} of {scale:e}");
}
