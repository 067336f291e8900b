//! D3's SPLIT (issue 31's extension): the pieces of a cut block are closed, outward, convex
//! polyhedra with their own exact mass properties, momentum is kept, the contacts are rebuilt
//! between cycles, concave parents cut into their pieces, and bad input refused naming the line.

use blockdem::d3::deck::parse_deck;
use blockdem::d3::exec::Executor;
use blockdem::d3::model::Model;
use glam::{DMat3, DVec3};

/// Runs a deck; the model, the run log and the error, if any.
fn run(deck: &str) -> (Model, String, Result<(), String>) {
    let mut log = Vec::new();
    let (model, result) = match parse_deck(deck, "t.dat") {
        Ok(commands) => {
            let mut exec = Executor::new(Box::new(&mut log), "t.dat");
            let r = exec.run(&commands).map_err(|e| e.to_string());
            (exec.model, r)
        }
        Err(e) => (Model::default(), Err(e.to_string())),
    };
    (model, String::from_utf8(log).unwrap(), result)
}

fn ok(deck: &str) -> (Model, String) {
    let (m, log, r) = run(deck);
    r.unwrap_or_else(|e| panic!("{e}\n{log}"));
    (m, log)
}

const PROPS: &str = "START\nPROP MAT=1 D=1000 KN=1E9 KS=1E9 F=0.5\n";

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

#[test]
fn a_plane_across_a_box_gives_two_boxes_with_exact_mass_properties() {
    let (m, log) = ok(&format!("{PROPS}BOX 0 1 0 2 0 3\nSPLIT 0.3 0 0 1 0 0\n"));
    assert!(log.contains("SPLIT: 1 BLOCKS CUT (1 -> 1 + 2)"), "{log}");
    assert_eq!(m.blocks.len(), 2);
    // The piece behind the plane (x < 0.3) keeps the parent's id and index.
    let (a, b) = (&m.blocks[0], &m.blocks[1]);
    assert_eq!((a.id, b.id), (1, 2));
    for (blk, (x0, x1)) in [(a, (0.0, 0.3)), (b, (0.3, 1.0))] {
        let w: f64 = x1 - x0;
        assert!(blk.shape.convex);
        assert!(close(blk.volume, w * 6.0, 1e-12), "{}", blk.volume);
        assert!((blk.centroid - DVec3::new(0.5 * (x0 + x1), 1.0, 1.5)).length() < 1e-12, "{}", blk.centroid);
        let mass = 1000.0 * w * 6.0;
        assert!(close(blk.mass, mass, 1e-12));
        // A box's principal moments m(b² + c²)/12 about the global axes.
        let expected = DMat3::from_diagonal(DVec3::new(4.0 + 9.0, w * w + 9.0, w * w + 4.0) * (mass / 12.0));
        let i = blk.inertia();
        for k in 0..3 {
            assert!((i.col(k) - expected.col(k)).length() <= 1e-9 * mass, "{i:?} vs {expected:?}");
        }
        // The piece is a box: its eight corners, no more (the crossings of the sides' diagonals
        // with the cut and the cap's centre are no vertices, `split::fewest_faces`), each on
        // its box's surface.
        for v in &blk.vertices {
            let inside = v.x >= x0 - 1e-12 && v.x <= x1 + 1e-12 && (-1e-12..=2.0 + 1e-12).contains(&v.y) && (-1e-12..=3.0 + 1e-12).contains(&v.z);
            let on_side = [v.x - x0, v.x - x1, v.y, v.y - 2.0, v.z, v.z - 3.0].iter().any(|d| d.abs() < 1e-12);
            assert!(inside && on_side, "{v}");
        }
        assert_eq!(blk.vertices.len(), 8);
    }
}

#[test]
fn a_plane_through_vertices_cuts_a_cube_into_two_prisms() {
    // The diagonal plane x = y passes through two vertical edges of the unit cube.
    let (m, _) = ok(&format!("{PROPS}BOX 0 1 0 1 0 1\nSPLIT 0 0 0 1 -1 0\n"));
    assert_eq!(m.blocks.len(), 2);
    for b in &m.blocks {
        // Six corners: the cut's points are the cap's corners, its centre no vertex
        // (`split::fewest_faces`), and each square side's diagonal the cut crosses leaves no
        // point on the side's edge.
        assert!(close(b.volume, 0.5, 1e-12) && b.shape.convex && b.vertices.len() == 6, "{} {}", b.volume, b.vertices.len());
    }
    // x − y < 0 behind: the prism with centroid (1/3, 2/3, 1/2).
    assert!((m.blocks[0].centroid - DVec3::new(1.0 / 3.0, 2.0 / 3.0, 0.5)).length() < 1e-12);
}

