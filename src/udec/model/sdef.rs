//! Simply-deformable blocks (SL-85-1 Part I ¶3–4 and Appendix A, CHANGE … SDEF; the Program
//! Guide's "simply-deformable extension array": strain rate KED, internal stress KSI, applied
//! stress times area KSA).
//!
//! A simply-deformable (SDEF) block is a rigid block plus three internal degrees of freedom: a
//! uniform strain ε (ε11, ε12, ε22) of its whole body. Its boundary points sit at
//!
//!   x = c + (I + ε)·R(θ)·x_local,
//!
//! the rigid placement stretched by the strain, so a point r from the centroid moves at
//! v + ω × r + ε̇·r, which is what the contact law reads (eqs. 13–15 with the strain rate).
//!
//! **Equations of motion of the strain.** The contact forces f acting at points r (from the
//! centroid) do work ε̇ : A at the rate P = Σ f·(ε̇ r) = ε̇_ij A_ji, where
//! A_ij = Σ r_i f_j is the *applied stress times area* (KSA; loads and gravity act at the
//! centroid, r = 0, and add nothing). The internal stress σ (KSI, tension positive) resists with
//! the block's area a: a generalised force −a·σ. The strain's inertia is the second moment of the
//! block's mass, M_kl = ∫ρ x_k x_l da about the centroid (`Sdef::moments`, in the body frame,
//! turned to world axes with the block): the kinetic energy of the motion ε̇·x is
//! ½ ε̇_ik ε̇_il M_kl. blockdem keeps its diagonal in world axes, J11 = M11 and J22 = M22 (exact
//! for a block whose principal axes are the world's, a rectangle at rest), and gives the shear
//! strain, ε12 = ε21 one degree of freedom, the mean J12 = ½(M11 + M22) = I/2:
//!
//!   J11 ε̈11 = A11 − a σ11,   J22 ε̈22 = A22 − a σ22,   J12 ε̈12 = ½(A12 + A21) − a σ12,
//!
//! integrated by central differences as the rigid motion is (the strain rate at half steps, the
//! strain and stress at whole steps), with the internal mass damping of DAMP … INTERNAL (UDEC's
//! ALPB, C1B and C2B) in the CON1/CON2 form. The stress follows the strain by isotropic
//! elasticity in plane strain from the material's bulk modulus K and shear modulus G,
//! λ = K − 2G/3:
//!
//!   σ11 = (λ + 2G) ε11 + λ ε22,   σ22 = λ ε11 + (λ + 2G) ε22,   σ12 = 2G ε12.
//!
//! **Energy.** The internal kinetic energy is ½(J11 ε̇11² + J22 ε̇22² + 2 J12 ε̇12²), the block's strain energy
//! ½a(σ11ε11 + σ22ε22 + 2σ12ε12); both enter the ledger (`Model::energies`), as does the work of
//! the internal damping.
//!
//! **Time step.** The internal modes' stiffness, volumetric 2a(λ + G) = 2a(K + G/3) per unit
//! strain against the smaller principal second moment M_min (whatever the block's turn, J11
//! and J22 are no smaller), bounds the step: it is the smaller of UDEC's FRAC·2√(m_min/k_max)
//! and ½·2√(M_min/(2a(K + G/3))) over the SDEF blocks, FRACTION not scaling the block's own
//! limit (`Model::critical_timestep`).
//!
//! The CPU's stage 1 calls [`internal_step`] for an SDEF block after its rigid step, stage 6
//! sums [`applied_stress`] beside the force and moment, and stage 2 places its corners with
//! `corners::place_corners_strained`.

use serde::{Deserialize, Serialize};

use super::BlockMaterial;

