//! Simply-deformable polyhedral blocks (SL-85-1 Part III ¶35d, Appendix B's CHANGE … SDEF and
//! DAMPING … INTERNAL): the 2D engine's simply-deformable block (`udec::model::sdef`) in three
//! dimensions.
//!
//! A simply-deformable (SDEF) block is a rigid block plus six internal degrees of freedom: a
//! uniform strain ε of its whole body, a symmetric 3 × 3 tensor in global axes. Its vertices sit
//! at
//!
//!   x = c + (I + ε)·R·x_ref,
//!
//! the rigid placement stretched by the strain, so a material point r from the centroid moves at
//! v + ω × r + ε̇·r: the velocity the force–displacement law reads (eqs. 11 and 13 of Part III with
//! the strain rate). Its faces stay planar (the map is linear); a face's outward normal becomes
//! (I + ε)⁻¹·R·n, made a unit vector (normals map by the inverse transpose, and I + ε is
//! symmetric).
//!
//! **Equations of motion of the strain.** The logical contacts' forces f acting at points r (from
//! the centroid) do work at the rate P = Σ f·(ε̇ r) = ε̇_ij A_ij, where A_ij = Σ r_i f_j is the
//! *applied stress times volume* (the report's KSA; gravity and loads act at the centroid, r = 0,
//! and add nothing). The internal stress σ (tension positive) resists with the block's volume V:
//! a generalised force −V·σ. The strain's inertia is the second moment of the block's mass about
//! its centroid, M = ∫ρ x xᵀ dV = ½ tr(I)·1 − I for the inertia tensor I (so no new integral
//! over the surface is needed), turned with the block, R M Rᵀ: the kinetic energy of the motion
//! ε̇·x is ½ ε̇_ik ε̇_jk M_ij. As in 2D, blockdem keeps its diagonal: a normal strain ε_ii has the
//! inertia J_ii = M_ii, a shear strain ε_ij = ε_ji (one degree of freedom) the inertia
//! J_ij = ½(M_ii + M_jj) (its motion ε̇_ij (x_j, x_i) has the kinetic energy ½ ε̇_ij² (M_ii + M_jj)):
//!
//!   J_ii ε̈_ii = A_ii − V σ_ii,   J_ij ε̈_ij = ½(A_ij + A_ji) − V σ_ij  (i ≠ j),
//!
//! exact for a block whose principal axes are the global ones (a box at rest), integrated by
//! central differences as the rigid motion is (the strain rate at half steps, strain and stress
//! at whole steps), with the internal mass damping of DAMPING … INTERNAL (the report's ALPB) in
//! the CON1/CON2 form. The stress follows the strain by isotropic elasticity from the material's
//! bulk modulus K and shear modulus G, λ = K − 2G/3:
//!
//!   σ = λ tr(ε)·1 + 2G ε.
//!
//! **Energy.** The internal kinetic energy ½ Σ J ε̇² (each shear strain counted twice, as ε_ij
//! and ε_ji) and the strain energy ½V σ:ε enter the ledger (`Model::energies`), as does the work
//! of the internal damping.
//!
//! **Time step.** The internal modes' stiffest, the volumetric one, has the stiffness 3K·V per
//! unit strain (2G·V for a material of negative Poisson's ratio), against the least principal
//! second moment M_min (no mode's inertia is smaller, whatever the block's turn): the step is
//! the smaller of FRACTION × the contacts' bound (`Model::critical_timestep`, where a logical
//! contact's lever r gives an SDEF block the extra compliance r²/M_min of its strain) and
//! √(M_min/k), half the internal modes' own limit 2/ω, FRACTION not scaling the latter (as in
//! 2D, `udec::model::sdef`).
//!
//! Stage 6 sums [`applied`] beside each block's force and moment (`d3::cpu::gather`); stage 1
//! calls [`internal_step`] after the rigid step and stage 2 places the vertices with the strain
//! (`Block::place_vertices`).

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

