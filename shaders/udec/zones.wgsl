// Stages 6, 1 and 3 of fully-deformable blocks (SL-85-1 Appendix A ¶11–12; twin of
// src/udec/cpu/zones.rs, the physics in `model::fdef`): the grid points sum their forces, move by
// central differences, and the zones take their stress increments from the new velocities. One
// invocation per grid point or zone, each pass a dispatch of its own so that no invocation reads
// what another writes in the same pass:
//
// - `gather_gridpoints`: each grid point's force, gravity and the load's share first, then its
//   contacts in its block's list order (boundary grid points only: the contact stage wrote each
//   contact's shares, `ContactShare`; each grid point walks its own list of the entries that may
//   act on it, `gpu::fdef::GridPointContacts`, or its block's whole list where a contact's
//   feature has moved out of the lists' reach, `check_fdef_lists`), then its zones in ascending order (`gridpoint_zones`): the
//   order the CPU's `gather_fdef` adds them in for that grid point, so a run repeats bit for bit
//   and sums as the CPU does. Stored on the grid point (the step reads it, as do a read-back
//   and the energy check).
// - `step_gridpoints`: v⁺ = [v⁻(1 − αΔt/2) + F/m Δt] / (1 + αΔt/2) per grid point (the rigid
//   blocks' law, eqs. 9–10), the position as a compensated pair, the too-fast and non-finite
//   checks with the grid point's block.
// - `zones`: the inverted-zone check (a zone whose signed area is not positive raises
//   ERR_ZONE_INVERTED with the lowest such zone), then Δσ from the strain rate times Δt.
//
// A fixed block's grid points stay still and its zones unstressed by the step, as on the CPU.

// The force a zone of stress s exerts on its corner n (−A σ·∇N_n; twin of `fdef::nodal_forces`).
fn nodal_forces(p: array<vec2<real>, 3>, s: array<real, 3>, n: u32) -> vec2<real> {
    var q = p;
    let a = q[(n + 1u) % 3u];
    let b = q[(n + 2u) % 3u];
    let gx = a.y - b.y;
    let gy = b.x - a.x;
    return vec2<real>(-0.5 * (s[0] * gx + s[1] * gy), -0.5 * (s[1] * gx + s[2] * gy));
}

// The strain rate (11, 12, 22) of the triangle p whose corners move at v, twice its area a2
// (twin of `fdef::strain_rate`): ε̇_ij = ½ Σ_n (v_i ∂N_n/∂x_j + v_j ∂N_n/∂x_i).
fn strain_rate(p: array<vec2<real>, 3>, v: array<vec2<real>, 3>, a2: real) -> vec3<real> {
    var e11 = real(0.0);
    var e22 = real(0.0);
    var e12 = real(0.0);
    for (var n = 0u; n < 3u; n += 1u) {
        var q = p;
        var w = v;
        let a = q[(n + 1u) % 3u];
        let b = q[(n + 2u) % 3u];
        let g = vec2<real>(a.y - b.y, b.x - a.x);
        e11 += w[n].x * g.x;
        e22 += w[n].y * g.y;
        e12 += w[n].x * g.y + w[n].y * g.x;
    }
    return vec3<real>(e11 / a2, 0.5 * e12 / a2, e22 / a2);
}

// The stress increment of the strain increment d (11, 12, 22) in plane strain (twin of
// `fdef::stress_increment`).
fn stress_increment(d: vec3<real>, lambda: real, shear: real) -> vec3<real> {
    return vec3<real>((lambda + 2.0 * shear) * d.x + lambda * d.z, 2.0 * shear * d.y, lambda * d.x + (lambda + 2.0 * shear) * d.z);
}

// Stage 6 for grid point g (twin of `cpu::zones::gather_fdef`, for one grid point).
fn gridpoint_force(g: u32, gp: GridPoint) -> vec2<real> {
    return gridpoint_force_from(g, gp, vec2<real>(gp.mass * params.gx + gp.load_x, gp.mass * params.gy + gp.load_y));
}

