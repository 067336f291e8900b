//! The fragment floor (an extension), the one cracking rule the 2D and 3D engines share. A
//! crack's pieces can crack in turn, and under a load that keeps rising (a press, a projectile's
//! push) each generation cracks sooner than the last: the point-load value grows as 1/d² as the
//! pieces shrink, and a Griffith piece, its stress set to zero under contacts that keep pressing,
//! is loaded afresh within a quarter period of its internal mode, which shortens with its size.
//! Left alone such a cascade doubles the blocks every cycle or two, and the run never ends (a
//! 2D block of 1 m² at ROUND 0.003 with TF = 1e-300: 17 924 blocks after 40 cycles and eleven
//! minutes; a D3 cube pressed at 0.5 m/s: 5 blocks, then 12 at cycle 3 and 66 at cycle 6). So a
//! crack is made only where each piece keeps at least [`FRAGMENT_FLOOR`] of the size (area in
//! 2D, volume in 3D) of the block the deck built, which a crack's pieces inherit: a built block
//! yields at most 64 fragments. A block under twice the floor is not checked at all.

/// The least share of its block's size as built that each piece of a crack must keep.
pub const FRAGMENT_FLOOR: f64 = 1.0 / 64.0;

/// Whether a block of size `size`, of a block built at `built`, holds enough of it to leave two
/// pieces at the floor: one that does not cracks no further.
pub fn above_floor(size: f64, built: f64) -> bool {
    size >= 2.0 * FRAGMENT_FLOOR * built
}

/// The smallest piece a crack of a block built at `built` may leave.
pub fn least_piece(built: f64) -> f64 {
    FRAGMENT_FLOOR * built
}
