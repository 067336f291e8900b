//! Fluid flow on the device (issue 30, stage 5; twin of `cpu::flow`): the domains, their flows
//! and boundaries, each contact's two domains and flow, each block's fluid load, in slots of
//! their own (`layout::Domain`, `layout::ContactFlow`, `layout::FluidLoad`, CSR words), made,
//! uploaded and read back only in a scene with fluid; a dry scene compiles, binds and
//! dispatches nothing of them (`kernels::FluidKernels`).
//!
//! The domains stay the CPU's (stage 7, `topology::domain`): each topology change rebuilds them
//! on the CPU (`cpu::maybe_update_topology`, `cpu::fluid_after_topology`), and the device takes
//! them whole (`upload_fluid`), with each domain's flows as a CSR list in ascending contact
//! order, so that its inflow is summed in the CPU's order and a rerun repeats bit for bit. Each
//! cycle runs `law_of_motion_fluid` (each block's fluid load summed in the same walk of its list
//! as its contact forces), the contact stage, then flow.wgsl's `flow` (per contact),
//! `domain_terms` (the terms of the long domains' sums, one invocation each: `term_items`,
//! `LONG_WALK`) and `domain_pressures` (per domain, which leaves each contact's two pressures
//! next to its feet for the next gather). What differs
//! otherwise, as in an SDEF scene: contact updates upload the contact list whole, so the splice
//! and partial read-backs are off. A read-back gives the model each domain's pressure and area,
//! each contact's flow and the ledger's fluid work and inflow (accumulated on the device from
//! zero since the upload, added to their f64 bases as the external work is).
//!
//! With simply-deformable or zoned blocks the pressures also push on their boundaries (the
//! CPU's `model::fluid::deformable_pressure_loads`): at each cycle's start `pressure_pieces`
//! (flow.wgsl) writes, per domain, each piece of block boundary around it at the link it follows
//! (`layout::FluidPiece`: an SDEF block's Σ r⊗f, a zoned block's force split to its edge's grid
//! points), `fluid_block_loads` sums each block's fluid load and an SDEF block's pieces, and for
//! zoned blocks `gridpoint_fluid_loads` its grid points' (each block's pieces as a CSR list in
//! ascending link order, the CPU's order: reruns repeat bit for bit); the block pass
//! (`law_of_motion_sdef_fluid`, `law_of_motion_fdef_fluid`) adds them to the contact sums that
//! `gather_sdef` or `gather_fdef` stored, and books their work as the CPU does (A : Δε, and a
//! grid point's F·½(v_old + v_new)·Δt from `step_gridpoints_fluid`). A void with a deformable
//! block on its boundary (`DOMAIN_REGULAR_DEFORMED`) is measured from its outline each step in
//! f64; in f32 it is followed by its boundary's motion as the voids of rigid blocks are, each
//! corner's move in the step (`corner_moves_sdef`, `corner_moves_fdef`: the rigid motion, an
//! SDEF block's strain increment, a zoned block's grid points' v·Δt) summed edge by edge
//! (`deformed_terms`), since its outline's round-off, times bulkw/A, was noise in its pressure. None of this is made,
//! bound or dispatched in a scene without both fluid and deformable blocks.

use crate::udec::model::domain::{DomainKind, DomainLink, NO_DOMAIN};
use crate::udec::model::{Model, MAX_MATERIALS};

use super::kernels::{FluidSizes, WetDeformableSizes};
use super::layout::{
    ContactFlow, Domain, FluidLoad, FluidMaterial, FluidParams, Real, DOMAIN_JOINT, DOMAIN_OUTER, DOMAIN_REGULAR, DOMAIN_REGULAR_DEFORMED, LINK_CORNER,
    LINK_LOOP_START, LINK_SIDE,
};
use super::{r, Engine, GpuError, Uploaded};

/// The device's fluid state of a model (`upload_fluid`).
struct FluidUpload<R: Real> {
    domains: Vec<Domain<R>>,
    flows: Vec<u32>,
    links: Vec<u32>,
    sides: Vec<u32>,
    loads: Vec<FluidLoad<R>>,
    /// Each contact's flow as the CPU found it at the rebuild (what a read-back before the
    /// first cycle gives back; the first `flow` pass writes them all again), its feet from its
    /// blocks' centroids and its two domains' pressures now, which the first cycle's gather reads
    /// for the pressure loads (`add_pressure_load`, gather.wgsl).
    contact_flows: Vec<ContactFlow<R>>,
    /// In a scene with deformable blocks: each deformable block's pieces of boundary around the
    /// domains (the indices of the links they follow), as CSR words (offsets for blocks 0 ..= n
    /// into the same array, then the entries, ascending: domain by domain in list order, each
    /// circuit in order, the CPU's order of `model::fluid::deformable_pressure_loads`). Empty
    /// in a scene of rigid blocks.
    block_pieces: Vec<u32>,
    /// The items of `domain_terms` (`term_items`).
    term_items: Vec<u32>,
}

