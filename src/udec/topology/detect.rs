//! Contact detection and update.
//!
//! The report's rule (¶26): a block is re-examined only after it has moved more than a threshold
//! since its previous update, so almost-stationary regions cost nothing. Here a block is due
//! when its corners have moved more than `etol` (a quarter of the contact-forming distance `atol`)
//! since its last update; two unflagged blocks can have approached each other by less than
//! 2·etol < atol since their pair was last examined, so no touch can be missed. A fast block gets
//! a speed margin m at its update (`Tolerances::speed_margin`, about 16 of its steps): it is
//! searched m farther around and is due only past etol + m, so a projectile asks for an update
//! every ~16 steps rather than every 3. Once an update is due, every block past half of its own
//! threshold is re-examined with it, so a crowd of flying blocks shares its updates.
//!
//! Candidates are the block pairs, at least one of them flagged, whose corner boxes inflated by
//! atol/2 and their speed margins overlap. Each is examined both ways round: every corner circle
//! of one block against the nearest feature of the other's rounded boundary. Contacts form when
//! the gap falls below `atol` and break when it exceeds `btol` (hysteresis, so a contact at the
//! threshold does not flicker), both plus the two blocks' speed margins.
//! A contact keeps its identity — and so its shear history — as long as the same corner stays near
//! the same block (feature ids, STYLE.md item 7).
//!
//! Broad phase: a uniform cell grid, stored as (cell, block) entries sorted by cell, over boxes
//! inflated by a further margin (very large blocks, such as a base, go to a list tested against
//! every flagged block). The grid outlives an update: a block's stored box holds its corners while
//! they stay within the margin of where they were when it was built, which the update checks from
//! the block's centroid and rotation, so an update examines the flagged blocks and their
//! neighbourhood and boxes only the blocks that have strayed. A full update, or one where many
//! blocks moved, rebuilds it and sweeps it cell by cell.
//!
//! Everything runs in parallel and lands in a fixed order: the pairs are sorted, each block's
//! corners are examined against its candidates in ascending order, and the contacts stay sorted by
//! (block 1, corner, block 2). New contacts get their ids in the order a serial sweep over the
//! sorted pairs would create them (lower block's corners first), so a run repeats bit for bit
//! whatever the thread count.

use rayon::prelude::*;

use super::adjacency::EntriesEdit;
use super::{Adjacency, Topology};
use crate::udec::contact::geometry::nearest_feature;
use crate::udec::contact::joint::{joint_share, law_parameters, opposed_length};
use crate::udec::model::{Block, Contact, ContactKind, Corner, Feature, Material, Model, Tolerances};

/// Bounding boxes above this many grid cells are treated as "large" and tested against all.
const MAX_CELLS_PER_BLOCK: u64 = 64;

/// Smallest number of blocks one parallel task takes.
const PARALLEL_BLOCKS: usize = 256;

/// Smallest number of contacts one parallel task takes.
const PARALLEL_CONTACTS: usize = 4096;

/// An update rebuilds the grid and sweeps it cell by cell when more than 1/SWEEP_FRACTION of the
/// blocks is flagged, and rebuilds it when more than 1/REBUILD_FRACTION has strayed from its
/// stored box (each update boxes the strayed blocks afresh; a rebuild boxes them all once).
const SWEEP_FRACTION: usize = 8;
const REBUILD_FRACTION: usize = 32;

/// Axis-aligned box of a block's corners, inflated by `pad`.
#[inline]
fn bounding_box(corners: &[Corner], pad: f64) -> [f64; 4] {
    let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for c in corners {
        bb[0] = bb[0].min(c.position[0]);
        bb[1] = bb[1].min(c.position[1]);
        bb[2] = bb[2].max(c.position[0]);
        bb[3] = bb[3].max(c.position[1]);
    }
    [bb[0] - pad, bb[1] - pad, bb[2] + pad, bb[3] + pad]
}

#[inline]
fn boxes_overlap(a: &[f64; 4], b: &[f64; 4]) -> bool {
    a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3]
}

#[inline]
fn corners_of<'a>(blocks: &[Block], corners: &'a [Corner], b: usize) -> &'a [Corner] {
    let blk = &blocks[b];
    &corners[blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize]
}

/// The cells of the grid: square, of side `size`, counted from (x0, y0).
#[derive(Clone, Copy, Debug, Default)]
struct Cells {
    x0: f64,
    y0: f64,
    size: f64,
}

/// A rectangle of cells, inclusive.
#[derive(Clone, Copy)]
struct CellRange {
    x: (u32, u32),
    y: (u32, u32),
}

impl CellRange {
    fn count(&self) -> u64 {
        (self.x.1 as u64 - self.x.0 as u64 + 1).saturating_mul(self.y.1 as u64 - self.y.0 as u64 + 1)
    }

    fn keys(self) -> impl Iterator<Item = u64> {
        (self.y.0..=self.y.1).flat_map(move |cy| (self.x.0..=self.x.1).map(move |cx| cell_key(cx, cy)))
    }
}

#[inline]
fn cell_key(cx: u32, cy: u32) -> u64 {
    (cy as u64) << 32 | cx as u64
}

impl Cells {
    /// The cell of a point. The map is monotone in each coordinate (the casts saturate), so the
    /// cells of a box's two corners bound the cell of every point inside it: two overlapping boxes
    /// share at least the cell of any common point.
    #[inline]
    fn of(&self, x: f64, y: f64) -> (u32, u32) {
        (((x - self.x0) / self.size).floor() as u32, ((y - self.y0) / self.size).floor() as u32)
    }

    #[inline]
    fn key_of(&self, x: f64, y: f64) -> u64 {
        let (cx, cy) = self.of(x, y);
        cell_key(cx, cy)
    }

    #[inline]
    fn range(&self, bb: &[f64; 4]) -> CellRange {
        let (cx0, cy0) = self.of(bb[0], bb[1]);
        let (cx1, cy1) = self.of(bb[2], bb[3]);
        CellRange { x: (cx0, cx1.max(cx0)), y: (cy0, cy1.max(cy0)) }
    }
}

/// The blocks of a sorted (cell, block) list in one cell.
fn members(entries: &[(u64, u32)], key: u64) -> &[(u64, u32)] {
    let lo = entries.partition_point(|e| e.0 < key);
    let hi = lo + entries[lo..].partition_point(|e| e.0 == key);
    &entries[lo..hi]
}

/// Splits `buf` into consecutive pieces ending at each of `ends` (ascending, the last ≤ len).
pub(super) fn split_at_ends<T>(mut buf: &mut [T], ends: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut pieces = Vec::new();
    let mut at = 0;
    for end in ends {
        let (piece, rest) = std::mem::take(&mut buf).split_at_mut(end - at);
        pieces.push(piece);
        buf = rest;
        at = end;
    }
    pieces
}

/// The broad phase's grid, kept between contact updates (in `Topology`, beside the adjacency
/// lists, the other index stage 7 keeps). Built from every block's box inflated by `margin`; a block's stored
/// box holds its current box as long as its corners stay within the margin of where they were
/// when the grid was built.
#[derive(Clone, Default)]
pub struct BlockGrid {
    /// Blocks and corners of the model it was built for; anything else means a rebuild.
    shape: Option<(usize, usize)>,
    cells: Cells,
    margin: f64,
    /// Per block when the grid was built: centroid, rotation, the farthest corner's distance
    /// from the centroid (measured here, so the test below does not lean on `Block::radius`),
    /// and its speed margin (a block given a larger one since has outgrown its stored box).
    reference: Vec<[f64; 5]>,
    /// Per block: its box (inflated by atol/2 and its speed margin) inflated by `margin` when the
    /// grid was built.
    stored: Vec<[f64; 4]>,
    /// (cell key, block) for every cell of every stored box that is not large, sorted.
    entries: Vec<(u64, u32)>,
    /// Blocks whose stored box spans more than MAX_CELLS_PER_BLOCK cells.
    large: Vec<u32>,
    /// Builds so far (`builds`).
    builds: u64,
}

impl std::fmt::Debug for BlockGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BlockGrid")
            .field("shape", &self.shape)
            .field("cells", &self.cells)
            .field("entries", &self.entries.len())
            .field("large", &self.large.len())
            .finish()
    }
}

impl BlockGrid {
    /// Whether the grid was built for a model of this shape (an update then keeps it).
    pub fn valid_for(&self, model: &Model) -> bool {
        self.shape == Some((model.blocks.len(), model.corners.len()))
    }

