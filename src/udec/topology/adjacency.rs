//! Per-block contact lists in compressed-row form, built on the CPU after every topology change.
//! Each entry is an [`AdjacencyEntry`] (a contact and the block's side of it, one u32), so the
//! same array serves the GPU gather unchanged.

use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

use rayon::prelude::*;

use super::detect::split_at_ends;
use crate::udec::contact::gather::AdjacencyEntry;
use crate::udec::model::Contact;

/// Smallest number of blocks one parallel task takes.
const PARALLEL_BLOCKS: usize = 1024;

/// Below this many contacts the lists are built on one thread.
const PARALLEL_CONTACTS: usize = 1 << 16;

/// The source bit of a run of `EntriesEdit::runs` that comes from `EntriesEdit::lists`.
pub const FROM_LISTS: u32 = 1 << 31;

/// What one contact update did to the adjacency lists (`Adjacency::apply`), for a backend that
/// keeps a copy of them (the GPU's) and makes the same edit to it: the lists of the blocks that
/// gained or lost a contact are new, every other entry is the old one renumbered (the contact
/// list's own edit, `detect::ListEdit::new_index`) and moved by the change in length of the
/// lists before it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EntriesEdit {
    /// The blocks whose lists changed (ascending).
    pub touched: Vec<u32>,
    /// For each touched block, the change in the entries' total up to and including its list:
    /// the offsets of the blocks after it, up to and including the next touched one, move by it.
    pub shift_after: Vec<i64>,
    /// The new entries as runs: (first new position, source), the source an old position or, with
    /// `FROM_LISTS`, a position in `lists`; ends with (new length, 0).
    pub runs: Vec<[u32; 2]>,
    /// The touched blocks' new lists, one after another.
    pub lists: Vec<AdjacencyEntry>,
}

impl EntriesEdit {
    /// No list changed: `entries` entries where they were.
    pub fn unchanged(entries: usize) -> Self {
        let n = entries as u32;
        EntriesEdit { runs: if n > 0 { vec![[0, 0], [n, 0]] } else { vec![[0, 0]] }, ..EntriesEdit::default() }
    }
}

#[derive(Debug, Default)]
pub struct Adjacency {
    /// `offsets[b] .. offsets[b+1]` indexes `entries` for block b.
    pub offsets: Vec<u32>,
    pub entries: Vec<AdjacencyEntry>,
    /// Room for the next `entries`, kept to spare a large allocation per update.
    spare: Vec<AdjacencyEntry>,
    /// The serial build's per-block fill cursors, kept likewise.
    fill: Vec<u32>,
    /// Per-block cursors and the slots of a parallel build, kept likewise.
    cursors: Vec<AtomicU32>,
    slots: Vec<AtomicU32>,
}

/// A copy of the lists (not of the work space).
impl Clone for Adjacency {
    fn clone(&self) -> Self {
        Adjacency { offsets: self.offsets.clone(), entries: self.entries.clone(), ..Adjacency::default() }
    }
}

/// Two adjacencies are equal when their lists are.
impl PartialEq for Adjacency {
    fn eq(&self, other: &Self) -> bool {
        self.offsets == other.offsets && self.entries == other.entries
    }
}

impl Adjacency {
    /// Builds the lists, each in ascending contact order (a fixed order: the gather repeats bit
    /// for bit).
    pub fn build(block_count: usize, contacts: &[Contact]) -> Self {
        let mut adjacency = Adjacency::default();
        adjacency.rebuild(block_count, contacts);
        adjacency
    }

    /// `build` into the lists' own storage.
    pub fn rebuild(&mut self, block_count: usize, contacts: &[Contact]) {
        if contacts.len() < PARALLEL_CONTACTS {
            self.rebuild_serial(block_count, contacts);
        } else {
            self.rebuild_parallel(block_count, contacts);
        }
    }

