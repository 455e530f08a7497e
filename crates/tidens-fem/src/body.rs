//! A deformable body: mesh, material, element geometry and the material state
//! of the last converged step.

use crate::error::FemError;
use crate::mean_dilatation::{
    self, Hex8Geometry, MeanDilatationGeometry, MeanDilatationOutput, Tet10Geometry,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tidens_material::{Material, PointState};

/// The element of a body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ElementKind {
    /// The 8-node mean-dilatation hexahedron (Q1/P0), 2x2x2 Gauss points.
    Hex8,
    /// The 10-node quadratic tetrahedron with one pressure (P2/P0), four
    /// material points.
    Tet10,
}

impl ElementKind {
    /// Nodes per element.
    pub fn nodes(self) -> usize {
        match self {
            ElementKind::Hex8 => 8,
            ElementKind::Tet10 => 10,
        }
    }

    /// Material points per element.
    pub fn points(self) -> usize {
        match self {
            ElementKind::Hex8 => 8,
            ElementKind::Tet10 => 4,
        }
    }

    /// The cell type name in VTK/meshio (`hexahedron`, `tetra10`).
    pub fn vtk_name(self) -> &'static str {
        match self {
            ElementKind::Hex8 => "hexahedron",
            ElementKind::Tet10 => "tetra10",
        }
    }
}

/// Reference data of all elements of a body.
#[derive(Clone, Debug, Default)]
enum Geometry {
    #[default]
    None,
    Hex8(Vec<Hex8Geometry>),
    Tet10(Vec<Tet10Geometry>),
}

/// A meshed body of mean-dilatation elements (hexahedra or quadratic
/// tetrahedra) of one material.
///
/// Dofs are the nodal displacements, dof `3 * node + i` for direction `i`.
/// The state is the material state at the material points at the last
/// converged step; [`Body::evaluate`] never changes it (so a Newton iteration
/// or a cut step can be redone), [`Body::commit`] replaces it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Body {
    nodes: Vec<[f64; 3]>,
    kind: ElementKind,
    /// Element nodes, `kind.nodes()` per element (VTK order).
    connectivity: Vec<usize>,
    #[serde(skip)]
    geometry: Geometry,
    material: Material,
    /// Material states, `kind.points()` per element.
    states: Vec<PointState>,
}

/// What one element evaluation gives, whatever the element.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementResult {
    /// Internal force, `residual[3 a + i]` \[N\].
    pub residual: Vec<f64>,
    /// Consistent tangent, row-major, entry `(3a+i, 3b+k)` \[N/mm\]; empty when
    /// not requested.
    pub tangent: Vec<f64>,
    /// Material states at the end of the step.
    pub states: Vec<PointState>,
    /// Current volume [mm^3].
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

impl<const NDOF: usize, const NGP: usize> From<MeanDilatationOutput<NDOF, NGP>> for ElementResult {
    fn from(o: MeanDilatationOutput<NDOF, NGP>) -> Self {
        Self {
            residual: o.residual.to_vec(),
            tangent: o.tangent,
            states: o.states.to_vec(),
            volume: o.volume,
            max_dp: o.max_dp,
            von_mises: o.von_mises,
            mean_stress: o.mean_stress,
            eqps: o.eqps,
        }
    }
}

/// Element results of one evaluation of the whole body.
#[derive(Clone, Debug)]
pub struct BodyEvaluation {
    /// One result per element, in element order.
    pub elements: Vec<ElementResult>,
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

fn reference_geometry<const NEN: usize, const NGP: usize, const NXP: usize>(
    nodes: &[[f64; 3]],
    connectivity: &[usize],
    build: impl Fn(&[[f64; 3]; NEN]) -> Result<MeanDilatationGeometry<NEN, NGP, NXP>, f64> + Sync,
) -> Result<Vec<MeanDilatationGeometry<NEN, NGP, NXP>>, FemError> {
    connectivity
        .chunks(NEN)
        .enumerate()
        .map(|(e, el)| {
            let x0: [[f64; 3]; NEN] = std::array::from_fn(|a| nodes[el[a]]);
            build(&x0).map_err(|det| FemError::InvertedReference { element: e, det })
        })
        .collect()
}

impl Body {
    /// A body of 8-node hexahedra `elements` (VTK order, right-handed) with
    /// reference node coordinates `nodes` \[mm\], in the virgin state.
    pub fn new(
        nodes: Vec<[f64; 3]>,
        elements: Vec<[usize; 8]>,
        material: Material,
    ) -> Result<Self, FemError> {
        Self::with_kind(
            nodes,
            ElementKind::Hex8,
            elements.into_iter().flatten().collect(),
            material,
        )
    }

    /// A body of 10-node tetrahedra `elements` (VTK quadratic-tetra order,
    /// right-handed), in the virgin state.
    pub fn new_tet10(
        nodes: Vec<[f64; 3]>,
        elements: Vec<[usize; 10]>,
        material: Material,
    ) -> Result<Self, FemError> {
        Self::with_kind(
            nodes,
            ElementKind::Tet10,
            elements.into_iter().flatten().collect(),
            material,
        )
    }

