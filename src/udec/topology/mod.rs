//! Stage 7, CPU only: topology. Contacts are created and dropped here, blocks cracked, and the
//! per-block adjacency lists the gather walks are rebuilt — always between cycles, never inside a
//! kernel (DESIGN.md §1, STYLE.md item 6).

pub mod adjacency;
pub mod cracking;
pub mod detect;
pub mod domain;

pub use adjacency::Adjacency;
pub use cracking::{apply_crack, find_griffith_crack, find_point_load_crack, PointLoadCrack};
pub use detect::{update_contacts, update_topology};
pub use domain::{build_domains, refresh_domains, refresh_domains_with};

/// The unit tests' random numbers: a xorshift64 stream from `seed`, each call a value below `m`
/// (`m` = 2⁵³ and a division by it give a uniform f64 in [0, 1)).
#[cfg(test)]
pub(crate) fn xorshift(mut seed: u64) -> impl FnMut(u64) -> u64 {
    move |m: u64| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed % m
    }
}
