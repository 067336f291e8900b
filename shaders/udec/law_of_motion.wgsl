// Stage 1: the law of motion for rigid blocks (SL-85-1 eqs. 9–10), central differences with
// mass-proportional Rayleigh damping (UDEC's CON1/CON2):
//   v(t+Δt/2) = [v(t−Δt/2)·(1 − αΔt/2) + (ΣF/m)·Δt] / (1 + αΔt/2).
// Twin of src/cpu/law_of_motion.rs. As on the CPU (`block_piece`), the invocation first sums the
// block's forces from the last contact stage (stage 6, `force_sum`, gather.wgsl: a block with a
// long list was summed by `gather_heavy` just before this dispatch); then moves it, raising the
// flags the CPU checks after stage 1 (a block past the update tolerance, a non-finite step, a
// block too fast for the contact update); then runs stage 2 for it (`geometry_update`,
// geometry_update.wgsl). A fixed block neither moves nor turns: its corners stay as uploaded.

// Energy the damping force −α·m·v takes in one step, from the velocities (vx, vy, ω) before (v0)
// and after (v1): v⁺ − v⁻ = (F/m − α·v̄)Δt with v̄ = (v⁺ + v⁻)/2 gives ½m(v⁺² − v⁻²) = F·v̄Δt −
// α·m·v̄²Δt exactly, the last term the dissipation. Twin of `cpu::law_of_motion::mass_damping_work`.
fn mass_damping_work(mass: real, inertia: real, v0: vec3<real>, v1: vec3<real>, alpha: real, dt: real) -> real {
    let m = 0.5 * (v0 + v1);
    return alpha * dt * (mass * (m.x * m.x + m.y * m.y) + inertia * m.z * m.z);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    var blk = blocks[b];
    if (blk.fixed != 0u) {
        blocks[b].vx = 0.0;
        blocks[b].vy = 0.0;
        blocks[b].w = 0.0;
        return;
    }
    // Stage 6 of the last cycle. The sums stay in this invocation: nothing reads a block's force
    // in the cycle, and `gather` stores them before they are read between cycles. A heavy
    // block's stored sums are read in its own (rare) branch, so that the others do not load them.
    let first = adj_offsets[b];
    let end = adj_offsets[b + 1u];
    if (is_heavy(first, end)) {
        blk.fx = blocks[b].fx;
        blk.fy = blocks[b].fy;
        blk.moment = blocks[b].moment;
    } else {
        let f = force_sum(blk, first, end);
        blk.fx = f.x;
        blk.fy = f.y;
        blk.moment = f.z;
    }
    let dt = params.dt;
    let con1 = 1.0 - 0.5 * params.alpha * dt;
    let con2 = 1.0 / (1.0 + 0.5 * params.alpha * dt);
    let inv_m = 1.0 / blk.mass;
    let vx = (blk.vx * con1 + blk.fx * inv_m * dt) * con2;
    let vy = (blk.vy * con1 + blk.fy * inv_m * dt) * con2;
    let w = (blk.w * con1 + blk.moment / blk.inertia * dt) * con2;
    let dx = vx * dt;
    let dy = vy * dt;
    let dtheta = w * dt;
    if (params.alpha > 0.0) {
        blk.damping_work += mass_damping_work(blk.mass, blk.inertia, vec3<real>(blk.vx, blk.vy, blk.w), vec3<real>(vx, vy, w), params.alpha, dt);
    }
    blk.vx = vx;
    blk.vy = vy;
    blk.w = w;
    // Compensated centroid: small increments are not lost on a large coordinate in f32.
    let one = real(params.one);
    let sx = two_sum(blk.cx, dx + blk.cx_lo, one);
    let sy = two_sum(blk.cy, dy + blk.cy_lo, one);
    blk.cx = sx.x;
    blk.cx_lo = sx.y;
    blk.cy = sy.x;
    blk.cy_lo = sy.y;
    // The rotation, in f32 (EXACT_CIRCLE), as the angle its corners are placed at, a multiple of
    // ROTATION_STEP, and the turn since (`rotation_lo`), which the contact stage applies to second
    // order (`circle_parts`). The corners are placed again only when that turn passes half a step
    // (the sums exact), so a block at rest keeps them, and the pair is the rotation rounded to the
    // nearest step and the rest, as an upload splits it (`shaders::split_rotation`: a RESTART goes
    // on bit for bit). A rotation kept in one f32 dropped every turn below its ulp (1.9e-6 rad
    // at θ = 20 rad) and moved the corners in steps of R × ulp(θ), and corners placed at every
    // step moved in steps of their own ulp; either way the contact forces of a small or a spun
    // block never settled. In f64 the corners follow the rotation every step, as on the CPU.
    var place = true;
    if (EXACT_CIRCLE) {
        blk.rotation_lo += dtheta;
        place = abs(blk.rotation_lo) > 0.5 * ROTATION_STEP;
        if (place) {
            // The sum is exact to 4096 rad; past that (ulp(θ) > ROTATION_STEP) the turn left is
            // what the angle really moved by, so θ = rotation + rotation_lo holds at any angle
            // (both differences exact: Sterbenz; `one` keeps the compiler from taking
            // (a + t) − a for t, as in `two_sum`).
            let placed = (blk.rotation + round(blk.rotation_lo / ROTATION_STEP) * ROTATION_STEP) * one;
            blk.rotation_lo -= (placed - blk.rotation) * one;
            blk.rotation = placed;
        }
    } else {
        blk.rotation += dtheta;
    }
    // A corner moves at most |Δx| + |Δθ|·R in this step (the too-fast check).
    let travel = sqrt(dx * dx + dy * dy) + abs(dtheta) * blk.radius;
    // Net displacement since the last contact update, kept at its largest (report ¶26).
    let ux = (blk.cx - blk.update_cx) + (blk.cx_lo - blk.update_cx_lo);
    let uy = (blk.cy - blk.update_cy) + (blk.cy_lo - blk.update_cy_lo);
    var turned = blk.rotation - blk.update_rotation;
    if (EXACT_CIRCLE) {
        turned += blk.rotation_lo;
    }
    let net = sqrt(ux * ux + uy * uy) + abs(turned) * blk.radius;
    blk.moved = max(blk.moved, net);
    let fx = blk.mass * params.gx + blk.load_x;
    let fy = blk.mass * params.gy + blk.load_y;
    let work = fx * dx + fy * dy;
    blk.work += work;
    // Only the fields this stage changes go back (a third of the block).
    blocks[b].vx = blk.vx;
    blocks[b].vy = blk.vy;
    blocks[b].w = blk.w;
    blocks[b].cx = blk.cx;
    blocks[b].cx_lo = blk.cx_lo;
    blocks[b].cy = blk.cy;
    blocks[b].cy_lo = blk.cy_lo;
    if (place) {
        blocks[b].rotation = blk.rotation;
        geometry_update(blk);
    }
    if (EXACT_CIRCLE) {
        blocks[b].rotation_lo = blk.rotation_lo;
    }
    blocks[b].moved = blk.moved;
    blocks[b].work = blk.work;
    blocks[b].damping_work = blk.damping_work;
    if (blk.moved > params.etol + blk.update_margin) {
        atomicOr(&flags.update_due, 1u);
    }
    if (!is_finite(work)) {
        atomicOr(&flags.errors, ERR_NONFINITE);
        atomicMin(&flags.nonfinite_block, b);
    }
    if (travel > params.fast_limit) {
        atomicOr(&flags.errors, ERR_TOO_FAST);
        atomicMin(&flags.toofast_block, b);
    }
}
