//! GPU state: flat storage buffers of `#[repr(C)]` Pod structs, defined once here and mirrored in
//! `shaders/udec/layout.wgsl` (DESIGN.md §2). A test reads the WGSL structs through naga's layouter and
//! checks every size and offset against these.
//!
//! Each struct is generic over the kernel precision `R` (f32 or f64, the WGSL `real` alias) and is
//! laid out as all `real` fields first, then an even number of `u32` words. That rule gives the
//! same layout in WGSL and Rust with no implicit padding in either precision (no vectors in
//! storage, so no vec2/vec3 alignment surprises).
//!
//! Hot state only (STYLE.md item 5): names, ids and topology stay in the CPU `Model`.

pub use crate::gpu::real::{Real, StructLayout};
use crate::gpu_struct;

gpu_struct! {
    /// One rigid block: 120 bytes in f32, 224 in f64. The centroid is kept relative to the run's
    /// origin as a compensated pair (`cx + cx_lo`), so that small increments added to a large
    /// coordinate are not lost in f32 (Kahan summation, law_of_motion.wgsl). In f32 the rotation
    /// is the angle the corners are placed at, a multiple of `shaders::ROTATION_STEP`, plus the
    /// turn since (`rotation_lo`), applied by the contact stage (`shaders::split_rotation`); in
    /// f64 it is the rotation, and `rotation_lo` is 0.
    Block {
        cx: R, cy: R, cx_lo: R, cy_lo: R,
        rotation: R, rotation_lo: R, vx: R, vy: R, w: R,
        fx: R, fy: R, moment: R, mass: R,
        inertia: R, load_x: R, load_y: R, radius: R,
        /// Work of gravity and load on this block since the block buffer was uploaded.
        work: R,
        /// Energy taken by the mass-proportional damping since the block buffer was uploaded
        /// (`Block::damping_work` counts from its value then; summed in f64 on the CPU).
        damping_work: R,
        /// Largest net displacement since the last contact update (`Block::moved_since_update`),
        /// then the reference centroid (compensated pair) and rotation it is measured from, and
        /// the block's speed margin (`Block::update_margin`: it is due past etol + margin).
        moved: R, update_cx: R, update_cy: R, update_cx_lo: R, update_cy_lo: R, update_rotation: R, update_margin: R,
        fixed: u32, corner_start: u32, corner_count: u32,
        /// The block's kind: `BLOCK_RIGID`, or `BLOCK_SDEF` (its strain is in the scene's `Sdef`
        /// slot at the block's index).
        kind: u32,
    }
}

/// `Block::kind` of a rigid block.
pub const BLOCK_RIGID: u32 = 0;
/// `Block::kind` of a simply-deformable block (`model::sdef`).
pub const BLOCK_SDEF: u32 = 1;
/// `Block::kind` of a zoned fully-deformable block (`model::fdef`): its motion is its grid
/// points' (`GridPoint`), the block record's velocity and force stay zero on the device, and its
/// centroid is the reference its corners are placed from (the mass centre at the upload).
pub const BLOCK_FDEF: u32 = 2;

impl<R: Real> Block<R> {
    /// The block's rotation: the angle its corners are placed at plus the turn since.
    pub fn whole_rotation(&self) -> f64 {
        self.rotation.to_f64() + self.rotation_lo.to_f64()
    }

    /// Byte offset of the fields a contact update resets ([`Block::update_reset`]).
    pub const UPDATE_RESET_OFFSET: usize = std::mem::offset_of!(Block<R>, moved);

    /// What a contact update writes over the seven fields from `moved` on, in their order: the
    /// distance moved since the update back to 0, the reference where the block is now (report
    /// ¶26: the next update is due when it has moved past the tolerance from here) and its new
    /// speed margin. The one definition for the host's copy and the device's few bytes.
    pub fn update_reset(&self, margin: R) -> [R; 7] {
        [R::default(), self.cx, self.cy, self.cx_lo, self.cy_lo, R::from_f64(self.whole_rotation()), margin]
    }

