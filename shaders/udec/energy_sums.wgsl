// The energy check on the device (twin: `Model::energies`, as `cpu::EnergyCheck` uses it): every
// hundred cycles the run must show that kinetic + strain energy has not outgrown the energy put
// in, which would mean the explicit scheme is unstable. Summing on the device means the CPU reads
// back one EnergySum per workgroup instead of the whole model.
//
// Each invocation takes ENERGY_ITEMS blocks and contacts, WORKGROUP_SIZE apart (neighbouring
// invocations read neighbouring items), so a workgroup covers ENERGY_ITEMS × WORKGROUP_SIZE items
// and there are that many times fewer tree reductions: on a software adapter each barrier of a
// reduction switches between the workgroup's SIMD slices, and with one item an invocation the
// check at 10^5 blocks cost as much as a cycle's contact stage on lavapipe (40 ms; 8 ms with 16
// items; reading fields one by one instead of whole structs made no difference there, since
// the compiler drops the loads of fields nobody uses).
//
// Kinetic energy is taken at time t, as the CPU takes it: velocities live at t − Δt/2, and half a
// step of the current force brings them to t. Strain energy is Fn²/2kn + Fs²/2ks. Each invocation
// adds its items in a fixed order and each workgroup reduces by a fixed binary tree, so the sums
// repeat bit for bit; the CPU adds the workgroups' sums in order, in f64.

var<workgroup> partial: array<vec3<real>, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn energy_sums(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let first = workgroup_index(wg) * (WORKGROUP_SIZE * ENERGY_ITEMS) + li;
    let h = 0.5 * params.dt;
    var e = vec3<real>(0.0, 0.0, 0.0);
    for (var k = 0u; k < ENERGY_ITEMS; k++) {
        let i = first + k * WORKGROUP_SIZE;
        if (i < params.n_blocks) {
            let mass = blocks[i].mass;
            if (blocks[i].fixed == 0u && mass > 0.0) {
                let vx = blocks[i].vx + blocks[i].fx / mass * h;
                let vy = blocks[i].vy + blocks[i].fy / mass * h;
                let inertia = blocks[i].inertia;
                var w = blocks[i].w;
                if (inertia > 0.0) {
                    w += blocks[i].moment / inertia * h;
                }
                e.x += 0.5 * mass * (vx * vx + vy * vy) + 0.5 * inertia * w * w;
            }
            e.z += blocks[i].work;
        }
        if (i < params.n_contacts) {
            let mat = contact_law(materials[contacts[i].material], contacts[i].length);
            if (mat.kn > 0.0) {
                let fn_ = contacts[i].normal_force;
                e.y += fn_ * fn_ / (2.0 * mat.kn);
            }
            if (mat.ks > 0.0) {
                let fs = contacts[i].shear_force;
                e.y += fs * fs / (2.0 * mat.ks);
            }
        }
    }
    let t = workgroup_sum(li, e);
    if (li == 0u) {
        energy_sums_out[workgroup_index(wg)] = EnergySum(t.x, t.y, t.z);
    }
}

// The sum of every invocation's `e` in the workgroup, by a fixed binary tree (so it repeats bit
// for bit); called by every invocation (it holds barriers), meaningful in invocation 0.
fn workgroup_sum(li: u32, e: vec3<real>) -> vec3<real> {
    partial[li] = e;
    workgroupBarrier();
    for (var s = WORKGROUP_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            partial[li] += partial[li + s];
        }
        workgroupBarrier();
    }
    return partial[0];
}

// The energy check's share of simply-deformable blocks, dispatched after `energy_sums` on the
// same grid in a scene that has them: each workgroup adds its SDEF blocks' strain modes to the
// sum `energy_sums` wrote, their kinetic energy at time t (the rate brought to the whole step by
// half a step of the generalised force the gather pass left, `sdef::rate_at_whole_step`) and
// their strain energy ½a σ:ε (twins of `Model::energies`' SDEF terms).
@compute @workgroup_size(WORKGROUP_SIZE)
fn energy_sums_sdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let first = workgroup_index(wg) * (WORKGROUP_SIZE * ENERGY_ITEMS) + li;
    let h = 0.5 * params.dt;
    var e = vec3<real>(0.0, 0.0, 0.0);
    for (var k = 0u; k < ENERGY_ITEMS; k++) {
        let i = first + k * WORKGROUP_SIZE;
        if (i < params.n_blocks && blocks[i].kind == BLOCK_SDEF) {
            let x = sdefs[i];
            if (blocks[i].fixed == 0u) {
                var theta = blocks[i].rotation;
                if (EXACT_CIRCLE) {
                    theta += blocks[i].rotation_lo;
                }
                let j = strain_inertia(x.moments, sin_cos(theta));
                if (j.x > 0.0 && j.z > 0.0) {
                    let r = vec3<real>(x.strain_rate[0], x.strain_rate[1], x.strain_rate[2]) + generalised_force(x) / j * h;
                    e.x += 0.5 * (j.x * r.x * r.x + 2.0 * j.y * r.y * r.y + j.z * r.z * r.z);
                }
            }
            e.y += 0.5 * x.area * (x.stress[0] * x.strain[0] + 2.0 * x.stress[1] * x.strain[1] + x.stress[2] * x.strain[2]);
        }
    }
    let t = workgroup_sum(li, e);
    if (li == 0u) {
        let w = workgroup_index(wg);
        energy_sums_out[w].kinetic += t.x;
        energy_sums_out[w].strain += t.y;
    }
}

