//! A block's volume, centroid (SL-85-1 ¶14–15, by the divergence theorem) and exact inertia
//! tensor (¶16 approximated it by ½ r̄² m) against closed forms: a box, a tetrahedron, a rotated
//! box, far from the origin.

use blockdem::d3::geometry::{box_faces, mass_properties, shape_from_faces};
use blockdem::d3::model::principal_moments;
use glam::{DMat3, DQuat, DVec3};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

fn assert_mat(a: DMat3, b: DMat3, tol: f64) {
    let scale = b.to_cols_array().iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for (x, y) in a.to_cols_array().iter().zip(b.to_cols_array()) {
        assert!((x - y).abs() <= tol * scale, "{a} != {b}");
    }
}

#[test]
fn box_volume_centroid_and_inertia() {
    let (a, b, c) = (1.0, 2.0, 3.0);
    let (_, p) = shape_from_faces(&box_faces([10.0, -4.0, 7.0], [10.0 + a, -4.0 + b, 7.0 + c])).unwrap();
    assert!(close(p.volume, a * b * c, 1e-14));
    assert!((p.centroid - DVec3::new(10.5, -3.0, 8.5)).length() < 1e-13);
    // Per unit density: I = V/12 diag(b² + c², a² + c², a² + b²).
    let v = a * b * c;
    assert_mat(p.inertia, DMat3::from_diagonal(DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) * (v / 12.0)), 1e-13);
}

#[test]
fn tetrahedron_volume_centroid_and_inertia() {
    // The corner tetrahedron (0, a e1, b e2, c e3), typed counter-clockwise looking along the
    // outward normal: V = abc/6, centroid (a, b, c)/4, and about the centroid
    // Ixx = 3m(b² + c²)/80, Ixy = m·ab/80 (the products of inertia −∫(x−x̄)(y−ȳ)dm).
    let (a, b, c) = (1.0, 2.0, 1.5);
    let o = [0.0, 0.0, 0.0];
    let (x, y, z) = ([a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]);
    let faces = [[o, x, y], [o, z, x], [o, y, z], [x, z, y]];
    let (shape, p) = shape_from_faces(&faces).unwrap();
    assert!(shape.convex);
    let m = a * b * c / 6.0;
    assert!(close(p.volume, m, 1e-14));
    assert!((p.centroid - DVec3::new(a, b, c) / 4.0).length() < 1e-14);
    let expected = DMat3::from_cols(
        DVec3::new(3.0 * m * (b * b + c * c) / 80.0, m * a * b / 80.0, m * a * c / 80.0),
        DVec3::new(m * a * b / 80.0, 3.0 * m * (a * a + c * c) / 80.0, m * b * c / 80.0),
        DVec3::new(m * a * c / 80.0, m * b * c / 80.0, 3.0 * m * (a * a + b * b) / 80.0),
    );
    assert_mat(p.inertia, expected, 1e-13);
    // ¶16's ½ r̄² m is not it: for this block it is off by far more than the accuracy above.
    let mean_r = shape.vertices.iter().map(|v| v.length()).sum::<f64>() / 4.0;
    let report = 0.5 * mean_r * mean_r * m;
    let exact = principal_moments(p.inertia);
    assert!(exact.iter().all(|i| (i - report).abs() > 0.05 * report), "{exact:?} vs {report}");
}

#[test]
fn the_sample_tetrahedra() {
    // D3's sample: the lower block, V = 1/6, centroid (3/4, 1/4, 1/4).
    let lower = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
        [[1.0, 0.0, 0.0], [1.0, 0.0, 1.0], [1.0, 1.0, 0.0]],
        [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 1.0]],
        [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 1.0]],
    ];
    let (_, p) = shape_from_faces(&lower).unwrap();
    assert!(close(p.volume, 1.0 / 6.0, 1e-14));
    assert!((p.centroid - DVec3::new(0.75, 0.25, 0.25)).length() < 1e-14);
}

