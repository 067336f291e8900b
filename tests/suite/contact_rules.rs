//! Rules of issue 2 item 4 that the closed-form scenes do not isolate, each on a scene built to
//! show it: point-load cracking (the criterion's threshold, the corner clearance, the new joint's
//! material), contact detection driven by displacement, flying blocks finding new contacts, shear
//! history kept through a contact update, cohesion and no tension beyond it. CPU f64.

use crate::common;

use blockdem::scenes::run_deck_on;
use blockdem::udec::backend::{Backend, CycleReport};
use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::model::Model;

fn run(deck: &str) -> Model {
    run_deck_on(deck, Box::new(CpuBackend::new())).unwrap_or_else(|e| panic!("{e}\n{deck}"))
}

/// Runs `cycles` more cycles of a model on the CPU backend, returning its report.
fn cycle(m: &mut Model, cycles: u64) -> CycleReport {
    CpuBackend::new().run(m, cycles, &mut |_| true).unwrap_or_else(|e| panic!("{e}"))
}

// ---------------------------------------------------------------------------------------------
// Point-load cracking (SL-85-1 Appendix A ¶15–16)
// ---------------------------------------------------------------------------------------------

/// A free 10 × 1 m beam (material 3, constitutive 2) squeezed between two fixed 90° wedges whose
/// rounded tips press into it by 5 mm at x = `a`, from above and below, with no gravity: equal,
/// opposite, collinear forces, so the beam stays put and the forces stay constant. Rounding 0.1:
/// a 90° tip's rounded surface lies 0.1(√2 − 1) = 0.0414 m inside its sharp tip, so the sharp
/// tips sit 0.0464 m inside the beam (under the overlap limit, half the rounding length, even
/// unrounded). The wedges are built pressing in on purpose: SET OVERLAP ACCEPT.
fn squeezed_beam(a: f64, tf: f64) -> String {
    let s = 0.005 + 0.1 * (2f64.sqrt() - 1.0);
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nPROP MAT=3 D=2000 KN=1E8 KS=1E8 F=0.5 TF={tf:e}\nROUND 0.1\nSET OVERLAP ACCEPT\n\
         BLOCK MAT=3 CONS=2 0,0 0,1 10,1 10,0\n\
         BLOCK {a},{top} {l},{up} {r},{up}\n\
         BLOCK {a},{bot} {r},{down} {l},{down}\n\
         FIX {l} {r} 1 3\nFIX {l} {r} -3 0\n",
        top = 1.0 - s,
        up = 2.0 - s,
        bot = s,
        down = s - 1.0,
        l = a - 1.0,
        r = a + 1.0,
    )
}

/// The point-load value (f1 + f2)/(2d²) of the two force-carrying contacts on the beam (block 1).
fn point_load_value(m: &Model) -> f64 {
    let loads: Vec<&blockdem::udec::model::Contact> = m.contacts.iter().filter(|c| (c.block1 == 0 || c.block2 == 0) && c.normal_force > 0.0).collect();
    assert_eq!(loads.len(), 2, "one contact per wedge: {:?}", m.contacts);
    let (p, q) = (loads[0].point, loads[1].point);
    let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
    (loads[0].normal_force + loads[1].normal_force) / (2.0 * d2)
}

#[test]
fn the_beam_cracks_when_the_point_load_value_reaches_tf_and_not_below() {
    // The value without cracking (TF = 0: no check at all): kn · 5 mm = 5e5 N each side, d ≈ 1 m.
    let mut probe = run(&format!("{}CYCLE 1\n", squeezed_beam(5.0, 0.0)));
    let v = point_load_value(&probe);
    assert!(v > 2e5 && v < 1e6, "value {v}");
    // The scene is static: 50 cycles later the value is the same to 1e-6 (round-off of a beam at
    // rest between two equal springs), far inside the ±2% margins below.
    cycle(&mut probe, 50);
    assert!((point_load_value(&probe) - v).abs() < 1e-6 * v, "the squeeze is static");

    // TF 2% above the value: never reached, no crack in 50 cycles.
    let m = run(&format!("{}CYCLE 50\n", squeezed_beam(5.0, 1.02 * v)));
    assert_eq!(m.blocks.len(), 3, "no crack below TF");
    // TF 2% below: the beam cracks at once, between the two contacts (x = 5), into two pieces.
    let mut m = run(&format!("{}CYCLE 0\n", squeezed_beam(5.0, 0.98 * v)));
    let report = cycle(&mut m, 5);
    assert_eq!(report.cracks.len(), 1, "{report:?}");
    let c = report.cracks[0];
    assert_eq!(c.block, 1);
    assert!(c.value >= 0.98 * v && (c.value - v).abs() < 1e-6 * v, "criterion {} against {v}", c.value);
    for end in [c.from, c.to] {
        assert!((end[0] - 5.0).abs() < 0.02, "crack end {end:?} lies under the wedges (x = 5)");
    }
    assert_eq!(m.blocks.len(), 4);
    // Both pieces keep the beam's material and constitutive number, and the area is conserved.
    let pieces: Vec<&blockdem::udec::model::Block> = m.blocks.iter().filter(|b| b.material == 3).collect();
    assert_eq!(pieces.len(), 2);
    assert!(pieces.iter().all(|b| b.constitutive == 2));
    assert!((pieces.iter().map(|b| b.area).sum::<f64>() - 10.0).abs() < 1e-9);
    // The new joint takes the block's material and constitutive number: the edges along the crack
    // are tagged 3 / 2 (an edge k → k+1 is tagged on corner k).
    let mut crack_edges = 0;
    for (i, b) in m.blocks.iter().enumerate().filter(|(_, b)| b.material == 3) {
        let corners = m.block_corners(i);
        for k in 0..corners.len() {
            let (p, q) = (corners[k].position, corners[(k + 1) % corners.len()].position);
            if (p[0] - c.from[0]).abs() < 0.02 && (q[0] - c.from[0]).abs() < 0.02 && (p[1] - q[1]).abs() > 0.5 {
                crack_edges += 1;
                assert_eq!((corners[k].edge_material, corners[k].edge_constitutive), (3, 2), "block {} edge {k}", b.id);
            }
        }
    }
    assert_eq!(crack_edges, 2, "one crack edge on each piece");
}

