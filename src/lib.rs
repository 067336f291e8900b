//! # blockdem: a distinct element code for jointed rock
//!
//! A re-implementation of UDEC 1.2 and D3 (Cundall & Hart, SL-85-1, 1985) whose explicit cycle runs
//! on the CPU in f64 (the accuracy reference) and, through wgpu, on the GPU.
//!
//! ## Module map (it mirrors the cycle, DESIGN.md §1; the layers and the stage-by-stage file
//! table are in docs/ARCHITECTURE.md, and `tests/architecture.rs` keeps the modules acyclic)
//!
//! From the bottom layer up; a module uses only those above it in this table's order, never one
//! below.
//!
//! | module | what |
//! |---|---|
//! | [`deck`] | the command language: lines → tokens → [`deck::Command`]s |
//! | [`model`] | the authoritative model: blocks, rounded corners, contacts, materials (by group), constitutive laws; polygon geometry and the vector helpers, corner placement, SPLIT, the verified limits |
//! | [`profile`] | the per-stage timer the backends report to while `blockdem bench` measures |
//! | [`contact`] | what topology and both backends share: the rounded-corner contact geometry, the force–displacement law, the gather record and sum, the adjacency entry |
//! | [`output`] | PRINT tables, PLOT (PNG/SVG), state JSON, VTK, SAVE/RESTART files |
//! | [`topology`] | stage 7, CPU only: contact detection and update, adjacency lists, point-load cracking |
//! | [`backend`] | the `Backend` trait the executor drives |
//! | [`driver`] | the run driver both backends run CYCLE through: resume or full detection, batches to the check interval, energy check, last good state and roll-back, progress and interruption |
//! | [`cpu`] | the CPU backend, one file per stage: law of motion, geometry update, contact forces, gather |
//! | [`gpu`] | the wgpu backend: the same stages as WGSL kernels (`shaders/`, one file per stage, named like the CPU files), device set-up, Pod state structs |
//! | [`exec`] | the command executor: runs a deck against a backend |
//! | [`scenes`] | decks shared by the tests, benchmarks and verification |
//! | [`compare`] | `blockdem compare`: a deck on the CPU reference and a GPU backend, the largest differences |
//! | [`verify`] | `blockdem verify`: closed-form cases on every backend, accuracy against speed, stability limits |
//! | [`mod@bench`] | `blockdem bench`: throughput on brick walls on every backend, the reference scene, roofline, targets |

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
