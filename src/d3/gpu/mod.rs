//! D3's cycle on the GPU (wgpu + WGSL, f32 or f64), on the chassis's device, precision and Pod
//! machinery (`crate::gpu`).
//!
//! # What runs where
//!
//! The state lives in storage buffers (`layout`): blocks (centroid, velocity, angular momentum
//! and velocity, orientation quaternion, mass, the inverse reference-frame inertia, load,
//! fixity, the stage-6 sums), their vertices, face planes and edges, the contacts (normal,
//! its law block's material) and their logical contacts (kind and vertices, point, gap, normal and shear
//! force). One cycle is three kernels, each the twin of the CPU function of its name:
//!
//! 1. `gather` (stage 6, `cpu::gather`): per block, its weight and load and its contacts' forces
//!    and moments, summed over the block's adjacency list in the contacts' order (no atomics on
//!    floats; the order is the CPU's);
//! 2. `law_of_motion` (stages 1–2, `motion::law_of_motion`): central differences, Euler's
//!    equations through the angular momentum, the quaternion by the implicit midpoint rule, the
//!    vertices placed;
//! 3. `track_contact` (stage 4, `contact::track_contact`): per contact, the common plane
//!    afresh, each logical contact placed anew with its gap, the force–displacement law with the
//!    shear force's rotation, Coulomb with cohesion;
//! 4. in a scene with Griffith's cracking candidates, `end_cycle` (one invocation, its twin
//!    [`end_cycle`]): the cycle counted, and the batch halted where a block's screen fired
//!    ("Cracking on the device").
//!
//! # Detection stays on the CPU, between cycles
//!
//! Which pairs are neighbours (stage 7, `topology`) and which logical contacts each contact has
//! (`contact::logical_contacts`: the touching features' projections intersected) change only on
//! the CPU. The CPU backend finds the logical contacts afresh every cycle; the GPU backend keeps
//! the set of the last detection and moves each member with its blocks (`track_contact`), and
//! detects again once a block has travelled half the contact-forming distance since the last
//! detection (`DETECTION_SHARE`): a feature further than that distance from the common plane
//! at a detection (so not a logical contact) cannot then have reached it, the two blocks having
//! closed on each other by less than the distance. A detection runs stage 7 and the CPU's stage 4
//! with Δt = 0 (new logical contacts, their shear forces carried by key; normal forces from the
//! gaps) for the blocks that moved ("Partial detections"), on their contacts read back, splices
//! the fresh contacts into the device's buffers (`splice`), renews the blocks' travel and
//! adjacency ranges there and uploads the adjacency lists where they changed; vertices, planes and edges (the
//! shapes) stay on the device.
//!
//! # Partial detections
//!
//! Most blocks of an impact scene hardly move between two detections (the wall the projectile
//! has not reached), and a whole detection (every pair searched, every contact's logical
//! contacts found afresh on the CPU) cost seconds at 10⁶ blocks, every ~160 cycles of the
//! struck wall. So a detection is partial where the lists are not stale (blocks made, cut or
//! deleted make them so): the blocks whose travel since their last refresh has reached
//! `REFRESH_SHARE` of the allowance are the moved ones; their pairs are searched afresh in a
//! grid of all blocks kept from one partial detection to the next, the moved ones re-inserted
//! (`topology::update_neighbours_kept`, `kept_grid`), the contacts that touch one of them
//! have their logical contacts found afresh (`cpu::contact_stage_of`), and only their travel
//! starts again from zero. A contact between two blocks that did not move keeps the logical
//! contacts the device tracks. The bound that made tracking safe holds per contact: each of its
//! blocks has travelled less than the allowance since the contact was last refreshed (a
//! detection is called as soon as any block reaches it, and a block's refresh refreshes all its
//! contacts), so the two have closed by less than the contact-forming distance. The transfers
//! are the changed contacts alone (`splice`): the moved blocks' contacts are gathered on the
//! device and read back, the fresh ones uploaded and spliced among the kept ones by a kernel
//! (`splice_contacts`), and the block records renewed in place (`renew_blocks`); in f64 the
//! state bit for bit a whole re-upload's.
//! `GpuBackend::set_whole_detections` makes every detection whole and
//! `GpuBackend::set_whole_uploads` every transfer, for comparison; `HostTimes` counts the
//! contacts refreshed and the bytes moved.
//!
//! So the GPU's results are not the CPU's bit for bit even in f64: between detections a vertex
//! that slides off its face keeps its logical contact (with the gap the ray through the other
//! block finds), and an edge–edge contact whose edges stop crossing is held at the nearer end,
//! until the next detection, within half the contact-forming distance of travel. The twins and
//! tests/suite/d3_gpu.rs measure the difference.
//!
//! Cycles run in batches sized to the next detection at the velocities of the batch's start
//! (`cycles_to_detection`); after each the blocks are read back (travel, finiteness, the
//! too-fast check). The time step is the CPU's rule (`Model::timestep`, from the logical
//! contacts there are and their lever arms) worked out on the device from its state at each
//! batch's start (`critical_rows`, `device_timestep`) and held over the batch, where the CPU
//! renews it every cycle. Everything the device does is in a fixed order, so a rerun repeats bit
//! for bit.
//!
//! # The energy check and the last good state
//!
//! Every hundred cycles the run checks that kinetic + strain energy has not outgrown the energy
//! put in and that no contact has been driven through (`driver::cycles`), and keeps the state as
//! the last good one. The blocks come back after every batch (travel, finiteness, the too-fast
//! check), so their terms are the CPU's (`Model::energies_at`); the contacts' springs are summed
//! on the device, where their state is (`contact_energy`, twin `model::contact_energy`, a record
//! per workgroup read back), with the overlap test of `cpu::overlap_check` (a contact it finds
//! brings the contacts back for the CPU's check to name it). The time step comes from the device
//! too (`critical_rows`, twin: the rows of `Model::critical_timestep`: each block's Gershgorin row
//! over its adjacency list in the contacts' order, from what the step reads of each block,
//! `layout::StepGive`, made at the upload; the largest row of each workgroup read back). The last
//! good state is the model (its blocks as read back) and a device copy of the contact and
//! logical buffers (`Checkpoint`, with the keys and bases they were taken under), read back into
//! it only when the run fails (`recover`). So a check reads back a record per workgroup, where it
//! read every contact and logical contact (at 10⁶ bricks about a gigabyte, every hundred
//! cycles), and makes no copy of the contacts on the CPU. The model's contacts are as the last
//! read-back left them: a detection reads back those of the blocks that moved, the run's end
//! (and a SAVE, a crack, a failure) every one.
//!
//! # Cracking on the device
//!
//! A block may crack at the end of any cycle (stage 7, `cracking::due` on the CPU's state after
//! the cycle, `cpu::cracks`). Griffith's law (constitutive 3–5 with TF, simply-deformable blocks;
//! SL-85-1 Appendix A ¶17) reads only the block's own internal stress, which the strain stage
//! sets in `law_of_motion` and stage 4 leaves: so each candidate screens itself there
//! (sdef.wgsl's `crack_screen`, twin `sdef::griffith_screen`), as the 2D engine's strain stage
//! raises `crack_due`. The screen bounds the principal stresses (Jacobi sweeps, the off-diagonal
//! part left and a margin for the round-off of the kernel and of the CPU's f64 check added,
//! `shaders::griffith_margin`), so that it fires wherever the exact check on the state read back
//! would find the block cracked, and a little early at worst. A block whose screen fires raises a
//! flag, and the batch halts at the END of that cycle (its stage 4 still runs, as on the CPU,
//! where the check follows the contacts): the CPU reads back the state of exactly that cycle
//! and runs the exact check, the cut and the upload as before; where the check says no (the
//! screen fired early) the run goes on. Batches of a Griffith scene are thus sized as any scene's
//! (`cycles_to_detection`, the energy checks), where each cycle used to be read back.
//!
//! The halting is the 2D engine's: the cycle's kernels are dispatched indirectly from grids in a
//! small halting record (`layout::Halt`), written at each batch's start; `end_cycle`, the
//! cycle's last kernel, counts the cycle and, where the flag is up, zeroes the grids, so the
//! batch's later cycles launch nothing and no kernel reads a flag. The kernels are held to eight
//! storage buffers (GL's limit on llvmpipe; the strain stage takes the eighth), so the flag lives
//! in the strain buffer, the `spare` word of a record after the blocks'
//! (`layout::screen_flag_offset`), and the halting record is bound to `end_cycle` alone, with the
//! params and the strain buffer (a buffer an indirect dispatch reads may not be bound for writing
//! to the kernel it launches). A scene without Griffith's candidates dispatches directly as
//! before; one with point-load candidates keeps its cycle-by-cycle read-back (`advance`: that law
//! reads pairs of contact forces on a block, which no kernel gathers).
//!
//! # f32: each contact in a frame of its own
//!
//! The f64 kernels work in global axes, as the CPU does. In f32 a coordinate's round-off is
//! ulp(|x|), and a normal force kn·gap from positions in global axes moved in steps of
//! kn·ulp(|x|) a logical contact: a settled stack at z = 1…4 m rang in a limit cycle of such steps
//! under heavy damping (4.9e-2 of the weight on an H100), and at 1000 m a step (6e4 N at 1e9 N/m)
//! outweighed the blocks. So the f32 kernels (the prelude's RELATIVE) keep each centroid as a
//! compensated pair, each vertex as its offset R·l from its centroid (stage 2), and work each
//! contact in a frame at the midpoint of its blocks' centroids (`track_contact.wgsl`), where a gap
//! is resolved at the round-off of the offsets near the contact; a logical contact's point is kept
//! from its block 1's centroid (`point_origin`), which the read-back adds.
//!
//! # Concave blocks
//!
//! A concave block is cut into convex parts when it is built (`d3::decompose`, `Block::parts`),
//! and contact detection and the contact law run between parts of different blocks, as on the
//! CPU: the CPU's detection finds the part pairs (`Contact::parts`), and `track_contact` works
//! each contact's geometry between its two convex bodies, a convex block or one part of a
//! concave one (`layout.wgsl`'s `contact_bodies`). A part's vertices lie in its block's vertex
//! range, in the block's reference frame about the block's centroid, so `law_of_motion` places
//! them as any vertex of the block (in f32 as offsets from the block's centroid, so the
//! contact's frame is its blocks' midpoint as for convex blocks); each part has a record of its
//! ranges (vertices, face planes, edges) and radius after the blocks in the block buffer, and
//! each contact's two bodies are named after the blocks' lists in the adjacency buffer, so the
//! kernels keep to their eight storage buffers. The points and forces are the contact's blocks':
//! `gather` sums each part-contact's force, with its moment about the block's centroid, into its
//! block. The read-back places the parts' vertices with the block's on the CPU
//! (`Block::place_vertices`), and the contacts keep the parts the detection gave them.
//!
//! # SAVE and RESTART
//!
//! The device holds more than the model it reads back: the logical contacts of the last
//! detection (dead ones in place), the energy sums since the last upload, the time step of the
//! batch, and in f32 each centroid's compensated pair (and the points from block 1's centroid,
//! save format 4: a format-3 file's f32 state is not taken). SAVE after a GPU run keeps them as the
//! device holds them (`restart::DeviceState`, read by `device_state_as`); RESTART on a GPU of the
//! same precision checks them against the model and uploads them as they were (`restore_as`),
//! so the run goes on as the saving run would have, bit for bit (tests/suite/d3_gpu.rs). Each CYCLE's
//! batches end at its energy checks (every `driver::CHECK_INTERVAL` cycles of the run), where the
//! next batch takes its time step and length afresh; a SAVE after a number of cycles that is a
//! multiple of that interval therefore continues the straight run exactly, another cuts a batch
//! the straight run would not have cut (as two CYCLEs do on one backend without a SAVE).
//! A concave scene's saved blocks and vertices hold its parts' records and vertices as the
//! device does (the format is unchanged: a convex scene's buffers are as they were).
//!
//! # Boundary conditions (BOUNDARY, ¶35e)
//!
//! A scene with held blocks or loaded faces runs the kernels compiled with the prelude's BOUNDARY
//! (a scene without runs kernels without their code, `Variant`). A held block is `fixed` =
//! `BLOCK_HELD`: `law_of_motion` steps it at its velocity and spin (`held_motion`, the twin of
//! `motion::held_motion`), and the read-back renews its angular momentum I(t)ω on the CPU. A
//! block's loaded faces are records in the plane buffer after its face planes (`layout::Plane`),
//! read by `gather` (their resultants, `Block::boundary_load`) and by `law_of_motion` (their work,
//! `Block::boundary_work`) from the vertices as placed; they bind no buffer of their own, so the
//! kernels stay at eight storage buffers with the strain stage's.
//!
//! # The energy ledger
//!
//! The kernels add the work of gravity and loads, the mass damping's and the dashpots'
//! dissipation (per block) and friction and released spring energy (per contact) to
//! accumulators that count from the upload; the model's totals are the values at the upload
//! (`Bases`) plus the accumulators, summed in f64 on the CPU at each read-back.

pub mod layout;
pub mod profile;
pub mod shaders;
pub mod splice;

use std::rc::Rc;

use rayon::prelude::*;

