//! Zoned fully-deformable blocks on the device (issue 29, `model::fdef`): their grid points and
//! zones in slots of their own (`layout::GridPoint`, `layout::Zone`, each block's constants and
//! ranges `layout::FdefBlock`, each grid point's zones as CSR, each contact's force shares
//! `layout::ContactShare`), made, uploaded and read back only in a scene that has zoned blocks;
//! a rigid scene binds and dispatches nothing of them (`kernels::FdefKernels`).
//!
//! What differs in such a scene (`Engine::stages`): each cycle runs `gather_gridpoints`,
//! `step_gridpoints` and `zones` (zones.wgsl) before `law_of_motion_fdef` (rigid blocks
//! as before, and a zoned block's corners on its grid points), `place_fdef_corners` (those of a
//! zoned block of many boundary grid points, a workgroup per block) and `contact_forces_fdef`. Each boundary grid point gathers its contacts from a list of
//! its own (`GridPointContacts`), not its block's whole list: no invocation walks a whole block,
//! which on a GPU runs one thread for as long as the block is large (issue 29). A zoned
//! block's record keeps its velocity and force at zero on the device and its centroid where the
//! upload put it (the reference its corners are placed from); a read-back gives the model its
//! grid points and zones and places its corners, centroid and velocity from them as the CPU
//! does (`place_corners_fdef`), and sums its external force. Contact updates upload the contact
//! list whole (the shares of a new list come from the CPU), so the device splice and partial
//! read-backs are off, as in an SDEF scene. A zone turned inside out raises
//! `Flags::inverted_zone`, and the run stops as on the CPU (`CycleError::ZoneInverted`).

use crate::udec::backend::CycleError;
use crate::udec::model::{BlockKind, Model};

use crate::udec::contact::gather::AdjacencyEntry;
use crate::udec::topology::adjacency::Adjacency;

use super::kernels::FdefSizes;
use super::layout::{ContactShare, FdefBlock, GridPoint, Real, Zone, BLOCK_FDEF, NO_INDEX};
use super::{r, Engine, GpuError, Uploaded};

/// Whether block `b` of `model` is zoned (fully deformable, with zones): the blocks the FDEF
/// kernels move; a fully-deformable block not yet zoned moves as a rigid one, as on the CPU.
pub fn is_zoned(model: &Model, b: usize) -> bool {
    model.fdef_of(b).is_some_and(|f| !f.zones.is_empty())
}

/// Each block's first grid point in the device's grid-point slot (the zoned blocks' grid points
/// in block order), `NO_INDEX` for a block that is not zoned.
pub fn gridpoint_starts(model: &Model) -> Vec<u32> {
    let mut at = 0u32;
    (0..model.blocks.len())
        .map(|b| {
            if !is_zoned(model, b) {
                return NO_INDEX;
            }
            let start = at;
            at += model.fdef[b].gridpoints.len() as u32;
            start
        })
        .collect()
}

/// For tests: the zoned blocks' grid points gather by walking their block's whole contact list
/// (as before `GridPointContacts`) rather than their own lists, from the next contact list
/// uploaded on; a run must come out bit for bit the same either way.
pub static WALK_BLOCK_LISTS: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether `model`'s zoned blocks' grid points walk their block's whole contact list: in a scene
/// with fluid (its cycle does not check the lists, `check_fdef_lists`), or when a test asks
/// (`WALK_BLOCK_LISTS`).
fn walk_block_lists(model: &Model) -> bool {
    WALK_BLOCK_LISTS.load(std::sync::atomic::Ordering::Relaxed) || (model.fluid.is_some() && model.domains.is_some())
}

/// A coordinate relative to the origin as the device's compensated pair (large part, rest).
fn split<R: Real>(x: f64) -> (R, R) {
    let hi = r::<R>(x);
    (hi, r(x - hi.to_f64()))
}

/// The device's FDEF state of a model: per block its record (zero for the others) and first
/// grid point (`NO_INDEX` for the others), the grid points and zones of every zoned block in
/// block order, and each grid point's zones as CSR (offsets for grid points 0 ..= n into the same
/// array, then entries zone·4 + place, ascending by zone).
struct FdefUpload<R: Real> {
    blocks: Vec<FdefBlock<R>>,
    gp_start: Vec<u32>,
    gridpoints: Vec<GridPoint<R>>,
    zones: Vec<Zone<R>>,
    csr: Vec<u32>,
}

