//! Contact geometry and mechanics between two convex polyhedral blocks (SL-85-1 ¶18–24, ¶32,
//! ¶35a and c).
//!
//! # The common plane and the physical category
//!
//! Two convex blocks either have a separating plane or overlap. Of the candidate directions (the
//! face normals of either block and the cross products of a feature edge of each: the separating
//! axis theorem's complete set for convex polyhedra) the one of greatest separation
//! s = min over block 2 of n·x − max over block 1 of n·x is the **common-plane normal** n, from
//! block 1 to block 2; s > 0 is their distance along it, s < 0 their overlap. The features of each
//! block within the contact tolerance of the plane (one vertex, two: an edge, three or more: a
//! face) give the physical category of ¶24, one of six (face–face, face–edge, face–vertex,
//! edge–edge, edge–vertex, vertex–vertex).
//!
//! # Logical contacts
//!
//! The touching features, projected on the common plane, are a point, a segment or a convex
//! polygon each; their intersection is the contact's region, whose corners are the logical
//! contacts of ¶24 and ¶32: a **vertex–face** contact where a vertex of one block lies over the
//! other's touching feature, an **edge–edge** contact where an edge of each cross. A face–face
//! contact thus has a logical contact at every corner of its overlap polygon and carries the
//! moment of its area (¶35c), as UDEC's edge–edge contact does with its two corner–edge contacts;
//! a vertex–face contact has one. Each logical contact's gap is measured along n exactly: the line
//! through its point along n leaves block 1 and enters block 2 at distances found from their face
//! planes (convex blocks), so that a contact point's gap is right however the features lie.
//! Logical contacts are keyed by their blocks' vertex numbers, so their shear force survives the
//! re-detection each cycle.
//!
//! # The report's normal prescription (¶23) and why the common plane is the default
//!
//! [`prescribed_normal`] is ¶23's rule: the faces around the vertex of the block nearest the
//! contact point, their normals averaged with weights 1/d. `tests/suite/d3_contacts.rs` compares it with
//! the common plane, as ¶35a asks. It agrees for a vertex pressed into the middle of a face, and
//! fails (1) for an edge–edge contact, where the true normal is the cross product of the two
//! edges and the prescription gives a mean of face normals of one block, off by up to half the
//! dihedral angle, so that two crossing edges slide apart along a wrong direction; (2) for a
//! point near the middle of a long face whose nearest vertex carries steep side faces, which then
//! tilt the normal by an amount that depends on the penetration; and (3) on a face cut in
//! triangles, whose normals it counts as many times as there are triangles at the vertex. The
//! common plane has none of these faults and is the same for both blocks (the prescription of
//! block 1 and that of block 2 differ), so it is the normal used here.
//!
//! # The force–displacement law (¶18, eqs. 13–20)
//!
//! For each logical contact: the relative velocity of block 2's point over block 1's (eq. 13),
//! split into normal and shear parts (eqs. 14–15). The normal force is eq. (16) integrated
//! exactly, Fn = −kn·gap (compression positive; the gap is known), as in 2D. The shear force is
//! stepped, ΔFs = −ks u̇s Δt, after turning the previous shear force with the normal (eq. 17's
//! second term; here as an exact rotation into the new plane, its magnitude kept, rather than the
//! small-angle cross product). Coulomb's limit with cohesion (eq. 20): |Fs| ≤ c + μFn. A contact
//! that opens (gap > 0) carries nothing. The force acts on block 2, its opposite on block 1, with
//! eq. (12)'s moments about their centroids. Stiffness-proportional damping (β) adds dashpots
//! β·k on the relative velocity, not stored, as in 2D.

use glam::{DVec2, DVec3};
use smallvec::SmallVec;

use super::model::{Block, Body, Contact, Feature, Logical, LogicalKind, Material};

/// A short list kept on the stack: a block's plane normals and edge directions, made for every
/// block every cycle ([`Placement`]), and a heap list each would cost more in malloc and free
/// than the turning. Longer lists (blocks of many faces) spill to the heap. (The lists stage 4
/// builds per contact live in [`Scratch`], kept from contact to contact.)
type Few<T> = SmallVec<[T; 8]>;

/// The outward normals of a block's face planes (`Shape::planes`, in that order) in global axes,
/// turned once for a contact's stage 4 rather than at each of the common plane's axes and each
/// logical contact's ray crossings.
pub type PlaneNormals = Few<DVec3>;

/// [`PlaneNormals`] of `block` (a convex block, or a part of a concave one).
pub fn plane_normals(block: Body) -> PlaneNormals {
    let mut normals = PlaneNormals::new();
    turn_planes(block, &mut normals);
    normals
}

/// Appends [`PlaneNormals`] of `block` to `normals`.
fn turn_planes(block: Body, normals: &mut PlaneNormals) {
    let planes = block.shape.planes.iter().map(|&f| block.shape.normals[f as usize]);
    match block.normal_map() {
        // A simply-deformable block's stretch inverted once for all its planes.
        Some(m) => normals.extend(planes.map(|n| (m * n).normalize())),
        None => normals.extend(planes.map(|n| block.block.orientation * n)),
    }
}

/// A body as stage 4 reads it: its vertices, its [`PlaneNormals`], its feature edges'
/// directions ([`edge_directions`]), its box ([`Body::bounds`]) and its inner ball
/// ([`Body::inner_ball`]). The contact stage works these out once a cycle
/// for each body ([`Placement`]) rather than at each of its contacts (a block of a wall has six
/// to ten).
#[derive(Clone, Copy, Debug)]
pub struct Placed<'a> {
    pub body: Body<'a>,
    pub normals: &'a [DVec3],
    pub edges: &'a [DVec3],
    pub bounds: (DVec3, DVec3),
    pub ball: (DVec3, f64),
}

impl<'a> Placed<'a> {
    /// `body` placed, given its [`PlaneNormals`] and [`edge_directions`].
    pub fn new(body: Body<'a>, normals: &'a [DVec3], edges: &'a [DVec3]) -> Placed<'a> {
        Placed { body, normals, edges, bounds: body.bounds(), ball: body.inner_ball() }
    }
}

/// A body with its [`PlaneNormals`] and [`edge_directions`] turned on their own, outside a
/// cycle's [`Placement`] (the Block-level wrappers, the GPU stage's Rust twin, tests).
pub struct Turned<'a> {
    body: Body<'a>,
    normals: PlaneNormals,
    edges: PlaneNormals,
}

impl<'a> Turned<'a> {
    /// `body`'s normals and edges as its vertices lie now.
    pub fn of(body: Body<'a>) -> Turned<'a> {
        Turned { body, normals: plane_normals(body), edges: edge_directions(body) }
    }

    /// The body as [`Placed`].
    pub fn placed(&self) -> Placed<'_> {
        Placed::new(self.body, &self.normals, &self.edges)
    }
}

/// The directions of a body's feature edges (`Shape::edge_directions`, in that order), from
/// its vertices as placed: end minus start of each.
pub fn edge_directions(block: Body) -> PlaneNormals {
    let mut edges = PlaneNormals::new();
    turn_edges(block, &mut edges);
    edges
}

/// Appends [`edge_directions`] of `block` to `edges`.
fn turn_edges(block: Body, edges: &mut PlaneNormals) {
    edges.extend(block.shape.edge_directions.iter().map(|&i| {
        let e = block.shape.edges[i as usize];
        block.vertices[e.b as usize] - block.vertices[e.a as usize]
    }));
}

/// Each body of a block ([`Block::body`]) as [`Placed`] this cycle: worked out once per block,
/// in parallel over the blocks, before the contacts read them.
#[derive(Default)]
pub struct Placement {
    /// The plane normals of its bodies, one body after another.
    normals: PlaneNormals,
    /// Their edge directions, one body after another.
    edges: PlaneNormals,
    bodies: SmallVec<[BodyPlacement; 1]>,
}

/// A body's part of a [`Placement`].
#[derive(Clone, Copy)]
struct BodyPlacement {
    /// Its first plane normal in `Placement::normals` and first edge in `Placement::edges`.
    planes: usize,
    edges: usize,
    bounds: (DVec3, DVec3),
    ball: (DVec3, f64),
}

impl Placement {
    /// The placement of `block`'s bodies as its vertices lie now.
    pub fn of(block: &Block) -> Placement {
        let mut placement = Placement::default();
        placement.renew(block);
        placement
    }

