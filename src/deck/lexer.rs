//! Lines → logical commands → tokens.
//!
//! This is the first half of the deck reader: it knows the *layout* rules of the UDEC 1.2 input
//! language (SL-85-1, Appendix A, "Input Commands") but nothing about what any command means.
//!
//! * "Input is free-format: parameters may be separated by any number of the following
//!   characters, in addition to spaces: `= ( ) , /`". Tabs, carriage returns and other white
//!   space count as spaces.
//! * `*` as the first non-blank character makes the line a comment.
//! * `+` as the first non-blank character makes the line a continuation of the previous command;
//!   the `+` itself is not a token. A `+` line with no command before it is an error.
//! * Blank lines (and lines holding only separators) are ignored; they do not end a command, so a
//!   `+` line after a blank or comment line still continues the command before it.
//!
//! Whole-file checks done here, before any command is looked at: NUL bytes or other control
//! characters (a binary file fed by mistake), and lines longer than [`MAX_LINE_CHARS`].
//!
//! The second half is an engine's: the 2D engine's `udec::deck::parse` turns each [`Statement`]
//! into a `udec::deck::Command`. The abbreviation rule ("upper-case letters of a command or
//! keyword must be typed, the rest are optional") is implemented here by [`lookup`] so that every
//! engine's command words and keywords share it; the name tables themselves are the engine's.

use super::DeckError;
use compact_str::CompactString;

/// The longest line accepted, in characters. The 1985 program read 80-column card images
/// (`LINE(80)` in the Program Guide); we are more generous but still refuse absurd lines, which
/// almost always mean a binary or mangled file.
pub const MAX_LINE_CHARS: usize = 4096;

/// One parameter of a command, with where it was typed.
#[derive(Clone, Debug, PartialEq)]
pub struct Token {
    /// The text as typed (case kept: SAVE/RESTART file names need it).
    pub text: CompactString,
    /// 1-based line number in the deck.
    pub line: usize,
    /// 1-based column (in characters) of the token's first character.
    pub column: usize,
    /// Which parenthesised group the token was typed in, if any: `(0,0) (1,0)` gives the first two
    /// tokens group 0 and the next two group 1. Parentheses are only separators in the language,
    /// but the grouping lets the parser notice a 3D (D3) deck, whose BLOCK corners are triples.
    pub group: Option<usize>,
}

impl Token {
    /// Whether the token looks like a number (starts with a digit, a sign or a decimal point).
    /// Such a token is never a command word or keyword; whether it really *is* a well-formed
    /// number is decided by [`parse_real`] / [`parse_int`], so `1.0x` gets a number error rather
    /// than an "unknown keyword" one.
    pub fn is_numeric(&self) -> bool {
        matches!(self.text.chars().next(), Some(c) if c.is_ascii_digit() || matches!(c, '.' | '+' | '-'))
    }

    /// The column just past the token's last character.
    pub fn end_column(&self) -> usize {
        self.column + self.text.chars().count()
    }

    /// The token text for an error message: control characters escaped, long tokens shortened.
    pub fn shown(&self) -> String {
        const MAX: usize = 40;
        let mut s: String = self.text.chars().take(MAX).flat_map(char::escape_default).collect();
        if self.text.chars().count() > MAX {
            s.push_str("...");
        }
        s
    }
}

/// A logical command: its first physical line plus any `+` continuation lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Statement {
    /// 1-based line of the command's first line.
    pub line: usize,
    /// The command as typed: the first line trimmed, then each continuation line's text after its
    /// `+` (trimmed), joined with single spaces.
    pub source: String,
    /// The tokens, command word first; never empty.
    pub tokens: Vec<Token>,
}

/// True for the characters that separate parameters (Appendix A: blanks and `= ( ) , /`).
fn is_separator(c: char) -> bool {
    c.is_whitespace() || matches!(c, '=' | '(' | ')' | ',' | '/')
}

