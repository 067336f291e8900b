//! What stage 6 reads of a contact, and the sum itself: a block's force and moment from its
//! contacts (eq. 12 in two dimensions, M = r × F) in the fixed order of its adjacency list, plus
//! gravity and its load. The CPU's gather stage (`cpu::gather`), a crack's re-made contacts
//! (`topology::cracking`) and the GPU's checkpoint restore all sum with this one function.

use crate::udec::model::{Block, Contact};

/// One entry of a block's contact list (`topology::Adjacency`): a contact and the side of it the
/// block is on (0: the contact's block 1, which receives the contact force; 1: block 2, which
/// receives the reaction, report ¶19). Stored as contact · 2 + side in one u32, so that the lists
/// upload to the GPU as they are; `entry_contact`, `entry_side` and `make_entry` in
/// `shaders/udec/layout.wgsl` are the WGSL twins. Entries order by contact, then side.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AdjacencyEntry(u32);

impl AdjacencyEntry {
    /// The entry of `contact` for the block on `side` (0 or 1).
    #[inline]
    pub const fn new(contact: u32, side: u32) -> Self {
        debug_assert!(side < 2 && contact < 1 << 31);
        AdjacencyEntry(contact << 1 | side)
    }

    /// The contact's index in `Model::contacts`.
    #[inline]
    pub const fn contact(self) -> u32 {
        self.0 >> 1
    }

    /// 0 when the block is the contact's block 1, 1 when it is block 2.
    #[inline]
    pub const fn side(self) -> u32 {
        self.0 & 1
    }

    /// The same side of contact `contact` (after the contact list was renumbered).
    #[inline]
    pub const fn with_contact(self, contact: u32) -> Self {
        Self::new(contact, self.side())
    }

    /// The encoded word, as the GPU holds it.
    #[inline]
    pub const fn raw(self) -> u32 {
        self.0
    }

    /// The entry whose encoded word is `raw` (from a parallel build's atomic slots).
    #[inline]
    pub const fn from_raw(raw: u32) -> Self {
        AdjacencyEntry(raw)
    }
}

/// What the gather reads of a contact: the point its force acts at and the force on block 1. The
/// contact stage writes this copy beside each contact (32 bytes against the contact's 160), so
/// that the gather's scattered reads, the memory-bound part of a cycle on large models, touch one
/// cache line for every two contacts instead of two lines for each (hot and cold data, STYLE.md 5).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactForce {
    pub point: [f64; 2],
    pub force: [f64; 2],
}

impl From<&Contact> for ContactForce {
    #[inline]
    fn from(c: &Contact) -> Self {
        ContactForce { point: c.point, force: c.force }
    }
}

/// The forces acting on a block from its adjacency entries (`topology::Adjacency::entries`), in
/// the entries' fixed order: each contact's point and its force on this block, the contact force
/// on block 1 and its reaction on block 2 (report ¶19). `forces[k]` is contact k's (see
/// [`ContactForce`]).
#[inline]
pub fn forces_on<'a>(forces: &'a [ContactForce], entries: &'a [AdjacencyEntry]) -> impl Iterator<Item = ContactForce> + 'a {
    entries.iter().map(|&entry| {
        let contact = &forces[entry.contact() as usize];
        let sign = if entry.side() == 0 { 1.0 } else { -1.0 };
        ContactForce { point: contact.point, force: [sign * contact.force[0], sign * contact.force[1]] }
    })
}

/// Sums the forces acting on `block` from its adjacency entries ([`forces_on`]), with gravity
/// and its load.
#[inline]
pub fn gather(block: &mut Block, forces: &[ContactForce], entries: &[AdjacencyEntry], gravity: [f64; 2]) {
    let mut fx = block.mass * gravity[0] + block.load[0];
    let mut fy = block.mass * gravity[1] + block.load[1];
    let mut m = 0.0;
    let [cx, cy] = block.centroid;
    for ContactForce { point: [px, py], force: [gx, gy] } in forces_on(forces, entries) {
        fx += gx;
        fy += gy;
        m += (px - cx) * gy - (py - cy) * gx;
    }
    block.force = [fx, fy];
    block.moment = m;
}

/// The applied stress times area of a simply-deformable block (`model::sdef`, the report's KSA):
/// Σ r_i f_j over its adjacency entries ([`forces_on`]), f the force on the block and r from its
/// centroid to the contact point. Gravity and the load act at the centroid and add nothing.
#[inline]
pub fn gather_applied_stress(block: &Block, forces: &[ContactForce], entries: &[AdjacencyEntry]) -> [f64; 4] {
    let mut a = [0.0; 4];
    for f in forces_on(forces, entries) {
        let da = crate::udec::model::sdef::applied_stress(f.point, block.centroid, f.force);
        for (a, d) in a.iter_mut().zip(da) {
            *a += d;
        }
    }
    a
}
