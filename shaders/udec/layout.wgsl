// The GPU structs, twins of src/gpu/layout.rs (sizes given as f32 / f64), and the layout of items
// over a dispatch: shared by every kernel, the cycle's (which add common.wgsl's bindings and
// helpers) and the topology kernels with bindings of their own (splice_contacts.wgsl). The Rust
// prelude in front of this file defines `alias real = f32;` or `f64`, WORKGROUP_SIZE and the
// other constants. Storage structs hold reals first and then an even number of u32 words, so both
// precisions have the same field order and no padding.

// 120 / 224 bytes. Centroid relative to the run's origin as a compensated pair (cx + cx_lo); in
// f32 the rotation as the angle the corners are placed at plus the turn since (rotation +
// rotation_lo; EXACT_CIRCLE, law_of_motion.wgsl), in f64 the rotation (rotation_lo 0);
// `work`, `damping_work`: external work and mass-damping dissipation since the upload;
// `moved` is the largest net displacement from the reference (update_*) of the last contact
// update, due for the next one past etol + update_margin (the block's speed margin).
struct Block {
    cx: real, cy: real, cx_lo: real, cy_lo: real,
    rotation: real, rotation_lo: real, vx: real, vy: real, w: real,
    fx: real, fy: real, moment: real, mass: real,
    inertia: real, load_x: real, load_y: real, radius: real,
    work: real, damping_work: real,
    moved: real, update_cx: real, update_cy: real, update_cx_lo: real, update_cy_lo: real, update_rotation: real, update_margin: real,
    fixed: u32, corner_start: u32, corner_count: u32,
    kind: u32, // BLOCK_RIGID or BLOCK_SDEF (its strain in `sdefs` at the block's index)
}

const BLOCK_RIGID: u32 = 0u;
const BLOCK_SDEF: u32 = 1u;
const BLOCK_FDEF: u32 = 2u; // zoned: its motion is its grid points' (zones.wgsl)

// 40 / 80 bytes. (px, py) corner and (ox, oy) circle centre relative to the block centroid. The
// edge to the next corner is measured where it is used (contact_forces.wgsl, `edge_from`); the
// block a corner belongs to is known to whoever reads it (the block's `corner_start`, a
// contact's `block1`), so it is not stored.
struct Corner {
    lx: real, ly: real, qx: real, qy: real, radius: real, round: real,
    px: real, py: real, ox: real, oy: real,
}

// 76 / 128 bytes. The point (px, py) is relative to block 2's centroid. slip_work, dashpot_work:
// dissipation since the upload; (dashpot_vn, dashpot_vs): the velocities the dashpots acted on in
// the last step, whose work is booked a step late; length: the length of joint the contact
// carries (¶5), 0 for a point contact (`contact_law`). The contact's force is kept once, in its
// `ContactForce` record (the gather's, read back with the contacts).
struct Contact {
    px: real, py: real, nx: real, ny: real, gap: real,
    normal_force: real, shear_force: real, shear_displacement: real,
    slip_work: real, dashpot_work: real, dashpot_vn: real, dashpot_vs: real,
    length: real,
    block1: u32, corner: u32, block2: u32, feature: u32,
    material: u32, bonded: u32,
}

// 16 / 32 bytes. What the gather needs of a contact: the force on block 1 (block 2 gets the
// reaction) and the moment of each about its own centroid (eq. 12), written by contact_forces.
struct ContactForce { fx: real, fy: real, m: array<real, 2> }

// 28 / 48 bytes. What a contact update reads back of a contact (pack_contacts.wgsl).
struct ContactSummary {
    gap: real, normal_force: real, shear_force: real, slip_work: real, dashpot_work: real,
    feature: u32, bonded: u32,
}

// 12 / 16 bytes. A kept contact the CPU read for a contact update: its law's length of joint,
// its index in the new list, the feature the update found (`patch_contacts`).
struct ContactPatch { length: real, index: u32, feature: u32 }

// 96 / 192 bytes. The simply-deformable extension of a block (twin of `layout::Sdef`, the model's
// `sdef::Sdef`): strain, strain rate and internal stress (11, 12, 22), applied stress times area
// (11, 12, 21, 22), the second moments of mass in the body frame, the strain at the last contact
// update, the internal damping's work since the upload, the area, Lamé's λ and G, and the
// Griffith strength (0: no candidate).
struct Sdef {
    strain: array<real, 3>,
    strain_rate: array<real, 3>,
    stress: array<real, 3>,
    applied: array<real, 4>,
    moments: array<real, 3>,
    update_strain: array<real, 3>,
    damping_work: real,
    area: real, lambda: real, shear: real,
    griffith_tf: real,
}

// 16 / 32 bytes. A contact's lever arms from block 1's and block 2's centroids to its point, for
// the applied stress of SDEF blocks (written by contact_forces_sdef).
struct ContactLever { r1x: real, r1y: real, r2x: real, r2y: real }

