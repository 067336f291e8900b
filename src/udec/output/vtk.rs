//! VTK output for ParaView (DESIGN.md §5): the blocks as polygons and the contacts as points, in
//! legacy binary `.vtk` files written with vtkio, one pair a frame, and a `.series` file
//! (ParaView's JSON file series) that lists the frames with their simulated times, so that a run
//! opens in ParaView as one time-dependent data set. Positions are f64 (a model far from the
//! origin keeps its millimetres); the data on them f32, which a picture needs and which halves
//! the files (a frame of the 10⁶-block wall: 1.2 GB in f64).
//!
//! - `blocks_<cycle>.vtk`: one polygon a block through its corners (the rounding, ROUND long,
//!   is not drawn). Cell data: `id`, `material`, `fixed` (1 or 0), `velocity` (m/s, vector),
//!   `angular_velocity` (rad/s), `rotation` (rad), `mass` (kg), `force` (the unbalanced force of
//!   the last cycle, N, vector).
//! - `contacts_<cycle>.vtk`: one point a contact, at its contact point. Point data: `normal_force`
//!   and `shear_force` (N, compression positive), `gap` (m, overlap negative), `normal` (unit,
//!   from block 2 into block 1), `force` (on block 1, N, vector: glyph it), `block1`, `block2`
//!   (ids), `corner_corner` (1 for a corner–corner contact), `bonded` (1 while intact), `joint`
//!   (1 for a contact that follows the joint law, Appendix A ¶5, 0 for a point contact) and
//!   `joint_length` (m: the length of joint it carries, half the faces' common length; 0 for a
//!   point contact).
//! - `zones_<cycle>.vtk`, only in a scene with fully-deformable blocks (Appendix A ¶11–12): the
//!   grid points of every zoned block as points, its zones as triangles through them. Cell data:
//!   `block` (the block's id), `zone` (its number in the block, from 1 as PRINT shows it),
//!   `stress` (Pa, tension positive, a 3×3 tensor with σ13 = σ23 = σ33 = 0) and `mass` (kg).
//!   Point data: `velocity` (m/s, vector), `gridpoint_mass` (the lumped mass, kg) and `force`
//!   (the unbalanced force of the last cycle, N, vector).
//!
//! - `domains_<cycle>.vtk`, only in a scene with fluid (Appendix A ¶6–9): every domain but the
//!   outer one as the polygon of its boundary's first loop (the void's outline, or a joint's four
//!   contact feet), with the current positions. Cell data: `id` (as PRINT DOMAINS shows it),
//!   `pressure` (Pa), `area` (the fluid's, m²), `fixed` (1 while PFIX holds it), `joint` (1 for a
//!   joint domain). The contacts' file then also has `flow` (from its first domain to its
//!   second, m²/s) and `aperture` (m) as point data.
//!
//! Frames are named by cycle, so a RESTART that goes on writes new ones beside the old, and one
//! that goes back replaces the frames after it (the series keeps the frames before its cycle).

use std::path::{Path, PathBuf};

use vtkio::model::{Attribute, Attributes, PolyDataPiece, VertexNumbers, Vtk};

/// The series file format and its upkeep are the chassis's (`output::vtk`), shared with D3.
pub use crate::output::vtk::{add_to_series, Series, SeriesFrame};
use crate::output::vtk::{poly_data, write_vtk};

use crate::udec::model::{ContactKind, Model};

/// The series file the frames of a folder are listed in.
pub const SERIES_FILE: &str = "blocks.vtk.series";
/// The series of the contact frames.
pub const CONTACT_SERIES_FILE: &str = "contacts.vtk.series";
/// The series of the domain frames (a scene with fluid).
pub const DOMAIN_SERIES_FILE: &str = "domains.vtk.series";
/// The series of the zone frames (a scene with fully-deformable blocks).
pub const ZONE_SERIES_FILE: &str = "zones.vtk.series";

/// The zone file of the frame at `cycle`.
pub fn zone_frame_name(cycle: u64) -> String {
    format!("zones_{cycle:09}.vtk")
}

