//! Tokens → commands: the second half of the deck reader.
//!
//! [`lexer::split`] has already cut the deck into logical commands (continuations joined,
//! comments dropped) and tokens with their line and column. Here each command word is resolved,
//! its parameters are read and checked against SL-85-1 Appendix A ("Input Commands"), and a
//! [`Command`] comes out. The first error stops the reading and names the line and column of the
//! offending token (or, when something is *missing*, the place just past the command's last
//! token).
//!
//! # Abbreviations
//!
//! "Upper-case letters in a command or parameter must be typed; the remaining letters are
//! optional." The manual's capitalisation clashes in places (`F` is printed for FIX, FRACTION's
//! `FRA` and FREE's `FR` overlap, `P` is PRINT and PLOT and ...), so blockdem fixes the minimum
//! prefix of every name as below. A typed word matches a name when it is a prefix of the full name
//! and at least the minimum long; see [`lexer::lookup`] for how remaining ties are broken.
//!
//! | command | min | | command | min | | command | min |
//! |---|---|---|---|---|---|---|---|
//! | BLOCK | `B` | | FREE | `FR` | | PROPERTY | `PRO` |
//! | CHANGE | `CH` | | GENERATE | `GE` | | RESTART | `R` |
//! | CYCLE | `C` | | GRAVITY | `G` | | RSET | `RS` |
//! | DAMPING | `D` | | LINK | `LI` | | ROUND | `RO` |
//! | DELETE | `DE` | | LOAD | `L` | | SAVE | `SA` |
//! | DUMP | `DU` | | PFIX | `PF` | | SPLIT | `SP` |
//! | END | `E` | | PFREE | `PFR` | | START | `STA` |
//! | FIX | `F` | | PLOT | `PL` | | STOP | `S` |
//! | FRACTION | `FRA` | | PRINT | `P` | | VIEW | `V` |
//! | FLUID | `FL` | | VELOCITY (extension) | `VE` | | WINDOW | `W` |
//! | | | | VTK (extension) | `VT` | | | |
//!
//! Keywords:
//!
//! | command | keywords (minimum prefix) |
//! |---|---|
//! | PROPERTY | MATERIAL `M` (first), BULK `B` or `K`, G, DENSITY `D`, KN, KS, COHESION `C`, FRICTION `F`, JKN, JKS, JCOHESION `JC`, JFRICTION `JF`, TF `T`, JPERM `JP`, CPERM `CP`, AZERO `AZ`, ARES `AR` |
//! | BLOCK, SPLIT | MATERIAL `M`, CONSTITUTIVE `CO` |
//! | CHANGE | SDEF `S`, FDEF `F`, MATERIAL `M`, CONSTITUTIVE `CO` |
//! | DAMPING | MASS `M`, STIFFNESS `S`, INTERNAL `I` |
//! | GENERATE | AUTOMATIC `A`, MANUAL `M`, GRIDPOINTS `GR`, ZONES `Z` |
//! | PFIX, PFREE | OUTER `O`, AT `AT` (then x y) |
//! | PLOT | NOFIX `N`, ZONES `Z`, NC, VELOCITY `V` |
//! | PRINT | BLOCKS `B`, CONTACTS `C`, CORNERS `COR`, DOMAINS `D`, LIST `L`, DLIST `DL`, FLOWS `F`, ENERGY `E` |
//!
//! # Choices beyond the manual
//!
//! * Parameters named i..n in the manual (`n`, `m`, `ix1`, zone triples) must be typed as
//!   integers: "Integers must be given for parameters starting with i, j, k, l, m, n. Real numbers
//!   may be given as integers, but not vice versa."
//! * A selection range with x1 ≥ x2 or y1 ≥ y2 selects nothing (the manual's range is the open
//!   x1 < x < x2); it is reported as an error since it is always a typing slip.
//! * RSET poked a value into the 1985 main array at a raw address; it is always an error here.
//! * A 3D (D3, Appendix B) deck is recognised by a BLOCK whose parenthesised groups hold three
//!   numbers, or GRAVITY with three components, and refused as "not supported yet" at that line,
//!   like the 2D commands whose physics comes later (D3 has a language of its own, so the rest of
//!   such a deck is not read as 2D commands).
//! * SAVE and RESTART take one bare file-name token, case kept. Since `/` is a separator in the
//!   language, a name with a directory part (`runs/a.sav`) reads as two tokens and is refused
//!   as "too many values".
//! * Commands after END are not read. END itself is returned (the executor may ignore it).

use super::command::*;
use super::lexer::{self, lookup, name, Name, NumberError, Token};
use super::{DeckError, Located};
// PROPERTY's keywords: the chassis's table (`deck::props`), shared with D3.
use crate::deck::props::PROP_KEYS;

type Result<T> = std::result::Result<T, DeckError>;

/// The command words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Word {
    Block,
    Change,
    Cycle,
    Damping,
    Delete,
    Dump,
    End,
    Fix,
    Fraction,
    Fluid,
    Free,
    Generate,
    Gravity,
    Link,
    Load,
    PFix,
    PFree,
    Plot,
    Print,
    Property,
    Restart,
    RSet,
    Round,
    Save,
    Set,
    Split,
    Start,
    Stop,
    View,
    Window,
    Velocity,
    Vtk,
}

/// Command names and their minimum abbreviations (see the table in the module docs).
const COMMANDS: &[Name<Word>] = &[
    name("BLOCK", "B", Word::Block),
    name("CHANGE", "CH", Word::Change),
    name("CYCLE", "C", Word::Cycle),
    name("DAMPING", "D", Word::Damping),
    name("DELETE", "DE", Word::Delete),
    name("DUMP", "DU", Word::Dump),
    name("END", "E", Word::End),
    name("FIX", "F", Word::Fix),
    name("FLUID", "FL", Word::Fluid),
    name("FRACTION", "FRA", Word::Fraction),
    name("FREE", "FR", Word::Free),
    name("GENERATE", "GE", Word::Generate),
    name("GRAVITY", "G", Word::Gravity),
    name("LINK", "LI", Word::Link),
    name("LOAD", "L", Word::Load),
    name("PFIX", "PF", Word::PFix),
    name("PFREE", "PFR", Word::PFree),
    name("PLOT", "PL", Word::Plot),
    name("PRINT", "P", Word::Print),
    name("PROPERTY", "PRO", Word::Property),
    name("RESTART", "R", Word::Restart),
    name("ROUND", "RO", Word::Round),
    name("RSET", "RS", Word::RSet),
    name("SAVE", "SA", Word::Save),
    name("SET", "SE", Word::Set),
    name("SPLIT", "SP", Word::Split),
    name("START", "STA", Word::Start),
    name("STOP", "S", Word::Stop),
    name("VELOCITY", "VE", Word::Velocity),
    name("VIEW", "V", Word::View),
    name("VTK", "VT", Word::Vtk),
    name("WINDOW", "W", Word::Window),
];

/// MATERIAL / CONSTITUTIVE, as BLOCK, SPLIT and CHANGE take them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MatCons {
    Material,
    Constitutive,
    Sdef,
    Fdef,
}

const MAT_CONS: &[Name<MatCons>] = &[name("MATERIAL", "M", MatCons::Material), name("CONSTITUTIVE", "CO", MatCons::Constitutive)];

const CHANGE_KEYS: &[Name<MatCons>] = &[
    name("SDEF", "S", MatCons::Sdef),
    name("FDEF", "F", MatCons::Fdef),
    name("MATERIAL", "M", MatCons::Material),
    name("CONSTITUTIVE", "CO", MatCons::Constitutive),
];

