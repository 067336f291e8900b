//! `blockdem compare`: one deck on the f64 CPU reference and on a GPU backend, and how far the
//! GPU's final state lies from the reference's. For a user who checks the GPU against the CPU
//! on their own model (the test suite does it on its scenes, tests/suite/physics.rs): the largest
//! difference in block position (against the rounding length, the scale contacts resolve
//! overlaps on), rotation, velocity (against the top speed, or √(2E/M) for a model at rest) and
//! the energy terms (against the largest), each naming its block, with the wall times of the two
//! runs.
//!
//! A smooth scene (a settling stack, a sliding block) agrees to the kernel precision's round-off
//! over many cycles; a chaotic one (an impact scattering blocks) diverges at the first touch that
//! round-off tips the other way, as two CPU runs with a different FRACTION would: the comparison
//! then says how far, and the energy terms are the better guide.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::driver::run::{Progress, RunOptions};
use crate::udec::backend::Backend;
use crate::udec::deck::Located;
use crate::udec::exec::Executor;
use crate::udec::model::Model;

/// One backend's run of the deck (a 2D model, or D3's).
#[derive(Clone, Debug)]
pub struct Outcome<M = Model> {
    /// The backend as it describes itself.
    pub backend: String,
    /// Wall time of the whole deck (s).
    pub wall_s: f64,
    /// The final model (after a numerical failure: the last good state).
    pub model: M,
    /// The error that stopped the run, if any.
    pub error: Option<String>,
}

/// The largest difference of one quantity over the blocks, and the block (its id) it is at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Largest {
    /// The difference in the quantity's own unit.
    pub value: f64,
    /// The difference over the quantity's scale (see [`Comparison`]).
    pub relative: f64,
    /// The block it is at (0 when no block differs).
    pub block: u32,
}

impl Largest {
    /// Keeps `value` (over `scale`, at `block`) if it is the largest yet; a non-finite
    /// difference is the largest there is.
    fn offer(&mut self, value: f64, scale: f64, block: u32) {
        if value.is_nan() || value > self.value {
            *self = Largest { value, relative: value / scale, block };
        }
    }

    /// No block-by-block comparison (the runs end on different blocks).
    const NOT_COMPARED: Largest = Largest { value: f64::NAN, relative: f64::NAN, block: 0 };
}

/// The speed velocity differences are measured against: the reference's top speed, or for a
/// model come to rest (a top speed of round-off) the speed its largest energy term `energy`
/// would give its free mass, √(2E/M).
fn speed_scale(top: f64, free_mass: f64, energy: f64) -> f64 {
    let energy_speed = if free_mass > 0.0 { (2.0 * energy / free_mass).sqrt() } else { 0.0 };
    top.max(energy_speed).max(f64::MIN_POSITIVE)
}

/// The ledger's terms of the two runs, their differences and those over `scale` (the
/// reference's largest term).
fn compare_terms(a: &[(&'static str, f64)], b: &[(&'static str, f64)], scale: f64) -> Vec<(String, f64, f64)> {
    let scale = scale.max(f64::MIN_POSITIVE);
    a.iter().zip(b).map(|((name, x), (_, y))| (name.to_string(), (x - y).abs(), (x - y).abs() / scale)).collect()
}

