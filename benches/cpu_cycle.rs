//! Throughput of the CPU cycle on a brick wall in running bond resting on a fixed ground block
//! (the scene of `blockdem::scenes::brick_wall_deck`), at about 10³ and 10⁴ blocks.
//! Reports block-cycles/s and contact-cycles/s (criterion's "elements/s" of each group).
//! Each iteration is one `Backend::run` of 50 cycles, including the full contact detection every
//! run starts with — what one CYCLE 50 command costs a user.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};

use blockdem::backend::Backend;
use blockdem::cpu::CpuBackend;
use blockdem::scenes::{brick_wall_deck, run_deck_on};

const CYCLES: u64 = 50;

fn wall(rows: usize, bricks: usize) -> blockdem::model::Model {
    // Settle briefly so the contacts carry load, as in a real run.
    let deck = brick_wall_deck(rows, bricks, 1.0, 0.5, 1e9, 0.6) + "CYCLE 10\n";
    run_deck_on(&deck, Box::new(CpuBackend::new())).expect("wall builds")
}

fn bench_cycle(c: &mut Criterion) {
    for (rows, bricks) in [(25usize, 40usize), (50, 200)] {
        let model = wall(rows, bricks);
        let (nb, nc) = (model.blocks.len() as u64, model.contacts.len() as u64);
        for (what, elements) in [("block-cycles", nb), ("contact-cycles", nc)] {
            let mut group = c.benchmark_group(format!("cpu_cycle/{what}"));
            group.sample_size(10);
            group.throughput(Throughput::Elements(elements * CYCLES));
            group.bench_function(format!("wall_{nb}_blocks_{nc}_contacts"), |b| {
                b.iter_batched(
                    || (model.clone(), CpuBackend::new()),
                    |(mut m, mut backend)| backend.run(&mut m, CYCLES, &mut |_| {}).expect("stable"),
                    BatchSize::LargeInput,
                )
            });
            group.finish();
        }
    }
}

criterion_group!(benches, bench_cycle);
criterion_main!(benches);
