//! Parameter validation and mesh levels.

use tidens_mesh::{HexMesh, MeshError, OctantSpec, divisions_for_level};

fn spec(a: f64, c: f64, divisions: usize, grading: f64) -> OctantSpec {
    OctantSpec {
        a,
        c,
        divisions,
        grading,
    }
}

fn octant_error(s: OctantSpec) -> MeshError {
    match HexMesh::spheroid_octant(&s) {
        Err(e) => e,
        Ok(_) => panic!("{s:?} accepted"),
    }
}

#[test]
fn bad_octant_parameters_are_rejected_with_a_clear_message() {
    let e = octant_error(spec(-1.0, 1.0, 4, 1.0));
    assert_eq!(e, MeshError::SemiAxisA(-1.0));
    assert_eq!(e.to_string(), "a = -1 mm: must be finite and > 0");

    assert_eq!(
        octant_error(spec(0.0, 1.0, 4, 1.0)),
        MeshError::SemiAxisA(0.0)
    );
    assert!(
        matches!(octant_error(spec(f64::NAN, 1.0, 4, 1.0)), MeshError::SemiAxisA(v) if v.is_nan())
    );

    let e = octant_error(spec(1.0, f64::INFINITY, 4, 1.0));
    assert_eq!(e, MeshError::SemiAxisC(f64::INFINITY));
    assert_eq!(e.to_string(), "c = inf mm: must be finite and > 0");

    let e = octant_error(spec(1.0, 1.0, 1, 1.0));
    assert_eq!(e, MeshError::OctantDivisions(1));
    assert_eq!(e.to_string(), "divisions = 1: must be in 2..=256");
    assert_eq!(
        octant_error(spec(1.0, 1.0, 0, 1.0)),
        MeshError::OctantDivisions(0)
    );
    assert_eq!(
        octant_error(spec(1.0, 1.0, 257, 1.0)),
        MeshError::OctantDivisions(257)
    );

    let e = octant_error(spec(1.0, 1.0, 4, 0.5));
    assert_eq!(e, MeshError::Grading(0.5));
    assert_eq!(e.to_string(), "grading = 0.5: must be finite and >= 1");
    assert!(matches!(
        octant_error(spec(1.0, 1.0, 4, f64::NAN)),
        MeshError::Grading(_)
    ));

    // The first bad parameter is reported.
    assert_eq!(
        octant_error(spec(-1.0, -1.0, 0, 0.0)),
        MeshError::SemiAxisA(-1.0)
    );
    // Boundary values are accepted.
    assert!(HexMesh::spheroid_octant(&spec(1e-3, 1e-3, 2, 1.0)).is_ok());
}

#[test]
fn bad_block_parameters_are_rejected_with_a_clear_message() {
    let e = HexMesh::block([1.0, 0.0, 1.0], [1, 1, 1]).unwrap_err();
    assert_eq!(
        e,
        MeshError::BlockLength {
            axis: 1,
            value: 0.0
        }
    );
    assert_eq!(e.to_string(), "lengths[1] = 0 mm: must be finite and > 0");

    let e = HexMesh::block([1.0, 1.0, 1.0], [1, 1, 0]).unwrap_err();
    assert_eq!(e, MeshError::BlockDivisions { axis: 2, value: 0 });
    assert_eq!(
        e.to_string(),
        "divisions[2] = 0: must be an integer in [1, 1024]"
    );

    assert!(matches!(
        HexMesh::block([f64::NAN, 1.0, 1.0], [1, 1, 1]),
        Err(MeshError::BlockLength { axis: 0, .. })
    ));
    assert!(matches!(
        HexMesh::block([1.0; 3], [2000, 1, 1]),
        Err(MeshError::BlockDivisions {
            axis: 0,
            value: 2000
        })
    ));
}

#[test]
fn levels_map_to_divisions() {
    let got: Vec<usize> = (1..=5)
        .map(|l| divisions_for_level(l).expect("valid level"))
        .collect();
    assert_eq!(got, vec![4, 6, 8, 11, 16]);
    assert_eq!(divisions_for_level(6), Ok(23));
    assert_eq!(divisions_for_level(8), Ok(45));
    // Each level refines the element size by about sqrt(2).
    for l in 1..8 {
        let r = divisions_for_level(l + 1).expect("valid") as f64
            / divisions_for_level(l).expect("valid") as f64;
        assert!((r - 2f64.sqrt()).abs() < 0.1, "level {l}: ratio {r}");
    }
}

