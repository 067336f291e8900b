//! SAVE/RESTART files (DESIGN.md §5): the whole problem state in a versioned binary file, so
//! that a restarted run continues identically.
//!
//! Layout, all integers little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `BLOCKDEM` |
//! | 4 | format version (u32), [`FORMAT_VERSION`] |
//! | 8 | payload length in bytes (u64) |
//! | 8 | FNV-1a 64 checksum of the payload (u64) |
//! | n | payload: [`SaveFile`] serialized with postcard |
//!
//! postcard writes every f64 as its 8 IEEE bytes, so the round trip is bit-exact (NaN payloads
//! and −0.0 included). The length and checksum make a truncated or damaged file an error, never
//! a model with silently wrong numbers. The version must change whenever `SaveFile` or anything
//! in it (the `Model` types) changes shape: postcard is not self-describing.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::plot::PlotSettings;
use crate::model::Model;

/// The first eight bytes of every save file.
pub const MAGIC: [u8; 8] = *b"BLOCKDEM";
/// The save format this program writes and reads.
pub const FORMAT_VERSION: u32 = 2;
/// Bytes before the payload: magic, version, length, checksum.
const HEADER_LEN: usize = 8 + 4 + 8 + 8;

/// Everything SAVE keeps: the model and the plot state (WINDOW, VIEW and how many plots have been
/// written, so that a restarted run numbers its plot files on from where it stopped).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaveFile {
    pub model: Model,
    pub plot: PlotSettings,
    pub plot_count: usize,
}

/// Why a save file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum RestartError {
    #[error("cannot access save file {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{path} is not a blockdem save file (it does not start with \"BLOCKDEM\")")]
    NotASaveFile { path: PathBuf },
    #[error("{path} is save format version {found}; this program reads version {supported}")]
    UnsupportedVersion {
        path: PathBuf,
        found: u32,
        supported: u32,
    },
    #[error("save file {path} is corrupt: {reason}")]
    Corrupt { path: PathBuf, reason: String },
}

/// FNV-1a, 64 bit: a few lines, no dependency, and enough to catch damage (not tampering).
fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// SAVE: writes `file` to `path`, atomically (a temporary file renamed into place), so an
/// interrupted SAVE leaves the previous save file intact.
pub fn save(path: &Path, file: &SaveFile) -> Result<(), RestartError> {
    let io_err = |source| RestartError::Io {
        path: path.to_path_buf(),
        source,
    };
    let payload = postcard::to_stdvec(file).map_err(|e| io_err(io::Error::other(e)))?;
    let mut bytes = Vec::with_capacity(HEADER_LEN + payload.len());
    bytes.extend_from_slice(&MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&fnv1a64(&payload).to_le_bytes());
    bytes.extend_from_slice(&payload);
    super::write_atomically(path, |w| w.write_all(&bytes)).map_err(io_err)
}

/// RESTART: reads a save file written by [`save`].
pub fn load(path: &Path) -> Result<SaveFile, RestartError> {
    let bytes = fs::read(path).map_err(|source| RestartError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode(&bytes).map_err(|e| e.at(path))
}

/// A decoding failure before the path is attached.
enum DecodeError {
    NotASaveFile,
    UnsupportedVersion(u32),
    Corrupt(String),
}

impl DecodeError {
    fn at(self, path: &Path) -> RestartError {
        let path = path.to_path_buf();
        match self {
            DecodeError::NotASaveFile => RestartError::NotASaveFile { path },
            DecodeError::UnsupportedVersion(found) => RestartError::UnsupportedVersion {
                path,
                found,
                supported: FORMAT_VERSION,
            },
            DecodeError::Corrupt(reason) => RestartError::Corrupt { path, reason },
        }
    }
}

fn decode(bytes: &[u8]) -> Result<SaveFile, DecodeError> {
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(DecodeError::NotASaveFile);
    }
    if bytes.len() < HEADER_LEN {
        return Err(DecodeError::Corrupt(format!(
            "the header is truncated ({} of {HEADER_LEN} bytes)",
            bytes.len()
        )));
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if version != FORMAT_VERSION {
        return Err(DecodeError::UnsupportedVersion(version));
    }
    let (length, checksum) = (u64_at(12), u64_at(20));
    let payload = &bytes[HEADER_LEN..];
    if payload.len() as u64 != length {
        return Err(DecodeError::Corrupt(format!(
            "the header announces {length} payload bytes but the file holds {} (truncated or appended to)",
            payload.len()
        )));
    }
    if fnv1a64(payload) != checksum {
        return Err(DecodeError::Corrupt(
            "the payload checksum does not match".to_string(),
        ));
    }
    let (file, rest) = postcard::take_from_bytes::<SaveFile>(payload)
        .map_err(|e| DecodeError::Corrupt(format!("bad payload: {e}")))?;
    if !rest.is_empty() {
        return Err(DecodeError::Corrupt(format!(
            "{} unread bytes after the payload",
            rest.len()
        )));
    }
    Ok(file)
}
