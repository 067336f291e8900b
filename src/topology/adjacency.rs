//! Per-block contact lists in compressed-row form, built on the CPU after every topology change.
//! Entry = contact index × 2 + side (0: the block is the contact's block 1, 1: block 2), so the
//! same u32 array serves the GPU gather unchanged.

use rayon::prelude::*;

use super::detect::BlockGrid;
use crate::model::Contact;

/// Smallest number of blocks one parallel task takes.
const PARALLEL_BLOCKS: usize = 1024;

#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    /// `offsets[b] .. offsets[b+1]` indexes `entries` for block b.
    pub offsets: Vec<u32>,
    pub entries: Vec<u32>,
    /// The broad phase's grid, kept for the next contact update (`detect::update_topology`).
    pub(crate) grid: BlockGrid,
    /// Room for the next `entries`, kept to spare a large allocation per update.
    spare: Vec<u32>,
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
        let fill = &mut self.spare;
        fill.clear();
        fill.extend_from_slice(&self.offsets[..block_count]);
        self.entries.clear();
        self.entries.resize(2 * contacts.len(), 0);
        for (i, c) in contacts.iter().enumerate() {
            for (block, side) in [(c.block1, 0u32), (c.block2, 1u32)] {
                let slot = &mut fill[block as usize];
                self.entries[*slot as usize] = (i as u32) << 1 | side;
                *slot += 1;
            }
        }
    }

    /// True when the lists have the shape of `block_count` blocks and `contact_count` contacts.
    pub fn fits(&self, block_count: usize, contact_count: usize) -> bool {
        self.offsets.len() == block_count + 1 && self.entries.len() == 2 * contact_count && self.offsets[block_count] as usize == self.entries.len()
    }

    /// Brings the lists up to date after a contact update removed the contacts `removed`
    /// (index, block 1, block 2; ascending by index in the old list) and inserted contacts at the
    /// indices `inserted` of the new list `contacts` (ascending). The same lists as `build` would
    /// give: the old entries renumbered (the contacts kept their order), and only the lists of
    /// blocks that lost or gained a contact rebuilt.
    pub fn apply(&mut self, block_count: usize, contacts: &[Contact], removed: &[(u32, u32, u32)], inserted: &[u32]) {
        // A kept contact at old index k lands at k − (removed before it) + (inserted before it);
        // an insertion at new index i sits before the kept contact at i − (inserted before it).
        let removed_at: Vec<u32> = removed.iter().map(|r| r.0).collect();
        let inserted_before: Vec<u32> = inserted.iter().enumerate().map(|(j, &i)| i - j as u32).collect();
        let renumber = |e: u32| {
            let k = e >> 1;
            let kept = k - removed_at.partition_point(|&r| r < k) as u32;
            (kept + inserted_before.partition_point(|&p| p <= kept) as u32) << 1 | (e & 1)
        };
        // Blocks whose lists change, with their new entries from inserted contacts.
        let mut gained: Vec<(u32, u32)> = inserted.iter().flat_map(|&i| [(contacts[i as usize].block1, i << 1), (contacts[i as usize].block2, i << 1 | 1)]).collect();
        gained.sort_unstable();
        let mut touched: Vec<u32> = removed.iter().flat_map(|r| [r.1, r.2]).chain(gained.iter().map(|g| g.0)).collect();
        touched.sort_unstable();
        touched.dedup();
        if touched.is_empty() {
            return;
        }
        let list_of = |t: u32| -> Vec<u32> {
            let t = t as usize;
            let old = &self.entries[self.offsets[t] as usize..self.offsets[t + 1] as usize];
            let mut list: Vec<u32> = old.iter().filter(|&&e| removed_at.binary_search(&(e >> 1)).is_err()).map(|&e| renumber(e)).collect();
            let lo = gained.partition_point(|g| g.0 < t as u32);
            list.extend(gained[lo..].iter().take_while(|g| g.0 == t as u32).map(|g| g.1));
            list.sort_unstable();
            list
        };
        let new_lists: Vec<Vec<u32>> = touched.par_iter().map(|&t| list_of(t)).collect();
        let mut shift_after: Vec<i64> = Vec::with_capacity(touched.len());
        let mut shift = 0i64;
        for (&t, list) in touched.iter().zip(&new_lists) {
            let t = t as usize;
            shift += list.len() as i64 - (self.offsets[t + 1] - self.offsets[t]) as i64;
            shift_after.push(shift);
        }
        let new_offset = |b: usize| -> u32 {
            let j = touched.partition_point(|&t| (t as usize) < b);
            (self.offsets[b] as i64 + if j == 0 { 0 } else { shift_after[j - 1] }) as u32
        };
        let mut entries = std::mem::take(&mut self.spare);
        entries.clear();
        entries.resize(2 * contacts.len(), 0);
        {
            let chunks = block_count.div_ceil(PARALLEL_BLOCKS);
            let mut pieces = Vec::with_capacity(chunks);
            let mut rest: &mut [u32] = &mut entries;
            for c in 0..chunks {
                let (lo, hi) = (new_offset(c * PARALLEL_BLOCKS), new_offset(((c + 1) * PARALLEL_BLOCKS).min(block_count)));
                let (piece, tail) = std::mem::take(&mut rest).split_at_mut((hi - lo) as usize);
                pieces.push(piece);
                rest = tail;
            }
            let (old_entries, old_offsets) = (&self.entries, &self.offsets);
            pieces.into_par_iter().enumerate().for_each(|(c, out)| {
                let mut w = 0;
                for b in c * PARALLEL_BLOCKS..((c + 1) * PARALLEL_BLOCKS).min(block_count) {
                    if let Ok(j) = touched.binary_search(&(b as u32)) {
                        out[w..w + new_lists[j].len()].copy_from_slice(&new_lists[j]);
                        w += new_lists[j].len();
                    } else {
                        for &e in &old_entries[old_offsets[b] as usize..old_offsets[b + 1] as usize] {
                            out[w] = renumber(e);
                            w += 1;
                        }
                    }
                }
            });
        }
        self.spare = std::mem::replace(&mut self.entries, entries);
        // Offsets move by the change in length of every touched list before them.
        let (touched, shift_after) = (&touched, &shift_after);
        self.offsets.par_iter_mut().enumerate().with_min_len(PARALLEL_BLOCKS).skip(touched[0] as usize + 1).for_each(|(b, o)| {
            let j = touched.partition_point(|&t| (t as usize) < b);
            *o = (*o as i64 + shift_after[j - 1]) as u32;
        });
    }

    /// The entries of block `b`.
    #[inline]
    pub fn entries(&self, b: usize) -> &[u32] {
        &self.entries[self.offsets[b] as usize..self.offsets[b + 1] as usize]
    }
}
