//! The targets next to the figures, the table, and the CSV / JSON files of a bench run.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{BenchReport, ScalingRow, TargetRow};

/// The peers' drift on the reference settle as issue 4 quotes them (m): Box2D drifts 7 mm,
/// Rapier2D lets the wall sink by 9 cm. The settle's drift is judged against them, beyond the
/// elastic settlement (the project's decision; see `scene::WallMeasures`).
const PEER_DRIFT_BOX2D: f64 = 7e-3;
const PEER_DRIFT_RAPIER: f64 = 9e-2;

fn gpu_hardware_labels(r: &BenchReport) -> Vec<String> {
    r.backends.iter().filter(|b| b.kind == "gpu" && !b.software && b.error.is_none()).map(|b| b.label.clone()).collect()
}

fn ok_rows<'a>(r: &'a BenchReport, backend: &'a str) -> impl Iterator<Item = &'a ScalingRow> + 'a {
    r.scaling.iter().filter(move |s| s.backend == backend && s.error.is_none() && s.cycles > 0)
}

fn largest<'a>(r: &'a BenchReport, backend: &'a str) -> Option<&'a ScalingRow> {
    ok_rows(r, backend).max_by_key(|s| s.nominal)
}

fn sci(x: f64) -> String {
    format!("{x:.3e}")
}

fn pct(x: f64) -> String {
    format!("{:.1}%", 100.0 * x)
}

/// The ratio of two backends' time per cycle on one wall: the median of the ratios taken within
/// each round (the two ran seconds apart, in turn), and how it was taken. Rows without rounds
/// (one run each) give the ratio of their rows.
pub fn round_ratio(a: &ScalingRow, b: &ScalingRow) -> (f64, String) {
    let mut ratios: Vec<f64> = a.round_s_per_cycle.iter().zip(&b.round_s_per_cycle).map(|(x, y)| x / y).filter(|r| r.is_finite()).collect();
    if ratios.len() < 2 {
        return (a.s_per_cycle / b.s_per_cycle, "one run each, same bench".into());
    }
    ratios.sort_by(f64::total_cmp);
    let n = ratios.len();
    let median = if n % 2 == 1 { ratios[n / 2] } else { 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]) };
    (median, format!("median of {n} rounds in turn ({:.2}x to {:.2}x)", ratios[0], ratios[n - 1]))
}

/// The bandwidth figures of a backend in words: the yardstick the roofline uses, and on a GPU the
/// streaming kernel's sizes, `copy_buffer_to_buffer` and the data sheet's figure beside it.
pub fn bandwidth_summary(b: &super::BackendInfo) -> String {
    let gb = |x: f64| format!("{:.1} GB/s", x / 1e9);
    let Some(y) = b.bandwidth_bytes_per_s else { return "bandwidth not measured".into() };
    let mut s = format!("bandwidth {} ({})", gb(y), b.yardstick);
    if b.kind != "gpu" {
        return s;
    }
    if let Some(k) = b.stream_bandwidth_bytes_per_s {
        let sizes: Vec<String> = b.stream_sizes.iter().map(|(n, bw)| format!("{} MiB {}", n >> 20, gb(*bw))).collect();
        s += &format!("; streaming kernel {} [{}]", gb(k), sizes.join(", "));
    }
    if let Some(c) = b.copy_bandwidth_bytes_per_s {
        s += &format!(", copy_buffer_to_buffer {}", gb(c));
    }
    if let (Some(spec), Some(card)) = (b.spec_bandwidth_bytes_per_s, &b.spec_card) {
        s += &format!(", data sheet {} ({card}: yardstick at {} of it)", gb(spec), pct(y / spec));
    }
    s
}

