// Bookkeeping at the end of each cycle (one invocation): counts the cycle and, when a kernel raised
// a flag the CPU must act on (stage 7 due, an error), halts the rest of the batch so that the CPU
// reads back the state of exactly this cycle, as the CPU backend would see it.

@compute @workgroup_size(1)
fn end_cycle() {
    if (halted()) {
        return;
    }
    atomicAdd(&flags.cycles_done, 1u);
    if (atomicLoad(&flags.update_due) != 0u || atomicLoad(&flags.errors) != 0u) {
        atomicStore(&flags.halted, 1u);
    }
}
