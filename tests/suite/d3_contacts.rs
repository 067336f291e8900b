//! D3's contacts on the CPU (SL-85-1 ¶18–26, ¶32, ¶35a and c): the six physical categories and
//! their logical contacts, ¶23's normal prescription against the common plane, the neighbour
//! grid against a search of all pairs, a box resting on a fixed box carrying its weight, and a
//! box sliding (and one sticking) on an incline whose dip direction is oblique to the axes:
//! s = ½gt²(sin ψ − cos ψ tan φ).

use blockdem::d3::contact::{common_plane, common_plane_of, logical_contacts, plane_normals, prescribed_normal};
use blockdem::d3::deck::parse_deck;
use blockdem::d3::exec::Executor;
use blockdem::d3::geometry::{box_faces, shape_from_faces};
use blockdem::d3::model::{Block, Body, Feature, LogicalKind, Model};
use blockdem::d3::sdef::Sdef;
use blockdem::d3::topology::neighbour_pairs;
use glam::{DQuat, DVec3};

/// The faces of the box [lo, hi] turned by `q` about the origin and moved by `shift`.
fn turned_box(lo: [f64; 3], hi: [f64; 3], q: DQuat, shift: DVec3) -> Vec<[[f64; 3]; 3]> {
    box_faces(lo, hi).iter().map(|f| f.map(|v| (q * DVec3::from_array(v) + shift).to_array())).collect()
}

fn block(id: u32, faces: &[[[f64; 3]; 3]]) -> Block {
    let (shape, props) = shape_from_faces(faces).unwrap();
    Block::new(id, 1, 1, shape, &props, 1000.0)
}

/// A unit cube centred at the origin, turned by `q`, then moved so that its lowest point (`up`
/// false) or highest (`up` true) is at z = 0, overlapping z = 0 by `overlap`.
fn cube_at_plane(q: DQuat, up: bool, overlap: f64) -> Vec<[[f64; 3]; 3]> {
    let faces = turned_box([-0.5; 3], [0.5; 3], q, DVec3::ZERO);
    let zs = faces.iter().flatten().map(|v| v[2]);
    let shift = if up { -zs.fold(f64::NEG_INFINITY, f64::max) + overlap } else { -zs.fold(f64::INFINITY, f64::min) - overlap };
    faces.iter().map(|f| f.map(|v| [v[0], v[1], v[2] + shift])).collect()
}

/// The rotation that points a cube's body diagonal (1,1,1) along −z (a vertex down) or +z.
fn diagonal(down: bool) -> DQuat {
    DQuat::from_rotation_arc(DVec3::ONE.normalize(), if down { -DVec3::Z } else { DVec3::Z })
}

#[test]
fn the_six_physical_categories() {
    let flat = DQuat::IDENTITY;
    let edge_x = DQuat::from_rotation_x(std::f64::consts::FRAC_PI_4);
    let edge_y = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
    let cases: [(&str, DQuat, DQuat, [Feature; 2], usize); 6] = [
        ("face-face", flat, flat, [Feature::Face, Feature::Face], 4),
        ("face-edge", flat, edge_y, [Feature::Face, Feature::Edge], 2),
        ("face-vertex", flat, diagonal(true), [Feature::Face, Feature::Vertex], 1),
        ("edge-edge", edge_x, edge_y, [Feature::Edge, Feature::Edge], 1),
        ("edge-vertex", edge_x, diagonal(true), [Feature::Edge, Feature::Vertex], 1),
        ("vertex-vertex", diagonal(false), diagonal(true), [Feature::Vertex, Feature::Vertex], 1),
    ];
    // The blocks a shade apart, within the contact-forming distance: about to touch. (Once they
    // overlap, a vertex pressed into an edge takes the normal of one of the edge's faces, the
    // least penetration; the first four categories are checked overlapping too.)
    for (name, lower, upper, category, count, overlap) in
        cases.iter().map(|c| (c.0, c.1, c.2, c.3, c.4, -1e-4)).chain(cases[..4].iter().map(|c| (c.0, c.1, c.2, c.3, c.4, 1e-4)))
    {
        // The lower block's top at z = overlap/2, the upper's bottom at −overlap/2.
        let a = block(1, &cube_at_plane(lower, true, overlap / 2.0));
        let b = block(2, &cube_at_plane(upper, false, overlap / 2.0));
        let plane = common_plane(&a, &b, 0.01);
        assert!((plane.separation + overlap).abs() < 1e-9, "{name}: separation {}", plane.separation);
        assert!((plane.normal - DVec3::Z).length() < 1e-9, "{name}: normal {}", plane.normal);
        let (found, logical, area) = logical_contacts(&a, &b, &plane, 0.01);
        assert_eq!(found, category, "{name}");
        assert_eq!(logical.len(), count, "{name}: {logical:?}");
        for (_, point, gap) in &logical {
            assert!((gap + overlap).abs() < 1e-9, "{name}: gap {gap}");
            assert!(point.z.abs() < 1e-9, "{name}: point {point}");
        }
        if name == "face-face" {
            assert!((area - 1.0).abs() < 1e-9, "the overlap square: {area}");
        }
        if name == "edge-edge" {
            assert!(matches!(logical[0].0, LogicalKind::EdgeEdge { .. }));
        }
    }
}