const DAMP_KEYS: &[Name<DampMode>] =
    &[name("MASS", "M", DampMode::Mass), name("STIFFNESS", "S", DampMode::Stiffness), name("INTERNAL", "I", DampMode::Internal)];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum GenKey {
    Auto,
    Manual,
    Grid,
    Zones,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SetKey {
    Overlap,
    Damin,
}

const SET_KEYS: &[Name<SetKey>] = &[name("OVERLAP", "O", SetKey::Overlap), name("DAMIN", "DA", SetKey::Damin)];

const OVERLAP_KEYS: &[Name<OverlapPolicy>] = &[name("ACCEPT", "A", OverlapPolicy::Accept), name("REFUSE", "R", OverlapPolicy::Refuse)];

const GEN_KEYS: &[Name<GenKey>] =
    &[name("AUTOMATIC", "A", GenKey::Auto), name("MANUAL", "M", GenKey::Manual), name("GRIDPOINTS", "GR", GenKey::Grid), name("ZONES", "Z", GenKey::Zones)];

const OUTER: &[Name<()>] = &[name("OUTER", "O", ())];
/// PFIX/PFREE AT x y: the domain at a point.
const AT: &[Name<()>] = &[name("AT", "AT", ())];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PlotKey {
    NoFix,
    Zones,
    Nc,
    Vel,
    Pressure,
}

const PLOT_KEYS: &[Name<PlotKey>] = &[
    name("NOFIX", "N", PlotKey::NoFix),
    name("ZONES", "Z", PlotKey::Zones),
    name("NC", "NC", PlotKey::Nc),
    name("VELOCITY", "V", PlotKey::Vel),
    name("PRESSURE", "P", PlotKey::Pressure),
];

const PRINT_KEYS: &[Name<PrintItem>] = &[
    name("BLOCKS", "B", PrintItem::Blocks),
    name("CONTACTS", "C", PrintItem::Contacts),
    name("CORNERS", "COR", PrintItem::Corners),
    name("DOMAINS", "D", PrintItem::Domains),
    name("LIST", "L", PrintItem::List),
    name("DLIST", "DL", PrintItem::DList),
    name("FLOWS", "F", PrintItem::Flows),
    name("ENERGY", "E", PrintItem::Energy),
];

/// The full names of a table, for "expected one of ..." messages.
fn names<T>(table: &[Name<T>]) -> String {
    table.iter().map(|n| n.full).collect::<Vec<_>>().join(", ")
}

/// The name of `table` nearest to a word that is none of them (issue 27 item 9: "did you
/// mean"), by the edit distance with transpositions of the word against each full name and
/// against each name cut to the word's length (an abbreviation typed wrong); None when even the
/// nearest is more than a third of the word's letters (at least one) away.
fn nearest_name<T>(word: &str, table: &[Name<T>]) -> Option<&'static str> {
    let word: Vec<char> = word.to_ascii_uppercase().chars().collect();
    let limit = (word.len() / 3).max(1);
    table
        .iter()
        .map(|n| {
            let full: Vec<char> = n.full.chars().collect();
            let cut = &full[..full.len().min(word.len().max(n.min))];
            (edit_distance(&word, &full).min(edit_distance(&word, cut)), n.full)
        })
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, name)| name)
}

/// Optimal string alignment distance: insertions, deletions, substitutions and swaps of two
/// neighbours each count one.
fn edit_distance(a: &[char], b: &[char]) -> usize {
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            d[i][j] = (d[i - 1][j] + 1).min(d[i][j - 1] + 1).min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d[i][j] = d[i][j].min(d[i - 2][j - 2] + 1);
            }
        }
    }
    d[a.len()][b.len()]
}

fn full_name(w: Word) -> &'static str {
    COMMANDS.iter().find(|n| n.value == w).map_or("?", |n| n.full)
}

/// The manual's synopsis of each command, quoted in messages about missing or extra values.
fn usage(w: Word) -> &'static str {
    match w {
        Word::Block => "BLOCK [MATERIAL n] [CONSTITUTIVE m] x1 y1 x2 y2 ...",
        Word::Change => "CHANGE x1 x2 y1 y2 [SDEF|FDEF] [MATERIAL n] [CONSTITUTIVE m]",
        Word::Cycle => "CYCLE n",
        Word::Damping => "DAMPING fcrit freq [MASS|STIFFNESS|INTERNAL]",
        Word::Delete => "DELETE x1 x2 y1 y2",
        Word::Dump => "DUMP [n m]",
        Word::End => "END",
        Word::Fix => "FIX x1 x2 y1 y2",
        Word::Fraction => "FRACTION f",
        Word::Fluid => "FLUID rhow bulkw",
        Word::Free => "FREE x1 x2 y1 y2",
        Word::Generate => "GENERATE x1 x2 y1 y2 AUTOMATIC amax | MANUAL GRIDPOINTS x y ... ZONES l m n ...",
        Word::Gravity => "GRAVITY gx gy",
        Word::Link => "LINK x1 y1 x2 y2",
        Word::Load => "LOAD x1 x2 y1 y2 fx fy",
        Word::PFix => "PFIX (n | OUTER | AT x y) p",
        Word::PFree => "PFREE (n | OUTER | AT x y)",
        Word::Plot => "PLOT [NOFIX] [ZONES] [NC] [VEL]",
        Word::Print => "PRINT BLOCKS|CONTACTS|CORNERS|DOMAINS|LIST|DLIST|FLOWS|ENERGY ...",
        Word::Property => "PROPERTY MATERIAL n keyword value ...",
        Word::Restart => "RESTART [file]",
        Word::RSet => "RSET v ia ioff",
        Word::Round => "ROUND d",
        Word::Save => "SAVE [file]",
        Word::Set => "SET OVERLAP ACCEPT|REFUSE or SET DAMIN a",
        Word::Split => "SPLIT x1 y1 x2 y2 [MATERIAL n] [CONSTITUTIVE m]",
        Word::Start => "START",
        Word::Stop => "STOP",
        Word::View => "VIEW ix1 ix2 iy1 iy2",
        Word::Window => "WINDOW x1 x2 y1 y2",
        Word::Velocity => "VELOCITY x1 x2 y1 y2 vx vy [w]",
        Word::Vtk => "VTK",
    }
}

/// "Not a number" message, with a word for NaN/infinity (which Rust would otherwise parse).
fn not_a_number(what: &str, t: &Token, integer: bool) -> String {
    let bare = t.text.trim_start_matches(['+', '-']).to_ascii_lowercase();
    let kind = if matches!(bare.as_str(), "nan" | "inf" | "infinity") {
        "a finite number"
    } else if integer {
        "an integer"
    } else {
        "a number"
    };
    match unit_after_number(&t.text) {
        Some(unit) => format!("expected {kind} for {what}, found '{}': units are not accepted ('{unit}'); {UNITS_ADVICE}", t.shown()),
        None => format!("expected {kind} for {what}, found '{}'", t.shown()),
    }
}

/// What to do instead of writing units (issue 27 item 9: `GRAV 0 -10m/s2` read as a number short).
const UNITS_ADVICE: &str = "give numbers alone, all in one consistent set of units (e.g. SI: m, kg, s, N, Pa)";