impl<R: Real> FdefUpload<R> {
    fn of(model: &Model, origin: [f64; 2]) -> Self {
        let n = model.blocks.len();
        let mut up =
            FdefUpload { blocks: vec![FdefBlock::default(); n], gp_start: vec![NO_INDEX; n], gridpoints: Vec::new(), zones: Vec::new(), csr: Vec::new() };
        for b in (0..n).filter(|&b| is_zoned(model, b)) {
            let f = &model.fdef[b];
            let blk = &model.blocks[b];
            let mat = &model.material(blk.material).block;
            let gp_start = up.gridpoints.len() as u32;
            up.gp_start[b] = gp_start;
            up.blocks[b] = FdefBlock {
                // As the CPU's stage 3 takes them (`cpu::zones::step_fdef`).
                lambda: r(mat.bulk - 2.0 * mat.shear / 3.0),
                shear: r(mat.shear),
                gp_start,
                gp_count: f.gridpoints.len() as u32,
                boundary: f.boundary,
                zone_start: up.zones.len() as u32,
                zone_count: f.zones.len() as u32,
                fixed: blk.fixed as u32,
            };
            // The load's share by mass, as the CPU's gather takes it.
            let total = blk.mass.max(f64::MIN_POSITIVE);
            for (k, g) in f.gridpoints.iter().enumerate() {
                let share = g.mass / total;
                let (x, x_lo) = split::<R>(g.position[0] - origin[0]);
                let (y, y_lo) = split::<R>(g.position[1] - origin[1]);
                let (ux, ux_lo) = split::<R>(g.update_position[0] - origin[0]);
                let (uy, uy_lo) = split::<R>(g.update_position[1] - origin[1]);
                up.gridpoints.push(GridPoint {
                    x,
                    y,
                    x_lo,
                    y_lo,
                    vx: r(g.velocity[0]),
                    vy: r(g.velocity[1]),
                    fx: r(g.force[0]),
                    fy: r(g.force[1]),
                    mass: r(g.mass),
                    load_x: r(blk.load[0] * share),
                    load_y: r(blk.load[1] * share),
                    ux,
                    uy,
                    ux_lo,
                    uy_lo,
                    work: R::default(),
                    damping_work: R::default(),
                    block: b as u32,
                    boundary: ((k as u32) < f.boundary) as u32,
                    fixed: blk.fixed as u32,
                    listed: ((k as u32) < f.boundary && !walk_block_lists(model)) as u32,
                });
            }
            for z in &f.zones {
                let [g0, g1, g2] = z.gridpoints.map(|g| gp_start + g);
                up.zones.push(Zone { stress: z.stress.map(r::<R>), g0, g1, g2, block: b as u32 });
            }
        }
        up.csr = zone_csr(up.gridpoints.len(), up.zones.iter().map(|z| [z.g0, z.g1, z.g2]));
        up
    }
}

/// Each grid point's zones as CSR (`FdefUpload::csr`) from the zones' grid points (global
/// indices) in zone order: ascending by zone, the order the CPU adds them in.
fn zone_csr(n_gp: usize, zones: impl Iterator<Item = [u32; 3]> + Clone) -> Vec<u32> {
    let mut count = vec![0u32; n_gp + 1];
    let mut n_zones = 0usize;
    for z in zones.clone() {
        n_zones += 1;
        for g in z {
            count[g as usize + 1] += 1;
        }
    }
    let mut csr = Vec::with_capacity(n_gp + 1 + 3 * n_zones);
    let mut at = (n_gp + 1) as u32;
    for c in &count[1..] {
        csr.push(at);
        at += c;
    }
    csr.push(at);
    let mut fill: Vec<u32> = csr[..n_gp].to_vec();
    csr.resize(at as usize, 0);
    for (z, zone) in zones.enumerate() {
        for (place, g) in zone.into_iter().enumerate() {
            let f = &mut fill[g as usize];
            csr[*f as usize] = ((z as u32) << 2) | place as u32;
            *f += 1;
        }
    }
    csr
}

