//! `blockdem bench`: throughput of the explicit cycle on brick walls, on every backend, adapter and
//! precision present (DESIGN.md §5), and the reference scene other engines are compared with.
//!
//! | file | what |
//! |---|---|
//! | [`scene`] | the reference wall (settle, impact), the decks in `examples/`, the scaling family, what is measured on the wall |
//! | [`host`] | machine info, the host's copy bandwidth, the byte model of the CPU cycle |
//! | [`memory_spec`] | GPUs' memory bandwidth by their data sheets, for adapters whose name identifies them |
//! | [`report`] | the targets, the table, CSV and JSON |
//! | [`chart`] | the PNG chart |
//!
//! ## What a scaling measurement is
//!
//! For each wall of about N blocks (25 rows, longer walls, the reference projectile flying at its
//! left end) and each backend: the wall is built (deck, full contact detection), runs 20 cycles
//! (its contacts start unloaded), a short run
//! calibrates the cost of a cycle, then runs of M cycles (M chosen so that the `rounds` runs
//! take about `measure_s` in all) are timed with the stage profiler on ([`crate::profile`]), the
//! backends taking turns: round 1 on every backend, then round 2, and so on. The machines this
//! runs on are shared, and their speed drifts by 20% and more over seconds; a ratio of two
//! backends is taken within each round (runs seconds apart) and its median reported, and each
//! row holds the round of median time per cycle (`round_s_per_cycle` lists them all). Every `Backend::run`
//! begins with a full contact detection (and, on the GPU, an upload of the whole model), unless it
//! goes on from the state the backend's last run left (the runs after the first here do), and
//! ends by handing the state back (on the GPU a read-back of the whole state, on both a copy of
//! it for the next run to resume from): that set-up and tear-down are reported apart
//! (`setup_s`, `teardown_s`, and in the whole-run share of topology work and transfers), and the
//! rates are those of the cycles between the backend's two marks. On the GPU the kernels are then timed per
//! stage on the same state (`gpu::profile`).

pub mod chart;
pub mod d3;
pub mod host;
pub mod memory_spec;
pub mod report;
pub mod scene;
pub mod zones;

use std::time::Instant;

use crate::profile::{self, Stage, StageTimes};
use crate::udec::backend::{Backend, CycleError, CycleReport};
use crate::udec::cpu::CpuBackend;
use crate::udec::gpu::{matching_adapters, AdapterChoice, GpuBackend, GpuOptions, Precision};
use crate::udec::model::Model;

pub use report::{table, write_outputs};
use scene::RefScene;

/// Nominal wall sizes of the scaling family (blocks).
pub const SIZES: &[usize] = &[1_000, 10_000, 100_000, 1_000_000];

/// Cycles a wall settles before it is timed (here and in the criterion benches).
pub const SETTLE_CYCLES: u64 = 20;

/// Where a bench runs.
#[derive(Clone, Debug, PartialEq)]
pub enum BackendSpec {
    Cpu,
    Gpu(GpuOptions),
}

/// What a bench covers.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub quick: bool,
    pub settle: bool,
    pub impact: bool,
    /// The settle scene with simply-deformable bricks (`RefScene::Sdef`).
    pub sdef: bool,
    /// The settle scene with fluid in the wall's joints (`RefScene::Fluid`).
    pub fluid: bool,
    pub scaling: bool,
    /// The scaling family with simply-deformable bricks (`scene::scaling_body_sdef`).
    pub sdef_scaling: bool,
    /// The zoned scene family (`zones`: fully-deformable blocks).
    pub zones: bool,
    /// Largest zoned scene (zones); None: `zones::DEFAULT_MAX_ZONES` (10³ with `quick`).
    pub max_zones: Option<usize>,
    /// D3's cubes in a lattice (`d3::cubes_deck`), and how many.
    pub d3_cubes: bool,
    pub d3_cubes_n: usize,
    /// D3's brick wall struck by a cube (`d3::wall_deck`), and its sizes (bricks).
    pub d3_wall: bool,
    pub d3_wall_sizes: Vec<usize>,
    /// D3's wall timed through the cube's impact (`d3::impact_deck`), at the wall's sizes.
    pub d3_impact: bool,
    pub backends: Vec<BackendSpec>,
    /// Largest wall of the scaling family; None: 10⁴ with `quick`, else 10⁵ on the CPU and
    /// software adapters and 10⁶ on hardware GPUs.
    pub max_blocks: Option<usize>,
    /// Nominal sizes of the scaling family.
    pub sizes: Vec<usize>,
    /// Simulated time of the settle and impact scenes.
    pub settle_time: f64,
    pub impact_time: f64,
    /// FRACTION of every scene.
    pub frac: f64,
    /// Wall time one scaling measurement aims at (seconds), over all its rounds.
    pub measure_s: f64,
    /// Rounds each scaling measurement is cut into, the backends taking turns (see the module
    /// doc): the ratio of two backends is taken within each round.
    pub rounds: u32,
    /// Progress lines on stderr.
    pub verbose: bool,
}

