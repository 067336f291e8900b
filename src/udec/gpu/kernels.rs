//! Kernels apart from state (STYLE.md item 3): `Pipelines` holds one compute pipeline per entry
//! point, named after it; `Buffers` holds the storage buffers.
//!
//! The cycle's kernels declare the state's bindings once (`shaders/udec/common.wgsl`, group 0, the
//! slots of [`StateSlot`]), and each binds only the slots its entry point uses: naga reads them
//! off the validated module when the pipeline is made ([`CycleKernel`]), and each kernel has a
//! bind group layout and a bind group of its own ([`CycleBindGroups`]). So the per-stage
//! storage-buffer limit (8 by DESIGN.md §3, 16 on GL) counts one kernel's buffers, not the
//! union of every stage's: a new stage or array (a deformable block's stress, zones, fluid
//! domains) adds slots that only its kernels bind, and a scene without it binds and dispatches
//! nothing of it. `end_cycle` (the flags and the grids of the indirect dispatches),
//! `splice_contacts` and `pack_contacts` have layouts of their own.

use super::device::GpuDevice;
use super::layout::{
    Block, BlockFluid, Contact, ContactFlow, ContactForce, ContactLever, ContactShare, ContactSummary, Corner, CornerMove, Domain, EnergySum, FdefBlock, Flags,
    FluidLoad, FluidMaterial, FluidParams, FluidPiece, GridPoint, GridPointFluid, Material, Params, Real, Sdef, Zone,
};
use super::shaders;
use crate::gpu::wgsl::{layouts, storage, uniform};
use crate::gpu::GpuError;

/// The state's bindings as `shaders/udec/common.wgsl` declares them (group 0; binding = the
/// discriminant). A test checks this table against the WGSL declarations through naga.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum StateSlot {
    Params = 0,
    Blocks = 1,
    Corners = 2,
    Contacts = 3,
    Materials = 4,
    AdjOffsets = 5,
    AdjEntries = 6,
    Flags = 7,
    ContactForces = 8,
    EnergySums = 9,
    /// Scenes with simply-deformable blocks only: each block's extension (`layout::Sdef`).
    Sdefs = 10,
    /// Scenes with simply-deformable blocks only: each contact's lever arms.
    ContactLevers = 11,
    /// Scenes with zoned fully-deformable blocks only: every zoned block's grid points
    /// (`layout::GridPoint`), zones (`layout::Zone`), each block's zone constants and ranges
    /// (`layout::FdefBlock`), each grid point's zones (CSR in one array) and each contact's force
    /// shares (`layout::ContactShare`). (Binding 15 is end_cycle's dispatch grids.)
    GridPoints = 12,
    Zones = 13,
    FdefBlocks = 14,
    GridPointZones = 16,
    ContactShares = 17,
    /// Scenes with fluid only (`gpu::flow`): the fluid's constants and each material's flow
    /// properties (uniforms), the domains (`layout::Domain`), each domain's flows and boundary
    /// links (CSR words), each contact's two domains, each contact's flow and feet
    /// (`layout::ContactFlow`) and each block's fluid load (`layout::FluidLoad`).
    FluidParams = 18,
    FluidMaterials = 19,
    Domains = 20,
    DomainFlows = 21,
    DomainLinks = 22,
    ContactSides = 23,
    ContactFlows = 24,
    FluidLoads = 25,
    /// Scenes with fluid and deformable blocks only (`gpu::flow`): each domain link's piece of
    /// block boundary (`layout::FluidPiece`), each block's pieces (CSR words), each block's
    /// fluid load (`layout::BlockFluid`) and, with zoned blocks, each grid point's
    /// (`layout::GridPointFluid`).
    FluidPieces = 26,
    BlockPieces = 27,
    BlockFluid = 28,
    GridPointFluid = 29,
    /// Scenes with fluid only (`gpu::flow`, flow.wgsl's `domain_terms`): the terms of the long
    /// domains' sums and the items that compute them (four words each).
    DomainTerms = 30,
    TermItems = 31,
    /// Scenes with fluid and deformable blocks, in f32 (flow.wgsl's `corner_moves_*`,
    /// `deformed_terms`): each corner's move in this step (`layout::CornerMove`).
    CornerMoves = 32,
}

/// How a slot is bound: a uniform, or a storage buffer read only or read and written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotKind {
    Uniform,
    StorageRead,
    StorageReadWrite,
}

impl StateSlot {
    pub const ALL: [StateSlot; 32] = [
        StateSlot::Params,
        StateSlot::Blocks,
        StateSlot::Corners,
        StateSlot::Contacts,
        StateSlot::Materials,
        StateSlot::AdjOffsets,
        StateSlot::AdjEntries,
        StateSlot::Flags,
        StateSlot::ContactForces,
        StateSlot::EnergySums,
        StateSlot::Sdefs,
        StateSlot::ContactLevers,
        StateSlot::GridPoints,
        StateSlot::Zones,
        StateSlot::FdefBlocks,
        StateSlot::GridPointZones,
        StateSlot::ContactShares,
        StateSlot::FluidParams,
        StateSlot::FluidMaterials,
        StateSlot::Domains,
        StateSlot::DomainFlows,
        StateSlot::DomainLinks,
        StateSlot::ContactSides,
        StateSlot::ContactFlows,
        StateSlot::FluidLoads,
        StateSlot::FluidPieces,
        StateSlot::BlockPieces,
        StateSlot::BlockFluid,
        StateSlot::GridPointFluid,
        StateSlot::DomainTerms,
        StateSlot::TermItems,
        StateSlot::CornerMoves,
    ];

    pub fn binding(self) -> u32 {
        self as u32
    }

    /// The slot of a binding number, if the state has one there.
    pub fn of_binding(binding: u32) -> Option<StateSlot> {
        Self::ALL.iter().copied().find(|s| s.binding() == binding)
    }

