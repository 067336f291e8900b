// Stage 5: fluid flow in joints and voids (SL-85-1 Appendix A ¶6–9, ¶19). Twin of
// src/udec/cpu/flow.rs on the pure pieces of `model::fluid`; compiled and dispatched only in a
// scene with fluid (`gpu::flow`), after the contact stage (the joints' apertures read the normal
// forces it has just set), in three passes, none reading what its own pass writes:
//
// 1. `flow`, per contact (the entry point named after the file; the loop body of
//    `model::fluid::contact_flows`): its aperture, its flow q = k_c·Δp across a point contact or
//    k_j·a³·Δp/l along a joint (¶6) at the pressures of the last step, and its feet;
// 2. `domain_terms`, per term of a long domain's sums (a void of many links, a long flow list:
//    see there), only where there are such domains; in f32 with deformable blocks, then
//    `corner_moves_sdef` or `corner_moves_fdef` (per block) and `deformed_terms` (per link of a
//    void they bound: the change of its area by its boundary's motion, see there);
// 3. `domain_pressures`, per domain: its inflow summed over its flows in ascending contact order
//    (the CPU's order: reruns repeat bit for bit, and f64 agrees with the CPU to round-off), its
//    area now, and the pressure update with its change of volume (¶7); a PFIX domain and the
//    outer domain keep theirs. A free domain then copies its new pressure into each of its
//    contacts' flow slots (`ContactFlow::p0`, `p1`: each contact's two domains write one each).
//
// The loads the pressures put on the blocks (buoyancy and the pressure jump at each contact's
// foot, the CPU's `block_load`) are summed by the next cycle's block pass in the same walk of a
// block's list as its contact forces (`force_sum_fluid`, gather.wgsl; `law_of_motion_fluid`).

// A corner's position relative to its block's centroid.
fn corner_at(i: u32) -> vec2<real> {
    return vec2<real>(corners[i].px, corners[i].py);
}

// Contact c's feet (twin of `model::fluid::contact_foot`): side 0, block 1's corner, from block
// 1's centroid; side 1, block 2's corner or the foot of block 1's corner on block 2's edge
// (within the edge), from block 2's centroid.
fn contact_feet(c: Contact) -> array<vec2<real>, 2> {
    let p1 = corner_at(c.corner);
    let b2 = blocks[c.block2];
    let n = max(b2.corner_count, 1u);
    let k = (c.feature / 2u) % n;
    let p = corner_at(b2.corner_start + k);
    if (c.feature % 2u == 0u) {
        return array<vec2<real>, 2>(p1, p);
    }
    let q = corner_at(b2.corner_start + (k + 1u) % n);
    let corner = centroid_difference(blocks[c.block1], b2) + p1;
    let e = q - p;
    let len2 = e.x * e.x + e.y * e.y;
    var t = real(0.0);
    if (len2 > 0.0) {
        t = clamp(((corner.x - p.x) * e.x + (corner.y - p.y) * e.y) / len2, 0.0, 1.0);
    }
    return array<vec2<real>, 2>(p1, vec2<real>(p.x + t * e.x, p.y + t * e.y));
}

// A joint's hydraulic aperture a = max(a_res, a_0 − σn′/k_n,j), 0 for a point contact (twin of
// `model::fluid::aperture`).
fn aperture(c: Contact, jkn: real, f: FluidMaterial) -> real {
    if (c.length <= 0.0) {
        return 0.0;
    }
    let sigma = c.normal_force / c.length;
    var closure = real(0.0);
    if (jkn > 0.0) {
        closure = sigma / jkn;
    }
    return max(f.azero - closure, f.ares);
}

