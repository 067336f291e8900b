//! D3's command language (SL-85-1, Appendix B, "Input Commands") on the chassis lexer: tokens →
//! [`Command`]s, checked as they are read. No physics: the faces of a BLOCK are read and grouped
//! here; whether they close a surface, face the right way and enclose a volume is the geometry's
//! check (`d3::geometry::Polyhedron::from_faces`), which names the face and its line.
//!
//! # Commands and their minimum abbreviations
//!
//! | command | min | | command | min | | command | min |
//! |---|---|---|---|---|---|---|---|
//! | BLOCK | `B` | | FIX | `F` | | PROPERTY | `PRO` |
//! | BOUNDARY (extension) | `BOU` | | | | | | |
//! | BOX (extension) | `BO` | | FRACTION | `FRA` | | RESTART | `R` |
//! | CHANGE | `CH` | | FREE | `FR` | | RSET | `RS` |
//! | CYCLE | `C` | | GRAVITY | `G` | | SAVE | `SA` |
//! | DAMPING | `D` | | LOAD (extension) | `L` | | SPLIT (extension) | `SP` |
//! | DUMP | `DU` | | PRINT | `P` | | START | `STA` |
//! | END | `E` | | VELOCITY (extension) | `VE` | | STOP | `S` |
//! | | | | VTK (extension) | `VT` | | | |
//!
//! PRINT's keywords: BLOCKS `B`, FACES `F`, VELOCITIES `V`, VERTICES `VERT`, CONTACTS `C`, and
//! ENERGY `E` (an extension, the energy ledger as 2D's).
//! PROPERTY's: those of the 2D language (MATERIAL `M` first, BULK `B` or `K`, G, DENSITY `D`, KN,
//! KS, COHESION `C`, FRICTION `F`, JKN, JKS, JCOHESION `JC`, JFRICTION `JF`, TF `T`); the fluid
//! keys (JPERM, CPERM, AZERO, ARES) belong to UDEC's fluid flow and are refused in a 3D deck.
//!
//! # Choices beyond the manual
//!
//! * BLOCK's vertices are typed three coordinates at a time, three vertices to a face; a face's
//!   nine numbers must stand on one line ("a set of three vertices defining a face must not be
//!   separated"). Parentheses, where typed, must each hold one vertex's three numbers.
//! * Ranges (`x1 x2 y1 y2 z1 z2`) select the blocks whose centroid lies in the open box, as in 2D;
//!   an empty range (x1 ≥ x2, …) is an error, and so is a range of four numbers (a 2D range).
//! * `LOAD x1 x2 y1 y2 z1 z2 fx fy fz`, `VELOCITY x1 x2 y1 y2 z1 z2 vx vy vz [wx wy wz]` and
//!   `BOX x1 x2 y1 y2 z1 z2 [MAT n] [CONS m]` (twelve faces) are extensions, as the issue asks.
//! * `BOUNDARY STRESS x1 x2 y1 y2 z1 z2 sxx syy szz sxy sxz syz` and `BOUNDARY VELOCITY x1 x2 y1
//!   y2 z1 z2 vx vy vz [wx wy wz]` (extensions, Part IV ¶35e's "comprehensive boundary
//!   conditions: stress tensor, arbitrary velocity prescription"): STRESS (`S`) loads every face
//!   whose centroid lies in the range with the traction σ·n (σ in global axes, tension
//!   positive); VELOCITY (`V`) holds the blocks whose centroid lies in the range at that velocity
//!   and spin (`d3::motion::held_motion`).
//! * A 2D (UDEC) command in a 3D deck is refused at its line, naming it as such: a BLOCK of
//!   (x,y) pairs, GRAVITY of two components, ROUND, GENERATE, PLOT, … .
//! * `SPLIT x y z nx ny nz [MAT n] [CONS m]` (extension): the plane through (x, y, z) with normal
//!   (nx, ny, nz) cuts every block it crosses (`d3::split`); MAT and CONS give the pieces'
//!   material and constitutive number (else they keep the parent's; in the 2D language they tag
//!   the new joint, which D3's contacts, taking their law block's material (`model::law_block`), have no place for).
//! * `SAVE [file]` and `RESTART [file]` write and read D3's own save file (`d3::restart`; the
//!   name as in 2D, `blockdem.sav` in the output folder when none is given); `DUMP [n m]` writes
//!   the whole state as JSON under a heading with Appendix B's pointers as counts (n and m, the
//!   main array's addresses, have no meaning here).
//! * `VTK` (extension, as in 2D): a frame of the blocks and contacts for ParaView in the output
//!   folder's `vtk/` (`d3::vtk`).
//! * `CHANGE x1 x2 y1 y2 z1 z2 [SDEF] [MATERIAL n] [CONSTITUTIVE m]` makes the blocks in the
//!   range simply deformable (`d3::sdef`) and/or changes their material and constitutive numbers,
//!   as Appendix B says; it asks for at least one of the three. Turning a simply-deformable block
//!   back into a rigid one is not in the report and has no keyword. `DAMPING fcrit freq
//!   INTERNAL` damps the simply-deformable blocks' strain (the report's ALPB, mass-proportional
//!   only, as UDEC 1.2 noted). RSET is refused as in 2D: there is no main array to poke.