    /// A counting sort: list lengths, their offsets, then each entry in contact order.
    fn rebuild_serial(&mut self, block_count: usize, contacts: &[Contact]) {
        let counts = &mut self.offsets;
        counts.clear();
        counts.resize(block_count + 1, 0);
        for c in contacts {
            counts[c.block1 as usize + 1] += 1;
            counts[c.block2 as usize + 1] += 1;
        }
        for b in 0..block_count {
            counts[b + 1] += counts[b];
        }
        let fill = &mut self.fill;
        fill.clear();
        fill.extend_from_slice(&self.offsets[..block_count]);
        self.entries.clear();
        self.entries.resize(2 * contacts.len(), AdjacencyEntry::default());
        for (i, c) in contacts.iter().enumerate() {
            for (block, side) in [(c.block1, 0u32), (c.block2, 1u32)] {
                let slot = &mut fill[block as usize];
                self.entries[*slot as usize] = AdjacencyEntry::new(i as u32, side);
                *slot += 1;
            }
        }
    }

    /// The counting sort in parallel: list lengths counted with atomic adds (the same counts in
    /// any order), each entry dropped into a free slot of its list's range, then every list
    /// sorted, which gives the serial build's order (ascending contact index) whatever order the
    /// slots were taken in.
    fn rebuild_parallel(&mut self, block_count: usize, contacts: &[Contact]) {
        let cursors = &mut self.cursors;
        cursors.clear();
        cursors.resize_with(block_count + 1, || AtomicU32::new(0));
        contacts.par_iter().with_min_len(PARALLEL_BLOCKS).for_each(|c| {
            cursors[c.block1 as usize + 1].fetch_add(1, Relaxed);
            cursors[c.block2 as usize + 1].fetch_add(1, Relaxed);
        });
        self.offsets.clear();
        self.offsets.extend(cursors.iter_mut().map(|a| *a.get_mut()));
        for b in 0..block_count {
            self.offsets[b + 1] += self.offsets[b];
        }
        cursors.par_iter_mut().zip(self.offsets.par_iter()).with_min_len(PARALLEL_BLOCKS).for_each(|(a, &o)| *a.get_mut() = o);
        let slots = &mut self.slots;
        slots.clear();
        slots.resize_with(2 * contacts.len(), || AtomicU32::new(0));
        contacts.par_iter().enumerate().with_min_len(PARALLEL_BLOCKS).for_each(|(i, c)| {
            for (block, side) in [(c.block1, 0u32), (c.block2, 1u32)] {
                let at = cursors[block as usize].fetch_add(1, Relaxed);
                slots[at as usize].store(AdjacencyEntry::new(i as u32, side).raw(), Relaxed);
            }
        });
        self.entries.clear();
        self.entries.resize(2 * contacts.len(), AdjacencyEntry::default());
        let offsets = &self.offsets;
        let chunks = block_count.div_ceil(PARALLEL_BLOCKS);
        let ends = (1..=chunks).map(|c| offsets[(c * PARALLEL_BLOCKS).min(block_count)] as usize);
        let pieces = split_at_ends(&mut self.entries, ends);
        let slots = &*slots;
        pieces.into_par_iter().enumerate().for_each(|(c, out)| {
            let base = offsets[c * PARALLEL_BLOCKS] as usize;
            for (o, slot) in out.iter_mut().zip(&slots[base..]) {
                *o = AdjacencyEntry::from_raw(slot.load(Relaxed));
            }
            for b in c * PARALLEL_BLOCKS..((c + 1) * PARALLEL_BLOCKS).min(block_count) {
                out[offsets[b] as usize - base..offsets[b + 1] as usize - base].sort_unstable();
            }
        });
    }

    /// True when the lists have the shape of `block_count` blocks and `contact_count` contacts.
    pub fn fits(&self, block_count: usize, contact_count: usize) -> bool {
        self.offsets.len() == block_count + 1 && self.entries.len() == 2 * contact_count && self.offsets[block_count] as usize == self.entries.len()
    }

