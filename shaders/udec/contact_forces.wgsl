// Stage 4: contact kinematics and the force–displacement law (SL-85-1 eqs. 13–20), and the
// geometry of a rounded corner against the rounded boundary of the other block. Twin of
// src/cpu/contact_forces.rs (`edge_distance`, `arc_distance`, `track_feature`, `contact_force_law`,
// `slip_dissipation`, `counts_force`). Geometry is relative to block 2's centroid. Besides the
// contact itself, each invocation writes the compact record the gather sums (`ContactForce`).
//
// Feature 2k is the arc of corner k, feature 2k+1 the straight part of edge k → k+1.

struct FeatureDistance {
    signed_distance: real,
    distance: real,
    normal: vec2<real>,
    inside: bool,
}

struct ContactGeometry {
    feature: u32,
    gap: real,
    normal: vec2<real>,
    point: vec2<real>,
    distance: real,
}

struct Motion {
    centroid: vec2<real>,
    velocity: vec2<real>,
    w: real,
}

// Edge k (corner k → k+1): start, unit direction, length (`edge_from`).
struct Edge {
    p0: vec2<real>,
    u: vec2<real>,
    len: real,
}

// A corner of block 2 as this stage reads it: its position, its rounding length along its
// edges, and its rounding circle (centre, radius).
struct CornerView {
    p: vec2<real>,
    round: real,
    circle: vec2<real>,
    radius: real,
}

// The corners around a tracked feature f of block 2 (j = f/2): j−1, j and j+1, with their indices,
// and the edges j−1, j, j+1 between them (the last one's end is corner j+2, of which only the
// position is read). Everything that tracking the feature and deciding which view of a touch
// counts reads of block 2, each field loaded once: a software adapter (lavapipe) loads from a
// storage buffer a lane at a time, so each load written in the kernel costs on every contact, and
// loads of a read_write buffer are not merged by its compiler.
struct Neighbourhood {
    feature: u32,
    start: u32,
    jm: u32,
    j: u32,
    jp: u32,
    m: CornerView,
    c: CornerView,
    p: CornerView,
    edge_m: Edge,
    edge_j: Edge,
    edge_p: Edge,
}

fn corner_view(i: u32) -> CornerView {
    let c = corners[i];
    return CornerView(vec2<real>(c.px, c.py), c.round, vec2<real>(c.ox, c.oy), c.radius);
}

// The edge from corner position a to the next corner's, b: the geometry stage's twin measures
// it so on the CPU (unit direction, length), here it is measured where it is used.
fn edge_from(a: vec2<real>, b: vec2<real>) -> Edge {
    let e = b - a;
    let len = sqrt(e.x * e.x + e.y * e.y);
    return Edge(a, vec2<real>(e.x / len, e.y / len), len);
}

// The neighbourhood of `feature` (clamped to the block's features) of the block whose corners
// are corners[start .. start+n] (counter-clockwise).
fn neighbourhood(start: u32, n: u32, feature: u32) -> Neighbourhood {
    let f = min(feature, 2u * n - 1u);
    let j = f / 2u;
    let jm = prev_index(j, n);
    let jp = next_index(j, n);
    let m = corner_view(start + jm);
    let c = corner_view(start + j);
    let p = corner_view(start + jp);
    let i_after = start + next_index(jp, n);
    let after = vec2<real>(corners[i_after].px, corners[i_after].py);
    return Neighbourhood(f, start, jm, j, jp, m, c, p, edge_from(m.p, c.p), edge_from(c.p, p.p), edge_from(p.p, after));
}

// Outward normal for a counter-clockwise outline.
fn edge_normal(e: Edge) -> vec2<real> {
    return vec2<real>(e.u.y, -e.u.x);
}

fn next_index(i: u32, n: u32) -> u32 {
    return select(i + 1u, 0u, i + 1u == n);
}

fn prev_index(i: u32, n: u32) -> u32 {
    return select(i - 1u, n - 1u, i == 0u);
}

// Straight part of edge e, between the tangent points of its corners' roundings (r0 at its start,
// r1 at its end). Its region is the slab over it; outside, it is measured from its nearer end.
fn edge_distance(e: Edge, r0: real, r1: real, c: vec2<real>) -> FeatureDistance {
    let normal = edge_normal(e);
    let ta = e.p0 + e.u * r0;
    let straight = e.len - r0 - r1;
    let rel = c - ta;
    let s = dot(rel, e.u);
    // The region test tolerates round-off (REGION_TOL, see the prelude): at aligned corners the
    // centre lies exactly on the slab's border, where exact arithmetic says "inside". Scaled by
    // the rounding length, like the wedge test below (unit vectors from a circle centre).
    let eps = REGION_TOL * r0;
    if (s >= -eps && s <= straight + eps) {
        let d = dot(rel, normal);
        return FeatureDistance(d, abs(d), normal, true);
    }
    let sc = min(max(s, 0.0), max(straight, 0.0));
    let r = c - (ta + e.u * sc);
    let d = sqrt(dot(r, r));
    var nrm = normal;
    if (d > 0.0) {
        nrm = r / d;
    }
    return FeatureDistance(d, d, nrm, false);
}

