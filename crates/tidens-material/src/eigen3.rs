//! Eigen-decomposition of a symmetric 3x3 matrix, tuned for the trial left
//! Cauchy-Green tensor `b = F Cp^-1 F^T` of the material point.
//!
//! That tensor is nearly always close to a multiple of the identity (elastic
//! strains of 1e-4 to 1e-2), so its eigenvalues are nearly equal and often
//! exactly equal (virgin state, uniaxial states, rigid rotations). A general
//! solver (Householder tridiagonalisation and shifted QR) spends most of its
//! time there on a problem that deflation solves in closed form:
//!
//! 1. Shift and scale: `s = (b - m I) / h` with `m = tr(b)/3` and `h` the
//!    largest entry of `|b - m I|`. The shift takes the common part out exactly
//!    (the entries of `b - m I` carry the rounding of `b` only, a few ulps of
//!    `|b|`; the shift is done twice so that `s` is traceless to ulps of `|s|`
//!    even then); the scaling keeps the invariants clear of under- and
//!    overflow.
//! 2. The eigenvalue of `s` farthest from zero, `eta_1`, is the root of largest
//!    magnitude of the characteristic polynomial `eta^3 - J2 eta - J3`
//!    (`J2 = tr(s^2)/2`, `J3 = det s`, `s` being traceless). It is always a
//!    simple root, separated from the other two by at least `sqrt(J2)`: the
//!    other two sum to `-eta_1`, so neither can approach `eta_1` unless all
//!    three vanish. Newton's method from `2 sqrt(J2/3)` (an upper bound of every
//!    `|eta|`) converges monotonically onto it, because the polynomial is
//!    convex and increasing beyond its largest root, in at most a handful of
//!    iterations and without trigonometric functions.
//! 3. Its eigenvector `v_1` is the largest cross product of two rows of
//!    `s - eta_1 I` (a matrix of rank two whose null space is `v_1`). Because
//!    `eta_1` is well separated, `v_1` is accurate to a few ulps.
//! 4. The other two eigenpairs live in the plane orthogonal to `v_1`: project
//!    `s` onto an orthonormal basis of that plane and diagonalise the 2x2
//!    matrix with one Jacobi rotation (Rutishauser's formulas). This step is
//!    exact in the sense that matters when the two eigenvalues are equal or
//!    nearly so: it returns an orthonormal pair and eigenvalues accurate to
//!    ulps of `|s|`, with no division by their difference.
//!
//! So the eigenvalues are accurate to a few ulps of `|b|` whether or not they
//! are (nearly) repeated, the eigenvectors are orthonormal to round-off by
//! construction, and `Q diag(lambda) Q^T` reproduces `b` to round-off. When
//! eigenvalues coincide, the eigenvectors are one orthonormal basis of the
//! eigenspace, which is all an isotropic tensor function needs.

use nalgebra::{Matrix3, Vector3};

/// Eigenvalues and orthonormal eigenvectors of a symmetric 3x3 matrix:
/// `a = eigenvectors * diag(eigenvalues) * eigenvectors^T`. The eigenvalues
/// are in no particular order; column `i` of `eigenvectors` belongs to
/// eigenvalue `i`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymmetricEigen3 {
    pub eigenvalues: Vector3<f64>,
    pub eigenvectors: Matrix3<f64>,
}

/// Cap on the Newton iterations for the extreme eigenvalue. From the upper
/// bound `2 sqrt(J2/3)` the worst case (`J3 = 0`, root `sqrt(J2)`) reaches full
/// precision in five iterations; the cap only guards against NaN input.
const MAX_NEWTON: usize = 16;

