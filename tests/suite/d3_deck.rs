//! D3's deck language (SL-85-1 Appendix B) and its input errors: each names the line (and the
//! face) and says what was expected; the engine rule of `blockdem run`.

use blockdem::d3::deck::{parse_deck, three_dimensional, Command, PrintItem};
use blockdem::d3::exec::Executor;
use blockdem::deck::lexer::split;

const SAMPLE: &str = include_str!("../../examples/d3_two_tetrahedra.dat");

/// Runs a deck's commands; the run log and the error, if any.
fn run(deck: &str) -> (String, Result<(), String>) {
    let mut log = Vec::new();
    let result = match parse_deck(deck, "t.dat") {
        Ok(commands) => {
            let mut exec = Executor::new(Box::new(&mut log), "t.dat");
            exec.run(&commands).map_err(|e| e.to_string())
        }
        Err(e) => Err(e.to_string()),
    };
    (String::from_utf8(log).unwrap(), result)
}

fn error_of(deck: &str) -> String {
    run(deck).1.expect_err("the deck must be refused")
}

#[test]
fn the_sample_reads_as_appendix_b_writes_it() {
    let commands = parse_deck(SAMPLE, "sample").unwrap();
    let words: Vec<&Command> = commands.iter().map(|c| &c.command).collect();
    assert_eq!(words[0], &Command::Start);
    match &commands[2].command {
        Command::Block { material, constitutive, faces } => {
            assert_eq!((*material, *constitutive, faces.len()), (1, 1, 4));
            assert_eq!(faces[1].vertices, [[1.0, 0.0, 0.0], [1.0, 0.0, 1.0], [1.0, 1.0, 0.0]]);
            assert_eq!(faces[1].line, 11, "a continuation line's face keeps its own line");
        }
        other => panic!("expected BLOCK, found {other:?}"),
    }
    assert!(matches!(commands[5].command, Command::Gravity { g: [0.0, 0.0, -10.0] }));
    assert!(matches!(&commands[7].command, Command::Print { items } if items == &[PrintItem::Contacts, PrintItem::Velocities]));
    assert_eq!(commands.last().unwrap().command, Command::End);
}

#[test]
fn the_engine_is_told_by_the_deck() {
    let d3 = three_dimensional(&split(SAMPLE, "s").unwrap()).expect("the D3 sample is 3D");
    assert_eq!(d3.line, 10, "the first BLOCK of (x,y,z) vertices");
    let udec = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK (0,0) (1,0) (1,1) (0,1)\nGRAV 0 -10\nCYC 10\nSTOP\n";
    assert_eq!(three_dimensional(&split(udec, "u").unwrap()), None);
    let boxed = "START\nBOX 0 1 0 1 0 1\nSTOP\n";
    assert_eq!(three_dimensional(&split(boxed, "b").unwrap()).unwrap().what, "a BOX");
    let gravity = "START\nGRAVITY 0 0 -9.81\nSTOP\n";
    assert_eq!(three_dimensional(&split(gravity, "g").unwrap()).unwrap().line, 2);
}

#[test]
fn box_makes_a_closed_block_of_twelve_faces() {
    let (log, result) = run("START\nPROP MAT=2 D=1000 KN=1E8 KS=1E8\nBOX 0 1 0 2 0 3 MAT 2\nPRINT BLOCKS FACES VERT\nSTOP\n");
    result.unwrap();
    assert!(log.contains("FACE DATA") && log.contains("VERTEX COORDINATES") && log.contains("BLOCK DATA"));
    // Volume 6, mass 6000: the block line has them.
    assert!(log.contains("6.000E+00  6.000E+03"), "{log}");
    assert_eq!(log.lines().filter(|l| l.trim_start().starts_with("12 ")).count(), 1, "twelve faces");
}

/// The sample's first block with its faces in the wrong order, one at a time or all.
#[test]
fn wrong_or_mixed_orientation_names_the_face_and_line() {
    let mixed = "START\nBLOCK (0,0,0) (1,0,0) (1,1,0)\n+ (1,0,0) (1,1,0) (1,0,1)\n+ (0,0,0) (1,1,0) (1,0,1)\n+ (1,0,0) (0,0,0) (1,0,1)\nSTOP\n";
    let e = error_of(mixed);
    assert!(e.starts_with("t.dat:"), "{e}");
    assert!(e.contains("face ") && e.contains("ordered the other way round"), "{e}");
    let all = "START\nBLOCK (0,0,0) (1,1,0) (1,0,0)\n+ (1,0,0) (1,1,0) (1,0,1)\n+ (0,0,0) (1,0,1) (1,1,0)\n+ (1,0,0) (1,0,1) (0,0,0)\nSTOP\n";
    let e = error_of(all);
    assert!(e.starts_with("t.dat:2:") && e.contains("clockwise looking along the outward normal"), "{e}");
}

