//! What D3's executor asks of a backend (the CPU's, `d3::cpu`, or the GPU's, `d3::gpu`): runs of
//! cycles through the chassis's run driver, and the state the last run left, to resume from.

use super::model::Model;
use super::restart::DeviceState;
use crate::driver::{CycleError, CycleReport};

pub trait Backend {
    /// Runs `cycles` cycles of `model`, what it does added to `report`. `progress` is told the
    /// cycles done at each check and may end the run there (false). On error the model is left
    /// at its last good state, and `report` holds what the run did up to it (the cracks the
    /// state holds, for the log).
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError>;
    /// [`Backend::run_into`] into a report of its own.
    fn run(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool) -> Result<CycleReport, CycleError> {
        let mut report = CycleReport::default();
        self.run_into(model, cycles, progress, &mut report)?;
        Ok(report)
    }
    /// Whether the backend would go on from `model` as the state its last run left (SAVE
    /// records it, `d3::restart`).
    fn resumes_from(&self, model: &Model) -> bool;
    /// What the backend holds beyond the model to go on from it (the GPU's device state, read
    /// back; None on the CPU, whose model is the whole state, or where the read-back failed: a
    /// RESTART then detects afresh). Asked by SAVE where [`Backend::resumes_from`] the model.
    fn device_state(&self) -> Option<DeviceState> {
        None
    }
    /// Takes `model` as the state its last run left (RESTART of a state saved as resumable),
    /// with the device state saved with it, if any.
    fn resume_from(&mut self, model: &Model, device: Option<&DeviceState>);
    /// Forgets the state its last run left (RESTART of a state not saved as resumable).
    fn forget(&mut self);
    /// The backend in words, e.g. `cpu (f64)`.
    fn describe(&self) -> String;
}

/// `--backend auto`'s D3 backend where a GPU was found (`driver::auto`, as 2D's): the GPU,
/// until a run comes that it does not take, a model past its limits (`CycleError::DoesNotFit`,
/// refused before any cycle; a concave block's convex parts run on the GPU as on the CPU,
/// `d3::gpu`); that run and every later one go to the CPU backend, which starts from the model
/// as it is (a full contact detection).
pub type GpuOrCpu = crate::driver::auto::GpuOrCpu<dyn Backend>;

impl Backend for GpuOrCpu {
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        self.run_with(model, report, |backend, model, report| backend.run_into(model, cycles, progress, report))
    }

    fn resumes_from(&self, model: &Model) -> bool {
        self.active().resumes_from(model)
    }

    fn device_state(&self) -> Option<DeviceState> {
        self.active().device_state()
    }

    fn resume_from(&mut self, model: &Model, device: Option<&DeviceState>) {
        self.active_mut().resume_from(model, device)
    }

    fn forget(&mut self) {
        self.active_mut().forget()
    }

    fn describe(&self) -> String {
        self.active().describe()
    }
}