    /// Builds the grid from the current positions; returns every block's current box (inflated
    /// by atol/2 and its speed margin) for a sweep that follows.
    fn build(&mut self, model: &Model) -> Vec<[f64; 4]> {
        let n = model.blocks.len();
        let pad = 0.5 * model.tol.atol;
        // The margin: a block may stray half of it before its stored box is given up (the other
        // half absorbs rounding, and the f32 corner offsets a GPU backend reads back).
        self.margin = model.tol.atol.max(2.0 * model.tol.etol);
        let margin = self.margin;
        let (blocks, corners) = (&model.blocks, &model.corners);
        let mut current = Vec::with_capacity(n);
        (0..n)
            .into_par_iter()
            .with_min_len(PARALLEL_BLOCKS)
            .map(|b| bounding_box(corners_of(blocks, corners, b), pad + blocks[b].update_margin))
            .collect_into_vec(&mut current);
        self.stored.clear();
        self.stored.par_extend(current.par_iter().map(|bb| [bb[0] - margin, bb[1] - margin, bb[2] + margin, bb[3] + margin]));
        self.reference.clear();
        self.reference.par_extend(blocks.par_iter().with_min_len(PARALLEL_BLOCKS).map(|blk| {
            let c = blk.centroid;
            let own = &corners[blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize];
            let reach = own.iter().map(|k| (k.position[0] - c[0]).hypot(k.position[1] - c[1])).fold(0.0f64, f64::max);
            [c[0], c[1], blk.rotation, reach, blk.update_margin]
        }));
        // Cell size: the mean stored extent, so a typical block spans about four cells. Summed in
        // fixed chunks so that it does not depend on the thread count (it only sets the speed).
        let extent = |bb: &[f64; 4]| (bb[2] - bb[0]).max(bb[3] - bb[1]);
        let partial: Vec<(f64, usize)> =
            self.stored.par_chunks(4096).map(|ch| ch.iter().map(extent).filter(|e| e.is_finite()).fold((0.0, 0), |(s, k), e| (s + e, k + 1))).collect();
        let (sum, count) = partial.iter().fold((0.0, 0), |(s, k), &(ps, pk)| (s + ps, k + pk));
        let size = if count > 0 && sum > 0.0 { sum / count as f64 } else { 1.0 };
        let size = size.max(1e-12);
        // Origin: the lowest box corner, unless that lies more than 2³¹ cells below the median
        // one (a block flung far away), so that the bulk of the blocks keeps distinct cells in
        // the u32 range; outliers beyond it share its edge cells (their tests stay exact).
        let origin = |axis: usize| {
            let mut v: Vec<f64> = self.stored.par_iter().map(|bb| bb[axis]).collect();
            let lowest = v.par_iter().copied().reduce(|| f64::INFINITY, f64::min);
            let k = v.len() / 2;
            let median = *v.select_nth_unstable_by(k, f64::total_cmp).1;
            let o = lowest.max(median - 2f64.powi(31) * size);
            if o.is_finite() {
                o
            } else {
                0.0
            }
        };
        self.cells = Cells { x0: origin(0), y0: origin(1), size };
        let cells = self.cells;
        // Entries: each block's cells, written in parallel at offsets from a prefix sum.
        let ranges: Vec<CellRange> = self.stored.par_iter().with_min_len(PARALLEL_BLOCKS).map(|bb| cells.range(bb)).collect();
        let mut ends = Vec::with_capacity(n);
        let mut total = 0usize;
        self.large.clear();
        for (b, r) in ranges.iter().enumerate() {
            let k = r.count();
            if k > MAX_CELLS_PER_BLOCK {
                self.large.push(b as u32);
            } else {
                total += k as usize;
            }
            ends.push(total);
        }
        self.entries.clear();
        self.entries.resize(total, (0, 0));
        let chunk_ends = (1..=n.div_ceil(PARALLEL_BLOCKS)).map(|c| ends[(c * PARALLEL_BLOCKS).min(n) - 1]);
        split_at_ends(&mut self.entries, chunk_ends).into_par_iter().enumerate().for_each(|(c, out)| {
            let mut w = 0;
            for (b, range) in ranges.iter().enumerate().take(((c + 1) * PARALLEL_BLOCKS).min(n)).skip(c * PARALLEL_BLOCKS) {
                if range.count() <= MAX_CELLS_PER_BLOCK {
                    for key in range.keys() {
                        out[w] = (key, b as u32);
                        w += 1;
                    }
                }
            }
        });
        self.entries.par_sort_unstable();
        self.shape = Some((n, model.corners.len()));
        self.builds += 1;
        current
    }

    /// True when block `b` may have left its stored box: its corners can have moved by up to
    /// |Δc| + |Δθ|·reach since the grid was built (a rigid motion), checked against half the
    /// margin; or its speed margin has grown since.
    #[inline]
    fn strayed(&self, b: usize, blk: &Block) -> bool {
        // A fully-deformable block changes shape: its stored box is never trusted.
        if blk.kind == crate::udec::model::BlockKind::FullyDeformable {
            return true;
        }
        let [x, y, rot, reach, speed_margin] = self.reference[b];
        let moved = (blk.centroid[0] - x).hypot(blk.centroid[1] - y) + (blk.rotation - rot).abs() * reach;
        moved.is_nan() || moved > 0.5 * self.margin || blk.update_margin > speed_margin
    }

    /// Every ordered pair (p, q), p ≠ q, of blocks whose current boxes overlap and at least one of
    /// which is flagged, sorted: a sweep over the whole grid, right after `build` (`current` is
    /// what it returned).
    fn sweep(&self, current: &[[f64; 4]], flagged: &[bool]) -> Vec<u64> {
        let cells = self.cells;
        let stored = &self.stored;
        let entries = &self.entries;
        // Tasks of whole cells: chunk starts moved forward to the next cell boundary.
        let step = 4 * PARALLEL_BLOCKS;
        let mut starts: Vec<usize> = (0..entries.len()).step_by(step).map(|i| i + entries[i..].partition_point(|e| i > 0 && e.0 == entries[i - 1].0)).collect();
        starts.push(entries.len());
        starts.dedup();
        let mut pairs: Vec<u64> = starts
            .par_windows(2)
            .flat_map_iter(|w| {
                let mut out = Vec::new();
                let mut i = w[0];
                while i < w[1] {
                    let key = entries[i].0;
                    let j = i + entries[i..].partition_point(|e| e.0 == key);
                    let cell = &entries[i..j];
                    for (x, &(_, p)) in cell.iter().enumerate() {
                        for &(_, q) in &cell[x + 1..] {
                            let (p, q) = (p as usize, q as usize);
                            if !(flagged[p] || flagged[q]) || !boxes_overlap(&current[p], &current[q]) {
                                continue;
                            }
                            // Counted once: in the cell of the lower-left corner of the stored
                            // boxes' intersection, which both boxes cover.
                            if cells.key_of(stored[p][0].max(stored[q][0]), stored[p][1].max(stored[q][1])) == key {
                                out.push((p as u64) << 32 | q as u64);
                                out.push((q as u64) << 32 | p as u64);
                            }
                        }
                    }
                    i = j;
                }
                out
            })
            .collect();
        for &l in &self.large {
            let l = l as usize;
            let found: Vec<u64> = (0..current.len())
                .into_par_iter()
                .with_min_len(PARALLEL_CONTACTS)
                .filter(|&b| b != l && (flagged[l] || flagged[b]) && boxes_overlap(&current[l], &current[b]))
                .flat_map_iter(|b| [(l as u64) << 32 | b as u64, (b as u64) << 32 | l as u64])
                .collect();
            pairs.extend(found);
        }
        pairs.par_sort_unstable();
        // Two large blocks find each other twice.
        pairs.dedup();
        pairs
    }

    /// How many times a grid was built (`build`): the reference below changes only then.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// Per block when the grid was built: centroid, rotation, reach, speed margin.
    pub fn reference(&self) -> &[[f64; 5]] {
        &self.reference
    }

    /// Half the grid's margin: a block whose corners moved farther since the build may have left
    /// its stored box (`strayed`).
    pub fn stray_limit(&self) -> f64 {
        0.5 * self.margin
    }

    /// Every block `query` may read for these flagged and strayed blocks (ascending): the flagged
    /// and strayed ones, and those whose stored boxes overlap a flagged block's box (`boxes`,
    /// current, in the order of `flagged_list`). None when a box spans more cells than there are
    /// blocks (the query then tests every block).
    fn neighbourhood(&self, n: usize, flagged_list: &[u32], strayed: &[u32], boxes: &[[f64; 4]]) -> Option<Vec<u32>> {
        let mut out: Vec<u32> = flagged_list.iter().chain(strayed).copied().collect();
        for fb in boxes {
            let range = self.cells.range(fb);
            if range.count() > (n as u64).max(MAX_CELLS_PER_BLOCK) {
                return None;
            }
            for key in range.keys() {
                out.extend(members(&self.entries, key).iter().map(|&(_, b)| b).filter(|&b| boxes_overlap(fb, &self.stored[b as usize])));
            }
            out.extend(self.large.iter().copied().filter(|&b| boxes_overlap(fb, &self.stored[b as usize])));
        }
        out.sort_unstable();
        out.dedup();
        Some(out)
    }

