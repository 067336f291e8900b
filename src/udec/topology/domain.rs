//! Domains built from the block and contact lists (SL-85-1 Appendix A ¶6–9, report ¶28).
//!
//! In two dimensions the voids share the circulating lists that trace the blocks, traced the
//! other way (¶28). Here the lists are each block's contacts in order around it, counter-
//! clockwise (as PRINT LIST shows them). Every contact meets two blocks; on each of them it is a
//! *dart*, a place on that block's boundary. From a dart, walk counter-clockwise along the block
//! (the block on the left, the void on the right) to the block's next dart; cross that contact
//! to the other block and walk on from the same contact there. The walk comes back to where it
//! started, having traced one void: a domain. Every dart starts exactly one piece of boundary
//! (the one to the next dart on its block), so every piece bounds exactly one domain: the
//! circuits are the orbits of a permutation and the tracing always ends, whatever the geometry.
//!
//! An enclosed void is traced clockwise (negative signed area); each connected group of blocks
//! has one circuit around its outside, traced counter-clockwise, the one of largest signed area.
//! A group that floats inside a void of another (a block in a cavity) is an island of that void,
//! whose area it reduces; the outsides of all the other groups, and of blocks with no contact,
//! are the one outer domain. A circuit of two contacts between the same two blocks that passes no
//! corner on either is the void of an edge-to-edge contact, a joint domain (¶7).
//!
//! Contacts within the contact-forming distance are links whether they touch or not, as in UDEC:
//! a domain is bounded by contacts, open ones included. Of the two views of a touch of two
//! corners only the one that carries the force counts (`Model::counts_force`).
//!
//! Building is deterministic (sorted darts, circuits found in dart order) and costs a sort of the
//! contacts; a rebuild keeps the ids, pressures and PFIX of the domains it finds again (the ones
//! with the most contacts in common).

use std::collections::HashMap;

use crate::udec::model::domain::{Domain, DomainKind, DomainLink, Domains, LOOP_START, MIN_AREA_FRACTION, NO_DOMAIN};
use crate::udec::model::geometry::{cross, distance, dot, point_in_polygon, signed_area, sub};
use crate::udec::model::{Contact, Model};

/// One contact seen from one of its two blocks.
#[derive(Clone, Copy, Debug)]
struct Dart {
    block: u32,
    /// Index in `Model::contacts`.
    contact: u32,
    /// Where on the block: 2k at corner k, 2k + 1 on the edge from corner k to k + 1.
    feature: u32,
    /// Order among darts at the same feature: the distance along an edge, or the angle of the
    /// direction towards the other block at a corner, counted in the corner's turning sense.
    along: f64,
    /// The point of the block's boundary the contact touches (the corner itself for the corner's
    /// owner, the corner's foot on the other block's edge or corner).
    foot: [f64; 2],
}

/// A traced circuit before it becomes a domain.
struct Circuit {
    /// Darts in circuit order; each starts the piece of boundary up to its block's next dart.
    darts: Vec<u32>,
    signed_area: f64,
    group: u32,
}

/// Whether contact `c` names blocks, a corner and a feature that exist (a corrupt model builds
/// what it can rather than panicking).
fn is_valid(model: &Model, c: &Contact) -> bool {
    let (n, nc) = (model.blocks.len(), model.corners.len());
    if c.block1 as usize >= n || c.block2 as usize >= n || c.block1 == c.block2 || c.corner as usize >= nc {
        return false;
    }
    let (b1, b2) = (&model.blocks[c.block1 as usize], &model.blocks[c.block2 as usize]);
    let ok_range = |b: &crate::udec::model::Block| b.corner_count >= 3 && (b.corner_start as usize + b.corner_count as usize) <= nc;
    ok_range(b1) && ok_range(b2) && c.corner >= b1.corner_start && c.corner < b1.corner_start + b1.corner_count && c.feature < 2 * b2.corner_count
}

/// The contacts that link domains: all valid ones, less the view of a touch of two corners that
/// does not carry its force when the view that does is there (the two stand for one touch).
fn linking_contacts(model: &Model) -> Vec<bool> {
    let valid: Vec<bool> = model.contacts.iter().map(|c| is_valid(model, c)).collect();
    let counts: Vec<bool> = model.contacts.iter().zip(&valid).map(|(c, &v)| v && model.counts_force(c)).collect();
    // The counting contacts by (corner, block touched).
    let by_corner: HashMap<(u32, u32), usize> = model.contacts.iter().enumerate().filter(|&(i, _)| counts[i]).map(|(i, c)| ((c.corner, c.block2), i)).collect();
    model
        .contacts
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if !valid[i] {
                return false;
            }
            if counts[i] {
                return true;
            }
            // The other view: block 2's corner this touch pairs with, seen touching block 1.
            let b2 = &model.blocks[c.block2 as usize];
            let corners2 = model.block_corners(c.block2 as usize);
            let n = corners2.len();
            let k = (c.feature / 2) as usize % n;
            let pair = if c.feature % 2 == 0 {
                k
            } else {
                let own = model.corners[c.corner as usize].circle;
                let j = (k + 1) % n;
                let (dk, dj) = (sub(own, corners2[k].circle), sub(own, corners2[j].circle));
                if dot(dk, dk) <= dot(dj, dj) {
                    k
                } else {
                    j
                }
            };
            !by_corner.contains_key(&(b2.corner_start + pair as u32, c.block1))
        })
        .collect()
}

