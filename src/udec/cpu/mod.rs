//! The CPU backend: the explicit cycle in f64, the accuracy reference (DESIGN.md §1–3).
//!
//! Each stage lives in its own file, named like its WGSL kernel twin:
//! `law_of_motion`, `geometry_update`, `contact_forces`, `gather`. A cycle makes two passes over
//! the model, each shared out over a team of threads (`team`):
//!
//! 1. per block — stage 6 of the previous cycle (gather the contact forces), stage 1 (law of
//!    motion), stage 2 (geometry update);
//! 2. per contact — stage 4 (contact kinematics and force–displacement law);
//!
//! then, on the calling thread, stage 7 when a block has moved past the update tolerance. The run
//! around the cycles (resume or full detection, energy check, last good state, roll-back,
//! progress) is the run driver's (`driver`); this backend supplies its stages.

pub mod contact_forces;
pub mod flow;
pub mod gather;
pub mod geometry_update;
pub mod law_of_motion;
mod team;
pub mod zones;

use crate::driver::{self, Position};
use crate::udec::backend::{Backend, CrackEvent, CycleError, CycleReport};
use crate::udec::model::fdef::Fdef;
use crate::udec::model::sdef::Sdef;
use crate::udec::model::{Block, BlockKind, Contact, Corner, Material, Model};
use crate::udec::topology::{self, Adjacency, Topology};

use crate::udec::contact::gather::ContactForce;
use contact_forces::contact_stage;
use gather::gather_all;
use law_of_motion::StepOutcome;
use team::Team;

/// Least work a thread takes in a stage, in blocks (stages 6+1+2, some 50 ns a block) or
/// contacts (stage 4, some 20 ns a contact): over 10 µs, several times what it costs to hand a
/// stage to the waiting helpers of the team (see `team`). A stage runs on at most
/// `items / MIN_…_PER_THREAD` threads, so a small model runs on the calling thread alone and a
/// large one on all.
const MIN_BLOCKS_PER_THREAD: usize = 256;
const MIN_CONTACTS_PER_THREAD: usize = 512;
/// Least elements in one chunk of work handed out to a thread.
const MIN_CHUNK: usize = 64;

#[derive(Default)]
pub struct CpuBackend {
    /// Per-block contact lists, rebuilt after every topology change, and what stage 7 keeps with
    /// them.
    topology: Topology,
    scratch: Scratch,
    /// The last good state of the previous run, kept so that the next run copies into its
    /// storage rather than allocating a second model (hundreds of megabytes at 10⁶ blocks).
    last_good: Model,
    /// The previous run ended well, so `last_good` is the state it left and `topology` its
    /// contact lists: a run on a model still equal to it goes on without a full detection.
    resumable: bool,
}

/// Per-cycle working arrays, kept between cycles so that a cycle allocates nothing.
#[derive(Default)]
struct Scratch {
    /// What each block's step did in the current cycle.
    steps: Vec<StepOutcome>,
    /// What the gather reads of each contact, in contact order: written by stage 4, and copied
    /// from the contacts after anything else changes them (`sync_forces`).
    forces: Vec<ContactForce>,
    /// Stage 5's state (empty in a dry scene).
    fluid: flow::FluidScratch,
    /// In a scene with zoned blocks, each zoned block's boundary grid-point velocities in corner
    /// order (indexed like the corners), written by stage 1 for stage 4: the contact law reads
    /// them there, in the order of the corners it already reads, instead of through each block's
    /// own grid-point list (a cache miss a contact side: the zoned wall's contact stage cost
    /// twenty times the rigid one's per contact on this machine). Empty in other scenes.
    corner_velocity: Vec<[f64; 2]>,
    /// In a scene with zoned blocks, each contact's corner and feature (`[corner, feature]`), in
    /// contact order beside `forces`: written by stage 4, which moves the feature, for a zoned
    /// block's gather, which shares each force out to its grid points by them
    /// (`zones::force_shares`). Read from the contacts themselves, they were a cache miss an
    /// adjacency entry (a third of the zoned wall's gather). Empty in other scenes.
    features: Vec<[u32; 2]>,
}

