//! Overlap relaxation: the energy `U = 1/2 sum h^2` over the overlapping
//! pairs (gap `h < 0`, periodic images included) and, in a die, over the
//! particles crossing a wall, minimised by FIRE over the centres and the
//! axes.
//!
//! FIRE: E. Bitzek, P. Koskinen, F. Gähler, M. Moseler, P. Gumbsch, Phys. Rev.
//! Lett. 97 (2006) 170201, in the form of "FIRE 2.0" (J. Guénolé et al.,
//! Comput. Mater. Sci. 175 (2020) 109584: semi-implicit Euler, half-step
//! back-off when the power turns negative). Unit masses and unit contact
//! stiffness, so the time step is dimensionless. A rotation is carried as the
//! surface displacement `R theta` (`R` the bounding radius), its generalised
//! force is the torque over `R`.

use nalgebra::{Rotation3, UnitVector3, Vector3};

use crate::neighbours::{self, Cell, PairImage};
use crate::overlap::{self, Shape};
use crate::progress::Stopped;

/// FIRE parameters (FIRE 2.0 defaults, time step for unit stiffness).
const DT_START: f64 = 0.1;
const DT_MAX: f64 = 0.3;
const DT_MIN: f64 = 1e-4;
const N_DELAY: usize = 5;
const F_INC: f64 = 1.1;
const F_DEC: f64 = 0.5;
const ALPHA_START: f64 = 0.1;
const F_ALPHA: f64 = 0.99;

/// A stage is jammed when the largest net (generalised) force is below this
/// fraction of the largest overlap: a force-balanced state that still
/// overlaps, a local minimum of `U > 0`.
const JAM_RATIO: f64 = 1e-5;

/// Neighbour-list skin, relative to the mean bounding radius.
const SKIN: f64 = 0.3;

/// How a relaxation ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Outcome {
    /// Largest overlap at or below the tolerance.
    Relaxed,
    /// Force-balanced with overlaps left, or out of iterations.
    Stuck,
}

/// Saved centres \[mm\] and unit axes.
#[derive(Clone, Debug)]
pub(crate) struct Snapshot {
    pub(crate) pos: Vec<Vector3<f64>>,
    pub(crate) axis: Vec<UnitVector3<f64>>,
}

/// The system being relaxed: particles of full-size semi-axes `(a, c)`
/// scaled by `s <= 1` in the final box (growing the particles in a fixed box
/// is compressing the box with fixed particles).
pub(crate) struct Relaxer {
    cell: Cell,
    die: bool,
    /// Full-size semi-axes `(a, c)` \[mm\].
    base: Vec<(f64, f64)>,
    rotations: bool,
    s: f64,
    /// Centres \[mm\].
    pub(crate) pos: Vec<Vector3<f64>>,
    /// Unit symmetry axes.
    pub(crate) axis: Vec<UnitVector3<f64>>,
    pairs: Vec<PairImage>,
    /// Last optimal Perram-Wertheim λ of each pair (NaN: none yet).
    lambda: Vec<f64>,
    pos_at_build: Vec<Vector3<f64>>,
    s_at_build: f64,
    skin: f64,
    /// Forces, minus `∂U/∂x` \[mm\].
    force: Vec<Vector3<f64>>,
    /// Torques, minus the rotational derivative of `U` \[mm^2\].
    torque: Vec<Vector3<f64>>,
}

/// Energy and largest overlap of a configuration.
#[derive(Clone, Copy, Debug)]
struct Eval {
    /// `U = 1/2 sum h^2` over the overlaps \[mm^2\].
    #[cfg_attr(not(test), allow(dead_code))]
    energy: f64,
    /// Largest overlap \[mm\].
    max_overlap: f64,
}

impl Relaxer {
    pub(crate) fn new(
        cell: Cell,
        die: bool,
        base: Vec<(f64, f64)>,
        pos: Vec<Vector3<f64>>,
        axis: Vec<UnitVector3<f64>>,
    ) -> Relaxer {
        let n = base.len();
        let rotations = base.iter().any(|&(a, c)| a != c);
        let mean_bound = base.iter().map(|&(a, c)| a.max(c)).sum::<f64>() / n as f64;
        Relaxer {
            cell,
            die,
            base,
            rotations,
            s: 1.0,
            pos,
            axis,
            pairs: Vec::new(),
            lambda: Vec::new(),
            pos_at_build: Vec::new(),
            s_at_build: f64::NAN,
            skin: SKIN * mean_bound,
            force: vec![Vector3::zeros(); n],
            torque: vec![Vector3::zeros(); n],
        }
    }

