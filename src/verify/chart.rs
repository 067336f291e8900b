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

/// Error ratios below this are drawn on it (log axes cannot show 0).
const FLOOR: f64 = 1e-4;
/// Numerical failures are drawn on this line, above every finite point.
const FAILED_AT: f64 = 1e3;

/// Registers the font of `output::font` with plotters (once).
fn ensure_font() -> Result<(), String> {
    static FONT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let bytes = crate::output::font::font_bytes()?;
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).map_err(|_| "the font file could not be read as a font".to_string())
    })
    .clone()
}

/// Draws a chart of `size` pixels (`draw` gets its white page) and writes it to `path` as a PNG.
/// plotters draws into an RGB buffer and the `png` crate (tiny-skia's encoder, which PLOT's
/// pictures use) writes it: plotters' own file output would bring the `image` crate and its
/// decoders into the build.
pub(crate) fn chart_png(path: &Path, size: (u32, u32), draw: impl FnOnce(&Panel) -> Result<(), String>) -> Result<PathBuf, String> {
    ensure_font()?;
    let mut rgb = vec![0u8; 3 * size.0 as usize * size.1 as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw(&root)?;
        root.present().map_err(|e| e.to_string())?;
    }
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, size.0, size.1);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Best);
        encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = encoder.write_header().map_err(|e| format!("PNG encoding failed: {e}"))?;
        writer.write_image_data(&rgb).map_err(|e| format!("PNG encoding failed: {e}"))?;
    }
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path.to_path_buf())
}

/// Pixels a legend entry takes (12-point text and its spacing), and the legend box's margins.
const LEGEND_ENTRY_PX: f64 = 17.0;
const LEGEND_MARGIN_PX: f64 = 24.0;

/// The factor by which a log axis from FLOOR/2 to 3·FAILED_AT must reach higher for a legend of
/// `entries` lines to fit above the failure line, on a plot `plot_px` pixels high: the band
/// added, d decades, holds the legend's L pixels when d·H/(D + d) ≥ L, D the data's decades.
fn legend_headroom(entries: usize, plot_px: f64) -> f64 {
    let legend_px = entries as f64 * LEGEND_ENTRY_PX + LEGEND_MARGIN_PX;
    let data_decades = (FAILED_AT * 3.0 / (FLOOR / 2.0)).log10();
    // A plot too small for its legend above the data gets three decades and the overlap.
    let decades = if plot_px > legend_px + 50.0 { legend_px * data_decades / (plot_px - legend_px) } else { 3.0 };
    10f64.powf(decades)
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

/// One line of a chart: a case on a backend (backend + precision), rows in FRACTION order.
struct Series<'a> {
    /// Index of the case (its colour) and of the backend (its marker and dash).
    case: usize,
    backend: usize,
    rows: Vec<&'a Row>,
}