/// Copies the gather's view of every contact after a topology change (stage 7, a crack): the
/// force records, and in a scene with zoned blocks the contacts' corners and features.
fn sync_forces(model: &Model, forces: &mut Vec<ContactForce>, features: &mut Vec<[u32; 2]>) {
    use rayon::prelude::*;
    let feature = |c: &Contact| [c.corner, c.feature];
    if model.contacts.len() < PARALLEL_SYNC {
        forces.clear();
        forces.extend(model.contacts.iter().map(ContactForce::from));
        features.clear();
        if !model.fdef.is_empty() {
            features.extend(model.contacts.iter().map(feature));
        }
    } else {
        model.contacts.par_iter().with_min_len(PARALLEL_SYNC / 4).map(ContactForce::from).collect_into_vec(forces);
        if model.fdef.is_empty() {
            features.clear();
        } else {
            model.contacts.par_iter().with_min_len(PARALLEL_SYNC / 4).map(feature).collect_into_vec(features);
        }
    }
}

/// Contacts from which `sync_forces` runs on rayon's threads (a topology change of a small model
/// would pay more to hand the copy over than it saves).
const PARALLEL_SYNC: usize = 1 << 16;

impl CpuBackend {
    pub fn new() -> Self {
        Self::default()
    }
}

/// How many threads the team of a run gets: as many as its largest stage can use (counting four
/// contacts a block, as contacts may form during the run), at most rayon's thread count (which
/// `RAYON_NUM_THREADS` sets).
fn team_size(model: &Model) -> usize {
    let (blocks, contacts) = (model.blocks.len(), model.contacts.len());
    let want = (blocks / MIN_BLOCKS_PER_THREAD).max(contacts.max(4 * blocks) / MIN_CONTACTS_PER_THREAD);
    want.clamp(1, rayon::current_num_threads())
}

/// A slice that the threads of a stage share, each taking its own elements from it.
struct SharedMut<T>(*mut T);
// SAFETY: the stages hand every thread disjoint ranges of the slice (see `range`).
unsafe impl<T: Send> Sync for SharedMut<T> {}

impl<T> SharedMut<T> {
    fn new(s: &mut [T]) -> Self {
        SharedMut(s.as_mut_ptr())
    }

    /// The elements `r` of the slice.
    ///
    /// # Safety
    /// `r` lies within the slice, the slice stays mutably borrowed by the caller of `new` while
    /// the result lives, and no other thread touches these elements meanwhile.
    #[allow(clippy::mut_from_ref)]
    unsafe fn range(&self, r: std::ops::Range<usize>) -> &mut [T] {
        std::slice::from_raw_parts_mut(self.0.add(r.start), r.len())
    }
}

/// Whether each block's corners are the contiguous range that follows the previous block's, as
/// `Model` keeps them: the block pass hands each thread the corners of its blocks.
fn corners_in_block_order(model: &Model) -> bool {
    let mut next = 0usize;
    for b in &model.blocks {
        if b.corner_start as usize != next {
            return false;
        }
        next += b.corner_count as usize;
    }
    next == model.corners.len()
}

/// Runs stage 7 when a block has moved past the update tolerance; returns whether it did. In a
/// scene with fluid the domains are rebuilt from the new lists (ids, pressures and PFIX kept), as
/// the CPU's own stage 7 does (`fluid_after_topology`).
pub(crate) fn maybe_update_topology(model: &mut Model, topology: &mut Topology, report: &mut CycleReport, force: bool) -> bool {
    if !force && !topology_update_due(model) {
        return false;
    }
    update_topology(model, topology, report, force);
    if model.fluid.is_some() {
        topology::refresh_domains(model);
    }
    true
}

/// Whether a block has passed its contact-update threshold (`Block::update_due`).
pub(crate) fn topology_update_due(model: &Model) -> bool {
    let tol = model.tol;
    model.blocks.iter().any(|b| b.update_due(&tol))
}

/// Stage 7: contact detection (all pairs when `full`, else around the blocks past the update
/// tolerance) and the adjacency lists.
fn update_topology(model: &mut Model, topology: &mut Topology, report: &mut CycleReport, full: bool) {
    let _p = crate::profile::scope(if full { crate::profile::Stage::DetectFull } else { crate::profile::Stage::DetectUpdate });
    // Also keeps the adjacency lists, and moves the energy terms of contacts dropped while
    // loaded to the ledger's retired account.
    let (created, dropped) = topology::update_topology(model, full, topology);
    report.topology_updates += 1;
    report.contacts_created += created as u64;
    report.contacts_dropped += dropped as u64;
}

