//! Fluid with deformable blocks (issue 30 with issues 28 and 29; SL-85-1 Appendix A ¶3, ¶6–9,
//! ¶19): the domain pressures load a simply-deformable block's applied stress and a zoned
//! block's boundary grid points (`model::fluid::deformable_pressure_loads`), the voids follow
//! the strained corners and the grid points, and the energy ledger books the pressures' work.
//! Closed forms: a block pressed on all sides by p takes the stress −p (in plane strain its
//! volumetric strain is −p/(K + G/3)); a pressurized cavity between deformable blocks in a fixed
//! frame keeps its ledger and its mass balance. The GPU runs both cavities as the CPU does.

use crate::common;

use blockdem::udec::model::domain::DomainKind;
use blockdem::udec::model::fluid::stored_volume;
use blockdem::udec::model::Model;
use common::{run_ok, sample, Target};

/// The outside pressure of the lone blocks, Pa.
const P: f64 = 1e5;
/// The blocks' moduli (K, G).
const K: f64 = 1e8;
const G: f64 = 6e7;

/// A lone unit square, `kind` (SDEF or FDEF with its GENERATE), under the outer domain's
/// pressure P; its internal modes (or grid points) damped to rest.
fn lone(kind: &str) -> String {
    let (change, damp) = match kind {
        "SDEF" => ("CHANGE -1 2 -1 2 SDEF\n", "DAMP 0.5 191 INTERNAL\n"),
        _ => ("CHANGE -1 2 -1 2 FDEF\nGEN -1 2 -1 2 AUTO 0.4\n", "DAMP 0.5 300 MASS\n"),
    };
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5 K={K:e} G={G:e} CPERM=1E-9\nROUND 0.05\nBLOCK 0,0 1,0 1,1 0,1\n{change}\
         FLUID 1000 1E9\nPFIX OUTER {P:e}\n{damp}CYCLE 3000\n"
    )
}

/// The ledger's error against the energy in play, and that no warning was given.
fn assert_ledger(model: &Model, log: &str, tolerance: f64) -> f64 {
    let e = model.energies();
    let rel = e.ledger().abs() / e.scale();
    assert!(rel < tolerance, "ledger {:e} of {:e} ({rel:e}): {e:?}", e.ledger(), e.scale());
    assert!(e.fluid_work > 0.0, "the pressures did work: {e:?}");
    assert!(!log.contains("THE ENERGY BALANCE IS"), "no ledger warning: {log}");
    rel
}

/// The mass balance: the fluid stored and what crossed the fixed domains add up.
fn assert_mass_balance(model: &Model) {
    let f = model.fluid.unwrap();
    let stored = stored_volume(model.domains.as_ref().unwrap(), f.bulk);
    assert!(f.balance_error(stored).abs() <= 1e-12 * stored.max(1.0), "{} of {stored}", f.balance_error(stored));
}

/// A simply-deformable block pressed on all sides by p: its applied stress times area is −p
/// times its (strained) area, its internal stress −p in both directions and no shear, its
/// volumetric strain −p/(K + G/3) (plane strain: σ11 = σ22 = 2(λ + G)·ε with λ = K − 2G/3). The
/// stress is −p·(1 + ε_v) exactly (the pressure acts on the strained boundary), which is −p to
/// 1e-3 here. Measured: ledger 1e-5 of the work done.
#[test]
fn a_simply_deformable_block_pressed_on_all_sides_takes_the_pressure_as_its_stress() {
    let (model, log) = run_ok(&lone("SDEF"));
    let s = model.sdef_of(0).expect("the block is simply deformable");
    let ev = s.strain[0] + s.strain[2];
    let expect = -P / (K + G / 3.0);
    assert!((ev - expect).abs() < 2e-3 * expect.abs(), "ε_v {ev:e}, closed form {expect:e}");
    for sigma in [s.stress[0], s.stress[2]] {
        assert!((sigma + P * (1.0 + ev)).abs() < 1e-6 * P, "σ {sigma:e}, −p(1 + ε_v) {:e}", -P * (1.0 + ev));
        assert!((sigma + P).abs() < 2e-3 * P, "σ {sigma:e}");
    }
    assert!(s.stress[1].abs() < 1e-9 * P && s.strain[1].abs() < 1e-15, "{s:?}");
    // The applied stress is the pressure's alone: −p·A·I over the strained square.
    let strained = (1.0 + s.strain[0]) * (1.0 + s.strain[2]);
    assert!((s.applied[0] + P * strained).abs() < 1e-9 * P && (s.applied[3] + P * strained).abs() < 1e-9 * P, "{:?}", s.applied);
    // It does not move: the pressures' force and moment cancel.
    let b = &model.blocks[0];
    assert!(b.velocity[0].abs() + b.velocity[1].abs() < 1e-12 && (b.centroid[0] - 0.5).abs() < 1e-12, "{b:?}");
    assert_ledger(&model, &log, 1e-3);
}

