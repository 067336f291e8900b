//! SPLIT for D3 (an extension, issue 31): a plane cuts every block it crosses into two convex
//! polyhedra (a concave block into as many pieces as the plane leaves), the 3D form of UDEC's
//! SPLIT (SL-85-1 Appendix A ¶13–14).
//!
//! A concave parent (made of convex parts, `d3::decompose`) is cut as a closed mesh
//! ([`concave_pieces`]): each side's connected pieces become blocks, cut into convex parts afresh
//! where concave. A convex parent is cut as follows: each of the parent's
//! triangular faces is clipped to either side of the plane (a triangle stays a triangle or
//! becomes a quadrilateral, cut into two triangles), and each piece is closed by the **cap**,
//! the convex polygon where the plane meets the block, fanned from its centroid into triangles so
//! that no triangle is degenerate where the cap's sides carry the crossings of a planar side's
//! diagonals. The points where the plane crosses an edge are computed once per edge, so that the
//! faces on either side of it and the cap share them exactly. A vertex within round-off of the
//! plane (10⁻⁹ of the block's radius) counts as on it. Each piece's surface goes through the
//! same checks as a BLOCK's (`geometry::shape_from_faces`: closed, outward, no zero-area face),
//! with its volume, centroid and exact inertia tensor computed afresh, and must come out convex;
//! a block whose cut fails any of these is left whole, with the reason.
//!
//! Momentum is kept: both pieces take the parent's angular velocity ω and the velocity of the
//! parent's motion at their own centroids, v + ω × (cᵢ − c), so that Σ mᵢvᵢ = m v and
//! Σ (Iᵢω + mᵢ (cᵢ − c) × vᵢ) = I ω (parallel axes). A load (LOAD) is shared by mass. A held
//! block's pieces are held at that motion; a piece's faces within a face loaded by BOUNDARY
//! STRESS keep its stress (`Block::inherit_boundary`).

use glam::DVec3;
use rustc_hash::FxHashMap;

use super::decompose::{self, Mesh};
use super::geometry;
use super::model::{Block, Model, Part};
use super::sdef::{strain_energy, Sdef};

/// What a SPLIT did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplitOutcome {
    /// (parent id, the new piece's id) for each block cut; the piece on the side the normal
    /// points away from keeps the parent's id and index.
    pub split: Vec<(u32, u32)>,
    /// Blocks the plane crosses that were left whole, with the reason.
    pub rejected: Vec<(u32, String)>,
    /// The strain energy the cut simply-deformable parents' stresses held, which their
    /// unstressed pieces no longer hold (SPLIT books it as released; a crack books the whole
    /// change of the energies instead, `cpu::crack_blocks`).
    pub released: f64,
}