/// The unit written straight after a number (`-10m` → `m`, `2.5E9Pa` → `Pa`), if the text is a
/// number followed by letters that are not its exponent.
fn unit_after_number(text: &str) -> Option<&str> {
    let body = text.trim_start_matches(['+', '-']);
    let digits = body.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(body.len());
    if digits == 0 || !body[..digits].contains(|c: char| c.is_ascii_digit()) {
        return None;
    }
    let mut rest = &body[digits..];
    // An exponent (E5, D-3) is part of the number.
    if let Some(exp) = rest.strip_prefix(['e', 'E', 'd', 'D']) {
        let exp_body = exp.trim_start_matches(['+', '-']);
        let n = exp_body.find(|c: char| !c.is_ascii_digit()).unwrap_or(exp_body.len());
        if n > 0 {
            rest = &exp_body[n..];
        }
    }
    // A second exponent (`1e5e3`) is a malformed number, not a unit.
    let exponent_like = rest.strip_prefix(['e', 'E', 'd', 'D']).is_some_and(|r| r.starts_with(|c: char| c.is_ascii_digit() || c == '+' || c == '-'));
    (rest.starts_with(|c: char| c.is_alphabetic()) && !exponent_like).then_some(rest)
}

/// Whether a word standing where a number or keyword belongs is a unit (`GRAV 0 -10 m/s2`).
fn is_unit_word(text: &str) -> bool {
    const UNITS: &[&str] = &[
        "m", "mm", "cm", "km", "s", "s2", "sec", "kg", "g", "t", "n", "kn", "mn", "pa", "kpa", "mpa", "gpa", "psi", "m2", "m3", "rad", "deg", "hz", "j", "kj",
        "kg/m3",
    ];
    UNITS.contains(&text.to_ascii_lowercase().as_str())
}

/// The parameters of one command, read left to right.
struct Args<'a> {
    file: &'a str,
    word: Word,
    /// The command word's token (for errors about the command as a whole, e.g. RSET).
    head: &'a Token,
    toks: &'a [Token],
    pos: usize,
    /// The command as typed (for file names, which may hold the separator '/').
    source: &'a str,
}

impl<'a> Args<'a> {
    fn name(&self) -> &'static str {
        full_name(self.word)
    }

    fn at(&self, t: &Token, msg: impl Into<String>) -> DeckError {
        DeckError::new(self.file, t.line, t.column, msg)
    }

    /// An error about something missing: placed just past the command's last token, which is
    /// on the line where the value should have been typed.
    fn at_end(&self, msg: impl Into<String>) -> DeckError {
        let last = self.toks.last().unwrap_or(self.head);
        DeckError::new(self.file, last.line, last.end_column(), msg)
    }

    fn next(&mut self) -> Option<&'a Token> {
        let t = self.toks.get(self.pos);
        if t.is_some() {
            self.pos += 1;
        }
        t
    }

    fn missing(&self, what: &str) -> DeckError {
        self.at_end(format!("{} needs {what} ({})", self.name(), usage(self.word)))
    }

    fn too_many(&self, t: &Token) -> DeckError {
        self.at(t, format!("too many values for {}: unexpected '{}' ({})", self.name(), t.shown(), usage(self.word)))
    }

    /// No tokens may be left.
    fn finish(&self) -> Result<()> {
        match self.toks.get(self.pos) {
            Some(t) => Err(self.too_many(t)),
            None => Ok(()),
        }
    }

    /// Read a token as a real number.
    fn real_of(&self, t: &Token, what: &str) -> Result<f64> {
        self.real_named(t, || what.to_string())
    }

    /// `real_of` with the quantity's name made only for an error message (a deck of 10⁶ BLOCKs
    /// reads 8·10⁶ coordinates).
    fn real_named(&self, t: &Token, what: impl FnOnce() -> String) -> Result<f64> {
        lexer::parse_real(&t.text).map_err(|e| {
            let what = what();
            match e {
                NumberError::TooLarge => self.at(t, format!("the number '{}' given for {what} is out of range (beyond about 1.8E308)", t.shown())),
                _ => self.at(t, not_a_number(&what, t, false)),
            }
        })
    }

    /// Read a token as an integer (parameters named i..n in the manual).
    fn int_of(&self, t: &Token, what: &str) -> Result<i64> {
        lexer::parse_int(&t.text).map_err(|e| match e {
            NumberError::TooLarge => self.at(t, format!("the integer '{}' given for {what} is out of range", t.shown())),
            _ => self.at(t, not_a_number(what, t, true)),
        })
    }

    fn real(&mut self, what: &str) -> Result<(f64, &'a Token)> {
        let t = self.next().ok_or_else(|| self.missing(what))?;
        Ok((self.real_of(t, what)?, t))
    }

    fn int(&mut self, what: &str) -> Result<(i64, &'a Token)> {
        let t = self.next().ok_or_else(|| self.missing(what))?;
        Ok((self.int_of(t, what)?, t))
    }

    /// A material or constitutive number: a positive integer.
    fn id(&mut self, what: &str) -> Result<u32> {
        let (v, t) = self.int(what)?;
        self.id_of(v, t, what)
    }

    fn id_of(&self, v: i64, t: &Token, what: &str) -> Result<u32> {
        match u32::try_from(v) {
            Ok(n) if n >= 1 => Ok(n),
            _ => Err(self.at(t, format!("{what} must be a positive integer, found '{}'", t.shown()))),
        }
    }

    fn positive(&self, v: f64, t: &Token, what: &str) -> Result<f64> {
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.at(t, format!("{what} must be positive, found {}", t.shown())))
        }
    }

    fn non_negative(&self, v: f64, t: &Token, what: &str) -> Result<f64> {
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(self.at(t, format!("{what} must not be negative, found {}", t.shown())))
        }
    }

    /// Set a keyword's value once; a second occurrence is an error (it is a slip, and which of
    /// the two the user meant cannot be known).
    fn once<T>(&self, slot: &mut Option<T>, v: T, t: &Token) -> Result<()> {
        if slot.is_some() {
            return Err(self.at(t, format!("'{}' is given twice in this {} command", t.shown(), self.name())));
        }
        *slot = Some(v);
        Ok(())
    }

    /// The common shape "numbers in fixed positions, keywords anywhere": numeric tokens fill
    /// `slots` in order (the first `required` of them must be given); words are looked up in
    /// `keywords` and handed to `on_kw`, which may read the keyword's own value. Returns the
    /// numeric tokens, unparsed, so the caller parses each with its slot's name.
    fn walk<K: Copy>(
        &mut self,
        slots: &[&str],
        required: usize,
        keywords: &[Name<K>],
        mut on_kw: impl FnMut(&mut Self, K, &'a Token) -> Result<()>,
    ) -> Result<Vec<&'a Token>> {
        let mut nums: Vec<&'a Token> = Vec::new();
        while let Some(t) = self.next() {
            // A number with a unit stuck to it (`-10m/s2`: '-10m' then 's2') is that number's
            // error, and a unit after a number (`-10 m/s2`) says that units are not accepted.
            if !t.is_numeric() && lookup(&t.text, keywords).is_none() {
                let slot = |t: &Token| nums.iter().position(|n| std::ptr::eq(*n, t)).map_or("a number", |i| slots[i.min(slots.len() - 1)]);
                if let Some(n) = nums.iter().find(|n| unit_after_number(&n.text).is_some() && lexer::parse_real(&n.text).is_err()) {
                    return Err(self.at(n, format!("{} ({})", not_a_number(slot(n), n, false), usage(self.word))));
                }
                if is_unit_word(&t.text) {
                    return Err(self.at(t, format!("units are not accepted: found '{}' after the numbers; {UNITS_ADVICE} ({})", t.shown(), usage(self.word))));
                }
            }
            if t.is_numeric() {
                if nums.len() >= slots.len() {
                    return Err(self.too_many(t));
                }
                nums.push(t);
            } else if let Some(k) = lookup(&t.text, keywords) {
                on_kw(self, k, t)?;
            } else if nums.len() < required || (keywords.is_empty() && nums.len() < slots.len()) {
                let msg = not_a_number(slots[nums.len()], t, false);
                return Err(self.at(t, format!("{msg} ({})", usage(self.word))));
            } else if keywords.is_empty() {
                return Err(self.too_many(t));
            } else {
                return Err(self.at(t, format!("unknown keyword '{}' for {}; it takes {}", t.shown(), self.name(), names(keywords))));
            }
        }
        if nums.len() < required {
            // Too few numbers with a malformed one among them is that number's error: `GRAVITY
            // 0-10` is two numbers run together, not one number short.
            if let Some((i, t)) = nums.iter().enumerate().find(|(_, t)| lexer::parse_real(&t.text) == Err(NumberError::Syntax)) {
                let joined = t.text[1..].contains(['+', '-']) && !t.text[1..].to_ascii_lowercase().contains(['e', 'd']);
                let hint = if joined { "; separate numbers with blanks or commas" } else { "" };
                return Err(self.at(t, format!("{}{hint} ({})", not_a_number(slots[i], t, false), usage(self.word))));
            }
            return Err(self.at_end(format!("{} needs {required} numbers ({}), found {}", self.name(), usage(self.word), nums.len())));
        }
        Ok(nums)
    }

    /// Read the tokens of x1 x2 y1 y2 as a selection range, which must not be empty.
    fn range(&self, t: &[&Token]) -> Result<Range> {
        let x1 = self.real_of(t[0], "x1")?;
        let x2 = self.real_of(t[1], "x2")?;
        let y1 = self.real_of(t[2], "y1")?;
        let y2 = self.real_of(t[3], "y2")?;
        self.ordered(x1, x2, t[0], t[1], "x1", "x2")?;
        self.ordered(y1, y2, t[2], t[3], "y1", "y2")?;
        Ok(Range { x1, x2, y1, y2 })
    }

    fn ordered<T: PartialOrd>(&self, a: T, b: T, ta: &Token, tb: &Token, na: &str, nb: &str) -> Result<()> {
        if a < b {
            Ok(())
        } else {
            Err(self.at(tb, format!("{} range is empty: {na} ({}) must be less than {nb} ({})", self.name(), ta.shown(), tb.shown())))
        }
    }

    /// Numbers only: exactly `slots.len()` reals.
    fn reals(&mut self, slots: &[&str]) -> Result<Vec<f64>> {
        let toks = self.walk::<()>(slots, slots.len(), &[], |_, _, _| Ok(()))?;
        toks.iter().zip(slots).map(|(t, s)| self.real_of(t, s)).collect()
    }

    /// A domain reference: a domain number, OUTER, or AT x y.
    fn domain(&mut self) -> Result<DomainRef> {
        let what = "the domain (a domain number, OUTER, or AT x y)";
        let t = self.next().ok_or_else(|| self.missing(what))?;
        if t.is_numeric() {
            let v = self.int_of(t, "the domain number")?;
            return u32::try_from(v)
                .map(DomainRef::Number)
                .map_err(|_| self.at(t, format!("the domain number must be a non-negative integer, found '{}'", t.shown())));
        }
        if lookup(&t.text, AT).is_some() {
            let (x, _) = self.real("x of the point AT x y")?;
            let (y, _) = self.real("y of the point AT x y")?;
            return Ok(DomainRef::At([x, y]));
        }
        match lookup(&t.text, OUTER) {
            Some(()) => Ok(DomainRef::Outer),
            None => Err(self.at(t, format!("expected {what}, found '{}'", t.shown()))),
        }
    }
}

