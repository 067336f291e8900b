//! Outputs: PRINT tables, PLOT files (PNG and SVG), the state JSON, the full DUMP, and SAVE/RESTART
//! files (DESIGN.md §5).
//!
//! | file | what |
//! |---|---|
//! | [`mod@format`] | numbers in the 1985 `1.234E+05` form |
//! | [`mod@print`] | PRINT BLOCKS, CONTACTS, CORNERS, LIST tables (print-formats.md) |
//! | [`mod@plot`] | PLOT: the plotter page as PNG (tiny-skia) and SVG, WINDOW/VIEW honoured |
//! | [`mod@state_json`] | `--state-json`: the observable state as JSON with fixed keys |
//! | [`mod@dump`] | DUMP: every field of the model, readable |
//! | [`restart`] | SAVE/RESTART: versioned binary files with a magic header |
//! | [`vtk`] | VTK (extension) and `--vtk-every`: blocks and contacts for ParaView, a file series |
//!
//! Every writer takes the model read-only; none of them changes state.

pub mod dump;
pub mod format;
pub mod plot;
pub mod print;
pub mod restart;
pub mod state_json;
pub mod vtk;

pub use dump::dump;
pub use format::fmt_e;
pub use plot::{block_outline, plot, PlotSettings};
pub use print::{print_block_lists, print_blocks, print_contacts, print_corners, print_item};
pub use restart::{load, save, RestartError, SaveFile, FORMAT_VERSION, MAGIC};
pub use state_json::{state_json, write_state_json};

use std::fs::{self, File};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// Writes a file so that a crash or a full disk never leaves a half-written one under `path`:
/// the content goes to a temporary file in the same directory (so the rename cannot cross file
/// systems), is flushed to disk, and is then renamed over `path` in one step.
/// The writer is buffered and seekable (SAVE fills in its header last).
pub(crate) fn write_atomically(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>) -> io::Result<()> {
    let tmp = temp_path(path);
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp)?);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        // Best effort: the original error is the one worth reporting.
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// `dir/.name.tmp.PID` beside `dir/name`.
fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp.{}", std::process::id()))
}
