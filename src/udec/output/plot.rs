//! PLOT: the block outlines on the 1985 plotter page, written as PNG (tiny-skia) and SVG.
//!
//! The page is the plotter's 2000 × 1400 units (Appendix A, VIEW defaults), drawn at 0.5 pixel per
//! unit: a 1000 × 700 image on white. WINDOW (problem units) is mapped onto the VIEW rectangle of
//! the page with equal scales in x and y, centred in the view, and everything is clipped to the
//! view, so four VIEW quadrants give four plots on one page as in sample problem 4.
//!
//! The drawing is built once as a `Scene` of polylines and labels in pixel coordinates, and the
//! PNG and SVG writers only render that scene: both files always show the same picture. Each
//! plot says what it is: a caption (the deck, the cycle and the time), axes along the view's
//! bottom and left edges with their values in metres, and with velocities the scale of the
//! arrows. The PNG's text needs a font (`output::font`); without one the PNG is drawn without
//! text and the SVG still carries it.

use std::fmt::Write as _;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use tiny_skia::{FillRule, Mask, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};

use super::format::fmt_e;
use crate::udec::deck::PlotOptions;
use crate::udec::model::geometry::{add, norm, scale, sub, unit};
use crate::udec::model::Model;

/// Plotter page size in plotter units (VIEW defaults ix2 = 2000, iy2 = 1400).
pub const PAGE_UNITS: [f64; 2] = [2000.0, 1400.0];
/// Pixels per plotter unit.
pub const PX_PER_UNIT: f64 = 0.5;
/// Image size in pixels.
pub const IMAGE_SIZE: [u32; 2] = [1000, 700];

/// Largest angle one straight segment of a tessellated corner arc may span (5°): at 1000 px a
/// rounding arc is at most a few tens of pixels, so the chords are invisible.
const ARC_STEP: f64 = std::f64::consts::PI / 36.0;
/// Shortest chord a plotted arc is cut into, pixels: an arc a few pixels long needs no 5° steps,
/// and the rounding of a block far smaller than a pixel (a whole 10⁶-block wall on one page) is
/// drawn as its two tangent points.
const MIN_CHORD_PX: f64 = 1.0;
/// Pixels beyond the VIEW within which a shape still counts as visible: half the 1-pixel stroke
/// and its anti-aliased fringe.
const CULL_MARGIN_PX: f64 = 2.0;
/// Half-length of the centroid cross, pixels.
const CROSS_PX: f64 = 4.0;
/// The largest velocity arrow is this fraction of the window width.
const ARROW_FRACTION: f64 = 0.05;
/// Text sizes, pixels: the caption, the axes' values and titles, the arrows' scale.
const CAPTION_PX: f64 = 13.0;
const LABEL_PX: f64 = 11.0;
/// Length of an axis tick, pixels.
const TICK_PX: f64 = 6.0;
/// About this many ticks along an axis (the step is 1, 2 or 5 times a power of ten).
const TICKS: f64 = 6.0;
/// Axes and their text.
const AXIS_GREY: Rgb = [90, 90, 90];

/// WINDOW and VIEW, the plot state that SAVE keeps with the model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlotSettings {
    /// WINDOW x1 x2 y1 y2: the model region plotted, problem units (default 0 10 0 7).
    pub window: [f64; 4],
    /// VIEW ix1 ix2 iy1 iy2: where on the page, plotter units (default 0 2000 0 1400).
    pub view: [i64; 4],
}

impl Default for PlotSettings {
    fn default() -> Self {
        PlotSettings { window: [0.0, 10.0, 0.0, 7.0], view: [0, 2000, 0, 1400] }
    }
}

/// The mapping problem units → pixels for one plot.
#[derive(Clone, Copy, Debug)]
struct Viewport {
    /// Pixels per problem unit, equal in x and y.
    scale: f64,
    /// Pixel position of problem point (0, 0).
    origin: [f64; 2],
    /// The VIEW rectangle in pixels: left, top, right, bottom.
    clip: [f64; 4],
}

