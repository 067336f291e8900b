//! Stage 5 on the CPU: flows across contacts and along joints, the domain pressure update, and
//! the loads the pressures put on the blocks (SL-85-1 Appendix A ¶6–9, `model::fluid`). Runs
//! only in a scene with fluid (`Model::fluid`), after stage 4 (the joints' apertures read the
//! normal forces it has just set); the loads join the contact forces in the next gather.
//!
//! Each contact's flow and feet, each domain's area and each block's load is computed alone, on
//! the team's threads as the contact stage is; every sum is taken serially in a fixed order
//! (each domain's inflow over its contacts in ascending contact order, each block's load over
//! its adjacency list), so a run repeats bit for bit whatever the number of threads, and gives
//! what a serial loop gives. The contacts' flows are taken by stage 4 itself, each right after
//! its contact's force (`cpu::contact_forces`): one walk of the contacts a cycle, not two; each
//! domain then sums its inflow, takes its area and steps its pressure in one pass over the
//! domains, and the blocks their loads in one over the blocks.

use super::team::Team;
use super::{SharedMut, MIN_BLOCKS_PER_THREAD, MIN_CHUNK};
use crate::udec::model::domain::{Domains, NO_DOMAIN};
use crate::udec::model::fluid::{contact_foot, deformable_pressure_loads, fluid_area_with, is_free, pressure_jump_with, pressure_load, pressure_step};
use crate::udec::model::{BlockKind, Model};
use crate::udec::topology::Adjacency;

/// What stage 5 keeps between cycles.
#[derive(Default)]
pub struct FluidScratch {
    /// Each domain's flows, ascending by contact (CSR: domain d's entries are
    /// `inflow_entries[inflow_offsets[d]..inflow_offsets[d + 1]]`, each `k << 1 | side`, side 0
    /// where d is the contact's first domain, whose flow leaves it): the order
    /// `model::fluid::sum_inflows` adds them in, so each domain sums its own inflow as that loop
    /// would. Built with the domains (`all_pressure_loads`, after each change of topology).
    inflow_offsets: Vec<u32>,
    inflow_entries: Vec<u32>,
    /// Each domain's new area, its inflow times Δt this cycle (0 for a domain whose pressure
    /// does not step) and its new pressure (¶7's step, or the pressure it keeps): each domain's
    /// own, taken on the team's threads, so that the serial pass after them only adds up the
    /// inflow and writes the domains.
    steps: Vec<[f64; 3]>,
    /// Each domain's pressure after this cycle's step, indexed like `Domains::list`: the same
    /// numbers as the list's, packed (8 bytes a domain, not a whole `Domain`), for the blocks'
    /// loads, which read two of them at each contact round each block.
    pressures: Vec<f64>,
    /// Each block's load from the domain pressures and buoyancy (force x, y, moment), as the next
    /// gather adds it.
    pub loads: Vec<[f64; 3]>,
    /// Each simply-deformable block's applied stress times area from the domain pressures
    /// (`model::fluid::deformable_pressure_loads`), as the next gather adds it to the contacts';
    /// indexed like the blocks, empty in a scene without such blocks.
    pub applied: Vec<[f64; 4]>,
    /// Each zoned block's boundary grid points' loads from the domain pressures, indexed like the
    /// corners (corner k of a zoned block is its grid point k); empty in a scene without zoned
    /// blocks.
    pub gridpoint: Vec<[f64; 2]>,
    /// Each contact's two feet this cycle (`model::fluid::contact_foot`, side 0 then 1), taken
    /// once, by stage 4 where it has the corners at hand (`contact_forces::contact_stage`), for
    /// the areas and the loads, where each domain's area and each block's load would take them
    /// again.
    pub(super) feet: Vec<[[f64; 2]; 2]>,
    /// `model::fluid::boundary_pieces`' scratch (one loop's vertices), kept between cycles.
    ring: Vec<crate::udec::model::fluid::PieceVertex>,
}

/// `out[i] = f(i)` for every `i`, on the team's threads: each element alone, so the result is
/// what a serial loop gives. (`f` generic, not `dyn`: it is called per domain and per block,
/// where a call through a vtable kept each domain's area out of line.)
fn fill_on_team<T: Send, F: Fn(usize) -> T + Sync>(team: &mut Team, out: &mut [T], min_per_thread: usize, f: &F) {
    let n = out.len();
    let shared = SharedMut::new(out);
    team.for_chunks(n, min_per_thread, MIN_CHUNK, &|r| {
        // SAFETY: `for_chunks` hands each call its own range of 0..n, within the slice, which
        // stays borrowed here until every call has returned.
        let part = unsafe { shared.range(r.clone()) };
        for (slot, i) in part.iter_mut().zip(r) {
            *slot = f(i);
        }
    });
}

