//! D3's critical time step (`Model::critical_timestep`): a block's logical contacts act in
//! parallel, so the step falls as they come, and at FRACTION 0.9 a stack of cubes (eight logical
//! contacts on each inner cube, four on the top one) stays stable.

use blockdem::d3::deck::parse_deck;
use blockdem::d3::exec::Executor;
use blockdem::d3::model::Model;

fn run(deck: &str) -> Result<Model, String> {
    let commands = parse_deck(deck, "t.dat").map_err(|e| e.to_string())?;
    let mut exec = Executor::new(Box::new(std::io::sink()), "t.dat");
    let r = exec.run(&commands);
    r.map(|_| exec.model).map_err(|e| e.to_string())
}

/// `n` unit cubes stacked on a fixed base (its top at z = 0), under gravity.
fn stack(n: usize, frac: f64, damping: &str) -> String {
    let mut deck = String::from("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nBOX -1 2 -1 2 -1 0\n");
    for k in 0..n {
        deck += &format!("BOX 0 1 0 1 {k} {}\n", k + 1);
    }
    deck += &format!("FIX -1 2 -1 2 -1 -0.1\nGRAV 0 0 -10\n{damping}FRACTION {frac}\n");
    deck
}

#[test]
fn the_step_falls_as_contacts_are_added() {
    // One cube alone: the material's bound (one spring at its farthest vertex).
    let alone = run("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nBOX 0 1 0 1 5 6\nFRACTION 1\nCYCLE 0\n").unwrap();
    let one = run(&format!("{}CYCLE 0\n", stack(1, 1.0, ""))).unwrap();
    let two = run(&format!("{}CYCLE 0\n", stack(2, 1.0, ""))).unwrap();
    let (d0, d1, d2) = (alone.timestep(), one.timestep(), two.timestep());
    // The cube on the base: four logical contacts of its face–face contact.
    assert_eq!(one.contacts.iter().map(|c| c.logical.len()).sum::<usize>(), 4);
    assert!(d1 < d0, "a cube on four springs steps {d1:e}, alone {d0:e}");
    // The lower cube of two has eight springs, four of them to a free cube: less again.
    assert!(d2 < d1, "two cubes step {d2:e}, one {d1:e}");
    // For a unit cube (m = 2000 kg, I_min = m/6, corners r² = 3/4 from its centroid) the bound
    // against the fixed base is 2/√(4k(1/m + 4.5/m)) = 2√(m/22k).
    let m = 2000.0;
    let expected = 2.0 * (m / (22.0 * 1e9f64)).sqrt();
    assert!((d1 - expected).abs() < 1e-9 * expected, "{d1:e} vs {expected:e}");
    // Alone: one spring at the farthest corner, 2√(m/(k(1 + 4.5))).
    let expected = 2.0 * (m / (5.5 * 1e9f64)).sqrt();
    assert!((d0 - expected).abs() < 1e-9 * expected, "{d0:e} vs {expected:e}");
}

#[test]
fn a_held_block_bounds_the_step_as_a_fixed_one() {
    // A block held by BOUNDARY VELOCITY moves whatever the forces on it: to the cube on it, it
    // is a moving wall, as the fixed base is, and its own mass sets no bound.
    let base = |hold: &str| run(&format!("{}{hold}CYCLE 0\n", stack(2, 1.0, "").replace("FIX -1 2 -1 2 -1 -0.1\n", ""))).unwrap();
    let fixed = base("FIX -1 2 -1 2 -1 -0.1\nFIX 0 1 0 1 0 1\n");
    let held = base("FIX -1 2 -1 2 -1 -0.1\nBOUNDARY VELOCITY 0 1 0 1 0 1 0 0 0.01\n");
    assert!(held.blocks[1].held && !held.blocks[1].fixed);
    assert_eq!(held.timestep(), fixed.timestep());
    // The upper cube on a fixed one, as the single cube on the base: 2√(m/22k).
    let expected = 2.0 * (2000.0 / (22.0 * 1e9f64)).sqrt();
    assert!((held.timestep() - expected).abs() < 1e-9 * expected, "{:e} vs {expected:e}", held.timestep());
}