/// A simply-deformable block's elastic moduli (its material's BULK and G; `Material::elastic`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Elastic {
    pub bulk: f64,
    pub shear: f64,
}

/// The internal state of one simply-deformable block (the report's extension array). Symmetric
/// tensors are in global axes as six numbers in Voigt's order (11, 22, 33, 12, 13, 23).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sdef {
    /// Strain ε since the block became simply deformable (or was cut from one), tension
    /// positive.
    pub strain: [f64; 6],
    /// Strain rate ε̇ at the half step.
    pub strain_rate: [f64; 6],
    /// Internal stress σ from the strain by the elastic law; Pa, tension positive.
    pub stress: [f64; 6],
    /// Applied stress times volume A_ij = Σ r_i f_j over the block's logical contacts (N·m),
    /// written by the gather (stage 6).
    pub applied: DMat3,
}

/// The (i, j) index pairs of the Voigt order.
pub const VOIGT: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// The symmetric tensor of six Voigt components.
#[inline]
pub fn tensor(v: [f64; 6]) -> DMat3 {
    DMat3::from_cols_array(&[v[0], v[3], v[4], v[3], v[1], v[5], v[4], v[5], v[2]])
}

/// The Voigt components of the symmetric part of `m`.
#[inline]
pub fn voigt(m: DMat3) -> [f64; 6] {
    VOIGT.map(|(i, j)| 0.5 * (m.col(j)[i] + m.col(i)[j]))
}

impl Sdef {
    /// The deformation I + ε that stretches the rigid placement.
    #[inline]
    pub fn stretch(&self) -> DMat3 {
        DMat3::IDENTITY + tensor(self.strain)
    }

    /// The velocity the strain rate gives a point `r` from the centroid: ε̇·r.
    #[inline]
    pub fn strain_velocity(&self, r: DVec3) -> DVec3 {
        tensor(self.strain_rate) * r
    }
}

/// Lamé's λ from the bulk and shear moduli.
#[inline]
pub fn lame_lambda(bulk: f64, shear: f64) -> f64 {
    bulk - 2.0 * shear / 3.0
}

/// The internal stress of the strain `e` by isotropic elasticity: λ tr(ε) + 2Gε.
#[inline]
pub fn elastic_stress(mat: &Elastic, e: [f64; 6]) -> [f64; 6] {
    let (l, g) = (lame_lambda(mat.bulk, mat.shear), mat.shear);
    let volumetric = l * (e[0] + e[1] + e[2]);
    std::array::from_fn(|k| if k < 3 { volumetric + 2.0 * g * e[k] } else { 2.0 * g * e[k] })
}

/// The second moments of a block's mass about its centroid, ∫ρ x xᵀ dV, from its inertia
/// tensor I = ∫ρ(|x|²·1 − x xᵀ) dV: ½ tr(I)·1 − I (in the axes I is given in).
#[inline]
pub fn second_moments(inertia: DMat3) -> DMat3 {
    let half_trace = 0.5 * (inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z);
    DMat3::from_diagonal(DVec3::splat(half_trace)) - inertia
}

/// The inertia of the six strain modes (Voigt order) of a block whose second moments in global
/// axes are `m`: the diagonal for the normal strains, the mean of two for a shear (module doc).
#[inline]
pub fn strain_inertia(m: DMat3) -> [f64; 6] {
    let d = [m.x_axis.x, m.y_axis.y, m.z_axis.z];
    VOIGT.map(|(i, j)| 0.5 * (d[i] + d[j]))
}

/// The stiffness of the block's stiffest internal mode per unit strain: the volumetric mode's
/// 3K·V (the largest eigenvalue of the elastic law, 3λ + 2G), or the shear modes' 2G·V where
/// that is larger (a negative Poisson's ratio).
#[inline]
pub fn internal_stiffness(mat: &Elastic, volume: f64) -> f64 {
    volume * (3.0 * mat.bulk).max(2.0 * mat.shear)
}

