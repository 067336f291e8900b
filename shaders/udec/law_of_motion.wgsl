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

// What stage 1 did to a block (`rigid_step`), before it is stored (`store_step`): the block,
// whether its corners must be placed again (f32: its placed angle moved), how far a corner moved
// in the step (the too-fast check), the work of gravity and load (the non-finite check) and its
// net displacement since the last contact update (`net_since_update`, which an SDEF block adds
// its strain's travel to).
struct Step {
    blk: Block,
    place: bool,
    travel: real,
    work: real,
    net: real,
}

// Stage 1 for a free block whose forces of the last cycle are `f` (force, moment): the rigid
// motion, not stored. Twin of `cpu::law_of_motion::law_of_motion`.
fn rigid_step(blk_in: Block, f: vec3<real>) -> Step {
    var blk = blk_in;
    blk.fx = f.x;
    blk.fy = f.y;
    blk.moment = f.z;
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
    let net = net_since_update(blk);
    blk.moved = max(blk.moved, net);
    let fx = blk.mass * params.gx + blk.load_x;
    let fy = blk.mass * params.gy + blk.load_y;
    let work = fx * dx + fy * dy;
    blk.work += work;
    return Step(blk, place, travel, work, net);
}

// How far the block's corners are from where they were at the last contact update, at most:
// |Δc| + |Δθ|·R (twin of `Block::net_since_update`).
fn net_since_update(blk: Block) -> real {
    let ux = (blk.cx - blk.update_cx) + (blk.cx_lo - blk.update_cx_lo);
    let uy = (blk.cy - blk.update_cy) + (blk.cy_lo - blk.update_cy_lo);
    var turned = blk.rotation - blk.update_rotation;
    if (EXACT_CIRCLE) {
        turned += blk.rotation_lo;
    }
    return sqrt(ux * ux + uy * uy) + abs(turned) * blk.radius;
}

