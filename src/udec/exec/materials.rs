//! The commands that set materials: PROPERTY, DAMPING; and the checks of the material and
//! constitutive numbers that BLOCK, CHANGE and SPLIT name, and of the masses a material gives.

use super::{Executor, RunError, MAX_CONSTITUTIVE};
use crate::udec::deck::{DampMode, Located, PropKey};
use crate::udec::model::constitutive::{Constitutive, ContactLaw};

impl Executor<'_> {
    /// The joints' properties before a CYCLE (Appendix A ¶5): a block or a SPLIT tag whose
    /// constitutive number gives joints (2, 4, 5) needs its material's joint stiffnesses JKN and
    /// JKS, both or neither. With neither, its joints follow the point-contact law on KN, KS,
    /// COHESION and FRICTION ("UDEC will still refer to contact parameters"; sample 4 gives
    /// CONS=4 and no JKN): said once per material. With neither and no KN either, an error that
    /// names JKN. Only CYCLE can tell: PROPERTY may come after BLOCK, CHANGE or SPLIT.
    // `!(x > 0.0)` on purpose: a NaN stiffness fails the check too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub(super) fn check_joints(&mut self, cmd: &Located) -> Result<(), RunError> {
        let joint_number = |c: u32| Constitutive::from_number(c).is_some_and(|k| k.contact == ContactLaw::Joint);
        let mut users: Vec<(u32, u32, String)> = Vec::new();
        for b in self.model.blocks.iter().filter(|b| joint_number(b.constitutive)) {
            if !users.iter().any(|u| u.0 == b.material) {
                users.push((b.material, b.constitutive, format!("block {}", b.id)));
            }
        }
        for c in self.model.corners.iter().filter(|c| c.edge_material != 0 && joint_number(c.edge_constitutive.max(1))) {
            if !users.iter().any(|u| u.0 == c.edge_material) {
                users.push((c.edge_material, c.edge_constitutive, "a joint of SPLIT MAT= CONS=".to_string()));
            }
        }
        for (m, cons, what) in users {
            let mat = *self.model.material(m);
            let (jkn, jks) = (mat.joint.kn > 0.0, mat.joint.ks > 0.0);
            let whose = format!("material {m} of {what} (constitutive number {cons}: joints, SL-85-1 Appendix A paragraph 5)");
            if jkn != jks {
                let (given, missing) = if jkn { ("JKN", "JKS") } else { ("JKS", "JKN") };
                return Err(self.command_error(
                    cmd,
                    format!("CYCLE: {whose} gives {given} but not {missing}: a joint needs both joint stiffnesses JKN and JKS (stress/displacement)"),
                ));
            }
            if jkn {
                continue;
            }
            if !(mat.contact.kn > 0.0) {
                return Err(self.command_error(
                    cmd,
                    format!(
                        "CYCLE: JKN missing: {whose} needs the joint stiffnesses JKN and JKS (stress/displacement, PROPERTY MAT={m} JKN=… JKS=…), \
                         and the contact stiffnesses KN and KS, which a joint falls back on"
                    ),
                ));
            }
            if !self.joint_fallback_noted.contains(&m) {
                self.joint_fallback_noted.push(m);
                self.echo(&format!(
                    "NOTE: {whose} has no joint stiffnesses JKN, JKS: its joints follow the point-contact law (KN, KS, COHESION, FRICTION), \
                     as UDEC did (\"UDEC will still refer to contact parameters\")"
                ));
            }
        }
        Ok(())
    }

    /// A material number a command names must be one PROPERTY can define (UDEC's NMAT slots):
    /// a BLOCK, CHANGE or SPLIT of material 25 was taken, and CYCLE then asked for a PROPERTY
    /// MAT=25 that PROPERTY refused.
    pub(super) fn check_material(&self, cmd: &Located, what: &str, material: Option<u32>) -> Result<(), RunError> {
        match material {
            Some(m) if m == 0 || m as usize > crate::udec::model::MAX_MATERIALS => {
                Err(self.command_error(cmd, format!("{what}: material number must be 1 to {}, found {m}", crate::udec::model::MAX_MATERIALS)))
            }
            _ => Ok(()),
        }
    }

    /// Constitutive numbers are those SL-85-1 defines: 1 to 4 of Table A1, and 5, which its
    /// paragraphs 5 and 17 name for joint contacts with Griffith cracking (run as 4). Any other
    /// number would run as one of these without saying so.
    pub(super) fn check_constitutive(&self, cmd: &Located, what: &str, constitutive: Option<u32>) -> Result<(), RunError> {
        match constitutive {
            Some(c) if Constitutive::from_number(c).is_none() => Err(self.command_error(
                cmd,
                format!(
                    "{what}: constitutive number must be 1 to {MAX_CONSTITUTIVE} (SL-85-1 Table A1: 1 point-load cracking and point \
                     contacts, 2 point-load and joints, 3 Griffith and point contacts, 4 and 5 Griffith and joints), found {c}"
                ),
            )),
            _ => Ok(()),
        }
    }

    /// The error for the first of `blocks` whose mass or moment of inertia (density × area, ×
    /// polar moment) overflows f64: CYCLE took an infinite mass for "no time step", and a SAVE
    /// wrote a model RESTART refuses. The caller undoes its command, which fails whole.
    pub(super) fn mass_overflow(&self, cmd: &Located, what: &str, mut blocks: impl Iterator<Item = usize>) -> Option<RunError> {
        let b = blocks.find(|&b| !(self.model.blocks[b].mass.is_finite() && self.model.blocks[b].inertia.is_finite()))?;
        let blk = &self.model.blocks[b];
        let density = self.model.material(blk.material).block.density;
        Some(self.command_error(
            cmd,
            format!(
                "{what}: the mass of block {} (density {density:e} of material {} × area {:e}) or its moment of inertia overflows f64; \
                 check DENSITY and the units of lengths",
                blk.id, blk.material, blk.area
            ),
        ))
    }

    /// PROPERTY MAT n key value …: the keywords of SL-85-1 Appendix A, each into its group of
    /// `Material`. A material whose density then overflows a block's mass is left as it was.
    pub(super) fn property(&mut self, cmd: &Located, material: u32, values: &[(PropKey, f64)]) -> Result<(), RunError> {
        use PropKey::*;
        self.check_material(cmd, "PROPERTY", Some(material))?;
        let before = self.model.materials[material as usize - 1];
        let m = &mut self.model.materials[material as usize - 1];
        for &(key, v) in values {
            match key {
                Bulk => m.block.bulk = v,
                Shear => m.block.shear = v,
                Density => m.block.density = v,
                Kn => m.contact.kn = v,
                Ks => m.contact.ks = v,
                Cohesion => m.contact.cohesion = v,
                Friction => m.contact.friction = v,
                Jkn => m.joint.kn = v,
                Jks => m.joint.ks = v,
                Jcohesion => m.joint.cohesion = v,
                Jfriction => m.joint.friction = v,
                Tf => m.block.tf = v,
                Jperm => m.fluid.jperm = v,
                Cperm => m.fluid.cperm = v,
                Azero => m.fluid.azero = v,
                Ares => m.fluid.ares = v,
            }
        }
        self.model.recompute_mass_properties();
        if let Some(e) = self.mass_overflow(cmd, "PROPERTY", 0..self.model.blocks.len()) {
            self.model.materials[material as usize - 1] = before;
            self.model.recompute_mass_properties();
            return Err(e);
        }
        Ok(())
    }

    /// DAMPING fcrit freq [MASS|STIFFNESS|INTERNAL].
    pub(super) fn damping(&mut self, cmd: &Located, fcrit: f64, freq: f64, mode: DampMode) -> Result<(), RunError> {
        // Rayleigh damping with its minimum ξ at the centre frequency ω = 2πf:
        // α = ξω (mass-proportional), β = ξ/ω (stiffness-proportional), so that
        // ξ(ω) = ½(α/ω + βω) equals fcrit there. MASS and STIFFNESS drop one term, as
        // UDEC 1.2 did ("STIFFNESS-DAMPING TERM SET TO ZERO").
        let omega = 2.0 * std::f64::consts::PI * freq;
        let (alpha, beta) = (fcrit * omega, fcrit / omega);
        // At the ends of f64 (DAMP 0 1E308: ω overflows and α = 0·∞) a constant is not a
        // number: the run would diverge at once, and its saves could not be restarted.
        let kept = match mode {
            DampMode::Full => [alpha, beta],
            DampMode::Mass | DampMode::Internal => [alpha, 0.0],
            DampMode::Stiffness => [0.0, beta],
        };
        if !kept.iter().all(|x| x.is_finite()) {
            return Err(self.command_error(
                cmd,
                format!(
                    "DAMPING: fcrit {fcrit:e} at freq {freq:e} gives the damping constants α = ξω = {alpha:e} and β = ξ/ω = {beta:e}, \
                     which are not finite numbers; give fcrit and freq in ordinary ranges (fcrit about 0 to 1, freq the model's frequency in Hz)"
                ),
            ));
        }
        match mode {
            DampMode::Full => {
                self.model.damping.alpha = alpha;
                self.model.damping.beta = beta;
            }
            DampMode::Mass => {
                self.model.damping.alpha = alpha;
                self.model.damping.beta = 0.0;
                self.echo("STIFFNESS-DAMPING TERM SET TO ZERO");
            }
            DampMode::Stiffness => {
                self.model.damping.alpha = 0.0;
                self.model.damping.beta = beta;
                self.echo("MASS-DAMPING TERM SET TO ZERO");
            }
            DampMode::Internal => {
                self.model.damping.alpha_internal = alpha;
                self.echo("NOTE - ONLY MASS-DAMPING USED");
            }
        }
        Ok(())
    }
}
