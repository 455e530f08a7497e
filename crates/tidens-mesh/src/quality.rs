//! Volumes and element-quality measures of a [`HexMesh`].

use crate::HexMesh;
use crate::hex::{CORNERS, TrilinearMap, det3, gauss_points, scaled_det};

impl HexMesh {
    /// Corner coordinates \[mm\] of element `e`, in its node order.
    ///
    /// Panics if `e >= self.element_count()` (like slice indexing).
    pub fn element_coordinates(&self, e: usize) -> [[f64; 3]; 8] {
        self.elements[e].map(|n| self.nodes[n])
    }

    /// Volume \[mm^3\] of the trilinear element `e` (2x2x2 Gauss rule, exact for
    /// a trilinear map). Panics if `e` is out of range.
    pub fn element_volume(&self, e: usize) -> f64 {
        let map = TrilinearMap::new(&self.element_coordinates(e));
        gauss_points().iter().map(|&g| det3(&map.jacobian(g))).sum()
    }

    /// Total volume \[mm^3\] of the trilinear elements.
    pub fn volume(&self) -> f64 {
        (0..self.elements.len())
            .map(|e| self.element_volume(e))
            .sum()
    }

    /// Smallest scaled Jacobian of element `e` over its 8 corners: 1 for a
    /// rectangular box, <= 0 for an inverted or degenerate element.
    pub fn element_min_scaled_jacobian(&self, e: usize) -> f64 {
        let map = TrilinearMap::new(&self.element_coordinates(e));
        CORNERS
            .iter()
            .map(|&c| scaled_det(&map.jacobian(c)))
            .fold(f64::INFINITY, f64::min)
    }

    /// Smallest scaled Jacobian over all elements and their 8 corners
    /// (`f64::INFINITY` for a mesh without elements).
    pub fn min_scaled_jacobian(&self) -> f64 {
        (0..self.elements.len())
            .map(|e| self.element_min_scaled_jacobian(e))
            .fold(f64::INFINITY, f64::min)
    }

    /// Smallest Jacobian determinant [mm^3 per unit reference volume] of
    /// element `e` over its 8 corners and 8 Gauss points, divided by the
    /// element's mean determinant (volume / 8): positive everywhere in a valid
    /// element, 1 for a parallelepiped.
    pub fn element_min_relative_det(&self, e: usize) -> f64 {
        let map = TrilinearMap::new(&self.element_coordinates(e));
        let gauss = gauss_points().map(|g| det3(&map.jacobian(g)));
        let corners = CORNERS.map(|c| det3(&map.jacobian(c)));
        // The Gauss rule is exact for the volume: mean determinant = volume / 8.
        let mean = gauss.iter().sum::<f64>() / 8.0;
        corners
            .iter()
            .chain(gauss.iter())
            .fold(f64::INFINITY, |m, &d| m.min(d))
            / mean.abs()
    }

    /// Smallest [`Self::element_min_relative_det`] over the mesh.
    pub fn min_relative_det(&self) -> f64 {
        (0..self.elements.len())
            .map(|e| self.element_min_relative_det(e))
            .fold(f64::INFINITY, f64::min)
    }
}
