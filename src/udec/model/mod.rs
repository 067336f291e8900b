//! The authoritative model (CPU, f64): blocks with their corners, contacts with their feature ids,
//! materials and the global settings of a run (SL-85-1, Appendix A, "Program Guide").
//!
//! Only the CPU changes topology (DESIGN.md §2): blocks are created by BLOCK and SPLIT, removed by
//! DELETE, cracked by the point-load criterion; contacts are created and dropped by the topology
//! stage between cycles. Kernels (CPU or GPU) only move blocks and update contact forces.
//!
//! Storage is flat: `Model::blocks` and `Model::corners` are plain vectors, each block owning the
//! contiguous corner range `corner_start .. corner_start + corner_count` (counter-clockwise). Hot
//! loops use indices; `Block::id` and `Contact::id` are stable numbers for PRINT that never change
//! when other blocks are deleted.

pub mod build;
pub mod constitutive;
pub mod corners;
pub mod domain;
pub mod fdef;
pub mod fluid;
pub mod geometry;
pub mod limits;
pub mod sdef;
pub mod split;
pub mod timestep;
pub mod zoning;

use constitutive::ContactLaw;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Number of material slots (UDEC's NMAT); materials are numbered 1..=MAX_MATERIALS.
pub const MAX_MATERIALS: usize = 20;

/// Where material `n` is stored in a table of `count` materials: at n − 1, 0 read as 1 (no
/// material given), past the table as its last.
#[inline]
pub fn material_slot(n: u32, count: usize) -> usize {
    (n.max(1) as usize - 1).min(count - 1)
}

/// Default rounding length DTOL when no ROUND command is given (problem units).
pub const DEFAULT_ROUND: f64 = 0.5;

/// Material properties (PROPERTY command; Appendix A "Property keywords"), in the groups that read
/// them: the block's, a point contact's, a joint's and the fluid's. One material number carries
/// all four (a block's material gives its contacts theirs). SAVE files keep the flat field order
/// of [`MaterialRecord`], so files written before the split restart unchanged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "MaterialRecord", into = "MaterialRecord")]
pub struct Material {
    pub block: BlockMaterial,
    pub contact: ContactMaterial,
    pub joint: JointMaterial,
    pub fluid: FluidMaterial,
}

/// What the block itself reads of its material.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BlockMaterial {
    /// Mass density ρ (DENSITY).
    pub density: f64,
    /// Bulk modulus K (BULK, B or K), for deformable blocks.
    pub bulk: f64,
    /// Shear modulus (G), for deformable blocks.
    pub shear: f64,
    /// Tensile strength factor t_f (TF): point-load or Griffith cracking of the block (Appendix A
    /// ¶15–17; which one, the block's constitutive number says).
    pub tf: f64,
}

/// The law of a point contact (eqs. 16–20), in force/displacement units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactMaterial {
    /// Normal stiffness kn (KN, force/displacement).
    pub kn: f64,
    /// Shear stiffness ks (KS, force/displacement).
    pub ks: f64,
    /// Cohesion c (COHESION, force): shear strength at zero normal force, and the tension an intact
    /// contact holds.
    pub cohesion: f64,
    /// Friction coefficient μ (FRICTION).
    pub friction: f64,
}

/// The law of a joint (constitutive numbers 2, 4 and 5), in stress/displacement units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointMaterial {
    /// Normal stiffness (JKN, stress/displacement).
    pub kn: f64,
    /// Shear stiffness (JKS, stress/displacement).
    pub ks: f64,
    /// Cohesion (JCOHESION, stress).
    pub cohesion: f64,
    /// Friction coefficient (JFRICTION).
    pub friction: f64,
}

/// Flow along joints and contacts (Appendix A, fluid).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FluidMaterial {
    /// Joint permeability factor (JPERM).
    pub jperm: f64,
    /// Contact permeability factor (CPERM).
    pub cperm: f64,
    /// Aperture at zero normal stress (AZERO).
    pub azero: f64,
    /// Residual aperture (ARES).
    pub ares: f64,
}

/// A [`Material`] as SAVE files hold it: the flat field order of the format's first version
/// (postcard writes fields in order, without names). Only serialization uses it.
#[derive(Clone, Copy, Serialize, Deserialize)]
pub struct MaterialRecord {
    density: f64,
    bulk: f64,
    shear: f64,
    kn: f64,
    ks: f64,
    cohesion: f64,
    friction: f64,
    jkn: f64,
    jks: f64,
    jcohesion: f64,
    jfriction: f64,
    tf: f64,
    jperm: f64,
    cperm: f64,
    azero: f64,
    ares: f64,
}