/// The faces (as a deck types them: counter-clockwise looking along the outward normal) of the
/// two pieces of the convex polyhedron `vertices`/`faces` (faces counter-clockwise seen from
/// outside) cut by the plane through `point` with unit normal `normal`: first the piece behind
/// the plane (n·(x − p) < 0), then the one in front. None when the plane does not cross it.
pub fn cut_faces(vertices: &[DVec3], faces: &[[u32; 3]], point: DVec3, normal: DVec3, radius: f64) -> Option<[Vec<[[f64; 3]; 3]>; 2]> {
    let eps = 1e-9 * radius;
    let d: Vec<f64> = vertices.iter().map(|v| normal.dot(*v - point)).map(|x| if x.abs() <= eps { 0.0 } else { x }).collect();
    if d.iter().all(|&x| x >= 0.0) || d.iter().all(|&x| x <= 0.0) {
        return None;
    }
    // The crossing of each edge the plane cuts, once per edge (its lower vertex first).
    let mut crossings: FxHashMap<(u32, u32), DVec3> = FxHashMap::default();
    let mut crossing = |a: u32, b: u32| -> DVec3 {
        let (lo, hi) = (a.min(b), a.max(b));
        *crossings.entry((lo, hi)).or_insert_with(|| {
            let (pa, pb) = (vertices[lo as usize], vertices[hi as usize]);
            let (da, db) = (d[lo as usize], d[hi as usize]);
            pa + (pb - pa) * (da / (da - db))
        })
    };
    let mut pieces: [Vec<[[f64; 3]; 3]>; 2] = [Vec::new(), Vec::new()];
    let mut cap: Vec<DVec3> = Vec::new();
    for f in faces {
        for (side, sign) in [(0usize, -1.0f64), (1, 1.0)] {
            // Sutherland–Hodgman against the half-space sign·d ≥ 0, keeping the face's order.
            let mut poly: Vec<DVec3> = Vec::with_capacity(4);
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                let (da, db) = (sign * d[a as usize], sign * d[b as usize]);
                if da >= 0.0 {
                    poly.push(vertices[a as usize]);
                }
                if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
                    poly.push(crossing(a, b));
                }
            }
            if poly.len() < 3 || f.iter().all(|&v| d[v as usize] == 0.0) {
                continue;
            }
            // Counter-clockwise from outside (a, b, c) is typed (a, c, b).
            for k in 1..poly.len() - 1 {
                pieces[side].push([poly[0].to_array(), poly[k + 1].to_array(), poly[k].to_array()]);
            }
        }
    }
    for (k, &x) in d.iter().enumerate() {
        if x == 0.0 {
            cap.push(vertices[k]);
        }
    }
    cap.extend(crossings.values().copied());
    // The cap: its points around their centroid, in the plane's own axes.
    let centre = cap.iter().copied().sum::<DVec3>() / cap.len() as f64;
    let u = normal.any_orthonormal_vector();
    let w = normal.cross(u);
    cap.sort_by(|p, q| {
        let (a, b) = (*p - centre, *q - centre);
        a.dot(w).atan2(a.dot(u)).total_cmp(&b.dot(w).atan2(b.dot(u)))
    });
    cap.dedup_by(|p, q| (*p - *q).length() <= eps);
    if cap.len() < 3 {
        return None;
    }
    // The cap's points run counter-clockwise about n (u × w = n). The back piece's cap faces +n:
    // (c, p_k, p_k+1) is counter-clockwise from its outside and typed (c, p_k+1, p_k); the front
    // piece's faces −n, so the other way round.
    for k in 0..cap.len() {
        let (p, q) = (cap[k].to_array(), cap[(k + 1) % cap.len()].to_array());
        pieces[0].push([centre.to_array(), q, p]);
        pieces[1].push([centre.to_array(), p, q]);
    }
    Some(pieces)
}