#[test]
fn no_crack_within_half_the_smallest_edge_of_a_corner() {
    // The beam's smallest edge is 1 m: a crack end must lie 0.5 m or more from every corner. With
    // the wedges at x = 0.3 both ends would be 0.3 m from a corner: no crack however low TF is
    // (here a millionth of the value); at x = 0.6 (0.6 m away) the same squeeze cracks it.
    let v = point_load_value(&run(&format!("{}CYCLE 1\n", squeezed_beam(0.3, 0.0))));
    let m = run(&format!("{}CYCLE 20\n", squeezed_beam(0.3, 1e-6 * v)));
    assert_eq!(m.blocks.len(), 3, "cracked too close to a corner");
    let mut m = run(&format!("{}CYCLE 0\n", squeezed_beam(0.6, 0.98 * v)));
    assert_eq!(cycle(&mut m, 5).cracks.len(), 1, "0.6 m from the corners the beam cracks");
}

/// A pair of loads is a point load only where the forces oppose (more than a right angle apart),
/// not merely where each pushes towards the other's point: a roof-shaped block (material 2, TF
/// 1 kPa; slopes of 0.3, 16.7°) carrying a block on each slope under gravity (damped to rest)
/// is pressed from above, its two loads tilted towards each other (down and towards the ridge).
/// The inner pair's value, (F1 + F2)/(2d²) = 4.3 kPa over d = 1.24 m, is four times TF and their points lie clear of the
/// corners, so the old test alone ("each towards the other") split the roof; now nothing cracks.
/// (The D3 wall that cracked under its own weight had two such loads a hair apart:
/// `d3_split::two_blocks_pressing_down_side_by_side_are_no_point_load_pair`.)
#[test]
fn two_loads_pressing_down_towards_each_other_are_no_point_load_pair() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.8\nPROP MAT=2 D=2000 KN=1E9 KS=1E9 F=0.8 TF=1E3\nROUND 0.02\n\
                BLOCK MAT=2 CONS=1 0,0 0,1 2,1.6 4,1 4,0\n\
                BLOCK 0.6,1.18 0.6,2.2 1.4,2.2 1.4,1.42\nBLOCK 2.6,1.42 2.6,2.2 3.4,2.2 3.4,1.18\n\
                BLOCK -1,-1 -1,0 5,0 5,-1\nFIX -2 6 -2 -0.3\nGRAV 0 -10\nDAMP 0.5 190\nCYCLE 3000\n";
    let m = run(deck);
    assert_eq!(m.blocks.len(), 4, "the roof cracked");
    let roof = m.blocks.iter().position(|b| b.material == 2).unwrap() as u32;
    // The two slopes' loads on the roof, each the force pressing into it (downwards).
    let loads: Vec<([f64; 2], [f64; 2], f64)> = m
        .contacts
        .iter()
        .filter(|c| (c.block1 == roof || c.block2 == roof) && c.normal_force > 0.0 && c.point[1] > 1.05)
        .map(|c| {
            let f = [c.normal_force * c.normal[0], c.normal_force * c.normal[1]];
            let f = if f[1] < 0.0 { f } else { [-f[0], -f[1]] };
            (c.point, f, c.normal_force)
        })
        .collect();
    assert_eq!(loads.len(), 4, "two corners on each slope: {loads:?}");
    // The nearest pair across the ridge: each towards the other, not opposing, over TF.
    let left = loads.iter().filter(|l| l.0[0] < 2.0).max_by(|a, b| a.0[0].total_cmp(&b.0[0])).unwrap();
    let right = loads.iter().filter(|l| l.0[0] > 2.0).min_by(|a, b| a.0[0].total_cmp(&b.0[0])).unwrap();
    let d = [right.0[0] - left.0[0], right.0[1] - left.0[1]];
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    assert!(dot(left.1, d) > 0.0 && dot(right.1, d) < 0.0, "each pushes towards the other: {left:?} {right:?}");
    assert!(dot(left.1, right.1) > 0.0, "the two forces are less than a right angle apart");
    let value = (left.2 + right.2) / (2.0 * dot(d, d));
    assert!(value > 4e3 && (d[0] - 1.24).abs() < 0.01, "value {value} over d = {d:?}");
}

// ---------------------------------------------------------------------------------------------
// Contact detection
// ---------------------------------------------------------------------------------------------

#[test]
fn contact_updates_follow_displacement_not_every_cycle() {
    // A block resting on a fixed base: after the first detection nothing moves past the update
    // tolerance, so 1000 cycles need no further update.
    let mut m = run("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\nGRAV 0 -10\nDAMP 0.5 50 MASS\nCYCLE 100\n");
    let rest = cycle(&mut m, 1000);
    assert!(rest.topology_updates <= 1, "a model at rest is updated {} times in 1000 cycles", rest.topology_updates);
    // A block flying at 5 m/s moves 5 · Δt = 4.5 mm a step; an update is due each time it has moved
    // the update tolerance (a fraction of the rounding length) since the last: many updates, but
    // far fewer than cycles.
    let mut m = run("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nVELOCITY 0 1 0 1 5 0\nCYCLE 0\n");
    // With the report's fixed tolerance (no speed margins), each update follows a displacement
    // of at most the tolerance: never more than one step past it.
    m.tol.margin_steps = 0.0;
    let mut fast = m.clone();
    let flying = cycle(&mut m, 1000);
    let per_update = 1000.0 / flying.topology_updates as f64;
    let step = 5.0 * m.timestep;
    assert!(flying.topology_updates >= 10 && per_update >= 3.0, "{} updates in 1000 cycles", flying.topology_updates);
    assert!(per_update * step <= m.tol.etol + step + 1e-12, "an update every {per_update} steps of {step} m; tolerance {}", m.tol.etol);
    // With speed margins (the default) the block is searched farther around and may move the
    // tolerance plus its margin, about `margin_steps` of its steps, between updates.
    fast.tol.margin_steps = blockdem::udec::model::DEFAULT_MARGIN_STEPS;
    let fewer = cycle(&mut fast, 1000);
    let margin = fast.tol.speed_margin(step);
    assert!(margin > 0.0 && (fast.blocks[0].update_margin - margin).abs() < 1e-12, "margin {} for {step} m a step", fast.blocks[0].update_margin);
    let per_update = 1000.0 / fewer.topology_updates as f64;
    assert!(
        per_update * step <= fast.tol.etol + margin + step + 1e-12 && per_update * step >= fast.tol.etol + margin - step,
        "an update every {per_update} steps of {step} m, margin {margin}"
    );
}

