//! D3's model (SL-85-1 ¶27–32, Appendix B's data arrays): blocks with their faces, edges and
//! vertices, the materials, the contacts (real ones with their logical contacts, and degenerate
//! ones: neighbour links), gravity, damping and the clock. Authoritative, in f64.

use glam::{DMat3, DQuat, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

pub use super::geometry::{least_eigenvalue, principal_moments};
use super::geometry::{MassProperties, Shape};
use super::sdef::{self, Elastic, Sdef};

/// A material's properties (PROPERTY; the keys of the 2D language less the fluid's).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub density: f64,
    pub bulk: f64,
    pub shear: f64,
    /// Contact normal and shear stiffness (force per length: a logical contact is a point).
    pub kn: f64,
    pub ks: f64,
    pub cohesion: f64,
    /// Friction coefficient μ (eq. 20).
    pub friction: f64,
    pub jkn: f64,
    pub jks: f64,
    pub jcohesion: f64,
    pub jfriction: f64,
    pub tf: f64,
}

impl Material {
    /// Its elastic moduli, what a simply-deformable block's strain needs (`d3::sdef`).
    pub fn elastic(&self) -> Elastic {
        Elastic { bulk: self.bulk, shear: self.shear }
    }

    /// The force–displacement law's parameters for each logical contact of a contact whose
    /// touching region has `area` and `logical` logical contacts. The point law (constitutive
    /// 1 and 3; and every contact without an area: vertex–face, edge–edge, edge–edge crossing)
    /// takes KN, KS, COHESION and FRICTION as they are, per logical contact. The **joint law**
    /// (`joint`: constitutive 2, 4 and 5, 2D's joint contacts of Table A1, as 3DEC's joints)
    /// gives a face–face or face–edge contact JKN, JKS and JCOHESION per unit area over its
    /// area, shared equally by its logical contacts (each takes area/n), and JFRICTION: the
    /// contact's stiffness is JKN·area however many corners its touching region has, so that a
    /// block cracked across a pressed face, whose halves' contacts have four corners each, carry
    /// what the whole face carried (the point law doubles it), and its strength is
    /// JCOHESION·area + JFRICTION·N, Coulomb's for a joint.
    ///
    /// As in 2D (¶5: "the point-contact logic is also used if ... sn_j·l_j < sn"), a contact
    /// whose joint would be softer in the normal direction than one point contact, JKN·area <
    /// KN, takes the point law: a small touching region is no softer than a corner. Without
    /// this, a face contact whose blocks rock between face and edge (a wall struck at 30 m/s,
    /// JKN·area ≈ KN/2 on its bricks' faces) switched from corners of JKN·area/4 to corners of
    /// KN at the same overlaps, each switch putting spring energy in: the wall stopped with
    /// `energy growing without a source` at the same simulated time at every FRACTION.
    pub fn contact_law(&self, joint: bool, area: f64, logical: usize) -> Material {
        if !self.joint_law(joint, area, logical) {
            return *self;
        }
        let share = area / logical as f64;
        Material { kn: self.jkn * share, ks: self.jks * share, cohesion: self.jcohesion * share, friction: self.jfriction, ..*self }
    }

    /// Whether [`Material::contact_law`] gives a contact the joint law: a joint constitutive
    /// number (`joint`), a touching region of some area shared by its `logical` contacts, and
    /// JKN·area ≥ KN.
    pub fn joint_law(&self, joint: bool, area: f64, logical: usize) -> bool {
        joint && area > 0.0 && logical > 0 && self.jkn * area >= self.kn
    }
}

/// The block of the two `blocks` (indices) whose material and constitutive number give their
/// contact its law: the one of the lower material number, then the lower constitutive number
/// (block 1 where both agree). The report's D3 has one material; taking block 1's, as this did,
/// made the law hang on the blocks' order, which a crack changes (its new piece goes at the end):
/// a brick's piece against a steel projectile took the steel's stiffness where the brick had
/// given its joint law, and the crack put that spring energy in.
pub fn law_block(all: &[Block], blocks: [u32; 2]) -> usize {
    let [i, j] = blocks.map(|k| k as usize);
    let key = |b: &Block| (b.material, b.constitutive);
    if key(&all[j]) < key(&all[i]) {
        j
    } else {
        i
    }
}

/// The material of the law block of a contact between `blocks` ([`law_block`]) and whether its
/// constitutive number gives face contacts the joint law ([`joint_contacts`]): what
/// [`Material::contact_law`] takes with the touching region.
pub fn law_material(all: &[Block], materials: &[Material], blocks: [u32; 2]) -> (Material, bool) {
    let by = &all[law_block(all, blocks)];
    (material_of(materials, by.material), joint_contacts(by.constitutive))
}

/// Whether blocks of constitutive number `constitutive` give their face contacts the joint law
/// ([`Material::contact_law`]): 2, 4 and 5, the numbers of 2D's joint contacts (Table A1).
pub fn joint_contacts(constitutive: u32) -> bool {
    matches!(constitutive, 2 | 4 | 5)
}

impl Default for Material {
    /// The 1985 programs started from zeroed arrays: a material not given has no density and no
    /// stiffness (the executor refuses blocks of such a material when mass is needed).
    fn default() -> Self {
        Material {
            density: 0.0,
            bulk: 0.0,
            shear: 0.0,
            kn: 0.0,
            ks: 0.0,
            cohesion: 0.0,
            friction: 0.0,
            jkn: 0.0,
            jks: 0.0,
            jcohesion: 0.0,
            jfriction: 0.0,
            tf: 0.0,
        }
    }
}

