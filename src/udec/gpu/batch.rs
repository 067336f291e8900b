//! Batches of cycles on the device with no round trip inside one: the dispatches of a cycle
//! (`law_of_motion`, which sums the block forces of the last cycle first, `contact_forces`,
//! `end_cycle`; `gather_heavy` first where a free block has a long list) over grids that follow
//! the live counts, encoded ten cycles a submission; then the flags (and, when asked, the state)
//! read back in one round trip. The energy check's sums are taken on the device too
//! (`energy_sums.wgsl`).

use crate::udec::model::Model;

use super::kernels::{self, Grid};
use super::layout::{Block, Corner, EnergySum, Flags, GridPoint, Params, Real, Sdef};
use super::readback::pod_view;
use super::{shaders, Engine, GpuError};

/// One dispatch of a cycle: the stage's label, its pipeline, its bind group and its
/// two-dimensional grid over the live counts; `indirect`: the grid in `Buffers::dispatch_args`
/// that a batch launches it with (None for `end_cycle`, launched directly).
pub(crate) struct Dispatch<'a> {
    pub label: &'static str,
    pub pipeline: &'a wgpu::ComputePipeline,
    pub bind_group: &'a wgpu::BindGroup,
    pub grid: (u32, u32),
    pub indirect: Option<Grid>,
}

/// Cycles encoded per submission inside a batch: the GPU starts on the first ones while the CPU
/// encodes the rest.
pub(super) const CYCLES_PER_SUBMIT: u64 = 10;