impl BenchOptions {
    /// The full bench (or the quick one) on the given backends: every scene.
    pub fn new(quick: bool, backends: Vec<BackendSpec>) -> Self {
        BenchOptions {
            quick,
            settle: true,
            sdef: true,
            fluid: true,
            impact: true,
            scaling: true,
            sdef_scaling: true,
            zones: true,
            max_zones: None,
            d3_cubes: true,
            d3_cubes_n: 1000,
            d3_wall: true,
            d3_impact: true,
            d3_wall_sizes: if quick { vec![1_000] } else { vec![1_000, 10_000] },
            backends,
            max_blocks: None,
            sizes: SIZES.to_vec(),
            settle_time: if quick { 0.1 } else { scene::SETTLE_TIME },
            impact_time: if quick { 0.1 } else { scene::IMPACT_TIME },
            frac: scene::FRAC,
            measure_s: if quick { 0.25 } else { 1.5 },
            rounds: if quick { 1 } else { 3 },
            verbose: false,
        }
    }
}

/// The backends present: the CPU (when `cpu`), and (when `gpu`) each GPU adapter `adapter`
/// allows, in f32 and, where it has SHADER_F64, f64 (only `precision` when given).
pub fn present_backends(cpu: bool, gpu: bool, adapter: &AdapterChoice, precision: Option<Precision>) -> Vec<BackendSpec> {
    let mut out = Vec::new();
    if cpu {
        out.push(BackendSpec::Cpu);
    }
    if !gpu {
        return out;
    }
    let found: Vec<_> = matching_adapters(adapter).into_iter().filter(|a| a.compute).collect();
    let mut choices: Vec<(AdapterChoice, bool)> = Vec::new();
    match adapter {
        AdapterChoice::Any => {
            // The best adapter of each API; further adapters by name.
            for (api, choice) in [("Vulkan", AdapterChoice::Vulkan), ("Gl", AdapterChoice::Gl)] {
                let of_api: Vec<_> = found.iter().filter(|a| a.backend == api).collect();
                if of_api.is_empty() {
                    continue;
                }
                choices.push((choice, of_api.iter().any(|a| a.shader_f64)));
                let first = &of_api[0].name;
                for a in of_api.iter().skip(1).filter(|a| &a.name != first) {
                    choices.push((AdapterChoice::Name(a.name.clone()), a.shader_f64));
                }
            }
        }
        other => {
            if !found.is_empty() {
                choices.push((other.clone(), found.iter().any(|a| a.shader_f64)));
            }
        }
    }
    for (choice, f64_ok) in choices {
        for p in [Precision::F32, Precision::F64] {
            if precision.is_some_and(|want| want != p) || (p == Precision::F64 && !f64_ok) {
                continue;
            }
            let spec = BackendSpec::Gpu(GpuOptions { adapter: choice.clone(), precision: p });
            if !out.contains(&spec) {
                out.push(spec);
            }
        }
    }
    out
}

/// The bandwidth figures of one backend: the yardstick the roofline divides by, and on a GPU each
/// way of moving memory measured apart. The yardstick is the physical limit as best measured:
/// the host memcpy on the CPU backend; on a GPU `gpu::profile::yardstick`.
fn measure_bandwidth(info: &mut BackendInfo, e: &Engine, say: &dyn Fn(&str)) {
    match e {
        Engine::Cpu(_) => {
            info.bandwidth_bytes_per_s = Some(host::host_copy_bandwidth());
            info.yardstick = "host memcpy".into();
        }
        Engine::Gpu(g) => {
            match g.stream_bandwidth() {
                Ok(s) => {
                    info.stream_bandwidth_bytes_per_s = Some(s.best);
                    info.stream_sizes = s.sizes;
                }
                Err(err) => say(&format!("{}: the streaming kernel failed ({err})", info.label)),
            }
            info.copy_bandwidth_bytes_per_s = g.copy_bandwidth().ok();
            if let Some((bw, which)) = crate::gpu::stream::yardstick(info.stream_bandwidth_bytes_per_s, info.copy_bandwidth_bytes_per_s) {
                info.bandwidth_bytes_per_s = Some(bw);
                info.yardstick = which.into();
            }
            if let Some((bw, card)) = memory_spec::spec_bandwidth(&info.adapter) {
                info.spec_bandwidth_bytes_per_s = Some(bw);
                info.spec_card = Some(card.to_string());
            }
        }
    }
}

/// One backend of the bench as the report names it.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BackendInfo {
    /// Short name used in the tables and charts, e.g. `cpu f64`, `vulkan llvmpipe f32`.
    pub label: String,
    /// "cpu" or "gpu".
    pub kind: String,
    /// A CPU, or a GPU adapter that is a CPU emulation (Mesa's lavapipe / llvmpipe).
    pub software: bool,
    pub adapter: String,
    pub api: String,
    pub driver: String,
    pub precision: String,
    /// The bandwidth yardstick the roofline divides by, bytes read + written per second: on the
    /// CPU backend a memcpy over rayon's threads, on a GPU adapter the faster of a streaming copy
    /// kernel (`gpu::profile::stream_bandwidth`) and `copy_buffer_to_buffer`
    /// (`measure_bandwidth`; before 2026-11-26 it was `copy_buffer_to_buffer` alone).
    pub bandwidth_bytes_per_s: Option<f64>,
    /// Which measurement the yardstick is: "host memcpy", "streaming kernel" or
    /// "copy_buffer_to_buffer".
    pub yardstick: String,
    /// GPU: the streaming kernel's best over its sizes, bytes read + written per second.
    pub stream_bandwidth_bytes_per_s: Option<f64>,
    /// GPU: the streaming kernel's best at each buffer size, (bytes of one buffer, bytes/s).
    pub stream_sizes: Vec<(u64, f64)>,
    /// GPU: `copy_buffer_to_buffer`'s bandwidth, bytes read + written per second (the old yardstick).
    pub copy_bandwidth_bytes_per_s: Option<f64>,
    /// GPU: the card's memory bandwidth by its data sheet, where the adapter's name identifies it
    /// (`memory_spec`), and the card as named there.
    pub spec_bandwidth_bytes_per_s: Option<f64>,
    pub spec_card: Option<String>,
    /// How stage times are measured.
    pub stage_timing: String,
    /// Largest nominal wall of the scaling family on this backend.
    pub max_blocks: usize,
    /// Why the backend could not be opened.
    pub error: Option<String>,
}