    /// Makes this the placement of `block` as its vertices lie now, in place (the cycle keeps
    /// its placements from cycle to cycle: a placement is some hundreds of bytes, and building
    /// each afresh moved them twice).
    pub fn renew(&mut self, block: &Block) {
        let Placement { normals, edges, bodies } = self;
        normals.clear();
        edges.clear();
        bodies.clear();
        for k in 0..block.part_count() as u32 {
            let body = block.body(k);
            bodies.push(BodyPlacement { planes: normals.len(), edges: edges.len(), bounds: body.bounds(), ball: body.inner_ball() });
            turn_planes(body, normals);
            turn_edges(body, edges);
        }
    }

    /// Body `k` of `block`, the block this is the placement of.
    pub fn placed<'a>(&'a self, block: &'a Block, k: u32) -> Placed<'a> {
        let body = block.body(k);
        let at = self.bodies[(k as usize).min(self.bodies.len() - 1)];
        Placed {
            body,
            normals: &self.normals[at.planes..at.planes + body.shape.planes.len()],
            edges: &self.edges[at.edges..at.edges + body.shape.edge_directions.len()],
            bounds: at.bounds,
            ball: at.ball,
        }
    }
}

/// The common plane of two blocks and the features of each that touch it.
#[derive(Clone, Debug, PartialEq)]
pub struct CommonPlane {
    /// Unit normal from block 1 to block 2.
    pub normal: DVec3,
    /// Their separation along it (negative: overlap).
    pub separation: f64,
    /// Block 1's greatest projection on the normal and block 2's least (their supports; the
    /// separation is the second less the first), kept for the logical contacts.
    pub supports: (f64, f64),
}

/// The common plane of convex blocks `a` and `b` (the separating axis of greatest separation).
///
/// Face normals and edge–edge cross products find the least penetration of two convex blocks
/// that overlap, and a separating plane of two that do not; but two blocks apart whose nearest
/// features are a vertex and an edge, or two vertices, are further apart than any of those axes
/// shows. So where the blocks are apart by no more than `reach` (the contact-forming distance)
/// the directions from each vertex to the nearest point of each feature edge of the other block,
/// and between vertices, are tried too (not where a vertex of one block at the plane lies over
/// a face of the other: the face's axis is their distance then, `face_meets`): the separation
/// is then the blocks' distance, and the
/// normal the direction between their nearest features (an edge–vertex or vertex–vertex contact
/// about to touch is recognised as such). Once they overlap, a vertex pressed into an edge's
/// wedge takes the normal of the face it is nearer to leaving through (the least penetration).
pub fn common_plane(a: &Block, b: &Block, reach: f64) -> CommonPlane {
    common_plane_of(Body::from(a), Body::from(b), reach, None)
}

/// [`common_plane_with`] of two bodies not placed in a cycle's [`Placement`]: their normals and
/// edges turned here ([`Turned`]).
pub fn common_plane_of(a: Body, b: Body, reach: f64, hint: Option<DVec3>) -> CommonPlane {
    common_plane_with(&Turned::of(a).placed(), &Turned::of(b).placed(), reach, hint)
}

/// [`common_plane`] of two convex bodies (blocks, or parts of concave ones) as [`Placed`]. `hint`: a unit vector likely near the answer
/// (the contact's normal of the last cycle), which makes the search cheaper, never different.
///
/// # Which axes are worked out
///
/// Most of a candidate axis's cost is its projections, a dot product for every vertex of both
/// bodies; but its separation s(n) has a cheap bound. Each body holds a ball about the mean p
/// of its vertices ([`Body::inner_ball`], radius r), so its least projection along n is at most
/// n·p_b − r_b and its greatest at least n·p_a + r_a:
///
///   s(n) ≤ n·(p_b − p_a) − (r_a + r_b).
///
/// An axis whose bound lies below the best separation found so far cannot win and is passed
/// over. The hint sharpens that: the separation along any unit direction is at most the
/// greatest over the candidates where the bodies overlap (the separating axis theorem's set is
/// complete), and the bodies apart have a candidate with s > 0; so s(hint), or 0 where that is
/// greater, is a floor under the answer, and an axis whose bound lies under it is passed over
/// from the start. Passing over is exact: the axes are still offered in their order, and the
/// ones passed over lie below the floor by a margin (`margin`: twice the slack of a near tie,
/// and the round-off of its comparison, times the number of axes, plus the round-off of the
/// projections at the bodies' distance from the origin) that no run of near ties accepted in their place can climb once an axis at
/// the floor is offered, so the axis found, and its separation, are those of the full search
/// bit for bit (where no axis reaches the floor, the search is made again without it). On settled blocks
/// (the hint the last cycle's answer, a face–face contact between cubes) about four axes of
/// thirty are worked out.
pub fn common_plane_with(a: &Placed, b: &Placed, reach: f64, hint: Option<DVec3>) -> CommonPlane {
    let (placed_a, placed_b) = (a, b);
    let (na, nb) = (a.normals, b.normals);
    let (edges_a, edges_b) = (a.edges, b.edges);
    let ((pa, ra), (pb, rb)) = (a.ball, b.ball);
    let (a, b) = (a.body, b.body);
    let sep = |n: DVec3| -> f64 { least(b.vertices, n) - greatest(a.vertices, n) };
    let slack = 1e-12 * (a.shape.radius + b.shape.radius);
    // An axis and the supports along it (block 1's greatest projection, block 2's least).
    // Whether it is taken (the best so far by more than the slack of a near tie).
    let offer = |best: &mut CommonPlane, n: DVec3, (hi_a, lo_b): (f64, f64)| -> bool {
        let s = lo_b - hi_a;
        let taken = s > best.separation + slack;
        if taken {
            *best = CommonPlane { normal: n, separation: s, supports: (hi_a, lo_b) };
        }
        taken
    };
    let consider = |best: &mut CommonPlane, n: DVec3| offer(best, n, (greatest(a.vertices, n), least(b.vertices, n)));
    // The bound on each axis's separation (see above): s(n) ≤ n·d − r.
    let (d, r) = (pb - pa, ra + rb);
    let axes = na.len() + nb.len() + 2 * a.shape.edge_directions.len() * b.shape.edge_directions.len();
    let size = pa.length() + pb.length() + a.shape.radius + b.shape.radius;
    let margin = 2.0 * (axes + 2) as f64 * (slack + f64::EPSILON * size) + 4e-14 * size;
    // The axes in their order, those whose bound lies under `floor` or under the best found so
    // far (less the margin) passed over.
    // Which axis it was, as well: a face plane of a body, or an edge pair.
    let search = |floor: f64| -> (CommonPlane, Axis) {
        let mut best = CommonPlane { normal: DVec3::Z, separation: f64::NEG_INFINITY, supports: (f64::INFINITY, f64::NEG_INFINITY) };
        let mut axis = Axis::Edges;
        let open = |best: &CommonPlane, bound: f64| bound >= floor.max(best.separation - margin);
        for (k, &n) in na.iter().enumerate() {
            if open(&best, n.dot(d) - r) && consider(&mut best, n) {
                axis = Axis::FaceA(k);
            }
        }
        for (k, &n) in nb.iter().enumerate() {
            if open(&best, -n.dot(d) - r) && consider(&mut best, -n) {
                axis = Axis::FaceB(k);
            }
        }
        for &da in edges_a {
            for &db in edges_b {
                let c = da.cross(db);
                if c.length_squared() <= 1e-12 * da.length_squared() * db.length_squared() {
                    continue;
                }
                // Both senses of the axis from one set of projections: along −n every
                // projection is exactly the negative of its value along n, so the support of
                // one block along −n is minus its least projection along n, bit for bit.
                let n = c.normalize();
                if !open(&best, n.dot(d).abs() - r) {
                    continue;
                }
                let (lo_a, hi_a) = extent(a.vertices, n);
                let (lo_b, hi_b) = extent(b.vertices, n);
                // (Both offered: `|` rather than `||`.)
                if offer(&mut best, n, (hi_a, lo_b)) | offer(&mut best, -n, (-lo_a, -hi_b)) {
                    axis = Axis::Edges;
                }
            }
        }
        (best, axis)
    };
    let (mut best, axis) = match hint {
        Some(h) => {
            let floor = sep(h).min(0.0) - margin;
            let found = search(floor);
            // The floor holds only where an axis reaches it: one of two nearly parallel edges
            // (passed over above) may be what the hint was near. Then the full search.
            if found.0.separation >= floor + 0.5 * margin {
                found
            } else {
                search(f64::NEG_INFINITY)
            }
        }
        None => search(f64::NEG_INFINITY),
    };
    if best.separation > 0.0 && best.separation <= reach && !face_meets(placed_a, placed_b, &best, axis, 0.25 * slack) {
        // The nearest pair of a vertex and a vertex or feature edge of the other block, among
        // those that can be within `reach` (near the plane found so far): its direction's
        // separation is the blocks' distance where those are their nearest features, and less
        // than what the axes above found otherwise.
        let (n, (hi_a, lo_b)) = (best.normal, best.supports);
        // Which vertices of each block lie near the plane, decided once each (a projection a
        // vertex; the loops below ask of each vertex many times).
        let near_a: SmallVec<[bool; 64]> = a.vertices.iter().map(|v| n.dot(*v) >= hi_a - reach).collect();
        let near_b: SmallVec<[bool; 64]> = b.vertices.iter().map(|v| n.dot(*v) <= lo_b + reach).collect();
        let mut nearest: Option<(f64, DVec3)> = None;
        let mut offer = |d: DVec3| {
            let l = d.length_squared();
            if l > 0.0 && nearest.is_none_or(|(m, _)| l < m) {
                nearest = Some((l, d));
            }
        };
        for (from, to, sign, near_from, near_to) in [(&a, &b, 1.0, &near_a, &near_b), (&b, &a, -1.0, &near_b, &near_a)] {
            for e in from.shape.edges.iter().filter(|e| e.feature) {
                if !near_from[e.a as usize] && !near_from[e.b as usize] {
                    continue;
                }
                let (p, q) = (from.vertices[e.a as usize], from.vertices[e.b as usize]);
                let d = q - p;
                for (v, _) in to.vertices.iter().zip(near_to.iter()).filter(|(_, near)| **near) {
                    let t = ((*v - p).dot(d) / d.length_squared()).clamp(0.0, 1.0);
                    offer((*v - (p + d * t)) * sign);
                }
            }
        }
        for (va, _) in a.vertices.iter().zip(near_a.iter()).filter(|(_, near)| **near) {
            for (vb, _) in b.vertices.iter().zip(near_b.iter()).filter(|(_, near)| **near) {
                offer(*vb - *va);
            }
        }
        if let Some((_, d)) = nearest {
            consider(&mut best, d.normalize());
        }
    }
    best
}