use glam::{DMat3, DQuat, DVec3};

use super::contact::Appearing;
use super::cpu::{self, contact_stage};
use super::geometry::Shape;
use super::model::{LogicalKind, Model};
use super::restart::DeviceState;
use super::topology;
use crate::driver::{self, CycleError, CycleReport};
use crate::gpu::real::Real;
use crate::gpu::wgsl::{dispatch_grid, layouts, storage, uniform, validate, workgroup_size};
use crate::gpu::{AdapterChoice, AdapterSummary, GpuDevice, GpuError, Precision};
use splice::Keys;

/// The share of the contact-forming distance a block may travel between detections.
pub const DETECTION_SHARE: f64 = 0.5;

/// A partial detection refreshes the blocks that have travelled this share of their
/// allowance (`DETECTION_SHARE` of the contact-forming distance) or more, not only the ones
/// that reached it: a block left at 0.9 of it would call the next detection after a tenth of a
/// batch ("Partial detections").
pub const REFRESH_SHARE: f64 = 0.5;

/// What a scene's kernels run beyond the rigid blocks' cycle: the strain stage of
/// simply-deformable blocks (`sdef`, the strain buffer at binding 8) and the boundary conditions
/// (`boundary`: held blocks and loaded faces, BOUNDARY; nothing more bound). A scene without
/// them runs kernels without their code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Variant {
    sdef: bool,
    boundary: bool,
}

impl Variant {
    /// The variant `model` needs.
    fn of(model: &Model) -> Variant {
        Variant { sdef: model.blocks.iter().any(|b| b.is_sdef()), boundary: model.blocks.iter().any(|b| b.held || !b.boundary_stress.is_empty()) }
    }
}

/// The kernels of the cycle, compiled for the device's precision.
struct Kernels {
    variant: Variant,
    group: wgpu::BindGroupLayout,
    pipelines: Vec<wgpu::ComputePipeline>,
    /// `end_cycle` and its bindings' layout (the params, the strain buffer, the halting record),
    /// in a variant with the strain stage: the batches of a scene with Griffith's cracking
    /// candidates end each cycle with it ("Cracking on the device").
    end_cycle: Option<(wgpu::BindGroupLayout, wgpu::ComputePipeline)>,
}

impl Kernels {
    /// The kernels of a scene of `variant`: a rigid scene's, or with the strain stage and its
    /// buffer at binding 8, and/or the boundary conditions.
    fn new(dev: &GpuDevice, variant: Variant) -> Result<Self, GpuError> {
        let Variant { sdef, boundary } = variant;
        let mut entries = vec![uniform(0)];
        entries.extend((1..=if sdef { 8 } else { 7 }).map(|b| storage(b, false)));
        let (group, pipeline_layout) = layouts(&dev.device, if sdef { "d3 sdef" } else { "d3" }, &entries);
        let scopes = dev.creation_scopes();
        let mut pipelines = Vec::new();
        for (name, _) in shaders::KERNELS {
            let src = shaders::source_with(name, dev.precision, sdef, boundary).ok_or_else(|| GpuError::Shader(format!("no kernel {name}")))?;
            validate(&src, dev.precision).map_err(|e| GpuError::Shader(format!("d3/{name}.wgsl: {e}")))?;
            let module = dev.device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(src.into()) });
            pipelines.push(dev.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(name),
                compilation_options: Default::default(),
                cache: None,
            }));
        }
        let end_cycle = if sdef {
            Some(kernel_of_its_own(dev, "end_cycle", shaders::end_cycle_source(dev.precision), &[uniform(0), storage(8, false), storage(9, false)])?)
        } else {
            None
        };
        scopes.check(dev)?;
        Ok(Kernels { variant, group, pipelines, end_cycle })
    }
}

/// The model's energy terms when the accumulators on the device were zero: the blocks' (work,
/// mass damping, dashpots) at the block upload, the contacts' (friction, released) at the
/// contact upload.
#[derive(Clone, Copy, Debug, Default)]
struct Bases {
    external_work: f64,
    mass_damping: f64,
    contact_damping: f64,
    friction: f64,
    released: f64,
}

/// The state on the device.
struct State {
    params: wgpu::Buffer,
    blocks: wgpu::Buffer,
    vertices: wgpu::Buffer,
    planes: wgpu::Buffer,
    edges: wgpu::Buffer,
    contacts: wgpu::Buffer,
    logicals: wgpu::Buffer,
    adjacency: wgpu::Buffer,
    /// The adjacency buffer's words as uploaded, kept on the host: a partial detection finds
    /// the moved blocks' contacts in it without a pass over the list.
    adjacency_host: Adjacency,
    /// The simply-deformable blocks' strain state (`layout::SdefBlock`, one per block, then the
    /// screen's record), in a scene with such blocks.
    sdef: Option<wgpu::Buffer>,
    /// The halting record (`layout::Halt`, its grids the indirect dispatches') and `end_cycle`'s
    /// bind group, in a scene with the strain stage.
    halt: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    /// The kernels the scene runs: `GpuBackend::kernels[variant]`.
    variant: usize,
    bind: wgpu::BindGroup,
    /// The logical contacts' kinds as uploaded, contact by contact (the read-back's keys;
    /// shared with the device checkpoint taken under them).
    keys: Rc<Keys>,
    bases: Bases,
    /// The time step in the params buffer.
    dt: f64,
    /// What the critical step reads of each block (`layout::StepGive`), made at the upload.
    gives: wgpu::Buffer,
    /// The contact-forming distance (`Model::contact_tolerance`, a pass over every block's
    /// shape: 2 ms at 10⁵ blocks) as of the upload: the shapes change only where the topology
    /// does, which uploads again; each run's start renews it too.
    tol: f64,
}

/// The GPU backend for D3.
pub struct GpuBackend {
    dev: GpuDevice,
    /// The kernels compiled: the rigid scene's first, then each [`Variant`] the first time a
    /// scene needs it.
    kernels: Vec<Kernels>,
    state: Option<State>,
    last_good: Model,
    resumable: bool,
    /// RESTART's device state, uploaded at the next run's start where it resumes.
    pending: Option<DeviceState>,
    /// Batches submitted since the backend was made (each a submission and a read-back of the
    /// blocks): with [`GpuBackend::batches`], how a run's cost is seen from outside.
    batches: u64,
    /// The longest batch of a scene with Griffith's candidates: a halted batch still submits
    /// the (empty) dispatches of the cycles after its halt, so where screens fire batch after
    /// batch (a stress within the margin below TF) the batches shrink to twice the cycles the
    /// last one ran, and grow back by doubling (as the 2D engine's `batch_cap`); each run starts
    /// at the energy checks' interval.
    screened_cap: u64,
    /// Host time the batches took outside the kernels, since the backend was made: each batch's
    /// read-back of the blocks, and the detections (their read-back of the contacts, stage 7,
    /// the CPU's stage 4 and the re-upload), with how many (`host_times`, the bench's shares).
    host: HostTimes,
    /// Every detection between batches whole (all pairs searched, every contact's stage 4), as
    /// before partial detections: for comparison ([`GpuBackend::set_whole_detections`]).
    whole_detections: bool,
    /// Every partial detection's transfers whole (every contact read back and uploaded), as
    /// before they were spliced: for comparison ([`GpuBackend::set_whole_uploads`]).
    whole_uploads: bool,
    /// `splice_contacts` (a partial detection's splice of the contact buffers, `splice`) and its
    /// bindings' layout: its output at bindings 5 and 6, its own at 9 to 15.
    splice_kernel: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    /// `renew_blocks` (a partial detection's renewal of the block records, `splice`) and its
    /// bindings' layout: the params, the blocks and its renewals at binding 9.
    renew_kernel: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    /// The contact and logical buffers the last splice replaced, the next one's output where
    /// they hold it.
    spare_contacts: Option<(wgpu::Buffer, wgpu::Buffer)>,
    /// The detection grid kept from one partial detection to the next (`topology::KeptGrid`: the
    /// moved blocks re-inserted); None after an upload or a whole detection (made again at the
    /// next partial one).
    kept_grid: Option<topology::KeptGrid>,
    /// `contact_energy` (the energy check's contact sums and overlap test) and its bindings'
    /// layout: the params, blocks, contacts, logical contacts and its records (binding 9).
    energy_kernel: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    /// Its records, one per workgroup (kept from check to check, grown as needed).
    energy_out: Option<wgpu::Buffer>,
    /// `critical_rows` (the critical step's largest row on the device) and its bindings'
    /// layout: the params, blocks, contacts, logical contacts, adjacency, the blocks' gives
    /// (binding 9) and its records (binding 10).
    step_kernel: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    /// Its records, one per workgroup (grown as needed).
    step_out: Option<wgpu::Buffer>,
    /// The contacts' part of the last good state, on the device ("The energy check and the last
    /// good state").
    checkpoint: Option<Checkpoint>,
    /// The time step an energy check took from the device (`device_timestep`), for the next
    /// batch of the run to start with (the state is as the check left it): taken once.
    next_timestep: Option<f64>,
}

/// The contacts' part of the last good state, on the device: copies of the contact and logical
/// buffers taken when an energy check passed (device to device), with the keys, counts and bases
/// they were taken under. The blocks' part is in the model the run keeps (read back after every
/// batch); a failure reads these back into it (`recover`).
struct Checkpoint {
    contacts: wgpu::Buffer,
    logicals: wgpu::Buffer,
    keys: Rc<Keys>,
    contact_count: usize,
    bases: Bases,
    /// Whether it holds a state of the current run (the buffers are kept from run to run).
    valid: bool,
}

/// What a D3 GPU backend's runs spent on the host ([`GpuBackend::host_times`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HostTimes {
    /// Seconds reading the blocks back after each batch (travel, finiteness, the too-fast check).
    pub readback_s: f64,
    /// Seconds in detections between batches, and how many there were.
    pub detection_s: f64,
    pub detections: u64,
    /// Over those detections: the contacts in the lists, and those whose logical contacts were
    /// found afresh (every one in a whole detection; a partial one's, those of the blocks that
    /// moved).
    pub listed: u64,
    pub refreshed: u64,
    /// The spliced detections whose lists kept their keys (no contact made or dropped): the
    /// moved blocks' contacts renewed in place, the adjacency kept on the device.
    pub kept_lists: u64,
    /// Bytes the detections moved between host and device (read back and uploaded): a whole
    /// transfer's every contact and logical contact both ways, a spliced one's the moved
    /// blocks' contacts (`splice`); the blocks and adjacency in both.
    pub detection_bytes: u64,
    /// Seconds in the energy checks (every hundred cycles: `contact_energy` and `critical_rows`
    /// on the device and their records read back, the blocks' terms on the CPU, the device
    /// checkpoint's copy after one passed), and how many there were.
    pub checks_s: f64,
    pub checks: u64,
}

fn device_error(e: GpuError) -> CycleError {
    match e {
        GpuError::DoesNotFit(_) => CycleError::DoesNotFit(e.to_string()),
        _ => CycleError::Setup(e.to_string()),
    }
}

impl GpuBackend {
    /// Opens the adapter `choice` names in `precision` and compiles the kernels.
    pub fn new(choice: &AdapterChoice, precision: Precision) -> Result<Self, GpuError> {
        let dev = GpuDevice::open(choice, precision)?;
        let kernels = vec![Kernels::new(&dev, Variant { sdef: false, boundary: false })?];
        let energy_kernel = energy_kernel(&dev)?;
        let step_kernel = step_kernel(&dev)?;
        let splice_kernel = splice_kernel(&dev)?;
        let renew_kernel = renew_kernel(&dev)?;
        Ok(GpuBackend {
            dev,
            kernels,
            state: None,
            last_good: Model::default(),
            resumable: false,
            pending: None,
            batches: 0,
            screened_cap: driver::CHECK_INTERVAL,
            host: HostTimes::default(),
            whole_detections: false,
            whole_uploads: false,
            splice_kernel,
            renew_kernel,
            spare_contacts: None,
            kept_grid: None,
            energy_kernel,
            energy_out: None,
            step_kernel,
            step_out: None,
            checkpoint: None,
            next_timestep: None,
        })
    }

    /// Makes every detection between batches whole (`true`: every pair searched, every
    /// contact's logical contacts found afresh, as before partial detections) or partial (the
    /// default: those of the blocks that moved; "Partial detections").
    pub fn set_whole_detections(&mut self, whole: bool) {
        self.whole_detections = whole;
    }

    /// Makes every partial detection's transfers whole (`true`: every contact and logical contact
    /// read back and uploaded, as before they were spliced) or spliced (the default: the moved
    /// blocks' contacts only, `splice`).
    pub fn set_whole_uploads(&mut self, whole: bool) {
        self.whole_uploads = whole;
    }

    pub fn adapter(&self) -> &AdapterSummary {
        &self.dev.summary
    }

    pub fn precision(&self) -> Precision {
        self.dev.precision
    }

    /// How many batches of cycles this backend has submitted (each ends with the blocks read
    /// back): a run of n cycles cracked cycle by cycle takes n, one in batches fewer.
    pub fn batches(&self) -> u64 {
        self.batches
    }

