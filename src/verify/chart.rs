//! PNG charts of the suite with `plotters` (bitmap backend, text through `ab_glyph`).
//!
//! Why this route: plotters draws log axes, legends and markers out of the box, and its bitmap
//! backend with `ab_glyph` is pure Rust, so nothing links against a system library. `ab_glyph`
//! needs a font file: DejaVu Sans from Debian's fonts-dejavu-core (scripts/setup.sh installs it),
//! or the file named by `BLOCKDEM_FONT`. Without one the charts are skipped with a message and
//! the CSV files still carry every number.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::prelude::*;

use super::{Row, Suite, CHECK_FRAC};

/// Where DejaVu Sans lives on Debian and other common layouts.
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
];

/// Error ratios below this are drawn on it (log axes cannot show 0).
const FLOOR: f64 = 1e-4;
/// Numerical failures are drawn on this line, above every finite point.
const FAILED_AT: f64 = 1e3;

pub(crate) fn ensure_font() -> Result<(), String> {
    static FONT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let mut candidates: Vec<String> = Vec::new();
        if let Ok(p) = std::env::var("BLOCKDEM_FONT") {
            candidates.push(p);
        }
        candidates.extend(FONT_PATHS.iter().map(|s| s.to_string()));
        for p in &candidates {
            if let Ok(bytes) = std::fs::read(p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return Ok(());
                }
            }
        }
        Err("no font for the chart text: install fonts-dejavu-core (scripts/setup.sh does) or set BLOCKDEM_FONT to a .ttf file".to_string())
    })
    .clone()
}

/// Error over tolerance (a count-of-regimes case with tolerance 0 is measured against 0.01, so
/// one misjudged regime plots far above 1).
pub fn normalized(r: &Row) -> Option<f64> {
    r.error.map(|e| (e / r.tolerance.max(0.01)).max(FLOOR))
}

pub(crate) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Series of the suite: one per (case, backend, precision), rows in FRACTION order.
fn series(suite: &Suite) -> Vec<(String, Vec<&Row>)> {
    let mut out: Vec<(String, Vec<&Row>)> = Vec::new();
    for r in &suite.rows {
        let key = format!("{} ({} {})", r.case, r.backend, r.precision);
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(r),
            None => out.push((key, vec![r])),
        }
    }
    for (_, v) in &mut out {
        v.sort_by(|a, b| a.frac.total_cmp(&b.frac));
    }
    out
}

type Panel<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

fn draw_panel(area: &Panel, suite: &Suite, title: &str, x_label: &str, x_of: &dyn Fn(&Row) -> f64, legend: bool) -> Result<(), String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let xs: Vec<f64> = suite.rows.iter().map(x_of).filter(|x| x.is_finite() && *x > 0.0).collect();
    let (mut x0, mut x1) = xs.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    if !(x0.is_finite() && x1 > 0.0) {
        (x0, x1) = (1e-3, 1.0);
    }
    let (x0, x1) = (x0 / 2.0, x1 * 2.0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((x0..x1).log_scale(), (FLOOR / 2.0..FAILED_AT * 3.0).log_scale())
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc("error / tolerance")
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|x| e(&x))?;
    chart.draw_series(LineSeries::new(vec![(x0, 1.0), (x1, 1.0)], BLACK.stroke_width(1))).map_err(|x| e(&x))?.label("tolerance").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
    chart
        .draw_series(LineSeries::new(vec![(x0, FAILED_AT), (x1, FAILED_AT)], RED.mix(0.4).stroke_width(1)))
        .map_err(|x| e(&x))?
        .label("numerical failure (x)")
        .legend(|(x, y)| Cross::new((x + 9, y), 5, RED.stroke_width(2)));
    for (i, (name, rows)) in series(suite).into_iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let ok: Vec<(f64, f64)> = rows.iter().filter_map(|r| normalized(r).map(|y| (x_of(r), y))).filter(|(x, _)| x.is_finite() && *x > 0.0).collect();
        chart
            .draw_series(LineSeries::new(ok.clone(), color.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
        chart.draw_series(ok.iter().map(|&p| Circle::new(p, 3, color.filled()))).map_err(|x| e(&x))?;
        // The check FRACTION gets a ring, the numerical failures a cross on the failure line.
        chart
            .draw_series(rows.iter().filter(|r| (r.frac - CHECK_FRAC).abs() < 1e-12).filter_map(|r| normalized(r).map(|y| Circle::new((x_of(r), y), 7, color.stroke_width(2)))))
            .map_err(|x| e(&x))?;
        chart
            .draw_series(rows.iter().filter(|r| r.error.is_none()).map(|r| Cross::new((x_of(r).max(x0 * 1.01), FAILED_AT), 6, color.stroke_width(2))))
            .map_err(|x| e(&x))?;
    }
    if legend {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .draw()
            .map_err(|x| e(&x))?;
    }
    Ok(())
}

/// Error against wall time (left) and against cycles per second (right), log axes, one line per
/// case through the FRACTION sweep (FRAC grows with falling wall time).
pub fn accuracy_vs_speed(suite: &Suite, path: &Path) -> Result<PathBuf, String> {
    ensure_font()?;
    {
        let root = BitMapBackend::new(path, (1500, 650)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (left, right) = root.split_horizontally(750);
        draw_panel(&left, suite, "Accuracy against wall time (FRAC sweep)", "wall time of the run [s]", &|r| r.cost.wall_s, true)?;
        draw_panel(&right, suite, "Accuracy against speed", "cycles per second", &|r| r.cost.cycles_per_s(), false)?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(path.to_path_buf())
}

/// Error against FRACTION, log axes: where the error grows and where runs fail.
pub fn error_vs_frac(suite: &Suite, path: &Path) -> Result<PathBuf, String> {
    ensure_font()?;
    {
        let root = BitMapBackend::new(path, (900, 650)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw_panel(&root, suite, "Error against FRACTION (ring: the default 0.1)", "FRACTION of the UDEC time step", &|r| r.frac, true)?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(path.to_path_buf())
}