/// One run of a reference scene.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ReferenceRow {
    pub scene: String,
    pub backend: String,
    pub blocks: usize,
    pub contacts: usize,
    pub cycles: u64,
    pub timestep: f64,
    pub simulated_s: f64,
    /// Wall time of the whole deck (parse, build, cycles).
    pub wall_s: f64,
    pub cycles_per_s: f64,
    pub measures: Option<scene::WallMeasures>,
    /// Where the wall time went: host stages over the whole deck (set-up, cycles and tear-down
    /// of every run together), seconds; the rest (parsing, building) is not listed.
    pub stages: Vec<(String, String, f64)>,
    /// Contact updates (stage 7 runs) during the CYCLE.
    pub topology_updates: u64,
    /// On a GPU: each kernel's time per cycle (pass timestamps over a short run from the state
    /// the deck left, `GpuBackend::profile_stages`), in dispatch order.
    pub kernels: Vec<(String, f64)>,
    pub error: Option<String>,
}

impl ReferenceRow {
    /// Cycles a second over the deck's wall time less the backend's one-off kernel build (the
    /// SDEF kernels, built the first time a scene has SDEF blocks: up to 0.85 s on the H100 in
    /// f64, which a comparison of block kinds per cycle must not charge to the cycles).
    pub fn cycles_per_s_without_kernel_build(&self) -> f64 {
        let build: f64 = self.stages.iter().filter(|(_, group, _)| group == "setup").map(|(_, _, t)| t).sum();
        let wall = self.wall_s - build;
        if wall > 0.0 {
            self.cycles as f64 / wall
        } else {
            0.0
        }
    }
}

/// Time of one stage per cycle.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct StageRow {
    /// "host" (timed on the host during the run) or "device" (kernel times, `gpu::profile`).
    pub source: String,
    pub stage: String,
    /// "cycle", "topology", "transfer", "check", "other" (host) or "kernel" (device).
    pub group: String,
    pub s_per_cycle: f64,
    /// Bytes the stage must read + write per cycle (the byte model), where it has one.
    pub bytes_per_cycle: Option<u64>,
}

/// One wall of the scaling family on one backend.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ScalingRow {
    pub backend: String,
    pub nominal: usize,
    pub blocks: usize,
    pub corners: usize,
    pub contacts: usize,
    /// Cycles timed.
    pub cycles: u64,
    /// The wall's deck read, its blocks built and its contacts first detected, on the CPU,
    /// seconds (what a user's run of the deck pays before its first cycle, less the backend's own
    /// set-up; one figure per wall, shared by its backends' rows).
    pub build_s: f64,
    /// Set-up of the timed run: full detection (and upload), seconds.
    pub setup_s: f64,
    /// Tear-down of the timed run: the final read-back of the state (GPU), seconds.
    pub teardown_s: f64,
    /// The timed cycles after the set-up, seconds.
    pub steady_s: f64,
    pub s_per_cycle: f64,
    pub s_per_block_cycle: f64,
    pub block_cycles_per_s: f64,
    pub contact_cycles_per_s: f64,
    pub stages: Vec<StageRow>,
    pub device_timing: Option<String>,
    pub bytes_per_cycle: u64,
    pub bandwidth_bytes_per_s: f64,
    /// Achieved bytes per second (the byte model over the whole cycle time) over the bandwidth.
    pub roofline: f64,
    /// The same over the kernels' time only (GPU).
    pub roofline_kernels: Option<f64>,
    /// Shares of the cycle time (after set-up) spent in CPU topology work and in transfers.
    pub topology_share: f64,
    pub transfer_share: f64,
    /// Share of the whole timed run, set-up included, spent in topology work and transfers.
    pub run_topology_transfer_share: f64,
    /// Contact updates (stage 7 runs) during the timed cycles of the median round.
    pub topology_updates: u64,
    /// Host time of topology work and transfers in those cycles per contact update, seconds
    /// (0 without updates): what an update costs the host, in proportion to what it changes.
    pub host_s_per_update: f64,
    /// Time per cycle of each round, in turn with the other backends (the row's rates are those
    /// of the round of median time).
    pub round_s_per_cycle: Vec<f64>,
    pub error: Option<String>,
}

