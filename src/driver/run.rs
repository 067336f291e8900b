//! A CYCLE command's run around the driver, for both engines' executors: the run options that do
//! not come from the deck ([`RunOptions`]: progress, Ctrl-C, running restart files, VTK frames),
//! the progress a long CYCLE shows ([`Ticker`]), and the run in pieces those options ask for
//! ([`run_in_pieces`]; each piece one [`super::cycles`] run, resumed bit for bit by the next).

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::{CycleError, CycleReport, CHECK_INTERVAL};

/// Settings of a run that do not come from the deck.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Folder for PLOT files, SAVE files named without a folder, VTK frames and running restart files.
    pub out_dir: PathBuf,
    /// How long CYCLE commands show their progress.
    pub progress: Progress,
    /// Set (by a Ctrl-C handler) to stop the run: a CYCLE ends at its next energy check (every
    /// 100 cycles) with its state intact, and no further command runs.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// Write the state to `CHECKPOINT_FILE` in `out_dir` about this often during a CYCLE (a
    /// running restart file: a run killed outright, by the system or a power cut, loses at most
    /// this much). The CYCLE then runs in pieces of whole energy-check intervals, which are one
    /// run bit for bit (a CYCLE after a CYCLE goes on from the backend's state); only the energy
    /// check's budget starts again with each piece, as it does with each CYCLE command (an
    /// instability grows exponentially, within a piece of 100 cycles or more).
    pub checkpoint_every: Option<std::time::Duration>,
    /// Write a VTK frame (each engine's own) into `VTK_DIR` in `out_dir` at the start of each CYCLE
    /// and every this many cycles of it, rounded up to whole energy-check intervals (100 cycles)
    /// so that the pieces the CYCLE then runs in are one run bit for bit, as above.
    pub vtk_every: Option<u64>,
}

/// The folder, in the output folder, of the VTK frames (the VTK command, `--vtk-every`).
pub const VTK_DIR: &str = "vtk";

/// The running restart file of `RunOptions::checkpoint_every`, in the output folder.
pub const CHECKPOINT_FILE: &str = "checkpoint.sav";

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions { out_dir: PathBuf::from("."), progress: Progress::Off, interrupt: None, checkpoint_every: None, vtk_every: None }
    }
}

/// How a CYCLE of 1000 cycles or more shows its progress.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Progress {
    /// Not at all (tests, the library's scenes).
    #[default]
    Off,
    /// A progress bar (the run's log goes to a terminal).
    Bar,
    /// A line on stderr at most every `every` of wall time (the log goes to a file or a pipe:
    /// a batch run still says how far it is and how long it has left).
    Lines { every: std::time::Duration },
}

impl RunOptions {
    /// Whether the interrupt flag is set.
    pub fn interrupted(&self) -> bool {
        self.interrupt.as_ref().is_some_and(|flag| flag.load(Ordering::Relaxed))
    }
}

/// The progress line of `Progress::Lines`: done of n cycles after `elapsed` seconds.
fn progress_line(done: u64, n: u64, elapsed: f64) -> String {
    let rate = done as f64 / elapsed.max(1e-9);
    let left = (n - done.min(n)) as f64 / rate.max(1e-9);
    let (m, sec) = ((left / 60.0).floor(), left % 60.0);
    format!(
        "blockdem: cycle {done} of {n} ({:.1}%), {} cycles/s, about {}{sec:.0} s left",
        100.0 * done as f64 / n as f64,
        rate_text(rate),
        if m > 0.0 { format!("{m:.0} min ") } else { String::new() }
    )
}

/// A rate of cycles per second as a person reads it: whole numbers from 100 up (`6532`, not
/// indicatif's `6,531.7848/s`), three significant digits below, exponent form past 10⁷.
fn rate_text(rate: f64) -> String {
    if !rate.is_finite() || rate >= 1e7 {
        format!("{rate:.2e}")
    } else if rate >= 100.0 {
        format!("{rate:.0}")
    } else if rate >= 10.0 {
        format!("{rate:.1}")
    } else {
        format!("{rate:.2}")
    }
}

/// The progress bar of `Progress::Bar`.
fn progress_bar(n: u64) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(n);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} cycles {rate} cycles/s eta {eta}")
            .map(|style| {
                style.with_key("rate", |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = w.write_str(&rate_text(state.per_sec()));
                })
            })
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    pb
}

/// The progress of one CYCLE of `n` cycles, which the backend reports (`tick`) at each energy
/// check: a bar or lines on stderr for a long CYCLE, and whether the run was interrupted.
pub struct Ticker {
    /// The run's options (a copy: the backend runs while the ticker is called).
    options: RunOptions,
    bar: Option<indicatif::ProgressBar>,
    n: u64,
    long: bool,
    started: Instant,
    last_line: Instant,
    /// The run was interrupted at the last tick.
    pub stopped: bool,
}

