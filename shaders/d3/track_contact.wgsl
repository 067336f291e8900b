// Stage 4 for D3, one invocation per contact (Rust twin: `d3::contact::track_contact`): the common
// plane afresh (`common_plane`), then each logical contact the last detection on the CPU found
// (keyed by its blocks' vertices) placed on it with its gap (`place_logical`), then the
// force–displacement law (`force_law`, eqs. 13–20). Which logical contacts a contact has changes
// only at a detection, on the CPU between cycles (module doc of `d3::gpu`).
//
// The geometry is between the contact's two convex bodies: a convex block is its own one body,
// a concave block's are its convex parts (`Block::parts`), and a contact is between one part of
// each (`Contact::parts`). A body is a record in `blocks` (a convex block's own; a part's after
// the blocks) holding its ranges of vertices, face planes and edges and its radius, named for
// each contact in `adjacency` (`contact_bodies`); below, `a`, `b` and `i` name those records.
// The motion a body shares (its orientation, a simply-deformable block's stretch) and the
// velocities, points and forces are the contact's blocks' (`owner`): a part's vertices are
// placed with its block's (stage 2), in f32 as offsets from the block's centroid, so the
// contact's frame is its blocks' as for convex blocks.
//
// In f32 (RELATIVE) the contact's geometry is worked in a frame at the midpoint of its blocks'
// centroids: a vertex is its offset from its centroid (stage 2) less or plus half the centroids'
// difference, that half kept as a pair hi + lo (`centroid_pair_from`; halving is exact), the
// offset and the high part added first. Near the contact the two nearly cancel (for two unit
// boxes face to face, ∓(d/2) ± h with d the centroids' distance and h the half-height), exactly
// where they lie within a factor 2 of each other (Sterbenz), and the low part then adds at the
// size of what is left. So a gap is resolved at the round-off of the offsets and of the
// coordinates near the contact, not at ulp(distance from the origin), nor at ulp(block size) as
// in a frame at block 1's centroid with the difference rounded (there a stack at z = 1…4 m
// settled no better than in global axes: each corner's force still moved in steps of
// kn·ulp(1 m) = 60…120 N). The points are stored from block 1's centroid (read by `velocity_at`,
// the gather and the read-back, which adds that centroid). Sums whose rounding matters are
// multiplied by `params.one` so that no compiler reassociates them (math.wgsl's `two_sum`). In
// f64 the frame is the global one, as on the CPU.

// The contact's frame: its block 1's body (its record), and half block 2's centroid less block
// 1's as a pair (f32; unused in f64).
var<private> frame_origin: u32;
var<private> frame_half: Pair;
// The contact's blocks, block 1 then block 2.
var<private> owners: vec2<u32>;

// The block whose motion body i (a record of the contact's) shares.
fn owner(i: u32) -> u32 {
    return select(owners.y, owners.x, i == frame_origin);
}

// Vertex k (the body's own numbering) of body i, a body of the contact, in the contact's frame.
fn block_vertex(i: u32, k: u32) -> vec3<real> {
    let x = vertex(blocks[i].vertex_start + k);
    if (RELATIVE) {
        let one = params.one;
        if (i == frame_origin) {
            return (x - frame_half.hi) * one - frame_half.lo;
        }
        return (x + frame_half.hi) * one + frame_half.lo;
    }
    return x;
}

// The frame's origin from block 1's centroid (f32): half block 2's centroid less block 1's.
fn midpoint_from_first() -> vec3<real> {
    return frame_half.hi + frame_half.lo;
}

// The outward normal of face plane k of body i, in global axes (`Body::face_normal`; a
// simply-deformable block's strained, sdef.wgsl).
fn plane_normal(i: u32, k: u32) -> vec3<real> {
    let pl = planes[blocks[i].plane_start + k];
    let n = quat_rotate(orientation(owner(i)), vec3<real>(pl.nx, pl.ny, pl.nz));
    if (SDEF) {
        return stretched_normal(owner(i), n);
    }
    return n;
}

// The greatest n·x over body i's vertices (`lowest`: the least).
fn support(i: u32, n: vec3<real>, lowest: bool) -> real {
    var s = dot3(n, block_vertex(i, 0u));
    for (var k = 1u; k < blocks[i].vertex_count; k++) {
        let d = dot3(n, block_vertex(i, k));
        s = select(max(s, d), min(s, d), lowest);
    }
    return s;
}