/// How far (in edges round a zoned block's boundary) a contact's feature on the block may move
/// from where it was when the grid points' contact lists were built before the lists no longer
/// hold every grid point it acts on (`LIST_REACH` in zones.wgsl, which a test checks against
/// this). A contact stage moves a feature by one edge at most (it searches the feature's
/// neighbourhood), so `check_fdef_lists`, which sees the features before each contact stage,
/// finds a feature at this reach in time and its block's boundary grid points walk the whole
/// list from the next gather on.
pub const LIST_REACH: u32 = 2;

/// Zoned blocks of more boundary grid points than this have their corners placed by a
/// workgroup each (`place_fdef_corners`: `GridPointContacts` lists them), the others by their
/// invocation of `law_of_motion_fdef` as before (`WIDE_BOUNDARY` in geometry_update.wgsl, which a
/// test checks against this): on a GPU one invocation's walk round a large block is the cycle's
/// longest thread, while a workgroup for a brick's few corners is mostly idle lanes, and on a
/// software adapter a workgroup with a barrier costs far more than a short walk.
pub const WIDE_BOUNDARY: u32 = 32;

/// The edge (or corner arc) index a contact's feature on a block of `n` corners lies at, as the
/// contact stage takes it (`zoned_of` in contact_forces.wgsl).
pub fn feature_edge(feature: u32, n: u32) -> u32 {
    feature.min(2 * n - 1) / 2
}

/// Each boundary grid point's contact list (`gather_gridpoints`), built by the CPU whenever the
/// contact list changes, stored after the zone CSR in the `gridpoint_zones` slot from word
/// `base`: offsets for grid points 0 ..= n (absolute indices into the same array), then the
/// zoned blocks of more than `WIDE_BOUNDARY` boundary grid points (their count, then each: the
/// workgroups of `place_fdef_corners`), then the entries, then per contact the edge its feature
/// on its block 2 was at (`feature_edge`, 0 where block 2 is not zoned).
///
/// A grid point's list is the subsequence of its block's adjacency list (`Adjacency`, the order
/// the CPU's `gather_fdef` adds the contacts in) that may act on it: on side 1 (block 1, the
/// corner) the entries whose corner is the grid point; on side 2 the entries whose feature's
/// edge lies within `LIST_REACH` of it (all of them on a block of at most 2·reach + 2
/// corners). The gather checks each entry's shares as the walk of the whole list did, and an
/// entry that does not act on a grid point adds nothing to it, so the sums are the walk's bit for
/// bit: each grid point's list drops only entries that add nothing to it.
pub struct GridPointContacts {
    pub words: Vec<u32>,
    /// How many zoned blocks are wide (`place_fdef_corners`' grid).
    pub wide: usize,
}

impl GridPointContacts {
    /// The lists of `model`'s zoned blocks (`gp_start`: each block's first grid point,
    /// `NO_INDEX` where it is not zoned; `n_gp` grid points in all) over the adjacency lists
    /// `offsets`, `entries`, stored from word `base`.
    pub fn of(model: &Model, offsets: &[u32], entries: &[AdjacencyEntry], gp_start: &[u32], n_gp: usize, base: u32) -> Self {
        // The grid points (block-local) an entry of block b goes to, in ascending order.
        let targets = |b: usize, e: AdjacencyEntry, out: &mut Vec<u32>| {
            out.clear();
            let c = &model.contacts[e.contact() as usize];
            let n = model.fdef[b].boundary;
            if e.side() == 0 {
                out.push(c.corner - model.blocks[b].corner_start);
            } else if n <= 2 * LIST_REACH + 2 {
                out.extend(0..n);
            } else {
                let j0 = feature_edge(c.feature, n);
                out.extend((0..=2 * LIST_REACH + 1).map(|d| (j0 + n - LIST_REACH + d) % n));
                out.sort_unstable();
            }
        };
        let zoned: Vec<usize> = (0..model.blocks.len()).filter(|&b| gp_start.get(b).is_some_and(|&g| g != NO_INDEX)).collect();
        let block_entries = |b: usize| entries[offsets[b] as usize..offsets[b + 1] as usize].iter().copied();
        let mut count = vec![0u32; n_gp + 1];
        let mut out = Vec::new();
        for &b in &zoned {
            for e in block_entries(b) {
                targets(b, e, &mut out);
                for &g in &out {
                    count[(gp_start[b] + g) as usize + 1] += 1;
                }
            }
        }
        let wide: Vec<u32> = zoned.iter().filter(|&&b| model.fdef[b].boundary > WIDE_BOUNDARY).map(|&b| b as u32).collect();
        let mut words = Vec::with_capacity(n_gp + 2 + wide.len());
        let mut at = base + (n_gp + 2 + wide.len()) as u32;
        for c in &count[1..] {
            words.push(at);
            at += c;
        }
        words.push(at);
        words.push(wide.len() as u32);
        words.extend(&wide);
        let mut fill: Vec<u32> = words[..n_gp].iter().map(|&w| w - base).collect();
        words.resize((at - base) as usize, 0);
        for &b in &zoned {
            for e in block_entries(b) {
                targets(b, e, &mut out);
                for &g in &out {
                    let f = &mut fill[(gp_start[b] + g) as usize];
                    words[*f as usize] = bytemuck::cast(e);
                    *f += 1;
                }
            }
        }
        words.extend(model.contacts.iter().map(|c| {
            let b2 = c.block2 as usize;
            if gp_start[b2] == NO_INDEX {
                0
            } else {
                feature_edge(c.feature, model.fdef[b2].boundary)
            }
        }));
        GridPointContacts { words, wide: wide.len() }
    }
}