// Arc of a corner (its rounding circle: centre, radius) between the edges `before` (k−1 → k) and
// `after` (k → k+1). Its region is the wedge between their outward normals; outside, it is
// measured from its nearer tangent point.
fn arc_distance(circle: vec2<real>, radius: real, before: Edge, after: Edge, c: vec2<real>) -> FeatureDistance {
    let n0 = edge_normal(before);
    let n1 = edge_normal(after);
    let r = c - circle;
    let dist_c = sqrt(dot(r, r));
    var dir = n0 + n1;
    if (dist_c > 0.0) {
        dir = r / dist_c;
    }
    // Inside the wedge turning counter-clockwise from n0 to n1 (less than π for a convex corner).
    let convex = n0.x * n1.y - n0.y * n1.x > 0.0;
    if (convex && (n0.x * dir.y - n0.y * dir.x) >= -REGION_TOL && (dir.x * n1.y - dir.y * n1.x) >= -REGION_TOL) {
        let d = dist_c - radius;
        return FeatureDistance(d, abs(d), dir, true);
    }
    let t0 = circle + n0 * radius;
    let t1 = circle + n1 * radius;
    let r0 = c - t0;
    let r1 = c - t1;
    let d0 = sqrt(dot(r0, r0));
    let d1 = sqrt(dot(r1, r1));
    var d = d1;
    var rr = r1;
    var fallback = n1;
    if (d0 <= d1) {
        d = d0;
        rr = r0;
        fallback = n0;
    }
    var nrm = fallback;
    if (d > 0.0) {
        nrm = rr / d;
    }
    return FeatureDistance(d, d, nrm, false);
}

// Nearer wins; on a tie (within TIE_TOL, set per precision by the prelude) a feature whose own
// region holds the centre wins, then an arc, so aligned corners meet as one corner–corner contact.
fn better(cand_d: real, cand_inside: bool, cand_f: u32, best_d: real, best_inside: bool, best_f: u32) -> bool {
    let tol = TIE_TOL * (1.0 + abs(best_d));
    if (cand_d < best_d - tol) {
        return true;
    }
    if (cand_d <= best_d + tol) {
        if (cand_inside != best_inside) {
            return cand_inside;
        }
        return cand_f % 2u == 0u && best_f % 2u == 1u;
    }
    return false;
}

// The contact geometry of circle centre c (radius r) measured from feature f.
fn contact_geometry(f: u32, fd: FeatureDistance, c: vec2<real>, radius: real) -> ContactGeometry {
    let gap = fd.signed_distance - radius;
    // Midway between block 1's surface point (c − n r) and block 2's (c − n (r + gap)).
    let depth = radius + 0.5 * gap;
    return ContactGeometry(f, gap, fd.normal, c - fd.normal * depth, fd.distance);
}

// Whether the outline turns left (convex) from edge a to edge b.
fn turns_left(a: Edge, b: Edge) -> bool {
    let na = edge_normal(a);
    let nb = edge_normal(b);
    return na.x * nb.y - na.y * nb.x > 0.0;
}