/// A target of the issue next to what was measured.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct TargetRow {
    pub target: String,
    pub backend: String,
    pub goal: String,
    pub measured: String,
    /// None: not measurable here (no hardware GPU, a shortened run, a size not reached).
    pub met: Option<bool>,
    pub note: String,
}

/// The options a report was made with (echoed in the JSON).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct OptionsEcho {
    pub quick: bool,
    pub scenes: Vec<String>,
    pub sizes: Vec<usize>,
    pub max_blocks: Option<usize>,
    pub settle_time: f64,
    pub impact_time: f64,
    pub frac: f64,
    pub round: f64,
    pub measure_s: f64,
    /// Timed rounds of each scaling measurement (not ROUND, the rounding length above).
    pub rounds: u32,
}

/// Everything a bench run measured.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BenchReport {
    pub machine: host::MachineInfo,
    pub options: OptionsEcho,
    pub backends: Vec<BackendInfo>,
    pub reference: Vec<ReferenceRow>,
    pub scaling: Vec<ScalingRow>,
    /// The scaling family with simply-deformable bricks (`sdef_scaling`): the same walls and
    /// projectile, rates and stage times as `scaling`'s rows; no byte model (roofline 0).
    pub sdef_scaling: Vec<ScalingRow>,
    /// The zoned scene family (`zones`).
    pub zones: Vec<zones::ZoneRow>,
    /// D3's scenes (`d3-cubes`, `d3-wall`), on its CPU backend.
    pub d3: Vec<d3::D3Row>,
    pub targets: Vec<TargetRow>,
}

enum Engine {
    Cpu(Box<CpuBackend>),
    Gpu(Box<GpuBackend>),
}

impl Engine {
    fn backend(&mut self) -> &mut dyn Backend {
        match self {
            Engine::Cpu(c) => c.as_mut(),
            Engine::Gpu(g) => g.as_mut(),
        }
    }
}

/// A borrowed backend behind the `Backend` trait (the executor takes a box).
struct Borrowed<'a>(&'a mut dyn Backend);

impl Backend for Borrowed<'_> {
    fn describe(&self) -> String {
        self.0.describe()
    }
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        self.0.run_into(model, cycles, progress, report)
    }
}

fn short_adapter_name(name: &str) -> String {
    name.split_whitespace().next().unwrap_or("gpu").to_lowercase()
}

/// Opens a backend; its report entry either way.
fn open(spec: &BackendSpec, opts: &BenchOptions) -> (BackendInfo, Option<Engine>) {
    let default_max = |software: bool| {
        opts.max_blocks.unwrap_or(if opts.quick {
            10_000
        } else if software {
            100_000
        } else {
            1_000_000
        })
    };
    match spec {
        BackendSpec::Cpu => (
            BackendInfo {
                label: "cpu f64".into(),
                kind: "cpu".into(),
                software: true,
                adapter: "CPU (rayon)".into(),
                api: "-".into(),
                driver: "-".into(),
                precision: "f64".into(),
                stage_timing: "host clock per stage".into(),
                max_blocks: default_max(true),
                ..Default::default()
            },
            Some(Engine::Cpu(Box::new(CpuBackend::new()))),
        ),
        BackendSpec::Gpu(o) => match GpuBackend::new(o) {
            Ok(g) => {
                let a = g.adapter().clone();
                let software = a.is_software();
                let info = BackendInfo {
                    label: format!("{} {} {}", a.backend.to_lowercase(), short_adapter_name(&a.name), g.precision()),
                    kind: "gpu".into(),
                    software,
                    adapter: a.name.clone(),
                    api: a.backend.clone(),
                    driver: format!("{} {}", a.driver, a.driver_info).trim().to_string(),
                    precision: g.precision().to_string(),
                    stage_timing: if g.has_timestamps() { "pass timestamps".into() } else { "isolated dispatches, host clock".into() },
                    max_blocks: default_max(software),
                    ..Default::default()
                };
                (info, Some(Engine::Gpu(Box::new(g))))
            }
            Err(e) => (
                BackendInfo {
                    label: format!("gpu {:?} {}", o.adapter, o.precision).to_lowercase(),
                    kind: "gpu".into(),
                    precision: o.precision.to_string(),
                    error: Some(e.to_string()),
                    ..Default::default()
                },
                None,
            ),
        },
    }
}

