//! The command executor: runs a parsed deck against a backend, printing the run log in the layout
//! of UDEC 1.2 (`)` echo, "INITIAL TIMESTEP", "CURRENT CYCLE COUNT", PRINT tables).
//!
//! The executor owns the model and all topology commands (BLOCK, SPLIT, DELETE, …); the backend
//! only cycles. It does not know which backend runs.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::backend::{Backend, CycleError};
use crate::deck::{Command, DampMode, DeckError, Located, PrintItem, Range};
use crate::model::constitutive::{Constitutive, CrackingLaw};
use crate::model::limits::{Limits, LIMITS_CPU_F64};
use crate::model::split::split_line;
use crate::model::Model;
use crate::output;
use crate::output::plot::PlotSettings;

/// The largest constitutive number (see `Executor::check_constitutive`).
pub const MAX_CONSTITUTIVE: u32 = Constitutive::MAX;

/// The file a SAVE or RESTART without a name uses, in the output folder.
pub const DEFAULT_SAVE_FILE: &str = "blockdem.sav";

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Input(#[from] DeckError),
    #[error("{file}:{line}: not supported yet: {what}")]
    Unsupported { file: String, line: usize, what: String },
    /// `advice` is empty, or names the largest safe FRACTION when FRACTION is above the stable
    /// limit of the model and the failure's own message does not (an overlap, a block too fast or
    /// a non-finite value can be the first sign of an unstable time step).
    #[error("{file}:{line}: {failure}{advice}")]
    Numerical { file: String, line: usize, failure: CycleError, advice: String },
    #[error("{file}:{line}: {message}")]
    Command { file: String, line: usize, message: String },
    /// The run was interrupted (`RunOptions::interrupt`): during a CYCLE, at its next energy
    /// check, with the model at that cycle; otherwise before the command at `line`.
    #[error("{file}:{line}: interrupted at cycle {cycle}")]
    Interrupted { file: String, line: usize, cycle: u64 },
}

impl RunError {
    /// True when the run failed in the numerics (the model then holds the last good state).
    pub fn is_numerical(&self) -> bool {
        matches!(self, RunError::Numerical { .. })
    }

    /// True when the run was interrupted (the model then holds the state it was stopped at).
    pub fn is_interrupted(&self) -> bool {
        matches!(self, RunError::Interrupted { .. })
    }
}

/// Settings of a run that do not come from the deck.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Folder for PLOT files and SAVE files named without a folder.
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
    /// Write a VTK frame (`output::vtk`) into `VTK_DIR` in `out_dir` at the start of each CYCLE
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

/// The progress line of `Progress::Lines`: done of n cycles after `elapsed` seconds.
/// A plot's title: the deck's file name without its folders (a deck given as text has none).
fn deck_title(file: &str) -> &str {
    std::path::Path::new(file).file_name().and_then(|n| n.to_str()).unwrap_or(file)
}

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

/// What of `command` is not supported yet (its physics comes in a later version), if anything.
/// The executor stops at such a command, and before the first CYCLE it looks ahead for one, so
/// that a deck of long CYCLEs followed by FLUID fails before it cycles, not after (issue 27
/// item 6).
fn not_supported_yet(command: &Command) -> Option<&'static str> {
    match command {
        Command::Change { to: Some(crate::deck::Deformability::Sdef), .. } => Some("CHANGE SDEF (simply-deformable blocks)"),
        Command::Change { to: Some(crate::deck::Deformability::Fdef), .. } => Some("CHANGE FDEF (fully-deformable blocks)"),
        Command::Fluid { .. } => Some("FLUID (fluid flow in joints and domains)"),
        Command::Generate { .. } => Some("GENERATE (zoning of fully-deformable blocks)"),
        Command::PFix { .. } => Some("PFIX (domain pressures)"),
        Command::PFree { .. } => Some("PFREE (domain pressures)"),
        Command::Print { items } => items.iter().find_map(|item| match item {
            PrintItem::Domains => Some("PRINT DOMAINS (fluid domains)"),
            PrintItem::DList => Some("PRINT DLIST (domain linked lists)"),
            PrintItem::Flows => Some("PRINT FLOWS (fluid flow)"),
            _ => None,
        }),
        _ => None,
    }
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

impl RunOptions {
    fn interrupted(&self) -> bool {
        self.interrupt.as_ref().is_some_and(|flag| flag.load(Ordering::Relaxed))
    }
}

pub struct Executor<'a> {
    pub model: Model,
    backend: Box<dyn Backend + 'a>,
    log: Box<dyn Write + 'a>,
    options: RunOptions,
    plot: PlotSettings,
    plot_count: usize,
    file: String,
    /// The verified ratios the model is checked against before CYCLE (the backend's precision).
    limits: Limits,
    /// Commands executed so far (START is only the first).
    executed: usize,
    /// The line printed under the banner ([`Executor::set_provenance`]).
    provenance: Option<String>,
    /// The ROUND (its bits) and the blocks it cuts that the ROUND warning last named.
    round_warned: Option<(u64, Vec<u32>)>,
}

