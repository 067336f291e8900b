//! The command-language parser against SL-85-1 Appendix A ("Input Commands"): every command in
//! full, abbreviated, mixed-case and with each separator; the sample decks; the error cases with
//! their line numbers and messages; continuation and comment handling; and a no-panic proptest.

use blockdem::udec::deck::*;
use proptest::prelude::*;

const FILE: &str = "t.dat";

fn parse(text: &str) -> Vec<Located> {
    parse_deck(text, FILE).unwrap_or_else(|e| panic!("unexpected error: {e}\n--- deck ---\n{text}"))
}

/// The single command in `START\n<body>`.
fn one(body: &str) -> Command {
    let v = parse(&format!("START\n{body}\n"));
    assert_eq!(v.len(), 2, "{body}: {v:?}");
    v[1].command.clone()
}

/// All of `bodies` must parse (after START) to the same command, `want`.
fn all_give(bodies: &[&str], want: Command) {
    for b in bodies {
        assert_eq!(one(b), want, "{b}");
    }
}

fn err(text: &str) -> DeckError {
    match parse_deck(text, FILE) {
        Ok(v) => panic!("expected an error, got {v:?}\n--- deck ---\n{text}"),
        Err(e) => e,
    }
}

/// The deck must fail on `line` with a message containing each of `needles`.
fn assert_err(text: &str, line: usize, needles: &[&str]) -> DeckError {
    let e = err(text);
    assert_eq!(e.file, FILE);
    assert_eq!(e.line, line, "wrong line for: {}\n--- deck ---\n{text}", e.message);
    for n in needles {
        assert!(e.message.contains(n), "message {:?} lacks {:?}", e.message, n);
    }
    e
}

/// `START` on line 1, then `body` starting on line 2.
fn assert_body_err(body: &str, line: usize, needles: &[&str]) -> DeckError {
    assert_err(&format!("START\n{body}\n"), line, needles)
}

fn range(x1: f64, x2: f64, y1: f64, y2: f64) -> Range {
    Range { x1, x2, y1, y2 }
}