// q = conductance·Δp: k_j·a³/l_c along a joint, k_c across a point contact (twin of
// `model::fluid::conductance`).
fn conductance(c: Contact, f: FluidMaterial, a: real) -> real {
    if (c.length > 0.0) {
        return f.jperm * a * a * a / c.length;
    }
    return f.cperm;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn flow(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = item_index(wg, li);
    if (k >= params.n_contacts) {
        return;
    }
    let c = contacts[k];
    let f = fluid_materials[c.material];
    let a = aperture(c, materials[c.material].jkn, f);
    let feet = contact_feet(c);
    let d0 = contact_sides[2u * k];
    let d1 = contact_sides[2u * k + 1u];
    var q = real(0.0);
    if (d0 != NO_INDEX && d0 != d1) {
        q = conductance(c, f, a) * (domains[d0].pressure - domains[d1].pressure);
        // A pressure or flow past the precision (a flow law or a fluid stiff past it) stops the
        // run, as the CPU's energy check does (`CycleError::non_finite_pressure`): between fixed
        // blocks no step would see it. The error names the read-back domain (`error_from_flags`).
        if (!is_finite(q)) {
            atomicOr(&flags.errors, ERR_NONFINITE);
            atomicMin(&flags.nonfinite_block, c.block1);
        }
    }
    // Field by field: the domains' pressures in the slot (`p0`, `p1`) are `domain_pressures`'.
    contact_flows_out[k].flow = q;
    contact_flows_out[k].aperture = a;
    contact_flows_out[k].length = c.length;
    contact_flows_out[k].f0x = feet[0].x;
    contact_flows_out[k].f0y = feet[0].y;
    contact_flows_out[k].f1x = feet[1].x;
    contact_flows_out[k].f1y = feet[1].y;
}

// Where a domain link's vertex t (0 or 1 of a contact's two feet, in circuit order; 0 of a
// corner) lies relative to the centroid of block `reference`.
fn link_vertex(l: u32, t: u32, reference: Block) -> vec2<real> {
    let bits = domain_links[4u * l];
    let index = domain_links[4u * l + 1u];
    if ((bits & LINK_CORNER) != 0u) {
        return centroid_difference(blocks[domain_links[4u * l + 2u]], reference) + corner_at(index);
    }
    // A contact gives the foot the circuit arrives at (the other side's), then its own side's.
    var side = bits & LINK_SIDE;
    if (t == 0u) {
        side = 1u - side;
    }
    // Field by field (here and below): the same pass writes the slots' pressures.
    var foot = vec2<real>(contact_flows_out[index].f0x, contact_flows_out[index].f0y);
    if (side == 1u) {
        foot = vec2<real>(contact_flows_out[index].f1x, contact_flows_out[index].f1y);
    }
    return centroid_difference(blocks[domain_links[4u * l + 2u + side]], reference) + foot;
}

fn cross2(p: vec2<real>, q: vec2<real>) -> real {
    return p.x * q.y - q.x * p.y;
}

// The area the fluid calculation gives domain `dom` now (twin of `model::fluid::fluid_area`): a
// regular domain's void (its loops' area, with the current positions, measured from one block's
// centroid so that f32 keeps a small void's digits), a joint's mean aperture times its length,
// never below A_d(min); 0 for the outer domain.
fn fluid_area(dom: Domain) -> real {
    if (dom.kind == DOMAIN_OUTER) {
        return 0.0;
    }
    let first = dom.link_start;
    let end = dom.link_start + dom.link_count;
    if (dom.kind == DOMAIN_JOINT) {
        var n = 0u;
        var sum = real(0.0);
        var a0 = real(0.0);
        for (var l = first; l < end; l += 1u) {
            if ((domain_links[4u * l] & LINK_CORNER) != 0u) {
                continue;
            }
            let k = domain_links[4u * l + 1u];
            if (contact_flows_out[k].length > 0.0) {
                let aperture = contact_flows_out[k].aperture;
                if (n == 0u) {
                    a0 = aperture;
                } else {
                    sum = a0 + aperture;
                }
                n += 1u;
            }
        }
        if (n == 2u) {
            return max(0.5 * sum * dom.length, fluid_params.min_area);
        }
        return fluid_params.min_area;
    }
    if (dom.link_count == 0u) {
        return fluid_params.min_area;
    }
    if (dom.kind == DOMAIN_REGULAR && dom.link_count > fluid_params.long_walk) {
        return max(summed_terms(dom), fluid_params.min_area);
    }
    let reference = blocks[domain_links[4u * first + 2u]];
    var void_area = real(0.0);
    var s = real(0.0);
    var start = vec2<real>(0.0, 0.0);
    var prev = vec2<real>(0.0, 0.0);
    var open = false;
    for (var l = first; l < end; l += 1u) {
        let bits = domain_links[4u * l];
        if ((bits & LINK_LOOP_START) != 0u && open) {
            // Close the loop: its last edge back to its first vertex.
            s += cross2(prev, start);
            void_area += -(0.5 * s);
            s = 0.0;
            open = false;
        }
        var count = 2u;
        if ((bits & LINK_CORNER) != 0u) {
            count = 1u;
        }
        for (var t = 0u; t < count; t += 1u) {
            let v = link_vertex(l, t, reference);
            if (open) {
                s += cross2(prev, v);
            } else {
                start = v;
                open = true;
            }
            prev = v;
        }
    }
    if (open) {
        s += cross2(prev, start);
        void_area += -(0.5 * s);
    }
    return max(void_area, fluid_params.min_area);
}

// A block's motion in this step as the law of motion took it: Δx = v·Δt, and the turn Δθ = ω·Δt
// as sin Δθ and 1 − cos Δθ (`Motion::turn`).
struct Motion {
    shift: vec2<real>,
    turn: vec2<real>,
}

// Block `b`'s motion in this step (its velocities were set by this cycle's law of motion, zero
// for a fixed block). Δθ is small (a corner travels less than the contact tolerance in a step,
// the too-fast check), so sin Δθ and 1 − cos Δθ are their series to Δθ³ and Δθ⁴ (the next
// terms under 1e-10 of Δθ for |Δθ| < 0.01), without cancellation.
fn motion(b: u32) -> Motion {
    let dt = params.dt;
    let a = blocks[b].w * dt;
    let a2 = a * a;
    return Motion(vec2<real>(blocks[b].vx * dt, blocks[b].vy * dt), vec2<real>(a - a * a2 / 6.0, 0.5 * a2 - a2 * a2 / 24.0));
}

// How far the point at `r` from the centroid of a block with motion `m` moved in this step:
// the shift and r − R(−Δθ)·r.
fn moved_by(m: Motion, r: vec2<real>) -> vec2<real> {
    let s = m.turn.x;
    let c1 = m.turn.y;
    return m.shift + vec2<real>(c1 * r.x - s * r.y, s * r.x + c1 * r.y);
}

// A vertex of a domain's boundary is a vec4 here: its position (`link_vertex`, from the centroid
// of the domain's reference block) in xy and how far it moved in this step in zw.

// The change of the edge p → q's term of the shoelace sum, p × q, when both vertices move back
// by their motion: p × q − (p − d_p) × (q − d_q).
fn edge_change(p: vec4<real>, q: vec4<real>) -> real {
    return cross2(p.xy, q.zw) + cross2(p.zw, q.xy) - cross2(p.zw, q.zw);
}

// A loop's shoelace sum of changes as `void_step` walks it: the sum, the loop's first vertex and
// the last one, and whether a loop is open.
struct VoidWalk {
    s: real,
    start: vec4<real>,
    prev: vec4<real>,
    open: bool,
}

// The walk `w` with the next vertex `v` of its loop.
fn walk_to(w_in: VoidWalk, v: vec4<real>) -> VoidWalk {
    var w = w_in;
    if (w.open) {
        w.s += edge_change(w.prev, v);
    } else {
        w.start = v;
        w.open = true;
    }
    w.prev = v;
    return w;
}

// Link l's vertices in circuit order (a corner's one twice), each with how far it moved in this
// step, from the centroid of block `reference` (see `void_step`).
fn moving_vertices(l: u32, reference: Block) -> array<vec4<real>, 2> {
    let bits = domain_links[4u * l];
    let index = domain_links[4u * l + 1u];
    let b1 = domain_links[4u * l + 2u];
    if ((bits & LINK_CORNER) != 0u) {
        let r = corner_at(index);
        let v = vec4<real>(centroid_difference(blocks[b1], reference) + r, moved_by(motion(b1), r));
        return array<vec4<real>, 2>(v, v);
    }
    let b2 = domain_links[4u * l + 3u];
    let f0 = vec2<real>(contact_flows_out[index].f0x, contact_flows_out[index].f0y);
    let f1 = vec2<real>(contact_flows_out[index].f1x, contact_flows_out[index].f1y);
    return feet_moving(l, reference, f0, moved_by(motion(b1), f0), f1, moved_by(motion(b2), f1));
}

// Contact link l's two feet f0 (from block 1's centroid) and f1 (from block 2's) in circuit
// order, from the centroid of block `reference`, with their moves: d0 block 1's corner's, d1 block
// 2's material point's under the foot, to which a foot on block 2's edge (an odd feature) adds
// its slide along the edge with the corner it is the foot of (the tangential part of the
// corner's move relative to that point; `contact_feet`).
fn feet_moving(l: u32, reference: Block, f0: vec2<real>, d0: vec2<real>, f1: vec2<real>, d1_point: vec2<real>) -> array<vec4<real>, 2> {
    let bits = domain_links[4u * l];
    let index = domain_links[4u * l + 1u];
    var d1 = d1_point;
    if (contacts[index].feature % 2u == 1u) {
        let rel = d0 - d1;
        let n = vec2<real>(contacts[index].nx, contacts[index].ny);
        d1 += rel - dot(rel, n) * n;
    }
    let v0 = vec4<real>(centroid_difference(blocks[domain_links[4u * l + 2u]], reference) + f0, d0);
    let v1 = vec4<real>(centroid_difference(blocks[domain_links[4u * l + 3u]], reference) + f1, d1);
    // The foot the circuit arrives at (the other side's), then its own side's.
    let own_is_1 = (bits & LINK_SIDE) != 0u;
    return array<vec4<real>, 2>(select(v1, v0, own_is_1), select(v0, v1, own_is_1));
}

// The change of regular domain `dom`'s void in this step, from its boundary's motion
// (AREA_BY_MOTION): with each vertex v_i now and d_i how far it moved, each loop's area before
// the step is A(v − d), so A(v) − A(v − d) = −½·Σ (v_i × d_i+1 + d_i × v_i+1 − d_i × d_i+1) over its
// edges (the circuits run clockwise: `fluid_area`'s sign). The terms are as small as the motion,
// so f32 keeps the change's own digits, where the difference of two f32 areas kept those of the
// areas (a void's pressure takes bulkw/A times the change). The vertices as `link_vertex` gives
// them, in its order: a corner moves with its block; a contact's foot on side 0 (block 1's
// corner) with block 1, its foot on side 1 with block 2, and a foot on block 2's edge (an odd
// feature) slides along the edge with the corner it is the foot of as well (`contact_feet`): by
// the tangential part of the corner's motion relative to block 2's point there (the edge's
// direction being the contact's tangent). Exact for the rigid motion of the corners.
fn void_step(dom: Domain) -> real {
    let first = dom.link_start;
    let end = dom.link_start + dom.link_count;
    let reference = blocks[domain_links[4u * first + 2u]];
    var change = real(0.0);
    var w = VoidWalk(0.0, vec4<real>(0.0, 0.0, 0.0, 0.0), vec4<real>(0.0, 0.0, 0.0, 0.0), false);
    for (var l = first; l < end; l += 1u) {
        let bits = domain_links[4u * l];
        if ((bits & LINK_LOOP_START) != 0u && w.open) {
            change += -(0.5 * (w.s + edge_change(w.prev, w.start)));
            w.s = 0.0;
            w.open = false;
        }
        let v = moving_vertices(l, reference);
        w = walk_to(w, v[0]);
        if ((bits & LINK_CORNER) == 0u) {
            w = walk_to(w, v[1]);
        }
    }
    if (w.open) {
        change += -(0.5 * (w.s + edge_change(w.prev, w.start)));
    }
    return change;
}

// A domain whose boundary has more than `fluid_params.long_walk` links, or whose free pressure
// gathers more flows than that, does not walk them in one invocation of `domain_pressures`: the
// bench wall's void along the ground block's top (197 links and 120 flows, where the wall's
// other voids have 3 or 7 links) made that pass one thread's chain of dependent loads, a
// link's feet, blocks and corners after its word, the whole of a small wall's cycle on a GPU.
// `domain_terms` computes each term of those sums in parallel, one item each, and
// `domain_pressures` adds them in the walk's order, which is the CPU's: a rerun repeats bit for
// bit, and each term is the walk's own expression on the same operands, so the result is the
// walk's (to the byte on lavapipe for the bench wall, f32 and f64, and for sample 2's pressurized
// voids in f32 with every void split, `BLOCKDEM_LONG_WALK=0`; sample 2 in f64 so split moved by
// 2e-12 of its pressure: the compiler may fuse a vertex's products otherwise in the two passes,
// and the default splits none of its domains). An item is
// four words in `term_items` (`gpu::flow::term_items`):
// - TERM_FLOW, entry e of `domain_flows`: the flow signed as the domain gathers it, at
//   2·n_links + e (q − f is q + (−f), exactly);
// - DOMAIN_REGULAR, link l, the link before it in its loop (the loop's last for its first), the
//   domain's reference block: at 2·l the term of the edge from the last vertex of the link
//   before to l's first (for a loop's first link, the loop's closing edge, added last), at
//   2·l + 1 a contact's own edge, from its first vertex to its second: `edge_change` on the
//   vertices' motion in f32 (`void_step`), `cross2` on their positions in f64 (`fluid_area`).
// A void bounded by a deformable block (DOMAIN_REGULAR_DEFORMED) is walked in f64 whatever its
// length; in f32 its items (tagged so) are `deformed_terms`', which this pass leaves.
const TERM_FLOW: u32 = 16u;

@compute @workgroup_size(WORKGROUP_SIZE)
fn domain_terms(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= fluid_params.n_term_items) {
        return;
    }
    let tag = term_items[4u * i];
    let l = term_items[4u * i + 1u];
    if (tag == TERM_FLOW) {
        let entry = domain_flows[l];
        let flow = contact_flows_out[entry >> 1u].flow;
        sum_terms[2u * fluid_params.n_links + l] = select(-flow, flow, (entry & 1u) != 0u);
        return;
    }
    // A deformed void's items are `deformed_terms`' (f32 only).
    if (tag == DOMAIN_REGULAR_DEFORMED) {
        return;
    }
    let before = term_items[4u * i + 2u];
    let reference = blocks[term_items[4u * i + 3u]];
    let corner = (domain_links[4u * l] & LINK_CORNER) != 0u;
    if (AREA_BY_MOTION && tag == DOMAIN_REGULAR) {
        let p = moving_vertices(before, reference);
        let v = moving_vertices(l, reference);
        sum_terms[2u * l] = edge_change(p[1], v[0]);
        if (!corner) {
            sum_terms[2u * l + 1u] = edge_change(v[0], v[1]);
        }
        return;
    }
    var last = 1u;
    if ((domain_links[4u * before] & LINK_CORNER) != 0u) {
        last = 0u;
    }
    let v0 = link_vertex(l, 0u, reference);
    sum_terms[2u * l] = cross2(link_vertex(before, last, reference), v0);
    if (!corner) {
        sum_terms[2u * l + 1u] = cross2(v0, link_vertex(l, 1u, reference));
    }
}

