//! D3's SAVE/RESTART files (Appendix B's SAVE and RESTART; DESIGN.md §5): the whole problem
//! state in a versioned binary file, so that a restarted run continues bit for bit.
//!
//! The envelope is the 2D engine's (`udec::output::restart`), with D3's own magic so that neither
//! engine mistakes the other's file for its own (and `blockdem run` can tell a RESTART deck's
//! engine by its file). All integers little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `BLOCKD3\0` |
//! | 4 | format version (u32), [`FORMAT_VERSION`] |
//! | 8 | payload length in bytes (u64) |
//! | 8 | CRC-32 (IEEE) of the payload (u64) |
//! | n | payload: [`SaveFile`] serialized with postcard |
//!
//! postcard writes every f64 as its 8 IEEE bytes, so the round trip is bit-exact. The length and
//! checksum make a truncated or damaged file an error; an intact file whose model no run could
//! have made (an index past its list, a non-finite position) is refused by [`check`]. The
//! version must change whenever `d3::model` changes shape: postcard is not self-describing.
//!
//! The file also records whether the saved model is the state the last CYCLE left untouched
//! (`resumable`): the CPU backend then goes on from it as it would have in the saving run,
//! without the full contact detection a changed model gets (which would renumber the
//! neighbour lists' contacts and restart the travel counts), so that CYCLE N, SAVE, RESTART,
//! CYCLE M leaves the state CYCLE N+M leaves, bit for bit.
//!
//! A GPU backend's state is more than the model: between detections it keeps each contact's
//! logical contacts as the last detection found them (dead ones too, `live` 0), the energy it
//! has counted since the last upload on top of the model's totals then, the time step of the
//! batch, and in f32 each centroid as a compensated pair. A file saved from a GPU run that SAVE
//! could resume keeps those as the device holds them ([`DeviceState`]), so that a RESTART on a
//! GPU backend of the same precision uploads them as they were instead of detecting afresh, and
//! goes on bit for bit as the saving run would have; any other backend (the CPU, the other
//! precision) ignores them and starts as from any model.

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::model::{FaceStress, LogicalKind, Model, Part};
use super::sdef::Sdef;

/// The first eight bytes of every D3 save file.
pub const MAGIC: [u8; 8] = *b"BLOCKD3\0";
/// The first eight bytes of a 2D (UDEC) save file, named in the refusal of one.
const UDEC_MAGIC: [u8; 8] = *b"BLOCKDEM";
/// The D3 save format this program writes and reads.
/// (Version 2: the model keeps the energy dissipated, `d3::model::Dissipation`; version 3: the GPU
/// backend's device state, [`DeviceState`]; version 4: the f32 kernels keep vertices as offsets
/// from their centroids and logical contacts' points from their contact's block 1's centroid
/// (`d3::gpu`, RELATIVE), where version 3's kept them in global axes. A version-3 file is read,
/// its model as it was, but its f32 device state is marked [`DeviceState::absolute_f32`] and not
/// taken (the run detects afresh, and says so); an older file is refused by name. Version 5: the
/// payload ends with the [`Extension`], the simply-deformable blocks' strain and the internal
/// damping; a version-3 or -4 file has none, its blocks rigid as they were. Version 6: after
/// that, the [`Boundaries`], the blocks held by BOUNDARY VELOCITY and the faces loaded by
/// BOUNDARY STRESS; a file of an older version has none. Version 7: after that, the [`Parts`],
/// the concave blocks' convex parts and the parts each contact is between; a concave block of an
/// older file, built but never cycled, is cut into its parts as it is read. Version 8: after
/// that, the [`Lineage`], the volume as built of each crack's piece; in an older file every
/// block counts as built as it is. Version 9: after that, the [`Offsets`] of the logical
/// contacts' normal springs; in an older file every one is 0.)
pub const FORMAT_VERSION: u32 = 9;
/// The oldest save format this program reads (its payload is version 4's, without the
/// extension).
pub const OLDEST_VERSION: u32 = 3;
const HEADER_LEN: usize = 8 + 4 + 8 + 8;

