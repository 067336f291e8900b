//! The closed-form problems of the suite (DESIGN.md §6). Each case builds its scene as a deck, runs
//! it through the executor on the backend it is given, and returns its error against the closed
//! form. Every tolerance says why it is what it is.
//!
//! Damping conventions used below (UDEC 1.2's, kept in `exec/materials.rs`): `DAMP ξ f` sets α = ξω and
//! β = ξ/ω with ω = 2πf, so that the Rayleigh ratio ξ(ω) = ½(α/ω + βω) has its minimum ξ at f.
//! With `MASS` or `STIFFNESS` alone one term is dropped and the other kept, so the ratio at f is
//! ξ/2. The cases ask for the ratio they want, ζ, by giving `DAMP 2ζ f …` at the oscillator's
//! own frequency f, and say so.

use std::f64::consts::PI;
use std::fmt::Write as _;

use super::{energy_balance, Ctx, Failure, Measured};
use crate::scenes::{SDEF_G, SDEF_K};
use crate::udec::model::Model;

/// One closed-form problem.
pub struct Case {
    pub name: &'static str,
    /// The closed form, in words.
    pub closed_form: &'static str,
    /// Largest error for a pass, in the case's own measure.
    pub tolerance: f64,
    /// Why that tolerance.
    pub why: &'static str,
    pub run: fn(&Ctx) -> Result<Measured, Failure>,
}

/// Every case, in the order the table prints them.
pub fn all() -> Vec<Case> {
    vec![
        Case {
            name: "free_flight",
            closed_form: "x(t) = x0 + v0 t + ½ g t² (relative position error after 0.5 s)",
            tolerance: 5e-3,
            why: "central differences integrate constant acceleration exactly except for the half-step offset ½gtΔt of the \
                  starting velocity: 0.1% of the flight at FRAC 0.1, 1% at FRAC 1",
            run: free_flight,
        },
        Case {
            name: "slide",
            closed_form: "s = ½ g t² (sin ψ − cos ψ tan φ), ψ = 30°, tan φ = 0.3 (relative error after 1 s)",
            tolerance: 0.02,
            why: "the block lands on unstressed springs and the normal force rings undamped at the contact frequency, so \
                  friction is briefly below μ m g cos ψ; that transient is under 2% of a metre-scale slide",
            run: slide,
        },
        Case {
            name: "stick",
            closed_form: "no slip when ψ < φ: ψ = 10°, tan φ = 0.3 (displacement over the frictionless slide)",
            tolerance: 1e-3,
            why: "the block moves only by the elastic shear of its contacts and creep while the undamped normal force rings \
                  (~1e-4 of the frictionless slide)",
            run: stick,
        },
        Case {
            name: "topple_vs_slide",
            closed_form: "topples when b/h < tan ψ, slides when tan ψ > μ (ψ = 30°; fraction of 4 regimes misjudged)",
            tolerance: 0.0,
            why: "each scene sits 20% from its regime boundary, far more than the rounding (2% of the width) and contact \
                  deflection shift it: every regime must be right",
            run: topple_vs_slide,
        },
        Case {
            name: "column",
            closed_form: "interface normal force = weight of the blocks above (largest relative error of 4 interfaces)",
            tolerance: 0.01,
            why: "heavily mass-damped settling for 2.7 s leaves a residual vibration of e^(−αt) ≈ 0; 1% covers round-off \
                  and the contact points' lever arms",
            run: column,
        },
        Case {
            name: "bounce_dashpot",
            closed_form: "e = exp(−πζ/√(1−ζ²)), contact time π/(ω√(1−ζ²)), ω = √(2kn/m), ζ = 0.1 (largest relative error)",
            tolerance: 0.03,
            why: "the contact lasts ~11 steps at FRAC 0.1; central differences shift the frequency by (ωΔt)²/24 ≈ 0.3% and \
                  the dashpot uses half-step velocities, an O(ωΔt·ζ) error in e of ~2%",
            run: bounce_dashpot,
        },
        Case {
            name: "vibration_mass",
            closed_form: "logarithmic decrement 2πζ/√(1−ζ²) of a block on its contacts, ζ = α/2ω = 0.05 (relative error)",
            tolerance: 0.02,
            why: "22 steps a period at FRAC 0.1: the scheme's own damping error is O((ωΔt)²) ≈ 1%; peaks are found by \
                  parabolic interpolation (< 0.1%)",
            run: vibration_mass,
        },
        Case {
            name: "pwave_joint",
            closed_form: "|T| = [1 + (ωZ/2kn)²]^−½, Z = ρc, c = L√(K/m) of the chain; ωZ/2kn = 1 (relative error)",
            tolerance: 0.03,
            why: "20 blocks a wavelength: the chain's dispersion is (kL)²/24 ≈ 0.4% and a discrete joint differs from the \
                  continuum one by O(kL/2)² ≈ 2.5%",
            run: pwave_joint,
        },
        Case {
            name: "impact",
            closed_form: "equal squares meet head-on at 5 m/s, elastic, no damping: they trade speeds and keep the kinetic energy \
                          (relative energy error after they part)",
            tolerance: 0.02,
            why: "the contact lasts ~8 steps at FRAC 0.1 (ωΔt = 0.4) and central differences sample the spring's kink at \
                  the touch and at the parting once a step: the error depends on where in its step each falls, up to ±1.3% \
                  (1.27% for this touch, mid-step), zero on average over touch phases, falling as FRAC² (issue 27 item 4)",
            run: impact,
        },
        Case {
            name: "joint_shear",
            closed_form: "direct shear of a joint (¶5): τ = JKS·u below the peak τp = JCOH + σn·JFRIC, slip above it (relative \
                          error of u at τ = τp/2 and 0.9τp; a wrong regime at 0.9τp or 1.1τp counts 1)",
            tolerance: 0.01,
            why: "critically damped loading settles to e^(−ωt) ≈ 1e-4 of the load in the time given; the block's tilt under \
                  the load's moment changes neither the shear sum nor the shear displacement; f32 round-off is ~1e-6",
            run: joint_shear,
        },
        Case {
            name: "sdef_uniaxial",
            closed_form: "a simply-deformable square between a fixed base and a frictionless loaded platen: plane-strain \
                          uniaxial stress σ22 = −F/a, ε22 = σ22(λ+2G)/((λ+2G)² − λ²), ε11 = −λ/(λ+2G)·ε22 (largest relative error)",
            tolerance: 3e-3,
            why: "the lever arms of the applied stress are the strained block's, a second-order term of ε22 = −1.2e-3; the \
                  critically damped loading settles to ~1e-4 in the time given",
            run: sdef_uniaxial,
        },
        Case {
            name: "griffith_threshold",
            closed_form: "Griffith (¶17): a square under a frictionless platen cracks at F = 8·a·TF in compression (s1 = 0), \
                          at F = a·TF glued in tension (s1 = σ22), parallel to s2 (fraction of 4 loads at 0.98 and 1.02 of the \
                          threshold misjudged, in regime or crack direction)",
            tolerance: 0.0,
            why: "the loads sit 2% from the threshold, and critically damped loading overshoots by far less",
            run: griffith_threshold,
        },
        Case {
            name: "fdef_patch",
            closed_form: "patch test: grid points of a zoned irregular pentagon moving with a uniform velocity gradient L give every \
                          zone the stress increment D·sym(L)·Δt of plane-strain elasticity (largest error relative to the largest \
                          component)",
            tolerance: 1e-4,
            why: "constant-strain triangles reproduce a linear velocity field exactly; the zones are measured on the moved \
                  grid points (a relative change |L|Δt ≈ 1e-9) and f32 positions carry ~1e-7 of the pentagon's size over a \
                  zone's height",
            run: fdef_patch,
        },
        Case {
            name: "fdef_column",
            closed_form: "a zoned elastic column (1 × 2 m, zones ≤ 0.3 m) on a frictionless fixed base under its own weight: \
                          σyy = −ρg·depth at each zone's centroid, σxx = 0 (root mean square over the zones of the larger \
                          error of the two over ρgH, zones whose centroids lie 0.6 m or more above the base)",
            tolerance: 0.03,
            why: "a constant-strain zone carries one stress for a linear field, right at the centroid only on a regular \
                  mesh: on the generator's irregular one the error falls as the zone size (first order: \
                  fdef_column_coarse, fdef_column_fine). The base's contacts are point loads a zone apart, whose \
                  disturbance reaches about a zone up: the zones below 0.6 m (the coarse mesh's zone size) are left \
                  out of all three, so that they measure one region",
            run: fdef_column,
        },
        Case {
            name: "fdef_column_coarse",
            closed_form: "fdef_column with zones ≤ 0.6 m (mesh convergence: error against zone size and cost)",
            tolerance: 0.06,
            why: "two zones across the column: the error of a first-order field twice fdef_column's",
            run: fdef_column_coarse,
        },
        Case {
            name: "fdef_column_fine",
            closed_form: "fdef_column with zones ≤ 0.15 m (mesh convergence: error against zone size and cost)",
            tolerance: 0.02,
            why: "half fdef_column's error (first order in the zone size), at four times the zones and twice the cycles \
                  (their step); f32 near FRACTION 1 adds ~0.5e-2",
            run: fdef_column_fine,
        },
        Case {
            name: "fdef_pwave",
            closed_form: "a zoned bar 10 m long between frictionless fixed walls (plane strain, no lateral strain) moving at v₀ \
                          against a fixed end: the compression front reaches the free end at L/c_p, c_p = √((K + 4G/3)/ρ), where \
                          its velocity turns from −v₀ to +v₀ (relative error of the arrival time, the end's mean velocity \
                          crossing 0, sampled every 10 steps)",
            tolerance: 0.05,
            why: "the step front spreads over a few zones by the mesh's dispersion (its middle still travels at c_p); the \
                  walls' contact springs let the bar widen by ~1e-3 of its strain; sampling adds 10Δt ≈ 0.5% of L/c_p",
            run: fdef_pwave,
        },
    ]
    .into_iter()
    .chain(fluid_cases())
    .chain(super::d3::cases())
    .collect()
}