/// Parse a whole deck. `file` is the name errors carry.
///
/// Returns every command up to and including END (commands after END are ignored; END may be
/// missing), or the first error.
pub fn parse_deck(text: &str, file: &str) -> Result<Vec<Located>> {
    // A byte-order mark, as some Windows editors write it, is not part of the first command.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let statements = lexer::split(text, file)?;
    if statements.is_empty() {
        return Err(DeckError::new(file, 1, 1, "empty deck: no commands (only blank or comment lines); expected START or RESTART as the first command"));
    }
    // Each statement is read on its own, in parallel (a generated deck may hold 10⁶ BLOCKs),
    // then taken in order: the first error in the file is the one reported, and nothing after
    // END counts.
    use rayon::prelude::*;
    let n = statements.len();
    let commands: Vec<(Result<Command>, usize, String)> =
        statements.into_par_iter().enumerate().with_min_len(256).map(|(i, st)| (statement(&st, i == 0, file), st.line, st.source)).collect();
    let mut out = Vec::with_capacity(n);
    for (command, line, source) in commands {
        let command = command?;
        let end = command == Command::End;
        out.push(Located { command, line, source });
        if end {
            break;
        }
    }
    Ok(out)
}

/// One statement's command; `first`: the deck's first, which must be START or RESTART.
fn statement(st: &lexer::Statement, first: bool, file: &str) -> Result<Command> {
    let head = &st.tokens[0];
    let word = lookup(&head.text, COMMANDS).filter(|_| !head.is_numeric()).ok_or_else(|| {
        let hint = nearest_name(&head.text, COMMANDS).map(|n| format!(" (did you mean {n}?)")).unwrap_or_default();
        DeckError::new(file, head.line, head.column, format!("unknown command '{}'{hint}; expected one of {}", head.shown(), names(COMMANDS)))
    })?;
    // "The first command must be START or RESTART."
    if first && !matches!(word, Word::Start | Word::Restart) {
        return Err(DeckError::new(file, head.line, head.column, format!("the first command must be START or RESTART, found {}", full_name(word))));
    }
    let mut args = Args { file, word, head, toks: &st.tokens[1..], pos: 0, source: &st.source };
    parse_command(&mut args)
}

/// Parse a deck read as raw bytes: text that is not valid UTF-8 is refused as a binary file,
/// except in comment lines, which are read as Latin-1 ([`lenient_text`]).
pub fn parse_deck_bytes(bytes: &[u8], file: &str) -> Result<Vec<Located>> {
    match lenient_text(bytes) {
        Ok(text) => parse_deck(&text, file),
        Err(bad) => Err(not_utf8(bytes, bad, file)),
    }
}

/// The deck's bytes as text: UTF-8, except that a comment line (`*` its first non-blank
/// character) that is not UTF-8 is read as Latin-1 — an editor's `°` or `é` (0xB0, 0xE9) in a
/// comment does not make a deck binary (issue 27 item 9). Elsewhere a byte that is not UTF-8 is
/// refused: its offset is the error.
pub fn lenient_text(bytes: &[u8]) -> std::result::Result<std::borrow::Cow<'_, str>, usize> {
    if let Ok(text) = std::str::from_utf8(bytes) {
        return Ok(text.into());
    }
    let mut text = String::with_capacity(bytes.len() + 16);
    let mut start = 0;
    for line in bytes.split_inclusive(|&b| b == b'\n') {
        match std::str::from_utf8(line) {
            Ok(t) => text.push_str(t),
            Err(e) => {
                let comment = line.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'*');
                if !comment {
                    return Err(start + e.valid_up_to());
                }
                text.extend(line.iter().map(|&b| char::from(b)));
            }
        }
        start += line.len();
    }
    Ok(text.into())
}