/// Each target of the issue with the figure measured here and whether it is met (None where it
/// cannot be judged on this machine or in this run).
pub fn targets(r: &BenchReport) -> Vec<TargetRow> {
    let mut t = Vec::new();
    let hw = gpu_hardware_labels(r);
    let none_here = |target: &str, goal: &str| TargetRow {
        target: target.into(),
        backend: "hardware GPU".into(),
        goal: goal.into(),
        measured: "-".into(),
        met: None,
        note: "no hardware GPU adapter here".into(),
    };
    // Hardware-GPU targets, at the largest wall each reached.
    let hw_targets: [(&str, &str); 3] = [
        ("contact-cycles/s, 10^6-block wall, one H100", ">= 1e9"),
        ("cycle vs streaming-kernel bandwidth (roofline), H100", ">= 40%"),
        ("CPU topology + transfers, H100", "< 10% of the run"),
    ];
    if hw.is_empty() {
        for (target, goal) in hw_targets {
            t.push(none_here(target, goal));
        }
    }
    for label in &hw {
        let Some(row) = largest(r, label) else {
            for (target, goal) in hw_targets {
                t.push(TargetRow {
                    target: target.into(),
                    backend: label.clone(),
                    goal: goal.into(),
                    measured: "-".into(),
                    met: None,
                    note: "no wall measured".into(),
                });
            }
            continue;
        };
        let at = format!("at {} blocks", row.blocks);
        let full = row.nominal >= 1_000_000;
        let note = |extra: &str| if full { format!("{at}{extra}") } else { format!("{at}: the 10^6 wall was not reached{extra}") };
        t.push(TargetRow {
            target: hw_targets[0].0.into(),
            backend: label.clone(),
            goal: hw_targets[0].1.into(),
            measured: sci(row.contact_cycles_per_s),
            met: full.then_some(row.contact_cycles_per_s >= 1e9),
            note: note(""),
        });
        t.push(TargetRow {
            target: hw_targets[1].0.into(),
            backend: label.clone(),
            goal: hw_targets[1].1.into(),
            measured: pct(row.roofline),
            met: Some(row.roofline >= 0.4),
            note: note(&row.roofline_kernels.map(|k| format!("; kernels alone {}", pct(k))).unwrap_or_default()),
        });
        let share = row.topology_share + row.transfer_share;
        t.push(TargetRow {
            target: hw_targets[2].0.into(),
            backend: label.clone(),
            goal: hw_targets[2].1.into(),
            measured: pct(share),
            met: Some(share < 0.1),
            note: note(&format!("; with the set-up of the run {}", pct(row.run_topology_transfer_share))),
        });
    }
    // Simply-deformable bricks against rigid ones, per cycle on each backend (issue 28).
    for b in r.backends.iter().filter(|b| b.error.is_none()) {
        let row = |scene: &str| r.reference.iter().find(|x| x.scene == scene && x.backend == b.label && x.error.is_none() && x.cycles_per_s > 0.0);
        if let (Some(rigid), Some(sdef)) = (row("settle"), row("sdef")) {
            let ratio = rigid.cycles_per_s_without_kernel_build() / sdef.cycles_per_s_without_kernel_build();
            t.push(TargetRow {
                target: "SDEF wall vs rigid wall, time per cycle".into(),
                backend: b.label.clone(),
                goal: "<= 1.5x".into(),
                measured: format!("{ratio:.2}x"),
                met: Some(ratio <= 1.5),
                note: format!("reference wall, {} cycles each, set-up included, the one-off kernel build not", sdef.cycles),
            });
        }
        // The wall with fluid in its joints against the dry wall (issue 30).
        if let (Some(dry), Some(wet)) = (row("settle"), row("fluid")) {
            let ratio = dry.cycles_per_s_without_kernel_build() / wet.cycles_per_s_without_kernel_build();
            t.push(TargetRow {
                target: "fluid wall vs dry wall, time per cycle".into(),
                backend: b.label.clone(),
                goal: "<= 1.3x".into(),
                measured: format!("{ratio:.2}x"),
                met: Some(ratio <= 1.3),
                note: format!("reference wall, {} and {} cycles, set-up included, the one-off kernel build not", dry.cycles, wet.cycles),
            });
        }
    }
    // The largest SDEF wall each backend ran, per block-cycle against its rigid twin (issue 28:
    // the 10⁶-block SDEF wall on a hardware GPU).
    for b in r.backends.iter().filter(|b| b.error.is_none()) {
        let largest = r.sdef_scaling.iter().filter(|x| x.backend == b.label && x.error.is_none()).max_by_key(|x| x.nominal);
        if let Some((x, q)) = largest.and_then(|x| sdef_vs_rigid(r, x).map(|q| (x, q))) {
            t.push(TargetRow {
                target: "SDEF wall vs rigid wall, scaling family".into(),
                backend: b.label.clone(),
                goal: "<= 1.5x".into(),
                measured: format!("{q:.2}x"),
                met: Some(q <= 1.5),
                note: format!("at {} blocks, per block-cycle, {:.3e} SDEF block-cycles/s", x.blocks, x.block_cycles_per_s),
            });
        }
    }
    // Software adapters against the CPU at 10^5 blocks (or the largest wall both reached).
    for b in r.backends.iter().filter(|b| b.kind == "gpu" && b.software && b.error.is_none()) {
        let cpu: Vec<&ScalingRow> = ok_rows(r, "cpu f64").collect();
        let pair = ok_rows(r, &b.label).filter_map(|g| cpu.iter().find(|c| c.nominal == g.nominal).map(|c| (g, *c))).max_by_key(|(g, _)| g.nominal);
        let target = "software adapter vs CPU backend at 10^5 blocks".to_string();
        match pair {
            Some((g, c)) => {
                let (ratio, spread) = round_ratio(g, c);
                let at_goal = g.nominal == 100_000;
                let at = if at_goal { format!("at {} blocks", g.blocks) } else { format!("at {} blocks (10^5 not run)", g.blocks) };
                t.push(TargetRow {
                    target,
                    backend: b.label.clone(),
                    goal: "<= 2x the CPU's time per cycle".into(),
                    measured: format!("{ratio:.2}x"),
                    met: at_goal.then_some(ratio <= 2.0),
                    note: format!("{at}, {spread}"),
                });
            }
            None => t.push(TargetRow {
                target,
                backend: b.label.clone(),
                goal: "<= 2x".into(),
                measured: "-".into(),
                met: None,
                note: "no common wall with the CPU".into(),
            }),
        }
    }
    // Flat time per block-cycle over the sizes.
    for b in r.backends.iter().filter(|b| b.error.is_none()) {
        let rows: Vec<&ScalingRow> = ok_rows(r, &b.label).collect();
        if rows.len() < 2 {
            continue;
        }
        let (lo, hi) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), s| (lo.min(s.s_per_block_cycle), hi.max(s.s_per_block_cycle)));
        let (n0, n1) = (rows.iter().map(|s| s.nominal).min().unwrap_or(0), rows.iter().map(|s| s.nominal).max().unwrap_or(0));
        let spread = hi / lo;
        let covered = n0 <= 1_000 && n1 >= 1_000_000;
        t.push(TargetRow {
            target: "time per block-cycle flat over N".into(),
            backend: b.label.clone(),
            goal: "max/min <= 1.2 from 10^3 to 10^6".into(),
            measured: format!("{spread:.2}"),
            met: Some(spread <= 1.2),
            note: if covered { "10^3 to 10^6".into() } else { format!("over {n0} to {n1} only") },
        });
    }
    // The reference settle on the CPU backend.
    for row in r.reference.iter().filter(|x| x.scene == "settle" && x.backend == "cpu f64") {
        let full = (row.simulated_s - super::scene::SETTLE_TIME).abs() < 1e-9;
        let shortened = if full { String::new() } else { format!("shortened run ({} s simulated)", row.simulated_s) };
        match (&row.error, &row.measures) {
            (None, Some(m)) => {
                let projected = row.wall_s * super::scene::SETTLE_TIME / row.simulated_s;
                t.push(TargetRow {
                    target: "reference settle, 2 s simulated, CPU backend".into(),
                    backend: row.backend.clone(),
                    goal: "< 4 s wall".into(),
                    measured: format!("{:.2} s{}", projected, if full { "" } else { " (scaled)" }),
                    met: full.then_some(projected < 4.0),
                    note: if full { format!("{} cycles, {} cores", row.cycles, r.machine.cores) } else { shortened.clone() },
                });
                // The drift is judged beyond the elastic settlement and side by side with the
                // peers (a project decision, not an absolute 1 mm): the undamped wall dropped
                // onto unloaded joints rings and spreads (`scene::WallMeasures` says why), where
                // the inelastic solvers of Box2D and Rapier creep and sink instead.
                t.push(TargetRow {
                    target: "reference settle drift beyond elastic, CPU".into(),
                    backend: row.backend.clone(),
                    goal: format!("< peers: Box2D {:.0} mm, Rapier {:.0} mm", 1e3 * PEER_DRIFT_BOX2D, 1e3 * PEER_DRIFT_RAPIER),
                    measured: format!("{:.2} mm", 1e3 * m.drift_beyond_elastic),
                    met: full.then_some(m.drift_beyond_elastic < PEER_DRIFT_BOX2D.min(PEER_DRIFT_RAPIER)),
                    note: format!(
                        "{}drift {:.2} mm, top-row sink {:.2} mm, elastic estimate {:.2} mm",
                        if full { String::new() } else { format!("{shortened}; ") },
                        1e3 * m.drift,
                        1e3 * m.top_sink,
                        1e3 * m.elastic_estimate
                    ),
                });
            }
            _ => t.push(TargetRow {
                target: "reference settle, CPU backend".into(),
                backend: row.backend.clone(),
                goal: "< 4 s, drift < 1 mm".into(),
                measured: "failed".into(),
                met: Some(false),
                note: row.error.clone().unwrap_or_default(),
            }),
        }
    }
    // D3's cycle on the CPU (issue 31): 10⁶ body-steps per second on the 1000 cubes.
    for row in r.d3.iter().filter(|x| x.scene == "d3-cubes" && x.backend.starts_with("cpu")) {
        let ok = row.error.is_none();
        t.push(TargetRow {
            target: format!("d3-cubes ({} cubes), D3 CPU cycle", row.blocks),
            backend: row.backend.clone(),
            goal: format!(">= {:.0e} body-steps/s", super::d3::CUBES_TARGET),
            measured: if ok { format!("{:.3e}", row.body_steps_per_s) } else { "failed".into() },
            met: Some(ok && row.body_steps_per_s >= super::d3::CUBES_TARGET),
            note: if ok { format!("{:.2} of the target", row.body_steps_per_s / super::d3::CUBES_TARGET) } else { row.error.clone().unwrap_or_default() },
        });
    }
    // D3's wall on a hardware GPU (issue 31): 10⁸ contact-cycles/s on the 10⁶-brick wall, at 40 %
    // of the roofline; judged at the largest wall each hardware GPU ran.
    let d3_targets = [
        ("D3 wall contact-cycles/s, 10^6 bricks, one H100".to_string(), format!(">= {:.0e}", super::d3::WALL_GPU_TARGET)),
        ("D3 wall cycle vs streaming-kernel bandwidth (roofline), H100".to_string(), format!(">= {:.0}%", 100.0 * super::d3::WALL_ROOFLINE_TARGET)),
    ];
    if r.options.scenes.iter().any(|x| x == "d3-wall") {
        let hw: Vec<&super::d3::D3Row> = r.d3.iter().filter(|x| x.scene == "d3-wall" && x.hardware_gpu).collect();
        if hw.is_empty() {
            for (target, goal) in &d3_targets {
                t.push(none_here(target, goal));
            }
        }
        let mut labels: Vec<&str> = hw.iter().map(|x| x.backend.as_str()).collect();
        labels.dedup();
        for label in labels {
            let largest = hw.iter().filter(|x| x.backend == label && x.error.is_none()).max_by_key(|x| x.blocks);
            let Some(row) = largest else {
                for (target, goal) in &d3_targets {
                    t.push(TargetRow {
                        target: target.clone(),
                        backend: label.into(),
                        goal: goal.clone(),
                        measured: "-".into(),
                        met: None,
                        note: "no wall measured".into(),
                    });
                }
                continue;
            };
            let full = row.blocks >= 1_000_000;
            let at = format!("at {} bricks", row.blocks);
            let note = |extra: String| if full { format!("{at}{extra}") } else { format!("{at}: the 10^6 wall was not reached{extra}") };
            t.push(TargetRow {
                target: d3_targets[0].0.clone(),
                backend: label.into(),
                goal: d3_targets[0].1.clone(),
                measured: sci(row.contact_cycles_per_s),
                met: full.then_some(row.contact_cycles_per_s >= super::d3::WALL_GPU_TARGET),
                note: note(String::new()),
            });
            t.push(TargetRow {
                target: d3_targets[1].0.clone(),
                backend: label.into(),
                goal: d3_targets[1].1.clone(),
                measured: pct(row.roofline),
                met: (row.roofline > 0.0).then_some(row.roofline >= super::d3::WALL_ROOFLINE_TARGET),
                note: note(row.roofline_kernels.map(|k| format!("; kernels alone {}", pct(k))).unwrap_or_default()),
            });
        }
    }
    t
}

