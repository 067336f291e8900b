//! The GPU backend (wgpu; DESIGN.md §1–3): stages 1, 2, 4 and 6 as compute kernels, stage 7 on the
//! CPU between batches of cycles.
//!
//! - `device`: adapters, device set-up with the adapter's own limits, bounded waits.
//! - `layout`: the Pod structs of the GPU state, twins of `shaders/layout.wgsl`.
//! - `shaders`: the WGSL prelude (the one precision alias) and naga validation.
//! - `kernels`: `Pipelines` (one per entry point) and `Buffers`.
//! - `splice`: the contact list after a contact update, built on the device from the old one.
//! - `partial`: what a contact update reads back: lists made on the device (`list_blocks.wgsl`),
//!   then only the blocks, corners and contacts the update touches.
//! - `targets`: every adapter and precision present, the GPU rows of the scenario tests and of
//!   `blockdem verify`.
//!
//! ## How a run goes
//!
//! The model is uploaded once; then the GPU runs batches of cycles with no round trip inside a
//! batch: one compute pass per ten cycles, each cycle the dispatches `law_of_motion` (whose
//! invocations also run stage 2, `geometry_update`, for the block they moved), `contact_forces`,
//! `gather` (and `gather_heavy` where a free block has more than `HEAVY_DEGREE` contacts),
//! `end_cycle`, over two-dimensional grids that follow the live counts of blocks and contacts.
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

pub mod device;
pub mod kernels;
pub mod layout;
pub mod profile;
pub mod shaders;
pub mod partial;
pub mod splice;
pub mod targets;

use crate::backend::{Backend, CycleError, CycleReport};
use crate::cpu;
use crate::model::{ContactKind, Model, MAX_MATERIALS};
use crate::topology::detect::ListEdit;
use crate::topology::Adjacency;
use rayon::prelude::*;

pub use device::{list_adapters, AdapterChoice, AdapterSummary, GpuApi, GpuDevice};
pub use targets::{find_target, scenario_backends, GpuTarget};
use kernels::{Buffers, Grid, Pipelines};
use layout::{Block, Contact, ContactForce, ContactSummary, Corner, EnergySum, Flags, ListParams, Material, Params, Real};

/// How many more cycles, at the velocities now, until the first block passes its contact-update
/// threshold (`Block::update_due`): the cycle that raises the flag, ⌊(threshold − moved)/s⌋ + 1 for
/// a block whose corners travel s a step. None when nothing moves.
fn cycles_to_next_update(model: &Model) -> Option<u64> {
    model.blocks.iter().filter_map(|b| cycles_to_threshold(model, b)).min()
}

/// `cycles_to_next_update` for one block (None: fixed, or not moving).
fn cycles_to_threshold(model: &Model, b: &crate::model::Block) -> Option<u64> {
    if b.fixed {
        return None;
    }
    let s = b.travel_per_step(model.timestep);
    let room = (b.update_threshold(&model.tol) - b.moved_since_update).max(0.0);
    (s > 0.0 && s.is_finite()).then(|| (room / s).floor().min(1e9) as u64 + 1)
}

/// When a contact update reads back only what it touches (`gpu::partial`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PartialReads {
    /// Never: every update reads the whole (packed) state back.
    Never,
    /// When the whole packed state is larger than `PARTIAL_READ_MIN_BYTES`.
    #[default]
    Large,
    /// On every model (the tests' way to run it on small ones).
    Always,
}

/// Below this many bytes of packed state (blocks, corners and contact summaries: ~1000 blocks in
/// f32 take 0.6 MB) a contact update reads it all back. The whole read is one round trip, which
/// the read of the state after the batch that stopped for the update already makes; a partial
/// read makes two or three (the lists, the items, the neighbourhoods). Measured on lavapipe on the
/// 10³-block wall struck by the projectile: 0.17 ms an update whole against 0.85 ms partly, a
/// run of 3000 cycles 11% faster; at 10⁴ blocks (6 MB) the two were even, and on a hardware GPU
/// the whole read also crosses the bus.
pub const PARTIAL_READ_MIN_BYTES: usize = 2 << 20;

/// What the device does not hold of a contact: its identity, material and constitutive model.
/// Between whole copies, the last good state keeps its contact list as these (24 bytes a contact
/// where a model contact takes 144); a restore rebuilds the contacts from them and fills in their
/// state from the device checkpoint (`Engine::restore_checkpoint`).
#[derive(Clone, Copy)]
struct ContactIdentity {
    id: u32,
    block1: u32,
    corner: u32,
    block2: u32,
    material: u32,
    constitutive: u32,
}

impl ContactIdentity {
    fn of(c: &crate::model::Contact) -> Self {
        ContactIdentity { id: c.id, block1: c.block1, corner: c.corner, block2: c.block2, material: c.material, constitutive: c.constitutive }
    }

    /// The contact with this identity, its state zero until a read-back fills it.
    fn contact(self) -> crate::model::Contact {
        let ContactIdentity { id, block1, corner, block2, material, constitutive } = self;
        crate::model::Contact::identity(id, block1, corner, block2, material, constitutive)
    }
}

/// What `Engine::partial_contact_update` did.
enum PartialUpdate {
    /// Nothing: the update needs the whole state (the caller reads it back as before).
    Declined,
    /// No block is past its threshold by the CPU's exact test: no update.
    NotDue,
    /// The update ran; the next one is expected after this many cycles.
    Updated(Option<u64>),
}

/// Kernel precision (`--precision`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Precision {
    #[default]
    F32,
    F64,
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        })
    }
}

/// Why the GPU backend could not start or went wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter: {0}")]
    NoAdapter(String),
    #[error("--precision f64 needs an adapter with SHADER_F64, and the adapter chosen ({0}) has none; use --precision f32 or a Vulkan adapter")]
    NoF64(String),
    #[error("GPU set-up: {0}")]
    Setup(String),
    /// A buffer the model needs is past the adapter's binding limit (`kernels::check_fits`).
    #[error("GPU set-up: {0}")]
    TooLarge(String),
    #[error("GPU shader: {0}")]
    Shader(String),
    #[error("GPU device: {0}")]
    Device(String),
}

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
        Ok(backend)
    }

    /// When contact updates read back only the blocks, corners and contacts they touch
    /// (`gpu::partial`; needs the splice) rather than the whole state (`PartialReads::Large` by
    /// default).
    pub fn set_partial_reads(&mut self, on: PartialReads) {
        match &mut self.engine {
            EngineAny::F32(e) => e.partial_reads = on,
            EngineAny::F64(e) => e.partial_reads = on,
        }
    }

    /// Bytes read back from the device so far (whole and partial read-backs, lists, flags).
    pub fn bytes_read(&self) -> u64 {
        match &self.engine {
            EngineAny::F32(e) => e.dev.bytes_read(),
            EngineAny::F64(e) => e.dev.bytes_read(),
        }
    }

    /// How many contact updates read back only what they touched so far.
    pub fn partial_updates(&self) -> u64 {
        match &self.engine {
            EngineAny::F32(e) => e.partial_updates,
            EngineAny::F64(e) => e.partial_updates,
        }
    }

    pub fn adapter(&self) -> &AdapterSummary {
        match &self.engine {
            EngineAny::F32(e) => &e.dev.summary,
            EngineAny::F64(e) => &e.dev.summary,
        }
    }

    /// The energy check's sums of the state on the device, as `energy_sums.wgsl` takes them:
    /// (kinetic, strain, external work). After a `run` the device holds the state the model was
    /// given back, so these are the twin of `Model::energies` on it.
    pub fn energy_sums(&self) -> Result<(f64, f64, f64), GpuError> {
        match &self.engine {
            EngineAny::F32(e) => e.energy_sums(),
            EngineAny::F64(e) => e.energy_sums(),
        }
    }

    /// Whether contact updates build the new list on the device from the old one (the default)
    /// or upload it whole, as before the splice (kept to measure the splice against, and to
    /// test that both give the same run).
    pub fn set_contact_splice(&mut self, on: bool) {
        match &mut self.engine {
            EngineAny::F32(e) => e.splice = on,
            EngineAny::F64(e) => e.splice = on,
        }
    }

    /// How many contact updates were spliced on the device so far (the others uploaded the list).
    pub fn contact_splices(&self) -> u64 {
        match &self.engine {
            EngineAny::F32(e) => e.splices,
            EngineAny::F64(e) => e.splices,
        }
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
        format!("gpu ({}, {} [{}], {})", a.backend, a.name, a.driver, self.precision())
    }

    fn run(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool) -> Result<CycleReport, CycleError> {
        match &mut self.engine {
            EngineAny::F32(e) => e.run(model, cycles, progress),
            EngineAny::F64(e) => e.run(model, cycles, progress),
        }
    }
}