/// The `binary file` error for the byte at `bad`, the first that is not UTF-8.
fn not_utf8(bytes: &[u8], bad: usize, file: &str) -> DeckError {
    let before = &bytes[..bad];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    // The column of the first bad byte, in characters of the (valid) text before it.
    let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let column = std::str::from_utf8(&before[line_start..]).map_or(0, |t| t.chars().count()) + 1;
    DeckError::new(
        file,
        line,
        column,
        format!("binary file: byte 0x{:02X} is not UTF-8 text (line {line}, column {column}); a deck must be plain text", bytes[bad]),
    )
}

/// The largest deck read, in bytes: 1 GiB, some 2·10⁷ BLOCK commands (twenty times the
/// 10⁶-block walls the benchmarks generate, 45 MB). Reading stops there, so that an input with
/// no end (a FIFO fed for ever, `/dev/stdin` from `yes`) is an error, not all of the memory.
pub const MAX_DECK_BYTES: usize = 1 << 30;

/// The start of a deck, read and checked for binary bytes before the rest: `/dev/zero`, or a
/// binary file given by mistake, is refused at once instead of being read to its end (if any).
pub const FIRST_BYTES: usize = 1 << 16;

/// Why a deck file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot read the deck {file}: {error}")]
    Io { file: String, error: std::io::Error },
    /// Not a deck: a binary file, or more than [`MAX_DECK_BYTES`].
    #[error(transparent)]
    Deck(#[from] DeckError),
}

/// Reads the deck at `path` (named `file` in errors) for [`parse_deck_bytes`]: a regular file,
/// or a FIFO, `/dev/stdin` or any other stream. Its first [`FIRST_BYTES`] (64 KiB) are checked as text
/// (UTF-8 with no NUL or other control character) before the rest is read, and reading stops
/// past [`MAX_DECK_BYTES`].
pub fn read_deck(path: &std::path::Path, file: &str) -> std::result::Result<Vec<u8>, ReadError> {
    let io = |error| ReadError::Io { file: file.to_string(), error };
    let source = std::fs::File::open(path).map_err(io)?;
    // A regular file's length is known: the bytes are read into one allocation, as fs::read does.
    let size = source.metadata().ok().filter(|m| m.is_file()).map_or(0, |m| m.len());
    read_deck_from(source, size.min(MAX_DECK_BYTES as u64 + 1) as usize, file, MAX_DECK_BYTES)
}

/// [`read_deck`] from any reader, with room for `size` bytes reserved and at most `limit` read.
fn read_deck_from(mut source: impl std::io::Read, size: usize, file: &str, limit: usize) -> std::result::Result<Vec<u8>, ReadError> {
    use std::io::Read;
    let io = |error| ReadError::Io { file: file.to_string(), error };
    let mut bytes = Vec::with_capacity(size);
    (&mut source).take(FIRST_BYTES.min(limit + 1) as u64).read_to_end(&mut bytes).map_err(io)?;
    let text = match lenient_text(&bytes) {
        Ok(text) => text,
        // A character cut at the end of the first bytes is whole in the deck.
        Err(bad) if std::str::from_utf8(&bytes[bad..]).is_err_and(|e| e.error_len().is_none() && e.valid_up_to() == 0) => {
            lenient_text(&bytes[..bad]).map_err(|bad| not_utf8(&bytes, bad, file))?
        }
        Err(bad) => return Err(not_utf8(&bytes, bad, file).into()),
    };
    lexer::check_text(&text, file)?;
    (&mut source).take((limit + 1).saturating_sub(bytes.len()) as u64).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() > limit {
        let line = bytes[..limit].iter().filter(|&&b| b == b'\n').count() + 1;
        let message =
            format!("the deck goes on past {limit} bytes, the most a deck may hold (a wall of 10⁶ blocks is 45 MB): an input with no end, or not a deck");
        return Err(DeckError::new(file, line, 0, message).into());
    }
    Ok(bytes)
}

/// The text after the command word, less blanks and the separators other than '/'.
fn file_name_as_typed(source: &str, word: &str) -> Option<String> {
    let start = source.find(word)? + word.len();
    let name = source[start..].trim_matches(|c: char| c.is_whitespace() || matches!(c, '=' | '(' | ')' | ','));
    (!name.is_empty() && !name.contains(char::is_whitespace)).then(|| name.to_string())
}

/// SAVE's and RESTART's optional file name. A name may hold '/', which the 1985 language counts
/// as a separator, so when the text after the command word is one blank-free word it is taken whole
/// (consuming the tokens the '/'s split it into); otherwise the first token is the name and any
/// other is reported as too many values.
fn file_name(a: &mut Args) -> Option<String> {
    let first = a.next()?.text.to_string();
    match file_name_as_typed(a.source, &a.head.text) {
        Some(whole) => {
            a.pos = a.toks.len();
            Some(whole)
        }
        None => Some(first),
    }
}

