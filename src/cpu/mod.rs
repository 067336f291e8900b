//! The CPU backend: the explicit cycle in f64, the accuracy reference (DESIGN.md §1–3).
//!
//! Each stage lives in its own file, named like its WGSL kernel twin:
//! `law_of_motion`, `geometry_update`, `contact_forces`, `gather`.

pub mod contact_forces;
pub mod gather;
pub mod geometry_update;
pub mod law_of_motion;

use crate::backend::{Backend, CrackEvent, CycleError, CycleReport};
use crate::model::Model;
use crate::topology::{self, Adjacency};

use contact_forces::{contact_force_law, track_feature, BlockMotion};

/// Cycles between energy checks and checkpoints of the last good state.
const CHECK_INTERVAL: u64 = 100;

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
fn maybe_update_topology(model: &mut Model, adjacency: &mut Adjacency, report: &mut CycleReport, force: bool) -> bool {
    let etol = model.tol.etol;
    if !force && !model.blocks.iter().any(|b| !b.fixed && b.moved_since_update > etol) {
        return false;
    }
    let (created, dropped) = topology::update_contacts(model, force);
    report.topology_updates += 1;
    report.contacts_created += created as u64;
    report.contacts_dropped += dropped as u64;
    *adjacency = Adjacency::build(model.blocks.len(), &model.contacts);
    true
}

/// Stages 4 and 6 for the whole model: contact kinematics and forces, then the gather.
/// Returns the first overlap beyond the limit, if any.
fn contacts_and_gather(model: &mut Model, adjacency: &Adjacency, dt: f64) -> Result<(), CycleError> {
    let limit = 0.5 * model.tol.round;
    let damping = model.damping;
    let mut failure = None;
    for k in 0..model.contacts.len() {
        let c = model.contacts[k];
        let corner = model.corners[c.corner as usize];
        let g = track_feature(model.block_corners(c.block2 as usize), c.feature, corner.circle, corner.radius);
        let (b1, b2) = (&model.blocks[c.block1 as usize], &model.blocks[c.block2 as usize]);
        let motion = |b: &crate::model::Block| BlockMotion { centroid: b.centroid, velocity: b.velocity, angular_velocity: b.angular_velocity };
        let (m1, m2) = (motion(b1), motion(b2));
        let mat = *model.material(c.material);
        let contact = &mut model.contacts[k];
        contact.feature = g.feature;
        contact.kind = g.kind;
        contact.gap = g.gap;
        contact.normal = g.normal;
        contact.point = g.point;
        let active = topology::detect::counts_force(model, &model.contacts[k]);
        let contact = &mut model.contacts[k];
        contact_force_law(contact, &mat, &m1, &m2, &damping, dt, active);
        if active && -g.gap > limit && failure.is_none() {
            failure = Some(CycleError::Overlap {
                cycle: model.cycle,
                block1: model.blocks[c.block1 as usize].id,
                block2: model.blocks[c.block2 as usize].id,
                overlap: -g.gap,
                limit,
                x: g.point[0],
                y: g.point[1],
            });
        }
    }
    gather_all(model, adjacency);
    failure.map_or(Ok(()), Err)
}

fn gather_all(model: &mut Model, adjacency: &Adjacency) {
    let gravity = model.gravity;
    let Model { blocks, contacts, .. } = model;
    for (b, block) in blocks.iter_mut().enumerate() {
        gather::gather(b, block, contacts, adjacency, gravity);
    }
}

/// One cycle of stages 1, 2, 4, 6 (the scene has no zones or fluid yet).
fn cycle_once(model: &mut Model, adjacency: &Adjacency) -> Result<(), CycleError> {
    let dt = model.timestep;
    let (gravity, alpha) = (model.gravity, model.damping.alpha);
    let mut work = 0.0;
    let mut fastest = (0.0f64, 0usize);
    // Stage 1: law of motion. Stage 2: geometry update.
    {
        let Model { blocks, corners, .. } = &mut *model;
        for (b, block) in blocks.iter_mut().enumerate() {
            let step = law_of_motion::law_of_motion(block, gravity, alpha, dt);
            work += step.external_work;
            if step.corner_travel > fastest.0 {
                fastest = (step.corner_travel, b);
            }
            let range = block.corner_start as usize..(block.corner_start + block.corner_count) as usize;
            geometry_update::geometry_update(block, &mut corners[range]);
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

/// The energy check: kinetic + strain energy may not outgrow the energy put in.
fn check_energy(model: &Model, baseline: f64, scale: f64) -> Result<(), CycleError> {
    let e = model.energies();
    let energy = e.kinetic + e.strain;
    let budget = baseline + e.external_work;
    if !energy.is_finite() || energy > ENERGY_GROWTH_FACTOR * budget.max(0.0) + 1e-6 * scale {
        return Err(CycleError::EnergyGrowth { cycle: model.cycle, energy, budget, frac: model.frac, safe_frac: model.stable_frac_estimate() });
    }
    Ok(())
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
        let e0 = model.energies();
        let baseline = e0.kinetic + e0.strain - e0.external_work;
        // Energy scale for the floor of the growth test: potential energy of each block's weight
        // and load over its own size.
        let g = (model.gravity[0].powi(2) + model.gravity[1].powi(2)).sqrt();
        let scale = model.blocks.iter().map(|b| (b.mass * g + b.load[0].hypot(b.load[1])) * b.radius).sum::<f64>() + (e0.kinetic + e0.strain).abs();
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
                if let Err(e) = check_energy(model, baseline, scale) {
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
            Err(mut e) => {
                // A block flying off may be the symptom of an unstable step: name the cause.
                if let CycleError::TooFast { .. } = e {
                    if let Err(energy) = check_energy(model, baseline, scale) {
                        e = energy;
                    }
                }
                // The stable-FRAC estimate needs the contact network of the last good state (the
                // diverged one may have flung its blocks apart).
                if let CycleError::EnergyGrowth { safe_frac, .. } = &mut e {
                    *safe_frac = last_good.stable_frac_estimate();
                }
                *model = last_good;
                Err(e)
            }
        }
    }
}

/// Checks every cracking candidate once and applies the cracks found. Returns whether any block
/// cracked.
fn crack_step(model: &mut Model, adjacency: &Adjacency, report: &mut CycleReport) -> bool {
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
        if topology::apply_crack(model, &crack).is_some() {
            changed = true;
            report.cracks.push(CrackEvent { cycle: model.cycle, block: id, new_block: before, value: crack.value, from: crack.from, to: crack.to });
        }
    }
    changed
}