/// The axis a common plane was found on ([`common_plane_with`]'s search).
#[derive(Clone, Copy)]
enum Axis {
    /// Block 1's face plane of that number (its [`PlaneNormals`]' order).
    FaceA(usize),
    /// Block 2's, reversed.
    FaceB(usize),
    /// The cross product of two edges' directions.
    Edges,
}

/// Whether the separation `plane` found on a face plane's axis is the bodies' distance, to
/// within `within`: some vertex of the other body at the support (within `within` of it),
/// moved along the normal onto the face's plane, lands in the face's body (behind all its
/// other planes; a convex body is the meet of its planes' half-spaces). That point and the
/// vertex are then `separation` (+ `within`) apart, and no direction separates the bodies by
/// more than any pair of their points is apart: no nearest pair of vertex and edge can give a
/// greater separation, and [`common_plane_with`] need not look for one (where the columns of a
/// stack rock and hop, nearly half the contacts of a cycle are apart by a little, face on face).
/// False for an edge pair's axis, or where no vertex lands inside. `a` and `b` are the two
/// bodies as placed (block 1's and block 2's, as [`common_plane_with`] takes them). (WGSL twin:
/// `face_meets` in `track_contact.wgsl`.)
fn face_meets(a: &Placed, b: &Placed, plane: &CommonPlane, axis: Axis, within: f64) -> bool {
    let (n, (hi_a, lo_b)) = (plane.normal, plane.supports);
    // The face's body, its plane's number, the other body, and the sense along n from the
    // other body towards the face.
    let (face, k, other, towards) = match axis {
        Axis::FaceA(k) => (a, k, b.body, -1.0),
        Axis::FaceB(k) => (b, k, a.body, 1.0),
        Axis::Edges => return false,
    };
    let (support, level) = if towards < 0.0 { (lo_b, hi_a) } else { (hi_a, lo_b) };
    let shape = face.body.shape;
    other.vertices.iter().any(|&w| {
        let h = n.dot(w);
        // Its distance from the support, on the far side from the face: within `within`.
        if (h - support) * -towards > within {
            return false;
        }
        let on = w + n * (level - h);
        face.normals.iter().enumerate().all(|(j, &nf)| j == k || nf.dot(on) <= nf.dot(face.body.vertices[shape.faces[shape.planes[j] as usize][0] as usize]))
    })
}

/// The least of n·x over the points `xs` (+∞ for none). A plain comparison rather than
/// `f64::min`, whose NaN handling costs two instructions more a point (there are no NaNs here:
/// the cycle stops on a non-finite position first).
#[inline]
fn least(xs: &[DVec3], n: DVec3) -> f64 {
    xs.iter().map(|x| n.dot(*x)).fold(f64::INFINITY, |m, p| if p < m { p } else { m })
}

/// The greatest of n·x over the points `xs` (−∞ for none); see [`least`].
#[inline]
fn greatest(xs: &[DVec3], n: DVec3) -> f64 {
    xs.iter().map(|x| n.dot(*x)).fold(f64::NEG_INFINITY, |m, p| if p > m { p } else { m })
}

/// The least and the greatest of n·x over the points `xs`.
#[inline]
fn extent(xs: &[DVec3], n: DVec3) -> (f64, f64) {
    xs.iter().map(|x| n.dot(*x)).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (if p < lo { p } else { lo }, if p > hi { p } else { hi }))
}

/// The face planes of a convex body that bound where a line along `n` leaves it (`entering`
/// false: those it heads out through, n·normal > `grazing`) or enters it (`entering`: those it
/// heads in through, n·normal < −`grazing`), as (outward normal, a point of the plane,
/// n·normal). Only these give [`ray_crossing`] its distance; they are sorted out once for all
/// the points of a contact (one plane of the four to ten of a block, where a face lies along
/// the contact). Only one face of each plane is tried (`Shape::planes`): the faces of a convex
/// block that share an outward normal lie in one supporting plane, so the others give the same
/// crossing. `normals`: the body's [`PlaneNormals`].
///
/// Planes far steeper to the line than the squarest facing one (|n·normal| below [`STEEP_SHARE`]
/// of the greatest) are passed over too: within the touching region the line leaves and enters
/// through the touching features' faces, which face the line most squarely, and a steep side
/// face is crossed only where the point lies on its edge, at a distance its tilt decides (the
/// point's offset from the plane, up to the hulls' tolerance, over n·normal): a corner of two
/// bricks' faces in touch, a side face tilting through parallel as the bricks rock, gave its
/// logical contact a gap that jumped by 3·10⁻⁴ m from one cycle to the next, a spring force
/// 3·10⁵ N for three cycles, and energy into the struck wall (`STEEP_SHARE`'s doc).
fn facing(block: Body, normals: &[DVec3], n: DVec3, entering: bool, grazing: f64, planes: &mut Vec<Facing>) {
    planes.clear();
    let sign = if entering { -1.0 } else { 1.0 };
    let mut squarest: f64 = 0.0;
    for (&f, &nf) in block.shape.planes.iter().zip(normals) {
        let d = nf.dot(n);
        squarest = squarest.max(sign * d);
        if sign * d > grazing {
            planes.push((nf, block.vertices[block.shape.faces[f as usize][0] as usize], d));
        }
    }
    // The steep ones out, once the squarest is known (in one pass over the normals).
    let least = STEEP_SHARE * squarest;
    if least > grazing {
        planes.retain(|&(_, _, d)| sign * d > least);
    }
}

/// The share of the squarest facing plane's n·normal below which `facing` passes a plane
/// over (the WGSL twin's STEEP_SHARE): the crossing of a plane the point lies on within a
/// distance ε is uncertain by ε / (n·normal), at most ten times the squarest plane's. The
/// touching features' own faces are kept: an edge's or a vertex's faces meet the line within a
/// factor of a few of each other, a needle's tip's all alike.
pub const STEEP_SHARE: f64 = 0.1;

/// A face plane a line crosses ([`facing`]): its outward normal, a point of it, and the line's
/// direction dotted with the normal.
type Facing = (DVec3, DVec3, f64);

/// The distance along `n` from `p` at which the line p + s·n leaves the convex block (the least
/// s over the planes it heads out through), or enters it (`entering`: the greatest s over the
/// planes it heads in through); `planes`: those of [`facing`] along `n`, the same `entering`.
/// ±∞ where there are none.
///
/// A crossing farther along the line than `reach` is passed over: the line leaves or enters a
/// body it meets near the contact within the two bodies' sizes of the mid-plane, and such a
/// crossing is a face nearly parallel to the line that the point, on the touching region's edge
/// and up to the hulls' tolerance outside it, sees from outside: n·normal of 10⁻⁸ and 10⁻⁶ of the
/// size outside put it a hundred sizes off (a crushed pile's fragments had logical contacts 79 m
/// from their 0.5 m blocks, an open gap, and a lever arm that cut the critical step 20-fold).
fn ray_crossing(planes: &[Facing], p: DVec3, entering: bool, reach: f64) -> f64 {
    let mut s_best = if entering { f64::NEG_INFINITY } else { f64::INFINITY };
    for &(nf, x, d) in planes {
        let s = nf.dot(x - p) / d;
        if s.abs() > reach {
            continue;
        }
        s_best = if entering { s_best.max(s) } else { s_best.min(s) };
    }
    s_best
}