/// Runs the bench.
pub fn run(opts: &BenchOptions) -> BenchReport {
    let began = Instant::now();
    let say = |s: &str| {
        if opts.verbose {
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), "bench [{:6.1} s]: {s}", began.elapsed().as_secs_f64());
        }
    };
    let mut report = BenchReport { machine: host::machine_info(), ..Default::default() };
    report.options = OptionsEcho {
        quick: opts.quick,
        scenes: [
            ("settle", opts.settle),
            ("impact", opts.impact),
            ("sdef", opts.sdef),
            ("fluid", opts.fluid),
            ("scaling", opts.scaling),
            ("sdef-scaling", opts.sdef_scaling),
            ("zones", opts.zones),
            ("d3-cubes", opts.d3_cubes),
            ("d3-wall", opts.d3_wall),
            ("d3-impact", opts.d3_impact),
        ]
        .iter()
        .filter(|s| s.1)
        .map(|s| s.0.to_string())
        .collect(),
        sizes: opts.sizes.clone(),
        max_blocks: opts.max_blocks,
        settle_time: opts.settle_time,
        impact_time: opts.impact_time,
        frac: opts.frac,
        round: scene::ROUND,
        measure_s: opts.measure_s,
        rounds: opts.rounds,
    };
    let mut engines: Vec<(usize, Engine)> = Vec::new();
    // Each backend asked for, its entry in `report.backends` (D3's rows take its yardstick).
    let mut info_of: Vec<usize> = Vec::new();
    for spec in &opts.backends {
        let (mut info, engine) = open(spec, opts);
        if let Some(k) = report.backends.iter().position(|b| b.label == info.label) {
            info_of.push(k);
            continue;
        }
        info_of.push(report.backends.len());
        if let Some(e) = engine {
            if opts.scaling || opts.sdef_scaling || opts.zones || opts.d3_cubes || opts.d3_wall || opts.d3_impact {
                measure_bandwidth(&mut info, &e, &say);
            }
            say(&format!("{} opened ({}), {}", info.label, info.driver, report::bandwidth_summary(&info)));
            engines.push((report.backends.len(), e));
        } else {
            say(&format!("{} not available: {}", info.label, info.error.as_deref().unwrap_or("")));
        }
        report.backends.push(info);
    }

    for (scene, wanted, time) in [
        (RefScene::Settle, opts.settle, opts.settle_time),
        (RefScene::Impact, opts.impact, opts.impact_time),
        (RefScene::Sdef, opts.sdef, opts.settle_time),
        (RefScene::Fluid, opts.fluid, opts.settle_time),
    ] {
        if !wanted {
            continue;
        }
        for (i, engine) in engines.iter_mut() {
            let label = report.backends[*i].label.clone();
            say(&format!("{} ({time} s) on {label}", scene.name()));
            let mut row = run_reference(scene, time, opts.frac, engine.backend(), &label);
            if let Some(e) = &row.error {
                say(&format!("  failed: {e}"));
            } else if let Engine::Gpu(g) = engine {
                // Where a GPU cycle of the scene goes, kernel by kernel (the scenes are small:
                // their cycles are a few dispatches each, so this says which one holds them).
                match kernel_times(g, if opts.quick { 20 } else { 200 }) {
                    Ok((_, kernels)) => row.kernels = kernels,
                    Err(e) => say(&format!("  kernels not timed: {e}")),
                }
            }
            report.reference.push(row);
        }
    }

    for (wanted, sdef) in [(opts.scaling, false), (opts.sdef_scaling, true)] {
        if !wanted {
            continue;
        }
        let family = if sdef { "sdef-scaling" } else { "scaling" };
        let mut rows = Vec::new();
        let largest = report.backends.iter().filter(|b| b.error.is_none()).map(|b| b.max_blocks).max().unwrap_or(0);
        for &n in opts.sizes.iter().filter(|&&n| n <= largest) {
            let wall = scene::scaling_wall(n, opts.frac);
            say(&format!("{family}: building a wall of {} blocks", wall.brick_count() + 2));
            let engines_here = engines.iter().filter(|(i, _)| n <= report.backends[*i].max_blocks).count();
            if let Some(problem) = memory_problem(wall.brick_count() + 2, engines_here) {
                for (i, _) in engines.iter().filter(|(i, _)| n <= report.backends[*i].max_blocks) {
                    rows.push(ScalingRow { backend: report.backends[*i].label.clone(), nominal: n, error: Some(problem.clone()), ..Default::default() });
                }
                continue;
            }
            let body = if sdef { scene::scaling_body_sdef(n, opts.frac) } else { scene::scaling_body(n, opts.frac) };
            let deck = format!("{body}CYCLE 0\n");
            let built = std::time::Instant::now();
            let model0 = match crate::scenes::run_deck_on(&deck, Box::new(CpuBackend::new())) {
                Ok(m) => m,
                Err(e) => {
                    say(&format!("  the wall does not build: {e}"));
                    continue;
                }
            };
            let mut here: Vec<(&mut Engine, &BackendInfo)> =
                engines.iter_mut().map(|(i, e)| (e, &report.backends[*i])).filter(|(_, info)| n <= info.max_blocks).collect();
            let build_s = built.elapsed().as_secs_f64();
            say(&format!("{family}: {} blocks (built in {build_s:.3} s) on {} backends, {} rounds", model0.blocks.len(), here.len(), opts.rounds.max(1)));
            for mut row in measure_scaling(&model0, n, &mut here, opts) {
                row.build_s = build_s;
                if sdef {
                    // The byte model counts the rigid cycle's structs: no roofline for SDEF rows.
                    row.bytes_per_cycle = 0;
                    row.roofline = 0.0;
                    row.roofline_kernels = None;
                    row.stages.iter_mut().for_each(|st| st.bytes_per_cycle = None);
                }
                match &row.error {
                    Some(e) => say(&format!("  {} failed: {e}", row.backend)),
                    None => say(&format!(
                        "  {}: {} cycles a round, {:.3e} block-cycles/s, {:.3e} contact-cycles/s",
                        row.backend, row.cycles, row.block_cycles_per_s, row.contact_cycles_per_s
                    )),
                }
                rows.push(row);
            }
        }
        if sdef {
            report.sdef_scaling = rows;
        } else {
            report.scaling = rows;
        }
    }
    if opts.zones {
        let max = opts.max_zones.unwrap_or(if opts.quick { 1_000 } else { zones::DEFAULT_MAX_ZONES });
        for &n in zones::ZONE_SIZES.iter().filter(|&&n| n <= max) {
            let decks = [("block", zones::block_deck(n)), ("wall", zones::wall_deck(n, opts.frac))];
            for (name, deck) in decks {
                let rows = zones::measure(name, n, &deck, &mut engines, &report.backends, opts.measure_s, &say);
                report.zones.extend(rows);
            }
        }
    }
    // D3 on every backend asked for, one after the other (the GPU/CPU ratio from one run).
    for (spec, &info) in opts.backends.iter().zip(&info_of) {
        let bandwidth = report.backends[info].bandwidth_bytes_per_s;
        let on = match spec {
            BackendSpec::Cpu => "the CPU".to_string(),
            BackendSpec::Gpu(o) => format!("the GPU ({})", o.precision),
        };
        if opts.d3_cubes {
            say(&format!("d3-cubes ({} cubes) on {on}", opts.d3_cubes_n));
            report.d3.push(d3::measure("d3-cubes", &d3::cubes_deck(opts.d3_cubes_n, opts.frac), (opts.measure_s, 0), opts.rounds, spec, bandwidth));
        }
        if opts.d3_wall {
            for &n in &opts.d3_wall_sizes {
                say(&format!("d3-wall ({n} bricks) on {on}"));
                report.d3.push(d3::measure("d3-wall", &d3::wall_deck(n, opts.frac), (opts.measure_s, 0), opts.rounds, spec, bandwidth));
            }
        }
        if opts.d3_impact {
            for &n in &opts.d3_wall_sizes {
                say(&format!("d3-impact ({n} bricks) on {on}"));
                // One timed run as long as the wall's rounds together (the state moves on
                // through the impact, so rounds would time different stretches of it), and at
                // least `d3::IMPACT_CYCLES`: the cube strikes in the first ~100.
                let measure_s = opts.measure_s * opts.rounds.max(1) as f64;
                let least = if opts.quick { d3::IMPACT_CYCLES / 4 } else { d3::IMPACT_CYCLES };
                report.d3.push(d3::measure("d3-impact", &d3::impact_deck(n, opts.frac), (measure_s, least), 1, spec, bandwidth));
            }
        }
    }
    report.targets = report::targets(&report);
    report
}

