//! Host to device: the model's state uploaded whole at a run's start (or after a crack), and
//! after a contact update only what it changed (DESIGN.md §3): the update's edit of the contact
//! list spliced on the device (`splice_contacts.wgsl`), the adjacency lists' edit, the reset
//! update distances of the blocks it re-examined, and the run constants.

use crate::udec::contact::gather::AdjacencyEntry;
use crate::udec::model::{Model, MAX_MATERIALS};
use crate::udec::topology::detect::ListEdit;
use crate::udec::topology::Adjacency;
use rayon::prelude::*;
use std::sync::Arc;

use super::kernels::{self, Buffers};
use super::layout::{Block, Contact, ContactForce, ContactPatch, Corner, EnergySum, Material, Params, Real};
use super::shaders::split_rotation;
use super::{r, shaders, splice, Engine, GpuError, Uploaded};

/// Where a contact update that made or dropped contacts changes the adjacency lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AdjacencyEdits {
    /// On the device (`splice_adjacency.wgsl`, in proportion to the changes) unless the adapter
    /// is a software one, whose device memory is the host's: there the whole lists are copied up
    /// (a memcpy of 4 bytes an entry), which costs less than the edit's kernels (lavapipe, wall
    /// of 10³ blocks struck by the projectile: the edit's dispatches took 0.41–0.48 ms an
    /// update, and with the whole copy instead an update's host upload time, contact splice
    /// included, fell from 0.3–0.4 to ~0.1 ms; docs/BENCHMARKS.md).
    #[default]
    Auto,
    /// Always on the device (the tests' way to run the edit on a software adapter).
    Always,
    /// Never: the lists are uploaded whole.
    Never,
}

impl<R: Real> Engine<R> {
    pub(super) fn gpu_contact(model: &Model, c: &crate::udec::model::Contact) -> Contact<R> {
        let c2 = model.blocks[c.block2 as usize].centroid;
        Contact {
            px: r(c.point[0] - c2[0]),
            py: r(c.point[1] - c2[1]),
            nx: r(c.normal[0]),
            ny: r(c.normal[1]),
            gap: r(c.gap),
            normal_force: r(c.normal_force),
            shear_force: r(c.shear_force),
            shear_displacement: r(c.shear_displacement),
            slip_work: R::default(),
            dashpot_work: R::default(),
            dashpot_vn: r(c.dashpot_velocity[0]),
            dashpot_vs: r(c.dashpot_velocity[1]),
            length: r(c.joint_length),
            block1: c.block1,
            corner: c.corner,
            block2: c.block2,
            feature: c.feature,
            material: crate::udec::model::material_slot(c.material, MAX_MATERIALS) as u32,
            bonded: c.bonded as u32,
        }
    }

    /// The gather's record of a contact, from the model (after a topology change): the force on
    /// block 1 and both moments, as `contact_forces` computes them.
    pub(super) fn gpu_contact_force(model: &Model, c: &crate::udec::model::Contact) -> ContactForce<R> {
        let (c1, c2) = (model.blocks[c.block1 as usize].centroid, model.blocks[c.block2 as usize].centroid);
        let [fx, fy] = c.force;
        let (r1, r2) = ([c.point[0] - c1[0], c.point[1] - c1[1]], [c.point[0] - c2[0], c.point[1] - c2[1]]);
        ContactForce { fx: r(fx), fy: r(fy), m: [r(r1[0] * fy - r1[1] * fx), r(r2[1] * fx - r2[0] * fy)] }
    }