fn parse_command(a: &mut Args) -> Result<Command> {
    let cmd = match a.word {
        Word::Start => Command::Start,
        Word::Stop => Command::Stop,
        Word::End => Command::End,
        Word::Vtk => Command::Vtk,
        Word::Restart => Command::Restart { file: file_name(a) },
        Word::Save => Command::Save { file: file_name(a) },
        Word::Set => set(a)?,
        Word::RSet => {
            return Err(a.at(
                a.head,
                "RSET wrote a value into the 1985 program's main array at a raw memory address; addresses \
                 have no meaning in blockdem (use PROPERTY, CHANGE or the command that sets the quantity)",
            ))
        }
        Word::Block => block(a)?,
        Word::Split => split(a)?,
        Word::Change => change(a)?,
        Word::Cycle => {
            let (n, t) = a.int("the number of cycles n")?;
            let n = u64::try_from(n).map_err(|_| a.at(t, format!("a negative cycle count is not allowed, found {}", t.shown())))?;
            Command::Cycle { n }
        }
        Word::Damping => damping(a)?,
        Word::Delete => Command::Delete { range: range_only(a)? },
        Word::Fix => Command::Fix { range: range_only(a)? },
        Word::Free => Command::Free { range: range_only(a)? },
        Word::Dump => {
            let toks = a.walk::<()>(&["n (first address)", "m (last address)"], 0, &[], |_, _, _| Ok(()))?;
            let from = toks.first().map(|t| a.int_of(t, "n (first address)")).transpose()?;
            let to = toks.get(1).map(|t| a.int_of(t, "m (last address)")).transpose()?;
            Command::Dump { from, to }
        }
        Word::Fraction => {
            let (f, t) = a.real("the fraction f of the critical time-step")?;
            Command::Fraction { f: a.positive(f, t, "the time-step fraction")? }
        }
        Word::Fluid => {
            let (rho, t) = a.real("the fluid density rhow")?;
            let density = a.non_negative(rho, t, "the fluid density")?;
            let (k, t) = a.real("the fluid bulk modulus bulkw")?;
            let bulk = a.positive(k, t, "the fluid bulk modulus")?;
            Command::Fluid { density, bulk }
        }
        Word::Generate => generate(a)?,
        Word::Gravity => {
            let toks = a.walk::<()>(&["gx", "gy", "gz"], 2, &[], |_, _, _| Ok(()))?;
            if let Some(t) = toks.get(2) {
                return Err(a.at(
                    t,
                    "GRAVITY gx gy gz (three components) is D3's, a 3D deck's (SL-85-1 Appendix B), not the 2D UDEC \
                     language's: `blockdem run` takes such a deck to the D3 engine (by its commands, or --dim 3)",
                ));
            }
            Command::Gravity { g: [a.real_of(toks[0], "gx")?, a.real_of(toks[1], "gy")?] }
        }
        Word::Link => {
            let v = a.reals(&["x1", "y1", "x2", "y2"])?;
            Command::Link { flying: [v[0], v[1]], anchor: [v[2], v[3]] }
        }
        Word::Load => {
            let toks = a.walk::<()>(&["x1", "x2", "y1", "y2", "fx", "fy"], 6, &[], |_, _, _| Ok(()))?;
            let range = a.range(&toks)?;
            Command::Load { range, force: [a.real_of(toks[4], "fx")?, a.real_of(toks[5], "fy")?] }
        }
        Word::Velocity => {
            let slots = ["x1", "x2", "y1", "y2", "vx", "vy", "w (angular velocity)"];
            let toks = a.walk::<()>(&slots, 6, &[], |_, _, _| Ok(()))?;
            let range = a.range(&toks)?;
            let velocity = [a.real_of(toks[4], "vx")?, a.real_of(toks[5], "vy")?];
            let angular = toks.get(6).map(|t| a.real_of(t, slots[6])).transpose()?;
            Command::Velocity { range, velocity, angular }
        }
        Word::PFix => {
            let domain = a.domain()?;
            let (pressure, _) = a.real("the pressure p")?;
            Command::PFix { domain, pressure }
        }
        Word::PFree => Command::PFree { domain: a.domain()? },
        Word::Plot => {
            let mut options = PlotOptions::default();
            while let Some(t) = a.next() {
                match lookup(&t.text, PLOT_KEYS).filter(|_| !t.is_numeric()) {
                    Some(PlotKey::NoFix) => options.nofix = true,
                    Some(PlotKey::Zones) => options.zones = true,
                    Some(PlotKey::Nc) => options.no_rounding = true,
                    Some(PlotKey::Vel) => options.velocities = true,
                    Some(PlotKey::Pressure) => options.pressure = true,
                    None => return Err(a.at(t, format!("unknown PLOT keyword '{}'; PLOT takes {}", t.shown(), names(PLOT_KEYS)))),
                }
            }
            Command::Plot { options }
        }
        Word::Print => {
            let mut items = Vec::new();
            while let Some(t) = a.next() {
                match lookup(&t.text, PRINT_KEYS).filter(|_| !t.is_numeric()) {
                    Some(item) => items.push(item),
                    None => return Err(a.at(t, format!("unknown PRINT keyword '{}'; PRINT takes {}", t.shown(), names(PRINT_KEYS)))),
                }
            }
            if items.is_empty() {
                return Err(a.at_end(format!("PRINT needs at least one of {}", names(PRINT_KEYS))));
            }
            Command::Print { items }
        }
        Word::Property => property(a)?,
        Word::Round => {
            let (d, t) = a.real("the rounding length d")?;
            Command::Round { d: a.positive(d, t, "the rounding length")? }
        }
        Word::View => {
            let slots = ["ix1", "ix2", "iy1", "iy2"];
            let toks = a.walk::<()>(&slots, 4, &[], |_, _, _| Ok(()))?;
            let v: Vec<i64> = toks.iter().zip(slots).map(|(t, s)| a.int_of(t, s)).collect::<Result<_>>()?;
            a.ordered(v[0], v[1], toks[0], toks[1], "ix1", "ix2")?;
            a.ordered(v[2], v[3], toks[2], toks[3], "iy1", "iy2")?;
            Command::View { ix1: v[0], ix2: v[1], iy1: v[2], iy2: v[3] }
        }
        Word::Window => {
            let toks = a.walk::<()>(&["x1", "x2", "y1", "y2"], 4, &[], |_, _, _| Ok(()))?;
            let r = a.range(&toks)?;
            Command::Window { x1: r.x1, x2: r.x2, y1: r.y1, y2: r.y2 }
        }
    };
    a.finish()?;
    Ok(cmd)
}

/// FIX, FREE, DELETE: exactly x1 x2 y1 y2.
fn range_only(a: &mut Args) -> Result<Range> {
    let toks = a.walk::<()>(&["x1", "x2", "y1", "y2"], 4, &[], |_, _, _| Ok(()))?;
    a.range(&toks)
}

/// `BLOCK [MATERIAL n] [CONSTITUTIVE m] x1 y1 x2 y2 ...`
///
/// "Corner coordinates are: (x1,y1), (x2,y2) etc., in a clockwise direction. Continuation lines
/// may be used, but a pair of numbers defining a corner must not be separated." The keywords come
/// before the corners, as in the manual's synopsis.
fn block(a: &mut Args) -> Result<Command> {
    let mut material = None;
    let mut constitutive = None;
    let mut coords: Vec<&Token> = Vec::new();
    while let Some(t) = a.next() {
        if t.is_numeric() {
            coords.push(t);
            continue;
        }
        let key = lookup(&t.text, MAT_CONS);
        if !coords.is_empty() {
            let n = coords.len();
            let xy = if n % 2 == 0 { "x" } else { "y" };
            let msg = if key.is_some() {
                format!("BLOCK's MATERIAL and CONSTITUTIVE must come before the corner coordinates, found '{}'", t.shown())
            } else {
                not_a_number(&format!("the {xy} coordinate of corner {}", n / 2 + 1), t, false)
            };
            return Err(a.at(t, msg));
        }
        match key {
            Some(MatCons::Material) => {
                let v = a.id("the material number n")?;
                a.once(&mut material, v, t)?
            }
            Some(_) => {
                let v = a.id("the constitutive number m")?;
                a.once(&mut constitutive, v, t)?
            }
            None => return Err(a.at(t, format!("expected MATERIAL, CONSTITUTIVE or the x coordinate of corner 1, found '{}'", t.shown()))),
        }
    }

    // A D3 deck types each corner as a parenthesised (x,y,z) triple: refuse it as 3D rather than
    // reading a nonsense 2D polygon from its numbers.
    for (i, t) in coords.iter().enumerate() {
        if let Some(g) = t.group {
            let in_group = coords.iter().filter(|u| u.group == Some(g)).count();
            if in_group == 3 && (i == 0 || coords[i - 1].group != Some(g)) {
                return Err(a.at(
                    t,
                    "BLOCK with (x,y,z) corners is D3's, a 3D deck's (SL-85-1 Appendix B), not the 2D UDEC \
                     language's: `blockdem run` takes such a deck to the D3 engine (by its commands, or --dim 3)",
                ));
            }
        }
    }

    let corners = pairs(a, &coords, "corner")?;
    if corners.len() < 3 {
        return Err(a.at_end(format!("BLOCK needs at least 3 corners (x y pairs), found {}", corners.len())));
    }
    Ok(Command::Block { material, constitutive, corners })
}

/// Read numeric tokens as x y pairs (BLOCK corners, GENERATE grid points): each must be a number,
/// the count must be even, and a pair may not straddle a continuation line.
fn pairs(a: &Args, coords: &[&Token], what: &str) -> Result<Vec<[f64; 2]>> {
    let mut out = Vec::with_capacity(coords.len() / 2);
    for (k, pair) in coords.chunks(2).enumerate() {
        let n = k + 1;
        let x = a.real_named(pair[0], || format!("the x coordinate of {what} {n}"))?;
        let Some(ty) = pair.get(1) else {
            return Err(a.at(pair[0], format!("{what} {n} has an x coordinate ({}) but no y coordinate: {} takes x y pairs", pair[0].shown(), a.name())));
        };
        let y = a.real_named(ty, || format!("the y coordinate of {what} {n}"))?;
        if ty.line != pair[0].line {
            return Err(a.at(
                ty,
                format!(
                    "{what} {n} is split across a continuation line (x on line {}, y on line {}); the pair \
                     of numbers defining a {what} must not be separated",
                    pair[0].line, ty.line
                ),
            ));
        }
        out.push([x, y]);
    }
    Ok(out)
}