// The separation of bodies a and b along n: least n·x over b less greatest over a.
fn separation_along(a: u32, b: u32, n: vec3<real>) -> real {
    return support(b, n, true) - support(a, n, false);
}

// A common plane: its normal, its separation, and the axis it was found on: face plane `face`
// of block 1 (`on_b` false) or of block 2, or NO_FACE (an edge pair's axis, a nearest pair's
// direction, the last cycle's normal).
struct Plane3 {
    normal: vec3<real>,
    separation: real,
    face: u32,
    on_b: bool,
}

const NO_FACE: u32 = 0xffffffffu;

// `best`, or the axis n where its separation beats it by more than the slack (found on face
// plane `face` of block 2 where `on_b`, of block 1 otherwise; NO_FACE for no face's axis).
fn consider(best: Plane3, a: u32, b: u32, n: vec3<real>, slack: real, face: u32, on_b: bool) -> Plane3 {
    let s = separation_along(a, b, n);
    if (s > best.separation + slack) {
        return Plane3(n, s, face, on_b);
    }
    return best;
}

// The radius of a ball about `mean` (the mean of body i's vertices, in the contact's frame) inside
// the body: the least distance from it to a face plane, as placed (a simply-deformable block's
// strained); -FINITE_MAX where the mean is not inside every plane (no bound then).
fn inradius(i: u32, mean: vec3<real>) -> real {
    var r = FINITE_MAX;
    for (var k = 0u; k < blocks[i].plane_count; k++) {
        let v = block_vertex(i, planes[blocks[i].plane_start + k].vertex);
        r = min(r, dot3(plane_normal(i, k), v - mean));
    }
    return select(-FINITE_MAX, r, r > 0.0);
}

// What the search passes over (`common_plane`'s bound): the centres' difference, the two radii's
// sum, the margin and the floor.
struct Bound {
    d: vec3<real>,
    r: real,
    margin: real,
    floor: real,
}

// Whether an axis whose bound is `bound` can still win against `best`.
fn open_axis(bound: real, best: Plane3, k: Bound) -> bool {
    return bound >= max(k.floor, best.separation - k.margin);
}

// The axes of `common_plane` in their order, those that cannot win passed over.
fn search_axes(a: u32, b: u32, slack: real, k: Bound) -> Plane3 {
    var best = Plane3(vec3<real>(0.0, 0.0, 1.0), -FINITE_MAX, NO_FACE, false);
    for (var p = 0u; p < blocks[a].plane_count; p++) {
        let n = plane_normal(a, p);
        if (open_axis(dot3(n, k.d) - k.r, best, k)) {
            best = consider(best, a, b, n, slack, p, false);
        }
    }
    for (var p = 0u; p < blocks[b].plane_count; p++) {
        let n = -plane_normal(b, p);
        if (open_axis(dot3(n, k.d) - k.r, best, k)) {
            best = consider(best, a, b, n, slack, p, true);
        }
    }
    let ea0 = blocks[a].edge_start;
    let eb0 = blocks[b].edge_start;
    for (var i = 0u; i < blocks[a].edge_dir_count; i++) {
        let da = block_vertex(a, edges[2u * (ea0 + i) + 1u]) - block_vertex(a, edges[2u * (ea0 + i)]);
        for (var j = 0u; j < blocks[b].edge_dir_count; j++) {
            let db = block_vertex(b, edges[2u * (eb0 + j) + 1u]) - block_vertex(b, edges[2u * (eb0 + j)]);
            let c = cross3(da, db);
            if (dot3(c, c) <= 1e-12 * dot3(da, da) * dot3(db, db)) {
                continue;
            }
            let n = normalize3(c);
            if (!open_axis(abs(dot3(n, k.d)) - k.r, best, k)) {
                continue;
            }
            best = consider(best, a, b, n, slack, NO_FACE, false);
            best = consider(best, a, b, -n, slack, NO_FACE, false);
        }
    }
    return best;
}

