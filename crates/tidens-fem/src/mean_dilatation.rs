//! Mean-dilatation elements for finite strain (Simo, Taylor and Pister 1985),
//! in their displacement-only (statically condensed) form: the Q1/P0
//! hexahedron ([`Hex8`]) and the P2/P0 quadratic tetrahedron ([`Tet10`]),
//! one kernel generic over the [`ReferenceElement`].
//!
//! The element energy is split into a deviatoric part integrated at the
//! material points (2x2x2 Gauss for the hexahedron, 4 points for the
//! tetrahedron) and a volumetric part evaluated once per element with the mean
//! dilatation `theta = v / V` (current over reference element volume, both
//! from a rule exact for `det J`):
//!
//! ```text
//! Pi_e(u) = sum_gp w0 W_dev(F_gp) + V U(theta),   U(theta) = K/2 (ln theta)^2
//! ```
//!
//! With Hencky elasticity this is exactly the energy of the F-bar gradient
//! `(theta / J)^(1/3) F`: scaling `F` changes only the volumetric log strain.
//! Plastic flow is isochoric, so the element imposes one incompressibility
//! constraint per element and does not lock (Q1/P0 and P2/P0 both pass the
//! inf-sup condition for one constant pressure per element); and since it is
//! the second variation of one (incremental) potential, its tangent is
//! symmetric, which lets the global system be factorised by Cholesky.
//!
//! Residual, with `g_a = grad_x N_a`, `J = det F`, `w0` the deviatoric weight
//! of a material point and `wv` the volume weight of a point of the volume
//! rule (the material points plus, for the tetrahedron, extra points), both
//! times `det J0`:
//!
//! ```text
//! f_a = sum_gp w0 tau_dev g_a + U'(theta) dv_a,    dv_a = sum_vp wv J g_a
//! K_ab = sum_gp w0 G_a^T a_dev G_b
//!        + U'(theta) sum_vp wv J (g_a g_b^T - g_b g_a^T)
//!        + U''(theta) / V  dv_a dv_b^T
//! ```
//!
//! `a_dev` is the deviatoric spatial tangent of `tidens-material`; the middle
//! term is the second variation of the current volume.
//!
//! That middle term, the volumetric initial-stress stiffness, is indefinite
//! (the second variation of the volume has modes of either sign), and its
//! weight `U'(theta)` is the element pressure. At a solution the pressure
//! is of the order of the applied stress and the term is a small correction
//! to the viscous stiffness; but a Newton iterate of a stiff material (E
//! 1e7 times the stress) can carry pressures thousands of times larger
//! (the extrapolated predictor of an isochoric flow changes each element's
//! volume at second order in the step's strain, by about 1e-4, and K times
//! that is 1e4 MPa), which makes the whole tangent indefinite and the Newton
//! directions useless. [`evaluate_into`] therefore limits `|U'(theta)|` in
//! this term to a `pressure_cap` given by the caller (infinite: the exact
//! tangent); the residual keeps the exact pressure, so the solution is
//! unchanged and, where the pressure is below the cap, so is the tangent.

use crate::error::FemError;
use crate::reference::{Hex8, ReferenceElement, Tet10, Tet10Degree3};
use nalgebra::Matrix3;
use tidens_material::{Material, PointState};

/// Reference-configuration data of one element with `NEN` nodes, `NGP`
/// material points and `NXP` extra volume points, computed once.
#[derive(Clone, Debug, PartialEq)]
pub struct MeanDilatationGeometry<const NEN: usize, const NGP: usize, const NXP: usize> {
    /// Gradients of the shape functions with respect to the reference
    /// coordinates at the material points, `grad[gp][a]\[J\]` [1/mm].
    pub grad: [[[f64; 3]; NEN]; NGP],
    /// Deviatoric weight times reference Jacobian determinant \[mm^3\].
    pub weight: [f64; NGP],
    /// Volume-rule weight at the material points times reference Jacobian
    /// determinant \[mm^3\] (equal to `weight` for the hexahedron).
    pub volume_weight: [f64; NGP],
    /// Shape-function gradients at the extra volume points [1/mm].
    pub extra_grad: [[[f64; 3]; NEN]; NXP],
    /// Volume-rule weight at the extra points times reference Jacobian
    /// determinant \[mm^3\].
    pub extra_weight: [f64; NXP],
    /// Reference volume \[mm^3\] (exact for the element's geometry).
    pub volume: f64,
}