// The nearest of the neighbourhood's feature and its two neighbours: the per-cycle update of a
// contact whose point slides along the boundary (a point moves far less than a feature's length
// in one step).
//
// Fast path, most contacts on most cycles (twin of the CPU's): a corner circle over the straight
// part of an edge between two convex corners. Its centre lies inside the edge's slab, clear of
// both ends by more than the region tolerance, and outside the line, so it is outside both
// neighbouring arcs' wedges (their tolerance included), and each arc is measured from its tangent
// point on this edge: √(s² + d²) ≥ d, and an inside feature wins every tie with an outside one.
// The full three-way comparison would pick this edge with the same numbers, so skip it.
fn track_feature(nb: Neighbourhood, c: vec2<real>, radius: real) -> ContactGeometry {
    let f = nb.feature;
    let line_j = edge_distance(nb.edge_j, nb.c.round, nb.p.round, c);
    if (f % 2u == 1u && line_j.inside && line_j.signed_distance > 0.0) {
        let e = nb.edge_j;
        let s = dot(c - (e.p0 + e.u * nb.c.round), e.u);
        let straight = e.len - nb.c.round - nb.p.round;
        let margin = 1e-6 * e.len + 4.0 * REGION_TOL * (nb.c.round + line_j.distance);
        if (s > margin && s < straight - margin && turns_left(nb.edge_m, e) && turns_left(e, nb.edge_p)) {
            return contact_geometry(f, line_j, c, radius);
        }
    }
    // The candidates are the feature and its two neighbours: arc j, edge j, arc j+1 around edge
    // f = 2j+1, or edge j−1, arc j, edge j around arc f = 2j. Both shapes are covered by the arcs
    // j, j+1 and the edges j−1, j, measured unconditionally: invocations of one SIMD batch or warp
    // that track features of different kinds then run one path, not both kinds thrice (the
    // same distances, compared in the same order, as the three-way comparison of the Rust twin).
    let arc_j = arc_distance(nb.c.circle, nb.c.radius, nb.edge_m, nb.edge_j, c);
    let arc_p = arc_distance(nb.p.circle, nb.p.radius, nb.edge_j, nb.edge_p, c);
    let line_m = edge_distance(nb.edge_m, nb.m.round, nb.c.round, c);
    var cand = array<FeatureDistance, 3>(line_m, arc_j, line_j);
    var ids = array<u32, 3>(2u * nb.jm + 1u, 2u * nb.j, 2u * nb.j + 1u);
    if (f % 2u == 1u) {
        cand = array<FeatureDistance, 3>(arc_j, line_j, arc_p);
        ids = array<u32, 3>(2u * nb.j, 2u * nb.j + 1u, 2u * nb.jp);
    }
    var best_f = ids[0];
    var best = cand[0];
    for (var i = 1u; i < 3u; i += 1u) {
        let fd = cand[i];
        if (better(fd.distance, fd.inside, ids[i], best.distance, best.inside, best_f)) {
            best = fd;
            best_f = ids[i];
        }
    }
    return contact_geometry(best_f, best, c, radius);
}

// What the force–displacement law gives: the contact's new state and the force it applies to
// block 1 (normal, shear and dashpot parts; block 2 gets the reaction).
struct ForceLaw {
    contact: Contact,
    force: vec2<real>,
}

// Velocity of the material point p (eq. 11 in two dimensions: v + ω × r).
fn velocity_at(m: Motion, p: vec2<real>) -> vec2<real> {
    let r = p - m.centroid;
    return vec2<real>(m.velocity.x - m.w * r.y, m.velocity.y + m.w * r.x);
}

// The force–displacement law, eqs. 13–20 (see the Rust twin for the physics), and the energy it
// dissipates: slip work at the Coulomb limit and on opening, dashpot work a step late. `vrel` is
// block 1's velocity relative to block 2's at the contact point (eq. 13). `counted` is false for
// the mirror copy of a corner–corner contact, which carries no force.
fn contact_force_law(contact: Contact, mat: Material, vrel: vec2<real>, beta: real, dt: real, counted: bool) -> ForceLaw {
    var c = contact;
    let n = vec2<real>(c.nx, c.ny);
    let t = vec2<real>(-n.y, n.x);
    let vn = dot(vrel, n); // eq. (14)
    let vs = dot(vrel, t); // eq. (15)
    c.shear_displacement += vs * dt;
    // The dashpot force of the last step, −β·k·v(t−Δt/2), did work over that step's mean
    // velocity ½(v(t−Δt/2) + v(t+Δt/2)) (booked a step late, as on the CPU).
    if (c.dashpot_vn != 0.0 || c.dashpot_vs != 0.0) {
        c.dashpot_work += beta * (mat.kn * c.dashpot_vn * 0.5 * (c.dashpot_vn + vn) + mat.ks * c.dashpot_vs * 0.5 * (c.dashpot_vs + vs)) * dt;
        c.dashpot_vn = 0.0;
        c.dashpot_vs = 0.0;
    }
    if (!counted) {
        // The other view carries the touch; this view's own shear spring lets go (see the twin).
        c.slip_work += slip_dissipation(c.shear_force, 0.0, vs * dt, mat.ks);
        c.normal_force = 0.0;
        c.shear_force = 0.0;
        return ForceLaw(c, vec2<real>(0.0, 0.0));
    }
    var fn_ = -mat.kn * c.gap; // eq. (16) integrated exactly
    let bonded = c.bonded != 0u;
    var cohesion: real = 0.0;
    if (bonded) {
        cohesion = mat.cohesion;
    }
    let fs_old = c.shear_force;
    if (fn_ < 0.0 && (!bonded || -fn_ > cohesion)) {
        // Open: the shear spring's energy and any bond tension go to the slip work.
        c.slip_work += slip_dissipation(fs_old, 0.0, vs * dt, mat.ks);
        if (c.normal_force < 0.0 && mat.kn > 0.0) {
            c.slip_work += c.normal_force * c.normal_force / (2.0 * mat.kn);
        }
        c.bonded = 0u;
        c.normal_force = 0.0;
        c.shear_force = 0.0;
        return ForceLaw(c, vec2<real>(0.0, 0.0));
    }
    var fs = fs_old - mat.ks * vs * dt; // eqs. (17), (19)
    let limit = cohesion + mat.friction * max(fn_, 0.0);
    if (abs(fs) > limit) {
        fs = select(-limit, limit, fs > 0.0); // eq. (20)
        c.slip_work += slip_dissipation(fs_old, fs, vs * dt, mat.ks);
        if (bonded && mat.cohesion > 0.0) {
            c.bonded = 0u;
        }
    }
    c.normal_force = fn_;
    c.shear_force = fs;
    var dn: real = 0.0;
    var ds: real = 0.0;
    if (beta > 0.0 && fn_ > 0.0) {
        dn = -beta * mat.kn * vn;
        ds = -beta * mat.ks * vs;
        c.dashpot_vn = vn;
        c.dashpot_vs = vs;
    }
    fn_ += dn;
    let fs_total = fs + ds;
    return ForceLaw(c, vec2<real>(fn_ * n.x + fs_total * t.x, fn_ * n.y + fs_total * t.y));
}