// The common plane of convex bodies a and b (Rust twin: `contact::common_plane_with`): of the
// face normals of either body and the cross products of an edge direction of each, the one of
// greatest separation; where they are apart by no more than `reach`, the directions between
// their nearest vertex and edge or vertex and vertex too. `mean_a`, `mean_b`: the means of the
// bodies' vertices; `hint`: the contact's last normal.
//
// An axis's separation is at most n·(mean_b − mean_a) − (r_a + r_b), r a ball's radius about the
// mean inside the body (`inradius`); an axis whose bound lies under the best found so far, or
// under the floor the hint gives (its separation, or 0 where greater), less a margin, cannot win
// and is passed over, its support loops (the vertices' loads) not run. The margin covers the
// runs of near ties (the slack, and the kernel's round-off of a comparison, once per axis) and
// the round-off of the projections (ROUNDOFF times the distances in the contact's frame), so the
// axis found is the full search's bit for bit, as the CPU's (the argument is in
// `contact::common_plane_with`'s doc); where no axis reaches the floor, the search runs again
// without it.
fn common_plane(a: u32, b: u32, reach: real, hint: vec3<real>, mean_a: vec3<real>, mean_b: vec3<real>) -> Plane3 {
    let slack = 1e-12 * (blocks[a].radius + blocks[b].radius);
    let axes = blocks[a].plane_count + blocks[b].plane_count + 2u * blocks[a].edge_dir_count * blocks[b].edge_dir_count;
    let size = length(mean_a) + length(mean_b) + blocks[a].radius + blocks[b].radius;
    let margin = 2.0 * real(axes + 2u) * (slack + ROUNDOFF * size) + 180.0 * ROUNDOFF * size;
    let r = inradius(a, mean_a) + inradius(b, mean_b);
    let floor = min(separation_along(a, b, hint), 0.0) - margin;
    var best = search_axes(a, b, slack, Bound(mean_b - mean_a, r, margin, floor));
    if (best.separation < floor + 0.5 * margin) {
        best = search_axes(a, b, slack, Bound(mean_b - mean_a, r, margin, -FINITE_MAX));
    }
    if (best.separation > 0.0 && best.separation <= reach) {
        let n = best.normal;
        let hi_a = support(a, n, false);
        let lo_b = support(b, n, true);
        if (face_meets(a, b, best, hi_a, lo_b, 0.25 * slack)) {
            return best;
        }
        var found = false;
        var nearest_l: real = 0.0;
        var nearest = vec3<real>(0.0, 0.0, 0.0);
        // Each feature edge of one block near the plane against each vertex of the other near
        // it (block a's edges first, then block b's, the direction always from a to b).
        for (var side = 0u; side < 2u; side++) {
            let src = select(b, a, side == 0u);
            let dst = select(a, b, side == 0u);
            let sign = select(real(-1.0), real(1.0), side == 0u);
            let e0 = blocks[src].edge_start + blocks[src].edge_dir_count;
            for (var k = 0u; k < blocks[src].feature_count; k++) {
                let p = block_vertex(src, edges[2u * (e0 + k)]);
                let q = block_vertex(src, edges[2u * (e0 + k) + 1u]);
                if (!near(side == 0u, dot3(n, p), hi_a, lo_b, reach) && !near(side == 0u, dot3(n, q), hi_a, lo_b, reach)) {
                    continue;
                }
                let d = q - p;
                for (var m = 0u; m < blocks[dst].vertex_count; m++) {
                    let v = block_vertex(dst, m);
                    if (!near(side != 0u, dot3(n, v), hi_a, lo_b, reach)) {
                        continue;
                    }
                    let t = clamp(dot3(v - p, d) / dot3(d, d), 0.0, 1.0);
                    let off = (v - (p + d * t)) * sign;
                    let l = dot3(off, off);
                    if (l > 0.0 && (!found || l < nearest_l)) {
                        found = true;
                        nearest_l = l;
                        nearest = off;
                    }
                }
            }
        }
        for (var i = 0u; i < blocks[a].vertex_count; i++) {
            let va = block_vertex(a, i);
            if (!near(true, dot3(n, va), hi_a, lo_b, reach)) {
                continue;
            }
            for (var j = 0u; j < blocks[b].vertex_count; j++) {
                let vb = block_vertex(b, j);
                if (!near(false, dot3(n, vb), hi_a, lo_b, reach)) {
                    continue;
                }
                let off = vb - va;
                let l = dot3(off, off);
                if (l > 0.0 && (!found || l < nearest_l)) {
                    found = true;
                    nearest_l = l;
                    nearest = off;
                }
            }
        }
        if (found) {
            best = consider(best, a, b, normalize3(nearest), slack, NO_FACE, false);
        }
    }
    return best;
}