/// How far along the normal from the mid-plane a face crossing of bodies `a` and `b` may lie and
/// still count ([`ray_crossing`]'s `reach`): twice their radii together (the WGSL
/// `place_logical`'s `reach`).
fn crossing_reach(a: Body, b: Body) -> f64 {
    2.0 * (a.shape.radius + b.shape.radius)
}

/// How near parallel to the ray a face may lie and still be crossed (the cosine): the f64
/// kernels' GRAZING (`d3::gpu::shaders`).
const GRAZING: f64 = 1e-9;

/// How near parallel to a tracked contact's normal a face of a concave block's convex part may
/// lie and still be crossed ([`place_logical`], the GPU's stage 4 between detections; the
/// kernels' PART_GRAZING, `d3::gpu::shaders`): a part's cut faces run through its block's seams,
/// where a stacked concave block's logical contacts lie, and a ray crossing a cut face the
/// rocking tilts off parallel by a little lands far off the surfaces. The CPU's detection, which
/// finds the logical contacts afresh each cycle, keeps `GRAZING` (1e-9).
pub const PART_GRAZING: f64 = 1e-3;

/// Orthonormal axes (t1, t2) of the plane normal to `n`.
fn plane_axes(n: DVec3) -> (DVec3, DVec3) {
    let t1 = n.any_orthonormal_vector();
    (t1, n.cross(t1))
}

/// A touching feature projected on the common plane: its vertices (block numbers) in
/// counter-clockwise order about n, as 2D points; one (a vertex), two (an edge) or more (a face).
/// Its lists are kept from contact to contact ([`Scratch`]).
#[derive(Default)]
struct Hull {
    ids: Vec<u32>,
    pts: Vec<DVec2>,
    /// The length of each of its [`Hull::edges`], in their order ([`Hull::measure`]).
    lengths: Vec<f64>,
    /// Each of its [`Hull::edges`] as a vector, end less start ([`Hull::measure`]).
    sides: Vec<DVec2>,
}

impl Hull {
    /// Makes it the hull of the corners `chain` (position, vertex number), in their order.
    fn set(&mut self, chain: &[Projected]) {
        self.ids.clear();
        self.ids.extend(chain.iter().map(|p| p.1));
        self.pts.clear();
        self.pts.extend(chain.iter().map(|p| p.0));
    }

    fn feature(&self) -> Feature {
        match self.ids.len() {
            1 => Feature::Vertex,
            2 => Feature::Edge,
            _ => Feature::Face,
        }
    }

    /// Whether `p` lies on the feature (within `tol`), once [`Hull::measure`]d.
    fn covers(&self, p: DVec2, tol: f64) -> bool {
        let (pts, lengths) = (&self.pts[..], &self.lengths[..]);
        match pts.len() {
            1 => (p - pts[0]).length() <= tol,
            2 => segment_distance(p, pts[0], pts[1]) <= tol,
            _ => {
                // Each edge from its corner a to the next (b − a its side).
                for ((&a, side), length) in pts.iter().zip(&self.sides).zip(lengths) {
                    let inside = side.perp_dot(p - a) >= -tol * length;
                    if !inside {
                        return false;
                    }
                }
                true
            }
        }
    }

    /// Works out the length of each of its [`Hull::edges`] (once for the covering and crossing
    /// tests, which ask each many times).
    fn measure(&mut self) {
        let n = self.pts.len();
        self.lengths.clear();
        self.sides.clear();
        for i in 0..Hull::edge_count(n) {
            let side = self.pts[if i + 1 == n { 0 } else { i + 1 }] - self.pts[i];
            self.sides.push(side);
            self.lengths.push(side.length());
        }
    }

    /// How many edges a hull of `n` corners has: none for a point, one for a segment, n for a
    /// polygon.
    fn edge_count(n: usize) -> usize {
        match n {
            0 | 1 => 0,
            2 => 1,
            n => n,
        }
    }

    /// Its edges as pairs of positions in `ids`: none for a point, one for a segment, n for a
    /// polygon of n corners.
    fn edges(&self) -> impl Iterator<Item = (usize, usize)> {
        let n = self.pts.len();
        (0..Hull::edge_count(n)).map(move |i| (i, if i + 1 == n { 0 } else { i + 1 }))
    }
}

fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let t = if d.length_squared() > 0.0 { ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + d * t)).length()
}

/// A vertex projected on the common plane: its position there and its number.
type Projected = (DVec2, u32);

/// Stage 4's working lists, kept from one contact to the next (a set per worker thread, rayon's
/// `map_init`): each contact projects its touching features' vertices and chains their hulls
/// every cycle, and lists of its own (on the stack) had to be cleared first, and copied out,
/// for every one.
#[derive(Default)]
pub struct Scratch {
    pts: Vec<Projected>,
    chain: Vec<Projected>,
    /// The touching features' hulls (block 1's, block 2's).
    hulls: [Hull; 2],
    /// The touching region's corners about their mean ([`region_area`]).
    around: Vec<(f64, DVec2)>,
    /// The planes the line along the normal leaves block 1 and enters block 2 through.
    leaving: Vec<Facing>,
    entering: Vec<Facing>,
    /// The logical contacts found, on the plane.
    on_plane: Vec<(LogicalKind, DVec2)>,
    /// The logical contacts found ([`logical_contacts_with`]): kind, point, gap.
    pub found: Vec<(LogicalKind, DVec3, f64)>,
    /// The last cycle's logical contacts of the contact in hand (`cpu::update_contact`).
    pub previous: Vec<Logical>,
    /// What a logical contact found now that was not there before starts with ([`Appearing`]).
    pub appearing: Appearing,
}

/// What a logical contact found now that was not there before starts with (`cpu::update_contact`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Appearing {
    /// Its whole overlap (offset 0): the run's first detection.
    #[default]
    Overlapped,
    /// No force (its offset its gap, eq. 16 as an increment): a crack's new corners, which
    /// `cpu::crack_blocks` then gives the parent's state where it had one.
    Unloaded,
    /// A running detection (a cycle, the GPU's between batches): where a loaded logical contact
    /// of the last one went within the contact-forming distance of it, that one's forces (the
    /// same corner of the touching region under another key, [`carry_swapped`]); else none.
    Carried,
}

/// The logical contacts of a contact that appeared this cycle (those of `logical` whose keys
/// `previous` has not), in `logical`'s order, each take the forces of the nearest loaded one of
/// the last cycle's (`previous`) that is neither found again (its key in `logical`) nor taken
/// by one before it, within `reach` (the contact-forming
/// distance): their shear force and normal force, the normal force as kn times an overlap beyond
/// an offset (offset = gap + Fn/kn, kn the law the force was made under, `law`), so that either
/// law of eq. (16) goes on from it. A corner of the touching region changes its key where a
/// vertex slides off the face it pressed and the edges from it cross that face's edge (vertex–
/// face becomes edge–edge, and back), or where a crossing passes from one edge to the next;
/// taken as a new spring, unloaded, with the old one's energy let go, it cost a struck wall of
/// twenty bricks 7.6 % of the cube's energy (951 J of 12 490, nearly all of what its ledger
/// booked as released, the new corners within 1 % of the bricks' size of the old). One old
/// spring goes to at most one new one: where a vertex gives way to two crossings, one takes its
/// forces and the other starts unloaded (no spring energy is made). Returns the strain energy of
/// the last cycle's logical contacts neither found again nor carried (released).
pub fn carry_swapped(previous: &[Logical], logical: &mut [Logical], reach: f64, law: &Material) -> f64 {
    // The last cycle's found again, and those a new one took.
    let mut taken: SmallVec<[bool; 16]> = previous.iter().map(|old| logical.iter().any(|l| l.kind == old.kind)).collect();
    for l in logical.iter_mut() {
        if previous.iter().any(|old| old.kind == l.kind) {
            continue;
        }
        let mut nearest: Option<(usize, f64)> = None;
        for (k, old) in previous.iter().enumerate() {
            let d = old.point.distance(l.point);
            if !taken[k] && old.normal_force > 0.0 && d <= reach && nearest.is_none_or(|(_, e)| d < e) {
                nearest = Some((k, d));
            }
        }
        if let Some((k, _)) = nearest {
            taken[k] = true;
            let old = &previous[k];
            l.normal_force = old.normal_force;
            l.shear_force = old.shear_force;
            l.offset = if law.kn > 0.0 { l.gap + old.normal_force / law.kn } else { l.offset };
        }
    }
    previous.iter().zip(&taken).filter(|(_, &t)| !t).map(|(l, _)| spring_energy(l, law)).sum()
}

