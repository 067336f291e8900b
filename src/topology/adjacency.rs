//! Per-block contact lists in compressed-row form, built on the CPU after every topology change.
//! Entry = contact index × 2 + side (0: the block is the contact's block 1, 1: block 2), so the
//! same u32 array serves the GPU gather unchanged.

use crate::model::Contact;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Adjacency {
    /// `offsets[b] .. offsets[b+1]` indexes `entries` for block b.
    pub offsets: Vec<u32>,
    pub entries: Vec<u32>,
}

impl Adjacency {
    /// Builds the lists, each in ascending contact order (a fixed order: the gather repeats bit
    /// for bit).
    pub fn build(block_count: usize, contacts: &[Contact]) -> Self {
        let mut counts = vec![0u32; block_count + 1];
        for c in contacts {
            counts[c.block1 as usize + 1] += 1;
            counts[c.block2 as usize + 1] += 1;
        }
        for b in 0..block_count {
            counts[b + 1] += counts[b];
        }
        let offsets = counts.clone();
        let mut fill = counts;
        let mut entries = vec![0u32; 2 * contacts.len()];
        for (i, c) in contacts.iter().enumerate() {
            for (block, side) in [(c.block1, 0u32), (c.block2, 1u32)] {
                let slot = &mut fill[block as usize];
                entries[*slot as usize] = (i as u32) << 1 | side;
                *slot += 1;
            }
        }
        Adjacency { offsets, entries }
    }

    /// The entries of block `b`.
    #[inline]
    pub fn entries(&self, b: usize) -> &[u32] {
        &self.entries[self.offsets[b] as usize..self.offsets[b + 1] as usize]
    }
}
