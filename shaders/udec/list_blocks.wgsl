// Stage 7's lists, on the device (twins `gpu::partial::list_blocks` and `list_contacts`). A
// contact update re-examines the blocks that moved past half their update threshold, boxes afresh
// those that may have left their boxes in the broad-phase grid, and drops the contacts whose gap
// has opened past btol (topology/detect.rs, `update`). Rather than read every block and contact
// back to find those few, these kernels list them here and the CPU reads back the lists and then
// only the blocks, corners and contacts the update touches (`Engine::partial_contact_update`).
//
// The lists are supersets: each test is loosened by LIST_SLACK, so that no block or contact the
// CPU's exact test (in f64, on the values read back) would pick is left out by the device's
// round-off; the CPU applies its own test to what is listed. Blocks listed for neither reason
// give, instead, the number of cycles until they would pass their threshold at their present
// speed (the next update expected, which sizes the batches; twin `cycles_to_next_update`).
//
// Order: the lists fill in whatever order the invocations run; the CPU sorts them.

const LIST_SLACK: real = 0.01;

@group(0) @binding(0) var<uniform> lp: ListParams;
@group(0) @binding(1) var<storage, read> blocks: array<Block>;
@group(0) @binding(2) var<storage, read> contacts: array<Contact>;
@group(0) @binding(3) var<storage, read> reference: array<GridReference>;
// [blocks listed, contacts listed, fewest cycles to the next update (u32::MAX: none), unused]
@group(0) @binding(4) var<storage, read_write> header: array<atomic<u32>, 4>;
@group(0) @binding(5) var<storage, read_write> listed_blocks: array<u32>;
@group(0) @binding(6) var<storage, read_write> listed_contacts: array<u32>;

// Past (loosely) half its update threshold (etol + its speed margin): re-examined by the update.
fn near_update(blk: Block) -> bool {
    return blk.fixed == 0u && blk.moved > 0.5 * (lp.etol + blk.update_margin) * (1.0 - LIST_SLACK);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn list_blocks(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= lp.n_blocks) {
        return;
    }
    let blk = blocks[b];
    var listed = near_update(blk);
    if (!listed && lp.grid_kept != 0u) {
        // Strayed: its corners may have moved |Δc| + |Δθ|·reach since the grid was built, past
        // half the grid's margin, or it was given a larger speed margin since.
        let r = reference[b];
        let dx = (blk.cx - r.x) + (blk.cx_lo - r.x_lo);
        let dy = (blk.cy - r.y) + (blk.cy_lo - r.y_lo);
        let moved = sqrt(dx * dx + dy * dy) + abs((blk.rotation - r.rotation) + blk.rotation_lo) * r.reach;
        listed = moved > lp.stray_limit * (1.0 - LIST_SLACK) || (blk.update_margin > 0.0 && blk.update_margin >= r.margin);
    }
    if (listed) {
        listed_blocks[atomicAdd(&header[0], 1u)] = b;
        return;
    }
    if (blk.fixed != 0u) {
        return;
    }
    // |v|·Δt + |ω|·Δt·R a step (`Block::travel_per_step`).
    let s = sqrt(blk.vx * blk.vx + blk.vy * blk.vy) * lp.dt + abs(blk.w) * lp.dt * blk.radius;
    if (s > 0.0) {
        let room = max(lp.etol + blk.update_margin - blk.moved, 0.0);
        let k = floor(min(room / s, 1e9));
        atomicMin(&header[2], u32(k) + 1u);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn list_contacts(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    if (k >= lp.n_contacts) {
        return;
    }
    let c = contacts[k];
    let b1 = blocks[c.block1];
    let b2 = blocks[c.block2];
    // Opened past btol and the two speed margins; or a contact of a block the update re-examines,
    // whose margin it is about to change.
    let limit = lp.btol + b1.update_margin + b2.update_margin;
    if (c.gap > limit * (1.0 - LIST_SLACK) || near_update(b1) || near_update(b2)) {
        listed_contacts[atomicAdd(&header[1], 1u)] = k;
    }
}
