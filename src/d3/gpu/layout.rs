//! D3's GPU state: flat storage buffers of `#[repr(C)]` Pod structs (`gpu_struct!`), mirrored in
//! `shaders/d3/layout.wgsl` and checked against it with naga (tests/suite/gpu_shaders.rs). Reals first,
//! then an even number of u32 words (`gpu::real`); no vectors in storage.

pub use crate::gpu::real::{Real, StructLayout};
use crate::gpu_struct;

gpu_struct! {
    /// One polyhedral block: 224 bytes in f32, 400 in f64. State at the half step (velocity,
    /// angular momentum and velocity) and the whole step (centroid, orientation); the inverse of
    /// the reference-frame inertia tensor, column-major (`Block::inertia_ref`); the force and
    /// moment sums of stage 6; and the sums since the upload of the block buffer: `travel` since
    /// the last detection (reset at each), `peak_travel` (the largest step), `work` of gravity
    /// and load, `damping_work` (mass damping) and `dashpot_work` (contact dashpots, booked on
    /// block 1 of each contact). `fixed`: [`BLOCK_FREE`], [`BLOCK_FIXED`] or [`BLOCK_HELD`].
    Block {
        cx: R, cy: R, cz: R,
        /// The centroid's low parts (f32: a compensated pair, so that steps below the
        /// coordinate's ulp are not lost; 0 in f64, whose kernels add as the CPU does).
        cx_lo: R, cy_lo: R, cz_lo: R,
        vx: R, vy: R, vz: R,
        lx: R, ly: R, lz: R,
        wx: R, wy: R, wz: R,
        qx: R, qy: R, qz: R, qw: R,
        mass: R,
        inv0: R, inv1: R, inv2: R, inv3: R, inv4: R, inv5: R, inv6: R, inv7: R, inv8: R,
        load_x: R, load_y: R, load_z: R, radius: R,
        fx: R, fy: R, fz: R, mx: R, my: R, mz: R,
        travel: R, peak_travel: R, work: R, damping_work: R, dashpot_work: R,
        fixed: u32, vertex_start: u32, vertex_count: u32, plane_start: u32, plane_count: u32, edge_start: u32,
        edge_dir_count: u32, feature_count: u32, adjacency_start: u32, adjacency_count: u32,
        /// 1, cleared by a step that leaves a non-finite value.
        finite: u32,
        /// Its faces loaded by BOUNDARY STRESS: two records each in the plane buffer after its
        /// face planes (`Plane`).
        stress_faces: u32,
    }
}

gpu_struct! {
    /// A vertex: in the block's reference frame about its centroid (`l*`), and placed by stage 2
    /// (`x`, `y`, `z`): in f64 its position in global axes, in f32 its offset R·l from the
    /// centroid, which the contact kernels add to the centroid's place in each contact's frame
    /// (`centroid_from`).
    Vertex {
        lx: R, ly: R, lz: R,
        x: R, y: R, z: R,
    }
}

gpu_struct! {
    /// A face plane of a block (one per distinct outward normal, `Shape::planes`): its normal in
    /// the reference frame and one of its vertices (the block's numbering). After a block's
    /// `plane_count` planes come, in a scene with boundary conditions, two records for each of its
    /// faces loaded by BOUNDARY STRESS (`Block::stress_faces`; `face_load` in `shaders/d3/common.wgsl`):
    /// (σ11, σ22, σ33, first vertex, second vertex) and (σ12, σ13, σ23, third vertex, 0), the
    /// vertices numbered in the vertex buffer, so the stresses bind no buffer of their own (the
    /// kernels keep to eight storage buffers with the strain stage's).
    Plane {
        nx: R, ny: R, nz: R,
        vertex: u32, spare: u32,
    }
}

