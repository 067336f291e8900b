//! Random decks of valid-looking commands on every backend: nothing panics, every error names
//! the deck's file and a line of it, and whatever stops a run leaves a finite model (the last
//! good state after a numerical failure). The parser's own fuzzing (random text, token soup) is
//! in tests/suite/deck_parser.rs; these decks parse, and go on to build, split, delete, load, damp,
//! cycle, plot (any window and view) and write out blocks with ordinary and extreme values
//! (1e-300 … 1e300), which is where the executor and the backends meet input nobody wrote a
//! test for; a quarter of the decks each make simply-deformable blocks, zoned blocks or fluid
//! domains (`Kind`), with the joint, Griffith and flow properties. D3's are in
//! tests/suite/d3_random_decks.rs. Found this way and fixed: an energy growth that named "about NaN" as the safe
//! FRACTION, blocks given overlapping reported as driven through each other, and damping the
//! f32 kernels cannot hold going non-finite.

use crate::common;

use blockdem::udec::exec::{Executor, RunError, RunOptions};
use common::{every_backend, Target};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

every_backend!(random_decks_never_panic_and_stop_with_a_line_and_a_finite_model, decks_at_any_scale_between_cycles_stop_with_a_line_and_a_restartable_model);

/// Runs `deck` (named `file`) on `t` with its outputs in `out`; a run that stops must say so with
/// the file and a line of the deck. Returns the executor, whose model the caller checks, and
/// whether the deck ran to its end.
fn run_naming_its_line(t: &Target, deck: &str, file: &str, out: &std::path::Path) -> Result<(Executor<'static>, bool), TestCaseError> {
    let lines = deck.lines().count();
    // The deck being run, where a hung campaign (or one that crashed inside the run) leaves it
    // to be read; gone once the run returns.
    let running = std::env::temp_dir().join(format!("blockdem-running-{}-{}-{file}", std::process::id(), t.name().replace(' ', "_")));
    let _ = std::fs::write(&running, deck);
    let parsed = blockdem::udec::deck::parse_deck(deck, file).map_err(|e| TestCaseError::fail(format!("the deck does not parse: {e}")))?;
    let _ = std::fs::remove_dir_all(out);
    let options = RunOptions { out_dir: out.to_path_buf(), ..Default::default() };
    let mut exec = Executor::new(t.backend(), Box::new(std::io::sink()), options, file);
    let result = exec.run(&parsed);
    let _ = std::fs::remove_file(&running);
    if let Err(e) = result {
        let text = e.to_string();
        let line = match &e {
            RunError::Input(d) => d.line,
            RunError::Unsupported { line, .. } | RunError::Numerical { line, .. } | RunError::Command { line, .. } => *line,
            RunError::Interrupted { .. } => return Err(TestCaseError::fail("interrupted without a signal")),
        };
        prop_assert!(text.starts_with(&format!("{file}:")) && (1..=lines).contains(&line), "{text}");
        // A file the deck's own SAVE wrote restarts.
        prop_assert!(!text.contains("is inconsistent"), "a SAVE that RESTART refuses: {text}\n{deck}");
        return Ok((exec, false));
    }
    Ok((exec, true))
}

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
        1 => (range(), 1u32..3, 1u32..6).prop_map(|(r, m, k)| format!("CHANGE {r} MAT {m} CONS {k}")),
        3 => (0u32..150).prop_map(|n| format!("CYCLE {n}")),
        1 => Just("PRINT BLOCKS CONTACTS ENERGY CORNERS DOMAINS DLIST".to_string()),
        1 => Just("PRINT FLOWS".to_string()),
        1 => prop_oneof![Just("LINK 3.5 1.5 4 0.5".to_string()), (-1.0f64..9.0, -1.0f64..6.0).prop_map(|(x, y)| format!("LINK {x:.2} {y:.2} 4 0.5"))],
        1 => Just("SAVE".to_string()),
        // (A RESTART before any SAVE stops the deck there: mostly after one.)
        1 => prop_oneof![4 => Just("SAVE\nRESTART"), 1 => Just("RESTART")].prop_map(String::from),
        1 => prop_oneof![range(), Just("-1E30 1E30 -1E30 1E30".to_string()), Just("0 1E-9 0 1E-9".to_string())].prop_map(|r| format!("WINDOW {r}")),
        1 => (0u32..2500, 1u32..2500, 0u32..2500, 1u32..2500).prop_map(|(x, w, y, h)| format!("VIEW {x} {} {y} {}", x + w, y + h)),
        1 => prop_oneof![Just("PLOT"), Just("PLOT NOFIX VEL"), Just("PLOT NC"), Just("PLOT ZONES PRESSURE"), Just("VTK"), Just("DUMP 0 5"), Just("PRINT LIST")].prop_map(String::from),
    ]
}

