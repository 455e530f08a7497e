//! Reading packings from text; contacts and coordination numbers of
//! lattices; the spheroid gap through the public API.

use tidens_packing::{Boundary, Packing, PackingError, Particle, Wall};

/// Lattice points of a unit cell, one line per sphere of radius `r`.
fn lattice(points: &[[f64; 3]], r: f64) -> String {
    points
        .iter()
        .map(|p| format!("{} {} {} {r}\n", p[0], p[1], p[2]))
        .collect()
}

const SC: [[f64; 3]; 1] = [[0.0, 0.0, 0.0]];
const BCC: [[f64; 3]; 2] = [[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]];
const FCC: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0],
    [0.5, 0.0, 0.5],
    [0.0, 0.5, 0.5],
];

fn read(points: &[[f64; 3]], r: f64) -> Packing {
    Packing::from_text(&lattice(points, r), [1.0; 3], Boundary::Periodic).unwrap()
}

#[test]
fn coordination_numbers_of_sc_bcc_fcc() {
    let sc = read(&SC, 0.5);
    let bcc = read(&BCC, 3f64.sqrt() / 4.0);
    let fcc = read(&FCC, 2f64.sqrt() / 4.0);
    assert_eq!(sc.coordination_number(1e-9), 6.0);
    assert_eq!(bcc.coordination_number(1e-9), 8.0);
    assert_eq!(fcc.coordination_number(1e-9), 12.0);
    // Densities: pi/6, pi sqrt(3)/8, pi sqrt(2)/6.
    let pi = std::f64::consts::PI;
    assert!((sc.rel_density() - pi / 6.0).abs() < 1e-15);
    assert!((bcc.rel_density() - pi * 3f64.sqrt() / 8.0).abs() < 1e-15);
    assert!((fcc.rel_density() - pi * 2f64.sqrt() / 6.0).abs() < 1e-15);
    // Touching, not overlapping.
    for p in [&sc, &bcc, &fcc] {
        assert!(p.max_overlap() < 1e-15);
    }
    // The bcc contacts: sphere 0 with 8 distinct images of sphere 1.
    let contacts = bcc.contacts(1e-9);
    assert_eq!(contacts.len(), 8);
    let mut images: Vec<[i32; 3]> = contacts.iter().map(|c| c.image).collect();
    images.sort();
    images.dedup();
    assert_eq!(images.len(), 8);
    assert!(
        contacts
            .iter()
            .all(|c| (c.i, c.j) == (0, 1) && c.gap.abs() < 1e-15)
    );
    // The sc contacts: the sphere with its own images, once per pair.
    let contacts = sc.contacts(1e-9);
    assert_eq!(contacts.len(), 3);
    assert!(contacts.iter().all(|c| c.i == 0 && c.j == 0));
}

#[test]
fn slightly_shrunk_lattices_have_no_contact() {
    let f = 1.0 - 1e-6;
    assert_eq!(read(&SC, 0.5 * f).coordination_number(1e-9), 0.0);
    assert_eq!(
        read(&BCC, 3f64.sqrt() / 4.0 * f).coordination_number(1e-9),
        0.0
    );
    assert_eq!(
        read(&FCC, 2f64.sqrt() / 4.0 * f).coordination_number(1e-9),
        0.0
    );
    // ... but a tolerance wider than the gap finds them again.
    assert_eq!(
        read(&FCC, 2f64.sqrt() / 4.0 * f).coordination_number(1e-5),
        12.0
    );
}

#[test]
fn a_lattice_between_die_walls_has_wall_contacts() {
    // sc layer of one sphere between walls 1 apart: 4 in-plane contacts,
    // and it touches both walls.
    let p = Packing::from_text("0 0 0.5 0.5", [1.0; 3], Boundary::Die).unwrap();
    assert_eq!(p.coordination_number(1e-9), 4.0);
    let walls = p.wall_contacts(1e-9);
    assert_eq!(walls.len(), 2);
    assert_eq!(walls[0].wall, Wall::Bottom);
    assert_eq!(walls[1].wall, Wall::Top);
    assert_eq!(p.max_overlap(), 0.0);
    // A periodic box has no walls.
    assert!(read(&SC, 0.5).wall_contacts(1.0).is_empty());
}

#[test]
fn text_format_with_commas_comments_defaults_and_wrapping() {
    let text = "# a comment\n\n  0.5, 1.5, 0.5, 0.2  # trailing comment\n\
                -0.5 0.5 0.5 0.1 0.3\n0.5,0.5,1.5 0.1 0.2 0 3 4\n";
    let p = Packing::from_text(text, [2.0; 3], Boundary::Periodic).unwrap();
    assert_eq!(p.particles.len(), 3);
    assert_eq!(p.particles[0].c, 0.2);
    assert_eq!(p.particles[0].axis, [0.0, 0.0, 1.0]);
    // Wrapped into [0, L).
    assert_eq!(p.particles[1].centre, [1.5, 0.5, 0.5]);
    assert_eq!((p.particles[1].a, p.particles[1].c), (0.1, 0.3));
    assert_eq!(p.particles[2].axis, [0.0, 0.6, 0.8]);
}