    /// Uploads the whole model (start of a run, or after a crack split a block).
    pub(super) fn upload_all(&mut self, model: &Model, adjacency: &Adjacency) -> Result<(), GpuError> {
        let _p = crate::profile::scope(crate::profile::Stage::Upload);
        self.block_generation += 1;
        // Origin: the middle of the model, rounded to a whole unit, only for f32 (f64 has digits
        // to spare and keeps the CPU's coordinates exactly).
        let mut origin = [0.0, 0.0];
        if std::mem::size_of::<R>() == 4 && !model.blocks.is_empty() {
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for b in &model.blocks {
                for i in 0..2 {
                    lo[i] = lo[i].min(b.centroid[i]);
                    hi[i] = hi[i].max(b.centroid[i]);
                }
            }
            origin = [(0.5 * (lo[0] + hi[0])).round(), (0.5 * (lo[1] + hi[1])).round()];
        }
        // The contact bases are set by `upload_contacts`, which follows.
        let uploaded = Uploaded {
            origin,
            work_base: model.external_work,
            damping_base: Arc::new(model.blocks.iter().map(|b| b.damping_work).collect()),
            contact_base: Default::default(),
            sdef_damping_base: Default::default(),
            fdef_damping_base: Default::default(),
            fluid_base: [0.0, 0.0],
        };
        let blocks: Vec<Block<R>> = model.blocks.par_iter().with_min_len(4096).map(|b| Block::from_model(b, origin)).collect();
        let corners: Vec<Corner<R>> = model.corners.par_iter().with_min_len(4096).map(|c| Corner::from_model(&model.blocks, c)).collect();
        let mut materials = vec![Material::<R>::default(); MAX_MATERIALS];
        for (g, m) in materials.iter_mut().zip(&model.materials) {
            let (c, j) = (&m.contact, &m.joint);
            *g = Material {
                kn: r(c.kn),
                ks: r(c.ks),
                cohesion: r(c.cohesion),
                friction: r(c.friction),
                jkn: r(j.kn),
                jks: r(j.ks),
                jcohesion: r(j.cohesion),
                jfriction: r(j.friction),
            };
        }
        let rebuild = match &mut self.buffers {
            None => {
                let buffers = Buffers::new::<R>(&self.dev, blocks.len(), corners.len(), model.contacts.len())?;
                self.end_cycle_bind_group = Some(buffers.end_cycle_bind_group(&self.dev, &self.pipelines.end_cycle_layout));
                self.buffers = Some(buffers);
                true
            }
            Some(b) => {
                let d = &self.dev;
                let mut g = Buffers::ensure(d, &mut b.blocks, "blocks", std::mem::size_of::<Block<R>>(), blocks.len())?;
                g |= Buffers::ensure(d, &mut b.corners, "corners", std::mem::size_of::<Corner<R>>(), corners.len())?;
                g |= Buffers::ensure(d, &mut b.adj_offsets, "adjacency offsets", 4, blocks.len() + 1)?;
                g
            }
        };
        if rebuild {
            self.bind_groups = None;
        }
        let q = &self.dev.queue;
        let b = self.buffers();
        q.write_buffer(&b.blocks.buffer, 0, bytemuck::cast_slice(&blocks));
        q.write_buffer(&b.corners.buffer, 0, bytemuck::cast_slice(&corners));
        q.write_buffer(&b.materials, 0, bytemuck::cast_slice(&materials));
        self.last_blocks = blocks;
        self.counts.0 = model.blocks.len();
        self.counts.1 = model.corners.len();
        self.uploaded = std::rc::Rc::new(uploaded);
        if self.upload_sdef(model)? {
            self.bind_groups = None;
        }
        if self.upload_fdef(model)? {
            self.bind_groups = None;
        }
        self.upload_contacts(model, adjacency)
    }

    /// Uploads contacts, their gather records and the adjacency (after stage 7 changed them).
    pub(super) fn upload_contacts(&mut self, model: &Model, adjacency: &Adjacency) -> Result<(), GpuError> {
        let _p = crate::profile::scope(crate::profile::Stage::Upload);
        let contacts: Vec<Contact<R>> = model.contacts.par_iter().with_min_len(4096).map(|c| Self::gpu_contact(model, c)).collect();
        let forces: Vec<ContactForce<R>> = model.contacts.par_iter().with_min_len(4096).map(|c| Self::gpu_contact_force(model, c)).collect();
        // Dashpot velocities of an earlier run (with β > 0) still owe their work, booked a step
        // late: the contact stage keeps its dashpot fields live for this list.
        self.dashpots_pending = model.contacts.par_iter().any(|c| c.dashpot_velocity != [0.0, 0.0]);
        self.new_contact_list(model);
        let b = self.buffers.as_mut().expect("buffers exist");
        let d = &self.dev;
        let mut g = Buffers::ensure(d, &mut b.contacts, "contacts", std::mem::size_of::<Contact<R>>(), contacts.len())?;
        g |= Buffers::ensure(d, &mut b.contact_forces, "contact forces", std::mem::size_of::<ContactForce<R>>(), contacts.len())?;
        g |= self.upload_adjacency(&model.blocks, contacts.len(), adjacency)?;
        g |= self.upload_levers(model)?;
        g |= self.upload_shares(model, adjacency)?;
        g |= self.upload_fluid(model)?;
        if g {
            self.bind_groups = None;
        }
        let b = self.buffers();
        let q = &self.dev.queue;
        q.write_buffer(&b.contacts.buffer, 0, bytemuck::cast_slice(&contacts));
        q.write_buffer(&b.contact_forces.buffer, 0, bytemuck::cast_slice(&forces));
        self.counts.2 = contacts.len();
        if self.bind_groups.is_none() {
            self.bind_groups = Some(kernels::CycleBindGroups::new(&self.dev, &self.pipelines, self.buffers()));
        }
        Ok(())
    }