/// A character that has no business in a text deck. Tab, CR, LF and form feed are fine (editors
/// and old card-image files produce them); any other control character (NUL above all) means the
/// file is not text.
fn is_binary(c: char) -> bool {
    c.is_control() && !matches!(c, '\t' | '\r' | '\n' | '\u{0c}')
}

/// The `binary file` error for the first character of `raw` (line `line`) that has no business in
/// a text deck.
fn check_text_line(raw: &str, line: usize, file: &str) -> Result<(), DeckError> {
    match raw.chars().enumerate().find(|&(_, c)| is_binary(c)) {
        Some((col, c)) => {
            let what = if c == '\0' { "a NUL byte".to_string() } else { format!("control character U+{:04X}", c as u32) };
            Err(DeckError::new(file, line, col + 1, format!("binary file: {what} at line {line}; a deck must be plain text")))
        }
        None => Ok(()),
    }
}

/// `split`'s `binary file` check alone, on the start of a deck (its last line may be cut short):
/// a binary file is told from a deck by its first bytes, before the rest is read.
pub(crate) fn check_text(text: &str, file: &str) -> Result<(), DeckError> {
    text.lines().enumerate().try_for_each(|(index, raw)| check_text_line(raw, index + 1, file))
}

/// Split one physical line (without its `+`) into tokens. `col0` is the 1-based column of the
/// first character of `text`; `group` carries the parenthesised-group counter through the
/// statement. A token's text is a slice of the line, kept inline (`CompactString`) when short, as
/// numbers and keywords are: a deck of 10⁶ BLOCKs has 10⁷ tokens.
fn tokenize(text: &str, line: usize, col0: usize, groups: &mut GroupState, out: &mut Vec<Token>) {
    // The current token: its first byte and its column.
    let mut current: Option<(usize, usize)> = None;
    let flush = |current: &mut Option<(usize, usize)>, end: usize, out: &mut Vec<Token>, group: Option<usize>| {
        if let Some((start, column)) = current.take() {
            out.push(Token { text: CompactString::from(&text[start..end]), line, column, group });
        }
    };
    for (i, (at, c)) in text.char_indices().enumerate() {
        if is_separator(c) {
            flush(&mut current, at, out, groups.open);
            match c {
                '(' => {
                    groups.open = Some(groups.next);
                    groups.next += 1;
                }
                ')' => groups.open = None,
                _ => {}
            }
        } else if current.is_none() {
            current = Some((at, col0 + i));
        }
    }
    flush(&mut current, text.len(), out, groups.open);
}

/// Parenthesis bookkeeping for [`Token::group`]. Unbalanced parentheses are not an error (they
/// are separators in the 1985 language); an unclosed group simply ends at the next `(` or `)`.
#[derive(Default)]
struct GroupState {
    next: usize,
    open: Option<usize>,
}

/// Split a deck into logical commands.
///
/// Errors: `binary file` (NUL or other control characters), `line too long`, and a `+`
/// continuation line with no command before it. An empty result is not an error here; the
/// parser reports "empty deck".
///
/// A long deck (a generated wall of 10⁶ BLOCK commands is 45 MB) is read in pieces on rayon's
/// threads: each piece but the first starts at a line that begins a command (its first
/// non-blank character a letter), so no statement spans two pieces, and the first error of the
/// earliest piece that has one is the first error of the file, as when read in one go.
pub fn split(text: &str, file: &str) -> Result<Vec<Statement>, DeckError> {
    split_in_pieces(text, file, PIECE_BYTES)
}

