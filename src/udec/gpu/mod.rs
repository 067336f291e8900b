//! The GPU backend (wgpu; DESIGN.md §1–3): stages 1, 2, 4 and 6 as compute kernels, stage 7 on the
//! CPU between batches of cycles.
//!
//! - `device`: adapters, device set-up with the adapter's own limits, bounded waits.
//! - `layout`: the Pod structs of the GPU state, twins of `shaders/udec/layout.wgsl`.
//! - `shaders`: the WGSL prelude (the one precision alias) and naga validation.
//! - `kernels`: `Pipelines` (one per entry point) and `Buffers`.
//!
//! The `Engine` (one per precision) that drives them, in the order of a run:
//! - `run`: `Backend::run_into` — set-up or resumption, batches, contact updates, the energy check,
//!   the failure paths.
//! - `upload`: host to device, whole at the start and only what a contact update changed after.
//! - `batch`: batches of cycles with no round trip, the flags after them, the energy sums.
//! - `partial`: stage 7 from what it touches: lists made on the device (`list_blocks.wgsl`),
//!   then only the blocks, corners and contacts the update reads.
//! - `splice`: the contact list after a contact update, built on the device from the old one.
//! - `checkpoint`: the last good state, a device-side copy taken when an energy check passes.
//! - `readback`: device to host, GPU records converted to the model's.
//! - `profile`: what `blockdem bench` asks besides cycles (stage times, bandwidth, bytes).
//! - `targets`: every adapter and precision present, the GPU rows of the scenario tests and of
//!   `blockdem verify`.
//!
//! ## How a run goes
//!
//! The model is uploaded once; then the GPU runs batches of cycles with no round trip inside a
//! batch: one compute pass per ten cycles, each cycle the dispatches `law_of_motion` (whose
//! invocations, as the CPU's block pass, first sum the forces the last contact stage left on
//! their block, stage 6, and after moving it run stage 2, `geometry_update`), `contact_forces`
//! and `end_cycle` (`gather_heavy` first where a free block has more than `HEAVY_DEGREE`
//! contacts), over two-dimensional grids that follow the live counts of blocks and contacts.
//! The `gather` kernel stores the sums on the blocks where they are read between cycles (a
//! read-back, the energy check).
//! Kernels raise flags (a block past the update tolerance, a non-finite step, a block too fast,
//! an overlap too great); `end_cycle` then halts the rest of the
//! batch, so the CPU sees exactly the state of the cycle that raised it, as the CPU backend would.
//! The cycle's kernels are dispatched indirectly from grids the CPU writes at the start of each
//! batch (`Buffers::dispatch_args`); halting zeroes them, so the cycles after a halt launch no
//! workgroups and no kernel reads the halt flag. Their dispatch commands are still encoded and
//! submitted, so after a contact update a batch is cut at the cycle where the next one is
//! expected at the velocities then (`cycles_to_next_update`).
//! After a batch the CPU reads back the flags only. When stage 7 is due, `list_blocks` and
//! `list_contacts` list on the device the blocks near their update threshold or strayed from the
//! kept grid and the contacts near btol; the CPU reads the lists, those blocks (records and
//! corners) and contacts, then the neighbourhoods of the blocks it re-examines, and runs the
//! update on that (`partial_contact_update`): a contact update of the 10⁴- and 10⁵-block walls
//! struck by the projectile reads 20–60 kB, where the packed whole state is 6 and 67 MB. The
//! whole state is read back (the blocks, the corners and a
//! summary of each contact, `pack_contacts`) when the update sweeps the grid (many blocks
//! re-examined), every cycle in scenes with point-load cracking candidates (the criterion is
//! evaluated by the existing CPU code on the read-back contacts, read whole), after a failure
//! and at the end of the run; between, the model is current only where it was read. The CPU runs
//! the existing CPU topology code on the `Model` and sends only what changed: after a contact
//! update, the update's own edit of the list as runs (`detect::ListEdit`), the contacts created
//! and a patch (index, feature) per kept contact it read, from which `splice_contacts` builds the
//! new list and gather records on the device (`splice`; the whole list is uploaded when the
//! update had to sort it), the edit of the adjacency lists when a contact was created or dropped
//! (`splice_adjacency`: the touched blocks' new lists and the renumbering), and the reset update
//! distances of the re-examined blocks; everything after a crack split a block. The
//! energy check every 100 cycles is summed on the device (`energy_sums`), and the last good state is a device-side copy of the state
//! buffers taken when a check passes (`take_checkpoint`), read back only if the run fails.
//!
//! ## The energy ledger
//!
//! The kernels book every term of `Model::energies()` with the CPU's formulas: external work and
//! mass-damping work per block (`law_of_motion`), slip and dashpot work per contact
//! (`contact_forces`, with the dashpot velocities carried to the next step). Each accumulates from
//! zero since its buffer was uploaded, in the kernel's `real`; the CPU adds the f64 value of the
//! model at upload on every read-back. So an f32 sum runs only between two uploads of one element,
//! and the model keeps the terms across contact updates (they live on the contacts the topology
//! stage matches by corner and block) and re-uploads.
//!
//! ## Precision
//!
//! f32 by default; f64 where the adapter has `SHADER_F64` (lavapipe does), by one alias in the
//! prelude. f32 keeps geometry relative to block centroids: corner offsets are body-frame and
//! rotated per block, contact points are stored relative to block 2's centroid, centroids are kept
//! relative to an origin near the model as compensated (hi, lo) pairs, so f32 keeps millimetres far
//! from the origin and small steps are not lost on large coordinates. f64 kernels use only the
//! operators + − × ÷ and sqrt, abs, min, max: the rotation's cos/sin come from the block's
//! rotation angle (the same state the CPU keeps) by range reduction and a Taylor polynomial
//! (`sin_cos` in common.wgsl), not from a drifting product of rotation increments.