    /// The host time the runs since the backend was made spent outside the kernels (read-backs,
    /// detections): with a run's wall time, the share a bench reports.
    pub fn host_times(&self) -> HostTimes {
        self.host
    }

    /// Runs `cycles` cycles of `model` through the run driver (`progress` is told the cycles done
    /// at each check and may end the run there: false), what the run does added to `report` (on
    /// error: up to the last good state, which the model is left at). `Backend::run` returns it.
    pub fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        let resume = driver::prepare(self, model, report)?;
        let mut kept = std::mem::take(&mut self.last_good);
        let result = driver::cycles(self, model, cycles, resume, &mut kept, report, progress);
        self.last_good = kept;
        if result.is_err() {
            // The device holds a state past the last good one: the next run starts afresh.
            self.state = None;
        }
        result?;
        // A run of no cycles that started afresh changed the model (its detection) but is no
        // state to go on from; one that resumed still is.
        self.resumable = (cycles > 0 || resume) && self.state.is_some();
        Ok(())
    }

    fn buffer(&self, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        // A binding may not be empty, nor shorter than one of its structs: zeros stand for an
        // empty list (the counts say it is empty).
        let zero = [0u8; 512];
        let contents = if bytes.is_empty() { &zero[..] } else { bytes };
        self.dev.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
    }

    /// The whole state uploaded (a run's start without resuming).
    fn upload(&mut self, model: &Model) -> Result<(), GpuError> {
        match self.dev.precision {
            Precision::F32 => self.upload_as::<f32>(model),
            Precision::F64 => self.upload_as::<f64>(model),
        }
    }

    fn upload_as<R: Real>(&mut self, model: &Model) -> Result<(), GpuError> {
        self.kept_grid = None;
        fits::<R>(model, crate::gpu::device::binding_cap(&self.dev))?;
        let storage_usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let (vertices, planes, edges) = shape_pods::<R>(model);
        let vertices = self.buffer("d3 vertices", bytemuck::cast_slice(&vertices), storage_usage);
        let (blocks, contacts, logicals, adjacency, keys, host) = self.topology_buffers::<R>(model);
        let dt = model.timestep();
        self.install::<R>(model, dt, vertices, ([blocks, contacts, logicals, adjacency], host), keys, (&planes, &edges), bases(model))
    }

    /// The state made of its buffers: the shapes' planes and edges and the params (with the time
    /// step `dt`) made here, the rest given.
    #[allow(clippy::too_many_arguments)]
    fn install<R: Real>(
        &mut self,
        model: &Model,
        dt: f64,
        vertices: wgpu::Buffer,
        ([blocks, contacts, logicals, adjacency], adjacency_host): ([wgpu::Buffer; 4], Adjacency),
        keys: Keys,
        (planes, edges): (&[layout::Plane<R>], &[u32]),
        bases: Bases,
    ) -> Result<(), GpuError> {
        let storage_usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let uniform_usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let tol = model.contact_tolerance();
        let params = self.buffer("d3 params", bytemuck::bytes_of(&params::<R>(model, dt, tol)), uniform_usage);
        let planes = self.buffer("d3 planes", bytemuck::cast_slice(planes), storage_usage);
        let edges = self.buffer("d3 edges", bytemuck::cast_slice(edges), storage_usage);
        // The strain buffer where the scene has simply-deformable blocks (its kernels compiled
        // the first time one has).
        let sdef = sdef_pods::<R>(model).map(|pods| self.buffer("d3 sdef", bytemuck::cast_slice(&pods), storage_usage));
        let wanted = Variant::of(model);
        let variant = match self.kernels.iter().position(|k| k.variant == wanted) {
            Some(k) => k,
            None => {
                self.kernels.push(Kernels::new(&self.dev, wanted)?);
                self.kernels.len() - 1
            }
        };
        let bind = self.bind(variant, &[&params, &blocks, &vertices, &planes, &edges, &contacts, &logicals, &adjacency], sdef.as_ref());
        // The halting record and end_cycle's bindings (the params and the strain buffer, which a
        // detection's re-upload keeps).
        let halt = match (&sdef, &self.kernels[variant].end_cycle) {
            (Some(strain), Some((group, _))) => {
                let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
                let halt = self.buffer("d3 halt", bytemuck::bytes_of(&layout::Halt::default()), usage);
                let entries = [
                    wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 8, resource: strain.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 9, resource: halt.as_entire_binding() },
                ];
                let bind = self.dev.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("d3 end_cycle"), layout: group, entries: &entries });
                Some((halt, bind))
            }
            _ => None,
        };
        let keys = Rc::new(keys);
        let gives = self.buffer("d3 step gives", bytemuck::cast_slice(&step_gives::<R>(model)), storage_usage);
        self.state = Some(State {
            params,
            blocks,
            vertices,
            planes,
            edges,
            contacts,
            logicals,
            adjacency,
            adjacency_host,
            sdef,
            halt,
            variant,
            bind,
            keys,
            bases,
            dt,
            gives,
            tol,
        });
        Ok(())
    }

    /// The device state a SAVE keeps (`restart::DeviceState`): the blocks, vertices, contacts and
    /// logical contacts as the device holds them, the keys, the time step and the bases.
    fn device_state_as<R: Real>(&self, model: &Model) -> Result<Option<DeviceState>, GpuError> {
        let Some(s) = self.state.as_ref() else { return Ok(None) };
        let sizes = [
            record_count(model) * std::mem::size_of::<layout::Block<R>>(),
            vertex_count(model) * std::mem::size_of::<layout::Vertex<R>>(),
            model.contacts.len() * std::mem::size_of::<layout::Contact<R>>(),
            s.keys.logical_count() * std::mem::size_of::<layout::Logical<R>>(),
        ];
        let [blocks, vertices, contacts, logicals] = self.dev.read_parts(
            &[(&s.blocks, sizes[0] as u64), (&s.vertices, sizes[1] as u64), (&s.contacts, sizes[2] as u64), (&s.logicals, sizes[3] as u64)],
            |bytes| [0, 1, 2, 3].map(|k| bytes[k].to_vec()),
        )?;
        let b = s.bases;
        Ok(Some(DeviceState {
            f64_kernels: self.dev.precision == Precision::F64,
            dt: s.dt,
            bases: [b.external_work, b.mass_damping, b.contact_damping, b.friction, b.released],
            keys: s.keys.to_lists(),
            blocks,
            vertices,
            contacts,
            logicals,
            absolute_f32: false,
        }))
    }

    /// RESTART's device state uploaded as it was saved, after checking it against the model:
    /// each block's ranges of vertices, planes, edges and adjacency and its fixity as the model
    /// gives them, each contact's blocks and a run of logical contacts whose kinds and vertices
    /// are its keys. Err says what does not fit (the run then detects afresh).
    fn restore_as<R: Real>(&mut self, model: &Model, device: &DeviceState) -> Result<(), String> {
        fits::<R>(model, crate::gpu::device::binding_cap(&self.dev)).map_err(|e| e.to_string())?;
        let (vertices, planes, edges) = shape_pods::<R>(model);
        let (blocks, contacts, _, adjacency, _) = topology_pods::<R>(model);
        let saved_blocks: Vec<layout::Block<R>> = pods(&device.blocks, blocks.len(), "blocks")?;
        let _: Vec<layout::Vertex<R>> = pods(&device.vertices, vertices.len(), "vertices")?;
        let saved_contacts: Vec<layout::Contact<R>> = pods(&device.contacts, contacts.len(), "contacts")?;
        let logical_count: usize = device.keys.iter().map(Vec::len).sum();
        let saved_logicals: Vec<layout::Logical<R>> = pods(&device.logicals, logical_count, "logical contacts")?;
        let ranges = |b: &layout::Block<R>| {
            [
                b.fixed,
                b.vertex_start,
                b.vertex_count,
                b.plane_start,
                b.plane_count,
                b.edge_start,
                b.edge_dir_count,
                b.feature_count,
                b.adjacency_start,
                b.adjacency_count,
                b.stress_faces,
            ]
        };
        if let Some(k) = (0..blocks.len()).find(|&k| ranges(&blocks[k]) != ranges(&saved_blocks[k])) {
            return Err(match model.blocks.get(k) {
                Some(b) => format!("block {}'s lists are not the model's", b.id),
                None => format!("the concave blocks' part record {} (after the blocks) is not the model's", k - model.blocks.len() + 1),
            });
        }
        if device.keys.len() != contacts.len() {
            return Err(format!("{} contacts' keys for {} contacts", device.keys.len(), contacts.len()));
        }
        let mut start = 0usize;
        for (k, (c, keys)) in saved_contacts.iter().zip(&device.keys).enumerate() {
            let fits = [c.block1, c.block2] == model.contacts[k].blocks
                && c.logical_start as usize == start
                && c.logical_count as usize == keys.len()
                && saved_logicals[start..start + keys.len()].iter().zip(keys).all(|(l, kind)| logical_words(*kind) == [l.kind, l.v1, l.v2, l.v3, l.v4]);
            if !fits {
                return Err(format!("contact {}'s logical contacts are not its keys", model.contacts[k].id));
            }
            start += keys.len();
        }
        let storage_usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let buffers = [
            self.buffer("d3 blocks", &device.blocks, storage_usage),
            self.buffer("d3 contacts", &device.contacts, storage_usage),
            self.buffer("d3 logicals", &device.logicals, storage_usage),
            self.buffer("d3 adjacency", bytemuck::cast_slice(&adjacency.words), storage_usage),
        ];
        let vertices = self.buffer("d3 vertices", &device.vertices, storage_usage);
        let [external_work, mass_damping, contact_damping, friction, released] = device.bases;
        let bases = Bases { external_work, mass_damping, contact_damping, friction, released };
        self.install::<R>(model, device.dt, vertices, (buffers, adjacency), Keys::from_lists(&device.keys), (&planes, &edges), bases).map_err(|e| e.to_string())
    }

    /// The bind group of the buffers for the kernels `variant`, with the strain buffer `sdef` at
    /// binding 8 where the scene has one (the strain stage's kernels' group).
    fn bind(&self, variant: usize, buffers: &[&wgpu::Buffer; 8], sdef: Option<&wgpu::Buffer>) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> =
            buffers.iter().copied().chain(sdef).enumerate().map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() }).collect();
        self.dev.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("d3"), layout: &self.kernels[variant].group, entries: &entries })
    }

    /// The kernels of the scene on the device.
    fn scene_kernels(&self) -> &Kernels {
        &self.kernels[self.state.as_ref().map_or(0, |s| s.variant)]
    }

    /// The buffers a detection changes: blocks (their travel reset and adjacency lists),
    /// contacts, logical contacts and adjacency.
    #[allow(clippy::type_complexity)]
    fn topology_buffers<R: Real>(&self, model: &Model) -> (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer, wgpu::Buffer, Keys, Adjacency) {
        let storage_usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let (blocks, contacts, logicals, adjacency, keys) = topology_pods::<R>(model);
        (
            self.buffer("d3 blocks", bytemuck::cast_slice(&blocks), storage_usage),
            self.buffer("d3 contacts", bytemuck::cast_slice(&contacts), storage_usage),
            self.buffer("d3 logicals", bytemuck::cast_slice(&logicals), storage_usage),
            self.buffer("d3 adjacency", bytemuck::cast_slice(&adjacency.words), storage_usage),
            keys,
            adjacency,
        )
    }

    /// After a detection: the blocks, contacts, logical contacts and adjacency re-uploaded (the
    /// shapes stay), the bases moved to the model's totals now.
    fn reupload(&mut self, model: &Model) -> Result<(), GpuError> {
        let cap = crate::gpu::device::binding_cap(&self.dev);
        match self.dev.precision {
            Precision::F32 => fits::<f32>(model, cap)?,
            Precision::F64 => fits::<f64>(model, cap)?,
        }
        let (blocks, contacts, logicals, adjacency, keys, host) = match self.dev.precision {
            Precision::F32 => self.topology_buffers::<f32>(model),
            Precision::F64 => self.topology_buffers::<f64>(model),
        };
        self.host.detection_bytes += blocks.size() + contacts.size() + logicals.size() + adjacency.size();
        let Some(s) = self.state.as_ref() else { return Ok(()) };
        let bind = self.bind(s.variant, &[&s.params, &blocks, &s.vertices, &s.planes, &s.edges, &contacts, &logicals, &adjacency], s.sdef.as_ref());
        let s = self.state.as_mut().expect("state");
        (s.blocks, s.contacts, s.logicals, s.adjacency, s.bind, s.keys) = (blocks, contacts, logicals, adjacency, bind, Rc::new(keys));
        s.adjacency_host = host;
        s.bases = bases(model);
        s.tol = model.contact_tolerance();
        // The params hold the counts the kernels bound their loops and the contacts' bodies'
        // place in the adjacency by (`contact_bodies`): the contacts may be more or fewer now.
        // (They were written only where the time step changed, which hid this where the step
        // moved at every batch; with a step held by a simply-deformable block's own limit, a
        // new contact went untracked and every contact read its bodies from the wrong words.)
        self.write_params(model);
        Ok(())
    }

    /// Writes the time step `dt` into the params where it changed.
    fn set_timestep(&mut self, model: &Model, dt: f64) {
        let Some(s) = self.state.as_mut() else { return };
        if s.dt == dt {
            return;
        }
        s.dt = dt;
        self.write_params(model);
    }

    /// Writes the params (the step the state holds, the counts) for `model` into the device's.
    fn write_params(&self, model: &Model) {
        let Some(s) = self.state.as_ref() else { return };
        match self.dev.precision {
            Precision::F32 => self.dev.queue.write_buffer(&s.params, 0, bytemuck::bytes_of(&params::<f32>(model, s.dt, s.tol))),
            Precision::F64 => self.dev.queue.write_buffer(&s.params, 0, bytemuck::bytes_of(&params::<f64>(model, s.dt, s.tol))),
        }
    }

    /// Records `n` cycles' kernels and submits them.
    fn dispatch(&self, model: &Model, n: u64) {
        let Some(s) = self.state.as_ref() else { return };
        let (blocks, contacts) = grids(model);
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("d3 cycles") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("d3 cycles"), timestamp_writes: None });
            pass.set_bind_group(0, &s.bind, &[]);
            let kernels = self.scene_kernels();
            for _ in 0..n {
                for (k, grid) in [blocks, blocks, contacts].into_iter().enumerate() {
                    pass.set_pipeline(&kernels.pipelines[k]);
                    pass.dispatch_workgroups(grid.0, grid.1, 1);
                }
            }
        }
        self.dev.queue.submit([enc.finish()]);
    }

    /// Records up to `n` cycles' kernels in a scene with Griffith's cracking candidates, each
    /// cycle's dispatched indirectly from the halting record and ended by `end_cycle`, submits
    /// them and reads the record back: how many cycles ran, and whether a block's screen halted
    /// the batch ("Cracking on the device"). None where the scene has no halting record.
    fn dispatch_halting(&self, model: &Model, n: u64) -> Result<Option<layout::Halt>, GpuError> {
        let Some(s) = self.state.as_ref() else { return Ok(None) };
        let (Some((halt, end_bind)), Some(strain), Some((_, end_cycle))) = (&s.halt, &s.sdef, &self.scene_kernels().end_cycle) else { return Ok(None) };
        let (blocks, contacts) = grids(model);
        let queue = &self.dev.queue;
        queue.write_buffer(halt, 0, bytemuck::bytes_of(&layout::Halt::start(blocks, blocks, contacts)));
        let flag = match self.dev.precision {
            Precision::F32 => layout::screen_flag_offset::<f32>(model.blocks.len()),
            Precision::F64 => layout::screen_flag_offset::<f64>(model.blocks.len()),
        };
        queue.write_buffer(strain, flag, bytemuck::bytes_of(&0u32));
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("d3 cycles") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("d3 cycles"), timestamp_writes: None });
            let kernels = self.scene_kernels();
            for _ in 0..n {
                pass.set_bind_group(0, &s.bind, &[]);
                for (k, pipeline) in kernels.pipelines.iter().enumerate() {
                    pass.set_pipeline(pipeline);
                    pass.dispatch_workgroups_indirect(halt, layout::Halt::grid_offset(k));
                }
                pass.set_pipeline(end_cycle);
                pass.set_bind_group(0, end_bind, &[]);
                pass.dispatch_workgroups(1, 1, 1);
            }
        }
        queue.submit([enc.finish()]);
        Ok(self.dev.read_pod::<layout::Halt>(halt, 1)?.first().copied())
    }

    /// Reads the blocks back into the model (state, sums, vertices placed on the CPU in f64);
    /// returns the index of a block left non-finite, if any, and the largest step's travel of
    /// each.
    fn read_blocks(&self, model: &mut Model) -> Result<(Option<usize>, Vec<f64>), GpuError> {
        match self.dev.precision {
            Precision::F32 => self.read_blocks_as::<f32>(model),
            Precision::F64 => self.read_blocks_as::<f64>(model),
        }
    }

    fn read_blocks_as<R: Real>(&self, model: &mut Model) -> Result<(Option<usize>, Vec<f64>), GpuError> {
        let Some(s) = self.state.as_ref() else { return Ok((None, Vec::new())) };
        let gpu: Vec<layout::Block<R>> = self.dev.read_pod(&s.blocks, model.blocks.len())?;
        let f = |x: R| x.to_f64();
        // The strain state first: the vertices are placed with it.
        if let Some(buffer) = &s.sdef {
            let strains: Vec<layout::SdefBlock<R>> = self.dev.read_pod(buffer, model.blocks.len())?;
            for (b, g) in model.blocks.iter_mut().zip(&strains) {
                if let Some(st) = &mut b.sdef {
                    st.strain = [g.e0, g.e1, g.e2, g.e3, g.e4, g.e5].map(f);
                    st.strain_rate = [g.r0, g.r1, g.r2, g.r3, g.r4, g.r5].map(f);
                    st.stress = [g.s0, g.s1, g.s2, g.s3, g.s4, g.s5].map(f);
                    st.applied = DMat3::from_cols_array(&[g.a0, g.a3, g.a6, g.a1, g.a4, g.a7, g.a2, g.a5, g.a8].map(f));
                }
            }
        }
        // The first block left non-finite; the blocks before it are placed (the vertices from
        // the state), in parallel: at 10⁶ blocks this pass is a batch's whole host time.
        let bad = gpu.iter().position(|g| g.finite == 0);
        let placed = bad.unwrap_or(gpu.len());
        model.blocks.par_iter_mut().zip(&gpu).enumerate().with_min_len(super::grain::BLOCK).for_each(|(k, (b, g))| {
            b.centroid = DVec3::new(f(g.cx) + f(g.cx_lo), f(g.cy) + f(g.cy_lo), f(g.cz) + f(g.cz_lo));
            b.velocity = DVec3::new(f(g.vx), f(g.vy), f(g.vz));
            b.angular_momentum = DVec3::new(f(g.lx), f(g.ly), f(g.lz));
            b.angular_velocity = DVec3::new(f(g.wx), f(g.wy), f(g.wz));
            b.orientation = DQuat::from_xyzw(f(g.qx), f(g.qy), f(g.qz), f(g.qw));
            if b.held {
                // A held block's angular momentum I(t)ω at its turn (`motion::held_motion`): the
                // kernels, which keep only the inverse inertia, leave it.
                b.angular_momentum = b.inertia() * b.angular_velocity;
            }
            b.force = DVec3::new(f(g.fx), f(g.fy), f(g.fz));
            b.moment = DVec3::new(f(g.mx), f(g.my), f(g.mz));
            b.travel = f(g.travel);
            if k < placed {
                b.place_vertices();
            }
        });
        let peaks: Vec<f64> = gpu.iter().map(|g| f(g.peak_travel)).collect();
        // The energy sums in the blocks' order (as the CPU adds them).
        let (mut work, mut damping, mut dashpots) = (0.0, 0.0, 0.0);
        for g in &gpu {
            work += f(g.work);
            damping += f(g.damping_work);
            dashpots += f(g.dashpot_work);
        }
        model.external_work = s.bases.external_work + work;
        model.dissipated.mass_damping = s.bases.mass_damping + damping;
        model.dissipated.contact_damping = s.bases.contact_damping + dashpots;
        Ok((bad, peaks))
    }

    /// Reads the contacts and logical contacts back into the model: normals, points, gaps and
    /// forces; logical contacts of a contact that parted dropped.
    fn read_contacts(&self, model: &mut Model) -> Result<(), GpuError> {
        match self.dev.precision {
            Precision::F32 => self.read_contacts_as::<f32>(model),
            Precision::F64 => self.read_contacts_as::<f64>(model),
        }
    }

    fn read_contacts_as<R: Real>(&self, model: &mut Model) -> Result<(), GpuError> {
        let Some(s) = self.state.as_ref() else { return Ok(()) };
        self.read_contacts_from::<R>(model, (&s.contacts, &s.logicals), &s.keys, s.bases)
    }

    /// Contacts and logical contacts read into the model from `buffers` (the state's, or the
    /// device checkpoint's), uploaded under `keys`, their energy accumulators counting from
    /// `bases`.
    fn read_contacts_from<R: Real>(&self, model: &mut Model, buffers: (&wgpu::Buffer, &wgpu::Buffer), keys: &Keys, bases: Bases) -> Result<(), GpuError> {
        let (contacts, logicals) = self.read_records::<R>((buffers.0, model.contacts.len()), (buffers.1, keys.logical_count()))?;
        // The points' origins: block 1's centroid in f32 (read back with the blocks, before).
        let origins: Vec<DVec3> = model.contacts.iter().map(|c| point_origin::<R>(model, c)).collect();
        model.contacts.par_iter_mut().zip(&contacts).zip(&origins).enumerate().with_min_len(super::grain::CONTACT).for_each(|(k, ((c, g), &origin))| {
            let run = &logicals[g.logical_start as usize..(g.logical_start + g.logical_count) as usize];
            splice::contact_from_pods(c, g, run, keys.run(k), origin);
        });
        // The accumulators in the contacts' order (reruns repeat bit for bit).
        let (mut friction, mut released) = (0.0, 0.0);
        for g in &contacts {
            friction += g.friction_work.to_f64();
            released += g.released_work.to_f64();
        }
        model.dissipated.friction = bases.friction + friction;
        model.dissipated.released = bases.released + released;
        Ok(())
    }

    /// The first `contacts.1` contact records and `logicals.1` logical ones of two buffers, read
    /// back.
    #[allow(clippy::type_complexity)]
    fn read_records<R: Real>(
        &self,
        contacts: (&wgpu::Buffer, usize),
        logicals: (&wgpu::Buffer, usize),
    ) -> Result<(Vec<layout::Contact<R>>, Vec<layout::Logical<R>>), GpuError> {
        self.dev.read_parts(
            &[
                (contacts.0, (contacts.1 * std::mem::size_of::<layout::Contact<R>>()) as u64),
                (logicals.0, (logicals.1 * std::mem::size_of::<layout::Logical<R>>()) as u64),
            ],
            |bytes| (bytemuck::pod_collect_to_vec::<u8, layout::Contact<R>>(bytes[0]), bytemuck::pod_collect_to_vec::<u8, layout::Logical<R>>(bytes[1])),
        )
    }

    /// The energy check's contact sums on the device (`contact_energy`, shaders/d3/contact_energy.wgsl)
    /// for the state the device holds (`model`: its counts): the strain energy of the contacts'
    /// springs, and whether a contact is driven through (by the device's test). A run takes them
    /// at each check; public for the tests that hold them against the CPU's.
    pub fn contact_energy(&mut self, model: &Model) -> Result<(f64, bool), GpuError> {
        match self.dev.precision {
            Precision::F32 => self.contact_energy_as::<f32>(model),
            Precision::F64 => self.contact_energy_as::<f64>(model),
        }
    }

    fn contact_energy_as<R: Real>(&mut self, model: &Model) -> Result<(f64, bool), GpuError> {
        let n = model.contacts.len() as u32;
        if n == 0 || self.state.is_none() {
            return Ok((0.0, false));
        }
        let groups = n.div_ceil(workgroup_size() * layout::ENERGY_ITEMS);
        let bytes = groups as u64 * std::mem::size_of::<layout::ContactEnergy<R>>() as u64;
        records_buffer(&self.dev, &mut self.energy_out, "d3 contact energy", bytes);
        let (Some(s), Some(out)) = (self.state.as_ref(), self.energy_out.as_ref()) else { return Ok((0.0, false)) };
        let entries = [
            wgpu::BindGroupEntry { binding: 0, resource: s.params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: s.blocks.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 5, resource: s.contacts.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 6, resource: s.logicals.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: out.as_entire_binding() },
        ];
        self.dispatch_own("contact_energy", &self.energy_kernel, &entries, groups);
        let sums: Vec<layout::ContactEnergy<R>> = self.dev.read_pod(out, groups as usize)?;
        let strain = sums.iter().map(|e| e.strain.to_f64()).sum();
        Ok((strain, sums.iter().any(|e| e.driven != layout::NONE_DRIVEN)))
    }

    /// The time step from the state on the device (`critical_rows`, shaders/d3/critical_rows.wgsl):
    /// the CPU's rule (`Model::timestep`, held blocks unyielding) on the device's lever arms and
    /// live logical contacts, FRACTION and the simply-deformable blocks' own limit applied on the
    /// CPU; where no row is positive (nothing gives, or no stiffness), the CPU's rule on the model.
    /// Public for the tests that hold it against the CPU's.
    pub fn device_timestep(&mut self, model: &Model) -> Result<f64, GpuError> {
        let lambda = match self.dev.precision {
            Precision::F32 => self.critical_row_as::<f32>(model)?,
            Precision::F64 => self.critical_row_as::<f64>(model)?,
        };
        // (With no stiffness, k_max = 0, every row is 0: the CPU's rule then.)
        Ok(match model.critical_step_of(lambda) {
            Some(critical) => model.timestep_of(Some(critical)),
            None => model.timestep(),
        })
    }

    /// The largest row of the critical step's bound on the device (0 with no state).
    fn critical_row_as<R: Real>(&mut self, model: &Model) -> Result<f64, GpuError> {
        let n = model.blocks.len() as u32;
        if n == 0 || self.state.is_none() {
            return Ok(0.0);
        }
        let groups = n.div_ceil(workgroup_size());
        let bytes = groups as u64 * std::mem::size_of::<R>() as u64;
        records_buffer(&self.dev, &mut self.step_out, "d3 critical rows", bytes);
        let (Some(s), Some(out)) = (self.state.as_ref(), self.step_out.as_ref()) else { return Ok(0.0) };
        let entries = [
            wgpu::BindGroupEntry { binding: 0, resource: s.params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: s.blocks.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 5, resource: s.contacts.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 6, resource: s.logicals.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 7, resource: s.adjacency.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: s.gives.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 10, resource: out.as_entire_binding() },
        ];
        self.dispatch_own("critical_rows", &self.step_kernel, &entries, groups);
        let rows: Vec<R> = self.dev.read_pod(out, groups as usize)?;
        Ok(rows.iter().map(|r| r.to_f64()).fold(0.0, f64::max))
    }

    /// Dispatches `name`, a kernel of its own (`kernel_of_its_own`: its bindings' layout and
    /// pipeline), over `groups` workgroups with the bindings `entries`, and submits it.
    fn dispatch_own(&self, name: &str, kernel: &(wgpu::BindGroupLayout, wgpu::ComputePipeline), entries: &[wgpu::BindGroupEntry], groups: u32) {
        let label = format!("d3 {name}");
        let bind = self.dev.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(&label), layout: &kernel.0, entries });
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(&label) });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&label), timestamp_writes: None });
            pass.set_pipeline(&kernel.1);
            pass.set_bind_group(0, &bind, &[]);
            let (x, y) = dispatch_grid(groups);
            pass.dispatch_workgroups(x, y, 1);
        }
        self.dev.queue.submit([enc.finish()]);
    }

    /// The contacts' part of the last good state kept on the device (`Checkpoint`): the contact
    /// and logical buffers copied, with their keys and bases.
    fn take_checkpoint(&mut self, model: &Model) {
        let Some(s) = self.state.as_ref() else { return };
        let (contact_size, logical_size) = match self.dev.precision {
            Precision::F32 => (std::mem::size_of::<layout::Contact<f32>>(), std::mem::size_of::<layout::Logical<f32>>()),
            Precision::F64 => (std::mem::size_of::<layout::Contact<f64>>(), std::mem::size_of::<layout::Logical<f64>>()),
        };
        let sizes = [(model.contacts.len() * contact_size) as u64, (s.keys.logical_count() * logical_size) as u64];
        let make = |label: &str, size: u64| {
            self.dev.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16).next_multiple_of(16),
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let (contacts, logicals) = match self.checkpoint.take() {
            Some(cp) if cp.contacts.size() >= sizes[0] && cp.logicals.size() >= sizes[1] => (cp.contacts, cp.logicals),
            // Half again as large as now, so that a run whose contacts grow does not make new
            // ones at every check.
            _ => (make("d3 checkpoint contacts", sizes[0] + sizes[0] / 2), make("d3 checkpoint logicals", sizes[1] + sizes[1] / 2)),
        };
        let mut enc = self.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("d3 checkpoint") });
        if sizes[0] > 0 {
            enc.copy_buffer_to_buffer(&s.contacts, 0, &contacts, 0, sizes[0]);
        }
        if sizes[1] > 0 {
            enc.copy_buffer_to_buffer(&s.logicals, 0, &logicals, 0, sizes[1]);
        }
        self.dev.queue.submit([enc.finish()]);
        self.checkpoint = Some(Checkpoint { contacts, logicals, keys: Rc::clone(&s.keys), contact_count: model.contacts.len(), bases: s.bases, valid: true });
    }

    /// The whole state read back into the model.
    fn read_all(&self, model: &mut Model) -> Result<Option<usize>, GpuError> {
        let (bad, _) = self.read_blocks(model)?;
        self.read_contacts(model)?;
        Ok(bad)
    }

    /// A detection between cycles: stage 7 (neighbour lists) and the CPU's stage 4 with Δt = 0
    /// (the logical contacts afresh), for every block where the lists are stale or detections are
    /// whole, else for the blocks that moved ("Partial detections"). A whole detection reads every
    /// contact back and uploads them all; a partial one the moved blocks' contacts, spliced into
    /// the device's buffers (`splice`), or every contact where uploads are whole.
    fn detect(&mut self, model: &mut Model, report: &mut CycleReport) -> Result<(), CycleError> {
        let whole = model.neighbours_stale || self.whole_detections;
        if !whole && !self.whole_uploads {
            return match self.dev.precision {
                Precision::F32 => self.detect_spliced::<f32>(model, report),
                Precision::F64 => self.detect_spliced::<f64>(model, report),
            };
        }
        self.read_contacts(model).map_err(device_error)?;
        self.host.detection_bytes += self.contact_bytes(model);
        if whole {
            self.kept_grid = None;
            let (created, dropped) = topology::update_neighbours(model);
            report.contacts_created += created;
            report.contacts_dropped += dropped;
            cpu::contact_stage_with(model, 0.0, Appearing::Carried);
            self.host.refreshed += model.contacts.len() as u64;
        } else {
            // Partial: the blocks that have used REFRESH_SHARE of their travel, their pairs
            // searched and their contacts' logical contacts found afresh; the rest as tracked.
            let tol = model.contact_tolerance();
            let (moved, limit) = moved_blocks(model, tol);
            let touched = topology::contacts_touching(model, |k| moved[k]);
            let renewal = topology::update_neighbours_kept(model, &moved, &touched, &mut self.kept_grid, (tol, limit));
            report.contacts_created += renewal.created;
            report.contacts_dropped += renewal.dropped;
            // Where the list kept its keys the contacts found before the renewal are the moved
            // blocks' still (the spliced path's rule); else their indices moved with the merge.
            let selected = if renewal.in_place() { touched } else { topology::contacts_touching(model, |k| moved[k]) };
            cpu::contact_stage_of(model, tol, 0.0, Appearing::Carried, &selected);
            self.host.refreshed += selected.len() as u64;
        }
        self.host.listed += model.contacts.len() as u64;
        report.topology_updates += 1;
        cpu::overlap_check(model)?;
        self.reupload(model).map_err(device_error)
    }

    /// The bytes of the contact and logical records the device holds for `model`'s contacts.
    fn contact_bytes(&self, model: &Model) -> u64 {
        let Some(s) = self.state.as_ref() else { return 0 };
        let (contact, logical) = match self.dev.precision {
            Precision::F32 => (std::mem::size_of::<layout::Contact<f32>>(), std::mem::size_of::<layout::Logical<f32>>()),
            Precision::F64 => (std::mem::size_of::<layout::Contact<f64>>(), std::mem::size_of::<layout::Logical<f64>>()),
        };
        (model.contacts.len() * contact + s.keys.logical_count() * logical) as u64
    }
}

