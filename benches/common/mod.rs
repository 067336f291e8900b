//! What the criterion benches share: the walls of `blockdem bench`'s scaling family (25 rows of
//! 1 × 0.5 m bricks in running bond on a fixed ground block, struck by the reference projectile at
//! the left end, `blockdem::bench::scene::scaling_body`) at about 10³ and 10⁴ blocks, and the
//! figures `blockdem bench` reports for them, each as criterion groups:
//!
//! - `<backend>/wall_<blocks>`: block-cycles/s and contact-cycles/s ("elements/s"), and the bytes
//!   the cycle must move by the bench's byte model (`bytes-per-cycle`, "bytes/s") next to the
//!   backend's bandwidth yardstick (`copy`: a memcpy on the host; on a GPU the faster of the
//!   streaming copy kernel and `copy_buffer_to_buffer`, as `blockdem bench` takes it): their
//!   ratio is the roofline ratio.
//! - `<backend>/wall_<blocks>/stages`: the time per iteration of each host stage that takes at
//!   least `MIN_SHARE` of the cycles (the stage profiler, `blockdem::profile`, as the bench reads
//!   it), the CPU topology work and host ↔ device transfers together (`topology+transfers`; over
//!   the `block-cycles` time, the bench's share), and on a GPU each kernel (pass timestamps).
//!
//! An iteration is `CYCLES` cycles of a run that goes on from the wall settled on that backend,
//! timed as the bench times its rounds (`blockdem::bench::timed_run`): the cycles alone, not the
//! run's set-up (full detection, upload) or final read-back.

use std::time::Duration;

use criterion::{Criterion, SamplingMode, Throughput};

use blockdem::bench::scene::{scaling_body, FRAC};
use blockdem::bench::{timed_run, Timed, SETTLE_CYCLES};
use blockdem::profile::Stage;
use blockdem::scenes::run_deck_on;
use blockdem::udec::backend::Backend;
use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::model::Model;

/// Cycles of one iteration.
pub const CYCLES: u64 = 50;

/// Iterations of the calibration run.
const CALIBRATION_ITERS: u64 = 4;

/// Nominal wall sizes (blocks).
pub const SIZES: [usize; 2] = [1_000, 10_000];

/// A stage taking less of the cycles than this is not benched on its own.
const MIN_SHARE: f64 = 0.01;

/// Iterations of each sample of a stage. Criterion sizes its samples by the time an iteration
/// reports, which for a stage is its part of the iteration's run: so a stage's samples are flat,
/// of this many iterations each, their measurement time set from the calibration's figure.
const STAGE_ITERS: f64 = 3.0;

/// The wall of about `n` blocks as the deck builds it (no cycle run).
pub fn wall(n: usize) -> Model {
    let deck = scaling_body(n, FRAC) + "CYCLE 0\n";
    run_deck_on(&deck, Box::new(CpuBackend::new())).expect("the wall builds")
}

/// A backend as the benches measure it.
pub trait Measured {
    fn backend(&mut self) -> &mut dyn Backend;
    /// The bytes a cycle must move by the bench's byte model.
    fn bytes_per_cycle(&self, model: &Model) -> u64;
    /// Copy bandwidth, bytes read + written per second, measured now.
    fn copy_bandwidth(&mut self) -> f64;
    /// Kernel times (seconds per cycle) on the state the last run left, over `cycles` cycles;
    /// none on the CPU.
    fn kernels(&mut self, cycles: u32) -> Vec<(&'static str, f64)>;
}

impl Measured for CpuBackend {
    fn backend(&mut self) -> &mut dyn Backend {
        self
    }
    fn bytes_per_cycle(&self, m: &Model) -> u64 {
        blockdem::bench::host::cpu_bytes_per_cycle(m.blocks.len(), m.corners.len(), m.contacts.len()).iter().map(|b| b.read + b.written).sum()
    }
    fn copy_bandwidth(&mut self) -> f64 {
        blockdem::bench::host::host_copy_bandwidth()
    }
    fn kernels(&mut self, _cycles: u32) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
}

impl Measured for blockdem::udec::gpu::GpuBackend {
    fn backend(&mut self) -> &mut dyn Backend {
        self
    }
    fn bytes_per_cycle(&self, m: &Model) -> u64 {
        blockdem::udec::gpu::GpuBackend::bytes_per_cycle(self, m.blocks.len(), m.corners.len(), m.contacts.len(), m.materials.len())
            .iter()
            .map(|b| b.read + b.written)
            .sum()
    }
    /// The bench's yardstick (`blockdem::gpu::stream::yardstick`) of the streaming copy kernel,
    /// measured once per adapter and precision (it takes a second), and `copy_buffer_to_buffer`,
    /// measured now.
    fn copy_bandwidth(&mut self) -> f64 {
        use std::collections::HashMap;
        use std::sync::{Mutex, OnceLock};
        static STREAM: OnceLock<Mutex<HashMap<String, f64>>> = OnceLock::new();
        let key = blockdem::udec::backend::Backend::describe(self);
        let stream = *STREAM
            .get_or_init(Default::default)
            .lock()
            .expect("the yardstick's cache")
            .entry(key)
            .or_insert_with(|| self.stream_bandwidth().map(|s| s.best).unwrap_or(0.0));
        let copy = blockdem::udec::gpu::GpuBackend::copy_bandwidth(self).expect("the adapter copies");
        blockdem::gpu::stream::yardstick(Some(stream), Some(copy)).expect("a bandwidth was measured").0
    }
    fn kernels(&mut self, cycles: u32) -> Vec<(&'static str, f64)> {
        self.profile_stages(cycles).expect("the kernels are timed").stages
    }
}

/// A part of a run's cycles that is benched on its own.
#[derive(Clone, Copy)]
enum Part {
    /// A host stage's self time.
    Stage(Stage),
    /// CPU topology work and host ↔ device transfers together.
    TopologyAndTransfers,
}

impl Part {
    fn name(self) -> &'static str {
        match self {
            Part::Stage(s) => s.name(),
            Part::TopologyAndTransfers => "topology+transfers",
        }
    }

