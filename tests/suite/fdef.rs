//! Fully-deformable blocks (issue 29; SL-85-1 Appendix A ¶11–12, CHANGE … FDEF, GENERATE): the
//! mesh generator, the constant-strain zones' patch test, an elastic column under its own
//! weight, the outputs, the input errors and sample 3 on the CPU backend; sample 3, reruns, the
//! ledger and the inverted-zone failure on every backend (`every_backend!`).

use crate::common;

use blockdem::scenes::run_deck_on;
use blockdem::udec::backend::Backend;
use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::model::fdef::{nodal_forces, strain_rate, stress_increment};
use blockdem::udec::model::geometry::{point_in_polygon, point_segment_distance, signed_area};
use blockdem::udec::model::zoning::{auto_mesh, manual_mesh, Mesh};
use blockdem::udec::model::{BlockKind, Model};
use common::{every_backend, Target};

fn cpu() -> Box<dyn Backend> {
    Box::new(CpuBackend::new())
}

/// The properties every generated mesh of `outline` must have: every side at most `amax`, the
/// zones counter-clockwise and adding up to the block's area, every zone inside the outline,
/// the boundary grid points on the outline in its order (each original corner among them), the
/// interior ones inside it.
fn check_mesh(outline: &[[f64; 2]], m: &Mesh, amax: f64) {
    assert!(m.longest_side() <= amax * (1.0 + 1e-12), "longest side {} > {amax}", m.longest_side());
    let area = signed_area(outline);
    let zoned: f64 = (0..m.zones.len()).map(|z| m.zone_area(z)).sum();
    assert!((zoned - area).abs() < 1e-10 * area, "zones {zoned} against block {area}");
    for z in 0..m.zones.len() {
        assert!(m.zone_area(z) > 0.0, "zone {z} is not counter-clockwise");
        let [a, b, c] = m.zones[z].map(|k| m.points[k as usize]);
        let centre = [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0];
        assert!(point_in_polygon(centre, outline), "zone {z} lies outside the block: {centre:?}");
    }
    let on_outline =
        |p: [f64; 2]| (0..outline.len()).map(|k| point_segment_distance(p, outline[k], outline[(k + 1) % outline.len()])).fold(f64::INFINITY, f64::min);
    for (k, p) in m.points.iter().enumerate() {
        if k < m.boundary {
            assert!(on_outline(*p) < 1e-12, "boundary grid point {k} {p:?} is off the outline");
        } else {
            assert!(point_in_polygon(*p, outline) && on_outline(*p) > 1e-9, "interior grid point {k} {p:?} is not inside");
        }
    }
    // The outline's corners appear among the boundary points in their order, and the boundary
    // itself is counter-clockwise with the block's area.
    let mut at = 0;
    for c in outline {
        let found = m.points[at..m.boundary].iter().position(|p| p == c).map(|i| i + at);
        at = found.unwrap_or_else(|| panic!("corner {c:?} is not a boundary grid point (in order)")) + 1;
    }
    assert!((signed_area(&m.points[..m.boundary]) - area).abs() < 1e-10 * area);
    // Conforming: every side is shared by two zones, or lies on the boundary (one zone).
    let mut sides = std::collections::BTreeMap::new();
    for z in &m.zones {
        for k in 0..3 {
            let (a, b) = (z[k], z[(k + 1) % 3]);
            *sides.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    for (&(a, b), &n) in &sides {
        let boundary_side = (a as usize) < m.boundary && (b as usize) < m.boundary && {
            let (a, b) = (a as usize, b as usize);
            (a + 1) % m.boundary == b || (b + 1) % m.boundary == a
        };
        assert_eq!(n, if boundary_side { 1 } else { 2 }, "side {a}–{b} is in {n} zones (a hanging node?)");
    }
}

#[test]
fn auto_meshes_a_rectangle_with_every_side_at_most_amax() {
    let rect = [[2.0, 3.0], [6.0, 3.0], [6.0, 7.0], [2.0, 7.0]];
    for amax in [5.0, 1.1, 0.37, 0.1] {
        let m = auto_mesh(&rect, amax).unwrap();
        check_mesh(&rect, &m, amax);
    }
    // Finer amax, more zones.
    assert!(auto_mesh(&rect, 0.5).unwrap().zones.len() > auto_mesh(&rect, 1.0).unwrap().zones.len());
}

#[test]
fn auto_meshes_a_concave_l_shaped_block_inside_its_outline() {
    // The notch (1..2, 1..2) must stay empty: a triangulation of the corners alone (without the
    // outline's constraint) would fill it.
    let l = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
    for amax in [3.0, 0.6, 0.25] {
        let m = auto_mesh(&l, amax).unwrap();
        check_mesh(&l, &m, amax);
        assert!((signed_area(&l) - 3.0).abs() < 1e-15);
    }
    // A more concave comb, with a re-entrant corner close to the far side.
    let comb = [[0.0, 0.0], [3.0, 0.0], [3.0, 2.0], [2.2, 2.0], [2.2, 0.3], [1.8, 0.3], [1.8, 2.0], [0.0, 2.0]];
    let m = auto_mesh(&comb, 0.4).unwrap();
    check_mesh(&comb, &m, 0.4);
}

#[test]
fn smoothing_moves_interior_points_towards_their_neighbours_mean() {
    let rect = [[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.0]];
    let rough = blockdem::udec::model::zoning::smooth(auto_mesh(&rect, 0.3).unwrap(), 0);
    let smooth = blockdem::udec::model::zoning::smooth(rough.clone(), 40);
    // The mean distance of an interior point from its neighbours' mean shrinks.
    let misfit = |m: &Mesh| {
        let mut nb: Vec<Vec<usize>> = vec![Vec::new(); m.points.len()];
        for z in &m.zones {
            for k in 0..3 {
                nb[z[k] as usize].push(z[(k + 1) % 3] as usize);
                nb[z[(k + 1) % 3] as usize].push(z[k] as usize);
            }
        }
        let mut sum = 0.0;
        for (k, list) in nb.iter_mut().enumerate().skip(m.boundary) {
            list.sort_unstable();
            list.dedup();
            let n = list.len() as f64;
            let mean = list.iter().fold([0.0, 0.0], |a, &j| [a[0] + m.points[j][0] / n, a[1] + m.points[j][1] / n]);
            sum += (m.points[k][0] - mean[0]).hypot(m.points[k][1] - mean[1]);
        }
        sum
    };
    assert!(m_interior(&rough) > 0, "the mesh has interior points");
    assert!(misfit(&smooth) < 0.5 * misfit(&rough) + 1e-12, "{} against {}", misfit(&smooth), misfit(&rough));
    check_mesh(&rect, &smooth, 0.3 * 1.5);
}

fn m_interior(m: &Mesh) -> usize {
    m.points.len() - m.boundary
}

/// The patch test: on an irregular mesh (a pentagon, smoothed), a linear velocity field gives
/// every zone the same strain rate exactly, the elastic stress that follows is uniform, and the
/// zones' forces on every interior grid point cancel (a uniform stress is in equilibrium).
#[test]
fn patch_test_a_uniform_strain_is_reproduced_exactly_on_an_irregular_mesh() {
    let pentagon = [[0.0, 0.0], [3.1, 0.4], [3.6, 2.3], [1.2, 3.4], [-0.7, 1.9]];
    let m = auto_mesh(&pentagon, 0.45).unwrap();
    assert!(m_interior(&m) > 10);
    let grad = [[2e-3, 7e-4], [-3e-4, -1.1e-3]]; // v_i = L_ij x_j
    let v = |p: [f64; 2]| [grad[0][0] * p[0] + grad[0][1] * p[1], grad[1][0] * p[0] + grad[1][1] * p[1]];
    let want = [grad[0][0], 0.5 * (grad[0][1] + grad[1][0]), grad[1][1]];
    let (k, g) = (1e9, 6e8);
    let lambda = k - 2.0 * g / 3.0;
    let stress = stress_increment(want, lambda, g);
    let mut force = vec![[0.0f64; 2]; m.points.len()];
    for z in &m.zones {
        let p = z.map(|k| m.points[k as usize]);
        let e = strain_rate(p, p.map(v));
        for i in 0..3 {
            assert!((e[i] - want[i]).abs() < 1e-15, "strain rate {e:?} against {want:?}");
        }
        let s = stress_increment(e, lambda, g);
        for i in 0..3 {
            assert!((s[i] - stress[i]).abs() < 1e-9 * stress[0].abs(), "stress {s:?} against {stress:?}");
        }
        for (n, f) in z.iter().zip(nodal_forces(p, stress)) {
            force[*n as usize][0] += f[0];
            force[*n as usize][1] += f[1];
        }
    }
    let scale = stress.iter().fold(0.0f64, |a, s| a.max(s.abs()));
    for (k, f) in force.iter().enumerate().skip(m.boundary) {
        assert!(f[0].abs() < 1e-12 * scale && f[1].abs() < 1e-12 * scale, "interior grid point {k}: {f:?}");
    }
    // On the boundary the forces are the traction σ·n on each point's half sides: they add up
    // to zero over the closed outline.
    let total = force.iter().fold([0.0, 0.0], |a, f| [a[0] + f[0], a[1] + f[1]]);
    assert!(total[0].abs() < 1e-9 * scale && total[1].abs() < 1e-9 * scale, "{total:?}");
}

/// A zoned block stretched by a uniform velocity gradient through the CPU's cycle keeps a
/// uniform stress: the run's own strain rates and stresses, not only the formulas.
#[test]
fn patch_test_through_the_cycle_keeps_the_stress_uniform() {
    let deck = "START\nPROP MAT=1 DENS=2000 K=1E9 G=6E8 KN=1E10 KS=1E10\nROUND 0.05\nBLOCK (0,0) (3.1,0.4) (3.6,2.3) (1.2,3.4) (-0.7,1.9)\n\
                CHANGE -1 4 -1 4 FDEF\nGENERATE -1 4 -1 4 AUTO 0.5\nCYCLE 0\nSTOP\n";
    let mut m = run_deck_on(deck, cpu()).unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    let grad = [[1e-3, 4e-4], [-2e-4, -5e-4]];
    for g in &mut m.fdef[b].gridpoints {
        let p = g.position;
        g.velocity = [grad[0][0] * p[0] + grad[0][1] * p[1], grad[1][0] * p[0] + grad[1][1] * p[1]];
    }
    // The grid points move with the field and no force (no gravity, no contacts); one step of
    // the zone stage from the velocities above.
    let mut backend = CpuBackend::new();
    for g in &mut m.fdef[b].gridpoints {
        g.mass = 1e30; // the forces do not change the velocities
    }
    backend.run(&mut m, 1, &mut |_| true).unwrap();
    let f = &m.fdef[b];
    let s0 = f.zones[0].stress;
    assert!(s0[0].abs() > 0.0);
    for z in &f.zones {
        for i in 0..3 {
            assert!((z.stress[i] - s0[i]).abs() < 1e-9 * s0[0].abs(), "{:?} against {s0:?}", z.stress);
        }
    }
}

/// An elastic column 1 m wide and 4 m high, zoned, on a fixed base with frictionless contacts,
/// under gravity, damped to rest: σyy = −ρ g (depth) and σxx ≈ 0 (free sides; uniaxial stress).
/// Tolerances: 5 % of ρ g depth below the top metre (a zone's stress is its mean over its
/// height, 0.3 m, which is most of the depth near the top), and σxx within 3 % of ρ g H.
#[test]
fn a_column_under_its_own_weight_carries_rho_g_depth() {
    let (rho, g, h) = (2000.0, 10.0, 4.0);
    let deck = format!(
        "START\nPROP MAT=1 DENS={rho} K=1E8 G=6E7 KN=1E10 KS=1E10 F=0\nROUND 0.02\nBLOCK (0,-1) (0,0) (3,0) (3,-1)\nBLOCK (1,0) (1,{h}) (2,{h}) (2,0)\n\
         FIX -1 4 -2 -0.2\nCHANGE 0.5 2.5 0 4 FDEF\nGENERATE 0.5 2.5 0 4 AUTO 0.3\nGRAV 0 -{g}\nFRAC 0.5\nDAMP 0.8 20 MASS\nCYCLE 8000\nSTOP\n"
    );
    let m = run_deck_on(&deck, cpu()).unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    let f = &m.fdef[b];
    let mut checked = 0;
    for (z, zone) in f.zones.iter().enumerate() {
        let p = f.zone_points(z);
        let y = (p[0][1] + p[1][1] + p[2][1]) / 3.0;
        let want = -rho * g * (h - y);
        assert!(zone.stress[0].abs() < 0.03 * rho * g * h, "zone {z}: σxx {}", zone.stress[0]);
        if h - y > 1.0 {
            assert!((zone.stress[2] / want - 1.0).abs() < 0.05, "zone {z} at depth {}: σyy {} against {want}", h - y, zone.stress[2]);
            checked += 1;
        }
    }
    assert!(checked > 150, "{checked} zones checked");
    // And the base carries the column's weight.
    let weight: f64 = f.gridpoints.iter().map(|g| g.mass).sum::<f64>() * g;
    assert!((weight - rho * g * h).abs() < 1e-9 * weight);
}

#[test]
fn manual_generation_numbers_from_the_last_point_and_reads_clockwise_zones() {
    // A square with a centre point: given as the manual says (the last point is number 1).
    let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    // Points as given: centre (5), then corners (4 3 2 1 = (0,0) (1,0) (1,1) (0,1) reversed).
    let points = [[0.5, 0.5], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.02, 0.01]];
    // Numbers: (0.02,0.01) → 1 (snapped to corner (0,0)), (1,0) → 2, (1,1) → 3, (0,1) → 4, centre → 5.
    let zones = [[1, 5, 2], [2, 5, 3], [3, 5, 4], [4, 5, 1]];
    let m = manual_mesh(&sq, &points, &zones, 0.05).unwrap();
    assert_eq!(m.boundary, 4);
    assert_eq!(m.points[..4], sq);
    assert_eq!(m.points[4], [0.5, 0.5]);
    check_mesh(&sq, &m, 1.0);
    // Counter-clockwise: refused, naming the zone as the deck numbers it.
    let e = manual_mesh(&sq, &points, &[[1, 2, 5], [2, 5, 3], [3, 5, 4], [4, 5, 1]], 0.05).unwrap_err();
    assert!(e.contains("zone 1 (1 2 5) is given counter-clockwise"), "{e}");
    let e = manual_mesh(&sq, &points, &[[1, 5, 2], [2, 5, 3], [3, 5, 4], [4, 5, 9]], 0.05).unwrap_err();
    assert!(e.contains("zone 4 names grid point 9"), "{e}");
    let e = manual_mesh(&sq, &[[0.5, 0.5], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0], [3.0, 3.0]], &zones, 0.05).unwrap_err();
    assert!(e.contains("not inside the block"), "{e}");
    let e = manual_mesh(&sq, &points, &zones[..3], 0.05).unwrap_err();
    assert!(e.contains("cover"), "{e}");
}

