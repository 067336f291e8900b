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
//! | 8 | checksum of the payload (u64): CRC-32 (IEEE) in versions 3 to 5, FNV-1a 64 in version 2 |
//! | n | payload: [`SaveFile`] serialized with postcard, then (version 4) the contacts' laws and the model's simply-deformable extension array (`Model::sdef`, a list), then (version 5) the fully-deformable one (`Model::fdef`, a list), then (version 6) the fluid (`Model::fluid`) and the domains (`Model::domains`), each an option, then (version 7) the areas as built of a crack's pieces (`Block::built_area`, a list) |
//!
//! postcard writes every f64 as its 8 IEEE bytes, so the round trip is bit-exact (NaN payloads
//! and −0.0 included). The length and checksum make a truncated or damaged file an error, never
//! a model with silently wrong numbers; a file intact but holding a model no run could have
//! made (an index past its list, a non-finite position: a writer's bug or a hand edit) is
//! refused by [`Model::validate`], since the rest of the program trusts those indices. The version must change whenever `SaveFile` or anything
//! in it (the `Model` types) changes shape: postcard is not self-describing.
//!
//! The payload is streamed to the file as it is serialized and the header's length and checksum
//! written last: a 10⁶-block model's 1.6 GB payload is never held in memory, twice, as it was
//! up to version 2, whose byte-at-a-time FNV checksum also cost a second a gigabyte (CRC-32 runs
//! at memory speed). Version 2 files are still read.
//!
//! Version 4 appends to the version 3 payload the joints (Appendix A ¶5): the index and
//! `Contact::joint_length` of each contact that follows the joint law, as one postcard list
//! (empty for a model without joints), which the contact's own record does not hold; then the
//! simply-deformable extension (`Model::sdef`, empty for a rigid model). Version 2 and 3 files,
//! written before both, read with every contact a point contact and every block rigid.
//!
//! Version 6 appends the fluid (FLUID's properties and the mass balance's and energy ledger's
//! accounts, `Model::fluid`) and the domains as the cycle carries them (`Model::domains`: their
//! ids, pressures, PFIX, the areas the next pressure update starts from, the boundaries and
//! each contact's sides and last flow), so that a scene with fluid restarts where it stopped:
//! CYCLE N, SAVE, RESTART, CYCLE M is CYCLE N + M bit for bit. A scene without fluid that had
//! its domains built (PRINT DOMAINS) keeps them too, with their ids. Files of versions 2 to 5
//! read as a model without fluid, whose domains RESTART builds again when asked.
//!
//! Version 7 appends the area as built of each block a crack made (`Block::built_area`, the
//! fragment floor's measure, `crate::cracking`: index and area, for the blocks whose own area it
//! is not), so that a restarted run cracks its pieces as the run that saved them would have.
//! Files of versions 2 to 6 read with every block built as it is.

use std::fs;
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::plot::PlotSettings;
use crate::udec::model::Model;

/// The first eight bytes of every save file.
pub const MAGIC: [u8; 8] = *b"BLOCKDEM";
/// The save format this program writes (and reads, with versions 2 to 6, which keep no areas
/// as built, 2 to 5 no fluid, and 2 and 3 no joints and no simply-deformable blocks).
pub const FORMAT_VERSION: u32 = 7;
/// The first version with the blocks' areas as built (this one).
const BUILT_VERSION: u32 = FORMAT_VERSION;
/// Version 5: the zones, no fluid and no domains (read as a dry model whose domains are built
/// again when asked).
const FDEF_VERSION: u32 = 5;
/// Version 6: the fluid and the domains, no areas as built (read with each block built as it is).
const FLUID_VERSION: u32 = 6;
/// Version 4: the joints and the simply-deformable extension, no zones (read as a model
/// without fully-deformable blocks' zones).
const SDEF_VERSION: u32 = 4;
/// The format before the joints' list and the simply-deformable extension (the same payload
/// without them, under CRC-32).
const POINT_VERSION: u32 = 3;
/// The older format still read: the same payload under an FNV-1a 64 checksum.
const FNV_VERSION: u32 = 2;
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
    UnsupportedVersion { path: PathBuf, found: u32, supported: u32 },
    #[error("save file {path} is corrupt: {reason}")]
    Corrupt { path: PathBuf, reason: String },
    /// Intact as a file (its checksum matches) but holding a model no run could have made: an
    /// index past its list, a corner range out of order, a non-finite position. The program
    /// trusts these throughout, so such a model is refused rather than cycled.
    #[error("the model saved in {path} is inconsistent: {reason}")]
    Inconsistent { path: PathBuf, reason: String },
}