    /// The WGSL variable of the slot in common.wgsl.
    pub fn wgsl_name(self) -> &'static str {
        match self {
            StateSlot::Params => "params",
            StateSlot::Blocks => "blocks",
            StateSlot::Corners => "corners",
            StateSlot::Contacts => "contacts",
            StateSlot::Materials => "materials",
            StateSlot::AdjOffsets => "adj_offsets",
            StateSlot::AdjEntries => "adj_entries",
            StateSlot::Flags => "flags",
            StateSlot::ContactForces => "contact_forces_out",
            StateSlot::EnergySums => "energy_sums_out",
            StateSlot::Sdefs => "sdefs",
            StateSlot::ContactLevers => "contact_levers",
            StateSlot::GridPoints => "gridpoints",
            StateSlot::Zones => "zone_list",
            StateSlot::FdefBlocks => "fdef_blocks",
            StateSlot::GridPointZones => "gridpoint_zones",
            StateSlot::ContactShares => "contact_shares",
            StateSlot::FluidParams => "fluid_params",
            StateSlot::FluidMaterials => "fluid_materials",
            StateSlot::Domains => "domains",
            StateSlot::DomainFlows => "domain_flows",
            StateSlot::DomainLinks => "domain_links",
            StateSlot::ContactSides => "contact_sides",
            StateSlot::ContactFlows => "contact_flows_out",
            StateSlot::FluidLoads => "fluid_loads",
            StateSlot::FluidPieces => "fluid_pieces",
            StateSlot::BlockPieces => "block_pieces",
            StateSlot::BlockFluid => "block_fluid",
            StateSlot::GridPointFluid => "gridpoint_fluid",
            StateSlot::DomainTerms => "sum_terms",
            StateSlot::TermItems => "term_items",
            StateSlot::CornerMoves => "corner_moves",
        }
    }

    pub fn kind(self) -> SlotKind {
        match self {
            StateSlot::Params | StateSlot::Materials | StateSlot::FluidParams | StateSlot::FluidMaterials => SlotKind::Uniform,
            StateSlot::AdjOffsets
            | StateSlot::AdjEntries
            | StateSlot::FdefBlocks
            | StateSlot::GridPointZones
            | StateSlot::DomainFlows
            | StateSlot::DomainLinks
            | StateSlot::ContactSides
            | StateSlot::BlockPieces
            | StateSlot::TermItems => SlotKind::StorageRead,
            _ => SlotKind::StorageReadWrite,
        }
    }

    fn layout_entry(self) -> wgpu::BindGroupLayoutEntry {
        match self.kind() {
            SlotKind::Uniform => uniform(self.binding()),
            SlotKind::StorageRead => storage(self.binding(), true),
            SlotKind::StorageReadWrite => storage(self.binding(), false),
        }
    }
}

/// The state slots the entry point `entry` of a validated cycle kernel uses (reads, writes or
/// queries the length of), ascending: what its bind group must hold, and all it may hold. naga's
/// analysis of an entry point includes the globals of the functions it calls.
pub fn used_slots(module: &naga::Module, info: &naga::valid::ModuleInfo, entry: &str) -> Result<Vec<StateSlot>, String> {
    let index = module.entry_points.iter().position(|e| e.name == entry).ok_or_else(|| format!("no entry point {entry}"))?;
    let uses = info.get_entry_point(index);
    let mut slots = Vec::new();
    for (handle, var) in module.global_variables.iter() {
        let Some(binding) = &var.binding else { continue };
        if uses[handle].is_empty() {
            continue;
        }
        let slot = StateSlot::of_binding(binding.binding).filter(|_| binding.group == 0).ok_or_else(|| {
            format!("{entry} uses binding {}:{} ({}), which is no state slot", binding.group, binding.binding, var.name.as_deref().unwrap_or("?"))
        })?;
        slots.push(slot);
    }
    slots.sort();
    Ok(slots)
}

/// A kernel of the cycle: its pipeline and the state slots it binds, with their layout.
pub struct CycleKernel {
    pub pipeline: wgpu::ComputePipeline,
    pub slots: Vec<StateSlot>,
    pub layout: wgpu::BindGroupLayout,
}

/// One bind group per cycle kernel, each of the buffers that kernel uses (made with the
/// buffers, again whenever one is re-created or the contact pairs change places).
pub struct CycleBindGroups {
    pub law_of_motion: wgpu::BindGroup,
    pub contact_forces: wgpu::BindGroup,
    pub contact_points: wgpu::BindGroup,
    pub gather: wgpu::BindGroup,
    pub gather_heavy: wgpu::BindGroup,
    pub energy_sums: wgpu::BindGroup,
    /// The SDEF kernels' (`SdefKernels`), in a scene with simply-deformable blocks.
    pub sdef: Option<SdefBindGroups>,
    /// The FDEF kernels' (`FdefKernels`), in a scene with zoned fully-deformable blocks.
    pub fdef: Option<FdefBindGroups>,
    /// The fluid's kernels' (`FluidKernels`), in a scene with fluid.
    pub fluid: Option<FluidBindGroups>,
    /// The kernels' of fluid with simply-deformable blocks (`WetSdefKernels`).
    pub wet_sdef: Option<WetSdefBindGroups>,
    /// The kernels' of fluid with zoned blocks (`WetFdefKernels`).
    pub wet_fdef: Option<WetFdefBindGroups>,
}

/// The bind groups of `WetSdefKernels`.
pub struct WetSdefBindGroups {
    pub pressure_pieces: wgpu::BindGroup,
    pub fluid_block_loads: wgpu::BindGroup,
    pub law_of_motion: wgpu::BindGroup,
    pub gather: wgpu::BindGroup,
    pub corner_moves: wgpu::BindGroup,
    pub deformed_terms: wgpu::BindGroup,
}

/// The bind groups of `WetFdefKernels`.
pub struct WetFdefBindGroups {
    pub pressure_pieces: wgpu::BindGroup,
    pub fluid_block_loads: wgpu::BindGroup,
    pub gridpoint_fluid_loads: wgpu::BindGroup,
    pub gather_gridpoints: wgpu::BindGroup,
    pub step_gridpoints: wgpu::BindGroup,
    pub law_of_motion: wgpu::BindGroup,
    pub gather: wgpu::BindGroup,
    pub corner_moves: wgpu::BindGroup,
    pub deformed_terms: wgpu::BindGroup,
}

