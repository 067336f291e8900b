//! `blockdem verify`: the engines against closed-form solutions (DESIGN.md §6, issue 4; D3's 3D cases, issue 31).
//!
//! Every case is a deck (so it exercises the command language too) run on every backend in
//! [`backends`], at every FRACTION of a sweep. A row records the error against the closed form, the
//! cost (wall time, cycles, cycles per second) and the energy balance; a run that stops with a
//! numerical error is a row too (a failure, plotted as such, never dropped). The rows at the
//! default FRACTION ([`CHECK_FRAC`]) are the checks: `blockdem verify` exits non-zero when one fails.
//!
//! | file | what |
//! |---|---|
//! | [`cases`] | the closed-form problems: decks, measurements, tolerances and why |
//! | [`stability`] | measured thresholds of instability against `stable_frac_estimate`, extreme ratios |
//! | [`chart`] | CSV and PNG charts (accuracy against speed) |
//! | [`d3`] | the 3D closed forms on D3's backends (torque-free rotation, oblique incline, stack, toppling, wedge), each GPU row also against the CPU's |

pub mod cases;
pub mod chart;
pub mod d3;
pub mod stability;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::udec::backend::Backend;
use crate::udec::cpu::CpuBackend;
use crate::udec::model::timestep::Energies;
use crate::udec::model::Model;

/// The FRACTION the checks run at: the model's default (UDEC's 0.1).
pub const CHECK_FRAC: f64 = 0.1;

/// FRACTIONs of the accuracy-against-speed sweep.
pub const QUICK_FRACS: &[f64] = &[0.05, 0.1, 0.2, 0.4, 0.7, 1.0];
pub const FULL_FRACS: &[f64] = &[0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];
/// FRACTIONs of the quick suite on the GPU rows: the check FRACTION only. Mesa's software
/// adapters, which CI has, take ~1 ms a cycle (five dispatches), against ~1 µs on the CPU for
/// these few-block scenes, so the quick sweep would cost minutes per adapter; the full suite
/// sweeps every FRACTION on every backend.
pub const QUICK_FRACS_GPU: &[f64] = &[CHECK_FRAC];
/// FRACTIONs of the quick suite for D3's cases: the check FRACTION only, so that the 3D rows add
/// about 6 s on the CPU and ~35 s per software adapter to the CI suite (their sweep, ~70 s on the
/// CPU, is the full suite's).
pub const QUICK_FRACS_D3: &[f64] = &[CHECK_FRAC];

/// A fresh D3 backend, or why none opens (the case's row then says it).
pub type MakeD3 = Box<dyn Fn() -> Result<Box<dyn crate::d3::backend::Backend>, String> + Send + Sync>;

/// One backend the suite runs on: a label, its precision, and a factory (a fresh backend per run)
/// for each engine: the 2D engine's, and D3's for the 3D cases (`verify::d3`).
pub struct BackendEntry {
    pub label: String,
    pub precision: String,
    /// A GPU adapter (the quick suite runs fewer FRACTIONs there, [`QUICK_FRACS_GPU`]).
    pub gpu: bool,
    pub make: Box<dyn Fn() -> Box<dyn Backend> + Send + Sync>,
    pub make_d3: MakeD3,
}

impl BackendEntry {
    /// An entry whose 3D cases run on D3's CPU backend ([`BackendEntry::with_d3`] gives another).
    pub fn new(label: &str, precision: &str, make: impl Fn() -> Box<dyn Backend> + Send + Sync + 'static) -> Self {
        BackendEntry {
            label: label.to_string(),
            precision: precision.to_string(),
            gpu: false,
            make: Box::new(make),
            make_d3: Box::new(|| Ok(Box::new(crate::d3::cpu::CpuBackend::new()))),
        }
    }