// Stores what stage 1 changed of block b (a third of the block; the corners are the caller's)
// and raises the flags the CPU checks after it.
fn store_step(b: u32, s: Step) {
    let blk = s.blk;
    blocks[b].vx = blk.vx;
    blocks[b].vy = blk.vy;
    blocks[b].w = blk.w;
    blocks[b].cx = blk.cx;
    blocks[b].cx_lo = blk.cx_lo;
    blocks[b].cy = blk.cy;
    blocks[b].cy_lo = blk.cy_lo;
    if (s.place) {
        blocks[b].rotation = blk.rotation;
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
    if (!is_finite(s.work)) {
        atomicOr(&flags.errors, ERR_NONFINITE);
        atomicMin(&flags.nonfinite_block, b);
    }
    if (s.travel > params.fast_limit) {
        atomicOr(&flags.errors, ERR_TOO_FAST);
        atomicMin(&flags.toofast_block, b);
    }
}

// A fixed block stays still: its velocities held at zero.
fn hold_still(b: u32) {
    blocks[b].vx = 0.0;
    blocks[b].vy = 0.0;
    blocks[b].w = 0.0;
}

// Stage 6 of the last cycle for block b: its contact forces, gravity and load summed (fx, fy,
// moment). The sums stay in this invocation: nothing reads a block's force in the cycle, and
// `gather` stores them before they are read between cycles. A heavy block's stored sums are read
// in its own (rare) branch, so that the others do not load them.
fn gathered_force(b: u32, blk: Block) -> vec3<real> {
    let first = adj_offsets[b];
    let end = adj_offsets[b + 1u];
    if (is_heavy(first, end)) {
        return vec3<real>(blocks[b].fx, blocks[b].fy, blocks[b].moment);
    }
    return force_sum(blk, first, end);
}

// Stage 1 (with stage 6 of the last cycle before it and stage 2 after it) for the rigid block b.
fn rigid_block(b: u32, blk: Block) {
    if (blk.fixed != 0u) {
        hold_still(b);
        return;
    }
    let s = rigid_step(blk, gathered_force(b, blk));
    store_step(b, s);
    if (s.place) {
        geometry_update(s.blk);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    rigid_block(b, blocks[b]);
}

// The largest stretch a strain change d (11, 12, 22) gives a point within `radius` of the
// centroid: its largest principal value in magnitude times the radius. Twin of
// `sdef::strain_travel`.
fn strain_travel(d: vec3<real>, radius: real) -> real {
    let mean = 0.5 * (d.x + d.z);
    let half_diff = 0.5 * (d.x - d.z);
    let rad = sqrt(half_diff * half_diff + d.y * d.y);
    return max(abs(mean + rad), abs(mean - rad)) * radius;
}

// Griffith's equivalent tensile stress of the stress s (11, 12, 22), tension positive (¶17; twin
// of `sdef::griffith_stress` on `sdef::principal_values`).
fn griffith_stress(s: array<real, 3>) -> real {
    let mean = 0.5 * (s[0] + s[2]);
    let half_diff = 0.5 * (s[0] - s[2]);
    let rad = sqrt(half_diff * half_diff + s[1] * s[1]);
    let s1 = mean + rad;
    let s2 = mean - rad;
    if (3.0 * s1 + s2 >= 0.0) {
        return s1;
    }
    return -(s1 - s2) * (s1 - s2) / (8.0 * (s1 + s2));
}

// One step of an SDEF block's strain (twin of `sdef::internal_step`, see there for the
// physics): the generalised force (applied less internal stress times area) over the strain's
// inertia, central differences with the internal mass damping (ALPB), then the strain and its
// plane-strain stress. Returns the block's extension as it now is.
fn internal_step(x_in: Sdef, theta: real) -> Sdef {
    var x = x_in;
    let j = strain_inertia(x.moments, sin_cos(theta));
    if (!(j.x > 0.0 && j.z > 0.0)) {
        return x;
    }
    let dt = params.dt;
    let alpha = params.alpha_internal;
    let c1 = 1.0 - 0.5 * alpha * dt;
    let c2 = 1.0 / (1.0 + 0.5 * alpha * dt);
    let q = generalised_force(x);
    let old = vec3<real>(x.strain_rate[0], x.strain_rate[1], x.strain_rate[2]);
    let rate = (old * c1 + q / j * dt) * c2;
    if (alpha > 0.0) {
        let m = 0.5 * (old + rate);
        x.damping_work += alpha * dt * (j.x * m.x * m.x + 2.0 * j.y * m.y * m.y + j.z * m.z * m.z);
    }
    x.strain_rate = array<real, 3>(rate.x, rate.y, rate.z);
    x.strain = array<real, 3>(x.strain[0] + rate.x * dt, x.strain[1] + rate.y * dt, x.strain[2] + rate.z * dt);
    let l = x.lambda;
    let g = x.shear;
    x.stress = array<real, 3>((l + 2.0 * g) * x.strain[0] + l * x.strain[2], 2.0 * g * x.strain[1], l * x.strain[0] + (l + 2.0 * g) * x.strain[2]);
    return x;
}

// A simply-deformable block's step on the sum of its forces `force` (x, y, moment), its
// applied stress already in `x` (twin of the CPU's `block_piece_sdef`): the rigid motion, the
// internal step at the new rotation, the update tolerance with the strain's travel, the
// geometry at the new strain, the extension stored and the Griffith check (¶17). Returns the
// step and the new strain rate (a caller booking work over the step needs them).
struct SdefStepped {
    step: Step,
    strain_rate: array<real, 3>,
}

fn step_sdef_block(b: u32, blk: Block, x_in: Sdef, force: vec3<real>) -> SdefStepped {
    var x = x_in;
    var s = rigid_step(blk, force);
    var theta = s.blk.rotation;
    if (EXACT_CIRCLE) {
        theta += s.blk.rotation_lo;
    }
    x = internal_step(x, theta);
    let dt = params.dt;
    s.travel += strain_travel(vec3<real>(x.strain_rate[0], x.strain_rate[1], x.strain_rate[2]) * dt, s.blk.radius);
    let since = vec3<real>(x.strain[0] - x.update_strain[0], x.strain[1] - x.update_strain[1], x.strain[2] - x.update_strain[2]);
    s.blk.moved = max(s.blk.moved, s.net + strain_travel(since, s.blk.radius));
    store_step(b, s);
    geometry_update_strained(s.blk, x.strain);
    sdefs[b].strain = x.strain;
    sdefs[b].strain_rate = x.strain_rate;
    sdefs[b].stress = x.stress;
    sdefs[b].applied = x.applied;
    sdefs[b].damping_work = x.damping_work;
    if (x.griffith_tf > 0.0 && griffith_stress(x.stress) >= x.griffith_tf) {
        atomicOr(&flags.crack_due, 1u);
    }
    return SdefStepped(s, x.strain_rate);
}

// Stage 1 in a scene with simply-deformable blocks (twin of the CPU's `block_piece_sdef`): a
// rigid block as `law_of_motion` moves it; an SDEF block sums its force and applied stress in
// list order (whatever its list's length), takes the rigid step, then its strain's step, counts
// the strain's motion of its corners towards the too-fast check and the update tolerance,
// places its corners strained (every step: the strain moves them), and raises `crack_due` where
// its stress reaches its Griffith strength.
@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion_sdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    if (blk.kind != BLOCK_SDEF) {
        rigid_block(b, blk);
        return;
    }
    if (blk.fixed != 0u) {
        hold_still(b);
        sdefs[b].strain_rate = array<real, 3>(0.0, 0.0, 0.0);
        return;
    }
    let first = adj_offsets[b];
    let end = adj_offsets[b + 1u];
    var x = sdefs[b];
    let sums = force_sum_sdef(blk, first, end);
    x.applied = sums.applied;
    step_sdef_block(b, blk, x, sums.force);
}

// Stages 1 and 2 in a scene with zoned fully-deformable blocks (twin of the CPU's
// `block_piece_fdef`): a rigid block as `law_of_motion` moves it; a zoned block's grid points
// have moved already (`step_gridpoints`, zones.wgsl), so its invocation places its corners on
// them and measures its boundary's travel for the update tolerance (`place_corners_fdef`),
// unless the block has so many that a workgroup of its own does (`place_fdef_corners`, both in
// geometry_update.wgsl). A fixed zoned block's corners stay as uploaded.
@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion_fdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    if (blk.kind != BLOCK_FDEF) {
        rigid_block(b, blk);
        return;
    }
    let fb = fdef_blocks[b];
    if (blk.fixed == 0u && fb.boundary <= WIDE_BOUNDARY) {
        place_corners_fdef(b, blk, fb);
    }
}