impl<R: Real> FluidUpload<R> {
    /// `deformed_by_motion`: the f32 kernels follow the voids of deformable blocks by their
    /// boundary's motion (`deformed_terms`, items for each of their links).
    fn of(model: &Model, deformable: bool, deformed_by_motion: bool) -> Self {
        let domains = model.domains.as_ref().expect("a scene with fluid has its domains");
        let n = domains.list.len();
        let is_deformable = |b: u32| model.sdef_of(b as usize).is_some() || super::fdef::is_zoned(model, b as usize);
        let mut pieces: Vec<Vec<u32>> = vec![Vec::new(); if deformable { model.blocks.len() } else { 0 }];
        // Each domain's flows, ascending by contact: the order the CPU sums them in
        // (`model::fluid::contact_flows`).
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n];
        let mut sides = vec![NO_DOMAIN; 2 * model.contacts.len()];
        for k in 0..model.contacts.len() {
            let Some(&[d0, d1]) = domains.sides.get(k) else { continue };
            sides[2 * k] = d0;
            sides[2 * k + 1] = d1;
            if d0 != NO_DOMAIN && d0 != d1 {
                lists[d0 as usize].push((k as u32) << 1);
                lists[d1 as usize].push(((k as u32) << 1) | 1);
            }
        }
        let mut flows = Vec::with_capacity(lists.iter().map(Vec::len).sum());
        let mut links = Vec::with_capacity(4 * domains.links.len());
        let mut out = Vec::with_capacity(n);
        for (d, (dom, list)) in domains.list.iter().zip(lists).enumerate() {
            let link_start = (links.len() / 4) as u32;
            let first = dom.link_start as usize;
            // Whether a deformable block bounds this void (its outline is then measured each
            // step: `DOMAIN_REGULAR_DEFORMED`).
            let mut wet_outline = false;
            for (j, link) in domains.links_of(dom).iter().enumerate() {
                let bits = domains.link_sides.get(first + j).copied().unwrap_or(0);
                let mut word = if bits & crate::udec::model::domain::LOOP_START != 0 { LINK_LOOP_START } else { 0 };
                let l = (links.len() / 4) as u32;
                // The block the piece after the link lies on (`piece_block`, flow.wgsl).
                let own = match *link {
                    DomainLink::Contact { index, .. } => {
                        let c = &model.contacts[index as usize];
                        word |= u32::from(bits & 1) * LINK_SIDE;
                        links.extend([word, index, c.block1, c.block2]);
                        if bits & 1 == 0 {
                            c.block1
                        } else {
                            c.block2
                        }
                    }
                    DomainLink::Corner { corner } => {
                        let block = model.corners[corner as usize].block;
                        links.extend([word | LINK_CORNER, corner, block, block]);
                        block
                    }
                };
                if deformable && is_deformable(own) {
                    pieces[own as usize].push(l);
                }
                if deformable && is_deformable(own) && dom.kind == DomainKind::Regular {
                    wet_outline = true;
                }
            }
            let kind = match dom.kind {
                DomainKind::Regular if wet_outline => DOMAIN_REGULAR_DEFORMED,
                DomainKind::Regular => DOMAIN_REGULAR,
                DomainKind::Joint => DOMAIN_JOINT,
                DomainKind::Outer => DOMAIN_OUTER,
            };
            // A regular domain's void, from which the f32 kernels follow it by its boundary's
            // motion: its area as the model has it (the device's own where it read the domains
            // back, so a run that goes on goes on from there) unless A_d(min) holds it.
            let void_base = match dom.kind {
                DomainKind::Regular if dom.area > domains.min_area => dom.area,
                DomainKind::Regular => crate::udec::model::fluid::void_area(model, domains, d),
                _ => 0.0,
            };
            out.push(Domain {
                pressure: r(dom.pressure),
                area: r(dom.area),
                length: r(dom.length),
                inflow: R::default(),
                void_base: r(void_base),
                void_change: R::default(),
                free: crate::udec::model::fluid::is_free(dom.kind, dom.fixed) as u32,
                kind,
                flow_start: flows.len() as u32,
                flow_count: list.len() as u32,
                link_start,
                link_count: (links.len() / 4) as u32 - link_start,
            });
            flows.extend(list);
            debug_assert_eq!(d + 1, out.len());
        }
        let fluid = model.fluid.expect("a scene with fluid");
        let g = model.gravity;
        let loads = model
            .blocks
            .iter()
            .map(|b| FluidLoad { buoy_x: r(-fluid.density * b.area * g[0]), buoy_y: r(-fluid.density * b.area * g[1]), work: R::default() })
            .collect();
        let contact_flows = model
            .contacts
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let f = domains.flows.get(k).copied().unwrap_or_default();
                // A foot from its block's centroid (`model::fluid::contact_foot`, as `flow` takes it).
                let foot = |side: u32, block: u32| {
                    let (p, o) = (crate::udec::model::fluid::contact_foot(model, c, side), model.blocks[block as usize].centroid);
                    [r(p[0] - o[0]), r(p[1] - o[1])]
                };
                let ([f0x, f0y], [f1x, f1y]) = (foot(0, c.block1), foot(1, c.block2));
                // Each domain's pressure where the contact is a link between two (the jump that
                // `model::fluid::pressure_jump` takes), 0 on both sides where it is not.
                let (p0, p1) = match (sides[2 * k], sides[2 * k + 1]) {
                    (d0, d1) if d0 != NO_DOMAIN && d0 != d1 => (r(domains.list[d0 as usize].pressure), r(domains.list[d1 as usize].pressure)),
                    _ => (R::default(), R::default()),
                };
                ContactFlow { flow: r(f.flow), aperture: r(f.aperture), length: r(f.length), f0x, f0y, f1x, f1y, p0, p1 }
            })
            .collect();
        let mut block_pieces = Vec::new();
        if deformable {
            let mut at = (pieces.len() + 1) as u32;
            block_pieces.reserve(pieces.len() + 1 + links.len() / 4);
            for p in &pieces {
                block_pieces.push(at);
                at += p.len() as u32;
            }
            block_pieces.push(at);
            block_pieces.extend(pieces.into_iter().flatten());
        }
        let term_items = term_items(&out, &links, long_walk(), deformed_by_motion);
        FluidUpload { domains: out, flows, links, sides, loads, contact_flows, block_pieces, term_items }
    }
}