// Energy a shear spring dissipates in one step while its force goes from fs_old to fs_new and the
// surfaces slide dus: the trapezoidal work −½(fs_old + fs_new)·dus less what the spring stored,
// (fs_new² − fs_old²)/2ks; zero for an elastic step, friction × slip at the Coulomb limit. Twin of
// `cpu::contact_forces::slip_dissipation`.
fn slip_dissipation(fs_old: real, fs_new: real, dus: real, ks: real) -> real {
    if (ks <= 0.0) {
        return 0.0;
    }
    return -0.5 * (fs_old + fs_new) * dus - (fs_new * fs_new - fs_old * fs_old) / (2.0 * ks);
}

// Whether the force law gives this contact the same result whether or not it is the counted view
// of a corner pair: open (gap > 0), unbonded, no tension held (twin of
// `contact::law::force_free_either_way`). Its gap is already this cycle's.
fn force_free_either_way(c: Contact, kn: real) -> bool {
    return c.bonded == 0u && c.normal_force >= 0.0 && c.gap > 0.0 && -kn * c.gap < 0.0;
}

// Whether a contact carries the force of its touch (twin of `contact::pair::counts_force`): of
// the two views of one touching corner pair exactly one counts, whatever kinds they found. A view
// on the arc of corner b, or on an edge whose nearer end b has a rounding circle overlapping the
// own corner a's, is one view of the pair (a, b), and the deeper of the pair's two views counts
// (`deeper_view_counts`); a view on an edge's straight part away from its ends always counts.
// Circles are relative to block 2's centroid; `feature` is one that `track_feature` chose in the
// neighbourhood `nb` (an edge among them is j−1 or j); `own_gap` is this view's gap; b1 and b2
// are the contact's blocks.
fn counts_force(own_corner: u32, own_circle: vec2<real>, own_radius: real, own_gap: real, nb: Neighbourhood, feature: u32, b1: Block, b2: Block) -> bool {
    let k = feature / 2u;
    if (feature % 2u == 0u) {
        // The arc of corner k of the neighbourhood (j−1, j or j+1).
        var ck = nb.c;
        if (k == nb.jm) {
            ck = nb.m;
        } else if (k == nb.jp) {
            ck = nb.p;
        }
        return deeper_view_counts(own_corner, own_radius, own_gap, b1, b2, ck, nb.start + k);
    }
    // Edge k runs from corner k to corner j = k+1: j → j+1, or j−1 → j. Corner j−1's circle
    // matters only here and only for edge j−1 (a contact on an arc that now finds the edge
    // before it nearer, a rare cycle): loaded then, so that other contacts do not load it (a
    // software adapter loads each field of each lane on its own, in a branch only when a lane of
    // its SIMD slice takes it).
    var ck = nb.c;
    var cj = nb.p;
    var j = nb.jp;
    if (k != nb.j) {
        ck = corner_view(nb.start + nb.jm);
        cj = nb.c;
        j = nb.j;
    }
    let rk = own_circle - ck.circle;
    let rj = own_circle - cj.circle;
    let dk = sqrt(dot(rk, rk));
    let dj = sqrt(dot(rj, rj));
    var b = k;
    var d = dk;
    var cb = ck;
    if (!(dk <= dj)) {
        b = j;
        d = dj;
        cb = cj;
    }
    if (d < own_radius + cb.radius) {
        return deeper_view_counts(own_corner, own_radius, own_gap, b1, b2, cb, nb.start + b);
    }
    return true;
}

