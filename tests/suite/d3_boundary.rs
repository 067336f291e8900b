//! D3's boundary conditions (SL-85-1 Part IV ¶35e, "comprehensive boundary conditions: stress
//! tensor, arbitrary velocity prescription"; extensions BOUNDARY STRESS and BOUNDARY VELOCITY):
//! closed forms on the CPU, the GPU against the CPU, input errors, SPLIT and SAVE/RESTART.
//!
//! Tolerances, and why: a constant force gives central differences the exact uniformly
//! accelerated motion, so the free box's velocity is p·A/m·t to round-off (1e-12); a closed
//! surface under a uniform stress has zero resultant and moment, so their round-off (1e-12 of
//! p·A) is the bound; the simply-deformable block's strain is the elastic law's to O(ε) (the
//! traction acts on the strained faces, the stress on the reference volume: ε ~ 1e-5 here) plus
//! what the damping leaves (1e-3); the ledger's O(Δt) error of central differences is a few
//! 1e-3 of its largest term. GPU against CPU: in f64 the kernels are the CPU's arithmetic (1e-9,
//! lavapipe contracts some products), in f32 a position's round-off, 1e-7 relative, grown over
//! the run (2e-4).

use crate::common;

use blockdem::d3::cpu::CpuBackend;
use blockdem::d3::exec::Executor;
use blockdem::d3::gpu::GpuBackend;
use blockdem::d3::model::Model;
use blockdem::udec::gpu::{GpuOptions, Precision};

/// Runs a D3 deck on `backend`, its files in `dir` (if any): the model and the run log.
fn run_on(deck: &str, backend: Box<dyn blockdem::d3::backend::Backend>, dir: Option<&std::path::Path>) -> (Model, String) {
    let commands = blockdem::d3::deck::parse_deck(deck, "t.dat").unwrap_or_else(|e| panic!("{e}"));
    let mut log = Vec::new();
    let model = {
        let mut exec = Executor::with_backend(Box::new(&mut log), "t.dat", backend);
        if let Some(d) = dir {
            exec.set_out_dir(d);
        }
        exec.run(&commands).unwrap_or_else(|e| panic!("deck failed: {e}"));
        std::mem::take(&mut exec.model)
    };
    (model, String::from_utf8(log).unwrap())
}

fn run(deck: &str) -> (Model, String) {
    run_on(deck, Box::new(CpuBackend::new()), None)
}

/// The error a deck is refused with (reading or running it).
fn error_of(deck: &str) -> String {
    match blockdem::d3::deck::parse_deck(deck, "t.dat") {
        Err(e) => e.to_string(),
        Ok(commands) => {
            let mut exec = Executor::new(Box::new(std::io::sink()), "t.dat");
            exec.run(&commands).expect_err("the deck must be refused").to_string()
        }
    }
}

/// The GPU targets present (tests/suite/common's): Vulkan f32 and f64, GL f32.
fn targets() -> Vec<GpuOptions> {
    common::gpu_options()
}

fn gpu(o: &GpuOptions) -> Box<dyn blockdem::d3::backend::Backend> {
    Box::new(GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}")))
}

const ROCK: &str = "PROP MAT 1 D 1000 K 1E9 G 6E8 KN 1E9 KS 1E9\n";

/// A unit box, no gravity, σzz = −p on its top face only (the two triangles at z = 1): it
/// accelerates downwards at p·A/m, without turning, and the stress's work is its kinetic energy.
fn top_loaded_box(p: f64, cycles: u64) -> String {
    format!("START\n{ROCK}BOX 0 1 0 1 0 1\nBOUNDARY STRESS -1 2 -1 2 0.9 1.1 0 0 {} 0 0 0\nCYCLE {cycles}\nSTOP\n", -p)
}

