//! Concave D3 blocks (SL-85-1 ¶13, issue 31): a block whose closed surface is concave is cut into
//! convex parts (`d3::decompose`) that move as one body with it. The cut (parts convex, their
//! volumes summing to the block's, every point of the block in exactly one part), the mass
//! properties of the whole block, an L-shaped block resting on a slab on its whole base, a cube
//! carried by the floor of a U-shaped block's notch, the energy ledger, SAVE/RESTART, and the
//! refusals (a self-touching surface at BLOCK); SPLIT of a concave block (as many blocks as the
//! plane leaves), a simply-deformable one, and one cracking. On the GPU backend:
//! tests/suite/d3_concave_gpu.rs.

use crate::common::voxels::{block_command, voxel_faces, L, U};
use blockdem::d3::backend::Backend as _;
use blockdem::d3::deck::parse_deck;
use blockdem::d3::decompose;
use blockdem::d3::exec::{Executor, RunError};
use blockdem::d3::geometry::{shape_from_faces, MassProperties, Shape};
use blockdem::d3::model::{Model, Part};
use glam::{DMat3, DVec3};

/// A 2 × 2 × 2 cube less one corner voxel: three reflex edges meeting at a vertex.
const CORNER: [[i32; 3]; 7] = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]];

fn run_with(deck: &str) -> (Model, Result<(), RunError>) {
    let commands = parse_deck(deck, "t.dat").unwrap();
    let mut exec = Executor::new(Box::new(std::io::sink()), "t.dat");
    let r = exec.run(&commands);
    (exec.model, r)
}

fn run(deck: &str) -> Model {
    let (m, r) = run_with(deck);
    r.unwrap_or_else(|e| panic!("deck failed: {e}"));
    m
}

fn error_of(deck: &str) -> String {
    match run_with(deck).1 {
        Err(e) => e.to_string(),
        Ok(()) => panic!("the deck ran"),
    }
}

/// A small deterministic generator (xorshift) for the sample points.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Whether the point `p` (the block's reference frame, about its centroid) lies inside the
/// convex `part`, by more than `margin` behind every face plane.
fn inside(part: &Part, p: DVec3, margin: f64) -> bool {
    let s: &Shape = &part.shape;
    s.faces.iter().zip(&s.normals).all(|(f, n)| n.dot(p - (part.offset + s.vertices[f[0] as usize])) < -margin)
}

/// Whether `p` is in any part by less than `margin` of a face plane (on a boundary).
fn near_boundary(part: &Part, p: DVec3, margin: f64) -> bool {
    let s: &Shape = &part.shape;
    let d = s.faces.iter().zip(&s.normals).map(|(f, n)| n.dot(p - (part.offset + s.vertices[f[0] as usize]))).fold(f64::NEG_INFINITY, f64::max);
    d.abs() <= margin
}

/// Cuts the voxel block and checks its parts: `expected` of them, each convex and closed, their
/// volumes summing to the block's to round-off, and, at random points of its box, every point
/// inside a voxel inside exactly one part and every other point in none.
fn check_cut(voxels: &[[i32; 3]], expected: usize) -> (Shape, MassProperties, Vec<Part>) {
    let (shape, props) = shape_from_faces(&voxel_faces(voxels, 1.0, [0.0; 3])).unwrap();
    assert!(!shape.convex);
    let parts = decompose::parts_of(&shape, props.volume).unwrap();
    assert_eq!(parts.len(), expected, "parts");
    let mut total = 0.0;
    for p in &parts {
        assert!(p.shape.convex);
        // Each part is a closed surface of its own: its volume by the divergence theorem.
        let q = blockdem::d3::geometry::mass_properties(&p.shape.vertices, &p.shape.faces);
        assert!(q.volume > 0.0 && q.centroid.length() < 1e-12, "a part about its centroid");
        total += q.volume;
    }
    assert!((total - props.volume).abs() < 1e-12 * props.volume, "{total} vs {}", props.volume);
    let mut rng = Rng(0x9e3779b97f4a7c15);
    let (mut hit, mut missed) = (0, 0);
    for _ in 0..4000 {
        let g = DVec3::new(rng.next() * 3.0 - 0.25, rng.next() * 3.0 - 0.25, rng.next() * 3.0 - 0.25);
        let local = g - props.centroid;
        if parts.iter().any(|p| near_boundary(p, local, 1e-9)) {
            continue;
        }
        let cell = [g.x.floor() as i32, g.y.floor() as i32, g.z.floor() as i32];
        let count = parts.iter().filter(|p| inside(p, local, 1e-9)).count();
        if voxels.contains(&cell) {
            assert_eq!(count, 1, "{g} is in the block and in {count} parts");
            hit += 1;
        } else {
            assert_eq!(count, 0, "{g} is outside the block but in {count} parts");
            missed += 1;
        }
    }
    assert!(hit > 100 && missed > 100, "{hit} {missed}");
    (shape, props, parts)
}

