//! Fluid flow in joints and voids (SL-85-1 Appendix A ¶6–9, ¶19): the fluid (FLUID rhow bulkw),
//! the flow laws across contacts and along joints, the domain pressure update, the loads the
//! pressures put on the blocks around a domain, and the limits they put on the time step.
//!
//! These are the pure pieces both backends share; the CPU's stage 5 (`cpu::flow`) drives them
//! over the model. The domains themselves (the voids, their circuits, their ids) are
//! `model::domain`, built by `topology::domain`.
//!
//! - Flow (¶6): across a point contact q = k_c·Δp (CPERM); along a joint q = k_j·a³·Δp/l (JPERM)
//!   with the aperture a = max(a_res, a_0 − σn′/k_n,j) (ARES, AZERO, JKN). An edge-to-edge joint is
//!   the two corner contacts at the ends of the faces in opposition, each carrying l_c = l_j/2 of
//!   it (¶5, `contact::joint`), with the joint's own domain between them: a flow along the whole
//!   joint crosses both, so each takes l = l_c and in series they give the cubic law over l_j.
//! - Pressure (¶7): p_del = Q·bulkw·Δt/A_d, Q the sum of the flows into the domain. The report's
//!   sample 2 pressurizes a cavity by pushing a block into it, so the domain's change of volume
//!   counts too: the fluid mass A_d(1 + p/bulkw) changes only by the flows,
//!   p_new = [A_old·p_old + bulkw·(Q·Δt − (A_new − A_old))]/A_new, which for a domain of constant
//!   area is the report's update. A fixed-pressure domain (PFIX) and the outer domain keep theirs.
//! - Loads (¶19): a domain's pressure pushes on the block boundary around it. On a piece of
//!   boundary from a to b (the block on its left) a uniform pressure p gives the force
//!   p·perp(b − a), perp(v) = (−v_y, v_x), and the moment about the centroid c
//!   p·(|b − c|² − |a − c|²)/2, whatever corners lie between: so a block's pressure load is a sum
//!   over its contacts, each giving at its foot f the pressure jump across it,
//!   (p_after − p_before)·perp(f − c) and (p_after − p_before)·|f − c|²/2 ([`pressure_load`]).
//!   The contact forces are then effective forces: the joint law's σn′ is the contact's.
//! - Buoyancy (¶9): with gravity, a saturated block carries −ρ_w·A·g; the scene is taken as
//!   fully saturated (the domain pressures are then the excess over hydrostatic), so every
//!   block does.

use super::domain::{ContactFlow, Domain, DomainKind, DomainLink, Domains, LOOP_START, NO_DOMAIN};
use super::{material_slot, Contact, Material, Model};

/// The fluid of a scene (FLUID rhow bulkw) and its accounts.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Fluid {
    /// ρ_w, for buoyancy (¶9).
    pub density: f64,
    /// bulkw, the fluid's bulk modulus (¶7).
    pub bulk: f64,
    /// Work the domain pressures and buoyancy did on the blocks since FLUID: the energy ledger's
    /// fluid term (an input to the blocks, as gravity's work is).
    pub work: f64,
    /// Fluid volume that flowed into the free domains from fixed-pressure domains and the outer
    /// domain since FLUID.
    pub inflow: f64,
    /// Changes of the stored volume not made by flow: the domains a contact update merges or
    /// splits (a rebuilt domain keeps the pressure of the one it is found again as), PFIX and
    /// PFREE. With `inflow` they add up to the stored volume's change ([`stored_volume`]).
    pub adjusted: f64,
    /// [`stored_volume`] when FLUID was given.
    pub stored_at_start: f64,
    /// Whether the model's domains and time step are as a run left them: a run sets it at its
    /// start (whose domains are then rebuilt and the step cut to the fluid's limits), and every
    /// command but those that only write or read (PRINT, PLOT, SAVE, …) clears it. Within a
    /// run the step falls only where stage 7 rebuilds the domains, so a run that starts from a
    /// state a run left (a RESTART of its SAVE) keeps those domains and that step where its
    /// detection finds the contacts as they were: CYCLE N, SAVE, RESTART, CYCLE M is then
    /// CYCLE N + M bit for bit. Not part of the model's equality (the backends' test of a
    /// run that goes on from the last: a command that changes nothing leaves it going on).
    pub as_run_left: bool,
}

/// Every field but [`Fluid::as_run_left`], which says how the state came about, not what it is.
impl PartialEq for Fluid {
    fn eq(&self, o: &Self) -> bool {
        let Fluid { density, bulk, work, inflow, adjusted, stored_at_start, as_run_left: _ } = *self;
        (density, bulk, work, inflow, adjusted, stored_at_start) == (o.density, o.bulk, o.work, o.inflow, o.adjusted, o.stored_at_start)
    }
}

impl Fluid {
    /// The mass balance's error: stored − (at start + inflow + adjusted), in volume.
    pub fn balance_error(&self, stored: f64) -> f64 {
        stored - (self.stored_at_start + self.inflow + self.adjusted)
    }
}

/// The fluid volume (at zero pressure, per unit thickness) the free domains hold: Σ A_d(1 + p_d/bulkw)
/// over the domains whose pressure is not held.
pub fn stored_volume(domains: &Domains, bulk: f64) -> f64 {
    domains.list.iter().filter(|d| !d.fixed && d.kind != DomainKind::Outer).map(|d| d.area * (1.0 + d.pressure / bulk)).sum()
}

