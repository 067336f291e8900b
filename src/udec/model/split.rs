//! Block splitting: the SPLIT command and the split of a cracking block (SL-85-1 Appendix A,
//! "General splitting logic" ¶13–14 and "Dynamic cracking of blocks" ¶15–17).
//!
//! ¶13: a split may have any orientation and may pass through corners. If a crossing point of the
//! split line would make a new corner whose rounding arc interferes with an existing corner (here:
//! closer to it than the rounding length d), the line is diverted through that corner. If the
//! diverted line would then coincide with an existing edge, the split is rejected for that block;
//! so it is when a new corner would still lie closer than d to a corner of another edge (a sliver,
//! or beside a sharp corner: see `interferes`).
//!
//! All work is done on world outlines (a block may be rotated when it is split mid-run); the pieces
//! get a fresh body frame with rotation 0. A block's parent is removed and its pieces are appended at
//! the end of `Model::blocks`, so the indices of blocks after a split parent shift down; ids are
//! stable, and the first piece of each split block keeps its parent's id.

use super::build::{bbox_extent, BlockSeed};
use super::geometry::{self, add, boundary_distance, cross, distance, dot, point_in_polygon, scale, sub};
use super::Model;

/// What a SPLIT did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplitOutcome {
    /// Ids of the blocks that were split (each one's first piece keeps that id).
    pub split: Vec<u32>,
    /// Blocks in the path of the split line that were left whole, with the reason.
    pub rejected: Vec<(u32, String)>,
}

/// Where a chord ends on a polygon's boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
enum OnBoundary {
    /// At vertex i.
    Vertex(usize),
    /// Inside edge i (from vertex i to i + 1), at the given point.
    Edge(usize, [f64; 2]),
}

/// A polygon with the joint tags (material, constitutive) of its edges, tag i on edge i.
#[derive(Clone, Debug)]
struct Outline {
    pts: Vec<[f64; 2]>,
    tags: Vec<(u32, u32)>,
}

impl Outline {
    fn point(&self, at: OnBoundary) -> [f64; 2] {
        match at {
            OnBoundary::Vertex(i) => self.pts[i],
            OnBoundary::Edge(_, p) => p,
        }
    }
}

/// Length below which two points are the same: round-off relative to the block's size.
fn round_off(pts: &[[f64; 2]]) -> f64 {
    1e-9 * bbox_extent(pts)
}

/// ¶13's diversion: a crossing inside an edge closer than `d` to one of the edge's corners is moved
/// onto that corner, so that the new corner's rounding arc cannot interfere with the old one's.
/// (At least round-off close, so that ROUND 0 never makes a zero-length edge.)
fn divert(pts: &[[f64; 2]], at: OnBoundary, d: f64, eps: f64) -> OnBoundary {
    match at {
        OnBoundary::Vertex(_) => at,
        OnBoundary::Edge(i, p) => {
            let j = (i + 1) % pts.len();
            let (di, dj) = (distance(p, pts[i]), distance(p, pts[j]));
            let (k, dk) = if di <= dj { (i, di) } else { (j, dj) };
            if dk < d.max(eps) {
                OnBoundary::Vertex(k)
            } else {
                at
            }
        }
    }
}

/// ¶13's interference check for a corner the diversion could not cure: a crossing left inside its
/// edge is at least d from that edge's ends, but on a sliver or beside a sharp corner it can still
/// lie closer than d to a corner of another edge (the chord's other end, or a corner across). Its
/// rounding arc would overlap that corner's, and diverting onto a corner off its edge would bend
/// the cut away from the split line (a second SPLIT along the same line would then cut again), so
/// the split is rejected for this block instead.
fn interferes(pts: &[[f64; 2]], at: OnBoundary, d: f64) -> Result<(), String> {
    let OnBoundary::Edge(_, p) = at else { return Ok(()) };
    match pts.iter().map(|&c| (c, distance(p, c))).filter(|&(_, dc)| dc < d).min_by(|a, b| a.1.total_cmp(&b.1)) {
        Some((c, dc)) => Err(format!(
            "a new corner at ({:.6}, {:.6}) would lie {:.4} from the corner at ({:.6}, {:.6}), closer than the rounding length {}: their rounding arcs would overlap",
            p[0], p[1], dc, c[0], c[1], d
        )),
        None => Ok(()),
    }
}

