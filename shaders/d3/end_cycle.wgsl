// The cycle's last kernel in a scene with Griffith's cracking candidates, one invocation (Rust
// twin: `d3::gpu::end_cycle`): counts the cycle and, where a block's Griffith screen fired in this
// cycle's strain stage (the flag in the strain buffer's record after the blocks, sdef.wgsl's
// `crack_screen`), halts the rest of the batch, so that the CPU reads back the state of exactly
// this cycle, the one its `cracking::due` would see, and checks the criterion exactly.
//
// The cycle's other kernels are dispatched indirectly, their grids read from `halt`, which the
// CPU writes at each batch's start. Halting zeroes them, so the batch's later cycles launch no
// workgroups at all and no kernel reads a halt flag (as the 2D engine's end_cycle.wgsl). `halt`
// is this kernel's own binding (a buffer an indirect dispatch reads may not be bound for writing
// to the kernel it launches), and the flag lives in the strain buffer, which the strain stage
// already binds: the cycle's kernels keep to eight storage buffers.

// Twin of `d3::gpu::layout::Halt`.
struct Halt {
    gather_x: u32, gather_y: u32, gather_z: u32,
    law_of_motion_x: u32, law_of_motion_y: u32, law_of_motion_z: u32,
    track_contact_x: u32, track_contact_y: u32, track_contact_z: u32,
    cycles_done: u32, halted: u32, spare: u32,
}

@group(0) @binding(9) var<storage, read_write> halt: Halt;

@compute @workgroup_size(1)
fn end_cycle() {
    if (halt.halted != 0u) {
        return;
    }
    halt.cycles_done += 1u;
    if (sdef[params.blocks].spare != 0u) {
        halt.halted = 1u;
        halt.gather_x = 0u;
        halt.gather_y = 0u;
        halt.gather_z = 0u;
        halt.law_of_motion_x = 0u;
        halt.law_of_motion_y = 0u;
        halt.law_of_motion_z = 0u;
        halt.track_contact_x = 0u;
        halt.track_contact_y = 0u;
        halt.track_contact_z = 0u;
    }
}
