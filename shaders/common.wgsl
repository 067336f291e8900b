// Shared by every kernel: the GPU structs (twins of src/gpu/layout.rs; sizes given as f32 / f64),
// the bindings, and the precision-neutral helpers. The Rust prelude in front of this file defines
// `alias real = f32;` or `f64`, WORKGROUP_SIZE and TIE_TOL. Storage structs hold reals first and
// then an even number of u32 words, so both precisions have the same field order and no padding.

// 116 / 216 bytes. Centroid relative to the run's origin as a compensated pair (cx + cx_lo);
// `work`, `damping_work`: external work and mass-damping dissipation since the upload;
// `moved` is the largest net displacement from the reference (update_*) of the last contact
// update, due for the next one past etol + update_margin (the block's speed margin).
struct Block {
    cx: real, cy: real, cx_lo: real, cy_lo: real,
    rotation: real, vx: real, vy: real, w: real,
    fx: real, fy: real, moment: real, mass: real,
    inertia: real, load_x: real, load_y: real, radius: real,
    work: real, damping_work: real,
    moved: real, update_cx: real, update_cy: real, update_cx_lo: real, update_cy_lo: real, update_rotation: real, update_margin: real,
    fixed: u32, corner_start: u32, corner_count: u32, _pad: u32,
}

// 60 / 112 bytes. (px, py) corner and (ox, oy) circle centre relative to the block centroid;
// (ux, uy) unit direction and len length of the edge to the next corner.
struct Corner {
    lx: real, ly: real, qx: real, qy: real, radius: real, round: real,
    px: real, py: real, ox: real, oy: real, ux: real, uy: real, len: real,
    block: u32, _pad: u32,
}

// 80 / 136 bytes. The point (px, py) is relative to block 2's centroid. slip_work, dashpot_work:
// dissipation since the upload; (dashpot_vn, dashpot_vs): the velocities the dashpots acted on in
// the last step, whose work is booked a step late.
struct Contact {
    px: real, py: real, nx: real, ny: real, gap: real,
    normal_force: real, shear_force: real, shear_displacement: real, fx: real, fy: real,
    slip_work: real, dashpot_work: real, dashpot_vn: real, dashpot_vs: real,
    block1: u32, corner: u32, block2: u32, feature: u32,
    material: u32, bonded: u32,
}

// 16 / 32 bytes. What the gather needs of a contact: the force on block 1 (block 2 gets the
// reaction) and the moment of each about its own centroid (eq. 12), written by contact_forces.
struct ContactForce { fx: real, fy: real, m1: real, m2: real }

// 16 / 32 bytes (the 16-byte stride a uniform array needs, in both precisions).
struct Material { kn: real, ks: real, cohesion: real, friction: real }

// 12 / 24 bytes: one workgroup's share of the energy check (energy_check.wgsl).
struct EnergySum { kinetic: real, strain: real, work: real }

// 56 / 88 bytes.
struct Params {
    dt: real, alpha: real, beta: real, gx: real, gy: real,
    etol: real, fast_limit: real, overlap_limit: real,
    n_blocks: u32, n_corners: u32, n_contacts: u32,
    one: u32, // always 1 (see two_sum)
    gather_fixed: u32, // 1: the gather also sums fixed blocks (before a read-back)
    n_heavy: u32, // blocks summed by gather_heavy, listed in adj_offsets after the offsets
}

// 32 bytes.
struct Flags {
    halted: atomic<u32>,
    cycles_done: atomic<u32>,
    update_due: atomic<u32>,
    errors: atomic<u32>,
    nonfinite_block: atomic<u32>,
    toofast_block: atomic<u32>,
    overlap_contact: atomic<u32>,
    _pad: atomic<u32>,
}

const ERR_NONFINITE: u32 = 1u;
const ERR_TOO_FAST: u32 = 2u;
const ERR_OVERLAP: u32 = 4u;

// Eight storage buffers (DESIGN.md §3) and two uniforms: run constants and the material table.
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> blocks: array<Block>;
@group(0) @binding(2) var<storage, read_write> corners: array<Corner>;
@group(0) @binding(3) var<storage, read_write> contacts: array<Contact>;
@group(0) @binding(4) var<uniform> materials: array<Material, MAX_MATERIALS>;
@group(0) @binding(5) var<storage, read> adj_offsets: array<u32>;
@group(0) @binding(6) var<storage, read> adj_entries: array<u32>;
@group(0) @binding(7) var<storage, read_write> flags: Flags;
@group(0) @binding(8) var<storage, read_write> contact_forces_out: array<ContactForce>;
@group(0) @binding(9) var<storage, read_write> energy_sums_out: array<EnergySum>;