/// The order of `f64::total_cmp` as an integer's: x before y exactly where key(x) < key(y).
#[inline]
fn order_key(x: f64) -> i64 {
    let bits = x.to_bits() as i64;
    bits ^ ((((bits >> 63) as u64) >> 1) as i64)
}

/// Whether |d| > `tol` (≥ 0), as `d.length() > tol` decides it, bit for bit: a square root only
/// where |d|² lies within 4 tol² (the points of a feature are mostly far apart next to the
/// tolerance, and a square root costs as much as the rest of the test).
#[inline]
fn farther_than(d: DVec2, tol: f64) -> bool {
    let d2 = d.length_squared();
    // |d|² > 4 tol² (rounded) puts |d| past tol with room for the roundings.
    d2 > 4.0 * (tol * tol) || d2.sqrt() > tol
}

/// Sorts projected points by x, then y, in `f64::total_cmp`'s order, keeping the order of
/// equal ones: a stable sort's result is fixed by its comparison, so this is the standard
/// library's `sort_by` to the bit, by insertion for the few points of a feature.
fn sort_points(pts: &mut [Projected]) {
    let before = |p: &Projected, q: &Projected| (order_key(p.0.x), order_key(p.0.y)) < (order_key(q.0.x), order_key(q.0.y));
    if pts.len() > 16 {
        pts.sort_by(|p, q| order_key(p.0.x).cmp(&order_key(q.0.x)).then_with(|| order_key(p.0.y).cmp(&order_key(q.0.y))));
        return;
    }
    for i in 1..pts.len() {
        let p = pts[i];
        let mut j = i;
        while j > 0 && before(&p, &pts[j - 1]) {
            pts[j] = pts[j - 1];
            j -= 1;
        }
        pts[j] = p;
    }
}

/// Makes `out` the convex hull (counter-clockwise) of the projected points `pts` (sorted and
/// thinned in place; `chain` is working space); collinear points (within `tol` ≥ 0) dropped, so
/// that a line of points is its two ends.
fn hull(pts: &mut [Projected], chain: &mut Vec<Projected>, tol: f64, out: &mut Hull) {
    sort_points(pts);
    // Points within `tol` of the last one kept dropped (as `Vec::dedup_by`).
    let mut m = pts.len().min(1);
    for r in 1..pts.len() {
        if farther_than(pts[r].0 - pts[m - 1].0, tol) {
            pts[m] = pts[r];
            m += 1;
        }
    }
    let pts = &pts[..m];
    if m <= 2 {
        return out.set(pts);
    }
    // Andrew's monotone chain, dropping points within `tol` of the line of their neighbours.
    // Whether a turns by no more than `tol` off the line from o to b (its distance from the line,
    // signed): a turn to the right (a cross product ≤ 0) needs no distance worked out, as
    // tol ≥ 0, nor does a turn to the left by more than twice `tol` times a bound over |b − o|
    // (|Δx| + |Δy| ≥ |b − o|, with a margin for the roundings): the same answer, bit for bit,
    // as the division would give, without its square root and division on the chain's path.
    let straight_or_right = |o: DVec2, a: DVec2, b: DVec2| {
        let cross = (a - o).perp_dot(b - o);
        if cross <= 0.0 {
            return true;
        }
        let w = b - o;
        if cross > 2.0 * tol * ((w.x.abs() + w.y.abs()) * (1.0 + 1e-14)) {
            return false;
        }
        cross / w.length().max(f64::MIN_POSITIVE) <= tol
    };
    chain.clear();
    chain.resize(2 * m, (DVec2::ZERO, 0));
    let mut top = 0;
    for pass in 0..2 {
        let start = top;
        for i in 0..m {
            let p = if pass == 0 { pts[i] } else { pts[m - 1 - i] };
            while top >= start + 2 && straight_or_right(chain[top - 2].0, chain[top - 1].0, p.0) {
                top -= 1;
            }
            chain[top] = p;
            top += 1;
        }
        top -= 1;
    }
    if top < 3 {
        // All on a line: its two ends.
        return out.set(&[pts[0], pts[m - 1]]);
    }
    out.set(&chain[..top])
}

/// Puts in `pts` the vertices of `verts` whose projection on `n` lies on the near side of
/// `bound` (at or above it where `above`, at or below otherwise), projected on the plane
/// (t1, t2), with their numbers.
fn project_near(pts: &mut Vec<Projected>, verts: &[DVec3], n: DVec3, bound: f64, above: bool, (t1, t2): (DVec3, DVec3)) {
    pts.clear();
    for (i, &v) in verts.iter().enumerate() {
        let along = n.dot(v);
        if (above && along >= bound) || (!above && along <= bound) {
            pts.push((DVec2::new(t1.dot(v), t2.dot(v)), i as u32));
        }
    }
}

/// The crossing of segments p0p1 and q0q1 strictly inside both (parameters on each), if any;
/// given as their starts and sides, `r` = p1 − p0 and `s` = q1 − q0; `lengths`: |r| and |s|.
fn crossing((p0, r): (DVec2, DVec2), (q0, s): (DVec2, DVec2), lengths: (f64, f64)) -> Option<(f64, f64)> {
    let den = r.perp_dot(s);
    if den.abs() <= 1e-12 * lengths.0 * lengths.1 {
        return None;
    }
    let t = (q0 - p0).perp_dot(s) / den;
    let u = (q0 - p0).perp_dot(r) / den;
    (t > 1e-9 && t < 1.0 - 1e-9 && u > 1e-9 && u < 1.0 - 1e-9).then_some((t, u))
}

/// The touching region of two blocks whose common plane is `plane`: the category, the logical
/// contacts' kinds, points (on the plane, between the surfaces) and gaps, and the region's area.
/// `tolerance` is the contact-forming distance (features within it of the plane touch).
pub fn logical_contacts(a: &Block, b: &Block, plane: &CommonPlane, tolerance: f64) -> ([Feature; 2], Vec<(LogicalKind, DVec3, f64)>, f64) {
    let (a, b) = (Body::from(a), Body::from(b));
    let mut scratch = Scratch::default();
    let (category, area) = logical_contacts_with(&Turned::of(a).placed(), &Turned::of(b).placed(), plane, tolerance, &mut scratch);
    (category, scratch.found, area)
}

