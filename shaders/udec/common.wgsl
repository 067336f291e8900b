// Shared by the kernels of the cycle: the bindings and the precision-neutral helpers. The structs
// they bind (and `item_index`) are in layout.wgsl, which comes before this file.

// The state's slots: ten storage buffers and two uniforms (run constants and the material
// table), `gpu::kernels::StateSlot` in Rust. Each kernel binds only the slots its entry point
// uses (`gpu::kernels::used_slots`, read off the module by naga), so the per-stage limit of
// DESIGN.md §3 (8 storage buffers) counts one kernel's, and a new stage's arrays take new slots.
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
// Scenes with simply-deformable blocks only (the `_sdef` entry points): each block's extension,
// at the block's index, and each contact's lever arms.
@group(0) @binding(10) var<storage, read_write> sdefs: array<Sdef>;
@group(0) @binding(11) var<storage, read_write> contact_levers: array<ContactLever>;
// Scenes with zoned fully-deformable blocks only (the `_fdef` entry points and zones.wgsl): the
// grid points and zones of every zoned block (each slot exactly as long as the scene's), each
// block's zone constants and ranges (at the block's index), each grid point's zones as CSR
// (offsets into this array for grid points 0 ..= n, then entries zone·4 + the grid point's
// place in the zone, ascending by zone: the CPU's order), each contact's force shares. (15 is
// end_cycle's dispatch grids.)
@group(0) @binding(12) var<storage, read_write> gridpoints: array<GridPoint>;
@group(0) @binding(13) var<storage, read_write> zone_list: array<Zone>;
@group(0) @binding(14) var<storage, read> fdef_blocks: array<FdefBlock>;
@group(0) @binding(16) var<storage, read> gridpoint_zones: array<u32>;
@group(0) @binding(17) var<storage, read_write> contact_shares: array<ContactShare>;

// Scenes with fluid only (flow.wgsl and the `_fluid` entry points; `gpu::flow`): the fluid's
// constants and each material's flow properties (uniforms), the domains, each domain's flows (CSR:
// contact·2 + 1 where it is the contact's second domain), each domain's boundary (four words a
// link), each contact's two domains (two words a contact, NO_INDEX for none), each contact's flow
// and feet, each block's fluid load.
@group(0) @binding(18) var<uniform> fluid_params: FluidParams;
@group(0) @binding(19) var<uniform> fluid_materials: array<FluidMaterial, MAX_MATERIALS>;
@group(0) @binding(20) var<storage, read_write> domains: array<Domain>;
@group(0) @binding(21) var<storage, read> domain_flows: array<u32>;
@group(0) @binding(22) var<storage, read> domain_links: array<u32>;
@group(0) @binding(23) var<storage, read> contact_sides: array<u32>;
@group(0) @binding(24) var<storage, read_write> contact_flows_out: array<ContactFlow>;
@group(0) @binding(25) var<storage, read_write> fluid_loads: array<FluidLoad>;
// Scenes with fluid and a domain of a long boundary or flow list (`gpu::flow`, `domain_terms`):
// each such domain's terms, two per link (at 2·link) and one per flow (at 2·n_links + entry),
// and what each invocation of `domain_terms` computes (four words an item).
@group(0) @binding(30) var<storage, read_write> sum_terms: array<real>;
@group(0) @binding(31) var<storage, read> term_items: array<u32>;
// Scenes with fluid and deformable blocks only (`gpu::flow`, the `_fluid` entry points of the
// SDEF and FDEF kernels): each domain link's piece of block boundary, each block's pieces (CSR:
// offsets for blocks 0 ..= n into this array, then the link indices, ascending: the CPU's order
// of domains and circuits), each block's fluid load, and each grid point's (zoned blocks only).
@group(0) @binding(26) var<storage, read_write> fluid_pieces: array<FluidPiece>;
@group(0) @binding(27) var<storage, read> block_pieces: array<u32>;
@group(0) @binding(28) var<storage, read_write> block_fluid: array<BlockFluid>;
@group(0) @binding(29) var<storage, read_write> gridpoint_fluid: array<GridPointFluid>;
// In f32 only, with deformable blocks on a void's boundary: each corner's move in this step
// (`corner_moves_sdef`, `corner_moves_fdef`), whose sum `deformed_terms` follows the void by.
@group(0) @binding(32) var<storage, read_write> corner_moves: array<CornerMove>;

// Centroid of block a minus centroid of block b, from the compensated pairs: the large parts
// cancel exactly when the blocks are near each other (Sterbenz), so the difference keeps full
// precision however far the model lies from the origin.
fn centroid_difference(a: Block, b: Block) -> vec2<real> {
    return vec2<real>((a.cx - b.cx) + (a.cx_lo - b.cx_lo), (a.cy - b.cy) + (a.cy_lo - b.cy_lo));
}

// The inertia of the strain modes (11, 12, 22) of a block whose body-frame second moments are m
// and whose rotation is θ: the diagonal of R M Rᵀ, their mean for the shear. Twin of
// `sdef::strain_inertia`.
fn strain_inertia(m: array<real, 3>, cs: vec2<real>) -> vec3<real> {
    let c = cs.x;
    let s = cs.y;
    let j11 = c * c * m[0] - 2.0 * c * s * m[1] + s * s * m[2];
    let j22 = s * s * m[0] + 2.0 * c * s * m[1] + c * c * m[2];
    return vec3<real>(j11, 0.5 * (m[0] + m[2]), j22);
}

// The generalised force on an SDEF block's strain modes (11, 12, 22): its applied stress times
// area less its internal stress times area (twin of `sdef::generalised_force`).
fn generalised_force(x: Sdef) -> vec3<real> {
    let a = x.applied;
    return vec3<real>(a[0] - x.area * x.stress[0], 0.5 * (a[1] + a[2]) - x.area * x.stress[1], a[3] - x.area * x.stress[2]);
}

// Twice the signed area of the triangle (a, b, c), positive counter-clockwise (twin of
// `model::fdef::twice_area` on `geometry::orient`).
fn twice_area(a: vec2<real>, b: vec2<real>, c: vec2<real>) -> real {
    let u = b - a;
    let v = c - a;
    return u.x * v.y - u.y * v.x;
}

// A grid point's position relative to the run's origin (the large part of its compensated
// pair: what the zones' gradients are measured from).
fn gridpoint_position(g: u32) -> vec2<real> {
    return vec2<real>(gridpoints[g].x, gridpoints[g].y);
}

// The three corners of zone z.
fn zone_points(z: Zone) -> array<vec2<real>, 3> {
    return array<vec2<real>, 3>(gridpoint_position(z.g0), gridpoint_position(z.g1), gridpoint_position(z.g2));
}