/// A polyhedral block (Appendix B's block array: KMAT, KCONS, KRCOD, KCBN, KCD, KTD, KVOL, KEM,
/// KBI, KBFX, KBFT, KCL).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Block {
    /// Stable id, from 1 in the order built.
    pub id: u32,
    pub material: u32,
    pub constitutive: u32,
    /// KRCOD: a fixed block does not move.
    pub fixed: bool,
    /// Its surface in its reference frame, about its centroid: shared, not copied, by the
    /// model's copies (the last good state is one, taken every hundred cycles: the shapes
    /// change only where a block is made, cut or split, which makes a new one).
    pub shape: Arc<Shape>,
    pub volume: f64,
    pub mass: f64,
    /// The inertia tensor about the centroid in the reference frame (exact, ¶16).
    pub inertia_ref: DMat3,
    pub centroid: DVec3,
    /// Rotation from the reference frame to the global axes, a unit quaternion.
    pub orientation: DQuat,
    /// Velocity of the centroid (at the half step).
    pub velocity: DVec3,
    /// Angular momentum about the centroid, global axes (at the half step).
    pub angular_momentum: DVec3,
    /// Angular velocity, global axes (at the half step): I⁻¹L.
    pub angular_velocity: DVec3,
    /// Force and moment sums (KBFX, KBFT) at the whole step, gravity and load included.
    pub force: DVec3,
    pub moment: DVec3,
    /// Applied load at the centroid (KCL).
    pub load: DVec3,
    /// Vertices in global coordinates, placed from centroid and orientation (stage 2).
    pub vertices: Vec<DVec3>,
    /// How far any vertex can have moved since the last neighbour update (¶26).
    pub travel: f64,
    /// The simply-deformable extension (CHANGE … SDEF, ¶35d; `d3::sdef`): the block's uniform
    /// strain, its rate and stress. None for a rigid block. Saved after the model, as the
    /// report's extension array (`d3::restart`, format 5).
    #[serde(skip)]
    pub sdef: Option<Sdef>,
    /// BOUNDARY VELOCITY (¶35e, extension): the block is held at its `velocity` and
    /// `angular_velocity` whatever the forces on it (its angular momentum I(t)ω follows its
    /// turn). FIX holds it at rest instead, FREE lets it go on from its velocity. Saved after
    /// the model (`d3::restart`, format 6).
    #[serde(skip)]
    pub held: bool,
    /// BOUNDARY STRESS (¶35e, extension): its faces loaded by a stress tensor, by face number,
    /// ascending (a later BOUNDARY STRESS on a face replaces its stress). Saved after the model
    /// (`d3::restart`, format 6).
    #[serde(skip)]
    pub boundary_stress: Vec<FaceStress>,
    /// A concave block's convex parts (SL-85-1 ¶13: any shape built of triangles, concave
    /// regions included; `d3::decompose`), which move as one body with it: contact detection
    /// runs between parts of different blocks, and a part's contact forces act on its block.
    /// Empty for a convex block, which is its own one part (its `shape` and `vertices`). Saved
    /// after the model (`d3::restart`, format 7).
    #[serde(skip)]
    pub parts: Vec<Part>,
    /// The volume of the block as the deck built it (BLOCK, BOX, SPLIT): a crack's pieces keep
    /// their parent's, so that a block cracks only while it holds at least
    /// [`super::cracking::FRAGMENT_FLOOR`] of it (`cracking::due`). Saved after the model
    /// (`d3::restart`, format 8).
    #[serde(skip)]
    pub built_volume: f64,
}

/// A convex part of a concave block (`Block::parts`): its surface about its own centroid in the
/// block's reference frame, that centroid's offset from the block's, and its vertices placed
/// from the block's centroid and orientation as the block's own are (stage 2). Its mass
/// properties are not used: the block's, of the whole surface, are exact.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// Shared by the model's copies, as `Block::shape`.
    pub shape: Arc<Shape>,
    /// The part's centroid from the block's, reference frame.
    pub offset: DVec3,
    /// Vertices in global coordinates.
    pub vertices: Vec<DVec3>,
}

/// What contact detection sees of a block (`d3::contact`): the block itself where it is convex,
/// or one convex part of a concave block, with the block whose motion it shares (its velocity
/// field, its orientation, the normal map of a simply-deformable block's stretch).
#[derive(Clone, Copy, Debug)]
pub struct Body<'a> {
    pub block: &'a Block,
    pub shape: &'a Shape,
    pub vertices: &'a [DVec3],
}

impl<'a> From<&'a Block> for Body<'a> {
    /// The whole block (a convex block's one part).
    #[inline]
    fn from(block: &'a Block) -> Body<'a> {
        Body { block, shape: &block.shape, vertices: &block.vertices }
    }
}

impl Body<'_> {
    /// The block's [`Block::normal_map`].
    #[inline]
    pub fn normal_map(&self) -> Option<DMat3> {
        self.block.normal_map()
    }

    /// The outward unit normal of face `f` of this body in global axes.
    #[inline]
    pub fn face_normal(&self, f: usize) -> DVec3 {
        match self.normal_map() {
            Some(m) => (m * self.shape.normals[f]).normalize(),
            None => self.block.orientation * self.shape.normals[f],
        }
    }

    /// The velocity of the block's material point at `p` ([`Block::velocity_at`]).
    #[inline]
    pub fn velocity_at(&self, p: DVec3) -> DVec3 {
        self.block.velocity_at(p)
    }

    /// The mean of the body's vertices as placed, and the radius of a ball about it inside the
    /// body ([`Shape::inradius`] as placed: a simply-deformable block's stretch ε scales it by
    /// at least 1 − |ε|, the Frobenius norm bounding the largest principal strain), or minus a
    /// radius about it holding the body (a negative [`Shape::inradius`], scaled by 1 + |ε|).
    /// `contact::common_plane_with` bounds a candidate axis's separation with them.
    pub fn inner_ball(&self) -> (DVec3, f64) {
        let mean = self.vertices.iter().copied().sum::<DVec3>() / self.vertices.len().max(1) as f64;
        let r = self.shape.inradius;
        let r = match &self.block.sdef {
            Some(s) => {
                let e = super::sdef::tensor(s.strain);
                let norm = (e.x_axis.length_squared() + e.y_axis.length_squared() + e.z_axis.length_squared()).sqrt();
                if r > 0.0 {
                    r * (1.0 - norm).max(0.0)
                } else {
                    r * (1.0 + norm)
                }
            }
            None => r,
        };
        (mean, r)
    }

    /// The axis-aligned box around the body's vertices.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.vertices.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
    }
}

/// A face loaded by BOUNDARY STRESS: its number in the block's shape and the stress tensor σ in
/// global axes (Pa, tension positive, Voigt's order 11, 22, 33, 12, 13, 23). The face takes the
/// traction σ·n, n its outward unit normal as it is now (the load follows the face as the block
/// turns and strains).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FaceStress {
    pub face: u32,
    pub stress: [f64; 6],
}