/// The names of the fluid cases start with this (they run on every backend, as the others do).
pub const FLUID_PREFIX: &str = "fluid_";

/// The closed forms of fluid flow (issue 30; SL-85-1 Appendix A ¶6–9), on the pinwheel of four
/// fixed blocks around a 1 × 1 void ([`FLUID_PINWHEEL`]), whose four joints each run from the void
/// to the outside, and on a block on a base.
fn fluid_cases() -> Vec<Case> {
    vec![
        Case {
            name: "fluid_cubic_law",
            closed_form: "steady flow along a joint between two fixed-pressure domains (the void at 1e5 Pa, the outer domain at 0):                           q = JPERM·a³·Δp/l, l = 1 m, in series over the joint's two contacts (each carrying l/2 at its aperture a, AZERO less \
                          the closure of its normal force: AZERO to round-off; largest relative error of the 8 contacts' flows); and the mass                           balance (stored − start − inflow − adjusted, over the stored volume)",
            tolerance: 1e-6,
            why: "2000 steps are ~2000 time constants of the joint domains, so the steady state is reached to round-off (in \
                  f32 the contacts' round-off overlap of ~5e-8 m closes the 1 mm aperture by ~5e-8 m through JKN: a³ \
                  moves 1.5e-4, which the series law with the contacts' own apertures follows)",
            run: fluid_cubic_law,
        },
        Case {
            name: "fluid_drainage",
            closed_form: "a closed void (A = 1 m²) draining through its four point contacts into fixed-pressure joint domains:                           p = p0·exp(−t/τ), τ = A_d/(bulkw·Σk_c) = 0.1 s (relative error at t = 2τ); and the mass balance",
            tolerance: 0.01,
            why: "the explicit update is (1 − Δt/τ)ⁿ, off exp(−nΔt/τ) by n(Δt/τ)²/2 = 4e-3 at FRAC 0.1 (Δt = 4e-4 s), growing                   as FRAC²",
            run: fluid_drainage,
        },
        Case {
            name: "fluid_buoyancy",
            closed_form: "a 1 × 1 m block (ρ = 2000) resting on a base in a fluid of ρw = 1000 under g = 10 weighs                           (ρ − ρw)·g·V = 1e4 N (relative error of the contact force sum)",
            tolerance: 1e-3,
            why: "critically damped settling for 0.05 s leaves e^(−ωt) ≈ e^(−50) of the load; the rest is round-off",
            run: fluid_buoyancy,
        },
        Case {
            name: "fluid_joint_opening",
            closed_form: "a joint (JKN = 1e10, l = 2 m) under a load of 2e5 Pa with its domain held at p = 1e5 Pa carries the                           effective stress σn′ = 2e5 − p and opens to a = AZERO − σn′/JKN (largest relative error of the contacts'                           normal force sum against (σ − p)·l and of the aperture's closure against σn′/JKN)",
            tolerance: 2e-3,
            why: "critically damped loading settles to e^(−ωt) ≈ 1e-4 in the time given; the block's tilt under the two                   contacts' unequal lever arms is below 1e-4",
            run: fluid_joint_opening,
        },
    ]
}

/// Four fixed blocks around a 1 × 1 hole (1.5, 1.5), each face against the next along 1 m: four
/// joints from the hole to the outside, at x = 2 (0 < y < 1), y = 2 (2 < x < 3), x = 1 (2 < y < 3)
/// and y = 1 (0 < x < 1). Each block reaches half a metre past the outer end of the joint it
/// closes, so that no two corners meet there: a touch of two coincident corners is traced by the
/// angle of its normal, an exact tie that round-off decides (the f32 kernels' normal, exact
/// where the CPU's is off by 5e-16, traced the joint domains into the outer one).
pub const FLUID_PINWHEEL: &str = "BLOCK CONS={c} -0.5,0 2,0 2,1 -0.5,1\nBLOCK CONS={c} 2,-0.5 3,-0.5 3,2 2,2\nBLOCK CONS={c} 1,2 3.5,2 3.5,3 1,3\n\
     BLOCK CONS={c} 0,1 1,1 1,3.5 0,3.5\nFIX -1 4 -1 4\n";

/// The fluid state's mass balance error over the stored volume (0 without fluid).
fn mass_balance(m: &Model) -> f64 {
    match (m.fluid, m.domains.as_ref()) {
        (Some(f), Some(d)) => {
            let stored = crate::udec::model::fluid::stored_volume(d, f.bulk);
            f.balance_error(stored).abs() / stored.abs().max(f.inflow.abs()).max(1e-300)
        }
        _ => 0.0,
    }
}

/// The pinwheel with constitutive number `cons`, material 1 as `props` gives it, and the fluid.
fn fluid_pinwheel(ctx: &Ctx, props: &str, cons: u32, fluid: &str) -> String {
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5 {props}\nROUND 0.05\n{}{}{fluid}\nCYCLE 0\n",
        FLUID_PINWHEEL.replace("{c}", &cons.to_string()),
        ctx.frac_line()
    )
}

