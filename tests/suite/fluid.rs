//! Fluid flow in joints and voids (issue 30; SL-85-1 Appendix A ¶6–9, ¶19): sample 2 end to end
//! on the CPU with its outputs, the state JSON's keys, PFIX/PFREE by OUTER, id and AT through
//! contact updates, a dry scene that builds nothing, bad input naming its line, and sample 2 on
//! every backend against the CPU (the fluid's kernels, issue 30 item 7). The closed forms (cubic
//! law, drainage, buoyancy, a pressurized joint, the mass balance) are `blockdem verify`'s fluid
//! cases, run here on the CPU (tests/suite/verify.rs runs them on every backend).

use crate::common;

use blockdem::udec::model::domain::DomainKind;
use blockdem::udec::output::state_json;
use common::{run_logged, run_ok, sample, Target};

/// Four blocks around a 1 × 1 hole at (1.5, 1.5), each face against the next along 1 m; point
/// contacts with CPERM, and the fluid.
const PINWHEEL: &str = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5 CPERM=1E-9\nROUND 0.05\n\
    BLOCK 0,0 2,0 2,1 0,1\nBLOCK 2,0 3,0 3,2 2,2\nBLOCK 1,2 3,2 3,3 1,3\nBLOCK 0,1 1,1 1,3 0,3\nFLUID 1000 1E9\n";

#[test]
fn sample_2_runs_to_its_end_with_its_flows_domains_and_blocks() {
    let deck = sample("udec2_pressurized_cavity.dat");
    let (model, log) = run_ok(&deck);
    assert!(log.contains(")STOP") && log.contains("CURRENT CYCLE COUNT = 3000"), "{log}");
    // PRINT FLOWS, DOMAINS, BLOCKS in the report's layouts.
    for title in ["FLOW ACROSS CONTACTS OR JOINTS", "DOMAIN DATA", "BLOCK DATA"] {
        assert!(log.contains(&format!("\n{title}\n")), "{title}:\n{log}");
    }
    let flows = log.split("FLOW ACROSS CONTACTS OR JOINTS").nth(1).unwrap();
    let heading = flows.lines().nth(2).unwrap();
    for word in ["CONTACT", "X,Y COORDS.", "FLOW", "LENGTH", "APERTURE", "DOM1", "DOM2"] {
        assert!(heading.contains(word), "{heading}");
    }
    let domains = model.domains.as_ref().expect("a scene with fluid has its domains");
    let outer = domains.outer().unwrap();
    assert!(outer.fixed && outer.pressure == 0.0, "PFIX OUTER 0.0");
    // The cavity (10 × 10, less what the loaded block pushed into it and the right-hand block
    // gave back) holds the highest pressure; every free domain's lies between it and the outer's.
    let cavity = domains.list.iter().filter(|d| d.kind == DomainKind::Regular).max_by(|a, b| a.area.total_cmp(&b.area)).unwrap();
    assert!((cavity.area - 100.0).abs() < 5.0, "{}", cavity.area);
    assert!(cavity.pressure > 1e4, "{}", cavity.pressure);
    assert!(domains.list.iter().all(|d| d.pressure >= 0.0 && d.pressure <= cavity.pressure), "{:?}", domains.list);
    // The pressure drives the right-hand block (centroid 32.5, 15) outwards, the loaded block down.
    let right = model.blocks.iter().find(|b| (b.centroid[1] - 15.0).abs() < 1.0 && b.centroid[0] > 30.0).unwrap();
    assert!(right.centroid[0] > 32.5 && right.velocity[0] > 0.0, "{:?}", right.centroid);
    let loaded = model.blocks.iter().find(|b| (b.centroid[0] - 20.0).abs() < 1.0 && b.centroid[1] > 20.0).unwrap();
    assert!(loaded.centroid[1] < 25.0, "{:?}", loaded.centroid);
    // Flows run from high pressure to low, and leak to the outer domain.
    for (k, f) in domains.flows.iter().enumerate() {
        let [d0, d1] = domains.sides[k];
        if d0 == blockdem::udec::model::domain::NO_DOMAIN {
            continue;
        }
        let dp = domains.list[d0 as usize].pressure - domains.list[d1 as usize].pressure;
        // q = CPERM·Δp (¶6), CPERM = 1e-9, at the pressures the last cycle started from (the
        // update has moved them since by far less than a thousandth).
        assert!((f.flow - 1e-9 * dp).abs() <= 1e-3 * (1e-9 * dp).abs() + 1e-15, "contact {k}: {f:?}, Δp {dp}");
    }
    // The fluid stored and what crossed add up.
    let f = model.fluid.unwrap();
    let stored = blockdem::udec::model::fluid::stored_volume(domains, f.bulk);
    assert!(f.balance_error(stored).abs() < 1e-9 * stored, "{}", f.balance_error(stored));
    assert!(f.inflow < 0.0, "fluid leaves the model through the outer domain: {}", f.inflow);
    // The energy ledger balances: what the loads and the fluid put in is kinetic, strain,
    // damped or slipped (it was 26% off while a corner sat 2.9 cm deep in an edge with no force,
    // its pair's other view counting instead, and counted in full at once when the circles
    // parted: `contact::pair`). Its drift is 1.4e-4 of the energy in play.
    let e = model.energies();
    assert!(e.ledger().abs() < 1e-3 * e.scale(), "ledger {:e} of {:e}: {e:?}", e.ledger(), e.scale());
    assert!(!log.contains("THE ENERGY BALANCE IS"), "no ledger warning: {log}");
}