/// The bind groups of `FluidKernels`.
pub struct FluidBindGroups {
    pub law_of_motion: wgpu::BindGroup,
    pub contact_flows: wgpu::BindGroup,
    pub domain_terms: wgpu::BindGroup,
    pub domain_pressures: wgpu::BindGroup,
    pub gather: wgpu::BindGroup,
    pub energy_sums: wgpu::BindGroup,
}

/// The bind groups of `FdefKernels`.
pub struct FdefBindGroups {
    pub gather_gridpoints: wgpu::BindGroup,
    pub step_gridpoints: wgpu::BindGroup,
    pub zones: wgpu::BindGroup,
    pub place_corners: wgpu::BindGroup,
    pub check_lists: wgpu::BindGroup,
    pub law_of_motion: wgpu::BindGroup,
    pub contact_forces: wgpu::BindGroup,
    pub gather: wgpu::BindGroup,
    pub energy_sums: wgpu::BindGroup,
}

/// The bind groups of `SdefKernels`.
pub struct SdefBindGroups {
    pub law_of_motion: wgpu::BindGroup,
    pub contact_forces: wgpu::BindGroup,
    pub gather: wgpu::BindGroup,
    pub energy_sums: wgpu::BindGroup,
}

impl CycleBindGroups {
    pub fn new(dev: &GpuDevice, p: &Pipelines, b: &Buffers) -> Self {
        let make = |k: &CycleKernel, label: &str| b.kernel_bind_group(dev, k, label);
        let sdef = p.sdef.as_ref().filter(|_| b.sdefs.is_some()).map(|k| SdefBindGroups {
            law_of_motion: make(&k.law_of_motion, "law_of_motion_sdef"),
            contact_forces: make(&k.contact_forces, "contact_forces_sdef"),
            gather: make(&k.gather, "gather_sdef"),
            energy_sums: make(&k.energy_sums, "energy_sums_sdef"),
        });
        let fdef = p.fdef.as_ref().filter(|_| b.gridpoints.is_some()).map(|k| FdefBindGroups {
            gather_gridpoints: make(&k.gather_gridpoints, "gather_gridpoints"),
            step_gridpoints: make(&k.step_gridpoints, "step_gridpoints"),
            zones: make(&k.zones, "zones"),
            place_corners: make(&k.place_corners, "place_fdef_corners"),
            check_lists: make(&k.check_lists, "check_fdef_lists"),
            law_of_motion: make(&k.law_of_motion, "law_of_motion_fdef"),
            contact_forces: make(&k.contact_forces, "contact_forces_fdef"),
            gather: make(&k.gather, "gather_fdef"),
            energy_sums: make(&k.energy_sums, "energy_sums_fdef"),
        });
        let fluid = p.fluid.as_ref().filter(|_| b.domains.is_some()).map(|k| FluidBindGroups {
            law_of_motion: make(&k.law_of_motion, "law_of_motion_fluid"),
            contact_flows: make(&k.contact_flows, "flow"),
            domain_terms: make(&k.domain_terms, "domain_terms"),
            domain_pressures: make(&k.domain_pressures, "domain_pressures"),
            gather: make(&k.gather, "gather_fluid"),
            energy_sums: make(&k.energy_sums, "energy_sums_fluid"),
        });
        let wet = b.fluid_pieces.is_some();
        let wet_sdef = p.wet_sdef.as_ref().filter(|_| wet && b.sdefs.is_some()).map(|k| WetSdefBindGroups {
            pressure_pieces: make(&k.pressure_pieces, "pressure_pieces"),
            fluid_block_loads: make(&k.fluid_block_loads, "fluid_block_loads"),
            law_of_motion: make(&k.law_of_motion, "law_of_motion_sdef_fluid"),
            gather: make(&k.gather, "gather_sdef_fluid"),
            corner_moves: make(&k.corner_moves, "corner_moves_sdef"),
            deformed_terms: make(&k.deformed_terms, "deformed_terms"),
        });
        let wet_fdef = p.wet_fdef.as_ref().filter(|_| wet && b.gridpoints.is_some() && b.gridpoint_fluid.is_some()).map(|k| WetFdefBindGroups {
            pressure_pieces: make(&k.pressure_pieces, "pressure_pieces"),
            fluid_block_loads: make(&k.fluid_block_loads, "fluid_block_loads"),
            gridpoint_fluid_loads: make(&k.gridpoint_fluid_loads, "gridpoint_fluid_loads"),
            gather_gridpoints: make(&k.gather_gridpoints, "gather_gridpoints_fluid"),
            step_gridpoints: make(&k.step_gridpoints, "step_gridpoints_fluid"),
            law_of_motion: make(&k.law_of_motion, "law_of_motion_fdef_fluid"),
            gather: make(&k.gather, "gather_fdef_fluid"),
            corner_moves: make(&k.corner_moves, "corner_moves_fdef"),
            deformed_terms: make(&k.deformed_terms, "deformed_terms"),
        });
        CycleBindGroups {
            sdef,
            fdef,
            fluid,
            wet_sdef,
            wet_fdef,
            law_of_motion: make(&p.law_of_motion, "law_of_motion"),
            contact_forces: make(&p.contact_forces, "contact_forces"),
            contact_points: make(&p.contact_points, "contact_points"),
            gather: make(&p.gather, "gather"),
            gather_heavy: make(&p.gather_heavy, "gather_heavy"),
            energy_sums: make(&p.energy_sums, "energy_sums"),
        }
    }
}

