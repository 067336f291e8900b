//! D3's outputs: the PRINT tables in the layouts of the 1985 listings
//! (`../shared/spec/print-formats.md`, "D3 PRINT tables") and the state JSON (`"dim": 3`).

use std::fmt::Write as _;

use serde_json::{json, Value};

use super::model::{principal_moments, Model};
use super::sdef;
use crate::output::format::fmt_e;

/// A row of numbers in the listings' columns.
fn row(out: &mut String, head: &str, values: &[f64]) {
    out.push_str(head);
    for v in values {
        let _ = write!(out, " {:>10}", fmt_e(*v));
    }
    out.push('\n');
}

/// PRINT BLOCKS: block, material, constitutive number, centroid, volume, mass, the principal
/// moments of inertia, and the force sums (the kind HELD for a block held by BOUNDARY VELOCITY);
/// a row BS for each face loaded by BOUNDARY STRESS; under a simply-deformable block its strain rate (ED),
/// internal stress (SI) and applied stress times volume (SA), as 2D's SDEF rows.
pub fn blocks_table(model: &Model) -> String {
    let mut out = String::from("\nBLOCK DATA\n");
    out.push_str("  BLOCK  MAT CONST   CENTROID X   CENTROID Y   CENTROID Z     VOLUME       MASS        I1         I2         I3     \n");
    for b in &model.blocks {
        let i = principal_moments(b.inertia_ref);
        let head = format!("{:>7} {:>4} {:>5}", b.id, b.material, b.constitutive);
        row(&mut out, &head, &[b.centroid.x, b.centroid.y, b.centroid.z, b.volume, b.mass, i[0], i[1], i[2]]);
        let kind = match (b.fixed, b.is_sdef(), b.held) {
            (true, false, _) => "FIXED",
            (false, false, false) => "RIGID",
            (false, false, true) => "HELD",
            (true, true, _) => "SDEF, FIXED",
            (false, true, false) => "SDEF",
            (false, true, true) => "SDEF, HELD",
        };
        let _ = writeln!(
            out,
            "  ({kind}) FORCE {} {} {}  MOMENT {} {} {}",
            fmt_e(b.force.x),
            fmt_e(b.force.y),
            fmt_e(b.force.z),
            fmt_e(b.moment.x),
            fmt_e(b.moment.y),
            fmt_e(b.moment.z)
        );
        // Its faces loaded by BOUNDARY STRESS: the face (from 1) and σ (11 22 33 12 13 23).
        for l in &b.boundary_stress {
            row(&mut out, &format!("  BS FACE {:>4}", l.face + 1), &l.stress);
        }
        if let Some(s) = &b.sdef {
            // As 2D's SDEF rows (ED, SI, SA: strain rate, internal stress, applied stress times
            // size), each tensor's nine components row by row: 11 12 13 21 22 23 31 32 33.
            for (name, t) in [("ED", sdef::tensor(s.strain_rate)), ("SI", sdef::tensor(s.stress)), ("SA", s.applied)] {
                let r = [t.row(0), t.row(1), t.row(2)];
                row(&mut out, &format!("  {name}"), &r.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>());
            }
        }
    }
    out
}

/// PRINT FACES: each face's three vertices (the block's vertex numbers, from 1, counter-clockwise
/// looking along the outward normal as typed), its three neighbouring faces (KFP1–KFP3) and its
/// outward normal.
pub fn faces_table(model: &Model) -> String {
    let mut out = String::from("\nFACE DATA\n");
    for b in &model.blocks {
        let _ = writeln!(out, "BLOCK {}", b.id);
        out.push_str("   FACE   V1   V2   V3   F1   F2   F3      N(1)       N(2)       N(3)\n");
        for (k, f) in b.shape.faces.iter().enumerate() {
            // Stored counter-clockwise from outside; printed as typed.
            let v = [f[0] + 1, f[2] + 1, f[1] + 1];
            let nb = b.shape.neighbours[k];
            let n = b.face_normal(k);
            let head = format!("{:>7} {:>4} {:>4} {:>4} {:>4} {:>4} {:>4}", k + 1, v[0], v[1], v[2], nb[2] + 1, nb[1] + 1, nb[0] + 1);
            row(&mut out, &head, &[n.x, n.y, n.z]);
        }
    }
    out
}

