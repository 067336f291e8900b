// Stage 2: geometry update (twin of src/cpu/geometry_update.rs). A rigid block's corners and
// rounding-circle centres follow its rotation exactly, x = R(θ)·x_local, stored relative to the
// block's centroid so that f32 keeps the shape to round-off wherever the block is. Each corner
// also measures the edge to the next corner (direction and length) once, for all the contacts
// that slide along it; it rotates the next corner itself rather than wait for its thread.

fn rotate(cs: vec2<real>, x: real, y: real) -> vec2<real> {
    return vec2<real>(cs.x * x - cs.y * y, cs.y * x + cs.x * y);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn geometry_update(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= params.n_corners) {
        return;
    }
    var corner = corners[i];
    let blk = blocks[corner.block];
    let cs = sin_cos(blk.rotation);
    let p = rotate(cs, corner.lx, corner.ly);
    let o = rotate(cs, corner.qx, corner.qy);
    var j = i + 1u;
    if (j == blk.corner_start + blk.corner_count) {
        j = blk.corner_start;
    }
    let nxt = corners[j];
    let e = rotate(cs, nxt.lx, nxt.ly) - p;
    let len = sqrt(e.x * e.x + e.y * e.y);
    corner.px = p.x;
    corner.py = p.y;
    corner.ox = o.x;
    corner.oy = o.y;
    corner.ux = e.x / len;
    corner.uy = e.y / len;
    corner.len = len;
    corners[i] = corner;
}