/// One compute pipeline per entry point; each entry point is in the WGSL file of the same name.
pub struct Pipelines {
    /// Stages 1 and 2 (the invocation that moves a block places its corners).
    pub law_of_motion: CycleKernel,
    pub contact_forces: CycleKernel,
    /// `contact_points` in contact_forces.wgsl: the contacts' points and normals, which the
    /// cycle does not store, placed before a read-back or checkpoint of whole contacts.
    pub contact_points: CycleKernel,
    pub gather: CycleKernel,
    /// `end_cycle.wgsl`, with its own bindings (the flags and the dispatch grids it zeroes on a
    /// halt, `Buffers::end_cycle_bind_group`).
    pub end_cycle: wgpu::ComputePipeline,
    pub end_cycle_layout: wgpu::BindGroupLayout,
    pub energy_sums: CycleKernel,
    pub gather_heavy: CycleKernel,
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
    /// The cycle's kernels for simply-deformable blocks, made at the first upload of a scene
    /// that has them (`Pipelines::with_sdef`): a rigid scene never compiles them.
    pub sdef: Option<SdefKernels>,
    /// The cycle's kernels for zoned fully-deformable blocks, made at the first upload of a
    /// scene that has them (`Pipelines::with_fdef`).
    pub fdef: Option<FdefKernels>,
    /// The fluid's kernels, made at the first upload of a scene with fluid
    /// (`Pipelines::with_fluid`): a dry scene never compiles them.
    pub fluid: Option<FluidKernels>,
    /// The kernels of fluid with simply-deformable or zoned blocks, made at the first upload of
    /// a scene with both (`Pipelines::with_wet_sdef`, `with_wet_fdef`).
    pub wet_sdef: Option<WetSdefKernels>,
    pub wet_fdef: Option<WetFdefKernels>,
}

/// The entry points a scene with fluid and simply-deformable blocks runs besides the fluid's
/// and the SDEF kernels (`gpu::flow`): flow.wgsl's `pressure_pieces` (each domain's pieces of
/// block boundary at its pressure), gather.wgsl's `fluid_block_loads` (each block's fluid load
/// and an SDEF block's applied stress from its pieces) and `gather_sdef_fluid` (those added to
/// the stored sums before a read-back), and `law_of_motion_sdef_fluid` (the block pass on the
/// stored sums of `gather_sdef` with the fluid's added, its work booked); in f32, flow.wgsl's
/// `corner_moves_sdef` and `deformed_terms` (the voids they bound followed by their motion).
/// Only they bind the slots of fluid with deformable blocks.
pub struct WetSdefKernels {
    pub pressure_pieces: CycleKernel,
    pub fluid_block_loads: CycleKernel,
    pub law_of_motion: CycleKernel,
    pub gather: CycleKernel,
    pub corner_moves: CycleKernel,
    pub deformed_terms: CycleKernel,
}

impl WetSdefKernels {
    pub fn new(dev: &GpuDevice) -> Result<Self, GpuError> {
        in_error_scopes(dev, || {
            Ok(WetSdefKernels {
                pressure_pieces: cycle_kernel(dev, "flow", "pressure_pieces")?,
                fluid_block_loads: cycle_kernel(dev, "gather", "fluid_block_loads")?,
                law_of_motion: cycle_kernel(dev, "law_of_motion", "law_of_motion_sdef_fluid")?,
                gather: cycle_kernel(dev, "gather", "gather_sdef_fluid")?,
                corner_moves: cycle_kernel(dev, "flow", "corner_moves_sdef")?,
                deformed_terms: cycle_kernel(dev, "flow", "deformed_terms")?,
            })
        })
    }
}

/// The entry points a scene with fluid and zoned blocks runs besides the fluid's and the FDEF
/// kernels: `pressure_pieces` and `fluid_block_loads` as with SDEF blocks, zones.wgsl's
/// `gridpoint_fluid_loads` (each zoned block's grid points' shares of its buoyancy and pieces),
/// `gather_gridpoints_fluid` and `step_gridpoints_fluid` in place of their dry twins (the
/// grid points' loads added, their work over the step kept), `law_of_motion_fdef_fluid` (the
/// rigid blocks on the stored sums of `gather_fdef` with their fluid load, a zoned block's
/// grid points' fluid work booked) and `gather_fdef_fluid` before a read-back; in f32,
/// `corner_moves_fdef` and `deformed_terms` as with SDEF blocks.
pub struct WetFdefKernels {
    pub pressure_pieces: CycleKernel,
    pub fluid_block_loads: CycleKernel,
    pub gridpoint_fluid_loads: CycleKernel,
    pub gather_gridpoints: CycleKernel,
    pub step_gridpoints: CycleKernel,
    pub law_of_motion: CycleKernel,
    pub gather: CycleKernel,
    pub corner_moves: CycleKernel,
    pub deformed_terms: CycleKernel,
}

impl WetFdefKernels {
    pub fn new(dev: &GpuDevice) -> Result<Self, GpuError> {
        in_error_scopes(dev, || {
            Ok(WetFdefKernels {
                pressure_pieces: cycle_kernel(dev, "flow", "pressure_pieces")?,
                fluid_block_loads: cycle_kernel(dev, "gather", "fluid_block_loads")?,
                gridpoint_fluid_loads: cycle_kernel(dev, "zones", "gridpoint_fluid_loads")?,
                gather_gridpoints: cycle_kernel(dev, "zones", "gather_gridpoints_fluid")?,
                step_gridpoints: cycle_kernel(dev, "zones", "step_gridpoints_fluid")?,
                law_of_motion: cycle_kernel(dev, "law_of_motion", "law_of_motion_fdef_fluid")?,
                gather: cycle_kernel(dev, "gather", "gather_fdef_fluid")?,
                corner_moves: cycle_kernel(dev, "flow", "corner_moves_fdef")?,
                deformed_terms: cycle_kernel(dev, "flow", "deformed_terms")?,
            })
        })
    }
}

/// The entry points a scene with fluid runs (stage 5, `gpu::flow`): flow.wgsl's `flow` (each
/// contact's flow, field `contact_flows`), `domain_terms` (the long domains' terms, where there
/// are such domains) and `domain_pressures` after the contact stage, and in
/// the files of their rigid twins `law_of_motion_fluid` (a block's fluid load summed with its
/// contact forces in its gather, its work booked), `gather_fluid` (before a read-back) and
/// `energy_sums_fluid` after `energy_sums`. Only they bind the fluid's slots.
pub struct FluidKernels {
    pub law_of_motion: CycleKernel,
    pub contact_flows: CycleKernel,
    pub domain_terms: CycleKernel,
    pub domain_pressures: CycleKernel,
    pub gather: CycleKernel,
    pub energy_sums: CycleKernel,
}

