//! The commands that make and cut blocks: BLOCK, CHANGE, DELETE, SPLIT (ROUND is set in the
//! dispatch, `Executor::execute`).

use super::{Executor, RunError};
use crate::udec::deck::{Located, Range};
use crate::udec::model::split::split_line;
use crate::udec::output;

impl Executor<'_> {
    /// BLOCK: a rigid block of the given corners.
    pub(super) fn block(&mut self, cmd: &Located, material: Option<u32>, constitutive: Option<u32>, corners: &[[f64; 2]]) -> Result<(), RunError> {
        self.check_material(cmd, "BLOCK", material)?;
        self.check_constitutive(cmd, "BLOCK", constitutive)?;
        let next_id = self.model.next_block_id;
        let b = self
            .model
            .add_block(corners, material.unwrap_or(1), constitutive.unwrap_or(1), None)
            .map_err(|e| self.command_error(cmd, format!("BLOCK: {e}")))?;
        if let Some(e) = self.mass_overflow(cmd, "BLOCK", [b].into_iter()) {
            // The command fails whole: the model is left as it was.
            self.model.remove_blocks(&[b]);
            self.model.next_block_id = next_id;
            return Err(e);
        }
        Ok(())
    }

    /// CHANGE: the material and constitutive numbers of the blocks in `range`, and with `sdef`
    /// (CHANGE … SDEF) their kind: simply deformable, unstrained, which needs the (new) material's
    /// bulk and shear moduli; with `fdef` (CHANGE … FDEF) fully deformable (`change_fdef`). A
    /// deformable block stays so: the report has no way back to rigid.
    pub(super) fn change(
        &mut self,
        cmd: &Located,
        range: &Range,
        sdef: bool,
        fdef: bool,
        material: Option<u32>,
        constitutive: Option<u32>,
    ) -> Result<(), RunError> {
        self.check_material(cmd, "CHANGE", material)?;
        self.check_constitutive(cmd, "CHANGE", constitutive)?;
        let blocks = self.in_range("CHANGE", range);
        if sdef {
            if let Some(&b) = blocks.iter().find(|&&b| self.model.blocks[b].kind == crate::udec::model::BlockKind::FullyDeformable) {
                return Err(
                    self.command_error(cmd, format!("CHANGE SDEF: block {} is fully deformable already; a block is one or the other", self.model.blocks[b].id))
                );
            }
            for &b in &blocks {
                let m = material.unwrap_or(self.model.blocks[b].material);
                let props = self.model.material(m).block;
                // `!(x > 0.0)`: a NaN modulus fails too.
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                if !(props.bulk > 0.0 && props.shear > 0.0) {
                    return Err(self.command_error(
                        cmd,
                        format!(
                            "CHANGE SDEF: block {} would be simply deformable in material {m}, which has no elastic moduli (K = {}, G = {}); \
                             give PROPERTY MAT={m} K=… G=… (bulk and shear modulus, > 0) before the CHANGE",
                            self.model.blocks[b].id,
                            output::format::fmt_short(props.bulk),
                            output::format::fmt_short(props.shear)
                        ),
                    ));
                }
            }
        }
        if fdef {
            self.change_fdef(cmd, &blocks, material)?;
        }
        let before: Vec<(u32, u32)> = blocks.iter().map(|&b| (self.model.blocks[b].material, self.model.blocks[b].constitutive)).collect();
        for &b in &blocks {
            if let Some(m) = material {
                self.model.blocks[b].material = m;
            }
            if let Some(c) = constitutive {
                self.model.blocks[b].constitutive = c;
            }
        }
        self.model.recompute_mass_properties();
        if let Some(e) = self.mass_overflow(cmd, "CHANGE", blocks.iter().copied()) {
            for (&b, &(m, c)) in blocks.iter().zip(&before) {
                (self.model.blocks[b].material, self.model.blocks[b].constitutive) = (m, c);
            }
            self.model.recompute_mass_properties();
            return Err(e);
        }
        if sdef {
            for &b in &blocks {
                self.model.make_sdef(b);
            }
        }
        Ok(())
    }

    /// DELETE: the blocks in `range`, their energy booked as released.
    pub(super) fn delete(&mut self, range: &Range) {
        let gone = self.in_range("DELETE", range);
        self.model.retire_energy_around(|m| m.remove_blocks(&gone));
    }

    /// SPLIT: every block the line from `from` to `to` crosses, cut in two along it.
    pub(super) fn split(&mut self, cmd: &Located, from: [f64; 2], to: [f64; 2], material: Option<u32>, constitutive: Option<u32>) -> Result<(), RunError> {
        self.check_material(cmd, "SPLIT", material)?;
        self.check_constitutive(cmd, "SPLIT", constitutive)?;
        let outcome = split_line(&mut self.model, from, to, material, constitutive);
        for (id, why) in &outcome.rejected {
            self.echo(&format!("SPLIT REJECTED FOR BLOCK {id}: {why}"));
        }
        if outcome.split.is_empty() && outcome.rejected.is_empty() {
            let f = output::format::fmt_short;
            let why = if from == to { "has zero length" } else { "crosses no block from one side to the other" };
            self.echo(&format!(
                "WARNING: SPLIT ({}, {}) ({}, {}) {why}; nothing was split (a split line must run through a block, ending outside it or on its edges)",
                f(from[0]),
                f(from[1]),
                f(to[0]),
                f(to[1])
            ));
        }
        Ok(())
    }
}