    /// Brings the lists up to date after a contact update removed the contacts `removed`
    /// (index, block 1, block 2; ascending by index in the old list) and inserted new ones, each
    /// before the old contact `insert_before` names and now at `inserted` in the new list
    /// `contacts` (both ascending). The same lists as `build` would give: the old entries
    /// renumbered (the kept contacts kept their order), and only the lists of blocks that lost or
    /// gained a contact rebuilt. Returns what changed.
    pub fn apply(&mut self, block_count: usize, contacts: &[Contact], removed: &[(u32, u32, u32)], insert_before: &[u32], inserted: &[u32]) -> EntriesEdit {
        let removed_at: Vec<u32> = removed.iter().map(|r| r.0).collect();
        let renumber = Renumber::new(self.entries.len() / 2, &removed_at, insert_before);
        let renumber_entry = |e: AdjacencyEntry| e.with_contact(renumber.of(e.contact()));
        // Blocks whose lists change, with their new entries from inserted contacts.
        let mut gained: Vec<(u32, AdjacencyEntry)> = inserted
            .iter()
            .flat_map(|&i| [(contacts[i as usize].block1, AdjacencyEntry::new(i, 0)), (contacts[i as usize].block2, AdjacencyEntry::new(i, 1))])
            .collect();
        gained.sort_unstable();
        let mut touched: Vec<u32> = removed.iter().flat_map(|r| [r.1, r.2]).chain(gained.iter().map(|g| g.0)).collect();
        touched.sort_unstable();
        touched.dedup();
        if touched.is_empty() {
            return EntriesEdit::unchanged(self.entries.len());
        }
        let list_of = |t: u32| -> Vec<AdjacencyEntry> {
            let old = self.entries(t as usize);
            let mut list: Vec<AdjacencyEntry> = old.iter().filter(|&&e| removed_at.binary_search(&e.contact()).is_err()).map(|&e| renumber_entry(e)).collect();
            let lo = gained.partition_point(|g| g.0 < t);
            list.extend(gained[lo..].iter().take_while(|g| g.0 == t).map(|g| g.1));
            list.sort_unstable();
            list
        };
        let new_lists: Vec<Vec<AdjacencyEntry>> = touched.par_iter().map(|&t| list_of(t)).collect();
        // Each touched list moves the offsets after it by its change in length.
        let mut shift_after: Vec<i64> = Vec::with_capacity(touched.len());
        let mut shift = 0i64;
        for (&t, list) in touched.iter().zip(&new_lists) {
            shift += list.len() as i64 - self.entries(t as usize).len() as i64;
            shift_after.push(shift);
        }
        let new_offset = |b: usize| -> u32 {
            let j = touched.partition_point(|&t| (t as usize) < b);
            (self.offsets[b] as i64 + if j == 0 { 0 } else { shift_after[j - 1] }) as u32
        };
        // The same as runs: each stretch of untouched blocks' entries moves as one, by the
        // shift before it; each touched list comes from `lists`.
        let mut runs: Vec<[u32; 2]> = Vec::with_capacity(2 * touched.len() + 2);
        let (mut first, mut at) = (0usize, 0u32);
        for (&t, list) in touched.iter().zip(&new_lists) {
            if self.offsets[t as usize] > self.offsets[first] {
                runs.push([new_offset(first), self.offsets[first]]);
            }
            if !list.is_empty() {
                runs.push([new_offset(t as usize), FROM_LISTS | at]);
                at += list.len() as u32;
            }
            first = t as usize + 1;
        }
        if self.offsets[block_count] > self.offsets[first] {
            runs.push([new_offset(first), self.offsets[first]]);
        }
        runs.push([2 * contacts.len() as u32, 0]);
        let mut entries = std::mem::take(&mut self.spare);
        entries.clear();
        entries.resize(2 * contacts.len(), AdjacencyEntry::default());
        {
            let chunks = block_count.div_ceil(PARALLEL_BLOCKS);
            let ends = (1..=chunks).map(|c| new_offset((c * PARALLEL_BLOCKS).min(block_count)) as usize);
            split_at_ends(&mut entries, ends).into_par_iter().enumerate().for_each(|(c, out)| {
                let (first, last) = (c * PARALLEL_BLOCKS, ((c + 1) * PARALLEL_BLOCKS).min(block_count));
                let old = &self.entries[self.offsets[first] as usize..self.offsets[last] as usize];
                let j0 = touched.partition_point(|&t| (t as usize) < first);
                let j1 = touched.partition_point(|&t| (t as usize) < last);
                if j0 == j1 {
                    // No touched list here: the chunk's entries renumbered in one sweep.
                    for (o, &e) in out.iter_mut().zip(old) {
                        *o = renumber_entry(e);
                    }
                    return;
                }
                let mut w = 0;
                for b in first..last {
                    if let Ok(j) = touched[j0..j1].binary_search(&(b as u32)) {
                        let list = &new_lists[j0 + j];
                        out[w..w + list.len()].copy_from_slice(list);
                        w += list.len();
                    } else {
                        for &e in self.entries(b) {
                            out[w] = renumber_entry(e);
                            w += 1;
                        }
                    }
                }
            });
        }
        self.spare = std::mem::replace(&mut self.entries, entries);
        for (j, &t) in touched.iter().enumerate() {
            let end = touched.get(j + 1).map_or(block_count, |&u| u as usize);
            for o in &mut self.offsets[t as usize + 1..=end] {
                *o = (*o as i64 + shift_after[j]) as u32;
            }
        }
        EntriesEdit { touched, shift_after, runs, lists: new_lists.concat() }
    }

