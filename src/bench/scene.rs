//! The reference scene other engines are compared with, and the scaling family of walls.
//!
//! The reference wall: 25 rows of 1 × 0.5 m bricks in running bond (40 whole bricks in even rows;
//! odd rows start and end with a half brick), 1012 bricks, density 2000, friction 0.6,
//! kn = ks = 1e9 N/m, no damping, on a fixed ground block under gravity −10.
//! - settle: the wall alone for 2 s of simulated time; the largest brick drift is reported.
//! - impact: a 0.5 m square projectile of density 8000 fired horizontally at 50 m/s from
//!   x = −2, y = 11, for 1 s; the number of bricks that moved more than 0.1 m is reported.
//!
//! Both are written out as decks in `examples/` by [`example_deck`] (a test keeps the files equal
//! to it). The scaling family keeps the 25 rows, makes the wall longer ([`scaling_wall`]) and
//! fires the same projectile at its left end ([`scaling_body`]).

use crate::scenes::BrickWall;
use crate::udec::model::Model;

/// ROUND of the reference scene. Not the 0.02·h = 0.01 of `brick_wall_deck`: at 50 m/s the
/// projectile travels 7 mm per step (Δt = 1.4e-4 s), more than the contact update can follow
/// (a quarter of the contact-forming distance atol = ROUND, the tunnelling guard), and the impact
/// compresses the contacts by about v·√(m_red/k) ≈ 0.03 m, beyond half the rounding length.
/// ROUND 0.1 allows 25 mm per step and 50 mm of overlap.
pub const ROUND: f64 = 0.1;

/// FRACTION of the reference scene: UDEC's default (see docs/BENCHMARKS.md for 0.2 and 0.3).
pub const FRAC: f64 = 0.1;

/// Simulated time of the settle and impact scenes.
pub const SETTLE_TIME: f64 = 2.0;
pub const IMPACT_TIME: f64 = 1.0;

/// A brick "moved" in the impact scene when its centroid is this far from where it started.
pub const MOVED_THRESHOLD: f64 = 0.1;

/// Rows of every wall of the bench.
pub const ROWS: usize = 25;

/// The projectile: side, density, centre, velocity.
pub const PROJECTILE_SIDE: f64 = 0.5;
pub const PROJECTILE_DENSITY: f64 = 8000.0;
pub const PROJECTILE_AT: [f64; 2] = [-2.0, 11.0];
pub const PROJECTILE_VELOCITY: [f64; 2] = [50.0, 0.0];

/// The moduli of the bricks of the `Sdef` scene (Pa): a soft brick (E ≈ 0.75 GPa), soft enough
/// that the bricks' own limit on the time step (`Model::critical_timestep`, ½·2√(M_min/k_int) =
/// 1.9e-4 s for a half brick) stays above the contacts' (1.4e-4 s): the scene runs the settle's
/// cycles at the settle's time step, and its cost per cycle is the SDEF blocks' alone.
pub const SDEF_BULK: f64 = 5e8;
pub const SDEF_SHEAR: f64 = 3e8;

/// The fluid of the `Fluid` scene: ρw = 1000 in the wall's joints and voids, flowing across its
/// contacts at CPERM = 1e-7 (the pressure update's explicit limit A_d(min)/(bulkw·Σk_c) is 6e-4 s,
/// four settle steps), the outer domain held at 0. Its bulk modulus, 2e5 Pa, is a compressible
/// fluid's, as the SDEF scene's bricks are soft: with water's 2e9 the voids' stiffness on the
/// bricks round them (bulkw·L²/A_d, `model::fluid::fluid_timestep`) would cut the settle's time
/// step 62 times; at 2e5 by 4.5%, so that the scene runs about the settle's cycles and its cost
/// per cycle is the fluid's.
pub const FLUID_LINES: &str = "PROP MAT=1 CPERM=1E-7\nFLUID 1000 2E5\nPFIX OUTER 0\n";