impl<R: Real> Engine<R> {
    /// With a new contact list (and at a run's start, resumed or not) in a scene with fluid: its
    /// kernels and slots made (once), the domains, their flows and boundaries, each contact's
    /// domains, each block's load now and the fluid's constants uploaded, the accumulators of
    /// fluid work and inflow counted from here (their bases the model's). Returns whether a
    /// buffer was re-created (the bind groups must then be rebuilt). Nothing in a dry scene.
    pub(super) fn upload_fluid(&mut self, model: &Model) -> Result<bool, GpuError> {
        self.fluid_scene = model.fluid.is_some() && model.domains.is_some();
        if !self.fluid_scene {
            self.n_domains = 0;
            self.n_term_items = 0;
            return Ok(false);
        }
        let had_kernels = self.pipelines.fluid.is_some();
        self.pipelines.with_fluid(&self.dev)?;
        // With deformable blocks (their kinds uploaded before: `upload_sdef`, `upload_fdef`),
        // the kernels and slots of the pressures' push on them.
        let deformable = self.sdef_scene || self.fdef_scene;
        let had_wet = if self.sdef_scene { self.pipelines.wet_sdef.is_some() } else { self.pipelines.wet_fdef.is_some() };
        if self.sdef_scene {
            self.pipelines.with_wet_sdef(&self.dev)?;
        } else if self.fdef_scene {
            self.pipelines.with_wet_fdef(&self.dev)?;
        }
        // In f32 the voids of deformable blocks are followed by their boundary's motion
        // (`corner_moves_*`, `deformed_terms`; in f64 their outline is exact enough).
        let deformed_by_motion = deformable && self.dev.precision == super::Precision::F32;
        let up = FluidUpload::<R>::of(model, deformable, deformed_by_motion);
        let sizes = FluidSizes {
            domains: up.domains.len(),
            flows: up.flows.len(),
            links: up.links.len() / 4,
            contacts: model.contacts.len(),
            blocks: model.blocks.len(),
            term_items: up.term_items.len() / 4,
        };
        let b = self.buffers.as_mut().expect("buffers exist");
        let mut made = b.ensure_fluid::<R>(&self.dev, sizes)?;
        if deformable {
            let wet = WetDeformableSizes {
                links: sizes.links,
                csr: up.block_pieces.len(),
                blocks: sizes.blocks,
                gridpoints: self.fdef_counts.0,
                corners: model.corners.len(),
            };
            made |= b.ensure_wet_deformable::<R>(&self.dev, wet)?;
        }
        let fluid = model.fluid.expect("checked above");
        let domains = model.domains.as_ref().expect("checked above");
        let params = FluidParams::<R> {
            bulk: r(fluid.bulk),
            min_area: r(domains.min_area),
            n_domains: up.domains.len() as u32,
            n_links: sizes.links as u32,
            n_term_items: sizes.term_items as u32,
            long_walk: long_walk(),
            ..Default::default()
        };
        let mut materials = vec![FluidMaterial::<R>::default(); MAX_MATERIALS];
        for (g, m) in materials.iter_mut().zip(&model.materials) {
            let f = &m.fluid;
            *g = FluidMaterial { jperm: r(f.jperm), cperm: r(f.cperm), azero: r(f.azero), ares: r(f.ares) };
        }
        let b = self.buffers();
        let q = &self.dev.queue;
        q.write_buffer(b.fluid_params.as_ref().expect("made above"), 0, bytemuck::bytes_of(&params));
        q.write_buffer(b.fluid_materials.as_ref().expect("made above"), 0, bytemuck::cast_slice(&materials));
        let write = |slot: &Option<super::kernels::Slab>, bytes: &[u8]| {
            if !bytes.is_empty() {
                q.write_buffer(&slot.as_ref().expect("made above").buffer, 0, bytes);
            }
        };
        write(&b.domains, bytemuck::cast_slice(&up.domains));
        write(&b.domain_flows, bytemuck::cast_slice(&up.flows));
        write(&b.domain_links, bytemuck::cast_slice(&up.links));
        write(&b.contact_sides, bytemuck::cast_slice(&up.sides));
        write(&b.fluid_loads, bytemuck::cast_slice(&up.loads));
        write(&b.contact_flows, bytemuck::cast_slice(&up.contact_flows));
        write(&b.term_items, bytemuck::cast_slice(&up.term_items));
        if deformable {
            write(&b.block_pieces, bytemuck::cast_slice(&up.block_pieces));
        }
        let base = std::rc::Rc::make_mut(&mut self.uploaded);
        base.fluid_base = [fluid.work, fluid.inflow];
        self.n_domains = up.domains.len();
        self.n_term_items = sizes.term_items;
        Ok(made || !had_kernels || (deformable && !had_wet))
    }

