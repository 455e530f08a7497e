//! Element-level verification: the consistent tangent equals finite
//! differences of the residual, and the patch test (a homogeneous finite
//! deformation of a distorted mesh is an exact solution) holds.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3};
use tidens_fem::{Body, DOF_DROPPED, SparseSystem};
use tidens_material::Material;
use tidens_mesh::HexMesh;

/// An n^3 block of unit size with interior nodes moved off the grid.
fn distorted_block(n: usize, amp: f64) -> (Vec<[f64; 3]>, Vec<[usize; 8]>, Vec<bool>) {
    let mesh = HexMesh::block([1.0; 3], [n; 3]).unwrap();
    let h = 1.0 / n as f64;
    let mut nodes = mesh.nodes.clone();
    let mut interior = Vec::with_capacity(nodes.len());
    for (k, p) in nodes.iter_mut().enumerate() {
        let inside = p.iter().all(|&x| x > 1e-12 && x < 1.0 - 1e-12);
        if inside {
            // Deterministic pseudo-random offsets.
            let s = k as f64;
            p[0] += amp * h * (s * 0.37).sin();
            p[1] += amp * h * (s * 0.71).cos();
            p[2] += amp * h * (s * 1.13).sin();
        }
        interior.push(inside);
    }
    (nodes, mesh.elements, interior)
}

fn affine_displacement(nodes: &[[f64; 3]], a: &Matrix3<f64>) -> Vec<f64> {
    let mut u = Vec::with_capacity(3 * nodes.len());
    for p in nodes {
        let x = a * nalgebra::Vector3::new(p[0], p[1], p[2]);
        u.extend_from_slice(&[x[0] - p[0], x[1] - p[1], x[2] - p[2]]);
    }
    u
}

fn stretch_rotation() -> Matrix3<f64> {
    let rot = Rotation3::from_euler_angles(0.4, -0.3, 0.9).into_inner();
    rot * Matrix3::new(1.2, 0.1, 0.0, 0.0, 0.85, 0.05, 0.02, 0.0, 1.05)
}

#[test]
fn element_tangent_equals_finite_differences() {
    // One distorted element (local node order = global order).
    let nodes = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.2, 0.9, 1.1],
        [0.1, 1.0, 0.8],
    ];
    let el = vec![[0, 1, 2, 3, 4, 5, 6, 7]];
    for &n in &[1.0, 2.8, 8.0] {
        for &dt in &[1e-3, 10.0, 1e4] {
            let mat = Material::new(4.35e4, 0.3, 1e-5, n).unwrap();
            let mut body = Body::new(nodes.clone(), el.clone(), mat).unwrap();
            // A first plastic step, committed, so the state is not virgin.
            let mut u = affine_displacement(&nodes, &stretch_rotation());
            for (k, v) in u.iter_mut().enumerate() {
                *v += 0.01 * ((k * 17) as f64).sin();
            }
            let ev = body.evaluate(&u, 100.0, false).unwrap();
            body.commit(&ev);
            // A further, non-affine deformation.
            for (k, v) in u.iter_mut().enumerate() {
                *v += 0.02 * ((k * 5) as f64).cos();
            }
            let ev = body.evaluate(&u, dt, true).unwrap();
            let k_an = ev.element_tangent(0);
            let scale = k_an.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let h = 1e-7;
            for q in 0..24 {
                let mut up = u.clone();
                up[q] += h;
                let mut um = u.clone();
                um[q] -= h;
                let rp = body
                    .evaluate(&up, dt, false)
                    .unwrap()
                    .element_residual(0)
                    .to_vec();
                let rm = body
                    .evaluate(&um, dt, false)
                    .unwrap()
                    .element_residual(0)
                    .to_vec();
                for p in 0..24 {
                    let fd = (rp[p] - rm[p]) / (2.0 * h);
                    let an = k_an[p * 24 + q];
                    assert!(
                        (fd - an).abs() <= 1e-5 * scale,
                        "n={n} dt={dt} K[{p},{q}]: analytic {an}, fd {fd}, scale {scale}"
                    );
                }
            }
            for p in 0..24 {
                for q in 0..p {
                    assert!(
                        (k_an[p * 24 + q] - k_an[q * 24 + p]).abs() <= 1e-9 * scale,
                        "asymmetric"
                    );
                }
            }
        }
    }
}