#[test]
fn the_state_json_has_the_keys_the_issue_names() {
    let (model, _) = run_ok(&sample("udec2_pressurized_cavity.dat"));
    let json = state_json::state_json(&model);
    let domains = json["domains"].as_array().unwrap();
    assert_eq!(domains.len(), model.domains.as_ref().unwrap().list.len());
    for d in domains {
        for key in ["id", "pressure", "area", "fixed", "outer"] {
            assert!(d.get(key).is_some(), "{key}: {d}");
        }
    }
    assert_eq!(domains.iter().filter(|d| d["outer"] == true).count(), 1);
    let flows = json["flows"].as_array().unwrap();
    assert!(!flows.is_empty());
    let ids: Vec<u64> = domains.iter().map(|d| d["id"].as_u64().unwrap()).collect();
    for f in flows {
        for key in ["contact", "domains", "flow", "length", "aperture"] {
            assert!(f.get(key).is_some(), "{key}: {f}");
        }
        let pair = f["domains"].as_array().unwrap();
        assert!(pair.len() == 2 && pair.iter().all(|d| ids.contains(&d.as_u64().unwrap())), "{f}");
        // Point contacts: no length, no aperture.
        assert_eq!((f["length"].as_f64(), f["aperture"].as_f64()), (Some(0.0), Some(0.0)), "{f}");
    }
    assert!(json["energy"]["fluid_work"].is_number() && json["fluid"]["balance_error"].is_number(), "{}", json["fluid"]);
}

#[test]
fn pfix_and_pfree_by_outer_id_and_point_hold_through_contact_updates() {
    let deck = format!("{PINWHEEL}CYCLE 0\nPFIX OUTER 0\nPFIX AT 1.5 1.5 1E5\nPRINT DOMAINS\nCYCLE 50\n");
    let (model, log) = run_ok(&deck);
    let d = model.domains.as_ref().unwrap();
    let hole = blockdem::udec::model::fluid::domain_at(&model, d, [1.5, 1.5]).unwrap();
    assert!(d.list[hole].fixed && d.list[hole].pressure == 1e5, "{:?}", d.list[hole]);
    assert!(log.contains("FIXED"), "{log}");
    // The hole's pressure pushes the four blocks outwards (nothing holds them).
    assert!(model.blocks.iter().all(|b| b.velocity[0].abs() + b.velocity[1].abs() > 0.0));
    // By id as PRINT DOMAINS shows it: PFREE the hole, then PFIX it again by its number.
    let id = d.list[hole].id;
    let (model, _) = run_ok(&format!("{deck}PFREE {id}\nCYCLE 10\nPFIX {id} 2E5\n"));
    let d = model.domains.as_ref().unwrap();
    let hole = d.index_of(id).unwrap();
    assert!(d.list[hole].fixed && d.list[hole].pressure == 2e5);
}

#[test]
fn a_dry_scene_builds_no_domains_and_carries_no_fluid() {
    let (model, _) = run_ok(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK 0,0 2,0 2,1 0,1\nBLOCK 0,1 2,1 2,2 0,2\nFIX 0 2 0 0.9\nGRAV 0 -10\nCYCLE 100\n",
    );
    assert!(model.domains.is_none() && model.fluid.is_none());
    let json = state_json::state_json(&model);
    assert!(json.get("domains").is_none() && json.get("flows").is_none() && json["energy"].get("fluid_work").is_none());
}

/// A deck's error: its line, and that its message contains each of `words`.
fn assert_error_at(deck: &str, line: usize, words: &[&str]) {
    let (r, log) = run_logged(deck);
    let e = r.expect_err(deck);
    let text = e.to_string();
    assert!(!text.contains("panicked"), "{text}");
    assert!(text.starts_with(&format!("<scene>:{line}:")), "line {line}: {text}\n{log}");
    for w in words {
        assert!(text.contains(w), "'{w}' in: {text}");
    }
}

#[test]
fn bad_fluid_input_names_its_line_and_what_was_expected() {
    let body = |more: &str| format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\n{more}");
    // FLUID with a non-positive bulk modulus or a negative density (the parser's).
    assert_error_at(&body("FLUID 1000 0\n"), 4, &["fluid bulk modulus must be positive"]);
    assert_error_at(&body("FLUID -1 1E9\n"), 4, &["fluid density must not be negative"]);
    // Negative apertures and permeabilities.
    assert_error_at(&body("PROP MAT=1 AZERO=-1E-4\n"), 4, &["azero"]);
    assert_error_at(&body("PROP MAT=1 ARES=-1\n"), 4, &["ares"]);
    assert_error_at(&body("PROP MAT=1 CPERM=-1\n"), 4, &["cperm"]);
    // No flow law where FLUID needs one, and a joint permeability without an aperture.
    assert_error_at(&body("FLUID 1000 1E9\nCYCLE 1\n"), 5, &["material 1 has no flow law", "CPERM", "JPERM"]);
    assert_error_at(
        "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 JKN=1E9 JKS=1E9 JPERM=1\nBLOCK CONS=2 0,0 0,1 1,1 1,0\nFLUID 1000 1E9\nCYCLE 1\n",
        5,
        &["JPERM but no aperture", "AZERO"],
    );
    // PFIX before FLUID, of an id that names no domain, of a point inside a block.
    assert_error_at(&body("PFIX OUTER 0\n"), 4, &["PFIX", "FLUID"]);
    assert_error_at(&format!("{PINWHEEL}CYCLE 0\nPFIX 999 1E5\n"), 10, &["PFIX: there is no domain 999", "PRINT DOMAINS"]);
    assert_error_at(&format!("{PINWHEEL}CYCLE 0\nPFREE AT 0.5 0.5\n"), 10, &["PFREE: there is no domain at (0.5, 0.5)"]);
    // Deformable blocks take the pressures on the CPU (tests/suite/fluid_deformable.rs); their flow laws
    // are checked as a rigid block's.
    assert_error_at(&body("PROP MAT=1 K=1E8 G=1E8\nCHANGE 0 1 0 1 SDEF\nFLUID 1000 1E9\nCYCLE 1\n"), 7, &["material 1 has no flow law"]);
}