impl Block {
    /// `self` made a copy of `source` in the allocations it has (its vertices', its parts'),
    /// the shape shared (`Model::keep_from`).
    pub fn copy_from(&mut self, source: &Block) {
        let Block {
            id,
            material,
            constitutive,
            fixed,
            shape,
            volume,
            mass,
            inertia_ref,
            centroid,
            orientation,
            velocity,
            angular_momentum,
            angular_velocity,
            force,
            moment,
            load,
            vertices,
            travel,
            sdef,
            held,
            boundary_stress,
            parts,
            built_volume,
        } = source;
        self.id = *id;
        self.material = *material;
        self.constitutive = *constitutive;
        self.fixed = *fixed;
        if !Arc::ptr_eq(&self.shape, shape) {
            self.shape = Arc::clone(shape);
        }
        self.volume = *volume;
        self.mass = *mass;
        self.inertia_ref = *inertia_ref;
        self.centroid = *centroid;
        self.orientation = *orientation;
        self.velocity = *velocity;
        self.angular_momentum = *angular_momentum;
        self.angular_velocity = *angular_velocity;
        self.force = *force;
        self.moment = *moment;
        self.load = *load;
        self.vertices.clone_from(vertices);
        self.travel = *travel;
        self.sdef = *sdef;
        self.held = *held;
        self.boundary_stress.clone_from(boundary_stress);
        self.parts.clone_from(parts);
        self.built_volume = *built_volume;
    }

    /// A block of `shape` with the mass properties `props` (per unit density) and `density`.
    pub fn new(id: u32, material: u32, constitutive: u32, shape: Shape, props: &MassProperties, density: f64) -> Block {
        let vertices = shape.vertices.iter().map(|v| *v + props.centroid).collect();
        Block {
            id,
            material,
            constitutive,
            fixed: false,
            shape: Arc::new(shape),
            volume: props.volume,
            mass: density * props.volume,
            inertia_ref: props.inertia * density,
            centroid: props.centroid,
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            angular_momentum: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            force: DVec3::ZERO,
            moment: DVec3::ZERO,
            load: DVec3::ZERO,
            vertices,
            travel: 0.0,
            sdef: None,
            held: false,
            boundary_stress: Vec::new(),
            parts: Vec::new(),
            built_volume: props.volume,
        }
    }

    /// The block made of the convex `parts` (`d3::decompose`), their vertices placed.
    pub fn with_parts(mut self, parts: Vec<Part>) -> Block {
        self.parts = parts;
        self.place_parts();
        self
    }

    /// How many convex parts contact detection sees: 1 for a convex block.
    #[inline]
    pub fn part_count(&self) -> usize {
        self.parts.len().max(1)
    }

