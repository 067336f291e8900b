//! Stage 4 on the CPU: every contact follows its feature of block 2 (the rounded-boundary
//! geometry of eqs. 13–15, [`crate::udec::contact::geometry`]) and applies the force–displacement law
//! (eqs. 16–20, [`crate::udec::contact::law`]), shared out over the team of threads. The GPU's twin is
//! `shaders/udec/contact_forces.wgsl`.

use std::sync::atomic::{AtomicUsize, Ordering};

use super::team::Team;
use super::{SharedMut, MIN_CHUNK, MIN_CONTACTS_PER_THREAD};
use crate::udec::backend::CycleError;
use crate::udec::contact::gather::ContactForce;
use crate::udec::contact::geometry::track_feature;
use crate::udec::contact::joint::law_parameters;
use crate::udec::contact::law::{contact_force_law, force_free_either_way, BlockMotion};
use crate::udec::contact::pair::counts_force;
use crate::udec::model::domain::{ContactFlow, Domains};
use crate::udec::model::fdef::Fdef;
use crate::udec::model::fluid::{contact_feet, contact_flow_of};
use crate::udec::model::sdef::Sdef;
use crate::udec::model::{material_slot, Block, BlockKind, Contact, Corner, Damping, Material, Model};

/// What stage 4 reads: the blocks and corners as stages 1–2 left them, and the constants.
struct ContactInputs<'a> {
    blocks: &'a [Block],
    corners: &'a [Corner],
    /// The simply-deformable extension of the blocks (empty in a rigid scene).
    sdef: &'a [Sdef],
    /// The fully-deformable extension of the blocks (empty in a scene without zones).
    fdef: &'a [Fdef],
    /// Each zoned block's boundary grid-point velocities in corner order (`Scratch::corner_velocity`;
    /// empty in a scene without zoned blocks).
    corner_velocity: &'a [[f64; 2]],
    materials: &'a [Material],
    /// In a scene with fluid, the domains (their pressures of the last stage 5): each contact's
    /// flow is taken right after its force (`model::fluid::contact_flow_of`).
    domains: Option<&'a Domains>,
    damping: Damping,
    dt: f64,
    /// Overlap beyond which the run stops (half the rounding length).
    limit: f64,
}

/// Stage 4 for the contacts `first .. first + contacts.len()`: each contact follows its feature
/// (the geometry of eqs. 13–15 at the rounded boundary) and applies the force–displacement law
/// (eqs. 16–20); `features` (as long as `contacts`, or empty) takes each contact's corner and
/// feature in a scene with zoned blocks, and in a scene with fluid `feet` (as long as
/// `contacts`) its two feet (`model::fluid::contact_foot`), which stage 5 reads, while its
/// corners are at hand, and where the domains are given its flow (stage 5's first step, ¶6:
/// each contact alone, from its force just set and the pressures of the last stage 5) into
/// `flows`. Returns the first contact of the piece (lowest index) whose overlap passes the
/// limit. `RIGID` says that the scene has neither simply- nor fully-deformable blocks (no `sdef`,
/// no `fdef`): the law's block motions are then rigid ones, known so when compiled, which keeps
/// the deformable blocks' cost out of a rigid scene's loop (same results: a rigid block's strain
/// rate is zero either way).
fn contact_piece<const RIGID: bool>(
    first: usize,
    contacts: &mut [Contact],
    forces: &mut [ContactForce],
    features: &mut [[u32; 2]],
    mut feet: Option<&mut [[[f64; 2]; 2]]>,
    mut flows: Option<&mut [ContactFlow]>,
    inp: &ContactInputs,
) -> Option<usize> {
    let motion = |k: u32, b: &Block| BlockMotion {
        centroid: b.centroid,
        velocity: b.velocity,
        angular_velocity: b.angular_velocity,
        strain_rate: match inp.sdef.get(k as usize) {
            Some(s) if !RIGID && b.kind == BlockKind::SimplyDeformable => s.strain_rate,
            _ => [0.0; 3],
        },
    };
    let mut failure = None;
    for (k, (contact, force)) in contacts.iter_mut().zip(forces.iter_mut()).enumerate() {
        let corner = &inp.corners[contact.corner as usize];
        let (b1, b2) = (&inp.blocks[contact.block1 as usize], &inp.blocks[contact.block2 as usize]);
        let corners2 = &inp.corners[b2.corner_start as usize..(b2.corner_start + b2.corner_count) as usize];
        let g = track_feature(corners2, contact.feature, corner.circle, corner.radius);
        contact.feature = g.feature;
        contact.kind = g.kind;
        if let Some(feet) = feet.as_deref_mut() {
            feet[k] = contact_feet(inp.corners, b2, contact, corner.position);
        }
        contact.gap = g.gap;
        contact.normal = g.normal;
        contact.point = g.point;
        // The other view of a corner-pair touch carries no force (the touch counts once); an open,
        // unbonded view gets none either way, and skips the comparison of the pair's depths.
        let mat = &inp.materials[material_slot(contact.material, inp.materials.len())];
        let corners1 = &inp.corners[b1.corner_start as usize..(b1.corner_start + b1.corner_count) as usize];
        let active = (g.gap > 0.0 && force_free_either_way(contact, g.gap, law_parameters(contact.joint_length, mat).kn))
            || counts_force(contact.corner, corner, g.gap, corners1, b1.corner_start, b1.kind == BlockKind::Rigid, corners2, b2.corner_start, g.feature);
        let (m1, m2) = if RIGID || inp.fdef.is_empty() {
            (motion(contact.block1, b1), motion(contact.block2, b2))
        } else {
            // A zoned block's boundary moves with its grid points (`cpu::zones`).
            let zoned = |k: u32, b: &Block, side: u32| match inp.fdef.get(k as usize) {
                Some(f) if b.kind == BlockKind::FullyDeformable && !f.zones.is_empty() => {
                    let mine = &inp.corners[b.corner_start as usize..(b.corner_start + b.corner_count) as usize];
                    let cv = &inp.corner_velocity[b.corner_start as usize..(b.corner_start + b.corner_count) as usize];
                    let velocity = super::zones::boundary_velocity(cv, contact, side, b.corner_start, mine, g.point);
                    BlockMotion { centroid: g.point, velocity, angular_velocity: 0.0, strain_rate: [0.0; 3] }
                }
                _ => motion(k, b),
            };
            (zoned(contact.block1, b1, 0), zoned(contact.block2, b2, 1))
        };
        contact_force_law(contact, mat, &m1, &m2, &inp.damping, inp.dt, active);
        *force = ContactForce::from(&*contact);
        if let (Some(flows), Some(domains)) = (flows.as_deref_mut(), inp.domains) {
            flows[k] = contact_flow_of(contact, mat, domains, first + k);
        }
        if let Some(f) = features.get_mut(k) {
            *f = [contact.corner, g.feature];
        }
        if -g.gap > inp.limit && active && failure.is_none() {
            failure = Some(first + k);
        }
    }
    failure
}

