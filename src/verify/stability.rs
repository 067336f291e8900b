//! Where the explicit scheme fails (issue 4, item 4): the measured threshold of instability in
//! FRACTION against `Model::stable_frac_estimate`, and the limits of extreme ratios (mass, contact
//! stiffness, distance from the origin) on a backend, with the input-time warnings they give.
//!
//! The limits in [`LIMITS_CPU_F64`], [`LIMITS_GPU_F64`] and [`LIMITS_GPU_F32`] were measured with
//! `blockdem verify` (the full suite, [`extreme_limits`]) on the CPU and on Mesa's lavapipe in
//! both precisions (see README, "Accuracy against speed"); [`limits_for`] picks the set of the
//! backend that runs, and the executor warns before CYCLE against it. They live in
//! [`crate::udec::model::limits`], below the executor, and are re-exported here beside the measurements.

use std::fmt::Write as _;

use super::{BackendEntry, Ctx};
pub use crate::udec::model::limits::{limits_for, warnings, Limits, LIMITS_CPU_F64, LIMITS_GPU_F32, LIMITS_GPU_F64};

/// A measured threshold of instability.
#[derive(Clone, Debug)]
pub struct Threshold {
    pub scene: &'static str,
    pub backend: String,
    /// `stable_frac_estimate()` of the scene's contact network.
    pub estimate: f64,
    /// Smallest FRACTION (within the bisection's resolution) at which the run stops with a
    /// numerical error within its cycles.
    pub measured: f64,
    /// The message of the first failing run above the threshold.
    pub failure: String,
    /// The estimate is safe (at or below the measured threshold) and not far off (above a third
    /// of it), and the failure names FRACTION.
    pub passed: bool,
}

/// Scenes of the stability measurement: deck text without FRAC and CYCLE, and its cycle count.
fn stability_scenes() -> Vec<(&'static str, String, u64)> {
    let base = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\n";
    vec![
        ("block_on_base", format!("{base}BLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\nGRAV 0 -10\n"), 2000),
        // Contact dashpots (stiffness-proportional damping) narrow the stable range: ξ = βω/2.
        ("block_on_base_dashpots", format!("{base}BLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\nGRAV 0 -10\nDAMP 0.5 50 STIFF\n"), 2000),
        (
            "column_of_4",
            format!("{base}BLOCK 1,1 1,2 2,2 2,1\nBLOCK 1,2 1,3 2,3 2,2\nBLOCK 1,3 1,4 2,4 2,3\nBLOCK 1,4 1,5 2,5 2,4\nFIX 0 4 0 0.9\nGRAV 0 -10\n"),
            2000,
        ),
        ("brick_wall_3x4", crate::scenes::brick_wall_deck(3, 4, 1.0, 0.5, 1e8, 0.6), 2000),
        ("pwave_chain_40", super::cases::pwave_deck(40, None, std::f64::consts::PI / 5.0, 15.5, 20.0, 0.01, ""), 2000),
    ]
}

/// Measures the threshold of instability of each scene by bisection on FRACTION.
pub fn thresholds(backend: &BackendEntry, quick: bool) -> Vec<Threshold> {
    let steps = if quick { 7 } else { 11 };
    stability_scenes().into_iter().map(|(name, deck, cycles)| threshold(name, &deck, cycles, backend, steps)).collect()
}

fn runs_clean(backend: &BackendEntry, deck: &str, frac: f64, cycles: u64) -> Result<(), String> {
    let ctx = Ctx { frac, backend };
    ctx.run(&format!("{deck}FRAC {frac}\nCYCLE {cycles}\n")).map(|_| ()).map_err(|f| f.message)
}

