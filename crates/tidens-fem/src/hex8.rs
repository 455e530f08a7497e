//! The 8-node trilinear hexahedron on the reference cube [-1, 1]^3.
//!
//! Node order is VTK_HEXAHEDRON: nodes 0-3 counter-clockwise on the face
//! zeta = -1 seen from +zeta, nodes 4-7 above them on zeta = +1.

/// Natural coordinates of the eight nodes.
pub const NODES: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// The 2x2x2 Gauss rule: points at +-1/sqrt(3), unit weights. Exact for the
/// volume of a trilinear element.
pub fn gauss_points() -> [[f64; 3]; 8] {
    let g = 1.0 / 3.0_f64.sqrt();
    let mut p = [[0.0; 3]; 8];
    for (k, node) in NODES.iter().enumerate() {
        p[k] = [node[0] * g, node[1] * g, node[2] * g];
    }
    p
}

/// Shape function values at natural coordinates `xi`.
pub fn shape(xi: [f64; 3]) -> [f64; 8] {
    let mut n = [0.0; 8];
    for (a, node) in NODES.iter().enumerate() {
        n[a] = 0.125 * (1.0 + node[0] * xi[0]) * (1.0 + node[1] * xi[1]) * (1.0 + node[2] * xi[2]);
    }
    n
}

/// Shape function derivatives with respect to the natural coordinates.
pub fn shape_gradients(xi: [f64; 3]) -> [[f64; 3]; 8] {
    let mut d = [[0.0; 3]; 8];
    for (a, s) in NODES.iter().enumerate() {
        let (p0, p1, p2) = (1.0 + s[0] * xi[0], 1.0 + s[1] * xi[1], 1.0 + s[2] * xi[2]);
        d[a] = [
            0.125 * s[0] * p1 * p2,
            0.125 * p0 * s[1] * p2,
            0.125 * p0 * p1 * s[2],
        ];
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_of_unity_and_kronecker_property() {
        for (a, node) in NODES.iter().enumerate() {
            let n = shape(*node);
            for (b, v) in n.iter().enumerate() {
                assert_eq!(*v, if a == b { 1.0 } else { 0.0 });
            }
        }
        for p in gauss_points() {
            let s: f64 = shape(p).iter().sum();
            assert!((s - 1.0).abs() < 1e-15);
            let g = shape_gradients(p);
            for k in 0..3 {
                let s: f64 = g.iter().map(|d| d[k]).sum();
                assert!(s.abs() < 1e-15);
            }
        }
    }

    #[test]
    fn gradients_match_finite_differences() {
        let xi = [0.3, -0.7, 0.1];
        let g = shape_gradients(xi);
        let h = 1e-6;
        for k in 0..3 {
            let mut xp = xi;
            xp[k] += h;
            let mut xm = xi;
            xm[k] -= h;
            let (np, nm) = (shape(xp), shape(xm));
            for a in 0..8 {
                assert!(((np[a] - nm[a]) / (2.0 * h) - g[a][k]).abs() < 1e-9);
            }
        }
    }
}