/// Reference data of the mean-dilatation hexahedron (Q1/P0).
pub type ElementGeometry = MeanDilatationGeometry<8, 8, 0>;
/// Same as [`ElementGeometry`].
pub type Hex8Geometry = ElementGeometry;
/// Reference data of the mean-dilatation quadratic tetrahedron (P2/P0).
pub type Tet10Geometry = MeanDilatationGeometry<10, 4, 6>;
/// Reference data of [`Tet10Degree3`], the quadratic tetrahedron on the
/// 10-point rule.
pub type Tet10Degree3Geometry = MeanDilatationGeometry<10, 10, 0>;

/// Reference gradients `dN_a/dX` [1/mm] and `det J0` at a point where the
/// reference-coordinate gradients are `dn`; the error is `det J0` when it is
/// not positive.
fn reference_gradients<const NEN: usize>(
    x0: &[[f64; 3]; NEN],
    dn: &[[f64; 3]; NEN],
) -> Result<([[f64; 3]; NEN], f64), f64> {
    let mut jac = Matrix3::zeros();
    for a in 0..NEN {
        for i in 0..3 {
            for k in 0..3 {
                jac[(i, k)] += x0[a][i] * dn[a][k];
            }
        }
    }
    let det = jac.determinant();
    if !(det > 0.0) {
        return Err(det);
    }
    let jinv = jac.try_inverse().ok_or(det)?;
    let mut grad = [[0.0; 3]; NEN];
    for a in 0..NEN {
        for j in 0..3 {
            grad[a][j] = (0..3).map(|k| dn[a][k] * jinv[(k, j)]).sum();
        }
    }
    Ok((grad, det))
}

impl<const NEN: usize, const NGP: usize, const NXP: usize> MeanDilatationGeometry<NEN, NGP, NXP> {
    /// Reference data of the element `E` with node coordinates `x0` \[mm\]; the
    /// error carries the Jacobian determinant of the first point (material
    /// points, then extra points) where it is not positive.
    pub fn from_reference<E: ReferenceElement<NEN, NGP, NXP>>(
        x0: &[[f64; 3]; NEN],
    ) -> Result<Self, f64> {
        let mut grad = [[[0.0; 3]; NEN]; NGP];
        let mut weight = [0.0; NGP];
        let mut volume_weight = [0.0; NGP];
        let (wm, wv) = (E::material_weights(), E::volume_weights());
        for (gp, xi) in E::material_points().iter().enumerate() {
            let (g, det) = reference_gradients(x0, &E::shape_derivatives(*xi))?;
            grad[gp] = g;
            weight[gp] = wm[gp] * det;
            volume_weight[gp] = wv[gp] * det;
        }
        let mut extra_grad = [[[0.0; 3]; NEN]; NXP];
        let mut extra_weight = [0.0; NXP];
        let wx = E::extra_volume_weights();
        for (xp, xi) in E::extra_volume_points().iter().enumerate() {
            let (g, det) = reference_gradients(x0, &E::shape_derivatives(*xi))?;
            extra_grad[xp] = g;
            extra_weight[xp] = wx[xp] * det;
        }
        Ok(Self {
            grad,
            weight,
            volume_weight,
            extra_grad,
            extra_weight,
            volume: volume_weight.iter().chain(extra_weight.iter()).sum(),
        })
    }
}

impl MeanDilatationGeometry<8, 8, 0> {
    /// Reference data of the hexahedron with node coordinates `x0` \[mm\] (VTK
    /// order); the error carries the first non-positive Jacobian determinant
    /// found at a Gauss point.
    pub fn new(x0: &[[f64; 3]; 8]) -> Result<Self, f64> {
        Self::from_reference::<Hex8>(x0)
    }
}

impl MeanDilatationGeometry<10, 10, 0> {
    /// Reference data of [`Tet10Degree3`] with node coordinates `x0` \[mm\];
    /// the error carries a non-positive Jacobian determinant found at a
    /// quadrature point.
    pub fn new(x0: &[[f64; 3]; 10]) -> Result<Self, f64> {
        Self::from_reference::<Tet10Degree3>(x0)
    }
}

