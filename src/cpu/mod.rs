//! The CPU backend: the explicit cycle in f64, the accuracy reference (DESIGN.md §1–3).
//!
//! Each stage lives in its own file, named like its WGSL kernel twin:
//! `law_of_motion`, `geometry_update`, `contact_forces`, `gather`.

pub mod contact_forces;
pub mod gather;
pub mod geometry_update;
pub mod law_of_motion;

use crate::backend::{Backend, CrackEvent, CycleError, CycleReport};
use crate::model::{Corner, Model};
use rayon::prelude::*;
use crate::topology::{self, Adjacency};

use contact_forces::{contact_force_law, track_feature, BlockMotion};

/// Smallest number of blocks or contacts one parallel task takes: below it a stage runs on one
/// thread, so small scenes pay no scheduling.
const PARALLEL_CHUNK: usize = 512;

/// Cycles between energy checks and checkpoints of the last good state.
pub(crate) const CHECK_INTERVAL: u64 = 100;

/// Energy may exceed what was put in by this factor (plus a floor) before the run is declared
/// unstable: an unstable explicit scheme grows exponentially, far past any such margin, while a
/// stable one stays within O(Δt) of its budget.
const ENERGY_GROWTH_FACTOR: f64 = 2.0;

#[derive(Default)]
pub struct CpuBackend {
    /// Per-block contact lists, rebuilt after every topology change.
    adjacency: Adjacency,
}

impl CpuBackend {
    pub fn new() -> Self {
        Self::default()
    }
}

/// Runs stage 7 when a block has moved past the update tolerance; returns whether it did.
pub(crate) fn maybe_update_topology(model: &mut Model, adjacency: &mut Adjacency, report: &mut CycleReport, force: bool) -> bool {
    let etol = model.tol.etol;
    if !force && !model.blocks.iter().any(|b| !b.fixed && b.moved_since_update > etol) {
        return false;
    }
    let _p = crate::profile::scope(if force { crate::profile::Stage::DetectFull } else { crate::profile::Stage::DetectUpdate });
    // Also keeps the adjacency lists, and moves the energy terms of contacts dropped while
    // loaded to the ledger's retired account.
    let (created, dropped) = topology::update_topology(model, force, adjacency);
    report.topology_updates += 1;
    report.contacts_created += created as u64;
    report.contacts_dropped += dropped as u64;
    true
}

/// Stages 4 and 6 for the whole model: contact kinematics and forces, then the gather.
/// Returns the first overlap beyond the limit, if any.
fn contacts_and_gather(model: &mut Model, adjacency: &Adjacency, dt: f64) -> Result<(), CycleError> {
    let _p = crate::profile::scope(crate::profile::Stage::ContactForces);
    let limit = 0.5 * model.tol.round;
    let damping = model.damping;
    let failure: Option<(usize, f64)>;
    {
        let Model { blocks, corners, contacts, materials, .. } = &mut *model;
        let motion = |b: &crate::model::Block| BlockMotion { centroid: b.centroid, velocity: b.velocity, angular_velocity: b.angular_velocity };
        // The first contact (lowest index, so the report repeats) whose overlap passes the limit.
        failure = contacts.par_iter_mut().enumerate().with_min_len(PARALLEL_CHUNK).filter_map(|(k, contact)| {
            let corner = &corners[contact.corner as usize];
            let (b1, b2) = (&blocks[contact.block1 as usize], &blocks[contact.block2 as usize]);
            let range2 = b2.corner_start as usize..(b2.corner_start + b2.corner_count) as usize;
            let g = track_feature(&corners[range2.clone()], contact.feature, corner.circle, corner.radius);
            contact.feature = g.feature;
            contact.kind = g.kind;
            contact.gap = g.gap;
            contact.normal = g.normal;
            contact.point = g.point;
            // The other view of a corner-pair touch carries no force (the touch counts once).
            let active = contact_forces::counts_force(contact.corner, corner, &corners[range2.clone()], b2.corner_start, g.feature);
            let mat = &materials[(contact.material.max(1) as usize - 1).min(materials.len() - 1)];
            contact_force_law(contact, mat, &motion(b1), &motion(b2), &damping, dt, active);
            (active && -g.gap > limit).then_some((k, -g.gap))
        }).min_by_key(|&(k, _)| k);
    }
    gather_all(model, adjacency);
    match failure {
        None => Ok(()),
        Some((k, overlap)) => {
            let c = &model.contacts[k];
            Err(CycleError::Overlap {
                cycle: model.cycle,
                block1: model.blocks[c.block1 as usize].id,
                block2: model.blocks[c.block2 as usize].id,
                overlap,
                limit,
                x: c.point[0],
                y: c.point[1],
            })
        }
    }
}

