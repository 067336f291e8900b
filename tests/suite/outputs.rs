//! Tests of the output layer: number format, PRINT tables, state JSON, SAVE/RESTART, PLOT, DUMP.
//!
//! The models are built by hand (two rectangles and one contact) so these tests do not depend on
//! the geometry or topology code.

use crate::common;

use std::path::{Path, PathBuf};

use blockdem::udec::deck::{PlotOptions, PrintItem};
use blockdem::udec::model::{Block, BlockKind, Contact, ContactKind, Corner, Model};
use blockdem::udec::output::{
    block_outline, dump, fmt_e, load, plot, print_block_lists, print_blocks, print_contacts, print_corners, print_item, save, state_json, write_state_json,
    PlotSettings, RestartError, SaveFile, FORMAT_VERSION, MAGIC,
};
use serde_json::Value;

// ---------------------------------------------------------------------------------------------
// Test models

/// Appends an axis-aligned rectangle block with counter-clockwise corners, each rounded with
/// length `round` (for a right angle the rounding circle has radius `round` and its centre lies
/// `round` inward along both edges). Returns the block's index.
fn add_rect(model: &mut Model, id: u32, [x0, y0, x1, y1]: [f64; 4], round: f64, fixed: bool) -> usize {
    let b = model.blocks.len();
    let start = model.corners.len() as u32;
    let c = [(x0 + x1) / 2.0, (y0 + y1) / 2.0];
    let (w, h) = (x1 - x0, y1 - y0);
    for p in [[x0, y0], [x1, y0], [x1, y1], [x0, y1]] {
        let inward = [(c[0] - p[0]).signum(), (c[1] - p[1]).signum()];
        let circle = [p[0] + inward[0] * round, p[1] + inward[1] * round];
        model.corners.push(Corner {
            block: b as u32,
            local: [p[0] - c[0], p[1] - c[1]],
            circle_local: [circle[0] - c[0], circle[1] - c[1]],
            radius: round,
            round,
            position: p,
            circle,
            edge_material: 0,
            edge_constitutive: 0,
            edge_dir: [0.0; 2],
            edge_length: 0.0,
        });
    }
    let density = 2000.0;
    let mass = density * w * h;
    model.blocks.push(Block {
        id,
        kind: BlockKind::Rigid,
        material: 1,
        constitutive: 1,
        fixed,
        corner_start: start,
        corner_count: 4,
        area: w * h,
        mass,
        inertia: mass * (w * w + h * h) / 12.0,
        centroid: c,
        rotation: 0.0,
        velocity: [0.0, 0.0],
        angular_velocity: 0.0,
        force: [0.0, 0.0],
        moment: 0.0,
        load: [0.0, 0.0],
        radius: 0.5 * w.hypot(h),
        moved_since_update: 0.0,
        update_centroid: c,
        update_rotation: 0.0,
        update_margin: 0.0,
        damping_work: 0.0,
        built_area: w * h,
    });
    model.next_block_id = model.next_block_id.max(id + 1);
    b
}

/// A fixed base (id 3, 0..6 × 0..1) with a block on it (id 5, 2..4 × 1..2, moving), and one
/// contact (id 7) of the top block's bottom-left corner (global corner 4, printed 5) on the
/// base's top edge (feature 5: the edge from corner 2 to corner 3). Ids differ from indices on
/// purpose, so a table that prints indices fails.
fn two_blocks() -> Model {
    let mut m = Model { cycle: 600, time: 1.25, timestep: 2.5e-4, gravity: [0.0, -10.0], ..Model::default() };
    add_rect(&mut m, 3, [0.0, 0.0, 6.0, 1.0], 0.1, true);
    let top = add_rect(&mut m, 5, [2.0, 1.0, 4.0, 2.0], 0.1, false);
    let b = &mut m.blocks[top];
    b.velocity = [0.5, -0.25];
    b.angular_velocity = 0.01;
    b.force = [10.0, -2.0e4];
    b.moment = 3.5;
    b.material = 2;
    b.constitutive = 4;
    m.contacts.push(Contact {
        id: 7,
        block1: 1,
        corner: 4,
        block2: 0,
        feature: 5,
        kind: ContactKind::CornerEdge,
        material: 1,
        constitutive: 2,
        bonded: true,
        point: [2.0, 1.0],
        normal: [0.0, 1.0],
        gap: -1.5e-4,
        normal_force: 1.962e4,
        shear_force: -12.5,
        shear_displacement: 3.0e-5,
        force: [-12.5, 1.962e4],
        slip_work: 0.0,
        dashpot_work: 0.0,
        dashpot_velocity: [0.0; 2],
        // A joint (constitutive 2) carrying half of a joint of length 1 (¶5).
        joint_length: 0.5,
    });
    m.next_contact_id = 8;
    m
}

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("outputs").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(f: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>) -> String {
    let mut buf = Vec::new();
    f(&mut buf).unwrap();
    String::from_utf8(buf).unwrap()
}

/// Four significant digits, as fmt_e prints them.
fn close(printed: &str, expected: f64) -> bool {
    let x: f64 = printed.parse().unwrap_or_else(|_| panic!("not a number: {printed:?}"));
    (x - expected).abs() <= 5e-4 * expected.abs()
}

// ---------------------------------------------------------------------------------------------
// fmt_e

#[test]
fn fmt_e_cases() {
    let cases: &[(f64, &str)] = &[
        (0.0, "0.000E+00"),
        (-0.0, "0.000E+00"),
        (1.0, "1.000E+00"),
        (123_400.0, "1.234E+05"),
        (-0.0095, "-9.500E-03"),
        (-1.0, "-1.000E+00"),
        (9.9996, "1.000E+01"),
        (0.12345, "1.235E-01"), // the binary value lies just above the tie
        (1.0005, "1.000E+00"),  // ... and this one just below
        (1e-300, "1.000E-300"),
        (1e300, "1.000E+300"),
        (-2.5e-120, "-2.500E-120"),
        (f64::MAX, "1.798E+308"),
        (5e-324, "4.941E-324"),
        (f64::NAN, "NaN"),
        (f64::INFINITY, "Inf"),
        (f64::NEG_INFINITY, "-Inf"),
    ];
    for &(x, want) in cases {
        assert_eq!(fmt_e(x), want, "fmt_e({x:e})");
    }
}

#[test]
fn fmt_e_parses_back_within_half_a_unit_of_the_last_digit() {
    let mut x: f64 = 1.234_567_89e-30;
    for _ in 0..120 {
        for v in [x, -x] {
            let s = fmt_e(v);
            assert!(s.len() <= 10, "{s} is wider than a column");
            let back: f64 = s.parse().unwrap();
            assert!((back - v).abs() <= 5.0001e-4 * v.abs(), "{v:e} printed {s}");
        }
        x *= 3.7;
    }
}

// ---------------------------------------------------------------------------------------------
// PRINT tables

/// The whitespace-separated fields of the first line whose first field is `first`.
fn row<'a>(table: &'a str, first: &str) -> Vec<&'a str> {
    table
        .lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .find(|f| f.first() == Some(&first))
        .unwrap_or_else(|| panic!("no row starting with {first} in\n{table}"))
}

fn assert_narrow(table: &str) {
    for line in table.lines() {
        assert!(line.len() <= 132, "line longer than 132 columns: {line:?}");
    }
}

