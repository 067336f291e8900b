//! The commands of the UDEC 1.2 input language (SL-85-1, Appendix A, "Input Commands"), parsed
//! into values. Every command of the 1985 language has a variant here, plus the documented
//! extensions of this program (VELOCITY).

use serde::{Deserialize, Serialize};

/// A command with the place it came from, for error messages and the run log's echo.
#[derive(Clone, Debug, PartialEq)]
pub struct Located {
    pub command: Command,
    /// Line number (1-based) of the command's first line in the deck.
    pub line: usize,
    /// The command's text as typed, continuation lines joined with a space (echoed after ')').
    pub source: String,
}

/// The rectangle x1 < x < x2, y1 < y < y2 that DELETE, FIX, FREE, LOAD, CHANGE, GENERATE use to
/// select blocks by centroid.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Range {
    pub x1: f64,
    pub x2: f64,
    pub y1: f64,
    pub y2: f64,
}

/// SET OVERLAP's choice (an extension): what a CYCLE does with blocks found overlapping before
/// any motion (given so by BLOCK corners, or by a ROUND lowered under an overlap).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OverlapPolicy {
    /// REFUSE (the default): the CYCLE stops with an error naming the pairs.
    #[default]
    Refuse,
    /// ACCEPT: the CYCLE runs with the overlaps' strain energy, which the first step releases;
    /// it is booked in the energy ledger as energy put in.
    Accept,
}

/// SET's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Setting {
    /// SET OVERLAP ACCEPT|REFUSE
    Overlap(OverlapPolicy),
    /// SET DAMIN a: the minimum domain area A_d(min) (Appendix A ¶7, the Program Guide's DAMIN,
    /// "which may be set by the user"), instead of a fraction of the average block area.
    Damin(f64),
}

/// DAMPING's third parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DampMode {
    /// No qualifier: full Rayleigh damping (mass and stiffness proportional).
    Full,
    /// MASS: the stiffness-proportional dashpots are eliminated.
    Mass,
    /// STIFFNESS: the mass-proportional dashpots are eliminated.
    Stiffness,
    /// INTERNAL: applied to the 3 internal degrees of freedom of simply-deformable blocks.
    Internal,
}

/// The block type CHANGE can set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Deformability {
    Sdef,
    Fdef,
}

/// GENERATE's mesh specification.
#[derive(Clone, Debug, PartialEq)]
pub enum Mesh {
    /// AUTOMATIC amax: triangles split until every side is shorter than amax.
    Auto { max_edge: f64 },
    /// MANUAL GRIDPOINTS (glist) ZONES (zlist): zone triples number the grid points from the
    /// last one given (the last grid point is number 1), as the manual says.
    Manual { grid_points: Vec<[f64; 2]>, zones: Vec<[u32; 3]> },
}

/// A domain named by PFIX/PFREE: the outer domain, a domain by its number (its id, as PRINT
/// DOMAINS shows it), or the domain at a point (AT x y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DomainRef {
    Outer,
    Number(u32),
    At([f64; 2]),
}

/// PROPERTY keywords (Appendix A table): the chassis's, shared with D3.
pub use crate::deck::props::PropKey;

/// PRINT keywords.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrintItem {
    Blocks,
    Contacts,
    Corners,
    Domains,
    /// Block linked lists (PRINT LIST).
    List,
    /// Domain linked lists (PRINT DLIST).
    DList,
    Flows,
    /// Energy bookkeeping (extension).
    Energy,
}

/// PLOT keywords.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlotOptions {
    /// NOFIX: fixed blocks are not plotted.
    pub nofix: bool,
    /// ZONES: zones of fully-deformable blocks are plotted.
    pub zones: bool,
    /// NC: corner rounding is not drawn.
    pub no_rounding: bool,
    /// VEL: velocity vectors at block centroids.
    pub velocities: bool,
    /// PRESSURE (an extension): the domains filled by their pore pressure.
    pub pressure: bool,
}

