//! Dynamic cracking (SL-85-1, Appendix A ¶15–17), each block by its cracking law ([`find_crack`]):
//! by Griffith's criterion on the internal stress of a simply-deformable block (constitutive
//! numbers 3, 4 and 5: a crack through the centroid parallel to the minimum principal stress; the
//! pieces stay simply deformable with their stresses set to zero), and by the point-load
//! criterion (constitutive numbers 1 and 2), below.
//!
//! The point-load criterion: A block with a tensile strength factor t_f is split between two opposing contact
//! forces f1, f2 a distance d apart when
//!
//!   (f1 + f2) / (2 d²) ≥ t_f,
//!
//! taking the pair with the largest value. Cracks through or too close to a corner are not allowed:
//! each end must lie at least half the block's smallest edge from every corner. The new joint takes
//! the block's material and constitutive number; velocities carry over through the split, and the
//! contacts of the old block are re-detected on the pieces with their shear history carried over.

use crate::udec::contact::gather::{gather, ContactForce};
use crate::udec::contact::law::normal_force;
use crate::udec::model::constitutive::{Constitutive, CrackingLaw};
use crate::udec::model::geometry::closest_point_on_segment;
use crate::udec::model::split::split_block_along;
use crate::udec::model::{BlockKind, Model};
use crate::udec::topology::{update_contacts, Adjacency};

/// A crack found in a block (by either criterion): its end points (on the block boundary) and the
/// criterion's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crack {
    pub block: usize,
    /// The criterion that found it.
    pub law: CrackingLaw,
    pub from: [f64; 2],
    pub to: [f64; 2],
    pub value: f64,
}

/// Whether block `b` is checked for point-load cracking at all (a piece of a crack under twice
/// the fragment floor is not, `crate::cracking`).
pub fn is_point_load_candidate(model: &Model, b: usize) -> bool {
    let blk = &model.blocks[b];
    crate::cracking::above_floor(blk.area, blk.built_area)
        && blk.kind != BlockKind::FullyDeformable
        && Constitutive::from_number(blk.constitutive).is_some_and(|c| c.cracking == CrackingLaw::PointLoad)
        && model.material(blk.material).block.tf > 0.0
}

/// Whether block `b` is checked for Griffith cracking (Appendix A ¶17; constitutive numbers 3, 4
/// and 5): a simply-deformable block, whose internal stress the criterion reads, with a tensile
/// strength factor, above the fragment floor (`crate::cracking`).
pub fn is_griffith_candidate(model: &Model, b: usize) -> bool {
    let blk = &model.blocks[b];
    crate::cracking::above_floor(blk.area, blk.built_area)
        && model.sdef_of(b).is_some()
        && Constitutive::from_number(blk.constitutive).is_some_and(|c| c.cracking == CrackingLaw::Griffith)
        && model.material(blk.material).block.tf > 0.0
}

/// Whether block `b` is checked for cracking by either criterion (stage 7 then runs every cycle).
pub fn is_crack_candidate(model: &Model, b: usize) -> bool {
    is_point_load_candidate(model, b) || is_griffith_candidate(model, b)
}

/// The crack block `b`'s cracking law finds in it, if the block is a candidate for either
/// criterion and its value reaches the tensile strength t_f; `adjacency` gives the contacts the
/// point-load criterion reads.
pub fn find_crack(model: &Model, adjacency: &Adjacency, b: usize) -> Option<Crack> {
    if is_point_load_candidate(model, b) {
        find_point_load_crack(model, adjacency, b)
    } else if is_griffith_candidate(model, b) {
        find_griffith_crack(model, b)
    } else {
        None
    }
}

