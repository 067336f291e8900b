//! D3's cycle on the CPU, in f64 (the reference), through the chassis's run driver.
//!
//! One cycle, in the order of DESIGN.md §1 (stage 6 of a cycle runs at the start of the next one's
//! block pass, as in 2D):
//!
//! 6. gather: each block's force and moment, gravity and load plus its contacts' forces summed in
//!    the contacts' order (eq. 12 for the moments; each contact's sums worked out in parallel,
//!    the order of the additions fixed, so reruns repeat bit for bit);
//! 1. law of motion and 2. geometry update (`d3::motion`);
//! 7. the neighbour lists, when a block has moved past the contact-forming distance
//!    (`d3::topology`);
//! 4. each block's bodies placed for their contacts (`contact::Placement`: plane normals, edge
//!    directions, box, inner ball), then each contact's common plane, logical contacts and
//!    force–displacement law (`d3::contact`), in parallel over the contacts, each worker thread
//!    with its working lists (`contact::Scratch`).

use glam::DVec3;
use rayon::prelude::*;

use super::contact::{self, spring_energy, Appearing};
use super::cracking;
use super::grain;
use super::model::{Contact, Logical, Model};
use super::motion;
use super::sdef;
use super::topology;
use crate::driver::{self, CycleError, CycleReport, Position};

impl driver::RunModel for Model {
    fn cycle(&self) -> u64 {
        self.cycle
    }

    fn timestep(&self) -> f64 {
        Model::timestep(self)
    }

    fn frac(&self) -> f64 {
        self.frac
    }

    fn energy_terms(&self) -> (f64, f64) {
        let e = self.energies();
        (e.kinetic + e.strain, e.external_work)
    }

    fn energy_baseline(&self) -> (f64, f64) {
        let e = self.energies();
        let baseline = e.kinetic + e.strain - e.external_work;
        // The floor's scale: each block's weight and load over its own size, and the strain of
        // its contacts at an overlap of 1e-3 of its size (as in 2D).
        let g = self.gravity.length();
        let kn = self.materials.iter().map(|m| m.kn).fold(0.0, f64::max);
        let scale = self.blocks.iter().map(|b| (b.mass * g + b.load.length()) * b.shape.radius + kn * (1e-3 * b.shape.radius).powi(2)).sum::<f64>()
            + (e.kinetic + e.strain).abs();
        (baseline, scale)
    }

    fn stable_frac_estimate(&self) -> f64 {
        f64::NAN
    }

    fn has_crack_candidates(&self) -> bool {
        (0..self.blocks.len()).any(|b| cracking::is_candidate(self, b))
    }
}

/// The CPU backend for D3: it keeps the state its last run left, to resume from.
#[derive(Default)]
pub struct CpuBackend {
    last_good: Model,
    resumable: bool,
}

impl CpuBackend {
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether the backend would go on from `model` as the state its last run left (SAVE
    /// records it, `d3::restart`).
    pub fn resumes_from(&self, model: &Model) -> bool {
        self.resumable && self.last_good == *model
    }

    /// Takes `model` as the state its last run left (RESTART of a state saved as resumable), so
    /// that the next run goes on from it as the saving run would have.
    pub fn resume_from(&mut self, model: &Model) {
        self.last_good.clone_from(model);
        self.resumable = true;
    }

    /// Runs `cycles` cycles of `model` through the run driver (`progress` is told the cycles done
    /// at each check and may end the run there: false), what the run does added to `report` (on
    /// error: up to the last good state, which the model is left at). `Backend::run` returns it.
    pub fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        let resume = driver::prepare(self, model, report)?;
        let mut kept = std::mem::take(&mut self.last_good);
        let result = driver::cycles(&mut Stages, model, cycles, resume, &mut kept, report, progress);
        self.last_good = kept;
        result?;
        self.resumable = cycles > 0;
        Ok(())
    }
}

impl super::backend::Backend for CpuBackend {
    fn run_into(&mut self, model: &mut Model, cycles: u64, progress: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        CpuBackend::run_into(self, model, cycles, progress, report)
    }

    fn resumes_from(&self, model: &Model) -> bool {
        CpuBackend::resumes_from(self, model)
    }

    fn resume_from(&mut self, model: &Model, _device: Option<&super::restart::DeviceState>) {
        // The model is the CPU's whole state; a GPU's device state is not the CPU's to take.
        CpuBackend::resume_from(self, model)
    }

    fn forget(&mut self) {
        *self = CpuBackend::new();
    }

    fn describe(&self) -> String {
        "cpu (f64)".into()
    }
}

