//! Throughput of the CPU cycle on the walls of `blockdem bench` (25 rows of 1 × 0.5 m bricks in
//! running bond on a fixed ground block struck by the reference projectile,
//! `blockdem::bench::scene::scaling_body`) at about 10³ and
//! 10⁴ blocks. Reports block-cycles/s and contact-cycles/s (criterion's "elements/s" of each
//! group). Each iteration is one `Backend::run` of 50 cycles, including the full contact
//! detection every run starts with — what one CYCLE 50 command costs a user.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};

use blockdem::backend::Backend;
use blockdem::bench::scene::{scaling_body, FRAC};
use blockdem::cpu::CpuBackend;
use blockdem::scenes::run_deck_on;

const CYCLES: u64 = 50;

/// The wall of about `n` blocks, settled for 10 cycles so that its contacts carry load.
fn wall(n: usize) -> blockdem::model::Model {
    let deck = scaling_body(n, FRAC) + "CYCLE 10\n";
    run_deck_on(&deck, Box::new(CpuBackend::new())).expect("wall builds")
}

fn bench_cycle(c: &mut Criterion) {
    for n in [1_000, 10_000] {
        let model = wall(n);
        let (nb, nc) = (model.blocks.len() as u64, model.contacts.len() as u64);
        for (what, elements) in [("block-cycles", nb), ("contact-cycles", nc)] {
            let mut group = c.benchmark_group(format!("cpu_cycle/{what}"));
            group.sample_size(10);
            group.throughput(Throughput::Elements(elements * CYCLES));
            group.bench_function(format!("wall_{nb}_blocks_{nc}_contacts"), |b| {
                b.iter_batched(
                    || (model.clone(), CpuBackend::new()),
                    |(mut m, mut backend)| backend.run(&mut m, CYCLES, &mut |_| true).expect("stable"),
                    BatchSize::LargeInput,
                )
            });
            group.finish();
        }
    }
}

criterion_group!(benches, bench_cycle);
criterion_main!(benches);