/// One scene's threshold: bisection in log FRACTION between a stable and an unstable value.
pub fn threshold(scene: &'static str, deck: &str, cycles: u64, backend: &BackendEntry, steps: usize) -> Threshold {
    let ctx = Ctx { frac: 0.1, backend };
    let estimate = ctx.run(&format!("{deck}CYCLE 0\n")).map_or(f64::NAN, |(m, _)| m.stable_frac_estimate());
    let (mut lo, mut hi) = (0.05f64, 4.0f64);
    let mut failure = match runs_clean(backend, deck, hi, cycles) {
        Err(f) => f,
        Ok(()) => String::from("no failure even at FRAC 4"),
    };
    if runs_clean(backend, deck, lo, cycles).is_err() {
        hi = lo;
    } else {
        for _ in 0..steps {
            let mid = (lo * hi).sqrt();
            match runs_clean(backend, deck, mid, cycles) {
                Ok(()) => lo = mid,
                Err(f) => {
                    hi = mid;
                    failure = f;
                }
            }
        }
    }
    let measured = hi;
    let passed = estimate <= measured * 1.0001 && estimate > measured / 3.0 && failure.contains("FRACTION");
    Threshold { scene, backend: format!("{} {}", backend.label, backend.precision), estimate, measured, failure, passed }
}

/// A measured limit of an extreme ratio.
#[derive(Clone, Debug)]
pub struct ExtremeLimit {
    pub what: &'static str,
    pub backend: String,
    /// Largest value tried at which the check passed.
    pub limit: f64,
    /// Every value tried with its error (or failure).
    pub tried: String,
}

/// Measures the extreme-ratio limits on one backend: each ratio over decades on a closed-form
/// case, the limit being the largest value that still passes it.
pub fn extreme_limits(backend: &BackendEntry, quick: bool) -> Vec<ExtremeLimit> {
    let ctx = Ctx { frac: super::CHECK_FRAC, backend };
    let be = format!("{} {}", backend.label, backend.precision);
    let mut out = Vec::new();

    // Distance from the origin: the slide (2% tolerance) with the scene moved by X along x and y.
    let offsets: &[f64] = if quick { &[1e4, 1e6, 1e8] } else { &[1e4, 1e6, 1e7, 1e8, 1e9, 1e10] };
    let mut tried = String::new();
    let mut limit = 0.0;
    for &x in offsets {
        let r = slide_offset(&ctx, x);
        let _ = write!(tried, "{x:.0e}: {}; ", r.as_ref().map_or_else(|e| e.clone(), |e| format!("{e:.2e}")));
        if r.is_ok_and(|e| e < 0.02) {
            limit = x;
        } else {
            break;
        }
    }
    out.push(ExtremeLimit { what: "offset from origin [m]", backend: be.clone(), limit, tried });

    // kn/ks: the slide with ks = kn/R.
    let ratios: &[f64] = if quick { &[1e1, 1e2, 1e3] } else { &[1e1, 1e2, 3e2, 1e3, 1e4] };
    let mut tried = String::new();
    let mut limit = 1.0;
    for &r in ratios {
        let res = slide_stiffness_ratio(&ctx, r);
        let _ = write!(tried, "{r:.0e}: {}; ", res.as_ref().map_or_else(|e| e.clone(), |e| format!("{e:.2e}")));
        if res.is_ok_and(|e| e < 0.02) {
            limit = r;
        } else {
            break;
        }
    }
    out.push(ExtremeLimit { what: "kn/ks", backend: be.clone(), limit, tried });

    // Mass ratio: a light block on a heavy one on a fixed base; interface forces = weight above.
    // Full suite: from 10 to 1e6 on the CPU; the GPU rows stop at 1e4, since the cycles needed
    // grow as √ratio and software adapters take ~1 ms a cycle.
    let ratios: &[f64] = match (quick, backend.gpu) {
        (true, _) => &[1e2, 1e4],
        (false, false) => &[1e1, 1e2, 1e4, 1e5, 1e6],
        (false, true) => &[1e1, 1e2, 1e3, 1e4],
    };
    let mut tried = String::new();
    let mut limit = 1.0;
    for &r in ratios {
        let res = column_mass_ratio(&ctx, r);
        let _ = write!(tried, "{r:.0e}: {}; ", res.as_ref().map_or_else(|e| e.clone(), |e| format!("{e:.2e}")));
        if res.is_ok_and(|e| e < 0.01) {
            limit = r;
        } else {
            break;
        }
    }
    out.push(ExtremeLimit { what: "mass ratio", backend: be, limit, tried });
    out
}