/// FNV-1a, 64 bit: the checksum of version 2 files.
fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

/// The checksum a file of format `version` carries for `payload`.
fn checksum(version: u32, payload: &[u8]) -> u64 {
    if version == FNV_VERSION {
        fnv1a64(payload)
    } else {
        crc32fast::hash(payload) as u64
    }
}

/// Bytes the payload is checksummed and written in.
const CHUNK: usize = 1 << 16;

/// The payload's way to the file: postcard writes it a field at a time (often 8 bytes), this
/// gathers them into chunks, checksums each chunk and writes it on, and counts the bytes. An
/// I/O error is kept (postcard reports every failure of its writer as a full buffer).
struct PayloadWriter<'a, W: Write> {
    file: &'a mut W,
    chunk: Vec<u8>,
    crc: crc32fast::Hasher,
    length: u64,
    error: Option<io::Error>,
}

impl<'a, W: Write> PayloadWriter<'a, W> {
    fn new(file: &'a mut W) -> Self {
        PayloadWriter { file, chunk: Vec::with_capacity(CHUNK), crc: crc32fast::Hasher::new(), length: 0, error: None }
    }

    fn write_chunk(&mut self) -> io::Result<()> {
        self.crc.update(&self.chunk);
        self.length += self.chunk.len() as u64;
        let r = self.file.write_all(&self.chunk);
        self.chunk.clear();
        r.inspect_err(|e| self.error = Some(io::Error::new(e.kind(), e.to_string())))
    }

    /// Writes what is left; the payload's length and checksum.
    fn finish(mut self) -> io::Result<(u64, u64)> {
        self.write_chunk()?;
        Ok((self.length, self.crc.finalize() as u64))
    }
}

impl<W: Write> Write for PayloadWriter<'_, W> {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        if self.chunk.len() + bytes.len() > CHUNK {
            self.write_chunk()?;
        }
        if bytes.len() >= CHUNK {
            self.chunk.extend_from_slice(bytes);
            self.write_chunk()?;
        } else {
            self.chunk.extend_from_slice(bytes);
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// What SAVE writes, borrowed from the running program: serialized field for field as a
/// [`SaveFile`] (postcard writes a struct as its fields in order), so a save needs no copy of
/// the model.
#[derive(Serialize)]
struct SaveView<'a> {
    model: &'a Model,
    plot: &'a PlotSettings,
    plot_count: usize,
    /// The contacts that are joints: (index, `Contact::joint_length`), ascending (version 4).
    joints: Vec<(u32, f64)>,
    /// Version 4's last trailer: the model's simply-deformable extension.
    sdef: &'a [crate::udec::model::sdef::Sdef],
    /// Version 5's: the fully-deformable blocks' zones and grid points (`Model::fdef`).
    fdef: &'a [crate::udec::model::fdef::Fdef],
    /// Version 6's: the fluid (`Model::fluid`), then the domains (`Model::domains`).
    fluid: &'a Option<crate::udec::model::fluid::Fluid>,
    domains: &'a Option<crate::udec::model::domain::Domains>,
    /// Version 7's: the area as built of each block a crack made (`built_areas_of`).
    built_areas: Vec<(u32, f64)>,
}

/// The area as built (`Block::built_area`, the fragment floor's measure) of each block whose
/// own area it is not (a crack's pieces), by block index, ascending: what version 7 appends.
fn built_areas_of(model: &Model) -> Vec<(u32, f64)> {
    model.blocks.iter().enumerate().filter(|(_, b)| b.built_area != b.area).map(|(i, b)| (i as u32, b.built_area)).collect()
}

/// The contacts of `model` that follow the joint law, as version 4 files list them.
fn joints_of(model: &Model) -> Vec<(u32, f64)> {
    model.contacts.iter().enumerate().filter(|(_, c)| c.joint_length != 0.0).map(|(k, c)| (k as u32, c.joint_length)).collect()
}

/// SAVE: writes `file` to `path` (see [`save_state`]).
pub fn save(path: &Path, file: &SaveFile) -> Result<(), RestartError> {
    save_state(path, &file.model, &file.plot, file.plot_count)
}

