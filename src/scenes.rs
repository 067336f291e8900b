//! Scenes shared by the tests, the benchmarks and (later) the verification suite: each is a deck,
//! so it exercises the language too, and the same scene runs on every backend (STYLE.md item 8,
//! item 13).

use std::fmt::Write;

use crate::udec::backend::Backend;
use crate::udec::exec::{Executor, RunError, RunOptions};
use crate::udec::model::Model;

/// Runs deck text on a backend with the log discarded; returns the final model.
pub fn run_deck_on(text: &str, backend: Box<dyn Backend>) -> Result<Model, RunError> {
    run_deck_logged(text, backend, Box::new(std::io::sink()))
}

/// Runs deck text on a backend writing the run log to `log`.
pub fn run_deck_logged<'a>(text: &str, backend: Box<dyn Backend + 'a>, log: Box<dyn std::io::Write + 'a>) -> Result<Model, RunError> {
    let commands = crate::udec::deck::parse_deck(text, "<scene>")?;
    let options = RunOptions { out_dir: std::env::temp_dir().join("blockdem-scenes"), ..Default::default() };
    let mut exec = Executor::new(backend, log, options, "<scene>");
    exec.run(&commands)?;
    Ok(exec.model)
}

/// A brick wall in running bond: `rows` rows of `bricks` bricks (w × h), odd rows starting and
/// ending with a half brick, on a fixed ground block. Returns the deck up to (not including) any
/// CYCLE command. Blocks are made with one BLOCK command each (an extension of the 1985 language,
/// which allowed one BLOCK per run), which is much faster to build than SPLITs. Rounding 0.02·h.
pub fn brick_wall_deck(rows: usize, bricks: usize, w: f64, h: f64, kn: f64, friction: f64) -> String {
    BrickWall { rows, bricks, brick: [w, h], kn, friction, ..BrickWall::default() }.deck()
}

/// The bulk and shear moduli (Pa) of the simply-deformable scenes' material.
pub const SDEF_K: f64 = 1e8;
pub const SDEF_G: f64 = 6e7;

/// A 1 m square simply-deformable block on a fixed base under a rigid platen loaded by `load`
/// (N, downwards positive), no gravity, critically damped (mass and internal damping); pulled
/// (`load` < 0) the contacts are glued (cohesion, friction), which restrain the block's sides,
/// pushed they are frictionless, so that its sides are free (uniaxial stress). Every block has
/// constitutive number `cons`, the material TF = `tf` (SDEF_K, SDEF_G). `settings` are deck
/// lines placed before the blocks (a FRACTION); the deck stops before any CYCLE.
pub fn sdef_platen_deck(load: f64, tf: f64, cons: u32, settings: &str) -> String {
    let glue = if load < 0.0 { "F=0.5 COH=1E9" } else { "F=0" };
    format!(
        "START\nPROP MAT=1 DENS=2000 K={SDEF_K:e} G={SDEF_G:e} KN=1E11 KS=1E11 {glue}\nPROP MAT=1 TF={tf:e}\nROUND 0.01\n{settings}\
         BLOCK CONS={cons} (0,-1) (0,0) (3,0) (3,-1)\nBLOCK CONS={cons} (1,0) (1,1) (2,1) (2,0)\nBLOCK CONS={cons} (0.5,1) (0.5,1.5) (2.5,1.5) (2.5,1)\n\
         CHANGE 0 3 0 1 SDEF\nFIX -1 4 -2 -0.2\nLOAD 0 3 1 1.5 0 {}\nDAMP 1 90 MASS\nDAMP 1 90 INTERNAL\n",
        -load
    )
}

