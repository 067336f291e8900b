//! D3's WGSL sources: a prelude generated here (the precision alias, the workgroup size, the
//! shared math constants: constants live in Rust, STYLE.md item 4), `shaders/math.wgsl` (the
//! dimension-free helpers), `shaders/d3/layout.wgsl` (structs and bindings),
//! `shaders/d3/common.wgsl` (vector and quaternion helpers), then one kernel file, named like its
//! Rust twin.

use crate::gpu::wgsl::{math_constants, workgroup_size, MATH, MAX_GROUPS_PER_DIMENSION};
use crate::gpu::Precision;

pub const LAYOUT: &str = include_str!("../../../shaders/d3/layout.wgsl");
pub const COMMON: &str = include_str!("../../../shaders/d3/common.wgsl");
/// The strain stage of simply-deformable blocks (`d3::sdef`): its struct, binding 8 and
/// functions, in the kernels of a scene with such blocks.
pub const SDEF: &str = include_str!("../../../shaders/d3/sdef.wgsl");
/// The stand-ins for [`SDEF`]'s functions in a rigid scene's kernels (never called; nothing
/// more bound).
pub const RIGID: &str = include_str!("../../../shaders/d3/rigid.wgsl");

/// The cycle's kernels in the order they run, each with its Rust twin's name: stage 6
/// (`cpu::gather`), stages 1–2 (`motion::law_of_motion`), stage 4 (`contact::track_contact`).
pub const KERNELS: &[(&str, &str)] = &[
    ("gather", include_str!("../../../shaders/d3/gather.wgsl")),
    ("law_of_motion", include_str!("../../../shaders/d3/law_of_motion.wgsl")),
    ("track_contact", include_str!("../../../shaders/d3/track_contact.wgsl")),
];

/// The prelude: the precision switch and the constants; `sdef` for a scene with simply-deformable
/// blocks (the SDEF switch: the kernels then run the strain stage, `shaders/d3/sdef.wgsl`);
/// `boundary` for a scene with boundary conditions (the BOUNDARY switch: held blocks and loaded
/// faces, BOUNDARY VELOCITY and STRESS; a scene without runs kernels without their code).
pub fn prelude(precision: Precision, sdef: bool, boundary: bool) -> String {
    // COMPENSATED: the f32 kernels keep the centroid as a compensated pair (law_of_motion.wgsl);
    // the f64 ones add as the CPU does, so that they follow it to round-off.
    //
    // RELATIVE: the f32 kernels keep the vertices as offsets from their centroids and work each
    // contact's geometry (vertices, points, lever arms) in a frame at its block 1's centroid
    // (`centroid_from`, common.wgsl), so that a gap is resolved at ulp(block size) rather than
    // ulp(distance from the origin); the f64 ones work in global axes, as the CPU does.
    //
    // GRAZING: `ray_crossing` passes over a face plane whose normal is within GRAZING (the
    // cosine) of perpendicular to the ray; the CPU takes 1e-9. The ray through a block's corner
    // meets every face at the corner at one point, and for a face nearly parallel to the ray
    // the crossing is round-off over that cosine: in f32, 1e-7 m over a box tilted by 1e-5 rad
    // put the crossing centimetres off, and a sliding box's corners took forces of kilonewtons
    // at random and rocked it. The faces across the ray give the crossing to round-off.
    //
    // PART_GRAZING: GRAZING for a convex part of a concave block (`d3::gpu`, "Concave blocks"),
    // in both precisions. A part's cut faces run through the seams of its block, where the
    // logical contacts of a stacked concave block's seam lie: the ray along a contact's normal
    // through such a point meets a cut face that the block's rocking tilts off parallel by a
    // little, and at GRAZING = 1e-9 the crossing is that point's small offset from the face over
    // the tilt, far off the surfaces; kept between detections (the CPU finds its contacts
    // afresh each cycle), such gaps spun an L stacked on an L in f64 to 0.28 rad/s (the CPU's:
    // 2e-3) and the run blew up at cycle 1000 (energy growing without a source). f32's GRAZING;
    // one constant with the Rust twin's, `contact::PART_GRAZING` (written as `1e-3`).
    let (real, compensated, grazing) = match precision {
        Precision::F32 => ("f32", true, "1e-3"),
        Precision::F64 => ("f64", false, "1e-9"),
    };
    let part_grazing = crate::d3::contact::PART_GRAZING;
    // STEEP_SHARE: `contact::STEEP_SHARE`, one constant with the Rust twin's.
    let steep_share = crate::d3::contact::STEEP_SHARE;
    // ROUNDOFF: the kernel precision's machine epsilon (the common plane's margin, track_contact.wgsl).
    let roundoff = match precision {
        Precision::F32 => f32::EPSILON as f64,
        Precision::F64 => f64::EPSILON,
    };
    // GRIFFITH_MARGIN and SCREEN_SWEEPS: Griffith's screen in the strain stage (sdef.wgsl's
    // `griffith_screen`, "Cracking on the device" in `d3::gpu`); only the kernels of a scene with
    // simply-deformable blocks declare them, so a rigid scene's kernels are as they were.
    let screen = if sdef {
        format!("const GRIFFITH_MARGIN: real = {:e};\nconst SCREEN_SWEEPS: u32 = {}u;\n", griffith_margin(precision), crate::d3::sdef::SCREEN_SWEEPS)
    } else {
        String::new()
    };
    format!(
        "alias real = {real};\nconst WORKGROUP_SIZE: u32 = {}u;\nconst GROUPS_PER_ROW: u32 = {MAX_GROUPS_PER_DIMENSION}u;\nconst COMPENSATED: bool = {compensated};\nconst RELATIVE: bool = {compensated};\nconst GRAZING: real = {grazing};\nconst PART_GRAZING: real = {part_grazing:e};\nconst STEEP_SHARE: real = {steep_share:e};\nconst ROUNDOFF: real = {roundoff:e};\nconst SDEF: bool = {sdef};\nconst BOUNDARY: bool = {boundary};\n{screen}{}",
        workgroup_size(),
        math_constants(precision)
    )
}

