//! The command language of UDEC 1.2 (SL-85-1, Appendix A, "Input Commands") on the shared deck
//! lexer ([`crate::udec::deck`]).
//!
//! `parse_deck` reads a whole deck into located commands before anything runs, so a typing error on
//! line 200 is reported before hours of cycling on lines 1–199.

pub mod command;
pub mod parse;

pub use crate::deck::{lexer, DeckError};
pub use command::*;
pub use parse::parse_deck;