/// The applied stress times volume of one force `f` acting at `r` from the centroid: r fᵀ
/// (A_ij = r_i f_j). The gather adds these up in its fixed order.
#[inline]
pub fn applied(r: DVec3, f: DVec3) -> DMat3 {
    DMat3::from_cols(r * f.x, r * f.y, r * f.z)
}

/// The generalised forces on the strain modes (Voigt order): A_ii − Vσ_ii and
/// ½(A_ij + A_ji) − Vσ_ij (module doc).
#[inline]
fn generalised_force(s: &Sdef, volume: f64) -> [f64; 6] {
    let a = voigt(s.applied);
    std::array::from_fn(|k| a[k] - volume * s.stress[k])
}

/// One step of the strain (module doc): the strain rate from the applied and internal stresses
/// with the internal damping `alpha` (ALPB), then the strain and its stress. `inertia` is the
/// block's inertia tensor in global axes (its turn at the step), `volume` its volume. Returns the
/// energy the internal damping took and how far the step's strain moved any point within
/// `radius` of the centroid (at most).
#[inline]
pub fn internal_step(s: &mut Sdef, mat: &Elastic, inertia: DMat3, volume: f64, alpha: f64, dt: f64, radius: f64) -> (f64, f64) {
    let j = strain_inertia(second_moments(inertia));
    if !j.iter().all(|&x| x > 0.0) {
        return (0.0, 0.0);
    }
    let c1 = 1.0 - 0.5 * alpha * dt;
    let c2 = 1.0 / (1.0 + 0.5 * alpha * dt);
    let q = generalised_force(s, volume);
    let old = s.strain_rate;
    let rate: [f64; 6] = std::array::from_fn(|k| (old[k] * c1 + q[k] / j[k] * dt) * c2);
    // As for the rigid motion (`d3::motion::law_of_motion`): the damping force −αJε̇ over the
    // step's mean rate, each shear strain counted twice (it is ε_ij and ε_ji).
    let damping_work = if alpha > 0.0 {
        (0..6)
            .map(|k| {
                let m = 0.5 * (old[k] + rate[k]);
                let twice = if k < 3 { 1.0 } else { 2.0 };
                twice * j[k] * m * m
            })
            .sum::<f64>()
            * alpha
            * dt
    } else {
        0.0
    };
    s.strain_rate = rate;
    let step: [f64; 6] = rate.map(|r| r * dt);
    for (e, d) in s.strain.iter_mut().zip(step) {
        *e += d;
    }
    s.stress = elastic_stress(mat, s.strain);
    (damping_work, strain_travel(step, radius))
}

/// How far the strain change `d` (Voigt) moves a point within `radius` of the centroid at most:
/// its Frobenius norm (no less than its largest singular value) times the radius.
#[inline]
pub fn strain_travel(d: [f64; 6], radius: f64) -> f64 {
    let sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * (d[3] * d[3] + d[4] * d[4] + d[5] * d[5]);
    sq.sqrt() * radius
}

/// The strain energy of the block's internal stress: ½V σ:ε.
#[inline]
pub fn strain_energy(s: &Sdef, volume: f64) -> f64 {
    0.5 * volume * double_contraction(s.stress, s.strain)
}

/// σ:ε of two symmetric tensors in Voigt order (the shears counted twice).
#[inline]
fn double_contraction(a: [f64; 6], b: [f64; 6]) -> f64 {
    (0..6).map(|k| if k < 3 { a[k] * b[k] } else { 2.0 * a[k] * b[k] }).sum()
}

/// The kinetic energy of the strain modes at the rate `rate` with the inertia `j`
/// ([`strain_inertia`]): ½ Σ J ε̇², the shears twice.
#[inline]
pub fn internal_kinetic_energy(rate: [f64; 6], j: [f64; 6]) -> f64 {
    0.5 * (0..6).map(|k| if k < 3 { j[k] * rate[k] * rate[k] } else { 2.0 * j[k] * rate[k] * rate[k] }).sum::<f64>()
}

