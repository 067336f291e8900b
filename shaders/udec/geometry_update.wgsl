// Stage 2: geometry update (twin of src/cpu/geometry_update.rs). A rigid block's corners and
// rounding-circle centres follow its rotation exactly, x = R(θ)·x_local, stored relative to the
// block's centroid so that f32 keeps the shape to round-off wherever the block is. The edges
// between corners, which the CPU's twin also measures here, are measured by the contact stage
// from the corners it loads (`edge_from` in contact_forces.wgsl): storing them cost three of
// every seven stores here and as many loads there.
//
// No dispatch of its own: the stage needs nothing but the block, so the invocation that moved a
// block in stage 1 places its corners (law_of_motion.wgsl calls this), as the CPU's cycle does
// in one pass over the blocks.

fn rotate(cs: vec2<real>, x: real, y: real) -> vec2<real> {
    return vec2<real>(cs.x * x - cs.y * y, cs.y * x + cs.x * y);
}

// Places the corners of `blk` (its rotation as stage 1 left it).
fn geometry_update(blk: Block) {
    let cs = sin_cos(blk.rotation);
    let end = blk.corner_start + blk.corner_count;
    for (var i = blk.corner_start; i < end; i += 1u) {
        let p = rotate(cs, corners[i].lx, corners[i].ly);
        let o = rotate(cs, corners[i].qx, corners[i].qy);
        corners[i].px = p.x;
        corners[i].py = p.y;
        corners[i].ox = o.x;
        corners[i].oy = o.y;
    }
}
