//! D3's bench scenes (issue 31, Speed), on its CPU and GPU backends:
//!
//! - `d3-cubes`: unit cubes in a lattice under gravity, the scene the Yade polyhedra peer runs:
//!   columns 0.1 m apart of cubes standing on each other on a fixed slab (so that every cube
//!   has its face–face contacts, eight logical contacts, from the first cycle; a lattice spaced
//!   vertically too would measure free fall for most of a short run): body-steps per second
//!   (blocks × cycles / s), target ≥ 10⁶ on this machine's CPU.
//! - `d3-wall`: a brick wall one brick thick (bricks 0.4 × 0.2 × 0.2 m in running bond, resting
//!   on each other and on a fixed slab) struck at mid-height by a 0.5 m cube at 10 m/s, 10³ and
//!   10⁴ bricks: contact-cycles per second (contacts in the neighbour lists, each one's stage 4
//!   every cycle, × cycles / s). The cube starts 0.1 m off the wall: the timed runs are the wall
//!   standing and the cube on its way (at the wall's step, ~5000 cycles to the impact).
//! - `d3-impact`: the same wall with the cube 2 mm off it, timed in one run through the start of
//!   the impact (the struck bricks pushed in, their contacts and the cube's refreshed at each
//!   detection): contact-cycles per second with the detections' share, and how closely the
//!   energy ledger closes at the end.
//!
//! Each scene is built by its deck (`CYCLE 0`: the contacts detected), then run for a few cycles
//! to find its pace, then timed over about `measure_s` of cycles. Each row has its roofline
//! ratio: the bytes the cycle must move by D3's byte model (`d3::gpu::profile`; in f64 on the
//! CPU) over the cycle's time, against the backend's bandwidth yardstick (the streaming kernel
//! on a GPU, the host's copy on the CPU); on a GPU each kernel's time too (pass timestamps), and
//! the roofline of the kernels alone. The D3 wall's targets on a hardware GPU (10⁸
//! contact-cycles/s at 10⁶ bricks, 40 % of the roofline) are `TargetRow`s (`report::targets`).

use std::fmt::Write as _;
use std::time::Instant;

use crate::d3;
use crate::d3::model::Model;

/// The body-steps per second D3's CPU cycle should reach on the cubes (issue 31).
pub const CUBES_TARGET: f64 = 1e6;

/// The contact-cycles per second D3's GPU cycle should reach on the 10⁶-brick wall, one H100
/// (issue 31), and the share of the roofline.
pub const WALL_GPU_TARGET: f64 = 1e8;
pub const WALL_ROOFLINE_TARGET: f64 = 0.4;

/// One measurement of a D3 scene.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct D3Row {
    pub scene: &'static str,
    pub backend: String,
    pub blocks: usize,
    /// Contacts in the neighbour lists at the end (real and degenerate).
    pub contacts: usize,
    /// Real contacts (touching) at the end, and their logical contacts.
    pub touching: usize,
    pub logical: usize,
    /// Cycles timed (all rounds) and the best round's seconds per cycle.
    pub cycles: u64,
    pub s_per_cycle: f64,
    pub body_steps_per_s: f64,
    pub contact_cycles_per_s: f64,
    /// A hardware GPU's row (not the CPU's, not a software adapter's).
    pub hardware_gpu: bool,
    /// The byte model's bytes a cycle (`d3::gpu::profile`), kernel by kernel, and in all.
    pub stage_bytes: Vec<crate::gpu::profile::StageBytes>,
    pub bytes_per_cycle: u64,
    /// The backend's bandwidth yardstick, bytes read + written per second (0: not measured).
    pub bandwidth_bytes_per_s: f64,
    /// The byte model over the cycle's time, against the yardstick (0: not measured).
    pub roofline: f64,
    /// GPU: each kernel's time per cycle (how timed, and (kernel, seconds)), and the byte model
    /// over the kernels' time alone against the yardstick.
    pub kernel_timing: Option<String>,
    pub kernels: Vec<(String, f64)>,
    pub roofline_kernels: Option<f64>,
    /// GPU: the detections between batches (read-back of the contacts, stage 7, the CPU's stage
    /// 4, the re-upload) in the timed runs, and the shares of the timed runs' time they and the
    /// batches' read-backs of the blocks took.
    pub detections: u64,
    pub detection_share: f64,
    /// GPU: the share of the listed contacts whose logical contacts those detections found afresh
    /// (1 for whole detections; a partial one's, the moved blocks' contacts: `d3::gpu`).
    pub refreshed_share: f64,
    /// GPU: the bytes those detections moved between host and device (read back and uploaded:
    /// a partial detection's the moved blocks' contacts, spliced; `d3::gpu::splice`).
    pub detection_bytes: u64,
    /// GPU: those detections whose lists kept their keys (no contact made or dropped: renewed
    /// in place, the adjacency kept on the device).
    pub kept_lists: u64,
    pub readback_share: f64,
    /// GPU: the energy checks (every hundred cycles and at each run's end: the contacts' sums on
    /// the device, the blocks' on the CPU, the device checkpoint) and their share of the time.
    pub checks: u64,
    pub check_share: f64,
    /// The energy ledger at the end of the timed runs: its imbalance (what is there and what
    /// went, less the work put in, `Energies::ledger`) over the energy in play, the largest
    /// term seen at the end of any of the row's runs (the pace's and each timed round's): a
    /// scene that rings undamped (the cubes dropped onto unloaded contacts) comes back near its
    /// start, every term near zero, where the last instant's largest term would inflate a
    /// ledger of ~1e-3 J of 4 J in play to 5 %.
    pub ledger_error: f64,
    pub error: Option<String>,
}