/// Everything SAVE keeps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaveFile {
    pub model: Model,
    /// The model is the state the last CYCLE left, unchanged since (the backend resumes from it).
    pub resumable: bool,
    /// The GPU backend's device state, when a GPU run left the model (and `resumable`).
    pub device: Option<DeviceState>,
}

/// The simply-deformable extension array (the report's, Appendix B; `d3::sdef`), written after
/// the [`SaveFile`] in the payload (format 5): each SDEF block's state by its index, and
/// DAMPING … INTERNAL's constant. Kept apart from the model's own fields so that the files of
/// formats 3 and 4, which end before it, read as they were.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Extension {
    pub sdef: Vec<(u32, Sdef)>,
    pub alpha_internal: f64,
}

impl Extension {
    /// The extension of `model`.
    pub fn of(model: &Model) -> Extension {
        Extension {
            sdef: model.blocks.iter().enumerate().filter_map(|(i, b)| b.sdef.map(|s| (i as u32, s))).collect(),
            alpha_internal: model.damping.alpha_internal,
        }
    }

    /// Puts the extension back into `model`; an index past its blocks is an error.
    pub fn apply(self, model: &mut Model) -> Result<(), String> {
        for (i, s) in self.sdef {
            let n = model.blocks.len();
            let b = model.blocks.get_mut(i as usize).ok_or_else(|| format!("a simply-deformable state names block index {i} of {n}"))?;
            let finite = s.strain.iter().chain(&s.strain_rate).chain(&s.stress).all(|x| x.is_finite());
            if !finite {
                return Err(format!("block {} has a non-finite strain or stress", b.id));
            }
            b.sdef = Some(s);
        }
        model.damping.alpha_internal = self.alpha_internal;
        Ok(())
    }
}

/// The boundary conditions (BOUNDARY, Part IV ¶35e; extension), written after the
/// [`Extension`] in the payload (format 6): the indices of the blocks held by BOUNDARY VELOCITY
/// (their velocity and spin are the model's), and each block's faces loaded by BOUNDARY STRESS
/// by its index.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Boundaries {
    pub held: Vec<u32>,
    pub stress: Vec<(u32, Vec<FaceStress>)>,
}

impl Boundaries {
    /// The boundary conditions of `model`.
    pub fn of(model: &Model) -> Boundaries {
        Boundaries {
            held: model.blocks.iter().enumerate().filter(|(_, b)| b.held).map(|(i, _)| i as u32).collect(),
            stress: model
                .blocks
                .iter()
                .enumerate()
                .filter(|(_, b)| !b.boundary_stress.is_empty())
                .map(|(i, b)| (i as u32, b.boundary_stress.clone()))
                .collect(),
        }
    }

    /// Puts the boundary conditions back into `model`; an index past its blocks or faces, a
    /// face listed twice or out of order, a held block that is fixed or a non-finite stress is
    /// an error.
    pub fn apply(self, model: &mut Model) -> Result<(), String> {
        let n = model.blocks.len();
        for i in self.held {
            let b = model.blocks.get_mut(i as usize).ok_or_else(|| format!("a held block names block index {i} of {n}"))?;
            if b.fixed {
                return Err(format!("block {} is both fixed and held", b.id));
            }
            b.held = true;
        }
        for (i, faces) in self.stress {
            let b = model.blocks.get_mut(i as usize).ok_or_else(|| format!("a boundary stress names block index {i} of {n}"))?;
            let count = b.shape.faces.len() as u32;
            if faces.iter().any(|l| l.face >= count) || faces.windows(2).any(|w| w[0].face >= w[1].face) {
                return Err(format!("block {}'s boundary stresses name faces out of order or past its {count}", b.id));
            }
            if !faces.iter().all(|l| l.stress.iter().all(|x| x.is_finite())) {
                return Err(format!("block {} has a non-finite boundary stress", b.id));
            }
            b.boundary_stress = faces;
        }
        Ok(())
    }
}

