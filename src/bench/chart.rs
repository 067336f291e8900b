//! bench.png: four panels drawn with plotters (the route and font of `verify::chart`).
//!
//! (a) block-cycles/s (solid) and contact-cycles/s (dashed) against N, log-log, one colour per
//! backend; (b) time per block-cycle against N (flat is the target), each point the median of
//! the measurement's rounds with a bar over their spread; (c) where a cycle's time goes
//! on each backend at its largest wall, in ns per block-cycle (GPU kernels from their own timing,
//! scaled to the measured batch time); (d) the roofline ratio (solid) and the share of CPU
//! topology work and transfers (dashed) against N.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::{BenchReport, ScalingRow};
use crate::verify::chart::{chart_png, PALETTE};

/// Legend entries (in black) for the solid and the dashed line of each colour.
fn style_legend<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    solid: &str,
    dashed: &str,
) -> Result<(), String> {
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(|e| e.to_string())?
        .label(format!("solid, dots: {solid}"))
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(2)));
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(|e| e.to_string())?
        .label(format!("dashed, triangles: {dashed}"))
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 6, y)], BLACK.stroke_width(2)));
    Ok(())
}

type Panel<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Backends with at least one measured wall, each with its rows in N order.
fn series(r: &BenchReport) -> Vec<(String, Vec<&ScalingRow>)> {
    let mut out: Vec<(String, Vec<&ScalingRow>)> = Vec::new();
    for x in r.scaling.iter().filter(|x| x.error.is_none() && x.cycles > 0) {
        match out.iter_mut().find(|(k, _)| *k == x.backend) {
            Some((_, v)) => v.push(x),
            None => out.push((x.backend.clone(), vec![x])),
        }
    }
    for (_, v) in &mut out {
        v.sort_by_key(|x| x.blocks);
    }
    out
}

fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.filter(|v| v.is_finite() && *v > 0.0).fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if lo.is_finite() && hi > 0.0 {
        (lo / 2.0, hi * 2.0)
    } else {
        (1.0, 10.0)
    }
}

fn n_range(r: &BenchReport) -> (f64, f64) {
    log_range(r.scaling.iter().filter(|x| x.error.is_none()).map(|x| x.blocks as f64))
}

type AgainstN<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// A log-log panel of a quantity against the wall size N (the walls' range), with its mesh drawn.
fn against_n<'a, 'b>(
    area: &'a Panel<'b>,
    r: &BenchReport,
    caption: &str,
    y: (f64, f64),
    y_desc: &str,
    y_ticks: &dyn Fn(&f64) -> String,
) -> Result<AgainstN<'a, 'b>, String> {
    let (x0, x1) = n_range(r);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(65)
        .build_cartesian_2d((x0..x1).log_scale(), (y.0..y.1).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("blocks N")
        .y_desc(y_desc)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(y_ticks)
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// One backend's pair of series in colour `c`: a solid line with dots (labelled `name` in the
/// legend) and a dashed line with triangles.
fn solid_and_dashed(chart: &mut AgainstN, c: RGBColor, name: &str, solid: Vec<(f64, f64)>, dashed: Vec<(f64, f64)>) -> Result<(), String> {
    chart
        .draw_series(LineSeries::new(solid.clone(), c.stroke_width(2)))
        .map_err(err)?
        .label(name)
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled()));
    chart.draw_series(solid.iter().map(|&p| Circle::new(p, 4, c.filled()))).map_err(err)?;
    chart.draw_series(DashedLineSeries::new(dashed.clone(), 6, 4, c.stroke_width(2))).map_err(err)?;
    chart.draw_series(dashed.iter().map(|&p| TriangleMarker::new(p, 5, c.filled()))).map_err(err)?;
    Ok(())
}

macro_rules! legend {
    ($chart:expr, $pos:expr) => {
        $chart.configure_series_labels().position($pos).background_style(WHITE.mix(0.85)).border_style(BLACK).label_font(("sans-serif", 12)).draw().map_err(err)
    };
}

