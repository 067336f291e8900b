//! What a run reports: what it did besides moving blocks ([`CycleReport`]) and why it stopped
//! ([`CycleError`]). Every engine's run speaks these; the 2D engine's constructors of an error
//! from its model (`CycleError::overlap`, `CycleError::non_finite_step`) are beside its model,
//! in `udec::backend`. Positions in them are [`Position`]s, of two coordinates or three, so the
//! same report serves the 2D engine and D3.

/// What a run of cycles did besides moving blocks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CycleReport {
    pub cycles: u64,
    /// Contact updates (stage 7 runs) and the contacts they created and dropped.
    pub topology_updates: u64,
    pub contacts_created: u64,
    pub contacts_dropped: u64,
    /// Cracks formed: (block id cracked, criterion value, crack ends).
    pub cracks: Vec<CrackEvent>,
    /// Time step changes forced by new, lighter blocks (from cracking).
    pub timestep_changes: Vec<(u64, f64)>,
}

/// A point in a report, of the engine's dimension: two coordinates (the 2D engine) or three (D3).
/// Indexing gives a coordinate; `Display` writes `(x, y)` or `(x, y, z)` each to four decimals in
/// exponent form, as the error messages print positions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position {
    coords: [f64; 3],
    dim: usize,
}

impl Position {
    /// A point of the plane.
    pub fn xy([x, y]: [f64; 2]) -> Self {
        Position { coords: [x, y, 0.0], dim: 2 }
    }

    /// A point of space.
    pub fn xyz(coords: [f64; 3]) -> Self {
        Position { coords, dim: 3 }
    }

    /// Its coordinates.
    pub fn coords(&self) -> &[f64] {
        &self.coords[..self.dim]
    }
}

impl std::ops::Index<usize> for Position {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.coords()[i]
    }
}

impl std::fmt::Display for Position {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let parts: Vec<String> = self.coords().iter().map(|c| format!("{c:.4e}")).collect();
        write!(f, "({})", parts.join(", "))
    }
}

/// A crack formed during a run: the block cracked, the piece it gave, and the criterion's value
/// (`criterion` names it, as the log prints it: the cracking law's label, "POINT-LOAD VALUE" or
/// "GRIFFITH STRESS").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrackEvent {
    pub cycle: u64,
    pub block: u32,
    pub new_block: u32,
    pub criterion: &'static str,
    pub value: f64,
    /// Its ends.
    pub from: Position,
    pub to: Position,
}

/// A numerical failure. When a backend returns one, the model it was given holds the last good
/// state (a checkpoint from before the failure), so it can still be printed and saved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CycleError {
    #[error(
        "contact overlap too great at cycle {cycle}: blocks {block1} and {block2} overlap by {overlap:.4e} near {at}, \
         more than half the rounding length ({limit:.4e}); the blocks are being driven through each other — \
         lower FRACTION, the loads or velocities, or raise the contact stiffness or ROUND"
    )]
    /// (`at` boxed: the error travels inside the executor's `RunError`, which stays small.)
    Overlap { cycle: u64, block1: u32, block2: u32, overlap: f64, limit: f64, at: Box<Position> },
    #[error("non-finite value at cycle {cycle}: block {block} has {what}; the run diverged — lower FRACTION, or check the loads and material properties")]
    NonFinite { cycle: u64, block: u32, what: String },
    /// `budget` is the energy the model started the CYCLE with plus the work gravity and loads
    /// did since (the largest seen): negative where blocks rose against gravity, since the work
    /// of gravity is then negative; the check counts it as zero.
    #[error(
        "energy growing without a source at cycle {cycle}: kinetic + strain energy {} exceeds the energy put in, {} \
         (the energy at the start of the CYCLE plus the work of gravity and loads since{}); \
         the explicit integration is unstable — lower FRACTION (now {}{})",
        crate::output::format::fmt_e(*.energy),
        crate::output::format::fmt_e(f64::max(*.budget, 0.0)),
        negative_budget_note(*.budget),
        frac_text(*.frac),
        safe_frac_note(*.safe_frac)
    )]
    EnergyGrowth { cycle: u64, energy: f64, budget: f64, frac: f64, safe_frac: f64 },
    #[error(
        "block {block} moves too fast at cycle {cycle}: its corners travel {travel:.4e} in one step ({speed:.4e} per unit time), \
         more than the contact update can follow ({limit:.4e}, a quarter of the contact-forming distance); it could pass through a neighbour between contact updates — \
         lower FRACTION or raise ROUND"
    )]
    TooFast { cycle: u64, block: u32, travel: f64, limit: f64, speed: f64 },
    /// A zone of a fully-deformable block turned inside out (its area not positive): the grid
    /// points were driven through each other. `zone` is its number within the block (from 1).
    #[error(
        "zone {zone} of block {block} turned inside out at cycle {cycle}: its grid points were driven through each other; \
         lower FRACTION, the loads or velocities, or zone the block finer or raise its moduli"
    )]
    ZoneInverted { cycle: u64, block: u32, zone: u32 },
    #[error("cannot cycle: {0}")]
    Setup(String),
    /// The model does not fit the backend (a GPU adapter's binding limit, a value outside the
    /// kernel precision's range); another may run it.
    #[error("cannot cycle: {0}")]
    DoesNotFit(String),
}

/// The largest safe FRACTION for an energy growth's message, where the last good state gives an
/// estimate (it has contacts carrying force; a state without them has no stiffness to estimate
/// from, and the growth came with contacts made after it).
pub(crate) fn safe_frac_note(safe_frac: f64) -> String {
    if safe_frac.is_finite() && safe_frac > 0.0 {
        format!("; the largest safe value is about {}", safe_frac_text(safe_frac))
    } else {
        String::new()
    }
}

/// Why the energy put in is counted as zero, where it is negative.
fn negative_budget_note(budget: f64) -> String {
    if budget < 0.0 {
        format!(", counted as zero: it is {} because the blocks moved against gravity and their loads", crate::output::format::fmt_e(budget))
    } else {
        String::new()
    }
}

/// A FRACTION for messages: as typed (`0.1`), or to four significant digits where it has more
/// (the FRACTIONs `blockdem verify` bisects: `0.6298`, not `0.6297873064661311`).
pub(crate) fn frac_text(frac: f64) -> String {
    let rounded = format!("{frac:.3e}").parse::<f64>().unwrap_or(frac);
    crate::output::format::fmt_short(rounded)
}

/// A safe FRACTION to two significant digits (a safe FRAC of 0.005 printed as 0.00 before).
pub(crate) fn safe_frac_text(safe_frac: f64) -> String {
    let digits = (1 - safe_frac.log10().floor() as i32).max(2) as usize;
    format!("{safe_frac:.digits$}")
}