#[test]
fn an_l_prism_is_two_convex_parts_that_fill_it() {
    check_cut(&L, 2);
}

#[test]
fn a_u_block_is_three_convex_parts_the_notch_floor_cuts_at_once() {
    let (_, _, parts) = check_cut(&U, 3);
    // The first cut is the notch floor's plane (z = 1), on which both reflex edges lie: a base
    // of three voxels' volume and two prongs of one each.
    let mut volumes: Vec<f64> = parts.iter().map(|p| blockdem::d3::geometry::mass_properties(&p.shape.vertices, &p.shape.faces).volume).collect();
    volumes.sort_by(f64::total_cmp);
    for (v, want) in volumes.iter().zip([1.0, 1.0, 3.0]) {
        assert!((v - want).abs() < 1e-12, "{volumes:?}");
    }
}

#[test]
fn a_cube_less_a_corner_is_cut_into_convex_parts_that_fill_it() {
    let (_, _, parts) = check_cut(&CORNER, 3);
    assert!(parts.iter().all(|p| p.shape.convex));
}

#[test]
fn a_turned_star_prism_is_cut_into_convex_parts_that_fill_it() {
    // A five-pointed star (tips at radius 1, notches at 0.4: its sides' planes pass close to
    // other corners, so the cuts leave slivers), 0.5 high, turned about an oblique axis: its top
    // and bottom fanned from their centres.
    let star: Vec<DVec3> = (0..10)
        .map(|k| {
            let (r, a) = (if k % 2 == 0 { 1.0 } else { 0.4 }, std::f64::consts::TAU * k as f64 / 10.0);
            DVec3::new(r * a.cos(), r * a.sin(), 0.0)
        })
        .collect();
    let q = glam::DQuat::from_axis_angle(DVec3::new(0.3, -0.5, 0.8).normalize(), 0.7);
    let at = |p: DVec3| (q * p + DVec3::new(10.0, -3.0, 5.0)).to_array();
    let up = DVec3::Z * 0.5;
    let mut faces = Vec::new();
    for k in 0..10 {
        let (a, b) = (star[k], star[(k + 1) % 10]);
        // Counter-clockwise from outside (p, q, r) is typed (p, r, q).
        faces.push([at(up), at(b + up), at(a + up)]);
        faces.push([at(DVec3::ZERO), at(a), at(b)]);
        faces.push([at(a), at(b + up), at(b)]);
        faces.push([at(a), at(a + up), at(b + up)]);
    }
    let (shape, props) = shape_from_faces(&faces).unwrap();
    assert!(!shape.convex);
    let parts = decompose::parts_of(&shape, props.volume).unwrap();
    assert!(parts.len() >= 6, "five arms and a core at least: {}", parts.len());
    let total: f64 = parts.iter().map(|p| blockdem::d3::geometry::mass_properties(&p.shape.vertices, &p.shape.faces).volume).sum();
    assert!((total - props.volume).abs() < 1e-9 * props.volume, "{total} vs {}", props.volume);
    // Points of the star (in its own axes) are in exactly one part.
    let inside_star = |p: DVec3| {
        // Turned into the sector of the tip at angle 0, ±π/5 either side; the polygon runs
        // counter-clockwise, so inside is left of the edge on the point's side of the tip.
        let h = std::f64::consts::PI / 5.0;
        let a = (p.y.atan2(p.x) + h).rem_euclid(2.0 * h) - h;
        let x = p.truncate().length() * glam::DVec2::new(a.cos(), a.sin());
        let tip = glam::DVec2::X;
        let notch = 0.4 * glam::DVec2::new(h.cos(), h.sin().copysign(a));
        if a >= 0.0 {
            (notch - tip).perp_dot(x - tip) > 0.0
        } else {
            (tip - notch).perp_dot(x - notch) > 0.0
        }
    };
    let mut rng = Rng(12345);
    let mut hits = 0;
    for _ in 0..3000 {
        let p = DVec3::new(rng.next() * 2.0 - 1.0, rng.next() * 2.0 - 1.0, rng.next() * 0.5);
        let local = q * p + DVec3::new(10.0, -3.0, 5.0) - props.centroid;
        if parts.iter().any(|part| near_boundary(part, local, 1e-9)) || !inside_star(p) {
            continue;
        }
        hits += 1;
        assert_eq!(parts.iter().filter(|part| inside(part, local, 1e-9)).count(), 1, "{p}");
    }
    assert!(hits > 300, "{hits}");
}