fn device_error(e: GpuError) -> CycleError {
    match e {
        GpuError::TooLarge(_) => CycleError::TooLarge(e.to_string()),
        _ => CycleError::Setup(e.to_string()),
    }
}

/// What the GPU's accumulators count from: the model's values when the state was uploaded (see
/// "The energy ledger" above), and the origin the f32 centroids are relative to. Shared with the
/// checkpoint taken under it, so a checkpoint costs no copy of these.
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
    damping_base: Vec<f64>,
    contact_base: Vec<[f64; 2]>,
}

/// The last good state on the device: copies of the state buffers taken right after an energy
/// check passed (device-to-device, no read-back), with the counts and bases they were taken
/// under. The CPU side of the checkpoint (topology, ids) is the `Model` the run keeps.
struct Checkpoint {
    blocks: wgpu::Buffer,
    corners: wgpu::Buffer,
    contacts: wgpu::Buffer,
    /// The contacts' gather records (their forces).
    forces: wgpu::Buffer,
    counts: (usize, usize, usize),
    uploaded: std::rc::Rc<Uploaded>,
    /// Whether it holds a state of the current run (the buffers are kept from run to run: a
    /// 10⁶-block model's copy is a gigabyte to allocate).
    valid: bool,
}

/// The GPU state of one precision and the code that drives it.
struct Engine<R: Real> {
    dev: GpuDevice,
    pipelines: Pipelines,
    buffers: Option<Buffers>,
    bind_group: Option<wgpu::BindGroup>,
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
    /// The buffers of `list_blocks.wgsl` (made at the first partial update).
    lists: Option<partial::ListBuffers>,
    /// The uploaded contacts carry dashpot velocities whose work is still to be booked.
    dashpots_pending: bool,
    /// The CPU copy of the last good state, kept from run to run so that a run copies into its
    /// storage instead of allocating a second model.
    last_good: Model,
    /// The previous run ended well: `last_good` is the state it read back last, `adjacency` its
    /// contact lists, and the device holds that state. A run on a model still equal to it goes
    /// on from the device without detection, upload or read-back.
    resumable: bool,
    adjacency: Adjacency,
}

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
const CYCLES_PER_SUBMIT: u64 = 10;

fn r<R: Real>(x: f64) -> R {
    R::from_f64(x)
}

/// Mapped bytes as GPU structs: in place when aligned (parts of a read-back start 16-byte
/// aligned), else copied.
fn pod_view<T: bytemuck::Pod>(bytes: &[u8]) -> std::borrow::Cow<'_, [T]> {
    match bytemuck::try_cast_slice(bytes) {
        Ok(items) => std::borrow::Cow::Borrowed(items),
        Err(_) => std::borrow::Cow::Owned(bytemuck::pod_collect_to_vec(bytes)),
    }
}

/// The checkpoint's buffers, as `read_state` reads them (the live state is read by
/// `read_live_state`, which may pack its contacts).
struct StateBuffers<'a> {
    blocks: &'a wgpu::Buffer,
    corners: &'a wgpu::Buffer,
    contacts: &'a wgpu::Buffer,
    /// The contacts' gather records, which hold their forces.
    forces: &'a wgpu::Buffer,
    counts: (usize, usize, usize),
}

impl<R: Real> Engine<R> {
    fn new(dev: GpuDevice, pipelines: Pipelines) -> Self {
        Engine {
            dev,
            pipelines,
            buffers: None,
            bind_group: None,
            end_cycle_bind_group: None,
            uploaded: Default::default(),
            generation: 0,
            block_generation: 0,
            last_good_contacts: None,
            checkpoint: None,
            last_blocks: Vec::new(),
            counts: (0, 0, 0),
            n_heavy: 0,
            n_heavy_free: 0,
            splice: true,
            dashpots_pending: false,
            splices: 0,
            list_in_order: false,
            partial_reads: PartialReads::default(),
            partial_updates: 0,
            lists: None,
            last_good: Model::default(),
            resumable: false,
            adjacency: Adjacency::default(),
        }
    }

    fn buffers(&self) -> &Buffers {
        self.buffers.as_ref().expect("buffers are created by upload_all")
    }