/// `split` with pieces of about `piece_bytes`.
fn split_in_pieces(text: &str, file: &str, piece_bytes: usize) -> Result<Vec<Statement>, DeckError> {
    use rayon::prelude::*;
    let starts = piece_starts(text, piece_bytes);
    let ends: Vec<usize> = starts.iter().skip(1).copied().chain([text.len()]).collect();
    // Each piece's first line number: 1 + the line ends before it.
    let breaks: Vec<usize> = starts.par_iter().zip(&ends).map(|(&a, &b)| text.as_bytes()[a..b].iter().filter(|&&c| c == b'\n').count()).collect();
    let first_lines: Vec<usize> = breaks
        .iter()
        .scan(1, |line, &n| {
            let first = *line;
            *line += n;
            Some(first)
        })
        .collect();
    let pieces: Vec<Result<Vec<Statement>, DeckError>> =
        starts.par_iter().zip(&ends).zip(&first_lines).map(|((&a, &b), &line)| split_lines(&text[a..b], line, file)).collect();
    let mut statements = Vec::new();
    for piece in pieces {
        statements.extend(piece?);
    }
    Ok(statements)
}

/// The size of a piece of deck read on one thread by [`split`].
const PIECE_BYTES: usize = 1 << 20;

/// Byte offsets where `split`'s pieces start: 0, then, about every `size` bytes, the start of the
/// next line whose first character other than blanks and tabs is an ASCII letter. Such a line is
/// neither blank, nor a comment, nor a continuation, nor a line of separators: it begins a
/// statement of its own.
fn piece_starts(text: &str, size: usize) -> Vec<usize> {
    let bytes = text.as_bytes();
    let mut starts = vec![0];
    let mut at = size;
    while at < bytes.len() {
        let Some(newline) = bytes[at - 1..].iter().position(|&c| c == b'\n') else { break };
        let line = at - 1 + newline + 1;
        let first = bytes[line..].iter().position(|&c| c != b' ' && c != b'\t').map(|k| bytes[line + k]);
        if line < bytes.len() && first.is_some_and(|c| c.is_ascii_alphabetic()) {
            starts.push(line);
            at = line + size;
        } else {
            at = line + 1;
        }
    }
    starts
}

/// `split` of the lines of `text`, the first of which is line `first_line` of the deck.
fn split_lines(text: &str, first_line: usize, file: &str) -> Result<Vec<Statement>, DeckError> {
    let mut statements: Vec<Statement> = Vec::new();
    let mut groups = GroupState::default();

    // `lines()` splits on `\n` and strips a `\r` before it, so DOS decks read the same.
    for (index, raw) in text.lines().enumerate() {
        let line = first_line + index;
        check_text_line(raw, line, file)?;
        let chars = raw.chars().count();
        if chars > MAX_LINE_CHARS {
            return Err(DeckError::new(file, line, MAX_LINE_CHARS + 1, format!("line too long ({chars} characters; at most {MAX_LINE_CHARS})")));
        }

        // Leading blanks are allowed before `*` and `+`; columns stay those of the raw line.
        let lead = raw.chars().take_while(|c| c.is_whitespace()).count();
        let body = raw.trim_start();
        match body.chars().next() {
            None => continue,      // blank line
            Some('*') => continue, // comment line
            Some('+') => {
                let rest = &body[1..];
                let Some(st) = statements.last_mut() else {
                    return Err(DeckError::new(file, line, lead + 1, "continuation line ('+') with no command before it to continue"));
                };
                let before = st.tokens.len();
                tokenize(rest, line, lead + 2, &mut groups, &mut st.tokens);
                if st.tokens.len() > before {
                    st.source.push(' ');
                    st.source.push_str(rest.trim());
                }
            }
            Some(_) => {
                groups = GroupState::default();
                let mut tokens = Vec::new();
                tokenize(body, line, lead + 1, &mut groups, &mut tokens);
                // A line of nothing but separators carries no command; treat it as blank.
                if tokens.is_empty() {
                    continue;
                }
                statements.push(Statement { line, source: body.trim_end().to_string(), tokens });
            }
        }
    }
    Ok(statements)
}

/// A command or keyword name with its minimum abbreviation (the manual's upper-case letters).
#[derive(Clone, Copy, Debug)]
pub struct Name<T> {
    /// The full name, upper case.
    pub full: &'static str,
    /// How many leading letters must be typed.
    pub min: usize,
    pub value: T,
}