// Of the two views of the corner pair (a, b), whether a's counts (twin of
// `contact::pair::deeper_view_counts`): b's gap against block 1 is measured from block 1's
// features around a (edge a−1, arc a, edge a), with b's circle placed relative to block 1 as
// b's own view places it (`circle_parts` in f32), so that both views compute the same two
// numbers. The deeper view counts; within PAIR_BAND of the two radii the lower index does.
// Only views of a corner pair come here (aligned corners in a wall), so block 1's corners are
// loaded only then.
fn deeper_view_counts(a: u32, radius_a: real, own_gap: real, b1: Block, b2: Block, cb: CornerView, b: u32) -> bool {
    if (a < b1.corner_start || a - b1.corner_start >= b1.corner_count) {
        return a < b;
    }
    let nb1 = neighbourhood(b1.corner_start, b1.corner_count, 2u * (a - b1.corner_start));
    var parts = array<vec2<real>, 2>(centroid_difference(b2, b1) + cb.circle, vec2<real>(0.0, 0.0));
    if (EXACT_CIRCLE) {
        parts = circle_parts(b2, b1, cb.circle);
    }
    let g = track_feature(nb1, parts[0], cb.radius);
    let other_gap = g.gap + dot(parts[1], g.normal);
    let band = PAIR_BAND * (radius_a + cb.radius);
    if (own_gap < other_gap - band) {
        return true;
    }
    if (other_gap < own_gap - band) {
        return false;
    }
    return a < b;
}

// The velocity the strain rate e (11, 12, 22) of a simply-deformable block gives a point r from
// its centroid: ε̇·r (twin of `sdef::strain_velocity`).
fn strain_velocity(e: vec3<real>, r: vec2<real>) -> vec2<real> {
    return vec2<real>(e.x * r.x + e.y * r.y, e.y * r.x + e.z * r.y);
}

// The grid points a contact of a zoned fully-deformable block may move with, loaded by
// `contact_forces_fdef` before the contact stage (which binds no FDEF slot itself): `on1`, block
// 1 is zoned and its corner is grid point g1 (velocity v1); `on2`, block 2 is zoned and g2 are
// its grid points at corners jm, j, jp and the one after of the feature's neighbourhood
// (`neighbourhood`), v2 their velocities. A scene without zoned blocks passes `not_zoned()`.
struct Zoned {
    on1: bool,
    on2: bool,
    g1: u32,
    v1: vec2<real>,
    g2: array<u32, 4>,
    v2: array<vec2<real>, 4>,
}

fn not_zoned() -> Zoned {
    let z = vec2<real>(0.0, 0.0);
    return Zoned(false, false, NO_INDEX, z, array<u32, 4>(NO_INDEX, NO_INDEX, NO_INDEX, NO_INDEX), array<vec2<real>, 4>(z, z, z, z));
}

// What the contact stage gives back besides what it stores: the lever arms from block 1's and
// block 2's centroids to the point (SDEF blocks), and the force shares of zoned blocks.
struct StageOut {
    levers: vec4<real>,
    share: ContactShare,
}

// Block 2's boundary velocity at the contact point `at` on its feature `feature` (twin of
// `cpu::zones::boundary_velocity` with `force_shares`): a corner arc moves with its grid point;
// an edge with its two, weighted by where the point lies along it; and the shares the gather
// gives the contact's reaction by. `nb` is the neighbourhood the feature was tracked in.
struct Boundary {
    velocity: vec2<real>,
    share: ContactShare,
}

fn boundary_velocity(z: Zoned, nb: Neighbourhood, feature: u32, at: vec2<real>) -> Boundary {
    let j = feature / 2u;
    var slot = 2u;
    var e = nb.edge_p;
    if (j == nb.jm) {
        slot = 0u;
        e = nb.edge_m;
    } else if (j == nb.j) {
        slot = 1u;
        e = nb.edge_j;
    }
    var g = z.g2;
    var v = z.v2;
    var out = Boundary(vec2<real>(0.0, 0.0), ContactShare(1.0, 0.0, z.g1, g[slot], NO_INDEX, 0u));
    if (feature % 2u == 0u) {
        out.velocity = v[slot];
        return out;
    }
    var t = real(0.0);
    if (e.len > 0.0) {
        let d = at - e.p0;
        t = clamp((d.x * e.u.x + d.y * e.u.y) / e.len, 0.0, 1.0);
    }
    out.share.wa = 1.0 - t;
    out.share.wb = t;
    out.share.g2b = g[slot + 1u];
    if (out.share.wa != 0.0) {
        out.velocity += out.share.wa * v[slot];
    }
    if (out.share.wb != 0.0) {
        out.velocity += out.share.wb * v[slot + 1u];
    }
    return out;
}