#[test]
fn the_fluid_closed_forms_pass_on_the_cpu() {
    let backend = blockdem::verify::backends().into_iter().find(|b| !b.gpu).unwrap();
    for case in blockdem::verify::cases::all().into_iter().filter(|c| c.name.starts_with(blockdem::verify::cases::FLUID_PREFIX)) {
        let row = blockdem::verify::run_case(&case, &backend, blockdem::verify::CHECK_FRAC);
        assert!(row.passed, "{}: error {:?} (tolerance {}), {} {:?}", case.name, row.error, case.tolerance, row.detail, row.failure);
    }
}

/// Sample 2 on every backend against the CPU reference (issue 30 item 7: the flows, the pressure
/// update and the loads on the device): the domains' pressures, the contacts' flows, the blocks'
/// positions and the mass balance. f64 kernels agree to round-off (measured on lavapipe 1.6e-11
/// of the largest pressure, 8e-14 m, flows 1.8e-11, fluid work 2e-12). f32 follows a void by its
/// boundary's motion (`AREA_BY_MOTION`): measured 3.3e-5 of the largest pressure, flows 3.3e-5
/// of the largest, 4.9e-6 m, the fluid work 1.3e-3 (summed per block in f32 over 3000 steps of
/// both signs); where it took the difference of two f32 areas, 2.6e-3 of the largest pressure and
/// 4.8e-3 of the largest flow.
fn sample_2_agrees_with_the_cpu(t: &Target) {
    let deck = sample("udec2_pressurized_cavity.dat");
    let (reference, _) = run_ok(&deck);
    let m = t.run(&deck);
    let (rd, md) = (reference.domains.as_ref().unwrap(), m.domains.as_ref().unwrap());
    assert_eq!(rd.list.len(), md.list.len(), "{}", t.name());
    let (p_tol, x_tol, w_tol) = if t.is_f32() { (2e-4, 2e-5, 1e-2) } else { (1e-9, 1e-9, 1e-9) };
    let p_max = rd.list.iter().map(|d| d.pressure.abs()).fold(0.0, f64::max);
    for (a, b) in rd.list.iter().zip(&md.list) {
        assert_eq!((a.id, a.kind, a.fixed), (b.id, b.kind, b.fixed), "{}", t.name());
        assert!((a.pressure - b.pressure).abs() <= p_tol * p_max, "{}: domain {} p {} vs {}", t.name(), a.id, b.pressure, a.pressure);
    }
    let q_max = rd.flows.iter().map(|f| f.flow.abs()).fold(0.0, f64::max);
    assert!(q_max > 0.0 && rd.flows.len() == md.flows.len());
    for (a, b) in rd.flows.iter().zip(&md.flows) {
        assert!((a.flow - b.flow).abs() <= p_tol * q_max, "{}: flow {} vs {}", t.name(), b.flow, a.flow);
    }
    for (a, b) in reference.blocks.iter().zip(&m.blocks) {
        let d = (a.centroid[0] - b.centroid[0]).hypot(a.centroid[1] - b.centroid[1]);
        assert!(d <= x_tol, "{}: block {} off by {d} m", t.name(), a.id);
    }
    let f = m.fluid.unwrap();
    let stored = blockdem::udec::model::fluid::stored_volume(md, f.bulk);
    assert!(f.balance_error(stored).abs() < 1e-6 * stored, "{}: mass balance {}", t.name(), f.balance_error(stored));
    let (wr, wm) = (reference.fluid.unwrap().work, f.work);
    assert!((wr - wm).abs() <= w_tol * wr.abs(), "{}: fluid work {wm} vs {wr}", t.name());
}