impl<'a> Executor<'a> {
    pub fn new(backend: Box<dyn Backend + 'a>, log: Box<dyn Write + 'a>, options: RunOptions, file: &str) -> Self {
        Executor {
            model: Model::default(),
            backend,
            log,
            options,
            plot: PlotSettings::default(),
            plot_count: 0,
            file: file.to_string(),
            limits: LIMITS_CPU_F64,
            executed: 0,
            provenance: None,
            round_warned: None,
        }
    }

    /// What made the run (`output::provenance::Provenance::line`): printed under the banner of
    /// START and RESTART, so that a log names its program, deck, backend and precision.
    pub fn set_provenance(&mut self, line: String) {
        self.provenance = Some(line);
    }

    fn banner(&mut self) {
        self.echo("PROGRAM UDEC: UNIVERSAL DISTINCT ELEMENT CODE (VERSION 1.2)");
        if let Some(line) = self.provenance.clone() {
            self.echo(&line);
        }
    }

    /// The limits of extreme ratios measured on the backend that runs (`blockdem verify`): a model
    /// beyond them gets a WARNING before each CYCLE. The default is the CPU f64 backend's; a run on
    /// f32 GPU kernels sets [`crate::model::limits::LIMITS_GPU_F32`].
    pub fn set_limits(&mut self, limits: Limits) {
        self.limits = limits;
    }

    /// Runs the commands in order until STOP, END or an error.
    pub fn run(&mut self, commands: &[Located]) -> Result<(), RunError> {
        let result = self.run_commands(commands);
        // Also on an error, before the caller reports it.
        let _ = self.log.flush();
        result
    }

    fn run_commands(&mut self, commands: &[Located]) -> Result<(), RunError> {
        let mut looked_ahead = false;
        for (i, cmd) in commands.iter().enumerate() {
            if self.options.interrupted() {
                return Err(self.interrupted(cmd));
            }
            // Before the first CYCLE: a command further on that cannot run stops the run now,
            // not after hours of cycling (the parser has read the whole deck, so typing errors
            // are already reported).
            if !looked_ahead && matches!(cmd.command, Command::Cycle { .. }) {
                looked_ahead = true;
                if let Some((later, what)) = commands[i..].iter().find_map(|c| not_supported_yet(&c.command).map(|w| (c, w))) {
                    self.echo(&format!(
                        "THE DECK CANNOT RUN TO ITS END: LINE {} ({}) IS NOT SUPPORTED YET; NOTHING IS CYCLED",
                        later.line,
                        later.source.trim()
                    ));
                    return Err(self.unsupported(later, what));
                }
            }
            self.echo(&format!("){}", cmd.source));
            let done = self.execute(cmd)?;
            self.executed += 1;
            if done {
                break;
            }
            // What a command printed is seen when it ends; BLOCK commands, which print only their
            // echo, are left to the log's buffer (a generated deck has 10⁶ of them).
            if !matches!(cmd.command, Command::Block { .. }) {
                let _ = self.log.flush();
            }
        }
        Ok(())
    }

    fn echo(&mut self, line: &str) {
        let _ = writeln!(self.log, "{line}");
    }

    fn interrupted(&self, cmd: &Located) -> RunError {
        RunError::Interrupted { file: self.file.clone(), line: cmd.line, cycle: self.model.cycle }
    }

    fn command_error(&self, cmd: &Located, message: impl Into<String>) -> RunError {
        RunError::Command { file: self.file.clone(), line: cmd.line, message: message.into() }
    }

    fn unsupported(&self, cmd: &Located, what: &str) -> RunError {
        RunError::Unsupported { file: self.file.clone(), line: cmd.line, what: what.to_string() }
    }

    /// A material number a command names must be one PROPERTY can define (UDEC's NMAT slots):
    /// a BLOCK, CHANGE or SPLIT of material 25 was taken, and CYCLE then asked for a PROPERTY
    /// MAT=25 that PROPERTY refused.
    fn check_material(&self, cmd: &Located, what: &str, material: Option<u32>) -> Result<(), RunError> {
        match material {
            Some(m) if m == 0 || m as usize > crate::model::MAX_MATERIALS => {
                Err(self.command_error(cmd, format!("{what}: material number must be 1 to {}, found {m}", crate::model::MAX_MATERIALS)))
            }
            _ => Ok(()),
        }
    }

    /// Constitutive numbers are those SL-85-1 defines: 1 to 4 of Table A1, and 5, which its
    /// paragraphs 5 and 17 name for joint contacts with Griffith cracking (run as 4). Any other
    /// number would run as one of these without saying so.
    fn check_constitutive(&self, cmd: &Located, what: &str, constitutive: Option<u32>) -> Result<(), RunError> {
        match constitutive {
            Some(c) if Constitutive::from_number(c).is_none() => Err(self.command_error(
                cmd,
                format!(
                    "{what}: constitutive number must be 1 to {MAX_CONSTITUTIVE} (SL-85-1 Table A1: 1 point-load cracking and point \
                     contacts, 2 point-load and joints, 3 Griffith and point contacts, 4 and 5 Griffith and joints), found {c}"
                ),
            )),
            _ => Ok(()),
        }
    }