/// What a random deck's scene holds besides rigid blocks: each gets its own set-up and commands
/// (a command of another kind, PFIX without FLUID or GENERATE over rigid blocks, would only stop
/// the deck at that line, as `bad_input` tests already).
#[derive(Clone, Copy, Debug)]
enum Kind {
    Rigid,
    /// Simply-deformable blocks (CHANGE … SDEF), joint stiffnesses and Griffith's strengths.
    Sdef,
    /// Fully-deformable blocks, each zoned where it is made (CHANGE … FDEF, then GENERATE).
    Fdef,
    /// Fluid in the domains, with the flow laws, PFIX and PFREE.
    Fluid,
}

/// A range that holds most blocks above the base, or a random one.
fn wide_range() -> impl Strategy<Value = String> {
    prop_oneof![3 => Just("-1 10 0.5 7".to_string()), 1 => range()]
}

/// The commands of `kind`, besides `command`'s.
fn kind_command(kind: Kind) -> BoxedStrategy<String> {
    let joints = (1u32..3, positive(), positive(), positive(), positive(), positive())
        .prop_map(|(m, k, g, jkn, jks, tf)| format!("PROP MAT={m} K={k} G={g} JKN={jkn} JKS={jks} TF={tf}"));
    match kind {
        Kind::Rigid => Just("PRINT LIST".to_string()).boxed(),
        Kind::Sdef => prop_oneof![
            3 => (wide_range(), prop_oneof![Just(""), Just(" MAT 1"), Just(" CONS 4"), Just(" CONS 3")]).prop_map(|(r, m)| format!("CHANGE {r} SDEF{m}")),
            1 => joints,
            1 => (0.0f64..1.0, positive()).prop_map(|(f, hz)| format!("DAMP {f:.2} {hz} INTERNAL")),
        ]
        .boxed(),
        Kind::Fdef => prop_oneof![
            // A zoned block is zoned where it is made: CHANGE … FDEF over a range, GENERATE over
            // the same range (AUTO, coarse enough for a test), or by hand over one new square.
            3 => (wide_range(), prop_oneof![Just("0.4"), Just("0.7"), Just("1.5"), Just("1E300")])
                .prop_map(|(r, a)| format!("CHANGE {r} FDEF\nGEN {r} AUTO {a}")),
            1 => (0.0f64..7.0, 1.5f64..4.0).prop_map(|(x, y)| {
                let (x1, y1) = (x + 1.0, y + 0.5);
                format!(
                    "BLOCK {x:.2},{y:.2} {x:.2},{y1:.2} {x1:.2},{y1:.2} {x1:.2},{y:.2}\nCHANGE {:.2} {:.2} {:.2} {:.2} FDEF\n\
                     GEN {:.2} {:.2} {:.2} {:.2} MANUAL GRIDPOINTS ({x:.2},{y:.2}) ({x1:.2},{y:.2}) ({x1:.2},{y1:.2}) ({x:.2},{y1:.2}) ZONES (1,2,3) (1,3,4)",
                    x + 0.4, x + 0.6, y + 0.2, y + 0.3, x - 0.1, x1 + 0.1, y - 0.1, y1 + 0.1)
            }),
            1 => Just("PLOT ZONES".to_string()),
        ]
        .boxed(),
        Kind::Fluid => prop_oneof![
            2 => (prop_oneof![Just("OUTER".to_string()), (1u32..12).prop_map(|d| d.to_string()), (0.0f64..8.0, 0.0f64..5.0).prop_map(|(x, y)| format!("AT {x:.2} {y:.2}"))], any_value())
                .prop_map(|(d, p)| format!("PFIX {d} {p}")),
            1 => prop_oneof![Just("OUTER".to_string()), (1u32..5).prop_map(|d| d.to_string())].prop_map(|d| format!("PFREE {d}")),
            // (Flow laws of ordinary size, and now and then a conductance past f64: its step
            // underflows, or its flows overflow where the CYCLE sets out, which the run refuses
            // there; see tests/suite/fluid.rs `a_fluid_step_that_underflows_is_refused_before_any_cycle`.)
            1 => (1u32..3, 0.01f64..5.0, prop_oneof![4 => Just(1e-7), 4 => Just(1e-3), 4 => Just(1.0), 1 => Just(1e300), 1 => Just(1e200)], 1e-5f64..1e-2, 1e-6f64..1e-4)
                .prop_map(|(m, jp, cp, a0, ar)| format!("PROP MAT={m} JPERM={jp:.3} CPERM={cp:e} AZERO={a0:e} ARES={ar:e}")),
            1 => joints,
            1 => Just("PRINT FLOWS DOMAINS DLIST".to_string()),
            1 => Just("PLOT PRESSURE".to_string()),
            1 => positive().prop_map(|a| format!("SET DAMIN {a}")),
        ]
        .boxed(),
    }
}