/// `SPLIT x1 y1 x2 y2 [MATERIAL n] [CONSTITUTIVE m]`, keywords in any order (e.g. the manual's
/// `SPLIT 10.,20 41.,20 MAT=1, CONS=1`).
fn split(a: &mut Args) -> Result<Command> {
    let mut material = None;
    let mut constitutive = None;
    let slots = ["x1", "y1", "x2", "y2"];
    let toks = a.walk(&slots, 4, MAT_CONS, |a, k, t| match k {
        MatCons::Material => {
            let v = a.id("the joint material number n")?;
            a.once(&mut material, v, t)
        }
        _ => {
            let v = a.id("the joint constitutive number m")?;
            a.once(&mut constitutive, v, t)
        }
    })?;
    let v: Vec<f64> = toks.iter().zip(slots).map(|(t, s)| a.real_of(t, s)).collect::<Result<_>>()?;
    Ok(Command::Split { from: [v[0], v[1]], to: [v[2], v[3]], material, constitutive })
}

/// `CHANGE x1 x2 y1 y2 [SDEF|FDEF] [MATERIAL n] [CONSTITUTIVE m]`.
fn change(a: &mut Args) -> Result<Command> {
    let mut to = None;
    let mut material = None;
    let mut constitutive = None;
    let toks = a.walk(&["x1", "x2", "y1", "y2"], 4, CHANGE_KEYS, |a, k, t| match k {
        MatCons::Sdef => a.once(&mut to, Deformability::Sdef, t),
        MatCons::Fdef => a.once(&mut to, Deformability::Fdef, t),
        MatCons::Material => {
            let v = a.id("the material number n")?;
            a.once(&mut material, v, t)
        }
        MatCons::Constitutive => {
            let v = a.id("the constitutive number m")?;
            a.once(&mut constitutive, v, t)
        }
    })?;
    let range = a.range(&toks)?;
    if to.is_none() && material.is_none() && constitutive.is_none() {
        return Err(a.at_end("CHANGE needs something to change: SDEF, FDEF, MATERIAL n or CONSTITUTIVE m"));
    }
    Ok(Command::Change { range, to, material, constitutive })
}

/// `DAMPING fcrit freq [MASS|STIFFNESS|INTERNAL]`, e.g. `DAMP .1 15 (MASS)`.
fn damping(a: &mut Args) -> Result<Command> {
    let mut mode = None;
    let toks = a.walk(&["fcrit", "freq"], 2, DAMP_KEYS, |a, k, t| a.once(&mut mode, k, t))?;
    let fcrit = a.real_of(toks[0], "fcrit")?;
    let fcrit = a.non_negative(fcrit, toks[0], "the fraction of critical damping fcrit")?;
    let freq = a.real_of(toks[1], "freq")?;
    let freq = a.positive(freq, toks[1], "the centre frequency freq")?;
    Ok(Command::Damping { fcrit, freq, mode: mode.unwrap_or(DampMode::Full) })
}

/// SET OVERLAP ACCEPT|REFUSE (an extension): what a CYCLE does with blocks found overlapping
/// before any motion. SET DAMIN a: the minimum domain area (the Program Guide's DAMIN).
fn set(a: &mut Args) -> Result<Command> {
    let t = a.next().ok_or_else(|| a.missing(&format!("a setting ({})", names(SET_KEYS))))?;
    match lookup(&t.text, SET_KEYS).filter(|_| !t.is_numeric()) {
        Some(SetKey::Overlap) => {}
        Some(SetKey::Damin) => {
            let t = a.next().ok_or_else(|| a.missing("the minimum domain area a"))?;
            let v = a.real_of(t, "the minimum domain area a")?;
            let v = a.positive(v, t, "the minimum domain area a")?;
            return Ok(Command::Set { setting: Setting::Damin(v) });
        }
        None => return Err(a.at(t, format!("unknown SET setting '{}'; SET takes {}", t.shown(), names(SET_KEYS)))),
    }
    let t = a.next().ok_or_else(|| a.missing(&format!("what OVERLAP does ({})", names(OVERLAP_KEYS))))?;
    match lookup(&t.text, OVERLAP_KEYS).filter(|_| !t.is_numeric()) {
        Some(policy) => Ok(Command::Set { setting: Setting::Overlap(policy) }),
        None => Err(a.at(t, format!("unknown SET OVERLAP choice '{}'; OVERLAP takes {}", t.shown(), names(OVERLAP_KEYS)))),
    }
}

/// PROPERTY MATERIAL n keyword value ... ("The first parameter must be the specification of the
/// material number").
fn property(a: &mut Args) -> Result<Command> {
    let first = a.next().ok_or_else(|| a.missing("MATERIAL n first"))?;
    if first.is_numeric() || lookup(&first.text, PROP_KEYS) != Some(None) {
        return Err(a.at(first, format!("PROPERTY must begin with MATERIAL n (the material number), found '{}'", first.shown())));
    }
    let material = a.id("the material number n")?;
    let mut values = Vec::new();
    while let Some(t) = a.next() {
        let key = match lookup(&t.text, PROP_KEYS).filter(|_| !t.is_numeric()) {
            Some(Some(k)) => k,
            Some(None) => return Err(a.at(t, "MATERIAL may be given only once, as PROPERTY's first parameter")),
            None => {
                let list = names(&PROP_KEYS[1..]);
                return Err(a.at(t, format!("expected a property keyword ({list}), found '{}'", t.shown())));
            }
        };
        let (label, must_be_positive) = (key.label(), key.must_be_positive());
        let (v, vt) = a.real(&format!("a value after {}", t.shown()))?;
        let v = if must_be_positive { a.positive(v, vt, label)? } else { a.non_negative(v, vt, label)? };
        values.push((key, v));
    }
    if values.is_empty() {
        return Err(a.at_end("PROPERTY needs at least one keyword and value after MATERIAL n"));
    }
    Ok(Command::Property { material, values })
}

