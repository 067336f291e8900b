//! Simply-deformable 3D blocks (SL-85-1 ¶35d; `d3::sdef`): CHANGE … SDEF and DAMPING … INTERNAL
//! in the D3 language, the strain's closed forms (a column under its own weight, the volumetric
//! vibration of a free cube), the energy ledger, SPLIT, SAVE/RESTART and the outputs.

use std::path::PathBuf;

use blockdem::d3::backend::Backend as _;
use blockdem::d3::deck::parse_deck;
use blockdem::d3::exec::{Executor, RunError};
use blockdem::d3::model::Model;
use blockdem::d3::sdef;
use blockdem::driver::run::RunOptions;
use glam::DVec3;

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("blockdem-d3sdef-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `deck`; the model, the log, and the outcome.
fn run_in(deck: &str, dir: Option<&PathBuf>) -> (Model, String, Result<(), RunError>) {
    let commands = parse_deck(deck, "t.dat").unwrap();
    let log = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    struct Sink(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);
    impl std::io::Write for Sink {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let mut exec = Executor::new(Box::new(Sink(log.clone())), "t.dat");
    if let Some(d) = dir {
        exec.set_options(RunOptions { out_dir: d.clone(), ..Default::default() });
    }
    let r = exec.run(&commands);
    let text = String::from_utf8(log.lock().unwrap().clone()).unwrap();
    (exec.model, text, r)
}

fn run(deck: &str) -> (Model, String) {
    let (m, log, r) = run_in(deck, None);
    r.unwrap_or_else(|e| panic!("{e}\n{log}"));
    (m, log)
}

/// A 1 × 1 × 2 m column of a soft material (E = 1.5e8 Pa, ν = 0.25) on a fixed frictionless
/// slab, simply deformable, under gravity; `damp` settles it.
fn column(damp: &str, cycles: u64) -> String {
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E10 KS=1E10 F=0.0\nPROP MAT=2 D=2000 K=1E8 G=6E7 KN=1E10 KS=1E10 F=0.0\n\
         BOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 2 MAT 2\nFIX -1 2 -1 2 -1 -0.1\nCHANGE 0 1 0 1 0 2 SDEF\nGRAV 0 0 -10\n{damp}CYCLE {cycles}\n"
    )
}

#[test]
fn a_column_under_its_own_weight_takes_the_mean_stress_and_the_elastic_strains() {
    let (m, log) = run(&column("DAMP 0.5 40 MASS\nDAMP 0.5 40 INTERNAL\n", 20_000));
    assert!(log.contains("NOTE - ONLY MASS-DAMPING USED"), "{log}");
    let s = m.blocks[1].sdef.expect("the column is simply deformable");
    // The weight acts at the centroid and the slab's reaction at the base, h/2 below: the mean
    // stress σzz = −ρ g h/2 = −20 kPa; the sides are free: σxx = σyy = 0; no shear.
    let szz = -2000.0 * 10.0 * 2.0 / 2.0;
    assert!((s.stress[2] - szz).abs() < 1e-3 * szz.abs(), "σzz {} against {szz}", s.stress[2]);
    for k in [0, 1, 3, 4, 5] {
        assert!(s.stress[k].abs() < 1e-4 * szz.abs(), "σ[{k}] = {}", s.stress[k]);
    }
    // εzz = σzz/E and εxx = εyy = −ν εzz, E = 9KG/(3K + G), ν = (3K − 2G)/(2(3K + G)).
    let (k, g) = (1e8, 6e7);
    let e = 9.0 * k * g / (3.0 * k + g);
    let nu = (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g));
    assert!((s.strain[2] - szz / e).abs() < 1e-3 * (szz / e).abs(), "εzz {}", s.strain[2]);
    assert!((s.strain[0] + nu * szz / e).abs() < 2e-3 * (nu * szz / e).abs(), "εxx {}", s.strain[0]);
    assert_eq!(s.strain[0], s.strain[1], "a square column's two sides strain alike");
    // The column's top has come down by the rigid settlement plus εzz·h.
    let top = m.blocks[1].vertices.iter().map(|v| v.z).fold(f64::MIN, f64::max);
    assert!(top < 2.0 + s.strain[2] * 2.0 + 1e-6, "top at {top}");
    // The ledger closes: nothing is booked to friction on a frictionless base.
    let en = m.energies();
    assert_eq!(en.friction, 0.0);
    assert!(en.ledger().abs() < 1e-3 * en.scale(), "ledger {} of {}", en.ledger(), en.scale());
    assert!(en.mass_damping > 0.0);
}