    /// The bookkeeping of a new contact list on the device: the ledger bases of its contacts and
    /// the generation the last good state's CPU copy is compared with.
    pub(super) fn new_contact_list(&mut self, model: &Model) {
        self.bases_from_model(model);
        self.generation += 1;
    }

    /// Every contact's ledger bases from the model: the contact update kept each surviving
    /// contact's ledger terms there (matched by corner and block, with their feature ids).
    pub(super) fn bases_from_model(&mut self, model: &Model) {
        std::rc::Rc::make_mut(&mut self.uploaded).contact_base =
            Arc::new(model.contacts.par_iter().with_min_len(4096).map(|c| [c.slip_work, c.dashpot_work]).collect());
    }

    /// `new_contact_list` after a splice of `edit`, where the kept contacts at `patched` (new
    /// indices; None: all) were read and take their bases from the model: the others keep their
    /// old bases, since the device keeps their dissipation. (Spliced in place, or into a new list
    /// when a checkpoint still shares them: one pass over the bases either way.) An edit that
    /// changed no contact leaves the generation: the last good state's copy of the topology still
    /// holds (a checkpoint's bases are its own).
    pub(super) fn edit_contact_list(&mut self, model: &Model, edit: &ListEdit, patched: Option<&[u32]>) {
        // Stage 7's bookkeeping on the host, in proportion to the list (a splice of 16 bytes a
        // contact): timed with the contact updates (it was "other" in the bench).
        let _p = crate::profile::scope(crate::profile::Stage::DetectUpdate);
        match patched {
            None => self.bases_from_model(model),
            // Every kept contact read (a read-back of them all): the bases are the model's, read
            // in parallel rather than spliced and then patched one by one.
            Some(patched) if patched.len() + edit.inserted_at.len() == model.contacts.len() => self.bases_from_model(model),
            Some(patched) => {
                use crate::udec::topology::detect::{splice, spliced};
                let up = std::rc::Rc::make_mut(&mut self.uploaded);
                let base = |k: u32| [model.contacts[k as usize].slip_work, model.contacts[k as usize].dashpot_work];
                let created = edit.inserted_at.iter().map(|&k| base(k));
                let bases = match Arc::get_mut(&mut up.contact_base) {
                    Some(bases) => {
                        splice(bases, &edit.dropped, &edit.insert_before, created);
                        bases
                    }
                    None => {
                        up.contact_base = Arc::new(spliced(&up.contact_base, &edit.dropped, &edit.insert_before, created));
                        Arc::get_mut(&mut up.contact_base).expect("made above")
                    }
                };
                for &k in patched {
                    bases[k as usize] = base(k);
                }
            }
        }
        self.generation += u64::from(!edit.is_empty());
    }