/// A deck of `kind`: its set-up, then `command`s and `kind_command`s.
fn deck_of(kind: Kind) -> impl Strategy<Value = String> {
    let setup = match kind {
        Kind::Rigid => "",
        // A block on the base for the first CHANGE to find.
        Kind::Fdef => "BLOCK 3,1 3,2 4,2 4,1\n",
        Kind::Sdef => "BLOCK 3,1 3,2 4,2 4,1\nPROP MAT=1 TF=1E5\nCHANGE -1 10 0.5 7 SDEF\n",
        Kind::Fluid => {
            "FLUID 1000 2E5\nPROP MAT=1 CPERM=1E-7 JPERM=100 AZERO=1E-4 ARES=1E-5\nPROP MAT=2 CPERM=1E-7 JPERM=100 AZERO=1E-4 ARES=1E-5\nPFIX OUTER 0\n"
        }
    };
    prop::collection::vec(prop_oneof![3 => command(), 1 => kind_command(kind)], 0..25).prop_map(move |commands| {
        format!(
            "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5 K=1E9 G=1E9\nROUND 0.05\nBLOCK 0,0 0,1 8,1 8,0\nFIX 0 8 0 1\nGRAV 0 -10\n{setup}{}\nCYCLE 50\nSTOP\n",
            commands.join("\n")
        )
    })
}

/// The number of cases: `default`, or BLOCKDEM_FUZZ_CASES for a long campaign.
fn fuzz_cases(default: u32) -> u32 {
    match std::env::var("BLOCKDEM_FUZZ_CASES") {
        Ok(v) => v.parse().unwrap_or_else(|_| panic!("BLOCKDEM_FUZZ_CASES must be a count of cases, found {v:?}")),
        Err(_) => default,
    }
}

