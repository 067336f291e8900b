//! A block's shape (SL-85-1 ¶12–16): a closed surface of triangular faces, checked as it is built,
//! with its volume, centroid and inertia tensor.
//!
//! * The surface (¶12–13, Appendix B's BLOCK): the faces' vertices are merged where they
//!   coincide; every edge must be shared by exactly two faces that run along it in opposite
//!   directions (a closed, consistently oriented surface); a face of zero area is refused; the
//!   faces must be ordered counter-clockwise looking along the outward normal, so that the
//!   enclosed volume is positive. Each failure is an input error naming the face and its line.
//! * Volume (¶14, eqs. 1–5) by the divergence theorem: the sum of the signed tetrahedra each
//!   face makes with a reference point (the report's origin; here the mean of the vertices, which
//!   keeps the sums well conditioned far from the origin).
//! * Centroid (¶15, eqs. 6–7): the volume-weighted mean of those tetrahedra's centroids.
//! * Inertia (¶16): the report took ½ r̄² m about every axis; here the exact tensor, from the
//!   second moment of each signed tetrahedron, ∫ x xᵀ dV = V/20 (Σ vᵢvᵢᵀ + (Σ vᵢ)(Σ vᵢ)ᵀ) over its
//!   four vertices, shifted to the centroid (parallel axes) and turned into I = tr(C)·1 − C.
//!
//! Internally a face is stored with its vertices counter-clockwise seen from outside (the
//! right-hand rule gives the outward normal): the deck's order (counter-clockwise looking along
//! the outward normal, i.e. seen from inside) with its second and third vertices swapped.

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

/// What is wrong with a surface, and which face (1-based, in the order typed) shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceError {
    /// The face (1-based) the message is about; None where it is about the surface as a whole.
    pub face: Option<usize>,
    pub message: String,
}

/// One edge of the surface: its two vertices (`a` → `b` as face `left` runs along it), the face on
/// either side, and whether it is a feature of the block (the faces on either side not coplanar).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Edge {
    pub a: u32,
    pub b: u32,
    pub left: u32,
    pub right: u32,
    /// A real edge of the polyhedron; false for the diagonal of a planar face cut in triangles.
    pub feature: bool,
}

/// A block's shape in its own frame: vertices relative to the centroid, in the axes the block had
/// when built (its orientation is then the identity).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Shape {
    /// Vertices relative to the centroid (reference frame).
    pub vertices: Vec<DVec3>,
    /// Faces, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
    /// The faces across each face's edges (v0→v1, v1→v2, v2→v0): the report's KFP1–KFP3.
    pub neighbours: Vec<[u32; 3]>,
    /// Unit outward normals of the faces (reference frame).
    pub normals: Vec<DVec3>,
    pub edges: Vec<Edge>,
    /// One face for each distinct outward normal (a planar side cut in triangles counts once):
    /// the face axes the common plane tries.
    pub planes: Vec<u32>,
    /// One feature edge for each distinct direction (parallel edges count once): the edge axes
    /// the common plane crosses.
    pub edge_directions: Vec<u32>,
    /// Whether the block is convex (every vertex on or behind every face's plane).
    pub convex: bool,
    /// The largest distance from the centroid to a vertex.
    pub radius: f64,
    /// The radius of a ball about the mean of the vertices that lies inside the block: the least
    /// distance from that point to a face plane (for a convex block, or a concave one whose
    /// faces all see the point). Where the point lies behind some face's plane, minus the
    /// largest distance from it to a vertex instead, so that in either case the support of the
    /// block along any unit n is at least n·(mean) + `inradius` (the common plane's bound,
    /// `contact::common_plane_with`). Computed from the rest of the shape, not saved
    /// (`Shape::with_inradius`; RESTART computes it afresh), so the save format is unchanged.
    #[serde(skip)]
    pub inradius: f64,
}

impl Shape {
    /// The shape with its [`Shape::inradius`] computed from its vertices, faces and normals.
    pub fn with_inradius(mut self) -> Shape {
        self.inradius = self.compute_inradius();
        self
    }

    /// [`Shape::inradius`] of this shape.
    pub fn compute_inradius(&self) -> f64 {
        let n = self.vertices.len().max(1) as f64;
        let mean = self.vertices.iter().copied().sum::<DVec3>() / n;
        let inside = self.faces.iter().zip(&self.normals).map(|(f, nf)| nf.dot(self.vertices[f[0] as usize] - mean)).fold(f64::INFINITY, f64::min);
        if inside > 0.0 && inside.is_finite() {
            inside
        } else {
            -self.vertices.iter().map(|v| (*v - mean).length()).fold(0.0, f64::max)
        }
    }
}

