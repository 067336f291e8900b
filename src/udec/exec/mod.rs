//! The command executor: runs a parsed deck against a backend, printing the run log in the layout
//! of UDEC 1.2 (`)` echo, "INITIAL TIMESTEP", "CURRENT CYCLE COUNT", PRINT tables).
//!
//! The executor owns the model and all topology commands (BLOCK, SPLIT, DELETE, …); the backend
//! only cycles. It does not know which backend runs.
//!
//! This file holds the executor itself, the run of a deck and the dispatch of each command; the
//! commands are carried out by command group, one file each (issue 26 item 8):
//! - `blocks`: BLOCK, CHANGE, DELETE, SPLIT (and ROUND, set in the dispatch);
//! - `materials`: PROPERTY, DAMPING, and the checks of material and constitutive numbers;
//! - `loads`: LOAD, FIX, FREE, VELOCITY, LINK (and GRAVITY, set in the dispatch);
//! - `output`: PRINT, PLOT, DUMP, VTK, SAVE, RESTART (and WINDOW, VIEW, set in the dispatch);
//! - `fluid`: FLUID, PFIX, PFREE and the checks of a scene with fluid;
//! - `cycling`: CYCLE (the checks before it, blocks built overlapping, the run through the
//!   backend in pieces, progress, running restart files and VTK frames, what a failure means, the
//!   energy-balance warning), and FRACTION and SET OVERLAP, set in the dispatch.

mod blocks;
mod cycling;
mod fdef;
mod fluid;
mod loads;
mod materials;
mod output;

use std::io::Write;

use crate::udec::backend::{Backend, CycleError};
use crate::udec::deck::{Command, DeckError, Located, Range};
use crate::udec::model::constitutive::Constitutive;
use crate::udec::model::limits::{Limits, LIMITS_CPU_F64};
use crate::udec::model::Model;
use crate::udec::output::plot::PlotSettings;

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

pub use crate::driver::run::{Progress, RunOptions, CHECKPOINT_FILE, VTK_DIR};

/// What of `command` is not supported yet (its physics comes in a later version), if anything.
/// The executor stops at such a command, and before the first CYCLE it looks ahead for one, so
/// that a deck of long CYCLEs followed by FLUID fails before it cycles, not after (issue 27
/// item 6).
/// Every command of UDEC 1.2 runs now (fluid came with issue 30, its SAVE with save format 6);
/// the look-ahead stays for what a later version adds.
fn not_supported_yet(_command: &Command) -> Option<&'static str> {
    None
}

/// Whether `command` leaves the model as the last run left it (`Fluid::as_run_left`): it only
/// writes or reads the state (a RESTART reads one, the flag with it), or is a run or the end.
fn leaves_the_run_state(command: &Command) -> bool {
    matches!(
        command,
        Command::Restart { .. }
            | Command::Stop
            | Command::End
            | Command::Cycle { .. }
            | Command::Dump { .. }
            | Command::Plot { .. }
            | Command::Print { .. }
            | Command::Save { .. }
            | Command::Vtk
            | Command::View { .. }
            | Command::Window { .. }
    )
}

