//! The run driver: one run of CYCLE n, written once for both backends (issue 26, item 2).
//!
//! A backend supplies its stages through [`Stages`] (the CPU one cycle at a time, the GPU in
//! batches it sizes itself); the driver owns everything around them, in this order:
//!
//! 1. [`prepare`]: the time step is checked, the backend's own preconditions
//!    ([`Start::preflight`]), then the resume test — a model equal to the state the backend's
//!    last run left (no command changed it: CYCLE after CYCLE) goes on from there, bit for bit as
//!    one run; any other starts with a full contact detection ([`Start::start`]).
//! 2. [`cycles`]: the energy check's baseline, the scan for point-load cracking candidates
//!    (stage 7 then runs every cycle), the last good state, then the cycles in pieces up to the
//!    next check interval ([`CHECK_INTERVAL`]); at each check the energy test, the caller's
//!    progress (which may interrupt the run: as if the cycles asked were done), and the last good
//!    state kept ([`Stages::keep`]); at the end the state handed back ([`Stages::finish`]).
//! 3. On a failure (a numerical one raised by a stage, or the energy test), the backend restores
//!    its checkpoint ([`Stages::recover`]) and the model is rolled back to the last good state,
//!    the error naming the cause ([`EnergyCheck::roll_back`]).
//!
//! `prepare` and `cycles` are two calls because the CPU backend sizes its team of threads on the
//! model the full detection leaves, and runs the cycles inside that team's scope. `prepare` only
//! borrows what the backend keeps from run to run (its last good state, through
//! [`Start::take_resumable`]), so a run refused there leaves the backend as it was with nothing
//! to restore; a backend takes its last good state for `cycles` once `prepare` has passed.
//!
//! The driver sits below the backends (they call it from `Backend::run_into`) and below the engines:
//! it knows the stages' contract and what it asks of a model ([`RunModel`]: the cycle, the time
//! step, the energy terms), not how a stage runs nor what a block is. The 2D engine's model
//! implements [`RunModel`] in `udec::backend`.

pub mod auto;
pub mod report;
pub mod run;

pub use report::{CrackEvent, CycleError, CycleReport, Position};

/// What the driver asks of an engine's model: the clock, the energy terms of the check (eq. 9's
/// kinetic and strain energy and the work of the loads), and the engine's knowledge of what
/// the check's baseline and scale are. `Clone` and `PartialEq`: the last good state is a copy,
/// and a model equal to the one the last run left resumes that run.
pub trait RunModel: Clone + PartialEq + Default {
    /// The cycle count.
    fn cycle(&self) -> u64;
    /// The time step Δt the run will take.
    fn timestep(&self) -> f64;
    /// FRACTION, the share of the critical time step taken (for the error messages).
    fn frac(&self) -> f64;
    /// Kinetic + strain energy and the external work done since the start, of the state now.
    fn energy_terms(&self) -> (f64, f64);
    /// At the start of a CYCLE run, once contacts are detected: the energy put in so far
    /// (kinetic + strain energy, the strain stored in contacts that start overlapping counted,
    /// less the external work done), and the energy scale of the check's floor (the work of each
    /// block's weight and load over its own size).
    fn energy_baseline(&self) -> (f64, f64);
    /// The largest FRACTION the model's contact network allows, estimated (for an energy growth's
    /// message); NaN where it has no contact to estimate from.
    fn stable_frac_estimate(&self) -> f64;
    /// Whether any block may crack during the run (stage 7 then runs every cycle).
    fn has_crack_candidates(&self) -> bool;
}

/// Cycles between energy checks and checkpoints of the last good state.
pub const CHECK_INTERVAL: u64 = 100;

/// Energy may exceed what was put in by this factor (plus a floor) before the run is declared
/// unstable: an unstable explicit scheme grows exponentially, far past any such margin, while a
/// stable one stays within O(Δt) of its budget.
const ENERGY_GROWTH_FACTOR: f64 = 2.0;