// Stage 4 for contact k (`contact`, as loaded): its geometry, its force law, the gather's record,
// the overlap flag.
// `strained`: the blocks' strain rates e1, e2 (simply-deformable blocks; zero for rigid ones)
// move the contact point too (`contact_forces_sdef`); a rigid scene passes false and computes
// nothing of them. `zoned`: the grid points a zoned block's boundary moves with
// (`contact_forces_fdef`). Returns the lever arms from block 1's and block 2's centroids to the
// point and the zoned blocks' force shares.
fn contact_stage(k: u32, contact: Contact, strained: bool, e1: vec3<real>, e2: vec3<real>, zoned: Zoned) -> StageOut {
    var c = contact;
    let feature_before = c.feature;
    let bonded_before = c.bonded;
    // Fields most contacts need on no cycle are read only where they matter (a software adapter
    // runs a branch only when a lane of its SIMD slice takes it, so a rare branch costs nothing,
    // but every load outside one costs on every contact): the accumulators start from zero and
    // their increments are added below; the normal force of the last step matters only to a
    // bond's tension (an unbonded contact never pulls); the dashpots only when live.
    c.slip_work = 0.0;
    c.dashpot_work = 0.0;
    c.normal_force = 0.0;
    if (c.bonded != 0u) {
        c.normal_force = contacts[k].normal_force;
    }
    c.dashpot_vn = 0.0;
    c.dashpot_vs = 0.0;
    if (params.dashpots != 0u) {
        c.dashpot_vn = contacts[k].dashpot_vn;
        c.dashpot_vs = contacts[k].dashpot_vs;
    }
    let b1 = blocks[c.block1];
    let b2 = blocks[c.block2];
    let corner = corners[c.corner];
    let d12 = centroid_difference(b1, b2);
    // The circle centre relative to block 2's centroid, in f32 split exactly into the nearest f32
    // and a remainder (`circle_parts`). The features are measured from the nearest f32 and the
    // gap takes the remainder along the normal: a block moving by less than its coordinates' ulp
    // moves its gap smoothly, where a rounded sum moved it in steps of that ulp (a light block
    // resting on a heavy one never settled: its contact force jumped by kn × ulp). In f64 the
    // rounded sum (EXACT_CIRCLE, see the prelude).
    var parts = array<vec2<real>, 2>(d12 + vec2<real>(corner.ox, corner.oy), vec2<real>(0.0, 0.0));
    if (EXACT_CIRCLE) {
        parts = circle_parts(b1, b2, vec2<real>(corner.ox, corner.oy));
    }
    let circle = parts[0];
    let nb = neighbourhood(b2.corner_start, b2.corner_count, c.feature);
    let g = track_feature(nb, circle, corner.radius);
    c.feature = g.feature;
    c.gap = g.gap + dot(parts[1], g.normal);
    let world = in_world(g, b2);
    c.nx = world.normal.x;
    c.ny = world.normal.y;
    c.px = world.point.x;
    c.py = world.point.y;
    // An open, unbonded view gets no force whether or not it counts: the comparison of the
    // pair's depths is skipped for it (`force_free_either_way`).
    let law_mat = contact_law(materials[c.material], c.length);
    var counted = true;
    if (!force_free_either_way(c, law_mat.kn)) {
        counted = counts_force(c.corner, circle, corner.radius, c.gap, nb, c.feature, b1, b2);
    }
    let m1 = Motion(d12, vec2<real>(b1.vx, b1.vy), b1.w);
    let m2 = Motion(vec2<real>(0.0, 0.0), vec2<real>(b2.vx, b2.vy), b2.w);
    let at = vec2<real>(c.px, c.py);
    var vrel = velocity_at(m1, at) - velocity_at(m2, at); // eq. (13)
    if (strained) {
        vrel = (velocity_at(m1, at) + strain_velocity(e1, at - d12)) - (velocity_at(m2, at) + strain_velocity(e2, at));
    }
    var share = ContactShare(0.0, 0.0, NO_INDEX, NO_INDEX, NO_INDEX, 0u);
    if (zoned.on1 || zoned.on2) {
        // A zoned block's boundary moves with its grid points (`cpu::contact_forces`).
        var v1 = velocity_at(m1, at);
        var v2 = velocity_at(m2, at);
        if (zoned.on1) {
            v1 = zoned.v1;
            share.wa = 1.0;
            share.g1 = zoned.g1;
        }
        if (zoned.on2) {
            let bv = boundary_velocity(zoned, nb, c.feature, at);
            v2 = bv.velocity;
            share.wa = bv.share.wa;
            share.wb = bv.share.wb;
            share.g2a = bv.share.g2a;
            share.g2b = bv.share.g2b;
        }
        vrel = v1 - v2;
    }
    let law = contact_force_law(c, law_mat, vrel, params.beta, params.dt, counted);
    c = law.contact;
    let f = law.force;
    store_contact_state(k, c);
    if (c.slip_work != 0.0) {
        contacts[k].slip_work += c.slip_work;
    }
    if (params.dashpots != 0u) {
        contacts[k].dashpot_vn = c.dashpot_vn;
        contacts[k].dashpot_vs = c.dashpot_vs;
        if (c.dashpot_work != 0.0) {
            contacts[k].dashpot_work += c.dashpot_work;
        }
    }
    if (c.feature != feature_before) {
        contacts[k].feature = c.feature;
    }
    if (c.bonded != bonded_before) {
        contacts[k].bonded = c.bonded;
    }
    // For the gather: the force on block 1 and its reaction on block 2, with their moments about
    // each block's centroid (eq. 12). The point is relative to block 2's centroid, so block 1's
    // lever arm is p − (c1 − c2).
    let p = vec2<real>(c.px, c.py);
    let r1 = p - d12;
    contact_forces_out[k] = ContactForce(f.x, f.y, array<real, 2>(r1.x * f.y - r1.y * f.x, p.y * f.x - p.x * f.y));
    if (counted && -g.gap > params.overlap_limit) {
        atomicOr(&flags.errors, ERR_OVERLAP);
        atomicMin(&flags.overlap_contact, k);
    }
    return StageOut(vec4<real>(r1, p), share);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn contact_forces(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    if (k >= params.n_contacts) {
        return;
    }
    let zero = vec3<real>(0.0, 0.0, 0.0);
    _ = contact_stage(k, contacts[k], false, zero, zero, not_zoned());
}

// The strain rate of block b (zero for a rigid block, whose extension stays zero).
fn strain_rate_of(b: u32) -> vec3<real> {
    let e = sdefs[b].strain_rate;
    return vec3<real>(e[0], e[1], e[2]);
}

// Stage 4 in a scene with simply-deformable blocks: the blocks' strain rates move the contact
// point (`contact::law::BlockMotion::velocity_at`), and the lever arms go to `contact_levers`
// for the gather's applied stress.
@compute @workgroup_size(WORKGROUP_SIZE)
fn contact_forces_sdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    if (k >= params.n_contacts) {
        return;
    }
    let c = contacts[k];
    let r = contact_stage(k, c, true, strain_rate_of(c.block1), strain_rate_of(c.block2), not_zoned()).levers;
    contact_levers[k] = ContactLever(r.x, r.y, r.z, r.w);
}


