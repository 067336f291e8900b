//! The force–displacement law of a contact (SL-85-1 eqs. 13–20), a pure function of the contact's
//! current geometry and its blocks' motion. The CPU's contact stage (`cpu::contact_forces`)
//! applies it to every contact; topology uses its normal part for the contacts a crack re-makes;
//! the GPU's twin is `shaders/udec/contact_forces.wgsl`, checked against it in `tests/suite/gpu_kernels.rs`.

use super::joint::law_parameters;
use crate::udec::model::geometry::{dot, sub};
use crate::udec::model::{Contact, Damping, Material};

/// Kinematic state of a block at the contact stage.
#[derive(Clone, Copy, Debug)]
pub struct BlockMotion {
    pub centroid: [f64; 2],
    pub velocity: [f64; 2],
    pub angular_velocity: f64,
    /// The strain rate (11, 12, 22) of a simply-deformable block (`model::sdef`), which moves a
    /// point r from the centroid at ε̇·r more; zero for a rigid block. The applied stress the
    /// gather sums takes the same lever arm (`model::corners::place_corners_strained` says why the
    /// two agree with the gap).
    pub strain_rate: [f64; 3],
}

impl BlockMotion {
    /// Velocity of the material point at `p` (eq. 11 in two dimensions: v + ω × r, plus the
    /// strain's share on a simply-deformable block).
    #[inline]
    pub fn velocity_at(&self, p: [f64; 2]) -> [f64; 2] {
        let r = sub(p, self.centroid);
        let v = [self.velocity[0] - self.angular_velocity * r[1], self.velocity[1] + self.angular_velocity * r[0]];
        // Three comparisons rather than an array's (which compiles to a slice comparison).
        let [e11, e12, e22] = self.strain_rate;
        if e11 == 0.0 && e12 == 0.0 && e22 == 0.0 {
            return v;
        }
        let e = crate::udec::model::sdef::strain_velocity(self.strain_rate, r);
        [v[0] + e[0], v[1] + e[1]]
    }
}

/// Whether a contact whose spring would hold the normal force `fn_` (compression positive) opens:
/// in tension, unless it is intact (bonded) and the tension is within its cohesion.
#[inline]
fn opens(fn_: f64, bonded: bool, cohesion: f64) -> bool {
    fn_ < 0.0 && (!bonded || -fn_ > cohesion)
}

/// Whether the force law gives this contact the same result whether or not it is the counted view
/// of a corner pair (`contact::pair::counts_force`), so that stage 4 need not decide which view
/// counts: an open (gap > 0), unbonded contact that held no tension. The uncounted view's branch
/// and the opening branch of [`contact_force_law`] then do the same: the shear spring lets go to
/// the slip work and the forces are zero (a bond's tension would be booked only on opening, hence
/// `normal_force ≥ 0`; with kn = 0 an open gap gives no tension, and the law would not open).
/// Twin of `force_free_either_way` in shaders/udec/contact_forces.wgsl.
#[inline]
pub fn force_free_either_way(contact: &Contact, gap: f64, kn: f64) -> bool {
    !contact.bonded && contact.normal_force >= 0.0 && opens(-kn * gap, false, 0.0)
}

/// The normal force a contact of gap `gap` holds, eq. (16) in total form (kn times the overlap,
/// compression positive), as the force law gives it: zero once it opens (`opens`), a tension up to
/// `cohesion` while it is intact (pass 0 for a broken contact).
pub fn normal_force(gap: f64, kn: f64, cohesion: f64) -> f64 {
    let fn_ = -kn * gap;
    if opens(fn_, cohesion > 0.0, cohesion) {
        0.0
    } else {
        fn_
    }
}