    /// The same pairs as `sweep` for a few flagged blocks (`flagged_list`, ascending), from the
    /// stored grid. `strayed` lists (ascending) the unflagged blocks that may have left their
    /// stored boxes: those, and the flagged ones, are boxed afresh and put in a small grid of
    /// their own.
    fn query(&self, model: &Model, flagged_list: &[u32], strayed: &[u32]) -> Vec<u64> {
        let (blocks, corners) = (&model.blocks, &model.corners);
        let n = blocks.len();
        let pad = 0.5 * model.tol.atol;
        let cells = self.cells;
        let boxed = |b: usize| bounding_box(corners_of(blocks, corners, b), pad + blocks[b].update_margin);
        // The moving set: flagged and strayed blocks, with their current boxes.
        let mut moving: Vec<u32> = Vec::with_capacity(flagged_list.len() + strayed.len());
        let (mut i, mut j) = (0, 0);
        while i < flagged_list.len() || j < strayed.len() {
            let take_f = j == strayed.len() || (i < flagged_list.len() && flagged_list[i] <= strayed[j]);
            if take_f {
                moving.push(flagged_list[i]);
                i += 1;
            } else {
                moving.push(strayed[j]);
                j += 1;
            }
        }
        moving.dedup();
        let is_moving = |b: u32| moving.binary_search(&b).is_ok();
        let moving_box: Vec<[f64; 4]> = moving.par_iter().map(|&b| boxed(b as usize)).collect();
        let box_of_moving = |b: u32| moving_box[moving.binary_search(&b).expect("a moving block")];
        let mut moving_entries: Vec<(u64, u32)> = Vec::new();
        let mut moving_large: Vec<u32> = Vec::new();
        for (&b, bb) in moving.iter().zip(&moving_box) {
            let r = cells.range(bb);
            if r.count() > MAX_CELLS_PER_BLOCK {
                moving_large.push(b);
            } else {
                moving_entries.extend(r.keys().map(|key| (key, b)));
            }
        }
        moving_entries.sort_unstable();
        let mut pairs: Vec<u64> = flagged_list
            .par_iter()
            .flat_map_iter(|&f| {
                let fb = box_of_moving(f);
                let range = cells.range(&fb);
                // A box over more cells than there are blocks tests every block instead.
                let huge = range.count() > (n as u64).max(MAX_CELLS_PER_BLOCK);
                let mut found: Vec<u32> = Vec::new();
                {
                    let mut offer_moving = |b: u32| {
                        if b != f && boxes_overlap(&fb, &box_of_moving(b)) {
                            found.push(b);
                        }
                    };
                    moving_large.iter().for_each(|&b| offer_moving(b));
                    if huge {
                        moving.iter().for_each(|&b| offer_moving(b));
                    } else {
                        for key in range.keys() {
                            members(&moving_entries, key).iter().for_each(|&(_, b)| offer_moving(b));
                        }
                    }
                }
                let mut offer_still = |b: u32| {
                    // A block that has not strayed: its stored box holds its current one.
                    if b != f && !is_moving(b) && boxes_overlap(&fb, &self.stored[b as usize]) && boxes_overlap(&fb, &boxed(b as usize)) {
                        found.push(b);
                    }
                };
                if huge {
                    (0..n as u32).for_each(&mut offer_still);
                } else {
                    for key in range.keys() {
                        members(&self.entries, key).iter().for_each(|&(_, b)| offer_still(b));
                    }
                    self.large.iter().for_each(|&b| offer_still(b));
                }
                found.into_iter().flat_map(move |b| [(f as u64) << 32 | b as u64, (b as u64) << 32 | f as u64])
            })
            .collect();
        pairs.par_sort_unstable();
        pairs.dedup();
        pairs
    }
}

/// The joint material and constitutive number of a new contact: a tag on the touched edge of
/// block 2, else a tag on an edge at block 1's corner (SPLIT MAT= CONS=), else block 2's own
/// (the manual: "the joint or contact will take the material and constitutive numbers of one of
/// the adjoining blocks").
fn contact_material(blocks: &[Block], corners: &[Corner], corner: u32, block2: usize, feature: u32) -> (u32, u32) {
    let b2 = &blocks[block2];
    let corners2 = corners_of(blocks, corners, block2);
    let k = (feature / 2) as usize % corners2.len();
    if feature % 2 == 1 && corners2[k].edge_material != 0 {
        return (corners2[k].edge_material, corners2[k].edge_constitutive.max(1));
    }
    let c = &corners[corner as usize];
    let b1 = &blocks[c.block as usize];
    let prev = if corner == b1.corner_start { b1.corner_start + b1.corner_count - 1 } else { corner - 1 };
    for tagged in [c, &corners[prev as usize]] {
        if tagged.edge_material != 0 {
            return (tagged.edge_material, tagged.edge_constitutive.max(1));
        }
    }
    (b2.material, b2.constitutive)
}

/// The length of joint contact `c` carries now (`contact::joint`): half the common length of its
/// faces in opposition when its constitutive number and material give the joint law, else 0.
/// The numbers and the material are looked at first: a model without joints measures no faces.
fn joint_length_of(c: &Contact, blocks: &[Block], corners: &[Corner], materials: &[Material]) -> f64 {
    use crate::udec::contact::joint::has_joint_law;
    use crate::udec::model::constitutive::{Constitutive, ContactLaw};
    let mat = &materials[crate::udec::model::material_slot(c.material, materials.len())];
    if !Constitutive::from_number(c.constitutive).is_some_and(|k| k.contact == ContactLaw::Joint) || !has_joint_law(mat) {
        return 0.0;
    }
    let b1 = &blocks[c.block1 as usize];
    let corners1 = corners_of(blocks, corners, c.block1 as usize);
    let i = c.corner.wrapping_sub(b1.corner_start) as usize;
    if i >= corners1.len() {
        return 0.0;
    }
    joint_share(c.constitutive, mat, opposed_length(corners1, i, corners_of(blocks, corners, c.block2 as usize), c.feature))
}

/// The strain energy a contact's springs give up when its law changes from `old` to `new` (the
/// parameters of `law_parameters`) at a contact update: the shear force stays (eq. 17 is
/// incremental), so its spring holds Fs²/2ks under the new stiffness; the normal force, eq. (16)
/// in total form, becomes kn_new/kn_old times as large at the next cycle. Booked as released, so
/// the ledger stays balanced across the change.
fn law_change_release(c: &Contact, old: &crate::udec::model::ContactMaterial, new: &crate::udec::model::ContactMaterial) -> f64 {
    let mut e = 0.0;
    if old.kn > 0.0 && new.kn > 0.0 {
        e += c.normal_force.powi(2) / (2.0 * old.kn) * (1.0 - new.kn / old.kn);
    }
    if old.ks > 0.0 && new.ks > 0.0 {
        e += c.shear_force.powi(2) * 0.5 * (1.0 / old.ks - 1.0 / new.ks);
    }
    e
}

/// What examining one block's corners against its candidates decided.
#[derive(Default)]
struct Examined {
    /// Strain energy the kept contacts whose law changed gave up (`law_change_release`).
    released: f64,
    /// Contacts (indices into the contact list) whose gap now exceeds btol.
    dropped: Vec<u32>,
    /// New contacts, sorted by (corner, block 2).
    created: Vec<NewContact>,
}

/// A contact that `examine` found, before it has an id: what it sets of the `Contact` it
/// becomes (the rest starts at zero) and the index of the first contact after it in the current
/// list. 72 bytes where a (position, Contact) pair takes 160: a first detection holds 8·10⁶ of
/// them at 10⁶ blocks.
#[derive(Clone, Copy)]
struct NewContact {
    before: u32,
    block1: u32,
    corner: u32,
    block2: u32,
    feature: Feature,
    material: u32,
    constitutive: u32,
    kind: ContactKind,
    bonded: bool,
    point: [f64; 2],
    normal: [f64; 2],
    gap: f64,
}

const _: () = assert!(std::mem::size_of::<NewContact>() == 72 && std::mem::size_of::<(u32, Contact)>() == 160);

impl NewContact {
    fn contact(&self, id: u32) -> Contact {
        let NewContact { before: _, block1, corner, block2, feature, material, constitutive, kind, bonded, point, normal, gap } = *self;
        Contact { feature, kind, bonded, point, normal, gap, ..Contact::identity(id, block1, corner, block2, material, constitutive) }
    }
}