/// The reference scenes: the wall settling and struck, and the settling wall of
/// simply-deformable bricks (`Sdef`, issue 28: its cost per cycle against `Settle`'s) or with
/// fluid in its joints (`Fluid`, issue 30: likewise).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RefScene {
    Settle,
    Impact,
    Sdef,
    Fluid,
}

impl RefScene {
    pub fn name(self) -> &'static str {
        match self {
            RefScene::Settle => "settle",
            RefScene::Impact => "impact",
            RefScene::Sdef => "sdef",
            RefScene::Fluid => "fluid",
        }
    }

    /// Simulated time of the reference.
    pub fn time(self) -> f64 {
        match self {
            RefScene::Settle | RefScene::Sdef | RefScene::Fluid => SETTLE_TIME,
            RefScene::Impact => IMPACT_TIME,
        }
    }
}

/// A wall of the bench: 25 rows, `bricks` whole bricks in even rows, the reference materials.
pub fn wall(bricks: usize, frac: f64) -> BrickWall {
    BrickWall { rows: ROWS, bricks, brick: [1.0, 0.5], density: 2000.0, kn: 1e9, friction: 0.6, round: Some(ROUND), frac: Some(frac), gravity: -10.0 }
}

/// The reference wall (1012 bricks).
pub fn reference_wall(frac: f64) -> BrickWall {
    wall(40, frac)
}

/// The scaling wall of about `n` blocks: the reference's 25 rows made longer (`n / 25` bricks per
/// row). Fixed rows rather than a wall growing in both directions: every wall then carries the
/// same loads, settles the same way and has the same contacts per block as the reference, so
/// the time per block-cycle of different sizes measures the engine, not a different problem (a
/// wall of 1000 rows would settle 1600 times as far and keep stage 7 busy).
pub fn scaling_wall(n: usize, frac: f64) -> BrickWall {
    wall((n / ROWS).max(2), frac)
}

/// The deck of the scaling wall of about `n` blocks struck by the reference projectile (the
/// issue's "family of brick walls of N blocks struck by a projectile"), up to its CYCLE command:
/// the projectile is the reference's, at the wall's left end, so every wall of the family meets
/// the same impact while the rest of it stands; what grows with N is the wall that each contact
/// update has to keep track of around the projectile.
pub fn scaling_body(n: usize, frac: f64) -> String {
    let wall = scaling_wall(n, frac);
    wall.deck() + &projectile_lines(&wall)
}

/// The scaling wall of about `n` blocks with every brick simply deformable (`SDEF_BULK`,
/// `SDEF_SHEAR`, as the reference `sdef` scene), struck by the same rigid projectile: the SDEF
/// kernels' cost per block-cycle against the rigid family's, up to 10⁶ blocks (issue 28's
/// "10⁶-block SDEF wall" on a lent GPU). The CHANGE range holds the bricks' centroids, not the
/// ground's (below y = 0) nor the projectile's (left of x = 0).
pub fn scaling_body_sdef(n: usize, frac: f64) -> String {
    let wall = scaling_wall(n, frac);
    let top = wall.rows as f64 * wall.brick[1];
    let right = wall.bricks as f64 * wall.brick[0];
    wall.deck() + &format!("PROP MAT=1 K={SDEF_BULK:e} G={SDEF_SHEAR:e}\nCHANGE 0 {} 0 {} SDEF\n", right + 1.0, top + 1.0) + &projectile_lines(&wall)
}

/// The projectile's commands: its material (2), its block, its velocity.
fn projectile_lines(wall: &BrickWall) -> String {
    let [x, y] = PROJECTILE_AT;
    let s = 0.5 * PROJECTILE_SIDE;
    let (x0, x1, y0, y1) = (x - s, x + s, y - s, y + s);
    let kn = wall.kn;
    format!(
        "PROP MAT=2 DENS={PROJECTILE_DENSITY} KN={kn:e} KS={kn:e} F={f}\nBLOCK MAT=2 {x0} {y0} {x0} {y1} {x1} {y1} {x1} {y0}\nVELOCITY {} {} {} {} {} {}\n",
        x0 - s,
        x1 + s,
        y0 - s,
        y1 + s,
        PROJECTILE_VELOCITY[0],
        PROJECTILE_VELOCITY[1],
        f = wall.friction,
    )
}