/// The ledger's terms compared, from the kinetic, strain, external, dissipated (damping +
/// friction) and released energies, 2D and 3D alike.
fn ledger_terms(kinetic: f64, strain: f64, external_work: f64, dissipated: f64, released: f64) -> [(&'static str, f64); 5] {
    [("kinetic", kinetic), ("strain", strain), ("external work", external_work), ("dissipated", dissipated), ("released", released)]
}

/// The run log (`run.log`) in `out`, made if need be; a sink where it cannot be written.
fn run_log(out: &Path) -> Box<dyn std::io::Write> {
    let _ = std::fs::create_dir_all(out);
    match std::fs::File::create(out.join("run.log")) {
        Ok(f) => Box::new(std::io::BufWriter::new(f)),
        Err(_) => Box::new(std::io::sink()),
    }
}

/// Runs `run` (a whole deck), timing it, into the run's `Outcome`.
fn timed<M>(backend: String, run: impl FnOnce() -> (M, Result<(), String>)) -> Outcome<M> {
    let start = Instant::now();
    let (model, result) = run();
    Outcome { backend, wall_s: start.elapsed().as_secs_f64(), model, error: result.err() }
}

/// The GPU run against the CPU reference.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Comparison {
    /// Cycles each run reached (reference, GPU).
    pub cycles: [u64; 2],
    /// Whether both runs end on the same blocks (the same ids in the same order: the same cracks
    /// and deletions); blocks are compared one by one only then.
    pub same_blocks: bool,
    /// Blocks and contacts at the end (reference, GPU).
    pub blocks: [usize; 2],
    pub contacts: [usize; 2],
    /// Centroid distance (m), relative to the rounding length.
    pub position: Largest,
    /// Rotation difference (rad), relative to one radian.
    pub rotation: Largest,
    /// Velocity difference (m/s), relative to the largest speed of the reference, or where larger
    /// (a model come to rest) to √(2E/M), E the largest energy term and M the free blocks' mass.
    pub velocity: Largest,
    /// Internal stress of the simply-deformable blocks (Pa; the largest component difference),
    /// relative to the largest stress component of the reference; None without SDEF blocks.
    pub stress: Option<Largest>,
    /// Zone stresses of the fully-deformable blocks (Pa; the largest component difference),
    /// relative to the largest zone stress component of the reference, and grid-point positions
    /// (m, relative to the rounding length); None without zoned blocks.
    pub zone_stress: Option<Largest>,
    pub gridpoint: Option<Largest>,
    /// Kinetic, strain, external work, dissipated (damping + friction) and released energy:
    /// difference (J) and relative to the largest term of the reference.
    pub energy: Vec<(String, f64, f64)>,
    /// Wall time of the GPU run over the reference's.
    pub time_ratio: f64,
    /// The engine: 2 (UDEC) or 3 (D3).
    pub dim: u32,
}

/// Runs `commands` on `backend`, writing its outputs (plots, SAVE files) and its run log
/// (`run.log`) into `out`; long CYCLE commands say how far they are as `progress` sets.
pub fn run_on(backend: Box<dyn Backend>, commands: &[Located], file: &str, out: &Path, progress: Progress) -> Outcome {
    let description = backend.describe();
    let options = RunOptions { out_dir: out.to_path_buf(), progress, ..Default::default() };
    let mut exec = Executor::new(backend, run_log(out), options, file);
    timed(description, || {
        let result = exec.run(commands).map_err(|e| e.to_string());
        (std::mem::take(&mut exec.model), result)
    })
}

/// The GPU's final state against the reference's.
pub fn compare(reference: &Outcome, gpu: &Outcome) -> Comparison {
    let (a, b) = (&reference.model, &gpu.model);
    let mut c = Comparison {
        cycles: [a.cycle, b.cycle],
        blocks: [a.blocks.len(), b.blocks.len()],
        contacts: [a.contacts.len(), b.contacts.len()],
        time_ratio: gpu.wall_s / reference.wall_s.max(1e-9),
        dim: 2,
        ..Comparison::default()
    };
    c.same_blocks = a.blocks.len() == b.blocks.len() && a.blocks.iter().zip(&b.blocks).all(|(x, y)| x.id == y.id);
    if c.same_blocks {
        let round = a.tol.round.max(f64::MIN_POSITIVE);
        let top = a.blocks.iter().map(|x| x.velocity[0].hypot(x.velocity[1])).fold(0.0, f64::max);
        let free_mass: f64 = a.blocks.iter().filter(|x| !x.fixed).map(|x| x.mass).sum();
        let speed = speed_scale(top, free_mass, energy_scale(a));
        for (x, y) in a.blocks.iter().zip(&b.blocks) {
            c.position.offer((x.centroid[0] - y.centroid[0]).hypot(x.centroid[1] - y.centroid[1]), round, x.id);
            c.rotation.offer((x.rotation - y.rotation).abs(), 1.0, x.id);
            c.velocity.offer((x.velocity[0] - y.velocity[0]).hypot(x.velocity[1] - y.velocity[1]), speed, x.id);
        }
        if a.has_sdef() {
            let stresses = |m: &Model| (0..m.blocks.len()).map(|k| m.sdef_of(k).map_or([0.0; 3], |s| s.stress)).collect::<Vec<_>>();
            let (sa, sb) = (stresses(a), stresses(b));
            let top = sa.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs())).max(f64::MIN_POSITIVE);
            let mut l = Largest::default();
            for ((x, y), blk) in sa.iter().zip(&sb).zip(&a.blocks) {
                let d = x.iter().zip(y).fold(0.0f64, |m, (p, q)| if (p - q).is_nan() { f64::NAN } else { m.max((p - q).abs()) });
                l.offer(d, top, blk.id);
            }
            c.stress = Some(l);
        }
        if a.has_fdef() {
            (c.zone_stress, c.gridpoint) = compare_zones(a, b);
        }
    } else {
        // Not the same blocks: no block-by-block comparison.
        (c.position, c.rotation, c.velocity) = (Largest::NOT_COMPARED, Largest::NOT_COMPARED, Largest::NOT_COMPARED);
    }
    c.energy = compare_terms(&energy_terms(a), &energy_terms(b), energy_scale(a));
    c
}