    /// The entry with D3's backend made by `make_d3`.
    pub fn with_d3(mut self, make_d3: impl Fn() -> Result<Box<dyn crate::d3::backend::Backend>, String> + Send + Sync + 'static) -> Self {
        self.make_d3 = Box::new(make_d3);
        self
    }

    /// "cpu f64", "vulkan (lavapipe) f32": how tables and charts name the backend.
    pub fn name(&self) -> String {
        format!("{} {}", self.label, self.precision)
    }

    /// Single-precision kernels: the cases' f32 tolerances apply.
    pub fn is_f32(&self) -> bool {
        self.precision == "f32"
    }
}

/// The backends of this build: the CPU (f64), then one entry per GPU adapter and precision
/// present (`gpu::scenario_backends`, the list the scenario tests run on too): with Mesa's
/// software adapters, "vulkan (lavapipe)" f32 and f64 and "gl (llvmpipe)" f32. Each entry runs
/// the 2D cases on the 2D engine's backend and the 3D ones on D3's, on the same adapter and in the
/// same precision.
pub fn backends() -> Vec<BackendEntry> {
    let mut v = vec![BackendEntry::new("cpu", "f64", || Box::new(CpuBackend::new()))];
    for target in crate::udec::gpu::scenario_backends() {
        let (label, precision) = (target.label(), target.precision().to_string());
        let d3_options = target.options.clone();
        let mut entry = BackendEntry::new(&label, &precision, move || -> Box<dyn Backend> {
            match target.backend() {
                Ok(b) => Box::new(b),
                Err(e) => Box::new(Unavailable(e.to_string())),
            }
        })
        .with_d3(move || match crate::d3::gpu::GpuBackend::new(&d3_options.adapter, d3_options.precision) {
            Ok(b) => Ok(Box::new(b)),
            Err(e) => Err(e.to_string()),
        });
        entry.gpu = true;
        v.push(entry);
    }
    v
}

/// A backend that could not be opened: every run fails with why, so the rows say it (a failed
/// row, never a panic or a silent skip).
struct Unavailable(String);

impl Backend for Unavailable {
    fn describe(&self) -> String {
        format!("unavailable ({})", self.0)
    }

    fn run_into(
        &mut self,
        _: &mut Model,
        _: u64,
        _: &mut dyn FnMut(u64) -> bool,
        _: &mut crate::udec::backend::CycleReport,
    ) -> Result<(), crate::udec::backend::CycleError> {
        Err(crate::udec::backend::CycleError::Setup(self.0.clone()))
    }
}

/// What a suite run covers.
#[derive(Clone, Debug)]
pub struct VerifyOptions {
    /// The CI suite: fewer FRACTIONs, shorter stability bisections.
    pub quick: bool,
    /// Where the CSV files and charts go (None: write nothing).
    pub out: Option<PathBuf>,
    /// Run only the cases whose name contains this.
    pub only: Option<String>,
    /// Run the backends side by side, a thread each (the tests: a 2-core CI machine otherwise
    /// idles a core while one backend's cases run one after the other). The rows come in the
    /// same order and with the same errors; their costs (wall time, cycles/s) are then not
    /// comparable, so `blockdem verify`, whose charts plot them, runs the backends in turn.
    pub side_by_side: bool,
}

impl Default for VerifyOptions {
    fn default() -> Self {
        VerifyOptions { quick: true, out: None, only: None, side_by_side: false }
    }
}

/// The cost of one run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    pub wall_s: f64,
    pub cycles: u64,
}

impl Cost {
    pub fn cycles_per_s(&self) -> f64 {
        if self.wall_s > 0.0 {
            self.cycles as f64 / self.wall_s
        } else {
            f64::NAN
        }
    }
    fn add(&mut self, o: Cost) {
        self.wall_s += o.wall_s;
        self.cycles += o.cycles;
    }
}

