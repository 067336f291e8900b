//! Stage 7's contact list on the device: after a contact update the CPU sends what the update
//! changed, and `splice_contacts.wgsl` builds the new list from the old one in place of an upload
//! of the whole list.
//!
//! The CPU's update (`topology::detect`) keeps the surviving contacts in their order, removes the
//! dropped ones and inserts the new ones, and records the edit (`detect::ListEdit`: the indices
//! dropped and where the new ones went) when the list was in order on entry. The new list is
//! then a few runs, each a stretch of the old list or of the created contacts
//! (`ListEdit::runs`); the kernel finds each new contact's run by a binary search. What moves to
//! the device is in proportion to the changes: 8 bytes a run, the created contacts whole, and
//! 12 (f32) or 16 (f64) bytes a *patch*, a kept contact the CPU read and may have given a new
//! feature or law (`patch_contacts`: the feature, the length of joint, and a fresh start of its
//! slip and dashpot work, which the CPU's ledger bases now hold). A kept contact the CPU did not read keeps the device's state.
//!
//! The read-back before the update is packed (`pack_contacts`): detection and the energy ledger
//! need a contact's gap, forces, dissipation and feature, not its point, normal or dashpot
//! velocities, which stay on the device. The model's copies of those are then stale until the
//! next whole read-back, so the whole-list upload must never follow a packed read: the caller
//! knows the list is in order beforehand, and so that the update will record its edit.

use super::layout::{Contact, ContactForce, ContactPatch, ContactSummary, Real};
use crate::udec::contact::gather::AdjacencyEntry;
use crate::udec::topology::adjacency::{EntriesEdit, FROM_LISTS};
use crate::udec::topology::detect::ListEdit;

/// The source bit of a run of created contacts (`ListEdit::runs`), not of old ones.
pub const NEW_CONTACT: u32 = 0x8000_0000;

/// Where item i of a list given as runs (first index, source; the binary search of the kernels)
/// comes from: whether its run's source has `bit` set (the second array), and its index there.
fn source_in_runs(runs: &[[u32; 2]], i: u32, bit: u32) -> (bool, usize) {
    let r = runs[runs.partition_point(|r| r[0] <= i) - 1];
    (r[1] & bit != 0, ((r[1] & !bit) + (i - r[0])) as usize)
}

/// Rust twin of `splice_contacts.wgsl`: the new list and its gather records from the old ones,
/// the runs (`ListEdit::runs(NEW_CONTACT)`, ending with the new length) and the created
/// contacts (with their records).
pub fn splice_contacts<R: Real>(
    old: &[Contact<R>],
    old_forces: &[ContactForce<R>],
    runs: &[[u32; 2]],
    created: &[Contact<R>],
    created_forces: &[ContactForce<R>],
) -> (Vec<Contact<R>>, Vec<ContactForce<R>>) {
    let n = runs.last().map_or(0, |r| r[0]);
    (0..n)
        .map(|i| match source_in_runs(runs, i, NEW_CONTACT) {
            (true, at) => (created[at], created_forces[at]),
            (false, at) => (old[at], old_forces[at]),
        })
        .unzip()
}

/// Rust twin of `patch_contacts` (splice_contacts.wgsl): each patch gives a kept contact the
/// feature and the law (length of joint) the CPU's update found and restarts its slip and
/// dashpot work.
pub fn patch_contacts<R: Real>(contacts: &mut [Contact<R>], patches: &[ContactPatch<R>]) {
    for p in patches {
        if let Some(c) = contacts.get_mut(p.index as usize) {
            c.feature = p.feature;
            c.length = p.length;
            c.slip_work = R::default();
            c.dashpot_work = R::default();
        }
    }
}

/// The renumbering of a contact list's edit as `splice_adjacency.wgsl` reads it: (first old
/// index, shift from there on as i32 bits), ascending, the first from index 0: a kept contact k
/// takes the shift of the last entry at or below it (`ListEdit::new_index`).
pub fn renumber_table(edit: &ListEdit) -> Vec<[u32; 2]> {
    let steps = crate::udec::topology::adjacency::renumber_steps(&edit.dropped, &edit.insert_before);
    let mut table: Vec<[u32; 2]> = vec![[0, 0]];
    let mut shift = 0i32;
    for (from, step) in steps {
        shift += step;
        match table.last_mut() {
            Some(last) if last[0] == from => last[1] = shift as u32,
            _ => table.push([from, shift as u32]),
        }
    }
    table
}

/// The touched lists of an adjacency edit as `shift_offsets` reads them: (block, change in length
/// up to and including its list, as i32 bits), ending with (`n_offsets`, 0).
pub fn touched_shifts(edit: &EntriesEdit, n_offsets: usize) -> Vec<[u32; 2]> {
    edit.touched.iter().zip(&edit.shift_after).map(|(&t, &s)| [t, s as i32 as u32]).chain([[n_offsets as u32, 0]]).collect()
}