fn gather_all(model: &mut Model, adjacency: &Adjacency) {
    let _p = crate::profile::scope(crate::profile::Stage::Gather);
    let gravity = model.gravity;
    let Model { blocks, contacts, .. } = model;
    blocks.par_iter_mut().enumerate().with_min_len(PARALLEL_CHUNK).for_each(|(b, block)| gather::gather(b, block, contacts, adjacency, gravity));
}

/// One cycle of stages 1, 2, 4, 6 (the scene has no zones or fluid yet).
fn cycle_once(model: &mut Model, adjacency: &Adjacency) -> Result<(), CycleError> {
    let dt = model.timestep;
    let (gravity, alpha) = (model.gravity, model.damping.alpha);
    // Stage 1: law of motion. Stage 2: geometry update. One block per task: its corners are its
    // own contiguous slice, so the blocks run in parallel and each result is what a serial loop
    // would give; the sums below are taken serially, so runs repeat bit for bit.
    let steps: Vec<law_of_motion::StepOutcome> = {
        let _p = crate::profile::scope(crate::profile::Stage::MotionGeometry);
        let Model { blocks, corners, .. } = &mut *model;
        let mut slices = Vec::with_capacity(blocks.len());
        let mut rest: &mut [Corner] = corners;
        for block in blocks.iter() {
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut(block.corner_count as usize);
            slices.push(mine);
            rest = tail;
        }
        blocks
            .par_iter_mut()
            .zip(slices.into_par_iter())
            .with_min_len(PARALLEL_CHUNK)
            .map(|(block, corners)| {
                let step = law_of_motion::law_of_motion(block, gravity, alpha, dt);
                geometry_update::geometry_update(block, corners);
                step
            })
            .collect()
    };
    let mut work = 0.0;
    let mut fastest = (0.0f64, 0usize);
    for (b, step) in steps.iter().enumerate() {
        work += step.external_work;
        if step.corner_travel > fastest.0 {
            fastest = (step.corner_travel, b);
        }
    }
    model.external_work += work;
    model.cycle += 1;
    model.time += dt;
    if !work.is_finite() {
        let block = model
            .blocks
            .iter()
            .find(|b| !(b.centroid[0].is_finite() && b.centroid[1].is_finite() && b.velocity[0].is_finite() && b.velocity[1].is_finite() && b.angular_velocity.is_finite()))
            .map_or(0, |b| b.id);
        return Err(CycleError::NonFinite { cycle: model.cycle, block, what: "a non-finite position or velocity".into() });
    }
    // Between contact updates a block's corners move at most etol plus one step's travel s, so two
    // blocks approach by at most 2(etol + s); that must stay below atol for no touch to be missed.
    // A faster block could cross a thin neighbour unseen: stop rather than let it tunnel.
    let limit = 0.5 * model.tol.atol - model.tol.etol;
    if fastest.0 > limit {
        let b = &model.blocks[fastest.1];
        return Err(CycleError::TooFast { cycle: model.cycle, block: b.id, travel: fastest.0, limit, speed: fastest.0 / dt });
    }
    // Stages 4 and 6.
    contacts_and_gather(model, adjacency, dt)
}

/// The energy check: kinetic + strain energy may not outgrow the energy put in. The budget is the
/// largest seen so far (`peak`): in a stable run that rings (a block dropped onto its contacts)
/// the budget falls to ~0 at each rebound apex while the half-step kinetic energy and the
/// shadow-energy error of central differences do not, which is no instability; an unstable run
/// grows exponentially past any such margin. Both backends use it between batches of cycles.
pub(crate) struct EnergyCheck {
    baseline: f64,
    scale: f64,
    peak: f64,
}

impl EnergyCheck {
    /// Taken at the start of a CYCLE run, once contacts are detected and their gaps known.
    pub(crate) fn new(model: &Model) -> Self {
        let e0 = model.energies();
        // Contacts that start overlapping (blocks built into each other, the stage not yet run)
        // hold strain energy the first force computation will release: it is energy put in.
        let overlap_strain: f64 = model.contacts.iter().map(|c| 0.5 * model.material(c.material).kn * c.gap.min(0.0).powi(2)).sum();
        let baseline = e0.kinetic + e0.strain.max(overlap_strain) - e0.external_work;
        // Energy scale for the floor of the growth test: potential energy of each block's weight
        // and load over its own size.
        let g = (model.gravity[0].powi(2) + model.gravity[1].powi(2)).sqrt();
        let scale = model.blocks.iter().map(|b| (b.mass * g + b.load[0].hypot(b.load[1])) * b.radius).sum::<f64>() + (e0.kinetic + e0.strain).abs();
        EnergyCheck { baseline, scale, peak: f64::NEG_INFINITY }
    }