    /// Part `k` as contact detection sees it (the block itself where it is convex).
    #[inline]
    pub fn body(&self, k: u32) -> Body<'_> {
        match self.parts.get(k as usize) {
            Some(p) => Body { block: self, shape: &p.shape, vertices: &p.vertices },
            None => Body::from(self),
        }
    }

    /// The resultant of the boundary stresses on the block's loaded faces (BOUNDARY STRESS) as
    /// its vertices are placed now: force, moment about the centroid, and applied stress times
    /// volume Σ r fᵀ (what a simply-deformable block's strain reads, `d3::sdef`). A uniform
    /// traction σ·n on a planar triangle has the resultant σ·a, a = ½ (p₁ − p₀) × (p₂ − p₀) its
    /// outward area vector (faces run counter-clockwise from outside), acting at its centroid
    /// r = (p₀ + p₁ + p₂)/3, and its ∫ r tᵀ dA is r (σ·a)ᵀ exactly (r is linear over the face).
    /// Summed face by face in the order of `boundary_stress` (the GPU's `boundary_load` is its
    /// twin).
    pub fn boundary_load(&self) -> (DVec3, DVec3, DMat3) {
        let (mut force, mut moment, mut applied) = (DVec3::ZERO, DVec3::ZERO, DMat3::ZERO);
        for l in &self.boundary_stress {
            let (r, t) = self.face_traction(l, self.centroid);
            force += t;
            moment += r.cross(t);
            applied += sdef::applied(r, t);
        }
        (force, moment, applied)
    }

    /// A loaded face's lever from `centroid` (its centroid's) and the resultant σ·a of its
    /// traction, from the vertices as placed.
    #[inline]
    fn face_traction(&self, l: &FaceStress, centroid: DVec3) -> (DVec3, DVec3) {
        let [p0, p1, p2] = self.shape.faces[l.face as usize].map(|k| self.vertices[k as usize]);
        let area = (p1 - p0).cross(p2 - p0) * 0.5;
        let r = (p0 + p1 + p2) / 3.0 - centroid;
        (r, sdef::tensor(l.stress) * area)
    }

    /// The work the boundary stresses do over a step in which the block moves by `dx`, turns at
    /// `omega` and strains at its strain rate (as stepped), the vertices still where the step
    /// began about the centroid `centroid` (then): each face's resultant times its centroid's
    /// travel, t·(Δx + (ω × r + ε̇ r) Δt), which sums to F·Δx + M·ωΔt + A:ε̇ Δt.
    pub fn boundary_work(&self, centroid: DVec3, dx: DVec3, omega: DVec3, dt: f64) -> f64 {
        let mut work = 0.0;
        for l in &self.boundary_stress {
            let (r, t) = self.face_traction(l, centroid);
            let mut u = omega.cross(r);
            if let Some(s) = &self.sdef {
                u += s.strain_velocity(r);
            }
            work += t.dot(dx + u * dt);
        }
        work
    }

    /// SPLIT's piece `self` of `parent`: held as the parent was, and each of its faces lying on a
    /// loaded face of the parent's (its three vertices on that face's plane, its centroid within
    /// the triangle) loaded by the same stress. Both blocks' vertices as placed, the piece's
    /// faces then numbered as its shape's.
    pub fn inherit_boundary(&mut self, parent: &Block) {
        self.held = parent.held;
        if parent.boundary_stress.is_empty() {
            return;
        }
        let eps = 1e-9 * parent.shape.radius;
        for (k, f) in self.shape.faces.iter().enumerate() {
            let p = f.map(|v| self.vertices[v as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let centre = (p[0] + p[1] + p[2]) / 3.0;
            let on = parent.boundary_stress.iter().find(|l| {
                let q = parent.shape.faces[l.face as usize].map(|v| parent.vertices[v as usize]);
                let m = (q[1] - q[0]).cross(q[2] - q[0]);
                let unit = m.normalize_or_zero();
                if n.dot(m) <= 0.0 || p.iter().any(|x| (*x - q[0]).dot(unit).abs() > eps) {
                    return false;
                }
                // Within the triangle: on the inner side of each of its edges.
                (0..3).all(|e| (q[(e + 1) % 3] - q[e]).cross(centre - q[e]).dot(unit) >= -eps * (q[(e + 1) % 3] - q[e]).length())
            });
            if let Some(l) = on {
                self.boundary_stress.push(FaceStress { face: k as u32, stress: l.stress });
            }
        }
    }

    /// Whether the block is simply deformable.
    pub fn is_sdef(&self) -> bool {
        self.sdef.is_some()
    }

    /// The inertia tensor about the centroid in global axes: R I Rᵀ.
    pub fn inertia(&self) -> DMat3 {
        let r = DMat3::from_quat(self.orientation);
        r * self.inertia_ref * r.transpose()
    }

    /// Sets the density: mass and inertia scale with it.
    pub fn set_density(&mut self, old: f64, new: f64) {
        (self.mass, self.inertia_ref) = self.at_density(old, new);
        self.angular_velocity = self.angular_velocity_from(self.angular_momentum);
    }

    /// The mass and the inertia tensor (reference axes) the block takes when its material's
    /// density goes from `old` to `new`, the block left as it is (a density past f64's range is
    /// refused on them before it is set).
    pub fn at_density(&self, old: f64, new: f64) -> (f64, DMat3) {
        let inertia = if old > 0.0 {
            self.inertia_ref * (new / old)
        } else {
            // From a zero density the tensor is lost: rebuild it per unit density from the shape.
            super::geometry::mass_properties(&self.shape.vertices, &self.shape.faces).inertia * new
        };
        // A cracked simply-deformable block's piece weighs its share of its parent's mass, not
        // ρ·V (`split::cut`): its mass scales with the density too.
        let mass = if old > 0.0 && self.mass != old * self.volume { self.mass * (new / old) } else { new * self.volume };
        (mass, inertia)
    }

    /// ω = I⁻¹ L in global axes (zero for a block without inertia).
    pub fn angular_velocity_from(&self, l: DVec3) -> DVec3 {
        super::geometry::inertia_inverse(self.inertia()).map_or(DVec3::ZERO, |inv| inv * l)
    }

    /// Velocity of the material point at `p` (eq. 11): v + ω × (p − c), and ε̇·(p − c) of a
    /// simply-deformable block's strain rate.
    pub fn velocity_at(&self, p: DVec3) -> DVec3 {
        let r = p - self.centroid;
        let rigid = self.velocity + self.angular_velocity.cross(r);
        match &self.sdef {
            Some(s) => rigid + s.strain_velocity(r),
            None => rigid,
        }
    }

    /// Places the vertices from centroid and orientation (stage 2, the geometry update), each
    /// stretched by a simply-deformable block's strain: c + (I + ε)·R·x_ref.
    pub fn place_vertices(&mut self) {
        let r = DMat3::from_quat(self.orientation);
        let r = match &self.sdef {
            Some(s) => s.stretch() * r,
            None => r,
        };
        for (g, l) in self.vertices.iter_mut().zip(&self.shape.vertices) {
            *g = self.centroid + r * *l;
        }
        self.place_parts_with(r);
    }

    /// Places a concave block's parts' vertices from its centroid and orientation (as
    /// [`Block::place_vertices`] does with its own).
    pub fn place_parts(&mut self) {
        if !self.parts.is_empty() {
            let r = DMat3::from_quat(self.orientation);
            let r = match &self.sdef {
                Some(s) => s.stretch() * r,
                None => r,
            };
            self.place_parts_with(r);
        }
    }

    /// The parts move with the block, rigidly: c + R·(offset + x_part), `r` the block's map.
    #[inline]
    fn place_parts_with(&mut self, r: DMat3) {
        for p in &mut self.parts {
            for (g, l) in p.vertices.iter_mut().zip(&p.shape.vertices) {
                *g = self.centroid + r * (p.offset + *l);
            }
        }
    }

    /// The map of reference normals to global ones, up to length: R, or (I + ε)⁻¹·R for a
    /// simply-deformable block (normals map by the inverse transpose of the stretch, which is
    /// symmetric). None for a rigid block (its normals turn with the orientation alone).
    pub fn normal_map(&self) -> Option<DMat3> {
        self.sdef.as_ref().map(|s| s.stretch().inverse() * DMat3::from_quat(self.orientation))
    }

    /// The outward unit normal of face `f` in global axes.
    pub fn face_normal(&self, f: usize) -> DVec3 {
        match self.normal_map() {
            Some(m) => (m * self.shape.normals[f]).normalize(),
            None => self.orientation * self.shape.normals[f],
        }
    }

    /// Kinetic energy: ½mv² + ½ω·L.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.mass * self.velocity.length_squared() + 0.5 * self.angular_velocity.dot(self.angular_momentum)
    }

    /// The axis-aligned box around the vertices.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        Body::from(self).bounds()
    }
}

/// The six physical categories of contact (¶24), by the features of block 1 and block 2 that
/// touch; the degenerate contact is a neighbour link that does not touch (¶32).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Feature {
    Vertex,
    Edge,
    Face,
}

impl Feature {
    pub fn name(self) -> &'static str {
        match self {
            Feature::Vertex => "VERTEX",
            Feature::Edge => "EDGE",
            Feature::Face => "FACE",
        }
    }
}

/// What a logical contact (¶24, ¶32) is between: a vertex of one block against a face of the
/// other, or an edge of each. The ids are the blocks' own vertex numbers (from 0), so that the
/// shear force survives the contact's re-detection every cycle (STYLE.md 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum LogicalKind {
    /// A vertex of block 1 (`on_first`) or block 2 against the other's face.
    VertexFace { on_first: bool, vertex: u32 },
    /// An edge of block 1 (its two vertices, lower first) against one of block 2.
    EdgeEdge { first: (u32, u32), second: (u32, u32) },
}