/// PRINT VELOCITIES: BLOCK, CODE (0 free, 1 fixed), UXDOT UYDOT UZDOT, TXDOT TYDOT TZDOT.
pub fn velocities_table(model: &Model) -> String {
    let mut out = String::from("\nBLOCK VELOCITIES\n");
    out.push_str("  BLOCK  CODE      UXDOT      UYDOT      UZDOT      TXDOT      TYDOT      TZDOT\n");
    for b in &model.blocks {
        let head = format!("{:>7} {:>5}", b.id, u8::from(b.fixed));
        let (v, w) = (b.velocity, b.angular_velocity);
        row(&mut out, &head, &[v.x, v.y, v.z, w.x, w.y, w.z]);
    }
    out
}

/// PRINT VERTICES: each block's vertices, numbered from 1, in global coordinates.
pub fn vertices_table(model: &Model) -> String {
    let mut out = String::from("\nVERTEX COORDINATES\n");
    for b in &model.blocks {
        let _ = writeln!(out, "BLOCK {}", b.id);
        out.push_str("  VERTEX        X          Y          Z\n");
        for (k, v) in b.vertices.iter().enumerate() {
            row(&mut out, &format!("{:>8}", k + 1), &[v.x, v.y, v.z]);
        }
    }
    out
}

/// PRINT ENERGY (an extension, as 2D's): the ledger's terms since START, and its balance
/// (`Energies::ledger`: kinetic + strain + dissipated + released − work, which stays at the
/// starting energy up to the O(Δt) errors of central differences).
pub fn energy_table(model: &Model) -> String {
    let e = model.energies();
    let mut out = String::from("\nENERGY\n");
    let strain = if model.blocks.iter().any(|b| b.sdef.is_some()) { "STRAIN (CONTACTS AND SDEF BLOCKS)" } else { "STRAIN (CONTACTS)" };
    let _ = writeln!(
        out,
        "  KINETIC {}   {strain} {}   WORK OF GRAVITY, LOADS, VELOCITY AND BOUNDARY {}",
        fmt_e(e.kinetic),
        fmt_e(e.strain),
        fmt_e(e.external_work)
    );
    let _ = writeln!(
        out,
        "  DISSIPATED: MASS DAMPING {}   CONTACT DASHPOTS {}   FRICTION {}   RELEASED (CONTACTS GONE WHILE LOADED, CRACKS) {}",
        fmt_e(e.mass_damping),
        fmt_e(e.contact_damping),
        fmt_e(e.friction),
        fmt_e(e.released)
    );
    let _ = writeln!(out, "  BALANCE: KINETIC + STRAIN + DISSIPATED + RELEASED - WORK = {}", fmt_e(e.ledger()));
    out
}

/// PRINT CONTACTS: CONTACT, TYPE, BLOCK-1, BLOCK-2, X(1) X(2) X(3), FS(1) FS(2) FS(3), FM. A
/// contact of several logical contacts (face–face, …) prints its sums on its line, then each
/// logical contact (VERTEX-FACE, FACE-VERTEX or EDGE-EDGE) on a line of its own.
pub fn contacts_table(model: &Model) -> String {
    let mut out = String::from("\nCONTACT DATA\n");
    out.push_str("  CONTACT  TYPE               BLOCK-1  BLOCK-2      X(1)       X(2)       X(3)      FS(1)      FS(2)      FS(3)        FM\n");
    for c in &model.contacts {
        let [a, b] = c.blocks.map(|i| model.blocks[i as usize].id);
        let head = format!("{:>9}  {:<18} {:>7}  {:>7}", c.id, format!("({})", c.type_name()), a, b);
        let p = c.point();
        let fs = c.shear_force();
        row(&mut out, &head, &[p.x, p.y, p.z, fs.x, fs.y, fs.z, c.normal_force()]);
        if c.logical.len() > 1 {
            for l in &c.logical {
                let kind = match l.kind {
                    super::model::LogicalKind::VertexFace { on_first: true, .. } => "VERTEX-FACE",
                    super::model::LogicalKind::VertexFace { on_first: false, .. } => "FACE-VERTEX",
                    super::model::LogicalKind::EdgeEdge { .. } => "EDGE-EDGE",
                };
                let head = format!("{:>9}  {:<18} {:>7}  {:>7}", "", format!("  {kind}"), "", "");
                row(&mut out, &head, &[l.point.x, l.point.y, l.point.z, l.shear_force.x, l.shear_force.y, l.shear_force.z, l.normal_force]);
            }
        }
    }
    out
}

