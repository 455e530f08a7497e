//! Python bindings of tidens: the native module `tidens_rs._core`.
//!
//! A thin layer over `tidens-solver`: validation stays in the core (its errors
//! become `ValueError` naming the Python argument, see [`errors`]), results
//! come back as dicts of plain numbers and numpy arrays ([`convert`]), and
//! every solver step runs with the GIL released ([`simulation`]). The
//! contract is the hand-written stub `python/tidens_rs/_core.pyi`, checked
//! with `python -m mypy.stubtest tidens_rs._core`.

mod arguments;
mod cell;
mod convert;
mod errors;
mod material;
mod packing;
mod simulation;
mod size;

pub use cell::PyCell;
pub use errors::{CheckpointError, ConvergenceError, TidensError, UnsupportedError};
pub use material::{PyMaterial, tmp_creep_coefficient};
pub use packing::PyPacking;
pub use simulation::{PySimulation, check_parameters};
pub use size::estimate_size;

/// Threads the solver's parallel parts (assembly, large Cholesky
/// factorisations) run on in this process: ``RAYON_NUM_THREADS`` if set
/// when the first solve started, else the machine's cores. The results do
/// not depend on it; the wall time does.
#[pyo3::pyfunction]
pub fn solver_threads() -> usize {
    tidens_solver::solver_threads()
}

/// Native core of tidens (Rust, PyO3). Units: mm, N, MPa, s.
///
/// Private module: use the public API of tidens_rs.
#[pyo3::pymodule]
mod _core {
    use pyo3::prelude::*;
    use tidens_material::Preset;

    #[pymodule_export]
    use super::{
        CheckpointError, ConvergenceError, PyCell, PyMaterial, PyPacking, PySimulation,
        TidensError, UnsupportedError, check_parameters, estimate_size, solver_threads,
        tmp_creep_coefficient,
    };

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        m.add("__version__", env!("CARGO_PKG_VERSION"))?;
        // The attributes every ConvergenceError has, None until set.
        let convergence = m.py().get_type::<ConvergenceError>();
        for name in super::errors::CONVERGENCE_ATTRIBUTES {
            convergence.setattr(name, m.py().None())?;
        }
        // The material preset names, in the order of the presets table (docs/model.md).
        m.add("PRESET_NAMES", Preset::ALL.map(Preset::name).to_vec())?;
        // The `contact` choices of Simulation, the default first.
        let modes: Vec<&str> = super::simulation::CONTACT_MODES
            .iter()
            .map(|(name, _)| *name)
            .collect();
        m.add("CONTACT_MODES", modes)?;
        // The `contact_facets` choices, the default first.
        let facets: Vec<&str> = super::simulation::CONTACT_FACETS
            .iter()
            .map(|(name, _)| *name)
            .collect();
        m.add("CONTACT_FACETS", facets)?;
        m.add("DEFAULT_SIZE_RATIO", tidens_solver::DEFAULT_SIZE_RATIO)?;
        // Every solver knob's default: the core's, read by the Python layer.
        m.add(
            "SOLVER_DEFAULTS",
            super::simulation::solver_defaults(m.py())?,
        )?;
        let elements: Vec<&str> = super::simulation::ELEMENTS
            .iter()
            .map(|(name, _)| *name)
            .collect();
        m.add("ELEMENTS", elements)?;
        // Inner-cube divisions of each mesh level (element size ~ 1 / divisions).
        let divisions = (1..=tidens_solver::MAX_MESH_LEVEL)
            .map(|level| Ok((level, tidens_mesh::divisions_for_level(level)?)))
            .collect::<Result<std::collections::BTreeMap<u32, usize>, tidens_mesh::MeshError>>()
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
        m.add("LEVEL_DIVISIONS", divisions)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    /// The GIL is released around the steps, which needs the core
    /// simulation to move between threads.
    #[test]
    fn the_core_simulation_is_send() {
        fn assert_send<T: Send>() {}
        assert_send::<tidens_solver::Simulation>();
    }
}
