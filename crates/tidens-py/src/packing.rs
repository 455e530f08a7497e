//! `Packing`: a random dense packing of spheres or spheroids (the
//! `tidens-packing` crate), generated with the GIL released or read from a
//! file of centres, semi-axes and axes.
//!
//! A generation of thousands of particles takes minutes. It asks the
//! core's `stop` callback before every FIRE iteration; the callback takes
//! the GIL at most every [`SIGNAL_INTERVAL`] to run Python's signal
//! handlers (Ctrl-C's KeyboardInterrupt, `signals.sigterm_stops`'s
//! Terminated) and at most every [`PROGRESS_INTERVAL`] to call the user's
//! `progress`; what either raises stops the generation and propagates.

use crate::arguments::integer;
use crate::errors::{Number, parameter_error};
use crate::simulation::named;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::time::{Duration, Instant};
use tidens_packing::{
    Boundary, MAX_PARTICLES, Packing, PackingError, PackingSpec, Progress, SizeDistribution,
};

/// How often a generation runs Python's signal handlers: a stop within a
/// tenth of a second, and the GIL taken ten times a second at most (each
/// time for microseconds), so other Python threads hardly notice.
const SIGNAL_INTERVAL: Duration = Duration::from_millis(100);
/// How often a generation calls `progress`: four times a second at most.
const PROGRESS_INTERVAL: Duration = Duration::from_millis(250);

/// A contact as Python gets it: (i, j, image of j in box lengths, gap [mm]).
type ContactTuple = (usize, usize, (i32, i32, i32), f64);

/// The Python names of the boundaries, the default first.
pub(crate) const BOUNDARIES: [(&str, Boundary); 2] =
    [("periodic", Boundary::Periodic), ("die", Boundary::Die)];

fn boundary(name: &str) -> PyResult<Boundary> {
    named("boundary", name, &BOUNDARIES)
}

fn boundary_name(b: Boundary) -> &'static str {
    BOUNDARIES
        .iter()
        .find(|(_, x)| *x == b)
        .map_or("periodic", |(n, _)| n)
}

/// A packing error as a ValueError naming the Python argument (or the line
/// and field of the text).
fn packing_error(e: PackingError) -> PyErr {
    match e {
        PackingError::Parameter {
            name,
            value,
            allowed,
        } => {
            let python = match name {
                "mean_radius" => "mean_radius_mm",
                "lengths[0]" => "lengths_mm[0]",
                "lengths[1]" => "lengths_mm[1]",
                "lengths[2]" => "lengths_mm[2]",
                other => other,
            };
            parameter_error(python, Number(value), allowed)
        }
        other => PyValueError::new_err(other.to_string()),
    }
}

/// The `particles` argument: an integer in [1, 10000].
fn particles_argument(value: &Bound<'_, PyAny>) -> PyResult<usize> {
    integer("particles", value, 1..=MAX_PARTICLES)
}

/// The `seed` argument: any 64-bit seed.
fn seed_argument(value: &Bound<'_, PyAny>) -> PyResult<u64> {
    integer("seed", value, 0..=u64::MAX)
}

/// The core's spec from the Python arguments, checked (a ValueError naming
/// the argument). `sizes`: size_ratio, small_fraction, sigma.
#[allow(clippy::too_many_arguments)]
fn spec(
    count: usize,
    rho0: f64,
    mean_radius_mm: f64,
    aspect_ratio: f64,
    sizes: (Option<f64>, f64, Option<f64>),
    boundary: &str,
    box_aspect: (f64, f64, f64),
    seed: u64,
) -> PyResult<PackingSpec> {
    let distribution = match sizes {
        (Some(_), _, Some(_)) => {
            return Err(PyValueError::new_err(
                "size_ratio and sigma are both given: size_ratio (with small_fraction) \
                 makes a bimodal distribution, sigma a lognormal one; give one or neither",
            ));
        }
        (Some(size_ratio), small_fraction, None) => SizeDistribution::Bimodal {
            size_ratio,
            small_fraction,
        },
        (None, _, Some(sigma)) => SizeDistribution::Lognormal { sigma },
        (None, _, None) => SizeDistribution::Monodisperse,
    };
    let spec = PackingSpec {
        particles: count,
        distribution,
        aspect_ratio,
        mean_radius: mean_radius_mm,
        rho0,
        boundary: self::boundary(boundary)?,
        box_aspect: [box_aspect.0, box_aspect.1, box_aspect.2],
        seed,
    };
    spec.validate().map_err(packing_error)?;
    Ok(spec)
}

