//! VTK output of D3 for ParaView (DESIGN.md §5), in the shape of the 2D engine's
//! (`udec::output::vtk`): one pair of legacy binary files a frame in the run's VTK folder, and
//! the `.series` files (`output::vtk`) that list the frames with their times. Positions are f64,
//! the data on them f32.
//!
//! - `blocks_<cycle>.vtk`: every block's vertices as points and its triangular faces as polygons
//!   through them (counter-clockwise seen from outside, so ParaView's normals point out). Cell
//!   data, each face carrying its block's: `id`, `material`, `fixed` (1 or 0), `velocity` (m/s,
//!   vector), `angular_velocity` (rad/s, vector), `mass` (kg), `force` and `moment` (the sums of
//!   the last cycle, N and N·m, vectors); in a scene with simply-deformable blocks, `stress`
//!   (Pa, tension positive, a 3 × 3 tensor, zero on rigid blocks).
//! - `contacts_<cycle>.vtk`: one point a real contact (degenerate ones, neighbour links, are left
//!   out), at its contact point. Point data: `normal_force` (N, compression positive, the logical
//!   contacts' sum), `shear_force` (N, vector), `normal` (unit, from block 1 into block 2),
//!   `force` (on block 2, N, vector: glyph it), `block1`, `block2` (ids), `area` (m², the touching
//!   region of a face–face or face–edge contact) and `logical` (how many logical contacts).

use std::path::{Path, PathBuf};

use glam::DVec3;
use vtkio::model::{Attribute, Attributes, PolyDataPiece, VertexNumbers, Vtk};

use super::model::{Block, Contact, Model};
use crate::output::vtk::{add_to_series, poly_data, write_vtk};

/// The series files of a folder's block and contact frames (the 2D engine's names).
pub const SERIES_FILE: &str = "blocks.vtk.series";
pub const CONTACT_SERIES_FILE: &str = "contacts.vtk.series";

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
    Ok(blocks_path)
}

fn f32s(v: DVec3) -> [f32; 3] {
    v.to_array().map(|x| x as f32)
}

/// The blocks' faces as polygons, each with its block's state as cell data.
pub fn blocks_vtk(model: &Model) -> Vtk {
    let points: Vec<f64> = model.blocks.iter().flat_map(|b| b.vertices.iter().flat_map(|v| v.to_array())).collect();
    let mut vertices = Vec::new();
    let mut owner: Vec<&Block> = Vec::new();
    let mut first = 0u32;
    for b in &model.blocks {
        for f in &b.shape.faces {
            vertices.push(3);
            vertices.extend(f.map(|k| first + k));
            owner.push(b);
        }
        first += b.vertices.len() as u32;
    }
    let vector = |f: &dyn Fn(&Block) -> DVec3| owner.iter().flat_map(|b| f32s(f(b))).collect::<Vec<f32>>();
    let cell = vec![
        Attribute::scalars("id", 1).with_data(owner.iter().map(|b| b.id as i32).collect::<Vec<_>>()),
        Attribute::scalars("material", 1).with_data(owner.iter().map(|b| b.material as i32).collect::<Vec<_>>()),
        Attribute::scalars("fixed", 1).with_data(owner.iter().map(|b| b.fixed as i32).collect::<Vec<_>>()),
        Attribute::vectors("velocity").with_data(vector(&|b| b.velocity)),
        Attribute::vectors("angular_velocity").with_data(vector(&|b| b.angular_velocity)),
        Attribute::scalars("mass", 1).with_data(owner.iter().map(|b| b.mass as f32).collect::<Vec<_>>()),
        Attribute::vectors("force").with_data(vector(&|b| b.force)),
        Attribute::vectors("moment").with_data(vector(&|b| b.moment)),
    ];
    let mut cell = cell;
    if model.blocks.iter().any(|b| b.is_sdef()) {
        // Simply-deformable blocks: their internal stress (Pa, tension positive) as a 3 × 3
        // tensor, zero for the rigid ones.
        let stress: Vec<f32> = owner
            .iter()
            .flat_map(|b| {
                let t = b.sdef.map_or(glam::DMat3::ZERO, |s| super::sdef::tensor(s.stress));
                [t.row(0), t.row(1), t.row(2)].map(|r| r.to_array().map(|x| x as f32))
            })
            .flatten()
            .collect();
        cell.push(Attribute::tensors("stress").with_data(stress));
    }
    let piece = PolyDataPiece {
        points: points.into(),
        polys: Some(VertexNumbers::Legacy { num_cells: owner.len() as u32, vertices }),
        data: Attributes { point: Vec::new(), cell },
        ..Default::default()
    };
    poly_data(&format!("blockdem D3 blocks, cycle {}, time {:e} s", model.cycle, model.time), piece)
}

/// The real contacts as points at their contact points, with their forces as point data.
pub fn contacts_vtk(model: &Model) -> Vtk {
    let contacts: Vec<&Contact> = model.contacts.iter().filter(|c| c.category.is_some()).collect();
    let points: Vec<f64> = contacts.iter().flat_map(|c| c.point().to_array()).collect();
    let n = contacts.len() as u32;
    let vertices: Vec<u32> = (0..n).flat_map(|k| [1, k]).collect();
    let id = |b: u32| model.blocks.get(b as usize).map_or(-1, |blk| blk.id as i32);
    let vector = |f: &dyn Fn(&Contact) -> DVec3| contacts.iter().flat_map(|c| f32s(f(c))).collect::<Vec<f32>>();
    let point = vec![
        Attribute::scalars("normal_force", 1).with_data(contacts.iter().map(|c| c.normal_force() as f32).collect::<Vec<_>>()),
        Attribute::vectors("shear_force").with_data(vector(&|c| c.shear_force())),
        Attribute::vectors("normal").with_data(vector(&|c| c.normal)),
        Attribute::vectors("force").with_data(vector(&|c| c.normal * c.normal_force() + c.shear_force())),
        Attribute::scalars("block1", 1).with_data(contacts.iter().map(|c| id(c.blocks[0])).collect::<Vec<_>>()),
        Attribute::scalars("block2", 1).with_data(contacts.iter().map(|c| id(c.blocks[1])).collect::<Vec<_>>()),
        Attribute::scalars("area", 1).with_data(contacts.iter().map(|c| c.area as f32).collect::<Vec<_>>()),
        Attribute::scalars("logical", 1).with_data(contacts.iter().map(|c| c.logical.len() as i32).collect::<Vec<_>>()),
    ];
    let piece = PolyDataPiece {
        points: points.into(),
        verts: Some(VertexNumbers::Legacy { num_cells: n, vertices }),
        data: Attributes { point, cell: Vec::new() },
        ..Default::default()
    };
    poly_data(&format!("blockdem D3 contacts, cycle {}, time {:e} s", model.cycle, model.time), piece)
}
