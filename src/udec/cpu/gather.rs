//! Stage 6 on the CPU: each block sums the forces and moments of its contacts (eq. 12 in two
//! dimensions, M = r × F) in the fixed order of its adjacency list, then adds gravity and its load
//! ([`crate::udec::contact::gather`]). Forces are gathered, not scattered (DESIGN.md §2), so the sum is
//! the same on every run and every backend. The GPU's twin is `shaders/udec/gather.wgsl`.

use super::team::Team;
use super::{SharedMut, MIN_BLOCKS_PER_THREAD, MIN_CHUNK};
use crate::udec::contact::gather::ContactForce;
use crate::udec::model::{Block, Model};
use crate::udec::topology::Adjacency;

/// Sums the forces acting on block `b`; `forces[k]` is contact k's (see [`ContactForce`]).
#[inline]
pub fn gather(b: usize, block: &mut Block, forces: &[ContactForce], adjacency: &Adjacency, gravity: [f64; 2]) {
    crate::udec::contact::gather::gather(block, forces, adjacency.entries(b), gravity);
}

/// Stage 6 alone, for the whole model: after a topology change, and wherever the block forces
/// must be current between cycles (energy check, checkpoint, end of a run).
pub(super) fn gather_all(model: &mut Model, forces: &[ContactForce], adjacency: &Adjacency, team: &mut Team) {
    let _p = crate::profile::scope(crate::profile::Stage::Gather);
    let gravity = model.gravity;
    let blocks = &mut model.blocks;
    debug_assert_eq!(forces.len(), model.contacts.len());
    let n = blocks.len();
    let shared = SharedMut::new(blocks);
    team.for_chunks(n, MIN_BLOCKS_PER_THREAD, MIN_CHUNK, &|r| {
        // SAFETY: the chunks are disjoint ranges of `blocks`, mutably borrowed here.
        let piece = unsafe { shared.range(r.clone()) };
        for (j, block) in piece.iter_mut().enumerate() {
            gather(r.start + j, block, forces, adjacency, gravity);
        }
    });
}