// `gridpoint_force` from `f_in`: gravity's and the load's share, and in a scene with fluid the
// grid point's fluid load after them (`gather_gridpoints_fluid`).
fn gridpoint_force_from(g: u32, gp: GridPoint, f_in: vec2<real>) -> vec2<real> {
    var f = f_in;
    if (gp.boundary != 0u) {
        let b = gp.block;
        if (gp.listed != 0u) {
            // Its own list (`GridPointContacts`): the entries of its block's list that may act
            // on it, in the block's order, after the zone CSR in the same array.
            let lists = gridpoint_zones[arrayLength(&gridpoints)];
            for (var e = gridpoint_zones[lists + g]; e < gridpoint_zones[lists + g + 1u]; e += 1u) {
                add_entry_share(g, gridpoint_zones[e], &f);
            }
        } else {
            for (var e = adj_offsets[b]; e < adj_offsets[b + 1u]; e += 1u) {
                add_entry_share(g, adj_entries[e], &f);
            }
        }
    }
    for (var e = gridpoint_zones[g]; e < gridpoint_zones[g + 1u]; e += 1u) {
        let entry = gridpoint_zones[e];
        let z = zone_list[entry >> 2u];
        f += nodal_forces(zone_points(z), z.stress, entry & 3u);
    }
    return f;
}

// Adds to `f` what the adjacency entry `entry` of grid point g's block gives g of its contact's
// force (twin of the contact term of `cpu::zones::gather_fdef`): on block 1 all of it where g is
// the corner, on block 2 the reaction's shares where g is one of the feature's grid points (a
// share of zero adds nothing, as on the CPU); nothing where the contact does not act on g.
fn add_entry_share(g: u32, entry: u32, f: ptr<function, vec2<real>>) {
    let k = entry_contact(entry);
    let side = entry_side(entry);
    let sign = select(real(1.0), real(-1.0), side == 1u);
    let fk = vec2<real>(sign * contact_forces_out[k].fx, sign * contact_forces_out[k].fy);
    let share = contact_shares[k];
    if (side == 0u) {
        if (share.g1 == g) {
            *f += fk;
        }
    } else {
        if (share.g2a == g && share.wa != 0.0) {
            *f += share.wa * fk;
        }
        if (share.g2b == g && share.wb != 0.0) {
            *f += share.wb * fk;
        }
    }
}

// How far (in edges round the boundary) a contact's feature on a zoned block may move from where
// it was when the grid points' contact lists were built (`gpu::fdef::LIST_REACH`): an entry is
// on the lists of the grid points of the edges within this reach of that feature, and a contact
// stage moves a feature by one edge at most.
const LIST_REACH: u32 = 2u;