/// Whether `command` can change the blocks, their positions or the contacts, after which a scene
/// with domains rebuilds them (RESTART's model has none; `Executor::restart` rebuilds them).
fn changes_topology(command: &Command) -> bool {
    // GENERATE gives its blocks new corners and drops their contacts (`Model::replace_outline`):
    // domains kept from before named contacts that were gone, and a SAVE then was refused by
    // RESTART (found by tests/suite/random_decks.rs).
    matches!(
        command,
        Command::Block { .. } | Command::Split { .. } | Command::Delete { .. } | Command::Cycle { .. } | Command::Change { .. } | Command::Generate { .. }
    )
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
    /// SET OVERLAP: what a CYCLE does with blocks found overlapping before any motion.
    overlap_policy: crate::udec::deck::OverlapPolicy,
    /// The model's shape (`cycling::ShapeMark`) when a CYCLE last looked for initial overlaps:
    /// only a CYCLE after a change of blocks or ROUND looks again.
    overlaps_checked: Option<cycling::ShapeMark>,
    /// The energy-balance warning was given (once a run).
    ledger_warned: bool,
    /// Whether the rigid blocks with a Griffith constitutive number were named once.
    griffith_rigid_warned: bool,
    /// Materials whose joints CYCLE said follow the point-contact law (no JKN, JKS; ¶5).
    joint_fallback_noted: Vec<u32>,
    /// SET DAMIN: the minimum domain area, for the domains built from then on.
    domain_min_area: Option<f64>,
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
            overlap_policy: crate::udec::deck::OverlapPolicy::default(),
            overlaps_checked: None,
            ledger_warned: false,
            griffith_rigid_warned: false,
            joint_fallback_noted: Vec::new(),
            domain_min_area: None,
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
    /// f32 GPU kernels sets [`crate::udec::model::limits::LIMITS_GPU_F32`].
    pub fn set_limits(&mut self, limits: Limits) {
        self.limits = limits;
    }

    /// Runs the commands in order until STOP, END or an error.
    pub fn run(&mut self, commands: &[Located]) -> Result<(), RunError> {
        let result = self.run_commands(commands);
        // The state a caller reads (the state JSON) has its domains right, also when a command
        // failed and the model went back to its last good state. With fluid, stage 7 keeps them
        // (and the last good state holds the ones it kept).
        if self.model.fluid.is_none() {
            self.refresh_domains_if_kept();
        }
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
            if !looked_ahead && matches!(cmd.command, Command::Cycle { .. }) {
                looked_ahead = true;
                self.look_ahead(&commands[i..])?;
            }
            self.echo(&format!("){}", cmd.source));
            let done = self.execute(cmd)?;
            if !leaves_the_run_state(&cmd.command) {
                if let Some(f) = self.model.fluid.as_mut() {
                    f.as_run_left = false;
                }
            }
            // With fluid a CYCLE's stage 7 rebuilds the domains itself at each contact update:
            // one more rebuild here, on the geometry the run ended with, could trace them
            // otherwise (a contact's feature moved on) and a CYCLE after it would not go on
            // from the run's state bit for bit.
            let kept_by_the_run = self.model.fluid.is_some() && matches!(cmd.command, Command::Cycle { .. });
            if changes_topology(&cmd.command) && !kept_by_the_run {
                self.refresh_domains_if_kept();
            }
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

    /// Before the first CYCLE (`rest` starts with it): a command further on that cannot run stops
    /// the run now, not after hours of cycling (the parser has read the whole deck, so typing
    /// errors are already reported).
    fn look_ahead(&mut self, rest: &[Located]) -> Result<(), RunError> {
        let later_unsupported = rest.iter().find_map(|c| not_supported_yet(&c.command).map(|w| (c, w)));
        if let Some((later, what)) = later_unsupported {
            self.echo(&format!("THE DECK CANNOT RUN TO ITS END: LINE {} ({}) IS NOT SUPPORTED YET; NOTHING IS CYCLED", later.line, later.source.trim()));
            return Err(self.unsupported(later, what));
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

    /// The blocks whose centroids lie in `r`. A range that catches none makes `what` (FIX, LOAD,
    /// …) a no-op, which the log says (issue 27 item 5): a range in the wrong units or with its
    /// ends swapped would otherwise pass unseen.
    fn in_range(&mut self, what: &str, r: &Range) -> Vec<usize> {
        let blocks = self.model.blocks_in_range(r.x1, r.x2, r.y1, r.y2);
        if blocks.is_empty() {
            let f = crate::output::format::fmt_short;
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

    /// START: the banner of a cold start.
    fn start(&mut self, cmd: &Located) -> Result<(), RunError> {
        if self.executed > 0 {
            // It would claim a cold start and keep the model (UDEC read START first only).
            return Err(self.command_error(cmd, "START must be the first command of a run (a cold start); to begin again, start a new run"));
        }
        self.banner();
        self.echo("THIS IS A START RUN");
        Ok(())
    }

    /// Executes one command; returns true when the run should stop (STOP, END). Each command
    /// group's handlers live in their own file; settings of one value are set here.
    fn execute(&mut self, cmd: &Located) -> Result<bool, RunError> {
        if let Some(what) = not_supported_yet(&cmd.command) {
            return Err(self.unsupported(cmd, what));
        }
        match &cmd.command {
            Command::Start => self.start(cmd)?,
            Command::Restart { file } => self.restart(cmd, file)?,
            Command::Stop | Command::End => return Ok(true),
            Command::Block { material, constitutive, corners } => self.block(cmd, *material, *constitutive, corners)?,
            Command::Change { range, to, material, constitutive } => {
                let sdef = *to == Some(crate::udec::deck::Deformability::Sdef);
                let fdef = *to == Some(crate::udec::deck::Deformability::Fdef);
                self.change(cmd, range, sdef, fdef, *material, *constitutive)?
            }
            Command::Cycle { n } => self.cycle(cmd, *n)?,
            Command::Damping { fcrit, freq, mode } => self.damping(cmd, *fcrit, *freq, *mode)?,
            Command::Delete { range } => self.delete(range),
            Command::Dump { .. } => self.dump(cmd)?,
            Command::Fix { range } => self.fix(range),
            Command::Free { range } => self.free(range),
            Command::Fraction { f } => self.model.frac = *f,
            Command::Fluid { density, bulk } => self.fluid(*density, *bulk),
            Command::PFix { domain, pressure } => self.pfix(cmd, *domain, *pressure)?,
            Command::PFree { domain } => self.pfree(cmd, *domain)?,
            Command::Generate { range, mesh } => self.generate(cmd, range, mesh)?,
            Command::Gravity { g } => self.model.gravity = *g,
            Command::Link { flying, anchor } => self.link(cmd, *flying, *anchor)?,
            Command::Load { range, force } => self.load(range, *force),
            Command::Plot { options } => self.plot_files(cmd, options)?,
            Command::Print { items } => self.print(cmd, items)?,
            Command::Property { material, values } => self.property(cmd, *material, values)?,
            Command::Round { d } => self.model.set_round(*d),
            Command::Vtk => self.vtk(cmd)?,
            Command::Save { file } => self.save(cmd, file)?,
            Command::Set { setting: crate::udec::deck::Setting::Overlap(policy) } => self.overlap_policy = *policy,
            Command::Set { setting: crate::udec::deck::Setting::Damin(a) } => {
                self.domain_min_area = Some(*a);
                self.refresh_domains_if_kept();
            }
            Command::Split { from, to, material, constitutive } => self.split(cmd, *from, *to, *material, *constitutive)?,
            Command::View { ix1, ix2, iy1, iy2 } => self.plot.view = [*ix1, *ix2, *iy1, *iy2],
            Command::Window { x1, x2, y1, y2 } => self.plot.window = [*x1, *x2, *y1, *y2],
            Command::Velocity { range, velocity, angular } => self.velocity(cmd, range, *velocity, *angular)?,
        }
        Ok(false)
    }

    /// The backend's description, for the run log.
    pub fn backend_description(&self) -> String {
        self.backend.describe()
    }
}
