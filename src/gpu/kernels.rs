//! Kernels apart from state (STYLE.md item 3): `Pipelines` holds one compute pipeline per entry
//! point, named after it; `Buffers` holds the storage buffers. Both share one bind group layout
//! (group 0, bindings as in `shaders/common.wgsl`), so one bind group serves the four stages of
//! the cycle; `end_cycle` (the flags and the grids of the indirect dispatches), `splice_contacts`
//! and `pack_contacts` have layouts of their own.

use super::device::GpuDevice;
use super::layout::{Block, Contact, ContactForce, ContactSummary, Corner, EnergySum, Flags, Material, Params, Real};
use super::{shaders, GpuError, Precision};

/// One compute pipeline per entry point; each entry point is in the WGSL file of the same name.
pub struct Pipelines {
    /// Stages 1 and 2 (the invocation that moves a block places its corners).
    pub law_of_motion: wgpu::ComputePipeline,
    pub contact_forces: wgpu::ComputePipeline,
    /// `contact_points` in contact_forces.wgsl: the contacts' points and normals, which the
    /// cycle does not store, placed before a read-back or checkpoint of whole contacts.
    pub contact_points: wgpu::ComputePipeline,
    pub gather: wgpu::ComputePipeline,
    /// `end_cycle.wgsl`, with its own bindings (the flags and the dispatch grids it zeroes on a
    /// halt, `Buffers::end_cycle_bind_group`).
    pub end_cycle: wgpu::ComputePipeline,
    pub end_cycle_layout: wgpu::BindGroupLayout,
    pub energy_sums: wgpu::ComputePipeline,
    pub gather_heavy: wgpu::ComputePipeline,
    pub bind_group_layout: wgpu::BindGroupLayout,
    /// `splice_contacts.wgsl`, with its own bindings (`splice_bind_group`).
    pub splice_contacts: wgpu::ComputePipeline,
    /// Its second entry, `patch_contacts`, on the same bindings.
    pub patch_contacts: wgpu::ComputePipeline,
    /// `splice_adjacency.wgsl`'s two entries, on bindings of their own (`adjacency_layout`).
    pub splice_adjacency: wgpu::ComputePipeline,
    pub shift_offsets: wgpu::ComputePipeline,
    pub adjacency_layout: wgpu::BindGroupLayout,
    pub splice_layout: wgpu::BindGroupLayout,
    /// `pack_contacts.wgsl`, with its own bindings (the contacts, the summaries).
    pub pack_contacts: wgpu::ComputePipeline,
    pub pack_layout: wgpu::BindGroupLayout,
    /// `list_blocks.wgsl` (`list_blocks`, `list_contacts`), with their own bindings (`ListBuffers`).
    pub list_blocks: wgpu::ComputePipeline,
    pub list_contacts: wgpu::ComputePipeline,
    pub lists_layout: wgpu::BindGroupLayout,
}

fn uniform(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only }, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

