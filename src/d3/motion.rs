//! Stages 1 and 2 for a polyhedral block: the law of motion (SL-85-1 ¶17, eqs. 9–10) by central
//! differences with mass-proportional Rayleigh damping, and the placing of its vertices.
//!
//! Translation is UDEC's scheme (Appendix B's CON1/CON2):
//!
//!   v(t+Δt/2) = [v(t−Δt/2)(1 − αΔt/2) + (ΣF/m)Δt] / (1 + αΔt/2),  x(t+Δt) = x(t) + v(t+Δt/2)Δt.
//!
//! Rotation (eq. 10) with the full inertia tensor: the report wrote Iᵢθ̈ᵢ = Mᵢ about fixed axes,
//! which holds only for a sphere. Euler's equations in the block's principal frame,
//! I ω̇ + ω × (I ω) = M, are the body-frame form of dL/dt = M for the angular momentum L = I(t)ω in
//! global axes, whose tensor I(t) = R I₀ Rᵀ turns with the block: the gyroscopic term ω × Iω is
//! the rate of that turning. So L is stepped by central differences exactly as v is (the damping
//! force αIω is αL),
//!
//!   L(t+Δt/2) = [L(t−Δt/2)(1 − αΔt/2) + ΣM Δt] / (1 + αΔt/2),
//!
//! and the orientation, a unit quaternion q (R = R(q)), by the implicit midpoint rule:
//! q(t+Δt) = exp(ω̄Δt) q(t), the rotation by the vector ω̄Δt, with ω̄ = R̄ I₀⁻¹ R̄ᵀ L(t+Δt/2) at the
//! midpoint orientation R̄ = R(exp(ω̄Δt/2) q(t)), found by a few fixed-point iterations. The scheme is time-reversible:
//! without a moment L is kept exactly and the energy ½ω·L stays within O(Δt²) of its start, with no
//! drift, so the tumbling of a free block (the intermediate-axis flip) comes out right.
//!
//! **Boundary conditions (¶35e, extensions).** A block held by BOUNDARY VELOCITY moves at its
//! velocity v and spin ω whatever the forces on it: x(t+Δt) = x(t) + vΔt, q(t+Δt) = exp(ωΔt) q(t),
//! L = I(t)ω (constant ω keeps ½ω·I(t)ω constant: İω = ω × Iω is normal to ω). The boundary does
//! the work that holds it, −(F·vΔt + M·ωΔt) with F and M the whole force and moment on the block
//! (its weight, load, boundary stress and contacts), on top of what the ledger books for the
//! weight, load and stress as on a free block, so the held block's kinetic energy stays and the
//! contacts' work on it is balanced in `external_work`. The boundary stresses (BOUNDARY STRESS)
//! on a block's faces do the work `Block::boundary_work` over the step, booked as external work.

use glam::{DMat3, DQuat, DVec3};

use super::model::Block;
use super::sdef;

/// Fixed-point iterations of the midpoint orientation (each contracts the error by ~|ω|Δt).
const MIDPOINT_ITERATIONS: usize = 4;

/// What one block's step did.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepOutcome {
    /// Work done by gravity, the load and the boundary conditions over the step.
    pub external_work: f64,
    /// How far any vertex can have moved in the step: |Δx| + |Δθ|·R.
    pub travel: f64,
    /// Energy the mass-proportional damping took in the step (the ledger's `mass_damping`).
    pub damping_work: f64,
}

/// Advances one block by one step (stages 1 and 2). `force` and `moment` on the block are the
/// sums of the contact forces, gravity and load (stage 6).
pub fn law_of_motion(block: &mut Block, gravity: DVec3, alpha: f64, dt: f64) -> StepOutcome {
    law_of_motion_with(block, gravity, alpha, dt, None)
}