/// The block and contact files of the frame at `cycle`.
pub fn frame_names(cycle: u64) -> (String, String) {
    (format!("blocks_{cycle:09}.vtk"), format!("contacts_{cycle:09}.vtk"))
}

/// Writes the model's frame into `dir` (made if missing) and lists it in the folder's two series
/// files; returns the block file's path.
pub fn write_frame(model: &Model, dir: &Path) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot make the VTK folder {}: {e}", dir.display()))?;
    let (blocks_name, contacts_name) = frame_names(model.cycle);
    let blocks_path = dir.join(&blocks_name);
    write_vtk(&blocks_path, blocks_vtk(model))?;
    write_vtk(&dir.join(&contacts_name), contacts_vtk(model))?;
    add_to_series(&dir.join(SERIES_FILE), &blocks_name, model.cycle, model.time)?;
    add_to_series(&dir.join(CONTACT_SERIES_FILE), &contacts_name, model.cycle, model.time)?;
    if let (Some(_), Some(domains)) = (model.fluid, model.domains.as_ref()) {
        let name = format!("domains_{:09}.vtk", model.cycle);
        write_vtk(&dir.join(&name), domains_vtk(model, domains))?;
        add_to_series(&dir.join(DOMAIN_SERIES_FILE), &name, model.cycle, model.time)?;
    }
    if model.has_fdef() {
        let zones_name = zone_frame_name(model.cycle);
        write_vtk(&dir.join(&zones_name), zones_vtk(model))?;
        add_to_series(&dir.join(ZONE_SERIES_FILE), &zones_name, model.cycle, model.time)?;
    }
    Ok(blocks_path)
}

fn flag(b: bool) -> i32 {
    b as i32
}

/// The blocks as polygons, with their state as cell data.
pub fn blocks_vtk(model: &Model) -> Vtk {
    // Every corner a point (their positions are current), each block the polygon of its own.
    let points: Vec<f64> = model.corners.iter().flat_map(|c| [c.position[0], c.position[1], 0.0]).collect();
    let vertices: Vec<u32> = model.blocks.iter().flat_map(|b| std::iter::once(b.corner_count).chain(b.corner_start..b.corner_start + b.corner_count)).collect();
    let blocks = &model.blocks;
    let vector =
        |f: &dyn Fn(&crate::udec::model::Block) -> [f64; 2]| blocks.iter().flat_map(|b| f(b).map(|x| x as f32).into_iter().chain([0.0])).collect::<Vec<f32>>();
    let scalars = |f: &dyn Fn(&crate::udec::model::Block) -> f64| blocks.iter().map(|b| f(b) as f32).collect::<Vec<f32>>();
    let mut cell = vec![
        Attribute::scalars("id", 1).with_data(blocks.iter().map(|b| b.id as i32).collect::<Vec<_>>()),
        Attribute::scalars("material", 1).with_data(blocks.iter().map(|b| b.material as i32).collect::<Vec<_>>()),
        Attribute::scalars("fixed", 1).with_data(blocks.iter().map(|b| flag(b.fixed)).collect::<Vec<_>>()),
        Attribute::vectors("velocity").with_data(vector(&|b| b.velocity)),
        Attribute::scalars("angular_velocity", 1).with_data(scalars(&|b| b.angular_velocity)),
        Attribute::scalars("rotation", 1).with_data(scalars(&|b| b.rotation)),
        Attribute::scalars("mass", 1).with_data(scalars(&|b| b.mass)),
        Attribute::vectors("force").with_data(vector(&|b| b.force)),
    ];
    if model.has_sdef() {
        // Simply-deformable blocks: their internal stress as a 3×3 tensor (σ33 left 0, rigid
        // blocks all 0), and which blocks they are.
        let stress: Vec<f32> = (0..blocks.len())
            .flat_map(|k| {
                let s = model.sdef_of(k).map_or([0.0; 3], |s| s.stress).map(|x| x as f32);
                [s[0], s[1], 0.0, s[1], s[2], 0.0, 0.0, 0.0, 0.0]
            })
            .collect();
        cell.push(Attribute::scalars("sdef", 1).with_data((0..blocks.len()).map(|k| flag(model.sdef_of(k).is_some())).collect::<Vec<_>>()));
        cell.push(Attribute::tensors("stress").with_data(stress));
    }
    let piece = PolyDataPiece {
        points: points.into(),
        polys: Some(VertexNumbers::Legacy { num_cells: blocks.len() as u32, vertices }),
        data: Attributes { point: Vec::new(), cell },
        ..Default::default()
    };
    poly_data(&format!("blockdem blocks, cycle {}, time {:e} s", model.cycle, model.time), piece)
}