/// DUMP: Appendix B's dump printed a range of the main array and the pointers MFREE, JUNK, IBPNT
/// and ICPNT; addresses mean nothing here, so the dump is the whole model as JSON (the fields of
/// `d3::model`, non-finite numbers as null) under a heading, and the pointers become the counts
/// they pointed into.
pub fn dump(model: &Model, out: &mut dyn std::io::Write) -> std::io::Result<()> {
    let logical: usize = model.contacts.iter().map(|c| c.logical.len()).sum();
    writeln!(out)?;
    writeln!(out, "FULL STATE DUMP (CYCLE {}, TIME {})", model.cycle, fmt_e(model.time))?;
    writeln!(
        out,
        "BLOCKS (IBPNT) {}  CONTACTS (ICPNT) {}  LOGICAL CONTACTS {}  MATERIALS {}  NEXT CONTACT ID {}",
        model.blocks.len(),
        model.contacts.len(),
        logical,
        model.materials.len(),
        model.next_contact_id
    )?;
    writeln!(out)?;
    serde_json::to_writer_pretty(&mut *out, model)?;
    writeln!(out)?;
    // What the model's own fields leave to the save file's extension arrays (restart.rs):
    // the simply-deformable blocks' strain and the boundary conditions, where there are any.
    let (extension, boundaries) = (super::restart::Extension::of(model), super::restart::Boundaries::of(model));
    if !extension.sdef.is_empty() || extension.alpha_internal != 0.0 || !boundaries.held.is_empty() || !boundaries.stress.is_empty() {
        writeln!(out, "EXTENSION (SIMPLY-DEFORMABLE BLOCKS BY INDEX, DAMPING INTERNAL; BOUNDARY: HELD BLOCKS, LOADED FACES)")?;
        serde_json::to_writer_pretty(&mut *out, &json!({"extension": extension, "boundaries": boundaries}))?;
        writeln!(out)?;
    }
    // The concave blocks' convex parts and the parts each contact is between (format 7).
    let parts = super::restart::Parts::of(model);
    if !parts.blocks.is_empty() {
        writeln!(out, "CONCAVE BLOCKS' CONVEX PARTS (BY BLOCK INDEX; CONTACTS' PARTS BY CONTACT INDEX)")?;
        serde_json::to_writer_pretty(&mut *out, &parts)?;
        writeln!(out)?;
    }
    Ok(())
}