impl Pipelines {
    /// Validates every kernel with naga first (clear errors), then builds the pipelines inside
    /// validation and internal error scopes, so a driver's rejection is an error value at set-up,
    /// not a panic or a failure at the first cycle. (NVIDIA's GL through EGL gives wgpu 30 a GL
    /// 3.3 context that advertises compute shaders, and its shader translation then refuses every
    /// kernel with an *internal* error: seen on an H100, 2026-11-26.)
    pub fn new(dev: &GpuDevice) -> Result<Self, GpuError> {
        let device = &dev.device;
        let internal = device.push_error_scope(wgpu::ErrorFilter::Internal);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        // A bind group layout of `entries` and the pipeline layout of it alone.
        let layouts = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
            let group = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries });
            let pipeline =
                device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some(label), bind_group_layouts: &[Some(&group)], immediate_size: 0 });
            (group, pipeline)
        };
        let (bind_group_layout, layout) = layouts(
            "blockdem state",
            &[
                uniform(0),
                storage(1, false),
                storage(2, false),
                storage(3, false),
                uniform(4),
                storage(5, true),
                storage(6, true),
                storage(7, false),
                storage(8, false),
                storage(9, false),
            ],
        );
        // The splice's bindings: the old list and records, the runs, the created contacts and
        // records (read), the new list and records (written), the patches (read).
        let (splice_layout, splice_pipeline_layout) = layouts(
            "blockdem splice",
            &[storage(0, true), storage(1, true), storage(2, true), storage(3, true), storage(4, true), storage(5, false), storage(6, false), storage(7, true)],
        );
        // The adjacency's edit: the old entries, runs, new lists and renumbering (read), the new
        // entries and the offsets (written), the touched lists (read).
        let (adjacency_layout, adjacency_pipeline_layout) = layouts(
            "blockdem adjacency",
            &[storage(0, true), storage(1, true), storage(2, true), storage(3, true), storage(4, false), storage(5, false), storage(6, true)],
        );
        let (pack_layout, pack_pipeline_layout) = layouts("blockdem pack", &[storage(0, true), storage(1, false)]);
        // Stage 7's lists: the constants, blocks, contacts and grid reference (read), the header
        // and the two lists (written).
        let (lists_layout, lists_pipeline_layout) = layouts(
            "blockdem update lists",
            &[uniform(0), storage(1, true), storage(2, true), storage(3, true), storage(4, false), storage(5, false), storage(6, false)],
        );
        // End of cycle: the flags (binding 7, as in common.wgsl) and the dispatch grids (10).
        let (end_cycle_layout, end_cycle_pipeline_layout) = layouts("blockdem end_cycle", &[storage(7, false), storage(10, false)]);
        // `entry` in the kernel file `name`.wgsl, on `layout`.
        let make_on = |layout: &wgpu::PipelineLayout, name: &str, entry: &str| -> Result<wgpu::ComputePipeline, GpuError> {
            let src = shaders::source(name, dev.precision).ok_or_else(|| GpuError::Shader(format!("no kernel {name}")))?;
            shaders::validate(&src, dev.precision).map_err(|e| GpuError::Shader(format!("{name}.wgsl: {e}")))?;
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(src.into()) });
            Ok(device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            }))
        };
        let make_entry = |name: &str, entry: &str| make_on(&layout, name, entry);
        let make = |name: &str| make_entry(name, name);
        let pipelines = Pipelines {
            law_of_motion: make("law_of_motion")?,
            contact_forces: make("contact_forces")?,
            contact_points: make_entry("contact_forces", "contact_points")?,
            gather: make("gather")?,
            end_cycle: make_on(&end_cycle_pipeline_layout, "end_cycle", "end_cycle")?,
            end_cycle_layout,
            energy_sums: make("energy_sums")?,
            gather_heavy: make_entry("gather", "gather_heavy")?,
            bind_group_layout,
            splice_contacts: make_on(&splice_pipeline_layout, "splice_contacts", "splice_contacts")?,
            patch_contacts: make_on(&splice_pipeline_layout, "splice_contacts", "patch_contacts")?,
            splice_adjacency: make_on(&adjacency_pipeline_layout, "splice_adjacency", "splice_adjacency")?,
            shift_offsets: make_on(&adjacency_pipeline_layout, "splice_adjacency", "shift_offsets")?,
            adjacency_layout,
            splice_layout,
            pack_contacts: make_on(&pack_pipeline_layout, "pack_contacts", "pack_contacts")?,
            pack_layout,
            list_blocks: make_on(&lists_pipeline_layout, "list_blocks", "list_blocks")?,
            list_contacts: make_on(&lists_pipeline_layout, "list_blocks", "list_contacts")?,
            lists_layout,
        };
        let rejected = [pollster::block_on(scope.pop()), pollster::block_on(internal.pop())];
        if let Some(e) = rejected.into_iter().flatten().next() {
            return Err(GpuError::Shader(format!(
                "the driver of {} ({} {}) rejected a kernel: {e}",
                dev.summary.name, dev.summary.backend, dev.summary.driver_info
            )));
        }
        Ok(pipelines)
    }
}