impl FluidKernels {
    pub fn new(dev: &GpuDevice) -> Result<Self, GpuError> {
        in_error_scopes(dev, || {
            Ok(FluidKernels {
                law_of_motion: cycle_kernel(dev, "law_of_motion", "law_of_motion_fluid")?,
                contact_flows: cycle_kernel(dev, "flow", "flow")?,
                domain_terms: cycle_kernel(dev, "flow", "domain_terms")?,
                domain_pressures: cycle_kernel(dev, "flow", "domain_pressures")?,
                gather: cycle_kernel(dev, "gather", "gather_fluid")?,
                energy_sums: cycle_kernel(dev, "energy_sums", "energy_sums_fluid")?,
            })
        })
    }
}

/// The entry points a scene with zoned fully-deformable blocks runs: zones.wgsl's
/// `gather_gridpoints`, `step_gridpoints` and `zones` (stages 6, 1 and 3 of the grid
/// points and zones), and in the files of their rigid twins `law_of_motion_fdef` (rigid blocks,
/// and a zoned block's corners on its grid points), `place_fdef_corners` (those of a zoned block
/// of many, a workgroup per block), `check_fdef_lists` (whether a contact's feature outruns the
/// grid points' contact lists),
/// `contact_forces_fdef` (a zoned boundary's
/// velocity, the force shares), `gather_fdef` (the rigid blocks' sums before a read-back) and
/// `energy_sums_fdef` after `energy_sums`. Only they bind the FDEF slots.
pub struct FdefKernels {
    pub gather_gridpoints: CycleKernel,
    pub step_gridpoints: CycleKernel,
    pub zones: CycleKernel,
    pub place_corners: CycleKernel,
    pub check_lists: CycleKernel,
    pub law_of_motion: CycleKernel,
    pub contact_forces: CycleKernel,
    pub gather: CycleKernel,
    pub energy_sums: CycleKernel,
}

impl FdefKernels {
    pub fn new(dev: &GpuDevice) -> Result<Self, GpuError> {
        in_error_scopes(dev, || {
            Ok(FdefKernels {
                gather_gridpoints: cycle_kernel(dev, "zones", "gather_gridpoints")?,
                step_gridpoints: cycle_kernel(dev, "zones", "step_gridpoints")?,
                zones: cycle_kernel(dev, "zones", "zones")?,
                place_corners: cycle_kernel(dev, "law_of_motion", "place_fdef_corners")?,
                check_lists: cycle_kernel(dev, "zones", "check_fdef_lists")?,
                law_of_motion: cycle_kernel(dev, "law_of_motion", "law_of_motion_fdef")?,
                contact_forces: cycle_kernel(dev, "contact_forces", "contact_forces_fdef")?,
                gather: cycle_kernel(dev, "gather", "gather_fdef")?,
                energy_sums: cycle_kernel(dev, "energy_sums", "energy_sums_fdef")?,
            })
        })
    }
}

/// The entry points a scene with simply-deformable blocks runs in place of the rigid ones, each
/// in the file of its rigid twin: `law_of_motion_sdef`, `contact_forces_sdef`, `gather_sdef`,
/// and `energy_sums_sdef` after `energy_sums`. Only they bind the `Sdefs` and `ContactLevers`
/// slots.
pub struct SdefKernels {
    pub law_of_motion: CycleKernel,
    pub contact_forces: CycleKernel,
    pub gather: CycleKernel,
    pub energy_sums: CycleKernel,
}

/// A cycle kernel: `entry` in `name`.wgsl, validated by naga first, on a layout of the state
/// slots it uses.
fn cycle_kernel(dev: &GpuDevice, name: &str, entry: &str) -> Result<CycleKernel, GpuError> {
    let device = &dev.device;
    let src = shaders::source(name, dev.precision).ok_or_else(|| GpuError::Shader(format!("no kernel {name}")))?;
    let (module, info) = shaders::validate(&src, dev.precision).map_err(|e| GpuError::Shader(format!("{name}.wgsl: {e}")))?;
    let slots = used_slots(&module, &info, entry).map_err(|e| GpuError::Shader(format!("{name}.wgsl: {e}")))?;
    let entries: Vec<wgpu::BindGroupLayoutEntry> = slots.iter().map(|s| s.layout_entry()).collect();
    let (layout, pipeline_layout) = layouts(device, entry, &entries);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(src.into()) });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    });
    Ok(CycleKernel { pipeline, slots, layout })
}

/// Runs `make` inside the device's creation scopes (`GpuDevice::creation_scopes`): a kernel the
/// driver rejects is an error value naming the adapter, not a panic or a failure at the first
/// cycle. (NVIDIA's GL through EGL gives wgpu 30 a GL 3.3 context that advertises compute
/// shaders, and its shader translation then refuses every kernel with an *internal* error: seen
/// on an H100, 2026-11-26.)
fn in_error_scopes<T>(dev: &GpuDevice, make: impl FnOnce() -> Result<T, GpuError>) -> Result<T, GpuError> {
    let scopes = dev.creation_scopes();
    let made = make();
    scopes.check(dev)?;
    made
}

impl SdefKernels {
    pub fn new(dev: &GpuDevice) -> Result<Self, GpuError> {
        in_error_scopes(dev, || {
            Ok(SdefKernels {
                law_of_motion: cycle_kernel(dev, "law_of_motion", "law_of_motion_sdef")?,
                contact_forces: cycle_kernel(dev, "contact_forces", "contact_forces_sdef")?,
                gather: cycle_kernel(dev, "gather", "gather_sdef")?,
                energy_sums: cycle_kernel(dev, "energy_sums", "energy_sums_sdef")?,
            })
        })
    }
}

impl Pipelines {
    /// Makes the fluid's kernels if they are not made yet.
    pub fn with_fluid(&mut self, dev: &GpuDevice) -> Result<(), GpuError> {
        if self.fluid.is_none() {
            let _p = crate::profile::scope(crate::profile::Stage::KernelBuild);
            self.fluid = Some(FluidKernels::new(dev)?);
        }
        Ok(())
    }

