//! Throughput of the GPU cycle on the walls of `blockdem bench` at about 10³ and 10⁴ blocks, on
//! every adapter and precision present (`blockdem::bench::present_backends`): block-cycles/s and
//! contact-cycles/s as criterion's "elements/s". Each iteration is one `Backend::run` of 50
//! cycles, including the contact detection and the upload every run starts with (what one CYCLE
//! 50 command costs). The device is opened and its kernels built once per adapter. With no
//! adapter the bench says so and measures nothing.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};

use blockdem::backend::Backend;
use blockdem::bench::scene::{scaling_body, FRAC};
use blockdem::bench::{present_backends, BackendSpec};
use blockdem::cpu::CpuBackend;
use blockdem::gpu::{AdapterChoice, GpuBackend};
use blockdem::scenes::run_deck_on;

const CYCLES: u64 = 50;

fn wall(n: usize) -> blockdem::model::Model {
    let deck = scaling_body(n, FRAC) + "CYCLE 10\n";
    run_deck_on(&deck, Box::new(CpuBackend::new())).expect("wall builds")
}

fn bench_cycle(c: &mut Criterion) {
    let specs = present_backends(false, true, &AdapterChoice::Any, None);
    if specs.is_empty() {
        eprintln!("gpu_cycle: no GPU adapter found; nothing to measure");
        return;
    }
    let walls: Vec<_> = [1_000, 10_000].into_iter().map(wall).collect();
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
        let name = format!("{}_{}_{}", a.backend, a.name.split_whitespace().next().unwrap_or("gpu"), gpu.precision()).to_lowercase();
        for model in &walls {
            let (nb, nc) = (model.blocks.len() as u64, model.contacts.len() as u64);
            for (what, elements) in [("block-cycles", nb), ("contact-cycles", nc)] {
                let mut group = c.benchmark_group(format!("gpu_cycle/{name}/{what}"));
                group.sample_size(10);
                group.throughput(Throughput::Elements(elements * CYCLES));
                group.bench_function(format!("wall_{nb}_blocks_{nc}_contacts"), |b| {
                    b.iter_batched(|| model.clone(), |mut m| gpu.run(&mut m, CYCLES, &mut |_| true).expect("stable"), BatchSize::LargeInput)
                });
                group.finish();
            }
        }
    }
}

criterion_group!(benches, bench_cycle);
criterion_main!(benches);