#[test]
fn a_face_face_contact_off_centre_has_the_corners_of_its_overlap() {
    // A unit cube over the corner of another, offset by (0.5, 0.25): the overlap is 0.5 × 0.75,
    // with four logical contacts: one vertex of each over the other's face, two edge crossings.
    let a = block(1, &box_faces([0.0, 0.0, -1.0], [1.0, 1.0, 0.0]));
    let b = block(2, &box_faces([0.5, 0.25, -1e-3], [1.5, 1.25, 1.0 - 1e-3]));
    let plane = common_plane(&a, &b, 0.01);
    let (category, logical, area) = logical_contacts(&a, &b, &plane, 0.01);
    assert_eq!(category, [Feature::Face, Feature::Face]);
    assert!((area - 0.375).abs() < 1e-9, "{area}");
    let kinds = |f: fn(&LogicalKind) -> bool| logical.iter().filter(|l| f(&l.0)).count();
    assert_eq!(kinds(|k| matches!(k, LogicalKind::VertexFace { on_first: true, .. })), 1);
    assert_eq!(kinds(|k| matches!(k, LogicalKind::VertexFace { on_first: false, .. })), 1);
    assert_eq!(kinds(|k| matches!(k, LogicalKind::EdgeEdge { .. })), 2);
}

/// Two bricks face to face, one tilted by a hair about an axis in the face so that its top and
/// bottom faces tilt through parallel to the contact's normal: every logical contact's gap is
/// the overlap, within the tilt over the brick's size, whichever way it tilts. A gap measured
/// through a face that steep (`contact::STEEP_SHARE`) was the corner's offset from that face
/// over the tilt: on a struck wall of 40 bricks it jumped by 3·10⁻⁴ m from one cycle to the
/// next at a corner of two bricks, and the ledger grew by 5 % of the work.
#[test]
fn a_corner_gap_does_not_jump_as_a_side_face_tilts_through_parallel() {
    let overlap = 1e-4;
    let b = block(2, &box_faces([0.4 - overlap, 0.0, 0.0], [0.8 - overlap, 0.2, 0.2]));
    for tilt in [1e-9, -1e-9, 1e-7, -1e-7, 1e-6, -1e-6, 3e-5, -3e-5] {
        let q = DQuat::from_rotation_y(tilt);
        let centre = DVec3::new(0.4, 0.1, 0.1);
        let a = block(1, &turned_box([-0.4, -0.1, -0.1], [0.0, 0.1, 0.1], q, centre));
        let plane = common_plane(&a, &b, 0.01);
        let (_, logical, _) = logical_contacts(&a, &b, &plane, 0.01);
        assert!(logical.len() >= 4, "tilt {tilt}: {logical:?}");
        for (kind, point, gap) in &logical {
            assert!((gap + overlap).abs() < 1e-6 + 0.3 * tilt.abs(), "tilt {tilt}: {kind:?} at {point}: gap {gap:e}");
        }
    }
}

/// ¶35a: the report's prescription (¶23) tested against the common plane.
#[test]
fn the_prescription_against_the_common_plane() {
    let angle = |a: DVec3, b: DVec3| a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
    // A vertex pressed 1 mm into the middle of a 2 × 2 face: the two agree within a degree.
    let slab = block(1, &box_faces([-1.0, -1.0, -1.0], [1.0, 1.0, 0.0]));
    let tip = block(2, &cube_at_plane(diagonal(true), false, 1e-3));
    let plane = common_plane(&slab, &tip, 0.01);
    let (_, logical, _) = logical_contacts(&slab, &tip, &plane, 0.01);
    let p = logical[0].1;
    let prescribed = -prescribed_normal(&tip, p);
    let from_slab = prescribed_normal(&slab, p);
    assert!(angle(from_slab, plane.normal) < 1.0, "the slab's prescription: {}°", angle(from_slab, plane.normal));
    // The tip's own prescription (its nearest vertex is the contact's vertex, whose three faces
    // are equally far): the mean of three face normals, which for a vertex pointing straight
    // down is the vertical too, by symmetry.
    assert!(angle(prescribed, plane.normal) < 1e-6, "{}", angle(prescribed, plane.normal));
    // Two crossing edges, block 1's turned 30° about x (its faces at the edge lean 30° and 60°),
    // block 2's 45° about y: the common plane gives the cross product of the edges, vertical;
    // block 1's prescription weights its two faces by 1/d, d ∝ cos 30° and cos 60°, and leans
    // 30° off; block 2's, whose crossing point is off the middle of its edge, leans 18° off; the
    // two blocks' prescriptions disagree with each other too.
    let a = block(1, &cube_at_plane(DQuat::from_rotation_x(30f64.to_radians()), true, 5e-4));
    let b = block(2, &cube_at_plane(DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4), false, 5e-4));
    let plane = common_plane(&a, &b, 0.01);
    let (_, logical, _) = logical_contacts(&a, &b, &plane, 0.01);
    let p = logical[0].1;
    let (na, nb) = (prescribed_normal(&a, p), -prescribed_normal(&b, p));
    assert!((plane.normal - DVec3::Z).length() < 1e-9);
    assert!((angle(na, plane.normal) - 30.0).abs() < 1.0, "block 1's prescription is {}° off", angle(na, plane.normal));
    assert!(angle(nb, plane.normal) > 10.0, "block 2's prescription is {}° off", angle(nb, plane.normal));
    assert!(angle(na, nb) > 10.0, "the two blocks' prescriptions differ by {}°", angle(na, nb));
}