/// A storage buffer with room for `capacity` items.
pub struct Slab {
    pub buffer: wgpu::Buffer,
    pub capacity: usize,
}

/// The GPU state of a run.
pub struct Buffers {
    pub params: wgpu::Buffer,
    pub blocks: Slab,
    pub corners: Slab,
    pub contacts: Slab,
    /// `ContactForce` per contact: what the gather sums.
    pub contact_forces: Slab,
    /// The material table, a uniform of `MAX_MATERIALS` entries.
    pub materials: wgpu::Buffer,
    pub adj_offsets: Slab,
    pub adj_entries: Slab,
    pub flags: wgpu::Buffer,
    /// The grids of the cycle's indirect dispatches, (x, y, z) for each of `Grid`; written at the
    /// start of each batch, zeroed by `end_cycle` when it halts the batch.
    pub dispatch_args: wgpu::Buffer,
    /// One `EnergySum` per workgroup of the energy check.
    pub energy_sums: Slab,
    /// The other pair of contact and gather-record buffers, which `splice_contacts` writes the
    /// new list into before the two pairs change places (made at the first splice).
    pub spare_contacts: Option<(Slab, Slab)>,
    /// Likewise the adjacency entries' other buffer, which `splice_adjacency` writes.
    pub spare_entries: Option<Slab>,
    /// `ContactSummary` per contact, the packed read-back of a contact update (made at the first).
    pub summaries: Option<Slab>,
}

/// The largest storage binding this device may hold: the adapter's own limit (128 MiB on Mesa's
/// software adapters, 2 GiB on NVIDIA's Vulkan driver), within its largest buffer.
pub fn binding_cap(dev: &GpuDevice) -> u64 {
    dev.summary.max_storage_buffer_binding_size.min(dev.summary.max_buffer_size)
}

/// Why a buffer cannot be made, with advice that fits the run: f32 halves most buffers; in f32
/// only a smaller model (at most cap / item of these items), an adapter with larger bindings or
/// the CPU backend helps.
fn too_large(label: &str, need: u64, cap: u64, item: usize, precision: Precision) -> String {
    let advice = match precision {
        Precision::F64 => "use a smaller model or --precision f32 (about half the bytes)".to_string(),
        Precision::F32 => format!(
            "use a smaller model (at most {} {label} here), an adapter with larger bindings (hardware GPUs allow 2 GiB and more) or --backend cpu (no such limit)",
            cap / item as u64
        ),
    };
    format!("the {label} buffer would need {need} bytes, more than one binding may hold on this adapter ({cap} bytes); {advice}")
}

/// Whether `count` items of `item` bytes fit one binding of `cap` bytes; if not, the error that
/// making their buffer would give.
pub(crate) fn check_fits(label: &str, item: usize, count: usize, cap: u64, precision: Precision) -> Result<(), GpuError> {
    let need = (count.max(1) * item) as u64;
    if need > cap {
        return Err(GpuError::DoesNotFit(too_large(label, need, cap, item, precision)));
    }
    Ok(())
}

/// A uniform buffer of `size` bytes, written from the CPU.
pub(crate) fn uniform_buffer(dev: &GpuDevice, label: &str, size: usize) -> wgpu::Buffer {
    dev.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The bind group entries of `buffers`, each whole, at bindings 0, 1, 2, … in order.
pub(crate) fn whole_bindings<'a>(buffers: &[&'a wgpu::Buffer]) -> Vec<wgpu::BindGroupEntry<'a>> {
    buffers.iter().enumerate().map(|(i, buffer)| wgpu::BindGroupEntry { binding: i as u32, resource: buffer.as_entire_binding() }).collect()
}

