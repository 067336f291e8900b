//! Polygon geometry for 2D blocks: mass properties, simplicity and containment tests, intersection
//! helpers, and UDEC's rounded corners (ROUND d; SL-85-1 Appendix A, "General splitting logic" ¶13
//! and the ROUND command).
//!
//! Everything here is a pure function on `[f64; 2]` points. Polygons are vertex lists without a
//! repeated closing vertex; edge `i` runs from vertex `i` to vertex `i + 1 (mod n)`.

/// Angle (radians) below which a convex corner's turn is treated as no turn at all; see
/// [`corner_rounding`].
pub const STRAIGHT_TURN: f64 = std::f64::consts::PI / 180.0;

#[inline]
pub fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline]
pub fn add(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

#[inline]
pub fn scale(a: [f64; 2], s: f64) -> [f64; 2] {
    [a[0] * s, a[1] * s]
}

#[inline]
pub fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// z-component of the 2D cross product a × b.
#[inline]
pub fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[inline]
pub fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

/// The length of `a` as √(a·a): one rounding fewer than [`norm`]'s `hypot`, for the contact
/// geometry of the cycle, whose distances are far from overflow (glam's `DVec2::length`).
#[inline]
pub fn length(a: [f64; 2]) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|` ([`norm`]), or `None` for a zero or non-finite vector.
#[inline]
pub fn unit(a: [f64; 2]) -> Option<[f64; 2]> {
    let l = norm(a);
    (l > 0.0 && l.is_finite()).then(|| scale(a, 1.0 / l))
}

/// The index after `i` around a polygon of `n` corners (no integer division in the hot loop).
#[inline]
pub fn next(i: usize, n: usize) -> usize {
    if i + 1 == n {
        0
    } else {
        i + 1
    }
}

/// The index before `i` around a polygon of `n` corners.
#[inline]
pub fn prev(i: usize, n: usize) -> usize {
    if i == 0 {
        n - 1
    } else {
        i - 1
    }
}

#[inline]
pub fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    norm(sub(a, b))
}

/// Twice the signed area of triangle (a, b, c): positive when a → b → c turns counter-clockwise.
#[inline]
pub fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    cross(sub(b, a), sub(c, a))
}

/// `v` rotated counter-clockwise by `angle` radians.
#[inline]
pub fn rotate(v: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, c) = angle.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

/// Area, centroid and polar second moment of area of a polygon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolygonProps {
    /// Signed area: positive when the vertices run counter-clockwise.
    pub area: f64,
    pub centroid: [f64; 2],
    /// ∫ r² dA about the centroid, always ≥ 0 whatever the orientation (block inertia is
    /// density × polar_moment).
    pub polar_moment: f64,
}

/// Signed area (shoelace formula), positive for a counter-clockwise polygon. Computed relative to
/// the first vertex so that polygons far from the origin keep their precision.
pub fn signed_area(pts: &[[f64; 2]]) -> f64 {
    if pts.len() < 3 {
        return 0.0;
    }
    let o = pts[0];
    let mut twice = 0.0;
    for w in pts[1..].windows(2) {
        twice += cross(sub(w[0], o), sub(w[1], o));
    }
    0.5 * twice
}

/// Area, centroid and polar moment by the shoelace formulas (Green's theorem over the edges).
///
/// With edge vectors taken from the first vertex o (a_i = p_i − o), each edge contributes
/// c_i = a_i × a_{i+1} and
///   A   = Σ c_i / 2,
///   S_x = Σ (x_i + x_{i+1}) c_i / 6            (first moments → centroid = S / A),
///   I_o = Σ (x_i² + x_i x_{i+1} + x_{i+1}² + y_i² + y_i y_{i+1} + y_{i+1}²) c_i / 12,
/// and the parallel-axis theorem moves I_o to the centroid: J = I_o − A |c − o|².
/// A degenerate polygon (zero area) gets its vertex mean as centroid and J = 0.
pub fn polygon_properties(pts: &[[f64; 2]]) -> PolygonProps {
    let n = pts.len();
    if n == 0 {
        return PolygonProps { area: 0.0, centroid: [0.0, 0.0], polar_moment: 0.0 };
    }
    let o = pts[0];
    let (mut a2, mut sx, mut sy, mut io) = (0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let p = sub(pts[i], o);
        let q = sub(pts[(i + 1) % n], o);
        let c = cross(p, q);
        a2 += c;
        sx += (p[0] + q[0]) * c;
        sy += (p[1] + q[1]) * c;
        io += (p[0] * p[0] + p[0] * q[0] + q[0] * q[0] + p[1] * p[1] + p[1] * q[1] + q[1] * q[1]) * c;
    }
    let area = 0.5 * a2;
    if area == 0.0 || !area.is_finite() {
        let mean = pts.iter().fold([0.0, 0.0], |s, p| add(s, sub(*p, o)));
        return PolygonProps { area, centroid: add(o, scale(mean, 1.0 / n as f64)), polar_moment: 0.0 };
    }
    let c = [sx / (6.0 * area), sy / (6.0 * area)];
    let j = io / 12.0 - area * dot(c, c);
    PolygonProps { area, centroid: add(o, c), polar_moment: j.abs() }
}

/// The point of the closed segment a–b nearest to `p` (`a` itself for a segment of no length).
#[inline]
pub fn closest_point_on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 { (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    add(a, scale(ab, t))
}

/// Distance from point `p` to the closed segment a–b.
pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    distance(p, closest_point_on_segment(p, a, b))
}

/// Distance from `p` to the nearest point of the polygon's boundary.
pub fn boundary_distance(p: [f64; 2], pts: &[[f64; 2]]) -> f64 {
    let n = pts.len();
    (0..n).map(|i| point_segment_distance(p, pts[i], pts[(i + 1) % n])).fold(f64::INFINITY, f64::min)
}

/// Whether `q` lies on the closed segment a–b, given that a, b, q are collinear.
fn on_collinear_segment(a: [f64; 2], b: [f64; 2], q: [f64; 2]) -> bool {
    q[0] >= a[0].min(b[0]) && q[0] <= a[0].max(b[0]) && q[1] >= a[1].min(b[1]) && q[1] <= a[1].max(b[1])
}

/// Whether the closed segments p1–p2 and q1–q2 share at least one point (touching counts).
pub fn segments_intersect(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> bool {
    let d1 = orient(q1, q2, p1);
    let d2 = orient(q1, q2, p2);
    let d3 = orient(p1, p2, q1);
    let d4 = orient(p1, p2, q2);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    (d1 == 0.0 && on_collinear_segment(q1, q2, p1))
        || (d2 == 0.0 && on_collinear_segment(q1, q2, p2))
        || (d3 == 0.0 && on_collinear_segment(p1, p2, q1))
        || (d4 == 0.0 && on_collinear_segment(p1, p2, q2))
}

/// The point where segments p1–p2 and q1–q2 cross, with parameters (s, t) along each
/// (point = p1 + s (p2 − p1) = q1 + t (q2 − q1)), or None when they do not meet or are parallel.
pub fn segment_intersection(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> Option<([f64; 2], f64, f64)> {
    let r = sub(p2, p1);
    let d = sub(q2, q1);
    let den = cross(r, d);
    if den == 0.0 {
        return None;
    }
    let w = sub(q1, p1);
    let s = cross(w, d) / den;
    let t = cross(w, r) / den;
    ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t)).then(|| (add(p1, scale(r, s)), s, t))
}

/// Where the infinite line through a, b crosses the segment c–d: the parameter t along c–d
/// (point = c + t (d − c), 0 ≤ t ≤ 1) and the parameter s along the line (point = a + s (b − a)).
/// None when the segment misses the line or is parallel to it.
pub fn line_segment_intersection(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> Option<(f64, f64)> {
    let sc = orient(a, b, c);
    let sd = orient(a, b, d);
    if sc == sd || (sc > 0.0 && sd > 0.0) || (sc < 0.0 && sd < 0.0) {
        return None;
    }
    let t = sc / (sc - sd);
    let p = add(c, scale(sub(d, c), t));
    let ab = sub(b, a);
    let s = dot(sub(p, a), ab) / dot(ab, ab);
    Some((t, s))
}

/// Whether the closed polygon is simple: at least three finite vertices, no zero-length edge, no
/// edge folding back onto its neighbour, and no two non-adjacent edges touching or crossing.
/// O(n²), which is fine for block outlines.
pub fn is_simple_polygon(pts: &[[f64; 2]]) -> bool {
    let n = pts.len();
    if n < 3 || pts.iter().any(|p| !p[0].is_finite() || !p[1].is_finite()) {
        return false;
    }
    for i in 0..n {
        let a = pts[i];
        let b = pts[(i + 1) % n];
        let c = pts[(i + 2) % n];
        if a == b {
            return false;
        }
        // Adjacent edges a→b and b→c overlap when they are collinear and point back.
        let e1 = sub(b, a);
        let e2 = sub(c, b);
        if cross(e1, e2).abs() <= 1e-14 * norm(e1) * norm(e2) && dot(e1, e2) < 0.0 {
            return false;
        }
    }
    for i in 0..n {
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue; // edges n−1 and 0 share vertex 0
            }
            if segments_intersect(pts[i], pts[(i + 1) % n], pts[j], pts[(j + 1) % n]) {
                return false;
            }
        }
    }
    true
}

/// Whether `p` lies inside the polygon (either orientation), by the crossing-number rule. Points
/// exactly on the boundary may go either way; use [`boundary_distance`] where that matters.
pub fn point_in_polygon(p: [f64; 2], pts: &[[f64; 2]]) -> bool {
    let n = pts.len();
    let mut inside = false;
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let (a, b) = (pts[i], pts[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Rounding of one corner (UDEC's KXCP, KYCP, KRAD and the tangent distance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerRound {
    /// Centre of the rounding circle (same frame as the input points).
    pub circle: [f64; 2],
    pub radius: f64,
    /// Distance from the corner to the arc's tangent points along both edges.
    pub round: f64,
}

/// Rounded corners of a counter-clockwise polygon for rounding length `d` (the ROUND command).
///
/// Each convex corner is replaced by a circular arc tangent to both adjoining edges at distance
/// `round` = min(d, ½ prev edge, ½ next edge) from the corner, so that two arcs never overlap on a
/// short edge, and shorter still where that circle would leave the block (below). For interior angle α the circle centre lies on the bisector at round / cos(α/2) from
/// the corner and the radius is round · tan(α/2). In terms of the turn θ = π − α of the boundary at
/// the corner: distance = round / sin(θ/2), radius = round / tan(θ/2).
///
/// A re-entrant corner (α ≥ 180°) needs no rounding: radius 0, round 0, circle at the corner.
///
/// Nearly straight corners (θ < [`STRAIGHT_TURN`] = 1°) are treated like re-entrant ones. The exact
/// arc would have a radius growing as 1/θ with its centre just as far away, which costs f32 kernels
/// their precision and gives the contact logic a circle it cannot tell from an edge. Dropping the
/// arc keeps both edges exactly as they are (tangency is trivially kept, the arc collapses to the
/// corner point) and changes the boundary by at most the arc's sag, round · tan(θ/4) < 0.005 d,
/// far below the contact tolerance ATOL = d. Contact logic must already handle radius-0 corners
/// for re-entrant corners, so this adds no new case.
///
/// The circle must also lie inside its own block. Contact detection measures a corner by its
/// circle alone (gap = distance from the centre to the other block's boundary − radius; two corners
/// whose circles overlap are a corner pair to `counts_force`), so a circle reaching through the
/// block's far side "touches" whatever lies beyond it: a 162° corner rounded at d = 0.1 has radius
/// 0.1 · tan 81° ≈ 0.63, which crosses a strip 1 m wide and made a SPLIT's pieces overlap their
/// neighbours before any motion. Where the circle of `round` would cross another edge, `round` is
/// lowered to the largest length whose circle stays inside (`fit_inside`); the arc then only sits
/// closer to the corner. Blocks whose circles already fit (any rectangle, where round ≤ ½ edge) are
/// rounded exactly as before.
pub fn corner_rounding(pts_ccw: &[[f64; 2]], d: f64) -> Vec<CornerRound> {
    let n = pts_ccw.len();
    (0..n)
        .map(|i| {
            let p = pts_ccw[i];
            let a = pts_ccw[(i + n - 1) % n];
            let b = pts_ccw[(i + 1) % n];
            let sharp = CornerRound { circle: p, radius: 0.0, round: 0.0 };
            let (e1, e2) = (sub(p, a), sub(b, p));
            let (l1, l2) = (norm(e1), norm(e2));
            if l1 == 0.0 || l2 == 0.0 || d <= 0.0 {
                return sharp;
            }
            let turn = cross(e1, e2).atan2(dot(e1, e2));
            if turn < STRAIGHT_TURN {
                return sharp;
            }
            let half = 0.5 * turn;
            // Inward bisector: the sum of the unit vectors from the corner along both edges.
            let bis = add(scale(e1, -1.0 / l1), scale(e2, 1.0 / l2));
            let bis = scale(bis, 1.0 / norm(bis));
            let round = fit_inside(pts_ccw, i, scale(bis, 1.0 / half.sin()), 1.0 / half.tan(), d.min(0.5 * l1).min(0.5 * l2));
            CornerRound { circle: add(p, scale(bis, round / half.sin())), radius: round / half.tan(), round }
        })
        .collect()
}

/// Relative shortfall below which a rounding length is kept as it is: a circle that reaches past
/// an edge by round-off only (the opposite side of a strip exactly 2·round wide) is not a
/// circle that crosses it, and keeping its rounding leaves such blocks bit-identical.
const FIT_SLACK: f64 = 1e-9;

/// The rounding length, at most `round`, of corner `i` for which its circle lies inside the
/// polygon (touching an edge at most). For rounding length t the circle has centre p + t·v and
/// radius t·ρ (v = bisector / sin(θ/2), ρ = 1 / tan(θ/2); |v|² − ρ² = 1): the circles are the
/// images of one circle under scalings about the corner p, and together they sweep the hull of p
/// and the largest one, so a circle crosses no edge as long as none of the smaller ones has
/// touched one (the polygon being simple). The corner's own two edges are tangent to every such circle (and the tangent
/// points stay on them, round ≤ ½ edge); any other edge is measured as a segment, which is exact
/// for re-entrant blocks too, where a supporting line would cut through the block. The result is
/// the earliest touch of any other edge when it comes before `round` (by more than
/// [`FIT_SLACK`]), `round` otherwise.
fn fit_inside(pts: &[[f64; 2]], i: usize, v: [f64; 2], rho: f64, round: f64) -> f64 {
    let n = pts.len();
    let p = pts[i];
    let touch = (0..n).filter(|&j| j != i && j != (i + n - 1) % n).map(|j| first_touch(p, v, rho, pts[j], pts[(j + 1) % n])).fold(f64::INFINITY, f64::min);
    if touch < round * (1.0 - FIT_SLACK) {
        touch
    } else {
        round
    }
}

/// The least t > 0 at which the circle of centre p + t·v and radius t·ρ (|v|² − ρ² = 1) touches
/// the segment q0 q1; infinity when it never does. The first touch is either at an end q, where
/// |p + t v − q| = t ρ, i.e. t² − 2 t (q − p)·v + |q − p|² = 0 (the smaller root), or inside the
/// segment, where the circle is tangent to its line, s0 + t (v·n) = ±t ρ for the signed distance
/// s0 of p (n the unit normal), with the centre's foot on the segment. Every candidate is a real
/// touch and the first touch is among them, so their least is it.
fn first_touch(p: [f64; 2], v: [f64; 2], rho: f64, q0: [f64; 2], q1: [f64; 2]) -> f64 {
    let mut t = f64::INFINITY;
    for q in [q0, q1] {
        let w = sub(q, p);
        let (g, w2) = (dot(w, v), dot(w, w));
        if g > 0.0 && g * g >= w2 {
            // g − √(g² − |w|²), in the form that does not cancel.
            t = t.min(w2 / (g + (g * g - w2).sqrt()));
        }
    }
    let e = sub(q1, q0);
    let len = norm(e);
    if len == 0.0 {
        return t;
    }
    let normal = [-e[1] / len, e[0] / len];
    let (s0, vn) = (dot(sub(p, q0), normal), dot(v, normal));
    for tangent in [s0 / (rho - vn), -s0 / (rho + vn)] {
        if tangent > 0.0 && tangent < t {
            let along = dot(sub(add(p, scale(v, tangent)), q0), e) / len;
            if (0.0..=len).contains(&along) {
                t = tangent;
            }
        }
    }
    t
}
