//! Random D3 decks on the CPU and on each GPU adapter present, as tests/suite/random_decks.rs does
//! for 2D: nothing panics, every error names the deck's file and a line of it, and whatever stops
//! a run leaves a finite model (the last good state after a numerical failure). The decks build
//! boxes, tetrahedra (now and then turned inside out), split them by planes, fix, free, load, set
//! velocities, make simply-deformable blocks with Griffith strengths and joint stiffnesses, put
//! stress and velocity boundaries on them, cycle, print, save and restart, with ordinary values
//! and, now and then, the ends of f64; and scenes of blocks from a micrometre to a kilometre, up
//! to 10¹² m from the origin, each saved and restarted after its cycles.

use crate::common;

use blockdem::d3::exec::{Executor, RunError};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// A value of a property: mostly ordinary, now and then zero, negative or at f64's ends.
fn property() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => prop_oneof![Just("1E8"), Just("1E9"), Just("2000"), Just("0.5"), Just("3")].prop_map(String::from),
        8 => (0.01f64..50.0).prop_map(|v| format!("{v:.3}")),
        1 => prop_oneof![Just("0"), Just("-1"), Just("1E-300"), Just("1E300")].prop_map(String::from),
    ]
}

/// A load, a velocity, a stress or gravity: mostly ordinary, now and then at f64's ends.
fn any_value() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => (-30.0f64..30.0).prop_map(|v| format!("{v:.3}")),
        1 => Just("0".to_string()),
        1 => prop_oneof![Just("1E30"), Just("-1E300"), Just("1E300")].prop_map(String::from),
    ]
}

/// A range x1 x2 y1 y2 z1 z2: most often one that holds every block above the slab.
fn range() -> impl Strategy<Value = String> {
    let one = || (-2.0f64..4.0, 0.05f64..5.0).prop_map(|(a, w)| format!("{a:.2} {:.2}", a + w));
    prop_oneof![1 => Just("-3 7 -3 7 0.01 9".to_string()), 2 => (one(), one(), one()).prop_map(|(x, y, z)| format!("{x} {y} {z}"))]
}