/// Cases and backends in suite order, and one series per (case, backend) pair.
fn series(suite: &Suite) -> (Vec<&'static str>, Vec<String>, Vec<Series<'_>>) {
    let (mut cases, mut backends): (Vec<&'static str>, Vec<String>) = (Vec::new(), Vec::new());
    let mut out: Vec<Series> = Vec::new();
    for r in &suite.rows {
        let be = r.backend_name();
        let c = cases.iter().position(|c| *c == r.case).unwrap_or_else(|| {
            cases.push(r.case);
            cases.len() - 1
        });
        let b = backends.iter().position(|b| *b == be).unwrap_or_else(|| {
            backends.push(be);
            backends.len() - 1
        });
        match out.iter_mut().find(|s| s.case == c && s.backend == b) {
            Some(s) => s.rows.push(r),
            None => out.push(Series { case: c, backend: b, rows: vec![r] }),
        }
    }
    for s in &mut out {
        s.rows.sort_by(|a, b| a.frac.total_cmp(&b.frac));
    }
    (cases, backends, out)
}

/// How a backend's series look: the CPU solid with circles, each GPU row its own dash and marker,
/// so that one colour (the case) compares the backends.
#[derive(Clone, Copy)]
enum Look {
    Circle,
    Triangle,
    HollowCircle,
    HollowTriangle,
}

const LOOKS: [Look; 4] = [Look::Circle, Look::Triangle, Look::HollowCircle, Look::HollowTriangle];

impl Look {
    /// The marker at `p` (data or pixel coordinates).
    fn marker<DB: DrawingBackend, C: Clone + 'static>(self, p: C, color: RGBColor) -> DynElement<'static, DB, C> {
        match self {
            Look::Circle => Circle::new(p, 3, color.filled()).into_dyn(),
            Look::Triangle => TriangleMarker::new(p, 5, color.filled()).into_dyn(),
            Look::HollowCircle => Circle::new(p, 4, color.stroke_width(2)).into_dyn(),
            Look::HollowTriangle => TriangleMarker::new(p, 7, color.stroke_width(1)).into_dyn(),
        }
    }

    /// Dash length and gap in pixels (None: a solid line).
    fn dash(self) -> Option<(u32, u32)> {
        match self {
            Look::Circle => None,
            Look::Triangle => Some((8, 5)),
            Look::HollowCircle => Some((3, 4)),
            Look::HollowTriangle => Some((12, 4)),
        }
    }
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
    let (cases, backends, lines) = series(suite);
    // The panel with the legend reaches above the failure line far enough that the legend's
    // box (upper left) covers no point: it covered the failures' crosses at 1e3.
    let top = if legend {
        let plot_px = area.dim_in_pixel().1 as f64 - (2.0 * 12.0 + 40.0 + 30.0);
        FAILED_AT * 3.0 * legend_headroom(2 + cases.len() + backends.len(), plot_px)
    } else {
        FAILED_AT * 3.0
    };
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((x0..x1).log_scale(), (FLOOR / 2.0..top).log_scale())
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
    chart
        .draw_series(LineSeries::new(vec![(x0, 1.0), (x1, 1.0)], BLACK.stroke_width(1)))
        .map_err(|x| e(&x))?
        .label("tolerance")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
    chart
        .draw_series(LineSeries::new(vec![(x0, FAILED_AT), (x1, FAILED_AT)], RED.mix(0.4).stroke_width(1)))
        .map_err(|x| e(&x))?
        .label("numerical failure (x)")
        .legend(|(x, y)| Cross::new((x + 9, y), 5, RED.stroke_width(2)));
    for line in &lines {
        let color = PALETTE[line.case % PALETTE.len()];
        let look = LOOKS[line.backend % LOOKS.len()];
        let rows = &line.rows;
        let ok: Vec<(f64, f64)> = rows.iter().filter_map(|r| normalized(r).map(|y| (x_of(r), y))).filter(|(x, _)| x.is_finite() && *x > 0.0).collect();
        let style = color.stroke_width(2);
        match look.dash() {
            None => chart.draw_series(LineSeries::new(ok.clone(), style)).map(|_| ()),
            Some((dash, gap)) => chart.draw_series(DashedLineSeries::new(ok.clone(), dash, gap, style)).map(|_| ()),
        }
        .map_err(|x| e(&x))?;
        chart.draw_series(ok.iter().map(|&p| look.marker(p, color))).map_err(|x| e(&x))?;
        // The check FRACTION gets a ring, the numerical failures a cross on the failure line.
        chart
            .draw_series(
                rows.iter()
                    .filter(|r| (r.frac - CHECK_FRAC).abs() < 1e-12)
                    .filter_map(|r| normalized(r).map(|y| Circle::new((x_of(r), y), 8, color.stroke_width(1)))),
            )
            .map_err(|x| e(&x))?;
        chart
            .draw_series(rows.iter().filter(|r| r.error.is_none()).map(|r| Cross::new((x_of(r).max(x0 * 1.01), FAILED_AT), 6, color.stroke_width(2))))
            .map_err(|x| e(&x))?;
    }
    // The legend: a colour per case, a line style and marker per backend (precision included).
    for (i, case) in cases.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(|x| e(&x))?
            .label(*case)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3)));
    }
    for (i, backend) in backends.iter().enumerate() {
        let look = LOOKS[i % LOOKS.len()];
        let grey = RGBColor(60, 60, 60);
        chart.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>()).map_err(|x| e(&x))?.label(backend.as_str()).legend(move |(x, y)| {
            let line: DynElement<_, (i32, i32)> = match look.dash() {
                None => PathElement::new(vec![(x, y), (x + 18, y)], grey.stroke_width(2)).into_dyn(),
                Some((dash, gap)) => {
                    plotters::element::DashedPathElement::new(vec![(x, y), (x + 18, y)], dash as i32 / 2, gap as i32 / 2, grey.stroke_width(2)).into_dyn()
                }
            };
            EmptyElement::at((0, 0)) + line + look.marker((x + 9, y), grey)
        });
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
    chart_png(path, (1500, 650), |root| {
        let (left, right) = root.split_horizontally(750);
        draw_panel(&left, suite, "Accuracy against wall time (FRAC sweep)", "wall time of the run [s]", &|r| r.cost.wall_s, true)?;
        draw_panel(&right, suite, "Accuracy against speed", "cycles per second", &|r| r.cost.cycles_per_s(), false)
    })
}

/// Error against FRACTION, log axes: where the error grows and where runs fail.
pub fn error_vs_frac(suite: &Suite, path: &Path) -> Result<PathBuf, String> {
    chart_png(path, (900, 650), |root| {
        draw_panel(root, suite, "Error against FRACTION (ring: the default 0.1)", "FRACTION of the UDEC time step", &|r| r.frac, true)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The band the headroom adds above the failure line holds the legend's pixels.
    #[test]
    fn the_legend_fits_above_the_failures() {
        for (entries, plot_px) in [(10, 550.0), (16, 550.0), (5, 300.0)] {
            let h = legend_headroom(entries, plot_px);
            let (lo, top) = ((FLOOR / 2.0).log10(), (FAILED_AT * 3.0 * h).log10());
            let band_px = plot_px * h.log10() / (top - lo);
            assert!(band_px + 1e-6 >= entries as f64 * LEGEND_ENTRY_PX + LEGEND_MARGIN_PX, "{entries} entries, {plot_px} px: band {band_px}");
        }
    }
}