#[test]
fn an_l_block_has_the_mass_properties_of_its_three_cubes() {
    // Density 2000, cubes of side 0.5 at (1, 2, 3): each cube's inertia about its centre is
    // m a²/6, shifted to the block's centroid by the parallel axes.
    let (h, origin, density) = (0.5, [1.0, 2.0, 3.0], 2000.0);
    let deck = format!("START\nPROP MAT=1 D={density} KN=1E8 KS=1E8\n{}", block_command(&voxel_faces(&L, h, origin), 1));
    let model = run(&deck);
    let b = &model.blocks[0];
    assert_eq!(b.parts.len(), 2);
    let centres: Vec<DVec3> = L.iter().map(|v| DVec3::from(origin) + (DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) + 0.5) * h).collect();
    let m = density * h * h * h;
    let centroid = centres.iter().sum::<DVec3>() / 3.0;
    let mut inertia = DMat3::ZERO;
    for c in &centres {
        let r = *c - centroid;
        inertia += DMat3::from_diagonal(DVec3::splat(m * h * h / 6.0))
            + (DMat3::from_diagonal(DVec3::splat(r.length_squared())) - DMat3::from_cols(r * r.x, r * r.y, r * r.z)) * m;
    }
    assert!((b.volume - 3.0 * h * h * h).abs() < 1e-14, "{}", b.volume);
    assert!((b.mass - 3.0 * m).abs() < 1e-9, "{}", b.mass);
    assert!((b.centroid - centroid).length() < 1e-13, "{} vs {centroid}", b.centroid);
    let scale = inertia.x_axis.x;
    for (got, want) in b.inertia_ref.to_cols_array().iter().zip(inertia.to_cols_array()) {
        assert!((got - want).abs() < 1e-12 * scale, "{} vs {inertia}", b.inertia_ref);
    }
    // The parts' vertices lie where the block's are: each a point of the L's box, placed from
    // the block's centroid.
    for p in &b.parts {
        for v in &p.vertices {
            assert!(v.x > 1.0 - 1e-12 && v.x < 2.0 + 1e-12 && v.y > 2.0 - 1e-12 && v.y < 3.0 + 1e-12 && (v.z - 3.0).abs() * (v.z - 3.5).abs() < 1e-12);
        }
    }
}