/// The concave blocks' convex parts (`Block::parts`, `d3::decompose`) by block index, and the
/// parts of the contacts that are not between parts 0 (by contact index), written after the
/// [`Boundaries`] in the payload (format 7). The parts are kept as built (their vertices as
/// placed) rather than cut again, so that a file reads the same whatever cut a later program
/// would make.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Parts {
    pub blocks: Vec<(u32, Vec<Part>)>,
    pub contacts: Vec<(u32, [u32; 2])>,
}

impl Parts {
    /// The parts of `model`.
    pub fn of(model: &Model) -> Parts {
        Parts {
            blocks: model.blocks.iter().enumerate().filter(|(_, b)| !b.parts.is_empty()).map(|(i, b)| (i as u32, b.parts.clone())).collect(),
            contacts: model.contacts.iter().enumerate().filter(|(_, c)| c.parts != [0, 0]).map(|(i, c)| (i as u32, c.parts)).collect(),
        }
    }

    /// Puts the parts back into `model`; an index past its blocks, contacts or a block's parts,
    /// or a part whose lists do not match, is an error. A concave block left without parts (a
    /// file older than format 7) is cut into them now; where that fails it stays without, and
    /// CYCLE says why.
    pub fn apply(self, model: &mut Model) -> Result<(), String> {
        let n = model.blocks.len();
        for (i, parts) in self.blocks {
            let b = model.blocks.get_mut(i as usize).ok_or_else(|| format!("a block's parts name block index {i} of {n}"))?;
            for p in &parts {
                let m = p.shape.vertices.len();
                if p.vertices.len() != m
                    || p.shape.faces.iter().flatten().any(|&v| v as usize >= m)
                    || p.shape.edges.iter().any(|e| e.a as usize >= m || e.b as usize >= m)
                {
                    return Err(format!("block {}'s parts do not match their lists", b.id));
                }
                let faces = p.shape.faces.len();
                if p.shape.normals.len() != faces
                    || p.shape.planes.iter().any(|&f| f as usize >= faces)
                    || p.shape.edge_directions.iter().any(|&e| e as usize >= p.shape.edges.len())
                {
                    return Err(format!("block {}'s parts name a face or edge past their lists", b.id));
                }
                if !(p.offset.is_finite() && p.vertices.iter().all(|v| v.is_finite())) {
                    return Err(format!("block {} has a part with a non-finite position", b.id));
                }
            }
            b.parts = parts;
        }
        let m = model.contacts.len();
        for (i, parts) in self.contacts {
            let c = model.contacts.get_mut(i as usize).ok_or_else(|| format!("a contact's parts name contact index {i} of {m}"))?;
            for (k, &p) in parts.iter().enumerate() {
                let count = model.blocks.get(c.blocks[k] as usize).map_or(0, |b| b.part_count());
                if p as usize >= count {
                    return Err(format!("contact {} names part {p} of a block of {count}", c.id));
                }
            }
            c.parts = parts;
        }
        for b in model.blocks.iter_mut().filter(|b| !b.shape.convex && b.parts.is_empty()) {
            if let Ok(parts) = super::decompose::parts_of(&b.shape, b.volume) {
                b.parts = parts;
                b.place_parts();
            }
        }
        Ok(())
    }
}

/// What a D3 GPU backend holds beyond the model (`d3::gpu`), as the device holds it: a RESTART
/// on a GPU backend of the same precision uploads it as it was, so that the run goes on bit for
/// bit. The buffers are the kernels' structs (`d3::gpu::layout`) as bytes; the backend checks
/// them against the model before it takes them (each block's and contact's lists and indices as
/// the model's give them), and detects afresh from the model where they do not fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeviceState {
    /// The kernels' precision: f64 (else f32).
    pub f64_kernels: bool,
    /// The time step the kernels held when the run ended.
    pub dt: f64,
    /// The model's energy terms when the device's sums were last zero (its last upload): the
    /// external work, mass damping, contact dashpots, friction and energy released.
    pub bases: [f64; 5],
    /// Each contact's logical contacts as the last detection found them (the keys of the run of
    /// `logicals` each contact owns; dead ones kept in place).
    pub keys: Vec<Vec<LogicalKind>>,
    /// The buffers' bytes: `layout::Block`, `Vertex`, `Contact` and `Logical` in the kernels'
    /// precision.
    pub blocks: Vec<u8>,
    pub vertices: Vec<u8>,
    pub contacts: Vec<u8>,
    pub logicals: Vec<u8>,
    /// Read from a version-3 file and of f32 kernels: its vertices and points are in global axes,
    /// which the kernels no longer read (`FORMAT_VERSION`); a GPU backend does not take it. Not
    /// written: a file this program writes never holds such a state.
    #[serde(skip)]
    pub absolute_f32: bool,
}