const SQUARE_DECK: &str = "START\nPROP MAT=1 DENS=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 F=0.5\nROUND 0.02\nBLOCK (0,-1) (0,0) (3,0) (3,-1)\nBLOCK (1,0) (1,1) (2,1) (2,0)\nFIX -1 4 -2 -0.2\n";

/// The error of running `rest` after [`SQUARE_DECK`] (its first line is line 7).
fn error_of(rest: &str) -> String {
    let deck = format!("{SQUARE_DECK}{rest}");
    match blockdem::udec::deck::parse_deck(&deck, "<scene>") {
        Err(e) => e.to_string(),
        Ok(_) => run_deck_on(&deck, cpu()).map(|_| ()).expect_err(rest).to_string(),
    }
}

#[test]
fn bad_input_is_a_clear_error_naming_its_line() {
    for (rest, line, needle) in [
        ("CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO 0\n", 8, "amax"),
        ("CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO -1\n", 8, "amax"),
        ("GENERATE 0.5 2.5 0 1 AUTO 0.2\n", 7, "none of the 1 block(s) in the range is fully deformable"),
        ("CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 5 6 5 6 AUTO 0.2\n", 8, "no block's centroid lies in the range"),
        ("CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 MANUAL GRID 1 0 1 1 2 1 2 0 1.5 ZONES 1 2 3\n", 8, ""),
        ("CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 MANUAL GRID 1 0 1 1 2 1 2 0 ZONES 1 2 5 1 3 4\n", 8, "grid point 5"),
        ("CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 MANUAL GRID 1 0 1 1 2 1 2 0 ZONES 1 2 3 1 3 4\n", 8, "counter-clockwise"),
        ("CHANGE 0.5 2.5 0 1 FDEF\nCYCLE 10\n", 8, "block 2 is fully deformable but has no zones"),
        ("PROP MAT=2 DENS=2000 KN=1E9 KS=1E9\nCHANGE 0.5 2.5 0 1 FDEF MAT=2\n", 8, "no elastic moduli"),
        ("PROP MAT=1 TF=2\nCHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO 0.5\nCYCLE 10\n", 10, "cracking through a zoned block"),
    ] {
        let e = error_of(rest);
        assert!(e.starts_with(&format!("<scene>:{line}:")), "{rest}: line {line}: {e}");
        assert!(e.contains(needle), "{rest}: expected '{needle}': {e}");
    }
}