/// `renew_blocks`' pipeline and its bindings' layout (the params, the blocks, its renewals at
/// binding 9), in the device's precision.
fn renew_kernel(dev: &GpuDevice) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), GpuError> {
    let scopes = dev.creation_scopes();
    let entries = [uniform(0), storage(1, false), storage(9, true)];
    let kernel = kernel_of_its_own(dev, "renew_blocks", shaders::renew_blocks_source(dev.precision), &entries)?;
    scopes.check(dev)?;
    Ok(kernel)
}

/// `splice_contacts`' pipeline and its bindings' layout (its output, the contacts and logical
/// contacts at bindings 5 and 6; its uniform at 9; the kept and fresh records, read, at 10 to
/// 13; the sources at 14 and the banks at 15), in the device's precision.
fn splice_kernel(dev: &GpuDevice) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), GpuError> {
    let scopes = dev.creation_scopes();
    let entries = [
        storage(5, false),
        storage(6, false),
        uniform(9),
        storage(10, true),
        storage(11, true),
        storage(12, true),
        storage(13, true),
        storage(14, true),
        storage(15, false),
    ];
    let kernel = kernel_of_its_own(dev, "splice_contacts", shaders::splice_contacts_source(dev.precision), &entries)?;
    scopes.check(dev)?;
    Ok(kernel)
}

