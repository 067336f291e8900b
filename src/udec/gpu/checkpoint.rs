//! The last good state: a device-side copy of the state buffers taken when an energy check
//! passes, and on the CPU the model it belongs to (its contacts as identities only when a contact
//! update came after the last whole copy). Read back only when a run fails, so the caller gets
//! the state of the last check (DESIGN.md: a numerical failure leaves the last good state).

use crate::udec::contact::gather;
use crate::udec::model::Model;
use crate::udec::topology::Adjacency;
use rayon::prelude::*;

use super::layout::{Block, Contact, ContactForce, Corner, Real};
use super::readback::StateBuffers;
use super::{Engine, GpuError, Uploaded};

/// What the device does not hold of a contact: its identity, material and constitutive model.
/// Between whole copies, the last good state keeps its contact list as these (32 bytes a contact
/// where a model contact takes 152); a restore rebuilds the contacts from them and fills in their
/// state from the device checkpoint (`Engine::restore_checkpoint`).
#[derive(Clone, Copy)]
pub(super) struct ContactIdentity {
    pub(super) id: u32,
    pub(super) block1: u32,
    pub(super) corner: u32,
    pub(super) block2: u32,
    pub(super) material: u32,
    pub(super) constitutive: u32,
    /// Its law (`Contact::joint_length`), which the device holds only in its precision.
    pub(super) joint_length: f64,
}

impl ContactIdentity {
    pub(super) fn of(c: &crate::udec::model::Contact) -> Self {
        ContactIdentity {
            id: c.id,
            block1: c.block1,
            corner: c.corner,
            block2: c.block2,
            material: c.material,
            constitutive: c.constitutive,
            joint_length: c.joint_length,
        }
    }

    /// The contact with this identity, its state zero until a read-back fills it.
    pub(super) fn contact(self) -> crate::udec::model::Contact {
        let ContactIdentity { id, block1, corner, block2, material, constitutive, joint_length } = self;
        crate::udec::model::Contact { joint_length, ..crate::udec::model::Contact::identity(id, block1, corner, block2, material, constitutive) }
    }
}