// One line a command (rustfmt would spread every variant over lines once one has a field comment).
#[rustfmt::skip]
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    Start,
    /// RESTART [file]: continue from a SAVE file (default name when omitted).
    Restart { file: Option<String> },
    Stop,
    End,
    /// BLOCK MAT n CONS m x1 y1 x2 y2 …
    Block { material: Option<u32>, constitutive: Option<u32>, corners: Vec<[f64; 2]> },
    /// CHANGE x1 x2 y1 y2 [SDEF|FDEF] [MAT n] [CONS m]
    Change { range: Range, to: Option<Deformability>, material: Option<u32>, constitutive: Option<u32> },
    /// CYCLE n
    Cycle { n: u64 },
    /// DAMPING fcrit freq [MASS|STIFFNESS|INTERNAL]
    Damping { fcrit: f64, freq: f64, mode: DampMode },
    /// DELETE x1 x2 y1 y2
    Delete { range: Range },
    /// DUMP [n m]: a full readable state dump (the 1985 addresses have no meaning here).
    Dump { from: Option<i64>, to: Option<i64> },
    Fix { range: Range },
    Free { range: Range },
    /// FRACTION f
    Fraction { f: f64 },
    /// FLUID rhow bulkw
    Fluid { density: f64, bulk: f64 },
    /// GENERATE x1 x2 y1 y2 AUTO amax | MANUAL GRID … ZONES …
    Generate { range: Range, mesh: Mesh },
    /// GRAVITY gx gy
    Gravity { g: [f64; 2] },
    /// LINK x1 y1 x2 y2
    Link { flying: [f64; 2], anchor: [f64; 2] },
    /// LOAD x1 x2 y1 y2 fx fy
    Load { range: Range, force: [f64; 2] },
    /// PFIX domain p
    PFix { domain: DomainRef, pressure: f64 },
    /// PFREE domain
    PFree { domain: DomainRef },
    Plot { options: PlotOptions },
    Print { items: Vec<PrintItem> },
    /// PROPERTY MAT n key value …
    Property { material: u32, values: Vec<(PropKey, f64)> },
    /// ROUND d
    Round { d: f64 },
    /// SAVE [file]
    Save { file: Option<String> },
    /// SET setting value: an extension (run settings, for the rest of the run).
    Set { setting: Setting },
    /// SPLIT x1 y1 x2 y2 [MAT n] [CONS m]
    Split { from: [f64; 2], to: [f64; 2], material: Option<u32>, constitutive: Option<u32> },
    /// VIEW ix1 ix2 iy1 iy2
    View { ix1: i64, ix2: i64, iy1: i64, iy2: i64 },
    /// WINDOW x1 x2 y1 y2
    Window { x1: f64, x2: f64, y1: f64, y2: f64 },
    /// VELOCITY x1 x2 y1 y2 vx vy \[w\] (extension): blocks whose centroids lie in the range start
    /// with this velocity and angular velocity.
    Velocity { range: Range, velocity: [f64; 2], angular: Option<f64> },
    /// VTK (extension): the blocks and contacts as a frame of VTK files for ParaView, in the
    /// output folder's `vtk/` (`output::vtk`).
    Vtk,
}

impl Command {
    /// The command's full name, as error messages and the README use it.
    pub fn name(&self) -> &'static str {
        match self {
            Command::Start => "START",
            Command::Restart { .. } => "RESTART",
            Command::Stop => "STOP",
            Command::End => "END",
            Command::Block { .. } => "BLOCK",
            Command::Change { .. } => "CHANGE",
            Command::Cycle { .. } => "CYCLE",
            Command::Damping { .. } => "DAMPING",
            Command::Delete { .. } => "DELETE",
            Command::Dump { .. } => "DUMP",
            Command::Fix { .. } => "FIX",
            Command::Free { .. } => "FREE",
            Command::Fraction { .. } => "FRACTION",
            Command::Fluid { .. } => "FLUID",
            Command::Generate { .. } => "GENERATE",
            Command::Gravity { .. } => "GRAVITY",
            Command::Link { .. } => "LINK",
            Command::Load { .. } => "LOAD",
            Command::PFix { .. } => "PFIX",
            Command::PFree { .. } => "PFREE",
            Command::Plot { .. } => "PLOT",
            Command::Print { .. } => "PRINT",
            Command::Property { .. } => "PROPERTY",
            Command::Round { .. } => "ROUND",
            Command::Save { .. } => "SAVE",
            Command::Set { .. } => "SET",
            Command::Split { .. } => "SPLIT",
            Command::View { .. } => "VIEW",
            Command::Window { .. } => "WINDOW",
            Command::Velocity { .. } => "VELOCITY",
            Command::Vtk => "VTK",
        }
    }
}
