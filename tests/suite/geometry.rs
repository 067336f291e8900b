//! Block geometry: mass properties, rounding, BLOCK/DELETE, and SPLIT (SL-85-1 Appendix A ¶13–14).

use approx::assert_relative_eq;
use blockdem::scenes::run_deck_on;
use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::model::build::GeometryError;
use blockdem::udec::model::geometry::{corner_rounding, is_simple_polygon, point_in_polygon, point_segment_distance, polygon_properties, rotate, signed_area};
use blockdem::udec::model::split::{split_block_along, split_line};
use blockdem::udec::model::{Contact, ContactKind, Link, Model};
use proptest::prelude::*;

use crate::common;
use common::Rng;

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<[f64; 2]> {
    vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
}

fn valid(m: &Model) {
    if let Err(e) = m.validate() {
        panic!("model invalid: {e}");
    }
}

fn total_area(m: &Model) -> f64 {
    m.blocks.iter().map(|b| b.area).sum()
}

/// Bounding box (x0, y0, x1, y1) of block b's world corners.
fn bbox(m: &Model, b: usize) -> [f64; 4] {
    m.corner_positions(b).iter().fold([f64::MAX, f64::MAX, f64::MIN, f64::MIN], |a, p| [a[0].min(p[0]), a[1].min(p[1]), a[2].max(p[0]), a[3].max(p[1])])
}

/// Block from a single rectangle with material density 1 so mass = area.
fn model_with(outline: &[[f64; 2]]) -> Model {
    let mut m = Model::default();
    m.materials[0].block.density = 1.0;
    m.add_block(outline, 1, 1, None).unwrap();
    valid(&m);
    m
}

fn contact(block1: u32, corner: u32, block2: u32) -> Contact {
    Contact {
        id: 7,
        block1,
        corner,
        block2,
        feature: 1,
        kind: ContactKind::CornerEdge,
        material: 1,
        constitutive: 1,
        bonded: true,
        point: [0.0, 0.0],
        normal: [0.0, 1.0],
        gap: 0.0,
        normal_force: 1.0,
        shear_force: 0.0,
        shear_displacement: 0.0,
        force: [0.0, 1.0],
        slip_work: 0.0,
        dashpot_work: 0.0,
        dashpot_velocity: [0.0, 0.0],
        joint_length: 0.0,
    }
}

// ---------------------------------------------------------------- mass properties

#[test]
fn rectangle_properties_near_and_far_from_origin() {
    for (x0, y0) in [(0.0, 0.0), (1.0e4, -2.0e4), (-3.0e6, 1.0e6)] {
        let (w, h) = (4.0, 2.5);
        let p = polygon_properties(&rect(x0, y0, x0 + w, y0 + h));
        let a = w * h;
        assert_relative_eq!(p.area, a, max_relative = 1e-12);
        assert_relative_eq!(p.centroid[0], x0 + w / 2.0, max_relative = 1e-14);
        assert_relative_eq!(p.centroid[1], y0 + h / 2.0, max_relative = 1e-14);
        assert_relative_eq!(p.polar_moment, a * (w * w + h * h) / 12.0, max_relative = 1e-10);
    }
}

#[test]
fn triangle_properties() {
    // Right triangle with legs a, b: J about the centroid = A (a² + b²) / 18.
    let (a, b) = (3.0, 5.0);
    for (x0, y0) in [(0.0, 0.0), (1.0e4, 1.0e4)] {
        let p = polygon_properties(&[[x0, y0], [x0 + a, y0], [x0, y0 + b]]);
        let area = a * b / 2.0;
        assert_relative_eq!(p.area, area, max_relative = 1e-12);
        assert_relative_eq!(p.centroid[0], x0 + a / 3.0, max_relative = 1e-14);
        assert_relative_eq!(p.centroid[1], y0 + b / 3.0, max_relative = 1e-14);
        assert_relative_eq!(p.polar_moment, area * (a * a + b * b) / 18.0, max_relative = 1e-9);
    }
}

#[test]
fn l_shape_properties_by_composition() {
    // L = [0,4]×[0,1] ∪ [0,1]×[1,3]; combine the two rectangles with the parallel-axis theorem.
    let x0 = 1.0e4;
    let l = [[x0, 0.0], [x0 + 4.0, 0.0], [x0 + 4.0, 1.0], [x0 + 1.0, 1.0], [x0 + 1.0, 3.0], [x0, 3.0]];
    let parts = [(4.0, 1.0, [x0 + 2.0, 0.5]), (1.0, 2.0, [x0 + 0.5, 2.0])];
    let area: f64 = parts.iter().map(|p| p.0 * p.1).sum();
    let cx = parts.iter().map(|p| p.0 * p.1 * p.2[0]).sum::<f64>() / area;
    let cy = parts.iter().map(|p| p.0 * p.1 * p.2[1]).sum::<f64>() / area;
    let j: f64 = parts
        .iter()
        .map(|&(w, h, c)| {
            let a = w * h;
            a * (w * w + h * h) / 12.0 + a * ((c[0] - cx).powi(2) + (c[1] - cy).powi(2))
        })
        .sum();
    let p = polygon_properties(&l);
    assert_relative_eq!(p.area, area, max_relative = 1e-12);
    assert_relative_eq!(p.centroid[0], cx, max_relative = 1e-14);
    assert_relative_eq!(p.centroid[1], cy, max_relative = 1e-12);
    assert_relative_eq!(p.polar_moment, j, max_relative = 1e-9);
    // Clockwise order: negative area, same centroid and J.
    let mut cw = l.to_vec();
    cw.reverse();
    let q = polygon_properties(&cw);
    assert_relative_eq!(q.area, -area, max_relative = 1e-12);
    assert_relative_eq!(q.polar_moment, j, max_relative = 1e-9);
}