/// The pressures of sample 2 on every backend against the CPU's along the run (cycles 300 and
/// 1400, where the f32 kernels' pressures were furthest from the CPU's, 3.4e-3 and 3.9e-3 of the
/// largest, while the update took the difference of two f32 areas): f32 now follows each void by
/// its boundary's motion (`AREA_BY_MOTION`, flow.wgsl `void_step`), measured 5.6e-6 and 5.2e-5 of
/// the largest pressure on lavapipe (the tolerance 2e-4: four times that); f64 to round-off.
fn sample_2_pressures_follow_the_cpu_along_the_run(t: &Target) {
    let tol = if t.is_f32() { 2e-4 } else { 1e-9 };
    for cycles in [300, 1400] {
        let deck = sample("udec2_pressurized_cavity.dat").replace("CYCLE 3000", &format!("CYCLE {cycles}"));
        let (reference, _) = run_ok(&deck);
        let m = t.run(&deck);
        let (rd, md) = (reference.domains.as_ref().unwrap(), m.domains.as_ref().unwrap());
        assert_eq!(rd.list.len(), md.list.len(), "{} at cycle {cycles}", t.name());
        let p_max = rd.list.iter().map(|d| d.pressure.abs()).fold(0.0, f64::max);
        assert!(p_max > 1e4, "{}: the cavity is pressurized at cycle {cycles}", t.name());
        for (a, b) in rd.list.iter().zip(&md.list) {
            let off = (a.pressure - b.pressure).abs() / p_max;
            assert!(off <= tol, "{} at cycle {cycles}: domain {} p {} vs {} ({off:e} of the largest)", t.name(), a.id, b.pressure, a.pressure);
        }
    }
}

/// On the device the flows are gathered per domain in a fixed order: a rerun repeats bit for bit.
fn a_rerun_repeats_bit_for_bit(t: &Target) {
    let deck = sample("udec2_pressurized_cavity.dat").replace("CYCLE 3000", "CYCLE 500");
    let (a, b) = (t.run(&deck), t.run(&deck));
    assert_eq!(state_json::state_json(&a), state_json::state_json(&b), "{}", t.name());
    assert!(a.domains.as_ref().unwrap().list.iter().any(|d| d.pressure > 0.0), "{}", t.name());
}

/// The energy check's budget is the work put in since the CYCLE began, the fluid's included, on
/// every backend: whatever the fluid's account held before (here shifted by 1e9 J, as the work a
/// long earlier run may have booked) the next CYCLE runs as it would have. (Its baseline took
/// off the loads' earlier work but not the fluid's, which the check then added: a later CYCLE
/// whose fluid had taken energy out stopped with "energy growing without a source".)
fn the_energy_check_counts_the_fluid_work_since_the_cycle_began(t: &Target) {
    let mut m = t.run(&sample("udec2_pressurized_cavity.dat").replace("CYCLE 3000", "CYCLE 100"));
    let before = m.fluid.expect("fluid").work;
    m.fluid.as_mut().unwrap().work -= 1e9;
    let mut backend = t.backend();
    backend.run(&mut m, 50, &mut |_| true).unwrap_or_else(|e| panic!("{}: {e}", t.name()));
    assert_eq!(m.cycle, 150, "{}", t.name());
    let done = m.fluid.unwrap().work + 1e9 - before;
    assert!(done.is_finite(), "{}: fluid work {done}", t.name());
}