    /// The error for the first of `blocks` whose mass or moment of inertia (density × area, ×
    /// polar moment) overflows f64: CYCLE took an infinite mass for "no time step", and a SAVE
    /// wrote a model RESTART refuses. The caller undoes its command, which fails whole.
    fn mass_overflow(&self, cmd: &Located, what: &str, mut blocks: impl Iterator<Item = usize>) -> Option<RunError> {
        let b = blocks.find(|&b| !(self.model.blocks[b].mass.is_finite() && self.model.blocks[b].inertia.is_finite()))?;
        let blk = &self.model.blocks[b];
        let density = self.model.material(blk.material).block.density;
        Some(self.command_error(
            cmd,
            format!(
                "{what}: the mass of block {} (density {density:e} of material {} × area {:e}) or its moment of inertia overflows f64; \
                 check DENSITY and the units of lengths",
                blk.id, blk.material, blk.area
            ),
        ))
    }

    /// A ROUND at or past half a block's shortest edge is cut to half each edge
    /// (`model::geometry::corner_rounding`): the arcs then meet along whole edges and the block
    /// touches as a disc would, through several corner–corner contacts at one point. Said at the
    /// first CYCLE it applies to, naming the blocks, and again only when ROUND or the blocks it
    /// cuts change (issue 27 item 9: it was said at every CYCLE).
    fn round_warning(&mut self) -> Option<String> {
        let round = self.model.tol.round;
        let mut cut = Vec::new();
        let mut shortest = f64::INFINITY;
        for b in 0..self.model.blocks.len() {
            let edge = self.model.block_corners(b).iter().map(|c| c.edge_length).fold(f64::INFINITY, f64::min);
            if round >= 0.5 * edge {
                cut.push(self.model.blocks[b].id);
                shortest = shortest.min(edge);
            }
        }
        let said = (round.to_bits(), cut.clone());
        if cut.is_empty() || self.round_warned.as_ref() == Some(&said) {
            return None;
        }
        self.round_warned = Some(said);
        const NAMED: usize = 20;
        let mut ids = cut.iter().take(NAMED).map(u32::to_string).collect::<Vec<_>>().join(", ");
        if cut.len() > NAMED {
            ids.push_str(&format!(" and {} more", cut.len() - NAMED));
        }
        Some(format!(
            "WARNING: ROUND {} is half the shortest edge or more in {} block(s) (block {ids}; the shortest edge {}); their corners are \
             rounded at half each edge instead, so they touch as discs would: give ROUND under half the shortest edge",
            output::format::fmt_e(round),
            cut.len(),
            output::format::fmt_e(shortest)
        ))
    }

    fn resolve(&self, name: &Option<String>) -> PathBuf {
        let name = name.as_deref().unwrap_or(DEFAULT_SAVE_FILE);
        let p = Path::new(name);
        if p.is_absolute() || p.components().count() > 1 {
            p.to_path_buf()
        } else {
            self.options.out_dir.join(p)
        }
    }

    /// The blocks whose centroids lie in `r`. A range that catches none makes `what` (FIX, LOAD,
    /// …) a no-op, which the log says (issue 27 item 5): a range in the wrong units or with its
    /// ends swapped would otherwise pass unseen.
    fn in_range(&mut self, what: &str, r: &Range) -> Vec<usize> {
        let blocks = self.model.blocks_in_range(r.x1, r.x2, r.y1, r.y2);
        if blocks.is_empty() {
            let f = output::format::fmt_short;
            self.echo(&format!(
                "WARNING: {what}: no block's centroid lies in x {} to {}, y {} to {} (of {} block(s)); nothing changed",
                f(r.x1),
                f(r.x2),
                f(r.y1),
                f(r.y2),
                self.model.blocks.len()
            ));
        }
        blocks
    }