#[test]
fn a_stack_of_cubes_at_fraction_0_9_stays_stable() {
    // Dropped onto each other undamped from unstressed contacts: they ring, and nothing grows.
    let deck = stack(4, 0.9, "");
    let first = run(&format!("{deck}CYCLE 0\n")).unwrap();
    let cycles = (0.5 / first.timestep()).ceil() as u64;
    let model = run(&format!("{deck}CYCLE {cycles}\n")).expect("the stack runs to its end");
    let e = model.energies();
    // What gravity put in: the stack's settling under its own weight. At rest interface k
    // (from the base) carries (4 − k)W on four springs, so the cubes sink 2, 3.5, 4.5 and 5 ×
    // 1e-5 m and gravity's work is W × 1.5e-4 m = 3 J; ringing undamped about that state the
    // stack sinks at most twice as far. Kinetic + strain energy can't exceed the work put in.
    let input = e.external_work;
    assert!(input > 0.0 && input < 6.0 * 1.0001, "external work {input} J");
    assert!(e.kinetic + e.strain <= 1.0001 * input, "kinetic {} + strain {} > input {input}", e.kinetic, e.strain);
    // No cube sank into another more than the static overlap's few times.
    let worst = model.contacts.iter().flat_map(|c| c.logical.iter()).map(|l| -l.gap).fold(0.0, f64::max);
    let static_overlap = 4.0 * 2000.0 * 10.0 / (4.0 * 1e9);
    assert!(worst < 3.0 * static_overlap, "overlap {worst:e} vs static {static_overlap:e}");
    // And the cubes stand where they were put.
    for (k, b) in model.blocks.iter().skip(1).enumerate() {
        assert!((b.centroid.z - (k as f64 + 0.5)).abs() < 1e-3, "cube {} at z {}", k + 1, b.centroid.z);
    }
}

#[test]
fn a_stack_of_cubes_at_fraction_1_settles_under_damping() {
    // With mass damping the stack comes to rest with each interface carrying the weight above.
    let deck = stack(4, 1.0, "DAMP 1 160 MASS\n");
    let model = run(&format!("{deck}CYCLE 3000\n")).expect("the stack runs to its end");
    for k in 0..4u32 {
        let above = (4 - k) as f64 * 2000.0 * 10.0;
        let f: f64 = model.contacts.iter().filter(|c| c.blocks == [k, k + 1]).map(|c| c.normal_force()).sum();
        assert!((f - above).abs() < 1e-3 * above, "interface {k}: {f} N of {above}");
    }
}

#[test]
fn a_box_tumbling_alone_at_fraction_1_is_not_stopped_as_too_fast() {
    // Its corners move more than the contact-forming distance per step, but nothing is near.
    let deck = "START\nPROP MAT=1 D=1000 KN=1E7 KS=1E7\nBOX 0 1 0 2 0 3\nFRACTION 1\nVELOCITY 0 1 0 2 0 3 0 0 0 0.1 2 0.1\nCYCLE 2000\n";
    let model = run(deck).expect("a free box tumbles");
    assert_eq!(model.cycle, 2000);
    // Beside another block the same spin is stopped (it could pass a contact unseen).
    let near = deck.replace("FRACTION 1", "BOX 1.01 2 0 2 0 3\nFIX 1.02 2 0 2 0 3\nFRACTION 1");
    let e = run(&near).unwrap_err();
    assert!(e.contains("fast") || e.contains("travel"), "{e}");
}

/// The log's TIMESTEP comes after each CYCLE (the 1985 layout) and is the step the run took: a
/// deck's first CYCLE printed the step of blocks without contacts before the run (its first
/// detection), 1.1e-5 s for a wall that then stepped at 1.9e-6 s.
#[test]
fn the_logged_step_is_the_one_the_run_took() {
    let deck = format!("{}CYCLE 20\nCYCLE 20\n", stack(3, 0.1, ""));
    let commands = parse_deck(&deck, "t.dat").unwrap();
    let mut log = Vec::new();
    let mut exec = Executor::new(Box::new(&mut log), "t.dat");
    exec.run(&commands).unwrap_or_else(|e| panic!("{e}"));
    let (time, cycle, dt) = (exec.model.time, exec.model.cycle, exec.model.timestep());
    // The contacts' step, well under the lone blocks' (no contacts: one spring at the farthest
    // vertex) the first CYCLE's log used to give.
    let lone = run(&stack(3, 0.1, "")).unwrap().timestep();
    drop(exec);
    let log = String::from_utf8(log).unwrap();
    assert!(dt < 0.7 * lone, "{dt} against {lone}");
    // Each CYCLE's lines: its echo, then TIMESTEP, then CURRENT CYCLE COUNT.
    let lines: Vec<&str> = log.lines().collect();
    let cycles: Vec<usize> = lines.iter().enumerate().filter(|(_, l)| l.starts_with(">CYCLE")).map(|(k, _)| k).collect();
    assert_eq!(cycles.len(), 2, "{log}");
    for &k in &cycles {
        assert!(lines[k + 1].starts_with("TIMESTEP = ") && lines[k + 2].starts_with("CURRENT CYCLE COUNT = "), "{log}");
    }
    let logged: f64 = lines[cycles[0] + 1].trim_start_matches("TIMESTEP = ").trim().parse().unwrap();
    // The runs stepped at it: the stack settles little in 40 cycles, the step stays (to the
    // print's four figures).
    assert_eq!(cycle, 40);
    assert!(((time / 40.0) - logged).abs() < 1e-3 * logged, "{} per cycle, logged {logged}", time / 40.0);
    assert!((dt - logged).abs() < 1e-3 * logged, "{dt} now, logged {logged}");
}