/// Checks that the chord a–b cuts the polygon into two: distinct ends, not along an existing edge,
/// and its inside strictly inside the polygon (it may leave after a diversion on a re-entrant block).
fn check_chord(pts: &[[f64; 2]], a: OnBoundary, b: OnBoundary, eps: f64) -> Result<(), String> {
    use OnBoundary::{Edge, Vertex};
    let n = pts.len();
    let adjacent = |i: usize, j: usize| (i + 1) % n == j || (j + 1) % n == i;
    // Edges that touch an end of the chord and so may meet it there.
    let incident = |at: OnBoundary, e: usize| match at {
        Vertex(i) => e == i || (e + 1) % n == i,
        Edge(i, _) => e == i,
    };
    match (a, b) {
        (Vertex(i), Vertex(j)) if i == j => return Err("the diverted split line degenerates to a point".into()),
        (Vertex(i), Vertex(j)) if adjacent(i, j) => return Err("the diverted split line coincides with an existing edge".into()),
        (Vertex(v), Edge(e, _)) | (Edge(e, _), Vertex(v)) if e == v || (e + 1) % n == v => {
            return Err("the diverted split line coincides with an existing edge".into())
        }
        (Edge(i, _), Edge(j, _)) if i == j => return Err("the split line runs along an existing edge".into()),
        _ => {}
    }
    let pa = match a {
        Vertex(i) => pts[i],
        Edge(_, p) => p,
    };
    let pb = match b {
        Vertex(i) => pts[i],
        Edge(_, p) => p,
    };
    if distance(pa, pb) <= eps {
        return Err("the diverted split line degenerates to a point".into());
    }
    let mid = scale(add(pa, pb), 0.5);
    let leaves = !point_in_polygon(mid, pts)
        || boundary_distance(mid, pts) <= eps
        || (0..n).any(|e| !incident(a, e) && !incident(b, e) && geometry::segments_intersect(pa, pb, pts[e], pts[(e + 1) % n]));
    if leaves {
        return Err("the diverted split line would leave the block".into());
    }
    Ok(())
}

/// The chords that the segment from → to cuts out of a polygon (counter-clockwise): every interval
/// of the line inside the polygon that lies entirely on the segment, with its ends diverted through
/// nearby corners. Ok(empty) when the segment cuts nothing (it misses the block, or starts or ends
/// inside it); Err(reason) when it would cut but the cut is refused.
fn chords_along_segment(pts: &[[f64; 2]], from: [f64; 2], to: [f64; 2], d: f64) -> Result<Vec<(OnBoundary, OnBoundary)>, String> {
    let n = pts.len();
    let eps = round_off(pts);
    let len = distance(from, to);
    if len <= eps {
        return Ok(Vec::new());
    }
    let u = scale(sub(to, from), 1.0 / len);
    // s: signed distance of each vertex from the line; t: its position along the line.
    let s: Vec<f64> = pts.iter().map(|p| cross(u, sub(*p, from))).collect();
    let t: Vec<f64> = pts.iter().map(|p| dot(u, sub(*p, from))).collect();
    let on = |i: usize| s[i].abs() <= eps;

    // Where the line meets the boundary: vertices on it, and edges whose ends lie strictly on
    // opposite sides.
    let mut events: Vec<(f64, OnBoundary)> = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        if on(i) {
            events.push((t[i], OnBoundary::Vertex(i)));
        } else if !on(j) && (s[i] > 0.0) != (s[j] > 0.0) {
            let f = s[i] / (s[i] - s[j]);
            let p = add(pts[i], scale(sub(pts[j], pts[i]), f));
            events.push((t[i] + f * (t[j] - t[i]), OnBoundary::Edge(i, p)));
        }
    }
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    events.dedup_by(|later, earlier| {
        if later.0 - earlier.0 > eps {
            return false;
        }
        if matches!(later.1, OnBoundary::Vertex(_)) {
            *earlier = *later;
        }
        true
    });

    // Classify the intervals between events by their midpoints.
    let on_segment = |ta: f64, tb: f64| ta >= -eps && tb <= len + eps;
    let mut chords = Vec::new();
    let mut along_edge = false;
    for w in events.windows(2) {
        let (ta, tb) = (w[0].0, w[1].0);
        let mid = add(from, scale(u, 0.5 * (ta + tb)));
        if boundary_distance(mid, pts) <= eps {
            along_edge |= on_segment(ta, tb);
        } else if point_in_polygon(mid, pts) && on_segment(ta, tb) {
            chords.push((w[0].1, w[1].1));
        }
    }
    if chords.is_empty() {
        return if along_edge { Err("the split line coincides with an existing edge".into()) } else { Ok(chords) };
    }
    for chord in &mut chords {
        *chord = (divert(pts, chord.0, d, eps), divert(pts, chord.1, d, eps));
        check_chord(pts, chord.0, chord.1, eps)?;
        for end in [chord.0, chord.1] {
            interferes(pts, end, d)?;
        }
    }
    Ok(chords)
}