/// Why a save file could not be written or read (each names the file).
#[derive(Debug, thiserror::Error)]
pub enum RestartError {
    #[error("cannot access save file {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{path} is not a D3 save file (it does not start with \"BLOCKD3\")")]
    NotASaveFile { path: PathBuf },
    #[error("{path} is a 2D (UDEC) save file: RESTART it from a 2D deck")]
    TwoDimensional { path: PathBuf },
    #[error("{path} is D3 save format version {found}; this program reads versions {OLDEST_VERSION} to {FORMAT_VERSION}")]
    UnsupportedVersion { path: PathBuf, found: u32 },
    #[error("save file {path} is corrupt: {reason}")]
    Corrupt { path: PathBuf, reason: String },
    #[error("the model saved in {path} is inconsistent: {reason}")]
    Inconsistent { path: PathBuf, reason: String },
}

/// The volume as built (`Block::built_volume`, the cracking floor's measure) of each block that
/// a crack made, by block index, written after the [`Parts`] in the payload (format 8); every
/// other block's is its own volume.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Lineage {
    pub built_volume: Vec<(u32, f64)>,
}

impl Lineage {
    /// The lineage of `model`.
    pub fn of(model: &Model) -> Lineage {
        Lineage { built_volume: model.blocks.iter().enumerate().filter(|(_, b)| b.built_volume != b.volume).map(|(i, b)| (i as u32, b.built_volume)).collect() }
    }

    /// Puts the lineage back into `model` (each block otherwise counted as built as it is); an
    /// index past its blocks or a volume that is not positive and finite is an error.
    pub fn apply(self, model: &mut Model) -> Result<(), String> {
        for b in &mut model.blocks {
            b.built_volume = b.volume;
        }
        let n = model.blocks.len();
        for (i, v) in self.built_volume {
            let b = model.blocks.get_mut(i as usize).ok_or_else(|| format!("a volume as built names block index {i} of {n}"))?;
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("block {} has a volume as built of {v}", b.id));
            }
            b.built_volume = v;
        }
        Ok(())
    }
}

/// The offsets of the logical contacts' normal springs (`Logical::offset`) that are not 0, as
/// (contact index, logical index, offset), written after the [`Lineage`] (format 9); in an older
/// file every one is 0.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Offsets {
    pub offsets: Vec<(u32, u32, f64)>,
}

impl Offsets {
    /// The offsets of `model`.
    pub fn of(model: &Model) -> Offsets {
        let mut offsets = Vec::new();
        for (k, c) in model.contacts.iter().enumerate() {
            for (j, l) in c.logical.iter().enumerate().filter(|(_, l)| l.offset != 0.0) {
                offsets.push((k as u32, j as u32, l.offset));
            }
        }
        Offsets { offsets }
    }

    /// Puts the offsets back into `model`; an index past its contacts or their logical contacts,
    /// or an offset that is not finite, is an error. An offset may be positive: a logical
    /// contact that took a swapped corner's forces (`contact::carry_swapped`) has its offset at
    /// gap + Fn/kn, above 0 where its gap is the larger (a file of a struck wall at 10¹² m from
    /// the origin was refused for an offset of 0.58 m; tests/suite/d3_random_decks.rs).
    pub fn apply(self, model: &mut Model) -> Result<(), String> {
        for (k, j, o) in self.offsets {
            let l = model
                .contacts
                .get_mut(k as usize)
                .and_then(|c| c.logical.get_mut(j as usize))
                .ok_or_else(|| format!("an offset names logical contact {j} of contact index {k}, which the model does not have"))?;
            if !o.is_finite() {
                return Err(format!("a logical contact's offset is {o}"));
            }
            l.offset = o;
        }
        Ok(())
    }
}