// Voids with a deformable block on their boundary, in f32 (AREA_BY_MOTION): measured from their
// outline each step, such a void's area carried the outline's round-off (each vertex at ~1e-7
// of its distance from the reference centroid), and the pressure update takes bulkw/A times the
// area's change each step: in the zoned cavity's small void (tests/suite/fluid_deformable.rs) a
// noise of 2 % of the pressure. Followed instead by its boundary's motion, as the voids of rigid
// blocks are (`void_step`), the change is as small as the motion and keeps its own digits. The
// motion of each corner first (`corner_moves_sdef`, `corner_moves_fdef`, per block; twin
// `gpu::flow::corner_moves`), then each edge's term of the change (`deformed_terms`, one item
// per link of such a void), which `domain_pressures` adds in the walk's order (`summed_terms`).

// Rigid and simply-deformable blocks' corners: the block's rigid motion at the corner
// (`moved_by`) and, for an SDEF block, the strain's increment ε̇·Δt at the corner's offset r
// (its corners sit at c + (I + ε)R·x, so the increment is Δε·R·x = Δε·(I + ε)⁻¹·r: r for
// R·x, a relative error of the strain's order, ~1e-4, in a move that is itself a step's).
@compute @workgroup_size(WORKGROUP_SIZE)
fn corner_moves_sdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    let m = motion(b);
    let sdef = blk.kind == BLOCK_SDEF && blk.fixed == 0u;
    var rate = array<real, 3>(0.0, 0.0, 0.0);
    if (sdef) {
        rate = sdefs[b].strain_rate;
    }
    let dt = params.dt;
    for (var i = blk.corner_start; i < blk.corner_start + blk.corner_count; i += 1u) {
        let r = corner_at(i);
        var d = moved_by(m, r);
        if (sdef) {
            d += dt * vec2<real>(rate[0] * r.x + rate[1] * r.y, rate[1] * r.x + rate[2] * r.y);
        }
        corner_moves[i] = CornerMove(d.x, d.y);
    }
}

