//! D3, the 3D engine (SL-85-1 Part III ¶9–32, Part IV ¶35, Appendix B): polyhedral blocks of
//! triangular faces on the same chassis as the 2D engine (the deck lexer, the run driver, the
//! output formatting). Its modules, from the bottom layer up:
//!
//! | module | what |
//! |---|---|
//! | [`deck`] | Appendix B's commands on the chassis lexer: tokens → [`deck::Command`]s; which decks are 3D |
//! | [`geometry`] | a block's closed surface checked, its volume, centroid and exact inertia tensor (¶12–16) |
//! | [`decompose`] | a concave block cut into the convex parts contact detection sees (¶13) |
//! | [`model`] | blocks, materials, contacts (real with their logical contacts, or degenerate), the clock |
//! | [`motion`] | stages 1–2: central differences for translation and for the angular momentum, the orientation a unit quaternion (¶17) |
//! | [`contact`] | stage 4: the common plane, the six physical categories, the logical vertex–face and edge–edge contacts, ¶23's normal prescription, the force–displacement law (¶18–24, ¶35) |
//! | [`sdef`] | simply-deformable blocks (¶35d): six internal degrees of freedom of uniform strain, their stress, inertia and step |
//! | [`cracking`] | stage 7's cracking criteria (¶35f): Griffith's law on simply-deformable blocks, the point-load law on the contact forces |
//! | [`split`] | SPLIT: a plane cuts the convex blocks it crosses in two, mass properties afresh, momentum kept |
//! | [`topology`] | stage 7: the neighbour lists on a uniform grid, rebuilt past a travel threshold (¶26) |
//! | [`grain`] | how finely the CPU cycle's parallel passes split (the fewest items a task takes) |
//! | [`backend`] | what the executor asks of a backend, the CPU's or the GPU's |
//! | [`cpu`] | the cycle on the CPU in f64 through the chassis's run driver |
//! | [`gpu`] | the cycle on the GPU (WGSL in `shaders/d3/`, f32 or f64), detection on the CPU between cycles |
//! | [`output`] | the PRINT tables, DUMP and the state JSON |
//! | [`restart`] | SAVE/RESTART files: the whole state, bit for bit, in a versioned, checksummed envelope |
//! | [`vtk`] | VTK frames of the blocks (faces with their block's motion) and contacts (points with normal and forces), and their series |
//! | [`exec`] | runs a deck's commands |

pub mod backend;
pub mod contact;
pub mod cpu;
pub mod cracking;
pub mod deck;
pub mod decompose;
pub mod exec;
pub mod geometry;
pub mod gpu;
pub mod grain;
pub mod model;
pub mod motion;
pub mod output;
pub mod restart;
pub mod sdef;
pub mod split;
pub mod topology;
pub mod vtk;