    /// What a read-back reads of the fluid's slots: every domain, each contact's flow and each
    /// block's load (nothing in a dry scene).
    pub(super) fn fluid_parts(&self) -> [(&wgpu::Buffer, u64); 3] {
        let b = self.buffers();
        match (&b.domains, &b.contact_flows, &b.fluid_loads) {
            (Some(d), Some(f), Some(l)) if self.fluid_scene => [
                (&d.buffer, (self.n_domains * std::mem::size_of::<Domain<R>>()) as u64),
                (&f.buffer, (self.counts.2 * std::mem::size_of::<ContactFlow<R>>()) as u64),
                (&l.buffer, (self.counts.0 * std::mem::size_of::<FluidLoad<R>>()) as u64),
            ],
            _ => [(&b.params, 0), (&b.params, 0), (&b.params, 0)],
        }
    }

    /// The fluid's slots as read (`fluid_parts`) into the model: each domain's pressure and area,
    /// each contact's flow, aperture and length (`Domains::flows`), the ledger's fluid work and
    /// the mass balance's inflow (their bases at the upload plus what the device added since,
    /// summed in order in f64).
    pub(super) fn convert_fluid(domains: &[Domain<R>], flows: &[ContactFlow<R>], loads: &[FluidLoad<R>], up: &Uploaded, model: &mut Model) {
        if domains.is_empty() && loads.is_empty() {
            return;
        }
        let Some(list) = model.domains.as_mut() else { return };
        let mut inflow = 0.0;
        for (m, g) in list.list.iter_mut().zip(domains) {
            m.pressure = g.pressure.to_f64();
            m.area = g.area.to_f64();
            inflow += g.inflow.to_f64();
        }
        list.flows.resize(flows.len(), Default::default());
        for (m, g) in list.flows.iter_mut().zip(flows) {
            m.flow = g.flow.to_f64();
            m.aperture = g.aperture.to_f64();
            m.length = g.length.to_f64();
        }
        let work: f64 = loads.iter().map(|l| l.work.to_f64()).sum();
        if let Some(f) = model.fluid.as_mut() {
            f.work = up.fluid_base[0] + work;
            f.inflow = up.fluid_base[1] + inflow;
        }
        zoned_fluid_forces(model);
    }