impl MeanDilatationGeometry<10, 4, 6> {
    /// Reference data of the quadratic tetrahedron with node coordinates `x0`
    /// \[mm\] (VTK_QUADRATIC_TETRA order); the error carries a non-positive
    /// Jacobian determinant found at a quadrature point.
    pub fn new(x0: &[[f64; 3]; 10]) -> Result<Self, f64> {
        Self::from_reference::<Tet10>(x0)
    }
}

/// What one element evaluation returns, for `NDOF = 3 NEN` dofs and `NGP`
/// material points.
#[derive(Clone, Debug, PartialEq)]
pub struct MeanDilatationOutput<const NDOF: usize, const NGP: usize> {
    /// Internal force, `residual[3 a + i]` \[N\].
    pub residual: [f64; NDOF],
    /// Consistent tangent, row-major NDOF x NDOF, entry `(3a+i, 3b+k)` \[N/mm\];
    /// empty when not requested.
    pub tangent: Vec<f64>,
    /// Material states at the end of the step.
    pub states: [PointState; NGP],
    /// Current volume \[mm^3\].
    pub volume: f64,
    /// Largest equivalent plastic strain increment over the material points.
    pub max_dp: f64,
    /// Volume-weighted mean von Mises Cauchy stress \[MPa\].
    pub von_mises: f64,
    /// Mean (Cauchy) stress, tension positive \[MPa\].
    pub mean_stress: f64,
    /// Volume-weighted mean equivalent plastic strain.
    pub eqps: f64,
}

/// What one hexahedron evaluation returns.
pub type ElementOutput = MeanDilatationOutput<24, 8>;
/// Same as [`ElementOutput`].
pub type Hex8Output = ElementOutput;
/// What one quadratic-tetrahedron evaluation returns.
pub type Tet10Output = MeanDilatationOutput<30, 4>;
/// What one [`Tet10Degree3`] evaluation returns.
pub type Tet10Degree3Output = MeanDilatationOutput<30, 10>;

/// Kinematics at one point of an element.
struct PointKinematics<const NEN: usize> {
    /// Deformation gradient.
    f: Matrix3<f64>,
    /// `det F`.
    det_f: f64,
    /// Spatial shape-function gradients `g_a = grad_x N_a` [1/mm].
    gx: [[f64; 3]; NEN],
}

/// Kinematics at a point with reference gradients `g0` for current node
/// coordinates `x`; error when `det F <= 0`.
fn kinematics<const NEN: usize>(
    element: usize,
    g0: &[[f64; 3]; NEN],
    x: &[[f64; 3]; NEN],
) -> Result<PointKinematics<NEN>, FemError> {
    let mut f = Matrix3::zeros();
    for a in 0..NEN {
        for i in 0..3 {
            for jj in 0..3 {
                f[(i, jj)] += x[a][i] * g0[a][jj];
            }
        }
    }
    let det_f = f.determinant();
    if !(det_f > 0.0) {
        return Err(FemError::Inverted { element, det_f });
    }
    let f_inv = f
        .try_inverse()
        .ok_or(FemError::Inverted { element, det_f })?;
    let mut gx = [[0.0; 3]; NEN];
    for a in 0..NEN {
        for j in 0..3 {
            gx[a][j] = (0..3).map(|jj| g0[a][jj] * f_inv[(jj, j)]).sum();
        }
    }
    Ok(PointKinematics { f, det_f, gx })
}

/// Adds `c (g_a g_b^T - g_b g_a^T)`, the second variation of `J` times `c`,
/// to the row-major tangent. The term is symmetric under `(a i) <-> (b k)`, so
/// each value is computed once and added to both entries (the same value the
/// full loop would add to each, bit for bit).
fn add_volume_curvature<const NEN: usize, const NDOF: usize>(
    tangent: &mut [f64],
    c: f64,
    g: &[[f64; 3]; NEN],
) {
    for a in 0..NEN {
        for i in 0..3 {
            let p = 3 * a + i;
            for b in a..NEN {
                let k0 = if b == a { i } else { 0 };
                for k in k0..3 {
                    let q = 3 * b + k;
                    let v = c * (g[a][i] * g[b][k] - g[a][k] * g[b][i]);
                    tangent[p * NDOF + q] += v;
                    if q != p {
                        tangent[q * NDOF + p] += v;
                    }
                }
            }
        }
    }
}