/// A tetrahedron of size `s` at (x, y, z), or with one face the wrong way round (an input error
/// naming the face).
fn tetrahedron() -> impl Strategy<Value = String> {
    (0.0f64..3.0, 0.0f64..3.0, 0.2f64..4.0, 0.05f64..1.0, prop::bool::weighted(0.15)).prop_map(|(x, y, z, s, wrong)| {
        let p = [[x, y, z], [x + s, y, z], [x, y + s, z], [x, y, z + s]];
        // Counter-clockwise looking along the outward normal (Appendix B), from inside.
        let faces = [if wrong { [0, 2, 1] } else { [0, 1, 2] }, [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        let face = |f: [usize; 3]| f.map(|i| format!("({:.3},{:.3},{:.3})", p[i][0], p[i][1], p[i][2])).join(" ");
        format!("BLOCK {}", faces.map(face).join("\n+ "))
    })
}

fn command() -> impl Strategy<Value = String> {
    let boxed = (
        -1.0f64..3.0,
        -1.0f64..3.0,
        0.0f64..4.0,
        0.05f64..2.0,
        0.05f64..2.0,
        0.05f64..2.0,
        prop_oneof![Just(""), Just(" MAT 2"), Just(" CONS 4"), Just(" MAT 1 CONS 3")],
    )
        .prop_map(|(x, y, z, a, b, c, m)| format!("BOX {x:.2} {:.2} {y:.2} {:.2} {z:.2} {:.2}{m}", x + a, y + b, z + c));
    let unit = || -1.0f64..1.0;
    prop_oneof![
        4 => boxed,
        1 => tetrahedron(),
        2 => (-1.0f64..3.0, -1.0f64..3.0, 0.0f64..4.0, unit(), unit(), unit(), prop_oneof![Just(""), Just(" MAT 2 CONS 4")])
            .prop_map(|(x, y, z, a, b, c, m)| format!("SPLIT {x:.2} {y:.2} {z:.2} {a:.2} {b:.2} {c:.2}{m}")),
        1 => range().prop_map(|r| format!("FIX {r}")),
        1 => range().prop_map(|r| format!("FREE {r}")),
        1 => (range(), any_value(), any_value(), any_value()).prop_map(|(r, x, y, z)| format!("LOAD {r} {x} {y} {z}")),
        1 => (range(), any_value(), any_value(), any_value(), prop_oneof![Just(String::new()), (any_value(), any_value(), any_value()).prop_map(|(a, b, c)| format!(" {a} {b} {c}"))])
            .prop_map(|(r, x, y, z, w)| format!("VELOCITY {r} {x} {y} {z}{w}")),
        1 => (any_value(), any_value(), any_value()).prop_map(|(x, y, z)| format!("GRAV {x} {y} {z}")),
        1 => (prop_oneof![Just("0"), Just("0.5"), Just("2")], property(), prop_oneof![Just(""), Just(" MASS"), Just(" STIFF"), Just(" INTERNAL")])
            .prop_map(|(f, hz, m)| format!("DAMP {f} {hz}{m}")),
        1 => prop_oneof![Just("0.1"), Just("0.9"), Just("1E-30"), Just("0.5"), Just("3")].prop_map(|f| format!("FRAC {f}")),
        1 => (1u32..3, property(), property(), property(), property(), property(), property(), property())
            .prop_map(|(m, d, kn, ks, f, k, g, tf)| format!("PROP MAT={m} D={d} KN={kn} KS={ks} F={f} K={k} G={g} TF={tf}")),
        1 => (1u32..3, property(), property(), property(), property()).prop_map(|(m, kn, ks, c, f)| format!("PROP MAT={m} JKN={kn} JKS={ks} JCOH={c} JFRIC={f}")),
        1 => (range(), 1u32..3, 1u32..6).prop_map(|(r, m, k)| format!("CHANGE {r} MAT {m} CONS {k}")),
        2 => (range(), prop_oneof![Just(""), Just(" MAT 1"), Just(" CONS 4")]).prop_map(|(r, m)| format!("CHANGE {r} SDEF{m}")),
        1 => (range(), any_value(), any_value(), any_value(), any_value(), any_value(), any_value())
            .prop_map(|(r, a, b, c, d, e, f)| format!("BOUNDARY STRESS {r} {a} {b} {c} {d} {e} {f}")),
        1 => (range(), any_value(), any_value(), any_value()).prop_map(|(r, x, y, z)| format!("BOUNDARY VELOCITY {r} {x} {y} {z}")),
        4 => prop_oneof![Just(0u32), Just(1), 2u32..150].prop_map(|n| format!("CYCLE {n}")),
        1 => prop_oneof![Just("PRINT BLOCKS FACES VELOCITIES VERTICES CONTACTS ENERGY"), Just("PRINT CONTACTS"), Just("VTK"), Just("DUMP")].prop_map(String::from),
        // (A RESTART before any SAVE stops the deck there: mostly after one.)
        1 => prop_oneof![3 => Just("SAVE a.sav\nRESTART a.sav"), 1 => Just("SAVE a.sav"), 1 => Just("RESTART a.sav")].prop_map(String::from),
    ]
}

/// Runs `deck` on `backend`'s engine with its files in `out`: a run that stops must say so with
/// the deck's file and a line of it, and leave finite blocks. Whether it ran to its end.
fn run_naming_its_line(backend: Box<dyn blockdem::d3::backend::Backend>, deck: &str, out: &std::path::Path) -> Result<bool, TestCaseError> {
    let file = "random3.dat";
    let lines = deck.lines().count();
    let named = |text: String| -> Result<bool, TestCaseError> {
        let line: Option<usize> = text.strip_prefix(&format!("{file}:")).and_then(|rest| rest.split(':').next()).and_then(|l| l.parse().ok());
        prop_assert!(line.is_some_and(|l| (1..=lines).contains(&l)), "not named by its line: {text}\n{deck}");
        // A file the deck's own SAVE wrote restarts.
        prop_assert!(!text.contains("is inconsistent"), "a SAVE that RESTART refuses: {text}\n{deck}");
        Ok(false)
    };
    // (A value the parser refuses, a negative stiffness, is refused there, by its line.)
    let commands = match blockdem::d3::deck::parse_deck(deck, file) {
        Ok(commands) => commands,
        Err(e) => return named(e.to_string()),
    };
    let _ = std::fs::remove_dir_all(out);
    let mut exec = Executor::with_backend(Box::new(std::io::sink()), file, backend);
    exec.set_out_dir(out);
    let result = exec.run(&commands);
    for b in &exec.model.blocks {
        prop_assert!(b.centroid.is_finite() && b.velocity.is_finite() && b.angular_velocity.is_finite(), "block {} not finite: {:?}\n{deck}", b.id, b.centroid);
    }
    match result {
        Ok(()) => Ok(true),
        Err(RunError::Interrupted(_)) => Err(TestCaseError::fail("interrupted without a signal")),
        Err(e) => named(e.to_string()),
    }
}

/// The number of cases: `default`, or BLOCKDEM_FUZZ_CASES for a long campaign.
fn fuzz_cases(default: u32) -> u32 {
    std::env::var("BLOCKDEM_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// The decks on `make()`'s backend, `cases` of them; how many ran to their end.
fn campaign(name: &str, cases: u32, make: &dyn Fn() -> Box<dyn blockdem::d3::backend::Backend>) -> u32 {
    let out = std::env::temp_dir().join(format!("blockdem-d3-random-{}-{}", std::process::id(), name.replace(' ', "_")));
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let ended = std::sync::atomic::AtomicU32::new(0);
    let deck = prop::collection::vec(command(), 0..20).prop_map(|commands| {
        // A slab, fixed, and a box on it; material 2 without joint stiffnesses (a joint law on
        // it is an input error).
        format!(
            "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5 K=1E9 G=1E9 JKN=1E9 JKS=1E9\nPROP MAT=2 D=2500 KN=1E9 KS=1E9 F=0.3 K=1E9 G=1E9\n\
             BOX -2 6 -2 6 -1 0\nFIX -3 7 -3 7 -2 0\nBOX 0 1 0 1 0 1\nGRAV 0 0 -10\n{}\nCYCLE 30\nSTOP\n",
            commands.join("\n")
        )
    });
    let result = runner.run(&deck, |deck| {
        if run_naming_its_line(make(), &deck, &out)? {
            ended.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&out);
    if let Err(e) = result {
        panic!("on {name}: {e}");
    }
    let ended = ended.into_inner();
    eprintln!("{name}: {ended} of {cases} D3 decks ran to their end");
    ended
}

#[test]
fn random_d3_decks_never_panic_and_stop_with_a_line_and_a_finite_model() {
    let cases = fuzz_cases(150);
    let ended = campaign("cpu", cases, &|| Box::new(blockdem::d3::cpu::CpuBackend::new()));
    // (About half run to their end: a generator whose decks all stop early tests little.)
    assert!(ended >= cases / 5, "{ended} of {cases} decks ran to their end");
}

#[test]
fn random_d3_decks_on_the_gpu_never_panic_and_stop_with_a_line_and_a_finite_model() {
    // Each deck builds its device: fewer of them.
    for o in common::gpu_options() {
        let name = format!("{:?} {:?}", o.adapter, o.precision);
        campaign(&name, fuzz_cases(6), &|| Box::new(blockdem::d3::gpu::GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"))));
    }
}

/// A scene of boxes `size` times the unit scene's, `origin` from the origin, dropped, split, made
/// simply deformable and set moving, then cycled, saved and restarted.
fn scaled_deck() -> impl Strategy<Value = String> {
    let scale = (prop_oneof![Just(1e-6), Just(1e-3), Just(1.0), Just(1e3)], prop_oneof![Just(0.0), Just(1e6), Just(-1e6), Just(1e12)]);
    scale.prop_flat_map(|(size, origin)| {
        let x = move |u: f64| format!("{:?}", origin + size * u);
        let boxed = move |(a, b, c, w, d, h): (f64, f64, f64, f64, f64, f64)| format!("BOX {} {} {} {} {} {}", x(a), x(a + w), x(b), x(b + d), x(c), x(c + h));
        let all = format!("{} {} {} {} {} {}", x(-3.0), x(7.0), x(-3.0), x(7.0), x(0.01), x(9.0));
        let command = prop_oneof![
            4 => (-1.0f64..3.0, -1.0f64..3.0, 0.0f64..3.0, 0.05f64..2.0, 0.05f64..2.0, 0.05f64..2.0).prop_map(boxed),
            2 => (-1.0f64..3.0, -1.0f64..3.0, 0.0f64..3.0, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
                .prop_map(move |(a, b, c, u, v, w)| format!("SPLIT {} {} {} {u:.3} {v:.3} {w:.3}", x(a), x(b), x(c))),
            1 => Just(format!("CHANGE {all} SDEF")),
            1 => (-5.0f64..5.0, -5.0f64..5.0, -3.0f64..3.0).prop_map({
                let all = all.clone();
                move |(vx, vz, w)| format!("VELOCITY {all} {vx:.3} 0 {vz:.3} 0 {w:.3} 0")
            }),
            1 => prop_oneof![Just("GRAV 0 0 -10"), Just("GRAV 0 0 -1E6"), Just("GRAV 0 0 0")].prop_map(String::from),
            2 => (1u32..300).prop_map(|n| format!("CYCLE {n}")),
        ];
        let slab = format!(
            "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5 K=1E9 G=1E9 JKN=1E9 JKS=1E9\n{}\nFIX {} {} {} {} {} {}\n",
            boxed((-2.0, -2.0, -1.0, 8.0, 8.0, 1.0)),
            x(-3.0),
            x(7.0),
            x(-3.0),
            x(7.0),
            x(-2.0),
            x(0.0)
        );
        (prop::collection::vec(command, 1..9), 10u32..400)
            .prop_map(move |(commands, n)| format!("{slab}{}\nGRAV 0 0 -10\nCYCLE {n}\nSAVE a.sav\nRESTART a.sav\nCYCLE 20\nSTOP\n", commands.join("\n")))
    })
}

/// Found by `d3_decks_at_any_scale_stop_with_a_line_and_restart_what_they_save`: boxes 10¹² m
/// from the origin whose SAVE after the impact the RESTART refused (a swapped corner's carried
/// spring has a positive offset, which `restart::Offsets::apply` took for a damaged file).
const POSITIVE_OFFSET: &str = "\
START\n\
PROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5 K=1E9 G=1E9 JKN=1E9 JKS=1E9\n\
BOX 999999998000.0 1000000006000.0 999999998000.0 1000000006000.0 999999999000.0 1000000000000.0\n\
FIX 999999997000.0 1000000007000.0 999999997000.0 1000000007000.0 999999998000.0 1000000000000.0\n\
BOX 1000000001448.5134 1000000001804.5958 1000000000609.2988 1000000002331.4955 1000000000844.0552 1000000002475.7764\n\
CHANGE 999999997000.0 1000000007000.0 999999997000.0 1000000007000.0 1000000000010.0 1000000009000.0 SDEF\n\
BOX 1000000000716.9617 1000000001506.4674 1000000000066.1418 1000000001184.0135 1000000000289.2153 1000000002122.3823\n\
GRAV 0 0 0\n\
SPLIT 1000000002942.033 999999999938.5618 1000000002176.3955 -0.831 -0.661 0.822\n\
BOX 1000000002036.4647 1000000002804.2754 1000000001400.8353 1000000002114.3915 1000000002523.3966 1000000003141.2664\n\
CYCLE 251\n\
BOX 1000000001204.6819 1000000001397.409 999999999417.1 1000000001156.1283 1000000000117.4135 1000000001704.2405\n\
GRAV 0 0 -10\n\
CYCLE 74\n\
SAVE a.sav\n\
RESTART a.sav\n\
CYCLE 20\n\
STOP\n\
";

#[test]
fn d3_decks_at_any_scale_stop_with_a_line_and_restart_what_they_save() {
    let cases = fuzz_cases(60);
    let out = std::env::temp_dir().join(format!("blockdem-d3-scaled-{}", std::process::id()));
    assert!(run_naming_its_line(Box::new(blockdem::d3::cpu::CpuBackend::new()), POSITIVE_OFFSET, &out).unwrap(), "the deck runs to its end");
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let result = runner.run(&scaled_deck(), |deck| {
        run_naming_its_line(Box::new(blockdem::d3::cpu::CpuBackend::new()), &deck, &out)?;
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&out);
    if let Err(e) = result {
        panic!("{e}");
    }
}