/// The internal state of one simply-deformable block (the report's extension array). Tensors are
/// in world axes; symmetric ones as (11, 12, 22).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sdef {
    /// Strain ε since the block became simply deformable (or was made by a crack), tension
    /// positive.
    pub strain: [f64; 3],
    /// Strain rate ε̇ at the half step (KED).
    pub strain_rate: [f64; 3],
    /// Internal stress σ (KSI), from the strain by the elastic law; Pa, tension positive.
    pub stress: [f64; 3],
    /// Applied stress times area A_ij = Σ r_i f_j over the block's contacts (KSA), as (11, 12,
    /// 21, 22); N·m. Written by the gather (stage 6).
    pub applied: [f64; 4],
    /// Energy the internal mass damping took since START (J).
    pub damping_work: f64,
    /// The second moments of the block's mass about its centroid in its body frame, ∫ρ x_k x_l da
    /// as (11, 12, 22): the strain's inertia (`strain_inertia`). Set when the block becomes
    /// simply deformable and with its mass (`Model::recompute_mass_properties`).
    pub moments: [f64; 3],
    /// The strain at the block's last contact update: its corners have moved by the strain since
    /// (at most [`strain_travel`]), which counts towards the update tolerance as the rigid
    /// motion does (`Block::moved_since_update`).
    pub update_strain: [f64; 3],
}

/// How far the strain change `d` (11, 12, 22) moves a point within `radius` of the centroid at
/// most: the largest singular value of the symmetric d, |mean| + √(half-difference² + d12²),
/// times the radius.
#[inline]
pub fn strain_travel(d: [f64; 3], radius: f64) -> f64 {
    // (The principal values without their direction: no atan2, this runs twice a block a cycle.)
    let (largest, smallest) = principal_pair(d);
    largest.abs().max(smallest.abs()) * radius
}

/// The strain's motion of a block's corners after its step (the report's ¶26 tolerance covers
/// every motion of a corner): this step's share is added to `corner_travel` (the too-fast
/// check), and the strain since the block's last contact update, past its rigid net
/// displacement, to its `moved_since_update`. Twin of the lines of `law_of_motion_sdef` that
/// follow `internal_step`.
#[inline]
pub fn count_strain_travel(s: &Sdef, block: &mut super::Block, corner_travel: &mut f64, dt: f64) {
    *corner_travel += strain_travel(s.strain_rate.map(|e| e * dt), block.radius);
    let since = [s.strain[0] - s.update_strain[0], s.strain[1] - s.update_strain[1], s.strain[2] - s.update_strain[2]];
    block.moved_since_update = block.moved_since_update.max(block.net_since_update() + strain_travel(since, block.radius));
}

/// Lamé's λ in plane strain from the bulk and shear moduli.
#[inline]
pub fn lame_lambda(bulk: f64, shear: f64) -> f64 {
    bulk - 2.0 * shear / 3.0
}

/// The internal stress of strain `e` (11, 12, 22) by isotropic elasticity in plane strain.
#[inline]
pub fn elastic_stress(mat: &BlockMaterial, e: [f64; 3]) -> [f64; 3] {
    let (l, g) = (lame_lambda(mat.bulk, mat.shear), mat.shear);
    [(l + 2.0 * g) * e[0] + l * e[2], 2.0 * g * e[1], l * e[0] + (l + 2.0 * g) * e[2]]
}

/// The inertia of the strain modes (11, 12, 22) of a block whose body-frame second moments are
/// `m` and whose rotation is `theta`: the diagonal of R M Rᵀ, and their mean for the shear (see
/// the module doc).
#[inline]
pub fn strain_inertia(m: [f64; 3], theta: f64) -> [f64; 3] {
    let (s, c) = theta.sin_cos();
    let j11 = c * c * m[0] - 2.0 * c * s * m[1] + s * s * m[2];
    let j22 = s * s * m[0] + 2.0 * c * s * m[1] + c * c * m[2];
    [j11, 0.5 * (m[0] + m[2]), j22]
}

/// The smaller principal second moment of `m` (11, 12, 22): the least inertia a strain mode has
/// at any turn of the block.
#[inline]
pub fn least_moment(m: [f64; 3]) -> f64 {
    principal_values(m).1
}

