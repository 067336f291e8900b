// Bookkeeping at the end of each cycle (one invocation): counts the cycle and, when a kernel raised
// a flag the CPU must act on (stage 7 due, a Griffith crack due, an error), halts the rest of the batch so that the CPU
// reads back the state of exactly this cycle, as the CPU backend would see it.
//
// The other kernels of the cycle are dispatched indirectly, their grids read from
// `dispatch_args` (x, y, z per grid: blocks, corners, contacts, heavy blocks), which the CPU
// writes at the start of each batch. Halting zeroes them, so the cycles left in the batch launch
// no workgroups at all, and no kernel has to read the halt flag (a read per invocation, or a
// workgroup barrier, which on a software adapter costs 15–20% of a pass). This kernel has bindings
// of its own (the flags and the grids): a buffer an indirect dispatch reads may not be bound for
// writing to the kernel it launches.

@group(0) @binding(15) var<storage, read_write> dispatch_args: array<u32>;

@compute @workgroup_size(1)
fn end_cycle() {
    if (atomicLoad(&flags.halted) != 0u) {
        return;
    }
    atomicAdd(&flags.cycles_done, 1u);
    if (atomicLoad(&flags.update_due) != 0u || atomicLoad(&flags.errors) != 0u || atomicLoad(&flags.crack_due) != 0u) {
        atomicStore(&flags.halted, 1u);
        for (var i = 0u; i < arrayLength(&dispatch_args); i += 1u) {
            dispatch_args[i] = 0u;
        }
    }
}
