//! CYCLE: the checks that the model can run, the time step, the run through the backend (in
//! pieces, for running restart files and VTK frames), its progress, and what a failure means.

use std::io::Write;
use std::time::{Duration, Instant};

use super::{Executor, Progress, RunError, RunOptions, CHECKPOINT_FILE, VTK_DIR};
use crate::udec::backend::{CycleError, CycleReport};
use crate::udec::deck::Located;
use crate::udec::model::constitutive::{Constitutive, CrackingLaw};
use crate::udec::model::Model;
use crate::udec::output;

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
struct Ticker {
    /// The run's options (a copy: the backend runs while the ticker is called).
    options: RunOptions,
    bar: Option<indicatif::ProgressBar>,
    n: u64,
    long: bool,
    started: Instant,
    last_line: Instant,
    /// The run was interrupted at the last tick.
    stopped: bool,
}

impl Ticker {
    fn new(options: &RunOptions, n: u64) -> Self {
        let long = n >= 1000;
        let bar = (options.progress == Progress::Bar && long).then(|| progress_bar(n));
        let started = Instant::now();
        Ticker { options: options.clone(), bar, n, long, started, last_line: started, stopped: false }
    }

    /// `done` cycles of the CYCLE are done; false asks the backend to stop (interrupted).
    fn tick(&mut self, done: u64) -> bool {
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
    fn finish(self) -> bool {
        if let Some(pb) = self.bar {
            pb.finish_and_clear();
        }
        self.stopped
    }
}

impl Executor<'_> {
    /// CYCLE n: checks the model can run, sets the time step, runs the backend.
    pub(super) fn cycle(&mut self, cmd: &Located, n: u64) -> Result<(), RunError> {
        let dt = self.check_can_cycle(cmd)?;
        self.model.timestep = dt;
        // Outside the ratios the suite has verified (blockdem verify): say so before cycling.
        for w in crate::udec::model::limits::warnings(&self.model, &self.limits) {
            self.echo(&w);
        }
        if let Some(w) = self.round_warning() {
            self.echo(&w);
        }
        self.echo(&format!("INITIAL TIMESTEP = {}", output::format::fmt_e(dt)));
        let start_cycle = self.model.cycle;
        let mut ticker = Ticker::new(&self.options, n);
        // The log up to here is seen while the cycles run.
        let _ = self.log.flush();
        let (report, result) = self.run_cycles(n, &mut ticker);
        let stopped = ticker.finish();
        if let Err(failure) = result {
            return Err(self.cycle_failure(cmd, failure, start_cycle));
        }
        self.echo_report(&report);
        self.echo(&format!("CURRENT CYCLE COUNT = {}", self.model.cycle));
        if stopped && report.cycles < n {
            self.echo(&format!("CYCLE INTERRUPTED AFTER {} OF {n} CYCLES", report.cycles));
            return Err(self.interrupted(cmd));
        }
        Ok(())
    }

    /// The checks before a CYCLE, in order: blocks, masses and stiffnesses, cracking the engine
    /// can run, the time step, and values that overflow f64. Returns the time step.
    fn check_can_cycle(&mut self, cmd: &Located) -> Result<f64, RunError> {
        if self.model.blocks.is_empty() {
            return Err(self.command_error(cmd, "CYCLE: there are no blocks (give a BLOCK command first)"));
        }
        self.model.recompute_mass_properties();
        self.check_joints(cmd)?;
        self.check_masses_and_stiffnesses(cmd)?;
        self.check_cracking(cmd)?;
        let dt = self.critical_timestep(cmd)?;
        self.check_overflows(cmd)?;
        Ok(dt)
    }