/// The angle of `d` from the outward normal of the edge arriving at corner `k` of a block with
/// corners `pts` (counter-clockwise), counted in the sense the outward normal turns through the
/// corner (counter-clockwise at a convex corner, clockwise at a re-entrant one): the order in
/// which a walk around the block meets directions leaving the corner.
fn angle_at_corner(pts: &[[f64; 2]], k: usize, d: [f64; 2]) -> f64 {
    let n = pts.len();
    let (a, p, b) = (pts[(k + n - 1) % n], pts[k], pts[(k + 1) % n]);
    let (t1, t2) = (sub(p, a), sub(b, p));
    let n1 = [t1[1], -t1[0]];
    let angle = cross(n1, d).atan2(dot(n1, d));
    if cross(t1, t2) >= 0.0 {
        angle
    } else {
        -angle
    }
}

/// The direction from block `from` towards the other block of contact `c`: the contact normal
/// (from block 2 into block 1) turned to face away from `from`, or, before the force law has set
/// a normal, the direction to the other block's centroid.
fn direction_out(model: &Model, c: &Contact, from_block1: bool, at: [f64; 2]) -> [f64; 2] {
    let n = c.normal;
    if n[0] != 0.0 || n[1] != 0.0 {
        return if from_block1 { [-n[0], -n[1]] } else { n };
    }
    let other = if from_block1 { c.block2 } else { c.block1 };
    sub(model.blocks[other as usize].centroid, at)
}

/// The two darts of contact `i`: on block 1 at its corner, on block 2 at the feature it touches.
fn darts_of(model: &Model, i: usize, positions: &[[f64; 2]]) -> [Dart; 2] {
    let c = &model.contacts[i];
    let (b1, b2) = (&model.blocks[c.block1 as usize], &model.blocks[c.block2 as usize]);
    let pts1 = &positions[b1.corner_start as usize..(b1.corner_start + b1.corner_count) as usize];
    let pts2 = &positions[b2.corner_start as usize..(b2.corner_start + b2.corner_count) as usize];
    let k1 = (c.corner - b1.corner_start) as usize;
    let corner = pts1[k1];
    let on1 = Dart {
        block: c.block1,
        contact: i as u32,
        feature: 2 * k1 as u32,
        along: angle_at_corner(pts1, k1, direction_out(model, c, true, corner)),
        foot: corner,
    };
    let k2 = (c.feature / 2) as usize;
    let on2 = if c.feature % 2 == 0 {
        let foot = pts2[k2];
        Dart { block: c.block2, contact: i as u32, feature: c.feature, along: angle_at_corner(pts2, k2, direction_out(model, c, false, foot)), foot }
    } else {
        // The foot of block 1's corner on the edge, within the edge.
        let (p, q) = (pts2[k2], pts2[(k2 + 1) % pts2.len()]);
        let e = sub(q, p);
        let len2 = dot(e, e);
        let t = if len2 > 0.0 { (dot(sub(corner, p), e) / len2).clamp(0.0, 1.0) } else { 0.0 };
        Dart { block: c.block2, contact: i as u32, feature: c.feature, along: t * len2.sqrt(), foot: [p[0] + t * e[0], p[1] + t * e[1]] }
    };
    [on1, on2]
}

/// The corners of a block (local indices) a piece of boundary passes going counter-clockwise from
/// feature `from` to feature `to`, exclusive; all the way round (`wrap`) when `to` is reached only
/// after passing corner 0 again (the block's last dart to its first, or its only dart to itself).
fn corners_between(from: u32, to: u32, wrap: bool, n: u32) -> impl Iterator<Item = u32> {
    // Past `from` (and before `to` unless the piece wraps), then from corner 0 on before `to`.
    let after = (0..n).filter(move |&k| 2 * k > from && (wrap || 2 * k < to));
    let before = (0..if wrap { n } else { 0 }).filter(move |&k| 2 * k < to);
    after.chain(before)
}

/// The bounding box of `pts`: [x min, y min, x max, y max].
fn bounding_box(pts: &[[f64; 2]]) -> [f64; 4] {
    pts.iter()
        .fold([f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY], |b, p| [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])])
}

/// Boxes larger than this many cells go to [`BoxGrid::large`], tested for every point.
const MAX_CELLS_PER_BOX: i64 = 64;

/// Bounding boxes in a uniform grid, to find those that may hold a point without testing all
/// of them (the voids a floating group may lie in: 3000 flying blocks over a wall of 30000 took
/// 2 s testing every void).
struct BoxGrid {
    cell: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
    large: Vec<usize>,
}

