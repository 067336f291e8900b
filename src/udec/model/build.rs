//! Creating, removing and re-rounding blocks (BLOCK, DELETE, ROUND; SL-85-1 Appendix A "Input
//! Commands"), the per-cycle corner update, and the model's consistency check.
//!
//! Every function here keeps the storage invariant of [`Model`]: blocks own contiguous,
//! non-overlapping corner ranges, stored counter-clockwise in the body frame, and every index held by
//! a corner, contact or link points at a live entry.

use super::geometry::{self, corner_rounding, polygon_properties};
use super::{Block, BlockKind, Corner, Model, Tolerances};

/// Why a block outline was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error("a block needs at least 3 corners, {count} given")]
    TooFewCorners { count: usize },
    /// `index` counts from 0; the message counts as the deck does, from 1.
    #[error("corner {} of the block outline is not a finite number", .index + 1)]
    NonFinite { index: usize },
    /// `index` and `next` count from 0; the message counts as the deck does, from 1.
    #[error("corners {} and {} of the block outline are at the same place (zero-length edge)", .index + 1, .next + 1)]
    RepeatedCorner { index: usize, next: usize },
    #[error("the block outline crosses or touches itself; give the corners in order around the block")]
    SelfIntersecting,
    #[error("the block outline is too large to compute with (it spans {extent:e}; its area overflows f64); check the units of the coordinates")]
    TooLarge { extent: f64 },
    #[error("the block outline encloses no area (area {area:e}); are its corners collinear?")]
    Degenerate { area: f64 },
    #[error("{given} edge tags given for a block of {corners} corners")]
    EdgeTagCount { given: usize, corners: usize },
}

/// Everything a new block takes over besides its outline: from the BLOCK command, or from the parent
/// of a split.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BlockSeed {
    pub id: u32,
    pub kind: BlockKind,
    pub material: u32,
    pub constitutive: u32,
    pub fixed: bool,
    pub velocity: [f64; 2],
    pub angular_velocity: f64,
    pub load: [f64; 2],
    pub moved_since_update: f64,
    /// The area of the block the deck built that a crack's piece comes from (`Block::built_area`);
    /// None for a block the deck builds (BLOCK, SPLIT), whose own area it is.
    pub built_area: Option<f64>,
}

impl Model {
    /// Creates a rigid block from its outline in world coordinates, in either orientation (the deck
    /// gives it clockwise); it is stored counter-clockwise. `edge_tags[i]` = (joint material,
    /// constitutive) of the edge from corner i to corner i + 1 of the GIVEN order (None: all 0, i.e.
    /// "take the block's"). Mass and inertia use the material's current density (0 until PROPERTY
    /// sets it; see [`Model::recompute_mass_properties`]). Returns the new block's index, which is
    /// the last one.
    pub fn add_block(&mut self, outline: &[[f64; 2]], material: u32, constitutive: u32, edge_tags: Option<&[(u32, u32)]>) -> Result<usize, GeometryError> {
        let n = outline.len();
        if n < 3 {
            return Err(GeometryError::TooFewCorners { count: n });
        }
        if let Some(index) = outline.iter().position(|p| !p[0].is_finite() || !p[1].is_finite()) {
            return Err(GeometryError::NonFinite { index });
        }
        if let Some(index) = (0..n).find(|&i| outline[i] == outline[(i + 1) % n]) {
            return Err(GeometryError::RepeatedCorner { index, next: (index + 1) % n });
        }
        if let Some(tags) = edge_tags {
            if tags.len() != n {
                return Err(GeometryError::EdgeTagCount { given: tags.len(), corners: n });
            }
        }
        if !geometry::is_simple_polygon(outline) {
            return Err(GeometryError::SelfIntersecting);
        }
        let props = polygon_properties(outline);
        // Zero area within round-off: relative to the square of the outline's extent.
        let extent = bbox_extent(outline);
        if !props.area.is_finite() || !(extent * extent).is_finite() {
            return Err(GeometryError::TooLarge { extent });
        }
        if props.area.abs() <= 1e-12 * extent * extent {
            return Err(GeometryError::Degenerate { area: props.area });
        }

        let mut pts = outline.to_vec();
        let mut tags = edge_tags.map_or_else(|| vec![(0, 0); n], <[_]>::to_vec);
        if props.area < 0.0 {
            reverse_outline(&mut pts, &mut tags);
        }
        let id = self.next_block_id;
        self.next_block_id += 1;
        let seed = BlockSeed {
            id,
            kind: BlockKind::Rigid,
            material,
            constitutive,
            fixed: false,
            velocity: [0.0, 0.0],
            angular_velocity: 0.0,
            load: [0.0, 0.0],
            moved_since_update: 0.0,
            built_area: None,
        };
        Ok(self.push_block(&pts, &tags, seed))
    }