#[test]
fn the_neighbour_grid_finds_every_pair_a_search_of_all_finds() {
    let mut model = Model::default();
    let mut id = 1;
    let mut seed = 12345u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for i in 0..6 {
        for j in 0..6 {
            for k in 0..4 {
                let size = 0.3 + 0.6 * next();
                let at = DVec3::new(i as f64, j as f64, k as f64) * 1.05 + DVec3::new(next(), next(), next()) * 0.2;
                let q = DQuat::from_axis_angle(DVec3::new(next(), next(), next() + 0.1).normalize(), next() * 3.0);
                model.blocks.push(block(id, &turned_box([0.0; 3], [size, 1.0, 0.8], q, at)));
                id += 1;
            }
        }
    }
    let margin = 0.05;
    let pairs = neighbour_pairs(&model, margin);
    let mut all = Vec::new();
    for i in 0..model.blocks.len() {
        for j in i + 1..model.blocks.len() {
            let (a0, a1) = model.blocks[i].bounds();
            let (b0, b1) = model.blocks[j].bounds();
            let h = DVec3::splat(0.5 * margin);
            if (a0 - h).cmple(b1 + h).all() && (b0 - h).cmple(a1 + h).all() {
                all.push((i as u32, j as u32));
            }
        }
    }
    assert!(all.len() > 100, "{}", all.len());
    assert_eq!(pairs, all);
}

/// A wall of `rows` courses of `per_row` bricks 0.999 × 0.4 × 0.499 m in running bond on a slab
/// (block 1) as long as the wall; the next free block id.
fn wall_on_slab(rows: usize, per_row: usize) -> (Model, u32) {
    let mut model = Model::default();
    let q = DQuat::IDENTITY;
    model.blocks.push(block(1, &turned_box([0.0; 3], [per_row as f64 + 1.0, 1.0, 0.5], q, DVec3::new(-0.5, 0.0, -0.51))));
    let mut id = 2;
    for row in 0..rows {
        for k in 0..per_row {
            let x = k as f64 + if row % 2 == 1 { 0.5 } else { 0.0 };
            model.blocks.push(block(id, &turned_box([0.0; 3], [0.999, 0.4, 0.499], q, DVec3::new(x, 0.3, row as f64 * 0.5))));
            id += 1;
        }
    }
    (model, id)
}

/// A wall of small blocks on a slab as long as the wall, and a few blocks of other sizes: the
/// grid's cells are the small blocks' size (a cell as large as the slab held every block: the
/// search cost N², 25 s for a wall of 10⁵ bricks), the slab is tested against every block
/// apart, and the pairs are those a search of all pairs finds.
#[test]
fn a_slab_under_a_wall_is_kept_out_of_the_neighbour_grid_and_no_pair_is_lost() {
    let (mut model, id) = wall_on_slab(30, 60);
    let q = DQuat::IDENTITY;
    // A projectile and two long beams across the wall's face.
    model.blocks.push(block(id, &turned_box([0.0; 3], [2.0, 2.0, 2.0], q, DVec3::new(29.0, -1.7, 6.0))));
    model.blocks.push(block(id + 1, &turned_box([0.0; 3], [20.0, 0.3, 0.3], q, DVec3::new(10.0, -0.005, 3.0))));
    model.blocks.push(block(id + 2, &turned_box([0.0; 3], [0.3, 0.3, 14.0], DQuat::from_rotation_y(0.3), DVec3::new(40.0, -0.005, 1.0))));
    let margin = 0.02;
    let boxes: Vec<(DVec3, DVec3)> =
        model.blocks.iter().map(|b| b.bounds()).map(|(lo, hi)| (lo - DVec3::splat(0.5 * margin), hi + DVec3::splat(0.5 * margin))).collect();
    let sizes: Vec<f64> = boxes.iter().map(|(lo, hi)| (*hi - *lo).max_element()).collect();
    let (cell, large) = blockdem::d3::topology::grid_cell(&sizes).unwrap();
    assert!(cell < 1.1, "a cell of {cell} m");
    for k in [0, model.blocks.len() - 3, model.blocks.len() - 2, model.blocks.len() - 1] {
        assert!(large.contains(&k), "block {} is in the grid ({large:?})", k + 1);
    }
    assert!(large.len() <= 16, "{large:?}");
    let pairs = neighbour_pairs(&model, margin);
    let mut all = Vec::new();
    for i in 0..boxes.len() {
        for j in i + 1..boxes.len() {
            let ((a0, a1), (b0, b1)) = (boxes[i], boxes[j]);
            if a0.cmple(b1).all() && b0.cmple(a1).all() {
                all.push((i as u32, j as u32));
            }
        }
    }
    // The slab under the 60 bricks of the first course, the beams across many.
    assert!(all.iter().filter(|p| p.0 == 0).count() >= 60, "{}", all.len());
    assert_eq!(pairs, all);
}