/// `$body` on the engine of either precision, bound to `$e` (the two arms are the same code,
/// compiled for each `Real`).
macro_rules! on_engine {
    ($engine:expr, $e:ident => $body:expr) => {
        match $engine {
            $crate::udec::gpu::EngineAny::F32($e) => $body,
            $crate::udec::gpu::EngineAny::F64($e) => $body,
        }
    };
}

mod batch;
mod checkpoint;
pub mod fdef;
pub mod flow;
pub mod kernels;
pub mod layout;
pub mod partial;
pub mod profile;
mod readback;
mod run;
mod sdef;
pub mod shaders;
pub mod splice;
pub mod targets;
mod upload;

use crate::udec::backend::{Backend, CycleError, CycleReport};
use crate::udec::model::Model;
use crate::udec::topology::Topology;
use std::sync::Arc;

pub use crate::gpu::{device, list_adapters, matching_adapters, AdapterChoice, AdapterSummary, GpuApi, GpuDevice, GpuError, Precision};
use checkpoint::{Checkpoint, ContactIdentity};
use kernels::{Buffers, Pipelines};
use layout::{Block, Real};
pub use partial::{PartialReads, PARTIAL_READ_MIN_BYTES};
pub use targets::{find_target, scenario_backends, GpuTarget};
pub use upload::AdjacencyEdits;

/// How to pick the GPU and precision.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuOptions {
    pub adapter: AdapterChoice,
    pub precision: Precision,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions { adapter: AdapterChoice::Any, precision: Precision::F32 }
    }
}

/// The wgpu backend behind the `Backend` trait.
pub struct GpuBackend {
    engine: EngineAny,
}

enum EngineAny {
    F32(Engine<f32>),
    F64(Engine<f64>),
}