/// What a case measured.
#[derive(Clone, Debug, Default)]
pub struct Measured {
    /// Error against the closed form, in the case's own measure (relative unless it says).
    pub error: f64,
    /// The numbers behind it, for the table.
    pub detail: String,
    pub cost: Cost,
    /// |ledger(end) − ledger(start)| / scale, when the case checks the energy balance.
    pub energy_balance: Option<f64>,
}

/// One row of the suite: a case on a backend at a FRACTION.
#[derive(Clone, Debug)]
pub struct Row {
    pub case: &'static str,
    pub backend: String,
    pub precision: String,
    pub frac: f64,
    pub tolerance: f64,
    /// None when the run stopped with a numerical error (`failure` says which).
    pub error: Option<f64>,
    pub failure: Option<String>,
    pub detail: String,
    pub cost: Cost,
    pub energy_balance: Option<f64>,
    /// Energy balance tolerance (1%) applies to the rows that report one.
    pub passed: bool,
    /// True for the rows at CHECK_FRAC: the assertions of the suite.
    pub is_check: bool,
}

/// Energy-balance tolerance: 1% of the largest term of the ledger (issue 4, item 3). Central
/// differences keep a shadow energy within O(ωΔt) of the true one; 1% leaves room for the
/// half-step lag of the kinetic energy at FRAC 0.1.
pub const ENERGY_TOLERANCE: f64 = 0.01;

/// The whole suite's result.
#[derive(Clone, Debug, Default)]
pub struct Suite {
    pub rows: Vec<Row>,
    pub stability: Vec<stability::Threshold>,
    pub extremes: Vec<stability::ExtremeLimit>,
    pub wall_s: f64,
    /// Run as `--quick` (fewer FRACTIONs; the GPU rows at the check FRACTION only).
    pub quick: bool,
}

impl Suite {
    pub fn checks(&self) -> impl Iterator<Item = &Row> {
        self.rows.iter().filter(|r| r.is_check)
    }
    pub fn failed_checks(&self) -> Vec<&Row> {
        self.checks().filter(|r| !r.passed).collect()
    }
    pub fn all_checks_pass(&self) -> bool {
        self.failed_checks().is_empty() && self.stability.iter().all(|t| t.passed)
    }
}

/// The FRACTIONs a backend sweeps.
pub fn fracs_for(backend: &BackendEntry, quick: bool) -> &'static [f64] {
    match (quick, backend.gpu) {
        (true, false) => QUICK_FRACS,
        (true, true) => QUICK_FRACS_GPU,
        (false, _) => FULL_FRACS,
    }
}

/// Runs the suite: every case × backend × FRACTION, then the stability measurements (in the quick
/// suite on the CPU only, in the full suite on every backend).
pub fn run_suite(options: &VerifyOptions) -> Suite {
    let start = Instant::now();
    let mut suite = Suite { quick: options.quick, ..Suite::default() };
    let backends = backends();
    let parts: Vec<BackendPart> = if options.side_by_side {
        std::thread::scope(|scope| {
            let handles: Vec<_> = backends.iter().map(|b| scope.spawn(move || run_backend(options, b))).collect();
            handles.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
        })
    } else {
        backends.iter().map(|b| run_backend(options, b)).collect()
    };
    for (rows, stability, extremes) in parts {
        suite.rows.extend(rows);
        suite.stability.extend(stability);
        suite.extremes.extend(extremes);
    }
    d3::against_cpu(&mut suite.rows);
    suite.wall_s = start.elapsed().as_secs_f64();
    suite
}

/// One backend's share of a suite: its rows, stability thresholds and extreme-ratio limits.
type BackendPart = (Vec<Row>, Vec<stability::Threshold>, Vec<stability::ExtremeLimit>);