#[test]
fn an_open_surface_a_degenerate_face_and_loose_vertices_are_refused() {
    // The sample's tetrahedron without its last face.
    let open = "START\nBLOCK (0,0,0) (1,0,0) (1,1,0)\n+ (1,0,0) (1,0,1) (1,1,0)\n+ (0,0,0) (1,1,0) (1,0,1)\n+ (0,0,0) (1,1,0) (1,0,1)\nSTOP\n";
    let e = error_of(open);
    assert!(e.contains("face 4") && e.starts_with("t.dat:5:"), "{e}");
    let three = "START\nBLOCK (0,0,0) (1,0,0) (1,1,0)\n+ (1,0,0) (1,0,1) (1,1,0)\n+ (0,0,0) (1,1,0) (1,0,1)\nSTOP\n";
    assert!(error_of(three).contains("at least four faces"));
    let degenerate =
        "START\nBLOCK (0,0,0) (1,0,0) (1,1,0)\n+ (1,0,0) (1,0,1) (1,1,0)\n+ (0,0,0) (1,1,0) (1,0,1)\n+ (1,0,0) (0,0,0) (1,0,1)\n+ (0,0,0) (0.5,0,0) (1,0,0)\nSTOP\n";
    let e = error_of(degenerate);
    assert!(e.starts_with("t.dat:6:") && e.contains("face 5") && e.contains("degenerate"), "{e}");
    let loose = "START\nBLOCK (0,0,0) (1,0,0) (1,1,0)\n+ (1,0,0) (1,0,1)\nSTOP\n";
    let e = error_of(loose);
    assert!(e.starts_with("t.dat:3:") && e.contains("face 2 has 2 vertices") && e.contains("three at a time"), "{e}");
    let split_face = "START\nBLOCK 0 0 0 1 0 0\n+ 1 1 0 1 0 0 1 0 1 1 1 0\nSTOP\n";
    assert!(error_of(split_face).contains("face 1 is split across lines 2 and 3"));
    let coordinates = "START\nBLOCK 0 0 0 1 0 0 1 1\nSTOP\n";
    assert!(error_of(coordinates).contains("coordinates left over"));
}

#[test]
fn a_2d_command_in_a_3d_deck_is_named_as_such() {
    let fix4 = "START\nBOX 0 1 0 1 0 1\nFIX 0 1 0 1\nSTOP\n";
    let e = error_of(fix4);
    assert!(e.starts_with("t.dat:3:") && e.contains("2D range"), "{e}");
    let free4 = "START\nBOX 0 1 0 1 0 1\nFREE 0 1 0 1\nSTOP\n";
    assert!(error_of(free4).contains("2D range"));
    let grav2 = "START\nBOX 0 1 0 1 0 1\nGRAV 0 -10\nSTOP\n";
    assert!(error_of(grav2).contains("three components"));
    let round = "START\nBOX 0 1 0 1 0 1\nROUND 0.01\nSTOP\n";
    let e = error_of(round);
    assert!(e.contains("ROUND is a command of the 2D language"), "{e}");
    let pairs = "START\nGRAV 0 0 -10\nBLOCK (0,0) (1,0) (1,1)\nSTOP\n";
    assert!(error_of(pairs).contains("2D corner"));
    let rset = "START\nRSET 1.0 100 2\nSTOP\n";
    assert!(error_of(rset).contains("RSET is not supported"));
    let fluid = "START\nPROP MAT 1 JPERM 1\nSTOP\n";
    assert!(error_of(fluid).contains("fluid property"));
    let empty = "START\nBOX 1 0 0 1 0 1\nSTOP\n";
    assert!(error_of(empty).contains("empty range"));
}