impl From<MaterialRecord> for Material {
    fn from(r: MaterialRecord) -> Self {
        let MaterialRecord { density, bulk, shear, kn, ks, cohesion, friction, jkn, jks, jcohesion, jfriction, tf, jperm, cperm, azero, ares } = r;
        Material {
            block: BlockMaterial { density, bulk, shear, tf },
            contact: ContactMaterial { kn, ks, cohesion, friction },
            joint: JointMaterial { kn: jkn, ks: jks, cohesion: jcohesion, friction: jfriction },
            fluid: FluidMaterial { jperm, cperm, azero, ares },
        }
    }
}

impl From<Material> for MaterialRecord {
    fn from(m: Material) -> Self {
        let Material {
            block: BlockMaterial { density, bulk, shear, tf },
            contact: ContactMaterial { kn, ks, cohesion, friction },
            joint: JointMaterial { kn: jkn, ks: jks, cohesion: jcohesion, friction: jfriction },
            fluid: FluidMaterial { jperm, cperm, azero, ares },
        } = m;
        MaterialRecord { density, bulk, shear, kn, ks, cohesion, friction, jkn, jks, jcohesion, jfriction, tf, jperm, cperm, azero, ares }
    }
}

/// How a block deforms (UDEC head codes MRIG, MSDEF, MFDEF). Serialized under the words of
/// [`BlockKind::name`], so that DUMP says what the state JSON does (save files keep the
/// variant's index, not its name).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BlockKind {
    #[serde(rename = "rigid")]
    Rigid,
    #[serde(rename = "sdef")]
    SimplyDeformable,
    #[serde(rename = "fdef")]
    FullyDeformable,
}

impl BlockKind {
    /// The word the state JSON and PRINT use: "rigid", "sdef", "fdef".
    pub fn name(self) -> &'static str {
        match self {
            BlockKind::Rigid => "rigid",
            BlockKind::SimplyDeformable => "sdef",
            BlockKind::FullyDeformable => "fdef",
        }
    }
}

/// One polygonal block. Its shape is stored in the body frame (corner offsets from the centroid at
/// rotation 0, in `Corner::local`), so a rigid block never distorts and f32 kernels keep millimetres
/// on models far from the origin (DESIGN.md §2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Block {
    /// Stable id shown by PRINT (never reused within a run).
    pub id: u32,
    pub kind: BlockKind,
    pub material: u32,
    pub constitutive: u32,
    pub fixed: bool,
    /// First corner in `Model::corners`.
    pub corner_start: u32,
    pub corner_count: u32,
    pub area: f64,
    pub mass: f64,
    /// Polar moment of inertia about the centroid.
    pub inertia: f64,
    pub centroid: [f64; 2],
    /// Rotation since the body-frame shape was recorded (radians, counter-clockwise).
    pub rotation: f64,
    pub velocity: [f64; 2],
    pub angular_velocity: f64,
    /// Force and moment sums at the centroid from the last gather (contacts + gravity + load).
    pub force: [f64; 2],
    pub moment: f64,
    /// Static load at the centroid (LOAD command).
    pub load: [f64; 2],
    /// Largest distance from the centroid to any corner (for update tolerances).
    pub radius: f64,
    /// How far this block's corners have moved since its last contact update (the report's
    /// update-after-threshold rule, ¶26): the largest |c − c_ref| + |θ − θ_ref|·radius seen since
    /// then, a net displacement, so a block vibrating in place does not trigger updates. Set it
    /// above the tolerance to ask for an update (new pieces of a split).
    pub moved_since_update: f64,
    /// Centroid and rotation at the last contact update (the reference of `moved_since_update`).
    pub update_centroid: [f64; 2],
    pub update_rotation: f64,
    /// Extra search distance this block was given at its last contact update, for its speed
    /// (`Tolerances::speed_margin`): it was examined against blocks up to atol + its margin + the
    /// other's away, and so it may move etol + margin before it needs the next update. 0 for a
    /// block that moves less than a few millimetres a step (every block of a quiet scene).
    #[serde(default)]
    pub update_margin: f64,
    /// Energy dissipated by the mass-proportional Rayleigh damping force −α·m·v on this block
    /// since START (J, summed each step; see `law_of_motion`).
    #[serde(default)]
    pub damping_work: f64,
    /// The area of the block as the deck built it (BLOCK, SPLIT): a crack's pieces keep their
    /// parent's, so that a block cracks only while it holds at least
    /// [`crate::cracking::FRAGMENT_FLOOR`] of it (`topology::cracking`). Saved after the model
    /// (`output::restart`, format 7).
    #[serde(skip)]
    pub built_area: f64,
}

