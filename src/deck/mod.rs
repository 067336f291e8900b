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
///
/// Shown as `file:line:column: message`, the form editors and compilers use; `file:line: message`
/// when the column is not known (0).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub struct DeckError {
    pub file: String,
    /// 1-based line number. Every error names a line: one about the file as a whole (an empty
    /// deck) names line 1, where the START or RESTART it lacks should have been.
    pub line: usize,
    /// 1-based column (0 when unknown).
    pub column: usize,
    pub message: String,
}

impl std::fmt::Display for DeckError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.column > 0 {
            write!(f, "{}:{}:{}: {}", self.file, self.line, self.column, self.message)
        } else {
            write!(f, "{}:{}: {}", self.file, self.line, self.message)
        }
    }
}

impl DeckError {
    pub fn new(file: &str, line: usize, column: usize, message: impl Into<String>) -> Self {
        DeckError { file: file.to_string(), line, column, message: message.into() }
    }
}
