// What a contact update needs of each contact, packed for the read-back (twin of
// `gpu::splice::pack_contacts`): the CPU's detection drops a contact by its gap, the energy ledger
// takes its forces and dissipation (`retire`, the bases of the next upload), and the splice that
// follows keeps the feature it follows. 28 of the contact's 72 bytes in f32 (48 of 120 in f64);
// the rest of the contact stays on the device, which the splice builds the new list from.

@group(0) @binding(0) var<storage, read> contacts: array<Contact>;
@group(0) @binding(1) var<storage, read_write> summaries: array<ContactSummary>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn pack_contacts(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= arrayLength(&summaries)) {
        return;
    }
    let c = contacts[i];
    summaries[i] = ContactSummary(c.gap, c.normal_force, c.shear_force, c.slip_work, c.dashpot_work, c.feature, c.bonded);
}
