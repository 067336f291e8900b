//! D3's outputs: SAVE/RESTART (a restarted run goes on bit for bit as the saving run would have,
//! a damaged or foreign file is refused naming it), DUMP (the whole state), VTK frames and their
//! series, and `blockdem run`, which tells a deck that restarts a D3 file for a D3 deck.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use blockdem::d3::deck::parse_deck;
use blockdem::d3::exec::Executor;
use blockdem::d3::model::Model;
use blockdem::d3::output::state_json;

/// Runs a deck with SAVE/RESTART files in `dir`; the model, the log and the error, if any.
fn run(deck: &str, dir: &Path) -> (Model, String, Result<(), String>) {
    let mut log = Vec::new();
    let commands = parse_deck(deck, "t.dat").unwrap_or_else(|e| panic!("{e}"));
    let (model, r) = {
        let mut exec = Executor::new(Box::new(&mut log), "t.dat");
        exec.set_out_dir(dir);
        let r = exec.run(&commands).map_err(|e| e.to_string());
        (std::mem::take(&mut exec.model), r)
    };
    (model, String::from_utf8(log).unwrap(), r)
}

fn ok(deck: &str, dir: &Path) -> (Model, String) {
    let (m, log, r) = run(deck, dir);
    r.unwrap_or_else(|e| panic!("{e}\n{log}"));
    (m, log)
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("blockdem-d3-restart-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A block that falls onto a fixed base beside another, slides on the tilted gravity (so its
/// neighbour lists are rebuilt several times and its contacts carry shear history) and is cut
/// by a SPLIT on the way.
const SCENE: &str = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.3\nBOX -2 6 -2 2 -1 0\nBOX 0 1 -0.5 0.5 0.001 0.6\n\
                     BOX 2 3 -0.5 0.5 0 1\nFIX -2 6 -2 2 -1 -0.1\nGRAV 4 1 -9\nDAMP 0.05 50 MASS\n";

fn same(a: &Model, b: &Model, what: &str) {
    assert_eq!(state_json(a, None), state_json(b, None), "{what}: the state JSON differs");
    assert!(a == b, "{what}: the models differ");
}

#[test]
fn cycle_save_restart_cycle_is_the_same_run_bit_for_bit() {
    let dir = scratch("resume");
    let (whole, _) = ok(&format!("{SCENE}CYCLE 900\nSPLIT 0.5 0 0 1 0.2 0.1\nCYCLE 700\n"), &dir);
    // The plane cuts the sliding block and the fixed base (five blocks).
    assert!(whole.blocks.len() == 5 && whole.contacts.iter().any(|c| c.shear_force().length() > 0.0), "the scene slides with shear history");
    let (_, log) = ok(&format!("{SCENE}CYCLE 900\nSPLIT 0.5 0 0 1 0.2 0.1\nCYCLE 300\nSAVE\n"), &dir);
    assert!(log.contains(&format!("STATE SAVED TO {}", dir.join("blockdem.sav").display())), "{log}");
    let (restarted, log) = ok("RESTART\nCYCLE 400\n", &dir);
    assert!(log.contains("THIS IS A RESTART RUN") && log.contains("CYCLE 1200"), "{log}");
    same(&whole, &restarted, "CYCLE 1600 against CYCLE 1200, SAVE, RESTART, CYCLE 400");

    // A state changed after its CYCLE (so the next CYCLE starts with a full contact detection)
    // restarts as such too.
    let (whole, _) = ok(&format!("{SCENE}CYCLE 500\nFREE -2 6 -2 2 -1 -0.1\nFIX -2 6 -2 2 -1 -0.1\nCYCLE 300\n"), &dir);
    ok(&format!("{SCENE}CYCLE 500\nFREE -2 6 -2 2 -1 -0.1\nFIX -2 6 -2 2 -1 -0.1\nSAVE changed.sav\n"), &dir);
    let (restarted, _) = ok("RESTART changed.sav\nCYCLE 300\n", &dir);
    same(&whole, &restarted, "a changed state saved and restarted");
}

#[test]
fn the_file_round_trips_and_damage_is_refused_naming_the_file() {
    let dir = scratch("damage");
    let (model, _) = ok(&format!("{SCENE}CYCLE 200\nSAVE a.sav\n"), &dir);
    let path = dir.join("a.sav");
    let saved = blockdem::d3::restart::load(&path).unwrap();
    assert!(saved.model == model && saved.resumable);
    assert!(blockdem::d3::restart::is_save_file(&path));
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..8], b"BLOCKD3\0");

    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("truncated.sav", bytes[..bytes.len() - 9].to_vec(), "truncated or appended to"),
        (
            "flipped.sav",
            {
                let mut b = bytes.clone();
                let k = b.len() - 100;
                b[k] ^= 0x40;
                b
            },
            "the payload checksum does not match",
        ),
        (
            "version.sav",
            {
                let mut b = bytes.clone();
                b[8] = 99;
                b
            },
            "is D3 save format version 99",
        ),
        ("deck.sav", b"START\nBOX 0 1 0 1 0 1\n".to_vec(), "is not a D3 save file"),
        ("udec.sav", b"BLOCKDEM\x05\0\0\0".to_vec(), "is a 2D (UDEC) save file: RESTART it from a 2D deck"),
        ("short.sav", b"BLOCKD3\0\x01\0".to_vec(), "the header is truncated"),
    ];
    for (name, content, expect) in cases {
        std::fs::write(dir.join(name), content).unwrap();
        let (_, _, r) = run(&format!("RESTART {name}\n"), &dir);
        let e = r.expect_err(name);
        assert!(e.contains("t.dat:1") && e.contains("RESTART") && e.contains(name) && e.contains(expect), "{name}: {e}");
    }
    let (_, _, r) = run("RESTART nowhere.sav\n", &dir);
    assert!(r.expect_err("missing").contains("cannot access save file"));
}

