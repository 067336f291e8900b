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

// A point r from the centroid stretched by the strain e (11, 12, 22): (I + ε)·r. Twin of
// `model::corners::strained`.
fn strained(e: array<real, 3>, r: vec2<real>) -> vec2<real> {
    return vec2<real>(r.x + e[0] * r.x + e[1] * r.y, r.y + e[1] * r.x + e[2] * r.y);
}

// Stage 2 of a simply-deformable block (twin of `model::corners::place_corners_strained`): its
// corners at (I + ε)·R(θ)·x_local, then each rounding circle fitted again tangent to its corner's
// two strained edges, its centre on the bisector at radius / cos(½ turn) from the corner, so
// that a contact on the straight parts moves with the strained edges (the lever arm of the
// applied stress is the contact point). cos(½ turn) = √((1 + cos turn)/2), turn ∈ (−π, π): no
// inverse trigonometry, which the f64 kernels do not have. One pass round the block with the
// previous, current and next corner in registers: each corner's body-frame position is loaded
// once (a software adapter loads each field of each lane on its own).
fn geometry_update_strained(blk: Block, e: array<real, 3>) {
    let cs = sin_cos(blk.rotation);
    let start = blk.corner_start;
    let n = blk.corner_count;
    let first = strained(e, rotate(cs, corners[start].lx, corners[start].ly));
    let last = start + n - 1u;
    var prev = strained(e, rotate(cs, corners[last].lx, corners[last].ly));
    var p = first;
    for (var k = 0u; k < n; k += 1u) {
        let i = start + k;
        var next = first;
        if (k + 1u < n) {
            next = strained(e, rotate(cs, corners[i + 1u].lx, corners[i + 1u].ly));
        }
        let e1 = p - prev;
        let e2 = next - p;
        let l1 = sqrt(dot(e1, e1));
        let l2 = sqrt(dot(e2, e2));
        let radius = corners[i].radius;
        var o = p;
        if (radius > 0.0 && l1 > 0.0 && l2 > 0.0) {
            let half = sqrt(max(0.5 * (1.0 + dot(e1, e2) / (l1 * l2)), 0.0));
            let bis = e2 / l2 - e1 / l1;
            let lb = sqrt(dot(bis, bis));
            if (lb > 0.0 && half > 0.0) {
                o = p + bis / lb * (radius / half);
            }
        }
        corners[i].px = p.x;
        corners[i].py = p.y;
        corners[i].ox = o.x;
        corners[i].oy = o.y;
        prev = p;
        p = next;
    }
}

// Where grid point g lies from block blk's centroid (the reference its corners are placed from:
// a zoned block's centroid on the device stays where the upload put it), from the two
// compensated pairs.
fn gridpoint_offset(blk: Block, g: u32) -> vec2<real> {
    let gp = gridpoints[g];
    return vec2<real>((gp.x - blk.cx) + (gp.x_lo - blk.cx_lo), (gp.y - blk.cy) + (gp.y_lo - blk.cy_lo));
}

// How far grid point g is from where it was at its block's last contact update.
fn gridpoint_travel(g: u32) -> real {
    let gp = gridpoints[g];
    let d = vec2<real>((gp.x - gp.ux) + (gp.x_lo - gp.ux_lo), (gp.y - gp.uy) + (gp.y_lo - gp.uy_lo));
    return sqrt(d.x * d.x + d.y * d.y);
}

// Corner k of zoned block `blk` on its boundary grid point k, given the boundary's n points
// (twin of one step of `model::corners::place_corners_fdef`): the rounding circle fitted again
// tangent to the corner's two edges (centre on the bisector at radius / cos(½ turn), as
// `fit_circles_to_edges` does), the body frame the world's (its rotation stays 0). Its
// neighbours are found by index (k − 1 and k + 1 round the boundary), so each corner is placed
// on its own, by the same arithmetic whichever invocation places it.
fn place_fdef_corner(blk: Block, fb: FdefBlock, k: u32) {
    let n = fb.boundary;
    let prev = gridpoint_offset(blk, fb.gp_start + (k + n - 1u) % n);
    let p = gridpoint_offset(blk, fb.gp_start + k);
    let next = gridpoint_offset(blk, fb.gp_start + (k + 1u) % n);
    let i = blk.corner_start + k;
    let e1 = p - prev;
    let e2 = next - p;
    let l1 = sqrt(e1.x * e1.x + e1.y * e1.y);
    let l2 = sqrt(e2.x * e2.x + e2.y * e2.y);
    let radius = corners[i].radius;
    var circle = p;
    if (radius > 0.0 && l1 > 0.0 && l2 > 0.0) {
        let half = sqrt(max(0.5 * (1.0 + (e1.x * e2.x + e1.y * e2.y) / (l1 * l2)), 0.0));
        let bis = vec2<real>(e2.x / l2 - e1.x / l1, e2.y / l2 - e1.y / l1);
        let lb = sqrt(bis.x * bis.x + bis.y * bis.y);
        if (lb > 0.0 && half > 0.0) {
            let offset = radius / half;
            circle = vec2<real>(p.x + bis.x / lb * offset, p.y + bis.y / lb * offset);
        }
    }
    corners[i].lx = p.x;
    corners[i].ly = p.y;
    corners[i].px = p.x;
    corners[i].py = p.y;
    corners[i].qx = circle.x;
    corners[i].qy = circle.y;
    corners[i].ox = circle.x;
    corners[i].oy = circle.y;
}