impl Block {
    /// Kinetic energy at the stored (half-step) velocities: ½ m |v|² + ½ I ω².
    pub fn kinetic_energy(&self) -> f64 {
        let [vx, vy] = self.velocity;
        0.5 * self.mass * (vx * vx + vy * vy) + 0.5 * self.inertia * self.angular_velocity * self.angular_velocity
    }

    /// How far the block's corners are from where its rigid motion put them at its last contact
    /// update at most: |c − c_ref| + |θ − θ_ref|·radius (see `moved_since_update`).
    #[inline]
    pub fn net_since_update(&self) -> f64 {
        let (ux, uy) = (self.centroid[0] - self.update_centroid[0], self.centroid[1] - self.update_centroid[1]);
        (ux * ux + uy * uy).sqrt() + (self.rotation - self.update_rotation).abs() * self.radius
    }

    /// How far this block may move from its last contact update before it needs the next one.
    #[inline]
    pub fn update_threshold(&self, tol: &Tolerances) -> f64 {
        tol.etol + self.update_margin
    }

    /// Whether this block has moved past its update threshold (fixed blocks never are).
    #[inline]
    pub fn update_due(&self, tol: &Tolerances) -> bool {
        !self.fixed && self.moved_since_update > self.update_threshold(tol)
    }

    /// How far its corners travel in one step of `dt` at its present velocity: |v|·Δt + |ω|·Δt·R
    /// (the too-fast check's measure).
    #[inline]
    pub fn travel_per_step(&self, dt: f64) -> f64 {
        (self.velocity[0] * dt).hypot(self.velocity[1] * dt) + (self.angular_velocity * dt).abs() * self.radius
    }
}

/// One rounded corner (UDEC corner data array: KXP, KYP, KXCP, KYCP, KRAD).
/// The corner's circle is tangent to both adjoining edges at distance `round` from the corner.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Corner {
    /// Owning block index.
    pub block: u32,
    /// Corner position relative to the centroid, body frame.
    pub local: [f64; 2],
    /// Centre of the rounding circle relative to the centroid, body frame.
    pub circle_local: [f64; 2],
    /// Radius of the rounding circle (0 for a re-entrant corner, which needs no rounding).
    pub radius: f64,
    /// Distance from the corner to the tangent points along its two edges (≤ the ROUND length,
    /// reduced on short edges so that two arcs never overlap).
    pub round: f64,
    /// Current world position of the corner.
    pub position: [f64; 2],
    /// Current world position of the rounding circle centre.
    pub circle: [f64; 2],
    /// Current unit direction and length of the edge from this corner to the next one (stage 2
    /// computes them once a cycle for all the contacts that measure against the edge).
    pub edge_dir: [f64; 2],
    pub edge_length: f64,
    /// Joint material and constitutive number of the edge from this corner to the next one
    /// (counter-clockwise), set by SPLIT MAT= CONS=; 0 means "take the block's".
    pub edge_material: u32,
    pub edge_constitutive: u32,
}

/// Kind of a contact, as PRINT LIST names it; serialized under the words of
/// [`ContactKind::name`], as [`BlockKind`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ContactKind {
    /// A corner of block 1 against a straight edge of block 2.
    #[serde(rename = "corner-edge")]
    CornerEdge,
    /// A corner of block 1 against a rounded corner of block 2.
    #[serde(rename = "corner-corner")]
    CornerCorner,
}

impl ContactKind {
    pub fn name(self) -> &'static str {
        match self {
            ContactKind::CornerEdge => "corner-edge",
            ContactKind::CornerCorner => "corner-corner",
        }
    }
}

/// A feature of a block's rounded boundary: corner k's arc is feature 2k, and the straight part of
/// the edge from corner k to corner k+1 is feature 2k+1. Features are local to their block.
pub type Feature = u32;