    /// The kernels of fluid with simply-deformable blocks and their bind groups, in a scene with
    /// both.
    pub(super) fn wet_sdef_kernels(&self) -> Option<(&super::kernels::WetSdefKernels, &super::kernels::WetSdefBindGroups)> {
        let groups = self.bind_groups.as_ref()?.wet_sdef.as_ref()?;
        Some((self.pipelines.wet_sdef.as_ref()?, groups)).filter(|_| self.fluid_scene && self.sdef_scene)
    }

    /// The kernels of fluid with zoned blocks and their bind groups, in a scene with both.
    pub(super) fn wet_fdef_kernels(&self) -> Option<(&super::kernels::WetFdefKernels, &super::kernels::WetFdefBindGroups)> {
        let groups = self.bind_groups.as_ref()?.wet_fdef.as_ref()?;
        Some((self.pipelines.wet_fdef.as_ref()?, groups)).filter(|_| self.fluid_scene && self.fdef_scene)
    }

    /// The fluid's kernels and their bind groups, in a scene with fluid (the cycle, the gather
    /// pass and the energy check run them then).
    pub(super) fn fluid_kernels(&self) -> Option<(&super::kernels::FluidKernels, &super::kernels::FluidBindGroups)> {
        let groups = self.bind_groups.as_ref()?.fluid.as_ref()?;
        Some((self.pipelines.fluid.as_ref()?, groups)).filter(|_| self.fluid_scene)
    }
}

/// The length of boundary (links) or of flow list past which a domain's sums are taken over terms
/// computed in parallel (`domain_terms`, flow.wgsl) rather than walked by one invocation of
/// `domain_pressures`: the wall's voids have 3 or 7 links and joints 2, the void along a row's
/// foot hundreds. The sums are taken in the walk's order from the walk's own terms (the bench
/// wall's run is the same to the byte both ways: tests/suite/fluid.rs); `BLOCKDEM_LONG_WALK` sets it
/// (0: every void and free flow list from terms).
pub const LONG_WALK: u32 = 16;

/// `LONG_WALK`, or `BLOCKDEM_LONG_WALK` where set to a number.
pub fn long_walk() -> u32 {
    std::env::var("BLOCKDEM_LONG_WALK").ok().and_then(|v| v.trim().parse().ok()).unwrap_or(LONG_WALK)
}

/// `TERM_FLOW` of flow.wgsl: an item of `domain_terms` that signs one flow of a domain's list.
pub const TERM_FLOW: u32 = 16;

/// The items of `domain_terms` (flow.wgsl; four words each) for the domains `domains` with their
/// boundary `links` (four words a link), those past `long_walk` only: for a void of rigid blocks
/// (`DOMAIN_REGULAR`) of more links, and with `deformed` for every void of deformable blocks
/// (`DOMAIN_REGULAR_DEFORMED`, `deformed_terms`' items, in f32), one item per link,
/// [its kind, the link, the link
/// before it in its loop (for the loop's first, its last: the closing edge), the reference block
/// (the domain's first link's block, from whose centroid `fluid_area` and `void_step` measure)];
/// for a free domain of more flows, one per flow, [`TERM_FLOW`, its entry in `domain_flows`, 0,
/// 0]. A loop opens at the domain's first link and at each link marked `LINK_LOOP_START`, as
/// the walks of flow.wgsl take it.
pub fn term_items<R: Real>(domains: &[Domain<R>], links: &[u32], long_walk: u32, deformed: bool) -> Vec<u32> {
    let mut items = Vec::new();
    for dom in domains {
        let (start, end) = (dom.link_start, dom.link_start + dom.link_count);
        let long = dom.kind == DOMAIN_REGULAR && dom.link_count > long_walk;
        if long || (deformed && dom.kind == DOMAIN_REGULAR_DEFORMED && dom.link_count > 0) {
            let reference = links[4 * start as usize + 2];
            let mut first = start;
            while first < end {
                // The loop from `first` to the link before the next one that opens a loop.
                let last = (first + 1..end).find(|&l| links[4 * l as usize] & LINK_LOOP_START != 0).unwrap_or(end) - 1;
                for l in first..=last {
                    let before = if l == first { last } else { l - 1 };
                    items.extend([dom.kind, l, before, reference]);
                }
                first = last + 1;
            }
        }
        if dom.free != 0 && dom.flow_count > long_walk {
            items.extend((dom.flow_start..dom.flow_start + dom.flow_count).flat_map(|e| [TERM_FLOW, e, 0, 0]));
        }
    }
    items
}