gpu_struct! {
    /// A contact: its common-plane normal, its law block's material (`model::law_block`) and the energy friction took and
    /// springs released since the upload; its logical contacts are a run of the logical buffer.
    Contact {
        nx: R, ny: R, nz: R,
        kn: R, ks: R, cohesion: R, friction: R,
        friction_work: R, released_work: R,
        block1: u32, block2: u32, logical_start: u32, logical_count: u32,
    }
}

gpu_struct! {
    /// A logical contact (`model::Logical`): point (f64: global; f32: from the contact's block
    /// 1's centroid, `point_from`), gap, normal force, the gap its normal spring is unloaded at
    /// (`model::Logical::offset`), shear force; its kind and vertices (the key its shear force
    /// and offset are carried by); `live` 0 once its contact parted.
    Logical {
        px: R, py: R, pz: R, gap: R, normal_force: R, offset: R,
        sx: R, sy: R, sz: R,
        kind: u32, v1: u32, v2: u32, v3: u32, v4: u32, live: u32,
    }
}

gpu_struct! {
    /// The run's constants (a uniform): gravity, α and β, the time step, the contact-forming
    /// distance, the counts.
    Params {
        gx: R, gy: R, gz: R,
        alpha: R, beta: R, dt: R, tol: R, one: R,
        blocks: u32, contacts: u32, spare0: u32, spare1: u32,
    }
}

gpu_struct! {
    /// A simply-deformable block's strain state (`d3::sdef::Sdef`), one per block in a scene
    /// with such blocks (binding 8, `shaders/d3/sdef.wgsl`; `live` 0 for a rigid block), none
    /// bound otherwise. Symmetric tensors in Voigt's order (11, 22, 33, 12, 13, 23): strain `e*`,
    /// its rate `r*` (half step) and the stress `s*`; the applied stress times volume `a*`
    /// (A_ij row by row, written by the gather); the second moments of the mass in the reference
    /// frame `m*` (`sdef::second_moments` of the reference inertia); volume, Lamé's λ, G and the
    /// internal damping α (DAMPING … INTERNAL); `tf` the material's tensile strength where
    /// Griffith's law cracks the block (`sdef::griffith_applies`), else 0 (the kernels screen it
    /// then, `crack_screen`); `live` 1 for a simply-deformable block. After the blocks' records
    /// one more, no block's (`live` 0), whose `spare` is the screen's flag ([`screen_flag_offset`]).
    /// 160 bytes in f32, 312 in f64.
    SdefBlock {
        e0: R, e1: R, e2: R, e3: R, e4: R, e5: R,
        r0: R, r1: R, r2: R, r3: R, r4: R, r5: R,
        s0: R, s1: R, s2: R, s3: R, s4: R, s5: R,
        a0: R, a1: R, a2: R, a3: R, a4: R, a5: R, a6: R, a7: R, a8: R,
        m0: R, m1: R, m2: R, m3: R, m4: R, m5: R,
        volume: R, lambda: R, shear: R, alpha: R, tf: R,
        live: u32, spare: u32,
    }
}

gpu_struct! {
    /// The energy check's sums of one workgroup of `contact_energy` (shaders/d3/contact_energy.wgsl;
    /// twin `d3::model::contact_energy`): the strain energy of its contacts' springs, and the
    /// first of its contacts driven through (`cpu::overlap_check`'s test), [`NONE_DRIVEN`] where
    /// none is.
    ContactEnergy {
        strain: R,
        driven: u32, spare: u32,
    }
}

gpu_struct! {
    /// What the critical step reads of a block (`model::Give`), one per block, worked out on the
    /// CPU when the state is uploaded (`critical_rows`, shaders/d3/critical_rows.wgsl): 1/m, the
    /// least principal moment, the least principal second moment of a simply-deformable block's
    /// mass, and `row0`, k_max times its compliance at its radius (its row's floor);
    /// `unyielding` 1 for a fixed, held or massless block (held counted unyielding, as the CPU's
    /// first try).
    StepGive {
        inverse_mass: R, least: R, least_second: R, row0: R,
        unyielding: u32, spare: u32,
    }
}

