//! Numerical failures on every backend (tests/suite/common): the same error as the CPU reference, at
//! the same cycle, and the model left at its last good state (the checkpoint of the energy check,
//! every 100 cycles), finite throughout.

use crate::common;

use blockdem::udec::backend::CycleError;
use blockdem::udec::exec::{Executor, RunError, RunOptions};
use blockdem::udec::model::Model;
use common::{every_backend, Target};

every_backend!(
    an_overlap_beyond_half_the_rounding_stops_at_the_last_good_state,
    blocks_given_overlapping_are_an_input_error_naming_them,
    blocks_built_overlapping_are_named_and_refused_unless_accepted,
    an_unstable_fraction_is_caught_before_any_nan,
    a_projectile_that_would_tunnel_is_stopped,
    a_step_that_overflows_names_its_block,
    a_value_f32_cannot_hold_is_refused_before_the_run,
    a_block_too_fast_to_integrate_is_refused_at_its_cycle_command,
    a_failure_after_a_checkpoint_restores_that_checkpoint,
    a_failure_in_a_later_run_restores_that_runs_start,
    a_failure_after_contact_updates_restores_the_checkpoints_contacts,
);

/// Runs a deck that must fail; returns the failure and the model the executor kept.
fn fail(t: &Target, deck: &str) -> (CycleError, Model) {
    let commands = blockdem::udec::deck::parse_deck(deck, "<scene>").unwrap();
    let options = RunOptions { out_dir: std::env::temp_dir().join("blockdem-failures"), ..Default::default() };
    let mut exec = Executor::new(t.backend(), Box::new(std::io::sink()), options, "<scene>");
    match exec.run(&commands) {
        Err(RunError::Numerical { failure, .. }) => (failure, exec.model),
        other => panic!("expected a numerical failure on {}, got {other:?}", t.name()),
    }
}

fn assert_last_good(m: &Model, t: &Target) {
    assert_eq!(m.cycle % 100, 0, "rolled back to a checkpoint on {}: cycle {}", t.name(), m.cycle);
    for b in &m.blocks {
        assert!(b.centroid.iter().chain(&b.velocity).all(|x| x.is_finite()) && b.angular_velocity.is_finite(), "finite state on {}", t.name());
    }
}

fn an_overlap_beyond_half_the_rounding_stops_at_the_last_good_state(t: &Target) {
    // A block fired at 2 m/s into a fixed one 5 cm away: the soft contact (stopping distance
    // v√(m/kn) ≈ 0.09 m) cannot stop it within d/2 = 0.05 m.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 1.05,0 1.05,1 2.05,1 2.05,0\nFIX 1 3 0 1\n\
         VELOCITY 0 1 0 1 2 0\nCYCLE 2000\n";
    let (e, m) = fail(t, deck);
    let (reference, _) = fail(&Target::Cpu, deck);
    match (&e, &reference) {
        (CycleError::Overlap { cycle, block1, block2, .. }, CycleError::Overlap { cycle: c0, .. }) => {
            assert!([*block1, *block2].contains(&1) && [*block1, *block2].contains(&2));
            // The overlap grows ~2 mm a step past the limit: f32 crosses it on the same step.
            assert_eq!(cycle, c0, "same cycle as the CPU on {}", t.name());
        }
        _ => panic!("expected an overlap on {}: {e}", t.name()),
    }
    assert_last_good(&m, t);
}

fn blocks_given_overlapping_are_an_input_error_naming_them(t: &Target) {
    // A block given 0.3 m into the base (more than half the rounding length, 0.025 m) fails at
    // the first cycle as an overlap, though nothing was driven: the CYCLE says the blocks were
    // given overlapping, names them, and leaves the model as the deck built it. (The block
    // driven into its neighbour above stays a numerical failure.)
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 8,1 8,0\nFIX 0 8 0 1\nGRAV 0 -10\n\
                BLOCK 2,0.7 2,1.7 3,1.7 3,0.7\nCYCLE 100\n";
    let commands = blockdem::udec::deck::parse_deck(deck, "<scene>").unwrap();
    let options = RunOptions { out_dir: std::env::temp_dir().join("blockdem-failures"), ..Default::default() };
    let mut exec = Executor::new(t.backend(), Box::new(std::io::sink()), options, "<scene>");
    match exec.run(&commands) {
        Err(RunError::Command { line: 8, message, .. }) => {
            assert!(message.contains("blocks 2 and 1 overlap by 3.000E-01") && message.contains("before any motion"), "{message} on {}", t.name())
        }
        other => panic!("expected an input error at the CYCLE on {}, got {other:?}", t.name()),
    }
    assert_eq!(exec.model.cycle, 0, "nothing run on {}", t.name());
    assert_eq!(exec.model.blocks[1].centroid, [2.5, 1.2], "the block where it was given on {}", t.name());
}