// Whether the separation of `plane`, found on a face plane's axis, is the bodies' distance to
// within `within` (Rust twin: `contact::face_meets`): some vertex of the other body at its
// support (`hi_a`, `lo_b`: block 1's greatest projection on the normal, block 2's least),
// moved along the normal onto the face's plane, lands behind all the face's body's other
// planes. Then no nearest pair of vertex and edge can give a greater separation.
fn face_meets(a: u32, b: u32, plane: Plane3, hi_a: real, lo_b: real, within: real) -> bool {
    if (plane.face == NO_FACE) {
        return false;
    }
    let n = plane.normal;
    let body = select(a, b, plane.on_b);
    let other = select(b, a, plane.on_b);
    // The other body's support, the face's plane, and the sense from the other towards it.
    let at = select(lo_b, hi_a, plane.on_b);
    let level = select(hi_a, lo_b, plane.on_b);
    let towards = select(real(-1.0), real(1.0), plane.on_b);
    for (var m = 0u; m < blocks[other].vertex_count; m++) {
        let w = block_vertex(other, m);
        let h = dot3(n, w);
        if ((h - at) * -towards > within) {
            continue;
        }
        let on = w + n * (level - h);
        var inside = true;
        for (var j = 0u; j < blocks[body].plane_count; j++) {
            if (j == plane.face) {
                continue;
            }
            let nf = plane_normal(body, j);
            if (dot3(nf, on) > dot3(nf, block_vertex(body, planes[blocks[body].plane_start + j].vertex))) {
                inside = false;
                break;
            }
        }
        if (inside) {
            return true;
        }
    }
    return false;
}

// Whether a vertex at height h along the normal is near the plane: within `reach` of block 1's
// top (`first`) or of block 2's bottom.
fn near(first: bool, h: real, hi_a: real, lo_b: real, reach: real) -> bool {
    if (first) {
        return h >= hi_a - reach;
    }
    return h <= lo_b + reach;
}

// The distance along n from p at which the line p + s·n leaves body i (the least s over the
// planes it heads out through), or enters it (`entering`: the greatest over those it heads in
// through) (Rust twin: `contact::ray_crossing` over the planes `contact::facing` sorts out once
// per contact); `found` false where no plane qualifies. Planes whose |n·normal| is no more than
// `least` (`facing_least`) are passed over, and so are crossings farther along the line than
// `reach`.
struct Crossing {
    s: real,
    found: bool,
}

// The |n·normal| a plane of body i must exceed to count in `ray_crossing` (Rust twin: the
// threshold `contact::facing` takes): GRAZING (the prelude says why; PART_GRAZING for a part of
// a concave block, whose record lies after the blocks), and STEEP_SHARE of the squarest plane's
// (a steep side face is crossed only where the point lies on its edge, at a distance its tilt
// decides: the twin's doc). Once per contact and body.
fn facing_least(i: u32, n: vec3<real>, entering: bool) -> real {
    let sign = select(real(1.0), real(-1.0), entering);
    var squarest: real = 0.0;
    for (var k = 0u; k < blocks[i].plane_count; k++) {
        squarest = max(squarest, sign * dot3(plane_normal(i, k), n));
    }
    return max(select(GRAZING, PART_GRAZING, i >= params.blocks), STEEP_SHARE * squarest);
}

fn ray_crossing(i: u32, p: vec3<real>, n: vec3<real>, entering: bool, reach: real, least: real) -> Crossing {
    var out = Crossing(0.0, false);
    for (var k = 0u; k < blocks[i].plane_count; k++) {
        let nf = plane_normal(i, k);
        let d = dot3(nf, n);
        let x = block_vertex(i, planes[blocks[i].plane_start + k].vertex);
        if ((entering && d < -least) || (!entering && d > least)) {
            let s = dot3(nf, x - p) / d;
            // Farther than `reach`: a face nearly parallel to the line, seen from just outside
            // (Rust twin's doc).
            if (abs(s) > reach) {
                continue;
            }
            if (!out.found || (entering && s > out.s) || (!entering && s < out.s)) {
                out = Crossing(s, true);
            }
        }
    }
    return out;
}

// Where a logical contact lies now, and its gap (Rust twin: `contact::place_logical`): its
// vertex (vertex–face), or the crossing of its two edges as seen along n (edge–edge; the nearest
// point of them where they no longer cross), on the mid-plane between the blocks' supports, then
// moved along n to halfway between where the line along n leaves block 1 and enters block 2.
struct Placed {
    point: vec3<real>,
    gap: real,
}