    pub(crate) fn set_scale(&mut self, s: f64) {
        self.s = s;
    }

    pub(crate) fn snapshot(&self) -> Snapshot {
        Snapshot {
            pos: self.pos.clone(),
            axis: self.axis.clone(),
        }
    }

    pub(crate) fn restore(&mut self, snap: &Snapshot) {
        self.pos.clone_from(&snap.pos);
        self.axis.clone_from(&snap.axis);
        self.s_at_build = f64::NAN;
    }

    fn shape(&self, i: usize) -> Shape {
        let (a, c) = self.base[i];
        Shape {
            a: self.s * a,
            c: self.s * c,
            axis: self.axis[i].into_inner(),
        }
    }

    fn bound(&self, i: usize) -> f64 {
        let (a, c) = self.base[i];
        self.s * a.max(c)
    }

    /// Rebuilds the neighbour list when the scale changed or a particle moved
    /// more than half the skin since the last build.
    fn ensure_list(&mut self) {
        let half = 0.5 * self.skin;
        let stale = self.s != self.s_at_build
            || self.pos.len() != self.pos_at_build.len()
            || self
                .pos
                .iter()
                .zip(&self.pos_at_build)
                .any(|(x, y)| (x - y).norm_squared() > half * half);
        if !stale {
            return;
        }
        for x in &mut self.pos {
            *x = self.cell.wrap(*x);
        }
        let radii: Vec<f64> = (0..self.base.len()).map(|i| self.bound(i)).collect();
        self.pairs = neighbours::pairs(&self.cell, &self.pos, &radii, self.skin);
        self.lambda = vec![f64::NAN; self.pairs.len()];
        self.pos_at_build.clone_from(&self.pos);
        self.s_at_build = self.s;
    }

    /// Forces and torques (minus the gradient of `U`) into `self.force`,
    /// `self.torque`.
    fn evaluate(&mut self) -> Eval {
        self.force.fill(Vector3::zeros());
        self.torque.fill(Vector3::zeros());
        let mut max_overlap = 0.0_f64;
        let mut energy = 0.0;
        for (p, lambda) in self.pairs.iter().zip(self.lambda.iter_mut()) {
            let (i, j) = (p.i, p.j);
            let d = self.cell.separation(&self.pos[i], &self.pos[j], p.image);
            let (a_i, c_i) = self.base[i];
            let (a_j, c_j) = self.base[j];
            let reach = self.s * (a_i.max(c_i) + a_j.max(c_j));
            if d.norm_squared() >= reach * reach {
                continue;
            }
            let si = Shape {
                a: self.s * a_i,
                c: self.s * c_i,
                axis: self.axis[i].into_inner(),
            };
            let sj = Shape {
                a: self.s * a_j,
                c: self.s * c_j,
                axis: self.axis[j].into_inner(),
            };
            if !(si.is_sphere() && sj.is_sphere()) {
                // Separating axis along d: the projections do not overlap.
                let dist = d.norm();
                let n = d * (1.0 / dist);
                if dist >= si.support(&n) + sj.support(&n) {
                    continue;
                }
            }
            let g = overlap::gap_gradient(d, &si, &sj, *lambda);
            *lambda = g.lambda;
            if g.h >= 0.0 {
                continue;
            }
            max_overlap = max_overlap.max(-g.h);
            energy += 0.5 * g.h * g.h;
            let fd = g.d_d * g.h;
            self.force[i] += fd;
            self.force[j] -= fd;
            if self.rotations {
                self.torque[i] -= si.axis.cross(&(g.d_ua * g.h));
                self.torque[j] -= sj.axis.cross(&(g.d_ub * g.h));
            }
        }
        if self.die {
            let lz = self.cell.lengths[2];
            for i in 0..self.pos.len() {
                let sh = self.shape(i);
                let e = sh.support(&Vector3::z());
                let z = self.pos[i][2];
                // d e / d u = (c^2 - a^2) u_z / e along z.
                let de_du = Vector3::z() * ((sh.c * sh.c - sh.a * sh.a) * sh.axis[2] / e);
                for (h, dir) in [(z - e, 1.0), (lz - z - e, -1.0)] {
                    if h < 0.0 {
                        max_overlap = max_overlap.max(-h);
                        energy += 0.5 * h * h;
                        self.force[i][2] -= h * dir;
                        if self.rotations {
                            self.torque[i] += sh.axis.cross(&(de_du * h));
                        }
                    }
                }
            }
        }
        Eval {
            energy,
            max_overlap,
        }
    }

