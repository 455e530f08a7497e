//! `Material`: the constitutive law, and the creep-coefficient helper.

use crate::errors::{Number, Phase, material_error, parameter_error};
use pyo3::prelude::*;
use tidens_material::{Material, Preset};

/// Hencky elasticity + J2 Norton viscoplasticity, eps_dot = C q^n.
///
/// Material(young_mpa, poisson, creep_c, creep_n): Young's modulus E [MPa] in
/// [1e-3, 1e9], Poisson's ratio nu in [-0.99, 0.4999], Norton coefficient C
/// [MPa^-n s^-1] in [1e-30, 1e6] and exponent n in [1, 50]; the equivalent
/// plastic strain rate is C q^n with q the von Mises stress [MPa]. Raises
/// ValueError naming the argument out of range.
#[pyclass(name = "Material", module = "tidens_rs._core", frozen)]
#[derive(Clone, Copy, Debug)]
pub struct PyMaterial {
    pub(crate) inner: Material,
}

impl PyMaterial {
    fn validated(young: f64, poisson: f64, creep_c: f64, creep_n: f64) -> PyResult<Self> {
        let inner = Material::new(young, poisson, creep_c, creep_n)
            .map_err(|e| material_error(e, Phase::Setup))?;
        Ok(Self { inner })
    }
}

#[pymethods]
impl PyMaterial {
    #[new]
    fn new(young_mpa: f64, poisson: f64, creep_c: f64, creep_n: f64) -> PyResult<Self> {
        Self::validated(young_mpa, poisson, creep_c, creep_n)
    }

    /// A preset by name (one of PRESET_NAMES), with E = 43.5 GPa, nu = 0.3.
    /// Raises ValueError listing the names for an unknown one.
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Self> {
        let preset = Preset::from_name(name).map_err(|e| material_error(e, Phase::Setup))?;
        Ok(Self {
            inner: preset.material(),
        })
    }

    /// Young's modulus E [MPa].
    #[getter]
    fn young_mpa(&self) -> f64 {
        self.inner.young
    }

    /// Poisson's ratio nu [-].
    #[getter]
    fn poisson(&self) -> f64 {
        self.inner.poisson
    }

    /// Norton coefficient C [MPa^-n s^-1].
    #[getter]
    fn creep_c(&self) -> f64 {
        self.inner.creep_c
    }

    /// Norton exponent n [-].
    #[getter]
    fn creep_n(&self) -> f64 {
        self.inner.creep_n
    }

    /// Shear modulus G = E / (2 (1 + nu)) [MPa].
    #[getter]
    fn shear_modulus_mpa(&self) -> f64 {
        self.inner.shear_modulus()
    }

    /// Bulk modulus K = E / (3 (1 - 2 nu)) [MPa].
    #[getter]
    fn bulk_modulus_mpa(&self) -> f64 {
        self.inner.bulk_modulus()
    }

    /// Constrained (P-wave) modulus M = K + 4 G / 3 [MPa].
    #[getter]
    fn constrained_modulus_mpa(&self) -> f64 {
        self.inner.constrained_modulus()
    }

    /// A copy with other elastic constants E [MPa] and nu [-] (validated).
    fn with_elastic(&self, young_mpa: f64, poisson: f64) -> PyResult<Self> {
        Self::validated(young_mpa, poisson, self.inner.creep_c, self.inner.creep_n)
    }

    /// Steady creep rate C q^n [1/s] at the von Mises stress q_mpa [MPa] (>= 0).
    fn creep_rate(&self, q_mpa: f64) -> PyResult<f64> {
        if !(q_mpa >= 0.0) {
            return Err(parameter_error("q_mpa", Number(q_mpa), ">= 0 MPa"));
        }
        Ok(self.inner.creep_rate(q_mpa))
    }

    fn __repr__(&self) -> String {
        let m = &self.inner;
        format!(
            "Material(young_mpa={:?}, poisson={:?}, creep_c={:?}, creep_n={:?})",
            m.young, m.poisson, m.creep_c, m.creep_n
        )
    }
}

/// Norton coefficient C [MPa^-1 s^-1] of transformation mismatch plasticity:
/// C = (4/3) 5n/(4n+1) (dV/V) / cycle_s / sigma0_mpa, with dv_over_v the
/// transformation volume change [-], cycle_s the thermal cycle period [s],
/// sigma0_mpa the internal stress [MPa] and n the creep exponent of the phases.
#[pyfunction]
pub fn tmp_creep_coefficient(dv_over_v: f64, cycle_s: f64, sigma0_mpa: f64, n: f64) -> f64 {
    tidens_material::tmp_creep_coefficient(dv_over_v, cycle_s, sigma0_mpa, n)
}