use crate::deck::lexer::{self, lookup, name, Name, NumberError, Statement, Token};
use crate::deck::props::PROP_KEYS;
use crate::deck::DeckError;

type Result<T> = std::result::Result<T, DeckError>;

/// An open box of space: the blocks whose centroid lies strictly inside are selected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range3 {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Range3 {
    /// Whether `p` lies strictly inside.
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|i| self.min[i] < p[i] && p[i] < self.max[i])
    }
}

/// One triangular face as typed: its three vertices (counter-clockwise looking along the outward
/// normal) and the line it stands on.
#[derive(Clone, Debug, PartialEq)]
pub struct FaceInput {
    pub vertices: [[f64; 3]; 3],
    pub line: usize,
}

/// PROPERTY's keys: the chassis's table, shared with the 2D language (`deck::props`).
pub use crate::deck::props::PropKey;

/// PRINT's items.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrintItem {
    Blocks,
    Faces,
    Velocities,
    Vertices,
    Contacts,
    /// The energy ledger (an extension, as 2D's PRINT ENERGY).
    Energy,
}

/// DAMPING's qualifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DampMode {
    /// Rayleigh damping, both terms.
    Full,
    /// "The word Mass eliminates the stiffness-proportional dashpots".
    Mass,
    /// "Stiffness eliminates the mass-proportional dashpots".
    Stiffness,
    /// "Internal causes the specific damping to be applied to the 3 internal degrees of freedom of
    /// simply-deformable blocks" (six in 3D): mass-proportional.
    Internal,
}

/// A D3 command.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    Start,
    Block {
        material: u32,
        constitutive: u32,
        faces: Vec<FaceInput>,
    },
    Box {
        range: Range3,
        material: u32,
        constitutive: u32,
    },
    Property {
        material: u32,
        values: Vec<(PropKey, f64)>,
    },
    Gravity {
        g: [f64; 3],
    },
    Fix {
        range: Range3,
    },
    Free {
        range: Range3,
    },
    Load {
        range: Range3,
        force: [f64; 3],
    },
    Velocity {
        range: Range3,
        velocity: [f64; 3],
        angular: Option<[f64; 3]>,
    },
    /// BOUNDARY STRESS x1 x2 y1 y2 z1 z2 sxx syy szz sxy sxz syz (extension, ¶35e): the faces
    /// whose centroid lies in the range take the traction σ·n; σ in Voigt's order.
    BoundaryStress {
        range: Range3,
        stress: [f64; 6],
    },
    /// BOUNDARY VELOCITY x1 x2 y1 y2 z1 z2 vx vy vz [wx wy wz] (extension, ¶35e): the blocks
    /// whose centroid lies in the range held at the velocity and spin.
    BoundaryVelocity {
        range: Range3,
        velocity: [f64; 3],
        angular: Option<[f64; 3]>,
    },
    Damping {
        fcrit: f64,
        freq: f64,
        mode: DampMode,
    },
    /// CHANGE x1 x2 y1 y2 z1 z2 \[SDEF\] \[MATERIAL n\] \[CONSTITUTIVE m\]: the blocks whose centroid
    /// lies in the range made simply deformable (`sdef`) and/or given the material and
    /// constitutive numbers.
    Change {
        range: Range3,
        sdef: bool,
        material: Option<u32>,
        constitutive: Option<u32>,
    },
    Fraction {
        f: f64,
    },
    Cycle {
        n: u64,
    },
    Print {
        items: Vec<PrintItem>,
    },
    /// SPLIT x y z nx ny nz [MATERIAL n] [CONSTITUTIVE m] (extension): the plane through the point
    /// with the normal cuts every block it crosses; MAT and CONS, where given, are the pieces'.
    Split {
        point: [f64; 3],
        normal: [f64; 3],
        material: Option<u32>,
        constitutive: Option<u32>,
    },
    /// RESTART [file]: the state a SAVE wrote (`d3::restart`).
    Restart {
        file: Option<String>,
    },
    /// SAVE [file].
    Save {
        file: Option<String>,
    },
    /// DUMP [n m]: the whole state, readable (n and m, the 1985 main array's addresses, are read
    /// and have no meaning here).
    Dump {
        from: Option<i64>,
        to: Option<i64>,
    },
    /// VTK (extension, as in 2D): a frame of the blocks and contacts (`d3::vtk`).
    Vtk,
    Stop,
    End,
}

