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

use crate::udec::backend::CycleReport;
use crate::udec::model::Model;
use crate::udec::topology::Topology;

use super::kernels::{self, slab, uniform_buffer, Slab};
use super::layout::{Block, Contact, ContactPatch, ContactSummary, Corner, GridReference, ListParams, Real, Sdef};
use super::readback::pod_view;
use super::run::cycles_to_threshold;
use super::{r, Engine, GpuError};

/// Twin of `LIST_SLACK` in list_blocks.wgsl: how much the device's tests are loosened.
pub const LIST_SLACK: f64 = 0.01;

/// Twin of `near_update` (list_blocks.wgsl).
/// What `Engine::read_subset` returns: the blocks' device records and, in an SDEF scene, their
/// extensions (empty in the others), both in the order of the blocks asked for.
type SubsetRecords<R> = (Vec<Block<R>>, Vec<Sdef<R>>);

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
            let moved = dx.hypot(dy) + ((f(blk.rotation) - f(r.rotation)) + f(blk.rotation_lo)).abs() * f(r.reach);
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

/// When a contact update reads back only what it touches (`gpu::partial`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PartialReads {
    /// Never: every update reads the whole (packed) state back.
    Never,
    /// When the whole packed state is larger than `PARTIAL_READ_MIN_BYTES`.
    #[default]
    Large,
    /// On every model (the tests' way to run it on small ones).
    Always,
}

/// Below this many bytes of packed state (blocks, corners and contact summaries: ~1000 blocks in
/// f32 take 0.6 MB) a contact update reads it all back. The whole read is one round trip, which
/// the read of the state after the batch that stopped for the update already makes; a partial
/// read makes two or three (the lists, the items, the neighbourhoods). Measured on lavapipe on the
/// 10³-block wall struck by the projectile: 0.17 ms an update whole against 0.85 ms partly, a
/// run of 3000 cycles 11% faster; at 10⁴ blocks (6 MB) the two were even, and on a hardware GPU
/// the whole read also crosses the bus.
pub const PARTIAL_READ_MIN_BYTES: usize = 2 << 20;

/// What `Engine::partial_contact_update` did.
pub(super) enum PartialUpdate {
    /// Nothing: the update needs the whole state (the caller reads it back as before).
    Declined,
    /// No block is past its threshold by the CPU's exact test: no update.
    NotDue,
    /// The update ran; the next one is expected after this many cycles.
    Updated(Option<u64>),
}

impl<R: Real> Engine<R> {
    /// Whether a contact update now reads back only what it touches (`PartialReads`).
    pub(super) fn partial_reads_pay(&self) -> bool {
        let (nb, nc, nk) = self.counts;
        let whole = nb * std::mem::size_of::<Block<R>>() + nc * std::mem::size_of::<Corner<R>>() + nk * std::mem::size_of::<ContactSummary<R>>();
        match self.partial_reads {
            PartialReads::Never => false,
            PartialReads::Large => whole > PARTIAL_READ_MIN_BYTES,
            PartialReads::Always => true,
        }
    }