/// An L of unit cubes (density 2000) dropped 2 cm onto a fixed slab, damped.
fn l_drop(tail: &str) -> String {
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBOX -1 3 -1 3 -1 0\n{}FIX -1 3 -1 3 -1 -0.1\nGRAV 0 0 -10\n{tail}",
        block_command(&voxel_faces(&L, 1.0, [0.0, 0.0, 0.02]), 1)
    )
}

#[test]
fn an_l_block_dropped_on_a_slab_rests_on_its_whole_base() {
    let model = run(&l_drop("DAMP 0.5 200 MASS\nCYCLE 10000\n"));
    let b = &model.blocks[1];
    let weight = b.mass * 10.0;
    let real: Vec<_> = model.contacts.iter().filter(|c| c.category.is_some()).collect();
    // Both parts stand on the slab, each on a face–face contact of its base's area.
    assert_eq!(real.len(), 2);
    let mut areas: Vec<f64> = real.iter().map(|c| c.area).collect();
    areas.sort_by(f64::total_cmp);
    assert!((areas[0] - 1.0).abs() < 1e-6 && (areas[1] - 2.0).abs() < 1e-6, "{areas:?}");
    for c in &real {
        assert_eq!(c.type_name(), "FACE-FACE");
        assert!((c.normal - DVec3::Z).length() < 1e-9);
        assert!(c.logical.iter().all(|l| l.normal_force > 0.0), "every corner of the base presses");
    }
    // The contacts carry the weight, without a moment about the centroid.
    let total: f64 = real.iter().map(|c| c.normal_force()).sum();
    assert!((total - weight).abs() < 1e-6 * weight, "{total} vs {weight}");
    let moment: DVec3 = real.iter().flat_map(|c| c.logical.iter().map(|l| (l.point - b.centroid).cross(DVec3::Z * l.normal_force))).sum();
    assert!(moment.length() < 1e-6 * weight, "{moment}");
    // Level, at rest, at the L's centroid (5/6, 5/6) above its base.
    assert!(b.velocity.length() < 1e-6 && b.angular_velocity.length() < 1e-6);
    // (Tilted by the springs' give only: their mean lies off the centroid, 1e-5 rad here.)
    assert!(b.orientation.to_scaled_axis().length() < 1e-4, "{}", b.orientation);
    assert!((b.centroid.x - 5.0 / 6.0).abs() < 1e-4 && (b.centroid.y - 5.0 / 6.0).abs() < 1e-4 && (b.centroid.z - 0.5).abs() < 1e-3, "{}", b.centroid);
}

#[test]
fn the_ledger_balances_on_the_l_block_rocking_on_the_slab() {
    // Set on the slab undamped, the L sinks onto its springs and rocks (their mean lies off its
    // centroid), its corners slipping: gravity's work goes to kinetic and strain energy and to
    // friction. (A drop adds the contacts' onset error, a spring found already compressed by
    // up to vΔt, some per cent per impact for convex blocks as well.)
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBOX -1 3 -1 3 -1 0\n{}FIX -1 3 -1 3 -1 -0.1\nGRAV 0 0 -10\nCYCLE 0\n",
        block_command(&voxel_faces(&L, 1.0, [0.0; 3]), 1)
    );
    let mut model = run(&deck);
    let e0 = model.energies();
    let mut backend = blockdem::d3::cpu::CpuBackend::new();
    let (mut worst, mut scale): (f64, f64) = (0.0, 0.0);
    for _ in 0..300 {
        backend.run(&mut model, 10, &mut |_| true).unwrap();
        let e = model.energies();
        scale = scale.max(e.scale());
        worst = worst.max((e.ledger() - e0.ledger()).abs());
    }
    let e = model.energies();
    assert!(e.external_work > 0.0 && e.strain > 0.0 && e.friction > 0.0, "{e:?}");
    // (6.5e-3 of the largest term here.)
    assert!(worst < 1e-2 * scale, "ledger drift {:e}", worst / scale);
    // Damped, at rest after a drop: the work of gravity is the strain energy and what the
    // damping took.
    let e = run(&l_drop("DAMP 0.5 200 MASS\nCYCLE 10000\n")).energies();
    assert!(e.ledger().abs() < 1e-4 * e.scale(), "{e:?}");
}

