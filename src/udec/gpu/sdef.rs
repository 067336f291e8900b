//! Simply-deformable blocks on the device (issue 28, `model::sdef`): their extension in its own
//! slot (`layout::Sdef`, one per block at the block's index) and each contact's lever arms
//! (`layout::ContactLever`), made, uploaded and read back only in a scene that has SDEF blocks;
//! a rigid scene binds and dispatches nothing of them (`kernels::SdefKernels`).
//!
//! What differs in such a scene: the cycle runs the `_sdef` entry points (`Engine::stages`); at a
//! contact update the lever arms follow their contacts as the list is spliced on the device
//! (`Engine::splice_levers`: the kept ones copied run by run, the new ones the CPU's, from the
//! contact points it read), and a partial read-back brings the listed blocks' extensions too, so
//! that the re-examined blocks' `update_strain` is reset on the device (`Engine::reset_sdef_
//! update_strains`); the block pass raises `Flags::crack_due` when a block's stress reaches its
//! Griffith strength, and the CPU's cracking stage runs on the state read back then (`gpu::run`).
//! (Until 2026-11-26 an SDEF scene uploaded its whole contact list at every update: on an H100
//! the wall of 10⁵ SDEF bricks ran at a ninth of the rigid wall's rate, and 10⁶ did not finish
//! its measurement.)

use crate::udec::model::{BlockKind, Model};
use crate::udec::topology::cracking::is_griffith_candidate;

use super::layout::{ContactLever, Real, Sdef, BLOCK_SDEF};
use super::{r, Engine, GpuError};

impl<R: Real> Sdef<R> {
    /// Block `b`'s extension as the device holds it (zero for a rigid block): the model's state,
    /// its area and its material's elastic constants, and the Griffith strength where the block
    /// is a Griffith candidate.
    pub fn from_model(model: &Model, b: usize) -> Self {
        let Some(s) = model.sdef_of(b) else { return Sdef::default() };
        let blk = &model.blocks[b];
        let mat = &model.material(blk.material).block;
        let a = |x: [f64; 3]| x.map(r::<R>);
        Sdef {
            strain: a(s.strain),
            strain_rate: a(s.strain_rate),
            stress: a(s.stress),
            applied: s.applied.map(r::<R>),
            moments: a(s.moments),
            update_strain: a(s.update_strain),
            damping_work: R::default(),
            area: r(blk.area),
            lambda: r(crate::udec::model::sdef::lame_lambda(mat.bulk, mat.shear)),
            shear: r(mat.shear),
            griffith_tf: if is_griffith_candidate(model, b) { r(mat.tf) } else { R::default() },
        }
    }

    /// The device state into the model's extension (`damping_base`: its internal damping's
    /// work at the upload).
    pub fn convert(&self, damping_base: f64, m: &mut crate::udec::model::sdef::Sdef) {
        let a = |x: [R; 3]| x.map(|v| v.to_f64());
        m.strain = a(self.strain);
        m.strain_rate = a(self.strain_rate);
        m.stress = a(self.stress);
        m.applied = self.applied.map(|v| v.to_f64());
        m.update_strain = a(self.update_strain);
        m.damping_work = damping_base + self.damping_work.to_f64();
    }
}

impl<R: Real> ContactLever<R> {
    /// The lever arms of a model contact, from its point and its blocks' centroids.
    pub fn of(model: &Model, c: &crate::udec::model::Contact) -> Self {
        let (c1, c2) = (model.blocks[c.block1 as usize].centroid, model.blocks[c.block2 as usize].centroid);
        ContactLever { r1x: r(c.point[0] - c1[0]), r1y: r(c.point[1] - c1[1]), r2x: r(c.point[0] - c2[0]), r2y: r(c.point[1] - c2[1]) }
    }
}