/// Eigen-decomposition of the symmetric matrix `a` (its two off-diagonal
/// triangles are averaged, so an `a` that is symmetric only to round-off is
/// fine). See the module docs for the method and its accuracy. NaN entries
/// give NaN eigenvalues; nothing panics.
pub fn symmetric_eigen(a: &Matrix3<f64>) -> SymmetricEigen3 {
    let a01 = 0.5 * (a[(0, 1)] + a[(1, 0)]);
    let a02 = 0.5 * (a[(0, 2)] + a[(2, 0)]);
    let a12 = 0.5 * (a[(1, 2)] + a[(2, 1)]);
    let mut mean = (a[(0, 0)] + a[(1, 1)] + a[(2, 2)]) / 3.0;
    let mut d = [a[(0, 0)] - mean, a[(1, 1)] - mean, a[(2, 2)] - mean];
    // The rounding of `mean` leaves a trace of a few ulps of |a| in `d`, which
    // can be the whole of `d` when the eigenvalues are (nearly) equal. A
    // second shift, at the scale of `d`, makes it traceless to ulps of |d|,
    // and gives exact multiples of the identity exactly.
    let d_mean = (d[0] + d[1] + d[2]) / 3.0;
    for x in &mut d {
        *x -= d_mean;
    }
    mean += d_mean;
    let h = d[0]
        .abs()
        .max(d[1].abs())
        .max(d[2].abs())
        .max(a01.abs())
        .max(a02.abs())
        .max(a12.abs());
    if h == 0.0 {
        // A multiple of the identity: every basis is an eigenbasis. (`max`
        // skips NaN, so a NaN off-diagonal entry lands here too and must
        // still come out as NaN.)
        let nan = (a01 + a02 + a12).is_nan();
        return SymmetricEigen3 {
            eigenvalues: Vector3::repeat(if nan { f64::NAN } else { mean }),
            eigenvectors: Matrix3::identity(),
        };
    }
    let inv_h = 1.0 / h;
    let s = Matrix3::new(
        d[0] * inv_h,
        a01 * inv_h,
        a02 * inv_h,
        a01 * inv_h,
        d[1] * inv_h,
        a12 * inv_h,
        a02 * inv_h,
        a12 * inv_h,
        d[2] * inv_h,
    );

    let eta1 = extreme_eigenvalue(&s);
    let v1 = null_vector(&s, eta1);

    // An orthonormal basis (u1, u2) of the plane orthogonal to v1. A row of
    // s - eta1 I lies in that plane (the matrix is symmetric, v1 spans its
    // null space); the largest row is the best conditioned, and removing its
    // residual component along v1 keeps the basis orthonormal to round-off.
    let m = s - Matrix3::from_diagonal_element(eta1);
    let mut r = m.row(0).transpose();
    for i in 1..3 {
        let ri = m.row(i).transpose();
        if ri.norm_squared() > r.norm_squared() {
            r = ri;
        }
    }
    let u1 = (r - v1 * r.dot(&v1)).normalize();
    let u2 = v1.cross(&u1);

    // The 2x2 block of s in that plane, and the Rayleigh quotient of v1
    // (which halves the error of the Newton root).
    let su1 = s * u1;
    let su2 = s * u2;
    let d11 = u1.dot(&su1);
    let d22 = u2.dot(&su2);
    let d12 = 0.5 * (u1.dot(&su2) + u2.dot(&su1));
    let eta1 = v1.dot(&(s * v1));

    // One Jacobi rotation diagonalises the 2x2 block: t = tan(phi) is the
    // smaller root of t^2 + 2 theta t - 1 = 0, which never divides by the
    // difference of the two eigenvalues.
    let (t, c, sn) = if d12 == 0.0 {
        (0.0, 1.0, 0.0)
    } else {
        let theta = 0.5 * (d22 - d11) / d12;
        let t = if theta.abs() > 1e150 {
            0.5 / theta
        } else {
            theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
        };
        let c = 1.0 / (t * t + 1.0).sqrt();
        (t, c, t * c)
    };
    let eta2 = d11 - t * d12;
    let eta3 = d22 + t * d12;
    let v2 = u1 * c - u2 * sn;
    let v3 = u1 * sn + u2 * c;

    SymmetricEigen3 {
        eigenvalues: Vector3::new(mean + h * eta1, mean + h * eta2, mean + h * eta3),
        eigenvectors: Matrix3::from_columns(&[v1, v2, v3]),
    }
}

