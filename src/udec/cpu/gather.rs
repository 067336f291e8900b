//! Stage 6 on the CPU: each block sums the forces and moments of its contacts (eq. 12 in two
//! dimensions, M = r × F) in the fixed order of its adjacency list, then adds gravity and its load
//! ([`crate::udec::contact::gather`]). Forces are gathered, not scattered (DESIGN.md §2), so the sum is
//! the same on every run and every backend. The GPU's twin is `shaders/udec/gather.wgsl`.

use super::flow::FluidScratch;
use super::team::Team;
use super::{SharedMut, MIN_BLOCKS_PER_THREAD, MIN_CHUNK};
use crate::udec::contact::gather::ContactForce;
use crate::udec::model::sdef::Sdef;
use crate::udec::model::{Block, BlockKind, Model};
use crate::udec::topology::Adjacency;

/// Sums the forces acting on block `b`; `forces[k]` is contact k's (see [`ContactForce`]).
#[inline]
pub fn gather(b: usize, block: &mut Block, forces: &[ContactForce], adjacency: &Adjacency, gravity: [f64; 2]) {
    crate::udec::contact::gather::gather(block, forces, adjacency.entries(b), gravity);
}

/// Stage 6 of a simply-deformable block: its force and moment, then its applied stress; in a
/// scene with fluid, `fluid` adds the domain pressures' share of each (stage 5: its load, and its
/// applied stress times area, `model::fluid::deformable_pressure_loads`).
#[inline]
pub fn gather_sdef(
    b: usize,
    block: &mut Block,
    sdef: &mut Sdef,
    forces: &[ContactForce],
    adjacency: &Adjacency,
    gravity: [f64; 2],
    fluid: Option<&FluidScratch>,
) {
    gather(b, block, forces, adjacency, gravity);
    sdef.applied = crate::udec::contact::gather::gather_applied_stress(block, forces, adjacency.entries(b));
    if let Some(fluid) = fluid {
        super::add_fluid_load(block, Some(&fluid.loads), b);
        if let Some(a) = fluid.applied.get(b) {
            for (x, y) in sdef.applied.iter_mut().zip(a) {
                *x += y;
            }
        }
    }
}

/// A zoned block's fluid loads for its gather (`zones::gather_fdef`): its buoyancy and its
/// corners' grid point loads; None without fluid.
#[inline]
pub(super) fn fdef_fluid<'a>(fluid: Option<&'a FluidScratch>, b: usize, block: &Block) -> Option<([f64; 3], &'a [[f64; 2]])> {
    let fluid = fluid?;
    let start = block.corner_start as usize;
    let pressures = fluid.gridpoint.get(start..start + block.corner_count as usize).unwrap_or(&[]);
    Some((fluid.loads.get(b).copied().unwrap_or([0.0; 3]), pressures))
}

/// Stage 6 alone, for the whole model: after a topology change, and wherever the block forces
/// must be current between cycles (energy check, checkpoint, end of a run).
/// In a scene with fluid, `fluid` holds the blocks' loads from the domain pressures and
/// buoyancy (stage 5), added to their sums.
pub(super) fn gather_all(model: &mut Model, forces: &[ContactForce], features: &[[u32; 2]], fluid: &FluidScratch, adjacency: &Adjacency, team: &mut Team) {
    let _p = crate::profile::scope(crate::profile::Stage::Gather);
    let gravity = model.gravity;
    let fluid = model.fluid.is_some().then_some(fluid);
    let fluid_loads = fluid.map(|f| &f.loads[..]);
    debug_assert_eq!(forces.len(), model.contacts.len());
    let Model { blocks, sdef, fdef, corners, .. } = model;
    let n = blocks.len();
    let shared = SharedMut::new(blocks);
    // The fully-deformable extension, likewise.
    let shared_fdef = (!fdef.is_empty()).then(|| SharedMut::new(fdef));
    let corners = &corners[..];
    // The simply-deformable extension, indexed like the blocks, where the scene has one.
    let shared_sdef = (!sdef.is_empty()).then(|| SharedMut::new(sdef));
    team.for_chunks(n, MIN_BLOCKS_PER_THREAD, MIN_CHUNK, &|r| {
        // SAFETY: the chunks are disjoint ranges of `blocks` (and of `sdef`, as long), mutably
        // borrowed here.
        let piece = unsafe { shared.range(r.clone()) };
        let mut sdef = shared_sdef.as_ref().map(|s| unsafe { s.range(r.clone()) });
        // SAFETY: as above.
        let mut fdef = shared_fdef.as_ref().map(|s| unsafe { s.range(r.clone()) });
        for (j, block) in piece.iter_mut().enumerate() {
            if let Some(f) = fdef.as_mut().map(|f| &mut f[j]).filter(|f| block.kind == BlockKind::FullyDeformable && !f.zones.is_empty()) {
                let mine = &corners[block.corner_start as usize..(block.corner_start + block.corner_count) as usize];
                let wet = fdef_fluid(fluid, r.start + j, block);
                super::zones::gather_fdef(block, f, mine, features, forces, adjacency.entries(r.start + j), gravity, wet);
                continue;
            }
            match &mut sdef {
                Some(sdef) if block.kind == BlockKind::SimplyDeformable => gather_sdef(r.start + j, block, &mut sdef[j], forces, adjacency, gravity, fluid),
                _ => {
                    gather(r.start + j, block, forces, adjacency, gravity);
                    super::add_fluid_load(block, fluid_loads, r.start + j);
                }
            }
        }
    });
}