/// The strain rate brought from the half step to the whole step by half a step of the current
/// generalised force (as `Model::energies` does for the rigid velocities).
#[inline]
pub fn rate_at_whole_step(s: &Sdef, volume: f64, j: [f64; 6], dt: f64) -> [f64; 6] {
    if !j.iter().all(|&x| x > 0.0) {
        return s.strain_rate;
    }
    let q = generalised_force(s, volume);
    std::array::from_fn(|k| s.strain_rate[k] + q[k] / j[k] * 0.5 * dt)
}

/// Griffith's criterion (SL-85-1 Appendix A ¶17, as the 2D engine takes it, tension positive)
/// on the major and minor principal stresses s1 ≥ s3: the uniaxial tensile stress they are
/// equivalent to,
///
///   s1                              if 3 s1 + s3 ≥ 0,
///   −(s1 − s3)² / (8 (s1 + s3))     otherwise;
///
/// the block cracks where it reaches the tensile strength TF. (The intermediate principal
/// stress plays no part, as in Griffith's own theory of the most dangerous crack.)
pub fn griffith_stress(s1: f64, s3: f64) -> f64 {
    if 3.0 * s1 + s3 >= 0.0 {
        s1
    } else {
        -(s1 - s3).powi(2) / (8.0 * (s1 + s3))
    }
}

/// Jacobi sweeps of Griffith's screen ([`griffith_screen`]): a 3×3 symmetric matrix converges
/// quadratically, four sweeps (twelve rotations) leave its off-diagonal part at round-off, and
/// whatever is left is added to the bounds.
pub const SCREEN_SWEEPS: u32 = 4;

/// Griffith's screen (the GPU's, sdef.wgsl's `griffith_screen`, computed here in f64 as the f64
/// kernels do): whether the block whose internal stress is `stress` (Voigt) may have reached the
/// tensile strength `tf` by Griffith's law (SL-85-1 Appendix A ¶17, [`griffith_stress`]), on
/// bounds of its principal stresses rather than the stresses themselves, so that it never says
/// no where the exact check (`cracking::due`) says yes. [`SCREEN_SWEEPS`] sweeps of Jacobi
/// rotations bring the tensor near diagonal form D + E; by Weyl's inequality its eigenvalues lie
/// within |E|₂ ≤ |E|_F of D's, so s1 ≤ max D + |E|_F and s3 ≥ min D − |E|_F. Each bound is
/// widened further by `margin`·|σ|_F (the round-off of both computations, `gpu::shaders::
/// griffith_margin`), and as Griffith's stress grows with s1 and falls with s3 (its partial
/// derivatives in the compressive branch are (s1 − s3)(−s1 − 3 s3) / (8 (s1 + s3)²) ≥ 0 and
/// (s1 − s3)(3 s1 + s3) / (8 (s1 + s3)²) ≤ 0), its value on the bounds is at least the exact
/// one; the screen fires where that reaches TF less the margin. Only arithmetic and square
/// roots (the f64 kernels have no arccosine).
pub fn griffith_screen(stress: [f64; 6], tf: f64, margin: f64) -> bool {
    let [mut d0, mut d1, mut d2, mut o01, mut o02, mut o12] = stress;
    let norm = (d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (o01 * o01 + o02 * o02 + o12 * o12)).sqrt();
    let m = margin * norm;
    // A rotation is skipped where its element is this small (its θ² would overflow f32); what it
    // leaves is in the residual.
    let tiny = 1e-3 * m;
    for _ in 0..SCREEN_SWEEPS {
        // (p, q) = (0, 1), (0, 2), (1, 2), the third row r's elements rotated with them.
        (d0, d1, o01, o02, o12) = jacobi_rotation(d0, d1, o01, o02, o12, tiny);
        (d0, d2, o02, o01, o12) = jacobi_rotation(d0, d2, o02, o01, o12, tiny);
        (d1, d2, o12, o01, o02) = jacobi_rotation(d1, d2, o12, o01, o02, tiny);
    }
    let off = (2.0 * (o01 * o01 + o02 * o02 + o12 * o12)).sqrt();
    let hi = d0.max(d1).max(d2) + off + m;
    let lo = d0.min(d1).min(d2) - off - m;
    griffith_stress(hi, lo) >= tf - m
}