    /// Appends a block from a counter-clockwise, simple world outline and its edge tags (tag i for
    /// the edge from corner i to corner i + 1). Body frame: centroid origin, rotation 0.
    pub(crate) fn push_block(&mut self, pts_ccw: &[[f64; 2]], tags: &[(u32, u32)], seed: BlockSeed) -> usize {
        debug_assert_eq!(pts_ccw.len(), tags.len());
        let props = polygon_properties(pts_ccw);
        let c = props.centroid;
        let local: Vec<[f64; 2]> = pts_ccw.iter().map(|p| geometry::sub(*p, c)).collect();
        let rounds = corner_rounding(&local, self.tol.round);
        let density = self.material(seed.material).block.density;
        let b = self.blocks.len();
        let corner_start = self.corners.len() as u32;
        self.corners.extend(local.iter().zip(&rounds).zip(tags).map(|((l, r), t)| Corner {
            block: b as u32,
            local: *l,
            circle_local: r.circle,
            radius: r.radius,
            round: r.round,
            position: geometry::add(c, *l),
            circle: geometry::add(c, r.circle),
            edge_dir: [0.0, 0.0],
            edge_length: 0.0,
            edge_material: t.0,
            edge_constitutive: t.1,
        }));
        self.blocks.push(Block {
            id: seed.id,
            kind: seed.kind,
            material: seed.material,
            constitutive: seed.constitutive,
            fixed: seed.fixed,
            corner_start,
            corner_count: pts_ccw.len() as u32,
            area: props.area,
            mass: density * props.area,
            inertia: density * props.polar_moment,
            centroid: c,
            rotation: 0.0,
            velocity: seed.velocity,
            angular_velocity: seed.angular_velocity,
            force: [0.0, 0.0],
            moment: 0.0,
            load: seed.load,
            radius: local.iter().map(|l| geometry::norm(*l)).fold(0.0, f64::max),
            moved_since_update: seed.moved_since_update,
            update_centroid: c,
            update_rotation: 0.0,
            update_margin: 0.0,
            damping_work: 0.0,
            built_area: seed.built_area.unwrap_or(props.area),
        });
        // The extension array follows the blocks once one is simply deformable (a new piece of
        // an SDEF block starts unstrained, ¶17: "the block stresses are set to zero").
        if seed.kind == BlockKind::SimplyDeformable || !self.sdef.is_empty() {
            self.sdef.resize(self.blocks.len(), super::sdef::Sdef::default());
            self.refresh_sdef_moments(b);
        }
        if !self.fdef.is_empty() {
            self.fdef.resize(self.blocks.len(), super::fdef::Fdef::default());
        }
        self.update_corner_positions(b);
        b
    }

