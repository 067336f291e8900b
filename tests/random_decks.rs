//! Random decks of valid-looking commands on every backend: nothing panics, every error names
//! the deck's file and a line of it, and whatever stops a run leaves a finite model (the last
//! good state after a numerical failure). The parser's own fuzzing (random text, token soup) is
//! in tests/deck_parser.rs; these decks parse, and go on to build, split, delete, load, damp,
//! cycle, plot (any window and view) and write out blocks with ordinary and extreme values
//! (1e-300 … 1e300), which is where the executor and the backends meet input nobody wrote a
//! test for. Found this way and fixed: an energy growth that named "about NaN" as the safe
//! FRACTION, blocks given overlapping reported as driven through each other, and damping the
//! f32 kernels cannot hold going non-finite.

mod common;

use blockdem::exec::{Executor, RunError, RunOptions};
use common::{every_backend, Target};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

every_backend!(random_decks_never_panic_and_stop_with_a_line_and_a_finite_model);

/// A positive value: mostly ordinary, sometimes at the ends of f64 and f32.
fn positive() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (0.01f64..5.0).prop_map(|v| format!("{v:.3}")),
        1 => Just("1E-30".to_string()),
        1 => Just("1E30".to_string()),
        1 => Just("1E-300".to_string()),
        1 => Just("1E300".to_string()),
        1 => Just("1E9".to_string()),
    ]
}

/// Any value for loads, velocities and gravity.
fn any_value() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (-30.0f64..30.0).prop_map(|v| format!("{v:.3}")),
        1 => Just("0".to_string()),
        1 => Just("1E30".to_string()),
        1 => Just("-1E300".to_string()),
        1 => Just("1E300".to_string()),
    ]
}

/// A non-empty range x1 x2 y1 y2 around the scene.
fn range() -> impl Strategy<Value = String> {
    (-2.0f64..10.0, 0.05f64..8.0, -1.0f64..6.0, 0.05f64..5.0).prop_map(|(x, w, y, h)| format!("{x:.2} {:.2} {y:.2} {:.2}", x + w, y + h))
}

/// A BLOCK: a rectangle, a regular polygon (clockwise, as the manual's decks give them), or
/// corners on a coarse grid (often self-crossing or degenerate).
fn block() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => (0.0f64..8.0, 1.0f64..4.0, 0.05f64..2.0, 0.05f64..1.0)
            .prop_map(|(x, y, w, h)| format!("BLOCK {x:.2},{y:.2} {x:.2},{:.2} {:.2},{:.2} {:.2},{y:.2}", y + h, x + w, y + h, x + w)),
        2 => (0.0f64..8.0, 1.0f64..5.0, 0.05f64..2.0, 3usize..8, 0.0f64..std::f64::consts::TAU).prop_map(|(cx, cy, r, n, a0)| {
            let corners: Vec<String> = (0..n)
                .map(|i| {
                    let a = a0 - i as f64 * std::f64::consts::TAU / n as f64;
                    format!("{:.3},{:.3}", cx + r * a.cos(), cy + r * a.sin())
                })
                .collect();
            format!("BLOCK {}", corners.join(" "))
        }),
        1 => prop::collection::vec((-6i32..9, 0i32..7), 3..7)
            .prop_map(|v| format!("BLOCK {}", v.iter().map(|(x, y)| format!("{x},{y}")).collect::<Vec<_>>().join(" "))),
    ]
}