/// Issue 27 item 1's deck: a block built 0.1 m into a fixed base (under half the rounding length,
/// so no overlap failure), `setting` given before the CYCLE.
fn built_overlapping(setting: &str) -> String {
    format!(
        "START\nPROP MAT=1 DENS=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.25\n{setting}GRAV 0 -10\nBLOCK (0,-1) (0,0) (4,0) (4,-1)\n\
         BLOCK (1,-0.1) (1,0.9) (2,0.9) (2,-0.1)\nFIX -1 5 -2 -0.2\nCYCLE 100\n"
    )
}

fn blocks_built_overlapping_are_named_and_refused_unless_accepted(t: &Target) {
    // Each contact of the pair starts at kn·δ = 1e8 N: the block left at ~100 m/s, silently
    // (exit status 0, no warning, the energy check quiet). Now the CYCLE names the pair, the
    // overlap, the energy ½kn·δ² (2 × 5e6 J/m) and the speed it gives the block (100 m/s), and
    // refuses, before any cycle, at its own line.
    let run = |deck: &str| {
        let commands = blockdem::udec::deck::parse_deck(deck, "<scene>").unwrap();
        let options = RunOptions { out_dir: std::env::temp_dir().join("blockdem-failures"), ..Default::default() };
        let log = common::SharedLog::default();
        let mut exec = Executor::new(t.backend(), Box::new(log.clone()), options, "<scene>");
        let result = exec.run(&commands);
        let text = String::from_utf8(log.0.borrow().clone()).unwrap();
        (result, exec.model, text)
    };
    let (result, m, log) = run(&built_overlapping(""));
    match result {
        Err(RunError::Command { line: 8, message, .. }) => assert!(
            message.contains("blocks 2 and 1 overlap by 1.000E-01")
                && message.contains("1.000E+07 J/m")
                && message.contains("launch block 2 at 1.000E+02 m/s")
                && message.contains("SET OVERLAP ACCEPT"),
            "{message} on {}",
            t.name()
        ),
        other => panic!("expected the CYCLE refused at its line on {}, got {other:?}", t.name()),
    }
    assert!(log.contains("WARNING: BLOCKS 2 AND 1 OVERLAP BY 1.000E-01"), "the log names the pair on {}:\n{log}", t.name());
    assert_eq!((m.cycle, m.blocks[1].centroid), (0, [1.5, 0.4]), "nothing run on {}", t.name());
    // Asked for, the CYCLE runs with that energy, booked as energy put in: the block leaves at
    // ~100 m/s and the ledger balances to the error of releasing a 0.1 m overlap in a few steps.
    let (result, m, log) = run(&built_overlapping("SET OVERLAP ACCEPT\n"));
    assert!(result.is_ok(), "{result:?} on {}", t.name());
    assert!(log.contains("SET OVERLAP ACCEPT: CYCLING WITH 1.000E+07 J/M"), "{log}");
    let e = m.energies();
    assert!(m.blocks[1].velocity[1] > 90.0, "launched at {:?} on {}", m.blocks[1].velocity, t.name());
    assert!(e.external_work > 0.99e7 && e.ledger().abs() < 0.01 * e.external_work, "the ledger {e:?} on {}", t.name());
    assert!(!log.contains("WARNING: THE ENERGY BALANCE"), "a 0.3 % balance is the scheme's own error: {log}");
    // At FRACTION 0.2 the release of 0.1 m in two steps leaves the ledger 6 % off: said once,
    // with the figures.
    let (result, _, log) = run(&built_overlapping("SET OVERLAP ACCEPT\nFRACTION 0.2\n").replace("CYCLE 100", "CYCLE 100\nCYCLE 100"));
    assert!(result.is_ok(), "{result:?} on {}", t.name());
    assert_eq!(log.matches("WARNING: THE ENERGY BALANCE IS").count(), 1, "{log}");
    assert!(log.contains("OF THE ENERGY IN PLAY (1.0"), "{log}");
}