/// The contacts as points at their contact points, with their state as point data.
pub fn contacts_vtk(model: &Model) -> Vtk {
    let contacts = &model.contacts;
    let points: Vec<f64> = contacts.iter().flat_map(|c| [c.point[0], c.point[1], 0.0]).collect();
    let n = contacts.len() as u32;
    // One vertex cell a point.
    let vertices: Vec<u32> = (0..n).flat_map(|k| [1, k]).collect();
    let id = |b: u32| model.blocks.get(b as usize).map_or(-1, |blk| blk.id as i32);
    let scalars = |f: &dyn Fn(&crate::udec::model::Contact) -> f64| contacts.iter().map(|c| f(c) as f32).collect::<Vec<f32>>();
    let vector = |f: &dyn Fn(&crate::udec::model::Contact) -> [f64; 2]| {
        contacts.iter().flat_map(|c| f(c).map(|x| x as f32).into_iter().chain([0.0])).collect::<Vec<f32>>()
    };
    let point = vec![
        Attribute::scalars("normal_force", 1).with_data(scalars(&|c| c.normal_force)),
        Attribute::scalars("shear_force", 1).with_data(scalars(&|c| c.shear_force)),
        Attribute::scalars("gap", 1).with_data(scalars(&|c| c.gap)),
        Attribute::vectors("normal").with_data(vector(&|c| c.normal)),
        Attribute::vectors("force").with_data(vector(&|c| c.force)),
        Attribute::scalars("block1", 1).with_data(contacts.iter().map(|c| id(c.block1)).collect::<Vec<_>>()),
        Attribute::scalars("block2", 1).with_data(contacts.iter().map(|c| id(c.block2)).collect::<Vec<_>>()),
        Attribute::scalars("corner_corner", 1).with_data(contacts.iter().map(|c| flag(c.kind == ContactKind::CornerCorner)).collect::<Vec<_>>()),
        Attribute::scalars("bonded", 1).with_data(contacts.iter().map(|c| flag(c.bonded)).collect::<Vec<_>>()),
        Attribute::scalars("joint", 1).with_data(contacts.iter().map(|c| flag(c.joint_length > 0.0)).collect::<Vec<_>>()),
        Attribute::scalars("joint_length", 1).with_data(scalars(&|c| c.joint_length)),
    ];
    let mut point = point;
    if let (Some(_), Some(d)) = (model.fluid, model.domains.as_ref()) {
        // With fluid, each contact's flow in the last cycle and its aperture (0 for a point
        // contact).
        let flow = |k: usize, f: &dyn Fn(&crate::udec::model::domain::ContactFlow) -> f64| d.flows.get(k).map_or(0.0, |x| f(x) as f32);
        point.push(Attribute::scalars("flow", 1).with_data((0..contacts.len()).map(|k| flow(k, &|x| x.flow)).collect::<Vec<f32>>()));
        point.push(Attribute::scalars("aperture", 1).with_data((0..contacts.len()).map(|k| flow(k, &|x| x.aperture)).collect::<Vec<f32>>()));
    }
    let piece = PolyDataPiece {
        points: points.into(),
        verts: Some(VertexNumbers::Legacy { num_cells: n, vertices }),
        data: Attributes { point, cell: Vec::new() },
        ..Default::default()
    };
    poly_data(&format!("blockdem contacts, cycle {}, time {:e} s", model.cycle, model.time), piece)
}