// Zoned blocks' corners, which are their boundary grid points (corner k is grid point
// gp_start + k): each grid point's v·Δt, the step its law of motion took (`step_gridpoints`);
// rigid blocks' as `corner_moves_sdef`.
@compute @workgroup_size(WORKGROUP_SIZE)
fn corner_moves_fdef(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    if (b >= params.n_blocks) {
        return;
    }
    let blk = blocks[b];
    let dt = params.dt;
    if (blk.kind == BLOCK_FDEF) {
        let fb = fdef_blocks[b];
        for (var k = 0u; k < fb.boundary; k += 1u) {
            var d = vec2<real>(0.0, 0.0);
            if (fb.fixed == 0u) {
                let g = gridpoints[fb.gp_start + k];
                d = vec2<real>(g.vx * dt, g.vy * dt);
            }
            corner_moves[blk.corner_start + k] = CornerMove(d.x, d.y);
        }
        return;
    }
    let m = motion(b);
    for (var i = blk.corner_start; i < blk.corner_start + blk.corner_count; i += 1u) {
        let d = moved_by(m, corner_at(i));
        corner_moves[i] = CornerMove(d.x, d.y);
    }
}

fn corner_move(i: u32) -> vec2<real> {
    return vec2<real>(corner_moves[i].dx, corner_moves[i].dy);
}