fn mib(b: u64) -> String {
    format!("{:.1}", b as f64 / (1u64 << 20) as f64)
}

/// The table `blockdem bench` prints.
pub fn table(r: &BenchReport) -> String {
    let mut s = String::new();
    let m = &r.machine;
    let _ = writeln!(s, "blockdem bench{} — {}", if r.options.quick { " --quick" } else { "" }, m.date);
    let _ = writeln!(
        s,
        "machine: {} ({} logical cores, rayon {} threads), {:.1} GiB, {}{}",
        m.cpu_model,
        m.cores,
        m.rayon_threads,
        m.memory_total_bytes as f64 / (1u64 << 30) as f64,
        m.os,
        m.commit.as_ref().map(|c| format!(", commit {c}")).unwrap_or_default()
    );
    let _ = writeln!(s, "backends:");
    for b in &r.backends {
        match &b.error {
            Some(e) => {
                let _ = writeln!(s, "  {:<24} not available: {e}", b.label);
            }
            None => {
                let _ = writeln!(
                    s,
                    "  {:<24} {} [{}]{} {}, stage times: {}",
                    b.label,
                    b.adapter,
                    b.driver,
                    if b.software && b.kind == "gpu" { " (software adapter)" } else { "" },
                    bandwidth_summary(b),
                    b.stage_timing
                );
            }
        }
    }
    let o = &r.options;
    let _ = writeln!(
        s,
        "scenes: {}; FRACTION {}, ROUND {}",
        o.scenes.join(", "),
        crate::output::format::fmt_short(o.frac),
        crate::output::format::fmt_short(o.round)
    );

    if !r.reference.is_empty() {
        let _ = writeln!(s, "\nREFERENCE WALL (1012 bricks; settle: the wall alone; impact: 0.5 m projectile, density 8000, 50 m/s)");
        let _ = writeln!(
            s,
            "{:<8} {:<24} {:>6} {:>7} {:>10} {:>8} {:>8} {:>9} {:>10} {:>10} {:>10} {:>7}",
            "scene", "backend", "bricks", "cycles", "dt (s)", "sim (s)", "wall (s)", "cycles/s", "drift (mm)", "sink (mm)", "elast (mm)", "moved"
        );
        for x in &r.reference {
            match (&x.error, &x.measures) {
                (None, Some(w)) => {
                    let _ = writeln!(
                        s,
                        "{:<8} {:<24} {:>6} {:>7} {:>10.4e} {:>8.3} {:>8.2} {:>9.0} {:>10.3} {:>10.3} {:>10.3} {:>7}",
                        x.scene,
                        x.backend,
                        w.bricks,
                        x.cycles,
                        x.timestep,
                        x.simulated_s,
                        x.wall_s,
                        x.cycles_per_s,
                        1e3 * w.drift,
                        1e3 * w.top_sink,
                        1e3 * w.elastic_estimate,
                        w.moved
                    );
                }
                _ => {
                    let _ = writeln!(s, "{:<8} {:<24} FAILED: {}", x.scene, x.backend, x.error.as_deref().unwrap_or("?"));
                }
            }
        }
        // Where each reference run's wall time went.
        for x in r.reference.iter().filter(|x| x.error.is_none()) {
            let parts: Vec<String> = x.stages.iter().map(|(name, _, t)| format!("{name} {:.1}%", 100.0 * t / x.wall_s.max(1e-12))).collect();
            let topo_xfer: f64 = x.stages.iter().filter(|(_, g, _)| g == "topology" || g == "transfer").map(|(_, _, t)| t).sum();
            let _ = writeln!(
                s,
                "  {} on {}: {} contact updates; topology + transfers {:.1}% of the wall time ({})",
                x.scene,
                x.backend,
                x.topology_updates,
                100.0 * topo_xfer / x.wall_s.max(1e-12),
                parts.join(", ")
            );
        }
        // Each GPU run's kernels, microseconds a cycle.
        for x in r.reference.iter().filter(|x| !x.kernels.is_empty()) {
            let parts: Vec<String> = x.kernels.iter().map(|(name, t)| format!("{name} {:.2}", t * 1e6)).collect();
            let sum: f64 = x.kernels.iter().map(|k| k.1).sum();
            let _ = writeln!(
                s,
                "  {} on {}: kernels (us/cycle, {:.1} of the {:.1} a cycle took) {}",
                x.scene,
                x.backend,
                sum * 1e6,
                1e6 * x.wall_s / x.cycles.max(1) as f64,
                parts.join(", ")
            );
        }
        for scene in ["settle", "impact"] {
            let cpu = r.reference.iter().find(|x| x.backend == "cpu f64" && x.scene == scene && x.error.is_none());
            for x in r.reference.iter().filter(|x| x.backend != "cpu f64" && x.scene == scene && x.error.is_none()) {
                if let Some(c) = cpu {
                    let _ = writeln!(s, "  {scene} wall time {} / cpu f64: {:.2}x", x.backend, x.wall_s / c.wall_s);
                }
            }
        }
    }

    if !r.scaling.is_empty() {
        let _ = writeln!(
            s,
            "\nSCALING (25-row walls; rates over the cycles between each run's set-up and its final read-back, shares of that time; set-up and final read-back apart)"
        );
        let _ = writeln!(
            s,
            "{:<24} {:>8} {:>8} {:>6} {:>10} {:>11} {:>11} {:>10} {:>8} {:>9} {:>7} {:>7} {:>8} {:>8}",
            "backend",
            "blocks",
            "contacts",
            "cycles",
            "s/cycle",
            "block-cyc/s",
            "contact-c/s",
            "MiB/cycle",
            "roofline",
            "(kernels)",
            "topo",
            "xfer",
            "setup(s)",
            "final(s)"
        );
        for x in &r.scaling {
            if let Some(e) = &x.error {
                let _ = writeln!(s, "{:<24} {:>8} FAILED/SKIPPED: {e}", x.backend, x.nominal);
                continue;
            }
            let _ = writeln!(
                s,
                "{:<24} {:>8} {:>8} {:>6} {:>10.3e} {:>11.3e} {:>11.3e} {:>10} {:>8} {:>9} {:>7} {:>7} {:>8.2} {:>8.2}",
                x.backend,
                x.blocks,
                x.contacts,
                x.cycles,
                x.s_per_cycle,
                x.block_cycles_per_s,
                x.contact_cycles_per_s,
                mib(x.bytes_per_cycle),
                pct(x.roofline),
                x.roofline_kernels.map(pct).unwrap_or_else(|| "-".into()),
                pct(x.topology_share),
                pct(x.transfer_share),
                x.setup_s,
                x.teardown_s
            );
        }
        // Ratios against the CPU in the same run.
        for x in r.scaling.iter().filter(|x| x.backend != "cpu f64" && x.error.is_none()) {
            if let Some(c) = r.scaling.iter().find(|c| c.backend == "cpu f64" && c.nominal == x.nominal && c.error.is_none()) {
                let (ratio, how) = round_ratio(x, c);
                let _ = writeln!(s, "  {} at {} blocks: time per cycle {ratio:.2}x the CPU's ({how})", x.backend, x.blocks);
            }
        }
        // What building each wall cost (deck, blocks, first detection on the CPU).
        let mut walls: Vec<(usize, f64)> = r.scaling.iter().filter(|x| x.error.is_none()).map(|x| (x.blocks, x.build_s)).collect();
        walls.dedup_by_key(|w| w.0);
        for (blocks, build_s) in walls {
            let _ = writeln!(s, "  the wall of {blocks} blocks: built in {build_s:.3} s (deck read, blocks, first contact detection, on the CPU)");
        }
        // What a contact update costs the host (topology work and transfers), per update.
        for x in r.scaling.iter().filter(|x| x.error.is_none() && x.topology_updates > 0) {
            let _ = writeln!(
                s,
                "  {} at {} blocks: {} contact updates in {} cycles, {:.3} ms of host topology + transfers each",
                x.backend,
                x.blocks,
                x.topology_updates,
                x.cycles,
                1e3 * x.host_s_per_update
            );
        }
        let _ = writeln!(
            s,
            "\nTIME PER STAGE (microseconds per cycle; host: timed during the run, shares of the cycle; device: kernel times, which run inside the host's GPU batches, shares of the kernels' sum)"
        );
        for x in r.scaling.iter().filter(|x| x.error.is_none()) {
            let kernels: f64 = x.stages.iter().filter(|st| st.source == "device").map(|st| st.s_per_cycle).sum();
            let _ = writeln!(
                s,
                "  {} at {} blocks ({:.1} us/cycle){}",
                x.backend,
                x.blocks,
                1e6 * x.s_per_cycle,
                x.device_timing.as_ref().map(|d| format!(", kernels by {d}")).unwrap_or_default()
            );
            for st in &x.stages {
                let _ = writeln!(
                    s,
                    "    {:<6} {:<30} {:>12.2} {:>6}{}",
                    st.source,
                    st.stage,
                    1e6 * st.s_per_cycle,
                    if st.source == "device" { pct(st.s_per_cycle / kernels) } else { pct(st.s_per_cycle / x.s_per_cycle) },
                    st.bytes_per_cycle.map(|b| format!("  {} MiB", mib(b))).unwrap_or_default()
                );
            }
        }
    }

    s += &sdef_scaling_table(r);
    s += &super::zones::table(&r.zones);
    s += &super::d3::table(&r.d3);
    if !r.targets.is_empty() {
        let _ = writeln!(s, "\nTARGETS");
        let _ = writeln!(s, "{:<50} {:<24} {:<30} {:<14} {:<5} note", "target", "backend", "goal", "measured", "met");
        for t in &r.targets {
            let met = match t.met {
                Some(true) => "yes",
                Some(false) => "NO",
                None => "n/a",
            };
            let _ = writeln!(s, "{:<50} {:<24} {:<30} {:<14} {:<5} {}", t.target, t.backend, t.goal, t.measured, met, t.note);
        }
    }
    s
}

