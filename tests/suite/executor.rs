//! The executor on the commands of issue 2 item 3 that the parser tests cannot see: what each
//! command does to the model and prints (DAMPING's coefficients and the report's messages,
//! PROPERTY, CHANGE, DELETE / FIX / FREE by centroid, LOAD, LINK, PRINT ENERGY), the commands whose
//! physics comes later stopping with "not supported yet" and their line (the report's samples 2–4
//! included), and the input errors found only when the model is built or cycled. CPU only.

use crate::common;

use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::exec::RunError;
use blockdem::verify::stability::{LIMITS_CPU_F64, LIMITS_GPU_F32};
use common::{run_logged, run_ok, sample, SharedLog};

const ONE_BLOCK: &str = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBLOCK 0,0 0,1 1,1 1,0\n";

#[test]
fn damping_sets_rayleigh_coefficients_and_prints_the_reports_messages() {
    // DAMP ξ f: α = ξω, β = ξ/ω at ω = 2πf, so ξ(ω) = ½(α/ω + βω) = ξ at f. Computed in f64 from
    // the same formula: equal to a few ulps (1e-12 relative).
    let (xi, f) = (0.1, 15.0);
    let omega = 2.0 * std::f64::consts::PI * f;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    for (mode, alpha, beta, message) in [
        ("", xi * omega, xi / omega, None),
        ("MASS", xi * omega, 0.0, Some("STIFFNESS-DAMPING TERM SET TO ZERO")),
        ("(MASS)", xi * omega, 0.0, Some("STIFFNESS-DAMPING TERM SET TO ZERO")),
        ("STIFFNESS", 0.0, xi / omega, Some("MASS-DAMPING TERM SET TO ZERO")),
    ] {
        let (m, log) = run_ok(&format!("{ONE_BLOCK}DAMP {xi} {f} {mode}\n"));
        assert!(close(m.damping.alpha, alpha) && close(m.damping.beta, beta), "DAMP {mode}: {:?}", m.damping);
        // The Rayleigh ratio at the centre frequency is ξ with both terms, ξ/2 with one.
        let ratio = 0.5 * (m.damping.alpha / omega + m.damping.beta * omega);
        let want = if mode.is_empty() { xi } else { xi / 2.0 };
        assert!(close(ratio, want), "DAMP {mode}: ratio {ratio} at f");
        match message {
            Some(text) => assert!(log.contains(&format!("){}", format!("DAMP {xi} {f} {mode}").trim())) && log.contains(text), "DAMP {mode}:\n{log}"),
            None => assert!(!log.contains("TERM SET TO ZERO") && !log.contains("NOTE"), "{log}"),
        }
        assert_eq!(m.damping.alpha_internal, 0.0);
    }
    // INTERNAL: the internal mass damping of simply-deformable blocks, and the report's note.
    let (m, log) = run_ok(&format!("{ONE_BLOCK}DAMP .5 16 INTERNAL\n"));
    assert!(close(m.damping.alpha_internal, 0.5 * 2.0 * std::f64::consts::PI * 16.0), "{:?}", m.damping);
    assert_eq!((m.damping.alpha, m.damping.beta), (0.0, 0.0), "INTERNAL leaves the block damping alone");
    assert!(log.contains("NOTE - ONLY MASS-DAMPING USED"), "{log}");
}

#[test]
fn damping_constants_that_are_not_numbers_are_refused_at_their_line() {
    // Found by tests/suite/random_decks.rs: ω = 2π·1E308 overflows and α = 0·∞ is NaN; β = 1E300/ω at
    // 1E-300 Hz is infinite. The run diverged at once and neither its SAVE nor its last good
    // state could be restarted (RESTART refuses a model with damping that is not finite).
    for damp in ["DAMP 0 1E308", "DAMP 1E300 1E-300", "DAMP 1E300 1E-300 STIFF", "DAMP 100 1E308 MASS"] {
        let deck = format!("{ONE_BLOCK}{damp}\nCYCLE 10\n");
        let (r, _) = run_logged(&deck);
        let e = r.unwrap_err().to_string();
        assert!(e.starts_with("<scene>:4: DAMPING: ") && e.contains("not finite"), "{damp}: {e}");
    }
    // The term a mode drops may overflow: only the kept one counts.
    let (m, _) = run_ok(&format!("{ONE_BLOCK}DAMP 1E300 1E-300 MASS\n"));
    assert!(m.damping.alpha.is_finite() && m.damping.beta == 0.0, "{:?}", m.damping);
}