// Stages 6, 1 and 2 in a scene with fluid (twin of the CPU's `block_piece` with
// `BlockInputs::fluid_loads`): a rigid block as `law_of_motion` moves it, its fluid load (the
// domain pressures of the last stage 5 and buoyancy, summed in the same walk of its list as its
// contact forces: `force_sum_fluid`, gather.wgsl) added after its contact forces, and the load's
// work over the step, F·Δx + M·Δθ at the new velocities, counted on the block
// (`cpu::flow::fluid_work`, the ledger's fluid term).
@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    if (blk.fixed != 0u) {
        hold_still(b);
        return;
    }
    let sums = force_sum_fluid(b, blk);
    let l = sums.load;
    let s = rigid_step(blk, sums.force + l);
    store_step(b, s);
    if (s.place) {
        geometry_update(s.blk);
    }
    fluid_loads[b].work += (l.x * s.blk.vx + l.y * s.blk.vy + l.z * s.blk.w) * params.dt;
}

// A rigid block's stage 1 and 2 in a scene with fluid and deformable blocks, on its contact sums
// as stored this cycle (`gather_sdef`, `gather_fdef`, `gather_heavy`) and its fluid load `l`
// (`fluid_block_loads`, gather.wgsl), the load's work over the step booked as
// `law_of_motion_fluid` books it.
fn rigid_block_wet(b: u32, blk: Block, l: vec3<real>) {
    let s = rigid_step(blk, vec3<real>(blk.fx, blk.fy, blk.moment) + l);
    store_step(b, s);
    if (s.place) {
        geometry_update(s.blk);
    }
    fluid_loads[b].work += (l.x * s.blk.vx + l.y * s.blk.vy + l.z * s.blk.w) * params.dt;
}

// Stages 1 and 2 in a scene with fluid and simply-deformable blocks (twin of the CPU's
// `block_piece_sdef` with its fluid, `cpu::gather::gather_sdef`): each block's contact sums as
// `gather_sdef` stored them this cycle, with its fluid load added (a rigid block as
// `law_of_motion_fluid` moves it); an SDEF block's applied stress with the pressures' share
// added, then its step as `law_of_motion_sdef` takes it, and the fluid's work over the step
// booked, F·Δx + M·Δθ and A : Δε (`cpu::flow::fluid_work`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion_sdef_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    if (blk.fixed != 0u) {
        hold_still(b);
        if (blk.kind == BLOCK_SDEF) {
            sdefs[b].strain_rate = array<real, 3>(0.0, 0.0, 0.0);
        }
        return;
    }
    let wet = block_fluid[b];
    let l = vec3<real>(wet.fx, wet.fy, wet.moment);
    if (blk.kind != BLOCK_SDEF) {
        rigid_block_wet(b, blk, l);
        return;
    }
    var x = sdefs[b];
    x.applied = array<real, 4>(x.applied[0] + wet.a11, x.applied[1] + wet.a12, x.applied[2] + wet.a21, x.applied[3] + wet.a22);
    let stepped = step_sdef_block(b, blk, x, vec3<real>(blk.fx, blk.fy, blk.moment) + l);
    let s = stepped.step;
    let e = stepped.strain_rate;
    let dt = params.dt;
    var work = fluid_loads[b].work + (l.x * s.blk.vx + l.y * s.blk.vy + l.z * s.blk.w) * dt;
    work += (wet.a11 * e[0] + (wet.a12 + wet.a21) * e[1] + wet.a22 * e[2]) * dt;
    fluid_loads[b].work = work;
}

// Stages 1 and 2 in a scene with fluid and zoned blocks (twin of the CPU's `block_piece_fdef`
// with its fluid): a rigid block on its contact sums as `gather_fdef` stored them this cycle,
// with its fluid load added; a zoned block's corners placed on its grid points, which have
// moved already (`step_gridpoints_fluid`), and their fluid work over the step added to its
// block's, grid point by grid point in order (`cpu::zones::step_fdef`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion_fdef_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    if (blk.kind == BLOCK_FDEF) {
        if (blk.fixed != 0u) {
            return;
        }
        let fb = fdef_blocks[b];
        place_corners_fdef(b, blk, fb);
        var w = real(0.0);
        for (var g = fb.gp_start; g < fb.gp_start + fb.gp_count; g += 1u) {
            w += gridpoint_fluid[g].step_work;
        }
        fluid_loads[b].work += w;
        return;
    }
    if (blk.fixed != 0u) {
        hold_still(b);
        return;
    }
    let wet = block_fluid[b];
    rigid_block_wet(b, blk, vec3<real>(wet.fx, wet.fy, wet.moment));
}
