//! The mesh generator of fully-deformable blocks (SL-85-1 Appendix A ¶11–12, GENERATE).
//!
//! GENERATE … AUTO amax zones a block in the report's three stages:
//!
//! 1. the boundary corners are linked into triangles: a constrained Delaunay triangulation of the
//!    outline (`spade`), its triangles outside the outline dropped, so a concave block is
//!    triangulated correctly;
//! 2. triangles are split until every side is at most amax: the longest side of the whole mesh is
//!    split at its midpoint, both triangles that share it with it (longest-edge bisection), so the
//!    mesh stays conforming and its angles do not degrade;
//! 3. each interior grid point is moved to the average of its neighbours, a few sweeps over them
//!    (a move that would turn a zone inside out is not made).
//!
//! GENERATE … MANUAL reads the grid points and zones as the manual gives them: grid points
//! numbered from the last one given (the last is number 1), zones clockwise, a grid point within
//! 0.9 × ROUND of a corner placed on it ([`manual_mesh`]).
//!
//! A mesh lists its boundary grid points first, in the block's corner order (grid point k is
//! corner k; new corners where a side was split), then the interior ones; zones are
//! counter-clockwise triples of grid point indices.

use std::collections::{BTreeMap, BinaryHeap};

use super::geometry::{orient, point_in_polygon, signed_area, sub};

/// A triangulated block: grid points (the first `boundary` of them are its outline,
/// counter-clockwise) and counter-clockwise zones.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub points: Vec<[f64; 2]>,
    pub boundary: usize,
    pub zones: Vec<[u32; 3]>,
}

impl Mesh {
    /// The area of zone `z` (positive: counter-clockwise).
    pub fn zone_area(&self, z: usize) -> f64 {
        let [a, b, c] = self.zones[z].map(|k| self.points[k as usize]);
        0.5 * orient(a, b, c)
    }

    /// The longest side of any zone.
    pub fn longest_side(&self) -> f64 {
        let mut l: f64 = 0.0;
        for z in &self.zones {
            for k in 0..3 {
                let d = sub(self.points[z[(k + 1) % 3] as usize], self.points[z[k] as usize]);
                l = l.max(d[0].hypot(d[1]));
            }
        }
        l
    }
}

/// Sweeps of the smoothing stage (stage 3): enough for the interior points of a block meshed to
/// a few zones across to settle within a few per cent of the neighbours' mean.
pub const SMOOTHING_SWEEPS: usize = 10;

/// Most zones one block may be given (a GENERATE with a tiny amax over a large block).
pub const MAX_ZONES: usize = 4_000_000;

/// A vertex of the constrained triangulation that remembers its corner.
#[derive(Clone, Copy)]
struct Vertex {
    p: spade::Point2<f64>,
    corner: usize,
}

impl spade::HasPosition for Vertex {
    type Scalar = f64;
    fn position(&self) -> spade::Point2<f64> {
        self.p
    }
}

/// Stage 1: the triangles of the outline `corners` (counter-clockwise, simple), as corner index
/// triples, counter-clockwise.
pub fn triangulate(corners: &[[f64; 2]]) -> Result<Vec<[u32; 3]>, String> {
    use spade::{ConstrainedDelaunayTriangulation, Triangulation};
    let n = corners.len();
    let vertices: Vec<Vertex> = corners.iter().enumerate().map(|(corner, c)| Vertex { p: spade::Point2::new(c[0], c[1]), corner }).collect();
    let edges: Vec<[usize; 2]> = (0..n).map(|k| [k, (k + 1) % n]).collect();
    let cdt = ConstrainedDelaunayTriangulation::<Vertex>::bulk_load_cdt(vertices, edges).map_err(|e| format!("the outline cannot be triangulated ({e:?})"))?;
    if cdt.num_vertices() != n {
        return Err("two corners of the outline coincide".into());
    }
    let mut tris = Vec::new();
    for face in cdt.inner_faces() {
        let [a, b, c] = face.vertices().map(|v| v.data().corner);
        let (pa, pb, pc) = (corners[a], corners[b], corners[c]);
        let centre = [(pa[0] + pb[0] + pc[0]) / 3.0, (pa[1] + pb[1] + pc[1]) / 3.0];
        // The triangulation covers the outline's convex hull: keep the triangles inside it.
        if !point_in_polygon(centre, corners) {
            continue;
        }
        if orient(pa, pb, pc) > 0.0 {
            tris.push([a as u32, b as u32, c as u32]);
        } else {
            tris.push([a as u32, c as u32, b as u32]);
        }
    }
    // Deterministic order whatever the triangulation's internal one.
    tris.sort_unstable();
    Ok(tris)
}