/// What stages 6, 1 and 2 read besides the blocks they move.
struct BlockInputs<'a> {
    /// The contact forces and adjacency to gather from; `None` when the block forces are current.
    gather: Option<(&'a [ContactForce], &'a Adjacency)>,
    gravity: [f64; 2],
    alpha: f64,
    /// Internal mass damping of simply-deformable blocks (DAMP … INTERNAL, ALPB).
    alpha_internal: f64,
    materials: &'a [Material],
    /// Each contact's corner and feature (`Scratch::features`: a fully-deformable block's gather
    /// shares its contact forces out by them; empty in a scene without zoned blocks).
    features: &'a [[u32; 2]],
    /// In a scene with fluid, stage 5's results (`flow`): each block's load from the domain
    /// pressures and buoyancy, which its gather adds, and the deformable blocks' share of the
    /// pressures.
    fluid: Option<&'a flow::FluidScratch>,
    dt: f64,
}

/// Adds block `b`'s fluid load (stage 5) to the force sums its gather has just made.
#[inline]
fn add_fluid_load(block: &mut Block, loads: Option<&[[f64; 3]]>, b: usize) {
    if let Some(l) = loads.and_then(|l| l.get(b)) {
        block.force[0] += l[0];
        block.force[1] += l[1];
        block.moment += l[2];
    }
}

/// Stages 6, 1 and 2 of one rigid block, whose corners are `corners`: it sums its contact forces
/// (unless they are current), takes its step and places its corners.
#[inline]
fn rigid_block(b: usize, block: &mut Block, corners: &mut [Corner], inp: &BlockInputs) -> StepOutcome {
    if let Some((forces, adjacency)) = inp.gather {
        gather::gather(b, block, forces, adjacency, inp.gravity);
        add_fluid_load(block, inp.fluid.map(|f| &f.loads[..]), b);
    }
    let step = law_of_motion::law_of_motion(block, inp.gravity, inp.alpha, inp.dt);
    geometry_update::geometry_update(block, corners);
    step
}

/// Stages 6, 1 and 2 for the blocks `first .. first + blocks.len()`, whose corners are `corners`
/// (each block's contiguous range, in block order): each block sums its contact forces, takes its
/// step and places its corners — one pass over the blocks instead of three.
fn block_piece(first: usize, blocks: &mut [Block], mut corners: &mut [Corner], steps: &mut [StepOutcome], inp: &BlockInputs) {
    for (j, (block, step)) in blocks.iter_mut().zip(steps.iter_mut()).enumerate() {
        let (mine, rest) = std::mem::take(&mut corners).split_at_mut(block.corner_count as usize);
        corners = rest;
        *step = rigid_block(first + j, block, mine, inp);
    }
}

/// [`block_piece`] in a scene with simply-deformable blocks: `sdef` is the extension of `blocks`
/// (as long); an SDEF block also sums its applied stress (stage 6), steps its strain after its
/// rigid motion (stage 1, `model::sdef::internal_step`, the strain's motion of its corners
/// counted by `model::sdef::count_strain_travel`) and places its corners strained. The GPU's twin
/// is `law_of_motion_sdef`.
fn block_piece_sdef(first: usize, blocks: &mut [Block], sdef: &mut [Sdef], mut corners: &mut [Corner], steps: &mut [StepOutcome], inp: &BlockInputs) {
    for (j, ((block, s), step)) in blocks.iter_mut().zip(sdef.iter_mut()).zip(steps.iter_mut()).enumerate() {
        let (mine, rest) = std::mem::take(&mut corners).split_at_mut(block.corner_count as usize);
        corners = rest;
        if block.kind != BlockKind::SimplyDeformable {
            *step = rigid_block(first + j, block, mine, inp);
            continue;
        }
        if let Some((forces, adjacency)) = inp.gather {
            gather::gather_sdef(first + j, block, s, forces, adjacency, inp.gravity, inp.fluid);
        }
        *step = law_of_motion::law_of_motion(block, inp.gravity, inp.alpha, inp.dt);
        if !block.fixed {
            let mat = &inp.materials[crate::udec::model::material_slot(block.material, inp.materials.len())].block;
            crate::udec::model::sdef::internal_step(s, mat, block.area, block.rotation, inp.alpha_internal, inp.dt);
            crate::udec::model::sdef::count_strain_travel(s, block, &mut step.corner_travel, inp.dt);
        } else {
            s.strain_rate = [0.0; 3];
        }
        geometry_update::geometry_update_strained(block, s.strain, mine);
    }
}

