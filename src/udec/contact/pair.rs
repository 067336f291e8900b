//! Which view of a touch of two corners carries its force (`counts_force`). Two rounded corners
//! that touch are seen from both blocks, as two contacts; exactly one of them may carry the
//! touch's force, or it counts twice. Twin of `counts_force` and `deeper_view_counts` in
//! shaders/udec/contact_forces.wgsl.

use super::geometry::{edge_normal, track_feature};
use crate::udec::model::geometry::{cross, dot, length, next, prev, sub};
use crate::udec::model::{BlockKind, Contact, Corner, Feature, Model};

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
/// 1's corners (the own corner's), `start1` the global index of its first, `rigid1` whether
/// block 1 is rigid (its rounding circles are then tangent to its edges to round-off, which
/// [`arc_view_verdict`] relies on); `corners2`, `start2` block 2's.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn counts_force(
    own_corner_global: u32,
    own: &Corner,
    own_gap: f64,
    corners1: &[Corner],
    start1: u32,
    rigid1: bool,
    corners2: &[Corner],
    start2: u32,
    feature: Feature,
) -> bool {
    let n = corners2.len();
    // (k mod n without a division where k < n, as it is for a tracked feature: stage 4 asks
    // this of every closed contact every cycle.)
    let k = (feature / 2) as usize;
    let k = if k < n { k } else { k % n };
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
    deeper_view_counts(own_corner_global, own, own_gap, corners1, own_local, rigid1, &corners2[b], start2 + b as u32)
}

/// Of the two views of the corner pair (a, b), whether a's counts: a's gap against block 2 is
/// `own_gap`; b's against block 1 is measured here, from the features of block 1 around a (edge
/// a−1, arc a, edge a: b's circle overlaps a's, so b's nearest feature is among them unless an
/// edge is shorter than the rounding), as b's own view tracks it. The deeper view counts; within
/// [`PAIR_BAND`] the lower index does, so exactly one view of a pair counts.
///
/// Where block 1 is rigid, [`arc_view_verdict`] first tries to settle the comparison from b's
/// distance to a's arc alone (a wall's aligned corners, most pair views), which gives the verdict
/// the tracked gap would, bit for bit; the GPU's twin always tracks.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn deeper_view_counts(a: u32, own: &Corner, own_gap: f64, corners1: &[Corner], a_local: usize, rigid1: bool, corner_b: &Corner, b: u32) -> bool {
    if a_local >= corners1.len() {
        return owns_corner_corner(a, b);
    }
    let band = PAIR_BAND * (own.radius + corner_b.radius);
    let quick = if rigid1 { arc_view_verdict(own_gap, corners1, a_local, corner_b, band) } else { None };
    let verdict = quick.unwrap_or_else(|| tracked_verdict(own_gap, corners1, a_local, corner_b, band));
    match verdict {
        Deeper::Own => true,
        Deeper::Other => false,
        Deeper::Level => owns_corner_corner(a, b),
    }
}

/// Which view of a corner pair is the deeper, as [`deeper_view_counts`] compares them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Deeper {
    /// This view's overlap exceeds the other's by more than the band.
    Own,
    /// The other view's does.
    Other,
    /// Within the band of each other: the lower index decides.
    Level,
}

/// The comparison with b's view tracked as that view tracks it (from a's arc, `track_feature`).
#[inline]
pub fn tracked_verdict(own_gap: f64, corners1: &[Corner], a_local: usize, corner_b: &Corner, band: f64) -> Deeper {
    let other_gap = track_feature(corners1, 2 * a_local as Feature, corner_b.circle, corner_b.radius).gap;
    if own_gap < other_gap - band {
        Deeper::Own
    } else if other_gap < own_gap - band {
        Deeper::Other
    } else {
        Deeper::Level
    }
}

