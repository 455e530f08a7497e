//! The overlap of one slave facet `s` and one master facet `m` on an
//! auxiliary plane, cut into integration cells (Puso and Laursen 2004;
//! Popp et al. 2010).
//!
//! Plane: through the slave centre `c0 = x_s(xi_c)` with the slave's unit
//! normal there, and an in-plane basis,
//!
//! ```text
//! n0 = unit(x_xi x x_eta)(xi_c),   t1 = unit(x_xi(xi_c) - (x_xi . n0) n0),   t2 = n0 x t1
//! P(p) = ((p - c0) . t1, (p - c0) . t2)
//! ```
//!
//! (`t1` is `x_xi`'s unit vector: `x_xi` is normal to `n0` at the centre.)
//!
//! 1. Facing: the pair is skipped unless the master's centre normal points
//!    against `n0`, `n_m(xi_c^m) . n0 < -FACING` (4C's
//!    `4C_mortar_coupling3d.cpp` takes the same 1e-12). A flat master's
//!    projected area is `|n_m . n0|` times its area, so a pair reaches
//!    the threshold with an overlap that goes to zero: the skip does not
//!    make the gaps jump.
//! 2. The slave nodes `P(x_k)` run counter-clockwise in the plane (a
//!    pair whose projected nodes' bounding boxes are apart is skipped); the
//!    master's `P(y_l)` run clockwise (it faces the other way) and are
//!    reversed. Sutherland-Hodgman clips the master polygon against each
//!    edge `(a, b)` of the slave polygon: a point `q` is inside while
//!    `(b - a) x (q - a) >= 0`, and an edge `(p, q)` that crosses is cut at
//!    `p + (q - p) s_p / (s_p - s_q)`, `s = (b - a) x (. - a)`. A projected
//!    slave quad that is not convex is clipped against its two triangles
//!    (split at its reflex corner) separately.
//! 3. Vertices closer than [`MERGE`] (1e-12) times the slave's largest
//!    projected edge to the one kept before them are dropped (round-off
//!    duplicates; a coarser merge makes the gaps jump, see [`MERGE`]); a
//!    polygon of less than [`MIN_AREA`] times the slave's projected area
//!    is no overlap.
//! 4. Cells: with the area and centroid of the polygon `q_0 .. q_{n-1}`,
//!
//!    ```text
//!    A = 1/2 sum_i q_i x q_{i+1},   q_c = sum_i (q_i + q_{i+1}) (q_i x q_{i+1}) / (6 A)
//!    ```
//!
//!    always the `n` triangles `(q_c, q_i, q_{i+1})`. A vertex that
//!    appears (on an edge, or on top of another) brings a cell of zero
//!    area, and `q_c` moves continuously: the cells, and the integrals on
//!    them, change continuously with the nodes, unlike a Delaunay
//!    triangulation (which flips on cocircular polygons) or a fan from a
//!    vertex.
//!
//! Everything is generic over the scalar, so the derivatives of the
//! integrals flow through the plane, the intersection points and the
//! cells (the choices, inside or out, are made on the real parts).
//! Every vertex made is recorded with how it was made ([`Origin`]), so
//! that the same steps can be differentiated by hand
//! (the crate's `mortar::clip_gradient`).

use nalgebra::Vector3;

use crate::mortar::trace::{AdScalar, Facet};

/// A pair is skipped unless `n_m . n0 < -FACING` (module docs).
pub const FACING: f64 = 1e-12;

/// Vertices of a clip polygon closer than this times the slave facet's
/// largest projected edge are merged.
///
/// Dropping a vertex within `MERGE h` of the one before it moves the
/// polygon's boundary by up to that, so the gaps jump by up to about
/// `MERGE` of their scale where it happens (a master edge sweeping over a
/// slave corner at a shallow angle to a slave edge). With 1e-10 (4C's
/// order) a master grid slid over a slave (`tests/mortar_continuity.rs`)
/// showed jumps of up to 4.9e-10 of a node's gap; with 1e-12, 8e-12. The
/// centroid fan needs no merging (a repeated vertex makes a cell of zero
/// area), so this only clears round-off duplicates.
pub const MERGE: f64 = 1e-12;

