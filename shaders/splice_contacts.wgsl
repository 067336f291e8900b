// Stage 7's contact list on the device (twin of `gpu::splice::splice_contacts`). A contact update
// on the CPU keeps most contacts, drops a few and creates a few, and keeps the kept ones in their
// order; rather than upload the whole new list, the CPU sends one move per contact of it and the
// contacts it created, and this kernel builds the new list from the old one on the device.
//
// A move is (source, feature). A kept contact copies its whole state from the old list at
// `source` — its shear force and displacement (eq. 18 is incremental), its dashpot velocities,
// its gather record — and takes the feature the update found nearest (the contact stage measures
// the geometry from it each cycle); its slip and dashpot work restart from zero, since the CPU
// has moved what they held onto the f64 bases of the ledger. A contact the CPU did not read
// (KEEP_FEATURE) keeps its feature and work. A source with NEW_CONTACT set names an entry of
// `created`, uploaded whole with its gather record.
//
// Its own bindings (not common.wgsl's): the old list is read from one pair of buffers and the new
// one written into another, which then take each other's places (`Buffers::swap_contacts`).

const NEW_CONTACT: u32 = 0x80000000u;
// The feature of a kept contact the CPU did not read back (a partial read, `gpu::partial`): it
// keeps the device's feature and its dissipation since its ledger bases, which stay as they were.
const KEEP_FEATURE: u32 = 0xffffffffu;

@group(0) @binding(0) var<storage, read> old_contacts: array<Contact>;
@group(0) @binding(1) var<storage, read> old_forces: array<ContactForce>;
@group(0) @binding(2) var<storage, read> moves: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read> created: array<Contact>;
@group(0) @binding(4) var<storage, read> created_forces: array<ContactForce>;
@group(0) @binding(5) var<storage, read_write> new_contacts: array<Contact>;
@group(0) @binding(6) var<storage, read_write> new_forces: array<ContactForce>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn splice_contacts(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= arrayLength(&moves)) {
        return;
    }
    let m = moves[i];
    if ((m.x & NEW_CONTACT) != 0u) {
        let k = m.x & ~NEW_CONTACT;
        new_contacts[i] = created[k];
        new_forces[i] = created_forces[k];
        return;
    }
    var c = old_contacts[m.x];
    if (m.y != KEEP_FEATURE) {
        c.feature = m.y;
        c.slip_work = real(0.0);
        c.dashpot_work = real(0.0);
    }
    new_contacts[i] = c;
    new_forces[i] = old_forces[m.x];
}