/// The partial search of the GPU's detections (`neighbour_pairs_of`): only the moved blocks'
/// boxes looked up in the grid (a large one, the slab or the projectile, against every block),
/// and the pairs those of the whole search with a moved member; then the lists updated for the
/// moved blocks alone (`update_neighbours_of`) after they moved are the whole update's: the same
/// contacts (ids, blocks, order), created and dropped, and only the moved blocks' travel reset.
#[test]
fn a_partial_neighbour_update_finds_what_the_whole_one_finds_for_the_blocks_that_moved() {
    let (mut model, id) = wall_on_slab(12, 30);
    let q = DQuat::IDENTITY;
    model.blocks.push(block(id, &turned_box([0.0; 3], [2.0, 2.0, 2.0], q, DVec3::new(14.0, -1.75, 2.0))));
    model.blocks[0].fixed = true;
    let n = model.blocks.len();
    let margin = blockdem::d3::topology::neighbour_margin(&model);
    let all = neighbour_pairs(&model, margin);
    assert_eq!(blockdem::d3::topology::neighbour_pairs_of(&model, margin, &vec![true; n]), all);
    let moved: Vec<bool> = (0..n).map(|k| k % 7 == 3 || k == 0 || k == n - 1).collect();
    let expected: Vec<(u32, u32)> = all.iter().copied().filter(|&(a, b)| moved[a as usize] || moved[b as usize]).collect();
    assert!(expected.len() > 100 && expected.len() < all.len(), "{} of {}", expected.len(), all.len());
    assert_eq!(blockdem::d3::topology::neighbour_pairs_of(&model, margin, &moved), expected);

    // The lists of the wall as built; then the projectile into the wall, a brick of the fourth
    // course out of it, the brick beside it a little sideways; those three (and any other the
    // test calls moved) updated alone.
    blockdem::d3::topology::update_neighbours(&mut model);
    assert!(model.contacts.len() > 800, "{}", model.contacts.len());
    let (projectile, out, beside) = (n - 1, 1 + 3 * 30 + 10, 1 + 3 * 30 + 11);
    for (k, shift) in [(projectile, DVec3::new(0.0, 1.5, 0.0)), (out, DVec3::new(0.0, -3.0, 0.0)), (beside, DVec3::new(0.0, 0.0, 0.002))] {
        let b = &mut model.blocks[k];
        b.centroid += shift;
        b.place_vertices();
    }
    let mut moved = vec![false; n];
    for (k, b) in model.blocks.iter_mut().enumerate() {
        b.travel = if [projectile, out, beside].contains(&k) { 1.0 } else { 1e-4 * k as f64 };
        moved[k] = [projectile, out, beside, 200].contains(&k);
    }
    let mut whole = model.clone();
    let whole_counts = blockdem::d3::topology::update_neighbours(&mut whole);
    let partial_counts = blockdem::d3::topology::update_neighbours_of(&mut model, &moved);
    let keys = |m: &Model| m.contacts.iter().map(|c| (c.id, c.blocks, c.parts)).collect::<Vec<_>>();
    assert_eq!(keys(&model), keys(&whole));
    assert_eq!(partial_counts, whole_counts);
    assert!(whole_counts.0 > 3 && whole_counts.1 > 3, "{whole_counts:?}");
    for (k, b) in model.blocks.iter().enumerate() {
        assert_eq!(b.travel, if moved[k] { 0.0 } else { 1e-4 * k as f64 }, "block {}", k + 1);
    }
}

/// The grid kept between the GPU's partial detections (`topology::KeptGrid`,
/// `neighbour_pairs_kept`): over rounds in which the moved blocks go far (the projectile through
/// the wall, a brick out of it: re-inserted) and every other block drifts by less than the slack
/// (left where it was inserted), its pairs are those of the grid of every block built afresh
/// (`neighbour_pairs_of`), round after round; the lists it gives are `update_neighbours_of`'s.
#[test]
fn a_kept_grid_finds_the_pairs_a_fresh_one_finds() {
    let (mut model, id) = wall_on_slab(12, 30);
    model.blocks.push(block(id, &turned_box([0.0; 3], [2.0, 2.0, 2.0], DQuat::IDENTITY, DVec3::new(14.0, -1.75, 2.0))));
    model.blocks[0].fixed = true;
    let n = model.blocks.len();
    let margin = blockdem::d3::topology::neighbour_margin(&model);
    let slack = 0.25 * margin;
    let mut kept = None;
    let (projectile, out) = (n - 1, 1 + 3 * 30 + 10);
    for round in 0..5 {
        let moved: Vec<bool> = (0..n).map(|k| k == projectile || k == out || k == 0 || (k + round) % 11 == 0).collect();
        let fresh = blockdem::d3::topology::neighbour_pairs_of(&model, margin, &moved);
        let from_kept = blockdem::d3::topology::neighbour_pairs_kept(&model, margin, &moved, &mut kept, slack);
        assert!(fresh.len() > 50, "round {round}: {}", fresh.len());
        assert_eq!(from_kept, fresh, "round {round}");
        // The moved blocks far (the projectile into the wall, the brick out of it, the others a
        // slack's worth), every other one by less than the slack, to and fro.
        for (k, b) in model.blocks.iter_mut().enumerate() {
            let sign = if (k + round) % 2 == 0 { 1.0 } else { -1.0 };
            b.centroid += if k == projectile {
                DVec3::new(0.0, 0.4, 0.0)
            } else if k == out {
                DVec3::new(0.0, -0.6, 0.0)
            } else if moved[k] {
                DVec3::new(0.0, 0.0, 1.5 * slack * sign)
            } else {
                DVec3::new(0.3 * slack * sign, 0.0, 0.0)
            };
            b.place_vertices();
        }
    }
    // The lists from the kept grid are the fresh grid's.
    let moved: Vec<bool> = (0..n).map(|k| k == projectile || k == out).collect();
    blockdem::d3::topology::update_neighbours(&mut model);
    // The projectile along the wall: pairs made on its way, dropped behind it.
    for (k, shift) in [(projectile, DVec3::new(1.5, 0.0, 0.0)), (out, DVec3::new(0.0, -0.6, 0.0))] {
        model.blocks[k].centroid += shift;
        model.blocks[k].place_vertices();
    }
    let mut fresh = model.clone();
    let counts = blockdem::d3::topology::update_neighbours_of(&mut fresh, &moved);
    let (touched, tol) = (touching(&model, &moved), model.contact_tolerance());
    let renewal = blockdem::d3::topology::update_neighbours_kept(&mut model, &moved, &touched, &mut kept, (tol, slack));
    assert_eq!((renewal.created, renewal.dropped), counts);
    assert!(counts.0 > 0 && counts.1 > 0 && !renewal.in_place(), "{counts:?}");
    assert!(model.contacts == fresh.contacts);
    // Again, nothing moved since: the same pairs, the list renewed in place, as a whole
    // update leaves it.
    let (touched, tol) = (touching(&model, &moved), model.contact_tolerance());
    let renewal = blockdem::d3::topology::update_neighbours_kept(&mut model, &moved, &touched, &mut kept, (tol, slack));
    assert!(renewal.in_place(), "{renewal:?}");
    let mut whole = model.clone();
    blockdem::d3::topology::update_neighbours(&mut whole);
    assert!(model.contacts == whole.contacts);
}

