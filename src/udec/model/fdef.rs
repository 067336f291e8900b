//! Fully-deformable blocks (SL-85-1 Appendix A ¶11–12, CHANGE … FDEF and GENERATE; the Program
//! Guide's zone and grid-point arrays: KZC, KZS11–22, KZM; KCOR, KXG, KYG, KXDC, KYDC, KCFX,
//! KCFY, KCPM).
//!
//! A fully-deformable (FDEF) block is divided into constant-strain triangular zones
//! (`model::zoning` makes them) whose corners are grid points; the grid points carry the mass
//! (a third of each zone's, lumped) and move by central differences, the zones carry a stress:
//!
//! - **Zone stresses** (stage 3, FLAC-style): the strain rate of a triangle from its grid
//!   points' velocities, ε̇_ij = ½ Σ_n (v_i^n ∂N_n/∂x_j + v_j^n ∂N_n/∂x_i), with the linear
//!   shape functions' gradients ∂N_n/∂x = (y_{n+1} − y_{n+2}, x_{n+2} − x_{n+1}) / 2A; the stress
//!   follows incrementally by isotropic elasticity in plane strain from K and G
//!   (λ = K − 2G/3): Δσ11 = (λ + 2G)Δε11 + λΔε22, Δσ22 = λΔε11 + (λ + 2G)Δε22, Δσ12 = 2GΔε12,
//!   tension positive. Small strain: the stresses are not turned with the zone (no Jaumann term).
//! - **Grid-point forces** (stage 6): a zone pulls on its grid point n with −A σ·∇N_n, i.e.
//!   f_x = −½[σ11 (y_{n+1} − y_{n+2}) + σ12 (x_{n+2} − x_{n+1})] (and f_y alike); gravity acts on
//!   each grid point's mass, the block's LOAD is shared by mass; a contact's force goes to the
//!   grid point of its corner, or, on an edge, to the edge's two grid points in proportion to
//!   where the contact point lies along it.
//! - **Motion** (stage 1): v⁺ = [v⁻(1 − αΔt/2) + F/m Δt] / (1 + αΔt/2), the rigid blocks' law
//!   (`cpu::law_of_motion`) per grid point; a fixed block's grid points stay still.
//!
//! The block's outline is its boundary grid points (grid point k is corner k), so contacts see
//! the mesh's corners; the block's centroid, velocity and area follow its grid points (the mass
//! mean) for PRINT, the update tolerance and the broad phase.
//!
//! **Time step.** A zone's own limit is Δt ≤ h/c_p with h its least height (twice its area over
//! its longest side) and c_p = √((K + 4G/3)/ρ) the plane-strain P-wave speed; the model's step is
//! at most half the least of these (`ZONE_STEP_SAFETY`), FRACTION not scaling it (as SDEF
//! blocks); the contacts' step counts the least boundary grid-point mass as a block's.

use serde::{Deserialize, Serialize};

use super::geometry::orient;

/// One grid point of a fully-deformable block.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GridPoint {
    /// World position (at whole steps).
    pub position: [f64; 2],
    /// Velocity at the half step.
    pub velocity: [f64; 2],
    /// Force sum of the last gather: zones, contacts, gravity and load.
    pub force: [f64; 2],
    /// Lumped mass: a third of each of its zones' masses.
    pub mass: f64,
    /// Where it was at the block's last contact update (the update tolerance, ¶26).
    pub update_position: [f64; 2],
}

/// One constant-strain triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Zone {
    /// Its grid points (indices into the block's), counter-clockwise.
    pub gridpoints: [u32; 3],
    /// Stress (11, 12, 22), Pa, tension positive.
    pub stress: [f64; 3],
    /// Mass: density × its area when it was made.
    pub mass: f64,
}

/// The zones and grid points of one block (empty for a block not fully deformable, or not yet
/// zoned). The first `boundary` grid points are the block's corners, in order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Fdef {
    pub gridpoints: Vec<GridPoint>,
    pub zones: Vec<Zone>,
    pub boundary: u32,
    /// Energy the mass damping took from the grid points since START (J).
    pub damping_work: f64,
}

