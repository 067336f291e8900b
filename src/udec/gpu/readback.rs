//! Device to host: the state read back into the `Model` (whole, or with the contacts packed into
//! summaries by `pack_contacts.wgsl`), each GPU record converted to the model's f64 one with the
//! ledger's bases added back (see "The energy ledger" in the module above).

use crate::udec::model::{ContactKind, Model};
use rayon::prelude::*;

use super::kernels;
use super::layout::{Block, Contact, ContactForce, ContactSummary, Corner, GridPoint, Real, Sdef};
use super::{shaders, Engine, GpuError, Uploaded};

/// Mapped bytes as GPU structs: in place when aligned (parts of a read-back start 16-byte
/// aligned), else copied.
pub(super) fn pod_view<T: bytemuck::Pod>(bytes: &[u8]) -> std::borrow::Cow<'_, [T]> {
    match bytemuck::try_cast_slice(bytes) {
        Ok(items) => std::borrow::Cow::Borrowed(items),
        Err(_) => std::borrow::Cow::Owned(bytemuck::pod_collect_to_vec(bytes)),
    }
}

/// The checkpoint's buffers, as `read_state` reads them (the live state is read by
/// `read_live_state`, which may pack its contacts).
pub(super) struct StateBuffers<'a> {
    pub(super) blocks: &'a wgpu::Buffer,
    pub(super) corners: &'a wgpu::Buffer,
    pub(super) contacts: &'a wgpu::Buffer,
    /// The contacts' gather records, which hold their forces.
    pub(super) forces: &'a wgpu::Buffer,
    /// The SDEF slot and the bytes of it to read (0 in a rigid scene).
    pub(super) sdefs: (&'a wgpu::Buffer, u64),
    /// The grid points and zones and the bytes of each to read (0 in a scene without zoned
    /// blocks).
    pub(super) fdef: [(&'a wgpu::Buffer, u64); 2],
    /// The domains, contact flows and fluid loads and the bytes of each to read (0 in a dry
    /// scene).
    pub(super) fluid: [(&'a wgpu::Buffer, u64); 3],
    pub(super) counts: (usize, usize, usize),
}

impl<R: Real> Engine<R> {
    pub(super) fn read<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, n: usize) -> Result<Vec<T>, GpuError> {
        self.dev.read_pod(buffer, n)
    }

    /// What a read-back reads of the live contacts: whole with their gather records (which
    /// hold their forces), or their packed summaries only (the second part then reads nothing).
    pub(super) fn contacts_parts(&self, packed: bool) -> [(&wgpu::Buffer, u64); 2] {
        let (b, nk) = (self.buffers(), self.counts.2);
        let forces = &b.contact_forces.buffer;
        match (packed, b.summaries.as_ref()) {
            (true, Some(s)) => [(&s.buffer, (nk * std::mem::size_of::<ContactSummary<R>>()) as u64), (forces, 0)],
            // No contacts were ever packed (none live): nothing to read.
            (true, None) => [(&b.contacts.buffer, 0), (forces, 0)],
            (false, _) => {
                [(&b.contacts.buffer, (nk * std::mem::size_of::<Contact<R>>()) as u64), (forces, (nk * std::mem::size_of::<ContactForce<R>>()) as u64)]
            }
        }
    }

    /// The contacts of a read-back (`contacts_parts`), whole or packed, into the model.
    pub(super) fn convert_contacts_read(parts: &[&[u8]], packed: bool, up: &Uploaded, model: &mut Model) {
        if packed {
            Self::convert_summaries(&pod_view(parts[0]), up, model);
        } else {
            Self::convert_contacts(&pod_view(parts[0]), &pod_view(parts[1]), up, model);
        }
    }

    /// Encodes `contact_points` over the live contacts: their points and normals, which the
    /// cycle does not store, for a read-back or checkpoint of whole contacts that follows.
    pub(super) fn encode_contact_points(&self, enc: &mut wgpu::CommandEncoder) {
        let n = self.counts.2;
        let Some(bg) = self.bind_groups.as_ref().filter(|_| n > 0).map(|g| &g.contact_points) else { return };
        let (x, y) = shaders::dispatch_grid((n as u32).div_ceil(shaders::workgroup_size()));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("contact_points"), timestamp_writes: None });
        pass.set_pipeline(&self.pipelines.contact_points.pipeline);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Queues `contact_points` (no wait; the read-back that follows waits for it).
    pub(super) fn place_contact_points(&self) -> Result<(), GpuError> {
        let scope = self.dev.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("contact points") });
        self.encode_contact_points(&mut enc);
        self.dev.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Device(format!("contact_points was rejected: {e}")));
        }
        Ok(())
    }

    /// Queues `pack_contacts`: each live contact's summary for a packed read-back.
    pub(super) fn pack_contacts(&mut self) -> Result<(), GpuError> {
        let n = self.counts.2;
        if n == 0 {
            return Ok(());
        }
        let dev = &self.dev;
        let b = self.buffers.as_mut().expect("buffers exist");
        b.ensure_summaries::<R>(dev, n)?;
        let summaries = b.summaries.as_ref().expect("made above");
        // Bound to the live count: the kernel packs arrayLength(&summaries) contacts.
        fn sized(buffer: &wgpu::Buffer, bytes: usize) -> wgpu::BindingResource<'_> {
            wgpu::BindingResource::Buffer(wgpu::BufferBinding { buffer, offset: 0, size: std::num::NonZeroU64::new(bytes as u64) })
        }
        let entries = [
            wgpu::BindGroupEntry { binding: 0, resource: sized(&b.contacts.buffer, n * std::mem::size_of::<Contact<R>>()) },
            wgpu::BindGroupEntry { binding: 1, resource: sized(&summaries.buffer, n * std::mem::size_of::<ContactSummary<R>>()) },
        ];
        kernels::dispatch_items(dev, "pack_contacts", &self.pipelines.pack_contacts, &self.pipelines.pack_layout, &entries, n)
    }

    /// Reads blocks, corners and contacts of `src` into the model (one copy, one wait);
    /// returns the blocks as read.
    pub(super) fn read_state(&self, src: &StateBuffers, up: &Uploaded, model: &mut Model) -> Result<Vec<Block<R>>, GpuError> {
        let (nb, nc, nk) = src.counts;
        let parts = [
            (src.blocks, (nb * std::mem::size_of::<Block<R>>()) as u64),
            (src.corners, (nc * std::mem::size_of::<Corner<R>>()) as u64),
            (src.contacts, (nk * std::mem::size_of::<Contact<R>>()) as u64),
            (src.forces, (nk * std::mem::size_of::<ContactForce<R>>()) as u64),
            src.sdefs,
            src.fdef[0],
            src.fdef[1],
            src.fluid[0],
            src.fluid[1],
            src.fluid[2],
        ];
        self.dev.read_parts(&parts, |bytes| {
            let blocks: Vec<Block<R>> = bytemuck::pod_collect_to_vec(bytes[0]);
            Self::convert_blocks_and_corners(&blocks, &pod_view(bytes[1]), up, model);
            Self::convert_contacts(&pod_view(bytes[2]), &pod_view(bytes[3]), up, model);
            Self::convert_sdefs(&pod_view(bytes[4]), up, model);
            Self::convert_fdef(&pod_view(bytes[5]), &pod_view(bytes[6]), up, model);
            Self::convert_fluid(&pod_view(bytes[7]), &pod_view(bytes[8]), &pod_view(bytes[9]), up, model);
            blocks
        })
    }

    /// The device state into the model: centroids back to the model's frame, accumulators onto
    /// their f64 bases. Converted in parallel (a 10⁶-block model is read back at every contact
    /// update); the external work is summed serially, so the result repeats bit for bit.
    pub(super) fn convert_blocks_and_corners(blocks: &[Block<R>], corners: &[Corner<R>], up: &Uploaded, model: &mut Model) {
        model
            .blocks
            .par_iter_mut()
            .zip(blocks.par_iter())
            .zip(up.damping_base.par_iter())
            .with_min_len(4096)
            .for_each(|((m, g), &base)| Self::convert_block(g, base, up.origin, m));
        let work: f64 = blocks.iter().map(|g| g.work.to_f64()).sum();
        model.external_work = up.work_base + work;
        let Model { blocks: model_blocks, corners: model_corners, .. } = model;
        model_corners.par_iter_mut().enumerate().zip(corners.par_iter()).with_min_len(4096).for_each(|((i, m), g)| {
            let blk = &model_blocks[m.block as usize];
            let next = if i + 1 == (blk.corner_start + blk.corner_count) as usize { blk.corner_start as usize } else { i + 1 };
            Self::convert_corner(g, &corners[next], blk.centroid, blocks[m.block as usize].rotation_lo.to_f64(), m);
        });
    }

    /// One block of the device state into the model (`damping_base`: its mass-damping base).
    pub(super) fn convert_block(g: &Block<R>, damping_base: f64, o: [f64; 2], m: &mut crate::udec::model::Block) {
        m.centroid = [o[0] + (g.cx.to_f64() + g.cx_lo.to_f64()), o[1] + (g.cy.to_f64() + g.cy_lo.to_f64())];
        m.rotation = g.whole_rotation();
        m.velocity = [g.vx.to_f64(), g.vy.to_f64()];
        m.angular_velocity = g.w.to_f64();
        m.force = [g.fx.to_f64(), g.fy.to_f64()];
        m.moment = g.moment.to_f64();
        m.moved_since_update = g.moved.to_f64();
        m.update_centroid = [o[0] + (g.update_cx.to_f64() + g.update_cx_lo.to_f64()), o[1] + (g.update_cy.to_f64() + g.update_cy_lo.to_f64())];
        m.update_rotation = g.update_rotation.to_f64();
        m.update_margin = g.update_margin.to_f64();
        m.damping_work = damping_base + g.damping_work.to_f64();
    }

    /// One corner of the device state into the model, its block's centroid already converted;
    /// `next` is the block's next corner, `turn` the block's turn since its corners were placed
    /// (`Block::rotation_lo`, f32; 0 in f64), applied here in f64.
    pub(super) fn convert_corner(g: &Corner<R>, next: &Corner<R>, centroid: [f64; 2], turn: f64, m: &mut crate::udec::model::Corner) {
        let (sin, cos) = if turn == 0.0 { (0.0, 1.0) } else { turn.sin_cos() };
        let at = |x: R, y: R| {
            let (x, y) = (x.to_f64(), y.to_f64());
            if turn == 0.0 {
                return [x, y];
            }
            [cos * x - sin * y, sin * x + cos * y]
        };
        let (p, o, q) = (at(g.px, g.py), at(g.ox, g.oy), at(next.px, next.py));
        m.position = [centroid[0] + p[0], centroid[1] + p[1]];
        m.circle = [centroid[0] + o[0], centroid[1] + o[1]];
        // The edge to the next corner of the block, measured as the contact stage measures it
        // (from the two corners relative to the centroid), in f64.
        let e = [q[0] - p[0], q[1] - p[1]];
        let len = e[0].hypot(e[1]);
        m.edge_dir = [e[0] / len, e[1] / len];
        m.edge_length = len;
    }

    /// Packed contacts into the model: what detection and the ledger use. The model's point,
    /// normal, shear displacement, force and dashpot velocities stay as they were (stale) until
    /// the next whole read-back; the splice keeps the device's.
    pub(super) fn convert_summaries(summaries: &[ContactSummary<R>], up: &Uploaded, model: &mut Model) {
        model
            .contacts
            .par_iter_mut()
            .zip(summaries.par_iter())
            .zip(up.contact_base.par_iter())
            .with_min_len(4096)
            .for_each(|((m, g), &base)| Self::convert_summary(g, base, m));
    }

    /// One contact's summary into the model (`base`: its ledger bases).
    pub(super) fn convert_summary(g: &ContactSummary<R>, base: [f64; 2], m: &mut crate::udec::model::Contact) {
        m.gap = g.gap.to_f64();
        m.normal_force = g.normal_force.to_f64();
        m.shear_force = g.shear_force.to_f64();
        m.slip_work = base[0] + g.slip_work.to_f64();
        m.dashpot_work = base[1] + g.dashpot_work.to_f64();
        m.feature = g.feature;
        m.kind = if g.feature % 2 == 0 { ContactKind::CornerCorner } else { ContactKind::CornerEdge };
        m.bonded = g.bonded != 0;
    }

    /// Whole contacts, with the forces of their gather records, into the model.
    pub(super) fn convert_contacts(contacts: &[Contact<R>], forces: &[ContactForce<R>], up: &Uploaded, model: &mut Model) {
        let Model { blocks: model_blocks, contacts: model_contacts, .. } = model;
        let device = contacts.par_iter().zip(forces.par_iter());
        model_contacts.par_iter_mut().zip(device).zip(up.contact_base.par_iter()).with_min_len(4096).for_each(|((m, (g, f)), base)| {
            let c2 = model_blocks[m.block2 as usize].centroid;
            m.point = [c2[0] + g.px.to_f64(), c2[1] + g.py.to_f64()];
            m.normal = [g.nx.to_f64(), g.ny.to_f64()];
            m.gap = g.gap.to_f64();
            m.normal_force = g.normal_force.to_f64();
            m.shear_force = g.shear_force.to_f64();
            m.shear_displacement = g.shear_displacement.to_f64();
            m.force = [f.fx.to_f64(), f.fy.to_f64()];
            m.slip_work = base[0] + g.slip_work.to_f64();
            m.dashpot_work = base[1] + g.dashpot_work.to_f64();
            m.dashpot_velocity = [g.dashpot_vn.to_f64(), g.dashpot_vs.to_f64()];
            m.feature = g.feature;
            m.kind = if g.feature % 2 == 0 { ContactKind::CornerCorner } else { ContactKind::CornerEdge };
            m.bonded = g.bonded != 0;
        });
    }

    /// Reads blocks, corners and contacts back into the model, after summing the fixed blocks'
    /// forces (the cycle skips them).
    pub(super) fn readback(&mut self, model: &mut Model) -> Result<(), GpuError> {
        self.run_batch(1, true)?;
        self.read_live_state(model, false)
    }

    /// Reads blocks, corners and contacts back as they are (fixed blocks' forces stale: what
    /// stage 7 needs); `packed`: the contacts' summaries only (`pack_contacts`).
    pub(super) fn read_live_state(&mut self, model: &mut Model, packed: bool) -> Result<(), GpuError> {
        let _p = crate::profile::scope(crate::profile::Stage::Download);
        if packed {
            self.pack_contacts()?;
        } else {
            self.place_contact_points()?;
        }
        let up = self.uploaded.clone();
        let (nb, nc, _) = self.counts;
        let b = self.buffers();
        let [contacts, forces] = self.contacts_parts(packed);
        let parts = [
            (&b.blocks.buffer, (nb * std::mem::size_of::<Block<R>>()) as u64),
            (&b.corners.buffer, (nc * std::mem::size_of::<Corner<R>>()) as u64),
            contacts,
            forces,
            self.sdef_part(),
            self.fdef_parts()[0],
            self.fdef_parts()[1],
            self.fluid_parts()[0],
            self.fluid_parts()[1],
            self.fluid_parts()[2],
        ];
        let (blocks, sdefs, gridpoints) = self.dev.read_parts(&parts, |bytes| {
            let blocks: Vec<Block<R>> = bytemuck::pod_collect_to_vec(bytes[0]);
            Self::convert_blocks_and_corners(&blocks, &pod_view(bytes[1]), &up, model);
            Self::convert_contacts_read(&bytes[2..4], packed, &up, model);
            let sdefs: Vec<Sdef<R>> = bytemuck::pod_collect_to_vec(bytes[4]);
            Self::convert_sdefs(&sdefs, &up, model);
            let gridpoints: Vec<GridPoint<R>> = bytemuck::pod_collect_to_vec(bytes[5]);
            Self::convert_fdef(&gridpoints, &pod_view(bytes[6]), &up, model);
            Self::convert_fluid(&pod_view(bytes[7]), &pod_view(bytes[8]), &pod_view(bytes[9]), &up, model);
            (blocks, sdefs, gridpoints)
        })?;
        self.last_blocks = blocks;
        self.last_sdefs = sdefs;
        self.last_gridpoints = gridpoints;
        Ok(())
    }
}