// The grid points contact c's blocks move with where they are zoned (`Zoned`): block 1's corner's,
// and block 2's around the feature it follows (the neighbourhood `track_feature` searches).
fn zoned_of(c: Contact) -> Zoned {
    var z = not_zoned();
    let b1 = blocks[c.block1];
    if (b1.kind == BLOCK_FDEF) {
        z.on1 = true;
        z.g1 = fdef_blocks[c.block1].gp_start + (c.corner - b1.corner_start);
        z.v1 = vec2<real>(gridpoints[z.g1].vx, gridpoints[z.g1].vy);
    }
    let b2 = blocks[c.block2];
    if (b2.kind == BLOCK_FDEF) {
        z.on2 = true;
        let start = fdef_blocks[c.block2].gp_start;
        let n = b2.corner_count;
        let j = min(c.feature, 2u * n - 1u) / 2u;
        let jp = next_index(j, n);
        let around = array<u32, 4>(prev_index(j, n), j, jp, next_index(jp, n));
        for (var i = 0u; i < 4u; i += 1u) {
            let g = start + around[i];
            z.g2[i] = g;
            z.v2[i] = vec2<real>(gridpoints[g].vx, gridpoints[g].vy);
        }
    }
    return z;
}

// Stage 4 in a scene with zoned fully-deformable blocks: a zoned block's boundary velocity at
// the contact point is its grid points' (`boundary_velocity`), and the force shares go to
// `contact_shares` for the grid points' gather (`gather_gridpoints`, zones.wgsl).
@compute @workgroup_size(WORKGROUP_SIZE)
fn contact_forces_fdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    if (k >= params.n_contacts) {
        return;
    }
    let c = contacts[k];
    let zero = vec3<real>(0.0, 0.0, 0.0);
    contact_shares[k] = contact_stage(k, c, false, zero, zero, zoned_of(c)).share;
}

