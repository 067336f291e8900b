// The energy check on the device (twin: `Model::energies`, as `cpu::EnergyCheck` uses it): every
// hundred cycles the run must show that kinetic + strain energy has not outgrown the energy put
// in, which would mean the explicit scheme is unstable. Summing on the device means the CPU reads
// back one EnergySum per workgroup instead of the whole model.
//
// Invocation i takes block i and contact i. Kinetic energy is taken at time t, as the CPU takes
// it: velocities live at t − Δt/2, and half a step of the current force brings them to t. Strain
// energy is Fn²/2kn + Fs²/2ks. Each workgroup reduces its values by a fixed binary tree, so the
// sums repeat bit for bit; the CPU adds the workgroups' sums in order, in f64.

var<workgroup> partial: array<vec3<real>, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn energy_sums(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    var e = vec3<real>(0.0, 0.0, 0.0);
    if (i < params.n_blocks) {
        let b = blocks[i];
        if (b.fixed == 0u && b.mass > 0.0) {
            let h = 0.5 * params.dt;
            let vx = b.vx + b.fx / b.mass * h;
            let vy = b.vy + b.fy / b.mass * h;
            var w = b.w;
            if (b.inertia > 0.0) {
                w += b.moment / b.inertia * h;
            }
            e.x = 0.5 * b.mass * (vx * vx + vy * vy) + 0.5 * b.inertia * w * w;
        }
        e.z = b.work;
    }
    if (i < params.n_contacts) {
        let c = contacts[i];
        let mat = materials[c.material];
        if (mat.kn > 0.0) {
            e.y += c.normal_force * c.normal_force / (2.0 * mat.kn);
        }
        if (mat.ks > 0.0) {
            e.y += c.shear_force * c.shear_force / (2.0 * mat.ks);
        }
    }
    partial[li] = e;
    workgroupBarrier();
    for (var s = WORKGROUP_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            partial[li] += partial[li + s];
        }
        workgroupBarrier();
    }
    if (li == 0u) {
        let t = partial[0];
        energy_sums_out[workgroup_index(wg)] = EnergySum(t.x, t.y, t.z);
    }
}
