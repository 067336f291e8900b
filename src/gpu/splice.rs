//! Stage 7's contact list on the device: after a contact update the CPU sends, per contact of the
//! new list, where it comes from (`contact_moves`), and `splice_contacts.wgsl` builds the new list
//! from the old one in place of an upload of the whole list.
//!
//! The CPU's update (`topology::detect`) keeps the surviving contacts in their order, removes the
//! dropped ones and inserts the new ones, whose ids start at the model's `next_contact_id` before
//! the update. So one merge over the ids, old list against new, finds each kept contact's old
//! index; a contact it cannot place (a list the update had to sort, an id out of turn) makes it
//! give up, and the caller uploads the whole list as before. A contact the merge takes for new is
//! uploaded whole from the model, which holds its state, so the only thing the merge must not get
//! wrong is an old index — it matches the contact's corner and blocks as well as its id.
//!
//! What moves is 8 bytes per contact (its source and its feature) plus the created contacts,
//! against 96 (f32) or 168 (f64) bytes per contact for the whole list and its gather records.
//!
//! The read-back before the update is packed the same way (`pack_contacts`): detection and the
//! energy ledger need a contact's gap, forces, dissipation and feature, not its point, normal or
//! dashpot velocities, which stay on the device. The model's copies of those are then stale
//! until the next whole read-back, so the whole-list upload must never follow a packed read:
//! `ContactsBefore::spliceable` says beforehand whether the merge will place every kept contact.

use super::layout::{Contact, ContactForce, ContactSummary, Real};
use crate::model;
use rayon::prelude::*;

/// The source bit of a move that names an entry of the created contacts, not an old index.
pub const NEW_CONTACT: u32 = 0x8000_0000;

/// The feature of a move whose kept contact the CPU did not read (a partial read-back,
/// `gpu::partial`): it keeps the device's feature and its dissipation since its ledger bases,
/// which stay as they were.
pub const KEEP_FEATURE: u32 = u32::MAX;

/// What identifies a contact of the list before an update: its id, block 1, corner and block 2.
pub type ContactKey = [u32; 4];

/// The contact list before an update, as the merge needs it.
pub struct ContactsBefore {
    pub keys: Vec<ContactKey>,
    /// `Model::next_contact_id` before the update: contacts it creates have ids from here on.
    pub first_new_id: u32,
}

impl ContactsBefore {
    pub fn of(model: &model::Model) -> Self {
        let keys = model.contacts.par_iter().with_min_len(4096).map(|c| [c.id, c.block1, c.corner, c.block2]).collect();
        ContactsBefore { keys, first_new_id: model.next_contact_id }
    }

    /// Whether the merge will place every contact the update keeps: the list is in the update's
    /// order (block 1, corner, block 2), which the update then keeps rather than re-sorts, and
    /// every id is below the first new one, so no kept contact is taken for a new one.
    pub fn spliceable(&self) -> bool {
        let n = self.keys.len();
        n < NEW_CONTACT as usize
            && self.keys.par_iter().enumerate().with_min_len(4096).all(|(i, k)| k[0] < self.first_new_id && (i == 0 || self.keys[i - 1][1..] <= k[1..]))
    }
}

/// The new list as moves: `moves[i]` = (source, feature) of contact i, the source an index into
/// the old list or `NEW_CONTACT | k` for `created[k]`, an index into the new list.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ContactMoves {
    pub moves: Vec<[u32; 2]>,
    pub created: Vec<u32>,
}

/// The moves that turn the old list into `new` (the model's list after the update), or None when
/// a kept contact is not found in order after the one before it.
pub fn contact_moves(before: &ContactsBefore, new: &[model::Contact]) -> Option<ContactMoves> {
    let old = &before.keys;
    if old.len() >= NEW_CONTACT as usize || new.len() >= NEW_CONTACT as usize {
        return None;
    }
    let mut out = ContactMoves { moves: Vec::with_capacity(new.len()), created: Vec::new() };
    let mut p = 0;
    for (i, c) in new.iter().enumerate() {
        if c.id >= before.first_new_id {
            out.moves.push([NEW_CONTACT | out.created.len() as u32, c.feature]);
            out.created.push(i as u32);
            continue;
        }
        let key = [c.id, c.block1, c.corner, c.block2];
        // Dropped contacts lie between two kept ones: skip them.
        p += old[p..].iter().position(|k| *k == key)?;
        out.moves.push([p as u32, c.feature]);
        p += 1;
    }
    Some(out)
}