/// A command with the line it starts on and its text as typed (for the echo).
#[derive(Clone, Debug, PartialEq)]
pub struct Located {
    pub line: usize,
    pub source: String,
    pub command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Word {
    Block,
    Boundary,
    Box,
    Change,
    Cycle,
    Damping,
    Dump,
    End,
    Fix,
    Fraction,
    Free,
    Gravity,
    Load,
    Print,
    Property,
    Restart,
    RSet,
    Save,
    Split,
    Start,
    Stop,
    Velocity,
    Vtk,
}

const COMMANDS: &[Name<Word>] = &[
    name("BLOCK", "B", Word::Block),
    name("BOUNDARY", "BOU", Word::Boundary),
    name("BOX", "BO", Word::Box),
    name("CHANGE", "CH", Word::Change),
    name("CYCLE", "C", Word::Cycle),
    name("DAMPING", "D", Word::Damping),
    name("DUMP", "DU", Word::Dump),
    name("END", "E", Word::End),
    name("FIX", "F", Word::Fix),
    name("FRACTION", "FRA", Word::Fraction),
    name("FREE", "FR", Word::Free),
    name("GRAVITY", "G", Word::Gravity),
    name("LOAD", "L", Word::Load),
    name("PRINT", "P", Word::Print),
    name("PROPERTY", "PRO", Word::Property),
    name("RESTART", "R", Word::Restart),
    name("RSET", "RS", Word::RSet),
    name("SAVE", "SA", Word::Save),
    name("SPLIT", "SP", Word::Split),
    name("START", "STA", Word::Start),
    name("STOP", "S", Word::Stop),
    name("VELOCITY", "VE", Word::Velocity),
    name("VTK", "VT", Word::Vtk),
];

/// The 2D language's commands that D3 has no counterpart of (refused by name in a 3D deck).
const UDEC_ONLY: &[Name<&str>] = &[
    name("DELETE", "DE", "DELETE"),
    name("FLUID", "FL", "FLUID"),
    name("GENERATE", "GE", "GENERATE"),
    name("LINK", "LI", "LINK"),
    name("PFIX", "PF", "PFIX"),
    name("PFREE", "PFR", "PFREE"),
    name("PLOT", "PL", "PLOT"),
    name("ROUND", "RO", "ROUND"),
    name("SET", "SE", "SET"),
    name("VIEW", "V", "VIEW"),
    name("WINDOW", "W", "WINDOW"),
];

const PRINT_ITEMS: &[Name<PrintItem>] = &[
    name("BLOCKS", "B", PrintItem::Blocks),
    name("FACES", "F", PrintItem::Faces),
    name("VELOCITIES", "V", PrintItem::Velocities),
    name("VERTICES", "VERT", PrintItem::Vertices),
    name("CONTACTS", "C", PrintItem::Contacts),
    name("ENERGY", "E", PrintItem::Energy),
];

const DAMP_MODES: &[Name<DampMode>] =
    &[name("MASS", "M", DampMode::Mass), name("STIFFNESS", "S", DampMode::Stiffness), name("INTERNAL", "I", DampMode::Internal)];

/// BOUNDARY's kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BoundaryKind {
    Stress,
    Velocity,
}
const BOUNDARY_KINDS: &[Name<BoundaryKind>] = &[name("STRESS", "S", BoundaryKind::Stress), name("VELOCITY", "V", BoundaryKind::Velocity)];

/// BLOCK/BOX keywords.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BlockKey {
    Material,
    Constitutive,
}
const BLOCK_KEYS: &[Name<BlockKey>] = &[name("MATERIAL", "M", BlockKey::Material), name("CONSTITUTIVE", "CO", BlockKey::Constitutive)];

/// CHANGE's keywords: the block kind and BLOCK's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ChangeKey {
    Sdef,
    Fdef,
    Block(BlockKey),
}
const CHANGE_KEYS: &[Name<ChangeKey>] = &[
    name("SDEF", "S", ChangeKey::Sdef),
    name("FDEF", "F", ChangeKey::Fdef),
    name("MATERIAL", "M", ChangeKey::Block(BlockKey::Material)),
    name("CONSTITUTIVE", "CO", ChangeKey::Block(BlockKey::Constitutive)),
];

/// Why a deck is read as D3 (the engine rule of `blockdem run`, README): the line and what was
/// seen there.
#[derive(Clone, Debug, PartialEq)]
pub struct ThreeDimensional {
    pub line: usize,
    pub what: &'static str,
}

/// Whether a deck is a 3D (D3) deck, by its commands: a BLOCK whose vertices are typed as
/// parenthesised (x,y,z) triples, a BOX, or GRAVITY with three components. The first such
/// command's line, or `None` for a 2D deck. The 2D language has no BOX; its BLOCK corners are
/// pairs and its GRAVITY has two components, so no 2D deck is taken for a 3D one.
pub fn three_dimensional(statements: &[Statement]) -> Option<ThreeDimensional> {
    for st in statements {
        let word = &st.tokens[0];
        if word.is_numeric() {
            continue;
        }
        match lookup(&word.text, COMMANDS) {
            Some(Word::Block) if has_triple_group(&st.tokens[1..]) => {
                return Some(ThreeDimensional { line: st.line, what: "a BLOCK with (x,y,z) vertices" });
            }
            Some(Word::Box) => return Some(ThreeDimensional { line: st.line, what: "a BOX" }),
            Some(Word::Gravity) if st.tokens.len() == 4 && st.tokens[1..].iter().all(Token::is_numeric) => {
                return Some(ThreeDimensional { line: st.line, what: "GRAVITY with three components" });
            }
            Some(Word::End) => break,
            _ => {}
        }
    }
    None
}