/// Makes sure the optional buffer `slot` holds `count` items of `item` bytes (its contents are
/// not kept: the old buffer goes first, so that the two are never held at once).
fn ensure_slot(dev: &GpuDevice, slot: &mut Option<Slab>, label: &str, item: usize, count: usize) -> Result<(), GpuError> {
    if slot.as_ref().is_none_or(|s| s.capacity < count) {
        *slot = None;
        *slot = Some(slab(dev, label, item, count)?);
    }
    Ok(())
}

pub(crate) fn slab(dev: &GpuDevice, label: &str, item: usize, count: usize) -> Result<Slab, GpuError> {
    let cap = binding_cap(dev);
    check_fits(label, item, count, cap, dev.precision)?;
    // Room to grow (contacts come and go) without re-creating the buffer every update: a quarter
    // more, within the cap.
    let capacity = ((count.max(1) as u64 * 5 / 4).min(cap / item as u64) as usize).max(count.max(1));
    let size = (capacity * item) as u64;
    let buffer = dev.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    Ok(Slab { buffer, capacity })
}

impl Buffers {
    pub fn new<R: Real>(dev: &GpuDevice, blocks: usize, corners: usize, contacts: usize) -> Result<Self, GpuError> {
        let params = uniform_buffer(dev, "params", std::mem::size_of::<Params<R>>());
        let flags = dev.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("flags"),
            size: std::mem::size_of::<Flags>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let dispatch_args = dev.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("dispatch grids"),
            size: (Grid::ALL.len() * 12) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let materials = uniform_buffer(dev, "materials", crate::model::MAX_MATERIALS * std::mem::size_of::<Material<R>>());
        Ok(Buffers {
            params,
            blocks: slab(dev, "blocks", std::mem::size_of::<Block<R>>(), blocks)?,
            corners: slab(dev, "corners", std::mem::size_of::<Corner<R>>(), corners)?,
            contacts: slab(dev, "contacts", std::mem::size_of::<Contact<R>>(), contacts)?,
            contact_forces: slab(dev, "contact forces", std::mem::size_of::<ContactForce<R>>(), contacts)?,
            materials,
            adj_offsets: slab(dev, "adjacency offsets", 4, blocks + 1)?,
            adj_entries: slab(dev, "adjacency entries", 4, 2 * contacts)?,
            flags,
            dispatch_args,
            energy_sums: slab(dev, "energy sums", std::mem::size_of::<EnergySum<R>>(), energy_groups(blocks, contacts))?,
            spare_contacts: None,
            spare_entries: None,
            summaries: None,
        })
    }

    /// Grows `which` to hold `count` items of `item` bytes; returns whether it was re-created
    /// (the bind group must then be rebuilt).
    pub fn ensure(dev: &GpuDevice, which: &mut Slab, label: &str, item: usize, count: usize) -> Result<bool, GpuError> {
        if count <= which.capacity {
            return Ok(false);
        }
        *which = slab(dev, label, item, count)?;
        Ok(true)
    }

    /// Makes sure the spare pair holds `count` contacts (its contents are not kept).
    pub fn ensure_spare<R: Real>(&mut self, dev: &GpuDevice, count: usize) -> Result<(), GpuError> {
        if self.spare_contacts.as_ref().is_some_and(|(c, f)| c.capacity >= count && f.capacity >= count) {
            return Ok(());
        }
        // The old spare goes first, so the two are never held at once.
        self.spare_contacts = None;
        let contacts = slab(dev, "contacts (spare)", std::mem::size_of::<Contact<R>>(), count)?;
        let forces = slab(dev, "contact forces (spare)", std::mem::size_of::<ContactForce<R>>(), count)?;
        self.spare_contacts = Some((contacts, forces));
        Ok(())
    }