/// The second moments ∫x_k x_l da (11, 12, 22) of the polygon `pts` about the origin (its
/// centroid, for a block's body-frame corners); times the density, `Sdef::moments`.
pub fn polygon_moments(pts: &[[f64; 2]]) -> [f64; 3] {
    let n = pts.len();
    let (mut xx, mut xy, mut yy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (p, q) = (pts[i], pts[(i + 1) % n]);
        let c = p[0] * q[1] - q[0] * p[1];
        xx += (p[0] * p[0] + p[0] * q[0] + q[0] * q[0]) * c;
        yy += (p[1] * p[1] + p[1] * q[1] + q[1] * q[1]) * c;
        xy += (p[0] * q[1] + 2.0 * p[0] * p[1] + 2.0 * q[0] * q[1] + q[0] * p[1]) * c;
    }
    [(xx / 12.0).abs(), xy / 24.0, (yy / 12.0).abs()]
}

/// The stiffness of the block's stiffest internal mode per unit strain, the volumetric one:
/// 2a(λ + G) = 2a(K + G/3).
#[inline]
pub fn internal_stiffness(mat: &BlockMaterial, area: f64) -> f64 {
    2.0 * area * (mat.bulk + mat.shear / 3.0)
}

/// The velocity the strain rate `e` gives a point `r` from the centroid: ε̇·r.
#[inline]
pub fn strain_velocity(e: [f64; 3], r: [f64; 2]) -> [f64; 2] {
    [e[0] * r[0] + e[1] * r[1], e[1] * r[0] + e[2] * r[1]]
}

/// The applied stress times area of one contact force `f` acting through the lever point `p` on a
/// block whose centroid is `c`: r_i f_j as (11, 12, 21, 22). The gather adds these up in its
/// fixed order. The lever point is the one whose motion sets the contact's gap: the rounding
/// circle's centre on the corner's side, the contact point on the other
/// (`contact::law::BlockMotion::strain_velocity`).
#[inline]
pub fn applied_stress(p: [f64; 2], c: [f64; 2], f: [f64; 2]) -> [f64; 4] {
    let (rx, ry) = (p[0] - c[0], p[1] - c[1]);
    [rx * f[0], rx * f[1], ry * f[0], ry * f[1]]
}

/// The generalised force on the strain modes (11, 12, 22): the applied stress times area less
/// the internal stress times area, A11 − aσ11, ½(A12 + A21) − aσ12, A22 − aσ22 (module doc).
#[inline]
fn generalised_force(s: &Sdef, area: f64) -> [f64; 3] {
    let a = s.applied;
    [a[0] - area * s.stress[0], 0.5 * (a[1] + a[2]) - area * s.stress[1], a[3] - area * s.stress[2]]
}

/// One step of the strain (see the module doc): the strain rate from the applied and internal
/// stresses with the internal damping `alpha` (ALPB), then the strain and its stress. `area` is
/// the block's area, `theta` its rotation.
#[inline]
pub fn internal_step(s: &mut Sdef, mat: &BlockMaterial, area: f64, theta: f64, alpha: f64, dt: f64) {
    let j = strain_inertia(s.moments, theta);
    if !(j[0] > 0.0 && j[2] > 0.0) {
        return;
    }
    let c1 = 1.0 - 0.5 * alpha * dt;
    let c2 = 1.0 / (1.0 + 0.5 * alpha * dt);
    let q = generalised_force(s, area);
    let old = s.strain_rate;
    let rate: [f64; 3] = std::array::from_fn(|k| (old[k] * c1 + q[k] / j[k] * dt) * c2);
    if alpha > 0.0 {
        // As for the rigid motion (`law_of_motion::mass_damping_work`): the damping force
        // −α·J·ε̇ over the step's mean rate, ε12 counted twice (it is ε12 and ε21).
        let m = [0.5 * (old[0] + rate[0]), 0.5 * (old[1] + rate[1]), 0.5 * (old[2] + rate[2])];
        s.damping_work += alpha * dt * (j[0] * m[0] * m[0] + 2.0 * j[1] * m[1] * m[1] + j[2] * m[2] * m[2]);
    }
    s.strain_rate = rate;
    for (e, r) in s.strain.iter_mut().zip(rate) {
        *e += r * dt;
    }
    s.stress = elastic_stress(mat, s.strain);
}