    /// Gives block `b` the outline `pts_ccw` (world, counter-clockwise), the same polygon as its
    /// present one with corners added along its edges (GENERATE's boundary grid points): its
    /// corners are made anew, rounded, each new one on an edge taking that edge's tags; its
    /// contacts are dropped (the next CYCLE's detection finds them again at the new corners) and
    /// the corner indices of the other blocks and contacts shifted. The body frame is the world's
    /// (rotation 0).
    pub fn replace_outline(&mut self, b: usize, pts_ccw: &[[f64; 2]]) {
        let old: Vec<Corner> = self.block_corners(b).to_vec();
        let old_positions: Vec<[f64; 2]> = old.iter().map(|c| c.position).collect();
        let (start, n_old) = (self.blocks[b].corner_start as usize, self.blocks[b].corner_count as usize);
        let props = polygon_properties(pts_ccw);
        let c = props.centroid;
        let local: Vec<[f64; 2]> = pts_ccw.iter().map(|p| geometry::sub(*p, c)).collect();
        let rounds = corner_rounding(&local, self.tol.round);
        // Each new corner takes the tags of the old edge it lies on (from the last old corner).
        let mut tag = (old[0].edge_material, old[0].edge_constitutive);
        let mut fresh = Vec::with_capacity(pts_ccw.len());
        for ((p, l), r) in pts_ccw.iter().zip(&local).zip(&rounds) {
            if let Some(k) = old_positions.iter().position(|q| geometry::distance(*q, *p) <= 1e-12 * (1.0 + geometry::norm(*q))) {
                tag = (old[k].edge_material, old[k].edge_constitutive);
            }
            fresh.push(Corner {
                block: b as u32,
                local: *l,
                circle_local: r.circle,
                radius: r.radius,
                round: r.round,
                position: *p,
                circle: geometry::add(c, r.circle),
                edge_dir: [0.0, 0.0],
                edge_length: 0.0,
                edge_material: tag.0,
                edge_constitutive: tag.1,
            });
        }
        let n_new = fresh.len();
        self.corners.splice(start..start + n_old, fresh);
        let shift = |k: u32| if k as usize >= start + n_old { (k as usize + n_new - n_old) as u32 } else { k };
        for blk in &mut self.blocks[b + 1..] {
            blk.corner_start = shift(blk.corner_start);
        }
        self.contacts.retain(|k| k.block1 as usize != b && k.block2 as usize != b);
        for k in &mut self.contacts {
            k.corner = shift(k.corner);
        }
        let density = self.material(self.blocks[b].material).block.density;
        let blk = &mut self.blocks[b];
        blk.corner_count = n_new as u32;
        blk.centroid = c;
        blk.rotation = 0.0;
        blk.area = props.area;
        blk.mass = density * props.area;
        blk.inertia = density * props.polar_moment;
        blk.radius = local.iter().map(|l| geometry::norm(*l)).fold(0.0, f64::max);
        blk.update_centroid = c;
        blk.update_rotation = 0.0;
        blk.moved_since_update = f64::INFINITY;
        self.update_corner_positions(b);
    }

    /// Mass = density · area and inertia = density · polar moment of every block, from the current
    /// materials (the executor calls this before cycling, after PROPERTY or CHANGE).
    pub fn recompute_mass_properties(&mut self) {
        for b in 0..self.blocks.len() {
            let local: Vec<[f64; 2]> = self.block_corners(b).iter().map(|c| c.local).collect();
            let props = polygon_properties(&local);
            let density = self.material(self.blocks[b].material).block.density;
            let blk = &mut self.blocks[b];
            blk.area = props.area;
            blk.mass = density * props.area;
            blk.inertia = density * props.polar_moment;
            self.refresh_sdef_moments(b);
            if self.blocks[b].kind == BlockKind::FullyDeformable {
                if let Some(f) = self.fdef.get_mut(b) {
                    f.set_density(density);
                }
            }
        }
    }

    /// Removes the blocks at `indices` (any order, duplicates allowed), their corners, and every
    /// contact and link that involves one of them. The remaining blocks and corners keep their
    /// relative order and are compacted, so indices above a removed one shift down; every index
    /// stored in corners, contacts and links is remapped. Ids never change.
    pub fn remove_blocks(&mut self, indices: &[usize]) {
        if indices.is_empty() {
            return;
        }
        let nb = self.blocks.len();
        let mut removed = vec![false; nb];
        for &i in indices {
            if i < nb {
                removed[i] = true;
            }
        }
        // Old block index → new one (u32::MAX for removed blocks).
        let mut block_map = vec![u32::MAX; nb];
        let mut next = 0u32;
        for (i, gone) in removed.iter().enumerate() {
            if !gone {
                block_map[i] = next;
                next += 1;
            }
        }
        // Old corner index → new one, compacting corners in their current order.
        let mut corner_map = vec![u32::MAX; self.corners.len()];
        let mut kept_corners = Vec::with_capacity(self.corners.len());
        for (ci, corner) in self.corners.iter().enumerate() {
            let nbk = block_map[corner.block as usize];
            if nbk != u32::MAX {
                corner_map[ci] = kept_corners.len() as u32;
                kept_corners.push(Corner { block: nbk, ..*corner });
            }
        }
        if !self.sdef.is_empty() {
            let sdef = std::mem::take(&mut self.sdef);
            self.sdef = sdef.into_iter().zip(&removed).filter(|&(_, &gone)| !gone).map(|(s, _)| s).collect();
        }
        if !self.fdef.is_empty() {
            let mut k = 0;
            self.fdef.retain(|_| {
                k += 1;
                !removed.get(k - 1).copied().unwrap_or(true)
            });
        }
        let mut new_blocks = Vec::with_capacity(next as usize);
        for (i, blk) in self.blocks.drain(..).enumerate() {
            if !removed[i] {
                let corner_start = corner_map[blk.corner_start as usize];
                new_blocks.push(Block { corner_start, ..blk });
            }
        }
        self.blocks = new_blocks;
        self.corners = kept_corners;
        self.contacts.retain_mut(|c| {
            let (b1, b2) = (block_map[c.block1 as usize], block_map[c.block2 as usize]);
            if b1 == u32::MAX || b2 == u32::MAX {
                return false;
            }
            c.block1 = b1;
            c.block2 = b2;
            c.corner = corner_map[c.corner as usize];
            true
        });
        self.links.retain_mut(|l| {
            let (f, a) = (block_map[l.flying as usize], block_map[l.anchor as usize]);
            if f == u32::MAX || a == u32::MAX {
                return false;
            }
            l.flying = f;
            l.anchor = a;
            true
        });
    }

