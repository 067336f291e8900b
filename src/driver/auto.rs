//! `--backend auto` on a GPU, for either engine: the GPU backend while the models fit it, the
//! CPU backend (f64) from the first run the GPU refuses before any cycle
//! ([`CycleError::DoesNotFit`]: a model past the adapter's limits, said once on stderr) to the
//! end of the deck. Each engine's backend trait (`udec::backend::Backend`,
//! `d3::backend::Backend`) is implemented for `GpuOrCpu<dyn ThatTrait>` in the engine's module,
//! passing its calls to [`GpuOrCpu::active`] and its runs through [`GpuOrCpu::run_with`].

use super::{CycleError, CycleReport};

/// The GPU backend, and the CPU backend once a run has gone to it. `B` is an engine's backend
/// trait object; the CPU backend comes from `make_cpu`, so that the engines' backend-trait
/// modules name no backend (no module cycle).
pub struct GpuOrCpu<B: ?Sized> {
    gpu: Box<B>,
    cpu: Option<Box<B>>,
    make_cpu: fn() -> Box<B>,
}

impl<B: ?Sized> GpuOrCpu<B> {
    /// `make_cpu` opens the CPU backend when the first run the GPU does not take comes.
    pub fn new(gpu: Box<B>, make_cpu: fn() -> Box<B>) -> Self {
        GpuOrCpu { gpu, cpu: None, make_cpu }
    }

    /// The backend the runs go to now.
    pub fn active(&self) -> &B {
        self.cpu.as_deref().unwrap_or(&*self.gpu)
    }

    /// [`GpuOrCpu::active`], to change.
    pub fn active_mut(&mut self) -> &mut B {
        match &mut self.cpu {
            Some(cpu) => cpu,
            None => &mut self.gpu,
        }
    }

    /// One run, `run` called on the backend that takes it, adding to `report`: the CPU once the
    /// runs have gone to it; otherwise the GPU, and where the GPU refuses the model before any
    /// cycle (the model is then as it was before the run), the CPU from then on, `report` as it
    /// was before the GPU's try (whose start may have counted a detection).
    pub fn run_with<M>(
        &mut self,
        model: &mut M,
        report: &mut CycleReport,
        mut run: impl FnMut(&mut B, &mut M, &mut CycleReport) -> Result<(), CycleError>,
    ) -> Result<(), CycleError> {
        if let Some(cpu) = &mut self.cpu {
            return run(&mut **cpu, model, report);
        }
        let before = report.clone();
        match run(&mut *self.gpu, model, report) {
            Err(CycleError::DoesNotFit(why)) => {
                use std::io::Write as _;
                let _ = writeln!(std::io::stderr(), "blockdem: {why}; --backend auto goes on on the CPU (f64)");
                *report = before;
                let cpu = self.cpu.insert((self.make_cpu)());
                run(&mut **cpu, model, report)
            }
            result => result,
        }
    }
}