impl<R: Real> ContactShare<R> {
    /// How contact `c`'s force is shared to grid points (`cpu::zones::force_shares`, from its
    /// point and feature as the model holds them): what the first gather after an upload reads
    /// (the contact stage writes them every cycle after). `gp_start`: each block's first grid
    /// point, `NO_INDEX` where it is not zoned.
    pub fn of(model: &Model, c: &crate::udec::model::Contact, gp_start: &[u32]) -> Self {
        let mut s = ContactShare { wa: R::default(), wb: R::default(), g1: NO_INDEX, g2a: NO_INDEX, g2b: NO_INDEX, _pad: 0 };
        let (b1, b2) = (c.block1 as usize, c.block2 as usize);
        if gp_start[b1] != NO_INDEX {
            s.g1 = gp_start[b1] + (c.corner - model.blocks[b1].corner_start);
        }
        if gp_start[b2] != NO_INDEX {
            let blk = &model.blocks[b2];
            let corners = &model.corners[blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize];
            let [(ka, wa), (kb, wb)] = crate::udec::cpu::zones::force_shares([c.corner, c.feature], 1, blk.corner_start, corners, c.point);
            s.g2a = gp_start[b2] + ka as u32;
            s.wa = r(wa);
            if c.feature % 2 == 1 {
                s.g2b = gp_start[b2] + kb as u32;
                s.wb = r(wb);
            }
        }
        s
    }
}