/// The contacts (indices, ascending) with a block among the `moved`.
fn touching(model: &Model, moved: &[bool]) -> Vec<usize> {
    model.contacts.iter().enumerate().filter(|(_, c)| c.blocks.iter().any(|&b| moved[b as usize])).map(|(k, _)| k).collect()
}

/// Runs a deck; the model at its end.
fn run(deck: &str) -> Model {
    let commands = parse_deck(deck, "t.dat").unwrap();
    let mut log = Vec::new();
    let mut exec = Executor::new(Box::new(&mut log), "t.dat");
    let result = exec.run(&commands);
    let model = exec.model.clone();
    drop(exec);
    result.unwrap_or_else(|e| panic!("{e}\n{}", String::from_utf8_lossy(&log)));
    model
}

/// A deck's BLOCK command for faces.
fn block_command(faces: &[[[f64; 3]; 3]]) -> String {
    let mut s = String::from("BLOCK");
    for f in faces {
        s.push_str("\n+");
        for v in f {
            s.push_str(&format!(" ({},{},{})", v[0], v[1], v[2]));
        }
    }
    s.push('\n');
    s
}

#[test]
fn a_box_resting_on_a_fixed_box_carries_its_weight() {
    let deck = "START\nPROP MAT 1 D 2000 KN 1E9 KS 1E9 F 0.5\nBOX -1 1 -1 1 -1 0\nBOX -0.3 0.5 -0.5 0.4 0 1\nFIX -2 2 -2 2 -2 -0.1\n\
                GRAV 0 0 -10\nDAMP 0.5 200 MASS\nCYCLE 4000\nSTOP\n";
    let model = run(deck);
    let weight = model.blocks[1].mass * 10.0;
    let c = model.contacts.iter().find(|c| c.category.is_some()).expect("a real contact");
    assert_eq!(c.type_name(), "FACE-FACE");
    assert_eq!(c.logical.len(), 4);
    assert!((c.area - 0.72).abs() < 1e-6, "{}", c.area);
    assert!((c.normal_force() - weight).abs() < 1e-3 * weight, "{} vs {weight}", c.normal_force());
    assert!(c.shear_force().length() < 1e-6 * weight);
    // The force is at the block's centroid line: it carries the weight without a moment.
    let p = c.point();
    assert!((p.x - 0.1).abs() < 1e-6 && (p.y + 0.05).abs() < 1e-6, "{p}");
    assert!(model.blocks[1].velocity.length() < 1e-4);
}

/// A 1 m cube on a slab whose dip ψ is towards an azimuth of 30° from x (the incline turned
/// about a horizontal axis oblique to x and y), friction φ; gravity −z. It slides
/// s = ½gt²(sin ψ − cos ψ tan φ) down the dip, or sticks where ψ < φ.
fn incline(psi_deg: f64, phi_deg: f64, t: f64) -> (f64, f64) {
    let (psi, phi) = (psi_deg.to_radians(), phi_deg.to_radians());
    let azimuth = 30f64.to_radians();
    let dip = DVec3::new(azimuth.cos(), azimuth.sin(), 0.0);
    // Turning about the horizontal axis z × dip by ψ tilts the slab's normal towards `dip`, so
    // that the slab falls away towards it.
    let q = DQuat::from_axis_angle(DVec3::Z.cross(dip).normalize(), psi);
    let (g, kn, density) = (10.0, 1e8, 1000.0);
    // The cube starts at its static overlap (its weight's normal share on four springs).
    let overlap = density * g * psi.cos() / (4.0 * kn);
    let slab = turned_box([-3.0, -3.0, -1.0], [3.0, 3.0, 0.0], q, DVec3::ZERO);
    let cube = turned_box([-0.5, -0.5, -overlap], [0.5, 0.5, 1.0 - overlap], q, DVec3::ZERO);
    let deck = format!(
        "START\nPROP MAT 1 D {density} KN {kn} KS {kn} F {}\n{}{}FIX -2 2 -2 2 -2 -0.1\nGRAV 0 0 -{g}\nCYCLE {}\nSTOP\n",
        phi.tan(),
        block_command(&slab),
        block_command(&cube),
        0
    );
    let model = run(&deck);
    let dt = model.timestep();
    let n = (t / dt).round() as u64;
    let deck = deck.replace("CYCLE 0", &format!("CYCLE {n}"));
    let start = model.blocks[1].centroid;
    let model = run(&deck);
    let moved = model.blocks[1].centroid - start;
    let downhill = q * dip;
    let expected = 0.5 * g * (n as f64 * dt).powi(2) * (psi.sin() - psi.cos() * phi.tan()).max(0.0);
    // Off the dip line: what it moved across the slope.
    let across = (moved - downhill * moved.dot(downhill)).length();
    (moved.dot(downhill) - expected, across)
}

#[test]
fn a_box_slides_on_an_oblique_incline_as_coulomb_says() {
    let (psi, phi, t) = (30.0f64, 20.0f64, 0.6);
    let expected = 0.5 * 10.0 * t * t * (psi.to_radians().sin() - psi.to_radians().cos() * phi.to_radians().tan());
    let (error, across) = incline(psi, phi, t);
    assert!(error.abs() < 0.01 * expected, "slid {} m more than {expected} m", error);
    assert!(across < 1e-3 * expected, "it left the dip line by {across} m");
}

