//! A concave block cut into convex parts (SL-85-1 ¶13: "any arbitrary shape can be devised by
//! using triangles as building blocks, including blocks with concave regions").
//!
//! D3's contact geometry (`d3::contact`: the common plane by separating axes, the logical
//! contacts, the rays' crossings) holds for convex bodies. So a concave block is cut, once when
//! it is built, into convex parts whose union is the block, as 3DEC makes a concave block of
//! convex sub-blocks; the parts move rigidly with the block (`Block::parts`), and contact
//! detection runs between parts of different blocks.
//!
//! # The cut
//!
//! A closed surface is convex exactly when no edge of it is **reflex** (the solid's dihedral angle
//! along it above 180°: the third vertex of one face lies in front of the other face's plane) and
//! it is connected and not self-touching. While a piece has a reflex edge, it is cut by the plane
//! of one of the two faces along that edge: the edge then lies in the cut and ends up between a
//! face and the cap, at an angle below 180°, or flat. A plane cut never makes a reflex edge (where
//! it crosses a face, the solid left is the meeting of two half-spaces), so the reflex edges only
//! go, and the cuts end. Of the candidate planes the one on which most reflex edges lie is taken
//! first (a U-shaped block's notch floor resolves both its inner edges at once: three parts);
//! where a cut does not come out clean (a plane through another reflex edge whose faces both lie
//! behind it pinches the piece along that edge), the next candidate is tried.
//!
//! Cutting a closed mesh by a plane: each vertex is in front, behind or on the plane (within
//! 10⁻⁹ of the block's size); each triangle is clipped into the part behind and the part in front
//! (Sutherland–Hodgman, the crossing point of an edge computed once for both faces along it); a
//! triangle on the plane goes to the side its outward normal points away from. Each side is then
//! open where the plane cut it: its half-edges without a twin bound the hole, which a cap closes.
//! The cap lies in the plane and may be non-convex or have holes (the cross-section of a concave
//! solid), so it is a constrained Delaunay triangulation (`spade`) of the hole's edges, of which
//! the triangles inside the hole are kept: those along a boundary edge on its inner side, and
//! their neighbours across edges that are no boundary (decided from the boundary's edges, not by
//! a point test, which a sliver along nearly collinear corners defeats). Each side is finally
//! split into its connected parts (across shared edges).
//!
//! The parts must come out closed, convex, and with volumes that sum to the block's: a surface
//! that does not (a self-touching or self-intersecting one, or a cut that leaves a sliver of a
//! face) is an error, for the caller to name the block.

use glam::{DVec2, DVec3};
use rustc_hash::FxHashMap;

use super::geometry::{self, Shape};
use super::model::Part;

/// The most cuts a block may take: far more than a block typed by hand needs.
const MAX_CUTS: usize = 512;

/// A closed triangulated surface: vertices, and faces counter-clockwise seen from outside.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
}

impl Mesh {
    /// The volume enclosed (divergence theorem, about the first vertex).
    pub fn volume(&self) -> f64 {
        let o = self.vertices.first().copied().unwrap_or_default();
        self.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|k| self.vertices[k as usize] - o);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// The outward normal (not unit) of face `f`.
    fn normal(&self, f: usize) -> DVec3 {
        let [a, b, c] = self.faces[f].map(|k| self.vertices[k as usize]);
        (b - a).cross(c - a)
    }

    /// The face on each half-edge (a, b): an error where two faces run along one edge the same
    /// way (a surface that touches itself along an edge).
    fn half_edges(&self) -> Result<FxHashMap<(u32, u32), u32>, String> {
        let mut map = FxHashMap::default();
        for (k, f) in self.faces.iter().enumerate() {
            for e in 0..3 {
                if map.insert((f[e], f[(e + 1) % 3]), k as u32).is_some() {
                    return Err("the surface touches itself along an edge (more than two faces share it)".into());
                }
            }
        }
        Ok(map)
    }