/// SPLIT through a zoned block is refused, naming the block; the block stays whole and zoned.
#[test]
fn split_through_a_zoned_block_is_refused_naming_it() {
    let deck = format!("{SQUARE_DECK}CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO 0.5\nSPLIT 0 0.5 3 0.5\nSTOP\n");
    let commands = blockdem::udec::deck::parse_deck(&deck, "<scene>").unwrap();
    let mut log = Vec::new();
    let mut exec = blockdem::udec::exec::Executor::new(cpu(), Box::new(&mut log), Default::default(), "<scene>");
    exec.run(&commands).unwrap();
    let m = std::mem::take(&mut exec.model);
    drop(exec);
    let log = String::from_utf8(log).unwrap();
    assert!(log.contains("SPLIT REJECTED FOR BLOCK 2: it is fully deformable"), "{log}");
    assert_eq!(m.blocks.len(), 2);
    assert!(m.fdef_of(1).is_some_and(|f| !f.zones.is_empty()));
}

/// A clockwise MANUAL mesh given over continuation lines runs, and its boundary grid points are
/// the block's corners.
#[test]
fn a_manual_mesh_over_continuation_lines_runs() {
    let m = run_deck_on(
        &format!("{SQUARE_DECK}CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 MANUAL GRID 1.5 0.5 1 1\n+ 2 1 2 0 1 0 ZONES 1 5 2\n+ 2 5 3 3 5 4 4 5 1\nGRAV 0 -10\nCYCLE 200\nSTOP\n"),
        cpu(),
    )
    .unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    assert_eq!(m.fdef[b].zones.len(), 4);
    assert_eq!(m.blocks[b].corner_count, 4);
    assert!(m.fdef[b].zones.iter().all(|z| z.stress[2] < 0.0), "the block presses on its base");
}