#[test]
fn a_box_sticks_on_an_incline_flatter_than_its_friction() {
    // It moves only by the elastic shear of its springs: mg sin ψ/(4ks) = 6.5e-6 m at rest, more
    // in the ringing of the sudden load and the cube's rocking on its corners; a frictionless
    // cube would have slid ½g sin ψ t² = 0.12 m.
    let (error, across) = incline(15.0, 20.0, 0.3);
    assert!(error.abs() < 1e-4, "it crept {error} m");
    assert!(across < 1e-5, "{across}");
}

/// Uniform numbers in [0, 1) from a xorshift generator seeded with `seed` (the random cases of
/// the common-plane tests, the same on every run).
fn xorshift(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A random unit vector from `uniform`.
fn unit(uniform: &mut dyn FnMut() -> f64) -> DVec3 {
    DVec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize()
}

/// The common plane's search passes over the axes whose bound lies under the best found or under
/// the floor a hint gives (`contact::common_plane_with`): the answer must be the full search's
/// bit for bit whatever the hint (the last cycle's answer, a direction near it, a random one,
/// the opposite one), for bodies overlapping, touching, a shade apart and far apart, near the
/// origin and 10 km from it, rigid and simply deformable (stretched by a strain of up to 2 %),
/// and a tetrahedron against a box (axes that are no face's normal win there).
#[test]
fn the_common_planes_search_is_the_full_one_whatever_the_hint() {
    let mut uniform = xorshift(0x9e37_79b9_7f4a_7c15);
    let tetrahedron = |q: DQuat, shift: DVec3| -> Vec<[[f64; 3]; 3]> {
        let v = [[0.0, 0.0, 0.0], [0.7, 0.0, 0.0], [0.1, 0.6, 0.0], [0.2, 0.2, 0.8]].map(|p| (q * DVec3::from_array(p) + shift).to_array());
        // Counter-clockwise looking along the outward normal (the volume is positive).
        vec![[v[0], v[1], v[2]], [v[0], v[3], v[1]], [v[1], v[3], v[2]], [v[2], v[3], v[0]]]
    };
    for k in 0..400 {
        let (qa, qb) = (DQuat::from_scaled_axis(unit(&mut uniform) * 3.0), DQuat::from_scaled_axis(unit(&mut uniform) * 3.0));
        let origin = if k % 4 == 3 { DVec3::new(1e4, -7e3, 3e3) } else { DVec3::ZERO };
        let size = DVec3::new(0.2 + uniform(), 0.2 + uniform(), 0.2 + uniform());
        let a_faces = turned_box((-0.5 * size).to_array(), (0.5 * size).to_array(), qa, origin);
        let direction = unit(&mut uniform);
        // Apart by the distance `gap` (negative: overlapping) along `direction`, about: the
        // second body is moved until the full search says so.
        let gap = [-0.05, -1e-4, 1e-5, 3e-3, 0.5][k % 5];
        let b_first = if k % 3 == 0 { tetrahedron(qb, origin) } else { turned_box([-0.3, -0.2, -0.25], [0.3, 0.2, 0.25], qb, origin) };
        let mut a = block(1, &a_faces);
        let mut b = block(2, &b_first);
        if k % 5 == 2 {
            // Simply deformable, strained.
            let strain =
                [0.02 * (uniform() - 0.5), 0.02 * (uniform() - 0.5), 0.02 * (uniform() - 0.5), 0.01 * (uniform() - 0.5), 0.0, 0.01 * (uniform() - 0.5)];
            for blk in [&mut a, &mut b] {
                blk.sdef = Some(Sdef { strain, ..Sdef::default() });
                blk.place_vertices();
            }
        }
        // Move b along `direction` until the full search finds the gap asked.
        let search = |a: &Block, b: &Block, hint: Option<DVec3>| {
            let (a, b) = (Body::from(a), Body::from(b));
            common_plane_of(a, b, 0.01, hint)
        };
        for _ in 0..4 {
            let s = search(&a, &b, None);
            b.centroid += direction * (gap - s.separation).min(5.0);
            b.place_vertices();
        }
        let full = search(&a, &b, None);
        assert!(full.separation.is_finite(), "case {k}: {full:?}");
        // Without the refinement of bodies a shade apart (reach 0), every axis worked out.
        let (body_a, body_b) = (Body::from(&a), Body::from(&b));
        let reference = every_axis(body_a, body_b);
        for hint in [None, Some(full.normal)] {
            let found = common_plane_of(body_a, body_b, 0.0, hint);
            assert!(
                found.normal.to_array().map(f64::to_bits) == reference.0.to_array().map(f64::to_bits) && found.separation.to_bits() == reference.1.to_bits(),
                "case {k} (gap {gap}), hint {hint:?}: {found:?} against every axis's {reference:?}"
            );
        }
        let near = (full.normal + unit(&mut uniform) * 0.05).normalize();
        let random = unit(&mut uniform);
        for hint in [full.normal, near, random, -full.normal, DVec3::Z] {
            let found = search(&a, &b, Some(hint));
            assert!(
                found.normal.to_array().map(f64::to_bits) == full.normal.to_array().map(f64::to_bits)
                    && found.separation.to_bits() == full.separation.to_bits(),
                "case {k} (gap {gap}), hint {hint}: {found:?} against the full search's {full:?}"
            );
        }
    }
}

/// The common plane's axes (the face normals of each body, the cross products of their edge
/// directions) every one worked out, in `common_plane_with`'s order and with its rule for near
/// ties: the normal and separation of the greatest separation.
fn every_axis(a: Body, b: Body) -> (DVec3, f64) {
    let least = |xs: &[DVec3], n: DVec3| xs.iter().map(|x| n.dot(*x)).fold(f64::INFINITY, |m, p| if p < m { p } else { m });
    let greatest = |xs: &[DVec3], n: DVec3| xs.iter().map(|x| n.dot(*x)).fold(f64::NEG_INFINITY, |m, p| if p > m { p } else { m });
    let slack = 1e-12 * (a.shape.radius + b.shape.radius);
    let mut best = (DVec3::Z, f64::NEG_INFINITY);
    let mut offer = |n: DVec3, s: f64| {
        if s > best.1 + slack {
            best = (n, s);
        }
    };
    for n in plane_normals(a) {
        offer(n, least(b.vertices, n) - greatest(a.vertices, n));
    }
    for n in plane_normals(b) {
        offer(-n, least(b.vertices, -n) - greatest(a.vertices, -n));
    }
    for &i in &a.shape.edge_directions {
        let ea = a.shape.edges[i as usize];
        let da = a.vertices[ea.b as usize] - a.vertices[ea.a as usize];
        for &j in &b.shape.edge_directions {
            let eb = b.shape.edges[j as usize];
            let db = b.vertices[eb.b as usize] - b.vertices[eb.a as usize];
            let c = da.cross(db);
            if c.length_squared() <= 1e-12 * da.length_squared() * db.length_squared() {
                continue;
            }
            let n = c.normalize();
            offer(n, least(b.vertices, n) - greatest(a.vertices, n));
            offer(-n, -greatest(b.vertices, n) + least(a.vertices, n));
        }
    }
    best
}

/// Bodies a shade apart (within the contact-forming distance): the common plane's separation is
/// their distance, whatever their nearest features (a face on a face, a vertex over a face, an
/// edge across an edge, a vertex by an edge or a vertex). `common_plane_with` tries the
/// directions between near vertices and edges only where no vertex under a face's plane lands in
/// the face's body (`face_meets`): for cubes stacked face on face, shifted and turned a little,
/// for boxes turned at random, for cubes corner by corner and edge by parallel edge (where no
/// face's axis finds the distance), near the origin and 10 km from it, the separation against
/// the least distance of the two surfaces' triangles, pair by pair.
#[test]
fn the_common_plane_of_bodies_a_shade_apart_is_their_distance() {
    let mut uniform = xorshift(0x2545_f491_4f6c_dd1d);
    let reach = 0.01;
    let plane = |a: &Block, b: &Block| {
        let (a, b) = (Body::from(a), Body::from(b));
        common_plane_of(a, b, reach, None)
    };
    let mut kinds = [0usize; 3];
    for k in 0..450 {
        let origin = if k % 4 == 3 { DVec3::new(1e4, -7e3, 3e3) } else { DVec3::ZERO };
        let gap = [1e-6, 1e-4, 3e-3, 9e-3][k % 4];
        let (a, mut b) = if k % 3 == 0 {
            // A cube on a cube, shifted across (exactly in line every eighth case) and turned
            // about the vertical a little.
            let shift = if k % 8 == 0 { DVec3::ZERO } else { DVec3::new(0.6 * uniform() - 0.3, 0.6 * uniform() - 0.3, 0.0) };
            let turn = DQuat::from_rotation_z(if k % 8 == 0 { 0.0 } else { 0.1 * (uniform() - 0.5) });
            let a = block(1, &turned_box([0.0; 3], [1.0; 3], DQuat::IDENTITY, origin));
            let b = block(2, &turned_box([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0], turn, origin + DVec3::new(0.5, 0.5, 1.0 + gap) + shift));
            (a, b)
        } else if k % 3 == 2 {
            // A cube off a cube's corner by `gap` along a direction out of all three faces
            // (corner by corner), or out of two, the third coordinate within the cube (edge by
            // parallel edge).
            let g = DVec3::new(0.1 + uniform(), 0.1 + uniform(), 0.1 + uniform()).normalize() * gap;
            let offset = if k % 2 == 0 { DVec3::ONE + g } else { DVec3::new(1.0 + g.x, 1.0 + g.y, 0.8 * uniform() - 0.4) };
            let a = block(1, &turned_box([0.0; 3], [1.0; 3], DQuat::IDENTITY, origin));
            let b = block(2, &turned_box([0.0; 3], [1.0; 3], DQuat::IDENTITY, origin + offset));
            (a, b)
        } else {
            let (qa, qb) = (DQuat::from_scaled_axis(unit(&mut uniform) * 3.0), DQuat::from_scaled_axis(unit(&mut uniform) * 3.0));
            let size = DVec3::new(0.2 + uniform(), 0.2 + uniform(), 0.2 + uniform());
            let a = block(1, &turned_box((-0.5 * size).to_array(), (0.5 * size).to_array(), qa, origin));
            let b = block(2, &turned_box([-0.3, -0.2, -0.25], [0.3, 0.2, 0.25], qb, origin));
            (a, b)
        };
        if k % 3 == 1 {
            // Moved along a random direction until the distance is `gap`.
            let direction = unit(&mut uniform);
            b.centroid += direction * 2.0;
            b.place_vertices();
            for _ in 0..30 {
                let d = distance(&a, &b);
                b.centroid -= direction * (d - gap);
                b.place_vertices();
                if (d - gap).abs() < 1e-13 {
                    break;
                }
            }
        }
        let d = distance(&a, &b);
        let found = plane(&a, &b);
        let tol = 1e-12 * (1.0 + origin.length());
        assert!(d > 0.0 && d <= reach, "case {k}: distance {d}");
        assert!((found.separation - d).abs() <= tol, "case {k} (gap {gap}): separation {} against the distance {d}", found.separation);
        kinds[k % 3] += 1;
    }
    assert_eq!(kinds, [150, 150, 150]);
}

/// The least distance between the surfaces of two blocks that do not overlap: the least over
/// pairs of their triangles of the distances between a vertex and a triangle, and between edges.
fn distance(a: &Block, b: &Block) -> f64 {
    let triangles = |x: &Block| -> Vec<[DVec3; 3]> { x.shape.faces.iter().map(|f| f.map(|i| x.vertices[i as usize])).collect() };
    let (ta, tb) = (triangles(a), triangles(b));
    let mut best = f64::INFINITY;
    for s in &ta {
        for t in &tb {
            for p in s {
                best = best.min(point_triangle(*p, t));
            }
            for p in t {
                best = best.min(point_triangle(*p, s));
            }
            for i in 0..3 {
                for j in 0..3 {
                    best = best.min(segment_segment(s[i], s[(i + 1) % 3], t[j], t[(j + 1) % 3]));
                }
            }
        }
    }
    best
}

/// The distance from `p` to the triangle `t`: to its plane where p's foot lies inside it, else
/// to the nearest of its edges.
fn point_triangle(p: DVec3, t: &[DVec3; 3]) -> f64 {
    let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
    let foot = p - n * n.dot(p - t[0]);
    let inside = (0..3).all(|i| (t[(i + 1) % 3] - t[i]).cross(foot - t[i]).dot(n) >= 0.0);
    if inside {
        return n.dot(p - t[0]).abs();
    }
    (0..3).map(|i| segment_segment(p, p, t[i], t[(i + 1) % 3])).fold(f64::INFINITY, f64::min)
}

/// The least distance between the segments [p1, q1] and [p2, q2] (either may be a point): the
/// nearest points' parameters clamped to the segments in turn.
fn segment_segment(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t) = if a <= 1e-30 && e <= 1e-30 {
        (0.0, 0.0)
    } else if a <= 1e-30 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= 1e-30 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-30 * a * e { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).length()
}

