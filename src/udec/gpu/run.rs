//! A run on the GPU backend (`Backend::run_into`): the GPU's stages for the run driver (`driver`,
//! which owns the loop, the checks and the roll-back): set-up (detection, upload) or resumption,
//! batches of cycles sized to the expected contact updates, stage 7 between them, the energy
//! sums on the device and its checkpoint, the state handed back. See "How a run goes" in the
//! module above.

use crate::driver;
use crate::udec::backend::{CycleError, CycleReport};
use crate::udec::cpu;
use crate::udec::model::Model;
use crate::udec::topology::Topology;
use rayon::prelude::*;

use super::kernels;
use super::layout::{self, Block, ContactPatch, Corner, Flags, Real};
use super::partial::PartialUpdate;
use super::{device_error, ContactIdentity, Engine, GpuError};

/// How many more cycles, at the velocities now, until the first block passes its contact-update
/// threshold (`Block::update_due`): the cycle that raises the flag, ⌊(threshold − moved)/s⌋ + 1 for
/// a block whose corners travel s a step. None when nothing moves.
pub(super) fn cycles_to_next_update(model: &Model) -> Option<u64> {
    model.blocks.iter().filter_map(|b| cycles_to_threshold(model, b)).min()
}

/// `cycles_to_next_update` for one block (None: fixed, or not moving).
pub(super) fn cycles_to_threshold(model: &Model, b: &crate::udec::model::Block) -> Option<u64> {
    if b.fixed {
        return None;
    }
    let s = b.travel_per_step(model.timestep);
    let room = (b.update_threshold(&model.tol) - b.moved_since_update).max(0.0);
    (s > 0.0 && s.is_finite()).then(|| (room / s).floor().min(1e9) as u64 + 1)
}

