//! The deck language every engine's commands are written in (SL-85-1, Appendix A, "Input
//! Commands", and D3's Appendix B share it): free format with the separators `= ( ) , /`, `*`
//! comment lines, `+` continuation lines, commands and keywords abbreviated to their upper-case
//! prefix. Here the lexer (lines → located tokens, numbers, name tables), PROPERTY's keywords
//! (`props`, one table for both engines) and the input error; the 2D engine's commands are
//! `udec::deck`, D3's `d3::deck`.

pub mod lexer;
pub mod props;

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