/// `name("PROPERTY", "PRO", v)`: a table entry whose minimum abbreviation is `PRO`.
pub const fn name<T>(full: &'static str, min: &'static str, value: T) -> Name<T> {
    Name { full, min: min.len(), value }
}

/// Resolve a typed word against a name table (case-insensitive).
///
/// A word matches a name if it is a prefix of the full name and at least as long as the minimum
/// abbreviation. Where the manual's abbreviations clash (e.g. `FR` is a prefix of both FREE and
/// FRACTION), only the names whose minimum is satisfied count (FRACTION needs `FRA`, so `FR` is
/// FREE); if several still match, the one with the longest minimum wins, being the more specific.
pub fn lookup<T: Copy>(word: &str, names: &[Name<T>]) -> Option<T> {
    let upper = word.to_ascii_uppercase();
    names.iter().filter(|n| upper.len() >= n.min && n.full.starts_with(upper.as_str())).max_by_key(|n| n.min).map(|n| n.value)
}

/// Why a token is not a number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NumberError {
    /// Not of the form `[sign] digits [. digits] [E [sign] digits]`.
    Syntax,
    /// Well formed, but beyond the range of f64 (`1E999`), or beyond i64 for an integer.
    TooLarge,
    /// A real where an integer is required ("Real numbers may be given as integers, but not
    /// vice versa").
    NotInteger,
}

/// Parse a Fortran-style real: `1`, `-1.`, `.1`, `1E8`, `1.0E-6`, `1e+09`, `-0.95E4`; a `D`
/// exponent (`1D3`, Fortran double precision) is accepted too. `NaN`, `inf` and trailing garbage
/// (`1.0x`) are rejected: Rust's own `f64::from_str` would accept the first two.
pub fn parse_real(s: &str) -> Result<f64, NumberError> {
    let b = s.as_bytes();
    let mut i = 0;
    if matches!(b.first(), Some(b'+' | b'-')) {
        i += 1;
    }
    let int_digits = b[i..].iter().take_while(|c| c.is_ascii_digit()).count();
    i += int_digits;
    let mut frac_digits = 0;
    if b.get(i) == Some(&b'.') {
        i += 1;
        frac_digits = b[i..].iter().take_while(|c| c.is_ascii_digit()).count();
        i += frac_digits;
    }
    if int_digits + frac_digits == 0 {
        return Err(NumberError::Syntax);
    }
    let mantissa_end = i;
    if matches!(b.get(i), Some(b'e' | b'E' | b'd' | b'D')) {
        i += 1;
        if matches!(b.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let exp_digits = b[i..].iter().take_while(|c| c.is_ascii_digit()).count();
        if exp_digits == 0 {
            return Err(NumberError::Syntax);
        }
        i += exp_digits;
    }
    if i != b.len() {
        return Err(NumberError::Syntax);
    }
    // Everything checked is ASCII, so byte slicing is on char boundaries.
    let normal = format!("{}e{}", &s[..mantissa_end], if mantissa_end < s.len() { &s[mantissa_end + 1..] } else { "0" });
    let v: f64 = normal.parse().map_err(|_| NumberError::Syntax)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(NumberError::TooLarge)
    }
}

