//! WGSL sources: a prelude generated here (precision alias, workgroup size, material count, tie tolerance —
//! constants live in Rust, STYLE.md item 4), then `shaders/udec/layout.wgsl` (the structs), then for the
//! kernels of the cycle `shaders/udec/common.wgsl` (their shared bindings and helpers), then one kernel
//! file.

pub use crate::gpu::wgsl::{dispatch_grid, validate, workgroup_size, MAX_GROUPS_PER_DIMENSION, WORKGROUP_SIZE};
use crate::udec::gpu::Precision;

/// A block with more contacts than this is gathered by a whole workgroup (`gather_heavy`)
/// rather than by one invocation: a fixed base under a long wall has tens of thousands, and one
/// invocation summing them stalls the pass.
pub const HEAVY_DEGREE: u32 = 64;

/// Threads of one `gather_heavy` workgroup.
pub const HEAVY_WORKGROUP_SIZE: u32 = 256;

/// Blocks and contacts one invocation of the energy check (`energy_sums`) adds up before its
/// workgroup's reduction: fewer workgroups, fewer barriers and partial sums.
pub const ENERGY_ITEMS: u32 = 16;

pub const LAYOUT: &str = include_str!("../../../shaders/udec/layout.wgsl");
/// The dimension-free helpers (`shaders/math.wgsl`: `is_finite`, `two_sum`, `sin_cos`), then the 2D cycle's
/// shared bindings and helpers.
pub const COMMON: &str = concat!(include_str!("../../../shaders/math.wgsl"), "\n", include_str!("../../../shaders/udec/common.wgsl"));

/// The kernel files of the cycle, one per stage, each named like its CPU twin in `src/udec/cpu/`;
/// they share the declarations of common.wgsl, and each binds the slots of them it uses
/// (`kernels::CycleKernel`). As on the CPU, stage
/// 1's invocations run stage 6 of the last cycle before it (`force_sum`, gather.wgsl) and stage 2
/// after it (`shaders/udec/geometry_update.wgsl`, no entry point of its own).
pub const KERNELS: &[(&str, &str)] = &[
    (
        "law_of_motion",
        concat!(
            include_str!("../../../shaders/udec/gather.wgsl"),
            "\n",
            include_str!("../../../shaders/udec/geometry_update.wgsl"),
            "\n",
            include_str!("../../../shaders/udec/law_of_motion.wgsl")
        ),
    ),
    ("contact_forces", include_str!("../../../shaders/udec/contact_forces.wgsl")),
    ("gather", include_str!("../../../shaders/udec/gather.wgsl")),
    ("end_cycle", include_str!("../../../shaders/udec/end_cycle.wgsl")),
    ("energy_sums", include_str!("../../../shaders/udec/energy_sums.wgsl")),
    // Zoned fully-deformable blocks' grid points and zones (stages 6, 1 and 3; twin of
    // `cpu::zones`), compiled only for a scene that has them.
    ("zones", include_str!("../../../shaders/udec/zones.wgsl")),
    // Stage 5, fluid flow in joints and voids (twin of `cpu::flow`), compiled only for a scene
    // with fluid.
    ("flow", include_str!("../../../shaders/udec/flow.wgsl")),
];

/// Kernels of the topology changes between cycles, with bindings of their own (the state's bind
/// slots are the cycle's); named like their Rust twins.
pub const TOPOLOGY_KERNELS: &[(&str, &str)] = &[
    ("splice_contacts", include_str!("../../../shaders/udec/splice_contacts.wgsl")),
    ("pack_contacts", include_str!("../../../shaders/udec/pack_contacts.wgsl")),
    ("list_blocks", include_str!("../../../shaders/udec/list_blocks.wgsl")),
    ("splice_adjacency", include_str!("../../../shaders/udec/splice_adjacency.wgsl")),
];

/// Every kernel file's name, the cycle's first.
pub fn kernel_names() -> impl Iterator<Item = &'static str> {
    KERNELS.iter().chain(TOPOLOGY_KERNELS).map(|(name, _)| *name)
}