/// The faces of a convex piece (typed as a deck types them, [`cut_faces`]'s) with each of its
/// planar sides in as few triangles as it needs: the triangles in one plane merged into the side's
/// polygon, of its corners only (the points along its edges and inside it, such as the crossings
/// of the parent's diagonals with the cut and the cap's centre, dropped: a point within `eps` of
/// the line of two others), fanned from one corner. Without this each cut would keep every point
/// it made, and a crack's pieces, cut again and again, would carry hundreds of vertices on their
/// flat sides (each a logical contact's corner: a stiffer contact, a smaller time step, a slower
/// cycle). Where a side's polygon comes out degenerate it is left out, and the piece's checks
/// (`geometry::shape_from_faces`) refuse the merged surface (`merged`).
pub fn fewest_faces(typed: &[[[f64; 3]; 3]], eps: f64) -> Vec<[[f64; 3]; 3]> {
    // The sides: outward unit normal, offset along it, and the points of their triangles.
    let mut sides: Vec<(DVec3, f64, Vec<DVec3>)> = Vec::new();
    for t in typed {
        let [a, b, c] = t.map(DVec3::from_array);
        // Typed (a, b, c) runs clockwise seen from outside: (a, c, b) counter-clockwise.
        let cross = (c - a).cross(b - a);
        let length = cross.length();
        // (A zero or NaN length: a degenerate triangle, whose points other triangles hold.)
        if length.is_nan() || length <= 0.0 {
            continue;
        }
        let n = cross / length;
        let d = n.dot(a);
        match sides.iter_mut().find(|(m, e, _)| m.dot(n) > 1.0 - 1e-9 && (e - d).abs() <= 100.0 * eps) {
            Some((_, _, points)) => points.extend([a, b, c]),
            None => sides.push((n, d, vec![a, b, c])),
        }
    }
    let mut out = Vec::with_capacity(2 * sides.len());
    for (n, _, points) in &sides {
        // The side's convex hull in its plane (u × w = n: counter-clockwise about n is
        // counter-clockwise seen from outside), by Andrew's monotone chain.
        let u = n.any_orthonormal_vector();
        let w = n.cross(u);
        let mut flat: Vec<(f64, f64, DVec3)> = points.iter().map(|&p| (p.dot(u), p.dot(w), p)).collect();
        flat.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.total_cmp(&q.1)));
        // How far o → a → b turns left: twice the triangle's area (a's distance from the line
        // o–b times |b − o|).
        let turn = |o: &(f64, f64, DVec3), a: &(f64, f64, DVec3), b: &(f64, f64, DVec3)| (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0);
        // The chains drop only points that make no left turn at all: a tolerance here would
        // test a point against the line of two others that need not lie on either side of it
        // (three points along an edge running across u, sorted out of their order along it by
        // round-off in u), and drop a true corner.
        let mut hull: Vec<(f64, f64, DVec3)> = Vec::with_capacity(flat.len() + 1);
        for pass in 0..2 {
            let start = hull.len();
            let chain: Box<dyn Iterator<Item = &(f64, f64, DVec3)>> = if pass == 0 { Box::new(flat.iter()) } else { Box::new(flat.iter().rev()) };
            for p in chain {
                while hull.len() >= start + 2 && turn(&hull[hull.len() - 2], &hull[hull.len() - 1], p) <= 0.0 {
                    hull.pop();
                }
                hull.push(*p);
            }
            // The chain's last point is the next chain's first.
            hull.pop();
        }
        // Then, round the closed polygon (its first point too), each point within `eps` of the
        // line of its two neighbours is dropped, the one nearest its line first: the side across
        // the edge drops that point too, so the two sides meet corner to corner.
        while hull.len() >= 3 {
            let n = hull.len();
            // (A NaN height: the neighbours coincide; the point goes too.)
            let height = |k: usize| {
                let (o, b) = (&hull[(k + n - 1) % n], &hull[(k + 1) % n]);
                turn(o, &hull[k], b) / (b.0 - o.0).hypot(b.1 - o.1)
            };
            match (0..n).map(|k| (height(k), k)).filter(|(h, _)| h.is_nan() || *h <= eps).min_by(|x, y| x.0.total_cmp(&y.0)) {
                Some((_, k)) => drop(hull.remove(k)),
                None => break,
            }
        }
        if hull.len() < 3 {
            continue;
        }
        // Counter-clockwise (h0, hk, hk+1) is typed (h0, hk+1, hk).
        for k in 1..hull.len() - 1 {
            out.push([hull[0].2.to_array(), hull[k + 1].2.to_array(), hull[k].2.to_array()]);
        }
    }
    out
}

/// The convex block of the typed faces `typed` with its flat sides merged ([`fewest_faces`],
/// points within `eps` of a line dropped), or None where that does not make a valid convex block
/// (the caller keeps the piece as cut).
fn merged(typed: &[[[f64; 3]; 3]], eps: f64) -> Option<(geometry::Shape, geometry::MassProperties)> {
    geometry::shape_from_faces(&fewest_faces(typed, eps)).ok().filter(|(shape, _)| shape.convex)
}

/// The pieces of a concave block (one made of convex parts, `d3::decompose`) cut by the plane
/// through `point` with unit normal `n`: its whole surface cut as a closed mesh
/// (`decompose::cut_sides`, the cross-section capped by a constrained triangulation, as it may be
/// non-convex or have holes), each side's connected pieces a block of their own, those behind
/// the plane first. A concave solid may leave more than one piece on a side (a U cut across its
/// arms leaves the two arms' tops in front). Each piece goes through the checks of a BLOCK's
/// surface and, where it is concave, is cut into convex parts afresh. None where the plane
/// does not cross the block; Err with the reason where a piece is not a valid block.
#[allow(clippy::type_complexity)]
pub fn concave_pieces(parent: &Block, point: DVec3, n: DVec3) -> Result<Option<Vec<(geometry::Shape, geometry::MassProperties, Vec<Part>)>>, String> {
    let size = 2.0 * parent.shape.radius;
    let mesh = Mesh { vertices: parent.vertices.clone(), faces: parent.shape.faces.clone() };
    let [back, front] = decompose::cut_sides(&mesh, n, n.dot(point), 1e-9 * parent.shape.radius)?;
    if back.is_empty() || front.is_empty() {
        return Ok(None);
    }
    let mut out = Vec::with_capacity(back.len() + front.len());
    for (side, piece) in back.into_iter().map(|p| (0, p)).chain(front.into_iter().map(|p| (1, p))) {
        let side = ["back", "front"][side];
        let (shape, props) =
            geometry::shape_from_mesh(piece.vertices, piece.faces, size).map_err(|e| format!("a {side} piece is not a valid block: {}", e.message))?;
        // A convex piece keeps its flat sides' corners only, as a convex parent's pieces do
        // ([`fewest_faces`]; its mesh's faces, counter-clockwise from outside, typed the other
        // way round).
        // (Where the merged sides do not make a valid convex block, the piece stays as cut.)
        let merged = shape.convex.then(|| {
            let typed: Vec<[[f64; 3]; 3]> =
                shape.faces.iter().map(|f| [f[0], f[2], f[1]].map(|v| (shape.vertices[v as usize] + props.centroid).to_array())).collect();
            merged(&typed, 1e-9 * parent.shape.radius)
        });
        let (shape, props) = merged.flatten().unwrap_or((shape, props));
        let parts =
            decompose::parts_if_concave(&shape, props.volume).map_err(|why| format!("a {side} piece is concave and cannot be made of convex parts: {why}"))?;
        out.push((shape, props, parts));
    }
    Ok(Some(out))
}