fn sample(name: &str) -> String {
    let path = format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

// ---------------------------------------------------------------------------------------------
// Every command: full names, minimum abbreviations, mixed case, each separator.
// ---------------------------------------------------------------------------------------------

#[test]
fn start_stop_end_restart_save() {
    for s in ["START", "STA", "start", "StArT"] {
        assert_eq!(parse(s)[0].command, Command::Start);
    }
    for s in ["RESTART", "R", "restart", "Res"] {
        assert_eq!(parse(s)[0].command, Command::Restart { file: None });
    }
    assert_eq!(parse("RESTART Run1.SAV")[0].command, Command::Restart { file: Some("Run1.SAV".into()) });
    all_give(&["STOP", "S", "st", "sToP"], Command::Stop);
    all_give(&["SAVE", "SA", "sav"], Command::Save { file: None });
    all_give(&["SAVE MyRun.sav", "sa=MyRun.sav", "SAVE (MyRun.sav)"], Command::Save { file: Some("MyRun.sav".into()) });
    let v = parse("START\nEND\n");
    assert_eq!(v[1].command, Command::End);
    for e in ["END", "E", "en", "eNd"] {
        assert_eq!(parse(&format!("START\n{e}"))[1].command, Command::End);
    }
}

#[test]
fn block_all_forms() {
    let sq = vec![[0.0, 0.0], [0.0, 30.0], [40.0, 30.0], [40.0, 0.0]];
    all_give(
        &[
            "BLOCK (0,0) (0,30) (40,30) (40,0)",
            "B 0 0 0 30 40 30 40 0",
            "block 0,0 0,30 40,30 40,0",
            "Bl 0/0 0/30 40/30 40/0",
            "BLOCK\t0 , 0 ,0,30 40 30 40 0",
            "BLOCK 0.,0. 0.,30. 40.,30. 40.,0.",
            "BLOCK 0E0 0 0 3E1 4.0e+01 30 40 -0",
        ],
        Command::Block { material: None, constitutive: None, corners: sq.clone() },
    );
    all_give(
        &[
            "BLOCK MAT=1 CONS=4 0,0 0,30 40,30 40,0",
            "B M 1 CO 4 0 0 0 30 40 30 40 0",
            "block material (1) constitutive (4) 0 0 0 30 40 30 40 0",
            "BLOCK CONS=4 MAT=1 0,0 0,30 40,30 40,0",
        ],
        Command::Block { material: Some(1), constitutive: Some(4), corners: sq },
    );
}

#[test]
fn change_all_forms() {
    let r = range(1.0, 5.0, 1.0, 2.0);
    all_give(
        &["CHANGE 1,5 1,2 SDEF", "CH 1 5 1 2 S", "change 1 5 1 2 sdef", "CHA (1,5) (1,2) Sd"],
        Command::Change { range: r, to: Some(Deformability::Sdef), material: None, constitutive: None },
    );
    all_give(
        &["CHANGE 2 6 3 7 FDEF", "ch 2 6 3 7 f"],
        Command::Change { range: range(2.0, 6.0, 3.0, 7.0), to: Some(Deformability::Fdef), material: None, constitutive: None },
    );
    all_give(
        &["CHANGE 4.5 5.5 7 8 MAT=2", "CH 4.5,5.5 7,8 M 2"],
        Command::Change { range: range(4.5, 5.5, 7.0, 8.0), to: None, material: Some(2), constitutive: None },
    );
    all_give(
        &["CHANGE 1 5 1 2 FDEF MAT 3 CONS 2", "CHANGE 1 5 1 2 CONS=2, MAT=3, F", "CHANGE MAT 3 1 5 1 2 CO 2 FDEF"],
        Command::Change { range: r, to: Some(Deformability::Fdef), material: Some(3), constitutive: Some(2) },
    );
}

#[test]
fn cycle_all_forms() {
    all_give(&["CYCLE 600", "C 600", "cyc 600", "Cycle=600", "CYCLE (600)"], Command::Cycle { n: 600 });
    all_give(&["CYCLE 0"], Command::Cycle { n: 0 });
}

#[test]
fn damping_all_forms() {
    all_give(
        &["DAMP .1 15 (MASS)", "DAMPING 0.1 15 MASS", "D .1 15 M", "damping .1,15,mass", "DA .1 15 / Ma"],
        Command::Damping { fcrit: 0.1, freq: 15.0, mode: DampMode::Mass },
    );
    all_give(&["DAMP .5 16. INTERNAL", "D .5 16 I"], Command::Damping { fcrit: 0.5, freq: 16.0, mode: DampMode::Internal });
    all_give(&["DAMP .5 16 STIFFNESS", "d .5 16 s"], Command::Damping { fcrit: 0.5, freq: 16.0, mode: DampMode::Stiffness });
    all_give(&["DAMP .5 16", "DAMPING=0.5=16"], Command::Damping { fcrit: 0.5, freq: 16.0, mode: DampMode::Full });
    all_give(&["DAMP 0 16"], Command::Damping { fcrit: 0.0, freq: 16.0, mode: DampMode::Full });
}

#[test]
fn range_commands_all_forms() {
    let r = range(0.0, 40.0, 0.0, 5.0);
    all_give(&["DELETE 0,40 0,5", "DE 0 40 0 5", "del (0,40) (0,5)", "DELETE 0=40/0=5"], Command::Delete { range: r });
    all_give(&["FIX 0,40 0,5", "F 0 40 0 5", "fix (0 40) (0 5)", "Fi\t0/40/0/5"], Command::Fix { range: r });
    all_give(&["FREE 0,40 0,5", "FR 0 40 0 5", "fre 0 40 0 5"], Command::Free { range: r });
    all_give(
        &["LOAD 1,5 2,3.35 -0.3E4 -0.95E4", "L 1 5 2 3.35 -3000 -9500", "lo (1,5) (2,3.35) (-.3e4,-.95e+4)"],
        Command::Load { range: range(1.0, 5.0, 2.0, 3.35), force: [-3000.0, -9500.0] },
    );
}

#[test]
fn dump_fraction_fluid_round() {
    all_give(&["DUMP", "DU"], Command::Dump { from: None, to: None });
    all_give(&["DUMP 10 200", "du 10,200"], Command::Dump { from: Some(10), to: Some(200) });
    all_give(&["FRACTION 0.1", "FRA .1", "frac=0.1"], Command::Fraction { f: 0.1 });
    all_give(&["FRACTION 1.5"], Command::Fraction { f: 1.5 });
    all_give(&["FLUID 0.0 1.0E9", "FL 0 1e9", "fluid (0, 1.0E+9)"], Command::Fluid { density: 0.0, bulk: 1e9 });
    all_give(&["ROUND 0.2", "RO .2", "ROUND = 0.2", "round(0.2)"], Command::Round { d: 0.2 });
}

#[test]
fn generate_all_forms() {
    all_give(
        &["GEN 2 6 3 7 AUTO=1.1", "GENERATE 2,6 3,7 AUTOMATIC 1.1", "ge 2 6 3 7 a 1.1"],
        Command::Generate { range: range(2.0, 6.0, 3.0, 7.0), mesh: Mesh::Auto { max_edge: 1.1 } },
    );
    let manual = Command::Generate {
        range: range(0.0, 10.0, 0.0, 10.0),
        mesh: Mesh::Manual { grid_points: vec![[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]], zones: vec![[4, 3, 2], [4, 2, 1]] },
    };
    all_give(
        &[
            "GENERATE 0 10 0 10 MANUAL GRIDPOINTS (1,1) (1,2) (2,2) (2,1) ZONES (4,3,2) (4,2,1)",
            "GE 0 10 0 10 M GR 1 1 1 2 2 2 2 1 Z 4 3 2 4 2 1",
            "gen 0 10 0 10 manual 1,1 1,2 2,2 2,1 zones 4,3,2 4,2,1",
            "GEN 0 10 0 10 MAN GRID (1,1) (1,2)\n+ (2,2) (2,1)\n+ ZONES (4,3,2)\n+ (4,2,1)",
        ],
        manual,
    );
}

#[test]
fn gravity_link_pfix_pfree() {
    all_give(&["GRAV 0 -10", "GRAVITY 0. -10.", "G 0,-10", "gr (0,-10)"], Command::Gravity { g: [0.0, -10.0] });
    all_give(&["LINK 3,3 4,1.5", "LI 3 3 4 1.5", "link (3,3) (4,1.5)"], Command::Link { flying: [3.0, 3.0], anchor: [4.0, 1.5] });
    all_give(&["PFIX OUTER 0.0", "PF O 0", "pfix outer=0"], Command::PFix { domain: DomainRef::Outer, pressure: 0.0 });
    all_give(&["PFIX 3 1E6", "PF 3,1e6"], Command::PFix { domain: DomainRef::Number(3), pressure: 1e6 });
    all_give(&["PFREE OUTER", "PFR O", "pfree outer"], Command::PFree { domain: DomainRef::Outer });
    all_give(&["PFREE 7", "pfr (7)"], Command::PFree { domain: DomainRef::Number(7) });
    all_give(&["PFIX AT 1.5 2.5 1E5", "pf at (1.5, 2.5) 1e5"], Command::PFix { domain: DomainRef::At([1.5, 2.5]), pressure: 1e5 });
}

#[test]
fn plot_all_forms() {
    all_give(&["PLOT", "PL", "plot"], Command::Plot { options: PlotOptions::default() });
    all_give(
        &["PLOT NOFIX ZONES NC VEL", "PL N Z NC V", "plot nofix,zones,nc,velocity", "PLOT (VEL) NC / Z N"],
        Command::Plot { options: PlotOptions { nofix: true, zones: true, no_rounding: true, velocities: true, pressure: false } },
    );
    all_give(&["PLOT ZONES"], Command::Plot { options: PlotOptions { zones: true, ..Default::default() } });
}

#[test]
fn print_all_forms() {
    use PrintItem::*;
    all_give(
        &["P B C COR DL L", "PRINT BLOCKS CONTACTS CORNERS DLIST LIST", "print b,c,cor,dl,l"],
        Command::Print { items: vec![Blocks, Contacts, Corners, DList, List] },
    );
    all_give(&["PRINT FLOWS, DOMAINS, BLOCKS", "PR F D B"], Command::Print { items: vec![Flows, Domains, Blocks] });
    all_give(&["PRINT ENERGY", "P E"], Command::Print { items: vec![Energy] });
    all_give(&["PRINT CON", "P CO"], Command::Print { items: vec![Contacts] });
}

#[test]
fn property_all_forms() {
    use PropKey::*;
    assert_eq!(
        one("PROP MAT=1 DENS=2000 KN=1E8 KS=1E8 F=2 TF=2.5E4"),
        Command::Property { material: 1, values: vec![(Density, 2000.0), (Kn, 1e8), (Ks, 1e8), (Friction, 2.0), (Tf, 2.5e4)] }
    );
    assert_eq!(
        one("PROPERTY MATERIAL 2 BULK 1 K 2 G 3 DENSITY 4 COHESION 5 FRICTION 6 JKN 7 JKS 8 JCOHESION 9 JFRICTION 10 TF 11 JPERM 12 CPERM 13 AZERO 14 ARES 15"),
        Command::Property {
            material: 2,
            values: vec![
                (Bulk, 1.0),
                (Bulk, 2.0),
                (Shear, 3.0),
                (Density, 4.0),
                (Cohesion, 5.0),
                (Friction, 6.0),
                (Jkn, 7.0),
                (Jks, 8.0),
                (Jcohesion, 9.0),
                (Jfriction, 10.0),
                (Tf, 11.0),
                (Jperm, 12.0),
                (Cperm, 13.0),
                (Azero, 14.0),
                (Ares, 15.0),
            ],
        }
    );
    assert_eq!(
        one("pro m 2 b 1 k 2 g 3 d 4 c 5 f 6 jkn 7 jks 8 jc 9 jf 10 t 11 jp 12 cp 13 az 14 ar 15"),
        one("PROPERTY MATERIAL 2 BULK 1 K 2 G 3 DENSITY 4 COHESION 5 FRICTION 6 JKN 7 JKS 8 JCOHESION 9 JFRICTION 10 TF 11 JPERM 12 CPERM 13 AZERO 14 ARES 15"),
    );
    assert_eq!(
        one("PROP MAT=1 D=2000 KN=1E6 KS=1E8 FRIC=.1 C=1E6 BULK=2E6 JCOH=0 JFRIC=0"),
        Command::Property {
            material: 1,
            values: vec![(Density, 2000.0), (Kn, 1e6), (Ks, 1e8), (Friction, 0.1), (Cohesion, 1e6), (Bulk, 2e6), (Jcohesion, 0.0), (Jfriction, 0.0)]
        }
    );
    assert_eq!(one("Prop (Mat 1) (CPerm 1E-9)"), Command::Property { material: 1, values: vec![(Cperm, 1e-9)] });
}

#[test]
fn split_all_forms() {
    all_give(
        &["SPLIT -1,10 41,10", "SP -1 10 41 10", "split (-1,10) (41,10)", "Spl -1.=10./41.=10."],
        Command::Split { from: [-1.0, 10.0], to: [41.0, 10.0], material: None, constitutive: None },
    );
    all_give(
        &["SPLIT 10.,20 41.,20 MAT=1, CONS=1", "SPLIT 10 20 41 20 CONS 1 MAT 1", "sp 10 20 41 20 m 1 co 1"],
        Command::Split { from: [10.0, 20.0], to: [41.0, 20.0], material: Some(1), constitutive: Some(1) },
    );
}

#[test]
fn view_window_velocity() {
    all_give(&["VIEW 0 700 700 1400", "V 0,700 700,1400", "view (0 700) (700 1400)"], Command::View { ix1: 0, ix2: 700, iy1: 700, iy2: 1400 });
    all_give(&["WINDOW 0 50 0 50", "WIND 0 50 0 50", "w 0,50 0,50"], Command::Window { x1: 0.0, x2: 50.0, y1: 0.0, y2: 50.0 });
    all_give(
        &["VELOCITY 0 1 0 1 2 -3", "VE 0 1 0 1 2 -3", "vel (0,1) (0,1) (2,-3)"],
        Command::Velocity { range: range(0.0, 1.0, 0.0, 1.0), velocity: [2.0, -3.0], angular: None },
    );
    all_give(&["VELOCITY 0 1 0 1 2 -3 0.5"], Command::Velocity { range: range(0.0, 1.0, 0.0, 1.0), velocity: [2.0, -3.0], angular: Some(0.5) });
    // VTK (extension): a frame for ParaView; VT is its shortest form (V is VIEW, VE VELOCITY).
    all_give(&["VTK", "VT", "vtk"], Command::Vtk);
}

// ---------------------------------------------------------------------------------------------
// Sample decks (SL-85-1 Appendix A figures A1–A4, Appendix B figure B1).
// ---------------------------------------------------------------------------------------------

#[test]
fn sample_1_point_load_cracking() {
    let v = parse(&sample("udec1_point_load_cracking.dat"));
    assert_eq!(v.len(), 21);
    assert_eq!(v[0].command, Command::Start);
    assert_eq!(v[0].line, 5);
    assert_eq!(v[3].command, Command::Damping { fcrit: 0.1, freq: 15.0, mode: DampMode::Mass });
    assert_eq!(v[3].source, "DAMP .1 15 (MASS)");
    assert_eq!(v[13].command, Command::Window { x1: 0.0, x2: 50.0, y1: 0.0, y2: 50.0 });
    assert_eq!(v.last().unwrap().command, Command::End);
}

#[test]
fn sample_2_pressurized_cavity() {
    let v = parse(&sample("udec2_pressurized_cavity.dat"));
    assert_eq!(v.len(), 24);
    assert!(v.iter().any(|l| l.command == Command::PFix { domain: DomainRef::Outer, pressure: 0.0 }));
    let split = v.iter().find(|l| l.source == "SPLIT 10.,20 41.,20 MAT=1, CONS=1").unwrap();
    assert_eq!(split.command, Command::Split { from: [10.0, 20.0], to: [41.0, 20.0], material: Some(1), constitutive: Some(1) });
    assert_eq!(split.line, 21);
    assert_eq!(v[v.len() - 4].command, Command::Print { items: vec![PrintItem::Flows, PrintItem::Domains, PrintItem::Blocks] });
}

#[test]
fn sample_3_deformable_block() {
    let v = parse(&sample("udec3_deformable_block.dat"));
    assert_eq!(v.len(), 23);
    assert!(v.iter().any(|l| l.command == Command::Generate { range: range(2.0, 6.0, 3.0, 7.0), mesh: Mesh::Auto { max_edge: 1.1 } }));
    assert!(v.iter().any(|l| l.command == Command::Round { d: 0.2 }));
}

#[test]
fn sample_4_projectile_beam() {
    let v = parse(&sample("udec4_projectile_beam.dat"));
    assert_eq!(v.len(), 42);
    assert_eq!(
        v.iter().find(|l| matches!(l.command, Command::Block { .. })).unwrap().command,
        Command::Block { material: Some(1), constitutive: Some(4), corners: vec![[1.0, 0.0], [1.0, 3.35], [5.0, 3.35], [5.0, 0.0]] }
    );
    assert!(v.iter().any(|l| l.command == Command::Link { flying: [3.0, 3.0], anchor: [4.0, 1.5] }));
    use PrintItem::*;
    assert_eq!(v[v.len() - 3].command, Command::Print { items: vec![Blocks, Contacts, Corners, DList, List] });
}

#[test]
fn sample_d3_is_refused_by_the_2d_parser_as_3d() {
    // The D3 deck's first BLOCK (line 10) gives corners as (x,y,z) triples: the 2D parser says
    // whose language it is and where such a deck runs.
    let e = assert_err(&sample("d3_two_tetrahedra.dat"), 10, &["BLOCK with (x,y,z) corners is D3's", "D3 engine", "--dim 3"]);
    assert_eq!(e.column, 14);
    // GRAVITY with three components is the other cheap tell.
    assert_body_err("GRAV 0 0 -10", 2, &["GRAVITY gx gy gz (three components) is D3's", "D3 engine"]);
}

// ---------------------------------------------------------------------------------------------
// Layout: continuation, comments, blank lines, source text.
// ---------------------------------------------------------------------------------------------

#[test]
fn continuation_comments_and_source() {
    let deck = "* a comment\n   * an indented comment\n\nSTART\nBLOCK MAT=1 (0,0)   (0,30)\n* comment inside\n\n  + (40,30)\n+(40,0)\nCYC 10\nEND\n";
    let v = parse(deck);
    assert_eq!(v.len(), 4);
    assert_eq!(v[0].line, 4);
    assert_eq!(v[1].line, 5);
    assert_eq!(v[1].source, "BLOCK MAT=1 (0,0)   (0,30) (40,30) (40,0)");
    assert_eq!(v[1].command, Command::Block { material: Some(1), constitutive: None, corners: vec![[0.0, 0.0], [0.0, 30.0], [40.0, 30.0], [40.0, 0.0]] });
    assert_eq!(v[2].line, 10);
    assert_eq!(v[2].source, "CYC 10");
}

#[test]
fn dos_line_endings_and_tabs() {
    let v = parse("START\r\nGRAV\t0\t-10\r\nCYC 5\r\n+\r\nEND\r\n");
    assert_eq!(v[1].command, Command::Gravity { g: [0.0, -10.0] });
    assert_eq!(v[1].source, "GRAV\t0\t-10");
    assert_eq!(v[2].command, Command::Cycle { n: 5 });
}

#[test]
fn commands_after_end_are_ignored_and_end_may_be_missing() {
    let v = parse("START\nCYC 1\nEND\nthis is not a command\nBLOCK\n");
    assert_eq!(v.len(), 3);
    let v = parse("START\nCYC 1\nSTOP\n");
    assert_eq!(v.last().unwrap().command, Command::Stop);
    // STOP does not end the parse; END does.
    let v = parse("START\nSTOP\nCYC 2\nEND");
    assert_eq!(v.len(), 4);
}

/// A long deck is read statement by statement in parallel; what it gives must not show it:
/// commands in order, the first bad command of the file reported, nothing after END read.
#[test]
fn a_long_deck_reads_in_order_and_reports_its_first_error() {
    let n = 5000;
    let mut deck = String::from("START\n");
    for k in 0..n {
        deck += &format!("BLOCK {k} 0 {k} 1 {} 1\n", k + 1);
    }
    let v = parse(&(deck.clone() + "END\n"));
    assert_eq!(v.len(), n + 2);
    for (k, located) in v[1..=n].iter().enumerate() {
        assert_eq!(located.line, k + 2);
        let Command::Block { corners, .. } = &located.command else { panic!("line {}: {:?}", k + 2, located.command) };
        assert_eq!(corners[0], [k as f64, 0.0]);
    }
    // Two bad coordinates, the later one first in no particular thread's order.
    let bad = deck.replacen("BLOCK 4000 0", "BLOCK 4000 x", 1).replacen("BLOCK 300 0", "BLOCK 300 y", 1);
    assert_err(&(bad.clone() + "END\n"), 302, &["the y coordinate of corner 1", "'y'"]);
    // A bad command after END is never read.
    let v = parse(&(deck + "END\nBLOCK 1 2 x\n"));
    assert_eq!(v.len(), n + 2);
}

#[test]
fn restart_may_come_first() {
    let v = parse("RESTART beam.sav\nCYC 100\nEND");
    assert_eq!(v[0].command, Command::Restart { file: Some("beam.sav".into()) });
}

// ---------------------------------------------------------------------------------------------
// Errors: line, column and message.
// ---------------------------------------------------------------------------------------------

#[test]
fn whole_file_errors() {
    // An empty deck names line 1, where the START it lacks belongs, and what was expected.
    let e = assert_err("", 1, &["empty deck", "expected START or RESTART"]);
    assert_eq!(e.column, 1);
    assert_eq!(e.to_string(), "t.dat:1:1: empty deck: no commands (only blank or comment lines); expected START or RESTART as the first command");
    assert_err("* only a comment\n\n   \n", 1, &["empty deck"]);
    assert_err("START\nCYC\0 10\n", 2, &["binary file"]);
    assert_err("START\n\u{1}\u{2}\u{3}", 2, &["binary file"]);
    // Bytes that are not UTF-8: line and column of the first bad byte, and the byte.
    let e = parse_deck_bytes_err(b"START\nCYC \xff\xfe 10\n");
    assert!(e.message.contains("binary file") && e.message.contains("0xFF"), "{e}");
    assert_eq!((e.line, e.column), (2, 5));
    // Columns count characters: the two-byte 'é' is one column.
    let e = parse_deck_bytes_err("START\n* é\n".bytes().chain([b'x', 0xc3]).collect::<Vec<u8>>().as_slice());
    assert_eq!((e.line, e.column), (3, 2), "{e}");
    assert!(e.to_string().starts_with("t.dat:3:2: binary file"), "{e}");
    let long = format!("START\nCYC 1 {}\n", " ".repeat(5000));
    let e = assert_err(&long, 2, &["line too long (5006 characters; at most 4096)"]);
    assert_eq!(e.column, 4097);
    // Exactly 4096 is fine.
    parse(&format!("START\nCYC 1{}\n", " ".repeat(4096 - 5)));
}

/// Issue 27 item 9: a Latin-1 byte in a comment line (an editor's '°') is read as Latin-1, not
/// taken for a binary file; outside comments it is still refused at its line and column.
#[test]
fn latin1_in_a_comment_is_read_leniently() {
    let deck = blockdem::udec::deck::parse::parse_deck_bytes(b"START\n* a slope of 30\xb0, caf\xe9\n  * indented \xb0\nGRAV 0 -10\n", FILE).unwrap();
    assert_eq!(deck.len(), 2);
    assert_eq!(deck[1].line, 4);
    let e = parse_deck_bytes_err(b"START\n* 30\xb0\nGRAV 0 -10 \xb0\n");
    assert_eq!((e.line, e.column), (3, 12), "{e}");
    assert!(e.message.contains("0xB0"), "{e}");
}

fn parse_deck_bytes_err(b: &[u8]) -> DeckError {
    blockdem::udec::deck::parse::parse_deck_bytes(b, FILE).unwrap_err()
}

#[test]
fn first_command_must_be_start_or_restart() {
    let e = assert_err("* header\n\nBLOCK 0 0 0 1 1 1\nEND\n", 3, &["first command must be START or RESTART", "BLOCK"]);
    assert_eq!(e.column, 1);
    assert_err("  CYC 10\n", 1, &["first command must be START or RESTART"]);
}

#[test]
fn continuation_without_command() {
    let e = assert_err("* c\n  + 1 2\nSTART\n", 2, &["continuation line", "no command before it"]);
    assert_eq!(e.column, 3);
}

#[test]
fn unknown_command() {
    let e = assert_body_err("CYC 1\nXYZ 1 2\n", 3, &["unknown command 'XYZ'", "expected one of BLOCK, CHANGE", "WINDOW"]);
    assert_eq!(e.column, 1);
    // FRACTION needs FRA; PFREE needs PFR; STA is START but ST is STOP: all typed as shorter
    // prefixes they are other commands, and a too-short prefix of only one is unknown.
    assert_body_err("CH2 1 2 3 4", 2, &["unknown command 'CH2'"]);
    assert_body_err("10 20", 2, &["unknown command '10'"]);
    assert_body_err("BLOCKS 0 0 0 1 1 1", 2, &["unknown command 'BLOCKS'"]);
}

#[test]
fn rset_is_refused() {
    let e = assert_body_err("CYC 1\n  RSET 1.0 100 3", 3, &[
        "RSET wrote a value into the 1985 program's main array at a raw memory address; addresses have no meaning in blockdem (use PROPERTY, CHANGE or the command that sets the quantity)",
    ]);
    assert_eq!(e.column, 3);
}

#[test]
fn block_errors() {
    let e = assert_body_err("BLOCK 0 0 1 abc 2 2", 2, &["expected a number for the y coordinate of corner 2, found 'abc'"]);
    assert_eq!(e.column, 13);
    assert_body_err("BLOCK 0 0 abc 1 2 2", 2, &["expected a number for the x coordinate of corner 2, found 'abc'"]);
    assert_body_err("BLOCK 0 0 0 1", 2, &["BLOCK needs at least 3 corners (x y pairs), found 2"]);
    assert_body_err("BLOCK", 2, &["BLOCK needs at least 3 corners (x y pairs), found 0"]);
    let e = assert_body_err("BLOCK 0 0 0 1 1 1 7", 2, &["corner 4 has an x coordinate (7) but no y coordinate"]);
    assert_eq!(e.column, 19);
    // A pair split across a continuation line: reported at the y on the continuation line.
    let e = assert_body_err("BLOCK 0 0 0 1 1\n+ 1 1 0\n", 3, &["corner 3 is split across a continuation line", "x on line 2, y on line 3"]);
    assert_eq!(e.column, 3);
    // A bad number on a continuation line names that line.
    let e = assert_body_err("BLOCK 0,0 0,1\n* comment\n+ 1,1 1.0x,0\n", 4, &["expected a number for the x coordinate of corner 4, found '1.0x'"]);
    assert_eq!(e.column, 7);
    assert_body_err("BLOCK MAT=2.5 0 0 0 1 1 1", 2, &["expected an integer for the material number n, found '2.5'"]);
    assert_body_err("BLOCK MAT=0 0 0 0 1 1 1", 2, &["material number n must be a positive integer, found '0'"]);
    assert_body_err("BLOCK MAT=1 MAT=2 0 0 0 1 1 1", 2, &["'MAT' is given twice"]);
    assert_body_err("BLOCK 0 0 0 1 1 1 MAT 2", 2, &["MATERIAL and CONSTITUTIVE must come before the corner coordinates"]);
    assert_body_err("BLOCK FOO 0 0 0 1 1 1", 2, &["expected MATERIAL, CONSTITUTIVE or the x coordinate of corner 1, found 'FOO'"]);
    assert_body_err("BLOCK MAT", 2, &["BLOCK needs the material number n"]);
}

#[test]
fn number_errors() {
    assert_body_err("GRAV 0 nan", 2, &["expected a finite number for gy, found 'nan'"]);
    assert_body_err("GRAV inf 0", 2, &["expected a finite number for gx, found 'inf'"]);
    assert_body_err("GRAV -Infinity 0", 2, &["expected a finite number for gx, found '-Infinity'"]);
    assert_body_err("GRAV 0 1E999", 2, &["'1E999'", "out of range"]);
    assert_body_err("FRAC 1.0x", 2, &["expected a number for the fraction f of the critical time-step, found '1.0x'"]);
    assert_body_err("FRAC 1..0", 2, &["found '1..0'"]);
    assert_body_err("CYCLE 99999999999999999999999", 2, &["out of range"]);
    // Two numbers run together are named as such, not as one number too few.
    let e = assert_body_err("GRAV 0-10", 2, &["expected a number for gx, found '0-10'; separate numbers with blanks or commas"]);
    assert_eq!(e.column, 6);
    assert_body_err("LOAD 0 1 0 1 5 1e5e3", 2, &["expected a number for fy, found '1e5e3'"]);
}

/// A UTF-8 byte-order mark (as some Windows editors write one) is not part of the first command,
/// and columns count from the first visible character.
#[test]
fn a_byte_order_mark_is_skipped() {
    let v = parse("\u{feff}START\nGRAV 0 -10\n");
    assert_eq!(v[0].command, Command::Start);
    assert_eq!(v[1].command, Command::Gravity { g: [0.0, -10.0] });
    let e = assert_err("\u{feff}STRAT\n", 1, &["unknown command 'STRAT'"]);
    assert_eq!(e.column, 1);
}

#[test]
fn value_range_errors() {
    assert_body_err("CYCLE -5", 2, &["a negative cycle count is not allowed, found -5"]);
    assert_body_err("CYCLE 2.5", 2, &["expected an integer for the number of cycles n, found '2.5'"]);
    assert_body_err("CYCLE", 2, &["CYCLE needs the number of cycles n"]);
    assert_body_err("PROP MAT=1 D=-2000", 2, &["density must be positive, found -2000"]);
    assert_body_err("PROP MAT=1 KN=0", 2, &["kn must be positive, found 0"]);
    assert_body_err("PROP MAT=1 KS=-1", 2, &["ks must be positive"]);
    assert_body_err("PROP MAT=1 BULK=-1", 2, &["bulk modulus must be positive"]);
    assert_body_err("PROP MAT=1 G=0", 2, &["shear modulus must be positive"]);
    assert_body_err("PROP MAT=1 F=-0.1", 2, &["friction must not be negative, found -0.1"]);
    assert_body_err("PROP MAT=1 C=-1", 2, &["cohesion must not be negative"]);
    assert_body_err("PROP MAT=1 TF=-1", 2, &["tf must not be negative"]);
    assert_body_err("PROP MAT=1 JPERM=-1", 2, &["jperm must not be negative"]);
    assert_body_err("PROP MAT=1 AZ=-1", 2, &["azero must not be negative"]);
    assert_body_err("DAMP -.1 15", 2, &["fcrit must not be negative"]);
    assert_body_err("DAMP .1 0", 2, &["freq must be positive"]);
    assert_body_err("FRAC 0", 2, &["time-step fraction must be positive, found 0"]);
    assert_body_err("FRAC -0.5", 2, &["must be positive"]);
    assert_body_err("ROUND 0", 2, &["rounding length must be positive"]);
    assert_body_err("FLUID -1 1E9", 2, &["fluid density must not be negative"]);
    assert_body_err("FLUID 1000 0", 2, &["fluid bulk modulus must be positive"]);
    assert_body_err("WINDOW 10 0 0 5", 2, &["WINDOW range is empty: x1 (10) must be less than x2 (0)"]);
    assert_body_err("WINDOW 0 10 5 5", 2, &["y1 (5) must be less than y2 (5)"]);
    assert_body_err("VIEW 700 0 0 700", 2, &["ix1 (700) must be less than ix2 (0)"]);
    assert_body_err("VIEW 0 700.5 0 700", 2, &["expected an integer for ix2, found '700.5'"]);
    assert_body_err("FIX 40 0 0 5", 2, &["FIX range is empty"]);
}

#[test]
fn property_errors() {
    assert_body_err("PROP D=2000 MAT=1", 2, &["PROPERTY must begin with MATERIAL n", "found 'D'"]);
    assert_body_err("PROP MAT=1", 2, &["PROPERTY needs at least one keyword and value"]);
    assert_body_err("PROP MAT=1 D=2000 XYZ=3", 2, &["expected a property keyword (BULK, K, G, DENSITY", "found 'XYZ'"]);
    assert_body_err("PROP MAT=1 D=2000 KN", 2, &["PROPERTY needs a value after KN"]);
    assert_body_err("PROP MAT=1 D 2000 3000", 2, &["expected a property keyword", "found '3000'"]);
    assert_body_err("PROP MAT=1.5 D=2000", 2, &["expected an integer for the material number n, found '1.5'"]);
    assert_body_err("PROP MAT=1 D=2000 MAT=2", 2, &["MATERIAL may be given only once"]);
    assert_body_err("PROP MAT=1 JK=1", 2, &["found 'JK'"]);
    // An error on a continuation line of PROP names that line and column.
    let e = assert_body_err("PROP MAT=1 D=2000\n+ KN=1E8\n+ KS=abc\n", 4, &["expected a number for a value after KS, found 'abc'"]);
    assert_eq!(e.column, 6);
}

#[test]
fn arity_errors() {
    let e = assert_body_err("FIX 0 40 0", 2, &["FIX needs 4 numbers (FIX x1 x2 y1 y2), found 3"]);
    assert_eq!(e.column, 11);
    let e = assert_body_err("FIX 0 40 0 5 6", 2, &["too many values for FIX: unexpected '6'"]);
    assert_eq!(e.column, 14);
    assert_body_err("FIX 0 40 zz 5", 2, &["expected a number for y1, found 'zz' (FIX x1 x2 y1 y2)"]);
    assert_body_err("LOAD 0 1 0 1 5", 2, &["LOAD needs 6 numbers", "found 5"]);
    assert_body_err("LOAD 0 1 0 1 5 6 7", 2, &["too many values for LOAD: unexpected '7'"]);
    assert_body_err("DELETE 0 1 0", 2, &["DELETE needs 4 numbers"]);
    assert_body_err("FREE 0 1", 2, &["FREE needs 4 numbers"]);
    assert_body_err("GRAV 0", 2, &["GRAVITY needs 2 numbers"]);
    assert_body_err("LINK 1 2 3", 2, &["LINK needs 4 numbers"]);
    assert_body_err("VELOCITY 0 1 0 1 2", 2, &["VELOCITY needs 6 numbers"]);
    assert_body_err("VELOCITY 0 1 0 1 2 3 4 5", 2, &["too many values for VELOCITY: unexpected '5'"]);
    assert_body_err("VTK 100", 2, &["too many values for VTK: unexpected '100'"]);
    assert_body_err("START 1", 2, &["too many values for START: unexpected '1'"]);
    assert_body_err("STOP NOW", 2, &["too many values for STOP: unexpected 'NOW'"]);
    assert_body_err("END 1", 2, &["too many values for END"]);
    assert_body_err("SAVE a b", 2, &["too many values for SAVE: unexpected 'b'"]);
    assert_body_err("CYCLE 10 20", 2, &["too many values for CYCLE: unexpected '20'"]);
    assert_body_err("DUMP 1 2 3", 2, &["too many values for DUMP: unexpected '3'"]);
    assert_body_err("DUMP 1.5", 2, &["expected an integer for n (first address), found '1.5'"]);
    assert_body_err("ROUND", 2, &["ROUND needs the rounding length d"]);
    assert_body_err("FLUID 1000", 2, &["FLUID needs the fluid bulk modulus bulkw"]);
    assert_body_err("SPLIT 0 0 1", 2, &["SPLIT needs 4 numbers"]);
    assert_body_err("SPLIT 0 0 1 1 2", 2, &["too many values for SPLIT: unexpected '2'"]);
    assert_body_err("SPLIT 0 0 1 1 MAT 1.5", 2, &["expected an integer for the joint material number n, found '1.5'"]);
    assert_body_err("SPLIT 0 0 1 1 FOO 1", 2, &["unknown keyword 'FOO' for SPLIT; it takes MATERIAL, CONSTITUTIVE"]);
    assert_body_err("SPLIT 0 q 1 1", 2, &["expected a number for y1", "found 'q'"]);
    assert_body_err("CHANGE 0 1 0 1", 2, &["CHANGE needs something to change"]);
    assert_body_err("CHANGE 0 1 0 1 SDEF FDEF", 2, &["'FDEF' is given twice"]);
    assert_body_err("CHANGE 0 1 0 1 RIGID", 2, &["unknown keyword 'RIGID' for CHANGE; it takes SDEF, FDEF, MATERIAL, CONSTITUTIVE"]);
    assert_body_err("DAMP .1", 2, &["DAMPING needs 2 numbers"]);
    assert_body_err("DAMP .1 15 MASS STIFF", 2, &["'STIFF' is given twice"]);
    assert_body_err("DAMP .1 15 FULL", 2, &["unknown keyword 'FULL' for DAMPING; it takes MASS, STIFFNESS, INTERNAL"]);
    assert_body_err("PFIX 3", 2, &["PFIX needs the pressure p"]);
    assert_body_err("PFIX INNER 0", 2, &["expected the domain (a domain number, OUTER, or AT x y), found 'INNER'"]);
    assert_body_err("PFIX AT 1 0", 2, &["PFIX needs the pressure p"]);
    assert_body_err("PFREE AT 1", 2, &["PFREE needs y of the point AT x y"]);
    assert_body_err("PFIX -3 0", 2, &["domain number must be a non-negative integer"]);
    assert_body_err("PFREE", 2, &["PFREE needs the domain"]);
    assert_body_err("PFREE OUTER 3", 2, &["too many values for PFREE"]);
    assert_body_err("PLOT BLOCKS", 2, &["unknown PLOT keyword 'BLOCKS'; PLOT takes NOFIX, ZONES, NC, VELOCITY"]);
    assert_body_err("PLOT 3", 2, &["unknown PLOT keyword '3'"]);
    assert_body_err("PRINT", 2, &["PRINT needs at least one of BLOCKS, CONTACTS, CORNERS, DOMAINS, LIST, DLIST, FLOWS, ENERGY"]);
    assert_body_err("PRINT BLOCKS VEL", 2, &["unknown PRINT keyword 'VEL'"]);
    assert_body_err("VIEW 0 1 2", 2, &["VIEW needs 4 numbers"]);
    assert_body_err("WINDOW 0 1 2 3 4", 2, &["too many values for WINDOW"]);
}

#[test]
fn generate_errors() {
    assert_body_err("GEN 2 6 3 7", 2, &["GENERATE needs AUTOMATIC amax or MANUAL"]);
    assert_body_err("GEN 2 6 3 7 AUTO", 2, &["GENERATE needs the maximum zone edge length amax"]);
    assert_body_err("GEN 2 6 3 7 AUTO 0", 2, &["maximum zone edge length amax must be positive"]);
    assert_body_err("GEN 2 6 3 7 AUTO 1 2", 2, &["too many values for GENERATE: unexpected '2'"]);
    assert_body_err("GEN 2 6 3 AUTO 1", 2, &["expected a number for y2, found 'AUTO'"]);
    assert_body_err("GEN 2 6 3 7 SOMETIMES 1", 2, &["expected AUTOMATIC amax or MANUAL", "found 'SOMETIMES'"]);
    let g = "GEN 0 10 0 10 MANUAL GRID";
    assert_body_err(&format!("{g} 1 1 1 2 2 2 2 ZONES 1 2 3"), 2, &["grid point 4 has an x coordinate (2) but no y coordinate"]);
    assert_body_err(&format!("{g} 1 1 1 2 ZONES 1 2 1"), 2, &["at least 3 grid points", "found 2"]);
    assert_body_err(&format!("{g} 1 1 1 2 2 2"), 2, &["GENERATE MANUAL needs ZONES"]);
    assert_body_err(&format!("{g} 1 1 1 2 2 2 ZONES"), 2, &["at least one zone"]);
    assert_body_err(&format!("{g} 1 1 1 2 2 2 ZONES 1 2"), 2, &["zone 1 is incomplete"]);
    assert_body_err(&format!("{g} 1 1 1 2 2 2 ZONES 1 2 0"), 2, &["grid-point number must be a positive integer, found '0'"]);
    assert_body_err(&format!("{g} 1 1 1 2 2 2 ZONES 1 2 4"), 2, &["zone 1 refers to grid point 4, but only 3 grid points were given"]);
    assert_body_err(&format!("{g} 1 1 1 2 2 2 ZONES 1 2 2.5"), 2, &["expected an integer for a grid-point number of zone 1, found '2.5'"]);
    assert_body_err(&format!("{g} 1 1 1 2 2 x"), 2, &["expected a number for the y coordinate of grid point 3 (or ZONES), found 'x'"]);
    // Doubles and triples must not be split over two lines.
    let e = assert_body_err(&format!("{g} 1 1 1 2 2\n+ 2 ZONES 1 2 3"), 3, &["grid point 3 is split across a continuation line"]);
    assert_eq!(e.column, 3);
    assert_body_err(&format!("{g} 1 1 1 2 2 2 ZONES 1 2\n+ 3"), 3, &["zone 1 is split across a continuation line"]);
}

#[test]
fn error_display_has_file_line_column() {
    let e = err("START\nCYC x\n");
    assert_eq!(e.to_string(), "t.dat:2:5: expected an integer for the number of cycles n, found 'x'");
}

#[test]
fn error_tokens_are_shown_safely() {
    let long = "Q".repeat(200);
    let e = assert_body_err(&format!("GRAV 0 {long}"), 2, &["QQQ..."]);
    assert!(e.message.len() < 200, "{}", e.message);
}

// ---------------------------------------------------------------------------------------------
// Never panic.
// ---------------------------------------------------------------------------------------------

/// Pieces a deck is made of, including the awkward ones.
fn soup_piece() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(vec![
            "START", "RESTART", "STOP", "END", "BLOCK", "B", "CHANGE", "CH", "CYCLE", "C", "DAMP", "DE", "DU", "F", "FRA", "FL", "FR", "GE", "G", "LI", "L",
            "PF", "PFR", "PL", "P", "PRO", "R", "RS", "RO", "SA", "SP", "STA", "S", "V", "W", "VE", "MAT", "CONS", "SDEF", "FDEF", "MASS", "INTERNAL", "AUTO",
            "MANUAL", "GRID", "ZONES", "OUTER", "NOFIX", "NC", "VEL", "BLOCKS", "COR", "DL", "K", "KN", "JKS", "TF", "AZ", "XYZ",
        ])
        .prop_map(String::from),
        prop::sample::select(vec![
            "0",
            "1",
            "-1",
            ".5",
            "1E8",
            "-0.95E4",
            "1e+09",
            "2.5",
            "1E999",
            "-1E999",
            "nan",
            "inf",
            "1.0x",
            "-",
            "+",
            ".",
            "99999999999999999999",
            "0.0",
            "-0",
            "1D3",
            "4294967296",
            "-9223372036854775808",
        ])
        .prop_map(String::from),
        prop::sample::select(vec![" ", "  ", "=", "(", ")", ",", "/", "\t", "\n", "\n+", "\n+ ", "\n*", "\r\n", "\n\n", "\u{0}", "é", "\u{85}"])
            .prop_map(String::from),
        any::<f64>().prop_map(|f| f.to_string()),
        any::<i64>().prop_map(|i| i.to_string()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn random_text_never_panics(s in any::<String>()) {
        let _ = parse_deck(&s, FILE);
    }

    #[test]
    fn random_line_soup_never_panics(s in "[A-Za-z0-9 =(),/.+*\\-\n\t]{0,200}") {
        let _ = parse_deck(&s, FILE);
    }

    #[test]
    fn token_soup_never_panics(pieces in prop::collection::vec(soup_piece(), 0..60), start in any::<bool>()) {
        let mut deck = if start { String::from("START\n") } else { String::new() };
        for p in &pieces {
            deck.push_str(p);
            if !p.chars().all(|c| c.is_whitespace() || "=(),/".contains(c)) {
                deck.push(' ');
            }
        }
        if let Err(e) = parse_deck(&deck, FILE) {
            // An error's line is 0 (whole file) or a real line of the deck.
            prop_assert!(e.line <= deck.lines().count().max(1));
            prop_assert!(!e.message.is_empty());
        }
    }

    #[test]
    fn random_bytes_never_panic(b in prop::collection::vec(any::<u8>(), 0..300)) {
        let _ = blockdem::udec::deck::parse::parse_deck_bytes(&b, FILE);
    }
}

#[test]
fn save_and_restart_take_paths_with_slashes_whole() {
    assert_eq!(parse("START\nSAVE /tmp/runs/a.sav")[1].command, Command::Save { file: Some("/tmp/runs/a.sav".into()) });
    assert_eq!(parse("RESTART runs/b.sav")[0].command, Command::Restart { file: Some("runs/b.sav".into()) });
}

/// Issue 27 item 9: an unknown command names the nearest command ("did you mean"), where one is
/// near; units written after or onto a number are said to be units, not a number short.
#[test]
fn unknown_commands_suggest_the_nearest_and_units_are_named_as_such() {
    for (typed, meant) in [("CYLCE 10", "CYCLE"), ("GRAVTY 0 -10", "GRAVITY"), ("PROPERTIES MAT=1 D=1", "PROPERTY"), ("VELOSITY 0 1 0 1 1 0", "VELOCITY")] {
        assert_body_err(typed, 2, &[&format!("(did you mean {meant}?); expected one of BLOCK")]);
    }
    let e = assert_body_err("QQQQQQ 1", 2, &["unknown command 'QQQQQQ'; expected one of"]);
    assert!(!e.message.contains("did you mean"), "{e}");
    let e = assert_body_err("GRAV 0 -10m/s2", 2, &["expected a number for gy, found '-10m': units are not accepted ('m'); give numbers alone"]);
    assert_eq!(e.column, 8);
    let e = assert_body_err("GRAV 0 -10 m/s2", 2, &["units are not accepted: found 'm' after the numbers"]);
    assert_eq!(e.column, 12);
    assert_body_err("PROP MAT=1 D=2000kg/m3 KN=1E8", 2, &["found '2000kg': units are not accepted ('kg')"]);
    // An exponent is not a unit.
    let e = assert_body_err("LOAD 0 1 0 1 5 1e5e3", 2, &["expected a number for fy, found '1e5e3'"]);
    assert!(!e.message.contains("units"), "{e}");
}