/// A brick wall in running bond on a fixed ground block (the scene of `brick_wall_deck`, the
/// verification suite and `blockdem bench`): `rows` rows of bricks `brick` = [w, h]; even rows
/// (counting from 0 at the bottom) hold `bricks` whole bricks, odd rows a half brick, `bricks − 1`
/// whole ones and a half brick, so the wall is `bricks · w` long with square ends. The ground
/// block is one brick height thick and one brick longer than the wall at each end. Material 1.
#[derive(Clone, Debug, PartialEq)]
pub struct BrickWall {
    pub rows: usize,
    pub bricks: usize,
    pub brick: [f64; 2],
    pub density: f64,
    /// Contact normal and shear stiffness (KN = KS).
    pub kn: f64,
    pub friction: f64,
    /// ROUND; `None`: 0.02 · the brick's smaller side.
    pub round: Option<f64>,
    /// FRACTION; `None`: UDEC's default (0.1), no FRACTION command.
    pub frac: Option<f64>,
    /// Vertical gravity.
    pub gravity: f64,
}

impl Default for BrickWall {
    fn default() -> Self {
        BrickWall { rows: 25, bricks: 40, brick: [1.0, 0.5], density: 2000.0, kn: 1e9, friction: 0.6, round: None, frac: None, gravity: -10.0 }
    }
}

impl BrickWall {
    /// The x of the brick edges of row `r`, left to right.
    fn edges(&self, r: usize) -> Vec<f64> {
        let w = self.brick[0];
        if r % 2 == 0 {
            (0..=self.bricks).map(|i| i as f64 * w).collect()
        } else {
            let mut e = vec![0.0];
            e.extend((0..self.bricks).map(|i| (i as f64 + 0.5) * w));
            e.push(self.bricks as f64 * w);
            e
        }
    }

    /// Number of bricks: `bricks` in each even row, `bricks + 1` in each odd row.
    pub fn brick_count(&self) -> usize {
        let odd = self.rows / 2;
        (self.rows - odd) * self.bricks + odd * (self.bricks + 1)
    }

    pub fn length(&self) -> f64 {
        self.bricks as f64 * self.brick[0]
    }

    pub fn height(&self) -> f64 {
        self.rows as f64 * self.brick[1]
    }

    /// The rounding length the deck sets.
    pub fn round(&self) -> f64 {
        self.round.unwrap_or(0.02 * self.brick[1].min(self.brick[0]))
    }

    /// Each brick's (row, centroid), in the order the deck creates them (after the ground block).
    pub fn brick_centroids(&self) -> Vec<(usize, [f64; 2])> {
        let h = self.brick[1];
        let mut out = Vec::with_capacity(self.brick_count());
        for r in 0..self.rows {
            let y = (r as f64 + 0.5) * h;
            for pair in self.edges(r).windows(2) {
                out.push((r, [0.5 * (pair[0] + pair[1]), y]));
            }
        }
        out
    }

    /// The deck up to (not including) any CYCLE command.
    pub fn deck(&self) -> String {
        let mut deck = String::new();
        let [w, h] = self.brick;
        let kn = self.kn;
        let _ = writeln!(deck, "START");
        let _ = writeln!(deck, "PROP MAT=1 DENS={} KN={kn:e} KS={kn:e} F={}", self.density, self.friction);
        let _ = writeln!(deck, "ROUND {}", self.round());
        if let Some(f) = self.frac {
            let _ = writeln!(deck, "FRACTION {f}");
        }
        let width = self.length();
        // Ground block, one brick height thick, wider than the wall.
        let _ = writeln!(deck, "BLOCK {} {} {} 0 {} 0 {} {}", -w, -h, -w, width + w, width + w, -h);
        for r in 0..self.rows {
            let y0 = r as f64 * h;
            let y1 = y0 + h;
            for pair in self.edges(r).windows(2) {
                let (x0, x1) = (pair[0], pair[1]);
                let _ = writeln!(deck, "BLOCK {x0} {y0} {x0} {y1} {x1} {y1} {x1} {y0}");
            }
        }
        let _ = writeln!(deck, "FIX {} {} {} 0", -2.0 * w, width + 2.0 * w, -2.0 * h);
        let _ = writeln!(deck, "GRAVITY 0 {}", self.gravity);
        deck
    }
}