impl Ticker {
    pub fn new(options: &RunOptions, n: u64) -> Self {
        let long = n >= 1000;
        let bar = (options.progress == Progress::Bar && long).then(|| progress_bar(n));
        let started = Instant::now();
        Ticker { options: options.clone(), bar, n, long, started, last_line: started, stopped: false }
    }

    /// `done` cycles of the CYCLE are done; false asks the backend to stop (interrupted).
    pub fn tick(&mut self, done: u64) -> bool {
        if let Some(pb) = &self.bar {
            pb.set_position(done);
        }
        if let (Progress::Lines { every }, true) = (self.options.progress, self.long && done < self.n) {
            if self.last_line.elapsed() >= every {
                self.last_line = Instant::now();
                let _ = writeln!(std::io::stderr(), "{}", progress_line(done, self.n, self.started.elapsed().as_secs_f64()));
            }
        }
        self.stopped = self.options.interrupted();
        !self.stopped
    }

    /// Clears the bar; returns whether the run was interrupted.
    pub fn finish(self) -> bool {
        if let Some(pb) = self.bar {
            pb.finish_and_clear();
        }
        self.stopped
    }
}

/// What [`run_in_pieces`] asks of an engine's executor.
pub trait Pieces {
    /// Runs `cycles` cycles (0: the contact detection alone) through the backend, what they do
    /// added to `report` (on a failure, up to the last good state), `tick` told the cycles done
    /// at each energy check (false stops the run there).
    fn run_piece(&mut self, cycles: u64, tick: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError>;
    /// A VTK frame of [`RunOptions::vtk_every`]; one that cannot be written does not stop the run.
    fn write_frame(&mut self);
    /// The running restart file of [`RunOptions::checkpoint_every`]; one that cannot be written
    /// does not stop the run.
    fn write_checkpoint(&mut self);
}

/// Runs the `n` cycles of a CYCLE through `engine`, in one run or in pieces of whole check
/// intervals: with running restart files, pieces sized to last about `every`, each followed
/// by the file when `every` has passed since the last; with VTK frames, pieces that end on the
/// frames' cycles. The options are the ticker's. Returns what the runs reported, and the
/// failure that ended them, if any.
pub fn run_in_pieces(engine: &mut (impl Pieces + ?Sized), n: u64, ticker: &mut Ticker) -> (CycleReport, Result<(), CycleError>) {
    let interval = CHECK_INTERVAL;
    let (vtk_every, checkpoint_every) = (ticker.options.vtk_every, ticker.options.checkpoint_every);
    let frame_every = vtk_every.map(|f| f.max(1).div_ceil(interval) * interval);
    let mut report = CycleReport::default();
    if frame_every.is_some() {
        // The frame of the CYCLE's start shows the contacts the CYCLE starts from: a run of no
        // cycles detects them (the run that follows finds nothing changed and does not detect
        // again, so the cycles are the same).
        match engine.run_piece(0, &mut |done| ticker.tick(done), &mut report) {
            Ok(()) => engine.write_frame(),
            Err(e) => return (report, Err(e)),
        }
    }
    let mut piece = if checkpoint_every.is_some() { interval } else { n };
    let mut last_checkpoint = Instant::now();
    // (At least one run: CYCLE 0 still detects the contacts.)
    loop {
        let (base, t0) = (report.cycles, Instant::now());
        let mut k = piece.min(n - base);
        if let Some(f) = frame_every {
            k = k.min(f - base % f);
        }
        if let Err(e) = engine.run_piece(k, &mut |done| ticker.tick(base + done), &mut report) {
            return (report, Err(e));
        }
        if frame_every.is_some_and(|f| report.cycles > base && report.cycles % f == 0) {
            engine.write_frame();
        }
        if let Some(every) = checkpoint_every {
            if last_checkpoint.elapsed() >= every {
                engine.write_checkpoint();
                last_checkpoint = Instant::now();
            }
        }
        if report.cycles >= n || report.cycles == base || ticker.stopped {
            return (report, Ok(()));
        }
        if let Some(every) = checkpoint_every {
            piece = piece_for(every, t0.elapsed(), report.cycles - base, interval);
        }
    }
}

/// The size of the next piece of a CYCLE with running restart files: about `every` of wall
/// time at the pace of the last piece (`done` cycles in `took`), in whole check intervals.
fn piece_for(every: Duration, took: Duration, done: u64, interval: u64) -> u64 {
    let per_cycle = took.as_secs_f64() / done as f64;
    ((every.as_secs_f64() / per_cycle.max(1e-12)) as u64).clamp(1, u64::MAX / 2).div_ceil(interval) * interval
}
