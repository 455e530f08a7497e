//! Candidate pairs: every pair of particles, periodic images included, whose
//! bounding spheres come within a given distance.
//!
//! Every periodic image is considered, not only the nearest one, so boxes
//! smaller than two particle diameters (and lattice unit cells holding one
//! particle that touches its own images) are handled. Large systems use a
//! cell list; small ones, or boxes with fewer than three cells along a
//! periodic side, check every pair and image.

use nalgebra::Vector3;

use crate::spec::Boundary;

/// Largest cell count along one side of the cell list.
const MAX_CELLS_PER_SIDE: usize = 64;
/// Below this particle count every pair is checked.
const CELL_LIST_MIN_PARTICLES: usize = 64;

/// The box: side lengths \[mm\] and which sides are periodic.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cell {
    pub(crate) lengths: Vector3<f64>,
    pub(crate) periodic: [bool; 3],
}

/// Particle `j`'s image shifted by `image` box lengths, paired with `i`
/// (`i <= j`; for `i == j` the image is non-zero and the first non-zero
/// component is positive, so each self-contact is listed once).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct PairImage {
    pub(crate) i: usize,
    pub(crate) j: usize,
    pub(crate) image: [i32; 3],
}

impl Cell {
    pub(crate) fn new(lengths: Vector3<f64>, boundary: Boundary) -> Cell {
        Cell {
            lengths,
            periodic: [
                boundary.is_periodic(0),
                boundary.is_periodic(1),
                boundary.is_periodic(2),
            ],
        }
    }

    /// The shift vector of an image \[mm\].
    pub(crate) fn offset(&self, image: [i32; 3]) -> Vector3<f64> {
        Vector3::from(image.map(f64::from)).component_mul(&self.lengths)
    }

    /// `x` wrapped into `[0, L)` along the periodic sides.
    pub(crate) fn wrap(&self, x: Vector3<f64>) -> Vector3<f64> {
        let mut y = x;
        for k in 0..3 {
            if self.periodic[k] {
                let l = self.lengths[k];
                let mut v = x[k] - l * (x[k] / l).floor();
                if v >= l {
                    v -= l;
                }
                if v < 0.0 {
                    v = 0.0;
                }
                y[k] = v;
            }
        }
        y
    }

    /// Centre distance vector `x_j + image - x_i` \[mm\].
    pub(crate) fn separation(
        &self,
        xi: &Vector3<f64>,
        xj: &Vector3<f64>,
        image: [i32; 3],
    ) -> Vector3<f64> {
        xj - xi + self.offset(image)
    }
}

fn positive_image(n: [i32; 3]) -> bool {
    for v in n {
        if v != 0 {
            return v > 0;
        }
    }
    false
}

/// Every `(i, j, image)` with `|x_j + image - x_i| < R_i + R_j + extra`, `R`
/// the bounding radii \[mm\]. The centres must be wrapped into the box along
/// the periodic sides.
pub(crate) fn pairs(
    cell: &Cell,
    centres: &[Vector3<f64>],
    radii: &[f64],
    extra: f64,
) -> Vec<PairImage> {
    let r_max = radii.iter().fold(0.0_f64, |m, &r| m.max(r));
    let cut = 2.0 * r_max + extra;
    let mut counts = [1usize; 3];
    let mut use_cells = centres.len() >= CELL_LIST_MIN_PARTICLES && cut > 0.0;
    for k in 0..3 {
        let n = ((cell.lengths[k] / cut).floor() as usize).clamp(1, MAX_CELLS_PER_SIDE);
        counts[k] = n;
        if cell.periodic[k] && n < 3 {
            use_cells = false;
        }
    }
    if use_cells {
        cell_list_pairs(cell, centres, radii, extra, counts)
    } else {
        all_pairs(cell, centres, radii, extra)
    }
}

fn within(d: &Vector3<f64>, cut: f64) -> bool {
    d.norm_squared() < cut * cut
}

fn all_pairs(cell: &Cell, centres: &[Vector3<f64>], radii: &[f64], extra: f64) -> Vec<PairImage> {
    let mut out = Vec::new();
    let n = centres.len();
    for i in 0..n {
        for j in i..n {
            let d0 = centres[j] - centres[i];
            let cut = radii[i] + radii[j] + extra;
            let mut lo = [0i32; 3];
            let mut hi = [0i32; 3];
            for k in 0..3 {
                if cell.periodic[k] {
                    let l = cell.lengths[k];
                    lo[k] = ((-cut - d0[k]) / l).ceil() as i32;
                    hi[k] = ((cut - d0[k]) / l).floor() as i32;
                }
            }
            for nx in lo[0]..=hi[0] {
                for ny in lo[1]..=hi[1] {
                    for nz in lo[2]..=hi[2] {
                        let image = [nx, ny, nz];
                        if i == j && !positive_image(image) {
                            continue;
                        }
                        if within(&(d0 + cell.offset(image)), cut) {
                            out.push(PairImage { i, j, image });
                        }
                    }
                }
            }
        }
    }
    out
}