/// The deck of `n` unit cubes (the cube root rounded up on a side, the last layer partial) in a
/// lattice of columns 0.1 m apart, each column's cubes standing on each other on a fixed slab,
/// under gravity.
pub fn cubes_deck(n: usize, frac: f64) -> String {
    let side = (n as f64).cbrt().ceil().max(1.0) as usize;
    let pitch = 1.1;
    let span = side as f64 * pitch;
    let mut deck = format!("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nBOX -1 {e} -1 {e} -1 0\n", e = span + 1.0);
    for k in 0..n {
        let (i, j, l) = (k % side, (k / side) % side, k / (side * side));
        let (x, y, z) = (i as f64 * pitch, j as f64 * pitch, l as f64);
        let _ = writeln!(deck, "BOX {x} {} {y} {} {z} {}", x + 1.0, y + 1.0, z + 1.0);
    }
    let _ = write!(deck, "FIX -0.5 {e} -0.5 {e} -0.6 -0.4\nGRAV 0 0 -10\nFRACTION {frac}\n", e = span + 0.5);
    deck
}

/// The deck of a wall of about `n` bricks (one brick thick, rows of `n / rows` bricks, every
/// other row shifted half a brick) on a fixed slab, struck by a cube 0.1 m off it.
pub fn wall_deck(n: usize, frac: f64) -> String {
    wall_deck_at(n, frac, 0.1)
}

/// The least cycles `d3-impact` times (a quarter with `--quick`): at the wall's step (2.0e-6 s
/// at FRACTION 0.1) the cube strikes at about cycle 100, and by cycle 1000 it has gone at most
/// 18 mm past the wall's face (its speed at the start, 10 m/s).
pub const IMPACT_CYCLES: u64 = 1000;

/// [`wall_deck`] with the cube 2 mm off the wall: it strikes in the first ~100 cycles.
pub fn impact_deck(n: usize, frac: f64) -> String {
    wall_deck_at(n, frac, 0.002)
}

/// [`wall_deck`] with the cube `gap` m off the wall.
fn wall_deck_at(n: usize, frac: f64, gap: f64) -> String {
    let (bx, bz, t) = (0.4, 0.2, 0.2);
    let rows = ((n as f64 / 8.0).sqrt().round() as usize).max(1);
    let per_row = n.div_ceil(rows).max(1);
    let length = per_row as f64 * bx + 0.5 * bx;
    let mut deck = format!("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6\nBOX -1 {} -1 {} -1 0\n", length + 1.0, t + 1.0);
    let mut placed = 0;
    'rows: for r in 0..rows {
        let shift = if r % 2 == 1 { 0.5 * bx } else { 0.0 };
        for c in 0..per_row {
            if placed == n {
                break 'rows;
            }
            let (x, z) = (shift + c as f64 * bx, r as f64 * bz);
            let _ = writeln!(deck, "BOX {x} {} 0 {t} {z} {}", x + bx, z + bz);
            placed += 1;
        }
    }
    // The projectile: a 0.5 m cube `gap` in front of the wall's middle, moving into it.
    let (cx, cz) = (0.5 * length, (0.5 * rows as f64 * bz).max(0.3));
    let _ = write!(
        deck,
        "BOX {} {} {} {} {} {}\nFIX -0.5 {} -0.5 {} -0.6 -0.4\nGRAV 0 0 -10\nVELOCITY {} {} {} {} {} {} 0 10 0\nFRACTION {frac}\n",
        cx - 0.25,
        cx + 0.25,
        -0.5 - gap,
        -gap,
        cz - 0.25,
        cz + 0.25,
        length + 0.5,
        t + 0.5,
        cx - 0.3,
        cx + 0.3,
        -0.55 - gap,
        -0.5 * gap,
        cz - 0.3,
        cz + 0.3
    );
    deck
}