/// Each kernel's time per cycle over `cycles` cycles from the state the last run left (pass
/// timestamps, `GpuBackend::profile_stages`), in dispatch order, and how they were timed.
pub(super) fn kernel_times(g: &mut GpuBackend, cycles: u32) -> Result<(String, Vec<(String, f64)>), crate::udec::gpu::GpuError> {
    let p = g.profile_stages(cycles)?;
    Ok((format!("{} over {} cycles", p.method, p.cycles), p.stages.iter().map(|(name, t)| (name.to_string(), *t)).collect()))
}

/// Why a wall of `blocks` blocks should not be built here, if it should not: the host model (and
/// the checkpoint copy each backend keeps) must fit in the memory available.
fn memory_problem(blocks: usize, engines: usize) -> Option<String> {
    use crate::udec::model::{Block, Contact, Corner};
    // Per block: the block, 4 corners, about 8 contacts, for the bench's pristine copy and, on
    // each backend measured in turn, the model and the backend's last good state; plus the deck
    // line.
    let copies = 1 + 2 * engines.max(1);
    let per_block = copies * (std::mem::size_of::<Block>() + 4 * std::mem::size_of::<Corner>() + 8 * std::mem::size_of::<Contact>()) + 64;
    let need = (blocks * per_block) as u64;
    let available = host::memory_available()?;
    (need > available / 10 * 7)
        .then(|| format!("not enough memory: a wall of {blocks} blocks needs about {} MiB, {} MiB available", need >> 20, available >> 20))
}

/// A backend that counts the contact updates of its runs.
struct Counting<B>(B, std::rc::Rc<std::cell::Cell<u64>>);

impl<B: Backend> Backend for Counting<B> {
    fn describe(&self) -> String {
        self.0.describe()
    }
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        let before = report.topology_updates;
        let result = self.0.run_into(model, cycles, progress, report);
        self.1.set(self.1.get() + report.topology_updates - before);
        result
    }
}