fn throughput(area: &Panel, r: &BenchReport) -> Result<(), String> {
    let (y0, y1) = log_range(r.scaling.iter().filter(|x| x.error.is_none()).flat_map(|x| [x.block_cycles_per_s, x.contact_cycles_per_s]));
    // Room below the data for the legend.
    let mut chart = against_n(area, r, "(a) Throughput against wall size", (y0 / 30.0, y1), "per second", &|v| format!("{v:.0e}"))?;
    for (i, (name, rows)) in series(r).into_iter().enumerate() {
        let blocks = rows.iter().map(|x| (x.blocks as f64, x.block_cycles_per_s)).collect();
        let contacts = rows.iter().map(|x| (x.blocks as f64, x.contact_cycles_per_s)).collect();
        solid_and_dashed(&mut chart, PALETTE[i % PALETTE.len()], &name, blocks, contacts)?;
    }
    style_legend(&mut chart, "block-cycles/s", "contact-cycles/s")?;
    legend!(chart, SeriesLabelPosition::LowerRight)
}

fn per_block_cycle(area: &Panel, r: &BenchReport) -> Result<(), String> {
    let y = log_range(
        r.scaling
            .iter()
            .filter(|x| x.error.is_none())
            .flat_map(|x| round_range(x).map(|(lo, hi)| [lo, hi]).unwrap_or([x.s_per_block_cycle; 2]))
            .map(|t| 1e9 * t),
    );
    let caption = "(b) Time per block-cycle (flat = perfect scaling; bars: the rounds)";
    let mut chart = against_n(area, r, caption, y, "ns per block-cycle", &|v| format!("{v:.0}"))?;
    for (i, (name, rows)) in series(r).into_iter().enumerate() {
        let c = PALETTE[i % PALETTE.len()];
        let pts: Vec<(f64, f64)> = rows.iter().map(|x| (x.blocks as f64, 1e9 * x.s_per_block_cycle)).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(err)?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled()))).map_err(err)?;
        // The spread of the rounds behind each point (the median round), as a bar.
        let bars: Vec<PathElement<(f64, f64)>> = rows
            .iter()
            .filter_map(|x| round_range(x).map(|(lo, hi)| PathElement::new(vec![(x.blocks as f64, 1e9 * lo), (x.blocks as f64, 1e9 * hi)], c.stroke_width(2))))
            .collect();
        chart.draw_series(bars).map_err(err)?;
    }
    legend!(chart, SeriesLabelPosition::UpperRight)
}

/// The shortest and the longest time per block-cycle among a row's rounds (None for one round).
fn round_range(x: &ScalingRow) -> Option<(f64, f64)> {
    if x.round_s_per_cycle.len() < 2 {
        return None;
    }
    let per = |t: f64| t / x.blocks.max(1) as f64;
    let (lo, hi) = x.round_s_per_cycle.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &t| (a.min(t), b.max(t)));
    Some((per(lo), per(hi)))
}

/// The segments of one backend's bar: (stage, ns per block-cycle).
fn segments(x: &ScalingRow) -> Vec<(String, f64)> {
    let per = 1e9 / x.blocks.max(1) as f64;
    let kernels: Vec<_> = x.stages.iter().filter(|s| s.source == "device").collect();
    let kernel_sum: f64 = kernels.iter().map(|s| s.s_per_cycle).sum();
    let mut out = Vec::new();
    for s in x.stages.iter().filter(|s| s.source == "host") {
        if s.stage.starts_with("GPU batches") && kernel_sum > 0.0 {
            // The batch time split by the kernels' own shares.
            for k in &kernels {
                out.push((format!("kernel {}", k.stage), s.s_per_cycle * k.s_per_cycle / kernel_sum * per));
            }
        } else {
            out.push((s.stage.clone(), s.s_per_cycle * per));
        }
    }
    out
}