/// A contact's logical contacts have distinct keys (`LogicalKind`), whatever the blocks' turn and
/// overlap: `cpu::update_contact` renews a contact's list in place where the keys come back in
/// the same order, which pairs old and new as its search by key does only where no key repeats.
/// Boxes turned at random against a cube, overlapping, touching and a shade apart.
#[test]
fn a_contacts_logical_contacts_have_distinct_keys() {
    let mut uniform = xorshift(0x6a09_e667_f3bc_c908);
    let mut touching = 0;
    for k in 0..300 {
        let q = if k % 3 == 0 { DQuat::IDENTITY } else { DQuat::from_scaled_axis(unit(&mut uniform) * 3.0) };
        let a = block(1, &turned_box([-0.5; 3], [0.5; 3], DQuat::IDENTITY, DVec3::ZERO));
        let mut b = block(2, &turned_box([-0.3, -0.2, -0.25], [0.3, 0.2, 0.25], q, DVec3::ZERO));
        let direction = if k % 3 == 0 { DVec3::Z } else { unit(&mut uniform) };
        let gap = [-1e-3, 0.0, 1e-3][k % 3];
        // Moved out along `direction` until the common plane says `gap`.
        b.centroid += direction * 2.0;
        b.place_vertices();
        for _ in 0..20 {
            let s = common_plane(&a, &b, 0.01).separation;
            b.centroid -= direction * (s - gap);
            b.place_vertices();
        }
        let plane = common_plane(&a, &b, 0.01);
        let (_, logical, _) = logical_contacts(&a, &b, &plane, 0.01);
        for (i, l) in logical.iter().enumerate() {
            assert!(logical[..i].iter().all(|m| m.0 != l.0), "case {k}: key {:?} twice in {logical:?}", l.0);
        }
        touching += usize::from(!logical.is_empty());
    }
    assert!(touching > 250, "{touching} of 300 cases touching");
}