/// `contact_energy`'s pipeline and its bindings' layout (the params, blocks, contacts, logical
/// contacts and its records at binding 9), in the device's precision.
fn energy_kernel(dev: &GpuDevice) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), GpuError> {
    let scopes = dev.creation_scopes();
    let entries = [uniform(0), storage(1, false), storage(5, false), storage(6, false), storage(9, false)];
    let kernel = kernel_of_its_own(dev, "contact_energy", shaders::contact_energy_source(dev.precision), &entries)?;
    scopes.check(dev)?;
    Ok(kernel)
}

/// A kernel's records buffer of at least `bytes` (storage, read back), kept in `slot` from call
/// to call and made anew where it is too small.
fn records_buffer(dev: &GpuDevice, slot: &mut Option<wgpu::Buffer>, label: &str, bytes: u64) {
    if slot.as_ref().is_none_or(|b| b.size() < bytes) {
        *slot = Some(dev.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.next_multiple_of(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        }));
    }
}

/// `critical_rows`' pipeline and its bindings' layout (the params, blocks, contacts, logical
/// contacts, adjacency, the blocks' gives at binding 9 and its records at binding 10).
fn step_kernel(dev: &GpuDevice) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), GpuError> {
    let scopes = dev.creation_scopes();
    let entries = [uniform(0), storage(1, false), storage(5, false), storage(6, false), storage(7, false), storage(9, false), storage(10, false)];
    let kernel = kernel_of_its_own(dev, "critical_rows", shaders::critical_rows_source(dev.precision), &entries)?;
    scopes.check(dev)?;
    Ok(kernel)
}

/// What the critical step reads of each block, as `critical_rows` takes it (`layout::StepGive`,
/// from `Model::step_gives` with held blocks unyielding, the CPU's first try): `row0` is k_max
/// times the block's compliance at its radius.
fn step_gives<R: Real>(model: &Model) -> Vec<layout::StepGive<R>> {
    let k_max = model.stiffest_contact();
    let r = |x: f64| R::from_f64(x);
    model
        .step_gives(true)
        .iter()
        .zip(&model.blocks)
        .map(|(g, b)| layout::StepGive::<R> {
            inverse_mass: r(g.inverse_mass),
            least: r(g.least),
            least_second: r(g.least_second),
            row0: r(k_max * g.compliance(b.shape.radius.powi(2))),
            unyielding: g.unyielding as u32,
            ..Default::default()
        })
        .collect()
}

/// A kernel outside the cycle's bind group (`end_cycle`, `contact_energy`, `critical_rows`): its source `src`
/// (shaders/d3/`name`.wgsl with the prelude) validated, its bindings' layout from `entries`, its
/// pipeline with the entry point `name`.
fn kernel_of_its_own(
    dev: &GpuDevice,
    name: &str,
    src: String,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), GpuError> {
    validate(&src, dev.precision).map_err(|e| GpuError::Shader(format!("d3/{name}.wgsl: {e}")))?;
    let (group, layout) = layouts(&dev.device, &format!("d3 {name}"), entries);
    let module = dev.device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(src.into()) });
    let pipeline = dev.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(name),
        layout: Some(&layout),
        module: &module,
        entry_point: Some(name),
        compilation_options: Default::default(),
        cache: None,
    });
    Ok((group, pipeline))
}

/// The items of each buffer a D3 scene's kernels bind (`State`), as the upload makes them from
/// `model`: (what it holds, bytes an item, items).
pub fn buffer_items<R: Real>(model: &Model) -> Vec<(&'static str, usize, usize)> {
    let shapes = || model.blocks.iter().flat_map(|b| std::iter::once(&b.shape).chain(b.parts.iter().map(|p| &p.shape)));
    let planes = shapes().map(|s| s.planes.len()).sum::<usize>() + 2 * model.blocks.iter().map(|b| b.boundary_stress.len()).sum::<usize>();
    let edge_words = shapes().map(|s| 2 * (s.edge_directions.len() + features_of(s) as usize)).sum();
    let mut items = vec![
        ("blocks", std::mem::size_of::<layout::Block<R>>(), record_count(model)),
        ("vertices", std::mem::size_of::<layout::Vertex<R>>(), vertex_count(model)),
        ("face planes", std::mem::size_of::<layout::Plane<R>>(), planes),
        ("edges", 4, edge_words),
        ("contacts", std::mem::size_of::<layout::Contact<R>>(), model.contacts.len()),
        ("logical contacts", std::mem::size_of::<layout::Logical<R>>(), model.contacts.iter().map(|c| c.logical.len()).sum()),
        // The blocks' adjacency lists (two entries a contact), then each contact's two bodies.
        ("adjacency", 4, 4 * model.contacts.len()),
    ];
    if model.blocks.iter().any(|b| b.is_sdef()) {
        items.push(("simply-deformable blocks", std::mem::size_of::<layout::SdefBlock<R>>(), model.blocks.len() + 1));
    }
    items
}

/// Whether every buffer of `model`'s scene fits one binding of `cap` bytes (the adapter's,
/// `gpu::device::binding_cap`): a model past it is refused before any buffer is made
/// (`CycleError::DoesNotFit`, naming the buffer), not left to the device's validation.
fn fits<R: Real>(model: &Model, cap: u64) -> Result<(), GpuError> {
    for (label, item, count) in buffer_items::<R>(model) {
        crate::gpu::device::check_fits(label, item, count, cap, R::PRECISION)?;
    }
    Ok(())
}