/// An edge's key, its ends in ascending order.
fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// An edge in the heap of stage 2: the longest first, ties by its ends.
#[derive(PartialEq)]
struct Side {
    length: f64,
    ends: (u32, u32),
}

impl Eq for Side {}

impl PartialOrd for Side {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Side {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.length.total_cmp(&other.length).then_with(|| other.ends.cmp(&self.ends))
    }
}

/// The whole AUTO generator: the outline `corners` (counter-clockwise) zoned so that every side
/// is at most `amax`.
pub fn auto_mesh(corners: &[[f64; 2]], amax: f64) -> Result<Mesh, String> {
    if !(amax > 0.0 && amax.is_finite()) {
        return Err(format!("the largest zone side must be positive, not {amax}"));
    }
    let mut points: Vec<[f64; 2]> = corners.to_vec();
    let mut zones = triangulate(corners)?;
    // Stage 2: longest-edge bisection. `edges` maps each side to the zones on it.
    let mut edges: BTreeMap<(u32, u32), Vec<usize>> = BTreeMap::new();
    let mut heap = BinaryHeap::new();
    let length = |p: &[[f64; 2]], (a, b): (u32, u32)| {
        let d = sub(p[b as usize], p[a as usize]);
        d[0].hypot(d[1])
    };
    for (z, t) in zones.iter().enumerate() {
        for k in 0..3 {
            let e = key(t[k], t[(k + 1) % 3]);
            edges.entry(e).or_default().push(z);
        }
    }
    for &e in edges.keys() {
        heap.push(Side { length: length(&points, e), ends: e });
    }
    // Midpoints of split boundary sides, to walk the new outline.
    let mut boundary_split: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    while let Some(Side { length: l, ends }) = heap.pop() {
        if l <= amax {
            break;
        }
        let Some(on) = edges.remove(&ends) else { continue };
        if zones.len() + on.len() > MAX_ZONES {
            return Err(format!("more than {MAX_ZONES} zones: amax {amax} is too small for the block"));
        }
        let (a, b) = ends;
        let (pa, pb) = (points[a as usize], points[b as usize]);
        let m = points.len() as u32;
        points.push([0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])]);
        if on.len() == 1 {
            boundary_split.insert(ends, m);
        }
        for z in on {
            // The zone (a, b, c) in its own order, a→b the split side: (a, m, c) and (m, b, c).
            let t = zones[z];
            let i = (0..3).find(|&i| key(t[i], t[(i + 1) % 3]) == ends).expect("the zone has the side");
            let (p, q, c) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
            let new = zones.len();
            zones[z] = [p, m, c];
            zones.push([m, q, c]);
            // The side q–c now belongs to the new zone; c–p stays with z.
            let qc = edges.get_mut(&key(q, c)).expect("every side is listed");
            for s in qc.iter_mut().filter(|s| **s == z) {
                *s = new;
            }
            for (e, owners) in [(key(p, m), vec![z]), (key(m, q), vec![new]), (key(m, c), vec![z, new])] {
                let entry = edges.entry(e).or_default();
                let fresh = entry.is_empty();
                entry.extend(owners);
                if fresh {
                    heap.push(Side { length: length(&points, e), ends: e });
                }
            }
        }
    }
    // The new outline: each side of the block walked through its midpoints, in order.
    let mut outline = Vec::new();
    fn walk(a: u32, b: u32, split: &BTreeMap<(u32, u32), u32>, out: &mut Vec<u32>) {
        match split.get(&key(a, b)) {
            Some(&m) => {
                walk(a, m, split, out);
                walk(m, b, split, out);
            }
            None => out.push(a),
        }
    }
    let n = corners.len() as u32;
    for k in 0..n {
        walk(k, (k + 1) % n, &boundary_split, &mut outline);
    }
    let mesh = renumber(points, &outline, zones);
    Ok(smooth_within(mesh, SMOOTHING_SWEEPS, amax))
}