/// Every corner of block `a` against the nearest feature of each candidate block `cands`
/// (ascending). `run` holds a's contacts (block 1 = a), which start at `run_start` in the list:
/// those that stay in touch get the new geometry, the others are reported dropped; a corner that
/// has no contact with a candidate and comes within atol of it makes a new one. Both distances
/// grow by the speed margins of the two blocks (`Tolerances::speed_margin`).
#[allow(clippy::too_many_arguments)]
fn examine(
    a: usize,
    cands: &[u64],
    run: &mut [Contact],
    run_start: usize,
    blocks: &[Block],
    corners: &[Corner],
    materials: &[Material],
    tol: &Tolerances,
) -> Examined {
    let mut out = Examined::default();
    let blk = &blocks[a];
    for corner in blk.corner_start..blk.corner_start + blk.corner_count {
        let c = &corners[corner as usize];
        for &pair in cands {
            let b = pair as u32;
            let extra = blk.update_margin + blocks[b as usize].update_margin;
            let g = nearest_feature(corners_of(blocks, corners, b as usize), c.circle, c.radius);
            // The run is sorted by (corner, block 2); an identity found twice counts as its last.
            let at = run.partition_point(|x| (x.corner, x.block2) <= (corner, b));
            match at.checked_sub(1).filter(|&k| run[k].corner == corner && run[k].block2 == b) {
                Some(k) => {
                    if g.gap > tol.btol + extra {
                        out.dropped.push((run_start + k) as u32);
                    } else {
                        let contact = &mut run[k];
                        contact.feature = g.feature;
                        contact.kind = g.kind;
                        contact.gap = g.gap;
                        contact.normal = g.normal;
                        contact.point = g.point;
                        // Joint or point contact (¶5), from the faces as they are now; the shear
                        // force and displacement stay (the history carries over).
                        let length = joint_length_of(contact, blocks, corners, materials);
                        if length != contact.joint_length {
                            let mat = &materials[crate::udec::model::material_slot(contact.material, materials.len())];
                            out.released += law_change_release(contact, &law_parameters(contact.joint_length, mat), &law_parameters(length, mat));
                            contact.joint_length = length;
                        }
                    }
                }
                None if g.gap < tol.atol + extra => {
                    let (material, constitutive) = contact_material(blocks, corners, corner, b as usize, g.feature);
                    out.created.push(NewContact {
                        before: (run_start + at) as u32,
                        block1: a as u32,
                        corner,
                        block2: b,
                        feature: g.feature,
                        material,
                        constitutive,
                        kind: g.kind,
                        // Surfaces already in touch when the contact forms (the two sides of
                        // a SPLIT, blocks built against each other) are an intact joint.
                        bonded: g.gap <= 1e-9 * tol.round.max(1e-300),
                        point: g.point,
                        normal: g.normal,
                        gap: g.gap,
                    });
                }
                None => {}
            }
        }
    }
    out
}

#[inline]
fn contact_key(c: &Contact) -> (u32, u32, u32) {
    (c.block1, c.corner, c.block2)
}

/// What one contact update did, for the caller's report and for keeping the adjacency lists.
pub struct ContactChanges {
    pub created: usize,
    pub dropped: usize,
    /// The list was out of order on entry and has been sorted: the adjacency lists are stale.
    pub reordered: bool,
    /// What changed in the list (given lists to keep, and the list in order on entry).
    pub edit: Option<ListEdit>,
}

/// Re-examines the neighbourhood of every flagged block (all blocks when `all` is true), creates
/// new contacts, drops broken ones, and returns how many contacts were created and dropped.
/// The caller rebuilds the adjacency lists afterwards.
pub fn update_contacts(model: &mut Model, all: bool) -> (usize, usize) {
    let ch = in_pool(|| update_here(model, all, &mut BlockGrid::default(), None));
    (ch.created, ch.dropped)
}

/// Stage 7's contact update as the backends run it: `update_contacts` with the broad phase's grid
/// kept in `topology` between calls, the adjacency lists brought up to date, the list's edit
/// recorded, and the energy terms of the contacts dropped moved to the ledger's retired account.
pub fn update_topology(model: &mut Model, all: bool, topology: &mut Topology) -> (usize, usize) {
    let Topology { lists, grid, edit } = topology;
    let ch = in_pool(|| update_here(model, all, grid, Some(lists)));
    *edit = ch.edit;
    (ch.created, ch.dropped)
}

/// Brings blocks (or, given None, everything) into a model current only in part (`Attention`).
pub type Fetch<'a> = dyn FnMut(&mut Model, Option<&[u32]>) -> Result<(), String> + 'a;

/// What a backend whose state lives elsewhere (the GPU's device memory) gives the contact update
/// instead of a model whose every block and contact is current (`update_topology_with`).
pub struct Attention<'a> {
    /// Ascending: a superset of the blocks the update may re-examine (past half their threshold)
    /// or find strayed from the grid, each current in the model (record and corners).
    pub blocks: Vec<u32>,
    /// Ascending: a superset of the contacts it may drop by their gap, each current in the model;
    /// with them every contact of a block in `blocks` whose margin it may change.
    pub contacts: Vec<u32>,
    /// Called once the re-examined and strayed blocks are known, before anything in the model
    /// changes: brings into the model the blocks the update will read (ascending; their records,
    /// corners and runs of contacts, block 1 first), or, given None, everything. An error ends
    /// the update with the model as it was.
    pub fetch: &'a mut Fetch<'a>,
}

/// `update_topology` on a model that is current only where `attention` says (and where its
/// `fetch` brings it): the contact list must be in the update's order (block 1, corner, block 2)
/// and the grid kept in `topology` built for this model. The blocks re-examined and the
/// contacts dropped are exactly those `update_topology` would find on the whole current model.
/// Returns the contacts created and dropped and the blocks re-examined (ascending).
pub fn update_topology_with(model: &mut Model, topology: &mut Topology, attention: &mut Attention<'_>) -> Result<(usize, usize, Vec<u32>), String> {
    let Topology { lists, grid, edit } = topology;
    // Not in rayon's pool: the fetch may hold the device, which stays on this thread.
    let (ch, flagged) = update(model, false, grid, Some(lists), Some(attention))?;
    *edit = ch.edit;
    Ok((ch.created, ch.dropped, flagged))
}

/// `update` where nothing is fetched (no attention), so nothing can fail.
fn update_here(model: &mut Model, all: bool, grid: &mut BlockGrid, adjacency: Option<&mut Adjacency>) -> ContactChanges {
    match update(model, all, grid, adjacency, None) {
        Ok((ch, _)) => ch,
        Err(e) => unreachable!("an update without attention fetched nothing: {e}"),
    }
}

/// Runs `f` on one of rayon's worker threads: the update's many short parallel loops then start
/// without each handing its work over from an outside thread (which costs about as much as a
/// small model's whole update).
fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| f())
}

/// The contacts that are about to be dropped take their energy terms to `model.retired`: the
/// strain energy of their springs (released) and what their dashpots and friction dissipated.
/// The same terms as the ledger's live sums, taken in storage order so the result repeats.
fn retire(model: &mut Model, dropped: &[u32]) {
    let (mut released, mut damping, mut friction) = (0.0, 0.0, 0.0);
    for &k in dropped {
        let c = &model.contacts[k as usize];
        let m = law_parameters(c.joint_length, model.material(c.material));
        if m.kn > 0.0 {
            released += c.normal_force.powi(2) / (2.0 * m.kn);
        }
        if m.ks > 0.0 {
            released += c.shear_force.powi(2) / (2.0 * m.ks);
        }
        damping += c.dashpot_work;
        friction += c.slip_work;
    }
    model.retired.released += released;
    model.retired.contact_damping += damping;
    model.retired.friction += friction;
}

/// What the update makes of a block (`update`'s first pass).
enum Pick {
    /// Re-examined: past half its update threshold (or every block, for a sweep).
    Flagged,
    /// Not flagged, but outside the box the kept grid stores for it: the grid must follow it.
    Strayed,
    Neither,
}