/// What a backend does to begin a run (step 1, [`prepare`]).
pub trait Start<M: RunModel> {
    /// The state the last run left, when it is still the backend's to go on from (that run
    /// ended well and the backend holds it): its last good state. Taken (reset) by the call.
    fn take_resumable(&mut self) -> Option<&M>;

    /// The backend's own preconditions on the model, after the time step's.
    fn preflight(&mut self, _model: &M) -> Result<(), CycleError> {
        Ok(())
    }

    /// Readies the run: with `resume`, goes on from the state the last run left; otherwise a full
    /// contact detection (stage 7) and whatever the backend needs of it (the GPU's upload).
    fn start(&mut self, model: &mut M, resume: bool, report: &mut CycleReport) -> Result<(), CycleError>;
}

/// What a backend does within a run's cycles (step 2, [`cycles`]), in the order of the module
/// doc.
pub trait Stages<M: RunModel> {
    /// Before the first cycle, once the backend's workers are up: the force sums the first step
    /// and the energy check's baseline need.
    fn begin_cycles(&mut self, _model: &mut M) -> Result<(), CycleError> {
        Ok(())
    }

    /// Runs at least one and at most `max` cycles, stage 7 between them as due (every cycle
    /// with `cracking`); returns how many ran. The model's cycle count and time move with them.
    fn advance(&mut self, model: &mut M, max: u64, cracking: bool, report: &mut CycleReport) -> Result<u64, CycleError>;

    /// Kinetic + strain energy and the external work done, of the state now (eq. 9's terms,
    /// `Model::energies`), for the energy check.
    fn energy(&mut self, model: &mut M) -> Result<(f64, f64), CycleError>;

    /// After a failed energy test: the state the test saw brought into the model.
    fn sync(&mut self, _model: &mut M) -> Result<(), CycleError> {
        Ok(())
    }

    /// After a passed check with cycles to go: keeps the state as the last good one.
    fn keep(&mut self, model: &M, last_good: &mut M);

    /// The run's end (its last check, or an interruption): the state handed back to the model.
    fn finish(&mut self, _model: &mut M) -> Result<(), CycleError> {
        Ok(())
    }

    /// A failure: the last good state made whole where the backend kept part of it itself (the
    /// GPU's device checkpoint), before the model is rolled back to it.
    fn recover(&mut self, _last_good: &mut M) -> Result<(), CycleError> {
        Ok(())
    }
}

/// Step 1 of a run: the checks, the resume test and the start. Returns whether the run resumes.
pub fn prepare<M: RunModel, S: Start<M> + ?Sized>(stages: &mut S, model: &mut M, report: &mut CycleReport) -> Result<bool, CycleError> {
    if model.timestep() <= 0.0 || !model.timestep().is_finite() {
        return Err(CycleError::Setup("the time step is not set".into()));
    }
    stages.preflight(model)?;
    let resume = stages.take_resumable().is_some_and(|last| *model == *last);
    stages.start(model, resume, report)?;
    Ok(resume)
}