/// A U block (cubes of side 1, its notch x ∈ [1, 2], z ∈ [1, 2]) fixed, and a 0.6 m cube of
/// density 2000 set on the notch's floor.
fn notch(tail: &str) -> String {
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\n{}BOX 1.2 1.8 0.2 0.8 1.0 1.6\nFIX -1 4 -1 2 -1 1.0\nGRAV 0 0 -10\n{tail}",
        block_command(&voxel_faces(&U, 1.0, [0.0; 3]), 1)
    )
}

#[test]
fn a_cube_in_the_notch_of_a_u_block_rests_on_the_notch_floor() {
    let model = run(&notch("DAMP 0.5 200 MASS\nCYCLE 6000\n"));
    let (u, cube) = (&model.blocks[0], &model.blocks[1]);
    assert!(u.fixed && u.parts.len() == 3);
    let weight = cube.mass * 10.0;
    // Never a contact between two parts of one block.
    assert!(model.contacts.iter().all(|c| c.blocks[0] != c.blocks[1]));
    let real: Vec<_> = model.contacts.iter().filter(|c| c.category.is_some()).collect();
    assert_eq!(real.len(), 1, "{real:?}");
    let c = real[0];
    // The U's part in touch is its base (three voxels' volume), whose top is the notch floor.
    let base = &u.parts[c.parts[0] as usize];
    let volume = blockdem::d3::geometry::mass_properties(&base.shape.vertices, &base.shape.faces).volume;
    assert!((volume - 3.0).abs() < 1e-12, "{volume}");
    assert!(base.vertices.iter().map(|v| v.z).fold(f64::NEG_INFINITY, f64::max) == 1.0);
    assert_eq!(c.type_name(), "FACE-FACE");
    assert!((c.area - 0.36).abs() < 1e-9, "{}", c.area);
    assert!((c.normal_force() - weight).abs() < 1e-6 * weight, "{} vs {weight}", c.normal_force());
    // Not fallen through, not pushed out: on the floor where it was set, at rest.
    assert!((cube.centroid - DVec3::new(1.5, 0.5, 1.3)).length() < 1e-4, "{}", cube.centroid);
    assert!(cube.velocity.length() < 1e-6);
}

#[test]
fn a_cube_pushed_in_a_snug_notch_is_kept_in_by_its_walls() {
    // The cube fills the notch but for 1 mm each side; set 5 cm above the notch's floor with a
    // push of 0.3 m/s along x, frictionless and undamped, it falls to the floor and rattles
    // between the prongs' walls.
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0\n{}BOX 1.001 1.999 0.1 0.9 1.05 2.048\nFIX -1 4 -1 2 -1 1.0\nGRAV 0 0 -10\n\
         VELOCITY 1.0 2.0 0.0 1.0 1.0 2.1 0.3 0 0\nCYCLE 0\n",
        block_command(&voxel_faces(&U, 1.0, [0.0; 3]), 1)
    );
    let mut model = run(&deck);
    let mut backend = blockdem::d3::cpu::CpuBackend::new();
    let (mut walls, mut floor, mut widest) = (false, false, 0.0f64);
    for _ in 0..400 {
        backend.run(&mut model, 10, &mut |_| true).unwrap();
        for c in model.contacts.iter().filter(|c| c.category.is_some() && c.normal_force() > 0.0) {
            walls |= c.normal.x.abs() > 0.99;
            floor |= c.normal.z.abs() > 0.99;
        }
        let cube = &model.blocks[1];
        widest = widest.max((cube.centroid.x - 1.5).abs());
        assert!(cube.centroid.z > 1.49 && cube.centroid.z < 1.6, "{}", cube.centroid);
    }
    assert!(walls && floor, "walls {walls}, floor {floor}");
    // To a wall, 1 mm away, and back, each time within the give of the wall's springs (at
    // most v·√(m/k) = 0.3 · √(1594/4e8) = 0.6 mm).
    assert!(widest > 1e-3 && widest < 1.7e-3, "{widest}");
}