#[test]
fn undamped_a_dropped_deformable_block_keeps_the_energy_ledger_to_first_order() {
    // Dropped 5 cm onto the slab (m g h = 1 kJ): it bounces, its strain rings, its base slips
    // (the Poisson spreading under the impact; friction books it). The ledger's error is the
    // scheme's O(Δt) one at the impact (as a rigid block's): under 2.5% of m g h at FRACTION 0.1,
    // and halved with the step.
    let ledger = |frac: f64| {
        let cycles = (600.0 / frac) as u64;
        let deck = format!(
            "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nPROP MAT=2 D=2000 K=5E7 G=3E7 KN=1E9 KS=1E9 F=0.5\n\
             BOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0.05 1.05 MAT 2\nFIX -1 2 -1 2 -1 -0.1\nCHANGE 0 1 0 1 0 2 SDEF\nGRAV 0 0 -10\nFRAC {frac}\nCYCLE {cycles}\n"
        );
        let (m, _) = run(&deck);
        let s = m.blocks[1].sdef.unwrap();
        assert!(s.strain[2] != 0.0 && s.strain_rate.iter().any(|r| *r != 0.0), "the strain rings: {s:?}");
        let e = m.energies();
        assert!(e.external_work > 0.0 && e.friction > 0.0, "{e:?}");
        e.ledger()
    };
    let mgh = 2000.0 * 10.0 * 0.05;
    let (coarse, fine) = (ledger(0.1), ledger(0.05));
    assert!(coarse.abs() < 0.025 * mgh, "ledger {coarse} of m g h {mgh}");
    // (−3.15 J at FRAC 0.1, −0.61 J at 0.05 since friction books what a slipping spring gives up
    // as its contact unloads, `d3::contact::slip_work`; before, −9 J and a ratio of 0.5.)
    let ratio = fine / coarse;
    assert!((0.0..0.6).contains(&ratio), "the ledger's error falls at least as Δt: {coarse} at FRAC 0.1, {fine} at 0.05");
}

#[test]
fn a_free_cube_breathes_at_the_volumetric_frequency() {
    // No gravity, no neighbour: a volumetric strain rate makes the cube breathe at
    // ω² = 3K·V/M11 = 36 K/(ρ a²) (a = 1 m); the shear strains stay zero.
    let deck = "START\nPROP MAT=1 D=2500 K=2E9 G=1.2E9 KN=1E10 KS=1E10\nBOX 0 1 0 1 0 1\nCHANGE -1 2 -1 2 -1 2 SDEF\nCYCLE 0\n";
    let (mut m, _) = run(deck);
    m.blocks[0].sdef.as_mut().unwrap().strain_rate = [1e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0];
    let omega = (36.0f64 * 2e9 / 2500.0).sqrt();
    let mut backend = blockdem::d3::cpu::CpuBackend::new();
    let dt = m.timestep();
    assert!(dt > 0.0 && dt <= (m.internal_timestep().unwrap() * 1.0000001), "the internal limit bounds the step");
    let mut crossings = Vec::new();
    let mut last = 0.0;
    let mut t = 0.0;
    while crossings.len() < 5 {
        backend.run(&mut m, 1, &mut |_| true).unwrap();
        t += dt;
        let e = m.blocks[0].sdef.unwrap().strain[0];
        if last > 0.0 && e <= 0.0 || last < 0.0 && e >= 0.0 {
            // Interpolated within the step.
            crossings.push(t - dt * e / (e - last));
        }
        last = e;
        assert!(t < 1.0, "no oscillation");
    }
    let period = crossings[4] - crossings[2];
    let expect = 2.0 * std::f64::consts::PI / omega;
    assert!((period - expect).abs() < 1e-3 * expect, "period {period} against {expect}");
    let s = m.blocks[0].sdef.unwrap();
    assert_eq!(s.strain[3..], [0.0; 3]);
    // The centroid did not move: the breathing is internal.
    assert!((m.blocks[0].centroid - DVec3::splat(0.5)).length() < 1e-12);
}