/// The preconditions of a D3 run on any backend: each block convex or made of convex parts
/// (`d3::decompose`), and a mass for every free one.
pub fn preflight(model: &Model) -> Result<(), CycleError> {
    if let Some(b) = model.blocks.iter().find(|b| !b.shape.convex && b.parts.is_empty()) {
        return Err(CycleError::Setup(format!(
            "block {} is not convex and has no convex parts; contact detection in D3 handles convex bodies (build a concave block from convex ones)",
            b.id
        )));
    }
    if let Some(b) = model.blocks.iter().find(|b| !b.fixed && (b.mass.is_nan() || b.mass <= 0.0)) {
        return Err(CycleError::Setup(format!("block {} has no mass: give its material (MATERIAL {}) a DENSITY", b.id, b.material)));
    }
    Ok(())
}

/// A contact driven through: a logical contact's overlap past half the smaller block's radius
/// (checked after each stage 4).
pub fn overlap_check(model: &Model) -> Result<(), CycleError> {
    // The first contact driven through, in the contacts' order (searched in parallel).
    let found = model.contacts.par_iter().enumerate().with_min_len(grain::CHECK).find_map_first(|(k, c)| driven_through(&model.blocks, c).map(|_| k));
    match found {
        Some(k) => Err(overlap_error(model, k)),
        None => Ok(()),
    }
}

/// [`overlap_check`] of the `selected` contacts only (their indices, ascending): the GPU's
/// partial detection's, whose other contacts are as the device's last check found them.
pub fn overlap_check_of(model: &Model, selected: &[usize]) -> Result<(), CycleError> {
    match selected.iter().copied().find(|&k| driven_through(&model.blocks, &model.contacts[k]).is_some()) {
        Some(k) => Err(overlap_error(model, k)),
        None => Ok(()),
    }
}

/// The deepest logical contact of contact `c` where its overlap is past half the smaller of its
/// blocks' radii (that limit): the logical contact, its overlap and the limit.
fn driven_through<'c>(blocks: &[super::model::Block], c: &'c Contact) -> Option<(&'c Logical, f64, f64)> {
    let (l, overlap) = c.logical.iter().map(|l| (l, -l.gap)).max_by(|x, y| x.1.total_cmp(&y.1))?;
    let limit = 0.5 * blocks[c.blocks[0] as usize].shape.radius.min(blocks[c.blocks[1] as usize].shape.radius);
    (overlap > limit).then_some((l, overlap, limit))
}

/// The failure of contact `k`, driven through ([`driven_through`]).
fn overlap_error(model: &Model, k: usize) -> CycleError {
    let c = &model.contacts[k];
    let (l, overlap, limit) = driven_through(&model.blocks, c).expect("a contact driven through");
    CycleError::Overlap {
        cycle: model.cycle,
        block1: model.blocks[c.blocks[0] as usize].id,
        block2: model.blocks[c.blocks[1] as usize].id,
        overlap,
        limit,
        at: Box::new(Position::xyz(l.point.to_array())),
    }
}

impl driver::Start<Model> for CpuBackend {
    fn take_resumable(&mut self) -> Option<&Model> {
        std::mem::take(&mut self.resumable).then_some(&self.last_good)
    }

    fn preflight(&mut self, model: &Model) -> Result<(), CycleError> {
        preflight(model)
    }

    fn start(&mut self, model: &mut Model, resume: bool, report: &mut CycleReport) -> Result<(), CycleError> {
        if !resume {
            let (created, dropped) = topology::update_neighbours(model);
            report.topology_updates += 1;
            report.contacts_created += created;
            report.contacts_dropped += dropped;
            // The contacts' geometry and their normal forces now; no shear increment (Δt = 0).
            contact_stage(model, 0.0);
        }
        Ok(())
    }
}

/// The CPU's stages within a run.
struct Stages;

impl driver::Stages<Model> for Stages {
    fn advance(&mut self, model: &mut Model, max: u64, _cracking: bool, report: &mut CycleReport) -> Result<u64, CycleError> {
        // The cycles run on one of rayon's worker threads (a scope's body does): each of a
        // cycle's parallel passes then splits on that worker, the other workers stealing, rather
        // than being handed from this thread to the pool and back, a sleep and a wake-up each,
        // eight times a cycle.
        rayon::scope(|_| {
            for _ in 0..max {
                cycle(model, report)?;
            }
            Ok(max)
        })
    }

    fn energy(&mut self, model: &mut Model) -> Result<(f64, f64), CycleError> {
        let e = model.energies();
        Ok((e.kinetic + e.strain, e.external_work))
    }