// `moving_vertices` on any blocks, the corners' moves from `corner_moves`: a corner and a foot
// at a corner move with it; a foot on block 2's edge (an odd feature) with the edge's point
// under it, the edge's two corners' moves interpolated (exact for a rigid or SDEF block's
// motion, linear in the point, and for a zoned block's edge, along which its zone's displacement
// is linear), and its slide along the edge (`feet_moving`).
fn moving_vertices_deformed(l: u32, reference: Block) -> array<vec4<real>, 2> {
    let bits = domain_links[4u * l];
    let index = domain_links[4u * l + 1u];
    let b1 = domain_links[4u * l + 2u];
    if ((bits & LINK_CORNER) != 0u) {
        let v = vec4<real>(centroid_difference(blocks[b1], reference) + corner_at(index), corner_move(index));
        return array<vec4<real>, 2>(v, v);
    }
    let b2 = domain_links[4u * l + 3u];
    let c = contacts[index];
    let f0 = vec2<real>(contact_flows_out[index].f0x, contact_flows_out[index].f0y);
    let f1 = vec2<real>(contact_flows_out[index].f1x, contact_flows_out[index].f1y);
    let d0 = corner_move(c.corner);
    let blk2 = blocks[b2];
    let n = max(blk2.corner_count, 1u);
    let k = (c.feature / 2u) % n;
    var d1 = corner_move(blk2.corner_start + k);
    if (c.feature % 2u == 1u) {
        let next = blk2.corner_start + (k + 1u) % n;
        let p = corner_at(blk2.corner_start + k);
        let e = corner_at(next) - p;
        let len2 = e.x * e.x + e.y * e.y;
        var t = real(0.0);
        if (len2 > 0.0) {
            t = clamp(((f1.x - p.x) * e.x + (f1.y - p.y) * e.y) / len2, 0.0, 1.0);
        }
        d1 += t * (corner_move(next) - d1);
    }
    return feet_moving(l, reference, f0, d0, f1, d1);
}