#[test]
fn ranges_load_and_velocity_take_three_components() {
    let deck = "START\nPROP MAT 1 D 1000 KN 1E8 KS 1E8\nBOX 0 1 0 1 0 1\nLOAD -1 2 -1 2 -1 2 1 2 3\nVEL -1 2 -1 2 -1 2 1 0 0 0 0 2\nPRINT VEL\nSTOP\n";
    let (log, result) = run(deck);
    result.unwrap();
    assert!(log.contains("1.000E+00  0.000E+00  0.000E+00  0.000E+00  0.000E+00  2.000E+00"), "{log}");
    assert!(error_of("START\nBOX 0 1 0 1 0 1\nLOAD 0 1 0 1 0 1 1 2\nSTOP\n").contains("9 numbers, found 8"));
    // Two blocks whose kinetic energies f64 holds one by one but not summed: refused at the
    // VELOCITY line, the blocks left at rest.
    let e = error_of("START\nPROP MAT 1 D 1000 KN 1E8 KS 1E8\nBOX 0 1 0 1 0 1\nBOX 3 4 0 1 0 1\nVEL -1 5 -1 2 -1 2 4.5E152 0 0\nSTOP\n");
    assert!(e.contains(":5:") && e.contains("VELOCITY: the blocks would move so fast together"), "{e}");
}

#[test]
fn a_deck_errs_without_a_panic_on_cycle_without_properties() {
    let e = error_of("START\nBOX 0 1 0 1 0 1\nCYCLE 10\nSTOP\n");
    assert!(e.starts_with("t.dat:3:") && e.contains("time step"), "{e}");
    // Every block fixed: said so, not blamed on the properties.
    let e = error_of("START\nPROP MAT 1 D 1000 KN 1E8 KS 1E8\nBOX 0 1 0 1 0 1\nFIX -1 2 -1 2 -1 2\nCYCLE 10\nSTOP\n");
    assert!(e.starts_with("t.dat:5:") && e.contains("every block is fixed") && e.contains("FREE"), "{e}");
}

/// Boxes given overlapping past the limit are an input error at their CYCLE, said so (as 2D's
/// are), not a divergence to cure by a smaller FRACTION; boxes touching run.
#[test]
fn blocks_given_overlapping_are_named_at_the_cycle() {
    let base = "START\nPROP MAT 1 D 2000 KN 1E8 KS 1E8 F 0.5\nBOX -2 6 -2 6 -1 0\nFIX -3 7 -3 7 -2 0\nBOX 0 1 0 1 0 1\n";
    let e = error_of(&format!("{base}BOX 0.5 1.5 0 1 0.5 1.5\nGRAV 0 0 -10\nCYCLE 100\nSTOP\n"));
    assert!(e.starts_with("t.dat:8:") && e.contains("blocks 2 and 3 overlap") && e.contains("before any motion") && e.contains("given overlapping"), "{e}");
    assert!(!e.contains("FRACTION"), "{e}");
    let (_, r) = run(&format!("{base}BOX 1 2 0 1 0 1\nGRAV 0 0 -10\nCYCLE 100\nSTOP\n"));
    r.unwrap();
}