/// SAVE: writes the model and the plot state to `path` as a [`SaveFile`], atomically (a
/// temporary file renamed into place), so an interrupted SAVE leaves the previous save file
/// intact. The header goes first with its length and checksum zero, the payload after it as it
/// is serialized, and then the two are written into the header. A path that is not a regular
/// file (a FIFO) is written in place and cannot seek: the payload is then serialized twice,
/// once for its length and checksum, written first, and once to the file.
pub fn save_state(path: &Path, model: &Model, plot: &PlotSettings, plot_count: usize) -> Result<(), RestartError> {
    let file = SaveView {
        model,
        plot,
        plot_count,
        joints: joints_of(model),
        sdef: &model.sdef,
        fdef: &model.fdef,
        fluid: &model.fluid,
        domains: &model.domains,
        built_areas: built_areas_of(model),
    };
    let io_err = |source| RestartError::Io { path: path.to_path_buf(), source };
    super::write_atomically(path, |w| {
        let seekable = w.get_ref().metadata()?.is_file();
        let header = |w: &mut dyn Write, length: u64, checksum: u64| {
            w.write_all(&MAGIC)?;
            w.write_all(&FORMAT_VERSION.to_le_bytes())?;
            w.write_all(&length.to_le_bytes())?;
            w.write_all(&checksum.to_le_bytes())
        };
        if seekable {
            header(w, 0, 0)?;
            let (length, checksum) = write_payload(&file, w)?;
            w.seek(SeekFrom::Start((MAGIC.len() + 4) as u64))?;
            w.write_all(&length.to_le_bytes())?;
            w.write_all(&checksum.to_le_bytes())
        } else {
            let (length, checksum) = write_payload(&file, &mut io::sink())?;
            header(w, length, checksum)?;
            // postcard's encoding of the same borrowed state is the same bytes.
            write_payload(&file, w).map(drop)
        }
    })
    .map_err(io_err)
}

/// Streams the payload of `file` to `w`; returns its length and checksum.
fn write_payload(file: &SaveView, w: &mut impl Write) -> io::Result<(u64, u64)> {
    let mut payload = PayloadWriter::new(w);
    if let Err(e) = postcard::to_io(file, &mut payload) {
        return Err(payload.error.take().unwrap_or_else(|| io::Error::other(e)));
    }
    payload.finish()
}

/// RESTART: reads a save file written by [`save`].
///
/// The header is read first, and the payload then only as far as the header announces: a path
/// that is not a save file (`/dev/zero`, a FIFO fed for ever, a deck given by mistake) is
/// refused at its first bytes instead of being read to an end it may not have.
pub fn load(path: &Path) -> Result<SaveFile, RestartError> {
    let io_err = |source| RestartError::Io { path: path.to_path_buf(), source };
    let mut file = fs::File::open(path).map_err(io_err)?;
    let mut header = Vec::with_capacity(HEADER_LEN);
    (&mut file).take(HEADER_LEN as u64).read_to_end(&mut header).map_err(io_err)?;
    let Header { version, length, checksum } = decode_header(&header).map_err(|e| e.at(path))?;
    let short = |holds: u64| {
        DecodeError::Corrupt(format!("the header announces {length} payload bytes but the file holds {holds} (truncated or appended to)")).at(path)
    };
    // A regular file's length is known: checked before anything is allocated for the payload.
    let size = file.metadata().ok().filter(|m| m.is_file()).map(|m| m.len());
    if let Some(holds) = size.map(|size| size.saturating_sub(HEADER_LEN as u64)).filter(|&holds| holds != length) {
        return Err(short(holds));
    }
    let mut payload = Vec::with_capacity(size.map_or(0, |_| length as usize));
    (&mut file).take(length).read_to_end(&mut payload).map_err(io_err)?;
    if payload.len() as u64 != length {
        return Err(short(payload.len() as u64));
    }
    if file.read(&mut [0u8]).map_err(io_err)? > 0 {
        return Err(DecodeError::Corrupt(format!("the header announces {length} payload bytes but more follow (appended to)")).at(path));
    }
    decode_payload(version, checksum, &payload).map_err(|e| e.at(path))
}

/// A decoding failure before the path is attached.
enum DecodeError {
    NotASaveFile,
    UnsupportedVersion(u32),
    Corrupt(String),
    Inconsistent(String),
}

impl DecodeError {
    fn at(self, path: &Path) -> RestartError {
        let path = path.to_path_buf();
        match self {
            DecodeError::NotASaveFile => RestartError::NotASaveFile { path },
            DecodeError::UnsupportedVersion(found) => RestartError::UnsupportedVersion { path, found, supported: FORMAT_VERSION },
            DecodeError::Corrupt(reason) => RestartError::Corrupt { path, reason },
            DecodeError::Inconsistent(reason) => RestartError::Inconsistent { path, reason },
        }
    }
}