/// Cuts an outline along chords between boundary points, one chord at a time on whichever piece
/// holds it. The two new edges of each chord get the tag `joint`; split edges keep their tag.
fn cut_outline(outline: &Outline, chords: &[(OnBoundary, OnBoundary)], joint: (u32, u32)) -> Result<Vec<Outline>, String> {
    let eps = round_off(&outline.pts);
    let ends: Vec<([f64; 2], [f64; 2])> = chords.iter().map(|c| (outline.point(c.0), outline.point(c.1))).collect();

    // Make every chord end a vertex: insert points inside edges, the highest edge index first (and
    // on one edge the point farthest along it first) so that earlier indices stay valid.
    let mut inserts: Vec<(usize, f64, [f64; 2])> = chords
        .iter()
        .flat_map(|c| [c.0, c.1])
        .filter_map(|at| match at {
            OnBoundary::Edge(i, p) => Some((i, distance(outline.pts[i], p), p)),
            OnBoundary::Vertex(_) => None,
        })
        .collect();
    inserts.sort_by(|a, b| b.0.cmp(&a.0).then(b.1.total_cmp(&a.1)));
    inserts.dedup_by(|x, y| x.2 == y.2);
    let mut whole = outline.clone();
    for (i, _, p) in inserts {
        whole.pts.insert(i + 1, p);
        whole.tags.insert(i + 1, whole.tags[i]);
    }

    let mut pieces = vec![whole];
    for &(pa, pb) in &ends {
        let mid = scale(add(pa, pb), 0.5);
        let found = pieces.iter().enumerate().find_map(|(k, piece)| {
            let i = piece.pts.iter().position(|p| *p == pa)?;
            let j = piece.pts.iter().position(|p| *p == pb)?;
            (point_in_polygon(mid, &piece.pts) && boundary_distance(mid, &piece.pts) > eps).then_some((k, i, j))
        });
        let Some((k, i, j)) = found else {
            return Err("the split line's pieces inside the block interfere with each other".into());
        };
        let piece = pieces.swap_remove(k);
        let (i, j) = (i.min(j), i.max(j));
        // Vertices i..=j, closed by the chord j → i; and j..n, 0..=i, closed by the chord i → j.
        let mut first = Outline { pts: piece.pts[i..=j].to_vec(), tags: piece.tags[i..j].to_vec() };
        first.tags.push(joint);
        let mut second = Outline {
            pts: piece.pts[j..].iter().chain(&piece.pts[..=i]).copied().collect(),
            tags: piece.tags[j..].iter().chain(&piece.tags[..i]).copied().collect(),
        };
        second.tags.push(joint);
        pieces.insert(k, second);
        pieces.insert(k, first);
    }
    let floor = 1e-12 * bbox_extent(&outline.pts).powi(2);
    if pieces.iter().any(|p| geometry::signed_area(&p.pts) <= floor) {
        return Err("the split would leave a piece without area".into());
    }
    Ok(pieces)
}