/// One contact: a corner of `block1` (the corner owner) touching the rounded boundary of `block2`
/// at feature `feature`. The normal points from block 2 into block 1; forces are those block 2
/// exerts on block 1 (compression positive), applied with opposite sign to block 2 (report ¶19).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    pub id: u32,
    pub block1: u32,
    /// Global corner index (into `Model::corners`) of block 1's corner.
    pub corner: u32,
    pub block2: u32,
    pub feature: Feature,
    pub kind: ContactKind,
    pub material: u32,
    pub constitutive: u32,
    /// True while the contact is still intact since creation in touch (it may carry tension up to
    /// the cohesion); lost for good once it opens in tension beyond cohesion or slips.
    pub bonded: bool,
    /// Current contact point (midway through the overlap).
    pub point: [f64; 2],
    /// Unit normal, from block 2 into block 1.
    pub normal: [f64; 2],
    /// Normal displacement: the gap between the rounded surfaces, overlap negative (as UDEC prints).
    pub gap: f64,
    /// Normal force, compression positive (eqs. 16, 18).
    pub normal_force: f64,
    /// Shear force along the tangent t = (−n_y, n_x) acting on block 1 (eqs. 17, 19, 20).
    pub shear_force: f64,
    /// Accumulated shear displacement of block 1 relative to block 2 along t.
    pub shear_displacement: f64,
    /// Total force on block 1 in world axes, including any stiffness-proportional damping force; the
    /// gather sums this (block 2 takes minus it).
    pub force: [f64; 2],
    /// Energy dissipated at this contact by friction (the shear force capped at the Coulomb limit
    /// working through the slip) and by bond breakage, since the contact formed.
    #[serde(default)]
    pub slip_work: f64,
    /// Energy dissipated at this contact by the stiffness-proportional dashpots β·k·v.
    #[serde(default)]
    pub dashpot_work: f64,
    /// Normal and shear relative velocities the dashpots acted on in the last step (zero when they
    /// did not act): their work is booked a step late, over the mean velocity of that step.
    #[serde(default)]
    pub dashpot_velocity: [f64; 2],
    /// The length of joint this contact carries, l_c (problem units), when it follows the joint
    /// law (Appendix A ¶5: an edge-to-edge contact between planar faces in opposition, with a
    /// joint constitutive number); 0 for a point contact. As in UDEC, the edge-to-edge contact is
    /// the two corner contacts at the ends of the faces' common length l_j, each carrying half of
    /// it: l_c = l_j/2 (`contact::joint`). Decided at each contact update (stage 7). SAVE files
    /// keep it beside the model (`output::restart`), not in the contact's own record, whose
    /// binary layout is that of the files written before joints (`readable_only`); DUMP and
    /// other readable forms show it.
    #[serde(default, with = "readable_only")]
    pub joint_length: f64,
}

/// A field that readable formats (DUMP's JSON) write and read as a number and binary ones
/// (postcard, SAVE files) as nothing at all (a unit, no bytes), so that a field added to a saved
/// struct leaves the binary layout as it was; a SAVE file that needs the value keeps it beside
/// the model (`output::restart`). Read from a binary form it is 0.
mod readable_only {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            x.serialize(s)
        } else {
            s.serialize_unit()
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        if d.is_human_readable() {
            f64::deserialize(d)
        } else {
            <()>::deserialize(d).map(|()| 0.0)
        }
    }
}

impl Contact {
    /// The law this contact follows now: the joint law while it carries a length of joint.
    #[inline]
    pub fn law(&self) -> ContactLaw {
        if self.joint_length > 0.0 {
            ContactLaw::Joint
        } else {
            ContactLaw::Point
        }
    }

    /// A contact of `corner` of `block1` against `block2` with no state yet (no feature, gap,
    /// force or history): what a read-back of its state fills in (the GPU backend's restore).
    pub fn identity(id: u32, block1: u32, corner: u32, block2: u32, material: u32, constitutive: u32) -> Contact {
        Contact {
            id,
            block1,
            corner,
            block2,
            feature: 0,
            kind: ContactKind::CornerEdge,
            material,
            constitutive,
            bonded: false,
            point: [0.0; 2],
            normal: [0.0; 2],
            gap: 0.0,
            normal_force: 0.0,
            shear_force: 0.0,
            shear_displacement: 0.0,
            force: [0.0; 2],
            slip_work: 0.0,
            dashpot_work: 0.0,
            dashpot_velocity: [0.0; 2],
            joint_length: 0.0,
        }
    }

    /// An unloaded corner–edge contact of corner 0 of `block1` against `block2`, material 1: a
    /// starting point for unit tests of the topology code.
    #[cfg(test)]
    pub(crate) fn unloaded(id: u32, block1: u32, block2: u32) -> Contact {
        Contact::identity(id, block1, 0, block2, 1, 1)
    }
}

