//! The state JSON (`--state-json FILE`, DESIGN.md §5): the observable state of a run with fixed
//! key names, for scripts and for comparing backends.
//!
//! Keys are part of the interface: tools may rely on every key written here; new keys may be
//! added, none renamed or removed. Blocks and contacts are named by their stable ids. Non-finite
//! numbers (a diverged run) are written as `null`, so the file is always valid JSON.

use std::io::{self, Write};
use std::path::Path;

use serde_json::{json, Value};

use crate::model::timestep::Energies;
use crate::model::{Block, Contact, Model};

/// A finite number, or `null`: JSON has no NaN or infinity.
fn num(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn pair(p: [f64; 2]) -> Value {
    Value::Array(vec![num(p[0]), num(p[1])])
}

fn block_json(model: &Model, b: usize, blk: &Block) -> Value {
    let corners: Vec<Value> = corner_positions(model, b).into_iter().map(pair).collect();
    json!({
        "id": blk.id,
        "kind": blk.kind.name(),
        "material": blk.material,
        "constitutive": blk.constitutive,
        "fixed": blk.fixed,
        "area": num(blk.area),
        "mass": num(blk.mass),
        "inertia": num(blk.inertia),
        "centroid": pair(blk.centroid),
        "rotation": num(blk.rotation),
        "velocity": pair(blk.velocity),
        "angular_velocity": num(blk.angular_velocity),
        "force": pair(blk.force),
        "moment": num(blk.moment),
        "load": pair(blk.load),
        "corners": corners,
    })
}

fn contact_json(model: &Model, c: &Contact) -> Value {
    // A contact naming a block index that does not exist (a corrupt model) gets `null` there.
    let id = |i: u32| {
        model
            .blocks
            .get(i as usize)
            .map_or(Value::Null, |b| json!(b.id))
    };
    json!({
        "id": c.id,
        "blocks": [id(c.block1), id(c.block2)],
        "kind": c.kind.name(),
        "material": c.material,
        "constitutive": c.constitutive,
        "corner": c.corner,
        "feature": c.feature,
        "bonded": c.bonded,
        "point": pair(c.point),
        "normal": pair(c.normal),
        "normal_force": num(c.normal_force),
        "shear_force": num(c.shear_force),
        "normal_displacement": num(c.gap),
        "shear_displacement": num(c.shear_displacement),
    })
}

/// The energy terms as JSON, for the state file's `energy` key.
pub fn energy_json(e: &Energies) -> Value {
    json!({
        "kinetic": num(e.kinetic),
        "strain": num(e.strain),
        "external_work": num(e.external_work),
        "mass_damping": num(e.mass_damping),
        "contact_damping": num(e.contact_damping),
        "friction": num(e.friction),
        "released": num(e.released),
        "ledger": num(e.ledger()),
    })
}

/// The state as a JSON value: `dim` (2), `cycle`, `time`, `timestep`, `gravity`, `energy`
/// ([`energy_json`]), `blocks` and `contacts` (see the module documentation for the rules on keys).
pub fn state_json(model: &Model) -> Value {
    let blocks: Vec<Value> = model
        .blocks
        .iter()
        .enumerate()
        .map(|(b, blk)| block_json(model, b, blk))
        .collect();
    let contacts: Vec<Value> = model
        .contacts
        .iter()
        .map(|c| contact_json(model, c))
        .collect();
    json!({
        "dim": 2,
        "cycle": model.cycle,
        "time": num(model.time),
        "timestep": num(model.timestep),
        "gravity": pair(model.gravity),
        "energy": energy_json(&model.energies()),
        "blocks": blocks,
        "contacts": contacts,
    })
}

/// Writes [`state_json`] to `path`, pretty-printed, replacing the file atomically.
pub fn write_state_json(model: &Model, path: &Path) -> io::Result<()> {
    let value = state_json(model);
    super::write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, &value)?;
        writeln!(w)
    })
}

/// World positions of block `b`'s corners, or none when its corner range lies outside
/// `Model::corners` (a corrupt model is still written rather than panicking).
fn corner_positions(model: &Model, b: usize) -> Vec<[f64; 2]> {
    let blk = &model.blocks[b];
    let start = blk.corner_start as usize;
    let end = start.saturating_add(blk.corner_count as usize);
    model
        .corners
        .get(start..end)
        .unwrap_or(&[])
        .iter()
        .map(|c| c.position)
        .collect()
}
