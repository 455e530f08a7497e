//! Whole-particle meshes: the eight mirror images of an octant mesh glued
//! into one conforming mesh along the planes x = 0, y = 0, z = 0.
//!
//! Gluing uses the octant's own structure, not a coordinate search: a node
//! lies on the plane x_axis = 0 when it belongs to one of the octant's
//! `FaceKind::Plane { axis, high: false }` faces. Mirroring the octant about
//! the axes of the flip pattern `g` maps such a node to the same point as the
//! pattern `g` without the flips of those axes, because [`HexMesh::mirrored`]
//! leaves a zero coordinate exactly +0.0. So node `k` of image `g` is node
//! `k` of image `g & !planes(k)`, created once, in the image with the fewest
//! flips; nodes on one plane are shared by 2 images, on two planes (an axis)
//! by 4, and the centre by all 8.

use crate::{BoundaryFace, FaceKind, HexMesh};

/// The flips of the mirror image numbered `g` in 0..8: axis `i` is flipped
/// when bit `i` of `g` is set.
fn flips(g: usize) -> [bool; 3] {
    std::array::from_fn(|i| g >> i & 1 == 1)
}

/// Per node of `half`, the bit set of the cut planes it lies on: bit `i`
/// when it is a node of a `FaceKind::Plane { axis: i, high: false }` face.
fn cut_planes(half: &HexMesh) -> Vec<usize> {
    let mut planes = vec![0; half.nodes.len()];
    for f in &half.boundary {
        if let FaceKind::Plane { axis, high: false } = f.kind {
            for &k in &f.nodes {
                debug_assert_eq!(half.nodes[k][axis], 0.0, "node {k} off plane {axis}");
                planes[k] |= 1 << axis;
            }
        }
    }
    planes
}

/// `half` and its seven mirror images glued into one conforming mesh.
///
/// `half` must lie in x, y, z >= 0 with its `FaceKind::Plane { axis, high:
/// false }` faces on x_axis = 0 exactly (as the spheroid octant and the
/// block do). Those faces become interior and are dropped; every other
/// boundary face is kept in each image, with its kind mirrored (see
/// [`HexMesh::mirrored`]). Element `g * E + e` (E elements in `half`) is
/// element `e` of the image with the flips of [`flips`]`(g)`, and boundary
/// faces follow the same image order; the first image is `half` itself, with
/// its node numbering.
pub(crate) fn glued_mirror_images(half: &HexMesh) -> HexMesh {
    let planes = cut_planes(half);
    let (n, e) = (half.nodes.len(), half.elements.len());
    let mut index = vec![usize::MAX; 8 * n];
    let mut nodes = Vec::new();
    let mut elements = Vec::with_capacity(8 * e);
    let mut boundary = Vec::new();
    for g in 0..8 {
        let image = half.mirrored(flips(g));
        for (k, p) in image.nodes.iter().enumerate() {
            // Clearing bits gives an image numbered below g, already built.
            let owner = g & !planes[k];
            index[g * n + k] = if owner == g {
                nodes.push(*p);
                nodes.len() - 1
            } else {
                index[owner * n + k]
            };
        }
        let global = &index[g * n..(g + 1) * n];
        elements.extend(image.elements.iter().map(|el| el.map(|k| global[k])));
        boundary.extend(
            image
                .boundary
                .iter()
                .zip(&half.boundary)
                .filter(|(_, f)| !matches!(f.kind, FaceKind::Plane { high: false, .. }))
                .map(|(f, _)| BoundaryFace {
                    nodes: f.nodes.map(|k| global[k]),
                    element: g * e + f.element,
                    kind: f.kind,
                }),
        );
    }
    HexMesh {
        nodes,
        elements,
        boundary,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::OctantSpec;

    #[test]
    fn cut_plane_nodes_are_exactly_on_their_planes_and_no_others_are() {
        for (c, n, grading) in [(1.0, 2, 1.0), (0.2, 5, 3.0), (5.0, 8, 1.0)] {
            let spec = OctantSpec {
                a: 0.05,
                c: 0.05 * c,
                divisions: n,
                grading,
            };
            for half in [
                HexMesh::spheroid_octant(&spec),
                HexMesh::spheroid_octant_exact_volume(&spec),
            ] {
                let half = half.expect("valid spec");
                for (p, bits) in half.nodes.iter().zip(cut_planes(&half)) {
                    for axis in 0..3 {
                        let on = bits >> axis & 1 == 1;
                        assert_eq!(p[axis] == 0.0, on, "{p:?} axis {axis}");
                        // +0.0, never -0.0, so mirror images agree bit for bit.
                        assert!(p[axis].is_sign_positive(), "{p:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn glued_block_is_the_symmetric_box() {
        let div = [2, 3, 1];
        let half = HexMesh::block([0.4, 0.3, 0.1], div).expect("valid block");
        let whole = glued_mirror_images(&half);
        assert_eq!(whole.node_count(), 5 * 7 * 3);
        assert_eq!(whole.element_count(), 8 * 6);
        assert_eq!(&whole.nodes[..half.node_count()], &half.nodes[..]);
        assert_eq!(&whole.elements[..6], &half.elements[..]);
        // Only the outer faces remain, 2 * (4 * 6 + 6 * 2 + 2 * 4).
        assert_eq!(whole.boundary.len(), 88);
        let extent = [0.4, 0.3, 0.1];
        for f in &whole.boundary {
            let FaceKind::Plane { axis, high } = f.kind else {
                panic!("{f:?}");
            };
            let value = if high { extent[axis] } else { -extent[axis] };
            assert!(f.nodes.iter().all(|&k| whole.nodes[k][axis] == value));
            let el = whole.elements[f.element];
            assert!(f.nodes.iter().all(|k| el.contains(k)), "{f:?}");
        }
        assert!((whole.volume() - 8.0 * 0.4 * 0.3 * 0.1).abs() < 1e-15);
    }
}
