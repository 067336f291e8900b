//! Contact detection and update.
//!
//! The report's rule (¶26): a block is re-examined only after it has moved more than a threshold
//! since its previous update, so almost-stationary regions cost nothing. Here a block is flagged
//! when its corners have moved more than `etol` (a quarter of the contact-forming distance `atol`)
//! since its last update; two unflagged blocks can have approached each other by less than
//! 2·etol < atol since their pair was last examined, so no touch can be missed.
//!
//! Broad phase: a uniform cell grid over bounding boxes inflated by atol/2 (very large blocks, such
//! as a base, go to a list tested against every flagged block). Narrow phase: each corner circle of
//! one block against the nearest feature of the other's rounded boundary, both ways round.
//! Contacts form when the gap falls below `atol` and break when it exceeds `btol` (hysteresis, so a
//! contact at the threshold does not flicker). A contact keeps its identity — and so its shear
//! history — as long as the same corner stays near the same block (feature ids, STYLE.md item 7).

use rustc_hash::FxHashMap as HashMap;

use crate::cpu::contact_forces::nearest_feature;
use crate::model::{Contact, Model};

/// Bounding boxes above this many grid cells are treated as "large" and tested against all.
const MAX_CELLS_PER_BLOCK: usize = 64;

/// Axis-aligned box of a block's corners, inflated by `pad`.
fn bounding_box(model: &Model, b: usize, pad: f64) -> [f64; 4] {
    let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for c in model.block_corners(b) {
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

/// Candidate block pairs (i < j), at least one of them flagged, whose inflated boxes overlap.
/// Sorted, so everything downstream runs in a fixed order.
pub fn candidate_pairs(model: &Model, flagged: &[bool]) -> Vec<(u32, u32)> {
    let n = model.blocks.len();
    if n < 2 {
        return Vec::new();
    }
    let pad = 0.5 * model.tol.atol;
    let boxes: Vec<[f64; 4]> = (0..n).map(|b| bounding_box(model, b, pad)).collect();
    // Cell size: the mean box extent, so a typical block spans about four cells.
    let mean_extent = boxes.iter().map(|b| (b[2] - b[0]).max(b[3] - b[1])).sum::<f64>() / n as f64;
    let cell = mean_extent.max(1e-12);
    let (mut x0, mut y0) = (f64::INFINITY, f64::INFINITY);
    for b in &boxes {
        x0 = x0.min(b[0]);
        y0 = y0.min(b[1]);
    }
    let cell_of = |x: f64, y: f64| -> (i64, i64) { (((x - x0) / cell).floor() as i64, ((y - y0) / cell).floor() as i64) };
    let mut grid: HashMap<(i64, i64), Vec<u32>> = HashMap::default();
    let mut large: Vec<u32> = Vec::new();
    for (b, bb) in boxes.iter().enumerate() {
        let (cx0, cy0) = cell_of(bb[0], bb[1]);
        let (cx1, cy1) = cell_of(bb[2], bb[3]);
        let cells = ((cx1 - cx0 + 1) * (cy1 - cy0 + 1)) as usize;
        if cells > MAX_CELLS_PER_BLOCK {
            large.push(b as u32);
            continue;
        }
        for cx in cx0..=cx1 {
            for cy in cy0..=cy1 {
                grid.entry((cx, cy)).or_default().push(b as u32);
            }
        }
    }
    let mut pairs = Vec::new();
    let mut consider = |i: u32, j: u32| {
        let (i, j) = if i < j { (i, j) } else { (j, i) };
        if i != j && (flagged[i as usize] || flagged[j as usize]) && boxes_overlap(&boxes[i as usize], &boxes[j as usize]) {
            pairs.push((i, j));
        }
    };
    for members in grid.values() {
        for (k, &i) in members.iter().enumerate() {
            for &j in &members[k + 1..] {
                consider(i, j);
            }
        }
    }
    for &l in &large {
        for j in 0..n as u32 {
            consider(l, j);
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// The joint material and constitutive number of a new contact: a tag on the touched edge of
/// block 2, else a tag on an edge at block 1's corner (SPLIT MAT= CONS=), else block 2's own
/// (the manual: "the joint or contact will take the material and constitutive numbers of one of
/// the adjoining blocks").
fn contact_material(model: &Model, corner: u32, block2: usize, feature: u32) -> (u32, u32) {
    let b2 = &model.blocks[block2];
    let corners2 = model.block_corners(block2);
    let k = (feature / 2) as usize % corners2.len();
    if feature % 2 == 1 && corners2[k].edge_material != 0 {
        return (corners2[k].edge_material, corners2[k].edge_constitutive.max(1));
    }
    let c = &model.corners[corner as usize];
    let b1 = &model.blocks[c.block as usize];
    let prev = if corner == b1.corner_start { b1.corner_start + b1.corner_count - 1 } else { corner - 1 };
    for tagged in [c, &model.corners[prev as usize]] {
        if tagged.edge_material != 0 {
            return (tagged.edge_material, tagged.edge_constitutive.max(1));
        }
    }
    (b2.material, b2.constitutive)
}

/// Re-examines the neighbourhood of every flagged block (all blocks when `all` is true), creates
/// new contacts, drops broken ones, and returns how many contacts were created and dropped.
/// The caller rebuilds the adjacency lists afterwards.
pub fn update_contacts(model: &mut Model, all: bool) -> (usize, usize) {
    let etol = model.tol.etol;
    let flagged: Vec<bool> = model.blocks.iter().map(|b| all || (!b.fixed && b.moved_since_update > etol)).collect();
    let pairs = candidate_pairs(model, &flagged);

    // Existing contacts by identity: the corner and the block it touches.
    let mut existing: HashMap<(u32, u32), usize> = HashMap::with_capacity_and_hasher(model.contacts.len(), Default::default());
    for (i, c) in model.contacts.iter().enumerate() {
        existing.insert((c.corner, c.block2), i);
    }
    let mut keep = vec![true; model.contacts.len()];
    // Contacts of flagged blocks are re-decided below; contacts of pairs no longer candidates are
    // decided by their current gap (kept up to date every cycle by the contact stage).
    let btol = model.tol.btol;
    for (i, c) in model.contacts.iter().enumerate() {
        if c.gap > btol {
            keep[i] = false;
        }
    }
    let atol = model.tol.atol;
    let mut created: Vec<Contact> = Vec::new();
    for &(i, j) in &pairs {
        for (a, b) in [(i as usize, j as usize), (j as usize, i as usize)] {
            let range = {
                let blk = &model.blocks[a];
                blk.corner_start..blk.corner_start + blk.corner_count
            };
            for corner in range {
                let c = &model.corners[corner as usize];
                let g = nearest_feature(model.block_corners(b), c.circle, c.radius);
                match existing.get(&(corner, b as u32)) {
                    Some(&k) => {
                        if g.gap > btol {
                            keep[k] = false;
                        } else {
                            let contact = &mut model.contacts[k];
                            contact.feature = g.feature;
                            contact.kind = g.kind;
                            contact.gap = g.gap;
                            contact.normal = g.normal;
                            contact.point = g.point;
                        }
                    }
                    None if g.gap < atol => {
                        let (material, constitutive) = contact_material(model, corner, b, g.feature);
                        created.push(Contact {
                            id: 0,
                            block1: a as u32,
                            corner,
                            block2: b as u32,
                            feature: g.feature,
                            kind: g.kind,
                            material,
                            constitutive,
                            // Surfaces already in touch when the contact forms (the two sides of
                            // a SPLIT, blocks built against each other) are an intact joint.
                            bonded: g.gap <= 1e-9 * model.tol.round.max(1e-300),
                            point: g.point,
                            normal: g.normal,
                            gap: g.gap,
                            normal_force: 0.0,
                            shear_force: 0.0,
                            shear_displacement: 0.0,
                            force: [0.0, 0.0],
                            slip_work: 0.0,
                            dashpot_work: 0.0,
                            dashpot_velocity: [0.0, 0.0],
                        });
                    }
                    None => {}
                }
            }
        }
    }
    let before = model.contacts.len();
    let mut k = 0;
    model.contacts.retain(|_| {
        k += 1;
        keep[k - 1]
    });
    let dropped = before - model.contacts.len();
    let n_created = created.len();
    for mut c in created {
        c.id = model.next_contact_id;
        model.next_contact_id += 1;
        model.contacts.push(c);
    }
    // A fixed order (by block 1, corner, block 2) makes runs repeat bit for bit.
    model.contacts.sort_by_key(|c| (c.block1, c.corner, c.block2));
    for (b, f) in model.blocks.iter_mut().zip(&flagged) {
        if *f {
            b.moved_since_update = 0.0;
            b.update_centroid = b.centroid;
            b.update_rotation = b.rotation;
        }
    }
    (n_created, dropped)
}

/// True for a contact that carries the force of its touch; false for the other view of a touch
/// of two corners (see `cpu::contact_forces::counts_force`).
#[inline]
pub fn counts_force(model: &Model, c: &Contact) -> bool {
    let b2 = &model.blocks[c.block2 as usize];
    crate::cpu::contact_forces::counts_force(c.corner, &model.corners[c.corner as usize], model.block_corners(c.block2 as usize), b2.corner_start, c.feature)
}