impl GpuBackend {
    /// Opens a device and builds the pipelines; errors (no adapter, no f64, a rejected kernel)
    /// are values.
    pub fn new(options: &GpuOptions) -> Result<Self, GpuError> {
        let dev = GpuDevice::open(&options.adapter, options.precision)?;
        let pipelines = Pipelines::new(&dev)?;
        let engine = match options.precision {
            Precision::F32 => EngineAny::F32(Engine::new(dev, pipelines)),
            Precision::F64 => EngineAny::F64(Engine::new(dev, pipelines)),
        };
        let mut backend = GpuBackend { engine };
        // BLOCKDEM_CONTACT_SPLICE=0: the whole list uploaded at each contact update, the baseline
        // the splice is measured against (docs/BENCHMARKS.md).
        if std::env::var("BLOCKDEM_CONTACT_SPLICE").is_ok_and(|v| v == "0") {
            backend.set_contact_splice(false);
        }
        // BLOCKDEM_PARTIAL_READS=0: contact updates read the whole state back (the baseline the
        // partial read-back is measured and tested against); =1: partly on every model.
        match std::env::var("BLOCKDEM_PARTIAL_READS").as_deref() {
            Ok("0") => backend.set_partial_reads(PartialReads::Never),
            Ok("1") => backend.set_partial_reads(PartialReads::Always),
            _ => {}
        }
        // BLOCKDEM_ADJACENCY_EDIT=1: the adjacency lists edited on the device on any adapter;
        // =0: uploaded whole at every structural update.
        match std::env::var("BLOCKDEM_ADJACENCY_EDIT").as_deref() {
            Ok("0") => backend.set_adjacency_edits(AdjacencyEdits::Never),
            Ok("1") => backend.set_adjacency_edits(AdjacencyEdits::Always),
            _ => {}
        }
        Ok(backend)
    }

    /// Where structural contact updates change the adjacency lists (`AdjacencyEdits::Auto` by
    /// default: on the device, but for a software adapter).
    pub fn set_adjacency_edits(&mut self, on: AdjacencyEdits) {
        on_engine!(&mut self.engine, e => e.adjacency_edits = on)
    }

    /// How many structural contact updates edited the adjacency lists on the device so far.
    pub fn adjacency_edit_count(&self) -> u64 {
        on_engine!(&self.engine, e => e.adjacency_edit_count)
    }

    /// When contact updates read back only the blocks, corners and contacts they touch
    /// (`gpu::partial`; needs the splice) rather than the whole state (`PartialReads::Large` by
    /// default).
    pub fn set_partial_reads(&mut self, on: PartialReads) {
        on_engine!(&mut self.engine, e => e.partial_reads = on)
    }

    /// Bytes read back from the device so far (whole and partial read-backs, lists, flags).
    pub fn bytes_read(&self) -> u64 {
        on_engine!(&self.engine, e => e.dev.bytes_read())
    }

    /// How many contact updates read back only what they touched so far.
    pub fn partial_updates(&self) -> u64 {
        on_engine!(&self.engine, e => e.partial_updates)
    }

    pub fn adapter(&self) -> &AdapterSummary {
        on_engine!(&self.engine, e => &e.dev.summary)
    }

    /// The energy check's sums of the state on the device, as `energy_sums.wgsl` takes them:
    /// (kinetic, strain, external work). After a `run` the device holds the state the model was
    /// given back, so these are the twin of `Model::energies` on it.
    pub fn energy_sums(&self) -> Result<(f64, f64, f64), GpuError> {
        on_engine!(&self.engine, e => e.energy_sums())
    }

    /// Whether contact updates build the new list on the device from the old one (the default)
    /// or upload it whole, as before the splice (kept to measure the splice against, and to
    /// test that both give the same run).
    pub fn set_contact_splice(&mut self, on: bool) {
        on_engine!(&mut self.engine, e => e.splice = on)
    }

    /// How many contact updates were spliced on the device so far (the others uploaded the list).
    pub fn contact_splices(&self) -> u64 {
        on_engine!(&self.engine, e => e.splices)
    }

    pub fn precision(&self) -> Precision {
        match &self.engine {
            EngineAny::F32(_) => Precision::F32,
            EngineAny::F64(_) => Precision::F64,
        }
    }
}

