//! D3 on the GPU (`d3::gpu`) against the CPU reference (`d3::cpu`), on Vulkan f32 and f64 and GL
//! f32 (lavapipe and llvmpipe here; the GPU tests' convention, tests/suite/common: skipped without the
//! adapter, a failure under `BLOCKDEM_REQUIRE_GPU=1`).
//!
//! Tolerances, and why: the GPU keeps each contact's logical contacts between detections and
//! moves them with their blocks (module doc of `d3::gpu`), where the CPU finds them afresh each
//! cycle, so even in f64 the two differ by more than round-off where the contact's touching
//! region changes; where it does not, the f64 GPU is its Rust twin (`contact::track_contact`) to
//! round-off. In f32 a position carries ~1e-7 relative round-off: at 1 m from the origin and a
//! contact stiffness of 1e8–1e9 N/m that is a force of 10–100 N on a contact, a few thousandths
//! of the loads here. Each test states what it measured; the bounds are a few times that.

use crate::common;

use blockdem::d3::exec::Executor;
use blockdem::d3::gpu::GpuBackend;
use blockdem::d3::model::Model;
use blockdem::udec::gpu::{GpuOptions, Precision};
use common::Target;

const SAMPLE: &str = include_str!("../../examples/d3_two_tetrahedra.dat");

/// Runs a D3 deck on the CPU (None) or on the GPU with `options`.
fn run(deck: &str, gpu: Option<&GpuOptions>) -> Model {
    let commands = blockdem::d3::deck::parse_deck(deck, "<test>").unwrap();
    let backend: Box<dyn blockdem::d3::backend::Backend> = match gpu {
        None => Box::new(blockdem::d3::cpu::CpuBackend::new()),
        Some(o) => Box::new(GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"))),
    };
    let mut exec = Executor::with_backend(Box::new(std::io::sink()), "<test>", backend);
    exec.run(&commands).unwrap_or_else(|e| panic!("deck failed: {e}"));
    exec.model
}

/// Runs a D3 deck on the GPU with `options`, its files (SAVE, RESTART) in `dir`.
fn run_in_dir(deck: &str, o: &GpuOptions, dir: &std::path::Path) -> Model {
    let commands = blockdem::d3::deck::parse_deck(deck, "<test>").unwrap();
    let backend = Box::new(GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}")));
    let mut exec = Executor::with_backend(Box::new(std::io::sink()), "<test>", backend);
    exec.set_out_dir(dir);
    exec.run(&commands).unwrap_or_else(|e| panic!("deck failed: {e}"));
    std::mem::take(&mut exec.model)
}

/// The GPU targets present (tests/suite/common's): Vulkan f32 and f64, GL f32.
fn targets() -> Vec<GpuOptions> {
    common::gpu_options()
}

fn is_f32(o: &GpuOptions) -> bool {
    o.precision == Precision::F32
}

/// The largest difference of the blocks' centroids and of their velocities, each relative to a
/// scale (a length and a speed).
fn state_difference(a: &Model, b: &Model, length: f64, speed: f64) -> (f64, f64) {
    let dx = a.blocks.iter().zip(&b.blocks).map(|(p, q)| (p.centroid - q.centroid).length()).fold(0.0, f64::max);
    let dv = a.blocks.iter().zip(&b.blocks).map(|(p, q)| (p.velocity - q.velocity).length()).fold(0.0, f64::max);
    (dx / length, dv / speed)
}

/// The report's sample: the tetrahedron falls onto the fixed one and rocks on a vertex–face
/// contact; the GPU's velocities and contact force follow the CPU's.
#[test]
fn the_sample_runs_on_the_gpu_as_on_the_cpu() {
    let cpu = run(SAMPLE, None);
    for o in targets() {
        let gpu = run(SAMPLE, Some(&o));
        assert_eq!(gpu.cycle, cpu.cycle);
        let (a, b) = (&cpu.blocks[1], &gpu.blocks[1]);
        let dv = (a.velocity - b.velocity).length() / a.velocity.length();
        let dw = (a.angular_velocity - b.angular_velocity).length() / a.angular_velocity.length();
        let (fa, fb) = (cpu.contacts[0].normal_force(), gpu.contacts[0].normal_force());
        let df = (fa - fb).abs() / fa;
        eprintln!("{:?}: velocity {dv:.2e}, angular velocity {dw:.2e}, normal force {df:.2e} (relative)", o.precision);
        // Measured: f64 3e-5 in the velocity and force, 3e-4 in the angular velocity (the logical
        // contact tracked rather than found afresh); f32 1.8e-4, 1.7e-3 and 9.9e-4. In f32 the
        // contact is worked in a frame at the blocks' midpoint (`d3::gpu`), where the gap
        // (4.2e-5 m) is resolved at the round-off of the turning upper block's vertex offsets,
        // ulp(|l|) = 6e-8…1.2e-7 m for |l| ≈ 0.5…1.5 m, steps of kn·ulp = 6…12 N in the 4.2 kN
        // force (1.4e-3…2.9e-3): the force's bound is one such step. (In global axes the vertex
        // at (1, 0, 1) sat on round numbers and measured 1e-4, within the same steps.)
        let (tv, tw, tf) = if is_f32(&o) { (2e-3, 2e-2, 3e-3) } else { (3e-4, 3e-3, 3e-4) };
        assert!(dv < tv && dw < tw && df < tf, "{:?}: velocity {dv:e}, angular velocity {dw:e}, force {df:e}", o.precision);
        assert_eq!(gpu.contacts[0].type_name(), cpu.contacts[0].type_name());
    }
}

/// A free 1 × 2 × 3 box spinning about an axis near the intermediate one: no contacts, so the
/// GPU's law of motion is the CPU's (Euler's equations through the angular momentum, the
/// quaternion by the implicit midpoint rule): the same state to round-off in f64; L kept and
/// the energy within the scheme's O(Δt²) on both.
#[test]
fn a_tumbling_box_turns_on_the_gpu_as_on_the_cpu() {
    let deck = "START\nPROP MAT=1 D=1000 KN=1E7 KS=1E7\nBOX 0 1 0 2 0 3\nVELOCITY 0 1 0 2 0 3 0 0 0 0.1 2 0.1\nCYCLE 3000\n";
    let cpu = run(deck, None);
    let b0 = {
        let m = run(&deck.replace("CYCLE 3000", "CYCLE 0"), None);
        m.blocks[0].clone()
    };
    let l0 = b0.angular_momentum;
    let e0 = 0.5 * l0.dot(b0.angular_velocity_from(l0));
    for o in targets() {
        let gpu = run(deck, Some(&o));
        let (c, g) = (&cpu.blocks[0], &gpu.blocks[0]);
        let dq = (c.orientation - g.orientation).length().min((c.orientation + g.orientation).length());
        let dw = (c.angular_velocity - g.angular_velocity).length() / c.angular_velocity.length();
        let dl = (g.angular_momentum - l0).length() / l0.length();
        let de = (0.5 * g.angular_momentum.dot(g.angular_velocity_from(g.angular_momentum)) - e0).abs() / e0;
        eprintln!("{:?}: orientation {dq:.2e}, ω {dw:.2e}, ΔL {dl:.2e}, ΔE {de:.2e}", o.precision);
        // Measured after 3000 steps: f64 1e-15 (a polynomial sin/cos against libm's), f32 3e-6.
        let tol = if is_f32(&o) { 1e-4 } else { 1e-12 };
        assert!(dq < tol && dw < tol, "{:?}: orientation {dq:e}, ω {dw:e}", o.precision);
        assert!(dl < if is_f32(&o) { 1e-6 } else { 1e-14 }, "{:?}: L drifts {dl:e}", o.precision);
        assert!(de < 1e-3, "{:?}: energy {de:e}", o.precision);
    }
}

/// A box on a flat fixed base under gravity tilted 20° from the vertical, towards a direction
/// oblique to the axes (a box on an incline whose dip direction is oblique): settled first under
/// vertical gravity with mass damping (so that the contact springs do not ring), then with
/// φ = 11.3° (F = 0.2) and no damping it slides, s = ½ g t² (sin ψ − cos ψ tan φ).
#[test]
fn a_box_slides_down_an_oblique_incline_on_the_gpu_as_on_the_cpu() {
    let (psi, azimuth, mu, g) = (20f64.to_radians(), 30f64.to_radians(), 0.2, 10.0);
    let (gh, gz) = (g * psi.sin(), -g * psi.cos());
    let settle = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F={mu}\nBOX -2 3 -2 3 -1 0\nBOX 0 1 0 1 0 1\nFIX -2 3 -2 3 -1 -0.1\nGRAV 0 0 {gz}\nDAMP 1 160 MASS\nCYCLE 1000\n"
    );
    let deck = format!("{settle}DAMP 0 160 MASS\nGRAV {} {} {gz}\nCYCLE 2000\n", gh * azimuth.cos(), gh * azimuth.sin());
    let settled = run(&settle, None);
    let cpu = run(&deck, None);
    let start = settled.blocks[1].centroid;
    let t = cpu.time - settled.time;
    let expected = 0.5 * g * t * t * (psi.sin() - psi.cos() * mu);
    let slid = |m: &Model| {
        let d = m.blocks[1].centroid - start;
        d.x.hypot(d.y)
    };
    let s_cpu = slid(&cpu);
    // 1.1 % measured: the normal force rings a little once gravity tilts.
    assert!((s_cpu - expected).abs() < 0.02 * expected, "cpu: {s_cpu} vs {expected}");
    for o in targets() {
        let gpu = run(&deck, Some(&o));
        let s = slid(&gpu);
        let (dx, dv) = state_difference(&cpu, &gpu, expected, cpu.blocks[1].velocity.length());
        eprintln!("{:?}: slid {s:.6} m (cpu {s_cpu:.6}, closed form {expected:.6}); state {dx:.2e}, {dv:.2e}", o.precision);
        // Measured: f64 5e-7 of the slide and 1.2e-6 of the speed (the logical contacts tracked
        // rather than found afresh, the time step held over a batch); f32 5.2e-6 and 2.4e-5.
        let tol = if is_f32(&o) { (1e-4, 3e-3) } else { (1e-5, 1e-5) };
        assert!(dx < tol.0 && dv < tol.1, "{:?}: positions {dx:e}, velocities {dv:e} off the cpu's", o.precision);
        assert!((s - expected).abs() < 0.02 * expected, "{:?}: slid {s} vs {expected}", o.precision);
    }
}

