//! The `Backend` trait: what the command executor asks of whichever engine runs the cycle
//! (DESIGN.md §3). Both backends take the same `Model`, run N cycles and give the same observable
//! state back; the executor never knows which one ran.

use crate::model::Model;

/// What a run of cycles did besides moving blocks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CycleReport {
    pub cycles: u64,
    /// Contact updates (stage 7 runs) and the contacts they created and dropped.
    pub topology_updates: u64,
    pub contacts_created: u64,
    pub contacts_dropped: u64,
    /// Cracks formed: (block id cracked, criterion value, crack ends).
    pub cracks: Vec<CrackEvent>,
    /// Time step changes forced by new, lighter blocks (from cracking).
    pub timestep_changes: Vec<(u64, f64)>,
}

impl CycleReport {
    /// Adds the report of the run that followed this one (a CYCLE run in pieces).
    pub fn extend(&mut self, next: CycleReport) {
        self.cycles += next.cycles;
        self.topology_updates += next.topology_updates;
        self.contacts_created += next.contacts_created;
        self.contacts_dropped += next.contacts_dropped;
        self.cracks.extend(next.cracks);
        self.timestep_changes.extend(next.timestep_changes);
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrackEvent {
    pub cycle: u64,
    pub block: u32,
    pub new_block: u32,
    pub value: f64,
    pub from: [f64; 2],
    pub to: [f64; 2],
}

/// A numerical failure. When a backend returns one, the model it was given holds the last good
/// state (a checkpoint from before the failure), so it can still be printed and saved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CycleError {
    #[error(
        "contact overlap too great at cycle {cycle}: blocks {block1} and {block2} overlap by {overlap:.4e} near ({x:.4e}, {y:.4e}), \
         more than half the rounding length ({limit:.4e}); the blocks are being driven through each other — \
         lower FRACTION, the loads or velocities, or raise the contact stiffness or ROUND"
    )]
    Overlap { cycle: u64, block1: u32, block2: u32, overlap: f64, limit: f64, x: f64, y: f64 },
    #[error("non-finite value at cycle {cycle}: block {block} has {what}; the run diverged — lower FRACTION, or check the loads and material properties")]
    NonFinite { cycle: u64, block: u32, what: String },
    /// `budget` is the energy the model started the CYCLE with plus the work gravity and loads
    /// did since (the largest seen): negative where blocks rose against gravity, since the work
    /// of gravity is then negative; the check counts it as zero.
    #[error(
        "energy growing without a source at cycle {cycle}: kinetic + strain energy {} exceeds the energy put in, {} \
         (the energy at the start of the CYCLE plus the work of gravity and loads since{}); \
         the explicit integration is unstable — lower FRACTION (now {}{})",
        crate::output::format::fmt_e(*.energy),
        crate::output::format::fmt_e(f64::max(*.budget, 0.0)),
        negative_budget_note(*.budget),
        frac_text(*.frac),
        safe_frac_note(*.safe_frac)
    )]
    EnergyGrowth { cycle: u64, energy: f64, budget: f64, frac: f64, safe_frac: f64 },
    #[error(
        "block {block} moves too fast at cycle {cycle}: its corners travel {travel:.4e} in one step ({speed:.4e} per unit time), \
         more than the contact update can follow ({limit:.4e}, a quarter of the contact-forming distance); it could pass through a neighbour between contact updates — \
         lower FRACTION or raise ROUND"
    )]
    TooFast { cycle: u64, block: u32, travel: f64, limit: f64, speed: f64 },
    #[error("cannot cycle: {0}")]
    Setup(String),
    /// The model does not fit the backend (a GPU adapter's binding limit, a value outside the
    /// kernel precision's range); another may run it.
    #[error("cannot cycle: {0}")]
    DoesNotFit(String),
}

/// The largest safe FRACTION for an energy growth's message, where the last good state gives an
/// estimate (it has contacts carrying force; a state without them has no stiffness to estimate
/// from, and the growth came with contacts made after it).
pub(crate) fn safe_frac_note(safe_frac: f64) -> String {
    if safe_frac.is_finite() && safe_frac > 0.0 {
        format!("; the largest safe value is about {}", safe_frac_text(safe_frac))
    } else {
        String::new()
    }
}

/// Why the energy put in is counted as zero, where it is negative.
fn negative_budget_note(budget: f64) -> String {
    if budget < 0.0 {
        format!(", counted as zero: it is {} because the blocks moved against gravity and their loads", crate::output::format::fmt_e(budget))
    } else {
        String::new()
    }
}