// Each edge's term of a deformed void's change in this step (f32), one invocation per item of
// `term_items` tagged DOMAIN_REGULAR_DEFORMED (the others are `domain_terms`'): at 2·l the edge
// from the last vertex of the link before to l's first, at 2·l + 1 a contact's own edge, as
// `domain_terms` writes a long rigid void's.
@compute @workgroup_size(WORKGROUP_SIZE)
fn deformed_terms(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= fluid_params.n_term_items || term_items[4u * i] != DOMAIN_REGULAR_DEFORMED) {
        return;
    }
    let l = term_items[4u * i + 1u];
    let before = term_items[4u * i + 2u];
    let reference = blocks[term_items[4u * i + 3u]];
    let p = moving_vertices_deformed(before, reference);
    let v = moving_vertices_deformed(l, reference);
    sum_terms[2u * l] = edge_change(p[1], v[0]);
    if ((domain_links[4u * l] & LINK_CORNER) == 0u) {
        sum_terms[2u * l + 1u] = edge_change(v[0], v[1]);
    }
}

// A long domain's void or its change in this step (`void_step`'s sum, or `fluid_area`'s before
// A_d(min)) from its terms, in the walk's order: each loop's edges as the walk meets them, its
// closing edge last, −½ times the loop's sum added loop by loop.
fn summed_terms(dom: Domain) -> real {
    let end = dom.link_start + dom.link_count;
    var total = real(0.0);
    var s = real(0.0);
    var close = real(0.0);
    var open = false;
    for (var l = dom.link_start; l < end; l += 1u) {
        let bits = domain_links[4u * l];
        if ((bits & LINK_LOOP_START) != 0u && open) {
            total += -(0.5 * (s + close));
            s = 0.0;
            open = false;
        }
        if (open) {
            s += sum_terms[2u * l];
        } else {
            close = sum_terms[2u * l];
            open = true;
        }
        if ((bits & LINK_CORNER) == 0u) {
            s += sum_terms[2u * l + 1u];
        }
    }
    if (open) {
        total += -(0.5 * (s + close));
    }
    return total;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn domain_pressures(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let d = item_index(wg, li);
    if (d >= fluid_params.n_domains) {
        return;
    }
    var dom = domains[d];
    var area = real(0.0);
    // The change of area in this step.
    var da = real(0.0);
    let by_motion = dom.kind == DOMAIN_REGULAR || dom.kind == DOMAIN_REGULAR_DEFORMED;
    if (AREA_BY_MOTION && by_motion && dom.link_count > 0u) {
        // The void followed by its boundary's motion from the upload's (`void_step`; a deformed
        // void's terms are `deformed_terms`'); the change is the step's own, unless A_d(min)
        // held the area before or after it.
        var step = real(0.0);
        if (dom.kind == DOMAIN_REGULAR_DEFORMED || dom.link_count > fluid_params.long_walk) {
            step = summed_terms(dom);
        } else {
            step = void_step(dom);
        }
        let before = dom.void_base + dom.void_change;
        let change = dom.void_change + step;
        let now = dom.void_base + change;
        area = max(now, fluid_params.min_area);
        da = area - dom.area;
        if (before >= fluid_params.min_area && now >= fluid_params.min_area) {
            da = step;
        }
        domains[d].void_change = change;
    } else {
        area = fluid_area(dom);
        da = area - dom.area;
    }
    if (dom.free != 0u) {
        var q = real(0.0);
        let end = dom.flow_start + dom.flow_count;
        if (dom.flow_count > fluid_params.long_walk) {
            // The flows signed by `domain_terms`, in the same order.
            for (var e = dom.flow_start; e < end; e += 1u) {
                q += sum_terms[2u * fluid_params.n_links + e];
            }
        } else {
            for (var e = dom.flow_start; e < end; e += 1u) {
                let entry = domain_flows[e];
                let flow = contact_flows_out[entry >> 1u].flow;
                if ((entry & 1u) != 0u) {
                    q += flow;
                } else {
                    q -= flow;
                }
            }
        }
        q = q * params.dt;
        // ¶7 with the domain's change of volume: the fluid mass A(1 + p/bulkw) changes by the
        // inflow alone (twin of `model::fluid::pressure_step`).
        if (AREA_BY_MOTION) {
            // The same update as p + [bulkw·(Q·Δt − ΔA) − p·ΔA]/A_new (A_new = A_old + ΔA), which
            // rounds the increment, not the pressure's whole: the area enters as a scale only.
            dom.pressure = dom.pressure + (fluid_params.bulk * (q - da) - dom.pressure * da) / area;
        } else {
            dom.pressure = (dom.area * dom.pressure + fluid_params.bulk * (q - (area - dom.area))) / area;
        }
        domains[d].pressure = dom.pressure;
        domains[d].inflow = dom.inflow + q;
        // The new pressure next to each of its contacts' feet, for the next cycle's gather
        // (`add_pressure_load`, gather.wgsl): this domain's side of the slot only, the other
        // domain of the contact writing the other (a fixed domain's stays as uploaded).
        for (var e = dom.flow_start; e < end; e += 1u) {
            let entry = domain_flows[e];
            if ((entry & 1u) != 0u) {
                contact_flows_out[entry >> 1u].p1 = dom.pressure;
            } else {
                contact_flows_out[entry >> 1u].p0 = dom.pressure;
            }
        }
    }
    domains[d].area = area;
}

// The pressures' push on deformable blocks (a scene with fluid and simply-deformable or zoned
// blocks only; twin of `model::fluid::pressure_pieces`, the CPU's `deformable_pressure_loads`):
// per domain, at the start of a cycle (the feet of the last `flow` pass, the corners as the last
// block pass placed them, the pressures of the last `domain_pressures`, as the CPU's stage 5
// took them), each piece of block boundary around it, one per link: from the link's last vertex
// to the next vertex of its loop, on the link's own block (the circuit keeps the void on its
// right, the block on its left). A uniform pressure p on a piece from a to b is the force
// p·perp(b − a), perp(v) = (−v_y, v_x), spread evenly along it (¶19):
// - on a simply-deformable block its Σ r ⊗ f is exactly (m − c) ⊗ p·perp(b − a), m the piece's
//   midpoint, c the centroid: the piece's share of the block's applied stress times area (KSA);
// - on a zoned block the force is split between the grid points of the piece's edge k, k + 1 by
//   the edge's linear shape functions, 1 − t̄ and t̄ with t̄ the mean of the ends' parameters
//   along the edge, so that the grid points' loads do the work the pressure does.
// Each piece is written at its link's index; `fluid_block_loads` (gather.wgsl) and
// `gridpoint_fluid_loads` (zones.wgsl) gather a block's pieces in ascending link order, which is
// the CPU's order of domains and of each circuit: a rerun repeats bit for bit.

// The block the piece after link l lies on: a contact's own side's block, a corner's block.
fn piece_block(l: u32) -> u32 {
    let bits = domain_links[4u * l];
    if ((bits & LINK_CORNER) != 0u) {
        return domain_links[4u * l + 2u];
    }
    return domain_links[4u * l + 2u + (bits & LINK_SIDE)];
}

// The edge of block `blk` the piece after link l lies on (the index within the block of the
// corner the edge starts at): a corner's own edge; a contact's, on side 0 block 1's corner's
// edge, on side 1 the edge of block 2 it touches.
fn piece_edge(l: u32, blk: Block) -> u32 {
    let bits = domain_links[4u * l];
    let index = domain_links[4u * l + 1u];
    if ((bits & LINK_CORNER) != 0u) {
        return index - blk.corner_start;
    }
    let c = contacts[index];
    if ((bits & LINK_SIDE) == 0u) {
        return c.corner - blk.corner_start;
    }
    return (c.feature / 2u) % max(blk.corner_count, 1u);
}

// A point's parameter along the edge p → q, within the edge (½ for an edge of no length).
fn edge_parameter(x: vec2<real>, p: vec2<real>, q: vec2<real>) -> real {
    let e = q - p;
    let len2 = e.x * e.x + e.y * e.y;
    if (len2 > 0.0) {
        return clamp(((x.x - p.x) * e.x + (x.y - p.y) * e.y) / len2, 0.0, 1.0);
    }
    return 0.5;
}

// The piece after link l, which ends at the first vertex of link `next`, at pressure p.
fn write_piece(l: u32, next: u32, p: real) {
    let b = piece_block(l);
    let blk = blocks[b];
    if (p == 0.0 || (blk.kind != BLOCK_SDEF && blk.kind != BLOCK_FDEF)) {
        fluid_pieces[l].edge = NO_INDEX;
        return;
    }
    var last = 1u;
    if ((domain_links[4u * l] & LINK_CORNER) != 0u) {
        last = 0u;
    }
    // Both ends from the block's own centroid.
    let start = link_vertex(l, last, blk);
    let end = link_vertex(next, 0u, blk);
    let f = vec2<real>(-p * (end.y - start.y), p * (end.x - start.x));
    let edge = piece_edge(l, blk);
    if (blk.kind == BLOCK_SDEF) {
        let m = 0.5 * (start + end);
        fluid_pieces[l] = FluidPiece(m.x * f.x, m.x * f.y, m.y * f.x, m.y * f.y, edge, 0u);
        return;
    }
    let n = max(blk.corner_count, 1u);
    let pi = corner_at(blk.corner_start + edge % n);
    let pj = corner_at(blk.corner_start + (edge + 1u) % n);
    let tm = 0.5 * (edge_parameter(start, pi, pj) + edge_parameter(end, pi, pj));
    fluid_pieces[l] = FluidPiece((1.0 - tm) * f.x, (1.0 - tm) * f.y, tm * f.x, tm * f.y, edge, 0u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn pressure_pieces(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let d = item_index(wg, li);
    if (d >= fluid_params.n_domains) {
        return;
    }
    let dom = domains[d];
    let p = dom.pressure;
    let end = dom.link_start + dom.link_count;
    var loop_first = dom.link_start;
    for (var l = dom.link_start; l < end; l += 1u) {
        if ((domain_links[4u * l] & LINK_LOOP_START) != 0u) {
            loop_first = l;
        }
        // The next link of the loop, or back to the loop's first.
        var next = l + 1u;
        if (next >= end || (domain_links[4u * next] & LINK_LOOP_START) != 0u) {
            next = loop_first;
        }
        write_piece(l, next, p);
    }
}