/// Whether a domain's pressure changes with its flows: not the outer domain (unbounded) and not
/// one PFIX holds.
#[inline]
pub fn is_free(kind: DomainKind, fixed: bool) -> bool {
    !fixed && kind != DomainKind::Outer
}

/// The hydraulic aperture of a joint contact (¶6): a = max(a_res, a_0 − σn′/k_n,j), σn′ the
/// effective normal stress the contact carries (its normal force over its length of joint,
/// compression positive). 0 for a point contact.
#[inline]
pub fn aperture(c: &Contact, mat: &Material) -> f64 {
    if c.joint_length <= 0.0 {
        return 0.0;
    }
    let f = &mat.fluid;
    let sigma = c.normal_force / c.joint_length;
    let closure = if mat.joint.kn > 0.0 { sigma / mat.joint.kn } else { 0.0 };
    (f.azero - closure).max(f.ares)
}

/// The conductance of a contact (¶6), q = conductance·Δp: k_j·a³/l_c along a joint of aperture
/// `a`, k_c across a point contact.
#[inline]
pub fn conductance(c: &Contact, mat: &Material, a: f64) -> f64 {
    if c.joint_length > 0.0 {
        mat.fluid.jperm * a * a * a / c.joint_length
    } else {
        mat.fluid.cperm
    }
}

/// The pressure after a step (¶7, with the domain's change of volume): the fluid mass
/// A(1 + p/bulkw) changes by the inflow `inflow` (Q·Δt) alone.
#[inline]
pub fn pressure_step(pressure: f64, area_before: f64, area_after: f64, inflow: f64, bulk: f64) -> f64 {
    (area_before * pressure + bulk * (inflow - (area_after - area_before))) / area_after
}

/// Where contact `c` meets the boundary of its block on `side` (0: block 1's corner; 1: block
/// 2's corner, or the foot of block 1's corner on block 2's edge, within the edge): the point the
/// domains on either side of the contact meet on that block.
pub fn contact_foot(model: &Model, c: &Contact, side: u32) -> [f64; 2] {
    contact_foot_in(&model.corners, &model.blocks[c.block2 as usize], c, side)
}

/// [`contact_foot`] from the corners and contact `c`'s block 2.
#[inline]
pub fn contact_foot_in(corners: &[super::Corner], b2: &super::Block, c: &Contact, side: u32) -> [f64; 2] {
    let corner = corners[c.corner as usize].position;
    if side == 0 {
        return corner;
    }
    foot_on_block2(corners, b2, c, corner)
}

/// Both feet of contact `c` ([`contact_foot`], side 0 then 1), its corner at `corner` (stage 4
/// takes each contact's feet where it has just read its corner and block 2, `cpu::contact_forces`).
#[inline]
pub fn contact_feet(corners: &[super::Corner], b2: &super::Block, c: &Contact, corner: [f64; 2]) -> [[f64; 2]; 2] {
    [corner, foot_on_block2(corners, b2, c, corner)]
}

