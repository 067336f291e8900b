//! `blockdem`: run UDEC 1.2 command decks.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use anyhow::{bail, Context};
use clap::{Parser, Subcommand, ValueEnum};

use blockdem::udec::backend::{Backend, GpuOrCpu};
use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::exec::{Executor, Progress, RunError, RunOptions};
use blockdem::udec::gpu::{list_adapters, matching_adapters, AdapterChoice, GpuBackend, GpuOptions, Precision};
use blockdem::udec::output::provenance::Provenance;

/// Standard output, as every subcommand writes it (its tables, `wrote FILE` lines, the run log):
/// a write that fails never panics, as `println!` does. A reader that leaves (`| head`, `| true`)
/// ends the output quietly while the work goes on and writes its files, and the exit status is
/// the work's own; any other failure (a full disk under `> run.log`) is kept and reported once
/// at the end, with exit status 1. Output after a failure is dropped.
struct Stdout;

/// Set once a write to standard output has failed: nothing more is written.
static STDOUT_FAILED: AtomicBool = AtomicBool::new(false);
/// The first failure other than a closed pipe, reported when the command ends.
static STDOUT_ERROR: Mutex<Option<std::io::Error>> = Mutex::new(None);

impl Stdout {
    fn failed(e: std::io::Error) {
        if !STDOUT_FAILED.swap(true, Ordering::Relaxed) && e.kind() != std::io::ErrorKind::BrokenPipe {
            if let Ok(mut first) = STDOUT_ERROR.lock() {
                *first = Some(e);
            }
        }
    }

