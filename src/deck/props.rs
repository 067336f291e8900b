//! PROPERTY's keywords, one table for both engines' languages (Appendix A's list; Appendix B's
//! D3 takes the same keys less the fluid's, which its parser refuses by name): the key, its
//! name and minimum abbreviation, and what values it takes.

use super::lexer::{name, Name};

/// PROPERTY keywords (Appendix A table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PropKey {
    Bulk,
    Shear,
    Density,
    Kn,
    Ks,
    Cohesion,
    Friction,
    Jkn,
    Jks,
    Jcohesion,
    Jfriction,
    Tf,
    Jperm,
    Cperm,
    Azero,
    Ares,
}

/// PROPERTY keywords; `None` is MATERIAL, which must come first.
pub const PROP_KEYS: &[Name<Option<PropKey>>] = &[
    name("MATERIAL", "M", None),
    name("BULK", "B", Some(PropKey::Bulk)),
    name("K", "K", Some(PropKey::Bulk)),
    name("G", "G", Some(PropKey::Shear)),
    name("DENSITY", "D", Some(PropKey::Density)),
    name("KN", "KN", Some(PropKey::Kn)),
    name("KS", "KS", Some(PropKey::Ks)),
    name("COHESION", "C", Some(PropKey::Cohesion)),
    name("FRICTION", "F", Some(PropKey::Friction)),
    name("JKN", "JKN", Some(PropKey::Jkn)),
    name("JKS", "JKS", Some(PropKey::Jks)),
    name("JCOHESION", "JC", Some(PropKey::Jcohesion)),
    name("JFRICTION", "JF", Some(PropKey::Jfriction)),
    name("TF", "T", Some(PropKey::Tf)),
    name("JPERM", "JP", Some(PropKey::Jperm)),
    name("CPERM", "CP", Some(PropKey::Cperm)),
    name("AZERO", "AZ", Some(PropKey::Azero)),
    name("ARES", "AR", Some(PropKey::Ares)),
];

impl PropKey {
    /// The quantity, as the 2D language's messages name it.
    pub fn label(self) -> &'static str {
        match self {
            PropKey::Bulk => "the bulk modulus",
            PropKey::Shear => "the shear modulus",
            PropKey::Density => "density",
            PropKey::Kn => "kn",
            PropKey::Ks => "ks",
            PropKey::Jkn => "jkn",
            PropKey::Jks => "jks",
            PropKey::Cohesion => "cohesion",
            PropKey::Friction => "friction",
            PropKey::Jcohesion => "jcohesion",
            PropKey::Jfriction => "jfriction",
            PropKey::Tf => "tf",
            PropKey::Jperm => "jperm",
            PropKey::Cperm => "cperm",
            PropKey::Azero => "azero",
            PropKey::Ares => "ares",
        }
    }

    /// Moduli, density and stiffnesses must be above zero; the others 0 or more.
    pub fn must_be_positive(self) -> bool {
        matches!(self, PropKey::Bulk | PropKey::Shear | PropKey::Density | PropKey::Kn | PropKey::Ks | PropKey::Jkn | PropKey::Jks)
    }

    /// The fluid flow's keys (Appendix A ¶6–9), which D3 has no use for.
    pub fn is_fluid(self) -> bool {
        matches!(self, PropKey::Jperm | PropKey::Cperm | PropKey::Azero | PropKey::Ares)
    }
}