/// The strain energy of the block's internal stress: ½a σ:ε.
#[inline]
pub fn strain_energy(s: &Sdef, area: f64) -> f64 {
    0.5 * area * (s.stress[0] * s.strain[0] + 2.0 * s.stress[1] * s.strain[1] + s.stress[2] * s.strain[2])
}

/// The kinetic energy of the strain modes at the rate `rate` with the inertia `j`
/// ([`strain_inertia`]): ½(J11 ε̇11² + 2 J12 ε̇12² + J22 ε̇22²).
#[inline]
pub fn internal_kinetic_energy(rate: [f64; 3], j: [f64; 3]) -> f64 {
    0.5 * (j[0] * rate[0] * rate[0] + 2.0 * j[1] * rate[1] * rate[1] + j[2] * rate[2] * rate[2])
}

/// The strain rate brought from the half step to the whole step by half a step of the current
/// generalised force (as `Model::energies` does for the rigid velocities).
#[inline]
pub fn rate_at_whole_step(s: &Sdef, area: f64, j: [f64; 3], dt: f64) -> [f64; 3] {
    if !(j[0] > 0.0 && j[2] > 0.0) {
        return s.strain_rate;
    }
    let q = generalised_force(s, area);
    let h = 0.5 * dt;
    [s.strain_rate[0] + q[0] / j[0] * h, s.strain_rate[1] + q[1] / j[1] * h, s.strain_rate[2] + q[2] / j[2] * h]
}

/// The principal values of a symmetric tensor (s11, s12, s22) (principal stresses, strains,
/// second moments): (largest, smallest, the angle of the largest's direction from the x axis).
pub fn principal_values(s: [f64; 3]) -> (f64, f64, f64) {
    let (largest, smallest) = principal_pair(s);
    let angle = 0.5 * (2.0 * s[1]).atan2(s[0] - s[2]);
    (largest, smallest, angle)
}

/// The principal values of a symmetric tensor (s11, s12, s22), largest first, without their
/// direction.
#[inline]
pub fn principal_pair(s: [f64; 3]) -> (f64, f64) {
    let mean = 0.5 * (s[0] + s[2]);
    let half_diff = 0.5 * (s[0] - s[2]);
    let radius = half_diff.hypot(s[1]);
    (mean + radius, mean - radius)
}