    /// The fields of [`Block::update_reset`] as they are.
    pub fn update_fields(&self) -> [R; 7] {
        [self.moved, self.update_cx, self.update_cy, self.update_cx_lo, self.update_cy_lo, self.update_rotation, self.update_margin]
    }

    /// Sets the fields of [`Block::update_reset`] to `fields`.
    pub fn set_update_reset(&mut self, fields: [R; 7]) {
        [self.moved, self.update_cx, self.update_cy, self.update_cx_lo, self.update_cy_lo, self.update_rotation, self.update_margin] = fields;
    }
}

// The reset is written to the device as one run of seven reals from `moved`: the seven are
// declared in that order, all reals, so in `repr(C)` the span from `moved` to `update_margin` is
// six reals in either precision.
const _: () = {
    use std::mem::{offset_of, size_of};
    assert!(offset_of!(Block<f32>, update_margin) == offset_of!(Block<f32>, moved) + 6 * size_of::<f32>());
    assert!(offset_of!(Block<f64>, update_margin) == offset_of!(Block<f64>, moved) + 6 * size_of::<f64>());
};

gpu_struct! {
    /// One rounded corner: 40 bytes in f32, 80 in f64. `px, py` and `ox, oy` (corner and
    /// rounding-circle centre) are relative to the block's centroid, rotated: world = centroid + p.
    /// The edge to the next corner (`edge_dir`, `edge_length` on the CPU) is not stored: the
    /// contact stage measures it from the two corners it loads anyway. Nor is the corner's
    /// block: every reader comes from it (a block's `corner_start`, a contact's `block1`).
    Corner {
        lx: R, ly: R, qx: R, qy: R, radius: R, round: R,
        px: R, py: R, ox: R, oy: R,
    }
}

gpu_struct! {
    /// One contact: 76 bytes in f32, 128 in f64. The point is relative to block 2's centroid.
    /// Its force on block 1 is kept once, in its `ContactForce` record.
    Contact {
        px: R, py: R, nx: R, ny: R, gap: R,
        normal_force: R, shear_force: R, shear_displacement: R,
        /// Friction and dashpot dissipation since the contact buffer was uploaded
        /// (`Contact::slip_work`, `Contact::dashpot_work` count from their values then).
        slip_work: R, dashpot_work: R,
        /// `Contact::dashpot_velocity`: the normal and shear velocities the dashpots acted on in
        /// the last step (state, uploaded and read back as is).
        dashpot_vn: R, dashpot_vs: R,
        /// `Contact::joint_length`: the length of joint it carries (¶5), 0 for a point contact;
        /// set by the CPU at creation and at each contact update that re-examines it.
        length: R,
        block1: u32, corner: u32, block2: u32, feature: u32,
        /// Index into the material table (0-based, as `Model::material` maps it).
        material: u32,
        bonded: u32,
    }
}

gpu_struct! {
    /// What a contact update reads back of one contact (`pack_contacts.wgsl`): 28 bytes in f32,
    /// 48 in f64, against 72 / 120 for the whole contact. The gap decides drops, the forces and
    /// the dissipation go to the ledger (and to its retired account when the contact is
    /// dropped), the feature is the one the contact follows, `bonded` whether it is still intact.
    ContactSummary {
        gap: R, normal_force: R, shear_force: R, slip_work: R, dashpot_work: R,
        feature: u32, bonded: u32,
    }
}

gpu_struct! {
    /// What the gather needs of one contact, written by `contact_forces` into its own compact
    /// slot: 16 bytes in f32, 32 in f64. The force on block 1 (block 2 gets its reaction) and
    /// the moment of each about its block's centroid (eq. 12, M = r × F), so that the gather
    /// reads 12 of these 16 contiguous bytes per contact instead of the whole contact and block
    /// 2. `m[0]` is block 1's moment, `m[1]` block 2's: an adjacency entry's side indexes it, so
    /// the gather loads three fields an entry, not four.
    ContactForce { fx: R, fy: R, m: [R; 2] }
}