    /// World position of block b's corners and rounding-circle centres:
    /// x = centroid + R(rotation) · local (stage 2 of the cycle, DESIGN.md §1).
    #[inline]
    pub fn update_corner_positions(&mut self, b: usize) {
        let blk = &self.blocks[b];
        let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
        if self.fdef_of(b).is_some_and(|f| !f.zones.is_empty()) {
            let (blk, f) = (&mut self.blocks[b], &self.fdef[b]);
            super::corners::place_corners_fdef(blk, f, &mut self.corners[range]);
            return;
        }
        match self.sdef_of(b) {
            Some(s) => super::corners::place_corners_strained(blk, s.strain, &mut self.corners[range]),
            None => super::corners::place_corners(blk, &mut self.corners[range]),
        }
    }

    /// The current world outline of block b, counter-clockwise, computed from centroid and rotation
    /// (and the strain of a simply-deformable block; not from the cached `Corner::position`).
    pub fn world_outline(&self, b: usize) -> Vec<[f64; 2]> {
        let blk = &self.blocks[b];
        if self.fdef_of(b).is_some_and(|f| !f.zones.is_empty()) {
            return self.block_corners(b).iter().map(|k| k.position).collect();
        }
        let strain = self.sdef_of(b).map_or([0.0; 3], |s| s.strain);
        self.block_corners(b).iter().map(|k| geometry::add(blk.centroid, super::corners::strained(strain, geometry::rotate(k.local, blk.rotation)))).collect()
    }

    /// ROUND d: sets the rounding length and the tolerances derived from it, and re-rounds every
    /// corner of every block in its body frame.
    pub fn set_round(&mut self, d: f64) {
        self.tol = Tolerances::from_round(d);
        for b in 0..self.blocks.len() {
            let blk = &self.blocks[b];
            let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
            let local: Vec<[f64; 2]> = self.corners[range.clone()].iter().map(|c| c.local).collect();
            for (k, r) in self.corners[range].iter_mut().zip(corner_rounding(&local, d)) {
                k.circle_local = r.circle;
                k.radius = r.radius;
                k.round = r.round;
            }
            self.update_corner_positions(b);
        }
    }