/// A 0.5 m projectile (density 8000) at 50 m/s into a small wall of 1 × 0.5 m bricks on a fixed
/// base, gravity on: 7 mm a step against an update tolerance of 25 mm.
fn projectile_into_bricks() -> Model {
    let mut deck =
        String::from("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6\nPROP MAT=2 D=8000 KN=1E9 KS=1E9 F=0.6\nROUND 0.1\nBLOCK -1,-0.5 -1,0 6,0 6,-0.5\n");
    for row in 0..3 {
        let y = 0.5 * row as f64;
        for col in 0..4 {
            let x = col as f64 + if row % 2 == 1 { 0.5 } else { 0.0 };
            deck += &format!("BLOCK {x},{y} {x},{} {},{} {},{y}\n", y + 0.5, x + 1.0, y + 0.5, x + 1.0);
        }
    }
    deck += "FIX -2 7 -1 0\nGRAV 0 -10\nBLOCK MAT=2 -2.25,0.5 -2.25,1 -1.75,1 -1.75,0.5\nVELOCITY -2.5 -1.5 0.5 1 50 0\nCYCLE 0\n";
    run(&deck)
}

#[test]
fn speed_margins_change_the_update_count_not_the_motion() {
    // Fast blocks are searched farther around and re-examined less often (`speed_margin`); the
    // contacts found early are open and carry no force, so the motion must be the same as with
    // the report's fixed tolerance, bit for bit, through the impact and the flying bricks.
    let mut fixed = projectile_into_bricks();
    fixed.tol.margin_steps = 0.0;
    let mut speedy = projectile_into_bricks();
    assert!(speedy.tol.margin_steps > 0.0, "margins are on by default");
    let (a, b) = (cycle(&mut fixed, 1500), cycle(&mut speedy, 1500));
    for (x, y) in fixed.blocks.iter().zip(&speedy.blocks) {
        let bits =
            |b: &blockdem::udec::model::Block| [b.centroid[0], b.centroid[1], b.rotation, b.velocity[0], b.velocity[1], b.angular_velocity].map(f64::to_bits);
        assert_eq!(bits(x), bits(y), "block {} moved differently with speed margins", x.id);
    }
    // The projectile hit the wall and moved bricks (the scene tests something).
    let hit = fixed.blocks.iter().filter(|b| !b.fixed && b.id != fixed.blocks.last().unwrap().id && b.velocity[0] > 1.0).count();
    assert!(hit >= 2, "{hit} bricks set moving");
    assert!(fixed.blocks.iter().all(|b| b.update_margin == 0.0), "no margins when margin_steps is 0");
    assert!(b.topology_updates * 3 < a.topology_updates, "{} contact updates with speed margins, {} without", b.topology_updates, a.topology_updates);
    // The margins made contacts beyond btol, which the fixed tolerance would have dropped: open,
    // no force. (Contacts between atol and btol exist either way, so they prove nothing.)
    // Looked at every 10 cycles of a third run.
    let mut probe = projectile_into_bricks();
    let mut early = 0;
    for _ in 0..150 {
        cycle(&mut probe, 10);
        for c in probe.contacts.iter().filter(|c| c.gap > probe.tol.btol) {
            assert!(c.normal_force == 0.0 && c.force == [0.0, 0.0], "an open contact with force: {c:?}");
            early += 1;
        }
    }
    assert!(early > 0, "no contact beyond btol: the margins were not used");
}

/// `model` run on a GPU target, contact updates spliced on the device or the whole list
/// uploaded; returns the model, the report and the number of splices.
fn gpu_run(t: &common::Target, m: Model, splice: bool, cycles: u64) -> (Model, CycleReport, u64) {
    let (m, report, gpu) = gpu_run_with(t, m, cycles, |gpu| gpu.set_contact_splice(splice));
    (m, report, gpu.contact_splices())
}

/// `model` run on a GPU target whose backend `set_up` configured first; returns the model, the
/// report and the backend.
fn gpu_run_with(
    t: &common::Target,
    mut m: Model,
    cycles: u64,
    set_up: impl FnOnce(&mut blockdem::udec::gpu::GpuBackend),
) -> (Model, CycleReport, blockdem::udec::gpu::GpuBackend) {
    let common::Target::Gpu(options) = t else { unreachable!("a GPU target") };
    let mut gpu = blockdem::udec::gpu::GpuBackend::new(options).unwrap_or_else(|e| panic!("{e}"));
    set_up(&mut gpu);
    let report = gpu.run(&mut m, cycles, &mut |_| true).unwrap_or_else(|e| panic!("{e} on {}", t.name()));
    (m, report, gpu)
}

/// A wall of `rows` × `cols` bricks on a fixed base, struck at its left end by a heavy block at
/// 50 m/s: most of the wall is far from the blocks that contact updates re-examine.
fn projectile_into_wall(rows: usize, cols: usize) -> Model {
    run(&wall_deck(rows, cols, ""))
}

/// The deck of `projectile_into_wall`, with `extra` commands after the bricks.
fn wall_deck(rows: usize, cols: usize, extra: &str) -> String {
    let mut deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6\nPROP MAT=2 D=8000 KN=1E9 KS=1E9 F=0.6\nROUND 0.1\nBLOCK -1,-0.5 -1,0 {w},0 {w},-0.5\n",
        w = cols + 1
    );
    for row in 0..rows {
        let y = 0.5 * row as f64;
        for col in 0..cols {
            let x = col as f64 + if row % 2 == 1 { 0.5 } else { 0.0 };
            deck += &format!("BLOCK {x},{y} {x},{} {},{} {},{y}\n", y + 0.5, x + 1.0, y + 0.5, x + 1.0);
        }
    }
    deck += extra;
    deck += &format!("FIX -2 {} -1 0\nGRAV 0 -10\nBLOCK MAT=2 -2.25,0.5 -2.25,1 -1.75,1 -1.75,0.5\nVELOCITY -2.5 -1.5 0.5 1 50 0\nCYCLE 0\n", cols + 2);
    deck
}