fn random_decks_never_panic_and_stop_with_a_line_and_a_finite_model(t: &Target) {
    // Each case builds its backend (a device on the GPU): fewer cases there. A long campaign
    // (not CI's) sets BLOCKDEM_FUZZ_CASES; proptest's PROPTEST_RNG_SEED replays one.
    let cases = fuzz_cases(if matches!(t, Target::Cpu) { 300 } else { 25 });
    let out = std::env::temp_dir().join(format!("blockdem-random-decks-{}-{}", std::process::id(), t.name().replace(' ', "_")));
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    // How many decks ran to their end, and of those how many with simply- and fully-deformable
    // blocks and with fluid: a generator whose decks all stop at an early error tests little.
    let ended = std::sync::atomic::AtomicUsize::new(0);
    let deep: [std::sync::atomic::AtomicUsize; 3] = Default::default();
    let decks = prop_oneof![deck_of(Kind::Rigid), deck_of(Kind::Sdef), deck_of(Kind::Fdef), deck_of(Kind::Fluid)];
    let result = runner.run(&decks, |deck| {
        let (exec, to_the_end) = run_naming_its_line(t, &deck, "random.dat", &out)?;
        if to_the_end {
            ended.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let m = &exec.model;
            let kinds = [!m.sdef.is_empty(), !m.fdef.is_empty(), m.fluid.is_some()];
            for (n, k) in deep.iter().zip(kinds) {
                n.fetch_add(usize::from(k), std::sync::atomic::Ordering::Relaxed);
            }
        }
        for b in &exec.model.blocks {
            let state = b.centroid.iter().chain(&b.velocity).chain([&b.angular_velocity, &b.rotation]);
            prop_assert!(state.into_iter().all(|x| x.is_finite()), "block {} not finite: {:?}", b.id, b);
        }
        // Whatever the deck left is a model RESTART takes back (a SAVE of it would restart).
        prop_assert!(exec.model.validate().is_ok(), "the model cannot be restarted: {:?}\n{deck}", exec.model.validate());
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&out);
    if let Err(e) = result {
        panic!("on {}: {e}", t.name());
    }
    let count = |a: &std::sync::atomic::AtomicUsize| a.load(std::sync::atomic::Ordering::Relaxed);
    let [sdef, fdef, fluid] = deep.each_ref().map(count);
    eprintln!("{}: {} of {cases} decks ran to their end ({sdef} with SDEF blocks, {fdef} with FDEF, {fluid} with fluid)", t.name(), count(&ended));
    // (About a third run to their end, a tenth of those zoned; the GPUs' 25 decks are too few to
    // hold to this.)
    if cases >= 100 {
        assert!(count(&ended) as u32 >= cases / 5 && sdef > 0 && fdef > 0 && fluid > 0, "too few decks reach the engines");
    }
}

/// Where the scene of `scaled_deck` lies: lengths are `size` times the unit scene's, offset by
/// `origin` (blocks of a micrometre, blocks a million or 10¹² m from the origin).
#[derive(Clone, Copy, Debug)]
struct Scale {
    size: f64,
    origin: f64,
}

impl Scale {
    /// A coordinate of the unit scene, written in full (f64's shortest round trip, no exponent).
    fn x(&self, u: f64) -> String {
        format!("{}", self.origin + self.size * u)
    }
    fn len(&self, u: f64) -> String {
        format!("{}", self.size * u)
    }
    fn range(&self, x1: f64, x2: f64, y1: f64, y2: f64) -> String {
        format!("{} {} {} {}", self.x(x1), self.x(x2), self.x(y1), self.x(y2))
    }
}

fn scale() -> impl Strategy<Value = Scale> {
    prop_oneof![
        6 => Just(Scale { size: 1.0, origin: 0.0 }),
        1 => Just(Scale { size: 1e-6, origin: 0.0 }),
        1 => Just(Scale { size: 1.0, origin: 1e6 }),
        1 => Just(Scale { size: 1.0, origin: 1e12 }),
        1 => Just(Scale { size: 1e3, origin: -1e6 }),
    ]
}

/// A value for loads, velocities, gravity and damping, with the ends of f64.
fn extreme() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (-30.0f64..30.0).prop_map(|v| format!("{v:.3}")),
        1 => Just("0".to_string()),
        1 => Just("1E-300".to_string()),
        1 => Just("-1E308".to_string()),
        1 => Just("1E308".to_string()),
        1 => Just("1E154".to_string()),
    ]
}