/// Side 1's foot of contact `c` whose corner is at `corner`: block 2's corner it touches, or the
/// corner's foot on block 2's edge, within the edge.
#[inline]
fn foot_on_block2(corners: &[super::Corner], b2: &super::Block, c: &Contact, corner: [f64; 2]) -> [f64; 2] {
    let n = b2.corner_count.max(1);
    // (k mod n and k + 1 mod n without a division where k < n, as it always is: stage 4 takes
    // this for every contact every cycle.)
    let k = c.feature / 2;
    let k = if k < n { k } else { k % n };
    let p = corners[(b2.corner_start + k) as usize].position;
    if c.feature % 2 == 0 {
        return p;
    }
    let next = if k + 1 < n { k + 1 } else { 0 };
    let q = corners[(b2.corner_start + next) as usize].position;
    let e = [q[0] - p[0], q[1] - p[1]];
    let len2 = e[0] * e[0] + e[1] * e[1];
    let t = if len2 > 0.0 { (((corner[0] - p[0]) * e[0] + (corner[1] - p[1]) * e[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
    [p[0] + t * e[0], p[1] + t * e[1]]
}

/// The load on a block (force x, y and moment about its centroid `centroid`) of a pressure jump
/// `jump` (the pressure of the piece of its boundary that ends at `foot`, less that of the piece
/// that starts there, going counter-clockwise round the block): see the module's "Loads".
#[inline]
pub fn pressure_load(jump: f64, foot: [f64; 2], centroid: [f64; 2]) -> [f64; 3] {
    let (rx, ry) = (foot[0] - centroid[0], foot[1] - centroid[1]);
    [-jump * ry, jump * rx, 0.5 * jump * (rx * rx + ry * ry)]
}

/// The pressure jump at contact `k`'s foot on its block on `side` (block 1: +, block 2: −), the
/// pressures of its two domains being p(`sides[0]`) and p(`sides[1]`); 0 for a contact that is not a
/// link.
#[inline]
pub fn pressure_jump(domains: &Domains, k: usize, side: u32) -> f64 {
    pressure_jump_with(domains, k, side, &|d| domains.list[d as usize].pressure)
}

/// [`pressure_jump`] with the domains' pressures from `pressure` (index in `Domains::list`):
/// stage 5 reads them from a packed copy (`cpu::flow`), the same numbers.
#[inline]
pub fn pressure_jump_with(domains: &Domains, k: usize, side: u32, pressure: &impl Fn(u32) -> f64) -> f64 {
    let Some(&[d0, d1]) = domains.sides.get(k) else { return 0.0 };
    if d0 == NO_DOMAIN || d0 == d1 {
        return 0.0;
    }
    let dp = pressure(d1) - pressure(d0);
    if side == 0 {
        dp
    } else {
        -dp
    }
}

/// Each loop of domain `d`'s boundary as a polygon with the current positions, in circuit order
/// (a contact gives the foot the circuit arrives at, then the one it leaves from), with for each
/// vertex the block whose boundary runs from it to the next (`u32::MAX` across a contact).
pub fn domain_loops(model: &Model, domains: &Domains, d: usize) -> Vec<Vec<([f64; 2], u32)>> {
    let dom = &domains.list[d];
    let start = dom.link_start as usize;
    let mut loops: Vec<Vec<([f64; 2], u32)>> = Vec::new();
    for (k, link) in domains.links_of(dom).iter().enumerate() {
        let bits = domains.link_sides.get(start + k).copied().unwrap_or(0);
        if bits & LOOP_START != 0 || loops.is_empty() {
            loops.push(Vec::new());
        }
        let poly = loops.last_mut().expect("pushed above");
        match *link {
            DomainLink::Contact { index, .. } => {
                let Some(c) = model.contacts.get(index as usize) else { continue };
                let s = u32::from(bits & 1);
                let block = if s == 0 { c.block1 } else { c.block2 };
                poly.push((contact_foot(model, c, 1 - s), u32::MAX));
                poly.push((contact_foot(model, c, s), block));
            }
            DomainLink::Corner { corner } => {
                if let Some(cn) = model.corners.get(corner as usize) {
                    poly.push((cn.position, cn.block));
                }
            }
        }
    }
    loops
}

/// The area the fluid calculation gives domain `d` now (¶7): a regular domain's void (its loops'
/// area, with the current positions), a joint domain's a·l (the mean aperture of its two
/// contacts when both are joints, else no known aperture), never below A_d(min); 0 for the outer
/// domain.
pub fn fluid_area(model: &Model, domains: &Domains, d: usize) -> f64 {
    let joint = |k: usize| {
        let c = &model.contacts[k];
        (c.joint_length > 0.0).then(|| aperture(c, &model.materials[material_slot(c.material, model.materials.len())]))
    };
    fluid_area_with(model, domains, d, &|k, side| contact_foot(model, &model.contacts[k], side), &joint)
}

/// [`fluid_area`] with the contacts' feet from `foot` (contact index, side) and, for a contact
/// that is a joint, its aperture from `joint` (contact index; None for a point contact): stage 5
/// takes each contact's two feet and its aperture once a cycle, where every domain's area would
/// take them again, twice for each domain a contact bounds. The same numbers in the same order.
pub fn fluid_area_with(model: &Model, domains: &Domains, d: usize, foot: &impl Fn(usize, u32) -> [f64; 2], joint: &impl Fn(usize) -> Option<f64>) -> f64 {
    let dom = &domains.list[d];
    match dom.kind {
        DomainKind::Outer => 0.0,
        DomainKind::Joint => {
            // The apertures of its contacts that are joints (without a list: every cycle).
            let (mut apertures, mut n) = ([0.0f64; 2], 0usize);
            for l in domains.links_of(dom) {
                if let DomainLink::Contact { index, .. } = *l {
                    if index as usize >= model.contacts.len() {
                        continue;
                    }
                    if let Some(a) = joint(index as usize) {
                        if n < 2 {
                            apertures[n] = a;
                        }
                        n += 1;
                    }
                }
            }
            if n == 2 {
                (0.5 * (apertures[0] + apertures[1]) * dom.length).max(domains.min_area)
            } else {
                domains.min_area
            }
        }
        DomainKind::Regular => regular_void(model, domains, d, foot).max(domains.min_area),
    }
}

/// The void of regular domain `d` now, below A_d(min) too (`fluid_area` gives at least that): where
/// the f32 kernels start the void they follow by its boundary's motion (`gpu::flow`).
pub fn void_area(model: &Model, domains: &Domains, d: usize) -> f64 {
    regular_void(model, domains, d, &|k, side| contact_foot(model, &model.contacts[k], side))
}

/// The void of regular domain `d`: its loops' area ([`domain_loops`]' vertices in their order,
/// each loop's shoelace sum Σ p_i × p_(i+1) taken in that order, as it was when the loops were
/// built first) without building the loops: stage 5 takes it for every domain every cycle.
/// The GPU's twin is `fluid_area` in flow.wgsl.
fn regular_void(model: &Model, domains: &Domains, d: usize, foot: &impl Fn(usize, u32) -> [f64; 2]) -> f64 {
    let dom = &domains.list[d];
    let start = dom.link_start as usize;
    let cross = |p: [f64; 2], q: [f64; 2]| p[0] * q[1] - q[0] * p[1];
    let (mut void, mut s) = (0.0, 0.0);
    let mut open: Option<([f64; 2], [f64; 2])> = None;
    let vertex = |v: [f64; 2], open: &mut Option<([f64; 2], [f64; 2])>, s: &mut f64| match open {
        Some((_, prev)) => {
            *s += cross(*prev, v);
            *prev = v;
        }
        None => *open = Some((v, v)),
    };
    for (k, link) in domains.links_of(dom).iter().enumerate() {
        let bits = domains.link_sides.get(start + k).copied().unwrap_or(0);
        if bits & LOOP_START != 0 {
            if let Some((first, last)) = open.take() {
                void += -(0.5 * (s + cross(last, first)));
                s = 0.0;
            }
        }
        match *link {
            DomainLink::Contact { index, .. } => {
                if index as usize >= model.contacts.len() {
                    continue;
                }
                let side = u32::from(bits & 1);
                vertex(foot(index as usize, 1 - side), &mut open, &mut s);
                vertex(foot(index as usize, side), &mut open, &mut s);
            }
            DomainLink::Corner { corner } => {
                if let Some(cn) = model.corners.get(corner as usize) {
                    vertex(cn.position, &mut open, &mut s);
                }
            }
        }
    }
    if let Some((first, last)) = open {
        void += -(0.5 * (s + cross(last, first)));
    }
    void
}

/// Calls `visit(block, edge, from, to)` for each piece of block boundary that bounds domain `d`,
/// in circuit order: the piece runs from `from` to `to` along the boundary of `block` (its index;
/// the block lies on the piece's left, the circuit keeping the void on its right) on its edge
/// `edge` (the index within the block of the corner the edge starts at). The contacts' feet come
/// from `foot` (contact index, side). The vertices are [`domain_loops`]' own: a piece never spans
/// a corner, whose link the circuit passes. `ring` is scratch for one loop's vertices (kept by
/// the caller, so that a cycle's walk of every domain allocates nothing).
pub fn boundary_pieces(
    model: &Model,
    domains: &Domains,
    d: usize,
    foot: &impl Fn(usize, u32) -> [f64; 2],
    ring: &mut Vec<PieceVertex>,
    visit: &mut impl FnMut(u32, u32, [f64; 2], [f64; 2]),
) {
    let dom = &domains.list[d];
    let start = dom.link_start as usize;
    ring.clear();
    let mut flush = |ring: &mut Vec<PieceVertex>| {
        for i in 0..ring.len() {
            if let (p, Some((b, e))) = ring[i] {
                visit(b, e, p, ring[(i + 1) % ring.len()].0);
            }
        }
        ring.clear();
    };
    for (k, link) in domains.links_of(dom).iter().enumerate() {
        let bits = domains.link_sides.get(start + k).copied().unwrap_or(0);
        if bits & LOOP_START != 0 {
            flush(ring);
        }
        match *link {
            DomainLink::Contact { index, .. } => {
                let Some(c) = model.contacts.get(index as usize) else { continue };
                let side = u32::from(bits & 1);
                let (block, edge) = if side == 0 {
                    (c.block1, c.corner - model.blocks[c.block1 as usize].corner_start)
                } else {
                    (c.block2, (c.feature / 2) % model.blocks[c.block2 as usize].corner_count.max(1))
                };
                ring.push((foot(index as usize, 1 - side), None));
                ring.push((foot(index as usize, side), Some((block, edge))));
            }
            DomainLink::Corner { corner } => {
                if let Some(cn) = model.corners.get(corner as usize) {
                    ring.push((cn.position, Some((cn.block, corner - model.blocks[cn.block as usize].corner_start))));
                }
            }
        }
    }
    flush(ring);
}

/// One vertex of a loop of a domain's boundary as [`boundary_pieces`] walks it, with the piece of
/// block boundary it starts (block, edge), if any.
pub type PieceVertex = ([f64; 2], Option<(u32, u32)>);

/// The share of the domain pressures that a deformable block takes beyond its force and moment
/// (the module's "Loads", which `cpu::flow` sums for every block by the pressure jumps at the
/// contacts' feet):
/// - a simply-deformable block's applied stress times area (`model::sdef`, KSA): a uniform
///   pressure p on a piece of its boundary from a to b is the force p·perp(b − a) spread evenly
///   along it, whose Σ r ⊗ f is exactly (m − c) ⊗ p·perp(b − a), m the piece's midpoint and c the
///   centroid. Round the whole block, −p·A·I: a block pressed on all sides by p takes the mean
///   stress −p, as a contact force would make it (¶3, ¶19);
/// - a zoned block's grid point loads (`model::fdef`): the same force split between the two
///   grid points of the edge k, k + 1 the piece lies on by the linear shape functions of the
///   edge, 1 − t̄ and t̄ with t̄ the mean of the piece's ends' parameters along the edge (so the
///   loads do on the grid points' motion the work the pressure does on the boundary's).
///
/// `applied` is indexed like the blocks (empty where the scene has no simply-deformable block),
/// `gridpoint` like the corners (a zoned block's corner k is its grid point k; empty where the
/// scene has no fully-deformable block). Summed serially, domain by domain in list order and
/// each domain's pieces in circuit order, so a run repeats bit for bit. `ring` is
/// [`boundary_pieces`]' scratch.
pub fn deformable_pressure_loads(
    model: &Model,
    domains: &Domains,
    foot: &impl Fn(usize, u32) -> [f64; 2],
    applied: &mut Vec<[f64; 4]>,
    gridpoint: &mut Vec<[f64; 2]>,
    ring: &mut Vec<PieceVertex>,
) {
    applied.clear();
    gridpoint.clear();
    if !model.sdef.is_empty() {
        applied.resize(model.blocks.len(), [0.0; 4]);
    }
    if !model.fdef.is_empty() {
        gridpoint.resize(model.corners.len(), [0.0; 2]);
    }
    if applied.is_empty() && gridpoint.is_empty() {
        return;
    }
    let (mut to_applied, mut to_point) = (std::mem::take(applied), std::mem::take(gridpoint));
    for (d, dom) in domains.list.iter().enumerate() {
        let p = dom.pressure;
        if p == 0.0 {
            continue;
        }
        pressure_pieces(model, domains, d, p, foot, ring, &mut |b, a| to_applied[b as usize].iter_mut().zip(a).for_each(|(x, y)| *x += y), &mut |g, f| {
            let x = &mut to_point[g as usize];
            x[0] += f[0];
            x[1] += f[1];
        });
    }
    *applied = to_applied;
    *gridpoint = to_point;
}

/// The pieces of [`deformable_pressure_loads`] of domain `d` at pressure `p`: `sdef(b, a)` for
/// each piece on simply-deformable block b with its applied stress times area a (11, 12, 21,
/// 22), `point(g, f)` for each of the two grid points g (a corner index) of a piece on a zoned
/// block with its share f of the piece's force; in circuit order. The GPU's twin is
/// `pressure_pieces` in flow.wgsl (each piece stored at its link, the blocks and grid points
/// gathering theirs in the same order: `fluid_block_loads`, `gridpoint_fluid_loads`).
#[allow(clippy::too_many_arguments)]
pub fn pressure_pieces(
    model: &Model,
    domains: &Domains,
    d: usize,
    p: f64,
    foot: &impl Fn(usize, u32) -> [f64; 2],
    ring: &mut Vec<PieceVertex>,
    sdef: &mut impl FnMut(u32, [f64; 4]),
    point: &mut impl FnMut(u32, [f64; 2]),
) {
    boundary_pieces(model, domains, d, foot, ring, &mut |b, edge, from, to| {
        let block = &model.blocks[b as usize];
        let f = [-p * (to[1] - from[1]), p * (to[0] - from[0])];
        if model.sdef_of(b as usize).is_some() {
            let m = [0.5 * (from[0] + to[0]), 0.5 * (from[1] + to[1])];
            sdef(b, super::sdef::applied_stress(m, block.centroid, f));
        } else if model.fdef_of(b as usize).is_some_and(|z| !z.zones.is_empty()) {
            let n = block.corner_count.max(1);
            let (i, j) = (block.corner_start + edge % n, block.corner_start + (edge + 1) % n);
            let (pi, pj) = (model.corners[i as usize].position, model.corners[j as usize].position);
            let e = [pj[0] - pi[0], pj[1] - pi[1]];
            let len2 = e[0] * e[0] + e[1] * e[1];
            let t = |x: [f64; 2]| if len2 > 0.0 { (((x[0] - pi[0]) * e[0] + (x[1] - pi[1]) * e[1]) / len2).clamp(0.0, 1.0) } else { 0.5 };
            let tm = 0.5 * (t(from) + t(to));
            point(i, [(1.0 - tm) * f[0], (1.0 - tm) * f[1]]);
            point(j, [tm * f[0], tm * f[1]]);
        }
    });
}

/// The flows of every contact now ([`ContactFlow`]: positive from its first domain to its
/// second), written into `domains.flows`, and each domain's net inflow Q into `inflow`: summed
/// in contact order, so a run repeats bit for bit.
pub fn contact_flows(model: &Model, domains: &mut Domains, inflow: &mut Vec<f64>) {
    let mut flows = std::mem::take(&mut domains.flows);
    flows.clear();
    flows.extend((0..model.contacts.len()).map(|k| contact_flow(model, domains, k)));
    domains.flows = flows;
    sum_inflows(domains, inflow);
}

/// Contact `k`'s flow now ([`ContactFlow`]: positive from its first domain to its second), its
/// aperture and length: each contact alone (stage 5 takes them on its threads).
#[inline]
pub fn contact_flow(model: &Model, domains: &Domains, k: usize) -> ContactFlow {
    let c = &model.contacts[k];
    contact_flow_of(c, &model.materials[material_slot(c.material, model.materials.len())], domains, k)
}

/// [`contact_flow`] of contact `c`, the `k`-th, of material `mat` (its own: stage 4 takes each
/// contact's flow right after its force, `cpu::contact_forces`, with the material it has at
/// hand; the joint's aperture reads that force).
#[inline]
pub fn contact_flow_of(c: &Contact, mat: &Material, domains: &Domains, k: usize) -> ContactFlow {
    let a = aperture(c, mat);
    let mut f = ContactFlow { flow: 0.0, aperture: a, length: c.joint_length };
    if let Some(&[d0, d1]) = domains.sides.get(k) {
        if d0 != NO_DOMAIN && d0 != d1 {
            let dp = domains.list[d0 as usize].pressure - domains.list[d1 as usize].pressure;
            f.flow = conductance(c, mat, a) * dp;
        }
    }
    f
}

/// The first domain (in list order) whose pressure is not finite, and a block it bounds (the
/// block of its first corner or contact link), as their ids: a flow law or a fluid stiff past
/// f64 (CPERM = 1e300: its step underflowed to 1e-308 and a flow of 1e300 × Δp overflowed) made
/// NaN pressures and, around fixed blocks that nothing moved, NaN forces that no step check saw
/// (found by tests/suite/random_decks.rs). None without domains.
pub fn non_finite_pressure(model: &Model) -> Option<(u32, u32)> {
    let domains = model.domains.as_ref()?;
    let d = domains.list.iter().find(|d| !d.pressure.is_finite())?;
    Some((d.id, block_beside(model, domains, d)))
}

/// The domain of the largest pressure in magnitude (the first in list order of equals), its
/// pressure, and a block it bounds, as ids: where the fluid's work overflowed (PFIX OUTER 1E300
/// pushing on a block of a few metres), the pressure that did it. None without domains.
pub fn largest_pressure(model: &Model) -> Option<(u32, f64, u32)> {
    let domains = model.domains.as_ref()?;
    let d = domains.list.iter().reduce(|a, b| if b.pressure.abs() > a.pressure.abs() { b } else { a })?;
    Some((d.id, d.pressure, block_beside(model, domains, d)))
}

/// A block domain `d` bounds (that of its first corner or contact link), as its id.
fn block_beside(model: &Model, domains: &Domains, d: &Domain) -> u32 {
    let block = domains.links_of(d).iter().find_map(|l| match *l {
        DomainLink::Corner { corner } => model.corners.get(corner as usize).map(|c| c.block),
        DomainLink::Contact { index, .. } => model.contacts.get(index as usize).map(|c| c.block1),
    });
    block.and_then(|b| model.blocks.get(b as usize)).or(model.blocks.first()).map_or(0, |b| b.id)
}

/// Each domain's net inflow Q from `domains.flows` into `inflow`, summed in contact order, so a
/// run repeats bit for bit.
pub fn sum_inflows(domains: &Domains, inflow: &mut Vec<f64>) {
    inflow.clear();
    inflow.resize(domains.list.len(), 0.0);
    for (k, f) in domains.flows.iter().enumerate() {
        if let Some(&[d0, d1]) = domains.sides.get(k) {
            if d0 != NO_DOMAIN && d0 != d1 {
                inflow[d0 as usize] -= f.flow;
                inflow[d1 as usize] += f.flow;
            }
        }
    }
}

/// The explicit limits the fluid puts on the time step, for the domains as they are now:
/// - the pressure update (¶7) is forward Euler on dp/dt = (bulkw/A_d)·Σ c (p_j − p_d); its
///   eigenvalues lie within 2·bulkw·Σc/A_d of the origin (Gershgorin), so
///   Δt ≤ A_d/(bulkw·Σc) over the free domains is stable; a joint's conductance is taken at
///   the larger of its aperture now and a_0;
/// - a free domain whose volume follows the blocks is a spring on each block around it of
///   stiffness bulkw·L²/A_d (L the length of the block's boundary on it): with the stiffest
///   contact k_max, Δt ≤ FRAC·2√(m/(k_max + Σ bulkw·L²/A_d)) over the free blocks, as UDEC's
///   2√(m/k);
/// - on a simply-deformable block the same spring acts on the strain modes: a strain ε_ij
///   changes the void by ∫ r_i n_j ds over the block's boundary on it, which is the applied
///   stress times area per unit pressure a_ij (`deformable_pressure_loads`), so the mode's
///   stiffness is bulkw·a_ij²/A_d; the largest of 11, 22 and the mean of 12 and 21, added to the
///   block's own volumetric stiffness, enters its internal limit ½·2√(M_min/k) (`model::sdef`);
/// - on a zoned block the spring acts on each boundary grid point, of stiffness bulkw·ℓ²/A_d
///   with ℓ the grid point's share of the block's boundary on the domain (the edge's shape
///   function integrated along it, the void's change per unit motion): Δt ≤ FRAC·2√(m_g/(k_max
///   + Σ bulkw·ℓ²/A_d)) over the boundary grid points, as the contacts' limit on them.
///
/// None without fluid or domains, or where neither limits anything.
pub fn fluid_timestep(model: &Model, k_contact: f64) -> Option<f64> {
    let (fluid, domains) = (model.fluid.as_ref()?, model.domains.as_ref()?);
    let k_bulk = fluid.bulk;
    let mut dt = f64::INFINITY;
    let mut sum_c = vec![0.0f64; domains.list.len()];
    for (k, c) in model.contacts.iter().enumerate() {
        let Some(&[d0, d1]) = domains.sides.get(k) else { continue };
        if d0 == NO_DOMAIN || d0 == d1 {
            continue;
        }
        let mat = &model.materials[material_slot(c.material, model.materials.len())];
        let a = aperture(c, mat).max(mat.fluid.azero);
        let cond = conductance(c, mat, a);
        sum_c[d0 as usize] += cond;
        sum_c[d1 as usize] += cond;
    }
    let mut k_fluid = vec![0.0f64; model.blocks.len()];
    // The deformable blocks' springs (none in a scene of rigid blocks): each simply-deformable
    // block's strain-mode stiffness, each zoned block's boundary grid point's.
    let deformable = model.sdef.len() + model.fdef.len() > 0;
    let mut k_strain = vec![0.0f64; if deformable { model.blocks.len() } else { 0 }];
    let mut k_point = vec![0.0f64; if deformable { model.corners.len() } else { 0 }];
    let zoned = |b: usize| model.fdef_of(b).is_some_and(|f| !f.zones.is_empty());
    let mut ring = Vec::new();
    for (d, dom) in domains.list.iter().enumerate() {
        if !is_free(dom.kind, dom.fixed) {
            continue;
        }
        let area = fluid_area(model, domains, d);
        if sum_c[d] > 0.0 && area > 0.0 {
            dt = dt.min(area / (k_bulk * sum_c[d]));
        }
        // A joint domain of point contacts has the constant area A_d(min): no spring.
        if dom.kind == DomainKind::Joint && area <= domains.min_area {
            continue;
        }
        let mut lengths: Vec<(u32, f64)> = Vec::new();
        for l in domain_loops(model, domains, d) {
            for i in 0..l.len() {
                let (p, b) = l[i];
                if b == u32::MAX {
                    continue;
                }
                let q = l[(i + 1) % l.len()].0;
                let len = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
                match lengths.iter_mut().find(|(x, _)| *x == b) {
                    Some(e) => e.1 += len,
                    None => lengths.push((b, len)),
                }
            }
        }
        for (b, len) in lengths {
            if let Some(k) = k_fluid.get_mut(b as usize) {
                *k += k_bulk * len * len / area;
            }
        }
        if deformable {
            // Per unit pressure: each simply-deformable block's a_ij, each grid point's ℓ.
            let mut strain: Vec<(u32, [f64; 4])> = Vec::new();
            let mut points: Vec<(u32, f64)> = Vec::new();
            let foot = |k: usize, side: u32| contact_foot(model, &model.contacts[k], side);
            pressure_pieces(
                model,
                domains,
                d,
                1.0,
                &foot,
                &mut ring,
                &mut |b, a| match strain.iter_mut().find(|(x, _)| *x == b) {
                    Some(e) => e.1.iter_mut().zip(a).for_each(|(x, y)| *x += y),
                    None => strain.push((b, a)),
                },
                &mut |g, f| {
                    let l = (f[0] * f[0] + f[1] * f[1]).sqrt();
                    match points.iter_mut().find(|(x, _)| *x == g) {
                        Some(e) => e.1 += l,
                        None => points.push((g, l)),
                    }
                },
            );
            for (b, a) in strain {
                let m = a[0].abs().max(a[3].abs()).max(0.5 * (a[1] + a[2]).abs());
                k_strain[b as usize] += k_bulk * m * m / area;
            }
            for (g, l) in points {
                k_point[g as usize] += k_bulk * l * l / area;
            }
        }
    }
    for (b, blk) in model.blocks.iter().enumerate() {
        if !blk.fixed && blk.mass > 0.0 && k_fluid[b] > 0.0 && !zoned(b) {
            dt = dt.min(model.frac * 2.0 * (blk.mass / (k_contact + k_fluid[b])).sqrt());
        }
        if blk.fixed || !deformable {
            continue;
        }
        if let Some(s) = model.sdef_of(b).filter(|_| k_strain[b] > 0.0) {
            let own = super::sdef::internal_stiffness(&model.material(blk.material).block, blk.area);
            let least = super::sdef::least_moment(s.moments);
            if least > 0.0 {
                dt = dt.min(super::timestep::SDEF_STEP_SAFETY * 2.0 * (least / (own + k_strain[b])).sqrt());
            }
        }
        if let Some(f) = model.fdef_of(b).filter(|f| !f.zones.is_empty()) {
            for (k, g) in f.gridpoints[..(f.boundary as usize).min(blk.corner_count as usize)].iter().enumerate() {
                let kg = k_point[blk.corner_start as usize + k];
                if kg > 0.0 && g.mass > 0.0 {
                    dt = dt.min(model.frac * 2.0 * (g.mass / (k_contact + kg)).sqrt());
                }
            }
        }
    }
    dt.is_finite().then_some(dt)
}

/// The failure of a fluid limit on the time step (`fluid_timestep`) that underflows f64: with
/// it no time would pass while the flows, conductance × Δp, overflow. Names the fluid's bulk
/// modulus and the largest flow-law constants the contacts use, where such a limit comes from.
pub fn step_underflow_text(model: &Model, dt: f64) -> String {
    let bulk = model.fluid.map_or(0.0, |f| f.bulk);
    let (mut cperm, mut jperm) = ((0.0f64, 0u32), (0.0f64, 0u32));
    for c in &model.contacts {
        let f = &model.material(c.material).fluid;
        if f.cperm > cperm.0 {
            cperm = (f.cperm, c.material);
        }
        if f.jperm > jperm.0 {
            jperm = (f.jperm, c.material);
        }
    }
    let largest = |(k, m): (f64, u32), name: &str| if k > 0.0 { format!(", the largest {name} {k:e} of material {m}") } else { String::new() };
    format!(
        "the fluid's explicit limit on the time step (A_d/(bulkw·Σc) over the domains, ¶7, and the domains' stiffness bulkw·L²/A_d on the \
         blocks) is {dt:e} at cycle {}: it underflows f64, and no time would pass; the fluid's bulk modulus ({bulk:e}, FLUID) or the \
         flow laws' conductances (q = c·Δp{}{}) are too large for the domains' areas — check the units of CPERM, JPERM and FLUID",
        model.cycle,
        largest(cperm, "CPERM"),
        largest(jperm, "JPERM"),
    )
}

/// The failure of a contact flow past f64 (q = c·Δp; PFIX OUTER 1E300 beside CPERM 10), the
/// first in contact order, naming its blocks, domains and their pressures; None where every
/// flow `domains.flows` holds is finite.
pub fn flow_overflow_text(model: &Model) -> Option<String> {
    let domains = model.domains.as_ref()?;
    let k = domains.flows.iter().position(|f| !f.flow.is_finite())?;
    let c = model.contacts.get(k)?;
    let id = |b: u32| model.blocks.get(b as usize).map_or(0, |b| b.id);
    let [d0, d1] = domains.sides.get(k).copied().unwrap_or([NO_DOMAIN; 2]);
    let domain = |d: u32| domains.list.get(d as usize).map_or((0, f64::NAN), |d| (d.id, d.pressure));
    let ((i0, p0), (i1, p1)) = (domain(d0), domain(d1));
    Some(format!(
        "the flow across the contact of blocks {} and {} (q = c·Δp, ¶6), from domain {i0} at pressure {p0:e} to domain {i1} at {p1:e}, \
         overflows f64; check PFIX, CPERM, JPERM and the units",
        id(c.block1),
        id(c.block2)
    ))
}

/// The domain PFIX … AT x y names: the regular domain whose void holds the point (the smallest
/// if voids nest), else the joint domain nearest to it within a quarter of its length, else the outer
/// domain when the point lies in no block; None when it lies in a block away from any joint.
pub fn domain_at(model: &Model, domains: &Domains, p: [f64; 2]) -> Option<usize> {
    use super::geometry::point_in_polygon;
    let mut best: Option<(usize, f64)> = None;
    for (d, dom) in domains.list.iter().enumerate() {
        if dom.kind != DomainKind::Regular {
            continue;
        }
        let loops = domain_loops(model, domains, d);
        let Some(first) = loops.first() else { continue };
        let outline: Vec<[f64; 2]> = first.iter().map(|v| v.0).collect();
        let in_island = loops[1..].iter().any(|l| point_in_polygon(p, &l.iter().map(|v| v.0).collect::<Vec<_>>()));
        if point_in_polygon(p, &outline) && !in_island && best.is_none_or(|(_, a)| dom.void_area < a) {
            best = Some((d, dom.void_area));
        }
    }
    if let Some((d, _)) = best {
        return Some(d);
    }
    let mut nearest: Option<(usize, f64)> = None;
    for (d, dom) in domains.list.iter().enumerate() {
        if dom.kind != DomainKind::Joint {
            continue;
        }
        let ends: Vec<[f64; 2]> = domains
            .links_of(dom)
            .iter()
            .filter_map(|l| if let DomainLink::Contact { index, .. } = *l { model.contacts.get(index as usize).map(|c| c.point) } else { None })
            .collect();
        if ends.len() != 2 {
            continue;
        }
        let dist = point_segment_distance(p, ends[0], ends[1]);
        if dist < 0.25 * dom.length && nearest.is_none_or(|(_, x)| dist < x) {
            nearest = Some((d, dist));
        }
    }
    if let Some((d, _)) = nearest {
        return Some(d);
    }
    let inside_block = (0..model.blocks.len()).any(|b| point_in_polygon(p, &model.corner_positions(b)));
    if inside_block {
        None
    } else {
        domains.list.iter().position(|d| d.kind == DomainKind::Outer)
    }
}

fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let e = [b[0] - a[0], b[1] - a[1]];
    let len2 = e[0] * e[0] + e[1] * e[1];
    let t = if len2 > 0.0 { (((p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
    ((p[0] - a[0] - t * e[0]).powi(2) + (p[1] - a[1] - t * e[1]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform pressure all round a block loads it with nothing; on the top half of a unit
    /// square (from (1, ½) round to (0, ½)) it pushes down with p·1 and no moment.
    #[test]
    fn pressure_loads_add_up_to_the_pressure_on_the_boundary() {
        let c = [0.5, 0.5];
        let p = 3.0;
        // The piece from a = (1, ½) to b = (0, ½) at pressure p, the rest at 0: at a the jump
        // is 0 − p (the piece ending there is at 0), at b it is p − 0.
        let la = pressure_load(-p, [1.0, 0.5], c);
        let lb = pressure_load(p, [0.0, 0.5], c);
        let f = [la[0] + lb[0], la[1] + lb[1], la[2] + lb[2]];
        assert!((f[0]).abs() < 1e-15 && (f[1] + p).abs() < 1e-15 && f[2].abs() < 1e-15, "{f:?}");
        // Off-centre: the piece over the top edge only, (1, 1) to (0, 1): the force p·1 down at
        // x = ½, no moment about the centre; about (0, ½) it is p·½ clockwise.
        let m = |c: [f64; 2]| pressure_load(-p, [1.0, 1.0], c)[2] + pressure_load(p, [0.0, 1.0], c)[2];
        assert!(m([0.5, 0.5]).abs() < 1e-15);
        assert!((m([0.0, 0.5]) + 0.5 * p).abs() < 1e-15, "{}", m([0.0, 0.5]));
    }

    /// The update keeps the fluid mass A(1 + p/K) but for the inflow, and is the report's
    /// p += Q·K·Δt/A at constant area.
    #[test]
    fn the_pressure_step_conserves_the_fluid_mass() {
        let (k, p, a0, a1, q) = (1e9, 2e5, 3.0, 2.9, 1e-4);
        let p1 = pressure_step(p, a0, a1, q, k);
        let before = a0 * (1.0 + p / k);
        let after = a1 * (1.0 + p1 / k);
        assert!((after - before - q).abs() < 1e-12, "{}", after - before - q);
        assert!((pressure_step(p, a0, a0, q, k) - (p + q * k / a0)).abs() < 1e-6);
    }
}