#[test]
fn a_partial_read_back_updates_as_the_whole_state_does() {
    // A contact update on the GPU reads back lists the device makes (`list_blocks.wgsl`) and then
    // only the blocks, corners and contacts it touches (`gpu::partial`); the rest of the model
    // stays stale until the run's last read-back, and the splice leaves unread contacts as the
    // device holds them. The update must re-examine the same blocks and make and drop the same
    // contacts as on the whole state read back, so the motion is the same bit for bit: every
    // block's position, rotation and velocity, every contact's forces. The ledger's dissipation
    // may differ in f32 by rounding only (an unread contact's slip work keeps adding up on the
    // device instead of moving to its f64 base at each update): to 1e-5 relative.
    partial_matches_whole(|| projectile_into_wall(8, 24));
}

#[test]
fn an_sdef_wall_splices_and_reads_partly_as_the_whole_state_does() {
    // The same with simply-deformable bricks: the lever arms follow their contacts through the
    // splice (`Engine::splice_levers`), and a partial update resets the re-examined blocks'
    // update strain from their extensions read back; motion, contacts and stresses the same bit
    // for bit as with the whole state read back at every update.
    partial_matches_whole(|| projectile_into_sdef_wall(8, 24));
}

/// A wall of `rows` × `cols` simply-deformable bricks (K 5e8, G 3e8) on a fixed base, struck by
/// the rigid heavy block of `projectile_into_wall`.
fn projectile_into_sdef_wall(rows: usize, cols: usize) -> Model {
    run(&wall_deck(rows, cols, &format!("PROP MAT=1 K=5E8 G=3E8\nCHANGE 0 {} 0 {} SDEF\n", cols + 1, rows)))
}

/// Runs `make()`'s model on every GPU target with partial read-backs always and never, and checks
/// that both make the same updates and end in the same state bit for bit (the ledger's slip work
/// to rounding in f32).
fn partial_matches_whole(make: impl Fn() -> Model) {
    for (adapter, precision) in common::GPU_TARGETS {
        let Some(t) = common::Target::gpu(adapter, precision) else { continue };
        let common::Target::Gpu(options) = &t else { unreachable!("a GPU target") };
        let go = |partial: bool| {
            let mut m = make();
            let mut gpu = blockdem::udec::gpu::GpuBackend::new(options).unwrap_or_else(|e| panic!("{e}"));
            gpu.set_partial_reads(if partial { blockdem::udec::gpu::PartialReads::Always } else { blockdem::udec::gpu::PartialReads::Never });
            let report = gpu.run(&mut m, 1500, &mut |_| true).unwrap_or_else(|e| panic!("{e} on {}", t.name()));
            (m, report, gpu.partial_updates(), gpu.contact_splices())
        };
        let (a, ra, partial, splices) = go(true);
        let (b, rb, none, _) = go(false);
        assert_eq!(none, 0, "no partial update when they are off");
        assert!(splices >= partial, "{splices} splices for {partial} partial updates on {}", t.name());
        // The updates while a few blocks move (47 of 106 here); once the bricks fly, an update
        // re-examines more than an eighth of the blocks, sweeps the grid and reads everything.
        assert!(partial >= 20 && ra.contacts_created > 10 && ra.contacts_dropped > 10, "{partial} partial updates on {}: {ra:?}", t.name());
        assert_eq!(
            (ra.topology_updates, ra.contacts_created, ra.contacts_dropped),
            (rb.topology_updates, rb.contacts_created, rb.contacts_dropped),
            "updates on {}",
            t.name()
        );
        let bits = |b: &blockdem::udec::model::Block| {
            [b.centroid[0], b.centroid[1], b.rotation, b.velocity[0], b.velocity[1], b.angular_velocity, b.update_margin].map(f64::to_bits)
        };
        for (x, y) in a.blocks.iter().zip(&b.blocks) {
            assert_eq!(bits(x), bits(y), "block {} on {}", x.id, t.name());
        }
        assert_eq!(a.contacts.len(), b.contacts.len(), "contacts on {}", t.name());
        // (The scene is chaotic: 3 or 4 bricks faster than 1 m/s by backend and precision, 11 to
        // 16 faster than 0.5 m/s after 1400–1600 cycles, the CPU's among them.)
        let moving = a.blocks.iter().filter(|b| b.velocity[0].hypot(b.velocity[1]) > 0.5).count();
        assert!(moving >= 10, "the projectile set {moving} bricks moving on {}", t.name());
        for (x, y) in a.contacts.iter().zip(&b.contacts) {
            assert_eq!((x.id, x.block1, x.corner, x.block2, x.feature), (y.id, y.block1, y.corner, y.block2, y.feature), "contact on {}", t.name());
            assert_eq!(
                [x.normal_force, x.shear_force, x.gap, x.shear_displacement].map(f64::to_bits),
                [y.normal_force, y.shear_force, y.gap, y.shear_displacement].map(f64::to_bits),
                "contact {} on {}",
                x.id,
                t.name()
            );
            let tol = if t.is_f32() { 1e-5 * (1.0 + x.slip_work.abs()) } else { 1e-9 * (1.0 + x.slip_work.abs()) };
            assert!((x.slip_work - y.slip_work).abs() <= tol, "contact {} on {}: slip work {} against {}", x.id, t.name(), x.slip_work, y.slip_work);
        }
        for (k, (x, y)) in a.sdef.iter().zip(&b.sdef).enumerate() {
            assert_eq!(
                [x.stress, x.strain, x.update_strain].map(|v| v.map(f64::to_bits)),
                [y.stress, y.strain, y.update_strain].map(|v| v.map(f64::to_bits)),
                "block {k}'s extension on {}",
                t.name()
            );
        }
    }
}