/// The crack Griffith's criterion finds in block `b` (Appendix A ¶17), if its internal stress
/// reaches the tensile strength t_f: through the centroid, parallel to the minimum principal
/// stress s_p2, from boundary to boundary. Its value is the criterion's equivalent tensile stress
/// (`sdef::griffith_stress`).
///
/// Two floors end a cascade of cracks: a block whose area is under that of a square of side
/// twice the rounding length does not crack (its corners' arcs already meet, so a crack would
/// make corners that interfere, which ¶13's splitting logic rejects), and no crack leaves a piece
/// under [`crate::cracking::FRAGMENT_FLOOR`] of the block the deck built (`split_block_along`),
/// nor is a block under twice that checked (`is_griffith_candidate`). Without the first a
/// strength far below the stress (TF = 1e-300) halved every piece every cycle, 2ⁿ blocks after n
/// cycles, and a run of 17 cycles never ended (found by tests/suite/random_decks.rs); with it
/// alone a small ROUND let the halving go on (ROUND 0.003: 17 924 blocks from one of 1 m² after
/// 40 cycles and eleven minutes). D3 has the second alone (it has no rounding).
fn find_griffith_crack(model: &Model, b: usize) -> Option<Crack> {
    let round = model.tol.round;
    if model.blocks[b].area < 4.0 * round * round {
        return None;
    }
    let s = model.sdef_of(b)?;
    let tf = model.material(model.blocks[b].material).block.tf;
    let (s1, s2, angle) = crate::udec::model::sdef::principal_values(s.stress);
    let value = crate::udec::model::sdef::griffith_stress(s1, s2);
    // A NaN stress never cracks a block.
    if value.is_nan() || value < tf {
        return None;
    }
    // s_p2 is perpendicular to s_p1, whose direction is `angle`.
    let d = [-angle.sin(), angle.cos()];
    let c = model.blocks[b].centroid;
    let outline = model.world_outline(b);
    let (from, to) = line_through(&outline, c, d)?;
    Some(Crack { block: b, law: CrackingLaw::Griffith, from, to, value })
}

/// Where the line through `c` (inside the polygon `pts`) along `d` leaves it on either side: the
/// nearest crossing of the boundary in each direction.
fn line_through(pts: &[[f64; 2]], c: [f64; 2], d: [f64; 2]) -> Option<([f64; 2], [f64; 2])> {
    let n = pts.len();
    let (mut ahead, mut behind) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..n {
        let (a, e) = (pts[k], pts[(k + 1) % n]);
        let edge = [e[0] - a[0], e[1] - a[1]];
        // c + t·d = a + u·edge, solved for t and u.
        let den = d[0] * edge[1] - d[1] * edge[0];
        if den.abs() <= f64::EPSILON * (edge[0].abs() + edge[1].abs()) {
            continue;
        }
        let w = [a[0] - c[0], a[1] - c[1]];
        let t = (w[0] * edge[1] - w[1] * edge[0]) / den;
        let u = (w[0] * d[1] - w[1] * d[0]) / den;
        if (0.0..=1.0).contains(&u) {
            if t > 0.0 {
                ahead = ahead.min(t);
            } else {
                behind = behind.max(t);
            }
        }
    }
    (ahead.is_finite() && behind.is_finite()).then(|| ([c[0] + behind * d[0], c[1] + behind * d[1]], [c[0] + ahead * d[0], c[1] + ahead * d[1]]))
}

/// Closest point to `p` on the boundary of block `b`, and the distance from it to the nearest
/// corner.
fn project_to_boundary(model: &Model, b: usize, p: [f64; 2]) -> ([f64; 2], f64) {
    let corners = model.block_corners(b);
    let n = corners.len();
    let mut best = (f64::INFINITY, p);
    for k in 0..n {
        let q = closest_point_on_segment(p, corners[k].position, corners[(k + 1) % n].position);
        let d2 = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
        if d2 < best.0 {
            best = (d2, q);
        }
    }
    let q = best.1;
    let to_corner = corners.iter().map(|c| ((c.position[0] - q[0]).powi(2) + (c.position[1] - q[1]).powi(2)).sqrt()).fold(f64::INFINITY, f64::min);
    (q, to_corner)
}