impl<R: Real> Engine<R> {
    /// At a whole upload: whether the scene has SDEF blocks; if it has, their kernels and slots
    /// made (once) and every block's extension written. Returns whether a buffer was re-created
    /// (the bind groups must then be rebuilt).
    pub(super) fn upload_sdef(&mut self, model: &Model) -> Result<bool, GpuError> {
        self.sdef_scene = model.has_sdef();
        if !self.sdef_scene {
            return Ok(false);
        }
        let had_kernels = self.pipelines.sdef.is_some();
        self.pipelines.with_sdef(&self.dev)?;
        let b = self.buffers.as_mut().expect("buffers exist");
        let made = b.ensure_sdef::<R>(&self.dev, model.blocks.len(), model.contacts.len())?;
        let sdefs: Vec<Sdef<R>> = (0..model.blocks.len()).map(|k| Sdef::from_model(model, k)).collect();
        let up = std::rc::Rc::make_mut(&mut self.uploaded);
        up.sdef_damping_base = std::sync::Arc::new((0..model.blocks.len()).map(|k| model.sdef_of(k).map_or(0.0, |s| s.damping_work)).collect());
        let b = self.buffers();
        self.dev.queue.write_buffer(&b.sdefs.as_ref().expect("made above").buffer, 0, bytemuck::cast_slice(&sdefs));
        self.last_sdefs = sdefs;
        Ok(made || !had_kernels)
    }

    /// With a new contact list in an SDEF scene: room for its lever arms and theirs from the
    /// model (what the first gather after the upload reads; the contact stage writes them every
    /// cycle after). Returns whether the buffer was re-created.
    pub(super) fn upload_levers(&mut self, model: &Model) -> Result<bool, GpuError> {
        if !self.sdef_scene {
            return Ok(false);
        }
        let b = self.buffers.as_mut().expect("buffers exist");
        let made = b.ensure_sdef::<R>(&self.dev, model.blocks.len(), model.contacts.len())?;
        let levers: Vec<ContactLever<R>> = model.contacts.iter().map(|c| ContactLever::of(model, c)).collect();
        let b = self.buffers();
        self.dev.queue.write_buffer(&b.contact_levers.as_ref().expect("made above").buffer, 0, bytemuck::cast_slice(&levers));
        Ok(made)
    }

    /// What a read-back reads of the SDEF slot: every block's extension (nothing in a rigid
    /// scene).
    pub(super) fn sdef_part(&self) -> (&wgpu::Buffer, u64) {
        let b = self.buffers();
        let n = if self.sdef_scene { self.counts.0 } else { 0 };
        match &b.sdefs {
            Some(s) => (&s.buffer, (n * std::mem::size_of::<Sdef<R>>()) as u64),
            None => (&b.params, 0),
        }
    }

    /// The SDEF slot as read (`sdef_part`) into the model's extension.
    pub(super) fn convert_sdefs(sdefs: &[Sdef<R>], up: &super::Uploaded, model: &mut Model) {
        if sdefs.is_empty() {
            return;
        }
        let Model { blocks, sdef, .. } = model;
        for (k, (g, m)) in sdefs.iter().zip(sdef.iter_mut()).enumerate() {
            if blocks[k].kind == BlockKind::SimplyDeformable {
                g.convert(up.sdef_damping_base.get(k).copied().unwrap_or(0.0), m);
            }
        }
    }

    /// After a contact update in an SDEF scene: the blocks it re-examined (`reset`) measure
    /// their strain from here on (`Sdef::update_strain`), as their reset update distances do.
    /// The extension as last read back is current (no cycle ran since).
    pub(super) fn reset_update_strains(&mut self, reset: &[usize]) {
        if !self.sdef_scene || self.last_sdefs.is_empty() {
            return;
        }
        let mut changed = false;
        for &i in reset {
            if self.last_blocks.get(i).is_some_and(|b| b.kind == BLOCK_SDEF) {
                let s = &mut self.last_sdefs[i];
                s.update_strain = s.strain;
                changed = true;
            }
        }
        if changed {
            let b = self.buffers();
            self.dev.queue.write_buffer(&b.sdefs.as_ref().expect("an SDEF scene has them").buffer, 0, bytemuck::cast_slice(&self.last_sdefs));
        }
    }