    /// The largest scale `s' <= s` at which the current configuration has no
    /// overlap: shrinking a particle about its centre shortens every contact
    /// distance along a fixed direction in proportion, so a pair with gap `h`
    /// at centre distance `|d|` is just touching at `s |d| / (|d| - h)`, and a
    /// particle crossing a wall at `s z / e` (or `s (Lz - z) / e`).
    pub(crate) fn overlap_free_scale(&mut self) -> f64 {
        self.ensure_list();
        let mut s_free = self.s;
        for p in &self.pairs {
            let (i, j) = (p.i, p.j);
            let d = self.cell.separation(&self.pos[i], &self.pos[j], p.image);
            let reach = self.bound(i) + self.bound(j);
            if d.norm_squared() >= reach * reach {
                continue;
            }
            let h = overlap::gap(d, &self.shape(i), &self.shape(j));
            if h < 0.0 {
                let dist = d.norm();
                s_free = s_free.min(self.s * dist / (dist - h));
            }
        }
        if self.die {
            let lz = self.cell.lengths[2];
            for i in 0..self.pos.len() {
                let e = self.shape(i).support(&Vector3::z());
                let z = self.pos[i][2];
                for room in [z, lz - z] {
                    if room < e {
                        s_free = s_free.min(self.s * room.max(0.0) / e);
                    }
                }
            }
        }
        s_free
    }

