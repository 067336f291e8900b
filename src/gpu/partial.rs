//! Stage 7 from the few blocks and contacts it touches: a contact update on the GPU backend
//! reads back lists made on the device (`list_blocks.wgsl`) and then only the blocks, corners
//! and contacts the update reads, instead of the whole state (DESIGN.md §3: the CPU reads back
//! flags and the few positions it needs).
//!
//! The update itself is the CPU's (`topology::detect::update_topology_with`), given the lists as
//! its `Attention` and a fetch that reads the flagged blocks' neighbourhoods in the kept grid;
//! it picks the same blocks and drops the same contacts as on the whole state, since the lists
//! are supersets (loosened tests) and the exact tests run on the CPU on what was read. The model
//! is then current only where it was read; the device keeps the rest, and the splice that
//! follows patches only the contacts read and leaves the others as the device holds them.

use super::kernels::{slab, uniform_buffer, Slab};
use super::layout::{Block, Contact, GridReference, ListParams, Real};
use super::GpuError;

/// Twin of `LIST_SLACK` in list_blocks.wgsl: how much the device's tests are loosened.
pub const LIST_SLACK: f64 = 0.01;

/// Twin of `near_update` (list_blocks.wgsl).
fn near_update<R: Real>(blk: &Block<R>, lp: &ListParams<R>) -> bool {
    let (etol, margin, moved) = (lp.etol.to_f64(), blk.update_margin.to_f64(), blk.moved.to_f64());
    blk.fixed == 0 && moved > 0.5 * (etol + margin) * (1.0 - LIST_SLACK)
}

/// Rust twin of `list_blocks` (list_blocks.wgsl), in f64 on the device's values: the blocks
/// listed (ascending) and the fewest cycles until an unlisted block passes its threshold
/// (`u32::MAX`: none moves).
pub fn list_blocks<R: Real>(blocks: &[Block<R>], reference: &[GridReference<R>], lp: &ListParams<R>) -> (Vec<u32>, u32) {
    let f = |x: R| x.to_f64();
    let mut listed = Vec::new();
    let mut fewest = u32::MAX;
    for (b, blk) in blocks.iter().enumerate().take(lp.n_blocks as usize) {
        let mut near = near_update(blk, lp);
        if !near && lp.grid_kept != 0 {
            let r = &reference[b];
            let dx = (f(blk.cx) - f(r.x)) + (f(blk.cx_lo) - f(r.x_lo));
            let dy = (f(blk.cy) - f(r.y)) + (f(blk.cy_lo) - f(r.y_lo));
            let moved = dx.hypot(dy) + (f(blk.rotation) - f(r.rotation)).abs() * f(r.reach);
            near = moved > f(lp.stray_limit) * (1.0 - LIST_SLACK) || (f(blk.update_margin) > 0.0 && f(blk.update_margin) >= f(r.margin));
        }
        if near {
            listed.push(b as u32);
            continue;
        }
        if blk.fixed != 0 {
            continue;
        }
        let dt = f(lp.dt);
        let s = f(blk.vx).hypot(f(blk.vy)) * dt + f(blk.w).abs() * dt * f(blk.radius);
        if s > 0.0 {
            let room = (f(lp.etol) + f(blk.update_margin) - f(blk.moved)).max(0.0);
            let k = (room / s).min(1e9).floor() as u32;
            fewest = fewest.min(k + 1);
        }
    }
    (listed, fewest)
}

/// Rust twin of `list_contacts` (list_blocks.wgsl): the contacts listed, ascending.
pub fn list_contacts<R: Real>(blocks: &[Block<R>], contacts: &[Contact<R>], lp: &ListParams<R>) -> Vec<u32> {
    contacts
        .iter()
        .enumerate()
        .take(lp.n_contacts as usize)
        .filter(|(_, c)| {
            let (b1, b2) = (&blocks[c.block1 as usize], &blocks[c.block2 as usize]);
            let limit = lp.btol.to_f64() + b1.update_margin.to_f64() + b2.update_margin.to_f64();
            c.gap.to_f64() > limit * (1.0 - LIST_SLACK) || near_update(b1, lp) || near_update(b2, lp)
        })
        .map(|(k, _)| k as u32)
        .collect()
}

