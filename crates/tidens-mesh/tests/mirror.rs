//! Mirror images and translations keep volume, quality, orientation and the
//! boundary description consistent.

mod common;

use common::{assert_conforming, assert_watertight, face_normal, octant};
use tidens_mesh::{FaceKind, HexMesh};

const FLIPS: [[bool; 3]; 8] = [
    [false, false, false],
    [true, false, false],
    [false, true, false],
    [false, false, true],
    [true, true, false],
    [true, false, true],
    [false, true, true],
    [true, true, true],
];

fn check_mirror(m: &HexMesh) {
    let vol = m.volume();
    let sj = m.min_scaled_jacobian();
    for flip in FLIPS {
        let r = m.mirrored(flip);
        assert!(
            (r.volume() - vol).abs() < 1e-12 * vol,
            "flip {flip:?}: volume"
        );
        assert!(
            (r.min_scaled_jacobian() - sj).abs() < 1e-12,
            "flip {flip:?}: quality"
        );
        assert!(
            r.min_relative_det() > 0.0,
            "flip {flip:?}: inverted element"
        );
        for e in 0..m.element_count() {
            assert!((r.element_volume(e) - m.element_volume(e)).abs() < 1e-12 * vol);
        }
        assert_eq!(r.boundary.len(), m.boundary.len());
        for (f, g) in m.boundary.iter().zip(&r.boundary) {
            assert_eq!(f.element, g.element);
            match (f.kind, g.kind) {
                (
                    FaceKind::Plane { axis, high },
                    FaceKind::Plane {
                        axis: axis2,
                        high: high2,
                    },
                ) => {
                    assert_eq!(axis, axis2);
                    assert_eq!(
                        high2,
                        high ^ flip[axis],
                        "flip {flip:?}: high flag on axis {axis}"
                    );
                    let nrm = face_normal(&r, g.nodes);
                    let want = if high2 { 1.0 } else { -1.0 };
                    assert!(
                        (nrm[axis] - want).abs() < 1e-12,
                        "flip {flip:?}: normal {nrm:?}"
                    );
                }
                (FaceKind::Curved, FaceKind::Curved) => {}
                (a, b) => panic!("face kind changed from {a:?} to {b:?}"),
            }
        }
        assert_conforming(&r);
        assert_watertight(&r);
    }
}

#[test]
fn mirrored_octant() {
    check_mirror(&octant(0.05, 0.06, 4, 2.0));
}

#[test]
fn mirrored_block() {
    check_mirror(&HexMesh::block([0.4, 0.2, 0.1], [2, 3, 1]).expect("valid block"));
}

#[test]
fn eight_mirrored_octants_make_a_closed_spheroid() {
    // Gluing the 8 images along the cut planes: the Curved faces alone form a
    // closed surface enclosing the whole (discrete) spheroid.
    let m = octant(1.0, 0.7, 5, 1.0);
    let mut area = [0.0; 3];
    let mut flux = 0.0;
    for flip in FLIPS {
        let r = m.mirrored(flip);
        for f in r.boundary.iter().filter(|f| f.kind == FaceKind::Curved) {
            let p = f.nodes.map(|n| r.nodes[n]);
            let a = tidens_mesh::hex::quad_area_vector(&p);
            for k in 0..3 {
                area[k] += a[k];
            }
            flux += tidens_mesh::hex::quad_position_flux(&p);
        }
    }
    assert!(area.iter().all(|v| v.abs() < 1e-12), "{area:?}");
    assert!((flux / 3.0 - 8.0 * m.volume()).abs() < 1e-10);
}

#[test]
fn translation_moves_nodes_only() {
    let m = octant(1.0, 1.0, 3, 1.0);
    let t = m.translated([1.0, -2.0, 0.5]);
    assert_eq!(t.elements, m.elements);
    assert_eq!(t.boundary, m.boundary);
    for (p, q) in m.nodes.iter().zip(&t.nodes) {
        assert_eq!([p[0] + 1.0, p[1] - 2.0, p[2] + 0.5], *q);
    }
    assert!((t.volume() - m.volume()).abs() < 1e-12);
}