/// Each domain's flows in ascending contact order (`FluidScratch::inflow_entries`), from the
/// contacts' sides.
fn build_inflow_lists(domains: &Domains, offsets: &mut Vec<u32>, entries: &mut Vec<u32>) {
    let n = domains.list.len();
    let live = |k: usize| domains.sides[k][0] != NO_DOMAIN && domains.sides[k][0] != domains.sides[k][1];
    offsets.clear();
    offsets.resize(n + 1, 0);
    for k in (0..domains.sides.len()).filter(|&k| live(k)) {
        for d in domains.sides[k] {
            offsets[d as usize + 1] += 1;
        }
    }
    for d in 0..n {
        offsets[d + 1] += offsets[d];
    }
    entries.clear();
    entries.resize(offsets[n] as usize, 0);
    let mut next: Vec<u32> = offsets[..n].to_vec();
    // Contacts in ascending order, so each domain's run is ascending too.
    for k in (0..domains.sides.len()).filter(|&k| live(k)) {
        for (side, d) in domains.sides[k].into_iter().enumerate() {
            let at = &mut next[d as usize];
            entries[*at as usize] = ((k as u32) << 1) | side as u32;
            *at += 1;
        }
    }
}

/// Domain `d`'s net inflow Q from the flows stage 4 took, over its contacts in ascending order:
/// the sum `model::fluid::sum_inflows` makes for it, term by term.
fn domain_inflow(domains: &Domains, offsets: &[u32], entries: &[u32], d: usize) -> f64 {
    let mut q = 0.0;
    for &e in &entries[offsets[d] as usize..offsets[d + 1] as usize] {
        // (A side past the flows, which a consistent model never has, adds nothing, as in
        // `sum_inflows`.)
        let Some(f) = domains.flows.get((e >> 1) as usize).map(|f| f.flow) else { continue };
        if e & 1 == 0 {
            q -= f;
        } else {
            q += f;
        }
    }
    q
}

/// Stage 5, after stage 4 has taken each contact's flow (¶6) and feet: each free domain's
/// pressure from its inflow and its change of volume (¶7), then the blocks' loads at the new
/// pressures. Nothing in a dry scene.
pub fn flow_stage(model: &mut Model, adjacency: &Adjacency, scratch: &mut FluidScratch, team: &mut Team) {
    // Counted with stage 4, whose contacts it follows.
    let _p = crate::profile::scope(crate::profile::Stage::ContactForces);
    let (Some(fluid), Some(mut domains)) = (model.fluid, model.domains.take()) else { return };
    let nk = model.contacts.len();
    debug_assert_eq!(scratch.feet.len(), nk, "stage 4 took every contact's feet");
    debug_assert_eq!(domains.flows.len(), nk, "stage 4 took every contact's flow");
    if scratch.inflow_offsets.len() != domains.list.len() + 1 {
        // (Built with the domains; here only where a caller changed them without
        // `all_pressure_loads`.)
        build_inflow_lists(&domains, &mut scratch.inflow_offsets, &mut scratch.inflow_entries);
    }
    let feet = &scratch.feet;
    let foot = |k: usize, side: u32| feet[k][side as usize];
    // A joint's aperture as its flow has just taken it (the same number).
    let joint = |k: usize| {
        let f = &domains.flows[k];
        (f.length > 0.0).then_some(f.aperture)
    };
    let (dt, bulk) = (model.timestep, fluid.bulk);
    let (offsets, entries) = (&scratch.inflow_offsets, &scratch.inflow_entries);
    scratch.steps.resize(domains.list.len(), [0.0; 3]);
    // Each domain alone: its area now, its inflow over the step and its pressure after it, where
    // its pressure steps (¶7); a held or outer domain keeps its pressure.
    fill_on_team(team, &mut scratch.steps, MIN_BLOCKS_PER_THREAD, &|d| {
        let area = fluid_area_with(model, &domains, d, &foot, &joint);
        let dom = &domains.list[d];
        if is_free(dom.kind, dom.fixed) {
            let q = domain_inflow(&domains, offsets, entries, d) * dt;
            [area, q, pressure_step(dom.pressure, dom.area, area, q, bulk)]
        } else {
            [area, 0.0, dom.pressure]
        }
    });
    // The fluid that flowed in, summed in domain order (so a run repeats bit for bit).
    let mut inflow = 0.0;
    scratch.pressures.clear();
    for (dom, &[area, q, pressure]) in domains.list.iter_mut().zip(&scratch.steps) {
        if is_free(dom.kind, dom.fixed) {
            inflow += q;
        }
        dom.pressure = pressure;
        dom.area = area;
        scratch.pressures.push(pressure);
    }
    model.domains = Some(domains);
    if let Some(f) = model.fluid.as_mut() {
        f.inflow += inflow;
    }
    let (feet, pressures) = (&scratch.feet, &scratch.pressures);
    scratch.loads.resize(model.blocks.len(), [0.0; 3]);
    let model = &*model;
    fill_on_team(team, &mut scratch.loads, MIN_BLOCKS_PER_THREAD, &|b| {
        block_load(model, adjacency, b, &|k, side| feet[k][side as usize], &|d| pressures[d as usize])
    });
    if let Some(domains) = model.domains.as_ref() {
        deformable_pressure_loads(model, domains, &|k, side| feet[k][side as usize], &mut scratch.applied, &mut scratch.gridpoint, &mut scratch.ring);
    }
}