/// Refuses a model whose inputs the kernel precision cannot hold: in f32 a mass of 1e-300 kg
/// is zero and a load of 1e300 N infinite, so the first step would divide by zero or overflow and
/// stop as "non-finite" with no hint why. What a step divides by or scales with (masses,
/// moments of inertia, stiffnesses, the time step) must lie in f32's normal range; the rest
/// (loads, velocities, gravity, strengths) below its largest value, a tiny one being as good as
/// zero. f64 holds whatever the CPU holds.
pub(super) fn representable<R: Real>(model: &Model) -> Result<(), GpuError> {
    if R::WGSL != "f32" {
        return Ok(());
    }
    let (tiny, huge) = (f32::MIN_POSITIVE as f64, f32::MAX as f64);
    let normal = |x: f64| (tiny..=huge).contains(&x.abs());
    let bounded = |x: f64| x.abs() <= huge;
    let refuse = |what: String, x: f64| Err(f32_refusal(&what, x));
    for b in &model.blocks {
        let scales = [("mass", b.mass), ("moment of inertia", b.inertia)];
        let values = [
            ("x load", b.load[0]),
            ("y load", b.load[1]),
            ("x velocity", b.velocity[0]),
            ("y velocity", b.velocity[1]),
            ("angular velocity", b.angular_velocity),
        ];
        let bad = scales.into_iter().find(|&(_, x)| !normal(x)).or_else(|| values.into_iter().find(|&(_, x)| !bounded(x)));
        if let Some((name, x)) = bad {
            return refuse(format!("block {}'s {name}", b.id), x);
        }
    }
    // The materials in use: the blocks' and the edges' set by SPLIT (0: the block's).
    let mut used = [false; crate::udec::model::MAX_MATERIALS + 1];
    for m in model.blocks.iter().map(|b| b.material).chain(model.corners.iter().map(|c| c.edge_material)) {
        used[(m as usize).min(crate::udec::model::MAX_MATERIALS)] = true;
    }
    for m in (1..used.len()).filter(|&m| used[m]) {
        let mat = model.material(m as u32);
        let bad = [("KN", mat.contact.kn), ("KS", mat.contact.ks)]
            .into_iter()
            .find(|&(_, x)| !normal(x))
            .or_else(|| [("cohesion", mat.contact.cohesion), ("friction", mat.contact.friction)].into_iter().find(|&(_, x)| !bounded(x)));
        if let Some((name, x)) = bad {
            return refuse(format!("material {m}'s {name}"), x);
        }
        // The joint group (¶5), uploaded with the material whether or not a contact uses it.
        let joint = [("JKN", mat.joint.kn), ("JKS", mat.joint.ks), ("JCOH", mat.joint.cohesion), ("JFRIC", mat.joint.friction)];
        if let Some((name, x)) = joint.into_iter().find(|&(_, x)| !bounded(x)) {
            return refuse(format!("material {m}'s {name}"), x);
        }
        // The contact dashpots' coefficients, β·k (stiffness-proportional Rayleigh damping).
        let beta = model.damping.beta;
        if let Some((name, x)) = [("β·KN", beta * mat.contact.kn), ("β·KS", beta * mat.contact.ks)].into_iter().find(|&(_, x)| !bounded(x)) {
            return refuse(format!("material {m}'s stiffness damping {name} (DAMPING)"), x);
        }
    }
    if !normal(model.timestep) {
        return refuse("the time step".into(), model.timestep);
    }
    // The fluid (FLUID, PFIX and the flow laws): bulkw scales each pressure step, the rest
    // may not pass f32's largest value.
    if let Some(f) = &model.fluid {
        if !normal(f.bulk) {
            return refuse("the fluid's bulk modulus (FLUID)".into(), f.bulk);
        }
        if !bounded(f.density) {
            return refuse("the fluid's density (FLUID)".into(), f.density);
        }
        for m in (1..used.len()).filter(|&m| used[m]) {
            let fm = &model.material(m as u32).fluid;
            let laws = [("CPERM", fm.cperm), ("JPERM", fm.jperm), ("AZERO", fm.azero), ("ARES", fm.ares)];
            if let Some((name, x)) = laws.into_iter().find(|&(_, x)| !bounded(x)) {
                return refuse(format!("material {m}'s {name}"), x);
            }
        }
        if let Some(d) = model.domains.iter().flat_map(|d| &d.list).find(|d| !bounded(d.pressure)) {
            return refuse(format!("domain {}'s pressure (PFIX)", d.id), d.pressure);
        }
        // A_d(min), every domain's least area (SET DAMIN 1E300 was infinite on the device, and
        // so every area the device gave back).
        if let Some(d) = model.domains.as_ref().filter(|d| !bounded(d.min_area)) {
            return refuse("the domains' minimum area (SET DAMIN)".into(), d.min_area);
        }
        flows_representable::<R>(model)?;
    }
    // The law of motion scales the velocities by (1 − αΔt/2)/(1 + αΔt/2) (eqs. 9–10, UDEC's CON1/CON2).
    let (alpha, dt) = (model.damping.alpha, model.timestep);
    let scalars = [
        ("the gravity's x", model.gravity[0]),
        ("the gravity's y", model.gravity[1]),
        ("the mass damping α (DAMPING)", alpha),
        ("the mass damping α·Δt (DAMPING)", alpha * dt),
        ("the stiffness damping β (DAMPING)", model.damping.beta),
    ];
    match scalars.into_iter().find(|&(_, x)| !bounded(x)) {
        Some((name, x)) => refuse(name.to_string(), x),
        None => Ok(()),
    }
}

/// The refusal of a value the f32 kernels cannot hold (`representable`).
fn f32_refusal(what: &str, x: f64) -> GpuError {
    let (tiny, huge) = (f32::MIN_POSITIVE as f64, f32::MAX as f64);
    GpuError::DoesNotFit(format!(
        "{what} is {x:e}, outside the range of the f32 kernels ({tiny:.1e} to {huge:.1e}); run with --precision f64 or --backend cpu, or check the units"
    ))
}

/// The flows as the domains were last built (CPERM·Δp), which the f32 kernels must hold: the
/// device's first step starts from them, and its last good state holds them. Part of
/// `representable`, and taken again where a run's start has just rebuilt the domains (the rest
/// of the model is as the preflight saw it).
fn flows_representable<R: Real>(model: &Model) -> Result<(), GpuError> {
    if R::WGSL != "f32" {
        return Ok(());
    }
    let flows = model.domains.iter().flat_map(|d| d.flows.iter().enumerate());
    if let Some((k, f)) = flows.into_iter().find(|(_, f)| f.flow.abs() > f32::MAX as f64 || f.flow.is_nan()) {
        let id = |b: u32| model.blocks.get(b as usize).map_or(0, |b| b.id);
        let (b1, b2) = model.contacts.get(k).map_or((0, 0), |c| (id(c.block1), id(c.block2)));
        return Err(f32_refusal(&format!("the flow across the contact of blocks {b1} and {b2} (CPERM·Δp, PFIX)"), f.flow));
    }
    Ok(())
}

