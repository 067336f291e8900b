//! The command language of UDEC 1.2 (SL-85-1, Appendix A, "Input Commands"): free format with the
//! separators `= ( ) , /`, `*` comment lines, `+` continuation lines, commands and keywords
//! abbreviated to their upper-case prefix.
//!
//! `parse_deck` reads a whole deck into located commands before anything runs, so a typing error on
//! line 200 is reported before hours of cycling on lines 1–199.

pub mod command;
pub mod lexer;
pub mod parse;

pub use command::*;
pub use parse::parse_deck;

/// An input error: the file, line and column, and what was expected there.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{column}: {message}")]
pub struct DeckError {
    pub file: String,
    /// 1-based line number (0 when the error concerns the whole file).
    pub line: usize,
    /// 1-based column (0 when unknown).
    pub column: usize,
    pub message: String,
}

impl DeckError {
    pub fn new(file: &str, line: usize, column: usize, message: impl Into<String>) -> Self {
        DeckError { file: file.to_string(), line, column, message: message.into() }
    }
}