/// [`pressure_loads`] and the deformable blocks' share of the pressures
/// (`model::fluid::deformable_pressure_loads`), into `scratch`: after a change of topology.
pub fn all_pressure_loads(model: &Model, adjacency: &Adjacency, scratch: &mut FluidScratch) {
    pressure_loads(model, adjacency, &mut scratch.loads);
    match model.domains.as_ref().filter(|_| model.fluid.is_some()) {
        Some(domains) => {
            build_inflow_lists(domains, &mut scratch.inflow_offsets, &mut scratch.inflow_entries);
            let foot = |k: usize, side: u32| contact_foot(model, &model.contacts[k], side);
            deformable_pressure_loads(model, domains, &foot, &mut scratch.applied, &mut scratch.gridpoint, &mut scratch.ring);
        }
        None => {
            scratch.inflow_offsets.clear();
            scratch.inflow_entries.clear();
            scratch.applied.clear();
            scratch.gridpoint.clear();
        }
    }
}

/// Each block's load from the pressures of the domains around it (the module doc of
/// `model::fluid`, "Loads": a sum over its adjacency list, each contact giving the pressure jump
/// at its foot) and, with gravity, its buoyancy −ρ_w·A·g (¶9).
pub fn pressure_loads(model: &Model, adjacency: &Adjacency, loads: &mut Vec<[f64; 3]>) {
    loads.clear();
    if model.fluid.is_none() || model.domains.is_none() {
        loads.resize(model.blocks.len(), [0.0; 3]);
        return;
    }
    let foot = |k: usize, side: u32| contact_foot(model, &model.contacts[k], side);
    let domains = model.domains.as_ref().expect("checked above");
    loads.extend((0..model.blocks.len()).map(|b| block_load(model, adjacency, b, &foot, &|d| domains.list[d as usize].pressure)));
}

/// Block `b`'s load ([`pressure_loads`]) with the contacts' feet from `foot` (contact index,
/// side) and the domains' pressures from `pressure` (index in `Domains::list`: the list's own,
/// or stage 5's packed copy of them, `FluidScratch::pressures`); 0 without fluid or domains. A zoned block's is its buoyancy alone (its grid points
/// take the pressures, `FluidScratch::gridpoint`), which its gather shares out by mass as it
/// does its LOAD.
fn block_load(model: &Model, adjacency: &Adjacency, b: usize, foot: &impl Fn(usize, u32) -> [f64; 2], pressure: &impl Fn(u32) -> f64) -> [f64; 3] {
    let (Some(fluid), Some(domains)) = (model.fluid.as_ref(), model.domains.as_ref()) else { return [0.0; 3] };
    let (block, g) = (&model.blocks[b], model.gravity);
    let mut l = [-fluid.density * block.area * g[0], -fluid.density * block.area * g[1], 0.0];
    if block.kind == BlockKind::FullyDeformable && model.fdef_of(b).is_some_and(|f| !f.zones.is_empty()) {
        return l;
    }
    for e in adjacency.entries(b) {
        let k = e.contact() as usize;
        let jump = pressure_jump_with(domains, k, e.side(), pressure);
        if jump != 0.0 {
            let p = pressure_load(jump, foot(k, e.side()), block.centroid);
            l = [l[0] + p[0], l[1] + p[1], l[2] + p[2]];
        }
    }
    l
}

/// The work of the fluid loads over this cycle's step, with the velocities the step just took:
/// the ledger's fluid term, summed forward as gravity's work is
/// (`law_of_motion::law_of_motion`), which the kinetic energy at whole steps balances. A rigid
/// block's load does F·Δx + M·Δθ; a simply-deformable block's applied stress from the pressures
/// does A : Δε besides, A11·Δε11 + (A12 + A21)·Δε12 + A22·Δε22 (`model::sdef`, the power of its
/// internal modes); a zoned block's grid point loads are booked by its step
/// (`zones::step_fdef`), which has the grid points' velocities before and after it.
pub fn fluid_work(model: &Model, scratch: &FluidScratch) -> f64 {
    let dt = model.timestep;
    let loads = &scratch.loads;
    let mut w = 0.0;
    for (b, (block, l)) in model.blocks.iter().zip(loads).enumerate() {
        if block.fixed {
            continue;
        }
        if model.fdef_of(b).is_some_and(|f| !f.zones.is_empty()) {
            // Booked by its step (`zones::step_fdef`).
            continue;
        }
        w += (l[0] * block.velocity[0] + l[1] * block.velocity[1] + l[2] * block.angular_velocity) * dt;
        if let (Some(s), Some(a)) = (model.sdef_of(b), scratch.applied.get(b)) {
            let e = s.strain_rate;
            w += (a[0] * e[0] + (a[1] + a[2]) * e[1] + a[3] * e[2]) * dt;
        }
    }
    w
}