impl<R: Real> Engine<R> {
    /// At a whole upload: whether the scene has zoned blocks; if it has, their kernels and slots
    /// made (once) and every grid point, zone and block constant written, the zoned blocks'
    /// records marked `BLOCK_FDEF` with their velocity and force zero. Returns whether a buffer
    /// was re-created (the bind groups must then be rebuilt).
    pub(super) fn upload_fdef(&mut self, model: &Model) -> Result<bool, GpuError> {
        self.fdef_scene = (0..model.blocks.len()).any(|b| is_zoned(model, b));
        if !self.fdef_scene {
            self.fdef_counts = (0, 0);
            self.fdef_wide = 0;
            self.fdef_gp_start.clear();
            self.last_gridpoints.clear();
            return Ok(false);
        }
        let had_kernels = self.pipelines.fdef.is_some();
        self.pipelines.with_fdef(&self.dev)?;
        let up = FdefUpload::<R>::of(model, self.uploaded.origin);
        let sizes =
            FdefSizes { gridpoints: up.gridpoints.len(), zones: up.zones.len(), blocks: model.blocks.len(), csr: up.csr.len(), contacts: model.contacts.len() };
        let b = self.buffers.as_mut().expect("buffers exist");
        let made = b.ensure_fdef::<R>(&self.dev, sizes)?;
        for (_, blk) in self.last_blocks.iter_mut().enumerate().filter(|(k, _)| up.gp_start[*k] != NO_INDEX) {
            blk.kind = BLOCK_FDEF;
            blk.vx = R::default();
            blk.vy = R::default();
            blk.w = R::default();
            blk.fx = R::default();
            blk.fy = R::default();
            blk.moment = R::default();
        }
        let b = self.buffers();
        let q = &self.dev.queue;
        q.write_buffer(&b.blocks.buffer, 0, bytemuck::cast_slice(&self.last_blocks));
        q.write_buffer(&b.gridpoints.as_ref().expect("made above").buffer, 0, bytemuck::cast_slice(&up.gridpoints));
        q.write_buffer(&b.zones.as_ref().expect("made above").buffer, 0, bytemuck::cast_slice(&up.zones));
        q.write_buffer(&b.fdef_blocks.as_ref().expect("made above").buffer, 0, bytemuck::cast_slice(&up.blocks));
        q.write_buffer(&b.gridpoint_zones.as_ref().expect("made above").buffer, 0, bytemuck::cast_slice(&up.csr));
        let base = std::rc::Rc::make_mut(&mut self.uploaded);
        base.fdef_damping_base = std::sync::Arc::new((0..model.blocks.len()).map(|k| model.fdef_of(k).map_or(0.0, |f| f.damping_work)).collect());
        self.fdef_counts = (up.gridpoints.len(), up.zones.len());
        self.fdef_gp_start = up.gp_start;
        self.last_gridpoints = up.gridpoints;
        Ok(made || !had_kernels)
    }

    /// With a new contact list (`adjacency` its blocks' lists) in a scene with zoned blocks:
    /// room for its force shares and theirs from the model, and the boundary grid points'
    /// contact lists (`GridPointContacts`, after the zone CSR), which their blocks' grid points
    /// gather from (`GridPoint::listed`) except in a scene with fluid, whose cycle does not check
    /// them (`place_fdef_corners` is the dry cycle's). Returns whether a buffer was re-created.
    pub(super) fn upload_shares(&mut self, model: &Model, adjacency: &Adjacency) -> Result<bool, GpuError> {
        if !self.fdef_scene {
            return Ok(false);
        }
        let (n_gp, n_zones) = self.fdef_counts;
        let zones_len = n_gp + 1 + 3 * n_zones;
        let lists = GridPointContacts::of(model, &adjacency.offsets, &adjacency.entries, &self.fdef_gp_start, n_gp, zones_len as u32);
        let sizes =
            FdefSizes { gridpoints: n_gp, zones: n_zones, blocks: model.blocks.len(), csr: zones_len + lists.words.len(), contacts: model.contacts.len() };
        let b = self.buffers.as_mut().expect("buffers exist");
        let made = b.ensure_fdef::<R>(&self.dev, sizes)?;
        let shares: Vec<ContactShare<R>> = model.contacts.iter().map(|c| ContactShare::of(model, c, &self.fdef_gp_start)).collect();
        let listed = u32::from(!walk_block_lists(model));
        // The blocks whose boundary grid points' flags differ from the lists' (a block that
        // walked since its lists were built, `check_fdef_lists`): their boundary records as last
        // read back, which are the device's (no cycle ran since), with the flags set.
        let mut stale = Vec::new();
        for (k, &start) in self.fdef_gp_start.iter().enumerate().filter(|&(_, &g)| g != NO_INDEX) {
            let range = start as usize..(start + model.fdef[k].boundary) as usize;
            if self.last_gridpoints[range.clone()].iter().any(|g| g.listed != listed) {
                self.last_gridpoints[range.clone()].iter_mut().for_each(|g| g.listed = listed);
                stale.push(range);
            }
        }
        self.fdef_wide = lists.wide;
        let b = self.buffers();
        let q = &self.dev.queue;
        q.write_buffer(&b.contact_shares.as_ref().expect("made above").buffer, 0, bytemuck::cast_slice(&shares));
        let csr = &b.gridpoint_zones.as_ref().expect("made above").buffer;
        if made {
            // A re-created slot lost the zone CSR before the lists.
            let gp_start = &self.fdef_gp_start;
            let zoned = (0..model.blocks.len()).filter(|&k| gp_start[k] != NO_INDEX);
            let zones = zoned.flat_map(|k| model.fdef[k].zones.iter().map(move |z| z.gridpoints.map(|g| gp_start[k] + g)));
            q.write_buffer(csr, 0, bytemuck::cast_slice(&zone_csr(n_gp, zones.collect::<Vec<_>>().into_iter())));
        }
        q.write_buffer(csr, (zones_len * 4) as u64, bytemuck::cast_slice(&lists.words));
        let gridpoints = &b.gridpoints.as_ref().expect("a scene with zoned blocks has them").buffer;
        for range in stale {
            let at = range.start * std::mem::size_of::<GridPoint<R>>();
            q.write_buffer(gridpoints, at as u64, bytemuck::cast_slice(&self.last_gridpoints[range]));
        }
        Ok(made)
    }