/// How the state came back for stage 7: `cracking`, the scene has point-load candidates (the
/// state is read whole every cycle); `packed`, contacts are read as summaries, for a splice;
/// `state_read`, the batch brought the state back with its flags (`run_batch_with_state`).
#[derive(Clone, Copy)]
struct Stage7Read {
    cracking: bool,
    packed: bool,
    state_read: bool,
}

impl<R: Real> Engine<R> {
    /// The CPU backend's error for the flags raised, from the read-back state (same priority as
    /// the CPU's checks within a cycle: non-finite, too fast, overlap).
    pub(super) fn error_from_flags(model: &Model, flags: &Flags) -> CycleError {
        let cycle = model.cycle;
        if flags.errors & layout::ERR_NONFINITE != 0 {
            // The `flow` kernel flags a non-finite pressure or flow by a block of its contact:
            // the read-back domains name it.
            if let Some(failure) = CycleError::non_finite_pressure(model) {
                return failure;
            }
            return CycleError::non_finite_step(model, flags.nonfinite_block as usize);
        }
        if flags.errors & layout::ERR_ZONE_INVERTED != 0 {
            return super::fdef::inverted_zone_error(model, flags.inverted_zone);
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
        CycleError::overlap(model, flags.overlap_contact as usize, 0.5 * model.tol.round)
    }

    /// Stage 7 between batches on the state read back (whole, or packed for a splice): the
    /// cracking check where the scene has point-load candidates (on every block's forces, read
    /// whole), then the contact update, and what it changed sent to the device (the splice of
    /// its edit, or the whole list). When the contacts were updated, `expected_update` takes the
    /// cycles until the next update is expected.
    fn stage7_on_read_back(
        &mut self,
        model: &mut Model,
        topology: &mut Topology,
        report: &mut CycleReport,
        read: Stage7Read,
        expected_update: &mut Option<u64>,
    ) -> Result<(), CycleError> {
        let Stage7Read { cracking, packed, state_read } = read;
        // Stage 7 on the CPU, on the read-back state: cracking, then contact updates. The cracking
        // criterion reads every block's forces, fixed ones too.
        if cracking {
            self.readback(model).map_err(device_error)?;
        } else if !state_read {
            self.read_live_state(model, packed).map_err(device_error)?;
        }
        // The model's state is read back only when the CPU needs it (here, the next stage 7, an
        // error, the end of the run): after a change the device holds it.
        if cracking && cpu::crack_step(model, &topology.lists, report) {
            *topology = Topology::build(model.blocks.len(), &model.contacts);
            if model.fluid.is_some() {
                crate::udec::topology::refresh_domains(model);
                cpu::fluid_timestep_cut(model, report)?;
            }
            if let Some(dt) = model.critical_timestep() {
                if dt < model.timestep {
                    model.timestep = dt;
                    report.timestep_changes.push((model.cycle, dt));
                }
            }
            self.upload_all(model, &topology.lists).map_err(device_error)?;
            self.list_in_order = false;
            self.write_params(model);
        }
        // After a packed read the update may go on only if the splice will follow it, which needs
        // the list in order (the whole upload would send stale fields): otherwise the contacts are
        // read whole first (the device has not moved since).
        let splice_follows = self.splices_on_device() && self.list_in_order;
        if packed && !splice_follows && cpu::topology_update_due(model) {
            self.read_live_state(model, false).map_err(device_error)?;
        }
        if cpu::maybe_update_topology(model, topology, report, false) {
            cpu::fluid_timestep_cut(model, report)?;
            self.list_in_order = true;
            *expected_update = cycles_to_next_update(model);
            self.upload_reset_distances(model);
            let edit = topology.take_edit().filter(|e| splice_follows && e.old_len as usize == self.counts.2);
            match edit {
                _ if model.contacts.is_empty() => self.upload_contacts(model, &topology.lists),
                Some(edit) => {
                    // Every kept contact was read: each is patched, and takes its bases from the
                    // model.
                    let mut created = edit.inserted_at.iter().peekable();
                    let patches: Vec<ContactPatch<R>> =
                        (0..model.contacts.len() as u32).filter(|&i| created.next_if_eq(&&i).is_none()).map(|i| ContactPatch::of(model, i)).collect();
                    self.edit_contact_list(model, &edit, None);
                    self.splice_contacts(model, &topology.lists, &edit, &patches)
                }
                None if packed && splice_follows => {
                    return Err(CycleError::Setup("GPU: the contact update sorted a list kept in order (a bug; run with BLOCKDEM_CONTACT_SPLICE=0)".into()))
                }
                None => self.upload_contacts(model, &topology.lists),
            }
            .map_err(device_error)?;
            self.write_params(model);
        }
        Ok(())
    }

    /// The last good state after a passed energy check: the device's copy of the state
    /// (`take_checkpoint`), and on the CPU the model it belongs to, re-taken only where the
    /// topology changed since `generation` (the contact list and blocks' generations): the
    /// contacts' identities when only the contacts changed, the whole model when blocks did.
    fn take_checkpoint_of(&mut self, model: &Model, last_good: &mut Model, generation: &mut (u64, u64)) {
        self.take_checkpoint();
        let now = (self.generation, self.block_generation);
        if *generation != now {
            let _p = crate::profile::scope(crate::profile::Stage::Checks);
            if generation.1 == now.1 {
                last_good.clone_settings_from(model);
                // The domains of the new list (the checkpoint holds their pressures).
                if model.fluid.is_some() {
                    last_good.domains.clone_from(&model.domains);
                    last_good.fluid = model.fluid;
                }
                let identities = self.last_good_contacts.get_or_insert_with(Vec::new);
                model.contacts.par_iter().map(ContactIdentity::of).collect_into_vec(identities);
            } else {
                last_good.clone_from(model);
                self.last_good_contacts = None;
            }
            *generation = now;
        }
        last_good.cycle = model.cycle;
        last_good.time = model.time;
        last_good.timestep = model.timestep;
    }

    /// A run through the run driver (`driver`), the GPU supplying its stages in batches
    /// (`GpuRun`).
    pub(super) fn run_into(
        &mut self,
        model: &mut Model,
        cycles: u64,
        progress: &mut dyn FnMut(u64) -> bool,
        report: &mut CycleReport,
    ) -> Result<(), CycleError> {
        let mut run = GpuRun {
            engine: self,
            topology: Topology::default(),
            batch_cap: driver::CHECK_INTERVAL,
            busy: false,
            expected_update: None,
            last_good_generation: (0, 0),
            point_load: None,
        };
        // Refused before the start (the time step, a model past the binding limit or the
        // precision's range), the backend is as it was; a start that failed (an upload) leaves
        // no contact lists to go on from.
        let resume = cpu::prepare_run(&mut run, model, report)?;
        let mut last_good = std::mem::take(&mut run.engine.last_good);
        let result = driver::cycles(&mut run, model, cycles, resume, &mut last_good, report, progress);
        let GpuRun { topology, .. } = run;
        // (On a failure the last good state went back into the model, and nothing is kept.)
        result?;
        self.last_good = last_good;
        self.topology = topology;
        self.resumable = true;
        Ok(())
    }
}

/// The GPU's stages of a run (`driver::Stages`): the engine, stage 7's lists, grid and edit while
/// the run holds them, and what the batches learn as they go.
struct GpuRun<'a, R: Real> {
    engine: &'a mut Engine<R>,
    topology: Topology,
    /// Cycles per submission: up to the next energy check, fewer while contact updates halt
    /// batches early. A halted batch still encodes and submits the dispatches of its remaining
    /// cycles (with zeroed grids: they launch nothing).
    batch_cap: u64,
    /// The last batch stopped for a contact update: the next one brings the state back with its
    /// flags (`run_batch_with_state`).
    busy: bool,
    /// Cycles until the next contact update is expected, from the velocities at the last one
    /// (`cycles_to_next_update`): a batch that would run past it is cut there, since the cycles
    /// after the halt are still encoded and submitted.
    expected_update: Option<u64>,
    /// The topology's generations when the last good state's CPU copy was taken
    /// (`take_checkpoint_of`).
    last_good_generation: (u64, u64),
    /// Whether the model has point-load cracking candidates (found at the first batch of the
    /// run; a crack's pieces inherit their parent's constitutive number, so they stay).
    point_load: Option<bool>,
}