/// A clip polygon of less than this times the projected slave facet's
/// area is no overlap.
pub const MIN_AREA: f64 = 1e-12;

/// A point of the auxiliary plane.
pub type Point<T> = [T; 2];

/// The auxiliary plane of a slave facet (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AuxPlane<T: AdScalar> {
    /// `c0` \[mm\].
    pub centre: Vector3<T>,
    /// `n0`.
    pub normal: Vector3<T>,
    /// `t1`, `t2`.
    pub basis: [Vector3<T>; 2],
}

impl<T: AdScalar> AuxPlane<T> {
    /// The plane through the centre of `slave`.
    pub fn of(slave: &Facet<T>) -> Self {
        let xi = slave.centre();
        let centre = slave.position(xi);
        let [a, b] = slave.tangents(xi);
        let m = a.cross(&b);
        let normal = m / m.dot(&m).sqrt();
        let t = a - normal * a.dot(&normal);
        let t1 = t / t.dot(&t).sqrt();
        let t2 = normal.cross(&t1);
        Self {
            centre,
            normal,
            basis: [t1, t2],
        }
    }

    /// `P(p)`.
    pub fn project(&self, p: &Vector3<T>) -> Point<T> {
        let d = p - self.centre;
        [d.dot(&self.basis[0]), d.dot(&self.basis[1])]
    }
}

fn sub<T: AdScalar>(a: &Point<T>, b: &Point<T>) -> Point<T> {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross<T: AdScalar>(a: &Point<T>, b: &Point<T>) -> T {
    a[0] * b[1] - a[1] * b[0]
}

/// How a vertex of the overlap was made ([`Clip::made`]): what a
/// derivative by hand retraces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// The projected master node `l`.
    Master(usize),
    /// The edge from made vertex `p` to made vertex `q` cut by the line
    /// through the projected slave nodes `a -> b`: `p + (q - p) s_p / (s_p -
    /// s_q)`, `s = (b - a) x (. - a)`.
    Cut {
        p: usize,
        q: usize,
        a: usize,
        b: usize,
    },
}

/// One convex (or at least simple) piece of the overlap.
#[derive(Clone, Debug, PartialEq)]
pub struct ClipPolygon<T: AdScalar> {
    /// Counter-clockwise vertices.
    pub vertices: Vec<Point<T>>,
    /// The vertices' entries in [`Clip::made`].
    pub made: Vec<usize>,
    /// The area centroid `q_c`.
    pub centroid: Point<T>,
    /// The area `A` \[mm^2\] (in the plane).
    pub area: T,
}

/// The area and the area centroid of the polygon `vertices` (at least
/// three), relative to the first vertex for round-off.
fn area_centroid<T: AdScalar>(vertices: &[Point<T>]) -> (T, Point<T>) {
    let q0 = vertices[0];
    let n = vertices.len();
    let zero = T::from(0.0);
    let (mut area2, mut c) = (zero, [zero; 2]);
    for i in 1..n - 1 {
        let (a, b) = (sub(&vertices[i], &q0), sub(&vertices[i + 1], &q0));
        let w = cross(&a, &b);
        area2 += w;
        c[0] += (a[0] + b[0]) * w;
        c[1] += (a[1] + b[1]) * w;
    }
    let area = area2 * 0.5;
    let centroid = [q0[0] + c[0] / (area * 6.0), q0[1] + c[1] / (area * 6.0)];
    (area, centroid)
}

impl<T: AdScalar> ClipPolygon<T> {
    /// The `n` cells `(q_c, q_i, q_{i+1})`.
    pub fn cells(&self) -> impl Iterator<Item = [Point<T>; 3]> + '_ {
        let n = self.vertices.len();
        (0..n).map(move |i| [self.centroid, self.vertices[i], self.vertices[(i + 1) % n]])
    }
}