fn stages(area: &Panel, r: &BenchReport) -> Result<(), String> {
    let bars: Vec<(String, Vec<(String, f64)>)> =
        series(r).into_iter().filter_map(|(name, rows)| rows.last().map(|x| (format!("{name} ({} blocks)", x.blocks), segments(x)))).collect();
    let mut names: Vec<String> = Vec::new();
    for (_, segs) in &bars {
        for (s, _) in segs {
            if !names.contains(s) {
                names.push(s.clone());
            }
        }
    }
    let xmax = bars.iter().map(|(_, s)| s.iter().map(|x| x.1).sum::<f64>()).fold(0.0f64, f64::max).max(1e-3) * 1.05;
    let n = bars.len().max(1);
    let labels: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
    let mut chart = ChartBuilder::on(area)
        .caption("(c) Where a cycle goes, at each backend's largest wall", ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(10)
        .build_cartesian_2d(0.0..xmax * 2.4, -0.5..(n as f64 - 0.5))
        .map_err(err)?;
    chart.configure_mesh().disable_y_mesh().disable_y_axis().x_desc("ns per block-cycle").label_style(("sans-serif", 12)).draw().map_err(err)?;
    let colour = |s: &str| {
        let i = names.iter().position(|n| n == s).unwrap_or(0);
        let base = PALETTE[i % PALETTE.len()];
        if i >= PALETTE.len() {
            base.mix(0.5)
        } else {
            base.mix(1.0)
        }
    };
    for (i, (_, segs)) in bars.iter().enumerate() {
        let y = i as f64;
        let mut x = 0.0;
        for (s, w) in segs {
            let c = colour(s);
            chart.draw_series(std::iter::once(Rectangle::new([(x, y - 0.3), (x + w, y + 0.3)], c.filled()))).map_err(err)?;
            x += w;
        }
        chart.draw_series(std::iter::once(Text::new(labels[i].clone(), (x + 0.01 * xmax, y + 0.1), ("sans-serif", 12)))).map_err(err)?;
    }
    for s in &names {
        let c = colour(s);
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(err)?
            .label(s.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled()));
    }
    legend!(chart, SeriesLabelPosition::UpperRight)
}

fn shares(area: &Panel, r: &BenchReport) -> Result<(), String> {
    // Shares below 0.1% are drawn on 0.1%; the band below is left to the legend.
    let floor = 1e-3;
    let percent = |v: &f64| {
        let p = format!("{:.4}", 100.0 * v);
        format!("{}%", p.trim_end_matches('0').trim_end_matches('.'))
    };
    let (x0, x1) = n_range(r);
    let mut chart = against_n(area, r, "(d) Roofline ratio and CPU topology + transfer share", (floor / 100.0, 1.5), "fraction", &percent)?;
    for (i, (name, rows)) in series(r).into_iter().enumerate() {
        let roof = rows.iter().map(|x| (x.blocks as f64, x.roofline.max(floor))).collect();
        let host = rows.iter().map(|x| (x.blocks as f64, (x.topology_share + x.transfer_share).max(floor))).collect();
        solid_and_dashed(&mut chart, PALETTE[i % PALETTE.len()], &name, roof, host)?;
    }
    style_legend(&mut chart, "roofline ratio", "topology + transfers (<= 0.1% drawn at 0.1%)")?;
    for (goal, label) in [(0.4, "roofline goal 40% (H100)"), (0.1, "topology+transfers limit 10% (H100)")] {
        chart
            .draw_series(LineSeries::new(vec![(x0, goal), (x1, goal)], BLACK.mix(0.5).stroke_width(1)))
            .map_err(err)?
            .label(label)
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.mix(0.5)));
    }
    legend!(chart, SeriesLabelPosition::LowerRight)
}

/// Draws the four panels into `path`.
pub fn draw(r: &BenchReport, path: &Path) -> Result<PathBuf, String> {
    if r.scaling.iter().all(|x| x.error.is_some()) {
        return Err("no scaling measurement to chart".into());
    }
    chart_png(path, (1600, 1150), |root| {
        let title = format!(
            "blockdem bench, {} ({} cores){}",
            r.machine.cpu_model,
            r.machine.cores,
            r.machine.commit.as_ref().map(|c| format!(", commit {c}, {}", r.machine.date)).unwrap_or_default()
        );
        let root = root.titled(&title, ("sans-serif", 20)).map_err(err)?;
        let panels = root.split_evenly((2, 2));
        throughput(&panels[0], r)?;
        per_block_cycle(&panels[1], r)?;
        stages(&panels[2], r)?;
        shares(&panels[3], r)
    })
}