    /// The SDEF kernels and their bind groups, in a scene with SDEF blocks (the cycle, the gather
    /// pass and the energy check run them then).
    pub(super) fn sdef_kernels(&self) -> Option<(&super::kernels::SdefKernels, &super::kernels::SdefBindGroups)> {
        let groups = self.bind_groups.as_ref()?.sdef.as_ref()?;
        Some((self.pipelines.sdef.as_ref()?, groups)).filter(|_| self.sdef_scene)
    }

    /// Contact updates splice the list on the device: not in a scene with zoned blocks
    /// (`gpu::fdef`) or fluid (`gpu::flow`: the domains are rebuilt on the CPU and uploaded with
    /// the list).
    pub(super) fn splices_on_device(&self) -> bool {
        self.splice && !self.fdef_scene && !self.fluid_scene
    }

    /// `splice_contacts`'s companion in an SDEF scene: the lever arms follow their contacts into
    /// the new list. `runs` is the edit's (`ListEdit::runs`, the new bit `new_bit`): each run of
    /// kept contacts is one device copy from the live levers into the spare ones, each run of new
    /// contacts a write of their levers from the model (the CPU read their blocks); the spare
    /// then becomes live. Copies, not a kernel: a contact update has few runs.
    pub(super) fn splice_levers(&mut self, model: &Model, inserted_at: &[u32], runs: &[[u32; 2]], new_bit: u32) -> Result<(), GpuError> {
        if !self.sdef_scene {
            return Ok(());
        }
        let n = model.contacts.len();
        let size = std::mem::size_of::<ContactLever<R>>() as u64;
        let created: Vec<ContactLever<R>> = inserted_at.iter().map(|&k| ContactLever::of(model, &model.contacts[k as usize])).collect();
        let dev = &self.dev;
        let b = self.buffers.as_mut().expect("buffers exist");
        b.ensure_spare_levers::<R>(dev, n)?;
        let (Some(live), Some(spare)) = (b.contact_levers.as_ref(), b.spare_levers.as_ref()) else {
            return Err(GpuError::Device("GPU: an SDEF scene without its lever buffers (a bug)".into()));
        };
        let mut encoder = dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("splice_levers") });
        for w in runs.windows(2) {
            let ([start, source], end) = (w[0], w[1][0]);
            let len = end.saturating_sub(start) as usize;
            if len == 0 {
                continue;
            }
            if source & new_bit != 0 {
                let j = (source & !new_bit) as usize;
                dev.queue.write_buffer(&spare.buffer, start as u64 * size, bytemuck::cast_slice(&created[j..j + len]));
            } else {
                encoder.copy_buffer_to_buffer(&live.buffer, source as u64 * size, &spare.buffer, start as u64 * size, len as u64 * size);
            }
        }
        dev.queue.submit([encoder.finish()]);
        b.swap_levers();
        Ok(())
    }

    /// After a partial contact update in an SDEF scene: the re-examined blocks (`flagged`)
    /// measure their strain from here on, `update_strain` set on the device to the strain just
    /// read (`records`: the listed blocks' extensions, in the order of `listed`).
    pub(super) fn reset_sdef_update_strains(&self, listed: &[u32], records: &[Sdef<R>], flagged: &[u32]) {
        if !self.sdef_scene || records.is_empty() {
            return;
        }
        let Some(sdefs) = self.buffers().sdefs.as_ref() else { return };
        let field = std::mem::offset_of!(Sdef<R>, update_strain);
        for &b in flagged {
            let Ok(i) = listed.binary_search(&b) else { continue };
            if self.last_blocks.get(b as usize).is_some_and(|g| g.kind == BLOCK_SDEF) {
                let at = (b as usize * std::mem::size_of::<Sdef<R>>() + field) as u64;
                self.dev.queue.write_buffer(&sdefs.buffer, at, bytemuck::cast_slice(&records[i].strain));
            }
        }
    }
}

/// Makes sure `buffers` can hold the SDEF slots of a model of `blocks` blocks (the preflight's
/// check, before the full detection).
pub(super) fn check_fits<R: Real>(buffers_cap: u64, blocks: usize, precision: crate::gpu::Precision) -> Result<(), GpuError> {
    super::kernels::check_fits("simply-deformable blocks", std::mem::size_of::<Sdef<R>>(), blocks, buffers_cap, precision)
}
