//! Where a block's corners are.
//!
//! A rigid block's corners and rounding-circle centres follow its centroid and rotation exactly:
//! x = c + R(θ)·x_local (eq. 11 integrated without drift), so a rigid block never distorts however
//! long it runs. Each edge's direction and length are then measured once, for all the contacts
//! that slide along it. This is stage 2 of the cycle (`cpu::geometry_update`, and
//! `shaders/udec/geometry_update.wgsl` on the GPU) and what BLOCK, SPLIT and a crack use to place new
//! corners.

use super::geometry::{dot, sub};
use super::{Block, Corner};

/// Places the corners of one block in world coordinates.
#[inline]
pub fn place_corners(block: &Block, corners: &mut [Corner]) {
    let (s, c) = block.rotation.sin_cos();
    let [cx, cy] = block.centroid;
    for corner in corners.iter_mut() {
        let [lx, ly] = corner.local;
        corner.position = [cx + c * lx - s * ly, cy + s * lx + c * ly];
        let [qx, qy] = corner.circle_local;
        corner.circle = [cx + c * qx - s * qy, cy + s * qx + c * qy];
    }
    let n = corners.len();
    for k in 0..n {
        let (p0, p1) = (corners[k].position, corners[(k + 1) % n].position);
        let (ex, ey) = (p1[0] - p0[0], p1[1] - p0[1]);
        let len = (ex * ex + ey * ey).sqrt();
        corners[k].edge_dir = if len > 0.0 {
            [ex / len, ey / len]
        } else {
            // The edge is lost in the round-off of its corners' positions (a 5 cm block flung to
            // 1e147 m): its direction is the body frame's, turned, not 0/0, which left a model
            // that RESTART refuses.
            let (l0, l1) = (corners[k].local, corners[(k + 1) % n].local);
            let (lx, ly) = (l1[0] - l0[0], l1[1] - l0[1]);
            let l = (lx * lx + ly * ly).sqrt();
            [(c * lx - s * ly) / l, (s * lx + c * ly) / l]
        };
        corners[k].edge_length = len;
    }
}

/// A point `r` from a block's centroid stretched by the block's strain `e` (11, 12, 22): (I + ε)·r.
/// The identity for a rigid block's zero strain (bit for bit: `r + 0·r`).
#[inline]
pub fn strained(e: [f64; 3], r: [f64; 2]) -> [f64; 2] {
    [r[0] + e[0] * r[0] + e[1] * r[1], r[1] + e[1] * r[0] + e[2] * r[1]]
}

/// Places the corners of a simply-deformable block: x = c + (I + ε)·R(θ)·x_local, the rigid
/// placement stretched by the block's uniform strain (`sdef`). Each rounding circle keeps its
/// radius and is fitted again tangent to its corner's two strained edges (its centre on the
/// bisector, radius / cos(½ turn) from the corner, as `geometry::corner_rounding` placed it), so
/// that the rounded boundary's straight parts move with the strained edges: a contact on them
/// then moves at ε̇·r, r from the centroid to the contact point, the lever arm of the applied
/// stress (`sdef`), and the contact force's work on the strain is what its spring stores.
/// cos(½ turn) is √((1 + cos turn)/2) (the turn lies in (−π, π)), as the GPU's twin
/// (`geometry_update_strained`, which has no inverse trigonometry in f64) takes it.
#[inline]
pub fn place_corners_strained(block: &Block, strain: [f64; 3], corners: &mut [Corner]) {
    let (s, c) = block.rotation.sin_cos();
    let [cx, cy] = block.centroid;
    for corner in corners.iter_mut() {
        let [lx, ly] = corner.local;
        let r = strained(strain, [c * lx - s * ly, s * lx + c * ly]);
        corner.position = [cx + r[0], cy + r[1]];
    }
    fit_circles_to_edges(corners);
}

/// Each rounding circle of corners already placed fitted again tangent to its corner's two
/// edges (its radius kept), and each edge's direction and length measured: the second half of
/// [`place_corners_strained`], which [`place_corners_fdef`] shares.
#[inline]
fn fit_circles_to_edges(corners: &mut [Corner]) {
    let n = corners.len();
    if n == 0 {
        return;
    }
    // Each edge is measured once: edge k−1's vector and length, from the last step (the same
    // difference of the same two positions, so the same bits as measuring it again).
    let mut e1 = sub(corners[0].position, corners[n - 1].position);
    let mut l1 = dot(e1, e1).sqrt();
    for k in 0..n {
        let (p, next) = (corners[k].position, corners[(k + 1) % n].position);
        let e2 = sub(next, p);
        let l2 = dot(e2, e2).sqrt();
        corners[k].circle = p;
        if corners[k].radius > 0.0 && l1 > 0.0 && l2 > 0.0 {
            let half = (0.5 * (1.0 + dot(e1, e2) / (l1 * l2))).max(0.0).sqrt();
            let bis = [e2[0] / l2 - e1[0] / l1, e2[1] / l2 - e1[1] / l1];
            let lb = dot(bis, bis).sqrt();
            if lb > 0.0 && half > 0.0 {
                let offset = corners[k].radius / half;
                corners[k].circle = [p[0] + bis[0] / lb * offset, p[1] + bis[1] / lb * offset];
            }
        }
        if l2 > 0.0 {
            corners[k].edge_dir = [e2[0] / l2, e2[1] / l2];
        }
        corners[k].edge_length = l2;
        (e1, l1) = (e2, l2);
    }
}

/// Places the corners of a zoned fully-deformable block on its boundary grid points (grid point
/// k is corner k, `model::fdef`) and refits their rounding circles as a strained block's are; the
/// block's centroid and velocity become its grid points' mass means, its area the outline's, its
/// body frame the world's turned by nothing (each corner's `local` its offset from the centroid
/// now), so that PRINT, SET ROUND and the broad phase see the deformed block.
pub fn place_corners_fdef(block: &mut Block, f: &super::fdef::Fdef, corners: &mut [Corner]) {
    let (c, v, _) = f.mass_centre();
    block.centroid = c;
    block.velocity = v;
    block.rotation = 0.0;
    block.angular_velocity = 0.0;
    let mut radius: f64 = 0.0;
    for (corner, g) in corners.iter_mut().zip(&f.gridpoints) {
        corner.position = g.position;
        corner.local = sub(g.position, c);
        radius = radius.max(dot(corner.local, corner.local));
    }
    block.radius = radius.sqrt();
    // `geometry::signed_area` of the corners' offsets, without collecting them.
    block.area = if corners.len() < 3 {
        0.0
    } else {
        let o = corners[0].local;
        let twice: f64 = corners[1..].windows(2).map(|w| super::geometry::cross(sub(w[0].local, o), sub(w[1].local, o))).fold(0.0, |a, x| a + x);
        0.5 * twice
    };
    fit_circles_to_edges(corners);
    for corner in corners.iter_mut() {
        corner.circle_local = sub(corner.circle, c);
    }
}