/// The eigenvalue of largest magnitude of the traceless symmetric `s`
/// (largest entry 1), by Newton's method on its characteristic polynomial
/// (module docs, step 2).
fn extreme_eigenvalue(s: &Matrix3<f64>) -> f64 {
    let j2 = 0.5 * (s[(0, 0)] * s[(0, 0)] + s[(1, 1)] * s[(1, 1)] + s[(2, 2)] * s[(2, 2)])
        + s[(0, 1)] * s[(0, 1)]
        + s[(0, 2)] * s[(0, 2)]
        + s[(1, 2)] * s[(1, 2)];
    let j3 = s.determinant();
    // p(x) = x^3 - J2 x - |J3| has the root x = |eta1|; its sign is J3's.
    let j3_abs = j3.abs();
    let mut x = 2.0 * (j2 / 3.0).sqrt();
    for _ in 0..MAX_NEWTON {
        let p = (x * x - j2) * x - j3_abs;
        let dp = 3.0 * x * x - j2;
        let step = p / dp;
        x -= step;
        // Beyond the root (x >= sqrt(J2) >= (3/4)^(1/2) x0) p''/p' <= 4/x, so
        // the error left after a step s is below 2 s^2 / x: a step under
        // 5e-9 x leaves a fraction of an ulp, and a step that is no longer
        // positive means round-off has been reached.
        if !(step > 5e-9 * x) {
            break;
        }
    }
    if j3 < 0.0 { -x } else { x }
}