fn update(
    model: &mut Model,
    all: bool,
    grid: &mut BlockGrid,
    adjacency: Option<&mut Adjacency>,
    mut attention: Option<&mut Attention<'_>>,
) -> Result<(ContactChanges, Vec<u32>), String> {
    let n = model.blocks.len();
    let tol = model.tol;
    let btol = tol.btol;
    // One pass over the blocks (or over those the attention lists): those flagged, and (with a
    // grid to keep) the unflagged ones that may have left their stored boxes. Flagged: past its
    // update threshold, or past half of it (an update is under way: re-examining the blocks that
    // would soon ask for one of their own keeps a crowd of moving blocks, flying debris, from
    // calling one update each).
    let keep_grid = !all && grid.valid_for(model);
    let pick = |g: &BlockGrid, b: usize, blk: &Block| -> Pick {
        if all || (!blk.fixed && blk.moved_since_update > 0.5 * blk.update_threshold(&tol)) {
            Pick::Flagged
        } else if keep_grid && g.strayed(b, blk) {
            Pick::Strayed
        } else {
            Pick::Neither
        }
    };
    let (flagged_list, strayed): (Vec<u32>, Vec<u32>) = match attention.as_deref() {
        Some(att) => {
            let (mut f, mut s) = (Vec::new(), Vec::new());
            for &b in &att.blocks {
                match pick(grid, b as usize, &model.blocks[b as usize]) {
                    Pick::Flagged => f.push(b),
                    Pick::Strayed => s.push(b),
                    Pick::Neither => {}
                }
            }
            (f, s)
        }
        None => {
            let g = &*grid;
            model
                .blocks
                .par_iter()
                .enumerate()
                .with_min_len(PARALLEL_BLOCKS)
                .fold(
                    || (Vec::new(), Vec::new()),
                    |(mut f, mut s), (b, blk)| {
                        match pick(g, b, blk) {
                            Pick::Flagged => f.push(b as u32),
                            Pick::Strayed => s.push(b as u32),
                            Pick::Neither => {}
                        }
                        (f, s)
                    },
                )
                .reduce(
                    || (Vec::new(), Vec::new()),
                    |(mut f, mut s), (f2, s2)| {
                        f.extend(f2);
                        s.extend(s2);
                        (f, s)
                    },
                )
        }
    };

    // The examined blocks' speed margins for the interval to their next update, from their
    // velocity now: the search below reaches that much farther around them.
    let dt = model.timestep;
    let new_margin = |b: &Block| if b.fixed { 0.0 } else { tol.speed_margin(b.travel_per_step(dt)) };
    if let Some(att) = attention.as_deref_mut() {
        // What the search below reads, brought in before the margins change (a fetch of
        // everything would overwrite them): the flagged blocks' neighbourhoods in the kept grid,
        // or everything when the update sweeps or rebuilds the grid.
        if n >= 2 && !flagged_list.is_empty() {
            let sweeps = !keep_grid || flagged_list.len() > n / SWEEP_FRACTION || strayed.len() > n / REBUILD_FRACTION;
            let needed = if sweeps {
                None
            } else {
                let pad = 0.5 * tol.atol;
                let boxes: Vec<[f64; 4]> = flagged_list
                    .iter()
                    .map(|&f| bounding_box(corners_of(&model.blocks, &model.corners, f as usize), pad + new_margin(&model.blocks[f as usize])))
                    .collect();
                grid.neighbourhood(n, &flagged_list, &strayed, &boxes)
            };
            (att.fetch)(model, needed.as_deref())?;
        }
    }
    let margin = |b: &mut Block| b.update_margin = new_margin(b);
    if all {
        model.blocks.par_iter_mut().with_min_len(PARALLEL_BLOCKS).for_each(margin);
    } else {
        flagged_list.iter().for_each(|&b| margin(&mut model.blocks[b as usize]));
    }

    // Candidate pairs, both ways round, sorted: a sweep over a new grid when many blocks are
    // flagged, else a query of the flagged ones, rebuilding the grid first when too many blocks
    // have strayed from it.
    let pairs = if n < 2 || flagged_list.is_empty() {
        Vec::new()
    } else if !keep_grid || flagged_list.len() > n / SWEEP_FRACTION {
        let current = grid.build(model);
        let mut flagged = vec![all; n];
        if !all {
            flagged_list.iter().for_each(|&b| flagged[b as usize] = true);
        }
        grid.sweep(&current, &flagged)
    } else if strayed.len() > n / REBUILD_FRACTION {
        grid.build(model);
        grid.query(model, &flagged_list, &[])
    } else {
        grid.query(model, &flagged_list, &strayed)
    };

    let owner_ends: Vec<usize> = {
        let mut ends = Vec::new();
        let mut i = 0;
        while i < pairs.len() {
            let p = pairs[i] >> 32;
            i += pairs[i..].partition_point(|&x| x >> 32 == p);
            ends.push(i);
        }
        ends
    };
    let many = owner_ends.len() > n / 64;
    // One pass over the list: whether it is sorted by (block 1, corner, block 2), so that each
    // block's contacts are one run; the contacts of pairs not examined below, decided by their
    // current gap (kept up to date every cycle by the contact stage); and, when many blocks are
    // examined, where each block's run starts.
    let exact_drop = |c: &Contact, blocks: &[Block]| c.gap > btol + blocks[c.block1 as usize].update_margin + blocks[c.block2 as usize].update_margin;
    let check_gaps = attention.is_none();
    let scan = |contacts: &[Contact], blocks: &[Block]| {
        contacts
            .par_iter()
            .enumerate()
            .with_min_len(PARALLEL_CONTACTS)
            .fold(
                || (true, Vec::new(), Vec::new()),
                |(mut in_order, mut drops, mut starts), (k, c)| {
                    let prev = k.checked_sub(1).map(|j| &contacts[j]);
                    in_order &= prev.is_none_or(|p| contact_key(p) <= contact_key(c));
                    if check_gaps && exact_drop(c, blocks) {
                        drops.push(k as u32);
                    }
                    if many && prev.is_none_or(|p| p.block1 != c.block1) {
                        starts.push((c.block1, k as u32));
                    }
                    (in_order, drops, starts)
                },
            )
            .reduce(
                || (true, Vec::new(), Vec::new()),
                |(o1, mut d1, mut s1), (o2, d2, s2)| {
                    d1.extend(d2);
                    s1.extend(s2);
                    (o1 && o2, d1, s1)
                },
            )
    };
    let Model { blocks, contacts, .. } = &mut *model;
    // An attention vouches for the order (its contact indices need it) and lists the contacts to
    // drop by their gap: the pass is then needed only for the runs' starts (a pass over every
    // contact is most of a small update's cost on a large model).
    let (sorted, mut gap_dropped, mut run_starts) = if attention.is_some() && !many {
        debug_assert!(contacts.is_sorted_by_key(contact_key), "an attention's contact list must be in the update's order");
        (true, Vec::new(), Vec::new())
    } else {
        scan(contacts, blocks)
    };
    if !sorted {
        // A list edited elsewhere: sorted first, stably, which leaves the result as it would be
        // from the list as given.
        contacts.par_sort_by_key(contact_key);
        (_, gap_dropped, run_starts) = scan(contacts, blocks);
    }
    if let Some(att) = attention.as_deref() {
        // The attention's contacts are indices into the list as it came (in order, checked by
        // the caller: `Attention` needs it).
        debug_assert!(sorted, "an attention's contact list must be in the update's order");
        gap_dropped = att.contacts.iter().copied().filter(|&k| exact_drop(&contacts[k as usize], blocks)).collect();
    }

    // Narrow phase, one task per block with candidates, on that block's own run of contacts.
    let owner_of = |e: usize| (pairs[e - 1] >> 32) as u32;
    let m = contacts.len();
    let runs: Vec<(usize, usize)> = owner_ends
        .par_iter()
        .map(|&e| {
            let a = owner_of(e);
            if many {
                let j = run_starts.partition_point(|s| s.0 < a);
                match run_starts.get(j) {
                    Some(&(b, lo)) if b == a => (lo as usize, run_starts.get(j + 1).map_or(m, |s| s.1 as usize)),
                    Some(&(_, lo)) => (lo as usize, lo as usize),
                    None => (m, m),
                }
            } else {
                let lo = contacts.partition_point(|c| c.block1 < a);
                (lo, lo + contacts[lo..].partition_point(|c| c.block1 == a))
            }
        })
        .collect();
    let examined: Vec<Examined> = {
        let Model { blocks, corners, contacts, materials, tol, .. } = &mut *model;
        let mut slices = Vec::with_capacity(runs.len());
        let mut rest: &mut [Contact] = contacts;
        let mut at = 0;
        for &(lo, hi) in &runs {
            let (_, tail) = std::mem::take(&mut rest).split_at_mut(lo - at);
            let (mine, tail) = tail.split_at_mut(hi - lo);
            slices.push(mine);
            rest = tail;
            at = hi;
        }
        let (blocks, corners, materials, tol) = (&*blocks, &*corners, &*materials, &*tol);
        let starts: Vec<usize> = std::iter::once(0).chain(owner_ends.iter().copied()).collect();
        slices
            .into_par_iter()
            .zip(runs.par_iter())
            .enumerate()
            .map(|(o, (run, &(lo, _)))| {
                let cands = &pairs[starts[o]..starts[o + 1]];
                examine(owner_of(starts[o + 1]) as usize, cands, run, lo, blocks, corners, materials, tol)
            })
            .collect()
    };
    drop(pairs);

    // Dropped: by stored gap or by the gap just found (ascending, each once).
    let mut dropped: Vec<u32> = gap_dropped;
    let found: Vec<u32> = examined.iter().flat_map(|e| e.dropped.iter().copied()).collect();
    if !found.is_empty() {
        dropped.extend(found);
        dropped.par_sort_unstable();
        dropped.dedup();
    }
    // New contacts: where each goes (before the contact it names) and its id, in the order a
    // serial sweep over the sorted pairs (i < j) creates them: pair by pair, block i's corners
    // against j first, then j's against i, corners ascending.
    let law_released: f64 = examined.iter().map(|e| e.released).sum();
    let parts: Vec<Vec<NewContact>> = examined.into_iter().map(|e| e.created).collect();
    let part_start: Vec<usize> = parts
        .iter()
        .scan(0, |s, p| {
            let at = *s;
            *s += p.len();
            Some(at)
        })
        .collect();
    let n_created: usize = parts.iter().map(Vec::len).sum();
    let mut ids: Vec<u32> = Vec::new();
    if n_created > 0 {
        let order_key = |c: &NewContact| {
            let (lo, hi) = (c.block1.min(c.block2), c.block1.max(c.block2));
            ((lo as u128) << 96) | ((hi as u128) << 64) | (((c.block1 > c.block2) as u128) << 32) | c.corner as u128
        };
        let mut order: Vec<(u128, u32)> =
            parts.par_iter().zip(&part_start).flat_map_iter(|(p, &s)| p.iter().enumerate().map(move |(i, c)| (order_key(c), (s + i) as u32))).collect();
        order.par_sort_unstable();
        ids.resize(n_created, 0);
        for (rank, &(_, i)) in order.iter().enumerate() {
            ids[i as usize] = model.next_contact_id + rank as u32;
        }
        model.next_contact_id += n_created as u32;
    }
    let insert_before: Vec<u32> = parts.iter().flat_map(|p| p.iter().map(|c| c.before)).collect();
    let new_contacts = parts.iter().flatten().zip(&ids).map(|(c, &id)| c.contact(id));

    let mut changes = ContactChanges { created: n_created, dropped: dropped.len(), reordered: !sorted, edit: None };
    if adjacency.is_some() && !dropped.is_empty() {
        retire(model, &dropped);
    }
    if adjacency.is_some() {
        model.retired.released += law_released;
    }
    let removed: Vec<(u32, u32, u32)> = if adjacency.is_some() {
        dropped.iter().map(|&k| (k, model.contacts[k as usize].block1, model.contacts[k as usize].block2)).collect()
    } else {
        Vec::new()
    };
    let old_len = model.contacts.len() as u32;
    let inserted_at = if dropped.len() == model.contacts.len() {
        // Nothing kept (the first detection of a model): the list is the new contacts.
        fill_contacts(&mut model.contacts, &parts, &part_start, &ids);
        (0..n_created as u32).collect()
    } else {
        splice(&mut model.contacts, &dropped, &insert_before, new_contacts)
    };
    // The new contacts' law (¶5): joints where their faces are in opposition.
    {
        let Model { blocks, corners, contacts, materials, .. } = &mut *model;
        let decide = |k: &u32| (*k, joint_length_of(&contacts[*k as usize], blocks, corners, materials));
        let lengths: Vec<(u32, f64)> = if inserted_at.len() >= PARALLEL_CONTACTS {
            inserted_at.par_iter().map(decide).filter(|&(_, l)| l > 0.0).collect()
        } else {
            inserted_at.iter().map(decide).filter(|&(_, l)| l > 0.0).collect()
        };
        for (k, l) in lengths {
            contacts[k as usize].joint_length = l;
        }
    }
    if let Some(adjacency) = adjacency {
        let entries = if all || !sorted || !adjacency.fits(n, model.contacts.len() + dropped.len() - n_created) {
            adjacency.rebuild(n, &model.contacts);
            None
        } else if !dropped.is_empty() || n_created > 0 {
            Some(adjacency.apply(n, &model.contacts, &removed, &insert_before, &inserted_at))
        } else {
            Some(EntriesEdit::unchanged(adjacency.entries.len()))
        };
        // What changed in the list, for a backend that keeps a copy of it (the GPU's).
        changes.edit = sorted.then_some(ListEdit { old_len, dropped, insert_before, inserted_at, entries });
    }

    let reset = |b: &mut Block| {
        b.moved_since_update = 0.0;
        b.update_centroid = b.centroid;
        b.update_rotation = b.rotation;
    };
    if all {
        model.blocks.par_iter_mut().with_min_len(PARALLEL_BLOCKS).for_each(reset);
    } else {
        for &b in &flagged_list {
            reset(&mut model.blocks[b as usize]);
        }
    }
    // A simply-deformable block's strain is measured from here too (`Sdef::update_strain`).
    if !model.sdef.is_empty() {
        let Model { blocks, sdef, .. } = &mut *model;
        let flagged: Box<dyn Iterator<Item = usize>> = if all { Box::new(0..blocks.len()) } else { Box::new(flagged_list.iter().map(|&b| b as usize)) };
        for b in flagged {
            sdef[b].update_strain = sdef[b].strain;
        }
    }
    // A fully-deformable block's boundary is measured from here too (`GridPoint::update_position`).
    if !model.fdef.is_empty() {
        let flagged: Box<dyn Iterator<Item = usize>> = if all { Box::new(0..model.blocks.len()) } else { Box::new(flagged_list.iter().map(|&b| b as usize)) };
        for b in flagged {
            for g in &mut model.fdef[b].gridpoints {
                g.update_position = g.position;
            }
        }
    }
    Ok((changes, flagged_list))
}