gpu_struct! {
    /// A kept contact the CPU read for a contact update (`patch_contacts`): 12 bytes in f32, 16
    /// in f64. The length of joint it carries now (its law, ¶5), its index in the new list and
    /// the feature the update found.
    ContactPatch { length: R, index: u32, feature: u32 }
}

impl<R: Real> ContactPatch<R> {
    /// The patch of contact `index` of the model's list: its feature and its law.
    pub fn of(model: &crate::udec::model::Model, index: u32) -> Self {
        let c = &model.contacts[index as usize];
        ContactPatch { length: R::from_f64(c.joint_length), index, feature: c.feature }
    }
}

gpu_struct! {
    /// The simply-deformable extension of one block (`model::sdef::Sdef`, the report's KBEX
    /// array): 96 bytes in f32, 192 in f64, one per block in a scene with SDEF blocks (a rigid
    /// block's stays zero), bound only by the SDEF kernels. Tensors in world axes; symmetric ones
    /// as (11, 12, 22), the applied stress times area as (11, 12, 21, 22).
    Sdef {
        strain: [R; 3],
        /// The strain rate at the half step (KED).
        strain_rate: [R; 3],
        /// The internal stress (KSI), tension positive.
        stress: [R; 3],
        /// The applied stress times area (KSA), as the last gather summed it.
        applied: [R; 4],
        /// The second moments of the block's mass in its body frame (the strain's inertia).
        moments: [R; 3],
        /// The strain at the block's last contact update (`Sdef::update_strain`).
        update_strain: [R; 3],
        /// Energy the internal damping took since the upload (`Sdef::damping_work` counts from
        /// its value then).
        damping_work: R,
        /// The block's area, and its material's Lamé λ and shear modulus G (plane strain).
        area: R, lambda: R, shear: R,
        /// The tensile strength t_f Griffith's criterion tests against (¶17); 0 where the block
        /// is no Griffith candidate.
        griffith_tf: R,
    }
}

gpu_struct! {
    /// The lever arms of one contact in a scene with SDEF blocks: from block 1's centroid and
    /// from block 2's to the contact point, r1 and r2, written by `contact_forces_sdef` with the
    /// force: 16 bytes in f32, 32 in f64. The gather of an SDEF block sums r_i f_j over them (its
    /// applied stress times area).
    ContactLever { r1x: R, r1y: R, r2x: R, r2y: R }
}

gpu_struct! {
    /// One grid point of a fully-deformable block (`model::fdef::GridPoint`), in a scene with
    /// zoned blocks only: 84 bytes in f32, 152 in f64. The position is relative to the run's
    /// origin as a compensated pair (`x + x_lo`, as the blocks' centroids), so that f32 keeps the
    /// small steps of a slow grid point. `ext_x, ext_y`: gravity's and the load's share on it,
    /// m·g + load·m/M (the CPU's `gather_fdef` order), computed in f64 at the upload.
    GridPoint {
        x: R, y: R, x_lo: R, y_lo: R,
        vx: R, vy: R, fx: R, fy: R, mass: R,
        load_x: R, load_y: R,
        /// Where it was at its block's last contact update (`GridPoint::update_position`).
        ux: R, uy: R, ux_lo: R, uy_lo: R,
        /// Work of gravity and load on it, and the mass damping's dissipation, since the upload.
        work: R, damping_work: R,
        /// Its block's index; 1 if it is a boundary grid point (a corner of its block), 0 if not;
        /// 1 if its block is fixed. `listed`: 1 while it (a boundary grid point) may gather from
        /// its own contact list (`gpu::fdef`, `GridPointContacts`), 0 where it walks its block's
        /// whole list.
        block: u32, boundary: u32, fixed: u32, listed: u32,
    }
}

