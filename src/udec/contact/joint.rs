//! Which contacts are joints, and the law a joint follows (SL-85-1 Appendix A ¶5, Table A1).
//!
//! ¶5: "UDEC recognizes edge-to-edge contacts between blocks as joints, and refers to a
//! constitutive model that works in terms of stresses rather than forces. The joint logic is
//! used for those blocks or joints that are given constitutive number 2 or 5 [Table A1: 4 too]
//! ... A joint reverts back to being a contact if it no longer consists of planar block faces in
//! opposition. The point-contact logic is also used if incremental normal deformation using the
//! joint parameters would be greater than that using the contact parameters: i.e. if
//! sn_j·l_j < sn."
//!
//! As in UDEC, an edge-to-edge contact is not a contact of its own: it is the two corner
//! contacts at the ends of the faces' common length l_j, each carrying half of it, l_c = l_j/2
//! (`Contact::joint_length`). Such a corner contact follows the joint law with stiffnesses
//! JKN·l_c, JKS·l_c (JKN, JKS in stress/displacement), cohesive strength JCOH·l_c and friction
//! JFRIC; the force–displacement law itself is the point contact's (eqs. 16–20,
//! [`super::law`]), so the shear history (eq. 17 is incremental) carries over when the law
//! changes: the shear force takes the new stiffness from its next increment on and the Coulomb
//! cap (eq. 20) the new strength.
//!
//! The decision is stage 7's (the CPU's, for both backends): at creation and whenever the
//! contact update re-examines the contact (its blocks moved past half the update tolerance, or
//! a full detection at the start of a CYCLE that changed anything). A block that turns enough to
//! break the faces' opposition has moved by its radius times the turn, far past the tolerance,
//! so the revert waits at most for the update that motion triggers (the report is silent on
//! when UDEC checked; its contact update is where it re-classified contacts).

pub use crate::udec::model::constitutive::law_parameters;
use crate::udec::model::constitutive::{Constitutive, ContactLaw};
use crate::udec::model::geometry::{dot, sub};
use crate::udec::model::{Corner, Feature, Material};

/// The largest angle (radians) between two faces that still counts as "in opposition": 1°. The
/// report gives none; two faces of a settled stack or a split meet at round-off angles, and a
/// block turned by more than a degree on its neighbour is rocking on a corner.
pub const OPPOSITION_ANGLE: f64 = std::f64::consts::PI / 180.0;

/// The common length l_j of the faces in opposition at a contact of corner `i` of block 1 (its
/// corners `corners1`, counter-clockwise, as stage 2 placed them) against feature `feature` of
/// block 2 (`corners2`): the longest overlap, projected on block 2's edge, of an edge of block 1
/// at the corner with an edge of block 2 at the feature (the edge itself, or either edge at a
/// corner's arc) whose direction is opposite within [`OPPOSITION_ANGLE`]. 0 when no pair of faces
/// is in opposition (a corner on a face at an angle, two corners touching tip to tip, faces in
/// line but not overlapping).
///
/// Both outlines run counter-clockwise, so two faces pressed together run in opposite
/// directions; both edges pass through the touch point, so anti-parallel edges there lie on one
/// line, block 1's interior on one side and block 2's on the other.
pub fn opposed_length(corners1: &[Corner], i: usize, corners2: &[Corner], feature: Feature) -> f64 {
    let (n1, n2) = (corners1.len(), corners2.len());
    if n1 < 3 || n2 < 3 {
        return 0.0;
    }
    let cos_limit = OPPOSITION_ANGLE.cos();
    let k = (feature / 2) as usize % n2;
    let edges1 = [i % n1, (i + n1 - 1) % n1];
    let edges2 = if feature % 2 == 1 { [k, k] } else { [k, (k + n2 - 1) % n2] };
    let mut best: f64 = 0.0;
    for &a in &edges1 {
        for &b in &edges2 {
            let (ea, eb) = (&corners1[a], &corners2[b]);
            if dot(ea.edge_dir, eb.edge_dir) > -cos_limit {
                continue;
            }
            let along = |p: [f64; 2]| dot(sub(p, eb.position), eb.edge_dir);
            let (s0, s1) = (along(ea.position), along(corners1[(a + 1) % n1].position));
            let overlap = s0.max(s1).min(eb.edge_length) - s0.min(s1).max(0.0);
            best = best.max(overlap);
        }
    }
    best
}

/// Whether material `mat` gives a joint its law: both joint stiffnesses JKN and JKS. A joint
/// constitutive number on a material without them runs as point contacts ("UDEC will still
/// refer to contact parameters", ¶5; the executor says so once).
#[inline]
pub fn has_joint_law(mat: &Material) -> bool {
    mat.joint.kn > 0.0 && mat.joint.ks > 0.0
}

