//! A deformable body: mesh, material, element geometry and the material state
//! of the last converged step.

use crate::error::FemError;
use crate::mean_dilatation::{
    self, ElementSummary, Hex8Geometry, MeanDilatationGeometry, Tet10Geometry,
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
    /// Largest pressure magnitude in the tangent's volumetric initial-stress
    /// term \[MPa\] (see `mean_dilatation`); infinite: the exact tangent. A
    /// solver setting, not part of the body's state.
    #[serde(skip, default = "exact_tangent")]
    tangent_pressure_cap: f64,
}

fn exact_tangent() -> f64 {
    f64::INFINITY
}

/// Element results of one evaluation of the whole body, in flat arrays in
/// element order (no allocation per element).
#[derive(Clone, Debug)]
pub struct BodyEvaluation {
    /// Dofs per element (`3 * nodes`).
    ndof: usize,
    /// Material points per element.
    npoints: usize,
    /// Element internal forces, `ndof` per element \[N\].
    residuals: Vec<f64>,
    /// Element tangents, row-major `ndof x ndof` per element \[N/mm\]; empty
    /// when not requested.
    tangents: Vec<f64>,
    /// Material states at the end of the step, `npoints` per element.
    states: Vec<PointState>,
    /// Scalar results per element.
    summaries: Vec<ElementSummary>,
}

/// Element-wise fields for output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
            tangent_pressure_cap: exact_tangent(),
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

    /// Limits the pressure in the tangent's volumetric initial-stress term
    /// to `cap` \[MPa\] in magnitude (`f64::INFINITY`, the default: the
    /// exact tangent). The forces, and so the solution, do not change; a
    /// cap of the order of the stresses the solution carries keeps Newton's
    /// directions useful from iterates with far larger transient pressures
    /// (see `mean_dilatation`).
    pub fn set_tangent_pressure_cap(&mut self, cap: f64) {
        self.tangent_pressure_cap = cap;
    }

    /// The cap of [`Body::set_tangent_pressure_cap`] \[MPa\].
    pub fn tangent_pressure_cap(&self) -> f64 {
        self.tangent_pressure_cap
    }

    pub fn dof_count(&self) -> usize {
        3 * self.nodes.len()
    }

    /// Material state at the last converged step, per material point
    /// (`kind().points()` per element, in element order).
    pub fn states(&self) -> &[PointState] {
        &self.states
    }

    /// Reference volume \[mm^3\].
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
    /// Deterministic: each element is computed independently into its own
    /// slots of the result; an error names the lowest failing element.
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
        match &self.geometry {
            Geometry::None => Err(FemError::Mesh("element geometry not built".into())),
            Geometry::Hex8(g) => self.evaluate_all::<8, 8, 0, 24>(g, u, dt, with_tangent),
            Geometry::Tet10(g) => self.evaluate_all::<10, 4, 6, 30>(g, u, dt, with_tangent),
        }
    }

    fn evaluate_all<const NEN: usize, const NGP: usize, const NXP: usize, const NDOF: usize>(
        &self,
        geometry: &[MeanDilatationGeometry<NEN, NGP, NXP>],
        u: &[f64],
        dt: f64,
        with_tangent: bool,
    ) -> Result<BodyEvaluation, FemError> {
        let count = geometry.len();
        let mut residuals = vec![0.0; count * NDOF];
        let mut tangents = if with_tangent {
            vec![0.0; count * NDOF * NDOF]
        } else {
            Vec::new()
        };
        let mut states = vec![PointState::default(); count * NGP];
        // With no tangent, each element gets an empty tangent slice.
        let tangent_len = if with_tangent { NDOF * NDOF } else { 0 };
        let tangent_chunks: Vec<&mut [f64]> = if with_tangent {
            tangents.chunks_mut(tangent_len).collect()
        } else {
            (0..count).map(|_| <&mut [f64]>::default()).collect()
        };
        let results: Vec<Result<ElementSummary, FemError>> = geometry
            .par_iter()
            .zip(residuals.par_chunks_mut(NDOF))
            .zip(states.par_chunks_mut(NGP))
            .zip(tangent_chunks.into_par_iter())
            .enumerate()
            .map(|(e, (((geom, residual), states), tangent))| {
                let el = self.element_nodes(e);
                let x: [[f64; 3]; NEN] = std::array::from_fn(|a| {
                    let (n, p) = (el[a], self.nodes[el[a]]);
                    [p[0] + u[3 * n], p[1] + u[3 * n + 1], p[2] + u[3 * n + 2]]
                });
                let states_n: [PointState; NGP] = std::array::from_fn(|k| self.states[NGP * e + k]);
                let residual: &mut [f64; NDOF] = residual
                    .try_into()
                    .map_err(|_| FemError::Mesh("element force buffer size".into()))?;
                let states: &mut [PointState; NGP] = states
                    .try_into()
                    .map_err(|_| FemError::Mesh("element state buffer size".into()))?;
                mean_dilatation::evaluate_into(
                    e,
                    geom,
                    &x,
                    &states_n,
                    &self.material,
                    dt,
                    self.tangent_pressure_cap,
                    residual,
                    with_tangent.then_some(tangent),
                    states,
                )
            })
            .collect();
        let summaries = results.into_iter().collect::<Result<Vec<_>, _>>()?;
        Ok(BodyEvaluation {
            ndof: NDOF,
            npoints: NGP,
            residuals,
            tangents,
            states,
            summaries,
        })
    }

    /// Makes the states of `eval` the converged state.
    /// Replaces the material states (a checkpoint's), one per material
    /// point in element order; fails when their number is not the body's.
    pub fn restore_states(&mut self, states: &[PointState]) -> Result<(), FemError> {
        if states.len() != self.states.len() {
            return Err(FemError::Mesh(format!(
                "{} material states for a body of {} points",
                states.len(),
                self.states.len()
            )));
        }
        self.states.copy_from_slice(states);
        Ok(())
    }

    pub fn commit(&mut self, eval: &BodyEvaluation) {
        self.states.copy_from_slice(&eval.states);
    }

    /// Replaces the material (e.g. to continue a run with other constants).
    pub fn set_material(&mut self, material: Material) {
        self.material = material;
    }
}