/// Searches block `b` for the pair of opposing contact forces with the largest point-load value;
/// returns it if it reaches the block's t_f.
fn find_point_load_crack(model: &Model, adjacency: &Adjacency, b: usize) -> Option<Crack> {
    let tf = model.material(model.blocks[b].material).block.tf;
    let corners = model.block_corners(b);
    let n = corners.len();
    let smallest_edge = (0..n)
        .map(|k| {
            let (a, c) = (corners[k].position, corners[(k + 1) % n].position);
            ((c[0] - a[0]).powi(2) + (c[1] - a[1]).powi(2)).sqrt()
        })
        .fold(f64::INFINITY, f64::min);
    let clearance = 0.5 * smallest_edge;
    // Compressive contacts with the force each exerts on this block.
    let loads: Vec<([f64; 2], [f64; 2], f64)> = adjacency
        .entries(b)
        .iter()
        .filter_map(|&e| {
            let c = &model.contacts[e.contact() as usize];
            if c.normal_force <= 0.0 {
                return None;
            }
            let sign = if e.side() == 0 { 1.0 } else { -1.0 };
            let f = [sign * c.normal_force * c.normal[0], sign * c.normal_force * c.normal[1]];
            Some((c.point, f, c.normal_force))
        })
        .collect();
    let mut best: Option<Crack> = None;
    for i in 0..loads.len() {
        for j in i + 1..loads.len() {
            let (p1, f1, m1) = loads[i];
            let (p2, f2, m2) = loads[j];
            let d = [p2[0] - p1[0], p2[1] - p1[1]];
            let dist2 = d[0] * d[0] + d[1] * d[1];
            if dist2 <= 0.0 {
                continue;
            }
            // Opposing (a point-load test): the forces point against each other (more than a
            // right angle apart) and each pushes towards the other point. (Without the first,
            // two blocks resting on this one either side of their joint, both pressing down,
            // their normals tilted towards each other by round-off, were a "pair" a hair
            // apart: a value of 1/d² that cracked walls under their own weight.)
            if f1[0] * f2[0] + f1[1] * f2[1] >= 0.0 || f1[0] * d[0] + f1[1] * d[1] <= 0.0 || f2[0] * d[0] + f2[1] * d[1] >= 0.0 {
                continue;
            }
            let value = (m1 + m2) / (2.0 * dist2);
            if value < tf || best.is_some_and(|c| c.value >= value) {
                continue;
            }
            let (q1, c1) = project_to_boundary(model, b, p1);
            let (q2, c2) = project_to_boundary(model, b, p2);
            if c1 < clearance || c2 < clearance {
                continue;
            }
            best = Some(Crack { block: b, law: CrackingLaw::PointLoad, from: q1, to: q2, value });
        }
    }
    best
}