/// What a save file's header says about its payload.
struct Header {
    version: u32,
    length: u64,
    checksum: u64,
}

/// Checks the first [`HEADER_LEN`] bytes of a file (fewer where the file is shorter).
fn decode_header(bytes: &[u8]) -> Result<Header, DecodeError> {
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(DecodeError::NotASaveFile);
    }
    if bytes.len() < HEADER_LEN {
        return Err(DecodeError::Corrupt(format!("the header is truncated ({} of {HEADER_LEN} bytes)", bytes.len())));
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if ![FORMAT_VERSION, FLUID_VERSION, FDEF_VERSION, SDEF_VERSION, POINT_VERSION, FNV_VERSION].contains(&version) {
        return Err(DecodeError::UnsupportedVersion(version));
    }
    Ok(Header { version, length: u64_at(12), checksum: u64_at(20) })
}

/// The payload of a file of format `version` whose header gives it checksum `expected`.
fn decode_payload(version: u32, expected: u64, payload: &[u8]) -> Result<SaveFile, DecodeError> {
    if checksum(version, payload) != expected {
        return Err(DecodeError::Corrupt("the payload checksum does not match".to_string()));
    }
    let (mut file, mut rest) = postcard::take_from_bytes::<SaveFile>(payload).map_err(|e| DecodeError::Corrupt(format!("bad payload: {e}")))?;
    if version >= SDEF_VERSION {
        let joints;
        (joints, rest) = postcard::take_from_bytes::<Vec<(u32, f64)>>(rest).map_err(|e| DecodeError::Corrupt(format!("bad list of joints: {e}")))?;
        for (k, length) in joints {
            let Some(c) = file.model.contacts.get_mut(k as usize) else {
                return Err(DecodeError::Inconsistent(format!("a joint names contact index {k}, past the {} contacts", file.model.contacts.len())));
            };
            if !(length.is_finite() && length > 0.0) {
                return Err(DecodeError::Inconsistent(format!("contact {} has a joint length of {length}", c.id)));
            }
            c.joint_length = length;
        }
        (file.model.sdef, rest) = postcard::take_from_bytes(rest).map_err(|e| DecodeError::Corrupt(format!("bad simply-deformable extension: {e}")))?;
    }
    if version >= FDEF_VERSION {
        (file.model.fdef, rest) = postcard::take_from_bytes(rest).map_err(|e| DecodeError::Corrupt(format!("bad fully-deformable extension: {e}")))?;
    }
    if version >= FLUID_VERSION {
        (file.model.fluid, rest) = postcard::take_from_bytes(rest).map_err(|e| DecodeError::Corrupt(format!("bad fluid: {e}")))?;
        (file.model.domains, rest) = postcard::take_from_bytes(rest).map_err(|e| DecodeError::Corrupt(format!("bad domains: {e}")))?;
    }
    // Each block built as it is, but for a crack's pieces (version 7).
    for b in &mut file.model.blocks {
        b.built_area = b.area;
    }
    if version >= BUILT_VERSION {
        let built: Vec<(u32, f64)>;
        (built, rest) = postcard::take_from_bytes(rest).map_err(|e| DecodeError::Corrupt(format!("bad areas as built: {e}")))?;
        let n = file.model.blocks.len();
        for (i, area) in built {
            let b = file.model.blocks.get_mut(i as usize).ok_or_else(|| DecodeError::Inconsistent(format!("an area as built names block index {i} of {n}")))?;
            b.built_area = area;
        }
    }
    if !rest.is_empty() {
        return Err(DecodeError::Corrupt(format!("{} unread bytes after the payload", rest.len())));
    }
    check(&file).map_err(DecodeError::Inconsistent)?;
    Ok(file)
}

/// What a save file must hold beyond a readable payload: a model that passes
/// [`Model::validate`], and plot settings that the WINDOW and VIEW commands could have set.
fn check(file: &SaveFile) -> Result<(), String> {
    let [x1, x2, y1, y2] = file.plot.window;
    if !(x1.is_finite() && x2.is_finite() && y1.is_finite() && y2.is_finite()) {
        return Err(format!("the plot window ({x1}, {x2}, {y1}, {y2}) is not finite"));
    }
    let [ix1, ix2, iy1, iy2] = file.plot.view;
    if ix1 > ix2 || iy1 > iy2 {
        return Err(format!("the plot view ({ix1}, {ix2}, {iy1}, {iy2}) is not in order"));
    }
    file.model.validate()
}