impl Viewport {
    fn new(settings: &PlotSettings) -> io::Result<Self> {
        let [x1, x2, y1, y2] = settings.window;
        let [ix1, ix2, iy1, iy2] = settings.view.map(|v| v as f64);
        let (ww, wh) = (x2 - x1, y2 - y1);
        let (vw, vh) = (ix2 - ix1, iy2 - iy1);
        if !(ww > 0.0 && wh > 0.0 && ww.is_finite() && wh.is_finite()) {
            return Err(invalid(format!("WINDOW {x1} {x2} {y1} {y2} is empty: need x1 < x2 and y1 < y2")));
        }
        if !(vw > 0.0 && vh > 0.0) {
            return Err(invalid(format!("VIEW {ix1} {ix2} {iy1} {iy2} is empty: need ix1 < ix2 and iy1 < iy2")));
        }
        // Plotter units per problem unit: the window fits the view in its tighter direction and
        // is centred in the other.
        let s = (vw / ww).min(vh / wh);
        let ux0 = ix1 + 0.5 * (vw - s * ww) - s * x1;
        let uy0 = iy1 + 0.5 * (vh - s * wh) - s * y1;
        // Plotter y grows upward, image y downward.
        Ok(Viewport {
            scale: s * PX_PER_UNIT,
            origin: [ux0 * PX_PER_UNIT, (PAGE_UNITS[1] - uy0) * PX_PER_UNIT],
            clip: [ix1 * PX_PER_UNIT, (PAGE_UNITS[1] - iy2) * PX_PER_UNIT, ix2 * PX_PER_UNIT, (PAGE_UNITS[1] - iy1) * PX_PER_UNIT],
        })
    }

    fn to_px(self, p: [f64; 2]) -> [f64; 2] {
        [self.origin[0] + self.scale * p[0], self.origin[1] - self.scale * p[1]]
    }

    /// Whether a shape within the pixel box `lo`..`hi` can show in the VIEW (everything is
    /// clipped to it, so a shape wholly outside draws nothing and is left out of both files).
    /// False for a box with a non-finite side.
    fn shows(self, [lo, hi]: [[f64; 2]; 2]) -> bool {
        let [l, t, r, b] = self.clip;
        let m = CULL_MARGIN_PX;
        lo[0] <= r + m && hi[0] >= l - m && lo[1] <= b + m && hi[1] >= t - m
    }

    /// The pixel box of the world box `lo`..`hi` (image y runs down).
    fn box_to_px(self, [lo, hi]: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
        let (a, b) = (self.to_px([lo[0], hi[1]]), self.to_px([hi[0], lo[1]]));
        [a, b]
    }
}

