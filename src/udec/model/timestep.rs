//! The time step and the energy bookkeeping of a model.

use super::{Block, Model};

/// The energy ledger of the model (issue 4, item 3). With E₀ the kinetic + strain energy at START
/// (what VELOCITY gave the blocks), the explicit cycle keeps
///
///   E_kin + E_strain + W_mass_damping + W_contact_damping + W_friction + E_released = E₀ + W_external
///
/// up to the O((ωΔt)²) shadow-energy term of central differences (the kinetic energy is taken at
/// the whole step, from the half-step velocity and half a step of the current force).
/// [`Energies::ledger`] is the left side minus W_external, which should stay at E₀.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Energies {
    /// ½mv² + ½Iω² of the free blocks, velocities brought to the whole step.
    pub kinetic: f64,
    /// Strain energy in the contact springs, Fn²/2kn + Fs²/2ks, and in the simply-deformable
    /// blocks, ½a σ:ε (`model::sdef`).
    pub strain: f64,
    /// Work done on the blocks by gravity and loads since START, plus the kinetic energy VELOCITY
    /// commands gave (new minus old kinetic energy of the blocks they set): the energy put in.
    pub external_work: f64,
    /// Dissipated by the mass-proportional damping force −α·m·v (per block, `Block::damping_work`),
    /// and on the strain of simply-deformable blocks by DAMP … INTERNAL (`Sdef::damping_work`).
    pub mass_damping: f64,
    /// Dissipated by the stiffness-proportional contact dashpots β·kn·vn, β·ks·vs
    /// (per contact, `Contact::dashpot_work`).
    pub contact_damping: f64,
    /// Dissipated by friction (slip work at the Coulomb limit) and bond breakage
    /// (per contact, `Contact::slip_work`).
    pub friction: f64,
    /// Strain and kinetic energy that left the model with deleted contacts and blocks (a contact
    /// dropped while still loaded, DELETE of a moving block).
    pub released: f64,
    /// Work the fluid did on the blocks (domain pressures and buoyancy, `model::fluid`) since
    /// FLUID: energy put in, as the external work is; 0 in a dry scene.
    #[serde(default)]
    pub fluid_work: f64,
}

impl Energies {
    /// Everything dissipated: mass and contact damping plus friction.
    pub fn dissipated(&self) -> f64 {
        self.mass_damping + self.contact_damping + self.friction
    }

    /// E_kin + E_strain + dissipated + released − W_external: constant (= E₀) in an exact
    /// bookkeeping. Its drift against its START value is the balance error.
    pub fn ledger(&self) -> f64 {
        self.kinetic + self.strain + self.dissipated() + self.released - self.external_work - self.fluid_work
    }

    /// The largest term of the ledger, the scale a balance error is measured against.
    pub fn scale(&self) -> f64 {
        [self.kinetic, self.strain, self.external_work, self.mass_damping, self.contact_damping, self.friction, self.released, self.fluid_work]
            .iter()
            .fold(0.0f64, |a, b| a.max(b.abs()))
    }
}

/// The accumulated energy terms of blocks and contacts that were removed (dropped contacts,
/// deleted or cracked blocks), so that removing an element does not lose its share of the ledger.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RetiredEnergy {
    pub mass_damping: f64,
    pub contact_damping: f64,
    pub friction: f64,
    /// Kinetic and strain energy carried away by removed blocks and contacts.
    pub released: f64,
}

impl Model {
    /// Runs a topology change (`f`: contact update, crack, DELETE) and moves the energy terms of
    /// whatever it removed into `self.retired`, so that the ledger still balances. Sums are taken
    /// in storage order, so the result repeats bit for bit.
    pub fn retire_energy_around<R>(&mut self, f: impl FnOnce(&mut Model) -> R) -> R {
        let before = self.live_energies();
        let r = f(self);
        let after = self.live_energies();
        self.retired.mass_damping += before.mass_damping - after.mass_damping;
        self.retired.contact_damping += before.contact_damping - after.contact_damping;
        self.retired.friction += before.friction - after.friction;
        self.retired.released += (before.kinetic + before.strain) - (after.kinetic + after.strain);
        r
    }