    /// Makes sure the summaries buffer holds `count` contacts.
    pub fn ensure_summaries<R: Real>(&mut self, dev: &GpuDevice, count: usize) -> Result<(), GpuError> {
        ensure_slot(dev, &mut self.summaries, "contact summaries", std::mem::size_of::<ContactSummary<R>>(), count)
    }

    /// Makes sure the spare adjacency entries hold `count` (its contents are not kept).
    pub fn ensure_spare_entries(&mut self, dev: &GpuDevice, count: usize) -> Result<(), GpuError> {
        ensure_slot(dev, &mut self.spare_entries, "adjacency entries (spare)", 4, count)
    }

    /// The spare entries become the live ones (after `splice_adjacency` wrote into them).
    pub fn swap_entries(&mut self) {
        let entries = self.spare_entries.take().expect("spare entries to swap in");
        self.spare_entries = Some(std::mem::replace(&mut self.adj_entries, entries));
    }

    /// The spare pair becomes the live contacts and records (after a splice wrote into it).
    pub fn swap_contacts(&mut self) {
        let (contacts, forces) = self.spare_contacts.take().expect("a spare pair to swap in");
        let old_contacts = std::mem::replace(&mut self.contacts, contacts);
        let old_forces = std::mem::replace(&mut self.contact_forces, forces);
        self.spare_contacts = Some((old_contacts, old_forces));
    }

    /// `end_cycle`'s bindings: the flags and the dispatch grids (neither is ever re-created).
    pub fn end_cycle_bind_group(&self, dev: &GpuDevice, layout: &wgpu::BindGroupLayout) -> wgpu::BindGroup {
        dev.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("blockdem end_cycle"),
            layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 7, resource: self.flags.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 10, resource: self.dispatch_args.as_entire_binding() },
            ],
        })
    }

    pub fn bind_group(&self, dev: &GpuDevice, layout: &wgpu::BindGroupLayout) -> wgpu::BindGroup {
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
        }
        dev.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("blockdem state"),
            layout,
            entries: &[
                entry(0, &self.params),
                entry(1, &self.blocks.buffer),
                entry(2, &self.corners.buffer),
                entry(3, &self.contacts.buffer),
                entry(4, &self.materials),
                entry(5, &self.adj_offsets.buffer),
                entry(6, &self.adj_entries.buffer),
                entry(7, &self.flags),
                entry(8, &self.contact_forces.buffer),
                entry(9, &self.energy_sums.buffer),
            ],
        })
    }
}

/// The grids of the cycle's indirect dispatches, in the order of `Buffers::dispatch_args`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grid {
    Blocks,
    Contacts,
    HeavyBlocks,
}

impl Grid {
    pub const ALL: [Grid; 3] = [Grid::Blocks, Grid::Contacts, Grid::HeavyBlocks];

    /// Byte offset of this grid's (x, y, z) in `Buffers::dispatch_args`.
    pub fn offset(self) -> u64 {
        self as u64 * 12
    }
}

/// One pass of a topology kernel (`shaders::TOPOLOGY_KERNELS`, bindings of its own) over `n`
/// items, submitted with no wait; a binding the driver rejects is an error value.
pub fn dispatch_items(
    dev: &GpuDevice,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    layout: &wgpu::BindGroupLayout,
    entries: &[wgpu::BindGroupEntry],
    n: usize,
) -> Result<(), GpuError> {
    dispatch_passes(dev, label, &[(pipeline, n)], layout, entries)
}

/// `dispatch_items` for several passes on one bind group, one after the other in one submission
/// (a pass of no items is left out).
pub fn dispatch_passes(
    dev: &GpuDevice,
    label: &str,
    passes: &[(&wgpu::ComputePipeline, usize)],
    layout: &wgpu::BindGroupLayout,
    entries: &[wgpu::BindGroupEntry],
) -> Result<(), GpuError> {
    let scope = dev.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let bind_group = dev.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries });
    let mut enc = dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
    for &(pipeline, n) in passes.iter().filter(|p| p.1 > 0) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        let (x, y) = shaders::dispatch_grid(n.div_ceil(shaders::workgroup_size() as usize) as u32);
        pass.dispatch_workgroups(x, y, 1);
    }
    dev.queue.submit([enc.finish()]);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Device(format!("{label} was rejected: {e}")));
    }
    Ok(())
}