/// A D3 backend of the bench: the CPU's, or the GPU's (which also times its kernels).
enum D3Engine {
    Cpu(d3::cpu::CpuBackend),
    Gpu(Box<d3::gpu::GpuBackend>),
}

impl D3Engine {
    fn backend(&mut self) -> &mut dyn d3::backend::Backend {
        match self {
            D3Engine::Cpu(c) => c,
            D3Engine::Gpu(g) => g.as_mut(),
        }
    }
}

/// A D3 backend for the bench: the CPU's, or the GPU's on an adapter in a precision; its label,
/// and whether it is a hardware GPU.
fn backend_for(spec: &super::BackendSpec) -> (String, bool, Result<D3Engine, String>) {
    match spec {
        super::BackendSpec::Cpu => (format!("cpu f64 ({} threads)", rayon::current_num_threads()), false, Ok(D3Engine::Cpu(d3::cpu::CpuBackend::new()))),
        super::BackendSpec::Gpu(o) => match d3::gpu::GpuBackend::new(&o.adapter, o.precision) {
            Ok(g) => {
                let a = g.adapter();
                (format!("gpu {} {} ({})", a.backend, o.precision, a.driver_name()), !a.is_software(), Ok(D3Engine::Gpu(Box::new(g))))
            }
            Err(e) => (format!("gpu {:?} {}", o.adapter, o.precision), false, Err(e.to_string())),
        },
    }
}