    /// The energy terms of the blocks and contacts that exist now (no retired terms).
    fn live_energies(&self) -> Energies {
        let mut e = Energies { external_work: self.external_work, fluid_work: self.fluid.map_or(0.0, |f| f.work), ..Energies::default() };
        for (k, b) in self.blocks.iter().enumerate() {
            // A zoned block's motion is its grid points' (below).
            let zoned = self.fdef.get(k).is_some_and(|f| !f.zones.is_empty() && b.kind == super::BlockKind::FullyDeformable);
            if let Some(kin) = kinetic_at_t(b, self.timestep).filter(|_| !zoned) {
                e.kinetic += kin;
            }
            e.mass_damping += b.damping_work;
        }
        // Simply-deformable blocks: the strain modes' kinetic energy and strain energy, and
        // their internal damping.
        for (k, s) in self.sdef.iter().enumerate() {
            let b = &self.blocks[k];
            if b.kind != super::BlockKind::SimplyDeformable {
                continue;
            }
            if let Some(k) = strain_kinetic_at_t(b, s, self.timestep) {
                e.kinetic += k;
            }
            e.strain += super::sdef::strain_energy(s, b.area);
            e.mass_damping += s.damping_work;
        }
        // Fully-deformable blocks: their grid points' kinetic energy (brought to the whole step
        // as the blocks' is), their zones' strain energy, their mass damping.
        for (k, f) in self.fdef.iter().enumerate() {
            let b = &self.blocks[k];
            if b.kind != super::BlockKind::FullyDeformable || f.zones.is_empty() {
                continue;
            }
            if !b.fixed {
                let h = 0.5 * self.timestep;
                for g in f.gridpoints.iter().filter(|g| g.mass > 0.0) {
                    let v = [g.velocity[0] + g.force[0] / g.mass * h, g.velocity[1] + g.force[1] / g.mass * h];
                    let at_t = 0.5 * g.mass * (v[0] * v[0] + v[1] * v[1]);
                    e.kinetic += if at_t.is_finite() { at_t } else { 0.5 * g.mass * (g.velocity[0].powi(2) + g.velocity[1].powi(2)) };
                }
            }
            let mat = self.material(b.material).block;
            let lambda = mat.bulk - 2.0 * mat.shear / 3.0;
            for z in 0..f.zones.len() {
                e.strain += super::fdef::zone_strain_energy(f.zones[z].stress, f.zone_area(z), lambda, mat.shear);
            }
            e.mass_damping += f.damping_work;
        }
        for c in &self.contacts {
            // The springs of the contact's law: a joint's are JKN·l_c, JKS·l_c (¶5).
            let m = super::constitutive::law_parameters(c.joint_length, self.material(c.material));
            if m.kn > 0.0 {
                e.strain += c.normal_force.powi(2) / (2.0 * m.kn);
            }
            if m.ks > 0.0 {
                e.strain += c.shear_force.powi(2) / (2.0 * m.ks);
            }
            e.contact_damping += c.dashpot_work;
            e.friction += c.slip_work;
        }
        e
    }
}

/// The share of a simply-deformable block's own critical step its time step may take
/// (`Model::critical_timestep`).
pub const SDEF_STEP_SAFETY: f64 = 0.5;

