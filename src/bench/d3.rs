//! D3's bench scenes (issue 31, Speed), on its CPU and GPU backends:
//!
//! - `d3-cubes`: unit cubes in a lattice under gravity, the scene the Yade polyhedra peer runs:
//!   columns 0.1 m apart of cubes standing on each other on a fixed slab (so that every cube
//!   has its face–face contacts, eight logical contacts, from the first cycle; a lattice spaced
//!   vertically too would measure free fall for most of a short run): body-steps per second
//!   (blocks × cycles / s), target ≥ 10⁶ on this machine's CPU.
//! - `d3-wall`: a brick wall one brick thick (bricks 0.4 × 0.2 × 0.2 m in running bond, resting
//!   on each other and on a fixed slab) struck at mid-height by a 0.5 m cube at 10 m/s, 10³ and
//!   10⁴ bricks: contact-cycles per second (contacts in the neighbour lists, each one's stage 4
//!   every cycle, × cycles / s).
//!
//! Each scene is built by its deck (`CYCLE 0`: the contacts detected), then run for a few cycles
//! to find its pace, then timed over about `measure_s` of cycles.

use std::fmt::Write as _;
use std::time::Instant;

use crate::d3;
use crate::d3::model::Model;

/// The body-steps per second D3's CPU cycle should reach on the cubes (issue 31).
pub const CUBES_TARGET: f64 = 1e6;

/// One measurement of a D3 scene.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct D3Row {
    pub scene: &'static str,
    pub backend: String,
    pub blocks: usize,
    /// Contacts in the neighbour lists at the end (real and degenerate).
    pub contacts: usize,
    /// Real contacts (touching) at the end, and their logical contacts.
    pub touching: usize,
    pub logical: usize,
    /// Cycles timed (all rounds) and the best round's seconds per cycle.
    pub cycles: u64,
    pub s_per_cycle: f64,
    pub body_steps_per_s: f64,
    pub contact_cycles_per_s: f64,
    pub error: Option<String>,
}

/// The deck of `n` unit cubes (the cube root rounded up on a side, the last layer partial) in a
/// lattice of columns 0.1 m apart, each column's cubes standing on each other on a fixed slab,
/// under gravity.
pub fn cubes_deck(n: usize, frac: f64) -> String {
    let side = (n as f64).cbrt().ceil().max(1.0) as usize;
    let pitch = 1.1;
    let span = side as f64 * pitch;
    let mut deck = format!("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5\nBOX -1 {e} -1 {e} -1 0\n", e = span + 1.0);
    for k in 0..n {
        let (i, j, l) = (k % side, (k / side) % side, k / (side * side));
        let (x, y, z) = (i as f64 * pitch, j as f64 * pitch, l as f64);
        let _ = writeln!(deck, "BOX {x} {} {y} {} {z} {}", x + 1.0, y + 1.0, z + 1.0);
    }
    let _ = write!(deck, "FIX -0.5 {e} -0.5 {e} -0.6 -0.4\nGRAV 0 0 -10\nFRACTION {frac}\n", e = span + 0.5);
    deck
}

/// The deck of a wall of about `n` bricks (one brick thick, rows of `n / rows` bricks, every
/// other row shifted half a brick) on a fixed slab, struck by a cube.
pub fn wall_deck(n: usize, frac: f64) -> String {
    let (bx, bz, t) = (0.4, 0.2, 0.2);
    let rows = ((n as f64 / 8.0).sqrt().round() as usize).max(1);
    let per_row = n.div_ceil(rows).max(1);
    let length = per_row as f64 * bx + 0.5 * bx;
    let mut deck = format!("START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.6\nBOX -1 {} -1 {} -1 0\n", length + 1.0, t + 1.0);
    let mut placed = 0;
    'rows: for r in 0..rows {
        let shift = if r % 2 == 1 { 0.5 * bx } else { 0.0 };
        for c in 0..per_row {
            if placed == n {
                break 'rows;
            }
            let (x, z) = (shift + c as f64 * bx, r as f64 * bz);
            let _ = writeln!(deck, "BOX {x} {} 0 {t} {z} {}", x + bx, z + bz);
            placed += 1;
        }
    }
    // The projectile: a 0.5 m cube 0.1 m in front of the wall's middle, moving into it.
    let (cx, cz) = (0.5 * length, (0.5 * rows as f64 * bz).max(0.3));
    let _ = write!(
        deck,
        "BOX {} {} -0.6 -0.1 {} {}\nFIX -0.5 {} -0.5 {} -0.6 -0.4\nGRAV 0 0 -10\nVELOCITY {} {} -0.6 -0.1 {} {} 0 10 0\nFRACTION {frac}\n",
        cx - 0.25,
        cx + 0.25,
        cz - 0.25,
        cz + 0.25,
        length + 0.5,
        t + 0.5,
        cx - 0.3,
        cx + 0.3,
        cz - 0.3,
        cz + 0.3
    );
    deck
}