/// Rust twin of `splice_adjacency` (splice_adjacency.wgsl): the new adjacency entries from the
/// old ones, the edit's runs (`EntriesEdit::runs`), the touched blocks' new lists and the
/// contacts' renumbering (`renumber_table`).
pub fn splice_adjacency(old: &[AdjacencyEntry], runs: &[[u32; 2]], lists: &[AdjacencyEntry], renumber: &[[u32; 2]]) -> Vec<AdjacencyEntry> {
    let n = runs.last().map_or(0, |r| r[0]);
    (0..n)
        .map(|p| {
            let (from_lists, at) = source_in_runs(runs, p, FROM_LISTS);
            if from_lists {
                return lists[at];
            }
            let e = old[at];
            let k = e.contact();
            let shift = renumber[renumber.partition_point(|x| x[0] <= k) - 1][1] as i32;
            e.with_contact((k as i32 + shift) as u32)
        })
        .collect()
}

/// Rust twin of `shift_offsets` (splice_adjacency.wgsl): the offsets moved, in place, by the
/// touched lists before each block (`touched_shifts`).
pub fn shift_offsets(offsets: &mut [u32], touched: &[[u32; 2]]) {
    let Some((&[n, _], touched)) = touched.split_last() else { return };
    for (b, o) in offsets.iter_mut().enumerate().take(n as usize) {
        let j = touched.partition_point(|t| (t[0] as usize) < b);
        if j > 0 {
            *o = (*o as i32 + touched[j - 1][1] as i32) as u32;
        }
    }
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
    use crate::udec::model::Model;

    fn wall(bricks: usize) -> Model {
        let deck = format!("{}CYCLE 0\n", crate::bench::scene::scaling_wall(bricks, 0.1).deck());
        crate::scenes::run_deck_on(&deck, Box::new(crate::udec::cpu::CpuBackend::new())).expect("the wall builds")
    }

    /// Moves block b by `by` (its corners follow, as after a cycle) and marks it for the update.
    fn shift(model: &mut Model, b: usize, by: [f64; 2]) {
        let blk = &mut model.blocks[b];
        blk.centroid = [blk.centroid[0] + by[0], blk.centroid[1] + by[1]];
        blk.moved_since_update = 1.0;
        let blk = blk.clone();
        let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
        crate::udec::model::corners::place_corners(&blk, &mut model.corners[range]);
    }

    /// The contacts' gaps as the contact stage of a cycle would leave them (the update drops
    /// the contacts of blocks it does not examine by their stored gap).
    fn measure_gaps(model: &mut Model) {
        let Model { blocks, corners, contacts, .. } = model;
        for c in contacts.iter_mut() {
            let b2 = &blocks[c.block2 as usize];
            let corners2 = &corners[b2.corner_start as usize..(b2.corner_start + b2.corner_count) as usize];
            let corner = &corners[c.corner as usize];
            c.gap = crate::udec::contact::geometry::track_feature(corners2, c.feature, corner.circle, corner.radius).gap;
        }
    }

    fn movable(model: &Model) -> Vec<usize> {
        (0..model.blocks.len()).filter(|&b| !model.blocks[b].fixed).collect()
    }

    #[test]
    fn the_edit_rebuilds_the_list_a_contact_update_makes() {
        let mut model = wall(1000);
        let mut topology = crate::udec::topology::Topology::default();
        crate::udec::topology::update_topology(&mut model, true, &mut topology);
        // Push a few blocks into their neighbours and lift others away, then update.
        for (k, b) in movable(&model).into_iter().step_by(37).enumerate() {
            shift(&mut model, b, [if k % 2 == 0 { 0.004 } else { -0.3 }, 0.0]);
        }
        measure_gaps(&mut model);
        crate::udec::topology::update_topology(&mut model, false, &mut topology);
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
        let (created, dropped) = crate::udec::topology::update_topology(&mut model, false, &mut topology);
        assert!(created > 0 && dropped > 0, "the update both creates and drops ({created}, {dropped})");
        let edit = topology.take_edit().expect("a list in order records its edit");
        assert_eq!((edit.inserted_at.len(), edit.dropped.len(), edit.new_len() as usize), (created, dropped, model.contacts.len()));
        let runs = edit.runs(NEW_CONTACT);
        let mut rebuilt = Vec::new();
        for w in runs.windows(2) {
            let source = w[0][1];
            for i in 0..(w[1][0] - w[0][0]) as usize {
                rebuilt.push(if source & NEW_CONTACT != 0 {
                    model.contacts[edit.inserted_at[(source & !NEW_CONTACT) as usize + i] as usize]
                } else {
                    old[source as usize + i]
                });
            }
        }
        assert_eq!(rebuilt.len(), model.contacts.len());
        for (a, b) in rebuilt.iter().zip(&model.contacts) {
            assert_eq!((a.id, a.block1, a.corner, a.block2), (b.id, b.block1, b.corner, b.block2));
            assert_eq!((a.shear_force, a.shear_displacement, a.normal_force), (b.shear_force, b.shear_displacement, b.normal_force));
        }
        // A kept contact's new index.
        let kept = (0..old.len() as u32).find(|k| edit.dropped.binary_search(k).is_err() && *k > edit.dropped[0]).expect("kept after a drop");
        assert_eq!(model.contacts[edit.new_index(kept) as usize].id, old[kept as usize].id);
    }

    /// The device's form of an update's adjacency edit (`renumber_table`, `touched_shifts` and
    /// the twins) turns the lists before the update into the CPU's lists after it.
    #[test]
    fn the_twins_edit_the_adjacency_as_the_update_does() {
        let mut model = wall(1000);
        let mut topology = crate::udec::topology::Topology::default();
        crate::udec::topology::update_topology(&mut model, true, &mut topology);
        measure_gaps(&mut model);
        crate::udec::topology::update_topology(&mut model, false, &mut topology);
        let before = topology.lists.clone();
        for (k, b) in movable(&model).into_iter().step_by(19).enumerate() {
            shift(&mut model, b, if k % 2 == 0 { [0.0, 30.0] } else { [0.35, 0.0] });
        }
        measure_gaps(&mut model);
        let (created, dropped) = crate::udec::topology::update_topology(&mut model, false, &mut topology);
        assert!(created > 0 && dropped > 0);
        let edit = topology.take_edit().expect("an edit");
        let entries = edit.entries.as_ref().expect("the lists were edited, not rebuilt");
        let renumber = renumber_table(&edit);
        assert_eq!(splice_adjacency(&before.entries, &entries.runs, &entries.lists, &renumber), topology.lists.entries);
        let mut offsets = before.offsets.clone();
        let touched = touched_shifts(entries, offsets.len());
        shift_offsets(&mut offsets, &touched);
        assert_eq!(offsets, topology.lists.offsets);
        for k in (0..edit.old_len).step_by(7).filter(|k| edit.dropped.binary_search(k).is_err()) {
            let shift = renumber[renumber.partition_point(|x| x[0] <= k) - 1][1] as i32;
            assert_eq!((k as i32 + shift) as u32, edit.new_index(k));
        }
    }

    #[test]
    fn a_list_out_of_order_records_no_edit() {
        let mut model = wall(1000);
        let mut topology = crate::udec::topology::Topology::default();
        crate::udec::topology::update_topology(&mut model, true, &mut topology);
        crate::udec::topology::update_topology(&mut model, false, &mut topology);
        assert_eq!(topology.take_edit().map(|e| (e.dropped.len(), e.inserted_at.len())), Some((0, 0)), "nothing changed");
        model.contacts.swap(3, 10);
        crate::udec::topology::update_topology(&mut model, false, &mut topology);
        assert_eq!(topology.take_edit(), None, "the list was sorted first");
        assert_eq!(topology.take_edit(), None, "taken once");
    }

    #[test]
    fn the_twin_copies_runs_and_patches_features_with_a_fresh_ledger() {
        let c = |k: u32| Contact::<f64> { px: k as f64, slip_work: 1.0, dashpot_work: 2.0, feature: k, block1: k, ..Default::default() };
        let f = |k: u32| ContactForce::<f64> { fx: k as f64, ..Default::default() };
        let old = [c(0), c(1), c(2), c(3)];
        let old_f = [f(0), f(1), f(2), f(3)];
        // Old 0, a created contact, old 2 and 3 (1 dropped).
        let (mut new, forces) = splice_contacts(&old, &old_f, &[[0, 0], [1, NEW_CONTACT], [2, 2], [4, 0]], &[c(5)], &[f(5)]);
        let patch = |index, feature| ContactPatch::<f64> { length: 0.0, index, feature };
        patch_contacts(&mut new, &[patch(2, 9), patch(7, 1)]);
        assert_eq!(
            new.iter().map(|c| (c.block1, c.feature, c.slip_work, c.dashpot_work)).collect::<Vec<_>>(),
            [(0, 0, 1.0, 2.0), (5, 5, 1.0, 2.0), (2, 9, 0.0, 0.0), (3, 3, 1.0, 2.0)]
        );
        assert_eq!(forces.iter().map(|f| f.fx).collect::<Vec<_>>(), [0.0, 5.0, 2.0, 3.0]);
    }
}