    /// After a failure: names the cause (a block flying off may be the symptom of an unstable
    /// step) and puts the last good state back in `model`.
    pub(crate) fn roll_back(&mut self, mut e: CycleError, model: &mut Model, last_good: Model) -> CycleError {
        if let CycleError::TooFast { .. } = e {
            if let Err(energy) = self.check(model) {
                e = energy;
            }
        }
        // The stable-FRAC estimate needs the contact network of the last good state (the
        // diverged one may have flung its blocks apart).
        if let CycleError::EnergyGrowth { safe_frac, .. } = &mut e {
            *safe_frac = last_good.stable_frac_estimate();
        }
        *model = last_good;
        e
    }

    pub(crate) fn check(&mut self, model: &Model) -> Result<(), CycleError> {
        let e = model.energies();
        self.check_sums(model.cycle, e.kinetic + e.strain, e.external_work, model.frac)
    }

    /// The check on sums taken elsewhere (the GPU's `energy_sums`): kinetic + strain energy
    /// against the external work done since the start. The largest safe FRAC in the error is
    /// filled in by `roll_back`, from the last good state's contact network.
    pub(crate) fn check_sums(&mut self, cycle: u64, energy: f64, external_work: f64, frac: f64) -> Result<(), CycleError> {
        self.peak = self.peak.max(self.baseline + external_work);
        let budget = self.peak;
        if !energy.is_finite() || energy > ENERGY_GROWTH_FACTOR * budget.max(0.0) + 1e-6 * self.scale {
            return Err(CycleError::EnergyGrowth { cycle, energy, budget, frac, safe_frac: f64::NAN });
        }
        Ok(())
    }
}

impl Backend for CpuBackend {
    fn describe(&self) -> String {
        "cpu (f64)".to_string()
    }

    fn run(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64)) -> Result<CycleReport, CycleError> {
        if model.timestep <= 0.0 || !model.timestep.is_finite() {
            return Err(CycleError::Setup("the time step is not set".into()));
        }
        let mut report = CycleReport::default();
        let mut adjacency = std::mem::take(&mut self.adjacency);
        // Between runs the executor may have split, deleted or moved blocks: start with a full
        // detection, then the force sums the first step needs.
        maybe_update_topology(model, &mut adjacency, &mut report, true);
        gather_all(model, &adjacency);
        crate::profile::mark_cycles_start();
        let mut energy_check = EnergyCheck::new(model);
        let cracking = (0..model.blocks.len()).any(|b| topology::cracking::is_point_load_candidate(model, b));
        let mut last_good = model.clone();
        let mut result = Ok(());
        for i in 0..cycles {
            if let Err(e) = cycle_once(model, &adjacency) {
                result = Err(e);
                break;
            }
            // Stage 7: cracking, then contact updates.
            let mut changed = false;
            if cracking {
                changed |= crack_step(model, &adjacency, &mut report);
            }
            if changed {
                adjacency = Adjacency::build(model.blocks.len(), &model.contacts);
                gather_all(model, &adjacency);
                if let Some(dt) = model.critical_timestep() {
                    if dt < model.timestep {
                        model.timestep = dt;
                        report.timestep_changes.push((model.cycle, dt));
                    }
                }
            }
            if maybe_update_topology(model, &mut adjacency, &mut report, false) {
                gather_all(model, &adjacency);
            }
            report.cycles += 1;
            if (i + 1) % CHECK_INTERVAL == 0 || i + 1 == cycles {
                let _p = crate::profile::scope(crate::profile::Stage::Checks);
                if let Err(e) = energy_check.check(model) {
                    result = Err(e);
                    break;
                }
                last_good.clone_from(model);
                progress(i + 1);
            }
        }
        match result {
            Ok(()) => {
                self.adjacency = adjacency;
                Ok(report)
            }
            Err(e) => Err(energy_check.roll_back(e, model, last_good)),
        }
    }
}

/// Checks every cracking candidate once and applies the cracks found. Returns whether any block
/// cracked.
pub(crate) fn crack_step(model: &mut Model, adjacency: &Adjacency, report: &mut CycleReport) -> bool {
    let _p = crate::profile::scope(crate::profile::Stage::Cracking);
    let mut found = Vec::new();
    for b in 0..model.blocks.len() {
        if topology::cracking::is_point_load_candidate(model, b) {
            if let Some(c) = topology::find_point_load_crack(model, adjacency, b) {
                found.push((model.blocks[b].id, c));
            }
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
            report.cracks.push(CrackEvent { cycle: model.cycle, block: id, new_block: before, value: crack.value, from: crack.from, to: crack.to });
        }
    }
    changed
}