/// Whether the file at `path` starts as a D3 save file does (for `blockdem run`'s engine rule).
/// Only a regular file is looked into: reading the head of a FIFO would take bytes its writer
/// meant for the RESTART that follows (and could leave that one waiting for a writer gone).
pub fn is_save_file(path: &Path) -> bool {
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return false;
    }
    let mut head = [0u8; 8];
    std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut head)).is_ok() && head == MAGIC
}

/// SAVE: writes `file` to `path` atomically (a temporary file renamed into place).
pub fn save(path: &Path, file: &SaveFile) -> Result<(), RestartError> {
    let payload = postcard::to_stdvec(&(
        file,
        Extension::of(&file.model),
        Boundaries::of(&file.model),
        Parts::of(&file.model),
        Lineage::of(&file.model),
        Offsets::of(&file.model),
    ))
    .map_err(|e| RestartError::Io { path: path.to_path_buf(), source: io::Error::other(e) })?;
    let crc = crc32fast::hash(&payload) as u64;
    crate::output::write_atomically(path, |w| {
        w.write_all(&MAGIC)?;
        w.write_all(&FORMAT_VERSION.to_le_bytes())?;
        w.write_all(&(payload.len() as u64).to_le_bytes())?;
        w.write_all(&crc.to_le_bytes())?;
        w.write_all(&payload)
    })
    .map_err(|source| RestartError::Io { path: path.to_path_buf(), source })
}

/// RESTART: reads a file [`save`] wrote. The header is read first and the payload only as far
/// as it announces, so a path that is no save file is refused at its first bytes.
pub fn load(path: &Path) -> Result<SaveFile, RestartError> {
    let p = || path.to_path_buf();
    let io_err = |source| RestartError::Io { path: p(), source };
    let mut file = std::fs::File::open(path).map_err(io_err)?;
    let mut header = Vec::with_capacity(HEADER_LEN);
    (&mut file).take(HEADER_LEN as u64).read_to_end(&mut header).map_err(io_err)?;
    if header.len() >= 8 && header[..8] == UDEC_MAGIC {
        return Err(RestartError::TwoDimensional { path: p() });
    }
    if header.len() < 8 || header[..8] != MAGIC {
        return Err(RestartError::NotASaveFile { path: p() });
    }
    if header.len() < HEADER_LEN {
        return Err(RestartError::Corrupt { path: p(), reason: format!("the header is truncated ({} of {HEADER_LEN} bytes)", header.len()) });
    }
    let version = u32::from_le_bytes(header[8..12].try_into().expect("4 bytes"));
    if !(OLDEST_VERSION..=FORMAT_VERSION).contains(&version) {
        return Err(RestartError::UnsupportedVersion { path: p(), found: version });
    }
    let length = u64::from_le_bytes(header[12..20].try_into().expect("8 bytes"));
    let checksum = u64::from_le_bytes(header[20..28].try_into().expect("8 bytes"));
    let size = file.metadata().ok().filter(|m| m.is_file()).map(|m| m.len().saturating_sub(HEADER_LEN as u64));
    if let Some(holds) = size.filter(|&holds| holds != length) {
        return Err(RestartError::Corrupt {
            path: p(),
            reason: format!("the header announces {length} payload bytes but the file holds {holds} (truncated or appended to)"),
        });
    }
    let mut payload = Vec::new();
    (&mut file).take(length).read_to_end(&mut payload).map_err(io_err)?;
    if payload.len() as u64 != length {
        return Err(RestartError::Corrupt { path: p(), reason: format!("the header announces {length} payload bytes but the file holds {}", payload.len()) });
    }
    if crc32fast::hash(&payload) as u64 != checksum {
        return Err(RestartError::Corrupt { path: p(), reason: "the payload checksum does not match".into() });
    }
    let bad = |e: postcard::Error| RestartError::Corrupt { path: p(), reason: format!("bad payload: {e}") };
    let (mut saved, extension, boundaries, parts, lineage, offsets): (SaveFile, Extension, Boundaries, Parts, Lineage, Offsets) = match version {
        9.. => postcard::from_bytes(&payload).map_err(bad)?,
        8 => {
            let (saved, extension, boundaries, parts, lineage) = postcard::from_bytes(&payload).map_err(bad)?;
            (saved, extension, boundaries, parts, lineage, Offsets::default())
        }
        7 => {
            let (saved, extension, boundaries, parts) = postcard::from_bytes(&payload).map_err(bad)?;
            (saved, extension, boundaries, parts, Lineage::default(), Offsets::default())
        }
        6 => {
            let (saved, extension, boundaries) = postcard::from_bytes(&payload).map_err(bad)?;
            (saved, extension, boundaries, Parts::default(), Lineage::default(), Offsets::default())
        }
        5 => {
            let (saved, extension) = postcard::from_bytes(&payload).map_err(bad)?;
            (saved, extension, Boundaries::default(), Parts::default(), Lineage::default(), Offsets::default())
        }
        _ => (
            postcard::from_bytes(&payload).map_err(bad)?,
            Extension::default(),
            Boundaries::default(),
            Parts::default(),
            Lineage::default(),
            Offsets::default(),
        ),
    };
    extension.apply(&mut saved.model).map_err(|reason| RestartError::Inconsistent { path: p(), reason })?;
    boundaries.apply(&mut saved.model).map_err(|reason| RestartError::Inconsistent { path: p(), reason })?;
    parts.apply(&mut saved.model).map_err(|reason| RestartError::Inconsistent { path: p(), reason })?;
    lineage.apply(&mut saved.model).map_err(|reason| RestartError::Inconsistent { path: p(), reason })?;
    offsets.apply(&mut saved.model).map_err(|reason| RestartError::Inconsistent { path: p(), reason })?;
    if let Some(device) = saved.device.as_mut().filter(|d| version < 4 && !d.f64_kernels) {
        device.absolute_f32 = true;
    }
    check(&saved.model).map_err(|reason| RestartError::Inconsistent { path: p(), reason })?;
    // What the shapes do not save (`Shape::inradius`), from what they do (the indices checked).
    for b in &mut saved.model.blocks {
        std::sync::Arc::make_mut(&mut b.shape).inradius = b.shape.compute_inradius();
        for part in &mut b.parts {
            std::sync::Arc::make_mut(&mut part.shape).inradius = part.shape.compute_inradius();
        }
    }
    Ok(saved)
}