fn fluid_cubic_law(ctx: &Ctx) -> Result<Measured, Failure> {
    let (k, a, p, l) = (1e5f64, 1e-3f64, 1e5f64, 1.0f64);
    let setup = fluid_pinwheel(ctx, &format!("JKN=1E10 JKS=1E10 JPERM={k:e} AZERO={a:e} CPERM=1E-9"), 2, "FLUID 1000 1E6");
    let (m, cost) = ctx.run(&format!("{setup}PFIX AT 1.5 1.5 {p:e}\nPFIX OUTER 0\nCYCLE 2000\n"))?;
    let d = m.domains.as_ref().ok_or_else(|| Failure { message: "no domains".into(), cost })?;
    // Each joint's two contacts (the joint domain between them) in series: q = Δp / Σ l_c/(k·a_i³).
    let mut joints: std::collections::BTreeMap<u32, Vec<(f64, f64, f64)>> = Default::default();
    for (i, (c, f)) in m.contacts.iter().zip(&d.flows).enumerate() {
        let joint = d
            .sides
            .get(i)
            .and_then(|s| s.iter().copied().find(|&x| d.list.get(x as usize).is_some_and(|x| x.kind == crate::udec::model::domain::DomainKind::Joint)));
        if let (true, Some(j), true) = (c.joint_length > 0.0, joint, f.flow != 0.0) {
            joints.entry(j).or_default().push((f.flow.abs(), f.aperture, c.joint_length));
        }
    }
    let flows: Vec<(f64, f64)> = joints
        .values()
        .filter(|v| v.len() == 2)
        .flat_map(|v| {
            let resistance: f64 = v.iter().map(|&(_, a, lc)| lc / (k * a * a * a)).sum();
            v.iter().map(move |&(q, _, _)| (q, p / resistance)).collect::<Vec<_>>()
        })
        .collect();
    if flows.len() != 8 {
        return Err(Failure { message: format!("expected 8 joint contacts carrying flow, two a joint, found {}", flows.len()), cost });
    }
    let expected = k * a * a * a * p / l;
    let worst = flows.iter().map(|(q, e)| (q - e).abs() / e).fold(0.0, f64::max);
    let balance = mass_balance(&m);
    let detail = format!(
        "q = {:.6e} … {:.6e} vs k·a³·Δp/l = {expected:.6e} at a = AZERO; mass balance {balance:.1e}",
        flows.iter().map(|f| f.0).fold(f64::INFINITY, f64::min),
        flows.iter().map(|f| f.0).fold(0.0, f64::max)
    );
    Ok(Measured { error: worst.max(balance), detail, cost, energy_balance: None })
}

fn fluid_drainage(ctx: &Ctx) -> Result<Measured, Failure> {
    let (bulk, kc, p0, area) = (1e6f64, 2.5e-6f64, 1e5f64, 1.0f64);
    let tau = area / (bulk * 4.0 * kc);
    let setup = fluid_pinwheel(ctx, &format!("CPERM={kc:e}"), 1, &format!("FLUID 1000 {bulk:e}"));
    let fixes = "PFIX OUTER 0\nPFIX AT 2 0.5 0\nPFIX AT 2.5 2 0\nPFIX AT 1 2.5 0\nPFIX AT 0.5 1 0\n";
    let start = format!("{setup}{fixes}PFIX AT 1.5 1.5 {p0:e}\nPFREE AT 1.5 1.5\n");
    let n = ctx.cycles_for(&start, 2.0 * tau)?;
    let (m, cost) = ctx.run(&format!("{start}CYCLE {n}\n"))?;
    let d = m.domains.as_ref().ok_or_else(|| Failure { message: "no domains".into(), cost })?;
    let hole = crate::udec::model::fluid::domain_at(&m, d, [1.5, 1.5]).ok_or_else(|| Failure { message: "no void at (1.5, 1.5)".into(), cost })?;
    let p = d.list[hole].pressure;
    let expected = p0 * (-m.time / tau).exp();
    let balance = mass_balance(&m);
    let error = (p - expected).abs() / expected;
    let detail = format!("p = {p:.5e} Pa at t = {:.4} s vs p0·exp(−t/τ) = {expected:.5e} (τ = {tau} s); mass balance {balance:.1e}", m.time);
    Ok(Measured { error: error.max(balance), detail, cost, energy_balance: None })
}

fn fluid_buoyancy(ctx: &Ctx) -> Result<Measured, Failure> {
    let (kn, mass) = (1e9f64, 2000.0f64);
    let f = (2.0 * kn / mass).sqrt() / (2.0 * PI);
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN={kn:e} KS={kn:e} F=0.5 CPERM=1E-12\nROUND 0.05\nBLOCK 0,-1 0,0 2,0 2,-1\nBLOCK 0.5,0 0.5,1 1.5,1 1.5,0\n\
         FIX 0 2 -1 -0.1\nGRAV 0 -10\nDAMP 2 {f} MASS\nFLUID 1000 1E9\nPFIX OUTER 0\n{}",
        ctx.frac_line()
    );
    let n = ctx.cycles_for(&setup, 0.05)?;
    let (m, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let expected = (2000.0 - 1000.0) * 10.0 * 1.0;
    let force: f64 = m.contacts.iter().filter(|c| m.counts_force(c)).map(|c| c.normal_force).sum();
    let error = (force - expected).abs() / expected;
    Ok(Measured { error, detail: format!("contact force {force:.3} N vs (ρ − ρw)gV = {expected} N"), cost, energy_balance: None })
}

fn fluid_joint_opening(ctx: &Ctx) -> Result<Measured, Failure> {
    let (jkn, l, sigma, p, a0) = (1e10f64, 2.0f64, 2e5f64, 1e5f64, 1e-4f64);
    // Normal ω = √(2·JKN·l_c/m) with m = 800 kg (2 × 0.2 m block): DAMP 2 f MASS at f = ω/2π
    // damps it critically.
    let omega = (2.0 * jkn * 0.5 * l / 800.0f64).sqrt();
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 JKN={jkn:e} JKS={jkn:e} F=0.5 JPERM=1 AZERO={a0:e} CPERM=1E-12\nROUND 0.05\n\
         BLOCK CONS=2 0,-1 0,0 4,0 4,-1\nBLOCK CONS=2 1,0 1,0.2 3,0.2 3,0\nFIX 0 4 -1 -0.1\nDAMP 2 {} MASS\nLOAD 0 4 0 0.2 0 {}\n\
         FLUID 0 1E9\nCYCLE 0\nPFIX OUTER 0\nPFIX AT 2 0 {p:e}\n{}",
        omega / (2.0 * PI),
        -sigma * l,
        ctx.frac_line()
    );
    let n = ctx.cycles_for(&setup, 0.05)?;
    let (m, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let top = m.block_index(2).expect("the loaded block") as u32;
    let joints: Vec<_> = m.contacts.iter().filter(|c| (c.block1 == top || c.block2 == top) && m.counts_force(c) && c.joint_length > 0.0).collect();
    if joints.len() != 2 {
        return Err(Failure { message: format!("expected the joint's two contacts, found {}", joints.len()), cost });
    }
    let force: f64 = joints.iter().map(|c| c.normal_force).sum();
    let effective = (sigma - p) * l;
    let mat = m.material(1);
    let closure = joints.iter().map(|c| a0 - crate::udec::model::fluid::aperture(c, mat)).sum::<f64>() / 2.0;
    let expected_closure = (sigma - p) / jkn;
    let errors = [(force - effective).abs() / effective, (closure - expected_closure).abs() / expected_closure];
    let detail = format!("Σ Fn = {force:.2} N vs (σ − p)·l = {effective:.0} N; closure {closure:.4e} m vs σn′/JKN = {expected_closure:.4e} m");
    Ok(Measured { error: errors[0].max(errors[1]), detail, cost, energy_balance: None })
}