/// Griffith's criterion (Appendix A ¶17, tension positive): the uniaxial tensile stress the
/// principal stresses s1 ≥ s2 are equivalent to,
///
///   s1                              if 3 s1 + s2 > 0,
///   −(s1 − s2)² / (8 (s1 + s2))     if 3 s1 + s2 < 0;
///
/// the block cracks where this reaches the tensile strength t_f. (On 3s1 + s2 = 0 the two agree.)
pub fn griffith_stress(s1: f64, s2: f64) -> f64 {
    if 3.0 * s1 + s2 >= 0.0 {
        s1
    } else {
        -(s1 - s2).powi(2) / (8.0 * (s1 + s2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat() -> BlockMaterial {
        BlockMaterial { density: 2000.0, bulk: 1e8, shear: 6e7, tf: 0.0 }
    }

    /// Plane strain: a uniaxial strain gives σ11 = (λ + 2G) ε, σ22 = λ ε; a pure shear 2Gε.
    #[test]
    fn elastic_stress_is_plane_strain_hooke() {
        let m = mat();
        let l = m.bulk - 2.0 * m.shear / 3.0;
        let s = elastic_stress(&m, [1e-3, 0.0, 0.0]);
        assert!((s[0] - (l + 2.0 * m.shear) * 1e-3).abs() < 1e-6 && (s[2] - l * 1e-3).abs() < 1e-6 && s[1] == 0.0);
        assert_eq!(elastic_stress(&m, [0.0, 1e-3, 0.0])[1], 2.0 * m.shear * 1e-3);
    }

    /// Griffith: in tension the major principal stress; in compression the parabola, which is
    /// continuous at 3s1 + s2 = 0 and gives t_f = σc/8 in uniaxial compression.
    #[test]
    fn griffith_is_continuous_and_an_eighth_in_compression() {
        assert_eq!(griffith_stress(2.0, -1.0), 2.0);
        let (s1, s2): (f64, f64) = (1.0, -3.0);
        let a = -(s1 - s2).powi(2) / (8.0 * (s1 + s2));
        assert!((a - s1).abs() < 1e-12, "continuous at 3s1 + s2 = 0: {a}");
        assert!((griffith_stress(0.0, -8.0) - 1.0).abs() < 1e-12);
    }

    /// The principal stresses of a rotated uniaxial stress and its direction.
    #[test]
    fn principal_values_of_a_turned_tension() {
        let t: f64 = 0.3;
        let (c, s) = (t.cos(), t.sin());
        let (p1, p2, angle) = principal_values([5.0 * c * c, 5.0 * c * s, 5.0 * s * s]);
        assert!((p1 - 5.0).abs() < 1e-12 && p2.abs() < 1e-12 && (angle - t).abs() < 1e-12);
    }

    /// A rectangle's second moments: b·h³/12 about its axes, no product; and turned, the same
    /// diagonal as R M Rᵀ.
    #[test]
    fn second_moments_of_a_rectangle() {
        let (b, h) = (2.0, 0.5);
        let pts = [[-b / 2.0, -h / 2.0], [b / 2.0, -h / 2.0], [b / 2.0, h / 2.0], [-b / 2.0, h / 2.0]];
        let m = polygon_moments(&pts);
        assert!((m[0] - h * b.powi(3) / 12.0).abs() < 1e-12 && m[1].abs() < 1e-12 && (m[2] - b * h.powi(3) / 12.0).abs() < 1e-12, "{m:?}");
        let j = strain_inertia(m, std::f64::consts::FRAC_PI_2);
        assert!((j[0] - m[2]).abs() < 1e-12 && (j[2] - m[0]).abs() < 1e-12 && (j[1] - 0.5 * (m[0] + m[2])).abs() < 1e-12);
        assert!((least_moment(m) - m[2]).abs() < 1e-12);
    }

    /// Undamped free vibration of the strain: energy ½J ε̇² + ½aσε is kept to O(Δt²).
    #[test]
    fn a_free_strain_oscillation_keeps_its_energy() {
        // A unit square of density 2000, turned by 0.3 rad.
        let (m, area, theta) = (mat(), 1.0, 0.3);
        let unit = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];
        let moments = polygon_moments(&unit).map(|x| 2000.0 * x);
        let mut s = Sdef { strain: [1e-4, 0.0, -5e-5], moments, ..Sdef::default() };
        s.stress = elastic_stress(&m, s.strain);
        let j = strain_inertia(moments, theta);
        let w2 = internal_stiffness(&m, area) / least_moment(moments);
        let dt = 0.05 * 2.0 / w2.sqrt();
        let e0 = strain_energy(&s, area);
        let mut worst: f64 = 0.0;
        for _ in 0..2000 {
            s.applied = [0.0; 4];
            internal_step(&mut s, &m, area, theta, 0.0, dt);
            let e = strain_energy(&s, area) + internal_kinetic_energy(rate_at_whole_step(&s, area, j, dt), j);
            worst = worst.max((e - e0).abs() / e0);
        }
        assert!(worst < 1e-2, "energy drift {worst}");
    }
}