gpu_struct! {
    /// One constant-strain triangle (`model::fdef::Zone`): 28 bytes in f32, 40 in f64. Its
    /// stress (11, 12, 22, tension positive), its three grid points (global indices into the
    /// `gridpoints` slot, counter-clockwise) and its block.
    Zone { stress: [R; 3], g0: u32, g1: u32, g2: u32, block: u32 }
}

gpu_struct! {
    /// A fully-deformable block's zone constants and ranges, one per block in a scene with zoned
    /// blocks (zero for the others): 32 bytes in f32, 40 in f64. Lamé's λ and G of its material
    /// (plane strain), its grid points `gp_start .. gp_start + gp_count` (the first `boundary`
    /// of them its corners, in order), its zones `zone_start .. zone_start + zone_count`, whether
    /// it is fixed.
    FdefBlock { lambda: R, shear: R, gp_start: u32, gp_count: u32, boundary: u32, zone_start: u32, zone_count: u32, fixed: u32 }
}

gpu_struct! {
    /// How a contact's force is shared to grid points (`cpu::zones::force_shares`), written by
    /// `contact_forces_fdef` with the force: 24 bytes in f32, 32 in f64. Block 1's corner gives
    /// all of it to grid point `g1`; on block 2 a corner arc to `g2a` (weight `wa` = 1), an edge
    /// to `g2a` and `g2b` by where the point lies along it (`wa`, `wb`). `NO_INDEX` where the
    /// block is not zoned.
    ContactShare { wa: R, wb: R, g1: u32, g2a: u32, g2b: u32, _pad: u32 }
}

gpu_struct! {
    /// The fluid's run constants (a uniform), in a scene with fluid only: 32 bytes in f32, 48 in
    /// f64. bulkw (¶7), A_d(min) (`Domains::min_area`), the live count of domains, of domain
    /// links and of the items of `domain_terms` (flow.wgsl), and the length of boundary or flow
    /// list past which a domain's sums are taken over terms computed in parallel
    /// (`gpu::flow::long_walk`).
    FluidParams { bulk: R, min_area: R, _r0: R, _r1: R, n_domains: u32, n_links: u32, n_term_items: u32, long_walk: u32 }
}

gpu_struct! {
    /// The flow properties of one material (¶6; `Material::fluid`): 16 bytes in f32, 32 in f64,
    /// a uniform array of `MAX_MATERIALS` beside the contact table, bound only by the fluid's
    /// kernels. JPERM, CPERM, AZERO, ARES.
    FluidMaterial { jperm: R, cperm: R, azero: R, ares: R }
}

gpu_struct! {
    /// One domain on the device (`model::domain::Domain`), in a scene with fluid only: 48 bytes
    /// in f32, 72 in f64. Its pressure, the area the fluid calculation gave it at the last step
    /// (`model::fluid::fluid_area`), a joint domain's length, the volume that flowed into it
    /// since the upload (Σ Q·Δt, the mass balance's `Fluid::inflow`), a regular domain's void at
    /// the upload and the sum of its changes since, step by step from its boundary's motion (the
    /// f32 kernels' `AREA_BY_MOTION`, `void_step` in flow.wgsl: the void is then their sum, and
    /// the pressure update takes each step's change itself rather than the difference of two
    /// large f32 areas; unused in f64); whether its pressure moves
    /// (`model::fluid::is_free`), its kind (`DOMAIN_*`), its flows
    /// (`domain_flows[flow_start .. + flow_count]`: contact·2 + 1 where it is the contact's second
    /// domain, + 0 where its first, ascending by contact: the CPU's order) and its boundary
    /// (`domain_links`, four words a link, see `Engine::upload_fluid`).
    Domain {
        pressure: R, area: R, length: R, inflow: R, void_base: R, void_change: R,
        free: u32, kind: u32, flow_start: u32, flow_count: u32, link_start: u32, link_count: u32,
    }
}

