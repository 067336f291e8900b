//! Where a run's wall time goes, stage by stage, for `blockdem bench`: a per-thread self-time
//! profiler behind a switch that costs one thread-local read per stage when it is off.
//!
//! The backends open a [`scope`] around each stage they run on the host (the CPU backend's stages
//! 1+2, 4 and 6; stage 7 on either backend; the GPU backend's batches, uploads and read-backs). A
//! scope's time is its *self* time: a stage nested in another (the adjacency rebuild inside a
//! contact update, a read-back inside a stage-7 pass) is charged to the inner stage only, so the
//! stages of a run add up to at most its wall time and never count a second twice.
//!
//! Times are split in phases at [`mark_cycles_start`], which each backend calls once its run has
//! set up (the full contact detection every run starts with, the upload to the GPU), and at
//! [`mark_cycles_end`], which the GPU backend calls before its final read-back: what a CYCLE
//! command costs once, and what each of its cycles costs.
//!
//! Off (the default), [`scope`] returns an inert guard and nothing is timed. The profiler is per
//! thread because a backend's `run` drives its stages from the calling thread (rayon workers run
//! inside a stage), and so that tests on parallel threads do not mix their figures.

use std::cell::RefCell;
use std::time::{Duration, Instant};

/// A host-side stage of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// CPU backend, the block pass: stage 6 of the previous cycle (the gather), stages 1 and 2
    /// (law of motion, geometry update), fused, block by block.
    MotionGeometry,
    /// CPU backend, stage 4: contact kinematics and the force–displacement law.
    ContactForces,
    /// CPU backend, stage 6 on its own: each block sums its contact forces where the block forces
    /// are read between cycles (energy check, topology changes, the end of a run).
    Gather,
    /// Stage 7, the full contact detection each run starts with (and its adjacency lists).
    DetectFull,
    /// Stage 7, contact updates after blocks moved past the update tolerance (and adjacency).
    DetectUpdate,
    /// Stage 7, point-load cracking checks and splits.
    Cracking,
    /// The energy check and the checkpoint of the last good state (every 100 cycles).
    Checks,
    /// GPU backend: encoding, submitting and waiting for batches of cycles (the kernels' time).
    GpuBatches,
    /// GPU backend: host → device writes (whole model, contacts and adjacency, reset distances).
    Upload,
    /// GPU backend: device → host read-backs and their conversion into the `Model`.
    Download,
    /// GPU backend: building the kernels of a block kind or of the fluid the first time a scene
    /// has it (the simply- and fully-deformable and the fluid kernels, made on demand: a rigid,
    /// dry scene never builds them).
    /// Once per backend, in the set-up of the run that needs them.
    KernelBuild,
}

impl Stage {
    pub const ALL: [Stage; 11] = [
        Stage::MotionGeometry,
        Stage::ContactForces,
        Stage::Gather,
        Stage::DetectFull,
        Stage::DetectUpdate,
        Stage::Cracking,
        Stage::Checks,
        Stage::GpuBatches,
        Stage::Upload,
        Stage::Download,
        Stage::KernelBuild,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::MotionGeometry => "gather+motion+geometry (6,1,2)",
            Stage::ContactForces => "contact forces (4)",
            Stage::Gather => "gather alone (6)",
            Stage::DetectFull => "detection, start of run (7)",
            Stage::DetectUpdate => "contact updates (7)",
            Stage::Cracking => "cracking (7)",
            Stage::Checks => "energy check + checkpoint",
            Stage::GpuBatches => "GPU batches (submit+wait)",
            Stage::Upload => "upload host->device",
            Stage::Download => "read-back device->host",
            Stage::KernelBuild => "kernel build (once)",
        }
    }

    /// The accounting group: "cycle" (the explicit cycle itself), "topology" (CPU topology work),
    /// "transfer" (host ↔ device), "check" or "setup" (a backend's one-off kernel build).
    pub fn group(self) -> &'static str {
        match self {
            Stage::MotionGeometry | Stage::ContactForces | Stage::Gather | Stage::GpuBatches => "cycle",
            Stage::DetectFull | Stage::DetectUpdate | Stage::Cracking => "topology",
            Stage::Upload | Stage::Download => "transfer",
            Stage::Checks => "check",
            Stage::KernelBuild => "setup",
        }
    }

    fn index(self) -> usize {
        Stage::ALL.iter().position(|&s| s == self).unwrap_or(0)
    }
}

const N: usize = Stage::ALL.len();

/// Self times of each stage in the two phases of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Before [`mark_cycles_start`]: the set-up of a run.
    pub setup: [Duration; N],
    /// After it: the cycles.
    pub cycles: [Duration; N],
    /// After [`mark_cycles_end`]: what a run does once its cycles are done (the GPU backend's
    /// final read-back of the state).
    pub teardown: [Duration; N],
    /// When the last run marked the start of its cycles.
    pub cycles_start: Option<Instant>,
    /// When the last run marked the end of its cycles (None: it ended with them).
    pub cycles_end: Option<Instant>,
}