/// Whether some parenthesised group of the tokens holds exactly three numbers.
fn has_triple_group(tokens: &[Token]) -> bool {
    let mut i = 0;
    while i < tokens.len() {
        match tokens[i].group {
            Some(g) => {
                let n = tokens[i..].iter().take_while(|t| t.group == Some(g)).count();
                if n == 3 && tokens[i..i + 3].iter().all(Token::is_numeric) {
                    return true;
                }
                i += n;
            }
            None => i += 1,
        }
    }
    false
}

/// Reads a D3 deck: the first command must be START or RESTART; commands after END are not
/// read. Errors name the file, line and column.
pub fn parse_deck(text: &str, file: &str) -> Result<Vec<Located>> {
    let statements = lexer::split(text, file)?;
    let Some(first) = statements.first() else {
        return Err(DeckError::new(file, 1, 0, "empty deck: the first command must be START or RESTART"));
    };
    let mut out = Vec::with_capacity(statements.len());
    for (k, st) in statements.iter().enumerate() {
        let command = parse_statement(st, file)?;
        if k == 0 && !matches!(command, Command::Start | Command::Restart { .. }) {
            let t = &first.tokens[0];
            return Err(DeckError::new(file, t.line, t.column, format!("the first command must be START or RESTART, found '{}'", t.shown())));
        }
        if k > 0 && command == Command::Start {
            let t = &st.tokens[0];
            return Err(DeckError::new(file, t.line, t.column, "START may only be the first command"));
        }
        let end = command == Command::End;
        out.push(Located { line: st.line, source: st.source.clone(), command });
        if end {
            break;
        }
    }
    Ok(out)
}

/// The parameters of one statement, read in order.
struct Args<'a> {
    file: &'a str,
    /// The statement as typed (for SAVE's and RESTART's file names).
    source: &'a str,
    word: &'a Token,
    tokens: &'a [Token],
    at: usize,
}

impl<'a> Args<'a> {
    fn at(&self, t: &Token, message: impl Into<String>) -> DeckError {
        DeckError::new(self.file, t.line, t.column, message)
    }

    /// An error for something missing: just past the last token.
    fn at_end(&self, message: impl Into<String>) -> DeckError {
        let last = self.tokens.last().unwrap_or(self.word);
        DeckError::new(self.file, last.line, last.end_column(), message)
    }

    fn next(&mut self) -> Option<&'a Token> {
        let t = self.tokens.get(self.at)?;
        self.at += 1;
        Some(t)
    }

    fn peek(&self) -> Option<&'a Token> {
        self.tokens.get(self.at)
    }

    fn real_of(&self, t: &Token, what: &str) -> Result<f64> {
        match lexer::parse_real(&t.text) {
            Ok(v) => Ok(v),
            Err(NumberError::TooLarge) => Err(self.at(t, format!("{what}: '{}' is out of range", t.shown()))),
            Err(_) => Err(self.at(t, format!("expected a number for {what}, found '{}'", t.shown()))),
        }
    }

    fn real(&mut self, what: &str) -> Result<(f64, &'a Token)> {
        let t = self.next().ok_or_else(|| self.at_end(format!("expected {what}")))?;
        Ok((self.real_of(t, what)?, t))
    }

    fn int_of(&self, t: &Token, what: &str) -> Result<i64> {
        match lexer::parse_int(&t.text) {
            Ok(v) => Ok(v),
            Err(NumberError::NotInteger) => Err(self.at(t, format!("{what} must be a whole number, found '{}'", t.shown()))),
            Err(NumberError::TooLarge) => Err(self.at(t, format!("{what}: '{}' is out of range", t.shown()))),
            Err(NumberError::Syntax) => Err(self.at(t, format!("expected a whole number for {what}, found '{}'", t.shown()))),
        }
    }

    /// A material or constitutive number: 1 or more.
    fn id(&mut self, what: &str) -> Result<u32> {
        let t = self.next().ok_or_else(|| self.at_end(format!("expected {what}")))?;
        let v = self.int_of(t, what)?;
        if v < 1 || v > u32::MAX as i64 {
            return Err(self.at(t, format!("{what} must be 1 or more, found {v}")));
        }
        Ok(v as u32)
    }

    /// Nothing may follow.
    fn done(&self) -> Result<()> {
        match self.peek() {
            Some(t) => Err(self.at(t, format!("too many values: '{}' is not expected after {}", t.shown(), self.word.text.to_ascii_uppercase()))),
            None => Ok(()),
        }
    }

    /// The numeric tokens up to the next word (or the end).
    fn numbers(&mut self) -> Vec<&'a Token> {
        let mut out = Vec::new();
        while let Some(t) = self.peek().filter(|t| t.is_numeric()) {
            out.push(t);
            self.at += 1;
        }
        out
    }

    /// A range x1 x2 y1 y2 z1 z2 from its six tokens.
    fn range(&self, toks: &[&Token]) -> Result<Range3> {
        let mut v = [0.0; 6];
        for (k, (t, what)) in toks.iter().zip(["x1", "x2", "y1", "y2", "z1", "z2"]).enumerate() {
            v[k] = self.real_of(t, what)?;
        }
        for (axis, pair) in ["x", "y", "z"].iter().zip([0, 2, 4]) {
            if v[pair] >= v[pair + 1] {
                return Err(self.at(
                    toks[pair],
                    format!("empty range: {axis}1 = {} is not below {axis}2 = {} (the range is the open {axis}1 < {axis} < {axis}2)", v[pair], v[pair + 1]),
                ));
            }
        }
        Ok(Range3 { min: [v[0], v[2], v[4]], max: [v[1], v[3], v[5]] })
    }

    /// A range followed by `n` numbers (`extra` names them) and, optionally, `optional` more.
    fn range_then(&mut self, command: &str, extra: &[&str], optional: &[&str]) -> Result<(Range3, Vec<f64>)> {
        let toks = self.numbers();
        let need = 6 + extra.len();
        if toks.len() == 4 + extra.len() || (toks.len() == 4 && extra.is_empty()) {
            return Err(self.at(
                toks[0],
                format!(
                    "{command} takes a 3D range x1 x2 y1 y2 z1 z2{}; found {} numbers, a 2D range (x1 x2 y1 y2) — this is a 3D (D3) deck",
                    tail(extra),
                    toks.len()
                ),
            ));
        }
        if toks.len() != need && toks.len() != need + optional.len() {
            let expected = if optional.is_empty() { format!("{need}") } else { format!("{need} or {}", need + optional.len()) };
            let at = toks.get(need.min(toks.len())).copied().or(toks.last().copied());
            let msg = format!("{command} takes x1 x2 y1 y2 z1 z2{}{}: {expected} numbers, found {}", tail(extra), tail(optional), toks.len());
            return Err(match at {
                Some(t) if toks.len() > need => self.at(t, msg),
                _ => self.at_end(msg),
            });
        }
        let range = self.range(&toks[..6])?;
        let names: Vec<&str> = extra.iter().chain(optional).copied().collect();
        let values = toks[6..].iter().zip(names).map(|(t, what)| self.real_of(t, what)).collect::<Result<Vec<f64>>>()?;
        self.done()?;
        Ok((range, values))
    }

    /// `[MATERIAL n] [CONSTITUTIVE m]`, in either order, each at most once.
    fn block_keys(&mut self, t: &'a Token, key: BlockKey, material: &mut Option<u32>, constitutive: &mut Option<u32>) -> Result<()> {
        let (slot, what) = match key {
            BlockKey::Material => (material, "the material number n"),
            BlockKey::Constitutive => (constitutive, "the constitutive number m"),
        };
        if slot.is_some() {
            return Err(self.at(t, format!("{} given twice", t.text.to_ascii_uppercase())));
        }
        *slot = Some(self.id(what)?);
        Ok(())
    }
}