/// A D3 backend for the bench: the CPU's, or the GPU's on an adapter in a precision.
pub fn backend_for(spec: &super::BackendSpec) -> (String, Result<Box<dyn d3::backend::Backend>, String>) {
    match spec {
        super::BackendSpec::Cpu => (format!("cpu f64 ({} threads)", rayon::current_num_threads()), Ok(Box::new(d3::cpu::CpuBackend::new()))),
        super::BackendSpec::Gpu(o) => match d3::gpu::GpuBackend::new(&o.adapter, o.precision) {
            Ok(g) => {
                let a = g.adapter();
                (format!("gpu {} {} ({})", a.backend, o.precision, a.driver_name()), Ok(Box::new(g)))
            }
            Err(e) => (format!("gpu {:?} {}", o.adapter, o.precision), Err(e.to_string())),
        },
    }
}

/// Builds `deck` (`CYCLE 0`), runs it a few cycles to find its pace, then times `rounds` runs of
/// about `measure_s` of cycles each on `backend` (`cycles`: all of them; `s_per_cycle`: the best
/// run's).
pub fn measure(scene: &'static str, deck: &str, measure_s: f64, rounds: u32, spec: &super::BackendSpec) -> D3Row {
    let (label, backend) = backend_for(spec);
    let mut row = D3Row { scene, backend: label, ..Default::default() };
    let mut backend = match backend {
        Ok(b) => b,
        Err(e) => {
            row.error = Some(e);
            return row;
        }
    };
    let commands = match d3::deck::parse_deck(&format!("{deck}CYCLE 0\n"), scene) {
        Ok(c) => c,
        Err(e) => {
            row.error = Some(e.to_string());
            return row;
        }
    };
    let mut exec = d3::exec::Executor::new(Box::new(std::io::sink()), scene);
    if let Err(e) = exec.run(&commands) {
        row.error = Some(e.to_string());
        return row;
    }
    let mut model: Model = std::mem::take(&mut exec.model);
    let mut run = |model: &mut Model, cycles: u64| -> Result<f64, String> {
        let t = Instant::now();
        backend.run(model, cycles, &mut |_| true).map_err(|e| e.to_string())?;
        Ok(t.elapsed().as_secs_f64())
    };
    // The pace: 10 cycles (the first run's contact detection included), then the rest timed.
    let pace = match run(&mut model, 10) {
        Ok(s) => s / 10.0,
        Err(e) => {
            row.error = Some(e);
            return row;
        }
    };
    let cycles = ((measure_s / pace.max(1e-9)) as u64).clamp(10, 1_000_000);
    // The best of `rounds` timed runs (this machine's two cores are shared: the least time is
    // the cycle's own).
    row.s_per_cycle = f64::INFINITY;
    for _ in 0..rounds.max(1) {
        match run(&mut model, cycles) {
            Ok(s) => {
                row.cycles += cycles;
                row.s_per_cycle = row.s_per_cycle.min(s / cycles as f64);
            }
            Err(e) => {
                row.error = Some(e);
                return row;
            }
        }
    }
    row.blocks = model.blocks.iter().filter(|b| !b.fixed).count();
    row.contacts = model.contacts.len();
    row.touching = model.contacts.iter().filter(|c| !c.logical.is_empty()).count();
    row.logical = model.contacts.iter().map(|c| c.logical.len()).sum();
    row.body_steps_per_s = row.blocks as f64 / row.s_per_cycle;
    row.contact_cycles_per_s = row.contacts as f64 / row.s_per_cycle;
    row
}

/// The D3 section of the bench table.
pub fn table(rows: &[D3Row]) -> String {
    let mut s = String::new();
    if rows.is_empty() {
        return s;
    }
    let _ = writeln!(s, "\nD3 (3D): cubes in a lattice falling on a slab; a brick wall struck by a cube");
    let _ = writeln!(
        s,
        "{:<9} {:<34} {:>7} {:>8} {:>8} {:>8} {:>7} {:>11} {:>13} {:>13}",
        "scene", "backend", "blocks", "contacts", "touching", "logical", "cycles", "s/cycle", "body-steps/s", "contact-c/s"
    );
    for r in rows {
        if let Some(e) = &r.error {
            let _ = writeln!(s, "{:<9} {:<34} failed: {e}", r.scene, r.backend);
            continue;
        }
        let _ = writeln!(
            s,
            "{:<9} {:<34} {:>7} {:>8} {:>8} {:>8} {:>7} {:>11.3e} {:>13.3e} {:>13.3e}",
            r.scene, r.backend, r.blocks, r.contacts, r.touching, r.logical, r.cycles, r.s_per_cycle, r.body_steps_per_s, r.contact_cycles_per_s
        );
    }
    s
}

/// The rows as CSV.
pub fn csv(rows: &[D3Row]) -> String {
    let mut s = String::from("scene,backend,blocks,contacts,touching,logical,cycles,s_per_cycle,body_steps_per_s,contact_cycles_per_s,error\n");
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{:e},{:e},{:e},{}",
            r.scene,
            r.backend,
            r.blocks,
            r.contacts,
            r.touching,
            r.logical,
            r.cycles,
            r.s_per_cycle,
            r.body_steps_per_s,
            r.contact_cycles_per_s,
            r.error.as_deref().unwrap_or("").replace(',', ";")
        );
    }
    s
}