/// SPLIT: cuts every block the plane through `point` with normal `normal` crosses. `material`
/// and `constitutive`, where given, are the pieces' (else the parent's). A simply-deformable
/// block's pieces are simply deformable, unstressed. A concave block may come apart in more than
/// two pieces ([`concave_pieces`]).
pub fn split(model: &mut Model, point: DVec3, normal: DVec3, material: Option<u32>, constitutive: Option<u32>) -> SplitOutcome {
    let n = normal.normalize();
    let crossed: Vec<usize> = (0..model.blocks.len())
        .filter(|&b| {
            let blk = &model.blocks[b];
            let eps = 1e-9 * blk.shape.radius;
            let (lo, hi) = blk.vertices.iter().map(|v| n.dot(*v - point)).fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(x), h.max(x)));
            lo < -eps && hi > eps
        })
        .collect();
    let outcome = cut(model, &crossed, point, n, material, constitutive, 0.0);
    // The strain energy the parents' stresses held is released (the ledger's `released`).
    model.dissipated.released += outcome.released;
    outcome
}

/// A crack (SL-85-1 Part III ¶35f; `d3::cracking` finds it): block `b` splits along the plane
/// through `point` with normal `normal`; both pieces keep its material and constitutive number, a
/// simply-deformable block's pieces stay simply deformable, unstressed (`cut`); its contacts go,
/// for the caller to find afresh (`cpu::crack_blocks`, which books the ledger). Returns the ids
/// of the piece that keeps the block's and of the first new one (a concave block may come apart
/// in more), or None where the cut would not give valid pieces (the block is left whole).
pub fn crack(model: &mut Model, b: usize, point: DVec3, normal: DVec3) -> Option<(u32, u32)> {
    let built = model.blocks[b].built_volume;
    let outcome = cut(model, &[b], point, normal.normalize(), None, None, crate::cracking::least_piece(built));
    // The pieces are the block's as built (the cracking floor, `cracking::FRAGMENT_FLOOR`): the
    // one that keeps its index and the new ones at the end.
    if !outcome.split.is_empty() {
        let n = model.blocks.len();
        model.blocks[b].built_volume = built;
        for piece in &mut model.blocks[n - outcome.split.len()..] {
            piece.built_volume = built;
        }
    }
    outcome.split.first().copied()
}

