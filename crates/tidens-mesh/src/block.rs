//! Uniform box ("block") mesh, used for verification tests.

use crate::hex::{FACE_ETA_MIN, FACE_XI_MIN, FACE_ZETA_MAX, FACE_ZETA_MIN, FACES};
use crate::{BoundaryFace, FaceKind, HexMesh};

/// Local face index (into [`FACES`]) of the face at the high end of each axis.
const FACE_HIGH: [usize; 3] = [1, 3, FACE_ZETA_MAX];
/// Local face index of the face at the low end of each axis.
const FACE_LOW: [usize; 3] = [FACE_XI_MIN, FACE_ETA_MIN, FACE_ZETA_MIN];

/// Builds the uniform mesh of `[0, L0] x [0, L1] x [0, L2]` \[mm\] with
/// `div[i]` elements along axis `i`; inputs must already be validated.
pub(crate) fn build(lengths: [f64; 3], div: [usize; 3]) -> HexMesh {
    let [nx, ny, nz] = div;
    // Coordinates per axis: i * L / n, with the far end pinned to exactly L so that
    // faces on x = L are exactly planar.
    let coords: [Vec<f64>; 3] = std::array::from_fn(|a| {
        let mut c: Vec<f64> = (0..=div[a])
            .map(|i| lengths[a] * i as f64 / div[a] as f64)
            .collect();
        c[div[a]] = lengths[a];
        c
    });
    let id = |i: usize, j: usize, k: usize| (k * (ny + 1) + j) * (nx + 1) + i;
    let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1) * (nz + 1));
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                nodes.push([coords[0][i], coords[1][j], coords[2][k]]);
            }
        }
    }
    let mut elements = Vec::with_capacity(nx * ny * nz);
    let mut boundary = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let el = [
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ];
                let e = elements.len();
                let index = [i, j, k];
                for axis in 0..3 {
                    if index[axis] == 0 {
                        let kind = FaceKind::Plane { axis, high: false };
                        boundary.push(BoundaryFace {
                            nodes: FACES[FACE_LOW[axis]].map(|l| el[l]),
                            element: e,
                            kind,
                        });
                    }
                    if index[axis] + 1 == div[axis] {
                        let kind = FaceKind::Plane { axis, high: true };
                        boundary.push(BoundaryFace {
                            nodes: FACES[FACE_HIGH[axis]].map(|l| el[l]),
                            element: e,
                            kind,
                        });
                    }
                }
                elements.push(el);
            }
        }
    }
    HexMesh {
        nodes,
        elements,
        boundary,
    }
}