/// The share of the zones' least critical step the time step may take.
pub const ZONE_STEP_SAFETY: f64 = 0.5;

/// Twice the signed area of the triangle of `p` (positive counter-clockwise).
#[inline]
pub fn twice_area(p: [[f64; 2]; 3]) -> f64 {
    orient(p[0], p[1], p[2])
}

/// The shape functions' gradients times twice the area, (y_{n+1} − y_{n+2}, x_{n+2} − x_{n+1}).
#[inline]
fn scaled_gradients(p: [[f64; 2]; 3]) -> [[f64; 2]; 3] {
    std::array::from_fn(|n| {
        let (j, k) = ((n + 1) % 3, (n + 2) % 3);
        [p[j][1] - p[k][1], p[k][0] - p[j][0]]
    })
}

/// The strain rate (11, 12, 22) of the triangle `p` whose corners move at `v`.
#[inline]
pub fn strain_rate(p: [[f64; 2]; 3], v: [[f64; 2]; 3]) -> [f64; 3] {
    strain_rate_of_area(p, v, twice_area(p))
}

/// [`strain_rate`] of a triangle whose twice signed area `a2` is known (the zone stage has it
/// from its inversion check).
#[inline]
pub fn strain_rate_of_area(p: [[f64; 2]; 3], v: [[f64; 2]; 3], a2: f64) -> [f64; 3] {
    let g = scaled_gradients(p);
    let (mut e11, mut e22, mut e12) = (0.0, 0.0, 0.0);
    for n in 0..3 {
        e11 += v[n][0] * g[n][0];
        e22 += v[n][1] * g[n][1];
        e12 += v[n][0] * g[n][1] + v[n][1] * g[n][0];
    }
    [e11 / a2, 0.5 * e12 / a2, e22 / a2]
}

/// The stress increment of a strain increment `d` (11, 12, 22) in plane strain.
#[inline]
pub fn stress_increment(d: [f64; 3], lambda: f64, shear: f64) -> [f64; 3] {
    [(lambda + 2.0 * shear) * d[0] + lambda * d[2], 2.0 * shear * d[1], lambda * d[0] + (lambda + 2.0 * shear) * d[2]]
}

/// The forces a zone of stress `s` exerts on its three grid points at `p`: −A σ·∇N_n.
#[inline]
pub fn nodal_forces(p: [[f64; 2]; 3], s: [f64; 3]) -> [[f64; 2]; 3] {
    let g = scaled_gradients(p);
    g.map(|[gx, gy]| [-0.5 * (s[0] * gx + s[1] * gy), -0.5 * (s[1] * gx + s[2] * gy)])
}

/// Strain energy of a zone of area `area` and stress `s` in plane strain: ½A σ:ε with the strain
/// from the stress, (σ11 + σ22)²/(8(λ + G)) + (σ11 − σ22)²/(8G) + σ12²/(2G) per unit area.
pub fn zone_strain_energy(s: [f64; 3], area: f64, lambda: f64, shear: f64) -> f64 {
    let sum = s[0] + s[2];
    let mut w = if lambda + shear > 0.0 { sum * sum / (8.0 * (lambda + shear)) } else { 0.0 };
    if shear > 0.0 {
        let diff = s[0] - s[2];
        w += diff * diff / (8.0 * shear) + s[1] * s[1] / (2.0 * shear);
    }
    w * area
}

/// The critical step of one zone: its least height over the P-wave speed.
pub fn zone_timestep(p: [[f64; 2]; 3], density: f64, bulk: f64, shear: f64) -> f64 {
    let longest = (0..3).map(|k| (p[(k + 1) % 3][0] - p[k][0]).hypot(p[(k + 1) % 3][1] - p[k][1])).fold(0.0, f64::max);
    let height = twice_area(p).abs() / longest;
    let modulus = bulk + 4.0 * shear / 3.0;
    if modulus > 0.0 && density > 0.0 {
        height / (modulus / density).sqrt()
    } else {
        f64::INFINITY
    }
}