/// The SDEF scaling family: rates per backend and wall, each against the rigid wall of the same
/// size on the same backend in this run (the rigid family's row), and the kernels' times.
fn sdef_scaling_table(r: &BenchReport) -> String {
    let mut s = String::new();
    if r.sdef_scaling.is_empty() {
        return s;
    }
    let _ = writeln!(
        s,
        "\nSDEF SCALING (the scaling walls with simply-deformable bricks, the same projectile; against the rigid wall of the same size and backend)"
    );
    let _ = writeln!(
        s,
        "{:<24} {:>8} {:>8} {:>6} {:>10} {:>11} {:>11} {:>9} {:>7} {:>7}",
        "backend", "blocks", "contacts", "cycles", "s/cycle", "block-cyc/s", "contact-c/s", "vs rigid", "topo", "xfer"
    );
    for x in &r.sdef_scaling {
        if let Some(e) = &x.error {
            let _ = writeln!(s, "{:<24} {:>8} FAILED/SKIPPED: {e}", x.backend, x.nominal);
            continue;
        }
        let _ = writeln!(
            s,
            "{:<24} {:>8} {:>8} {:>6} {:>10.3e} {:>11.3e} {:>11.3e} {:>9} {:>7} {:>7}",
            x.backend,
            x.blocks,
            x.contacts,
            x.cycles,
            x.s_per_cycle,
            x.block_cycles_per_s,
            x.contact_cycles_per_s,
            sdef_vs_rigid(r, x).map(|q| format!("{q:.2}x")).unwrap_or_else(|| "-".into()),
            pct(x.topology_share),
            pct(x.transfer_share),
        );
    }
    for x in r.sdef_scaling.iter().filter(|x| x.error.is_none() && x.stages.iter().any(|st| st.source == "device")) {
        let kernels: Vec<String> = x.stages.iter().filter(|st| st.source == "device").map(|st| format!("{} {:.2}", st.stage, 1e6 * st.s_per_cycle)).collect();
        let _ = writeln!(s, "  {} at {} blocks: kernels (us/cycle) {}", x.backend, x.blocks, kernels.join(", "));
    }
    s
}

