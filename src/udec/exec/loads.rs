//! Loads and boundary conditions: LOAD, FIX, FREE, VELOCITY, LINK (GRAVITY is set in the
//! dispatch, `Executor::execute`).

use super::{Executor, RunError};
use crate::udec::deck::{Located, Range};
use crate::udec::output;

impl Executor<'_> {
    /// FIX: the blocks in `range` held still.
    pub(super) fn fix(&mut self, range: &Range) {
        for b in self.in_range("FIX", range) {
            let blk = &mut self.model.blocks[b];
            blk.fixed = true;
            blk.velocity = [0.0, 0.0];
            blk.angular_velocity = 0.0;
        }
    }

    /// FREE: the blocks in `range` free to move again.
    pub(super) fn free(&mut self, range: &Range) {
        for b in self.in_range("FREE", range) {
            self.model.blocks[b].fixed = false;
        }
    }

    /// LOAD: a constant force on each block in `range`.
    pub(super) fn load(&mut self, range: &Range, force: [f64; 2]) {
        for b in self.in_range("LOAD", range) {
            self.model.blocks[b].load = force;
        }
    }

    /// VELOCITY (extension): the velocity and angular velocity of the free blocks in `range`.
    pub(super) fn velocity(&mut self, cmd: &Located, range: &Range, velocity: [f64; 2], angular: Option<f64>) -> Result<(), RunError> {
        let blocks = self.in_range("VELOCITY", range);
        // A velocity whose ½mv² overflows f64 is refused here, where it is given: CYCLE
        // would refuse it too, but a DELETE or a contact update before that books the
        // energy of what it removes, and ∞ − ∞ left the ledger NaN for good.
        let w = angular.unwrap_or(0.0);
        if let Some(&b) = blocks.iter().find(|&&b| {
            let blk = &self.model.blocks[b];
            !blk.fixed && !(0.5 * blk.mass * (velocity[0] * velocity[0] + velocity[1] * velocity[1]) + 0.5 * blk.inertia * w * w).is_finite()
        }) {
            return Err(self.command_error(
                cmd,
                format!(
                    "VELOCITY: block {} would move so fast (velocity ({:e}, {:e}), angular {w:e}) that its kinetic energy overflows f64; check the values and the units",
                    self.model.blocks[b].id, velocity[0], velocity[1]
                ),
            ));
        }
        // Each block's energy may be finite and their sum not: the ledger would book ∞ (and a
        // run stopped at once could not be saved and restarted). The blocks' kinetic energy
        // now, plus what the command gives, must stay a finite number.
        let given: f64 = blocks
            .iter()
            .map(|&b| &self.model.blocks[b])
            .filter(|blk| !blk.fixed)
            .map(|blk| 0.5 * blk.mass * (velocity[0] * velocity[0] + velocity[1] * velocity[1]) + 0.5 * blk.inertia * w * w)
            .sum();
        if !(given + self.model.energies().kinetic + self.model.external_work.abs()).is_finite() {
            return Err(self.command_error(
                cmd,
                format!(
                    "VELOCITY: the blocks would move so fast together (velocity ({:e}, {:e}), angular {w:e}) that their kinetic energy overflows f64; check the values and the units",
                    velocity[0], velocity[1]
                ),
            ));
        }
        // The kinetic energy VELOCITY gives (or takes, slowing a block) is input, booked
        // with the work of gravity and loads: the balance is unchanged by the command, and
        // what it shows later is the cycle's error alone. Measured as the ledger measures
        // kinetic energy (at the whole step), so that the booking is exact.
        if self.model.fdef.is_empty() {
            self.model.external_work += self.model.set_velocities(&blocks, velocity, w);
            return Ok(());
        }
        // A scene with zoned blocks: each zoned block moves by its grid points, which take the
        // rigid motion v + ω × r.
        let before = self.model.energies().kinetic;
        for b in blocks {
            let blk = &mut self.model.blocks[b];
            if !blk.fixed {
                blk.velocity = velocity;
                blk.angular_velocity = angular.unwrap_or(0.0);
                // A zoned block moves by its grid points: each takes the rigid motion v + ω × r.
                let c = blk.centroid;
                if let Some(f) = self.model.fdef.get_mut(b).filter(|f| !f.zones.is_empty()) {
                    for g in &mut f.gridpoints {
                        g.velocity = [velocity[0] - w * (g.position[1] - c[1]), velocity[1] + w * (g.position[0] - c[0])];
                    }
                    self.model.blocks[b].angular_velocity = 0.0;
                }
            }
        }
        self.model.external_work += self.model.energies().kinetic - before;
        Ok(())
    }

    /// LINK: the block containing `flying` linked to the block containing `anchor`.
    pub(super) fn link(&mut self, cmd: &Located, flying: [f64; 2], anchor: [f64; 2]) -> Result<(), RunError> {
        let find = |p: [f64; 2]| (0..self.model.blocks.len()).find(|&b| crate::udec::model::geometry::point_in_polygon(p, &self.model.corner_positions(b)));
        let not_found = |p: [f64; 2], which: &str| {
            let f = output::format::fmt_short;
            self.command_error(cmd, format!("LINK: no block contains the point ({}, {}) given for the {which} block", f(p[0]), f(p[1])))
        };
        let f = find(flying).ok_or_else(|| not_found(flying, "flying"))?;
        let a = find(anchor).ok_or_else(|| not_found(anchor, "linking"))?;
        if f == a {
            return Err(self.command_error(cmd, "LINK: both points lie in the same block"));
        }
        // Contact detection here searches every block's neighbourhood each update, so a
        // flying block is never lost; the link is kept and printed (PRINT LIST), as the
        // virtual contact of UDEC 1.2 was.
        self.model.links.push(crate::udec::model::Link { flying: f as u32, anchor: a as u32 });
        Ok(())
    }
}