    /// Makes the FDEF kernels if they are not made yet.
    pub fn with_wet_sdef(&mut self, dev: &GpuDevice) -> Result<(), GpuError> {
        if self.wet_sdef.is_none() {
            let _p = crate::profile::scope(crate::profile::Stage::KernelBuild);
            self.wet_sdef = Some(WetSdefKernels::new(dev)?);
        }
        Ok(())
    }

    pub fn with_wet_fdef(&mut self, dev: &GpuDevice) -> Result<(), GpuError> {
        if self.wet_fdef.is_none() {
            let _p = crate::profile::scope(crate::profile::Stage::KernelBuild);
            self.wet_fdef = Some(WetFdefKernels::new(dev)?);
        }
        Ok(())
    }

    pub fn with_fdef(&mut self, dev: &GpuDevice) -> Result<(), GpuError> {
        if self.fdef.is_none() {
            let _p = crate::profile::scope(crate::profile::Stage::KernelBuild);
            self.fdef = Some(FdefKernels::new(dev)?);
        }
        Ok(())
    }

    /// Makes the SDEF kernels if they are not made yet.
    pub fn with_sdef(&mut self, dev: &GpuDevice) -> Result<(), GpuError> {
        if self.sdef.is_none() {
            let _p = crate::profile::scope(crate::profile::Stage::KernelBuild);
            self.sdef = Some(SdefKernels::new(dev)?);
        }
        Ok(())
    }

    /// Validates every kernel with naga first (clear errors), then builds the pipelines inside
    /// error scopes (`GpuDevice::creation_scopes`), so a driver's rejection is an error value at
    /// set-up, not a panic or a failure at the first cycle.
    pub fn new(dev: &GpuDevice) -> Result<Self, GpuError> {
        in_error_scopes(dev, || Self::make(dev))
    }

    fn make(dev: &GpuDevice) -> Result<Self, GpuError> {
        let device = &dev.device;
        let layouts = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| layouts(device, label, entries);
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
        // End of cycle: the flags (binding 7, as in common.wgsl) and the dispatch grids (15, past
        // the state's slots).
        let (end_cycle_layout, end_cycle_pipeline_layout) = layouts("blockdem end_cycle", &[storage(7, false), storage(15, false)]);
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
        let make_entry = |name: &str, entry: &str| cycle_kernel(dev, name, entry);
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
            sdef: None,
            fdef: None,
            fluid: None,
            wet_sdef: None,
            wet_fdef: None,
        };
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
    /// Likewise the contact levers' other buffer, in an SDEF scene (`Engine::splice_levers`).
    pub spare_levers: Option<Slab>,
    /// `layout::Sdef` per block and `ContactLever` per contact, in a scene with simply-deformable
    /// blocks (`Buffers::ensure_sdef`); None in a rigid one.
    pub sdefs: Option<Slab>,
    pub contact_levers: Option<Slab>,
    /// The FDEF slots, in a scene with zoned fully-deformable blocks (`Buffers::ensure_fdef`;
    /// grid points and zones exactly as long as the scene's, which their kernels take from
    /// `arrayLength`); None in the others.
    pub gridpoints: Option<Slab>,
    pub zones: Option<Slab>,
    pub fdef_blocks: Option<Slab>,
    pub gridpoint_zones: Option<Slab>,
    pub contact_shares: Option<Slab>,
    /// The fluid's slots, in a scene with fluid (`Buffers::ensure_fluid`; None in a dry one):
    /// its two uniforms, then the domains, their flows and links, each contact's domains and
    /// flow, each block's load.
    pub fluid_params: Option<wgpu::Buffer>,
    pub fluid_materials: Option<wgpu::Buffer>,
    pub domains: Option<Slab>,
    pub domain_flows: Option<Slab>,
    pub domain_links: Option<Slab>,
    pub contact_sides: Option<Slab>,
    pub contact_flows: Option<Slab>,
    pub fluid_loads: Option<Slab>,
    /// The long domains' terms and their items (`StateSlot::DomainTerms`, `TermItems`).
    pub domain_terms: Option<Slab>,
    pub term_items: Option<Slab>,
    /// Scenes with fluid and deformable blocks only (`StateSlot::FluidPieces` …
    /// `GridPointFluid`; the grid points' with zoned blocks only).
    pub fluid_pieces: Option<Slab>,
    pub block_pieces: Option<Slab>,
    pub block_fluid: Option<Slab>,
    pub gridpoint_fluid: Option<Slab>,
    /// Each corner's move in this step (`StateSlot::CornerMoves`), in a scene with fluid and
    /// deformable blocks.
    pub corner_moves: Option<Slab>,
    /// `ContactSummary` per contact, the packed read-back of a contact update (made at the first).
    pub summaries: Option<Slab>,
}