/// The box around `points`: [lower, upper] corners (NaN sides if a point is not finite).
fn bounding_box<'a>(points: impl IntoIterator<Item = &'a [f64; 2]>) -> [[f64; 2]; 2] {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points {
        for i in 0..2 {
            if !p[i].is_finite() {
                return [[f64::NAN; 2]; 2];
            }
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    [lo, hi]
}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

/// The outline of block `b` in world coordinates, counter-clockwise, as a closed polygon (the
/// first point is not repeated).
///
/// With `rounded`, each corner is replaced by the arc of its rounding circle between its two
/// tangent points, the points at distance `round` from the corner along its two edges (DESIGN.md
/// §4), tessellated into chords of at most 5°; straight edges join the arcs. A corner with no
/// rounding (re-entrant, `radius` or `round` zero) stays a sharp point. Without `rounded` the
/// outline is the sharp polygon of the corner positions.
///
/// This is the one tessellation both the PNG and the SVG use.
pub fn block_outline(model: &Model, b: usize, rounded: bool) -> Vec<[f64; 2]> {
    outline(model, b, rounded, 0.0)
}

/// [`block_outline`] with no arc chord shorter than `min_chord` (world units) where 5° steps
/// would make them shorter: what a plot at a given scale needs.
fn outline(model: &Model, b: usize, rounded: bool, min_chord: f64) -> Vec<[f64; 2]> {
    let blk = &model.blocks[b];
    let start = blk.corner_start as usize;
    let corners = model.corners.get(start..start + blk.corner_count as usize).unwrap_or(&[]);
    let n = corners.len();
    if !rounded || n < 3 {
        return corners.iter().map(|c| c.position).collect();
    }
    let mut out = Vec::with_capacity(n * 8);
    for k in 0..n {
        let c = &corners[k];
        let prev = corners[(k + n - 1) % n].position;
        let next = corners[(k + 1) % n].position;
        let p = c.position;
        let (Some(u_in), Some(u_out)) = (unit(sub(prev, p)), unit(sub(next, p))) else {
            out.push(p);
            continue;
        };
        // A rounding shorter than half a chord (half a pixel, in a plot) is drawn sharp: its two
        // tangent points would land within a pixel of the corner.
        if !(c.round > 0.0 && c.radius > 0.0 && c.round >= 0.5 * min_chord) {
            out.push(p);
            continue;
        }
        let t_in = add(p, scale(u_in, c.round));
        let t_out = add(p, scale(u_out, c.round));
        arc(c.circle, t_in, t_out, min_chord, &mut out);
    }
    out
}

/// Appends the arc about `centre` from `a` to `b` (both included), the short way round. A
/// rounding arc always subtends less than π (it is π minus the interior angle of a convex
/// corner), so the short way is the right one. The radius is interpolated between the two end
/// distances so the ends land exactly on the tangent points even if the stored circle is off by
/// rounding error. Steps of at most 5°, fewer where they would be shorter than `min_chord`.
fn arc(centre: [f64; 2], a: [f64; 2], b: [f64; 2], min_chord: f64, out: &mut Vec<[f64; 2]>) {
    let (da, db) = (sub(a, centre), sub(b, centre));
    let (ra, rb) = (norm(da), norm(db));
    let a0 = da[1].atan2(da[0]);
    let mut sweep = db[1].atan2(db[0]) - a0;
    if sweep > std::f64::consts::PI {
        sweep -= std::f64::consts::TAU;
    } else if sweep < -std::f64::consts::PI {
        sweep += std::f64::consts::TAU;
    }
    let mut steps = ((sweep.abs() / ARC_STEP).ceil() as usize).max(1);
    if min_chord > 0.0 {
        let length = sweep.abs() * ra.max(rb);
        steps = steps.min((length / min_chord).floor() as usize).max(1);
    }
    out.push(a);
    for i in 1..steps {
        let f = i as f64 / steps as f64;
        let (r, t) = (ra + f * (rb - ra), a0 + f * sweep);
        out.push([centre[0] + r * t.cos(), centre[1] + r * t.sin()]);
    }
    out.push(b);
}

/// An RGB colour.
type Rgb = [u8; 3];
const BLACK: Rgb = [0, 0, 0];
/// Fill of fixed blocks.
const FIXED_GREY: Rgb = [200, 200, 200];
/// Velocity arrows.
const ARROW_BLUE: Rgb = [0, 70, 200];
/// Zone sides (PLOT ZONES).
const ZONE_GREY: Rgb = [110, 110, 110];

/// A zone's fill for its mean stress relative to the largest shown, `r` in −1..1: white at 0,
/// towards blue in compression and red in tension.
fn stress_colour(r: f64) -> Rgb {
    let r = if r.is_finite() { r.clamp(-1.0, 1.0) } else { 0.0 };
    let fade = |x: f64| (255.0 * (1.0 - 0.75 * x)).round() as u8;
    if r < 0.0 {
        [fade(-r), fade(-r), 255]
    } else {
        [255, fade(r), fade(r)]
    }
}

/// What a shape is, for the SVG's `class` attribute.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ShapeKind {
    Block(u32),
    /// A zone of a fully-deformable block (the block's id).
    Zone(u32),
    /// A domain filled by its pressure (PLOT PRESSURE; the domain's id).
    Domain(u32),
    Centroid,
    Velocity,
    Axis,
    Scale,
}

/// Which end of a label its position is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Anchor {
    Start,
    Middle,
    End,
}

/// A line of text, pixels: `at` is the baseline's start, middle or end (`anchor`).
struct Label {
    at: [f64; 2],
    text: String,
    size: f64,
    anchor: Anchor,
    colour: Rgb,
}

/// One polyline in pixel coordinates.
struct Shape {
    kind: ShapeKind,
    points: Vec<[f64; 2]>,
    closed: bool,
    fill: Option<Rgb>,
    stroke: Rgb,
}

/// Everything one plot draws, in pixels.
struct Scene {
    /// The VIEW rectangle: left, top, right, bottom.
    clip: [f64; 4],
    shapes: Vec<Shape>,
    /// The caption first, then the axes' and the scale's text.
    labels: Vec<Label>,
}

/// The tick step for a span of `range`: 1, 2 or 5 times a power of ten, about `TICKS` a span.
fn tick_step(range: f64) -> f64 {
    let raw = range / TICKS;
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * mag).find(|&s| s >= raw * (1.0 - 1e-9)).unwrap_or(10.0 * mag)
}