/// A FRACTION for messages: as typed (`0.1`), or to four significant digits where it has more
/// (the FRACTIONs `blockdem verify` bisects: `0.6298`, not `0.6297873064661311`).
pub(crate) fn frac_text(frac: f64) -> String {
    let rounded = format!("{frac:.3e}").parse::<f64>().unwrap_or(frac);
    crate::output::format::fmt_short(rounded)
}

/// A safe FRACTION to two significant digits (a safe FRAC of 0.005 printed as 0.00 before).
pub(crate) fn safe_frac_text(safe_frac: f64) -> String {
    let digits = (1 - safe_frac.log10().floor() as i32).max(2) as usize;
    format!("{safe_frac:.digits$}")
}

impl CycleError {
    /// The failure of a cycle in which the step of block `b` (an index; the lowest such on every
    /// backend) was not finite: its work, force × displacement, overflowed, or its state did.
    pub fn non_finite_step(model: &Model, b: usize) -> CycleError {
        let block = &model.blocks[b.min(model.blocks.len().saturating_sub(1))];
        let state_finite = block.centroid.iter().chain(&block.velocity).all(|x| x.is_finite()) && block.angular_velocity.is_finite();
        let what = if state_finite { "a step whose work (force × displacement) is not finite" } else { "a non-finite position or velocity" };
        CycleError::NonFinite { cycle: model.cycle, block: block.id, what: what.into() }
    }

    /// The failure of a cycle in which contact `flagged` (an index) overlapped by more than
    /// `limit`: the message names the contact that overlaps most (ties: the lowest index, on every
    /// backend), not merely the first past the limit, so it does not understate how far the blocks
    /// went into each other.
    pub fn overlap(model: &Model, flagged: usize, limit: f64) -> CycleError {
        let mut worst = flagged.min(model.contacts.len().saturating_sub(1));
        for (k, c) in model.contacts.iter().enumerate() {
            if -c.gap > limit && -c.gap > -model.contacts[worst].gap {
                worst = k;
            }
        }
        let c = &model.contacts[worst];
        CycleError::Overlap {
            cycle: model.cycle,
            block1: model.blocks[c.block1 as usize].id,
            block2: model.blocks[c.block2 as usize].id,
            overlap: -c.gap,
            limit,
            x: c.point[0],
            y: c.point[1],
        }
    }
}

/// `--backend auto` on a GPU: the GPU backend while the models fit it, the CPU backend (f64)
/// from the first run whose model is past its limits (said once on stderr) to the end. The CPU
/// backend comes from `make_cpu`, so that this trait's layer names no backend (no module cycle).
pub struct GpuOrCpu {
    gpu: Box<dyn Backend>,
    cpu: Option<Box<dyn Backend>>,
    make_cpu: fn() -> Box<dyn Backend>,
}

impl GpuOrCpu {
    /// `make_cpu` opens the CPU backend when the first model past the GPU's limits comes.
    pub fn new(gpu: Box<dyn Backend>, make_cpu: fn() -> Box<dyn Backend>) -> Self {
        GpuOrCpu { gpu, cpu: None, make_cpu }
    }
}

impl Backend for GpuOrCpu {
    fn describe(&self) -> String {
        match &self.cpu {
            Some(cpu) => cpu.describe(),
            None => self.gpu.describe(),
        }
    }

    fn run(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool) -> Result<CycleReport, CycleError> {
        if let Some(cpu) = &mut self.cpu {
            return cpu.run(model, cycles, progress);
        }
        match self.gpu.run(model, cycles, progress) {
            // Refused before any cycle, the model at its state before the run.
            Err(CycleError::DoesNotFit(why)) => {
                use std::io::Write as _;
                let _ = writeln!(std::io::stderr(), "blockdem: {why}; --backend auto goes on on the CPU (f64)");
                self.cpu.insert((self.make_cpu)()).run(model, cycles, progress)
            }
            result => result,
        }
    }
}

pub trait Backend {
    /// A one-line description: backend, adapter, precision.
    fn describe(&self) -> String;

    /// Runs `cycles` cycles of the explicit scheme on `model`, calling `progress(done)` at each
    /// energy check (every `CHECK_INTERVAL` cycles) and at the end. `progress` returns whether to
    /// go on: `false` ends the run there, with the model at that cycle as after a run of that
    /// many cycles (`CycleReport::cycles` says how many ran; an interrupted run). `model.timestep`
    /// is set by the caller. On error the model is left at its last good state.
    fn run(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool) -> Result<CycleReport, CycleError>;
}
