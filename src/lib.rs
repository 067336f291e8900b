//! # blockdem: a distinct element code for jointed rock
//!
//! A re-implementation of UDEC 1.2 and D3 (Cundall & Hart, SL-85-1, 1985) whose explicit cycle runs
//! on the CPU in f64 (the accuracy reference) and, through wgpu, on the GPU.
//!
//! ## Module map (it mirrors the cycle, DESIGN.md §1)
//!
//! | module | what |
//! |---|---|
//! | [`deck`] | the command language: lines → tokens → [`deck::Command`]s |
//! | [`model`] | the authoritative model: blocks, rounded corners, contacts, materials; geometry and SPLIT |
//! | [`cpu`] | the CPU backend, one file per stage: law of motion, geometry update, contact forces, gather |
//! | [`gpu`] | the wgpu backend: the same stages as WGSL kernels (`shaders/`, one file per stage, named like the CPU files), device set-up, Pod state structs |
//! | [`topology`] | stage 7, CPU only: contact detection and update, point-load cracking |
//! | [`backend`] | the `Backend` trait the executor drives |
//! | [`driver`] | the run driver both backends run CYCLE through: resume or full detection, batches to the check interval, energy check, last good state and roll-back, progress and interruption |
//! | [`exec`] | the command executor: runs a deck against a backend |
//! | [`compare`] | `blockdem compare`: a deck on the CPU reference and a GPU backend, the largest differences |
//! | [`output`] | PRINT tables, PLOT (PNG/SVG), state JSON, SAVE/RESTART files |
//! | [`scenes`] | decks shared by the tests, benchmarks and verification |
//! | [`verify`] | `blockdem verify`: closed-form cases on every backend, accuracy against speed, stability limits |
//! | [`mod@bench`] | `blockdem bench`: throughput on brick walls on every backend, the reference scene, roofline, targets |
//! | [`profile`] | the per-stage timer the backends report to while `blockdem bench` measures |

pub mod backend;
pub mod bench;
pub mod compare;
pub mod contact;
pub mod cpu;
pub mod deck;
pub mod driver;
pub mod exec;
pub mod gpu;
pub mod model;
pub mod output;
pub mod profile;
pub mod scenes;
pub mod topology;
pub mod verify;