    /// Stage 7 from what it touches (`gpu::partial`): the device lists the blocks that may be
    /// re-examined or have strayed from the kept grid and the contacts that may be dropped; the
    /// CPU reads those back, then the neighbourhoods of the blocks it re-examines (their blocks,
    /// corners and contacts), runs the update on them, resets the re-examined blocks' update
    /// distances on the device and splices the contact list there, leaving every contact it did
    /// not read as the device holds it. The model is current only where it was read until the
    /// next whole read-back. Declines, changing nothing, when the update needs the whole state.
    pub(super) fn partial_contact_update(&mut self, model: &mut Model, topology: &mut Topology, report: &mut CycleReport) -> Result<PartialUpdate, GpuError> {
        let (nb, _, nk) = self.counts;
        // (The attention's contact indices and the splice need the list in the update's order.)
        if nb < 2 || !self.list_in_order || !topology.grid.valid_for(model) {
            return Ok(PartialUpdate::Declined);
        }
        // The lists, on the device.
        let (listed, listed_contacts, fewest) = {
            let _p = crate::profile::scope(crate::profile::Stage::Download);
            if self.lists.as_ref().is_none_or(|l| !l.fits(nb, nk)) {
                self.lists = None;
                self.lists = Some(ListBuffers::new::<R>(&self.dev, nb, nk)?);
            }
            let origin = self.uploaded.origin;
            let grid = &topology.grid;
            let lists = self.lists.as_mut().expect("made above");
            let key = (grid.builds(), origin, nb);
            if lists.reference_of != Some(key) {
                let reference = grid_reference::<R>(grid.reference(), origin);
                self.dev.queue.write_buffer(&lists.reference.buffer, 0, bytemuck::cast_slice(&reference));
                lists.reference_of = Some(key);
            }
            let t = model.tol;
            let lp = ListParams::<R> {
                dt: r(model.timestep),
                etol: r(t.etol),
                btol: r(t.btol),
                stray_limit: r(grid.stray_limit()),
                n_blocks: nb as u32,
                n_contacts: nk as u32,
                grid_kept: 1,
                _pad: 0,
            };
            let q = &self.dev.queue;
            q.write_buffer(&lists.params, 0, bytemuck::bytes_of(&lp));
            q.write_buffer(&lists.header.buffer, 0, bytemuck::cast_slice(&[0u32, 0, u32::MAX, 0]));
            let b = self.buffers();
            let lists = self.lists.as_ref().expect("made above");
            let entries = kernels::whole_bindings(&[
                &lists.params,
                &b.blocks.buffer,
                &b.contacts.buffer,
                &lists.reference.buffer,
                &lists.header.buffer,
                &lists.listed_blocks.buffer,
                &lists.listed_contacts.buffer,
            ]);
            let p = &self.pipelines;
            kernels::dispatch_items(&self.dev, "list_blocks", &p.list_blocks, &p.lists_layout, &entries, nb)?;
            if nk > 0 {
                kernels::dispatch_items(&self.dev, "list_contacts", &p.list_contacts, &p.lists_layout, &entries, nk)?;
            }
            let header: Vec<u32> = self.dev.read_pod(&lists.header.buffer, 4)?;
            let (n_listed, n_contacts) = (header[0] as usize, header[1] as usize);
            // Many listed: an update that sweeps or rebuilds the grid (it reads every block), or
            // one that drops a crowd of contacts; the whole read-back is then as cheap.
            if n_listed > nb / 8 || n_contacts > nk / 8 + 64 {
                return Ok(PartialUpdate::Declined);
            }
            let (mut listed, mut listed_contacts) = self
                .dev
                .read_parts(&[(&lists.listed_blocks.buffer, (n_listed * 4) as u64), (&lists.listed_contacts.buffer, (n_contacts * 4) as u64)], |bytes| {
                    (bytemuck::pod_collect_to_vec::<u8, u32>(bytes[0]), bytemuck::pod_collect_to_vec::<u8, u32>(bytes[1]))
                })?;
            listed.sort_unstable();
            listed_contacts.sort_unstable();
            (listed, listed_contacts, header[2])
        };
        // The listed blocks and contacts into the model.
        let mut read_contacts = runs(&listed_contacts);
        let (records, sdef_records) = self.read_subset(model, &listed, &read_contacts)?;
        let tol = model.tol;
        if !listed.iter().any(|&b| model.blocks[b as usize].update_due(&tol)) {
            return Ok(PartialUpdate::NotDue);
        }
        // The update, which fetches the re-examined blocks' neighbourhoods.
        let mut read_all = false;
        let outcome = {
            let _p = crate::profile::scope(crate::profile::Stage::DetectUpdate);
            let mut fetch = |m: &mut Model, needed: Option<&[u32]>| -> Result<(), String> {
                match needed {
                    None => {
                        self.read_live_state(m, true).map_err(|e| e.to_string())?;
                        read_all = true;
                    }
                    Some(blocks) => {
                        // Each block's run of contacts (as block 1; the list is in that order).
                        let contact_runs = join_runs(blocks.iter().map(|&b| {
                            let lo = m.contacts.partition_point(|c| c.block1 < b);
                            (lo as u32, (lo + m.contacts[lo..].partition_point(|c| c.block1 == b)) as u32)
                        }));
                        self.read_subset(m, blocks, &contact_runs).map_err(|e| e.to_string())?;
                        read_contacts = join_runs(read_contacts.iter().chain(&contact_runs).copied());
                    }
                }
                Ok(())
            };
            let mut attention = crate::udec::topology::detect::Attention { blocks: listed.clone(), contacts: listed_contacts, fetch: &mut fetch };
            crate::udec::topology::detect::update_topology_with(model, topology, &mut attention)
        };
        let (created, dropped, flagged) = outcome.map_err(GpuError::Device)?;
        report.topology_updates += 1;
        report.contacts_created += created as u64;
        report.contacts_dropped += dropped as u64;
        self.partial_updates += 1;
        {
            // The re-examined blocks: their update distance reset on the device, their reference
            // where they are now and their new speed margin (the model keeps it as the device
            // does, rounded to its precision, as a read-back would give it).
            let _p = crate::profile::scope(crate::profile::Stage::Upload);
            for &b in &flagged {
                let Ok(i) = listed.binary_search(&b) else {
                    return Err(GpuError::Device(format!("GPU: block {b} was re-examined but not listed (a bug; run with BLOCKDEM_PARTIAL_READS=0)")));
                };
                let g = &records[i];
                let m = &mut model.blocks[b as usize];
                let margin = R::from_f64(m.update_margin);
                m.update_margin = margin.to_f64();
                self.write_update_reset(b as usize, &g.update_reset(margin));
            }
            self.reset_sdef_update_strains(&listed, &sdef_records, &flagged);
        }
        // The next update expected: the device's figure for the blocks not listed, the CPU's for
        // those it read.
        let from_listed = listed.iter().filter_map(|&b| cycles_to_threshold(model, &model.blocks[b as usize])).min();
        let from_device = (fewest != u32::MAX).then_some(fewest as u64);
        let expected = from_listed.into_iter().chain(from_device).min();
        // The splice: the kept contacts read are patched, the others keep the device's state.
        let Some(edit) = topology.take_edit().filter(|e| e.old_len as usize == nk) else {
            return Err(GpuError::Device("GPU: the contact update sorted a list kept in order (a bug; run with BLOCKDEM_PARTIAL_READS=0)".into()));
        };
        if model.contacts.is_empty() {
            self.upload_contacts(model, &topology.lists)?;
        } else {
            let read: Vec<u32> = if read_all { (0..edit.old_len).collect() } else { read_contacts.iter().flat_map(|&(s, e)| s..e).collect() };
            let patches: Vec<ContactPatch<R>> =
                read.into_iter().filter(|k| edit.dropped.binary_search(k).is_err()).map(|k| ContactPatch::of(model, edit.new_index(k))).collect();
            let patched: Vec<u32> = patches.iter().map(|p| p.index).collect();
            self.edit_contact_list(model, &edit, Some(&patched));
            self.splice_contacts(model, &topology.lists, &edit, &patches)?;
        }
        self.write_params(model);
        Ok(PartialUpdate::Updated(expected))
    }