/// The suite's cases (and, on the CPU and in the full suite, the stability bisections) on one
/// backend.
fn run_backend(options: &VerifyOptions, backend: &BackendEntry) -> BackendPart {
    let mut part: BackendPart = Default::default();
    for case in cases::all() {
        if options.only.as_deref().is_some_and(|o| !case.name.contains(o)) {
            continue;
        }
        let fracs = if options.quick && case.name.starts_with(d3::D3_PREFIX) { QUICK_FRACS_D3 } else { fracs_for(backend, options.quick) };
        for &frac in fracs {
            part.0.push(run_case(&case, backend, frac));
        }
    }
    if options.only.is_none() && !(options.quick && backend.gpu) {
        part.1 = stability::thresholds(backend, options.quick);
        part.2 = stability::extreme_limits(backend, options.quick);
    }
    part
}

/// Runs one case at one FRACTION on one backend.
pub fn run_case(case: &cases::Case, backend: &BackendEntry, frac: f64) -> Row {
    let ctx = Ctx { frac, backend };
    let result = (case.run)(&ctx);
    let is_check = (frac - CHECK_FRAC).abs() < 1e-12;
    let mut row = Row {
        case: case.name,
        backend: backend.label.clone(),
        precision: backend.precision.clone(),
        frac,
        tolerance: case.tolerance,
        error: None,
        failure: None,
        detail: String::new(),
        cost: Cost::default(),
        energy_balance: None,
        passed: false,
        is_check,
    };
    match result {
        Ok(m) => {
            row.passed = m.error <= case.tolerance && m.energy_balance.is_none_or(|e| e <= ENERGY_TOLERANCE);
            row.error = Some(m.error);
            row.detail = m.detail;
            row.cost = m.cost;
            row.energy_balance = m.energy_balance;
        }
        Err(f) => {
            row.failure = Some(f.message);
            row.cost = f.cost;
        }
    }
    row
}

/// A run that stopped: the message and what it cost up to then.
#[derive(Clone, Debug)]
pub struct Failure {
    pub message: String,
    pub cost: Cost,
}

/// What a case runs with.
pub struct Ctx<'a> {
    pub frac: f64,
    pub backend: &'a BackendEntry,
}

impl Ctx<'_> {
    /// Runs deck text to its end on a fresh backend, timing it.
    pub fn run(&self, deck: &str) -> Result<(Model, Cost), Failure> {
        let t = Instant::now();
        let commands = crate::udec::deck::parse_deck(deck, "<verify>").map_err(|e| Failure { message: e.to_string(), cost: Cost::default() })?;
        let options = crate::udec::exec::RunOptions { out_dir: std::env::temp_dir().join("blockdem-verify"), ..Default::default() };
        let mut exec = crate::udec::exec::Executor::new((self.backend.make)(), Box::new(std::io::sink()), options, "<verify>");
        exec.set_limits(stability::limits_for(self.backend.gpu, &self.backend.precision));
        let r = exec.run(&commands);
        let cost = Cost { wall_s: t.elapsed().as_secs_f64(), cycles: exec.model.cycle };
        match r {
            Ok(()) => Ok((exec.model, cost)),
            Err(e) => Err(Failure { message: e.to_string(), cost }),
        }
    }

    /// Runs `setup` (a deck ending before its CYCLE), then `cycles` single cycles, calling
    /// `observe` after each: the time history a closed form needs. The probe's per-call overhead
    /// makes this slow, so the cost reported is that of the same run done in one CYCLE.
    pub fn run_observed(&self, setup: &str, cycles: u64, mut observe: impl FnMut(&Model)) -> Result<(Model, Cost), Failure> {
        let (_, cost) = self.run(&format!("{setup}CYCLE {cycles}\n"))?;
        let (mut model, _) = self.run(&format!("{setup}CYCLE 0\n"))?;
        let mut backend = (self.backend.make)();
        for _ in 0..cycles {
            backend.run(&mut model, 1, &mut |_| true).map_err(|e| Failure { message: e.to_string(), cost })?;
            observe(&model);
        }
        Ok((model, cost))
    }

    /// `FRACTION f` for this run.
    pub fn frac_line(&self) -> String {
        format!("FRAC {}\n", self.frac)
    }

    /// Number of cycles to cover `time` with the UDEC time step of `model` at this FRACTION.
    pub fn cycles_for(&self, setup: &str, time: f64) -> Result<u64, Failure> {
        let (m, _) = self.run(&format!("{setup}CYCLE 0\n"))?;
        Ok((time / m.timestep).ceil() as u64)
    }
}