/// [`block_piece`] in a scene with fully-deformable blocks: `fdef` is the extension of `blocks`
/// (as long), `sdef` the simply-deformable one where the scene has it. A zoned block sums its
/// grid points' forces (stage 6), steps them (stage 1), updates its zones' stresses (stage 3)
/// and places its corners on them (stage 2, `zones`); any other block as before.
#[allow(clippy::too_many_arguments)]
fn block_piece_fdef(
    first: usize,
    blocks: &mut [Block],
    mut sdef: Option<&mut [Sdef]>,
    fdef: &mut [Fdef],
    mut corners: &mut [Corner],
    mut corner_velocity: &mut [[f64; 2]],
    steps: &mut [StepOutcome],
    inp: &BlockInputs,
) {
    for (j, ((block, f), step)) in blocks.iter_mut().zip(fdef.iter_mut()).zip(steps.iter_mut()).enumerate() {
        let (mine, rest) = std::mem::take(&mut corners).split_at_mut(block.corner_count as usize);
        corners = rest;
        let (velocities, rest) = std::mem::take(&mut corner_velocity).split_at_mut(block.corner_count as usize);
        corner_velocity = rest;
        match block.kind {
            BlockKind::FullyDeformable if !f.zones.is_empty() => {
                let wet = gather::fdef_fluid(inp.fluid, first + j, block);
                if let Some((forces, adjacency)) = inp.gather {
                    zones::gather_fdef(block, f, mine, inp.features, forces, adjacency.entries(first + j), inp.gravity, wet);
                }
                *step = zones::step_fdef(block, f, mine, inp, wet);
                // Its boundary's velocities for stage 4 (grid point k is corner k).
                for (v, g) in velocities.iter_mut().zip(&f.gridpoints) {
                    *v = g.velocity;
                }
            }
            BlockKind::SimplyDeformable if sdef.is_some() => {
                let s = &mut sdef.as_deref_mut().expect("checked")[j];
                block_piece_sdef(first + j, std::slice::from_mut(block), std::slice::from_mut(s), mine, std::slice::from_mut(step), inp);
            }
            _ => *step = rigid_block(first + j, block, mine, inp),
        }
    }
}

