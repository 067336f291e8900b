//! Stage 7's cracking criteria for D3: SL-85-1 Part III ¶35f asks to "allow blocks to split,
//! dynamically and statically; include point-to-point splitting law and Griffith's law for
//! simply-deformable blocks". Both are the 2D engine's laws (Appendix A ¶15–17) carried into three
//! dimensions; a block's constitutive number picks its law as in 2D (Table A1): 1 and 2 the
//! point-load law, 3 to 5 Griffith's, each only where the block's material has a tensile strength
//! factor TF. This module finds the cracks due (a pure function of the model after a cycle);
//! `split::crack` cuts and `cpu::crack_blocks` re-detects the contacts and books the ledger.
//!
//! **Griffith's law** (constitutive 3–5, simply-deformable blocks): on the major and minor
//! principal stresses s1 ≥ s3 of the block's internal stress (`sdef::griffith_stress`); the crack
//! is the plane through the centroid across the major principal stress (it holds the other two
//! principal directions, as 2D's crack runs along s_p2).
//!
//! **The point-load law** (constitutive 1 and 2, rigid or simply-deformable blocks): as in 2D,
//! the pair of opposing compressive contact forces F1, F2 on the block, at points a distance d
//! apart, with the largest value
//!
//!   (F1 + F2) / (2 d²),
//!
//! splits the block where it reaches TF. In 3D this is the point-load strength index of rock
//! mechanics, Is = P/D² (Franklin's test: a lump squeezed between two cones), so TF is that
//! index's strength. Each force is a contact's resultant normal force at its point (the logical
//! contacts' points weighted by their forces), and "opposing" means the two point against each
//! other (more than a right angle apart: two blocks resting on this one, both pressing down, are
//! no pair however their normals tilt) and each pushes towards the other point. As 2D keeps a crack's ends half the block's smallest edge from every corner, a load
//! point must lie that far (half the shortest distance between two of the block's corners) from
//! every corner, a corner being a vertex where three or more distinct face planes meet (the
//! vertices a SPLIT's cap or a face's triangulation adds in the middle of a planar side are not
//! corners). The crack plane holds the line between the two load points; about that line it takes
//! the orientation of the diametral tests: its normal is the direction across the line in which the
//! block is longest (the largest second moment of its mass there), so that a disc squeezed across
//! a diameter splits along the plane of that diameter and its axis (the Brazilian test) and a
//! core squeezed across its diameter breaks across its axis. Where the block's section across the
//! line is round (the two second moments within 10⁻⁹ of each other) the plane holds the centroid
//! too, or, where the centroid lies on the line, takes a fixed direction across it.
//!
//! **The fragment floor** (extension, `crate::cracking`, which the 2D engine shares): D3 has no
//! rounding length to end a cascade of cracks, so a crack is made only where each piece keeps at
//! least [`FRAGMENT_FLOOR`] of the volume of the block the deck built (`Block::built_volume`,
//! which a crack's pieces inherit; `split::crack` leaves the block whole otherwise). A block under
//! twice the floor is not checked at all ([`above_floor`]).

use glam::{DMat3, DVec3};

use super::model::Model;
use super::sdef;

pub use crate::cracking::FRAGMENT_FLOOR;

/// Whether block `b` holds enough of its block as built to leave two pieces at the floor: one
/// that does not cracks no further (`crate::cracking`).
pub fn above_floor(b: &super::model::Block) -> bool {
    crate::cracking::above_floor(b.volume, b.built_volume)
}

/// Which law a crack came from, as the log names it.
pub const GRIFFITH: &str = "GRIFFITH";
/// The point-load law's name in the log.
pub const POINT_LOAD: &str = "POINT-LOAD";

/// A crack found due after a cycle: the block (its index), the crack plane (a point on it and its
/// unit normal), the criterion's value (Pa) and its law's name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crack {
    pub block: usize,
    pub point: DVec3,
    pub normal: DVec3,
    pub value: f64,
    pub criterion: &'static str,
}

/// Whether a block of constitutive number `constitutive` whose material's tensile strength is
/// `tf` is checked by the point-load law: constitutive 1 or 2 with a TF (as in 2D).
pub fn point_load_applies(constitutive: u32, tf: f64) -> bool {
    (1..=2).contains(&constitutive) && tf > 0.0
}

/// Whether block `b` may crack: a simply-deformable block under Griffith's law, or any block
/// under the point-load law.
pub fn is_candidate(model: &Model, b: usize) -> bool {
    let blk = &model.blocks[b];
    let tf = model.material(blk.material).tf;
    (blk.is_sdef() && sdef::griffith_applies(blk.constitutive, tf)) || point_load_applies(blk.constitutive, tf)
}

/// Whether any block is checked by the point-load law (which reads the contact forces: the GPU
/// then reads them back every cycle).
pub fn has_point_load_candidates(model: &Model) -> bool {
    model.blocks.iter().any(|b| point_load_applies(b.constitutive, model.material(b.material).tf))
}