#[test]
fn bad_levels_are_rejected() {
    for level in [0, 9, u32::MAX] {
        let e = divisions_for_level(level).unwrap_err();
        assert_eq!(e, MeshError::Level(level));
        assert!(
            e.to_string()
                .starts_with(&format!("level = {level}: must be an integer in [1, 8]"))
        );
    }
}

#[test]
fn bad_explicit_shapes_are_rejected() {
    use tidens_mesh::OctantShape;
    let s = spec(1.0, 1.0, 4, 1.0);
    let shape = |h, inflation, z_stretch| OctantShape {
        h,
        inflation,
        z_stretch,
    };
    let err = |sh: OctantShape| match HexMesh::spheroid_octant_with_shape(&s, &sh) {
        Err(e) => e,
        Ok(_) => panic!("{sh:?} accepted"),
    };
    assert_eq!(err(shape(0.0, 0.5, 1.0)), MeshError::ShapeHalfSize(0.0));
    assert_eq!(
        err(shape(1.0, 0.5, 1.0)).to_string(),
        "h = 1: must be in (0, 1) (unit sphere)"
    );
    assert_eq!(err(shape(0.5, 1.0, 1.0)), MeshError::ShapeInflation(1.0));
    assert_eq!(
        err(shape(0.5, f64::NAN, 1.0)).to_string(),
        "inflation = NaN: must be in [0, 1)"
    );
    assert_eq!(
        err(shape(0.5, 0.5, 2.5)),
        MeshError::ShapeZStretch { value: 2.5, h: 0.5 }
    );
    assert_eq!(
        err(shape(0.5, 0.5, -1.0)).to_string(),
        "z_stretch = -1: must be > 0 with h * z_stretch < 1 (h = 0.5)"
    );
    // The spec is checked first.
    assert!(matches!(
        HexMesh::spheroid_octant_with_shape(&spec(1.0, 1.0, 1, 1.0), &shape(0.0, 0.0, 0.0)),
        Err(MeshError::OctantDivisions(1))
    ));
    // The default layout is valid and used by spheroid_octant.
    let default = OctantShape::for_aspect(1.3);
    assert_eq!(default.validate(), Ok(()));
    let a = HexMesh::spheroid_octant(&spec(1.0, 1.3, 5, 2.0)).expect("valid");
    let b = HexMesh::spheroid_octant_with_shape(&spec(1.0, 1.3, 5, 2.0), &default).expect("valid");
    assert_eq!(a, b);
}

#[test]
fn exact_volume_out_of_reach_is_reported() {
    // With 2 divisions and grading 4 almost every surface node is a special
    // point or held back next to one: the volume cannot be made exact.
    let s = spec(1.0, 1.0, 2, 4.0);
    let e = match HexMesh::spheroid_octant_exact_volume(&s) {
        Err(e) => e,
        Ok(m) => panic!("{s:?} accepted with volume {}", m.volume()),
    };
    let MeshError::VolumeFit {
        volume,
        target,
        tolerance,
    } = e
    else {
        panic!("unexpected error {e:?}");
    };
    assert!((target - std::f64::consts::PI / 6.0).abs() < 1e-15);
    assert!(volume < target * (1.0 - tolerance), "{volume} vs {target}");
    assert!(e.to_string().contains("target"), "{e}");
    // Invalid parameters are rejected before any fitting.
    assert_eq!(
        HexMesh::spheroid_octant_exact_volume(&spec(1.0, 1.0, 1, 1.0)),
        Err(MeshError::OctantDivisions(1))
    );
    assert_eq!(
        HexMesh::spheroid_octant_exact_volume(&spec(1.0, -2.0, 4, 1.0)),
        Err(MeshError::SemiAxisC(-2.0))
    );
    // Without grading 2 divisions still reach it.
    assert!(HexMesh::spheroid_octant_exact_volume(&spec(1.0, 1.0, 2, 1.0)).is_ok());
}