/// Cuts the blocks `crossed` by the plane through `point` with unit normal `n` (the body of
/// [`split`] and [`crack`]); a block a piece of which would have a volume under `floor` is left
/// whole.
fn cut(model: &mut Model, crossed: &[usize], point: DVec3, n: DVec3, material: Option<u32>, constitutive: Option<u32>, floor: f64) -> SplitOutcome {
    let mut outcome = SplitOutcome::default();
    let mut next_id = model.blocks.iter().map(|b| b.id).max().unwrap_or(0) + 1;
    let mut touched = Vec::new();
    for &b in crossed {
        let parent = model.blocks[b].clone();
        let mut built = Vec::with_capacity(2);
        if parent.parts.is_empty() {
            let faces: Vec<[u32; 3]> = parent.shape.faces.clone();
            let Some(typed) = cut_faces(&parent.vertices, &faces, point, n, parent.shape.radius) else {
                continue;
            };
            for (side, faces) in typed.iter().enumerate() {
                // The sides merged to their corners (`fewest_faces`), or, where that does not
                // make a valid convex block, the piece as cut.
                match merged(faces, 1e-9 * parent.shape.radius).map_or_else(|| geometry::shape_from_faces(faces), Ok) {
                    Ok((shape, props)) if shape.convex => built.push((shape, props, Vec::new())),
                    Ok(_) => {
                        built.clear();
                        outcome.rejected.push((parent.id, format!("its {} piece comes out not convex within round-off", ["back", "front"][side])));
                        break;
                    }
                    Err(e) => {
                        built.clear();
                        outcome.rejected.push((parent.id, format!("its {} piece is not a valid block: {}", ["back", "front"][side], e.message)));
                        break;
                    }
                }
            }
            if built.len() != 2 {
                continue;
            }
        } else {
            match concave_pieces(&parent, point, n) {
                Ok(Some(pieces)) => built = pieces,
                Ok(None) => continue,
                Err(why) => {
                    outcome.rejected.push((parent.id, why));
                    continue;
                }
            }
        }
        if let Some((_, props, _)) = built.iter().find(|(_, props, _)| props.volume < floor) {
            outcome.rejected.push((parent.id, format!("a piece would have a volume of {:.3E}, under the floor of {floor:.3E}", props.volume)));
            continue;
        }
        let mat = material.unwrap_or(parent.material);
        let cons = constitutive.unwrap_or(parent.constitutive);
        // A simply-deformable parent is cut in its strained shape, whose volume is its own times
        // (1 + tr ε) to first order: its pieces' density is scaled so that they keep its mass
        // (and so its momentum); a rigid parent's pieces take the material's.
        let strained = built.iter().map(|(_, props, _)| props.volume).sum::<f64>();
        let scale = if parent.sdef.is_some() && strained > 0.0 { parent.volume / strained } else { 1.0 };
        let density = model.material(mat).density * scale;
        let first_new = next_id;
        let pieces: Vec<Block> = built
            .into_iter()
            .enumerate()
            .map(|(k, (shape, props, parts))| {
                let id = if k == 0 { parent.id } else { first_new + k as u32 - 1 };
                let mut piece = Block::new(id, mat, cons, shape, &props, density).with_parts(parts);
                piece.fixed = parent.fixed;
                if !parent.fixed {
                    // The parent's motion at the piece's centroid; its spin.
                    piece.velocity = parent.velocity_at(piece.centroid);
                    piece.angular_velocity = parent.angular_velocity;
                    piece.angular_momentum = piece.inertia() * parent.angular_velocity;
                }
                // Held as the parent (at its motion at the piece's centroid, above), and its
                // faces on a loaded face of the parent's loaded as that face (BOUNDARY, ¶35e).
                piece.inherit_boundary(&parent);
                piece.load = if parent.volume > 0.0 { parent.load * (props.volume / parent.volume) } else { DVec3::ZERO };
                // A simply-deformable parent's pieces stay simply deformable, their present
                // shape unstrained (stress zero, as 2D's cracked halves) and the parent's strain
                // rate kept: with the velocity at their centroids it gives each piece the
                // parent's motion at every point, so momentum is kept.
                piece.sdef = parent.sdef.map(|s| Sdef { strain_rate: if parent.fixed { [0.0; 6] } else { s.strain_rate }, ..Sdef::default() });
                piece
            })
            .collect();
        if let Some(s) = &parent.sdef {
            outcome.released += strain_energy(s, parent.volume);
        }
        let mut pieces = pieces.into_iter();
        let Some(back) = pieces.next() else { continue };
        model.blocks[b] = back;
        touched.push(b as u32);
        for piece in pieces {
            outcome.split.push((parent.id, piece.id));
            next_id = piece.id + 1;
            touched.push(model.blocks.len() as u32);
            model.blocks.push(piece);
        }
    }
    if !outcome.split.is_empty() {
        // The split blocks' contacts go (their logical contacts were keyed by the parents'
        // vertices); the lists are rebuilt before the next cycle.
        model.contacts.retain(|c| !touched.contains(&c.blocks[0]) && !touched.contains(&c.blocks[1]));
        model.neighbours_stale = true;
    }
    outcome
}
