//! Small 3-vector and symmetric 3x3 helpers.

pub(crate) type V3 = [f64; 3];

pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn scale(s: f64, a: V3) -> V3 {
    [s * a[0], s * a[1], s * a[2]]
}

pub(crate) fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `v` rotated by the rotation vector `phi` (angle `|phi|` rad about
/// `phi / |phi|`), Rodrigues' formula.
pub(crate) fn rotate(v: V3, phi: V3) -> V3 {
    let angle = norm(phi);
    if angle < 1e-300 {
        return v;
    }
    let k = scale(1.0 / angle, phi);
    let (sin, cos) = angle.sin_cos();
    let kxv = cross(k, v);
    let kv = dot(k, v);
    [
        v[0] * cos + kxv[0] * sin + k[0] * kv * (1.0 - cos),
        v[1] * cos + kxv[1] * sin + k[1] * kv * (1.0 - cos),
        v[2] * cos + kxv[2] * sin + k[2] * kv * (1.0 - cos),
    ]
}

/// Symmetric 3x3 matrix stored as `[xx, yy, zz, yz, xz, xy]`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sym3(pub(crate) [f64; 6]);

impl Sym3 {
    /// `alpha I + beta u u^T`.
    pub(crate) fn iso_plus_dyad(alpha: f64, beta: f64, u: V3) -> Sym3 {
        Sym3([
            alpha + beta * u[0] * u[0],
            alpha + beta * u[1] * u[1],
            alpha + beta * u[2] * u[2],
            beta * u[1] * u[2],
            beta * u[0] * u[2],
            beta * u[0] * u[1],
        ])
    }

    /// `sa A + sb B`.
    pub(crate) fn combine(sa: f64, a: &Sym3, sb: f64, b: &Sym3) -> Sym3 {
        let mut m = [0.0; 6];
        for k in 0..6 {
            m[k] = sa * a.0[k] + sb * b.0[k];
        }
        Sym3(m)
    }

    pub(crate) fn mul(&self, v: V3) -> V3 {
        let [xx, yy, zz, yz, xz, xy] = self.0;
        [
            xx * v[0] + xy * v[1] + xz * v[2],
            xy * v[0] + yy * v[1] + yz * v[2],
            xz * v[0] + yz * v[1] + zz * v[2],
        ]
    }

    /// `M^-1 v` by the adjugate; `None` when `M` is singular.
    pub(crate) fn solve(&self, v: V3) -> Option<V3> {
        let [xx, yy, zz, yz, xz, xy] = self.0;
        // Cofactors (symmetric).
        let c_xx = yy * zz - yz * yz;
        let c_yy = xx * zz - xz * xz;
        let c_zz = xx * yy - xy * xy;
        let c_yz = xy * xz - xx * yz;
        let c_xz = xy * yz - yy * xz;
        let c_xy = xz * yz - zz * xy;
        let det = xx * c_xx + xy * c_xy + xz * c_xz;
        if !(det.abs() > 0.0) || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        Some([
            inv * (c_xx * v[0] + c_xy * v[1] + c_xz * v[2]),
            inv * (c_xy * v[0] + c_yy * v[1] + c_yz * v[2]),
            inv * (c_xz * v[0] + c_yz * v[1] + c_zz * v[2]),
        ])
    }
}