/// Force–displacement law for one contact whose geometry (gap, normal, point) is already current
/// (eqs. 13–20). `active` is false for the mirror copy of a corner–corner contact, which carries
/// no force so that the touch is counted once.
///
/// - Normal: eq. (16) integrated exactly, Fn = −kn·gap, since the rounded geometry gives the gap
///   itself; tension is allowed only on an intact (bonded) contact and only up to the cohesion.
/// - Shear: eq. (17) incrementally, ΔFs = −ks·Δus with Δus = v_s Δt; in 2D the shear force is a
///   scalar along the current tangent, so the rotation correction of eq. (17) is implicit.
/// - Coulomb limit, eq. (20): |Fs| ≤ c + μ Fn; once a contact slips or opens in tension it has lost
///   its cohesion for good (residual strength).
/// - Stiffness-proportional Rayleigh damping adds β·k·(relative velocity) dashpots, not stored.
///
/// The parameters are the contact's law's (`joint::law_parameters`): a joint (¶5) reads JKN·l_c,
/// JKS·l_c, JCOH·l_c and JFRIC, a point contact KN, KS, COHESION and FRICTION. A contact whose law
/// changed at the last contact update keeps its shear force and displacement: the increments of
/// eq. (17) take the new stiffness and the cap of eq. (20) the new strength from here on.
#[inline(always)]
pub fn contact_force_law(contact: &mut Contact, mat: &Material, a: &BlockMotion, b: &BlockMotion, damping: &Damping, dt: f64, active: bool) {
    let law = law_parameters(contact.joint_length, mat);
    let n = contact.normal;
    let t = [-n[1], n[0]];
    let va = a.velocity_at(contact.point);
    let vb = b.velocity_at(contact.point);
    let vrel = sub(va, vb); // eq. (13): block 1 relative to block 2
    let vn = dot(vrel, n); // eq. (14)
    let vs = dot(vrel, t); // eq. (15)
    contact.shear_displacement += vs * dt;
    // The dashpot force of the last step, −β·k·v(t−Δt/2), did work over that step's mean
    // velocity ½(v(t−Δt/2) + v(t+Δt/2)), the velocity central differences move the blocks with;
    // booking it so makes the ledger exact for the dashpots.
    let [pvn, pvs] = contact.dashpot_velocity;
    if pvn != 0.0 || pvs != 0.0 {
        contact.dashpot_work += damping.beta * (law.kn * pvn * 0.5 * (pvn + vn) + law.ks * pvs * 0.5 * (pvs + vs)) * dt;
        contact.dashpot_velocity = [0.0, 0.0];
    }
    if !active {
        // The other view carries the touch. The normal force follows the shared gap, but the
        // shear spring is this view's own (eq. 17 is incremental): if it held a force from when
        // this view was the counted one, it lets go as on opening (its energy to the slip
        // work), or it would stay in the ledger's strain energy and in a PRINT of the contact.
        contact.slip_work += slip_dissipation(contact.shear_force, 0.0, vs * dt, law.ks);
        contact.normal_force = 0.0;
        contact.shear_force = 0.0;
        contact.force = [0.0, 0.0];
        return;
    }
    let mut fn_ = -law.kn * contact.gap;
    let cohesion = if contact.bonded { law.cohesion } else { 0.0 };
    let fs_old = contact.shear_force;
    if opens(fn_, contact.bonded, cohesion) {
        // Open: no tension beyond the cohesion; an intact contact that breaks loses it for good.
        // The shear spring's energy and any bond tension go to the slip work.
        contact.slip_work += slip_dissipation(fs_old, 0.0, vs * dt, law.ks);
        if contact.normal_force < 0.0 && law.kn > 0.0 {
            contact.slip_work += contact.normal_force * contact.normal_force / (2.0 * law.kn);
        }
        contact.bonded = false;
        contact.normal_force = 0.0;
        contact.shear_force = 0.0;
        contact.force = [0.0, 0.0];
        return;
    }
    let mut fs = fs_old - law.ks * vs * dt; // eqs. (17), (19)
    let limit = cohesion + law.friction * fn_.max(0.0);
    if fs.abs() > limit {
        fs = fs.signum() * limit; // eq. (20)
        contact.slip_work += slip_dissipation(fs_old, fs, vs * dt, law.ks);
        if contact.bonded && law.cohesion > 0.0 {
            contact.bonded = false;
        }
    }
    contact.normal_force = fn_;
    contact.shear_force = fs;
    let (mut dn, mut ds) = (0.0, 0.0);
    if damping.beta > 0.0 && fn_ > 0.0 {
        dn = -damping.beta * law.kn * vn;
        ds = -damping.beta * law.ks * vs;
        contact.dashpot_velocity = [vn, vs];
    }
    fn_ += dn;
    let fs_total = fs + ds;
    contact.force = [fn_ * n[0] + fs_total * t[0], fn_ * n[1] + fs_total * t[1]];
}