    /// Its reflex edges, each as (face on one side, face on the other, the edge's ends), found
    /// with the tolerance `eps` (a length).
    fn reflex_edges(&self, half: &FxHashMap<(u32, u32), u32>, eps: f64) -> Vec<(u32, u32, u32, u32)> {
        let mut out = Vec::new();
        for (k, f) in self.faces.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (f[e], f[(e + 1) % 3]);
                if a > b {
                    continue;
                }
                let Some(&g) = half.get(&(b, a)) else { continue };
                // The vertex of face g off the edge, against face k's plane.
                let third = self.faces[g as usize].iter().copied().find(|&v| v != a && v != b).unwrap_or(a);
                let n = self.normal(k).normalize_or_zero();
                if n.dot(self.vertices[third as usize] - self.vertices[a as usize]) > eps {
                    out.push((k as u32, g, a, b));
                }
            }
        }
        out
    }

    /// Whether every vertex is on or behind every face's plane (within `eps`).
    fn is_convex(&self, eps: f64) -> bool {
        (0..self.faces.len()).all(|f| {
            let n = self.normal(f).normalize_or_zero();
            let p = self.vertices[self.faces[f][0] as usize];
            self.vertices.iter().all(|v| n.dot(*v - p) <= eps)
        })
    }

    /// The mesh split into its parts connected across edges, each with only the vertices it uses.
    fn components(&self) -> Result<Vec<Mesh>, String> {
        let half = self.half_edges()?;
        let n = self.faces.len();
        let mut label = vec![u32::MAX; n];
        let mut out = Vec::new();
        for start in 0..n {
            if label[start] != u32::MAX {
                continue;
            }
            let id = out.len() as u32;
            let mut stack = vec![start];
            label[start] = id;
            let mut faces = Vec::new();
            while let Some(f) = stack.pop() {
                faces.push(f);
                let t = self.faces[f];
                for e in 0..3 {
                    let Some(&g) = half.get(&(t[(e + 1) % 3], t[e])) else {
                        return Err("a piece of the cut surface is not closed".into());
                    };
                    if label[g as usize] == u32::MAX {
                        label[g as usize] = id;
                        stack.push(g as usize);
                    }
                }
            }
            faces.sort_unstable();
            let mut index: FxHashMap<u32, u32> = FxHashMap::default();
            let mut mesh = Mesh::default();
            for f in faces {
                let t = self.faces[f].map(|v| {
                    *index.entry(v).or_insert_with(|| {
                        mesh.vertices.push(self.vertices[v as usize]);
                        mesh.vertices.len() as u32 - 1
                    })
                });
                mesh.faces.push(t);
            }
            out.push(mesh);
        }
        Ok(out)
    }
}

/// Whether each vertex's faces make one fan (one cycle of faces around it): a surface two of
/// whose sheets touch at a vertex is not one.
fn single_fans(mesh: &Mesh, half: &FxHashMap<(u32, u32), u32>) -> bool {
    let mut incident = vec![0usize; mesh.vertices.len()];
    for f in &mesh.faces {
        for &v in f {
            incident[v as usize] += 1;
        }
    }
    let mut seen = vec![false; mesh.vertices.len()];
    for (k, f) in mesh.faces.iter().enumerate() {
        for &v in f {
            if std::mem::replace(&mut seen[v as usize], true) {
                continue;
            }
            // Walk around v from face k: across each face's edge arriving at v (prev → v) into
            // the face running along it the other way, until back at k.
            let (mut face, mut count) = (k as u32, 0usize);
            loop {
                count += 1;
                let t = mesh.faces[face as usize];
                let i = t.iter().position(|&x| x == v).unwrap_or(0);
                let prev = t[(i + 2) % 3];
                // The edge prev → v of this face; its twin v → prev is on the next face.
                match half.get(&(v, prev)) {
                    Some(&g) if g != k as u32 && count <= incident[v as usize] => face = g,
                    Some(_) => break,
                    None => return false,
                }
            }
            if count != incident[v as usize] {
                return false;
            }
        }
    }
    true
}

/// Cuts `mesh` by the plane n·x = d: the closed pieces behind it and in front of it (each
/// possibly in several connected parts).
fn cut(mesh: &Mesh, n: DVec3, d: f64, eps: f64) -> Result<Vec<Mesh>, String> {
    Ok(cut_sides(mesh, n, d, eps)?.into_iter().flatten().collect())
}