/// A run's state JSON on lavapipe with `BLOCKDEM_LONG_WALK` set (`gpu::flow::LONG_WALK`: the
/// length past which a domain's sums are taken over terms computed in parallel, `domain_terms`),
/// its provenance left out; None without the adapter.
fn run_with_long_walk(deck: &str, precision: blockdem::udec::gpu::Precision, long_walk: &str) -> Option<serde_json::Value> {
    use std::process::Command;
    Target::gpu("vulkan", precision)?;
    let dir = std::env::temp_dir().join(format!("blockdem-fluid-long-walk-{}-{precision}-{long_walk}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (path, json) = (dir.join("deck.dat"), dir.join("state.json"));
    std::fs::write(&path, deck).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_blockdem"))
        .args(["run", path.to_str().unwrap(), "--backend", "gpu", "--adapter", "vulkan", "--precision", &precision.to_string()])
        .args(["--out", dir.to_str().unwrap(), "--state-json", json.to_str().unwrap()])
        .env("BLOCKDEM_LONG_WALK", long_walk)
        .output()
        .expect("runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut state: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    state.as_object_mut().unwrap().remove("provenance");
    let _ = std::fs::remove_dir_all(&dir);
    Some(state)
}

/// A domain's sums split over `domain_terms` (flow.wgsl) are its walk's to the byte: the bench's
/// fluid wall (`examples/brick_wall_fluid.dat`, 150 cycles; its void along the ground block has
/// 197 links and 120 flows, split by default) against every domain walked by one invocation
/// (the largest u32), f32 and f64; and sample 2 in f32 (500 cycles; voids of 12 links at most,
/// pressurized, followed by their boundary's motion) with every void and flow list split
/// (`BLOCKDEM_LONG_WALK=0`) against walked. The sums are taken in the walk's order from the
/// walk's own terms. (Sample 2 in f64 with every void split moved by 2e-12 of its pressure on
/// lavapipe, the compiler fusing a vertex's products otherwise in the two passes: the default
/// splits none of its domains.)
#[test]
fn long_domains_split_or_walked_give_the_same_run_bit_for_bit() {
    let wall = std::fs::read_to_string(format!("{}/examples/brick_wall_fluid.dat", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let wall = wall.lines().map(|l| if l.starts_with("CYCLE ") { "CYCLE 150" } else { l }).collect::<Vec<_>>().join("\n") + "\n";
    let walked = u32::MAX.to_string();
    for precision in [blockdem::udec::gpu::Precision::F32, blockdem::udec::gpu::Precision::F64] {
        let Some(split) = run_with_long_walk(&wall, precision, "16") else { continue };
        let domains = split["domains"].as_array().unwrap();
        assert!(domains.iter().any(|d| d["contacts"].as_array().unwrap().len() > 16 && d["kind"] == "regular"), "a long void");
        assert_eq!(Some(split), run_with_long_walk(&wall, precision, &walked), "{precision}: the wall, every domain walked");
    }
    let s2 = sample("udec2_pressurized_cavity.dat").replace("CYCLE 3000", "CYCLE 500");
    let f32 = blockdem::udec::gpu::Precision::F32;
    if let Some(split) = run_with_long_walk(&s2, f32, "0") {
        assert!(split["domains"].as_array().unwrap().iter().any(|d| d["pressure"].as_f64().unwrap() > 1e4), "the cavity is pressurized");
        assert_eq!(Some(split), run_with_long_walk(&s2, f32, &walked), "sample 2 f32, every sum split and every domain walked");
    }
}

common::every_backend!(
    sample_2_agrees_with_the_cpu,
    sample_2_pressures_follow_the_cpu_along_the_run,
    a_rerun_repeats_bit_for_bit,
    a_restarted_run_agrees_with_the_run_straight_through,
    the_energy_check_counts_the_fluid_work_since_the_cycle_began,
    a_non_finite_pressure_stops_the_run_at_the_last_good_state
);

#[test]
fn plot_pressure_fills_the_domains_by_their_pressure() {
    let dir = std::env::temp_dir().join(format!("blockdem-fluid-plot-{}", std::process::id()));
    let deck = format!("{PINWHEEL}CYCLE 0\nPFIX OUTER 0\nPFIX AT 1.5 1.5 1E5\nCYCLE 5\nWINDOW -1 4 -1 4\nPLOT PRESSURE\n");
    let commands = blockdem::udec::deck::parse_deck(&deck, "<scene>").unwrap();
    let options = blockdem::udec::exec::RunOptions { out_dir: dir.clone(), ..Default::default() };
    let mut exec = blockdem::udec::exec::Executor::new(Box::new(blockdem::udec::cpu::CpuBackend::new()), Box::new(std::io::sink()), options, "<scene>");
    exec.run(&commands).unwrap();
    let svg = std::fs::read_to_string(dir.join("plot_001.svg")).unwrap();
    let domains = exec.model.domains.as_ref().unwrap();
    let hole = blockdem::udec::model::fluid::domain_at(&exec.model, domains, [1.5, 1.5]).unwrap();
    // The hole, the largest pressure, filled full red; every inner domain drawn.
    let hole_shape = format!(r#"class="domain" data-domain="{}""#, domains.list[hole].id);
    let line = svg.lines().find(|l| l.contains(&hole_shape)).unwrap_or_else(|| panic!("{svg}"));
    assert!(line.contains("rgb(255,64,64)") || line.contains("#ff4040"), "{line}");
    assert_eq!(svg.matches(r#"class="domain""#).count(), domains.list.len() - 1, "{svg}");
    assert!(svg.contains("PORE PRESSURE"), "{svg}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn vtk_writes_the_domains_with_their_pressures_and_the_contacts_flows() {
    let dir = std::env::temp_dir().join(format!("blockdem-fluid-vtk-{}", std::process::id()));
    let deck = format!("{PINWHEEL}CYCLE 0\nPFIX OUTER 0\nPFIX AT 1.5 1.5 1E5\nCYCLE 5\nVTK\n");
    let commands = blockdem::udec::deck::parse_deck(&deck, "<scene>").unwrap();
    let options = blockdem::udec::exec::RunOptions { out_dir: dir.clone(), ..Default::default() };
    let mut exec = blockdem::udec::exec::Executor::new(Box::new(blockdem::udec::cpu::CpuBackend::new()), Box::new(std::io::sink()), options, "<scene>");
    exec.run(&commands).unwrap();
    let domains = exec.model.domains.as_ref().unwrap();
    let vtk = dir.join(blockdem::udec::exec::VTK_DIR);
    let frame = common::VtkFrame::read(&vtk.join("domains_000000005.vtk"));
    // Every domain but the outer one, the hole at its PFIX pressure.
    let ids = frame.array("id");
    assert_eq!(ids.len(), domains.list.len() - 1);
    let hole = blockdem::udec::model::fluid::domain_at(&exec.model, domains, [1.5, 1.5]).unwrap();
    let at = ids.iter().position(|&i| i == domains.list[hole].id as f64).unwrap();
    assert_eq!(frame.array("pressure")[at], 1e5);
    let contacts = common::VtkFrame::read(&vtk.join("contacts_000000005.vtk"));
    let flows = contacts.array("flow");
    assert_eq!(flows.len(), exec.model.contacts.len());
    assert!(flows.iter().any(|&q| q != 0.0), "{flows:?}");
    assert!(std::fs::read_to_string(vtk.join("domains.vtk.series")).unwrap().contains("domains_000000005.vtk"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cycle_split_in_two_is_the_same_run_bit_for_bit() {
    // The second CYCLE goes on from the state the first left: its domains (rebuilt by stage 7
    // alone in a scene with fluid), its loads and its time step (which only falls).
    let deck = sample("udec2_pressurized_cavity.dat");
    let whole = run_ok(&deck.replace("CYCLE 3000", "CYCLE 700")).0;
    let split = run_ok(&deck.replace("CYCLE 3000", "CYCLE 300\nCYCLE 400")).0;
    assert_eq!(state_json::state_json(&whole), state_json::state_json(&split));
}

/// The model and its domains as bytes (SAVE's encoding: every f64 as its 8 IEEE bytes), the
/// fluid's accounts included.
fn fluid_bits(m: &blockdem::udec::model::Model) -> Vec<u8> {
    let mut b = postcard::to_stdvec(m).unwrap();
    b.extend(postcard::to_stdvec(&m.fluid).unwrap());
    b.extend(postcard::to_stdvec(&m.domains).unwrap());
    b
}

/// Runs `deck` through the executor on `backend`: the error's text and the model it leaves.
fn run_failing(deck: &str, backend: Box<dyn blockdem::udec::backend::Backend>) -> (String, blockdem::udec::model::Model) {
    let parsed = blockdem::udec::deck::parse_deck(deck, "t.dat").unwrap();
    let mut exec = blockdem::udec::exec::Executor::new(backend, Box::new(std::io::sink()), Default::default(), "t.dat");
    let e = exec.run(&parsed).unwrap_err().to_string();
    (e, exec.model)
}

/// A flow law past f64 (CPERM = 1e300 against bulkw = 2e5): the fluid's limit on the time step
/// underflows (1e-308), so no time would pass while a flow of 1e300 × Δp overflows. It made NaN
/// pressures, and between two fixed blocks nothing moved and no step check saw them (found by
/// tests/suite/random_decks.rs). Now the run's start refuses it, naming the line, the limit and
/// the constants, and hands back the model as the CYCLE found it (the rebuilt domains held the
/// overflowing flows, which no SAVE can hold): restartable, its flows and pressures finite.
#[test]
fn a_fluid_step_that_underflows_is_refused_before_any_cycle() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 8,1 8,0\nFIX 0 8 0 1\nFLUID 1000 2E5\n\
                PROP MAT=1 JPERM=0.01 CPERM=1E300 AZERO=0.01 ARES=0.01\nSPLIT 0 0 8.37 2.78\nPFIX OUTER 1E30\nCYCLE 50\nSTOP\n";
    let (e, m) = run_failing(deck, Box::new(blockdem::udec::cpu::CpuBackend::new()));
    assert!(e.starts_with("t.dat:10:") && e.contains("limit on the time step") && e.contains("underflows f64") && e.contains("CPERM 1e300"), "{e}");
    assert_eq!(m.cycle, 0);
    m.validate().unwrap();
    assert!(m.domains.as_ref().unwrap().flows.iter().all(|f| f.flow.is_finite()));
}

/// A flow past f64 where the run sets out (PFIX OUTER 1E300 beside CPERM 10: the step is
/// ordinary) is refused there, naming the contact's blocks and the domains' pressures; a pressure
/// whose push on the blocks overflows their energies (PFIX OUTER 1E300 beside CPERM 1E-7) stops
/// the first step as a non-finite fluid work under that pressure, not as an "energy growing"
/// whose cure would be a lower FRACTION. Both leave a state a RESTART takes.
#[test]
fn a_pressure_past_f64_is_named_not_taken_for_an_instability() {
    let scene = |cperm: &str| {
        format!(
            "START\nPROP MAT=1 DENS=2000 KN=1e9 KS=1e9 F=0.6 CPERM={cperm}\nROUND 0.02\nBLOCK 0 -1 0 0 4 0 4 -1\nBLOCK 1 0 1 1 2 1 2 0\n\
             BLOCK 2 0 2 1 3 1 3 0\nBLOCK 1 1 1 2 3 2 3 1\nFIX 0 4 -1 0\nGRAVITY 0 -10\nFLUID 1000 2E9\nPFIX OUTER 1E300\nCYCLE 10\nSTOP\n"
        )
    };
    let (e, m) = run_failing(&scene("1E10"), Box::new(blockdem::udec::cpu::CpuBackend::new()));
    assert!(
        e.starts_with("t.dat:12:") && e.contains("the flow across the contact of blocks") && e.contains("pressure 1e300") && e.contains("overflows f64"),
        "{e}"
    );
    assert_eq!(m.cycle, 0);
    m.validate().unwrap();
    let (e, m) = run_failing(&scene("1E-7"), Box::new(blockdem::udec::cpu::CpuBackend::new()));
    assert!(e.starts_with("t.dat:12:") && e.contains("fluid work") && e.contains("pressure 1e300 of domain 1") && !e.contains("energy growing"), "{e}");
    assert_eq!(m.cycle, 0);
    m.validate().unwrap();
}

/// A pressure raised between two CYCLEs past what the flows can hold (PFIX OUTER 1E300 in f64,
/// 1E30 in f32, beside CPERM 1E9: the flow 1e39 is past f32, 1e309 past f64) makes the pressure
/// in the joint between two fixed blocks non-finite, where no step sees it. Every backend stops
/// the run at the last good state (cycle 10), naming the domain: the CPU's energy check, the
/// device's `flow` kernel by its error flag (before, the GPU ran on and only the executor saw
/// the pressure after the run, at the state it reached, which no RESTART took).
fn a_non_finite_pressure_stops_the_run_at_the_last_good_state(t: &Target) {
    let pressure = if t.is_f32() { "1E30" } else { "1E300" };
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 8,1 8,0\nFIX 0 8 0 1\nFLUID 1000 2E5\n\
         PROP MAT=1 JPERM=0.01 CPERM=1E9 AZERO=0.01 ARES=0.01\nSPLIT 0 0 8.37 2.78\nPFIX OUTER 0\nCYCLE 10\nPFIX OUTER {pressure}\nCYCLE 10\nSTOP\n"
    );
    let (e, m) = run_failing(&deck, t.backend());
    assert!(e.starts_with("t.dat:12:") && e.contains("non-finite fluid pressure in domain") && e.contains("CPERM"), "{}: {e}", t.name());
    assert_eq!(m.cycle, 10, "{}", t.name());
    m.validate().unwrap_or_else(|e| panic!("{}: {e}", t.name()));
    assert!(m.domains.as_ref().unwrap().list.iter().all(|d| d.pressure.is_finite()));
    assert!(m.blocks.iter().all(|b| b.force.iter().all(|f| f.is_finite()) && b.moment.is_finite()));
}

/// GENERATE after the domains are built (with fluid) gives its blocks new corners and drops
/// their contacts: the domains are rebuilt with them, so a SAVE then restarts. They were kept,
/// naming contacts that were gone, and RESTART refused the file ("domain link 0 names contact
/// 1 of 0"; found by tests/suite/random_decks.rs).
#[test]
fn a_save_after_generate_in_a_fluid_scene_restarts() {
    let dir = std::env::temp_dir().join(format!("blockdem-fluid-generate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("zoned.sav");
    let deck = format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5 K=1E9 G=1E9 CPERM=1E-7\nROUND 0.05\nBLOCK 0,0 0,1 8,1 8,0\nFIX 0 8 0 1\nGRAV 0 -10\n\
         BLOCK 1,1 1,2 3,2 3,1\nFLUID 1000 2E5\nPFIX OUTER 0\nCYCLE 1\nCHANGE -1 10 0.5 7 FDEF\nGEN -1 10 0.5 7 AUTO 0.3\nSAVE {}\nSTOP\n",
        file.display()
    );
    let (saved, _) = run_ok(&deck);
    saved.validate().unwrap();
    let (resumed, log) = run_ok(&format!("RESTART {}\nCYCLE 10\nSTOP\n", file.display()));
    assert!(log.contains("THIS IS A RESTART RUN") && resumed.cycle == 11, "{log}");
    assert!(resumed.fdef.iter().any(|f| !f.zones.is_empty()) && resumed.domains.is_some());
    let _ = std::fs::remove_dir_all(&dir);
}

/// CYCLE N, SAVE, RESTART (another run), CYCLE M is CYCLE N + M bit for bit on the CPU (save
/// format 6 keeps the fluid and the domains as the cycle carries them): on sample 2, and on a
/// scene whose pressures PFIX holds.
#[test]
fn cycle_save_restart_cycle_is_the_same_run_bit_for_bit() {
    let dir = std::env::temp_dir().join(format!("blockdem-fluid-restart-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("half.sav");
    let sample2 = sample("udec2_pressurized_cavity.dat");
    let pinwheel = format!("{PINWHEEL}GRAV 0 -10\nCYCLE 0\nPFIX OUTER 0\nPFIX AT 1.5 1.5 1E5\nCYCLE 200\n");
    for (name, deck, first, second) in [("sample 2", sample2.split("PRINT FLOWS").next().unwrap().to_string(), 3000, 1200), ("PFIX", pinwheel, 200, 300)] {
        let whole_deck = deck.replace(&format!("CYCLE {first}\n"), &format!("CYCLE {}\n", first + second));
        let whole = run_ok(&whole_deck).0;
        let (saved, log) = run_ok(&format!("{deck}SAVE {}\nSTOP\n", file.display()));
        assert!(log.contains("STATE SAVED TO"), "{log}");
        assert!(saved.fluid.is_some() && saved.domains.is_some());
        let (resumed, log) = run_ok(&format!("RESTART {}\nCYCLE {second}\nSTOP\n", file.display()));
        assert!(log.contains("THIS IS A RESTART RUN"), "{log}");
        assert_eq!(resumed.cycle, whole.cycle, "{name}");
        assert_eq!(state_json::state_json(&whole), state_json::state_json(&resumed), "{name}");
        assert!(fluid_bits(&whole) == fluid_bits(&resumed), "{name}: not bit for bit");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The restarted run on each backend against the same backend's run straight through (sample 2,
/// CYCLE 3000, SAVE, RESTART, CYCLE 1200 against CYCLE 4200). The CPU is bit for bit
/// (`cycle_save_restart_cycle_is_the_same_run_bit_for_bit`). A device run that goes on keeps
/// digits the model does not (the energy accounts' device sums, re-based on the model's f64 at
/// an upload, and each domain's area as the device last took it, which the next pressure update
/// differences against bulkw·ΔA), so the restarted one agrees to round-off: measured on lavapipe,
/// f64 1.6e-13 of the largest pressure and positions equal. In f32 the round-off grows: which
/// view of a corner pair counts is decided by which is deeper, beyond a band of 4e-5 m here
/// (`contact::pair`), and f32 round-off moves the cycle at which a pair leaves the band, where
/// the normal force steps by kn·band and the counting view's shear spring starts afresh: 2.6e-6 m
/// and 2.5e-3 of the largest pressure after 1200 cycles (the f32 run's own distance from the CPU
/// reference is 5e-6 m and 4.1e-3; the pressures, bulkw·ΔA/A with bulkw = 1e9, magnify a
/// domain's area change 1e9-fold); the energy terms 2.2e-6 (the strain energy, of 1.1 J; the
/// others ≤ 1.7e-6 of their size), bounded at 2e-5. Counting by index alone it was 4.8e-8 m and
/// 3.1e-6, but with a corner 2.9 cm into an edge carrying no force and the ledger 26% off.
fn a_restarted_run_agrees_with_the_run_straight_through(t: &Target) {
    let tag: String = t.name().chars().filter(|c| c.is_ascii_alphanumeric()).collect();
    let dir = std::env::temp_dir().join(format!("blockdem-fluid-restart-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("half.sav");
    let deck = sample("udec2_pressurized_cavity.dat").split("PRINT FLOWS").next().unwrap().to_string();
    let whole = t.run(&deck.replace("CYCLE 3000\n", "CYCLE 4200\n"));
    t.run(&format!("{deck}SAVE {}\nSTOP\n", file.display()));
    let resumed = t.run(&format!("RESTART {}\nCYCLE 1200\nSTOP\n", file.display()));
    let _ = std::fs::remove_dir_all(&dir);
    if matches!(t, Target::Cpu) {
        assert!(fluid_bits(&whole) == fluid_bits(&resumed), "bit for bit on the CPU");
        return;
    }
    let (p_tol, x_tol, e_tol) = if t.is_f32() { (5e-3, 1e-5, 2e-5) } else { (1e-11, 1e-12, 1e-11) };
    assert_eq!(whole.cycle, resumed.cycle);
    let (wd, rd) = (whole.domains.as_ref().unwrap(), resumed.domains.as_ref().unwrap());
    let p_max = wd.list.iter().map(|d| d.pressure.abs()).fold(0.0, f64::max);
    assert_eq!(wd.list.len(), rd.list.len(), "{}", t.name());
    for (a, b) in wd.list.iter().zip(&rd.list) {
        assert_eq!((a.id, a.kind, a.fixed), (b.id, b.kind, b.fixed), "{}", t.name());
        assert!((a.pressure - b.pressure).abs() <= p_tol * p_max, "{}: domain {} p {} vs {}", t.name(), a.id, b.pressure, a.pressure);
    }
    for (a, b) in whole.blocks.iter().zip(&resumed.blocks) {
        let d = (a.centroid[0] - b.centroid[0]).hypot(a.centroid[1] - b.centroid[1]);
        assert!(d <= x_tol, "{}: block {} off by {d} m", t.name(), a.id);
    }
    let (ew, er) = (whole.energies(), resumed.energies());
    let terms = |e: &blockdem::udec::model::timestep::Energies| [e.kinetic, e.strain, e.external_work, e.mass_damping, e.friction, e.fluid_work];
    for (k, (a, b)) in terms(&ew).iter().zip(terms(&er)).enumerate() {
        assert!((a - b).abs() <= e_tol * a.abs().max(1.0), "{}: energy term {k}: {b} vs {a}", t.name());
    }
}

/// SAVE keeps the fluid and the domains whole (save format 6), and RESTART refuses a file whose
/// fluid or domains no run could have left (a domain index past the list, a bulk modulus of 0),
/// naming what is wrong.
#[test]
fn save_keeps_the_fluid_and_the_domains_and_restart_checks_them() {
    use blockdem::udec::output::{load, restart::save_state, RestartError};
    let (m, _) = run_ok(&format!("{PINWHEEL}CYCLE 0\nPFIX OUTER 0\nPFIX AT 1.5 1.5 1E5\nCYCLE 20\n"));
    let path = std::env::temp_dir().join(format!("blockdem-fluid-save-{}.sav", std::process::id()));
    save_state(&path, &m, &Default::default(), 0).unwrap();
    let back = load(&path).unwrap().model;
    assert!(back == m && back.fluid.is_some());
    assert_eq!(back.domains, m.domains);
    assert!(fluid_bits(&back) == fluid_bits(&m));
    let refused = |bad: &blockdem::udec::model::Model, words: &str| {
        save_state(&path, bad, &Default::default(), 0).unwrap();
        match load(&path) {
            Err(e @ RestartError::Inconsistent { .. }) => assert!(e.to_string().contains(words), "{e}"),
            other => panic!("{other:?}"),
        }
    };
    let mut bad = m.clone();
    bad.domains.as_mut().unwrap().sides[0] = [0, 99];
    refused(&bad, "are not among the");
    let mut bad = m.clone();
    bad.fluid.as_mut().unwrap().bulk = 0.0;
    refused(&bad, "bulk modulus 0");
    let mut bad = m.clone();
    bad.domains.as_mut().unwrap().list.swap(0, 1);
    refused(&bad, "the ids must rise");
    std::fs::remove_file(&path).ok();
}