fn sample3() -> String {
    std::fs::read_to_string(format!("{}/examples/udec3_deformable_block.dat", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// Sample 3 (Figure A3): the heavy block sinks into the soft, zoned one; the run reaches cycle
/// 1000 with every zone the right way round, its grid points under the block pushed down, and
/// PRINT BLOCKS and the state JSON give the zone and grid-point tables.
#[test]
fn sample_3_runs_end_to_end() {
    let mut log = Vec::new();
    let m = {
        let commands = blockdem::udec::deck::parse_deck(&sample3(), "udec3").unwrap();
        let options = blockdem::udec::exec::RunOptions { out_dir: std::env::temp_dir().join("blockdem-fdef-sample3"), ..Default::default() };
        let mut exec = blockdem::udec::exec::Executor::new(cpu(), Box::new(&mut log), options, "udec3");
        exec.run(&commands).unwrap();
        std::mem::take(&mut exec.model)
    };
    let log = String::from_utf8(log).unwrap();
    assert_eq!(m.cycle, 1000);
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    let f = &m.fdef[b];
    assert!(f.zones.len() >= 16 && f.boundary as usize == m.blocks[b].corner_count as usize);
    assert!((0..f.zones.len()).all(|z| f.zone_area(z) > 0.0));
    assert!(m.validate().is_ok(), "{:?}", m.validate());
    // The heavy block (material 2) went down from 7.5.
    let heavy = m.blocks.iter().find(|b| b.material == 2).unwrap();
    assert!(heavy.centroid[1] < 7.5 - 0.05, "{:?}", heavy.centroid);
    // The zones are in compression on the whole.
    let mean: f64 = f.zones.iter().map(|z| z.stress[0] + z.stress[2]).sum::<f64>() / f.zones.len() as f64;
    assert!(mean < 0.0, "{mean}");
    assert!(log.contains("(FDEF)") && log.contains("GRID-POINTS") && log.contains("CORNER-LINK"), "{log}");
    let v = blockdem::udec::output::state_json::state_json(&m);
    let blk = v["blocks"].as_array().unwrap().iter().find(|x| x["kind"] == "fdef").unwrap();
    let (zones, gps) = (blk["zones"].as_array().unwrap(), blk["gridpoints"].as_array().unwrap());
    assert_eq!(zones.len(), f.zones.len());
    assert_eq!(gps.len(), f.gridpoints.len());
    for key in ["id", "gridpoints", "stress", "mass"] {
        assert!(!zones[0][key].is_null(), "zone key {key}");
    }
    for key in ["id", "position", "velocity", "mass"] {
        assert!(!gps[0][key].is_null(), "grid point key {key}");
    }
    assert_eq!(zones[0]["gridpoints"].as_array().unwrap().len(), 3);
    assert_eq!(zones[0]["stress"].as_array().unwrap().len(), 3);
    // PLOT ZONES draws every zone (the SVG's zone paths), a plain PLOT none.
    let dir = std::env::temp_dir().join(format!("blockdem-fdef-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let settings = blockdem::udec::output::plot::PlotSettings { window: [0.0, 8.0, 0.0, 10.0], ..Default::default() };
    for (zones_on, want) in [(true, f.zones.len()), (false, 0)] {
        let options = blockdem::udec::deck::PlotOptions { zones: zones_on, ..Default::default() };
        let [_, svg] = blockdem::udec::output::plot::plot(&m, &settings, &options, &dir, 1, "udec3").unwrap();
        let text = std::fs::read_to_string(svg).unwrap();
        assert_eq!(text.matches(r#"class="zone""#).count(), want, "PLOT ZONES {zones_on}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A rigid scene carries no zone extension at all, and a zoned scene's contacts see the new
/// corners.
#[test]
fn the_extension_is_empty_in_rigid_scenes_and_zoning_adds_corners() {
    let m = run_deck_on(&format!("{SQUARE_DECK}GRAV 0 -10\nCYCLE 10\nSTOP\n"), cpu()).unwrap();
    assert!(m.fdef.is_empty());
    let m: Model = run_deck_on(&format!("{SQUARE_DECK}CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO 0.3\nGRAV 0 -10\nCYCLE 50\nSTOP\n"), cpu()).unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    assert!(m.blocks[b].corner_count > 4);
    // Contacts on the base from the new bottom corners, not only the original two.
    let on_base = m.contacts.iter().filter(|c| c.block1 as usize == b && c.normal_force > 0.0).count();
    assert!(on_base > 2, "{on_base} contacts of the zoned block's corners carry force");
}

/// SAVE keeps the zones and grid points (save format 5), and a RESTART goes on from them.
#[test]
fn save_and_restart_keep_the_zones() {
    let m = run_deck_on(&format!("{SQUARE_DECK}CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO 0.3\nGRAV 0 -10\nCYCLE 100\nSTOP\n"), cpu()).unwrap();
    let path = std::env::temp_dir().join(format!("blockdem-fdef-{}.sav", std::process::id()));
    blockdem::udec::output::restart::save_state(&path, &m, &Default::default(), 0).unwrap();
    let back = blockdem::udec::output::load(&path).unwrap();
    std::fs::remove_file(&path).ok();
    assert_eq!(back.model.fdef, m.fdef);
    assert!(back.model == m);
    assert!(back.model.fdef.iter().any(|f| !f.zones.is_empty()));
}

/// A zone driven inside out stops the run as a numerical failure naming the block and the zone,
/// and the model goes back to its last good state.
#[test]
fn a_zone_turned_inside_out_stops_the_run_and_rolls_back() {
    let deck = "START\nPROP MAT=1 DENS=2000 K=1E9 G=6E8 KN=1E10 KS=1E10\nROUND 0.05\nBLOCK (0,0) (2,0) (2,2) (0,2)\n\
                CHANGE -1 3 -1 3 FDEF\nGENERATE -1 3 -1 3 AUTO 0.6\nCYCLE 0\nSTOP\n";
    let mut m = run_deck_on(deck, cpu()).unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    let before = m.clone();
    // An interior grid point flung 10 m in one step, unstoppable: its zones turn inside out.
    let k = m.fdef[b].boundary as usize;
    let dt = m.timestep;
    let g = &mut m.fdef[b].gridpoints[k];
    g.mass = 1e30;
    g.velocity = [10.0 / dt, 0.0];
    let flung = m.clone();
    let e = CpuBackend::new().run(&mut m, 10, &mut |_| true).unwrap_err();
    match &e {
        blockdem::udec::backend::CycleError::ZoneInverted { cycle, block, zone } => {
            assert_eq!((*cycle, *block), (1, m.blocks[b].id));
            let z = *zone as usize - 1;
            assert!(m.fdef[b].zones[z].gridpoints.contains(&(k as u32)), "zone {zone} is one of the flung point's");
        }
        other => panic!("{other}"),
    }
    assert!(e.to_string().contains("turned inside out"), "{e}");
    assert_eq!(m, flung, "the model is the last good state (the one the run started from)");
    assert!(before.fdef[b].zones.len() == m.fdef[b].zones.len());
}

/// VELOCITY sets a zoned block's grid points moving (v + ω × r), and the block flies with them.
#[test]
fn velocity_moves_a_zoned_block_by_its_grid_points() {
    let deck = "START\nPROP MAT=1 DENS=2000 K=1E9 G=6E8 KN=1E10 KS=1E10\nROUND 0.05\nBLOCK (0,0) (2,0) (2,2) (0,2)\n\
                CHANGE -1 3 -1 3 FDEF\nGENERATE -1 3 -1 3 AUTO 0.6\nVELOCITY -1 3 -1 3 2 0 0\nCYCLE 100\nSTOP\n";
    let m = run_deck_on(deck, cpu()).unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    assert!(m.fdef[b].gridpoints.iter().all(|g| (g.velocity[0] - 2.0).abs() < 1e-9 && g.velocity[1].abs() < 1e-9));
    let moved = m.blocks[b].centroid[0] - 1.0;
    assert!((moved - 2.0 * m.time).abs() < 1e-9, "moved {moved} in {} s", m.time);
}

/// VTK (issue 29 item 4): a scene with zoned blocks writes a zone frame beside the block and
/// contact frames, its grid points as points with their velocity, its zones as triangles through
/// them with their stress; a rigid scene writes none.
#[test]
fn a_vtk_frame_holds_the_zones_and_grid_points() {
    use blockdem::udec::output::vtk::{write_frame, zone_frame_name, ZONE_SERIES_FILE};
    let m = run_deck_on(&format!("{SQUARE_DECK}CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO 0.3\nGRAV 0 -10\nCYCLE 100\nSTOP\n"), cpu()).unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    let f = &m.fdef[b];
    let dir = std::env::temp_dir().join(format!("blockdem-fdef-vtk-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    write_frame(&m, &dir).unwrap();
    let frame = common::VtkFrame::read(&dir.join(zone_frame_name(m.cycle)));
    assert!(dir.join(ZONE_SERIES_FILE).is_file());
    let points: Vec<f64> = f.gridpoints.iter().flat_map(|g| [g.position[0], g.position[1], 0.0]).collect();
    assert_eq!(frame.points, points);
    let cells: Vec<u32> = f.zones.iter().flat_map(|z| std::iter::once(3).chain(z.gridpoints)).collect();
    assert_eq!(frame.cells, cells);
    let f32s = |xs: &mut dyn Iterator<Item = f64>| xs.map(|x| x as f32 as f64).collect::<Vec<_>>();
    assert_eq!(frame.array("velocity"), f32s(&mut f.gridpoints.iter().flat_map(|g| [g.velocity[0], g.velocity[1], 0.0])));
    assert_eq!(frame.array("gridpoint_mass"), f32s(&mut f.gridpoints.iter().map(|g| g.mass)));
    let stress = f32s(&mut f.zones.iter().flat_map(|z| [z.stress[0], z.stress[1], 0.0, z.stress[1], z.stress[2], 0.0, 0.0, 0.0, 0.0]));
    assert_eq!(frame.array("stress"), stress);
    assert!(frame.array("stress").iter().any(|&s| s < 0.0), "the block presses on its base");
    assert_eq!(frame.array("zone"), (1..=f.zones.len()).map(|k| k as f64).collect::<Vec<_>>());
    assert!(frame.array("block").iter().all(|&id| id == m.blocks[b].id as f64));
    assert_eq!(frame.array("mass"), f32s(&mut f.zones.iter().map(|z| z.mass)));
    // A rigid scene: no zone frame.
    let rigid = run_deck_on(&format!("{SQUARE_DECK}GRAV 0 -10\nCYCLE 10\nSTOP\n"), cpu()).unwrap();
    let dir2 = dir.join("rigid");
    write_frame(&rigid, &dir2).unwrap();
    assert!(!dir2.join(zone_frame_name(rigid.cycle)).exists() && !dir2.join(ZONE_SERIES_FILE).exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// The first zoned block of `m` and its extension.
fn zoned(m: &Model) -> (usize, &blockdem::udec::model::fdef::Fdef) {
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    (b, &m.fdef[b])
}

/// Sample 3 on every backend against the CPU's run: every zone stress, grid point and block
/// within the precision's round-off of the reference (f64: 1e-9 relative; f32: 1e-3 of the
/// largest stress and 1e-4 m, 5e-4 of ROUND: f32's digits over a thousand steps of a soft block
/// ringing under a heavy one), the zones the right way
/// round, and a rerun on the same backend bit for bit the same (the gather's fixed order).
fn sample_3_agrees_with_the_cpu(t: &Target) {
    let deck = sample3().replace("WIND 0 8 0 10\nPLOT\nPRINT BLOCKS\n", "");
    let reference = run_deck_on(&deck, cpu()).unwrap();
    let m = t.run(&deck);
    assert_eq!(m.cycle, 1000, "{}", t.name());
    let ((b, f), (_, fr)) = (zoned(&m), zoned(&reference));
    assert!((0..f.zones.len()).all(|z| f.zone_area(z) > 0.0));
    let top = fr.zones.iter().flat_map(|z| z.stress).fold(0.0f64, |a, s| a.max(s.abs()));
    let (stress_tol, pos_tol) = if t.is_f32() { (1e-3 * top, 1e-4) } else { (1e-9 * top, 1e-12) };
    for (z, (x, y)) in f.zones.iter().zip(&fr.zones).enumerate() {
        for i in 0..3 {
            assert!((x.stress[i] - y.stress[i]).abs() <= stress_tol, "{}: zone {z} stress {:?} against {:?}", t.name(), x.stress, y.stress);
        }
    }
    for (g, (x, y)) in f.gridpoints.iter().zip(&fr.gridpoints).enumerate() {
        let d = (x.position[0] - y.position[0]).hypot(x.position[1] - y.position[1]);
        assert!(d <= pos_tol, "{}: grid point {g} {:?} against {:?}", t.name(), x.position, y.position);
    }
    for (x, y) in m.blocks.iter().zip(&reference.blocks) {
        let d = (x.centroid[0] - y.centroid[0]).hypot(x.centroid[1] - y.centroid[1]);
        assert!(d <= pos_tol.max(1e-12), "{}: block {} at {:?} against {:?}", t.name(), x.id, x.centroid, y.centroid);
    }
    // The zoned block's corners are its boundary grid points, its centroid their mass centre.
    for (k, c) in m.block_corners(b).iter().enumerate() {
        assert_eq!(c.position, f.gridpoints[k].position);
    }
    assert!(m.validate().is_ok(), "{:?}", m.validate());
    let again = t.run(&deck);
    assert_eq!(again.fdef, m.fdef, "{}: a rerun repeats bit for bit", t.name());
    assert_eq!(again.blocks, m.blocks);
}

/// The ledger balances with zoned blocks on every backend: the energy put in (the work of
/// gravity) is the kinetic and strain energy held plus what damping and friction took, to the
/// precision's round-off (the central-difference step's own error is second order and small).
fn the_ledger_balances_with_zoned_blocks(t: &Target) {
    let m = t.run(&format!("{SQUARE_DECK}CHANGE 0.5 2.5 0 1 FDEF\nGENERATE 0.5 2.5 0 1 AUTO 0.3\nGRAV 0 -10\nDAMP 0.05 5 MASS\nCYCLE 400\nSTOP\n"));
    let e = m.energies();
    let held = e.kinetic + e.strain + e.mass_damping + e.contact_damping + e.friction + e.released;
    assert!(e.external_work > 0.0 && e.strain > 0.0, "{}: {e:?}", t.name());
    let tol = if t.is_f32() { 2e-2 } else { 1e-2 };
    assert!((held - e.external_work).abs() <= tol * e.external_work, "{}: held {held} against work {}", t.name(), e.external_work);
}

/// A zone driven inside out on any backend stops the run naming the block and a zone of the
/// flung grid point, and the model goes back to the state the run started from.
fn a_zone_turned_inside_out_stops_every_backend(t: &Target) {
    let deck = "START\nPROP MAT=1 DENS=2000 K=1E9 G=6E8 KN=1E10 KS=1E10\nROUND 0.05\nBLOCK (0,0) (2,0) (2,2) (0,2)\n\
                CHANGE -1 3 -1 3 FDEF\nGENERATE -1 3 -1 3 AUTO 0.6\nCYCLE 0\nSTOP\n";
    let mut m = run_deck_on(deck, cpu()).unwrap();
    let b = m.blocks.iter().position(|b| b.kind == BlockKind::FullyDeformable).unwrap();
    let k = m.fdef[b].boundary as usize;
    let dt = m.timestep;
    let g = &mut m.fdef[b].gridpoints[k];
    g.mass = 1e30;
    g.velocity = [10.0 / dt, 0.0];
    let e = t.backend().run(&mut m, 10, &mut |_| true).unwrap_err();
    match &e {
        blockdem::udec::backend::CycleError::ZoneInverted { cycle, block, zone } => {
            assert_eq!((*cycle, *block), (1, m.blocks[b].id), "{}", t.name());
            assert!(m.fdef[b].zones[*zone as usize - 1].gridpoints.contains(&(k as u32)), "{}: zone {zone}", t.name());
        }
        other => panic!("{}: {other}", t.name()),
    }
    assert_eq!(m.cycle, 0, "{}: rolled back", t.name());
    let v = m.fdef[b].gridpoints[k].velocity;
    assert!((v[0] / (10.0 / dt) - 1.0).abs() < 1e-6 && v[1] == 0.0, "{}: {v:?}", t.name());
}

every_backend!(sample_3_agrees_with_the_cpu, the_ledger_balances_with_zoned_blocks, a_zone_turned_inside_out_stops_every_backend,);