    /// Uploads the adjacency lists (and makes room for the energy check's sums of the new
    /// counts); returns whether a buffer was re-created (the bind group must then be rebuilt).
    pub(super) fn upload_adjacency(&mut self, blocks: &[crate::udec::model::Block], n_contacts: usize, adjacency: &Adjacency) -> Result<bool, GpuError> {
        let n_blocks = blocks.len();
        let zoned = self.fdef_gp_start.clone();
        let is_zoned = |b: usize| zoned.get(b).is_some_and(|&g| g != super::layout::NO_INDEX);
        // The offsets, then the blocks `gather_heavy` sums (see gather.wgsl): free ones first,
        // then fixed ones, which only the pass before a read-back sums (a base under a wall).
        let mut offsets = adjacency.offsets.clone();
        let heavy = |fixed: bool| {
            adjacency
                .offsets
                .windows(2)
                .enumerate()
                // (A zoned block's grid points sum its contacts: `gather_gridpoints`.)
                .filter(move |(b, w)| w[1] - w[0] > shaders::HEAVY_DEGREE && summed_by_gather_heavy(&blocks[*b], fixed) && !is_zoned(*b))
                .map(|(b, _)| b as u32)
        };
        let free: Vec<u32> = heavy(false).collect();
        self.n_heavy_free = free.len();
        offsets.extend(free);
        offsets.extend(heavy(true));
        self.n_heavy = offsets.len() - adjacency.offsets.len();
        let b = self.buffers.as_mut().expect("buffers exist");
        let d = &self.dev;
        let mut g = Buffers::ensure(d, &mut b.adj_entries, "adjacency entries", 4, adjacency.entries.len())?;
        g |= Buffers::ensure(d, &mut b.adj_offsets, "adjacency offsets", 4, offsets.len())?;
        let items = self.energy_items(n_blocks);
        let b = self.buffers.as_mut().expect("buffers exist");
        let d = &self.dev;
        g |= Buffers::ensure(d, &mut b.energy_sums, "energy sums", std::mem::size_of::<EnergySum<R>>(), kernels::energy_groups(items, n_contacts))?;
        let q = &self.dev.queue;
        q.write_buffer(&b.adj_offsets.buffer, 0, bytemuck::cast_slice(&offsets));
        q.write_buffer(&b.adj_entries.buffer, 0, bytemuck::cast_slice(&adjacency.entries));
        Ok(g)
    }