/// Appends the pieces of block `b` with the carry-over rules of a split: material, constitutive,
/// kind and fixed flag inherited; velocity of the rigid motion v + ω × (c_piece − c_parent) with the
/// same ω; load shared in proportion to area; the first piece keeps the parent's id. Pieces have
/// no contacts yet, so they are marked as due for a contact update (moved at least ETOL). The
/// pieces of a crack (`cracked`) keep the parent's area as built (`Block::built_area`); a SPLIT's
/// are built by the deck, each its own. Does not remove the parent.
fn push_pieces(model: &mut Model, b: usize, pieces: &[Outline], cracked: bool) {
    let parent = model.blocks[b].clone();
    // A simply-deformable parent's points also moved at ε̇·r: its pieces take that velocity at
    // their centroids (momentum is kept, Σ m·r = 0 about the parent's centroid).
    let rate = model.sdef_of(b).map_or([0.0; 3], |s| s.strain_rate);
    let total: f64 = pieces.iter().map(|p| geometry::signed_area(&p.pts)).sum();
    for (k, piece) in pieces.iter().enumerate() {
        let props = geometry::polygon_properties(&piece.pts);
        let r = sub(props.centroid, parent.centroid);
        let w = parent.angular_velocity;
        let id = if k == 0 {
            parent.id
        } else {
            model.next_block_id += 1;
            model.next_block_id - 1
        };
        let seed = BlockSeed {
            id,
            kind: parent.kind,
            material: parent.material,
            constitutive: parent.constitutive,
            fixed: parent.fixed,
            velocity: if rate == [0.0; 3] {
                [parent.velocity[0] - w * r[1], parent.velocity[1] + w * r[0]]
            } else {
                [parent.velocity[0] - w * r[1] + rate[0] * r[0] + rate[1] * r[1], parent.velocity[1] + w * r[0] + rate[1] * r[0] + rate[2] * r[1]]
            },
            angular_velocity: w,
            load: scale(parent.load, props.area / total),
            // New pieces have no contacts yet: due for detection at the next update.
            moved_since_update: f64::INFINITY,
            built_area: cracked.then_some(parent.built_area),
        };
        model.push_block(&piece.pts, &piece.tags, seed);
    }
}

/// The current world outline of block `b` with its edge tags.
fn block_outline(model: &Model, b: usize) -> Outline {
    Outline { pts: model.world_outline(b), tags: model.block_corners(b).iter().map(|c| (c.edge_material, c.edge_constitutive)).collect() }
}

