// A partial detection's contacts spliced on the device (twin: `d3::gpu::splice::splice_contacts`;
// `d3::gpu`, "Partial detections"). Between two detections only the contacts of the blocks that
// moved change on the CPU (stage 7 and its stage 4); the others keep the state the device tracks.
// So the CPU uploads only the fresh contacts (their records and logical contacts, found afresh)
// and, for each contact of the new list, where it comes from: `sources[k]` = (the contact it is,
// SPLICE_FRESH set for a fresh one, else its index in the buffers as they were; the start of its
// run in the new logical buffer, the runs in the new contacts' order). Each invocation makes one
// contact of the new list: its record copied, its logical contacts copied to its run (dead ones
// too: they stay in place, as between detections), `logical_start` set to the run's start.
//
// The same kernel gathers the contacts a detection reads back (those of the blocks that moved)
// into short buffers: then every source is a kept one, and the output is the read-back's.
//
// The energy accumulators (friction and released, since the upload) move into the bank: each
// record's are zeroed in the output and summed, per workgroup by a fixed binary tree (the CPU
// adds the workgroups' in order, in f64, into the bases), so that after a splice every
// accumulator counts from the detection, as after a whole upload. Copies only, in a fixed order:
// the output repeats bit for bit.

// Twin of `d3::gpu::layout::Splice`: how many contacts the output holds.
struct Splice {
    contacts: u32, spare0: u32, spare1: u32, spare2: u32,
}

// Twin of `d3::gpu::layout::Banked`: a workgroup's sums of the accumulators it zeroed.
struct Banked {
    friction: real, released: real,
}

// The output is the layout's contacts (binding 5) and logical contacts (binding 6).
@group(0) @binding(9) var<uniform> splice: Splice;
@group(0) @binding(10) var<storage, read> kept_contacts: array<Contact>;
@group(0) @binding(11) var<storage, read> kept_logicals: array<Logical>;
@group(0) @binding(12) var<storage, read> fresh_contacts: array<Contact>;
@group(0) @binding(13) var<storage, read> fresh_logicals: array<Logical>;
@group(0) @binding(14) var<storage, read> sources: array<vec2<u32>>;
@group(0) @binding(15) var<storage, read_write> banked: array<Banked>;

var<workgroup> friction_part: array<real, WORKGROUP_SIZE>;
var<workgroup> released_part: array<real, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn splice_contacts(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    var friction = real(0.0);
    var released = real(0.0);
    if (k < splice.contacts) {
        let source = sources[k];
        let i = source.x & ~SPLICE_FRESH;
        let start = source.y;
        var c: Contact;
        if ((source.x & SPLICE_FRESH) != 0u) {
            c = fresh_contacts[i];
            for (var j = 0u; j < c.logical_count; j++) {
                logicals[start + j] = fresh_logicals[c.logical_start + j];
            }
        } else {
            c = kept_contacts[i];
            for (var j = 0u; j < c.logical_count; j++) {
                logicals[start + j] = kept_logicals[c.logical_start + j];
            }
        }
        friction = c.friction_work;
        released = c.released_work;
        c.friction_work = 0.0;
        c.released_work = 0.0;
        c.logical_start = start;
        contacts[k] = c;
    }
    friction_part[li] = friction;
    released_part[li] = released;
    workgroupBarrier();
    for (var s = WORKGROUP_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            friction_part[li] += friction_part[li + s];
            released_part[li] += released_part[li + s];
        }
        workgroupBarrier();
    }
    if (li == 0u) {
        banked[wg.y * GROUPS_PER_ROW + wg.x] = Banked(friction_part[0], released_part[0]);
    }
}