gpu_struct! {
    /// The sums of the energy accumulators (friction, released; `Contact`) that one workgroup of
    /// `splice_contacts` zeroed (shaders/d3/splice_contacts.wgsl; twin `splice::splice_contacts`):
    /// a detection adds them into the bases ("Partial detections" in `d3::gpu`).
    Banked {
        friction: R, released: R,
    }
}

/// `splice_contacts`' uniform (shaders/d3/splice_contacts.wgsl, its binding 9): how many
/// contacts the output holds. 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Splice {
    pub contacts: u32,
    pub spare0: u32,
    pub spare1: u32,
    pub spare2: u32,
}

impl Splice {
    /// The WGSL struct name and each field with its byte offset (for the naga layout test).
    pub fn layout() -> StructLayout {
        use std::mem::offset_of;
        StructLayout {
            name: "Splice",
            size: std::mem::size_of::<Self>(),
            fields: vec![
                ("contacts", offset_of!(Self, contacts)),
                ("spare0", offset_of!(Self, spare0)),
                ("spare1", offset_of!(Self, spare1)),
                ("spare2", offset_of!(Self, spare2)),
            ],
        }
    }
}

/// A renewal of `renew_blocks` (`renewals[i].y`, the adjacency list's length) with this bit is a
/// block that moved (its travel from zero again).
pub const RENEW_MOVED: u32 = 1 << 31;

/// A source of `splice_contacts` (`sources[k].x`) with this bit is a fresh contact (its index
/// in the fresh buffers below the bit); without, a contact of the buffers as they were.
pub const SPLICE_FRESH: u32 = 1 << 31;

/// `ContactEnergy::driven` of a workgroup none of whose contacts is driven through.
pub const NONE_DRIVEN: u32 = u32::MAX;

/// Contacts a `contact_energy` invocation adds (ENERGY_ITEMS in shaders/d3/contact_energy.wgsl),
/// neighbouring invocations on neighbouring contacts: a workgroup covers this many times its size.
pub const ENERGY_ITEMS: u32 = 16;

/// The byte offset of the screen's flag in the strain buffer of a scene of `blocks` blocks: the
/// `spare` word of the record after theirs, raised by a block whose Griffith screen fires
/// (sdef.wgsl's `crack_screen`), read by `end_cycle`, cleared by the CPU at each batch's start.
pub fn screen_flag_offset<R: Real>(blocks: usize) -> u64 {
    (blocks * std::mem::size_of::<SdefBlock<R>>() + std::mem::offset_of!(SdefBlock<R>, spare)) as u64
}

/// The batch's halting record (`shaders/d3/end_cycle.wgsl`, its own binding 9) in a scene with
/// Griffith's cracking candidates: the grids (x, y, z) the batch's kernels are dispatched with
/// indirectly (gather, law_of_motion, track_contact), which `end_cycle` zeroes to halt the
/// batch; the cycles it counted; `halted`, 1 once it halted (the screen fired). 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Halt {
    pub gather_x: u32,
    pub gather_y: u32,
    pub gather_z: u32,
    pub law_of_motion_x: u32,
    pub law_of_motion_y: u32,
    pub law_of_motion_z: u32,
    pub track_contact_x: u32,
    pub track_contact_y: u32,
    pub track_contact_z: u32,
    pub cycles_done: u32,
    pub halted: u32,
    pub spare: u32,
}

impl Halt {
    /// A batch's start: the kernels' grids, (x, y) each, nothing counted, not halted.
    pub fn start(gather: (u32, u32), law_of_motion: (u32, u32), track_contact: (u32, u32)) -> Self {
        Halt {
            gather_x: gather.0,
            gather_y: gather.1,
            gather_z: 1,
            law_of_motion_x: law_of_motion.0,
            law_of_motion_y: law_of_motion.1,
            law_of_motion_z: 1,
            track_contact_x: track_contact.0,
            track_contact_y: track_contact.1,
            track_contact_z: 1,
            ..Default::default()
        }
    }