#[test]
fn property_sets_every_keyword_of_the_table() {
    let (m, _) = run_ok("START\nPROP MAT=2 BULK=1 G=2 DENS=3 KN=4 KS=5 COH=6 FRIC=7 JKN=8 JKS=9 JCOH=10 JFRIC=11 TF=12 JPERM=13 CPERM=14 AZERO=15 ARES=16\n");
    let p = &m.materials[1];
    let got = [
        p.block.bulk,
        p.block.shear,
        p.block.density,
        p.contact.kn,
        p.contact.ks,
        p.contact.cohesion,
        p.contact.friction,
        p.joint.kn,
        p.joint.ks,
        p.joint.cohesion,
        p.joint.friction,
        p.block.tf,
        p.fluid.jperm,
        p.fluid.cperm,
        p.fluid.azero,
        p.fluid.ares,
    ];
    let want: Vec<f64> = (1..=16).map(f64::from).collect();
    assert_eq!(got.to_vec(), want);
    assert_eq!(m.materials[0].block.density, 0.0, "material 1 untouched");
    // K is BULK; a later PROPERTY changes one key and keeps the others.
    let (m, _) = run_ok("START\nPROP MAT=1 K=7 D=100\nPROP MAT=1 D=200\n");
    assert_eq!((m.materials[0].block.bulk, m.materials[0].block.density), (7.0, 200.0));
    // Materials are numbered 1..=MAX_MATERIALS.
    let (r, _) = run_logged("START\nPROP MAT=99 D=1\n");
    let e = r.unwrap_err().to_string();
    assert!(e.starts_with("<scene>:2:") && e.contains("material number must be 1 to"), "{e}");
    // So are the materials BLOCK, CHANGE and SPLIT name (a BLOCK of material 25 was taken, and
    // CYCLE then asked for a PROPERTY MAT=25 that PROPERTY refuses).
    for (line, deck) in [
        (2, "START\nBLOCK MAT=25 0,0 0,1 1,1 1,0\n"),
        (3, "START\nBLOCK 0,0 0,1 1,1 1,0\nCHANGE 0 1 0 1 MAT=21\n"),
        (3, "START\nBLOCK 0,0 0,1 2,1 2,0\nSPLIT 1,-1 1,2 MAT=30\n"),
    ] {
        let (r, _) = run_logged(deck);
        let e = r.unwrap_err().to_string();
        assert!(e.starts_with(&format!("<scene>:{line}:")) && e.contains("material number must be 1 to 20"), "{e}");
    }
    // Constitutive numbers are the report's, 1 to 5: another ran silently as one of them.
    for (line, deck) in [
        (2, "START\nBLOCK CONS 6 0,0 0,1 1,1 1,0\n"),
        (3, "START\nBLOCK 0,0 0,1 1,1 1,0\nCHANGE 0 1 0 1 CONS=7\n"),
        (3, "START\nBLOCK 0,0 0,1 2,1 2,0\nSPLIT 1,-1 1,2 CONS=9\n"),
    ] {
        let (r, _) = run_logged(deck);
        let e = r.unwrap_err().to_string();
        assert!(e.starts_with(&format!("<scene>:{line}:")) && e.contains("constitutive number must be 1 to 5"), "{e}");
    }
    let (m, _) = run_ok("START\nBLOCK CONS 5 0,0 0,1 2,1 2,0\nSPLIT 1,-1 1,2 CONS=2\n");
    assert_eq!(m.blocks.iter().map(|b| b.constitutive).collect::<Vec<_>>(), [5, 5]);
}

/// START is a cold start, the first command only: later it claimed one and kept the model.
#[test]
fn a_second_start_is_an_error_with_its_line() {
    let (r, _) = run_logged("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 10\nSTART\nCYCLE 10\n");
    let e = r.unwrap_err().to_string();
    assert!(e.starts_with("<scene>:5:") && e.contains("START must be the first command"), "{e}");
}

#[test]
fn change_sets_material_and_constitutive_and_the_mass_follows() {
    let deck = "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8\nPROP MAT=2 D=3000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 2,1 2,0\nSPLIT 1,-1 1,2\n\
                CHANGE 0 1 0 1 MAT=2 CONS=2\n";
    let (m, _) = run_ok(deck);
    let left = m.blocks.iter().find(|b| b.centroid[0] < 1.0).unwrap();
    let right = m.blocks.iter().find(|b| b.centroid[0] > 1.0).unwrap();
    assert_eq!((left.material, left.constitutive), (2, 2));
    assert_eq!((right.material, right.constitutive), (1, 1));
    // 1 m² at 3000 kg/m³ against 1 m² at 1000 kg/m³, to round-off.
    assert!((left.mass - 3000.0).abs() < 1e-9 && (right.mass - 1000.0).abs() < 1e-9, "{} {}", left.mass, right.mass);
}