pub use crate::gpu::device::{binding_cap, check_fits};

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
        let materials = uniform_buffer(dev, "materials", crate::udec::model::MAX_MATERIALS * std::mem::size_of::<Material<R>>());
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
            spare_levers: None,
            sdefs: None,
            contact_levers: None,
            gridpoints: None,
            zones: None,
            fdef_blocks: None,
            gridpoint_zones: None,
            contact_shares: None,
            fluid_params: None,
            fluid_materials: None,
            domains: None,
            domain_flows: None,
            domain_links: None,
            contact_sides: None,
            contact_flows: None,
            fluid_loads: None,
            domain_terms: None,
            term_items: None,
            fluid_pieces: None,
            block_pieces: None,
            block_fluid: None,
            gridpoint_fluid: None,
            corner_moves: None,
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

    /// Makes sure the SDEF slots hold `blocks` extensions and `contacts` lever records; returns
    /// whether one was re-created (the bind groups must then be rebuilt).
    pub fn ensure_sdef<R: Real>(&mut self, dev: &GpuDevice, blocks: usize, contacts: usize) -> Result<bool, GpuError> {
        let mut made = false;
        for (slot, label, item, count) in [
            (&mut self.sdefs, "simply-deformable blocks", std::mem::size_of::<Sdef<R>>(), blocks),
            (&mut self.contact_levers, "contact levers", std::mem::size_of::<ContactLever<R>>(), contacts),
        ] {
            if slot.as_ref().is_none_or(|s| s.capacity < count.max(1)) {
                ensure_slot(dev, slot, label, item, count)?;
                made = true;
            }
        }
        Ok(made)
    }

    /// Makes sure the FDEF slots hold `gridpoints` grid points and `zones` zones exactly (their
    /// old contents not kept), `blocks` block records, `csr` grid-point zone words and
    /// `contacts` shares; returns whether one was re-created (the bind groups must then be
    /// rebuilt).
    pub fn ensure_fdef<R: Real>(&mut self, dev: &GpuDevice, sizes: FdefSizes) -> Result<bool, GpuError> {
        let mut made = false;
        for (slot, label, item, count) in [
            (&mut self.gridpoints, "grid points", std::mem::size_of::<GridPoint<R>>(), sizes.gridpoints),
            (&mut self.zones, "zones", std::mem::size_of::<Zone<R>>(), sizes.zones),
        ] {
            if slot.as_ref().is_none_or(|s| s.capacity != count.max(1)) {
                *slot = None;
                *slot = Some(exact_slab(dev, label, item, count)?);
                made = true;
            }
        }
        for (slot, label, item, count) in [
            (&mut self.fdef_blocks, "fully-deformable blocks", std::mem::size_of::<FdefBlock<R>>(), sizes.blocks),
            (&mut self.gridpoint_zones, "grid-point zones", 4, sizes.csr),
            (&mut self.contact_shares, "contact shares", std::mem::size_of::<ContactShare<R>>(), sizes.contacts),
        ] {
            if slot.as_ref().is_none_or(|s| s.capacity < count.max(1)) {
                ensure_slot(dev, slot, label, item, count)?;
                made = true;
            }
        }
        Ok(made)
    }

    /// Makes sure the fluid's slots hold what `sizes` asks (their old contents not kept), its
    /// uniforms made; returns whether one was (re-)created (the bind groups must then be
    /// rebuilt).
    pub fn ensure_fluid<R: Real>(&mut self, dev: &GpuDevice, sizes: FluidSizes) -> Result<bool, GpuError> {
        let mut made = false;
        if self.fluid_params.is_none() {
            self.fluid_params = Some(uniform_buffer(dev, "fluid params", std::mem::size_of::<FluidParams<R>>()));
            self.fluid_materials = Some(uniform_buffer(dev, "fluid materials", crate::udec::model::MAX_MATERIALS * std::mem::size_of::<FluidMaterial<R>>()));
            made = true;
        }
        for (slot, label, item, count) in [
            (&mut self.domains, "domains", std::mem::size_of::<Domain<R>>(), sizes.domains),
            (&mut self.domain_flows, "domain flows", 4, sizes.flows),
            (&mut self.domain_links, "domain links", 16, sizes.links),
            (&mut self.contact_sides, "contact domains", 8, sizes.contacts),
            (&mut self.contact_flows, "contact flows", std::mem::size_of::<ContactFlow<R>>(), sizes.contacts),
            (&mut self.fluid_loads, "fluid loads", std::mem::size_of::<FluidLoad<R>>(), sizes.blocks),
            (&mut self.domain_terms, "domain terms", std::mem::size_of::<R>(), 2 * sizes.links + sizes.flows),
            (&mut self.term_items, "domain term items", 16, sizes.term_items),
        ] {
            if slot.as_ref().is_none_or(|s| s.capacity < count.max(1)) {
                ensure_slot(dev, slot, label, item, count.max(1))?;
                made = true;
            }
        }
        Ok(made)
    }

    /// Makes sure the summaries buffer holds `count` contacts.
    /// Room for the slots of fluid with deformable blocks (`WetDeformableSizes`); whether one
    /// was re-created.
    pub fn ensure_wet_deformable<R: Real>(&mut self, dev: &GpuDevice, sizes: WetDeformableSizes) -> Result<bool, GpuError> {
        let mut made = false;
        for (slot, label, item, count) in [
            (&mut self.fluid_pieces, "fluid pieces", std::mem::size_of::<FluidPiece<R>>(), sizes.links),
            (&mut self.block_pieces, "block pieces", 4, sizes.csr),
            (&mut self.block_fluid, "block fluid loads", std::mem::size_of::<BlockFluid<R>>(), sizes.blocks),
            (&mut self.gridpoint_fluid, "grid-point fluid loads", std::mem::size_of::<GridPointFluid<R>>(), sizes.gridpoints),
            (&mut self.corner_moves, "corner moves", std::mem::size_of::<CornerMove<R>>(), sizes.corners),
        ] {
            if slot.as_ref().is_none_or(|s| s.capacity < count.max(1)) {
                ensure_slot(dev, slot, label, item, count.max(1))?;
                made = true;
            }
        }
        Ok(made)
    }

    pub fn ensure_summaries<R: Real>(&mut self, dev: &GpuDevice, count: usize) -> Result<(), GpuError> {
        ensure_slot(dev, &mut self.summaries, "contact summaries", std::mem::size_of::<ContactSummary<R>>(), count)
    }

    /// Makes sure the spare adjacency entries hold `count` (its contents are not kept).
    pub fn ensure_spare_entries(&mut self, dev: &GpuDevice, count: usize) -> Result<(), GpuError> {
        ensure_slot(dev, &mut self.spare_entries, "adjacency entries (spare)", 4, count)
    }

    /// Makes sure the spare lever buffer holds `count` records.
    pub fn ensure_spare_levers<R: Real>(&mut self, dev: &GpuDevice, count: usize) -> Result<(), GpuError> {
        ensure_slot(dev, &mut self.spare_levers, "contact levers (spare)", std::mem::size_of::<super::layout::ContactLever<R>>(), count)
    }

    /// The spare levers become the live ones (after `Engine::splice_levers` wrote into them).
    pub fn swap_levers(&mut self) {
        let levers = self.spare_levers.take().expect("spare levers to swap in");
        self.spare_levers = self.contact_levers.replace(levers);
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
                wgpu::BindGroupEntry { binding: 15, resource: self.dispatch_args.as_entire_binding() },
            ],
        })
    }

    /// The buffer of a state slot.
    pub fn slot(&self, slot: StateSlot) -> &wgpu::Buffer {
        match slot {
            StateSlot::Params => &self.params,
            StateSlot::Blocks => &self.blocks.buffer,
            StateSlot::Corners => &self.corners.buffer,
            StateSlot::Contacts => &self.contacts.buffer,
            StateSlot::Materials => &self.materials,
            StateSlot::AdjOffsets => &self.adj_offsets.buffer,
            StateSlot::AdjEntries => &self.adj_entries.buffer,
            StateSlot::Flags => &self.flags,
            StateSlot::ContactForces => &self.contact_forces.buffer,
            StateSlot::EnergySums => &self.energy_sums.buffer,
            StateSlot::Sdefs => &self.sdefs.as_ref().expect("the SDEF kernels are bound only in a scene with SDEF blocks").buffer,
            StateSlot::ContactLevers => &self.contact_levers.as_ref().expect("the SDEF kernels are bound only in a scene with SDEF blocks").buffer,
            StateSlot::GridPoints => &self.gridpoints.as_ref().expect(FDEF_ONLY).buffer,
            StateSlot::Zones => &self.zones.as_ref().expect(FDEF_ONLY).buffer,
            StateSlot::FdefBlocks => &self.fdef_blocks.as_ref().expect(FDEF_ONLY).buffer,
            StateSlot::GridPointZones => &self.gridpoint_zones.as_ref().expect(FDEF_ONLY).buffer,
            StateSlot::ContactShares => &self.contact_shares.as_ref().expect(FDEF_ONLY).buffer,
            StateSlot::FluidParams => self.fluid_params.as_ref().expect(FLUID_ONLY),
            StateSlot::FluidMaterials => self.fluid_materials.as_ref().expect(FLUID_ONLY),
            StateSlot::Domains => &self.domains.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::DomainFlows => &self.domain_flows.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::DomainLinks => &self.domain_links.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::ContactSides => &self.contact_sides.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::ContactFlows => &self.contact_flows.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::FluidLoads => &self.fluid_loads.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::DomainTerms => &self.domain_terms.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::TermItems => &self.term_items.as_ref().expect(FLUID_ONLY).buffer,
            StateSlot::FluidPieces => &self.fluid_pieces.as_ref().expect(WET_DEFORMABLE_ONLY).buffer,
            StateSlot::BlockPieces => &self.block_pieces.as_ref().expect(WET_DEFORMABLE_ONLY).buffer,
            StateSlot::BlockFluid => &self.block_fluid.as_ref().expect(WET_DEFORMABLE_ONLY).buffer,
            StateSlot::GridPointFluid => &self.gridpoint_fluid.as_ref().expect(WET_DEFORMABLE_ONLY).buffer,
            StateSlot::CornerMoves => &self.corner_moves.as_ref().expect(WET_DEFORMABLE_ONLY).buffer,
        }
    }

    /// The bind group of one cycle kernel: the buffers of the slots it uses, nothing else.
    pub fn kernel_bind_group(&self, dev: &GpuDevice, kernel: &CycleKernel, label: &str) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> =
            kernel.slots.iter().map(|&s| wgpu::BindGroupEntry { binding: s.binding(), resource: self.slot(s).as_entire_binding() }).collect();
        dev.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout: &kernel.layout, entries: &entries })
    }
}