    /// After a contact update that recorded its edit (the list was in order): the new list is
    /// built on the device from the old one (`splice_contacts.wgsl`) from the edit's runs, the
    /// contacts created and the patches (index, feature) of the kept contacts the CPU read,
    /// instead of an upload of the whole list and its gather records. The kept contacts keep the
    /// device's own state (no round trip through f64). The caller has brought the ledger bases
    /// up to date for the patches (`edit_contact_list`). An edit that changed no contact only
    /// patches the live list: nothing moves, and the adjacency stays as it is on the device.
    pub(super) fn splice_contacts(&mut self, model: &Model, adjacency: &Adjacency, edit: &ListEdit, patches: &[ContactPatch<R>]) -> Result<(), GpuError> {
        use wgpu::util::DeviceExt;
        let _p = crate::profile::scope(crate::profile::Stage::Upload);
        let n = model.contacts.len();
        debug_assert_eq!(edit.new_len() as usize, n);
        let mut created: Vec<Contact<R>> = edit.inserted_at.iter().map(|&i| Self::gpu_contact(model, &model.contacts[i as usize])).collect();
        let mut created_forces: Vec<ContactForce<R>> = edit.inserted_at.iter().map(|&i| Self::gpu_contact_force(model, &model.contacts[i as usize])).collect();
        if created.is_empty() {
            // A binding holds at least one item.
            created.push(Contact::default());
            created_forces.push(ContactForce::default());
        }
        let runs = edit.runs(splice::NEW_CONTACT);
        // (An index past the list patches nothing: the binding's one item when there are none.)
        let no_patch = [ContactPatch { length: R::default(), index: u32::MAX, feature: 0 }];
        let patches = if patches.is_empty() { &no_patch[..] } else { patches };
        let dev = &self.dev;
        let b = self.buffers.as_mut().expect("buffers exist");
        b.ensure_spare::<R>(dev, n)?;
        let init = |label: &str, contents: &[u8]| {
            dev.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage: wgpu::BufferUsages::STORAGE })
        };
        let runs_buffer = init("contact runs", bytemuck::cast_slice(&runs));
        let created_buffer = init("created contacts", bytemuck::cast_slice(&created));
        let created_forces_buffer = init("created contact forces", bytemuck::cast_slice(&created_forces));
        let patches_buffer = init("contact patches", bytemuck::cast_slice(patches));
        let (spare, spare_forces) = b.spare_contacts.as_ref().expect("made above");
        let (live, live_forces) = (&b.contacts.buffer, &b.contact_forces.buffer);
        let (spare, spare_forces) = (&spare.buffer, &spare_forces.buffer);
        let moves = !edit.is_empty();
        // Old list → new list; or, with nothing to move, the patches on the live list (the spare
        // bound as the unused old one).
        let (old, old_forces, new, new_forces) = if moves { (live, live_forces, spare, spare_forces) } else { (spare, spare_forces, live, live_forces) };
        let entries = kernels::whole_bindings(&[old, old_forces, &runs_buffer, &created_buffer, &created_forces_buffer, new, new_forces, &patches_buffer]);
        let p = &self.pipelines;
        kernels::dispatch_passes(
            dev,
            "splice_contacts",
            &[(&p.splice_contacts, if moves { n } else { 0 }), (&p.patch_contacts, patches.len())],
            &p.splice_layout,
            &entries,
        )?;
        self.splices += 1;
        if !moves {
            return Ok(());
        }
        b.swap_contacts();
        self.counts.2 = n;
        self.splice_levers(model, &edit.inserted_at, &runs, splice::NEW_CONTACT)?;
        let on_device = match self.adjacency_edits {
            AdjacencyEdits::Auto => !self.dev.summary.is_software(),
            AdjacencyEdits::Always => true,
            AdjacencyEdits::Never => false,
        };
        if on_device && self.edit_adjacency(&model.blocks, adjacency, edit)? {
            self.adjacency_edit_count += 1;
        } else {
            self.upload_adjacency(&model.blocks, n, adjacency)?;
        }
        self.bind_groups = Some(kernels::CycleBindGroups::new(&self.dev, &self.pipelines, self.buffers()));
        Ok(())
    }

    /// The adjacency lists on the device take the update's edit (`splice_adjacency.wgsl`): the
    /// touched blocks' new lists, the renumbering and the offsets' shifts, in proportion to the
    /// changes, where `upload_adjacency` sends the lists whole (4 bytes an entry). The blocks
    /// `gather_heavy` sums are listed again only when a touched block crossed `HEAVY_DEGREE`.
    /// Returns false, having changed nothing, when the lists were rebuilt rather than edited or
    /// the heavy blocks outgrow their room: the caller uploads the lists whole.
    pub(super) fn edit_adjacency(&mut self, blocks: &[crate::udec::model::Block], adjacency: &Adjacency, edit: &ListEdit) -> Result<bool, GpuError> {
        use wgpu::util::DeviceExt;
        let Some(entries) = edit.entries.as_ref() else { return Ok(false) };
        let n_blocks = blocks.len();
        let n_entries = adjacency.entries.len();
        if adjacency.offsets.len() != n_blocks + 1 || entries.runs.last().map(|r| r[0] as usize) != Some(n_entries) {
            return Ok(false);
        }
        // Whether a touched block crossed HEAVY_DEGREE (its degree before: now less its change).
        let heavy = |degree: i64| degree > shaders::HEAVY_DEGREE as i64;
        let crossed = entries.touched.iter().enumerate().any(|(j, &t)| {
            let now = (adjacency.offsets[t as usize + 1] - adjacency.offsets[t as usize]) as i64;
            let change = entries.shift_after[j] - if j == 0 { 0 } else { entries.shift_after[j - 1] };
            heavy(now) != heavy(now - change)
        });
        let heavy_list: Option<(Vec<u32>, usize)> = crossed.then(|| {
            let list = |fixed: bool| {
                adjacency
                    .offsets
                    .windows(2)
                    .enumerate()
                    .filter(move |(b, w)| heavy((w[1] - w[0]) as i64) && summed_by_gather_heavy(&blocks[*b], fixed))
                    .map(|(b, _)| b as u32)
            };
            let free: Vec<u32> = list(false).collect();
            let n_free = free.len();
            (free.into_iter().chain(list(true)).collect(), n_free)
        });
        let b = self.buffers.as_mut().expect("buffers exist");
        if heavy_list.as_ref().is_some_and(|(h, _)| n_blocks + 1 + h.len() > b.adj_offsets.capacity) {
            return Ok(false);
        }
        let dev = &self.dev;
        b.ensure_spare_entries(dev, n_entries.max(1))?;
        Buffers::ensure(
            dev,
            &mut b.energy_sums,
            "energy sums",
            std::mem::size_of::<EnergySum<R>>(),
            kernels::energy_groups(n_blocks, edit.new_len() as usize),
        )?;
        let init = |label: &str, contents: &[u8]| {
            dev.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage: wgpu::BufferUsages::STORAGE })
        };
        // (A binding holds at least one item.)
        let one = [AdjacencyEntry::default()];
        let lists: &[AdjacencyEntry] = if entries.lists.is_empty() { &one } else { &entries.lists };
        let touched = splice::touched_shifts(entries, n_blocks + 1);
        let runs_buffer = init("adjacency runs", bytemuck::cast_slice(&entries.runs));
        let lists_buffer = init("adjacency lists", bytemuck::cast_slice(lists));
        let renumber_buffer = init("contact renumbering", bytemuck::cast_slice(&splice::renumber_table(edit)));
        let touched_buffer = init("touched lists", bytemuck::cast_slice(&touched));
        let spare = b.spare_entries.as_ref().expect("made above");
        let bindings = kernels::whole_bindings(&[
            &b.adj_entries.buffer,
            &runs_buffer,
            &lists_buffer,
            &renumber_buffer,
            &spare.buffer,
            &b.adj_offsets.buffer,
            &touched_buffer,
        ]);
        let p = &self.pipelines;
        kernels::dispatch_passes(
            dev,
            "splice_adjacency",
            &[(&p.splice_adjacency, n_entries), (&p.shift_offsets, n_blocks + 1)],
            &p.adjacency_layout,
            &bindings,
        )?;
        b.swap_entries();
        if let Some((list, n_free)) = heavy_list {
            dev.queue.write_buffer(&b.adj_offsets.buffer, ((n_blocks + 1) * 4) as u64, bytemuck::cast_slice(&list));
            self.n_heavy = list.len();
            self.n_heavy_free = n_free;
        }
        Ok(true)
    }

    pub(super) fn write_params(&self, model: &Model) {
        let t = model.tol;
        let params = Params::<R> {
            dt: r(model.timestep),
            alpha: r(model.damping.alpha),
            beta: r(model.damping.beta),
            gx: r(model.gravity[0]),
            gy: r(model.gravity[1]),
            etol: r(t.etol),
            fast_limit: r(0.5 * t.atol - t.etol),
            overlap_limit: r(0.5 * t.round),
            alpha_internal: r(model.damping.alpha_internal),
            n_blocks: self.counts.0 as u32,
            n_corners: self.counts.1 as u32,
            n_contacts: self.counts.2 as u32,
            one: 1,
            n_heavy: self.heavy_blocks(false) as u32,
            dashpots: (model.damping.beta > 0.0 || self.dashpots_pending) as u32,
        };
        self.dev.queue.write_buffer(&self.buffers().params, 0, bytemuck::bytes_of(&params));
    }

    /// Writes a contact update's reset of block `b` (`Block::update_reset`) to the device.
    pub(super) fn write_update_reset(&self, b: usize, fields: &[R; 7]) {
        let at = (b * std::mem::size_of::<Block<R>>() + Block::<R>::UPDATE_RESET_OFFSET) as u64;
        self.dev.queue.write_buffer(&self.buffers().blocks.buffer, at, bytemuck::cast_slice(fields));
    }

    /// After stage 7: the blocks it re-examined get their update distance reset, their
    /// reference set to where they are now and their new speed margin (one contiguous write of
    /// seven fields each, the reference copied from the GPU's own values so that it is exact).
    ///
    /// `last_blocks` is the device's block state as just read back (no cycle ran since), so
    /// when many blocks were re-examined (a busy impact) the whole block buffer is written in one
    /// go with their fields reset, instead of one small write per block.
    pub(super) fn upload_reset_distances(&mut self, model: &Model) {
        let _p = crate::profile::scope(crate::profile::Stage::Upload);
        let reset: Vec<usize> = model
            .blocks
            .iter()
            .zip(&self.last_blocks)
            .enumerate()
            .filter(|(_, (m, g))| m.moved_since_update == 0.0 && g.update_fields() != g.update_reset(R::from_f64(m.update_margin)))
            .map(|(i, _)| i)
            .collect();
        let whole = reset.len() * 8 > self.last_blocks.len();
        for &i in &reset {
            let fields = self.last_blocks[i].update_reset(R::from_f64(model.blocks[i].update_margin));
            self.last_blocks[i].set_update_reset(fields);
            if !whole {
                self.write_update_reset(i, &fields);
            }
        }
        if whole {
            self.dev.queue.write_buffer(&self.buffers().blocks.buffer, 0, bytemuck::cast_slice(&self.last_blocks));
        }
        self.reset_update_strains(&reset);
        self.reset_update_positions(&reset);
    }
}