/// One Jacobi rotation of a symmetric matrix in the plane (p, q) (sdef.wgsl's twin): zeroes
/// a_pq (left where |a_pq| ≤ `tiny`) and returns the new a_pp, a_qq, a_pq and the third row's
/// a_rp, a_rq (Numerical Recipes' form: t the tangent of the angle, the smaller root).
pub fn jacobi_rotation(pp: f64, qq: f64, pq: f64, rp: f64, rq: f64, tiny: f64) -> (f64, f64, f64, f64, f64) {
    if pq.abs() <= tiny {
        return (pp, qq, pq, rp, rq);
    }
    let theta = (qq - pp) / (2.0 * pq);
    let sign = if theta >= 0.0 { 1.0 } else { -1.0 };
    let t = sign / (theta.abs() + (theta * theta + 1.0).sqrt());
    let c = 1.0 / (t * t + 1.0).sqrt();
    let s = t * c;
    (pp - t * pq, qq + t * pq, 0.0, c * rp - s * rq, s * rp + c * rq)
}

/// The principal stresses of `stress` (Voigt), greatest first, and the unit direction of the
/// greatest: the crack's normal. The direction is the null vector of σ − s1·1, the largest cross
/// product of two of its rows (any of them where s1 is repeated).
pub fn principal_stresses(stress: [f64; 6]) -> ([f64; 3], DVec3) {
    let t = tensor(stress);
    let [s3, s2, s1] = super::geometry::principal_moments(t);
    let m = t - DMat3::from_diagonal(DVec3::splat(s1));
    let rows = [m.row(0), m.row(1), m.row(2)];
    let candidates = [rows[0].cross(rows[1]), rows[0].cross(rows[2]), rows[1].cross(rows[2])];
    let best = candidates.into_iter().max_by(|a, b| a.length_squared().total_cmp(&b.length_squared())).unwrap_or(DVec3::X);
    let direction = if best.length_squared() > 0.0 { best.normalize() } else { DVec3::X };
    ([s1, s2, s3], direction)
}