fn impact(ctx: &Ctx) -> Result<Measured, Failure> {
    // Two 1 m squares (2000 kg, kn = 1e9 on each of the two corner pairs of the faces that meet):
    // reduced mass m/2 on 2kn, ω = 2√(kn/m). The touch falls mid-step at FRAC 0.1 (the gap is
    // 1 mm plus half a step's travel), the worst phase there; at other FRACs wherever it falls.
    let (v0, m) = (5.0f64, 2000.0f64);
    let step = v0 * 0.1 * 2.0 * (m / 1e9).sqrt();
    let gap = 1e-3 + 0.5 * step;
    let x = 1.0 + gap;
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.05\n{}BLOCK 0,0 0,1 1,1 1,0\nBLOCK {x},0 {x},1 {},1 {},0\n\
         VELOCITY 1.5 2.5 0 1 {} 0\n",
        ctx.frac_line(),
        x + 1.0,
        x + 1.0,
        -v0
    );
    let t_contact = PI / (2.0 * (1e9 / m).sqrt());
    let n = ctx.cycles_for(&setup, gap / v0 + t_contact + 0.01)?;
    let (model, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let (left, right) = (model.blocks[0].velocity[0], model.blocks[1].velocity[0]);
    let energy_in = 0.5 * m * v0 * v0;
    let kinetic = model.energies().kinetic;
    let error = (kinetic - energy_in).abs() / energy_in;
    if left >= 0.0 || model.contacts.iter().any(|c| c.normal_force != 0.0) {
        return Err(Failure { message: format!("the squares have not parted: velocities {left}, {right}"), cost });
    }
    // The error is the energy error itself (the ledger's balance is the same figure): no second
    // energy check.
    Ok(Measured {
        error,
        detail: format!("velocities {left:.5}, {right:.5} m/s ({:.1}, 0); kinetic energy {kinetic:.6e} J ({energy_in:.6e})", -v0),
        cost,
        energy_balance: None,
    })
}

/// The ledger after the first cycle (so that initial overlaps count as E₀) and at the end.
fn balance_of(ctx: &Ctx, setup: &str, end: &Model) -> Result<f64, Failure> {
    let (first, _) = ctx.run(&format!("{setup}CYCLE 1\n"))?;
    Ok(energy_balance(&first.energies(), &end.energies()))
}

// ---------------------------------------------------------------------------------------------

fn free_flight(ctx: &Ctx) -> Result<Measured, Failure> {
    let setup = format!("START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nGRAV 0 -10\n{}VELOCITY 0 1 0 1 3 4\n", ctx.frac_line());
    let n = ctx.cycles_for(&setup, 0.5)?;
    let (m, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let t = m.time;
    let exact = [0.5 + 3.0 * t, 0.5 + 4.0 * t - 5.0 * t * t];
    let c = m.blocks[0].centroid;
    let travel = ((exact[0] - 0.5).powi(2) + (exact[1] - 0.5).powi(2)).sqrt();
    let error = ((c[0] - exact[0]).powi(2) + (c[1] - exact[1]).powi(2)).sqrt() / travel;
    Ok(Measured { error, detail: format!("t={t:.4} s, at ({:.5}, {:.5}) vs ({:.5}, {:.5})", c[0], c[1], exact[0], exact[1]), cost, energy_balance: None })
}

/// A 2 × 0.5 m block on a fixed 10 m base under gravity tilted by ψ, friction tan φ.
fn plane_setup(psi_deg: f64, tan_phi: f64, frac: &str) -> String {
    let psi = psi_deg.to_radians();
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F={tan_phi}\nROUND 0.05\nBLOCK 0,0 0,1 10,1 10,0\nBLOCK 1,1 1,1.5 3,1.5 3,1\n\
         FIX 0 10 0 0.9\nGRAV {} {}\n{frac}",
        10.0 * psi.sin(),
        -10.0 * psi.cos()
    )
}