/// The deck of a reference scene up to (not including) its CYCLE command.
pub fn reference_body(scene: RefScene, frac: f64) -> String {
    let wall = reference_wall(frac);
    let mut deck = wall.deck();
    match scene {
        RefScene::Settle => {}
        RefScene::Impact => deck += &projectile_lines(&wall),
        RefScene::Sdef => {
            // Every brick (centroids above the ground's top, y = 0) simply deformable.
            let top = wall.rows as f64 * wall.brick[1];
            let right = wall.bricks as f64 * wall.brick[0];
            deck += &format!("PROP MAT=1 K={SDEF_BULK:e} G={SDEF_SHEAR:e}\nCHANGE -1 {} 0 {} SDEF\n", right + 1.0, top + 1.0);
        }
        RefScene::Fluid => deck += FLUID_LINES,
    }
    deck
}

/// The cycles that cover `time` at the time step the deck gets (UDEC's Δt = FRAC·2√(m_min/k_max)),
/// and that time step.
pub fn cycles_for(body: &str, time: f64) -> Result<(u64, f64), crate::udec::exec::RunError> {
    let model = crate::scenes::run_deck_on(&format!("{body}CYCLE 0\n"), Box::new(crate::udec::cpu::CpuBackend::new()))?;
    Ok(((time / model.timestep - 1e-9).ceil() as u64, model.timestep))
}

/// The text of `examples/brick_wall_settle.dat` or `examples/brick_wall_impact.dat`: the reference
/// scene at its full simulated time, with comments that say what it is and why ROUND and FRACTION
/// have their values.
pub fn example_deck(scene: RefScene) -> String {
    let body = reference_body(scene, FRAC);
    let (cycles, dt) = cycles_for(&body, scene.time()).expect("the reference deck builds");
    let wall = reference_wall(FRAC);
    let what = match scene {
        RefScene::Settle => format!(
            "* SETTLE: the wall alone for {SETTLE_TIME} s of simulated time. `blockdem bench --scene settle`\n\
             * reports the largest displacement of any brick from where it started (the drift), the\n\
             * largest sink of the top row, and the elastic settlement expected under self-weight.\n"
        ),
        RefScene::Sdef => format!(
            "* SDEF: the settle scene with every brick simply deformable (K = {SDEF_BULK:e}, G = {SDEF_SHEAR:e},\n\
             * CHANGE ... SDEF): `blockdem bench --scene sdef` reports its cost per cycle against the\n\
             * settle scene's on each backend (issue 28: at most 1.5 times).\n"
        ),
        RefScene::Fluid => "* FLUID: the settle scene with fluid in the wall's joints and voids (FLUID 1000 2E5: a\n\
             * compressible fluid, whose voids do not cut the time step much; CPERM 1e-7 across each\n\
             * contact; the outer domain held at 0 with PFIX): `blockdem bench --scene fluid` reports its\n\
             * cost per cycle against the dry settle scene's on each backend (issue 30: at most 1.3 times).\n"
            .to_string(),
        RefScene::Impact => format!(
            "* IMPACT: a {PROJECTILE_SIDE} m square projectile of density {PROJECTILE_DENSITY} (material 2) fired\n\
             * horizontally at {} m/s from x = {}, y = {} (VELOCITY, an extension of the 1985\n\
             * language) strikes the wall for {IMPACT_TIME} s. `blockdem bench --scene impact` reports how\n\
             * many bricks moved more than {MOVED_THRESHOLD} m.\n",
            PROJECTILE_VELOCITY[0], PROJECTILE_AT[0], PROJECTILE_AT[1]
        ),
    };
    format!(
        "* blockdem reference scene: a brick wall in running bond ({name}).\n\
         * Generated by blockdem::bench::scene::example_deck; tests/suite/bench.rs checks that this file\n\
         * equals the generator's output (BLOCKDEM_BLESS=1 cargo test --release --test suite bench:: rewrites it).\n\
         *\n\
         * {rows} rows of 1 x 0.5 m bricks: {b} whole bricks in even rows, odd rows start and end with a\n\
         * half brick ({b1} bricks); {n} bricks in all, one BLOCK command each (an extension: the 1985\n\
         * program took one BLOCK per run). Density 2000, friction 0.6, kn = ks = 1e9 N/m, no damping;\n\
         * a fixed ground block; gravity -10.\n\
         {what}\
         *\n\
         * ROUND {ROUND}, not the 0.02 h = 0.01 of a default brick wall: at 50 m/s the projectile moves\n\
         * 7 mm per step, more than the contact update can follow (a quarter of the contact-forming\n\
         * distance, which is ROUND: the tunnelling guard stops the run), and the impact compresses\n\
         * its contacts by about v sqrt(m_red / k) = 0.03 m, more than half the rounding length (an\n\
         * overlap error). ROUND {ROUND} allows 25 mm per step and 50 mm of overlap. Both scenes use it.\n\
         * FRACTION {FRAC} (UDEC's default): dt = FRAC 2 sqrt(m_min / k_max) = {dt:.4e} s, m_min being a\n\
         * half brick (500 kg); {time} s is {cycles} cycles.\n\
         {body}\
         CYCLE {cycles}\n\
         STOP\n",
        name = scene.name(),
        rows = wall.rows,
        b = wall.bricks,
        b1 = wall.bricks + 1,
        n = wall.brick_count(),
        time = scene.time(),
    )
}