/// Builds `deck` (`CYCLE 0`), runs it a few cycles to find its pace, then times `rounds` runs of
/// about `measure_s` of cycles each, and at least `min_cycles`, on `backend` (`cycles`: all of
/// them; `s_per_cycle`: the best run's).
pub fn measure(scene: &'static str, deck: &str, (measure_s, min_cycles): (f64, u64), rounds: u32, spec: &super::BackendSpec, bandwidth: Option<f64>) -> D3Row {
    let (label, hardware_gpu, backend) = backend_for(spec);
    let mut row = D3Row { scene, backend: label, hardware_gpu, ..Default::default() };
    let mut engine = match backend {
        Ok(b) => b,
        Err(e) => {
            row.error = Some(e);
            return row;
        }
    };
    let commands = match d3::deck::parse_deck(&format!("{deck}CYCLE 0\n"), scene) {
        Ok(c) => c,
        Err(e) => {
            row.error = Some(e.to_string());
            return row;
        }
    };
    let mut exec = d3::exec::Executor::new(Box::new(std::io::sink()), scene);
    if let Err(e) = exec.run(&commands) {
        row.error = Some(e.to_string());
        return row;
    }
    let mut model: Model = std::mem::take(&mut exec.model);
    // The host's share of a GPU's runs (read-backs, detections), from before the pace's run.
    let host = |engine: &D3Engine| match engine {
        D3Engine::Gpu(g) => g.host_times(),
        D3Engine::Cpu(_) => Default::default(),
    };
    let mut timed_s = 0.0;
    let run = |engine: &mut D3Engine, model: &mut Model, cycles: u64| -> Result<f64, String> {
        let t = Instant::now();
        engine.backend().run(model, cycles, &mut |_| true).map_err(|e| e.to_string())?;
        Ok(t.elapsed().as_secs_f64())
    };
    // The pace: 10 cycles (the first run's contact detection included), then the rest timed.
    let pace = match run(&mut engine, &mut model, 10) {
        Ok(s) => s / 10.0,
        Err(e) => {
            row.error = Some(e);
            return row;
        }
    };
    // The energy in play: the largest term at the end of each run (see `D3Row::ledger_error`).
    let mut in_play = model.energies().scale();
    let cycles = ((measure_s / pace.max(1e-9)) as u64).clamp(min_cycles.max(10), 1_000_000.max(min_cycles));
    let host_before = host(&engine);
    // The best of `rounds` timed runs (this machine's two cores are shared: the least time is
    // the cycle's own).
    row.s_per_cycle = f64::INFINITY;
    for _ in 0..rounds.max(1) {
        match run(&mut engine, &mut model, cycles) {
            Ok(s) => {
                row.cycles += cycles;
                row.s_per_cycle = row.s_per_cycle.min(s / cycles as f64);
                timed_s += s;
                in_play = in_play.max(model.energies().scale());
            }
            Err(e) => {
                row.error = Some(e);
                return row;
            }
        }
    }
    let host_after = host(&engine);
    row.detections = host_after.detections - host_before.detections;
    row.detection_bytes = host_after.detection_bytes - host_before.detection_bytes;
    row.kept_lists = host_after.kept_lists - host_before.kept_lists;
    let listed = host_after.listed - host_before.listed;
    if listed > 0 {
        row.refreshed_share = (host_after.refreshed - host_before.refreshed) as f64 / listed as f64;
    }
    if timed_s > 0.0 {
        row.detection_share = (host_after.detection_s - host_before.detection_s) / timed_s;
        row.readback_share = (host_after.readback_s - host_before.readback_s) / timed_s;
        row.check_share = (host_after.checks_s - host_before.checks_s) / timed_s;
    }
    row.checks = host_after.checks - host_before.checks;
    // The ledger as the run left it (a GPU's run ends with every contact read back).
    let energies = model.energies();
    row.ledger_error = energies.ledger().abs() / in_play.max(energies.scale()).max(f64::MIN_POSITIVE);
    row.blocks = model.blocks.iter().filter(|b| !b.fixed).count();
    row.contacts = model.contacts.len();
    row.touching = model.contacts.iter().filter(|c| !c.logical.is_empty()).count();
    row.logical = model.contacts.iter().map(|c| c.logical.len()).sum();
    row.body_steps_per_s = row.blocks as f64 / row.s_per_cycle;
    row.contact_cycles_per_s = row.contacts as f64 / row.s_per_cycle;
    // The roofline: the byte model of the scene as it ended (in f64 on the CPU).
    row.stage_bytes = match &engine {
        D3Engine::Cpu(_) => d3::gpu::profile::bytes_per_cycle::<f64>(&model),
        D3Engine::Gpu(g) => g.bytes_per_cycle(&model),
    };
    row.bytes_per_cycle = row.stage_bytes.iter().map(|b| b.read + b.written).sum();
    if let Some(bw) = bandwidth.filter(|&bw| bw > 0.0) {
        row.bandwidth_bytes_per_s = bw;
        row.roofline = row.bytes_per_cycle as f64 / row.s_per_cycle / bw;
    }
    if let D3Engine::Gpu(g) = &mut engine {
        // Each kernel's time, on the state the timed runs left (a short run's worth of cycles).
        match g.profile_kernels(&model, cycles.clamp(1, 100) as u32) {
            Ok(p) => {
                let kernels: f64 = p.stages.iter().map(|(_, t)| t).sum();
                row.kernel_timing = Some(format!("{} over {} cycles", p.method, p.cycles));
                row.kernels = p.stages.iter().map(|(k, t)| (k.to_string(), *t)).collect();
                if row.bandwidth_bytes_per_s > 0.0 && kernels > 0.0 {
                    row.roofline_kernels = Some(row.bytes_per_cycle as f64 / kernels / row.bandwidth_bytes_per_s);
                }
            }
            Err(e) => row.kernel_timing = Some(format!("not timed: {e}")),
        }
    }
    row
}

