//! CYCLE: the checks that the model can run, the time step, the run through the backend (in
//! pieces, for running restart files and VTK frames), its progress, and what a failure means.

use std::io::Write;

use super::{Executor, RunError, CHECKPOINT_FILE, VTK_DIR};
use crate::driver::run::Ticker;
use crate::udec::backend::{CycleError, CycleReport};
use crate::udec::deck::Located;
use crate::udec::model::constitutive::{Constitutive, CrackingLaw};
use crate::udec::model::{BlockKind, Model};
use crate::udec::output;

impl crate::driver::run::Pieces for Executor<'_> {
    fn run_piece(&mut self, cycles: u64, tick: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        self.backend.run_into(&mut self.model, cycles, tick, report)
    }

    fn write_frame(&mut self) {
        if let Err(e) = output::vtk::write_frame(&self.model, &self.options.out_dir.join(VTK_DIR)) {
            let _ = writeln!(std::io::stderr(), "blockdem: a VTK frame was not written ({e}); the run goes on");
        }
    }

    fn write_checkpoint(&mut self) {
        let path = self.options.out_dir.join(CHECKPOINT_FILE);
        let _ = std::fs::create_dir_all(&self.options.out_dir);
        if let Err(e) = output::restart::save_state(&path, &self.model, &self.plot, self.plot_count) {
            let _ = writeln!(std::io::stderr(), "blockdem: the running restart file was not written ({e}); the run goes on");
        }
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
        self.initial_overlaps(cmd)?;
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
        // The CPU's energy checks and the device's `flow` kernel (its error flag) stop a run at
        // a non-finite pressure and go back to the last good state; a pressure neither sees (a
        // domain without flows) still stops the run here, at the state it reached.
        if let Some(failure) = CycleError::non_finite_pressure(&self.model) {
            return Err(RunError::Numerical { file: self.file.clone(), line: cmd.line, failure, advice: String::new() });
        }
        self.echo_report(&report);
        self.overlaps_checked = Some(ShapeMark::of(&self.model));
        if let Some(w) = self.ledger_warning() {
            self.echo(&w);
        }
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
        self.check_fdef(cmd)?;
        self.check_fluid(cmd)?;
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
            if b.kind == BlockKind::SimplyDeformable && !(mat.block.bulk > 0.0 && mat.block.shear > 0.0) {
                return Err(self.command_error(
                    cmd,
                    format!("CYCLE: block {} is simply deformable, and its material {} needs a bulk modulus K and a shear modulus G (> 0)", b.id, b.material),
                ));
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
    /// internal stresses of simply-deformable blocks (Appendix A ¶17); a rigid block has none.
    /// Where no simply-deformable block could crack by it, a rigid block that asks for it (a
    /// tensile strength factor set) is an input error: the deck expects cracks that cannot come.
    /// Where some can (sample 4: the beam is SDEF, the projectile and the supports, rigid,
    /// inherit the one BLOCK command's CONS=4), the rigid ones are named in a warning once and
    /// run uncracked, as UDEC 1.2 ran them.
    fn check_cracking(&mut self, cmd: &Located) -> Result<(), RunError> {
        let griffith = |b: &crate::udec::model::Block| {
            Constitutive::from_number(b.constitutive).is_some_and(|c| c.cracking == CrackingLaw::Griffith) && self.model.material(b.material).block.tf > 0.0
        };
        let rigid: Vec<&crate::udec::model::Block> = self.model.blocks.iter().filter(|b| b.kind == BlockKind::Rigid && griffith(b)).collect();
        let Some(first) = rigid.first() else { return Ok(()) };
        let any_sdef = self.model.blocks.iter().any(|b| b.kind == BlockKind::SimplyDeformable && griffith(b));
        if !any_sdef {
            return Err(self.command_error(
                cmd,
                format!(
                    "CYCLE: block {} is rigid, but its constitutive number {} cracks it by Griffith's criterion (material {} has TF = {}), \
                     which reads the internal stress only a simply-deformable block has; make it simply deformable \
                     (CHANGE x1 x2 y1 y2 SDEF over its centroid) or give it constitutive number 1 or 2 (point-load cracking)",
                    first.id,
                    first.constitutive,
                    first.material,
                    output::format::fmt_short(self.model.material(first.material).block.tf)
                ),
            ));
        }
        if !self.griffith_rigid_warned {
            let ids: Vec<String> = rigid.iter().take(8).map(|b| b.id.to_string()).collect();
            let more = if rigid.len() > 8 { format!(" and {} more", rigid.len() - 8) } else { String::new() };
            let text = format!(
                "WARNING: {} rigid block(s) ({}{more}) have a Griffith constitutive number and a TF, but no internal stress: they will not crack \
                 (CHANGE … SDEF makes a block simply deformable)",
                rigid.len(),
                ids.join(", ")
            );
            self.griffith_rigid_warned = true;
            self.echo(&text);
        }
        Ok(())
    }

    /// The time step FRAC·2√(m_min/k_max), which must be a positive finite number.
    // `!(x > 0.0)` on purpose: a NaN time step fails the check too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn critical_timestep(&self, cmd: &Located) -> Result<f64, RunError> {
        let mut dt =
            self.model.critical_timestep().ok_or_else(|| self.command_error(cmd, "CYCLE: cannot compute a time step (no block mass or contact stiffness)"))?;
        // With fluid the run cuts the step to the fluid's limits after its detection and every
        // contact update (`model::fluid::fluid_timestep`); a later CYCLE keeps that cut, so that
        // the step only falls and CYCLE 100, CYCLE 100 is CYCLE 200 bit for bit.
        if self.model.fluid.is_some() && self.model.timestep > 0.0 {
            dt = dt.min(self.model.timestep);
        }
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

    /// Runs the `n` cycles through the backend, in one run or in pieces (`driver::run`).
    fn run_cycles(&mut self, n: u64, ticker: &mut Ticker) -> (CycleReport, Result<(), CycleError>) {
        crate::driver::run::run_in_pieces(self, n, ticker)
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
        // A position as the log prints numbers: (x, y) in the report's E format.
        let point = |p: &crate::driver::Position| format!("({})", p.coords().iter().map(|&x| output::format::fmt_e(x)).collect::<Vec<_>>().join(", "));
        for c in &report.cracks {
            self.echo(&format!(
                "BLOCK {} CRACKED AT CYCLE {} ({} {}): NEW BLOCK {} ALONG {} - {}",
                c.block,
                c.cycle,
                c.criterion,
                output::format::fmt_e(c.value),
                c.new_block,
                point(&c.from),
                point(&c.to)
            ));
        }
        for (cycle, dt) in &report.timestep_changes {
            let why = if self.model.fluid.is_some() { "A LIGHTER BLOCK WAS CREATED, OR THE FLUID'S LIMIT FELL" } else { "A LIGHTER BLOCK WAS CREATED" };
            self.echo(&format!("TIMESTEP REDUCED TO {} AT CYCLE {cycle} ({why})", output::format::fmt_e(*dt)));
        }
        // The fluid's mass balance, every run: the volume the free domains store against what
        // flowed in and what rebuilds and PFIX changed (`model::fluid::Fluid`); it holds to
        // round-off, so a miss is a fault worth saying.
        if let Some((stored, error)) = self.fluid_balance() {
            let inflow = self.model.fluid.map_or(0.0, |f| f.inflow);
            if error.abs() > FLUID_BALANCE_TOLERANCE * stored.abs().max(inflow.abs()) {
                let f = output::format::fmt_e;
                self.echo(&format!("WARNING: THE FLUID'S MASS BALANCE IS OFF BY {} (STORED {}, INFLOW {})", f(error), f(stored), f(inflow)));
            }
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

    /// Before a CYCLE whose blocks or ROUND changed since the last look (issue 27 item 1): block
    /// pairs given overlapping ([`initial_overlaps`], on a copy of the model with its contacts
    /// detected). Their contacts would start at the force kn·δ and release ½kn·δ² at the first
    /// step, launching the blocks. Each pair is named (up to ten) with its overlap, its strain
    /// energy and the speed that gives the lighter block; then the CYCLE stops (SET OVERLAP
    /// REFUSE, the default) or runs with that energy booked in the ledger as energy put in (SET
    /// OVERLAP ACCEPT), so that the balance stays near zero. Overlaps past half the rounding
    /// length are left to the backend's overlap check (`overlap_before_motion`): no choice runs
    /// them.
    fn initial_overlaps(&mut self, cmd: &Located) -> Result<(), RunError> {
        let mark = ShapeMark::of(&self.model);
        if self.overlaps_checked == Some(mark) {
            return Ok(());
        }
        let mut probe = self.model.clone();
        crate::udec::topology::update_contacts(&mut probe, true);
        let pairs = initial_overlaps(&probe);
        drop(probe);
        if pairs.is_empty() || pairs.iter().any(|p| p.overlap > 0.5 * self.model.tol.round) {
            self.overlaps_checked = Some(mark);
            return Ok(());
        }
        let f = output::format::fmt_e;
        let total: f64 = pairs.iter().map(|p| p.energy).sum();
        const NAMED: usize = 10;
        for p in pairs.iter().take(NAMED) {
            self.echo(&format!(
                "WARNING: BLOCKS {} AND {} OVERLAP BY {} NEAR ({}, {}) BEFORE ANY MOTION ({} CONTACT(S)): STRAIN ENERGY 1/2 KN D^2 = {} J/M, \
                ENOUGH TO LAUNCH BLOCK {} AT {} M/S",
                p.blocks[0],
                p.blocks[1],
                f(p.overlap),
                f(p.point[0]),
                f(p.point[1]),
                p.contacts,
                f(p.energy),
                p.launched,
                f(p.speed)
            ));
        }
        if pairs.len() > NAMED {
            self.echo(&format!("WARNING: AND {} MORE OVERLAPPING PAIR(S)", pairs.len() - NAMED));
        }
        match self.overlap_policy {
            crate::udec::deck::OverlapPolicy::Accept => {
                self.echo(&format!("SET OVERLAP ACCEPT: CYCLING WITH {} J/M OF INITIAL STRAIN ENERGY, BOOKED AS ENERGY PUT IN", f(total)));
                self.model.external_work += total;
                self.overlaps_checked = Some(mark);
                Ok(())
            }
            crate::udec::deck::OverlapPolicy::Refuse => {
                let p = &pairs[0];
                Err(self.command_error(
                    cmd,
                    format!(
                        "CYCLE: blocks {} and {} overlap by {} near ({}, {}) before any motion ({} overlapping pair(s) in all, more than {} of the \
                        rounding length and than their weight settles them; the log names them): their contacts would start at the force kn·δ and release {} J/m, \
                        ½kn·δ², at the first step, enough to launch block {} at {} m/s. Move the blocks apart, or give SET OVERLAP ACCEPT \
                        before the CYCLE to run with that energy (booked in the energy ledger as energy put in)",
                        p.blocks[0],
                        p.blocks[1],
                        f(p.overlap),
                        f(p.point[0]),
                        f(p.point[1]),
                        pairs.len(),
                        INITIAL_OVERLAP_TOLERANCE,
                        f(total),
                        p.launched,
                        f(p.speed)
                    ),
                ))
            }
        }
    }

    /// After a CYCLE, once a run: a warning when the energy ledger has moved by more than
    /// [`LEDGER_WARNING_FRACTION`] of the energy in play, with the figures (issue 27 item 4).
    fn ledger_warning(&mut self) -> Option<String> {
        // From the first energy check on: over the first steps the ledger carries the O(Δt)
        // start of central differences (the half-step velocity of a block set moving: 11 % after
        // one cycle of a block under a load), which falls as 1/n.
        if self.ledger_warned || self.model.cycle < crate::driver::CHECK_INTERVAL {
            return None;
        }
        let e = self.model.energies();
        let in_play = (e.kinetic + e.strain).max(e.external_work.abs()).max(e.dissipated() + e.released);
        let balance = e.ledger();
        if !(in_play > 0.0 && balance.abs() > LEDGER_WARNING_FRACTION * in_play) {
            return None;
        }
        self.ledger_warned = true;
        let f = output::format::fmt_e;
        Some(format!(
            "WARNING: THE ENERGY BALANCE IS {} AT CYCLE {}, {:.1}% OF THE ENERGY IN PLAY ({}; KINETIC {}, STRAIN {}, WORK PUT IN {}, \
            DISSIPATED AND RELEASED {}), MORE THAN {}%: A TIME STEP TOO COARSE FOR THE CONTACTS (TRY A SMALLER FRACTION) OR ENERGY MADE \
            WHERE NONE SHOULD BE (SAID ONCE A RUN)",
            f(balance),
            self.model.cycle,
            100.0 * balance.abs() / in_play,
            f(in_play),
            f(e.kinetic),
            f(e.strain),
            f(e.external_work),
            f(e.dissipated() + e.released),
            100.0 * LEDGER_WARNING_FRACTION
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

/// A contact found overlapping by more than this fraction of the rounding length before any
/// motion, while it carries no force yet, and by more than twice what the weight and load of its
/// blocks would press one contact in (2·|m·g + load|/kn: a block built in the static equilibrium
/// of its contacts, as a verification scene starts one, is not refused) makes its block pair an
/// initial overlap (`Executor::initial_overlaps`). Round-off of blocks built touching (SPLIT,
/// shared corners) is ~1e-16 of the coordinates, far below it; the overlap it allows (1e-4 m at
/// ROUND 0.1) stores ½kn·δ² = 5 J/m at kn = 1e9, a launch speed of cm/s.
pub const INITIAL_OVERLAP_TOLERANCE: f64 = 1e-3;

/// The fluid's mass balance may miss by this fraction of the volume stored or flowed in (it is
/// exact but for round-off) before a CYCLE says so.
pub const FLUID_BALANCE_TOLERANCE: f64 = 1e-9;

/// The energy ledger (`Energies::ledger`, PRINT ENERGY's BALANCE) may move by this fraction of
/// the energy in play (the largest of kinetic + strain energy, the work put in, and the energy
/// dissipated and released) before a CYCLE warns, once a run, from cycle 100 on. Central
/// differences keep the ledger to O((ωΔt)²) of the energy that rings in the contacts, which at
/// FRACTION 0.1 reaches 1–3 % (a block settling undamped on its base: 1.4 %; a collision: up to
/// 1.3 %, by where the touch falls in its step); 5 % is past the scheme's own error at the
/// default step: a time step too coarse for the contacts, or energy made where none should be
/// (a 0.1 m overlap released in two steps at FRACTION 0.2: 6 %).
pub const LEDGER_WARNING_FRACTION: f64 = 0.05;

/// What a CYCLE's look for initial overlaps depends on: a CYCLE after no change of blocks, corners
/// or ROUND does not look again (the contacts of the last run carry their force).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct ShapeMark {
    blocks: usize,
    corners: usize,
    next_block_id: u32,
    round: u64,
}

impl ShapeMark {
    pub(super) fn of(model: &Model) -> Self {
        ShapeMark { blocks: model.blocks.len(), corners: model.corners.len(), next_block_id: model.next_block_id, round: model.tol.round.to_bits() }
    }
}

/// A pair of blocks found overlapping before any motion (`initial_overlaps`).
#[derive(Clone, Debug)]
pub struct InitialOverlap {
    /// The blocks' ids, corner owner first (as PRINT CONTACTS gives them).
    pub blocks: [u32; 2],
    /// The largest overlap of its contacts, and where.
    pub overlap: f64,
    pub point: [f64; 2],
    /// Its contacts that start overlapping.
    pub contacts: usize,
    /// The strain energy their springs take at the first step, ½kn·δ² summed (J per metre).
    pub energy: f64,
    /// The lighter free block of the pair and the speed that energy would give it alone, √(2E/m).
    pub launched: u32,
    pub speed: f64,
}

/// The block pairs of `model` (its contacts just detected) that overlap before any motion: the
/// contacts that carry no force yet (new ones; a contact that has been through the force law
/// carries its overlap's force) and overlap by more than [`INITIAL_OVERLAP_TOLERANCE`] of the
/// rounding length and twice their blocks' weight and load over kn, counted once a touch (`Model::counts_force`), between blocks not both fixed.
/// Largest energy first.
pub fn initial_overlaps(model: &Model) -> Vec<InitialOverlap> {
    let tol = INITIAL_OVERLAP_TOLERANCE * model.tol.round;
    let mut pairs: Vec<InitialOverlap> = Vec::new();
    let mut index = std::collections::HashMap::new();
    for c in &model.contacts {
        let (b1, b2) = (&model.blocks[c.block1 as usize], &model.blocks[c.block2 as usize]);
        if c.normal_force != 0.0 || -c.gap <= tol || (b1.fixed && b2.fixed) || !model.counts_force(c) {
            continue;
        }
        let kn = model.material(c.material).contact.kn;
        let weight = [b1, b2]
            .into_iter()
            .filter(|b| !b.fixed)
            .map(|b| (b.mass * model.gravity[0] + b.load[0]).hypot(b.mass * model.gravity[1] + b.load[1]))
            .fold(0.0, f64::max);
        if kn > 0.0 && -c.gap <= 2.0 * weight / kn {
            continue;
        }
        let energy = 0.5 * kn * c.gap * c.gap;
        let key = (c.block1.min(c.block2), c.block1.max(c.block2));
        let k = *index.entry(key).or_insert_with(|| {
            let free = [b1, b2].into_iter().filter(|b| !b.fixed).min_by(|x, y| x.mass.total_cmp(&y.mass)).unwrap_or(b1);
            pairs.push(InitialOverlap { blocks: [b1.id, b2.id], overlap: 0.0, point: c.point, contacts: 0, energy: 0.0, launched: free.id, speed: 0.0 });
            pairs.len() - 1
        });
        let p = &mut pairs[k];
        p.contacts += 1;
        p.energy += energy;
        if -c.gap > p.overlap {
            p.overlap = -c.gap;
            p.point = c.point;
        }
    }
    for p in &mut pairs {
        let m = model.block_index(p.launched).map_or(0.0, |b| model.blocks[b].mass);
        p.speed = if m > 0.0 { (2.0 * p.energy / m).sqrt() } else { f64::NAN };
    }
    pairs.sort_by(|a, b| b.energy.total_cmp(&a.energy));
    pairs
}
