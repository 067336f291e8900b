//! Domains: the voids between blocks (SL-85-1 Appendix A ¶6–9; the Program Guide's domain group
//! MDOM, its list IDPNT, the outer domain IODPNT and the minimum area DAMIN).
//!
//! In two dimensions the void spaces share the circulating lists that describe the blocks (report
//! ¶28): walking along block boundaries from contact to contact with the void always on the same
//! side traces one void. Each such circuit is a domain: a *regular* domain (an enclosed void), a
//! *joint* domain (the sliver between the two contacts of an edge-to-edge contact, ¶7) or the
//! *outer* domain, everything outside the assembly, of which there is one.
//!
//! Domains are derived data: `topology::domain` builds them from the blocks, corners and contacts,
//! and rebuilds them after the topology changes. They exist only in a scene that asks for them
//! (`Model::domains` is `None` otherwise), so a rigid scene that never prints them or carries
//! fluid pays nothing. This module holds what a built set is; the building is stage 7's.

use serde::{Deserialize, Serialize};

/// The default minimum area of a domain as a fraction of the average block area: the report's
/// A_d(min), "a small fraction of average block areas" (¶7), which bounds the area of every domain
/// used by the fluid calculation from below, and is the area of a joint domain whose aperture is
/// not known.
pub const MIN_AREA_FRACTION: f64 = 1.0e-3;

/// Marks "no domain" in [`Domains::sides`]: the view of a touch of two corners that does not carry
/// its force, whose touch the other view already stands for.
pub const NO_DOMAIN: u32 = u32::MAX;

/// Bit 1 of [`Domains::link_sides`]: the link opens a closed loop of the domain's boundary (its
/// own circuit, or that of a group of blocks floating in it).
pub const LOOP_START: u8 = 2;

/// The fluid's view of one contact in the last cycle (Appendix A ¶6, PRINT FLOWS).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ContactFlow {
    /// Flow from the contact's first domain (`Domains::sides[k][0]`) to its second, volume per
    /// unit time per unit thickness.
    pub flow: f64,
    /// The hydraulic aperture a = max(a_res, a_0 − σn′/k_n,j) of a joint; 0 for a point contact.
    pub aperture: f64,
    /// The length of joint the flow runs along (the contact's share l_c); 0 for a point contact.
    pub length: f64,
}

/// What a domain is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DomainKind {
    /// An enclosed void between blocks (its area is the void's).
    #[serde(rename = "regular")]
    Regular,
    /// The void between the two contacts of an edge-to-edge contact (¶7: A_d = a_j·l_j).
    #[serde(rename = "joint")]
    Joint,
    /// Everything outside the assembly (the report's IODPNT), unbounded.
    #[serde(rename = "outer")]
    Outer,
}

impl DomainKind {
    /// The word the state JSON uses: "regular", "joint", "outer".
    pub fn name(self) -> &'static str {
        match self {
            DomainKind::Regular => "regular",
            DomainKind::Joint => "joint",
            DomainKind::Outer => "outer",
        }
    }
}

/// One domain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    /// Stable id shown by PRINT: kept by a rebuild for the domain that has the most contacts in
    /// common with one before it (the same void), never reused for another.
    pub id: u32,
    pub kind: DomainKind,
    /// The area the fluid calculation uses (VOLUME per unit thickness): the void's area for a
    /// regular domain, a·l for a joint domain, never below [`Domains::min_area`]; 0 for the outer
    /// domain, which has none.
    pub area: f64,
    /// The area enclosed by the traced boundary (less the blocks of any group that floats inside
    /// it): what `area` is for a regular domain before the minimum; the sliver's for a joint;
    /// for the outer domain, minus the area inside its circuits (the assembly's outline). Over
    /// all domains these add up to minus the blocks' area: each piece of block boundary bounds
    /// exactly one domain.
    pub void_area: f64,
    /// A joint domain's length l_j: the distance between its two contacts; 0 for other kinds.
    pub length: f64,
    /// Pore pressure (0 until fluid flows).
    pub pressure: f64,
    /// Whether the pressure is held (PFIX).
    pub fixed: bool,
    /// The largest distance any block around the domain has moved since its last contact update
    /// (`Block::moved_since_update`): UDEC's domain displacement, measured against ETOL.
    pub max_displacement: f64,
    /// The domain's boundary, `Domains::links[link_start .. link_start + link_count]`.
    pub link_start: u32,
    pub link_count: u32,
}

/// One item of a domain's boundary, in the order the circuit passes it (PRINT DLIST).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DomainLink {
    /// A contact the circuit crosses from one block to the next: its index in `Model::contacts`
    /// when the domains were built, and its id.
    Contact { index: u32, id: u32 },
    /// A block corner the circuit passes (global index into `Model::corners`).
    Corner { corner: u32 },
}

/// The domains of a model, as built from its lists.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Domains {
    /// Ordered by id.
    pub list: Vec<Domain>,
    pub links: Vec<DomainLink>,
    /// Beside each of `links`: for a contact, the side whose dart starts the piece of block
    /// boundary that follows it (bit 0: 0 block 1, 1 block 2); [`LOOP_START`] on the first link of
    /// each closed loop.
    pub link_sides: Vec<u8>,
    /// For each contact (indexed like `Model::contacts` when built) the indices in `list` of the
    /// domains on its two sides: first the side the circuit leaves along block 1, then along
    /// block 2 (both the same for a contact with one void around it). A flow across the contact
    /// goes between them. [`NO_DOMAIN`] twice for the second view of a corner pair.
    pub sides: Vec<[u32; 2]>,
    /// A_d(min), the smallest area a domain is given (DAMIN): `given_min_area` when SET DAMIN
    /// gave one, otherwise [`MIN_AREA_FRACTION`] of the average block area.
    pub min_area: f64,
    /// The minimum area SET DAMIN gave, kept by every rebuild.
    pub given_min_area: Option<f64>,
    /// The id the next new domain gets.
    pub next_id: u32,
    /// With fluid, each contact's flow in the last cycle (indexed like `sides`); empty without.
    pub flows: Vec<ContactFlow>,
}

impl Domains {
    /// Domain `d`'s boundary, in circuit order.
    pub fn links_of(&self, d: &Domain) -> &[DomainLink] {
        let start = d.link_start as usize;
        self.links.get(start..start + d.link_count as usize).unwrap_or(&[])
    }

    /// The outer domain.
    pub fn outer(&self) -> Option<&Domain> {
        self.list.iter().find(|d| d.kind == DomainKind::Outer)
    }

    /// Index in `list` of the domain with id `id`.
    pub fn index_of(&self, id: u32) -> Option<usize> {
        self.list.binary_search_by_key(&id, |d| d.id).ok()
    }
}