/// Twin of flow.wgsl's `corner_moves_sdef` and `corner_moves_fdef`: how far each corner of
/// `model` moves in a step of `dt` at the velocities it has now (those of the step just taken: the
/// central-difference velocity at the half step). A rigid or simply-deformable block's corner at
/// r from its centroid by the block's turn Δθ = ωΔt and shift vΔt, r − R(−Δθ)·r + vΔt (exact for
/// its rigid motion), plus for an SDEF block the strain's increment ε̇Δt·r (its corners sit at
/// c + (I + ε)R·x: first order in ε); a zoned block's corner, its boundary grid point, by that
/// grid point's vΔt; a fixed block's not at all.
pub fn corner_moves(model: &Model, dt: f64) -> Vec<[f64; 2]> {
    let mut moves = vec![[0.0; 2]; model.corners.len()];
    for (b, blk) in model.blocks.iter().enumerate() {
        let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
        if blk.fixed {
            continue;
        }
        if super::fdef::is_zoned(model, b) {
            for (m, g) in moves[range].iter_mut().zip(&model.fdef[b].gridpoints) {
                *m = [g.velocity[0] * dt, g.velocity[1] * dt];
            }
            continue;
        }
        let a = blk.angular_velocity * dt;
        let (sin, one_less_cos) = (a.sin(), 1.0 - a.cos());
        let rate = model.sdef_of(b).map(|x| x.strain_rate);
        for (m, c) in moves[range].iter_mut().zip(&model.corners[blk.corner_start as usize..]) {
            let r = [c.position[0] - blk.centroid[0], c.position[1] - blk.centroid[1]];
            let mut d = [blk.velocity[0] * dt + one_less_cos * r[0] - sin * r[1], blk.velocity[1] * dt + sin * r[0] + one_less_cos * r[1]];
            if let Some(e) = rate {
                d[0] += dt * (e[0] * r[0] + e[1] * r[1]);
                d[1] += dt * (e[1] * r[0] + e[2] * r[1]);
            }
            *m = d;
        }
    }
    moves
}

/// A zoned block's external force as the CPU's gather sums it includes its grid points' fluid
/// loads (`cpu::zones::gather_fdef`), which `convert_fdef` (from the device's grid points, before
/// the domains are read) leaves out: added here with the pressures just read, each grid point's
/// share of its block's buoyancy by mass and its boundary's pressure pieces
/// (`model::fluid::deformable_pressure_loads`, the loads the device's grid points carry now).
fn zoned_fluid_forces(model: &mut Model) {
    let (Some(fluid), Some(domains)) = (model.fluid, model.domains.as_ref()) else { return };
    let zoned: Vec<usize> = (0..model.blocks.len()).filter(|&b| super::fdef::is_zoned(model, b)).collect();
    if zoned.is_empty() {
        return;
    }
    let (mut applied, mut points, mut ring) = (Vec::new(), Vec::new(), Vec::new());
    let foot = |k: usize, side: u32| crate::udec::model::fluid::contact_foot(model, &model.contacts[k], side);
    crate::udec::model::fluid::deformable_pressure_loads(model, domains, &foot, &mut applied, &mut points, &mut ring);
    let g = model.gravity;
    for b in zoned {
        let (blk, f) = (&model.blocks[b], &model.fdef[b]);
        let buoyancy = [-fluid.density * blk.area * g[0], -fluid.density * blk.area * g[1]];
        let total = blk.mass.max(f64::MIN_POSITIVE);
        let mut sum = [0.0; 2];
        for (k, gp) in f.gridpoints.iter().enumerate() {
            let share = gp.mass / total;
            let p = if (k as u32) < f.boundary { points.get(blk.corner_start as usize + k).copied().unwrap_or([0.0; 2]) } else { [0.0; 2] };
            sum[0] += buoyancy[0] * share + p[0];
            sum[1] += buoyancy[1] * share + p[1];
        }
        let blk = &mut model.blocks[b];
        blk.force[0] += sum[0];
        blk.force[1] += sum[1];
    }
}

