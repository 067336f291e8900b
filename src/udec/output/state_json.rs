//! The state JSON (`--state-json FILE`, DESIGN.md §5): the observable state of a run with fixed
//! key names, for scripts and for comparing backends.
//!
//! Keys are part of the interface: tools may rely on every key written here; new keys may be
//! added, none renamed or removed. Blocks and contacts are named by their stable ids. Non-finite
//! numbers (a diverged run) are written as `null`, so the file is always valid JSON.

use std::io::{self, Write};
use std::path::Path;

use rayon::prelude::*;
use serde::ser::{Serialize, Serializer};
use serde_json::Value;

use super::provenance::Provenance;
use crate::udec::model::constitutive::ContactLaw;
use crate::udec::model::domain::{DomainKind, DomainLink, Domains};
use crate::udec::model::timestep::Energies;
use crate::udec::model::{Block, Contact, Model};

// The state file is serialized from views of the model as it is written, never built as a
// `serde_json::Value` tree first: that tree cost ~50 times the file's size in memory (5.5 GB for
// a 10⁵-block wall; a 10⁶-block one did not fit). The fields of each view are in alphabetical
// order, the order the JSON has always had (serde_json's maps are sorted).

/// A finite number, or `null`: JSON has no NaN or infinity.
struct Num(f64);

impl Serialize for Num {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0.is_finite() {
            s.serialize_f64(self.0)
        } else {
            s.serialize_none()
        }
    }
}

fn pair(p: [f64; 2]) -> [Num; 2] {
    p.map(Num)
}