// The item an invocation handles. Dispatches are two-dimensional (at most 65535 workgroups a
// dimension, and a 10⁶-block wall has 8·10⁶ contacts), rows of workgroups laid end to end.
fn item_index(wg: vec3<u32>, nwg: vec3<u32>, li: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * WORKGROUP_SIZE + li;
}

// True when the batch was stopped at the end of an earlier cycle: the remaining cycles of the
// batch do nothing, so the CPU sees the state of the cycle that raised the flag.
fn halted() -> bool {
    return atomicLoad(&flags.halted) != 0u;
}

// The same, read once per workgroup (by its first invocation) and shared: an atomic load by
// every invocation of an 8·10⁶-contact pass is 8·10⁶ reads of one word. Call it first, from
// uniform control flow (it holds a workgroup barrier).
var<workgroup> workgroup_halt: u32;
fn workgroup_halted(li: u32) -> bool {
    if (li == 0u) {
        workgroup_halt = atomicLoad(&flags.halted);
    }
    return workgroupUniformLoad(&workgroup_halt) != 0u;
}

// Finite test without isnan/isinf (which compilers may fold away): false for NaN and ±inf.
fn is_finite(x: real) -> bool {
    return abs(x) <= real(1.0e38);
}

// Exact sum of two reals as (sum, rounding error): Knuth's TwoSum, six additions. Shader
// compilers may rewrite floating point as if it were real arithmetic (no WGSL qualifier forbids
// it): Mesa folds (a + b) − a to b, and the error term to 0, so in f32 every position step lost
// the bits below the coordinate's ulp (at 10 m, 1e-6 m a step) and a wave in a chain of stiff
// contacts gained 40% energy in 120 cycles. Multiplying by `one` (= 1, exact, read from the
// params at run time) hides the identities from the compiler. Twin test: tests/gpu_kernels.rs.
fn two_sum(a: real, b: real, one: real) -> vec2<real> {
    let s = (a + b) * one;
    let bb = (s - a) * one;
    let err = (a - (s - bb)) + (b - bb);
    return vec2<real>(s, err);
}

// (cos θ, sin θ) with + − × only (f64 kernels have no sin/cos): θ is reduced by the nearest
// multiple k of π/2 (k found in f32, any nearby integer works; π/2 split Cody–Waite style so
// k·π/2 is subtracted almost exactly), then Taylor series to r¹⁷ / r¹⁶, whose truncation error on
// |r| ≤ π/4 is below 1e-19, and the quadrant of k. Rust twin: `gpu::kernels::sin_cos`.
fn sin_cos(theta: real) -> vec2<real> {
    let k = i32(round(f32(theta) * 0.636619772367581343));
    let kr = real(k);
    let r = (theta - kr * real(1.57079632673412561417e+00)) - kr * real(6.07710050650619224932e-11);
    let r2 = r * r;
    let s = r * (1.0 + r2 * (-1.0 / 6.0 + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362880.0
        + r2 * (-1.0 / 39916800.0 + r2 * (1.0 / 6227020800.0 + r2 * (-1.0 / 1307674368000.0
        + r2 * (1.0 / 355687428096000.0)))))))));
    let c = 1.0 + r2 * (-0.5 + r2 * (1.0 / 24.0 + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40320.0
        + r2 * (-1.0 / 3628800.0 + r2 * (1.0 / 479001600.0 + r2 * (-1.0 / 87178291200.0
        + r2 * (1.0 / 20922789888000.0))))))));
    switch (k & 3) {
        case 0: { return vec2<real>(c, s); }
        case 1: { return vec2<real>(-s, c); }
        case 2: { return vec2<real>(-c, -s); }
        default: { return vec2<real>(s, -c); }
    }
}

// Centroid of block a minus centroid of block b, from the compensated pairs: the large parts
// cancel exactly when the blocks are near each other (Sterbenz), so the difference keeps full
// precision however far the model lies from the origin.
fn centroid_difference(a: Block, b: Block) -> vec2<real> {
    return vec2<real>((a.cx - b.cx) + (a.cx_lo - b.cx_lo), (a.cy - b.cy) + (a.cy_lo - b.cy_lo));
}