#[test]
fn a_stress_on_one_face_accelerates_a_free_box_at_p_a_over_m() {
    let p = 1e4;
    let (m, log) = run(&top_loaded_box(p, 200));
    assert!(log.contains("BOUNDARY STRESS ON 2 FACES OF 1 BLOCKS"), "{log}");
    let b = &m.blocks[0];
    assert_eq!(b.boundary_stress.len(), 2);
    // Compression pushes into the block: downwards, at p·A/m (A = 1, m = 1000).
    let a = p * 1.0 / b.mass;
    let v = -a * m.time;
    assert!((b.velocity.z - v).abs() < 1e-12 * v.abs(), "vz {} against {v}", b.velocity.z);
    assert!(b.velocity.x.abs() + b.velocity.y.abs() < 1e-12 * v.abs(), "{}", b.velocity);
    assert!(b.angular_velocity.length() < 1e-12, "{}", b.angular_velocity);
    assert!((b.force.z + p).abs() < 1e-9 * p && b.moment.length() < 1e-9 * p, "{} {}", b.force, b.moment);
    // The work the stress did is the kinetic energy the box has (the ledger's balance).
    let e = m.energies();
    assert!(e.external_work > 0.0);
    assert!(e.ledger().abs() < 1e-3 * e.scale(), "ledger {} of {}", e.ledger(), e.scale());
}

#[test]
fn a_hydrostatic_stress_on_every_face_leaves_a_box_at_rest() {
    let p = 1e6;
    let (m, _) = run(&format!("START\n{ROCK}BOX 0 1 0 1 0 1\nBOUNDARY STRESS -1 2 -1 2 -1 2 {0} {0} {0} 0 0 0\nCYCLE 50\nSTOP\n", -p));
    let b = &m.blocks[0];
    assert_eq!(b.boundary_stress.len(), 12);
    assert!(b.force.length() < 1e-12 * p, "{}", b.force);
    assert!(b.moment.length() < 1e-12 * p, "{}", b.moment);
    assert!(b.velocity.length() < 1e-12 && b.angular_velocity.length() < 1e-12);
}

