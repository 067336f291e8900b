//! Stage 7 for D3: the neighbour lists (SL-85-1 ¶26, ¶31–32). Every pair of blocks whose boxes,
//! widened by the neighbour margin, overlap is a contact: a degenerate one (a link between nearby
//! blocks) until they touch. The pairs come from a uniform grid of cells as large as nearly every
//! widened block, the few larger ones (a slab under a wall) tested against every block, so the
//! search costs a number of operations proportional to the number of blocks N, not N². The lists
//! are rebuilt only once some block has moved, since the last rebuild, by as much as the
//! contact-forming distance (`Block::travel`): a pair further apart
//! than the margin (four times that distance) cannot come within touching distance before then.
//! A contact kept across a rebuild keeps its id and its logical contacts (their shear forces).

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::model::{Contact, Model};

/// The neighbour margin: four times the contact-forming distance.
pub fn neighbour_margin(model: &Model) -> f64 {
    margin_of(model.contact_tolerance())
}

/// The neighbour margin of the contact-forming distance `tol` ([`neighbour_margin`]).
fn margin_of(tol: f64) -> f64 {
    4.0 * tol
}

/// Whether a block has moved far enough since the last rebuild to need one; `tol`: the model's
/// contact-forming distance (`Model::contact_tolerance`), as the caller has it.
pub fn rebuild_due(model: &Model, tol: f64) -> bool {
    model.neighbours_stale || model.blocks.iter().any(|b| b.travel >= tol)
}

/// Whether no block but block `k` has its box within `reach` of block `k`'s box.
pub fn alone(model: &Model, k: usize, reach: f64) -> bool {
    let (lo, hi) = model.blocks[k].bounds();
    let (lo, hi) = (lo - DVec3::splat(reach), hi + DVec3::splat(reach));
    model.blocks.iter().enumerate().all(|(j, b)| {
        if j == k {
            return true;
        }
        let (a, c) = b.bounds();
        !(a.cmple(hi).all() && lo.cmple(c).all())
    })
}