#[test]
fn print_blocks_table() {
    let m = two_blocks();
    let t = text(|w| print_blocks(&m, w));
    assert_narrow(&t);
    assert!(t.starts_with("\nBLOCK DATA\n"), "{t}");
    for heading in ["BLOCK", "MAT", "CONST", "CENTROID COORDS.", "MASS", "POL. MOM.", "X,Y,THETA VELOCITIES", "X,Y,THETA FORCES"] {
        assert!(t.contains(heading), "missing heading {heading}:\n{t}");
    }
    let r = row(&t, "5");
    assert_eq!(r.len(), 13, "{r:?}");
    assert_eq!(&r[1..3], ["2", "4"]);
    let b = &m.blocks[1];
    let want = [3.0, 1.5, b.mass, b.inertia, 0.5, -0.25, 0.01, 10.0, -2.0e4, 3.5];
    for (s, x) in r[3..].iter().zip(want) {
        assert!(close(s, x), "printed {s}, expected {x}");
    }
    // The type line follows each block's row; the fixed base says so.
    let lines: Vec<&str> = t.lines().collect();
    let i = lines.iter().position(|l| l.split_whitespace().next() == Some("3")).unwrap();
    assert_eq!(lines[i + 1].trim(), "(RIGID) FIXED");
    let i = lines.iter().position(|l| l.split_whitespace().next() == Some("5")).unwrap();
    assert_eq!(lines[i + 1].trim(), "(RIGID)");
    // No block is numbered by its index.
    assert!(t.lines().all(|l| !l.trim_start().starts_with("0 ") && !l.trim_start().starts_with("1 ")));
}

#[test]
fn print_blocks_names_deformable_types() {
    let mut m = two_blocks();
    m.blocks[0].kind = BlockKind::SimplyDeformable;
    m.blocks[1].kind = BlockKind::FullyDeformable;
    let t = text(|w| print_blocks(&m, w));
    assert!(t.contains("(SDEF) FIXED") && t.contains("(FDEF)"), "{t}");
}

#[test]
fn print_contacts_table() {
    let m = two_blocks();
    let t = text(|w| print_contacts(&m, w));
    assert_narrow(&t);
    assert!(t.starts_with("\nCONTACT DATA\n"), "{t}");
    for heading in ["CONTACT", "BLOCK1", "BLOCK2", "MAT", "CONST", "X,Y COORDS.", "FORCE", "DISPLACEMENT", "NORMAL", "SHEAR"] {
        assert!(t.contains(heading), "missing heading {heading}:\n{t}");
    }
    let r = row(&t, "7");
    assert_eq!(&r[1..5], ["5", "3", "1", "2"], "ids, not indices: {r:?}");
    let want = [2.0, 1.0, 1.962e4, -12.5, -1.5e-4, 3.0e-5];
    for (s, x) in r[5..11].iter().zip(want) {
        assert!(close(s, x), "printed {s}, expected {x}");
    }
    assert_eq!(r[11], "CORNER/EDGE");
}

#[test]
fn print_contacts_leaves_unset_material_blank() {
    let mut m = two_blocks();
    m.contacts[0].material = 0;
    m.contacts[0].constitutive = 0;
    let t = text(|w| print_contacts(&m, w));
    let r = row(&t, "7");
    assert_eq!(&r[1..3], ["5", "3"]);
    assert!(close(r[3], 2.0), "MAT and CONST columns should be blank: {r:?}");
}

#[test]
fn print_corners_table() {
    let m = two_blocks();
    let t = text(|w| print_corners(&m, w));
    assert_narrow(&t);
    assert!(t.contains("CORNER COORDINATES (IN X,Y ORDER)"));
    let r = row(&t, "BLOCK");
    assert_eq!(r[1], "3");
    let want = [0.0, 0.0, 6.0, 0.0, 6.0, 1.0, 0.0, 1.0];
    assert_eq!(r.len(), 2 + want.len());
    for (s, x) in r[2..].iter().zip(want) {
        assert!(close(s, x), "printed {s}, expected {x}");
    }
}

#[test]
fn print_corners_wraps_long_blocks() {
    // A 12-corner block needs three lines of at most five pairs.
    let mut m = Model::default();
    let n = 12;
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        let p = [5.0 + a.cos(), 5.0 + a.sin()];
        m.corners.push(Corner {
            block: 0,
            local: [p[0] - 5.0, p[1] - 5.0],
            circle_local: [0.0; 2],
            radius: 0.0,
            round: 0.0,
            position: p,
            circle: p,
            edge_material: 0,
            edge_constitutive: 0,
            edge_dir: [0.0; 2],
            edge_length: 0.0,
        });
    }
    m.blocks.push(Block {
        id: 42,
        kind: BlockKind::Rigid,
        material: 1,
        constitutive: 1,
        fixed: false,
        corner_start: 0,
        corner_count: n,
        area: 3.0,
        mass: 1.0,
        inertia: 1.0,
        centroid: [5.0, 5.0],
        rotation: 0.0,
        velocity: [0.0; 2],
        angular_velocity: 0.0,
        force: [0.0; 2],
        moment: 0.0,
        load: [0.0; 2],
        radius: 1.0,
        moved_since_update: 0.0,
        update_centroid: [5.0, 5.0],
        update_rotation: 0.0,
        update_margin: 0.0,
        damping_work: 0.0,
        built_area: 3.0,
    });
    let t = text(|w| print_corners(&m, w));
    assert_narrow(&t);
    let body: Vec<&str> = t.lines().filter(|l| l.contains("E+") || l.contains("E-")).collect();
    assert_eq!(body.len(), 3, "{t}");
    assert!(body[0].starts_with("BLOCK     42"));
    assert!(body[1].starts_with("            ") && body[2].starts_with("            "));
    let numbers: usize = body.iter().map(|l| l.split_whitespace().filter(|f| f.contains('E')).count()).sum();
    assert_eq!(numbers, 2 * n as usize);
}

#[test]
fn print_block_lists_table() {
    let m = two_blocks();
    let t = text(|w| print_block_lists(&m, w));
    assert_narrow(&t);
    assert!(t.contains("BLOCK LINKED LISTS"));
    let lines: Vec<&str> = t.lines().map(str::trim).collect();
    // Base (id 3): corners 1..4; the contact sits on the edge after corner 3 (top edge), and the
    // base is block 2 of it.
    let base = lines.iter().position(|l| *l == "BLOCK 3 (RIGID)").unwrap();
    assert_eq!(
        &lines[base + 1..base + 7],
        [
            "CORNER 1, BLOCK 3, R-LINK 2",
            "CORNER 2, BLOCK 3, R-LINK 3",
            "CORNER 3, BLOCK 3, R-LINK 4",
            "CONTACT 7, BLOCK1 5, BLOCK2 3 EDGE/CORNER",
            "CORNER 4, BLOCK 3, R-LINK 1",
            "",
        ]
    );
    // Top block (id 5): corners 5..8; it owns corner 5, which makes the contact. R-LINK closes
    // each block's corner list: the last corner links back to the first.
    let top = lines.iter().position(|l| *l == "BLOCK 5 (RIGID)").unwrap();
    assert_eq!(
        &lines[top + 1..],
        [
            "CORNER 5, BLOCK 5, R-LINK 6",
            "CONTACT 7, BLOCK1 5, BLOCK2 3 CORNER/EDGE",
            "CORNER 6, BLOCK 5, R-LINK 7",
            "CORNER 7, BLOCK 5, R-LINK 8",
            "CORNER 8, BLOCK 5, R-LINK 5",
        ]
    );
}