/// `Domain::kind` of a regular domain (a void), a joint domain and the outer domain.
pub const DOMAIN_REGULAR: u32 = 0;
pub const DOMAIN_JOINT: u32 = 1;
pub const DOMAIN_OUTER: u32 = 2;
/// `Domain::kind` of a regular domain with a deformable block on its boundary: its void is
/// measured from its outline every step (`fluid_area`, flow.wgsl), never followed by the rigid
/// motion of its blocks (`void_step`), which a strained outline does not follow.
pub const DOMAIN_REGULAR_DEFORMED: u32 = 3;
/// Bits of a domain link's first word (`domain_links`): the contact's side whose piece of block
/// boundary follows it (`Domains::link_sides` bit 0), the link opens a loop (`LOOP_START`), the
/// link is a corner (else a contact).
pub const LINK_SIDE: u32 = 1;
pub const LINK_LOOP_START: u32 = 2;
pub const LINK_CORNER: u32 = 4;

gpu_struct! {
    /// One contact's flow in the last cycle (`model::domain::ContactFlow`), written by `flow`:
    /// 36 bytes in f32, 72 in f64. The flow from its first domain to its second, the joint's
    /// aperture and length (0 for a point contact), its feet (`contact_foot`): on side 0 relative
    /// to block 1's centroid, on side 1 relative to block 2's, where the domain areas and the
    /// pressure loads read them; and the pressures of its first and second domain as the last
    /// pressure update left them (`domain_pressures` writes a free domain's into each of its
    /// contacts, the upload every domain's; equal, 0, for a contact that is not a link between
    /// two domains), so that the gather takes each contact's pressure jump from the slot it
    /// reads the foot from (`add_pressure_load`, gather.wgsl).
    ContactFlow { flow: R, aperture: R, length: R, f0x: R, f0y: R, f1x: R, f1y: R, p0: R, p1: R }
}

gpu_struct! {
    /// One block's share of the fluid, in a scene with fluid only: 12 bytes in f32, 24 in f64.
    /// Buoyancy −ρ_w·A·g (¶9, from the CPU at the upload) and the work of the block's fluid load
    /// since the upload (the ledger's fluid work). The load itself, buoyancy and the pressure
    /// jumps across its contacts, is summed by its gather (`law_of_motion_fluid`,
    /// `gather_fluid`) and never stored.
    FluidLoad { buoy_x: R, buoy_y: R, work: R }
}

gpu_struct! {
    /// One piece of block boundary around a domain in a scene with fluid and deformable blocks
    /// (`model::fluid::pressure_pieces`): one per domain link (`domain_links`, same index), the
    /// piece that starts at the link's last vertex and runs to the next vertex of its loop, on
    /// the link's own block; 24 bytes in f32, 40 in f64. Written each cycle by
    /// `pressure_pieces` (flow.wgsl) at its domain's pressure p, where its block is deformable:
    /// on a simply-deformable block its applied stress times area Σ r⊗f (11, 12, 21, 22), on a
    /// zoned block its force p·perp(b − a) split to the edge's two grid points (x, y at the edge's
    /// first grid point, then at its second); `edge` the edge it lies on (the index within its
    /// block of the corner the edge starts at), `NO_INDEX` where the piece loads nothing (a rigid
    /// block, or a domain at zero pressure, which the CPU skips).
    FluidPiece { a0: R, a1: R, a2: R, a3: R, edge: u32, _pad: u32 }
}

gpu_struct! {
    /// One block's fluid load in a scene with fluid and deformable blocks (`fluid_block_loads`,
    /// gather.wgsl): 28 bytes in f32, 56 in f64. Its buoyancy and pressure jumps (force x, y,
    /// moment; a zoned block's buoyancy alone, which its grid points share by mass), and a
    /// simply-deformable block's applied stress times area from the pieces of its boundary
    /// (11, 12, 21, 22). The block pass adds them to the stored contact sums.
    BlockFluid { fx: R, fy: R, moment: R, a11: R, a12: R, a21: R, a22: R }
}