fn tail(names: &[&str]) -> String {
    names.iter().map(|n| format!(" {n}")).collect()
}

fn parse_statement(st: &Statement, file: &str) -> Result<Command> {
    let word = &st.tokens[0];
    let mut a = Args { file, source: &st.source, word, tokens: &st.tokens[1..], at: 0 };
    let Some(w) = (!word.is_numeric()).then(|| lookup(&word.text, COMMANDS)).flatten() else {
        if let Some(udec) = (!word.is_numeric()).then(|| lookup(&word.text, UDEC_ONLY)).flatten() {
            return Err(a.at(word, format!("{udec} is a command of the 2D language (UDEC, Appendix A), not of D3's: this is a 3D deck")));
        }
        return Err(a.at(word, format!("unknown command '{}'", word.shown())));
    };
    let command = match w {
        Word::Start => {
            a.done()?;
            Command::Start
        }
        Word::Restart => Command::Restart { file: file_name(&mut a) },
        Word::Save => Command::Save { file: file_name(&mut a) },
        Word::Change => {
            let toks = a.numbers();
            if toks.len() == 4 {
                return Err(a.at(toks[0], "CHANGE takes a 3D range x1 x2 y1 y2 z1 z2; found 4 numbers, a 2D range (x1 x2 y1 y2) — this is a 3D (D3) deck"));
            }
            if toks.len() != 6 {
                let msg = format!("CHANGE takes x1 x2 y1 y2 z1 z2 [SDEF] [MATERIAL n] [CONSTITUTIVE m]: 6 numbers, found {}", toks.len());
                return Err(if toks.len() > 6 { a.at(toks[6], msg) } else { a.at_end(msg) });
            }
            let range = a.range(&toks)?;
            let (mut material, mut constitutive, mut sdef) = (None, None, false);
            while let Some(t) = a.next() {
                match (!t.is_numeric()).then(|| lookup(&t.text, CHANGE_KEYS)).flatten() {
                    Some(ChangeKey::Sdef) if sdef => return Err(a.at(t, "SDEF given twice")),
                    Some(ChangeKey::Sdef) => sdef = true,
                    Some(ChangeKey::Fdef) => {
                        return Err(
                            a.at(t, "FDEF (fully-deformable, zoned blocks) belongs to the 2D language; D3 has rigid and simply-deformable (SDEF) blocks")
                        )
                    }
                    Some(ChangeKey::Block(k)) => a.block_keys(t, k, &mut material, &mut constitutive)?,
                    None => return Err(a.at(t, format!("expected SDEF, MATERIAL or CONSTITUTIVE, found '{}'", t.shown()))),
                }
            }
            if !sdef && material.is_none() && constitutive.is_none() {
                return Err(a.at_end("CHANGE changes nothing: give SDEF, MATERIAL n or CONSTITUTIVE m after the range"));
            }
            Command::Change { range, sdef, material, constitutive }
        }
        Word::Dump => {
            let toks = a.numbers();
            if toks.len() > 2 {
                return Err(a.at(toks[2], format!("DUMP takes [n m]: at most 2 numbers, found {}", toks.len())));
            }
            let from = toks.first().map(|t| a.int_of(t, "n (first address)")).transpose()?;
            let to = toks.get(1).map(|t| a.int_of(t, "m (last address)")).transpose()?;
            a.done()?;
            Command::Dump { from, to }
        }
        Word::Split => {
            let toks = a.numbers();
            if toks.len() != 6 {
                let msg =
                    format!("SPLIT takes x y z nx ny nz [MATERIAL n] [CONSTITUTIVE m]: a point of the plane and its normal, 6 numbers, found {}", toks.len());
                return Err(if toks.len() > 6 { a.at(toks[6], msg) } else { a.at_end(msg) });
            }
            let mut v = [0.0; 6];
            for (k, (t, what)) in toks.iter().zip(["x", "y", "z", "nx", "ny", "nz"]).enumerate() {
                v[k] = a.real_of(t, what)?;
            }
            let length = (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]).sqrt();
            if !(length > 0.0 && length.is_finite()) {
                return Err(a.at(toks[3], "SPLIT: the plane's normal nx ny nz must be a non-zero vector"));
            }
            let (mut material, mut constitutive) = (None, None);
            while let Some(t) = a.next() {
                match (!t.is_numeric()).then(|| lookup(&t.text, BLOCK_KEYS)).flatten() {
                    Some(k) => a.block_keys(t, k, &mut material, &mut constitutive)?,
                    None => return Err(a.at(t, format!("expected MATERIAL or CONSTITUTIVE, found '{}'", t.shown()))),
                }
            }
            Command::Split { point: [v[0], v[1], v[2]], normal: [v[3], v[4], v[5]], material, constitutive }
        }
        Word::RSet => {
            return Err(
                a.at(word, "RSET is not supported: it poked a value into the 1985 program's main array at a raw memory address, which has no meaning here")
            )
        }
        Word::Block => block(&mut a)?,
        Word::Box => {
            let toks = a.numbers();
            if toks.len() != 6 {
                let msg = format!("BOX takes x1 x2 y1 y2 z1 z2 [MATERIAL n] [CONSTITUTIVE m]: 6 numbers, found {}", toks.len());
                return Err(if toks.len() > 6 { a.at(toks[6], msg) } else { a.at_end(msg) });
            }
            let range = a.range(&toks)?;
            let (mut material, mut constitutive) = (None, None);
            while let Some(t) = a.next() {
                match (!t.is_numeric()).then(|| lookup(&t.text, BLOCK_KEYS)).flatten() {
                    Some(k) => a.block_keys(t, k, &mut material, &mut constitutive)?,
                    None => return Err(a.at(t, format!("expected MATERIAL or CONSTITUTIVE, found '{}'", t.shown()))),
                }
            }
            Command::Box { range, material: material.unwrap_or(1), constitutive: constitutive.unwrap_or(1) }
        }
        Word::Property => property(&mut a)?,
        Word::Gravity => {
            let toks = a.numbers();
            if toks.len() == 2 {
                return Err(a.at(word, "GRAVITY takes three components gx gy gz in a 3D deck; found two (the 2D form)"));
            }
            if toks.len() != 3 {
                let msg = format!("GRAVITY takes gx gy gz: 3 numbers, found {}", toks.len());
                return Err(if toks.len() > 3 { a.at(toks[3], msg) } else { a.at_end(msg) });
            }
            a.done()?;
            Command::Gravity { g: [a.real_of(toks[0], "gx")?, a.real_of(toks[1], "gy")?, a.real_of(toks[2], "gz")?] }
        }
        Word::Fix => Command::Fix { range: a.range_then("FIX", &[], &[])?.0 },
        Word::Free => Command::Free { range: a.range_then("FREE", &[], &[])?.0 },
        Word::Load => {
            let (range, v) = a.range_then("LOAD", &["fx", "fy", "fz"], &[])?;
            Command::Load { range, force: [v[0], v[1], v[2]] }
        }
        Word::Velocity => {
            let (range, v) = a.range_then("VELOCITY", &["vx", "vy", "vz"], &["wx", "wy", "wz"])?;
            let angular = (v.len() == 6).then(|| [v[3], v[4], v[5]]);
            Command::Velocity { range, velocity: [v[0], v[1], v[2]], angular }
        }
        Word::Boundary => {
            let kind = match a.next() {
                Some(t) => match (!t.is_numeric()).then(|| lookup(&t.text, BOUNDARY_KINDS)).flatten() {
                    Some(k) => k,
                    None => return Err(a.at(t, format!("BOUNDARY takes STRESS or VELOCITY first, found '{}'", t.shown()))),
                },
                None => return Err(a.at_end("BOUNDARY takes STRESS or VELOCITY, then a range x1 x2 y1 y2 z1 z2 and their values")),
            };
            match kind {
                BoundaryKind::Stress => {
                    let (range, v) = a.range_then("BOUNDARY STRESS", &["sxx", "syy", "szz", "sxy", "sxz", "syz"], &[])?;
                    Command::BoundaryStress { range, stress: [v[0], v[1], v[2], v[3], v[4], v[5]] }
                }
                BoundaryKind::Velocity => {
                    let (range, v) = a.range_then("BOUNDARY VELOCITY", &["vx", "vy", "vz"], &["wx", "wy", "wz"])?;
                    let angular = (v.len() == 6).then(|| [v[3], v[4], v[5]]);
                    Command::BoundaryVelocity { range, velocity: [v[0], v[1], v[2]], angular }
                }
            }
        }
        Word::Damping => {
            let (fcrit, t) = a.real("fcrit (the fraction of critical damping)")?;
            if fcrit.is_nan() || fcrit < 0.0 {
                return Err(a.at(t, format!("fcrit must be 0 or more, found {fcrit}")));
            }
            let (freq, t) = a.real("freq (the centre frequency)")?;
            if freq.is_nan() || freq <= 0.0 {
                return Err(a.at(t, format!("freq must be above zero, found {freq}")));
            }
            let mode = match a.next() {
                None => DampMode::Full,
                Some(t) => match (!t.is_numeric()).then(|| lookup(&t.text, DAMP_MODES)).flatten() {
                    Some(m) => m,
                    None => return Err(a.at(t, format!("expected MASS, STIFFNESS or INTERNAL, found '{}'", t.shown()))),
                },
            };
            a.done()?;
            Command::Damping { fcrit, freq, mode }
        }
        Word::Fraction => {
            let (f, t) = a.real("the fraction f of the critical time-step")?;
            if f.is_nan() || f <= 0.0 || f.is_infinite() {
                return Err(a.at(t, format!("the time-step fraction must be above zero, found {f}")));
            }
            a.done()?;
            Command::Fraction { f }
        }
        Word::Cycle => {
            let t = a.next().ok_or_else(|| a.at_end("expected n, the number of cycles"))?;
            let n = a.int_of(t, "the number of cycles n")?;
            if n < 0 {
                return Err(a.at(t, format!("the number of cycles must be 0 or more, found {n}")));
            }
            a.done()?;
            Command::Cycle { n: n as u64 }
        }
        Word::Print => {
            let mut items = Vec::new();
            while let Some(t) = a.next() {
                match (!t.is_numeric()).then(|| lookup(&t.text, PRINT_ITEMS)).flatten() {
                    Some(i) => items.push(i),
                    None => return Err(a.at(t, format!("expected BLOCKS, FACES, VELOCITIES, VERTICES or CONTACTS, found '{}'", t.shown()))),
                }
            }
            if items.is_empty() {
                return Err(a.at_end("PRINT needs what to print: BLOCKS, FACES, VELOCITIES, VERTICES, CONTACTS or ENERGY"));
            }
            Command::Print { items }
        }
        Word::Stop => {
            a.done()?;
            Command::Stop
        }
        Word::Vtk => {
            a.done()?;
            Command::Vtk
        }
        Word::End => {
            a.done()?;
            Command::End
        }
    };
    Ok(command)
}

