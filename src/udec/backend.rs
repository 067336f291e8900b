//! The `Backend` trait: what the command executor asks of whichever engine runs the cycle
//! (DESIGN.md §3). Both backends take the same `Model`, run N cycles and give the same observable
//! state back; the executor never knows which one ran.

use crate::udec::model::Model;

pub(crate) use crate::driver::report::{frac_text, safe_frac_text};
pub use crate::driver::report::{CrackEvent, CycleError, CycleReport};

/// The 2D model as the run driver sees it (`driver::RunModel`).
impl crate::driver::RunModel for Model {
    fn cycle(&self) -> u64 {
        self.cycle
    }

    fn timestep(&self) -> f64 {
        self.timestep
    }

    fn frac(&self) -> f64 {
        self.frac
    }

    /// The work put in counts the fluid's, as both backends' energy sums do (the CPU's
    /// `Model::energies`, the GPU's `energy_sums`).
    fn energy_terms(&self) -> (f64, f64) {
        let e = self.energies();
        (e.kinetic + e.strain, e.external_work + e.fluid_work)
    }

    fn energy_baseline(&self) -> (f64, f64) {
        let e0 = self.energies();
        // Contacts that start overlapping (blocks built into each other, the stage not yet run)
        // hold strain energy the first force computation will release: it is energy put in.
        let overlap_strain: f64 = self.contacts.iter().map(|c| 0.5 * self.material(c.material).contact.kn * c.gap.min(0.0).powi(2)).sum();
        // The work put in before this run (gravity's and loads', and the fluid's) is taken off:
        // the budget is the work done since.
        let baseline = e0.kinetic + e0.strain.max(overlap_strain) - e0.external_work - e0.fluid_work;
        // Energy scale for the floor of the growth test: potential energy of each block's weight
        // and load over its own size.
        let g = (self.gravity[0].powi(2) + self.gravity[1].powi(2)).sqrt();
        // With no gravity, load or motion to drive it, that scale is zero, and the round-off
        // energy of touching blocks (1e-21 J) failed the check; so each block also counts the
        // strain energy of its contacts at an overlap of 1e-3 of its size, a floor of 1e-6 of
        // that (an overlap of ~1e-6 of the size at the stiffest contact).
        let kn = self.materials.iter().map(|m| m.contact.kn).fold(0.0, f64::max);
        let scale = self.blocks.iter().map(|b| (b.mass * g + b.load[0].hypot(b.load[1])) * b.radius + kn * (1e-3 * b.radius).powi(2)).sum::<f64>()
            + (e0.kinetic + e0.strain).abs();
        (baseline, scale)
    }

    fn stable_frac_estimate(&self) -> f64 {
        Model::stable_frac_estimate(self)
    }

    fn has_crack_candidates(&self) -> bool {
        (0..self.blocks.len()).any(|b| crate::udec::topology::cracking::is_crack_candidate(self, b))
    }
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

    /// The failure of a model with a non-finite domain pressure
    /// (`model::fluid::non_finite_pressure`), named by the domain and a block beside it; None
    /// where every pressure is finite. The CPU's energy check asks it, and the executor after a
    /// GPU run.
    pub fn non_finite_pressure(model: &Model) -> Option<CycleError> {
        let (domain, block) = crate::udec::model::fluid::non_finite_pressure(model)?;
        let what = format!("a non-finite fluid pressure in domain {domain} beside it (check CPERM, JPERM and AZERO against the fluid's bulk modulus, FLUID)");
        Some(CycleError::NonFinite { cycle: model.cycle, block, what })
    }

    /// The failure of a cycle in which the fluid's work (pressure × change of a domain's volume,
    /// `cpu::flow::fluid_work`) was not finite, named by the domain of the largest pressure and a
    /// block beside it: a pressure whose push on the blocks overflows their energies (PFIX 1E300),
    /// not an unstable step, so not an "energy growing" whose cure would be a lower FRACTION.
    pub fn non_finite_fluid_work(model: &Model) -> CycleError {
        let (domain, pressure, block) = crate::udec::model::fluid::largest_pressure(model).unwrap_or((0, f64::NAN, model.blocks.first().map_or(0, |b| b.id)));
        let what = format!(
            "a step whose fluid work (pressure × change of volume) is not finite, under the pressure {pressure:e} of domain {domain} beside it \
             (check PFIX, FLUID and the units)"
        );
        CycleError::NonFinite { cycle: model.cycle, block, what }
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
            at: Box::new(crate::driver::report::Position::xy(c.point)),
        }
    }
}

/// `--backend auto` on a GPU: the GPU backend while the models fit it, the CPU backend (f64)
/// from the first run whose model is past its limits to the end (`driver::auto`).
pub type GpuOrCpu = crate::driver::auto::GpuOrCpu<dyn Backend>;

impl Backend for GpuOrCpu {
    fn describe(&self) -> String {
        self.active().describe()
    }

    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        self.run_with(model, report, |backend, model, report| backend.run_into(model, cycles, progress, report))
    }
}

pub trait Backend {
    /// A one-line description: backend, adapter, precision.
    fn describe(&self) -> String;

    /// Runs `cycles` cycles of the explicit scheme on `model`, calling `progress(done)` at each
    /// energy check (every `CHECK_INTERVAL` cycles) and at the end. `progress` returns whether to
    /// go on: `false` ends the run there, with the model at that cycle as after a run of that
    /// many cycles (`CycleReport::cycles` says how many ran; an interrupted run). `model.timestep`
    /// is set by the caller. On error the model is left at its last good state, and `report`
    /// holds what the run did up to it (the cracks the state holds, for the log).
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError>;
    /// [`Backend::run_into`] into a report of its own.
    fn run(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool) -> Result<CycleReport, CycleError> {
        let mut report = CycleReport::default();
        self.run_into(model, cycles, progress, &mut report)?;
        Ok(report)
    }
}