    /// Executes one command; returns true when the run should stop (STOP, END).
    fn execute(&mut self, cmd: &Located) -> Result<bool, RunError> {
        if let Some(what) = not_supported_yet(&cmd.command) {
            return Err(self.unsupported(cmd, what));
        }
        match &cmd.command {
            Command::Start => {
                if self.executed > 0 {
                    // It would claim a cold start and keep the model (UDEC read START first only).
                    return Err(self.command_error(cmd, "START must be the first command of a run (a cold start); to begin again, start a new run"));
                }
                self.banner();
                self.echo("THIS IS A START RUN");
            }
            Command::Restart { file } => {
                let path = self.resolve(file);
                // Every RestartError names the file.
                let saved = output::restart::load(&path).map_err(|e| self.command_error(cmd, format!("RESTART: {e}")))?;
                self.model = saved.model;
                self.plot = saved.plot;
                self.plot_count = saved.plot_count;
                self.banner();
                self.echo(&format!("THIS IS A RESTART RUN (FROM {}, CYCLE {})", path.display(), self.model.cycle));
            }
            Command::Stop | Command::End => return Ok(true),
            Command::Block { material, constitutive, corners } => {
                self.check_material(cmd, "BLOCK", *material)?;
                self.check_constitutive(cmd, "BLOCK", *constitutive)?;
                let next_id = self.model.next_block_id;
                let b = self
                    .model
                    .add_block(corners, material.unwrap_or(1), constitutive.unwrap_or(1), None)
                    .map_err(|e| self.command_error(cmd, format!("BLOCK: {e}")))?;
                if let Some(e) = self.mass_overflow(cmd, "BLOCK", [b].into_iter()) {
                    // The command fails whole: the model is left as it was.
                    self.model.remove_blocks(&[b]);
                    self.model.next_block_id = next_id;
                    return Err(e);
                }
            }
            Command::Change { range, to, material, constitutive } => {
                self.check_material(cmd, "CHANGE", *material)?;
                self.check_constitutive(cmd, "CHANGE", *constitutive)?;
                // CHANGE SDEF / FDEF stopped above (`not_supported_yet`).
                debug_assert!(to.is_none());
                let blocks = self.in_range("CHANGE", range);
                let before: Vec<(u32, u32)> = blocks.iter().map(|&b| (self.model.blocks[b].material, self.model.blocks[b].constitutive)).collect();
                for &b in &blocks {
                    if let Some(m) = material {
                        self.model.blocks[b].material = *m;
                    }
                    if let Some(c) = constitutive {
                        self.model.blocks[b].constitutive = *c;
                    }
                }
                self.model.recompute_mass_properties();
                if let Some(e) = self.mass_overflow(cmd, "CHANGE", blocks.iter().copied()) {
                    for (&b, &(m, c)) in blocks.iter().zip(&before) {
                        (self.model.blocks[b].material, self.model.blocks[b].constitutive) = (m, c);
                    }
                    self.model.recompute_mass_properties();
                    return Err(e);
                }
            }
            Command::Cycle { n } => self.cycle(cmd, *n)?,
            Command::Damping { fcrit, freq, mode } => {
                // Rayleigh damping with its minimum ξ at the centre frequency ω = 2πf:
                // α = ξω (mass-proportional), β = ξ/ω (stiffness-proportional), so that
                // ξ(ω) = ½(α/ω + βω) equals fcrit there. MASS and STIFFNESS drop one term, as
                // UDEC 1.2 did ("STIFFNESS-DAMPING TERM SET TO ZERO").
                let omega = 2.0 * std::f64::consts::PI * freq;
                let (alpha, beta) = (fcrit * omega, fcrit / omega);
                // At the ends of f64 (DAMP 0 1E308: ω overflows and α = 0·∞) a constant is not a
                // number: the run would diverge at once, and its saves could not be restarted.
                let kept = match mode {
                    DampMode::Full => [alpha, beta],
                    DampMode::Mass | DampMode::Internal => [alpha, 0.0],
                    DampMode::Stiffness => [0.0, beta],
                };
                if !kept.iter().all(|x| x.is_finite()) {
                    return Err(self.command_error(
                        cmd,
                        format!(
                            "DAMPING: fcrit {fcrit:e} at freq {freq:e} gives the damping constants α = ξω = {alpha:e} and β = ξ/ω = {beta:e}, \
                             which are not finite numbers; give fcrit and freq in ordinary ranges (fcrit about 0 to 1, freq the model's frequency in Hz)"
                        ),
                    ));
                }
                match mode {
                    DampMode::Full => {
                        self.model.damping.alpha = alpha;
                        self.model.damping.beta = beta;
                    }
                    DampMode::Mass => {
                        self.model.damping.alpha = alpha;
                        self.model.damping.beta = 0.0;
                        self.echo("STIFFNESS-DAMPING TERM SET TO ZERO");
                    }
                    DampMode::Stiffness => {
                        self.model.damping.alpha = 0.0;
                        self.model.damping.beta = beta;
                        self.echo("MASS-DAMPING TERM SET TO ZERO");
                    }
                    DampMode::Internal => {
                        self.model.damping.alpha_internal = alpha;
                        self.echo("NOTE - ONLY MASS-DAMPING USED");
                    }
                }
            }
            Command::Delete { range } => {
                let gone = self.in_range("DELETE", range);
                self.model.retire_energy_around(|m| m.remove_blocks(&gone));
            }
            Command::Dump { .. } => {
                output::dump::dump(&self.model, &mut self.log).map_err(|e| self.command_error(cmd, format!("DUMP: {e}")))?;
            }
            Command::Fix { range } => {
                for b in self.in_range("FIX", range) {
                    let blk = &mut self.model.blocks[b];
                    blk.fixed = true;
                    blk.velocity = [0.0, 0.0];
                    blk.angular_velocity = 0.0;
                }
            }
            Command::Free { range } => {
                for b in self.in_range("FREE", range) {
                    self.model.blocks[b].fixed = false;
                }
            }
            Command::Fraction { f } => self.model.frac = *f,
            // Stopped above (`not_supported_yet`).
            Command::Fluid { .. } | Command::Generate { .. } | Command::PFix { .. } | Command::PFree { .. } => {}
            Command::Gravity { g } => self.model.gravity = *g,
            Command::Link { flying, anchor } => {
                let find = |p: [f64; 2]| (0..self.model.blocks.len()).find(|&b| crate::model::geometry::point_in_polygon(p, &self.model.corner_positions(b)));
                let f = find(*flying).ok_or_else(|| {
                    self.command_error(
                        cmd,
                        format!(
                            "LINK: no block contains the point ({}, {}) given for the flying block",
                            output::format::fmt_short(flying[0]),
                            output::format::fmt_short(flying[1])
                        ),
                    )
                })?;
                let a = find(*anchor).ok_or_else(|| {
                    self.command_error(
                        cmd,
                        format!(
                            "LINK: no block contains the point ({}, {}) given for the linking block",
                            output::format::fmt_short(anchor[0]),
                            output::format::fmt_short(anchor[1])
                        ),
                    )
                })?;
                if f == a {
                    return Err(self.command_error(cmd, "LINK: both points lie in the same block"));
                }
                // Contact detection here searches every block's neighbourhood each update, so a
                // flying block is never lost; the link is kept and printed (PRINT LIST), as the
                // virtual contact of UDEC 1.2 was.
                self.model.links.push(crate::model::Link { flying: f as u32, anchor: a as u32 });
            }
            Command::Load { range, force } => {
                for b in self.in_range("LOAD", range) {
                    self.model.blocks[b].load = *force;
                }
            }
            Command::Plot { options } => {
                self.plot_count += 1;
                std::fs::create_dir_all(&self.options.out_dir)
                    .map_err(|e| self.command_error(cmd, format!("PLOT: cannot create {}: {e}", self.options.out_dir.display())))?;
                let files = output::plot::plot(&self.model, &self.plot, options, &self.options.out_dir, self.plot_count, deck_title(&self.file))
                    .map_err(|e| self.command_error(cmd, format!("PLOT: {e}")))?;
                self.echo(&format!("PLOT WRITTEN TO {} AND {}", files[0].display(), files[1].display()));
                if let Ok(Some(why)) = output::plot::shows_nothing(&self.model, &self.plot, options) {
                    self.echo(&format!("WARNING: PLOT shows no block: {why}"));
                }
            }
            Command::Print { items } => {
                for item in items {
                    let r = match item {
                        PrintItem::Blocks => output::print::print_blocks(&self.model, &mut self.log),
                        PrintItem::Contacts => output::print::print_contacts(&self.model, &mut self.log),
                        PrintItem::Corners => output::print::print_corners(&self.model, &mut self.log),
                        PrintItem::List => output::print::print_block_lists(&self.model, &mut self.log),
                        PrintItem::Energy => self.print_energy(),
                        // Stopped above (`not_supported_yet`).
                        PrintItem::Domains | PrintItem::DList | PrintItem::Flows => Ok(()),
                    };
                    r.map_err(|e| self.command_error(cmd, format!("PRINT: {e}")))?;
                }
            }
            Command::Property { material, values } => {
                use crate::deck::PropKey::*;
                self.check_material(cmd, "PROPERTY", Some(*material))?;
                let before = self.model.materials[*material as usize - 1];
                let m = &mut self.model.materials[*material as usize - 1];
                for &(key, v) in values {
                    match key {
                        Bulk => m.block.bulk = v,
                        Shear => m.block.shear = v,
                        Density => m.block.density = v,
                        Kn => m.contact.kn = v,
                        Ks => m.contact.ks = v,
                        Cohesion => m.contact.cohesion = v,
                        Friction => m.contact.friction = v,
                        Jkn => m.joint.kn = v,
                        Jks => m.joint.ks = v,
                        Jcohesion => m.joint.cohesion = v,
                        Jfriction => m.joint.friction = v,
                        Tf => m.block.tf = v,
                        Jperm => m.fluid.jperm = v,
                        Cperm => m.fluid.cperm = v,
                        Azero => m.fluid.azero = v,
                        Ares => m.fluid.ares = v,
                    }
                }
                self.model.recompute_mass_properties();
                if let Some(e) = self.mass_overflow(cmd, "PROPERTY", 0..self.model.blocks.len()) {
                    self.model.materials[*material as usize - 1] = before;
                    self.model.recompute_mass_properties();
                    return Err(e);
                }
            }
            Command::Round { d } => self.model.set_round(*d),
            Command::Vtk => {
                let dir = self.options.out_dir.join(VTK_DIR);
                let path = output::vtk::write_frame(&self.model, &dir).map_err(|e| self.command_error(cmd, format!("VTK: {e}")))?;
                self.echo(&format!("VTK FRAME WRITTEN TO {} (AND ITS CONTACTS BESIDE IT)", path.display()));
            }
            Command::Save { file } => {
                let path = self.resolve(file);
                if let Some(dir) = path.parent() {
                    let _ = std::fs::create_dir_all(dir);
                }
                output::restart::save_state(&path, &self.model, &self.plot, self.plot_count).map_err(|e| self.command_error(cmd, format!("SAVE: {e}")))?;
                self.echo(&format!("STATE SAVED TO {}", path.display()));
            }
            Command::Split { from, to, material, constitutive } => {
                self.check_material(cmd, "SPLIT", *material)?;
                self.check_constitutive(cmd, "SPLIT", *constitutive)?;
                let outcome = split_line(&mut self.model, *from, *to, *material, *constitutive);
                for (id, why) in &outcome.rejected {
                    self.echo(&format!("SPLIT REJECTED FOR BLOCK {id}: {why}"));
                }
                if outcome.split.is_empty() && outcome.rejected.is_empty() {
                    let f = output::format::fmt_short;
                    let why = if from == to { "has zero length" } else { "crosses no block from one side to the other" };
                    self.echo(&format!(
                        "WARNING: SPLIT ({}, {}) ({}, {}) {why}; nothing was split (a split line must run through a block, ending outside it or on its edges)",
                        f(from[0]),
                        f(from[1]),
                        f(to[0]),
                        f(to[1])
                    ));
                }
            }
            Command::View { ix1, ix2, iy1, iy2 } => self.plot.view = [*ix1, *ix2, *iy1, *iy2],
            Command::Window { x1, x2, y1, y2 } => self.plot.window = [*x1, *x2, *y1, *y2],
            Command::Velocity { range, velocity, angular } => {
                let blocks = self.in_range("VELOCITY", range);
                // A velocity whose ½mv² overflows f64 is refused here, where it is given: CYCLE
                // would refuse it too, but a DELETE or a contact update before that books the
                // energy of what it removes, and ∞ − ∞ left the ledger NaN for good.
                let w = angular.unwrap_or(0.0);
                if let Some(&b) = blocks.iter().find(|&&b| {
                    let blk = &self.model.blocks[b];
                    !blk.fixed && !(0.5 * blk.mass * (velocity[0] * velocity[0] + velocity[1] * velocity[1]) + 0.5 * blk.inertia * w * w).is_finite()
                }) {
                    return Err(self.command_error(
                        cmd,
                        format!(
                            "VELOCITY: block {} would move so fast (velocity ({:e}, {:e}), angular {w:e}) that its kinetic energy overflows f64; check the values and the units",
                            self.model.blocks[b].id, velocity[0], velocity[1]
                        ),
                    ));
                }
                // The kinetic energy VELOCITY gives (or takes, slowing a block) is input, booked
                // with the work of gravity and loads: the balance is unchanged by the command, and
                // what it shows later is the cycle's error alone. Measured as the ledger measures
                // kinetic energy (at the whole step), so that the booking is exact.
                let before = self.model.energies().kinetic;
                for b in blocks {
                    let blk = &mut self.model.blocks[b];
                    if !blk.fixed {
                        blk.velocity = *velocity;
                        blk.angular_velocity = angular.unwrap_or(0.0);
                    }
                }
                self.model.external_work += self.model.energies().kinetic - before;
            }
        }
        Ok(false)
    }