/// One cycle of stages 6, 1, 2, 3 (zones, where the scene has them) and 4 (no fluid yet). Stage 6 of the
/// previous cycle — the force sums stage 1 needs — runs here, fused with stages 1 and 2, unless
/// `gathered` says the block forces are current already; on return they are not (stage 4 has
/// changed the contact forces). The corners must be in block order (`corners_in_block_order`).
fn cycle_once(model: &mut Model, adjacency: &Adjacency, scratch: &mut Scratch, gathered: bool, team: &mut Team) -> Result<(), CycleError> {
    let Scratch { steps, forces, fluid, corner_velocity, features } = scratch;
    let has_fluid = model.fluid.is_some();
    let dt = model.timestep;
    let (gravity, alpha) = (model.gravity, model.damping.alpha);
    // Stages 6, 1 and 2, block by block: a block's corners are its own contiguous slice and its
    // force sum reads only the contacts, so the blocks run on any thread and each result is what
    // a serial loop would give; the sums below are taken serially, so runs repeat bit for bit
    // whatever the number of threads.
    {
        let _p = crate::profile::scope(crate::profile::Stage::MotionGeometry);
        let Model { blocks, corners, sdef, fdef, materials, damping, .. } = &mut *model;
        steps.resize(blocks.len(), StepOutcome::default());
        let inp = BlockInputs {
            gather: (!gathered).then_some((&forces[..], adjacency)),
            gravity,
            alpha,
            alpha_internal: damping.alpha_internal,
            materials,
            features,
            fluid: has_fluid.then_some(&*fluid),
            dt,
        };
        let n = blocks.len();
        corner_velocity.resize(if fdef.is_empty() { 0 } else { corners.len() }, [0.0; 2]);
        let shared_velocity = SharedMut::new(&mut corner_velocity[..]);
        let (shared_blocks, shared_corners, shared_steps) = (SharedMut::new(blocks), SharedMut::new(corners), SharedMut::new(steps));
        // The simply-deformable extension, where the scene has one (indexed like the blocks).
        let shared_sdef = (!sdef.is_empty()).then(|| SharedMut::new(sdef));
        // The fully-deformable extension, likewise.
        let shared_fdef = (!fdef.is_empty()).then(|| SharedMut::new(fdef));
        team.for_chunks(n, MIN_BLOCKS_PER_THREAD, MIN_CHUNK, &|r| {
            // SAFETY: the chunks are disjoint ranges of blocks; their corners, the contiguous
            // range from the first block's first corner to the last block's last (corners in
            // block order), are then disjoint too; `steps` has one slot per block.
            let (blocks, steps) = unsafe { (shared_blocks.range(r.clone()), shared_steps.range(r.clone())) };
            let (first, last) = (&blocks[0], &blocks[blocks.len() - 1]);
            let corner_range = first.corner_start as usize..(last.corner_start + last.corner_count) as usize;
            // SAFETY: as above.
            let corners = unsafe { shared_corners.range(corner_range.clone()) };
            match (&shared_sdef, &shared_fdef) {
                // SAFETY: `fdef` (and `sdef`, where there) is as long as `blocks`; the chunk's
                // range of it is disjoint too.
                (sdef, Some(fdef)) => block_piece_fdef(
                    r.start,
                    blocks,
                    sdef.as_ref().map(|s| unsafe { s.range(r.clone()) }),
                    unsafe { fdef.range(r.clone()) },
                    corners,
                    // SAFETY: indexed like the corners (sized to them above): the same disjoint range.
                    unsafe { shared_velocity.range(corner_range.clone()) },
                    steps,
                    &inp,
                ),
                // SAFETY: `sdef` is as long as `blocks`; the chunk's range of it is disjoint too.
                (Some(sdef), None) => block_piece_sdef(r.start, blocks, unsafe { sdef.range(r.clone()) }, corners, steps, &inp),
                (None, None) => block_piece(r.start, blocks, corners, steps, &inp),
            }
        });
    }
    let mut work = 0.0;
    // The zoned blocks' fluid work (none elsewhere: `flow::fluid_work` takes the others').
    let mut zoned_fluid_work = 0.0;
    let mut fastest = (0.0f64, 0usize);
    let mut inverted = None;
    for (b, step) in steps.iter().enumerate() {
        if let (None, Some(z)) = (inverted, step.inverted_zone) {
            inverted = Some((b, z));
        }
        work += step.external_work;
        zoned_fluid_work += step.fluid_work;
        if step.corner_travel > fastest.0 {
            fastest = (step.corner_travel, b);
        }
    }
    model.external_work += work;
    if has_fluid {
        let mut w = flow::fluid_work(model, fluid);
        if !model.fdef.is_empty() {
            w += zoned_fluid_work;
        }
        if let Some(f) = model.fluid.as_mut() {
            f.work += w;
        }
    }
    model.cycle += 1;
    model.time += dt;
    if !work.is_finite() {
        // The first block whose step is not finite (as the kernel's atomicMin picks), or, where
        // only the sum overflowed, the one that added most.
        let b = steps
            .iter()
            .position(|s| !s.external_work.is_finite())
            .unwrap_or_else(|| steps.iter().enumerate().max_by(|x, y| x.1.external_work.abs().total_cmp(&y.1.external_work.abs())).map_or(0, |(b, _)| b));
        return Err(CycleError::non_finite_step(model, b));
    }
    if has_fluid && !model.fluid.is_some_and(|f| f.work.is_finite()) {
        return Err(CycleError::non_finite_fluid_work(model));
    }
    if let Some((b, z)) = inverted {
        return Err(CycleError::ZoneInverted { cycle: model.cycle, block: model.blocks[b].id, zone: z + 1 });
    }
    // Between contact updates a block's corners move at most etol plus one step's travel s, so two
    // blocks approach by at most 2(etol + s); that must stay below atol for no touch to be missed.
    // A faster block could cross a thin neighbour unseen: stop rather than let it tunnel.
    let limit = 0.5 * model.tol.atol - model.tol.etol;
    if fastest.0 > limit {
        let b = &model.blocks[fastest.1];
        return Err(CycleError::TooFast { cycle: model.cycle, block: b.id, travel: fastest.0, limit, speed: fastest.0 / dt });
    }
    // Stage 4.
    contact_stage(model, forces, features, has_fluid.then_some(&mut fluid.feet), corner_velocity, dt, team)?;
    // Stage 5.
    if has_fluid {
        flow::flow_stage(model, adjacency, fluid, team);
    }
    Ok(())
}