/// A logical contact: where it is, its gap along the contact's normal (negative: overlap) and
/// its forces (Appendix B: KCX, KCFN, KCFV). The normal force is a scalar, compression positive;
/// the shear force a vector in global axes. Both act on block 2; block 1 takes their opposite.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Logical {
    pub kind: LogicalKind,
    pub point: DVec3,
    pub gap: f64,
    pub normal_force: f64,
    pub shear_force: DVec3,
    /// The gap at which its normal spring is unloaded: the overlap it had when it first
    /// appeared inside a loaded face (≤ 0), ratcheted up as it opens (eq. 16 as an increment),
    /// or where it took a swapped corner's force Fn, its gap then plus Fn/kn (which may be
    /// above 0: `contact::carry_swapped`). Saved after the model (`d3::restart::Offsets`,
    /// format 9).
    #[serde(skip)]
    pub offset: f64,
}

/// A contact between two blocks (indices `blocks`, the lower first): a real one with its
/// physical category, common-plane normal (from block 1 to block 2) and logical contacts, or a
/// degenerate one (a neighbour link; `category` None, no logical contacts).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Stable id, from 1, kept while the two blocks stay neighbours.
    pub id: u32,
    pub blocks: [u32; 2],
    /// The features of block 1 and block 2 in touch; None for a degenerate contact.
    pub category: Option<[Feature; 2]>,
    pub normal: DVec3,
    /// The area of the touching region (a face–face or face–edge contact's overlap polygon; 0
    /// for the others).
    pub area: f64,
    pub logical: Vec<Logical>,
    /// The convex parts of block 1 and block 2 in touch (`Block::parts`; 0 for a convex
    /// block): two concave blocks have a contact for each pair of their parts that are
    /// neighbours. Saved after the model (`d3::restart`, format 7).
    #[serde(skip)]
    pub parts: [u32; 2],
}

impl Contact {
    /// A contact standing in a list's place while the contact there is taken out (no logical
    /// contacts, so nothing allocated).
    pub fn vacant() -> Contact {
        Contact { id: 0, blocks: [0, 0], category: None, normal: DVec3::ZERO, area: 0.0, logical: Vec::new(), parts: [0, 0] }
    }

    /// `self` made a copy of `source` in the allocation it has, its logical contacts where
    /// `with_logical` (else none: `Model::keep_from`).
    pub fn copy_from(&mut self, source: &Contact, with_logical: bool) {
        let Contact { id, blocks, category, normal, area, logical, parts } = source;
        self.id = *id;
        self.blocks = *blocks;
        self.category = *category;
        self.normal = *normal;
        self.area = *area;
        if with_logical {
            self.logical.clone_from(logical);
        } else {
            self.logical.clear();
        }
        self.parts = *parts;
    }

    /// The type as PRINT names it, e.g. `VERTEX-FACE`, `DEGENERATE`.
    pub fn type_name(&self) -> String {
        match self.category {
            Some([a, b]) => format!("{}-{}", a.name(), b.name()),
            None => "DEGENERATE".into(),
        }
    }

    /// The normal force summed over the logical contacts.
    pub fn normal_force(&self) -> f64 {
        self.logical.iter().map(|l| l.normal_force).sum()
    }

    /// The shear force summed over the logical contacts.
    pub fn shear_force(&self) -> DVec3 {
        self.logical.iter().map(|l| l.shear_force).sum()
    }

    /// The point of the contact: the logical contacts' points weighted by their normal force
    /// (their mean where none carries force).
    pub fn point(&self) -> DVec3 {
        let total = self.normal_force();
        if total > 0.0 {
            self.logical.iter().map(|l| l.point * l.normal_force).sum::<DVec3>() / total
        } else if self.logical.is_empty() {
            DVec3::ZERO
        } else {
            self.logical.iter().map(|l| l.point).sum::<DVec3>() / self.logical.len() as f64
        }
    }
}

/// Rayleigh damping's constants (DAMPING): α mass-proportional, β stiffness-proportional.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Damping {
    pub alpha: f64,
    pub beta: f64,
    /// Internal mass damping of simply-deformable blocks' strain (DAMPING … INTERNAL, the
    /// report's ALPB). Saved with the extension array (`d3::restart`, format 5).
    #[serde(skip)]
    pub alpha_internal: f64,
}

/// The D3 model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Model {
    pub blocks: Vec<Block>,
    /// Material n is `materials[n - 1]`; grown as PROPERTY names them.
    pub materials: Vec<Material>,
    pub contacts: Vec<Contact>,
    pub gravity: DVec3,
    pub damping: Damping,
    /// FRACTION of the critical time step.
    pub frac: f64,
    pub cycle: u64,
    pub time: f64,
    /// Work done by gravity, loads, VELOCITY and the boundary conditions (BOUNDARY) since the start.
    pub external_work: f64,
    /// The energy dissipated and released since the start (the ledger's other terms).
    pub dissipated: Dissipation,
    /// The next contact id.
    pub next_contact_id: u32,
    /// The neighbour lists are stale (a command moved, added or changed blocks).
    pub neighbours_stale: bool,
}

impl Default for Model {
    fn default() -> Self {
        Model {
            blocks: Vec::new(),
            materials: Vec::new(),
            contacts: Vec::new(),
            gravity: DVec3::ZERO,
            damping: Damping::default(),
            frac: 0.1,
            cycle: 0,
            time: 0.0,
            external_work: 0.0,
            dissipated: Dissipation::default(),
            next_contact_id: 1,
            neighbours_stale: true,
        }
    }
}

/// The energy taken out of the blocks' motion and the contact springs since the start, summed
/// in a fixed order each cycle (so reruns repeat bit for bit).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Dissipation {
    /// By the mass-proportional damping force −αmv (and −αL on the rotation).
    pub mass_damping: f64,
    /// By the stiffness-proportional contact dashpots β·kn·u̇n, β·ks·u̇s.
    pub contact_damping: f64,
    /// By friction (slip at the Coulomb limit) and by shear springs lost as contacts open.
    pub friction: f64,
    /// Strain energy of logical contacts that went while loaded (the touching region changed).
    pub released: f64,
}