/// The dispatch grids of the cycle's kernels: over the blocks (gather, law_of_motion) and over
/// the contacts (track_contact).
fn grids(model: &Model) -> ((u32, u32), (u32, u32)) {
    let wg = workgroup_size();
    (dispatch_grid((model.blocks.len() as u32).div_ceil(wg).max(1)), dispatch_grid((model.contacts.len() as u32).div_ceil(wg).max(1)))
}

/// `end_cycle`'s Rust twin (shaders/d3/end_cycle.wgsl): at a cycle's end, unless the batch
/// halted already, the cycle is counted, and where a block's Griffith screen fired in it (`flag`,
/// the strain buffer's word that sdef.wgsl's `crack_screen` raises) the batch halts: every grid
/// zeroed, so that its later cycles launch nothing.
pub fn end_cycle(halt: &mut layout::Halt, flag: u32) {
    if halt.halted != 0 {
        return;
    }
    halt.cycles_done += 1;
    if flag != 0 {
        *halt = layout::Halt { cycles_done: halt.cycles_done, halted: 1, spare: halt.spare, ..Default::default() };
    }
}

/// Whether kernels of precision `R` work each contact in a frame at its block 1's centroid (the
/// prelude's RELATIVE, f32): their vertices are offsets from the centroid and their logical
/// contacts' points are from block 1's centroid (`point_origin`). The f64 kernels work in global
/// axes, as the CPU does.
fn relative<R: Real>() -> bool {
    R::PRECISION == Precision::F32
}

/// Where the kernels of precision `R` measure contact `c`'s logical contacts' points from: its
/// block 1's centroid in f32 (`relative`), the origin in f64.
fn point_origin<R: Real>(model: &Model, c: &super::model::Contact) -> DVec3 {
    if relative::<R>() {
        model.blocks[c.blocks[0] as usize].centroid
    } else {
        DVec3::ZERO
    }
}

/// The shapes as the kernels take them: each block's vertices (reference frame and placed: in
/// f32 as offsets from the centroid, `relative`), its face planes and its edges (the
/// directions', then the feature edges); a concave block's convex parts' after its own, each
/// part's vertices in the block's reference frame about its centroid (the part's offset added),
/// so that stage 2 places them as the block's own (`Block::place_vertices`), and its planes and
/// edges numbered in the part's own vertices, as the logical contacts' keys are.
fn shape_pods<R: Real>(model: &Model) -> (Vec<layout::Vertex<R>>, Vec<layout::Plane<R>>, Vec<u32>) {
    let mut vertices = Vec::new();
    let mut planes = Vec::new();
    let mut edges = Vec::new();
    for b in &model.blocks {
        let vertex_base = vertices.len() as u32;
        let r = |x: f64| R::from_f64(x);
        let offset_from = |g: DVec3| if relative::<R>() { g - b.centroid } else { g };
        for (l, g) in b.shape.vertices.iter().zip(&b.vertices) {
            let g = offset_from(*g);
            vertices.push(layout::Vertex::<R> { lx: r(l.x), ly: r(l.y), lz: r(l.z), x: r(g.x), y: r(g.y), z: r(g.z) });
        }
        for p in &b.parts {
            for (l, g) in p.shape.vertices.iter().zip(&p.vertices) {
                let (l, g) = (p.offset + *l, offset_from(*g));
                vertices.push(layout::Vertex::<R> { lx: r(l.x), ly: r(l.y), lz: r(l.z), x: r(g.x), y: r(g.y), z: r(g.z) });
            }
        }
        face_planes(&b.shape, &mut planes);
        // Its faces loaded by BOUNDARY STRESS, two records each (`layout::Plane`), their
        // vertices numbered in the vertex buffer.
        for l in &b.boundary_stress {
            let [v0, v1, v2] = b.shape.faces[l.face as usize].map(|v| vertex_base + v);
            let s = l.stress.map(R::from_f64);
            planes.push(layout::Plane::<R> { nx: s[0], ny: s[1], nz: s[2], vertex: v0, spare: v1 });
            planes.push(layout::Plane::<R> { nx: s[3], ny: s[4], nz: s[5], vertex: v2, spare: 0 });
        }
        for p in &b.parts {
            face_planes(&p.shape, &mut planes);
        }
        for shape in std::iter::once(&b.shape).chain(b.parts.iter().map(|p| &p.shape)) {
            for &e in &shape.edge_directions {
                let e = shape.edges[e as usize];
                edges.extend([e.a, e.b]);
            }
            for e in shape.edges.iter().filter(|e| e.feature) {
                edges.extend([e.a, e.b]);
            }
        }
    }
    (vertices, planes, edges)
}

/// A convex shape's face planes (one per distinct normal, `Shape::planes`), each with one of its
/// vertices in the shape's own numbering.
fn face_planes<R: Real>(shape: &Shape, planes: &mut Vec<layout::Plane<R>>) {
    for &f in &shape.planes {
        let n = shape.normals[f as usize];
        planes.push(layout::Plane::<R> { nx: R::from_f64(n.x), ny: R::from_f64(n.y), nz: R::from_f64(n.z), vertex: shape.faces[f as usize][0], spare: 0 });
    }
}

/// How many feature edges a shape has (after its edge directions in the edge buffer).
fn features_of(shape: &Shape) -> u32 {
    shape.edges.iter().filter(|e| e.feature).count() as u32
}

/// How many records the block buffer holds: the blocks, then a record for each convex part of
/// a concave block (`layout.wgsl`'s `contact_bodies`).
fn record_count(model: &Model) -> usize {
    model.blocks.len() + model.blocks.iter().map(|b| b.parts.len()).sum::<usize>()
}

/// How many vertices the vertex buffer holds: each block's, then its parts'.
fn vertex_count(model: &Model) -> usize {
    model.blocks.iter().map(|b| b.shape.vertices.len() + b.parts.iter().map(|p| p.shape.vertices.len()).sum::<usize>()).sum()
}

/// What a detection changes, as the kernels take it: the blocks (their travel and adjacency
/// lists) and the parts' records after them, the contacts, their logical contacts, the adjacency
/// (the blocks' lists, then the contacts' bodies), and each contact's keys.
#[allow(clippy::type_complexity)]
fn topology_pods<R: Real>(model: &Model) -> (Vec<layout::Block<R>>, Vec<layout::Contact<R>>, Vec<layout::Logical<R>>, Adjacency, Keys) {
    let (blocks, adjacency) = block_pods::<R>(model);
    let (contacts, logicals, keys) = contact_pods::<R>(model, model.contacts.iter());
    (blocks, contacts, logicals, adjacency, keys)
}

/// The blocks (their travel and adjacency lists) and the parts' records after them, and the
/// adjacency (the blocks' lists, then the contacts' bodies), as the kernels take them.
fn block_pods<R: Real>(model: &Model) -> (Vec<layout::Block<R>>, Adjacency) {
    let n = model.blocks.len();
    let adjacency = adjacency_pods(model);
    let adjacency_start = &adjacency.starts;
    // Where each block's vertices, planes and edges start (a pass of sums), and the parts'
    // records, after the blocks'.
    #[derive(Clone, Copy)]
    struct Starts {
        vertex: u32,
        plane: u32,
        edge: u32,
    }
    let mut starts = Vec::with_capacity(n);
    let mut part_records = Vec::new();
    let (mut vertex_start, mut plane_start, mut edge_start) = (0u32, 0u32, 0u32);
    // Each block's own: its vertices, planes (then two records for each loaded face) and edges
    // (counted in parallel), then its parts' (`shape_pods`), each part a record of its ranges
    // and its radius.
    let own: Vec<[u32; 4]> = model
        .blocks
        .par_iter()
        .with_min_len(super::grain::BLOCK)
        .map(|b| {
            let feature_count = features_of(&b.shape);
            [
                b.shape.vertices.len() as u32,
                (b.shape.planes.len() + 2 * b.boundary_stress.len()) as u32,
                b.shape.edge_directions.len() as u32 + feature_count,
                feature_count,
            ]
        })
        .collect();
    for (b, [vertices, planes, edges, _]) in model.blocks.iter().zip(&own) {
        starts.push(Starts { vertex: vertex_start, plane: plane_start, edge: edge_start });
        vertex_start += vertices;
        plane_start += planes;
        edge_start += edges;
        for p in &b.parts {
            let feature_count = features_of(&p.shape);
            part_records.push(layout::Block::<R> {
                radius: R::from_f64(p.shape.radius),
                vertex_start,
                vertex_count: p.shape.vertices.len() as u32,
                plane_start,
                plane_count: p.shape.planes.len() as u32,
                edge_start,
                edge_dir_count: p.shape.edge_directions.len() as u32,
                feature_count,
                finite: 1,
                ..Default::default()
            });
            vertex_start += p.shape.vertices.len() as u32;
            plane_start += p.shape.planes.len() as u32;
            edge_start += p.shape.edge_directions.len() as u32 + feature_count;
        }
    }
    // The blocks' records, in parallel (at 10⁶ blocks a serial pass was most of a partial
    // detection's host time).
    let mut blocks: Vec<layout::Block<R>> = Vec::with_capacity(n + part_records.len());
    model
        .blocks
        .par_iter()
        .zip(&starts)
        .zip(&own)
        .enumerate()
        .with_min_len(super::grain::BLOCK)
        .map(|(k, ((b, at), &[.., feature_count]))| {
            let inv = crate::d3::geometry::inertia_inverse(b.inertia_ref).unwrap_or(DMat3::ZERO);
            let r = |x: f64| R::from_f64(x);
            let cols = inv.to_cols_array();
            let part_vertices: usize = b.parts.iter().map(|p| p.shape.vertices.len()).sum();
            // The centroid in the kernel precision and what that leaves (the compensated pair).
            let hi = [r(b.centroid.x), r(b.centroid.y), r(b.centroid.z)];
            layout::Block::<R> {
                cx: hi[0],
                cy: hi[1],
                cz: hi[2],
                cx_lo: r(b.centroid.x - hi[0].to_f64()),
                cy_lo: r(b.centroid.y - hi[1].to_f64()),
                cz_lo: r(b.centroid.z - hi[2].to_f64()),
                vx: r(b.velocity.x),
                vy: r(b.velocity.y),
                vz: r(b.velocity.z),
                lx: r(b.angular_momentum.x),
                ly: r(b.angular_momentum.y),
                lz: r(b.angular_momentum.z),
                wx: r(b.angular_velocity.x),
                wy: r(b.angular_velocity.y),
                wz: r(b.angular_velocity.z),
                qx: r(b.orientation.x),
                qy: r(b.orientation.y),
                qz: r(b.orientation.z),
                qw: r(b.orientation.w),
                mass: r(b.mass),
                inv0: r(cols[0]),
                inv1: r(cols[1]),
                inv2: r(cols[2]),
                inv3: r(cols[3]),
                inv4: r(cols[4]),
                inv5: r(cols[5]),
                inv6: r(cols[6]),
                inv7: r(cols[7]),
                inv8: r(cols[8]),
                load_x: r(b.load.x),
                load_y: r(b.load.y),
                load_z: r(b.load.z),
                radius: r(b.shape.radius),
                fx: r(b.force.x),
                fy: r(b.force.y),
                fz: r(b.force.z),
                mx: r(b.moment.x),
                my: r(b.moment.y),
                mz: r(b.moment.z),
                travel: r(b.travel),
                fixed: if b.fixed {
                    layout::BLOCK_FIXED
                } else if b.held {
                    layout::BLOCK_HELD
                } else {
                    layout::BLOCK_FREE
                },
                vertex_start: at.vertex,
                // A concave block's parts' vertices too: stage 2 places them with its own.
                vertex_count: (b.shape.vertices.len() + part_vertices) as u32,
                plane_start: at.plane,
                plane_count: b.shape.planes.len() as u32,
                edge_start: at.edge,
                edge_dir_count: b.shape.edge_directions.len() as u32,
                feature_count,
                adjacency_start: adjacency_start[k],
                adjacency_count: adjacency_start[k + 1] - adjacency_start[k],
                finite: 1,
                stress_faces: b.boundary_stress.len() as u32,
                ..Default::default()
            }
        })
        .collect_into_vec(&mut blocks);
    blocks.extend(part_records);
    (blocks, adjacency)
}

/// The adjacency as the kernels take it ([`Adjacency`]).
fn adjacency_pods(model: &Model) -> Adjacency {
    let n = model.blocks.len();
    let mut starts = vec![0u32; n + 1];
    for c in &model.contacts {
        starts[c.blocks[0] as usize + 1] += 1;
        starts[c.blocks[1] as usize + 1] += 1;
    }
    for k in 0..n {
        starts[k + 1] += starts[k];
    }
    let mut adjacency = vec![0u32; starts[n] as usize + 2 * model.contacts.len()];
    let mut next = starts.clone();
    for (k, c) in model.contacts.iter().enumerate() {
        for (side, b) in c.blocks.into_iter().enumerate() {
            adjacency[next[b as usize] as usize] = 2 * k as u32 + side as u32;
            next[b as usize] += 1;
        }
    }
    let mut first_part = Vec::with_capacity(n);
    let mut parts = n as u32;
    for b in &model.blocks {
        first_part.push(parts);
        parts += b.parts.len() as u32;
    }
    let bodies = &mut adjacency[starts[n] as usize..];
    for (c, pair) in model.contacts.iter().zip(bodies.chunks_exact_mut(2)) {
        for ((i, part), body) in c.blocks.into_iter().zip(c.parts).zip(pair) {
            *body = if model.blocks[i as usize].parts.is_empty() { i } else { first_part[i as usize] + part };
        }
    }
    Adjacency { words: adjacency, starts }
}