// Strain energy of a zone of area `area` and stress s in plane strain (twin of
// `fdef::zone_strain_energy`): (σ11 + σ22)²/(8(λ + G)) + (σ11 − σ22)²/(8G) + σ12²/(2G) per unit
// area.
fn zone_strain_energy(s: array<real, 3>, area: real, lambda: real, shear: real) -> real {
    let sum = s[0] + s[2];
    var w = real(0.0);
    if (lambda + shear > 0.0) {
        w = sum * sum / (8.0 * (lambda + shear));
    }
    if (shear > 0.0) {
        let diff = s[0] - s[2];
        w += diff * diff / (8.0 * shear) + s[1] * s[1] / (2.0 * shear);
    }
    return w * area;
}

// The energy check's share of zoned fully-deformable blocks, dispatched after `energy_sums` on
// the same grid in a scene that has them (the grid then covers the grid points and zones too):
// each workgroup adds its grid points' kinetic energy at time t (half a step of the force the
// gather pass left, as `Model::energies` takes it; a free block's only) and their work since the
// upload, and its zones' strain energy (twins of `Model::energies`' FDEF terms).
@compute @workgroup_size(WORKGROUP_SIZE)
fn energy_sums_fdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let first = workgroup_index(wg) * (WORKGROUP_SIZE * ENERGY_ITEMS) + li;
    let h = 0.5 * params.dt;
    var e = vec3<real>(0.0, 0.0, 0.0);
    for (var k = 0u; k < ENERGY_ITEMS; k++) {
        let i = first + k * WORKGROUP_SIZE;
        if (i < arrayLength(&gridpoints)) {
            let gp = gridpoints[i];
            if (gp.fixed == 0u && gp.mass > 0.0) {
                let v = vec2<real>(gp.vx + gp.fx / gp.mass * h, gp.vy + gp.fy / gp.mass * h);
                let at_t = 0.5 * gp.mass * (v.x * v.x + v.y * v.y);
                if (is_finite(at_t)) {
                    e.x += at_t;
                } else {
                    e.x += 0.5 * gp.mass * (gp.vx * gp.vx + gp.vy * gp.vy);
                }
            }
            e.z += gp.work;
        }
        if (i < arrayLength(&zone_list)) {
            let z = zone_list[i];
            let fb = fdef_blocks[z.block];
            let p = zone_points(z);
            e.y += zone_strain_energy(z.stress, 0.5 * twice_area(p[0], p[1], p[2]), fb.lambda, fb.shear);
        }
    }
    let t = workgroup_sum(li, e);
    if (li == 0u) {
        let w = workgroup_index(wg);
        energy_sums_out[w].kinetic += t.x;
        energy_sums_out[w].strain += t.y;
        energy_sums_out[w].work += t.z;
    }
}

// The energy check's share of the fluid, dispatched after `energy_sums` on the same grid in a
// scene with fluid: each workgroup adds its blocks' fluid work since the upload (the ledger's
// `fluid_work`, which the check counts with the external work, as the CPU's does).
@compute @workgroup_size(WORKGROUP_SIZE)
fn energy_sums_fluid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let first = workgroup_index(wg) * (WORKGROUP_SIZE * ENERGY_ITEMS) + li;
    var e = vec3<real>(0.0, 0.0, 0.0);
    for (var k = 0u; k < ENERGY_ITEMS; k++) {
        let i = first + k * WORKGROUP_SIZE;
        if (i < params.n_blocks) {
            e.z += fluid_loads[i].work;
        }
    }
    let t = workgroup_sum(li, e);
    if (li == 0u) {
        energy_sums_out[workgroup_index(wg)].work += t.z;
    }
}