fn an_unstable_fraction_is_caught_before_any_nan(t: &Target) {
    // FRAC 5 is far above the stable limit of the central-difference scheme (≈ 0.5 here).
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nFRAC 5\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 5000\n";
    let (e, m) = fail(t, deck);
    assert!(matches!(e, CycleError::EnergyGrowth { .. } | CycleError::Overlap { .. } | CycleError::TooFast { .. }), "{e} on {}", t.name());
    assert_last_good(&m, t);
}

fn a_step_that_overflows_names_its_block(t: &Target) {
    // A load on the second block whose first step's work (force × displacement) overflows: 1e300
    // N in f64 (~1e300 × 1e292 J), 1e38 N in f32 (just below its largest value, which the f32
    // kernels would refuse; ~1e38 × 1e30 J). Every backend names that block, at cycle 1, and
    // keeps the state the CYCLE started from.
    let load = if t.is_f32() { "1E38" } else { "1E300" };
    let deck = format!("START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 3,0 3,1 4,1 4,0\nLOAD 3 4 0 1 {load} 0\nCYCLE 10\n");
    let (e, m) = fail(t, &deck);
    let loaded = m.blocks.iter().find(|b| b.load[0] > 0.0).expect("the loaded block").id;
    assert_ne!(loaded, m.blocks[0].id);
    assert!(matches!(e, CycleError::NonFinite { cycle: 1, block, .. } if block == loaded), "{e} on {}", t.name());
    assert_eq!(m.cycle, 0, "on {}", t.name());
    assert_last_good(&m, t);
    if t.is_f32() {
        return;
    }
    // A step's work past f32's range but finite in f64 (1e40 N over ~1e32 m: 1e72 J) is finite
    // on the f64 kernels as on the CPU (they held it to f32's range and called it not finite):
    // the block is too fast, named as such.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 3,0 3,1 4,1 4,0\nLOAD 3 4 0 1 1E40 0\nCYCLE 10\n";
    let (e, _) = fail(t, deck);
    assert!(matches!(e, CycleError::TooFast { cycle: 1, block, .. } if block == loaded), "{e} on {}", t.name());
}

fn a_value_f32_cannot_hold_is_refused_before_the_run(t: &Target) {
    // DENSITY 1e40 and KN 1e45 (a wall of 2000 kg/m³ and 2e9 N/m in other units): masses of
    // 1e40 kg, infinite in f32. f64 runs it as the CPU does; the f32 kernels refuse it before any
    // cycle, naming the value and the way out, as "does not fit" (so `--backend auto` goes on on
    // the CPU).
    let deck = "START\nPROP MAT=1 D=1E40 KN=1E45 KS=1E45\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX 0 1 0 0.9\nGRAV 0 -10\nCYCLE 10\n";
    // Likewise Rayleigh damping whose coefficients f32 cannot hold: α = ξ·2πf of 8e299 (DAMPING
    // at 1e300 Hz, found by fuzzing random decks: the f32 run went non-finite where f64 runs it),
    // and contact dashpots β·KN of 1.6e307 (which diverge in f64 too, far past the stable range).
    let wall = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX 0 1 0 0.9\nGRAV 0 -10\n";
    let cases = [
        (deck.to_string(), "block 1's mass is 1e40", true),
        (format!("{wall}DAMP 0.13 1E300 MASS\nCYCLE 10\n"), "the mass damping α (DAMPING) is 8.16", true),
        (format!("{wall}DAMP 0.1 1E-300 STIFF\nCYCLE 10\n"), "material 1's stiffness damping β·KN (DAMPING) is 1.59", false),
        // And the fluid's: a flow law, and A_d(min) (SET DAMIN 1E300 made every area the device
        // gave back infinite, and the last good state of a failing run one no RESTART took;
        // found by fuzzing random decks).
        (format!("{wall}FLUID 1000 2E5\nPROP MAT=1 CPERM=1E200\nPFIX OUTER 0\nCYCLE 10\n"), "material 1's CPERM is 1e200", true),
        (
            format!("{wall}FLUID 1000 2E5\nPROP MAT=1 CPERM=1E-7\nPFIX OUTER 0\nSET DAMIN 1E300\nCYCLE 10\n"),
            "the domains' minimum area (SET DAMIN) is 1e300",
            true,
        ),
    ];
    for (deck, named, f64_runs) in &cases {
        if !t.is_f32() {
            let run = blockdem::scenes::run_deck_on(deck, t.backend());
            match run {
                Ok(m) => assert!(*f64_runs && m.cycle == 10, "runs on {}", t.name()),
                Err(e) => assert!(!f64_runs && e.is_numerical(), "{e} on {}", t.name()),
            }
            continue;
        }
        let (e, m) = fail(t, deck);
        match e {
            CycleError::DoesNotFit(why) => assert!(why.contains(named) && why.contains("--precision f64"), "{why}"),
            other => panic!("expected the f32 kernels to refuse the model, got {other}"),
        }
        assert_eq!(m.cycle, 0);
    }
}