/// The verdict of [`tracked_verdict`] without tracking b's view, where it is certain; `None`
/// where it is not (then track). `corners1` must be a rigid block's: each rounding circle tangent
/// to its two edges at `round` from the corner, to round-off.
///
/// Why it holds. Let r = (b's centre − a's centre) and d = |r| − r_a, b's distance to a's arc. If
/// a is a convex corner and r lies in a's wedge (between the outward normals n0, n1 of its two
/// edges), a's rounded boundary is nearest to b's centre on the arc: each edge's straight part
/// starts at its tangent point on the circle and runs away from the wedge, so b's centre is at
/// least d from it (triangle inequality about a's centre). Where r lies outside the wedge by an
/// angle θ with |r| sin θ ≤ `slack` (aligned corners sit on its boundary, either side by
/// round-off), the edge's line is nearer, by at most |r|(1 − cos θ) ≤ slack²/|r|. The tracked
/// view takes the nearest of the three features up to `better`'s tie tolerance (1e-9 (1 + d),
/// twice at most), so its gap lies within `guard` of d − r_b, the round-off of both computations
/// (1e-10 of the coordinates' size, many times theirs) included. A verdict that holds for every
/// gap within `guard` of d − r_b is then the tracked one's; near the band's edges it is left to
/// the tracked comparison. Where d is small the features' signed and unsigned distances could
/// differ (the centre inside a's circle): left to it as well.
#[inline]
pub fn arc_view_verdict(own_gap: f64, corners1: &[Corner], a_local: usize, corner_b: &Corner, band: f64) -> Option<Deeper> {
    let n = corners1.len();
    let corner_a = &corners1[a_local];
    let (n0, n1) = (edge_normal(corners1, prev(a_local, n)), edge_normal(corners1, a_local));
    if cross(n0, n1) <= 0.0 {
        return None;
    }
    let (ca, cb) = (corner_a.circle, corner_b.circle);
    let size = 1.0 + ca[0].abs() + ca[1].abs() + cb[0].abs() + cb[1].abs();
    let radii = corner_a.radius + corner_b.radius;
    let slack = 1e-12 * size + 1e-9 * radii;
    let r = sub(cb, ca);
    if cross(n0, r) < -slack || cross(r, n1) < -slack {
        return None;
    }
    let d = length(r) - corner_a.radius;
    // (Not greater: also a NaN, which is left to the tracked comparison.)
    if d.partial_cmp(&(1e-3 * radii)) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let guard = 1e-8 * (1.0 + d) + 1e-10 * size + slack * slack / d;
    let estimate = d - corner_b.radius;
    if own_gap < estimate - band - guard {
        Some(Deeper::Own)
    } else if estimate < own_gap - band - guard {
        Some(Deeper::Other)
    } else if (own_gap - estimate).abs() < band - guard {
        Some(Deeper::Level)
    } else {
        None
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
            b1.kind == BlockKind::Rigid,
            self.block_corners(c.block2 as usize),
            b2.corner_start,
            c.feature,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::run_deck_on;

    /// `arc_view_verdict`, where it gives a verdict, gives the tracked one: b's circle placed
    /// round every corner of rigid blocks (a brick's right angles, a rotated hexagon's, a
    /// triangle's sharp ones, far from the origin too), along each wedge boundary exactly and
    /// round-off either side of it (a wall's aligned corners), inside and outside the wedge, at
    /// overlaps from none to beyond the run's limit; this view's gap at the band's edges, a
    /// round-off either side, and anywhere. It settles most aligned pairs (the wall's case).
    #[test]
    fn the_arc_verdict_is_the_tracked_one() {
        let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nROUND 0.1\nBLOCK 0,0 0,0.5 1,0.5 1,0\n\
                    BLOCK 3,0 4.2,0.7 3.9,1.9 2.7,2.6 1.5,1.9 1.8,0.7\nBLOCK 6,0 8,0 7,3\n\
                    BLOCK 2000.3,1000 2000.3,1000.5 2001.3,1000.5 2001.3,1000\nCYCLE 0\n";
        let model = run_deck_on(deck, Box::new(crate::udec::cpu::CpuBackend::new())).unwrap();
        let mut next = crate::udec::topology::xorshift(0x2545_F491_4F6C_DD1D);
        let mut unit = || next(1 << 53) as f64 / (1u64 << 53) as f64;
        let (mut settled, mut aligned, mut aligned_settled) = (0, 0, 0);
        for b in 0..model.blocks.len() {
            let corners = model.block_corners(b);
            let n = corners.len();
            for a in 0..n {
                let ca = corners[a].circle;
                let (n0, n1) = (edge_normal(corners, prev(a, n)), edge_normal(corners, a));
                let (a0, a1) = (n0[1].atan2(n0[0]), n1[1].atan2(n1[0]));
                let turn = (a1 - a0).rem_euclid(std::f64::consts::TAU);
                for i in 0..300 {
                    // Directions: along n0 or n1 exactly (aligned corners), a round-off or a
                    // little either side, or anywhere from before n0 to past n1.
                    let nudge = [0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6][i % 8];
                    let on_edge = i % 3 != 2;
                    let dir = if on_edge {
                        let base = if i % 2 == 0 { a0 } else { a1 };
                        let t = base + nudge;
                        [t.cos(), t.sin()]
                    } else {
                        let t = a0 - 0.4 + (turn + 0.8) * unit();
                        [t.cos(), t.sin()]
                    };
                    let rb = [0.1, 0.05, corners[a].radius, 0.3][i % 4];
                    // From no overlap to past the run's limit (half the rounding length).
                    let depth = [0.0, 1e-6, 1e-3, 0.02, 0.049, 0.2 * unit()][i % 6];
                    let rho = corners[a].radius + rb - depth;
                    let mut corner_b = corners[a];
                    corner_b.circle = [ca[0] + rho * dir[0], ca[1] + rho * dir[1]];
                    corner_b.radius = rb;
                    let band = PAIR_BAND * (corners[a].radius + rb);
                    let other = track_feature(corners, 2 * a as Feature, corner_b.circle, rb).gap;
                    let mut gaps = vec![other, other - 5.0 * band, other + 5.0 * band, -0.1 + 0.2 * unit()];
                    for s in [-1.0, 1.0] {
                        for t in [0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 1e-7, -1e-7] {
                            gaps.push(other + s * band + t);
                            gaps.push(other + s * band * (1.0 + t));
                        }
                        gaps.push(other + s * 1e-9);
                    }
                    for own_gap in gaps {
                        let tracked = tracked_verdict(own_gap, corners, a, &corner_b, band);
                        let quick = arc_view_verdict(own_gap, corners, a, &corner_b, band);
                        if let Some(v) = quick {
                            assert_eq!(v, tracked, "block {b} corner {a}: b at {:?} r {rb}, own gap {own_gap:e}, tracked gap {other:e}", corner_b.circle);
                            settled += 1;
                        }
                        if on_edge && nudge.abs() <= 1e-12 && depth < 0.01 && own_gap == other {
                            aligned += 1;
                            aligned_settled += quick.is_some() as usize;
                        }
                    }
                }
            }
        }
        assert!(settled > 10_000, "the arc verdict was exercised ({settled})");
        assert!(aligned_settled * 10 >= aligned * 9, "aligned corners of equal gaps are settled ({aligned_settled} of {aligned})");
    }
}