/// Energy balance of a run: |ledger(end) − ledger(start)| over the largest term.
pub fn energy_balance(start: &Energies, end: &Energies) -> f64 {
    let scale = start.scale().max(end.scale());
    if scale > 0.0 {
        (end.ledger() - start.ledger()).abs() / scale
    } else {
        0.0
    }
}

fn fmt_err(e: Option<f64>) -> String {
    e.map_or_else(|| "FAILED".to_string(), |e| format!("{e:.3e}"))
}

impl Row {
    /// "cpu f64", "vulkan (lavapipe) f32".
    pub fn backend_name(&self) -> String {
        format!("{} {}", self.backend, self.precision)
    }
}

/// The table `blockdem verify` prints.
pub fn table(suite: &Suite) -> String {
    let mut s = String::new();
    // The backend column fits the longest name ("vulkan (lavapipe) f32").
    let w =
        suite.rows.iter().map(|r| r.backend_name().chars().count()).chain(suite.stability.iter().map(|t| t.backend.chars().count())).max().unwrap_or(7).max(7);
    let _ = writeln!(s, "CLOSED-FORM CHECKS (FRAC {CHECK_FRAC})");
    let _ = writeln!(
        s,
        "{:<16} {:<w$} {:>10} {:>10} {:>10} {:>9} {:>9} {:>11}  {:<6} detail",
        "case", "backend", "error", "tolerance", "energy", "wall s", "cycles", "cycles/s", "result"
    );
    for r in suite.checks() {
        let _ = writeln!(
            s,
            "{:<16} {:<w$} {:>10} {:>10.1e} {:>10} {:>9.4} {:>9} {:>11.3e}  {:<6} {}",
            r.case,
            r.backend_name(),
            fmt_err(r.error),
            r.tolerance,
            r.energy_balance.map_or("-".to_string(), |e| format!("{e:.2e}")),
            r.cost.wall_s,
            r.cost.cycles,
            r.cost.cycles_per_s(),
            if r.passed { "ok" } else { "FAIL" },
            r.failure.as_deref().unwrap_or(&r.detail)
        );
    }
    let _ = writeln!(
        s,
        "\nACCURACY AGAINST SPEED (error / tolerance; FAILED = the run stopped with a numerical error{})",
        if suite.quick && suite.rows.iter().any(|r| r.backend != "cpu") { "; --quick runs the GPU rows at the check FRACTION only" } else { "" }
    );
    let mut fracs: Vec<f64> = suite.rows.iter().map(|r| r.frac).collect();
    fracs.sort_by(f64::total_cmp);
    fracs.dedup();
    let _ = write!(s, "{:<16} {:<w$}", "case", "backend");
    for f in &fracs {
        let _ = write!(s, " {:>9}", format!("F={f}"));
    }
    let _ = writeln!(s);
    let mut keys: Vec<(&str, String)> = suite.rows.iter().map(|r| (r.case, r.backend_name())).collect();
    keys.dedup();
    for (case, be) in keys {
        let _ = write!(s, "{case:<16} {be:<w$}");
        for f in &fracs {
            let cell = suite
                .rows
                .iter()
                .find(|r| r.case == case && r.backend_name() == be && r.frac == *f)
                .map_or(String::new(), |r| r.error.map_or("FAILED".into(), |e| format!("{:.2e}", e / r.tolerance.max(1e-300))));
            let _ = write!(s, " {cell:>9}");
        }
        let _ = writeln!(s);
    }
    if !suite.stability.is_empty() {
        let _ = writeln!(s, "\nSTABLE FRACTION: estimate (stable_frac_estimate) against the measured threshold of instability");
        let _ = writeln!(s, "{:<22} {:<w$} {:>9} {:>9} {:>7}  {:<6} first failure above", "scene", "backend", "estimate", "measured", "ratio", "result");
        for t in &suite.stability {
            let _ = writeln!(
                s,
                "{:<22} {:<w$} {:>9.3} {:>9.3} {:>7.2}  {:<6} {}",
                t.scene,
                t.backend,
                t.estimate,
                t.measured,
                t.estimate / t.measured,
                if t.passed { "ok" } else { "FAIL" },
                t.failure
            );
        }
    }
    if !suite.extremes.is_empty() {
        let _ = writeln!(s, "\nEXTREME RATIOS: largest value at which the check still passes (within the values tried)");
        for x in &suite.extremes {
            let _ = writeln!(s, "{:<26} {:<w$} limit {:>9.1e}   tried: {}", x.what, x.backend, x.limit, x.tried);
        }
    }
    let _ = writeln!(s, "\nsuite wall time {:.1} s", suite.wall_s);
    s
}