#[test]
fn delete_fix_free_and_load_select_blocks_by_centroid() {
    // Three 1 × 1 blocks in a row: centroids at x = 0.5, 1.5, 2.5. Ranges are open (x1 < x < x2)
    // and select by centroid only: 0.9..2.1 touches all three outlines but holds one centroid.
    let base = "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 3,1 3,0\nSPLIT 1,-1 1,2\nSPLIT 2,-1 2,2\n";
    let (m, _) = run_ok(&format!("{base}DELETE 0.9 2.1 -1 2\n"));
    let mut xs: Vec<f64> = m.blocks.iter().map(|b| b.centroid[0]).collect();
    xs.sort_by(f64::total_cmp);
    assert_eq!(xs, [0.5, 2.5]);

    // FIX holds a block under gravity, FREE lets it go; LOAD acts at the centroid only of the
    // blocks in its range. Blocks 1.2 m apart never touch. Free fall under g + F/m from rest, by
    // central differences: v(t − Δt/2) = a t exactly, to round-off (1e-12 relative).
    let deck = "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 2.2,0 2.2,2 3.2,2 3.2,0\nBLOCK 4.4,0 4.4,1 5.4,1 5.4,0\n\
                GRAV 0 -10\nFIX 0 6 -1 3\nFREE 4 6 -1 3\nLOAD 2 4 -1 3 500 0\nLOAD 4 6 -1 3 1000 4000\nCYCLE 100\n";
    let (m, _) = run_ok(deck);
    let t = m.time;
    let [fixed, loaded_but_fixed, free] = [&m.blocks[0], &m.blocks[1], &m.blocks[2]];
    assert!(fixed.fixed && loaded_but_fixed.fixed && !free.fixed);
    // 1000 kg: a = (1000, 4000 − 10 000) / 1000 = (1, −6) m/s².
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
    let at = |b: &blockdem::udec::model::Block, c: [f64; 2]| close(b.centroid[0], c[0]) && close(b.centroid[1], c[1]) && b.velocity == [0.0, 0.0];
    assert!(at(fixed, [0.5, 0.5]), "{:?}", fixed.centroid);
    assert!(at(loaded_but_fixed, [2.7, 1.0]), "a fixed block ignores its load: {:?}", loaded_but_fixed.centroid);
    assert!(close(free.velocity[0], 1.0 * t) && close(free.velocity[1], -6.0 * t), "{:?} at t = {t}", free.velocity);
    assert_eq!(free.angular_velocity, 0.0, "a load at the centroid exerts no moment");
}

#[test]
fn link_records_the_pair_and_names_the_line_of_a_point_outside_every_block() {
    let deck = "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,2 0,3 1,3 1,2\n";
    let (m, _) = run_ok(&format!("{deck}LINK 0.5 2.5 0.5 0.5\n"));
    assert_eq!(m.links.len(), 1);
    assert_eq!((m.links[0].flying, m.links[0].anchor), (1, 0), "flying block (at 0.5, 2.5), anchor (at 0.5, 0.5)");
    let (r, _) = run_logged(&format!("{deck}LINK 0.5 1.5 0.5 0.5\n"));
    let e = r.unwrap_err().to_string();
    assert!(e.starts_with("<scene>:5:") && e.contains("no block contains the point (0.5, 1.5)"), "{e}");
    let (r, _) = run_logged(&format!("{deck}LINK 0.2 0.2 0.8 0.8\n"));
    assert!(r.unwrap_err().to_string().contains("same block"));
}