/// The margin of Griffith's screen on the device (`sdef::griffith_screen`, sdef.wgsl), as a share
/// of the stress's Frobenius norm |σ|: the screen fires where Griffith's stress of the principal
/// stresses widened by it reaches TF less it, so that it never misses a crack the CPU's exact
/// check (`cracking::due`, f64, on the stresses read back) finds. It covers two round-offs:
///
/// * the kernel's own: its Jacobi rotations in the kernel precision move the eigenvalues by a few
///   ε|σ| each (twelve rotations; f32's ε = 1.2e-7, so ~1e-5|σ| at worst, and the residual
///   off-diagonal part is added to the bounds outright);
/// * the CPU's: `geometry::principal_moments` takes the eigenvalues by the trigonometric method,
///   whose arccosine is ill-conditioned at a double eigenvalue: a rounding δ of its argument moves
///   the largest (or smallest) eigenvalue by ~0.8 p √δ (p the deviator's size), up to ~1e-7|σ|
///   in f64 for a nearly hydrostatic stress.
///
/// Hence f32 1e-4 and f64 1e-6 (ten times the larger of the two); tests/suite/d3_crack_gpu.rs
/// checks the kernel's screen in both against the exact check on 4000 stresses (double and
/// near-double eigenvalues, nearly hydrostatic ones among them): it fires at TF, never three
/// margins below it. A
/// block whose stress lies within the margin below TF halts its batch each cycle (the CPU's check
/// then says no): as before, where every cycle was read back.
pub fn griffith_margin(precision: Precision) -> f64 {
    match precision {
        Precision::F32 => 1e-4,
        Precision::F64 => 1e-6,
    }
}

/// `end_cycle`, the cycle's last kernel in a scene with Griffith's cracking candidates: it counts
/// the cycle and, where a block's screen fired, halts the rest of the batch (`d3::gpu`, "Cracking
/// on the device"). Not in [`KERNELS`]: it has bindings of its own (`end_cycle_source`).
pub const END_CYCLE: &str = include_str!("../../../shaders/d3/end_cycle.wgsl");

/// The full source of `end_cycle` in one precision: the strain stage's prelude and structs (it
/// reads the screen's flag after the blocks' strain records), then its own bindings.
pub fn end_cycle_source(precision: Precision) -> String {
    format!("{}\n{MATH}\n{LAYOUT}\n{SDEF}\n{COMMON}\n{END_CYCLE}", prelude(precision, true, false))
}