/// The dispatch of the energy check: one invocation per `ENERGY_ITEMS` blocks and contacts,
/// whichever are more.
pub fn energy_grid(blocks: usize, contacts: usize) -> (u32, u32) {
    let per_group = (shaders::workgroup_size() * shaders::ENERGY_ITEMS) as usize;
    shaders::dispatch_grid(blocks.max(contacts).div_ceil(per_group).max(1) as u32)
}

/// Workgroups of the energy check, whole rows of its grid (each workgroup writes one sum).
pub fn energy_groups(blocks: usize, contacts: usize) -> usize {
    let (x, y) = energy_grid(blocks, contacts);
    (x * y) as usize
}

/// Rust twin of the WGSL `sin_cos` (common.wgsl), in f64: (cos θ, sin θ) by reduction to
/// |r| ≤ π/4 and Taylor series, with + − × only. The f64 kernels' π/2 split (the prelude's
/// PIO2_*; the f32 kernels split it in three parts of fewer bits).
pub fn sin_cos(theta: f64) -> (f64, f64) {
    // 2/π in f32, as the WGSL literal rounds to: the quadrant k is found in f32 there too.
    let k = ((theta as f32) * std::f32::consts::FRAC_2_PI).round() as i32;
    let kr = k as f64;
    let r = (theta - kr * 1.570_796_326_734_125_6) - kr * 6.077_100_506_506_192e-11;
    let r2 = r * r;
    let s = r
        * (1.0
            + r2 * (-1.0 / 6.0
                + r2 * (1.0 / 120.0
                    + r2 * (-1.0 / 5040.0
                        + r2 * (1.0 / 362880.0
                            + r2 * (-1.0 / 39916800.0 + r2 * (1.0 / 6227020800.0 + r2 * (-1.0 / 1307674368000.0 + r2 * (1.0 / 355687428096000.0)))))))));
    let c = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0
                + r2 * (-1.0 / 720.0
                    + r2 * (1.0 / 40320.0
                        + r2 * (-1.0 / 3628800.0 + r2 * (1.0 / 479001600.0 + r2 * (-1.0 / 87178291200.0 + r2 * (1.0 / 20922789888000.0))))))));
    match k & 3 {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model too large for one binding is refused with advice that fits the run: f32 only where
    /// the run is in f64, and in f32 how many items the adapter's binding holds.
    #[test]
    fn a_buffer_past_the_binding_limit_gets_advice_for_its_precision() {
        let cap = 134_217_728;
        let f32_msg = too_large("corners", 160_000_560, cap, 40, Precision::F32);
        assert!(f32_msg.contains("160000560 bytes") && f32_msg.contains("(134217728 bytes)"), "{f32_msg}");
        assert!(f32_msg.contains("at most 3355443 corners here") && !f32_msg.contains("--precision f32"), "{f32_msg}");
        let f64_msg = too_large("contacts", 960_000_000, cap, 120, Precision::F64);
        assert!(f64_msg.contains("--precision f32"), "{f64_msg}");
        // The check a run makes before its full detection gives the same refusal, and passes
        // what fits.
        match check_fits("corners", 40, 4_000_014, cap, Precision::F32) {
            Err(GpuError::DoesNotFit(m)) => assert!(m.contains("160000560 bytes") && m.contains("at most 3355443 corners here"), "{m}"),
            other => panic!("{other:?}"),
        }
        assert!(check_fits("corners", 40, 3_355_443, cap, Precision::F32).is_ok());
    }
}