/// An SDEF scaling row's time per block-cycle over the rigid row's of the same wall and backend.
pub fn sdef_vs_rigid(r: &BenchReport, x: &ScalingRow) -> Option<f64> {
    let rigid = r.scaling.iter().find(|c| c.backend == x.backend && c.nominal == x.nominal && c.error.is_none() && c.s_per_block_cycle > 0.0)?;
    (x.error.is_none() && x.s_per_block_cycle > 0.0).then(|| x.s_per_block_cycle / rigid.s_per_block_cycle)
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:e}")).unwrap_or_default()
}

/// bench.csv: one row per wall and backend of the scaling family.
pub fn scaling_csv(r: &BenchReport) -> String {
    rows_csv(&r.scaling)
}

/// The rows of a scaling family as CSV (bench.csv, bench_sdef_scaling.csv).
pub fn rows_csv(rows: &[ScalingRow]) -> String {
    let mut s = String::from(
        "backend,nominal,blocks,corners,contacts,cycles,setup_s,teardown_s,steady_s,s_per_cycle,s_per_block_cycle,block_cycles_per_s,contact_cycles_per_s,bytes_per_cycle,bandwidth_bytes_per_s,roofline,roofline_kernels,topology_share,transfer_share,run_topology_transfer_share,contact_updates,host_s_per_update,build_s,round_s_per_cycle,error\n",
    );
    for x in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{},{:e},{:e},{},{:e},{:e},{:e},{},{:e},{:e},{},{}",
            csv_field(&x.backend),
            x.nominal,
            x.blocks,
            x.corners,
            x.contacts,
            x.cycles,
            x.setup_s,
            x.teardown_s,
            x.steady_s,
            x.s_per_cycle,
            x.s_per_block_cycle,
            x.block_cycles_per_s,
            x.contact_cycles_per_s,
            x.bytes_per_cycle,
            x.bandwidth_bytes_per_s,
            x.roofline,
            opt(x.roofline_kernels),
            x.topology_share,
            x.transfer_share,
            x.run_topology_transfer_share,
            x.topology_updates,
            x.host_s_per_update,
            x.build_s,
            x.round_s_per_cycle.iter().map(|t| format!("{t:e}")).collect::<Vec<_>>().join(";"),
            csv_field(x.error.as_deref().unwrap_or(""))
        );
    }
    s
}