    /// The entries of block `b`.
    #[inline]
    pub fn entries(&self, b: usize) -> &[AdjacencyEntry] {
        &self.entries[self.offsets[b] as usize..self.offsets[b + 1] as usize]
    }
}

/// Old contact index → new, for the contacts an update kept: k plus the insertions at or before
/// it less the removals before it. A step function, tabulated per bucket of indices: most
/// buckets hold no step, and an index in one costs a table look-up.
struct Renumber {
    /// (index from which the step applies, +1 for an insertion or −1 for a removal), ascending.
    steps: Vec<(u32, i32)>,
    /// Per bucket: the shift at its first index, and where its own steps start in `steps`.
    base: Vec<i32>,
    first: Vec<u32>,
}

/// The steps of a contact list's renumbering by an edit: (first old index it applies to, ±1),
/// ascending. A contact dropped at r moves every later one down by one; one inserted before p
/// moves p and every later one up. A kept contact's new index is its old one plus the steps at or
/// below it (`Renumber` here, `gpu::splice::renumber_table` for the device).
pub(crate) fn renumber_steps(removed_at: &[u32], insert_before: &[u32]) -> Vec<(u32, i32)> {
    let mut steps: Vec<(u32, i32)> = removed_at.iter().map(|&r| (r + 1, -1)).chain(insert_before.iter().map(|&p| (p, 1))).collect();
    steps.sort_unstable();
    steps
}

impl Renumber {
    const BUCKET_BITS: u32 = 10;

    fn new(old_count: usize, removed_at: &[u32], insert_before: &[u32]) -> Self {
        let steps = renumber_steps(removed_at, insert_before);
        let buckets = (old_count >> Self::BUCKET_BITS) + 2;
        let (mut base, mut first) = (Vec::with_capacity(buckets + 1), Vec::with_capacity(buckets + 1));
        let (mut at, mut shift) = (0usize, 0i32);
        for b in 0..=buckets {
            let start = (b as u64) << Self::BUCKET_BITS;
            while at < steps.len() && steps[at].0 as u64 <= start {
                shift += steps[at].1;
                at += 1;
            }
            base.push(shift);
            first.push(at as u32);
        }
        Renumber { steps, base, first }
    }