impl<R: Real> Block<R> {
    /// A model block as the device holds it: the centroid (and the update reference) relative to
    /// the run's `origin` as compensated pairs, the rotation split as the kernels keep it
    /// (`split_rotation`), the step's work accumulators from zero.
    pub fn from_model(b: &crate::udec::model::Block, origin: [f64; 2]) -> Self {
        let (x, y) = (b.centroid[0] - origin[0], b.centroid[1] - origin[1]);
        let (hx, hy) = (r::<R>(x), r::<R>(y));
        let (x0, y0) = (b.update_centroid[0] - origin[0], b.update_centroid[1] - origin[1]);
        let (ux, uy) = (r::<R>(x0), r::<R>(y0));
        let (placed, turn) = split_rotation(b.rotation, R::PRECISION);
        Block {
            cx: hx,
            cy: hy,
            cx_lo: r(x - hx.to_f64()),
            cy_lo: r(y - hy.to_f64()),
            rotation: r(placed),
            rotation_lo: r(turn),
            vx: r(b.velocity[0]),
            vy: r(b.velocity[1]),
            w: r(b.angular_velocity),
            fx: r(b.force[0]),
            fy: r(b.force[1]),
            moment: r(b.moment),
            mass: r(b.mass),
            inertia: r(b.inertia),
            load_x: r(b.load[0]),
            load_y: r(b.load[1]),
            radius: r(b.radius),
            work: R::default(),
            damping_work: R::default(),
            moved: r(b.moved_since_update),
            update_cx: ux,
            update_cy: uy,
            update_cx_lo: r(x0 - ux.to_f64()),
            update_cy_lo: r(y0 - uy.to_f64()),
            update_rotation: r(b.update_rotation),
            update_margin: r(b.update_margin),
            fixed: b.fixed as u32,
            corner_start: b.corner_start,
            corner_count: b.corner_count,
            kind: if b.kind == crate::udec::model::BlockKind::SimplyDeformable { super::layout::BLOCK_SDEF } else { super::layout::BLOCK_RIGID },
        }
    }
}