    fn gpu_contact(model: &Model, c: &crate::model::Contact) -> Contact<R> {
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
            block1: c.block1,
            corner: c.corner,
            block2: c.block2,
            feature: c.feature,
            material: (c.material.max(1) as usize - 1).min(MAX_MATERIALS - 1) as u32,
            bonded: c.bonded as u32,
        }
    }

    /// The gather's record of a contact, from the model (after a topology change): the force on
    /// block 1 and both moments, as `contact_forces` computes them.
    fn gpu_contact_force(model: &Model, c: &crate::model::Contact) -> ContactForce<R> {
        let (c1, c2) = (model.blocks[c.block1 as usize].centroid, model.blocks[c.block2 as usize].centroid);
        let [fx, fy] = c.force;
        let (r1, r2) = ([c.point[0] - c1[0], c.point[1] - c1[1]], [c.point[0] - c2[0], c.point[1] - c2[1]]);
        ContactForce { fx: r(fx), fy: r(fy), m: [r(r1[0] * fy - r1[1] * fx), r(r2[1] * fx - r2[0] * fy)] }
    }

    /// Uploads the whole model (start of a run, or after a crack split a block).
    fn upload_all(&mut self, model: &Model, adjacency: &Adjacency) -> Result<(), GpuError> {
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
        let uploaded = Uploaded { origin, work_base: model.external_work, damping_base: model.blocks.iter().map(|b| b.damping_work).collect(), contact_base: Vec::new() };
        let blocks: Vec<Block<R>> = model
            .blocks
            .par_iter()
            .with_min_len(4096)
            .map(|b| {
                let (x, y) = (b.centroid[0] - origin[0], b.centroid[1] - origin[1]);
                let (hx, hy) = (r::<R>(x), r::<R>(y));
                let (x0, y0) = (b.update_centroid[0] - origin[0], b.update_centroid[1] - origin[1]);
                let (ux, uy) = (r::<R>(x0), r::<R>(y0));
                Block {
                    cx: hx,
                    cy: hy,
                    cx_lo: r(x - hx.to_f64()),
                    cy_lo: r(y - hy.to_f64()),
                    rotation: r(b.rotation),
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
                    _pad: 0,
                }
            })
            .collect();
        let corners: Vec<Corner<R>> = model
            .corners
            .par_iter()
            .with_min_len(4096)
            .map(|c| {
                let cen = model.blocks[c.block as usize].centroid;
                Corner {
                    lx: r(c.local[0]),
                    ly: r(c.local[1]),
                    qx: r(c.circle_local[0]),
                    qy: r(c.circle_local[1]),
                    radius: r(c.radius),
                    round: r(c.round),
                    px: r(c.position[0] - cen[0]),
                    py: r(c.position[1] - cen[1]),
                    ox: r(c.circle[0] - cen[0]),
                    oy: r(c.circle[1] - cen[1]),
                }
            })
            .collect();
        let mut materials = vec![Material::<R>::default(); MAX_MATERIALS];
        for (g, m) in materials.iter_mut().zip(&model.materials) {
            *g = Material { kn: r(m.kn), ks: r(m.ks), cohesion: r(m.cohesion), friction: r(m.friction) };
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
            self.bind_group = None;
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
        self.upload_contacts(model, adjacency)
    }

    /// Uploads contacts, their gather records and the adjacency (after stage 7 changed them).
    fn upload_contacts(&mut self, model: &Model, adjacency: &Adjacency) -> Result<(), GpuError> {
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
        if g {
            self.bind_group = None;
        }
        let b = self.buffers();
        let q = &self.dev.queue;
        q.write_buffer(&b.contacts.buffer, 0, bytemuck::cast_slice(&contacts));
        q.write_buffer(&b.contact_forces.buffer, 0, bytemuck::cast_slice(&forces));
        self.counts.2 = contacts.len();
        if self.bind_group.is_none() {
            self.bind_group = Some(self.buffers().bind_group(&self.dev, &self.pipelines.bind_group_layout));
        }
        Ok(())
    }

    /// The bookkeeping of a new contact list on the device: the ledger bases of its contacts and
    /// the generation the last good state's CPU copy is compared with.
    fn new_contact_list(&mut self, model: &Model) {
        self.bases_from_model(model);
        self.generation += 1;
    }

    /// Every contact's ledger bases from the model: the contact update kept each surviving
    /// contact's ledger terms there (matched by corner and block, with their feature ids).
    fn bases_from_model(&mut self, model: &Model) {
        std::rc::Rc::make_mut(&mut self.uploaded).contact_base = model.contacts.iter().map(|c| [c.slip_work, c.dashpot_work]).collect();
    }

    /// `new_contact_list` after a splice of `edit`, where the kept contacts at `patched` (new
    /// indices; None: all) were read and take their bases from the model: the others keep their
    /// old bases, since the device keeps their dissipation. (A copy of the bases only when a
    /// checkpoint still shares them.) An edit that changed no contact leaves the generation: the
    /// last good state's copy of the topology still holds (a checkpoint's bases are its own).
    fn edit_contact_list(&mut self, model: &Model, edit: &ListEdit, patched: Option<&[u32]>) {
        match patched {
            None => self.bases_from_model(model),
            Some(patched) => {
                let bases = &mut std::rc::Rc::make_mut(&mut self.uploaded).contact_base;
                let base = |k: u32| [model.contacts[k as usize].slip_work, model.contacts[k as usize].dashpot_work];
                crate::topology::detect::splice(bases, &edit.dropped, &edit.insert_before, edit.inserted_at.iter().map(|&k| base(k)));
                for &k in patched {
                    bases[k as usize] = base(k);
                }
            }
        }
        self.generation += u64::from(!edit.is_empty());
    }

    /// Uploads the adjacency lists (and makes room for the energy check's sums of the new
    /// counts); returns whether a buffer was re-created (the bind group must then be rebuilt).
    fn upload_adjacency(&mut self, blocks: &[crate::model::Block], n_contacts: usize, adjacency: &Adjacency) -> Result<bool, GpuError> {
        let n_blocks = blocks.len();
        // The offsets, then the blocks `gather_heavy` sums (see gather.wgsl): free ones first,
        // then fixed ones, which only the pass before a read-back sums (a base under a wall).
        let mut offsets = adjacency.offsets.clone();
        let heavy = |fixed: bool| adjacency.offsets.windows(2).enumerate().filter(move |(b, w)| w[1] - w[0] > shaders::HEAVY_DEGREE && blocks[*b].fixed == fixed).map(|(b, _)| b as u32);
        let free: Vec<u32> = heavy(false).collect();
        self.n_heavy_free = free.len();
        offsets.extend(free);
        offsets.extend(heavy(true));
        self.n_heavy = offsets.len() - adjacency.offsets.len();
        let b = self.buffers.as_mut().expect("buffers exist");
        let d = &self.dev;
        let mut g = Buffers::ensure(d, &mut b.adj_entries, "adjacency entries", 4, adjacency.entries.len())?;
        g |= Buffers::ensure(d, &mut b.adj_offsets, "adjacency offsets", 4, offsets.len())?;
        g |= Buffers::ensure(d, &mut b.energy_sums, "energy sums", std::mem::size_of::<EnergySum<R>>(), kernels::energy_groups(n_blocks, n_contacts))?;
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
    fn splice_contacts(&mut self, model: &Model, adjacency: &Adjacency, edit: &ListEdit, patches: &[[u32; 2]]) -> Result<(), GpuError> {
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
        let no_patch = [[u32::MAX, 0]];
        let patches = if patches.is_empty() { &no_patch[..] } else { patches };
        let dev = &self.dev;
        let b = self.buffers.as_mut().expect("buffers exist");
        b.ensure_spare::<R>(dev, n)?;
        let init = |label: &str, contents: &[u8]| dev.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage: wgpu::BufferUsages::STORAGE });
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
        kernels::dispatch_passes(dev, "splice_contacts", &[(&p.splice_contacts, if moves { n } else { 0 }), (&p.patch_contacts, patches.len())], &p.splice_layout, &entries)?;
        self.splices += 1;
        if !moves {
            return Ok(());
        }
        b.swap_contacts();
        self.counts.2 = n;
        if !self.edit_adjacency(&model.blocks, adjacency, edit)? {
            self.upload_adjacency(&model.blocks, n, adjacency)?;
        }
        self.bind_group = Some(self.buffers().bind_group(&self.dev, &self.pipelines.bind_group_layout));
        Ok(())
    }

    /// The adjacency lists on the device take the update's edit (`splice_adjacency.wgsl`): the
    /// touched blocks' new lists, the renumbering and the offsets' shifts, in proportion to the
    /// changes, where `upload_adjacency` sends the lists whole (4 bytes an entry). The blocks
    /// `gather_heavy` sums are listed again only when a touched block crossed `HEAVY_DEGREE`.
    /// Returns false, having changed nothing, when the lists were rebuilt rather than edited or
    /// the heavy blocks outgrow their room: the caller uploads the lists whole.
    fn edit_adjacency(&mut self, blocks: &[crate::model::Block], adjacency: &Adjacency, edit: &ListEdit) -> Result<bool, GpuError> {
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
            let list = |fixed: bool| adjacency.offsets.windows(2).enumerate().filter(move |(b, w)| heavy((w[1] - w[0]) as i64) && blocks[*b].fixed == fixed).map(|(b, _)| b as u32);
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
        Buffers::ensure(dev, &mut b.energy_sums, "energy sums", std::mem::size_of::<EnergySum<R>>(), kernels::energy_groups(n_blocks, edit.new_len() as usize))?;
        let init = |label: &str, contents: &[u8]| dev.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage: wgpu::BufferUsages::STORAGE });
        // (A binding holds at least one item.)
        let lists: &[u32] = if entries.lists.is_empty() { &[0] } else { &entries.lists };
        let touched = splice::touched_shifts(entries, n_blocks + 1);
        let runs_buffer = init("adjacency runs", bytemuck::cast_slice(&entries.runs));
        let lists_buffer = init("adjacency lists", bytemuck::cast_slice(lists));
        let renumber_buffer = init("contact renumbering", bytemuck::cast_slice(&splice::renumber_table(edit)));
        let touched_buffer = init("touched lists", bytemuck::cast_slice(&touched));
        let spare = b.spare_entries.as_ref().expect("made above");
        let bindings = kernels::whole_bindings(&[&b.adj_entries.buffer, &runs_buffer, &lists_buffer, &renumber_buffer, &spare.buffer, &b.adj_offsets.buffer, &touched_buffer]);
        let p = &self.pipelines;
        kernels::dispatch_passes(dev, "splice_adjacency", &[(&p.splice_adjacency, n_entries), (&p.shift_offsets, n_blocks + 1)], &p.adjacency_layout, &bindings)?;
        b.swap_entries();
        if let Some((list, n_free)) = heavy_list {
            dev.queue.write_buffer(&b.adj_offsets.buffer, ((n_blocks + 1) * 4) as u64, bytemuck::cast_slice(&list));
            self.n_heavy = list.len();
            self.n_heavy_free = n_free;
        }
        Ok(true)
    }

    fn write_params(&self, model: &Model) {
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
            n_blocks: self.counts.0 as u32,
            n_corners: self.counts.1 as u32,
            n_contacts: self.counts.2 as u32,
            one: 1,
            gather_fixed: 0,
            n_heavy: self.heavy_blocks(false) as u32,
            dashpots: (model.damping.beta > 0.0 || self.dashpots_pending) as u32,
            _pad: 0,
        };
        self.dev.queue.write_buffer(&self.buffers().params, 0, bytemuck::bytes_of(&params));
    }

    /// The dispatches of one cycle over the live counts (stage 6 alone with `gather_only`).
    /// Stages with nothing to do are left out.
    pub(crate) fn stages(&self, gather_only: bool) -> Vec<Dispatch<'_>> {
        let p = &self.pipelines;
        let bg = self.bind_group.as_ref().expect("bind group built on upload");
        let cycle = |label, pipeline, g: Grid| Dispatch { label, pipeline, bind_group: bg, grid: self.grid(g, gather_only), indirect: Some(g) };
        let mut stages = Vec::with_capacity(6);
        if !gather_only {
            stages.push(cycle("law_of_motion", &p.law_of_motion, Grid::Blocks));
            stages.push(cycle("contact_forces", &p.contact_forces, Grid::Contacts));
        }
        stages.push(cycle("gather", &p.gather, Grid::Blocks));
        if self.heavy_blocks(gather_only) > 0 {
            stages.push(cycle("gather_heavy", &p.gather_heavy, Grid::HeavyBlocks));
        }
        if !gather_only {
            let end = self.end_cycle_bind_group.as_ref().expect("made with the buffers");
            stages.push(Dispatch { label: "end_cycle", pipeline: &p.end_cycle, bind_group: end, grid: (1, 1), indirect: None });
        }
        stages.retain(|d| d.grid.0 > 0);
        stages
    }

    /// The grid of `g` over the live counts: one invocation per block or contact, one workgroup
    /// per heavy block the pass gathers.
    fn grid(&self, g: Grid, gather_only: bool) -> (u32, u32) {
        let items = |n: usize| shaders::dispatch_grid((n as u32).div_ceil(shaders::WORKGROUP_SIZE));
        match g {
            Grid::Blocks => items(self.counts.0),
            Grid::Contacts => items(self.counts.2),
            Grid::HeavyBlocks => shaders::dispatch_grid(self.heavy_blocks(gather_only) as u32),
        }
    }

    /// Heavy blocks a pass gathers: the free ones in a cycle, all (fixed ones too) in the pass
    /// before a read-back.
    fn heavy_blocks(&self, gather_only: bool) -> usize {
        if gather_only { self.n_heavy } else { self.n_heavy_free }
    }

    /// The run constants that differ between a cycle and the gather-only pass before a
    /// read-back (queued; the pass's dispatches follow).
    pub(crate) fn write_pass_params(&self, gather_only: bool) {
        let (b, q) = (self.buffers(), &self.dev.queue);
        q.write_buffer(&b.params, std::mem::offset_of!(Params<R>, gather_fixed) as u64, bytemuck::bytes_of(&(gather_only as u32)));
        q.write_buffer(&b.params, std::mem::offset_of!(Params<R>, n_heavy) as u64, bytemuck::bytes_of(&(self.heavy_blocks(gather_only) as u32)));
    }

    /// Runs `cycles` cycles (or fewer, if a kernel raises a flag) with no round trip; returns the
    /// flags. With `gather_only`, runs stage 6 alone over every block, fixed ones too (the force
    /// sums after a topology change, and before a read-back). Each submission holds one compute
    /// pass of `CYCLES_PER_SUBMIT` cycles (wgpu orders the dispatches inside it), with a debug
    /// group per stage so that tools and errors name it.
    fn run_batch(&self, cycles: u64, gather_only: bool) -> Result<Flags, GpuError> {
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
    fn submit_batch(&self, cycles: u64, gather_only: bool) -> Result<(), GpuError> {
        let b = self.buffers();
        let q = &self.dev.queue;
        q.write_buffer(&b.flags, 0, bytemuck::bytes_of(&Flags::cleared()));
        // The grids of the indirect dispatches, which end_cycle zeroes when it halts the batch.
        let args: Vec<u32> = Grid::ALL.iter().flat_map(|&g| {
            let (x, y) = self.grid(g, gather_only);
            [x, y, 1]
        }).collect();
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
    fn run_batch_with_state(&mut self, cycles: u64, model: &mut Model, packed: bool) -> Result<(Flags, bool), GpuError> {
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
            Self::convert_contacts_read(&bytes[3..], packed, &up, model);
            (flags, Some(blocks))
        })?;
        let read = blocks.is_some();
        if let Some(blocks) = blocks {
            self.last_blocks = blocks;
        }
        Ok((flags, read))
    }

    /// The energy check's sums on the device: (kinetic, strain, external work) of the state now,
    /// the per-workgroup sums read back and added in order in f64.
    fn energy_sums(&self) -> Result<(f64, f64, f64), GpuError> {
        let Some(b) = self.buffers.as_ref() else {
            return Err(GpuError::Setup("no state on the device: run some cycles first".into()));
        };
        let bg = self.bind_group.as_ref().expect("bind group built on upload");
        let (x, y) = kernels::energy_grid(self.counts.0, self.counts.2);
        let groups = (x * y) as usize;
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("energy check") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("energy_sums"), timestamp_writes: None });
            pass.set_pipeline(&self.pipelines.energy_sums);
            pass.set_bind_group(0, bg, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        self.dev.queue.submit([enc.finish()]);
        let sums: Vec<EnergySum<R>> = self.read(&b.energy_sums.buffer, groups)?;
        let (mut kinetic, mut strain, mut work) = (0.0, 0.0, 0.0);
        for s in &sums {
            kinetic += s.kinetic.to_f64();
            strain += s.strain.to_f64();
            work += s.work.to_f64();
        }
        Ok((kinetic, strain, self.uploaded.work_base + work))
    }

    /// Copies the live state into the checkpoint buffers on the device (queued; no wait).
    fn take_checkpoint(&mut self) {
        let _p = crate::profile::scope(crate::profile::Stage::Checks);
        let b = self.buffers.as_ref().expect("buffers exist");
        let (nb, nc, nk) = self.counts;
        let sizes = [
            (nb * std::mem::size_of::<Block<R>>()) as u64,
            (nc * std::mem::size_of::<Corner<R>>()) as u64,
            (nk * std::mem::size_of::<Contact<R>>()) as u64,
            (nk * std::mem::size_of::<ContactForce<R>>()) as u64,
        ];
        let fits = self.checkpoint.as_ref().is_some_and(|c| c.blocks.size() >= sizes[0] && c.corners.size() >= sizes[1] && c.contacts.size() >= sizes[2] && c.forces.size() >= sizes[3]);
        if !fits {
            let make = |label: &str, size: u64| {
                self.dev.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: size.max(16),
                    usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })
            };
            self.checkpoint = Some(Checkpoint {
                blocks: make("checkpoint blocks", b.blocks.buffer.size()),
                corners: make("checkpoint corners", b.corners.buffer.size()),
                contacts: make("checkpoint contacts", b.contacts.buffer.size()),
                forces: make("checkpoint contact forces", b.contact_forces.buffer.size()),
                counts: self.counts,
                uploaded: self.uploaded.clone(),
                valid: false,
            });
        }
        let ck = self.checkpoint.as_mut().expect("made above");
        ck.valid = true;
        ck.counts = self.counts;
        ck.uploaded = self.uploaded.clone();
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("checkpoint") });
        self.encode_contact_points(&mut enc);
        let b = self.buffers.as_ref().expect("buffers exist");
        let ck = self.checkpoint.as_ref().expect("made above");
        let pairs = [(&b.blocks.buffer, &ck.blocks), (&b.corners.buffer, &ck.corners), (&b.contacts.buffer, &ck.contacts), (&b.contact_forces.buffer, &ck.forces)];
        for ((src, dst), size) in pairs.into_iter().zip(sizes) {
            if size > 0 {
                enc.copy_buffer_to_buffer(src, 0, dst, 0, size);
            }
        }
        self.dev.queue.submit([enc.finish()]);
    }

    /// Puts the device checkpoint's state into `model` (the CPU copy taken at that checkpoint),
    /// and sums the fixed blocks' forces, which the cycle does not keep up to date.
    fn restore_checkpoint(&self, model: &mut Model) -> Result<(), GpuError> {
        let Some(ck) = self.checkpoint.as_ref().filter(|c| c.valid) else { return Ok(()) };
        if let Some(identities) = &self.last_good_contacts {
            model.contacts = identities.par_iter().map(|c| c.contact()).collect();
        }
        let src = StateBuffers { blocks: &ck.blocks, corners: &ck.corners, contacts: &ck.contacts, forces: &ck.forces, counts: ck.counts };
        self.read_state(&src, &ck.uploaded, model)?;
        let adjacency = Adjacency::build(model.blocks.len(), &model.contacts);
        let gravity = model.gravity;
        let forces: Vec<cpu::gather::ContactForce> = model.contacts.iter().map(cpu::gather::ContactForce::from).collect();
        for (b, block) in model.blocks.iter_mut().enumerate().filter(|(_, blk)| blk.fixed) {
            cpu::gather::gather(b, block, &forces, &adjacency, gravity);
        }
        Ok(())
    }

    fn read<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, n: usize) -> Result<Vec<T>, GpuError> {
        self.dev.read_pod(buffer, n)
    }

    /// What a read-back reads of the live contacts: whole with their gather records (which
    /// hold their forces), or their packed summaries only (the second part then reads nothing).
    fn contacts_parts(&self, packed: bool) -> [(&wgpu::Buffer, u64); 2] {
        let (b, nk) = (self.buffers(), self.counts.2);
        let forces = &b.contact_forces.buffer;
        match (packed, b.summaries.as_ref()) {
            (true, Some(s)) => [(&s.buffer, (nk * std::mem::size_of::<ContactSummary<R>>()) as u64), (forces, 0)],
            // No contacts were ever packed (none live): nothing to read.
            (true, None) => [(&b.contacts.buffer, 0), (forces, 0)],
            (false, _) => [(&b.contacts.buffer, (nk * std::mem::size_of::<Contact<R>>()) as u64), (forces, (nk * std::mem::size_of::<ContactForce<R>>()) as u64)],
        }
    }

    /// The contacts of a read-back (`contacts_parts`), whole or packed, into the model.
    fn convert_contacts_read(parts: &[&[u8]], packed: bool, up: &Uploaded, model: &mut Model) {
        if packed {
            Self::convert_summaries(&pod_view(parts[0]), up, model);
        } else {
            Self::convert_contacts(&pod_view(parts[0]), &pod_view(parts[1]), up, model);
        }
    }

    /// Encodes `contact_points` over the live contacts: their points and normals, which the
    /// cycle does not store, for a read-back or checkpoint of whole contacts that follows.
    fn encode_contact_points(&self, enc: &mut wgpu::CommandEncoder) {
        let n = self.counts.2;
        let Some(bg) = self.bind_group.as_ref().filter(|_| n > 0) else { return };
        let (x, y) = shaders::dispatch_grid((n as u32).div_ceil(shaders::WORKGROUP_SIZE));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("contact_points"), timestamp_writes: None });
        pass.set_pipeline(&self.pipelines.contact_points);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Queues `contact_points` (no wait; the read-back that follows waits for it).
    fn place_contact_points(&self) -> Result<(), GpuError> {
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
    fn pack_contacts(&mut self) -> Result<(), GpuError> {
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
    fn read_state(&self, src: &StateBuffers, up: &Uploaded, model: &mut Model) -> Result<Vec<Block<R>>, GpuError> {
        let (nb, nc, nk) = src.counts;
        let parts = [
            (src.blocks, (nb * std::mem::size_of::<Block<R>>()) as u64),
            (src.corners, (nc * std::mem::size_of::<Corner<R>>()) as u64),
            (src.contacts, (nk * std::mem::size_of::<Contact<R>>()) as u64),
            (src.forces, (nk * std::mem::size_of::<ContactForce<R>>()) as u64),
        ];
        self.dev.read_parts(&parts, |bytes| {
            let blocks: Vec<Block<R>> = bytemuck::pod_collect_to_vec(bytes[0]);
            Self::convert_blocks_and_corners(&blocks, &pod_view(bytes[1]), up, model);
            Self::convert_contacts(&pod_view(bytes[2]), &pod_view(bytes[3]), up, model);
            blocks
        })
    }

    /// The device state into the model: centroids back to the model's frame, accumulators onto
    /// their f64 bases. Converted in parallel (a 10⁶-block model is read back at every contact
    /// update); the external work is summed serially, so the result repeats bit for bit.
    fn convert_blocks_and_corners(blocks: &[Block<R>], corners: &[Corner<R>], up: &Uploaded, model: &mut Model) {
        model.blocks.par_iter_mut().zip(blocks.par_iter()).zip(up.damping_base.par_iter()).with_min_len(4096).for_each(|((m, g), &base)| Self::convert_block(g, base, up.origin, m));
        let work: f64 = blocks.iter().map(|g| g.work.to_f64()).sum();
        model.external_work = up.work_base + work;
        let Model { blocks: model_blocks, corners: model_corners, .. } = model;
        model_corners.par_iter_mut().enumerate().zip(corners.par_iter()).with_min_len(4096).for_each(|((i, m), g)| {
            let blk = &model_blocks[m.block as usize];
            let next = if i + 1 == (blk.corner_start + blk.corner_count) as usize { blk.corner_start as usize } else { i + 1 };
            Self::convert_corner(g, &corners[next], blk.centroid, m);
        });
    }

    /// One block of the device state into the model (`damping_base`: its mass-damping base).
    fn convert_block(g: &Block<R>, damping_base: f64, o: [f64; 2], m: &mut crate::model::Block) {
        m.centroid = [o[0] + (g.cx.to_f64() + g.cx_lo.to_f64()), o[1] + (g.cy.to_f64() + g.cy_lo.to_f64())];
        m.rotation = g.rotation.to_f64();
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
    /// `next` is the block's next corner.
    fn convert_corner(g: &Corner<R>, next: &Corner<R>, centroid: [f64; 2], m: &mut crate::model::Corner) {
        m.position = [centroid[0] + g.px.to_f64(), centroid[1] + g.py.to_f64()];
        m.circle = [centroid[0] + g.ox.to_f64(), centroid[1] + g.oy.to_f64()];
        // The edge to the next corner of the block, measured as the contact stage measures it
        // (from the two corners relative to the centroid), in f64.
        let e = [next.px.to_f64() - g.px.to_f64(), next.py.to_f64() - g.py.to_f64()];
        let len = e[0].hypot(e[1]);
        m.edge_dir = [e[0] / len, e[1] / len];
        m.edge_length = len;
    }

    /// Packed contacts into the model: what detection and the ledger use. The model's point,
    /// normal, shear displacement, force and dashpot velocities stay as they were (stale) until
    /// the next whole read-back; the splice keeps the device's.
    fn convert_summaries(summaries: &[ContactSummary<R>], up: &Uploaded, model: &mut Model) {
        model.contacts.par_iter_mut().zip(summaries.par_iter()).zip(up.contact_base.par_iter()).with_min_len(4096).for_each(|((m, g), &base)| Self::convert_summary(g, base, m));
    }

    /// One contact's summary into the model (`base`: its ledger bases).
    fn convert_summary(g: &ContactSummary<R>, base: [f64; 2], m: &mut crate::model::Contact) {
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
    fn convert_contacts(contacts: &[Contact<R>], forces: &[ContactForce<R>], up: &Uploaded, model: &mut Model) {
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
    fn readback(&mut self, model: &mut Model) -> Result<(), GpuError> {
        self.run_batch(1, true)?;
        self.read_live_state(model, false)
    }

    /// Reads blocks, corners and contacts back as they are (fixed blocks' forces stale: what
    /// stage 7 needs); `packed`: the contacts' summaries only (`pack_contacts`).
    fn read_live_state(&mut self, model: &mut Model, packed: bool) -> Result<(), GpuError> {
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
        let parts = [(&b.blocks.buffer, (nb * std::mem::size_of::<Block<R>>()) as u64), (&b.corners.buffer, (nc * std::mem::size_of::<Corner<R>>()) as u64), contacts, forces];
        self.last_blocks = self.dev.read_parts(&parts, |bytes| {
            let blocks: Vec<Block<R>> = bytemuck::pod_collect_to_vec(bytes[0]);
            Self::convert_blocks_and_corners(&blocks, &pod_view(bytes[1]), &up, model);
            Self::convert_contacts_read(&bytes[2..], packed, &up, model);
            blocks
        })?;
        Ok(())
    }

    /// After stage 7: the blocks it re-examined get their update distance reset, their
    /// reference set to where they are now and their new speed margin (one contiguous write of
    /// seven fields each, the reference copied from the GPU's own values so that it is exact).
    ///
    /// `last_blocks` is the device's block state as just read back (no cycle ran since), so
    /// when many blocks were re-examined (a busy impact) the whole block buffer is written in one
    /// go with their fields reset, instead of one small write per block.
    fn upload_reset_distances(&mut self, model: &Model) {
        let _p = crate::profile::scope(crate::profile::Stage::Upload);
        let size = std::mem::size_of::<Block<R>>() as u64;
        let offset = std::mem::offset_of!(Block<R>, moved) as u64;
        let reset: Vec<usize> = model
            .blocks
            .iter()
            .zip(&self.last_blocks)
            .enumerate()
            .filter(|(_, (m, g))| {
                m.moved_since_update == 0.0
                    && (g.moved.to_f64() != 0.0 || g.update_cx != g.cx || g.update_cy != g.cy || g.update_rotation != g.rotation || g.update_margin != R::from_f64(m.update_margin))
            })
            .map(|(i, _)| i)
            .collect();
        let whole = reset.len() * 8 > self.last_blocks.len();
        for &i in &reset {
            let g = &mut self.last_blocks[i];
            (g.moved, g.update_cx, g.update_cy, g.update_cx_lo, g.update_cy_lo, g.update_rotation) = (R::default(), g.cx, g.cy, g.cx_lo, g.cy_lo, g.rotation);
            g.update_margin = R::from_f64(model.blocks[i].update_margin);
            if !whole {
                let fields = [g.moved, g.update_cx, g.update_cy, g.update_cx_lo, g.update_cy_lo, g.update_rotation, g.update_margin];
                self.dev.queue.write_buffer(&self.buffers().blocks.buffer, i as u64 * size + offset, bytemuck::cast_slice(&fields));
            }
        }
        if whole {
            self.dev.queue.write_buffer(&self.buffers().blocks.buffer, 0, bytemuck::cast_slice(&self.last_blocks));
        }
    }

    /// Whether a contact update now reads back only what it touches (`PartialReads`).
    fn partial_reads_pay(&self) -> bool {
        let (nb, nc, nk) = self.counts;
        let whole = nb * std::mem::size_of::<Block<R>>() + nc * std::mem::size_of::<Corner<R>>() + nk * std::mem::size_of::<ContactSummary<R>>();
        match self.partial_reads {
            PartialReads::Never => false,
            PartialReads::Large => whole > PARTIAL_READ_MIN_BYTES,
            PartialReads::Always => true,
        }
    }

    /// Stage 7 from what it touches (`gpu::partial`): the device lists the blocks that may be
    /// re-examined or have strayed from the kept grid and the contacts that may be dropped; the
    /// CPU reads those back, then the neighbourhoods of the blocks it re-examines (their blocks,
    /// corners and contacts), runs the update on them, resets the re-examined blocks' update
    /// distances on the device and splices the contact list there, leaving every contact it did
    /// not read as the device holds it. The model is current only where it was read until the
    /// next whole read-back. Declines, changing nothing, when the update needs the whole state.
    fn partial_contact_update(&mut self, model: &mut Model, adjacency: &mut Adjacency, report: &mut CycleReport) -> Result<PartialUpdate, GpuError> {
        let (nb, _, nk) = self.counts;
        // (The attention's contact indices and the splice need the list in the update's order.)
        if nb < 2 || !self.list_in_order || !adjacency.grid.valid_for(model) {
            return Ok(PartialUpdate::Declined);
        }
        // The lists, on the device.
        let (listed, listed_contacts, fewest) = {
            let _p = crate::profile::scope(crate::profile::Stage::Download);
            if self.lists.as_ref().is_none_or(|l| !l.fits(nb, nk)) {
                self.lists = None;
                self.lists = Some(partial::ListBuffers::new::<R>(&self.dev, nb, nk)?);
            }
            let origin = self.uploaded.origin;
            let grid = &adjacency.grid;
            let lists = self.lists.as_mut().expect("made above");
            let key = (grid.builds(), origin, nb);
            if lists.reference_of != Some(key) {
                let reference = partial::grid_reference::<R>(grid.reference(), origin);
                self.dev.queue.write_buffer(&lists.reference.buffer, 0, bytemuck::cast_slice(&reference));
                lists.reference_of = Some(key);
            }
            let t = model.tol;
            let lp = ListParams::<R> {
                dt: r(model.timestep),
                etol: r(t.etol),
                btol: r(t.btol),
                stray_limit: r(grid.stray_limit()),
                n_blocks: nb as u32,
                n_contacts: nk as u32,
                grid_kept: 1,
                _pad: 0,
            };
            let q = &self.dev.queue;
            q.write_buffer(&lists.params, 0, bytemuck::bytes_of(&lp));
            q.write_buffer(&lists.header.buffer, 0, bytemuck::cast_slice(&[0u32, 0, u32::MAX, 0]));
            let b = self.buffers();
            let lists = self.lists.as_ref().expect("made above");
            let entries = kernels::whole_bindings(&[
                &lists.params,
                &b.blocks.buffer,
                &b.contacts.buffer,
                &lists.reference.buffer,
                &lists.header.buffer,
                &lists.listed_blocks.buffer,
                &lists.listed_contacts.buffer,
            ]);
            let p = &self.pipelines;
            kernels::dispatch_items(&self.dev, "list_blocks", &p.list_blocks, &p.lists_layout, &entries, nb)?;
            if nk > 0 {
                kernels::dispatch_items(&self.dev, "list_contacts", &p.list_contacts, &p.lists_layout, &entries, nk)?;
            }
            let header: Vec<u32> = self.dev.read_pod(&lists.header.buffer, 4)?;
            let (n_listed, n_contacts) = (header[0] as usize, header[1] as usize);
            // Many listed: an update that sweeps or rebuilds the grid (it reads every block), or
            // one that drops a crowd of contacts; the whole read-back is then as cheap.
            if n_listed > nb / 8 || n_contacts > nk / 8 + 64 {
                return Ok(PartialUpdate::Declined);
            }
            let (mut listed, mut listed_contacts) = self.dev.read_parts(&[(&lists.listed_blocks.buffer, (n_listed * 4) as u64), (&lists.listed_contacts.buffer, (n_contacts * 4) as u64)], |bytes| {
                (bytemuck::pod_collect_to_vec::<u8, u32>(bytes[0]), bytemuck::pod_collect_to_vec::<u8, u32>(bytes[1]))
            })?;
            listed.sort_unstable();
            listed_contacts.sort_unstable();
            (listed, listed_contacts, header[2])
        };
        // The listed blocks and contacts into the model.
        let mut read_contacts = partial::runs(&listed_contacts);
        let records = self.read_subset(model, &listed, &read_contacts)?;
        let tol = model.tol;
        if !listed.iter().any(|&b| model.blocks[b as usize].update_due(&tol)) {
            return Ok(PartialUpdate::NotDue);
        }
        // The update, which fetches the re-examined blocks' neighbourhoods.
        let mut read_all = false;
        let outcome = {
            let _p = crate::profile::scope(crate::profile::Stage::DetectUpdate);
            let mut fetch = |m: &mut Model, needed: Option<&[u32]>| -> Result<(), String> {
                match needed {
                    None => {
                        self.read_live_state(m, true).map_err(|e| e.to_string())?;
                        read_all = true;
                    }
                    Some(blocks) => {
                        // Each block's run of contacts (as block 1; the list is in that order).
                        let contact_runs = partial::join_runs(blocks.iter().map(|&b| {
                            let lo = m.contacts.partition_point(|c| c.block1 < b);
                            (lo as u32, (lo + m.contacts[lo..].partition_point(|c| c.block1 == b)) as u32)
                        }));
                        self.read_subset(m, blocks, &contact_runs).map_err(|e| e.to_string())?;
                        read_contacts = partial::join_runs(read_contacts.iter().chain(&contact_runs).copied());
                    }
                }
                Ok(())
            };
            let mut attention = crate::topology::detect::Attention { blocks: listed.clone(), contacts: listed_contacts, fetch: &mut fetch };
            crate::topology::detect::update_topology_with(model, adjacency, &mut attention)
        };
        let (created, dropped, flagged) = outcome.map_err(GpuError::Device)?;
        report.topology_updates += 1;
        report.contacts_created += created as u64;
        report.contacts_dropped += dropped as u64;
        self.partial_updates += 1;
        {
            // The re-examined blocks: their update distance reset on the device, their reference
            // where they are now and their new speed margin (the model keeps it as the device
            // does, rounded to its precision, as a read-back would give it).
            let _p = crate::profile::scope(crate::profile::Stage::Upload);
            let size = std::mem::size_of::<Block<R>>() as u64;
            let offset = std::mem::offset_of!(Block<R>, moved) as u64;
            for &b in &flagged {
                let Ok(i) = listed.binary_search(&b) else {
                    return Err(GpuError::Device(format!("GPU: block {b} was re-examined but not listed (a bug; run with BLOCKDEM_PARTIAL_READS=0)")));
                };
                let g = &records[i];
                let m = &mut model.blocks[b as usize];
                let margin = R::from_f64(m.update_margin);
                m.update_margin = margin.to_f64();
                let fields = [R::default(), g.cx, g.cy, g.cx_lo, g.cy_lo, g.rotation, margin];
                self.dev.queue.write_buffer(&self.buffers().blocks.buffer, b as u64 * size + offset, bytemuck::cast_slice(&fields));
            }
        }
        // The next update expected: the device's figure for the blocks not listed, the CPU's for
        // those it read.
        let from_listed = listed.iter().filter_map(|&b| cycles_to_threshold(model, &model.blocks[b as usize])).min();
        let from_device = (fewest != u32::MAX).then_some(fewest as u64);
        let expected = from_listed.into_iter().chain(from_device).min();
        // The splice: the kept contacts read are patched, the others keep the device's state.
        let Some(edit) = adjacency.take_edit().filter(|e| e.old_len as usize == nk) else {
            return Err(GpuError::Device("GPU: the contact update sorted a list kept in order (a bug; run with BLOCKDEM_PARTIAL_READS=0)".into()));
        };
        if model.contacts.is_empty() {
            self.upload_contacts(model, adjacency)?;
        } else {
            let read: Vec<u32> = if read_all {
                (0..edit.old_len).collect()
            } else {
                read_contacts.iter().flat_map(|&(s, e)| s..e).collect()
            };
            let patches: Vec<[u32; 2]> = read
                .into_iter()
                .filter(|k| edit.dropped.binary_search(k).is_err())
                .map(|k| {
                    let i = edit.new_index(k);
                    [i, model.contacts[i as usize].feature]
                })
                .collect();
            let patched: Vec<u32> = patches.iter().map(|p| p[0]).collect();
            self.edit_contact_list(model, &edit, Some(&patched));
            self.splice_contacts(model, adjacency, &edit, &patches)?;
        }
        self.write_params(model);
        self.run_batch(1, true)?;
        Ok(PartialUpdate::Updated(expected))
    }

    /// Reads the blocks `blocks` (ascending; records and corners) and the contacts of `contacts`
    /// (runs of indices) back into the model, as a whole read-back would convert them (contacts
    /// as their summaries: gap, forces, dissipation, feature, bond); returns the block records.
    fn read_subset(&mut self, model: &mut Model, blocks: &[u32], contacts: &[(u32, u32)]) -> Result<Vec<Block<R>>, GpuError> {
        let _p = crate::profile::scope(crate::profile::Stage::Download);
        let b = self.buffers();
        let (bs, cs, ks) = (std::mem::size_of::<Block<R>>() as u64, std::mem::size_of::<Corner<R>>() as u64, std::mem::size_of::<Contact<R>>() as u64);
        let block_runs = partial::runs(blocks);
        let corner_runs = partial::join_runs(blocks.iter().map(|&k| {
            let blk = &model.blocks[k as usize];
            (blk.corner_start, blk.corner_start + blk.corner_count)
        }));
        fn ranges<'a>(buffer: &'a wgpu::Buffer, runs: &[(u32, u32)], size: u64) -> Vec<(&'a wgpu::Buffer, u64, u64)> {
            runs.iter().map(|&(s, e)| (buffer, s as u64 * size, (e - s) as u64 * size)).collect()
        }
        let (rb, rc, rk) = (ranges(&b.blocks.buffer, &block_runs, bs), ranges(&b.corners.buffer, &corner_runs, cs), ranges(&b.contacts.buffer, contacts, ks));
        let up = self.uploaded.clone();
        self.dev.read_gathered(&[&rb, &rc, &rk], |bytes| {
            let records: Vec<Block<R>> = bytemuck::pod_collect_to_vec(bytes[0]);
            let corners: std::borrow::Cow<'_, [Corner<R>]> = pod_view(bytes[1]);
            let gathered: std::borrow::Cow<'_, [Contact<R>]> = pod_view(bytes[2]);
            for (&k, g) in blocks.iter().zip(&records) {
                Self::convert_block(g, up.damping_base[k as usize], up.origin, &mut model.blocks[k as usize]);
            }
            // Corners: the runs laid end to end; each block's are within one run.
            let mut at = 0usize;
            let mut first = Vec::with_capacity(corner_runs.len());
            for &(s, e) in &corner_runs {
                first.push((s, e, at));
                at += (e - s) as usize;
            }
            for &k in blocks {
                let (centroid, s, count) = {
                    let blk = &model.blocks[k as usize];
                    (blk.centroid, blk.corner_start, blk.corner_count as usize)
                };
                let start = s as usize;
                let run = first.partition_point(|r| r.1 <= s);
                let base = first[run].2 + (s - first[run].0) as usize;
                for j in 0..count {
                    let next = if j + 1 == count { 0 } else { j + 1 };
                    Self::convert_corner(&corners[base + j], &corners[base + next], centroid, &mut model.corners[start + j]);
                }
            }
            let mut at = 0usize;
            for &(s, e) in contacts {
                for k in s..e {
                    let g = &gathered[at];
                    at += 1;
                    let summary = ContactSummary { gap: g.gap, normal_force: g.normal_force, shear_force: g.shear_force, slip_work: g.slip_work, dashpot_work: g.dashpot_work, feature: g.feature, bonded: g.bonded };
                    Self::convert_summary(&summary, up.contact_base[k as usize], &mut model.contacts[k as usize]);
                }
            }
            records
        })
    }

    /// The CPU backend's error for the flags raised, from the read-back state (same priority as
    /// the CPU's checks within a cycle: non-finite, too fast, overlap).
    fn error_from_flags(model: &Model, flags: &Flags) -> CycleError {
        let cycle = model.cycle;
        if flags.errors & layout::ERR_NONFINITE != 0 {
            let block = model
                .blocks
                .iter()
                .find(|b| !(b.centroid[0].is_finite() && b.centroid[1].is_finite() && b.velocity[0].is_finite() && b.velocity[1].is_finite() && b.angular_velocity.is_finite()))
                .map_or(0, |b| b.id);
            return CycleError::NonFinite { cycle, block, what: "a non-finite position or velocity".into() };
        }
        if flags.errors & layout::ERR_TOO_FAST != 0 {
            let dt = model.timestep;
            let mut fastest = (0.0f64, flags.toofast_block as usize);
            for (i, b) in model.blocks.iter().enumerate() {
                if b.fixed {
                    continue;
                }
                let travel = b.travel_per_step(dt);
                if travel > fastest.0 {
                    fastest = (travel, i);
                }
            }
            let limit = 0.5 * model.tol.atol - model.tol.etol;
            let b = &model.blocks[fastest.1.min(model.blocks.len() - 1)];
            return CycleError::TooFast { cycle, block: b.id, travel: fastest.0, limit, speed: fastest.0 / dt };
        }
        let k = (flags.overlap_contact as usize).min(model.contacts.len().saturating_sub(1));
        let c = &model.contacts[k];
        CycleError::Overlap {
            cycle,
            block1: model.blocks[c.block1 as usize].id,
            block2: model.blocks[c.block2 as usize].id,
            overlap: -c.gap,
            limit: 0.5 * model.tol.round,
            x: c.point[0],
            y: c.point[1],
        }
    }

    fn run(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool) -> Result<CycleReport, CycleError> {
        if model.timestep <= 0.0 || !model.timestep.is_finite() {
            return Err(CycleError::Setup("the time step is not set".into()));
        }
        // A model whose blocks or corners alone are past the adapter's binding limit is refused
        // now, not after the full detection (seconds at 10⁶ blocks).
        let cap = kernels::binding_cap(&self.dev);
        kernels::check_fits("blocks", std::mem::size_of::<Block<R>>(), model.blocks.len(), cap, self.dev.precision)
            .and_then(|()| kernels::check_fits("corners", std::mem::size_of::<Corner<R>>(), model.corners.len(), cap, self.dev.precision))
            .map_err(device_error)?;
        let mut report = CycleReport::default();
        let mut adjacency = std::mem::take(&mut self.adjacency);
        // As on the CPU: a full detection first (the executor may have changed the model), then
        // the force sums the first step needs; unless the model is the very state the last run
        // left (CYCLE after CYCLE), which the device still holds with its contacts, its force
        // sums and the f32 digits the model does not keep: then the run goes on from there.
        let resume = std::mem::take(&mut self.resumable) && self.buffers.is_some() && *model == self.last_good;
        if resume {
            self.write_params(model);
        } else {
            cpu::maybe_update_topology(model, &mut adjacency, &mut report, true);
            self.list_in_order = true;
            self.upload_all(model, &adjacency).map_err(device_error)?;
            self.write_params(model);
            self.run_batch(1, true).map_err(device_error)?;
            self.readback(model).map_err(device_error)?;
        }
        let mut energy_check = cpu::EnergyCheck::new(model);
        let cracking = (0..model.blocks.len()).any(|b| crate::topology::cracking::is_point_load_candidate(model, b));
        // The last good state: this CPU copy holds its topology (and, until the first device
        // checkpoint, its state); after a passed energy check the state is on the device
        // (`take_checkpoint`) and the copy is re-taken only when the topology changed since.
        if let Some(ck) = &mut self.checkpoint {
            ck.valid = false;
        }
        let mut last_good = std::mem::take(&mut self.last_good);
        self.last_good_contacts = None;
        if !resume {
            // (When resuming it is the model already.)
            last_good.clone_from(model);
        }
        crate::profile::mark_cycles_start();
        let mut last_good_generation = (self.generation, self.block_generation);
        let mut done_total = 0u64;
        // Cycles per submission: up to the next energy check, fewer while contact updates halt
        // batches early. A halted batch still encodes and submits the dispatches of its remaining
        // cycles (with zeroed grids: they launch nothing).
        let mut batch_cap = cpu::CHECK_INTERVAL;
        // The last batch stopped for a contact update: the next one brings the state back with
        // its flags (`run_batch_with_state`).
        let mut busy = false;
        // Cycles until the next contact update is expected, from the velocities at the last one
        // (`cycles_to_next_update`): a batch that would run past it is cut there, since the
        // cycles after the halt are still encoded and submitted.
        let mut expected_update: Option<u64> = None;
        // Read-backs for a contact update bring the contacts' summaries only (`pack_contacts`),
        // since the splice keeps the rest on the device; cracking reads everything.
        let packed = self.splice && !cracking;
        let result = (|| -> Result<(), CycleError> {
            while done_total < cycles {
                let left = cycles - done_total;
                let mut batch = if cracking { 1 } else { (cpu::CHECK_INTERVAL - done_total % cpu::CHECK_INTERVAL).min(left).min(batch_cap) };
                if let Some(k) = expected_update {
                    batch = batch.min(k.max(1));
                }
                self.write_params(model);
                let partial_reads = self.splice && !cracking && self.partial_reads_pay();
                let (flags, state_read) = if busy && !cracking && !partial_reads {
                    self.run_batch_with_state(batch, model, packed).map_err(device_error)?
                } else {
                    (self.run_batch(batch, false).map_err(device_error)?, false)
                };
                busy = flags.update_due != 0;
                let done = flags.cycles_done as u64;
                batch_cap = if done < batch { (2 * done).max(1) } else { (2 * batch_cap).min(cpu::CHECK_INTERVAL) };
                for _ in 0..done {
                    model.time += model.timestep;
                }
                model.cycle += done;
                done_total += done;
                expected_update = expected_update.map(|k| k.saturating_sub(done)).filter(|&k| k > 0);
                if flags.errors != 0 {
                    self.readback(model).map_err(device_error)?;
                    return Err(Self::error_from_flags(model, &flags));
                }
                if done == 0 {
                    return Err(CycleError::Setup("GPU: a batch ran no cycle".into()));
                }
                report.cycles += done;
                let at_check = done_total % cpu::CHECK_INTERVAL == 0 || done_total == cycles;
                let mut handled = false;
                if partial_reads && flags.update_due != 0 {
                    // Stage 7 on what it touches (`partial_contact_update`), unless it needs the
                    // whole state.
                    match self.partial_contact_update(model, &mut adjacency, &mut report).map_err(device_error)? {
                        PartialUpdate::Declined => {}
                        PartialUpdate::NotDue => handled = true,
                        PartialUpdate::Updated(expected) => {
                            self.list_in_order = true;
                            expected_update = expected;
                            handled = true;
                        }
                    }
                }
                if !handled && (cracking || flags.update_due != 0) {
                    // Stage 7 on the CPU, on the read-back state: cracking, then contact updates.
                    // The cracking criterion reads every block's forces, fixed ones too.
                    if cracking {
                        self.readback(model).map_err(device_error)?;
                    } else if !state_read {
                        self.read_live_state(model, packed).map_err(device_error)?;
                    }
                    // The model's state is read back only when the CPU needs it (here, the next
                    // stage 7, an error, the end of the run): after a change the device holds it.
                    if cracking && cpu::crack_step(model, &adjacency, &mut report) {
                        adjacency = Adjacency::build(model.blocks.len(), &model.contacts);
                        if let Some(dt) = model.critical_timestep() {
                            if dt < model.timestep {
                                model.timestep = dt;
                                report.timestep_changes.push((model.cycle, dt));
                            }
                        }
                        self.upload_all(model, &adjacency).map_err(device_error)?;
                        self.list_in_order = false;
                        self.write_params(model);
                        self.run_batch(1, true).map_err(device_error)?;
                    }
                    // After a packed read the update may go on only if the splice will follow
                    // it, which needs the list in order (the whole upload would send stale
                    // fields): otherwise the contacts are read whole first (the device has not
                    // moved since).
                    let splice_follows = self.splice && self.list_in_order;
                    if packed && !splice_follows && cpu::topology_update_due(model) {
                        self.read_live_state(model, false).map_err(device_error)?;
                    }
                    if cpu::maybe_update_topology(model, &mut adjacency, &mut report, false) {
                        self.list_in_order = true;
                        expected_update = cycles_to_next_update(model);
                        self.upload_reset_distances(model);
                        let edit = adjacency.take_edit().filter(|e| splice_follows && e.old_len as usize == self.counts.2);
                        match edit {
                            _ if model.contacts.is_empty() => self.upload_contacts(model, &adjacency),
                            Some(edit) => {
                                // Every kept contact was read: each is patched, and takes its
                                // bases from the model.
                                let mut created = edit.inserted_at.iter().peekable();
                                let patches: Vec<[u32; 2]> = (0..model.contacts.len() as u32)
                                    .filter(|&i| created.next_if_eq(&&i).is_none())
                                    .map(|i| [i, model.contacts[i as usize].feature])
                                    .collect();
                                self.edit_contact_list(model, &edit, None);
                                self.splice_contacts(model, &adjacency, &edit, &patches)
                            }
                            None if packed && splice_follows => {
                                return Err(CycleError::Setup("GPU: the contact update sorted a list kept in order (a bug; run with BLOCKDEM_CONTACT_SPLICE=0)".into()))
                            }
                            None => self.upload_contacts(model, &adjacency),
                        }
                        .map_err(device_error)?;
                        self.write_params(model);
                        self.run_batch(1, true).map_err(device_error)?;
                    }
                }
                if at_check {
                    // The energy check on device sums; the state stays on the device.
                    let (kinetic, strain, external_work) = {
                        let _p = crate::profile::scope(crate::profile::Stage::Checks);
                        self.energy_sums().map_err(device_error)?
                    };
                    if let Err(e) = energy_check.check_sums(model.cycle, kinetic + strain, external_work, model.frac) {
                        self.readback(model).map_err(device_error)?;
                        return Err(e);
                    }
                    // The caller may end the run here (an interrupt): as if `cycles` were done.
                    let go_on = progress(done_total) && done_total < cycles;
                    if !go_on {
                        // The run's end: the state comes back to the model, which becomes the
                        // last good state below. No device checkpoint or CPU copy of the
                        // topology is taken for it (the next run starts by invalidating the
                        // one, the other would be a copy of a copy); if the read-back fails,
                        // the checkpoint before, with its topology, is what is restored.
                        crate::profile::mark_cycles_end();
                        self.readback(model).map_err(device_error)?;
                    } else {
                        self.take_checkpoint();
                        let now = (self.generation, self.block_generation);
                        if last_good_generation != now {
                            let _p = crate::profile::scope(crate::profile::Stage::Checks);
                            if last_good_generation.1 == now.1 {
                                last_good.clone_settings_from(model);
                                let identities = self.last_good_contacts.get_or_insert_with(Vec::new);
                                model.contacts.par_iter().map(ContactIdentity::of).collect_into_vec(identities);
                            } else {
                                last_good.clone_from(model);
                                self.last_good_contacts = None;
                            }
                            last_good_generation = now;
                        }
                        last_good.cycle = model.cycle;
                        last_good.time = model.time;
                        last_good.timestep = model.timestep;
                    }
                    if !go_on {
                        break;
                    }
                }
            }
            Ok(())
        })();
        match result {
            Ok(()) => {
                // The state read back last, for the next run to compare with.
                last_good.clone_from(model);
                self.last_good_contacts = None;
                self.last_good = last_good;
                self.adjacency = adjacency;
                self.resumable = true;
                Ok(report)
            }
            Err(e) => {
                if let Err(d) = self.restore_checkpoint(&mut last_good) {
                    return Err(device_error(d));
                }
                Err(energy_check.roll_back(e, model, last_good))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_next_contact_update_is_expected_when_the_fastest_block_passes_its_threshold() {
        let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nROUND 0.1\nBLOCK 0,0 0,1 1,1 1,0\nBLOCK 5,0 5,1 6,1 6,0\nVELOCITY 0 1 0 1 5 0\nCYCLE 0\n";
        let mut m = crate::scenes::run_deck_on(deck, Box::new(cpu::CpuBackend::new())).expect("deck runs");
        let s = 5.0 * m.timestep;
        let threshold = m.blocks[0].update_threshold(&m.tol);
        // The moving block raises the flag on the cycle its displacement first exceeds the
        // threshold; the block at rest never does.
        assert_eq!(cycles_to_next_update(&m), Some((threshold / s).floor() as u64 + 1));
        m.blocks[0].moved_since_update = threshold - 2.5 * s;
        assert_eq!(cycles_to_next_update(&m), Some(3));
        m.blocks[0].velocity = [0.0, 0.0];
        assert_eq!(cycles_to_next_update(&m), None);
    }
}