/// What a loaded model must hold for the program to trust its indices: each block's vertices
/// as many as its shape's, its faces' vertex numbers in range, finite positions, materials from
/// 1; each contact's blocks in range, the lower first.
pub fn check(model: &Model) -> Result<(), String> {
    for b in &model.blocks {
        let n = b.shape.vertices.len();
        if b.vertices.len() != n || b.shape.faces.len() != b.shape.normals.len() || b.shape.faces.len() != b.shape.neighbours.len() {
            return Err(format!("block {}'s vertex and face lists do not match its shape", b.id));
        }
        if b.shape.faces.iter().flatten().any(|&v| v as usize >= n) || b.shape.neighbours.iter().flatten().any(|&f| f as usize >= b.shape.faces.len()) {
            return Err(format!("block {} names a vertex or face past its lists", b.id));
        }
        if b.shape.edges.iter().any(|e| e.a as usize >= n || e.b as usize >= n) {
            return Err(format!("block {} has an edge past its vertices", b.id));
        }
        if !(b.centroid.is_finite() && b.velocity.is_finite() && b.angular_momentum.is_finite() && b.vertices.iter().all(|v| v.is_finite())) {
            return Err(format!("block {} has a non-finite position or velocity", b.id));
        }
        if b.material == 0 {
            return Err(format!("block {} has material 0", b.id));
        }
    }
    for c in &model.contacts {
        let [a, b] = c.blocks;
        if a >= b || b as usize >= model.blocks.len() {
            return Err(format!("contact {} names blocks {a} and {b} of {}", c.id, model.blocks.len()));
        }
    }
    Ok(())
}