impl<R: Real> Corner<R> {
    /// A model corner as the device holds it, relative to its block's centroid: placed at the
    /// block's placed angle (f32; a simply-deformable block's strained) or where the model has it
    /// (f64).
    pub fn from_model(blocks: &[crate::udec::model::Block], c: &crate::udec::model::Corner) -> Self {
        let blk = &blocks[c.block as usize];
        let cen = blk.centroid;
        let (placed, turn) = split_rotation(blk.rotation, R::PRECISION);
        let (p, o) = if turn == 0.0 && placed == blk.rotation {
            ([c.position[0] - cen[0], c.position[1] - cen[1]], [c.circle[0] - cen[0], c.circle[1] - cen[1]])
        } else if blk.kind == crate::udec::model::BlockKind::SimplyDeformable {
            // Strained: the model's corners turned back by the turn since the placed angle
            // (the kernel places them again, strained, at every step).
            let (sin, cos) = (-turn).sin_cos();
            let at = |x: [f64; 2]| {
                let d = [x[0] - cen[0], x[1] - cen[1]];
                [cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]]
            };
            (at(c.position), at(c.circle))
        } else {
            let (sin, cos) = placed.sin_cos();
            let at = |x: [f64; 2]| [cos * x[0] - sin * x[1], sin * x[0] + cos * x[1]];
            (at(c.local), at(c.circle_local))
        };
        Corner {
            lx: r(c.local[0]),
            ly: r(c.local[1]),
            qx: r(c.circle_local[0]),
            qy: r(c.circle_local[1]),
            radius: r(c.radius),
            round: r(c.round),
            px: r(p[0]),
            py: r(p[1]),
            ox: r(o[0]),
            oy: r(o[1]),
        }
    }
}

/// Whether `gather_heavy` sums block `b` when its list is long, in the part of its list for fixed
/// or free blocks: a rigid block. A simply-deformable block sums its force and applied stress
/// itself, in list order, whatever its list's length (`law_of_motion_sdef`, `gather_sdef`), so a
/// workgroup's sum of its force would be done twice and never read.
fn summed_by_gather_heavy(b: &crate::udec::model::Block, fixed: bool) -> bool {
    b.fixed == fixed && b.kind != crate::udec::model::BlockKind::SimplyDeformable
}