#[test]
fn the_strain_places_the_vertices_and_turns_the_face_normals() {
    let deck = "START\nPROP MAT=1 D=2500 K=2E9 G=1.2E9 KN=1E10 KS=1E10\nBOX 0 1 0 1 0 1\nCHANGE -1 2 -1 2 -1 2 SDEF\nCYCLE 0\n";
    let (mut m, _) = run(deck);
    let b = &mut m.blocks[0];
    // A shear strain ε12 = 0.01: x' = x + 0.01 y, y' = y + 0.01 x about the centroid.
    b.sdef.as_mut().unwrap().strain = [0.0, 0.0, 0.0, 0.01, 0.0, 0.0];
    b.place_vertices();
    for (v, l) in b.vertices.iter().zip(&b.shape.vertices) {
        let expect = DVec3::new(0.5 + l.x + 0.01 * l.y, 0.5 + l.y + 0.01 * l.x, 0.5 + l.z);
        assert!((*v - expect).length() < 1e-15, "{v} against {expect}");
    }
    // Each face's normal is perpendicular to its (strained) edges.
    for (f, face) in b.shape.faces.iter().enumerate() {
        let n = b.face_normal(f);
        let [p, q, r] = face.map(|k| b.vertices[k as usize]);
        assert!(n.dot(q - p).abs() < 1e-14 && n.dot(r - p).abs() < 1e-14, "face {f}");
        assert!((n.length() - 1.0).abs() < 1e-14);
        assert!(n.dot(p - b.centroid) > 0.0, "outward");
    }
    // A point's velocity takes the strain rate: ε̇·r.
    b.sdef.as_mut().unwrap().strain_rate = [0.1, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(b.velocity_at(b.centroid + DVec3::new(0.5, 0.2, 0.0)), DVec3::new(0.05, 0.0, 0.0));
}

#[test]
fn split_keeps_pieces_deformable_unstressed_and_the_motion() {
    let deck = format!("{}SPLIT 0.5 0.5 1.0 0 0 1\nCYCLE 10\n", column("", 400));
    let (before, _) = run(&column("", 400));
    let (m, log) = run(&deck);
    assert!(log.contains("SPLIT: 1 BLOCKS CUT"), "{log}");
    assert_eq!(m.blocks.len(), 3);
    for b in &m.blocks[1..] {
        assert!(b.is_sdef(), "block {} stays simply deformable", b.id);
    }
    // Right after the cut: the pieces are unstressed and carry the parent's momentum (its
    // strain rate adds none: ∫ρ ε̇ r dV = 0 about the centroid).
    let (cut, _) = run(&format!("{}SPLIT 0.5 0.5 1.0 0 0 1\n", column("", 400)));
    let momentum = |bs: &[blockdem::d3::model::Block]| bs.iter().map(|b| b.velocity * b.mass).sum::<DVec3>();
    let (p0, p1) = (momentum(&before.blocks[1..]), momentum(&cut.blocks[1..]));
    assert!((p1 - p0).length() <= 1e-9 * p0.length().max(1e-12), "momentum {p1} against {p0}");
    for b in &cut.blocks[1..] {
        assert_eq!(b.sdef.unwrap().stress, [0.0; 6], "block {} is unstressed", b.id);
    }
    // What the parent's stress held is released, booked in the ledger.
    let held = sdef::strain_energy(&before.blocks[1].sdef.unwrap(), before.blocks[1].volume);
    assert!(held > 0.0);
    assert!(m.dissipated.released >= held);
}

#[test]
fn save_and_restart_go_on_bit_for_bit_with_the_strain() {
    let dir = temp("save");
    let (whole, _) = run(&column("DAMP 0.2 40 INTERNAL\n", 600));
    let first = format!("{}SAVE {}\n", column("DAMP 0.2 40 INTERNAL\n", 300), dir.join("s.sav").display());
    run(&first);
    let (again, _) = run(&format!("RESTART {}\nCYCLE 300\n", dir.join("s.sav").display()));
    assert!(again.blocks[1].is_sdef());
    assert_eq!(again.damping.alpha_internal, whole.damping.alpha_internal);
    assert_eq!(again, whole, "CYCLE 300, SAVE, RESTART, CYCLE 300 is CYCLE 600");
}

#[test]
fn outputs_show_the_deformable_block() {
    let dir = temp("out");
    let deck = format!("{}PRINT BLOCKS\nVTK\n", column("", 50));
    let (m, log, r) = run_in(&deck, Some(&dir));
    r.unwrap();
    assert!(log.contains("(SDEF) FORCE"), "{log}");
    assert!(log.contains("\n  ED ") && log.contains("\n  SI ") && log.contains("\n  SA "), "{log}");
    let json = blockdem::d3::output::state_json(&m, None);
    let blocks = json["blocks"].as_array().unwrap();
    assert_eq!(blocks[0]["kind"], "rigid");
    assert_eq!(blocks[1]["kind"], "sdef");
    assert_eq!(blocks[1]["stress"].as_array().unwrap().len(), 6);
    assert_eq!(blocks[1]["strain"][2].as_f64().unwrap(), m.blocks[1].sdef.unwrap().strain[2]);
    let vtk = std::fs::read_dir(dir.join(blockdem::d3::exec::VTK_DIR))
        .unwrap()
        .filter_map(|e| e.ok())
        .find(|e| e.file_name().to_string_lossy().starts_with("blocks_"))
        .unwrap();
    let bytes = std::fs::read(vtk.path()).unwrap();
    assert!(bytes.windows(13).any(|w| w == b"TENSORS stres"), "the VTK frame carries the stress tensor");
}

#[test]
fn bad_change_and_damping_input_is_refused_at_its_line() {
    let base = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nBOX 0 1 0 1 0 1\n";
    let err = |deck: &str| match parse_deck(deck, "t.dat") {
        Err(e) => e.to_string(),
        Ok(c) => {
            let mut exec = Executor::new(Box::new(std::io::sink()), "t.dat");
            exec.run(&c).expect_err("refused").to_string()
        }
    };
    let e = err(&format!("{base}CHANGE 0 1 0 1 SDEF\n"));
    assert!(e.contains("t.dat:4:") && e.contains("2D range"), "{e}");
    let e = err(&format!("{base}CHANGE -1 2 -1 2 -1 2 FDEF\n"));
    assert!(e.contains("t.dat:4:") && e.contains("FDEF"), "{e}");
    let e = err(&format!("{base}CHANGE -1 2 -1 2 -1 2\n"));
    assert!(e.contains("changes nothing"), "{e}");
    let e = err(&format!("{base}CHANGE -1 2 -1 2 -1 2 SDEF SDEF\n"));
    assert!(e.contains("twice"), "{e}");
    // A material without moduli cannot strain.
    let e = err(&format!("{base}CHANGE -1 2 -1 2 -1 2 SDEF\n"));
    assert!(e.contains("t.dat:4") && e.contains("BULK"), "{e}");
    // CHANGE MAT gives the new material's mass.
    let (m, _) = run(&format!("{base}PROP MAT=2 D=3000 K=1E8 G=1E8 KN=1E9 KS=1E9\nCHANGE -1 2 -1 2 -1 2 MAT 2 SDEF\nCYCLE 0\n"));
    assert_eq!((m.blocks[0].material, m.blocks[0].mass), (2, 3000.0));
    assert!(m.blocks[0].is_sdef());
}

/// The column of constitutive number 3 in uniaxial compression, σzz = −ρgh/2 = −20 kPa and the
/// sides free: Griffith's equivalent tension is −(s1 − s3)²/(8(s1 + s3)) = σc/8 = 2.5 kPa. With TF
/// = 2 kPa it cracks, as settling brings its stress past TF, through its centroid along the
/// compression (a vertical plane: its normal the major principal stress's direction, horizontal);
/// the halves are simply deformable, of its material and constitutive number, and the ledger
/// books what the crack released. With TF = 3 kPa it stands.
#[test]
fn griffith_cracks_a_compressed_column_along_its_axis() {
    let deck = |tf: f64| {
        format!(
            "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.0\nPROP MAT=2 D=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 F=0.0 TF={tf}\n\
             BOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 2 MAT 2 CONS 3\nFIX -1 2 -1 2 -1 -0.1\nCHANGE 0 1 0 1 0 2 SDEF\nGRAV 0 0 -10\n\
             DAMP 1 80 MASS\nDAMP 1 80 INTERNAL\nCYCLE 600\n"
        )
    };
    let (m, log) = run(&deck(2000.0));
    let line = log.lines().find(|l| l.contains("CRACKED")).unwrap_or_else(|| panic!("no crack:\n{log}"));
    assert!(line.starts_with("BLOCK 2 CRACKED AT CYCLE") && line.contains("GRIFFITH") && line.contains("NEW BLOCK 3"), "{line}");
    assert!(m.blocks.len() >= 3);
    for b in &m.blocks[1..] {
        assert!(b.is_sdef() && b.material == 2 && b.constitutive == 3, "block {}", b.id);
        // Each piece spans the column's height: the crack is vertical.
        let (lo, hi) = b.bounds();
        assert!(hi.z - lo.z > 1.99, "block {} spans {} m", b.id, hi.z - lo.z);
    }
    let e = m.energies();
    assert!(e.released != 0.0);
    // Measured: 7.8e-4 J of 5.04 J (1.5e-4), the damped settling's own error; the crack books
    // its change of the energies exactly.
    assert!(e.ledger().abs() < 1e-3 * e.scale(), "ledger {} of {}", e.ledger(), e.scale());
    // Below the criterion nothing cracks.
    let (m, log) = run(&deck(3000.0));
    assert!(!log.contains("CRACKED") && m.blocks.len() == 2, "{log}");
    // A rigid block cannot crack by Griffith: an input error at CYCLE, suggesting CHANGE SDEF.
    let rigid = deck(2000.0).replace("CHANGE 0 1 0 1 0 2 SDEF\n", "");
    let commands = parse_deck(&rigid, "t.dat").unwrap();
    let mut exec = Executor::new(Box::new(std::io::sink()), "t.dat");
    let e = exec.run(&commands).expect_err("refused").to_string();
    assert!(e.contains("t.dat:10") && e.contains("block 2 is rigid") && e.contains("SDEF"), "{e}");
}