/// GENERATE x1 x2 y1 y2 AUTOMATIC amax | MANUAL GRIDPOINTS (glist) ZONES (zlist).
///
/// "Both (glist) and (zlist) may extend over an arbitrary number of continuation lines, but
/// doubles and triples should not be split over two lines." Zone triples number the grid points
/// counting back from the last one (the last grid point is number 1), so each must lie in
/// 1..=number of grid points.
fn generate(a: &mut Args) -> Result<Command> {
    let mut range_toks = Vec::new();
    for what in ["x1", "x2", "y1", "y2"] {
        let t = a.next().ok_or_else(|| a.missing(&format!("{what} of the range")))?;
        a.real_of(t, what)?;
        range_toks.push(t);
    }
    let range = a.range(&range_toks)?;

    let mode_what = "AUTOMATIC amax or MANUAL GRIDPOINTS ... ZONES ...";
    let t = a.next().ok_or_else(|| a.missing(mode_what))?;
    let mesh = match lookup(&t.text, GEN_KEYS).filter(|_| !t.is_numeric()) {
        Some(GenKey::Auto) => {
            let (amax, t) = a.real("the maximum zone edge length amax")?;
            Mesh::Auto { max_edge: a.positive(amax, t, "the maximum zone edge length amax")? }
        }
        Some(GenKey::Manual) => {
            // GRIDPOINTS is printed in the synopsis; accept the list without it too.
            if let Some(t) = a.toks.get(a.pos) {
                if !t.is_numeric() && lookup(&t.text, GEN_KEYS) == Some(GenKey::Grid) {
                    a.pos += 1;
                }
            }
            let mut coords = Vec::new();
            let mut saw_zones = false;
            while let Some(t) = a.next() {
                if t.is_numeric() {
                    coords.push(t);
                } else if lookup(&t.text, GEN_KEYS) == Some(GenKey::Zones) {
                    saw_zones = true;
                    break;
                } else {
                    let n = coords.len();
                    let xy = if n % 2 == 0 { "x" } else { "y" };
                    let msg = not_a_number(&format!("the {xy} coordinate of grid point {} (or ZONES)", n / 2 + 1), t, false);
                    return Err(a.at(t, msg));
                }
            }
            let grid_points = pairs(a, &coords, "grid point")?;
            if grid_points.len() < 3 {
                return Err(a.at_end(format!("GENERATE MANUAL needs at least 3 grid points (x y pairs), found {}", grid_points.len())));
            }
            if !saw_zones {
                return Err(a.at_end("GENERATE MANUAL needs ZONES and the zone list after the grid points"));
            }
            let mut ztoks = Vec::new();
            while let Some(t) = a.next() {
                let v = a.int_of(t, &format!("a grid-point number of zone {}", ztoks.len() / 3 + 1))?;
                ztoks.push((v, t));
            }
            let mut zones = Vec::new();
            for (k, tri) in ztoks.chunks(3).enumerate() {
                let n = k + 1;
                if tri.len() < 3 {
                    let t = tri[tri.len() - 1].1;
                    return Err(a.at(t, format!("zone {n} is incomplete: a zone needs three grid-point numbers (l m n)")));
                }
                let mut z = [0u32; 3];
                for (slot, &(v, t)) in z.iter_mut().zip(tri) {
                    if t.line != tri[0].1.line {
                        return Err(a.at(t, format!("zone {n} is split across a continuation line; a triple must not be separated")));
                    }
                    let id = a.id_of(v, t, "a grid-point number")?;
                    if id as usize > grid_points.len() {
                        return Err(a.at(t, format!("zone {n} refers to grid point {id}, but only {} grid points were given", grid_points.len())));
                    }
                    *slot = id;
                }
                zones.push(z);
            }
            if zones.is_empty() {
                return Err(a.at_end("GENERATE MANUAL needs at least one zone (l m n) after ZONES"));
            }
            Mesh::Manual { grid_points, zones }
        }
        _ => return Err(a.at(t, format!("expected {mode_what}, found '{}'", t.shown()))),
    };
    Ok(Command::Generate { range, mesh })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deck is told from a binary input by its first bytes: endless NULs are refused without
    /// reading on, endless text stops past the limit, a character cut at the end of the first
    /// bytes is read whole, and bytes that are not UTF-8 are refused at their line and column.
    #[test]
    fn reading_a_deck_stops_at_binary_bytes_and_past_the_limit() {
        let e = read_deck_from(std::io::repeat(0), 0, "zeros", MAX_DECK_BYTES).unwrap_err();
        assert_eq!(e.to_string(), "zeros:1:1: binary file: a NUL byte at line 1; a deck must be plain text");
        let e = read_deck_from(std::io::repeat(b'\n'), 0, "endless", 1000).unwrap_err();
        assert!(e.to_string().starts_with("endless:1001: the deck goes on past 1000 bytes"), "{e}");
        let mut deck = "*".repeat(FIRST_BYTES - 1).into_bytes();
        deck.extend("é\nSTART\n".as_bytes());
        assert_eq!(read_deck_from(&deck[..], 0, "cut", MAX_DECK_BYTES).unwrap(), deck);
        assert_eq!(read_deck_from(&deck[..], 0, "at the limit", deck.len()).unwrap(), deck);
        let e = read_deck_from(&b"START\nGRAV 0 \xff\n"[..], 0, "latin1", MAX_DECK_BYTES).unwrap_err();
        assert!(e.to_string().starts_with("latin1:2:8: binary file: byte 0xFF is not UTF-8"), "{e}");
        // In a comment line a Latin-1 byte is read as Latin-1 (issue 27 item 9), also where the
        // first bytes end in a character cut in two.
        let deck = b"START\n* a slope of 30\xb0\nGRAV 0 -10\n";
        assert_eq!(read_deck_from(&deck[..], 0, "comment", MAX_DECK_BYTES).unwrap(), deck);
        let mut deck = b"* 30\xb0\n".to_vec();
        deck.extend("*".repeat(FIRST_BYTES - deck.len() - 1).into_bytes());
        deck.extend("é\nSTART\n".as_bytes());
        assert_eq!(read_deck_from(&deck[..], 0, "cut", MAX_DECK_BYTES).unwrap(), deck);
    }

    /// Every name's full spelling and its minimum abbreviation (in either case) resolve to that
    /// name, so no minimum is shadowed by another entry.
    fn resolves<T: Copy + PartialEq + std::fmt::Debug>(table: &[Name<T>]) {
        for n in table {
            assert!(n.min >= 1 && n.min <= n.full.len(), "{}", n.full);
            for typed in [n.full.to_string(), n.full[..n.min].to_string(), n.full[..n.min].to_lowercase()] {
                assert_eq!(lookup(&typed, table), Some(n.value), "{typed} should be {}", n.full);
            }
        }
    }

    #[test]
    fn tables_are_unambiguous() {
        resolves(COMMANDS);
        resolves(MAT_CONS);
        resolves(CHANGE_KEYS);
        resolves(DAMP_KEYS);
        resolves(GEN_KEYS);
        resolves(SET_KEYS);
        resolves(OVERLAP_KEYS);
        resolves(PLOT_KEYS);
        resolves(PRINT_KEYS);
        resolves(PROP_KEYS);
    }

    #[test]
    fn manual_clashes() {
        for (typed, want) in [
            ("FR", Word::Free),
            ("FRA", Word::Fraction),
            ("P", Word::Print),
            ("PR", Word::Print),
            ("PRO", Word::Property),
            ("PF", Word::PFix),
            ("PFR", Word::PFree),
            ("ST", Word::Stop),
            ("STA", Word::Start),
            ("S", Word::Stop),
            ("G", Word::Gravity),
            ("GE", Word::Generate),
            ("D", Word::Damping),
            ("DE", Word::Delete),
            ("V", Word::View),
            ("VE", Word::Velocity),
            ("VT", Word::Vtk),
            ("VTK", Word::Vtk),
            ("R", Word::Restart),
            ("RS", Word::RSet),
            ("RO", Word::Round),
            ("SE", Word::Set),
            ("SA", Word::Save),
        ] {
            assert_eq!(lookup(typed, COMMANDS), Some(want), "{typed}");
        }
        assert_eq!(lookup("K", PROP_KEYS), Some(Some(PropKey::Bulk)));
        assert_eq!(lookup("KN", PROP_KEYS), Some(Some(PropKey::Kn)));
        assert_eq!(lookup("JK", PROP_KEYS), None);
        assert_eq!(lookup("CO", PRINT_KEYS), Some(PrintItem::Contacts));
        assert_eq!(lookup("COR", PRINT_KEYS), Some(PrintItem::Corners));
    }
}