    fn keep(&mut self, model: &Model, last_good: &mut Model) {
        last_good.keep_from(model, true);
    }
}

/// Stage 6: each block's force and moment sums, gravity, load, boundary stress and contacts, in
/// a fixed order;
/// the contact dashpots' work over the step `dt` to come (their power β(kn u̇n² + ks|u̇s|²) at
/// the half-step velocities) booked in the ledger. The WGSL `gather`'s twin; [`cycle`] runs its
/// two halves itself, the first beside the step.
pub fn gather(model: &mut Model, dt: f64) {
    let sums = contact_sums(model);
    add_sums(model, sums, dt);
}

/// Each contact's sums over its logical contacts ([`ContactSums`]), worked out in parallel, to
/// be added to its blocks in the contacts' order ([`add_sums`]): bit for bit what one pass in
/// that order gives. They read the blocks' velocities and places, not their sums, nor the step
/// (the dashpots' power is kept, times the step when added), so that a cycle works them out
/// while it finds its step ([`cycle`]).
fn contact_sums(model: &Model) -> Vec<ContactSums> {
    let beta = model.damping.beta;
    let (blocks, contacts) = (&model.blocks, &model.contacts);
    contacts
        .par_iter()
        .with_min_len(grain::SUMS)
        .map(|c| {
            let mat = model.contact_material(c);
            let (a, b) = (&blocks[c.blocks[0] as usize], &blocks[c.blocks[1] as usize]);
            let mut sums = ContactSums { fa: DVec3::ZERO, ma: DVec3::ZERO, fb: DVec3::ZERO, mb: DVec3::ZERO, applied: None, dashpots: Default::default() };
            // A simply-deformable block's applied stress times volume, Σ r fᵀ (`d3::sdef`),
            // summed in the same order.
            let (sdef_a, sdef_b) = (a.is_sdef(), b.is_sdef());
            let (mut applied_a, mut applied_b) = (glam::DMat3::ZERO, glam::DMat3::ZERO);
            for l in &c.logical {
                let f = contact::logical_force(l, c.normal, a, b, &mat, beta);
                if beta > 0.0 && l.gap <= 0.0 {
                    let u = b.velocity_at(l.point) - a.velocity_at(l.point);
                    let un = u.dot(c.normal);
                    sums.dashpots.push(beta * (mat.kn * un * un + mat.ks * (u - un * c.normal).length_squared()));
                }
                // Eq. (12) on each block: positive on block 2, negative on block 1 (¶19).
                sums.fb += f;
                sums.mb += (l.point - b.centroid).cross(f);
                sums.fa -= f;
                sums.ma -= (l.point - a.centroid).cross(f);
                if sdef_b {
                    applied_b += sdef::applied(l.point - b.centroid, f);
                }
                if sdef_a {
                    applied_a += sdef::applied(l.point - a.centroid, -f);
                }
            }
            if sdef_a || sdef_b {
                sums.applied = Some(Box::new((applied_a, applied_b)));
            }
            sums
        })
        .collect()
}

/// The rest of stage 6 ([`gather`]): each block's sums renewed (gravity, load, boundary
/// stress), then the contacts' `sums` added in the contacts' order, the dashpots' work over
/// the step `dt` booked.
fn add_sums(model: &mut Model, sums: Vec<ContactSums>, dt: f64) {
    let g = model.gravity;
    model.blocks.par_iter_mut().with_min_len(grain::RESET).for_each(|b| {
        b.force = b.mass * g + b.load;
        b.moment = DVec3::ZERO;
        if let Some(s) = &mut b.sdef {
            s.applied = glam::DMat3::ZERO;
        }
        // BOUNDARY STRESS on its faces (`Block::boundary_load`), before its contacts.
        if !b.boundary_stress.is_empty() {
            let (f, m, a) = b.boundary_load();
            b.force += f;
            b.moment += m;
            if let Some(s) = &mut b.sdef {
                s.applied += a;
            }
        }
    });
    let mut dashpots = 0.0;
    for (c, sums) in model.contacts.iter().zip(sums) {
        let [ia, ib] = c.blocks.map(|i| i as usize);
        dashpots = sums.dashpots.iter().fold(dashpots, |total, d| total + d * dt);
        model.blocks[ia].force += sums.fa;
        model.blocks[ia].moment += sums.ma;
        model.blocks[ib].force += sums.fb;
        model.blocks[ib].moment += sums.mb;
        if let Some(applied) = sums.applied {
            if let Some(s) = &mut model.blocks[ia].sdef {
                s.applied += applied.0;
            }
            if let Some(s) = &mut model.blocks[ib].sdef {
                s.applied += applied.1;
            }
        }
    }
    model.dissipated.contact_damping += dashpots;
}