/// A stack of three boxes on a fixed base, damped to rest: each contact carries the weight above
/// it, on both backends.
#[test]
fn a_stack_carries_its_weight_on_the_gpu_as_on_the_cpu() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nBOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nBOX 0 1 0 1 1 2\nBOX 0 1 0 1 2 3\n\
                FIX -1 2 -1 2 -1 -0.1\nGRAV 0 0 -10\nDAMP 1 160 MASS\nCYCLE 3000\n";
    let cpu = run(deck, None);
    let weight = 2000.0 * 10.0;
    let carried = |m: &Model| -> Vec<f64> {
        // The contact under box k (k = 1, 2, 3) carries 4 − k boxes.
        (1..4).map(|k| m.contacts.iter().find(|c| c.blocks[1] as usize == k && c.blocks[0] as usize == k - 1).map_or(0.0, |c| c.normal_force())).collect()
    };
    let f_cpu = carried(&cpu);
    for (k, f) in f_cpu.iter().enumerate() {
        let expected = (3 - k) as f64 * weight;
        assert!((f - expected).abs() < 1e-3 * expected, "cpu: contact under box {} carries {f} vs {expected}", k + 1);
    }
    for o in targets() {
        let gpu = run(deck, Some(&o));
        let f = carried(&gpu);
        let off = f.iter().zip(&f_cpu).map(|(a, b)| (a - b).abs() / b).fold(0.0, f64::max);
        eprintln!("{:?}: {f:?} vs cpu {f_cpu:?} ({off:.2e})", o.precision);
        // Measured: f64 4e-11, f32 6.7e-10 (in global axes 1.4e-3: a corner's overlap, 2.5e-6
        // m, was 20 ulps of its coordinate at z = 2; f32 now works each contact in a frame at
        // its blocks' midpoint, where upright boxes' corners meet exactly). Bound: one step of a
        // tilted box's corner, kn·ulp(0.5 m) = 60 N, 3e-3 of the top box's weight.
        let tol = if is_f32(&o) { 3e-3 } else { 1e-9 };
        assert!(off < tol, "{:?}: forces {f:?} vs {f_cpu:?}", o.precision);
    }
}

/// The stack of `verify`'s d3_stack (four unit boxes of 20 kN on a fixed base, heavy mass damping)
/// moved 1000 m from the origin along each axis: the interfaces carry the weight above on every
/// GPU target. In f32 each contact is worked in a frame at its blocks' midpoint (`d3::gpu`,
/// RELATIVE), so a corner's gap is resolved at the round-off of the vertex offsets there, not at
/// ulp(1000 m) = 6.1e-5 m, which with kn = 1e9 N/m made each corner's force move in steps of
/// 6.1e4 N, three times a box's weight: before the frame the stack never settled (measured on
/// lavapipe and llvmpipe: all four boxes bouncing together at 9.5e-3 m/s at the end, the
/// interfaces carrying 0 N, an error of 1.0 of the weight above).
#[test]
fn a_stack_far_from_the_origin_carries_its_weight_in_f32() {
    let shift = 1000.0;
    // A range (or a box's extent) moved by `shift` along each axis.
    let at = |r: [f64; 6]| r.map(|x| (x + shift).to_string()).join(" ");
    let mut deck = format!("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nBOX {}\n", at([-1.0, 2.0, -1.0, 2.0, -1.0, 0.0]));
    for k in 0..4 {
        deck += &format!("BOX {}\n", at([0.0, 1.0, 0.0, 1.0, k as f64, k as f64 + 1.0]));
    }
    deck += &format!("FIX {}\nGRAV 0 0 -10\nDAMP 1 160 MASS\nFRAC 0.1\nCYCLE 3317\n", at([-1.0, 2.0, -1.0, 2.0, -1.0, -0.1]));
    let weight = 2000.0 * 10.0;
    let error = |m: &Model| -> (f64, Vec<f64>) {
        let forces: Vec<f64> = (0..4u32).map(|k| m.contacts.iter().filter(|c| c.blocks == [k, k + 1]).map(|c| c.normal_force()).sum()).collect();
        let worst = forces.iter().enumerate().map(|(k, f)| (f - (4 - k) as f64 * weight).abs() / ((4 - k) as f64 * weight)).fold(0.0, f64::max);
        (worst, forces)
    };
    let (cpu, f_cpu) = error(&run(&deck, None));
    assert!(cpu < 1e-3, "cpu: {f_cpu:?} ({cpu:.2e})");
    for o in targets() {
        let (off, f) = error(&run(&deck, Some(&o)));
        eprintln!("{:?}: interfaces carry {f:?} ({off:.2e} of the weight above; cpu {cpu:.2e})", o.precision);
        // f32: a corner's gap is resolved at the round-off of its box's vertex offsets (exact
        // upright, ulp(0.5 m) = 6e-8 m once tilted enough to round them), a step of
        // kn·ulp = 60 N, 3e-3 of the top box's weight: the bound. Measured 1.7e-6 (lavapipe,
        // llvmpipe). f64: the CPU's to round-off, measured 1.2e-7 (the CPU's 1.1e-7).
        let tol = if is_f32(&o) { 3e-3 } else { 1e-6 };
        assert!(off < tol, "{:?}: interfaces carry {f:?} N ({off:.2e} of the weight above)", o.precision);
    }
}

/// A rerun on the GPU repeats the first bit for bit: every kernel sums in a fixed order and the
/// batches and detections depend on the state alone.
#[test]
fn gpu_reruns_repeat_bit_for_bit() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.3\nBOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nBOX 0.2 1.2 0.1 1.1 1.05 2.05\n\
                FIX -1 2 -1 2 -1 -0.1\nGRAV 1 2 -10\nVELOCITY 0.1 1.3 0 1.2 1 2.1 0.5 0 0 0 0 1\nCYCLE 1500\n";
    for o in targets() {
        let first = run(deck, Some(&o));
        let second = run(deck, Some(&o));
        assert!(first.cycle == 1500 && first.contacts.iter().any(|c| !c.logical.is_empty()));
        assert!(first == second, "{:?}: a rerun differs", o.precision);
        eprintln!("{:?}: two runs of 1500 cycles identical", o.precision);
    }
}

