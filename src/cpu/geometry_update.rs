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
        corners[k].edge_dir = [ex / len, ey / len];
        corners[k].edge_length = len;
    }
}