fn a_block_too_fast_to_integrate_is_refused_at_its_cycle_command(t: &Target) {
    // ½mv² overflows f64 before any step; the energy check would call that an instability and
    // advise a smaller FRACTION. VELOCITY 1e300 is refused at its own line (a DELETE before the
    // CYCLE booked ∞ − ∞ as released energy); a velocity that overflows only once PROPERTY makes
    // the block heavier is refused by the CYCLE command, on every backend, naming the block.
    let base = "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX 0 1 0 0.9\n";
    let err = blockdem::scenes::run_deck_on(&format!("{base}VELOCITY 0 1 1 2 1E300 0\nDELETE 0 1 1 2\nCYCLE 10\n"), t.backend()).unwrap_err().to_string();
    assert!(err.starts_with("<scene>:7: VELOCITY: block 2 would move so fast"), "on {}: {err}", t.name());
    let deck = format!("{base}VELOCITY 0 1 1 2 1E152 0\nPROP MAT=1 D=2E9\nCYCLE 10\n");
    let err = blockdem::scenes::run_deck_on(&deck, t.backend()).unwrap_err().to_string();
    assert!(err.contains("line 9") || err.contains(":9"), "names the CYCLE line on {}: {err}", t.name());
    assert!(err.contains("block 2 moves so fast") && err.contains("check VELOCITY"), "on {}: {err}", t.name());
}

fn a_projectile_that_would_tunnel_is_stopped(t: &Target) {
    // 200 m/s with Δt ≈ 9e-3 s: 1.8 m a step, through a 1 m block in one step. Stopped at the
    // first step, before any checkpoint: the model is the one the CYCLE started from.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 3,0 3,1 4,1 4,0\nFIX 2 5 0 1\n\
         VELOCITY 0 1 0 1 200 0\nCYCLE 100\n";
    let (e, m) = fail(t, deck);
    match e {
        CycleError::TooFast { cycle, block, .. } => {
            assert_eq!((cycle, block), (1, 1), "on {}", t.name());
        }
        _ => panic!("expected too fast on {}: {e}", t.name()),
    }
    assert_last_good(&m, t);
    assert!((m.blocks[0].centroid[0] - 0.5).abs() < 1e-6 && (m.blocks[0].velocity[0] - 200.0).abs() < 1e-3);
}