/// After a change of topology in a scene with fluid (stage 7: a contact update, a crack): the
/// domains rebuilt from the new lists (keeping ids, pressures and PFIX), the blocks' loads at
/// them, and the time step cut where the new domains need a shorter one
/// (`model::fluid::fluid_timestep`). Nothing in a dry scene.
fn fluid_after_topology(model: &mut Model, topology: &Topology, fluid: &mut flow::FluidScratch, report: &mut CycleReport) -> Result<(), CycleError> {
    if model.fluid.is_none() {
        return Ok(());
    }
    topology::refresh_domains(model);
    flow::all_pressure_loads(model, &topology.lists, fluid);
    fluid_timestep_cut(model, report)
}

/// The contact lists a run starts from when it does not go on from the last: a full detection
/// (stage 7 over all pairs), or, in a scene with fluid whose state is as a run left it
/// (`Fluid::as_run_left`: a RESTART of a SAVE after a CYCLE), the lists of the contacts it has,
/// which that run kept current. A run's updates are incremental: a full detection would restart
/// every block's distance moved (`Block::moved_since_update`), and with it the timing of the
/// updates after, at which the domains are rebuilt and the step cut to the fluid's limits; so
/// such a state's contacts, domains and step are kept, as in a run that went on, and CYCLE N,
/// SAVE, RESTART, CYCLE M is CYCLE N + M bit for bit. Returns whether they were kept.
pub(crate) fn start_detection(model: &mut Model, topology: &mut Topology, report: &mut CycleReport) -> bool {
    let kept = keeps_run_state(model);
    if kept {
        *topology = Topology::build(model.blocks.len(), &model.contacts);
    } else {
        update_topology(model, topology, report, true);
    }
    kept
}

/// Whether a run's start keeps the contacts, domains and step of `model` (`start_detection`): a
/// scene with fluid whose state is as a run left it, domains included.
fn keeps_run_state(model: &Model) -> bool {
    model.fluid.is_some_and(|f| f.as_run_left) && model.domains.is_some()
}

/// A run has started: in a scene with fluid its state is as a run left it from here on
/// (`Fluid::as_run_left`).
pub(crate) fn mark_as_run_left(model: &mut Model) {
    if let Some(f) = model.fluid.as_mut() {
        f.as_run_left = true;
    }
}

/// The time step cut where the domains as they are now need a shorter one
/// (`model::fluid::fluid_timestep`): after each rebuild of the domains, on either backend. A
/// limit that underflows f64 (CPERM = 1e300 against bulkw = 2e9: the step would be 0, the run
/// would cycle without time passing while its flows overflow) stops the run before the cycle.
// `!(dt >= …)` on purpose: a NaN limit fails the check too.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn fluid_timestep_cut(model: &mut Model, report: &mut CycleReport) -> Result<(), CycleError> {
    if model.fluid.is_none() {
        return Ok(());
    }
    let k_contact = model.contact_stiffness_max();
    if let Some(dt) = crate::udec::model::fluid::fluid_timestep(model, k_contact) {
        if !(dt >= f64::MIN_POSITIVE) {
            return Err(CycleError::Setup(crate::udec::model::fluid::step_underflow_text(model, dt)));
        }
        if dt < model.timestep {
            model.timestep = dt;
            report.timestep_changes.push((model.cycle, dt));
        }
    }
    // Likewise a flow, conductance × Δp, past f64 (PFIX OUTER 1E300 beside CPERM 10): the
    // rebuild has just computed each contact's.
    match crate::udec::model::fluid::flow_overflow_text(model) {
        Some(text) => Err(CycleError::Setup(text)),
        None => Ok(()),
    }
}