/// SPLIT x1,y1 x2,y2 [MAT=n] [CONS=m] (¶13–14): splits every block that the segment from → to
/// crosses completely. A block is cut along each interval where the line is inside it and that lies
/// entirely on the segment (a segment starting or ending inside a block leaves that interval
/// alone); a re-entrant block crossed 2k times may fall into k + 1 pieces. Crossings closer than the
/// rounding length to a corner are diverted through it; a diverted chord that runs along an edge or
/// shrinks to a point rejects the split of that block. The new joint edges get (MAT, CONS), 0 when
/// omitted; the split blocks' contacts are dropped for the topology stage to re-detect.
///
/// Block indices: the split parents are removed and their pieces appended at the end, in the order of
/// the parents; the other blocks keep their order but shift down past removed parents.
pub fn split_line(model: &mut Model, from: [f64; 2], to: [f64; 2], material: Option<u32>, constitutive: Option<u32>) -> SplitOutcome {
    let joint = (material.unwrap_or(0), constitutive.unwrap_or(0));
    let d = model.tol.round;
    let mut outcome = SplitOutcome::default();
    let mut cuts: Vec<(usize, Vec<Outline>)> = Vec::new();
    for b in 0..model.blocks.len() {
        let outline = block_outline(model, b);
        let id = model.blocks[b].id;
        let pieces =
            chords_along_segment(&outline.pts, from, to, d).and_then(
                |chords| {
                    if chords.is_empty() {
                        Ok(Vec::new())
                    } else {
                        cut_outline(&outline, &chords, joint)
                    }
                },
            );
        match pieces {
            Ok(p) if p.is_empty() => {}
            // The report splits rigid and simply-deformable blocks; a zoned block's zones would
            // not follow the cut.
            Ok(_) if model.blocks[b].kind == super::BlockKind::FullyDeformable => outcome.rejected.push((
                id,
                "it is fully deformable (zoned), and splitting a zoned block is not in the report; split it before CHANGE … FDEF and GENERATE".into(),
            )),
            Ok(p) => {
                outcome.split.push(id);
                cuts.push((b, p));
            }
            Err(why) => outcome.rejected.push((id, why)),
        }
    }
    for (b, pieces) in &cuts {
        push_pieces(model, *b, pieces, false);
    }
    let parents: Vec<usize> = cuts.iter().map(|c| c.0).collect();
    model.remove_blocks(&parents);
    outcome
}

/// Locates a point on (or within round-off of) the boundary: a vertex, or the nearest point inside
/// the nearest edge.
fn locate_on_boundary(pts: &[[f64; 2]], p: [f64; 2]) -> Option<OnBoundary> {
    let n = pts.len();
    let tol = 1e-7 * bbox_extent(pts);
    let (v, dv) = (0..n).map(|i| (i, distance(p, pts[i]))).min_by(|a, b| a.1.total_cmp(&b.1))?;
    if dv <= tol {
        return Some(OnBoundary::Vertex(v));
    }
    let (e, de) = (0..n).map(|i| (i, geometry::point_segment_distance(p, pts[i], pts[(i + 1) % n]))).min_by(|a, b| a.1.total_cmp(&b.1))?;
    if de > tol {
        return None;
    }
    let (a, b) = (pts[e], pts[(e + 1) % n]);
    let ab = sub(b, a);
    let f = (dot(sub(p, a), ab) / dot(ab, ab)).clamp(0.0, 1.0);
    Some(OnBoundary::Edge(e, add(a, scale(ab, f))))
}

/// Splits block `b` along the chord between boundary points p and q (dynamic cracking, ¶15–17);
/// the new joint gets (material, constitutive). Ends closer than the rounding length to a corner are
/// diverted through it, as for SPLIT. Same carry-over rules as [`split_line`].
///
/// The pieces are a crack's: they keep the block's area as built (`Block::built_area`), and a
/// chord that would leave a piece under `floor` in area is rejected (the fragment floor,
/// `crate::cracking`).
///
/// Returns the indices of the two pieces after compaction (they are the last two blocks; blocks
/// after `b` shift down by one), or None, leaving the model untouched, when p or q is not on the
/// boundary or the chord is rejected.
pub fn split_block_along(model: &mut Model, b: usize, p: [f64; 2], q: [f64; 2], material: u32, constitutive: u32, floor: f64) -> Option<Vec<usize>> {
    let outline = block_outline(model, b);
    let eps = round_off(&outline.pts);
    let d = model.tol.round;
    let a = divert(&outline.pts, locate_on_boundary(&outline.pts, p)?, d, eps);
    let c = divert(&outline.pts, locate_on_boundary(&outline.pts, q)?, d, eps);
    check_chord(&outline.pts, a, c, eps).ok()?;
    let pieces = cut_outline(&outline, &[(a, c)], (material, constitutive)).ok()?;
    if pieces.iter().any(|p| geometry::signed_area(&p.pts) < floor) {
        return None;
    }
    push_pieces(model, b, &pieces, true);
    model.remove_blocks(&[b]);
    let n = model.blocks.len();
    Some((n - pieces.len()..n).collect())
}