// 84 / 152 bytes. A grid point of a fully-deformable block (twin of `layout::GridPoint`):
// position relative to the run's origin as a compensated pair, velocity, force of the last
// gather, lumped mass, gravity's and the load's share (m·g + load·m/M), the position at its
// block's last contact update, the work and damping since the upload; its block, whether it is a
// boundary grid point (its block's corner), whether its block is fixed and whether it gathers
// from its own contact list.
struct GridPoint {
    x: real, y: real, x_lo: real, y_lo: real,
    vx: real, vy: real, fx: real, fy: real, mass: real,
    load_x: real, load_y: real,
    ux: real, uy: real, ux_lo: real, uy_lo: real,
    work: real, damping_work: real,
    block: u32, boundary: u32, fixed: u32, listed: u32,
}
// 28 / 40 bytes. A constant-strain triangle: stress (11, 12, 22), its grid points (global,
// counter-clockwise) and its block.
struct Zone { stress: array<real, 3>, g0: u32, g1: u32, g2: u32, block: u32 }
// 32 / 40 bytes. A fully-deformable block's λ, G, grid-point and zone ranges, whether fixed.
struct FdefBlock { lambda: real, shear: real, gp_start: u32, gp_count: u32, boundary: u32, zone_start: u32, zone_count: u32, fixed: u32 }
// 24 / 32 bytes. How a contact's force is shared to grid points (block 1's corner: g1; block 2:
// g2a and g2b with weights wa, wb), NO_INDEX where the block is not zoned.
struct ContactShare { wa: real, wb: real, g1: u32, g2a: u32, g2b: u32, _pad: u32 }
// Scenes with fluid only (twins of `layout::FluidParams` etc., flow.wgsl).
// 32 / 48 bytes (a uniform): bulkw, A_d(min), the number of domains, of domain links and of
// `domain_terms` items, and the length past which a domain's walk is split (`domain_terms`).
struct FluidParams { bulk: real, min_area: real, _r0: real, _r1: real, n_domains: u32, n_links: u32, n_term_items: u32, long_walk: u32 }
// 16 / 32 bytes (a uniform array of MAX_MATERIALS): JPERM, CPERM, AZERO, ARES.
struct FluidMaterial { jperm: real, cperm: real, azero: real, ares: real }
// 48 / 72 bytes. A domain: pressure, area at the last step, a joint's length, inflow since the
// upload, a regular domain's void at the upload and its change since (AREA_BY_MOTION); free (1:
// its pressure moves), kind (DOMAIN_*), its flows and its boundary links.
struct Domain {
    pressure: real, area: real, length: real, inflow: real, void_base: real, void_change: real,
    free: u32, kind: u32, flow_start: u32, flow_count: u32, link_start: u32, link_count: u32,
}
const DOMAIN_REGULAR: u32 = 0u;
const DOMAIN_JOINT: u32 = 1u;
const DOMAIN_OUTER: u32 = 2u;
const DOMAIN_REGULAR_DEFORMED: u32 = 3u;
// A domain link is four words in `domain_links`: bits (LINK_*), the contact or corner index, the
// block of the contact's side 0 (block 1) or the corner's block, the block of its side 1.
const LINK_SIDE: u32 = 1u;
const LINK_LOOP_START: u32 = 2u;
const LINK_CORNER: u32 = 4u;
// 36 / 72 bytes. A contact's flow (first domain to second), aperture and length of joint, its
// feet on side 0 (from block 1's centroid) and side 1 (from block 2's), and the pressures of its
// first and second domain as the last pressure update left them (equal for a contact that is not
// a link between two domains), which the gather's pressure loads read.
struct ContactFlow { flow: real, aperture: real, length: real, f0x: real, f0y: real, f1x: real, f1y: real, p0: real, p1: real }
// 12 / 24 bytes. A block's buoyancy and the work of its fluid load since the upload.
struct FluidLoad { buoy_x: real, buoy_y: real, work: real }

// Scenes with fluid and deformable blocks only (twins of `layout::FluidPiece` etc.).
// 24 / 40 bytes. A piece of block boundary around a domain (one per domain link): a
// simply-deformable block's applied stress times area from it, or a zoned block's force from
// it at the edge's first grid point (a0, a1) and second (a2, a3); its edge, NO_INDEX where it
// loads nothing.
struct FluidPiece { a0: real, a1: real, a2: real, a3: real, edge: u32, _pad: u32 }
// 28 / 56 bytes. A block's fluid load (buoyancy and pressure jumps) and a simply-deformable
// block's applied stress times area from its pieces.
struct BlockFluid { fx: real, fy: real, moment: real, a11: real, a12: real, a21: real, a22: real }
// 12 / 24 bytes. A grid point's fluid load and its work over the last step.
struct GridPointFluid { fx: real, fy: real, step_work: real }
// 8 / 16 bytes. How far a corner moved in this step (the f32 kernels' deformed voids followed by
// their boundary's motion: `corner_moves_*`, flow.wgsl), from the block's own velocities: a rigid
// or simply-deformable block's motion at the corner, a zoned block's grid point's v·Δt.
struct CornerMove { dx: real, dy: real }