/// Scalar results of one element evaluation (the force, tangent and states
/// go to the caller's buffers, see [`evaluate_into`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementSummary {
    /// Current volume \[mm^3\].
    pub volume: f64,
    /// Largest equivalent plastic strain increment over the material points.
    pub max_dp: f64,
    /// Volume-weighted mean von Mises Cauchy stress \[MPa\].
    pub von_mises: f64,
    /// Mean (Cauchy) stress, tension positive \[MPa\].
    pub mean_stress: f64,
    /// Volume-weighted mean equivalent plastic strain.
    pub eqps: f64,
}

/// Evaluates one element at current node coordinates `x` \[mm\] after a time
/// step `dt` \[s\] from the states `states_n` at its material points: the
/// internal force, and the consistent tangent when `with_tangent`.
///
/// Generic over the element: `NEN` nodes, `NGP` material points, `NXP` extra
/// volume points and `NDOF = 3 NEN` dofs, all fixed by the geometry and the
/// output type, e.g. `let out: Tet10Output = evaluate(e, &geom, ...)?` with
/// `geom: Tet10Geometry`.
pub fn evaluate<const NEN: usize, const NGP: usize, const NXP: usize, const NDOF: usize>(
    element: usize,
    geom: &MeanDilatationGeometry<NEN, NGP, NXP>,
    x: &[[f64; 3]; NEN],
    states_n: &[PointState; NGP],
    material: &Material,
    dt: f64,
    with_tangent: bool,
) -> Result<MeanDilatationOutput<NDOF, NGP>, FemError> {
    let mut residual = [0.0; NDOF];
    let mut tangent = if with_tangent {
        vec![0.0; NDOF * NDOF]
    } else {
        Vec::new()
    };
    let mut states = [PointState::default(); NGP];
    let s = evaluate_into(
        element,
        geom,
        x,
        states_n,
        material,
        dt,
        f64::INFINITY,
        &mut residual,
        with_tangent.then_some(tangent.as_mut_slice()),
        &mut states,
    )?;
    Ok(MeanDilatationOutput {
        residual,
        tangent,
        states,
        volume: s.volume,
        max_dp: s.max_dp,
        von_mises: s.von_mises,
        mean_stress: s.mean_stress,
        eqps: s.eqps,
    })
}