/// Largest difference of block positions and of velocities between two runs of one model.
fn largest_difference(a: &Model, b: &Model) -> (f64, f64) {
    a.blocks.iter().zip(&b.blocks).fold((0.0f64, 0.0f64), |(p, v), (x, y)| {
        (
            p.max((x.centroid[0] - y.centroid[0]).hypot(x.centroid[1] - y.centroid[1])),
            v.max((x.velocity[0] - y.velocity[0]).hypot(x.velocity[1] - y.velocity[1])),
        )
    })
}

#[test]
fn read_back_contacts_have_the_points_and_normals_of_the_read_back_state() {
    // The GPU cycle does not store a contact's point and normal (nothing on the device reads
    // them); `contact_points` places them before each read-back and checkpoint. So every contact
    // read back must have the point and normal of its feature in the state read back with it, as
    // the CPU's stage 4 finds them from that state: a point left from the upload or the last
    // splice would be off by the bricks' motion since (centimetres here). f64 agrees to rounding
    // (1e-9 m: f64 positions relative to a centroid, converted back); f32 to 1e-5 m and 1e-5 in
    // the normal (~100 f32 ulps of the metre-sized geometry). A contact whose tracked feature
    // differs is left out: none in f64; in f32 the aligned corners of the bricks tie within the
    // wider f32 tie window (TIE_TOL 1e-5, `gpu::shaders::prelude`; 6 to 10 of 72 contacts after
    // 37 cycles), so the GPU's feature must then be as near as the CPU's within that window.
    for (adapter, precision) in common::GPU_TARGETS {
        let Some(t) = common::Target::gpu(adapter, precision) else { continue };
        let tol = if t.is_f32() { 1e-5 } else { 1e-9 };
        // Several lengths, so that the state read back follows contact updates (splices) as well
        // as plain cycles; a checkpoint's read-back is checked by the failures suite.
        for cycles in [1, 37, 400, 1200] {
            let (m, _, _) = gpu_run(&t, projectile_into_bricks(), true, cycles);
            let (mut checked, mut other_feature) = (0, 0);
            for c in &m.contacts {
                let b2 = &m.blocks[c.block2 as usize];
                let corners2 = &m.corners[b2.corner_start as usize..(b2.corner_start + b2.corner_count) as usize];
                let own = &m.corners[c.corner as usize];
                let g = blockdem::udec::contact::geometry::track_feature(corners2, c.feature, own.circle, own.radius);
                if g.feature != c.feature {
                    // A tie: the GPU's feature is as near as the CPU's choice, within the f32 tie
                    // window and the read-back positions' round-off.
                    assert!(t.is_f32(), "{} after {cycles} cycles: contact {} tracks feature {} where the CPU finds {}", t.name(), c.id, c.feature, g.feature);
                    let d = blockdem::udec::contact::geometry::distance_to_feature(corners2, c.feature, own.circle);
                    assert!(
                        (d - g.distance).abs() <= 1e-5 * (1.0 + g.distance) + tol,
                        "{} after {cycles} cycles: contact {} tracks feature {} at {d}, the CPU's {} is at {}: not a tie",
                        t.name(),
                        c.id,
                        c.feature,
                        g.feature,
                        g.distance
                    );
                    other_feature += 1;
                    continue;
                }
                let dp = (g.point[0] - c.point[0]).hypot(g.point[1] - c.point[1]);
                let dn = (g.normal[0] - c.normal[0]).hypot(g.normal[1] - c.normal[1]);
                assert!(
                    dp <= tol && dn <= tol,
                    "{} after {cycles} cycles: contact {} point {:?} vs {:?}, normal {:?} vs {:?}",
                    t.name(),
                    c.id,
                    c.point,
                    g.point,
                    c.normal,
                    g.normal
                );
                checked += 1;
            }
            assert!(checked > 20 && other_feature <= m.contacts.len() / 4, "{} after {cycles} cycles: {checked} checked, {other_feature} tied", t.name());
        }
    }
}

#[test]
fn a_contact_splice_on_the_device_runs_as_a_whole_upload() {
    // After a contact update the GPU builds the new contact list from the old one on the device
    // (`gpu::splice`), having read back only each contact's summary (`pack_contacts`); the whole
    // read-back and upload they replace send the model's copy of every contact.
    // Both hold the same state but for rounding: a kept contact's gather record is the device's
    // own rather than recomputed in f64 from the read-back point. So the runs agree to rounding
    // amplified by the motion. A block thrown at a fixed block and bouncing back (contacts made,
    // loaded and dropped, ~35 updates): to 1e-9 m in f64, 1e-5 m in f32 (~100 f32 ulps of the
    // 3 m positions). The projectile into bricks (~100 updates, many contacts made and dropped)
    // is chaotic, so there only f64 is compared, to 1e-6 m (rounding grows ~10⁷× there: 3e-9 m
    // measured), and in f32 both runs must move the same bricks.
    let bounce = "START\nPROP MAT=1 D=8000 KN=1E9 KS=1E9\nROUND 0.1\nBLOCK 0,0 0,0.5 0.5,0.5 0.5,0\nBLOCK 3,-1 3,1.5 4,1.5 4,-1\nFIX 2.5 4.5 -1.5 2\nVELOCITY 0 0.5 0 0.5 20 0\nCYCLE 0\n";
    for (adapter, precision) in common::GPU_TARGETS {
        let Some(t) = common::Target::gpu(adapter, precision) else { continue };
        let f32_kernels = t.is_f32();
        let (a, ra, splices) = gpu_run(&t, run(bounce), true, 600);
        let (b, _, none) = gpu_run(&t, run(bounce), false, 600);
        assert_eq!(none, 0, "no splice when it is off");
        // The updates while the block is in touch (an empty list is simply uploaded).
        assert!(
            splices > 0 && ra.contacts_created > 0 && ra.contacts_dropped > 0,
            "{splices} of {} contact updates spliced on {}: {ra:?}",
            ra.topology_updates,
            t.name()
        );
        let (dx, dv) = largest_difference(&a, &b);
        eprintln!("bounce on {}: {splices} splices, {dx:.3e} m, {dv:.3e} m/s", t.name());
        let tol = if f32_kernels { 1e-5 } else { 1e-9 };
        assert!(dx <= tol && dv <= 100.0 * tol, "bounce on {}: positions differ by {dx:.3e} m, velocities by {dv:.3e} m/s", t.name());

        let (a, ra, splices) = gpu_run(&t, projectile_into_bricks(), true, 1500);
        let (b, _, _) = gpu_run(&t, projectile_into_bricks(), false, 1500);
        // Every update after the run's first detection (which comes with the upload of the model).
        assert!(splices + 1 == ra.topology_updates && ra.contacts_created > 10 && ra.contacts_dropped > 10, "{splices} splices on {}: {ra:?}", t.name());
        let moving = |m: &Model| m.blocks.iter().filter(|b| b.velocity[0] > 1.0).count();
        if f32_kernels {
            assert_eq!(moving(&a), moving(&b), "impact on {}: bricks set moving", t.name());
        } else {
            let (dx, dv) = largest_difference(&a, &b);
            assert!(dx <= 1e-6 && dv <= 1e-4, "impact on {}: positions differ by {dx:.3e} m, velocities by {dv:.3e} m/s", t.name());
        }
    }
}