impl Model {
    /// UDEC 1.2's time step: Δt = FRAC · 2√(m_min / k_max), m_min the smallest block mass and k_max
    /// the largest contact stiffness of the materials in use (blocks and joint tags); with
    /// simply-deformable blocks, no more than ½ · 2√(M_min / k_int) of any of them, its strain
    /// modes' least inertia M_min against their stiffest, volumetric stiffness k_int =
    /// 2a(K + G/3) (`model::sdef`). As UDEC's Δt_b of deformable blocks, FRAC does not scale the
    /// block's own limit (it is that mode's exact one); the half is the margin for the contacts,
    /// whose springs act on the strain modes too. Returns None when no block has mass or no
    /// stiffness is defined.
    pub fn critical_timestep(&self) -> Option<f64> {
        let rigid = self.contact_timestep();
        let mut internal = f64::INFINITY;
        for (k, b) in self.blocks.iter().enumerate() {
            if let Some(s) = self.sdef_of(k) {
                let stiffness = super::sdef::internal_stiffness(&self.material(b.material).block, b.area);
                let least = super::sdef::least_moment(s.moments);
                if stiffness > 0.0 && least > 0.0 {
                    internal = internal.min(SDEF_STEP_SAFETY * 2.0 * (least / stiffness).sqrt());
                }
            }
            // A zoned block's zones (`model::fdef`): half the least zone height over c_p.
            if let Some(f) = self.fdef_of(k) {
                let m = self.material(b.material).block;
                for z in 0..f.zones.len() {
                    internal = internal.min(super::fdef::ZONE_STEP_SAFETY * super::fdef::zone_timestep(f.zone_points(z), m.density, m.bulk, m.shear));
                }
            }
        }
        match rigid {
            Some(dt) => Some(dt.min(internal)),
            None => internal.is_finite().then_some(internal),
        }
    }

    /// UDEC 1.2's contact time step alone (see [`Model::critical_timestep`]).
    fn contact_timestep(&self) -> Option<f64> {
        // A zoned block's contact springs push on its boundary grid points, not its whole mass.
        let mass = |(k, b): (usize, &super::Block)| match self.fdef_of(k) {
            Some(f) if !f.zones.is_empty() => f.least_boundary_mass(),
            _ => b.mass,
        };
        let m_min = self.blocks.iter().enumerate().map(mass).filter(|&m| m > 0.0).fold(f64::INFINITY, f64::min);
        let k_max = self.contact_stiffness_max();
        (m_min.is_finite() && k_max > 0.0).then(|| self.frac * 2.0 * (m_min / k_max).sqrt())
    }