/// Energy dissipated in one step by a shear spring whose force went from `fs_old` to `fs_new`
/// while the surfaces slid `dus` (block 1 relative to block 2): the trapezoidal work the blocks
/// did on the contact, −½(fs_old + fs_new)·Δus, less what the spring stored,
/// (fs_new² − fs_old²)/2ks. Exactly zero for an elastic step (fs_new = fs_old − ks·Δus); at the
/// Coulomb limit it is the friction force times the slip, ≥ 0.
#[inline]
pub fn slip_dissipation(fs_old: f64, fs_new: f64, dus: f64, ks: f64) -> f64 {
    if ks <= 0.0 {
        return 0.0;
    }
    -0.5 * (fs_old + fs_new) * dus - (fs_new * fs_new - fs_old * fs_old) / (2.0 * ks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::udec::model::ContactMaterial;

    /// A view of a corner–corner touch that stops being the counted one lets its shear spring go:
    /// no force, no shear force left to print or to count as strain energy, its spring's energy
    /// booked as slip work (the ledger stays balanced); a view that never carried one is unchanged.
    #[test]
    fn an_uncounted_view_keeps_no_shear_force() {
        let mat = Material { contact: ContactMaterial { kn: 1e9, ks: 5e8, friction: 0.6, ..Default::default() }, ..Default::default() };
        let still = BlockMotion { centroid: [0.0, 0.0], velocity: [0.0, 0.0], angular_velocity: 0.0, strain_rate: [0.0; 3] };
        let mut c = Contact { normal: [0.0, 1.0], gap: -1e-4, normal_force: 1e5, shear_force: 2e4, force: [-2e4, 1e5], ..Contact::unloaded(0, 0, 1) };
        contact_force_law(&mut c, &mat, &still, &still, &Damping::default(), 1e-4, false);
        assert_eq!((c.normal_force, c.shear_force, c.force), (0.0, 0.0, [0.0, 0.0]));
        assert!((c.slip_work - 2e4f64.powi(2) / (2.0 * mat.contact.ks)).abs() < 1e-9, "the spring's energy, {}", c.slip_work);
        let before = c;
        contact_force_law(&mut c, &mat, &still, &still, &Damping::default(), 1e-4, false);
        assert_eq!(c, before, "nothing more to let go");
    }

    /// `force_free_either_way` holds exactly where the law's result does not depend on which view
    /// counts (stage 4 then skips the comparison of the pair's depths): an open, unbonded contact
    /// gives the same contact counted or not, shear spring and dashpot bookings included; a closed,
    /// a bonded or a tension-holding one is not free (counted, it carries a force or books the bond).
    #[test]
    fn an_open_unbonded_view_gets_the_same_law_counted_or_not() {
        let mat = Material { contact: ContactMaterial { kn: 1e9, ks: 5e8, friction: 0.6, cohesion: 1e3 }, ..Default::default() };
        let still = BlockMotion { centroid: [0.0, 0.0], velocity: [0.0, 0.0], angular_velocity: 0.0, strain_rate: [0.0; 3] };
        let sliding = BlockMotion { velocity: [0.3, -0.1], angular_velocity: 0.2, ..still };
        let damping = Damping { beta: 1e-4, ..Default::default() };
        let open = Contact { normal: [0.0, 1.0], gap: 2e-6, shear_force: 3e3, dashpot_velocity: [0.01, -0.02], ..Contact::unloaded(0, 0, 1) };
        let kn = mat.contact.kn;
        let cases = [
            (open, true),
            (Contact { gap: -1e-6, ..open }, false),
            (Contact { bonded: true, ..open }, false),
            (Contact { normal_force: -500.0, ..open }, false),
        ];
        for (c, free) in cases {
            assert_eq!(force_free_either_way(&c, c.gap, kn), free, "{c:?}");
            let (mut counted, mut mirror) = (c, c);
            contact_force_law(&mut counted, &mat, &sliding, &still, &damping, 1e-4, true);
            contact_force_law(&mut mirror, &mat, &sliding, &still, &damping, 1e-4, false);
            if free {
                assert_eq!(counted, mirror, "an open unbonded view: the same either way");
            } else {
                assert_ne!(counted, mirror, "this one depends on which view counts: {c:?}");
            }
        }
    }
}