/// The D3 section of the bench table.
pub fn table(rows: &[D3Row]) -> String {
    let mut s = String::new();
    if rows.is_empty() {
        return s;
    }
    let _ = writeln!(s, "\nD3 (3D): cubes in a lattice falling on a slab; a brick wall struck by a cube (d3-impact: timed through the impact)");
    let _ = writeln!(
        s,
        "{:<9} {:<34} {:>7} {:>8} {:>8} {:>8} {:>7} {:>11} {:>13} {:>13} {:>10} {:>9} {:>8}",
        "scene", "backend", "blocks", "contacts", "touching", "logical", "cycles", "s/cycle", "body-steps/s", "contact-c/s", "B/cycle", "roofline", "ledger"
    );
    let pct = |x: f64| if x > 0.0 { format!("{:.1}%", 100.0 * x) } else { "-".into() };
    for r in rows {
        if let Some(e) = &r.error {
            let _ = writeln!(s, "{:<9} {:<34} failed: {e}", r.scene, r.backend);
            continue;
        }
        let _ = writeln!(
            s,
            "{:<9} {:<34} {:>7} {:>8} {:>8} {:>8} {:>7} {:>11.3e} {:>13.3e} {:>13.3e} {:>10.3e} {:>9} {:>8.1e}",
            r.scene,
            r.backend,
            r.blocks,
            r.contacts,
            r.touching,
            r.logical,
            r.cycles,
            r.s_per_cycle,
            r.body_steps_per_s,
            r.contact_cycles_per_s,
            r.bytes_per_cycle as f64,
            pct(r.roofline),
            r.ledger_error
        );
        if let Some(timing) = &r.kernel_timing {
            let kernels: Vec<String> = r.kernels.iter().map(|(k, t)| format!("{k} {:.3e} s", t)).collect();
            let alone = r.roofline_kernels.map(|x| format!("; roofline of the kernels alone {}", pct(x))).unwrap_or_default();
            let _ = writeln!(s, "{:<9}   kernels ({timing}): {}{alone}", "", kernels.join(", "));
            let _ = writeln!(
                s,
                "{:<9}   host: {} detections in {} cycles ({} kept their lists; {} of the listed contacts refreshed, {:.3} MB moved each), {} of the time; read-backs of the blocks {}; {} energy checks {}",
                "",
                r.detections,
                r.cycles,
                r.kept_lists,
                pct(r.refreshed_share),
                r.detection_bytes as f64 / r.detections.max(1) as f64 / 1e6,
                pct(r.detection_share),
                pct(r.readback_share),
                r.checks,
                pct(r.check_share)
            );
        }
    }
    s
}

/// The rows as CSV (each kernel's time a column `kernel:<name>_s`, in the first row's order).
pub fn csv(rows: &[D3Row]) -> String {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        for (k, _) in &r.kernels {
            if !names.contains(k) {
                names.push(k.clone());
            }
        }
    }
    let Some(first) = rows.first() else { return String::new() };
    let mut header: Vec<String> = first.csv_fields().into_iter().map(|(name, _)| name.to_string()).collect();
    header.extend(names.iter().map(|k| format!("kernel:{k}_s")));
    header.push("error".into());
    let mut s = header.join(",") + "\n";
    for r in rows {
        let mut cells: Vec<String> = r.csv_fields().into_iter().map(|(_, v)| v).collect();
        cells.extend(names.iter().map(|k| r.kernels.iter().find(|(n, _)| n == k).map(|(_, t)| format!("{t:e}")).unwrap_or_default()));
        cells.push(r.error.as_deref().unwrap_or("").replace(',', ";"));
        let _ = writeln!(s, "{}", cells.join(","));
    }
    s
}

impl D3Row {
    /// The row's CSV columns (name, value), the kernels' and the error's apart.
    fn csv_fields(&self) -> Vec<(&'static str, String)> {
        let e = |x: f64| format!("{x:e}");
        vec![
            ("scene", self.scene.to_string()),
            ("backend", self.backend.clone()),
            ("hardware_gpu", self.hardware_gpu.to_string()),
            ("blocks", self.blocks.to_string()),
            ("contacts", self.contacts.to_string()),
            ("touching", self.touching.to_string()),
            ("logical", self.logical.to_string()),
            ("cycles", self.cycles.to_string()),
            ("s_per_cycle", e(self.s_per_cycle)),
            ("body_steps_per_s", e(self.body_steps_per_s)),
            ("contact_cycles_per_s", e(self.contact_cycles_per_s)),
            ("bytes_per_cycle", self.bytes_per_cycle.to_string()),
            ("bandwidth_bytes_per_s", e(self.bandwidth_bytes_per_s)),
            ("roofline", e(self.roofline)),
            ("roofline_kernels", self.roofline_kernels.map(e).unwrap_or_default()),
            ("detections", self.detections.to_string()),
            ("detection_share", e(self.detection_share)),
            ("refreshed_share", e(self.refreshed_share)),
            ("detection_bytes", self.detection_bytes.to_string()),
            ("kept_lists", self.kept_lists.to_string()),
            ("readback_share", e(self.readback_share)),
            ("checks", self.checks.to_string()),
            ("check_share", e(self.check_share)),
            ("ledger_error", e(self.ledger_error)),
        ]
    }
}