/// SAVE's and RESTART's optional file name. A name may hold '/', which the 1985 language counts
/// as a separator, so when the text after the command word is one blank-free word it is taken
/// whole (as in the 2D language); otherwise the first token is the name and any other is too many.
fn file_name(a: &mut Args) -> Option<String> {
    let first = a.next()?.text.to_string();
    let word = &a.word.text;
    let whole =
        a.source.find(word.as_str()).map(|at| a.source[at + word.len()..].trim_matches(|c: char| c.is_whitespace() || matches!(c, '=' | '(' | ')' | ',')));
    match whole.filter(|n| !n.is_empty() && !n.contains(char::is_whitespace)) {
        Some(name) => {
            let name = name.to_string();
            a.at = a.tokens.len();
            Some(name)
        }
        None => Some(first),
    }
}

/// BLOCK [MATERIAL n] [CONSTITUTIVE m] x1 y1 z1 x2 y2 z2 x3 y3 z3 …: faces of three vertices.
fn block(a: &mut Args) -> Result<Command> {
    let (mut material, mut constitutive) = (None, None);
    let mut coords: Vec<&Token> = Vec::new();
    while let Some(t) = a.next() {
        if t.is_numeric() {
            coords.push(t);
            continue;
        }
        match lookup(&t.text, BLOCK_KEYS) {
            Some(k) if coords.is_empty() => a.block_keys(t, k, &mut material, &mut constitutive)?,
            Some(_) => return Err(a.at(t, "MATERIAL and CONSTITUTIVE come before the vertices")),
            None => return Err(a.at(t, format!("expected MATERIAL, CONSTITUTIVE or a vertex coordinate, found '{}'", t.shown()))),
        }
    }
    // Parenthesised vertices: each group one vertex, three numbers (a pair is a 2D corner).
    let mut i = 0;
    while i < coords.len() {
        if let Some(g) = coords[i].group {
            let n = coords[i..].iter().take_while(|t| t.group == Some(g)).count();
            if n != 3 {
                let what = if n == 2 { " (an (x,y) pair is a 2D corner: this is a 3D deck)" } else { "" };
                return Err(a.at(coords[i], format!("a vertex in parentheses needs three coordinates (x,y,z), found {n}{what}")));
            }
            i += n;
        } else {
            i += 1;
        }
    }
    if coords.is_empty() {
        return Err(a.at_end("BLOCK needs its faces: three vertices (x y z) each, at least four faces"));
    }
    let mut faces = Vec::with_capacity(coords.len() / 9);
    for (k, chunk) in coords.chunks(9).enumerate() {
        let face = k + 1;
        if chunk.len() < 9 {
            let vertices = chunk.len() / 3;
            let msg = if chunk.len() % 3 == 0 {
                format!("face {face} has {vertices} vertices: vertices are given three at a time, three to a face")
            } else {
                format!("face {face}: {} coordinates left over: vertices are given as x y z, three to a face", chunk.len())
            };
            return Err(a.at(chunk[0], msg));
        }
        if let Some(t) = chunk.iter().find(|t| t.line != chunk[0].line) {
            return Err(a.at(
                t,
                format!("face {face} is split across lines {} and {}: a set of three vertices defining a face must not be separated", chunk[0].line, t.line),
            ));
        }
        let mut vertices = [[0.0; 3]; 3];
        for (j, t) in chunk.iter().enumerate() {
            let what = format!("{} of vertex {} of face {face}", ["x", "y", "z"][j % 3], j / 3 + 1);
            vertices[j / 3][j % 3] = a.real_of(t, &what)?;
        }
        faces.push(FaceInput { vertices, line: chunk[0].line });
    }
    if faces.len() < 4 {
        return Err(a.at_end(format!("BLOCK needs at least four faces to close a surface, found {}", faces.len())));
    }
    Ok(Command::Block { material: material.unwrap_or(1), constitutive: constitutive.unwrap_or(1), faces })
}

