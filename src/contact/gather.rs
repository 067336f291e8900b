//! What stage 6 reads of a contact, and the sum itself: a block's force and moment from its
//! contacts (eq. 12 in two dimensions, M = r × F) in the fixed order of its adjacency list, plus
//! gravity and its load. The CPU's gather stage (`cpu::gather`), a crack's re-made contacts
//! (`topology::cracking`) and the GPU's checkpoint restore all sum with this one function.

use crate::model::{Block, Contact};

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

/// Sums the forces acting on `block` from its adjacency entries (`topology::Adjacency::entries`);
/// `forces[k]` is contact k's (see [`ContactForce`]).
#[inline]
pub fn gather(block: &mut Block, forces: &[ContactForce], entries: &[u32], gravity: [f64; 2]) {
    let mut fx = block.mass * gravity[0] + block.load[0];
    let mut fy = block.mass * gravity[1] + block.load[1];
    let mut m = 0.0;
    let [cx, cy] = block.centroid;
    for &entry in entries {
        let contact = &forces[(entry >> 1) as usize];
        // Block 1 receives the contact force, block 2 its reaction (report ¶19).
        let sign = if entry & 1 == 0 { 1.0 } else { -1.0 };
        let [px, py] = contact.point;
        let (gx, gy) = (sign * contact.force[0], sign * contact.force[1]);
        fx += gx;
        fy += gy;
        m += (px - cx) * gy - (py - cy) * gx;
    }
    block.force = [fx, fy];
    block.moment = m;
}