/// Twin of flow.wgsl's `domain_terms` (checked against the walk by the tests below; the device
/// runs the WGSL) for one void's items (`term_items`, four words each) on
/// its boundary `links` (four words a link, indexed from 0 as the items' link words are) and
/// each link's vertices in circuit order (a corner's one twice), with the term of each edge
/// `edge` (`cross2` on positions, `edge_change` on positions and motion): at 2·l the edge from
/// the last vertex of the link before to l's first, at 2·l + 1 a contact's own edge (0 for a
/// corner, which has none).
#[cfg(test)]
pub fn domain_terms<V: Copy, T: Copy + Default>(items: &[u32], links: &[u32], vertices: &[[V; 2]], edge: impl Fn(V, V) -> T) -> Vec<T> {
    let mut terms = vec![T::default(); 2 * vertices.len()];
    for item in items.chunks_exact(4).filter(|i| i[0] != TERM_FLOW) {
        let (l, before) = (item[1] as usize, item[2] as usize);
        let last = if links[4 * before] & LINK_CORNER != 0 { 0 } else { 1 };
        terms[2 * l] = edge(vertices[before][last], vertices[l][0]);
        if links[4 * l] & LINK_CORNER == 0 {
            terms[2 * l + 1] = edge(vertices[l][0], vertices[l][1]);
        }
    }
    terms
}

