//! The verification suite through the library API: every closed-form check of `blockdem verify
//! --quick` passes on every backend of this build (the CPU and every GPU adapter and precision
//! present), the energy ledger balances, and the stable-FRAC estimate is safe against the
//! measured threshold of instability.

use crate::common;

use blockdem::verify::{self, cases, VerifyOptions};

/// The cases that report an energy balance (the ledger's 1% check).
const LEDGER_CASES: [&str; 4] = ["slide", "bounce_dashpot", "vibration_mass", "column"];

#[test]
fn quick_suite_passes_every_check() {
    // The backends side by side: the suite is most of this file's time on CI's two cores.
    let suite = verify::run_suite(&VerifyOptions { quick: true, out: None, only: None, side_by_side: true });
    let table = verify::table(&suite);
    let backends = verify::backends();
    // Every case on every backend (the SDEF, FDEF, fluid and D3 cases too); D3's at the check
    // FRACTION only.
    let fluid = cases::all().iter().filter(|c| c.name.starts_with(cases::FLUID_PREFIX)).count();
    let d3 = cases::all().iter().filter(|c| c.name.starts_with(verify::d3::D3_PREFIX)).count();
    let expected: usize = backends.len() * cases::all().len();
    assert!(fluid == 4 && table.contains("fluid_cubic_law"), "{table}");
    assert_eq!(d3, 8, "{table}");
    for name in ["d3_tumbling", "d3_slide", "d3_stick", "d3_stack", "d3_topple", "d3_wedge", "d3_sdef_column", "d3_sdef_breathing"] {
        let rows: Vec<_> = suite.rows.iter().filter(|r| r.case == name).collect();
        assert!(rows.len() == backends.len() && rows.iter().all(|r| r.is_check), "{name}: {} rows\n{table}", rows.len());
        // A GPU row (lavapipe f32 and f64, llvmpipe f32 here) carries the CPU's error beside its
        // own and passes the GPU tolerance against it.
        for r in rows.iter().filter(|r| r.backend != "cpu") {
            assert!(r.detail.starts_with("cpu f64 error") && r.detail.contains("gpu tolerance"), "{name} on {}: {}", r.backend_name(), r.detail);
        }
    }
    for (api, precision) in common::GPU_TARGETS {
        if common::Target::gpu(api, precision).is_some() {
            let p = precision.to_string();
            assert!(
                suite.rows.iter().any(|r| r.case == "d3_wedge" && r.backend.starts_with(&format!("{api} (")) && r.precision == p),
                "no d3_wedge row on {api} {p}\n{table}"
            );
        }
    }
    // The 3D closed forms say what they saw: the intermediate axis flips with the free top's
    // period, the others keep their spin; the held wedge creeps by less than 1% of the slide.
    let detail = |name: &str| suite.rows.iter().find(|r| r.case == name).map(|r| r.detail.clone()).unwrap_or_default();
    let tumbling = detail("d3_tumbling");
    assert!(tumbling.contains("y (intermediate)") && tumbling.contains("flips, period") && tumbling.matches("keeps its spin").count() == 2, "{tumbling}");
    assert!(detail("d3_topple").matches("Topples").count() == 1 && detail("d3_topple").matches("Slides").count() == 1, "{table}");
    // The simply-deformable column carries its mean stress; the free cube breathes, unsheared.
    assert!(detail("d3_sdef_column").contains("σzz") && detail("d3_sdef_breathing").contains("shear strain ≤ 0.0e0"), "{table}");
    assert_eq!(suite.checks().count(), expected, "one check per case and backend\n{table}");
    assert!(table.contains("sdef_uniaxial") && table.contains("griffith_threshold"), "{table}");
    for r in suite.checks() {
        assert!(
            r.passed,
            "{} on {} {} failed: error {:?} (tolerance {}), energy balance {:?}, {:?}\n{table}",
            r.case, r.backend, r.precision, r.error, r.tolerance, r.energy_balance, r.failure
        );
        // The ledger balances on the GPU rows too: their kernels book every dissipation term.
        if LEDGER_CASES.contains(&r.case) {
            assert!(
                r.energy_balance.is_some_and(|e| e < verify::ENERGY_TOLERANCE),
                "{} on {}: energy balance {:?}\n{table}",
                r.case,
                r.backend_name(),
                r.energy_balance
            );
        }
    }
    assert!(table.contains("STABLE FRACTION") && !suite.stability.is_empty(), "{table}");
    for t in &suite.stability {
        assert!(t.passed, "stable-FRAC estimate of {}: {} against a measured threshold {}\n{table}", t.scene, t.estimate, t.measured);
    }
    assert!(suite.all_checks_pass());
}