impl Fdef {
    /// The positions of zone `z`'s grid points.
    #[inline]
    pub fn zone_points(&self, z: usize) -> [[f64; 2]; 3] {
        self.zones[z].gridpoints.map(|g| self.gridpoints[g as usize].position)
    }

    /// The velocities of zone `z`'s grid points.
    #[inline]
    pub fn zone_velocities(&self, z: usize) -> [[f64; 2]; 3] {
        self.zones[z].gridpoints.map(|g| self.gridpoints[g as usize].velocity)
    }

    /// The area of zone `z` now.
    pub fn zone_area(&self, z: usize) -> f64 {
        0.5 * twice_area(self.zone_points(z))
    }

    /// The least mass of a boundary grid point (what a contact's spring pushes on).
    pub fn least_boundary_mass(&self) -> f64 {
        self.gridpoints[..self.boundary as usize].iter().map(|g| g.mass).filter(|&m| m > 0.0).fold(f64::INFINITY, f64::min)
    }

    /// The zones and grid points of `mesh`, at rest and unstressed, with density `density`.
    pub fn from_mesh(mesh: &super::zoning::Mesh, density: f64) -> Fdef {
        let mut f = Fdef {
            gridpoints: mesh.points.iter().map(|&p| GridPoint { position: p, update_position: p, ..GridPoint::default() }).collect(),
            zones: mesh.zones.iter().map(|&gridpoints| Zone { gridpoints, ..Zone::default() }).collect(),
            boundary: mesh.boundary as u32,
            damping_work: 0.0,
        };
        f.set_density(density);
        f
    }

    /// Zone masses (density × area now) and the grid points' lumped masses.
    pub fn set_density(&mut self, density: f64) {
        for g in &mut self.gridpoints {
            g.mass = 0.0;
        }
        for z in 0..self.zones.len() {
            let m = density * self.zone_area(z);
            self.zones[z].mass = m;
            for g in self.zones[z].gridpoints {
                self.gridpoints[g as usize].mass += m / 3.0;
            }
        }
    }

    /// The mass-weighted mean position and velocity of the grid points, and the total mass.
    pub fn mass_centre(&self) -> ([f64; 2], [f64; 2], f64) {
        let (mut c, mut v, mut m) = ([0.0; 2], [0.0; 2], 0.0);
        for g in &self.gridpoints {
            m += g.mass;
            for k in 0..2 {
                c[k] += g.mass * g.position[k];
                v[k] += g.mass * g.velocity[k];
            }
        }
        if m > 0.0 {
            (c.map(|x| x / m), v.map(|x| x / m), m)
        } else {
            (c, v, m)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rigid motion (translation and spin) strains nothing; a uniform stretch is read exactly.
    #[test]
    fn strain_rate_of_rigid_and_uniform_motions() {
        let p = [[0.1, 0.2], [1.3, 0.1], [0.4, 1.1]];
        let spin = p.map(|x| [3.0 - 0.5 * x[1], -1.0 + 0.5 * x[0]]);
        let e = strain_rate(p, spin);
        assert!(e.iter().all(|x| x.abs() < 1e-14), "{e:?}");
        let stretch = p.map(|x| [2.0 * x[0] + 0.3 * x[1], 0.3 * x[0] - x[1]]);
        let e = strain_rate(p, stretch);
        assert!((e[0] - 2.0).abs() < 1e-13 && (e[1] - 0.3).abs() < 1e-13 && (e[2] + 1.0).abs() < 1e-13, "{e:?}");
    }

    /// A uniform stress on a zone gives nodal forces that sum to zero and equal the traction on
    /// the opposite sides: σ11 = 1 on the unit right triangle pulls the corner at x = 1 by −½.
    #[test]
    fn nodal_forces_balance() {
        let p = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let f = nodal_forces(p, [1.0, 0.0, 0.0]);
        let sum = f.iter().fold([0.0, 0.0], |a, b| [a[0] + b[0], a[1] + b[1]]);
        assert!(sum[0].abs() < 1e-15 && sum[1].abs() < 1e-15);
        assert!((f[1][0] + 0.5).abs() < 1e-15, "{f:?}");
    }
}