#[derive(serde::Serialize)]
struct BlockJson {
    angular_velocity: Num,
    area: Num,
    centroid: [Num; 2],
    constitutive: u32,
    corners: Vec<[Num; 2]>,
    fixed: bool,
    force: [Num; 2],
    /// A zoned fully-deformable block's grid points (ids from 1, grid point k on corner k for
    /// the boundary ones) and zones (their grid points' ids, counter-clockwise; stress s11, s12,
    /// s22 in Pa, tension positive); absent for another block.
    #[serde(skip_serializing_if = "Option::is_none")]
    gridpoints: Option<Vec<GridPointJson>>,
    id: u32,
    inertia: Num,
    kind: &'static str,
    load: [Num; 2],
    mass: Num,
    material: u32,
    moment: Num,
    rotation: Num,
    /// A simply-deformable block's internal stress (s11, s12, s22; Pa, tension positive), its
    /// strain (e11, e12, e22) and strain rate; absent for a rigid block.
    #[serde(skip_serializing_if = "Option::is_none")]
    stress: Option<[Num; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    strain: Option<[Num; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    strain_rate: Option<[Num; 3]>,
    velocity: [Num; 2],
    #[serde(skip_serializing_if = "Option::is_none")]
    zones: Option<Vec<ZoneJson>>,
}

#[derive(serde::Serialize)]
struct GridPointJson {
    id: u32,
    mass: Num,
    position: [Num; 2],
    velocity: [Num; 2],
}

#[derive(serde::Serialize)]
struct ZoneJson {
    gridpoints: [u32; 3],
    id: u32,
    mass: Num,
    stress: [Num; 3],
}

fn block_json(model: &Model, b: usize, blk: &Block) -> BlockJson {
    BlockJson {
        angular_velocity: Num(blk.angular_velocity),
        area: Num(blk.area),
        centroid: pair(blk.centroid),
        constitutive: blk.constitutive,
        corners: corner_positions(model, b).into_iter().map(pair).collect(),
        fixed: blk.fixed,
        force: pair(blk.force),
        gridpoints: model.fdef_of(b).map(|f| {
            f.gridpoints
                .iter()
                .enumerate()
                .map(|(k, g)| GridPointJson { id: k as u32 + 1, mass: Num(g.mass), position: pair(g.position), velocity: pair(g.velocity) })
                .collect()
        }),
        id: blk.id,
        inertia: Num(blk.inertia),
        kind: blk.kind.name(),
        load: pair(blk.load),
        mass: Num(blk.mass),
        material: blk.material,
        moment: Num(blk.moment),
        rotation: Num(blk.rotation),
        stress: model.sdef_of(b).map(|s| s.stress.map(Num)),
        strain: model.sdef_of(b).map(|s| s.strain.map(Num)),
        strain_rate: model.sdef_of(b).map(|s| s.strain_rate.map(Num)),
        velocity: pair(blk.velocity),
        zones: model.fdef_of(b).map(|f| {
            f.zones
                .iter()
                .enumerate()
                .map(|(k, z)| ZoneJson { gridpoints: z.gridpoints.map(|g| g + 1), id: k as u32 + 1, mass: Num(z.mass), stress: z.stress.map(Num) })
                .collect()
        }),
    }
}

#[derive(serde::Serialize)]
struct ContactJson {
    blocks: [Option<u32>; 2],
    bonded: bool,
    constitutive: u32,
    corner: u32,
    feature: u32,
    id: u32,
    kind: &'static str,
    /// "point" or "joint" (Appendix A ¶5).
    law: &'static str,
    /// For a joint, the length of joint this contact carries (half the common length of the
    /// faces in opposition, `Contact::joint_length`); absent for a point contact.
    #[serde(skip_serializing_if = "Option::is_none")]
    length: Option<Num>,
    material: u32,
    normal: [Num; 2],
    normal_displacement: Num,
    normal_force: Num,
    point: [Num; 2],
    shear_displacement: Num,
    shear_force: Num,
}

fn contact_json(model: &Model, c: &Contact) -> ContactJson {
    // A contact naming a block index that does not exist (a corrupt model) gets `null` there.
    let id = |i: u32| model.blocks.get(i as usize).map(|b| b.id);
    ContactJson {
        blocks: [id(c.block1), id(c.block2)],
        bonded: c.bonded,
        constitutive: c.constitutive,
        corner: c.corner,
        feature: c.feature,
        id: c.id,
        kind: c.kind.name(),
        law: match c.law() {
            ContactLaw::Point => "point",
            ContactLaw::Joint => "joint",
        },
        length: (c.law() == ContactLaw::Joint).then_some(Num(c.joint_length)),
        material: c.material,
        normal: pair(c.normal),
        normal_displacement: Num(c.gap),
        normal_force: Num(c.normal_force),
        point: pair(c.point),
        shear_displacement: Num(c.shear_displacement),
        shear_force: Num(c.shear_force),
    }
}

#[derive(serde::Serialize)]
struct EnergyJson {
    contact_damping: Num,
    external_work: Num,
    /// The fluid's work on the blocks, in a scene with fluid.
    #[serde(skip_serializing_if = "Option::is_none")]
    fluid_work: Option<Num>,
    friction: Num,
    kinetic: Num,
    ledger: Num,
    mass_damping: Num,
    released: Num,
    strain: Num,
}

fn energy_view(e: &Energies) -> EnergyJson {
    EnergyJson {
        contact_damping: Num(e.contact_damping),
        external_work: Num(e.external_work),
        friction: Num(e.friction),
        kinetic: Num(e.kinetic),
        ledger: Num(e.ledger()),
        mass_damping: Num(e.mass_damping),
        released: Num(e.released),
        strain: Num(e.strain),
        fluid_work: (e.fluid_work != 0.0).then_some(Num(e.fluid_work)),
    }
}

/// The energy terms as JSON, for the state file's `energy` key.
pub fn energy_json(e: &Energies) -> Value {
    serde_json::to_value(energy_view(e)).expect("numbers and strings always convert")
}

/// The whole state as one view, for [`state_json`]'s value (a test's or a check's model; the
/// file is written list by list, [`write_state_json`]).
#[derive(serde::Serialize)]
struct StateJson {
    blocks: Vec<BlockJson>,
    contacts: Vec<ContactJson>,
    #[serde(flatten)]
    scalars: Scalars,
}

/// One domain (`model::domain`): the keys issue 30 fixes (`id`, `pressure`, `area`, `fixed`,
/// `outer`) and its kind, its joint length and the contacts around it in circuit order.
#[derive(serde::Serialize)]
struct DomainJson {
    /// The area the fluid calculation uses (0 for the outer domain).
    area: Num,
    /// Ids of the contacts the domain's circuit crosses, in order.
    contacts: Vec<u32>,
    fixed: bool,
    id: u32,
    /// "regular", "joint" or "outer".
    kind: &'static str,
    /// A joint domain's length; absent for the others.
    #[serde(skip_serializing_if = "Option::is_none")]
    length: Option<Num>,
    outer: bool,
    pressure: Num,
}

fn domains_json(domains: &Domains) -> Vec<DomainJson> {
    domains
        .list
        .iter()
        .map(|d| DomainJson {
            area: Num(d.area),
            contacts: domains.links_of(d).iter().filter_map(|l| if let DomainLink::Contact { id, .. } = *l { Some(id) } else { None }).collect(),
            fixed: d.fixed,
            id: d.id,
            kind: d.kind.name(),
            length: (d.kind == DomainKind::Joint).then_some(Num(d.length)),
            outer: d.kind == DomainKind::Outer,
            pressure: Num(d.pressure),
        })
        .collect()
}

/// One contact's flow in the last cycle (issue 30: `contact`, `domains`, `flow`, `length`,
/// `aperture`): flow positive from `domains[0]` to `domains[1]`, in volume per unit time per
/// unit thickness; length (the contact's share of joint, l_c) and aperture 0 for a point contact.
#[derive(serde::Serialize)]
struct FlowJson {
    aperture: Num,
    contact: u32,
    domains: [u32; 2],
    flow: Num,
    length: Num,
}

fn flows_json(model: &Model, domains: &Domains) -> Vec<FlowJson> {
    model
        .contacts
        .iter()
        .zip(domains.sides.iter().zip(&domains.flows))
        .filter(|(_, (s, _))| s[0] != crate::udec::model::domain::NO_DOMAIN)
        .map(|(c, (s, f))| FlowJson {
            aperture: Num(f.aperture),
            contact: c.id,
            domains: [domains.list[s[0] as usize].id, domains.list[s[1] as usize].id],
            flow: Num(f.flow),
            length: Num(f.length),
        })
        .collect()
}

/// The fluid (FLUID) and its mass balance, in a scene with fluid.
#[derive(serde::Serialize)]
struct FluidJson {
    /// Stored − (stored at FLUID + inflow + adjusted): the mass balance's error, in volume.
    balance_error: Num,
    bulk: Num,
    density: Num,
    /// Volume that flowed into the free domains from fixed-pressure and outer domains.
    inflow: Num,
    /// The fluid volume the free domains hold now, Σ A_d(1 + p_d/bulkw).
    stored: Num,
    /// The fluid's work on the blocks.
    work: Num,
}

fn fluid_json(model: &Model) -> Option<FluidJson> {
    let (f, d) = (model.fluid?, model.domains.as_ref()?);
    let stored = crate::udec::model::fluid::stored_volume(d, f.bulk);
    Some(FluidJson {
        balance_error: Num(f.balance_error(stored)),
        bulk: Num(f.bulk),
        density: Num(f.density),
        inflow: Num(f.inflow),
        stored: Num(stored),
        work: Num(f.work),
    })
}

/// The members after the two lists (alphabetical, as the lists are).
#[derive(serde::Serialize)]
struct Scalars {
    cycle: u64,
    dim: u32,
    /// The domains, when the scene has them (`Model::domains`).
    #[serde(skip_serializing_if = "Option::is_none")]
    domains: Option<Vec<DomainJson>>,
    energy: EnergyJson,
    /// Each contact's flow, in a scene with fluid.
    #[serde(skip_serializing_if = "Option::is_none")]
    flows: Option<Vec<FlowJson>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    fluid: Option<FluidJson>,
    gravity: [Num; 2],
    /// What made the run (`blockdem run` writes it; a state taken in a test has none).
    #[serde(skip_serializing_if = "Option::is_none")]
    provenance: Option<Provenance>,
    time: Num,
    timestep: Num,
}

fn scalars(model: &Model, provenance: Option<&Provenance>) -> Scalars {
    Scalars {
        cycle: model.cycle,
        dim: 2,
        domains: model.domains.as_ref().map(domains_json),
        energy: energy_view(&model.energies()),
        flows: model.domains.as_ref().filter(|_| model.fluid.is_some()).map(|d| flows_json(model, d)),
        fluid: fluid_json(model),
        gravity: pair(model.gravity),
        provenance: provenance.cloned(),
        time: Num(model.time),
        timestep: Num(model.timestep),
    }
}

/// The state as a JSON value: `dim` (2), `cycle`, `time`, `timestep`, `gravity`, `energy`
/// ([`energy_json`]), `blocks`, `contacts` and, in a scene with domains, `domains` (see the
/// module documentation for the rules on keys).
/// For a large model write it with [`write_state_json`], which streams it.
pub fn state_json(model: &Model) -> Value {
    let state = StateJson {
        blocks: model.blocks.iter().enumerate().map(|(b, blk)| block_json(model, b, blk)).collect(),
        contacts: model.contacts.iter().map(|c| contact_json(model, c)).collect(),
        scalars: scalars(model, None),
    };
    serde_json::to_value(state).expect("numbers and strings always convert")
}

/// Writes [`state_json`] to `path`, pretty-printed, replacing the file atomically. The two lists
/// are formatted in parallel pieces and written in order, the rest as serde_json prints it: the
/// text is serde_json's pretty print of the value, byte for byte (4.7 GB for a 10⁶-block wall).
pub fn write_state_json(model: &Model, path: &Path) -> io::Result<()> {
    write_state_json_with(model, None, path)
}

/// [`write_state_json`] with a `provenance` object ([`Provenance`]: version, commit, deck,
/// backend, adapter, precision, date), as `blockdem run --state-json` writes it.
pub fn write_state_json_with(model: &Model, provenance: Option<&Provenance>, path: &Path) -> io::Result<()> {
    super::write_atomically(path, |w| {
        w.write_all(b"{\n  \"blocks\": ")?;
        write_list(w, model.blocks.len(), |b| block_json(model, b, &model.blocks[b]))?;
        w.write_all(b",\n  \"contacts\": ")?;
        write_list(w, model.contacts.len(), |k| contact_json(model, &model.contacts[k]))?;
        // The other members as serde_json prints them at the top level, less its opening brace.
        let rest = serde_json::to_vec_pretty(&scalars(model, provenance))?;
        w.write_all(b",\n")?;
        w.write_all(&rest[2..])?;
        writeln!(w)
    })
}

/// Items one worker formats at a time.
const PIECE: usize = 2048;
/// Pieces formatted before they are written (bounds the text in memory to ~100 MB).
const WAVE: usize = 64;

/// Writes the JSON array of `count` elements (`element(i)`), a member of the top-level object,
/// as serde_json's pretty printer would: `[]` when empty; otherwise each element on lines of its
/// own, four spaces in.
fn write_list<V: Serialize>(w: &mut impl Write, count: usize, element: impl Fn(usize) -> V + Sync) -> io::Result<()> {
    if count == 0 {
        return w.write_all(b"[]");
    }
    w.write_all(b"[")?;
    let pieces: Vec<std::ops::Range<usize>> = (0..count).step_by(PIECE).map(|s| s..(s + PIECE).min(count)).collect();
    for wave in pieces.chunks(WAVE) {
        let texts: Vec<io::Result<Vec<u8>>> = wave
            .par_iter()
            .map(|range| {
                let (mut text, mut one) = (Vec::new(), Vec::new());
                for i in range.clone() {
                    one.clear();
                    serde_json::to_writer_pretty(&mut one, &element(i))?;
                    text.extend_from_slice(if i == 0 { b"\n    " } else { b",\n    " });
                    for line in one.split_inclusive(|&c| c == b'\n') {
                        text.extend_from_slice(line);
                        if line.ends_with(b"\n") {
                            text.extend_from_slice(b"    ");
                        }
                    }
                }
                Ok(text)
            })
            .collect();
        for text in texts {
            w.write_all(&text?)?;
        }
    }
    w.write_all(b"\n  ]")
}

/// World positions of block `b`'s corners, or none when its corner range lies outside
/// `Model::corners` (a corrupt model is still written rather than panicking).
fn corner_positions(model: &Model, b: usize) -> Vec<[f64; 2]> {
    let blk = &model.blocks[b];
    let start = blk.corner_start as usize;
    let end = start.saturating_add(blk.corner_count as usize);
    model.corners.get(start..end).unwrap_or(&[]).iter().map(|c| c.position).collect()
}