/// Twin of flow.wgsl's `summed_terms` (tests only, as `domain_terms`): a void of boundary `links` (four words a link) from its
/// `terms` (`domain_terms`), in the order of the walk that measures it: each loop's edges as the
/// walk meets them, its closing edge last, −½ times each loop's sum added loop by loop.
#[cfg(test)]
pub fn summed_terms<T>(links: &[u32], terms: &[T]) -> T
where
    T: Copy + Default + std::ops::Add<Output = T> + std::ops::Mul<Output = T> + std::ops::Neg<Output = T> + From<f32>,
{
    let (mut total, mut s, mut close, mut open) = (T::default(), T::default(), T::default(), false);
    for l in 0..links.len() / 4 {
        let bits = links[4 * l];
        if bits & LINK_LOOP_START != 0 && open {
            total = total + -(T::from(0.5) * (s + close));
            s = T::default();
            open = false;
        }
        if open {
            s = s + terms[2 * l];
        } else {
            close = terms[2 * l];
            open = true;
        }
        if bits & LINK_CORNER == 0 {
            s = s + terms[2 * l + 1];
        }
    }
    if open {
        total = total + -(T::from(0.5) * (s + close));
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A regular domain's words for `term_items`: kind, flows and links.
    fn domain(kind: u32, free: u32, flows: (u32, u32), links: (u32, u32)) -> Domain<f32> {
        Domain { kind, free, flow_start: flows.0, flow_count: flows.1, link_start: links.0, link_count: links.1, ..Default::default() }
    }

    /// Links of one domain: (corner?, opens a loop?) each, block 10 + the link's index.
    fn links_of(shape: &[(bool, bool)]) -> Vec<u32> {
        let mut words = Vec::new();
        for (i, &(corner, start)) in shape.iter().enumerate() {
            let bits = if corner { LINK_CORNER } else { 0 } | if start { LINK_LOOP_START } else { 0 };
            words.extend([bits, i as u32, 10 + i as u32, 20 + i as u32]);
        }
        words
    }

    #[test]
    fn long_domains_get_an_item_per_link_with_the_link_before_it_in_its_loop_and_per_flow_if_free() {
        // Domain 0: a void of two loops (links 0–2 and 3–4); domain 1 a joint of 2 links; domain
        // 2 a short void of 2 links; domain 3 the outer (fixed) with 3 flows.
        let shape = [(true, true), (false, false), (true, false), (false, true), (true, false), (false, true), (false, false), (true, true), (true, false)];
        let links = links_of(&shape);
        let domains = [
            domain(DOMAIN_REGULAR, 1, (0, 3), (0, 5)),
            domain(DOMAIN_JOINT, 1, (3, 2), (5, 2)),
            domain(DOMAIN_REGULAR_DEFORMED, 1, (5, 1), (7, 2)),
            domain(DOMAIN_OUTER, 0, (6, 3), (0, 0)),
        ];
        let items = term_items(&domains, &links, 2, false);
        #[rustfmt::skip]
        assert_eq!(items, [
            DOMAIN_REGULAR, 0, 2, 10, DOMAIN_REGULAR, 1, 0, 10, DOMAIN_REGULAR, 2, 1, 10,
            DOMAIN_REGULAR, 3, 4, 10, DOMAIN_REGULAR, 4, 3, 10,
            TERM_FLOW, 0, 0, 0, TERM_FLOW, 1, 0, 0, TERM_FLOW, 2, 0, 0,
        ]);
        // At 1, the joint's links and the deformed void's are still walked (the joint's mean
        // aperture; the deformed outline, see flow.wgsl), and the fixed outer domain gathers no
        // flows.
        let items = term_items(&domains, &links, 1, false);
        assert!(items.chunks(4).all(|i| i[0] == TERM_FLOW || i[0] == DOMAIN_REGULAR), "{items:?}");
        assert_eq!(items.chunks(4).filter(|i| i[0] == TERM_FLOW).count(), 5, "{items:?}");
        assert!(items.chunks(4).all(|i| i[0] == TERM_FLOW || i[1] < 5 || i[1] >= 7), "{items:?}");
        assert!(term_items(&domains, &links, LONG_WALK, false).is_empty());
    }

    /// `fluid_area`'s walk (flow.wgsl) on the same vertices: each vertex after a loop's first adds
    /// the edge from the one before, the loop closes back to its first.
    fn walked(links: &[u32], vertices: &[[[f32; 2]; 2]]) -> f32 {
        let cross = |p: [f32; 2], q: [f32; 2]| p[0] * q[1] - q[0] * p[1];
        let (mut total, mut s, mut start, mut prev, mut open) = (0.0f32, 0.0f32, [0.0; 2], [0.0; 2], false);
        for (l, v) in vertices.iter().enumerate() {
            if links[4 * l] & LINK_LOOP_START != 0 && open {
                s += cross(prev, start);
                total += -(0.5 * s);
                s = 0.0;
                open = false;
            }
            let count = if links[4 * l] & LINK_CORNER != 0 { 1 } else { 2 };
            for &x in &v[..count] {
                if open {
                    s += cross(prev, x);
                } else {
                    start = x;
                    open = true;
                }
                prev = x;
            }
        }
        if open {
            s += cross(prev, start);
            total += -(0.5 * s);
        }
        total
    }

    #[test]
    fn a_void_summed_from_its_terms_is_its_walk_to_the_bit() {
        // Pseudo-random loops of corners and contacts around a few centres, f32 positions of a
        // few metres (the kernels' precision, where the order of the sum shows).
        let mut seed = 0x9e37_79b9_u32;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        for case in 0..200 {
            let n = 1 + (next() * 40.0) as usize;
            let shape: Vec<(bool, bool)> = (0..n).map(|i| (next() < 0.4, i == 0 || next() < 0.1)).collect();
            let links = links_of(&shape);
            // A corner's one vertex twice, as `moving_vertices` gives it.
            let vertices: Vec<[[f32; 2]; 2]> = shape
                .iter()
                .map(|&(corner, _)| {
                    let a = [3.0 + next() * 2.0, -1.0 + next()];
                    if corner {
                        [a, a]
                    } else {
                        [a, [3.0 + next() * 2.0, -1.0 + next()]]
                    }
                })
                .collect();
            let domains = [domain(DOMAIN_REGULAR, 1, (0, 0), (0, n as u32))];
            let items = term_items(&domains, &links, 0, false);
            assert_eq!(items.len(), 4 * n);
            let terms = domain_terms(&items, &links, &vertices, |p: [f32; 2], q: [f32; 2]| p[0] * q[1] - q[0] * p[1]);
            let (a, b) = (summed_terms(&links, &terms), walked(&links, &vertices));
            assert_eq!(a.to_bits(), b.to_bits(), "case {case}: {a} vs {b}");
        }
    }
}