/// `contact_energy`, the energy check's sums of the contacts' springs and its overlap test on
/// the device (twin `d3::model::contact_energy`). Not in [`KERNELS`]: not a stage of the cycle,
/// and it has a binding of its own (`contact_energy_source`).
pub const CONTACT_ENERGY: &str = include_str!("../../../shaders/d3/contact_energy.wgsl");

/// The full source of `contact_energy` in one precision (any scene's: it reads the blocks'
/// radii, the contacts and their logical contacts, then writes its own binding 9).
pub fn contact_energy_source(precision: Precision) -> String {
    compose(CONTACT_ENERGY, precision, false, false)
}

/// `critical_rows`, the critical time step's largest row on the device (twin: the rows of
/// `Model::critical_timestep_with`). Not in [`KERNELS`]: not a stage of the cycle, and it has
/// bindings of its own (`critical_rows_source`).
pub const CRITICAL_ROWS: &str = include_str!("../../../shaders/d3/critical_rows.wgsl");

/// The full source of `critical_rows` in one precision (any scene's: it reads the blocks, the
/// contacts, their logical contacts and the adjacency, then its own bindings 9 and 10).
pub fn critical_rows_source(precision: Precision) -> String {
    compose(CRITICAL_ROWS, precision, false, false)
}

/// `splice_contacts`, a partial detection's splice of the contact buffers on the device (twin
/// `d3::gpu::splice::splice_contacts`). Not in [`KERNELS`]: not a stage of the cycle, and it has
/// bindings of its own (`splice_contacts_source`).
pub const SPLICE_CONTACTS: &str = include_str!("../../../shaders/d3/splice_contacts.wgsl");

/// The full source of `splice_contacts` in one precision (any scene's: it copies the contacts and
/// logical contacts, bindings 5 and 6 its output, and its own bindings 9 to 15), with the fresh
/// sources' bit (`layout::SPLICE_FRESH`).
pub fn splice_contacts_source(precision: Precision) -> String {
    let body = format!("const SPLICE_FRESH: u32 = {:#x}u;\n{SPLICE_CONTACTS}", super::layout::SPLICE_FRESH);
    compose(&body, precision, false, false)
}

/// `renew_blocks`, a partial detection's renewal of the block records on the device (twin
/// `d3::gpu::splice::renew_blocks`). Not in [`KERNELS`]: not a stage of the cycle, and it has a
/// binding of its own (`renew_blocks_source`).
pub const RENEW_BLOCKS: &str = include_str!("../../../shaders/d3/renew_blocks.wgsl");

/// The full source of `renew_blocks` in one precision (any scene's: the params and the blocks,
/// and its own binding 9), with the moved blocks' bit (`layout::RENEW_MOVED`).
pub fn renew_blocks_source(precision: Precision) -> String {
    let body = format!("const RENEW_MOVED: u32 = {:#x}u;\n{RENEW_BLOCKS}", super::layout::RENEW_MOVED);
    compose(&body, precision, false, false)
}

/// The full source of one kernel in one precision, for a rigid scene.
pub fn source(kernel: &str, precision: Precision) -> Option<String> {
    source_for(kernel, precision, false)
}

/// The full source of one kernel in one precision; with `sdef`, for a scene with
/// simply-deformable blocks.
pub fn source_for(kernel: &str, precision: Precision, sdef: bool) -> Option<String> {
    source_with(kernel, precision, sdef, false)
}

/// The full source of one kernel in one precision; with `sdef`, for a scene with
/// simply-deformable blocks; with `boundary`, for a scene with boundary conditions (BOUNDARY).
pub fn source_with(kernel: &str, precision: Precision, sdef: bool, boundary: bool) -> Option<String> {
    let body = KERNELS.iter().find(|(name, _)| *name == kernel)?.1;
    Some(compose(body, precision, sdef, boundary))
}

/// A kernel file `body` behind the prelude, the shared math, the layout, the strain stage (or
/// its rigid stand-ins) and the common helpers.
fn compose(body: &str, precision: Precision, sdef: bool, boundary: bool) -> String {
    let strain = if sdef { SDEF } else { RIGID };
    format!("{}\n{MATH}\n{LAYOUT}\n{strain}\n{COMMON}\n{body}", prelude(precision, sdef, boundary))
}