/// The grid's reference (`BlockGrid::reference`: centroid, rotation, reach, margin per block)
/// for the device, centroids relative to `origin` as compensated pairs.
pub fn grid_reference<R: Real>(reference: &[[f64; 5]], origin: [f64; 2]) -> Vec<GridReference<R>> {
    let split = |x: f64| {
        let hi = R::from_f64(x);
        (hi, R::from_f64(x - hi.to_f64()))
    };
    reference
        .iter()
        .map(|&[x, y, rotation, reach, margin]| {
            let ((x, x_lo), (y, y_lo)) = (split(x - origin[0]), split(y - origin[1]));
            GridReference { x, y, x_lo, y_lo, rotation: R::from_f64(rotation), reach: R::from_f64(reach), margin: R::from_f64(margin), _r: R::default() }
        })
        .collect()
}

/// Ascending indices as runs [start, end) of consecutive ones: one copy each.
pub fn runs(sorted: &[u32]) -> Vec<(u32, u32)> {
    let mut out: Vec<(u32, u32)> = Vec::new();
    for &i in sorted {
        match out.last_mut() {
            Some(last) if last.1 == i => last.1 = i + 1,
            Some(last) if last.1 > i => {}
            _ => out.push((i, i + 1)),
        }
    }
    out
}

/// Runs [start, end) in any order, overlapping or touching, joined into ascending disjoint ones.
pub fn join_runs(runs: impl IntoIterator<Item = (u32, u32)>) -> Vec<(u32, u32)> {
    let mut all: Vec<(u32, u32)> = runs.into_iter().filter(|r| r.0 < r.1).collect();
    all.sort_unstable();
    let mut out: Vec<(u32, u32)> = Vec::with_capacity(all.len());
    for r in all {
        match out.last_mut() {
            Some(last) if r.0 <= last.1 => last.1 = last.1.max(r.1),
            _ => out.push(r),
        }
    }
    out
}

/// The device buffers of the lists: their constants, the grid's reference, the header (counts
/// and fewest cycles) and the two lists.
pub struct ListBuffers {
    pub params: wgpu::Buffer,
    pub reference: Slab,
    pub header: Slab,
    pub listed_blocks: Slab,
    pub listed_contacts: Slab,
    /// (grid builds, origin, blocks) the reference on the device was made for.
    pub reference_of: Option<(u64, [f64; 2], usize)>,
}

impl ListBuffers {
    pub fn new<R: Real>(dev: &super::GpuDevice, blocks: usize, contacts: usize) -> Result<Self, GpuError> {
        Ok(ListBuffers {
            params: uniform_buffer(dev, "list params", std::mem::size_of::<ListParams<R>>()),
            reference: slab(dev, "grid reference", std::mem::size_of::<GridReference<R>>(), blocks)?,
            header: slab(dev, "list header", 4, 4)?,
            listed_blocks: slab(dev, "listed blocks", 4, blocks)?,
            listed_contacts: slab(dev, "listed contacts", 4, contacts)?,
            reference_of: None,
        })
    }

    /// Whether these buffers hold lists of this many blocks and contacts.
    pub fn fits(&self, blocks: usize, contacts: usize) -> bool {
        self.reference.capacity >= blocks && self.listed_blocks.capacity >= blocks && self.listed_contacts.capacity >= contacts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_join_consecutive_indices() {
        assert_eq!(runs(&[]), vec![]);
        assert_eq!(runs(&[3, 4, 5, 9, 11, 12]), vec![(3, 6), (9, 10), (11, 13)]);
        assert_eq!(runs(&[3, 3, 4]), vec![(3, 5)]);
        assert_eq!(join_runs([(5, 7), (0, 2), (1, 3), (7, 8), (10, 10)]), vec![(0, 3), (5, 8)]);
    }
}