#[test]
fn an_adjacency_edit_on_the_device_runs_as_a_whole_upload() {
    // After a contact update that made or dropped contacts, the adjacency lists on the device
    // take the CPU's edit (`splice_adjacency.wgsl`) or are uploaded whole; `Auto` uploads them
    // on a software adapter (a memcpy there, cheaper than the edit's kernels) and edits them on
    // a hardware one. The lists are integers the CPU computes either way, so the runs are the
    // same bit for bit. The projectile into a wall (~100 updates, contacts made and dropped; the
    // fixed base has more than `HEAVY_DEGREE` contacts).
    use blockdem::udec::gpu::AdjacencyEdits;
    for (adapter, precision) in common::GPU_TARGETS {
        let Some(t) = common::Target::gpu(adapter, precision) else { continue };
        let go = |edits: AdjacencyEdits| {
            let (m, report, gpu) = gpu_run_with(&t, projectile_into_wall(3, 40), 1200, |gpu| gpu.set_adjacency_edits(edits));
            (m, report, gpu.adjacency_edit_count(), gpu.adapter().is_software())
        };
        let (edited, report, edits, software) = go(AdjacencyEdits::Always);
        let (whole, _, none, _) = go(AdjacencyEdits::Never);
        let (auto, _, auto_edits, _) = go(AdjacencyEdits::Auto);
        assert!(edits > 10 && report.contacts_created > 10 && report.contacts_dropped > 10, "{edits} edits on {}: {report:?}", t.name());
        assert_eq!(none, 0, "no edit when they are off");
        assert_eq!(auto_edits == 0, software, "{auto_edits} edits on {} with Auto", t.name());
        assert!(edited == whole, "edited and whole adjacency runs differ on {}: {:?}", t.name(), largest_difference(&edited, &whole));
        assert!(auto == whole, "Auto differs from the whole upload on {}", t.name());
    }
}

#[test]
fn a_flying_block_finds_the_block_it_hits_and_bounces() {
    // No gravity: a block thrown at 5 m/s at a fixed block 3 m away, far beyond any contact
    // tolerance at the start. It must be detected on arrival and bounce back (elastic contact, no
    // damping: |v| returns within 2%, the energy error of central differences over a contact of a
    // few tens of steps), never pass through.
    let mut m =
        run("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 4,0 4,1 5,1 5,0\nFIX 3.5 6 0 1\nVELOCITY 0 1 0 1 5 0\nCYCLE 0\n");
    assert!(m.contacts.is_empty(), "no contact at the start");
    // Arrival after 3 m / 5 m/s = 0.6 s = ~670 steps of 8.9e-4 s; 1000 steps see it back.
    cycle(&mut m, 1000);
    let b = &m.blocks[0];
    assert!(b.centroid[0] < 3.5, "passed through: {:?}", b.centroid);
    assert!((b.velocity[0] + 5.0).abs() < 0.1, "bounced back at {:?}", b.velocity);
}

#[test]
fn shear_history_survives_a_contact_update() {
    // A 2 × 0.5 m block sticking on a 10° plane (tan φ = 0.3), settled under heavy mass damping:
    // its contacts hold the shear force m g sin ψ. A full contact re-detection must hand every
    // contact its accumulated shear force and displacement (matched by corner and touched block,
    // the feature id kept), bit for bit; a lost history would zero them.
    let psi = 10f64.to_radians();
    let mut m = run(&format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.3\nROUND 0.05\nBLOCK 0,0 0,1 10,1 10,0\nBLOCK 1,1 1,1.5 3,1.5 3,1\n\
         FIX 0 10 0 0.9\nGRAV {} {}\nDAMP 0.5 50 MASS\nCYCLE 3000\n",
        10.0 * psi.sin(),
        -10.0 * psi.cos()
    ));
    // Total shear = m g sin ψ = 2000 kg · 10 · sin 10° within 1% (the damped transient is gone:
    // e^(−αt) with α = 157 /s over 0.85 s).
    let shear: f64 = m.contacts.iter().map(|c| c.shear_force.abs()).sum();
    let want = 2000.0 * 10.0 * psi.sin();
    assert!((shear - want).abs() < 0.01 * want, "shear {shear} N, m g sin ψ = {want} N");
    let before: Vec<(u32, u32, u32, u64, u64)> =
        m.contacts.iter().map(|c| (c.corner, c.block2, c.feature, c.shear_force.to_bits(), c.shear_displacement.to_bits())).collect();
    blockdem::udec::topology::update_contacts(&mut m, true);
    let after: Vec<(u32, u32, u32, u64, u64)> =
        m.contacts.iter().map(|c| (c.corner, c.block2, c.feature, c.shear_force.to_bits(), c.shear_displacement.to_bits())).collect();
    let mut b = before.clone();
    let mut a = after.clone();
    b.sort_unstable();
    a.sort_unstable();
    assert_eq!(a, b, "contacts and their shear history after a full update");
    // And the block keeps sticking: 1000 more cycles move it less than a micrometre.
    let x = m.blocks[1].centroid[0];
    cycle(&mut m, 1000);
    assert!((m.blocks[1].centroid[0] - x).abs() < 1e-6, "moved {} m", m.blocks[1].centroid[0] - x);
}