fn place_logical(l: Logical, a: u32, b: u32, n: vec3<real>, hi_a: real, lo_b: real, separation: real, least_a: real, least_b: real) -> Placed {
    let mid = 0.5 * (hi_a + lo_b);
    var x: vec3<real>;
    if (l.kind == LOGICAL_VERTEX_FIRST) {
        x = block_vertex(a, l.v1);
    } else if (l.kind == LOGICAL_VERTEX_SECOND) {
        x = block_vertex(b, l.v1);
    } else {
        let p0 = block_vertex(a, l.v1);
        let r = block_vertex(a, l.v2) - p0;
        let q0 = block_vertex(b, l.v3);
        let s = block_vertex(b, l.v4) - q0;
        let den = dot3(cross3(r, s), n);
        var t: real = 0.5;
        if (abs(den) > 1e-12 * length3(r) * length3(s)) {
            t = clamp(dot3(cross3(q0 - p0, s), n) / den, 0.0, 1.0);
        }
        x = p0 + r * t;
    }
    let p = x + n * (mid - dot3(n, x));
    let reach = 2.0 * (blocks[a].radius + blocks[b].radius);
    let leave = ray_crossing(a, p, n, false, reach, least_a);
    let enter = ray_crossing(b, p, n, true, reach, least_b);
    var ls: real = 0.0;
    var es: real = separation;
    if (leave.found && enter.found) {
        ls = leave.s;
        es = enter.s;
    }
    return Placed(p + n * (0.5 * (ls + es)), es - ls);
}

// The energy a shear spring gave up to slip in one step (Rust twin: `contact::slip_work`): the
// trapezoidal work the blocks did on it, −½(held + new)·slide, less what it stored.
fn slip_work(held: vec3<real>, new_force: vec3<real>, slide: vec3<real>, ks: real) -> real {
    if (ks <= 0.0) {
        return 0.0;
    }
    return -0.5 * dot3(held + new_force, slide) - (dot3(new_force, new_force) - dot3(held, held)) / (2.0 * ks);
}

// The force–displacement law for the contact's live logical contacts (Rust twin:
// `contact::force_law`), at its normal n; `old` is the normal of the cycle before. Returns the
// energy friction took and the energy the normal springs of those that opened loaded held
// (released: an edge–edge contact's stepped force can stand above kn times its overlap there).
fn force_law(c: Contact, old: vec3<real>, dt: real) -> vec2<real> {
    let n = normal_of(c);
    var friction: real = 0.0;
    var released: real = 0.0;
    for (var j = 0u; j < c.logical_count; j++) {
        let k = c.logical_start + j;
        var l = logicals[k];
        if (l.live == 0u) {
            continue;
        }
        if (l.gap > l.offset) {
            // Open: no force, and the shear history is lost; the spring reloads from here.
            l.offset = min(l.gap, 0.0);
            let fs = shear_of(l);
            if (c.ks > 0.0) {
                friction += 0.5 * dot3(fs, fs) / c.ks;
            }
            if (c.kn > 0.0 && l.normal_force > 0.0 && l.kind == LOGICAL_EDGE_EDGE) {
                released += 0.5 * l.normal_force * l.normal_force / c.kn;
            }
            l.normal_force = 0.0;
            l.sx = 0.0;
            l.sy = 0.0;
            l.sz = 0.0;
            logicals[k] = l;
            continue;
        }
        // Eq. (13): block 2's point relative to block 1's; eqs. (14)–(15).
        let p = point_of(l);
        let u = velocity_at(c.block2, p, c.block1) - velocity_at(c.block1, p, c.block1);
        let un = dot3(u, n);
        let us = u - un * n;
        // Eq. (16), ΔFn = −kn·Δun, in compression only (`contact::force_law`): the CPU's detection
        // between batches gives each logical contact it found its first force.
        let loaded = -c.kn * (l.gap - l.offset);
        if (l.kind != LOGICAL_EDGE_EDGE) {
            l.normal_force = loaded;
        } else if (l.normal_force == 0.0) {
            l.normal_force = max(min(loaded, -c.kn * un * dt), 0.0);
        } else {
            l.normal_force = max(l.normal_force - c.kn * un * dt, 0.0);
        }
        // Eq. (17): the previous shear force turned into the new plane, magnitude kept.
        var fs = shear_of(l);
        if (any(old != n)) {
            let magnitude = length3(fs);
            fs = fs - n * dot3(n, fs);
            let left = length3(fs);
            if (left > 0.0) {
                fs = fs * (magnitude / left);
            } else {
                fs = vec3<real>(0.0, 0.0, 0.0);
            }
        }
        let held = fs;
        fs = fs - us * (c.ks * dt);
        // Eq. (20): Coulomb's limit with cohesion.
        let limit = c.cohesion + c.friction * l.normal_force;
        let size = length3(fs);
        if (size > limit) {
            let kept = max(limit, 0.0);
            if (size > 0.0) {
                fs = fs * (kept / size);
            } else {
                fs = fs * 0.0;
            }
            friction += slip_work(held, fs, us * dt, c.ks);
        }
        l.sx = fs.x;
        l.sy = fs.y;
        l.sz = fs.z;
        logicals[k] = l;
    }
    return vec2<real>(friction, released);
}