/// The path of a scene's deck under the crate's `examples/`.
pub fn example_path(scene: RefScene) -> &'static str {
    match scene {
        RefScene::Settle => "examples/brick_wall_settle.dat",
        RefScene::Impact => "examples/brick_wall_impact.dat",
        RefScene::Sdef => "examples/brick_wall_sdef.dat",
        RefScene::Fluid => "examples/brick_wall_fluid.dat",
    }
}

/// What the reference scene reports about the wall at the end of a run.
///
/// # What the drift of the settle scene is
///
/// `drift` is the largest displacement of any brick centroid from where the deck built it. With
/// the reference settings it is 3.06 mm at 2 s (CPU, FRAC 0.1), and it is physics, not creep:
///
/// - About 0.85 mm of it is vertical: the joints compressing under the weight above them,
///   `elastic_estimate` (0.875 mm at the top).
/// - The rest is horizontal: the upper courses spread outward, most at the free ends (the end
///   half brick of row 23 moves 2.9 mm left, its twin at the right end 2.1 mm right; 1.1 mm at
///   x = 3.5 m in the top row; below 0.3 mm in the lower half). Their head joints have opened,
///   up to 1.6 mm each near the ends of the top rows.
///
/// The spread comes from the scene's start: bricks placed touching, contacts unloaded, gravity
/// on and no damping, is a drop of the whole wall onto its joints. It rings about its loaded
/// state with an amplitude equal to the settlement (period 0.07 s), so at the top of each
/// rebound the joint forces fall to zero: in the first 0.5 s up to 2250 of the 3920 loaded bed
/// contacts are open at once. An open contact carries no friction and loses its shear force
/// (eq. 20); head joints push but never pull; so while the courses are weightless the bricks
/// shift sideways and the courses ratchet longer, until friction and the shear resets have taken
/// the ringing's energy (2900 J of 5500 J of work done by gravity; the ledger balances to 1.2%,
/// an O(Δt²) error). From 0.55 s on at most a dozen joints open at a time, and the worst brick
/// keeps its horizontal position to 0.05 mm while the residual ringing moves it ±0.13 mm
/// vertically. The checks that make this physics and not a defect:
///
/// - the same wall first brought to rest (damped) and then run undamped for 2 s moves by
///   1.6e-12 m: the engine itself does not creep (`an_equilibrated_wall_stands_still` below);
/// - with damping (DAMPING 0.5 14 MASS, diagnostic only) the drift is the elastic estimate,
///   0.875 mm, with no horizontal motion at all;
/// - halving Δt does not make it go away (3.3 mm at FRAC 0.05, 4.9 mm at FRAC 0.2: a ratchet,
///   not a discretisation error); friction 10 instead of 0.6 leaves it (3.3 mm): it is the
///   opening of joints, not sliding under load;
/// - no touch is counted twice: the two views of a corner pair never both carry force.
///
/// Engines with inelastic contact solvers (Box2D, Rapier) do not rebound, so their drift is creep
/// and penetration; to compare with them, `drift_beyond_elastic` takes the elastic settlement
/// away and `spread` names the horizontal part that the drop leaves.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct WallMeasures {
    /// Bricks of the wall (material 1, not fixed).
    pub bricks: usize,
    /// Largest displacement of a brick centroid from where it started (m), and where that brick
    /// started.
    pub drift: f64,
    pub drift_at: [f64; 2],
    /// Largest displacement of a brick centroid once the elastic settlement expected at its
    /// height ([`elastic_profile`]) is taken away (m), and where that brick started: what the
    /// wall moved beyond compressing its joints.
    pub drift_beyond_elastic: f64,
    pub drift_beyond_elastic_at: [f64; 2],
    /// Largest horizontal displacement of a brick centroid (m).
    pub spread: f64,
    /// Largest downward displacement of a brick of the top row (m).
    pub top_sink: f64,
    /// Elastic settlement of the top under self-weight: Σ over the bed joints of the weight above
    /// the joint over the joint's stiffness (force-carrying contacts across it × kn) (m).
    pub elastic_estimate: f64,
    /// Bricks whose centroid moved more than [`MOVED_THRESHOLD`].
    pub moved: usize,
}