/// The pairs of blocks (indices, lower first, ascending) whose boxes widened by half `margin`
/// each overlap, by a uniform grid whose cells are as large as nearly every block: each such
/// block lies in at most two cells along each axis, and each cell holds a bounded number of
/// them. The few blocks larger than a cell (at most [`LARGE_SHARE`] of them, at least 16: the
/// slab a wall stands on, a projectile) are each tested against every block, a pass over N each,
/// not put in the grid: a cell as large as the largest block (a slab under the whole wall) would
/// hold every block, and the search would cost N².
pub fn neighbour_pairs(model: &Model, margin: f64) -> Vec<(u32, u32)> {
    let Some(grid) = Grid::new(model, margin) else { return Vec::new() };
    let overlap = |i: usize, j: usize| boxes_overlap(grid.boxes[i], grid.boxes[j]);
    let mut pairs = Vec::new();
    for members in grid.cells.values() {
        for (k, &i) in members.iter().enumerate() {
            for &j in &members[k + 1..] {
                let (i, j) = (i.min(j), i.max(j));
                if overlap(i as usize, j as usize) {
                    pairs.push((i, j));
                }
            }
        }
    }
    let n = grid.boxes.len();
    for &i in &grid.large {
        for j in (0..n).filter(|&j| j != i && overlap(i, j)) {
            pairs.push((i.min(j) as u32, i.max(j) as u32));
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// The pairs of [`neighbour_pairs`] of which at least one block is `moved` (a flag per block):
/// the grid is built over every block, and only the moved blocks' boxes are looked up in it, so
/// the search costs the grid's N inserts and a bounded number of tests per moved block (a large
/// moved block: N tests). With every block moved, the same pairs as [`neighbour_pairs`].
pub fn neighbour_pairs_of(model: &Model, margin: f64, moved: &[bool]) -> Vec<(u32, u32)> {
    let Some(grid) = Grid::new(model, margin) else { return Vec::new() };
    grid.pairs_of_moved(moved, |i| grid.boxes[i], |at, j| boxes_overlap(at, grid.boxes[j]))
}

/// The broad phase's grid kept from one partial detection to the next (the GPU's,
/// [`update_neighbours_kept`]): each block in the cells of its box as it was when last inserted,
/// widened by half the margin and by `slack`, the most it may travel before it is moved (and
/// re-inserted). A pair whose current boxes (widened by half the margin) overlap thus shares a
/// cell with the moved block's current box, and the candidates are tested on their current
/// boxes: the pairs [`neighbour_pairs_of`] finds, where only the moved blocks are re-inserted
/// (at 10⁵ bricks the grid of every block was 50–63 ms of each partial detection here, its hash
/// inserts serial).
pub struct KeptGrid {
    grid: Grid,
    margin: f64,
    slack: f64,
}

/// The pairs of [`neighbour_pairs_of`] from the grid `kept` (made where None or not of this
/// model, margin or slack), the moved blocks re-inserted first.
pub fn neighbour_pairs_kept(model: &Model, margin: f64, moved: &[bool], kept: &mut Option<KeptGrid>, slack: f64) -> Vec<(u32, u32)> {
    let fits = |k: &KeptGrid| k.grid.boxes.len() == model.blocks.len() && k.margin == margin && k.slack == slack;
    if !kept.as_ref().is_some_and(fits) {
        *kept = Grid::new(model, margin + 2.0 * slack).map(|grid| KeptGrid { grid, margin, slack });
    } else if let Some(k) = kept.as_mut() {
        for i in (0..moved.len()).filter(|&i| moved[i]) {
            k.grid.reinsert(i, widened(model.blocks[i].bounds(), margin + 2.0 * slack));
        }
    }
    let Some(k) = kept.as_ref() else { return Vec::new() };
    let grid = &k.grid;
    let now = |j: usize| widened(model.blocks[j].bounds(), margin);
    grid.pairs_of_moved(moved, now, |at, j| boxes_overlap(at, grid.boxes[j]) && boxes_overlap(at, now(j)))
}

/// The broad phase's uniform grid ([`neighbour_pairs`]): each block's widened box, the cell's
/// size, the blocks (not large) in each cell their boxes reach, and the large blocks left out.
struct Grid {
    boxes: Vec<(DVec3, DVec3)>,
    cell: f64,
    cells: FxHashMap<(i64, i64, i64), Vec<u32>>,
    large: Vec<usize>,
}

impl Grid {
    /// The grid of `model`'s blocks widened by half `margin`; None where there are fewer than two
    /// or the cell has no size.
    fn new(model: &Model, margin: f64) -> Option<Grid> {
        // (In parallel: at 10⁶ blocks a partial detection's search is mostly this grid.)
        let boxes: Vec<(DVec3, DVec3)> = model.blocks.par_iter().with_min_len(super::grain::BLOCK).map(|b| widened(b.bounds(), margin)).collect();
        let sizes: Vec<f64> = boxes.iter().map(|(lo, hi)| (*hi - *lo).max_element()).collect();
        let (cell, large) = grid_cell(&sizes)?;
        let mut grid = Grid { boxes, cell, cells: FxHashMap::default(), large };
        for i in 0..grid.boxes.len() {
            if grid.large.binary_search(&i).is_ok() {
                continue;
            }
            for cell in grid.cells_of(grid.boxes[i]) {
                grid.cells.entry(cell).or_default().push(i as u32);
            }
        }
        Some(grid)
    }

    /// The pairs (ascending) of each `moved` block i whose box `at(i)`, looked up in the cells
    /// (a large block's against every block), `overlaps(at(i), j)` block j's.
    fn pairs_of_moved(&self, moved: &[bool], at: impl Fn(usize) -> (DVec3, DVec3), overlaps: impl Fn((DVec3, DVec3), usize) -> bool) -> Vec<(u32, u32)> {
        let n = self.boxes.len();
        let mut pairs = Vec::new();
        for i in (0..n).filter(|&i| moved[i]) {
            let at = at(i);
            let mut near = |j: usize| {
                if j != i && overlaps(at, j) {
                    pairs.push((i.min(j) as u32, i.max(j) as u32));
                }
            };
            if self.large.binary_search(&i).is_ok() {
                (0..n).for_each(&mut near);
                continue;
            }
            for cell in self.cells_of(at) {
                if let Some(members) = self.cells.get(&cell) {
                    members.iter().for_each(|&j| near(j as usize));
                }
            }
            self.large.iter().for_each(|&j| near(j));
        }
        pairs.sort_unstable();
        pairs.dedup();
        pairs
    }

    /// Block `i` moved to the cells of its widened box `at` (a large block's box alone).
    fn reinsert(&mut self, i: usize, at: (DVec3, DVec3)) {
        if self.large.binary_search(&i).is_err() {
            for cell in self.cells_of(self.boxes[i]).collect::<Vec<_>>() {
                if let Some(members) = self.cells.get_mut(&cell) {
                    members.retain(|&j| j as usize != i);
                }
            }
            for cell in self.cells_of(at).collect::<Vec<_>>() {
                self.cells.entry(cell).or_default().push(i as u32);
            }
        }
        self.boxes[i] = at;
    }

    /// The cells a box reaches.
    fn cells_of(&self, (lo, hi): (DVec3, DVec3)) -> impl Iterator<Item = (i64, i64, i64)> {
        let cell_of = |p: DVec3| (p / self.cell).floor().as_i64vec3();
        let (a, b) = (cell_of(lo), cell_of(hi));
        (a.x..=b.x).flat_map(move |x| (a.y..=b.y).flat_map(move |y| (a.z..=b.z).map(move |z| (x, y, z))))
    }
}

/// The grid's cell for widened boxes of these `sizes` (their largest extents), and the large
/// blocks, left out of the grid ([`neighbour_pairs`]): the cell is the size of the largest block
/// but [`LARGE_SHARE`]'s share (at least 16), and the large blocks are those larger (or without a
/// size: a box of NaNs overlaps nothing). None where the cell has no size.
pub fn grid_cell(sizes: &[f64]) -> Option<(f64, Vec<usize>)> {
    let n = sizes.len();
    if n < 2 {
        return None;
    }
    // The size of rank n − 1 − few, found in linear time (a full sort was N log N).
    let few = (n / LARGE_SHARE).max(16).min(n - 1);
    let mut ranked = sizes.to_vec();
    let (_, &mut cell, _) = ranked.select_nth_unstable_by(n - 1 - few, f64::total_cmp);
    if !(cell > 0.0 && cell.is_finite()) {
        return None;
    }
    let within = |size: f64| size <= cell;
    Some((cell, (0..n).filter(|&i| !within(sizes[i])).collect()))
}

/// The broad phase leaves out of its grid at most one block in this many (and at least 16), the
/// largest ([`neighbour_pairs`]).
pub const LARGE_SHARE: usize = 1000;

/// A box `(lo, hi)` widened by half the neighbour margin on every side (two boxes so widened
/// overlap where their bodies are within the margin along each axis).
fn widened((lo, hi): (DVec3, DVec3), margin: f64) -> (DVec3, DVec3) {
    (lo - DVec3::splat(0.5 * margin), hi + DVec3::splat(0.5 * margin))
}

/// Whether two axis-aligned boxes overlap (touching counts).
fn boxes_overlap(a: (DVec3, DVec3), b: (DVec3, DVec3)) -> bool {
    a.0.cmple(b.1).all() && b.0.cmple(a.1).all()
}

/// Rebuilds the neighbour lists: the contacts of pairs still neighbours are kept (id, normal,
/// logical contacts), new pairs come in as degenerate contacts, pairs no longer neighbours go.
/// A concave block is seen as its convex parts (`Block::parts`): a pair of neighbour blocks of
/// which one or both are concave has a contact for each pair of their parts whose boxes, widened
/// as the blocks' are, overlap (never one between two parts of one block: they move as one).
/// Every block's travel starts again from zero. Returns (created, dropped).
pub fn update_neighbours(model: &mut Model) -> (u64, u64) {
    let margin = neighbour_margin(model);
    let pairs = neighbour_pairs(model, margin);
    let mut old: FxHashMap<ContactKey, Contact> = std::mem::take(&mut model.contacts).into_iter().map(|c| (key(&c), c)).collect();
    let mut created = 0;
    model.contacts = contacts_of_pairs(model, &pairs, margin, &mut old, &mut created);
    for b in &mut model.blocks {
        b.travel = 0.0;
    }
    model.neighbours_stale = false;
    (created, old.len() as u64)
}

/// [`update_neighbours`] for the `moved` blocks only (a flag per block): the pairs of which at
/// least one block is moved are searched afresh ([`neighbour_pairs_of`]), kept, created or
/// dropped as there; the contacts between blocks neither of which is moved are kept as they
/// are; only the moved blocks' travel starts again from zero. The lists come out in the order
/// [`update_neighbours`] gives (by blocks, then parts).
///
/// Why a pair of unmoved blocks may keep its status: it was last judged when one of its blocks
/// last had its travel reset (its pairs were all searched then), and since then each has moved
/// by less than its travel, which stays below the contact-forming distance (the caller moves
/// every block whose travel has reached its limit): the two have closed on each other by less
/// than twice that, well within the neighbour margin's four times. The caller must not take this
/// path where the lists are stale (`Model::neighbours_stale`: blocks made, cut or deleted).
/// Returns (created, dropped).
pub fn update_neighbours_of(model: &mut Model, moved: &[bool]) -> (u64, u64) {
    let margin = neighbour_margin(model);
    let pairs = neighbour_pairs_of(model, margin, moved);
    let touched = contacts_touching(model, |k| moved[k]);
    let renewal = renew_contacts_of(model, moved, &touched, &pairs, margin);
    (renewal.created, renewal.dropped)
}

/// The contacts (indices, ascending) one of whose blocks (indices) is one `block` says yes to
/// (the contacts a partial detection or a crack renews, `cpu::contact_stage_of`).
pub fn contacts_touching(model: &Model, block: impl Fn(usize) -> bool) -> Vec<usize> {
    model.contacts.iter().enumerate().filter(|(_, c)| c.blocks.iter().any(|&k| block(k as usize))).map(|(k, _)| k).collect()
}

/// What a partial renewal of the neighbour lists did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Renewal {
    pub created: u64,
    pub dropped: u64,
}

impl Renewal {
    /// Whether the list kept its contacts' keys (none created, none dropped): each contact where
    /// it was, those of the moved blocks renewed in place.
    pub fn in_place(&self) -> bool {
        self.created == 0 && self.dropped == 0
    }
}

/// [`update_neighbours_of`] with the pairs from a grid kept from one partial detection to the
/// next ([`KeptGrid`]: the moved blocks re-inserted, where [`neighbour_pairs_of`] builds a grid
/// of every block), made where `kept` is None or not of this model; `slack` is the most any
/// block not moved may have travelled since its last refresh (the caller's refresh limit).
/// The same lists as [`update_neighbours_of`]'s.
/// `touched`: the contacts (indices, ascending) with a block among the `moved`, as the caller
/// knows them (the GPU's from the adjacency it uploaded), so that nothing here walks the list
/// where its keys stay ([`Renewal::in_place`]).
/// `tol`: the model's contact-forming distance (`Model::contact_tolerance`, a pass over every
/// block's shape), as the caller has it.
pub fn update_neighbours_kept(model: &mut Model, moved: &[bool], touched: &[usize], kept: &mut Option<KeptGrid>, (tol, slack): (f64, f64)) -> Renewal {
    let margin = margin_of(tol);
    let pairs = neighbour_pairs_kept(model, margin, moved, kept, slack);
    renew_contacts_of(model, moved, touched, &pairs, margin)
}

/// The contacts of the neighbour `pairs` of the `moved` blocks renewed (`update_neighbours_of`);
/// `touched`: the contacts (indices, ascending) with a block among the moved.
fn renew_contacts_of(model: &mut Model, moved: &[bool], touched: &[usize], pairs: &[(u32, u32)], margin: f64) -> Renewal {
    // The moved blocks' contacts taken out of their places.
    let mut list = std::mem::take(&mut model.contacts);
    let mut old: FxHashMap<ContactKey, Contact> = touched
        .iter()
        .map(|&k| {
            let c = std::mem::replace(&mut list[k], Contact::vacant());
            (key(&c), c)
        })
        .collect();
    let mut created = 0;
    let fresh = contacts_of_pairs(model, pairs, margin, &mut old, &mut created);
    let renewal = Renewal { created, dropped: old.len() as u64 };
    if renewal.in_place() {
        // The same keys: the fresh list (in key order) is the taken one's, place for place.
        for (&k, c) in touched.iter().zip(fresh) {
            list[k] = c;
        }
    } else {
        // Both lists in key order (keys are distinct): merged in one pass.
        let mut merged = Vec::with_capacity(list.len() - touched.len() + fresh.len());
        let mut fresh = fresh.into_iter().peekable();
        let mut taken = touched.iter().copied().peekable();
        for (k, c) in list.into_iter().enumerate() {
            if taken.next_if_eq(&k).is_some() {
                continue;
            }
            let at = key(&c);
            while let Some(f) = fresh.next_if(|f| key(f) < at) {
                merged.push(f);
            }
            merged.push(c);
        }
        merged.extend(fresh);
        list = merged;
    }
    model.contacts = list;
    for (b, _) in model.blocks.iter_mut().zip(moved).filter(|(_, &m)| m) {
        b.travel = 0.0;
    }
    renewal
}

/// A contact's key in the neighbour lists: its blocks, then its parts.
type ContactKey = (u32, u32, [u32; 2]);

fn key(c: &Contact) -> ContactKey {
    (c.blocks[0], c.blocks[1], c.parts)
}

/// The contacts of neighbour `pairs` (ascending), each pair's parts in touch range paired: the
/// contact of `old` of the same key taken out of it where there is one, else a new degenerate
/// contact (counted in `created`). Pairs of two fixed blocks have none. In key order.
fn contacts_of_pairs(model: &mut Model, pairs: &[(u32, u32)], margin: f64, old: &mut FxHashMap<ContactKey, Contact>, created: &mut u64) -> Vec<Contact> {
    let mut contacts = Vec::with_capacity(pairs.len());
    let mut part_pairs: Vec<[u32; 2]> = Vec::new();
    for &(a, b) in pairs {
        let (ba, bb) = (&model.blocks[a as usize], &model.blocks[b as usize]);
        // Two fixed blocks never act on each other.
        if ba.fixed && bb.fixed {
            continue;
        }
        part_pairs.clear();
        if ba.parts.is_empty() && bb.parts.is_empty() {
            part_pairs.push([0, 0]);
        } else {
            let boxes_b: Vec<_> = (0..bb.part_count() as u32).map(|k| widened(bb.body(k).bounds(), margin)).collect();
            for pa in 0..ba.part_count() as u32 {
                let box_a = widened(ba.body(pa).bounds(), margin);
                for (pb, box_b) in boxes_b.iter().enumerate() {
                    if boxes_overlap(box_a, *box_b) {
                        part_pairs.push([pa, pb as u32]);
                    }
                }
            }
        }
        for &parts in &part_pairs {
            match old.remove(&(a, b, parts)) {
                Some(c) => contacts.push(c),
                None => {
                    *created += 1;
                    contacts.push(Contact {
                        id: model.next_contact_id,
                        blocks: [a, b],
                        category: None,
                        normal: DVec3::Z,
                        area: 0.0,
                        logical: Vec::new(),
                        parts,
                    });
                    model.next_contact_id += 1;
                }
            }
        }
    }
    contacts
}