/// The progress of a generation as `progress` gets it.
fn progress_dict<'py>(py: Python<'py>, p: &Progress) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("stage", p.stage.name())?;
    d.set_item("rel_density", p.rel_density)?;
    d.set_item("densest", p.densest)?;
    d.set_item("round", p.round)?;
    d.set_item("iterations", p.iterations)?;
    Ok(d)
}

/// Generates the packing of `spec` (`jam`: [`Packing::jam`]) with the GIL
/// released, running Python's signal handlers and `progress` from the
/// core's stop callback at a bounded rate; what they raise ends the
/// generation and is returned.
fn generate_watched(
    py: Python<'_>,
    spec: &PackingSpec,
    jam: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Packing> {
    let make = if jam {
        Packing::jam_unless
    } else {
        Packing::generate_unless
    };
    let mut raised: Option<PyErr> = None;
    let result = py.detach(|| {
        let (mut signals_at, mut progress_at) = (Instant::now(), Instant::now());
        make(spec, &mut |p| {
            let now = Instant::now();
            let signals_due = now - signals_at >= SIGNAL_INTERVAL;
            let progress_due = progress.is_some() && now - progress_at >= PROGRESS_INTERVAL;
            if !(signals_due || progress_due) {
                return false;
            }
            let outcome = Python::attach(|py| {
                if signals_due {
                    signals_at = now;
                    py.check_signals()?;
                }
                if let (true, Some(callback)) = (progress_due, &progress) {
                    progress_at = now;
                    callback.call1(py, (progress_dict(py, p)?,))?;
                }
                Ok(())
            });
            match outcome {
                Ok(()) => false,
                Err(e) => {
                    raised = Some(e);
                    true
                }
            }
        })
    });
    match (result, raised) {
        (Err(PackingError::Interrupted { .. }), Some(e)) => Err(e),
        (result, _) => result.map_err(packing_error),
    }
}

/// A packing of spheroids in a box [0, Lx) x [0, Ly) x [0, Lz) [mm].
///
/// Packing.generate(particles, ...) makes a random dense one at a target
/// relative density rho0 (overlap relaxation with box compression, the
/// jamming protocol of O'Hern et al., Phys. Rev. E 68 (2003) 011306; the
/// box is sized so that the density is exactly rho0, and no two particles
/// overlap by more than 1e-6 of the mean radius). Packing.from_text(text,
/// lengths_mm, boundary) reads one particle per line, `x y z a [c [ax ay
/// az]]` (mm; c defaults to a, the axis to z), e.g. a packing from a DEM
/// code; to_text() writes that format. boundary: "periodic" (periodic in x,
/// y and z) or "die" (periodic in x and y, rigid walls at z = 0 and z = Lz).
#[pyclass(name = "Packing", module = "tidens_rs._core", frozen)]
#[derive(Clone, Debug)]
pub struct PyPacking {
    pub(crate) inner: Packing,
}

#[pymethods]
impl PyPacking {
    /// A random dense packing. particles in [1, 10000]; rho0 in [0.3, 0.74]
    /// (what the relaxation can reach, shaken and compressed again where it
    /// jams, depends on the size distribution and the boundary: about
    /// 0.64-0.69 for monodisperse spheres in a periodic box, less in a die;
    /// above it a ValueError says the density reached, or jam=True returns
    /// the packing where it first jams, about 0.60-0.65 for 32 or more
    /// spheres);
    /// mean_radius_mm: number mean of the volume-equivalent radius
    /// (a^2 c)^(1/3) [mm]; aspect_ratio c/a in [0.2, 5] (c along each
    /// particle's random axis); size_ratio (large/small radius, in (1, 10])
    /// with small_fraction (number fraction of small particles, in [0, 1])
    /// for a bimodal distribution, or sigma (standard deviation of
    /// ln(radius), in (0, 1]) for a lognormal one, neither for monodisperse;
    /// box_aspect: the box's relative side lengths; seed: the same arguments
    /// and seed give the same packing on every machine. Below jamming few
    /// particles touch. jam: where the packing jams below rho0, the state
    /// of its first jam instead of the refusal (not shaken and compressed
    /// again, which anneals small boxes into ordered states), refined
    /// until touching particles are apart by less than 1e-6 of the mean
    /// radius, the particles' sizes kept and the box scaled to the density
    /// reached (rel_density); frictionless jammed packings are isostatic,
    /// about 6 contacts per sphere without rattlers. A box that fits a
    /// crystal (32 spheres in a cube fit fcc) can crystallise and reach
    /// rho0 itself: check the coordination number.
    ///
    /// Runs with the GIL released; Python's signal handlers run ten times
    /// a second, so Ctrl-C raises KeyboardInterrupt (and SIGTERM, inside
    /// signals.sigterm_stops, Terminated) within about 0.1 s. progress: a
    /// callable, called at most four times a second with a dict: stage
    /// ("start": relaxing the random start, "compress", "shake": after a
    /// jam below rho0, "refine": locating the jamming point with jam=True),
    /// rel_density (the density being relaxed at), densest (the densest
    /// overlap-free density so far), round (0, then the number of shakes,
    /// at most 20), iterations (relaxation iterations so far). What it
    /// raises stops the generation and propagates.
    #[staticmethod]
    #[pyo3(signature = (
        particles,
        *,
        rho0 = 0.6,
        mean_radius_mm = 0.05,
        aspect_ratio = 1.0,
        size_ratio = None,
        small_fraction = 0.5,
        sigma = None,
        boundary = "periodic",
        box_aspect = (1.0, 1.0, 1.0),
        seed = 0,
        jam = false,
        progress = None,
    ))]
    #[allow(clippy::too_many_arguments)]
    fn generate(
        py: Python<'_>,
        #[pyo3(from_py_with = particles_argument)] particles: usize,
        rho0: f64,
        mean_radius_mm: f64,
        aspect_ratio: f64,
        size_ratio: Option<f64>,
        small_fraction: f64,
        sigma: Option<f64>,
        boundary: &str,
        box_aspect: (f64, f64, f64),
        #[pyo3(from_py_with = seed_argument)] seed: u64,
        jam: bool,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        let spec = spec(
            particles,
            rho0,
            mean_radius_mm,
            aspect_ratio,
            (size_ratio, small_fraction, sigma),
            boundary,
            box_aspect,
            seed,
        )?;
        if let Some(callback) = &progress
            && !callback.bind(py).is_callable()
        {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "progress = {}: must be a callable (taking a dict) or None",
                callback.bind(py).repr()?
            )));
        }
        let inner = generate_watched(py, &spec, jam, progress)?;
        Ok(Self { inner })
    }

    /// Reads a packing (format in the class docstring) in the box
    /// lengths_mm with the given boundary. A ValueError names the line and
    /// field of an unreadable line, a particle crossing a die wall, or two
    /// particles that overlap (more than 1e-6 of the smaller radius).
    #[staticmethod]
    #[pyo3(signature = (text, lengths_mm, boundary = "periodic"))]
    fn from_text(text: &str, lengths_mm: (f64, f64, f64), boundary: &str) -> PyResult<Self> {
        let lengths = [lengths_mm.0, lengths_mm.1, lengths_mm.2];
        let inner =
            Packing::from_text(text, lengths, self::boundary(boundary)?).map_err(packing_error)?;
        Ok(Self { inner })
    }

    /// The packing as text, one particle per line (`x y z a c ax ay az`,
    /// mm); from_text reads it back.
    fn to_text(&self) -> String {
        self.inner.to_text()
    }

    /// Box side lengths (Lx, Ly, Lz) [mm].
    #[getter]
    fn lengths_mm(&self) -> (f64, f64, f64) {
        let [x, y, z] = self.inner.lengths;
        (x, y, z)
    }

    /// "periodic" or "die".
    #[getter]
    fn boundary(&self) -> &'static str {
        boundary_name(self.inner.boundary)
    }

    /// Particle volume over box volume.
    #[getter]
    fn rel_density(&self) -> f64 {
        self.inner.rel_density()
    }

    /// Particle centres [mm], shape (N, 3).
    #[getter]
    fn centres_mm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = &self.inner.particles;
        table(py, 3, p.iter().flat_map(|p| p.centre).collect())
    }

    /// Semi-axes (a, c) [mm], shape (N, 2): a across the axis, c along it.
    #[getter]
    fn semi_axes_mm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = &self.inner.particles;
        table(py, 2, p.iter().flat_map(|p| [p.a, p.c]).collect())
    }

    /// Unit axes of the particles (the direction of c), shape (N, 3).
    #[getter]
    fn axes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = &self.inner.particles;
        table(py, 3, p.iter().flat_map(|p| p.axis).collect())
    }

    /// Particle-particle contacts: (i, j, image, gap_mm) for every pair
    /// (periodic images included; image in box lengths) whose surface gap
    /// is at most tolerance_mm (overlaps included), i <= j.
    fn contacts(&self, tolerance_mm: f64) -> PyResult<Vec<ContactTuple>> {
        check_tolerance(tolerance_mm)?;
        Ok(self
            .inner
            .contacts(tolerance_mm)
            .into_iter()
            .map(|c| (c.i, c.j, (c.image[0], c.image[1], c.image[2]), c.gap))
            .collect())
    }

    /// Mean number of particle-particle contacts per particle (gap at most
    /// tolerance_mm), 2 x contacts / particles; die walls are not counted
    /// and rattlers are not removed.
    fn coordination_number(&self, tolerance_mm: f64) -> PyResult<f64> {
        check_tolerance(tolerance_mm)?;
        Ok(self.inner.coordination_number(tolerance_mm))
    }

    /// The coordination number without the rattlers: particles with fewer
    /// than 4 contacts (gap at most tolerance_mm; a die wall counts) are
    /// removed, round after round, and the contacts among the rest are
    /// counted per particle left (0 when none is left).
    fn backbone_coordination_number(&self, tolerance_mm: f64) -> PyResult<f64> {
        check_tolerance(tolerance_mm)?;
        Ok(self.inner.backbone_coordination_number(tolerance_mm))
    }

    /// Largest overlap depth [mm] between two particles or of a particle
    /// across a die wall; 0 when nothing overlaps.
    #[getter]
    fn max_overlap_mm(&self) -> f64 {
        self.inner.max_overlap()
    }

    fn __len__(&self) -> usize {
        self.inner.particles.len()
    }

    fn __repr__(&self) -> String {
        let [x, y, z] = self.inner.lengths;
        format!(
            "Packing({} particles, {} box {x:.6} x {y:.6} x {z:.6} mm, rho = {:.6})",
            self.inner.particles.len(),
            boundary_name(self.inner.boundary),
            self.inner.rel_density()
        )
    }
}

/// `values`, one particle's `columns` after another, as an (N, columns)
/// numpy array.
fn table(py: Python<'_>, columns: usize, values: Vec<f64>) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let rows = values.len() / columns;
    PyArray1::from_vec(py, values).reshape([rows, columns])
}

fn check_tolerance(tolerance_mm: f64) -> PyResult<()> {
    if tolerance_mm.is_finite() && tolerance_mm >= 0.0 {
        Ok(())
    } else {
        Err(parameter_error(
            "tolerance_mm",
            Number(tolerance_mm),
            "finite and >= 0 mm",
        ))
    }
}
