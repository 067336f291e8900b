//! The GPU backend on the walls of `blockdem bench` (about 10³ and 10⁴ blocks, struck by the
//! reference projectile), on every adapter and precision present
//! (`blockdem::bench::present_backends`): block-cycles/s and contact-cycles/s, the bytes a cycle
//! moves against the adapter's copy bandwidth, the time of each host stage (batches, uploads,
//! read-backs, contact updates; `topology+transfers` together) and of each kernel, as `blockdem
//! bench` reports them (`common` says how each is measured). The device is opened and its kernels
//! built once per adapter. With no adapter the bench says so and measures nothing.

use criterion::{criterion_group, criterion_main, Criterion};

use blockdem::bench::{present_backends, BackendSpec};
use blockdem::udec::gpu::{AdapterChoice, GpuBackend};

mod common;

fn bench_cycle(c: &mut Criterion) {
    let specs = present_backends(false, true, &AdapterChoice::Any, None);
    if specs.is_empty() {
        eprintln!("gpu_cycle: no GPU adapter found; nothing to measure");
        return;
    }
    let walls: Vec<_> = common::SIZES.into_iter().map(common::wall).collect();
    for spec in specs {
        let BackendSpec::Gpu(options) = spec else { continue };
        let mut gpu = match GpuBackend::new(&options) {
            Ok(g) => g,
            Err(e) => {
                eprintln!("gpu_cycle: {e}");
                continue;
            }
        };
        let a = gpu.adapter().clone();
        let label = format!("{}_{}_{}", a.backend, a.name.split_whitespace().next().unwrap_or("gpu"), gpu.precision()).to_lowercase();
        for wall in &walls {
            common::cover(c, &label, &mut gpu, wall);
        }
    }
}

criterion_group!(benches, bench_cycle);
criterion_main!(benches);