/// The length of joint a contact of constitutive number `constitutive` and material `mat` carries
/// when its faces in opposition share the length `opposed` (`opposed_length`): l_j/2 when it
/// follows the joint law, 0 for a point contact: a point-contact number, no faces in opposition,
/// no joint stiffnesses, or sn_j·l_j < sn (¶5: the joint would be softer in the normal
/// direction than the point contact).
pub fn joint_share(constitutive: u32, mat: &Material, opposed: f64) -> f64 {
    let joint = Constitutive::from_number(constitutive).is_some_and(|c| c.contact == ContactLaw::Joint);
    if !joint || opposed.is_nan() || opposed <= 0.0 || !has_joint_law(mat) || mat.joint.kn * opposed < mat.contact.kn {
        return 0.0;
    }
    0.5 * opposed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::udec::model::{ContactMaterial, JointMaterial};

    /// Corners of a counter-clockwise polygon placed as stage 2 leaves them (positions, edges).
    fn outline(points: &[[f64; 2]]) -> Vec<Corner> {
        let n = points.len();
        (0..n)
            .map(|k| {
                let (p, q) = (points[k], points[(k + 1) % n]);
                let len = (q[0] - p[0]).hypot(q[1] - p[1]);
                Corner {
                    block: 0,
                    local: p,
                    circle_local: p,
                    radius: 0.0,
                    round: 0.0,
                    position: p,
                    circle: p,
                    edge_dir: [(q[0] - p[0]) / len, (q[1] - p[1]) / len],
                    edge_length: len,
                    edge_material: 0,
                    edge_constitutive: 0,
                }
            })
            .collect()
    }

    fn square(x: f64, y: f64, w: f64, turn: f64) -> Vec<Corner> {
        let (c, s) = (turn.cos(), turn.sin());
        let (cx, cy) = (x + 0.5 * w, y + 0.5 * w);
        let at = |dx: f64, dy: f64| [cx + c * dx - s * dy, cy + s * dx + c * dy];
        let h = 0.5 * w;
        outline(&[at(-h, -h), at(h, -h), at(h, h), at(-h, h)])
    }

    /// A block of width 1 on a block of width 2: its bottom corners on the base's top edge
    /// (feature 2·2+1) share the whole width; on a block offset by half, the overlap; turned by
    /// two degrees, none; corner to corner in line, none.
    #[test]
    fn faces_in_opposition_share_their_overlap() {
        let base = square(0.0, -2.0, 2.0, 0.0); // top edge is edge 2 (corner 2 → 3)
        let top = square(0.5, 0.0, 1.0, 0.0);
        assert!((opposed_length(&top, 0, &base, 5) - 1.0).abs() < 1e-12);
        assert!((opposed_length(&top, 1, &base, 5) - 1.0).abs() < 1e-12);
        let offset = square(1.5, 0.0, 1.0, 0.0);
        assert!((opposed_length(&offset, 0, &base, 5) - 0.5).abs() < 1e-12);
        let turned = square(0.5, 0.0, 1.0, 2.0f64.to_radians());
        assert_eq!(opposed_length(&turned, 0, &base, 5), 0.0);
        let nearly = square(0.5, 0.0, 1.0, 0.5f64.to_radians());
        assert!(opposed_length(&nearly, 0, &base, 5) > 0.99);
        // Tip to tip: the base's top-right corner (arc, feature 2·2) against the corner of a
        // block beside and above it.
        let beside = square(2.0, 0.0, 1.0, 0.0);
        assert_eq!(opposed_length(&beside, 0, &base, 4), 0.0);
        // Equal widths, corner on corner (the arc of the base's top-left corner, feature 2·3).
        let equal = square(0.0, 0.0, 2.0, 0.0);
        assert!((opposed_length(&equal, 0, &base, 6) - 2.0).abs() < 1e-12);
    }

    /// Table A1's point numbers, no faces, no joint stiffnesses and ¶5's sn_j·l_j < sn give a
    /// point contact; a joint number on faces in opposition half the common length.
    #[test]
    fn the_joint_law_needs_a_joint_number_faces_and_enough_stiffness() {
        let mat = Material {
            contact: ContactMaterial { kn: 1e9, ks: 1e9, cohesion: 0.0, friction: 0.5 },
            joint: JointMaterial { kn: 2e9, ks: 1e9, cohesion: 1e5, friction: 0.7 },
            ..Default::default()
        };
        assert_eq!(joint_share(2, &mat, 1.0), 0.5);
        assert_eq!(joint_share(4, &mat, 1.0), 0.5);
        assert_eq!(joint_share(5, &mat, 1.0), 0.5);
        assert_eq!(joint_share(1, &mat, 1.0), 0.0);
        assert_eq!(joint_share(3, &mat, 1.0), 0.0);
        assert_eq!(joint_share(2, &mat, 0.0), 0.0);
        assert_eq!(joint_share(2, &mat, 0.4), 0.0, "2e9 × 0.4 < 1e9: the point law");
        let no_joint = Material { joint: JointMaterial::default(), ..mat };
        assert_eq!(joint_share(2, &no_joint, 1.0), 0.0);
        let p = law_parameters(0.5, &mat);
        assert_eq!((p.kn, p.ks, p.cohesion, p.friction), (1e9, 5e8, 5e4, 0.7));
        assert_eq!(law_parameters(0.0, &mat), mat.contact);
    }
}