impl<R: Real> GpuRun<'_, R> {
    /// Whether any block of `model` is a point-load cracking candidate (`point_load`).
    fn point_load_candidates(&mut self, model: &Model) -> bool {
        *self.point_load.get_or_insert_with(|| (0..model.blocks.len()).any(|b| crate::udec::topology::cracking::is_point_load_candidate(model, b)))
    }
}

impl<R: Real> driver::Start<Model> for GpuRun<'_, R> {
    fn take_resumable(&mut self) -> Option<&Model> {
        let e = &mut *self.engine;
        (std::mem::take(&mut e.resumable) && e.buffers.is_some()).then_some(&e.last_good)
    }

    /// A model whose blocks or corners alone are past the adapter's binding limit is refused
    /// now, not after the full detection (seconds at 10⁶ blocks); so is one with values the
    /// kernel precision cannot hold (`representable`).
    fn preflight(&mut self, model: &Model) -> Result<(), CycleError> {
        let e = &self.engine;
        let cap = kernels::binding_cap(&e.dev);
        let sdef_blocks = if model.has_sdef() { model.blocks.len() } else { 0 };
        kernels::check_fits("blocks", std::mem::size_of::<Block<R>>(), model.blocks.len(), cap, e.dev.precision)
            .and_then(|()| kernels::check_fits("corners", std::mem::size_of::<Corner<R>>(), model.corners.len(), cap, e.dev.precision))
            .and_then(|()| super::sdef::check_fits::<R>(cap, sdef_blocks, e.dev.precision))
            .and_then(|()| super::fdef::check_fits::<R>(model, cap, e.dev.precision))
            .map_err(device_error)?;
        representable::<R>(model).map_err(device_error)
    }

    /// As on the CPU: a full detection first (the executor may have changed the model), then
    /// the upload, read back so that the model holds what the device holds (its reals, the force
    /// sums); when resuming, the device still holds the state the last run left, with its
    /// contacts and the f32 digits the model does not keep. (The first cycle sums the forces it
    /// moves by itself, as every cycle does: nothing else is summed after an upload or an
    /// update.) The device checkpoint of an earlier run is no longer this run's.
    fn start(&mut self, model: &mut Model, resume: bool, report: &mut CycleReport) -> Result<(), CycleError> {
        // The contact lists are the run's from here on.
        self.topology = std::mem::take(&mut self.engine.topology);
        let e = &mut *self.engine;
        if resume {
            // The domains as the model holds them now (PFIX and PFREE may have changed them
            // between runs; the model's equality leaves them out), their loads, the accounts'
            // bases.
            if (e.fluid_scene || model.fluid.is_some()) && e.upload_fluid(model).map_err(device_error)? {
                e.bind_groups = Some(kernels::CycleBindGroups::new(&e.dev, &e.pipelines, e.buffers()));
            }
            e.write_params(model);
        } else {
            // With fluid: the domains of the lists detected and the time step they allow (their
            // loads go up with them), or those of a state a run left (`cpu::start_detection`).
            if !cpu::start_detection(model, &mut self.topology, report) && model.fluid.is_some() {
                crate::udec::topology::refresh_domains(model);
                cpu::fluid_timestep_cut(model, report)?;
                // The flows of the domains just built, which the preflight did not see.
                flows_representable::<R>(model).map_err(device_error)?;
            }
            cpu::mark_as_run_left(model);
            e.list_in_order = true;
            e.upload_all(model, &self.topology.lists).map_err(device_error)?;
            e.write_params(model);
            e.readback(model).map_err(device_error)?;
        }
        // The last good state: the driver's CPU copy holds its topology (and, until the first
        // device checkpoint, its state); after a passed energy check the state is on the device
        // (`take_checkpoint`) and the copy is re-taken only when the topology changed since.
        if let Some(ck) = &mut e.checkpoint {
            ck.valid = false;
        }
        e.last_good_contacts = None;
        Ok(())
    }
}