/// The commands of `command`, and those that meet the executor between cycles: SAVE and a
/// RESTART of it (or of a file never written), DELETE, FIX and FREE of everything, materials
/// without PROPERTY, slivers, ROUND past the blocks, the ends of LOAD, VELOCITY, DAMPING,
/// GRAVITY, WINDOW, VIEW, DUMP, and LINK at odd points.
fn scaled_command(s: Scale) -> impl Strategy<Value = String> {
    let r = move |(x, w, y, h): (f64, f64, f64, f64)| s.range(x, x + w, y, y + h);
    let any_range = (-2.0f64..10.0, 0.05f64..8.0, -1.0f64..6.0, 0.05f64..5.0).prop_map(r);
    let everything = Just("-1E300 1E300 -1E300 1E300".to_string());
    let range = prop_oneof![4 => any_range, 1 => everything];
    prop_oneof![
        3 => (0.0f64..8.0, 1.0f64..4.0, 0.05f64..2.0, 0.05f64..1.0).prop_map(move |(x, y, w, h)| format!(
            "BLOCK {},{} {},{} {},{} {},{}", s.x(x), s.x(y), s.x(x), s.x(y + h), s.x(x + w), s.x(y + h), s.x(x + w), s.x(y))),
        1 => (0.0f64..8.0, 1.0f64..4.0, prop_oneof![Just(1e-9), Just(1e-6), Just(1e-3)]).prop_map(move |(x, y, t)| format!(
            "BLOCK {},{} {},{} {},{} {},{}", s.x(x), s.x(y), s.x(x), s.x(y + t), s.x(x + 2.0), s.x(y + t), s.x(x + 2.0), s.x(y))),
        3 => (-1.0f64..9.0, -1.0f64..6.0, -1.0f64..9.0, -1.0f64..6.0, prop_oneof![Just(""), Just(" MAT 7"), Just(" MAT 1 CONS 2")])
            .prop_map(move |(a, b, c, d, m)| format!("SPLIT {} {} {} {}{m}", s.x(a), s.x(b), s.x(c), s.x(d))),
        1 => range.clone().prop_map(|r| format!("DELETE {r}")),
        1 => range.clone().prop_map(|r| format!("FIX {r}")),
        1 => range.clone().prop_map(|r| format!("FREE {r}")),
        1 => (range.clone(), extreme(), extreme()).prop_map(|(r, fx, fy)| format!("LOAD {r} {fx} {fy}")),
        1 => (range.clone(), extreme(), extreme(), extreme()).prop_map(|(r, vx, vy, w)| format!("VELOCITY {r} {vx} {vy} {w}")),
        1 => (extreme(), extreme()).prop_map(|(gx, gy)| format!("GRAV {gx} {gy}")),
        1 => Just("GRAV 0 0".to_string()),
        1 => (prop_oneof![Just("0"), Just("0.5"), Just("1E300"), Just("1E-300")], prop_oneof![Just("1E-300"), Just("1E300"), Just("1E308"), Just("5")],
              prop_oneof![Just(""), Just(" MASS"), Just(" STIFF"), Just(" INTERNAL")])
            .prop_map(|(f, hz, m)| format!("DAMP {f} {hz}{m}")),
        1 => prop_oneof![Just("1E-30"), Just("0.1"), Just("0.9"), Just("1E300")].prop_map(|f| format!("FRAC {f}")),
        2 => prop_oneof![(0.001f64..5.0).prop_map(move |d| s.len(d)), Just("1E300".to_string()), Just("1E-300".to_string())].prop_map(|d| format!("ROUND {d}")),
        1 => (1u32..21, positive(), positive(), positive()).prop_map(|(m, d, kn, ks)| format!("PROP MAT={m} D={d} KN={kn} KS={ks} F=0.5")),
        1 => (range.clone(), 1u32..21, 1u32..3).prop_map(|(r, m, k)| format!("CHANGE {r} MAT {m} CONS {k}")),
        4 => prop_oneof![Just(0u32), Just(1), 2u32..200].prop_map(|n| format!("CYCLE {n}")),
        1 => Just("PRINT BLOCKS CONTACTS ENERGY CORNERS LIST DOMAINS DLIST".to_string()),
        1 => prop_oneof![
            (-1.0f64..9.0, -1.0f64..6.0, -1.0f64..9.0, -1.0f64..6.0).prop_map(move |(a, b, c, d)| format!("LINK {} {} {} {}", s.x(a), s.x(b), s.x(c), s.x(d))),
            Just(format!("LINK {} {} {} {}", s.x(0.0), s.x(0.0), s.x(8.0), s.x(1.0))),
            Just("LINK 1E300 1E300 -1E300 -1E300".to_string()),
            Just(format!("LINK {} {} {} {}", s.x(4.0), s.x(0.5), s.x(4.0), s.x(0.5))),
        ],
        2 => Just("SAVE a.sav".to_string()),
        2 => Just("RESTART a.sav".to_string()),
        1 => Just("RESTART never.sav".to_string()),
        1 => prop_oneof![
            (-2.0f64..10.0, 0.05f64..8.0, -1.0f64..6.0, 0.05f64..5.0).prop_map(r),
            Just("-1E300 1E300 -1E300 1E300".to_string()),
            Just("-1E308 1E308 -1E308 1E308".to_string()),
            Just("0 1E-300 0 1E-300".to_string()),
            Just(s.range(1.0, 1.0 + 1e-12 + 1e-14 * s.origin.abs() / s.size, 1.0, 1.0 + 1e-12 + 1e-14 * s.origin.abs() / s.size)),
        ].prop_map(|r| format!("WINDOW {r}")),
        1 => prop_oneof![Just("VIEW 0 1 0 1"), Just("VIEW 0 2000 0 1400"), Just("VIEW 0 2147483647 0 2147483647"), Just("VIEW 1999 2000 1399 1400"), Just("VIEW 5000 6000 5000 6000")]
            .prop_map(String::from),
        2 => prop_oneof![Just("PLOT"), Just("PLOT NOFIX VEL"), Just("PLOT NC ZONES"), Just("VTK"), Just("DUMP"), Just("DUMP 0 2147483647"), Just("DUMP 5 0"), Just("PRINT LIST")]
            .prop_map(String::from),
        // The later block kinds and the fluid at this scale: SDEF blocks, blocks zoned where they
        // are made, fluid with the outer domain held.
        1 => Just(format!("CHANGE {} SDEF", s.range(-1.0, 10.0, 0.5, 7.0))),
        1 => prop_oneof![Just(0.3), Just(0.7), Just(1.5)].prop_map(move |a| {
            let r = s.range(-1.0, 10.0, 0.5, 7.0);
            format!("CHANGE {r} FDEF\nGEN {r} AUTO {}", s.len(a))
        }),
        1 => Just("FLUID 1000 2E5\nPFIX OUTER 0".to_string()),
        1 => Just("PRINT DOMAINS FLOWS".to_string()),
    ]
}