/// Measures the wall of `fin` against its state in `initial` (the same deck before any cycle).
pub fn measure(wall: &BrickWall, initial: &Model, fin: &Model) -> WallMeasures {
    let start: std::collections::HashMap<u32, [f64; 2]> = initial.blocks.iter().filter(|b| !b.fixed && b.material == 1).map(|b| (b.id, b.centroid)).collect();
    let h = wall.brick[1];
    let top_y = (wall.rows as f64 - 0.5) * h;
    let profile = elastic_profile(wall, fin);
    let mut m = WallMeasures::default();
    for b in fin.blocks.iter().filter(|b| !b.fixed && b.material == 1) {
        let Some(c0) = start.get(&b.id) else { continue };
        m.bricks += 1;
        let (dx, dy) = (b.centroid[0] - c0[0], b.centroid[1] - c0[1]);
        let d = dx.hypot(dy);
        if d > m.drift {
            m.drift = d;
            m.drift_at = *c0;
        }
        // The row the brick was built in sinks by the settlement of the joints below it.
        let row = ((c0[1] / h).floor().max(0.0) as usize).min(wall.rows - 1);
        let beyond = dx.hypot(dy + profile[row]);
        if beyond > m.drift_beyond_elastic {
            m.drift_beyond_elastic = beyond;
            m.drift_beyond_elastic_at = *c0;
        }
        m.spread = m.spread.max(dx.abs());
        if (c0[1] - top_y).abs() < 0.25 * h {
            m.top_sink = m.top_sink.max(-dy);
        }
        if d > MOVED_THRESHOLD {
            m.moved += 1;
        }
    }
    m.elastic_estimate = profile.last().copied().unwrap_or(0.0);
    m
}

/// The elastic settlement of the top of the wall under self-weight (module doc of
/// [`WallMeasures::elastic_estimate`]): the last entry of [`elastic_profile`].
pub fn elastic_settlement(wall: &BrickWall, model: &Model) -> f64 {
    elastic_profile(wall, model).last().copied().unwrap_or(0.0)
}

