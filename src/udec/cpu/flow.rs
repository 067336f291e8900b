//! Stage 5 on the CPU: flows across contacts and along joints, the domain pressure update, and
//! the loads the pressures put on the blocks (SL-85-1 Appendix A ¶6–9, `model::fluid`). Runs
//! only in a scene with fluid (`Model::fluid`), after stage 4 (the joints' apertures read the
//! normal forces it has just set); the loads join the contact forces in the next gather.
//!
//! Every sum is taken serially in a fixed order (contacts in order for the flows, each block's
//! adjacency list for its loads), so a run repeats bit for bit.

use crate::udec::model::fluid::{contact_flows, fluid_area, is_free, pressure_jump, pressure_load, pressure_step};
use crate::udec::model::Model;
use crate::udec::topology::Adjacency;

/// What stage 5 keeps between cycles.
#[derive(Default)]
pub struct FluidScratch {
    /// Each domain's net inflow Q in this cycle.
    inflow: Vec<f64>,
    /// Each block's load from the domain pressures and buoyancy (force x, y, moment), as the next
    /// gather adds it.
    pub loads: Vec<[f64; 3]>,
}

/// Stage 5: each contact's flow (¶6), each free domain's pressure from its inflow and its change
/// of volume (¶7), and the blocks' loads at the new pressures. Nothing in a dry scene.
pub fn flow_stage(model: &mut Model, adjacency: &Adjacency, scratch: &mut FluidScratch) {
    // Counted with stage 4, whose contacts it walks again.
    let _p = crate::profile::scope(crate::profile::Stage::ContactForces);
    let (Some(fluid), Some(mut domains)) = (model.fluid, model.domains.take()) else { return };
    contact_flows(model, &mut domains, &mut scratch.inflow);
    let dt = model.timestep;
    let mut inflow = 0.0;
    for d in 0..domains.list.len() {
        let area = fluid_area(model, &domains, d);
        let dom = &mut domains.list[d];
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
    pressure_loads(model, adjacency, &mut scratch.loads);
}

/// Each block's load from the pressures of the domains around it (the module doc of
/// `model::fluid`, "Loads": a sum over its adjacency list, each contact giving the pressure jump
/// at its foot) and, with gravity, its buoyancy −ρ_w·A·g (¶9).
pub fn pressure_loads(model: &Model, adjacency: &Adjacency, loads: &mut Vec<[f64; 3]>) {
    loads.clear();
    loads.resize(model.blocks.len(), [0.0; 3]);
    let (Some(fluid), Some(domains)) = (model.fluid.as_ref(), model.domains.as_ref()) else { return };
    let g = model.gravity;
    for (b, (block, load)) in model.blocks.iter().zip(loads.iter_mut()).enumerate() {
        let mut l = [-fluid.density * block.area * g[0], -fluid.density * block.area * g[1], 0.0];
        for e in adjacency.entries(b) {
            let k = e.contact() as usize;
            let jump = pressure_jump(domains, k, e.side());
            if jump != 0.0 {
                let foot = crate::udec::model::fluid::contact_foot(model, &model.contacts[k], e.side());
                let p = pressure_load(jump, foot, block.centroid);
                l = [l[0] + p[0], l[1] + p[1], l[2] + p[2]];
            }
        }
        *load = l;
    }
}

/// The work of the fluid loads over this cycle's step, F·Δx + M·Δθ with the velocities the step
/// just took: the ledger's fluid term, summed forward as gravity's work is
/// (`law_of_motion::law_of_motion`), which the kinetic energy at whole steps balances.
pub fn fluid_work(model: &Model, loads: &[[f64; 3]]) -> f64 {
    let dt = model.timestep;
    model.blocks.iter().zip(loads).filter(|(b, _)| !b.fixed).map(|(b, l)| (l[0] * b.velocity[0] + l[1] * b.velocity[1] + l[2] * b.angular_velocity) * dt).sum()
}