    fn print_energy(&mut self) -> std::io::Result<()> {
        let e = self.model.energies();
        let f = output::format::fmt_e;
        writeln!(self.log)?;
        writeln!(self.log, "ENERGY")?;
        writeln!(self.log, "  KINETIC {}   STRAIN (CONTACTS) {}   WORK OF GRAVITY, LOADS AND VELOCITY {}", f(e.kinetic), f(e.strain), f(e.external_work))?;
        writeln!(
            self.log,
            "  DISSIPATED: MASS DAMPING {}   CONTACT DASHPOTS {}   FRICTION {}   RELEASED (DELETED CONTACTS AND BLOCKS) {}",
            f(e.mass_damping),
            f(e.contact_damping),
            f(e.friction),
            f(e.released)
        )?;
        writeln!(self.log, "  BALANCE: KINETIC + STRAIN + DISSIPATED + RELEASED - WORK = {}", f(e.ledger()))
    }

    /// CYCLE n: checks the model can run, sets the time step, runs the backend.
    // `!(x > 0.0)` on purpose: a NaN mass or stiffness fails the check too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn cycle(&mut self, cmd: &Located, n: u64) -> Result<(), RunError> {
        if self.model.blocks.is_empty() {
            return Err(self.command_error(cmd, "CYCLE: there are no blocks (give a BLOCK command first)"));
        }
        self.model.recompute_mass_properties();
        for b in &self.model.blocks {
            let mat = self.model.material(b.material);
            if !(b.mass > 0.0) {
                return Err(self.command_error(
                    cmd,
                    format!("CYCLE: block {} has no mass: material {} has no density (PROPERTY MAT={} DENSITY=…)", b.id, b.material, b.material),
                ));
            }
            if !(mat.contact.kn > 0.0 && mat.contact.ks > 0.0) {
                return Err(self.command_error(cmd, format!("CYCLE: material {} of block {} needs contact stiffnesses KN and KS", b.material, b.id)));
            }
        }
        for c in &self.model.corners {
            if c.edge_material != 0 {
                let mat = self.model.material(c.edge_material);
                if !(mat.contact.kn > 0.0 && mat.contact.ks > 0.0) {
                    return Err(
                        self.command_error(cmd, format!("CYCLE: joint material {} (from SPLIT MAT=) needs contact stiffnesses KN and KS", c.edge_material))
                    );
                }
            }
        }
        // Griffith cracking (constitutive numbers 3 and 4, SL-85-1 Table A1, and 5) acts on the internal
        // stresses of simply-deformable blocks, which come later: a block that asks for it (a
        // tensile strength factor set) must not run as if it could not crack.
        if let Some(b) = self.model.blocks.iter().find(|b| {
            Constitutive::from_number(b.constitutive).is_some_and(|c| c.cracking == CrackingLaw::Griffith) && self.model.material(b.material).block.tf > 0.0
        }) {
            let what = format!(
                "Griffith cracking (block {} has constitutive number {} and material {} has TF = {}; the Griffith criterion \
                 needs the stresses of simply-deformable blocks; constitutive numbers 1 and 2 crack by the point-load criterion)",
                b.id,
                b.constitutive,
                b.material,
                output::format::fmt_short(self.model.material(b.material).block.tf)
            );
            return Err(self.unsupported(cmd, &what));
        }
        let dt =
            self.model.critical_timestep().ok_or_else(|| self.command_error(cmd, "CYCLE: cannot compute a time step (no block mass or contact stiffness)"))?;
        if !(dt > 0.0 && dt.is_finite()) {
            // m_min/k_max under- or overflowed f64: no explicit run can follow such a model.
            let m_min = self.model.blocks.iter().map(|b| b.mass).fold(f64::INFINITY, f64::min);
            return Err(self.command_error(
                cmd,
                format!(
                    "CYCLE: the time step FRAC·2√(m_min/k_max) is {dt:e}: the smallest block mass ({m_min:e}) and the largest contact \
                     stiffness are too far apart to be represented; check the units of DENSITY, KN and KS"
                ),
            ));
        }
        // A block so fast that ½mv² overflows cannot be integrated (the energy check would call
        // it an instability): name it.
        if let Some(b) = self.model.blocks.iter().find(|b| !b.kinetic_energy().is_finite()) {
            return Err(self.command_error(
                cmd,
                format!(
                    "CYCLE: block {} moves so fast (velocity ({:e}, {:e}), angular {:e}) that its kinetic energy overflows f64; check VELOCITY and the units",
                    b.id, b.velocity[0], b.velocity[1], b.angular_velocity
                ),
            ));
        }
        // Likewise a weight and load whose sum overflows (GRAVITY 0 -1E308 on a block of a few
        // kilograms): the backend's first force sum would store it in the model, fixed blocks
        // included, and a CYCLE 0, a SAVE after it and the last good state of a failing CYCLE
        // would all hold a force RESTART refuses.
        let g = self.model.gravity;
        if let Some(b) = self.model.blocks.iter().find(|b| !(b.mass * g[0] + b.load[0]).is_finite() || !(b.mass * g[1] + b.load[1]).is_finite()) {
            return Err(self.command_error(
                cmd,
                format!(
                    "CYCLE: the weight and load of block {} (mass {:e} × gravity ({:e}, {:e}) + load ({:e}, {:e})) overflow f64; check GRAVITY, LOAD and the units",
                    b.id, b.mass, g[0], g[1], b.load[0], b.load[1]
                ),
            ));
        }
        self.model.timestep = dt;
        // Outside the ratios the suite has verified (blockdem verify): say so before cycling.
        for w in crate::model::limits::warnings(&self.model, &self.limits) {
            self.echo(&w);
        }
        if let Some(w) = self.round_warning() {
            self.echo(&w);
        }
        self.echo(&format!("INITIAL TIMESTEP = {}", output::format::fmt_e(dt)));
        let start_cycle = self.model.cycle;
        let long = n >= 1000;
        let bar = (self.options.progress == Progress::Bar && long).then(|| {
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
        });
        let options = &self.options;
        let stopped = std::cell::Cell::new(false);
        let started = std::time::Instant::now();
        let mut last_line = started;
        let mut progress = |done: u64| {
            if let Some(pb) = &bar {
                pb.set_position(done);
            }
            if let (Progress::Lines { every }, true) = (options.progress, long && done < n) {
                if last_line.elapsed() >= every {
                    last_line = std::time::Instant::now();
                    let _ = writeln!(std::io::stderr(), "{}", progress_line(done, n, started.elapsed().as_secs_f64()));
                }
            }
            stopped.set(options.interrupted());
            !stopped.get()
        };
        // The log up to here is seen while the cycles run.
        let _ = self.log.flush();
        // In one run, or in pieces of whole check intervals: with running restart files, pieces
        // sized to last about `every`, each followed by the file when `every` has passed since
        // the last; with VTK frames, pieces that end on the frames' cycles.
        let interval = crate::driver::CHECK_INTERVAL;
        let frame_every = options.vtk_every.map(|f| f.max(1).div_ceil(interval) * interval);
        let vtk_dir = options.out_dir.join(VTK_DIR);
        let write_frame = |model: &Model| {
            if let Err(e) = output::vtk::write_frame(model, &vtk_dir) {
                let _ = writeln!(std::io::stderr(), "blockdem: a VTK frame was not written ({e}); the run goes on");
            }
        };
        let mut report = crate::backend::CycleReport::default();
        let mut result = Ok(());
        if frame_every.is_some() {
            // The frame of the CYCLE's start shows the contacts the CYCLE starts from: a run of no
            // cycles detects them (the run that follows finds nothing changed and does not detect
            // again, so the cycles are the same).
            match self.backend.run(&mut self.model, 0, &mut |done| progress(done)) {
                Ok(r) => {
                    report.extend(r);
                    write_frame(&self.model);
                }
                Err(e) => result = Err(e),
            }
        }
        let mut piece = if options.checkpoint_every.is_some() { interval } else { n };
        let mut last_checkpoint = std::time::Instant::now();
        // (At least one run: CYCLE 0 still detects the contacts.)
        while result.is_ok() {
            let (base, t0) = (report.cycles, std::time::Instant::now());
            let mut k = piece.min(n - base);
            if let Some(f) = frame_every {
                k = k.min(f - base % f);
            }
            match self.backend.run(&mut self.model, k, &mut |done| progress(base + done)) {
                Ok(r) => report.extend(r),
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
            if frame_every.is_some_and(|f| report.cycles > base && report.cycles % f == 0) {
                write_frame(&self.model);
            }
            if let Some(every) = options.checkpoint_every {
                if last_checkpoint.elapsed() >= every {
                    let path = options.out_dir.join(CHECKPOINT_FILE);
                    let _ = std::fs::create_dir_all(&options.out_dir);
                    if let Err(e) = output::restart::save_state(&path, &self.model, &self.plot, self.plot_count) {
                        let _ = writeln!(std::io::stderr(), "blockdem: the running restart file was not written ({e}); the run goes on");
                    }
                    last_checkpoint = std::time::Instant::now();
                }
            }
            if report.cycles >= n || report.cycles == base || stopped.get() {
                break;
            }
            if let Some(every) = options.checkpoint_every {
                let per_cycle = t0.elapsed().as_secs_f64() / (report.cycles - base) as f64;
                piece = ((every.as_secs_f64() / per_cycle.max(1e-12)) as u64).clamp(1, u64::MAX / 2).div_ceil(interval) * interval;
            }
        }
        let stopped = stopped.get();
        if let Some(pb) = bar {
            pb.finish_and_clear();
        }
        if let Err(failure) = result {
            // The contacts of the last good state (the model rolled back), detected once for both
            // questions below; an energy growth (which names its own safe FRACTION) and a failure
            // outside the numerics (set-up, a model that does not fit) ask neither.
            let (given_overlapping, advice) = if matches!(failure, CycleError::EnergyGrowth { .. } | CycleError::Setup(_) | CycleError::DoesNotFit(_)) {
                (None, String::new())
            } else {
                let mut probe = self.model.clone();
                crate::topology::update_contacts(&mut probe, true);
                (self.overlap_before_motion(&failure, start_cycle, &probe), self.fraction_advice(&probe))
            };
            // Blocks given overlapping are an input error, not a divergence: nothing has moved.
            if let Some(what) = given_overlapping {
                return Err(self.command_error(cmd, what));
            }
            return Err(RunError::Numerical { file: self.file.clone(), line: cmd.line, failure, advice });
        }
        for c in &report.cracks {
            self.echo(&format!(
                "BLOCK {} CRACKED AT CYCLE {} (POINT-LOAD VALUE {}): NEW BLOCK {} ALONG ({}, {}) - ({}, {})",
                c.block,
                c.cycle,
                output::format::fmt_e(c.value),
                c.new_block,
                output::format::fmt_e(c.from[0]),
                output::format::fmt_e(c.from[1]),
                output::format::fmt_e(c.to[0]),
                output::format::fmt_e(c.to[1])
            ));
        }
        for (cycle, dt) in &report.timestep_changes {
            self.echo(&format!("TIMESTEP REDUCED TO {} AT CYCLE {cycle} (A LIGHTER BLOCK WAS CREATED)", output::format::fmt_e(*dt)));
        }
        self.echo(&format!("CURRENT CYCLE COUNT = {}", self.model.cycle));
        if stopped && report.cycles < n {
            self.echo(&format!("CYCLE INTERRUPTED AFTER {} OF {n} CYCLES", report.cycles));
            return Err(self.interrupted(cmd));
        }
        Ok(())
    }