impl BoxGrid {
    fn new(boxes: &[[f64; 4]], cell: f64) -> Self {
        let cell = if cell.is_finite() && cell > 0.0 { cell } else { 1.0 };
        let mut grid = BoxGrid { cell, cells: HashMap::new(), large: Vec::new() };
        for (v, b) in boxes.iter().enumerate() {
            let (lo, hi) = (grid.key([b[0], b[1]]), grid.key([b[2], b[3]]));
            let span = |a: i64, b: i64| b.saturating_sub(a).saturating_add(1);
            let count = span(lo.0, hi.0).saturating_mul(span(lo.1, hi.1));
            if !(1..=MAX_CELLS_PER_BOX).contains(&count) {
                grid.large.push(v);
                continue;
            }
            for i in lo.0..=hi.0 {
                for j in lo.1..=hi.1 {
                    grid.cells.entry((i, j)).or_default().push(v);
                }
            }
        }
        grid
    }

    /// The cell of `p` (coordinates beyond i64 saturate: such a box is large anyway).
    fn key(&self, p: [f64; 2]) -> (i64, i64) {
        ((p[0] / self.cell).floor() as i64, (p[1] / self.cell).floor() as i64)
    }

    /// The boxes that may hold `p`: those of its cell and the large ones.
    fn candidates(&self, p: [f64; 2]) -> impl Iterator<Item = usize> + '_ {
        self.cells.get(&self.key(p)).into_iter().flatten().copied().chain(self.large.iter().copied())
    }
}

