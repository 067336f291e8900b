// Stage 6: each block sums its contact forces and moments (eq. 12, M = r × F) in the fixed order
// of its CSR adjacency list (entry = contact·2 + side), then gravity and load. Gathered, never
// scattered, and no float atomics: a run repeats bit for bit. Twin of src/cpu/gather.rs.
//
// In a cycle the sums are taken by the invocation that moves the block, at the start of the next
// cycle's law of motion (law_of_motion.wgsl, as the CPU's `block_piece` fuses stages 6, 1 and 2):
// one dispatch and one pass over the blocks fewer, and the sums are never stored. The `gather`
// kernel here stores them on the blocks for whoever reads them between cycles (a read-back, the
// energy check: kinetic energy at time t), fixed blocks' too, which the cycle skips (their force
// moves nothing, but it is printed, and a fixed base can carry a whole wall's contacts).
//
// The contact stage has already put each contact's force and both moments into its compact
// `ContactForce` slot, so a block reads 12 of 16 contiguous bytes per contact (in f32: the force
// and its own side's moment) and never its neighbours.
//
// A block with a long list (a base under a long wall carries tens of thousands of contacts) is
// left to `gather_heavy`: one workgroup per such block, each invocation summing a strided share
// and the shares added by a fixed binary tree, so its sum also repeats bit for bit (in another
// order than the CPU's serial sum: the two agree to rounding). The CPU lists these blocks after
// the offsets in `adj_offsets`, free ones first: a cycle dispatches only those (`params.n_heavy`),
// before the law of motion, which then reads their stored sums; a fixed base under a long wall is
// summed only in the pass before a read-back.

// Force and moment on a block from one adjacency entry (`entry_contact`, `entry_side`). Block 1 (side 0)
// receives the contact force, block 2 its reaction (report ¶19); the side picks the moment, so
// an entry loads three fields (a software adapter loads each field of each lane on its own).
fn entry_force(entry: u32) -> vec3<real> {
    let k = entry_contact(entry);
    let side = entry_side(entry);
    let sign = select(real(1.0), real(-1.0), side == 1u);
    return vec3<real>(sign * contact_forces_out[k].fx, sign * contact_forces_out[k].fy, contact_forces_out[k].m[side]);
}

// Whether block b's list is long enough for `gather_heavy` (its adjacency entries first .. end).
fn is_heavy(first: u32, end: u32) -> bool {
    return end - first > HEAVY_DEGREE;
}

// The force and moment on a block whose adjacency entries are first .. end: its contacts' in
// list order, after gravity and its load.
fn force_sum(blk: Block, first: u32, end: u32) -> vec3<real> {
    var f = vec3<real>(blk.mass * params.gx + blk.load_x, blk.mass * params.gy + blk.load_y, 0.0);
    for (var e = first; e < end; e += 1u) {
        f += entry_force(adj_entries[e]);
    }
    return f;
}

// Stage 6 of block b, its sums stored (a block with a long list is `gather_heavy`'s).
fn gather_block(b: u32) {
    let blk = blocks[b];
    let first = adj_offsets[b];
    let end = adj_offsets[b + 1u];
    if (is_heavy(first, end)) {
        return;
    }
    let f = force_sum(blk, first, end);
    blocks[b].fx = f.x;
    blocks[b].fy = f.y;
    blocks[b].moment = f.z;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gather(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    gather_block(b);
}

var<workgroup> shares: array<vec3<real>, HEAVY_WORKGROUP_SIZE>;

@compute @workgroup_size(HEAVY_WORKGROUP_SIZE)
fn gather_heavy(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let h = workgroup_index(wg);
    // Uniform across the workgroup: every invocation reaches every barrier.
    let listed = h < params.n_heavy;
    var b = 0u;
    var f = vec3<real>(0.0, 0.0, 0.0);
    if (listed) {
        b = adj_offsets[params.n_blocks + 1u + h];
        for (var e = adj_offsets[b] + li; e < adj_offsets[b + 1u]; e += HEAVY_WORKGROUP_SIZE) {
            f += entry_force(adj_entries[e]);
        }
    }
    shares[li] = f;
    workgroupBarrier();
    for (var s = HEAVY_WORKGROUP_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            shares[li] += shares[li + s];
        }
        workgroupBarrier();
    }
    if (listed && li == 0u) {
        let blk = blocks[b];
        let t = shares[0] + vec3<real>(blk.mass * params.gx + blk.load_x, blk.mass * params.gy + blk.load_y, 0.0);
        blocks[b].fx = t.x;
        blocks[b].fy = t.y;
        blocks[b].moment = t.z;
    }
}

// Stage 6 of a simply-deformable block whose adjacency entries are first .. end: its force and
// moment as `force_sum` gives them, and its applied stress times area (`model::sdef`, the
// report's KSA), Σ r_i f_j as (11, 12, 21, 22), f the force on the block and r its lever arm from
// the contact stage (`contact_levers`), in list order, in one pass over the entries. Twin of
// `cpu::gather::gather_sdef`. Gravity and the load act at the centroid: no applied stress.
struct SdefForces {
    force: vec3<real>,
    applied: array<real, 4>,
}