/// The zoned blocks' zone stresses and grid-point positions, the GPU's against the reference's
/// (the block named is the zoned block with the largest difference); (None, None) when the two
/// do not hold the same zones.
fn compare_zones(a: &Model, b: &Model) -> (Option<Largest>, Option<Largest>) {
    fn zoned(m: &Model) -> Vec<(u32, &crate::udec::model::fdef::Fdef)> {
        (0..m.blocks.len()).filter_map(|k| m.fdef_of(k).map(|f| (m.blocks[k].id, f))).collect()
    }
    let (za, zb) = (zoned(a), zoned(b));
    let same =
        za.len() == zb.len() && za.iter().zip(&zb).all(|((i, f), (j, g))| i == j && f.zones.len() == g.zones.len() && f.gridpoints.len() == g.gridpoints.len());
    if !same {
        return (None, None);
    }
    let top = za.iter().flat_map(|(_, f)| f.zones.iter().flat_map(|z| z.stress)).fold(0.0f64, |m, v| m.max(v.abs())).max(f64::MIN_POSITIVE);
    let round = a.tol.round.max(f64::MIN_POSITIVE);
    let (mut stress, mut point) = (Largest::default(), Largest::default());
    for ((id, f), (_, g)) in za.iter().zip(&zb) {
        for (x, y) in f.zones.iter().zip(&g.zones) {
            let d = x.stress.iter().zip(y.stress).fold(0.0f64, |m, (p, q)| if (p - q).is_nan() { f64::NAN } else { m.max((p - q).abs()) });
            stress.offer(d, top, *id);
        }
        for (x, y) in f.gridpoints.iter().zip(&g.gridpoints) {
            point.offer((x.position[0] - y.position[0]).hypot(x.position[1] - y.position[1]), round, *id);
        }
    }
    (Some(stress), Some(point))
}

/// The energy ledger's terms that are compared.
fn energy_terms(model: &Model) -> [(&'static str, f64); 5] {
    let e = model.energies();
    ledger_terms(e.kinetic, e.strain, e.external_work, e.mass_damping + e.contact_damping + e.friction, e.released)
}

/// The largest term of the ledger (J).
fn energy_scale(model: &Model) -> f64 {
    energy_terms(model).iter().map(|(_, v)| v.abs()).fold(0.0, f64::max)
}

/// The comparison as a table.
pub fn table<M>(reference: &Outcome<M>, gpu: &Outcome<M>, c: &Comparison) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let outcome = |o: &Outcome<M>| o.error.as_deref().map_or_else(|| "ok".to_string(), |e| format!("stopped: {e}"));
    let _ = writeln!(s, "run                 backend                                                          wall (s)   cycles  blocks contacts  outcome");
    for (name, o, i) in [("reference (cpu)", reference, 0), ("gpu", gpu, 1)] {
        let _ = writeln!(
            s,
            "{name:<19} {:<64} {:>8.3} {:>8} {:>7} {:>8}  {}",
            truncate(&o.backend, 64),
            o.wall_s,
            c.cycles[i],
            c.blocks[i],
            c.contacts[i],
            outcome(o)
        );
    }
    let _ = writeln!(s, "gpu / cpu wall time: {:.2}x", c.time_ratio);
    let _ = writeln!(s);
    if c.same_blocks {
        // D3 measures positions against the contact-forming distance (it has no ROUND).
        let length = if c.dim == 3 { "of the contact distance" } else { "of ROUND" };
        let mut rows =
            vec![("position", c.position, "m", length), ("rotation", c.rotation, "rad", "rad"), ("velocity", c.velocity, "m/s", "of the speed scale")];
        rows.extend(c.stress.map(|l| ("stress (SDEF)", l, "Pa", "of the largest stress")));
        rows.extend(c.zone_stress.map(|l| ("zone stress (FDEF)", l, "Pa", "of the largest stress")));
        rows.extend(c.gridpoint.map(|l| ("grid point (FDEF)", l, "m", "of ROUND")));
        let rows: Vec<_> =
            rows.into_iter().map(|(name, l, unit, over)| (name, format!("{:.3e} {unit}", l.value), format!("{:.2e} {over}", l.relative), l.block)).collect();
        // Columns as wide as their widest cell, so that every row's block lines up.
        let wide = |cells: &mut dyn Iterator<Item = usize>, title: &str| cells.max().unwrap_or(0).max(title.len());
        let (vw, rw) = (wide(&mut rows.iter().map(|r| r.1.chars().count()), "value"), wide(&mut rows.iter().map(|r| r.2.chars().count()), "relative"));
        let _ = writeln!(s, "{:<20} {:<vw$} {:<rw$} block", "largest difference", "value", "relative");
        for (name, value, relative, block) in &rows {
            let _ = writeln!(s, "{name:<20} {value:<vw$} {relative:<rw$} {block}");
        }
    } else {
        let _ = writeln!(s, "the runs end on different blocks ({} and {}, or other ids): not compared block by block", c.blocks[0], c.blocks[1]);
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "energy               difference (J)  relative to the largest term");
    for (name, d, r) in &c.energy {
        let _ = writeln!(s, "{name:<20} {d:<15.3e} {r:.2e}");
    }
    s
}

