//! # blockdem: a distinct element code for jointed rock
//!
//! A re-implementation of UDEC 1.2 and D3 (Cundall & Hart, SL-85-1, 1985) whose explicit cycle runs
//! on the CPU in f64 (the accuracy reference) and, through wgpu, on the GPU.
//!
//! ## Module map (it mirrors the cycle, DESIGN.md §1; the layers and the stage-by-stage file
//! table are in docs/ARCHITECTURE.md, and `tests/suite/architecture.rs` keeps the modules acyclic and
//! the chassis free of any engine)
//!
//! The chassis, dimension-free, from the bottom layer up:
//!
//! | module | what |
//! |---|---|
//! | [`deck`] | the deck language's lexer: lines → located tokens, numbers, name tables, the input error |
//! | [`output`] | numbers in the 1985 form, the plot font, a run's provenance, atomic file writes |
//! | [`profile`] | the per-stage timer the backends report to while `blockdem bench` measures |
//! | [`gpu`] | the GPU chassis: device set-up, the kernel precision (`Real`, `gpu_struct!`), shared WGSL pieces and naga validation, the bandwidth yardstick |
//! | [`driver`] | the run driver every engine and backend runs CYCLE through: resume or full detection, batches to the check interval, energy check, last good state and roll-back, progress and interruption; what a run reports |
//!
//! The engines, each in its own folder (modules listed in its own doc):
//!
//! | module | what |
//! |---|---|
//! | [`udec`] | UDEC, the 2D engine: its commands, model, contact mechanics, topology, CPU and GPU backends, executor and outputs |
//! | [`d3`] | D3, the 3D engine: its commands, polyhedral blocks, contacts, the cycle on the CPU, outputs |
//!
//! Above the engines:
//!
//! | module | what |
//! |---|---|
//! | [`scenes`] | decks shared by the tests, benchmarks and verification |
//! | [`compare`] | `blockdem compare`: a deck on the CPU reference and a GPU backend, the largest differences |
//! | [`verify`] | `blockdem verify`: closed-form cases on every backend, accuracy against speed, stability limits |
//! | [`mod@bench`] | `blockdem bench`: throughput on brick walls on every backend, the reference scene, roofline, targets |

pub mod bench;
pub mod compare;
pub mod cracking;
pub mod d3;
pub mod deck;
pub mod driver;
pub mod gpu;
pub mod output;
pub mod profile;
pub mod scenes;
pub mod udec;
pub mod verify;