fn force_sum_sdef(blk: Block, first: u32, end: u32) -> SdefForces {
    var f = vec3<real>(blk.mass * params.gx + blk.load_x, blk.mass * params.gy + blk.load_y, 0.0);
    var a = array<real, 4>(0.0, 0.0, 0.0, 0.0);
    for (var e = first; e < end; e += 1u) {
        let entry = adj_entries[e];
        let k = entry_contact(entry);
        let side = entry_side(entry);
        let sign = select(real(1.0), real(-1.0), side == 1u);
        let g = vec3<real>(sign * contact_forces_out[k].fx, sign * contact_forces_out[k].fy, contact_forces_out[k].m[side]);
        f += g;
        var r = vec2<real>(contact_levers[k].r1x, contact_levers[k].r1y);
        if (side == 1u) {
            r = vec2<real>(contact_levers[k].r2x, contact_levers[k].r2y);
        }
        a[0] += r.x * g.x;
        a[1] += r.x * g.y;
        a[2] += r.y * g.x;
        a[3] += r.y * g.y;
    }
    return SdefForces(f, a);
}

// `gather` in a scene with simply-deformable blocks: a rigid block as `gather` sums it; an SDEF
// block's force and moment in list order whatever its list's length (the heavy list that
// `gather_heavy` sums holds rigid blocks only), its applied stress stored with them.
@compute @workgroup_size(WORKGROUP_SIZE)
fn gather_sdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    if (blk.kind != BLOCK_SDEF) {
        gather_block(b);
        return;
    }
    let s = force_sum_sdef(blk, adj_offsets[b], adj_offsets[b + 1u]);
    blocks[b].fx = s.force.x;
    blocks[b].fy = s.force.y;
    blocks[b].moment = s.force.z;
    sdefs[b].applied = s.applied;
}

// `gather` in a scene with zoned fully-deformable blocks: a rigid block as `gather` sums it; a
// zoned block's forces are its grid points' (`gather_gridpoints`, zones.wgsl), and its block
// record's stay zero on the device (the CPU sums its external force at a read-back), so that
// the energy check counts its grid points' motion, not the block's.
@compute @workgroup_size(WORKGROUP_SIZE)
fn gather_fdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks || blocks[b].kind == BLOCK_FDEF) {
        return;
    }
    gather_block(b);
}

// Stage 5's loads, folded into the gather in a scene with fluid (twin of `cpu::flow::block_load`;
// the module doc of `model::fluid`, "Loads"): a block's buoyancy −ρ_w·A·g (¶9) and, over its
// adjacency list in order, the pressure jump at each contact's foot, (p_after − p_before)·perp(r)
// and (p_after − p_before)·|r|²/2 with r the foot from the block's centroid
// (`model::fluid::pressure_load`). The pressures are the last pressure update's, each contact's
// two copied into its flow slot next to its feet (`domain_pressures`, flow.wgsl), so the gather
// reads one slot per contact for them and binds neither the domains nor each contact's two
// domains; it runs in the same pass as the contact forces' sums, where a pass of its own walked
// every block's list again (one dispatch and one pass over the blocks and their lists fewer).

// The load of adjacency entry `entry`'s pressure jump added to `l` (`l` unchanged where the
// jump is 0, as for a contact that is not a link between two domains).
fn add_pressure_load(l: vec3<real>, entry: u32) -> vec3<real> {
    let k = entry_contact(entry);
    let side = entry_side(entry);
    var jump = contact_flows_out[k].p1 - contact_flows_out[k].p0;
    if (side == 1u) {
        jump = -jump;
    }
    if (jump == 0.0) {
        return l;
    }
    var r = vec2<real>(contact_flows_out[k].f0x, contact_flows_out[k].f0y);
    if (side == 1u) {
        r = vec2<real>(contact_flows_out[k].f1x, contact_flows_out[k].f1y);
    }
    return l + vec3<real>(-jump * r.y, jump * r.x, 0.5 * jump * (r.x * r.x + r.y * r.y));
}

// Block b's buoyancy, where its fluid load starts.
fn buoyancy(b: u32) -> vec3<real> {
    return vec3<real>(fluid_loads[b].buoy_x, fluid_loads[b].buoy_y, 0.0);
}

// Block b's fluid load alone, over its entries first .. end (a block with a long list, whose
// contact forces `gather_heavy` summed).
fn pressure_load_sum(b: u32, first: u32, end: u32) -> vec3<real> {
    var l = buoyancy(b);
    for (var e = first; e < end; e += 1u) {
        l = add_pressure_load(l, adj_entries[e]);
    }
    return l;
}