fn truncate(text: &str, n: usize) -> String {
    if text.chars().count() <= n {
        text.to_string()
    } else {
        format!("{}…", text.chars().take(n - 1).collect::<String>())
    }
}

/// Runs D3's `commands` on `backend`, its run log (`run.log`) and outputs in `out`.
pub fn run_d3_on(
    backend: Box<dyn crate::d3::backend::Backend>,
    commands: &[crate::d3::deck::Located],
    file: &str,
    out: &Path,
    progress: Progress,
) -> Outcome<crate::d3::model::Model> {
    let description = backend.describe();
    let mut exec = crate::d3::exec::Executor::with_backend(run_log(out), file, backend);
    exec.set_options(RunOptions { out_dir: out.to_path_buf(), progress, ..Default::default() });
    timed(description, || {
        let result = exec.run(commands).map_err(|e| e.to_string());
        (std::mem::take(&mut exec.model), result)
    })
}

/// D3's GPU final state against the reference's: positions against the contact-forming
/// distance, rotations as the angle between the orientations, velocities against the top speed
/// (or √(2E/M) for a model at rest), the ledger's terms against the largest.
pub fn compare_d3(reference: &Outcome<crate::d3::model::Model>, gpu: &Outcome<crate::d3::model::Model>) -> Comparison {
    let (a, b) = (&reference.model, &gpu.model);
    let mut c = Comparison {
        cycles: [a.cycle, b.cycle],
        blocks: [a.blocks.len(), b.blocks.len()],
        contacts: [a.contacts.len(), b.contacts.len()],
        time_ratio: gpu.wall_s / reference.wall_s.max(1e-9),
        dim: 3,
        ..Comparison::default()
    };
    let terms = |m: &crate::d3::model::Model| {
        let e = m.energies();
        ledger_terms(e.kinetic, e.strain, e.external_work, e.mass_damping + e.contact_damping + e.friction, e.released)
    };
    let scale = terms(a).iter().map(|(_, v)| v.abs()).fold(0.0, f64::max);
    c.same_blocks = a.blocks.len() == b.blocks.len() && a.blocks.iter().zip(&b.blocks).all(|(x, y)| x.id == y.id);
    if c.same_blocks {
        let length = a.contact_tolerance().max(f64::MIN_POSITIVE);
        let top = a.blocks.iter().map(|x| x.velocity.length()).fold(0.0, f64::max);
        let free_mass: f64 = a.blocks.iter().filter(|x| !x.fixed).map(|x| x.mass).sum();
        let speed = speed_scale(top, free_mass, scale);
        for (x, y) in a.blocks.iter().zip(&b.blocks) {
            c.position.offer((x.centroid - y.centroid).length(), length, x.id);
            // The angle of the rotation from one orientation to the other, 2·atan2(|v|, |w|) of
            // q₁⁻¹q₂ (acos of a dot product loses angles below 1e-8 rad).
            let d = x.orientation.inverse() * y.orientation;
            c.rotation.offer(2.0 * d.xyz().length().atan2(d.w.abs()), 1.0, x.id);
            c.velocity.offer((x.velocity - y.velocity).length(), speed, x.id);
        }
    } else {
        (c.position, c.rotation, c.velocity) = (Largest::NOT_COMPARED, Largest::NOT_COMPARED, Largest::NOT_COMPARED);
    }
    c.energy = compare_terms(&terms(a), &terms(b), scale);
    c
}