/// `driver::prepare` for the 2D backends: a start that fails in a scene with fluid (a step that
/// underflows or a flow that overflows, found on the domains the start built,
/// `fluid_timestep_cut`) hands the model back as it was given, so that the last good state of
/// the failed CYCLE is the one before it, which a SAVE holds and a RESTART takes (the rebuilt
/// domains held the overflowing flows). Only a start that rebuilds the domains keeps the copy:
/// a dry start writes nothing a SAVE cannot hold, and one that goes on from the state a run left
/// (a piece of a CYCLE, a RESTART of its SAVE: `start_detection`) keeps its domains as they are.
pub(crate) fn prepare_run<S: driver::Start<Model> + ?Sized>(start: &mut S, model: &mut Model, report: &mut CycleReport) -> Result<bool, CycleError> {
    let before = (model.fluid.is_some() && !keeps_run_state(model)).then(|| model.clone());
    driver::prepare(start, model, report).inspect_err(|_| {
        if let Some(before) = before {
            *model = before;
        }
    })
}

impl Backend for CpuBackend {
    fn describe(&self) -> String {
        "cpu (f64)".to_string()
    }

    /// A run through the run driver (`driver`): the CPU's stages are one cycle at a time on a
    /// team of threads sized to the model the start's detection leaves.
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        let mut start = CpuStart {
            topology: &mut self.topology,
            forces: &mut self.scratch.forces,
            features: &mut self.scratch.features,
            fluid: &mut self.scratch.fluid,
            last_good: &self.last_good,
            resumable: &mut self.resumable,
        };
        let resume = prepare_run(&mut start, model, report)?;
        let mut kept = std::mem::take(&mut self.last_good);
        let mut topology = std::mem::take(&mut self.topology);
        let scratch = &mut self.scratch;
        let result = team::with_team(team_size(model), |team| {
            let mut stages = CpuStages { topology: &mut topology, scratch, team, gathered: true };
            driver::cycles(&mut stages, model, cycles, resume, &mut kept, report, progress)
        });
        self.last_good = kept;
        result?;
        // The last check copied the final state (its cycle is the last).
        self.resumable = cycles > 0;
        self.topology = topology;
        Ok(())
    }
}

/// The CPU's start of a run (before its team exists): the resume test's flag and state, and the
/// full detection.
struct CpuStart<'a> {
    topology: &'a mut Topology,
    forces: &'a mut Vec<ContactForce>,
    features: &'a mut Vec<[u32; 2]>,
    fluid: &'a mut flow::FluidScratch,
    last_good: &'a Model,
    resumable: &'a mut bool,
}

impl driver::Start<Model> for CpuStart<'_> {
    fn take_resumable(&mut self) -> Option<&Model> {
        std::mem::take(self.resumable).then_some(self.last_good)
    }

    fn preflight(&mut self, model: &Model) -> Result<(), CycleError> {
        // The block pass relies on it (and the model always keeps it).
        assert!(corners_in_block_order(model), "corners are stored in block order");
        Ok(())
    }

    /// Between runs the executor may have split, deleted or moved blocks: a full detection,
    /// unless the model is the very state the last run left, whose contacts are current.
    fn start(&mut self, model: &mut Model, resume: bool, report: &mut CycleReport) -> Result<(), CycleError> {
        if resume {
            sync_forces(model, self.forces, self.features);
            return Ok(());
        }
        let kept = start_detection(model, self.topology, report);
        sync_forces(model, self.forces, self.features);
        // With fluid: the domains of the lists just detected, their loads, and the time step the
        // fluid allows; or, from a state a run left, that state's domains and step and their
        // loads. A run that goes on from the last keeps the domains, loads and time step that
        // run left, so that CYCLE 100, CYCLE 100 is CYCLE 200 bit for bit.
        if kept {
            flow::all_pressure_loads(model, &self.topology.lists, self.fluid);
        } else {
            fluid_after_topology(model, self.topology, self.fluid, report)?;
        }
        mark_as_run_left(model);
        Ok(())
    }
}