fn a_failure_after_a_checkpoint_restores_that_checkpoint(t: &Target) {
    // A block pressed onto a fixed base by its weight and a load: the static overlap
    // (W + L)/2kn = 0.035 m is under the limit d/2 = 0.05 m, but the dynamic one (twice that,
    // undamped) is not, and crosses it at cycle 178 with FRAC 0.004. So the run fails after the
    // checkpoint of cycle 100, and the model must be that checkpoint: on the GPU it comes from
    // the device copy taken after the energy check passed, with the fixed base's force summed
    // on restore (the cycle skips fixed blocks).
    let deck = "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6 F=0.5\nROUND 0.1\nFRAC 0.004\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\n\
         FIX 0 4 0 0.9\nGRAV 0 -10\nLOAD 1 2 1 2 0 -50000\nCYCLE 5000\n";
    let (e, m) = fail(t, deck);
    let (_, reference) = fail(&Target::Cpu, deck);
    assert!(matches!(e, CycleError::Overlap { cycle: 178, .. }), "{e} on {}", t.name());
    assert_eq!((m.cycle, reference.cycle), (100, 100), "on {}", t.name());
    assert!((m.time - reference.time).abs() < 1e-12 * reference.time, "on {}", t.name());
    // f32 keeps the centroid to ~1e-7 m and the velocity to ~1e-7 relative over 100 steps; the
    // forces to f32 round-off of 1e5 N. The tolerances leave a factor of 10 or more.
    assert_blocks_near(&m, &reference, t);
    for (g, c) in m.blocks.iter().zip(&reference.blocks) {
        for i in 0..2 {
            assert!((g.force[i] - c.force[i]).abs() < 1e-4 * (1.0 + c.force[0].hypot(c.force[1])), "force on {}: {:?} vs {:?}", t.name(), g.force, c.force);
        }
    }
    assert_eq!(m.contacts.len(), reference.contacts.len());
    // The contacts' points and normals are the checkpoint's too (the GPU places them before it
    // copies the contacts; the block has sunk ~1 cm onto the base by then, so points of the
    // upload would be off by millimetres). Same tolerance as the centroids.
    for (g, c) in m.contacts.iter().zip(&reference.contacts) {
        let (dp, dn) = ((g.point[0] - c.point[0]).hypot(g.point[1] - c.point[1]), (g.normal[0] - c.normal[0]).hypot(g.normal[1] - c.normal[1]));
        assert!(dp < 1e-5 && dn < 1e-5, "contact {} on {}: point {:?} vs {:?}, normal {:?} vs {:?}", c.id, t.name(), g.point, c.point, g.normal, c.normal);
    }
    assert_last_good(&m, t);
}

/// Each block's centroid to 1e-5 m and velocity to 1e-5 relative of the reference's (what f32
/// keeps over the ~100 steps since a checkpoint, with a factor of 10 or more to spare).
fn assert_blocks_near(m: &Model, reference: &Model, t: &Target) {
    for (g, c) in m.blocks.iter().zip(&reference.blocks) {
        for i in 0..2 {
            assert!((g.centroid[i] - c.centroid[i]).abs() < 1e-5, "centroid on {}: {:?} vs {:?}", t.name(), g.centroid, c.centroid);
            let near = (g.velocity[i] - c.velocity[i]).abs() < 1e-5 * (1.0 + c.velocity[i].abs());
            assert!(near, "velocity on {}: {:?} vs {:?}", t.name(), g.velocity, c.velocity);
        }
    }
}

fn a_failure_in_a_later_run_restores_that_runs_start(t: &Target) {
    // The block of the test above settles for 150 cycles without the load; the second CYCLE
    // adds a load large enough to cross the overlap limit (cycle 234) before that run's first
    // checkpoint. The last good state is then the second run's start, load included: the
    // backends keep their copy of the last good state from run to run (its storage is reused),
    // and a copy left from the first run (cycle 150 too, but without the load) would be wrong.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6 F=0.5\nROUND 0.1\nFRAC 0.004\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\n\
         FIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 150\nLOAD 1 2 1 2 0 -150000\nCYCLE 5000\n";
    let (e, m) = fail(t, deck);
    let (_, reference) = fail(&Target::Cpu, deck);
    assert!(matches!(e, CycleError::Overlap { cycle: 234, .. }), "{e} on {}", t.name());
    assert_eq!((m.cycle, reference.cycle), (150, 150), "on {}", t.name());
    let loaded = m.blocks.iter().find(|b| !b.fixed).expect("a free block");
    assert_eq!(loaded.load, [0.0, -150000.0], "the load of the second run is kept on {}", t.name());
    // The state 150 cycles into the settling (as in the test above, f32 keeps ~1e-7).
    assert_blocks_near(&m, &reference, t);
}