/// Stage 4 for the whole model, shared out over the team, with each contact's feet into `feet`
/// where given (a scene with fluid; resized to the contacts) and then, where the model has its
/// domains, each contact's flow into `domains.flows` (resized likewise). Returns the first contact (lowest
/// index, so the report repeats) whose overlap passes the limit, if any.
/// `features`: each contact's corner and feature, kept beside the forces in a scene with zoned
/// blocks (`Scratch::features`; empty in other scenes).
pub(super) fn contact_stage(
    model: &mut Model,
    forces: &mut [ContactForce],
    features: &mut [[u32; 2]],
    feet: Option<&mut Vec<[[f64; 2]; 2]>>,
    corner_velocity: &[[f64; 2]],
    dt: f64,
    team: &mut Team,
) -> Result<(), CycleError> {
    let _p = crate::profile::scope(crate::profile::Stage::ContactForces);
    let limit = 0.5 * model.tol.round;
    let failure = {
        let Model { blocks, corners, contacts, materials, damping, sdef, fdef, domains, .. } = &mut *model;
        let n = contacts.len();
        // The flows leave the domains while the team writes them (the domains' pressures are
        // read meanwhile), and go back after.
        let mut flows = match (&feet, domains.as_mut()) {
            (Some(_), Some(d)) => {
                let mut f = std::mem::take(&mut d.flows);
                f.resize(n, ContactFlow::default());
                Some(f)
            }
            _ => None,
        };
        let inp = ContactInputs { blocks, corners, sdef, fdef, corner_velocity, materials, domains: domains.as_ref(), damping: *damping, dt, limit };
        assert_eq!(forces.len(), n, "one gather record per contact");
        let first = AtomicUsize::new(usize::MAX);
        assert!(features.is_empty() || features.len() == n, "a corner and feature per contact, or none");
        let (shared, shared_forces) = (SharedMut::new(contacts), SharedMut::new(forces));
        let shared_feet = feet.map(|f| {
            f.resize(n, [[0.0; 2]; 2]);
            SharedMut::new(f)
        });
        let zoned = !features.is_empty();
        let rigid = inp.sdef.is_empty() && inp.fdef.is_empty();
        let shared_features = SharedMut::new(features);
        let shared_flows = flows.as_deref_mut().map(SharedMut::new);
        team.for_chunks(n, MIN_CONTACTS_PER_THREAD, MIN_CHUNK, &|r| {
            // SAFETY: the chunks are disjoint ranges of `contacts` and of `forces` and `feet` (as
            // long), mutably borrowed here.
            let (piece, forces) = unsafe { (shared.range(r.clone()), shared_forces.range(r.clone())) };
            // SAFETY: likewise, where the scene keeps them (else the empty slice).
            let features = if zoned { unsafe { shared_features.range(r.clone()) } } else { &mut [] };
            // SAFETY: as above.
            let feet = shared_feet.as_ref().map(|f| unsafe { f.range(r.clone()) });
            // SAFETY: as above.
            let flows = shared_flows.as_ref().map(|f| unsafe { f.range(r.clone()) });
            let failure = if rigid {
                contact_piece::<true>(r.start, piece, forces, features, feet, flows, &inp)
            } else {
                contact_piece::<false>(r.start, piece, forces, features, feet, flows, &inp)
            };
            if let Some(k) = failure {
                first.fetch_min(k, Ordering::Relaxed);
            }
        });
        if let (Some(f), Some(d)) = (flows, domains.as_mut()) {
            d.flows = f;
        }
        first.into_inner()
    };
    if failure == usize::MAX {
        return Ok(());
    }
    Err(CycleError::overlap(model, failure, limit))
}
