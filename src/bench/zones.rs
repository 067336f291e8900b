//! The zoned scene family (issue 29): fully-deformable blocks of 10³ zones upward on every
//! backend, in zone-cycles per second and as a share of the bandwidth roofline.
//!
//! - `block`: one large zoned block (10 × 10 m, K = 5e8, G = 3e8 Pa, density 2000) resting on a
//!   fixed base under gravity, its zones at most `amax` long so that it has about N zones: the
//!   zone stages' cost with few contacts.
//! - `wall`: the scaling family's wall ([`scene::scaling_body`]: 25 rows, the reference
//!   projectile at its left end) with every brick zoned (zones at most 0.35 m: about 22 a
//!   brick), bricks as soft as the SDEF scene's so that the zones' own step limit stays above the
//!   contacts': zones among many contacts and contact updates.
//!
//! Sizes are 10³, 10⁴ and 10⁵ zones (10³ with `--quick`); 10⁶ only when `--max-zones` asks for it
//! (its mesh takes minutes to generate on this machine's CPU).
//!
//! The roofline: the bytes a cycle of the zone stages moves by the byte model
//! [`zone_bytes_per_cycle`] (each kernel's loads and stores of the FDEF slots, a structure read
//! whole where the kernel reads most of it), over the cycle's time, over the backend's bandwidth
//! yardstick (`BackendInfo::bandwidth_bytes_per_s`). The rigid stages of the wall (its contacts)
//! are not counted: the ratio is the zones' share.

use std::time::Instant;

use super::{scene, BackendInfo, Engine};
use crate::udec::model::Model;

/// Nominal zone counts of the family.
pub const ZONE_SIZES: &[usize] = &[1_000, 10_000, 100_000, 1_000_000];

/// The largest size run unless `--max-zones` asks for more.
pub const DEFAULT_MAX_ZONES: usize = 100_000;

/// The bricks' and the large block's moduli (Pa), as the SDEF scene's.
const BULK: f64 = scene::SDEF_BULK;
const SHEAR: f64 = scene::SDEF_SHEAR;

/// One measurement: a scene of about `nominal` zones on one backend.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ZoneRow {
    pub scene: &'static str,
    pub backend: String,
    pub nominal: usize,
    pub zones: usize,
    pub gridpoints: usize,
    pub blocks: usize,
    pub contacts: usize,
    pub cycles: u64,
    pub s_per_cycle: f64,
    pub zone_cycles_per_s: f64,
    /// The byte model's bytes a cycle of the zone stages (`zone_bytes_per_cycle`).
    pub bytes_per_cycle: u64,
    pub bandwidth_bytes_per_s: f64,
    /// Achieved bytes per second of the zone stages over the bandwidth.
    pub roofline: f64,
    /// On a GPU: each kernel's time per cycle (pass timestamps over a short run after the
    /// measurement, `GpuBackend::profile_stages`), in dispatch order; how they were timed.
    pub kernels: Vec<(String, f64)>,
    pub device_timing: Option<String>,
    /// Contact updates in the timed run, and the shares of its cycles' time spent in CPU
    /// topology work and in host ↔ device transfers (as the scaling rows give them).
    pub updates: u64,
    pub topology_share: f64,
    pub transfer_share: f64,
    pub error: Option<String>,
}

/// The deck of one large zoned block of about `zones` zones on a fixed base, up to its CYCLE.
pub fn block_deck(zones: usize) -> String {
    // AUTO bisects the square's two right triangles (hypotenuse 10√2 m) until the longest side
    // is at most amax: 2·2ᵏ zones with 10√2/2^(k/2) ≤ amax, so this amax gives the least 2·2ᵏ of
    // at least `zones` (1024, 16384, 131072, 1048576 for the nominal sizes).
    let amax = 0.999 * 10.0 * std::f64::consts::SQRT_2 * (2.0 / zones as f64).sqrt();
    format!(
        "START\nPROP MAT=1 DENS=2000 K={BULK:e} G={SHEAR:e} KN=1E10 KS=1E10 F=0.5\nROUND 0.05\nBLOCK (-1,-1) (-1,0) (11,0) (11,-1)\n\
         BLOCK (0,0) (0,10) (10,10) (10,0)\nFIX -2 12 -2 -0.2\nCHANGE -0.5 10.5 0 10 FDEF\nGENERATE -0.5 10.5 0 10 AUTO {amax:.6}\nGRAV 0 -10\n"
    )
}

/// The deck of the scaling wall with about `zones` zones, every brick zoned, struck by the
/// projectile, up to its CYCLE.
pub fn wall_deck(zones: usize, frac: f64) -> String {
    // About 22 zones a brick, 25 rows.
    let wall = scene::scaling_wall(zones / 22, frac);
    let top = wall.rows as f64 * wall.brick[1];
    let right = wall.bricks as f64 * wall.brick[0];
    let body = scene::scaling_body(zones / 22, frac);
    format!("{body}PROP MAT=1 K={BULK:e} G={SHEAR:e}\nCHANGE -1 {r} 0 {t} FDEF\nGENERATE -1 {r} 0 {t} AUTO 0.35\n", r = right + 1.0, t = top + 1.0)
}