fn slide(ctx: &Ctx) -> Result<Measured, Failure> {
    let (psi, tan_phi) = (30.0f64, 0.3);
    let setup = plane_setup(psi, tan_phi, &ctx.frac_line());
    let n = ctx.cycles_for(&setup, 1.0)?;
    let (m, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let t = m.time;
    let r = psi.to_radians();
    let expected = 0.5 * 10.0 * t * t * (r.sin() - r.cos() * tan_phi);
    let slid = m.blocks[1].centroid[0] - 2.0;
    let balance = balance_of(ctx, &setup, &m)?;
    Ok(Measured {
        error: (slid - expected).abs() / expected,
        detail: format!("slid {slid:.5} m, expected {expected:.5} m at t={t:.4} s; friction work {:.4e} J", m.energies().friction),
        cost,
        energy_balance: Some(balance),
    })
}

fn stick(ctx: &Ctx) -> Result<Measured, Failure> {
    let setup = plane_setup(10.0, 0.3, &ctx.frac_line());
    let n = ctx.cycles_for(&setup, 1.0)?;
    let (m, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let slid = (m.blocks[1].centroid[0] - 2.0).abs();
    let frictionless = 0.5 * 10.0 * m.time * m.time * 10f64.to_radians().sin();
    Ok(Measured { error: slid / frictionless, detail: format!("moved {slid:.3e} m of a frictionless {frictionless:.3} m"), cost, energy_balance: None })
}

/// What a prism on an incline does (the topple-vs-slide cases of both engines).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Regime {
    Stands,
    Slides,
    Topples,
}

impl Regime {
    /// The regime of a prism turned by `turned` (rad) and moved `slid` (m) down the dip: it
    /// toppled above `toppled_above`, else slid more than 0.02 m, else stood.
    pub(super) fn of(turned: f64, slid: f64, toppled_above: f64) -> Regime {
        if turned > toppled_above {
            Regime::Topples
        } else if slid.abs() > 0.02 {
            Regime::Slides
        } else {
            Regime::Stands
        }
    }
}

fn topple_vs_slide(ctx: &Ctx) -> Result<Measured, Failure> {
    let psi = 30f64.to_radians();
    let tan = psi.tan();
    // (b/h, μ, expected): each 20% from a boundary.
    let scenes = [
        (0.8 * tan, 1.2 * tan, Regime::Topples),
        (1.2 * tan, 1.2 * tan, Regime::Stands),
        (1.5 * tan, 0.8 * tan, Regime::Slides),
        (1.5 * tan, 1.2 * tan, Regime::Stands),
    ];
    let mut wrong = 0;
    let mut cost = super::Cost::default();
    let mut detail = String::new();
    for (bh, mu, expected) in scenes {
        // Settled under the tilted gravity with heavy mass damping for 0.2 s (the contacts' ringing
        // decays as e^(−αt/2) ≈ 1e-7; a block that must slide or tip creeps < 2 mm meanwhile),
        // then released undamped for 0.8 s: a block that can stand stays at rest, without the
        // creep that undamped ringing of its normal force would cause (see `stick`).
        let (h, b) = (1.0, bh);
        let setup = format!(
            "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F={mu}\nROUND 0.01\nBLOCK -2,-1 -2,0 3,0 3,-1\nBLOCK 0,0 0,{h} {b},{h} {b},0\n\
             FIX -3 4 -2 -0.1\nGRAV {} {}\n{}DAMP 0.5 50 MASS\n",
            10.0 * psi.sin(),
            -10.0 * psi.cos(),
            ctx.frac_line()
        );
        let settle = ctx.cycles_for(&setup, 0.2)?;
        let n = ctx.cycles_for(&setup, 0.8)?;
        let (m, c) = ctx.run(&format!("{setup}CYCLE {settle}\nDAMP 0 1\nCYCLE {n}\n"))?;
        cost.add(c);
        let blk = &m.blocks[1];
        let rot = blk.rotation.abs();
        let dx = blk.centroid[0] - 0.5 * b;
        let got = Regime::of(rot, dx, 0.05);
        if got != expected {
            wrong += 1;
        }
        let _ = write!(detail, "b/h={bh:.3} μ={mu:.3}: {got:?} (θ={rot:.3}, dx={dx:.3}); ");
    }
    Ok(Measured { error: wrong as f64 / scenes.len() as f64, detail, cost, energy_balance: None })
}

fn column(ctx: &Ctx) -> Result<Measured, Failure> {
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 4,1 4,0\n\
         BLOCK 1,1 1,2 2,2 2,1\nBLOCK 1,2 1,3 2,3 2,2\nBLOCK 1,3 1,4 2,4 2,3\nBLOCK 1,4 1,5 2,5 2,4\n\
         FIX 0 4 0 0.9\nGRAV 0 -10\nDAMP 0.5 50 MASS\n{}",
        ctx.frac_line()
    );
    let n = ctx.cycles_for(&setup, 2.7)?;
    let (m, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let w = 2000.0 * 10.0;
    let mut worst: f64 = 0.0;
    let mut detail = String::new();
    for (k, (lower, upper)) in [(1u32, 2u32), (2, 3), (3, 4), (4, 5)].iter().enumerate() {
        let above = (4 - k) as f64 * w;
        let (ia, ib) = (m.block_index(*lower).unwrap() as u32, m.block_index(*upper).unwrap() as u32);
        let f: f64 = m.contacts.iter().filter(|c| (c.block1 == ia && c.block2 == ib) || (c.block1 == ib && c.block2 == ia)).map(|c| c.normal_force).sum();
        worst = worst.max((f - above).abs() / above);
        let _ = write!(detail, "{lower}-{upper}: {f:.1} N of {above:.0}; ");
    }
    let balance = balance_of(ctx, &setup, &m)?;
    Ok(Measured { error: worst, detail, cost, energy_balance: Some(balance) })
}

fn bounce_dashpot(ctx: &Ctx) -> Result<Measured, Failure> {
    // A 1 × 1 m block (m = 2000 kg) lands flat on two corner–edge contacts: total normal stiffness
    // 2kn, ω = √(2kn/m). The dashpots c = β·kn at each contact sum to 2βkn, so ζ = βω/2. DAMP with
    // STIFFNESS sets β = fcrit/(2πf): with f = ω/2π, fcrit = 2ζ gives ζ.
    let (kn, m, zeta, v0, gap0) = (1e8f64, 2000.0f64, 0.1f64, 0.1f64, 0.01f64);
    let omega = (2.0 * kn / m).sqrt();
    let f = omega / (2.0 * PI);
    let (y0, y1) = (1.0 + gap0, 2.0 + gap0);
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN={kn:e} KS={kn:e} F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,{y0} 1,{y1} 2,{y1} 2,{y0}\n\
         FIX 0 4 0 0.9\nDAMP {} {f} STIFFNESS\n{}VELOCITY 1 2 1 3 0 {}\n",
        2.0 * zeta,
        ctx.frac_line(),
        -v0
    );
    let wd = omega * (1.0 - zeta * zeta).sqrt();
    let t_contact = PI / wd;
    let total = gap0 / v0 + t_contact + 0.05;
    let n = ctx.cycles_for(&setup, total)?;
    let (model, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let b = &model.blocks[1];
    let v_out = b.velocity[1];
    if v_out <= 0.0 {
        return Err(Failure { message: format!("no rebound: vy = {v_out}"), cost });
    }
    let e = v_out / v0;
    let e_exact = (-PI * zeta / (1.0 - zeta * zeta).sqrt()).exp();
    // Free flight before and after is exact in central differences: the touch happens at
    // y = 1.5 (t = gap0/v0) and the release where the rebound line meets y = 1.5 again.
    let t_start = gap0 / v0;
    let t_end = model.time - (b.centroid[1] - 1.5) / v_out;
    let dur = t_end - t_start;
    let err = ((e - e_exact).abs() / e_exact).max((dur - t_contact).abs() / t_contact);
    let balance = balance_of(ctx, &setup, &model)?;
    Ok(Measured {
        error: err,
        detail: format!("e={e:.4} ({e_exact:.4}), contact {dur:.5} s ({t_contact:.5}); dashpot work {:.3e} J", model.energies().contact_damping),
        cost,
        energy_balance: Some(balance),
    })
}

fn vibration_mass(ctx: &Ctx) -> Result<Measured, Failure> {
    // The block rests on two contacts (2kn) preloaded by its weight: static overlap δ = mg/2kn, set
    // in the geometry so that it starts in equilibrium; a downward kick of half δω keeps the
    // contacts closed. DAMP 2ζ f MASS at f = ω/2π sets α = 2ζω, i.e. the ratio α/2ω = ζ (UDEC's
    // convention: MASS alone gives half the requested fraction at the centre frequency).
    let (kn, m, g, zeta) = (1e8f64, 2000.0f64, 10.0f64, 0.05f64);
    let omega = (2.0 * kn / m).sqrt();
    let f = omega / (2.0 * PI);
    let delta = m * g / (2.0 * kn);
    let (y0, y1) = (1.0 - delta, 2.0 - delta);
    let setup = format!(
        "START\nPROP MAT=1 D=2000 KN={kn:e} KS={kn:e} F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,{y0} 1,{y1} 2,{y1} 2,{y0}\n\
         FIX 0 4 0 0.9\nGRAV 0 -{g}\nDAMP {} {f} MASS\n{}VELOCITY 1 2 0.5 3 0 {}\n",
        2.0 * zeta,
        ctx.frac_line(),
        -0.5 * delta * omega
    );
    let periods = 10.0;
    let n = ctx.cycles_for(&setup, periods * 2.0 * PI / omega)?;
    let y_eq = 1.5 - delta;
    let mut z = Vec::with_capacity(n as usize);
    let (model, cost) = ctx.run_observed(&setup, n, |m| z.push(m.blocks[1].centroid[1] - y_eq))?;
    // Maxima of the displacement about equilibrium, refined by a parabola through three samples.
    let mut peaks = Vec::new();
    for i in 1..z.len().saturating_sub(1) {
        if z[i] > z[i - 1] && z[i] >= z[i + 1] && z[i] > 0.0 {
            let (a, b, c) = (z[i - 1], z[i], z[i + 1]);
            let denom = a - 2.0 * b + c;
            let p = if denom != 0.0 { b - 0.125 * (a - c).powi(2) / denom } else { b };
            peaks.push(p);
        }
    }
    if peaks.len() < 3 {
        return Err(Failure { message: format!("only {} peaks", peaks.len()), cost });
    }
    // Least-squares slope of ln(peak) against the peak number.
    let n_p = peaks.len() as f64;
    let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
    for (i, p) in peaks.iter().enumerate() {
        let (x, y) = (i as f64, p.ln());
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    let decrement = -(n_p * sxy - sx * sy) / (n_p * sxx - sx * sx);
    let exact = 2.0 * PI * zeta / (1.0 - zeta * zeta).sqrt();
    let balance = balance_of(ctx, &setup, &model)?;
    Ok(Measured {
        error: (decrement - exact).abs() / exact,
        detail: format!("decrement {decrement:.4} ({exact:.4}) over {} peaks; damping work {:.3e} J", peaks.len(), model.energies().mass_damping),
        cost,
        energy_balance: Some(balance),
    })
}

/// The P-wave chain: `n` blocks 1 × 1 m side by side (density 1000, kn = ks = 1e8 per contact,
/// two active corner–corner contacts per interface: K = 2kn), bonded with a cohesion far above
/// the wave's tension so the interfaces are linear springs both ways. The interface between block
/// `joint` and `joint + 1` takes material 2 with stiffness `kn_joint` per contact. A tone burst
/// of wavenumber k (4 wavelengths, Hann window) is given as initial velocities centred at x_p.
pub fn pwave_deck(n: usize, joint: Option<(usize, f64)>, k: f64, xp: f64, width: f64, v: f64, frac: &str) -> String {
    let mut d = String::new();
    let _ = writeln!(d, "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8 COH=1E12 F=1\nROUND 0.05");
    if let Some((_, kj)) = joint {
        let _ = writeln!(d, "PROP MAT=2 D=1000 KN={kj:e} KS={kj:e} COH=1E12 F=1");
    }
    for i in 0..n {
        let mat = if joint.is_some_and(|(j, _)| i == j + 1) { 2 } else { 1 };
        let _ = writeln!(d, "BLOCK MAT={mat} {i},0 {i},1 {},1 {},0", i + 1, i + 1);
    }
    d.push_str(frac);
    for i in 0..n {
        let x = i as f64 + 0.5 - xp;
        if x.abs() < 0.5 * width {
            let hann = 0.5 * (1.0 + (2.0 * PI * x / width).cos());
            let vi = v * (k * x).sin() * hann;
            let _ = writeln!(d, "VELOCITY {i} {} 0 1 {vi:e} 0", i + 1);
        }
    }
    d
}

fn pwave_joint(ctx: &Ctx) -> Result<Measured, Failure> {
    // Continuum approximation: 20 blocks a wavelength (kL = π/10), so the chain behaves as a bar
    // with E = K L/A, ρ = m/(A L), c = L√(K/m), Z = ρc = √(Km)/A; a joint of specific stiffness
    // κ = K_j/A gives ωZ/2κ = ωτK/(2K_j) with τ = √(m/K). The joint interface is the block-to-block
    // spring K in series with the joint K_j: K_i = 1/(1/K + 1/K_j), two contacts of K_i/2.
    let (kn, m) = (1e8f64, 1000.0f64);
    let big_k = 2.0 * kn;
    let tau = (m / big_k).sqrt();
    let k = 2.0 * PI / 20.0;
    let omega = k / tau; // c·k with c = L/τ, L = 1
    let x = 1.0; // ωZ/2κ
    let k_joint = omega * tau * big_k / (2.0 * x);
    let k_i = 1.0 / (1.0 / big_k + 1.0 / k_joint);
    let t_exact = 1.0 / (1.0 + x * x).sqrt();
    let (n, joint, receiver, xp, width) = (260usize, 130usize, 150usize, 60.5f64, 80.0f64);
    let window = 165.0 * tau;
    let mut spectra = [0.0f64; 2];
    let mut cost = super::Cost::default();
    let mut final_model = None;
    for (which, j) in [None, Some((joint, 0.5 * k_i))].into_iter().enumerate() {
        let setup = pwave_deck(n, j, k, xp, width, 0.01, &ctx.frac_line());
        let cycles = ctx.cycles_for(&setup, window)?;
        let (mut re, mut im) = (0.0, 0.0);
        let (model, c) = ctx.run_observed(&setup, cycles, |mdl| {
            // Velocities live at half steps: t − Δt/2.
            let t = mdl.time - 0.5 * mdl.timestep;
            let v = mdl.blocks[receiver].velocity[0];
            re += v * (omega * t).cos();
            im -= v * (omega * t).sin();
        })?;
        cost.add(c);
        spectra[which] = (re * re + im * im).sqrt();
        final_model = Some(model);
    }
    let t_meas = spectra[1] / spectra[0];
    let _ = final_model;
    Ok(Measured {
        error: (t_meas - t_exact).abs() / t_exact,
        detail: format!("|T| = {t_meas:.4} ({t_exact:.4}) at ωτ = {:.3}, K_joint/K = {:.3}", omega * tau, k_joint / big_k),
        cost,
        energy_balance: None,
    })
}

/// Direct shear of a joint (Appendix A ¶5): a 2 × 0.2 m block (constitutive 2) on a fixed base,
/// pressed by a normal load P and pushed by a shear load F at its centroid, under critical mass
/// damping (no gravity). Its bottom face and the base's top face are a joint of length L = 2:
/// two corner contacts, each carrying L/2 with stiffnesses JKS·L/2 and JKN·L/2. With σn = P/L
/// and τ = F/L, statics gives the joint's shear displacement u = τ/JKS while τ is below the peak
/// τp = JCOH + σn·JFRIC (eq. 20 over the joint: the contacts' caps JCOH·L/2 + JFRIC·Fn sum to
/// τp·L whatever the load's moment does to the two normal forces); above it the block slides.
pub fn joint_shear_deck(f_over_peak: f64, frac: &str) -> (String, f64) {
    let (l, p, jks, jcoh, jfric) = (2.0f64, 2e5f64, 1e9f64, 5e4f64, 0.5f64);
    let peak = (jcoh + p / l * jfric) * l;
    // Shear ω = √(JKS·L/m) = 1581 rad/s (m = 800 kg): DAMP 2 f MASS at f = ω/2π gives α = 2ω,
    // critical damping of the shear mode (the normal mode, √2 stiffer, at ζ = 0.71).
    let omega = (jks * l / 800.0f64).sqrt();
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 JKN=2E9 JKS={jks:e} JCOH={jcoh:e} JFRIC={jfric}\nROUND 0.05\n\
         BLOCK CONS=2 0,-1 0,0 4,0 4,-1\nBLOCK CONS=2 1,0 1,0.2 3,0.2 3,0\nFIX 0 4 -1 -0.1\nDAMP 2 {} MASS\n{frac}\
         LOAD 0 4 0 0.2 0 {}\nCYCLE 400\nLOAD 0 4 0 0.2 {} {}\nCYCLE 600\n",
        omega / (2.0 * PI),
        -p,
        f_over_peak * peak,
        -p
    );
    (deck, peak)
}

fn joint_shear(ctx: &Ctx) -> Result<Measured, Failure> {
    let (l, jks) = (2.0f64, 1e9f64);
    let mut worst: f64 = 0.0;
    let mut detail = String::new();
    let mut cost = super::Cost::default();
    for ratio in [0.5, 0.9, 1.1] {
        let (deck, peak) = joint_shear_deck(ratio, &ctx.frac_line());
        let (m, c) = ctx.run(&deck)?;
        cost.wall_s += c.wall_s;
        cost.cycles += c.cycles;
        let top = m.block_index(2).expect("the sheared block") as u32;
        let joints: Vec<_> = m.contacts.iter().filter(|c| c.block1 == top || c.block2 == top).filter(|c| m.counts_force(c)).collect();
        if joints.len() != 2 || joints.iter().any(|c| (c.joint_length - 0.5 * l).abs() > 1e-9) {
            let lengths: Vec<f64> = joints.iter().map(|c| c.joint_length).collect();
            let _ = write!(detail, "{ratio}τp: not one joint of length {l} ({lengths:?}); ");
            worst = worst.max(1.0);
            continue;
        }
        let u = joints.iter().map(|c| c.shear_displacement.abs()).sum::<f64>() / 2.0;
        let tau = ratio * peak / l;
        let elastic = tau / jks;
        if ratio < 1.0 {
            let e = (u - elastic).abs() / elastic;
            worst = worst.max(e);
            let _ = write!(detail, "{ratio}τp: u = {u:.4e} m vs τ/JKS = {elastic:.4e}; ");
        } else {
            // Sliding: far past the elastic displacement the peak would allow.
            let slid = u > 10.0 * peak / l / jks;
            if !slid {
                worst = worst.max(1.0);
            }
            let _ = write!(detail, "{ratio}τp: u = {u:.3e} m ({}); ", if slid { "slides" } else { "STICKS" });
        }
    }
    Ok(Measured { error: worst, detail, cost, energy_balance: None })
}

/// The platen scene (`scenes::sdef_platen_deck`, Griffith's constitutive number 3) at this
/// FRACTION.
fn sdef_platen_deck(ctx: &Ctx, load: f64, tf: f64) -> String {
    crate::scenes::sdef_platen_deck(load, tf, 3, &ctx.frac_line())
}

/// Cycles of the simply-deformable cases: 0.2 s of the UDEC time step at this FRACTION.
fn sdef_cycles(ctx: &Ctx, deck: &str) -> Result<u64, Failure> {
    ctx.cycles_for(deck, 0.2)
}

fn sdef_uniaxial(ctx: &Ctx) -> Result<Measured, Failure> {
    let f = 2e5;
    let deck = sdef_platen_deck(ctx, f, 0.0);
    let n = sdef_cycles(ctx, &deck)?;
    let (m, cost) = ctx.run(&format!("{deck}CYCLE {n}\n"))?;
    let b = (0..m.blocks.len()).find(|&b| m.sdef_of(b).is_some()).ok_or_else(|| Failure { message: "no simply-deformable block".into(), cost })?;
    let s = m.sdef[b];
    let (l, g) = (SDEF_K - 2.0 * SDEF_G / 3.0, SDEF_G);
    let sigma = -f;
    let e22 = sigma * (l + 2.0 * g) / ((l + 2.0 * g).powi(2) - l * l);
    let e11 = -l / (l + 2.0 * g) * e22;
    let errors = [(s.stress[2] - sigma).abs() / f, s.stress[0].abs() / f, (s.strain[2] - e22).abs() / e22.abs(), (s.strain[0] - e11).abs() / e22.abs()];
    let error = errors.iter().cloned().fold(0.0, f64::max);
    let detail = format!(
        "σ22 {:.5e} (−F/a {sigma:.5e}), σ11 {:.2e}, ε22 {:.5e} ({e22:.5e}), ε11 {:.5e} ({e11:.5e})",
        s.stress[2], s.stress[0], s.strain[2], s.strain[0]
    );
    Ok(Measured { error, detail, cost, energy_balance: None })
}

fn griffith_threshold(ctx: &Ctx) -> Result<Measured, Failure> {
    let tf = 5e4;
    let mut wrong = 0;
    let mut detail = String::new();
    let mut cost = super::Cost::default();
    // (load, compression?) at 0.98 and 1.02 of each threshold.
    for (compression, ratio) in [(true, 0.98), (true, 1.02), (false, 0.98), (false, 1.02)] {
        let threshold = if compression { 8.0 * tf } else { tf };
        let load = if compression { ratio * threshold } else { -ratio * threshold };
        // Loaded in two steps (the second small), so that the overshoot stays far below 2%.
        let first = sdef_platen_deck(ctx, 0.9 * load, tf);
        let n = sdef_cycles(ctx, &first)?;
        let (m, c) = ctx.run(&format!("{first}CYCLE {n}\nLOAD 0 3 1 1.5 0 {}\nCYCLE {n}\n", -load))?;
        cost.wall_s += c.wall_s;
        cost.cycles += c.cycles;
        let pieces: Vec<usize> = (0..m.blocks.len()).filter(|&b| m.sdef_of(b).is_some()).collect();
        let cracked = pieces.len() > 1;
        // The crack is parallel to s2: vertical in compression (pieces side by side), horizontal
        // in tension (one above the other).
        let direction_right = !cracked || {
            let (a, b) = (m.blocks[pieces[0]].centroid, m.blocks[pieces[1]].centroid);
            if compression {
                (a[0] - b[0]).abs() > (a[1] - b[1]).abs()
            } else {
                (a[1] - b[1]).abs() > (a[0] - b[0]).abs()
            }
        };
        let right = cracked == (ratio > 1.0) && direction_right;
        if !right {
            wrong += 1;
        }
        let _ = write!(
            detail,
            "{} {ratio}: {}; ",
            if compression { "compression" } else { "tension" },
            if cracked {
                if direction_right {
                    "cracks"
                } else {
                    "cracks ACROSS"
                }
            } else {
                "holds"
            }
        );
    }
    Ok(Measured { error: wrong as f64 / 4.0, detail, cost, energy_balance: None })
}

/// A zoned block on its own (no gravity): the irregular pentagon of the patch test.
const FDEF_PENTAGON: &str = "START\nPROP MAT=1 DENS=2000 K=1E9 G=6E8 KN=1E10 KS=1E10\nROUND 0.05\n\
                             BLOCK (0,0) (3.1,0.4) (3.6,2.3) (1.2,3.4) (-0.7,1.9)\nCHANGE -1 4 -1 4 FDEF\nGENERATE -1 4 -1 4 AUTO 0.5\n";

/// The zoned block of `m` (the first).
fn zoned_block(m: &Model, cost: super::Cost) -> Result<usize, Failure> {
    (0..m.blocks.len()).find(|&b| m.fdef_of(b).is_some_and(|f| !f.zones.is_empty())).ok_or_else(|| Failure { message: "no zoned block".into(), cost })
}

fn fdef_patch(ctx: &Ctx) -> Result<Measured, Failure> {
    let (mut m, cost) = ctx.run(&format!("{FDEF_PENTAGON}{}CYCLE 0\n", ctx.frac_line()))?;
    let b = zoned_block(&m, cost)?;
    let grad = [[1e-3, 4e-4], [-2e-4, -5e-4]];
    for g in &mut m.fdef[b].gridpoints {
        let p = g.position;
        g.velocity = [grad[0][0] * p[0] + grad[0][1] * p[1], grad[1][0] * p[0] + grad[1][1] * p[1]];
        // So heavy that the zones' forces do not change the velocities in the step.
        g.mass = 1e30;
    }
    let dt = m.timestep;
    let mut backend = (ctx.backend.make)();
    backend.run(&mut m, 1, &mut |_| true).map_err(|e| Failure { message: e.to_string(), cost })?;
    let mat = m.material(m.blocks[b].material).block;
    let lambda = mat.bulk - 2.0 * mat.shear / 3.0;
    let e = [grad[0][0] * dt, 0.5 * (grad[0][1] + grad[1][0]) * dt, grad[1][1] * dt];
    let want = crate::udec::model::fdef::stress_increment(e, lambda, mat.shear);
    let top = want.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let f = &m.fdef[b];
    let error = f.zones.iter().flat_map(|z| (0..3).map(move |i| (z.stress[i] - want[i]).abs() / top)).fold(0.0, f64::max);
    let s = f.zones[0].stress;
    let detail = format!(
        "{} zones; zone 1 σ ({:.6e}, {:.6e}, {:.6e}) against D·sym(L)Δt ({:.6e}, {:.6e}, {:.6e})",
        f.zones.len(),
        s[0],
        s[1],
        s[2],
        want[0],
        want[1],
        want[2]
    );
    Ok(Measured { error, detail, cost, energy_balance: None })
}

/// Height above the base below which `fdef_column_with` leaves the zones out, for every zone
/// size: the coarse mesh's zone size, so that the three meshes measure the same region.
const COLUMN_CUT: f64 = 0.6;

/// The zoned column of `fdef_column` with zones at most `amax` long: the root mean square, over
/// the zones whose centroids lie `COLUMN_CUT` or more above the base, of each zone's larger error
/// of σyy and σxx over ρgH (the worst zone in the detail).
fn fdef_column_with(ctx: &Ctx, amax: f64) -> Result<Measured, Failure> {
    let (rho, g, h) = (2000.0, 10.0, 2.0);
    // Its axial mode: c = √(E/ρ), E = 9KG/(3K + G) = 1.5e8 Pa, f = c/4H ≈ 34 Hz; mass damping
    // α = 0.8·2π·34 s⁻¹ takes every mode down by e^(−αt/2) ≈ e^(−13) in 0.15 s. The base's
    // contacts are stiff against the column (KN = 1e10 N/m a contact, against E ≈ 1.5e8 Pa over
    // a zone), so that it holds the column's bottom level and the weight goes down as in a
    // column on a rigid base, not shared by the contacts' springs.
    let setup = format!(
        "START\nPROP MAT=1 DENS={rho} K=1E8 G=6E7 KN=1E10 KS=1E10 F=0\nROUND 0.02\nBLOCK (-1,-1) (-1,0) (2,0) (2,-1)\n\
         BLOCK (0,0) (0,{h}) (1,{h}) (1,0)\nFIX -2 3 -2 -0.2\nCHANGE -0.5 1.5 0 {h} FDEF\nGENERATE -0.5 1.5 0 {h} AUTO {amax}\n\
         GRAV 0 -{g}\nDAMP 0.8 34 MASS\n{}",
        ctx.frac_line()
    );
    let n = ctx.cycles_for(&setup, 0.15)?;
    let (m, cost) = ctx.run(&format!("{setup}CYCLE {n}\n"))?;
    let b = zoned_block(&m, cost)?;
    let f = &m.fdef[b];
    let scale = rho * g * h;
    let (mut largest, mut worst, mut squares, mut counted) = (0.0f64, String::new(), 0.0, 0usize);
    for (z, zone) in f.zones.iter().enumerate() {
        let p = f.zone_points(z);
        let depth = h - (p[0][1] + p[1][1] + p[2][1]) / 3.0;
        // The base carries the column on its bottom grid points' contacts, point loads a zone
        // apart: their disturbance fades within about that distance (Saint-Venant), so the zones
        // whose centroids lie within the coarse mesh's zone size of the base are left out.
        if h - depth < COLUMN_CUT {
            continue;
        }
        let e = ((zone.stress[2] + rho * g * depth).abs() / scale).max(zone.stress[0].abs() / scale);
        squares += e * e;
        counted += 1;
        if e > largest {
            largest = e;
            worst = format!("zone {} at depth {depth:.2} m: σyy {:.4e} (−ρgd {:.4e}), σxx {:.3e}", z + 1, zone.stress[2], -rho * g * depth, zone.stress[0]);
        }
    }
    if counted == 0 {
        return Err(Failure { message: format!("no zone lies {COLUMN_CUT} m above the base"), cost });
    }
    let error = (squares / counted as f64).sqrt();
    let balance = balance_of(ctx, &setup, &m)?;
    let detail = format!("{} zones, {counted} measured; rms {error:.3e}, worst {largest:.3e}: {worst}", f.zones.len());
    Ok(Measured { error, detail, cost, energy_balance: Some(balance) })
}

fn fdef_column(ctx: &Ctx) -> Result<Measured, Failure> {
    fdef_column_with(ctx, 0.3)
}

fn fdef_column_coarse(ctx: &Ctx) -> Result<Measured, Failure> {
    fdef_column_with(ctx, 0.6)
}

fn fdef_column_fine(ctx: &Ctx) -> Result<Measured, Failure> {
    fdef_column_with(ctx, 0.15)
}

fn fdef_pwave(ctx: &Ctx) -> Result<Measured, Failure> {
    let (rho, k, g, len, v0): (f64, f64, f64, f64, f64) = (2000.0, 1e8, 6e7, 10.0, 0.1);
    let setup = format!(
        "START\nPROP MAT=1 DENS={rho} K={k:e} G={g:e} KN=1E10 KS=1E10 F=0\nROUND 0.01\n\
         BLOCK (-1,-1) (-1,1.5) (0,1.5) (0,-1)\nBLOCK (0,-1) (0,0) ({len},0) ({len},-1)\nBLOCK (0,0.5) (0,1.5) ({len},1.5) ({len},0.5)\n\
         BLOCK (0,0) (0,0.5) ({len},0.5) ({len},0)\nFIX -2 0 -2 2\nFIX 0 {x} -2 -0.1\nFIX 0 {x} 0.6 2\n\
         CHANGE 0 {x} 0.1 0.4 FDEF\nGENERATE 0 {x} 0.1 0.4 AUTO 0.25\nVELOCITY 0 {x} 0.1 0.4 -{v0} 0 0\n{}",
        ctx.frac_line(),
        x = len + 1.0
    );
    let c = ((k + 4.0 * g / 3.0) / rho).sqrt();
    let want = len / c;
    let (mut m, cost) = ctx.run(&format!("{setup}CYCLE 0\n"))?;
    let b = zoned_block(&m, cost)?;
    let far: Vec<usize> = m.fdef[b].gridpoints.iter().enumerate().filter(|(_, p)| p.position[0] > len - 1e-6).map(|(i, _)| i).collect();
    let dt = m.timestep;
    let (every, limit) = (10u64, (1.5 * want / dt).ceil() as u64);
    let mut backend = (ctx.backend.make)();
    let t0 = std::time::Instant::now();
    let mut arrival = None;
    while m.cycle < limit && arrival.is_none() {
        backend.run(&mut m, every, &mut |_| true).map_err(|e| Failure { message: e.to_string(), cost })?;
        let v: f64 = far.iter().map(|&i| m.fdef[b].gridpoints[i].velocity[0]).sum::<f64>() / far.len() as f64;
        if v >= 0.0 {
            arrival = Some(m.time);
        }
    }
    let cost = super::Cost { wall_s: cost.wall_s + t0.elapsed().as_secs_f64(), cycles: m.cycle };
    let Some(t) = arrival else {
        return Err(Failure { message: format!("the front did not reach the free end in {:.4} s (L/c_p = {want:.4} s)", m.time), cost });
    };
    let detail = format!("{} zones; arrival {t:.5} s, L/c_p {want:.5} s (c_p {c:.1} m/s)", m.fdef[b].zones.len());
    Ok(Measured { error: (t - want).abs() / want, detail, cost, energy_balance: None })
}