/// [`law_of_motion`] with a simply-deformable block's strain (`d3::sdef`): `internal` gives its
/// material and the internal damping (DAMPING … INTERNAL). Its strain is stepped after the rigid
/// motion and before the vertices are placed; the strain's motion of the vertices counts towards
/// the step's travel, the internal damping's work towards `damping_work`. A fixed block's strain
/// stays as it is, its rate zero (as in 2D); a held one's too ([`held_motion`]).
pub fn law_of_motion_with(block: &mut Block, gravity: DVec3, alpha: f64, dt: f64, internal: Option<(&sdef::Elastic, f64)>) -> StepOutcome {
    if block.held && !block.fixed {
        return held_motion(block, gravity, dt);
    }
    if block.fixed {
        block.velocity = DVec3::ZERO;
        block.angular_momentum = DVec3::ZERO;
        block.angular_velocity = DVec3::ZERO;
        if let Some(s) = &mut block.sdef {
            s.strain_rate = [0.0; 6];
        }
        return StepOutcome::default();
    }
    let con1 = 1.0 - 0.5 * alpha * dt;
    let con2 = 1.0 / (1.0 + 0.5 * alpha * dt);
    let (v0, l0) = (block.velocity, block.angular_momentum);
    block.velocity = (block.velocity * con1 + block.force / block.mass * dt) * con2;
    block.angular_momentum = (block.angular_momentum * con1 + block.moment * dt) * con2;
    // The scheme is v⁺ − v⁻ = (F/m − αv̄)Δt with v̄ = (v⁺ + v⁻)/2, so ½m(v⁺² − v⁻²) =
    // F·v̄Δt − αm v̄²Δt exactly: the last term is the dissipation (as in 2D); the angular
    // momentum's twin is α L̄·I⁻¹L̄ Δt, I at the step's start.
    let damping_work = if alpha > 0.0 {
        let (v, l) = (0.5 * (v0 + block.velocity), 0.5 * (l0 + block.angular_momentum));
        alpha * dt * (block.mass * v.length_squared() + l.dot(block.angular_velocity_from(l)))
    } else {
        0.0
    };
    let dx = block.velocity * dt;
    let start = block.centroid;
    block.centroid += dx;
    let (orientation, omega) = rotate(block.orientation, block.inertia_ref, block.angular_momentum, dt);
    block.orientation = orientation;
    block.angular_velocity = omega;
    let (mut damping_work, mut strain_travel) = (damping_work, 0.0);
    if let (Some((mat, alpha_internal)), Some(mut s)) = (internal, block.sdef) {
        let (work, travel) = sdef::internal_step(&mut s, mat, block.inertia(), block.volume, alpha_internal, dt, block.shape.radius);
        block.sdef = Some(s);
        damping_work += work;
        strain_travel = travel;
    }
    // The boundary stresses' work, from the faces where the step began (placed below).
    let stress_work = (!block.boundary_stress.is_empty()).then(|| block.boundary_work(start, dx, omega, dt));
    block.place_vertices();
    let travel = dx.length() + omega.length() * dt * block.shape.radius + strain_travel;
    block.travel += travel;
    let applied = block.mass * gravity + block.load;
    let mut external_work = applied.dot(dx);
    if let Some(w) = stress_work {
        external_work += w;
    }
    StepOutcome { external_work, travel, damping_work }
}

/// One step of a block held by BOUNDARY VELOCITY (module doc): it moves at its velocity and
/// spin, its angular momentum I(t)ω at its new turn, a simply-deformable block's strain kept and
/// its rate zero. The work booked is its weight's, load's and boundary stresses' (as for a free
/// block) less the boundary's holding, F·Δx + M·ωΔt.
pub fn held_motion(block: &mut Block, gravity: DVec3, dt: f64) -> StepOutcome {
    if let Some(s) = &mut block.sdef {
        s.strain_rate = [0.0; 6];
    }
    let (v, omega) = (block.velocity, block.angular_velocity);
    let dx = v * dt;
    let start = block.centroid;
    block.centroid += dx;
    if omega != DVec3::ZERO {
        block.orientation = (DQuat::from_scaled_axis(omega * dt) * block.orientation).normalize();
    }
    block.angular_momentum = block.inertia() * omega;
    let stress_work = (!block.boundary_stress.is_empty()).then(|| block.boundary_work(start, dx, omega, dt));
    block.place_vertices();
    let travel = dx.length() + omega.length() * dt * block.shape.radius;
    block.travel += travel;
    let applied = block.mass * gravity + block.load;
    let mut external_work = applied.dot(dx);
    if let Some(w) = stress_work {
        external_work += w;
    }
    external_work -= block.force.dot(dx) + block.moment.dot(omega) * dt;
    StepOutcome { external_work, travel, damping_work: 0.0 }
}

/// The angular velocity ω = R I₀⁻¹ Rᵀ L of a block at orientation `q`.
pub fn angular_velocity(q: DQuat, inertia_ref_inv: DMat3, l: DVec3) -> DVec3 {
    q * (inertia_ref_inv * (q.inverse() * l))
}

/// One step of the orientation under the angular momentum `l` (held over the step): the
/// implicit midpoint rule of the module doc. Returns the new orientation and the step's
/// angular velocity ω̄.
pub fn rotate(q: DQuat, inertia_ref: DMat3, l: DVec3, dt: f64) -> (DQuat, DVec3) {
    if l == DVec3::ZERO {
        return (q, DVec3::ZERO);
    }
    let inv = super::geometry::inertia_inverse(inertia_ref).unwrap_or_else(|| inertia_ref.inverse());
    let mut omega = angular_velocity(q, inv, l);
    for _ in 0..MIDPOINT_ITERATIONS {
        let mid = (DQuat::from_scaled_axis(omega * (0.5 * dt)) * q).normalize();
        let next = angular_velocity(mid, inv, l);
        // At the fixed point to the last bit (a slow turn gets there in one or two): each
        // iteration left would give the same again.
        if next == omega {
            break;
        }
        omega = next;
    }
    ((DQuat::from_scaled_axis(omega * dt) * q).normalize(), omega)
}