/// The prelude: the one precision switch and the constants.
///
/// TIE_TOL is the relative tolerance within which two candidate features are "equally near" (the
/// arc-wins rule of `better`). The CPU uses 1e-9; f32 positions relative to a centroid a few
/// metres away carry ~1e-7 relative round-off, so f32 needs a wider window or two aligned corners
/// could be seen as corner–edge from one side and double-count their force.
///
/// REGION_TOL widens the "centre lies in this feature's own region" tests (the slab over an
/// edge, relative to the rounding length; the wedge of an arc, on unit cross products) by round-off. At
/// two aligned corners (a column of equal blocks) the corner's circle centre lies exactly on the
/// border of the arc's wedge and the edge's slab; exact arithmetic (and the CPU, whose round-off
/// happens to cancel there) finds it inside both, so the arc wins from both sides and the touch
/// counts once. Without the tolerance, GPU round-off (fused multiply–adds) flipped one side to
/// corner–edge after ~2800 cycles of tests/suite/physics.rs's column and the touch counted twice.
///
/// EXACT_CIRCLE (f32 only) has the contact stage measure a gap from the rounding circle's exact
/// position (`circle_parts` in contact_forces.wgsl), the blocks' turns since their corners were
/// placed included (`split_rotation`), below the ulp of the centroid distance: an
/// f32 ulp (1.2e-7 m at 1 m) is the overlap of a light block's weight, an f64 one is not. In f64
/// the kernels keep to f64 positions, as a SAVE file does, so that a RESTART goes on bit for bit
/// (the compensated centroid carries bits no f64 holds).
///
/// PIO2_1 + PIO2_2 + PIO2_3 is π/2 split for `sin_cos`'s reduction θ − k·π/2 (Cody–Waite): each
/// part has few enough bits that k times it is exact. In f32 the parts are 1.5703125 (8 bits),
/// 4.8375e-4 (11 bits) and the rest: π/2 rounded to one f32 was off by 4.4e-8, and k·π/2 rounded
/// by up to ulp(θ)/2 (7.6e-6 rad at θ = 200), a step in a spinning block's shape at every
/// quarter turn. In f64 the two parts the kernels always had (the third is 0), so f64 runs are
/// unchanged.
///
/// PAIR_BAND is `contact::pair::PAIR_BAND`: overlaps of a corner pair's two views closer than it
/// (a fraction of the two radii) count as equal and the lower index decides which view counts.
///
/// AREA_BY_MOTION (f32 only) has the fluid's pressure update (flow.wgsl, `domain_pressures`) follow
/// a regular domain's void by the motion of its boundary over each step (`void_step`) rather than
/// take the difference of its area now and at the last step: two f32 areas each off by ~ε·L·P
/// (ε the f32 round-off, L the distance of the boundary from the block centroid it is measured
/// from, P the perimeter), which the update multiplies by bulkw/A (sample 2's cavity: 2.6e-3 of
/// its largest pressure). In f64 the difference is exact enough, and the update is the CPU's.
///
/// ROTATION_STEP (f32): the f32 kernels place a block's corners at a multiple of it and apply the
/// turn since to second order (law_of_motion.wgsl, `circle_parts`); see `split_rotation`.
pub fn prelude(precision: Precision) -> String {
    let (real, tie, region, exact_circle) = match precision {
        Precision::F32 => ("f32", "1e-5", "1e-5", true),
        Precision::F64 => ("f64", "1e-9", "1e-12", false),
    };
    let area_by_motion = precision == Precision::F32;
    let materials = crate::udec::model::MAX_MATERIALS;
    let workgroup = workgroup_size();
    let pair_band = crate::udec::contact::pair::PAIR_BAND;
    format!(
        "alias real = {real};\nconst WORKGROUP_SIZE: u32 = {workgroup}u;\nconst GROUPS_PER_ROW: u32 = {MAX_GROUPS_PER_DIMENSION}u;\nconst HEAVY_WORKGROUP_SIZE: u32 = {HEAVY_WORKGROUP_SIZE}u;\nconst HEAVY_DEGREE: u32 = {HEAVY_DEGREE}u;\nconst ENERGY_ITEMS: u32 = {ENERGY_ITEMS}u;\nconst MAX_MATERIALS: u32 = {materials}u;\nconst TIE_TOL: real = {tie};\nconst REGION_TOL: real = {region};\nconst EXACT_CIRCLE: bool = {exact_circle};\nconst AREA_BY_MOTION: bool = {area_by_motion};\nconst ROTATION_STEP: real = {ROTATION_STEP:e};\nconst PAIR_BAND: real = {pair_band:e};\n{}",
        crate::gpu::wgsl::math_constants(precision)
    )
}

/// The step of the angles the f32 kernels place corners at, 2⁻¹² rad: small enough that the turn
/// since, applied to second order, is exact to f32 round-off (R·δ³/6 < 3e-12 R), large enough that
/// a block at rest or turning slowly keeps its corners for many steps, and a power of two so that
/// every sum of steps is exact (to 4096 rad).
pub const ROTATION_STEP: f64 = 1.0 / 4096.0;

/// A rotation as the f32 kernels hold it: the angle the corners are placed at (the nearest
/// multiple of ROTATION_STEP, as an f32 holds it) and the turn since, which law_of_motion.wgsl
/// keeps within half a step, so that it holds the pair this gives; in f64 the rotation and 0.
pub fn split_rotation(theta: f64, precision: Precision) -> (f64, f64) {
    match precision {
        Precision::F32 => {
            let placed = ((theta / ROTATION_STEP).round() * ROTATION_STEP) as f32 as f64;
            (placed, theta - placed)
        }
        Precision::F64 => (theta, 0.0),
    }
}

/// The full source of one kernel file in one precision.
pub fn source(kernel: &str, precision: Precision) -> Option<String> {
    if let Some((_, body)) = KERNELS.iter().find(|(name, _)| *name == kernel) {
        return Some(format!("{}\n{LAYOUT}\n{COMMON}\n{body}", prelude(precision)));
    }
    let body = TOPOLOGY_KERNELS.iter().find(|(name, _)| *name == kernel)?.1;
    Some(format!("{}\n{LAYOUT}\n{body}", prelude(precision)))
}