/// [`logical_contacts`] of two convex bodies (blocks, or parts of concave ones) as [`Placed`],
/// the logical contacts left in `scratch.found` ([`Scratch::found`]). The vertex numbers of the
/// logical contacts' keys are the bodies'.
pub fn logical_contacts_with(a: &Placed, b: &Placed, plane: &CommonPlane, tolerance: f64, scratch: &mut Scratch) -> ([Feature; 2], f64) {
    let Scratch { pts, chain, hulls: [ha, hb], around, leaving, entering, on_plane, found, .. } = scratch;
    let n = plane.normal;
    facing(a.body, a.normals, n, false, GRAZING, leaving);
    facing(b.body, b.normals, n, true, GRAZING, entering);
    let (a, b) = (a.body, b.body);
    let (t1, t2) = plane_axes(n);
    let (hi_a, lo_b) = plane.supports;
    let size = a.shape.radius.min(b.shape.radius);
    let flat = 1e-6 * size;
    // The features of each within the tolerance of the plane, their hulls on it.
    project_near(pts, a.vertices, n, hi_a - tolerance, true, (t1, t2));
    hull(pts, chain, flat, ha);
    project_near(pts, b.vertices, n, lo_b + tolerance, false, (t1, t2));
    hull(pts, chain, flat, hb);
    let category = [ha.feature(), hb.feature()];
    ha.measure();
    hb.measure();
    let (ha, hb) = (&*ha, &*hb);

    on_plane.clear();
    for (k, &p) in ha.pts.iter().enumerate() {
        if hb.covers(p, flat) {
            on_plane.push((LogicalKind::VertexFace { on_first: true, vertex: ha.ids[k] }, p));
        }
    }
    for (k, &p) in hb.pts.iter().enumerate() {
        // A vertex of each at one place is one logical contact (vertex–vertex, or the corner
        // of two faces matching): keep block 1's.
        if ha.covers(p, flat) && !on_plane.iter().any(|(_, q)| !farther_than(*q - p, flat)) {
            on_plane.push((LogicalKind::VertexFace { on_first: false, vertex: hb.ids[k] }, p));
        }
    }
    let key = |x: u32, y: u32| (x.min(y), x.max(y));
    for (e, (i, j)) in ha.edges().enumerate() {
        for (f, (k, l)) in hb.edges().enumerate() {
            if let Some((t, _)) = crossing((ha.pts[i], ha.sides[e]), (hb.pts[k], hb.sides[f]), (ha.lengths[e], hb.lengths[f])) {
                let p = ha.pts[i] + ha.sides[e] * t;
                if !on_plane.iter().any(|(_, q)| !farther_than(*q - p, flat)) {
                    on_plane.push((LogicalKind::EdgeEdge { first: key(ha.ids[i], ha.ids[j]), second: key(hb.ids[k], hb.ids[l]) }, p));
                }
            }
        }
    }
    if on_plane.is_empty() {
        // Features that touch without their projections meeting within the tolerance of the
        // tests (an edge and a vertex at a grazing angle): one contact at the nearest pair.
        let (mut best, mut at) = (f64::INFINITY, (0, 0));
        for (i, p) in ha.pts.iter().enumerate() {
            for (j, q) in hb.pts.iter().enumerate() {
                let d = (*p - *q).length();
                if d < best {
                    best = d;
                    at = (i, j);
                }
            }
        }
        let p = 0.5 * (ha.pts[at.0] + hb.pts[at.1]);
        on_plane.push((LogicalKind::VertexFace { on_first: true, vertex: ha.ids[at.0] }, p));
    }
    // Each point on the plane: the gap along n between where the line leaves block 1 and enters
    // block 2 (no farther than `reach`, [`ray_crossing`]), and the point halfway between the two
    // surfaces.
    let reach = crossing_reach(a, b);
    let origin = n * (0.5 * (hi_a + lo_b));
    found.clear();
    found.extend(on_plane.iter().map(|(kind, p2)| {
        let p = origin + t1 * p2.x + t2 * p2.y;
        let leave = ray_crossing(leaving, p, false, reach);
        let enter = ray_crossing(entering, p, true, reach);
        let (leave, enter) = if leave.is_finite() && enter.is_finite() { (leave, enter) } else { (0.0, plane.separation) };
        (*kind, p + n * (0.5 * (leave + enter)), enter - leave)
    }));
    (category, region_area(on_plane, around))
}

/// The area of the touching region whose corners are the logical contacts `on_plane` (points
/// on the plane, in the order found): the corners of the intersection of two convex polygons,
/// so in convex position; taken in order of their angle about their mean (a pseudo-angle,
/// monotonic in the true one, needs no trigonometry) and summed as triangles from the mean. Of
/// two or fewer corners, none. `around`: working space.
fn region_area(on_plane: &[(LogicalKind, DVec2)], around: &mut Vec<(f64, DVec2)>) -> f64 {
    if on_plane.len() < 3 {
        return 0.0;
    }
    let mean = on_plane.iter().map(|(_, p)| *p).sum::<DVec2>() / on_plane.len() as f64;
    around.clear();
    for (_, p) in on_plane {
        let d = *p - mean;
        // In [0, 4) counter-clockwise from +x: 1 − x/(|x| + |y|) above the axis, 3 + x/… below.
        let l1 = d.x.abs() + d.y.abs();
        let along = if l1 > 0.0 { d.x / l1 } else { 1.0 };
        let angle = if d.y >= 0.0 { 1.0 - along } else { 3.0 + along };
        let at = around.iter().position(|(a, _)| *a > angle).unwrap_or(around.len());
        around.insert(at, (angle, d));
    }
    let m = around.len();
    0.5 * (0..m).map(|i| around[i].1.perp_dot(around[if i + 1 == m { 0 } else { i + 1 }].1)).sum::<f64>()
}

/// ¶23's prescription for the normal at a point `p` inside (or on) block `block`: the vertex of
/// the block nearest p; the faces around it; their outward normals averaged with weights
/// 1/d (d the distance of p from each face's plane), or the normal of a face p lies on; made a
/// unit vector. Outward from `block`.
pub fn prescribed_normal(block: &Block, p: DVec3) -> DVec3 {
    let nearest =
        (0..block.vertices.len()).min_by(|&i, &j| (block.vertices[i] - p).length_squared().total_cmp(&(block.vertices[j] - p).length_squared())).unwrap_or(0);
    let mut sum = DVec3::ZERO;
    for (f, face) in block.shape.faces.iter().enumerate() {
        if !face.contains(&(nearest as u32)) {
            continue;
        }
        let n = block.face_normal(f);
        let d = n.dot(p - block.vertices[face[0] as usize]).abs();
        if d <= 1e-12 * block.shape.radius {
            return n;
        }
        sum += n / d;
    }
    sum.normalize_or_zero()
}

/// The normal force of a logical contact found this cycle, before [`force_law`] loads it from its
/// offset (every other one's is carried from the last cycle).
pub const NEW_NORMAL_FORCE: f64 = f64::NAN;

/// The force–displacement law for the logical contacts of `contact` (eqs. 13–20), at the
/// contact's current normal; `old_normal` is the normal of the previous cycle (for the rotation
/// of the shear force). The forces are stored in the logical contacts; returns the energy
/// friction took (the ledger's `friction`): what a spring at the Coulomb limit gives up
/// ([`slip_work`]), and the shear spring's energy of a contact that opens; and the energy its
/// normal spring held when it opened (the ledger's `released`, as a contact gone while loaded):
/// an edge–edge logical contact's stepped force can stand above kn times its overlap when its
/// gap passes its offset (below), and that spring's ½Fn²/kn goes with it. Unbooked, it was the
/// struck wall's ledger imbalance: 2·10⁻³ of the cube's energy, not shrinking with the step
/// (docs/BENCHMARKS.md).
///
/// The normal force (eq. 16): a vertex–face logical contact's is kn times its overlap beyond its
/// offset (the whole overlap at a run's first detection, none where it appeared inside a face
/// already overlapped); its point is the vertex, a point of its block, so that force is the
/// work's own (the spring's energy ½Fn²/kn changes by what the force does on the blocks). An
/// edge–edge logical contact is the crossing of two edges as seen along the normal, which slides
/// along them as the blocks turn: ~1.7 mm a cycle for 45 µm of the blocks' motion where two
/// bricks' faces meet at a small angle in a struck wall, into deeper overlap, so that kn times its
/// gap grew with no work done (the wall ended with 9.7 % more energy than the cube brought;
/// docs/BENCHMARKS.md). Its force is stepped as the report's eq. (16) gives it, ΔFn = −kn·u̇n·Δt
/// with u̇n the blocks' relative velocity at its point along the normal, never below 0; new
/// ([`NEW_NORMAL_FORCE`]) it starts at kn times its overlap beyond its offset, and at no force at
/// the lesser of that and one step's approach (it touched within the step). (A vertex–face
/// contact stepped so too drifted off its overlap in f32 on the GPU: an L resting on an L moved
/// 0.3 mm from the CPU's.) Either opens, its force dropped, where its gap passes its offset.
pub fn force_law(contact: &mut Contact, old_normal: DVec3, a: &Block, b: &Block, mat: &Material, dt: f64) -> (f64, f64) {
    let n = contact.normal;
    let (mut friction, mut released) = (0.0, 0.0);
    for l in &mut contact.logical {
        if l.gap > l.offset {
            // Open: no force, and the shear history is lost; the spring reloads from here.
            l.offset = l.gap.min(0.0);
            if mat.ks > 0.0 {
                friction += 0.5 * l.shear_force.length_squared() / mat.ks;
            }
            // An edge–edge one's stepped force, where it stood above kn times the overlap (a
            // vertex–face one's is kn times the last overlap, which the blocks' motion in the
            // step took back as work: booked again, the settling cubes' ledger crept up by
            // 7e-3 J in 10⁴ cycles; a new one's, not yet loaded, holds nothing).
            if mat.kn > 0.0 && l.normal_force > 0.0 && matches!(l.kind, LogicalKind::EdgeEdge { .. }) {
                released += 0.5 * l.normal_force * l.normal_force / mat.kn;
            }
            l.normal_force = 0.0;
            l.shear_force = DVec3::ZERO;
            continue;
        }
        // Eq. (13): block 2's point relative to block 1's; eqs. (14)–(15).
        let u = b.velocity_at(l.point) - a.velocity_at(l.point);
        let un = u.dot(n);
        let us = u - un * n;
        // Eq. (16), ΔFn = −kn·Δun: the relative displacement of the blocks at the point along
        // the normal, in compression only. A logical contact found this cycle starts from its
        // overlap beyond its offset (0 where it appeared unloaded).
        let loaded = -mat.kn * (l.gap - l.offset);
        l.normal_force = if l.normal_force.is_nan() || !matches!(l.kind, LogicalKind::EdgeEdge { .. }) {
            loaded
        } else if l.normal_force == 0.0 {
            loaded.min(-mat.kn * un * dt).max(0.0)
        } else {
            (l.normal_force - mat.kn * un * dt).max(0.0)
        };
        // Eq. (17): the previous shear force turned into the new plane, magnitude kept.
        let mut fs = l.shear_force;
        if old_normal != n {
            let magnitude = fs.length();
            fs -= n * n.dot(fs);
            let left = fs.length();
            fs = if left > 0.0 { fs * (magnitude / left) } else { DVec3::ZERO };
        }
        let held = fs;
        fs -= us * (mat.ks * dt);
        // Eq. (20): Coulomb's limit with cohesion.
        let limit = mat.cohesion + mat.friction * l.normal_force;
        let size = fs.length();
        if size > limit {
            let kept = limit.max(0.0);
            fs *= if size > 0.0 { kept / size } else { 0.0 };
            friction += slip_work(held, fs, us * dt, mat.ks);
        }
        l.shear_force = fs;
    }
    (friction, released)
}

