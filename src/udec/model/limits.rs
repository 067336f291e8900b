//! The limits of extreme ratios (mass, contact stiffness, distance from the origin) within which
//! a backend has been verified, and the input-time warnings a model outside them gets before
//! CYCLE. The numbers were measured by `blockdem verify` (`verify::stability::extreme_limits`,
//! README "Accuracy against speed"); they live here, below the executor that warns with them.

use super::Model;

/// Limits beyond which the executor warns before CYCLE, measured on the CPU f64 backend.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Largest over smallest mass of the free blocks.
    pub mass_ratio: f64,
    /// kn/ks or ks/kn of any material in use.
    pub stiffness_ratio: f64,
    /// Largest centroid distance from the origin over the rounding length.
    pub offset_over_round: f64,
}

/// Measured with `blockdem verify` (full) on the CPU f64 backend; see `verify::stability::extreme_limits`.
///
/// - mass ratio: the light-on-heavy column passes to 1e6 (error 3e-5); beyond, the cycles needed
///   grow as √ratio.
/// - kn/ks: the slide passes at 10 (0.7%) and misses at 100 (4.7%): the soft shear springs ring
///   slowly with the undamped landing and the block slides in stick-slip.
/// - offset: the slide passes unchanged at 1e10 m with ROUND 0.05 (2e11 rounding lengths), the
///   largest tried: geometry relative to the centroid keeps f64 contacts exact far out.
pub const LIMITS_CPU_F64: Limits = Limits { mass_ratio: 1e6, stiffness_ratio: 10.0, offset_over_round: 2e11 };

/// Measured with `blockdem verify` (full) on the GPU f64 kernels (Vulkan, lavapipe): the same as
/// the CPU where tried. The mass ratio is tried only to 1e4 there (error 7e-9): the cycles
/// grow as √ratio and a software adapter takes ~1 ms a cycle.
pub const LIMITS_GPU_F64: Limits = Limits { mass_ratio: 1e4, stiffness_ratio: 10.0, offset_over_round: 2e11 };

/// Measured with `blockdem verify` (full) on the GPU f32 kernels (Vulkan, lavapipe; the rounding
/// of f32 arithmetic is the same on every IEEE adapter):
///
/// - mass ratio 1e4, as far as the suite tries it on a GPU (as for f64): the light-on-heavy
///   column's interface forces are right to f32 round-off (1e-7 at 1e4; measured once further:
///   9e-8 at 1e5, 5e-5 at 1e6, where the CPU's is 3e-5). The contact stage measures a gap from
///   the circle centre's exact position (`circle_parts` in contact_forces.wgsl: the centroids'
///   compensated pairs and the corner offset summed without loss), where it used a sum rounded
///   to the f32 ulp of the centroid distance (1.2e-7 m at 1 m): a light block's force then jumped
///   by kn × ulp and never settled (0.09% off at 10, 2.3% at 30, 5% at 100).
/// - kn/ks 10: as on the CPU (the limit is the physics of the scene, not round-off).
/// - offset: the slide is unchanged (error 2.9e-4) at 1e10 m from the origin with ROUND 0.05,
///   the largest tried: centroids are compensated (two_sum) pairs and contact geometry is
///   relative to them, so f32 loses nothing to the distance from the origin.
pub const LIMITS_GPU_F32: Limits = Limits { mass_ratio: 1e4, stiffness_ratio: 10.0, offset_over_round: 2e11 };

/// The limits of a backend: the CPU (always f64), or the GPU kernels in `precision`.
pub fn limits_for(gpu: bool, precision: &str) -> Limits {
    match (gpu, precision) {
        (false, _) => LIMITS_CPU_F64,
        (true, "f32") => LIMITS_GPU_F32,
        (true, _) => LIMITS_GPU_F64,
    }
}

/// The warnings a model outside `limits` gets at input time (the executor prints them before CYCLE).
pub fn warnings(model: &Model, limits: &Limits) -> Vec<String> {
    let mut w = Vec::new();
    let free = || model.blocks.iter().filter(|b| !b.fixed && b.mass > 0.0);
    let (mmin, mmax) = free().fold((f64::INFINITY, 0.0f64), |(a, b), blk| (a.min(blk.mass), b.max(blk.mass)));
    if mmax > 0.0 && mmax / mmin > limits.mass_ratio {
        w.push(format!(
            "WARNING: block masses range over {:.1e} (more than the {:.0e} verified); the time step follows the lightest block, \
             so the heavy ones need {:.0}x more cycles to respond",
            mmax / mmin,
            limits.mass_ratio,
            (mmax / mmin).sqrt()
        ));
    }
    let mut seen = Vec::new();
    for b in &model.blocks {
        seen.push(b.material);
    }
    for c in &model.corners {
        if c.edge_material != 0 {
            seen.push(c.edge_material);
        }
    }
    seen.sort_unstable();
    seen.dedup();
    for m in seen {
        let mat = model.material(m);
        if mat.contact.kn > 0.0 && mat.contact.ks > 0.0 {
            let r = (mat.contact.kn / mat.contact.ks).max(mat.contact.ks / mat.contact.kn);
            if r > limits.stiffness_ratio {
                w.push(format!(
                    "WARNING: material {m} has KN/KS = {:.1e} (a ratio beyond the {:.0e} verified); the softer direction responds \
                     slowly and may not reach its closed form in the cycles given",
                    mat.contact.kn / mat.contact.ks,
                    limits.stiffness_ratio
                ));
            }
        }
    }
    let far = model.blocks.iter().map(|b| b.centroid[0].abs().max(b.centroid[1].abs())).fold(0.0f64, f64::max);
    if model.tol.round > 0.0 && far / model.tol.round > limits.offset_over_round {
        w.push(format!(
            "WARNING: blocks lie {far:.1e} from the origin, {:.1e} rounding lengths (beyond the {:.0e} verified); round-off in \
             positions becomes a visible part of contact overlaps — move the origin into the model",
            far / model.tol.round,
            limits.offset_over_round
        ));
    }
    w
}