/// The cut of a mesh by a plane (`cut`), the pieces by side: first those behind the plane (n·x < d), then those in front,
/// each side's closed pieces connected across edges (a concave solid may leave several on a
/// side: a U cut across its arms). SPLIT of a concave block (`d3::split`) takes them as blocks.
pub fn cut_sides(mesh: &Mesh, n: DVec3, d: f64, eps: f64) -> Result<[Vec<Mesh>; 2], String> {
    let s: Vec<f64> = mesh.vertices.iter().map(|v| n.dot(*v) - d).collect();
    let class: Vec<i8> = s
        .iter()
        .map(|&x| {
            if x > eps {
                1
            } else if x < -eps {
                -1
            } else {
                0
            }
        })
        .collect();
    let mut vertices = mesh.vertices.clone();
    let mut crossings: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    let mut sides: [Vec<[u32; 3]>; 2] = [Vec::new(), Vec::new()];
    for (k, f) in mesh.faces.iter().enumerate() {
        let c = f.map(|v| class[v as usize]);
        if c == [0, 0, 0] {
            // On the plane: the side its outward normal points away from.
            let side = if mesh.normal(k).dot(n) > 0.0 { 0 } else { 1 };
            sides[side].push(*f);
            continue;
        }
        let mut polys: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
        for e in 0..3 {
            let (p, q) = (f[e], f[(e + 1) % 3]);
            let (cp, cq) = (class[p as usize], class[q as usize]);
            if cp <= 0 {
                polys[0].push(p);
            }
            if cp >= 0 {
                polys[1].push(p);
            }
            if cp * cq < 0 {
                let key = (p.min(q), p.max(q));
                let x = *crossings.entry(key).or_insert_with(|| {
                    let (a, b) = (key.0 as usize, key.1 as usize);
                    let t = s[a] / (s[a] - s[b]);
                    vertices.push(mesh.vertices[a] + (mesh.vertices[b] - mesh.vertices[a]) * t);
                    vertices.len() as u32 - 1
                });
                polys[0].push(x);
                polys[1].push(x);
            }
        }
        for (side, poly) in polys.iter().enumerate() {
            // A side holding only an edge or a vertex of the face gets no face; the clipped
            // polygon is convex, fanned from its first corner.
            if poly.len() < 3 {
                continue;
            }
            for i in 1..poly.len() - 1 {
                sides[side].push([poly[0], poly[i], poly[i + 1]]);
            }
        }
    }
    let mut out: [Vec<Mesh>; 2] = [Vec::new(), Vec::new()];
    for (side, faces) in sides.into_iter().enumerate() {
        if faces.is_empty() {
            continue;
        }
        // The cap: outward along +n for the piece behind, −n for the one in front.
        let m = if side == 0 { n } else { -n };
        let mut closed = faces.clone();
        closed.extend(cap(&vertices, &faces, m)?);
        let piece = Mesh { vertices: vertices.clone(), faces: closed };
        out[side] = piece.components()?;
    }
    Ok(out)
}

/// A vertex of the cap's triangulation, with its number in the mesh.
#[derive(Clone, Copy)]
struct CapVertex {
    p: spade::Point2<f64>,
    id: u32,
}

impl spade::HasPosition for CapVertex {
    type Scalar = f64;
    fn position(&self) -> spade::Point2<f64> {
        self.p
    }
}