/// One contact's part of stage 6 ([`gather`]): the force and moment on each block, the applied
/// stress times volume of a simply-deformable one (on each block, where either is one), and
/// the dashpots' power, one term per logical contact (times the step and summed in their
/// order).
struct ContactSums {
    fa: DVec3,
    ma: DVec3,
    fb: DVec3,
    mb: DVec3,
    applied: Option<Box<(glam::DMat3, glam::DMat3)>>,
    dashpots: smallvec::SmallVec<[f64; 4]>,
}

thread_local! {
    /// The blocks' placements of the last stage 4 run on this thread, their lists' room kept for
    /// the next ([`contact_stage`] takes them out and puts them back: a stage 4 of another model
    /// that a worker thread picks up while it waits gets lists of its own).
    static PLACEMENTS: std::cell::Cell<Vec<contact::Placement>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Stage 4 over every contact: common plane, logical contacts (their shear forces carried by
/// key), force–displacement law. With `dt` = 0 only the geometry and normal forces are renewed.
/// A detection outside a run's cycles (its first, a crack's): the logical contacts that appear
/// take their overlap whole. Returns the first contact (its index) driven through
/// ([`overlap_check`]'s check, made in the same pass).
pub fn contact_stage(model: &mut Model, dt: f64) -> Option<usize> {
    contact_stage_with(model, dt, Appearing::Overlapped)
}

/// [`contact_stage`], the logical contacts that appear starting as `appearing` says
/// (`contact::Scratch::appearing`): the GPU's detections between batches, at Δt = 0, are running
/// ones as the CPU's cycles are.
pub fn contact_stage_with(model: &mut Model, dt: f64, appearing: Appearing) -> Option<usize> {
    // Each block's bodies placed (their plane normals turned, boxes, inner balls) once for all
    // their contacts.
    // Kept from cycle to cycle on the thread that runs them ([`PLACEMENTS`]), renewed in place.
    let mut placements = PLACEMENTS.take();
    placements.resize_with(model.blocks.len(), contact::Placement::default);
    placements.par_iter_mut().zip(model.blocks.par_iter()).with_min_len(grain::BLOCK).for_each(|(p, b)| p.renew(b));
    contact_stage_placed(model, model.contact_tolerance(), dt, appearing, placements, None)
}

/// [`contact_stage_with`] for the `selected` contacts only (their indices, ascending), the
/// others left as they are: the GPU's partial detections, whose contacts between blocks that
/// have not moved keep the logical contacts the device tracks. Only the selected contacts' blocks
/// are placed; the work is the selected contacts' (and a flag per block), not the list's.
/// `tol`: the model's contact-forming distance (`Model::contact_tolerance`), as the caller has it.
pub fn contact_stage_of(model: &mut Model, tol: f64, dt: f64, appearing: Appearing, selected: &[usize]) -> Option<usize> {
    let mut wanted = vec![false; model.blocks.len()];
    for &k in selected {
        model.contacts[k].blocks.iter().for_each(|&b| wanted[b as usize] = true);
    }
    let mut placements = PLACEMENTS.take();
    placements.resize_with(model.blocks.len(), contact::Placement::default);
    placements
        .par_iter_mut()
        .zip(model.blocks.par_iter())
        .zip(wanted.par_iter())
        .with_min_len(grain::BLOCK)
        .filter(|(_, &w)| w)
        .for_each(|((p, b), _)| p.renew(b));
    contact_stage_placed(model, tol, dt, appearing, placements, Some(selected))
}

/// [`contact_stage`] with the blocks' bodies `placements` renewed where they are (by the cycle's
/// block pass); they go back to [`PLACEMENTS`] after. Every contact, or the `only` ones.
fn contact_stage_placed(
    model: &mut Model,
    tol: f64,
    dt: f64,
    appearing: Appearing,
    placements: Vec<contact::Placement>,
    only: Option<&[usize]>,
) -> Option<usize> {
    let (blocks, materials, contacts) = (&model.blocks, &model.materials, &mut model.contacts);
    let scratch = || {
        let mut s = contact::Scratch::default();
        s.appearing = appearing;
        s
    };
    let stage = |scratch: &mut contact::Scratch, c: &mut Contact| {
        let [i, j] = c.blocks.map(|k| k as usize);
        // The law block's material and whether its law is the joint law (the law's parameters
        // follow from the touching region found).
        let (mat, joint) = super::model::law_material(blocks, materials, c.blocks);
        // The parts in touch (a convex block is its own one part).
        let (a, b) = (placements[i].placed(&blocks[i], c.parts[0]), placements[j].placed(&blocks[j], c.parts[1]));
        let (friction, released) = update_contact(c, a, b, &mat, joint, tol, dt, scratch);
        (friction, released, driven_through(blocks, c).is_some())
    };
    let energy: Vec<(f64, f64, bool)> = match only {
        None => contacts.par_iter_mut().with_min_len(grain::CONTACT).map_init(scratch, stage).collect(),
        Some(at) => {
            // The selected contacts taken out of the list (each move a few words), staged, put
            // back: the work is theirs, not a pass over every contact.
            let mut taken: Vec<Contact> = at.iter().map(|&k| std::mem::replace(&mut contacts[k], Contact::vacant())).collect();
            let energy = taken.par_iter_mut().with_min_len(grain::CONTACT).map_init(scratch, stage).collect();
            for (&k, c) in at.iter().zip(taken) {
                contacts[k] = c;
            }
            energy
        }
    };
    PLACEMENTS.set(placements);
    // Summed in the contacts' order: reruns repeat bit for bit.
    let mut first_through = None;
    for (k, (friction, released, through)) in energy.into_iter().enumerate() {
        model.dissipated.friction += friction;
        model.dissipated.released += released;
        if through && first_through.is_none() {
            first_through = Some(only.map_or(k, |at| at[k]));
        }
    }
    first_through
}

/// One contact's stage 4. Returns the energy friction took and that released by logical
/// contacts that went while loaded (for the ledger). `mat` is the law block's material and
/// `joint` whether its law is the joint law (`Material::contact_law`): the parameters follow
/// the touching region, the last cycle's for the springs that go, this cycle's for the law.
/// `a` and `b` are the contact's convex bodies as placed: its blocks, or the parts of concave
/// ones in touch (`Contact::parts`). `scratch`: working space.
#[allow(clippy::too_many_arguments)]
pub fn update_contact(
    c: &mut Contact,
    a: contact::Placed,
    b: contact::Placed,
    mat: &super::model::Material,
    joint: bool,
    tol: f64,
    dt: f64,
    scratch: &mut contact::Scratch,
) -> (f64, f64) {
    let old_law = mat.contact_law(joint, c.area, c.logical.len());
    // Swapped corners take their forces under the point law only (`Appearing::Carried`): under
    // the joint law a corner's stiffness is its share of the region, which the swap changes, and
    // forces carried at the old share put energy in (`d3_split`'s struck wall of jointed bricks:
    // the stiffness changes, `contact::restiffening`, put in 1582 J more than every release took
    // out, where with the swapped corners let go they take out 13 270 J; docs/BENCHMARKS.md).
    let carried = scratch.appearing == Appearing::Carried && !mat.joint_law(joint, c.area, c.logical.len());
    // Boxes apart by more than the contact-forming distance: the blocks are (a lower bound of
    // their distance), and the common plane is not needed.
    let ((a0, a1), (b0, b1)) = (a.bounds, b.bounds);
    let apart = (b0 - a1).max(a0 - b1).max_element() > tol;
    let plane = (!apart).then(|| contact::common_plane_with(&a, &b, tol, Some(c.normal)));
    let old_normal = c.normal;
    if let Some(p) = &plane {
        c.normal = p.normal;
    }
    let Some(plane) = plane.filter(|p| p.separation <= tol) else {
        let released = c.logical.iter().map(|l| spring_energy(l, &old_law)).sum();
        c.category = None;
        c.area = 0.0;
        c.logical.clear();
        return (0.0, released);
    };
    let (category, area) = contact::logical_contacts_with(&a, &b, &plane, tol, scratch);
    let contact::Scratch { previous, found, appearing, .. } = scratch;
    let appearing = *appearing;
    let released: f64 = if found.len() == c.logical.len() && found.iter().zip(&c.logical).all(|(f, l)| f.0 == l.kind) {
        // The same logical contacts in the same order (a settled contact, most cycles): each
        // keeps its shear force, none is released. (A contact's logical contacts have distinct
        // keys, so the search below would pair them so too.)
        for (&(_, point, gap), l) in found.iter().zip(c.logical.iter_mut()) {
            (l.point, l.gap) = (point, gap);
        }
        // Nothing released: the empty sum, as the search's branch gives it (the sign of its
        // zero too).
        std::iter::empty::<f64>().sum()
    } else {
        // The last cycle's logical contacts (copied aside; the lists keep their allocations),
        // each new one taking the shear force of the old one of its key.
        previous.clear();
        previous.extend_from_slice(&c.logical);
        c.logical.clear();
        c.logical.extend(found.iter().map(|&(kind, point, gap)| {
            let old = previous.iter().find(|l| l.kind == kind);
            let shear_force = old.map_or(DVec3::ZERO, |l| l.shear_force);
            // A logical contact that appears during a run (a cycle, the GPU's detection between
            // batches, a crack: `Scratch::appearing`) inside an overlapped face starts unloaded
            // (eq. 16 as an increment; in a run, unless it takes a swapped corner's forces,
            // below); at the run's first detection, at its whole overlap.
            let offset = old.map_or(if appearing == Appearing::Overlapped { 0.0 } else { gap.min(0.0) }, |l| l.offset);
            // Its normal force: the old one's, carried and stepped by eq. (16); a new one's is
            // not yet known (`contact::force_law` loads it from its offset).
            let normal_force = old.map_or(contact::NEW_NORMAL_FORCE, |l| l.normal_force);
            Logical { kind, point, gap, normal_force, shear_force, offset }
        }));
        // The strain of logical contacts not found again (their shear springs; their normal
        // ones too, where the touching region lost a loaded corner); in a run, less those whose
        // corner a new one took (`contact::carry_swapped`).
        if carried {
            contact::carry_swapped(previous, &mut c.logical, tol, &old_law)
        } else {
            previous.iter().filter(|l| !c.logical.iter().any(|n| n.kind == l.kind)).map(|l| spring_energy(l, &old_law)).sum()
        }
    };
    c.category = Some(category);
    c.area = area;
    let law = mat.contact_law(joint, area, c.logical.len());
    // The joint law's stiffness per corner is its share of the region (JKN·area over the
    // corners): where that changed, the springs held alter their energy with no work done.
    let restiffened = if law.kn != old_law.kn || law.ks != old_law.ks { contact::restiffening(&c.logical, &old_law, &law) } else { 0.0 };
    let (friction, opened) = contact::force_law(c, old_normal, a.body.block, b.body.block, &law, dt);
    (friction, released + opened - restiffened)
}

/// One cycle: stages 6, 1–2, 7 as due, 4.
pub fn cycle(model: &mut Model, report: &mut CycleReport) -> Result<(), CycleError> {
    // The step and the contacts' sums of stage 6 at once: the step's sums over the logical
    // contacts run on one thread (they are added in order), the contacts' sums beside them.
    let (dt, sums) = rayon::join(|| model.timestep(), || contact_sums(model));
    add_sums(model, sums, dt);
    let (gravity, alpha, alpha_internal) = (model.gravity, model.damping.alpha, model.damping.alpha_internal);
    let materials = &model.materials;
    // Each block's step, and its bodies placed for stage 4 where it now is, in one pass (stage 7
    // between them moves no block).
    let mut placements = PLACEMENTS.take();
    placements.resize_with(model.blocks.len(), contact::Placement::default);
    let outcomes: Vec<motion::StepOutcome> = model
        .blocks
        .par_iter_mut()
        .zip(placements.par_iter_mut())
        .with_min_len(grain::BLOCK)
        .map(|(b, p)| {
            // A simply-deformable block steps its strain with its material's moduli.
            let mat = b.sdef.is_some().then(|| super::model::material_of(materials, b.material).elastic());
            let outcome = motion::law_of_motion_with(b, gravity, alpha, dt, mat.as_ref().map(|m| (m, alpha_internal)));
            p.renew(b);
            outcome
        })
        .collect();
    let tol = model.contact_tolerance();
    let fastest = outcomes.iter().map(|o| o.travel).fold(0.0, f64::max);
    for (k, o) in outcomes.iter().enumerate() {
        let b = &model.blocks[k];
        if !(o.external_work.is_finite() && b.centroid.is_finite() && b.velocity.is_finite() && b.angular_momentum.is_finite()) {
            return Err(CycleError::NonFinite { cycle: model.cycle + 1, block: b.id, what: "a non-finite position or velocity".into() });
        }
        // A block that moved more than the contact-forming distance in one step could pass a
        // contact unseen; one with no other block within its travel plus the neighbour margin
        // (and the fastest block's travel) cannot, and the lists are rebuilt after the step
        // (its travel is past the threshold): a block tumbling alone is not stopped.
        if o.travel > tol && !topology::alone(model, k, o.travel + fastest + topology::neighbour_margin(model)) {
            return Err(CycleError::TooFast { cycle: model.cycle + 1, block: b.id, travel: o.travel, limit: tol, speed: o.travel / dt });
        }
        model.external_work += o.external_work;
        model.dissipated.mass_damping += o.damping_work;
    }
    model.cycle += 1;
    model.time += dt;
    // The shapes are as they were at the step's check (cracks come after the contacts).
    if topology::rebuild_due(model, tol) {
        let (created, dropped) = topology::update_neighbours(model);
        report.topology_updates += 1;
        report.contacts_created += created;
        report.contacts_dropped += dropped;
    }
    if let Some(k) = contact_stage_placed(model, tol, dt, Appearing::Carried, placements, None) {
        return Err(overlap_error(model, k));
    }
    cracks(model, report);
    Ok(())
}

/// Stage 7's cracking, after the cycle (SL-85-1 ¶35f): the cracks `cracking::due` finds
/// (Griffith's law on simply-deformable blocks, the point-load law on the contact forces), each
/// cut by `split::crack` ([`crack_blocks`]).
pub fn cracks(model: &mut Model, report: &mut CycleReport) {
    let due = cracking::due(model);
    crack_blocks(model, due, report);
}

/// Cracks the blocks `due` ([`cracking::due`]) in turn, each crack keeping the indices of the
/// blocks before it (the new piece goes at the end), then finds the contacts and neighbour lists
/// afresh once for them all (stage 7, stage 4 with Δt = 0: each cut depends on its own block
/// alone, and a contact update per crack made a cycle of many cracks cost as many passes over
/// the whole model), carries the cracked blocks' contact state over to their pieces
/// (`carry_across_cracks`), and books as released what the cracks took from the kinetic and
/// strain energies (the parents' stresses, what the contacts' springs lost or gained with
/// their share of a halved face). Each crack goes into `report` (`from`: a point of the crack
/// plane; `to`: its unit normal).
pub fn crack_blocks(model: &mut Model, due: Vec<cracking::Crack>, report: &mut CycleReport) {
    if due.is_empty() {
        return;
    }
    let before = model.energies();
    let released = model.dissipated.released;
    // What the contacts of the blocks to crack carry, by the blocks' indices (which a crack
    // keeps: the piece that keeps the parent's index, the new ones at the end, their parent's
    // index in `origin`).
    let carried: Vec<Carried> = model
        .contacts
        .iter()
        .filter(|c| !c.logical.is_empty() && due.iter().any(|d| c.blocks.contains(&(d.block as u32))))
        .map(|c| {
            let (mat, joint) = super::model::law_material(&model.blocks, &model.materials, c.blocks);
            let n = c.logical.len();
            Carried { blocks: c.blocks, law: mat.contact_law(joint, c.area, n), joint: mat.joint_law(joint, c.area, n), logical: c.logical.clone() }
        })
        .collect();
    let mut origin: Vec<u32> = (0..model.blocks.len() as u32).collect();
    let mut cracked = Vec::new();
    for c in due {
        let Some((block, new_block)) = super::split::crack(model, c.block, c.point, c.normal) else { continue };
        cracked.push(c.block as u32);
        origin.resize(model.blocks.len(), c.block as u32);
        report.cracks.push(crate::driver::CrackEvent {
            cycle: model.cycle,
            block,
            new_block,
            criterion: c.criterion,
            value: c.value,
            from: Position::xyz(c.point.to_array()),
            to: Position::xyz(c.normal.normalize().to_array()),
        });
    }
    if cracked.is_empty() {
        return;
    }
    let first_new = model.next_contact_id;
    topology::update_neighbours(model);
    // The logical contacts the cracks make start unloaded, as those that appear in a cycle;
    // those the parents had take their state back below. Only the contacts the cut touched (of
    // a cracked block or a piece) and the new ones: the others are as the cycle (or the GPU's
    // read-back) left them, and the energies before and after the cut count them alike.
    let touched = |k: u32| origin[k as usize] != k || cracked.contains(&k);
    let selected: Vec<usize> =
        model.contacts.iter().enumerate().filter(|(_, c)| c.id >= first_new || c.blocks.iter().any(|&k| touched(k))).map(|(k, _)| k).collect();
    contact_stage_of(model, model.contact_tolerance(), 0.0, Appearing::Unloaded, &selected);
    carry_across_cracks(model, &origin, &cracked, &carried);
    let after = model.energies();
    model.dissipated.released = released + (before.kinetic + before.strain) - (after.kinetic + after.strain);
}

/// A contact of a block about to crack, as it was: its blocks (indices), its law and its
/// logical contacts.
struct Carried {
    blocks: [u32; 2],
    law: super::model::Material,
    joint: bool,
    logical: Vec<Logical>,
}

/// The state of the cracked blocks' contacts carried over to their pieces' (`origin`: each
/// block's index before the cracks, a new piece's its parent's; `cracked`: the parents'
/// indices, which their first pieces keep). A crack moves nothing, so each logical contact of a
/// piece's contact that lies where one of the parent's did (a corner of the old touching region)
/// is that one: under the same law it takes its offset and its normal and shear displacements
/// (its forces over its stiffnesses: the joint law's per-corner stiffness follows its share of
/// the region, which the crack halves); where the piece's region is too small for the joint law
/// (`Material::joint_law`) it keeps its forces. A logical contact the crack made (a piece's new
/// corner on the crack plane, inside a face the parent pressed) is a new spring:
/// - under the point law (a stiffness per corner) it starts unloaded, so that the force across
///   the face is what it was and only its stiffness grows (the face has more corners): before
///   this it took its whole overlap, and a crack through a loaded face put that spring energy
///   in (the squeezed block of `tests/suite/d3_split.rs` doubled its springs' energy);
/// - under the joint law (a stiffness per unit area) it takes the state of the old region's
///   side it lies on (interpolated along it), so that the joint carries the stress it carried:
///   its corners' shares halve and they are twice as many.
///
/// Each such contact's law is then applied at Δt = 0 (an opened spring let go, Coulomb's cap).
fn carry_across_cracks(model: &mut Model, origin: &[u32], cracked: &[u32], carried: &[Carried]) {
    let eps = 1e-6 * model.contact_tolerance();
    let Model { contacts, blocks, materials, .. } = model;
    let touched = |k: u32| origin[k as usize] != k || cracked.contains(&k);
    for c in contacts.iter_mut().filter(|c| !c.logical.is_empty() && (touched(c.blocks[0]) || touched(c.blocks[1]))) {
        let o = c.blocks.map(|k| origin[k as usize]);
        let Some((old, sign)) = carried.iter().find_map(|x| {
            if x.blocks == o {
                Some((x, 1.0))
            } else if x.blocks == [o[1], o[0]] {
                // Block 1 and block 2 swapped: the shear force acts on the other block.
                Some((x, -1.0))
            } else {
                None
            }
        }) else {
            continue;
        };
        let [i, j] = c.blocks.map(|k| k as usize);
        let (mat, joint_number) = super::model::law_material(blocks, materials, c.blocks);
        let (joint, law) = (mat.joint_law(joint_number, c.area, c.logical.len()), mat.contact_law(joint_number, c.area, c.logical.len()));
        // Under the same law, a force of the old law as one of the new: the same displacement
        // (the joint law's corners' stiffness follows their share of the region); under another
        // (a piece's region too small for the joint law) the same force.
        let same = joint == old.joint;
        let scaled = |f: f64, k_new: f64, k_old: f64| if !same || k_new == k_old || k_old <= 0.0 { f } else { f * (k_new / k_old) };
        for l in &mut c.logical {
            if let Some(m) = old.logical.iter().find(|m| m.point.distance(l.point) <= eps) {
                l.offset = m.offset;
                l.normal_force = scaled(m.normal_force, law.kn, old.law.kn);
                l.shear_force = sign * scaled(1.0, law.ks, old.law.ks) * m.shear_force;
            } else if joint && old.joint {
                if let Some((m, n, t)) = on_a_side(&old.logical, l.point, eps) {
                    l.offset = m.offset + t * (n.offset - m.offset);
                    l.normal_force = scaled(m.normal_force + t * (n.normal_force - m.normal_force), law.kn, old.law.kn);
                    l.shear_force = sign * scaled(1.0, law.ks, old.law.ks) * m.shear_force.lerp(n.shear_force, t);
                }
            }
        }
        contact::force_law(c, c.normal, &blocks[i], &blocks[j], &law, 0.0);
    }
}

/// The two logical contacts of `old` on whose segment `p` lies (within `eps`), and where along
/// it (0 at the first): a side of the old touching region a crack crossed.
fn on_a_side(old: &[Logical], p: DVec3, eps: f64) -> Option<(&Logical, &Logical, f64)> {
    for (k, m) in old.iter().enumerate() {
        for n in &old[k + 1..] {
            let d = n.point - m.point;
            let len2 = d.length_squared();
            if len2 <= eps * eps {
                continue;
            }
            let t = (p - m.point).dot(d) / len2;
            if (0.0..=1.0).contains(&t) && (m.point + t * d).distance(p) <= eps {
                return Some((m, n, t));
            }
        }
    }
    None
}
