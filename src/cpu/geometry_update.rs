//! Stage 2: geometry update. A rigid block's corners and rounding-circle centres follow its
//! centroid and rotation exactly: x = c + R(θ)·x_local (eq. 11 integrated without drift), so a
//! rigid block never distorts however long it runs. Each edge's direction and length are then
//! measured once, for all the contacts that slide along it.

use crate::model::{Block, Corner};

/// Places the corners of one block in world coordinates.
#[inline]
pub fn geometry_update(block: &Block, corners: &mut [Corner]) {
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
