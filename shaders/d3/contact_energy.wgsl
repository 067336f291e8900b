// The energy check's share of the contacts, on the device (twin: `d3::model::contact_energy`,
// summed by `Model::energies`; and `cpu::overlap_check`): every hundred cycles a run shows that
// kinetic + strain energy has not outgrown the energy put in (an unstable explicit scheme grows
// exponentially) and that no contact has been driven through. The blocks' terms come from the
// blocks the CPU reads back after every batch; the contacts' springs, ½Fn²/kn + ½|Fs|²/ks over
// the live logical contacts, are summed here, so the check reads back one record per workgroup
// instead of every contact and logical contact (the time step comes from critical_rows.wgsl).
//
// Each invocation takes ENERGY_ITEMS contacts, WORKGROUP_SIZE apart (neighbouring invocations on
// neighbouring contacts), adds them in a fixed order, and each workgroup reduces by a fixed
// binary tree: the sums repeat bit for bit; the CPU adds the workgroups' in order, in f64.
//
// Driven through (`cpu::driven_through`): a contact whose deepest live logical contact overlaps
// by more than half the smaller of its blocks' radii. Each workgroup gives the first such
// contact it holds (the least index; NONE where none), and the CPU reads the contacts back and
// names it as its own check would.

// Twin of `d3::gpu::layout::ContactEnergy`.
struct ContactEnergy {
    strain: real,
    driven: u32, spare: u32,
}

@group(0) @binding(9) var<storage, read_write> energy_out: array<ContactEnergy>;

const ENERGY_ITEMS: u32 = 16u;
const NONE: u32 = 0xffffffffu;

var<workgroup> strain_part: array<real, WORKGROUP_SIZE>;
var<workgroup> driven_part: array<u32, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn contact_energy(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let group = wg.y * GROUPS_PER_ROW + wg.x;
    let first = group * (WORKGROUP_SIZE * ENERGY_ITEMS) + li;
    var strain = real(0.0);
    var driven = NONE;
    for (var k = 0u; k < ENERGY_ITEMS; k++) {
        let ci = first + k * WORKGROUP_SIZE;
        if (ci < params.contacts) {
            let c = contacts[ci];
            var deepest = real(0.0);
            var live = false;
            for (var i = c.logical_start; i < c.logical_start + c.logical_count; i++) {
                let l = logicals[i];
                if (l.live == 0u) {
                    continue;
                }
                if (c.kn > 0.0) {
                    strain += 0.5 * l.normal_force * l.normal_force / c.kn;
                }
                if (c.ks > 0.0) {
                    strain += 0.5 * (l.sx * l.sx + l.sy * l.sy + l.sz * l.sz) / c.ks;
                }
                if (!live || -l.gap > deepest) {
                    deepest = -l.gap;
                }
                live = true;
            }
            let limit = 0.5 * min(blocks[c.block1].radius, blocks[c.block2].radius);
            if (live && deepest > limit && driven == NONE) {
                driven = ci;
            }
        }
    }
    strain_part[li] = strain;
    driven_part[li] = driven;
    workgroupBarrier();
    for (var s = WORKGROUP_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            strain_part[li] += strain_part[li + s];
            driven_part[li] = min(driven_part[li], driven_part[li + s]);
        }
        workgroupBarrier();
    }
    if (li == 0u) {
        energy_out[group] = ContactEnergy(strain_part[0], driven_part[0], 0u);
    }
}