/// Mass properties of a closed surface, per unit density: volume, centroid and the inertia tensor
/// per unit density about the centroid (global axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProperties {
    pub volume: f64,
    pub centroid: DVec3,
    /// ∫ (|r|²·1 − r rᵀ) dV about the centroid: the inertia tensor divided by the density.
    pub inertia: DMat3,
}

/// Volume, centroid and exact inertia of the closed surface `faces` (counter-clockwise from
/// outside) over `vertices`, by the divergence theorem (¶14–16).
pub fn mass_properties(vertices: &[DVec3], faces: &[[u32; 3]]) -> MassProperties {
    let reference = vertices.iter().copied().sum::<DVec3>() / vertices.len().max(1) as f64;
    let mut volume = 0.0;
    let mut first = DVec3::ZERO;
    let mut second = DMat3::ZERO;
    for f in faces {
        let [a, b, c] = f.map(|k| vertices[k as usize] - reference);
        // Eq. (5): the signed tetrahedron (reference, a, b, c).
        let v = a.dot(b.cross(c)) / 6.0;
        volume += v;
        // Eq. (7): its centroid is (a + b + c)/4 from the reference.
        first += v * (a + b + c) / 4.0;
        // ∫ x xᵀ dV over the tetrahedron (the reference vertex is 0).
        let s = a + b + c;
        let outer = |p: DVec3| DMat3::from_cols(p * p.x, p * p.y, p * p.z);
        second += (outer(a) + outer(b) + outer(c) + outer(s)) * (v / 20.0);
    }
    let c = if volume != 0.0 { first / volume } else { DVec3::ZERO };
    // Parallel axes: the second moment about the centroid.
    let outer_c = DMat3::from_cols(c * c.x, c * c.y, c * c.z);
    let about_c = second - outer_c * volume;
    let trace = about_c.x_axis.x + about_c.y_axis.y + about_c.z_axis.z;
    let inertia = DMat3::from_diagonal(DVec3::splat(trace)) - about_c;
    MassProperties { volume, centroid: reference + c, inertia }
}