/// A finite number, or null.
fn num(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn vec3(v: glam::DVec3) -> Value {
    json!([num(v.x), num(v.y), num(v.z)])
}

/// The state JSON of a D3 model: `"dim": 3`, the clock, the blocks (centroid, velocity,
/// angular_velocity, mass, volume, inertia 3 × 3 in global axes, vertices, faces as vertex
/// numbers from 0 counter-clockwise seen from outside, fixed, kind `rigid` or `sdef`, and a
/// simply-deformable block's `stress` and `strain`; a held block's `boundary_velocity` and a
/// loaded block's `boundary_stress`, its faces (from 0) and their σ) and the real contacts (kind,
/// blocks, point, normal, normal_force, shear_force as a vector, area, and their logical
/// contacts).
pub fn state_json(model: &Model, provenance: Option<&crate::output::provenance::Provenance>) -> Value {
    let blocks: Vec<Value> = model
        .blocks
        .iter()
        .map(|b| {
            let i = b.inertia();
            let mut v = json!({
                "id": b.id,
                "material": b.material,
                "constitutive": b.constitutive,
                "centroid": vec3(b.centroid),
                "velocity": vec3(b.velocity),
                "angular_velocity": vec3(b.angular_velocity),
                "mass": num(b.mass),
                "volume": num(b.volume),
                "inertia": [vec3(i.row(0)), vec3(i.row(1)), vec3(i.row(2))],
                "orientation": [num(b.orientation.w), num(b.orientation.x), num(b.orientation.y), num(b.orientation.z)],
                "vertices": b.vertices.iter().map(|v| vec3(*v)).collect::<Vec<_>>(),
                "faces": b.shape.faces,
                "fixed": b.fixed,
                "force": vec3(b.force),
                "moment": vec3(b.moment),
                "load": vec3(b.load),
            });
            // The block's kind, and a simply-deformable block's strain and internal stress (Pa,
            // tension positive) in Voigt's order (11, 22, 33, 12, 13, 23).
            v["kind"] = json!(if b.is_sdef() { "sdef" } else { "rigid" });
            if let Some(s) = &b.sdef {
                v["stress"] = json!(s.stress.map(num));
                v["strain"] = json!(s.strain.map(num));
                v["strain_rate"] = json!(s.strain_rate.map(num));
            }
            // The boundary conditions (BOUNDARY, ¶35e), where the block has them.
            if b.held {
                v["boundary_velocity"] = json!({"velocity": vec3(b.velocity), "angular_velocity": vec3(b.angular_velocity)});
            }
            if !b.boundary_stress.is_empty() {
                v["boundary_stress"] = b.boundary_stress.iter().map(|l| json!({"face": l.face, "stress": l.stress.map(num)})).collect::<Vec<_>>().into();
            }
            v
        })
        .collect();
    let contacts: Vec<Value> = model
        .contacts
        .iter()
        .filter(|c| c.category.is_some())
        .map(|c| {
            let logical: Vec<Value> = c
                .logical
                .iter()
                .map(|l| {
                    let kind = match l.kind {
                        super::model::LogicalKind::VertexFace { on_first: true, .. } => "vertex-face",
                        super::model::LogicalKind::VertexFace { on_first: false, .. } => "face-vertex",
                        super::model::LogicalKind::EdgeEdge { .. } => "edge-edge",
                    };
                    json!({"kind": kind, "point": vec3(l.point), "gap": num(l.gap), "normal_force": num(l.normal_force), "shear_force": vec3(l.shear_force)})
                })
                .collect();
            json!({
                "id": c.id,
                "kind": c.type_name().to_ascii_lowercase(),
                "blocks": c.blocks.map(|i| model.blocks[i as usize].id),
                "point": vec3(c.point()),
                "normal": vec3(c.normal),
                "normal_force": num(c.normal_force()),
                "shear_force": vec3(c.shear_force()),
                "area": num(c.area),
                "logical": logical,
            })
        })
        .collect();
    let e = model.energies();
    let mut v = json!({
        "dim": 3,
        "cycle": model.cycle,
        "time": num(model.time),
        "timestep": num(model.timestep()),
        "gravity": vec3(model.gravity),
        "blocks": blocks,
        "contacts": contacts,
        "energy": {"kinetic": num(e.kinetic), "strain": num(e.strain), "external_work": num(e.external_work),
                   "mass_damping": num(e.mass_damping), "contact_damping": num(e.contact_damping), "friction": num(e.friction),
                   "released": num(e.released), "ledger": num(e.ledger())},
    });
    if let Some(p) = provenance {
        v["provenance"] = serde_json::to_value(p).unwrap_or(Value::Null);
    }
    v
}