#[test]
fn print_energy_prints_every_term_and_the_balance() {
    let (m, log) = run_ok(&format!("{ONE_BLOCK}ROUND 0.1\nBLOCK 0,1.5 0,2.5 1,2.5 1,1.5\nFIX 0 1 0 1\nGRAV 0 -10\nDAMP .05 20\nCYCLE 2000\nPRINT ENERGY\n"));
    let e = m.energies();
    assert!(e.kinetic > 0.0 || e.strain > 0.0);
    let energy = &log[log.find("\nENERGY\n").expect("ENERGY table")..];
    // Each printed term equals the model's to the 4 digits of the 1.234E+05 format (half a unit
    // in the last digit: 5e-4 relative).
    let value = |label: &str| -> f64 {
        let rest = &energy[energy.find(label).unwrap_or_else(|| panic!("{label} missing:\n{energy}")) + label.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    for (label, want) in [
        ("KINETIC ", e.kinetic),
        ("STRAIN (CONTACTS) ", e.strain),
        ("WORK OF GRAVITY, LOADS AND VELOCITY ", e.external_work),
        ("MASS DAMPING ", e.mass_damping),
        ("CONTACT DASHPOTS ", e.contact_damping),
        ("FRICTION ", e.friction),
        ("RELEASED (DELETED CONTACTS AND BLOCKS) ", e.released),
        ("- WORK = ", e.ledger()),
    ] {
        let got = value(label);
        assert!((got - want).abs() <= 5e-4 * want.abs() + 1e-300, "{label}{got} against {want}");
    }
    // The block dropped 0.5 m onto the base (gravity's work 2000 kg · 10 m/s² · 0.5 m = 1e4 J,
    // less whatever rebound is left) and every damping account filled.
    assert!(e.external_work > 0.9e4 && e.mass_damping > 0.0 && e.contact_damping > 0.0, "{e:?}");
}

/// The line (1-based) of the first line of `deck` starting with `prefix`.
fn line_of(deck: &str, prefix: &str) -> usize {
    deck.lines().position(|l| l.starts_with(prefix)).unwrap_or_else(|| panic!("no line starts with {prefix}")) + 1
}

#[test]
fn save_of_a_scene_with_fluid_writes_a_file_restart_reads() {
    // Save format 6 keeps the fluid and the domain pressures (issue 30): the run saves, and a
    // RESTART has the fluid and its domains back.
    let file = std::env::temp_dir().join(format!("blockdem-fluid-save-{}.sav", std::process::id()));
    let deck = format!("{ONE_BLOCK}PROP MAT=1 CPERM=1E-9\nFLUID 1000 2E9\nSAVE {f}\nCYCLE 10\nSAVE {f}\nSTOP\n", f = file.display());
    let (m, log) = run_ok(&deck);
    assert!(log.contains("STATE SAVED TO"), "{log}");
    let (back, _) = run_ok(&format!("RESTART {}\nSTOP\n", file.display()));
    assert_eq!(back.fluid, m.fluid);
    assert_eq!(back.domains, m.domains);
    std::fs::remove_file(&file).ok();
}

#[test]
fn griffith_cracking_of_rigid_blocks_alone_is_an_input_error() {
    // Constitutive numbers 3 and 4 crack by Griffith's criterion (SL-85-1 Table A1, ¶17), which
    // reads the stress of simply-deformable blocks: with TF set and no such block the run stops
    // at CYCLE, naming the block and CHANGE SDEF, rather than never cracking.
    for setup in ["BLOCK CONS=3 0,0 0,1 1,1 1,0\n", "BLOCK 0,0 0,1 1,1 1,0\nCHANGE 0 1 0 1 CONS=4\n"] {
        let deck = format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 TF=100\n{setup}GRAV 0 -10\nCYCLE 10\n");
        let (r, _) = run_logged(&deck);
        let e = r.unwrap_err();
        let line = line_of(&deck, "CYCLE");
        assert!(matches!(e, RunError::Command { line: l, .. } if l == line), "{e}");
        assert!(e.to_string().contains("block 1 is rigid, but its constitutive number") && e.to_string().contains("CHANGE x1 x2 y1 y2 SDEF"), "{e}");
    }
    // Without TF nothing cracks, and constitutive 3 runs as a point contact.
    let (m, _) = run_ok("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK CONS=3 0,0 0,1 1,1 1,0\nGRAV 0 -10\nCYCLE 10\n");
    assert_eq!(m.cycle, 10);
    // Point-load cracking (constitutive 1 and 2) runs: sample 1 is the test of it.
}

#[test]
fn d3_deck_is_refused_by_the_2d_parser_at_its_first_3d_command() {
    let deck = sample("d3_two_tetrahedra.dat");
    let e = blockdem::udec::deck::parse_deck(&deck, "d3.dat").unwrap_err();
    let line = line_of(&deck, "BLOCK");
    assert_eq!(e.line, line);
    assert!(e.to_string().starts_with(&format!("d3.dat:{line}:14: BLOCK with (x,y,z) corners is D3's")), "{e}");
}

#[test]
fn models_the_engine_cannot_run_are_refused_at_cycle_with_their_line() {
    for (body, needle) in [
        ("BLOCK 0,0 0,1 1,1 1,0\nCYCLE 10\n", "material 1 has no density"),
        ("PROP MAT=1 D=1000\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 10\n", "needs contact stiffnesses KN and KS"),
        ("PROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nSPLIT 0.5 -1 0.5 2 MAT=2\nCYCLE 10\n", "joint material 2"),
        ("PROP MAT=1 D=1000 KN=1E8 KS=1E8\nCYCLE 10\n", "there are no blocks"),
        // m_min/k_max underflows f64: Δt = 0 would hang or divide by zero.
        ("PROP MAT=1 D=1E-300 KN=1E300 KS=1E300\nROUND 0.01\nBLOCK 0,0 0,1 1,1 1,0\nCYCLE 10\n", "time step FRAC·2√(m_min/k_max) is 0e0"),
        // A weight, or weight and load, that overflows f64 (found by tests/suite/random_decks.rs): the
        // first force sum stored it, and a CYCLE 0 or a failing CYCLE left a model holding an
        // infinite force, which SAVE wrote and RESTART refused.
        ("PROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nGRAV 0 -1E308\nCYCLE 0\n", "block 1 (mass 1e3 × gravity"),
        ("PROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nFIX 0 1 0 1\nGRAV 0 -1E305\nLOAD 0 1 0 1 0 -1E308\nCYCLE 10\n", "overflow f64"),
    ] {
        let deck = format!("START\n{body}");
        let (r, log) = run_logged(&deck);
        let e = r.unwrap_err().to_string();
        let line = line_of(&deck, "CYCLE");
        assert!(e.starts_with(&format!("<scene>:{line}: ")) && e.contains(needle), "{e}");
        assert!(!log.contains("INITIAL TIMESTEP"), "{log}");
    }
    // Two blocks each given a kinetic energy f64 holds, whose sum it does not (found by
    // tests/suite/random_decks.rs: the ledger booked ∞, and the stopped run's model could not be
    // restarted): refused at the VELOCITY, nothing changed.
    let deck = "START\nPROP MAT=1 D=3.548 KN=1E8 KS=1E8\nBLOCK 0,1 0,1.5 1.6,1.5 1.6,1\nBLOCK 3,1 3,1.73 3.34,1.73 3.34,1\n\
                VELOCITY -1E300 1E300 -1E300 1E300 1E154 0 0\nCYCLE 1\n";
    let (r, log) = run_logged(deck);
    let e = r.unwrap_err().to_string();
    assert!(e.starts_with("<scene>:5: VELOCITY: the blocks would move so fast together") && e.contains("overflows f64"), "{e}");
    assert!(!log.contains("TIMESTEP"), "{log}");
    // A BLOCK outline whose area overflows f64 is refused on its own line, saying so.
    let (r, _) = run_logged("START\nBLOCK 0,0 0,1E200 1E200,1E200 1E200,0\n");
    let e = r.unwrap_err().to_string();
    assert!(e.starts_with("<scene>:2: BLOCK: the block outline is too large") && e.contains("overflows"), "{e}");
}

#[test]
fn extreme_ratios_are_warned_against_the_limits_of_the_precision_that_runs() {
    // A light block (mass ratio 1e5) on a heavy one: inside the CPU f64 limits (1e6), outside the
    // f32 GPU kernels' (1e4, as far as the suite tries a GPU; README, Verification).
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nPROP MAT=2 D=0.02 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 4,1 4,0\n\
                BLOCK 1,1 1,2 2,2 2,1\nBLOCK MAT=2 1,2 1,3 2,3 2,2\nFIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 1\n";
    let run_with = |limits| {
        let commands = blockdem::udec::deck::parse_deck(deck, "<scene>").unwrap();
        let log = SharedLog::default();
        let mut exec = blockdem::udec::exec::Executor::new(Box::new(CpuBackend::new()), Box::new(log.clone()), Default::default(), "<scene>");
        exec.set_limits(limits);
        exec.run(&commands).unwrap();
        let text = String::from_utf8(log.0.borrow().clone()).unwrap();
        text
    };
    let cpu = run_with(LIMITS_CPU_F64);
    assert!(!cpu.contains("WARNING"), "{cpu}");
    let f32 = run_with(LIMITS_GPU_F32);
    let warn = f32.find("WARNING: block masses range over 1.0e5").unwrap_or_else(|| panic!("{f32}"));
    assert!(warn < f32.find("INITIAL TIMESTEP").unwrap(), "before the run: {f32}");
    // The default is the CPU's.
    let (_, log) = run_logged(deck);
    assert!(!log.contains("WARNING"), "{log}");
}

/// A ROUND of half the shortest edge or more is said once, naming the blocks, not at every CYCLE
/// (issue 27 item 9; the corners are rounded less than the deck asks, and touch as discs); again
/// when ROUND changes; a ROUND under it is not.
#[test]
fn a_round_past_half_an_edge_is_warned_against() {
    let deck = |round: &str| {
        format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND {round}\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX 0 1 0 1\nCYCLE 5\nCYCLE 5\nCYCLE 5\n")
    };
    let (_, log) = run_ok(&deck("0.5"));
    assert_eq!(log.matches("WARNING: ROUND 5.000E-01 is half the shortest edge or more in 2 block(s) (block 1, 2; ").count(), 1, "{log}");
    assert_eq!(log.matches("WARNING: ROUND").count(), 1, "{log}");
    let (_, log) = run_ok(&format!("{}ROUND 0.6\nCYCLE 5\n", deck("0.5")));
    assert_eq!(log.matches("WARNING: ROUND").count(), 2, "{log}");
    let (_, log) = run_ok(&deck("0.1"));
    assert!(!log.contains("WARNING"), "{log}");
}

/// A save file whose checksum is right but whose contents were damaged (a byte changed and the
/// CRC-32 recomputed, as a buggy writer or a hand edit would leave it) is refused by RESTART or
/// runs; it never panics. Every payload byte is changed in turn, with a few values, and then a
/// thousand bytes at random with random values (~5 s; before RESTART checked the model, 13 of
/// these files panicked, on a corner range or a contact's corner or feature past its list).
#[test]
fn a_damaged_save_file_with_a_good_checksum_never_panics_restart_or_cycle() {
    let dir = std::env::temp_dir().join(format!("blockdem-executor-{}-damaged-save", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("good.sav");
    // Blocks on a fixed base, in contact, with a link and a second material: every index a save
    // file holds is there to damage.
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nPROP MAT=2 D=1000 KN=1E8 KS=1E8 F=0.3\nROUND 0.05\nBLOCK 0,0 0,1 3,1 3,0\n\
         BLOCK 0.5,1 0.5,2 1.5,2 1.5,1\nBLOCK MAT=2 1.5,1 1.5,2 2.5,2 2.5,1\nBLOCK 1,4 1,5 2,5 2,4\nLINK 1.5 4.5 1 1.5\nFIX 0 3 0 0.9\n\
         GRAV 0 -10\nCYCLE 10\nSAVE {}\n",
        good.display()
    );
    let (m, _) = run_ok(&deck);
    assert!(!m.contacts.is_empty() && !m.links.is_empty(), "the scene has contacts and a link");
    let bytes = std::fs::read(&good).unwrap();
    const HEADER: usize = 28;
    let payload_len = bytes.len() - HEADER;
    let bad = dir.join("bad.sav");
    let restart = format!("RESTART {}\nCYCLE 10\n", bad.display());
    let mut mutations: Vec<(usize, u8)> = (0..payload_len).map(|i| (i, [0x01, 0x80, 0xff, 0x7f, 0x10, 0x02][i % 6])).collect();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for _ in 0..1000 {
        let (i, v) = (next() as usize % payload_len, (next() % 255 + 1) as u8);
        mutations.push((i, v));
    }
    let (mut refused, mut ran, mut panics) = (0, 0, Vec::new());
    for &(i, xor) in &mutations {
        let mut damaged = bytes.clone();
        damaged[HEADER + i] ^= xor;
        let crc = crc32fast::hash(&damaged[HEADER..]) as u64;
        damaged[20..28].copy_from_slice(&crc.to_le_bytes());
        std::fs::write(&bad, &damaged).unwrap();
        match std::panic::catch_unwind(|| run_logged(&restart).0) {
            Ok(Ok(_)) => ran += 1,
            Ok(Err(e)) => {
                // Refused at RESTART (line 1) or stopped by CYCLE (line 2), with the line.
                let e = e.to_string();
                assert!(e.starts_with("<scene>:1: RESTART: ") || e.starts_with("<scene>:2: "), "payload byte {i} ^ 0x{xor:02x}: {e}");
                refused += 1
            }
            Err(p) => {
                let what = p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default();
                panics.push(format!("payload byte {i} ^ 0x{xor:02x}: {what}"));
            }
        }
    }
    assert!(panics.is_empty(), "{} of {} damaged files panicked ({ran} ran, {refused} refused):\n{}", panics.len(), mutations.len(), panics.join("\n"));
    assert!(refused > 0 && ran > 0, "{ran} ran, {refused} refused");
}

/// RESTART checks the model it reads as the program keeps it (`Model::validate`): a contact that
/// names a corner past the list is refused with the deck's line, the file and the entry.
#[test]
fn restart_refuses_a_saved_model_whose_contact_names_a_corner_past_the_list() {
    let dir = std::env::temp_dir().join(format!("blockdem-executor-{}-inconsistent-save", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("x.sav");
    let (m, _) = run_ok(&format!("{ONE_BLOCK}BLOCK 0,1 0,2 1,2 1,1\nGRAV 0 -10\nCYCLE 10\nSAVE {}\n", path.display()));
    assert!(!m.contacts.is_empty());
    let mut file = blockdem::udec::output::load(&path).unwrap();
    let (id, corners) = (file.model.contacts[0].id, file.model.corners.len());
    file.model.contacts[0].corner = 87;
    blockdem::udec::output::save(&path, &file).unwrap();
    let (r, _) = run_logged(&format!("RESTART {}\nCYCLE 10\n", path.display()));
    let e = r.unwrap_err().to_string();
    let expected = format!("<scene>:1: RESTART: the model saved in {} is inconsistent: contact 0 (id {id}) names corner 87 of {corners}", path.display());
    assert_eq!(e, expected);
}

/// A BLOCK outline's corners are named as the deck counts them, from 1.
#[test]
fn block_outline_errors_count_corners_from_one() {
    let (r, _) = run_logged("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,1\n");
    let e = r.unwrap_err().to_string();
    assert!(e.contains(":3: BLOCK: corners 3 and 4 of the block outline are at the same place"), "{e}");
    let (r, _) = run_logged("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 1,1 0,0 0,1 1,1\n");
    let e = r.unwrap_err().to_string();
    assert!(e.contains("corners 4 and 1 of the block outline are at the same place"), "{e}");
}

#[test]
fn a_mass_that_overflows_f64_is_refused_at_the_command_that_makes_it() {
    // Found by tests/suite/random_decks.rs (a block 8 km wide, DENSITY 1E300): the mass stood at ∞,
    // CYCLE said it could not compute a time step "(no block mass …)", and SAVE wrote a model
    // RESTART refused. Each command now fails whole, naming the block, and leaves the model as
    // it was (a restartable one: the driver saves it as the state before the failing command).
    let big = "BLOCK 0,0 0,1E4 1E4,1E4 1E4,0";
    for (body, what, blocks) in [
        (format!("PROP MAT=1 D=1000 KN=1E8 KS=1E8\n{big}\nPROP MAT=1 D=1E300\n"), "PROPERTY", 1),
        (format!("PROP MAT=1 D=1000 KN=1E8 KS=1E8\nPROP MAT=2 D=1E300 KN=1E8 KS=1E8\n{big}\nCHANGE -1 2E4 -1 2E4 MAT 2\n"), "CHANGE", 1),
        (format!("PROP MAT=1 D=1E300 KN=1E8 KS=1E8\nBLOCK 0,-1 0,0 1,0 1,-1\n{big}\n"), "BLOCK", 1),
    ] {
        let deck = format!("START\n{body}CYCLE 10\n");
        let commands = blockdem::udec::deck::parse_deck(&deck, "<scene>").unwrap();
        let mut exec = blockdem::udec::exec::Executor::new(Box::new(CpuBackend::new()), Box::new(std::io::sink()), Default::default(), "<scene>");
        let e = exec.run(&commands).unwrap_err().to_string();
        let line = deck.lines().count() - 1;
        assert!(e.starts_with(&format!("<scene>:{line}: {what}: the mass of block ")) && e.contains("overflows f64"), "{e}");
        assert_eq!(exec.model.blocks.len(), blocks, "{what}");
        exec.model.validate().unwrap_or_else(|v| panic!("{what}: the model left is not restartable: {v}"));
        assert!(exec.model.blocks.iter().all(|b| b.mass.is_finite() && b.material == 1), "{what}");
    }
}

#[test]
fn a_block_flung_so_far_that_its_edges_vanish_in_round_off_stays_restartable() {
    // Found by tests/suite/random_decks.rs: GRAVITY 1E154 flings a 5 cm block to 2.5e147 m, where its
    // corners' world positions coincide; the edge directions measured from them were 0/0, and
    // the model (SAVE, the state JSON) held NaN that RESTART refused.
    let (m, _) = run_ok("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nBLOCK 0,1 0,1.05 0.05,1.05 0.05,1\nROUND 1E300\nGRAV 1E154 0\nCYCLE 50\n");
    assert!(m.blocks[0].centroid[0] > 1e140, "{:?}", m.blocks[0].centroid);
    m.validate().unwrap_or_else(|e| panic!("not restartable: {e}"));
}

/// Issue 27 item 1: SET OVERLAP ACCEPT|REFUSE, and decks built touching run as before.
#[test]
fn set_overlap_is_parsed_and_blocks_built_touching_are_not_refused() {
    use blockdem::udec::deck::{Command, OverlapPolicy, Setting};
    let parsed = blockdem::udec::deck::parse_deck("START\nSET OVERLAP ACCEPT\nSE OV REF\n", "d").unwrap();
    assert_eq!(parsed[1].command, Command::Set { setting: Setting::Overlap(OverlapPolicy::Accept) });
    assert_eq!(parsed[2].command, Command::Set { setting: Setting::Overlap(OverlapPolicy::Refuse) });
    for bad in ["SET", "SET OVERLAP", "SET OVERLAP MAYBE", "SET ROUND 1", "SET OVERLAP ACCEPT 2"] {
        let e = blockdem::udec::deck::parse_deck(&format!("START\n{bad}\n"), "d").unwrap_err();
        assert_eq!(e.line, 2, "{bad}: {e}");
    }
    // Blocks built touching (shared edges, a SPLIT) and a block settled on its base: no overlap
    // beyond round-off and the settlement mg/kn, so no warning, and the ledger within 1 %.
    let (_, log) = run_ok(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nBLOCK 2,1 2,2 3,2 3,1\n\
         SPLIT 2.5 0.5 2.5 3\nFIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 500\nBLOCK 1,2 1,3 2,3 2,2\nCYCLE 500\n",
    );
    assert!(!log.contains("WARNING"), "{log}");
}

/// Issue 27 item 3: the kinetic energy VELOCITY gives is input, booked with the work of gravity
/// and loads, so that the balance stays at zero (it read 5.000E+04 for this block); a second
/// VELOCITY on the moving block books its new less its old kinetic energy.
#[test]
fn the_kinetic_energy_velocity_gives_is_booked_as_input() {
    let deck = "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8 F=0.5\nBLOCK 0,0 0,1 1,1 1,0\nVELOCITY -1 2 -1 2 10 0\nCYCLE 100\nPRINT ENERGY\n";
    let (m, log) = run_ok(deck);
    let e = m.energies();
    assert!((e.kinetic - 5e4).abs() < 1e-9 * 5e4 && (e.external_work - 5e4).abs() < 1e-9 * 5e4, "{e:?}");
    assert!(e.ledger().abs() < 1e-9 * 5e4, "{e:?}");
    let balance = log.lines().find(|l| l.contains("BALANCE")).expect("BALANCE line");
    let value: f64 = balance.rsplit(' ').next().unwrap().parse().unwrap();
    assert!(value.abs() < 1e-6, "{balance}");
    // Slowed to 2 m/s (it is near x = 2 by now): 2000 J left, 48 000 J taken back out.
    let (m, _) = run_ok(&format!("{deck}VELOCITY -10 10 -10 10 2 0\nCYCLE 100\n"));
    let e = m.energies();
    assert!((e.kinetic - 2e3).abs() < 1e-9 * 5e4 && e.ledger().abs() < 1e-9 * 5e4, "{e:?}");
    // The brick wall struck at 50 m/s: the balance is a small part of the 2.5e6 J given (it was
    // all of it), what the impact itself does to the ledger.
    let (m, _) = run_ok(&sample("brick_wall_impact.dat"));
    let e = m.energies();
    assert!(e.external_work > 2.5e6 && e.ledger().abs() < 0.02 * e.scale(), "{e:?}");
}

/// Issue 27 item 5: a command that would do nothing says so in the log and the run goes on — a
/// range catching no centroid (FIX, FREE, DELETE, LOAD, VELOCITY, CHANGE), a SPLIT crossing no
/// block or of zero length, a PLOT whose WINDOW or VIEW shows no block.
#[test]
fn silent_no_ops_are_warned_against_and_the_run_goes_on() {
    for (cmd, warning) in [
        ("FIX 5 6 5 6", "WARNING: FIX: no block's centroid lies in x 5 to 6, y 5 to 6 (of 1 block(s)); nothing changed"),
        ("FREE 5 6 -3 -2", "WARNING: FREE: no block's centroid lies in x 5 to 6, y -3 to -2"),
        ("DELETE 5 6 5 6", "WARNING: DELETE: no block's centroid"),
        ("LOAD 5 6 5 6 0 -10", "WARNING: LOAD: no block's centroid"),
        ("VELOCITY 5 6 5 6 1 0", "WARNING: VELOCITY: no block's centroid"),
        ("CHANGE 5 6 5 6 MAT=1", "WARNING: CHANGE: no block's centroid"),
        ("SPLIT 0.5,0.5 0.5,0.5", "WARNING: SPLIT (0.5, 0.5) (0.5, 0.5) has zero length; nothing was split"),
        ("SPLIT 5,-1 5,2", "WARNING: SPLIT (5, -1) (5, 2) crosses no block from one side to the other; nothing was split"),
        ("SPLIT 0.5,-1 0.5,0.5", "WARNING: SPLIT (0.5, -1) (0.5, 0.5) crosses no block"),
        ("WINDOW 20 30 20 30\nPLOT", "WARNING: PLOT shows no block: none lies in WINDOW"),
        ("VIEW 3000 4000 0 1400\nPLOT", "WARNING: PLOT shows no block: VIEW 3000 4000 0 1400 lies off the page"),
    ] {
        let dir = std::env::temp_dir().join(format!("blockdem-noop-{}", std::process::id()));
        let commands = blockdem::udec::deck::parse_deck(&format!("{ONE_BLOCK}{cmd}\nCYCLE 1\n"), "<scene>").unwrap();
        let log = SharedLog::default();
        let options = blockdem::udec::exec::RunOptions { out_dir: dir, ..Default::default() };
        let mut exec = blockdem::udec::exec::Executor::new(Box::new(CpuBackend::new()), Box::new(log.clone()), options, "<scene>");
        let result = exec.run(&commands);
        let log = String::from_utf8(log.0.borrow().clone()).unwrap();
        assert!(result.is_ok() && log.contains(warning) && log.contains("CURRENT CYCLE COUNT = 1"), "{cmd}:\n{log}");
    }
    // Ranges that catch a block, a split across it and a plot that shows it say nothing.
    let (_, log) = run_ok(&format!(
        "{ONE_BLOCK}ROUND 0.01\nFIX -1 2 -1 2\nFREE -1 2 -1 2\nLOAD -1 2 -1 2 0 -10\nCHANGE -1 2 -1 2 MAT=1\nVELOCITY -1 2 -1 2 0 0\nSPLIT 0.5,-1 0.5,2\nPLOT\nCYCLE 1\n"
    ));
    assert!(!log.contains("WARNING"), "{log}");
}

/// Issue 27 item 6: a command that cannot run found after a long CYCLE stops the run before it
/// cycles, naming that command's line (a deck of CYCLE 100000 then FLUID cycled first, then
/// failed); typing errors are the parser's, before anything runs. Since fluid runs (issue 30) and
/// its SAVE too (save format 6), every command runs: the look-ahead lets a deck with fluid and a
/// SAVE after its CYCLEs run to its end, whichever comes first.
#[test]
fn a_command_that_cannot_run_is_found_before_the_first_cycle() {
    for fluid_first in [true, false] {
        let (before, after) = if fluid_first { ("FLUID 1000 2E9\n", "") } else { ("", "FLUID 1000 2E9\n") };
        let file = std::env::temp_dir().join(format!("blockdem-lookahead-{}-{fluid_first}.sav", std::process::id()));
        let deck = format!("{ONE_BLOCK}PROP MAT=1 CPERM=1E-9\nVELOCITY -1 2 -1 2 0.1 0 0\n{before}CYCLE 100\n{after}CYCLE 10\nSAVE {}\nSTOP\n", file.display());
        let (r, log) = run_logged(&deck);
        r.unwrap();
        assert!(!log.contains("CANNOT RUN TO ITS END") && log.contains("CURRENT CYCLE COUNT = 110") && log.contains("STATE SAVED TO"), "{log}");
        std::fs::remove_file(&file).ok();
    }
    // A dry scene saves.
    let (r, _) = run_logged(&format!("{ONE_BLOCK}CYCLE 1\nSAVE {}\n", std::env::temp_dir().join("blockdem-dry-save.sav").display()));
    r.unwrap();
    let e = blockdem::udec::deck::parse_deck(&format!("{ONE_BLOCK}CYCLE 100000000\nCYLCE 10\n"), "<scene>").unwrap_err();
    assert!(e.to_string().starts_with("<scene>:5:1: unknown command 'CYLCE' (did you mean CYCLE?)"), "{e}");
}