/// Writes `checks.csv`, `sweep.csv`, `stability.csv` and the charts into `dir`; returns the files
/// written and, separately, why a chart could not be drawn (the CSV files are always written).
pub fn write_outputs(suite: &Suite, dir: &Path) -> std::io::Result<(Vec<PathBuf>, Option<String>)> {
    std::fs::create_dir_all(dir)?;
    let mut files = Vec::new();
    let mut sweep = String::from(
        "case,backend,precision,frac,error,tolerance,error_over_tolerance,failed,failure,energy_balance,wall_s,cycles,cycles_per_s,passed,is_check\n",
    );
    for r in &suite.rows {
        let _ = writeln!(
            sweep,
            "{},{},{},{},{},{},{},{},\"{}\",{},{},{},{},{},{}",
            r.case,
            r.backend,
            r.precision,
            r.frac,
            r.error.map_or(String::new(), |e| format!("{e:e}")),
            r.tolerance,
            r.error.map_or(String::new(), |e| format!("{:e}", e / r.tolerance.max(1e-300))),
            r.error.is_none(),
            r.failure.as_deref().unwrap_or("").replace('"', "'"),
            r.energy_balance.map_or(String::new(), |e| format!("{e:e}")),
            r.cost.wall_s,
            r.cost.cycles,
            r.cost.cycles_per_s(),
            r.passed,
            r.is_check
        );
    }
    let p = dir.join("sweep.csv");
    std::fs::write(&p, sweep)?;
    files.push(p);
    let mut st = String::from("scene,backend,estimate,measured,ratio,passed\n");
    for t in &suite.stability {
        let _ = writeln!(st, "{},{},{},{},{},{}", t.scene, t.backend, t.estimate, t.measured, t.estimate / t.measured, t.passed);
    }
    let p = dir.join("stability.csv");
    std::fs::write(&p, st)?;
    files.push(p);
    let mut ex = String::from("what,backend,limit,tried\n");
    for x in &suite.extremes {
        let _ = writeln!(ex, "{},{},{},\"{}\"", x.what, x.backend, x.limit, x.tried);
    }
    let p = dir.join("extremes.csv");
    std::fs::write(&p, ex)?;
    files.push(p);
    let mut chart_problem = None;
    match chart::accuracy_vs_speed(suite, &dir.join("accuracy_vs_speed.png")) {
        Ok(p) => files.push(p),
        Err(e) => chart_problem = Some(e),
    }
    match chart::error_vs_frac(suite, &dir.join("error_vs_frac.png")) {
        Ok(p) => files.push(p),
        Err(e) => chart_problem = chart_problem.or(Some(e)),
    }
    Ok((files, chart_problem))
}