/// The energy ledger of a state (as 2D's, `udec::model::timestep::Energies`). With E₀ the
/// kinetic + strain energy at START, the explicit cycle keeps
///
///   E_kin + E_strain + W_mass_damping + W_contact_damping + W_friction + E_released = E₀ + W_external
///
/// up to the O(Δt) errors of central differences; [`Energies::ledger`] is the left side minus
/// W_external, which should stay at E₀ (0 from rest).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energies {
    /// ½mv² + ½ω·L of the free blocks, brought to the whole step by half a step of the current
    /// force and moment (velocities live at t − Δt/2, positions and forces at t).
    pub kinetic: f64,
    /// Fn²/2kn + |Fs|²/2ks over the logical contacts.
    pub strain: f64,
    /// Work of gravity, loads, VELOCITY and BOUNDARY since START: the energy put in.
    pub external_work: f64,
    pub mass_damping: f64,
    pub contact_damping: f64,
    pub friction: f64,
    pub released: f64,
}

impl Energies {
    /// Everything dissipated: mass and contact damping plus friction.
    pub fn dissipated(&self) -> f64 {
        self.mass_damping + self.contact_damping + self.friction
    }

    /// E_kin + E_strain + dissipated + released − W_external: constant in an exact bookkeeping.
    pub fn ledger(&self) -> f64 {
        self.kinetic + self.strain + self.dissipated() + self.released - self.external_work
    }

    /// The largest term, the scale a balance error is measured against.
    pub fn scale(&self) -> f64 {
        [self.kinetic, self.strain, self.external_work, self.mass_damping, self.contact_damping, self.friction, self.released]
            .iter()
            .fold(0.0f64, |a, b| a.max(b.abs()))
    }
}

/// What the critical step reads of a block, gathered in one pass (`Model::critical_timestep`):
/// its centroid, whether it gives at a contact, 1/m, its least principal moment and, for a
/// simply-deformable block, the least principal second moment of its mass. The step's sums
/// over the logical contacts (added in order, on one thread) then read these few words a
/// block, not the block, and divide once less.
pub struct Give {
    pub centroid: DVec3,
    pub unyielding: bool,
    pub inverse_mass: f64,
    pub least: f64,
    pub least_second: f64,
}

impl Give {
    /// The block's compliance at a lever arm r (r² given): 1/m + r²/I_min (+ r²/M_min for a
    /// simply-deformable block); none for an unyielding block. Twin of `compliance` in
    /// shaders/d3/critical_rows.wgsl.
    pub fn compliance(&self, r2: f64) -> f64 {
        if self.unyielding {
            return 0.0;
        }
        let strain = if self.least_second > 0.0 { r2 / self.least_second } else { 0.0 };
        self.inverse_mass + if self.least > 0.0 { r2 / self.least } else { 0.0 } + strain
    }
}

impl Model {
    /// `self` made a copy of `source` as the run driver's last good state (every hundred cycles),
    /// in place: the blocks copied in parallel into the allocations `self` has (their shapes
    /// shared), the contacts with their logical contacts where `with_logical`, else without (the
    /// GPU's, whose device checkpoint holds them: `d3::gpu`, "The energy check and the last good
    /// state"). `Model::clone_from` made every block's and contact's lists anew: at 10⁵ bricks
    /// 0.1–0.3 s of each check here, more than the hundred cycles it followed on a GPU.
    pub fn keep_from(&mut self, source: &Model, with_logical: bool) {
        let Model { blocks, materials, contacts, gravity, damping, frac, cycle, time, external_work, dissipated, next_contact_id, neighbours_stale } = source;
        if self.blocks.len() != blocks.len() {
            self.blocks.clone_from(blocks);
        } else {
            self.blocks.par_iter_mut().zip(blocks).with_min_len(super::grain::BLOCK).for_each(|(kept, b)| kept.copy_from(b));
        }
        self.materials.clone_from(materials);
        self.contacts.truncate(contacts.len());
        let common = self.contacts.len();
        self.contacts.par_iter_mut().zip(&contacts[..common]).with_min_len(super::grain::CONTACT).for_each(|(kept, c)| kept.copy_from(c, with_logical));
        self.contacts.extend(contacts[common..].iter().map(|c| {
            let mut kept = Contact { id: 0, blocks: [0; 2], category: None, normal: DVec3::ZERO, area: 0.0, logical: Vec::new(), parts: [0; 2] };
            kept.copy_from(c, with_logical);
            kept
        }));
        self.gravity = *gravity;
        self.damping = *damping;
        self.frac = *frac;
        self.cycle = *cycle;
        self.time = *time;
        self.external_work = *external_work;
        self.dissipated = *dissipated;
        self.next_contact_id = *next_contact_id;
        self.neighbours_stale = *neighbours_stale;
    }

    /// Material `n` (the default, all zero, where not given).
    pub fn material(&self, n: u32) -> Material {
        material_of(&self.materials, n)
    }

    /// The law's parameters of a contact: its law block's material ([`law_block`]), by its
    /// constitutive number's law ([`Material::contact_law`]) over the touching region the contact
    /// holds.
    pub fn contact_material(&self, c: &Contact) -> Material {
        let (mat, joint) = law_material(&self.blocks, &self.materials, c.blocks);
        mat.contact_law(joint, c.area, c.logical.len())
    }

    /// The contact-forming distance: a logical contact whose gap is within it is kept (its
    /// shear history with it); and the margin of the neighbour lists (¶26) is twice it.
    pub fn contact_tolerance(&self) -> f64 {
        let r = self.blocks.iter().map(|b| b.shape.radius).fold(f64::INFINITY, f64::min);
        if r.is_finite() {
            0.02 * r
        } else {
            0.0
        }
    }

