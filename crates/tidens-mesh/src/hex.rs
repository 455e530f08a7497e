//! Trilinear 8-node hexahedron: reference corners, faces, shape-function
//! derivatives and the Jacobian of the map from the reference cube [-1,1]^3.
//!
//! Node order is VTK_HEXAHEDRON: corners 0-3 are the bottom (zeta = -1) quad,
//! counter-clockwise seen from +zeta, corners 4-7 lie above 0-3.

/// Reference coordinates (xi, eta, zeta) of the 8 corners, in VTK order.
pub const CORNERS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// Local corner indices of the 6 faces, each ordered so that its right-hand
/// normal points out of a right-handed element. Order: xi = -1, xi = +1,
/// eta = -1, eta = +1, zeta = -1, zeta = +1.
pub const FACES: [[usize; 4]; 6] = [
    [3, 0, 4, 7],
    [1, 2, 6, 5],
    [0, 1, 5, 4],
    [2, 3, 7, 6],
    [0, 3, 2, 1],
    [4, 5, 6, 7],
];

/// Index into [`FACES`] of the face xi = -1.
pub const FACE_XI_MIN: usize = 0;
/// Index into [`FACES`] of the face eta = -1.
pub const FACE_ETA_MIN: usize = 2;
/// Index into [`FACES`] of the face zeta = -1.
pub const FACE_ZETA_MIN: usize = 4;
/// Index into [`FACES`] of the face zeta = +1.
pub const FACE_ZETA_MAX: usize = 5;

/// Reference coordinate of the 2-point Gauss rule on [-1, 1] (weights 1).
pub const GAUSS_2: f64 = 0.577_350_269_189_625_8;

/// The 8 points of the 2x2x2 Gauss rule (all weights 1). It integrates the
/// Jacobian determinant of a trilinear hexahedron exactly.
pub fn gauss_points() -> [[f64; 3]; 8] {
    CORNERS.map(|c| c.map(|v| v * GAUSS_2))
}

/// Values of the 8 trilinear shape functions at `xi`.
pub fn shape(xi: [f64; 3]) -> [f64; 8] {
    CORNERS.map(|c| 0.125 * (1.0 + c[0] * xi[0]) * (1.0 + c[1] * xi[1]) * (1.0 + c[2] * xi[2]))
}

/// Derivatives dN_i/d(xi, eta, zeta) of the 8 trilinear shape functions at `xi`.
pub fn shape_derivatives(xi: [f64; 3]) -> [[f64; 3]; 8] {
    CORNERS.map(|c| {
        let f = [1.0 + c[0] * xi[0], 1.0 + c[1] * xi[1], 1.0 + c[2] * xi[2]];
        [
            0.125 * c[0] * f[1] * f[2],
            0.125 * c[1] * f[0] * f[2],
            0.125 * c[2] * f[0] * f[1],
        ]
    })
}

/// Jacobian of the trilinear map at `xi`: `j[r][c] = d x_r / d xi_c` \[mm\].
pub fn jacobian(x: &[[f64; 3]; 8], xi: [f64; 3]) -> [[f64; 3]; 3] {
    TrilinearMap::new(x).jacobian(xi)
}

/// The trilinear map of one hexahedron in monomial form,
/// `x = c0 + c1 xi + c2 eta + c3 zeta + c4 xi eta + c5 eta zeta + c6 zeta xi + c7 xi eta zeta`,
/// so that Jacobians at many points cost a few multiplications each.
#[derive(Clone, Copy, Debug)]
pub struct TrilinearMap {
    c: [[f64; 3]; 8],
}

impl TrilinearMap {
    /// Map of the hexahedron with corner coordinates `x` (VTK order) \[mm\].
    pub fn new(x: &[[f64; 3]; 8]) -> Self {
        // Each monomial's coefficient is (1/8) sum_i x_i m(corner_i).
        let mut c = [[0.0; 3]; 8];
        for (p, r) in x.iter().zip(CORNERS.iter()) {
            let m = [
                1.0,
                r[0],
                r[1],
                r[2],
                r[0] * r[1],
                r[1] * r[2],
                r[2] * r[0],
                r[0] * r[1] * r[2],
            ];
            for (ck, mk) in c.iter_mut().zip(m) {
                for d in 0..3 {
                    ck[d] += 0.125 * mk * p[d];
                }
            }
        }
        TrilinearMap { c }
    }

    /// Jacobian `j[r][c] = d x_r / d xi_c` \[mm\] at reference point `xi`.
    pub fn jacobian(&self, xi: [f64; 3]) -> [[f64; 3]; 3] {
        let [x, y, z] = xi;
        let c = &self.c;
        let mut j = [[0.0; 3]; 3];
        for (r, row) in j.iter_mut().enumerate() {
            row[0] = c[1][r] + c[4][r] * y + c[6][r] * z + c[7][r] * y * z;
            row[1] = c[2][r] + c[4][r] * x + c[5][r] * z + c[7][r] * z * x;
            row[2] = c[3][r] + c[5][r] * y + c[6][r] * x + c[7][r] * x * y;
        }
        j
    }
}

/// Determinant of a 3x3 matrix.
pub fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Scaled Jacobian det(J) / (|J e1| |J e2| |J e3|) of a Jacobian: 1 for an
/// orthogonal frame, 0 for a degenerate one, negative for an inverted one.
pub fn scaled_det(j: &[[f64; 3]; 3]) -> f64 {
    let col = |c: usize| (j[0][c] * j[0][c] + j[1][c] * j[1][c] + j[2][c] * j[2][c]).sqrt();
    let norms = col(0) * col(1) * col(2);
    if norms > 0.0 { det3(j) / norms } else { 0.0 }
}

