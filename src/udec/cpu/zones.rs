//! Stages 6, 1, 2 and 3 of a fully-deformable block on the CPU (`model::fdef` has the physics):
//! its grid points sum their forces (zones, contacts, gravity, load), move by central
//! differences with mass damping, its zones take their stress increments from the new
//! velocities, and its corners follow its boundary grid points. One block at a time, so the
//! block pass runs it on any thread (its state is its own).

use super::law_of_motion::StepOutcome;
use super::BlockInputs;
use crate::udec::contact::gather::{AdjacencyEntry, ContactForce};
use crate::udec::model::corners::place_corners_fdef;
use crate::udec::model::fdef::{nodal_forces, strain_rate_of_area, stress_increment, twice_area, Fdef};
use crate::udec::model::{material_slot, Block, Contact, Corner};

/// Where a force on a block's boundary at a contact acts: the grid points and their shares, from
/// the contact's corner and feature (`[corner, feature]`). Block 1 of the contact owns the corner
/// (its grid point takes it all); on block 2 a corner arc (feature 2k) gives it to grid point k,
/// an edge (feature 2k + 1) shares it between k and k + 1 by where the contact point lies along
/// the edge.
#[inline]
pub fn force_shares([corner, feature]: [u32; 2], side: u32, corner_start: u32, corners: &[Corner], point: [f64; 2]) -> [(usize, f64); 2] {
    let n = corners.len();
    if side == 0 {
        return [((corner - corner_start) as usize, 1.0), (0, 0.0)];
    }
    let k = (feature / 2) as usize % n;
    if feature % 2 == 0 {
        return [(k, 1.0), (0, 0.0)];
    }
    let j = (k + 1) % n;
    let (a, e) = (corners[k].position, corners[k].edge_dir);
    let len = corners[k].edge_length;
    let t = if len > 0.0 { (((point[0] - a[0]) * e[0] + (point[1] - a[1]) * e[1]) / len).clamp(0.0, 1.0) } else { 0.0 };
    [(k, 1.0 - t), (j, t)]
}

/// The velocity of a zoned block's boundary at contact `c` (the contact law's twin of
/// [`force_shares`]), from `corner_velocity`, its boundary grid points' velocities in corner order
/// (grid point k is corner k, `model::fdef`).
#[inline]
pub fn boundary_velocity(corner_velocity: &[[f64; 2]], c: &Contact, side: u32, corner_start: u32, corners: &[Corner], point: [f64; 2]) -> [f64; 2] {
    let mut v = [0.0; 2];
    for (g, w) in force_shares([c.corner, c.feature], side, corner_start, corners, point) {
        if w != 0.0 {
            v[0] += w * corner_velocity[g][0];
            v[1] += w * corner_velocity[g][1];
        }
    }
    v
}

/// Stage 6 of a fully-deformable block: each grid point's force from its zones' stresses,
/// gravity on its mass and its share of the block's load (by mass), then the contacts in the
/// block's list order (a fixed order, so runs repeat). The block's force is the sum of the
/// external ones (for PRINT), its moment zero. `features`: each contact's corner and feature
/// (`Scratch::features`), which stage 4 writes beside its force record. In a scene with fluid,
/// `fluid` is the block's buoyancy (shared by mass, as the load is) and its corners' grid point
/// loads from the domain pressures (`cpu::flow::FluidScratch`).
#[allow(clippy::too_many_arguments)]
pub fn gather_fdef(
    block: &mut Block,
    f: &mut Fdef,
    corners: &[Corner],
    features: &[[u32; 2]],
    forces: &[ContactForce],
    entries: &[AdjacencyEntry],
    gravity: [f64; 2],
    fluid: Option<([f64; 3], &[[f64; 2]])>,
) {
    let total = block.mass.max(f64::MIN_POSITIVE);
    for g in &mut f.gridpoints {
        let share = g.mass / total;
        g.force = [g.mass * gravity[0] + block.load[0] * share, g.mass * gravity[1] + block.load[1] * share];
    }
    let mut external = [block.mass * gravity[0] + block.load[0], block.mass * gravity[1] + block.load[1]];
    if let Some((buoyancy, pressures)) = fluid {
        for (k, g) in f.gridpoints.iter_mut().enumerate() {
            let share = g.mass / total;
            let p = if (k as u32) < f.boundary { pressures.get(k).copied().unwrap_or([0.0; 2]) } else { [0.0; 2] };
            let l = [buoyancy[0] * share + p[0], buoyancy[1] * share + p[1]];
            g.force[0] += l[0];
            g.force[1] += l[1];
            external[0] += l[0];
            external[1] += l[1];
        }
    }
    for e in entries {
        let k = e.contact() as usize;
        let cf = &forces[k];
        let sign = if e.side() == 0 { 1.0 } else { -1.0 };
        let fx = [sign * cf.force[0], sign * cf.force[1]];
        external[0] += fx[0];
        external[1] += fx[1];
        for (g, w) in force_shares(features[k], e.side(), block.corner_start, corners, cf.point) {
            if w != 0.0 {
                f.gridpoints[g].force[0] += w * fx[0];
                f.gridpoints[g].force[1] += w * fx[1];
            }
        }
    }
    for z in 0..f.zones.len() {
        let nodal = nodal_forces(f.zone_points(z), f.zones[z].stress);
        for (g, fz) in f.zones[z].gridpoints.into_iter().zip(nodal) {
            f.gridpoints[g as usize].force[0] += fz[0];
            f.gridpoints[g as usize].force[1] += fz[1];
        }
    }
    block.force = external;
    block.moment = 0.0;
}