/// A tick's value as the axis writes it: the step's decimals (0.25 with a step of 0.05), and an
/// exponent where the values are very large or very small.
fn tick_text(v: f64, step: f64) -> String {
    let v = if v.abs() < 1e-9 * step { 0.0 } else { v };
    if !(1e-3..1e5).contains(&step) {
        return format!("{v:.1E}");
    }
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// The axes along the view's bottom and left edges: ticks inward at round values of the
/// problem's coordinates, their values, and the axes' names with the unit.
fn axes(vp: &Viewport, shapes: &mut Vec<Shape>, labels: &mut Vec<Label>) {
    let [l, t, r, b] = vp.clip;
    let world_x = |px: f64| (px - vp.origin[0]) / vp.scale;
    let world_y = |py: f64| (vp.origin[1] - py) / vp.scale;
    let label = |at, text, anchor| Label { at, text, size: LABEL_PX, anchor, colour: AXIS_GREY };
    let tick = |points| Shape { kind: ShapeKind::Axis, points, closed: false, fill: None, stroke: AXIS_GREY };
    // Values near the view's corners are left out (they would run into the other axis or the
    // caption); so are ticks of a view too small to hold them.
    let margin = 4.0 * LABEL_PX;
    if r - l > 3.0 * margin {
        let (x0, x1) = (world_x(l), world_x(r));
        let step = tick_step(x1 - x0);
        let mut k = (x0 / step).ceil();
        while k * step <= x1 {
            let px = vp.to_px([k * step, 0.0])[0];
            if px > l + margin && px < r - margin {
                shapes.push(tick(vec![[px, b], [px, b - TICK_PX]]));
                labels.push(label([px, b - TICK_PX - 3.0], tick_text(k * step, step), Anchor::Middle));
            }
            k += 1.0;
        }
        labels.push(label([r - 6.0, b - TICK_PX - 3.0 - 1.4 * LABEL_PX], "x (m)".into(), Anchor::End));
    }
    if b - t > 3.0 * margin {
        let (y0, y1) = (world_y(b), world_y(t));
        let step = tick_step(y1 - y0);
        let mut k = (y0 / step).ceil();
        while k * step <= y1 {
            let py = vp.to_px([0.0, k * step])[1];
            if py > t + margin && py < b - margin {
                shapes.push(tick(vec![[l, py], [l + TICK_PX, py]]));
                labels.push(label([l + TICK_PX + 3.0, py + 0.35 * LABEL_PX], tick_text(k * step, step), Anchor::Start));
            }
            k += 1.0;
        }
        labels.push(label([l + TICK_PX + 3.0, t + 6.0 + CAPTION_PX + 1.4 * LABEL_PX], "y (m)".into(), Anchor::Start));
    }
}

/// The speed under which a block is at rest to round-off, m/s: a millionth of the speed of a
/// fall through the window's width, √(|g| w), plus a block that moves 10⁻¹² of the window a
/// step. A stack at rest carries velocities of 1e-13 m/s from the round-off of its contact
/// forces; scaled to the largest of them, they were drawn as full-length arrows.
fn rest_speed(model: &Model, window_width: f64) -> f64 {
    let g = norm(model.gravity);
    let per_step = if model.timestep > 0.0 { 1e-12 * window_width / model.timestep } else { 0.0 };
    1e-6 * (g * window_width).sqrt() + per_step
}

fn build_scene(model: &Model, settings: &PlotSettings, options: &PlotOptions, title: &str) -> io::Result<Scene> {
    let vp = Viewport::new(settings)?;
    let shown: Vec<usize> = (0..model.blocks.len()).filter(|&b| !(options.nofix && model.blocks[b].fixed)).collect();
    let mut shapes = Vec::new();
    // Only what shows in the VIEW is drawn: a plot of a 10x7 m window of a 10⁶-block wall draws
    // a few hundred blocks, not a million clipped away. A block's rounded outline lies within
    // the box of its corners.
    let block_shows = |b: usize| {
        let blk = &model.blocks[b];
        let start = blk.corner_start as usize;
        let corners = model.corners.get(start..start + blk.corner_count as usize).unwrap_or(&[]);
        vp.shows(vp.box_to_px(bounding_box(corners.iter().map(|c| &c.position))))
    };
    let min_chord = MIN_CHORD_PX / vp.scale;

    // PLOT ZONES: the zones of fully-deformable blocks, filled by their mean stress
    // ½(σ11 + σ22) (blue compression, red tension, white zero, against the largest shown), under
    // the outlines.
    if options.zones {
        let zoned: Vec<usize> = shown.iter().copied().filter(|&b| block_shows(b) && model.fdef_of(b).is_some_and(|f| !f.zones.is_empty())).collect();
        let mean = |z: &crate::udec::model::fdef::Zone| 0.5 * (z.stress[0] + z.stress[2]);
        let largest = zoned.iter().flat_map(|&b| model.fdef[b].zones.iter().map(mean)).filter(|x| x.is_finite()).fold(0.0f64, |a, x| a.max(x.abs()));
        for &b in &zoned {
            let f = &model.fdef[b];
            for (z, zone) in f.zones.iter().enumerate() {
                let points: Vec<[f64; 2]> = f.zone_points(z).iter().map(|&p| vp.to_px(p)).collect();
                let fill = stress_colour(if largest > 0.0 { mean(zone) / largest } else { 0.0 });
                shapes.push(Shape { kind: ShapeKind::Zone(model.blocks[b].id), points, closed: true, fill: Some(fill), stroke: ZONE_GREY });
            }
        }
    }
    // PLOT PRESSURE: each domain's void (its first loop, with the current positions) filled by
    // its pore pressure against the largest shown (white 0, red the largest, blue suction),
    // under the outlines.
    let mut pressure_scale = None;
    if let (true, Some(domains)) = (options.pressure, model.domains.as_ref()) {
        use crate::udec::model::domain::DomainKind;
        let voids: Vec<(u32, f64, Vec<[f64; 2]>)> = (0..domains.list.len())
            .filter(|&d| domains.list[d].kind != DomainKind::Outer)
            .filter_map(|d| {
                let first = crate::udec::model::fluid::domain_loops(model, domains, d).into_iter().next()?;
                let points: Vec<[f64; 2]> = first.into_iter().map(|(p, _)| vp.to_px(p)).collect();
                (points.len() >= 3 && vp.shows(bounding_box(&points))).then(|| (domains.list[d].id, domains.list[d].pressure, points))
            })
            .collect();
        let largest = voids.iter().map(|v| v.1.abs()).filter(|x| x.is_finite()).fold(0.0f64, f64::max);
        for (id, p, points) in voids {
            let fill = stress_colour(if largest > 0.0 { p / largest } else { 0.0 });
            shapes.push(Shape { kind: ShapeKind::Domain(id), points, closed: true, fill: Some(fill), stroke: fill });
        }
        pressure_scale = Some(largest);
    }
    // Outlines first so that crosses and arrows are drawn over the grey of fixed blocks.
    for &b in shown.iter().filter(|&&b| block_shows(b)) {
        let blk = &model.blocks[b];
        let points: Vec<[f64; 2]> = outline(model, b, !options.no_rounding, min_chord).into_iter().map(|p| vp.to_px(p)).collect();
        if points.len() >= 2 && vp.shows(bounding_box(&points)) {
            let fill = blk.fixed.then_some(FIXED_GREY);
            shapes.push(Shape { kind: ShapeKind::Block(blk.id), points, closed: true, fill, stroke: BLACK });
        }
    }
    for &b in &shown {
        let [cx, cy] = vp.to_px(model.blocks[b].centroid);
        if !vp.shows([[cx - CROSS_PX, cy - CROSS_PX], [cx + CROSS_PX, cy + CROSS_PX]]) {
            continue;
        }
        for (dx, dy) in [(CROSS_PX, 0.0), (0.0, CROSS_PX)] {
            let points = vec![[cx - dx, cy - dy], [cx + dx, cy + dy]];
            shapes.push(Shape { kind: ShapeKind::Centroid, points, closed: false, fill: None, stroke: BLACK });
        }
    }
    let [l, t, r, b] = vp.clip;
    let mut labels = vec![Label {
        at: [l + 6.0, t + 6.0 + CAPTION_PX],
        text: format!("{title}   CYCLE {}   TIME {} s", model.cycle, fmt_e(model.time)),
        size: CAPTION_PX,
        anchor: Anchor::Start,
        colour: BLACK,
    }];
    axes(&vp, &mut shapes, &mut labels);
    if let Some(largest) = pressure_scale {
        let text = format!("PORE PRESSURE: WHITE 0, RED {} Pa", fmt_e(largest));
        labels.push(Label { at: [l + 6.0, t + 6.0 + CAPTION_PX + 3.0 * LABEL_PX], text, size: LABEL_PX, anchor: Anchor::Start, colour: BLACK });
    }
    if options.velocities {
        // Arrows scaled so the fastest block's arrow is 5% of the window width; none for a
        // block at rest to round-off.
        let width = settings.window[1] - settings.window[0];
        let rest = rest_speed(model, width);
        let speed = |b: usize| norm(model.blocks[b].velocity);
        let vmax = shown.iter().map(|&b| speed(b)).filter(|v| v.is_finite()).fold(0.0, f64::max);
        let scale_at = [r - 8.0, b - TICK_PX - 3.0 - 3.2 * LABEL_PX];
        if vmax > rest {
            let k = ARROW_FRACTION * width / vmax;
            for &b in &shown {
                let blk = &model.blocks[b];
                if !(speed(b) > rest && speed(b).is_finite()) {
                    continue;
                }
                let tail = vp.to_px(blk.centroid);
                let head = vp.to_px(add(blk.centroid, scale(blk.velocity, k)));
                shapes.extend(arrow(tail, head).into_iter().filter(|a| vp.shows(bounding_box(&a.points))));
            }
            // The scale: the fastest block's arrow, with its speed.
            let length = ARROW_FRACTION * width * vp.scale;
            let head = [scale_at[0], scale_at[1] + 0.5 * LABEL_PX];
            let tail = [head[0] - length, head[1]];
            shapes.extend(arrow(tail, head).into_iter().map(|a| Shape { kind: ShapeKind::Scale, ..a }));
            let text = format!("{} m/s", fmt_e(vmax));
            labels.push(Label { at: [tail[0] - 6.0, head[1] + 0.35 * LABEL_PX], text, size: LABEL_PX, anchor: Anchor::End, colour: ARROW_BLUE });
        } else {
            let text = format!("VELOCITIES AT REST TO ROUND-OFF (LARGEST {} m/s)", fmt_e(vmax));
            labels.push(Label { at: scale_at, text, size: LABEL_PX, anchor: Anchor::End, colour: ARROW_BLUE });
        }
    }
    Ok(Scene { clip: vp.clip, shapes, labels })
}

/// An arrow from `tail` to `head` (pixels): the shaft and a head of two 30° barbs.
fn arrow(tail: [f64; 2], head: [f64; 2]) -> Vec<Shape> {
    let d = sub(head, tail);
    let l = norm(d);
    let mut shapes = vec![Shape { kind: ShapeKind::Velocity, points: vec![tail, head], closed: false, fill: None, stroke: ARROW_BLUE }];
    if let Some(u) = unit(d) {
        let barb = (0.3 * l).min(6.0);
        let (c, s) = (std::f64::consts::FRAC_PI_6.cos(), std::f64::consts::FRAC_PI_6.sin());
        let back = scale(u, -barb);
        let left = add(head, [c * back[0] - s * back[1], s * back[0] + c * back[1]]);
        let right = add(head, [c * back[0] + s * back[1], -s * back[0] + c * back[1]]);
        shapes.push(Shape { kind: ShapeKind::Velocity, points: vec![left, head, right], closed: false, fill: None, stroke: ARROW_BLUE });
    }
    shapes
}

/// PLOT: writes `plot_NNN.png` and `plot_NNN.svg` (NNN = `number`, three digits) into `out_dir`
/// and returns their paths in that order.
///
/// Draws every block's outline (rounded unless `no_rounding`), fixed blocks shaded light grey
/// (left out entirely with `nofix`), a cross at each centroid, and with `velocities` an arrow at
/// each centroid moving faster than round-off, with the arrows' scale. Both files carry a
/// caption (`title`, usually the deck's name, the cycle and the time) and axes in metres (the
/// PNG's text where a font is found, `output::font`). With `zones` the zones of fully-deformable
/// blocks are drawn under the outlines, filled by their mean stress. An empty WINDOW or VIEW is an
/// `InvalidInput` error.
pub fn plot(model: &Model, settings: &PlotSettings, options: &PlotOptions, out_dir: &Path, number: usize, title: &str) -> io::Result<[PathBuf; 2]> {
    plot_noting_empty(model, settings, options, out_dir, number, title).map(|(files, _)| files)
}

/// [`plot`], and why the plot shows no block where it shows none (`shows_nothing`), from the one
/// scene both files are drawn from.
pub fn plot_noting_empty(
    model: &Model,
    settings: &PlotSettings,
    options: &PlotOptions,
    out_dir: &Path,
    number: usize,
    title: &str,
) -> io::Result<([PathBuf; 2], Option<String>)> {
    let scene = build_scene(model, settings, options, title)?;
    let empty = shows_nothing(&scene, model, settings, options);
    let png = out_dir.join(format!("plot_{number:03}.png"));
    let svg = out_dir.join(format!("plot_{number:03}.svg"));
    let pixmap = render_png(&scene)?;
    let bytes = pixmap.encode_png().map_err(|e| io::Error::other(format!("PNG encoding failed: {e}")))?;
    fs::write(&png, bytes)?;
    let mut w = io::BufWriter::new(fs::File::create(&svg)?);
    render_svg(&scene, &mut w)?;
    io::Write::flush(&mut w)?;
    Ok(([png, svg], empty))
}

/// Why a PLOT with these settings shows no block, or None when one shows: its VIEW lies off the
/// page, or no block lies in its WINDOW (as fitted into the VIEW). PLOT warns with it (issue 27
/// item 5), since an empty page is otherwise written without a word.
fn shows_nothing(scene: &Scene, model: &Model, settings: &PlotSettings, options: &PlotOptions) -> Option<String> {
    let [l, t, r, b] = scene.clip;
    let [w, h] = IMAGE_SIZE.map(f64::from);
    let [x1, x2, y1, y2] = settings.window.map(fmt_e);
    let [ix1, ix2, iy1, iy2] = settings.view;
    if r <= 0.0 || b <= 0.0 || l >= w || t >= h {
        Some(format!("VIEW {ix1} {ix2} {iy1} {iy2} lies off the page (0 to {} by 0 to {})", PAGE_UNITS[0], PAGE_UNITS[1]))
    } else if model.blocks.is_empty() {
        Some("there are no blocks".into())
    } else if !scene.shapes.iter().any(|s| matches!(s.kind, ShapeKind::Block(_))) {
        let hidden = if options.nofix { " (NOFIX hides the fixed ones)" } else { "" };
        Some(format!("none lies in WINDOW {x1} {x2} {y1} {y2}{hidden}"))
    } else {
        None
    }
}

fn render_png(scene: &Scene) -> io::Result<Pixmap> {
    let [w, h] = IMAGE_SIZE;
    let mut pixmap = Pixmap::new(w, h).expect("the page size is nonzero");
    pixmap.fill(tiny_skia::Color::WHITE);

    // Clip mask: the VIEW rectangle, hard-edged so nothing bleeds a half pixel outside it.
    let [l, t, r, b] = scene.clip.map(|v| v as f32);
    let mut mask = Mask::new(w, h).expect("the page size is nonzero");
    if let Some(rect) = Rect::from_ltrb(l.max(0.0), t.max(0.0), r.min(w as f32), b.min(h as f32)) {
        mask.fill_path(&PathBuilder::from_rect(rect), FillRule::Winding, false, Transform::identity());
    } else {
        return Ok(pixmap); // the view lies off the page: nothing is visible
    }

    let stroke = Stroke { width: 1.0, ..Stroke::default() };
    for shape in &scene.shapes {
        let Some(path) = tiny_path(&shape.points, shape.closed) else {
            continue;
        };
        if let Some(fill) = shape.fill {
            tiny_skia_fill(&mut pixmap, &path, fill, &mask);
        }
        let mut paint = Paint::default();
        paint.set_color_rgba8(shape.stroke[0], shape.stroke[1], shape.stroke[2], 255);
        paint.anti_alias = true;
        pixmap.stroke_path(&path, &paint, &stroke, Transform::identity(), Some(&mask));
    }
    if let Ok(bytes) = super::font::font_bytes() {
        if let Ok(font) = ab_glyph::FontRef::try_from_slice(bytes) {
            let clip = [l.max(0.0), t.max(0.0), r.min(w as f32), b.min(h as f32)].map(|v| v as f64);
            for label in &scene.labels {
                draw_text(&mut pixmap, &font, label, clip);
            }
        }
    }
    Ok(pixmap)
}

/// The width of `text` at `size` pixels.
fn text_width(font: &ab_glyph::FontRef, text: &str, size: f64) -> f64 {
    use ab_glyph::{Font, ScaleFont};
    let scaled = font.as_scaled(size as f32);
    let mut width = 0.0f32;
    let mut prev = None;
    for ch in text.chars() {
        let id = scaled.glyph_id(ch);
        if let Some(p) = prev {
            width += scaled.kern(p, id);
        }
        width += scaled.h_advance(id);
        prev = Some(id);
    }
    width as f64
}

/// Draws `label` into the pixmap (anti-aliased coverage blended over what is there), clipped to
/// `clip` (left, top, right, bottom) as the shapes are.
fn draw_text(pixmap: &mut Pixmap, font: &ab_glyph::FontRef, label: &Label, clip: [f64; 4]) {
    use ab_glyph::{Font, ScaleFont};
    let width = text_width(font, &label.text, label.size);
    let mut x = match label.anchor {
        Anchor::Start => label.at[0],
        Anchor::Middle => label.at[0] - 0.5 * width,
        Anchor::End => label.at[0] - width,
    } as f32;
    let scaled = font.as_scaled(label.size as f32);
    let (w, h) = (pixmap.width() as i64, pixmap.height() as i64);
    let [cl, ct, cr, cb] = clip;
    let colour = label.colour.map(f32::from);
    let pixels = pixmap.pixels_mut();
    let mut prev = None;
    for ch in label.text.chars() {
        let id = scaled.glyph_id(ch);
        if let Some(p) = prev {
            x += scaled.kern(p, id);
        }
        prev = Some(id);
        let glyph = id.with_scale_and_position(label.size as f32, ab_glyph::point(x, label.at[1] as f32));
        x += scaled.h_advance(id);
        let Some(outline) = font.outline_glyph(glyph) else { continue };
        let bounds = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let (px, py) = (bounds.min.x as i64 + gx as i64, bounds.min.y as i64 + gy as i64);
            let inside = (px as f64) >= cl && (px as f64) < cr && (py as f64) >= ct && (py as f64) < cb;
            if !(inside && px >= 0 && py >= 0 && px < w && py < h) {
                return;
            }
            let c = coverage.clamp(0.0, 1.0);
            let p = &mut pixels[(py * w + px) as usize];
            // The page is opaque, so its premultiplied colour is its colour.
            let mix = |old: u8, new: f32| (old as f32 * (1.0 - c) + new * c).round() as u8;
            let (r, g, b) = (mix(p.red(), colour[0]), mix(p.green(), colour[1]), mix(p.blue(), colour[2]));
            if let Some(v) = tiny_skia::PremultipliedColorU8::from_rgba(r, g, b, 255) {
                *p = v;
            }
        });
    }
}