fn slide_offset(ctx: &Ctx, x: f64) -> Result<f64, String> {
    let psi = 30f64.to_radians();
    let tan_phi = 0.3;
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F={tan_phi}\nROUND 0.05\nBLOCK {a},{a} {a},{b} {c},{b} {c},{a}\nBLOCK {d},{b} {d},{e} {f},{e} {f},{b}\n\
         FIX {a} {c} {a} {g}\nGRAV {} {}\n{}",
        10.0 * psi.sin(),
        -10.0 * psi.cos(),
        ctx.frac_line(),
        a = x,
        b = x + 1.0,
        c = x + 10.0,
        d = x + 1.0,
        e = x + 1.5,
        f = x + 3.0,
        g = x + 0.9,
    );
    let n = ctx.cycles_for(&setup, 1.0).map_err(|f| f.message)?;
    let (m, _) = ctx.run(&format!("{setup}CYCLE {n}\n")).map_err(|f| f.message)?;
    let t = m.time;
    let expected = 0.5 * 10.0 * t * t * (psi.sin() - psi.cos() * tan_phi);
    let slid = m.blocks[1].centroid[0] - (x + 2.0);
    Ok((slid - expected).abs() / expected)
}

fn slide_stiffness_ratio(ctx: &Ctx, r: f64) -> Result<f64, String> {
    let psi = 30f64.to_radians();
    let tan_phi = 0.3;
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS={:e} F={tan_phi}\nROUND 0.05\nBLOCK 0,0 0,1 10,1 10,0\nBLOCK 1,1 1,1.5 3,1.5 3,1\n\
         FIX 0 10 0 0.9\nGRAV {} {}\n{}",
        1e9 / r,
        10.0 * psi.sin(),
        -10.0 * psi.cos(),
        ctx.frac_line()
    );
    let n = ctx.cycles_for(&setup, 1.0).map_err(|f| f.message)?;
    let (m, _) = ctx.run(&format!("{setup}CYCLE {n}\n")).map_err(|f| f.message)?;
    let t = m.time;
    let expected = 0.5 * 10.0 * t * t * (psi.sin() - psi.cos() * tan_phi);
    let slid = m.blocks[1].centroid[0] - 2.0;
    Ok((slid - expected).abs() / expected)
}

/// The relative error of the interface forces of the mass-ratio column (a block 1/`r` as heavy
/// on a heavy one on a fixed base) on `backend` at FRACTION 0.1: the check behind the "mass
/// ratio" limit.
pub fn column_mass_ratio_error(backend: &BackendEntry, r: f64) -> Result<f64, String> {
    column_mass_ratio(&Ctx { frac: super::CHECK_FRAC, backend }, r)
}

fn column_mass_ratio(ctx: &Ctx, r: f64) -> Result<f64, String> {
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nPROP MAT=2 D={:e} KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 4,1 4,0\n\
         BLOCK 1,1 1,2 2,2 2,1\nBLOCK MAT=2 1,2 1,3 2,3 2,2\nFIX 0 4 0 0.9\nGRAV 0 -10\nDAMP 0.5 50 MASS\n{}",
        2000.0 / r,
        ctx.frac_line()
    );
    let n = ctx.cycles_for(&setup, 2.7).map_err(|f| f.message)?;
    let (m, _) = ctx.run(&format!("{setup}CYCLE {n}\n")).map_err(|f| f.message)?;
    let (heavy, light) = (2000.0 * 10.0, 2000.0 / r * 10.0);
    let force = |a: u32, b: u32| -> f64 {
        let (ia, ib) = (m.block_index(a).unwrap() as u32, m.block_index(b).unwrap() as u32);
        m.contacts.iter().filter(|c| (c.block1 == ia && c.block2 == ib) || (c.block1 == ib && c.block2 == ia)).map(|c| c.normal_force).sum()
    };
    let e1 = (force(1, 2) - (heavy + light)).abs() / (heavy + light);
    let e2 = (force(2, 3) - light).abs() / light;
    Ok(e1.max(e2))
}