/// The overlap of a slave and a master facet on the slave's plane.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip<T: AdScalar> {
    pub plane: AuxPlane<T>,
    /// `P(x_k)` of the slave nodes, in node order.
    pub slave: [Point<T>; 4],
    /// `P(y_l)` of the master nodes, in node order.
    pub master: [Point<T>; 4],
    /// The overlap: one polygon, two if the projected slave quad is not
    /// convex.
    pub pieces: Vec<ClipPolygon<T>>,
    /// Every vertex the clipping made, in order (the master nodes first),
    /// and how.
    pub made: Vec<(Point<T>, Origin)>,
}

/// Whether `master`'s centre normal points against the plane normal `n0`
/// (module docs, step 1).
pub fn facing<T: AdScalar>(plane: &AuxPlane<T>, master: &Facet<T>) -> bool {
    let nm = master.area_normal(master.centre()).map(|v| v.re());
    let n0 = plane.normal.map(|v| v.re());
    nm.dot(&n0) < -FACING * nm.norm()
}

/// The made vertices `subject` clipped by the half-plane left of the
/// directed line through the projected slave nodes `s[a] -> s[b]`; the cuts
/// are appended to `made`.
fn clip_edge<T: AdScalar>(
    made: &mut Vec<(Point<T>, Origin)>,
    subject: &[usize],
    s: &[Point<T>; 4],
    (a, b): (usize, usize),
) -> Vec<usize> {
    let e = sub(&s[b], &s[a]);
    let side = |q: &Point<T>| cross(&e, &sub(q, &s[a]));
    let n = subject.len();
    let mut out = Vec::with_capacity(n + 2);
    for i in 0..n {
        let (ip, iq) = (subject[i], subject[(i + 1) % n]);
        let (p, q) = (made[ip].0, made[iq].0);
        let (sp, sq) = (side(&p), side(&q));
        let (p_in, q_in) = (sp.re() >= 0.0, sq.re() >= 0.0);
        if p_in {
            out.push(ip);
        }
        if p_in != q_in {
            let t = sp / (sp - sq);
            let cut = [p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t];
            made.push((cut, Origin::Cut { p: ip, q: iq, a, b }));
            out.push(made.len() - 1);
        }
    }
    out
}

/// The made vertices `subject` clipped by the convex counter-clockwise
/// polygon of the projected slave nodes `clipper`, near-duplicate vertices
/// merged (within `merge`); None if fewer than three are left.
fn clip_convex<T: AdScalar>(
    made: &mut Vec<(Point<T>, Origin)>,
    subject: &[usize],
    s: &[Point<T>; 4],
    clipper: &[usize],
    merge: f64,
) -> Option<Vec<usize>> {
    let mut poly = subject.to_vec();
    for i in 0..clipper.len() {
        if poly.len() < 3 {
            return None;
        }
        let edge = (clipper[i], clipper[(i + 1) % clipper.len()]);
        poly = clip_edge(made, &poly, s, edge);
    }
    let close = |a: usize, b: usize| {
        let d = sub(&made[a].0, &made[b].0).map(|v| v.re());
        d[0] * d[0] + d[1] * d[1] <= merge * merge
    };
    let mut kept: Vec<usize> = Vec::with_capacity(poly.len());
    for p in poly {
        if kept.last().is_none_or(|&q| !close(q, p)) {
            kept.push(p);
        }
    }
    while kept.len() > 1 && close(kept[kept.len() - 1], kept[0]) {
        kept.pop();
    }
    (kept.len() >= 3).then_some(kept)
}

/// Whether the bounding boxes of the polygons `a` and `b` are apart (then
/// so are the polygons: no clipping needed).
fn apart<T: AdScalar>(a: &[Point<T>], b: &[Point<T>]) -> bool {
    let bounds = |p: &[Point<T>], c: usize| {
        p.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q[c].re()), hi.max(q[c].re()))
            })
    };
    (0..2).any(|c| {
        let ((la, ha), (lb, hb)) = (bounds(a, c), bounds(b, c));
        ha < lb || hb < la
    })
}

