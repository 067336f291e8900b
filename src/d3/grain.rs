//! The grain of the D3 CPU cycle's parallel passes (`d3::cpu`, and the critical step's pass in
//! `d3::model`).
//!
//! The fewest items one parallel task of the cycle takes, by the work an item is: handing a
//! task to the other thread and joining it costs some microseconds (a cycle of eight cubes took
//! 22 µs on one thread and 60 µs on two of this machine's, its passes split to the last item),
//! so each pass splits only where a task's share is well over that, and a small scene's cycle
//! runs on one thread. Where the tasks fall changes no result: each item's work is its own, and
//! what is summed is summed in order after the pass.

/// A block's forces reset (tens of instructions).
pub const RESET: usize = 1024;
/// A contact's sums for gather (hundreds).
pub const SUMS: usize = 256;
/// A block's law of motion, its placement, its principal moments (about a thousand).
pub const BLOCK: usize = 128;
/// A contact's stage 4 (about ten thousand).
pub const CONTACT: usize = 8;
/// A contact's deepest overlap (tens).
pub const CHECK: usize = 1024;
