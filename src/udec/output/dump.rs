//! DUMP: a full readable dump of the model state.
//!
//! In 1985 DUMP printed a range of the main memory array; addresses mean nothing here, so DUMP
//! writes every field of the `Model` instead, as pretty JSON under a heading line. Field names
//! are those of the Rust structs (src/udec/model/mod.rs). Non-finite numbers appear as `null`.

use std::io::{self, Write};

use super::format::fmt_e;
use crate::udec::model::Model;

/// Writes the heading `FULL STATE DUMP (CYCLE n, TIME t)` and then the whole model as JSON.
pub fn dump(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    writeln!(out)?;
    writeln!(out, "FULL STATE DUMP (CYCLE {}, TIME {})", model.cycle, fmt_e(model.time))?;
    writeln!(out)?;
    serde_json::to_writer_pretty(&mut *out, model)?;
    writeln!(out)
}