/// bench_stages.csv: the time (and bytes) of each stage per cycle.
pub fn stages_csv(r: &BenchReport) -> String {
    let mut s = String::from("backend,blocks,source,stage,group,s_per_cycle,share_of_cycle,bytes_per_cycle\n");
    for x in r.scaling.iter().filter(|x| x.error.is_none()) {
        for st in &x.stages {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{:e},{:e},{}",
                csv_field(&x.backend),
                x.blocks,
                st.source,
                csv_field(&st.stage),
                st.group,
                st.s_per_cycle,
                st.s_per_cycle / x.s_per_cycle,
                st.bytes_per_cycle.map(|b| b.to_string()).unwrap_or_default()
            );
        }
    }
    s
}

/// bench_reference.csv: the reference scenes.
pub fn reference_csv(r: &BenchReport) -> String {
    let mut s = String::from(
        "scene,backend,bricks,blocks,contacts,cycles,timestep,simulated_s,wall_s,cycles_per_s,drift_m,top_sink_m,elastic_estimate_m,moved,error\n",
    );
    for x in &r.reference {
        let m = x.measures.unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{:e},{},{:e},{:e},{:e},{:e},{:e},{},{}",
            x.scene,
            csv_field(&x.backend),
            m.bricks,
            x.blocks,
            x.contacts,
            x.cycles,
            x.timestep,
            x.simulated_s,
            x.wall_s,
            x.cycles_per_s,
            m.drift,
            m.top_sink,
            m.elastic_estimate,
            m.moved,
            csv_field(x.error.as_deref().unwrap_or(""))
        );
    }
    s
}