/// The command line: `run --backend gpu` takes a 3D deck to its end on D3's GPU backend (its
/// tables as the CPU's), and `compare` of a 3D deck reports the GPU against the CPU within a
/// tolerance.
#[test]
fn run_and_compare_take_3d_decks_on_the_gpu() {
    let Some(Target::Gpu(o)) = Target::gpu("vulkan", Precision::F64) else { return };
    assert_eq!(o.precision, Precision::F64);
    let exe = env!("CARGO_BIN_EXE_blockdem");
    let dir = std::env::temp_dir().join(format!("blockdem-d3gpu-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let run = std::process::Command::new(exe)
        .args(["run", "--backend", "gpu", "--adapter", "vulkan", "--precision", "f64", "examples/d3_two_tetrahedra.dat", "--out"])
        .arg(dir.join("run"))
        .output()
        .unwrap();
    let (out, err) = (String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "{out}\n{err}");
    assert!(err.contains("the D3 engine, on gpu") && out.contains("CURRENT CYCLE COUNT = 16") && out.contains("(VERTEX-FACE)"), "{out}\n{err}");
    let compare = std::process::Command::new(exe)
        .args(["compare", "examples/d3_two_tetrahedra.dat", "--adapter", "vulkan", "--precision", "f64", "--tolerance", "1e-3", "--out"])
        .arg(dir.join("compare"))
        .output()
        .unwrap();
    let (out, err) = (String::from_utf8_lossy(&compare.stdout), String::from_utf8_lossy(&compare.stderr));
    assert!(compare.status.success(), "{out}\n{err}");
    assert!(out.contains("of the contact distance") && dir.join("compare/compare.json").exists(), "{out}");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("compare/compare.json")).unwrap()).unwrap();
    assert_eq!(json["comparison"]["dim"], 3);
    assert!(json["comparison"]["velocity"]["relative"].as_f64().unwrap() < 1e-3);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The GPU's stage 4 between detections places each logical contact by its key
/// (`contact::place_logical`, twin of the WGSL's): right after a detection that is where the
/// detection put it (`contact::logical_contacts`), to round-off, for vertex–face contacts (a
/// stack's faces) and edge–edge ones (two crossed bars).
#[test]
fn a_logical_contact_is_placed_by_its_key_where_detection_found_it() {
    use blockdem::d3::contact::{common_plane, place_logical};
    use blockdem::d3::model::LogicalKind;
    let decks = [
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nBOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 -0.001 1\nBOX 0.2 1.2 0.1 1.1 0.9995 2\nFIX -1 2 -1 2 -1 -0.1\nCYCLE 0\n",
        // A bar along y lying across a bar along x: their long edges cross at four points.
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nBOX -1 1 -0.1 0.1 -0.2 0\nBOX -0.1 0.1 -1 1 -0.0005 0.2\nCYCLE 0\n",
    ];
    let mut kinds = (0, 0);
    for deck in decks {
        let m = run(deck, None);
        for c in m.contacts.iter().filter(|c| !c.logical.is_empty()) {
            let (a, b) = (&m.blocks[c.blocks[0] as usize], &m.blocks[c.blocks[1] as usize]);
            let tol = m.contact_tolerance();
            let plane = common_plane(a, b, tol);
            let n = plane.normal;
            let hi_a = a.vertices.iter().map(|v| n.dot(*v)).fold(f64::NEG_INFINITY, f64::max);
            let lo_b = b.vertices.iter().map(|v| n.dot(*v)).fold(f64::INFINITY, f64::min);
            for l in &c.logical {
                let (p, gap) = place_logical(l.kind, a.into(), b.into(), n, hi_a, lo_b, plane.separation);
                match l.kind {
                    LogicalKind::VertexFace { .. } => kinds.0 += 1,
                    LogicalKind::EdgeEdge { .. } => kinds.1 += 1,
                }
                let scale = a.shape.radius.min(b.shape.radius);
                assert!((p - l.point).length() < 1e-12 * scale, "{:?}: point {p} vs {}", l.kind, l.point);
                assert!((gap - l.gap).abs() < 1e-12 * scale, "{:?}: gap {gap} vs {}", l.kind, l.gap);
            }
        }
    }
    assert!(kinds.0 >= 4 && kinds.1 >= 4, "vertex–face {}, edge–edge {}", kinds.0, kinds.1);
}

/// SAVE and RESTART of a GPU run: the file keeps the device state (`d3::restart::DeviceState`:
/// the logical contacts the last detection found, dead ones too, the energy sums since the last
/// upload, the time step held, the f32 centroids' compensated pairs), so that CYCLE 600, SAVE,
/// RESTART, CYCLE 600 on the GPU is CYCLE 1200 bit for bit, in f64 and in f32 (where a fresh
/// detection at the restart would move the run off by the tracked contacts' difference).
#[test]
fn a_gpu_run_saved_and_restarted_goes_on_bit_for_bit() {
    // A block falls onto a fixed base beside another and slides on tilted gravity: its neighbour
    // lists are rebuilt on the way and its contacts carry shear history at the SAVE.
    let scene = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.3\nBOX -2 6 -2 2 -1 0\nBOX 0 1 -0.5 0.5 0.001 0.6\n\
                 BOX 2 3 -0.5 0.5 0 1\nFIX -2 6 -2 2 -1 -0.1\nGRAV 4 1 -9\nDAMP 0.05 50 MASS\n";
    let dir = std::env::temp_dir().join(format!("blockdem-d3gpu-restart-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let run_in = |deck: &str, o: &GpuOptions| run_in_dir(deck, o, &dir);
    for o in targets() {
        let whole = run_in(&format!("{scene}CYCLE 1200\n"), &o);
        let saved = run_in(&format!("{scene}CYCLE 600\nSAVE gpu.sav\n"), &o);
        assert!(saved.contacts.iter().any(|c| c.shear_force().length() > 0.0), "{:?}: shear history at the SAVE", o.precision);
        let file = blockdem::d3::restart::load(&dir.join("gpu.sav")).unwrap();
        let device = file.device.as_ref().expect("a GPU run's SAVE keeps its device state");
        assert!(file.resumable && device.f64_kernels == (o.precision == Precision::F64));
        let restarted = run_in("RESTART gpu.sav\nCYCLE 600\n", &o);
        assert_eq!(restarted.cycle, 1200);
        assert!(whole == restarted, "{:?}: CYCLE 600, SAVE, RESTART, CYCLE 600 differs from CYCLE 1200", o.precision);
        // A RESTART saved again before any CYCLE keeps the device state it restarted from.
        run_in("RESTART gpu.sav\nSAVE again.sav\n", &o);
        assert_eq!(blockdem::d3::restart::load(&dir.join("again.sav")).unwrap().device.as_ref(), Some(device));
        let again = run_in("RESTART again.sav\nCYCLE 600\n", &o);
        assert!(whole == again, "{:?}: RESTART, SAVE, RESTART, CYCLE 600 differs from CYCLE 1200", o.precision);
        // Without the device state (the file as version 2 wrote it) the restart detects afresh:
        // the run goes on, off the whole run by the tracked contacts' difference.
        let mut bare = file.clone();
        bare.device = None;
        blockdem::d3::restart::save(&dir.join("bare.sav"), &bare).unwrap();
        let afresh = run_in("RESTART bare.sav\nCYCLE 600\n", &o);
        let (dx, _) = state_difference(&whole, &afresh, 1.0, 1.0);
        // Measured: f64 6.8e-10 m, f32 4.2e-9 m: the device state is what makes it bit for bit.
        assert!(whole != afresh, "{:?}: a fresh detection at the restart happened to give the same run", o.precision);
        eprintln!("{:?}: restarted bit for bit; detecting afresh at the restart moves the blocks by {dx:.2e} m", o.precision);
        // The same file as save format 3 wrote it (the payload is the same): its f64 device state
        // means what it did and is taken; its f32 one kept vertices and contact points in global
        // axes, which the f32 kernels no longer read, so it is not taken (the run detects afresh,
        // as from a file without one, and a SAVE before any CYCLE does not pass it on).
        let mut v3 = std::fs::read(dir.join("gpu.sav")).unwrap();
        v3[8..12].copy_from_slice(&3u32.to_le_bytes());
        std::fs::write(dir.join("v3.sav"), &v3).unwrap();
        let old = blockdem::d3::restart::load(&dir.join("v3.sav")).unwrap();
        assert_eq!(old.device.as_ref().map(|d| d.absolute_f32), Some(is_f32(&o)));
        let from_v3 = run_in("RESTART v3.sav\nCYCLE 600\n", &o);
        if is_f32(&o) {
            assert!(from_v3 == afresh, "{:?}: a format-3 f32 device state is not taken: the run is the fresh detection's", o.precision);
            run_in("RESTART v3.sav\nSAVE v3again.sav\n", &o);
            assert_eq!(blockdem::d3::restart::load(&dir.join("v3again.sav")).unwrap().device, None);
        } else {
            assert!(from_v3 == whole, "{:?}: a format-3 f64 device state is taken as it was", o.precision);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A simply-deformable column (`d3::sdef`) on a fixed frictionless slab under gravity, its strain
/// ringing undamped and then under internal damping, on every GPU target as on the CPU: the
/// strain stage's kernels (`shaders/d3/sdef.wgsl`) are the CPU's twins; reruns repeat bit for
/// bit, and a SAVE and RESTART of the GPU run goes on bit for bit with the strain.
#[test]
fn a_deformable_column_strains_on_the_gpu_as_on_the_cpu() {
    let scene = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.0\nPROP MAT=2 D=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 F=0.3\n\
                 BOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 2 MAT 2\nFIX -1 2 -1 2 -1 -0.1\nCHANGE 0 1 0 1 0 2 SDEF\nGRAV 0 0 -10\n\
                 CYCLE 1500\nDAMP 0.3 40 INTERNAL\n";
    let deck = format!("{scene}CYCLE 1500\n");
    let cpu = run(&deck, None);
    let stress = |m: &Model| m.blocks[1].sdef.expect("simply deformable").stress;
    let s_cpu = stress(&cpu);
    let scale = s_cpu.iter().fold(0.0f64, |a, s| a.max(s.abs()));
    assert!(scale > 1e4, "the column is loaded: {s_cpu:?}");
    let dir = std::env::temp_dir().join(format!("blockdem-d3gpu-sdef-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let run_in = |deck: &str, o: &GpuOptions| run_in_dir(deck, o, &dir);
    for o in targets() {
        let gpu = run_in(&deck, &o);
        let s = stress(&gpu);
        let off = s.iter().zip(&s_cpu).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
        let (dx, _) = state_difference(&cpu, &gpu, 1.0, 1.0);
        eprintln!("{:?}: stress {s:?} vs cpu {s_cpu:?}: {off:.2e} of the largest; centroids {dx:.2e} m", o.precision);
        // Measured (lavapipe, llvmpipe): f64 1.6e-5, f32 6.5e-5 of the largest stress; centroids
        // 1.7e-9 and 6.3e-10 m. The column bounces on its slab undamped, so the step the CPU
        // renews each cycle (the logical contacts' lever arms move with the bounce) and the GPU
        // holds over a batch differ, as for a sliding rigid box (README, "D3"); settled, the
        // twins agree to round-off (2.5e-12 of the stress, `verify`'s d3_sdef_column). f32 adds
        // a corner force's quantum kn·ulp(1 m) = 60 N, 4e-3 of the column's 14 kN: the bound.
        let tol = if is_f32(&o) { 4e-3 } else { 1e-4 };
        assert!(off < tol, "{:?}: stress {s:?} vs {s_cpu:?}", o.precision);
        assert!(dx < 1e-7, "{:?}: centroids {dx:.2e} m apart", o.precision);
        assert!(gpu == run_in(&deck, &o), "{:?}: a rerun differs", o.precision);
        // CYCLE 1500, SAVE, RESTART, CYCLE 1500 is the whole run.
        let _ = run_in(&format!("{scene}SAVE sdef.sav\n"), &o);
        let restarted = run_in("RESTART sdef.sav\nCYCLE 1500\n", &o);
        assert!(restarted == gpu, "{:?}: the restarted run differs", o.precision);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Griffith's cracking of a simply-deformable column on the GPU: the criterion screened on the
/// device in the strain stage, the batch halted at the cycle the screen fires, the exact check,
/// the cut on the CPU and the state uploaded afresh (`d3::gpu`, "Cracking on the device"). The
/// column cracks at the cycle the CPU's does (382; the GPU holds each batch's time step where the
/// CPU renews it each cycle, which here moves no crack), in batches: before the crack it takes
/// four batches where it used to take one per cycle. The crack is vertical on every target (its
/// direction within the horizontal plane is round-off's: the two lateral stresses are equal).
#[test]
fn a_deformable_column_cracks_on_the_gpu_at_the_cpus_cycle() {
    let scene = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.0\nPROP MAT=2 D=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 F=0.0 TF=2000\n\
                 BOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 2 MAT 2 CONS 3\nFIX -1 2 -1 2 -1 -0.1\nCHANGE 0 1 0 1 0 2 SDEF\nGRAV 0 0 -10\n\
                 DAMP 1 80 MASS\nDAMP 1 80 INTERNAL\n";
    let model = run(scene, None);
    let run_on = |backend: &mut dyn blockdem::d3::backend::Backend| {
        let mut m = model.clone();
        let report = backend.run(&mut m, 400, &mut |_| true).unwrap_or_else(|e| panic!("{e}"));
        (m, report.cracks.iter().map(|c| (c.cycle, c.block, c.new_block)).collect::<Vec<_>>())
    };
    let (cpu, cpu_cracks) = run_on(&mut blockdem::d3::cpu::CpuBackend::new());
    assert_eq!(cpu.blocks.len(), 3, "the CPU's column cracked once");
    for o in targets() {
        let mut backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
        let (gpu, cracks) = run_on(&mut backend);
        assert_eq!(cracks, cpu_cracks, "{:?}: the CPU's crack", o.precision);
        // Batches: up to the energy checks (every 100 cycles), the one that halted at the
        // crack's cycle, and the rest; one per cycle before.
        assert!(backend.batches() <= 6, "{:?}: {} batches for 400 cycles", o.precision, backend.batches());
        assert_eq!(gpu.blocks.len(), 3, "{:?}: one crack", o.precision);
        for b in &gpu.blocks[1..] {
            let (lo, hi) = b.bounds();
            assert!(b.is_sdef() && hi.z - lo.z > 1.99, "{:?}: block {} spans {} m", o.precision, b.id, hi.z - lo.z);
        }
        // The halves are cut from the strained column: their volume is its strained one, the CPU's.
        let volume = |m: &Model| m.blocks[1..].iter().map(|b| b.volume).sum::<f64>();
        assert!((volume(&gpu) - volume(&cpu)).abs() < 1e-6, "{:?}: the halves' volume {} vs the cpu's {}", o.precision, volume(&gpu), volume(&cpu));
    }
}

/// The point-load law on the GPU (SL-85-1 ¶35f), with the joint law's contacts (constitutive 2:
/// each contact's stiffness JKN over its area, shared by its corners, uploaded with it): the
/// contact forces read back after every cycle, the criterion and the cut on the CPU. The squeezed
/// block of tests/suite/d3_split.rs, settled, then given a TF it exceeds, splits at the CPU's cycle
/// along the CPU's plane (y = 1: two unit cubes) on every target, and the crack leaves the
/// springs' energy as it was (the joint law), as on the CPU.
#[test]
fn a_squeezed_block_splits_by_the_point_load_law_on_the_gpu_as_on_the_cpu() {
    let deck =
        "START\nPROP MAT=1 D=1000 KN=1E10 KS=1E10 F=0.5 JKN=1E10 JKS=1E10 JF=0.5\nPROP MAT=2 D=1000 KN=1E10 KS=1E10 F=0.5 JKN=1E10 JKS=1E10 JF=0.5 TF=1E9\n\
                BOX -1 2 -1 3 -1 0 CONS 2\nBOX 0 1 0 2 0 1 MAT 2 CONS 2\nBOX 0 1 0 2 1 2 CONS 2\nFIX -1 2 -1 3 -1 -0.1\n\
                LOAD 0 1 0 2 1 2 0 0 -1E6\nGRAV 0 0 -10\nDAMP 1 700 MASS\nCYCLE 3000\nPROP MAT=2 TF=5E5\nCYCLE 1\n";
    let cpu = run(deck, None);
    assert_eq!(cpu.blocks.len(), 4, "the CPU's block cracked once");
    let halves = |m: &Model| -> Vec<(f64, f64)> {
        let mut h: Vec<(f64, f64)> = m.blocks.iter().filter(|b| b.id == 2 || b.id == 4).map(|b| (b.bounds().0.y, b.bounds().1.y)).collect();
        h.sort_by(|a, b| a.0.total_cmp(&b.0));
        h
    };
    for o in targets() {
        let gpu = run(deck, Some(&o));
        assert_eq!((gpu.blocks.len(), gpu.cycle), (4, cpu.cycle), "{:?}: one crack", o.precision);
        for ((g0, g1), (c0, c1)) in halves(&gpu).into_iter().zip(halves(&cpu)) {
            assert!((g0 - c0).abs() < 1e-4 && (g1 - c1).abs() < 1e-4, "{:?}: a half spans y {g0}..{g1}, the CPU's {c0}..{c1}", o.precision);
        }
        let e = gpu.energies();
        assert!(e.strain > 0.0 && e.released.abs() < 1e-3 * e.strain, "{:?}: released {} of the springs' {}", o.precision, e.released, e.strain);
    }
}

/// A steel cube fired at 30 m/s into three courses of four bricks that crack by the point-load
/// law: the ledger stays within 0.3 % of the cube's energy on the GPU, as on the CPU. Before each
/// crack the device's logical contacts (kept from the last detection) were what the cut carried
/// to the pieces: some of the parent's loaded corners were not found among them, their springs'
/// energy was booked as let go, and the ledger then grew by as much (f32: +1.8e4 J of 9.5e4 after
/// 71 cracks; the 60-brick wall +1.7e5 J). Now the CPU finds the logical contacts afresh on the
/// state read back before it cuts (`cpu::contact_stage_with`, as a detection does): f32 765 J
/// after 74 cracks, f64 25 J; the CPU 44 J after 60. A gap measured through a brick's side face
/// as it tilted through parallel to the normal (`contact::STEEP_SHARE`) made the rest: now the
/// CPU 37.9 J (0.040 %), f32 30.2 J (0.032 %), f64 54.7 J (0.058 %).
#[test]
fn a_struck_wall_cracks_on_the_gpu_and_keeps_its_energy() {
    let mut deck = String::from("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6 TF=2E5\nBOX -1 2.6 -1 1.2 -1 0\n");
    deck += &common::d3_brick_courses(3, 4);
    deck += "PROP MAT=2 D=7800 KN=1E10 KS=1E10 F=0.3\nBOX 0.65 0.95 -0.5 -0.2 0.15 0.45 MAT 2\nFIX -0.5 2.1 -0.5 0.7 -0.6 -0.4\nGRAV 0 0 -10\n\
             VELOCITY 0.6 1.0 -0.6 -0.1 0.1 0.5 0 30 0\nCYCLE 4400\n";
    let cpu = run(&deck, None);
    for (name, m) in
        std::iter::once(("cpu".to_string(), cpu)).chain(targets().into_iter().map(|o| (format!("{:?} {:?}", o.adapter, o.precision), run(&deck, Some(&o)))))
    {
        let e = m.energies();
        eprintln!("{name}: {} blocks, ledger {:.1} J of {:.4e} J ({:.3} %)", m.blocks.len(), e.ledger(), e.external_work, 100.0 * e.ledger() / e.external_work);
        assert!(m.blocks.len() > 30 && e.external_work > 9e4, "{name}: {} blocks, {e:?}", m.blocks.len());
        assert!(e.ledger().abs() < 0.003 * e.external_work, "{name}: ledger {} of {} ({} blocks)", e.ledger(), e.external_work, m.blocks.len());
    }
}

/// The struck wall's ledger through the impact (1.5 ms at FRACTION 0.1, then 0.05) on the GPU
/// in f64: an edge–edge logical contact that opens loaded lets its normal spring's energy go as
/// released (`force_law` in track_contact.wgsl, as the CPU's `contact::force_law`), a corner
/// the detection finds under a new key keeps its springs (`contact::carry_swapped`), and what
/// is left shrinks with the step. Before, the ledger stood at −1.6e-4 and −3.9e-4 of the work at
/// FRACTION 0.1 and 0.05, and released 4.3 % (now 1.2e-4, 7.3e-5 and 0.07 %).
#[test]
fn the_struck_walls_ledger_closes_with_the_step_on_the_gpu() {
    let Some(Target::Gpu(o)) = Target::gpu("vulkan", Precision::F64) else { return };
    let ledger = |fraction: f64, cycles: u64| {
        let deck = struck_wall().replace("FRACTION 0.1", &format!("FRACTION {fraction}")) + &format!("CYCLE {cycles}\n");
        let e = run(&deck, Some(&o)).energies();
        (e.ledger() / e.external_work, e)
    };
    let (coarse, _) = ledger(0.1, 1500);
    let (fine, e) = ledger(0.05, 3000);
    eprintln!("struck wall on the GPU: ledger {coarse:e} (FRACTION 0.1), {fine:e} (0.05) of the work; {e:?}");
    assert!(e.friction > 0.0 && e.external_work > 1e4 && e.released < 0.01 * e.external_work, "{e:?}");
    assert!(fine.abs() < 5e-4 && fine.abs() < 0.75 * coarse.abs(), "the imbalance shrinks with the step: {coarse:e} → {fine:e}");
}

/// How near the CPU's the kinetic energy of the struck wall after the impact lies on the GPU
/// (a share of the CPU's). The GPU moves its logical contacts with the blocks between
/// detections where the CPU finds them afresh every cycle, so the impact's scatter differs: 1.1 %
/// apart with partial detections, 0.1–0.2 % with whole ones, in f32 and f64 alike (lavapipe,
/// 1500 cycles; 1.9 % apart before corners changing their keys kept their springs,
/// `contact::carry_swapped`).
const KINETIC_AGREEMENT: f64 = 0.015;

/// The struck wall of twenty bricks (`common::d3_struck_wall`), the cube 1 cm off it (it
/// strikes at cycle ~300).
fn struck_wall() -> String {
    struck_wall_from(0.0)
}

/// [`struck_wall`] with the cube `gap` m farther from the wall.
fn struck_wall_from(gap: f64) -> String {
    common::d3_struck_wall(0.01 + gap, 0.1)
}

/// Partial detections ("Partial detections" in `d3::gpu`): a wall of twenty bricks struck by a
/// cube. Only the contacts of the blocks that moved are found afresh at a detection (most of the
/// wall stands still), and the run is the whole detections' run to within the impact's scatter:
/// the cube's momentum, the ledger (within 1 % of the work on both), and the kinetic energy left
/// after the impact, each near the CPU's.
#[test]
fn partial_detections_refresh_the_moved_blocks_and_run_as_whole_ones() {
    let built = run(&struck_wall(), None);
    let run_on = |backend: &mut dyn blockdem::d3::backend::Backend| {
        let mut m = built.clone();
        backend.run(&mut m, 1500, &mut |_| true).unwrap_or_else(|e| panic!("{e}"));
        m
    };
    let cpu = run_on(&mut blockdem::d3::cpu::CpuBackend::new());
    let cube = |m: &Model| m.blocks.last().unwrap().velocity;
    let ledger = |m: &Model| {
        let e = m.energies();
        e.ledger() / e.external_work
    };
    assert!(cube(&cpu).y < 9.0 && ledger(&cpu).abs() < 0.01, "cpu: the cube at {}, ledger {:e}", cube(&cpu), ledger(&cpu));
    for o in targets() {
        let mut runs = Vec::new();
        for whole in [false, true] {
            let mut backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
            backend.set_whole_detections(whole);
            let m = run_on(&mut backend);
            runs.push((m, backend.host_times()));
        }
        let [(partial, p), (whole, w)] = [runs.remove(0), runs.remove(0)];
        let share = |h: &blockdem::d3::gpu::HostTimes| h.refreshed as f64 / h.listed as f64;
        eprintln!(
            "{:?} {:?}: detections {} / {}, refreshed {:.3} / {:.3}; cube {} / {} (cpu {}); ledger {:e} / {:e} (cpu {:e})",
            o.adapter,
            o.precision,
            p.detections,
            w.detections,
            share(&p),
            share(&w),
            cube(&partial),
            cube(&whole),
            cube(&cpu),
            ledger(&partial),
            ledger(&whole),
            ledger(&cpu)
        );
        assert!(p.detections > 3 && share(&w) == 1.0 && share(&p) < 0.5, "{:?}: {p:?} {w:?}", o.precision);
        for m in [&partial, &whole] {
            assert!((cube(m) - cube(&cpu)).length() < 0.05 * cube(&cpu).length(), "{:?}: the cube at {} (cpu {})", o.precision, cube(m), cube(&cpu));
            assert!(ledger(m).abs() < 0.01, "{:?}: ledger {:e} of the work", o.precision, ledger(m));
            // The energy the impact left in motion, the CPU's to within KINETIC_AGREEMENT.
            let (k, k_cpu) = (m.energies().kinetic, cpu.energies().kinetic);
            eprintln!("{:?} {:?}: kinetic {k:.6e} J (cpu {k_cpu:.6e} J, {:.2e} apart)", o.adapter, o.precision, (k - k_cpu).abs() / k_cpu);
            assert!((k - k_cpu).abs() < KINETIC_AGREEMENT * k_cpu, "{:?}: kinetic {k} J against the cpu's {k_cpu} J", o.precision);
        }
    }
}

/// The energy check's contact terms on the device (`contact_energy`, "The energy check and the
/// last good state" in `d3::gpu`): the springs' strain energy of a loaded stack summed on the
/// device is the CPU's sum over the same state read back (`model::contact_energy`), and a contact
/// driven through (two boxes built half inside each other) is found there, as
/// `cpu::overlap_check` finds it.
#[test]
fn the_energy_check_sums_the_contacts_on_the_device_as_the_cpu_does() {
    let stack = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.3\nBOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nBOX 0.2 1.2 0.1 1.1 1 2\n\
                 FIX -1 2 -1 2 -1 -0.1\nGRAV 1 2 -10\n";
    let deep = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nBOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 -0.6 0.4\nFIX -1 2 -1 2 -1 -0.1\n";
    for o in targets() {
        for (deck, cycles, driven) in [(stack, 700, false), (deep, 0, true)] {
            let mut model = run(deck, None);
            let mut backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
            let mut report = blockdem::driver::CycleReport::default();
            backend.run_into(&mut model, cycles, &mut |_| true, &mut report).unwrap_or_else(|e| panic!("{e}"));
            let (strain, found) = backend.contact_energy(&model).unwrap_or_else(|e| panic!("{e}"));
            let cpu: f64 = model.contacts.iter().map(|c| blockdem::d3::model::contact_energy(c, &model.contact_material(c))).sum();
            let rel = (strain - cpu).abs() / cpu;
            eprintln!("{:?} {:?}: strain {strain:e} J on the device, {cpu:e} J on the CPU ({rel:.1e}); driven through: {found}", o.adapter, o.precision);
            assert!(cpu > 0.0 && rel < if is_f32(&o) { 1e-5 } else { 1e-12 }, "{:?}: {strain} against {cpu}", o.precision);
            assert_eq!(found, driven, "{:?}: driven through", o.precision);
            assert_eq!(blockdem::d3::cpu::overlap_check(&model).is_err(), driven);
        }
    }
}

/// A run that fails goes back to its last good state whole: the contacts' state of the last
/// check comes from the device's checkpoint (the model the run keeps has the contacts only as a
/// detection left them). A cube pushed into the slab at 20 m/s (BOUNDARY VELOCITY) is driven
/// through at cycle 108; the state it leaves is that of a run of 100 cycles on the same device,
/// bit for bit.
#[test]
fn a_failed_gpu_run_goes_back_to_the_last_checks_contacts() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nFIX -1 2 -1 2 -1 -0.1\n\
                BOUNDARY VELOCITY 0 1 0 1 0 1 0 0 -20\n";
    let built = run(deck, None);
    for o in targets() {
        let mut failed = built.clone();
        let mut backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
        let mut report = blockdem::driver::CycleReport::default();
        let e = backend.run_into(&mut failed, 3000, &mut |_| true, &mut report).expect_err("driven through");
        assert!(e.to_string().contains("overlap"), "{e}");
        let mut good = built.clone();
        let mut backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
        backend.run_into(&mut good, failed.cycle, &mut |_| true, &mut report).unwrap_or_else(|e| panic!("{e}"));
        eprintln!("{:?} {:?}: failed ({e}); back at cycle {}", o.adapter, o.precision, failed.cycle);
        assert_eq!(failed.cycle, 100);
        let loaded = |m: &Model| m.contacts.iter().flat_map(|c| &c.logical).map(|l| l.normal_force).sum::<f64>();
        assert!(loaded(&good) > 0.0);
        assert!(
            failed.contacts == good.contacts,
            "{:?}: the contacts are not the last check's: {} N against {} N",
            o.precision,
            loaded(&failed),
            loaded(&good)
        );
        assert!(failed == good, "{:?}: the state is not the last check's", o.precision);
    }
}

/// A detection that changes the number of contacts while the time step stays as it was (held
/// by a simply-deformable block's own limit, which no contact changes): the kernels must see the
/// new count (the params, which bound their loops and place each contact's bodies in the
/// adjacency, were written only where the step changed). A cube moving at 5 m/s strikes a
/// resting simply-deformable cube of stiff rock, no gravity: on the CPU the two swap their
/// momentum (equal masses, a head-on elastic strike); the GPU did not see the new contact, every
/// contact read its bodies from the wrong words, and the run stopped for growing energy.
#[test]
fn a_contact_made_while_the_step_holds_is_tracked_on_the_gpu() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.3\nPROP MAT=2 D=2000 K=1E12 G=6E11 KN=1E9 KS=1E9 F=0.3\n\
                BOX 0 1 0 1 0 1 MAT 2\nCHANGE 0 1 0 1 0 1 SDEF\nBOX 1.3 2.3 0 1 0 1\nVELOCITY 1.2 2.5 -1 2 -1 2 -5 0 0\nCYCLE 12000\n";
    let cpu = run(deck, None);
    let vx = |m: &Model| [m.blocks[0].velocity.x, m.blocks[1].velocity.x];
    assert!((vx(&cpu)[0] + 5.0).abs() < 1e-3 && vx(&cpu)[1].abs() < 1e-3, "cpu: {:?}", vx(&cpu));
    for o in targets() {
        let gpu = run(deck, Some(&o));
        let (dx, dv) = state_difference(&cpu, &gpu, 1.0, 5.0);
        eprintln!("{:?} {:?}: velocities {:?} (cpu {:?}); state {dx:.1e}, {dv:.1e}", o.adapter, o.precision, vx(&gpu), vx(&cpu));
        assert!(dx < 1e-4 && dv < 1e-4, "{:?}: {:?} against {:?}", o.precision, vx(&gpu), vx(&cpu));
    }
}

/// The time step each batch starts with comes from the state on the device (`critical_rows`,
/// `GpuBackend::device_timestep`): the CPU's rule (`Model::timestep`) on the same state read
/// back, to round-off in f64 and to f32's in f32, for a stack of a rigid and a simply-deformable
/// box resting tilted on a slab (lever arms off the centroids, the strain modes' compliance) and
/// for a box held by BOUNDARY VELOCITY against it (unyielding).
#[test]
fn the_time_step_from_the_device_is_the_cpus_rule() {
    let stack = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.3\nPROP MAT=2 D=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 F=0.3\n\
                 BOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nBOX 0.2 1.2 0.1 1.1 1 2 MAT 2\nCHANGE 0 1.3 0 1.2 1.1 2 SDEF\n\
                 FIX -1 2 -1 2 -1 -0.1\nGRAV 1 2 -10\n";
    let held = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBOX -1 2 -1 2 -1 0\nBOX 0 1 0 1 0 1\nBOX 0 1 0 1 1 2\n\
                FIX -1 2 -1 2 -1 -0.1\nBOUNDARY VELOCITY 0 1 0 1 1 2 0 0 -0.01\n";
    for o in targets() {
        for (name, deck) in [("stack", stack), ("held", held)] {
            let mut model = run(deck, None);
            let mut backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
            let mut report = blockdem::driver::CycleReport::default();
            backend.run_into(&mut model, 500, &mut |_| true, &mut report).unwrap_or_else(|e| panic!("{e}"));
            let device = backend.device_timestep(&model).unwrap_or_else(|e| panic!("{e}"));
            let cpu = model.timestep();
            let rel = (device - cpu).abs() / cpu;
            eprintln!("{:?} {:?} {name}: step {device:e} on the device, {cpu:e} on the CPU ({rel:.1e})", o.adapter, o.precision);
            assert!(cpu > 0.0 && rel < if is_f32(&o) { 1e-5 } else { 1e-12 }, "{:?} {name}: {device} against {cpu}", o.precision);
        }
    }
}

/// Spliced detections (`d3::gpu::splice`): a partial detection reads back only the contacts of
/// the blocks that moved and splices the fresh ones into the device's buffers, where it read
/// back and uploaded every contact, and renews the block records on the device where it uploaded
/// them. The struck wall, the cube 0.02 m farther off it, run both ways for 2000 cycles (the
/// cube's contacts made by a partial detection, others made and dropped as it goes through): in f64 every block's state and every contact (its normal and live logical
/// contacts) bit for bit the same; in f32 within 3.2e-7 m and 4.3e-5 m/s (a whole upload
/// re-splits each centroid's compensated pair from the f64 sum read back, which loses the low
/// part's last bits where it lies 2⁻³⁰ below the high one; the device keeps its pair); the
/// ledger's friction and released terms to round-off (banked by workgroup sums in the kernel
/// precision); and the spliced detections moved fewer bytes. Some of its detections keep the
/// list's keys (renewed in place), some change them.
#[test]
fn spliced_detections_leave_the_state_a_whole_upload_leaves() {
    let built = run(&struck_wall_from(0.02), None);
    for o in targets() {
        let mut runs = Vec::new();
        for whole in [false, true] {
            let mut backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
            backend.set_whole_uploads(whole);
            let mut m = built.clone();
            blockdem::d3::backend::Backend::run(&mut backend, &mut m, 2000, &mut |_| true).unwrap_or_else(|e| panic!("{e}"));
            runs.push((m, backend.host_times()));
        }
        let [(spliced, s), (whole, w)] = [runs.remove(0), runs.remove(0)];
        let (f, r) = (spliced.dissipated.friction, spliced.dissipated.released);
        let (wf, wr) = (whole.dissipated.friction, whole.dissipated.released);
        eprintln!(
            "{:?} {:?}: {} / {} detections, {} / {} bytes moved ({:.3}); {} contacts; friction {f:e} / {wf:e} J, released {r:e} / {wr:e} J",
            o.adapter,
            o.precision,
            s.detections,
            w.detections,
            s.detection_bytes,
            w.detection_bytes,
            s.detection_bytes as f64 / w.detection_bytes as f64,
            spliced.contacts.len(),
        );
        assert!(s.detections > 3 && s.detections == w.detections, "{:?}: {s:?} {w:?}", o.precision);
        // Both kinds of spliced detection: lists that kept their keys (renewed in place, the
        // adjacency kept) and lists that changed (merged, the adjacency made anew).
        assert!(s.kept_lists > 0 && s.kept_lists < s.detections, "{:?}: {s:?}", o.precision);
        let (dx, dv) = state_difference(&spliced, &whole, 1.0, 10.0);
        eprintln!("{:?} {:?}: state {dx:.1e}, {dv:.1e}", o.adapter, o.precision);
        if is_f32(&o) {
            // A whole upload re-splits each centroid's compensated pair from the f64 sum read
            // back, which does not hold a low part 2⁻³⁰ below a high one to its last bit.
            assert!(dx < 1e-6 && dv < 1e-4 && spliced.contacts.len() == whole.contacts.len(), "{:?}: {dx:e} {dv:e}", o.precision);
        } else {
            assert!(spliced.blocks == whole.blocks, "{:?}: the blocks differ", o.precision);
            assert!(spliced.contacts == whole.contacts, "{:?}: the contacts differ", o.precision);
        }
        let round = if is_f32(&o) { 1e-5 } else { 1e-12 };
        assert!(f > 0.0 && (f - wf).abs() <= round * f && (r - wr).abs() <= round * (f + r), "{:?}: the ledger", o.precision);
        assert!(s.detection_bytes < w.detection_bytes, "{:?}: {s:?} {w:?}", o.precision);
    }
}

/// A splice's plan (`d3::gpu::splice::splice_plan`): for each contact of the new list its
/// source (kept: its index in the old list; fresh: its index among the fresh) and the start of
/// its run. A contact renewed in its place with its run's keys leaves the old keys standing (none
/// copied); one more logical contact moves every run after it by one; a contact dropped shifts
/// the kept ones past it; counts that do not add up are an error, not a panic.
#[test]
fn a_splice_plan_names_each_contact_its_source_and_run() {
    use blockdem::d3::gpu::layout::SPLICE_FRESH;
    use blockdem::d3::gpu::splice::{splice_plan, Keys};
    let model = run(&format!("{}CYCLE 10\n", struck_wall()), None);
    let n = model.contacts.len();
    let lists: Vec<Vec<_>> = model.contacts.iter().map(|c| c.logical.iter().map(|l| l.kind).collect()).collect();
    let old = Keys::from_lists(&lists);
    let k = model.contacts.iter().position(|c| c.logical.len() >= 2).expect("a touching contact");
    assert!(k + 2 < n, "{k} of {n}");
    // Renewed in place, the same keys.
    let (sources, keys) = splice_plan(&model.contacts, &[k], (&[k], n), &old, |_| false).unwrap();
    assert!(keys.is_none());
    let expected: Vec<[u32; 2]> = (0..n).map(|i| [if i == k { SPLICE_FRESH } else { i as u32 }, old.start(i)]).collect();
    assert_eq!(sources, expected);
    // One logical contact more on the fresh contact.
    let mut more = model.clone();
    let extra = more.contacts[k].logical[0];
    more.contacts[k].logical.push(extra);
    let (sources, keys) = splice_plan(&more.contacts, &[k], (&[k], n), &old, |_| false).unwrap();
    let keys = keys.expect("keys made anew");
    assert_eq!(keys.run(k).len(), old.run(k).len() + 1);
    for (i, &source) in sources.iter().enumerate() {
        let shift = u32::from(i > k);
        assert_eq!(source, [if i == k { SPLICE_FRESH } else { i as u32 }, old.start(i) + shift], "contact {i}");
        if i != k {
            assert_eq!(keys.run(i), old.run(i), "contact {i}");
        }
    }
    // Contact k dropped, none fresh.
    let mut fewer = model.clone();
    fewer.contacts.remove(k);
    let (sources, keys) = splice_plan(&fewer.contacts, &[], (&[k], n), &old, |_| false).unwrap();
    let keys = keys.expect("keys made anew");
    assert_eq!(sources.len(), n - 1);
    for (i, &[source, _]) in sources.iter().enumerate() {
        let from = if i < k { i } else { i + 1 };
        assert_eq!(source, from as u32, "contact {i}");
        assert_eq!(keys.run(i), old.run(from), "contact {i}");
    }
    // Counts that do not add up, or a kept stretch that ends on a moved block's contact.
    assert!(splice_plan(&fewer.contacts, &[], (&[], n), &old, |_| false).is_err());
    assert!(splice_plan(&fewer.contacts, &[], (&[k], n), &old, |_| true).is_err());
}

/// `splice_contacts` on the device is its Rust twin (`d3::gpu::splice::splice_contacts`) bit for
/// bit: records kept and fresh in a shuffled order over several workgroups (a kept contact named
/// twice, runs of no logical contacts, a subnormal and a negative zero among the values), the
/// output's records, logical contacts and the workgroups' banks.
#[test]
fn the_splice_kernel_is_its_twin() {
    use blockdem::d3::gpu::layout::{Contact, Logical, Real};
    use blockdem::d3::gpu::splice::splice_contacts;
    fn check<R: Real>(backend: &GpuBackend, what: &str) {
        let r = R::from_f64;
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        let records = |n: usize, next: &mut dyn FnMut() -> u64| {
            let mut contacts = Vec::new();
            let mut logicals = Vec::new();
            for k in 0..n {
                let count = (next() % 5) as u32;
                let value = |next: &mut dyn FnMut() -> u64| r((next() % 20_001) as f64 / 1000.0 - 10.0);
                contacts.push(Contact::<R> {
                    nx: value(next),
                    ny: if k == 3 { r(-0.0) } else { value(next) },
                    nz: value(next),
                    kn: r(1e9),
                    ks: r(5e8),
                    friction: r(0.5),
                    friction_work: r((next() % 1000) as f64 / 7.0),
                    released_work: r((next() % 1000) as f64 / 3.0),
                    block1: k as u32,
                    block2: k as u32 + 1,
                    logical_start: logicals.len() as u32,
                    logical_count: count,
                    ..Default::default()
                });
                for j in 0..count {
                    logicals.push(Logical::<R> {
                        px: value(next),
                        py: value(next),
                        pz: value(next),
                        gap: if j == 1 { r(1e-40) } else { value(next) },
                        normal_force: value(next),
                        sx: value(next),
                        kind: j % 3,
                        v1: (next() % 8) as u32,
                        live: (next() % 4 != 0) as u32,
                        ..Default::default()
                    });
                }
            }
            (contacts, logicals)
        };
        let kept = records(300, &mut next);
        let fresh = records(120, &mut next);
        let mut sources = Vec::new();
        let mut start = 0u32;
        for k in 0..400u32 {
            let (source, count) = if next() % 3 == 0 {
                let i = (next() % 120) as u32;
                (blockdem::d3::gpu::layout::SPLICE_FRESH | i, fresh.0[i as usize].logical_count)
            } else {
                let i = if k == 7 { 5 } else { (next() % 300) as u32 };
                (i, kept.0[i as usize].logical_count)
            };
            sources.push([source, start]);
            start += count;
        }
        let twin = splice_contacts((&kept.0, &kept.1), (&fresh.0, &fresh.1), &sources);
        let device = backend.splice_contacts_on_device((&kept.0, &kept.1), (&fresh.0, &fresh.1), &sources).unwrap_or_else(|e| panic!("{e}"));
        let bits = |x: &[u8]| x.to_vec();
        assert!(twin.2.len() > 1, "{what}: one workgroup");
        assert!(bits(bytemuck::cast_slice(&device.0)) == bits(bytemuck::cast_slice(&twin.0)), "{what}: the contacts");
        assert!(bits(bytemuck::cast_slice(&device.1)) == bits(bytemuck::cast_slice(&twin.1)), "{what}: the logical contacts");
        assert!(bits(bytemuck::cast_slice(&device.2)) == bits(bytemuck::cast_slice(&twin.2)), "{what}: the banks {:?} against {:?}", device.2, twin.2);
    }
    on_every_target(check::<f32>, check::<f64>);
}

/// `renew_blocks` on the device is its Rust twin (`d3::gpu::splice::renew_blocks`) bit for bit:
/// blocks of random state over several workgroups, moved and not, their adjacency ranges, travel
/// and the sums that count from the upload renewed, the rest of each record left.
#[test]
fn the_renew_kernel_is_its_twin() {
    use blockdem::d3::gpu::layout::{Block, Real, RENEW_MOVED};
    use blockdem::d3::gpu::splice::renew_blocks;
    fn check<R: Real>(backend: &GpuBackend, what: &str) {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        let r = R::from_f64;
        let mut value = || r((next() % 20_001) as f64 / 1000.0 - 10.0);
        let blocks: Vec<Block<R>> = (0..300)
            .map(|k| Block::<R> {
                cx: value(),
                vx: value(),
                travel: value(),
                peak_travel: value(),
                work: value(),
                damping_work: value(),
                dashpot_work: value(),
                radius: r(0.3),
                adjacency_start: 7,
                adjacency_count: 3,
                vertex_start: k,
                finite: 1,
                ..Default::default()
            })
            .collect();
        let renewals: Vec<[u32; 2]> = (0..300u32).map(|k| [5 * k, (k % 6) | if k % 3 == 0 { RENEW_MOVED } else { 0 }]).collect();
        let mut twin = blocks.clone();
        renew_blocks(&mut twin, &renewals);
        let device = backend.renew_blocks_on_device(&blocks, &renewals).unwrap_or_else(|e| panic!("{e}"));
        assert!(twin[3].travel == r(0.0) && twin[4].travel == blocks[4].travel && twin[4].adjacency_count == 4, "{what}: the twin");
        assert!(bytemuck::cast_slice::<_, u8>(&device) == bytemuck::cast_slice::<_, u8>(&twin), "{what}: the records");
    }
    on_every_target(check::<f32>, check::<f64>);
}

/// A xorshift generator from `seed` (the kernels' twin tests' records).
fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    }
}

/// A twin test's check on each target in its precision (`single` for f32, `double` for f64), with
/// a backend of it and its name.
fn on_every_target(single: fn(&GpuBackend, &str), double: fn(&GpuBackend, &str)) {
    for o in targets() {
        let backend = GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}"));
        let what = format!("{:?} {:?}", o.adapter, o.precision);
        match o.precision {
            Precision::F32 => single(&backend, &what),
            Precision::F64 => double(&backend, &what),
        }
    }
}

/// A spin past what the kernels hold (VELOCITY's 1e30 rad/s on a 5 cm tetrahedron: |ω|·Δt
/// overflows f32 in the turn's axis-angle quaternion) made the orientation NaN, whose travel no
/// too-fast check saw (a NaN compares false): the run went on 30 cycles and left a NaN angular
/// velocity (found by tests/suite/d3_random_decks.rs). The law of motion now flags the block not
/// finite: the run stops at cycle 1, naming the line, and hands back the last good state.
#[test]
fn a_spin_past_the_precision_stops_the_run_at_the_last_good_state() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nBOX -2 6 -2 6 -1 0\nFIX -3 7 -3 7 -2 0\nGRAV 0 0 -10\n\
                BLOCK (0,2.678,0.2) (0.05,2.678,0.2) (0,2.728,0.2)\n+ (0,2.678,0.2) (0,2.678,0.25) (0.05,2.678,0.2)\n\
                + (0,2.678,0.2) (0,2.728,0.2) (0,2.678,0.25)\n+ (0.05,2.678,0.2) (0,2.678,0.25) (0,2.728,0.2)\n\
                VELOCITY 0 0.05 0 4.72 0 3.86 0 0 0 1E30 0 0\nCYCLE 30\nSTOP\n";
    let commands = blockdem::d3::deck::parse_deck(deck, "t.dat").unwrap();
    for o in targets() {
        let backend = Box::new(GpuBackend::new(&o.adapter, o.precision).unwrap_or_else(|e| panic!("{e}")));
        let mut exec = Executor::with_backend(Box::new(std::io::sink()), "t.dat", backend);
        let e = match exec.run(&commands) {
            Ok(()) => panic!("{:?} {}: the run went on to cycle {}", o.adapter, o.precision, exec.model.cycle),
            Err(e) => e.to_string(),
        };
        assert!(e.starts_with("t.dat:11:") && e.contains("at cycle 1") && e.contains("block 2"), "{:?} {}: {e}", o.adapter, o.precision);
        assert_eq!(exec.model.cycle, 0, "{:?} {}", o.adapter, o.precision);
        for b in &exec.model.blocks {
            assert!(b.centroid.is_finite() && b.velocity.is_finite() && b.angular_velocity.is_finite(), "{:?} {}: block {}", o.adapter, o.precision, b.id);
        }
    }
}