/// Builds and checks a block's surface from faces typed as the deck gives them (each three
/// vertices counter-clockwise looking along the outward normal). Returns the shape (in the
/// reference frame, about its centroid), the centroid and the mass properties per unit density.
pub fn shape_from_faces(typed: &[[[f64; 3]; 3]]) -> Result<(Shape, MassProperties), SurfaceError> {
    let err = |face: usize, message: String| SurfaceError { face: Some(face + 1), message };
    let whole = |message: &str| SurfaceError { face: None, message: message.into() };
    // The block's size, for the tolerances.
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for f in typed {
        for v in f {
            let p = DVec3::from_array(*v);
            if !p.is_finite() {
                return Err(err(typed.iter().position(|g| g == f).unwrap_or(0), "a vertex coordinate is not a finite number".into()));
            }
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let size = (hi - lo).max_element();
    if size.is_nan() || size <= 0.0 {
        return Err(whole("all the vertices coincide: the block has no size"));
    }
    let merge = 1e-9 * size;

    // Merge coincident vertices; faces as indices, stored counter-clockwise seen from outside.
    let mut vertices: Vec<DVec3> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::with_capacity(typed.len());
    for f in typed {
        let mut idx = [0u32; 3];
        for (k, v) in f.iter().enumerate() {
            let p = DVec3::from_array(*v);
            let i = match vertices.iter().position(|q| (*q - p).abs().max_element() <= merge) {
                Some(i) => i,
                None => {
                    vertices.push(p);
                    vertices.len() - 1
                }
            };
            idx[k] = i as u32;
        }
        faces.push([idx[0], idx[2], idx[1]]);
    }
    shape_from_mesh(vertices, faces, size)
}

/// A surface bent by less than `FLAT` times its size counts as flat: a block is convex where no
/// vertex stands in front of a face's plane by more (`Shape::convex`), and only bends past it are
/// reflex edges to cut a concave block along (`d3::decompose`). Typed coordinates carry a few
/// digits: a box turned and typed to nine digits has faces split into triangles bent by ~10⁻⁹ of
/// its size, and it is a box, not a concave block of two parts. Contact geometry that takes such a
/// surface as convex errs by at most this much, far under the contact tolerance (2 % of the
/// smallest block's radius).
pub const FLAT: f64 = 1e-6;

/// Builds and checks a surface given as merged vertices and faces counter-clockwise seen from
/// outside (the rest of [`shape_from_faces`]; a concave block's convex parts are built by it,
/// `d3::decompose`). `size` is the extent the tolerances scale with; the errors' face numbers
/// are 1-based positions in `faces`.
pub fn shape_from_mesh(vertices: Vec<DVec3>, faces: Vec<[u32; 3]>, size: f64) -> Result<(Shape, MassProperties), SurfaceError> {
    let err = |face: usize, message: String| SurfaceError { face: Some(face + 1), message };
    let whole = |message: &str| SurfaceError { face: None, message: message.into() };

    // Degenerate faces: coincident or collinear vertices.
    let mut normals = Vec::with_capacity(faces.len());
    for (k, f) in faces.iter().enumerate() {
        let [a, b, c] = f.map(|i| vertices[i as usize]);
        let n = (b - a).cross(c - a);
        if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || n.length() <= 1e-12 * size * size {
            return Err(err(k, "the face is degenerate: its vertices coincide or lie on one line (zero area)".into()));
        }
        normals.push(n.normalize());
    }

    // Edges: each must be run along by exactly two faces, in opposite directions.
    let mut directed: rustc_hash::FxHashMap<(u32, u32), u32> = rustc_hash::FxHashMap::default();
    let show = |i: u32| {
        let p = vertices[i as usize];
        format!("({}, {}, {})", p.x, p.y, p.z)
    };
    for (k, f) in faces.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (f[e], f[(e + 1) % 3]);
            if let Some(&other) = directed.get(&(a, b)) {
                let both = directed.contains_key(&(b, a));
                let message = if both {
                    format!(
                        "the edge from {} to {} is shared by more than two faces (face {} and others): the surface must be a simple closed one",
                        show(a),
                        show(b),
                        other + 1
                    )
                } else {
                    format!(
                        "the face is ordered the other way round from face {} (they share the edge from {} to {} and run along it in the same direction): \
                         the vertices of every face must be counter-clockwise looking along the outward normal",
                        other + 1,
                        show(b),
                        show(a)
                    )
                };
                return Err(err(k, message));
            }
            directed.insert((a, b), k as u32);
        }
    }
    let mut neighbours = vec![[0u32; 3]; faces.len()];
    let mut edges = Vec::with_capacity(faces.len() * 3 / 2);
    for (k, f) in faces.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (f[e], f[(e + 1) % 3]);
            let Some(&other) = directed.get(&(b, a)) else {
                return Err(err(k, format!("the surface is not closed: the edge from {} to {} of this face is on no other face", show(b), show(a))));
            };
            neighbours[k][e] = other;
            if (k as u32) < other {
                let feature = normals[k].dot(normals[other as usize]) < 1.0 - 1e-9;
                edges.push(Edge { a, b, left: k as u32, right: other, feature });
            }
        }
    }

    let props = mass_properties(&vertices, &faces);
    if props.volume.is_nan() || props.volume <= 0.0 {
        return Err(whole(
            "the faces are ordered clockwise looking along the outward normal (the surface encloses a negative volume): \
             give each face's vertices counter-clockwise looking along the outward normal (from inside the block)",
        ));
    }
    if props.volume <= 1e-12 * size * size * size {
        return Err(whole("the surface encloses no volume (its faces are flat on one another)"));
    }
    let local: Vec<DVec3> = vertices.iter().map(|v| *v - props.centroid).collect();
    let convex = faces.iter().zip(&normals).all(|(f, n)| {
        let p = local[f[0] as usize];
        local.iter().all(|v| n.dot(*v - p) <= FLAT * size)
    });
    let radius = local.iter().map(|v| v.length()).fold(0.0, f64::max);
    let same = 1.0 - 1e-9;
    let mut planes: Vec<u32> = Vec::new();
    for (k, n) in normals.iter().enumerate() {
        if !planes.iter().any(|&p| normals[p as usize].dot(*n) > same) {
            planes.push(k as u32);
        }
    }
    let direction = |e: &Edge| (vertices[e.b as usize] - vertices[e.a as usize]).normalize();
    let mut edge_directions: Vec<u32> = Vec::new();
    for (k, e) in edges.iter().enumerate().filter(|(_, e)| e.feature) {
        let d = direction(e);
        if !edge_directions.iter().any(|&j| direction(&edges[j as usize]).dot(d).abs() > same) {
            edge_directions.push(k as u32);
        }
    }
    Ok((Shape { vertices: local, faces, neighbours, normals, edges, planes, edge_directions, convex, radius, inradius: 0.0 }.with_inradius(), props))
}