/// The energy a shear spring gave up to slip in one step (as 2D's `law::slip_dissipation`, in
/// vectors): the trapezoidal work the blocks did on it while block 2 slid `slide` relative to
/// block 1, −½(held + new)·slide, less what it stored, (|new|² − |held|²)/2ks. Zero for an
/// elastic step (new = held − ks·slide); at the Coulomb limit the friction force times the slip,
/// and where the limit fell under the force held (a contact unloading in its normal, as a block
/// rebounds or rocks), the stored energy (|held|² − |new|²)/2ks let go with it: booking only the
/// limit times the slip (kept·(|trial| − kept)/ks) misses ½(|held| − kept)²/ks a step there, and a
/// rocking block's ledger fell by 4 % of its friction. `held` is the step's starting force turned
/// into the new plane (magnitude kept, so the turn stores nothing). WGSL twin: `slip_work` in
/// `shaders/d3/track_contact.wgsl`.
#[inline]
pub fn slip_work(held: DVec3, new: DVec3, slide: DVec3, ks: f64) -> f64 {
    if ks <= 0.0 {
        return 0.0;
    }
    -0.5 * (held + new).dot(slide) - (new.length_squared() - held.length_squared()) / (2.0 * ks)
}

/// The total force each logical contact puts on block 2 (block 1 takes its opposite), the
/// stiffness-proportional dashpots included (not stored): Fn·n + Fs + β(kn u̇n n + ks u̇s).
pub fn logical_force(l: &Logical, n: DVec3, a: &Block, b: &Block, mat: &Material, beta: f64) -> DVec3 {
    let mut f = n * l.normal_force + l.shear_force;
    if beta > 0.0 && l.gap <= 0.0 {
        let u = b.velocity_at(l.point) - a.velocity_at(l.point);
        let un = u.dot(n);
        f -= beta * (mat.kn * un * n + mat.ks * (u - un * n));
    }
    f
}

/// Where a logical contact of the last detection lies now, and its gap, given the contact's
/// common plane (normal `n`, block 1's support `hi_a` and block 2's `lo_b` along it): its vertex
/// (vertex–face), or the point of block 1's edge where block 2's crosses it as seen along n
/// (edge–edge; the nearest end where they no longer cross, the middle where they are parallel),
/// on the mid-plane between the supports; then moved along n to halfway between where the line
/// along n leaves block 1 and enters block 2, as [`logical_contacts`] places the contacts it
/// finds. The GPU's stage 4 between detections (`track_contact`; WGSL twin in
/// `shaders/d3/track_contact.wgsl`).
pub fn place_logical(kind: LogicalKind, a: Body, b: Body, n: DVec3, hi_a: f64, lo_b: f64, separation: f64) -> (DVec3, f64) {
    let mid = 0.5 * (hi_a + lo_b);
    let x = match kind {
        LogicalKind::VertexFace { on_first: true, vertex } => a.vertices[vertex as usize],
        LogicalKind::VertexFace { on_first: false, vertex } => b.vertices[vertex as usize],
        LogicalKind::EdgeEdge { first, second } => {
            let p0 = a.vertices[first.0 as usize];
            let r = a.vertices[first.1 as usize] - p0;
            let q0 = b.vertices[second.0 as usize];
            let s = b.vertices[second.1 as usize] - q0;
            // In the plane's axes (t1, t2, n right-handed) a perp-dot product is (· × ·)·n.
            let den = r.cross(s).dot(n);
            let t = if den.abs() > 1e-12 * r.length() * s.length() { ((q0 - p0).cross(s).dot(n) / den).clamp(0.0, 1.0) } else { 0.5 };
            p0 + r * t
        }
    };
    let p = x + n * (mid - n.dot(x));
    let grazing = |body: Body| if body.block.parts.is_empty() { GRAZING } else { PART_GRAZING };
    let mut planes = Vec::new();
    facing(a, &plane_normals(a), n, false, grazing(a), &mut planes);
    let reach = crossing_reach(a, b);
    let leave = ray_crossing(&planes, p, false, reach);
    facing(b, &plane_normals(b), n, true, grazing(b), &mut planes);
    let enter = ray_crossing(&planes, p, true, reach);
    let (leave, enter) = if leave.is_finite() && enter.is_finite() { (leave, enter) } else { (0.0, separation) };
    (p + n * (0.5 * (leave + enter)), enter - leave)
}

/// Stage 4 of one contact between detections, as the GPU runs it (WGSL twin in
/// `shaders/d3/track_contact.wgsl`): the common plane afresh; a contact whose blocks have parted
/// (boxes or plane apart by more than `tol`) loses its logical contacts, their springs' energy
/// released; otherwise each logical contact the last detection found is placed anew
/// ([`place_logical`]) and the force–displacement law applied ([`force_law`]). The set of
/// logical contacts changes only at a detection ([`logical_contacts`], on the CPU between
/// cycles). `a` and `b` are the contact's bodies (its blocks, or the parts of concave ones in
/// touch, `Contact::parts`). Returns the energy friction took and that released.
pub fn track_contact(c: &mut Contact, a: Body, b: Body, mat: &Material, tol: f64, dt: f64) -> (f64, f64) {
    let ((a0, a1), (b0, b1)) = (a.bounds(), b.bounds());
    let apart = (b0 - a1).max(a0 - b1).max_element() > tol;
    let plane = (!apart).then(|| common_plane_of(a, b, tol, Some(c.normal)));
    let old_normal = c.normal;
    if let Some(p) = &plane {
        c.normal = p.normal;
    }
    let Some(plane) = plane.filter(|p| p.separation <= tol) else {
        let released = c.logical.iter().map(|l| spring_energy(l, mat)).sum();
        c.logical.clear();
        return (0.0, released);
    };
    let (n, (hi_a, lo_b)) = (plane.normal, plane.supports);
    for l in &mut c.logical {
        (l.point, l.gap) = place_logical(l.kind, a, b, n, hi_a, lo_b, plane.separation);
    }
    force_law(c, old_normal, a.block, b.block, mat, dt)
}

/// What a change of a contact's spring stiffnesses from `old` to `new` (the joint law's share of
/// its touching region, `Material::contact_law`) does to the energy its logical contacts hold,
/// before this cycle's increments: a vertex–face spring holds its displacement (its force is kn
/// times its overlap beyond its offset, Fn/kn_old of it), ½(kn_new − kn_old)(Fn/kn_old)²; an
/// edge–edge one and every shear spring hold their force, ½F²(1/k_new − 1/k_old). Energy the law
/// put in where positive (the ledger books it as a negative release). A spring appearing now
/// holds nothing. Without it, a struck wall of jointed bricks ended with 0.64 % of the cube's
/// energy the ledger could not account for.
pub fn restiffening(logical: &[Logical], old: &Material, new: &Material) -> f64 {
    let mut gained = 0.0;
    for l in logical {
        let f = l.normal_force;
        if f.is_finite() && f > 0.0 && old.kn > 0.0 && new.kn > 0.0 {
            gained += if matches!(l.kind, LogicalKind::EdgeEdge { .. }) {
                0.5 * f * f * (1.0 / new.kn - 1.0 / old.kn)
            } else {
                0.5 * (new.kn - old.kn) * (f / old.kn) * (f / old.kn)
            };
        }
        if old.ks > 0.0 && new.ks > 0.0 {
            gained += 0.5 * l.shear_force.length_squared() * (1.0 / new.ks - 1.0 / old.ks);
        }
    }
    gained
}