    /// The failure to report, if standard output failed other than by its reader leaving.
    fn error() -> Option<std::io::Error> {
        STDOUT_ERROR.lock().ok().and_then(|mut e| e.take())
    }
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if !STDOUT_FAILED.load(Ordering::Relaxed) {
            if let Err(e) = std::io::stdout().lock().write_all(buf) {
                Stdout::failed(e);
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if !STDOUT_FAILED.load(Ordering::Relaxed) {
            if let Err(e) = std::io::stdout().lock().flush() {
                Stdout::failed(e);
            }
        }
        Ok(())
    }
}

/// `println!` through [`Stdout`].
macro_rules! say {
    ($($arg:tt)*) => {{
        let _ = writeln!(Stdout, $($arg)*);
    }};
}

/// `eprintln!` that never panics: a message to a closed standard error is lost, not a crash.
macro_rules! note {
    ($($arg:tt)*) => {{
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

#[derive(Parser)]
#[command(name = "blockdem", version, about = "Distinct element code for jointed rock (UDEC 1.2 / D3 after Cundall & Hart 1985)")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum BackendChoice {
    /// A hardware GPU adapter when there is one, otherwise the CPU.
    Auto,
    /// The f64 CPU backend (the accuracy reference).
    Cpu,
    /// The wgpu backend (a GPU adapter, or Mesa's lavapipe / llvmpipe on a CPU).
    Gpu,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum PrecisionChoice {
    /// Single precision (every adapter).
    F32,
    /// Double precision (adapters with SHADER_F64, e.g. Vulkan; not GL).
    F64,
}

impl From<PrecisionChoice> for Precision {
    fn from(p: PrecisionChoice) -> Precision {
        match p {
            PrecisionChoice::F32 => Precision::F32,
            PrecisionChoice::F64 => Precision::F64,
        }
    }
}

/// `blockdem run`'s arguments.
#[derive(clap::Args)]
struct RunArgs {
    /// The deck file.
    deck: PathBuf,
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// GPU adapter: vulkan, gl, any, or part of an adapter's name (see `blockdem adapters`).
    /// WGPU_BACKEND and WGPU_ADAPTER_NAME are honoured too. [default: any]
    #[arg(long)]
    adapter: Option<String>,
    /// Kernel precision on the GPU (the CPU is always f64). [default: f32]
    #[arg(long, value_enum)]
    precision: Option<PrecisionChoice>,
    /// Folder for PLOT files and SAVE / RESTART files named without a folder.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Write the final state as JSON (also after a numerical failure: the last good state).
    #[arg(long)]
    state_json: Option<PathBuf>,
    /// Write a running restart file, OUT/checkpoint.sav, about every SECONDS during long
    /// CYCLE commands (a run killed outright loses at most that much; RESTART goes on).
    #[arg(long, value_name = "SECONDS", value_parser = seconds, allow_negative_numbers = true)]
    checkpoint_every: Option<f64>,
    /// Write VTK frames for ParaView (blocks and contacts, OUT/vtk/, with .series files of
    /// their times) at the start of each CYCLE and every CYCLES cycles of it (rounded up to
    /// a multiple of 100).
    #[arg(long, value_name = "CYCLES", value_parser = count::<u64>, allow_negative_numbers = true)]
    vtk_every: Option<u64>,
    /// The engine: 2 (UDEC) or 3 (D3). [default: 3 when the deck has a BLOCK of (x,y,z)
    /// vertices, a BOX or a GRAVITY of three components, else 2]
    #[arg(long, value_parser = clap::value_parser!(u8).range(2..=3))]
    dim: Option<u8>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a command deck (START … STOP/END).
    Run(RunArgs),
    /// List the GPU adapters wgpu finds (Vulkan and GL/EGL, off-screen) with their limits.
    Adapters,
    /// Run a deck on the f64 CPU reference and on a GPU backend and report how far the GPU's final
    /// state lies from the reference's (positions, rotations, velocities, energies), with the
    /// wall times of both; each run's log and outputs go to OUT/cpu and OUT/gpu, the figures to
    /// OUT/compare.json.
    Compare {
        /// The deck file.
        deck: PathBuf,
        /// GPU adapter: vulkan, gl, any, or part of an adapter's name (see `blockdem adapters`).
        #[arg(long, default_value = "any")]
        adapter: String,
        /// Kernel precision on the GPU.
        #[arg(long, value_enum, default_value_t = PrecisionChoice::F32)]
        precision: PrecisionChoice,
        /// Folder for the two runs' logs and outputs and compare.json.
        #[arg(long, default_value = "compare-out")]
        out: PathBuf,
        /// Fail (non-zero exit) when a block's position differs by more than TOL rounding
        /// lengths, its rotation by more than TOL radians or its velocity by more than TOL of
        /// the speed scale (the reference's top speed, or √(2E/M) for a model at rest), or the
        /// runs end on different blocks.
        #[arg(long, value_name = "TOL", allow_negative_numbers = true)]
        tolerance: Option<f64>,
    },
    /// Run the closed-form verification suite on every backend: a table of errors and costs, CSV
    /// files and charts in --out. Exits non-zero when a check fails.
    Verify {
        /// The CI suite (fewer FRACTIONs, shorter stability bisections; well under 3 minutes).
        #[arg(long)]
        quick: bool,
        /// Folder for the CSV files and PNG charts.
        #[arg(long, default_value = "verify-out")]
        out: PathBuf,
        /// Run only the cases whose name contains this.
        #[arg(long)]
        only: Option<String>,
    },
    /// Throughput on brick walls of 10^3 to 10^6 blocks and the reference wall (settle, impact)
    /// on every backend, adapter and precision present: a table of rates, stage times, roofline
    /// ratios and the targets; bench.csv, bench.json and bench.png (and more CSV) in --out.
    Bench {
        /// A short run (well under a minute): shortened reference scenes, walls up to 10^4 blocks.
        #[arg(long)]
        quick: bool,
        /// Folder for the CSV, JSON and PNG files.
        #[arg(long, default_value = "bench-out")]
        out: PathBuf,
        /// Which scenes, one or several separated by commas (e.g. `scaling,sdef-scaling`): the
        /// reference settle or impact, the settle with simply-deformable bricks (sdef) or with
        /// fluid in its joints (fluid), each with the dry settle it is measured against, the
        /// scaling families, the zoned family, D3's scenes, or all.
        #[arg(long, value_enum, value_delimiter = ',', default_value = "all")]
        scene: Vec<BenchScene>,
        /// Which backends: all present, the CPU, or the GPU adapters.
        #[arg(long, value_enum, default_value_t = BenchBackends::All)]
        backend: BenchBackends,
        /// GPU adapters: any (every adapter found), vulkan, gl, or part of an adapter's name.
        #[arg(long, default_value = "any")]
        adapter: String,
        /// GPU precisions: both where the adapter has f64, or one.
        #[arg(long, value_enum)]
        precision: Option<PrecisionChoice>,
        /// Largest wall of the scaling family (blocks). Default: 10^5 on the CPU and software
        /// adapters, 10^6 on hardware GPUs, 10^4 with --quick.
        #[arg(long, value_parser = count::<usize>, allow_negative_numbers = true)]
        max_blocks: Option<usize>,
        /// Nominal sizes of the scaling family, comma-separated (default 1000,10000,100000,1000000;
        /// those above --max-blocks are left out).
        #[arg(long, value_delimiter = ',', value_parser = count::<usize>, allow_negative_numbers = true)]
        sizes: Option<Vec<usize>>,
        /// Simulated seconds of the settle scene (default 2, 0.1 with --quick).
        #[arg(long, value_parser = positive, allow_negative_numbers = true)]
        settle_time: Option<f64>,
        /// Simulated seconds of the impact scene (default 1, 0.1 with --quick).
        #[arg(long, value_parser = positive, allow_negative_numbers = true)]
        impact_time: Option<f64>,
        /// FRACTION of the time step for every scene (default UDEC's 0.1).
        #[arg(long, value_parser = positive, allow_negative_numbers = true)]
        frac: Option<f64>,
        /// Wall seconds each scaling measurement aims at (default 1.5, 0.25 with --quick);
        /// longer runs average out the noise of a shared machine.
        #[arg(long, value_parser = positive, allow_negative_numbers = true)]
        measure: Option<f64>,
        /// Rounds each scaling measurement is cut into, the backends taking turns, so that a
        /// ratio of two backends is taken from runs seconds apart (default 3, 1 with --quick).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100), allow_negative_numbers = true)]
        rounds: Option<u32>,
        /// Largest scene of the zoned family (zones; default 10^5, 10^3 with --quick; 10^6 only
        /// when asked: its mesh takes minutes to generate).
        #[arg(long, value_parser = count::<usize>, allow_negative_numbers = true)]
        max_zones: Option<usize>,
    },
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum BenchScene {
    Settle,
    Impact,
    /// The settle scene with simply-deformable bricks, and the dry settle scene it is measured
    /// against (its cost per cycle against settle's).
    Sdef,
    /// The settle scene with fluid in the wall's joints, and the dry settle scene it is measured
    /// against back to back.
    Fluid,
    Scaling,
    /// The scaling family with simply-deformable bricks (10^3 to 10^6 blocks, against the rigid walls when both run)
    SdefScaling,
    /// The zoned scene family (fully-deformable blocks: one large block, a wall of zoned bricks).
    Zones,
    /// D3: 1000 unit cubes in a lattice falling on a slab (body-steps/s; CPU).
    D3Cubes,
    /// D3: a brick wall of 10^3 and 10^4 bricks struck by a cube (contact-cycles/s; CPU).
    D3Wall,
    /// D3: the same wall timed through the cube's impact (contact-cycles/s, the detections' share, the energy ledger's closure).
    D3Impact,
    All,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum BenchBackends {
    All,
    Cpu,
    Gpu,
}

#[allow(clippy::too_many_arguments)]
fn bench(
    quick: bool,
    out: PathBuf,
    scenes: Vec<BenchScene>,
    backend: BenchBackends,
    adapter: String,
    precision: Option<PrecisionChoice>,
    max_blocks: Option<usize>,
    sizes: Option<Vec<usize>>,
    settle_time: Option<f64>,
    impact_time: Option<f64>,
    frac: Option<f64>,
    measure: Option<f64>,
    rounds: Option<u32>,
    max_zones: Option<usize>,
) -> anyhow::Result<()> {
    check_out_dir(&out)?;
    let choice: AdapterChoice = adapter.parse().unwrap_or(AdapterChoice::Any);
    let precision = precision.map(Precision::from);
    let specs = blockdem::bench::present_backends(backend != BenchBackends::Gpu, backend != BenchBackends::Cpu, &choice, precision);
    let gpu_specs = specs.iter().filter(|s| matches!(s, blockdem::bench::BackendSpec::Gpu(_))).count();
    if backend != BenchBackends::Cpu && gpu_specs == 0 {
        // Say why: no adapter at all, or adapters without the f64 asked of them.
        let found: Vec<String> = matching_adapters(&choice).into_iter().filter(|a| a.compute).map(|a| format!("{} ({})", a.name, a.backend)).collect();
        let why = if found.is_empty() {
            format!("no GPU adapter found for --adapter {adapter}")
        } else {
            format!(
                "--precision f64 needs SHADER_F64, which {} (found for --adapter {adapter}) lacks; use --precision f32 or a Vulkan adapter",
                found.join(", ")
            )
        };
        if specs.is_empty() {
            bail!("no backend to benchmark: {why}");
        }
        note!("blockdem: benchmarking the CPU only: {why}");
    }
    let mut options = blockdem::bench::BenchOptions::new(quick, specs);
    // Whether any scene asked for is one of `these` (or all).
    let wanted = |these: &[BenchScene]| scenes.iter().any(|s| *s == BenchScene::All || these.contains(s));
    options.settle = wanted(&[BenchScene::Settle, BenchScene::Sdef, BenchScene::Fluid]);
    options.impact = wanted(&[BenchScene::Impact]);
    options.sdef = wanted(&[BenchScene::Sdef]);
    options.fluid = wanted(&[BenchScene::Fluid]);
    options.scaling = wanted(&[BenchScene::Scaling]);
    options.sdef_scaling = wanted(&[BenchScene::SdefScaling]);
    options.zones = wanted(&[BenchScene::Zones]);
    options.d3_cubes = wanted(&[BenchScene::D3Cubes]);
    options.d3_wall = wanted(&[BenchScene::D3Wall]);
    options.d3_impact = wanted(&[BenchScene::D3Impact]);
    // --sizes: the D3 walls' brick counts when one is asked for and no scaling family is (the
    // families' sizes otherwise).
    let d3_sizes = (scenes.contains(&BenchScene::D3Wall) || scenes.contains(&BenchScene::D3Impact)) && !options.scaling && !options.sdef_scaling;
    if let (true, Some(sizes)) = (d3_sizes, &sizes) {
        options.d3_wall_sizes = sizes.clone();
    }
    options.max_zones = max_zones;
    options.max_blocks = max_blocks;
    if let Some(sizes) = sizes {
        options.sizes = sizes;
    }
    options.verbose = true;
    if let Some(t) = settle_time {
        options.settle_time = t;
    }
    if let Some(t) = impact_time {
        options.impact_time = t;
    }
    // Each checked above zero by its parser (`positive`).
    if let Some(f) = frac {
        options.frac = f;
    }
    if let Some(m) = measure {
        options.measure_s = m;
    }
    if let Some(r) = rounds {
        options.rounds = r;
    }
    let report = blockdem::bench::run(&options);
    let _ = write!(Stdout, "{}", blockdem::bench::table(&report));
    let (files, chart_problem) = blockdem::bench::write_outputs(&report, &out).with_context(|| format!("cannot write into {}", out.display()))?;
    for f in files {
        say!("wrote {}", f.display());
    }
    if let Some(p) = chart_problem {
        note!("blockdem: chart not drawn: {p}");
    }
    let failed: Vec<String> = report.reference.iter().filter_map(|r| r.error.as_ref().map(|e| format!("{} on {}: {e}", r.scene, r.backend))).collect();
    if !failed.is_empty() {
        bail!("reference scene failed: {}", failed.join("; "));
    }
    Ok(())
}

fn verify(quick: bool, out: PathBuf, only: Option<String>) -> anyhow::Result<()> {
    // A misspelt case would run nothing and pass.
    if let Some(o) = &only {
        let names: Vec<&str> = blockdem::verify::cases::all().iter().map(|c| c.name).collect();
        if !names.iter().any(|n| n.contains(o.as_str())) {
            bail!("--only {o}: no case's name contains it; the cases are {}", names.join(", "));
        }
    }
    check_out_dir(&out)?;
    let options = blockdem::verify::VerifyOptions { quick, out: Some(out.clone()), only, side_by_side: false };
    let suite = blockdem::verify::run_suite(&options);
    let _ = write!(Stdout, "{}", blockdem::verify::table(&suite));
    let (files, chart_problem) = blockdem::verify::write_outputs(&suite, &out).with_context(|| format!("cannot write into {}", out.display()))?;
    for f in files {
        say!("wrote {}", f.display());
    }
    if let Some(p) = chart_problem {
        note!("blockdem: charts not drawn: {p}");
    }
    let failed: Vec<String> = suite.failed_checks().iter().map(|r| format!("{} ({} {})", r.case, r.backend, r.precision)).collect();
    let unstable: Vec<&str> = suite.stability.iter().filter(|t| !t.passed).map(|t| t.scene).collect();
    if !failed.is_empty() || !unstable.is_empty() {
        bail!("verification failed: closed-form checks {:?}, stability estimates {:?}", failed, unstable);
    }
    Ok(())
}

fn compare(deck: PathBuf, adapter: String, precision: PrecisionChoice, out: PathBuf, tolerance: Option<f64>) -> anyhow::Result<()> {
    use blockdem::compare;
    if tolerance.is_some_and(|t| t.is_nan() || t < 0.0 || t.is_infinite()) {
        bail!("--tolerance must be a number, zero or more");
    }
    let name = deck.display().to_string();
    let bytes = blockdem::udec::deck::parse::read_deck(&deck, &name)?;
    // A 3D deck (README, "2D or 3D"): D3 on the CPU and on the GPU.
    if let Ok(text) = blockdem::udec::deck::parse::lenient_text(&bytes) {
        if blockdem::d3::deck::three_dimensional(&blockdem::deck::lexer::split(&text, &name)?).is_some() {
            return compare_d3(&text, &name, adapter, precision, out, tolerance);
        }
    }
    let commands = blockdem::udec::deck::parse::parse_deck_bytes(&bytes, &name)?;
    warn_after_end(&bytes, &commands, &name);
    check_out_dir(&out)?;
    let choice: AdapterChoice = adapter.parse().unwrap_or(AdapterChoice::Any);
    let gpu = GpuBackend::new(&GpuOptions { adapter: choice, precision: precision.into() }).map_err(|e| anyhow::anyhow!("compare needs a GPU adapter: {e}"))?;
    note!("blockdem: running {name} on the CPU (f64), then on {}", gpu.describe());
    // The logs go to files: long CYCLE commands say how far they are on stderr, as `run` does.
    let progress = Progress::Lines { every: std::time::Duration::from_secs(30) };
    let reference = compare::run_on(Box::new(CpuBackend::new()), &commands, &name, &out.join("cpu"), progress);
    let on_gpu = compare::run_on(Box::new(gpu), &commands, &name, &out.join("gpu"), progress);
    let c = compare::compare(&reference, &on_gpu);
    finish_compare(&name, &reference, &on_gpu, &c, &out, tolerance, ", or other ids")
}

/// The end of `blockdem compare`, 2D and 3D alike: the table, compare.json, and the verdict (a
/// run that stopped where the other did not, or a difference past `--tolerance`). `differ` adds
/// to the counts of blocks in the message for runs that end on different blocks.
fn finish_compare<M>(
    name: &str,
    reference: &blockdem::compare::Outcome<M>,
    on_gpu: &blockdem::compare::Outcome<M>,
    c: &blockdem::compare::Comparison,
    out: &std::path::Path,
    tolerance: Option<f64>,
    differ: &str,
) -> anyhow::Result<()> {
    use blockdem::compare;
    let _ = write!(Stdout, "{}", compare::table(reference, on_gpu, c));
    let json = serde_json::json!({
        "deck": name,
        "reference": { "backend": reference.backend, "wall_s": reference.wall_s, "error": reference.error },
        "gpu": { "backend": on_gpu.backend, "wall_s": on_gpu.wall_s, "error": on_gpu.error },
        "comparison": c,
    });
    let path = out.join("compare.json");
    std::fs::write(&path, serde_json::to_string_pretty(&json)?).with_context(|| format!("cannot write {}", path.display()))?;
    say!("wrote {}", path.display());
    match (&reference.error, &on_gpu.error) {
        (None, Some(e)) => bail!("the GPU run stopped where the reference did not: {e}"),
        (Some(e), None) => bail!("the reference run stopped where the GPU's did not: {e}"),
        (Some(e), Some(_)) => bail!("both runs stopped (the reference: {e})"),
        (None, None) => {}
    }
    if let Some(tol) = tolerance {
        if !c.same_blocks {
            bail!("the runs end on different blocks ({} and {}{differ}): a crack or deletion differs", c.blocks[0], c.blocks[1]);
        }
        for (what, l) in [("position", c.position), ("rotation", c.rotation), ("velocity", c.velocity)] {
            if l.relative.is_nan() || l.relative > tol {
                bail!("block {}'s {what} differs by {:.3e} relative, more than the tolerance {tol:e}", l.block, l.relative);
            }
        }
    }
    Ok(())
}

/// `blockdem compare` of a 3D deck: D3 on the CPU (f64) and on the GPU, the same report.
fn compare_d3(text: &str, name: &str, adapter: String, precision: PrecisionChoice, out: PathBuf, tolerance: Option<f64>) -> anyhow::Result<()> {
    use blockdem::compare;
    let commands = blockdem::d3::deck::parse_deck(text, name)?;
    check_out_dir(&out)?;
    let choice: AdapterChoice = adapter.parse().unwrap_or(AdapterChoice::Any);
    let gpu = blockdem::d3::gpu::GpuBackend::new(&choice, precision.into()).map_err(|e| anyhow::anyhow!("compare needs a GPU adapter: {e}"))?;
    note!("blockdem: running {name} (a 3D deck, D3) on the CPU (f64), then on {}", blockdem::d3::backend::Backend::describe(&gpu));
    let progress = Progress::Lines { every: std::time::Duration::from_secs(30) };
    let reference = compare::run_d3_on(Box::new(blockdem::d3::cpu::CpuBackend::new()), &commands, name, &out.join("cpu"), progress);
    let on_gpu = compare::run_d3_on(Box::new(gpu), &commands, name, &out.join("gpu"), progress);
    let c = compare::compare_d3(&reference, &on_gpu);
    finish_compare(name, &reference, &on_gpu, &c, &out, tolerance, "")
}

fn adapters() -> anyhow::Result<()> {
    let list = list_adapters(&AdapterChoice::Any);
    if list.is_empty() {
        say!("no GPU adapter found (Vulkan or GL); runs use the CPU backend");
        return Ok(());
    }
    for (i, a) in list.iter().enumerate() {
        say!("[{i}] {} ({}, {})", a.name, a.backend, a.device_type);
        say!("    driver: {} ({})", a.driver_name(), if a.driver_info.trim().is_empty() { "no driver information" } else { &a.driver_info });
        say!("    max_storage_buffers_per_shader_stage: {}", a.max_storage_buffers_per_shader_stage);
        say!("    max_storage_buffer_binding_size: {}", a.max_storage_buffer_binding_size);
        say!("    max_buffer_size: {}", a.max_buffer_size);
        say!("    max_compute_workgroup_size_x: {}", a.max_compute_workgroup_size_x);
        say!("    SHADER_F64: {}", if a.shader_f64 { "yes" } else { "no" });
        say!("    compute shaders: {}", if a.compute { "yes" } else { "no (unusable)" });
    }
    Ok(())
}

/// Commands after END are not run: says so, with the line of the first (issue 27 item 9).
fn warn_after_end(bytes: &[u8], commands: &[blockdem::udec::deck::Located], file: &str) {
    let Some(end) = commands.last().filter(|c| c.command == blockdem::udec::deck::Command::End) else {
        return;
    };
    // Blank lines, comments and lines of separators only are not commands.
    let ignored = |line: &[u8]| {
        let text = String::from_utf8_lossy(line);
        let t = text.trim_matches(|c: char| c.is_whitespace() || matches!(c, '=' | '(' | ')' | ',' | '/'));
        t.is_empty() || t.starts_with('*')
    };
    if let Some(i) = bytes.split(|&b| b == b'\n').skip(end.line).position(|l| !ignored(l)) {
        note!("blockdem: {file}:{}: text after END is ignored (from this line on)", end.line + 1 + i);
    }
}

/// Refuses an output folder that cannot be made or written before the work starts, not after
/// hours of it: `--out` naming a file (or a folder under a file), or a place this user cannot
/// write. The folder itself is made only when something is written to it.
fn check_out_dir(out: &Path) -> anyhow::Result<()> {
    check_writable_folder(out, &format!("--out {}:", out.display()))
}

/// `check_out_dir` for a file an option names (`--state-json`): not a folder, and its folder one
/// that can be made and written.
fn check_out_file(path: &Path, option: &str) -> anyhow::Result<()> {
    if path.is_dir() {
        bail!("{option} {}: is a folder; give a file name", path.display());
    }
    match path.parent() {
        Some(folder) => check_writable_folder(folder, &format!("{option} {}:", path.display())),
        None => Ok(()),
    }
}

/// The walk behind `check_out_dir` and `check_out_file`; `what` starts each message.
fn check_writable_folder(out: &Path, what: &str) -> anyhow::Result<()> {
    for place in out.ancestors() {
        let place = if place.as_os_str().is_empty() { Path::new(".") } else { place };
        match std::fs::metadata(place) {
            Ok(m) if m.is_dir() => {
                // A probe file rather than the permission bits: those do not tell root, ACLs or a
                // read-only mount apart.
                let probe = place.join(format!(".blockdem-write-test-{}", std::process::id()));
                return match std::fs::File::create(&probe) {
                    Ok(_) => {
                        let _ = std::fs::remove_file(&probe);
                        Ok(())
                    }
                    Err(e) => bail!("{what} cannot write in {}: {e}", place.display()),
                };
            }
            Ok(_) => bail!("{what} {} is a file, not a folder", place.display()),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory) => continue,
            Err(e) => bail!("{what} {}: {e}", place.display()),
        }
    }
    Ok(())
}

/// A whole number above zero (a count of blocks or cycles).
fn count<T: std::str::FromStr + Default + PartialOrd>(text: &str) -> Result<T, String> {
    match text.parse::<T>() {
        Ok(n) if n > T::default() => Ok(n),
        _ => Err(format!("expected a whole number above zero, found '{text}'")),
    }
}

/// A finite number above zero (a time, a FRACTION).
fn positive(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("expected a number above zero, found '{text}'")),
    }
}

/// A duration in seconds: a finite number, zero or more.
fn seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && s >= 0.0 => Ok(s),
        _ => Err(format!("expected a number of seconds (0 or more), found '{text}'")),
    }
}

fn run(args: RunArgs) -> anyhow::Result<()> {
    let RunArgs { deck, backend, adapter, precision, out, state_json, checkpoint_every, vtk_every, dim } = args;
    if backend == BackendChoice::Cpu {
        let given: Vec<&str> = [adapter.as_ref().map(|_| "--adapter"), precision.map(|_| "--precision")].into_iter().flatten().collect();
        if !given.is_empty() {
            note!("blockdem: --backend cpu runs in f64 on the CPU; {} ignored", given.join(" and "));
        }
    }
    let adapter = adapter.unwrap_or_else(|| "any".into());
    let precision = precision.unwrap_or(PrecisionChoice::F32);
    let name = deck.display().to_string();
    let bytes = blockdem::udec::deck::parse::read_deck(&deck, &name)?;
    // The engine (README, "2D or 3D"): `--dim`, or the deck's own commands.
    if let Ok(text) = blockdem::udec::deck::parse::lenient_text(&bytes) {
        let three_d = blockdem::d3::deck::three_dimensional(&blockdem::deck::lexer::split(&text, &name)?);
        // A deck that starts by RESTART of a D3 save file is a D3 deck too.
        let d3_restart = three_d.is_none() && dim.is_none() && restarts_d3(&text, &name, &out);
        match (dim, three_d) {
            (Some(3), _) | (None, Some(_)) => {
                return run_d3(&text, &name, (backend, &adapter, precision), state_json, run_options(&out, checkpoint_every, vtk_every))
            }
            (None, None) if d3_restart => {
                return run_d3(&text, &name, (backend, &adapter, precision), state_json, run_options(&out, checkpoint_every, vtk_every))
            }
            (Some(2), Some(why)) => bail!("{name}:{}: {} makes this a 3D (D3) deck, but --dim 2 was given", why.line, why.what),
            _ => {}
        }
    }
    let commands = blockdem::udec::deck::parse::parse_deck_bytes(&bytes, &name)?;
    warn_after_end(&bytes, &commands, &name);
    check_out_dir(&out)?;
    if let Some(path) = &state_json {
        check_out_file(path, "--state-json")?;
    }
    // The precision the cycle runs in, for the extreme-ratio warnings (`verify::stability`).
    let mut runs_on = (false, "f64");
    let mut adapter_name = None;
    let backend: Box<dyn blockdem::udec::backend::Backend> = match backend {
        BackendChoice::Cpu => Box::new(CpuBackend::new()),
        BackendChoice::Auto | BackendChoice::Gpu => {
            let precision = Precision::from(precision);
            let choice: AdapterChoice = adapter.parse().unwrap_or(AdapterChoice::Any);
            // `auto` wants a real GPU: a software adapter (Mesa's lavapipe or llvmpipe) is slower
            // than the CPU backend and less precise, so it is used only when asked for.
            let hardware = matching_adapters(&choice).into_iter().any(|a| a.compute && !a.is_software());
            if backend == BackendChoice::Auto && !hardware {
                note!("blockdem: no GPU adapter found (software adapters are used only with --backend gpu); running on the CPU (f64)");
                Box::new(CpuBackend::new())
            } else {
                match GpuBackend::new(&GpuOptions { adapter: choice, precision }) {
                    Ok(gpu) => {
                        note!("blockdem: running on {}", gpu.describe());
                        runs_on = (true, if precision == Precision::F32 { "f32" } else { "f64" });
                        let a = gpu.adapter();
                        adapter_name = Some(format!("{} ({}, {})", a.name, a.backend, a.driver_name()));
                        if backend == BackendChoice::Auto {
                            // A model past the adapter's limits runs on the CPU instead.
                            Box::new(GpuOrCpu::new(Box::new(gpu), || Box::new(CpuBackend::new())))
                        } else {
                            Box::new(gpu)
                        }
                    }
                    Err(e) if backend == BackendChoice::Auto => {
                        note!("blockdem: {e}; running on the CPU (f64)");
                        Box::new(CpuBackend::new())
                    }
                    Err(e) => bail!("--backend gpu: {e}"),
                }
            }
        }
    };
    let options = run_options(&out, checkpoint_every, vtk_every);
    // Buffered: the executor flushes the log after every command but BLOCK, so a generated deck's
    // 10⁶ BLOCK echoes cost buffered writes rather than one write each (0.2–0.6 s here).
    let mut exec = Executor::new(backend, Box::new(std::io::BufWriter::new(Stdout)), options, &name);
    exec.set_limits(blockdem::udec::model::limits::limits_for(runs_on.0, runs_on.1));
    let provenance = Provenance::now(&name, if runs_on.0 { "gpu" } else { "cpu" }, adapter_name, runs_on.1);
    exec.set_provenance(provenance.line());
    let result = exec.run(&commands);
    // Written first, reported last: a state JSON that cannot be written must not keep the
    // restart file below from being written.
    let json_written = match &state_json {
        Some(path) => {
            // Its folder is made as --out's is, when first written to.
            if let Some(folder) = path.parent().filter(|f| !f.as_os_str().is_empty()) {
                let _ = std::fs::create_dir_all(folder);
            }
            blockdem::udec::output::state_json::write_state_json_with(&exec.model, Some(&provenance), path)
                .with_context(|| format!("cannot write {}", path.display()))
        }
        None => Ok(()),
    };
    if let Err(e) = result {
        // Never lose work: the last good state (or the state an interrupt stopped at, or, after
        // an input error later in a deck that has cycled, the state before the failing
        // command, which a command that fails leaves as it was) goes to a restart file beside
        // the plots.
        if e.is_numerical() || e.is_interrupted() || exec.model.cycle > 0 {
            let _ = std::fs::create_dir_all(&out);
            let path = out.join("last_good.sav");
            let which = if e.is_interrupted() {
                "the state"
            } else if e.is_numerical() {
                "the last good state"
            } else {
                "the state before the failing command"
            };
            if blockdem::udec::output::restart::save_state(&path, &exec.model, &Default::default(), 0).is_ok() {
                note!("blockdem: {which} (cycle {}) is saved in {}", exec.model.cycle, path.display());
            }
        }
        if let Err(json) = json_written {
            note!("blockdem: {json:#}");
        }
        return Err(e.into());
    }
    json_written
}

/// The run options of `blockdem run` for either engine: `--out`, Ctrl-C watched, progress (a
/// bar on a terminal; otherwise, a batch run or a log file, a line on stderr every 30 s or every
/// BLOCKDEM_PROGRESS_SECONDS), `--checkpoint-every`, `--vtk-every`.
fn run_options(out: &std::path::Path, checkpoint_every: Option<f64>, vtk_every: Option<u64>) -> RunOptions {
    let interrupt = Arc::new(AtomicBool::new(false));
    watch_interrupts(interrupt.clone());
    let progress = if std::io::stdout().is_terminal() {
        Progress::Bar
    } else {
        let seconds = std::env::var("BLOCKDEM_PROGRESS_SECONDS").ok().and_then(|v| v.parse::<f64>().ok()).filter(|s| s.is_finite() && *s >= 0.0);
        Progress::Lines { every: std::time::Duration::from_secs_f64(seconds.unwrap_or(30.0)) }
    };
    let checkpoint_every = checkpoint_every.map(std::time::Duration::from_secs_f64);
    RunOptions { out_dir: out.to_path_buf(), progress, interrupt: Some(interrupt), checkpoint_every, vtk_every }
}

/// Whether the deck's first command is a RESTART of a D3 save file (`d3::restart::MAGIC`), the
/// file named as D3's executor resolves it (in `out` when it names no folder).
fn restarts_d3(text: &str, name: &str, out: &std::path::Path) -> bool {
    let Ok(commands) = blockdem::d3::deck::parse_deck(text, name) else {
        return false;
    };
    let Some(blockdem::d3::deck::Command::Restart { file }) = commands.first().map(|c| &c.command) else {
        return false;
    };
    let path = blockdem::output::resolve_in(out, file.as_deref(), blockdem::d3::exec::DEFAULT_SAVE_FILE);
    blockdem::d3::restart::is_save_file(&path)
}

/// `blockdem run` of a 3D deck: D3 on the backend asked for (as a 2D deck's), with the chassis's
/// run options (as 2D's). After a numerical failure or an interrupt the last good state (or the
/// state the interrupt stopped at) goes to OUT/last_good.sav, a D3 save file RESTART reads.
fn run_d3(
    text: &str,
    name: &str,
    (backend, adapter, precision): (BackendChoice, &str, PrecisionChoice),
    state_json: Option<PathBuf>,
    options: RunOptions,
) -> anyhow::Result<()> {
    let commands = blockdem::d3::deck::parse_deck(text, name)?;
    // The backend as for a 2D deck: `auto` takes a hardware GPU where there is one.
    let choice: AdapterChoice = adapter.parse().unwrap_or(AdapterChoice::Any);
    let precision = Precision::from(precision);
    let mut runs_on = ("cpu", None, "f64");
    let engine: Box<dyn blockdem::d3::backend::Backend> = match backend {
        BackendChoice::Cpu => Box::new(blockdem::d3::cpu::CpuBackend::new()),
        BackendChoice::Auto if !matching_adapters(&choice).into_iter().any(|a| a.compute && !a.is_software()) => {
            note!("blockdem: a 3D deck: the D3 engine, on the CPU (f64) (no hardware GPU adapter; software adapters are used only with --backend gpu)");
            Box::new(blockdem::d3::cpu::CpuBackend::new())
        }
        BackendChoice::Auto | BackendChoice::Gpu => match blockdem::d3::gpu::GpuBackend::new(&choice, precision) {
            Ok(gpu) => {
                note!("blockdem: a 3D deck: the D3 engine, on {}", blockdem::d3::backend::Backend::describe(&gpu));
                let a = gpu.adapter();
                runs_on = ("gpu", Some(format!("{} ({}, {})", a.name, a.backend, a.driver_name())), if precision == Precision::F32 { "f32" } else { "f64" });
                if backend == BackendChoice::Auto {
                    // A concave block, or a model past the adapter's limits, runs on the CPU instead.
                    Box::new(blockdem::d3::backend::GpuOrCpu::new(Box::new(gpu), || Box::new(blockdem::d3::cpu::CpuBackend::new())))
                } else {
                    Box::new(gpu)
                }
            }
            Err(e) if backend == BackendChoice::Auto => {
                note!("blockdem: {e}; running on the CPU (f64)");
                Box::new(blockdem::d3::cpu::CpuBackend::new())
            }
            Err(e) => bail!("--backend gpu: {e}"),
        },
    };
    check_out_dir(&options.out_dir)?;
    if let Some(path) = &state_json {
        check_out_file(path, "--state-json")?;
    }
    let out = options.out_dir.clone();
    let mut exec = blockdem::d3::exec::Executor::with_backend(Box::new(std::io::BufWriter::new(Stdout)), name, engine);
    exec.set_options(options);
    let result = exec.run(&commands);
    let provenance = Provenance::now(name, runs_on.0, runs_on.1, runs_on.2);
    let json_written = match &state_json {
        Some(path) => {
            if let Some(folder) = path.parent().filter(|f| !f.as_os_str().is_empty()) {
                let _ = std::fs::create_dir_all(folder);
            }
            let json = blockdem::d3::output::state_json(&exec.model, Some(&provenance));
            std::fs::write(path, serde_json::to_string_pretty(&json)?).with_context(|| format!("cannot write {}", path.display()))
        }
        None => Ok(()),
    };
    if let Err(e) = &result {
        // Never lose work (as in 2D): the last good state, or the state an interrupt stopped at.
        let numerical = matches!(e, blockdem::d3::exec::RunError::Cycle { .. });
        if numerical || e.is_interrupted() {
            let _ = std::fs::create_dir_all(&out);
            let path = out.join("last_good.sav");
            let which = if numerical { "the last good state" } else { "the state" };
            if exec.save_state(&path).is_ok() {
                note!("blockdem: {which} (cycle {}) is saved in {}", exec.model.cycle, path.display());
            }
        }
    }
    drop(exec);
    if let (Err(_), Err(json)) = (&result, &json_written) {
        note!("blockdem: {json:#}");
    }
    result?;
    json_written
}

/// Ctrl-C (SIGINT) or SIGTERM (a batch system's time limit, `kill`) sets `flag`, which stops the
/// run at its next energy check with the state saved; a second one quits at once. SIGHUP keeps
/// its own handling, so that `nohup` still keeps a run going after a logout.
#[cfg(unix)]
fn watch_interrupts(flag: Arc<AtomicBool>) {
    match signal_hook::iterator::Signals::new([signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM]) {
        Ok(mut signals) => {
            std::thread::spawn(move || {
                for _ in signals.forever() {
                    if flag.swap(true, Ordering::Relaxed) {
                        std::process::exit(INTERRUPTED_EXIT);
                    }
                    note!("\nblockdem: interrupted; stopping at the next energy check (within 100 cycles) to save the state (Ctrl-C again to quit now)");
                }
            });
        }
        Err(e) => note!("blockdem: Ctrl-C will end the run without saving its state ({e})"),
    }
}

/// Elsewhere Ctrl-C ends the run as the system does (the flag is never set).
#[cfg(not(unix))]
fn watch_interrupts(_flag: Arc<AtomicBool>) {}

/// The exit status of a run ended by Ctrl-C or SIGTERM (128 + SIGINT, as a shell reports
/// Ctrl-C).
const INTERRUPTED_EXIT: i32 = 130;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Cmd::Run(args) => run(args),
        Cmd::Adapters => adapters(),
        Cmd::Compare { deck, adapter, precision, out, tolerance } => compare(deck, adapter, precision, out, tolerance),
        Cmd::Verify { quick, out, only } => verify(quick, out, only),
        Cmd::Bench { quick, out, scene, backend, adapter, precision, max_blocks, sizes, settle_time, impact_time, frac, measure, rounds, max_zones } => {
            bench(quick, out, scene, backend, adapter, precision, max_blocks, sizes, settle_time, impact_time, frac, measure, rounds, max_zones)
        }
    };
    let _ = Stdout.flush();
    // A failure to write the output fails a command that did its work otherwise.
    let result = match (result, Stdout::error()) {
        (Ok(()), Some(e)) => Err(anyhow::anyhow!("cannot write to standard output: {e}")),
        (Err(e), Some(out)) => {
            note!("blockdem: cannot write to standard output: {out}");
            Err(e)
        }
        (result, None) => result,
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            note!("error: {e:#}");
            let interrupted = e.downcast_ref::<RunError>().is_some_and(RunError::is_interrupted)
                || e.downcast_ref::<blockdem::d3::exec::RunError>().is_some_and(blockdem::d3::exec::RunError::is_interrupted);
            if interrupted {
                ExitCode::from(INTERRUPTED_EXIT as u8)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
