//! The 2D engine's outputs: PRINT tables, PLOT files (PNG and SVG), the state JSON, the full
//! DUMP, VTK and SAVE/RESTART files (DESIGN.md §5), on the shared machinery of [`crate::udec::output`].
//!
//! | file | what |
//! |---|---|
//! | [`mod@print`] | PRINT BLOCKS, CONTACTS, CORNERS, LIST tables (print-formats.md) |
//! | [`mod@plot`] | PLOT: the plotter page as PNG (tiny-skia) and SVG, WINDOW/VIEW honoured |
//! | [`mod@state_json`] | `--state-json`: the observable state as JSON with fixed keys |
//! | [`mod@dump`] | DUMP: every field of the model, readable |
//! | [`restart`] | SAVE/RESTART: versioned binary files with a magic header |
//! | [`vtk`] | VTK (extension) and `--vtk-every`: blocks and contacts for ParaView, a file series |
//!
//! Every writer takes the model read-only; none of them changes state.

pub mod dump;
pub mod plot;
pub mod print;
pub mod restart;
pub mod state_json;
pub mod vtk;

pub(crate) use crate::output::write_atomically;
pub use crate::output::{fmt_e, font, format, provenance};
pub use dump::dump;
pub use plot::{block_outline, plot, PlotSettings};
pub use print::{print_block_lists, print_blocks, print_contacts, print_corners, print_item};
pub use restart::{load, save, RestartError, SaveFile, FORMAT_VERSION, MAGIC};
pub use state_json::{state_json, write_state_json};