/// The CPU's stages inside its team's scope.
struct CpuStages<'a, 't> {
    topology: &'a mut Topology,
    scratch: &'a mut Scratch,
    team: &'a mut Team<'t>,
    /// Whether the block forces are the gather of the current contact forces. Stage 6 runs
    /// fused into the next cycle's block pass; it runs on its own only where something reads the
    /// block forces between cycles: the energy terms (kinetic energy is taken at the whole step
    /// from the force, see `Model::energies`) that the energy check and every topology change
    /// book, and the state a run leaves.
    gathered: bool,
}

impl CpuStages<'_, '_> {
    fn gather(&mut self, model: &mut Model) {
        if !self.gathered {
            gather_all(model, &self.scratch.forces, &self.scratch.features, &self.scratch.fluid, &self.topology.lists, self.team);
            self.gathered = true;
        }
    }
}

impl driver::Stages<Model> for CpuStages<'_, '_> {
    /// The force sums the first step needs.
    fn begin_cycles(&mut self, model: &mut Model) -> Result<(), CycleError> {
        gather_all(model, &self.scratch.forces, &self.scratch.features, &self.scratch.fluid, &self.topology.lists, self.team);
        self.gathered = true;
        Ok(())
    }

    /// One cycle at a time, each followed by stage 7: cracking, then contact updates.
    fn advance(&mut self, model: &mut Model, max: u64, cracking: bool, report: &mut CycleReport) -> Result<u64, CycleError> {
        for _ in 0..max {
            cycle_once(model, &self.topology.lists, self.scratch, self.gathered, self.team)?;
            self.gathered = false;
            if cracking {
                self.gather(model);
                if crack_step(model, &self.topology.lists, report) {
                    assert!(corners_in_block_order(model), "corners are stored in block order");
                    *self.topology = Topology::build(model.blocks.len(), &model.contacts);
                    sync_forces(model, &mut self.scratch.forces, &mut self.scratch.features);
                    fluid_after_topology(model, self.topology, &mut self.scratch.fluid, report)?;
                    self.gathered = false;
                    if let Some(dt) = model.critical_timestep() {
                        if dt < model.timestep {
                            model.timestep = dt;
                            report.timestep_changes.push((model.cycle, dt));
                        }
                    }
                }
            }
            let tol = model.tol;
            if model.blocks.iter().any(|b| b.update_due(&tol)) {
                // The update books the energy of the contacts it drops, from the forces.
                self.gather(model);
                update_topology(model, self.topology, report, false);
                sync_forces(model, &mut self.scratch.forces, &mut self.scratch.features);
                fluid_after_topology(model, self.topology, &mut self.scratch.fluid, report)?;
                self.gathered = false;
            }
        }
        Ok(max)
    }

    fn energy(&mut self, model: &mut Model) -> Result<(f64, f64), CycleError> {
        self.gather(model);
        let _p = crate::profile::scope(crate::profile::Stage::Checks);
        if let Some(failure) = CycleError::non_finite_pressure(model) {
            return Err(failure);
        }
        let e = model.energies();
        Ok((e.kinetic + e.strain, e.external_work + e.fluid_work))
    }

    fn keep(&mut self, model: &Model, last_good: &mut Model) {
        last_good.clone_from(model);
    }
}

/// Checks every cracking candidate once and applies the cracks found. Returns whether any block
/// cracked.
pub(crate) fn crack_step(model: &mut Model, adjacency: &Adjacency, report: &mut CycleReport) -> bool {
    let _p = crate::profile::scope(crate::profile::Stage::Cracking);
    let mut found = Vec::new();
    for b in 0..model.blocks.len() {
        if let Some(c) = topology::find_crack(model, adjacency, b) {
            found.push((model.blocks[b].id, c));
        }
    }
    let mut changed = false;
    // Apply one crack per block; indices shift after each split, so look blocks up by id.
    for (id, mut crack) in found {
        let Some(b) = model.block_index(id) else { continue };
        crack.block = b;
        let before = model.next_block_id;
        if model.retire_energy_around(|m| topology::apply_crack(m, &crack)).is_some() {
            changed = true;
            let criterion = crack.law.label();
            report.cracks.push(CrackEvent {
                cycle: model.cycle,
                block: id,
                new_block: before,
                criterion,
                value: crack.value,
                from: Position::xy(crack.from),
                to: Position::xy(crack.to),
            });
        }
    }
    changed
}