/// Two corners of the upper block just outside the lower one's side face (within the hulls'
/// tolerance), the common normal turned off that face's plane by 10⁻⁷ rad: the line along the
/// normal through the corner crosses the side face's plane 5 m down (5·10⁻⁷ outside over 10⁻⁷),
/// which used to be taken as where it leaves the lower block: a logical contact 2.5 m off the
/// blocks with a 5 m gap (a crushed pile's fragments had them 79 m off, and their lever arm cut
/// the critical step 20-fold). A crossing farther than the two blocks' sizes is passed over
/// (`contact::ray_crossing`): every logical contact lies on the touching region.
#[test]
fn a_corner_just_outside_a_face_along_the_normal_stays_on_the_contact() {
    use blockdem::d3::contact::CommonPlane;
    let a = block(1, &turned_box([-0.5, -0.5, -1.0], [0.5, 0.5, 0.0], DQuat::IDENTITY, DVec3::ZERO));
    let q = DQuat::from_rotation_y(1e-7);
    // Narrower in y than the lower block, so that its corners are no corners of the other.
    let b = block(2, &turned_box([-0.5, -0.3, 0.0], [0.5, 0.3, 1.0], q, DVec3::new(5e-7, 0.0, -1e-5)));
    let n = q * DVec3::Z;
    let hi_a = a.vertices.iter().map(|v| n.dot(*v)).fold(f64::NEG_INFINITY, f64::max);
    let lo_b = b.vertices.iter().map(|v| n.dot(*v)).fold(f64::INFINITY, f64::min);
    let plane = CommonPlane { normal: n, separation: lo_b - hi_a, supports: (hi_a, lo_b) };
    let (_, logical, _) = logical_contacts(&a, &b, &plane, 0.01);
    assert_eq!(logical.len(), 4, "{logical:?}");
    for (kind, p, gap) in &logical {
        assert!(p.z.abs() < 1e-4 && p.x.abs() < 0.5 + 1e-5 && gap.abs() < 1e-4, "{kind:?} at {p}, gap {gap}");
    }
}