// The centre of a corner's rounding circle (offset `o` from block 1's centroid) relative to block
// 2's centroid, in the frame block 2's corners are placed in, as an exact sum [nearest,
// remainder]: the centroids' large and small parts and the offset are summed by `two_sum` (the
// rounding errors kept), `nearest` is the real nearest that sum and `remainder` what it leaves,
// so motion below the nearest's ulp lies in the remainder. The turns since the corners were
// placed (`rotation_lo`, below ROTATION_STEP) enter to second order, R(δ)x ≈ x + δ·x⊥ − δ²x/2
// (the third order, R·δ³/6, is below 3e-12 R): block 1's turns its offset by δ1, and block 2's
// turns its features, which is the circle turned by −δ2 about block 2's centroid. Used by the
// f32 kernels (EXACT_CIRCLE).
fn circle_parts(b1: Block, b2: Block, o: vec2<real>) -> array<vec2<real>, 2> {
    let one = real(params.one);
    let dx = two_sum(b1.cx, -b2.cx, one);
    let dy = two_sum(b1.cy, -b2.cy, one);
    let sx = two_sum(dx.x, o.x, one);
    let sy = two_sum(dy.x, o.y, one);
    let s = vec2<real>(sx.x, sy.x);
    let turn1 = turned_by(o, b1.rotation_lo);
    let turn2 = turned_by(s + turn1, -b2.rotation_lo);
    let rest = vec2<real>((b1.cx_lo - b2.cx_lo) + (dx.y + sx.y), (b1.cy_lo - b2.cy_lo) + (dy.y + sy.y)) + (turn1 + turn2);
    let nearest = s + rest;
    return array<vec2<real>, 2>(nearest, (s - nearest) + rest);
}

// What turning x by the small angle δ adds to it, to second order: δ·x⊥ − δ²x/2.
fn turned_by(x: vec2<real>, delta: real) -> vec2<real> {
    return delta * vec2<real>(-x.y, x.x) - (0.5 * delta * delta) * x;
}

// A contact's geometry measured in the frame block 2's corners are placed in, with its normal and
// point turned into the world by block 2's turn since (f32 only: in f64 the corners follow the
// rotation every step and the geometry is the world's, so nothing is loaded or added).
fn in_world(g: ContactGeometry, b2: Block) -> ContactGeometry {
    var w = g;
    if (EXACT_CIRCLE) {
        w.normal += turned_by(g.normal, b2.rotation_lo);
        w.point += turned_by(g.point, b2.rotation_lo);
    }
    return w;
}

// Stores what every cycle changes of contact k and the next cycle or a contact update reads (the
// kernel stores the rest only when it changed). The point and normal are not stored: nothing on
// the device reads them, and `contact_points` places them for a read-back.
fn store_contact_state(k: u32, c: Contact) {
    contacts[k].gap = c.gap;
    contacts[k].normal_force = c.normal_force;
    contacts[k].shear_force = c.shear_force;
    contacts[k].shear_displacement = c.shear_displacement;
}

// The geometry of the neighbourhood's own feature, without tracking: edge j or arc j, measured as
// `track_feature` measures it (the same distance function on the same corners and edges, since
// the neighbourhood of the feature it chose holds them).
fn feature_geometry(nb: Neighbourhood, c: vec2<real>, radius: real) -> ContactGeometry {
    if (nb.feature % 2u == 1u) {
        return contact_geometry(nb.feature, edge_distance(nb.edge_j, nb.c.round, nb.p.round, c), c, radius);
    }
    return contact_geometry(nb.feature, arc_distance(nb.c.circle, nb.c.radius, nb.edge_m, nb.edge_j, c), c, radius);
}

// Each contact's point and normal for the feature it follows, from the blocks where they are now:
// what the last `contact_forces` found, since no block has moved since and the contact keeps the
// feature it chose. The cycle does not store them (four stores a contact a cycle that nothing on
// the device reads); this runs before a read-back or checkpoint of whole contacts. The CPU's twin
// is the point and normal its stage 4 stores (`cpu::contact_forces`, from `track_feature`);
// tests/suite/contact_rules.rs checks the read-back ones against it.
@compute @workgroup_size(WORKGROUP_SIZE)
fn contact_points(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    if (k >= params.n_contacts) {
        return;
    }
    let b1 = blocks[contacts[k].block1];
    let b2 = blocks[contacts[k].block2];
    let corner = corners[contacts[k].corner];
    var circle = centroid_difference(b1, b2) + vec2<real>(corner.ox, corner.oy);
    if (EXACT_CIRCLE) {
        circle = circle_parts(b1, b2, vec2<real>(corner.ox, corner.oy))[0];
    }
    let nb = neighbourhood(b2.corner_start, b2.corner_count, contacts[k].feature);
    let g = feature_geometry(nb, circle, corner.radius);
    let world = in_world(g, b2);
    contacts[k].px = world.point.x;
    contacts[k].py = world.point.y;
    contacts[k].nx = world.normal.x;
    contacts[k].ny = world.normal.y;
}
