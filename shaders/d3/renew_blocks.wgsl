// A partial detection's renewal of the block records on the device (twin:
// `d3::gpu::splice::renew_blocks`; `d3::gpu`, "Partial detections"). A detection changes three
// things of a block's record: its adjacency range (the contacts' lists are renewed), its travel
// (from zero again where the block moved) and the sums that count from the upload (the largest
// step's travel, the work and the dissipation, which the CPU has just read back and moved into
// the bases). The CPU uploads 8 bytes a block (`renewals[i]` = (the adjacency list's start, its
// length with RENEW_MOVED set where the block moved)) where it uploaded each whole record; the
// rest of the record is the device's, as a whole upload of the state read back would leave it.

@group(0) @binding(9) var<storage, read> renewals: array<vec2<u32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn renew_blocks(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= params.blocks) {
        return;
    }
    let r = renewals[i];
    var b = blocks[i];
    b.adjacency_start = r.x;
    b.adjacency_count = r.y & ~RENEW_MOVED;
    if ((r.y & RENEW_MOVED) != 0u) {
        b.travel = 0.0;
    }
    b.peak_travel = 0.0;
    b.work = 0.0;
    b.damping_work = 0.0;
    b.dashpot_work = 0.0;
    blocks[i] = b;
}