/// The twelve faces of the box `[x1,x2]×[y1,y2]×[z1,z2]`, as a deck would type them (each
/// counter-clockwise looking along the outward normal): two triangles per side.
pub fn box_faces(min: [f64; 3], max: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
    let p = |i: usize| [if i & 1 == 0 { min[0] } else { max[0] }, if i & 2 == 0 { min[1] } else { max[1] }, if i & 4 == 0 { min[2] } else { max[2] }];
    // Each side as four corners counter-clockwise seen from outside.
    let sides: [[usize; 4]; 6] = [
        [0, 2, 3, 1], // z = z1 (normal −z)
        [4, 5, 7, 6], // z = z2 (+z)
        [0, 1, 5, 4], // y = y1 (−y)
        [2, 6, 7, 3], // y = y2 (+y)
        [0, 4, 6, 2], // x = x1 (−x)
        [1, 3, 7, 5], // x = x2 (+x)
    ];
    let mut out = Vec::with_capacity(12);
    for s in sides {
        // Counter-clockwise from outside (a, b, c) is typed (a, c, b).
        out.push([p(s[0]), p(s[2]), p(s[1])]);
        out.push([p(s[0]), p(s[3]), p(s[2])]);
    }
    out
}

/// The least eigenvalue of a symmetric 3 × 3 matrix (the least principal moment of inertia), by
/// the trigonometric solution of its characteristic cubic.
pub fn least_eigenvalue(m: DMat3) -> f64 {
    principal_moments(m)[0]
}

/// The eigenvalues of a symmetric 3 × 3 matrix, ascending (Smith's closed form).
pub fn principal_moments(m: DMat3) -> [f64; 3] {
    let (a11, a22, a33) = (m.x_axis.x, m.y_axis.y, m.z_axis.z);
    let (a12, a13, a23) = (m.y_axis.x, m.z_axis.x, m.z_axis.y);
    let p1 = a12 * a12 + a13 * a13 + a23 * a23;
    let mut e = if p1 <= 1e-30 * (a11 * a11 + a22 * a22 + a33 * a33) {
        [a11, a22, a33]
    } else {
        let q = (a11 + a22 + a33) / 3.0;
        let p2 = (a11 - q).powi(2) + (a22 - q).powi(2) + (a33 - q).powi(2) + 2.0 * p1;
        let p = (p2 / 6.0).sqrt();
        let b = (m - DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
        let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
        let phi = r.acos() / 3.0;
        let e1 = q + 2.0 * p * phi.cos();
        let e3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
        [e3, 3.0 * q - e1 - e3, e1]
    };
    e.sort_by(f64::total_cmp);
    e
}

/// The inverse of an inertia tensor `i` (symmetric positive definite, so no entry larger than
/// the largest on its diagonal), None where it is singular. Where the determinant, the cube of
/// the tensor's scale, overflows or underflows f64 (a block of inertia past ~1e102 kg·m², made of
/// a density of 1e300, or below ~1e-102), the tensor is inverted at unit scale and scaled back:
/// glam's inverse of it was NaN (its adjugate over an infinite determinant), and so was the
/// block's angular velocity, even at rest (found by tests/suite/d3_random_decks.rs). Within that
/// range it is glam's inverse, bit for bit.
pub fn inertia_inverse(i: DMat3) -> Option<DMat3> {
    let det = i.determinant();
    if det.is_finite() && det >= f64::MIN_POSITIVE {
        return Some(i.inverse());
    }
    let scale = i.x_axis.x.abs().max(i.y_axis.y.abs()).max(i.z_axis.z.abs());
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    let unit = i * (1.0 / scale);
    (unit.determinant() > 0.0).then(|| unit.inverse() * (1.0 / scale))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_cube_is_closed_and_convex() {
        let (shape, props) = shape_from_faces(&box_faces([0.0; 3], [1.0; 3])).unwrap();
        assert_eq!(shape.vertices.len(), 8);
        assert_eq!(shape.edges.len(), 18);
        assert_eq!(shape.edges.iter().filter(|e| e.feature).count(), 12);
        assert!(shape.convex);
        assert!((props.volume - 1.0).abs() < 1e-14);
    }
}
