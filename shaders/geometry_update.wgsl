// Stage 2: geometry update (twin of src/cpu/geometry_update.rs). A rigid block's corners and
// rounding-circle centres follow its rotation exactly, x = R(θ)·x_local, stored relative to the
// block's centroid so that f32 keeps the shape to round-off wherever the block is. Each corner
// also measures the edge to the next corner (direction and length) once, for all the contacts
// that slide along it.
//
// No dispatch of its own: the stage needs nothing but the block, so the invocation that moved a
// block in stage 1 places its corners (law_of_motion.wgsl calls this), as the CPU's cycle does
// in one pass over the blocks. That saves a pass (on a software adapter, tens of microseconds
// of launch a cycle) and the reads of the block and of each next corner a per-corner pass made.

fn rotate(cs: vec2<real>, x: real, y: real) -> vec2<real> {
    return vec2<real>(cs.x * x - cs.y * y, cs.y * x + cs.x * y);
}

// Places the corners of `blk` (its rotation as stage 1 left it); a block has at least three.
fn geometry_update(blk: Block) {
    let cs = sin_cos(blk.rotation);
    let first = blk.corner_start;
    let last = first + blk.corner_count - 1u;
    let p_first = rotate(cs, corners[first].lx, corners[first].ly);
    var p = p_first;
    for (var i = first; i <= last; i += 1u) {
        var next = p_first;
        if (i < last) {
            next = rotate(cs, corners[i + 1u].lx, corners[i + 1u].ly);
        }
        let o = rotate(cs, corners[i].qx, corners[i].qy);
        let e = next - p;
        let len = sqrt(e.x * e.x + e.y * e.y);
        corners[i].px = p.x;
        corners[i].py = p.y;
        corners[i].ox = o.x;
        corners[i].oy = o.y;
        corners[i].ux = e.x / len;
        corners[i].uy = e.y / len;
        corners[i].len = len;
        p = next;
    }
}
