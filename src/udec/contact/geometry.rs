//! The geometry of a rounded corner against a rounded block boundary (DESIGN.md §4): which
//! feature of block 2 a corner circle of block 1 touches, the gap between the two rounded
//! surfaces, the normal and the contact point. Topology (detection) and both backends' contact
//! stage use it; the GPU's twin is `shaders/udec/contact_forces.wgsl`, checked against it in
//! `tests/suite/gpu_kernels.rs`.
//!
//! A contact is a corner of block 1 (a circle of radius r about `circle`) against one *feature* of
//! block 2's rounded boundary: the arc of corner k (feature 2k) or the straight part of the edge
//! from corner k to k+1 (feature 2k+1). Because every convex corner is rounded, the normal turns
//! smoothly as a contact point slides round a corner (report ¶20), and "edge-to-edge" contact is
//! simply two corner–edge contacts, one at each end of the touching length.

use crate::udec::model::geometry::{dot, length, next, prev, sub};
use crate::udec::model::{ContactKind, Corner, Feature};

/// Where a corner circle meets a block boundary: the feature, the gap between the two rounded
/// surfaces (overlap negative), the unit normal from block 2 into block 1 and the contact point,
/// taken midway through the overlap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerContactGeometry {
    pub feature: Feature,
    pub kind: ContactKind,
    pub gap: f64,
    pub normal: [f64; 2],
    pub point: [f64; 2],
    /// Unsigned distance from the circle centre to the feature's curve (the selection key).
    pub distance: f64,
}

/// A straight edge of a block, from corner k to corner k+1: its start, unit direction and length.
#[derive(Clone, Copy, Debug)]
struct Edge {
    p0: [f64; 2],
    u: [f64; 2],
    len: f64,
}

impl Edge {
    /// Edge k as the geometry stage left it.
    #[inline]
    fn of(corners: &[Corner], k: usize) -> Edge {
        let c = &corners[k];
        Edge { p0: c.position, u: c.edge_dir, len: c.edge_length }
    }

    /// Outward normal for a counter-clockwise outline.
    #[inline]
    fn normal(&self) -> [f64; 2] {
        [self.u[1], -self.u[0]]
    }
}

/// A feature's measurement: signed distance from its surface, the unsigned distance that ranks
/// features, the outward direction *not yet normalised* (`dir / len` is the unit normal; the
/// division is left to the feature that wins, see [`Best::geometry`]), and whether `c` lies in the
/// feature's own region.
#[derive(Clone, Copy)]
struct Measure {
    signed: f64,
    unsigned: f64,
    dir: [f64; 2],
    len: f64,
    inside: bool,
}

impl Measure {
    #[inline]
    fn normal(&self) -> [f64; 2] {
        if self.len == 1.0 {
            self.dir
        } else {
            [self.dir[0] / self.len, self.dir[1] / self.len]
        }
    }
}

/// Straight part of edge k (between the tangent points of corners k and k+1). Its region is the
/// slab over it; outside, it is measured from its nearer end.
#[inline]
fn edge_distance(corners: &[Corner], k: usize, e: &Edge, c: [f64; 2]) -> Measure {
    edge_measure(corners, k, e, c).0
}

/// [`edge_distance`], with the coordinate `s` of `c` along the straight part (from its start) and
/// that part's length, which the fast path of [`track_feature`] tests.
#[inline]
fn edge_measure(corners: &[Corner], k: usize, e: &Edge, c: [f64; 2]) -> (Measure, f64, f64) {
    let n = corners.len();
    let normal = e.normal();
    let r0 = corners[k].round;
    let ta = [e.p0[0] + e.u[0] * r0, e.p0[1] + e.u[1] * r0];
    let straight = e.len - r0 - corners[next(k, n)].round;
    let rel = sub(c, ta);
    let s = dot(rel, e.u);
    let m = if s >= 0.0 && s <= straight {
        let d = dot(rel, normal);
        Measure { signed: d, unsigned: d.abs(), dir: normal, len: 1.0, inside: true }
    } else {
        let s = s.clamp(0.0, straight.max(0.0));
        let r = sub(c, [ta[0] + e.u[0] * s, ta[1] + e.u[1] * s]);
        let d = length(r);
        if d > 0.0 {
            Measure { signed: d, unsigned: d, dir: r, len: d, inside: false }
        } else {
            Measure { signed: d, unsigned: d, dir: normal, len: 1.0, inside: false }
        }
    };
    (m, s, straight)
}