/// A box of sides 1 × 2 × 3 built turned (its faces typed rotated), under a hydrostatic and under
/// a general symmetric stress on all its faces: the resultant σ·Σa and the moment of a uniform
/// symmetric stress over a closed surface are zero.
#[test]
fn a_uniform_stress_on_a_rotated_closed_box_has_no_resultant_and_no_moment() {
    let q = glam::DQuat::from_axis_angle(glam::DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let faces = blockdem::d3::geometry::box_faces([0.0, 0.0, 0.0], [1.0, 2.0, 3.0]);
    // A face's nine numbers on a line of their own: BLOCK's, then `+` continuation lines.
    let mut block = String::from("BLOCK");
    for (k, f) in faces.into_iter().enumerate() {
        if k > 0 {
            block.push_str("\n+");
        }
        for v in f {
            let x = q * glam::DVec3::from_array(v) + glam::DVec3::new(5.0, 5.0, 5.0);
            block.push_str(&format!(" {:.17} {:.17} {:.17}", x.x, x.y, x.z));
        }
    }
    for (sigma, scale) in [("-1E6 -1E6 -1E6 0 0 0", 1e6), ("-3E6 2E6 -1E6 5E5 -7E5 9E5", 3e6)] {
        let deck = format!("START\n{ROCK}{block}\nBOUNDARY STRESS 0 10 0 10 0 10 {sigma}\nCYCLE 1\nSTOP\n");
        let (m, _) = run(&deck);
        let b = &m.blocks[0];
        assert_eq!(b.boundary_stress.len(), 12);
        // |a| sums to 22 m², the lever arms to 1.9 m.
        assert!(b.force.length() < 1e-12 * scale * 22.0, "{sigma}: {}", b.force);
        assert!(b.moment.length() < 1e-12 * scale * 22.0 * 2.0, "{sigma}: {}", b.moment);
    }
}

/// A simply-deformable unit box with σzz = −p on its top and bottom faces, settled by its
/// internal damping: the elastic law's uniaxial strains εzz = σ(1/9K + 1/3G) and
/// εxx = εyy = σ(1/9K − 1/6G), σ = −p, and no rigid motion.
#[test]
fn a_uniaxial_stress_strains_a_simply_deformable_box_as_the_elastic_law_says() {
    let (k, g, p) = (1e9, 6e8, 1e4);
    let deck = format!(
        "START\n{ROCK}BOX 0 1 0 1 0 1\nCHANGE -1 2 -1 2 -1 2 SDEF\nDAMPING 0.8 955 INTERNAL\n\
         BOUNDARY STRESS -1 2 -1 2 0.9 1.1 0 0 {0} 0 0 0\nBOUNDARY STRESS -1 2 -1 2 -0.1 0.1 0 0 {0} 0 0 0\nCYCLE 3000\nSTOP\n",
        -p
    );
    let (m, log) = run(&deck);
    assert_eq!(log.matches("BOUNDARY STRESS ON 2 FACES OF 1 BLOCKS").count(), 2, "{log}");
    let b = &m.blocks[0];
    let s = b.sdef.unwrap();
    let sigma = -p;
    let ezz = sigma * (1.0 / (9.0 * k) + 1.0 / (3.0 * g));
    let exx = sigma * (1.0 / (9.0 * k) - 1.0 / (6.0 * g));
    assert!((s.strain[2] - ezz).abs() < 1e-3 * ezz.abs(), "εzz {} against {ezz}", s.strain[2]);
    assert!((s.strain[0] - exx).abs() < 1e-3 * exx.abs(), "εxx {} against {exx}", s.strain[0]);
    assert!((s.strain[1] - exx).abs() < 1e-3 * exx.abs(), "εyy {} against {exx}", s.strain[1]);
    assert!(s.strain[3..].iter().all(|e| e.abs() < 1e-6 * ezz.abs()), "{:?}", s.strain);
    assert!((s.stress[2] - sigma).abs() < 1e-3 * p && s.stress[0].abs() < 1e-3 * p, "{:?}", s.stress);
    assert!(b.velocity.length() < 1e-9 && b.angular_velocity.length() < 1e-9, "{} {}", b.velocity, b.angular_velocity);
    // The stress's work is the strain energy plus what the damping took.
    let e = m.energies();
    assert!(e.ledger().abs() < 5e-3 * e.scale(), "ledger {} of {}", e.ledger(), e.scale());
}

/// A slab on a fixed floor, pushed down by a block held at 0.1 m/s: the held block moves exactly
/// at its velocity whatever the contact pushes back with, and the ledger books the work that holds
/// it (the contacts' strain and the damping balance it).
fn pushed_slab(cycles: u64, tail: &str) -> String {
    format!(
        "START\n{ROCK}GRAVITY 0 0 -10\nBOX 0 1 0 1 -1 0\nFIX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nBOX 0.25 0.75 0.25 0.75 1 1.5\n\
         DAMPING 0.05 100\nBOUNDARY VELOCITY 0 1 0 1 1 1.5 0 0 -0.1\nCYCLE {cycles}\n{tail}STOP\n"
    )
}

#[test]
fn a_held_block_pushes_a_slab_at_its_velocity_and_the_ledger_balances() {
    let (m, log) = run(&pushed_slab(400, "PRINT BLOCKS\n"));
    assert!(log.contains("BOUNDARY VELOCITY: 1 BLOCKS HELD") && log.contains("(HELD)"), "{log}");
    let held = &m.blocks[2];
    assert!(held.held && !held.fixed);
    assert_eq!(held.velocity, glam::DVec3::new(0.0, 0.0, -0.1), "the velocity is held exactly");
    let z = 1.25 - 0.1 * m.time;
    assert!((held.centroid.z - z).abs() < 1e-12, "centroid {} against {z}", held.centroid.z);
    assert!(held.centroid.x == 0.5 && held.centroid.y == 0.5);
    // The slab is pushed into the floor: the held block takes a reaction well over the weights.
    assert!(held.force.z > 10.0 * held.mass * 10.0, "reaction {}", held.force.z);
    let e = m.energies();
    assert!(e.strain > 0.0 && e.external_work > 0.0);
    assert!(e.ledger().abs() < 1e-2 * e.scale(), "ledger {} of {}: {e:?}", e.ledger(), e.scale());
}

#[test]
fn free_releases_a_held_block_and_fix_holds_it_at_rest() {
    let deck = |then: &str| {
        // A free box far off keeps a time step when the first is fixed.
        format!("START\n{ROCK}BOX 0 1 0 1 0 1\nBOX 10 11 0 1 0 1\nBOUNDARY VELOCITY -1 2 -1 2 -1 2 1 0 0 0 0 2\nCYCLE 10\n{then}\nGRAVITY 0 0 -10\nCYCLE 10\nSTOP\n")
    };
    let (held, _) = run(&deck(""));
    assert!(held.blocks[0].held && held.blocks[0].velocity == glam::DVec3::new(1.0, 0.0, 0.0), "gravity does not move a held block");
    assert_eq!(held.blocks[0].angular_velocity, glam::DVec3::new(0.0, 0.0, 2.0));
    let (freed, _) = run(&deck("FREE -1 2 -1 2 -1 2"));
    let b = &freed.blocks[0];
    assert!(!b.held && !b.fixed);
    assert!((b.velocity.x - 1.0).abs() < 1e-12 && b.velocity.z < -1e-3, "it goes on and falls: {}", b.velocity);
    let (fixed, _) = run(&deck("FIX -1 10 -1 2 -1 2"));
    let b = &fixed.blocks[0];
    assert!(!b.held && b.fixed && b.velocity == glam::DVec3::ZERO && b.angular_velocity == glam::DVec3::ZERO);
}

#[test]
fn a_held_simply_deformable_block_keeps_its_strain() {
    let deck = format!(
        "START\n{ROCK}BOX 0 1 0 1 0 1\nCHANGE -1 2 -1 2 -1 2 SDEF\nBOUNDARY STRESS -1 2 -1 2 0.9 1.1 0 0 -1E6 0 0 0\nCYCLE 5\n\
         BOUNDARY VELOCITY -1 2 -1 2 -1 2 0 0 0\nCYCLE 20\nSTOP\n"
    );
    let (m, _) = run(&deck);
    let s = m.blocks[0].sdef.unwrap();
    assert_eq!(s.strain_rate, [0.0; 6]);
    assert!(s.strain[2] < 0.0, "strained by the first five cycles: {:?}", s.strain);
}

#[test]
fn a_later_stress_replaces_and_an_empty_range_warns() {
    let (m, log) = run(&format!(
        "START\n{ROCK}BOX 0 1 0 1 0 1\nBOUNDARY STRESS -1 2 -1 2 0.9 1.1 0 0 -1 0 0 0\nBOU S -1 2 -1 2 0.9 1.1 0 0 -2 0 0 0\n\
         BOUNDARY STRESS 5 6 5 6 5 6 1 1 1 0 0 0\nBOUNDARY VELOCITY 5 6 5 6 5 6 1 0 0\nSTOP\n"
    ));
    assert!(log.contains("BOUNDARY STRESS ON 2 FACES OF 1 BLOCKS, 2 OF THEM LOADED BEFORE: THEIR STRESS REPLACED"), "{log}");
    assert!(log.contains("WARNING: BOUNDARY STRESS: no face has its centroid in the range"), "{log}");
    assert!(log.contains("WARNING: BOUNDARY VELOCITY: no block has its centroid in the range"), "{log}");
    assert!(m.blocks[0].boundary_stress.iter().all(|l| l.stress == [0.0, 0.0, -2.0, 0.0, 0.0, 0.0]));
    assert_eq!(m.blocks[0].boundary_stress.len(), 2);
}

#[test]
fn bad_boundary_input_is_refused_at_its_line() {
    let e = error_of("START\nBOX 0 1 0 1 0 1\nBOUNDARY STRESS 0 1 0 1 0 1 1 2 3\nSTOP\n");
    assert!(e.starts_with("t.dat:3:") && e.contains("12 numbers, found 9"), "{e}");
    let e = error_of("START\nBOX 0 1 0 1 0 1\nBOUNDARY STRESS 0 1 0 1 1 2 3 4 5 6\nSTOP\n");
    assert!(e.starts_with("t.dat:3:") && e.contains("2D range"), "{e}");
    let e = error_of("START\nBOX 0 1 0 1 0 1\nBOUNDARY VELOCITY 0 1 0 1 1 2 3\nSTOP\n");
    assert!(e.starts_with("t.dat:3:") && e.contains("2D range"), "{e}");
    let e = error_of("START\nBOX 0 1 0 1 0 1\nBOUNDARY VELOCITY 0 1 0 1 0 1 1 2 3 4\nSTOP\n");
    assert!(e.starts_with("t.dat:3:") && e.contains("9 or 12 numbers, found 10"), "{e}");
    let e = error_of("START\nBOX 0 1 0 1 0 1\n\nBOUNDARY XVEL 0 1 0 1 0 1 1\nSTOP\n");
    assert!(e.starts_with("t.dat:4:") && e.contains("STRESS or VELOCITY"), "{e}");
    let e = error_of("START\nBOX 0 1 0 1 0 1\nBOUNDARY STRESS 1 0 0 1 0 1 1 2 3 4 5 6\nSTOP\n");
    assert!(e.starts_with("t.dat:3:") && e.contains("empty range"), "{e}");
    // A block without mass cannot be held (the run would need it).
    let e = error_of("START\nBOX 0 1 0 1 0 1\nBOUNDARY VELOCITY -1 2 -1 2 -1 2 1 0 0\nSTOP\n");
    assert!(e.starts_with("t.dat:3:") && e.contains("no mass"), "{e}");
    // The 2D language has no BOUNDARY: a 2D deck names the line.
    let e = blockdem::udec::deck::parse_deck("START\n\n\nBOUNDARY STRESS 0 1 0 1 -1 -1 0\nSTOP\n", "t2.dat").unwrap_err().to_string();
    assert!(e.starts_with("t2.dat:4:") && e.contains("BOUNDARY"), "{e}");
}

/// SPLIT of a loaded, held box: its pieces' faces in the loaded top keep the stress (the force
/// on the pieces is the parent's), and both pieces are held at the parent's motion.
#[test]
fn split_keeps_loaded_faces_and_holds_the_pieces() {
    let deck = format!(
        "START\n{ROCK}BOX 0 1 0 1 0 1\nBOUNDARY STRESS -1 2 -1 2 0.9 1.1 0 0 -1E4 0 0 0\nBOUNDARY VELOCITY -1 2 -1 2 -1 2 0 0 0.5 0 0 1\n\
         SPLIT 0.3 0.5 0.5 1 0 0\nCYCLE 1\nSTOP\n"
    );
    let (m, _) = run(&deck);
    assert_eq!(m.blocks.len(), 2);
    let total: glam::DVec3 = m.blocks.iter().map(|b| b.boundary_load().0).sum();
    assert!((total - glam::DVec3::new(0.0, 0.0, -1e4)).length() < 1e-9, "{total}");
    for b in &m.blocks {
        assert!(b.held && !b.boundary_stress.is_empty());
        // Held at the parent's motion at its centroid when cut (before the cycle's move).
        let expect =
            glam::DVec3::new(0.0, 0.0, 0.5) + glam::DVec3::new(0.0, 0.0, 1.0).cross(b.centroid - b.velocity * m.time - glam::DVec3::new(0.5, 0.5, 0.5));
        assert!((b.velocity - expect).length() < 1e-12, "{} against {expect}", b.velocity);
        assert_eq!(b.angular_velocity, glam::DVec3::new(0.0, 0.0, 1.0));
    }
    let faces: usize = m.blocks.iter().map(|b| b.boundary_stress.len()).sum();
    assert!(faces >= 4, "{faces} faces loaded on the pieces");
}

#[test]
fn the_state_json_shows_the_boundary_conditions() {
    let (m, _) = run(&format!(
        "START\n{ROCK}BOX 0 1 0 1 0 1\nBOX 2 3 0 1 0 1\nBOUNDARY STRESS -1 1.5 -1 2 0.9 1.1 0 0 -5 0 0 0\nBOUNDARY VELOCITY 1.5 4 -1 2 -1 2 1 2 3\nSTOP\n"
    ));
    let v = blockdem::d3::output::state_json(&m, None);
    assert_eq!(v["blocks"][0]["boundary_stress"].as_array().unwrap().len(), 2);
    assert_eq!(v["blocks"][0]["boundary_stress"][0]["stress"][2], -5.0);
    assert!(v["blocks"][0]["boundary_velocity"].is_null() && v["blocks"][1]["boundary_stress"].is_null());
    assert_eq!(v["blocks"][1]["boundary_velocity"]["velocity"], serde_json::json!([1.0, 2.0, 3.0]));
}

/// CYCLE N, SAVE, RESTART, CYCLE M leaves the state CYCLE N+M leaves, bit for bit, with held
/// blocks and loaded faces (a simply-deformable one among them); and the file keeps them.
#[test]
fn save_and_restart_keep_the_boundary_conditions_bit_for_bit() {
    let dir = std::env::temp_dir().join(format!("blockdem-d3-boundary-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let setup = format!(
        "{ROCK}GRAVITY 0 0 -10\nBOX 0 1 0 1 -1 0\nFIX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nBOX 0.25 0.75 0.25 0.75 1 1.5\nCHANGE -1 2 -1 2 0 1 SDEF\n\
         BOUNDARY STRESS -1 2 -1 2 0.1 0.9 -1E4 0 0 0 0 0\nDAMPING 0.05 100\nBOUNDARY VELOCITY 0 1 0 1 1 1.5 0 0 -0.1\n"
    );
    let (straight, _) = run_on(&format!("START\n{setup}CYCLE 200\nSTOP\n"), Box::new(CpuBackend::new()), Some(&dir));
    let (saved, _) = run_on(&format!("START\n{setup}CYCLE 100\nSAVE b.sav\nSTOP\n"), Box::new(CpuBackend::new()), Some(&dir));
    let file = blockdem::d3::restart::load(&dir.join("b.sav")).unwrap();
    assert_eq!(file.model, saved, "the file holds the state, boundary conditions and all");
    assert!(file.model.blocks[2].held && !file.model.blocks[1].boundary_stress.is_empty());
    let (restarted, _) = run_on("RESTART b.sav\nCYCLE 100\nSTOP\n", Box::new(CpuBackend::new()), Some(&dir));
    assert_eq!(restarted, straight, "restarted run against the straight one");
    // And on each GPU target, the restart from its own file against its own straight run.
    for o in targets() {
        let (straight, _) = run_on(&format!("START\n{setup}CYCLE 200\nSTOP\n"), gpu(&o), Some(&dir));
        run_on(&format!("START\n{setup}CYCLE 100\nSAVE g.sav\nSTOP\n"), gpu(&o), Some(&dir));
        let (restarted, _) = run_on("RESTART g.sav\nCYCLE 100\nSTOP\n", gpu(&o), Some(&dir));
        assert_eq!(restarted, straight, "{:?} {}: restarted run against the straight one", o.adapter, o.precision);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The GPU against the CPU: the loaded free box (its velocity p·A/m·t), the uniaxially loaded
/// simply-deformable box, and the held block pushing the slab (the held block at its velocity on
/// every backend, the slab's motion and the ledger the CPU's).
#[test]
fn the_boundary_conditions_run_on_the_gpu_as_on_the_cpu() {
    let sdef = format!(
        "START\n{ROCK}BOX 0 1 0 1 0 1\nCHANGE -1 2 -1 2 -1 2 SDEF\nDAMPING 0.8 955 INTERNAL\n\
         BOUNDARY STRESS -1 2 -1 2 0.9 1.1 0 0 -1E4 0 0 0\nBOUNDARY STRESS -1 2 -1 2 -0.1 0.1 0 0 -1E4 0 0 0\nCYCLE 300\nSTOP\n"
    );
    let decks = [top_loaded_box(1e4, 200), sdef, pushed_slab(200, "")];
    let cpu: Vec<Model> = decks.iter().map(|d| run(d).0).collect();
    for o in targets() {
        let f32 = o.precision == Precision::F32;
        let name = format!("{:?} {}", o.adapter, o.precision);
        let mut last = Model::default();
        for (k, deck) in decks.iter().enumerate() {
            // The pushed slab (deck 2) has contacts, which the GPU keeps between detections and
            // whose time step it holds over a batch (module doc of `d3::gpu`): even in f64 it is
            // not the CPU's to round-off (1.3e-9 m of the slab's 8.7e-5 m measured on lavapipe).
            let tol = match (f32, k) {
                (true, _) => 2e-4,
                (false, 2) => 1e-7,
                (false, _) => 1e-9,
            };
            let (g, _) = run_on(deck, gpu(&o), None);
            let c = &cpu[k];
            assert_eq!(g.cycle, c.cycle, "{name}");
            for (a, b) in c.blocks.iter().zip(&g.blocks) {
                let (dx, dv) = ((a.centroid - b.centroid).length(), (a.velocity - b.velocity).length());
                eprintln!("{name} deck {k} block {}: |Δx| {dx:.2e} m, |Δv| {dv:.2e} m/s", a.id);
                assert!(dx < tol, "{name} deck {k}: block {} at {} against {}", a.id, b.centroid, a.centroid);
                assert!(dv < 100.0 * tol, "{name} deck {k}: block {} at {} against {}", a.id, b.velocity, a.velocity);
                if let (Some(s), Some(t)) = (&a.sdef, &b.sdef) {
                    let scale = s.strain.iter().fold(0.0f64, |m, e| m.max(e.abs()));
                    assert!(
                        s.strain.iter().zip(&t.strain).all(|(x, y)| (x - y).abs() < tol.max(1e-6) * scale),
                        "{name}: {:?} against {:?}",
                        t.strain,
                        s.strain
                    );
                }
            }
            let (ec, eg) = (c.energies(), g.energies());
            eprintln!("{name} deck {k}: work {:.6e} against {:.6e}, ledger {:.2e} of {:.2e}", eg.external_work, ec.external_work, eg.ledger(), eg.scale());
            let work_tol = if f32 || k == 2 { 2e-4 } else { 1e-6 };
            assert!(
                (ec.external_work - eg.external_work).abs() < work_tol * ec.scale(),
                "{name} deck {k}: work {} against {}",
                eg.external_work,
                ec.external_work
            );
            assert!(eg.ledger().abs() < 1e-2 * eg.scale(), "{name} deck {k}: ledger {} of {}", eg.ledger(), eg.scale());
            last = g;
        }
        // The held block at its velocity exactly (in the kernels' precision), and where it is
        // driven.
        let g = last;
        let held = &g.blocks[2];
        let vz = if o.precision == Precision::F32 { -0.1f32 as f64 } else { -0.1 };
        assert_eq!(held.velocity, glam::DVec3::new(0.0, 0.0, vz), "{name}");
        assert!((held.centroid.z - (1.25 + vz * g.time)).abs() < if o.precision == Precision::F32 { 1e-6 } else { 1e-12 }, "{name}: {}", held.centroid.z);
    }
}

/// A file of format 5 (before the boundary conditions: the model and the simply-deformable
/// extension) still reads, its blocks neither held nor loaded.
#[test]
fn a_format_5_file_reads_without_boundary_conditions() {
    use blockdem::d3::restart::{load, Extension, SaveFile, MAGIC};
    let (mut m, _) = run(&format!("START\n{ROCK}BOX 0 1 0 1 0 1\nCHANGE -1 2 -1 2 -1 2 SDEF\nCYCLE 3\nSTOP\n"));
    m.damping.alpha_internal = 7.0;
    let file = SaveFile { model: m.clone(), resumable: false, device: None };
    let payload = postcard::to_stdvec(&(&file, Extension::of(&m))).unwrap();
    let mut bytes = MAGIC.to_vec();
    bytes.extend(5u32.to_le_bytes());
    bytes.extend((payload.len() as u64).to_le_bytes());
    bytes.extend((crc32fast::hash(&payload) as u64).to_le_bytes());
    bytes.extend(&payload);
    let path = std::env::temp_dir().join(format!("blockdem-d3-v5-{}.sav", std::process::id()));
    std::fs::write(&path, bytes).unwrap();
    let read = load(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    assert_eq!(read.model, m);
    assert!(read.model.blocks.iter().all(|b| !b.held && b.boundary_stress.is_empty()));
}