#[test]
fn patch_test_homogeneous_finite_deformation_is_exact() {
    let (nodes, elements, interior) = distorted_block(3, 0.25);
    let mat = Material::new(4.35e4, 0.3, 4.8e-7, 2.8).unwrap();
    let mut body = Body::new(nodes.clone(), elements.clone(), mat).unwrap();
    let a = stretch_rotation();
    let exact = affine_displacement(&nodes, &a);
    // Equations: interior dofs only; boundary dofs prescribed to the affine field.
    let mut map = vec![DOF_DROPPED; body.dof_count()];
    let mut neq = 0;
    for (node, &inside) in interior.iter().enumerate() {
        if inside {
            for i in 0..3 {
                map[3 * node + i] = neq;
                neq += 1;
            }
        }
    }
    let cliques: Vec<Vec<usize>> = (0..elements.len())
        .map(|e| {
            body.element_dofs(e)
                .iter()
                .map(|&d| map[d])
                .filter(|&q| q != DOF_DROPPED)
                .collect()
        })
        .collect();
    let mut sys = SparseSystem::from_cliques(neq, cliques.iter().map(|c| c.as_slice()));
    // Two time steps: an elastic-viscoplastic loading step and a creep step at
    // fixed deformation; the homogeneous field must stay exact in both.
    for &dt in &[1.0, 1e3] {
        let mut u = exact.clone();
        for (d, v) in u.iter_mut().enumerate() {
            if map[d] != DOF_DROPPED {
                *v += 1e-3 * ((d * 11) as f64).sin();
            }
        }
        let mut norms = Vec::new();
        for _ in 0..12 {
            let ev = body.evaluate(&u, dt, true).unwrap();
            let f = ev.internal_force(&body);
            let mut r = DVector::zeros(neq);
            for (d, &q) in map.iter().enumerate() {
                if q != DOF_DROPPED {
                    r[q] += f[d];
                }
            }
            norms.push(r.norm());
            if r.norm() < 1e-9 {
                break;
            }
            sys.clear();
            for e in 0..elements.len() {
                sys.add_block(&body.element_dofs(e), ev.element_tangent(e), &map);
            }
            let mut k = DMatrix::zeros(neq, neq);
            for c in 0..neq {
                for idx in sys.col_ptr()[c]..sys.col_ptr()[c + 1] {
                    k[(sys.row_idx()[idx], c)] = sys.values()[idx];
                }
            }
            let du = k.lu().solve(&(-r)).unwrap();
            for (d, &q) in map.iter().enumerate() {
                if q != DOF_DROPPED {
                    u[d] += du[q];
                }
            }
        }
        let last = *norms.last().unwrap();
        assert!(last < 1e-9, "Newton did not converge: {norms:?}");
        // Quadratic convergence: the tangent is consistent.
        assert!(norms.len() <= 7, "too many iterations: {norms:?}");
        let k = norms.len();
        // With residuals scaled by the first one, e_(i+1) <= 10 e_i^2.
        let e: Vec<f64> = norms.iter().map(|r| r / norms[0]).collect();
        assert!(
            e[k - 2] <= 10.0 * e[k - 3].powi(2),
            "not quadratic: {norms:?}"
        );
        let err = u
            .iter()
            .zip(&exact)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "interior nodes off the affine field by {err}");
        let ev = body.evaluate(&u, dt, false).unwrap();
        // Uniform stress: every element has the same von Mises stress.
        let vm = ev.fields().von_mises;
        let spread = vm.iter().fold(0.0_f64, |m, v| m.max((v - vm[0]).abs()));
        assert!(
            spread < 1e-8 * vm[0].abs().max(1.0),
            "von Mises varies by {spread}"
        );
        // Volume of the body follows det A exactly.
        assert!((ev.volume() / body.reference_volume() - a.determinant()).abs() < 1e-12);
        body.commit(&ev);
    }
}

/// The parallel gather of element tangents and forces equals the serial
/// scatter in element order, bit for bit, with one thread and with two.
#[test]
fn parallel_gather_equals_the_serial_scatter_bit_for_bit() {
    let (nodes, elements, _) = distorted_block(5, 0.2);
    let mat = Material::new(4.35e4, 0.3, 4.8e-7, 2.8).unwrap();
    let body = Body::new(nodes.clone(), elements.clone(), mat).unwrap();
    let u = affine_displacement(&nodes, &stretch_rotation());
    let ev = body.evaluate(&u, 10.0, true).unwrap();
    let identity: Vec<usize> = (0..body.dof_count()).collect();
    let cliques: Vec<Vec<usize>> = (0..elements.len()).map(|e| body.element_dofs(e)).collect();
    let mut serial =
        SparseSystem::from_cliques(body.dof_count(), cliques.iter().map(|c| c.as_slice()));
    for e in 0..elements.len() {
        serial.add_block(&body.element_dofs(e), ev.element_tangent(e), &identity);
    }
    let force = ev.internal_force(&body);
    let dofs: Vec<usize> = cliques.iter().flatten().copied().collect();
    let plan = tidens_fem::ElementAssembler::new(body.dof_count(), 24, &dofs);
    assert_eq!(plan.col_ptr(), serial.col_ptr());
    assert_eq!(plan.row_idx(), serial.row_idx());
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let (values, gathered) = pool.install(|| {
            let mut values = vec![0.0; plan.nnz()];
            plan.assemble_matrix(ev.tangents(), &mut values);
            let mut f = vec![0.0; plan.dim()];
            plan.assemble_vector(ev.residuals(), &mut f);
            (values, f)
        });
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(
            same(&values, serial.values()),
            "{threads} thread(s): matrix differs"
        );
        assert!(
            same(&gathered, &force),
            "{threads} thread(s): force differs"
        );
    }
}