/// The bytes a cycle of the zone stages moves in precision `real` (4 or 8 bytes), by the kernels'
/// loads and stores (zones.wgsl; the placement of a zoned block's corners is counted with its
/// boundary): `gather_gridpoints` reads each grid point, its two CSR offsets, its entries and
/// for each entry the zone and its three corners' positions, and writes the force;
/// `step_gridpoints` reads the grid point and writes velocity, position pair, work and damping;
/// `zones` reads the zone, its block's constants and its corners' positions and velocities, and
/// writes the stress.
pub fn zone_bytes_per_cycle(gridpoints: usize, zones: usize, real: usize) -> u64 {
    let gp = 17 * real + 16;
    let zone = 3 * real + 16;
    let fdef_block = 2 * real + 24;
    let entries = 3 * zones;
    let gather = gridpoints * (gp + 8 + 2 * real) + entries * (4 + zone + 3 * 2 * real);
    let step = gridpoints * (gp + 8 * real);
    let stress = zones * (zone + fdef_block + 3 * 4 * real + 3 * real);
    (gather + step + stress) as u64
}

/// The zones and grid points of a model.
fn counts(m: &Model) -> (usize, usize) {
    m.fdef.iter().fold((0, 0), |(g, z), f| (g + f.gridpoints.len(), z + f.zones.len()))
}

/// Builds `deck` on the CPU (its GENERATE included), then on each engine runs it calibrated to
/// about `measure_s` of cycles and times a second run of that many cycles.
pub(super) fn measure(
    scene_name: &'static str,
    nominal: usize,
    deck: &str,
    engines: &mut [(usize, Engine)],
    infos: &[BackendInfo],
    measure_s: f64,
    say: &dyn Fn(&str),
) -> Vec<ZoneRow> {
    let built = Instant::now();
    let model0 = match crate::scenes::run_deck_on(&format!("{deck}CYCLE 0\n"), Box::new(crate::udec::cpu::CpuBackend::new())) {
        Ok(m) => m,
        Err(e) => {
            say(&format!("  the {scene_name} scene does not build: {e}"));
            return Vec::new();
        }
    };
    let (gridpoints, zones) = counts(&model0);
    say(&format!("zones: {scene_name} of {zones} zones, {gridpoints} grid points (built in {:.2} s)", built.elapsed().as_secs_f64()));
    let mut rows = Vec::new();
    for (i, engine) in engines.iter_mut() {
        let info = &infos[*i];
        let real = if info.precision == "f32" { 4 } else { 8 };
        let mut row = ZoneRow {
            scene: scene_name,
            backend: info.label.clone(),
            nominal,
            zones,
            gridpoints,
            blocks: model0.blocks.len(),
            contacts: model0.contacts.len(),
            bytes_per_cycle: zone_bytes_per_cycle(gridpoints, zones, real),
            bandwidth_bytes_per_s: info.bandwidth_bytes_per_s.unwrap_or(0.0),
            ..Default::default()
        };
        let mut model = model0.clone();
        // Calibration: ten cycles (the set-up and the first upload paid here), then as many as
        // fill `measure_s` at that rate, timed apart from the run's set-up.
        let result = super::timed_run(engine.backend(), &mut model, 10).and_then(|t| {
            let per = (t.steady_s / 10.0).max(1e-7);
            let cycles = ((measure_s / per) as u64).clamp(10, 100_000);
            super::timed_run(engine.backend(), &mut model, cycles).map(|t| (cycles, t))
        });
        match result {
            Ok((cycles, t)) => {
                row.cycles = cycles;
                row.s_per_cycle = t.steady_s / cycles as f64;
                row.zone_cycles_per_s = zones as f64 / row.s_per_cycle;
                row.updates = t.updates;
                let share = |group: &str| {
                    crate::profile::Stage::ALL.iter().filter(|s| s.group() == group).map(|&s| t.times.cycles_of(s).as_secs_f64()).sum::<f64>()
                        / t.steady_s.max(1e-300)
                };
                row.topology_share = share("topology");
                row.transfer_share = share("transfer");
                if row.bandwidth_bytes_per_s > 0.0 {
                    row.roofline = row.bytes_per_cycle as f64 / row.s_per_cycle / row.bandwidth_bytes_per_s;
                }
                say(&format!("  {}: {:.3e} zone-cycles/s, roofline {:.3}", row.backend, row.zone_cycles_per_s, row.roofline));
                if let Engine::Gpu(g) = engine {
                    // Where a GPU cycle of zones goes, kernel by kernel (a fifth of the
                    // measurement's time more), as the scaling walls report it.
                    let reps = ((0.2 * measure_s / row.s_per_cycle.max(1e-7)) as u32).clamp(3, 400);
                    match super::kernel_times(g, reps) {
                        Ok((how, kernels)) => (row.device_timing, row.kernels) = (Some(how), kernels),
                        Err(e) => row.device_timing = Some(format!("not measured: {e}")),
                    }
                }
            }
            Err(e) => {
                say(&format!("  {} failed: {e}", row.backend));
                row.error = Some(e.to_string());
            }
        }
        rows.push(row);
    }
    rows
}

