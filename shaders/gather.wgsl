// Stage 6: each block sums its contact forces and moments (eq. 12, M = r × F) in the fixed order
// of its CSR adjacency list (entry = contact·2 + side), then gravity and load. Gathered, never
// scattered, and no float atomics: a run repeats bit for bit. Twin of src/cpu/gather.rs.
//
// The contact stage has already put each contact's force and both moments into its compact
// `ContactForce` slot, so a block reads 16 contiguous bytes per contact (in f32) and never its
// neighbours. Fixed blocks are skipped in the cycle (their force moves nothing; a fixed base
// under a long wall has tens of thousands of contacts, and one thread summing them would stall
// every cycle); `params.gather_fixed` sums them too, in the pass before each read-back.

@compute @workgroup_size(WORKGROUP_SIZE)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = gid.x;
    if (b >= params.n_blocks || halted()) {
        return;
    }
    let blk = blocks[b];
    if (blk.fixed != 0u && params.gather_fixed == 0u) {
        return;
    }
    var fx = blk.mass * params.gx + blk.load_x;
    var fy = blk.mass * params.gy + blk.load_y;
    var m: real = 0.0;
    for (var e = adj_offsets[b]; e < adj_offsets[b + 1u]; e += 1u) {
        let entry = adj_entries[e];
        let f = contact_forces_out[entry >> 1u];
        // Block 1 receives the contact force, block 2 its reaction (report ¶19).
        if ((entry & 1u) == 0u) {
            fx += f.fx;
            fy += f.fy;
            m += f.m1;
        } else {
            fx -= f.fx;
            fy -= f.fy;
            m += f.m2;
        }
    }
    blocks[b].fx = fx;
    blocks[b].fy = fy;
    blocks[b].moment = m;
}