// Whether contact k's feature on its block 2, if that block is zoned and its boundary grid
// points gather from their own lists (`GridPointContacts`), could be moved out of its lists'
// reach by the next contact stage (`LIST_REACH` edges from the feature's edge when they were
// built, stored after the lists); if so its block's boundary grid points walk the block's whole
// list (`GridPoint::listed` cleared) until the lists are built again, and the sums stay the
// walk's. One invocation per contact, each cycle before the contact stage (after the last one:
// its features); twin of the lists' reach in `gpu::fdef::GridPointContacts::of`.
@compute @workgroup_size(WORKGROUP_SIZE)
fn check_fdef_lists(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    if (k >= params.n_contacts) {
        return;
    }
    // A block that is not zoned has a zero record (no boundary).
    let fb = fdef_blocks[contacts[k].block2];
    let n = fb.boundary;
    // A block of few corners has every entry of its side 2 on every list.
    if (n <= 2u * LIST_REACH + 2u || gridpoints[fb.gp_start].listed == 0u) {
        return;
    }
    let n_gp = arrayLength(&gridpoints);
    let homes = gridpoint_zones[gridpoint_zones[n_gp] + n_gp];
    let j = min(contacts[k].feature, 2u * n - 1u) / 2u;
    let j0 = gridpoint_zones[homes + k];
    let d = select(j0 - j, j - j0, j >= j0);
    if (min(d, n - d) + 1u > LIST_REACH) {
        for (var g = fb.gp_start; g < fb.gp_start + n; g += 1u) {
            gridpoints[g].listed = 0u;
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gather_gridpoints(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let g = item_index(wg, li);
    if (g >= arrayLength(&gridpoints)) {
        return;
    }
    let f = gridpoint_force(g, gridpoints[g]);
    gridpoints[g].fx = f.x;
    gridpoints[g].fy = f.y;
}

// Stage 1 for grid point g, its force gathered (twin of the motion in `cpu::zones::step_fdef`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn step_gridpoints(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let g = item_index(wg, li);
    if (g >= arrayLength(&gridpoints)) {
        return;
    }
    step_gridpoint(g);
}

// `step_gridpoints`' step of grid point g; whether it moved (not where its block is fixed or it
// has no mass).
fn step_gridpoint(g: u32) -> bool {
    var gp = gridpoints[g];
    if (gp.fixed != 0u) {
        gridpoints[g].vx = 0.0;
        gridpoints[g].vy = 0.0;
        return false;
    }
    if (!(gp.mass > 0.0)) {
        return false;
    }
    let dt = params.dt;
    let con1 = 1.0 - 0.5 * params.alpha * dt;
    let con2 = 1.0 / (1.0 + 0.5 * params.alpha * dt);
    let v0 = vec2<real>(gp.vx, gp.vy);
    let v = vec2<real>((v0.x * con1 + gp.fx / gp.mass * dt) * con2, (v0.y * con1 + gp.fy / gp.mass * dt) * con2);
    let d = vec2<real>(v.x * dt, v.y * dt);
    if (params.alpha > 0.0) {
        let m = 0.5 * (v0 + v);
        gp.damping_work += params.alpha * dt * gp.mass * (m.x * m.x + m.y * m.y);
    }
    let one = real(params.one);
    let sx = two_sum(gp.x, d.x + gp.x_lo, one);
    let sy = two_sum(gp.y, d.y + gp.y_lo, one);
    let work = (gp.mass * params.gx + gp.load_x) * d.x + (gp.mass * params.gy + gp.load_y) * d.y;
    gridpoints[g].vx = v.x;
    gridpoints[g].vy = v.y;
    gridpoints[g].x = sx.x;
    gridpoints[g].x_lo = sx.y;
    gridpoints[g].y = sy.x;
    gridpoints[g].y_lo = sy.y;
    gridpoints[g].work = gp.work + work;
    gridpoints[g].damping_work = gp.damping_work;
    if (!is_finite(work)) {
        atomicOr(&flags.errors, ERR_NONFINITE);
        atomicMin(&flags.nonfinite_block, gp.block);
    }
    if (sqrt(d.x * d.x + d.y * d.y) > params.fast_limit) {
        atomicOr(&flags.errors, ERR_TOO_FAST);
        atomicMin(&flags.toofast_block, gp.block);
    }
    return true;
}

// Stage 3 for zone z (twin of `cpu::zones::zones`, for one zone).
@compute @workgroup_size(WORKGROUP_SIZE)
fn zones(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let z = item_index(wg, li);
    if (z >= arrayLength(&zone_list)) {
        return;
    }
    let zone = zone_list[z];
    let fb = fdef_blocks[zone.block];
    if (fb.fixed != 0u) {
        return;
    }
    let p = zone_points(zone);
    let a2 = twice_area(p[0], p[1], p[2]);
    // Not positive, or NaN: turned inside out.
    if (!(a2 > 0.0)) {
        atomicOr(&flags.errors, ERR_ZONE_INVERTED);
        atomicMin(&flags.inverted_zone, z);
        return;
    }
    let v = array<vec2<real>, 3>(
        vec2<real>(gridpoints[zone.g0].vx, gridpoints[zone.g0].vy),
        vec2<real>(gridpoints[zone.g1].vx, gridpoints[zone.g1].vy),
        vec2<real>(gridpoints[zone.g2].vx, gridpoints[zone.g2].vy),
    );
    let ds = stress_increment(strain_rate(p, v, a2) * params.dt, fb.lambda, fb.shear);
    zone_list[z].stress = array<real, 3>(zone.stress[0] + ds.x, zone.stress[1] + ds.y, zone.stress[2] + ds.z);
}

// Stage 5's loads on zoned blocks' grid points in a scene with fluid (twin of the grid points'
// share of `model::fluid::deformable_pressure_loads` and of `cpu::zones::gather_fdef`'s fluid),
// one invocation per zoned block, after `fluid_block_loads`: the pieces of its boundary
// (`pressure_pieces`, flow.wgsl) in ascending link order (`block_pieces`: the CPU's order),
// each adding its two shares to its edge's grid points; then each grid point's load, its share
// of the block's buoyancy by mass plus, on the boundary, its pressures' shares.
@compute @workgroup_size(WORKGROUP_SIZE)
fn gridpoint_fluid_loads(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks || blocks[b].kind != BLOCK_FDEF) {
        return;
    }
    let blk = blocks[b];
    let fb = fdef_blocks[b];
    let end = fb.gp_start + fb.gp_count;
    for (var g = fb.gp_start; g < end; g += 1u) {
        gridpoint_fluid[g].fx = 0.0;
        gridpoint_fluid[g].fy = 0.0;
    }
    let n = max(blk.corner_count, 1u);
    for (var e = block_pieces[b]; e < block_pieces[b + 1u]; e += 1u) {
        let piece = fluid_pieces[block_pieces[e]];
        if (piece.edge == NO_INDEX) {
            continue;
        }
        let gi = fb.gp_start + piece.edge % n;
        let gj = fb.gp_start + (piece.edge + 1u) % n;
        gridpoint_fluid[gi].fx += piece.a0;
        gridpoint_fluid[gi].fy += piece.a1;
        gridpoint_fluid[gj].fx += piece.a2;
        gridpoint_fluid[gj].fy += piece.a3;
    }
    // The CPU's share of the load: by mass over the block's (never zero).
    let total = max(blk.mass, real(1e-30));
    let buoy = vec2<real>(fluid_loads[b].buoy_x, fluid_loads[b].buoy_y);
    for (var g = fb.gp_start; g < end; g += 1u) {
        let share = gridpoints[g].mass / total;
        var p = vec2<real>(0.0, 0.0);
        if (g - fb.gp_start < fb.boundary) {
            p = vec2<real>(gridpoint_fluid[g].fx, gridpoint_fluid[g].fy);
        }
        gridpoint_fluid[g].fx = buoy.x * share + p.x;
        gridpoint_fluid[g].fy = buoy.y * share + p.y;
    }
}

// `gather_gridpoints` in a scene with fluid: each grid point's fluid load
// (`gridpoint_fluid_loads`) added after gravity's and the load's share, before its contacts and
// zones (`cpu::zones::gather_fdef`'s order).
@compute @workgroup_size(WORKGROUP_SIZE)
fn gather_gridpoints_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let g = item_index(wg, li);
    if (g >= arrayLength(&gridpoints)) {
        return;
    }
    let gp = gridpoints[g];
    let l = vec2<real>(gridpoint_fluid[g].fx, gridpoint_fluid[g].fy);
    var f = vec2<real>(gp.mass * params.gx + gp.load_x, gp.mass * params.gy + gp.load_y);
    f += l;
    f = gridpoint_force_from(g, gp, f);
    gridpoints[g].fx = f.x;
    gridpoints[g].fy = f.y;
}

// `step_gridpoints` in a scene with fluid: the step, and the work the grid point's fluid load
// did over it at the mean velocity, F·½(v_old + v_new)·Δt (`cpu::zones::step_fdef`: the grid
// points' fluid springs are stiff and light, and the forward product would leave the ledger off
// by ½ΣΔF·Δx), kept for its block's pass (`law_of_motion_fdef_fluid`); none where it did not move.
@compute @workgroup_size(WORKGROUP_SIZE)
fn step_gridpoints_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let g = item_index(wg, li);
    if (g >= arrayLength(&gridpoints)) {
        return;
    }
    let v0 = vec2<real>(gridpoints[g].vx, gridpoints[g].vy);
    var w = real(0.0);
    if (step_gridpoint(g)) {
        let v = vec2<real>(gridpoints[g].vx, gridpoints[g].vy);
        let l = vec2<real>(gridpoint_fluid[g].fx, gridpoint_fluid[g].fy);
        w = 0.5 * params.dt * (l.x * (v0.x + v.x) + l.y * (v0.y + v.y));
    }
    gridpoint_fluid[g].step_work = w;
}