/// Arc of corner k, between the edges `before` (k−1 → k) and `after` (k → k+1). Its region is the
/// wedge between their outward normals; outside, it is measured from its nearer tangent point.
/// The wedge test is a pair of cross products, which do not care about the length of `c −
/// circle`, so only the distance that ranks the arc takes a square root.
#[inline]
fn arc_distance(corner: &Corner, before: &Edge, after: &Edge, c: [f64; 2]) -> Measure {
    let (n0, n1) = (before.normal(), after.normal());
    let r = sub(c, corner.circle);
    // Inside the wedge turning counter-clockwise from n0 to n1 (less than π for a convex corner).
    let convex = n0[0] * n1[1] - n0[1] * n1[0] > 0.0;
    if convex && (n0[0] * r[1] - n0[1] * r[0]) >= 0.0 && (r[0] * n1[1] - r[1] * n1[0]) >= 0.0 {
        let dist_c = length(r);
        let d = dist_c - corner.radius;
        return if dist_c > 0.0 {
            Measure { signed: d, unsigned: d.abs(), dir: r, len: dist_c, inside: true }
        } else {
            // The centres coincide: any direction in the wedge will do.
            Measure { signed: d, unsigned: d.abs(), dir: [n0[0] + n1[0], n0[1] + n1[1]], len: 1.0, inside: true }
        };
    }
    let t0 = [corner.circle[0] + n0[0] * corner.radius, corner.circle[1] + n0[1] * corner.radius];
    let t1 = [corner.circle[0] + n1[0] * corner.radius, corner.circle[1] + n1[1] * corner.radius];
    let (r0, r1) = (sub(c, t0), sub(c, t1));
    // The nearer tangent point, by squared distance: one square root instead of two.
    let (rr, fallback) = if dot(r0, r0) <= dot(r1, r1) { (r0, n0) } else { (r1, n1) };
    let d = length(rr);
    if d > 0.0 {
        Measure { signed: d, unsigned: d, dir: rr, len: d, inside: false }
    } else {
        Measure { signed: d, unsigned: d, dir: fallback, len: 1.0, inside: false }
    }
}

/// The outward unit normal of edge k (from corner k to k+1) of a counter-clockwise outline, as
/// the geometry stage left its direction: the normal every feature measurement here uses.
#[inline]
pub fn edge_normal(corners: &[Corner], k: usize) -> [f64; 2] {
    Edge::of(corners, k).normal()
}

/// Measures feature f with the edges supplied by `edge(k)`.
#[inline]
fn feature_distance(corners: &[Corner], f: Feature, c: [f64; 2], edge: impl Fn(usize) -> Edge) -> Measure {
    let n = corners.len();
    let k = (f / 2) as usize;
    if f % 2 == 1 {
        edge_distance(corners, k, &edge(k), c)
    } else {
        arc_distance(&corners[k], &edge(prev(k, n)), &edge(k), c)
    }
}

/// The distance by which `track_feature` ranks feature `feature` of the outline `corners` for the
/// circle centre `c` (for checks that two features tie).
pub fn distance_to_feature(corners: &[Corner], feature: Feature, c: [f64; 2]) -> f64 {
    feature_distance(corners, feature, c, |k| Edge::of(corners, k)).unsigned
}

/// Builds the contact geometry from a feature's measurement.
#[inline]
fn geometry_from(f: Feature, signed: f64, unsigned: f64, normal: [f64; 2], c: [f64; 2], r: f64) -> CornerContactGeometry {
    let gap = signed - r;
    // Midway between block 1's surface point (c − n r) and block 2's (c − n (r + gap)).
    let depth = r + 0.5 * gap;
    CornerContactGeometry {
        feature: f,
        kind: if f % 2 == 0 { ContactKind::CornerCorner } else { ContactKind::CornerEdge },
        gap,
        normal,
        point: [c[0] - normal[0] * depth, c[1] - normal[1] * depth],
        distance: unsigned,
    }
}

/// Ranks two candidate features: nearer wins; on a tie (within round-off) an arc wins, so two
/// aligned corners (a column of equal blocks) meet as one corner–corner contact.
#[inline]
fn better(candidate: (f64, bool, Feature), best: (f64, bool, Feature)) -> bool {
    let tol = 1e-9 * (1.0 + best.0.abs());
    if candidate.0 < best.0 - tol {
        return true;
    }
    if candidate.0 <= best.0 + tol {
        // Prefer a feature whose own region holds the centre, then an arc.
        if candidate.1 != best.1 {
            return candidate.1;
        }
        return candidate.2 % 2 == 0 && best.2 % 2 == 1;
    }
    false
}

/// Keeps the best-ranked feature seen so far.
#[derive(Default)]
struct Best(Option<((f64, bool, Feature), Measure)>);

impl Best {
    #[inline]
    fn offer(&mut self, f: Feature, m: Measure) {
        let key = (m.unsigned, m.inside, f);
        if self.0.is_none_or(|(b, _)| better(key, b)) {
            self.0 = Some((key, m));
        }
    }