    /// Reads the blocks `blocks` (ascending; records and corners) and the contacts of `contacts`
    /// (runs of indices) back into the model, as a whole read-back would convert them (contacts
    /// as their summaries: gap, forces, dissipation, feature, bond); returns the block records.
    pub(super) fn read_subset(&mut self, model: &mut Model, blocks: &[u32], contacts: &[(u32, u32)]) -> Result<SubsetRecords<R>, GpuError> {
        let _p = crate::profile::scope(crate::profile::Stage::Download);
        let b = self.buffers();
        let (bs, cs, ks) = (std::mem::size_of::<Block<R>>() as u64, std::mem::size_of::<Corner<R>>() as u64, std::mem::size_of::<Contact<R>>() as u64);
        let block_runs = runs(blocks);
        let corner_runs = join_runs(blocks.iter().map(|&k| {
            let blk = &model.blocks[k as usize];
            (blk.corner_start, blk.corner_start + blk.corner_count)
        }));
        fn ranges<'a>(buffer: &'a wgpu::Buffer, runs: &[(u32, u32)], size: u64) -> Vec<(&'a wgpu::Buffer, u64, u64)> {
            runs.iter().map(|&(s, e)| (buffer, s as u64 * size, (e - s) as u64 * size)).collect()
        }
        let (rb, rc, rk) = (ranges(&b.blocks.buffer, &block_runs, bs), ranges(&b.corners.buffer, &corner_runs, cs), ranges(&b.contacts.buffer, contacts, ks));
        // In an SDEF scene, the blocks' extensions too (`reset_sdef_update_strains`).
        let rs = match b.sdefs.as_ref().filter(|_| self.sdef_scene) {
            Some(sdefs) => ranges(&sdefs.buffer, &block_runs, std::mem::size_of::<Sdef<R>>() as u64),
            None => Vec::new(),
        };
        let up = self.uploaded.clone();
        self.dev.read_gathered(&[&rb, &rc, &rk, &rs], |bytes| {
            let records: Vec<Block<R>> = bytemuck::pod_collect_to_vec(bytes[0]);
            let sdef_records: Vec<Sdef<R>> = bytemuck::pod_collect_to_vec(bytes[3]);
            if !sdef_records.is_empty() {
                for (&k, g) in blocks.iter().zip(&sdef_records) {
                    if model.blocks[k as usize].kind == crate::udec::model::BlockKind::SimplyDeformable {
                        g.convert(up.sdef_damping_base.get(k as usize).copied().unwrap_or(0.0), &mut model.sdef[k as usize]);
                    }
                }
            }
            let corners: std::borrow::Cow<'_, [Corner<R>]> = pod_view(bytes[1]);
            let gathered: std::borrow::Cow<'_, [Contact<R>]> = pod_view(bytes[2]);
            for (&k, g) in blocks.iter().zip(&records) {
                Self::convert_block(g, up.damping_base[k as usize], up.origin, &mut model.blocks[k as usize]);
            }
            // Corners: the runs laid end to end; each block's are within one run.
            let mut at = 0usize;
            let mut first = Vec::with_capacity(corner_runs.len());
            for &(s, e) in &corner_runs {
                first.push((s, e, at));
                at += (e - s) as usize;
            }
            for (&k, record) in blocks.iter().zip(&records) {
                let (centroid, s, count) = {
                    let blk = &model.blocks[k as usize];
                    (blk.centroid, blk.corner_start, blk.corner_count as usize)
                };
                let turn = record.rotation_lo.to_f64();
                let start = s as usize;
                let run = first.partition_point(|r| r.1 <= s);
                let base = first[run].2 + (s - first[run].0) as usize;
                for j in 0..count {
                    let next = if j + 1 == count { 0 } else { j + 1 };
                    Self::convert_corner(&corners[base + j], &corners[base + next], centroid, turn, &mut model.corners[start + j]);
                }
            }
            let mut at = 0usize;
            for &(s, e) in contacts {
                for k in s..e {
                    let g = &gathered[at];
                    at += 1;
                    let summary = ContactSummary {
                        gap: g.gap,
                        normal_force: g.normal_force,
                        shear_force: g.shear_force,
                        slip_work: g.slip_work,
                        dashpot_work: g.dashpot_work,
                        feature: g.feature,
                        bonded: g.bonded,
                    };
                    Self::convert_summary(&summary, up.contact_base[k as usize], &mut model.contacts[k as usize]);
                }
            }
            (records, sdef_records)
        })
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