gpu_struct! {
    /// One grid point's fluid load in a scene with fluid and zoned blocks
    /// (`gridpoint_fluid_loads`, zones.wgsl): 12 bytes in f32, 24 in f64. Its share of its
    /// block's buoyancy by mass plus, on the boundary, its shares of the pressure pieces; and the
    /// work the load did over the last step, F·½(v_old + v_new)·Δt (`step_gridpoints_fluid`),
    /// which the block pass adds to its block's fluid work.
    GridPointFluid { fx: R, fy: R, step_work: R }
}

gpu_struct! {
    /// How far one corner moved in this step, in a scene with fluid and deformable blocks in f32
    /// (`corner_moves_sdef`, `corner_moves_fdef`, flow.wgsl; twin [`crate::udec::gpu::flow::corner_moves`]):
    /// 8 bytes in f32, 16 in f64. The voids with a deformable block on their boundary are
    /// followed by these moves (`deformed_terms`), as those of rigid blocks by their motion.
    CornerMove { dx: R, dy: R }
}

gpu_struct! {
    /// Contact properties of one material: 32 bytes in f32, 64 in f64, the point contact's
    /// (KN, KS, COHESION, FRICTION) and the joint's (JKN, JKS, JCOH, JFRIC, ¶5). A uniform array
    /// of `MAX_MATERIALS` (a stride of a multiple of 16 bytes in both precisions, as uniform
    /// arrays require).
    Material { kn: R, ks: R, cohesion: R, friction: R, jkn: R, jks: R, jcohesion: R, jfriction: R }
}

gpu_struct! {
    /// One workgroup's share of the energy check (`energy_sums`): 12 bytes in f32, 24 in f64.
    /// Kinetic energy of its blocks (at time t, as `Model::energies` takes it), strain energy of
    /// its contacts, and its blocks' external work since the upload.
    EnergySum { kinetic: R, strain: R, work: R }
}

gpu_struct! {
    /// Run constants and live counts (a uniform): 60 bytes in f32, 96 in f64.
    Params {
        dt: R, alpha: R, beta: R, gx: R, gy: R,
        /// The contact update tolerance.
        etol: R,
        /// Largest corner travel per step (½ atol − etol), beyond which a block is too fast.
        fast_limit: R,
        /// Overlap beyond which the run stops (½ ROUND).
        overlap_limit: R,
        /// The internal damping of SDEF blocks' strain (DAMP … INTERNAL, ALPB).
        alpha_internal: R,
        n_blocks: u32, n_corners: u32, n_contacts: u32,
        /// Always 1: a one whose value the shader compiler cannot see, for `two_sum`.
        one: u32,
        /// Blocks `gather_heavy` sums in this pass (long contact lists), listed after the CSR
        /// offsets: the free ones in a cycle, fixed ones too in the pass before a read-back.
        n_heavy: u32,
        /// 1: the contacts' dashpots are live (β > 0, or velocities of an earlier run's dashpots
        /// still to be booked); 0: the contact stage neither reads nor writes dashpot fields.
        dashpots: u32,
    }
}

gpu_struct! {
    /// Where a block stood when stage 7's broad-phase grid was last built (`BlockGrid`'s
    /// reference): 32 bytes in f32, 64 in f64. Centroid relative to the run's origin as a
    /// compensated pair, rotation, reach (farthest corner from the centroid), speed margin then.
    /// `list_blocks.wgsl` lists the blocks that may have left their boxes in the grid from it.
    GridReference { x: R, y: R, x_lo: R, y_lo: R, rotation: R, reach: R, margin: R, _r: R }
}

gpu_struct! {
    /// The constants of `list_blocks.wgsl` (a uniform): 32 bytes in f32, 48 in f64.
    ListParams {
        dt: R, etol: R, btol: R,
        /// Half the grid's margin: a block whose corners moved farther since the grid was built
        /// may have left its box in it.
        stray_limit: R,
        n_blocks: u32, n_contacts: u32,
        /// 1: the grid is kept from an earlier update (its reference is on the device).
        grid_kept: u32,
        _pad: u32,
    }
}