fn cell_list_pairs(
    cell: &Cell,
    centres: &[Vector3<f64>],
    radii: &[f64],
    extra: f64,
    counts: [usize; 3],
) -> Vec<PairImage> {
    let index_along = |x: f64, k: usize| -> usize {
        let t = (x / cell.lengths[k] * counts[k] as f64).floor();
        if t < 0.0 {
            0
        } else {
            (t as usize).min(counts[k] - 1)
        }
    };
    let flat = |c: [usize; 3]| (c[2] * counts[1] + c[1]) * counts[0] + c[0];
    let total = counts[0] * counts[1] * counts[2];
    let own: Vec<[usize; 3]> = centres
        .iter()
        .map(|x| {
            [
                index_along(x[0], 0),
                index_along(x[1], 1),
                index_along(x[2], 2),
            ]
        })
        .collect();
    // Counting sort of the particles by cell.
    let mut start = vec![0usize; total + 1];
    for c in &own {
        start[flat(*c) + 1] += 1;
    }
    for k in 0..total {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut members = vec![0usize; centres.len()];
    for (p, c) in own.iter().enumerate() {
        let f = flat(*c);
        members[fill[f]] = p;
        fill[f] += 1;
    }
    let mut out = Vec::new();
    for (i, ci) in own.iter().enumerate() {
        for oz in -1i64..=1 {
            for oy in -1i64..=1 {
                for ox in -1i64..=1 {
                    let o = [ox, oy, oz];
                    let mut nc = [0usize; 3];
                    let mut image = [0i32; 3];
                    let mut skip = false;
                    for k in 0..3 {
                        let m = counts[k] as i64;
                        let mut v = ci[k] as i64 + o[k];
                        if v < 0 || v >= m {
                            if !cell.periodic[k] {
                                skip = true;
                                break;
                            }
                            image[k] = if v < 0 { -1 } else { 1 };
                            v -= i64::from(image[k]) * m;
                        }
                        nc[k] = v as usize;
                    }
                    if skip {
                        continue;
                    }
                    let f = flat(nc);
                    for &j in &members[start[f]..start[f + 1]] {
                        if j <= i {
                            continue;
                        }
                        let cut = radii[i] + radii[j] + extra;
                        if within(&cell.separation(&centres[i], &centres[j], image), cut) {
                            out.push(PairImage { i, j, image });
                        }
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    fn random_system(
        n: usize,
        boundary: Boundary,
        seed: u64,
    ) -> (Cell, Vec<Vector3<f64>>, Vec<f64>) {
        let mut rng = crate::distribution::stream(seed, 7);
        let cell = Cell::new(Vector3::new(11.0, 9.0, 13.0), boundary);
        let centres = (0..n)
            .map(|_| {
                cell.wrap(Vector3::new(
                    rng.random::<f64>() * 11.0,
                    rng.random::<f64>() * 9.0,
                    rng.random::<f64>() * 13.0,
                ))
            })
            .collect();
        let radii = (0..n).map(|_| 0.2 + 0.4 * rng.random::<f64>()).collect();
        (cell, centres, radii)
    }

    #[test]
    fn cell_list_finds_the_same_pairs_as_the_full_search() {
        for boundary in [Boundary::Periodic, Boundary::Die] {
            let (cell, x, r) = random_system(600, boundary, 3);
            // Cut 2 * 0.6 + 0.1 = 1.3: 8 x 6 x 10 cells.
            let mut a = cell_list_pairs(&cell, &x, &r, 0.1, [8, 6, 10]);
            let mut b = all_pairs(&cell, &x, &r, 0.1);
            let mut c = pairs(&cell, &x, &r, 0.1);
            a.sort();
            b.sort();
            c.sort();
            assert!(b.len() > 300, "{}", b.len());
            assert_eq!(a, b);
            assert_eq!(c, b);
            // Wrap-around pairs exist in the periodic directions.
            assert!(b.iter().any(|p| p.image[0] != 0));
            assert_eq!(boundary == Boundary::Die, b.iter().all(|p| p.image[2] == 0));
        }
    }

    #[test]
    fn a_particle_in_a_small_box_sees_each_touching_image_once() {
        // One sphere of radius 0.5 in a unit cube: 3 self-pairs (+x, +y, +z),
        // 6 contacts counted from both sides.
        let centre = [Vector3::repeat(0.5)];
        let cell = Cell::new(Vector3::repeat(1.0), Boundary::Periodic);
        assert_eq!(pairs(&cell, &centre, &[0.5], 1e-9).len(), 3);
        let cell = Cell::new(Vector3::repeat(1.0), Boundary::Die);
        assert_eq!(pairs(&cell, &centre, &[0.5], 1e-9).len(), 2);
    }
}