#[test]
fn the_linked_lists_name_every_contact_under_both_its_blocks() {
    // A wall of 200 bricks and its ~1500 contacts: each contact is listed exactly once under its
    // block 1 and once under its block 2 (the lists are grouped by one sort of the contacts, not
    // a scan of them per block).
    let deck = format!("{}CYCLE 1\n", blockdem::bench::scene::scaling_body(200, 0.1));
    let m = blockdem::scenes::run_deck_on(&deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    assert!(m.contacts.len() > 1000);
    let t = text(|w| print_block_lists(&m, w));
    let mut seen: std::collections::HashMap<u32, Vec<u32>> = Default::default();
    let mut block = 0;
    for line in t.lines().map(str::trim) {
        if let Some(id) = line.strip_prefix("BLOCK ").and_then(|rest| rest.split(' ').next()?.parse().ok()) {
            block = id;
        } else if let Some(rest) = line.strip_prefix("CONTACT ") {
            let id: u32 = rest.split(',').next().unwrap().parse().unwrap();
            seen.entry(id).or_default().push(block);
        }
    }
    assert_eq!(seen.len(), m.contacts.len(), "every contact is listed");
    for c in &m.contacts {
        let mut blocks = seen[&c.id].clone();
        blocks.sort_unstable();
        let mut expected = vec![m.blocks[c.block1 as usize].id, m.blocks[c.block2 as usize].id];
        expected.sort_unstable();
        assert_eq!(blocks, expected, "contact {}", c.id);
    }
}

#[test]
fn print_item_dispatches_and_survives_a_bad_index() {
    let mut m = two_blocks();
    for item in
        [PrintItem::Blocks, PrintItem::Contacts, PrintItem::Corners, PrintItem::List, PrintItem::Energy, PrintItem::Domains, PrintItem::DList, PrintItem::Flows]
    {
        let t = text(|w| print_item(&m, item, w));
        assert!(t.starts_with('\n') && t.len() > 10, "{item:?}: {t}");
    }
    // A contact that names a block that is not there prints "?" rather than panicking.
    m.contacts[0].block2 = 99;
    m.contacts[0].corner = 999;
    let t = text(|w| print_contacts(&m, w));
    assert_eq!(&row(&t, "7")[1..3], ["5", "?"]);
    let t = text(|w| print_block_lists(&m, w));
    assert!(t.contains("CONTACT 7, BLOCK1 5, BLOCK2 ? CORNER/EDGE"), "{t}");
}

// ---------------------------------------------------------------------------------------------
// State JSON

#[test]
fn state_json_has_every_key() {
    let m = two_blocks();
    let v = state_json(&m);
    assert_eq!(v["dim"], 2);
    assert_eq!(v["cycle"], 600);
    assert_eq!(v["time"], 1.25);
    assert_eq!(v["timestep"], 2.5e-4);
    let blocks = v["blocks"].as_array().unwrap();
    assert_eq!(blocks.len(), 2);

    let base = &blocks[0];
    let keys = [
        "id",
        "kind",
        "material",
        "constitutive",
        "fixed",
        "area",
        "mass",
        "inertia",
        "centroid",
        "velocity",
        "angular_velocity",
        "force",
        "moment",
        "corners",
    ];
    for b in blocks {
        for k in keys {
            assert!(b.get(k).is_some(), "block lacks {k}: {b}");
        }
    }
    assert_eq!(base["id"], 3);
    assert_eq!(base["kind"], "rigid");
    assert_eq!(base["fixed"], true);
    assert_eq!(base["area"], 6.0);
    assert_eq!(base["mass"], 12000.0);
    assert_eq!(base["corners"], serde_json::json!([[0.0, 0.0], [6.0, 0.0], [6.0, 1.0], [0.0, 1.0]]));

    let top = &blocks[1];
    assert_eq!(top["id"], 5);
    assert_eq!(top["material"], 2);
    assert_eq!(top["constitutive"], 4);
    assert_eq!(top["fixed"], false);
    assert_eq!(top["centroid"], serde_json::json!([3.0, 1.5]));
    assert_eq!(top["velocity"], serde_json::json!([0.5, -0.25]));
    assert_eq!(top["angular_velocity"], 0.01);
    assert_eq!(top["force"], serde_json::json!([10.0, -2.0e4]));
    assert_eq!(top["moment"], 3.5);
    assert!(top["inertia"].is_f64() && top["id"].is_u64() && top["kind"].is_string());

    let contacts = v["contacts"].as_array().unwrap();
    assert_eq!(contacts.len(), 1);
    let c = &contacts[0];
    assert_eq!(c["id"], 7);
    assert_eq!(c["blocks"], serde_json::json!([5, 3]));
    assert_eq!(c["kind"], "corner-edge");
    assert_eq!(c["point"], serde_json::json!([2.0, 1.0]));
    assert_eq!(c["normal"], serde_json::json!([0.0, 1.0]));
    assert_eq!(c["normal_force"], 1.962e4);
    assert_eq!(c["shear_force"], -12.5);
    assert_eq!(c["normal_displacement"], -1.5e-4);
    assert_eq!(c["shear_displacement"], 3.0e-5);
}

#[test]
fn state_json_writes_null_for_non_finite_numbers() {
    let mut m = two_blocks();
    m.blocks[1].velocity = [f64::NAN, 1.0];
    m.blocks[1].moment = f64::INFINITY;
    m.time = f64::NEG_INFINITY;
    let dir = out_dir("state_json_nan");
    let path = dir.join("state.json");
    write_state_json(&m, &path).unwrap();
    let back: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(back, state_json(&m));
    assert_eq!(back["blocks"][1]["velocity"], serde_json::json!([null, 1.0]));
    assert!(back["blocks"][1]["moment"].is_null());
    assert!(back["time"].is_null());
    // Only the file itself is left: the temporary file was renamed into place.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
}

#[test]
fn the_streamed_state_file_is_the_state_value_pretty_printed() {
    // write_state_json streams the state from the model; its text must be the JSON value's,
    // keys in alphabetical order (serde_json's maps are sorted), the layout tools have read.
    let mut m = two_blocks();
    m.blocks[1].rotation = f64::NAN;
    m.contacts[0].block2 = 99; // a corrupt reference is written as null
    let dir = out_dir("state_json_stream");
    let path = dir.join("state.json");
    write_state_json(&m, &path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let value = state_json(&m);
    assert_eq!(text, serde_json::to_string_pretty(&value).unwrap() + "\n");
    assert_eq!(value["contacts"][0]["blocks"], serde_json::json!([5, null]));
    // The lists are formatted in parallel pieces of 2048: a wall of 400 bricks has ~3000
    // contacts, so its contact list spans two pieces; a model with no contacts writes `[]`.
    let deck = format!("{}CYCLE 1\n", blockdem::bench::scene::scaling_body(400, 0.1));
    let wall = blockdem::scenes::run_deck_on(&deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    assert!(wall.contacts.len() > 2048);
    let mut bare = two_blocks();
    bare.contacts.clear();
    for (name, m) in [("wall", &wall), ("bare", &bare)] {
        let path = dir.join(format!("{name}.json"));
        write_state_json(m, &path).unwrap();
        assert!(std::fs::read_to_string(&path).unwrap() == serde_json::to_string_pretty(&state_json(m)).unwrap() + "\n", "{name}");
    }
}

// ---------------------------------------------------------------------------------------------
// SAVE / RESTART

fn save_file() -> SaveFile {
    SaveFile { model: two_blocks(), plot: PlotSettings { window: [0.0, 6.0, 0.0, 7.0], view: [0, 700, 700, 1400] }, plot_count: 3 }
}

#[test]
fn save_and_load_round_trip_exactly() {
    let dir = out_dir("restart_round_trip");
    let path = dir.join("run.sav");
    let mut file = save_file();
    // Values whose last bits a text format would lose.
    file.model.blocks[1].centroid = [0.1 + 0.2, std::f64::consts::PI];
    file.model.blocks[1].rotation = -0.0;
    file.model.time = 1.0 / 3.0;
    save(&path, &file).unwrap();
    let back = load(&path).unwrap();
    assert_eq!(back, file);
    assert_eq!(back.model.blocks[1].centroid[0].to_bits(), (0.1f64 + 0.2).to_bits());
    assert_eq!(back.model.blocks[1].rotation.to_bits(), (-0.0f64).to_bits());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "temporary file left behind");

    // Saving again over the same file replaces it.
    file.plot_count = 4;
    save(&path, &file).unwrap();
    assert_eq!(load(&path).unwrap().plot_count, 4);
}

#[test]
fn save_preserves_nan_bits() {
    // The format keeps a NaN's payload; RESTART accepts one only where the model may hold it (the
    // energy bookkeeping) and refuses a non-finite state (Model::validate), naming the block.
    let dir = out_dir("restart_nan");
    let path = dir.join("nan.sav");
    let mut file = save_file();
    let odd_nan = f64::from_bits(0x7ff8_dead_beef_0001);
    file.model.blocks[0].damping_work = odd_nan;
    save(&path, &file).unwrap();
    let back = load(&path).unwrap();
    assert_eq!(back.model.blocks[0].damping_work.to_bits(), odd_nan.to_bits());
    file.model.blocks[0].velocity[0] = odd_nan;
    save(&path, &file).unwrap();
    match load(&path) {
        Err(e @ RestartError::Inconsistent { .. }) => assert!(e.to_string().ends_with("is inconsistent: block 0 (id 3) has a non-finite value"), "{e}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_save_header_is_filled_in_after_its_streamed_payload() {
    // SAVE streams the payload and writes its length and checksum into the header last: they
    // must describe the bytes that follow, and the payload must be postcard's encoding.
    let dir = out_dir("restart_header");
    let path = dir.join("streamed.sav");
    let file = save_file();
    save(&path, &file).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let payload = &bytes[28..];
    // Version 7: the save file's fields, then the joints (index, length of joint) of ¶5, then the
    // simply-deformable extension array, then the fully-deformable one, then the fluid and the
    // domains (options: none here).
    let mut expected = postcard::to_stdvec(&file).unwrap();
    expected.extend(postcard::to_stdvec(&vec![(0u32, 0.5f64)]).unwrap());
    expected.extend(postcard::to_stdvec(&file.model.sdef).unwrap());
    expected.extend(postcard::to_stdvec(&file.model.fdef).unwrap());
    expected.extend(postcard::to_stdvec(&file.model.fluid).unwrap());
    expected.extend(postcard::to_stdvec(&file.model.domains).unwrap());
    // Version 7: the areas as built of a crack's pieces (none here).
    expected.extend(postcard::to_stdvec(&Vec::<(u32, f64)>::new()).unwrap());
    assert!(file.model.fluid.is_none() && file.model.domains.is_none());
    assert_eq!(payload, expected.as_slice());
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), FORMAT_VERSION);
    assert_eq!(u64::from_le_bytes(bytes[12..20].try_into().unwrap()), payload.len() as u64);
    assert_eq!(u64::from_le_bytes(bytes[20..28].try_into().unwrap()), crc32fast::hash(payload) as u64);
}

#[test]
fn a_save_file_of_format_3_still_loads() {
    // Version 3 files (before joints and simply-deformable blocks) hold the same payload without
    // the two lists, under a CRC-32: they load with every contact a point contact.
    let dir = out_dir("restart_v3");
    let mut file = save_file();
    for c in &mut file.model.contacts {
        c.joint_length = 0.0;
    }
    let payload = postcard::to_stdvec(&file).unwrap();
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(&3u32.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&(crc32fast::hash(&payload) as u64).to_le_bytes());
    bytes.extend_from_slice(&payload);
    let path = dir.join("v3.sav");
    std::fs::write(&path, &bytes).unwrap();
    assert_eq!(load(&path).unwrap(), file);
}

#[test]
fn a_save_file_of_format_4_still_loads() {
    // Version 4 files (before fully-deformable blocks) end with the simply-deformable extension:
    // they load with no zones.
    let dir = out_dir("restart_v4");
    let file = save_file();
    let mut payload = postcard::to_stdvec(&file).unwrap();
    payload.extend(postcard::to_stdvec(&vec![(0u32, 0.5f64)]).unwrap());
    payload.extend(postcard::to_stdvec(&file.model.sdef).unwrap());
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(&4u32.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&(crc32fast::hash(&payload) as u64).to_le_bytes());
    bytes.extend_from_slice(&payload);
    let path = dir.join("v4.sav");
    std::fs::write(&path, &bytes).unwrap();
    let back = load(&path).unwrap();
    assert!(back.model.fdef.is_empty());
    assert_eq!(back, file);
}

#[test]
fn a_save_file_of_format_5_still_loads() {
    // Version 5 files (before the fluid) end with the fully-deformable extension: they load as a
    // model without fluid and without domains (RESTART builds these again when asked).
    let dir = out_dir("restart_v5");
    let file = save_file();
    let mut payload = postcard::to_stdvec(&file).unwrap();
    payload.extend(postcard::to_stdvec(&vec![(0u32, 0.5f64)]).unwrap());
    payload.extend(postcard::to_stdvec(&file.model.sdef).unwrap());
    payload.extend(postcard::to_stdvec(&file.model.fdef).unwrap());
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(&5u32.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&(crc32fast::hash(&payload) as u64).to_le_bytes());
    bytes.extend_from_slice(&payload);
    let path = dir.join("v5.sav");
    std::fs::write(&path, &bytes).unwrap();
    let back = load(&path).unwrap();
    assert!(back.model.fluid.is_none() && back.model.domains.is_none());
    assert_eq!(back, file);
}

#[test]
fn a_save_file_of_format_2_still_loads() {
    // Version 2 files (up to this format change) carry an FNV-1a 64 checksum of the same payload.
    let dir = out_dir("restart_v2");
    let file = save_file();
    let payload = postcard::to_stdvec(&file).unwrap();
    let fnv = payload.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3));
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(&2u32.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&fnv.to_le_bytes());
    bytes.extend_from_slice(&payload);
    let path = dir.join("v2.sav");
    std::fs::write(&path, &bytes).unwrap();
    // Written before joints: every contact loads as a point contact.
    let mut points = file.clone();
    points.model.contacts.iter_mut().for_each(|c| c.joint_length = 0.0);
    assert_eq!(load(&path).unwrap(), points);
    // Its checksum is checked as FNV: a damaged byte is still found.
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&path, &bytes).unwrap();
    assert!(matches!(load(&path), Err(RestartError::Corrupt { .. })));
}