/// Runs one reference scene on `backend`: the deck with its CYCLE command, timed whole.
fn run_reference(scene: RefScene, time: f64, frac: f64, backend: &mut dyn Backend, label: &str) -> ReferenceRow {
    let mut row = ReferenceRow { scene: scene.name().into(), backend: label.into(), simulated_s: time, ..Default::default() };
    let body = scene::reference_body(scene, frac);
    let wall = scene::reference_wall(frac);
    let initial = match crate::scenes::run_deck_on(&body, Box::new(CpuBackend::new())) {
        Ok(m) => m,
        Err(e) => {
            row.error = Some(e.to_string());
            return row;
        }
    };
    let (cycles, dt) = match scene::cycles_for(&body, time) {
        Ok(c) => c,
        Err(e) => {
            row.error = Some(e.to_string());
            return row;
        }
    };
    row.cycles = cycles;
    row.timestep = dt;
    let deck = format!("{body}CYCLE {cycles}\n");
    let updates = std::rc::Rc::new(std::cell::Cell::new(0u64));
    let start = Instant::now();
    profile::enable();
    let result = crate::scenes::run_deck_logged(&deck, Box::new(Counting(Borrowed(backend), updates.clone())), Box::new(std::io::sink()));
    let times = profile::take();
    row.wall_s = start.elapsed().as_secs_f64();
    row.topology_updates = updates.get();
    for s in Stage::ALL {
        let t = (times.setup_of(s) + times.cycles_of(s) + times.teardown_of(s)).as_secs_f64();
        if t > 0.0 {
            row.stages.push((s.name().to_string(), s.group().to_string(), t));
        }
    }
    match result {
        Ok(model) => {
            row.blocks = model.blocks.len();
            row.contacts = model.contacts.len();
            row.cycles_per_s = cycles as f64 / row.wall_s;
            row.measures = Some(scene::measure(&wall, &initial, &model));
        }
        Err(e) => row.error = Some(e.to_string()),
    }
    row
}

/// A run timed with the stage profiler on: how `blockdem bench` and the criterion benches
/// (`benches/`) time the cycles apart from a run's set-up and final read-back.
pub struct Timed {
    /// Before the first cycle: the full detection and, on a GPU, the upload (none when the run
    /// goes on from the state the last one left).
    pub setup_s: f64,
    /// After the last cycle: the GPU's final read-back.
    pub teardown_s: f64,
    /// The cycles.
    pub steady_s: f64,
    /// Self time of each host stage, per phase.
    pub times: StageTimes,
    /// Contact updates the run made (its set-up's full detection not counted).
    pub updates: u64,
}

impl Timed {
    /// The cycles' CPU topology work (stage 7) and host ↔ device transfers, in seconds: the
    /// numerator of the bench's topology and transfer shares.
    pub fn topology_and_transfers_s(&self) -> f64 {
        Stage::ALL.iter().filter(|s| matches!(s.group(), "topology" | "transfer")).map(|&s| self.times.cycles_of(s).as_secs_f64()).sum()
    }
}

/// Runs `cycles` cycles of `model` on `backend` with the stage profiler on (`Timed`).
pub fn timed_run(backend: &mut dyn Backend, model: &mut Model, cycles: u64) -> Result<Timed, CycleError> {
    profile::enable();
    let start = Instant::now();
    let result = backend.run(model, cycles, &mut |_| true);
    let end = Instant::now();
    let times = profile::take();
    let report = result?;
    let mark = times.cycles_start.unwrap_or(start);
    let last = times.cycles_end.unwrap_or(end);
    // (A run that starts from the model counts its full detection as an update too.)
    let full_detection = times.setup_of(Stage::DetectFull) > std::time::Duration::ZERO;
    let updates = report.topology_updates.saturating_sub(u64::from(full_detection));
    Ok(Timed { setup_s: (mark - start).as_secs_f64(), steady_s: (last - mark).as_secs_f64(), teardown_s: (end - last).as_secs_f64(), times, updates })
}

/// One wall on each backend of `engines`: settled and calibrated on each, then timed in
/// `opts.rounds` rounds, the backends taking turns (module doc). One row per backend.
fn measure_scaling(model0: &Model, nominal: usize, engines: &mut [(&mut Engine, &BackendInfo)], opts: &BenchOptions) -> Vec<ScalingRow> {
    let rounds = opts.rounds.max(1) as u64;
    // Per backend: its model, the cycles of one round, its timed rounds, or why it stopped.
    let mut runs: Vec<(Model, u64, Vec<Timed>, Option<String>)> = Vec::with_capacity(engines.len());
    for (engine, _) in engines.iter_mut() {
        let mut model = model0.clone();
        let prepared = (|| -> Result<u64, CycleError> {
            let backend = engine.backend();
            backend.run(&mut model, SETTLE_CYCLES, &mut |_| true)?;
            let calibration = timed_run(backend, &mut model, 10)?;
            let per_cycle = (calibration.steady_s / 10.0).max(1e-7);
            Ok(((opts.measure_s / rounds as f64 / per_cycle).ceil() as u64).clamp(10, 1_000_000))
        })();
        match prepared {
            Ok(cycles) => runs.push((model, cycles, Vec::new(), None)),
            Err(e) => runs.push((model, 0, Vec::new(), Some(e.to_string()))),
        }
    }
    for _ in 0..rounds {
        for ((engine, _), (model, cycles, timed, error)) in engines.iter_mut().zip(runs.iter_mut()) {
            if error.is_some() {
                continue;
            }
            match timed_run(engine.backend(), model, *cycles) {
                Ok(t) => timed.push(t),
                Err(e) => *error = Some(e.to_string()),
            }
        }
    }
    engines
        .iter_mut()
        .zip(runs)
        .map(|((engine, info), (model, cycles, timed, error))| finish_scaling(model0, nominal, engine, info, opts, &model, cycles, timed, error))
        .collect()
}