/// The domains of a scene with fluid (all but the outer one) as polygons, with their pressures
/// as cell data.
pub fn domains_vtk(model: &Model, domains: &crate::udec::model::domain::Domains) -> Vtk {
    use crate::udec::model::domain::DomainKind;
    let (mut points, mut vertices) = (Vec::new(), Vec::new());
    let (mut id, mut pressure, mut area, mut fixed, mut joint) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (d, dom) in domains.list.iter().enumerate().filter(|(_, d)| d.kind != DomainKind::Outer) {
        let loops = crate::udec::model::fluid::domain_loops(model, domains, d);
        let Some(outline) = loops.first().filter(|l| l.len() >= 3) else { continue };
        let first = (points.len() / 3) as u32;
        vertices.push(outline.len() as u32);
        for (k, (p, _)) in outline.iter().enumerate() {
            points.extend([p[0], p[1], 0.0]);
            vertices.push(first + k as u32);
        }
        id.push(dom.id as i32);
        pressure.push(dom.pressure as f32);
        area.push(dom.area as f32);
        fixed.push(flag(dom.fixed));
        joint.push(flag(dom.kind == DomainKind::Joint));
    }
    let cells = id.len() as u32;
    let cell = vec![
        Attribute::scalars("id", 1).with_data(id),
        Attribute::scalars("pressure", 1).with_data(pressure),
        Attribute::scalars("area", 1).with_data(area),
        Attribute::scalars("fixed", 1).with_data(fixed),
        Attribute::scalars("joint", 1).with_data(joint),
    ];
    let piece = PolyDataPiece {
        points: points.into(),
        polys: Some(VertexNumbers::Legacy { num_cells: cells, vertices }),
        data: Attributes { point: Vec::new(), cell },
        ..Default::default()
    };
    poly_data(&format!("blockdem domains, cycle {}, time {:e} s", model.cycle, model.time), piece)
}

/// The zones of the fully-deformable blocks as triangles through their grid points, with the
/// zones' stresses as cell data and the grid points' motion as point data.
pub fn zones_vtk(model: &Model) -> Vtk {
    let zoned: Vec<(usize, &crate::udec::model::fdef::Fdef)> = (0..model.blocks.len()).filter_map(|b| model.fdef_of(b).map(|f| (b, f))).collect();
    let (mut points, mut vertices) = (Vec::new(), Vec::new());
    let (mut velocity, mut gp_mass, mut gp_force) = (Vec::new(), Vec::new(), Vec::new());
    let (mut stress, mut zone_mass, mut zone_block, mut zone_number) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut cells = 0u32;
    for &(b, f) in &zoned {
        // The block's grid points are numbered from here in the file.
        let first = (points.len() / 3) as u32;
        let id = model.blocks[b].id as i32;
        for g in &f.gridpoints {
            points.extend([g.position[0], g.position[1], 0.0]);
            velocity.extend([g.velocity[0] as f32, g.velocity[1] as f32, 0.0]);
            gp_force.extend([g.force[0] as f32, g.force[1] as f32, 0.0]);
            gp_mass.push(g.mass as f32);
        }
        for (k, z) in f.zones.iter().enumerate() {
            vertices.push(3);
            vertices.extend(z.gridpoints.map(|g| first + g));
            let s = z.stress.map(|x| x as f32);
            stress.extend([s[0], s[1], 0.0, s[1], s[2], 0.0, 0.0, 0.0, 0.0]);
            zone_mass.push(z.mass as f32);
            zone_block.push(id);
            zone_number.push(k as i32 + 1);
            cells += 1;
        }
    }
    let cell = vec![
        Attribute::scalars("block", 1).with_data(zone_block),
        Attribute::scalars("zone", 1).with_data(zone_number),
        Attribute::tensors("stress").with_data(stress),
        Attribute::scalars("mass", 1).with_data(zone_mass),
    ];
    let point = vec![
        Attribute::vectors("velocity").with_data(velocity),
        Attribute::scalars("gridpoint_mass", 1).with_data(gp_mass),
        Attribute::vectors("force").with_data(gp_force),
    ];
    let piece = PolyDataPiece {
        points: points.into(),
        polys: Some(VertexNumbers::Legacy { num_cells: cells, vertices }),
        data: Attributes { point, cell },
        ..Default::default()
    };
    poly_data(&format!("blockdem zones, cycle {}, time {:e} s", model.cycle, model.time), piece)
}