    fn with_kind(
        nodes: Vec<[f64; 3]>,
        kind: ElementKind,
        connectivity: Vec<usize>,
        material: Material,
    ) -> Result<Self, FemError> {
        let count = connectivity.len() / kind.nodes();
        let mut body = Self {
            nodes,
            kind,
            connectivity,
            geometry: Geometry::None,
            material,
            states: vec![PointState::default(); count * kind.points()],
        };
        body.rebuild_geometry()?;
        Ok(body)
    }

    /// Recomputes the reference element data (after deserialisation).
    pub fn rebuild_geometry(&mut self) -> Result<(), FemError> {
        let n = self.nodes.len();
        if let Some(k) = self.connectivity.iter().position(|&a| a >= n) {
            return Err(FemError::Mesh(format!(
                "element {} refers to a node >= {n}",
                k / self.kind.nodes()
            )));
        }
        self.geometry = match self.kind {
            ElementKind::Hex8 => Geometry::Hex8(reference_geometry(
                &self.nodes,
                &self.connectivity,
                Hex8Geometry::new,
            )?),
            ElementKind::Tet10 => Geometry::Tet10(reference_geometry(
                &self.nodes,
                &self.connectivity,
                Tet10Geometry::new,
            )?),
        };
        Ok(())
    }

    pub fn nodes(&self) -> &[[f64; 3]] {
        &self.nodes
    }

    pub fn kind(&self) -> ElementKind {
        self.kind
    }

    pub fn element_count(&self) -> usize {
        self.connectivity.len() / self.kind.nodes()
    }

    /// The elements' node lists, in element order.
    pub fn elements(&self) -> std::slice::ChunksExact<'_, usize> {
        self.connectivity.chunks_exact(self.kind.nodes())
    }

    /// The nodes of element `e`, in VTK order.
    pub fn element_nodes(&self, e: usize) -> &[usize] {
        let k = self.kind.nodes();
        &self.connectivity[k * e..k * (e + 1)]
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    pub fn dof_count(&self) -> usize {
        3 * self.nodes.len()
    }

    /// Material state at the last converged step, per material point
    /// (`kind().points()` per element, in element order).
    pub fn states(&self) -> &[PointState] {
        &self.states
    }

    /// Reference volume [mm^3].
    pub fn reference_volume(&self) -> f64 {
        match &self.geometry {
            Geometry::None => 0.0,
            Geometry::Hex8(g) => g.iter().map(|g| g.volume).sum(),
            Geometry::Tet10(g) => g.iter().map(|g| g.volume).sum(),
        }
    }

    /// The body dofs of element `e`: `3 * node + i`, in element node order.
    pub fn element_dofs(&self, e: usize) -> Vec<usize> {
        self.element_nodes(e)
            .iter()
            .flat_map(|&n| [3 * n, 3 * n + 1, 3 * n + 2])
            .collect()
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
        let elements = match &self.geometry {
            Geometry::None => Err(FemError::Mesh("element geometry not built".into())),
            Geometry::Hex8(g) => self.evaluate_all::<8, 8, 0, 24>(g, u, dt, with_tangent),
            Geometry::Tet10(g) => self.evaluate_all::<10, 4, 6, 30>(g, u, dt, with_tangent),
        }?;
        Ok(BodyEvaluation { elements })
    }

    fn evaluate_all<const NEN: usize, const NGP: usize, const NXP: usize, const NDOF: usize>(
        &self,
        geometry: &[MeanDilatationGeometry<NEN, NGP, NXP>],
        u: &[f64],
        dt: f64,
        with_tangent: bool,
    ) -> Result<Vec<ElementResult>, FemError> {
        geometry
            .par_iter()
            .enumerate()
            .map(|(e, geom)| {
                let el = self.element_nodes(e);
                let x: [[f64; 3]; NEN] = std::array::from_fn(|a| {
                    let (n, p) = (el[a], self.nodes[el[a]]);
                    [p[0] + u[3 * n], p[1] + u[3 * n + 1], p[2] + u[3 * n + 2]]
                });
                let states: [PointState; NGP] = std::array::from_fn(|k| self.states[NGP * e + k]);
                let out: MeanDilatationOutput<NDOF, NGP> = mean_dilatation::evaluate(
                    e,
                    geom,
                    &x,
                    &states,
                    &self.material,
                    dt,
                    with_tangent,
                )?;
                Ok(ElementResult::from(out))
            })
            .collect()
    }

    /// Makes the states of `eval` the converged state.
    pub fn commit(&mut self, eval: &BodyEvaluation) {
        let k = self.kind.points();
        for (e, out) in eval.elements.iter().enumerate() {
            self.states[k * e..k * (e + 1)].copy_from_slice(&out.states);
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
            for (a, &node) in body.element_nodes(e).iter().enumerate() {
                for i in 0..3 {
                    f[3 * node + i] += out.residual[3 * a + i];
                }
            }
        }
        f
    }

    /// Current volume of the body [mm^3].
    pub fn volume(&self) -> f64 {
        self.elements.iter().map(|o| o.volume).sum()
    }

    /// Largest equivalent plastic strain increment at any material point.
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
