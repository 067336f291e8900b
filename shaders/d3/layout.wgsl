// D3's GPU structs and bindings, twins of src/d3/gpu/layout.rs (naga checks the layouts,
// tests/suite/gpu_shaders.rs). The prelude in front (src/d3/gpu/shaders.rs) defines `alias real = f32;`
// or `f64` and the constants. Storage structs hold reals first and then an even number of u32
// words, so both precisions have the same field order and no padding; no vectors in storage.

// One polyhedral block. Centroid c (in f32 a compensated pair c + c_lo, COMPENSATED), velocity v (half step), angular momentum l and angular
// velocity w (global axes, half step), orientation q (a unit quaternion, x y z w), the inverse
// of its inertia tensor in the reference frame (inv0..inv8, column-major), load, bounding radius;
// force f and moment m, the sums of stage 6; travel since the last detection (¶26) and the
// largest step's travel since the upload (`peak_travel`, for the too-fast check); work of gravity
// and load, mass-damping and contact-dashpot dissipation (as block 1 of its contacts) since the
// upload. `vertex_start`: its vertices; `plane_start`: its face planes (one per distinct normal);
// `edge_start`: its edge directions (`edge_dir_count`), then its feature edges (`feature_count`);
// `adjacency_start`: its contacts, in the contacts' order. A concave block's vertex range holds
// its own vertices and then its convex parts' (in its reference frame about its centroid, so
// stage 2 places them with its own); each part has a record of its own after the blocks, which
// only the contact stage reads (`contact_bodies`). `finite` is cleared by a step that
// leaves a non-finite value. `stress_faces`: its faces loaded by BOUNDARY STRESS, two records
// each in the plane buffer after its planes (`Plane`).
struct Block {
    cx: real, cy: real, cz: real, cx_lo: real, cy_lo: real, cz_lo: real,
    vx: real, vy: real, vz: real,
    lx: real, ly: real, lz: real,
    wx: real, wy: real, wz: real,
    qx: real, qy: real, qz: real, qw: real,
    mass: real,
    inv0: real, inv1: real, inv2: real, inv3: real, inv4: real, inv5: real, inv6: real, inv7: real, inv8: real,
    load_x: real, load_y: real, load_z: real, radius: real,
    fx: real, fy: real, fz: real, mx: real, my: real, mz: real,
    travel: real, peak_travel: real, work: real, damping_work: real, dashpot_work: real,
    fixed: u32, vertex_start: u32, vertex_count: u32, plane_start: u32, plane_count: u32, edge_start: u32,
    edge_dir_count: u32, feature_count: u32, adjacency_start: u32, adjacency_count: u32, finite: u32, stress_faces: u32,
}

// `Block::fixed`: free, fixed (FIX), or held by BOUNDARY VELOCITY at its velocity and spin.
const BLOCK_FREE: u32 = 0u;
const BLOCK_FIXED: u32 = 1u;
const BLOCK_HELD: u32 = 2u;

// A vertex: (lx, ly, lz) in the block's reference frame about its centroid, (x, y, z) placed by
// stage 2: in f64 its position, in f32 (RELATIVE) its offset R·l from the centroid (`block_vertex`
// in track_contact.wgsl puts it in a contact's frame).
struct Vertex {
    lx: real, ly: real, lz: real,
    x: real, y: real, z: real,
}

// A face plane of a block: its outward normal in the reference frame and one of its vertices
// (the block's own numbering). After a block's planes, in a scene with boundary conditions
// (BOUNDARY), two records for each face loaded by BOUNDARY STRESS: (σ11, σ22, σ33 | its first
// vertex, second vertex), (σ12, σ13, σ23 | third vertex, 0), vertices numbered in `vertices`
// (`face_load`, common.wgsl).
struct Plane {
    nx: real, ny: real, nz: real,
    vertex: u32, spare: u32,
}

// A contact between block1 and block2: its common-plane normal (from block 1 to block 2), the
// material of block 1 (kn, ks, cohesion, friction) and the energy friction took and that
// released by logical contacts that went, since the upload. Its logical contacts are
// logicals[logical_start .. logical_start + logical_count].
struct Contact {
    nx: real, ny: real, nz: real,
    kn: real, ks: real, cohesion: real, friction: real,
    friction_work: real, released_work: real,
    block1: u32, block2: u32, logical_start: u32, logical_count: u32,
}

// A logical contact (¶24, ¶32): point (in f64 global; in f32, RELATIVE, from its contact's
// block 1's centroid), gap along the normal (negative: overlap), normal force
// (compression positive) and shear force vector, on block 2. `kind`: LOGICAL_VERTEX_FIRST (vertex
// v1 of block 1 against block 2), LOGICAL_VERTEX_SECOND (vertex v1 of block 2 against block 1),
// LOGICAL_EDGE_EDGE (edge v1 v2 of block 1 across edge v3 v4 of block 2). `live` is 0 once its
// contact has parted (until the next detection).
struct Logical {
    px: real, py: real, pz: real, gap: real, normal_force: real, offset: real,
    sx: real, sy: real, sz: real,
    kind: u32, v1: u32, v2: u32, v3: u32, v4: u32, live: u32,
}

const LOGICAL_VERTEX_FIRST: u32 = 0u;
const LOGICAL_VERTEX_SECOND: u32 = 1u;
const LOGICAL_EDGE_EDGE: u32 = 2u;

// The run's constants: gravity, Rayleigh damping (α, β), the time step, the contact-forming
// distance, 1 (read at run time, for `two_sum`); the counts.
struct Params {
    gx: real, gy: real, gz: real,
    alpha: real, beta: real, dt: real, tol: real, one: real,
    blocks: u32, contacts: u32, spare0: u32, spare1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> blocks: array<Block>;
@group(0) @binding(2) var<storage, read_write> vertices: array<Vertex>;
@group(0) @binding(3) var<storage, read_write> planes: array<Plane>;
// Edges by their two vertices (the block's own numbering): edge k is edges[2k], edges[2k + 1].
@group(0) @binding(4) var<storage, read_write> edges: array<u32>;
@group(0) @binding(5) var<storage, read_write> contacts: array<Contact>;
@group(0) @binding(6) var<storage, read_write> logicals: array<Logical>;
// Each block's contacts: contact index × 2 + 1 where the block is the contact's block 2 (the
// lists, 2 × params.contacts words in all); then each contact's two bodies (`contact_bodies`).
@group(0) @binding(7) var<storage, read_write> adjacency: array<u32>;

// Where contact ci's two bodies are named in `adjacency`, after the blocks' lists: the records
// in `blocks` of the convex bodies its geometry is between (`track_contact`), its block 1's
// then its block 2's. A convex block is its own body (its record is the block's); a concave
// block's convex parts (`Block::parts`) have records after the params.blocks blocks, with their
// ranges of vertices (within their block's, placed with it), face planes and edges and their
// radius, the rest of the record unused. So the parts bind no buffer of their own.
fn contact_bodies(ci: u32) -> u32 {
    return 2u * params.contacts + 2u * ci;
}

// The item of this invocation over a dispatch of `dispatch_grid` rows (gpu::wgsl).
fn item_index(wg: vec3<u32>, local: u32) -> u32 {
    return (wg.y * GROUPS_PER_ROW + wg.x) * WORKGROUP_SIZE + local;
}
