// Stage 6 for D3, one invocation per block (Rust twin: `d3::cpu::gather`): the block's force and
// moment, its weight and load, the boundary stresses on its faces (BOUNDARY scenes) plus the forces of its contacts' logical contacts with eq. (12)'s
// moments about its centroid, summed in the contacts' order (its adjacency list, built in that
// order), so that the sum is the CPU's, term for term, with no atomics. The dashpots' work over
// the coming step is booked on the contact's block 1.

// The total force a logical contact puts on block 2 (block 1 takes its opposite), the
// stiffness-proportional dashpots included (Rust twin: `contact::logical_force`).
fn logical_force(l: Logical, c: Contact, beta: real) -> vec3<real> {
    let n = normal_of(c);
    var f = n * l.normal_force + shear_of(l);
    if (beta > 0.0 && l.gap <= 0.0) {
        let p = point_of(l);
        let u = velocity_at(c.block2, p, c.block1) - velocity_at(c.block1, p, c.block1);
        let un = dot3(u, n);
        f = f - beta * (c.kn * un * n + c.ks * (u - un * n));
    }
    return f;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gather(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= params.blocks) {
        return;
    }
    let g = vec3<real>(params.gx, params.gy, params.gz);
    let beta = params.beta;
    let dt = params.dt;
    let mass = blocks[i].mass;
    var force = mass * g + vec3<real>(blocks[i].load_x, blocks[i].load_y, blocks[i].load_z);
    var moment = vec3<real>(0.0, 0.0, 0.0);
    var dashpots: real = 0.0;
    // A simply-deformable block's applied stress times volume, Σ r fᵀ (sdef.wgsl), contact by
    // contact in the same order (`cpu::gather`).
    let zero = vec3<real>(0.0, 0.0, 0.0);
    var applied = Mat3(zero, zero, zero);
    if (BOUNDARY) {
        // BOUNDARY STRESS on its faces, before its contacts (`Block::boundary_load`): each face's
        // resultant at its centroid, with its moment and its applied stress times volume.
        let faces = blocks[i].stress_faces;
        if (faces > 0u) {
            let c0 = centroid_from(i, i);
            let records = stress_records(i);
            var bf = zero;
            var bm = zero;
            var ba = Mat3(zero, zero, zero);
            for (var k = 0u; k < faces; k++) {
                let l = face_load(records + 2u * k, c0);
                bf = bf + l.t;
                bm = bm + cross3(l.r, l.t);
                if (SDEF) {
                    ba = mat_add(ba, outer(l.r, l.t));
                }
            }
            force = force + bf;
            moment = moment + bm;
            if (SDEF) {
                applied = mat_add(applied, ba);
            }
        }
    }
    let start = blocks[i].adjacency_start;
    let count = blocks[i].adjacency_count;
    for (var k = 0u; k < count; k++) {
        let entry = adjacency[start + k];
        let c = contacts[entry >> 1u];
        let second = (entry & 1u) == 1u;
        let n = normal_of(c);
        // The block's centroid in the frame of the contact's points (`centroid_from`).
        let c0 = centroid_from(i, c.block1);
        var fc = vec3<real>(0.0, 0.0, 0.0);
        var mc = vec3<real>(0.0, 0.0, 0.0);
        var ac = Mat3(zero, zero, zero);
        for (var j = 0u; j < c.logical_count; j++) {
            let l = logicals[c.logical_start + j];
            if (l.live == 0u) {
                continue;
            }
            let f = logical_force(l, c, beta);
            let p = point_of(l);
            if (!second && beta > 0.0 && l.gap <= 0.0) {
                let u = velocity_at(c.block2, p, c.block1) - velocity_at(c.block1, p, c.block1);
                let un = dot3(u, n);
                let us = u - un * n;
                dashpots += beta * (c.kn * un * un + c.ks * dot3(us, us)) * dt;
            }
            // Eq. (12): positive on block 2, negative on block 1 (¶19).
            if (second) {
                fc = fc + f;
                mc = mc + cross3(p - c0, f);
            } else {
                fc = fc - f;
                mc = mc - cross3(p - c0, f);
            }
            if (SDEF) {
                if (second) {
                    ac = mat_add(ac, outer(p - c0, f));
                } else {
                    ac = mat_sub(ac, outer(p - c0, f));
                }
            }
        }
        force = force + fc;
        moment = moment + mc;
        if (SDEF) {
            applied = mat_add(applied, ac);
        }
    }
    if (SDEF) {
        store_applied(i, applied);
    }
    blocks[i].fx = force.x;
    blocks[i].fy = force.y;
    blocks[i].fz = force.z;
    blocks[i].mx = moment.x;
    blocks[i].my = moment.y;
    blocks[i].mz = moment.z;
    blocks[i].dashpot_work += dashpots;
}