impl<R: Real> driver::Stages<Model> for GpuRun<'_, R> {
    fn begin_cycles(&mut self, _model: &mut Model) -> Result<(), CycleError> {
        self.last_good_generation = (self.engine.generation, self.engine.block_generation);
        self.point_load = None;
        Ok(())
    }

    /// One batch of cycles on the device (one at a time with cracking, whose check reads every
    /// cycle's state), then stage 7 on what the flags ask for.
    fn advance(&mut self, model: &mut Model, max: u64, cracking: bool, report: &mut CycleReport) -> Result<u64, CycleError> {
        // The point-load criterion reads every block's contact forces each cycle: such a scene
        // runs one cycle a batch, the state read whole. Griffith's criterion is tested on the
        // device (`law_of_motion_sdef` raises `crack_due`), so a scene with Griffith candidates
        // alone runs in batches and reads the state when a block reaches its strength.
        let cracking = cracking && self.point_load_candidates(model);
        // Read-backs for a contact update bring the contacts' summaries only (`pack_contacts`),
        // since the splice keeps the rest on the device; cracking reads everything.
        let packed = self.engine.splices_on_device() && !cracking;
        let mut batch = if cracking { 1 } else { max.min(self.batch_cap) };
        if let Some(k) = self.expected_update {
            batch = batch.min(k.max(1));
        }
        let e = &mut *self.engine;
        e.write_params(model);
        let partial_reads = e.splices_on_device() && !cracking && e.partial_reads_pay();
        let (flags, state_read) = if self.busy && !cracking && !partial_reads {
            e.run_batch_with_state(batch, model, packed).map_err(device_error)?
        } else {
            (e.run_batch(batch, false).map_err(device_error)?, false)
        };
        self.busy = flags.update_due != 0;
        let done = flags.cycles_done as u64;
        self.batch_cap = if done < batch { (2 * done).max(1) } else { (2 * self.batch_cap).min(driver::CHECK_INTERVAL) };
        for _ in 0..done {
            model.time += model.timestep;
        }
        model.cycle += done;
        self.expected_update = self.expected_update.map(|k| k.saturating_sub(done)).filter(|&k| k > 0);
        if flags.errors != 0 {
            e.readback(model).map_err(device_error)?;
            return Err(Engine::<R>::error_from_flags(model, &flags));
        }
        if done == 0 {
            return Err(CycleError::Setup("GPU: a batch ran no cycle".into()));
        }
        let mut handled = false;
        if partial_reads && flags.update_due != 0 {
            // Stage 7 on what it touches (`partial_contact_update`), unless it needs the whole
            // state.
            match e.partial_contact_update(model, &mut self.topology, report).map_err(device_error)? {
                PartialUpdate::Declined => {}
                PartialUpdate::NotDue => handled = true,
                PartialUpdate::Updated(expected) => {
                    e.list_in_order = true;
                    self.expected_update = expected;
                    handled = true;
                }
            }
        }
        // A Griffith crack is due: the cracking stage on the whole state read back.
        let cracking = cracking || flags.crack_due != 0;
        if !handled && (cracking || flags.update_due != 0) {
            let read = Stage7Read { cracking, packed, state_read };
            e.stage7_on_read_back(model, &mut self.topology, report, read, &mut self.expected_update)?;
        }
        Ok(done)
    }

    /// The energy check's sums on the device; the state stays there.
    fn energy(&mut self, _model: &mut Model) -> Result<(f64, f64), CycleError> {
        let _p = crate::profile::scope(crate::profile::Stage::Checks);
        let (kinetic, strain, external_work) = self.engine.energy_sums().map_err(device_error)?;
        Ok((kinetic + strain, external_work))
    }

    fn sync(&mut self, model: &mut Model) -> Result<(), CycleError> {
        self.engine.readback(model).map_err(device_error)
    }

    fn keep(&mut self, model: &Model, last_good: &mut Model) {
        self.engine.take_checkpoint_of(model, last_good, &mut self.last_good_generation);
    }

    /// The run's end: the state comes back to the model, which becomes the last good state. No
    /// device checkpoint or CPU copy of the topology is taken for it (the next run starts by
    /// invalidating the one, the other would be a copy of a copy); if the read-back fails, the
    /// checkpoint before, with its topology, is what is restored.
    fn finish(&mut self, model: &mut Model) -> Result<(), CycleError> {
        self.engine.readback(model).map_err(device_error)?;
        self.engine.last_good_contacts = None;
        Ok(())
    }

    fn recover(&mut self, last_good: &mut Model) -> Result<(), CycleError> {
        self.engine.restore_checkpoint(last_good).map_err(device_error)
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