#[test]
fn a_rotated_box_turns_its_tensor() {
    let (a, b, c) = (1.0, 2.0, 3.0);
    let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 0.7);
    let shift = DVec3::new(1e5, -2e5, 3e5);
    let faces: Vec<[[f64; 3]; 3]> = box_faces([0.0; 3], [a, b, c]).iter().map(|f| f.map(|v| (q * DVec3::from_array(v) + shift).to_array())).collect();
    let (_, p) = shape_from_faces(&faces).unwrap();
    assert!(close(p.volume, a * b * c, 1e-9));
    assert!((p.centroid - (q * DVec3::new(a, b, c) / 2.0 + shift)).length() < 1e-9);
    let r = DMat3::from_quat(q);
    let body = DMat3::from_diagonal(DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) * (a * b * c / 12.0));
    assert_mat(p.inertia, r * body * r.transpose(), 1e-9);
    let moments = principal_moments(p.inertia);
    for (m, e) in moments.iter().zip([5.0 / 2.0, 10.0 / 2.0, 13.0 / 2.0]) {
        assert!(close(*m, e, 1e-9), "{moments:?}");
    }
}

/// A turned box typed to seven decimals: each side's two triangles are bent by the rounding
/// (~10⁻⁷ m), and it is still a box, convex (`geometry::FLAT`), not a concave block to cut into
/// parts (at the old tolerance of 10⁻⁹ of its size the deck's block was refused as "concave and
/// cannot be made of convex parts").
#[test]
fn a_turned_box_typed_to_a_few_digits_is_convex() {
    let q = DQuat::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), 0.61);
    let typed = |x: f64| (x * 1e7).round() / 1e7;
    let faces: Vec<[[f64; 3]; 3]> = box_faces([0.0; 3], [1.0, 2.0, 3.0]).iter().map(|f| f.map(|v| (q * DVec3::from_array(v)).to_array().map(typed))).collect();
    let bent = faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(DVec3::from_array);
            let n = (b - a).cross(c - a).normalize();
            faces.iter().flatten().map(|v| n.dot(DVec3::from_array(*v) - a)).fold(f64::NEG_INFINITY, f64::max)
        })
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(bent > 1e-9 * 3.0, "the rounding bends the sides past the old tolerance: {bent:e}");
    let (shape, p) = shape_from_faces(&faces).unwrap();
    assert!(shape.convex, "bent by {bent:e}");
    assert!(close(p.volume, 6.0, 1e-6));
}

#[test]
fn mass_properties_of_a_concave_block() {
    // A concave L-prism, the union of [0,2]×[0,1]×[0,1] and [0,1]×[1,2]×[0,1]: volume 3,
    // centroid (5/6, 5/6, 1/2); built, and refused as not convex for contact detection.
    let pts = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
    let v = |i: usize, z: f64| DVec3::new(pts[i][0], pts[i][1], z);
    let mut vertices = Vec::new();
    for z in [0.0, 1.0] {
        for i in 0..6 {
            vertices.push(v(i, z));
        }
    }
    // Faces counter-clockwise from outside: the bottom and top as fans from the concave corner
    // 3, the six sides as two triangles each.
    let mut faces: Vec<[u32; 3]> = Vec::new();
    for k in [4u32, 5, 0, 1] {
        faces.push([3, (k + 1) % 6, k]);
        faces.push([9, 6 + k, 6 + (k + 1) % 6]);
    }
    for i in 0..6u32 {
        let j = (i + 1) % 6;
        faces.push([i, j, 6 + j]);
        faces.push([i, 6 + j, 6 + i]);
    }
    let p = mass_properties(&vertices, &faces);
    assert!(close(p.volume, 3.0, 1e-14));
    assert!((p.centroid - DVec3::new(5.0 / 6.0, 5.0 / 6.0, 0.5)).length() < 1e-14);
    let typed: Vec<[[f64; 3]; 3]> = faces.iter().map(|f| [f[0], f[2], f[1]].map(|i| vertices[i as usize].to_array())).collect();
    let (shape, q) = shape_from_faces(&typed).unwrap();
    assert!(!shape.convex);
    assert!(close(q.volume, 3.0, 1e-14));
}
