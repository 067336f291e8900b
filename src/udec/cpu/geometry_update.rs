//! Stage 2: geometry update. A rigid block's corners and rounding-circle centres follow its
//! centroid and rotation exactly (x = c + R(θ)·x_local, eq. 11 integrated without drift); the
//! placement itself is the model's own, [`crate::udec::model::corners::place_corners`], which BLOCK,
//! SPLIT and cracking use too, so that the CPU stage and the model can never disagree.

use crate::udec::model::corners::{place_corners, place_corners_strained};
use crate::udec::model::{Block, Corner};

/// Places the corners of one block in world coordinates (stage 2 on the CPU).
#[inline]
pub fn geometry_update(block: &Block, corners: &mut [Corner]) {
    place_corners(block, corners);
}

/// Places the corners of a simply-deformable block, stretched by its strain (stage 2 on the CPU;
/// `model::corners::place_corners_strained`).
#[inline]
pub fn geometry_update_strained(block: &Block, strain: [f64; 3], corners: &mut [Corner]) {
    place_corners_strained(block, strain, corners);
}
