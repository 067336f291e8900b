//! The commands of fully-deformable blocks: CHANGE … FDEF and GENERATE (SL-85-1 Appendix A
//! ¶11–12), and the checks a CYCLE makes of such blocks.

use super::{Executor, RunError};
use crate::udec::deck::{Located, Mesh, Range};
use crate::udec::model::constitutive::Constitutive;
use crate::udec::model::zoning;
use crate::udec::model::BlockKind;
use crate::udec::output::format::fmt_short;

impl Executor<'_> {
    /// CHANGE … FDEF: the blocks in `range` become fully deformable (zoned by a later GENERATE).
    /// Their material needs a bulk modulus K > 0; a shear modulus G of 0 (none given, as sample 3's
    /// material 1) is allowed with a warning: such zones resist only a change of volume.
    pub(super) fn change_fdef(&mut self, cmd: &Located, blocks: &[usize], material: Option<u32>) -> Result<(), RunError> {
        for &b in blocks {
            let m = material.unwrap_or(self.model.blocks[b].material);
            let props = self.model.material(m).block;
            let id = self.model.blocks[b].id;
            // `!(x > 0.0)`: a NaN modulus fails too.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(props.bulk > 0.0 && props.bulk.is_finite() && props.shear >= 0.0 && props.shear.is_finite()) {
                return Err(self.command_error(
                    cmd,
                    format!(
                        "CHANGE FDEF: block {id} would be fully deformable in material {m}, which has no elastic moduli (K = {}, G = {}); \
                         give PROPERTY MAT={m} K=… G=… (bulk modulus > 0, shear modulus ≥ 0) before the CHANGE",
                        fmt_short(props.bulk),
                        fmt_short(props.shear)
                    ),
                ));
            }
            if self.model.blocks[b].kind == BlockKind::SimplyDeformable {
                return Err(self.command_error(cmd, format!("CHANGE FDEF: block {id} is simply deformable already; a block is one or the other")));
            }
        }
        let weak: Vec<u32> =
            blocks.iter().map(|&b| material.unwrap_or(self.model.blocks[b].material)).filter(|&m| self.model.material(m).block.shear == 0.0).collect();
        if let Some(&m) = weak.first() {
            self.echo(&format!("WARNING: CHANGE FDEF: material {m} has no shear modulus (G = 0): its zones resist only a change of volume"));
        }
        for &b in blocks {
            self.model.make_fdef(b);
        }
        Ok(())
    }

    /// GENERATE: zones every fully-deformable block whose centroid lies in `range` (AUTO by the
    /// report's three stages, MANUAL from the grid points and zones given). Fails whole, the
    /// model unchanged, where a block cannot be zoned; a range over no fully-deformable block is
    /// an error.
    pub(super) fn generate(&mut self, cmd: &Located, range: &Range, mesh: &Mesh) -> Result<(), RunError> {
        let all = self.model.blocks_in_range(range.x1, range.x2, range.y1, range.y2);
        let blocks: Vec<usize> = all.iter().copied().filter(|&b| self.model.blocks[b].kind == BlockKind::FullyDeformable).collect();
        if blocks.is_empty() {
            let what = if all.is_empty() {
                "no block's centroid lies in the range".to_string()
            } else {
                format!("none of the {} block(s) in the range is fully deformable", all.len())
            };
            return Err(self.command_error(
                cmd,
                format!(
                    "GENERATE: {what} (x {} to {}, y {} to {}); make blocks fully deformable with CHANGE x1 x2 y1 y2 FDEF first",
                    fmt_short(range.x1),
                    fmt_short(range.x2),
                    fmt_short(range.y1),
                    fmt_short(range.y2)
                ),
            ));
        }
        let mut meshes = Vec::with_capacity(blocks.len());
        for &b in &blocks {
            let outline = self.model.world_outline(b);
            let id = self.model.blocks[b].id;
            let made = match mesh {
                Mesh::Auto { max_edge } => zoning::auto_mesh(&outline, *max_edge),
                Mesh::Manual { grid_points, zones } => {
                    if blocks.len() > 1 {
                        Err(format!("MANUAL zones one block, and {} fully-deformable blocks lie in the range", blocks.len()))
                    } else {
                        zoning::manual_mesh(&outline, grid_points, zones, self.model.tol.round)
                    }
                }
            };
            meshes.push(made.map_err(|e| self.command_error(cmd, format!("GENERATE: block {id}: {e}")))?);
        }
        let mut zones = 0;
        self.model.retire_energy_around(|m| {
            // From the last, so that the indices of the ones before stay.
            for (&b, mesh) in blocks.iter().zip(&meshes).rev() {
                m.zone_block(b, mesh);
                zones += mesh.zones.len();
            }
        });
        let points: usize = meshes.iter().map(|m| m.points.len()).sum();
        self.echo(&format!("{} BLOCK(S) ZONED: {zones} ZONES, {points} GRID POINTS", blocks.len()));
        Ok(())
    }

    /// What CYCLE asks of fully-deformable blocks: each zoned (GENERATE), and none cracking (the
    /// report cracks rigid and simply-deformable blocks only, ¶15).
    pub(super) fn check_fdef(&self, cmd: &Located) -> Result<(), RunError> {
        for (b, blk) in self.model.blocks.iter().enumerate() {
            if blk.kind != BlockKind::FullyDeformable {
                continue;
            }
            if self.model.fdef_of(b).is_none_or(|f| f.zones.is_empty()) {
                return Err(self
                    .command_error(cmd, format!("CYCLE: block {} is fully deformable but has no zones; give GENERATE x1 x2 y1 y2 AUTO amax over it", blk.id)));
            }
            let cracks = Constitutive::from_number(blk.constitutive).is_some();
            if cracks && self.model.material(blk.material).block.tf > 0.0 {
                return Err(self.command_error(
                    cmd,
                    format!(
                        "CYCLE: block {} is fully deformable and its material {} has a tensile strength factor TF: cracking through a zoned block is not in the report (¶15 cracks rigid and simply-deformable blocks); set TF=0 or leave the block rigid or SDEF",
                        blk.id, blk.material
                    ),
                ));
            }
        }
        Ok(())
    }
}