#[test]
fn load_reports_bad_files_without_panicking() {
    let dir = out_dir("restart_bad");
    let good = dir.join("good.sav");
    save(&good, &save_file()).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    assert_eq!(bytes[..8], MAGIC);
    let bad = dir.join("bad.sav");

    // Every truncation is an error: short of the magic it is not a save file, after it corrupt.
    for cut in (0..bytes.len()).step_by(7).chain([8, 12, 27, 28, bytes.len() - 1]) {
        std::fs::write(&bad, &bytes[..cut]).unwrap();
        match load(&bad) {
            Err(RestartError::NotASaveFile { .. }) => assert!(cut < 8, "cut {cut}"),
            Err(RestartError::Corrupt { .. }) => assert!(cut >= 8, "cut {cut}"),
            other => panic!("cut at {cut}: {other:?}"),
        }
    }

    // Wrong magic.
    let mut wrong = bytes.clone();
    wrong[..8].copy_from_slice(b"UDEC1985");
    std::fs::write(&bad, &wrong).unwrap();
    assert!(matches!(load(&bad), Err(RestartError::NotASaveFile { .. })));
    std::fs::write(&bad, "PROP MAT=1 DENS=2000\n").unwrap();
    let err = load(&bad).unwrap_err();
    assert!(matches!(err, RestartError::NotASaveFile { .. }));
    assert!(err.to_string().contains("not a blockdem save file"), "{err}");

    // Another version.
    let mut future = bytes.clone();
    future[8..12].copy_from_slice(&(FORMAT_VERSION + 98).to_le_bytes());
    std::fs::write(&bad, &future).unwrap();
    match load(&bad) {
        Err(RestartError::UnsupportedVersion { found, supported, .. }) => {
            assert_eq!((found, supported), (FORMAT_VERSION + 98, FORMAT_VERSION))
        }
        other => panic!("{other:?}"),
    }

    // A damaged payload byte, and bytes appended.
    let mut damaged = bytes.clone();
    let last = damaged.len() - 1;
    damaged[last] ^= 0x40;
    std::fs::write(&bad, &damaged).unwrap();
    assert!(matches!(load(&bad), Err(RestartError::Corrupt { .. })));
    let mut longer = bytes.clone();
    longer.extend_from_slice(b"junk");
    std::fs::write(&bad, &longer).unwrap();
    assert!(matches!(load(&bad), Err(RestartError::Corrupt { .. })));

    // A file that is not there.
    assert!(matches!(load(&dir.join("missing.sav")), Err(RestartError::Io { .. })));
}