    /// The stiffest contact spring of the materials in use, k_max of UDEC's 2√(m_min/k_max)
    /// (joints' JKN·l_c and JKS·l_c included).
    pub fn contact_stiffness_max(&self) -> f64 {
        let mut k_max: f64 = 0.0;
        let mut consider = |m: u32| {
            let mat = self.material(m);
            k_max = k_max.max(mat.contact.kn).max(mat.contact.ks);
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
        // Joints (¶5): JKN·l_c and JKS·l_c, which may exceed KN and KS. Before the first
        // detection the contacts are not known: bounded by the longest edge of a block whose
        // number gives joints, halved (a joint's share); nothing changes for a model without
        // joint stiffnesses.
        k_max = k_max.max(self.joint_stiffness_bound());
        k_max
    }

    /// The largest stiffness a joint of this model may have (¶5: JKN·l_c, JKS·l_c): over the
    /// contacts that are joints now, and over the materials and joint constitutive numbers of
    /// blocks and SPLIT tags, with l_c at most half the longest edge of the model. 0 for a model
    /// with no joint stiffnesses.
    pub fn joint_stiffness_bound(&self) -> f64 {
        use super::constitutive::{Constitutive, ContactLaw};
        let joint_number = |m: u32| Constitutive::from_number(m).is_some_and(|c| c.contact == ContactLaw::Joint);
        let stiffness = |m: u32| {
            let j = &self.material(m).joint;
            if j.kn > 0.0 && j.ks > 0.0 {
                j.kn.max(j.ks)
            } else {
                0.0
            }
        };
        let mut k_per_length: f64 = 0.0;
        for b in &self.blocks {
            if joint_number(b.constitutive) {
                k_per_length = k_per_length.max(stiffness(b.material));
            }
        }
        for c in &self.corners {
            if c.edge_material != 0 && joint_number(c.edge_constitutive.max(1)) {
                k_per_length = k_per_length.max(stiffness(c.edge_material));
            }
        }
        let mut k: f64 = 0.0;
        for c in &self.contacts {
            if c.joint_length > 0.0 {
                k = k.max(stiffness(c.material) * c.joint_length);
            }
        }
        if k_per_length > 0.0 {
            let longest = self.corners.iter().map(|c| c.edge_length).fold(0.0, f64::max);
            k = k.max(k_per_length * 0.5 * longest);
        }
        k
    }

    /// Every term of the energy ledger now (see [`Energies`]): per-element accumulators summed
    /// in storage order, plus the terms of removed elements.
    pub fn energies(&self) -> Energies {
        let mut e = self.live_energies();
        e.mass_damping += self.retired.mass_damping;
        e.contact_damping += self.retired.contact_damping;
        e.friction += self.retired.friction;
        e.released += self.retired.released;
        e
    }

    /// VELOCITY: gives the free blocks `blocks` the velocity `velocity` and the angular velocity
    /// `angular`, and returns the change this makes in the ledger's kinetic energy (the input it
    /// books as external work): the kinetic sums of `energies` after and before, both taken in
    /// one pass over the blocks, in the ledger's order (so the difference is bit for bit theirs).
    pub fn set_velocities(&mut self, blocks: &[usize], velocity: [f64; 2], angular: f64) -> f64 {
        let dt = self.timestep;
        let mut given = vec![false; self.blocks.len()];
        for &b in blocks {
            given[b] = true;
        }
        let (mut before, mut after) = (0.0, 0.0);
        for (b, given) in self.blocks.iter_mut().zip(given) {
            if let Some(k) = kinetic_at_t(b, dt) {
                before += k;
            }
            if given && !b.fixed {
                b.velocity = velocity;
                b.angular_velocity = angular;
            }
            if let Some(k) = kinetic_at_t(b, dt) {
                after += k;
            }
        }
        // The strain modes' share, which the command leaves as it was.
        for (b, s) in self.blocks.iter().zip(&self.sdef).filter(|(b, _)| b.kind == super::BlockKind::SimplyDeformable) {
            if let Some(k) = strain_kinetic_at_t(b, s, dt) {
                before += k;
                after += k;
            }
        }
        after - before
    }
}

/// A free block's kinetic energy at t, as the ledger takes it (None for a fixed or massless
/// block). Velocities live at t − Δt/2, positions and forces at t: half a step of the current
/// force brings the velocity to t, so that kinetic and strain energy are taken at the same
/// instant (otherwise an oscillation shows an O(ωΔt) swing in the ledger; free flight becomes
/// exact).
fn kinetic_at_t(b: &Block, dt: f64) -> Option<f64> {
    if b.fixed || b.mass <= 0.0 {
        return None;
    }
    let h = 0.5 * dt;
    let vx = b.velocity[0] + b.force[0] / b.mass * h;
    let vy = b.velocity[1] + b.force[1] / b.mass * h;
    let w = b.angular_velocity + if b.inertia > 0.0 { b.moment / b.inertia * h } else { 0.0 };
    let at_t = 0.5 * b.mass * (vx * vx + vy * vy) + 0.5 * b.inertia * w * w;
    // Where that half step overflows f64 (a FRACTION of 1e300, a load of 1e300: the run stops
    // at its first step, or a block freed after a CYCLE 0 is deleted), the energy at t − Δt/2,
    // which the state holds, keeps the ledger a number.
    Some(if at_t.is_finite() { at_t } else { b.kinetic_energy() })
}

/// The kinetic energy at t of a free simply-deformable block's strain modes (None for a fixed
/// one): the strain rate brought to the whole step as the velocities are.
fn strain_kinetic_at_t(b: &Block, s: &super::sdef::Sdef, dt: f64) -> Option<f64> {
    if b.fixed {
        return None;
    }
    let j = super::sdef::strain_inertia(s.moments, b.rotation);
    let rate = super::sdef::rate_at_whole_step(s, b.area, j, dt);
    let at_t = super::sdef::internal_kinetic_energy(rate, j);
    Some(if at_t.is_finite() { at_t } else { super::sdef::internal_kinetic_energy(s.strain_rate, j) })
}

impl Model {
    /// An estimate of the largest stable FRACTION for the current contact network. Central
    /// differences are stable for Δt < 2/ω_max; ω_max² is bounded (Gershgorin, on the
    /// mass-normalised stiffness) by the largest per-block row sum: each force-carrying contact of
    /// stiffness k = max(kn, ks) adds k·(a_i + √(a_i a_j)) to block i, with a = 1/m + r²/I the
    /// block's compliance at the contact point (r from its centroid) and a_j = 0 for a fixed
    /// neighbour; stiffness-proportional damping narrows the limit (below). FRAC scales UDEC's
    /// 2√(m_min/k_max). Measured against the threshold of
    /// instability by `blockdem verify` (README): 0.4–0.7 of it on the scenes there.
    pub fn stable_frac_estimate(&self) -> f64 {
        let mut per_block = vec![0.0f64; self.blocks.len()];
        let compliance = |b: usize, p: [f64; 2]| -> f64 {
            let blk = &self.blocks[b];
            if blk.fixed || blk.mass <= 0.0 {
                return 0.0;
            }
            // A zoned block gives at a contact as its lightest boundary grid point at most.
            if let Some(f) = self.fdef_of(b).filter(|f| !f.zones.is_empty()) {
                return 1.0 / f.least_boundary_mass();
            }
            let r2 = (p[0] - blk.centroid[0]).powi(2) + (p[1] - blk.centroid[1]).powi(2);
            // A simply-deformable block gives at a point r from its centroid through its strain
            // modes too: at most r²/M_min, M_min its smaller principal second moment (`model::sdef`).
            let strain = match self.sdef_of(b) {
                Some(s) if super::sdef::least_moment(s.moments) > 0.0 => r2 / super::sdef::least_moment(s.moments),
                _ => 0.0,
            };
            1.0 / blk.mass + if blk.inertia > 0.0 { r2 / blk.inertia } else { 0.0 } + strain
        };
        for c in &self.contacts {
            // The mirror copy of a corner–corner touch carries no force.
            if !self.counts_force(c) {
                continue;
            }
            let m = super::constitutive::law_parameters(c.joint_length, self.material(c.material));
            let k = m.kn.max(m.ks);
            let (b1, b2) = (c.block1 as usize, c.block2 as usize);
            let (a1, a2) = (compliance(b1, c.point), compliance(b2, c.point));
            let shared = (a1 * a2).sqrt();
            if a1 > 0.0 {
                per_block[b1] += k * (a1 + shared);
            }
            if a2 > 0.0 {
                per_block[b2] += k * (a2 + shared);
            }
        }
        // The strain modes' own stiffness, k_int/J, on the row of each free SDEF block.
        for (b, blk) in self.blocks.iter().enumerate() {
            if let Some(s) = self.sdef_of(b).filter(|s| !blk.fixed && super::sdef::least_moment(s.moments) > 0.0) {
                per_block[b] += super::sdef::internal_stiffness(&self.material(blk.material).block, blk.area) / super::sdef::least_moment(s.moments);
            }
        }
        let lambda = per_block.iter().cloned().fold(0.0, f64::max);
        let base = match self.critical_timestep() {
            Some(dt) if self.frac > 0.0 => dt / self.frac,
            _ => return f64::NAN,
        };
        if lambda <= 0.0 {
            return f64::NAN;
        }
        // Stiffness-proportional damping: the contact dashpots −β·k·v act on the velocities of
        // the last half step, which narrows the stable range of central differences to
        // Δt ≤ (2/ω)(√(1+ξ²) − ξ) with ξ = βω/2 (written as 2/(ω(√(1+ξ²) + ξ)) to keep its
        // digits for large ξ). Mass damping, centred in the law of motion (CON1/CON2), leaves it.
        let omega = lambda.sqrt();
        let xi = 0.5 * self.damping.beta * omega;
        (2.0 / (omega * ((1.0 + xi * xi).sqrt() + xi))) / base
    }
}
