//! Scenes shared by the tests, the benchmarks and (later) the verification suite: each is a deck,
//! so it exercises the language too, and the same scene runs on every backend (STYLE.md item 8,
//! item 13).

use std::fmt::Write;

use crate::backend::Backend;
use crate::exec::{Executor, RunError, RunOptions};
use crate::model::Model;

/// Runs deck text on a backend with the log discarded; returns the final model.
pub fn run_deck_on(text: &str, backend: Box<dyn Backend>) -> Result<Model, RunError> {
    run_deck_logged(text, backend, Box::new(std::io::sink()))
}

/// Runs deck text on a backend writing the run log to `log`.
pub fn run_deck_logged<'a>(text: &str, backend: Box<dyn Backend + 'a>, log: Box<dyn std::io::Write + 'a>) -> Result<Model, RunError> {
    let commands = crate::deck::parse_deck(text, "<scene>")?;
    let options = RunOptions { out_dir: std::env::temp_dir().join("blockdem-scenes"), progress: false };
    let mut exec = Executor::new(backend, log, options, "<scene>");
    exec.run(&commands)?;
    Ok(exec.model)
}

/// A brick wall in running bond: `rows` rows of `bricks` bricks (w × h), odd rows starting and
/// ending with a half brick, on a fixed ground block. Returns the deck up to (not including) any
/// CYCLE command. Blocks are made with one BLOCK command each (an extension of the 1985 language,
/// which allowed one BLOCK per run), which is much faster to build than SPLITs.
pub fn brick_wall_deck(rows: usize, bricks: usize, w: f64, h: f64, kn: f64, friction: f64) -> String {
    let mut deck = String::new();
    let _ = writeln!(deck, "START");
    let _ = writeln!(deck, "PROP MAT=1 DENS=2000 KN={kn:e} KS={kn:e} F={friction}");
    let _ = writeln!(deck, "ROUND {}", 0.02 * h.min(w));
    let width = bricks as f64 * w;
    // Ground block, one brick height thick, wider than the wall.
    let _ = writeln!(deck, "BLOCK {} {} {} 0 {} 0 {} {}", -w, -h, -w, width + w, width + w, -h);
    for r in 0..rows {
        let y0 = r as f64 * h;
        let y1 = y0 + h;
        let mut edges = Vec::new();
        if r % 2 == 0 {
            for i in 0..=bricks {
                edges.push(i as f64 * w);
            }
        } else {
            edges.push(0.0);
            for i in 0..bricks {
                edges.push((i as f64 + 0.5) * w);
            }
            edges.push(width);
        }
        for pair in edges.windows(2) {
            let (x0, x1) = (pair[0], pair[1]);
            let _ = writeln!(deck, "BLOCK {x0} {y0} {x0} {y1} {x1} {y1} {x1} {y0}");
        }
    }
    let _ = writeln!(deck, "FIX {} {} {} 0", -2.0 * w, width + 2.0 * w, -2.0 * h);
    let _ = writeln!(deck, "GRAVITY 0 -10");
    deck
}