/// The mesh with the outline's points first (in its order), then the rest in their order.
fn renumber(points: Vec<[f64; 2]>, outline: &[u32], zones: Vec<[u32; 3]>) -> Mesh {
    let mut map = vec![u32::MAX; points.len()];
    let mut new_points = Vec::with_capacity(points.len());
    for &k in outline {
        map[k as usize] = new_points.len() as u32;
        new_points.push(points[k as usize]);
    }
    for (k, p) in points.iter().enumerate() {
        if map[k] == u32::MAX {
            map[k] = new_points.len() as u32;
            new_points.push(*p);
        }
    }
    let zones = zones.into_iter().map(|z| z.map(|k| map[k as usize])).collect();
    Mesh { points: new_points, boundary: outline.len(), zones }
}

/// Stage 3: each interior point moved to the mean of its neighbours, `sweeps` times in point
/// order (Gauss–Seidel); a move that would turn one of its zones inside out (or flatten it) is
/// not made.
pub fn smooth(mesh: Mesh, sweeps: usize) -> Mesh {
    smooth_within(mesh, sweeps, f64::INFINITY)
}

/// [`smooth`], a move that would make one of the point's sides longer than `amax` not made
/// either (GENERATE AUTO keeps its promise of sides at most amax).
pub fn smooth_within(mut mesh: Mesh, sweeps: usize, amax: f64) -> Mesh {
    let n = mesh.points.len();
    if n == mesh.boundary {
        return mesh;
    }
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (z, t) in mesh.zones.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
            around[a as usize].push(z);
        }
    }
    for list in &mut neighbours {
        list.sort_unstable();
        list.dedup();
    }
    for _ in 0..sweeps {
        for k in mesh.boundary..n {
            let list = &neighbours[k];
            if list.is_empty() {
                continue;
            }
            let mut mean = [0.0, 0.0];
            for &j in list {
                mean[0] += mesh.points[j as usize][0];
                mean[1] += mesh.points[j as usize][1];
            }
            let mean = [mean[0] / list.len() as f64, mean[1] / list.len() as f64];
            let old = mesh.points[k];
            mesh.points[k] = mean;
            let too_long = list.iter().any(|&j| {
                let d = sub(mesh.points[j as usize], mean);
                d[0].hypot(d[1]) > amax
            });
            if too_long || around[k].iter().any(|&z| mesh.zone_area(z) <= 0.0) {
                mesh.points[k] = old;
            }
        }
    }
    mesh
}