/// What one contact update did to the list, as indices: a backend holding a copy of the list
/// (the GPU backend's device buffers) makes the same edit to its copy from this, in proportion
/// to the changes. Given only when the list was in the update's order on entry (an update that
/// had to sort it first changed every index).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ListEdit {
    /// The list's length before the update.
    pub old_len: u32,
    /// Indices in the old list of the contacts dropped (ascending).
    pub dropped: Vec<u32>,
    /// For each new contact, the old contact it was inserted before (ascending; `old_len`: at
    /// the end).
    pub insert_before: Vec<u32>,
    /// The new contacts' indices in the new list (ascending).
    pub inserted_at: Vec<u32>,
    /// The same update's edit of the adjacency lists, when they were edited rather than rebuilt.
    pub entries: Option<EntriesEdit>,
}

impl ListEdit {
    /// The list's length after the update.
    pub fn new_len(&self) -> u32 {
        self.old_len + self.inserted_at.len() as u32 - self.dropped.len() as u32
    }

    /// Nothing dropped and nothing created: the list is as it was.
    pub fn is_empty(&self) -> bool {
        self.dropped.is_empty() && self.inserted_at.is_empty()
    }

    /// The new index of the kept contact at old index `k`: k, plus the insertions before it, less
    /// the removals before it.
    pub fn new_index(&self, k: u32) -> u32 {
        k + self.insert_before.partition_point(|&p| p <= k) as u32 - self.dropped.partition_point(|&d| d < k) as u32
    }

    /// The new list as runs: (first new index, source), ascending, where the source is the old
    /// index of the run's first contact, or, with `new_bit` set, the index among the inserted
    /// contacts of its first; contacts within a run follow one another in their source. Ends with
    /// (new length, 0), so that run r covers `runs[r].0 .. runs[r + 1].0`.
    pub fn runs(&self, new_bit: u32) -> Vec<[u32; 2]> {
        let mut runs: Vec<[u32; 2]> = Vec::with_capacity(2 * (self.dropped.len() + self.inserted_at.len()) + 2);
        let (mut d, mut j, mut new) = (0usize, 0usize, 0u32);
        let mut old = 0u32;
        loop {
            // Kept contacts up to the next change.
            let next_drop = self.dropped.get(d).copied().unwrap_or(self.old_len);
            let next_insert = self.insert_before.get(j).copied().unwrap_or(self.old_len);
            let at = next_drop.min(next_insert);
            if at > old {
                runs.push([new, old]);
                new += at - old;
            }
            old = at;
            // The insertions before the contact at `at`, then its removal.
            if j < self.insert_before.len() && self.insert_before[j] == at {
                runs.push([new, new_bit | j as u32]);
                while j < self.insert_before.len() && self.insert_before[j] == at {
                    j += 1;
                    new += 1;
                }
            }
            if d < self.dropped.len() && self.dropped[d] == at {
                d += 1;
                old = at + 1;
            }
            if old >= self.old_len && j == self.insert_before.len() {
                break;
            }
        }
        runs.push([new, 0]);
        runs
    }
}

/// Makes `contacts` the new contacts of `parts` (each part's starting at `part_start`), with
/// their `ids`, in parallel: a first detection writes the whole list (a gigabyte at 10⁶ blocks),
/// which grown from an iterator would be written and copied on one thread.
fn fill_contacts(contacts: &mut Vec<Contact>, parts: &[Vec<NewContact>], part_start: &[usize], ids: &[u32]) {
    let n = ids.len();
    contacts.clear();
    contacts.reserve_exact(n);
    let spare = &mut contacts.spare_capacity_mut()[..n];
    let pieces = split_at_ends(spare, part_start.iter().skip(1).copied().chain([n]));
    pieces.into_par_iter().zip(parts).zip(part_start).for_each(|((out, part), &s)| {
        for ((slot, c), &id) in out.iter_mut().zip(part).zip(&ids[s..]) {
            slot.write(c.contact(id));
        }
    });
    // SAFETY: the pieces cover the first n slots (part_start ascends from 0 and the parts hold
    // n contacts in all), and every slot of each piece was written just above.
    unsafe { contacts.set_len(n) };
}

