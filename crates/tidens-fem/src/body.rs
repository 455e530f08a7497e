//! A deformable body: mesh, material, element geometry and the material state
//! of the last converged step.

use crate::error::FemError;
use crate::mean_dilatation::{self, ElementGeometry, ElementOutput};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tidens_material::{Material, PointState};

/// A meshed body of mean-dilatation hexahedra of one material.
///
/// Dofs are the nodal displacements, dof `3 * node + i` for direction `i`.
/// The state is the material state at the Gauss points at the last converged
/// step; [`Body::evaluate`] never changes it (so a Newton iteration or a cut
/// step can be redone), [`Body::commit`] replaces it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Body {
    nodes: Vec<[f64; 3]>,
    elements: Vec<[usize; 8]>,
    #[serde(skip)]
    geometry: Vec<ElementGeometry>,
    material: Material,
    states: Vec<[PointState; 8]>,
}

/// Element results of one evaluation of the whole body.
#[derive(Clone, Debug)]
pub struct BodyEvaluation {
    /// One output per element, in element order.
    pub elements: Vec<ElementOutput>,
}

/// Element-wise fields for output.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementFields {
    /// von Mises (Cauchy) stress \[MPa\].
    pub von_mises: Vec<f64>,
    /// Mean (Cauchy) stress, tension positive \[MPa\].
    pub mean_stress: Vec<f64>,
    /// Equivalent plastic strain [-].
    pub eqps: Vec<f64>,
}

impl Body {
    /// A body with reference node coordinates `nodes` \[mm\] and 8-node
    /// hexahedra `elements` (VTK order, right-handed), in the virgin state.
    pub fn new(
        nodes: Vec<[f64; 3]>,
        elements: Vec<[usize; 8]>,
        material: Material,
    ) -> Result<Self, FemError> {
        let states = vec![[PointState::default(); 8]; elements.len()];
        let mut body = Self {
            nodes,
            elements,
            geometry: Vec::new(),
            material,
            states,
        };
        body.rebuild_geometry()?;
        Ok(body)
    }

    /// Recomputes the reference element data (after deserialisation).
    pub fn rebuild_geometry(&mut self) -> Result<(), FemError> {
        let n = self.nodes.len();
        if let Some((e, _)) = self
            .elements
            .iter()
            .enumerate()
            .find(|(_, el)| el.iter().any(|&a| a >= n))
        {
            return Err(FemError::Mesh(format!(
                "element {e} refers to a node >= {n}"
            )));
        }
        self.geometry = self
            .elements
            .iter()
            .enumerate()
            .map(|(e, el)| {
                let x0 = el.map(|a| self.nodes[a]);
                ElementGeometry::new(&x0)
                    .map_err(|det| FemError::InvertedReference { element: e, det })
            })
            .collect::<Result<_, _>>()?;
        Ok(())
    }

    pub fn nodes(&self) -> &[[f64; 3]] {
        &self.nodes
    }

    pub fn elements(&self) -> &[[usize; 8]] {
        &self.elements
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    pub fn dof_count(&self) -> usize {
        3 * self.nodes.len()
    }

    /// Material state at the last converged step, per element and Gauss point.
    pub fn states(&self) -> &[[PointState; 8]] {
        &self.states
    }

    /// Reference volume [mm^3].
    pub fn reference_volume(&self) -> f64 {
        self.geometry.iter().map(|g| g.volume).sum()
    }

    /// The body dofs of element `e`: `3 * node + i`, in element node order.
    pub fn element_dofs(&self, e: usize) -> [usize; 24] {
        let mut d = [0; 24];
        for (a, &node) in self.elements[e].iter().enumerate() {
            for i in 0..3 {
                d[3 * a + i] = 3 * node + i;
            }
        }
        d
    }

    /// Evaluates every element (in parallel) at displacement `u` (length
    /// `dof_count`) \[mm\] after a step of `dt` \[s\] from the committed state.
    /// Deterministic: each element is computed independently.
    pub fn evaluate(
        &self,
        u: &[f64],
        dt: f64,
        with_tangent: bool,
    ) -> Result<BodyEvaluation, FemError> {
        if u.len() != self.dof_count() {
            return Err(FemError::Mesh(format!(
                "displacement vector has {} entries, expected {}",
                u.len(),
                self.dof_count()
            )));
        }
        let elements = self
            .elements
            .par_iter()
            .enumerate()
            .map(|(e, el)| {
                let x = el.map(|a| {
                    let p = self.nodes[a];
                    [p[0] + u[3 * a], p[1] + u[3 * a + 1], p[2] + u[3 * a + 2]]
                });
                mean_dilatation::evaluate(
                    e,
                    &self.geometry[e],
                    &x,
                    &self.states[e],
                    &self.material,
                    dt,
                    with_tangent,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(BodyEvaluation { elements })
    }

    /// Makes the states of `eval` the converged state.
    pub fn commit(&mut self, eval: &BodyEvaluation) {
        for (s, out) in self.states.iter_mut().zip(&eval.elements) {
            *s = out.states;
        }
    }

    /// Replaces the material (e.g. to continue a run with other constants).
    pub fn set_material(&mut self, material: Material) {
        self.material = material;
    }
}

impl BodyEvaluation {
    /// Internal force vector of the body (length `3 * nodes`) \[N\], summed in
    /// element order (deterministic).
    pub fn internal_force(&self, body: &Body) -> Vec<f64> {
        let mut f = vec![0.0; body.dof_count()];
        for (e, out) in self.elements.iter().enumerate() {
            for (k, d) in body.element_dofs(e).iter().enumerate() {
                f[*d] += out.residual[k];
            }
        }
        f
    }

    /// Current volume of the body [mm^3].
    pub fn volume(&self) -> f64 {
        self.elements.iter().map(|o| o.volume).sum()
    }

    /// Largest equivalent plastic strain increment at any Gauss point.
    pub fn max_dp(&self) -> f64 {
        self.elements.iter().map(|o| o.max_dp).fold(0.0, f64::max)
    }

    /// Element-wise output fields.
    pub fn fields(&self) -> ElementFields {
        ElementFields {
            von_mises: self.elements.iter().map(|o| o.von_mises).collect(),
            mean_stress: self.elements.iter().map(|o| o.mean_stress).collect(),
            eqps: self.elements.iter().map(|o| o.eqps).collect(),
        }
    }
}