#[test]
fn verify_runs_on_every_gpu_target_of_the_scenario_suite() {
    // One list of GPU targets for the scenario tests and the suite (`gpu::scenario_backends`): each
    // target the scenario tests find (Vulkan f32 and f64, GL f32; a failure under
    // BLOCKDEM_REQUIRE_GPU=1 when absent) is a row of `blockdem verify`.
    let backends = verify::backends();
    assert_eq!((backends[0].label.as_str(), backends[0].precision.as_str(), backends[0].gpu), ("cpu", "f64", false));
    for (api, precision) in common::GPU_TARGETS {
        if common::Target::gpu(api, precision).is_none() {
            continue;
        }
        let p = precision.to_string();
        assert!(
            backends.iter().any(|b| b.gpu && b.label.starts_with(&format!("{api} (")) && b.precision == p),
            "no {api} {p} row among {:?}",
            backends.iter().map(|b| b.name()).collect::<Vec<_>>()
        );
    }
    // Mesa's software adapters carry their driver's name.
    for b in backends.iter().filter(|b| b.gpu) {
        assert!(!b.label.contains("llvmpipe") || b.label == "gl (llvmpipe)", "{}", b.label);
        assert!(!b.label.starts_with("vulkan (llvmpipe"), "{}: Mesa's Vulkan driver is lavapipe", b.label);
    }
}

#[test]
fn energy_ledger_balances_within_one_percent_on_the_closed_form_scenes() {
    // E_kin + E_strain + W_damping + W_friction = E_0 + W_external (issue 4, item 3).
    let backends = verify::backends();
    for case in cases::all() {
        if !LEDGER_CASES.contains(&case.name) {
            continue;
        }
        let row = verify::run_case(&case, &backends[0], verify::CHECK_FRAC);
        let balance = row.energy_balance.unwrap_or_else(|| panic!("{} reports no energy balance: {:?}", case.name, row.failure));
        assert!(balance < 0.01, "{}: ledger drifts by {balance:.3e} of its largest term ({})", case.name, row.detail);
    }
}