    #[inline]
    fn of(&self, k: u32) -> u32 {
        let b = (k >> Self::BUCKET_BITS) as usize;
        let mut shift = self.base[b];
        for &(from, step) in &self.steps[self.first[b] as usize..self.first[b + 1] as usize] {
            if from > k {
                break;
            }
            shift += step;
        }
        (k as i64 + shift as i64) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_build_gives_the_serial_lists() {
        let mut rng = crate::udec::topology::xorshift(0x9e3779b97f4a7c15u64);
        let mut next = |m: u64| rng(m) as u32;
        let blocks = 5000;
        let contacts: Vec<Contact> = (0..3 * PARALLEL_CONTACTS as u32)
            .map(|id| {
                let block1 = next(blocks);
                let block2 = (block1 + 1 + next(blocks - 1)) % blocks as u32;
                Contact::unloaded(id, block1, block2)
            })
            .collect();
        let (mut serial, mut parallel) = (Adjacency::default(), Adjacency::default());
        serial.rebuild_serial(blocks as usize, &contacts);
        parallel.rebuild_parallel(blocks as usize, &contacts);
        assert!(serial == parallel);
        // Storage kept from a larger build.
        parallel.rebuild_parallel(blocks as usize, &contacts[..PARALLEL_CONTACTS + 7]);
        serial.rebuild_serial(blocks as usize, &contacts[..PARALLEL_CONTACTS + 7]);
        assert!(serial == parallel);
    }

    /// `apply` gives the lists `build` gives on the new contact list, and the edit it returns
    /// turns the old lists into them (runs of renumbered old entries and new lists; offsets moved
    /// by the touched lists' shifts), as a backend holding a copy makes it.
    #[test]
    fn an_applied_edit_rebuilds_the_lists() {
        let mut rng = crate::udec::topology::xorshift(0x1234_5678_9abc_def1u64);
        let mut next = |m: u64| rng(m) as u32;
        let blocks = 3000u32;
        for (n, changes) in [(20_000u32, 40u32), (20_000, 2), (500, 300)] {
            let contact = |id: u32, next: &mut dyn FnMut(u64) -> u32| {
                let block1 = next(blocks as u64);
                let block2 = (block1 + 1 + next(blocks as u64 - 1)) % blocks;
                Contact::unloaded(id, block1, block2)
            };
            let old: Vec<Contact> = (0..n).map(|id| contact(id, &mut next)).collect();
            let mut dropped: Vec<u32> = (0..changes).map(|_| next(n as u64)).collect();
            dropped.sort_unstable();
            dropped.dedup();
            let mut insert_before: Vec<u32> = (0..changes).map(|_| next(n as u64 + 1)).collect();
            insert_before.sort_unstable();
            let created: Vec<Contact> = (0..insert_before.len() as u32).map(|i| contact(n + i, &mut next)).collect();
            let mut new = old.clone();
            let inserted = crate::udec::topology::detect::splice(&mut new, &dropped, &insert_before, created.into_iter());
            let removed: Vec<(u32, u32, u32)> = dropped.iter().map(|&k| (k, old[k as usize].block1, old[k as usize].block2)).collect();
            let before = Adjacency::build(blocks as usize, &old);
            let mut after = Adjacency::build(blocks as usize, &old);
            let edit = after.apply(blocks as usize, &new, &removed, &insert_before, &inserted);
            assert!(after == Adjacency::build(blocks as usize, &new), "apply gives the built lists");
            // The edit on the old lists.
            let renumber = Renumber::new(old.len(), &dropped, &insert_before);
            let mut entries = Vec::new();
            for w in edit.runs.windows(2) {
                assert!(w[0][0] < w[1][0], "no empty run");
                let (source, len) = (w[0][1], (w[1][0] - w[0][0]) as usize);
                for i in 0..len {
                    entries.push(if source & FROM_LISTS != 0 {
                        edit.lists[(source & !FROM_LISTS) as usize + i]
                    } else {
                        let e = before.entries[source as usize + i];
                        e.with_contact(renumber.of(e.contact()))
                    });
                }
            }
            assert_eq!(*edit.runs.last().unwrap(), [after.entries.len() as u32, 0]);
            assert!(entries == after.entries, "entries from the runs ({n} contacts, {changes} changes)");
            let offsets: Vec<u32> = (0..=blocks)
                .map(|b| {
                    let j = edit.touched.partition_point(|&t| t < b);
                    (before.offsets[b as usize] as i64 + if j == 0 { 0 } else { edit.shift_after[j - 1] }) as u32
                })
                .collect();
            assert!(offsets == after.offsets, "offsets from the shifts");
        }
    }
}