/// Splits the block along the crack, re-detects the contacts of the pieces and carries over the
/// shear history of the old contacts whose corner and far block are unchanged. Returns the block
/// indices of the pieces, or None if the split was rejected (the model is then unchanged).
pub fn apply_crack(model: &mut Model, crack: &Crack) -> Option<Vec<usize>> {
    let b = crack.block;
    let (material, constitutive) = (model.blocks[b].material, model.blocks[b].constitutive);
    let cracked_id = model.blocks[b].id;
    // History of the old contacts: (other block id, corner position) → shear state.
    let mut history = Vec::new();
    let mut neighbours = Vec::new();
    for c in &model.contacts {
        if c.block1 as usize == b || c.block2 as usize == b {
            let other = if c.block1 as usize == b { c.block2 } else { c.block1 };
            neighbours.push(model.blocks[other as usize].id);
            history.push((model.blocks[other as usize].id, model.corners[c.corner as usize].position, c.shear_force, c.shear_displacement, c.bonded));
        }
    }
    let floor = crate::cracking::least_piece(model.blocks[b].built_area);
    let pieces = split_block_along(model, b, crack.from, crack.to, material, constitutive, floor)?;
    // Re-examine the pieces and every former neighbour.
    for blk in model.blocks.iter_mut() {
        if blk.id == cracked_id || neighbours.contains(&blk.id) {
            blk.moved_since_update = f64::INFINITY;
        }
    }
    for &p in &pieces {
        model.blocks[p].moved_since_update = f64::INFINITY;
    }
    update_contacts(model, false);
    let tol = 1e-6 * model.tol.round.max(1e-12);
    let piece_ids: Vec<u32> = pieces.iter().map(|&p| model.blocks[p].id).collect();
    for k in 0..model.contacts.len() {
        let c = model.contacts[k];
        let (id1, id2) = (model.blocks[c.block1 as usize].id, model.blocks[c.block2 as usize].id);
        let other = match (piece_ids.contains(&id1), piece_ids.contains(&id2)) {
            (true, false) => id2,
            (false, true) => id1,
            // The crack itself is a fresh fracture: it has no cohesion to lose.
            (true, true) => {
                model.contacts[k].bonded = false;
                continue;
            }
            (false, false) => continue,
        };
        let pos = model.corners[c.corner as usize].position;
        if let Some(h) = history.iter().find(|h| h.0 == other && (h.1[0] - pos[0]).abs() <= tol && (h.1[1] - pos[1]).abs() <= tol) {
            let contact = &mut model.contacts[k];
            contact.shear_force = h.2;
            contact.shear_displacement = h.3;
            contact.bonded = h.4;
        }
    }
    // A contact re-made on a piece starts with the forces the contact stage would give it now, so
    // that the first cycle after the crack moves the pieces with them and the crack's energy
    // books (`Model::retire_energy_around`) release only what really went:
    // - the normal force is the total form of eq. (16), kn times the overlap: made at zero, its
    //   spring's energy was booked as released and came back a cycle later with no work done
    //   (sample 1: the ledger jumped by 2.3e5 J, 16% of its largest term);
    // - the shear force carried over above keeps within the Coulomb limit of eq. (20), so a
    //   carried force on a contact that is open now is released here, not a cycle later;
    // - the force the gather sums (`Contact::force`), which the pieces otherwise felt as zero
    //   for a cycle (they fell a step under gravity alone: 2.5e4 J more);
    // - the view of a corner pair that does not carry the touch (`counts_force`) carries nothing.
    // Contacts the update kept hold their forces already.
    for k in 0..model.contacts.len() {
        let c = model.contacts[k];
        let touches_piece = pieces.contains(&(c.block1 as usize)) || pieces.contains(&(c.block2 as usize));
        if !touches_piece || c.normal_force != 0.0 {
            continue;
        }
        let active = model.counts_force(&c);
        let m = crate::udec::model::constitutive::law_parameters(c.joint_length, model.material(c.material));
        let cohesion = if c.bonded { m.cohesion } else { 0.0 };
        let fn_ = if active { normal_force(c.gap, m.kn, cohesion) } else { 0.0 };
        let limit = if active { cohesion + m.friction * fn_.max(0.0) } else { 0.0 };
        let fs = c.shear_force.clamp(-limit, limit);
        let (n, t) = (c.normal, [-c.normal[1], c.normal[0]]);
        let contact = &mut model.contacts[k];
        contact.normal_force = fn_;
        contact.shear_force = fs;
        contact.force = [fn_ * n[0] + fs * t[0], fn_ * n[1] + fs * t[1]];
    }
    // Stage 6 for the blocks whose contacts changed, so that the energy books taken after the
    // crack measure the kinetic energy at t (half a step of the block force, see
    // `Model::live_energies`) with the forces the next cycle moves the blocks with.
    let changed: Vec<usize> = (0..model.blocks.len()).filter(|&i| pieces.contains(&i) || neighbours.contains(&model.blocks[i].id)).collect();
    let adjacency = Adjacency::build(model.blocks.len(), &model.contacts);
    let forces: Vec<ContactForce> = model.contacts.iter().map(ContactForce::from).collect();
    let gravity = model.gravity;
    for b in changed {
        gather(&mut model.blocks[b], &forces, adjacency.entries(b), gravity);
    }
    Some(pieces)
}