    /// The byte offset of kernel `k`'s grid (0 gather, 1 law_of_motion, 2 track_contact), for
    /// `dispatch_workgroups_indirect`.
    pub fn grid_offset(k: usize) -> u64 {
        (12 * k) as u64
    }

    /// The WGSL struct name and each field with its byte offset (for the naga layout test).
    pub fn layout() -> StructLayout {
        use std::mem::offset_of;
        StructLayout {
            name: "Halt",
            size: std::mem::size_of::<Self>(),
            fields: vec![
                ("gather_x", offset_of!(Self, gather_x)),
                ("gather_y", offset_of!(Self, gather_y)),
                ("gather_z", offset_of!(Self, gather_z)),
                ("law_of_motion_x", offset_of!(Self, law_of_motion_x)),
                ("law_of_motion_y", offset_of!(Self, law_of_motion_y)),
                ("law_of_motion_z", offset_of!(Self, law_of_motion_z)),
                ("track_contact_x", offset_of!(Self, track_contact_x)),
                ("track_contact_y", offset_of!(Self, track_contact_y)),
                ("track_contact_z", offset_of!(Self, track_contact_z)),
                ("cycles_done", offset_of!(Self, cycles_done)),
                ("halted", offset_of!(Self, halted)),
                ("spare", offset_of!(Self, spare)),
            ],
        }
    }
}

/// `Block::fixed`: a free block.
pub const BLOCK_FREE: u32 = 0;
/// `Block::fixed`: a fixed block (FIX).
pub const BLOCK_FIXED: u32 = 1;
/// `Block::fixed`: a block held by BOUNDARY VELOCITY at its velocity and spin (`motion::held_motion`).
pub const BLOCK_HELD: u32 = 2;

/// `Logical::kind`: a vertex of block 1 against block 2.
pub const LOGICAL_VERTEX_FIRST: u32 = 0;
/// `Logical::kind`: a vertex of block 2 against block 1.
pub const LOGICAL_VERTEX_SECOND: u32 = 1;
/// `Logical::kind`: an edge of block 1 across an edge of block 2.
pub const LOGICAL_EDGE_EDGE: u32 = 2;

/// Every D3 GPU struct's layout, for the naga check.
pub fn layouts<R: Real>() -> Vec<StructLayout> {
    vec![Block::<R>::layout(), Vertex::<R>::layout(), Plane::<R>::layout(), Contact::<R>::layout(), Logical::<R>::layout(), Params::<R>::layout()]
}

/// The simply-deformable scenes' struct's layout (declared by `shaders/d3/sdef.wgsl`), for the
/// naga check.
pub fn sdef_layouts<R: Real>() -> Vec<StructLayout> {
    vec![SdefBlock::<R>::layout()]
}

/// `contact_energy`'s struct's layout (declared by `shaders/d3/contact_energy.wgsl`), for the
/// naga check.
pub fn energy_layouts<R: Real>() -> Vec<StructLayout> {
    vec![ContactEnergy::<R>::layout()]
}

/// `critical_rows`' struct's layout (declared by `shaders/d3/critical_rows.wgsl`), for the naga
/// check.
pub fn step_layouts<R: Real>() -> Vec<StructLayout> {
    vec![StepGive::<R>::layout()]
}

/// `splice_contacts`' structs' layouts (declared by `shaders/d3/splice_contacts.wgsl`), for the
/// naga check.
pub fn splice_layouts<R: Real>() -> Vec<StructLayout> {
    vec![Banked::<R>::layout(), Splice::layout()]
}

/// `end_cycle`'s struct's layout (declared by `shaders/d3/end_cycle.wgsl`), for the naga check.
pub fn halt_layouts() -> Vec<StructLayout> {
    vec![Halt::layout()]
}