/// Area vector (outward normal times area) \[mm^2\] of the bilinear quad through
/// `p` (nodes in right-hand order): half the cross product of its diagonals,
/// which is exact for a bilinear (possibly warped) quad.
pub fn quad_area_vector(p: &[[f64; 3]; 4]) -> [f64; 3] {
    let d1 = sub(p[2], p[0]);
    let d2 = sub(p[3], p[1]);
    cross(d1, d2).map(|v| 0.5 * v)
}

/// Flux integral of the position field, integral over the bilinear quad of x . n dA
/// \[mm^3\], for nodes `p` in right-hand order. Exact (2x2 Gauss on a polynomial of
/// degree 2 per direction).
pub fn quad_position_flux(p: &[[f64; 3]; 4]) -> f64 {
    let mut flux = 0.0;
    for s in [-GAUSS_2, GAUSS_2] {
        for t in [-GAUSS_2, GAUSS_2] {
            let n = [
                0.25 * (1.0 - s) * (1.0 - t),
                0.25 * (1.0 + s) * (1.0 - t),
                0.25 * (1.0 + s) * (1.0 + t),
                0.25 * (1.0 - s) * (1.0 + t),
            ];
            let mut x = [0.0; 3];
            let mut dxs = [0.0; 3];
            let mut dxt = [0.0; 3];
            let ds = [
                -0.25 * (1.0 - t),
                0.25 * (1.0 - t),
                0.25 * (1.0 + t),
                -0.25 * (1.0 + t),
            ];
            let dt = [
                -0.25 * (1.0 - s),
                -0.25 * (1.0 + s),
                0.25 * (1.0 + s),
                0.25 * (1.0 - s),
            ];
            for k in 0..4 {
                for r in 0..3 {
                    x[r] += n[k] * p[k][r];
                    dxs[r] += ds[k] * p[k][r];
                    dxt[r] += dt[k] * p[k][r];
                }
            }
            let nda = cross(dxs, dxt);
            flux += x[0] * nda[0] + x[1] * nda[1] + x[2] * nda[2];
        }
    }
    flux
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_cube() -> [[f64; 3]; 8] {
        CORNERS.map(|c| c.map(|v| 0.5 * (v + 1.0)))
    }

    #[test]
    fn shape_functions_interpolate_and_sum_to_one() {
        for (a, corner) in CORNERS.iter().enumerate() {
            for (b, v) in shape(*corner).iter().enumerate() {
                assert_eq!(*v, if a == b { 1.0 } else { 0.0 });
            }
        }
        for p in gauss_points() {
            assert!((shape(p).iter().sum::<f64>() - 1.0).abs() < 1e-15);
            for k in 0..3 {
                assert!(shape_derivatives(p).iter().map(|d| d[k]).sum::<f64>().abs() < 1e-15);
            }
        }
    }

    #[test]
    fn shape_derivatives_match_finite_differences() {
        let xi = [0.3, -0.7, 0.1];
        let g = shape_derivatives(xi);
        let h = 1e-6;
        for k in 0..3 {
            let (mut xp, mut xm) = (xi, xi);
            xp[k] += h;
            xm[k] -= h;
            let (np, nm) = (shape(xp), shape(xm));
            for a in 0..8 {
                assert!(((np[a] - nm[a]) / (2.0 * h) - g[a][k]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn unit_cube_jacobian_is_half_identity() {
        let j = jacobian(&unit_cube(), [0.3, -0.2, 0.7]);
        for (r, row) in j.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                let want = if r == c { 0.5 } else { 0.0 };
                assert!((v - want).abs() < 1e-15);
            }
        }
        assert!((scaled_det(&j) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn monomial_jacobian_matches_shape_derivatives() {
        let x: [[f64; 3]; 8] = std::array::from_fn(|i| {
            let c = CORNERS[i];
            [
                c[0] + 0.1 * (i as f64).sin(),
                c[1] + 0.2 * c[0] * c[2],
                1.5 * c[2] + 0.05 * i as f64,
            ]
        });
        for xi in [[0.0, 0.0, 0.0], [0.3, -0.7, 0.9], [-1.0, 1.0, -1.0]] {
            let dn = shape_derivatives(xi);
            let j = jacobian(&x, xi);
            for r in 0..3 {
                for c in 0..3 {
                    let want: f64 = (0..8).map(|i| x[i][r] * dn[i][c]).sum();
                    assert!((j[r][c] - want).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn faces_point_outward_on_unit_cube() {
        let x = unit_cube();
        let centre = [0.5; 3];
        for f in FACES {
            let p = f.map(|i| x[i]);
            let a = quad_area_vector(&p);
            let fc: [f64; 3] =
                std::array::from_fn(|r| 0.25 * (p[0][r] + p[1][r] + p[2][r] + p[3][r]));
            let out: f64 = (0..3).map(|r| a[r] * (fc[r] - centre[r])).sum();
            assert!(out > 0.0, "face {f:?} points inward");
            let area: f64 = a.iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((area - 1.0).abs() < 1e-15);
        }
        // Divergence theorem on the unit cube: (1/3) sum x.n dA = 1.
        let flux: f64 = FACES
            .iter()
            .map(|f| quad_position_flux(&f.map(|i| x[i])))
            .sum();
        assert!((flux / 3.0 - 1.0).abs() < 1e-14);
    }
}