/// Union–find root of `x`.
fn root(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

/// The domains of `model`, from its blocks, corners and contacts. `previous` (the set built
/// before the last change of topology) gives its ids, pressures and PFIX to the domains found
/// again; without it the outer domain is 1 and the others follow in the order they are traced.
/// `min_area` is SET DAMIN's minimum area, if given now; otherwise `previous`'s, if it had one,
/// or [`MIN_AREA_FRACTION`] of the average block area.
pub fn build_domains(model: &Model, previous: Option<&Domains>, min_area: Option<f64>) -> Domains {
    let positions: Vec<[f64; 2]> = model.corners.iter().map(|c| c.position).collect();
    let linking = linking_contacts(model);

    // The darts, two a contact, and each block's darts in order around it.
    let mut darts: Vec<Dart> = Vec::with_capacity(2 * model.contacts.len());
    let mut dart_of: Vec<[u32; 2]> = vec![[u32::MAX; 2]; model.contacts.len()];
    for (i, &link) in linking.iter().enumerate() {
        if link {
            let [a, b] = darts_of(model, i, &positions);
            dart_of[i] = [darts.len() as u32, darts.len() as u32 + 1];
            darts.push(a);
            darts.push(b);
        }
    }
    let mut order: Vec<u32> = (0..darts.len() as u32).collect();
    order.sort_by(|&x, &y| {
        let (a, b) = (&darts[x as usize], &darts[y as usize]);
        (a.block, a.feature)
            .cmp(&(b.block, b.feature))
            .then(a.along.total_cmp(&b.along))
            .then(model.contacts[a.contact as usize].id.cmp(&model.contacts[b.contact as usize].id))
    });
    // next[d]: the block's next dart counter-clockwise; wraps[d]: whether reaching it passes
    // corner 0 (the last dart of the block to its first).
    let mut next = vec![0u32; darts.len()];
    let mut wraps = vec![false; darts.len()];
    let mut s = 0;
    while s < order.len() {
        let block = darts[order[s] as usize].block;
        let mut e = s;
        while e < order.len() && darts[order[e] as usize].block == block {
            e += 1;
        }
        for p in s..e {
            let q = if p + 1 < e { p + 1 } else { s };
            next[order[p] as usize] = order[q];
            wraps[order[p] as usize] = q <= p;
        }
        s = e;
    }
    // The other side of a dart's contact.
    let across = |d: u32| d ^ 1;

    // Groups of blocks linked by contacts.
    let mut parent: Vec<u32> = (0..model.blocks.len() as u32).collect();
    for d in (0..darts.len()).step_by(2) {
        let (a, b) = (root(&mut parent, darts[d].block), root(&mut parent, darts[d + 1].block));
        if a != b {
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let group: Vec<u32> = (0..model.blocks.len() as u32).map(|b| root(&mut parent, b)).collect();

    // The circuits, in dart order.
    let mut circuit_of = vec![u32::MAX; darts.len()];
    let mut circuits: Vec<Circuit> = Vec::new();
    let mut polygon = Vec::new();
    for &start in &order {
        if circuit_of[start as usize] != u32::MAX {
            continue;
        }
        let mut list = Vec::new();
        polygon.clear();
        let mut d = start;
        loop {
            circuit_of[d as usize] = circuits.len() as u32;
            list.push(d);
            let n = next[d as usize];
            trace_piece(model, &darts, &positions, d, n, wraps[d as usize], |p| polygon.push(p), |_| {});
            d = across(n);
            if d == start {
                break;
            }
        }
        let g = group[darts[start as usize].block as usize];
        circuits.push(Circuit { darts: list, signed_area: signed_area(&polygon), group: g });
    }

    // Each group's outside: its circuit of largest signed area (counter-clockwise), or the block
    // itself for a block with no contact.
    let mut outside_of_group: HashMap<u32, u32> = HashMap::new();
    for (k, c) in circuits.iter().enumerate() {
        let best = outside_of_group.entry(c.group).or_insert(k as u32);
        if c.signed_area > circuits[*best as usize].signed_area {
            *best = k as u32;
        }
    }
    let is_outside: Vec<bool> = circuits.iter().enumerate().map(|(k, c)| outside_of_group[&c.group] == k as u32).collect();

    // The voids, then the islands: each group's outside, placed in the smallest void of another
    // group that holds its first block's centroid, or outside.
    let voids: Vec<u32> = (0..circuits.len() as u32).filter(|&k| !is_outside[k as usize]).collect();
    // Islands: (group, first block, circuit of its outside or none for a lone block).
    let mut islands: Vec<(u32, u32, Option<u32>)> = Vec::new();
    let mut seen_group = vec![false; model.blocks.len()];
    for b in 0..model.blocks.len() as u32 {
        let g = group[b as usize];
        if !seen_group[g as usize] {
            seen_group[g as usize] = true;
            islands.push((g, b, outside_of_group.get(&g).copied()));
        }
    }
    // host[i]: the void (index into `voids`) island i floats in, if any. With one group there is
    // no void of another group to float in.
    let host: Vec<Option<usize>> = if islands.len() < 2 || voids.is_empty() {
        vec![None; islands.len()]
    } else {
        let polygons: Vec<Vec<[f64; 2]>> = voids
            .iter()
            .map(|&k| {
                let mut pts = Vec::new();
                for &d in &circuits[k as usize].darts {
                    trace_piece(model, &darts, &positions, d, next[d as usize], wraps[d as usize], |p| pts.push(p), |_| {});
                }
                pts
            })
            .collect();
        let boxes: Vec<[f64; 4]> = polygons.iter().map(|pts| bounding_box(pts)).collect();
        let average = model.blocks.iter().map(|b| b.area.abs()).sum::<f64>() / model.blocks.len() as f64;
        let grid = BoxGrid::new(&boxes, average.sqrt());
        islands
            .iter()
            .map(|&(g, b, _)| {
                let p = model.blocks[b as usize].centroid;
                let mut best: Option<(usize, f64)> = None;
                for v in grid.candidates(p) {
                    let (c, bb) = (&circuits[voids[v] as usize], &boxes[v]);
                    if c.group == g || p[0] < bb[0] || p[0] > bb[2] || p[1] < bb[1] || p[1] > bb[3] {
                        continue;
                    }
                    let area = -c.signed_area;
                    if best.is_none_or(|(w, a)| area < a || (area == a && v < w)) && point_in_polygon(p, &polygons[v]) {
                        best = Some((v, area));
                    }
                }
                best.map(|(v, _)| v)
            })
            .collect()
    };

    // The domains: the outer one first, then the voids in tracing order.
    let average_block_area = if model.blocks.is_empty() { 0.0 } else { model.blocks.iter().map(|b| b.area.abs()).sum::<f64>() / model.blocks.len() as f64 };
    let given_min_area = min_area.or(previous.and_then(|p| p.given_min_area));
    let min_area = given_min_area.unwrap_or(MIN_AREA_FRACTION * average_block_area);
    let mut list: Vec<Domain> = Vec::with_capacity(voids.len() + 1);
    let mut links: Vec<DomainLink> = Vec::new();
    let mut link_sides: Vec<u8> = Vec::new();
    let mut domain_of_circuit = vec![0u32; circuits.len()];
    let mut blocks_seen: Vec<u32> = Vec::new();
    let blank =
        |kind| Domain { id: 0, kind, area: 0.0, void_area: 0.0, length: 0.0, pressure: 0.0, fixed: false, max_displacement: 0.0, link_start: 0, link_count: 0 };

    // Appends a circuit's boundary to `links` and notes its blocks.
    // `sides` gets, beside each link, the side of the contact whose dart starts the piece that
    // follows it (bit 0: 0 on block 1, 1 on block 2) and whether it opens a loop (bit 1): what
    // the fluid stage needs to trace the void's polygon with the current positions.
    let push_circuit = |k: usize, links: &mut Vec<DomainLink>, sides: &mut Vec<u8>, blocks_seen: &mut Vec<u32>| {
        for (n, &d) in circuits[k].darts.iter().enumerate() {
            let dart = &darts[d as usize];
            links.push(DomainLink::Contact { index: dart.contact, id: model.contacts[dart.contact as usize].id });
            // Darts are pushed in pairs, block 1's first: the dart's index gives its side.
            sides.push((d & 1) as u8 | if n == 0 { LOOP_START } else { 0 });
            blocks_seen.push(dart.block);
            trace_piece(
                model,
                &darts,
                &positions,
                d,
                next[d as usize],
                wraps[d as usize],
                |_| {},
                |corner| {
                    links.push(DomainLink::Corner { corner });
                    sides.push(0);
                },
            );
        }
    };
    // A lone block's boundary: its corners; returns the area they enclose.
    let push_lone = |b: u32, links: &mut Vec<DomainLink>, sides: &mut Vec<u8>, blocks_seen: &mut Vec<u32>| -> f64 {
        let blk = &model.blocks[b as usize];
        blocks_seen.push(b);
        let range = blk.corner_start as usize..(blk.corner_start + blk.corner_count) as usize;
        match positions.get(range.clone()) {
            Some(pts) => {
                sides.extend((0..pts.len()).map(|k| if k == 0 { LOOP_START } else { 0 }));
                links.extend(range.map(|corner| DomainLink::Corner { corner: corner as u32 }));
                signed_area(pts)
            }
            None => 0.0,
        }
    };
    let max_moved = |blocks: &[u32]| blocks.iter().map(|&b| model.blocks[b as usize].moved_since_update).fold(0.0, f64::max);

    // The outer domain: every island not in a void. Its void area is minus the area its
    // circuits enclose, so that the void areas of all domains add up to minus the blocks' area
    // (each piece of block boundary bounds one domain).
    let mut outer = blank(DomainKind::Outer);
    blocks_seen.clear();
    for (i, &(_, b, outside)) in islands.iter().enumerate() {
        if host[i].is_none() {
            match outside {
                Some(k) => {
                    domain_of_circuit[k as usize] = 0;
                    outer.void_area -= circuits[k as usize].signed_area;
                    push_circuit(k as usize, &mut links, &mut link_sides, &mut blocks_seen)
                }
                None => outer.void_area -= push_lone(b, &mut links, &mut link_sides, &mut blocks_seen),
            }
        }
    }
    outer.link_count = links.len() as u32;
    outer.max_displacement = max_moved(&blocks_seen);
    list.push(outer);

    // The islands of each void, in island order.
    let mut guests: Vec<(usize, usize)> = host.iter().enumerate().filter_map(|(i, h)| h.map(|v| (v, i))).collect();
    guests.sort_unstable();
    let mut guest = 0;
    for (v, &k) in voids.iter().enumerate() {
        let c = &circuits[k as usize];
        let mut domain = blank(DomainKind::Regular);
        domain.link_start = links.len() as u32;
        blocks_seen.clear();
        push_circuit(k as usize, &mut links, &mut link_sides, &mut blocks_seen);
        domain.void_area = -c.signed_area;
        // The islands floating in this void: their boundaries, less their area.
        let first_guest = guest;
        while guest < guests.len() && guests[guest].0 == v {
            let (_, b, outside) = islands[guests[guest].1];
            match outside {
                Some(o) => {
                    domain_of_circuit[o as usize] = list.len() as u32;
                    domain.void_area -= circuits[o as usize].signed_area;
                    push_circuit(o as usize, &mut links, &mut link_sides, &mut blocks_seen)
                }
                None => domain.void_area -= push_lone(b, &mut links, &mut link_sides, &mut blocks_seen),
            }
            guest += 1;
        }
        domain.link_count = links.len() as u32 - domain.link_start;
        domain.max_displacement = max_moved(&blocks_seen);
        let joint = if guest == first_guest { joint_length(&darts, &next, &wraps, c, model) } else { None };
        if let Some(length) = joint {
            // ¶7: A_d = a_j·l_j; the aperture is the fluid's (0 until fluid flows), so A_d(min).
            domain.kind = DomainKind::Joint;
            domain.length = length;
            domain.area = min_area;
        } else {
            domain.area = domain.void_area.max(min_area);
        }
        domain_of_circuit[k as usize] = list.len() as u32;
        list.push(domain);
    }

    // Which domains each contact separates.
    let mut sides = vec![[NO_DOMAIN; 2]; model.contacts.len()];
    for (i, pair) in dart_of.iter().enumerate() {
        if pair[0] != u32::MAX {
            sides[i] = pair.map(|d| domain_of_circuit[circuit_of[d as usize] as usize]);
        }
    }

    let mut domains = Domains { list, links, link_sides, sides, min_area, given_min_area, next_id: 1, flows: Vec::new() };
    assign_ids(&mut domains, previous);
    domains
}

/// Walks the piece of block boundary from dart `from` counter-clockwise to its block's next dart
/// `to`: `point` gets the polygon's vertices (the foot at `from`, the corners passed, the foot at
/// `to`), `corner` the global indices of the corners passed.
#[allow(clippy::too_many_arguments)]
fn trace_piece(
    model: &Model,
    darts: &[Dart],
    positions: &[[f64; 2]],
    from: u32,
    to: u32,
    wrap: bool,
    mut point: impl FnMut([f64; 2]),
    mut corner: impl FnMut(u32),
) {
    let (a, b) = (&darts[from as usize], &darts[to as usize]);
    let blk = &model.blocks[a.block as usize];
    point(a.foot);
    for k in corners_between(a.feature, b.feature, wrap, blk.corner_count) {
        let g = blk.corner_start + k;
        point(positions[g as usize]);
        corner(g);
    }
    point(b.foot);
}

/// The length of the joint a circuit is the void of, if it is one: two darts, whose pieces pass
/// no corner (the faces in opposition of an edge-to-edge contact; both contacts then join the
/// same two blocks). The length is the distance between the two contacts.
fn joint_length(darts: &[Dart], next: &[u32], wraps: &[bool], c: &Circuit, model: &Model) -> Option<f64> {
    if c.darts.len() != 2 {
        return None;
    }
    for &d in &c.darts {
        let (a, b) = (&darts[d as usize], &darts[next[d as usize] as usize]);
        let n = model.blocks[a.block as usize].corner_count;
        if corners_between(a.feature, b.feature, wraps[d as usize], n).next().is_some() {
            return None;
        }
    }
    Some(distance(darts[c.darts[0] as usize].foot, darts[c.darts[1] as usize].foot))
}

/// Gives each domain its id: the outer domain and each domain found again (the most contacts in
/// common with one of `previous`, greedily, most first) keep theirs with its pressure and PFIX;
/// the others get new ids in order. Then sorts the list by id (and remaps `sides`).
fn assign_ids(domains: &mut Domains, previous: Option<&Domains>) {
    let mut next_id = previous.map_or(1, |p| p.next_id.max(1));
    let mut taken: Vec<Option<usize>> = vec![None; domains.list.len()];
    if let Some(prev) = previous {
        let mut used = vec![false; prev.list.len()];
        // The outer domain stays the outer domain.
        if let Some(po) = prev.list.iter().position(|d| d.kind == DomainKind::Outer) {
            if let Some(no) = domains.list.iter().position(|d| d.kind == DomainKind::Outer) {
                taken[no] = Some(po);
                used[po] = true;
            }
        }
        let mut by_contact: HashMap<u32, Vec<usize>> = HashMap::new();
        for (p, d) in prev.list.iter().enumerate() {
            if d.kind == DomainKind::Outer {
                continue;
            }
            for l in prev.links_of(d) {
                if let DomainLink::Contact { id, .. } = *l {
                    by_contact.entry(id).or_default().push(p);
                }
            }
        }
        // (shared contacts, new, previous) for every pair that shares one.
        let mut pairs: Vec<(u32, usize, usize)> = Vec::new();
        for (n, d) in domains.list.iter().enumerate() {
            if d.kind == DomainKind::Outer {
                continue;
            }
            let mut count: HashMap<usize, u32> = HashMap::new();
            for l in domains.links_of(d) {
                if let DomainLink::Contact { id, .. } = *l {
                    for &p in by_contact.get(&id).map(Vec::as_slice).unwrap_or(&[]) {
                        *count.entry(p).or_default() += 1;
                    }
                }
            }
            pairs.extend(count.into_iter().map(|(p, k)| (k, n, p)));
        }
        pairs.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)).then(prev.list[a.2].id.cmp(&prev.list[b.2].id)));
        for (_, n, p) in pairs {
            if taken[n].is_none() && !used[p] {
                taken[n] = Some(p);
                used[p] = true;
            }
        }
    }
    for (n, d) in domains.list.iter_mut().enumerate() {
        match (taken[n], previous) {
            (Some(p), Some(prev)) => {
                let old = &prev.list[p];
                d.id = old.id;
                d.pressure = old.pressure;
                d.fixed = old.fixed;
            }
            _ => {
                d.id = next_id;
                next_id += 1;
            }
        }
    }
    domains.next_id = next_id;
    // Sort by id; remap `sides` to the new positions.
    let mut perm: Vec<usize> = (0..domains.list.len()).collect();
    perm.sort_by_key(|&k| domains.list[k].id);
    let mut new_pos = vec![0u32; perm.len()];
    for (to, &from) in perm.iter().enumerate() {
        new_pos[from] = to as u32;
    }
    let old = std::mem::take(&mut domains.list);
    let mut slots: Vec<Option<Domain>> = old.into_iter().map(Some).collect();
    domains.list = perm.iter().map(|&k| slots[k].take().expect("each domain moved once")).collect();
    for s in &mut domains.sides {
        for d in s.iter_mut() {
            if *d != NO_DOMAIN {
                *d = new_pos[*d as usize];
            }
        }
    }
}