    /// Consistency check of the whole model (STYLE.md item 6), and what RESTART asks of a save
    /// file before it takes the model in (a file whose checksum is right may still have been
    /// written wrong or edited): the settings finite and in the ranges their commands allow, all
    /// [`MAX_MATERIALS`](super::MAX_MATERIALS) materials there; each block's corner range the one
    /// after the previous block's (the CPU block pass and the GPU upload slice the corners so),
    /// with at least 3 corners, the whole list covered; corners pointing back at their block;
    /// body-frame outlines counter-clockwise with the stored area; finite state; unique block ids
    /// below `next_block_id`; contact and link indices in range, between distinct blocks, with
    /// the contact corner owned by block 1 and the feature on block 2. Returns the first problem
    /// found, in words that name the entry by its index in its list.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        self.validate_settings()?;
        let (nb, nk) = (self.blocks.len(), self.corners.len());
        if !self.sdef.is_empty() && self.sdef.len() != nb {
            return Err(format!("{} simply-deformable extensions for {nb} blocks", self.sdef.len()));
        }
        if let Some(k) = self.sdef.iter().position(|s| !(s.strain.iter().chain(&s.strain_rate).chain(&s.stress).all(|x| x.is_finite()))) {
            return Err(format!("block {k}'s strain, strain rate or stress is not finite"));
        }
        if !self.fdef.is_empty() && self.fdef.len() != nb {
            return Err(format!("{} fully-deformable extensions for {nb} blocks", self.fdef.len()));
        }
        for (k, f) in self.fdef.iter().enumerate() {
            if f.zones.is_empty() {
                continue;
            }
            let ng = f.gridpoints.len();
            if f.boundary != self.blocks[k].corner_count || f.boundary as usize > ng {
                return Err(format!("block {k}: {} boundary grid points for {} corners", f.boundary, self.blocks[k].corner_count));
            }
            if f.zones.iter().any(|z| z.gridpoints.iter().any(|&g| g as usize >= ng)) {
                return Err(format!("block {k}: a zone names a grid point beyond its {ng}"));
            }
            if !f.gridpoints.iter().all(|g| finite(&g.position) && finite(&g.velocity) && finite(&g.force) && g.mass.is_finite())
                || !f.zones.iter().all(|z| finite(&z.stress) && z.mass.is_finite())
            {
                return Err(format!("block {k}: a zone or grid point has a non-finite value"));
            }
        }
        if self.sdef.is_empty() {
            if let Some(b) = self.blocks.iter().find(|b| b.kind == super::BlockKind::SimplyDeformable) {
                return Err(format!("block {} is simply deformable but has no extension", b.id));
            }
        }
        // Corner indices are u32 everywhere (blocks, contacts, the GPU buffers).
        if nk > u32::MAX as usize {
            return Err(format!("{nk} corners, more than a u32 indexes"));
        }
        let mut ids = std::collections::HashSet::with_capacity(nb);
        let mut local: Vec<[f64; 2]> = Vec::new();
        let mut next_corner = 0usize;
        for (b, blk) in self.blocks.iter().enumerate() {
            if !(blk.built_area.is_finite() && blk.built_area > 0.0) {
                return Err(format!("block {b} (id {}) has an area as built of {}", blk.id, blk.built_area));
            }
            let (s, n) = (blk.corner_start as usize, blk.corner_count as usize);
            if n < 3 {
                return Err(format!("block {b} (id {}) has {n} corners", blk.id));
            }
            if s != next_corner || s + n > nk {
                return Err(format!(
                    "block {b} (id {}) has corners {s}..{} of {nk}; its corners must follow the previous block's, from corner {next_corner}",
                    blk.id,
                    s + n
                ));
            }
            next_corner = s + n;
            if !ids.insert(blk.id) || blk.id >= self.next_block_id {
                return Err(format!("block {b}: id {} repeated or not below the next block id {}", blk.id, self.next_block_id));
            }
            let scalars = [blk.area, blk.mass, blk.inertia, blk.rotation, blk.angular_velocity, blk.moment, blk.radius, blk.update_rotation];
            let pairs = [blk.centroid, blk.velocity, blk.force, blk.load, blk.update_centroid];
            if !finite(&scalars) || !pairs.iter().all(|p| finite(p)) {
                return Err(format!("block {b} (id {}) has a non-finite value", blk.id));
            }
            // NaN fails these too. The distance moved may be infinite: cracking sets it so to ask
            // for the pieces' contact update.
            if !(blk.update_margin >= 0.0 && blk.update_margin.is_finite() && blk.moved_since_update >= 0.0 && blk.radius >= 0.0) {
                return Err(format!(
                    "block {b} (id {}): radius {}, update margin {} and distance moved {} must be finite and not negative",
                    blk.id, blk.radius, blk.update_margin, blk.moved_since_update
                ));
            }
            if blk.area <= 0.0 || blk.mass < 0.0 || blk.inertia < 0.0 {
                return Err(format!("block {b} (id {}): area {} mass {} inertia {}", blk.id, blk.area, blk.mass, blk.inertia));
            }
            let corners = &self.corners[s..s + n];
            for (k, c) in corners.iter().enumerate() {
                if c.block as usize != b {
                    return Err(format!("corner {} belongs to block {b} but says block {}", s + k, c.block));
                }
                let vals = [c.local, c.circle_local, c.position, c.circle, c.edge_dir];
                let lengths = [c.radius, c.round, c.edge_length];
                if !vals.iter().all(|p| finite(p)) || !finite(&lengths) || lengths.iter().any(|&x| x < 0.0) {
                    return Err(format!("corner {} of block {b} has a bad value", s + k));
                }
            }
            local.clear();
            local.extend(corners.iter().map(|c| c.local));
            let area = geometry::signed_area(&local);
            if (area - blk.area).abs() > 1e-9 * blk.area.max(blk.radius * blk.radius) {
                return Err(format!("block {b} (id {}): outline area {area} (clockwise if negative) ≠ stored {}", blk.id, blk.area));
            }
        }
        if next_corner != nk {
            return Err(format!("corners {next_corner}..{nk} belong to no block"));
        }
        for (i, c) in self.contacts.iter().enumerate() {
            let (b1, b2) = (c.block1 as usize, c.block2 as usize);
            if b1 >= nb || b2 >= nb || b1 == b2 {
                return Err(format!("contact {i} (id {}) joins blocks {b1} and {b2} of {nb}", c.id));
            }
            let blk1 = &self.blocks[b1];
            let corner = c.corner as usize;
            if corner >= nk {
                return Err(format!("contact {i} (id {}) names corner {corner} of {nk}", c.id));
            }
            if corner < blk1.corner_start as usize || corner >= blk1.corner_start as usize + blk1.corner_count as usize {
                return Err(format!("contact {i} (id {}): corner {corner} is not a corner of block {b1}", c.id));
            }
            if c.feature >= 2 * self.blocks[b2].corner_count {
                return Err(format!("contact {i} (id {}): feature {} beyond block {b2}", c.id, c.feature));
            }
            let vals = [c.gap, c.normal_force, c.shear_force, c.shear_displacement];
            if !finite(&vals) || !finite(&c.point) || !finite(&c.normal) || !finite(&c.force) || !finite(&c.dashpot_velocity) {
                return Err(format!("contact {i} (id {}) has a non-finite value", c.id));
            }
        }
        for (i, l) in self.links.iter().enumerate() {
            if l.flying as usize >= nb || l.anchor as usize >= nb || l.flying == l.anchor {
                return Err(format!("link {i} joins blocks {} and {} of {nb}", l.flying, l.anchor));
            }
        }
        self.validate_fluid()
    }

    /// The fluid's part of [`Model::validate`] (save format 6 keeps the fluid and the domains):
    /// FLUID's density not negative and bulk modulus positive, the accounts finite; the domains
    /// in id order below `next_id`, their boundaries within the links, the links naming contacts
    /// and corners that exist, each contact's two sides domains that exist, the pressures and
    /// areas finite.
    fn validate_fluid(&self) -> Result<(), String> {
        use super::domain::{DomainLink, NO_DOMAIN};
        if let Some(f) = &self.fluid {
            if !(f.density >= 0.0 && f.density.is_finite() && f.bulk > 0.0 && f.bulk.is_finite()) {
                return Err(format!("the fluid's density {} or bulk modulus {} is out of range (FLUID asks for rhow >= 0, bulkw > 0)", f.density, f.bulk));
            }
            if ![f.work, f.inflow, f.adjusted, f.stored_at_start].iter().all(|x| x.is_finite()) {
                return Err("the fluid's accounts (work, inflow, adjusted, stored) are not finite".to_string());
            }
        }
        let Some(d) = &self.domains else { return Ok(()) };
        let (nd, nk, nc) = (d.list.len(), self.corners.len(), self.contacts.len());
        if d.link_sides.len() != d.links.len() {
            return Err(format!("the domains have {} links but {} link sides", d.links.len(), d.link_sides.len()));
        }
        // The numbers are checked where the cycle reads them, with fluid: in a dry scene they are
        // derived data (PRINT DOMAINS), which a model of extreme scale may hold as infinities.
        let fluid = self.fluid.is_some();
        if fluid && (!(d.min_area.is_finite() && d.min_area >= 0.0) || d.given_min_area.is_some_and(|a| !(a.is_finite() && a > 0.0))) {
            return Err(format!("the domains' minimum area {} (given {:?}) is out of range", d.min_area, d.given_min_area));
        }
        let mut last_id = None;
        for (k, dom) in d.list.iter().enumerate() {
            if last_id.is_some_and(|id| dom.id <= id) || dom.id >= d.next_id {
                return Err(format!("domain {k} has id {}: the ids must rise and stay below the next id {}", dom.id, d.next_id));
            }
            last_id = Some(dom.id);
            let (s, n) = (dom.link_start as usize, dom.link_count as usize);
            if s + n > d.links.len() {
                return Err(format!("domain {k} (id {}) has links {s}..{} of {}", dom.id, s + n, d.links.len()));
            }
            // The distance moved may be infinite, as its blocks' may (cracking asks so for an
            // update).
            if fluid && (![dom.area, dom.length, dom.pressure].iter().all(|x| x.is_finite()) || dom.max_displacement.is_nan() || dom.max_displacement < 0.0) {
                return Err(format!("domain {k} (id {}) has a non-finite value", dom.id));
            }
        }
        for (i, l) in d.links.iter().enumerate() {
            match *l {
                DomainLink::Contact { index, .. } if index as usize >= nc => return Err(format!("domain link {i} names contact {index} of {nc}")),
                DomainLink::Corner { corner } if corner as usize >= nk => return Err(format!("domain link {i} names corner {corner} of {nk}")),
                _ => {}
            }
        }
        if let Some((k, s)) = d.sides.iter().enumerate().find(|(_, s)| s.iter().any(|&x| x != NO_DOMAIN && x as usize >= nd)) {
            return Err(format!("contact {k}'s domains {s:?} are not among the {nd} domains"));
        }
        if fluid && d.flows.iter().any(|f| !(f.flow.is_finite() && f.aperture.is_finite() && f.length.is_finite())) {
            return Err("a contact's flow is not finite".to_string());
        }
        Ok(())
    }

    /// The settings' part of [`Model::validate`]: each within what its command accepts (FRACTION
    /// positive, the tolerances not negative, the others finite), so that a CYCLE never starts
    /// from a fraction or a tolerance no deck could give. The material numbers that blocks,
    /// edges and contacts hold are not checked: [`Model::material`] maps any number to a slot.
    fn validate_settings(&self) -> Result<(), String> {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if self.materials.len() != super::MAX_MATERIALS {
            return Err(format!("{} materials, not {}", self.materials.len(), super::MAX_MATERIALS));
        }
        for (m, mat) in self.materials.iter().enumerate() {
            let values = [
                mat.block.density,
                mat.block.bulk,
                mat.block.shear,
                mat.contact.kn,
                mat.contact.ks,
                mat.contact.cohesion,
                mat.contact.friction,
                mat.joint.kn,
                mat.joint.ks,
                mat.joint.cohesion,
                mat.joint.friction,
                mat.block.tf,
                mat.fluid.jperm,
                mat.fluid.cperm,
                mat.fluid.azero,
                mat.fluid.ares,
            ];
            if !finite(&values) {
                return Err(format!("material {} has a non-finite property", m + 1));
            }
        }
        // ROUND asks for a positive length, but a model built through the library may have sharp
        // corners (rounding 0, and so tolerances 0).
        let Tolerances { round, atol, btol, etol, margin_steps } = self.tol;
        if !finite(&[round, atol, btol, etol, margin_steps]) || [round, atol, btol, etol, margin_steps].iter().any(|&x| x < 0.0) {
            return Err(format!(
                "the contact tolerances (rounding {round}, atol {atol}, btol {btol}, etol {etol}, margin steps {margin_steps}) must be finite and not negative"
            ));
        }
        if !(self.frac > 0.0 && self.frac.is_finite()) {
            return Err(format!("the time-step fraction {} is not a positive number", self.frac));
        }
        if !(self.timestep >= 0.0 && self.timestep.is_finite() && self.time.is_finite()) {
            return Err(format!("the time step {} or the time {} is not a finite number (the step not negative)", self.timestep, self.time));
        }
        let d = &self.damping;
        if !finite(&self.gravity) || !finite(&[d.alpha, d.beta, d.alpha_internal, self.external_work]) {
            return Err("the gravity, the damping or the work done is not a finite number".to_string());
        }
        Ok(())
    }
}

/// Largest side of the outline's bounding box.
pub(crate) fn bbox_extent(pts: &[[f64; 2]]) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (hi[0] - lo[0]).max(hi[1] - lo[1])
}

/// Reverses an outline's orientation, keeping each edge's tag on the same edge: with q_k = p_{n−1−k},
/// the edge q_k → q_{k+1} is the given edge p_{n−2−k} → p_{n−1−k}, i.e. tag index n−2−k (mod n).
pub(crate) fn reverse_outline(pts: &mut [[f64; 2]], tags: &mut Vec<(u32, u32)>) {
    let n = pts.len();
    pts.reverse();
    *tags = (0..n).map(|k| tags[(2 * n - 2 - k) % n]).collect();
}