/// The adjacency as the kernels take it: `words`, each block's contacts in the contacts' order
/// (`2k + side`), block after block (counted, then placed), then each contact's two bodies'
/// records (`layout.wgsl`'s `contact_bodies`: a convex block's own, or the record of the part
/// of a concave one it is between, the parts' records after the blocks'); and where each
/// block's list starts (one more entry: the lists' end).
#[derive(Debug)]
pub(crate) struct Adjacency {
    words: Vec<u32>,
    starts: Vec<u32>,
}

impl Adjacency {
    /// The contacts (indices, ascending) with a block among the `moved` (a flag per block):
    /// their lists, no pass over the contacts.
    fn contacts_of(&self, moved: &[bool]) -> Vec<usize> {
        let mut at: Vec<usize> = moved
            .iter()
            .enumerate()
            .filter(|(_, &m)| m)
            .flat_map(|(b, _)| self.words[self.starts[b] as usize..self.starts[b + 1] as usize].iter().map(|&w| (w / 2) as usize))
            .collect();
        at.sort_unstable();
        at.dedup();
        at
    }
}

/// The contacts `which` (of the model's) as the kernels take them: their records, each with the
/// run of its logical contacts in the second list, and their keys.
fn contact_pods<'m, R: Real>(
    model: &'m Model,
    which: impl ExactSizeIterator<Item = &'m super::model::Contact>,
) -> (Vec<layout::Contact<R>>, Vec<layout::Logical<R>>, Keys) {
    let mut contacts = Vec::with_capacity(which.len());
    let mut logicals = Vec::new();
    let mut keys = Keys::with_capacity(which.len(), 0);
    for c in which {
        let mat = model.contact_material(c);
        let r = |x: f64| R::from_f64(x);
        contacts.push(layout::Contact::<R> {
            nx: r(c.normal.x),
            ny: r(c.normal.y),
            nz: r(c.normal.z),
            kn: r(mat.kn),
            ks: r(mat.ks),
            cohesion: r(mat.cohesion),
            friction: r(mat.friction),
            block1: c.blocks[0],
            block2: c.blocks[1],
            logical_start: logicals.len() as u32,
            logical_count: c.logical.len() as u32,
            ..Default::default()
        });
        keys.push(c.logical.iter().map(|l| l.kind));
        let origin = point_origin::<R>(model, c);
        for l in &c.logical {
            let [kind, v1, v2, v3, v4] = logical_words(l.kind);
            let point = if relative::<R>() { l.point - origin } else { l.point };
            logicals.push(layout::Logical::<R> {
                px: r(point.x),
                py: r(point.y),
                pz: r(point.z),
                gap: r(l.gap),
                normal_force: r(l.normal_force),
                offset: r(l.offset),
                sx: r(l.shear_force.x),
                sy: r(l.shear_force.y),
                sz: r(l.shear_force.z),
                kind,
                v1,
                v2,
                v3,
                v4,
                live: 1,
            });
        }
    }
    (contacts, logicals, keys)
}

/// The strain state as the kernels take it (`layout::SdefBlock`, one per block, `live` 0 for a
/// rigid block, then the screen's record), where the model has simply-deformable blocks; None
/// where it has none (nothing of the strain is bound then).
fn sdef_pods<R: Real>(model: &Model) -> Option<Vec<layout::SdefBlock<R>>> {
    if !model.blocks.iter().any(|b| b.is_sdef()) {
        return None;
    }
    let r = |x: f64| R::from_f64(x);
    let mut pods: Vec<layout::SdefBlock<R>> = model
        .blocks
        .iter()
        .map(|b| {
            let Some(s) = &b.sdef else { return layout::SdefBlock::<R>::default() };
            let mat = model.material(b.material);
            let [e0, e1, e2, e3, e4, e5] = s.strain.map(r);
            let [r0, r1, r2, r3, r4, r5] = s.strain_rate.map(r);
            let [s0, s1, s2, s3, s4, s5] = s.stress.map(r);
            // A_ij row by row.
            let a = s.applied.transpose().to_cols_array().map(r);
            let [m0, m1, m2, m3, m4, m5] = super::sdef::voigt(super::sdef::second_moments(b.inertia_ref)).map(r);
            layout::SdefBlock::<R> {
                e0,
                e1,
                e2,
                e3,
                e4,
                e5,
                r0,
                r1,
                r2,
                r3,
                r4,
                r5,
                s0,
                s1,
                s2,
                s3,
                s4,
                s5,
                a0: a[0],
                a1: a[1],
                a2: a[2],
                a3: a[3],
                a4: a[4],
                a5: a[5],
                a6: a[6],
                a7: a[7],
                a8: a[8],
                m0,
                m1,
                m2,
                m3,
                m4,
                m5,
                volume: r(b.volume),
                lambda: r(super::sdef::lame_lambda(mat.bulk, mat.shear)),
                shear: r(mat.shear),
                alpha: r(model.damping.alpha_internal),
                // Screened on the device where Griffith's law may crack it (`crack_screen`):
                // not a fragment at the floor (`cracking::above_floor`).
                tf: r(if super::sdef::griffith_applies(b.constitutive, mat.tf) && super::cracking::above_floor(b) { mat.tf } else { 0.0 }),
                live: 1,
                spare: 0,
            }
        })
        .collect();
    // The screen's record: its flag (`spare`) cleared at each batch's start.
    pods.push(layout::SdefBlock::<R>::default());
    Some(pods)
}

/// A logical contact's kind and vertices as `layout::Logical` holds them.
fn logical_words(kind: LogicalKind) -> [u32; 5] {
    match kind {
        LogicalKind::VertexFace { on_first: true, vertex } => [layout::LOGICAL_VERTEX_FIRST, vertex, 0, 0, 0],
        LogicalKind::VertexFace { on_first: false, vertex } => [layout::LOGICAL_VERTEX_SECOND, vertex, 0, 0, 0],
        LogicalKind::EdgeEdge { first, second } => [layout::LOGICAL_EDGE_EDGE, first.0, first.1, second.0, second.1],
    }
}

/// `n` structs `T` from a saved buffer's bytes; Err names the buffer whose length is not theirs.
fn pods<T: bytemuck::Pod>(bytes: &[u8], n: usize, what: &str) -> Result<Vec<T>, String> {
    if bytes.len() != n * std::mem::size_of::<T>() {
        return Err(format!("the saved {what} are {} bytes, not {n} of {}", bytes.len(), std::mem::size_of::<T>()));
    }
    Ok(bytemuck::pod_collect_to_vec(bytes))
}

/// The run's constants as the kernels take them, with the time step `dt`.
fn params<R: Real>(model: &Model, dt: f64, tol: f64) -> layout::Params<R> {
    let r = |x: f64| R::from_f64(x);
    layout::Params::<R> {
        gx: r(model.gravity.x),
        gy: r(model.gravity.y),
        gz: r(model.gravity.z),
        alpha: r(model.damping.alpha),
        beta: r(model.damping.beta),
        dt: r(dt),
        tol: r(tol),
        one: r(1.0),
        blocks: model.blocks.len() as u32,
        contacts: model.contacts.len() as u32,
        ..Default::default()
    }
}

fn bases(model: &Model) -> Bases {
    Bases {
        external_work: model.external_work,
        mass_damping: model.dissipated.mass_damping,
        contact_damping: model.dissipated.contact_damping,
        friction: model.dissipated.friction,
        released: model.dissipated.released,
    }
}

/// The blocks a partial detection refreshes (those whose travel since their last refresh has
/// reached `REFRESH_SHARE` of the allowance, a flag each), and that limit: the most a block not
/// refreshed may have travelled (the kept grid's slack).
fn moved_blocks(model: &Model, tol: f64) -> (Vec<bool>, f64) {
    let limit = REFRESH_SHARE * DETECTION_SHARE * tol;
    (model.blocks.iter().map(|b| b.travel >= limit).collect(), limit)
}

/// How many cycles of step `dt`, at the velocities now, until the first free block has
/// travelled `DETECTION_SHARE` of the contact-forming distance since the last detection (at
/// least 1); None when nothing moves.
pub fn cycles_to_detection(model: &Model, dt: f64) -> Option<u64> {
    let limit = DETECTION_SHARE * model.contact_tolerance();
    model
        .blocks
        .iter()
        .filter(|b| !b.fixed)
        .filter_map(|b| {
            // A simply-deformable block's vertices move by its strain rate too.
            let strain = b.sdef.map_or(0.0, |s| super::sdef::strain_travel(s.strain_rate.map(|r| r * dt), b.shape.radius));
            let s = b.velocity.length() * dt + b.angular_velocity.length() * dt * b.shape.radius + strain;
            (s > 0.0 && s.is_finite()).then(|| ((limit - b.travel).max(0.0) / s).floor().min(1e9) as u64 + 1)
        })
        .min()
}

impl driver::Start<Model> for GpuBackend {
    fn take_resumable(&mut self) -> Option<&Model> {
        std::mem::take(&mut self.resumable).then_some(&self.last_good)
    }

    fn preflight(&mut self, model: &Model) -> Result<(), CycleError> {
        // A concave block runs as its convex parts, each a body of the contact stage (`layout.wgsl`'s
        // `contact_bodies`), as on the CPU.
        cpu::preflight(model)
    }

    fn start(&mut self, model: &mut Model, resume: bool, report: &mut CycleReport) -> Result<(), CycleError> {
        // Each run starts with batches as long as its detections and energy checks allow, and
        // from a last good state that is the model it starts from, whole (no checkpoint yet).
        self.screened_cap = driver::CHECK_INTERVAL;
        self.next_timestep = None;
        self.kept_grid = None;
        if let Some(cp) = self.checkpoint.as_mut() {
            cp.valid = false;
        }
        let pending = self.pending.take();
        if resume && self.state.is_some() {
            if let Some(s) = self.state.as_mut() {
                s.tol = model.contact_tolerance();
            }
            return Ok(());
        }
        if let Some(device) = pending.filter(|_| resume) {
            // RESTART of a GPU run: its device state as it was (not a detection, which would
            // find the logical contacts afresh and restart the energy sums).
            let restored = match self.dev.precision {
                Precision::F32 if !device.f64_kernels => self.restore_as::<f32>(model, &device),
                Precision::F64 if device.f64_kernels => self.restore_as::<f64>(model, &device),
                _ => Err("it was saved from kernels of the other precision".into()),
            };
            match restored {
                Ok(()) => return Ok(()),
                Err(why) => {
                    use std::io::Write as _;
                    let _ = writeln!(std::io::stderr(), "blockdem: the saved GPU state is not taken ({why}); the run starts with a contact detection");
                }
            }
        }
        let (created, dropped) = topology::update_neighbours(model);
        report.topology_updates += 1;
        report.contacts_created += created;
        report.contacts_dropped += dropped;
        contact_stage(model, 0.0);
        self.upload(model).map_err(device_error)
    }
}