/// PROPERTY MATERIAL n keyword value …
fn property(a: &mut Args) -> Result<Command> {
    let first = a.next().ok_or_else(|| a.at_end("expected MATERIAL n first"))?;
    if first.is_numeric() || lookup(&first.text, PROP_KEYS) != Some(None) {
        return Err(a.at(first, format!("PROPERTY must begin with MATERIAL n (the material number), found '{}'", first.shown())));
    }
    let material = a.id("the material number n")?;
    let mut values = Vec::new();
    while let Some(t) = a.next() {
        let key = match (!t.is_numeric()).then(|| lookup(&t.text, PROP_KEYS)).flatten() {
            Some(Some(k)) if k.is_fluid() => {
                let fluid = PROP_KEYS.iter().find(|n| n.value == Some(k)).map_or("", |n| n.full);
                return Err(a.at(t, format!("{fluid} is a fluid property of the 2D language (UDEC); D3 has no fluid flow")));
            }
            Some(Some(k)) => k,
            Some(None) => return Err(a.at(t, "MATERIAL may be given only once, as PROPERTY's first parameter")),
            None => {
                return Err(a.at(
                    t,
                    format!(
                        "expected a property keyword (BULK, K, G, DENSITY, KN, KS, COHESION, FRICTION, JKN, JKS, JCOHESION, JFRICTION, TF), found '{}'",
                        t.shown()
                    ),
                ));
            }
        };
        let must_be_positive = key.must_be_positive();
        let (v, vt) = a.real(&format!("a value after {}", t.shown()))?;
        if must_be_positive && (v.is_nan() || v <= 0.0 || v.is_infinite()) {
            return Err(a.at(vt, format!("{} must be above zero, found {}", t.text.to_ascii_uppercase(), vt.shown())));
        }
        if !must_be_positive && (v.is_nan() || v < 0.0 || v.is_infinite()) {
            return Err(a.at(vt, format!("{} must be 0 or more, found {}", t.text.to_ascii_uppercase(), vt.shown())));
        }
        values.push((key, v));
    }
    if values.is_empty() {
        return Err(a.at_end("PROPERTY needs at least one keyword and value after MATERIAL n"));
    }
    Ok(Command::Property { material, values })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abbreviations() {
        assert_eq!(lookup("BO", COMMANDS), Some(Word::Box));
        assert_eq!(lookup("BOU", COMMANDS), Some(Word::Boundary));
        assert_eq!(lookup("S", BOUNDARY_KINDS), Some(BoundaryKind::Stress));
        assert_eq!(lookup("B", COMMANDS), Some(Word::Block));
        assert_eq!(lookup("VERT", PRINT_ITEMS), Some(PrintItem::Vertices));
        assert_eq!(lookup("VEL", PRINT_ITEMS), Some(PrintItem::Velocities));
        assert_eq!(lookup("CON", PRINT_ITEMS), Some(PrintItem::Contacts));
        assert_eq!(lookup("FR", COMMANDS), Some(Word::Free));
    }
}
