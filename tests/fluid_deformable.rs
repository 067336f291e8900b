//! Fluid with deformable blocks (issue 30 with issues 28 and 29; SL-85-1 Appendix A ¶3, ¶6–9,
//! ¶19): the domain pressures load a simply-deformable block's applied stress and a zoned
//! block's boundary grid points (`model::fluid::deformable_pressure_loads`), the voids follow
//! the strained corners and the grid points, and the energy ledger books the pressures' work.
//! Closed forms: a block pressed on all sides by p takes the stress −p (in plane strain its
//! volumetric strain is −p/(K + G/3)); a pressurized cavity between deformable blocks in a fixed
//! frame keeps its ledger and its mass balance. The GPU refuses fluid with deformable blocks,
//! naming the CPU backend.

mod common;

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

/// The GPU runs fluid with rigid blocks only: a deck with deformable blocks is refused with a
/// message naming the CPU backend, nothing run; `--backend auto` runs it on the CPU.
#[test]
fn the_gpu_refuses_fluid_with_deformable_blocks_naming_the_cpu_backend() {
    let Some(target) = Target::gpu("vulkan", blockdem::udec::gpu::Precision::F64) else { return };
    for deck in [sample("fluid_deformable_cavity.dat"), cavity_fdef()] {
        let r = blockdem::scenes::run_deck_on(&deck, target.backend());
        let e = r.expect_err("the GPU refuses fluid with deformable blocks").to_string();
        assert!(e.contains("deformable") && e.contains("--backend cpu"), "{e}");
        // `--backend auto` (the GPU wrapped in `GpuOrCpu`, as `blockdem run` wraps a hardware
        // adapter) takes the refusal as a model the GPU cannot hold and runs the deck on the CPU:
        // the same run as the CPU backend's, bit for bit.
        let auto = blockdem::udec::backend::GpuOrCpu::new(target.backend(), || Box::new(blockdem::udec::cpu::CpuBackend::new()));
        let on_auto = blockdem::scenes::run_deck_on(&deck, Box::new(auto)).expect("--backend auto runs it on the CPU");
        let (on_cpu, _) = run_ok(&deck);
        let json = blockdem::udec::output::state_json::state_json;
        assert_eq!(json(&on_auto), json(&on_cpu));
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