/// SAVE through a symbolic link writes the file the link names, created where the link
/// dangles, and leaves the link a link.
#[cfg(unix)]
#[test]
fn save_through_a_symbolic_link_writes_the_file_it_names_and_keeps_the_link() {
    let dir = out_dir("restart_symlink");
    std::fs::create_dir(dir.join("runs")).unwrap();
    let link = dir.join("latest.sav");
    std::os::unix::fs::symlink("runs/first.sav", &link).unwrap();
    let mut file = save_file();
    for plot_count in [3, 4] {
        file.plot_count = plot_count;
        save(&link, &file).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link was replaced");
        assert_eq!(load(&dir.join("runs/first.sav")).unwrap(), file);
        assert_eq!(load(&link).unwrap().plot_count, plot_count);
    }
    assert_eq!(std::fs::read_dir(dir.join("runs")).unwrap().count(), 1, "temporary file left behind");
}

/// Runs `write` on a FIFO that `cat` reads (so that the pipe is not left waiting for a reader
/// and the test cannot hang on it); returns what came through and checks the FIFO is still one.
#[cfg(unix)]
fn through_a_fifo(dir: &Path, write: impl FnOnce(&Path) -> Result<(), String>) -> Vec<u8> {
    use std::os::unix::fs::FileTypeExt;
    let (fifo, out) = (dir.join("pipe"), dir.join("came_through"));
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let mut cat = std::process::Command::new("cat").arg(&fifo).stdout(std::fs::File::create(&out).unwrap()).spawn().unwrap();
    let written = write(&fifo);
    let start = std::time::Instant::now();
    while written.is_ok() && cat.try_wait().unwrap().is_none() && start.elapsed().as_secs() < 20 {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let _ = cat.kill();
    let _ = cat.wait();
    written.unwrap();
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the FIFO was replaced by a file");
    std::fs::read(&out).unwrap()
}

/// A FIFO is written through, not replaced: SAVE writes the same bytes as to a file (its header
/// first: a pipe cannot seek back to it), and the state file is the same text.
#[cfg(unix)]
#[test]
fn save_and_the_state_file_write_through_a_fifo() {
    let dir = out_dir("restart_fifo");
    let file = save_file();
    save(&dir.join("file.sav"), &file).unwrap();
    let piped = through_a_fifo(&dir, |p| save(p, &file).map_err(|e| e.to_string()));
    assert_eq!(piped, std::fs::read(dir.join("file.sav")).unwrap());
    std::fs::remove_file(dir.join("pipe")).unwrap();
    write_state_json(&file.model, &dir.join("state.json")).unwrap();
    let piped = through_a_fifo(&dir, |p| write_state_json(&file.model, p).map_err(|e| e.to_string()));
    assert_eq!(piped, std::fs::read(dir.join("state.json")).unwrap());
}

/// RESTART from a FIFO (whose length is not known ahead) reads the payload only as far as the
/// header announces: a whole file loads, a short one or one with more after it is corrupt.
#[cfg(unix)]
#[test]
fn load_reads_a_fifo_as_far_as_the_header_announces() {
    let dir = out_dir("restart_from_fifo");
    let file = save_file();
    save(&dir.join("file.sav"), &file).unwrap();
    let bytes = std::fs::read(dir.join("file.sav")).unwrap();
    let fifo = dir.join("pipe");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    // The writer ignores the reader going early (a broken pipe): what matters is what load says.
    let feed = |b: Vec<u8>| {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            use std::io::Write;
            let _ = std::fs::OpenOptions::new().write(true).open(&fifo).and_then(|mut w| w.write_all(&b));
        })
    };
    let writer = feed(bytes.clone());
    assert_eq!(load(&fifo).unwrap(), file);
    writer.join().unwrap();
    let n = bytes.len() as u64 - 28;
    for (damaged, says) in [
        ([&bytes[..], b"junk"].concat(), format!("announces {n} payload bytes but more follow")),
        (bytes[..bytes.len() - 10].to_vec(), format!("announces {n} payload bytes but the file holds {}", n - 10)),
    ] {
        let writer = feed(damaged);
        match load(&fifo) {
            Err(RestartError::Corrupt { reason, .. }) => assert!(reason.contains(&says), "{reason}"),
            other => panic!("{other:?}"),
        }
        writer.join().unwrap();
    }
}

#[test]
fn save_into_a_missing_directory_is_an_io_error() {
    let dir = out_dir("restart_no_dir");
    let err = save(&dir.join("no/such/dir/x.sav"), &save_file()).unwrap_err();
    assert!(matches!(err, RestartError::Io { .. }), "{err:?}");
}