/// The faces closing the hole the open surface `faces` leaves in the plane of outward normal
/// `m` (each counter-clockwise seen from outside, along +m).
fn cap(vertices: &[DVec3], faces: &[[u32; 3]], m: DVec3) -> Result<Vec<[u32; 3]>, String> {
    use spade::{ConstrainedDelaunayTriangulation, Triangulation};
    let mut count: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    for f in faces {
        for e in 0..3 {
            *count.entry((f[e], f[(e + 1) % 3])).or_default() += 1;
        }
    }
    if count.values().any(|&c| c > 1) {
        return Err("the surface touches itself along an edge where it is cut".into());
    }
    // The hole's boundary run the way the cap's faces run: each half-edge without a twin, reversed.
    let mut boundary: Vec<(u32, u32)> = count.keys().filter(|&&(a, b)| !count.contains_key(&(b, a))).map(|&(a, b)| (b, a)).collect();
    if boundary.is_empty() {
        return Ok(Vec::new());
    }
    boundary.sort_unstable();
    let t1 = m.any_orthonormal_vector();
    let t2 = m.cross(t1);
    let mut ids: Vec<u32> = boundary.iter().flat_map(|&(a, b)| [a, b]).collect();
    ids.sort_unstable();
    ids.dedup();
    let at: FxHashMap<u32, usize> = ids.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    let flat: Vec<DVec2> = ids.iter().map(|&v| DVec2::new(t1.dot(vertices[v as usize]), t2.dot(vertices[v as usize]))).collect();
    let points: Vec<CapVertex> = ids.iter().zip(&flat).map(|(&id, p)| CapVertex { p: spade::Point2::new(p.x, p.y), id }).collect();
    let edges: Vec<[usize; 2]> = boundary.iter().map(|&(a, b)| [at[&a], at[&b]]).collect();
    let mut conflicts = 0usize;
    let cdt = ConstrainedDelaunayTriangulation::<CapVertex>::try_bulk_load_cdt(points, edges, |_| conflicts += 1)
        .map_err(|e| format!("the cut's cross-section cannot be triangulated ({e:?})"))?;
    if conflicts > 0 {
        return Err("the cut's cross-section has edges that cross (the surface intersects itself)".into());
    }
    if cdt.num_vertices() != ids.len() {
        return Err("two corners of the cut's cross-section coincide".into());
    }
    // Which triangles fill the hole, found from its boundary rather than by a point test (a
    // sliver along a boundary of nearly collinear corners has its centroid within round-off of
    // the boundary): a triangle running along a boundary edge the cap's way (b → a) is in, one
    // running along it the other way is out, and the others take the side of their neighbours
    // across edges that are no boundary (the triangulation's faces run counter-clockwise).
    let on_boundary: rustc_hash::FxHashSet<(u32, u32)> = boundary.iter().copied().collect();
    let tris: Vec<[u32; 3]> = cdt.inner_faces().map(|f| f.vertices().map(|v| v.data().id)).collect();
    let mut inside: Vec<Option<bool>> = vec![None; tris.len()];
    let mut across: FxHashMap<(u32, u32), Vec<usize>> = FxHashMap::default();
    let conflict = || "the cut's cross-section does not close consistently (the surface may touch itself)".to_string();
    for (k, t) in tris.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            let side = if on_boundary.contains(&(a, b)) {
                Some(true)
            } else if on_boundary.contains(&(b, a)) {
                Some(false)
            } else {
                across.entry((a.min(b), a.max(b))).or_default().push(k);
                None
            };
            if let Some(side) = side {
                if inside[k].is_some_and(|s| s != side) {
                    return Err(conflict());
                }
                inside[k] = Some(side);
            }
        }
    }
    let mut stack: Vec<usize> = (0..tris.len()).filter(|&k| inside[k].is_some()).collect();
    while let Some(k) = stack.pop() {
        let side = inside[k];
        let t = tris[k];
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            for &g in across.get(&(a.min(b), a.max(b))).map_or(&[][..], |v| &v[..]) {
                match inside[g] {
                    None => {
                        inside[g] = side;
                        stack.push(g);
                    }
                    Some(s) if Some(s) != side => return Err(conflict()),
                    Some(_) => {}
                }
            }
        }
    }
    let mut out: Vec<[u32; 3]> = tris.iter().zip(&inside).filter(|(_, s)| **s == Some(true)).map(|(t, _)| *t).collect();
    out.sort_unstable();
    Ok(out)
}

/// The planes to cut `mesh` by, best first: the planes of the faces along its reflex edges, those
/// on which most reflex edges lie first (in face order among equals), each once. As (unit
/// normal, offset).
fn candidate_planes(mesh: &Mesh, reflex: &[(u32, u32, u32, u32)], eps: f64) -> Vec<(DVec3, f64)> {
    let mut out: Vec<(usize, DVec3, f64)> = Vec::new();
    for &(f, g, _, _) in reflex {
        for face in [f, g] {
            let n = mesh.normal(face as usize).normalize();
            let d = n.dot(mesh.vertices[mesh.faces[face as usize][0] as usize]);
            if out.iter().any(|&(_, m, e)| m.dot(n) > 1.0 - 1e-12 && (e - d).abs() <= eps) {
                continue;
            }
            let on = |v: u32| (n.dot(mesh.vertices[v as usize]) - d).abs() <= eps;
            let score = reflex.iter().filter(|&&(_, _, a, b)| on(a) && on(b)).count();
            out.push((score, n, d));
        }
    }
    // Stable: among planes of one score, the first found first.
    out.sort_by_key(|c| std::cmp::Reverse(c.0));
    out.into_iter().map(|(_, n, d)| (n, d)).collect()
}