/// Builds the model's domains afresh from its lists, keeping the ids, pressures and PFIX of the
/// domains found again in the set it had (and its SET DAMIN): after every change of topology in
/// a scene that has domains, and when a scene first asks for them.
pub fn refresh_domains(model: &mut Model) {
    refresh_domains_with(model, None);
}

/// [`refresh_domains`] with SET DAMIN's minimum area, when one was given. In a scene with fluid
/// the domains found again keep their pressures and PFIX, every domain gets the area the fluid
/// calculation uses now (`model::fluid::fluid_area`), the contacts their flows, and the change
/// this makes in the fluid stored goes to the mass balance's `adjusted` account (two voids a
/// new contact splits both keep the pressure of the one before; a void a lost contact merges
/// takes the pressure of the one most of its contacts came from).
pub fn refresh_domains_with(model: &mut Model, min_area: Option<f64>) {
    let previous = model.domains.take();
    let before = match (&model.fluid, &previous) {
        (Some(f), Some(d)) => crate::udec::model::fluid::stored_volume(d, f.bulk),
        _ => 0.0,
    };
    let mut domains = build_domains(model, previous.as_ref(), min_area);
    if let Some(fluid) = model.fluid {
        fluid_state(model, &mut domains);
        let after = crate::udec::model::fluid::stored_volume(&domains, fluid.bulk);
        if let Some(f) = model.fluid.as_mut() {
            if previous.is_some() {
                f.adjusted += after - before;
            } else {
                f.stored_at_start = after - f.inflow - f.adjusted;
            }
        }
    }
    model.domains = Some(domains);
}