/// Parse an integer parameter (`[sign] digits`). A well-formed real such as `2.5` or `1E3` gives
/// [`NumberError::NotInteger`], so the message can say an integer was needed.
pub fn parse_int(s: &str) -> Result<i64, NumberError> {
    let digits = s.strip_prefix(['+', '-']).unwrap_or(s);
    if !digits.is_empty() && digits.bytes().all(|c| c.is_ascii_digit()) {
        return s.parse::<i64>().map_err(|_| NumberError::TooLarge);
    }
    match parse_real(s) {
        Ok(_) => Err(NumberError::NotInteger),
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deck of every layout rule (comments, blank and separator-only lines, continuations
    /// after them, indented and parenthesised lines, DOS line ends), read in pieces of a few
    /// bytes, gives the statements of one piece, and the first error of the file.
    #[test]
    fn a_deck_read_in_pieces_is_the_deck_read_whole() {
        let mut deck = String::from("START\n");
        for k in 0..400 {
            deck += &match k % 8 {
                0 => format!("BLOCK MAT=1 {k} 0 {k} 1 {} 1\n", k + 1),
                1 => "* a comment\n\n".to_string(),
                2 => format!("  PROP MAT={} (DENS=2000)\r\n", k % 5 + 1),
                3 => "+ KN=1e9\n".to_string(),
                4 => "= , /\n+ KS=1e9\n".to_string(),
                5 => format!("\tFIX {k} {} 0 1\n", k + 1),
                6 => "   \n".to_string(),
                _ => format!("SPLIT ({k},0) ({k},1)\n+ (2,3)\n"),
            };
        }
        deck += "CYCLE 10\nEND\n";
        let whole = split_lines(&deck, 1, "d").unwrap();
        for size in [1, 7, 64, 1000] {
            assert!(piece_starts(&deck, size).len() > deck.len() / size.max(40) / 2, "{size}-byte pieces");
            assert_eq!(split_in_pieces(&deck, "d", size).unwrap(), whole, "{size}-byte pieces");
        }
        // Errors in two places: the first in the file is reported, whichever piece it is in.
        let bad = deck.replacen("FIX 13", "FIX\u{1}13", 1).replacen("FIX 101", "FIX\u{0}101", 1);
        let first = split_lines(&bad, 1, "d").unwrap_err();
        assert!(first.to_string().contains("U+0001"), "{first}");
        for size in [1, 64, 1000] {
            assert_eq!(split_in_pieces(&bad, "d", size).unwrap_err().to_string(), first.to_string(), "{size}-byte pieces");
        }
    }

    #[test]
    fn reals() {
        for (s, v) in
            [("1", 1.0), ("-1.", -1.0), (".1", 0.1), ("1E8", 1e8), ("1.0E-6", 1e-6), ("1e+09", 1e9), ("-0.95E4", -9500.0), ("1D3", 1000.0), ("+2", 2.0)]
        {
            assert_eq!(parse_real(s), Ok(v), "{s}");
        }
        for s in ["", ".", "-", "1.0x", "nan", "inf", "1E", "1E+", "1..2", "1e5.0", "--1", "0x10"] {
            assert_eq!(parse_real(s), Err(NumberError::Syntax), "{s}");
        }
        assert_eq!(parse_real("1E999"), Err(NumberError::TooLarge));
        assert_eq!(parse_real("-1E999"), Err(NumberError::TooLarge));
    }

    #[test]
    fn ints() {
        assert_eq!(parse_int("12"), Ok(12));
        assert_eq!(parse_int("-3"), Ok(-3));
        assert_eq!(parse_int("2.5"), Err(NumberError::NotInteger));
        assert_eq!(parse_int("1E3"), Err(NumberError::NotInteger));
        assert_eq!(parse_int("99999999999999999999"), Err(NumberError::TooLarge));
        assert_eq!(parse_int("x"), Err(NumberError::Syntax));
        assert_eq!(parse_int("-"), Err(NumberError::Syntax));
    }

    #[test]
    fn tokens_and_groups() {
        let st = split("BLOCK MAT=1 (0,0) (1,0)\n+ (1,1)\n", "t").unwrap();
        assert_eq!(st.len(), 1);
        let t = &st[0].tokens;
        let texts: Vec<&str> = t.iter().map(|t| t.text.as_str()).collect();
        assert_eq!(texts, ["BLOCK", "MAT", "1", "0", "0", "1", "0", "1", "1"]);
        assert_eq!((t[2].line, t[2].column), (1, 11));
        assert_eq!((t[7].line, t[7].column), (2, 4));
        assert_eq!(t[3].group, t[4].group);
        assert_ne!(t[4].group, t[5].group);
        assert_eq!(t[1].group, None);
        assert_eq!(st[0].source, "BLOCK MAT=1 (0,0) (1,0) (1,1)");
    }
}