fn command() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => block(),
        3 => (-1.0f64..9.0, -1.0f64..6.0, -1.0f64..9.0, -1.0f64..6.0).prop_map(|(a, b, c, d)| format!("SPLIT {a:.2} {b:.2} {c:.2} {d:.2}")),
        1 => range().prop_map(|r| format!("DELETE {r}")),
        1 => range().prop_map(|r| format!("FIX {r}")),
        1 => range().prop_map(|r| format!("FREE {r}")),
        1 => (range(), any_value(), any_value()).prop_map(|(r, fx, fy)| format!("LOAD {r} {fx} {fy}")),
        1 => (range(), any_value(), any_value(), any_value()).prop_map(|(r, vx, vy, w)| format!("VELOCITY {r} {vx} {vy} {w}")),
        1 => (any_value(), any_value()).prop_map(|(gx, gy)| format!("GRAV {gx} {gy}")),
        1 => (0.0f64..2.0, positive(), prop_oneof![Just(""), Just(" MASS"), Just(" STIFF")]).prop_map(|(f, hz, m)| format!("DAMP {f:.2} {hz}{m}")),
        1 => (0.01f64..3.0).prop_map(|f| format!("FRAC {f:.2}")),
        1 => positive().prop_map(|d| format!("ROUND {d}")),
        1 => (1u32..3, positive(), positive(), positive(), positive(), positive(), positive())
            .prop_map(|(m, d, kn, ks, f, c, tf)| format!("PROP MAT={m} D={d} KN={kn} KS={ks} F={f} C={c} TF={tf}")),
        1 => (range(), 1u32..3, 1u32..3).prop_map(|(r, m, k)| format!("CHANGE {r} MAT {m} CONS {k}")),
        3 => (0u32..150).prop_map(|n| format!("CYCLE {n}")),
        1 => Just("PRINT BLOCKS CONTACTS ENERGY CORNERS".to_string()),
        1 => range().prop_map(|r| format!("LINK {r}")),
        1 => Just("SAVE".to_string()),
        1 => Just("RESTART".to_string()),
        1 => prop_oneof![range(), Just("-1E30 1E30 -1E30 1E30".to_string()), Just("0 1E-9 0 1E-9".to_string())].prop_map(|r| format!("WINDOW {r}")),
        1 => (0u32..2500, 1u32..2500, 0u32..2500, 1u32..2500).prop_map(|(x, w, y, h)| format!("VIEW {x} {} {y} {}", x + w, y + h)),
        1 => prop_oneof![Just("PLOT"), Just("PLOT NOFIX VEL"), Just("PLOT NC"), Just("VTK"), Just("DUMP 0 5"), Just("PRINT LIST")].prop_map(String::from),
    ]
}

fn random_decks_never_panic_and_stop_with_a_line_and_a_finite_model(t: &Target) {
    // Each case builds its backend (a device on the GPU): fewer cases there.
    let cases = if matches!(t, Target::Cpu) { 300 } else { 25 };
    let out = std::env::temp_dir().join(format!("blockdem-random-decks-{}-{}", std::process::id(), t.name().replace(' ', "_")));
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let result = runner.run(&prop::collection::vec(command(), 0..25), |commands| {
        let deck = format!(
            "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 8,1 8,0\nFIX 0 8 0 1\nGRAV 0 -10\n{}\nCYCLE 50\nSTOP\n",
            commands.join("\n")
        );
        let lines = deck.lines().count();
        let parsed = blockdem::deck::parse_deck(&deck, "random.dat").map_err(|e| TestCaseError::fail(format!("the deck does not parse: {e}")))?;
        let _ = std::fs::remove_dir_all(&out);
        let options = RunOptions { out_dir: out.clone(), ..Default::default() };
        let mut exec = Executor::new(t.backend(), Box::new(std::io::sink()), options, "random.dat");
        if let Err(e) = exec.run(&parsed) {
            let text = e.to_string();
            let line = match &e {
                RunError::Input(d) => d.line,
                RunError::Unsupported { line, .. } | RunError::Numerical { line, .. } | RunError::Command { line, .. } => *line,
                RunError::Interrupted { .. } => return Err(TestCaseError::fail("interrupted without a signal")),
            };
            prop_assert!(text.starts_with("random.dat:") && (1..=lines).contains(&line), "{text}");
        }
        for b in &exec.model.blocks {
            let state = b.centroid.iter().chain(&b.velocity).chain([&b.angular_velocity, &b.rotation]);
            prop_assert!(state.into_iter().all(|x| x.is_finite()), "block {} not finite: {:?}", b.id, b);
        }
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&out);
    if let Err(e) = result {
        panic!("on {}: {e}", t.name());
    }
}