/// A freshly built set's fluid state: each domain's area as the fluid calculation takes it now,
/// and each contact's flow at the pressures it has.
fn fluid_state(model: &Model, domains: &mut Domains) {
    use crate::udec::model::fluid::{contact_flows, fluid_area};
    let areas: Vec<f64> = (0..domains.list.len()).map(|d| fluid_area(model, domains, d)).collect();
    for (d, a) in domains.list.iter_mut().zip(areas) {
        d.area = a;
    }
    contact_flows(model, domains, &mut Vec::new());
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The model a deck leaves after `CYCLE 0` (a full contact detection, no motion).
    fn detected(blocks: &str) -> Model {
        let deck = format!("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\n{blocks}CYCLE 0\n");
        crate::scenes::run_deck_on(&deck, Box::new(crate::udec::cpu::CpuBackend::new())).expect("the scene builds")
    }

    /// Four blocks around a 1 × 1 hole, each in face contact with the next along 1 m.
    const PINWHEEL: &str = "BLOCK 0,0 2,0 2,1 0,1\nBLOCK 2,0 3,0 3,2 2,2\nBLOCK 1,2 3,2 3,3 1,3\nBLOCK 0,1 1,1 1,3 0,3\n";

    fn kinds(d: &Domains) -> Vec<DomainKind> {
        d.list.iter().map(|x| x.kind).collect()
    }

    /// Every linking contact is crossed twice in all (once by the circuit on each of its sides),
    /// the sides name the domains that list it, and every corner of a block is passed once.
    fn assert_consistent(model: &Model, d: &Domains) {
        let mut crossings = vec![Vec::new(); model.contacts.len()];
        let mut corners = vec![0; model.corners.len()];
        for (k, dom) in d.list.iter().enumerate() {
            for l in d.links_of(dom) {
                match *l {
                    DomainLink::Contact { index, id } => {
                        assert_eq!(model.contacts[index as usize].id, id);
                        crossings[index as usize].push(k as u32);
                    }
                    DomainLink::Corner { corner } => corners[corner as usize] += 1,
                }
            }
        }
        for (i, side) in d.sides.iter().enumerate() {
            if side[0] == NO_DOMAIN {
                assert!(crossings[i].is_empty(), "contact {i} is not a link but is crossed");
                continue;
            }
            let mut listed = crossings[i].clone();
            let mut expected = side.to_vec();
            listed.sort_unstable();
            expected.sort_unstable();
            assert_eq!(listed, expected, "contact {}", model.contacts[i].id);
        }
        // A corner is passed once, by the domain it faces, unless a contact sits at it (the
        // contact stands for it there).
        let mut at_contact = vec![false; model.corners.len()];
        for (i, c) in model.contacts.iter().enumerate() {
            if d.sides[i][0] != NO_DOMAIN {
                at_contact[c.corner as usize] = true;
                if c.feature % 2 == 0 {
                    at_contact[(model.blocks[c.block2 as usize].corner_start + c.feature / 2) as usize] = true;
                }
            }
        }
        for (k, &n) in corners.iter().enumerate() {
            assert_eq!(n, usize::from(!at_contact[k]), "corner {k}: {corners:?}");
        }
        assert_eq!(d.list.iter().filter(|x| x.kind == DomainKind::Outer).count(), 1);
        assert!(d.list.windows(2).all(|w| w[0].id < w[1].id), "ordered by id");
        let blocks: f64 = (0..model.blocks.len()).map(|b| signed_area(&model.corner_positions(b))).sum();
        let voids: f64 = d.list.iter().map(|x| x.void_area).sum();
        assert!((blocks + voids).abs() <= 1e-12 * blocks.max(1.0), "blocks {blocks}, voids {voids}");
    }

    #[test]
    fn corners_between_walks_counter_clockwise_and_wraps() {
        let v = |from, to, wrap| corners_between(from, to, wrap, 4).collect::<Vec<_>>();
        // From corner 1 to corner 3: corner 2 between; from edge 1 to edge 2: corner 2.
        assert_eq!(v(2, 6, false), [2]);
        assert_eq!(v(3, 5, false), [2]);
        // Two darts on one edge, or at one corner: none.
        assert_eq!(v(3, 3, false), Vec::<u32>::new());
        // From edge 2 round past corner 0 to edge 0: corners 3 and 0.
        assert_eq!(v(5, 1, true), [3, 0]);
        // The only dart of a block, at corner 1: all the others.
        assert_eq!(v(2, 2, true), [2, 3, 0]);
    }

    #[test]
    fn a_closed_void_between_four_blocks_is_one_regular_domain_of_its_area() {
        let model = detected(PINWHEEL);
        let d = build_domains(&model, None, None);
        assert_consistent(&model, &d);
        let regular: Vec<&Domain> = d.list.iter().filter(|x| x.kind == DomainKind::Regular).collect();
        assert_eq!(regular.len(), 1, "{:?}", kinds(&d));
        // The hole is 1 × 1; the traced boundary runs through the sharp corners and the corners'
        // feet on the edges, so the area is exact to round-off.
        assert!((regular[0].area - 1.0).abs() < 1e-12, "{}", regular[0].area);
        assert!((regular[0].void_area - 1.0).abs() < 1e-12);
        // Four contacts bound it, one from each block.
        let around: Vec<u32> =
            d.links_of(regular[0]).iter().filter_map(|l| if let DomainLink::Contact { index, .. } = *l { Some(index) } else { None }).collect();
        assert_eq!(around.len(), 4);
        let mut blocks: Vec<u32> = around.iter().map(|&i| model.contacts[i as usize].block1).collect();
        blocks.sort_unstable();
        assert_eq!(blocks, [0, 1, 2, 3]);
        // And four joint domains of length 1 at the minimum area, and the outer domain, id 1.
        let joints: Vec<&Domain> = d.list.iter().filter(|x| x.kind == DomainKind::Joint).collect();
        assert_eq!(joints.len(), 4);
        let average = model.blocks.iter().map(|b| b.area).sum::<f64>() / 4.0;
        for j in joints {
            assert!((j.length - 1.0).abs() < 1e-12, "{}", j.length);
            assert_eq!(j.area, MIN_AREA_FRACTION * average);
        }
        assert_eq!(d.outer().map(|o| (o.id, o.area)), Some((1, 0.0)));
    }

    #[test]
    fn a_block_floating_in_a_void_is_an_island_of_it() {
        // The pinwheel's hole made 2 × 2, a 0.5 × 0.5 block in it touching nothing.
        let ring =
            "BLOCK 0,0 3,0 3,1 0,1\nBLOCK 3,0 4,0 4,3 3,3\nBLOCK 1,3 4,3 4,4 1,4\nBLOCK 0,1 1,1 1,4 0,4\nBLOCK 1.75,1.75 2.25,1.75 2.25,2.25 1.75,2.25\n";
        let model = detected(ring);
        let d = build_domains(&model, None, None);
        assert_consistent(&model, &d);
        let void = d.list.iter().find(|x| x.kind == DomainKind::Regular).expect("the hole");
        assert!((void.area - (4.0 - 0.25)).abs() < 1e-12, "{}", void.area);
        let island = &model.blocks[4];
        let corners: Vec<u32> = d.links_of(void).iter().filter_map(|l| if let DomainLink::Corner { corner } = *l { Some(corner) } else { None }).collect();
        assert!((island.corner_start..island.corner_start + 4).all(|c| corners.contains(&c)), "{corners:?}");
        // The outer domain does not see it.
        let outer = d.outer().unwrap();
        assert!(!d.links_of(outer).iter().any(|l| matches!(*l, DomainLink::Corner { corner } if corner >= island.corner_start)));
    }

    #[test]
    fn lone_blocks_and_an_empty_model_have_only_the_outer_domain() {
        let d = build_domains(&Model::default(), None, None);
        assert_eq!(kinds(&d), [DomainKind::Outer]);
        assert!(d.links.is_empty() && d.min_area == 0.0);
        // Two blocks 1 m apart: no contact, both on the outer domain's list.
        let model = detected("BLOCK 0,0 1,0 1,1 0,1\nBLOCK 2,0 3,0 3,1 2,1\n");
        assert!(model.contacts.is_empty());
        let d = build_domains(&model, None, None);
        assert_consistent(&model, &d);
        assert_eq!(kinds(&d), [DomainKind::Outer]);
        assert_eq!(d.links.len(), 8);
    }

    #[test]
    fn a_rebuild_keeps_the_ids_pressures_and_pfix_of_the_domains_found_again() {
        let mut model = detected(PINWHEEL);
        let mut first = build_domains(&model, None, None);
        // Fluid would have set these: a rebuild on the same lists keeps them all.
        for (k, d) in first.list.iter_mut().enumerate() {
            d.pressure = 100.0 * k as f64;
            d.fixed = k % 2 == 0;
        }
        let again = build_domains(&model, Some(&first), None);
        let summary = |d: &Domains| d.list.iter().map(|x| (x.id, x.kind, x.pressure, x.fixed)).collect::<Vec<_>>();
        assert_eq!(summary(&again), summary(&first));
        assert_eq!(again.next_id, first.next_id);
        // Without block 3 (index 2) the hole opens into the outer domain: the two joints it had
        // go, the two others keep their ids and pressures, and no id is reused.
        model.remove_blocks(&[2]);
        let after = build_domains(&model, Some(&first), None);
        assert_consistent(&model, &after);
        let joints = |d: &Domains| d.list.iter().filter(|x| x.kind == DomainKind::Joint).map(|x| (x.id, x.pressure)).collect::<Vec<_>>();
        let kept: Vec<(u32, f64)> = joints(&first).into_iter().filter(|j| joints(&after).contains(j)).collect();
        assert_eq!(kept.len(), 2, "{:?} then {:?}", joints(&first), joints(&after));
        assert_eq!(joints(&after).len(), 2);
        assert_eq!(kinds(&after), [DomainKind::Outer, DomainKind::Joint, DomainKind::Joint]);
        assert_eq!(after.outer().unwrap().id, first.outer().unwrap().id);
    }
}