impl Backend for GpuBackend {
    fn describe(&self) -> String {
        let a = self.adapter();
        format!("gpu ({}, {} [{}], {})", a.backend, a.name, a.driver_name(), self.precision())
    }

    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        on_engine!(&mut self.engine, e => e.run_into(model, cycles, progress, report))
    }
}

fn device_error(e: GpuError) -> CycleError {
    match e {
        GpuError::DoesNotFit(_) => CycleError::DoesNotFit(e.to_string()),
        _ => CycleError::Setup(e.to_string()),
    }
}

/// What the GPU's accumulators count from: the model's values when the state was uploaded (see
/// "The energy ledger" above), and the origin the f32 centroids are relative to. Shared with the
/// checkpoint taken under it, so a checkpoint costs no copy of these; each list is shared on its
/// own, so that a change of one (a contact update's bases) copies none of the others, and a list
/// the checkpoint still shares is replaced, never copied to be edited (`edit_contact_list`).
#[derive(Clone, Debug, Default)]
struct Uploaded {
    /// The model origin the GPU centroids are relative to.
    origin: [f64; 2],
    /// `Model::external_work` when the block buffer was last uploaded (its `work` fields count
    /// from there).
    work_base: f64,
    /// Each block's `damping_work` when the block buffer was last uploaded, and each contact's
    /// `slip_work` and `dashpot_work` when the contact buffer was: the GPU accumulates from zero
    /// in its `real` (a short sum per element, so f32 keeps its digits) and the CPU adds these
    /// f64 bases back on read-back.
    damping_base: Arc<Vec<f64>>,
    contact_base: Arc<Vec<[f64; 2]>>,
    /// Each simply-deformable block's internal damping work (`Sdef::damping_work`) at the
    /// upload of the SDEF slot (0 for the others; empty in a rigid scene).
    sdef_damping_base: Arc<Vec<f64>>,
    /// Each zoned block's mass damping work (`Fdef::damping_work`) at the upload of the FDEF
    /// slots (0 for the others; empty in a scene without zoned blocks).
    fdef_damping_base: Arc<Vec<f64>>,
    /// The fluid's ledger work and inflow (`Fluid::work`, `Fluid::inflow`) at the upload of the
    /// fluid's slots (the device counts from zero since; 0 in a dry scene).
    fluid_base: [f64; 2],
}