#[test]
fn small_helpers() {
    let sq = rect(0.0, 0.0, 1.0, 1.0);
    assert_relative_eq!(signed_area(&sq), 1.0);
    assert!(point_in_polygon([0.5, 0.5], &sq));
    assert!(!point_in_polygon([1.5, 0.5], &sq));
    let r = rotate([1.0, 0.0], std::f64::consts::FRAC_PI_2);
    assert_relative_eq!(r[0], 0.0, epsilon = 1e-15);
    assert_relative_eq!(r[1], 1.0);
    assert!(is_simple_polygon(&sq));
    assert!(!is_simple_polygon(&[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]));
    assert!(!is_simple_polygon(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]));
}

// ---------------------------------------------------------------- BLOCK

#[test]
fn clockwise_deck_outline_is_stored_counter_clockwise_with_tags() {
    let mut m = Model::default();
    m.materials[0].block.density = 2000.0;
    // The deck's clockwise order, tag i on the edge from corner i to corner i + 1 as given.
    let given = [[0.0, 0.0], [0.0, 30.0], [40.0, 30.0], [40.0, 0.0]];
    let tags = [(1, 11), (2, 12), (3, 13), (4, 14)];
    let b = m.add_block(&given, 1, 1, Some(&tags)).unwrap();
    valid(&m);
    let blk = &m.blocks[b];
    assert_eq!(blk.id, 1);
    assert_eq!(m.next_block_id, 2);
    assert_relative_eq!(blk.area, 1200.0);
    assert_relative_eq!(blk.mass, 2000.0 * 1200.0);
    assert_relative_eq!(blk.inertia, 2000.0 * 1200.0 * (1600.0 + 900.0) / 12.0, max_relative = 1e-12);
    assert_eq!(blk.centroid, [20.0, 15.0]);
    assert_relative_eq!(blk.radius, 25.0);
    let local: Vec<_> = m.block_corners(b).iter().map(|c| c.local).collect();
    assert!(signed_area(&local) > 0.0);
    // Every stored edge carries the tag of the same (undirected) given edge.
    let pos = m.corner_positions(b);
    for (k, c) in m.block_corners(b).iter().enumerate() {
        let (p, q) = (pos[k], pos[(k + 1) % 4]);
        let i = (0..4).find(|&i| (given[i] == q && given[(i + 1) % 4] == p) || (given[i] == p && given[(i + 1) % 4] == q)).unwrap();
        assert_eq!((c.edge_material, c.edge_constitutive), tags[i]);
    }
}

#[test]
fn bad_outlines_are_rejected() {
    let mut m = Model::default();
    assert!(matches!(m.add_block(&[[0.0, 0.0], [1.0, 0.0]], 1, 1, None), Err(GeometryError::TooFewCorners { count: 2 })));
    let bowtie = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
    assert!(matches!(m.add_block(&bowtie, 1, 1, None), Err(GeometryError::SelfIntersecting)));
    let line = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
    assert!(m.add_block(&line, 1, 1, None).is_err());
    let nan = [[0.0, 0.0], [1.0, f64::NAN], [0.0, 1.0]];
    assert!(matches!(m.add_block(&nan, 1, 1, None), Err(GeometryError::NonFinite { index: 1 })));
    let rep = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    assert!(matches!(m.add_block(&rep, 1, 1, None), Err(GeometryError::RepeatedCorner { index: 1, .. })));
    let e = m.add_block(&bowtie, 1, 1, None).unwrap_err();
    assert!(e.to_string().contains("crosses"), "{e}");
    assert!(m.blocks.is_empty() && m.corners.is_empty());
}

// ---------------------------------------------------------------- rounding

#[test]
fn rounding_of_right_and_sixty_degree_corners() {
    let d = 0.5;
    let r = corner_rounding(&rect(0.0, 0.0, 10.0, 10.0), d);
    assert_relative_eq!(r[0].round, d);
    assert_relative_eq!(r[0].radius, d, max_relative = 1e-14); // round · tan 45°
    assert_relative_eq!(r[0].circle[0], 0.5, max_relative = 1e-14);
    assert_relative_eq!(r[0].circle[1], 0.5, max_relative = 1e-14);
    assert_relative_eq!(r[2].circle[0], 9.5, max_relative = 1e-14);

    // Equilateral triangle: α = 60°, radius = round tan 30°, centre round / cos 30° along the bisector.
    let tri = [[0.0, 0.0], [10.0, 0.0], [5.0, 10.0 * 3f64.sqrt() / 2.0]];
    let r = corner_rounding(&tri, d);
    let dist = d / (30f64).to_radians().cos();
    assert_relative_eq!(r[0].radius, d * (30f64).to_radians().tan(), max_relative = 1e-12);
    assert_relative_eq!(r[0].circle[0], dist * (30f64).to_radians().cos(), max_relative = 1e-12);
    assert_relative_eq!(r[0].circle[1], dist * (30f64).to_radians().sin(), max_relative = 1e-12);
    // The circle is tangent to both edges: its distance to each equals the radius.
    // Every circle is tangent to both adjoining edges, `round` away from the corner: the foot of the
    // perpendicular from the centre onto each edge line is at distance `round` from the corner, and
    // the centre's distance to the line is the radius.
    for (i, c) in r.iter().enumerate() {
        let p = tri[i];
        for q in [tri[(i + 1) % 3], tri[(i + 2) % 3]] {
            let e = [q[0] - p[0], q[1] - p[1]];
            let len = e[0].hypot(e[1]);
            let w = [c.circle[0] - p[0], c.circle[1] - p[1]];
            let along = (w[0] * e[0] + w[1] * e[1]) / len;
            let off = (w[0] * e[1] - w[1] * e[0]).abs() / len;
            assert_relative_eq!(along, c.round, max_relative = 1e-12);
            assert_relative_eq!(off, c.radius, max_relative = 1e-12);
        }
    }
}

