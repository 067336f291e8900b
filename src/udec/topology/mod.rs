//! Stage 7, CPU only: topology. Contacts are created and dropped here, blocks cracked, and the
//! per-block adjacency lists the gather walks are rebuilt — always between cycles, never inside a
//! kernel (DESIGN.md §1, STYLE.md item 6).

pub mod adjacency;
pub mod cracking;
pub mod detect;
pub mod domain;

pub use adjacency::Adjacency;
pub use cracking::{apply_crack, find_crack, Crack};
pub use detect::{update_contacts, update_topology, BlockGrid, ListEdit};
pub use domain::{build_domains, refresh_domains, refresh_domains_with};

/// What stage 7 keeps between contact updates, three things apart: the per-block contact lists
/// the gather walks, the broad phase's grid the next update starts from, and the edit the last
/// update made to the contact list, which a backend holding a copy of the list (the GPU's) takes
/// to make the same edit to it.
#[derive(Clone, Debug, Default)]
pub struct Topology {
    pub lists: Adjacency,
    pub(crate) grid: BlockGrid,
    /// None when nothing was recorded, or that update had to sort the list first.
    edit: Option<ListEdit>,
}

impl Topology {
    /// The lists built afresh for `contacts`, with no grid kept and no edit recorded (after a
    /// change the update did not make: a crack).
    pub fn build(block_count: usize, contacts: &[crate::udec::model::Contact]) -> Self {
        Topology { lists: Adjacency::build(block_count, contacts), ..Topology::default() }
    }

    /// Takes the edit the last contact update made to the contact list (None: none recorded,
    /// or that update sorted the list first).
    pub fn take_edit(&mut self) -> Option<ListEdit> {
        self.edit.take()
    }
}

/// The unit tests' random numbers: a xorshift64 stream from `seed`, each call a value below `m`
/// (`m` = 2⁵³ and a division by it give a uniform f64 in [0, 1)).
#[cfg(test)]
pub(crate) fn xorshift(mut seed: u64) -> impl FnMut(u64) -> u64 {
    move |m: u64| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed % m
    }
}
