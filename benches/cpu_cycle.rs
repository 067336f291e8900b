//! The CPU backend on the walls of `blockdem bench` (about 10³ and 10⁴ blocks, struck by the
//! reference projectile): block-cycles/s and contact-cycles/s, the bytes a cycle moves against
//! the host's copy bandwidth, the time of each host stage and of the contact updates
//! (`topology+transfers`), as `blockdem bench` reports them (`common` says how each is
//! measured). `cargo bench --bench cpu_cycle`; about a minute on 2 cores.

use criterion::{criterion_group, criterion_main, Criterion};

use blockdem::udec::cpu::CpuBackend;

mod common;

fn bench_cycle(c: &mut Criterion) {
    for n in common::SIZES {
        let wall = common::wall(n);
        common::cover(c, "cpu_f64", &mut CpuBackend::new(), &wall);
    }
}

criterion_group!(benches, bench_cycle);
criterion_main!(benches);