/// Rust twin of `splice_contacts.wgsl`: the new list and its gather records from the old ones,
/// the moves and the created contacts (with their records).
pub fn splice_contacts<R: Real>(
    old: &[Contact<R>],
    old_forces: &[ContactForce<R>],
    moves: &[[u32; 2]],
    created: &[Contact<R>],
    created_forces: &[ContactForce<R>],
) -> (Vec<Contact<R>>, Vec<ContactForce<R>>)
where
    Contact<R>: bytemuck::Pod,
    ContactForce<R>: bytemuck::Pod,
{
    moves
        .iter()
        .map(|&[source, feature]| {
            if source & NEW_CONTACT != 0 {
                let k = (source & !NEW_CONTACT) as usize;
                return (created[k], created_forces[k]);
            }
            let mut c = old[source as usize];
            if feature != KEEP_FEATURE {
                c.feature = feature;
                c.slip_work = R::default();
                c.dashpot_work = R::default();
            }
            (c, old_forces[source as usize])
        })
        .unzip()
}

/// Rust twin of `pack_contacts.wgsl`: what a contact update reads back of each contact.
pub fn pack_contacts<R: Real>(contacts: &[Contact<R>]) -> Vec<ContactSummary<R>> {
    contacts
        .iter()
        .map(|c| ContactSummary {
            gap: c.gap,
            normal_force: c.normal_force,
            shear_force: c.shear_force,
            slip_work: c.slip_work,
            dashpot_work: c.dashpot_work,
            feature: c.feature,
            bonded: c.bonded,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;

    fn wall(bricks: usize) -> Model {
        let deck = format!("{}CYCLE 0\n", crate::bench::scene::scaling_wall(bricks, 0.1).deck());
        crate::scenes::run_deck_on(&deck, Box::new(crate::cpu::CpuBackend::new())).expect("the wall builds")
    }

    /// Moves block b by `by` (its corners follow, as after a cycle) and marks it for the update.
    fn shift(model: &mut Model, b: usize, by: [f64; 2]) {
        let blk = &mut model.blocks[b];
        blk.centroid = [blk.centroid[0] + by[0], blk.centroid[1] + by[1]];
        blk.moved_since_update = 1.0;
        let blk = blk.clone();
        let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
        crate::cpu::geometry_update::geometry_update(&blk, &mut model.corners[range]);
    }

    /// The contacts' gaps as the contact stage of a cycle would leave them (the update drops
    /// the contacts of blocks it does not examine by their stored gap).
    fn measure_gaps(model: &mut Model) {
        let Model { blocks, corners, contacts, .. } = model;
        for c in contacts.iter_mut() {
            let b2 = &blocks[c.block2 as usize];
            let corners2 = &corners[b2.corner_start as usize..(b2.corner_start + b2.corner_count) as usize];
            let corner = &corners[c.corner as usize];
            c.gap = crate::cpu::contact_forces::track_feature(corners2, c.feature, corner.circle, corner.radius).gap;
        }
    }

    fn movable(model: &Model) -> Vec<usize> {
        (0..model.blocks.len()).filter(|&b| !model.blocks[b].fixed).collect()
    }

    /// Applies the moves to the old list of model contacts (the twin's logic on the CPU's structs).
    fn apply(old: &[model::Contact], new: &[model::Contact], m: &ContactMoves) -> Vec<model::Contact> {
        m.moves
            .iter()
            .map(|&[s, feature]| if s & NEW_CONTACT != 0 { new[m.created[(s & !NEW_CONTACT) as usize] as usize] } else { model::Contact { feature, ..old[s as usize] } })
            .collect()
    }

    #[test]
    fn moves_rebuild_the_list_a_contact_update_makes() {
        let mut model = wall(1000);
        let mut adjacency = crate::topology::Adjacency::default();
        crate::topology::update_topology(&mut model, true, &mut adjacency);
        // Push a few blocks into their neighbours and lift others away, then update.
        for (k, b) in movable(&model).into_iter().step_by(37).enumerate() {
            shift(&mut model, b, [if k % 2 == 0 { 0.004 } else { -0.3 }, 0.0]);
        }
        measure_gaps(&mut model);
        crate::topology::update_topology(&mut model, false, &mut adjacency);
        let before = ContactsBefore::of(&model);
        let old = model.contacts.clone();
        for (k, b) in movable(&model).into_iter().step_by(23).enumerate() {
            let by = match k % 3 {
                0 => [0.0, 30.0], // far away: every contact dropped
                1 => [0.35, 0.0], // along its course: new corners meet the joints above and below
                _ => [0.0, -0.003],
            };
            shift(&mut model, b, by);
        }
        measure_gaps(&mut model);
        let (created, dropped) = crate::topology::update_topology(&mut model, false, &mut adjacency);
        assert!(created > 0 && dropped > 0, "the update both creates and drops ({created}, {dropped})");
        let m = contact_moves(&before, &model.contacts).expect("kept contacts are in order");
        assert_eq!(m.created.len(), created);
        assert_eq!(m.moves.len(), model.contacts.len());
        let rebuilt = apply(&old, &model.contacts, &m);
        for (a, b) in rebuilt.iter().zip(&model.contacts) {
            assert_eq!((a.id, a.block1, a.corner, a.block2, a.feature), (b.id, b.block1, b.corner, b.block2, b.feature));
            assert_eq!((a.shear_force, a.shear_displacement, a.normal_force), (b.shear_force, b.shear_displacement, b.normal_force));
        }
    }

    #[test]
    fn a_list_out_of_order_has_no_moves() {
        let mut model = wall(1000);
        let mut adjacency = crate::topology::Adjacency::default();
        crate::topology::update_topology(&mut model, true, &mut adjacency);
        let before = ContactsBefore::of(&model);
        let mut new = model.contacts.clone();
        assert_eq!(contact_moves(&before, &new).map(|m| m.created.len()), Some(0));
        assert!(before.spliceable());
        new.swap(3, 10);
        assert_eq!(contact_moves(&before, &new), None);
        let mut swapped = model.clone();
        swapped.contacts.swap(3, 10);
        assert!(!ContactsBefore::of(&swapped).spliceable(), "out of order");
        swapped.contacts.swap(3, 10);
        swapped.contacts[7].id = swapped.next_contact_id;
        assert!(!ContactsBefore::of(&swapped).spliceable(), "an id not below the next");
        // An old id on another pair is not taken for that contact.
        let mut new = model.contacts.clone();
        new[5].corner += 1;
        assert_eq!(contact_moves(&before, &new), None);
    }

    #[test]
    fn the_twin_copies_kept_contacts_with_their_new_feature_and_a_fresh_ledger() {
        let c = |k: u32| Contact::<f64> { px: k as f64, slip_work: 1.0, dashpot_work: 2.0, feature: k, block1: k, ..Default::default() };
        let f = |k: u32| ContactForce::<f64> { fx: k as f64, ..Default::default() };
        let old = [c(0), c(1), c(2)];
        let old_f = [f(0), f(1), f(2)];
        let (new, forces) = splice_contacts(&old, &old_f, &[[2, 9], [NEW_CONTACT, 7], [0, 0]], &[c(5)], &[f(5)]);
        assert_eq!(new.iter().map(|c| (c.block1, c.feature, c.slip_work, c.dashpot_work)).collect::<Vec<_>>(), [(2, 9, 0.0, 0.0), (5, 5, 1.0, 2.0), (0, 0, 0.0, 0.0)]);
        assert_eq!(forces.iter().map(|f| f.fx).collect::<Vec<_>>(), [2.0, 5.0, 0.0]);
    }
}