/// The cracks due now, in block order, one per block at most.
pub fn due(model: &Model) -> Vec<Crack> {
    // The compressive contact forces on each point-load candidate: (point, force on it, |force|).
    let mut loads: Vec<Vec<(DVec3, DVec3, f64)>> = Vec::new();
    if has_point_load_candidates(model) {
        loads.resize(model.blocks.len(), Vec::new());
        for c in &model.contacts {
            let fn_ = c.normal_force();
            if fn_ <= 0.0 || !fn_.is_finite() {
                continue;
            }
            let p = c.point();
            // The normal points from block 1 to block 2: a compressive force pushes block 2 along
            // it and block 1 against it.
            for (side, sign) in [(0, -1.0), (1, 1.0)] {
                let b = c.blocks[side] as usize;
                let blk = &model.blocks[b];
                if point_load_applies(blk.constitutive, model.material(blk.material).tf) {
                    loads[b].push((p, c.normal * (sign * fn_), fn_));
                }
            }
        }
    }
    let mut out = Vec::new();
    for (k, b) in model.blocks.iter().enumerate() {
        if !above_floor(b) {
            continue;
        }
        let tf = model.material(b.material).tf;
        if let Some(s) = b.sdef.as_ref().filter(|_| sdef::griffith_applies(b.constitutive, tf)) {
            let (p, n) = sdef::principal_stresses(s.stress);
            let value = sdef::griffith_stress(p[0], p[2]);
            // A NaN stress never cracks a block.
            if value >= tf {
                out.push(Crack { block: k, point: b.centroid, normal: n, value, criterion: GRIFFITH });
            }
        } else if point_load_applies(b.constitutive, tf) {
            if let Some(c) = point_load_crack(model, k, &loads[k], tf) {
                out.push(c);
            }
        }
    }
    out
}

/// The corners of block `b` (vertices where three or more distinct face planes meet) and the
/// clearance a load point keeps from them: half the shortest distance between two corners.
fn corners(model: &Model, b: usize) -> (Vec<DVec3>, f64) {
    let blk = &model.blocks[b];
    let mut normals: Vec<Vec<DVec3>> = vec![Vec::new(); blk.vertices.len()];
    for (f, face) in blk.shape.faces.iter().enumerate() {
        let n = blk.face_normal(f);
        for &v in face {
            let seen = &mut normals[v as usize];
            if !seen.iter().any(|m| m.dot(n) > 1.0 - 1e-9) {
                seen.push(n);
            }
        }
    }
    let corners: Vec<DVec3> = normals.iter().zip(&blk.vertices).filter(|(n, _)| n.len() >= 3).map(|(_, &v)| v).collect();
    let mut shortest = f64::INFINITY;
    for i in 0..corners.len() {
        for j in i + 1..corners.len() {
            shortest = shortest.min((corners[i] - corners[j]).length());
        }
    }
    (corners, 0.5 * shortest)
}

/// The point-load crack of block `b` from its compressive contact `loads` (point, force on the
/// block, magnitude), if its largest value reaches `tf` (module doc).
fn point_load_crack(model: &Model, b: usize, loads: &[(DVec3, DVec3, f64)], tf: f64) -> Option<Crack> {
    if loads.len() < 2 {
        return None;
    }
    // The corners depend on the shape alone; found only once a pair reaches TF (this runs after
    // every cycle for every candidate).
    let mut found: Option<(Vec<DVec3>, f64)> = None;
    let mut clear = |p: DVec3| {
        let (corners, clearance) = found.get_or_insert_with(|| corners(model, b));
        corners.iter().all(|c| (*c - p).length() >= *clearance)
    };
    let mut best: Option<(usize, usize, f64)> = None;
    for i in 0..loads.len() {
        for j in i + 1..loads.len() {
            let ((p1, f1, m1), (p2, f2, m2)) = (loads[i], loads[j]);
            let d = p2 - p1;
            let dist2 = d.length_squared();
            // Opposing: the forces point against each other (more than a right angle apart)
            // and each pushes towards the other point. (Without the first, two bricks resting
            // on this one either side of their joint, both pressing down, their normals tilted
            // towards each other by a hair, were a "pair" 10⁻⁷ m apart: a value of 10¹⁵ that
            // cracked a wall under its own weight.)
            if dist2 <= 0.0 || f1.dot(f2) >= 0.0 || f1.dot(d) <= 0.0 || f2.dot(d) >= 0.0 {
                continue;
            }
            let value = (m1 + m2) / (2.0 * dist2);
            if value < tf || best.is_some_and(|(_, _, v)| v >= value) || !clear(p1) || !clear(p2) {
                continue;
            }
            best = Some((i, j, value));
        }
    }
    let (i, j, value) = best?;
    let (p1, p2) = (loads[i].0, loads[j].0);
    Some(Crack { block: b, point: p1, normal: across_line(model, b, p1, p2), value, criterion: POINT_LOAD })
}

/// The unit normal of the plane holding the line p1–p2 through block `b` (module doc): across the
/// line, the direction in which the block is longest.
fn across_line(model: &Model, b: usize, p1: DVec3, p2: DVec3) -> DVec3 {
    let blk = &model.blocks[b];
    let d = (p2 - p1).normalize();
    let e1 = d.any_orthonormal_vector();
    let e2 = d.cross(e1);
    // The second moments of the mass, Σ m x xᵀ = ½ tr(I)·1 − I, in the plane across the line.
    let i = blk.inertia();
    let m = DMat3::from_diagonal(DVec3::splat(0.5 * (i.x_axis.x + i.y_axis.y + i.z_axis.z))) - i;
    let (a, c, bb) = (e1.dot(m * e1), e2.dot(m * e2), e1.dot(m * e2));
    let spread = (0.25 * (a - c).powi(2) + bb * bb).sqrt();
    if spread > 1e-9 * (a + c).abs() {
        // The eigenvector of the larger eigenvalue of [[a, b], [b, c]].
        let theta = 0.5 * (2.0 * bb).atan2(a - c);
        return (e1 * theta.cos() + e2 * theta.sin()).normalize();
    }
    // A round section: the plane through the centroid too, where it is off the line.
    let off = blk.centroid - p1;
    let across = off - d * d.dot(off);
    if across.length() > 1e-9 * blk.shape.radius {
        return d.cross(across).normalize();
    }
    e1
}