/// The strain energy of a logical contact's springs, Fn²/2kn + |Fs|²/2ks.
pub fn spring_energy(l: &Logical, mat: &Material) -> f64 {
    let mut e = 0.0;
    if mat.kn > 0.0 {
        e += 0.5 * l.normal_force * l.normal_force / mat.kn;
    }
    if mat.ks > 0.0 {
        e += 0.5 * l.shear_force.length_squared() / mat.ks;
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A change of stiffness books what the springs held gain: a vertex–face spring keeps its
    /// displacement, an edge–edge one and the shear springs their forces; no change, nothing.
    #[test]
    fn restiffening_is_the_held_springs_energy_change() {
        let (old, new) = (Material { kn: 1e9, ks: 5e8, ..Default::default() }, Material { kn: 2e9, ks: 1e9, ..Default::default() });
        let spring = |kind, normal_force: f64, shear: f64| Logical {
            kind,
            point: DVec3::ZERO,
            gap: -1e-4,
            normal_force,
            shear_force: DVec3::new(shear, 0.0, 0.0),
            offset: 0.0,
        };
        let vertex = spring(LogicalKind::VertexFace { on_first: true, vertex: 0 }, 1e5, 0.0);
        let crossing = spring(LogicalKind::EdgeEdge { first: (0, 1), second: (2, 3) }, 1e5, 2e4);
        let appearing = spring(LogicalKind::VertexFace { on_first: false, vertex: 1 }, NEW_NORMAL_FORCE, 0.0);
        // The vertex: displacement 1e-4 m held, ½(2e9 − 1e9)(1e-4)² = 5 J more.
        assert!((restiffening(&[vertex], &old, &new) - 5.0).abs() < 1e-12);
        // The crossing: 1e5 N held, ½·1e10·(1/2e9 − 1/1e9) = −2.5 J; its shear 2e4 N, ½·4e8·(1/1e9 − 1/5e8) = −0.2 J.
        assert!((restiffening(&[crossing], &old, &new) + 2.7).abs() < 1e-12);
        assert_eq!(restiffening(&[appearing], &old, &new), 0.0);
        assert_eq!(restiffening(&[vertex, crossing], &old, &old), 0.0);
        // Back again: the energy the first change put in comes out.
        let there_and_back = restiffening(&[vertex], &old, &new) + restiffening(&[spring(vertex.kind, 2e5, 0.0)], &new, &old);
        assert!(there_and_back.abs() < 1e-12, "{there_and_back}");
    }

    /// A corner under a new key takes the forces of the nearest loaded logical contact that
    /// went, within the reach, one old one to one new one; the rest are released.
    #[test]
    fn carry_swapped_gives_a_gone_corners_springs_to_the_nearest_new_one() {
        let law = Material { kn: 1e9, ks: 5e8, ..Default::default() };
        let at = |kind, x: f64, gap: f64, normal_force: f64, offset: f64| Logical {
            kind,
            point: DVec3::new(x, 0.0, 0.0),
            gap,
            normal_force,
            shear_force: DVec3::new(0.0, normal_force * 0.1, 0.0),
            offset,
        };
        let vertex = |v| LogicalKind::VertexFace { on_first: true, vertex: v };
        let edges = |a, b| LogicalKind::EdgeEdge { first: (a, b), second: (4, 5) };
        // The last cycle: a loaded vertex at x = 0 (gone), one at x = 1 (found again), a loaded
        // one at x = 5 (gone, nothing new near it), an open one at x = 2 (gone).
        let previous = [
            at(vertex(0), 0.0, -2e-4, 1e5, -1e-4),
            at(vertex(1), 1.0, -1e-4, 1e5, 0.0),
            at(vertex(2), 5.0, -1e-4, 1e5, 0.0),
            at(vertex(3), 2.0, 1e-3, 0.0, 0.0),
        ];
        // This cycle: the vertex at 1 again, two crossings near 0 (the nearer takes its springs),
        // a crossing near the open one at 2 (nothing to take).
        let new = |kind, x: f64| Logical { shear_force: DVec3::ZERO, ..at(kind, x, -3e-4, NEW_NORMAL_FORCE, -3e-4) };
        let mut logical = [new(edges(0, 1), 0.004), at(vertex(1), 1.0, -1e-4, 1e5, 0.0), new(edges(0, 2), 0.001), new(edges(3, 6), 2.0)];
        let released = carry_swapped(&previous, &mut logical, 0.01, &law);
        // The crossing at 0.004 comes first and is within reach: it takes vertex 0's springs
        // (one old spring to one new one), the crossing at 0.001 starts unloaded.
        let taken = &logical[0];
        assert_eq!((taken.normal_force, taken.shear_force), (1e5, previous[0].shear_force));
        assert!((taken.offset - (taken.gap + 1e5 / law.kn)).abs() < 1e-18, "{taken:?}");
        assert!(logical[2].normal_force.is_nan() && logical[2].shear_force == DVec3::ZERO && logical[2].offset == -3e-4);
        assert!(logical[3].normal_force.is_nan(), "an open spring is not carried");
        assert_eq!(logical[1], previous[1]);
        // Released: the one at 5 (nothing new within reach) and the open one (its springs hold nothing).
        let expected = spring_energy(&previous[2], &law) + spring_energy(&previous[3], &law);
        assert_eq!(released, expected);
        assert!(released > 0.0);
    }

    /// The touching region's area (`region_area`) whatever the order its corners were found in:
    /// the corners of random convex polygons (on ellipses), shuffled, against the shoelace sum
    /// in their order; a line of points, and a square with a corner found twice.
    #[test]
    fn region_area_is_the_convex_polygons_whatever_the_order() {
        let mut around = Vec::new();
        let kind = LogicalKind::VertexFace { on_first: true, vertex: 0 };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..300 {
            let k = 3 + case % 6;
            let centre = DVec2::new(10.0 * uniform() - 5.0, 10.0 * uniform() - 5.0);
            let (rx, ry) = (0.1 + uniform(), 0.1 + uniform());
            let mut angles: Vec<f64> = (0..k).map(|_| std::f64::consts::TAU * uniform()).collect();
            angles.sort_by(f64::total_cmp);
            let corners: Vec<DVec2> = angles.iter().map(|t| centre + DVec2::new(rx * t.cos(), ry * t.sin())).collect();
            let expected = 0.5 * (0..k).map(|i| (corners[i] - centre).perp_dot(corners[(i + 1) % k] - centre)).sum::<f64>();
            let mut found: Vec<(LogicalKind, DVec2)> = corners.iter().map(|p| (kind, *p)).collect();
            for i in (1..k).rev() {
                let j = ((uniform() * (i + 1) as f64) as usize).min(i);
                found.swap(i, j);
            }
            let area = region_area(&found, &mut around);
            assert!(expected > 0.0 && (area - expected).abs() <= 1e-12 * expected.max(1.0), "case {case}: {area} against {expected}");
        }
        let line: Vec<_> = (0..4).map(|i| (kind, DVec2::new(i as f64, 2.0 * i as f64))).collect();
        assert_eq!(region_area(&line, &mut around), 0.0);
        let square: Vec<_> = [(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)].iter().map(|&(x, y)| (kind, DVec2::new(x, y))).collect();
        assert!((region_area(&square, &mut around) - 1.0).abs() < 1e-15);
        assert_eq!(region_area(&square[..2], &mut around), 0.0, "two corners hold no area");
    }

    /// What a shear spring gives up (`slip_work`): nothing in an elastic step; the limit times
    /// the slip when it slides at a steady limit; all it let go of where the limit fell under
    /// the force held with no slide.
    #[test]
    fn slip_work_is_zero_elastic_and_books_the_unloading() {
        let ks = 2e8;
        let held = DVec3::new(3e4, -1e4, 0.0);
        let slide = DVec3::new(-1e-5, 2e-5, 0.0);
        assert!(slip_work(held, held - slide * ks, slide, ks).abs() < 1e-9);
        // Steady sliding at the limit L along x: the spring keeps L, the slip is |slide|.
        let l = 5e4;
        let along = DVec3::new(-3e-5, 0.0, 0.0);
        let w = slip_work(DVec3::new(l, 0.0, 0.0), DVec3::new(l, 0.0, 0.0), along, ks);
        assert!((w - l * 3e-5).abs() < 1e-9 * w, "{w}");
        // The limit falls from |held| to 1e4 with no slide: the stored energy difference.
        let kept = held.normalize() * 1e4;
        let w = slip_work(held, kept, DVec3::ZERO, ks);
        assert!((w - (held.length_squared() - 1e8) / (2.0 * ks)).abs() < 1e-12, "{w}");
        assert!(w > kept.length() * (held.length() - kept.length()) / ks, "more than the limit times the spring's give");
        assert_eq!(slip_work(held, kept, slide, 0.0), 0.0);
    }
}