/// Rayleigh damping (DAMPING command): mass-proportional α and stiffness-proportional β.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Damping {
    pub alpha: f64,
    pub beta: f64,
    /// Internal mass damping of simply-deformable blocks (DAMP … INTERNAL, UDEC's ALPB).
    pub alpha_internal: f64,
}

/// A LINK between a flying block and the block topologically closest to it (Appendix A ¶10).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Link {
    pub flying: u32,
    pub anchor: u32,
}

/// Tolerances of contact detection (UDEC's ATOL, BTOL, DTOL, ETOL), all derived from the rounding
/// length so that they scale with the model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tolerances {
    /// Rounding length d (ROUND).
    pub round: f64,
    /// A contact is formed when the gap is below this.
    pub atol: f64,
    /// A contact is broken when the gap exceeds this.
    pub btol: f64,
    /// A block triggers a contact update after its corners moved this far since its last one
    /// (plus its own `Block::update_margin`). Two blocks each below it approach by less than
    /// 2·etol < atol, so no contact can be missed.
    pub etol: f64,
    /// Steps of its current travel a fast block may make between two of its contact updates (0:
    /// no speed margins, every block uses etol alone). See `speed_margin`.
    #[serde(default = "default_margin_steps")]
    pub margin_steps: f64,
}

/// A fast block is re-examined about every this many of its steps (`Tolerances::speed_margin`).
pub const DEFAULT_MARGIN_STEPS: f64 = 16.0;

fn default_margin_steps() -> f64 {
    DEFAULT_MARGIN_STEPS
}

impl Tolerances {
    pub fn from_round(round: f64) -> Self {
        let atol = round;
        Tolerances { round, atol, btol: 1.5 * atol, etol: 0.25 * atol, margin_steps: DEFAULT_MARGIN_STEPS }
    }

    /// The extra search distance for a block whose corners travel `travel` a step, given at its
    /// contact update: enough for `margin_steps` steps at that speed beyond etol, at most 2·atol.
    ///
    /// The report's rule re-examines a block after it moved a fixed distance, so a projectile
    /// that moves a third of etol a step forces a contact update every few cycles (on a GPU each
    /// one is a round trip). A block examined against its neighbours up to atol + m_a + m_b away
    /// may move etol + m_a before its next update: two blocks then approach by at most
    /// (etol + m_a + s_a) + (etol + m_b + s_b), less than that distance while each step s stays
    /// under the too-fast limit atol/2 − etol, as before. The contacts found early are open (a
    /// positive gap carries no force, eq. 16), so the motion is the same as without the margin,
    /// bit for bit (tests/suite/contact_rules.rs); only the contact list is longer by the few pairs in
    /// the margin of fast blocks. Slow blocks (m = 0) are examined exactly as before.
    pub fn speed_margin(&self, travel: f64) -> f64 {
        let m = self.margin_steps * travel - self.etol;
        if m > 0.0 && m.is_finite() {
            m.min(2.0 * self.atol)
        } else {
            0.0
        }
    }
}

/// The whole problem state. Serializable for SAVE/RESTART. `clone_from` copies into the
/// target's own storage (see the `Clone` impl below).
#[derive(Debug, Serialize, Deserialize)]
pub struct Model {
    pub blocks: Vec<Block>,
    pub corners: Vec<Corner>,
    pub contacts: Vec<Contact>,
    /// Materials 1..=MAX_MATERIALS stored at index n−1.
    pub materials: Vec<Material>,
    pub links: Vec<Link>,
    pub gravity: [f64; 2],
    pub damping: Damping,
    /// Fraction of the critical time step (FRACTION).
    pub frac: f64,
    pub tol: Tolerances,
    /// Current time step (0 until the first CYCLE computes it).
    pub timestep: f64,
    pub cycle: u64,
    pub time: f64,
    pub next_block_id: u32,
    pub next_contact_id: u32,
    /// Energy bookkeeping for the blow-up check and the ledger: work done by gravity and loads
    /// since START, plus the kinetic energy VELOCITY commands gave.
    pub external_work: f64,
    /// Energy terms of blocks and contacts that no longer exist (see `timestep::RetiredEnergy`).
    #[serde(default)]
    pub retired: timestep::RetiredEnergy,
    /// The simply-deformable extension of each block (the report's KBEX array, `sdef::Sdef`),
    /// indexed like `blocks`: empty while no block is simply deformable (a rigid scene carries
    /// none of it), one entry a block from the first CHANGE … SDEF on (a rigid block's stays
    /// zero). Saved after the model (save format 4).
    #[serde(skip)]
    pub sdef: Vec<sdef::Sdef>,
    /// The domains (voids between blocks, `domain::Domains`), derived from the lists by
    /// `topology::domain`: `None` in a scene that never asked for them (a rigid scene pays
    /// nothing), rebuilt after each change of topology once asked. Derived data only: it takes
    /// no part in the model's equality (the run driver's resume test compares the state the
    /// cycle reads), and SAVE files do not keep it (a RESTART rebuilds it when asked).
    #[serde(skip)]
    pub domains: Option<domain::Domains>,
    /// The zones and grid points of each fully-deformable block (`fdef::Fdef`), indexed like
    /// `blocks`: empty while no block is fully deformable (a rigid scene carries none of it), one
    /// entry a block from the first CHANGE … FDEF on (empty for any other block). Saved after the
    /// model (save format 5).
    #[serde(skip)]
    pub fdef: Vec<fdef::Fdef>,
    /// The fluid (FLUID rhow bulkw, `fluid::Fluid`) and its accounts: `None` in a dry scene,
    /// which then builds no domains for it and runs no stage of it. SAVE files keep it after the
    /// model (`output::restart`).
    #[serde(skip)]
    pub fluid: Option<fluid::Fluid>,
}

