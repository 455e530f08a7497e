//! Cells shared by the solver's integration tests.

use tidens_solver::{Cell, Octant};

/// Two sphere octants of radius `radius` \[mm\] stacked along z, touching
/// at their poles: the sc cell doubled along the load. Their contact
/// plane is the mirror plane of the sc cell.
pub fn stacked_pair(radius: f64) -> Cell {
    let oct = |top| Octant {
        corner: [false, false, top],
        a: radius,
        c: radius,
    };
    Cell::new(
        "stacked pair",
        [radius, radius, 2.0 * radius],
        vec![oct(false), oct(true)],
    )
    .unwrap()
}