/// The last good state on the device: copies of the state buffers taken right after an energy
/// check passed (device-to-device, no read-back), with the counts and bases they were taken
/// under. The CPU side of the checkpoint (topology, ids) is the `Model` the run keeps.
pub(super) struct Checkpoint {
    pub(super) blocks: wgpu::Buffer,
    pub(super) corners: wgpu::Buffer,
    pub(super) contacts: wgpu::Buffer,
    /// The contacts' gather records (their forces).
    pub(super) forces: wgpu::Buffer,
    /// The SDEF slot, in a scene with simply-deformable blocks (made at its first checkpoint).
    pub(super) sdefs: Option<wgpu::Buffer>,
    /// The SDEF slot's bytes copied (0 in a rigid scene).
    pub(super) sdef_bytes: u64,
    /// The grid points and zones, in a scene with zoned blocks (made at its first checkpoint),
    /// and the bytes of each copied (0 in the other scenes).
    pub(super) fdef: Option<[wgpu::Buffer; 2]>,
    pub(super) fdef_bytes: [u64; 2],
    /// The domains, contact flows and fluid loads, in a scene with fluid (made at its first
    /// checkpoint), and the bytes of each copied (0 in a dry scene).
    pub(super) fluid: Option<[wgpu::Buffer; 3]>,
    pub(super) fluid_bytes: [u64; 3],
    pub(super) counts: (usize, usize, usize),
    pub(super) uploaded: std::rc::Rc<Uploaded>,
    /// Whether it holds a state of the current run (the buffers are kept from run to run: a
    /// 10⁶-block model's copy is a gigabyte to allocate).
    pub(super) valid: bool,
}
/// A checkpoint buffer of `size` bytes (16 at least: a scene's empty list still gets one), a
/// copy's target and source: the one maker of every slot of the checkpoint.
fn checkpoint_buffer(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

impl<R: Real> Engine<R> {
    /// Copies the live state into the checkpoint buffers on the device (queued; no wait).
    pub(super) fn take_checkpoint(&mut self) {
        let _p = crate::profile::scope(crate::profile::Stage::Checks);
        let b = self.buffers.as_ref().expect("buffers exist");
        let (nb, nc, nk) = self.counts;
        let sizes = [
            (nb * std::mem::size_of::<Block<R>>()) as u64,
            (nc * std::mem::size_of::<Corner<R>>()) as u64,
            (nk * std::mem::size_of::<Contact<R>>()) as u64,
            (nk * std::mem::size_of::<ContactForce<R>>()) as u64,
        ];
        let fits = self
            .checkpoint
            .as_ref()
            .is_some_and(|c| c.blocks.size() >= sizes[0] && c.corners.size() >= sizes[1] && c.contacts.size() >= sizes[2] && c.forces.size() >= sizes[3]);
        if !fits {
            let make = |label: &str, size: u64| checkpoint_buffer(&self.dev.device, label, size);
            self.checkpoint = Some(Checkpoint {
                blocks: make("checkpoint blocks", b.blocks.buffer.size()),
                corners: make("checkpoint corners", b.corners.buffer.size()),
                contacts: make("checkpoint contacts", b.contacts.buffer.size()),
                forces: make("checkpoint contact forces", b.contact_forces.buffer.size()),
                sdefs: None,
                sdef_bytes: 0,
                fdef: None,
                fdef_bytes: [0, 0],
                fluid: None,
                fluid_bytes: [0; 3],
                counts: self.counts,
                uploaded: self.uploaded.clone(),
                valid: false,
            });
        }
        let ck = self.checkpoint.as_mut().expect("made above");
        // The SDEF slot: copied where the scene has one (its buffer made or grown here).
        let (sdef_src, sdef_bytes) = {
            let (src, n) = (b.sdefs.as_ref().filter(|_| self.sdef_scene), self.counts.0 * std::mem::size_of::<super::layout::Sdef<R>>());
            (src, if src.is_some() { n as u64 } else { 0 })
        };
        if let Some(src) = sdef_src {
            if ck.sdefs.as_ref().is_none_or(|d| d.size() < src.buffer.size()) {
                ck.sdefs = Some(checkpoint_buffer(&self.dev.device, "checkpoint simply-deformable blocks", src.buffer.size()));
            }
        }
        ck.sdef_bytes = sdef_bytes;
        self.checkpoint_fdef();
        self.checkpoint_fluid();
        let ck = self.checkpoint.as_mut().expect("made above");
        ck.valid = true;
        ck.counts = self.counts;
        ck.uploaded = self.uploaded.clone();
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("checkpoint") });
        self.encode_contact_points(&mut enc);
        let b = self.buffers.as_ref().expect("buffers exist");
        let ck = self.checkpoint.as_ref().expect("made above");
        let pairs =
            [(&b.blocks.buffer, &ck.blocks), (&b.corners.buffer, &ck.corners), (&b.contacts.buffer, &ck.contacts), (&b.contact_forces.buffer, &ck.forces)];
        for ((src, dst), size) in pairs.into_iter().zip(sizes) {
            if size > 0 {
                enc.copy_buffer_to_buffer(src, 0, dst, 0, size);
            }
        }
        if let (Some(src), Some(dst)) = (b.sdefs.as_ref(), ck.sdefs.as_ref()) {
            if ck.sdef_bytes > 0 {
                enc.copy_buffer_to_buffer(&src.buffer, 0, dst, 0, ck.sdef_bytes);
            }
        }
        if let (Some(g), Some(z), Some([dg, dz])) = (b.gridpoints.as_ref(), b.zones.as_ref(), ck.fdef.as_ref()) {
            for (src, dst, bytes) in [(g, dg, ck.fdef_bytes[0]), (z, dz, ck.fdef_bytes[1])] {
                if bytes > 0 {
                    enc.copy_buffer_to_buffer(&src.buffer, 0, dst, 0, bytes);
                }
            }
        }
        if let (Some(d), Some(f), Some(l), Some(dst)) = (b.domains.as_ref(), b.contact_flows.as_ref(), b.fluid_loads.as_ref(), ck.fluid.as_ref()) {
            for (src, dst, bytes) in [(d, &dst[0], ck.fluid_bytes[0]), (f, &dst[1], ck.fluid_bytes[1]), (l, &dst[2], ck.fluid_bytes[2])] {
                if bytes > 0 {
                    enc.copy_buffer_to_buffer(&src.buffer, 0, dst, 0, bytes);
                }
            }
        }
        self.dev.queue.submit([enc.finish()]);
    }

    /// The fluid's part of `take_checkpoint`: where the scene has fluid, the checkpoint's
    /// domain, flow and load buffers made or grown and the bytes to copy set (0 in the others).
    fn checkpoint_fluid(&mut self) {
        let parts = self.fluid_parts().map(|(buffer, bytes)| (buffer.size(), bytes));
        let ck = self.checkpoint.as_mut().expect("made by take_checkpoint");
        ck.fluid_bytes = parts.map(|p| p.1);
        if !self.fluid_scene {
            return;
        }
        let make = |label: &str, size: u64| checkpoint_buffer(&self.dev.device, label, size);
        if ck.fluid.as_ref().is_none_or(|d| d.iter().zip(&parts).any(|(d, p)| d.size() < p.0)) {
            ck.fluid = Some([make("checkpoint domains", parts[0].0), make("checkpoint contact flows", parts[1].0), make("checkpoint fluid loads", parts[2].0)]);
        }
    }

    /// Puts the device checkpoint's state into `model` (the CPU copy taken at that checkpoint),
    /// and sums the fixed blocks' forces on the CPU. (The checkpoint is copied after the energy
    /// check's gather pass, which stores every block's sums, fixed ones too; summing them here
    /// keeps a restore right whatever pass ran before the copy: the cycle itself stores none.)
    pub(super) fn restore_checkpoint(&self, model: &mut Model) -> Result<(), GpuError> {
        let Some(ck) = self.checkpoint.as_ref().filter(|c| c.valid) else { return Ok(()) };
        if let Some(identities) = &self.last_good_contacts {
            model.contacts = identities.par_iter().map(|c| c.contact()).collect();
        }
        let sdefs = match &ck.sdefs {
            Some(s) => (s, ck.sdef_bytes),
            None => (&ck.blocks, 0),
        };
        let fdef = match &ck.fdef {
            Some([g, z]) => [(g, ck.fdef_bytes[0]), (z, ck.fdef_bytes[1])],
            None => [(&ck.blocks, 0), (&ck.blocks, 0)],
        };
        let fluid = match &ck.fluid {
            Some([d, f, l]) => [(d, ck.fluid_bytes[0]), (f, ck.fluid_bytes[1]), (l, ck.fluid_bytes[2])],
            None => [(&ck.blocks, 0), (&ck.blocks, 0), (&ck.blocks, 0)],
        };
        let src = StateBuffers { blocks: &ck.blocks, corners: &ck.corners, contacts: &ck.contacts, forces: &ck.forces, sdefs, fdef, fluid, counts: ck.counts };
        self.read_state(&src, &ck.uploaded, model)?;
        let adjacency = Adjacency::build(model.blocks.len(), &model.contacts);
        let gravity = model.gravity;
        let forces: Vec<gather::ContactForce> = model.contacts.iter().map(gather::ContactForce::from).collect();
        for (b, block) in model.blocks.iter_mut().enumerate().filter(|(_, blk)| blk.fixed) {
            gather::gather(block, &forces, adjacency.entries(b), gravity);
        }
        if model.fluid.is_some() {
            // Their fluid loads too, as the gather pass before the copy added them.
            let mut loads = Vec::new();
            crate::udec::cpu::flow::pressure_loads(model, &adjacency, &mut loads);
            for (block, l) in model.blocks.iter_mut().zip(&loads).filter(|(blk, _)| blk.fixed) {
                block.force[0] += l[0];
                block.force[1] += l[1];
                block.moment += l[2];
            }
        }
        Ok(())
    }

    /// The FDEF part of `take_checkpoint`: where the scene has zoned blocks, the checkpoint's
    /// grid-point and zone buffers made or grown and the bytes to copy set (0 in the others).
    fn checkpoint_fdef(&mut self) {
        let b = self.buffers.as_ref().expect("buffers exist");
        let ck = self.checkpoint.as_mut().expect("made by take_checkpoint");
        ck.fdef_bytes = [0, 0];
        let (Some(g), Some(z)) = (b.gridpoints.as_ref().filter(|_| self.fdef_scene), b.zones.as_ref()) else { return };
        let make = |label: &str, size: u64| checkpoint_buffer(&self.dev.device, label, size);
        if ck.fdef.as_ref().is_none_or(|[dg, dz]| dg.size() < g.buffer.size() || dz.size() < z.buffer.size()) {
            ck.fdef = Some([make("checkpoint grid points", g.buffer.size()), make("checkpoint zones", z.buffer.size())]);
        }
        let (n_gp, n_zones) = self.fdef_counts;
        ck.fdef_bytes = [(n_gp * std::mem::size_of::<super::layout::GridPoint<R>>()) as u64, (n_zones * std::mem::size_of::<super::layout::Zone<R>>()) as u64];
    }
}