/// Field by field, so that `clone_from` reuses the target's vectors: the backends keep a copy of
/// the last good state and refresh it after every energy check (every 100 cycles), and the derived
/// `clone_from` (a fresh clone dropped into place) allocated and first-touched the whole model each
/// time: 80–330 ms at 10⁵ blocks where copying into the kept vectors takes ~16 ms. The lists are
/// copied on rayon's threads; `clone_settings_from` destructures the model exhaustively, so a new
/// field cannot be left out.
impl Clone for Model {
    fn clone(&self) -> Self {
        let mut model = Model::default();
        model.clone_from(self);
        model
    }

    fn clone_from(&mut self, source: &Self) {
        clone_list_from(&mut self.blocks, &source.blocks);
        clone_list_from(&mut self.corners, &source.corners);
        clone_list_from(&mut self.contacts, &source.contacts);
        self.domains.clone_from(&source.domains);
        self.clone_settings_from(source);
    }
}

/// Names the model's fields besides its three long lists for `$apply!(args; fields)`: the one list
/// of them that `PartialEq` and `clone_settings_from` take, each destructuring the model
/// exhaustively with it, so that a new field is a compile error until it is named here.
macro_rules! with_settings {
    ($apply:ident!($($args:tt)*)) => {
        $apply!($($args)*; materials, links, gravity, damping, frac, tol, timestep, cycle, time, next_block_id, next_contact_id, external_work, retired, sdef, fdef, fluid)
    };
}

/// `a == b` for two models: the settings, then the long lists (`lists_equal`).
macro_rules! models_equal {
    ($a:expr, $b:expr; $($field:ident),*) => {{
        let Model { blocks, corners, contacts, domains: _, $($field),* } = $a;
        $($field == &$b.$field &&)* lists_equal(blocks, &$b.blocks) && lists_equal(corners, &$b.corners) && lists_equal(contacts, &$b.contacts)
    }};
}

/// `dst.field.clone_from(&src.field)` for every setting.
macro_rules! clone_settings {
    ($dst:expr, $src:expr; $($field:ident),*) => {{
        let Model { blocks: _, corners: _, contacts: _, domains: _, $($field),* } = $src;
        $($dst.$field.clone_from($field);)*
    }};
}

impl PartialEq for Model {
    /// Field by field, the long lists on rayon's threads: a run that may go on from the last
    /// (CYCLE after CYCLE) compares the model with the state the last run left, 1.7 GB at 10⁶
    /// blocks (~0.1 s on one core).
    fn eq(&self, other: &Self) -> bool {
        with_settings!(models_equal!(self, other))
    }
}

/// `a == b` for lists, a long one compared on rayon's threads.
pub fn lists_equal<T: PartialEq + Sync>(a: &[T], b: &[T]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    if a.len() < PARALLEL_COPY {
        return a == b;
    }
    a.par_chunks(COPY_CHUNK).zip(b.par_chunks(COPY_CHUNK)).all(|(x, y)| x == y)
}

/// Lists shorter than this are copied (and compared) on the calling thread.
const PARALLEL_COPY: usize = 1 << 16;
/// Elements a thread copies at a time.
const COPY_CHUNK: usize = 1 << 14;