// ---------------------------------------------------------------------------------------------
// PLOT

const WHITE: [u8; 4] = [255, 255, 255, 255];

fn rgba(p: &tiny_skia::Pixmap, x: u32, y: u32) -> [u8; 4] {
    let c = p.pixel(x, y).unwrap();
    [c.red(), c.green(), c.blue(), c.alpha()]
}

fn load_png(path: &Path) -> tiny_skia::Pixmap {
    tiny_skia::Pixmap::load_png(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn plot_default_page() {
    let m = two_blocks();
    let dir = out_dir("plot_default");
    let [png, svg] = plot(&m, &PlotSettings::default(), &PlotOptions::default(), &dir, 1, "outputs.dat").unwrap();
    assert_eq!(png, dir.join("plot_001.png"));
    assert_eq!(svg, dir.join("plot_001.svg"));
    let p = load_png(&png);
    assert_eq!((p.width(), p.height()), (1000, 700));
    // WINDOW 0 10 0 7 fills the whole page at 100 px per unit: (x, y) → (100x, 700 − 100y).
    assert_eq!(rgba(&p, 100, 650), [200, 200, 200, 255], "fixed base interior is grey");
    assert_eq!(rgba(&p, 250, 550), WHITE, "free block interior is white");
    assert_ne!(rgba(&p, 300, 600), WHITE, "edge between the blocks is drawn");
    assert_ne!(rgba(&p, 300, 550), WHITE, "centroid cross");
    assert_ne!(rgba(&p, 250, 500), WHITE, "top edge of the free block");
    // The rounded corner cuts the sharp corner: the corner pixel at (2, 2) → (200, 500) is outside
    // the rounded outline, while the points 0.1 along the edges are on it.
    assert_eq!(rgba(&p, 201, 501), WHITE, "corner rounding");
    assert_eq!(rgba(&p, 900, 100), WHITE);
}

#[test]
fn plot_in_a_view_quadrant_is_clipped_to_it() {
    let m = two_blocks();
    let dir = out_dir("plot_quadrant");
    // Sample problem 4's first quadrant; the window is narrower than the base (0..6), so the base
    // runs out of the view on the right and must be cut at its edge.
    let settings = PlotSettings { window: [0.0, 4.0, 0.0, 3.0], view: [0, 700, 700, 1400] };
    let [png, svg] = plot(&m, &settings, &PlotOptions { velocities: true, ..Default::default() }, &dir, 12, "outputs.dat").unwrap();
    assert!(png.ends_with("plot_012.png"));
    // The SVG is clipped to the same quadrant: the top-left 350 × 350 px of the 1000 × 700 page.
    let s = std::fs::read_to_string(&svg).unwrap();
    assert!(s.contains(r#"<clipPath id="view"><rect x="0.00" y="0.00" width="350.00" height="350.00"/></clipPath>"#), "{s}");
    let p = load_png(&png);
    let mut inside = 0;
    for y in 0..p.height() {
        for x in 0..p.width() {
            let c = rgba(&p, x, y);
            if x < 350 && y < 350 {
                inside += (c != WHITE) as usize;
            } else {
                assert_eq!(c, WHITE, "pixel ({x}, {y}) outside the view is drawn");
            }
        }
    }
    assert!(inside > 1000, "only {inside} pixels drawn in the view");
    // 175 plotter units per problem unit, centred vertically: y = 0.5 → image row 262.
    assert_eq!(rgba(&p, 345, 262), [200, 200, 200, 255], "base shaded up to the view edge");
}

#[test]
fn plot_options_change_the_picture() {
    let mut m = two_blocks();
    m.blocks[0].velocity = [0.0, 0.0];
    let dir = out_dir("plot_options");
    let full = PlotOptions::default();
    let nofix = PlotOptions { nofix: true, ..full };
    let nc = PlotOptions { no_rounding: true, velocities: true, ..full };
    let [png1, svg1] = plot(&m, &PlotSettings::default(), &full, &dir, 1, "outputs.dat").unwrap();
    let [png2, svg2] = plot(&m, &PlotSettings::default(), &nofix, &dir, 2, "outputs.dat").unwrap();
    let [_, svg3] = plot(&m, &PlotSettings::default(), &nc, &dir, 3, "outputs.dat").unwrap();
    let (s1, s2, s3) = [svg1, svg2, svg3].map(|p| std::fs::read_to_string(p).unwrap()).into();

    // SVG: well-formed enough, one path per shown block, caption with cycle and time.
    for s in [&s1, &s2, &s3] {
        assert!(s.starts_with("<?xml") && s.trim_end().ends_with("</svg>"));
        assert_eq!(s.matches("<path").count(), s.matches("/>").count() - 2, "paths are self-closing (plus two rects)");
        assert!(s.contains("CYCLE 600") && s.contains("TIME 1.250E+00"));
    }
    assert_eq!(s1.matches(r#"class="block""#).count(), 2);
    assert_eq!(s1.matches(r#"data-id="3""#).count(), 1);
    assert_eq!(s2.matches(r#"class="block""#).count(), 1, "NOFIX leaves the fixed block out");
    assert!(!s2.contains(r#"data-id="3""#));
    assert!(!s1.contains("velocity") && s3.contains(r#"class="velocity""#));

    // With NC a rectangle is its four corners; with rounding each corner is an arc.
    let block_points = |s: &str, id: u32| {
        let line = s.lines().find(|l| l.contains(&format!(r#"data-id="{id}""#))).unwrap();
        line.split(" d=\"").nth(1).unwrap().split('"').next().unwrap().matches(',').count()
    };
    assert_eq!(block_points(&s3, 5), 4);
    assert!(block_points(&s1, 5) > 4 * 10);

    let (p1, p2) = (load_png(&png1), load_png(&png2));
    assert_eq!(rgba(&p1, 100, 650), [200, 200, 200, 255]);
    assert_eq!(rgba(&p2, 100, 650), WHITE, "NOFIX: no grey");
    assert_ne!(rgba(&p2, 250, 500), WHITE, "NOFIX still draws free blocks");
}

#[test]
fn plot_draws_only_what_shows_in_the_view() {
    // Blocks wholly outside the VIEW (beyond the default window 0..10 x 0..7, on every side and
    // just past its corner) are clipped away: the PNG is pixel for pixel the one without them,
    // and the SVG leaves them out (a 10^6-block model plotted through a small window wrote a
    // 1.7 GB SVG of shapes nobody could see).
    let dir = out_dir("plot_cull");
    let m = two_blocks();
    let mut with_far = two_blocks();
    let far = [[20.0, 0.0, 22.0, 1.0], [-5.0, 2.0, -3.0, 3.0], [2.0, 9.0, 4.0, 10.0], [2.0, -4.0, 4.0, -3.0], [10.05, 7.05, 11.0, 8.0]];
    for (id, r) in (100..).zip(far) {
        add_rect(&mut with_far, id, r, 0.1, false);
    }
    // One block overlapping the window's right edge is still drawn (in part).
    let mut with_edge = with_far.clone();
    add_rect(&mut with_edge, 200, [9.5, 3.0, 11.0, 4.0], 0.1, false);
    let vel = PlotOptions { velocities: true, ..Default::default() };
    let [png0, svg0] = plot(&m, &PlotSettings::default(), &vel, &dir, 1, "outputs.dat").unwrap();
    let [png1, svg1] = plot(&with_far, &PlotSettings::default(), &vel, &dir, 2, "outputs.dat").unwrap();
    let [png2, svg2] = plot(&with_edge, &PlotSettings::default(), &vel, &dir, 3, "outputs.dat").unwrap();
    let (p0, p1, p2) = (load_png(&png0), load_png(&png1), load_png(&png2));
    assert!(p0.data() == p1.data(), "blocks outside the view changed the PNG");
    assert!(p0.data() != p2.data(), "a block across the view's edge is drawn");
    let (s0, s1, s2) = [svg0, svg1, svg2].map(|p| std::fs::read_to_string(p).unwrap()).into();
    assert_eq!(s0, s1, "blocks outside the view are not in the SVG");
    assert_eq!(s2.matches(r#"class="block""#).count(), 3);
    assert!(s2.contains(r#"data-id="200""#));
    assert_eq!(s2.matches(r#"class="centroid""#).count(), 4, "the edge block's cross (10.25, 3.5) is in the view");

    // Zoomed out to the whole model, the outlines keep their shape but a rounding far under a
    // pixel is drawn as its corner: four points a rectangle, where 5-degree steps make 76.
    let far_view = PlotSettings { window: [-1.0e4, 1.0e4, -7.0e3, 7.0e3], ..Default::default() };
    let [_, svg] = plot(&m, &far_view, &PlotOptions::default(), &dir, 4, "outputs.dat").unwrap();
    let s = std::fs::read_to_string(svg).unwrap();
    let line = s.lines().find(|l| l.contains(r#"data-id="5""#)).unwrap();
    assert_eq!(line.matches(',').count(), 4, "{line}");
}

#[test]
fn plot_rejects_an_empty_window() {
    let m = two_blocks();
    let dir = out_dir("plot_empty");
    let settings = PlotSettings { window: [5.0, 5.0, 0.0, 7.0], ..Default::default() };
    let err = plot(&m, &settings, &PlotOptions::default(), &dir, 1, "outputs.dat").unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
    let settings = PlotSettings { view: [0, 2000, 700, 700], ..Default::default() };
    assert!(plot(&m, &settings, &PlotOptions::default(), &dir, 1, "outputs.dat").is_err());
}

#[test]
fn block_outline_follows_the_rounding_arcs() {
    let m = two_blocks();
    let sharp = block_outline(&m, 1, false);
    assert_eq!(sharp, vec![[2.0, 1.0], [4.0, 1.0], [4.0, 2.0], [2.0, 2.0]]);
    let round = block_outline(&m, 1, true);
    // Each corner contributes its two tangent points and the arc between them.
    for t in [[2.1, 1.0], [3.9, 1.0], [4.0, 1.1], [4.0, 1.9], [3.9, 2.0], [2.1, 2.0], [2.0, 1.9], [2.0, 1.1]] {
        assert!(round.iter().any(|p| (p[0] - t[0]).abs() < 1e-12 && (p[1] - t[1]).abs() < 1e-12), "no tangent point {t:?}");
    }
    for p in &round {
        assert!(p[0] >= 2.0 - 1e-12 && p[0] <= 4.0 + 1e-12 && p[1] >= 1.0 - 1e-12 && p[1] <= 2.0 + 1e-12);
        // A point is on an edge or on an arc of radius 0.1 about one of the circle centres.
        let on_edge = [p[0] - 2.0, 4.0 - p[0], p[1] - 1.0, 2.0 - p[1]].iter().any(|d| d.abs() < 1e-12);
        let on_arc = m.block_corners(1).iter().any(|c| ((p[0] - c.circle[0]).hypot(p[1] - c.circle[1]) - 0.1).abs() < 1e-12);
        assert!(on_edge || on_arc, "{p:?}");
    }
    // Counter-clockwise: positive signed area, a little less than the sharp 2 × 1.
    let area: f64 = (0..round.len())
        .map(|i| {
            let (a, b) = (round[i], round[(i + 1) % round.len()]);
            0.5 * (a[0] * b[1] - b[0] * a[1])
        })
        .sum();
    let expected = 2.0 - 4.0 * (0.01 - std::f64::consts::PI * 0.01 / 4.0);
    assert!(area < 2.0 && (area - expected).abs() < 1e-4, "area {area}, expected {expected}");
}

// ---------------------------------------------------------------------------------------------
// DUMP

#[test]
fn dump_writes_every_field() {
    let m = two_blocks();
    let t = text(|w| dump(&m, w));
    let (head, body) = t.trim_start().split_once('\n').unwrap();
    assert_eq!(head, "FULL STATE DUMP (CYCLE 600, TIME 1.250E+00)");
    let mut back: Model = serde_json::from_str(body).unwrap();
    // (The areas as built, like the extension arrays, are SAVE's trailers, not the model's own
    // serialization: each block here is built as it is.)
    back.blocks.iter_mut().for_each(|b| b.built_area = b.area);
    assert_eq!(back, m);
    // Kinds in the words of the state JSON and PRINT (issue 27 item 9: DUMP said "Rigid").
    assert!(body.contains("\"kind\": \"rigid\"") && !body.contains("\"Rigid\""), "{body}");
    if !m.contacts.is_empty() {
        assert!(body.contains("\"kind\": \"corner-") && !body.contains("\"Corner"), "{body}");
    }
}

// ---------------------------------------------------------------------------------------------
// VTK

#[test]
fn a_vtk_frame_holds_the_blocks_and_contacts() {
    // The two blocks as polygons through their corners, with their state as cell data; the
    // contact as a point at its contact point, with its forces as point data; read back with
    // vtkio's own parser.
    let m = two_blocks();
    let dir = out_dir("vtk_frame");
    let path = blockdem::udec::output::vtk::write_frame(&m, &dir).unwrap();
    assert_eq!(path, dir.join("blocks_000000600.vtk"));
    let blocks = common::VtkFrame::read(&path);
    let corners: Vec<f64> = (0..2).flat_map(|b| m.corner_positions(b)).flat_map(|p| [p[0], p[1], 0.0]).collect();
    assert_eq!(blocks.points, corners);
    assert_eq!(blocks.cells, [4, 0, 1, 2, 3, 4, 4, 5, 6, 7]);
    assert_eq!(blocks.array("id"), [3.0, 5.0]);
    assert_eq!(blocks.array("material"), [1.0, 2.0]);
    assert_eq!(blocks.array("fixed"), [1.0, 0.0]);
    assert_eq!(blocks.array("velocity"), [0.0, 0.0, 0.0, 0.5, -0.25, 0.0]);
    // The data in f32 (positions in f64, above).
    let f32s = |xs: &[f64]| xs.iter().map(|&x| x as f32 as f64).collect::<Vec<_>>();
    assert_eq!(blocks.array("angular_velocity"), f32s(&[0.0, 0.01]));
    assert_eq!(blocks.array("force")[3..5], [10.0, -2.0e4]);
    assert_eq!(blocks.array("mass"), f32s(&[m.blocks[0].mass, m.blocks[1].mass]));
    let contacts = common::VtkFrame::read(&dir.join("contacts_000000600.vtk"));
    assert_eq!(contacts.points, [2.0, 1.0, 0.0]);
    assert_eq!(contacts.cells, [1, 0]);
    assert_eq!(contacts.array("normal_force"), [1.962e4]);
    assert_eq!(contacts.array("shear_force"), [-12.5]);
    assert_eq!(contacts.array("gap"), f32s(&[-1.5e-4]));
    assert_eq!(contacts.array("normal"), [0.0, 1.0, 0.0]);
    assert_eq!(contacts.array("force"), [-12.5, 1.962e4, 0.0]);
    assert_eq!((contacts.array("block1"), contacts.array("block2")), (&[5.0][..], &[3.0][..]));
    assert_eq!((contacts.array("corner_corner"), contacts.array("bonded")), (&[0.0][..], &[1.0][..]));
}

#[test]
fn a_vtk_series_lists_its_frames_in_time_and_forgets_those_a_restart_goes_back_over() {
    use blockdem::udec::output::vtk::{add_to_series, Series, SeriesFrame, SERIES_FILE};
    let dir = out_dir("vtk_series");
    let path = dir.join(SERIES_FILE);
    let frame = |cycle: u64, time: f64| SeriesFrame { name: format!("blocks_{cycle:09}.vtk"), time };
    let read = || serde_json::from_slice::<Series>(&std::fs::read(&path).unwrap()).unwrap();
    for (cycle, time) in [(0, 0.0), (100, 0.5), (200, 1.0), (300, 1.5)] {
        add_to_series(&path, &frame(cycle, time).name, cycle, time).unwrap();
    }
    assert_eq!(read().files, [frame(0, 0.0), frame(100, 0.5), frame(200, 1.0), frame(300, 1.5)]);
    // ParaView's keys.
    let json: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(json["file-series-version"], "1.0");
    assert_eq!(json["files"][1]["name"], "blocks_000000100.vtk");
    // A run restarted from cycle 100 writes its frame of cycle 200 again: the old frames of
    // cycles 200 and 300 are not that run's.
    add_to_series(&path, &frame(200, 1.01).name, 200, 1.01).unwrap();
    assert_eq!(read().files, [frame(0, 0.0), frame(100, 0.5), frame(200, 1.01)]);
    // A damaged series file is started again rather than stopping the run.
    std::fs::write(&path, b"{ not json").unwrap();
    add_to_series(&path, &frame(300, 1.5).name, 300, 1.5).unwrap();
    assert_eq!(read().files, [frame(300, 1.5)]);
}

/// A plot says what it shows (issue 27, item 7): a caption with the deck, the cycle and the time,
/// axes in metres along the view's edges, the arrows' scale with the speed it stands for, and no
/// arrows for blocks at rest to round-off (a stack at rest, 1e-13 m/s, showed full-length
/// arrows, scaled to the largest of them). The PNG carries the same text where a font is found.
#[test]
fn a_plot_has_a_caption_axes_and_an_arrow_scale() {
    let dir = out_dir("plot_caption");
    let vel = PlotOptions { velocities: true, ..Default::default() };
    let mut m = two_blocks();
    m.blocks[1].velocity = [2.0, 0.0];
    let [png, svg] = plot(&m, &PlotSettings::default(), &vel, &dir, 1, "slide.dat").unwrap();
    let s = std::fs::read_to_string(&svg).unwrap();
    assert!(s.contains(">slide.dat   CYCLE 600   TIME 1.250E+00 s</text>"), "{s}");
    assert!(s.contains(">x (m)</text>") && s.contains(">y (m)</text>"), "{s}");
    // WINDOW 0 10 0 7 on the whole page: ticks every 2 m along both axes, their values written
    // (2, 4, 6 on both, 8 along x); those by the corners left out.
    for (v, n) in [(">2</text>", 2), (">4</text>", 2), (">6</text>", 2), (">8</text>", 1), (">0</text>", 0)] {
        assert_eq!(s.matches(v).count(), n, "tick value {v} in {s}");
    }
    assert_eq!(s.matches(r#"class="axis""#).count(), 7, "{s}");
    assert!(s.contains(">2.000E+00 m/s</text>") && s.contains(r#"class="scale""#), "{s}");
    assert!(s.contains(r#"class="velocity""#));

    // At rest to round-off: no arrow, and the plot says so.
    m.blocks[1].velocity = [1e-13, -3e-14];
    let [_, svg] = plot(&m, &PlotSettings::default(), &vel, &dir, 2, "stack.dat").unwrap();
    let s = std::fs::read_to_string(&svg).unwrap();
    assert!(!s.contains(r#"class="velocity""#) && !s.contains(r#"class="scale""#), "{s}");
    assert!(s.contains("VELOCITIES AT REST TO ROUND-OFF (LARGEST 1.044E-13 m/s)"), "{s}");
    // A slow block well above round-off still has its arrow.
    m.blocks[1].velocity = [1e-3, 0.0];
    let [_, svg] = plot(&m, &PlotSettings::default(), &vel, &dir, 3, "creep.dat").unwrap();
    assert!(std::fs::read_to_string(&svg).unwrap().contains(r#"class="velocity""#));

    // The PNG's caption: dark pixels along its line at the view's top left, where the page
    // without text is white.
    if blockdem::udec::output::font::font_bytes().is_ok() {
        let p = load_png(&png);
        let dark = (6..300).flat_map(|x| (6..24).map(move |y| (x, y))).filter(|&(x, y)| rgba(&p, x, y)[0] < 128).count();
        assert!(dark > 100, "only {dark} dark pixels where the caption is");
    }
}

/// PRINT CONTACTS names, on the view of a corner–corner touch that does not carry its force,
/// the contact that does (issue 27 item 9: both views were listed, one with zero force, with no
/// word on which counts). A block on an equal one: each top corner of the lower block touches a
/// corner of the upper, seen from both blocks.
#[test]
fn print_contacts_names_the_view_that_carries_a_corner_touch() {
    let deck =
        "START\nPROP MAT=1 DENS=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.1\nGRAV 0 -10\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX -1 2 -1 0.5\nCYCLE 50\n";
    let m = blockdem::scenes::run_deck_on(deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    let t = text(|w| print_contacts(&m, w));
    let corner_corner: Vec<&str> = t.lines().filter(|l| l.contains("CORNER/CORNER")).collect();
    assert_eq!(corner_corner.len(), 4, "{t}");
    // Of each pair exactly one view counts, and the other names it.
    let others: Vec<&str> = corner_corner.iter().copied().filter(|l| l.contains("OTHER VIEW")).collect();
    assert_eq!(others.len(), 2, "{t}");
    for l in &others {
        let named: u32 = l.rsplit("CONTACT ").next().unwrap().trim_end_matches(')').parse().unwrap();
        let c = m.contacts.iter().find(|c| c.id == named).unwrap_or_else(|| panic!("no contact {named}: {t}"));
        assert!(m.counts_force(c), "contact {named} is named as the one that counts: {t}");
        let this: u32 = l.split_whitespace().next().unwrap().parse().unwrap();
        let this = m.contacts.iter().find(|c| c.id == this).unwrap();
        assert!(!m.counts_force(this));
        assert_eq!((c.block1, c.block2), (this.block2, this.block1));
        assert!((c.point[0] - this.point[0]).abs() < 1e-9, "the same corner: {t}");
    }
}