impl<R: Real> Engine<R> {
    /// One pass of a cycle (or of a gather before a read-back) over `g`'s live count, dispatched
    /// indirectly from it.
    fn pass<'a>(
        &'a self,
        label: &'static str,
        pipeline: &'a wgpu::ComputePipeline,
        bind_group: &'a wgpu::BindGroup,
        g: Grid,
        gather_only: bool,
    ) -> Dispatch<'a> {
        Dispatch { label, pipeline, bind_group, grid: self.grid(g, gather_only), indirect: Some(g) }
    }

    /// `gather_heavy` where there are blocks with long lists to sum (free ones in a cycle, fixed
    /// ones too before a read-back).
    fn gather_heavy_pass(&self, gather_only: bool) -> Option<Dispatch<'_>> {
        let (p, bg) = (&self.pipelines, self.bind_groups.as_ref().expect("bind groups built on upload"));
        (self.heavy_blocks(gather_only) > 0).then(|| self.pass("gather_heavy", &p.gather_heavy.pipeline, &bg.gather_heavy, Grid::HeavyBlocks, gather_only))
    }

    /// The cycle's last pass: the step's flags and counts (`end_cycle.wgsl`), one invocation.
    fn end_cycle_pass(&self) -> Dispatch<'_> {
        let end = self.end_cycle_bind_group.as_ref().expect("made with the buffers");
        Dispatch { label: "end_cycle", pipeline: &self.pipelines.end_cycle, bind_group: end, grid: (1, 1), indirect: None }
    }

    /// Stage 5 after the contact stage: each contact's flow, the terms of the long domains' sums
    /// (none where there are no such domains: the pass is left out), then each domain's pressure.
    fn stage_5_passes<'a>(&'a self, k: &'a kernels::FluidKernels, g: &'a kernels::FluidBindGroups) -> [Dispatch<'a>; 3] {
        [
            self.pass("flow", &k.contact_flows.pipeline, &g.contact_flows, Grid::Contacts, false),
            self.pass("domain_terms", &k.domain_terms.pipeline, &g.domain_terms, Grid::DomainTerms, false),
            self.pass("domain_pressures", &k.domain_pressures.pipeline, &g.domain_pressures, Grid::Domains, false),
        ]
    }

    /// `stage_5_passes` with deformable blocks: in f32, before the pressures, each corner's move
    /// in this step (`corner_moves_sdef` or `_fdef`) and the terms of the deformed voids' changes
    /// (`deformed_terms`), by which `domain_pressures` follows those voids.
    fn wet_stage_5_passes<'a>(
        &'a self,
        (k, g): (&'a kernels::FluidKernels, &'a kernels::FluidBindGroups),
        moves: (&'a kernels::CycleKernel, &'a wgpu::BindGroup),
        terms: (&'a kernels::CycleKernel, &'a wgpu::BindGroup),
    ) -> Vec<Dispatch<'a>> {
        let [flow, domain_terms, pressures] = self.stage_5_passes(k, g);
        let mut passes = vec![flow, domain_terms];
        if self.dev.precision == crate::gpu::Precision::F32 {
            passes.push(self.pass("corner_moves", &moves.0.pipeline, moves.1, Grid::Blocks, false));
            passes.push(self.pass("deformed_terms", &terms.0.pipeline, terms.1, Grid::DomainTerms, false));
        }
        passes.push(pressures);
        passes
    }

    /// The dispatches of one cycle over the live counts; with `gather_only`, stage 6 alone, its
    /// sums stored on the blocks (fixed ones too). Stages with nothing to do are left out.
    ///
    /// A cycle runs stage 6 of the last cycle inside `law_of_motion`, as the CPU does (one pass
    /// over the blocks, the sums never stored), after `gather_heavy` has summed and stored the
    /// long lists of free blocks.
    pub(crate) fn stages(&self, gather_only: bool) -> Vec<Dispatch<'_>> {
        let p = &self.pipelines;
        let bg = self.bind_groups.as_ref().expect("bind groups built on upload");
        let cycle = |label, pipeline, bind_group, g: Grid| self.pass(label, pipeline, bind_group, g, gather_only);
        let mut stages = Vec::with_capacity(4);
        if let (Some(fdef), Some(fluid), Some(wet)) = (self.fdef_kernels(), self.fluid_kernels(), self.wet_fdef_kernels()) {
            return self.stages_fdef_fluid(fdef, fluid, wet, gather_only);
        }
        if let (Some(sdef), Some(fluid), Some(wet)) = (self.sdef_kernels(), self.fluid_kernels(), self.wet_sdef_kernels()) {
            return self.stages_sdef_fluid(sdef, fluid, wet, gather_only);
        }
        if let Some((k, g)) = self.fdef_kernels() {
            return self.stages_fdef(k, g, gather_only);
        }
        if let Some((k, g)) = self.fluid_kernels() {
            return self.stages_fluid(k, g, gather_only);
        }
        if gather_only {
            match self.sdef_kernels() {
                Some((k, g)) => stages.push(cycle("gather_sdef", &k.gather.pipeline, &g.gather, Grid::Blocks)),
                None => stages.push(cycle("gather", &p.gather.pipeline, &bg.gather, Grid::Blocks)),
            }
        }
        stages.extend(self.gather_heavy_pass(gather_only));
        if !gather_only {
            match self.sdef_kernels() {
                Some((k, g)) => {
                    stages.push(cycle("law_of_motion_sdef", &k.law_of_motion.pipeline, &g.law_of_motion, Grid::Blocks));
                    stages.push(cycle("contact_forces_sdef", &k.contact_forces.pipeline, &g.contact_forces, Grid::Contacts));
                }
                None => {
                    stages.push(cycle("law_of_motion", &p.law_of_motion.pipeline, &bg.law_of_motion, Grid::Blocks));
                    stages.push(cycle("contact_forces", &p.contact_forces.pipeline, &bg.contact_forces, Grid::Contacts));
                }
            }
            stages.push(self.end_cycle_pass());
        }
        stages.retain(|d| d.grid.0 > 0);
        stages
    }

    /// `stages` in a scene with zoned fully-deformable blocks (`gpu::fdef`): the gather of the
    /// rigid blocks (before a read-back) and of the grid points, then in a cycle the grid
    /// points' step, the zones' stresses, the blocks' motion (a zoned block's corners placed on
    /// its grid points), the corners of the zoned blocks of many (a workgroup per block), the
    /// check of the grid points' contact lists against the features and the contact stage, each a pass of its own: no invocation reads what
    /// another of its pass writes.
    fn stages_fdef<'a>(&'a self, k: &'a kernels::FdefKernels, g: &'a kernels::FdefBindGroups, gather_only: bool) -> Vec<Dispatch<'a>> {
        let cycle = |label, pipeline, bind_group, g: Grid| self.pass(label, pipeline, bind_group, g, gather_only);
        let mut stages = Vec::with_capacity(7);
        if gather_only {
            stages.push(cycle("gather_fdef", &k.gather.pipeline, &g.gather, Grid::Blocks));
        }
        stages.extend(self.gather_heavy_pass(gather_only));
        stages.push(cycle("gather_gridpoints", &k.gather_gridpoints.pipeline, &g.gather_gridpoints, Grid::GridPoints));
        if !gather_only {
            stages.push(cycle("step_gridpoints", &k.step_gridpoints.pipeline, &g.step_gridpoints, Grid::GridPoints));
            stages.push(cycle("zones", &k.zones.pipeline, &g.zones, Grid::Zones));
            stages.push(cycle("law_of_motion_fdef", &k.law_of_motion.pipeline, &g.law_of_motion, Grid::Blocks));
            stages.push(cycle("place_fdef_corners", &k.place_corners.pipeline, &g.place_corners, Grid::BlockGroups));
            stages.push(cycle("check_fdef_lists", &k.check_lists.pipeline, &g.check_lists, Grid::Contacts));
            stages.push(cycle("contact_forces_fdef", &k.contact_forces.pipeline, &g.contact_forces, Grid::Contacts));
            stages.push(self.end_cycle_pass());
        }
        stages.retain(|d| d.grid.0 > 0);
        stages
    }

    /// `stages` in a scene with fluid (`gpu::flow`): the blocks with long lists summed first
    /// (`gather_heavy`), then the blocks' gather with their fluid loads (before a read-back) or
    /// in a cycle their motion with it (`law_of_motion_fluid`, which sums the loads of the last
    /// stage 5's pressures with the contact forces), the contact stage, and stage 5: each
    /// contact's flow, then each domain's pressure, each a pass of its own.
    fn stages_fluid<'a>(&'a self, k: &'a kernels::FluidKernels, g: &'a kernels::FluidBindGroups, gather_only: bool) -> Vec<Dispatch<'a>> {
        let p = &self.pipelines;
        let bg = self.bind_groups.as_ref().expect("bind groups built on upload");
        let cycle = |label, pipeline, bind_group, g: Grid| self.pass(label, pipeline, bind_group, g, gather_only);
        let mut stages = Vec::with_capacity(7);
        stages.extend(self.gather_heavy_pass(gather_only));
        if gather_only {
            stages.push(cycle("gather_fluid", &k.gather.pipeline, &g.gather, Grid::Blocks));
        } else {
            stages.push(cycle("law_of_motion_fluid", &k.law_of_motion.pipeline, &g.law_of_motion, Grid::Blocks));
            stages.push(cycle("contact_forces", &p.contact_forces.pipeline, &bg.contact_forces, Grid::Contacts));
            stages.extend(self.stage_5_passes(k, g));
            stages.push(self.end_cycle_pass());
        }
        stages.retain(|d| d.grid.0 > 0);
        stages
    }

    /// `stages` in a scene with fluid and simply-deformable blocks (`gpu::flow`): the blocks'
    /// contact sums stored (`gather_heavy`, `gather_sdef`), the pieces of block boundary around
    /// each domain at its pressure (`pressure_pieces`) and each block's fluid load from them
    /// (`fluid_block_loads`), all from the state the last cycle left as the CPU's stage 5 took
    /// it; then before a read-back those added to the stored sums (`gather_sdef_fluid`), or in a
    /// cycle the blocks' motion on them (`law_of_motion_sdef_fluid`), the contact stage and
    /// stage 5's flows and pressures.
    fn stages_sdef_fluid<'a>(
        &'a self,
        sdef: (&'a kernels::SdefKernels, &'a kernels::SdefBindGroups),
        fluid: (&'a kernels::FluidKernels, &'a kernels::FluidBindGroups),
        wet: (&'a kernels::WetSdefKernels, &'a kernels::WetSdefBindGroups),
        gather_only: bool,
    ) -> Vec<Dispatch<'a>> {
        let cycle = |label, pipeline, bind_group, g: Grid| self.pass(label, pipeline, bind_group, g, gather_only);
        let ((sk, sg), (fk, fg), (wk, wg)) = (sdef, fluid, wet);
        let mut stages = Vec::with_capacity(9);
        stages.extend(self.gather_heavy_pass(gather_only));
        stages.push(cycle("gather_sdef", &sk.gather.pipeline, &sg.gather, Grid::Blocks));
        stages.push(cycle("pressure_pieces", &wk.pressure_pieces.pipeline, &wg.pressure_pieces, Grid::Domains));
        stages.push(cycle("fluid_block_loads", &wk.fluid_block_loads.pipeline, &wg.fluid_block_loads, Grid::Blocks));
        if gather_only {
            stages.push(cycle("gather_sdef_fluid", &wk.gather.pipeline, &wg.gather, Grid::Blocks));
        } else {
            stages.push(cycle("law_of_motion_sdef_fluid", &wk.law_of_motion.pipeline, &wg.law_of_motion, Grid::Blocks));
            stages.push(cycle("contact_forces_sdef", &sk.contact_forces.pipeline, &sg.contact_forces, Grid::Contacts));
            stages.extend(self.wet_stage_5_passes((fk, fg), (&wk.corner_moves, &wg.corner_moves), (&wk.deformed_terms, &wg.deformed_terms)));
            stages.push(self.end_cycle_pass());
        }
        stages.retain(|d| d.grid.0 > 0);
        stages
    }

    /// `stages` in a scene with fluid and zoned blocks (`gpu::flow`): the rigid blocks' contact
    /// sums stored (`gather_heavy`, `gather_fdef`), the pieces of block boundary around each
    /// domain (`pressure_pieces`), each block's fluid load (`fluid_block_loads`) and each zoned
    /// block's grid points' (`gridpoint_fluid_loads`), the grid points' gather with theirs;
    /// then before a read-back the rigid blocks' loads added to their stored sums
    /// (`gather_fdef_fluid`), or in a cycle the grid points' step with their fluid work, the
    /// zones, the blocks' motion (`law_of_motion_fdef_fluid`), the contact stage and stage 5.
    fn stages_fdef_fluid<'a>(
        &'a self,
        fdef: (&'a kernels::FdefKernels, &'a kernels::FdefBindGroups),
        fluid: (&'a kernels::FluidKernels, &'a kernels::FluidBindGroups),
        wet: (&'a kernels::WetFdefKernels, &'a kernels::WetFdefBindGroups),
        gather_only: bool,
    ) -> Vec<Dispatch<'a>> {
        let cycle = |label, pipeline, bind_group, g: Grid| self.pass(label, pipeline, bind_group, g, gather_only);
        let ((dk, dg), (fk, fg), (wk, wg)) = (fdef, fluid, wet);
        let mut stages = Vec::with_capacity(13);
        stages.extend(self.gather_heavy_pass(gather_only));
        stages.push(cycle("gather_fdef", &dk.gather.pipeline, &dg.gather, Grid::Blocks));
        stages.push(cycle("pressure_pieces", &wk.pressure_pieces.pipeline, &wg.pressure_pieces, Grid::Domains));
        stages.push(cycle("fluid_block_loads", &wk.fluid_block_loads.pipeline, &wg.fluid_block_loads, Grid::Blocks));
        stages.push(cycle("gridpoint_fluid_loads", &wk.gridpoint_fluid_loads.pipeline, &wg.gridpoint_fluid_loads, Grid::Blocks));
        stages.push(cycle("gather_gridpoints_fluid", &wk.gather_gridpoints.pipeline, &wg.gather_gridpoints, Grid::GridPoints));
        if gather_only {
            stages.push(cycle("gather_fdef_fluid", &wk.gather.pipeline, &wg.gather, Grid::Blocks));
        } else {
            stages.push(cycle("step_gridpoints_fluid", &wk.step_gridpoints.pipeline, &wg.step_gridpoints, Grid::GridPoints));
            stages.push(cycle("zones", &dk.zones.pipeline, &dg.zones, Grid::Zones));
            stages.push(cycle("law_of_motion_fdef_fluid", &wk.law_of_motion.pipeline, &wg.law_of_motion, Grid::Blocks));
            stages.push(cycle("contact_forces_fdef", &dk.contact_forces.pipeline, &dg.contact_forces, Grid::Contacts));
            stages.extend(self.wet_stage_5_passes((fk, fg), (&wk.corner_moves, &wg.corner_moves), (&wk.deformed_terms, &wg.deformed_terms)));
            stages.push(self.end_cycle_pass());
        }
        stages.retain(|d| d.grid.0 > 0);
        stages
    }

    /// The grid of `g` over the live counts: one invocation per block or contact, one workgroup
    /// per heavy block the pass gathers.
    pub(super) fn grid(&self, g: Grid, gather_only: bool) -> (u32, u32) {
        let items = |n: usize| shaders::dispatch_grid((n as u32).div_ceil(shaders::workgroup_size()));
        match g {
            Grid::Blocks => items(self.counts.0),
            Grid::Contacts => items(self.counts.2),
            Grid::HeavyBlocks => shaders::dispatch_grid(self.heavy_blocks(gather_only) as u32),
            Grid::GridPoints => items(self.fdef_counts.0),
            Grid::Zones => items(self.fdef_counts.1),
            Grid::Domains => items(self.n_domains),
            Grid::BlockGroups => shaders::dispatch_grid(self.fdef_wide as u32),
            Grid::DomainTerms => items(self.n_term_items),
        }
    }

    /// Heavy blocks a pass gathers: the free ones in a cycle, all (fixed ones too) in the pass
    /// before a read-back.
    pub(super) fn heavy_blocks(&self, gather_only: bool) -> usize {
        if gather_only {
            self.n_heavy
        } else {
            self.n_heavy_free
        }
    }

    /// The run constant that differs between a cycle and a gather-only pass: how many heavy
    /// blocks `gather_heavy` sums, the free ones or all (queued; the pass's dispatches follow).
    pub(crate) fn write_pass_params(&self, gather_only: bool) {
        let (b, q) = (self.buffers(), &self.dev.queue);
        q.write_buffer(&b.params, std::mem::offset_of!(Params<R>, n_heavy) as u64, bytemuck::bytes_of(&(self.heavy_blocks(gather_only) as u32)));
    }

    /// Runs `cycles` cycles (or fewer, if a kernel raises a flag) with no round trip; returns the
    /// flags. With `gather_only`, runs stage 6 alone over every block, fixed ones too, and stores
    /// the sums (before a read-back or the energy check). Each submission holds one compute
    /// pass of `CYCLES_PER_SUBMIT` cycles (wgpu orders the dispatches inside it), with a debug
    /// group per stage so that tools and errors name it.
    pub(super) fn run_batch(&self, cycles: u64, gather_only: bool) -> Result<Flags, GpuError> {
        let _p = crate::profile::scope(crate::profile::Stage::GpuBatches);
        self.submit_batch(cycles, gather_only)?;
        if gather_only {
            // Nothing raises a flag in a gather; the next wait covers it.
            return Ok(Flags::cleared());
        }
        let b = self.buffers();
        let bytes = self.dev.read_buffer(&b.flags, std::mem::size_of::<Flags>() as u64)?;
        Ok(bytemuck::pod_read_unaligned(&bytes))
    }

    /// Submits the passes of `run_batch` without waiting for them.
    pub(super) fn submit_batch(&self, cycles: u64, gather_only: bool) -> Result<(), GpuError> {
        let b = self.buffers();
        let q = &self.dev.queue;
        q.write_buffer(&b.flags, 0, bytemuck::bytes_of(&Flags::cleared()));
        // The grids of the indirect dispatches, which end_cycle zeroes when it halts the batch.
        let args: Vec<u32> = Grid::ALL
            .iter()
            .flat_map(|&g| {
                let (x, y) = self.grid(g, gather_only);
                [x, y, 1]
            })
            .collect();
        q.write_buffer(&b.dispatch_args, 0, bytemuck::cast_slice(&args));
        self.write_pass_params(gather_only);
        let stages = self.stages(gather_only);
        let scope = self.dev.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut left = cycles.max(1);
        while left > 0 {
            let n = left.min(CYCLES_PER_SUBMIT);
            left -= n;
            let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("cycles") });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("cycles"), timestamp_writes: None });
                // The bind group changes only around end_cycle's own: set it when it changes.
                let mut bound: Option<&wgpu::BindGroup> = None;
                for _ in 0..n {
                    for d in &stages {
                        pass.push_debug_group(d.label);
                        pass.set_pipeline(d.pipeline);
                        if !bound.is_some_and(|g| std::ptr::eq(g, d.bind_group)) {
                            pass.set_bind_group(0, d.bind_group, &[]);
                            bound = Some(d.bind_group);
                        }
                        match d.indirect {
                            Some(g) => pass.dispatch_workgroups_indirect(&b.dispatch_args, g.offset()),
                            None => pass.dispatch_workgroups(d.grid.0, d.grid.1, 1),
                        }
                        pass.pop_debug_group();
                    }
                }
            }
            q.submit([enc.finish()]);
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Device(format!("a cycle was rejected: {e}")));
        }
        Ok(())
    }

    /// Runs a batch and reads back its flags together with the whole state, in one round trip;
    /// the state goes into the model only when stage 7 is due. For runs whose contacts change
    /// every few cycles (a projectile), where a batch that stops for a contact update would
    /// otherwise cost a second round trip for the state. Returns the flags and whether the model
    /// now holds the state.
    ///
    /// `packed`: the contacts come back as `ContactSummary` records (`pack_contacts`), not whole.
    pub(super) fn run_batch_with_state(&mut self, cycles: u64, model: &mut Model, packed: bool) -> Result<(Flags, bool), GpuError> {
        let _p = crate::profile::scope(crate::profile::Stage::GpuBatches);
        self.submit_batch(cycles, false)?;
        if packed {
            self.pack_contacts()?;
        } else {
            self.place_contact_points()?;
        }
        let (nb, nc, _) = self.counts;
        let b = self.buffers();
        let [contacts, forces] = self.contacts_parts(packed);
        let parts = [
            (&b.flags, std::mem::size_of::<Flags>() as u64),
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
        let up = self.uploaded.clone();
        let (flags, blocks) = self.dev.read_parts(&parts, |bytes| {
            let flags: Flags = bytemuck::pod_read_unaligned(bytes[0]);
            if flags.update_due == 0 || flags.errors != 0 {
                return (flags, None);
            }
            let _p = crate::profile::scope(crate::profile::Stage::Download);
            let blocks: Vec<Block<R>> = bytemuck::pod_collect_to_vec(bytes[1]);
            Self::convert_blocks_and_corners(&blocks, &pod_view(bytes[2]), &up, model);
            Self::convert_contacts_read(&bytes[3..5], packed, &up, model);
            let sdefs: Vec<Sdef<R>> = bytemuck::pod_collect_to_vec(bytes[5]);
            Self::convert_sdefs(&sdefs, &up, model);
            let gridpoints: Vec<GridPoint<R>> = bytemuck::pod_collect_to_vec(bytes[6]);
            Self::convert_fdef(&gridpoints, &pod_view(bytes[7]), &up, model);
            Self::convert_fluid(&pod_view(bytes[8]), &pod_view(bytes[9]), &pod_view(bytes[10]), &up, model);
            (flags, Some((blocks, sdefs, gridpoints)))
        })?;
        let read = blocks.is_some();
        if let Some((blocks, sdefs, gridpoints)) = blocks {
            self.last_blocks = blocks;
            self.last_sdefs = sdefs;
            self.last_gridpoints = gridpoints;
        }
        Ok((flags, read))
    }

    /// The energy check's sums on the device: (kinetic, strain, external work) of the state now,
    /// the per-workgroup sums read back and added in order in f64. The kinetic energy at time t
    /// takes half a step of the forces the contact stage left, which the cycle has not summed
    /// yet: a gather pass stores them first.
    pub(super) fn energy_sums(&self) -> Result<(f64, f64, f64), GpuError> {
        let Some(b) = self.buffers.as_ref() else {
            return Err(GpuError::Setup("no state on the device: run some cycles first".into()));
        };
        self.submit_batch(1, true)?;
        let bg = &self.bind_groups.as_ref().expect("bind groups built on upload").energy_sums;
        let (x, y) = kernels::energy_grid(self.energy_items(self.counts.0), self.counts.2);
        let groups = (x * y) as usize;
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("energy check") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("energy_sums"), timestamp_writes: None });
            pass.set_pipeline(&self.pipelines.energy_sums.pipeline);
            pass.set_bind_group(0, bg, &[]);
            pass.dispatch_workgroups(x, y, 1);
            // Simply-deformable blocks add their strain modes to each workgroup's sum.
            if let Some((k, g)) = self.sdef_kernels() {
                pass.set_pipeline(&k.energy_sums.pipeline);
                pass.set_bind_group(0, &g.energy_sums, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
            // Zoned blocks add their grid points' motion and zones' strain.
            if let Some((k, g)) = self.fdef_kernels() {
                pass.set_pipeline(&k.energy_sums.pipeline);
                pass.set_bind_group(0, &g.energy_sums, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
            // The fluid adds its loads' work.
            if let Some((k, g)) = self.fluid_kernels() {
                pass.set_pipeline(&k.energy_sums.pipeline);
                pass.set_bind_group(0, &g.energy_sums, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        self.dev.queue.submit([enc.finish()]);
        let sums: Vec<EnergySum<R>> = self.read(&b.energy_sums.buffer, groups)?;
        let (mut kinetic, mut strain, mut work) = (0.0, 0.0, 0.0);
        for s in &sums {
            kinetic += s.kinetic.to_f64();
            strain += s.strain.to_f64();
            work += s.work.to_f64();
        }
        // The fluid's work counts from its own base (0 in a dry scene), as `Model::energies`
        // books it beside the external work.
        let fluid_base = if self.fluid_scene { self.uploaded.fluid_base[0] } else { 0.0 };
        Ok((kinetic, strain, self.uploaded.work_base + work + fluid_base))
    }
}