/// `dst.clone_from(src)`, a long list on rayon's threads: at 10⁶ blocks the model's lists are
/// 1.7 GB, whose copy (the last good state each run starts with) is bound by memory bandwidth
/// and, into new memory, by the kernel's page faults, both of which scale with threads.
pub fn clone_list_from<T: Clone + Send + Sync>(dst: &mut Vec<T>, src: &[T]) {
    if src.len() < PARALLEL_COPY {
        src.clone_into(dst);
        return;
    }
    dst.truncate(src.len());
    let kept = dst.len();
    dst.par_chunks_mut(COPY_CHUNK).zip(src[..kept].par_chunks(COPY_CHUNK)).for_each(|(d, s)| d.clone_from_slice(s));
    let more = src.len() - kept;
    dst.reserve_exact(more);
    dst.spare_capacity_mut()[..more].par_chunks_mut(COPY_CHUNK).zip(src[kept..].par_chunks(COPY_CHUNK)).for_each(|(d, s)| {
        for (slot, x) in d.iter_mut().zip(s) {
            slot.write(x.clone());
        }
    });
    // SAFETY: the `more` slots past the length were each written just above.
    unsafe { dst.set_len(src.len()) };
}

/// A copy of a list (`clone_list_from` into a new one).
pub fn cloned_list<T: Clone + Send + Sync>(src: &[T]) -> Vec<T> {
    let mut v = Vec::new();
    clone_list_from(&mut v, src);
    v
}

impl Model {
    /// `clone_from` of everything but the blocks, corners and contacts: for a copy of the last
    /// good state whose lists take their state from elsewhere when it is restored (the GPU
    /// backend's device checkpoint, and its own copy of the contacts' identities), refreshed
    /// after contact updates (a whole copy of the lists takes 90 ms at 10⁶ blocks here).
    pub fn clone_settings_from(&mut self, source: &Self) {
        with_settings!(clone_settings!(self, source));
    }
}

impl Default for Model {
    fn default() -> Self {
        Model {
            blocks: Vec::new(),
            corners: Vec::new(),
            contacts: Vec::new(),
            materials: vec![Material::default(); MAX_MATERIALS],
            links: Vec::new(),
            gravity: [0.0, 0.0],
            damping: Damping::default(),
            frac: 0.1,
            tol: Tolerances::from_round(DEFAULT_ROUND),
            timestep: 0.0,
            cycle: 0,
            time: 0.0,
            next_block_id: 1,
            next_contact_id: 1,
            external_work: 0.0,
            retired: timestep::RetiredEnergy::default(),
            sdef: Vec::new(),
            domains: None,
            fdef: Vec::new(),
            fluid: None,
        }
    }
}

impl Model {
    pub fn material(&self, n: u32) -> &Material {
        &self.materials[material_slot(n, MAX_MATERIALS)]
    }

    /// The simply-deformable state of block `b`, if it is simply deformable.
    #[inline]
    pub fn sdef_of(&self, b: usize) -> Option<&sdef::Sdef> {
        (self.blocks[b].kind == BlockKind::SimplyDeformable).then(|| self.sdef.get(b)).flatten()
    }

    /// Whether any block is simply deformable (the scene then runs the strain's stages).
    pub fn has_sdef(&self) -> bool {
        !self.sdef.is_empty() && self.blocks.iter().any(|b| b.kind == BlockKind::SimplyDeformable)
    }

    /// Makes block `b` simply deformable (CHANGE … SDEF) with no strain, or keeps its strain if
    /// it is already.
    pub fn make_sdef(&mut self, b: usize) {
        self.sdef.resize(self.blocks.len(), sdef::Sdef::default());
        if self.blocks[b].kind != BlockKind::SimplyDeformable {
            self.blocks[b].kind = BlockKind::SimplyDeformable;
            self.sdef[b] = sdef::Sdef::default();
        }
        self.refresh_sdef_moments(b);
    }

    /// The second moments of block `b`'s mass (`Sdef::moments`), from its body-frame corners and
    /// its material's density, if it is simply deformable.
    pub fn refresh_sdef_moments(&mut self, b: usize) {
        if self.blocks[b].kind != BlockKind::SimplyDeformable || b >= self.sdef.len() {
            return;
        }
        let local: Vec<[f64; 2]> = self.block_corners(b).iter().map(|c| c.local).collect();
        let density = self.material(self.blocks[b].material).block.density;
        self.sdef[b].moments = sdef::polygon_moments(&local).map(|x| density * x);
    }