#[test]
fn a_moving_spinning_block_cut_obliquely_keeps_its_momentum() {
    // A rotated block (its faces typed by hand from a turned box), given a velocity and a spin,
    // cut by an oblique plane off its centroid.
    let q = glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
    let corners: Vec<DVec3> = (0..8)
        .map(|i| q * DVec3::new(if i & 1 == 0 { -0.5 } else { 0.5 }, if i & 2 == 0 { -1.0 } else { 1.0 }, if i & 4 == 0 { -0.75 } else { 0.75 }))
        .collect();
    let sides: [[usize; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let mut block = String::from("BLOCK\n");
    for s in sides {
        for tri in [[s[0], s[2], s[1]], [s[0], s[3], s[2]]] {
            block.push('+');
            for k in tri {
                let p = corners[k] + DVec3::new(5.0, 5.0, 5.0);
                block.push_str(&format!(" {} {} {}", p.x, p.y, p.z));
            }
            block.push('\n');
        }
    }
    let before = format!("{PROPS}{block}VELOCITY 4 6 4 6 4 6 1 -2 0.5 3 1 -2\n");
    let (parent, _) = ok(&before);
    let (m, log) = ok(&format!("{before}SPLIT 5.1 5.2 4.9 0.3 -0.8 1\n"));
    assert!(log.contains("SPLIT: 1 BLOCKS CUT"), "{log}");
    let p = &parent.blocks[0];
    let mass: f64 = m.blocks.iter().map(|b| b.mass).sum();
    let momentum: DVec3 = m.blocks.iter().map(|b| b.mass * b.velocity).sum();
    let centroid: DVec3 = m.blocks.iter().map(|b| b.mass * b.centroid).sum::<DVec3>() / mass;
    let spin: DVec3 = m.blocks.iter().map(|b| b.angular_momentum + b.mass * (b.centroid - p.centroid).cross(b.velocity - p.velocity)).sum();
    assert!(close(mass, p.mass, 1e-12), "{mass} vs {}", p.mass);
    assert!((centroid - p.centroid).length() < 1e-12, "{centroid} vs {}", p.centroid);
    assert!((momentum - p.mass * p.velocity).length() <= 1e-12 * p.mass * p.velocity.length(), "{momentum}");
    assert!((spin - p.angular_momentum).length() <= 1e-10 * p.angular_momentum.length(), "{spin} vs {}", p.angular_momentum);
    for b in &m.blocks {
        assert!(b.shape.convex);
        assert!((b.angular_velocity - p.angular_velocity).length() < 1e-12);
        assert!((b.velocity - p.velocity_at(b.centroid)).length() < 1e-12);
        // Every face's outward normal points away from the piece's centroid (convex).
        for (k, f) in b.shape.faces.iter().enumerate() {
            assert!(b.face_normal(k).dot(b.vertices[f[0] as usize] - b.centroid) > 0.0, "block {} face {k}", b.id);
        }
    }
    // The kinetic energy is the parent's (the pieces move as it did).
    let ke: f64 = m.blocks.iter().map(|b| b.kinetic_energy()).sum();
    assert!(close(ke, p.kinetic_energy(), 1e-10), "{ke} vs {}", p.kinetic_energy());
}

#[test]
fn split_pieces_touch_and_settle_as_the_parent_did() {
    // A 1 × 1 × 2 column on a base cut at mid-height: the lower piece carries the upper's weight
    // across the cut (a face–face contact found by the next cycle's neighbour lists).
    let deck = format!(
        "{PROPS}BOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 2\nFIX -1 2 -1 2 -1 -0.1\nSPLIT 0.5 0.5 1 0 0 1 MAT 1 CONS 1\nGRAV 0 0 -10\nDAMP 1 160 MASS\nCYCLE 1500\n"
    );
    let (m, log) = ok(&deck);
    assert!(log.contains("SPLIT: 1 BLOCKS CUT (2 -> 2 + 3)"), "{log}");
    let cut = m.contacts.iter().find(|c| c.blocks == [1, 2]).expect("a contact across the cut");
    assert_eq!(cut.type_name(), "FACE-FACE");
    assert!(close(cut.normal_force(), 1000.0 * 10.0, 1e-6), "{}", cut.normal_force());
    let base = m.contacts.iter().find(|c| c.blocks == [0, 1]).expect("the base contact");
    assert!(close(base.normal_force(), 2.0 * 1000.0 * 10.0, 1e-6), "{}", base.normal_force());
}

#[test]
fn a_plane_that_crosses_nothing_warns_and_splits_are_repeatable() {
    let (m, log) = ok(&format!("{PROPS}BOX 0 1 0 1 0 1\nSPLIT 0 0 5 0 0 1\nSPLIT 0 0 1 0 0 1\n"));
    assert_eq!(m.blocks.len(), 1);
    assert_eq!(log.matches("WARNING: SPLIT: the plane crosses no block").count(), 2, "a plane on a face crosses nothing\n{log}");
    // Three cuts of a cube into eight: each later cut crosses every piece before it.
    let (m, log) = ok(&format!("{PROPS}BOX 0 1 0 1 0 1\nSPLIT 0.5 0 0 1 0 0\nSPLIT 0 0.5 0 0 1 0\nSPLIT 0 0 0.5 0 0 1\n"));
    assert_eq!(m.blocks.len(), 8, "{log}");
    let ids: Vec<u32> = m.blocks.iter().map(|b| b.id).collect();
    assert_eq!(ids, [1, 2, 3, 4, 5, 6, 7, 8]);
    for b in &m.blocks {
        assert!(close(b.volume, 0.125, 1e-12) && b.shape.convex);
    }
}

#[test]
fn concave_parents_are_cut_and_bad_split_input_is_refused_at_its_line() {
    // A cube with an inverted pyramid pressed into its top: star-shaped about (0.5, 0.5, 0.2),
    // so each face is typed with its normal away from that point.
    let c = [
        DVec3::new(0., 0., 0.),
        DVec3::new(1., 0., 0.),
        DVec3::new(1., 1., 0.),
        DVec3::new(0., 1., 0.),
        DVec3::new(0., 0., 1.),
        DVec3::new(1., 0., 1.),
        DVec3::new(1., 1., 1.),
        DVec3::new(0., 1., 1.),
        DVec3::new(0.5, 0.5, 0.5),
    ];
    let tris = [
        [0, 1, 2],
        [0, 2, 3],
        [0, 1, 5],
        [0, 5, 4],
        [1, 2, 6],
        [1, 6, 5],
        [2, 3, 7],
        [2, 7, 6],
        [3, 0, 4],
        [3, 4, 7],
        [4, 5, 8],
        [5, 6, 8],
        [6, 7, 8],
        [7, 4, 8],
    ];
    let inside = DVec3::new(0.5, 0.5, 0.2);
    let mut block = String::from("BLOCK\n");
    for t in tris {
        let [a, b, d] = t.map(|k| c[k]);
        let outward = (b - a).cross(d - a).dot((a + b + d) / 3.0 - inside) > 0.0;
        let typed = if outward { [a, d, b] } else { [a, b, d] };
        block.push('+');
        for p in typed {
            block.push_str(&format!(" {} {} {}", p.x, p.y, p.z));
        }
        block.push('\n');
    }
    // Cut through the pyramid's apex: two halves, each still notched (concave, in convex parts),
    // of volume (1 − 1/6)/2 each.
    let deck = format!("{PROPS}{block}SPLIT 0.5 0.5 0.5 1 0 0\n");
    let (m, _, r) = run(&deck);
    r.unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.blocks.len(), 2);
    for b in &m.blocks {
        assert!(!b.parts.is_empty() && (b.volume - 5.0 / 12.0).abs() < 1e-12, "{} in {} parts", b.volume, b.parts.len());
    }

    for (text, expect) in [
        ("SPLIT 0 0 0 1 0", "SPLIT takes x y z nx ny nz"),
        ("SPLIT 0 0 0 0 0 0", "must be a non-zero vector"),
        ("SPLIT 0 0 0 1 0 0 MAT 0", "the material number n must be 1 or more"),
        ("SPLIT 0 0 0 1 0 0 7", "SPLIT takes x y z nx ny nz"),
        ("SPLIT 0 0 0 1 0 0 FOO", "expected MATERIAL or CONSTITUTIVE"),
    ] {
        let (_, _, r) = run(&format!("{PROPS}BOX 0 1 0 1 0 1\n{text}\n"));
        let e = r.expect_err(text);
        assert!(e.contains("t.dat:4") && e.contains(expect), "{text}: {e}");
    }
}

/// The point-load law's specimen (SL-85-1 ¶35f, constitutive 1): a 1 × 2 × 1 m block squeezed
/// between a fixed base and a platen carrying 1 MN, settled under a TF it cannot reach, then given
/// TF = 0.5 MPa. The loads are the two face–face contacts' resultants at the centres of its top
/// and bottom faces, 1 m apart: (F_top + F_bottom)/(2 d²) = (1.02 + 1.04) MN / 2 m² = 1.03 MPa.
/// The crack holds the load line, its normal across it where the block is longest (y): the plane
/// y = 1 halves it into two unit cubes.
fn squeezed_block(tf_after: f64) -> String {
    format!(
        "START\nPROP MAT=1 D=1000 KN=1E10 KS=1E10 F=0.5\nPROP MAT=2 D=1000 KN=1E10 KS=1E10 F=0.5 TF=1E9\n\
         BOX -1 2 -1 3 -1 0\nBOX 0 1 0 2 0 1 MAT 2 CONS 1\nBOX 0 1 0 2 1 2\nFIX -1 2 -1 3 -1 -0.1\n\
         LOAD 0 1 0 2 1 2 0 0 -1E6\nGRAV 0 0 -10\nDAMP 1 700 MASS\nCYCLE 3000\nPROP MAT=2 TF={tf_after}\nCYCLE 1\n"
    )
}

#[test]
fn the_point_load_law_splits_a_squeezed_block_across_its_length() {
    let (m, log) = ok(&squeezed_block(5e5));
    let line = log.lines().find(|l| l.contains("CRACKED")).unwrap_or_else(|| panic!("no crack:\n{log}"));
    assert!(line.starts_with("BLOCK 2 CRACKED AT CYCLE 3001 (POINT-LOAD ") && line.contains("NEW BLOCK 4"), "{line}");
    let value: f64 = line.split("(POINT-LOAD ").nth(1).and_then(|s| s.split(')').next()).and_then(|s| s.trim().parse().ok()).unwrap();
    assert!((value - 1.03e6).abs() < 0.01 * 1.03e6, "value {value}");
    assert!(line.contains("WITH NORMAL (0.000E+00, 1.000E+00, 0.000E+00)") || line.contains("WITH NORMAL (0.000E+00, -1.000E+00, 0.000E+00)"), "{line}");
    assert_eq!(m.blocks.len(), 4);
    let halves: Vec<_> = m.blocks.iter().filter(|b| b.id == 2 || b.id == 4).collect();
    assert_eq!(halves.len(), 2);
    for b in &halves {
        let (lo, hi) = b.bounds();
        assert!(close(b.volume, 1.0, 1e-9) && close(hi.y - lo.y, 1.0, 1e-6) && close(hi.z - lo.z, 1.0, 1e-6), "block {}: {lo} {hi}", b.id);
        assert_eq!((b.material, b.constitutive), (2, 1));
        assert!(!b.is_sdef(), "a rigid block's pieces are rigid");
    }
    // The crack keeps the contacts' state (`cpu::carry_across_cracks`): each half's parts of the
    // pressed faces keep their old corners' forces, and their new corners on the crack plane
    // start unloaded (point law: a spring per corner), so the springs hold what they held
    // (26.5 J; before, the new corners took their overlap whole and the energy doubled) and the
    // blocks above and below are pushed as they were.
    let e = m.energies();
    assert!(e.released.abs() < 1e-9 * e.strain && close(e.strain, 26.525, 1e-3), "released {}, strain {}", e.released, e.strain);
    assert!(e.ledger().abs() < 1e-6 * e.scale(), "ledger {} of {}", e.ledger(), e.scale());
    let (whole, _) = ok(&squeezed_block(1.2e6));
    assert_eq!(whole.cycle, m.cycle);
    for top in [0usize, 2] {
        let push = |m: &Model| -> f64 { m.contacts.iter().filter(|c| c.blocks.contains(&(top as u32))).flat_map(|c| &c.logical).map(|l| l.normal_force).sum() };
        assert!(close(push(&m), push(&whole), 1e-9), "block {top}: {} after the crack, {} uncracked", push(&m), push(&whole));
    }
    // Blocks 1 and 3 are the halves; 0 and 2 the slab and the block above.
    let pressed = m.contacts.iter().filter(|c| c.blocks.iter().any(|b| [1, 3].contains(b)) && c.blocks.iter().any(|b| [0, 2].contains(b)));
    let unloaded = pressed.flat_map(|c| &c.logical).filter(|l| l.gap < 0.0 && l.normal_force == 0.0).count();
    assert_eq!(unloaded, 8, "the halves' new corners on the pressed faces (two on each face of each half)");
    // Below the criterion nothing cracks.
    let (m, log) = ok(&squeezed_block(1.2e6));
    assert!(!log.contains("CRACKED") && m.blocks.len() == 3, "{log}");
}

/// The joint law (constitutive 2: point-load cracking, joint contacts; SL-85-1 Table A1) on the
/// squeezed block: its face contacts' stiffness is JKN per unit area over their area, shared by
/// their corners, so the halves' contacts (four corners each, on half the area, the new ones
/// taking the state of the old region's side they lie on) carry what the whole face carried: the
/// crack changes the springs' energy by less than 1e-3 of it and the push on the blocks above
/// and below not at all. (JKN·area stays above KN on the halves: ¶5's rule keeps the joint law.)
/// A joint-law block whose material lacks JKN is refused at CYCLE.
#[test]
fn the_joint_law_keeps_a_cracked_faces_stiffness() {
    let deck = squeezed_block(5e5)
        .replace("CONS 1", "CONS 2")
        .replace("BOX -1 2 -1 3 -1 0", "BOX -1 2 -1 3 -1 0 CONS 2")
        .replace("BOX 0 1 0 2 1 2\n", "BOX 0 1 0 2 1 2 CONS 2\n");
    let joints = |deck: &str| {
        deck.replace("F=0.5 TF=1E9", "F=0.5 JKN=2E10 JKS=2E10 JF=0.5 TF=1E9").replace("F=0.5\nPROP MAT=2", "F=0.5 JKN=2E10 JKS=2E10 JF=0.5\nPROP MAT=2")
    };
    let deck = joints(&deck);
    let (m, log) = ok(&deck);
    let line = log.lines().find(|l| l.contains("CRACKED")).unwrap_or_else(|| panic!("no crack:\n{log}"));
    assert!(line.starts_with("BLOCK 2 CRACKED AT CYCLE 3001 (POINT-LOAD ") && line.contains("NEW BLOCK 4"), "{line}");
    let e = m.energies();
    assert!(e.strain > 0.0 && e.released.abs() < 1e-3 * e.strain, "released {} of the springs' {}", e.released, e.strain);
    assert!(e.ledger().abs() < 1e-6 * e.scale(), "ledger {} of {}", e.ledger(), e.scale());
    let whole_deck = joints(
        &squeezed_block(1.2e6)
            .replace("CONS 1", "CONS 2")
            .replace("BOX -1 2 -1 3 -1 0", "BOX -1 2 -1 3 -1 0 CONS 2")
            .replace("BOX 0 1 0 2 1 2\n", "BOX 0 1 0 2 1 2 CONS 2\n"),
    );
    let (whole, _) = ok(&whole_deck);
    for other in [0u32, 2] {
        let push = |m: &Model| -> f64 { m.contacts.iter().filter(|c| c.blocks.contains(&other)).flat_map(|c| &c.logical).map(|l| l.normal_force).sum() };
        assert!(push(&whole) > 1e5 && close(push(&m), push(&whole), 1e-9), "block {other}: {} after the crack, {} uncracked", push(&m), push(&whole));
    }
    // Without JKN: refused at the first CYCLE, naming the block and the material.
    let bad = deck.replace("JKN=2E10 JKS=2E10 JF=0.5\nPROP MAT=2", "\nPROP MAT=2");
    let (_, _, r) = run(&bad);
    let e = r.unwrap_err();
    assert!(
        e.contains("t.dat:11:") && e.contains("constitutive number 2 gives its face contacts the joint law") && e.contains("material 1 needs JKN and JKS"),
        "{e}"
    );
}

/// A press far beyond the rock's strength (`cracking`, "The fragment floor"): a column of three
/// rigid cubes of TF = 2·10⁴ Pa (point-load law) on a fixed slab, a fourth held by BOUNDARY
/// VELOCITY driving down into them at 0.5 m/s. Each crack's pieces crack in turn, each generation
/// sooner than the last (the value grows as 1/d²); before the floor the blocks doubled every
/// cycle or two and 200 cycles never ended. Now every crack's pieces keep at least 1/64 of the
/// cube they came from, the cascade stops, and the fragments are convex blocks of few corners
/// (their flat sides merged, `split::fewest_faces`; they had hundreds of vertices). The floor
/// survives SAVE and RESTART: the restarted run goes on as the straight one, bit for bit.
#[test]
fn a_press_crushes_blocks_down_to_the_fragment_floor_and_no_further() {
    use blockdem::d3::cracking::FRAGMENT_FLOOR;
    let dir = std::env::temp_dir().join(format!("blockdem-d3-floor-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let setup = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5 TF=2E4\nBOX -2 3 -2 3 -1 0\nBOX 0 1 0 1 0 1\n\
                 BOX 0.1 0.9 0.1 0.9 1 2\nBOX 0 1 0 1 2 3\nBOX 0.2 1.2 0 1 3 4\nFIX -2 3 -2 3 -0.6 -0.4\n\
                 BOUNDARY VELOCITY 0 1.2 0 1 3.4 3.6 0 0 -0.5\nGRAV 0 0 -10\n";
    let save = dir.join("floor.sav");
    let (m, log) = ok(&format!("{setup}CYCLE 100\nSAVE {}\nCYCLE 100\n", save.display()));
    let cracks = log.matches("CRACKED").count();
    // The three cubes under the press and the press itself crack, again and again.
    assert!(cracks >= 12, "{cracks} cracks\n{log}");
    // Built: the slab, three cubes of 1, 0.64 and 1 m³, and the press (1 m³).
    let built: Vec<f64> = vec![25.0, 1.0, 0.64, 1.0, 1.0];
    assert!(m.blocks.len() <= 5 + 4 * 63, "{} blocks", m.blocks.len());
    for b in &m.blocks {
        assert!(built.iter().any(|v| close(b.built_volume, *v, 1e-9)), "block {}'s volume as built {}", b.id, b.built_volume);
        assert!(b.volume >= FRAGMENT_FLOOR * b.built_volume * (1.0 - 1e-12), "block {}: {} of {}", b.id, b.volume, b.built_volume);
        assert!(b.shape.convex && b.vertices.len() <= 16, "block {}: {} vertices", b.id, b.vertices.len());
    }
    // Some piece is down at the floor's generation (a cube halved five times or more).
    assert!(m.blocks.iter().any(|b| b.volume < 4.0 * FRAGMENT_FLOOR * b.built_volume), "no fragment near the floor");
    // The last 100 cycles crack less than the first (the cascade ends).
    let late = log
        .lines()
        .filter(|l| {
            l.contains("CRACKED") && l.split("AT CYCLE ").nth(1).and_then(|s| s.split(' ').next()).and_then(|c| c.parse::<u64>().ok()).is_some_and(|c| c > 100)
        })
        .count();
    assert!(late < cracks - late, "{late} of {cracks} cracks after cycle 100");
    // RESTART keeps each piece's volume as built.
    let file = blockdem::d3::restart::load(&save).unwrap();
    assert!(file.model.blocks.iter().any(|b| b.built_volume != b.volume), "the file keeps the pieces' volumes as built");
    let (restarted, _) = ok(&format!("RESTART {}\nCYCLE 100\n", save.display()));
    assert_eq!(restarted, m, "restarted run against the straight one");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A concave parent's convex piece keeps its flat sides' corners only, as a convex parent's do
/// (`split::concave_pieces`, `split::fewest_faces`): the L of three unit voxels cut across its
/// long arm leaves a box of eight vertices (the cross-section's triangulation and the voxel
/// sides' diagonals add none) and an L of its parts.
#[test]
fn a_concave_blocks_convex_piece_has_only_its_corners() {
    use crate::common::voxels::{block_command, voxel_faces, L};
    let block = block_command(&voxel_faces(&L, 1.0, [0.0; 3]), 1);
    let (m, _) = ok(&format!("{PROPS}{block}SPLIT 1.5 0 0 1 0 0\n"));
    assert_eq!(m.blocks.len(), 2);
    let front = m.blocks.iter().find(|b| b.centroid.x > 1.5).expect("the piece in front of the plane");
    assert!(front.shape.convex && front.parts.is_empty() && close(front.volume, 0.5, 1e-12), "{}", front.volume);
    assert_eq!(front.vertices.len(), 8);
    assert_eq!(front.shape.faces.len(), 12);
    let back = m.blocks.iter().find(|b| b.centroid.x < 1.5).expect("the piece behind");
    assert!(!back.shape.convex && !back.parts.is_empty() && close(back.volume, 2.5, 1e-12), "{}", back.volume);
}

/// A point that two flat sides share, within round-off of the line of their common edge, is a
/// corner of neither: `split::fewest_faces` drops it from both sides, so the merged surface is
/// closed. (The crushed L of issue 31's press lost merges this way: the monotone chain keeps each
/// side's first point in its sort order, and where an edge ran across the sort axis that point was
/// the one bulging by round-off; the side across the edge dropped it.) The box
/// [0,1]×[0,0.5]×[0,1] with an extra point on the edge between its y = 0.5 side and its top, 1e-13
/// above the edge: that side's sort axis (glam's `any_orthonormal_vector` of +y) is −z, so the
/// point comes first in its sort.
#[test]
fn a_point_on_a_sides_edge_within_round_off_is_dropped_by_both_sides() {
    use blockdem::d3::split::fewest_faces;
    let centre = DVec3::new(0.5, 0.25, 0.5);
    let m = DVec3::new(0.5, 0.5, 1.0 + 1e-13);
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    // Each side's polygon, fanned from its first point, every triangle typed clockwise seen
    // from outside ((c − a) × (b − a) outward).
    let sides: [Vec<DVec3>; 6] = [
        vec![v(0., 0., 0.), v(1., 0., 0.), v(1., 0., 1.), v(0., 0., 1.)],
        vec![v(0., 0.5, 0.), v(1., 0.5, 0.), v(1., 0.5, 1.), m, v(0., 0.5, 1.)],
        vec![v(0., 0., 1.), v(1., 0., 1.), v(1., 0.5, 1.), m, v(0., 0.5, 1.)],
        vec![v(0., 0., 0.), v(1., 0., 0.), v(1., 0.5, 0.), v(0., 0.5, 0.)],
        vec![v(0., 0., 0.), v(0., 0.5, 0.), v(0., 0.5, 1.), v(0., 0., 1.)],
        vec![v(1., 0., 0.), v(1., 0.5, 0.), v(1., 0.5, 1.), v(1., 0., 1.)],
    ];
    let mut typed = Vec::new();
    for side in &sides {
        for k in 1..side.len() - 1 {
            let [a, mut b, mut c] = [side[0], side[k], side[k + 1]];
            if (c - a).cross(b - a).dot(a - centre) < 0.0 {
                std::mem::swap(&mut b, &mut c);
            }
            typed.push([a, b, c].map(|p| p.to_array()));
        }
    }
    let merged = fewest_faces(&typed, 1e-9 * 0.75);
    let (shape, props) = blockdem::d3::geometry::shape_from_faces(&merged).unwrap_or_else(|e| panic!("the merged sides: {}", e.message));
    assert!(shape.convex);
    assert_eq!(shape.vertices.len(), 8, "the box's corners only");
    assert_eq!(shape.faces.len(), 12);
    assert!(close(props.volume, 0.5, 1e-12), "{}", props.volume);
}

/// The point-load law's pair must oppose: two bricks resting on a third either side of their
/// joint both press it down, their contact points a hair apart across the joint, and however
/// their normals tilt (towards each other by round-off, each then pushing "towards" the other's
/// point) they are no pair: the value (F1 + F2)/(2d²) of such a pair ran to 10²² and cracked this
/// wall of six courses under its own weight at cycle 27. (A brick of the lowest course carries
/// five courses, ~1.6 kN over its 0.2 m height: a true pair's value of ~4·10⁴, under TF.)
#[test]
fn two_blocks_pressing_down_side_by_side_are_no_point_load_pair() {
    let mut deck = String::from("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6 TF=2E5\nBOX -1 3.6 -1 1.2 -1 0\n");
    deck += &crate::common::d3_brick_courses(6, 6);
    deck += "FIX -0.5 3.1 -0.5 0.7 -0.6 -0.4\nGRAV 0 0 -10\nCYCLE 300\n";
    let (m, log) = ok(&deck);
    assert!(!log.contains("CRACKED"), "{log}");
    assert_eq!(m.blocks.len(), 37);
}

/// A run that fails after cracks lists the cracks its last good state holds (the log had lost
/// every crack of a CYCLE that ended in a numerical failure: the backend's report went with the
/// error). A press crushes a cube in its first cycles; a block driven into the slab by a huge
/// load then stops the run some cycles later, rolled back to its last check.
#[test]
fn a_run_that_fails_lists_the_cracks_its_last_good_state_holds() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5 TF=2E4\nBOX -2 3 -2 3 -1 0\nBOX 0 1 0 1 0 1\nBOX 0 1 0 1 1 2\n\
                BOX 4 5 0 1 -0.5 0.5\nFIX -2 3 -2 3 -0.6 -0.4\nBOUNDARY VELOCITY 0 1 0 1 1.4 1.6 0 0 -0.5\nLOAD 3.5 5.5 -1 2 -1 2 -1E11 0 0\nCYCLE 400\n";
    let (m, log, result) = run(deck);
    let e = result.expect_err("the loaded block is driven through the slab");
    assert!(e.contains("overlap") || e.contains("energy") || e.contains("too fast"), "{e}");
    assert!(m.cycle > 0 && m.cycle < 400 && m.cycle % 100 == 0, "rolled back to a check: cycle {}", m.cycle);
    let cracks: Vec<u64> = log.lines().filter_map(|l| l.split(" CRACKED AT CYCLE ").nth(1)).map(|s| s.split(' ').next().unwrap().parse().unwrap()).collect();
    assert!(!cracks.is_empty(), "{log}");
    // Each crack made one block, and each listed is in the state the run went back to.
    assert_eq!(cracks.len(), m.blocks.len() - 4, "{log}");
    assert!(cracks.iter().all(|&c| c <= m.cycle), "{cracks:?} past cycle {}", m.cycle);
}

/// A wall of 60 bricks (constitutive 2: joint contacts) on a fixed slab, struck at mid-height by a
/// 0.3 m steel cube at 30 m/s, `jkn` its material's JKN = JKS (Pa/m), at FRACTION 0.1.
fn struck_wall(jkn: &str, cycles: u64) -> String {
    let mut deck =
        format!("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6 JKN={jkn} JKS={jkn} JF=0.6\nPROP MAT=2 D=7800 KN=1E10 KS=1E10 F=0.3\nBOX -1 5.2 -1 1.2 -1 0\n");
    for course in 0..6 {
        let shift = if course % 2 == 1 { 0.2 } else { 0.0 };
        for k in 0..10 {
            let (x, z) = (shift + 0.4 * k as f64, 0.2 * course as f64);
            deck += &format!("BOX {x:.3} {:.3} 0 0.2 {z:.3} {:.3} CONS 2\n", x + 0.4, z + 0.2);
        }
    }
    deck + &format!(
        "BOX 1.950 2.250 -0.5 -0.2 0.450 0.750 MAT 2\nFIX -0.5 4.7 -0.5 0.7 -0.6 -0.4\nGRAV 0 0 -10\nVELOCITY 1.9 2.3 -0.6 -0.1 0.4 0.8 0 30 0\nCYCLE {cycles}\n"
    )
}

/// ¶5's rule, as in 2D (`Material::contact_law`): a contact whose joint would be softer than one
/// point contact, JKN·area < KN, takes the point law. The struck wall's bricks have JKN·area =
/// 4·10⁸ and 8·10⁸ N/m on their faces against KN = 10⁹: before the rule their contacts switched,
/// as the bricks rocked between face and edge, from four corners of JKN·area/4 to corners of KN at
/// the same overlaps, each switch putting spring energy in, and the run stopped with `energy
/// growing without a source` at the same simulated time at FRACTION 0.1, 0.05 and 0.025 (cycle
/// 2100 at 0.1). With the rule it runs. With JKN = 10¹¹ (the joint law on the bricks' faces) it
/// runs too. The ledger: 0.14 % and −0.07 % of the cube's energy (−0.56 % and 0.26 % before the
/// opened edge–edge springs were booked and swapped corners kept their springs, which the point
/// law of JKN = 10¹⁰ does and the joint law does not: `contact::carry_swapped`; 0.64 % under the
/// joint law before its stiffness changes were booked: `contact::restiffening`; 9.7 % and 7.3 %
/// while the normal force of an edge–edge logical contact was kn times its gap:
/// `contact::force_law`).
#[test]
fn a_joint_softer_than_a_point_contact_is_one_and_a_struck_wall_keeps_its_energy() {
    let m = blockdem::d3::model::Material { kn: 1e9, ks: 1e9, jkn: 1e10, jks: 1e10, ..Default::default() };
    assert!(!m.joint_law(true, 0.08, 4) && m.contact_law(true, 0.08, 4).kn == 1e9);
    assert!(m.joint_law(true, 0.1, 4) && close(m.contact_law(true, 0.2, 4).kn, 1e10 * 0.05, 1e-15));
    assert!(!m.joint_law(false, 0.2, 4) && !m.joint_law(true, 0.0, 4));
    for jkn in ["1E10", "1E11"] {
        let (m, log) = ok(&struck_wall(jkn, 8000));
        let e = m.energies();
        // The cube (210.6 kg at 30 m/s) struck the wall: the bricks move, friction took some.
        assert!(e.external_work > 9e4 && e.friction > 1e3, "JKN {jkn}: {e:?}\n{log}");
        assert!(e.ledger().abs() < 0.004 * e.external_work, "JKN {jkn}: ledger {} of {}", e.ledger(), e.external_work);
        let faces =
            m.contacts.iter().filter(|c| c.area > 0.01 && m.blocks[c.blocks[0] as usize].constitutive == 2 && m.blocks[c.blocks[1] as usize].constitutive == 2);
        let joints = faces.filter(|c| m.contact_material(c).kn != 1e9).count();
        assert_eq!(joints > 0, jkn == "1E11", "JKN {jkn}: {joints} brick face contacts under the joint law");
    }
}

/// A contact's law comes from its block of the lower material number, then constitutive number
/// (`model::law_block`), whatever the blocks' order. A crack's new piece goes at the end of the
/// list: when the law was block 1's, the squeezed block's piece took the stiffer material of the
/// block above (KN 10¹¹ where its own gives 10¹⁰) at its contact with it, and the crack put that
/// spring energy in. Now every contact of the halves keeps its parent's law, and the springs hold
/// what they held.
#[test]
fn a_cracks_piece_keeps_its_contacts_law_against_another_material() {
    use blockdem::d3::model::law_block;
    let deck = squeezed_block(5e5)
        .replace("PROP MAT=2", "PROP MAT=3 D=1000 KN=1E11 KS=1E11 F=0.5\nPROP MAT=2")
        .replace("BOX 0 1 0 2 1 2\n", "BOX 0 1 0 2 1 2 MAT 3\n");
    let (m, log) = ok(&deck);
    assert!(log.contains("BLOCK 2 CRACKED AT CYCLE 3001") && m.blocks.len() == 4, "{log}");
    // The block above (index 2, material 3) on both halves (indices 1 and 3, material 2).
    let above: Vec<_> = m.contacts.iter().filter(|c| c.blocks.contains(&2) && !c.logical.is_empty()).collect();
    assert_eq!(above.len(), 2);
    for c in above {
        assert_eq!(m.contact_material(c).kn, 1e10, "{:?}", c.blocks);
    }
    assert_eq!((law_block(&m.blocks, [2, 3]), law_block(&m.blocks, [3, 2])), (3, 3));
    let e = m.energies();
    assert!(e.released.abs() < 1e-9 * e.strain, "released {} of {}", e.released, e.strain);
}

/// Eq. (16) as the report gives it, an increment (`contact::force_law`): a logical contact's
/// normal spring is unloaded at its offset (the overlap it had when it appeared inside a face
/// already overlapped), loads from there, and as it opens past the offset the offset follows it
/// back up to 0, so that it reloads from where it is and, once apart, as a fresh contact would
/// (a vertex–face contact, kn times its overlap beyond the offset); an edge–edge contact's force
/// is stepped by the blocks' approach at its point (below).
#[test]
fn a_logical_contacts_normal_force_is_an_increment_from_where_it_appeared() {
    use blockdem::d3::contact::force_law;
    let (m, _) = ok(&format!("{PROPS}BOX 0 1 0 1 0 1\nBOX 0 1 0 1 1 2\nCYCLE 0\n"));
    let mut c = m.contacts.iter().find(|c| !c.logical.is_empty()).expect("the face–face contact").clone();
    let (a, b) = (&m.blocks[c.blocks[0] as usize], &m.blocks[c.blocks[1] as usize]);
    let mat = m.material(1);
    c.logical.truncate(1);
    let mut at = |gap: f64, offset: Option<f64>| {
        let l = &mut c.logical[0];
        l.gap = gap;
        if let Some(o) = offset {
            l.offset = o;
        }
        l.shear_force = DVec3::ZERO;
        let n = c.normal;
        force_law(&mut c, n, a, b, &mat, 0.0);
        (c.logical[0].normal_force, c.logical[0].offset)
    };
    // Appeared at an overlap of 1e-4: no force there, kn × the overlap since beyond it.
    assert_eq!(at(-1e-4, Some(-1e-4)), (0.0, -1e-4));
    let (f, o) = at(-3e-4, None);
    assert!(close(f, 1e9 * 2e-4, 1e-12) && o == -1e-4, "{f} {o}");
    // Opening past the offset: no force, the offset follows the gap.
    assert_eq!(at(-0.5e-4, None), (0.0, -0.5e-4));
    let (f, _) = at(-1.5e-4, None);
    assert!(close(f, 1e9 * 1e-4, 1e-12), "{f}");
    // Apart: the offset back at 0; touching again, the whole overlap counts.
    assert_eq!(at(1e-5, None), (0.0, 0.0));
    let (f, _) = at(-1e-4, None);
    assert!(close(f, 1e9 * 1e-4, 1e-12), "{f}");

    // An edge–edge logical contact (a crossing of two edges, which slides along them as the blocks
    // turn) steps its force by −kn·u̇n·Δt, the blocks' approach at its point, whatever its gap
    // does; new (`NEW_NORMAL_FORCE`), it starts at its overlap beyond its offset; at no force,
    // at the lesser of that and one step's approach (it touched within the step).
    use blockdem::d3::contact::NEW_NORMAL_FORCE;
    use blockdem::d3::model::LogicalKind;
    let (a, mut b) = (a.clone(), b.clone());
    b.velocity = DVec3::new(0.0, 0.0, -0.01);
    let dt = 1e-4;
    let mut edge = |gap: f64, offset: f64, force: f64| {
        let l = &mut c.logical[0];
        (l.kind, l.gap, l.offset, l.normal_force, l.shear_force) = (LogicalKind::EdgeEdge { first: (0, 1), second: (0, 1) }, gap, offset, force, DVec3::ZERO);
        let n = c.normal;
        force_law(&mut c, n, &a, &b, &mat, dt);
        c.logical[0].normal_force
    };
    let step = 1e9 * 0.01 * dt;
    assert!(close(edge(-3e-4, -1e-4, NEW_NORMAL_FORCE), 1e9 * 2e-4, 1e-12));
    assert!(close(edge(-9e-4, 0.0, 5e4), 5e4 + step, 1e-12), "the gap's 9e-4 does not count");
    assert!(close(edge(-1e-4, 0.0, 0.0), step, 1e-12) && close(edge(-1e-7, 0.0, 0.0), 1e2, 1e-9));
}