impl StageTimes {
    pub fn setup_of(&self, s: Stage) -> Duration {
        self.setup[s.index()]
    }
    pub fn cycles_of(&self, s: Stage) -> Duration {
        self.cycles[s.index()]
    }
    pub fn teardown_of(&self, s: Stage) -> Duration {
        self.teardown[s.index()]
    }
}

struct Profiler {
    times: StageTimes,
    phase: usize,
    /// Open scopes, innermost last, each with the instant its self time last resumed.
    stack: Vec<(Stage, Instant)>,
}

impl Profiler {
    fn charge(&mut self, stage: Stage, d: Duration) {
        let slot = match self.phase {
            0 => &mut self.times.setup,
            1 => &mut self.times.cycles,
            _ => &mut self.times.teardown,
        };
        slot[stage.index()] += d;
    }
}

thread_local! {
    static PROFILE: RefCell<Option<Profiler>> = const { RefCell::new(None) };
}

/// Starts profiling this thread (clearing earlier figures).
pub fn enable() {
    PROFILE.with(|p| *p.borrow_mut() = Some(Profiler { times: StageTimes::default(), phase: 0, stack: Vec::new() }));
}

/// Stops profiling this thread and returns what was measured since [`enable`].
pub fn take() -> StageTimes {
    PROFILE.with(|p| p.borrow_mut().take().map(|p| p.times).unwrap_or_default())
}

/// Whether this thread is profiling.
pub fn enabled() -> bool {
    PROFILE.with(|p| p.borrow().is_some())
}

/// Called by a backend once its run is set up: later time is charged to the cycles.
pub fn mark_cycles_start() {
    mark_phase(1, |t, now| t.cycles_start = Some(now));
}

/// Called by a backend when its last cycle is done and only the hand-back of the state is left:
/// later time is charged to the tear-down.
pub fn mark_cycles_end() {
    mark_phase(2, |t, now| t.cycles_end = Some(now));
}

/// Charges the open scope up to now to the current phase, then moves to `phase`.
fn mark_phase(phase: usize, record: impl FnOnce(&mut StageTimes, Instant)) {
    PROFILE.with(|p| {
        if let Some(p) = p.borrow_mut().as_mut() {
            let now = Instant::now();
            if let Some(&(stage, since)) = p.stack.last() {
                p.charge(stage, now - since);
                p.stack.last_mut().expect("non-empty").1 = now;
            }
            p.phase = phase;
            record(&mut p.times, now);
        }
    });
}

/// Times `stage` until the guard drops (self time: nested scopes pause it).
#[must_use = "the stage is timed until the guard drops"]
pub fn scope(stage: Stage) -> Scope {
    let active = PROFILE.with(|p| match p.borrow_mut().as_mut() {
        Some(p) => {
            let now = Instant::now();
            if let Some(&(outer, since)) = p.stack.last() {
                p.charge(outer, now - since);
            }
            p.stack.push((stage, now));
            true
        }
        None => false,
    });
    Scope { active }
}

/// Guard of [`scope`].
pub struct Scope {
    active: bool,
}

impl Drop for Scope {
    fn drop(&mut self) {
        if !self.active {
            return;
        }
        PROFILE.with(|p| {
            if let Some(p) = p.borrow_mut().as_mut() {
                let now = Instant::now();
                if let Some((stage, since)) = p.stack.pop() {
                    p.charge(stage, now - since);
                }
                if let Some(outer) = p.stack.last_mut() {
                    outer.1 = now;
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nested_scopes_charge_self_time_and_phases_split() {
        assert!(!enabled());
        {
            let _off = scope(Stage::Gather);
        }
        enable();
        {
            let _outer = scope(Stage::DetectFull);
            std::thread::sleep(Duration::from_millis(20));
            {
                let _inner = scope(Stage::Upload);
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        mark_cycles_start();
        {
            let _c = scope(Stage::Gather);
            std::thread::sleep(Duration::from_millis(10));
        }
        let t = take();
        assert!(!enabled());
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        assert!((20.0..35.0).contains(&ms(t.setup_of(Stage::DetectFull))), "{t:?}");
        assert!((20.0..35.0).contains(&ms(t.setup_of(Stage::Upload))), "{t:?}");
        assert!((10.0..25.0).contains(&ms(t.cycles_of(Stage::Gather))), "{t:?}");
        assert_eq!(t.cycles_of(Stage::DetectFull), Duration::ZERO);
        assert!(t.cycles_start.is_some());
    }
}