/// The convex pieces of the closed, outward surface `mesh` (any shape; a convex one is returned
/// as it is), or why it cannot be cut into them.
pub fn convex_pieces(mesh: &Mesh) -> Result<Vec<Mesh>, String> {
    let (lo, hi) = mesh.vertices.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let size = (hi - lo).max_element();
    if !(size > 0.0 && size.is_finite()) {
        return Err("the surface has no size".into());
    }
    // Vertices within `eps` of a cut plane lie on it; bends under `flat` are no reflex edges
    // (`geometry::FLAT`: typed coordinates carry a few digits).
    let eps = 1e-9 * size;
    let flat = geometry::FLAT * size;
    let half = mesh.half_edges()?;
    if !single_fans(mesh, &half) {
        return Err("the surface touches itself at a vertex (its faces around the vertex make more than one fan)".into());
    }
    let whole = mesh.components()?;
    if whole.len() != 1 {
        return Err(format!("the surface is {} separate closed surfaces, not one", whole.len()));
    }
    let mut todo = whole;
    let mut done = Vec::new();
    let mut cuts = 0;
    while let Some(piece) = todo.pop() {
        let half = piece.half_edges()?;
        let reflex = piece.reflex_edges(&half, flat);
        if reflex.is_empty() {
            if !piece.is_convex(flat) {
                return Err("a piece without reflex edges is not convex (the surface intersects itself)".into());
            }
            done.push(piece);
            continue;
        }
        cuts += 1;
        if cuts > MAX_CUTS {
            return Err(format!("more than {MAX_CUTS} cuts would be needed to make it of convex parts"));
        }
        // The best plane first; where its cut does not come out clean (a plane through a
        // reflex edge elsewhere pinches a side along it), the next.
        let mut pieces = Err("a cut along a reflex edge left the piece whole (the surface intersects itself)".to_string());
        for (n, d) in candidate_planes(&piece, &reflex, eps) {
            pieces = match cut(&piece, n, d, eps) {
                Ok(p) if p.len() >= 2 => Ok(p),
                Ok(_) => Err("a cut along a reflex edge left the piece whole (the surface intersects itself)".into()),
                Err(e) => Err(e),
            };
            if pieces.is_ok() {
                break;
            }
        }
        let pieces = pieces?;
        // In reverse, so that the pieces come out in the order cut (the stack pops the last).
        todo.extend(pieces.into_iter().rev());
    }
    Ok(done)
}

/// The convex parts a block of `shape` and `volume` needs: none where it is convex, else
/// [`parts_of`]'s (a BLOCK, a SPLIT's or a crack's piece, a block read from an older save).
pub fn parts_if_concave(shape: &Shape, volume: f64) -> Result<Vec<Part>, String> {
    if shape.convex {
        Ok(Vec::new())
    } else {
        parts_of(shape, volume)
    }
}

/// The convex parts of a concave block's `shape` (its vertices about its centroid, reference
/// frame), as the block keeps them (`Block::parts`; their vertices still to be placed): each
/// part closed and convex, their volumes summing to `volume`, the block's, to round-off.
pub fn parts_of(shape: &Shape, volume: f64) -> Result<Vec<Part>, String> {
    let mesh = Mesh { vertices: shape.vertices.clone(), faces: shape.faces.clone() };
    let pieces = convex_pieces(&mesh)?;
    let size = 2.0 * shape.radius;
    let mut parts = Vec::with_capacity(pieces.len());
    let mut total = 0.0;
    for (k, piece) in pieces.into_iter().enumerate() {
        let (part, props) = geometry::shape_from_mesh(piece.vertices, piece.faces, size).map_err(|e| {
            format!(
                "its convex part {} comes out malformed ({}{}): the surface may touch or cross itself",
                k + 1,
                e.face.map_or(String::new(), |f| format!("face {f}: ")),
                e.message
            )
        })?;
        if !part.convex {
            return Err(format!("its part {} does not come out convex: the surface may touch or cross itself", k + 1));
        }
        total += props.volume;
        let n = part.vertices.len();
        parts.push(Part { shape: std::sync::Arc::new(part), offset: props.centroid, vertices: vec![DVec3::ZERO; n] });
    }
    if (total - volume).abs() > 1e-9 * volume.abs() {
        return Err(format!("its convex parts' volumes sum to {total}, not its volume {volume}: the surface may touch or cross itself"));
    }
    Ok(parts)
}
