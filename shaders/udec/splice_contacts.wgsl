// Stage 7's contact list on the device (twins in `gpu::splice`). A contact update on the CPU keeps
// most contacts, drops a few and creates a few, and keeps the kept ones in their order; rather
// than upload the whole new list, the CPU sends what changed and these kernels build the new list
// from the old one on the device.
//
// `splice_contacts`: the new list is a few runs (`detect::ListEdit::runs`), each (first new
// index, source) with the source the old index of its first contact or, with NEW_CONTACT set, the
// index of its first among `created` (uploaded whole with their gather records); the runs end
// with (new length, 0). Each new contact finds its run by a binary search, then copies the whole
// state of its source: a kept contact's shear force and displacement (eq. 18 is incremental), its
// dashpot velocities, its feature and dissipation, and its gather record.
//
// `patch_contacts`, after it on the new list: each patch (length, index, feature) is a kept
// contact the CPU read back for the update. It takes the feature the update found nearest (the
// contact stage measures the geometry from it each cycle) and the law the update decided (its
// length of joint, ¶5; the shear force stays, the history carries over), and its slip and
// dashpot work restart from zero,
// since the CPU has moved what they held onto the f64 bases of the ledger. A kept contact the CPU
// did not read keeps the device's feature and work (its bases stay as they were).
//
// Its own bindings (not common.wgsl's): the old list is read from one pair of buffers and the new
// one written into another, which then take each other's places (`Buffers::swap_contacts`).

const NEW_CONTACT: u32 = 0x80000000u;

@group(0) @binding(0) var<storage, read> old_contacts: array<Contact>;
@group(0) @binding(1) var<storage, read> old_forces: array<ContactForce>;
@group(0) @binding(2) var<storage, read> runs: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read> created: array<Contact>;
@group(0) @binding(4) var<storage, read> created_forces: array<ContactForce>;
@group(0) @binding(5) var<storage, read_write> new_contacts: array<Contact>;
@group(0) @binding(6) var<storage, read_write> new_forces: array<ContactForce>;
@group(0) @binding(7) var<storage, read> patches: array<ContactPatch>;

// The length of the new list: the start of the closing run.
fn new_length() -> u32 {
    return runs[arrayLength(&runs) - 1u].x;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn splice_contacts(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    let last = arrayLength(&runs) - 1u;
    if (i >= runs[last].x) {
        return;
    }
    // runs[lo].x <= i < runs[hi].x
    var lo = 0u;
    var hi = last;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (runs[mid].x <= i) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let r = runs[lo];
    let at = (r.y & ~NEW_CONTACT) + (i - r.x);
    if ((r.y & NEW_CONTACT) != 0u) {
        new_contacts[i] = created[at];
        new_forces[i] = created_forces[at];
        return;
    }
    new_contacts[i] = old_contacts[at];
    new_forces[i] = old_forces[at];
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn patch_contacts(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let p = item_index(wg, li);
    if (p >= arrayLength(&patches)) {
        return;
    }
    let k = patches[p].index;
    if (k >= new_length()) {
        return;
    }
    new_contacts[k].feature = patches[p].feature;
    new_contacts[k].length = patches[p].length;
    new_contacts[k].slip_work = real(0.0);
    new_contacts[k].dashpot_work = real(0.0);
}