/// A zoned block pressed on all sides by p: every zone takes σ11 = σ22 = −p and no shear, the
/// patch test with the pressures' grid point loads (each boundary edge's force split between
/// its two grid points). Measured: 2.5e-5·p off in every zone (the strained boundary), ledger
/// 1.5e-4.
#[test]
fn a_zoned_block_pressed_on_all_sides_takes_the_pressure_in_every_zone() {
    let (model, log) = run_ok(&lone("FDEF"));
    let f = model.fdef_of(0).expect("the block is fully deformable");
    assert!(f.zones.len() > 8, "zoned: {}", f.zones.len());
    for (z, zone) in f.zones.iter().enumerate() {
        let s = zone.stress;
        assert!((s[0] + P).abs() < 1e-3 * P && (s[2] + P).abs() < 1e-3 * P && s[1].abs() < 1e-3 * P, "zone {}: {s:?}", z + 1);
    }
    // The outline's area shrank by the volumetric strain −p/(K + G/3).
    let outline: Vec<[f64; 2]> = f.gridpoints[..f.boundary as usize].iter().map(|g| g.position).collect();
    let area = shoelace(&outline).abs();
    let expect = 1.0 - P / (K + G / 3.0);
    assert!((area - expect).abs() < 2e-3 * (1.0 - expect), "area {area}, closed form {expect}");
    assert_ledger(&model, &log, 1e-3);
}

/// Twice the signed area of a polygon, halved.
fn shoelace(p: &[[f64; 2]]) -> f64 {
    0.5 * (0..p.len()).map(|i| p[i][0] * p[(i + 1) % p.len()][1] - p[(i + 1) % p.len()][0] * p[i][1]).sum::<f64>()
}

/// The deck of examples/fluid_deformable_cavity.dat with its blocks fully deformable.
fn cavity_fdef() -> String {
    sample("fluid_deformable_cavity.dat").replace("CHANGE 0 3 0 3 SDEF\n", "CHANGE 0 3 0 3 FDEF\nGEN 0 3 0 3 AUTO 0.5\n").replace("DAMP 0.5 100 INTERNAL\n", "")
}

/// The cavity of examples/fluid_deformable_cavity.dat after its run: the held domain at
/// (1.5, 1.5), its area, and the area of the hole as the blocks' corners (strained, or on the
/// grid points) bound it now. Each of the hole's four corners is a block's corner touching the
/// next block's face (block 4's at (1, 1) on block 1's top, block 1's at (2, 1) on block 2's left
/// side, …), and the void runs from that corner's foot on the face along the face to the next
/// block's corner: the polygon foot, corner, foot, corner, … (the slivers the blocks open as
/// they shrink away from the hole included).
fn hole(model: &Model) -> (f64, f64, f64) {
    let domains = model.domains.as_ref().unwrap();
    let d = blockdem::udec::model::fluid::domain_at(model, domains, [1.5, 1.5]).expect("the hole is a domain");
    let dom = &domains.list[d];
    assert_eq!(dom.kind, DomainKind::Regular);
    let corners = |b: usize| model.corner_positions(b);
    let corner_near = |b: usize, q: [f64; 2]| (0..corners(b).len()).min_by(|&x, &y| dist(corners(b)[x], q).total_cmp(&dist(corners(b)[y], q))).unwrap();
    // The point of block b's boundary nearest p, and the edge it lies on.
    let foot = |b: usize, p: [f64; 2]| {
        let c = corners(b);
        (0..c.len()).map(|i| (project(p, c[i], c[(i + 1) % c.len()]), i)).min_by(|x, y| dist(x.0, p).total_cmp(&dist(y.0, p))).unwrap()
    };
    // (block whose corner it is, the corner, the block whose face it touches), counter-clockwise.
    let at = [(3, [1.0, 1.0], 0), (0, [2.0, 1.0], 1), (1, [2.0, 2.0], 2), (2, [1.0, 2.0], 3)];
    let mut polygon = Vec::new();
    for (i, (b, q, face)) in at.into_iter().enumerate() {
        let (f, edge) = foot(face, corners(b)[corner_near(b, q)]);
        polygon.push(f);
        // Along the face to the next corner of the hole (clockwise round the face's block, whose
        // corners run counter-clockwise), by the corners between (a zoned block's boundary
        // grid points).
        let c = corners(face);
        let (next, q_next, _) = at[(i + 1) % 4];
        let last = corner_near(next, q_next);
        let mut k = edge;
        loop {
            polygon.push(c[k]);
            if k == last {
                break;
            }
            k = (k + c.len() - 1) % c.len();
        }
    }
    (dom.pressure, dom.area, shoelace(&polygon))
}