#[test]
fn dump_writes_the_whole_state() {
    let dir = scratch("dump");
    let (model, log) = ok(&format!("{SCENE}CYCLE 50\nDUMP\nDUMP 1 100\n"), &dir);
    assert_eq!(log.matches("FULL STATE DUMP (CYCLE 50, TIME").count(), 2, "{log}");
    assert!(log.contains(&format!("BLOCKS (IBPNT) 3  CONTACTS (ICPNT) {}", model.contacts.len())), "{log}");
    // The JSON after the heading is the model.
    let start = log.find("\n{").unwrap() + 1;
    let mut de = serde_json::Deserializer::from_str(&log[start..]).into_iter::<serde_json::Value>();
    let json = de.next().unwrap().unwrap();
    assert_eq!(json["blocks"].as_array().unwrap().len(), 3);
    assert_eq!(json["cycle"], 50);
    // A rigid scene has no extension arrays to show.
    assert!(!log.contains("EXTENSION ("), "{log}");
    let e = parse_deck(&format!("{SCENE}DUMP 1 2 3\n"), "t.dat").unwrap_err().to_string();
    assert!(e.contains("t.dat:9") && e.contains("DUMP takes [n m]"), "{e}");
    // A simply-deformable block's strain and a held block, which the model's own fields leave to
    // the save file's extension arrays, follow the model.
    let deck = "START\nPROP MAT=1 D=1000 K=1E8 G=6E7 KN=1E8 KS=1E8\nBOX 0 1 0 1 0 1\nBOX 2 3 0 1 0 1\nCHANGE 0 1 0 1 0 1 SDEF\n\
                BOUNDARY VELOCITY 2 3 0 1 0 1 1 0 0\nCYCLE 5\nDUMP\n";
    let (_, log) = ok(deck, &dir);
    let start = log.find("EXTENSION (").unwrap_or_else(|| panic!("{log}"));
    let at = start + log[start..].find('{').unwrap();
    let json: serde_json::Value = serde_json::Deserializer::from_str(&log[at..]).into_iter().next().unwrap().unwrap();
    assert_eq!(json["extension"]["sdef"][0][0], 0, "{json}");
    assert_eq!(json["boundaries"]["held"], serde_json::json!([1]), "{json}");
}

#[test]
fn blockdem_run_restarts_a_d3_file_with_the_d3_engine() {
    let dir = scratch("cli");
    let first = dir.join("first.dat");
    std::fs::write(&first, format!("{SCENE}CYCLE 100\nSAVE\nSTOP\n")).unwrap();
    let bin = env!("CARGO_BIN_EXE_blockdem");
    let out = dir.join("out");
    let o = Command::new(bin).args(["run", first.to_str().unwrap(), "--backend", "cpu", "--out", out.to_str().unwrap()]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("blockdem.sav").exists());
    let again = dir.join("again.dat");
    std::fs::write(&again, "RESTART\nCYCLE 50\nPRINT VEL\nSTOP\n").unwrap();
    let state = dir.join("state.json");
    let o = Command::new(bin)
        .args(["run", again.to_str().unwrap(), "--backend", "cpu", "--out", out.to_str().unwrap(), "--state-json", state.to_str().unwrap()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}\n{stdout}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("THIS IS A RESTART RUN") && stdout.contains("BLOCK VELOCITIES"), "{stdout}");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&state).unwrap()).unwrap();
    assert_eq!((json["dim"].as_u64(), json["cycle"].as_u64()), (Some(3), Some(150)));
}

