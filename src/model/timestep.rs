//! The time step and the energy bookkeeping of a model.

use super::Model;

/// Mechanical energy of the model: kinetic energy of the blocks and strain energy stored in the
/// contact springs, with the work done on it by gravity and loads since START.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energies {
    pub kinetic: f64,
    pub strain: f64,
    pub external_work: f64,
}

impl Model {
    /// UDEC 1.2's time step: Δt = FRAC · 2√(m_min / k_max), m_min the smallest block mass and k_max
    /// the largest contact stiffness of the materials in use (blocks and joint tags). Returns None
    /// when no block has mass or no stiffness is defined.
    pub fn critical_timestep(&self) -> Option<f64> {
        let m_min = self.blocks.iter().map(|b| b.mass).filter(|&m| m > 0.0).fold(f64::INFINITY, f64::min);
        let mut k_max: f64 = 0.0;
        let mut consider = |m: u32| {
            let mat = self.material(m);
            k_max = k_max.max(mat.kn).max(mat.ks);
        };
        for b in &self.blocks {
            consider(b.material);
        }
        for c in &self.corners {
            if c.edge_material != 0 {
                consider(c.edge_material);
            }
        }
        for c in &self.contacts {
            consider(c.material);
        }
        (m_min.is_finite() && k_max > 0.0).then(|| self.frac * 2.0 * (m_min / k_max).sqrt())
    }

    /// Kinetic and contact strain energy now. Velocities are at the half step, so the kinetic
    /// energy lags the strain energy by Δt/2 — a small, bounded difference, not a drift.
    pub fn energies(&self) -> Energies {
        let kinetic = self
            .blocks
            .iter()
            .filter(|b| !b.fixed)
            .map(|b| 0.5 * b.mass * (b.velocity[0].powi(2) + b.velocity[1].powi(2)) + 0.5 * b.inertia * b.angular_velocity.powi(2))
            .sum();
        let strain = self
            .contacts
            .iter()
            .map(|c| {
                let m = self.material(c.material);
                let mut e = 0.0;
                if m.kn > 0.0 {
                    e += c.normal_force.powi(2) / (2.0 * m.kn);
                }
                if m.ks > 0.0 {
                    e += c.shear_force.powi(2) / (2.0 * m.ks);
                }
                e
            })
            .sum();
        Energies { kinetic, strain, external_work: self.external_work }
    }
}

impl Model {
    /// An estimate of the largest stable FRACTION for the current contact network. The largest
    /// eigenvalue of M⁻¹K is bounded (Gershgorin) by twice the largest per-block sum of contact
    /// stiffness over the block's translational and rotational inertia; the central-difference
    /// scheme is stable for Δt < 2/ω_max, and FRAC scales UDEC's 2√(m_min/k_max).
    pub fn stable_frac_estimate(&self) -> f64 {
        let mut per_block = vec![0.0f64; self.blocks.len()];
        for c in &self.contacts {
            let m = self.material(c.material);
            let k = m.kn.max(m.ks);
            for b in [c.block1 as usize, c.block2 as usize] {
                let blk = &self.blocks[b];
                if blk.fixed || blk.mass <= 0.0 {
                    continue;
                }
                let r2 = (c.point[0] - blk.centroid[0]).powi(2) + (c.point[1] - blk.centroid[1]).powi(2);
                per_block[b] += k * (1.0 / blk.mass + if blk.inertia > 0.0 { r2 / blk.inertia } else { 0.0 });
            }
        }
        let lambda = 2.0 * per_block.iter().cloned().fold(0.0, f64::max);
        let base = match self.critical_timestep() {
            Some(dt) if self.frac > 0.0 => dt / self.frac,
            _ => return f64::NAN,
        };
        if lambda <= 0.0 {
            return f64::NAN;
        }
        (2.0 / lambda.sqrt()) / base
    }
}