    #[inline]
    fn geometry(self, c: [f64; 2], r: f64) -> CornerContactGeometry {
        let ((_, _, f), m) = self.0.expect("at least one feature offered");
        geometry_from(f, m.signed, m.unsigned, m.normal(), c, r)
    }
}

/// Full search: the nearest feature of the whole boundary of a block (topology stage).
pub fn nearest_feature(corners: &[Corner], c: [f64; 2], r: f64) -> CornerContactGeometry {
    let mut best = Best::default();
    for f in 0..2 * corners.len() as Feature {
        best.offer(f, feature_distance(corners, f, c, |k| Edge::of(corners, k)));
    }
    best.geometry(c, r)
}

/// Local search: the nearest of `feature` and its two neighbours, the per-cycle update of a
/// contact whose point slides along the boundary (stage 4). A contact point moves far less than a
/// feature's length in one step, so it can only pass onto a neighbouring feature.
#[inline]
pub fn track_feature(corners: &[Corner], feature: Feature, c: [f64; 2], r: f64) -> CornerContactGeometry {
    let nf = 2 * corners.len() as Feature;
    let edge = |j: usize| Edge::of(corners, j);
    let feature = feature.min(nf - 1);
    let f = feature as usize;
    let n = corners.len();
    let k = f / 2;
    // The contact's own feature is measured first; where no fast path below settles the contact,
    // the three-way comparison reuses this measurement.
    let own = if f % 2 == 1 {
        // Fast path, most contacts on most cycles: a corner circle over the straight part of an
        // edge between two convex corners. Its centre lies strictly inside the edge's slab and
        // outside the line, so it is outside both neighbouring arcs' wedges, and the nearer
        // tangent point of each arc is the one on this edge: their distances are √(s² + d²) ≥ d,
        // and an inside feature wins every tie with an outside one. The full three-way comparison
        // would pick this edge, so skip it (same result bit for bit; checked by
        // `track_feature_fast_path_agrees` in the unit tests).
        let e = edge(k);
        let (m, s, straight) = edge_measure(corners, k, &e, c);
        if m.inside && m.signed > 0.0 {
            let cross = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
            let turns_left = |a: &Edge, b: &Edge| cross(a.normal(), b.normal()) > 0.0;
            // Clear of the slab's ends by more than round-off, which could otherwise put the
            // centre in an arc's wedge too (aligned corners, where the full comparison prefers
            // the arc).
            let margin = 1e-6 * e.len + 1e-12 * (c[0].abs() + c[1].abs());
            if s > margin && s < straight - margin && turns_left(&edge(prev(k, n)), &e) && turns_left(&e, &edge(next(k, n))) {
                return geometry_from(feature, m.signed, m.unsigned, m.normal(), c, r);
            }
        }
        m
    } else {
        // Fast path for a corner circle over the arc of a convex corner k (corner–corner
        // touches): strictly inside the arc's wedge, the centre is outside both neighbouring
        // edges' slabs, so each edge is measured from its tangent point T on this arc, and
        // |c − T| ≥ |c − C| − r (the triangle inequality about the arc's centre C): the arc is
        // nearest, or ties and wins as the inside feature. The wedge tests equal minus the slab
        // coordinates, hence the same margin.
        let (before, after) = (edge(prev(k, n)), edge(k));
        let m = arc_distance(&corners[k], &before, &after, c);
        if m.inside && m.signed > 0.0 {
            let (n0, n1) = (before.normal(), after.normal());
            let rel = sub(c, corners[k].circle);
            let margin = 1e-6 * (before.len + after.len) + 1e-12 * (c[0].abs() + c[1].abs());
            if n0[0] * rel[1] - n0[1] * rel[0] > margin && rel[0] * n1[1] - rel[1] * n1[0] > margin {
                return geometry_from(feature, m.signed, m.unsigned, m.normal(), c, r);
            }
        }
        m
    };
    three_way(corners, feature, own, c, r)
}

/// [`track_feature`] without its fast path: the three-way comparison.
#[inline]
pub fn track_feature_full(corners: &[Corner], feature: Feature, c: [f64; 2], r: f64) -> CornerContactGeometry {
    let nf = 2 * corners.len() as Feature;
    let feature = feature.min(nf - 1);
    let own = feature_distance(corners, feature, c, |k| Edge::of(corners, k));
    three_way(corners, feature, own, c, r)
}