// 32 / 64 bytes (a multiple of the 16-byte stride a uniform array needs, in both precisions):
// the point contact's KN, KS, COHESION, FRICTION, then the joint's JKN, JKS, JCOH, JFRIC.
struct Material {
    kn: real, ks: real, cohesion: real, friction: real,
    jkn: real, jks: real, jcohesion: real, jfriction: real,
}

// The force–displacement law's parameters of a contact carrying `length` of joint (twin of
// `model::constitutive::law_parameters`, SL-85-1 Appendix A ¶5): a joint's JKN·l, JKS·l, JCOH·l
// and JFRIC (stresses over its share of the joint) in the point fields; a point contact's
// material as it is.
fn contact_law(m: Material, length: real) -> Material {
    if (length > 0.0) {
        return Material(m.jkn * length, m.jks * length, m.jcohesion * length, m.jfriction, m.jkn, m.jks, m.jcohesion, m.jfriction);
    }
    return m;
}

// 12 / 24 bytes: one workgroup's share of the energy check (energy_check.wgsl).
struct EnergySum { kinetic: real, strain: real, work: real }

// 60 / 96 bytes.
struct Params {
    dt: real, alpha: real, beta: real, gx: real, gy: real,
    etol: real, fast_limit: real, overlap_limit: real,
    alpha_internal: real, // DAMP ... INTERNAL: the SDEF strain's mass damping
    n_blocks: u32, n_corners: u32, n_contacts: u32,
    one: u32, // always 1 (see two_sum)
    n_heavy: u32, // blocks summed by gather_heavy, listed in adj_offsets after the offsets
    dashpots: u32, // 1: contact dashpots live (beta > 0 or velocities left to book); 0: untouched
}

// 32 / 64 bytes. Where a block stood when stage 7's broad-phase grid was built (the grid's
// reference, `BlockGrid` in topology/detect.rs): centroid relative to the run's origin as a
// compensated pair, rotation, reach (its farthest corner from the centroid), speed margin then.
// Read by list_blocks.wgsl to list the blocks that may have left their boxes in the grid.
struct GridReference {
    x: real, y: real, x_lo: real, y_lo: real, rotation: real, reach: real, margin: real, _r: real,
}

// 32 / 48 bytes (a uniform). The constants of list_blocks.wgsl.
struct ListParams {
    dt: real, etol: real, btol: real, stray_limit: real,
    n_blocks: u32, n_contacts: u32, grid_kept: u32, _pad: u32,
}

// 36 bytes.
struct Flags {
    halted: atomic<u32>,
    cycles_done: atomic<u32>,
    update_due: atomic<u32>,
    errors: atomic<u32>,
    nonfinite_block: atomic<u32>,
    toofast_block: atomic<u32>,
    overlap_contact: atomic<u32>,
    crack_due: atomic<u32>, // an SDEF block reached its Griffith strength: cracking is due
    inverted_zone: atomic<u32>, // lowest zone turned inside out (zones.wgsl)
}

const ERR_NONFINITE: u32 = 1u;
const ERR_TOO_FAST: u32 = 2u;
const ERR_OVERLAP: u32 = 4u;
const ERR_ZONE_INVERTED: u32 = 8u;
const NO_INDEX: u32 = 0xffffffffu;

// The workgroup's place in its dispatch and the item an invocation handles. Dispatches are
// two-dimensional (at most 65535 workgroups a dimension, and a 10⁶-block wall has 8·10⁶
// contacts): rows of GROUPS_PER_ROW workgroups laid end to end (`shaders::dispatch_grid`). The row
// length is a constant rather than `num_workgroups`, which an indirect dispatch need not supply.
fn workgroup_index(wg: vec3<u32>) -> u32 {
    return wg.y * GROUPS_PER_ROW + wg.x;
}

fn item_index(wg: vec3<u32>, li: u32) -> u32 {
    return workgroup_index(wg) * WORKGROUP_SIZE + li;
}

// An adjacency entry (twin of `contact::gather::AdjacencyEntry`): contact index · 2 + side, side 0
// when the block is the contact's block 1 (it receives the contact force), 1 when it is block 2
// (the reaction, report ¶19).
fn make_entry(contact: u32, side: u32) -> u32 {
    return (contact << 1u) | side;
}

fn entry_contact(entry: u32) -> u32 {
    return entry >> 1u;
}

fn entry_side(entry: u32) -> u32 {
    return entry & 1u;
}