fn a_failure_after_contact_updates_restores_the_checkpoints_contacts(t: &Target) {
    // A block slides without friction at 5 m/s over a row of fixed blocks, its corners passing
    // from one to the next (contacts made and dropped at contact updates), and strikes a fixed
    // wall hard enough to overlap it past the limit (cycle 2373 on the CPU). The last good state
    // is the checkpoint of cycle 2300, with the contacts of then, not of the run's start: the
    // GPU backend refreshes its copy of the topology after contact updates (the contacts'
    // identities alone, their state and the blocks' coming from its device checkpoint).
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.0\nROUND 0.01\n\
         BLOCK 0,0 0,1 1,1 1,0\nBLOCK 1,0 1,1 2,1 2,0\nBLOCK 2,0 2,1 3,1 3,0\nBLOCK 3,0 3,1 4,1 4,0\nBLOCK 4,0 4,1 5,1 5,0\nBLOCK 5,0 5,1 6,1 6,0\n\
         BLOCK 6,0 6,2 7,2 7,0\nBLOCK 0.2,1 0.2,1.5 0.7,1.5 0.7,1\nFIX 0 7 0 0.99\nFIX 6 7 0 2\nGRAV 0 -10\nVELOCITY 0 1 1 1.5 5 0\nCYCLE 5000\n";
    let (e, m) = fail(t, deck);
    let (re, reference) = fail(&Target::Cpu, deck);
    assert!(matches!(re, CycleError::Overlap { cycle: 2373, .. }), "{re} on the CPU");
    assert!(matches!(e, CycleError::Overlap { .. }), "{e} on {}", t.name());
    assert_eq!((m.cycle, reference.cycle), (2300, 2300), "on {}", t.name());
    // The slider touches the last blocks of the row by then, not the first it started on.
    let slider = reference.blocks.iter().position(|b| !b.fixed).expect("a free block") as u32;
    let touched: Vec<u32> = reference.contacts.iter().filter(|c| c.block1 == slider || c.block2 == slider).map(|c| c.block1 + c.block2 - slider).collect();
    assert!(!touched.is_empty() && touched.iter().all(|&b| b >= 4), "the slider's contacts at cycle 2300: {touched:?}");
    let key = |m: &Model| m.contacts.iter().map(|c| (c.block1, c.corner, c.block2)).collect::<Vec<_>>();
    assert_eq!(key(&m), key(&reference), "the checkpoint's contacts on {}", t.name());
    // Its state of cycle 2300 (another checkpoint's would be 0.2 m away): the position to 1e-3 m;
    // the velocity to 0.05 m/s, since the corners rattle over each joint of the row and round-off
    // decides the small bounces (the GPU in f64 and the CPU differ by 0.015–0.03 m/s vertically,
    // f32 and the CPU by 1.2e-4 m along the row).
    let (g, c) = (&m.blocks[slider as usize], &reference.blocks[slider as usize]);
    for i in 0..2 {
        assert!((g.centroid[i] - c.centroid[i]).abs() < 1e-3, "centroid on {}: {:?} vs {:?}", t.name(), g.centroid, c.centroid);
        assert!((g.velocity[i] - c.velocity[i]).abs() < 0.05, "velocity on {}: {:?} vs {:?}", t.name(), g.velocity, c.velocity);
    }
    assert_last_good(&m, t);
}