    /// The zones and grid points of block `b`, if it is fully deformable.
    #[inline]
    pub fn fdef_of(&self, b: usize) -> Option<&fdef::Fdef> {
        (self.blocks[b].kind == BlockKind::FullyDeformable).then(|| self.fdef.get(b)).flatten()
    }

    /// Whether any block is fully deformable (the scene then runs the zones' stages).
    pub fn has_fdef(&self) -> bool {
        !self.fdef.is_empty() && self.blocks.iter().any(|b| b.kind == BlockKind::FullyDeformable)
    }

    /// Makes block `b` fully deformable (CHANGE … FDEF), not yet zoned (GENERATE zones it); a
    /// block that already is keeps its zones.
    pub fn make_fdef(&mut self, b: usize) {
        self.fdef.resize(self.blocks.len(), fdef::Fdef::default());
        if self.blocks[b].kind != BlockKind::FullyDeformable {
            self.blocks[b].kind = BlockKind::FullyDeformable;
            self.fdef[b] = fdef::Fdef::default();
        }
    }

    /// Gives fully-deformable block `b` the zones of `mesh` (GENERATE): its corners become the
    /// mesh's boundary grid points (rounded anew), its zones and grid points start at rest and
    /// unstressed, their masses from the block's density.
    pub fn zone_block(&mut self, b: usize, mesh: &zoning::Mesh) {
        self.fdef.resize(self.blocks.len(), fdef::Fdef::default());
        let density = self.material(self.blocks[b].material).block.density;
        let outline: Vec<[f64; 2]> = mesh.points[..mesh.boundary].to_vec();
        self.replace_outline(b, &outline);
        let mut f = fdef::Fdef::from_mesh(mesh, density);
        let v = self.blocks[b].velocity;
        for g in &mut f.gridpoints {
            g.velocity = v;
        }
        self.fdef[b] = f;
        self.blocks[b].angular_velocity = 0.0;
        self.update_corner_positions(b);
    }

    /// The corners of block `b`, counter-clockwise.
    pub fn block_corners(&self, b: usize) -> &[Corner] {
        let blk = &self.blocks[b];
        &self.corners[blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize]
    }

    /// Index of the block with stable id `id`.
    pub fn block_index(&self, id: u32) -> Option<usize> {
        self.blocks.iter().position(|b| b.id == id)
    }

    /// Indices of blocks whose centroid lies strictly inside x1 < x < x2, y1 < y < y2 (the range
    /// rule of DELETE, FIX, FREE, LOAD, CHANGE).
    pub fn blocks_in_range(&self, x1: f64, x2: f64, y1: f64, y2: f64) -> Vec<usize> {
        let (xl, xh) = (x1.min(x2), x1.max(x2));
        let (yl, yh) = (y1.min(y2), y1.max(y2));
        self.blocks
            .iter()
            .enumerate()
            .filter(|(_, b)| {
                let [x, y] = b.centroid;
                x > xl && x < xh && y > yl && y < yh
            })
            .map(|(i, _)| i)
            .collect()
    }

    /// World positions of block `b`'s corners.
    pub fn corner_positions(&self, b: usize) -> Vec<[f64; 2]> {
        self.block_corners(b).iter().map(|c| c.position).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel copy is `clone_from`: into an empty list, a longer one and a shorter one,
    /// small lists and long ones.
    #[test]
    fn a_list_copied_in_parallel_is_its_clone() {
        for len in [0, 10, PARALLEL_COPY - 1, PARALLEL_COPY, 3 * PARALLEL_COPY + 17] {
            let src: Vec<(u64, String)> = (0..len).map(|k| (k as u64 * 7919, format!("{k}"))).collect();
            for start in [0, len / 2, len + COPY_CHUNK + 3] {
                let mut dst: Vec<(u64, String)> = (0..start).map(|k| (k as u64, "old".to_string())).collect();
                clone_list_from(&mut dst, &src);
                assert_eq!(dst, src, "{len} elements over {start}");
            }
            assert_eq!(cloned_list(&src), src);
            // And compared the same way: equal, then one element off anywhere.
            assert!(lists_equal(&src, &cloned_list(&src)));
            for at in [0, len / 2, len.saturating_sub(1)].into_iter().filter(|_| len > 0) {
                let mut other = src.clone();
                other[at].0 += 1;
                assert!(!lists_equal(&src, &other), "{len} elements, {at} changed");
            }
            assert!(len == 0 || !lists_equal(&src, &src[1..]));
        }
    }
}