/// The elastic settlement of each row under self-weight: row r sinks by the compression of the
/// bed joints 0..=r below it (joint j below row j, j = 0 on the ground). Joint j carries the
/// weight of rows j and above, on the force-carrying contacts whose point lies on it and whose
/// normal is near vertical; each is a spring kn. This assumes the weight spreads evenly along the
/// wall, which running bond does away from the ends.
pub fn elastic_profile(wall: &BrickWall, model: &Model) -> Vec<f64> {
    let h = wall.brick[1];
    let g = model.gravity[1].abs();
    let mut springs = vec![0usize; wall.rows];
    for c in &model.contacts {
        if c.normal[1].abs() < 0.7 || !model.counts_force(c) {
            continue;
        }
        let j = (c.point[1] / h).round();
        if j >= 0.0 && (c.point[1] - j * h).abs() < 0.25 * h && (j as usize) < wall.rows {
            springs[j as usize] += 1;
        }
    }
    let mut weight_above = vec![0.0f64; wall.rows + 1];
    for b in model.blocks.iter().filter(|b| !b.fixed && b.material == 1) {
        let row = ((b.centroid[1] / h).floor().max(0.0) as usize).min(wall.rows - 1);
        weight_above[row] += b.mass * g;
    }
    for j in (0..wall.rows).rev() {
        weight_above[j] += weight_above[j + 1];
    }
    let mut sunk = 0.0;
    (0..wall.rows)
        .map(|j| {
            if springs[j] > 0 {
                sunk += weight_above[j] / (springs[j] as f64 * wall.kn);
            }
            sunk
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::run_deck_on;

    fn run(deck: &str) -> Model {
        run_deck_on(deck, Box::new(crate::udec::cpu::CpuBackend::new())).expect("the wall deck runs")
    }

    /// The engine keeps a wall at rest where it is: a wall of the reference bricks, materials and
    /// time step (10 rows of 8), first brought to rest with mass damping, then run undamped, does
    /// not move. The bound, 1e-9 m, is what is left of the damped transient after 3000 cycles
    /// (the reference wall moves by 1.6e-12 m in 2 s from its equilibrium); creep from the
    /// contact law (a shear force that drifts at rest, a touch counted twice, energy that grows)
    /// would move it by orders more. And with the transient damped, the wall sinks by its elastic
    /// settlement and spreads by nothing: the drift of the undamped settle scene beyond that is
    /// the rebound of its unloaded start (see [`WallMeasures`]).
    #[test]
    fn an_equilibrated_wall_stands_still() {
        let wall = BrickWall { rows: 10, ..super::wall(8, FRAC) };
        let body = wall.deck();
        let initial = run(&format!("{body}CYCLE 0\n"));
        // Fundamental frequency of the wall's vertical ringing: c / 4H with c = h √(k/m) the speed
        // of a wave down the courses (2 kn per brick overlap, 1000 kg per brick): 35 Hz.
        let settled_deck = format!("{body}DAMPING 0.5 35 MASS\nCYCLE 3000\n");
        let settled = run(&settled_deck);
        let still = run(&format!("{settled_deck}DAMPING 0 35 MASS\nCYCLE 3000\n"));
        let moved =
            settled.blocks.iter().zip(&still.blocks).map(|(a, b)| (a.centroid[0] - b.centroid[0]).hypot(a.centroid[1] - b.centroid[1])).fold(0.0, f64::max);
        assert!(moved < 1e-9, "an equilibrated wall moved {moved} m in 3000 undamped cycles");
        let m = measure(&wall, &initial, &settled);
        assert!((m.top_sink - m.elastic_estimate).abs() < 0.02 * m.elastic_estimate, "{m:?}");
        assert!(m.spread < 1e-9 && m.drift_beyond_elastic < 0.02 * m.elastic_estimate, "{m:?}");
    }
}
