//! The constitutive number of a block, a contact or a joint tag (COns m of BLOCK, SPLIT and
//! CHANGE), decoded in this one place into the laws it selects (SL-85-1 Appendix A, Table A1,
//! and paragraphs 5 and 17):
//!
//! | m | cracking of the block | contact law |
//! |---|---|---|
//! | 1 | point load, (f1 + f2)/(2d²) ≥ t_f (¶15–16) | point contacts |
//! | 2 | point load | joints (a length and a stress-based stiffness) |
//! | 3 | Griffith, from the block's internal stresses (¶17) | point contacts |
//! | 4 | Griffith | joints |
//! | 5 | Griffith | joints (¶5 and ¶17 name it; run as 4) |
//!
//! How a block deforms (rigid, simply- or fully-deformable) is not in the number: CHANGE SDEF /
//! FDEF sets it ([`super::BlockKind`]). Griffith cracking reads the stresses that only a
//! deformable block has ([`Constitutive::needs_block_stress`]). The model stores the number
//! itself, as the deck gave it (PRINT, the state JSON and SAVE files show it).

/// How a block cracks once its material has a tensile strength factor t_f (TF).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CrackingLaw {
    /// Between two opposing contact forces (Appendix A ¶15–16; `topology::cracking`).
    PointLoad,
    /// From the block's internal stresses (Appendix A ¶17).
    Griffith,
}

impl CrackingLaw {
    /// The name of the criterion's value, as the cycle log prints it beside a crack.
    pub fn label(self) -> &'static str {
        match self {
            CrackingLaw::PointLoad => "POINT-LOAD VALUE",
            CrackingLaw::Griffith => "GRIFFITH STRESS",
        }
    }
}

/// The force–displacement law of a contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactLaw {
    /// A corner against a boundary, stiffnesses in force/displacement (eqs. 16–20).
    Point,
    /// An edge against an edge with a length, stiffnesses in stress/displacement.
    Joint,
}

/// The laws a constitutive number selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Constitutive {
    pub cracking: CrackingLaw,
    pub contact: ContactLaw,
}

impl Constitutive {
    /// The largest constitutive number the report defines.
    pub const MAX: u32 = 5;

    /// The laws of number `m`, or `None` for a number the report does not define (0 is a joint
    /// tag's "none", see `Corner::edge_constitutive`).
    pub fn from_number(m: u32) -> Option<Constitutive> {
        use {ContactLaw::*, CrackingLaw::*};
        let (cracking, contact) = match m {
            1 => (PointLoad, Point),
            2 => (PointLoad, Joint),
            3 => (Griffith, Point),
            4 | 5 => (Griffith, Joint),
            _ => return None,
        };
        Some(Constitutive { cracking, contact })
    }

    /// Whether the cracking law reads the block's internal stresses (which a rigid block has not).
    pub fn needs_block_stress(self) -> bool {
        self.cracking == CrackingLaw::Griffith
    }
}

use super::{ContactMaterial, Material};

/// The force–displacement law's parameters of a contact carrying `joint_length` of joint
/// (`Contact::joint_length`): for a joint JKN·l_c, JKS·l_c, JCOH·l_c and JFRIC (the stresses of
/// ¶5 over its share of the joint), for a point contact the material's KN, KS, COHESION and
/// FRICTION, as they are. The model's energies, the time step and
/// the force law (`contact::law`) read it; the GPU's twin is `contact_law` in `shaders/udec/layout.wgsl`.
#[inline]
pub fn law_parameters(joint_length: f64, mat: &Material) -> ContactMaterial {
    if joint_length > 0.0 {
        let j = &mat.joint;
        ContactMaterial { kn: j.kn * joint_length, ks: j.ks * joint_length, cohesion: j.cohesion * joint_length, friction: j.friction }
    } else {
        mat.contact
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table A1 row by row, and nothing outside 1..=5.
    #[test]
    fn numbers_decode_as_table_a1() {
        let laws: Vec<_> = (0..=6).map(Constitutive::from_number).collect();
        let row = |cracking, contact| Some(Constitutive { cracking, contact });
        use {ContactLaw::*, CrackingLaw::*};
        assert_eq!(laws, [None, row(PointLoad, Point), row(PointLoad, Joint), row(Griffith, Point), row(Griffith, Joint), row(Griffith, Joint), None]);
    }
}
