//! Stage 5 on the CPU: flows across contacts and along joints, the domain pressure update, and
//! the loads the pressures put on the blocks (SL-85-1 Appendix A ¶6–9, `model::fluid`). Runs
//! only in a scene with fluid (`Model::fluid`), after stage 4 (the joints' apertures read the
//! normal forces it has just set); the loads join the contact forces in the next gather.
//!
//! Each contact's flow and feet, each domain's area and each block's load is computed alone, on
//! the team's threads as the contact stage is; every sum is taken serially in a fixed order
//! (the domains' inflows in contact order, each block's load over its adjacency list), so a
//! run repeats bit for bit whatever the number of threads, and gives what a serial loop gives.

use super::team::Team;
use super::{SharedMut, MIN_BLOCKS_PER_THREAD, MIN_CHUNK, MIN_CONTACTS_PER_THREAD};
use crate::udec::model::fluid::{
    contact_flow, contact_foot, deformable_pressure_loads, fluid_area_with, is_free, pressure_jump, pressure_load, pressure_step, sum_inflows,
};
use crate::udec::model::{BlockKind, Model};
use crate::udec::topology::Adjacency;

/// What stage 5 keeps between cycles.
#[derive(Default)]
pub struct FluidScratch {
    /// Each domain's net inflow Q in this cycle.
    inflow: Vec<f64>,
    /// Each domain's area this cycle.
    areas: Vec<f64>,
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
/// what a serial loop gives.
fn fill_on_team<T: Send>(team: &mut Team, out: &mut [T], min_per_thread: usize, f: &(dyn Fn(usize) -> T + Sync)) {
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

/// Stage 5: each contact's flow (¶6), each free domain's pressure from its inflow and its change
/// of volume (¶7), and the blocks' loads at the new pressures, with the contacts' feet stage 4
/// has just taken (`scratch.feet`). Nothing in a dry scene.
pub fn flow_stage(model: &mut Model, adjacency: &Adjacency, scratch: &mut FluidScratch, team: &mut Team) {
    // Counted with stage 4, whose contacts it walks again.
    let _p = crate::profile::scope(crate::profile::Stage::ContactForces);
    let (Some(fluid), Some(mut domains)) = (model.fluid, model.domains.take()) else { return };
    let nk = model.contacts.len();
    let mut flows = std::mem::take(&mut domains.flows);
    flows.resize(nk, Default::default());
    fill_on_team(team, &mut flows, MIN_CONTACTS_PER_THREAD, &|k| contact_flow(model, &domains, k));
    domains.flows = flows;
    sum_inflows(&domains, &mut scratch.inflow);
    debug_assert_eq!(scratch.feet.len(), nk, "stage 4 took every contact's feet");
    let feet = &scratch.feet;
    let foot = |k: usize, side: u32| feet[k][side as usize];
    scratch.areas.resize(domains.list.len(), 0.0);
    // A joint's aperture as its flow has just taken it (the same number).
    let joint = |k: usize| {
        let f = &domains.flows[k];
        (f.length > 0.0).then_some(f.aperture)
    };
    fill_on_team(team, &mut scratch.areas, MIN_BLOCKS_PER_THREAD, &|d| fluid_area_with(model, &domains, d, &foot, &joint));
    let dt = model.timestep;
    let mut inflow = 0.0;
    for (d, (dom, &area)) in domains.list.iter_mut().zip(&scratch.areas).enumerate() {
        if is_free(dom.kind, dom.fixed) {
            let q = scratch.inflow[d] * dt;
            inflow += q;
            dom.pressure = pressure_step(dom.pressure, dom.area, area, q, fluid.bulk);
        }
        dom.area = area;
    }
    model.domains = Some(domains);
    if let Some(f) = model.fluid.as_mut() {
        f.inflow += inflow;
    }
    let feet = &scratch.feet;
    scratch.loads.resize(model.blocks.len(), [0.0; 3]);
    let model = &*model;
    fill_on_team(team, &mut scratch.loads, MIN_BLOCKS_PER_THREAD, &|b| block_load(model, adjacency, b, &|k, side| feet[k][side as usize]));
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
            let foot = |k: usize, side: u32| contact_foot(model, &model.contacts[k], side);
            deformable_pressure_loads(model, domains, &foot, &mut scratch.applied, &mut scratch.gridpoint, &mut scratch.ring);
        }
        None => {
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
    loads.extend((0..model.blocks.len()).map(|b| block_load(model, adjacency, b, &foot)));
}

/// Block `b`'s load ([`pressure_loads`]) with the contacts' feet from `foot` (contact index,
/// side); 0 without fluid or domains. A zoned block's is its buoyancy alone (its grid points
/// take the pressures, `FluidScratch::gridpoint`), which its gather shares out by mass as it
/// does its LOAD.
fn block_load(model: &Model, adjacency: &Adjacency, b: usize, foot: &impl Fn(usize, u32) -> [f64; 2]) -> [f64; 3] {
    let (Some(fluid), Some(domains)) = (model.fluid.as_ref(), model.domains.as_ref()) else { return [0.0; 3] };
    let (block, g) = (&model.blocks[b], model.gravity);
    let mut l = [-fluid.density * block.area * g[0], -fluid.density * block.area * g[1], 0.0];
    if block.kind == BlockKind::FullyDeformable && model.fdef_of(b).is_some_and(|f| !f.zones.is_empty()) {
        return l;
    }
    for e in adjacency.entries(b) {
        let k = e.contact() as usize;
        let jump = pressure_jump(domains, k, e.side());
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