    /// What a read-back reads of the FDEF slots: every grid point and zone (nothing in a scene
    /// without zoned blocks).
    pub(super) fn fdef_parts(&self) -> [(&wgpu::Buffer, u64); 2] {
        let b = self.buffers();
        let (n_gp, n_zones) = if self.fdef_scene { self.fdef_counts } else { (0, 0) };
        match (&b.gridpoints, &b.zones) {
            (Some(g), Some(z)) => {
                [(&g.buffer, (n_gp * std::mem::size_of::<GridPoint<R>>()) as u64), (&z.buffer, (n_zones * std::mem::size_of::<Zone<R>>()) as u64)]
            }
            _ => [(&b.params, 0), (&b.params, 0)],
        }
    }

    /// The FDEF slots as read (`fdef_parts`) into the model, after its blocks, corners and
    /// contacts: each zoned block's grid points and zones, its corners, centroid, velocity and
    /// area placed from its grid points (`place_corners_fdef`, as the CPU's stage 2 leaves
    /// them), its external force summed (gravity, load, its contacts in list order; moment 0),
    /// the grid points' work added to the ledger's external work and their damping to the
    /// block's.
    pub(super) fn convert_fdef(gridpoints: &[GridPoint<R>], zones: &[Zone<R>], up: &Uploaded, model: &mut Model) {
        if gridpoints.is_empty() {
            return;
        }
        let o = up.origin;
        let pair = |hi: R, lo: R, o: f64| o + (hi.to_f64() + lo.to_f64());
        let (mut g, mut z) = (0usize, 0usize);
        let mut work = 0.0;
        let n = model.blocks.len();
        let mut external: Vec<Option<[f64; 2]>> = vec![None; n];
        let zoned: Vec<usize> = (0..n).filter(|&b| is_zoned(model, b)).collect();
        for b in zoned {
            let Model { blocks, corners, fdef, gravity, .. } = &mut *model;
            let f = &mut fdef[b];
            let mut damping = 0.0;
            for m in &mut f.gridpoints {
                let d = &gridpoints[g];
                m.position = [pair(d.x, d.x_lo, o[0]), pair(d.y, d.y_lo, o[1])];
                m.velocity = [d.vx.to_f64(), d.vy.to_f64()];
                m.force = [d.fx.to_f64(), d.fy.to_f64()];
                m.update_position = [pair(d.ux, d.ux_lo, o[0]), pair(d.uy, d.uy_lo, o[1])];
                damping += d.damping_work.to_f64();
                work += d.work.to_f64();
                g += 1;
            }
            f.damping_work = up.fdef_damping_base.get(b).copied().unwrap_or(0.0) + damping;
            for m in &mut f.zones {
                m.stress = zones[z].stress.map(|s| s.to_f64());
                z += 1;
            }
            let blk = &mut blocks[b];
            let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
            crate::udec::model::corners::place_corners_fdef(blk, f, &mut corners[range]);
            external[b] = Some([blk.mass * gravity[0] + blk.load[0], blk.mass * gravity[1] + blk.load[1]]);
        }
        for c in &model.contacts {
            for (b, sign) in [(c.block1 as usize, 1.0), (c.block2 as usize, -1.0)] {
                if let Some(e) = external[b].as_mut() {
                    e[0] += sign * c.force[0];
                    e[1] += sign * c.force[1];
                }
            }
        }
        for (blk, e) in model.blocks.iter_mut().zip(external) {
            if let Some(e) = e {
                blk.force = e;
                blk.moment = 0.0;
            }
        }
        model.external_work += work;
    }