/// FRACTION far above the stable limit can fail first as a block too fast for the contact update
/// (or an overlap) rather than as energy growth: the message still names the cause and the
/// largest safe FRACTION, that FRACTION runs clean, and the state kept holds no NaN. CPU: the
/// advice comes from the executor, the same for every backend.
#[test]
fn a_fraction_far_above_the_limit_names_the_largest_safe_fraction_whatever_fails_first() {
    let deck = |frac: f64| {
        format!(
            "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nFRAC {frac}\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\n\
             GRAV 0 -10\nCYCLE 2000\n"
        )
    };
    for frac in [20.0, 100.0] {
        let text = deck(frac);
        let (failure, m) = fail(&Target::Cpu, &text);
        let err = blockdem::scenes::run_deck_on(&text, Target::Cpu.backend()).unwrap_err().to_string();
        assert!(err.contains(&failure.to_string()), "the cause comes first: {err}");
        let safe: f64 = err
            .split("the largest safe value is about ")
            .nth(1)
            .unwrap_or_else(|| panic!("FRAC {frac}: no safe FRACTION named: {err}"))
            .trim_end_matches(')')
            .parse()
            .unwrap();
        assert!(safe > 0.05 && safe < 1.0, "FRAC {frac}: {err}");
        blockdem::scenes::run_deck_on(&deck(safe), Target::Cpu.backend()).unwrap_or_else(|e| panic!("the named FRACTION {safe} fails too: {e}"));
        let json = blockdem::udec::output::state_json::state_json(&m).to_string();
        assert!(!json.contains("null") && !json.contains("NaN"), "FRAC {frac}: non-finite state kept");
    }
    // A failure that is not the time step's (a projectile too fast at the default FRACTION, no
    // contact to make FRACTION unstable) names no FRACTION.
    let err = blockdem::scenes::run_deck_on(
        "START\nPROP MAT=1 D=2000 KN=1E6 KS=1E6\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 3,0 3,1 4,1 4,0\nFIX 2 5 0 1\nVELOCITY 0 1 0 1 200 0\nCYCLE 100\n",
        Target::Cpu.backend(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("moves too fast") && !err.contains("largest safe"), "{err}");
}

/// An energy growth names the largest safe FRACTION where the last good state gives an estimate,
/// and names none (not "about NaN") where it has no contact carrying force: the growth came with
/// contacts made after it, found by the fuzzing of random decks.
#[test]
fn an_energy_growth_names_a_safe_fraction_only_where_one_was_estimated() {
    let growth = |safe_frac: f64| CycleError::EnergyGrowth { cycle: 200, energy: 8.2e4, budget: 1.4e4, frac: 2.55, safe_frac }.to_string();
    assert!(growth(0.3).ends_with("lower FRACTION (now 2.55; the largest safe value is about 0.30)"), "{}", growth(0.3));
    for none in [f64::NAN, 0.0, f64::INFINITY] {
        let text = growth(none);
        assert!(text.ends_with("lower FRACTION (now 2.55)") && !text.contains("NaN") && !text.contains("largest safe"), "{text}");
    }
}

/// A GPU backend whose adapter cannot hold the model: refuses every run before any cycle.
struct TooSmallAdapter(std::rc::Rc<std::cell::Cell<u32>>);

impl blockdem::udec::backend::Backend for TooSmallAdapter {
    fn describe(&self) -> String {
        "gpu (a small adapter)".into()
    }
    fn run_into(&mut self, _: &mut Model, _: u64, _: &mut dyn FnMut(u64) -> bool, report: &mut blockdem::udec::backend::CycleReport) -> Result<(), CycleError> {
        self.0.set(self.0.get() + 1);
        // (As a start that counted its detection before its upload failed.)
        report.topology_updates += 1000;
        Err(CycleError::DoesNotFit("GPU set-up: the corners buffer would need more than one binding may hold".into()))
    }
}

#[test]
fn auto_goes_on_on_the_cpu_when_the_model_is_past_the_gpus_limits() {
    // `--backend auto` wraps the GPU in GpuOrCpu: a run the GPU refuses as too large runs on the
    // CPU backend, as if the CPU had been chosen, and so does every later run (the GPU is not
    // asked again). Any other failure stays a failure.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0,1 0,2 1,2 1,1\nFIX -1 2 0 1\nGRAVITY 0 -10\nCYCLE 300\nCYCLE 200\n";
    let asked = std::rc::Rc::new(std::cell::Cell::new(0));
    let auto = blockdem::udec::backend::GpuOrCpu::new(Box::new(TooSmallAdapter(asked.clone())), || Box::new(blockdem::udec::cpu::CpuBackend::new()));
    let m = blockdem::scenes::run_deck_on(deck, Box::new(auto)).unwrap();
    let cpu = blockdem::scenes::run_deck_on(deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    assert!(m == cpu && m.cycle == 500, "the CPU's run");
    assert_eq!(asked.get(), 1, "the GPU is asked once");
    let err = blockdem::scenes::run_deck_on(deck, Box::new(TooSmallAdapter(asked.clone()))).unwrap_err();
    assert!(matches!(err, RunError::Numerical { failure: CycleError::DoesNotFit(_), .. }), "{err:?}");
    // The report of the run that went on on the CPU is the CPU's alone: what the GPU's try
    // added before it refused is taken back.
    use blockdem::udec::backend::Backend;
    let start = blockdem::scenes::run_deck_on(&deck.replace("CYCLE 300\nCYCLE 200\n", "CYCLE 1\n"), Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    assert!(start.timestep > 0.0);
    let mut auto = blockdem::udec::backend::GpuOrCpu::new(Box::new(TooSmallAdapter(asked.clone())), || Box::new(blockdem::udec::cpu::CpuBackend::new()));
    let (mut a, mut c) = (start.clone(), start);
    let on_auto = auto.run(&mut a, 50, &mut |_| true).unwrap();
    let on_cpu = blockdem::udec::cpu::CpuBackend::new().run(&mut c, 50, &mut |_| true).unwrap();
    assert_eq!(on_auto, on_cpu);
}

/// The overlap failure names the contact that overlaps most, not the first one past the limit
/// (which may be barely past it while another is far in): the message must not understate how far
/// the blocks went into each other. Both backends build their error with `CycleError::overlap`.
#[test]
fn an_overlap_failure_names_the_deepest_contact() {
    // Three blocks in a row touching: contacts between 1–2 and 2–3.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 1,0 1,1 2,1 2,0\n\
                BLOCK 2,0 2,1 3,1 3,0\nFIX 0 3 0 1\nCYCLE 1\n";
    let mut m = blockdem::scenes::run_deck_on(deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    assert!(m.contacts.len() >= 2);
    let last = m.contacts.len() - 1;
    let pair = |m: &Model, k: usize| (m.blocks[m.contacts[k].block1 as usize].id, m.blocks[m.contacts[k].block2 as usize].id);
    m.contacts[0].gap = -0.06;
    m.contacts[last].gap = -0.09;
    match CycleError::overlap(&m, 0, 0.05) {
        CycleError::Overlap { overlap, limit, block1, block2, .. } => {
            assert_eq!((overlap, limit), (0.09, 0.05));
            assert_eq!((block1, block2), pair(&m, last));
        }
        e => panic!("{e}"),
    }
    // With one contact past the limit, that one.
    m.contacts[last].gap = 0.0;
    match CycleError::overlap(&m, 0, 0.05) {
        CycleError::Overlap { overlap, .. } => assert_eq!(overlap, 0.06),
        e => panic!("{e}"),
    }
}

/// A FRACTION far past the stable limit is named as typed (1e300, not 301 digits) with the safe
/// value to two significant digits.
#[test]
fn a_huge_fraction_is_named_short_with_the_safe_value() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nFRAC 1e300\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\n\
                FIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 50\n";
    let commands = blockdem::udec::deck::parse_deck(deck, "<scene>").unwrap();
    let options = RunOptions { out_dir: std::env::temp_dir().join("blockdem-failures"), ..Default::default() };
    let mut exec = Executor::new(Box::new(blockdem::udec::cpu::CpuBackend::new()), Box::new(std::io::sink()), options, "<scene>");
    let e = exec.run(&commands).unwrap_err().to_string();
    assert!(e.contains("(FRACTION 1e300 is above the stable limit of this model") && e.contains("the largest safe value is about 0.38)"), "{e}");
    assert!(e.len() < 400, "{e}");
    assert_eq!(blockdem::udec::output::format::fmt_short(0.1), "0.1");
    assert_eq!(blockdem::udec::output::format::fmt_short(5.0), "5");
    assert_eq!(blockdem::udec::output::format::fmt_short(1e-7), "1e-7");
}

/// Issue 27 item 9: the energy-growth failure prints its numbers as the log does and a bisected
/// FRACTION to four digits (it printed "now 0.6297873064661311"), and a negative energy put in
/// (blocks thrown up against gravity: its work is negative) is shown as the zero the check counts,
/// with why.
#[test]
fn the_energy_growth_message_formats_its_numbers_and_explains_a_negative_budget() {
    let e = CycleError::EnergyGrowth { cycle: 100, energy: 20.621, budget: -1127.7, frac: 0.6297873064661311, safe_frac: 0.38 }.to_string();
    assert!(e.contains("kinetic + strain energy 2.062E+01 exceeds the energy put in, 0.000E+00"), "{e}");
    assert!(e.contains("counted as zero: it is -1.128E+03 because the blocks moved against gravity"), "{e}");
    assert!(e.contains("(now 0.6298; the largest safe value is about 0.38)"), "{e}");
    let e = CycleError::EnergyGrowth { cycle: 100, energy: 20.621, budget: 3.5, frac: 0.1, safe_frac: f64::NAN }.to_string();
    assert!(e.contains("exceeds the energy put in, 3.500E+00 (the energy at the start") && e.contains("(now 0.1)") && !e.contains("counted as zero"), "{e}");
}