/// The nearest of `feature` (already measured: `own`) and its two neighbours, offered in the
/// order previous, own, next (the order decides exact ties). The neighbours of an edge are the
/// arcs at its two ends, those of an arc the edges on either side of it: each is measured
/// directly, with the edges loaded once.
#[inline]
fn three_way(corners: &[Corner], feature: Feature, own: Measure, c: [f64; 2], r: f64) -> CornerContactGeometry {
    let n = corners.len();
    let (nf, f) = (2 * n, feature as usize);
    let (before, after) = (prev(f, nf) as Feature, next(f, nf) as Feature);
    let k = f / 2;
    let mut best = Best::default();
    if f % 2 == 1 {
        // Edge k: the arcs of corners k and k+1.
        let (j, kn) = (prev(k, n), next(k, n));
        let (ej, ek, en) = (Edge::of(corners, j), Edge::of(corners, k), Edge::of(corners, kn));
        best.offer(before, arc_distance(&corners[k], &ej, &ek, c));
        best.offer(feature, own);
        best.offer(after, arc_distance(&corners[kn], &ek, &en, c));
    } else {
        // Arc k: the edges k−1 and k.
        let j = prev(k, n);
        best.offer(before, edge_distance(corners, j, &Edge::of(corners, j), c));
        best.offer(feature, own);
        best.offer(after, edge_distance(corners, k, &Edge::of(corners, k), c));
    }
    best.geometry(c, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::run_deck_on;

    /// The fast path of `track_feature` gives what the three-way comparison gives, bit for bit:
    /// on rectangles, a rotated hexagon and a triangle, with circle centres spread over and
    /// beyond every edge, including the aligned-corner ties of a brick wall (centres exactly over
    /// a slab's end).
    #[test]
    fn track_feature_fast_path_agrees() {
        let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nROUND 0.1\nBLOCK 0,0 0,0.5 1,0.5 1,0\n\
                    BLOCK 3,0 4.2,0.7 3.9,1.9 2.7,2.6 1.5,1.9 1.8,0.7\nBLOCK 6,0 8,0 7,3\nBLOCK 20,20 20,20.5 20.5,20.5 20.5,20\nCYCLE 0\n";
        let model = run_deck_on(deck, Box::new(crate::udec::cpu::CpuBackend::new())).unwrap();
        let mut next = crate::udec::topology::xorshift(0x9E37_79B9_7F4A_7C15);
        let mut unit = || next(1 << 53) as f64 / (1u64 << 53) as f64;
        let mut fast_taken = 0;
        for b in 0..model.blocks.len() {
            let corners = model.block_corners(b);
            let n = corners.len();
            for k in 0..n {
                let e = Edge::of(corners, k);
                let nrm = e.normal();
                for i in 0..400 {
                    // Along the edge from before its start to past its end; exactly at the
                    // tangent points every 10th sample.
                    let t = if i % 10 == 0 { [corners[k].round, e.len - corners[(k + 1) % n].round][i / 10 % 2] } else { -0.2 + 1.4 * unit() * e.len };
                    let h = 0.05 + 0.15 * unit();
                    let c = [e.p0[0] + e.u[0] * t + nrm[0] * h, e.p0[1] + e.u[1] * t + nrm[1] * h];
                    let r = 0.1;
                    let feature = (2 * k + 1) as Feature;
                    let fast = track_feature(corners, feature, c, r);
                    let full = track_feature_full(corners, feature, c, r);
                    assert_eq!(fast, full, "block {b} edge {k} at t={t} h={h}");
                    if fast.feature == feature {
                        fast_taken += 1;
                    }
                }
            }
        }
        // Around every corner: the arc's wedge, its boundaries and both neighbouring slabs.
        let mut arcs_taken = 0;
        for b in 0..model.blocks.len() {
            let corners = model.block_corners(b);
            let n = corners.len();
            for k in 0..n {
                let (n0, n1) = (Edge::of(corners, (k + n - 1) % n).normal(), Edge::of(corners, k).normal());
                let (a0, a1) = (n0[1].atan2(n0[0]), n1[1].atan2(n1[0]));
                let mut turn = a1 - a0;
                if turn < 0.0 {
                    turn += std::f64::consts::TAU;
                }
                for i in 0..400 {
                    // Angles from before n0 to past n1; exactly along n0 or n1 every 10th sample.
                    let a = if i % 10 == 0 { [a0, a0 + turn][i / 10 % 2] } else { a0 - 0.3 + (turn + 0.6) * unit() };
                    let rho = corners[k].radius + 0.05 + 0.15 * unit();
                    let c = [corners[k].circle[0] + rho * a.cos(), corners[k].circle[1] + rho * a.sin()];
                    let feature = (2 * k) as Feature;
                    let fast = track_feature(corners, feature, c, 0.1);
                    let full = track_feature_full(corners, feature, c, 0.1);
                    assert_eq!(fast, full, "block {b} arc {k} at angle {a} radius {rho}");
                    if fast.feature == feature {
                        arcs_taken += 1;
                    }
                }
            }
        }
        assert!(fast_taken > 1000 && arcs_taken > 1000, "the fast paths were exercised ({fast_taken} edge, {arcs_taken} arc results)");
    }
}