    /// After an overlap failure in the first check interval of a CYCLE (the model rolled back to
    /// the CYCLE's start): whether blocks already overlapped by more than the limit before any
    /// motion. Then nothing was driven through anything and no FRACTION helps: the blocks were
    /// given overlapping (BLOCK corners, a ROUND lowered under an overlap). The message names the
    /// pair with the largest such overlap. `probe`: the rolled-back model with its contacts
    /// detected.
    fn overlap_before_motion(&self, failure: &CycleError, start_cycle: u64, probe: &Model) -> Option<String> {
        if !matches!(failure, CycleError::Overlap { .. }) || self.model.cycle != start_cycle {
            return None;
        }
        let limit = 0.5 * probe.tol.round;
        let c = probe.contacts.iter().filter(|c| -c.gap > limit && probe.counts_force(c)).max_by(|a, b| b.gap.total_cmp(&a.gap))?;
        let (b1, b2) = (probe.blocks[c.block1 as usize].id, probe.blocks[c.block2 as usize].id);
        Some(format!(
            "CYCLE: blocks {b1} and {b2} overlap by {} near ({}, {}) before any motion, more than half the rounding length ({}): \
             they were given overlapping (BLOCK corners, or a ROUND lowered under an overlap); blocks may touch but not overlap",
            output::format::fmt_e(-c.gap),
            output::format::fmt_e(c.point[0]),
            output::format::fmt_e(c.point[1]),
            output::format::fmt_e(limit)
        ))
    }

    /// Names the largest safe FRACTION after a numerical failure whose message does not, when
    /// FRACTION is above the stability estimate of the model (`Model::stable_frac_estimate`, taken
    /// on the contacts the last good state has or would form at once: `probe`). Empty otherwise:
    /// then the failure is not one of the time step.
    fn fraction_advice(&self, probe: &Model) -> String {
        let safe = probe.stable_frac_estimate();
        if safe.is_finite() && safe > 0.0 && self.model.frac > safe {
            format!(
                " (FRACTION {} is above the stable limit of this model: the explicit integration diverges; the largest safe value \
                 is about {})",
                crate::backend::frac_text(self.model.frac),
                crate::backend::safe_frac_text(safe)
            )
        } else {
            String::new()
        }
    }

    /// The backend's description, for the run log.
    pub fn backend_description(&self) -> String {
        self.backend.describe()
    }
}