#[test]
fn save_and_restart_of_a_concave_block_go_on_bit_for_bit() {
    let dir = std::env::temp_dir().join(format!("blockdem-concave-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("l.sav");
    let first = run(&l_drop(&format!("CYCLE 300\nSAVE {}\n", file.display())));
    let saved = blockdem::d3::restart::load(&file).unwrap();
    assert_eq!(saved.model, first, "the parts and the contacts' parts read back as saved");
    assert!(saved.model.contacts.iter().any(|c| c.parts[1] == 1));
    let again = run(&format!("RESTART {}\nCYCLE 300\n", file.display()));
    assert_eq!(again, run(&l_drop("CYCLE 600\n")), "CYCLE 300, SAVE, RESTART, CYCLE 300 is CYCLE 600");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_outputs_show_the_whole_block() {
    let model = run(&l_drop("CYCLE 10\n"));
    let json = blockdem::d3::output::state_json(&model, None);
    let b = &json["blocks"][1];
    // The L's surface: its 8 + 8 corners less the four the cubes share, of 2 × 14 sides less 4.
    assert_eq!(b["vertices"].as_array().unwrap().len(), model.blocks[1].shape.vertices.len());
    assert_eq!(b["faces"].as_array().unwrap().len(), 2 * (18 - 4));
    let table = blockdem::d3::output::blocks_table(&model);
    assert_eq!(table.lines().filter(|l| l.trim_start().starts_with("2 ")).count(), 1, "{table}");
}

#[test]
fn a_self_touching_surface_is_an_error_naming_the_block() {
    // Two cubes that share one corner: a closed surface, but two sheets meet at that vertex.
    let faces = voxel_faces(&[[0, 0, 0], [1, 1, 1]], 1.0, [0.0; 3]);
    let deck = format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBOX 5 6 5 6 5 6\n{}", block_command(&faces, 1));
    let message = error_of(&deck);
    assert!(message.contains("block 2") && message.contains("touches itself at a vertex"), "{message}");
    // Two cubes apart, typed as one block: two surfaces.
    let faces = voxel_faces(&[[0, 0, 0], [2, 0, 0]], 1.0, [0.0; 3]);
    let message = error_of(&format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\n{}", block_command(&faces, 1)));
    assert!(message.contains("block 1") && message.contains("separate closed surfaces"), "{message}");
}

/// The total momentum and angular momentum (about the origin) of the free blocks.
fn momenta(model: &Model) -> (DVec3, DVec3) {
    let free = model.blocks.iter().filter(|b| !b.fixed);
    let p: DVec3 = free.clone().map(|b| b.velocity * b.mass).sum();
    let l: DVec3 = free.map(|b| b.angular_momentum + b.centroid.cross(b.velocity * b.mass)).sum();
    (p, l)
}

#[test]
fn split_cuts_a_concave_block_into_as_many_blocks_as_the_plane_leaves() {
    // The U (fixed, cubes of side 1) cut across its prongs at z = 1.5: behind the plane a U of
    // shorter prongs (concave, 3 parts), in front the prongs' two tops (convex): three blocks,
    // the volumes 3 + 2·0.5 and 2 · 0.5, the first keeping the U's id.
    let deck = format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\n{}SPLIT 0 0 1.5 0 0 1\n", block_command(&voxel_faces(&U, 1.0, [0.0; 3]), 1));
    let model = run(&deck);
    assert_eq!(model.blocks.len(), 3);
    assert_eq!(model.blocks.iter().map(|b| b.id).collect::<Vec<_>>(), [1, 2, 3]);
    let (base, tops) = (&model.blocks[0], &model.blocks[1..]);
    assert!((base.volume - 4.0).abs() < 1e-12 && base.parts.len() == 3, "{} in {} parts", base.volume, base.parts.len());
    let part_volumes: f64 = base.parts.iter().map(|p| blockdem::d3::geometry::mass_properties(&p.shape.vertices, &p.shape.faces).volume).sum();
    assert!((part_volumes - 4.0).abs() < 1e-12);
    for t in tops {
        assert!(t.parts.is_empty() && t.shape.convex && (t.volume - 0.5).abs() < 1e-12, "{}", t.volume);
        assert!((t.centroid.z - 1.75).abs() < 1e-12 && ((t.centroid.x - 0.5).abs() < 1e-12 || (t.centroid.x - 2.5).abs() < 1e-12), "{}", t.centroid);
    }
    // The L cut at x = 1 between its cubes: two convex blocks, a 1 × 2 × 1 bar and a cube.
    let deck = format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\n{}SPLIT 1 0 0 1 0 0\n", block_command(&voxel_faces(&L, 1.0, [0.0; 3]), 1));
    let model = run(&deck);
    assert_eq!(model.blocks.len(), 2);
    assert!(model.blocks.iter().all(|b| b.parts.is_empty() && b.shape.convex));
    assert!((model.blocks[0].volume - 2.0).abs() < 1e-12 && (model.blocks[1].volume - 1.0).abs() < 1e-12);
}

#[test]
fn a_spinning_concave_block_split_keeps_its_momenta_and_its_pieces_run() {
    // The L thrown spinning, cut along its height on a plane oblique to its sides (clear of the
    // slab, which a SPLIT's plane would cut too): two L-shaped pieces, both concave, each cut
    // into convex parts afresh; they move with the parent's motion at their centroids (momentum
    // and angular momentum kept), and fall onto the slab and settle as blocks of their own.
    let deck = l_drop("VELOCITY -1 3 -1 3 0 2 0.3 -0.2 0.1 0.5 -0.4 1.0\nCYCLE 0\n");
    let before = momenta(&run(&deck));
    let cut = run(&format!("{deck}SPLIT 0.5 0.5 0.6 0.1 0.05 1\n"));
    assert_eq!(cut.blocks.len(), 3, "the slab and two pieces");
    assert!(cut.blocks[1..].iter().all(|b| b.parts.len() == 2), "both L-shaped");
    let after = momenta(&cut);
    assert!((after.0 - before.0).length() < 1e-9 * before.0.length(), "{:?} vs {:?}", after.0, before.0);
    assert!((after.1 - before.1).length() < 1e-9 * before.1.length(), "{:?} vs {:?}", after.1, before.1);
    let total: f64 = cut.blocks[1..].iter().map(|b| b.volume).sum();
    assert!((total - 3.0).abs() < 1e-12, "{total}");
    let settled = run(&format!("{deck}SPLIT 0.5 0.5 0.6 0.1 0.05 1\nDAMP 0.5 50 MASS\nCYCLE 12000\n"));
    for b in &settled.blocks[1..] {
        assert!(b.velocity.length() < 1e-6 && b.centroid.z > 0.0, "block {} at {} moving {}", b.id, b.centroid, b.velocity);
    }
    // The lower piece carries the upper on the cut, the slab carries both.
    let weight = |k: usize| settled.blocks[k].mass * 10.0;
    // (The force on a contact's second block: n·Fn + Fs, its shear carrying part of the weight
    // on the tilted cut.)
    let carried =
        |a: u32, b: u32| -> f64 { settled.contacts.iter().filter(|c| c.blocks == [a, b]).map(|c| (c.normal * c.normal_force() + c.shear_force()).z).sum() };
    assert!((carried(1, 2) - weight(2)).abs() < 1e-3 * weight(2), "{} vs {}", carried(1, 2), weight(2));
    assert!((carried(0, 1) + carried(0, 2) - weight(1) - weight(2)).abs() < 1e-3 * (weight(1) + weight(2)));
}

#[test]
fn a_simply_deformable_concave_block_strains_as_one_body() {
    // The L made simply deformable and dropped: its parts are placed by the one map
    // c + (I + ε)·R·x, so each corner the parts share with the block's surface stays where the
    // block's own vertex is (the parts fill the strained block, no gap opens between them), and
    // the ledger balances with the strain's energy in it.
    let model = run(&l_drop("PROP MAT=1 K=5E7 G=3E7\nCHANGE -1 3 -1 3 0 2 SDEF\nDAMP 0.2 50 MASS\nCYCLE 3000\n"));
    let b = &model.blocks[1];
    let s = b.sdef.expect("simply deformable");
    assert!(s.strain.iter().any(|e| e.abs() > 1e-7), "it strains under its weight: {:?}", s.strain);
    let mut shared = 0;
    for p in &b.parts {
        for (g, l) in p.vertices.iter().zip(&p.shape.vertices) {
            let reference = p.offset + *l;
            if let Some(k) = b.shape.vertices.iter().position(|v| (*v - reference).length() < 1e-12) {
                assert!((b.vertices[k] - *g).length() < 1e-12, "a part's corner {g} off the block's {}", b.vertices[k]);
                shared += 1;
            }
        }
    }
    assert!(shared >= 12, "{shared}");
    let real: Vec<_> = model.contacts.iter().filter(|c| c.category.is_some()).collect();
    assert_eq!(real.len(), 2, "both parts stand on the slab");
    let e = model.energies();
    assert!(e.ledger().abs() < 1e-2 * e.scale(), "{e:?}");
}

#[test]
fn a_concave_block_cracks_by_the_point_load_law() {
    // The L, its material given a tensile strength (constitutive 1: the point-load law), is
    // squeezed between the slab and a heavy block pressed down on its corner cube: the crack
    // cuts it, and the run goes on with its pieces (the concave parent's cut, `split::crack`).
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nPROP MAT=2 D=2000 KN=1E9 KS=1E9 F=0.5 TF=1E4\nBOX -1 3 -1 3 -1 0\n{}\
         BOX 0.25 0.75 0.25 0.75 1.0 1.5\nFIX -1 3 -1 3 -1 -0.1\nGRAV 0 0 -10\nLOAD 0.25 0.75 0.25 0.75 1 1.5 0 0 -2E5\nDAMP 0.5 100 MASS\nCYCLE 0\n",
        block_command(&voxel_faces(&L, 1.0, [0.0; 3]), 2)
    );
    let mut model = run(&deck);
    let mut backend = blockdem::d3::cpu::CpuBackend::new();
    // Up to the first crack (its pieces, squeezed as the parent was, crack on: a cascade, as
    // 2D's point-load law gives).
    let mut report = blockdem::driver::CycleReport::default();
    while model.blocks.len() == 3 && model.cycle < 2000 {
        report = backend.run(&mut model, 1, &mut |_| true).unwrap();
    }
    assert!(model.blocks.len() >= 4, "the L cracked: {} blocks at cycle {}", model.blocks.len(), model.cycle);
    assert_eq!(report.cracks.len(), 1, "{:?}", report.cracks);
    assert_eq!(report.cracks[0].criterion, "POINT-LOAD");
    assert!(report.cracks[0].value >= 1e4);
    let l_volume: f64 = model.blocks.iter().filter(|b| b.material == 2).map(|b| b.volume).sum();
    assert!((l_volume - 3.0).abs() < 1e-9, "its pieces make the L: {l_volume}");
}