    /// After a contact update in a scene with zoned blocks: the blocks it re-examined
    /// (`reset`) measure their boundary's travel from here on (`GridPoint::update_position`), as
    /// their reset update distances do. The grid points as last read back are current (no cycle
    /// ran since).
    pub(super) fn reset_update_positions(&mut self, reset: &[usize]) {
        if !self.fdef_scene || self.last_gridpoints.is_empty() {
            return;
        }
        let mut changed = false;
        for &b in reset {
            if self.last_blocks.get(b).is_some_and(|blk| blk.kind == BLOCK_FDEF) {
                let start = self.fdef_gp_start[b] as usize;
                for gp in self.last_gridpoints[start..].iter_mut().take_while(|g| g.block == b as u32) {
                    (gp.ux, gp.uy, gp.ux_lo, gp.uy_lo) = (gp.x, gp.y, gp.x_lo, gp.y_lo);
                }
                changed = true;
            }
        }
        if changed {
            let b = self.buffers();
            self.dev.queue.write_buffer(
                &b.gridpoints.as_ref().expect("a scene with zoned blocks has them").buffer,
                0,
                bytemuck::cast_slice(&self.last_gridpoints),
            );
        }
    }

    /// The FDEF kernels and their bind groups, in a scene with zoned blocks (the cycle, the
    /// gather pass and the energy check run them then).
    pub(super) fn fdef_kernels(&self) -> Option<(&super::kernels::FdefKernels, &super::kernels::FdefBindGroups)> {
        let groups = self.bind_groups.as_ref()?.fdef.as_ref()?;
        Some((self.pipelines.fdef.as_ref()?, groups)).filter(|_| self.fdef_scene)
    }

    /// The items the energy check's grid covers: blocks, and in a scene with zoned blocks their
    /// grid points and zones too (`energy_sums_fdef` adds them on the same grid).
    pub(super) fn energy_items(&self, blocks: usize) -> usize {
        if self.fdef_scene {
            blocks.max(self.fdef_counts.0).max(self.fdef_counts.1)
        } else {
            blocks
        }
    }
}

/// The CPU backend's error for a zone turned inside out, from the lowest zone index the device
/// flagged (its zones in block order, as uploaded): the block and the zone's number in it.
pub(super) fn inverted_zone_error(model: &Model, zone: u32) -> CycleError {
    let mut first = 0usize;
    for (b, blk) in model.blocks.iter().enumerate().filter(|&(b, _)| is_zoned(model, b)) {
        let n = model.fdef[b].zones.len();
        if (zone as usize) < first + n {
            return CycleError::ZoneInverted { cycle: model.cycle, block: blk.id, zone: (zone as usize - first) as u32 + 1 };
        }
        first += n;
    }
    CycleError::Setup(format!("GPU: zone {zone} was flagged inverted, but the model has {first} zones (a bug)"))
}

/// Refuses what the GPU does not run of fully-deformable blocks: a scene with both zoned and
/// simply-deformable blocks (their kernels are apart; the CPU backend runs it), and slots past
/// the adapter's binding limit.
pub(super) fn check_fits<R: Real>(model: &Model, cap: u64, precision: crate::gpu::Precision) -> Result<(), GpuError> {
    let zoned: Vec<usize> = (0..model.blocks.len()).filter(|&b| is_zoned(model, b)).collect();
    if zoned.is_empty() {
        return Ok(());
    }
    if model.blocks.iter().any(|b| b.kind == BlockKind::SimplyDeformable) {
        return Err(GpuError::DoesNotFit(
            "a scene with both fully-deformable (zoned) and simply-deformable blocks runs on the CPU backend only in this version; use --backend cpu or --backend auto"
                .into(),
        ));
    }
    let (gps, zones) = zoned.iter().fold((0, 0), |(g, z), &b| (g + model.fdef[b].gridpoints.len(), z + model.fdef[b].zones.len()));
    super::kernels::check_fits("grid points", std::mem::size_of::<GridPoint<R>>(), gps, cap, precision)?;
    super::kernels::check_fits("zones", std::mem::size_of::<Zone<R>>(), zones, cap, precision)
}