// A block's contact forces (with gravity and its load, as `force_sum` adds them) and its fluid
// load, kept apart: the block's force is their sum, the load's work is booked on its own.
struct FluidSums {
    force: vec3<real>,
    load: vec3<real>,
}

// Stage 6 of block b in a scene with fluid: its contact forces and its fluid load in one walk of
// its list (a block with a long list: the stored sums of `gather_heavy` and its load's own walk).
fn force_sum_fluid(b: u32, blk: Block) -> FluidSums {
    let first = adj_offsets[b];
    let end = adj_offsets[b + 1u];
    if (is_heavy(first, end)) {
        return FluidSums(vec3<real>(blocks[b].fx, blocks[b].fy, blocks[b].moment), pressure_load_sum(b, first, end));
    }
    var f = vec3<real>(blk.mass * params.gx + blk.load_x, blk.mass * params.gy + blk.load_y, 0.0);
    var l = buoyancy(b);
    for (var e = first; e < end; e += 1u) {
        let entry = adj_entries[e];
        f += entry_force(entry);
        l = add_pressure_load(l, entry);
    }
    return FluidSums(f, l);
}

// `gather` in a scene with fluid (before a read-back or the energy check): each block's contact
// forces and its fluid load (`force_sum_fluid`), as the CPU's `gather_all` adds it. A block with
// a long list was summed by `gather_heavy`, dispatched before this pass in such a scene: its
// load is added to the stored sums.
@compute @workgroup_size(WORKGROUP_SIZE)
fn gather_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let s = force_sum_fluid(b, blocks[b]);
    let f = s.force + s.load;
    blocks[b].fx = f.x;
    blocks[b].fy = f.y;
    blocks[b].moment = f.z;
}

// Stage 5's loads in a scene with fluid and deformable blocks (twin of `cpu::flow::block_load`
// and the blocks' share of `model::fluid::deformable_pressure_loads`), each block's stored for
// the block pass, which adds it to the contact sums that `gather_sdef` or `gather_fdef` stored
// (`law_of_motion_sdef_fluid`, `law_of_motion_fdef_fluid`: their kernels are at the limit of 8
// storage buffers, so the sums reach them stored): a rigid or simply-deformable block's
// buoyancy and pressure jumps (`pressure_load_sum`), a zoned block's buoyancy alone (its grid
// points take the pressures, `gridpoint_fluid_loads`); and a simply-deformable block's applied
// stress times area from the pieces of its boundary (`pressure_pieces`, flow.wgsl), summed in
// ascending link order (`block_pieces`: the CPU's order), pieces that load nothing passed over.
@compute @workgroup_size(WORKGROUP_SIZE)
fn fluid_block_loads(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let kind = blocks[b].kind;
    var l = buoyancy(b);
    if (kind != BLOCK_FDEF) {
        l = pressure_load_sum(b, adj_offsets[b], adj_offsets[b + 1u]);
    }
    var a = array<real, 4>(0.0, 0.0, 0.0, 0.0);
    if (kind == BLOCK_SDEF) {
        for (var e = block_pieces[b]; e < block_pieces[b + 1u]; e += 1u) {
            let piece = fluid_pieces[block_pieces[e]];
            if (piece.edge == NO_INDEX) {
                continue;
            }
            a[0] += piece.a0;
            a[1] += piece.a1;
            a[2] += piece.a2;
            a[3] += piece.a3;
        }
    }
    block_fluid[b] = BlockFluid(l.x, l.y, l.z, a[0], a[1], a[2], a[3]);
}

// `gather_sdef` in a scene with fluid (before a read-back or the energy check, after
// `gather_sdef` and `fluid_block_loads`): each block's fluid load added to its stored sums, an
// SDEF block's applied stress from the pressures to its stored applied stress (the CPU's
// `gather_sdef` with its fluid).
@compute @workgroup_size(WORKGROUP_SIZE)
fn gather_sdef_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let l = block_fluid[b];
    blocks[b].fx = blocks[b].fx + l.fx;
    blocks[b].fy = blocks[b].fy + l.fy;
    blocks[b].moment = blocks[b].moment + l.moment;
    if (blocks[b].kind == BLOCK_SDEF) {
        let a = sdefs[b].applied;
        sdefs[b].applied = array<real, 4>(a[0] + l.a11, a[1] + l.a12, a[2] + l.a21, a[3] + l.a22);
    }
}

// `gather_fdef` in a scene with fluid (before a read-back or the energy check, after
// `gather_fdef` and `fluid_block_loads`): each rigid block's fluid load added to its stored sums
// (a zoned block's record stays zero: its grid points carry its loads).
@compute @workgroup_size(WORKGROUP_SIZE)
fn gather_fdef_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks || blocks[b].kind == BLOCK_FDEF) {
        return;
    }
    let l = block_fluid[b];
    blocks[b].fx = blocks[b].fx + l.fx;
    blocks[b].fy = blocks[b].fy + l.fy;
    blocks[b].moment = blocks[b].moment + l.moment;
}