/// A deck of `scaled_command`s on a base at `scale`.
fn scaled_deck() -> impl Strategy<Value = String> {
    scale().prop_flat_map(|s| {
        (prop::collection::vec(scaled_command(s), 0..30)).prop_map(move |commands| {
            format!(
                // (Moduli and flow laws for the decks that make SDEF or zoned blocks or fluid.)
                "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5 K=1E9 G=1E9 CPERM=1E-7 JPERM=100 AZERO=1E-4 ARES=1E-5\n\
                 ROUND {}\nBLOCK {},{} {},{} {},{} {},{}\nFIX {}\nGRAV 0 -10\n{}\nCYCLE 50\nSTOP\n",
                s.len(0.05),
                s.x(0.0),
                s.x(0.0),
                s.x(0.0),
                s.x(1.0),
                s.x(8.0),
                s.x(1.0),
                s.x(8.0),
                s.x(0.0),
                s.range(0.0, 8.0, 0.0, 1.0),
                commands.join("\n")
            )
        })
    })
}

/// The decks of `scaled_deck` on every backend: nothing panics or runs on without end, every
/// error names the deck's file and a line of it, and the model the run ends with (the last good
/// state after a numerical failure) is one RESTART takes back: it passes `Model::validate`, saves
/// and loads, and its state JSON holds no `null` (a non-finite number).
fn decks_at_any_scale_between_cycles_stop_with_a_line_and_a_restartable_model(t: &Target) {
    let cases = fuzz_cases(if matches!(t, Target::Cpu) { 300 } else { 25 });
    let out = std::env::temp_dir().join(format!("blockdem-scaled-decks-{}-{}", std::process::id(), t.name().replace(' ', "_")));
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let result = runner.run(&scaled_deck(), |deck| {
        let started = std::time::Instant::now();
        let (exec, _) = run_naming_its_line(t, &deck, "scaled.dat", &out)?;
        // Not a proof that no deck hangs, but a campaign's slowest decks are seen.
        if started.elapsed().as_secs() > 30 {
            eprintln!("slow deck ({:.0} s) on {}:\n{deck}", started.elapsed().as_secs_f64(), t.name());
        }
        prop_assert!(exec.model.validate().is_ok(), "the model cannot be restarted: {:?}", exec.model.validate());
        let path = out.join("end.sav");
        std::fs::create_dir_all(&out).unwrap();
        blockdem::udec::output::restart::save_state(&path, &exec.model, &Default::default(), 0).map_err(|e| TestCaseError::fail(e.to_string()))?;
        blockdem::udec::output::restart::load(&path).map_err(|e| TestCaseError::fail(e.to_string()))?;
        // Every term, the kinetic energy included: where its half step to the whole step
        // overflows (a load or a FRACTION of 1e300), the ledger takes it at the half step.
        let json = blockdem::udec::output::state_json::state_json(&exec.model);
        let json = json.to_string();
        prop_assert!(!json.contains("null"), "a non-finite value in the state JSON: {json}");
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&out);
    if let Err(e) = result {
        panic!("on {}: {e}", t.name());
    }
}