    /// The critical time step (the FRACTION of it is the run's), renewed every cycle from the
    /// contacts there are, as 3DEC and PFC do (the report gives no rule for D3: Part III's law of
    /// motion, ¶17, is UDEC's central differences, stable for Δt < 2/ω_max).
    ///
    /// UDEC takes 2√(m/k) for the lightest block on the stiffest spring: one spring per block.
    /// A D3 block has several logical contacts at once (four at a face–face contact, eight
    /// between two faces of a stack, ¶24) acting in parallel, and its rotation gives at a vertex
    /// as its translation does, so ω_max is bounded here as in 2D's `stable_frac_estimate`, by
    /// Gershgorin's theorem on the mass-normalised stiffness, block by block. A logical contact at
    /// the point p with springs kn (normal) and ks (shear) moves block i by a compliance of at most
    /// a_i = 1/m_i + |p − c_i|²/I_min,i (its translation, and its rotation about its softest
    /// principal axis, the lever arm |p − c_i|), so its 3 × 6 block of the stiffness has norm at
    /// most k·a_i with k = max(kn, ks), and the coupling with block j at most k·√(a_i a_j) (0 for a
    /// fixed block j). Then
    ///
    ///   ω_max² ≤ max over free blocks i of Σ_{logical contacts of i} k (a_i + √(a_i a_j)),
    ///
    /// which for a block translating against fixed neighbours is UDEC/3DEC's Σk/m: the step
    /// 2√(m/Σk). Before a block has contacts (and as a floor after) the row is that of one spring
    /// of the stiffest material in use at the block's farthest vertex against a fixed block,
    /// k_max·(1/m + R²/I_min), so FRACTION means the same from the first cycle. Stiffness-
    /// proportional damping narrows the range to (2/ω)(√(1+ξ²) − ξ), ξ = βω/2, as in 2D. At
    /// FRACTION 1 the step is at the bound, which lies at or below the true limit: the D3 cases
    /// run stable there (`blockdem verify`, README). A block held by BOUNDARY VELOCITY gives no
    /// more than a fixed one (its neighbours meet a moving wall); where every block is fixed or
    /// held, the held ones are bounded as free ones, so that their prescribed motion is still
    /// followed at the contacts' pace. Returns None when no free or held block has mass or no
    /// stiffness is defined.
    pub fn critical_timestep(&self) -> Option<f64> {
        self.critical_timestep_with(true).or_else(|| self.critical_timestep_with(false))
    }

    /// The stiffest contact a block's material can give (`k_max` of the critical step's rows):
    /// KN, KS, and a joint-law block's face contact, stiffer the larger its area, no more than
    /// its radius squared (a touching region shared by three or more corners). 0: none.
    pub fn stiffest_contact(&self) -> f64 {
        self.blocks.iter().fold(0.0f64, |k, b| {
            let m = self.material(b.material);
            let joint = if joint_contacts(b.constitutive) { m.jkn.max(m.jks) * b.shape.radius * b.shape.radius } else { 0.0 };
            k.max(m.kn).max(m.ks).max(joint)
        })
    }

    /// What the critical step reads of each block ([`Give`]), a held block counted as
    /// unyielding (`held_stiff`) or free. Each free block's least principal moment (zero for a
    /// fixed or massless block, which does not give at a contact, nor a held one: BOUNDARY
    /// VELOCITY moves it whatever the forces on it, its strain held as it is, so it is a moving
    /// wall to its neighbours) and, for a simply-deformable block, the least principal second
    /// moment of its mass, M_min: it gives at a lever arm r by its strain too, by r²/M_min (no
    /// strain mode has less inertia). Block by block, in parallel (the eigenvalues are most of
    /// this).
    pub fn step_gives(&self, held_stiff: bool) -> Vec<Give> {
        let unyielding = |b: &Block| b.fixed || (held_stiff && b.held) || b.mass <= 0.0;
        self.blocks
            .par_iter()
            .with_min_len(super::grain::BLOCK)
            .map(|b| {
                let stiff = unyielding(b);
                let least = if stiff { 0.0 } else { least_eigenvalue(b.inertia_ref) };
                let least_second = if b.is_sdef() && !stiff { least_eigenvalue(sdef::second_moments(b.inertia_ref)) } else { 0.0 };
                Give { centroid: b.centroid, unyielding: stiff, inverse_mass: 1.0 / b.mass, least, least_second }
            })
            .collect()
    }

    /// The critical step of the stiffest mode λ (the Gershgorin bound's largest row): 2/ω, less
    /// with stiffness-proportional damping β: 2/(ω(√(1 + ξ²) + ξ)), ξ = βω/2. None where λ is
    /// not a positive number.
    pub fn critical_step_of(&self, lambda: f64) -> Option<f64> {
        if !(lambda > 0.0 && lambda.is_finite()) {
            return None;
        }
        let omega = lambda.sqrt();
        let xi = 0.5 * self.damping.beta * omega;
        Some(2.0 / (omega * ((1.0 + xi * xi).sqrt() + xi)))
    }

    /// [`Model::critical_timestep`], a held block counted as unyielding (`held_stiff`) or free.
    fn critical_timestep_with(&self, held_stiff: bool) -> Option<f64> {
        let k_max = self.stiffest_contact();
        if k_max <= 0.0 {
            return None;
        }
        let gives = self.step_gives(held_stiff);
        // The compliance of block i at a lever arm r (r² given).
        let compliance = |i: usize, r2: f64| -> f64 { gives[i].compliance(r2) };
        let mut row: Vec<f64> = (0..self.blocks.len()).map(|i| k_max * compliance(i, self.blocks[i].shape.radius.powi(2))).collect();
        // Each logical contact's terms on its two blocks' rows, k(a_i + √(a_i a_j)) and
        // k(a_j + √(a_i a_j)), worked out in parallel into one list in the contacts' order (each
        // contact its own stretch of it), then added to the rows in that order: bit for bit the
        // sums of one pass in order, with the square roots and divisions shared out.
        let mut stretches: Vec<&mut [(f64, f64)]> = Vec::with_capacity(self.contacts.len());
        let mut terms = vec![(0.0f64, 0.0f64); self.contacts.iter().map(|c| c.logical.len()).sum()];
        let mut rest = terms.as_mut_slice();
        for c in &self.contacts {
            let (stretch, after) = rest.split_at_mut(c.logical.len());
            stretches.push(stretch);
            rest = after;
        }
        self.contacts.par_iter().zip(stretches.par_iter_mut()).with_min_len(super::grain::SUMS).for_each(|(c, stretch)| {
            if c.logical.is_empty() {
                return;
            }
            let mat = self.contact_material(c);
            let k = mat.kn.max(mat.ks);
            let [i, j] = c.blocks.map(|b| b as usize);
            for (l, t) in c.logical.iter().zip(stretch.iter_mut()) {
                let ai = compliance(i, (l.point - gives[i].centroid).length_squared());
                let aj = compliance(j, (l.point - gives[j].centroid).length_squared());
                let shared = (ai * aj).sqrt();
                *t = (k * (ai + shared), k * (aj + shared));
            }
        });
        drop(stretches);
        let mut contact_rows = vec![0.0f64; self.blocks.len()];
        let mut next = terms.iter();
        for c in &self.contacts {
            let [i, j] = c.blocks.map(|b| b as usize);
            for (ti, tj) in next.by_ref().take(c.logical.len()) {
                contact_rows[i] += ti;
                contact_rows[j] += tj;
            }
        }
        for (r, c) in row.iter_mut().zip(&contact_rows) {
            *r = r.max(*c);
        }
        let lambda = row.iter().copied().fold(0.0, f64::max);
        self.critical_step_of(lambda)
    }