const FDEF_ONLY: &str = "the FDEF kernels are bound only in a scene with zoned blocks";
const FLUID_ONLY: &str = "the fluid's kernels are bound only in a scene with fluid";
const WET_DEFORMABLE_ONLY: &str = "the kernels of fluid with deformable blocks are bound only in a scene with both";

/// How many of each slot of fluid with deformable blocks a scene needs
/// (`Buffers::ensure_wet_deformable`): domain links (one piece each), CSR words of the blocks'
/// pieces, blocks, grid points (0 without zoned blocks).
#[derive(Clone, Copy, Debug, Default)]
pub struct WetDeformableSizes {
    pub links: usize,
    pub csr: usize,
    pub blocks: usize,
    pub gridpoints: usize,
    pub corners: usize,
}

/// How many of each fluid slot's items a scene needs (`Buffers::ensure_fluid`): domains, domain
/// flow words, domain links, contacts, blocks.
#[derive(Clone, Copy, Debug, Default)]
pub struct FluidSizes {
    pub domains: usize,
    pub flows: usize,
    pub links: usize,
    pub contacts: usize,
    pub blocks: usize,
    /// `domain_terms`' items (`gpu::flow::TermItems`).
    pub term_items: usize,
}

/// How many of each FDEF slot's items a scene needs (`Buffers::ensure_fdef`).
#[derive(Clone, Copy, Debug, Default)]
pub struct FdefSizes {
    pub gridpoints: usize,
    pub zones: usize,
    pub blocks: usize,
    pub csr: usize,
    pub contacts: usize,
}

/// A storage buffer of exactly `count` items (at least one), for the slots whose kernels take
/// their length from `arrayLength`.
fn exact_slab(dev: &GpuDevice, label: &str, item: usize, count: usize) -> Result<Slab, GpuError> {
    let cap = binding_cap(dev);
    check_fits(label, item, count, cap, dev.precision)?;
    let capacity = count.max(1);
    let buffer = dev.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (capacity * item) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    Ok(Slab { buffer, capacity })
}

/// The grids of the cycle's indirect dispatches, in the order of `Buffers::dispatch_args`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grid {
    Blocks,
    Contacts,
    HeavyBlocks,
    /// Scenes with zoned blocks: one invocation per grid point, per zone.
    GridPoints,
    Zones,
    /// Scenes with fluid: one invocation per domain (`domain_pressures`), per item of
    /// `domain_terms`.
    Domains,
    /// Scenes with zoned blocks: one workgroup per zoned block of many boundary grid points
    /// (`place_fdef_corners`).
    BlockGroups,
    DomainTerms,
}

impl Grid {
    pub const ALL: [Grid; 8] =
        [Grid::Blocks, Grid::Contacts, Grid::HeavyBlocks, Grid::GridPoints, Grid::Zones, Grid::Domains, Grid::BlockGroups, Grid::DomainTerms];

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