impl BodyEvaluation {
    /// Number of elements.
    pub fn element_count(&self) -> usize {
        self.summaries.len()
    }

    /// Internal force of element `e`, `residual[3 a + i]` \[N\].
    pub fn element_residual(&self, e: usize) -> &[f64] {
        &self.residuals[self.ndof * e..self.ndof * (e + 1)]
    }

    /// Consistent tangent of element `e`, row-major, entry `(3a+i, 3b+k)`
    /// \[N/mm\]; empty when the evaluation was made without tangents.
    pub fn element_tangent(&self, e: usize) -> &[f64] {
        let m = self.ndof * self.ndof;
        self.tangents.get(m * e..m * (e + 1)).unwrap_or(&[])
    }

    /// All element tangents, `ndof x ndof` each, in element order (empty
    /// without tangents).
    pub fn tangents(&self) -> &[f64] {
        &self.tangents
    }

    /// All element internal forces, `ndof` each, in element order.
    pub fn residuals(&self) -> &[f64] {
        &self.residuals
    }

    /// True when the evaluation carries element tangents.
    pub fn has_tangent(&self) -> bool {
        !self.tangents.is_empty()
    }

    /// Material states of element `e` at the end of the step.
    pub fn element_states(&self, e: usize) -> &[PointState] {
        &self.states[self.npoints * e..self.npoints * (e + 1)]
    }

    /// Scalar results of element `e` (volume, largest plastic strain
    /// increment, mean stresses).
    pub fn element_summary(&self, e: usize) -> &ElementSummary {
        &self.summaries[e]
    }

    /// Internal force vector of the body (length `3 * nodes`) \[N\], summed in
    /// element order (deterministic).
    pub fn internal_force(&self, body: &Body) -> Vec<f64> {
        let mut f = vec![0.0; body.dof_count()];
        for e in 0..self.element_count() {
            let r = self.element_residual(e);
            for (a, &node) in body.element_nodes(e).iter().enumerate() {
                for i in 0..3 {
                    f[3 * node + i] += r[3 * a + i];
                }
            }
        }
        f
    }

    /// Current volume of the body \[mm^3\].
    pub fn volume(&self) -> f64 {
        self.summaries.iter().map(|o| o.volume).sum()
    }

    /// Largest equivalent plastic strain increment at any material point.
    pub fn max_dp(&self) -> f64 {
        self.summaries.iter().map(|o| o.max_dp).fold(0.0, f64::max)
    }

    /// Element-wise output fields.
    pub fn fields(&self) -> ElementFields {
        ElementFields {
            von_mises: self.summaries.iter().map(|o| o.von_mises).collect(),
            mean_stress: self.summaries.iter().map(|o| o.mean_stress).collect(),
            eqps: self.summaries.iter().map(|o| o.eqps).collect(),
        }
    }
}