/// Bits of `Flags::errors`.
pub const ERR_NONFINITE: u32 = 1;
pub const ERR_TOO_FAST: u32 = 2;
pub const ERR_OVERLAP: u32 = 4;
/// A zone of a fully-deformable block turned inside out (`zones`, zones.wgsl).
pub const ERR_ZONE_INVERTED: u32 = 8;
/// "No index" in the atomic-min index slots.
pub const NO_INDEX: u32 = u32::MAX;

/// Flags and counters the kernels raise (atomics in WGSL): 36 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Flags {
    /// Set at the end of a cycle that needs the CPU: later cycles of the batch do nothing.
    pub halted: u32,
    pub cycles_done: u32,
    /// A block moved past the update tolerance (stage 7 is due).
    pub update_due: u32,
    pub errors: u32,
    /// Lowest index of a block with a non-finite state, of a too-fast block, of an overlapping
    /// contact (`NO_INDEX` when none).
    pub nonfinite_block: u32,
    pub toofast_block: u32,
    pub overlap_contact: u32,
    /// An SDEF block's stress reached its Griffith strength (`law_of_motion_sdef`): the CPU's
    /// cracking stage is due.
    pub crack_due: u32,
    /// Lowest index (into the `zones` slot) of a zone turned inside out (`NO_INDEX` when none).
    pub inverted_zone: u32,
}

impl Flags {
    pub fn cleared() -> Self {
        Flags {
            halted: 0,
            cycles_done: 0,
            update_due: 0,
            errors: 0,
            nonfinite_block: NO_INDEX,
            toofast_block: NO_INDEX,
            overlap_contact: NO_INDEX,
            crack_due: 0,
            inverted_zone: NO_INDEX,
        }
    }
    pub fn layout() -> StructLayout {
        StructLayout {
            name: "Flags",
            size: std::mem::size_of::<Self>(),
            fields: vec![
                ("halted", std::mem::offset_of!(Self, halted)),
                ("cycles_done", std::mem::offset_of!(Self, cycles_done)),
                ("update_due", std::mem::offset_of!(Self, update_due)),
                ("errors", std::mem::offset_of!(Self, errors)),
                ("nonfinite_block", std::mem::offset_of!(Self, nonfinite_block)),
                ("toofast_block", std::mem::offset_of!(Self, toofast_block)),
                ("overlap_contact", std::mem::offset_of!(Self, overlap_contact)),
                ("crack_due", std::mem::offset_of!(Self, crack_due)),
                ("inverted_zone", std::mem::offset_of!(Self, inverted_zone)),
            ],
        }
    }
}

/// Every GPU struct's Rust layout in precision `R`.
pub fn layouts<R: Real>() -> Vec<StructLayout> {
    vec![
        Block::<R>::layout(),
        Corner::<R>::layout(),
        Contact::<R>::layout(),
        ContactForce::<R>::layout(),
        ContactSummary::<R>::layout(),
        ContactPatch::<R>::layout(),
        Sdef::<R>::layout(),
        ContactLever::<R>::layout(),
        GridPoint::<R>::layout(),
        Zone::<R>::layout(),
        FdefBlock::<R>::layout(),
        ContactShare::<R>::layout(),
        FluidParams::<R>::layout(),
        FluidMaterial::<R>::layout(),
        Domain::<R>::layout(),
        ContactFlow::<R>::layout(),
        FluidLoad::<R>::layout(),
        FluidPiece::<R>::layout(),
        BlockFluid::<R>::layout(),
        GridPointFluid::<R>::layout(),
        CornerMove::<R>::layout(),
        Material::<R>::layout(),
        EnergySum::<R>::layout(),
        Params::<R>::layout(),
        GridReference::<R>::layout(),
        ListParams::<R>::layout(),
        Flags::layout(),
    ]
}