/// The row of one backend's rounds: the rates of its round of median time per cycle, then (GPU)
/// the kernels timed per stage on the state the rounds left.
#[allow(clippy::too_many_arguments)]
fn finish_scaling(
    model0: &Model,
    nominal: usize,
    engine: &mut Engine,
    info: &BackendInfo,
    opts: &BenchOptions,
    model: &Model,
    cycles: u64,
    mut timed: Vec<Timed>,
    error: Option<String>,
) -> ScalingRow {
    let mut row = ScalingRow {
        backend: info.label.clone(),
        nominal,
        blocks: model0.blocks.len(),
        corners: model0.corners.len(),
        contacts: model0.contacts.len(),
        ..Default::default()
    };
    if let Some(e) = error {
        row.error = Some(e);
        return row;
    }
    row.round_s_per_cycle = timed.iter().map(|t| t.steady_s / cycles as f64).collect();
    timed.sort_by(|a, b| a.steady_s.total_cmp(&b.steady_s));
    let median = timed.swap_remove(timed.len() / 2);
    fill_timing(&mut row, model, cycles, &median, info);
    match engine {
        Engine::Cpu(_) => {
            let bytes = host::cpu_bytes_per_cycle(row.blocks, row.corners, row.contacts);
            for s in &mut row.stages {
                if let Some(b) = bytes.iter().find(|b| b.stage == s.stage) {
                    s.bytes_per_cycle = Some(b.read + b.written);
                }
            }
            row.bytes_per_cycle = bytes.iter().map(|b| b.read + b.written).sum();
        }
        Engine::Gpu(g) => {
            let bytes = g.bytes_per_cycle(row.blocks, row.corners, row.contacts, model.materials.len());
            row.bytes_per_cycle = bytes.iter().map(|b| b.read + b.written).sum();
            // Kernel times on the state the run left (a fraction of the measurement's time).
            let reps = ((0.2 * opts.measure_s / row.s_per_cycle.max(1e-7)) as u32).clamp(3, 400);
            match g.profile_stages(reps) {
                Ok(p) => {
                    row.device_timing = Some(format!("{} over {} cycles", p.method, p.cycles));
                    let mut kernels = 0.0;
                    for (name, s) in &p.stages {
                        kernels += s;
                        let b = bytes.iter().find(|b| b.stage == *name).map(|b| b.read + b.written);
                        row.stages.push(StageRow {
                            source: "device".into(),
                            stage: name.to_string(),
                            group: "kernel".into(),
                            s_per_cycle: *s,
                            bytes_per_cycle: b,
                        });
                    }
                    if kernels > 0.0 && row.bandwidth_bytes_per_s > 0.0 {
                        row.roofline_kernels = Some(row.bytes_per_cycle as f64 / kernels / row.bandwidth_bytes_per_s);
                    }
                }
                Err(e) => row.device_timing = Some(format!("not measured: {e}")),
            }
        }
    }
    if row.bandwidth_bytes_per_s > 0.0 && row.s_per_cycle > 0.0 {
        row.roofline = row.bytes_per_cycle as f64 / row.s_per_cycle / row.bandwidth_bytes_per_s;
    }
    row
}

/// Rates, stage rows and shares of a timed run.
fn fill_timing(row: &mut ScalingRow, model: &Model, cycles: u64, run: &Timed, info: &BackendInfo) {
    row.blocks = model.blocks.len();
    row.corners = model.corners.len();
    row.contacts = model.contacts.len();
    row.cycles = cycles;
    row.setup_s = run.setup_s;
    row.teardown_s = run.teardown_s;
    row.steady_s = run.steady_s;
    row.s_per_cycle = run.steady_s / cycles as f64;
    row.s_per_block_cycle = row.s_per_cycle / row.blocks.max(1) as f64;
    row.block_cycles_per_s = (row.blocks as u64 * cycles) as f64 / run.steady_s;
    row.contact_cycles_per_s = (row.contacts as u64 * cycles) as f64 / run.steady_s;
    row.bandwidth_bytes_per_s = info.bandwidth_bytes_per_s.unwrap_or(0.0);
    let mut accounted = 0.0;
    let (mut topology, mut transfer, mut run_tt) = (0.0, 0.0, 0.0);
    for s in Stage::ALL {
        let d = run.times.cycles_of(s).as_secs_f64();
        let setup = run.times.setup_of(s).as_secs_f64() + run.times.teardown_of(s).as_secs_f64();
        match s.group() {
            "topology" => {
                topology += d;
                run_tt += d + setup;
            }
            "transfer" => {
                transfer += d;
                run_tt += d + setup;
            }
            _ => {}
        }
        if d > 0.0 {
            accounted += d;
            row.stages.push(StageRow {
                source: "host".into(),
                stage: s.name().into(),
                group: s.group().into(),
                s_per_cycle: d / cycles as f64,
                bytes_per_cycle: None,
            });
        }
    }
    let other = (run.steady_s - accounted).max(0.0);
    row.stages.push(StageRow {
        source: "host".into(),
        stage: "other".into(),
        group: "other".into(),
        s_per_cycle: other / cycles as f64,
        bytes_per_cycle: None,
    });
    row.topology_share = topology / run.steady_s;
    row.transfer_share = transfer / run.steady_s;
    row.topology_updates = run.updates;
    row.host_s_per_update = if run.updates > 0 { (topology + transfer) / run.updates as f64 } else { 0.0 };
    row.run_topology_transfer_share = run_tt / (run.steady_s + run.setup_s + run.teardown_s);
}