#[test]
fn rounding_on_short_edge_reflex_and_straight_corners() {
    let r = corner_rounding(&rect(0.0, 0.0, 10.0, 0.6), 0.5);
    for c in &r {
        assert_relative_eq!(c.round, 0.3, max_relative = 1e-14);
        assert_relative_eq!(c.radius, 0.3, max_relative = 1e-12);
    }
    // L-shape: the re-entrant corner (1,1) has no rounding.
    let l = [[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [1.0, 1.0], [1.0, 3.0], [0.0, 3.0]];
    let r = corner_rounding(&l, 0.2);
    assert_eq!(r[3].radius, 0.0);
    assert_eq!(r[3].round, 0.0);
    assert_eq!(r[3].circle, [1.0, 1.0]);
    // A 0.5° bend is treated as straight; a 5° one gets a large but finite arc: at d = 0.1 a
    // radius of 2.3 (at d = 0.5 it would be 11.5, more than this block is high, and is lowered
    // to fit: see the thin-strip test below).
    for (deg, straight) in [(0.5f64, true), (5.0, false)] {
        let t = deg.to_radians();
        let poly = [[0.0, 0.0], [10.0, 0.0], [20.0, 10.0 * t.tan()], [10.0, 10.0]];
        let r = corner_rounding(&poly, 0.1);
        assert_eq!(r[1].radius == 0.0, straight, "{deg}°");
        if !straight {
            assert_relative_eq!(r[1].radius, 0.1 / (t / 2.0).tan(), max_relative = 1e-9);
        }
    }
}

/// The least clearance `distance(centre, edge) − radius` of corner i's circle from the edges of
/// `pts` other than its own two (positive: the circle keeps clear of them).
fn clearance(pts: &[[f64; 2]], i: usize, centre: [f64; 2], radius: f64) -> f64 {
    let n = pts.len();
    (0..n).filter(|&j| j != i && j != (i + n - 1) % n).map(|j| point_segment_distance(centre, pts[j], pts[(j + 1) % n]) - radius).fold(f64::INFINITY, f64::min)
}

#[test]
fn an_obtuse_corner_in_a_thin_strip_is_rounded_inside_its_block() {
    // A strip 1 m wide cut off at a 162° corner (0, 5), as a SPLIT at 18° to the strip's side
    // leaves it. At d = 0.1 the circle tangent to both edges 0.1 from the corner would have radius
    // 0.1 tan 81° ≈ 0.63 and reach to x ≈ 1.26, through the strip's far side x = 1. Its centre
    // lies at x = round · tan 81° (the bisector is 9° above the normal of the side x = 0), so the
    // largest circle that fits touches x = 1: radius ½, round ½ / tan 81°.
    let t72 = 72f64.to_radians().tan();
    let strip = [[0.0, 5.0], [1.0, 5.0 - t72], [1.0, 10.0], [0.0, 10.0]];
    let r = corner_rounding(&strip, 0.1);
    let t81 = 81f64.to_radians().tan();
    assert!(0.1 * t81 > 0.6, "the circle of the full rounding would not fit: radius {}", 0.1 * t81);
    assert_relative_eq!(r[0].radius, 0.5, max_relative = 1e-12);
    assert_relative_eq!(r[0].round, 0.5 / t81, max_relative = 1e-12);
    assert_relative_eq!(r[0].circle[0] + r[0].radius, 1.0, max_relative = 1e-12);
    assert!(point_in_polygon(r[0].circle, &strip));
    assert!(clearance(&strip, 0, r[0].circle, r[0].radius) > -1e-12, "{:?}", r[0]);
    // Still tangent to both of its own edges, round from the corner.
    let dir = [1.0 / (1.0 + t72 * t72).sqrt(), -t72 / (1.0 + t72 * t72).sqrt()];
    let w = [r[0].circle[0] - strip[0][0], r[0].circle[1] - strip[0][1]];
    assert_relative_eq!(w[1], r[0].round, max_relative = 1e-12);
    assert_relative_eq!(w[0] * dir[0] + w[1] * dir[1], r[0].round, max_relative = 1e-12);
    assert_relative_eq!((w[0] * dir[1] - w[1] * dir[0]).abs(), r[0].radius, max_relative = 1e-12);
    // The other corners fit with the full rounding and keep it.
    for c in &r[1..] {
        assert_eq!(c.round, 0.1);
    }
    // A rectangle exactly 2·round wide keeps its full rounding, circles touching the far side.
    // (Their radius, 0.5 tan 45°, is 0.5 + 1 ulp: a reach past the far side by round-off only.)
    let r = corner_rounding(&rect(0.0, 0.0, 10.0, 1.0), 0.5);
    assert!(r.iter().all(|c| c.round == 0.5 && (c.radius - 0.5).abs() < 1e-15), "{r:?}");
}

#[test]
fn model_rounding_follows_set_round_and_rotation() {
    let mut m = model_with(&rect(0.0, 0.0, 4.0, 2.0));
    assert_relative_eq!(m.corners[0].round, 0.5);
    m.set_round(0.2);
    assert_eq!(m.tol.round, 0.2);
    assert!(m.corners.iter().all(|c| c.round == 0.2 && (c.radius - 0.2).abs() < 1e-12));
    valid(&m);
    m.blocks[0].rotation = std::f64::consts::FRAC_PI_2;
    m.blocks[0].centroid = [10.0, 10.0];
    m.update_corner_positions(0);
    // Local corner (−2,−1) turned by 90° → (1,−2).
    let c0 = m.corners[0];
    assert_relative_eq!(c0.position[0], 11.0, max_relative = 1e-12);
    assert_relative_eq!(c0.position[1], 8.0, max_relative = 1e-12);
    assert_relative_eq!(c0.circle[0], 11.0 - 0.2, max_relative = 1e-12);
    assert_relative_eq!(c0.circle[1], 8.0 + 0.2, max_relative = 1e-12);
}

#[test]
fn mass_properties_follow_density_changes() {
    let mut m = Model::default();
    m.add_block(&rect(0.0, 0.0, 2.0, 1.0), 3, 1, None).unwrap();
    assert_eq!(m.blocks[0].mass, 0.0);
    m.materials[2].block.density = 10.0;
    m.recompute_mass_properties();
    assert_relative_eq!(m.blocks[0].mass, 20.0);
    assert_relative_eq!(m.blocks[0].inertia, 10.0 * 2.0 * 5.0 / 12.0, max_relative = 1e-12);
    valid(&m);
}

// ---------------------------------------------------------------- SPLIT

#[test]
fn diagonal_split_through_corners_gives_two_triangles() {
    let mut m = model_with(&rect(0.0, 0.0, 10.0, 10.0));
    let out = split_line(&mut m, [-1.0, -1.0], [11.0, 11.0], None, None);
    valid(&m);
    assert_eq!(out.split, vec![1]);
    assert!(out.rejected.is_empty());
    assert_eq!(m.blocks.len(), 2);
    for b in 0..2 {
        assert_eq!(m.blocks[b].corner_count, 3);
        assert_relative_eq!(m.blocks[b].area, 50.0, max_relative = 1e-12);
    }
    assert_eq!(m.blocks[0].id, 1);
    assert_eq!(m.blocks[1].id, 2);
}

#[test]
fn crossing_near_a_corner_is_diverted_through_it() {
    let mut m = model_with(&rect(0.0, 0.0, 10.0, 10.0));
    // Crosses the bottom at x = 0.3 and the top at x = 9.8, both within d = 0.5 of a corner.
    let out = split_line(&mut m, [0.3 - 0.95, -1.0], [9.8 + 0.95, 11.0], None, None);
    valid(&m);
    assert_eq!(out.split.len(), 1);
    let corners = rect(0.0, 0.0, 10.0, 10.0);
    for b in 0..2 {
        assert_eq!(m.blocks[b].corner_count, 3);
        assert_relative_eq!(m.blocks[b].area, 50.0, max_relative = 1e-12);
        assert!(m.corner_positions(b).iter().all(|p| corners.iter().any(|c| (p[0] - c[0]).abs() < 1e-9 && (p[1] - c[1]).abs() < 1e-9)));
    }
    // Beyond d the crossing makes a new corner.
    let mut m = model_with(&rect(0.0, 0.0, 10.0, 10.0));
    split_line(&mut m, [0.7, -1.0], [0.7, 11.0], None, None);
    valid(&m);
    assert_eq!(m.blocks.len(), 2);
    assert_relative_eq!(total_area(&m), 100.0, max_relative = 1e-12);
}

#[test]
fn split_along_an_existing_edge_is_rejected() {
    let mut m = model_with(&rect(0.0, 0.0, 10.0, 10.0));
    // Exactly along the bottom edge.
    let out = split_line(&mut m, [-1.0, 0.0], [11.0, 0.0], None, None);
    assert!(out.split.is_empty());
    assert_eq!(out.rejected.len(), 1);
    assert!(out.rejected[0].1.contains("existing edge"), "{}", out.rejected[0].1);
    // Within d of the left edge: both crossings are diverted onto the edge's corners.
    let out = split_line(&mut m, [0.3, -1.0], [0.3, 11.0], None, None);
    assert_eq!(out.rejected.len(), 1);
    assert!(out.rejected[0].1.contains("existing edge"), "{}", out.rejected[0].1);
    assert_eq!(m.blocks.len(), 1);
    // Splitting twice along the same line: the second one lies on both pieces' common edge.
    split_line(&mut m, [-1.0, 5.0], [11.0, 5.0], None, None);
    let out = split_line(&mut m, [-1.0, 5.0], [11.0, 5.0], None, None);
    assert!(out.split.is_empty());
    assert_eq!(out.rejected.len(), 2);
    assert_eq!(m.blocks.len(), 2);
    valid(&m);
}

#[test]
fn segment_ending_inside_a_block_does_not_split_it() {
    let mut m = model_with(&rect(0.0, 0.0, 10.0, 10.0));
    let out = split_line(&mut m, [-1.0, 5.0], [5.0, 5.0], None, None);
    assert!(out.split.is_empty() && out.rejected.is_empty());
    let out = split_line(&mut m, [3.0, 5.0], [7.0, 5.0], None, None);
    assert!(out.split.is_empty() && out.rejected.is_empty());
    let out = split_line(&mut m, [20.0, 5.0], [30.0, 5.0], None, None);
    assert!(out.split.is_empty() && out.rejected.is_empty());
    assert_eq!(m.blocks.len(), 1);
    valid(&m);
}

#[test]
fn re_entrant_split_of_a_u_shape_gives_three_pieces() {
    let u = [[0.0, 0.0], [30.0, 0.0], [30.0, 20.0], [20.0, 20.0], [20.0, 10.0], [10.0, 10.0], [10.0, 20.0], [0.0, 20.0]];
    let mut m = model_with(&u);
    let area = m.blocks[0].area;
    let out = split_line(&mut m, [31.0, 15.0], [-1.0, 15.0], Some(2), Some(3));
    valid(&m);
    assert_eq!(out.split, vec![1]);
    assert_eq!(m.blocks.len(), 3);
    assert_relative_eq!(total_area(&m), area, max_relative = 1e-12);
    let mut boxes: Vec<[f64; 4]> = (0..3).map(|b| bbox(&m, b)).collect();
    boxes.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(boxes, vec![[0.0, 0.0, 30.0, 15.0], [0.0, 15.0, 10.0, 20.0], [20.0, 15.0, 30.0, 20.0]]);
    // Ids: the first piece keeps the parent's.
    let mut ids: Vec<u32> = m.blocks.iter().map(|b| b.id).collect();
    ids.sort();
    assert_eq!(ids, vec![1, 2, 3]);
    // The four new joint edges (two per chord) carry MAT/CONS; all others keep tag 0.
    let joints = m.corners.iter().filter(|c| (c.edge_material, c.edge_constitutive) == (2, 3)).count();
    let plain = m.corners.iter().filter(|c| (c.edge_material, c.edge_constitutive) == (0, 0)).count();
    assert_eq!(joints, 4);
    assert_eq!(plain, m.corners.len() - 4);
    // Only part of the U in the segment's reach: the left arm alone is cut.
    let mut m = model_with(&u);
    let out = split_line(&mut m, [15.0, 15.0], [-1.0, 15.0], None, None);
    assert_eq!(out.split.len(), 1);
    assert_eq!(m.blocks.len(), 2);
    valid(&m);
}

#[test]
fn udec_sample_1_carving() {
    let mut m = Model::default();
    m.add_block(&[[0.0, 0.0], [0.0, 30.0], [40.0, 30.0], [40.0, 0.0]], 1, 1, None).unwrap();
    for (a, b) in [([-1.0, 10.0], [41.0, 10.0]), ([-1.0, 20.0], [41.0, 20.0]), ([-1.0, 5.0], [41.0, 5.0])] {
        let out = split_line(&mut m, a, b, None, None);
        assert_eq!(out.split.len(), 1);
        valid(&m);
    }
    assert_eq!(m.blocks.len(), 4);
    // Starts inside [0,40]×[0,5] and ends inside [0,40]×[10,20]: only [0,40]×[5,10] is cut.
    let out = split_line(&mut m, [25.0, 2.5], [25.0, 12.5], None, None);
    assert_eq!(out.split.len(), 1);
    assert!(out.rejected.is_empty());
    assert_eq!(m.blocks.len(), 5);
    let gone = m.blocks_in_range(25.0, 40.0, 5.0, 10.0);
    assert_eq!(gone.len(), 1);
    m.remove_blocks(&gone);
    valid(&m);
    let out = split_line(&mut m, [30.0, 15.0], [30.0, 40.0], None, None);
    assert_eq!(out.split.len(), 1);
    assert_eq!(m.blocks.len(), 5);
    let gone = m.blocks_in_range(30.0, 40.0, 20.0, 30.0);
    assert_eq!(gone.len(), 1);
    m.remove_blocks(&gone);
    valid(&m);
    // Base, the support under the left part, the beam that will crack, and the weight on top.
    let mut boxes: Vec<[f64; 4]> = (0..m.blocks.len()).map(|b| bbox(&m, b)).collect();
    boxes.sort_by(|a, b| (a[1], a[0]).partial_cmp(&(b[1], b[0])).unwrap());
    assert_eq!(boxes, vec![[0.0, 0.0, 40.0, 5.0], [0.0, 5.0, 25.0, 10.0], [0.0, 10.0, 40.0, 20.0], [0.0, 20.0, 30.0, 30.0]]);
    assert!(m.blocks.iter().all(|b| b.corner_count == 4));
    assert_relative_eq!(total_area(&m), 200.0 + 125.0 + 400.0 + 300.0, max_relative = 1e-12);
}

#[test]
fn delete_keeps_ids_and_remaps_contacts_and_links() {
    let mut m = model_with(&rect(0.0, 0.0, 30.0, 10.0));
    split_line(&mut m, [10.0, -1.0], [10.0, 11.0], None, None);
    split_line(&mut m, [20.0, -1.0], [20.0, 11.0], None, None);
    valid(&m);
    assert_eq!(m.blocks.len(), 3);
    let by_x = |m: &Model, x: f64| m.blocks.iter().position(|b| (b.centroid[0] - x).abs() < 1e-9).unwrap();
    let (left, mid, right) = (by_x(&m, 5.0), by_x(&m, 15.0), by_x(&m, 25.0));
    let (mid_id, right_id) = (m.blocks[mid].id, m.blocks[right].id);
    // A contact between the middle and right blocks (corner 2 of the middle block), one involving the
    // left block, and links both ways.
    let corner = m.blocks[mid].corner_start + 2;
    let corner_pos = m.corners[corner as usize].position;
    m.contacts.push(contact(mid as u32, corner, right as u32));
    m.contacts.push(contact(left as u32, m.blocks[left].corner_start, mid as u32));
    m.links.push(Link { flying: right as u32, anchor: mid as u32 });
    m.links.push(Link { flying: left as u32, anchor: right as u32 });
    valid(&m);
    let gone = m.blocks_in_range(0.0, 10.0, 0.0, 10.0);
    assert_eq!(gone, vec![left]);
    m.remove_blocks(&gone);
    valid(&m);
    assert_eq!(m.blocks.len(), 2);
    assert_eq!(m.contacts.len(), 1);
    assert_eq!(m.links.len(), 1);
    let c = m.contacts[0];
    assert_eq!(m.blocks[c.block1 as usize].id, mid_id);
    assert_eq!(m.blocks[c.block2 as usize].id, right_id);
    assert_eq!(m.corners[c.corner as usize].position, corner_pos);
    assert_eq!(m.corners[c.corner as usize].block, c.block1);
    assert_eq!(m.blocks[m.links[0].flying as usize].id, right_id);
    assert_eq!(m.blocks[m.links[0].anchor as usize].id, mid_id);
    assert!(m.blocks_in_range(0.0, 10.0, 0.0, 10.0).is_empty());
}

#[test]
fn spinning_block_split_keeps_rigid_motion_and_shares_load() {
    let mut m = model_with(&rect(0.0, 0.0, 10.0, 10.0));
    {
        let b = &mut m.blocks[0];
        b.velocity = [1.0, 2.0];
        b.angular_velocity = 0.5;
        b.load = [10.0, -20.0];
        b.fixed = true;
    }
    m.contacts.push(contact(0, 0, 0)); // dropped with the parent (and would fail validate)
    m.contacts.clear();
    split_line(&mut m, [4.0, -1.0], [4.0, 11.0], Some(1), Some(2));
    valid(&m);
    assert_eq!(m.blocks.len(), 2);
    for b in &m.blocks {
        let r = [b.centroid[0] - 5.0, b.centroid[1] - 5.0];
        assert_relative_eq!(b.velocity[0], 1.0 - 0.5 * r[1], epsilon = 1e-12);
        assert_relative_eq!(b.velocity[1], 2.0 + 0.5 * r[0], epsilon = 1e-12);
        assert_eq!(b.angular_velocity, 0.5);
        assert_relative_eq!(b.load[0], 10.0 * b.area / 100.0, max_relative = 1e-12);
        assert_relative_eq!(b.load[1], -20.0 * b.area / 100.0, max_relative = 1e-12);
        assert!(b.fixed);
        assert_eq!(b.rotation, 0.0);
    }
    // Momentum is conserved: Σ m v = M v_parent, Σ (I ω + m r × v) = I_parent ω.
    let px: f64 = m.blocks.iter().map(|b| b.mass * b.velocity[0]).sum();
    assert_relative_eq!(px, 100.0, max_relative = 1e-12);
    let l: f64 = m
        .blocks
        .iter()
        .map(|b| {
            let r = [b.centroid[0] - 5.0, b.centroid[1] - 5.0];
            let v = [b.velocity[0] - 1.0, b.velocity[1] - 2.0];
            b.inertia * b.angular_velocity + b.mass * (r[0] * v[1] - r[1] * v[0])
        })
        .sum();
    assert_relative_eq!(l, 0.5 * 100.0 * 200.0 / 12.0, max_relative = 1e-12);
}

#[test]
fn rotated_block_is_split_in_world_coordinates() {
    let mut m = model_with(&rect(0.0, 0.0, 20.0, 10.0));
    m.blocks[0].rotation = std::f64::consts::FRAC_PI_2;
    m.update_corner_positions(0);
    assert_eq!(bbox(&m, 0).map(|v| (v * 1e9).round() / 1e9), [5.0, -5.0, 15.0, 15.0]);
    let out = split_line(&mut m, [0.0, 5.0], [20.0, 5.0], None, None);
    assert_eq!(out.split.len(), 1);
    valid(&m);
    let mut boxes: Vec<[f64; 4]> = (0..2).map(|b| bbox(&m, b).map(|v| (v * 1e9).round() / 1e9)).collect();
    boxes.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(boxes, vec![[5.0, -5.0, 15.0, 5.0], [5.0, 5.0, 15.0, 15.0]]);
}

#[test]
fn split_block_along_a_chord() {
    let mut m = model_with(&rect(0.0, 0.0, 10.0, 10.0));
    m.add_block(&rect(20.0, 0.0, 30.0, 10.0), 1, 1, None).unwrap();
    // Along an edge (rejected) and off the boundary (refused): nothing changes.
    assert!(split_block_along(&mut m, 0, [0.0, 0.0], [10.0, 0.0], 4, 5, 0.0).is_none());
    assert!(split_block_along(&mut m, 0, [1.0, 1.0], [10.0, 5.0], 4, 5, 0.0).is_none());
    assert_eq!(m.blocks.len(), 2);
    let pieces = split_block_along(&mut m, 0, [0.0, 3.0], [10.0, 7.0 + 1e-12], 4, 5, 0.0).unwrap();
    valid(&m);
    assert_eq!(pieces, vec![1, 2]);
    assert_eq!(m.blocks[0].id, 2); // the other block shifted down
    assert_eq!(m.blocks[1].id, 1);
    assert_relative_eq!(m.blocks[1].area + m.blocks[2].area, 100.0, max_relative = 1e-12);
    let joints = m.corners.iter().filter(|c| (c.edge_material, c.edge_constitutive) == (4, 5)).count();
    assert_eq!(joints, 2);
    // The pieces are a crack's: they keep the area the block was built with, and a chord that
    // would leave a piece under the floor is refused (the fragment floor, `blockdem::cracking`).
    assert_eq!((m.blocks[1].built_area, m.blocks[2].built_area), (100.0, 100.0));
    // The lower piece (0,0) (10,0) (10,7) (0,3): a chord from (0,1) to (10,5) leaves 30 and 20.
    let lower = if m.blocks[1].centroid[1] < m.blocks[2].centroid[1] { 1 } else { 2 };
    assert!(split_block_along(&mut m, lower, [0.0, 1.0], [10.0, 5.0], 4, 5, 25.0).is_none());
    assert_eq!(m.blocks.len(), 3);
    let again = split_block_along(&mut m, lower, [0.0, 1.0], [10.0, 5.0], 4, 5, 10.0).unwrap();
    assert!(again.iter().all(|&p| m.blocks[p].built_area == 100.0 && m.blocks[p].area < 50.0));
    valid(&m);
}

/// ¶13 on a sliver (the case proptest found): the line crosses the top edge 0.54 from the corner
/// below it, a corner of another edge (and the chord's other end); with d = 0.76 the new corner's
/// rounding arc would overlap that corner's, which no diversion along the crossed edge cures: the
/// cut is refused for the block.
#[test]
fn split_diverts_onto_a_corner_across_a_sliver() {
    let poly = vec![
        [23.919779763002676, 0.0],
        [20.122599230169797, 0.5406408174555976],
        [9.936635621250018, 0.9096319953545183],
        [-3.4041395885043215, 0.9898214418809328],
        [-15.664124531409508, 0.7557495743542583],
        [-23.81183428393228, -0.09489604498306926],
        [-21.72140328077984, -0.41876685905581845],
        [-15.664124531409513, -0.7557495743542582],
        [-3.404139588504327, -0.9898214418809327],
        [9.936635621250007, -0.9096319953545186],
        [20.122599230169797, -0.5406408174555974],
    ];
    let mut m = Model::default();
    m.materials[0].block.density = 1.0;
    m.add_block(&poly, 1, 1, None).unwrap();
    m.set_round(0.7619681127556684);
    let (c, s) = (m.blocks[0].centroid, m.blocks[0].radius);
    let from = [c[0] - 0.6873386704193756 * s, c[1] + 0.7691534022767548 * s];
    let to = [c[0] - 1.1892594063131599 * s, c[1] - 0.9275290643968269 * s];
    let out = split_line(&mut m, from, to, Some(1), Some(1));
    valid(&m);
    assert_eq!(m.blocks.len(), 1, "{out:?}");
    assert_eq!(out.rejected.len(), 1);
    assert!(out.rejected[0].1.contains("rounding arcs would overlap"), "{out:?}");
    // With a rounding length below that 0.54 m the same line cuts the tip off.
    let mut m = Model::default();
    m.materials[0].block.density = 1.0;
    m.add_block(&poly, 1, 1, None).unwrap();
    m.set_round(0.3);
    let out = split_line(&mut m, from, to, Some(1), Some(1));
    valid(&m);
    assert_eq!((m.blocks.len(), out.split.len()), (2, 1), "{out:?}");
}

// ---------------------------------------------------------------- property-based

/// A convex polygon: points on an ellipse at sorted angles at least ~2° apart.
fn convex_polygon() -> impl Strategy<Value = Vec<[f64; 2]>> {
    (prop::collection::vec(0.0..1.0f64, 3..12), 1.0..50.0f64, 1.0..50.0f64, -1.0e4..1.0e4f64, -1.0e4..1.0e4f64).prop_map(|(fracs, a, b, cx, cy)| {
        let n = fracs.len();
        let step = std::f64::consts::TAU / n as f64;
        (0..n)
            .map(|i| {
                let t = step * (i as f64 + 0.8 * fracs[i]);
                [cx + a * t.cos(), cy + b * t.sin()]
            })
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn split_conserves_area_and_keeps_the_model_valid(
        poly in convex_polygon(),
        p in (-1.5..1.5f64, -1.5..1.5f64),
        q in (-1.5..1.5f64, -1.5..1.5f64),
        d in prop_oneof![Just(0.0), 0.01..1.0f64],
    ) {
        let mut m = Model::default();
        m.materials[0].block.density = 1.0;
        m.add_block(&poly, 1, 1, None).unwrap();
        m.set_round(d);
        let c = m.blocks[0].centroid;
        let s = m.blocks[0].radius;
        let from = [c[0] + p.0 * s, c[1] + p.1 * s];
        let to = [c[0] + q.0 * s, c[1] + q.1 * s];
        let area = m.blocks[0].area;
        let out = split_line(&mut m, from, to, Some(1), Some(1));
        prop_assert!(m.validate().is_ok(), "{:?}", m.validate());
        prop_assert!(m.blocks.len() == 1 || m.blocks.len() == 2);
        prop_assert_eq!(m.blocks.len() == 2, out.split.len() == 1);
        let total: f64 = m.blocks.iter().map(|b| b.area).sum();
        prop_assert!((total - area).abs() <= 1e-9 * area, "{} vs {}", total, area);
        for b in 0..m.blocks.len() {
            prop_assert!(is_simple_polygon(&m.corner_positions(b)));
        }
        // ¶13: a new corner is never closer than d to an existing one (else it is diverted onto it).
        for b in 0..m.blocks.len() {
            for p in m.corner_positions(b) {
                let dmin = poly.iter().map(|c| (p[0] - c[0]).hypot(p[1] - c[1])).fold(f64::INFINITY, f64::min);
                prop_assert!(dmin < 1e-9 * s || dmin >= d * (1.0 - 1e-9), "new corner {} from an old one", dmin);
            }
        }
    }
}

/// A star-shaped (generally re-entrant) simple polygon around (cx, cy).
fn star_polygon() -> impl Strategy<Value = Vec<[f64; 2]>> {
    (prop::collection::vec((0.0..1.0f64, 0.25..1.0f64), 3..16), 1.0..50.0f64, -1.0e4..1.0e4f64, -1.0e4..1.0e4f64).prop_map(|(v, size, cx, cy)| {
        let n = v.len();
        let step = std::f64::consts::TAU / n as f64;
        v.iter()
            .enumerate()
            .map(|(i, &(f, r))| {
                let t = step * (i as f64 + 0.8 * f);
                [cx + size * r * t.cos(), cy + size * r * t.sin()]
            })
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn re_entrant_splits_conserve_area(
        poly in star_polygon(),
        p in (-1.2..1.2f64, -1.2..1.2f64),
        q in (-1.2..1.2f64, -1.2..1.2f64),
        d in prop_oneof![Just(0.0), 0.01..0.5f64],
    ) {
        let mut m = Model::default();
        m.materials[0].block.density = 1.0;
        m.set_round(d);
        m.add_block(&poly, 1, 1, None).unwrap();
        let c = m.blocks[0].centroid;
        let s = m.blocks[0].radius;
        let from = [c[0] + p.0 * s, c[1] + p.1 * s];
        let to = [c[0] + q.0 * s, c[1] + q.1 * s];
        let area = m.blocks[0].area;
        let out = split_line(&mut m, from, to, None, None);
        prop_assert!(m.validate().is_ok(), "{:?}", m.validate());
        prop_assert_eq!(m.blocks.len() > 1, out.split.len() == 1);
        let total: f64 = m.blocks.iter().map(|b| b.area).sum();
        prop_assert!((total - area).abs() <= 1e-9 * area, "{} vs {}", total, area);
        for b in 0..m.blocks.len() {
            prop_assert!(is_simple_polygon(&m.corner_positions(b)));
        }
        // Splitting the pieces again along the same line changes nothing.
        let n = m.blocks.len();
        let again = split_line(&mut m, from, to, None, None);
        prop_assert!(again.split.is_empty(), "{:?}", again);
        prop_assert_eq!(m.blocks.len(), n);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn every_rounding_circle_lies_inside_its_block_and_is_the_largest_that_does(
        poly in prop_oneof![star_polygon(), convex_polygon()],
        d in 0.01..20.0f64,
    ) {
        // Measured about the first corner: the outline sits far from the origin.
        let o = poly[0];
        let pts: Vec<[f64; 2]> = poly.iter().map(|p| [p[0] - o[0], p[1] - o[1]]).collect();
        let size = pts.iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
        let n = pts.len();
        for (i, c) in corner_rounding(&pts, d).iter().enumerate() {
            if c.radius == 0.0 {
                continue;
            }
            let gap = clearance(&pts, i, c.circle, c.radius);
            prop_assert!(point_in_polygon(c.circle, &pts), "corner {}: centre {:?} outside", i, c.circle);
            prop_assert!(gap >= -1e-6 * c.round - 1e-12 * size, "corner {} of {:?}: circle {:?} crosses an edge by {}", i, pts, c, -gap);
            // Lowered only as far as the circle would cross an edge: then it touches one.
            let (a, p, b) = (pts[(i + n - 1) % n], pts[i], pts[(i + 1) % n]);
            let full = d.min(0.5 * (p[0] - a[0]).hypot(p[1] - a[1])).min(0.5 * (b[0] - p[0]).hypot(b[1] - p[1]));
            prop_assert!(c.round <= full);
            if c.round < full {
                prop_assert!(gap <= 1e-9 * size, "corner {}: lowered to {} of {} but clear by {}", i, c.round, full, gap);
            }
        }
    }
}

// ---------------------------------------------------------------- decks

/// The blocks of `m` as given: every corner circle inside its own block, and no contact
/// overlapping (pieces of one block touch along their cut, gap 0 up to round-off).
fn given_touching_not_overlapping(m: &mut Model, deck: &str) {
    for b in 0..m.blocks.len() {
        let outline = m.world_outline(b);
        let size = outline.iter().map(|p| (p[0] - outline[0][0]).hypot(p[1] - outline[0][1])).fold(0.0, f64::max);
        for (i, c) in m.block_corners(b).iter().enumerate() {
            if c.radius > 0.0 {
                let gap = clearance(&outline, i, c.circle, c.radius);
                assert!(gap >= -1e-6 * c.round - 1e-12 * size, "block {} corner {i}: circle crosses an edge by {}\n{deck}", m.blocks[b].id, -gap);
            }
        }
    }
    blockdem::udec::topology::update_contacts(m, true);
    for c in &m.contacts {
        assert!(c.gap >= -1e-9, "blocks {} and {} given overlapping by {:e}\n{deck}", m.blocks[c.block1 as usize].id, m.blocks[c.block2 as usize].id, -c.gap);
    }
}

#[test]
fn split_pieces_are_given_touching_and_cycle() {
    let cpu = || Box::new(CpuBackend::new());
    // The reviewer's deck: the first SPLIT leaves a 162° corner at (0, 5), the second cuts a strip
    // 1 m wide beside it, and the corner's circle reached through the strip into block 4.
    let head = "START\nPROP MAT=1 DENS=2000 KN=1e9 KS=1e9 F=0.5\nROUND 0.1\nBLOCK 0 0 0 10 10 10 10 0\n\
                SPLIT -0.309 5.951 1.854 -0.706\nSPLIT 1 -1 1 11\n";
    let mut m = run_deck_on(head, cpu()).expect("the SPLITs");
    given_touching_not_overlapping(&mut m, head);
    run_deck_on(&format!("{head}CYCLE 1\nSTOP\n"), cpu()).expect("the reviewer's deck cycles");
    // One 10 m block and 2–5 random cuts, half of them with a parallel cut 0.3–1.5 m away (a thin
    // strip, whose obtuse corners are the ones whose circles would not fit), at ROUND 0.1–1. Of 200
    // decks made this way (a script, same
    // ranges) 146 failed with "given overlapping" before the rounding was fitted inside each block.
    let mut rng = Rng(0x5eed_b10c);
    for _ in 0..40 {
        let mut deck = format!("START\nPROP MAT=1 DENS=2000 KN=1e9 KS=1e9 F=0.5\nROUND {:.3}\nBLOCK 0 0 0 10 10 10 10 0\n", rng.range(0.1, 1.0));
        for _ in 0..2 + (rng.next() * 4.0) as usize {
            let (cx, cy, a) = (rng.range(0.0, 10.0), rng.range(0.0, 10.0), rng.range(0.0, std::f64::consts::PI));
            let (dx, dy) = (15.0 * a.cos(), 15.0 * a.sin());
            deck += &format!("SPLIT {:.3} {:.3} {:.3} {:.3}\n", cx - dx, cy - dy, cx + dx, cy + dy);
            if rng.next() < 0.5 {
                let w = rng.range(0.3, 1.5);
                let (nx, ny) = (-a.sin() * w, a.cos() * w);
                deck += &format!("SPLIT {:.3} {:.3} {:.3} {:.3}\n", cx - dx + nx, cy - dy + ny, cx + dx + nx, cy + dy + ny);
            }
        }
        let mut m = run_deck_on(&deck, cpu()).unwrap_or_else(|e| panic!("{e}\n{deck}"));
        given_touching_not_overlapping(&mut m, &deck);
        // Under gravity, so that the energy check has a scale: with neither gravity nor loads
        // its floor is zero and round-off forces alone trip it.
        let run = format!("{deck}GRAV 0 -10\nCYCLE 10\nSTOP\n");
        run_deck_on(&run, cpu()).unwrap_or_else(|e| panic!("{e}\n{run}"));
    }
}
