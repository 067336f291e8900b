// Stage 6: each block sums its contact forces and moments (eq. 12, M = r × F) in the fixed order
// of its CSR adjacency list (entry = contact·2 + side), then gravity and load. Gathered, never
// scattered, and no float atomics: a run repeats bit for bit. Twin of src/cpu/gather.rs.

@compute @workgroup_size(WORKGROUP_SIZE)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = gid.x;
    if (b >= params.n_blocks || halted()) {
        return;
    }
    let blk = blocks[b];
    var fx = blk.mass * params.gx + blk.load_x;
    var fy = blk.mass * params.gy + blk.load_y;
    var m: real = 0.0;
    for (var e = adj_offsets[b]; e < adj_offsets[b + 1u]; e += 1u) {
        let entry = adj_entries[e];
        let c = contacts[entry >> 1u];
        // Block 1 receives the contact force, block 2 its reaction (report ¶19). The point is
        // stored relative to block 2's centroid.
        var r = vec2<real>(c.px, c.py);
        var sign: real = 1.0;
        if ((entry & 1u) == 0u) {
            r += centroid_difference(blocks[c.block2], blk);
        } else {
            sign = -1.0;
        }
        let gx = sign * c.fx;
        let gy = sign * c.fy;
        fx += gx;
        fy += gy;
        m += r.x * gy - r.y * gx;
    }
    blocks[b].fx = fx;
    blocks[b].fy = fy;
    blocks[b].moment = m;
}