/// GENERATE … MANUAL for one block: `outline` its corners (counter-clockwise), `points` the grid
/// points as given and `zones` the triples as given (numbered from the last point, the last is
/// 1; clockwise), `round` the rounding length. A grid point within 0.9 × round of a corner is
/// placed on it; every corner must have one, and the rest must lie inside the outline; the
/// zones must be clockwise and cover the block. Errors say which grid point or zone is wrong,
/// numbered as the deck numbers them.
pub fn manual_mesh(outline: &[[f64; 2]], points: &[[f64; 2]], zones: &[[u32; 3]], round: f64) -> Result<Mesh, String> {
    let np = points.len();
    let snap = 0.9 * round;
    // The deck's number of the grid point given at position i (0-based): the last is 1.
    let number = |i: usize| np - i;
    let mut at_corner: Vec<Option<usize>> = vec![None; outline.len()];
    let mut placed: Vec<[f64; 2]> = Vec::with_capacity(np);
    let mut corner_of: Vec<Option<usize>> = vec![None; np];
    for (i, &p) in points.iter().enumerate() {
        let near = outline.iter().enumerate().map(|(k, c)| (k, (p[0] - c[0]).hypot(p[1] - c[1]))).min_by(|a, b| a.1.total_cmp(&b.1));
        match near {
            Some((k, d)) if d <= snap => {
                if let Some(j) = at_corner[k] {
                    return Err(format!("grid points {} and {} both lie on corner ({}, {})", number(j), number(i), outline[k][0], outline[k][1]));
                }
                at_corner[k] = Some(i);
                corner_of[i] = Some(k);
                placed.push(outline[k]);
            }
            _ => {
                if !point_in_polygon(p, outline) || super::geometry::boundary_distance(p, outline) <= snap.max(1e-12) {
                    return Err(format!(
                        "grid point {} ({}, {}) is not inside the block (grid points go on its corners or inside it, not on its edges)",
                        number(i),
                        p[0],
                        p[1]
                    ));
                }
                placed.push(p);
            }
        }
    }
    if let Some(k) = at_corner.iter().position(|c| c.is_none()) {
        return Err(format!("no grid point on the block's corner ({}, {}): every corner must be a grid point", outline[k][0], outline[k][1]));
    }
    // Outline first, in corner order; then the interior points in the order given.
    let mut map = vec![0u32; np];
    let mut new_points: Vec<[f64; 2]> = outline.to_vec();
    for (k, i) in at_corner.iter().enumerate() {
        map[i.expect("checked above")] = k as u32;
    }
    for i in 0..np {
        if corner_of[i].is_none() {
            map[i] = new_points.len() as u32;
            new_points.push(placed[i]);
        }
    }
    let mut out = Vec::with_capacity(zones.len());
    for (z, t) in zones.iter().enumerate() {
        if let Some(&g) = t.iter().find(|&&g| g == 0 || g as usize > np) {
            return Err(format!("zone {} names grid point {g}; there are grid points 1 to {np}", z + 1));
        }
        // Given as numbers from the last point: number g is position np − g.
        let idx = t.map(|g| map[np - g as usize]);
        let [a, b, c] = idx.map(|k| new_points[k as usize]);
        let area = 0.5 * orient(a, b, c);
        if area > 0.0 {
            return Err(format!("zone {} ({} {} {}) is given counter-clockwise; give its grid points clockwise", z + 1, t[0], t[1], t[2]));
        }
        if area == 0.0 {
            return Err(format!("zone {} ({} {} {}) has no area", z + 1, t[0], t[1], t[2]));
        }
        out.push([idx[0], idx[2], idx[1]]);
    }
    let mesh = Mesh { points: new_points, boundary: outline.len(), zones: out };
    let block_area = signed_area(outline);
    let zoned: f64 = (0..mesh.zones.len()).map(|z| mesh.zone_area(z)).sum();
    if (zoned - block_area).abs() > 1e-9 * block_area {
        return Err(format!("the zones cover an area of {zoned}, the block's is {block_area}: they must cover the block once"));
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_is_two_triangles_then_split_to_amax() {
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert_eq!(triangulate(&sq).unwrap().len(), 2);
        let m = auto_mesh(&sq, 0.3).unwrap();
        assert!(m.longest_side() <= 0.3);
        let total: f64 = (0..m.zones.len()).map(|z| m.zone_area(z)).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert!((0..m.zones.len()).all(|z| m.zone_area(z) > 0.0));
    }
}