#[test]
fn a_deleted_loaded_contact_keeps_the_ledger_balanced() {
    // A column settled under gravity, then its top block deleted while its contacts carry the
    // weight: the strain and kinetic energy leave through `released`, the ledger stays put.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 4,1 4,0\n\
         BLOCK 1,1 1,2 2,2 2,1\nBLOCK 1,2 1,3 2,3 2,2\nFIX 0 4 0 0.9\nGRAV 0 -10\nDAMP 0.5 50 MASS\nCYCLE 1\n";
    let first = blockdem::scenes::run_deck_on(deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap().energies();
    let m =
        blockdem::scenes::run_deck_on(&format!("{deck}CYCLE 1500\nDELETE 0 4 2 3\nCYCLE 1500\n"), Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    let end = m.energies();
    assert!(end.released > 0.0, "the deleted block's contacts carried strain energy");
    let drift = (end.ledger() - first.ledger()).abs() / end.scale();
    assert!(drift < 0.01, "ledger drift {drift:.3e}: {end:?}");
}

#[test]
fn energy_json_names_every_term() {
    let m = blockdem::scenes::run_deck_on(
        "START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nGRAV 0 -10\nCYCLE 10\n",
        Box::new(blockdem::udec::cpu::CpuBackend::new()),
    )
    .unwrap();
    let j = blockdem::udec::output::state_json::energy_json(&m.energies());
    for key in ["kinetic", "strain", "external_work", "mass_damping", "contact_damping", "friction", "released", "ledger"] {
        assert!(j[key].is_number(), "{key} missing in {j}");
    }
    // The state file carries the same terms under `energy`.
    let state = blockdem::udec::output::state_json::state_json(&m);
    assert_eq!(state["energy"], j);
    assert!(state["energy"]["external_work"].as_f64().unwrap() > 0.0, "gravity did work on the falling block");
}

#[test]
fn a_model_beyond_the_verified_ratios_is_warned_before_cycle() {
    let mut log = Vec::new();
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E5 F=0.5\nPROP MAT=2 D=1E-4 KN=1E9 KS=1E5\nROUND 0.05\nBLOCK 1E11,1E11 1E11,100000000001 100000000001,100000000001 100000000001,1E11\n\
         BLOCK MAT=2 0,0 0,1 1,1 1,0\nCYCLE 1\n";
    let r = blockdem::scenes::run_deck_logged(deck, Box::new(blockdem::udec::cpu::CpuBackend::new()), Box::new(&mut log));
    assert!(r.is_ok(), "{:?}", r.err());
    let text = String::from_utf8(log).unwrap();
    assert!(text.contains("WARNING: block masses range"), "{text}");
    assert!(text.contains("WARNING: material 1 has KN/KS"), "{text}");
    assert!(text.contains("WARNING: blocks lie"), "{text}");
    let warn = text.find("WARNING").unwrap();
    assert!(warn < text.find("INITIAL TIMESTEP").unwrap(), "warnings come before the run: {text}");
}

#[test]
fn an_unstable_fraction_stops_naming_the_cause_and_a_safe_fraction_and_never_nan() {
    // FRAC twice the measured threshold on the block-on-base scene.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\nGRAV 0 -10\nFRAC 1.3\nCYCLE 3000\n";
    let err = blockdem::scenes::run_deck_on(deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap_err();
    let msg = err.to_string();
    assert!(err.is_numerical() && msg.contains("FRACTION") && msg.contains("largest safe value"), "{msg}");
    // The safe value named must itself run clean.
    let safe: f64 = msg.split("largest safe value is about ").nth(1).unwrap().trim_end_matches(')').parse().unwrap();
    assert!(safe > 0.05 && safe < 1.3, "{msg}");
    let ok = blockdem::scenes::run_deck_on(&deck.replace("FRAC 1.3", &format!("FRAC {safe}")), Box::new(blockdem::udec::cpu::CpuBackend::new()));
    assert!(ok.is_ok(), "the named FRAC {safe} fails too: {:?}", ok.err());
}

#[test]
fn the_safe_fraction_named_accounts_for_contact_dashpots() {
    // Stiffness-proportional damping (contact dashpots −β·k·v on the last half step's velocity)
    // narrows the stable range of central differences to Δt ≤ (2/ω)(√(1+ξ²) − ξ), ξ = βω/2: the
    // block on its base with DAMP 1 20 STIFF diverges at FRAC ≈ 0.26 and with DAMP 1 5 STIFF at
    // ≈ 0.07, below the 0.38 the undamped estimate named. The estimate stays safe (at or below
    // the measured threshold) and within a factor 4 of it (the Gershgorin bound on ω enters
    // squared once ξ is large), and the message of the failure names it.
    let entry = verify::BackendEntry::new("cpu", "f64", || Box::new(blockdem::udec::cpu::CpuBackend::new()));
    let base = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nFIX 0 4 0 0.9\nGRAV 0 -10\n";
    for damp in ["DAMP 1 20 STIFF", "DAMP 1 5 STIFF"] {
        let deck = format!("{base}{damp}\n");
        let t = verify::stability::threshold("dashpots", &deck, 2000, &entry, 9);
        assert!(t.estimate <= t.measured && t.estimate > t.measured / 4.0, "{damp}: estimate {} against a measured threshold {}", t.estimate, t.measured);
        let err =
            blockdem::scenes::run_deck_on(&format!("{deck}FRAC 0.5\nCYCLE 3000\n"), Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap_err().to_string();
        let named: f64 = err.split("largest safe value is about ").nth(1).unwrap_or_else(|| panic!("{damp}: {err}")).trim_end_matches(')').parse().unwrap();
        assert!((named - t.estimate).abs() < 0.006, "{damp}: named {named}, estimate {}: {err}", t.estimate);
    }
}

#[test]
fn the_f32_kernels_resolve_a_light_block_on_a_heavy_one() {
    // The extreme-ratio column (a block 1/100 as heavy on a heavy one, on a fixed base): its
    // interface forces are the weights above to f32 round-off on the f32 kernels, as on the CPU.
    // They were 5% off while the contact stage measured gaps from a circle centre rounded to the
    // f32 ulp of the centroid distance (the light block's force jumped by kn × ulp and never
    // settled); `circle_parts` in contact_forces.wgsl keeps the exact position.
    for b in verify::backends().iter().filter(|b| b.gpu && b.precision == "f32") {
        let e = verify::stability::column_mass_ratio_error(b, 100.0).unwrap_or_else(|e| panic!("{}: {e}", b.name()));
        assert!(e < 1e-5, "{}: interface forces {e:e} off at a mass ratio of 100", b.name());
    }
}

/// Mesh convergence (issue 29): the zoned column's stress error, measured over one region for
/// every mesh, falls with the zone size, at about first order (halving the zones' size at least
/// 1.7 times smaller an error each time), on the CPU reference.
#[test]
fn the_zoned_column_converges_with_the_zone_size() {
    let cpu = verify::BackendEntry::new("cpu", "f64", || Box::new(blockdem::udec::cpu::CpuBackend::new()));
    let all = cases::all();
    let error = |name: &str| {
        let case = all.iter().find(|c| c.name == name).expect("the case");
        let row = verify::run_case(case, &cpu, verify::CHECK_FRAC);
        assert!(row.passed, "{name}: {row:?}");
        row.error.expect("measured")
    };
    let (coarse, mid, fine) = (error("fdef_column_coarse"), error("fdef_column"), error("fdef_column_fine"));
    assert!(coarse / mid > 1.7 && mid / fine > 1.7, "zones 0.6, 0.3, 0.15 m: errors {coarse:.3e}, {mid:.3e}, {fine:.3e}");
}
