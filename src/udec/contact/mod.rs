//! What topology and both backends share about a contact, below all of them (docs/ARCHITECTURE.md):
//! the geometry of a rounded corner against a rounded boundary, which view of a corner pair counts,
//! which contacts are joints (¶5), the force–displacement law, and
//! the gather record with the force sum over a block's adjacency list. Each is a pure function of
//! the model's data; the CPU stage files (`cpu::contact_forces`, `cpu::gather`) drive them over the
//! whole model, and the WGSL kernels of the same names are their twins.

pub mod gather;
pub mod geometry;
pub mod joint;
pub mod law;
pub mod pair;
