//! The integration tests, one test binary: each file here is a module (named as the file) and
//! `common` holds what they share (the backends of `every_backend!`). One binary rather than one
//! per file because each binary compiles and links the crate's generics anew: thirty-six of them
//! were most of CI's build time. Run one file's tests with its module path, e.g.
//! `cargo test --release --test suite d3_split::`.

mod common;

mod architecture;
mod bench;
mod cli;
mod compare;
mod contact_rules;
mod d3_boundary;
mod d3_concave;
mod d3_concave_gpu;
mod d3_contacts;
mod d3_crack_gpu;
mod d3_deck;
mod d3_geometry;
mod d3_gpu;
mod d3_motion;
mod d3_outputs;
mod d3_random_decks;
mod d3_run;
mod d3_sdef;
mod d3_split;
mod d3_timestep;
mod deck_parser;
mod domains;
mod executor;
mod failures;
mod fdef;
mod fdef_gridpoint_lists;
mod fluid;
mod fluid_deformable;
mod geometry;
mod gpu_cli;
mod gpu_kernels;
mod gpu_shaders;
mod joints;
mod outputs;
mod physics;
mod random_decks;
mod samples;
mod sdef;
mod verify;