fn parse_error(text: &str) -> (usize, &'static str, String) {
    match Packing::from_text(text, [10.0; 3], Boundary::Die) {
        Err(e @ PackingError::Parse { line, field, .. }) => (line, field, e.to_string()),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn bad_lines_name_the_line_and_the_field() {
    let ok = "5 5 5 1\n";
    assert_eq!(parse_error(&format!("{ok}5 5 x 1\n")).0, 2);
    assert_eq!(parse_error(&format!("{ok}5 5 x 1\n")).1, "z");
    assert_eq!(
        parse_error(&format!("# c\n{ok}5 5 5 -1\n")),
        (3, "a", "line 3: a: -1 mm: must be > 0".to_string())
    );
    assert_eq!(parse_error(&format!("{ok}5 5 5 1 0\n")).1, "c");
    assert_eq!(parse_error(&format!("{ok}5 5 5 1 1 0 0 0\n")).1, "ax");
    assert_eq!(parse_error(&format!("{ok}5 5 5 1 1 0 0\n")).1, "fields");
    assert_eq!(parse_error(&format!("{ok}5 5 inf 1\n")).1, "z");
    assert_eq!(parse_error(&format!("{ok}5 NaN 5 1\n")).1, "y");
    // No particle at all.
    assert!(matches!(
        Packing::from_text("# nothing\n", [1.0; 3], Boundary::Periodic),
        Err(PackingError::Parameter {
            name: "particles",
            ..
        })
    ));
    // A bad box.
    match Packing::from_text("0 0 0 0.1", [1.0, 0.0, 1.0], Boundary::Periodic) {
        Err(e) => assert_eq!(e.to_string(), "lengths[1] = 0: must be finite and > 0"),
        Ok(_) => panic!("accepted a zero box side"),
    }
}

#[test]
fn overlapping_particles_are_refused_naming_both_lines() {
    let text = "# header\n1 1 1 0.5\n3 3 3 0.5\n1.9 1 1 0.5\n";
    match Packing::from_text(text, [5.0; 3], Boundary::Periodic) {
        Err(PackingError::Overlap {
            first,
            second,
            overlap,
            ..
        }) => {
            assert_eq!((first, second), (2, 4));
            assert!((overlap - 0.1).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
    // Across the periodic boundary.
    let text = "0.2 1 1 0.5\n4.5 1 1 0.5\n";
    assert!(matches!(
        Packing::from_text(text, [5.0; 3], Boundary::Periodic),
        Err(PackingError::Overlap {
            first: 1,
            second: 2,
            ..
        })
    ));
    // A particle overlapping its own image (box narrower than it).
    assert!(matches!(
        Packing::from_text("0.5 0.5 0.5 0.6", [1.0; 3], Boundary::Periodic),
        Err(PackingError::Overlap {
            first: 1,
            second: 1,
            ..
        })
    ));
    // Within 1e-6 of the smaller radius is accepted.
    assert!(
        Packing::from_text(
            "1 1 1 0.5\n2.0000000001 1 1 0.5 0.5\n",
            [5.0; 3],
            Boundary::Periodic
        )
        .is_ok()
    );
    assert!(
        Packing::from_text(
            "1 1 1 0.5\n1.999999 1 1 0.5\n",
            [5.0; 3],
            Boundary::Periodic
        )
        .is_err()
    );
}

#[test]
fn particles_must_lie_between_the_die_walls() {
    match Packing::from_text("1 1 1 0.5\n2 2 0.3 0.5\n", [4.0; 3], Boundary::Die) {
        Err(PackingError::OutsideWalls {
            line,
            wall,
            overlap,
        }) => {
            assert_eq!((line, wall), (2, 0.0));
            assert!((overlap - 0.2).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
    // A prolate spheroid lying flat fits where a standing one does not.
    assert!(Packing::from_text("1 1 0.5 0.5 1 1 0 0", [4.0; 3], Boundary::Die).is_ok());
    assert!(matches!(
        Packing::from_text("1 1 3.5 0.5 1 0 0 1", [4.0; 3], Boundary::Die),
        Err(PackingError::OutsideWalls {
            line: 1,
            wall: 4.0,
            ..
        })
    ));
    // Periodic along z: the same centre is only wrapped.
    assert!(Packing::from_text("1 1 4.2 0.5", [4.0; 3], Boundary::Periodic).is_ok());
}

#[test]
fn gap_of_spheres_and_prolate_spheroids() {
    let sphere = |x: f64, r: f64| Particle {
        centre: [x, 0.3, -0.2],
        a: r,
        c: r,
        axis: [0.0, 0.0, 1.0],
    };
    assert!((sphere(0.0, 0.4).gap(&sphere(1.5, 0.6)) - 0.5).abs() < 1e-15);
    let prolate = |centre: [f64; 3]| Particle {
        centre,
        a: 1.0,
        c: 2.0,
        axis: [0.0, 0.0, 1.0],
    };
    let o = prolate([0.0; 3]);
    // Tip to tip at 2c on z, side by side at 2a on x.
    assert!(o.gap(&prolate([0.0, 0.0, 4.0])).abs() < 1e-13);
    assert!(o.gap(&prolate([2.0, 0.0, 0.0])).abs() < 1e-13);
    assert!((o.gap(&prolate([0.0, 0.0, 3.0])) + 1.0).abs() < 1e-13);
    assert!((o.gap(&prolate([2.5, 0.0, 0.0])) - 0.5).abs() < 1e-13);
    // At 2a on z they overlap deeply, at 2c on x they are apart.
    assert!(o.gap(&prolate([0.0, 0.0, 2.0])) < -1.9);
    assert!(o.gap(&prolate([4.0, 0.0, 0.0])) > 1.9);
    // Two prolate spheroids overlapping by 0.1 along z: max_overlap sees it.
    let p = Packing {
        lengths: [10.0; 3],
        boundary: Boundary::Periodic,
        particles: vec![prolate([5.0, 5.0, 3.0]), prolate([5.0, 5.0, 6.9])],
    };
    assert!((p.max_overlap() - 0.1).abs() < 1e-12);
    // One contact between two particles: one contact per particle.
    assert_eq!(p.contacts(0.0).len(), 1);
    assert_eq!(p.coordination_number(0.0), 1.0);
}