impl driver::Stages<Model> for GpuBackend {
    fn advance(&mut self, model: &mut Model, max: u64, cracking: bool, report: &mut CycleReport) -> Result<u64, CycleError> {
        // Where a block may crack, the criteria are checked on the state of the cycle the CPU
        // checks them at (`cpu::cracks`). Griffith's law reads a block's own stress, which the
        // strain stage screens on the device ("Cracking on the device"): a batch runs as any
        // other and halts at the end of a cycle whose screen fired. The point-load law reads the
        // pairs of contact forces on a block, gathered over its contacts with their points and
        // the block's corners (`cracking::point_load_crack`): no kernel holds a block's contact
        // forces together, so such a scene runs cycle by cycle, its contacts read back after each.
        let point_load = cracking && super::cracking::has_point_load_candidates(model);
        let screened = cracking && !point_load && self.state.as_ref().is_some_and(|s| s.halt.is_some());
        // The time step as the CPU takes it (`Model::timestep`, from the contacts there are and
        // their lever arms), worked out on the device from its state at the batch's start (or
        // by the energy check just before): the kernels hold it over the batch (the CPU renews
        // it each cycle, as the logical contacts' lever arms move). The batch runs at it to the
        // next detection (the model's contacts are the device's only as last read back).
        let dt = match self.next_timestep.take() {
            Some(dt) => dt,
            None => self.device_timestep(model).map_err(device_error)?,
        };
        self.set_timestep(model, dt);
        let mut n = if cracking && !screened { 1 } else { cycles_to_detection(model, dt).unwrap_or(max).clamp(1, max.max(1)) };
        if screened {
            n = n.min(self.screened_cap);
        }
        let (ran, halted) = if screened {
            let (ran, halted) = match self.dispatch_halting(model, n).map_err(device_error)? {
                Some(h) => (h.cycles_done as u64, h.halted != 0),
                None => return Err(CycleError::Setup("GPU: the scene's halting record is missing".into())),
            };
            self.screened_cap = if halted { (2 * ran).max(1) } else { (2 * self.screened_cap).min(driver::CHECK_INTERVAL) };
            (ran, halted)
        } else {
            self.dispatch(model, n);
            (n, false)
        };
        self.batches += 1;
        if ran == 0 || ran > n {
            return Err(CycleError::Setup(format!("GPU: a batch of {n} cycles ran {ran}")));
        }
        // (The batch's kernels finished first: the read-back's time is the transfer's.)
        self.dev.wait().map_err(device_error)?;
        let read = std::time::Instant::now();
        let (bad, peaks) = self.read_blocks(model).map_err(device_error)?;
        self.host.readback_s += read.elapsed().as_secs_f64();
        let first = model.cycle + 1;
        for _ in 0..ran {
            model.cycle += 1;
            model.time += dt;
        }
        if let Some(k) = bad {
            return Err(CycleError::NonFinite { cycle: first, block: model.blocks[k].id, what: "a non-finite position or velocity".into() });
        }
        // A block that moved more than the contact-forming distance in one step could pass a
        // contact unseen, unless it is alone (as on the CPU, `cpu::cycle`).
        let tol = model.contact_tolerance();
        let fastest = peaks.iter().copied().fold(0.0, f64::max);
        for (k, &travel) in peaks.iter().enumerate() {
            if travel > tol && !topology::alone(model, k, travel + fastest + topology::neighbour_margin(model)) {
                return Err(CycleError::TooFast { cycle: model.cycle, block: model.blocks[k].id, travel, limit: tol, speed: travel / dt });
            }
        }
        let limit = DETECTION_SHARE * tol;
        if model.neighbours_stale || model.blocks.iter().any(|b| b.travel >= limit) {
            let detection = std::time::Instant::now();
            self.detect(model, report)?;
            self.host.detection_s += detection.elapsed().as_secs_f64();
            self.host.detections += 1;
        }
        // The exact check where a crack may be due: after each cycle of a point-load scene, and
        // after a batch its screen halted (the screen fires wherever the exact check would, so a
        // batch that ran through has no crack due; one that halted may have none: then the run
        // goes on).
        if cracking && (!screened || halted) {
            // A crack changes the shapes: the cut is the CPU's (topology between cycles), then
            // the whole state is uploaded afresh. Griffith's law reads the stresses read back
            // with the blocks; the point-load law reads the contact forces, which come back every
            // cycle where a block obeys it, and otherwise only where a block cracks.
            if point_load {
                self.read_contacts(model).map_err(device_error)?;
            }
            let due = super::cracking::due(model);
            if !due.is_empty() {
                if !point_load {
                    self.read_contacts(model).map_err(device_error)?;
                }
                // The cut carries the parent's logical contacts to its pieces by where they lie
                // (`cpu::carry_across_cracks`): it must see the set the CPU finds on this state,
                // not the device's, kept since the last detection with points the kernels placed,
                // among which some loaded corners were not found (their springs' energy booked as
                // let go at the cut, and the ledger then grew by as much: +1.8e4 J of 9.5e4 on a
                // struck wall of twelve bricks in f32). So a detection's stage 4 first, for the
                // contacts of the blocks to crack: the cut's own stage 4 renews only the contacts
                // it touches (`cpu::crack_blocks`), so the others count alike before and after.
                let mut cracking = vec![false; model.blocks.len()];
                due.iter().for_each(|d| cracking[d.block] = true);
                cpu::contact_stage_of(model, model.contact_tolerance(), 0.0, Appearing::Carried, &topology::contacts_touching(model, |k| cracking[k]));
                cpu::crack_blocks(model, due, report);
                self.upload(model).map_err(device_error)?;
            }
        }
        Ok(ran)
    }

    /// The energy check ("The energy check and the last good state"): the contacts' springs
    /// summed on the device, where their state is, with the overlap test; the blocks' terms from
    /// the blocks read back after the batch. A contact the device finds driven through brings
    /// the contacts back, for the CPU's check to name it.
    fn energy(&mut self, model: &mut Model) -> Result<(f64, f64), CycleError> {
        let clock = std::time::Instant::now();
        let (strain, driven) = self.contact_energy(model).map_err(device_error)?;
        if driven {
            self.read_contacts(model).map_err(device_error)?;
            cpu::overlap_check(model)?;
        }
        // The step the next batch starts with (`advance`), from the state on the device.
        let dt = self.device_timestep(model).map_err(device_error)?;
        self.next_timestep = Some(dt);
        let e = model.energies_at(Some(strain), dt);
        self.host.checks_s += clock.elapsed().as_secs_f64();
        self.host.checks += 1;
        Ok((e.kinetic + e.strain, e.external_work))
    }

    fn sync(&mut self, model: &mut Model) -> Result<(), CycleError> {
        self.read_contacts(model).map_err(device_error)
    }

    /// The last good state: the model (its blocks as the batch left them, read back) and, on the
    /// device, a copy of the contacts' state (`Checkpoint`).
    fn keep(&mut self, model: &Model, last_good: &mut Model) {
        let clock = std::time::Instant::now();
        // The contacts without their logical contacts: the checkpoint holds those.
        last_good.keep_from(model, false);
        self.take_checkpoint(model);
        self.host.checks_s += clock.elapsed().as_secs_f64();
    }

    fn finish(&mut self, model: &mut Model) -> Result<(), CycleError> {
        self.read_all(model).map_err(device_error)?;
        Ok(())
    }

    /// A failure: the contacts of the last good state read back from the device checkpoint
    /// into it (where one was taken in this run; before the first, the model the run started
    /// from is whole).
    fn recover(&mut self, last_good: &mut Model) -> Result<(), CycleError> {
        let Some(cp) = self.checkpoint.as_mut().filter(|cp| cp.valid) else { return Ok(()) };
        cp.valid = false;
        if cp.contact_count != last_good.contacts.len() {
            return Err(CycleError::Setup(format!(
                "GPU: the checkpoint holds {} contacts, the last good state {}",
                cp.contact_count,
                last_good.contacts.len()
            )));
        }
        let Some(cp) = self.checkpoint.as_ref() else { return Ok(()) };
        let read = match self.dev.precision {
            Precision::F32 => self.read_contacts_from::<f32>(last_good, (&cp.contacts, &cp.logicals), &cp.keys, cp.bases),
            Precision::F64 => self.read_contacts_from::<f64>(last_good, (&cp.contacts, &cp.logicals), &cp.keys, cp.bases),
        };
        read.map_err(device_error)
    }
}

impl super::backend::Backend for GpuBackend {
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        GpuBackend::run_into(self, model, cycles, progress, report)
    }

    fn resumes_from(&self, model: &Model) -> bool {
        self.resumable && self.last_good == *model
    }

    fn device_state(&self) -> Option<DeviceState> {
        if self.state.is_none() {
            // RESTART then SAVE with no CYCLE between: the state restarted from, not uploaded yet.
            return self.pending.clone();
        }
        let read = match self.dev.precision {
            Precision::F32 => self.device_state_as::<f32>(&self.last_good),
            Precision::F64 => self.device_state_as::<f64>(&self.last_good),
        };
        read.ok().flatten()
    }

    fn resume_from(&mut self, model: &Model, device: Option<&DeviceState>) {
        // With the device state saved by a GPU run, the next run uploads it as it was and goes on
        // as the saving run would have; without it (a CPU run's file), the next run uploads the
        // model afresh (a detection at its start, as after any command).
        self.last_good.clone_from(model);
        self.state = None;
        // A version-3 file's f32 state holds vertices and points in global axes, which the f32
        // kernels no longer read (`restart::FORMAT_VERSION`): dropped, so that neither this run
        // nor a SAVE before it takes it.
        let device = device.filter(|d| {
            if d.absolute_f32 {
                use std::io::Write as _;
                let _ = writeln!(
                    std::io::stderr(),
                    "blockdem: the saved GPU state is not taken (it is save format 3's, whose f32 kernels kept vertices and contact points in \
                     global axes where these keep them from each contact's block 1); the run starts with a contact detection"
                );
            }
            !d.absolute_f32
        });
        self.resumable = device.is_some();
        self.pending = device.cloned();
    }

    fn forget(&mut self) {
        self.state = None;
        self.resumable = false;
        self.pending = None;
        self.last_good = Model::default();
    }

    fn describe(&self) -> String {
        let a = self.adapter();
        format!("gpu ({}, {} [{}], {})", a.backend, a.name, a.driver_name(), self.precision())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The device's Griffith screen (`crack_screen`) is given a TF only where the CPU may crack
    /// the block: a simply-deformable block of constitutive 3–5 with a TF, not a fragment at the
    /// floor (`cracking::above_floor`). A fragment at the floor, screened, would halt its batch
    /// at every cycle its stress passed TF for the CPU to refuse the crack.
    #[test]
    fn a_fragment_at_the_floor_is_not_screened_on_the_device() {
        let deck = "START\nPROP MAT=1 D=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 TF=2E3\nBOX 0 1 0 1 0 1 CONS 3\nBOX 5 6 5 6 0 1 CONS 1\n\
                    CHANGE -1 7 -1 7 -1 2 SDEF\n";
        let commands = super::super::deck::parse_deck(deck, "<test>").unwrap();
        let mut exec = super::super::exec::Executor::new(Box::new(std::io::sink()), "<test>");
        exec.run(&commands).unwrap_or_else(|e| panic!("{e}"));
        let mut model = std::mem::take(&mut exec.model);
        assert!(model.blocks.iter().all(|b| b.is_sdef()));
        let tf = |model: &Model| sdef_pods::<f64>(model).unwrap()[..2].iter().map(|p| p.tf).collect::<Vec<_>>();
        // Griffith's block is screened, the point-load one (constitutive 1) is not.
        assert_eq!(tf(&model), [2e3, 0.0]);
        // The same block as a piece of 1/32 of the block built (two pieces at the floor of 1/64):
        // still screened; under it, not.
        model.blocks[0].built_volume = 32.0 * model.blocks[0].volume;
        assert_eq!(tf(&model), [2e3, 0.0]);
        model.blocks[0].built_volume = 33.0 * model.blocks[0].volume;
        assert_eq!(tf(&model)[0], 0.0);
        assert_eq!(sdef_pods::<f32>(&model).unwrap()[0].tf, 0.0);
    }

    /// A scene past the adapter's binding limit is refused before any buffer is made, naming the
    /// buffer and the way out, not left to wgpu's validation (which panics off an error scope).
    /// Its buffers' items are those the upload makes.
    #[test]
    fn a_scene_past_the_binding_limit_is_refused_naming_its_buffer() {
        // Four cubes side by side on a fixed slab.
        let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9\nBOX -1 3 -1 3 -1 0\nBOX 0 1 0 1 0 1\nBOX 1 2 0 1 0 1\nBOX 0 1 1 2 0 1\nBOX 1 2 1 2 0 1\n\
                    FIX -1 3 -1 3 -0.6 -0.4\nCYCLE 0\n";
        let commands = super::super::deck::parse_deck(deck, "<test>").unwrap();
        let mut exec = super::super::exec::Executor::new(Box::new(std::io::sink()), "<test>");
        exec.run(&commands).unwrap_or_else(|e| panic!("{e}"));
        let model = std::mem::take(&mut exec.model);
        fn check<R: Real>(model: &Model, advice: &str) {
            let items = buffer_items::<R>(model);
            let count = |what: &str| items.iter().find(|(label, _, _)| *label == what).map(|&(_, _, n)| n).unwrap();
            // As the upload makes them.
            let (_, _, logicals, adjacency, _) = topology_pods::<R>(model);
            let (vertices, planes, edges) = shape_pods::<R>(model);
            assert_eq!((count("blocks"), count("vertices"), count("face planes"), count("edges")), (5, vertices.len(), planes.len(), edges.len()));
            assert_eq!((count("contacts"), count("logical contacts"), count("adjacency")), (model.contacts.len(), logicals.len(), adjacency.words.len()));
            // Every buffer fits a binding of 128 MiB. The logical contacts' is the largest (four
            // a face–face contact): a binding a byte short of it refuses that buffer alone,
            // named, with the way out.
            assert!(fits::<R>(model, 128 << 20).is_ok());
            let bytes = |what: &str| items.iter().filter(|(label, _, _)| *label == what).map(|&(_, item, n)| (item * n) as u64).sum::<u64>();
            let need = bytes("logical contacts");
            assert!(items.iter().all(|(label, _, _)| *label == "logical contacts" || bytes(label) < need), "{items:?}");
            match fits::<R>(model, need - 1) {
                Err(GpuError::DoesNotFit(why)) => {
                    assert!(why.contains(&format!("the logical contacts buffer would need {need} bytes")) && why.contains(advice), "{why}")
                }
                other => panic!("{other:?}"),
            }
        }
        check::<f32>(&model, "--backend cpu");
        check::<f64>(&model, "--precision f32");
    }
}