/// Removes the contacts at `dropped` (ascending) and inserts `new_contacts`, each before the
/// contact `insert_before` names (ascending), in place. Returns the new indices of the inserted
/// contacts, ascending. (Any list kept index for index with the contacts takes the same edit.)
///
/// Each stretch of kept contacts between two changes moves once, by the insertions less the
/// removals before it: those moving left first, front to back, then those moving right, back to
/// front. Every move lands on the stretch's final place, which no stretch still to move occupies
/// (final places keep the order), and a stretch whose changes cancel stays put.
pub fn splice<T: Copy + Send + Sync>(contacts: &mut Vec<T>, dropped: &[u32], insert_before: &[u32], new_contacts: impl Iterator<Item = T>) -> Vec<u32> {
    let old_len = contacts.len();
    let new_len = (old_len + insert_before.len()) - dropped.len();
    if dropped.len() == old_len {
        // Nothing kept (the first detection of a model): the list is the new contacts.
        contacts.clear();
        contacts.reserve_exact(new_len);
        contacts.extend(new_contacts);
        return (0..new_len as u32).collect();
    }
    if dropped.is_empty() && insert_before.is_empty() {
        return Vec::new();
    }
    let (stretches, inserted_at) = splice_plan(old_len, dropped, insert_before);
    if new_len > old_len {
        let filler = contacts[0];
        contacts.resize(new_len, filler);
    }
    for &(s, e, d) in stretches.iter().filter(|t| t.2 < 0) {
        move_stretch(contacts, s, e, d);
    }
    for &(s, e, d) in stretches.iter().rev().filter(|t| t.2 > 0) {
        move_stretch(contacts, s, e, d);
    }
    for (&at, c) in inserted_at.iter().zip(new_contacts) {
        contacts[at as usize] = c;
    }
    contacts.truncate(new_len);
    inserted_at
}

/// A splice's kept stretches (start, end, shift: where each stretch of kept contacts moves) and
/// the final index of each insertion, for a list of `old_len` contacts.
fn splice_plan(old_len: usize, dropped: &[u32], insert_before: &[u32]) -> (Vec<(usize, usize, isize)>, Vec<u32>) {
    let mut stretches: Vec<(usize, usize, isize)> = Vec::with_capacity(dropped.len() + insert_before.len() + 1);
    let mut inserted_at: Vec<u32> = Vec::with_capacity(insert_before.len());
    let (mut i, mut j, mut start, mut shift) = (0, 0, 0usize, 0isize);
    loop {
        let next_drop = dropped.get(i).map_or(old_len, |&k| k as usize);
        let next_insert = insert_before.get(j).map_or(old_len, |&k| k as usize);
        let at = next_drop.min(next_insert);
        if at > start {
            stretches.push((start, at, shift));
        }
        if at == old_len && j == insert_before.len() {
            break;
        }
        // Insertions before the contact at `at`, then that contact's removal.
        while j < insert_before.len() && insert_before[j] as usize == at {
            inserted_at.push((at as isize + shift) as u32);
            shift += 1;
            j += 1;
        }
        start = at;
        if i < dropped.len() && dropped[i] as usize == at {
            shift -= 1;
            i += 1;
            start = at + 1;
        }
    }
    (stretches, inserted_at)
}

/// `splice` into a new list, `contacts` left as it is: for a list another owner still shares (a
/// checkpoint's ledger bases), one pass over it where a copy and then a splice would take two.
pub fn spliced<T: Copy>(contacts: &[T], dropped: &[u32], insert_before: &[u32], new_contacts: impl Iterator<Item = T>) -> Vec<T> {
    let new_len = (contacts.len() + insert_before.len()) - dropped.len();
    let (stretches, inserted_at) = splice_plan(contacts.len(), dropped, insert_before);
    let mut out = Vec::with_capacity(new_len);
    // The final places are the stretches' and the insertions', in order and without gaps.
    let mut created = inserted_at.iter().zip(new_contacts).peekable();
    for &(s, e, shift) in &stretches {
        let to = (s as isize + shift) as usize;
        while let Some((_, c)) = created.next_if(|(&at, _)| (at as usize) < to) {
            out.push(c);
        }
        out.extend_from_slice(&contacts[s..e]);
    }
    out.extend(created.map(|(_, c)| c));
    debug_assert_eq!(out.len(), new_len);
    out
}