// The update tolerance of zoned block b once its boundary has moved `moved` (the largest travel
// of a boundary grid point since the last contact update, report ¶26): kept on the block, and
// an update due when it passes ETOL and the block's margin.
fn fdef_block_moved(b: u32, blk: Block, moved: real) {
    let m = max(blk.moved, moved);
    blocks[b].moved = m;
    if (m > params.etol + blk.update_margin) {
        atomicOr(&flags.update_due, 1u);
    }
}

// Stage 2 of a zoned fully-deformable block b (twin of `model::corners::place_corners_fdef`)
// in one invocation: its corners in boundary order (`place_fdef_corner`) and the update
// tolerance. The fluid scene's `law_of_motion_fdef_fluid` places a zoned block's corners so, as
// does a dry scene's `law_of_motion_fdef` those of a block of few (at most `WIDE_BOUNDARY`).
fn place_corners_fdef(b: u32, blk: Block, fb: FdefBlock) {
    var moved = real(0.0);
    for (var k = 0u; k < fb.boundary; k += 1u) {
        place_fdef_corner(blk, fb, k);
        moved = max(moved, gridpoint_travel(fb.gp_start + k));
    }
    fdef_block_moved(b, blk, moved);
}

var<workgroup> fdef_moved: array<real, WORKGROUP_SIZE>;

// Zoned blocks of more boundary grid points than this are placed by a workgroup each
// (`place_fdef_corners`), the others by their invocation of `law_of_motion_fdef`
// (`gpu::fdef::WIDE_BOUNDARY`): a brick's few corners cost a workgroup more than its walk.
const WIDE_BOUNDARY: u32 = 32u;

// Stage 2 of the zoned blocks of many boundary grid points in a dry scene (twin of
// `model::corners::place_corners_fdef`), one workgroup per such block (`GridPointContacts`
// lists them): each invocation places the corners k ≡ its index (mod the workgroup's size) and
// keeps the largest travel of their grid points, and the first takes the largest of the
// workgroup's. A block of a thousand boundary grid points was one invocation's serial walk; the
// corners do not depend on one another, and the largest travel is the same whatever order it is
// taken in, so the result is that walk's bit for bit. After `step_gridpoints` (the grid points'
// new positions), before the contact stage.
@compute @workgroup_size(WORKGROUP_SIZE)
fn place_fdef_corners(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = workgroup_index(wg);
    // The wide blocks' count and list, after the grid points' list offsets (`GridPointContacts`).
    let n_gp = arrayLength(&gridpoints);
    let wide = gridpoint_zones[n_gp] + n_gp + 1u;
    // Uniform across the workgroup (read-only words at a uniform index): every invocation
    // returns here, or reaches the barrier.
    if (i >= gridpoint_zones[wide]) {
        return;
    }
    let b = gridpoint_zones[wide + 1u + i];
    let blk = blocks[b];
    let fb = fdef_blocks[b];
    let moving = blk.fixed == 0u;
    var moved = real(0.0);
    if (moving) {
        for (var k = li; k < fb.boundary; k += WORKGROUP_SIZE) {
            place_fdef_corner(blk, fb, k);
            moved = max(moved, gridpoint_travel(fb.gp_start + k));
        }
    }
    fdef_moved[li] = moved;
    workgroupBarrier();
    if (moving && li == 0u) {
        var m = fdef_moved[0];
        for (var l = 1u; l < WORKGROUP_SIZE; l += 1u) {
            m = max(m, fdef_moved[l]);
        }
        fdef_block_moved(b, blk, m);
    }
}