/// [`evaluate`] into the caller's buffers: the internal force into
/// `residual` \[N\], the consistent tangent (row-major `NDOF x NDOF`,
/// \[N/mm\]) into `tangent` when given (overwritten), the material states at
/// the end of the step into `states`. No heap allocation. The pressure in
/// the tangent's volumetric initial-stress term is limited to
/// `pressure_cap` \[MPa\] in magnitude (see the module docs; infinite for
/// the exact tangent).
#[allow(clippy::too_many_arguments)]
pub fn evaluate_into<const NEN: usize, const NGP: usize, const NXP: usize, const NDOF: usize>(
    element: usize,
    geom: &MeanDilatationGeometry<NEN, NGP, NXP>,
    x: &[[f64; 3]; NEN],
    states_n: &[PointState; NGP],
    material: &Material,
    dt: f64,
    pressure_cap: f64,
    residual: &mut [f64; NDOF],
    mut tangent: Option<&mut [f64]>,
    states: &mut [PointState; NGP],
) -> Result<ElementSummary, FemError> {
    const { assert!(NDOF == 3 * NEN, "NDOF must be 3 NEN") };
    let with_tangent = tangent.is_some();
    residual.fill(0.0);
    if let Some(t) = tangent.as_deref_mut() {
        debug_assert_eq!(t.len(), NDOF * NDOF);
        t.fill(0.0);
    }
    let mut dv = [0.0; NDOF];
    let mut gx = [[[0.0; 3]; NEN]; NGP];
    let mut jdet = [0.0; NGP];
    let mut volume = 0.0;
    let mut max_dp: f64 = 0.0;
    let mut q_sum = 0.0;
    let mut p_sum = 0.0;
    for gp in 0..NGP {
        let PointKinematics { f, det_f, gx: g } = kinematics(element, &geom.grad[gp], x)?;
        gx[gp] = g;
        jdet[gp] = det_f;
        let w = geom.weight[gp];
        let wv = geom.volume_weight[gp];
        volume += wv * det_f;
        for a in 0..NEN {
            for i in 0..3 {
                dv[3 * a + i] += wv * det_f * gx[gp][a][i];
            }
        }
        let resp = material
            .update_deviatoric(&f, &states_n[gp], dt, with_tangent)
            .map_err(|_| FemError::Inverted { element, det_f })?;
        states[gp] = resp.state;
        max_dp = max_dp.max(resp.dp);
        q_sum += w * resp.q;
        p_sum += w * resp.state.eqps;
        let g = &gx[gp];
        for a in 0..NEN {
            for i in 0..3 {
                residual[3 * a + i] +=
                    w * (0..3).map(|j| resp.tau_dev[(i, j)] * g[a][j]).sum::<f64>();
            }
        }
        if let (Some(at), Some(tangent)) = (&resp.tangent, tangent.as_deref_mut()) {
            // t[(ij), (b k)] = sum_l a[(ij),(kl)] g_b,l
            let mut t = [[0.0; NDOF]; 9];
            for (ij, row) in t.iter_mut().enumerate() {
                for b in 0..NEN {
                    for k in 0..3 {
                        row[3 * b + k] = (0..3).map(|l| at[(ij, 3 * k + l)] * g[b][l]).sum();
                    }
                }
            }
            // The deviatoric part is symmetric (the spatial tangent has the
            // major symmetry): its upper triangle only, mirrored below.
            for a in 0..NEN {
                for i in 0..3 {
                    let p = 3 * a + i;
                    let r = p * NDOF;
                    let (g0, g1, g2) = (w * g[a][0], w * g[a][1], w * g[a][2]);
                    let (t0, t1, t2) = (&t[3 * i], &t[3 * i + 1], &t[3 * i + 2]);
                    for col in p..NDOF {
                        tangent[r + col] += g0 * t0[col] + g1 * t1[col] + g2 * t2[col];
                    }
                }
            }
        }
    }
    if let Some(tangent) = tangent.as_deref_mut() {
        for p in 0..NDOF {
            for q in p + 1..NDOF {
                tangent[q * NDOF + p] = tangent[p * NDOF + q];
            }
        }
    }
    // Extra points of the volume rule: kinematics only.
    let mut gx_extra = [[[0.0; 3]; NEN]; NXP];
    let mut jdet_extra = [0.0; NXP];
    for xp in 0..NXP {
        let PointKinematics { det_f, gx: g, .. } = kinematics(element, &geom.extra_grad[xp], x)?;
        let wv = geom.extra_weight[xp];
        volume += wv * det_f;
        for a in 0..NEN {
            for i in 0..3 {
                dv[3 * a + i] += wv * det_f * g[a][i];
            }
        }
        gx_extra[xp] = g;
        jdet_extra[xp] = det_f;
    }
    let v0 = geom.volume;
    let theta = volume / v0;
    let k_bulk = material.bulk_modulus();
    let ln_theta = theta.ln();
    let u1 = k_bulk * ln_theta / theta;
    let u2 = k_bulk * (1.0 - ln_theta) / (theta * theta);
    for (r, d) in residual.iter_mut().zip(dv.iter()) {
        *r += u1 * d;
    }
    if let Some(tangent) = tangent {
        // The initial-stress term at the pressure, limited (module docs).
        let u1 = u1.clamp(-pressure_cap, pressure_cap);
        for gp in 0..NGP {
            let c = u1 * geom.volume_weight[gp] * jdet[gp];
            add_volume_curvature::<NEN, NDOF>(tangent, c, &gx[gp]);
        }
        for xp in 0..NXP {
            let c = u1 * geom.extra_weight[xp] * jdet_extra[xp];
            add_volume_curvature::<NEN, NDOF>(tangent, c, &gx_extra[xp]);
        }
        let c = u2 / v0;
        for p in 0..NDOF {
            for q in 0..NDOF {
                tangent[p * NDOF + q] += c * dv[p] * dv[q];
            }
        }
    }
    // Means over the material points (the deviatoric rule's own volume, which
    // is the reference volume for the hexahedron).
    let w_sum: f64 = geom.weight.iter().sum();
    Ok(ElementSummary {
        volume,
        max_dp,
        von_mises: q_sum / w_sum / theta,
        mean_stress: u1,
        eqps: p_sum / w_sum,
    })
}