/// `v.copy_within(s..e, s + shift)`, in parallel for a long stretch and a short shift (a splice
/// moves most of the list by a few places): the stretch is cut into pieces at least as long as
/// the shift, each moved within its destination window, which no other piece reads or writes;
/// the few elements each piece takes from a neighbouring window are put aside first.
fn move_stretch<T: Copy + Send + Sync>(v: &mut [T], s: usize, e: usize, shift: isize) {
    const PIECE: usize = 16384;
    let d = shift.unsigned_abs();
    if e - s < 4 * PIECE || d > PIECE {
        v.copy_within(s..e, (s as isize + shift) as usize);
        return;
    }
    let pieces = (e - s) / PIECE;
    let bounds: Vec<usize> = (0..pieces).map(|i| s + i * PIECE).chain([e]).collect();
    if shift < 0 {
        // Window i = [a_i − d, a_{i+1} − d): its own [a_i, a_{i+1} − d) slides to the front, and
        // [a_{i+1} − d, a_{i+1}), the start of the next window, lands at its end.
        let aside: Vec<Vec<T>> = bounds[1..].iter().map(|&a| v[a - d..a].to_vec()).collect();
        let windows = split_at_ends(&mut v[s - d..e - d], bounds[1..].iter().map(|&a| a - s));
        windows.into_par_iter().zip(aside).for_each(|(w, next)| {
            let len = w.len();
            w.copy_within(d..len, 0);
            w[len - d..].copy_from_slice(&next);
        });
    } else {
        // Window i = [a_i + d, a_{i+1} + d): its own [a_i + d, a_{i+1}) slides to the back, and
        // [a_i, a_i + d), the end of the previous window, lands at its start.
        let aside: Vec<Vec<T>> = bounds[..pieces].iter().map(|&a| v[a..a + d].to_vec()).collect();
        let windows = split_at_ends(&mut v[s + d..e + d], bounds[1..].iter().map(|&a| a - s));
        windows.into_par_iter().zip(aside).for_each(|(w, previous)| {
            let len = w.len();
            w.copy_within(0..len - d, d);
            w[..d].copy_from_slice(&previous);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall after a full detection, its adjacency kept as a backend keeps it.
    fn wall(bricks: usize) -> (Model, Topology) {
        let deck = format!("{}CYCLE 0\n", crate::bench::scene::scaling_wall(bricks, 0.1).deck());
        let mut model = crate::scenes::run_deck_on(&deck, Box::new(crate::udec::cpu::CpuBackend::new())).expect("the wall builds");
        let mut topology = Topology::default();
        update_topology(&mut model, true, &mut topology);
        (model, topology)
    }

    /// Moves block b rigidly (its corners follow, as after a cycle).
    fn shift(model: &mut Model, b: usize, by: [f64; 2], turn: f64) {
        let blk = &mut model.blocks[b];
        blk.centroid = [blk.centroid[0] + by[0], blk.centroid[1] + by[1]];
        blk.rotation += turn;
        let blk = blk.clone();
        let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
        crate::udec::model::corners::place_corners(&blk, &mut model.corners[range]);
    }

    #[test]
    fn kept_grid_and_lists_match_a_fresh_detection() {
        // Updates through the kept grid (flagged blocks queried, strayed ones boxed afresh) and
        // the renumbered adjacency lists against a detection from scratch and a rebuilt list.
        let (mut model, mut topology) = wall(1000);
        let etol = model.tol.etol;
        for round in 0..6usize {
            for k in 0..40 {
                let b = 1 + (round * 97 + k * 13) % (model.blocks.len() - 1);
                if model.blocks[b].fixed {
                    continue;
                }
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                shift(&mut model, b, [sign * 0.07 * (round + 1) as f64, 0.01 * round as f64], 0.002 * sign);
                // Most are flagged; some move without the flag (they stray from the grid).
                model.blocks[b].moved_since_update = if k % 5 == 0 { 0.5 * etol } else { 2.0 * etol };
            }
            let mut fresh = model.clone();
            let expected = update_contacts(&mut fresh, false);
            let got = update_topology(&mut model, false, &mut topology);
            assert_eq!(got, expected, "round {round}");
            assert!(model.contacts == fresh.contacts && model.blocks == fresh.blocks, "round {round}: contacts differ");
            assert!(topology.lists == Adjacency::build(model.blocks.len(), &model.contacts), "round {round}: adjacency");
        }
    }

    #[test]
    fn an_update_from_what_it_reads_matches_the_whole_state() {
        // A backend that keeps the state elsewhere (the GPU) gives the update lists of what it may
        // touch and a fetch for the rest (`update_topology_with`); the model it holds is stale
        // elsewhere. Here `stale` is current only where the lists and the fetches made it so,
        // and the update must find what the whole current state (`truth`) gives: the same
        // contacts created, dropped and re-featured, the same blocks re-examined. Each round also
        // moves the flagged blocks' right-hand neighbours by 3 cm, unflagged and within the grid's
        // margin, so a fetch that missed a neighbourhood would measure gaps from stale corners.
        let (mut truth, mut topology) = wall(1000);
        let mut stale = truth.clone();
        let mut stale_topology = topology.clone();
        let etol = truth.tol.etol;
        let mut changed = 0;
        for round in 0..6usize {
            for k in 0..30 {
                let b = 1 + (round * 97 + k * 13) % (truth.blocks.len() - 2);
                if truth.blocks[b].fixed || truth.blocks[b + 1].fixed {
                    continue;
                }
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                shift(&mut truth, b, [sign * 0.07 * (round + 1) as f64, 0.01 * round as f64], 0.002 * sign);
                truth.blocks[b].moved_since_update = if k % 5 == 0 { 0.5 * etol } else { 2.0 * etol };
                shift(&mut truth, b + 1, [-0.03 * sign, 0.0], 0.0);
                truth.blocks[b + 1].moved_since_update = truth.blocks[b + 1].moved_since_update.max(0.3 * etol);
            }
            // The lists, loosened as the device's are: blocks near their update or strayed,
            // contacts opened near btol or of such a block.
            let grid = &stale_topology.grid;
            let near = |m: &Model, b: usize| !m.blocks[b].fixed && m.blocks[b].moved_since_update > 0.45 * m.blocks[b].update_threshold(&m.tol);
            let blocks: Vec<u32> = (0..truth.blocks.len()).filter(|&b| near(&truth, b) || grid.strayed(b, &truth.blocks[b])).map(|b| b as u32).collect();
            let contacts: Vec<u32> = (0..truth.contacts.len())
                .filter(|&k| {
                    let c = &truth.contacts[k];
                    let limit = truth.tol.btol + truth.blocks[c.block1 as usize].update_margin + truth.blocks[c.block2 as usize].update_margin;
                    c.gap > 0.99 * limit || near(&truth, c.block1 as usize) || near(&truth, c.block2 as usize)
                })
                .map(|k| k as u32)
                .collect();
            // What a backend reads back: the listed blocks (records, corners) and contacts.
            let bring_block = |to: &mut Model, from: &Model, b: usize| {
                to.blocks[b] = from.blocks[b].clone();
                let blk = &from.blocks[b];
                let r = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
                to.corners[r.clone()].clone_from_slice(&from.corners[r]);
            };
            for &b in &blocks {
                bring_block(&mut stale, &truth, b as usize);
            }
            for &k in &contacts {
                stale.contacts[k as usize] = truth.contacts[k as usize];
            }
            let before = truth.clone();
            let mut fetched = 0;
            let mut fetch = |m: &mut Model, needed: Option<&[u32]>| -> Result<(), String> {
                match needed {
                    None => *m = before.clone(),
                    Some(list) => {
                        fetched += list.len();
                        for &b in list {
                            bring_block(m, &before, b as usize);
                            for (k, c) in before.contacts.iter().enumerate().filter(|(_, c)| c.block1 == b) {
                                m.contacts[k] = *c;
                            }
                        }
                    }
                }
                Ok(())
            };
            let mut attention = Attention { blocks, contacts, fetch: &mut fetch };
            let (created, dropped, flagged) = update_topology_with(&mut stale, &mut stale_topology, &mut attention).expect("fetched");
            let expected = update_topology(&mut truth, false, &mut topology);
            assert_eq!((created, dropped), expected, "round {round}");
            assert!(!flagged.is_empty(), "round {round}: nothing re-examined");
            changed += created + dropped;
            assert!(fetched < truth.blocks.len() / 4, "round {round}: fetched {fetched} blocks");
            let key = |c: &Contact| (c.id, c.block1, c.corner, c.block2, c.feature, c.kind);
            assert!(stale.contacts.iter().map(key).eq(truth.contacts.iter().map(key)), "round {round}: contact lists differ");
            for &b in &flagged {
                assert_eq!(stale.blocks[b as usize], truth.blocks[b as usize], "round {round}: block {b}");
            }
            assert!(stale_topology.lists == topology.lists, "round {round}: adjacency");
        }
        assert!(changed > 50, "the moves created and dropped {changed} contacts");
    }

    #[test]
    fn move_stretch_is_copy_within() {
        // Short stretches (one copy) and long ones (pieces in parallel), either way, shifts up to
        // a whole piece.
        for (len, s, e, shift) in [
            (100, 5, 50, 3),
            (100, 5, 50, -5),
            (200_000, 10, 150_000, -7),
            (200_000, 1000, 190_000, 9),
            (200_000, 0, 199_990, 10),
            (200_000, 16384, 200_000, -16384),
            (200_000, 3, 170_000, 16384),
        ] {
            let mut a: Vec<u64> = (0..len as u64).collect();
            let mut b = a.clone();
            move_stretch(&mut a, s, e, shift);
            b.copy_within(s..e, (s as isize + shift) as usize);
            assert!(a == b, "len {len}, {s}..{e} by {shift}");
        }
    }

    fn contact(id: u32) -> Contact {
        Contact::unloaded(id, 0, 1)
    }

    #[test]
    fn splice_removes_and_inserts_in_place() {
        // A naive splice to compare with: kept contacts and insertions by position.
        let naive = |old: &[Contact], dropped: &[u32], insert_before: &[u32], new: &[Contact]| {
            let mut out = Vec::new();
            let mut j = 0;
            for (k, c) in old.iter().enumerate() {
                while j < insert_before.len() && insert_before[j] as usize == k {
                    out.push(new[j]);
                    j += 1;
                }
                if dropped.binary_search(&(k as u32)).is_err() {
                    out.push(*c);
                }
            }
            out.extend_from_slice(&new[j..]);
            out
        };
        let mut next = crate::udec::topology::xorshift(0x2545f4914f6cdd1d);
        for len in [0usize, 1, 7, 300, 100_000] {
            for _ in 0..6 {
                let old: Vec<Contact> = (0..len as u32).map(contact).collect();
                let mut dropped: Vec<u32> = (0..next(len as u64 / 10 + 2)).map(|_| next(len.max(1) as u64) as u32).filter(|&k| (k as usize) < len).collect();
                dropped.sort_unstable();
                dropped.dedup();
                let mut insert_before: Vec<u32> = (0..next(len as u64 / 10 + 3)).map(|_| next(len as u64 + 1) as u32).collect();
                insert_before.sort_unstable();
                let new: Vec<Contact> = (0..insert_before.len() as u32).map(|i| contact(1_000_000 + i)).collect();
                let expected = naive(&old, &dropped, &insert_before, &new);
                let mut got = old.clone();
                let at = splice(&mut got, &dropped, &insert_before, new.iter().copied());
                assert!(got == expected, "len {len}, dropped {dropped:?}, inserted before {insert_before:?}");
                // Into a new list, the old one left as it was.
                assert!(spliced(&old, &dropped, &insert_before, new.iter().copied()) == expected, "spliced: len {len}");
                let positions: Vec<u32> = expected.iter().enumerate().filter(|(_, c)| c.id >= 1_000_000).map(|(k, _)| k as u32).collect();
                assert_eq!(at, positions);
                // The same edit as runs and as a renumbering of the kept contacts.
                let edit = ListEdit { old_len: len as u32, dropped: dropped.clone(), insert_before: insert_before.clone(), inserted_at: at, entries: None };
                assert_eq!(edit.new_len() as usize, expected.len());
                const NEW: u32 = 1 << 31;
                let runs = edit.runs(NEW);
                assert_eq!(runs[0][0], 0);
                assert_eq!(*runs.last().unwrap(), [expected.len() as u32, 0]);
                let mut from_runs = Vec::new();
                for w in runs.windows(2) {
                    assert!(w[0][0] < w[1][0], "runs are not empty");
                    for i in 0..w[1][0] - w[0][0] {
                        let source = w[0][1];
                        from_runs.push(if source & NEW != 0 { new[(source & !NEW) as usize + i as usize] } else { old[(source + i) as usize] });
                    }
                }
                assert!(from_runs == expected, "runs of len {len}, dropped {dropped:?}, inserted before {insert_before:?}: {runs:?}");
                for k in (0..len as u32).filter(|k| dropped.binary_search(k).is_err()) {
                    assert_eq!(expected[edit.new_index(k) as usize].id, k);
                }
            }
        }
    }
}