// The strain energy of a logical contact's springs, Fn²/2kn + |Fs|²/2ks (`cpu::spring_energy`).
fn spring_energy(l: Logical, c: Contact) -> real {
    var e: real = 0.0;
    if (c.kn > 0.0) {
        e += 0.5 * l.normal_force * l.normal_force / c.kn;
    }
    if (c.ks > 0.0) {
        let fs = shear_of(l);
        e += 0.5 * dot3(fs, fs) / c.ks;
    }
    return e;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn track_contact(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let ci = item_index(wg, li);
    if (ci >= params.contacts) {
        return;
    }
    var c = contacts[ci];
    let tol = params.tol;
    if (RELATIVE) {
        let d = centroid_pair_from(c.block2, c.block1);
        frame_half = Pair(d.hi * 0.5, d.lo * 0.5);
    }
    // The bodies' records: the geometry's (`contact_bodies`).
    owners = vec2<u32>(c.block1, c.block2);
    let a = adjacency[contact_bodies(ci)];
    let b = adjacency[contact_bodies(ci) + 1u];
    frame_origin = a;
    // Boxes apart by more than the contact-forming distance: the bodies are.
    // (And the means of the bodies' vertices, for the common plane's bound.)
    var a0 = block_vertex(a, 0u);
    var a1 = a0;
    var sum_a = a0;
    for (var k = 1u; k < blocks[a].vertex_count; k++) {
        let v = block_vertex(a, k);
        a0 = min(a0, v);
        a1 = max(a1, v);
        sum_a += v;
    }
    var b0 = block_vertex(b, 0u);
    var b1 = b0;
    var sum_b = b0;
    for (var k = 1u; k < blocks[b].vertex_count; k++) {
        let v = block_vertex(b, k);
        b0 = min(b0, v);
        b1 = max(b1, v);
        sum_b += v;
    }
    let gaps = max(b0 - a1, a0 - b1);
    let apart = max(max(gaps.x, gaps.y), gaps.z) > tol;
    var plane = Plane3(normal_of(c), FINITE_MAX, NO_FACE, false);
    if (!apart) {
        plane = common_plane(a, b, tol, normal_of(c), sum_a / real(blocks[a].vertex_count), sum_b / real(blocks[b].vertex_count));
    }
    let old = normal_of(c);
    c.nx = plane.normal.x;
    c.ny = plane.normal.y;
    c.nz = plane.normal.z;
    if (apart || plane.separation > tol) {
        // Parted: the logical contacts go, their springs' energy released.
        var released: real = 0.0;
        for (var j = 0u; j < c.logical_count; j++) {
            let k = c.logical_start + j;
            if (logicals[k].live != 0u) {
                released += spring_energy(logicals[k], c);
                logicals[k].live = 0u;
                logicals[k].normal_force = 0.0;
                logicals[k].sx = 0.0;
                logicals[k].sy = 0.0;
                logicals[k].sz = 0.0;
            }
        }
        c.released_work += released;
        contacts[ci] = c;
        return;
    }
    let n = plane.normal;
    let hi_a = support(a, n, false);
    let lo_b = support(b, n, true);
    let least_a = facing_least(a, n, false);
    let least_b = facing_least(b, n, true);
    for (var j = 0u; j < c.logical_count; j++) {
        let k = c.logical_start + j;
        if (logicals[k].live == 0u) {
            continue;
        }
        let placed = place_logical(logicals[k], a, b, n, hi_a, lo_b, plane.separation, least_a, least_b);
        var point = placed.point;
        if (RELATIVE) {
            // From the midpoint to block 1's centroid, where the points are kept.
            point = point + midpoint_from_first();
        }
        logicals[k].px = point.x;
        logicals[k].py = point.y;
        logicals[k].pz = point.z;
        logicals[k].gap = placed.gap;
    }
    let work = force_law(c, old, params.dt);
    c.friction_work += work.x;
    c.released_work += work.y;
    contacts[ci] = c;
}