#[test]
fn vtk_frames_hold_the_faces_with_their_blocks_motion_and_the_contacts_forces() {
    let dir = scratch("vtk");
    let (m, log) = ok(&format!("{SCENE}VTK\nCYCLE 300\nVTK\n"), &dir);
    assert!(log.contains("VTK FRAME WRITTEN TO") && log.contains("blocks_000000300.vtk"), "{log}");
    let vtk = dir.join(blockdem::d3::exec::VTK_DIR);
    let series: blockdem::output::vtk::Series = serde_json::from_slice(&std::fs::read(vtk.join(blockdem::d3::vtk::SERIES_FILE)).unwrap()).unwrap();
    let names: Vec<&str> = series.files.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["blocks_000000000.vtk", "blocks_000000300.vtk"]);
    assert!(series.files[0].time == 0.0 && series.files[1].time == m.time);

    let blocks = common::VtkFrame::read(&vtk.join("blocks_000000300.vtk"));
    let points: Vec<f64> = m.blocks.iter().flat_map(|b| b.vertices.iter().flat_map(|v| v.to_array())).collect();
    assert_eq!(blocks.points, points);
    let faces: usize = m.blocks.iter().map(|b| b.shape.faces.len()).sum();
    assert_eq!(blocks.cells.len(), 4 * faces);
    // Block 2's faces (after the base's twelve) run through its own vertices (8 from 8).
    assert_eq!(blocks.cells[48..52], [3, 8 + m.blocks[1].shape.faces[0][0], 8 + m.blocks[1].shape.faces[0][1], 8 + m.blocks[1].shape.faces[0][2]]);
    let velocity = blocks.array("velocity");
    assert_eq!(velocity.len(), 3 * faces);
    let v = m.blocks[1].velocity;
    assert_eq!(velocity[36..39], [v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64]);
    assert_eq!(blocks.array("id")[12], 2.0);
    assert_eq!(blocks.array("fixed")[0], 1.0);
    assert_eq!(blocks.array("angular_velocity").len(), 3 * faces);

    let contacts = common::VtkFrame::read(&vtk.join("contacts_000000300.vtk"));
    let real: Vec<_> = m.contacts.iter().filter(|c| c.category.is_some()).collect();
    assert!(!real.is_empty());
    assert_eq!(contacts.points.len(), 3 * real.len());
    assert_eq!(contacts.array("normal_force").len(), real.len());
    let c = real[0];
    assert_eq!(contacts.points[..3], c.point().to_array());
    assert_eq!(contacts.array("normal_force")[0], c.normal_force() as f32 as f64);
    let f = c.normal * c.normal_force() + c.shear_force();
    assert_eq!(contacts.array("force")[..3], f.to_array().map(|x| x as f32 as f64));
    assert_eq!(contacts.array("shear_force").len(), 3 * real.len());
    assert_eq!(contacts.array("normal").len(), 3 * real.len());
    assert_eq!(
        (contacts.array("block1")[0], contacts.array("block2")[0]),
        (m.blocks[c.blocks[0] as usize].id as f64, m.blocks[c.blocks[1] as usize].id as f64)
    );
}

/// PRINT ENERGY (an extension, as 2D's): the ledger's terms as `Model::energies` has them, and
/// the balance.
#[test]
fn print_energy_lists_the_ledger() {
    let dir = scratch("energy");
    let (model, log) = ok(&format!("{SCENE}CYCLE 300\nP E\n"), &dir);
    let e = model.energies();
    let f = blockdem::output::format::fmt_e;
    let table = &log[log.find("\nENERGY\n").expect("the ENERGY table")..];
    for (what, value) in [("KINETIC", e.kinetic), ("FRICTION", e.friction), ("WORK OF GRAVITY, LOADS, VELOCITY AND BOUNDARY", e.external_work)] {
        assert!(table.contains(&format!("{what} {}", f(value))), "{what} {}: {table}", f(value));
    }
    assert!(e.friction > 0.0 && e.mass_damping > 0.0, "{e:?}");
    assert!(table.contains(&format!("BALANCE: KINETIC + STRAIN + DISSIPATED + RELEASED - WORK = {}", f(e.ledger()))), "{table}");
    let _ = std::fs::remove_dir_all(&dir);
}