/// The point of segment a–b nearest p.
fn project(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let e = [b[0] - a[0], b[1] - a[1]];
    let t = (((p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1]) / (e[0] * e[0] + e[1] * e[1])).clamp(0.0, 1.0);
    [a[0] + t * e[0], a[1] + t * e[1]]
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// What both cavities must show: the run reaches its end, the ledger within `ledger` of the
/// energy in play, the mass balance, the hole held at 1 MPa and grown as the blocks moved out and
/// strained, its area that of its deformed corners now (the feet of the contacts at them lie
/// within their overlap, a few µm). Returns the model and the hole's pressure.
fn a_cavity_keeps_its_ledger(deck: &str, ledger: f64) -> (Model, f64) {
    let (model, log) = run_ok(deck);
    assert!(log.contains("CURRENT CYCLE COUNT = 4000"), "{log}");
    assert_ledger(&model, &log, ledger);
    assert_mass_balance(&model);
    let (p, area, corners) = hole(&model);
    assert_eq!(p, 1e6);
    assert!(area > 1.0 + 1e-3, "{area}");
    assert!((area - corners).abs() < 1e-4 * area, "domain {area}, corners {corners}");
    (model, p)
}

/// The cavity between simply-deformable blocks: the held pressure pushes them against the frame
/// and compresses them; the ledger books the pressures' work (measured 1.6e-5 of the energy in
/// play), the mass balance holds, the hole's area is the void between the strained corners.
#[test]
fn a_pressurized_cavity_between_simply_deformable_blocks_keeps_its_ledger() {
    let (model, p) = a_cavity_keeps_its_ledger(&sample("fluid_deformable_cavity.dat"), 1e-3);
    // Each block is compressed, by stresses of the order of the pressure.
    for b in 0..4 {
        let s = model.sdef_of(b).unwrap().stress;
        let mean = 0.5 * (s[0] + s[2]);
        assert!(mean < -0.2 * p && mean > -2.0 * p, "block {}: {s:?}", b + 1);
    }
    // The fluid leaks into the voids between the blocks and the frame.
    let f = model.fluid.unwrap();
    assert!(f.inflow > 0.0, "{}", f.inflow);
}

/// The same cavity between zoned blocks: the ledger (measured 4.6e-4: their grid points' fluid
/// work is booked with the mean velocity over each step, `cpu::zones::step_fdef`), the mass
/// balance, the hole's area from the grid points.
#[test]
fn a_pressurized_cavity_between_zoned_blocks_keeps_its_ledger() {
    let (model, p) = a_cavity_keeps_its_ledger(&cavity_fdef(), 2e-3);
    // Every zoned block is compressed on average.
    for b in 0..4 {
        let f = model.fdef_of(b).unwrap();
        let mean = f.zones.iter().map(|z| 0.5 * (z.stress[0] + z.stress[2])).sum::<f64>() / f.zones.len() as f64;
        assert!(mean < -0.1 * p && mean > -2.0 * p, "block {}: {mean:e}", b + 1);
    }
}

/// How far a GPU run of a cavity lies from the CPU's: the largest difference of a corner's
/// position (m), of a domain's pressure over the hole's (1 MPa), and of a block's stress over the
/// hole's pressure (an SDEF block's, or a zoned block's zones').
fn gpu_against_cpu(gpu: &Model, cpu: &Model) -> (f64, f64, f64) {
    let position = gpu.corners.iter().zip(&cpu.corners).map(|(a, b)| dist(a.position, b.position)).fold(0.0, f64::max);
    let (dg, dc) = (gpu.domains.as_ref().unwrap(), cpu.domains.as_ref().unwrap());
    assert_eq!(dg.list.len(), dc.list.len(), "the same domains");
    let pressure = dg.list.iter().zip(&dc.list).map(|(a, b)| (a.pressure - b.pressure).abs()).fold(0.0, f64::max) / 1e6;
    let mut stress = 0.0f64;
    for b in 0..4 {
        let pairs: Vec<([f64; 3], [f64; 3])> = match (gpu.sdef_of(b), cpu.sdef_of(b)) {
            (Some(g), Some(c)) => vec![(g.stress, c.stress)],
            _ => gpu.fdef_of(b).unwrap().zones.iter().zip(&cpu.fdef_of(b).unwrap().zones).map(|(g, c)| (g.stress, c.stress)).collect(),
        };
        for (g, c) in pairs {
            stress = stress.max((0..3).map(|i| (g[i] - c[i]).abs()).fold(0.0, f64::max) / 1e6);
        }
    }
    (position, pressure, stress)
}

/// A cavity deck split where its run starts: its set-up (to the held pressures and the damping)
/// run on the CPU and saved, then `RESTART`, `CYCLE 4000` for every backend to run. So every
/// backend starts from the CPU's f64 state and contacts: a GPU run of the whole deck reads its
/// `CYCLE 0` back in its own precision, and in f32 the next detection of these blocks, placed
/// face to face exactly, finds other contacts than the CPU's (18 domains against 8 at the second
/// CYCLE's start: rigid blocks too, before and after this test's subject; then positions differ
/// by millimetres). Returns the deck that restarts.
fn restarted(deck: &str, name: &str, cycles: u32) -> String {
    let dir = std::env::temp_dir().join(format!("blockdem-fluid-deformable-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("{name}.sav"));
    let (head, _) = deck.split_once("CYCLE 4000").expect("the cavity's run");
    let (_, log) = run_ok(&format!("{head}SAVE {}\nSTOP\n", file.display()));
    assert!(log.contains("STATE SAVED TO"), "{log}");
    format!("RESTART {}\nCYCLE {cycles}\nSTOP\n", file.display())
}

/// The GPU runs fluid with deformable blocks (the pressures' push on an SDEF block's applied
/// stress and a zoned block's grid points on the device, `pressure_pieces` and its gathers) as
/// the CPU does: a cavity from the same start on the CPU and the GPU target agrees within
/// `bound` (the largest difference of a corner's position in m, of a domain's pressure and of a
/// block's stress over the hole's 1 MPa), keeps its ledger and mass balance, and holds the hole
/// at its pressure with its area that of its deformed outline.
fn the_gpu_runs_a_cavity_as_the_cpu_does(target: &Target, deck: &str, name: &str, bound: (f64, f64, f64)) {
    let deck = restarted(deck, &format!("{name}-{}", target.name().replace([' ', ':'], "-")), 4000);
    let (cpu, _) = run_ok(&deck);
    let gpu = target.run(&deck);
    let (position, pressure, stress) = gpu_against_cpu(&gpu, &cpu);
    eprintln!("{name} on {}: positions {position:.2e} m, pressures {pressure:.2e}, stresses {stress:.2e} of 1 MPa", target.name());
    assert!(position < bound.0 && pressure < bound.1 && stress < bound.2, "{}: {position:e} m, {pressure:e}, {stress:e} against {bound:?}", target.name());
    // The ledger as the CPU's (1.6e-5 and 4.6e-4 of the energy in play on the CPU), the mass
    // balance to the precision's round-off.
    let (e, c) = (gpu.energies(), cpu.energies());
    let (rel, cpu_rel) = (e.ledger().abs() / e.scale(), c.ledger().abs() / c.scale());
    eprintln!("{name} on {}: ledger {rel:.2e} of the energy in play, the CPU's {cpu_rel:.2e}", target.name());
    assert!(rel < 3.0 * cpu_rel.max(1e-5) && e.fluid_work > 0.0, "{}: ledger {rel:e} (the CPU's {cpu_rel:e}): {e:?}", target.name());
    let f = gpu.fluid.unwrap();
    let stored = stored_volume(gpu.domains.as_ref().unwrap(), f.bulk);
    let tolerance = if target.is_f32() { 1e-6 } else { 1e-12 };
    assert!(f.balance_error(stored).abs() <= tolerance * stored, "{}: mass balance {} of {stored}", target.name(), f.balance_error(stored));
    let (p, area, corners) = hole(&gpu);
    assert_eq!(p, 1e6);
    assert!((area - corners).abs() < 1e-4 * area, "domain {area}, corners {corners}");
}

/// The SDEF cavity on every GPU target. Measured (positions m, pressures and stresses over
/// 1 MPa): lavapipe f64 1.4e-14, 0, 6.4e-13 (round-off); lavapipe and llvmpipe f32 1.2e-6,
/// 2.0e-7, 1.6e-4; ledgers 1.6e-5 (f64, as the CPU's) and 2.4e-5 (f32) of the energy in play.
/// Bounds: f64 near round-off, f32 a few times the measured.
fn the_gpu_runs_the_sdef_cavity_as_the_cpu_does(target: &Target) {
    if matches!(target, Target::Cpu) {
        return;
    }
    let bound = if target.is_f32() { (5e-6, 1e-6, 5e-4) } else { (1e-12, 1e-12, 1e-10) };
    the_gpu_runs_a_cavity_as_the_cpu_does(target, &sample("fluid_deformable_cavity.dat"), "sdef", bound);
}

/// The FDEF cavity on every GPU target. Measured: lavapipe f64 1.9e-7, 5.7e-7, 5.9e-5 (round-off,
/// 2e-13 of the stress, for its first 150 cycles, then grown by the run: at cycle 200 3e-10, at
/// 500 4e-7; the CPU's own zoned cavity is as sensitive, a split CYCLE of it moving millimetres);
/// lavapipe and llvmpipe f32 6.5e-7, 5.9e-5, 8.2e-5 with the voids followed by their boundary's
/// motion (`corner_moves_fdef`, `deformed_terms`; measured from their zoned outline each step
/// the pressures were 1.9e-2 off, bulkw·ΔA/A of the outline's rounding in a void of a few
/// litres, and the positions 1.3e-7); ledgers 4.6e-4 of the energy in play on both, as the
/// CPU's. Bounds a few times the measured, and in f64 the first 100 cycles to round-off.
fn the_gpu_runs_the_fdef_cavity_as_the_cpu_does(target: &Target) {
    if matches!(target, Target::Cpu) {
        return;
    }
    let bound = if target.is_f32() { (2e-6, 3e-4, 3e-4) } else { (1e-6, 3e-6, 3e-4) };
    the_gpu_runs_a_cavity_as_the_cpu_does(target, &cavity_fdef(), "fdef", bound);
    if !target.is_f32() {
        let deck = restarted(&cavity_fdef(), &format!("fdef-short-{}", target.name().replace([' ', ':'], "-")), 100);
        let (position, pressure, stress) = gpu_against_cpu(&target.run(&deck), &run_ok(&deck).0);
        eprintln!("fdef, 100 cycles, on {}: positions {position:.2e} m, pressures {pressure:.2e}, stresses {stress:.2e} of 1 MPa", target.name());
        assert!(position < 1e-13 && pressure < 1e-11 && stress < 1e-11, "{}: {position:e} m, {pressure:e}, {stress:e}", target.name());
    }
}

/// `gpu::flow::corner_moves`, the twin of the f32 kernels' `corner_moves_*` that follow a void of
/// deformable blocks by its boundary's motion, is how far the corners move in a step: over one
/// CPU cycle of either cavity while the held pressure squeezes its blocks, a zoned block's
/// corners (its boundary grid points' v·Δt) and a rigid block's (its rigid motion) to round-off,
/// an SDEF block's (the strain's increment taken at the strained offset) to the strain's order.
#[test]
fn corner_moves_are_the_corners_steps() {
    use blockdem::udec::backend::Backend as _;
    for (deck, name) in [(sample("fluid_deformable_cavity.dat"), "sdef"), (cavity_fdef(), "fdef")] {
        let (before, _) = run_ok(&deck.replace("CYCLE 4000", "CYCLE 40"));
        let mut after = before.clone();
        blockdem::udec::cpu::CpuBackend::new().run(&mut after, 1, &mut |_| true).expect("one more cycle");
        let moves = blockdem::udec::gpu::flow::corner_moves(&after, after.timestep);
        let (mut step, mut off, mut off_sdef) = (0.0f64, 0.0f64, 0.0f64);
        for (i, (a, b)) in after.corners.iter().zip(&before.corners).enumerate() {
            let d = [a.position[0] - b.position[0], a.position[1] - b.position[1]];
            step = step.max(d[0].hypot(d[1]));
            let e = (d[0] - moves[i][0]).hypot(d[1] - moves[i][1]);
            if after.sdef_of(a.block as usize).is_some() {
                off_sdef = off_sdef.max(e);
            } else {
                off = off.max(e);
            }
        }
        eprintln!("{name}: corners moved up to {step:.3e} m in the step; the twin off by {off:.1e} (rigid, zoned), {off_sdef:.1e} (SDEF)");
        assert!(step > 1e-9, "{name}: the blocks move ({step:e} m)");
        assert!(off <= 1e-9 * step, "{name}: rigid and zoned corners off by {off:e} of a step of {step:e}");
        assert!(off_sdef <= 1e-2 * step, "{name}: SDEF corners off by {off_sdef:e} of a step of {step:e}");
    }
}

/// A GPU rerun of either cavity repeats bit for bit (every gather in a fixed order).
fn gpu_reruns_are_bit_for_bit(target: &Target) {
    if matches!(target, Target::Cpu) {
        return;
    }
    use blockdem::udec::output::state_json::state_json;
    for (deck, name) in [(sample("fluid_deformable_cavity.dat"), "sdef"), (cavity_fdef(), "fdef")] {
        let deck = restarted(&deck, &format!("{name}-rerun-{}", target.name().replace([' ', ':'], "-")), 600);
        assert_eq!(state_json(&target.run(&deck)), state_json(&target.run(&deck)), "{name} on {}", target.name());
    }
}

common::every_backend!(the_gpu_runs_the_sdef_cavity_as_the_cpu_does, the_gpu_runs_the_fdef_cavity_as_the_cpu_does, gpu_reruns_are_bit_for_bit);

/// `--backend auto` (the GPU wrapped in `GpuOrCpu`, as `blockdem run` wraps a hardware adapter)
/// runs fluid with deformable blocks on the GPU where one is present: the same run as the GPU
/// backend's, bit for bit (it fell back to the CPU while the GPU refused such scenes).
#[test]
fn backend_auto_runs_fluid_with_deformable_blocks_on_the_gpu() {
    let Some(target) = Target::gpu("vulkan", blockdem::udec::gpu::Precision::F64) else { return };
    let json = blockdem::udec::output::state_json::state_json;
    for deck in [sample("fluid_deformable_cavity.dat"), cavity_fdef()] {
        let deck = deck.replace("CYCLE 4000", "CYCLE 300");
        let auto = blockdem::udec::backend::GpuOrCpu::new(target.backend(), || Box::new(blockdem::udec::cpu::CpuBackend::new()));
        let on_auto = blockdem::scenes::run_deck_on(&deck, Box::new(auto)).expect("--backend auto runs it");
        assert_eq!(json(&on_auto), json(&target.run(&deck)));
        assert_ne!(json(&on_auto), json(&run_ok(&deck).0), "not the CPU's run");
    }
}

/// CYCLE 1500, CYCLE 2500 is CYCLE 4000 bit for bit with simply-deformable blocks too: the
/// second CYCLE goes on from the domains, the loads (their share of the pressures included) and
/// the step the first left. (Zoned blocks are not: a split CYCLE of a dry zoned scene differs
/// from the whole one already: 2 mm on the FDEF cavity settling dry under gravity.)
#[test]
fn a_cycle_split_in_two_is_the_same_run_bit_for_bit_with_simply_deformable_blocks() {
    use blockdem::udec::output::state_json::state_json;
    let deck = sample("fluid_deformable_cavity.dat");
    let whole = run_ok(&deck).0;
    let split = run_ok(&deck.replace("CYCLE 4000", "CYCLE 1500\nCYCLE 2500")).0;
    assert_eq!(state_json(&whole), state_json(&split));
}
