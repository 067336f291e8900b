//! Which view of a touch of two corners carries its force (`counts_force`). Two rounded corners
//! that touch are seen from both blocks, as two contacts; exactly one of them may carry the
//! touch's force, or it counts twice. Twin of `counts_force` and `deeper_view_counts` in
//! shaders/udec/contact_forces.wgsl.

use super::geometry::track_feature;
use crate::udec::model::geometry::{dot, next, sub};
use crate::udec::model::{Contact, Corner, Feature, Model};

/// Whether a corner–corner contact is the counted one of its mirrored pair: the corner with the
/// lower global index owns the touch.
#[inline]
pub fn owns_corner_corner(own_corner_global: u32, other_corner_global: u32) -> bool {
    own_corner_global < other_corner_global
}

/// Overlaps of the two views of one corner pair that differ by less than this fraction of the
/// sum of the two rounding radii count as equal, and the index decides: aligned corners (a brick
/// wall's, a column's) have equal overlaps up to round-off, and with the index rule there they
/// neither flip from view to view nor differ between the CPU and an f32 GPU (whose overlaps carry
/// round-off of ~1e-7 of a block's size). A switch between views outside the band changes the
/// normal force by at most kn times this band.
pub const PAIR_BAND: f64 = 1e-4;

/// Whether a contact carries the force of its touch. Two rounded corners that touch are seen from
/// both blocks, and the two views need not agree on the kind: one may find the other's arc
/// (corner–corner), the other the straight edge beside the first corner (corner–edge), or both
/// may find edges. Counting every view then counts such a touch twice. The rule:
///
/// - a view on the arc of corner b, or on an edge whose nearer end corner b has a rounding circle
///   that overlaps the own corner a's, is one view of the corner pair (a, b); of the pair's two
///   views the one with the deeper overlap counts ([`deeper_view_counts`]);
/// - otherwise (a corner on an edge's straight part, away from its ends) the view always counts.
///
/// Which is deeper matters: a corner of one block can sit well inside the straight part of the
/// other's edge, next to that edge's end corner, whose own view of the pair finds almost no
/// overlap. Counting by index alone (the rule before) left such a penetration without force until
/// the circles parted, then counted it in full at once (UDEC sample 2: 2.9 cm, 2.9 MN, 4e4 J out
/// of nothing). By depth, the count passes from one view to the other where their overlaps are
/// equal, so the normal force (kn times the overlap) does not jump.
///
/// `own_gap` is this view's gap (negative: overlap) as stage 4 measured it; `corners1` are block
/// 1's corners (the own corner's), `start1` the global index of its first; `corners2`, `start2`
/// block 2's.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn counts_force(
    own_corner_global: u32,
    own: &Corner,
    own_gap: f64,
    corners1: &[Corner],
    start1: u32,
    corners2: &[Corner],
    start2: u32,
    feature: Feature,
) -> bool {
    let n = corners2.len();
    let k = (feature / 2) as usize % n;
    let b = if feature % 2 == 0 {
        k
    } else {
        let j = next(k, n);
        let (rk, rj) = (sub(own.circle, corners2[k].circle), sub(own.circle, corners2[j].circle));
        let (b, d2) = if dot(rk, rk) <= dot(rj, rj) { (k, dot(rk, rk)) } else { (j, dot(rj, rj)) };
        let reach = own.radius + corners2[b].radius;
        if d2 >= reach * reach {
            return true;
        }
        b
    };
    let own_local = own_corner_global.wrapping_sub(start1) as usize;
    deeper_view_counts(own_corner_global, own, own_gap, corners1, own_local, &corners2[b], start2 + b as u32)
}

/// Of the two views of the corner pair (a, b), whether a's counts: a's gap against block 2 is
/// `own_gap`; b's against block 1 is measured here, from the features of block 1 around a (edge
/// a−1, arc a, edge a: b's circle overlaps a's, so b's nearest feature is among them unless an
/// edge is shorter than the rounding), as b's own view tracks it. The deeper view counts; within
/// [`PAIR_BAND`] the lower index does, so exactly one view of a pair counts.
#[inline]
pub fn deeper_view_counts(a: u32, own: &Corner, own_gap: f64, corners1: &[Corner], a_local: usize, corner_b: &Corner, b: u32) -> bool {
    if a_local >= corners1.len() {
        return owns_corner_corner(a, b);
    }
    let other_gap = track_feature(corners1, 2 * a_local as Feature, corner_b.circle, corner_b.radius).gap;
    let band = PAIR_BAND * (own.radius + corner_b.radius);
    if own_gap < other_gap - band {
        true
    } else if other_gap < own_gap - band {
        false
    } else {
        owns_corner_corner(a, b)
    }
}

impl Model {
    /// True for a contact that carries the force of its touch; false for the other view of a
    /// touch of two corners (see [`counts_force`]), by the gap stage 4 last measured.
    #[inline]
    pub fn counts_force(&self, c: &Contact) -> bool {
        let (b1, b2) = (&self.blocks[c.block1 as usize], &self.blocks[c.block2 as usize]);
        counts_force(
            c.corner,
            &self.corners[c.corner as usize],
            c.gap,
            self.block_corners(c.block1 as usize),
            b1.corner_start,
            self.block_corners(c.block2 as usize),
            b2.corner_start,
            c.feature,
        )
    }
}