// ---------------------------------------------------------------------------------------------
// Cohesion and tension (eq. 20; "no tension beyond it")
// ---------------------------------------------------------------------------------------------

/// A 1 × 1 m block (20 kN) hanging from a fixed block above it, glued by cohesion `c` (a force
/// per contact) on the shared edge; `damp`: heavy mass damping to settle it.
fn hanging(c: f64, damp: bool, cycles: u64) -> Model {
    let damping = if damp { "DAMP 0.5 20 MASS\n" } else { "" };
    run(&format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5 C={c:e}\nROUND 0.05\nBLOCK 0,0 0,2 1,2 1,0\nSPLIT -1,1 2,1\nFIX 0 1 1 2\n\
         GRAV 0 -10\n{damping}CYCLE {cycles}\n"
    ))
}

#[test]
fn cohesion_holds_tension_up_to_its_value_and_no_further() {
    let weight = 2000.0 * 10.0;
    // Cohesion 20 kN a contact: the weight hangs on the bonded contacts, each in tension no more
    // than the cohesion, and together carrying the weight (1%: the damped settling is over).
    let m = hanging(2e4, true, 2000);
    let hung = &m.blocks.iter().find(|b| !b.fixed).unwrap();
    assert!((hung.centroid[1] - 0.5).abs() < 1e-3, "the glued block stays: {:?}", hung.centroid);
    let tension: f64 = m.contacts.iter().filter(|c| c.normal_force < 0.0).map(|c| -c.normal_force).sum();
    assert!((tension - weight).abs() < 0.01 * weight, "tension {tension} N against the weight {weight} N");
    for c in &m.contacts {
        assert!(c.normal_force >= -2e4, "tension {} beyond the cohesion", -c.normal_force);
    }
    // Cohesion below the half weight each of the two contacts would carry, no damping: the bond
    // breaks within a few steps (when kn · gap passes 5 kN, 5e-5 m) and the block falls freely.
    // The bond's pull before it breaks (≤ 10 kN for ~4 steps of 9e-4 s) is under 1% of the
    // momentum after 300 steps, so the drop is ½ g t² within 2%.
    let m = hanging(0.25 * weight, false, 300);
    let fell = &m.blocks.iter().find(|b| !b.fixed).unwrap();
    let drop = 0.5 - fell.centroid[1];
    let free = 0.5 * 10.0 * m.time * m.time;
    assert!(drop > 0.98 * free, "dropped {drop} m in {} s; free fall {free} m", m.time);
    assert!(m.contacts.iter().all(|c| c.normal_force >= 0.0 && !c.bonded), "broken bonds take no tension");
    // And with no cohesion no tension at all.
    let m = hanging(0.0, false, 50);
    assert!(m.contacts.iter().all(|c| c.normal_force >= 0.0));
    assert!(m.blocks.iter().find(|b| !b.fixed).unwrap().velocity[1] < 0.0);
}

#[test]
fn contacts_form_within_one_tolerance_and_break_past_another() {
    // A 1 × 1 m block over a fixed base, no gravity, its bottom edge `g` above the base's top: the
    // gap of its two corner–edge contacts is g (a rounded corner is tangent to its edges). A
    // contact forms when the gap is under the forming tolerance and is kept until the gap passes
    // the breaking one (ROUND 0.1: 0.1 and 0.15 m).
    let at = |g: f64| {
        run(&format!(
            "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,{a} 1,{b} 2,{b} 2,{a}\nFIX 0 4 0 0.9\nCYCLE 0\n",
            a = 1.0 + g,
            b = 2.0 + g
        ))
    };
    let probe = at(0.5);
    let (atol, btol) = (probe.tol.atol, probe.tol.btol);
    assert!(atol > 0.0 && btol > atol, "{:?}", probe.tol);
    let near = at(0.5 * atol);
    assert_eq!(near.contacts.len(), 2, "two corner–edge contacts: {:?}", near.contacts);
    for c in &near.contacts {
        assert_eq!(c.kind, blockdem::udec::model::ContactKind::CornerEdge);
        assert_eq!((c.block1, c.block2), (1, 0));
        assert!((c.gap - 0.5 * atol).abs() < 1e-9 && (c.normal[1] - 1.0).abs() < 1e-12, "{c:?}");
    }
    assert!(at(1.2 * atol).contacts.is_empty(), "no contact beyond the forming tolerance");
    // Moving away at 1 m/s from 0.5 atol, the contact stage tracks the gap every cycle and each
    // update (every `etol` of travel) re-decides: kept while the gap is between the tolerances,
    // dropped at the first update after it passes the breaking one.
    let mut m = run(&format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,{a} 1,{b} 2,{b} 2,{a}\nFIX 0 4 0 0.9\nVELOCITY 1 2 1 3 0 1\nCYCLE 0\n",
        a = 1.0 + 0.5 * atol,
        b = 2.0 + 0.5 * atol
    ));
    let (step, etol) = (m.timestep, m.tol.etol);
    let mut backend = CpuBackend::new();
    let mut run_to = |m: &mut Model, gap: f64| {
        let now = m.blocks[1].centroid[1] - 1.5;
        let n = ((gap - now) / step).ceil() as u64;
        backend.run(m, n, &mut |_| true).unwrap();
    };
    run_to(&mut m, 0.5 * (atol + btol));
    assert_eq!(m.contacts.len(), 2, "kept between the tolerances");
    assert!(m.contacts.iter().all(|c| c.gap > atol && c.gap < btol), "{:?}", m.contacts);
    run_to(&mut m, btol + etol + 2.0 * step);
    assert!(m.contacts.is_empty(), "broken past the breaking tolerance: {:?}", m.contacts);
}