    /// Every block has a mass, and every contact material (the blocks', and the joints' of SPLIT
    /// MAT=) its stiffnesses KN and KS.
    // `!(x > 0.0)` on purpose: a NaN mass or stiffness fails the check too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn check_masses_and_stiffnesses(&self, cmd: &Located) -> Result<(), RunError> {
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
        Ok(())
    }

    /// Griffith cracking (constitutive numbers 3 and 4, SL-85-1 Table A1, and 5) acts on the
    /// internal stresses of simply-deformable blocks, which come later: a block that asks for it
    /// (a tensile strength factor set) must not run as if it could not crack.
    fn check_cracking(&self, cmd: &Located) -> Result<(), RunError> {
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
        Ok(())
    }

    /// The time step FRAC·2√(m_min/k_max), which must be a positive finite number.
    // `!(x > 0.0)` on purpose: a NaN time step fails the check too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn critical_timestep(&self, cmd: &Located) -> Result<f64, RunError> {
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
        Ok(dt)
    }

    /// Blocks whose kinetic energy, or weight and load, overflow f64.
    fn check_overflows(&self, cmd: &Located) -> Result<(), RunError> {
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
        Ok(())
    }

    /// Runs the `n` cycles through the backend, in one run or in pieces of whole check
    /// intervals: with running restart files, pieces sized to last about `every`, each followed
    /// by the file when `every` has passed since the last; with VTK frames, pieces that end on the
    /// frames' cycles. Returns what the runs reported, and the failure that ended them, if any.
    fn run_cycles(&mut self, n: u64, ticker: &mut Ticker) -> (CycleReport, Result<(), CycleError>) {
        let interval = crate::driver::CHECK_INTERVAL;
        let frame_every = self.options.vtk_every.map(|f| f.max(1).div_ceil(interval) * interval);
        let mut report = CycleReport::default();
        if frame_every.is_some() {
            // The frame of the CYCLE's start shows the contacts the CYCLE starts from: a run of no
            // cycles detects them (the run that follows finds nothing changed and does not detect
            // again, so the cycles are the same).
            match self.backend.run(&mut self.model, 0, &mut |done| ticker.tick(done)) {
                Ok(r) => {
                    report.extend(r);
                    self.write_frame();
                }
                Err(e) => return (report, Err(e)),
            }
        }
        let mut piece = if self.options.checkpoint_every.is_some() { interval } else { n };
        let mut last_checkpoint = Instant::now();
        // (At least one run: CYCLE 0 still detects the contacts.)
        loop {
            let (base, t0) = (report.cycles, Instant::now());
            let mut k = piece.min(n - base);
            if let Some(f) = frame_every {
                k = k.min(f - base % f);
            }
            match self.backend.run(&mut self.model, k, &mut |done| ticker.tick(base + done)) {
                Ok(r) => report.extend(r),
                Err(e) => return (report, Err(e)),
            }
            if frame_every.is_some_and(|f| report.cycles > base && report.cycles % f == 0) {
                self.write_frame();
            }
            if let Some(every) = self.options.checkpoint_every {
                if last_checkpoint.elapsed() >= every {
                    self.write_checkpoint();
                    last_checkpoint = Instant::now();
                }
            }
            if report.cycles >= n || report.cycles == base || ticker.stopped {
                return (report, Ok(()));
            }
            if let Some(every) = self.options.checkpoint_every {
                piece = piece_for(every, t0.elapsed(), report.cycles - base, interval);
            }
        }
    }

    /// A VTK frame of `RunOptions::vtk_every`; a frame that cannot be written does not stop the run.
    fn write_frame(&self) {
        if let Err(e) = output::vtk::write_frame(&self.model, &self.options.out_dir.join(VTK_DIR)) {
            let _ = writeln!(std::io::stderr(), "blockdem: a VTK frame was not written ({e}); the run goes on");
        }
    }

    /// The running restart file of `RunOptions::checkpoint_every`; one that cannot be written
    /// does not stop the run.
    fn write_checkpoint(&self) {
        let path = self.options.out_dir.join(CHECKPOINT_FILE);
        let _ = std::fs::create_dir_all(&self.options.out_dir);
        if let Err(e) = output::restart::save_state(&path, &self.model, &self.plot, self.plot_count) {
            let _ = writeln!(std::io::stderr(), "blockdem: the running restart file was not written ({e}); the run goes on");
        }
    }

    /// The error of a CYCLE the backend failed in (the model rolled back to its last good state).
    fn cycle_failure(&self, cmd: &Located, failure: CycleError, start_cycle: u64) -> RunError {
        // The contacts of the last good state (the model rolled back), detected once for both
        // questions below; an energy growth (which names its own safe FRACTION) and a failure
        // outside the numerics (set-up, a model that does not fit) ask neither.
        let (given_overlapping, advice) = if matches!(failure, CycleError::EnergyGrowth { .. } | CycleError::Setup(_) | CycleError::DoesNotFit(_)) {
            (None, String::new())
        } else {
            let mut probe = self.model.clone();
            crate::udec::topology::update_contacts(&mut probe, true);
            (self.overlap_before_motion(&failure, start_cycle, &probe), self.fraction_advice(&probe))
        };
        // Blocks given overlapping are an input error, not a divergence: nothing has moved.
        if let Some(what) = given_overlapping {
            return self.command_error(cmd, what);
        }
        RunError::Numerical { file: self.file.clone(), line: cmd.line, failure, advice }
    }

    /// The log's lines of what happened during the cycles: cracks and smaller time steps.
    fn echo_report(&mut self, report: &CycleReport) {
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
                crate::udec::backend::frac_text(self.model.frac),
                crate::udec::backend::safe_frac_text(safe)
            )
        } else {
            String::new()
        }
    }
}

/// The size of the next piece of a CYCLE with running restart files: about `every` of wall
/// time at the pace of the last piece (`done` cycles in `took`), in whole check intervals.
fn piece_for(every: Duration, took: Duration, done: u64, interval: u64) -> u64 {
    let per_cycle = took.as_secs_f64() / done as f64;
    ((every.as_secs_f64() / per_cycle.max(1e-12)) as u64).clamp(1, u64::MAX / 2).div_ceil(interval) * interval
}
