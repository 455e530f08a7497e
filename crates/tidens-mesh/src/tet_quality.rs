//! Volumes and validity measures of a [`TetMesh`].

use crate::TetMesh;
use crate::hex::det3;
use crate::tet10::{det_bernstein, jacobian, nodes, volume_rule};

impl TetMesh {
    /// Node coordinates \[mm\] of element `e`, in its node order.
    ///
    /// Panics if `e >= self.element_count()` (like slice indexing).
    pub fn element_coordinates(&self, e: usize) -> [[f64; 3]; 10] {
        self.elements[e].map(|n| self.nodes[n])
    }

    /// Volume \[mm^3\] of the quadratic element `e`: `det J` is a cubic in the
    /// reference coordinates and the 10-point rule
    /// [`crate::tet10::volume_rule`] is exact to degree 3. Panics if `e` is
    /// out of range.
    pub fn element_volume(&self, e: usize) -> f64 {
        let x = self.element_coordinates(e);
        volume_rule()
            .iter()
            .map(|(p, w)| w * det3(&jacobian(&x, *p)))
            .sum()
    }

    /// Total volume \[mm^3\] of the quadratic elements.
    pub fn volume(&self) -> f64 {
        (0..self.elements.len())
            .map(|e| self.element_volume(e))
            .sum()
    }

    /// Smallest Jacobian determinant of element `e` over its 10 nodes and
    /// the 10 points of the volume rule (which include the 4 Gauss points),
    /// divided by the element's mean determinant (6 x volume): positive in a
    /// valid element, 1 for a straight-sided one.
    pub fn element_min_relative_det(&self, e: usize) -> f64 {
        let x = self.element_coordinates(e);
        let rule = volume_rule();
        let at_points = rule.map(|(p, _)| det3(&jacobian(&x, p)));
        let mean = 6.0
            * rule
                .iter()
                .zip(&at_points)
                .map(|((_, w), d)| w * d)
                .sum::<f64>();
        nodes()
            .iter()
            .map(|&p| det3(&jacobian(&x, p)))
            .chain(at_points)
            .fold(f64::INFINITY, f64::min)
            / mean.abs()
    }

    /// Smallest [`Self::element_min_relative_det`] over the mesh
    /// (`f64::INFINITY` for a mesh without elements).
    pub fn min_relative_det(&self) -> f64 {
        (0..self.elements.len())
            .map(|e| self.element_min_relative_det(e))
            .fold(f64::INFINITY, f64::min)
    }

    /// A lower bound of `det J` over the whole element `e` (not only at sample
    /// points), relative to its mean: the smallest Bernstein coefficient of the
    /// cubic `det J` ([`crate::tet10::det_bernstein`]) over their mean. When it
    /// is positive the element is certainly not inverted anywhere.
    pub fn element_relative_det_bound(&self, e: usize) -> f64 {
        let c = det_bernstein(&self.element_coordinates(e));
        let mean = c.iter().sum::<f64>() / 20.0;
        c.iter().fold(f64::INFINITY, |m, &v| m.min(v)) / mean.abs()
    }

    /// Mean-ratio shape quality of the straight tetrahedron through the corners
    /// of element `e`: `12 (3 V)^(2/3) / sum of the squared edge lengths`, 1 for
    /// a regular tetrahedron, 0 for a flat one, negative when inverted. The
    /// six tetrahedra of a cube score 0.76 or 0.84.
    pub fn element_mean_ratio(&self, e: usize) -> f64 {
        let x = self.element_coordinates(e);
        let d = |i: usize, j: usize| -> [f64; 3] { std::array::from_fn(|r| x[j][r] - x[i][r]) };
        let (a, b, c) = (d(0, 1), d(0, 2), d(0, 3));
        let six_v = det3(&[[a[0], b[0], c[0]], [a[1], b[1], c[1]], [a[2], b[2], c[2]]]);
        let sq = |v: [f64; 3]| v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        let edges: f64 = crate::tet10::EDGES.iter().map(|&[i, j]| sq(d(i, j))).sum();
        let three_v = 0.5 * six_v;
        12.0 * three_v.signum() * three_v.abs().powf(2.0 / 3.0) / edges
    }

    /// Smallest [`Self::element_mean_ratio`] over the mesh.
    pub fn min_mean_ratio(&self) -> f64 {
        (0..self.elements.len())
            .map(|e| self.element_mean_ratio(e))
            .fold(f64::INFINITY, f64::min)
    }

    /// Smallest [`Self::element_relative_det_bound`] over the mesh.
    pub fn min_relative_det_bound(&self) -> f64 {
        (0..self.elements.len())
            .map(|e| self.element_relative_det_bound(e))
            .fold(f64::INFINITY, f64::min)
    }
}
