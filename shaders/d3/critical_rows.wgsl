// The critical time step's largest row on the device (twin: the rows of
// `Model::critical_timestep_with`, held blocks unyielding): the Gershgorin bound on the stiffest
// mode. Each block's row is the larger of k_max times its compliance at its radius (`row0`,
// worked out with the block's `StepGive` on the CPU when the state is uploaded) and the sum over
// its live logical contacts of k(a + √(a a')), k the contact's stiffer spring and a, a' the
// compliances of the block and of the other at the logical contact's point (`compliance`); each
// workgroup gives the largest of its blocks' rows, the CPU the largest of those and the step from
// it (`Model::critical_step_of`). The sums run over the block's adjacency list, which is in the
// contacts' order, each contact's logical contacts in theirs: the CPU's order of additions. So
// the step each batch starts with comes from the state on the device, without bringing the
// contacts back.

// Twin of `d3::gpu::layout::StepGive`.
struct StepGive {
    inverse_mass: real, least: real, least_second: real, row0: real,
    unyielding: u32, spare: u32,
}

@group(0) @binding(9) var<storage, read_write> gives: array<StepGive>;
@group(0) @binding(10) var<storage, read_write> rows_out: array<real>;

var<workgroup> row_part: array<real, WORKGROUP_SIZE>;

// Block `g`'s compliance at a lever arm r (r² given): twin of `model::Give::compliance`.
fn compliance(g: StepGive, r2: real) -> real {
    if (g.unyielding != 0u) {
        return 0.0;
    }
    var strain = real(0.0);
    if (g.least_second > 0.0) {
        strain = r2 / g.least_second;
    }
    var turn = real(0.0);
    if (g.least > 0.0) {
        turn = r2 / g.least;
    }
    return g.inverse_mass + turn + strain;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn critical_rows(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    var row = real(0.0);
    if (i < params.blocks) {
        let g = gives[i];
        var sum = real(0.0);
        let b = blocks[i];
        for (var e = b.adjacency_start; e < b.adjacency_start + b.adjacency_count; e++) {
            let entry = adjacency[e];
            let ci = entry >> 1u;
            let c = contacts[ci];
            var other = c.block2;
            if ((entry & 1u) == 1u) {
                other = c.block1;
            }
            let k = max(c.kn, c.ks);
            let go = gives[other];
            // Both centroids in the frame of the contact's points (`centroid_from`).
            let here = centroid_from(i, c.block1);
            let there = centroid_from(other, c.block1);
            for (var n = c.logical_start; n < c.logical_start + c.logical_count; n++) {
                let l = logicals[n];
                if (l.live == 0u) {
                    continue;
                }
                let p = point_of(l);
                let a = compliance(g, dot3(p - here, p - here));
                let a_other = compliance(go, dot3(p - there, p - there));
                sum += k * (a + sqrt(a * a_other));
            }
        }
        row = max(g.row0, sum);
    }
    row_part[li] = row;
    workgroupBarrier();
    for (var s = WORKGROUP_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            row_part[li] = max(row_part[li], row_part[li + s]);
        }
        workgroupBarrier();
    }
    if (li == 0u) {
        rows_out[wg.y * GROUPS_PER_ROW + wg.x] = row_part[0];
    }
}