fn tiny_skia_fill(pixmap: &mut Pixmap, path: &tiny_skia::Path, rgb: Rgb, mask: &Mask) {
    let mut paint = Paint::default();
    paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
    paint.anti_alias = true;
    pixmap.fill_path(path, &paint, FillRule::Winding, Transform::identity(), Some(mask));
}

fn tiny_path(points: &[[f64; 2]], closed: bool) -> Option<tiny_skia::Path> {
    let (first, rest) = points.split_first()?;
    let mut pb = PathBuilder::new();
    pb.move_to(first[0] as f32, first[1] as f32);
    rest.iter().for_each(|p| pb.line_to(p[0] as f32, p[1] as f32));
    if closed {
        pb.close();
    }
    pb.finish()
}

/// Writes the SVG of `scene` to `s` (streamed: a plot of many blocks is never one string).
fn render_svg(scene: &Scene, s: &mut impl io::Write) -> io::Result<()> {
    let [w, h] = IMAGE_SIZE;
    let [l, t, r, b] = scene.clip;
    writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">"#)?;
    writeln!(s, r#"<rect x="0" y="0" width="{w}" height="{h}" fill="white"/>"#)?;
    writeln!(s, r#"<defs><clipPath id="view"><rect x="{l:.2}" y="{t:.2}" width="{:.2}" height="{:.2}"/></clipPath></defs>"#, r - l, b - t)?;
    writeln!(s, r#"<g clip-path="url(#view)" stroke-width="1" stroke-linejoin="round">"#)?;
    for shape in &scene.shapes {
        let mut d = String::new();
        for (i, p) in shape.points.iter().enumerate() {
            let _ = write!(d, "{}{:.2},{:.2} ", if i == 0 { 'M' } else { 'L' }, p[0], p[1]);
        }
        if shape.closed {
            d.push('Z');
        }
        let class = match shape.kind {
            ShapeKind::Block(id) => format!(r#"class="block" data-id="{id}""#),
            ShapeKind::Zone(id) => format!(r#"class="zone" data-block="{id}""#),
            ShapeKind::Domain(id) => format!(r#"class="domain" data-domain="{id}""#),
            ShapeKind::Centroid => r#"class="centroid""#.to_string(),
            ShapeKind::Velocity => r#"class="velocity""#.to_string(),
            ShapeKind::Axis => r#"class="axis""#.to_string(),
            ShapeKind::Scale => r#"class="scale""#.to_string(),
        };
        let fill = shape.fill.map_or_else(|| "none".to_string(), hex);
        writeln!(s, r#"<path {class} d="{}" fill="{fill}" stroke="{}"/>"#, d.trim_end(), hex(shape.stroke))?;
    }
    // The caption, the axes' and the scale's text, inside the clip like everything else.
    for label in &scene.labels {
        let anchor = match label.anchor {
            Anchor::Start => "start",
            Anchor::Middle => "middle",
            Anchor::End => "end",
        };
        writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" font-family="DejaVu Sans, sans-serif" font-size="{}" text-anchor="{anchor}" fill="{}">{}</text>"#,
            label.at[0],
            label.at[1],
            label.size,
            hex(label.colour),
            xml_escape(&label.text)
        )?;
    }
    writeln!(s, "</g>")?;
    writeln!(s, "</svg>")
}

fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