/// A density whose mass or inertia overflows f64 is refused where it is given (PROPERTY on a
/// material blocks have, a BOX of it, CHANGE to it), naming the line and the block, and leaves
/// the model as it was; one that does not overflow runs. Found by tests/suite/d3_random_decks.rs:
/// a density of 1e300 made a fixed slab's inertia 3.5e302 kg·m², whose determinant overflows,
/// and its angular velocity I⁻¹·0 NaN (`geometry::inertia_inverse` now inverts it at unit scale).
#[test]
fn a_density_that_overflows_a_blocks_mass_is_refused_at_its_line() {
    let base = "START\nPROP MAT 1 D 1000 KN 1E8 KS 1E8\nBOX -2 6 -2 6 -1 0\nFIX -3 7 -3 7 -2 0\n";
    let e = error_of(&format!("{base}PROP MAT 1 D 1E307\nSTOP\n"));
    assert!(e.starts_with("t.dat:5:") && e.contains("PROPERTY") && e.contains("block 1") && e.contains("overflows"), "{e}");
    let e = error_of(&format!("{base}PROP MAT 2 D 1E307 KN 1E8 KS 1E8\nBOX 0 10 0 10 0 1 MAT 2\nSTOP\n"));
    assert!(e.starts_with("t.dat:6:") && e.contains("BLOCK") && e.contains("block 2"), "{e}");
    let e = error_of(&format!("{base}PROP MAT 2 D 1E307 KN 1E8 KS 1E8\nCHANGE -3 7 -3 7 -2 0 MAT 2\nSTOP\n"));
    assert!(e.starts_with("t.dat:6:") && e.contains("CHANGE") && e.contains("block 1"), "{e}");
    // Refused whole: the material keeps its density, the slab its mass.
    let deck = format!("{base}BOX 0 1 0 1 0 1\nPROP MAT 1 D 1E307\nSTOP\n");
    let mut exec = Executor::new(Box::new(std::io::sink()), "t.dat");
    assert!(exec.run(&parse_deck(&deck, "t.dat").unwrap()).is_err());
    assert_eq!(exec.model.blocks[0].mass, 1000.0 * 64.0);
    assert_eq!(exec.model.material(1).density, 1000.0);
    // A density of 1e300 does not overflow: the fixed slab of it stays at rest (its angular
    // velocity was NaN), the box of material 2 on it runs, everything finite.
    let deck = format!("{base}PROP MAT 2 D 1000 KN 1E8 KS 1E8\nBOX 0 1 0 1 0 1 MAT 2\nGRAV 0 0 -10\nPROP MAT 1 D 1E300\nCYCLE 30\nSTOP\n");
    let mut exec = Executor::new(Box::new(std::io::sink()), "t.dat");
    exec.run(&parse_deck(&deck, "t.dat").unwrap()).unwrap();
    for b in &exec.model.blocks {
        assert!(
            b.angular_velocity.is_finite() && b.velocity.is_finite() && b.centroid.is_finite(),
            "block {}: {:?} {:?}",
            b.id,
            b.velocity,
            b.angular_velocity
        );
    }
    assert_eq!(exec.model.blocks[0].angular_velocity, glam::DVec3::ZERO);
    assert!(exec.model.blocks[1].velocity.length() > 0.0, "the box moves");
}

/// `blockdem run` picks the engine: the sample runs as D3 and prints its tables; `--dim 2` on it
/// is refused; a 3D deck given `--dim 3` without a 3D command still runs as D3.
#[test]
fn blockdem_run_takes_a_3d_deck_to_d3() {
    let exe = env!("CARGO_BIN_EXE_blockdem");
    let dir = std::env::temp_dir().join(format!("blockdem-d3-deck-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("state.json");
    let out = std::process::Command::new(exe)
        .args(["run", "--backend", "cpu", "examples/d3_two_tetrahedra.dat", "--state-json"])
        .arg(&json)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{log}{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(log.matches("CONTACT DATA").count(), 3);
    assert_eq!(log.matches("BLOCK VELOCITIES").count(), 3);
    assert!(log.contains("(VERTEX-FACE)"));
    assert!(log.contains("CURRENT CYCLE COUNT = 16"));
    let state: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(state["dim"], 3);
    for key in ["centroid", "velocity", "angular_velocity", "mass", "volume", "inertia", "vertices", "faces", "fixed"] {
        assert!(!state["blocks"][1][key].is_null(), "blocks have {key}");
    }
    for key in ["kind", "blocks", "point", "normal", "normal_force", "shear_force"] {
        assert!(!state["contacts"][0][key].is_null(), "contacts have {key}");
    }
    assert_eq!(state["contacts"][0]["kind"], "vertex-face");
    let refused = std::process::Command::new(exe)
        .args(["run", "--backend", "cpu", "--dim", "2", "examples/d3_two_tetrahedra.dat"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--dim 2"));
    let plain = dir.join("plain.dat");
    std::fs::write(
        &plain,
        "START\nPROP MAT 1 D 1000 KN 1E8 KS 1E8\nBLOCK 0 0 0 1 0 0 0 1 0\n+ 0 0 0 0 0 1 1 0 0\n+ 0 0 0 0 1 0 0 0 1\n+ 1 0 0 0 0 1 0 1 0\nPRINT BLOCKS\nSTOP\n",
    )
    .unwrap();
    let out = std::process::Command::new(exe).args(["run", "--backend", "cpu", "--dim", "3"]).arg(&plain).output().unwrap();
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{log}{}", String::from_utf8_lossy(&out.stderr));
    assert!(log.contains("BLOCK DATA"));
    let _ = std::fs::remove_dir_all(&dir);
}