/// The unit null vector of `s - eta I`, a symmetric matrix of rank two: the
/// largest of the cross products of its rows (module docs, step 3).
fn null_vector(s: &Matrix3<f64>, eta: f64) -> Vector3<f64> {
    let m = s - Matrix3::from_diagonal_element(eta);
    let r0 = m.row(0).transpose();
    let r1 = m.row(1).transpose();
    let r2 = m.row(2).transpose();
    let c01 = r0.cross(&r1);
    let c02 = r0.cross(&r2);
    let c12 = r1.cross(&r2);
    let (n01, n02, n12) = (c01.norm_squared(), c02.norm_squared(), c12.norm_squared());
    let (c, n) = if n01 >= n02 && n01 >= n12 {
        (c01, n01)
    } else if n02 >= n12 {
        (c02, n02)
    } else {
        (c12, n12)
    };
    c / n.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, SymmetricEigen};

    /// A small deterministic generator.
    struct Lcg(u64);

    impl Lcg {
        /// Uniform in [-1, 1).
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }

        fn rotation(&mut self) -> Matrix3<f64> {
            Rotation3::from_euler_angles(self.next() * 3.2, self.next() * 1.6, self.next() * 3.2)
                .into_inner()
        }

        fn symmetric(&mut self, scale: f64) -> Matrix3<f64> {
            let m = Matrix3::from_fn(|_, _| self.next() * scale);
            (m + m.transpose()) * 0.5
        }
    }

    fn sorted(v: &Vector3<f64>) -> [f64; 3] {
        let mut s = [v[0], v[1], v[2]];
        s.sort_by(f64::total_cmp);
        s
    }

    fn frobenius(a: &Matrix3<f64>) -> f64 {
        a.norm()
    }

    /// Round-off allowed in orthonormality and reconstruction: 6 ulps. The
    /// worst seen over 1e5 random matrices is 5 ulps (nalgebra's
    /// `SymmetricEigen`: 11 ulps for orthonormality, 16 for reconstruction).
    const ROUND_OFF: f64 = 6.0 * f64::EPSILON;

    /// The properties that must hold for any symmetric input: eigenvectors
    /// orthonormal to 1.3e-15, `Q diag(lambda) Q^T = a` to 1.3e-15 relative,
    /// each column an eigenvector (`a q = lambda q`) to the same accuracy.
    /// Returns the decomposition for further checks.
    fn check_decomposition(a: &Matrix3<f64>) -> SymmetricEigen3 {
        let e = symmetric_eigen(a);
        let q = e.eigenvectors;
        let orth = (q.transpose() * q - Matrix3::identity()).amax();
        assert!(orth <= ROUND_OFF, "Q^T Q - I = {orth:e} for {a}");
        let scale = frobenius(a);
        let recon = (q * Matrix3::from_diagonal(&e.eigenvalues) * q.transpose() - a).amax();
        assert!(
            recon <= ROUND_OFF * scale,
            "reconstruction error {recon:e} (|a| = {scale:e}) for {a}"
        );
        for i in 0..3 {
            let res = (a * q.column(i) - q.column(i) * e.eigenvalues[i]).amax();
            assert!(
                res <= ROUND_OFF * scale,
                "eigenpair {i} residual {res:e} for {a}"
            );
        }
        e
    }

    /// Eigenvalues equal to `expected` (any order) within `tol_ulps` ulps of
    /// `|a|` (Frobenius).
    fn check_eigenvalues(a: &Matrix3<f64>, got: &Vector3<f64>, expected: [f64; 3], tol_ulps: f64) {
        let got = sorted(got);
        let mut expected = expected;
        expected.sort_by(f64::total_cmp);
        let tol = tol_ulps * f64::EPSILON * frobenius(a);
        for i in 0..3 {
            assert!(
                (got[i] - expected[i]).abs() <= tol,
                "eigenvalue {i}: {} vs {} (error {:e}, tolerance {tol:e}) for {a}",
                got[i],
                expected[i],
                (got[i] - expected[i]).abs()
            );
        }
    }

    /// `R diag(d) R^T`, symmetrised so the input is exactly symmetric; the
    /// rounding of the product perturbs the eigenvalues by ~1 ulp of `|d|`.
    fn rotated(r: &Matrix3<f64>, d: [f64; 3]) -> Matrix3<f64> {
        let a = r * Matrix3::from_diagonal(&Vector3::from(d)) * r.transpose();
        (a + a.transpose()) * 0.5
    }

    /// Against nalgebra the tolerance is the sum of both solvers' errors:
    /// nalgebra's own reconstruction error reaches 16 ulps.
    #[test]
    fn random_matrices_agree_with_nalgebra() {
        let mut rng = Lcg(1);
        for k in 0..2000 {
            let scale = 10f64.powi(k % 7 - 3);
            let a = rng.symmetric(scale);
            let e = check_decomposition(&a);
            let reference = SymmetricEigen::new(a).eigenvalues;
            check_eigenvalues(&a, &e.eigenvalues, sorted(&reference), 16.0);
        }
    }

    #[test]
    fn exact_identity_and_multiples() {
        for c in [1.0, 1e-300, 3.7, 1e300] {
            let a = Matrix3::identity() * c;
            let e = check_decomposition(&a);
            assert_eq!(e.eigenvalues, Vector3::repeat(c));
            assert_eq!(e.eigenvectors, Matrix3::identity());
        }
        let e = symmetric_eigen(&Matrix3::zeros());
        assert_eq!(e.eigenvalues, Vector3::zeros());
    }

    #[test]
    fn diagonal_and_permuted_diagonal_matrices_are_exact() {
        let diagonals = [
            [1.0, 2.0, 3.0],
            [3.0, 1.0, 2.0],
            [2.0, 3.0, 1.0],
            [1.0, 1.0, 2.0],
            [2.0, 1.0, 1.0],
            [1.0, 2.0, 1.0],
            [1.0 + 1e-15, 1.0, 1.0 - 1e-15],
            [1e-2, 1e2, 1.0],
            [-4.0, 0.0, 4.0],
        ];
        for d in diagonals {
            let a = Matrix3::from_diagonal(&Vector3::from(d));
            let e = check_decomposition(&a);
            check_eigenvalues(&a, &e.eigenvalues, d, 2.0);
            // Permutation matrices as eigenvector sets: P diag P^T stays
            // diagonal, with the same eigenvalues.
            for p in [[1, 2, 0], [2, 0, 1], [0, 2, 1]] {
                let pm = Matrix3::from_fn(|i, j| if p[i] == j { 1.0 } else { 0.0 });
                let ap = pm * a * pm.transpose();
                let e = check_decomposition(&ap);
                check_eigenvalues(&ap, &e.eigenvalues, d, 2.0);
            }
        }
    }

    #[test]
    fn rotated_diagonal_matrices() {
        let mut rng = Lcg(2);
        let spectra = [
            [1.0, 2.0, 3.0],
            [0.5, 1.0, 4.0],
            [-3.0, 0.1, 2.0],
            [1e-2, 1.0, 1e2],
            [1e-2, 1e-2, 1e2],
            [1e-2, 1e2, 1e2],
        ];
        for d in spectra {
            for _ in 0..200 {
                let a = rotated(&rng.rotation(), d);
                let e = check_decomposition(&a);
                check_eigenvalues(&a, &e.eigenvalues, d, 4.0);
            }
        }
    }

    #[test]
    fn exactly_and_nearly_repeated_pairs_and_triples() {
        let mut rng = Lcg(3);
        for split in [0.0, 1e-14, 1e-10, 1e-6] {
            let spectra = [
                // Pairs, above and below the third eigenvalue.
                [1.0, 1.0 + split, 2.0],
                [1.0, 1.0 + split, 0.5],
                // Pairs at the scale of b near I.
                [1.0, 1.0 + split, 1.0 + 3e-4],
                [1.0 - 2e-4, 1.0, 1.0 + split],
                // Triples.
                [1.0, 1.0 + split, 1.0 - split],
                [1.0, 1.0 + split, 1.0 + 2.0 * split],
            ];
            for d in spectra {
                for _ in 0..200 {
                    let a = rotated(&rng.rotation(), d);
                    let e = check_decomposition(&a);
                    check_eigenvalues(&a, &e.eigenvalues, d, 4.0);
                }
            }
        }
    }

    #[test]
    fn near_identity_perturbations_at_the_scale_of_b() {
        // b = I + 1e-4 perturbations: the typical trial state. Compared with
        // nalgebra, and with the spectrum of an exactly known rotation.
        let mut rng = Lcg(4);
        for _ in 0..2000 {
            let a = Matrix3::identity() + rng.symmetric(1e-4);
            let e = check_decomposition(&a);
            let reference = SymmetricEigen::new(a).eigenvalues;
            check_eigenvalues(&a, &e.eigenvalues, sorted(&reference), 16.0);
            let d = [
                1.0 + 1e-4 * rng.next(),
                1.0 + 1e-4 * rng.next(),
                1.0 + 1e-4 * rng.next(),
            ];
            let a = rotated(&rng.rotation(), d);
            let e = check_decomposition(&a);
            check_eigenvalues(&a, &e.eigenvalues, d, 4.0);
        }
    }

    #[test]
    fn large_strains() {
        // Eigenvalues spread over 1e-2..1e2: stretches of 0.1 to 10.
        let mut rng = Lcg(5);
        for _ in 0..2000 {
            let d = [
                10f64.powf(2.0 * rng.next()),
                10f64.powf(2.0 * rng.next()),
                10f64.powf(2.0 * rng.next()),
            ];
            let a = rotated(&rng.rotation(), d);
            let e = check_decomposition(&a);
            check_eigenvalues(&a, &e.eigenvalues, d, 4.0);
            let f = Matrix3::identity() + rng.symmetric(1.0) + rng.rotation() * 0.5;
            let b = f * f.transpose();
            let e = check_decomposition(&b);
            let reference = SymmetricEigen::new(b).eigenvalues;
            check_eigenvalues(&b, &e.eigenvalues, sorted(&reference), 16.0);
        }
    }

    #[test]
    fn nan_input_gives_nan_without_panicking() {
        let mut a = Matrix3::identity();
        a[(0, 1)] = f64::NAN;
        a[(1, 0)] = f64::NAN;
        let e = symmetric_eigen(&a);
        assert!(e.eigenvalues.iter().any(|x| x.is_nan()));
    }
}