/// bench_targets.csv.
pub fn targets_csv(r: &BenchReport) -> String {
    let mut s = String::from("target,backend,goal,measured,met,note\n");
    for t in &r.targets {
        let met = t.met.map(|m| if m { "yes" } else { "no" }).unwrap_or("n/a");
        let _ =
            writeln!(s, "{},{},{},{},{},{}", csv_field(&t.target), csv_field(&t.backend), csv_field(&t.goal), csv_field(&t.measured), met, csv_field(&t.note));
    }
    s
}

/// Writes bench.csv, bench_stages.csv, bench_reference.csv, bench_targets.csv, bench_zones.csv,
/// bench_zone_kernels.csv,
/// bench_sdef_scaling.csv, bench_d3.csv, bench.json and
/// bench.png into `dir`. Returns the files written and, when the chart could not be drawn, why.
pub fn write_outputs(r: &BenchReport, dir: &Path) -> std::io::Result<(Vec<PathBuf>, Option<String>)> {
    std::fs::create_dir_all(dir)?;
    let mut files = Vec::new();
    for (name, text) in [
        ("bench.csv", scaling_csv(r)),
        ("bench_stages.csv", stages_csv(r)),
        ("bench_reference.csv", reference_csv(r)),
        ("bench_targets.csv", targets_csv(r)),
        ("bench_zones.csv", super::zones::csv(&r.zones)),
        ("bench_zone_kernels.csv", super::zones::kernels_csv(&r.zones)),
        ("bench_d3.csv", super::d3::csv(&r.d3)),
        ("bench_sdef_scaling.csv", rows_csv(&r.sdef_scaling)),
        ("bench.json", serde_json::to_string_pretty(r).map_err(std::io::Error::other)?),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text)?;
        files.push(p);
    }
    let chart = dir.join("bench.png");
    let problem = match super::chart::draw(r, &chart) {
        Ok(p) => {
            files.push(p);
            None
        }
        Err(e) => Some(e),
    };
    Ok((files, problem))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::ReferenceRow;

    fn row(rounds: &[f64]) -> ScalingRow {
        ScalingRow { s_per_cycle: rounds.first().copied().unwrap_or(1.0), round_s_per_cycle: rounds.to_vec(), ..Default::default() }
    }

    /// The ratio is taken round by round (the machine's speed drifts between rounds, alike for
    /// both backends of a round), and the median of those ratios is reported.
    #[test]
    fn a_ratio_of_two_backends_is_the_median_of_its_rounds() {
        // The machine slows by 2x in round 2 and 3x in round 3; within each round the GPU takes
        // 1.5x, 1.8x and 1.6x the CPU's time.
        let gpu = row(&[1.5, 3.6, 4.8]);
        let cpu = row(&[1.0, 2.0, 3.0]);
        let (ratio, how) = round_ratio(&gpu, &cpu);
        assert!((ratio - 1.6).abs() < 1e-12, "{ratio}");
        assert!(how.contains("median of 3 rounds") && how.contains("1.50x to 1.80x"), "{how}");
        // Even counts take the mean of the middle two.
        let (ratio, _) = round_ratio(&row(&[1.0, 3.0, 2.0, 8.0]), &row(&[1.0, 1.0, 1.0, 1.0]));
        assert!((ratio - 2.5).abs() < 1e-12, "{ratio}");
        // One run each: the rows' own times.
        let (ratio, how) = round_ratio(&row(&[3.0]), &row(&[2.0]));
        assert!((ratio - 1.5).abs() < 1e-12 && how.contains("one run"), "{ratio} {how}");
    }

    /// The settle's drift is judged beyond the elastic settlement against the peers' (Box2D's
    /// 7 mm the nearer), not against an absolute 1 mm: the wall's 2.96 mm of drift, 2.85 mm
    /// beyond the elastic settlement, meets it; 8 mm beyond would not; a shortened run is not
    /// judged.
    #[test]
    fn the_settle_drift_is_judged_beyond_the_elastic_settlement_against_the_peers() {
        let settle = |simulated_s: f64, drift_beyond_elastic: f64| ReferenceRow {
            scene: "settle".into(),
            backend: "cpu f64".into(),
            simulated_s,
            wall_s: 3.0,
            measures: Some(super::super::scene::WallMeasures { drift: 2.96e-3, drift_beyond_elastic, elastic_estimate: 0.88e-3, ..Default::default() }),
            ..Default::default()
        };
        let drift_row = |row: ReferenceRow| {
            let report = BenchReport { reference: vec![row], ..Default::default() };
            targets(&report).into_iter().find(|t| t.target.starts_with("reference settle drift")).expect("the drift's row")
        };
        let full = super::super::scene::SETTLE_TIME;
        let met = drift_row(settle(full, 2.85e-3));
        assert_eq!((met.met, met.measured.as_str()), (Some(true), "2.85 mm"), "{met:?}");
        assert!(met.goal.contains("Box2D 7 mm") && met.goal.contains("Rapier 90 mm") && met.note.contains("drift 2.96 mm"), "{met:?}");
        assert_eq!(drift_row(settle(full, 8e-3)).met, Some(false));
        assert_eq!(drift_row(settle(0.1, 2.85e-3)).met, None);
    }
}