/// Whether a block of constitutive number `constitutive` whose material's tensile strength is
/// `tf` is checked for Griffith's cracking: constitutive 3, 4 or 5 with a TF (as in 2D).
pub fn griffith_applies(constitutive: u32, tf: f64) -> bool {
    (3..=5).contains(&constitutive) && tf > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    const DENSITY: f64 = 2500.0;

    fn rock() -> Elastic {
        Elastic { bulk: 2e9, shear: 1.2e9 }
    }

    #[test]
    fn the_major_principal_stress_and_its_direction() {
        // A uniaxial tension of 5 along a direction d.
        let d = DVec3::new(1.0, 2.0, 2.0) / 3.0;
        let t = DMat3::from_cols(d * d.x, d * d.y, d * d.z) * 5.0;
        let (s, n) = principal_stresses(voigt(t));
        assert!((s[0] - 5.0).abs() < 1e-12 && s[1].abs() < 1e-12 && s[2].abs() < 1e-12, "{s:?}");
        assert!((n.dot(d).abs() - 1.0).abs() < 1e-12, "{n} against {d}");
        assert_eq!(griffith_stress(2.0, -1.0), 2.0);
        assert!((griffith_stress(0.0, -8.0) - 1.0).abs() < 1e-12, "an eighth in uniaxial compression");
    }

    #[test]
    fn voigt_round_trips_and_the_elastic_law_is_hookes() {
        let e = [1e-4, -2e-4, 3e-4, 5e-5, -6e-5, 7e-5];
        assert_eq!(voigt(tensor(e)), e);
        let m = rock();
        let s = elastic_stress(&m, e);
        // Against σ = λ tr ε + 2Gε written out, and the bulk modulus: mean stress = K tr ε.
        let l = m.bulk - 2.0 * m.shear / 3.0;
        assert!((s[0] - (l * 2e-4 + 2.0 * m.shear * 1e-4)).abs() < 1e-6);
        assert!((s[3] - 2.0 * m.shear * 5e-5).abs() < 1e-6);
        let mean = (s[0] + s[1] + s[2]) / 3.0;
        assert!((mean - m.bulk * 2e-4).abs() < 1e-3 * mean.abs());
    }

    #[test]
    fn the_second_moments_of_a_box_are_its_inertia_turned_inside_out() {
        // A box a × b × c of unit density: I_xx = V(b² + c²)/12, ∫x² dV = V a²/12.
        let (a, b, c) = (1.0, 2.0, 3.0);
        let v = a * b * c;
        let i = DMat3::from_diagonal(DVec3::new(v * (b * b + c * c), v * (a * a + c * c), v * (a * a + b * b)) / 12.0);
        let m = second_moments(i);
        assert!((m.x_axis.x - v * a * a / 12.0).abs() < 1e-12);
        assert!((m.y_axis.y - v * b * b / 12.0).abs() < 1e-12);
        assert!((m.z_axis.z - v * c * c / 12.0).abs() < 1e-12);
        let j = strain_inertia(m);
        assert!((j[3] - 0.5 * (m.x_axis.x + m.y_axis.y)).abs() < 1e-12);
    }

    #[test]
    fn a_free_cube_breathes_at_the_volumetric_frequency_and_keeps_its_energy() {
        // A unit cube, no contacts: an initial volumetric strain rate oscillates at
        // ω² = 3K·V/M_11 = 36 K/(ρ a²).
        let m = rock();
        let a = 1.0;
        let v = a * a * a;
        let mass = DENSITY * v;
        let i = DMat3::from_diagonal(DVec3::splat(mass * (2.0 * a * a) / 12.0));
        let omega = (36.0 * m.bulk / (DENSITY * a * a)).sqrt();
        let dt = 0.01 / omega;
        let mut s = Sdef { strain_rate: [1e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0], ..Sdef::default() };
        let j = strain_inertia(second_moments(i));
        // The energy at the whole step (the rate brought forward half a step), which central
        // differences keep without drift: taken a few periods apart.
        let energy = |s: &Sdef| internal_kinetic_energy(rate_at_whole_step(s, v, j, dt), j) + strain_energy(s, v);
        let mut e0 = 0.0;
        // Zero crossings of the strain after the start: half a period apart.
        let mut crossings = Vec::new();
        let mut last = 0.0;
        for n in 0..2000 {
            internal_step(&mut s, &m, i, v, 0.0, dt, 0.9);
            if n == 100 {
                e0 = energy(&s);
            }
            if n > 0 && last > 0.0 && s.strain[0] <= 0.0 || last < 0.0 && s.strain[0] >= 0.0 {
                crossings.push(n as f64 * dt);
            }
            last = s.strain[0];
        }
        assert!(crossings.len() >= 4, "{crossings:?}");
        let period = 2.0 * (crossings[3] - crossings[1]) / 2.0;
        let expect = 2.0 * std::f64::consts::PI / omega;
        assert!((period - expect).abs() < 1e-3 * expect, "period {period} against {expect}");
        let e = energy(&s);
        // The estimate oscillates by O((ωΔt)²) = 1e-4 about the kept energy.
        assert!((e - e0).abs() < 1e-3 * e0, "energy {e} against {e0}");
        // Shear modes untouched, the three normal strains equal.
        assert_eq!(s.strain[3], 0.0);
        assert_eq!(s.strain[0], s.strain[2]);
    }
}