/// Step 2 of a run: `cycles` cycles with the checks, progress and roll-back of the module doc.
/// `last_good` is the last good state (the model itself when resuming); on success it holds the
/// final state, on a failure the model holds the last good state and `last_good` is left empty.
pub fn cycles<M: RunModel, S: Stages<M> + ?Sized>(
    stages: &mut S,
    model: &mut M,
    cycles: u64,
    resume: bool,
    last_good: &mut M,
    report: &mut CycleReport,
    progress: &mut dyn FnMut(u64) -> bool,
) -> Result<(), CycleError> {
    stages.begin_cycles(model)?;
    let mut energy_check = EnergyCheck::new(model);
    let cracking = model.has_crack_candidates();
    if !resume {
        // (When resuming it is the model already.)
        last_good.clone_from(model);
    }
    crate::profile::mark_cycles_start();
    let result = (|| -> Result<(), CycleError> {
        let mut done = 0u64;
        while done < cycles {
            let max = (CHECK_INTERVAL - done % CHECK_INTERVAL).min(cycles - done);
            let ran = stages.advance(model, max, cracking, report)?;
            done += ran;
            report.cycles += ran;
            if done % CHECK_INTERVAL == 0 || done == cycles {
                let (energy, external_work) = stages.energy(model)?;
                if let Err(e) = energy_check.check_sums(model.cycle(), energy, external_work, model.frac()) {
                    stages.sync(model)?;
                    return Err(e);
                }
                // The caller may end the run here (an interrupt): as if `cycles` were done.
                let go_on = progress(done) && done < cycles;
                if !go_on {
                    // What is left is the hand-back: the state back in the model and the copy
                    // the next run resumes from, charged to the run's tear-down.
                    crate::profile::mark_cycles_end();
                    stages.finish(model)?;
                    last_good.clone_from(model);
                    break;
                }
                stages.keep(model, last_good);
            }
        }
        Ok(())
    })();
    match result {
        Ok(()) => Ok(()),
        Err(e) => {
            stages.recover(last_good)?;
            let e = energy_check.roll_back(e, model, std::mem::take(last_good));
            // The report keeps what the state it went back to holds: the cracks and smaller
            // steps after it are undone (a crack at the last good cycle is in its state).
            let at = model.cycle();
            report.cracks.retain(|c| c.cycle <= at);
            report.timestep_changes.retain(|&(c, _)| c <= at);
            Err(e)
        }
    }
}

/// The energy check: kinetic + strain energy may not outgrow the energy put in. The budget is the
/// largest seen so far (`peak`): in a stable run that rings (a block dropped onto its contacts)
/// the budget falls to ~0 at each rebound apex while the half-step kinetic energy and the
/// shadow-energy error of central differences do not, which is no instability; an unstable run
/// grows exponentially past any such margin.
pub struct EnergyCheck {
    baseline: f64,
    scale: f64,
    peak: f64,
}

impl EnergyCheck {
    /// Taken at the start of a CYCLE run, once contacts are detected and their gaps known.
    pub fn new<M: RunModel>(model: &M) -> Self {
        let (baseline, scale) = model.energy_baseline();
        EnergyCheck { baseline, scale, peak: f64::NEG_INFINITY }
    }

    /// After a failure: names the cause (a block flying off may be the symptom of an unstable
    /// step) and puts the last good state back in `model`.
    pub fn roll_back<M: RunModel>(&mut self, mut e: CycleError, model: &mut M, last_good: M) -> CycleError {
        if let CycleError::TooFast { cycle, .. } = e {
            if let Err(mut energy) = self.check(model) {
                // At the too-fast block's cycle: the model may have stopped inside it (D3's
                // check comes before its cycle count steps), which read as "at cycle 0" for a
                // failure in the first step.
                if let CycleError::EnergyGrowth { cycle: at, .. } = &mut energy {
                    *at = cycle;
                }
                e = energy;
            }
        }
        // The stable-FRAC estimate needs the contact network of the last good state (the
        // diverged one may have flung its blocks apart).
        if let CycleError::EnergyGrowth { safe_frac, .. } = &mut e {
            *safe_frac = last_good.stable_frac_estimate();
        }
        *model = last_good;
        e
    }

    /// The check on the model's own energy terms.
    pub fn check<M: RunModel>(&mut self, model: &M) -> Result<(), CycleError> {
        let (energy, external_work) = model.energy_terms();
        self.check_sums(model.cycle(), energy, external_work, model.frac())
    }

    /// The check on sums taken by a backend (the CPU's `Model::energies`, the GPU's
    /// `energy_sums`): kinetic + strain energy against the external work done since the start.
    /// The largest safe FRAC in the error is filled in by `roll_back`, from the last good state's
    /// contact network.
    pub fn check_sums(&mut self, cycle: u64, energy: f64, external_work: f64, frac: f64) -> Result<(), CycleError> {
        self.peak = self.peak.max(self.baseline + external_work);
        let budget = self.peak;
        if !energy.is_finite() || energy > ENERGY_GROWTH_FACTOR * budget.max(0.0) + 1e-6 * self.scale {
            return Err(CycleError::EnergyGrowth { cycle, energy, budget, frac, safe_frac: f64::NAN });
        }
        Ok(())
    }
}
