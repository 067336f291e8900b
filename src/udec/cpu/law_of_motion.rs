//! Stage 1: the law of motion for rigid blocks (SL-85-1 eqs. 9–10 in two dimensions), integrated by
//! central differences with mass-proportional Rayleigh damping:
//!
//!   v(t+Δt/2) = [v(t−Δt/2)·(1 − αΔt/2) + (ΣF/m)·Δt] / (1 + αΔt/2)
//!
//! which is UDEC's CON1/CON2 form (Appendix A, "Main Common Block Variables"). Velocities live at
//! half steps, positions and forces at whole steps.

use crate::udec::model::Block;

/// What one block's step did, for the update tolerance and the energy bookkeeping.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepOutcome {
    /// Work done on the block by gravity and its load over this step.
    pub external_work: f64,
    /// How far the block's corners can have moved in this step (|Δx| + |Δθ|·R).
    pub corner_travel: f64,
    /// The first zone of a fully-deformable block turned inside out in this step (its index).
    pub inverted_zone: Option<u32>,
    /// Work the fluid loads did on a zoned block's grid points over this step (`zones::step_fdef`;
    /// the other blocks' is `flow::fluid_work`'s).
    pub fluid_work: f64,
}

/// Advances one free block by one step. Fixed blocks do not move (their velocity stays zero).
/// `force` and `moment` are the sums gathered at the end of the previous cycle (stage 6), which
/// already include gravity and load.
#[inline]
pub fn law_of_motion(block: &mut Block, gravity: [f64; 2], alpha: f64, dt: f64) -> StepOutcome {
    if block.fixed {
        block.velocity = [0.0, 0.0];
        block.angular_velocity = 0.0;
        return StepOutcome::default();
    }
    let con1 = 1.0 - 0.5 * alpha * dt;
    let con2 = 1.0 / (1.0 + 0.5 * alpha * dt);
    let inv_m = 1.0 / block.mass;
    let vx = (block.velocity[0] * con1 + block.force[0] * inv_m * dt) * con2;
    let vy = (block.velocity[1] * con1 + block.force[1] * inv_m * dt) * con2;
    let w = (block.angular_velocity * con1 + block.moment / block.inertia * dt) * con2;
    let (dx, dy, dtheta) = (vx * dt, vy * dt, w * dt);
    if alpha > 0.0 {
        block.damping_work +=
            mass_damping_work(block.mass, block.inertia, [block.velocity[0], block.velocity[1], block.angular_velocity], [vx, vy, w], alpha, dt);
    }
    block.velocity = [vx, vy];
    block.angular_velocity = w;
    block.centroid[0] += dx;
    block.centroid[1] += dy;
    block.rotation += dtheta;
    // A corner moves at most |Δx| + |Δθ|·R: the displacement the update tolerance watches.
    let corner_travel = (dx * dx + dy * dy).sqrt() + dtheta.abs() * block.radius;
    // Net displacement since the last contact update, kept at its largest (report ¶26).
    block.moved_since_update = block.moved_since_update.max(block.net_since_update());
    let fx = block.mass * gravity[0] + block.load[0];
    let fy = block.mass * gravity[1] + block.load[1];
    StepOutcome { external_work: fx * dx + fy * dy, corner_travel, inverted_zone: None, fluid_work: 0.0 }
}

/// Energy the mass-proportional damping force takes from a block in one step, from its velocities
/// (vx, vy, ω) before (`v0`, at t − Δt/2) and after (`v1`, at t + Δt/2). The scheme above is
/// v⁺ − v⁻ = (F/m − α·v̄)Δt with v̄ = (v⁺ + v⁻)/2, so ½m(v⁺² − v⁻²) = F·v̄Δt − α·m·v̄²Δt exactly:
/// the last term (and its rotational twin with I) is the dissipation. WGSL twin:
/// `mass_damping_work` in law_of_motion.wgsl.
#[inline]
pub fn mass_damping_work(mass: f64, inertia: f64, v0: [f64; 3], v1: [f64; 3], alpha: f64, dt: f64) -> f64 {
    let (mx, my, mw) = (0.5 * (v0[0] + v1[0]), 0.5 * (v0[1] + v1[1]), 0.5 * (v0[2] + v1[2]));
    alpha * dt * (mass * (mx * mx + my * my) + inertia * mw * mw)
}