    /// The time step the run takes: FRACTION × the critical one, and no more than the
    /// simply-deformable blocks' own limit ([`Model::internal_timestep`]).
    pub fn timestep(&self) -> f64 {
        self.timestep_of(self.critical_timestep())
    }

    /// [`Model::timestep`] of the critical step `critical` (None: no contact stiffness).
    pub fn timestep_of(&self, critical: Option<f64>) -> f64 {
        let dt = critical.map_or(0.0, |dt| self.frac * dt);
        match self.internal_timestep() {
            Some(limit) if dt > 0.0 => dt.min(limit),
            _ => dt,
        }
    }

    /// The simply-deformable blocks' own limit on the step (`d3::sdef`, "Time step"): √(M_min/k)
    /// over the free SDEF blocks (not a held one, whose strain is held), half the stiffest internal mode's 2/ω, with M_min the least
    /// principal second moment of the block's mass and k = 3K·V. None without such blocks.
    pub fn internal_timestep(&self) -> Option<f64> {
        self.blocks
            .iter()
            .filter(|b| b.is_sdef() && !b.fixed && !b.held && b.mass > 0.0)
            .filter_map(|b| {
                let k = sdef::internal_stiffness(&self.material(b.material).elastic(), b.volume);
                let m = least_eigenvalue(sdef::second_moments(b.inertia_ref));
                (k > 0.0 && m > 0.0).then(|| (m / k).sqrt())
            })
            .reduce(f64::min)
    }

    /// The energy ledger now (see [`Energies`]).
    pub fn energies(&self) -> Energies {
        self.energies_at(None, self.timestep())
    }

    /// The energy ledger now, the kinetic energy brought to the whole step with the time step
    /// `dt` (the model's, [`Model::timestep`]: given where the caller has it), the contacts'
    /// strain energy (the sum of [`contact_energy`] over them) taken as `contact_strain` where
    /// given: the GPU's energy check sums it on the device, where the contacts' state is
    /// (`contact_energy` in shaders/d3/contact_energy.wgsl), and the rest from the blocks it
    /// reads back after each batch.
    pub fn energies_at(&self, contact_strain: Option<f64>, dt: f64) -> Energies {
        let h = 0.5 * dt;
        let kinetic: f64 = self
            .blocks
            .iter()
            .filter(|b| !b.fixed && b.mass > 0.0)
            .map(|b| {
                // A held block (BOUNDARY VELOCITY) moves at its velocity at every step.
                if b.held {
                    return b.kinetic_energy();
                }
                let v = b.velocity + b.force / b.mass * h;
                let l = b.angular_momentum + b.moment * h;
                let at_t = 0.5 * b.mass * v.length_squared() + 0.5 * l.dot(b.angular_velocity_from(l));
                // Where half a step overflows, the half-step's energy keeps the ledger a number.
                if at_t.is_finite() {
                    at_t
                } else {
                    b.kinetic_energy()
                }
            })
            .sum();
        // The simply-deformable blocks' strain modes: their kinetic energy at the whole step and
        // the strain energy of their internal stress (`d3::sdef`).
        let mut internal_kinetic = 0.0;
        let mut strain = 0.0;
        for b in &self.blocks {
            let Some(s) = &b.sdef else { continue };
            strain += sdef::strain_energy(s, b.volume);
            if !b.fixed && !b.held && b.mass > 0.0 {
                let j = sdef::strain_inertia(sdef::second_moments(b.inertia()));
                internal_kinetic += sdef::internal_kinetic_energy(sdef::rate_at_whole_step(s, b.volume, j, 2.0 * h), j);
            }
        }
        let kinetic: f64 = kinetic + internal_kinetic;
        let strain = match contact_strain {
            Some(contacts) => strain + contacts,
            None => self.contacts.iter().fold(strain, |sum, c| add_contact_energy(sum, c, &self.contact_material(c))),
        };
        let d = self.dissipated;
        Energies {
            kinetic,
            strain,
            external_work: self.external_work,
            mass_damping: d.mass_damping,
            contact_damping: d.contact_damping,
            friction: d.friction,
            released: d.released,
        }
    }
}

/// The strain energy of contact `c`'s springs under the law `m` (its law block's material,
/// [`Model::contact_material`]): ½Fn²/kn + ½|Fs|²/ks over its logical contacts. Twin of
/// `contact_energy` (shaders/d3/contact_energy.wgsl), which sums it on the device.
pub fn contact_energy(c: &Contact, m: &Material) -> f64 {
    add_contact_energy(0.0, c, m)
}

/// `sum` plus [`contact_energy`] of `c`, term by term (the ledger's order of additions).
fn add_contact_energy(sum: f64, c: &Contact, m: &Material) -> f64 {
    let mut strain = sum;
    for l in &c.logical {
        if m.kn > 0.0 {
            strain += 0.5 * l.normal_force * l.normal_force / m.kn;
        }
        if m.ks > 0.0 {
            strain += 0.5 * l.shear_force.length_squared() / m.ks;
        }
    }
    strain
}

/// Material `n` (numbered from 1) of `materials`, the default where there is none: the lookup of
/// [`Model::material`] for a caller that holds the blocks mutably (the CPU's block pass).
pub fn material_of(materials: &[Material], n: u32) -> Material {
    materials.get(n as usize - 1).copied().unwrap_or_default()
}