#[test]
fn corners_meeting_corners_make_one_force_carrying_corner_corner_contact() {
    // Two unit squares meeting corner to corner across a 2 cm diagonal gap between their rounded
    // corners: a corner–corner contact seen from each block, of which exactly one carries force.
    let r = 0.1;
    // Rounded corners of radius r: the circles' centres sit r from each edge, so along the
    // diagonal the surfaces are 2·(r√2 − r) + √2·s apart for squares offset by s on both axes.
    let s = (0.02 - 2.0 * r * (2f64.sqrt() - 1.0)) / 2f64.sqrt();
    let m = run(&format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND {r}\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK {a},{a} {a},{b} {b},{b} {b},{a}\nFIX 0 1 0 1\nCYCLE 0\n",
        a = 1.0 + s,
        b = 2.0 + s
    ));
    assert!(!m.contacts.is_empty());
    for c in &m.contacts {
        assert_eq!(c.kind, blockdem::udec::model::ContactKind::CornerCorner, "{c:?}");
        assert!((c.gap - 0.02).abs() < 1e-9, "gap {} along the diagonal", c.gap);
        let d = std::f64::consts::FRAC_1_SQRT_2;
        assert!((c.normal[0].abs() - d).abs() < 1e-9 && (c.normal[1].abs() - d).abs() < 1e-9, "diagonal normal {:?}", c.normal);
    }
    let counted = m.contacts.iter().filter(|c| m.counts_force(c)).count();
    assert_eq!(counted, 1, "the touch counts once: {:?}", m.contacts);
}

/// Runs a deck of two blocks, the first fixed (its centroid in the unit square about (0.5, 0.5)
/// or (1, 1)), for one cycle without gravity and returns the model: its contacts hold the forces
/// of the positions as built.
fn pressed(deck: &str) -> Model {
    run(&format!("{deck}FIX 0.4 1.1 0.4 1.1\nCYCLE 1\n"))
}

#[test]
fn of_a_corner_pair_the_deeper_view_carries_the_touch() {
    // Block 1, a 2 × 2 square; block 2's bottom-left corner a sits 3 cm deep in block 1's top
    // edge, 0.12 m from block 1's top-left corner b (ROUND 0.2: the two rounding circles, centres
    // (0.2, 1.8) and (0.32, 2.17), overlap, so the two views are those of a corner pair). a's
    // view finds the straight part of the top edge, 3 cm deep; b's view finds a's arc, 1.1 cm
    // deep (0.2 − (0.389 − 0.2)). The touch is a's: 3 cm, as UDEC sample 2 found it (a corner
    // 2.9 cm into an edge beside its corner). By index alone b's view counted (block 1 is
    // first): 1.1 cm of force, then the whole 3 cm at once when the circles parted.
    let (r, depth, off) = (0.2, 0.03, 0.12);
    let y = 2.0 - depth;
    let m = pressed(&format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND {r}\nSET OVERLAP ACCEPT\nBLOCK 0,0 0,2 2,2 2,0\nBLOCK {off},{y} {off},{t} {e},{t} {e},{y}\n",
        t = y + 2.0,
        e = off + 2.0
    ));
    // The pair at the left (block 2's corner a, block 1's corner b); block 1's top-right corner
    // sits in block 2's bottom edge likewise, a pair of its own on the right.
    let left: Vec<_> = m.contacts.iter().filter(|c| c.gap < 0.0 && c.point[0] < 1.0).collect();
    assert_eq!(left.len(), 2, "the pair's two views, both in touch: {:?}", m.contacts);
    let counted: Vec<_> = left.iter().filter(|c| m.counts_force(c)).collect();
    assert_eq!(counted.len(), 1, "one view carries the touch: {left:?}");
    let c = counted[0];
    assert_eq!(c.block1, 1, "block 2's corner carries it: {c:?}");
    assert!((c.gap + depth).abs() < 1e-9, "3 cm deep: {}", c.gap);
    assert!((c.normal_force - 1e9 * depth).abs() < 1e-3 * 1e9 * depth, "kn · 3 cm: {}", c.normal_force);
    // The other view of the pair is in touch too (1.1 cm) but carries nothing.
    let other = left.iter().find(|d| d.block1 == 0).expect("b's view of the pair");
    assert!((other.gap + (r - ((0.32f64 - 0.2).hypot(2.17 - 1.8) - r))).abs() < 1e-3, "b's view: {}", other.gap);
    assert!(!m.counts_force(other) && other.normal_force == 0.0, "{other:?}");
    // The right-hand pair mirrors it: block 1's corner, 3 cm deep in block 2's edge, carries it.
    let right: Vec<_> = m.contacts.iter().filter(|c| c.gap < 0.0 && c.point[0] > 1.0 && m.counts_force(c)).collect();
    assert!(right.len() == 1 && right[0].block1 == 0 && (right[0].gap + depth).abs() < 1e-9, "{right:?}");
}

#[test]
fn of_aligned_corners_the_lower_index_carries_the_touch() {
    // Two equal squares side by side, their facing corners aligned and pressed 1 cm together:
    // each corner pair's two views are equally deep (up to round-off, within `PAIR_BAND`), and
    // the view of the corner with the lower index counts, as before the depth rule, so a brick
    // wall's aligned corners count as they did.
    let m = pressed("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.1\nSET OVERLAP ACCEPT\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 0.99,0 0.99,1 1.99,1 1.99,0\n");
    let touching: Vec<_> = m.contacts.iter().filter(|c| c.gap < 0.0).collect();
    assert_eq!(touching.len(), 4, "two corner pairs, two views each: {:?}", m.contacts);
    for c in &touching {
        let mirror = touching.iter().find(|d| d.block1 == c.block2 && (d.point[1] - c.point[1]).abs() < 0.2).expect("the pair's other view");
        assert!((c.gap - mirror.gap).abs() < 1e-12, "equal depths: {} {}", c.gap, mirror.gap);
        assert_eq!(m.counts_force(c), c.block1 == 0, "the lower index (block 1's corner) counts: {c:?}");
    }
    let total: f64 = touching.iter().map(|c| c.normal_force).sum();
    assert!((total - 2.0 * 1e9 * 0.01).abs() < 1e-6 * total, "two touches of 1 cm each: {total}");
}