/// The zone rows as a table.
pub fn table(rows: &[ZoneRow]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    if rows.is_empty() {
        return s;
    }
    let _ = writeln!(s, "\nZONED SCENES (fully-deformable blocks; roofline: the zone stages' bytes over the bandwidth yardstick)");
    let _ = writeln!(
        s,
        "{:<6} {:<28} {:>9} {:>9} {:>7} {:>9} {:>8} {:>12} {:>12} {:>9} {:>8} {:>7} {:>7}",
        "scene", "backend", "zones", "gridpts", "blocks", "contacts", "cycles", "s/cycle", "zone-cyc/s", "roofline", "updates", "topo", "xfer"
    );
    for r in rows {
        match &r.error {
            Some(e) => {
                let _ = writeln!(s, "{:<6} {:<28} {:>9} failed: {e}", r.scene, r.backend, r.zones);
            }
            None => {
                let (sizes, rates) = ((r.zones, r.gridpoints, r.blocks, r.contacts), (r.cycles, r.s_per_cycle, r.zone_cycles_per_s, r.roofline));
                let _ = write!(s, "{:<6} {:<28} {:>9} {:>9} {:>7} {:>9} ", r.scene, r.backend, sizes.0, sizes.1, sizes.2, sizes.3);
                let _ = write!(s, "{:>8} {:>12.3e} {:>12.3e} {:>9.3} ", rates.0, rates.1, rates.2, rates.3);
                let _ = writeln!(s, "{:>8} {:>6.1}% {:>6.1}%", r.updates, 100.0 * r.topology_share, 100.0 * r.transfer_share);
            }
        }
    }
    // Each GPU row's kernels, in microseconds a cycle and as a share of their sum.
    for r in rows.iter().filter(|r| r.device_timing.is_some()) {
        let _ = writeln!(
            s,
            "  {} {} of {} zones ({:.1} us/cycle), kernels by {}",
            r.backend,
            r.scene,
            r.zones,
            r.s_per_cycle * 1e6,
            r.device_timing.as_deref().unwrap_or("")
        );
        let sum: f64 = r.kernels.iter().map(|k| k.1).sum();
        for (name, t) in &r.kernels {
            let _ = writeln!(s, "    device {name:<28} {:>10.2} {:>6.1}%", t * 1e6, 100.0 * t / sum.max(1e-300));
        }
    }
    s
}

/// Each GPU zone row's kernel times as CSV (bench_zone_kernels.csv).
pub fn kernels_csv(rows: &[ZoneRow]) -> String {
    let mut s = String::from("scene,backend,zones,kernel,s_per_cycle\n");
    for r in rows {
        for (name, t) in &r.kernels {
            s += &format!("{},{},{},{},{:e}\n", r.scene, r.backend, r.zones, name, t);
        }
    }
    s
}

/// The zone rows as CSV.
pub fn csv(rows: &[ZoneRow]) -> String {
    let mut s = String::from(
        "scene,backend,nominal,zones,gridpoints,blocks,contacts,cycles,s_per_cycle,zone_cycles_per_s,bytes_per_cycle,bandwidth_bytes_per_s,roofline,updates,topology_share,transfer_share,error\n",
    );
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{},{},{},{:e},{:e},{},{:e},{:e},{},{:e},{:e},{}\n",
            r.scene,
            r.backend,
            r.nominal,
            r.zones,
            r.gridpoints,
            r.blocks,
            r.contacts,
            r.cycles,
            r.s_per_cycle,
            r.zone_cycles_per_s,
            r.bytes_per_cycle,
            r.bandwidth_bytes_per_s,
            r.roofline,
            r.updates,
            r.topology_share,
            r.transfer_share,
            r.error.as_deref().unwrap_or("").replace(',', ";")
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The family's decks make about the zones they are named for (within a factor of two: the
    /// mesh generator's bisection and the bricks' shapes), zoned blocks only where meant.
    #[test]
    fn the_decks_make_about_the_zones_asked_for() {
        for (deck, nominal) in [(block_deck(1000), 1000), (wall_deck(1000, scene::FRAC), 1000)] {
            let m = crate::scenes::run_deck_on(&format!("{deck}CYCLE 0\n"), Box::new(crate::udec::cpu::CpuBackend::new())).expect("the deck runs");
            let (_, zones) = counts(&m);
            assert!(zones >= nominal / 2 && zones <= nominal * 2, "{zones} zones for {nominal}");
        }
        assert!(zone_bytes_per_cycle(500, 1000, 8) > zone_bytes_per_cycle(500, 1000, 4));
    }
}