/// The GPU state of one precision and the code that drives it.
struct Engine<R: Real> {
    dev: GpuDevice,
    pipelines: Pipelines,
    buffers: Option<Buffers>,
    /// Each cycle kernel's bindings (`kernels::CycleBindGroups`), made with the buffers.
    bind_groups: Option<kernels::CycleBindGroups>,
    /// `end_cycle`'s bindings (`Buffers::end_cycle_bind_group`), made with the buffers.
    end_cycle_bind_group: Option<wgpu::BindGroup>,
    uploaded: std::rc::Rc<Uploaded>,
    /// Counts uploads of the contact list (any topology change): the CPU copy of the last good
    /// state must be re-taken when it changed since the checkpoint.
    generation: u64,
    /// Counts uploads of the whole model (blocks and corners too: a run's start, a crack): when
    /// only `generation` moved, the last good state's copy takes the contacts' identities alone
    /// (`last_good_contacts`) and the model's scalars; a restore takes the blocks', corners' and
    /// contacts' state from the device checkpoint.
    block_generation: u64,
    /// The last good state's contact list when it is newer than the copy's own (Some after a
    /// contact update since the last whole copy): identities only.
    last_good_contacts: Option<Vec<ContactIdentity>>,
    checkpoint: Option<Checkpoint>,
    /// The block buffer as last read back (to see which update distances stage 7 reset).
    last_blocks: Vec<Block<R>>,
    /// The scene has simply-deformable blocks: the cycle runs the SDEF kernels (`sdef`).
    sdef_scene: bool,
    /// The SDEF slot as last uploaded or read back (to reset the update strains).
    last_sdefs: Vec<layout::Sdef<R>>,
    /// The scene has zoned fully-deformable blocks: the cycle runs the FDEF kernels (`fdef`).
    fdef_scene: bool,
    /// Grid points and zones on the device (0 in a scene without zoned blocks).
    fdef_counts: (usize, usize),
    /// Each block's first grid point on the device (`layout::NO_INDEX` where it is not zoned).
    fdef_gp_start: Vec<u32>,
    /// Zoned blocks whose corners a workgroup each places (`fdef::WIDE_BOUNDARY`).
    fdef_wide: usize,
    /// The grid points as last uploaded or read back (to reset their update positions).
    last_gridpoints: Vec<layout::GridPoint<R>>,
    /// The scene has fluid: the cycle runs the fluid's kernels (`flow`).
    fluid_scene: bool,
    /// Domains on the device (0 in a dry scene), and the items of `domain_terms` (`gpu::flow`).
    n_domains: usize,
    n_term_items: usize,
    counts: (usize, usize, usize),
    /// Blocks gathered by `gather_heavy` (more than `HEAVY_DEGREE` contacts), and how many of
    /// them (listed first) are free: a cycle skips fixed blocks, so it dispatches only those.
    n_heavy: usize,
    n_heavy_free: usize,
    /// Contact updates splice the list on the device (`splice_contacts`) rather than upload it.
    splice: bool,
    /// Contact updates spliced on the device since the backend was made.
    splices: u64,
    /// The model's contact list is in the contact update's order (block 1, corner, block 2), as
    /// every update leaves it: the next update then records its edit (`detect::ListEdit`), which
    /// the splice follows. Cleared when something else (a crack) changed the list.
    list_in_order: bool,
    /// When contact updates read back only the blocks, corners and contacts they touch
    /// (`partial_contact_update`), if the splice is on.
    partial_reads: PartialReads,
    /// Contact updates made that way since the backend was made.
    partial_updates: u64,
    /// Where structural contact updates change the adjacency lists.
    adjacency_edits: AdjacencyEdits,
    /// Structural contact updates that edited the adjacency lists on the device.
    adjacency_edit_count: u64,
    /// The buffers of `list_blocks.wgsl` (made at the first partial update).
    lists: Option<partial::ListBuffers>,
    /// The uploaded contacts carry dashpot velocities whose work is still to be booked.
    dashpots_pending: bool,
    /// The CPU copy of the last good state, kept from run to run so that a run copies into its
    /// storage instead of allocating a second model.
    last_good: Model,
    /// The previous run ended well: `last_good` is the state it read back last, `topology` its
    /// contact lists, and the device holds that state. A run on a model still equal to it goes
    /// on from the device without detection, upload or read-back.
    resumable: bool,
    topology: Topology,
}

/// An f64 value in the kernel precision.
fn r<R: Real>(x: f64) -> R {
    R::from_f64(x)
}

impl<R: Real> Engine<R> {
    fn new(dev: GpuDevice, pipelines: Pipelines) -> Self {
        Engine {
            dev,
            pipelines,
            buffers: None,
            bind_groups: None,
            end_cycle_bind_group: None,
            uploaded: Default::default(),
            generation: 0,
            block_generation: 0,
            last_good_contacts: None,
            checkpoint: None,
            last_blocks: Vec::new(),
            sdef_scene: false,
            last_sdefs: Vec::new(),
            fdef_scene: false,
            fdef_counts: (0, 0),
            fdef_gp_start: Vec::new(),
            fdef_wide: 0,
            last_gridpoints: Vec::new(),
            fluid_scene: false,
            n_domains: 0,
            n_term_items: 0,
            counts: (0, 0, 0),
            n_heavy: 0,
            n_heavy_free: 0,
            splice: true,
            dashpots_pending: false,
            splices: 0,
            list_in_order: false,
            partial_reads: PartialReads::default(),
            partial_updates: 0,
            adjacency_edits: AdjacencyEdits::default(),
            adjacency_edit_count: 0,
            lists: None,
            last_good: Model::default(),
            resumable: false,
            topology: Topology::default(),
        }
    }

    fn buffers(&self) -> &Buffers {
        self.buffers.as_ref().expect("buffers are created by upload_all")
    }
}