    /// FIRE until the largest overlap is at most `tol` \[mm\], the system is
    /// force-balanced with overlaps left, or `max_iter` steps; `Err(Stopped)`
    /// as soon as `stop`, asked before every step, answers true (the
    /// configuration is then that of the step reached).
    pub(crate) fn relax(
        &mut self,
        tol: f64,
        max_iter: usize,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<Outcome, Stopped> {
        let n = self.pos.len();
        let mut vel = vec![Vector3::zeros(); n];
        let mut omega = vec![Vector3::zeros(); n];
        let mut dt = DT_START;
        let mut alpha = ALPHA_START;
        let mut positive = 0usize;
        let lever: Vec<f64> = (0..n).map(|i| self.bound(i)).collect();
        for _ in 0..max_iter {
            if stop() {
                return Err(Stopped);
            }
            self.ensure_list();
            let eval = self.evaluate();
            if eval.max_overlap <= tol {
                return Ok(Outcome::Relaxed);
            }
            // Generalised forces: F and T / R.
            let mut fmax2 = 0.0_f64;
            let mut power = 0.0;
            let mut f2 = 0.0;
            for i in 0..n {
                let f = self.force[i];
                let q = self.torque[i] * (1.0 / lever[i]);
                fmax2 = fmax2.max(f.norm_squared()).max(q.norm_squared());
                power += f.dot(&vel[i]) + q.dot(&omega[i]);
                f2 += f.norm_squared() + q.norm_squared();
            }
            if fmax2.sqrt() <= JAM_RATIO * eval.max_overlap {
                return Ok(Outcome::Stuck);
            }
            if power > 0.0 {
                positive += 1;
                if positive > N_DELAY {
                    dt = (dt * F_INC).min(DT_MAX);
                    alpha *= F_ALPHA;
                }
            } else {
                positive = 0;
                dt = (dt * F_DEC).max(DT_MIN);
                alpha = ALPHA_START;
                for i in 0..n {
                    self.pos[i] -= vel[i] * (0.5 * dt);
                    if self.rotations {
                        let back = omega[i] * (-0.5 * dt / lever[i]);
                        self.axis[i] = turned(&self.axis[i], &back);
                    }
                    vel[i] = Vector3::zeros();
                    omega[i] = Vector3::zeros();
                }
            }
            // Semi-implicit Euler with FIRE mixing.
            let mut v2 = 0.0;
            for i in 0..n {
                vel[i] += self.force[i] * dt;
                omega[i] += self.torque[i] * (dt / lever[i]);
                v2 += vel[i].norm_squared() + omega[i].norm_squared();
            }
            if f2 > 0.0 {
                let mix = alpha * (v2 / f2).sqrt();
                for i in 0..n {
                    vel[i] = vel[i] * (1.0 - alpha) + self.force[i] * mix;
                    let q = self.torque[i] * (1.0 / lever[i]);
                    omega[i] = omega[i] * (1.0 - alpha) + q * mix;
                }
            }
            for i in 0..n {
                self.pos[i] += vel[i] * dt;
                if self.rotations {
                    let turn = omega[i] * (dt / lever[i]);
                    self.axis[i] = turned(&self.axis[i], &turn);
                }
            }
        }
        self.ensure_list();
        Ok(if self.evaluate().max_overlap <= tol {
            Outcome::Relaxed
        } else {
            Outcome::Stuck
        })
    }
}

/// The unit vector `axis` rotated by the rotation vector `phi` (angle
/// `|phi|` rad about `phi / |phi|`), normalised again so that many small
/// turns do not let its length drift.
pub(crate) fn turned(axis: &UnitVector3<f64>, phi: &Vector3<f64>) -> UnitVector3<f64> {
    let mut u = Rotation3::new(*phi) * *axis;
    u.renormalize();
    u
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::Boundary;
    use rand::Rng;

    /// Forces and torques are minus the derivatives of the energy, for
    /// overlapping spheroids across periodic images and die walls.
    #[test]
    fn forces_and_torques_are_the_energy_gradient() {
        let mut rng = crate::distribution::stream(11, 9);
        let n = 12;
        let lengths = Vector3::new(3.0, 3.5, 3.2);
        let cell = Cell::new(lengths, Boundary::Die);
        let base: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                if k % 3 == 0 {
                    (0.45, 0.45)
                } else {
                    (0.35, 0.75)
                }
            })
            .collect();
        let pos: Vec<Vector3<f64>> = (0..n)
            .map(|_| {
                Vector3::new(
                    lengths[0] * rng.random::<f64>(),
                    lengths[1] * rng.random::<f64>(),
                    -0.2 + (lengths[2] + 0.4) * rng.random::<f64>(),
                )
            })
            .collect();
        let axis: Vec<UnitVector3<f64>> = (0..n)
            .map(|_| {
                UnitVector3::new_normalize(Vector3::new(
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                ))
            })
            .collect();
        let mut sys = Relaxer::new(cell, true, base, pos, axis);
        sys.set_scale(1.0);
        sys.ensure_list();
        let e0 = sys.evaluate();
        assert!(e0.energy > 0.01 && e0.max_overlap > 0.05, "{e0:?}");
        let walls = sys
            .pos
            .iter()
            .filter(|x| x[2] < 0.45 || x[2] > 2.75)
            .count();
        assert!(walls > 0);
        let (force, torque) = (sys.force.clone(), sys.torque.clone());
        let eps = 1e-6;
        // Minus the central difference of the energy under the move
        // `set(sys, ±eps)`, the same pair list kept (small moves only).
        let minus_slope = |sys: &mut Relaxer, set: &dyn Fn(&mut Relaxer, f64)| {
            set(sys, eps);
            let up = sys.evaluate().energy;
            set(sys, -eps);
            let down = sys.evaluate().energy;
            -(up - down) / (2.0 * eps)
        };
        let mut checked = 0;
        for i in 0..n {
            for k in 0..3 {
                let (x0, u0) = (sys.pos[i], sys.axis[i]);
                let fd_force = minus_slope(&mut sys, &|s, t| s.pos[i][k] = x0[k] + t);
                sys.pos[i] = x0;
                let fd_torque = minus_slope(&mut sys, &|s, t| {
                    s.axis[i] = Rotation3::new(Vector3::ith(k, t)) * u0;
                });
                sys.axis[i] = u0;
                for (name, fd, exact) in [
                    ("force", fd_force, force[i][k]),
                    ("torque", fd_torque, torque[i][k]),
                ] {
                    assert!((fd - exact).abs() < 1e-6, "{name} {i} {k}: {fd} vs {exact}");
                }
                if force[i][k].abs() > 1e-3 || torque[i][k].abs() > 1e-3 {
                    checked += 1;
                }
            }
        }
        assert!(checked > 10, "{checked}");
    }
}