/// The overlap of `slave` and `master` (module docs), None if they do not
/// face each other or do not overlap.
pub fn clip<T: AdScalar>(slave: &Facet<T>, master: &Facet<T>) -> Option<Clip<T>> {
    let plane = AuxPlane::of(slave);
    if !facing(&plane, master) {
        return None;
    }
    let ns = slave.node_count();
    let nm = master.node_count();
    let s: [Point<T>; 4] = std::array::from_fn(|k| plane.project(&slave.x[k.min(ns - 1)]));
    let m: [Point<T>; 4] = std::array::from_fn(|l| plane.project(&master.x[l.min(nm - 1)]));
    if apart(&s[..ns], &m[..nm]) {
        return None;
    }
    let mut made: Vec<(Point<T>, Origin)> = (0..nm).map(|l| (m[l], Origin::Master(l))).collect();
    let subject: Vec<usize> = (0..nm).rev().collect();
    let polygon = &s[..ns];
    let size = (0..ns)
        .map(|k| {
            let d = sub(&polygon[(k + 1) % ns], &polygon[k]).map(|v| v.re());
            (d[0] * d[0] + d[1] * d[1]).sqrt()
        })
        .fold(0.0, f64::max);
    let turn = |k: usize| {
        let (a, b, c) = (&polygon[k], &polygon[(k + 1) % ns], &polygon[(k + 2) % ns]);
        cross(&sub(b, a), &sub(c, b)).re()
    };
    // The convex pieces of the slave polygon: itself, or the two triangles
    // of a quad split at its reflex corner.
    let pieces: Vec<Vec<usize>> = match (0..ns).find(|&k| !(turn(k) > 0.0)) {
        Some(k) if ns == 4 => {
            let r = (k + 1) % 4;
            vec![
                vec![r, (r + 1) % 4, (r + 2) % 4],
                vec![(r + 2) % 4, (r + 3) % 4, r],
            ]
        }
        _ => vec![(0..ns).collect()],
    };
    let slave_area = area_centroid(polygon).0.re();
    let mut out = Vec::with_capacity(pieces.len());
    for piece in &pieces {
        if let Some(kept) = clip_convex(&mut made, &subject, &s, piece, MERGE * size) {
            let vertices: Vec<Point<T>> = kept.iter().map(|&i| made[i].0).collect();
            let (area, centroid) = area_centroid(&vertices);
            if area.re() >= MIN_AREA * slave_area {
                out.push(ClipPolygon {
                    vertices,
                    made: kept,
                    centroid,
                    area,
                });
            }
        }
    }
    (!out.is_empty()).then_some(Clip {
        plane,
        slave: s,
        master: m,
        pieces: out,
        made,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facet(trace: crate::mortar::Trace, x: [[f64; 3]; 4]) -> Facet<f64> {
        Facet {
            trace,
            x: x.map(Vector3::from),
        }
    }

    fn unit_square(z: f64) -> Facet<f64> {
        facet(
            crate::mortar::Trace::Quad4,
            [[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]],
        )
    }

    /// A square of half-width `h` centred at `(cx, cy)` at height `z`,
    /// facing down (clockwise seen from above), turned by `angle`.
    fn master(cx: f64, cy: f64, h: f64, angle: f64, z: f64) -> Facet<f64> {
        let (c, s) = (angle.cos(), angle.sin());
        let corner = |u: f64, v: f64| [cx + c * u - s * v, cy + s * u + c * v, z];
        facet(
            crate::mortar::Trace::Quad4,
            [corner(-h, -h), corner(-h, h), corner(h, h), corner(h, -h)],
        )
    }

    #[test]
    fn a_covering_master_leaves_the_whole_slave() {
        let s = unit_square(0.0);
        let c = clip(&s, &master(0.5, 0.5, 2.0, 0.3, 0.1)).unwrap();
        assert_eq!(c.pieces.len(), 1);
        let p = &c.pieces[0];
        assert_eq!(p.vertices.len(), 4);
        assert!((p.area - 1.0).abs() < 1e-15);
        // Centroid at the slave centre, which is the plane's origin.
        assert!(p.centroid[0].abs() < 1e-15 && p.centroid[1].abs() < 1e-15);
        assert_eq!(p.cells().count(), 4);
    }

    #[test]
    fn a_turned_square_on_a_square_is_an_octagon() {
        let s = unit_square(0.0);
        let c = clip(&s, &master(0.5, 0.5, 0.5, std::f64::consts::FRAC_PI_4, 0.2)).unwrap();
        let p = &c.pieces[0];
        assert_eq!(p.vertices.len(), 8);
        // The regular octagon of two unit squares: 2 (sqrt 2 - 1).
        assert!((p.area - 2.0 * (2f64.sqrt() - 1.0)).abs() < 1e-14);
        let cells: f64 = p
            .cells()
            .map(|[a, b, c]| 0.5 * cross(&sub(&b, &a), &sub(&c, &a)))
            .sum();
        assert!((cells - p.area).abs() < 1e-15);
        assert!(
            p.cells()
                .all(|[a, b, c]| cross(&sub(&b, &a), &sub(&c, &a)) > 0.0)
        );
    }

    #[test]
    fn facets_that_do_not_face_each_other_or_do_not_meet_give_nothing() {
        let s = unit_square(0.0);
        // Same orientation as the slave: not facing.
        assert!(clip(&s, &unit_square(0.1)).is_none());
        // Facing but apart.
        assert!(clip(&s, &master(3.0, 0.5, 0.5, 0.0, 0.1)).is_none());
        // Touching along an edge only: no area.
        assert!(clip(&s, &master(1.5, 0.5, 0.5, 0.0, 0.1)).is_none());
    }

    #[test]
    fn a_non_convex_slave_quad_is_clipped_by_its_two_triangles() {
        // A dart: corner 3 is reflex.
        let s = facet(
            crate::mortar::Trace::Quad4,
            [
                [0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [2.0, 2.0, 0.0],
                [1.5, 0.5, 0.0],
            ],
        );
        let c = clip(&s, &master(1.0, 1.0, 3.0, 0.1, 0.5)).unwrap();
        assert_eq!(c.pieces.len(), 2);
        let area: f64 = c.pieces.iter().map(|p| p.area).sum();
        // Shoelace of the dart: 0.5 * |(2*2 - 0) + (2*0.5 - 2*1.5) + 0| = 1.
        assert!((area - 1.0).abs() < 1e-14, "{area}");
    }

    #[test]
    fn derivatives_flow_through_the_intersections() {
        use nalgebra::SVector;
        use num_dual::{DualNum, DualSVec64};
        // The area of the octagon against the master's turn angle.
        let area = |angle: f64| {
            clip(&unit_square(0.0), &master(0.5, 0.5, 0.5, angle, 0.2))
                .unwrap()
                .pieces[0]
                .area
        };
        let a0 = 0.6;
        let (_, g) = num_dual::gradient(
            |v: SVector<DualSVec64<1>, 1>| {
                let (c, s) = (v[0].cos(), v[0].sin());
                let corner = |u: f64, w: f64| {
                    Vector3::new(
                        c * u - s * w + 0.5,
                        s * u + c * w + 0.5,
                        DualSVec64::from(0.2),
                    )
                };
                let m = Facet {
                    trace: crate::mortar::Trace::Quad4,
                    x: [
                        corner(-0.5, -0.5),
                        corner(-0.5, 0.5),
                        corner(0.5, 0.5),
                        corner(0.5, -0.5),
                    ],
                };
                let s = unit_square(0.0).map(|p| p.map(DualSVec64::from));
                clip(&s, &m).unwrap().pieces[0].area
            },
            &SVector::from([a0]),
        );
        let h = 1e-6;
        let fd = (area(a0 + h) - area(a0 - h)) / (2.0 * h);
        assert!((fd - g[0]).abs() < 1e-8, "{fd} {}", g[0]);
    }
}