    /// Its seconds in the cycles of a timed run.
    fn of(self, t: &Timed) -> f64 {
        match self {
            Part::Stage(s) => t.times.cycles_of(s).as_secs_f64(),
            Part::TopologyAndTransfers => t.topology_and_transfers_s(),
        }
    }
}

/// `iters` iterations from the settled wall: a run of `iters` × `CYCLES` cycles.
fn sample(backend: &mut dyn Backend, settled: &Model, iters: u64) -> Timed {
    let mut model = settled.clone();
    timed_run(backend, &mut model, iters * CYCLES).expect("the wall runs")
}

fn seconds(s: f64) -> Duration {
    Duration::from_secs_f64(s.max(0.0))
}

/// Every group of the module doc for one backend (`label`, e.g. `cpu_f64`) and wall.
pub fn cover(c: &mut Criterion, label: &str, measured: &mut dyn Measured, wall: &Model) {
    let mut settled = wall.clone();
    measured.backend().run(&mut settled, SETTLE_CYCLES, &mut |_| true).expect("the wall settles");
    let (nb, nc) = (settled.blocks.len() as u64, settled.contacts.len() as u64);
    let bytes = measured.bytes_per_cycle(&settled);
    // One calibration sample: which stages take a share worth a bench of their own.
    let calibration = sample(measured.backend(), &settled, CALIBRATION_ITERS);
    let steady = calibration.steady_s.max(1e-9);

    let mut group = c.benchmark_group(format!("{label}/wall_{nb}"));
    group.sampling_mode(SamplingMode::Flat).sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
    for (name, throughput) in [
        ("block-cycles", Throughput::Elements(nb * CYCLES)),
        ("contact-cycles", Throughput::Elements(nc * CYCLES)),
        ("bytes-per-cycle", Throughput::Bytes(bytes * CYCLES)),
    ] {
        group.throughput(throughput);
        group.bench_function(name, |b| b.iter_custom(|iters| seconds(sample(measured.backend(), &settled, iters).steady_s)));
    }
    // The copy a cycle's bytes are measured against: the time `bytes` × `CYCLES` take at the
    // bandwidth measured now, as the bench divides by it.
    group.throughput(Throughput::Bytes(bytes * CYCLES));
    group.bench_function("copy", |b| {
        b.iter_custom(|iters| {
            let bandwidth = measured.copy_bandwidth();
            seconds((iters * bytes * CYCLES) as f64 / bandwidth)
        })
    });
    group.finish();

    // Host stages and topology + transfers, each as its part of the runs it is measured on.
    let parts = Stage::ALL.iter().map(|&s| Part::Stage(s)).chain([Part::TopologyAndTransfers]);
    for part in parts {
        let seconds_in_calibration = part.of(&calibration);
        if seconds_in_calibration < MIN_SHARE * steady {
            continue;
        }
        let per_iteration = seconds_in_calibration / CALIBRATION_ITERS as f64;
        let mut group = c.benchmark_group(format!("{label}/wall_{nb}/stages"));
        group
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(seconds(STAGE_ITERS * per_iteration))
            .measurement_time(seconds(10.0 * STAGE_ITERS * per_iteration));
        group.bench_function(slug(part.name()), |b| b.iter_custom(|iters| seconds(part.of(&sample(measured.backend(), &settled, iters)))));
        group.finish();
    }
    // Kernels, on the state a run left on the device.
    let mut model = settled.clone();
    measured.backend().run(&mut model, CYCLES, &mut |_| true).expect("the wall runs");
    for (kernel, _) in measured.kernels(4) {
        let mut group = c.benchmark_group(format!("{label}/wall_{nb}/stages"));
        group.sampling_mode(SamplingMode::Flat).sample_size(10).warm_up_time(Duration::from_millis(200)).measurement_time(Duration::from_secs(1));
        group.bench_function(format!("kernel_{kernel}"), |b| {
            b.iter_custom(|iters| {
                let per_cycle = measured.kernels(CYCLES as u32).into_iter().find(|k| k.0 == kernel).map_or(0.0, |k| k.1);
                seconds(per_cycle * (iters * CYCLES) as f64)
            })
        });
        group.finish();
    }
}

/// A stage's name as a criterion id: lower case, words joined by `_`.
fn slug(name: &str) -> String {
    let mut out = String::new();
    for w in name.split(|ch: char| !ch.is_ascii_alphanumeric() && ch != '+').filter(|w| !w.is_empty()) {
        if !out.is_empty() {
            out.push('_');
        }
        out.push_str(&w.to_ascii_lowercase());
    }
    out
}