/// Stages 1, 3 and 2 of a fully-deformable block whose forces are gathered: its grid points
/// step (eqs. 9–10 per grid point, with mass damping; a fixed block's stay still), its zones
/// take their stress increments, its corners follow. The outcome's `inverted_zone` names the
/// first zone turned inside out (its index), if any. In a scene with fluid `fluid` is what the
/// gather added of it ([`gather_fdef`]), whose work over the step the outcome books: each grid
/// point's fluid force times its mean velocity over the step, ½(v_old + v_new)·Δt, which is what
/// the step gives its kinetic energy (the grid points' springs of fluid are stiff and light: the
/// forward product F·v_new·Δt that gravity's work takes would leave the ledger off by
/// ½Σ ΔF·Δx, first order in the step).
pub(super) fn step_fdef(block: &mut Block, f: &mut Fdef, corners: &mut [Corner], inp: &BlockInputs, fluid: Option<([f64; 3], &[[f64; 2]])>) -> StepOutcome {
    let dt = inp.dt;
    let mut out = StepOutcome::default();
    if block.fixed {
        for g in &mut f.gridpoints {
            g.velocity = [0.0; 2];
        }
    } else {
        let con1 = 1.0 - 0.5 * inp.alpha * dt;
        let con2 = 1.0 / (1.0 + 0.5 * inp.alpha * dt);
        let total = block.mass.max(f64::MIN_POSITIVE);
        // The largest squared step (one square root at the end: `hypot` per grid point took a
        // fifth of the zoned wall's cycle).
        let mut travel: f64 = 0.0;
        let mut damping = 0.0;
        let boundary = f.boundary as usize;
        for (k, g) in f.gridpoints.iter_mut().enumerate() {
            if g.mass <= 0.0 {
                continue;
            }
            let v0 = g.velocity;
            let v = [(v0[0] * con1 + g.force[0] / g.mass * dt) * con2, (v0[1] * con1 + g.force[1] / g.mass * dt) * con2];
            let d = [v[0] * dt, v[1] * dt];
            if inp.alpha > 0.0 {
                let m = [0.5 * (v0[0] + v[0]), 0.5 * (v0[1] + v[1])];
                damping += inp.alpha * dt * g.mass * (m[0] * m[0] + m[1] * m[1]);
            }
            g.velocity = v;
            g.position[0] += d[0];
            g.position[1] += d[1];
            travel = travel.max(d[0] * d[0] + d[1] * d[1]);
            let share = g.mass / total;
            out.external_work += (g.mass * inp.gravity[0] + block.load[0] * share) * d[0] + (g.mass * inp.gravity[1] + block.load[1] * share) * d[1];
            if let Some((buoyancy, pressures)) = fluid {
                let p = if k < boundary { pressures.get(k).copied().unwrap_or([0.0; 2]) } else { [0.0; 2] };
                let l = [buoyancy[0] * share + p[0], buoyancy[1] * share + p[1]];
                out.fluid_work += 0.5 * dt * (l[0] * (v0[0] + v[0]) + l[1] * (v0[1] + v[1]));
            }
        }
        f.damping_work += damping;
        out.corner_travel = travel.sqrt();
        // Stage 3: the zones' stress increments from the new velocities.
        let mat = &inp.materials[material_slot(block.material, inp.materials.len())].block;
        out.inverted_zone = zones(f, mat.bulk - 2.0 * mat.shear / 3.0, mat.shear, dt);
        // The update tolerance: how far the boundary moved since the last contact update.
        let mut moved: f64 = 0.0;
        for g in &f.gridpoints[..f.boundary as usize] {
            let d = [g.position[0] - g.update_position[0], g.position[1] - g.update_position[1]];
            moved = moved.max(d[0] * d[0] + d[1] * d[1]);
        }
        block.moved_since_update = block.moved_since_update.max(moved.sqrt());
    }
    place_corners_fdef(block, f, corners);
    out
}

/// Stage 3 of a fully-deformable block whose grid points have stepped (the GPU's twin is
/// zones.wgsl's `zones`, one invocation a zone): each zone's stress increment from its grid
/// points' new velocities, Δσ = D·ε̇Δt in plane strain (λ, G); a zone whose signed area is not
/// positive (turned inside out, or NaN) keeps its stress. Returns the first such zone's index.
pub fn zones(f: &mut Fdef, lambda: f64, shear: f64, dt: f64) -> Option<u32> {
    let mut inverted = None;
    let Fdef { gridpoints, zones, .. } = f;
    for (z, zone) in zones.iter_mut().enumerate() {
        let corners = zone.gridpoints.map(|g| &gridpoints[g as usize]);
        let p = corners.map(|g| g.position);
        let a2 = twice_area(p);
        // Not positive, or NaN.
        if a2.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            inverted.get_or_insert(z as u32);
            continue;
        }
        let e = strain_rate_of_area(p, corners.map(|g| g.velocity), a2);
        let ds = stress_increment(e.map(|x| x * dt), lambda, shear);
        let s = &mut zone.stress;
        s[0] += ds[0];
        s[1] += ds[1];
        s[2] += ds[2];
    }
    inverted
}
