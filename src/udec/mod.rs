//! UDEC, the 2D engine (SL-85-1, Part I and Appendix A): polygonal blocks with rounded corners,
//! their contacts, the cycle on the CPU and the GPU, the command language and the outputs. It
//! stands on the dimension-free chassis (`deck`'s lexer, `driver`, `gpu`'s device and precision,
//! `output`'s machinery, `profile`); a 3D engine (D3) will be its sibling on the same chassis.
//!
//! | module | what |
//! |---|---|
//! | [`deck`] | UDEC's commands: tokens → [`deck::Command`]s |
//! | [`model`] | the authoritative model: blocks, rounded corners, contacts, materials (by group), constitutive laws; polygon geometry and the vector helpers, corner placement, SPLIT, the verified limits |
//! | [`contact`] | what topology and both backends share: the rounded-corner contact geometry, the force–displacement law, the gather record and sum, the adjacency entry |
//! | [`output`] | PRINT tables, PLOT (PNG/SVG), state JSON, VTK, SAVE/RESTART files |
//! | [`topology`] | stage 7, CPU only: contact detection and update, adjacency lists, point-load cracking |
//! | [`backend`] | the `Backend` trait the executor drives; the model's side of the run driver |
//! | [`cpu`] | the CPU backend, one file per stage: law of motion, geometry update, contact forces, gather |
//! | [`gpu`] | the wgpu backend: the same stages as WGSL kernels (`shaders/udec/`, one file per stage, named like the CPU files), Pod state structs |
//! | [`exec`] | the command executor: runs a deck against a backend |

pub mod backend;
pub mod contact;
pub mod cpu;
pub mod deck;
pub mod exec;
pub mod gpu;
pub mod model;
pub mod output;
pub mod topology;
