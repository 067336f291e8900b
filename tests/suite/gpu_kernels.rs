//! Each WGSL function with a Rust twin, checked on random inputs against the twin (dimforge's
//! wgebra approach, STYLE.md item 10): a small test entry point is appended to the kernel file, run
//! on the adapter, and its results compared with the Rust function's.
//!
//! - `track_feature` (with `neighbourhood`, `edge_distance`, `arc_distance`, `better`) and
//!   `counts_force`: the contact geometry of a rounded corner against a rounded polygon;
//! - `contact_force_law`: the force–displacement law (eqs. 13–20) with the energy it books
//!   (slip work, dashpot work and the dashpot velocities it carries to the next step);
//! - `mass_damping_work`: the energy the mass-proportional damping takes in a step (law_of_motion);
//! - `force_sum`: stage 6, a block's sum of its contacts' gather records (run by law_of_motion and
//!   gather), against the CPU's gather on the contacts' points and forces;
//! - the `law_of_motion` kernel whole (stage 6, then 1 and 2: `geometry_update`, with the f32
//!   rotation placed at whole steps and the turn since) against the CPU's block pass;
//! - `sin_cos`: the rotation of the geometry update, with + − × only;
//! - `splice_contacts`: the contact list built on the device after a contact update, and
//!   `pack_contacts`, the summaries of the contacts a contact update reads back;
//! - `list_blocks` and `list_contacts`: the lists a contact update reads back first;
//! - `energy_sums` (the energy check on the device): its sums against `Model::energies` on the
//!   state the run read back.
//!
//! Tolerances: f64 kernels agree to rounding (a few ulps; the GPU compiler may fuse
//! multiply–adds). f32 kernels get the inputs rounded to f32 and agree to f32 round-off scaled by
//! the size of the numbers involved, stated at each check; a branch decided within round-off of
//! its threshold (a tie between two features, |Fs| at the Coulomb limit) may go the other way in
//! f32 for a small share of the random cases, bounded below.

use crate::common;

use blockdem::udec::contact::gather::AdjacencyEntry;
use blockdem::udec::contact::geometry::track_feature;
use blockdem::udec::contact::law::{contact_force_law, BlockMotion};
use blockdem::udec::contact::pair::counts_force;
use blockdem::udec::gpu::layout::{
    Block as GBlock, Contact as GContact, ContactForce as GForce, ContactPatch as GPatch, ContactSummary as GSummary, Corner as GCorner, GridReference,
    ListParams, Material as GMaterial, Params as GParams, Real,
};
use blockdem::udec::gpu::shaders::split_rotation;
use blockdem::udec::gpu::splice::{pack_contacts, patch_contacts, renumber_table, shift_offsets, splice_adjacency, splice_contacts, NEW_CONTACT};
use blockdem::udec::gpu::{shaders, AdapterChoice, GpuDevice, Precision};
use blockdem::udec::model::{Contact, ContactKind, ContactMaterial, Damping, JointMaterial, Material, Model};
use blockdem::udec::topology::adjacency::FROM_LISTS;
use blockdem::udec::topology::detect::ListEdit;
use common::{Rng, Target};

/// A device for the target, or None (skipped) when the adapter is absent.
fn device(adapter: &str, precision: Precision) -> Option<GpuDevice> {
    Target::gpu(adapter, precision)?;
    let choice: AdapterChoice = adapter.parse().unwrap();
    Some(GpuDevice::open(&choice, precision).unwrap_or_else(|e| panic!("{e}")))
}

/// Runs `entry` (appended to the kernel file `kernel`.wgsl) over `cases` invocations with the
/// given storage buffers (binding, bytes, is_output); returns the outputs in order.
fn run_kernel(dev: &GpuDevice, kernel: &str, snippet: &str, entry: &str, cases: usize, buffers: &[(u32, Vec<u8>, bool)]) -> Vec<Vec<u8>> {
    let src = format!("{}\n{snippet}", shaders::source(kernel, dev.precision).unwrap());
    shaders::validate(&src, dev.precision).unwrap_or_else(|e| panic!("{e}"));
    common::run_wgsl(dev, &src, entry, cases, buffers)
}

fn reals<R: Real>(xs: &[f64]) -> Vec<u8> {
    bytemuck::cast_slice(&xs.iter().map(|&x| R::from_f64(x)).collect::<Vec<R>>()).to_vec()
}

fn back<R: Real>(bytes: &[u8]) -> Vec<f64> {
    bytemuck::pod_collect_to_vec::<u8, R>(bytes).into_iter().map(Real::to_f64).collect()
}

/// Rounds to the kernel precision and back (the CPU reference sees the GPU's inputs).
fn q<R: Real>(x: f64) -> f64 {
    R::from_f64(x).to_f64()
}

const TRACK: &str = r#"
@group(0) @binding(20) var<storage, read> t_in_r: array<real>;
@group(0) @binding(21) var<storage, read> t_in_u: array<u32>;
@group(0) @binding(22) var<storage, read_write> t_out_r: array<real>;
@group(0) @binding(23) var<storage, read_write> t_out_u: array<u32>;

@compute @workgroup_size(64)
fn test_track_feature(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&t_in_u) / 4u) {
        return;
    }
    let c = vec2<real>(t_in_r[3u * i], t_in_r[3u * i + 1u]);
    let r = t_in_r[3u * i + 2u];
    let start = t_in_u[4u * i];
    let n = t_in_u[4u * i + 1u];
    let nb = neighbourhood(start, n, t_in_u[4u * i + 2u]);
    let g = track_feature(nb, c, r);
    t_out_r[6u * i] = g.gap;
    t_out_r[6u * i + 1u] = g.normal.x;
    t_out_r[6u * i + 2u] = g.normal.y;
    t_out_r[6u * i + 3u] = g.point.x;
    t_out_r[6u * i + 4u] = g.point.y;
    t_out_r[6u * i + 5u] = g.distance;
    t_out_u[2u * i] = g.feature;
    t_out_u[2u * i + 1u] = select(0u, 1u, counts_force(t_in_u[4u * i + 3u], c, r, g.gap, nb, g.feature, blocks[2u * i], blocks[2u * i + 1u]));
}
"#;

/// Rounds a block's corners to the kernel precision relative to its centroid `cen`, so that the
/// CPU reference measures what the GPU measures; the kernel measures each edge from the two
/// rounded corners (`edge_from`), so the reference does too.
fn quantize<R: Real>(corners: &mut [blockdem::udec::model::Corner], cen: [f64; 2]) {
    for c in corners.iter_mut() {
        for (i, &o) in cen.iter().enumerate() {
            c.position[i] = o + q::<R>(c.position[i] - o);
            c.circle[i] = o + q::<R>(c.circle[i] - o);
        }
        c.radius = q::<R>(c.radius);
        c.round = q::<R>(c.round);
    }
    let n = corners.len();
    let rel = |c: &blockdem::udec::model::Corner| [c.position[0] - cen[0], c.position[1] - cen[1]];
    for k in 0..n {
        let (a, b) = (rel(&corners[k]), rel(&corners[(k + 1) % n]));
        let e = [b[0] - a[0], b[1] - a[1]];
        let len = e[0].hypot(e[1]);
        corners[k].edge_dir = [e[0] / len, e[1] / len];
        corners[k].edge_length = len;
    }
}

fn track_feature_matches_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    let cases = 2000;
    let (mut gpu_corners, mut in_r, mut in_u) = (Vec::<GCorner<R>>::new(), Vec::new(), Vec::new());
    let (mut expected, mut pairs, mut gblocks) = (Vec::new(), 0usize, Vec::<GBlock<R>>::new());
    for _ in 0..cases {
        // A random convex polygon (3–6 corners on a circle of radius 0.5–2 m, jittered), far from
        // the origin so that the relative-to-centroid geometry is exercised, rounded by 2–20 cm.
        let n = 3 + rng.below(4) as usize;
        let size = rng.range(0.5, 2.0);
        let far = [rng.range(-1e3, 1e3), rng.range(-1e3, 1e3)];
        let phase = rng.range(0.0, 6.3);
        let outline: Vec<[f64; 2]> = (0..n)
            .map(|k| {
                let a = phase + (k as f64 + rng.range(-0.25, 0.25)) * std::f64::consts::TAU / n as f64;
                [far[0] + size * a.cos(), far[1] + size * a.sin()]
            })
            .collect();
        let mut model = Model::default();
        model.set_round(rng.range(0.02, 0.2) * size);
        model.add_block(&outline, 1, 1, None).unwrap();
        let cen = model.blocks[0].centroid;
        let corners = model.block_corners(0).to_vec();
        // Round the polygon to the kernel precision (relative to its centroid) so that the CPU
        // reference measures what the GPU measures; the kernel measures each edge from the two
        // rounded corners (`edge_from`), so the reference does too.
        let mut ref_corners = corners.clone();
        quantize::<R>(&mut ref_corners, cen);
        // A corner circle near a random feature: on the boundary ± up to 30% of the size, the
        // tracked feature one of that feature and its neighbours. The circle is corner 0 of block
        // 1, a second random polygon turned so that this corner points at block 2: a circle near
        // an end of the feature is a view of a corner pair, whose depth is compared with the other
        // view's.
        let nf = 2 * n as u32;
        let f0 = rng.below(nf);
        let k = (f0 / 2) as usize;
        let (p0, p1) = (corners[k].position, corners[(k + 1) % n].position);
        let t = if f0 % 2 == 1 { rng.range(0.0, 1.0) } else { 0.0 };
        let base = [p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1])];
        let dir = [base[0] - cen[0], base[1] - cen[1]];
        let dl = (dir[0] * dir[0] + dir[1] * dir[1]).sqrt();
        let off = rng.range(-0.1, 0.3) * size;
        let target = [base[0] + dir[0] / dl * off, base[1] + dir[1] / dl * off];
        // Block 1: corner 0 towards block 2 (at −dir from block 1's centre), the others spread.
        let n1 = 3 + rng.below(4) as usize;
        let size1 = rng.range(0.3, 1.0) * size;
        let toward = (-dir[1]).atan2(-dir[0]) + rng.range(-0.3, 0.3);
        let outline1: Vec<[f64; 2]> = (0..n1)
            .map(|j| {
                let jitter = if j == 0 { 0.0 } else { rng.range(-0.2, 0.2) };
                let a = toward + (j as f64 + jitter) * std::f64::consts::TAU / n1 as f64;
                [size1 * a.cos(), size1 * a.sin()]
            })
            .collect();
        let round1 = rng.range(0.01, 0.1) * size;
        let placed = |shift: [f64; 2]| {
            let mut m = Model::default();
            m.set_round(round1);
            m.add_block(&outline1.iter().map(|p| [p[0] + shift[0], p[1] + shift[1]]).collect::<Vec<_>>(), 1, 1, None).unwrap();
            m
        };
        let probe = placed([0.0, 0.0]);
        let model1 = placed([target[0] - probe.corners[0].circle[0], target[1] - probe.corners[0].circle[1]]);
        let cen1 = model1.blocks[0].centroid;
        let mut ref_corners1 = model1.block_corners(0).to_vec();
        quantize::<R>(&mut ref_corners1, cen1);
        let rel = [q::<R>(ref_corners1[0].circle[0] - cen[0]), q::<R>(ref_corners1[0].circle[1] - cen[1])];
        let c = [cen[0] + rel[0], cen[1] + rel[1]];
        let r = ref_corners1[0].radius;
        // Block 1's corners before or after block 2's (the index decides ties).
        let first1 = rng.below(2) == 0;
        let here = gpu_corners.len() as u32;
        let (start, start1) = if first1 { (here + n1 as u32, here) } else { (here, here + n as u32) };
        let mut push = |cs: &[blockdem::udec::model::Corner], o: [f64; 2]| {
            for c in cs {
                gpu_corners.push(GCorner {
                    radius: R::from_f64(c.radius),
                    round: R::from_f64(c.round),
                    px: R::from_f64(c.position[0] - o[0]),
                    py: R::from_f64(c.position[1] - o[1]),
                    ox: R::from_f64(c.circle[0] - o[0]),
                    oy: R::from_f64(c.circle[1] - o[1]),
                    ..Default::default()
                });
            }
        };
        if first1 {
            push(&ref_corners1, cen1);
            push(&ref_corners, cen);
        } else {
            push(&ref_corners, cen);
            push(&ref_corners1, cen1);
        }
        let feature = (f0 + nf + rng.below(3) - 1) % nf;
        let g = track_feature(&ref_corners, feature, c, r);
        let mut own_corner = ref_corners1[0];
        own_corner.circle = c;
        let counts = |gap: f64| counts_force(start1, &own_corner, gap, &ref_corners1, start1, true, &ref_corners, start, g.feature);
        let counted = counts(g.gap);
        // A view of a corner pair: its count depends on its depth. Decided within round-off of
        // the band's edges, the f32 kernel may decide the other way (checked only where sure).
        let pair = counts(-1e3 * size) != counts(1e3 * size);
        // Each of the two gaps carries the f32 round-off of a gap (2e-6 of the size, below).
        let tl = if f32_kernel { 4e-6 * size } else { 1e-12 * size };
        // A run stops where an overlap passes half the rounding length (`CycleError`), so a pair
        // deeper than that (two circles nearly concentric, where the nearest feature of either
        // view is a tie between an arc from inside and an edge from outside) is not compared.
        let limit = 0.5 * round1.min(ref_corners[0].round);
        let other = track_feature(&ref_corners1, 0, ref_corners[(g.feature / 2) as usize % n].circle, ref_corners[(g.feature / 2) as usize % n].radius);
        let in_range = -g.gap < limit && -other.gap < limit;
        let sure = counts(g.gap - tl) == counted && counts(g.gap + tl) == counted;
        in_r.extend([rel[0], rel[1], r]);
        in_u.extend([start, n as u32, feature, start1]);
        // The two blocks as the kernel holds them: each centroid as a compensated pair.
        let block = |cen: [f64; 2], start: u32, count: usize| {
            let (hx, hy) = (R::from_f64(cen[0]), R::from_f64(cen[1]));
            GBlock::<R> {
                cx: hx,
                cy: hy,
                cx_lo: R::from_f64(cen[0] - hx.to_f64()),
                cy_lo: R::from_f64(cen[1] - hy.to_f64()),
                corner_start: start,
                corner_count: count as u32,
                ..bytemuck::Zeroable::zeroed()
            }
        };
        gblocks.extend([block(cen1, start1, n1), block(cen, start, n)]);
        pairs += usize::from(pair && in_range);
        expected.push((g, cen, size, counted, in_range, sure));
    }
    let out = run_kernel(
        dev,
        "contact_forces",
        TRACK,
        "test_track_feature",
        cases,
        &[
            (0, bytemuck::bytes_of(&GParams::<R> { one: 1, ..bytemuck::Zeroable::zeroed() }).to_vec(), false),
            (1, bytemuck::cast_slice(&gblocks).to_vec(), false),
            (2, bytemuck::cast_slice(&gpu_corners).to_vec(), false),
            (20, reals::<R>(&in_r), false),
            (21, bytemuck::cast_slice(&in_u).to_vec(), false),
            (22, vec![0; cases * 6 * std::mem::size_of::<R>()], true),
            (23, vec![0; cases * 8], true),
        ],
    );
    let (out_r, out_u) = (back::<R>(&out[0]), bytemuck::pod_collect_to_vec::<u8, u32>(&out[1]));
    let (mut other_feature, mut unsure) = (0, 0);
    for (i, (g, cen, size, counted, in_range, sure)) in expected.iter().enumerate() {
        if out_u[2 * i] != g.feature {
            other_feature += 1;
            continue;
        }
        // f64: rounding (1e-12 of the polygon's size). f32: positions carry 2⁻²⁴ of the size
        // (6e-8), a few operations each: 2e-6 of the size for lengths; the normal divides by
        // distances no smaller than the 1 cm radius floor: 1e-4.
        let (tl, tn) = if f32_kernel { (2e-6 * size, 1e-4) } else { (1e-12 * size, 1e-11) };
        let o = &out_r[6 * i..6 * i + 6];
        assert!((o[0] - g.gap).abs() < tl, "case {i}: gap {} vs {}", o[0], g.gap);
        assert!((o[1] - g.normal[0]).abs() < tn && (o[2] - g.normal[1]).abs() < tn, "case {i}: normal");
        assert!((o[3] + cen[0] - g.point[0]).abs() < tl && (o[4] + cen[1] - g.point[1]).abs() < tl, "case {i}: point");
        assert!((o[5] - g.distance).abs() < tl, "case {i}: distance");
        if !*in_range {
            continue;
        }
        if *sure {
            assert_eq!(out_u[2 * i + 1] != 0, *counted, "case {i}: counts_force, gap {:e} (GPU {:e}), feature {}, size {size}", g.gap, o[0], g.feature);
        } else {
            unsure += 1;
        }
    }
    // The cases cover the views of corner pairs (their count decided by depth) well.
    assert!(pairs > cases / 20, "only {pairs} of {cases} cases are views of a corner pair within the overlap limit");
    assert!(unsure <= cases / 100, "{unsure} of {cases} cases decided within round-off");
    // Features are chosen alike except within round-off of a tie: none in f64; in f32, under 1%.
    let allowed = if f32_kernel { cases / 100 } else { 0 };
    assert!(other_feature <= allowed, "{other_feature} of {cases} cases chose another feature");
}

const LAW: &str = r#"
@group(0) @binding(20) var<storage, read> l_contacts: array<Contact>;
@group(0) @binding(21) var<storage, read> l_materials: array<Material>;
@group(0) @binding(22) var<storage, read> l_motion: array<real>;
@group(0) @binding(23) var<storage, read_write> l_out: array<Contact>;
@group(0) @binding(24) var<storage, read_write> l_force: array<vec2<real>>;

@compute @workgroup_size(64)
fn test_contact_force_law(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&l_out)) {
        return;
    }
    let m = 13u * i;
    let a = Motion(vec2<real>(l_motion[m], l_motion[m + 1u]), vec2<real>(l_motion[m + 2u], l_motion[m + 3u]), l_motion[m + 4u]);
    let b = Motion(vec2<real>(l_motion[m + 5u], l_motion[m + 6u]), vec2<real>(l_motion[m + 7u], l_motion[m + 8u]), l_motion[m + 9u]);
    let at = vec2<real>(l_contacts[i].px, l_contacts[i].py);
    let vrel = velocity_at(a, at) - velocity_at(b, at);
    let law = contact_force_law(l_contacts[i], contact_law(l_materials[i], l_contacts[i].length), vrel, l_motion[m + 10u], l_motion[m + 11u], l_motion[m + 12u] != 0.0);
    l_out[i] = law.contact;
    l_force[i] = law.force;
}
"#;

fn contact_force_law_matches_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_0000_0000_0002);
    let cases = 4000;
    let (mut gc, mut gm, mut motion, mut expected) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for _ in 0..cases {
        let a = rng.range(0.0, 6.3);
        let kn = q::<R>(10f64.powf(rng.range(6.0, 10.0)));
        let mat = Material {
            contact: ContactMaterial {
                kn,
                ks: q::<R>(kn * rng.range(0.1, 1.0)),
                cohesion: q::<R>(if rng.next() < 0.3 { rng.range(0.0, 1e5) } else { 0.0 }),
                friction: q::<R>(rng.range(0.0, 1.0)),
            },
            // A third of the cases are joints (¶5): stresses over a length, same scales.
            joint: JointMaterial {
                kn: q::<R>(kn * 2.0),
                ks: q::<R>(kn * rng.range(0.2, 2.0)),
                cohesion: q::<R>(if rng.next() < 0.3 { rng.range(0.0, 2e5) } else { 0.0 }),
                friction: q::<R>(rng.range(0.0, 1.0)),
            },
            ..Default::default()
        };
        let joint_length = if rng.next() < 0.33 { q::<R>(rng.range(0.5, 1.0)) } else { 0.0 };
        let gap = q::<R>(rng.range(-2e-3, 5e-4));
        let bonded = rng.next() < 0.5;
        // Ledger inputs: the accumulated works so far, the dashpot velocities of the last step
        // (half the cases), the last normal force (a bonded contact may carry tension, which
        // goes to the slip work when it opens).
        let dashpot = rng.next() < 0.5;
        let mut u = || q::<R>(rng.range(-1.0, 1.0));
        let dashpot_velocity = if dashpot { [u(), u()] } else { [0.0; 2] };
        let normal_force = q::<R>(if bonded { rng.range(-1.0, 1.0) } else { rng.range(0.0, 1.0) } * kn * 1e-3);
        let (slip_work, dashpot_work) = (q::<R>(rng.range(0.0, 100.0)), q::<R>(rng.range(0.0, 100.0)));
        let contact = Contact {
            id: 0,
            block1: 0,
            corner: 0,
            block2: 1,
            feature: 1,
            kind: ContactKind::CornerEdge,
            material: 1,
            constitutive: 1,
            bonded,
            point: [q::<R>(rng.range(-1.0, 1.0)), q::<R>(rng.range(-1.0, 1.0))],
            normal: [q::<R>(a.cos()), q::<R>(a.sin())],
            gap,
            normal_force,
            shear_force: q::<R>(rng.range(-1.0, 1.0) * kn * 1e-3),
            shear_displacement: q::<R>(rng.range(-1e-3, 1e-3)),
            force: [0.0, 0.0],
            slip_work,
            dashpot_work,
            dashpot_velocity,
            joint_length,
        };
        let mut v = || q::<R>(rng.range(-1.0, 1.0));
        let m1 = BlockMotion { centroid: [v(), v()], velocity: [v(), v()], angular_velocity: v(), strain_rate: [0.0; 3] };
        let m2 = BlockMotion { centroid: [v(), v()], velocity: [v(), v()], angular_velocity: v(), strain_rate: [0.0; 3] };
        let beta = q::<R>(if rng.next() < 0.5 { rng.range(0.0, 1e-3) } else { 0.0 });
        let dt = q::<R>(rng.range(1e-5, 1e-3));
        let active = rng.next() < 0.9;
        let mut out = contact;
        contact_force_law(&mut out, &mat, &m1, &m2, &Damping { alpha: 0.0, beta, alpha_internal: 0.0 }, dt, active);
        let r = R::from_f64;
        gc.push(GContact {
            px: r(contact.point[0]),
            py: r(contact.point[1]),
            nx: r(contact.normal[0]),
            ny: r(contact.normal[1]),
            gap: r(gap),
            normal_force: r(normal_force),
            shear_force: r(contact.shear_force),
            shear_displacement: r(contact.shear_displacement),
            slip_work: r(slip_work),
            dashpot_work: r(dashpot_work),
            dashpot_vn: r(dashpot_velocity[0]),
            dashpot_vs: r(dashpot_velocity[1]),
            length: r(joint_length),
            bonded: contact.bonded as u32,
            ..Default::default()
        });
        gm.push(GMaterial {
            kn: r(mat.contact.kn),
            ks: r(mat.contact.ks),
            cohesion: r(mat.contact.cohesion),
            friction: r(mat.contact.friction),
            jkn: r(mat.joint.kn),
            jks: r(mat.joint.ks),
            jcohesion: r(mat.joint.cohesion),
            jfriction: r(mat.joint.friction),
        });
        motion.extend([m1.centroid[0], m1.centroid[1], m1.velocity[0], m1.velocity[1], m1.angular_velocity]);
        motion.extend([m2.centroid[0], m2.centroid[1], m2.velocity[0], m2.velocity[1], m2.angular_velocity]);
        motion.extend([beta, dt, active as u32 as f64]);
        // Energy scale of one step's bookkeeping: the larger of the spring energies F²/2k of the
        // forces in play and the work of a force over the step's slip or dashpot velocity.
        let vrel = {
            let (va, vb) = (m1.velocity_at(contact.point), m2.velocity_at(contact.point));
            (va[0] - vb[0]).hypot(va[1] - vb[1])
        };
        let force = (kn * gap.abs()).max(contact.shear_force.abs()).max(normal_force.abs()).max(1.0);
        let dash = beta * kn * (dashpot_velocity[0].abs() + dashpot_velocity[1].abs() + vrel).powi(2) * dt;
        let energy = (force * force / mat.contact.ks).max(force * vrel * dt).max(dash);
        expected.push((out, kn, energy, contact));
    }
    let out = run_kernel(
        dev,
        "contact_forces",
        LAW,
        "test_contact_force_law",
        cases,
        &[
            (20, bytemuck::cast_slice(&gc).to_vec(), false),
            (21, bytemuck::cast_slice(&gm).to_vec(), false),
            (22, reals::<R>(&motion), false),
            (23, vec![0; cases * std::mem::size_of::<GContact<R>>()], true),
            (24, vec![0; cases * 2 * std::mem::size_of::<R>()], true),
        ],
    );
    let got: Vec<GContact<R>> = bytemuck::pod_collect_to_vec(&out[0]);
    let got_force: Vec<[R; 2]> = bytemuck::pod_collect_to_vec(&out[1]);
    let (mut branch_flips, mut slipped, mut damped) = (0, 0, 0);
    for (i, (((e, kn, energy, input), g), gf)) in expected.iter().zip(&got).zip(&got_force).enumerate() {
        if (g.bonded != 0) != e.bonded {
            branch_flips += 1;
            continue;
        }
        // Force scale: the larger of kn·|gap| and |Fs| (f32: 1e-5 of it, a few roundings of
        // products of f32 inputs; f64: 1e-12).
        let scale = (kn * e.gap.abs()).max(e.shear_force.abs()).max(e.normal_force.abs()).max(1.0);
        let tol = if f32_kernel { 1e-5 } else { 1e-12 } * scale;
        let pairs =
            [(g.normal_force.to_f64(), e.normal_force), (g.shear_force.to_f64(), e.shear_force), (gf[0].to_f64(), e.force[0]), (gf[1].to_f64(), e.force[1])];
        if pairs.iter().any(|(a, b)| (a - b).abs() > tol) {
            branch_flips += 1;
            if !f32_kernel {
                panic!("case {i}: {pairs:?} (tol {tol})");
            }
            continue;
        }
        let us_tol = if f32_kernel { 1e-6 } else { 1e-15 };
        assert!((g.shear_displacement.to_f64() - e.shear_displacement).abs() < us_tol, "case {i}: shear displacement");
        // The ledger: the dashpot velocities handed to the next step are the step's relative
        // velocities (f32: 1e-6 of them, velocities of order 1 m/s; f64: 1e-15); the works
        // agree to 1e-5 (f32) or 1e-12 (f64) of the step's energy scale plus the rounding of the
        // accumulated value they add to (f32: 2⁻²⁴ of it).
        let v_tol = if f32_kernel { 1e-6 } else { 1e-15 };
        assert!(
            (g.dashpot_vn.to_f64() - e.dashpot_velocity[0]).abs() < v_tol && (g.dashpot_vs.to_f64() - e.dashpot_velocity[1]).abs() < v_tol,
            "case {i}: dashpot velocity ({}, {}) vs {:?}",
            g.dashpot_vn.to_f64(),
            g.dashpot_vs.to_f64(),
            e.dashpot_velocity
        );
        let (rel, acc) = if f32_kernel { (1e-5, 6e-8) } else { (1e-12, 2.3e-16) };
        for (what, got, want, before) in
            [("slip work", g.slip_work.to_f64(), e.slip_work, input.slip_work), ("dashpot work", g.dashpot_work.to_f64(), e.dashpot_work, input.dashpot_work)]
        {
            let tol = rel * energy + acc * before.abs();
            assert!((got - want).abs() <= tol, "case {i}: {what} {got:e} vs {want:e} (from {before:e}; tol {tol:e})");
        }
        if e.slip_work != input.slip_work {
            slipped += 1;
        }
        if e.dashpot_work != input.dashpot_work {
            damped += 1;
        }
    }
    // The random cases reach every branch of the bookkeeping.
    assert!(slipped > cases / 10 && damped > cases / 10, "{slipped} slips, {damped} dashpot steps of {cases}");
    // Branches decided within round-off of their threshold (|Fs| at the Coulomb limit, Fn at the
    // cohesion): none in f64, under 1% in f32.
    let allowed = if f32_kernel { cases / 100 } else { 0 };
    assert!(branch_flips <= allowed, "{branch_flips} of {cases} cases differ");
}

const MASS_DAMPING: &str = r#"
@group(0) @binding(20) var<storage, read> d_in: array<real>;
@group(0) @binding(21) var<storage, read_write> d_out: array<real>;

@compute @workgroup_size(64)
fn test_mass_damping_work(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&d_out)) {
        return;
    }
    let m = 10u * i;
    let v0 = vec3<real>(d_in[m + 2u], d_in[m + 3u], d_in[m + 4u]);
    let v1 = vec3<real>(d_in[m + 5u], d_in[m + 6u], d_in[m + 7u]);
    d_out[i] = mass_damping_work(d_in[m], d_in[m + 1u], v0, v1, d_in[m + 8u], d_in[m + 9u]);
}
"#;

fn mass_damping_work_matches_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_0000_0000_0004);
    let cases = 4096;
    let (mut input, mut expected) = (Vec::new(), Vec::new());
    for _ in 0..cases {
        // Masses 1 kg – 1e6 kg, inertias of blocks 0.1–10 m across, velocities up to 10 m/s
        // (and rad/s) of either sign, α up to 100 /s, Δt 1e-6 – 1e-2 s.
        let mass = q::<R>(10f64.powf(rng.range(0.0, 6.0)));
        let inertia = q::<R>(mass * 10f64.powf(rng.range(-2.0, 2.0)));
        let mut v = || q::<R>(rng.range(-10.0, 10.0));
        let (v0, v1) = ([v(), v(), v()], [v(), v(), v()]);
        let alpha = q::<R>(rng.range(0.0, 100.0));
        let dt = q::<R>(10f64.powf(rng.range(-6.0, -2.0)));
        input.extend([mass, inertia, v0[0], v0[1], v0[2], v1[0], v1[1], v1[2], alpha, dt]);
        expected.push(blockdem::udec::cpu::law_of_motion::mass_damping_work(mass, inertia, v0, v1, alpha, dt));
    }
    let out = run_kernel(
        dev,
        "law_of_motion",
        MASS_DAMPING,
        "test_mass_damping_work",
        cases,
        &[(20, reals::<R>(&input), false), (21, vec![0; cases * std::mem::size_of::<R>()], true)],
    );
    let got = back::<R>(&out[0]);
    for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
        // A sum of non-negative terms, each a product of a few rounded factors: relative error a
        // few ulps — f32 2⁻²⁴ ≈ 6e-8 per operation, ~10 operations: 1e-6; f64: 1e-14. The mean
        // velocity ½(v0 + v1) may cancel; its rounding is relative to |v0| + |v1| (the scale
        // term below).
        let rel = if f32_kernel { 1e-6 } else { 1e-14 };
        let k = &input[10 * i..10 * i + 10];
        let scale = k[8] * k[9] * (k[0] * ((k[2].abs() + k[5].abs()).powi(2) + (k[3].abs() + k[6].abs()).powi(2)) + k[1] * (k[4].abs() + k[7].abs()).powi(2));
        assert!((g - e).abs() <= rel * scale, "case {i}: {g:e} vs {e:e}");
    }
}

const FORCE_SUM: &str = r#"
@group(0) @binding(21) var<storage, read_write> s_out: array<real>;

@compute @workgroup_size(64)
fn test_force_sum(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = gid.x;
    if (b >= arrayLength(&s_out) / 3u) {
        return;
    }
    let f = force_sum(blocks[b], adj_offsets[b], adj_offsets[b + 1u]);
    s_out[3u * b] = f.x;
    s_out[3u * b + 1u] = f.y;
    s_out[3u * b + 2u] = f.z;
}
"#;

/// A small wall in running bond on a fixed base (48 bricks, a few hundred contacts) with random
/// masses, loads and gravity, and random contact points (within a metre of block 2's centroid)
/// and forces (to 1e5 N), every value rounded to the kernel precision: the model, its adjacency,
/// the CPU's gather inputs, the device's gather records as `contact_forces.wgsl` writes them (the
/// force on block 1 and each side's moment about its own centroid, points relative to block 2's),
/// and the gravity.
struct ForceScene<R: Real> {
    model: Model,
    adjacency: blockdem::udec::topology::Adjacency,
    forces: Vec<blockdem::udec::contact::gather::ContactForce>,
    records: Vec<GForce<R>>,
    gravity: [f64; 2],
}

fn force_scene<R: Real>(rng: &mut Rng) -> ForceScene<R> {
    let mut deck = String::from("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK -1,-1 -1,0 9,0 9,-1\n");
    for row in 0..6 {
        let shift = if row % 2 == 0 { 0.0 } else { 0.5 };
        for i in 0..8 {
            let (x0, y0) = (i as f64 + shift, row as f64 * 0.5);
            deck += &format!("BLOCK {x0},{y0} {x0},{} {},{} {},{y0}\n", y0 + 0.5, x0 + 1.0, y0 + 0.5, x0 + 1.0);
        }
    }
    deck += "FIX -1 9 -1 -0.1\nGRAV 0 -10\nCYCLE 1\n";
    let mut model = blockdem::scenes::run_deck_on(&deck, Target::Cpu.backend()).unwrap();
    assert!(model.contacts.len() > 100, "{} contacts", model.contacts.len());
    for b in &mut model.blocks {
        b.mass = q::<R>(10f64.powf(rng.range(1.0, 4.0)));
        b.load = [q::<R>(rng.range(-1e3, 1e3)), q::<R>(rng.range(-1e3, 1e3))];
    }
    let gravity = [q::<R>(rng.range(-1.0, 1.0)), q::<R>(-10.0)];
    let centroids: Vec<[f64; 2]> = model.blocks.iter().map(|b| b.centroid).collect();
    let mut records = Vec::new();
    for c in &mut model.contacts {
        let c2 = centroids[c.block2 as usize];
        let c1 = centroids[c.block1 as usize];
        let rel = [q::<R>(rng.range(-1.0, 1.0)), q::<R>(rng.range(-1.0, 1.0))];
        c.point = [c2[0] + rel[0], c2[1] + rel[1]];
        c.force = [q::<R>(rng.range(-1e5, 1e5)), q::<R>(rng.range(-1e5, 1e5))];
        let f = c.force;
        let r1 = [rel[0] - (c1[0] - c2[0]), rel[1] - (c1[1] - c2[1])];
        records.push(GForce::<R> {
            fx: R::from_f64(f[0]),
            fy: R::from_f64(f[1]),
            m: [R::from_f64(r1[0] * f[1] - r1[1] * f[0]), R::from_f64(rel[1] * f[0] - rel[0] * f[1])],
        });
    }
    let adjacency = blockdem::udec::topology::Adjacency::build(model.blocks.len(), &model.contacts);
    let forces = model.contacts.iter().map(Into::into).collect();
    ForceScene { model, adjacency, forces, records, gravity }
}

/// Stage 6 on the device against the CPU's on `force_scene`: the device sums the gather records,
/// the CPU the contacts' points and forces, both in adjacency order. f64: the same sums to
/// rounding (the moments are formed before the sum on the device, inside it on the CPU: a few
/// ulps of the terms' magnitudes). f32: records and block fields rounded to f32, each of the
/// n + 1 additions off by 2⁻²⁴ of the running magnitude, so 1e-6 × (n + 2) of the sum of the
/// terms' magnitudes bounds it.
fn force_sum_matches_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_0000_0000_0009);
    let ForceScene { mut model, adjacency, forces, records, gravity } = force_scene::<R>(&mut rng);
    let gblocks: Vec<GBlock<R>> = model
        .blocks
        .iter()
        .map(|b| GBlock::<R> { mass: R::from_f64(b.mass), load_x: R::from_f64(b.load[0]), load_y: R::from_f64(b.load[1]), ..bytemuck::Zeroable::zeroed() })
        .collect();
    let params = GParams::<R> { gx: R::from_f64(gravity[0]), gy: R::from_f64(gravity[1]), one: 1, ..bytemuck::Zeroable::zeroed() };
    let nb = model.blocks.len();
    let out = run_kernel(
        dev,
        "gather",
        FORCE_SUM,
        "test_force_sum",
        nb,
        &[
            (0, bytemuck::bytes_of(&params).to_vec(), false),
            (1, bytemuck::cast_slice(&gblocks).to_vec(), false),
            (5, bytemuck::cast_slice(&adjacency.offsets).to_vec(), false),
            (6, bytemuck::cast_slice(&adjacency.entries).to_vec(), false),
            (8, bytemuck::cast_slice(&records).to_vec(), false),
            (21, vec![0; 3 * nb * std::mem::size_of::<R>()], true),
        ],
    );
    let got = back::<R>(&out[0]);
    for (b, block) in model.blocks.iter_mut().enumerate() {
        blockdem::udec::cpu::gather::gather(b, block, &forces, &adjacency, gravity);
        let entries = adjacency.entries(b);
        // The magnitudes summed: weight and load, then each contact's force and moment.
        let base = (block.mass * gravity[0]).abs() + block.load[0].abs() + (block.mass * gravity[1]).abs() + block.load[1].abs();
        let scale = base
            + entries
                .iter()
                .map(|&e| records[e.contact() as usize])
                .map(|r| r.fx.to_f64().abs() + r.fy.to_f64().abs() + r.m[0].to_f64().abs() + r.m[1].to_f64().abs())
                .sum::<f64>();
        let tol = if f32_kernel { 1e-6 * (entries.len() as f64 + 2.0) } else { 1e-14 } * scale;
        let want = [block.force[0], block.force[1], block.moment];
        for i in 0..3 {
            assert!((got[3 * b + i] - want[i]).abs() <= tol, "block {b} ({} entries), component {i}: {:e} vs {:e}", entries.len(), got[3 * b + i], want[i]);
        }
    }
}

/// The block pass, the `law_of_motion` kernel itself (stage 6 of the last cycle, then stages 1
/// and 2), against the CPU's `gather`, `law_of_motion` and `geometry_update` on `force_scene`,
/// each free block given a random velocity (to 5 m/s), spin (to 20 rad/s), rotation (to ±100
/// rad), moment of inertia and update reference, under a random mass damping (α to 50 /s);
/// some blocks fixed. Compared: velocities, centroid (the compensated pair), rotation (in f32
/// the placed angle plus the turn since), corners and circle centres relative to the centroid
/// (in f32 turned by the turn since, as a read-back turns them), the update distance and the
/// external and damping work of the step. Tolerances: each quantity's rounding relative to the
/// magnitudes it is made of, u = 1e-6 in f32 (a few operations of 2⁻²⁴, the force sum's n + 2
/// additions counted apart), 1e-13 in f64 (fused multiply–adds allowed); a corner at radius r
/// moves with the rotation's error times r, and in f32 `sin_cos` is good to 2.5e-7.
fn law_of_motion_matches_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let precision = if f32_kernel { Precision::F32 } else { Precision::F64 };
    let u = if f32_kernel { 1e-6 } else { 1e-13 };
    let mut rng = Rng(0x5eed_0000_0000_000a);
    let ForceScene { mut model, adjacency, forces, records, gravity } = force_scene::<R>(&mut rng);
    let (dt, alpha) = (q::<R>(1e-4), q::<R>(rng.range(0.0, 50.0)));
    for (i, b) in model.blocks.iter_mut().enumerate() {
        b.fixed |= i % 13 == 5;
        b.centroid = [q::<R>(b.centroid[0]), q::<R>(b.centroid[1])];
        b.velocity = [q::<R>(rng.range(-5.0, 5.0)), q::<R>(rng.range(-5.0, 5.0))];
        b.angular_velocity = q::<R>(rng.range(-20.0, 20.0));
        b.inertia = q::<R>(b.mass * 10f64.powf(rng.range(-2.0, 0.0)));
        b.radius = q::<R>(b.radius);
        // An angle the device holds exactly: the placed angle and the turn since, each a real.
        let (placed, turn) = split_rotation(rng.range(-100.0, 100.0), precision);
        b.rotation = q::<R>(placed) + q::<R>(turn);
        b.update_rotation = q::<R>(b.rotation + rng.range(-0.01, 0.01));
        b.update_centroid = [q::<R>(b.centroid[0] + rng.range(-0.01, 0.01)), q::<R>(b.centroid[1] + rng.range(-0.01, 0.01))];
        b.moved_since_update = q::<R>(rng.range(0.0, 0.01));
        b.update_margin = q::<R>(rng.range(0.0, 0.01));
        b.damping_work = 0.0;
    }
    for c in &mut model.corners {
        c.local = [q::<R>(c.local[0]), q::<R>(c.local[1])];
        c.circle_local = [q::<R>(c.circle_local[0]), q::<R>(c.circle_local[1])];
    }
    // The corners where the blocks' rotations put them, then both as an upload converts them.
    for b in 0..model.blocks.len() {
        let (start, count) = (model.blocks[b].corner_start as usize, model.blocks[b].corner_count as usize);
        blockdem::udec::cpu::geometry_update::geometry_update(&model.blocks[b], &mut model.corners[start..start + count]);
    }
    let gblocks: Vec<GBlock<R>> = model.blocks.iter().map(|b| GBlock::<R>::from_model(b, [0.0, 0.0])).collect();
    let gcorners: Vec<GCorner<R>> = model.corners.iter().map(|c| GCorner::<R>::from_model(&model.blocks, c)).collect();
    let r = R::from_f64;
    let turned = |x: [f64; 2], a: f64| {
        let (s, c) = a.sin_cos();
        [c * x[0] - s * x[1], s * x[0] + c * x[1]]
    };
    let params = GParams::<R> {
        dt: r(dt),
        alpha: r(alpha),
        gx: r(gravity[0]),
        gy: r(gravity[1]),
        etol: r(0.025),
        fast_limit: r(1e9),
        overlap_limit: r(1.0),
        n_blocks: model.blocks.len() as u32,
        n_corners: model.corners.len() as u32,
        n_contacts: model.contacts.len() as u32,
        one: 1,
        ..bytemuck::Zeroable::zeroed()
    };
    let flags = blockdem::udec::gpu::layout::Flags::cleared();
    let nb = model.blocks.len();
    let out = run_kernel(
        dev,
        "law_of_motion",
        "",
        "law_of_motion",
        nb,
        &[
            (0, bytemuck::bytes_of(&params).to_vec(), false),
            (1, bytemuck::cast_slice(&gblocks).to_vec(), true),
            (2, bytemuck::cast_slice(&gcorners).to_vec(), true),
            (5, bytemuck::cast_slice(&adjacency.offsets).to_vec(), false),
            (6, bytemuck::cast_slice(&adjacency.entries).to_vec(), false),
            (7, bytemuck::bytes_of(&flags).to_vec(), false),
            (8, bytemuck::cast_slice(&records).to_vec(), false),
        ],
    );
    let got_blocks: Vec<GBlock<R>> = bytemuck::pod_collect_to_vec(&out[0]);
    let got_corners: Vec<GCorner<R>> = bytemuck::pod_collect_to_vec(&out[1]);
    let mut placed_again = 0;
    for b in 0..nb {
        let before = model.blocks[b].clone();
        let entries = adjacency.entries(b);
        let block = &mut model.blocks[b];
        if !block.fixed {
            blockdem::udec::cpu::gather::gather(b, block, &forces, &adjacency, gravity);
        }
        let step = blockdem::udec::cpu::law_of_motion::law_of_motion(block, gravity, alpha, dt);
        let range = block.corner_start as usize..(block.corner_start + block.corner_count) as usize;
        blockdem::udec::cpu::geometry_update::geometry_update(block, &mut model.corners[range.clone()]);
        let block = &model.blocks[b];
        let g = &got_blocks[b];
        let f = |x: R| x.to_f64();
        let what = format!("block {b} ({} entries, fixed {})", entries.len(), block.fixed);
        // Magnitudes the step is made of: the force sum's terms, then the velocity update.
        let terms = |i: usize| {
            entries
                .iter()
                .map(|&e| {
                    let r = records[e.contact() as usize];
                    [r.fx, r.fy, r.m[e.side() as usize]][i].to_f64().abs()
                })
                .sum::<f64>()
        };
        let sum_u = u * (entries.len() as f64 + 4.0);
        let fscale =
            [terms(0) + (block.mass * gravity[0]).abs() + block.load[0].abs(), terms(1) + (block.mass * gravity[1]).abs() + block.load[1].abs(), terms(2)];
        let tol_v = [
            u * before.velocity[0].abs() + sum_u * fscale[0] * dt / block.mass + 1e-30,
            u * before.velocity[1].abs() + sum_u * fscale[1] * dt / block.mass + 1e-30,
            u * before.angular_velocity.abs() + sum_u * fscale[2] * dt / block.inertia + 1e-30,
        ];
        let near = |got: f64, want: f64, tol: f64, name: &str| assert!((got - want).abs() <= tol, "{what}: {name} {got:e} vs {want:e} (tolerance {tol:e})");
        near(f(g.vx), block.velocity[0], tol_v[0], "vx");
        near(f(g.vy), block.velocity[1], tol_v[1], "vy");
        near(f(g.w), block.angular_velocity, tol_v[2], "w");
        if block.fixed {
            continue;
        }
        let d = [block.centroid[0] - before.centroid[0], block.centroid[1] - before.centroid[1]];
        near(f(g.cx) + f(g.cx_lo), block.centroid[0], tol_v[0] * dt + u * d[0].abs() + 1e-15 * block.centroid[0].abs(), "x");
        near(f(g.cy) + f(g.cy_lo), block.centroid[1], tol_v[1] * dt + u * d[1].abs() + 1e-15 * block.centroid[1].abs(), "y");
        let dtheta = block.rotation - before.rotation;
        let tol_theta = tol_v[2] * dt + u * dtheta.abs() + 1e-15 * block.rotation.abs() + 1e-12;
        near(f(g.rotation) + f(g.rotation_lo), block.rotation, tol_theta, "rotation");
        placed_again += usize::from(g.rotation != gblocks[b].rotation);
        let tol_corner = |x: [f64; 2]| {
            let radius = x[0].hypot(x[1]);
            (if f32_kernel { 2.5e-7 } else { 1e-14 } + u + tol_theta) * radius
        };
        for k in range {
            let (c, gc) = (&model.corners[k], &got_corners[k]);
            let p = turned([f(gc.px), f(gc.py)], f(g.rotation_lo));
            let o = turned([f(gc.ox), f(gc.oy)], f(g.rotation_lo));
            let want_p = [c.position[0] - block.centroid[0], c.position[1] - block.centroid[1]];
            let want_o = [c.circle[0] - block.centroid[0], c.circle[1] - block.centroid[1]];
            for i in 0..2 {
                near(p[i], want_p[i], tol_corner(want_p), "corner");
                near(o[i], want_o[i], tol_corner(want_o), "circle centre");
            }
        }
        near(f(g.moved), block.moved_since_update, 10.0 * u * block.moved_since_update + block.radius * tol_theta + 1e-12, "update distance");
        let ext = (block.mass * gravity[0] + block.load[0]).abs() * d[0].abs() + (block.mass * gravity[1] + block.load[1]).abs() * d[1].abs();
        near(f(g.work), step.external_work, 10.0 * u * ext + 1e-30, "external work");
        near(f(g.damping_work), block.damping_work, 10.0 * u * block.damping_work + 1e-30, "damping work");
    }
    // In f32 some blocks turned past half a step and had their corners placed again.
    assert!(!f32_kernel || placed_again > 0, "no block placed its corners again");
}

const TWO_SUM: &str = r#"
@group(0) @binding(20) var<storage, read> t_in: array<real>;
@group(0) @binding(21) var<storage, read_write> t_out: array<real>;
@group(0) @binding(22) var<storage, read> t_one: array<real>;

@compute @workgroup_size(64)
fn test_two_sum(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (2u * i >= arrayLength(&t_in)) {
        return;
    }
    let s = two_sum(t_in[2u * i], t_in[2u * i + 1u], t_one[0]);
    t_out[2u * i] = s.x;
    t_out[2u * i + 1u] = s.y;
}
"#;

/// Knuth's TwoSum in the kernel precision (Rust does not rewrite floating point): the exact
/// rounding error of a + b.
fn two_sum_rust<R: Real + std::ops::Add<Output = R> + std::ops::Sub<Output = R>>(a: R, b: R) -> (R, R) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

fn two_sum_is_exact<R: Real + std::ops::Add<Output = R> + std::ops::Sub<Output = R>>(dev: &GpuDevice) {
    let mut rng = Rng(0x5eed_0000_0000_0005);
    let cases = 4096;
    let mut input = Vec::new();
    for _ in 0..cases {
        // A coordinate of 1–1e4 m and a step of 1e-9–1e-3 m of either sign (the position update
        // of law_of_motion), and now and then the other way round.
        let sign = |x: f64, r: &mut Rng| if r.next() < 0.5 { -x } else { x };
        let a = sign(rng.range(1.0, 1e4), &mut rng);
        let b = sign(10f64.powf(rng.range(-9.0, -3.0)), &mut rng);
        if rng.next() < 0.1 {
            input.extend([q::<R>(b), q::<R>(a)]);
        } else {
            input.extend([q::<R>(a), q::<R>(b)]);
        }
    }
    let out = run_kernel(
        dev,
        "contact_forces",
        TWO_SUM,
        "test_two_sum",
        cases,
        &[(20, reals::<R>(&input), false), (21, vec![0; cases * 2 * std::mem::size_of::<R>()], true), (22, reals::<R>(&[1.0]), false)],
    );
    let got = back::<R>(&out[0]);
    for i in 0..cases {
        // Exact: sum and error bit for bit, and together a + b (the error is not lost, as it was
        // when the compiler folded it to 0).
        let (s, e) = two_sum_rust(R::from_f64(input[2 * i]), R::from_f64(input[2 * i + 1]));
        assert!(
            got[2 * i] == s.to_f64() && got[2 * i + 1] == e.to_f64(),
            "{} + {}: ({}, {}) vs ({:?}, {:?})",
            input[2 * i],
            input[2 * i + 1],
            got[2 * i],
            got[2 * i + 1],
            s,
            e
        );
    }
    assert!((0..cases).filter(|&i| got[2 * i + 1] != 0.0).count() > cases / 2, "most sums round");
}

const SIN_COS: &str = r#"
@group(0) @binding(20) var<storage, read> s_in: array<real>;
@group(0) @binding(21) var<storage, read_write> s_out: array<real>;

@compute @workgroup_size(64)
fn test_sin_cos(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&s_in)) {
        return;
    }
    let cs = sin_cos(s_in[i]);
    s_out[2u * i] = cs.x;
    s_out[2u * i + 1u] = cs.y;
}
"#;

fn sin_cos_matches_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_0000_0000_0003);
    let cases = 4096;
    let thetas: Vec<f64> = (0..cases).map(|i| q::<R>(if i % 2 == 0 { rng.range(-0.5, 0.5) } else { rng.range(-100.0, 100.0) })).collect();
    let out = run_kernel(
        dev,
        "contact_forces",
        SIN_COS,
        "test_sin_cos",
        cases,
        &[(20, reals::<R>(&thetas), false), (21, vec![0; cases * 2 * std::mem::size_of::<R>()], true)],
    );
    let got = back::<R>(&out[0]);
    for (i, &t) in thetas.iter().enumerate() {
        let (s, c) = t.sin_cos();
        let rust_twin = blockdem::udec::gpu::kernels::sin_cos(t);
        // f64: a few ulps (the Cody–Waite reduction by k·π/2 is exact for |θ| ≤ 100). f32: π/2
        // in three parts of few bits (the prelude's PIO2_*), so the reduction is exact but for the
        // rounding of r itself, whatever |θ|: the f32 polynomial's few ulps (it was 1e-6 +
        // 2.4e-7·|θ| when k·π/2 was rounded to one f32).
        let tol = if f32_kernel { 2.5e-7 } else { 4e-16 };
        assert!((got[2 * i] - c).abs() <= tol && (got[2 * i + 1] - s).abs() <= tol, "θ = {t}: ({}, {}) vs ({c}, {s})", got[2 * i], got[2 * i + 1]);
        assert!((rust_twin.0 - c).abs() <= 4e-16 && (rust_twin.1 - s).abs() <= 4e-16, "Rust twin at θ = {t}");
    }
}

/// `splice_contacts.wgsl` against `gpu::splice::splice_contacts` and `patch_contacts` on a random
/// old list, a random edit (a few dropped, new contacts between the kept ones, as runs) with
/// random created contacts, and random patches of kept contacts (and one past the list): the
/// kernels only copy and clear, so the lists agree bit for bit in both precisions.
fn splice_contacts_matches_rust<R: Real>(dev: &GpuDevice) {
    let mut rng = Rng(0x5eed_0000_0000_0004);
    let contact = |rng: &mut Rng| {
        let mut c: GContact<R> = bytemuck::Zeroable::zeroed();
        let reals: &mut [R] = bytemuck::cast_slice_mut(&mut bytemuck::bytes_of_mut(&mut c)[..15 * std::mem::size_of::<R>()]);
        for x in reals.iter_mut() {
            *x = R::from_f64(rng.range(-1e3, 1e3));
        }
        (c.block1, c.corner, c.block2, c.feature, c.material, c.bonded) =
            (rng.below(1000), rng.below(4000), rng.below(1000), rng.below(8), rng.below(4), rng.below(2));
        c
    };
    let force = |rng: &mut Rng| GForce::<R> {
        fx: R::from_f64(rng.range(-1e6, 1e6)),
        fy: R::from_f64(rng.range(-1e6, 1e6)),
        m: [R::from_f64(rng.next()), R::from_f64(-rng.next())],
    };
    let n_old = 3000u32;
    let old: Vec<GContact<R>> = (0..n_old).map(|_| contact(&mut rng)).collect();
    let old_forces: Vec<GForce<R>> = (0..n_old).map(|_| force(&mut rng)).collect();
    let (mut dropped, mut insert_before) = (Vec::new(), Vec::new());
    for k in 0..=n_old {
        while rng.next() < 0.1 {
            insert_before.push(k);
        }
        if k < n_old && rng.next() < 0.05 {
            dropped.push(k);
        }
    }
    let created: Vec<GContact<R>> = insert_before.iter().map(|_| contact(&mut rng)).collect();
    let created_forces: Vec<GForce<R>> = insert_before.iter().map(|_| force(&mut rng)).collect();
    let mut positions: Vec<u32> = (0..n_old).collect();
    let inserted_at = blockdem::udec::topology::detect::splice(&mut positions, &dropped, &insert_before, std::iter::repeat_n(u32::MAX, insert_before.len()));
    let edit = ListEdit { old_len: n_old, dropped, insert_before, inserted_at, entries: None };
    let runs = edit.runs(NEW_CONTACT);
    let n = edit.new_len() as usize;
    // A fifth of the kept contacts patched, as a partial read-back gives them.
    let mut patches: Vec<GPatch<R>> = Vec::new();
    for k in (0..n_old).filter(|k| edit.dropped.binary_search(k).is_err()) {
        if rng.next() < 0.2 {
            let length = if rng.next() < 0.5 { 0.0 } else { rng.range(0.0, 2.0) };
            patches.push(GPatch { length: R::from_f64(length), index: edit.new_index(k), feature: rng.below(8) });
        }
    }
    patches.push(GPatch { length: R::from_f64(1.0), index: n as u32 + 5, feature: 3 });
    let (mut want, want_forces) = splice_contacts(&old, &old_forces, &runs, &created, &created_forces);
    let out = run_kernel(
        dev,
        "splice_contacts",
        "",
        "splice_contacts",
        n,
        &[
            (0, bytemuck::cast_slice(&old).to_vec(), false),
            (1, bytemuck::cast_slice(&old_forces).to_vec(), false),
            (2, bytemuck::cast_slice(&runs).to_vec(), false),
            (3, bytemuck::cast_slice(&created).to_vec(), false),
            (4, bytemuck::cast_slice(&created_forces).to_vec(), false),
            (5, vec![0; n * std::mem::size_of::<GContact<R>>()], true),
            (6, vec![0; n * std::mem::size_of::<GForce<R>>()], true),
        ],
    );
    assert!(created.len() > 200 && edit.dropped.len() > 100 && runs.len() > 300, "the case creates and drops");
    assert_eq!(bytemuck::cast_slice::<GContact<R>, u8>(&want), &out[0][..], "contacts");
    assert_eq!(bytemuck::cast_slice::<GForce<R>, u8>(&want_forces), &out[1][..], "gather records");
    // The patches on the spliced list.
    let patched = run_kernel(
        dev,
        "splice_contacts",
        "",
        "patch_contacts",
        patches.len(),
        &[(2, bytemuck::cast_slice(&runs).to_vec(), false), (5, out[0].clone(), true), (7, bytemuck::cast_slice(&patches).to_vec(), false)],
    );
    patch_contacts(&mut want, &patches);
    assert!(patches.len() > 300);
    assert_eq!(bytemuck::cast_slice::<GContact<R>, u8>(&want), &patched[0][..], "patched contacts");

    // `pack_contacts.wgsl` on the spliced list: the summaries a contact update reads back.
    let packed = run_kernel(
        dev,
        "pack_contacts",
        "",
        "pack_contacts",
        n,
        &[(0, bytemuck::cast_slice(&want).to_vec(), false), (1, vec![0; n * std::mem::size_of::<GSummary<R>>()], true)],
    );
    assert_eq!(bytemuck::cast_slice::<GSummary<R>, u8>(&pack_contacts(&want)), &packed[0][..], "contact summaries");
}

/// `splice_adjacency.wgsl` against `gpu::splice::splice_adjacency` and `shift_offsets` on random
/// old entries, runs (stretches of old entries and of new lists), a random contact edit's
/// renumbering, and random touched lists shifting random offsets both ways: integer work, the
/// same bit for bit.
/// (Generic like its neighbours for `on_adapters!`: integer work, in either precision's prelude.)
#[allow(clippy::extra_unused_type_parameters)]
fn splice_adjacency_matches_rust<R: Real>(dev: &GpuDevice) {
    let mut rng = Rng(0x5eed_0000_0000_0006);
    let n_old = 5000u32;
    let old: Vec<AdjacencyEntry> = (0..2 * n_old).map(|_| AdjacencyEntry::new(rng.below(n_old), rng.below(2))).collect();
    let (mut dropped, mut insert_before) = (Vec::new(), Vec::new());
    for k in 0..=n_old {
        if rng.next() < 0.05 {
            insert_before.push(k);
        }
        if k < n_old && rng.next() < 0.05 {
            dropped.push(k);
        }
    }
    let renumber = renumber_table(&ListEdit { old_len: n_old, dropped, insert_before, ..Default::default() });
    let (mut runs, mut lists, mut at) = (Vec::new(), Vec::new(), 0u32);
    let mut new_len = 0u32;
    while at < 2 * n_old {
        let len = 1 + rng.below(40);
        if rng.next() < 0.3 {
            runs.push([new_len, FROM_LISTS | lists.len() as u32]);
            lists.extend((0..len).map(|_| AdjacencyEntry::from_raw(rng.below(1 << 30))));
        } else {
            let len = len.min(2 * n_old - at);
            runs.push([new_len, at]);
            at += len + rng.below(3);
            new_len += len;
            continue;
        }
        new_len += len;
    }
    runs.push([new_len, 0]);
    let want = splice_adjacency(&old, &runs, &lists, &renumber);
    let out = run_kernel(
        dev,
        "splice_adjacency",
        "",
        "splice_adjacency",
        new_len as usize,
        &[
            (0, bytemuck::cast_slice(&old).to_vec(), false),
            (1, bytemuck::cast_slice(&runs).to_vec(), false),
            (2, bytemuck::cast_slice(&lists).to_vec(), false),
            (3, bytemuck::cast_slice(&renumber).to_vec(), false),
            (4, vec![0; new_len as usize * 4], true),
        ],
    );
    assert!(renumber.len() > 300 && runs.len() > 200 && !lists.is_empty(), "the case renumbers and splices");
    assert_eq!(bytemuck::cast_slice::<AdjacencyEntry, u8>(&want), &out[0][..], "entries");
    // Offsets after touched lists that grew and shrank; the blocks after the offsets stay.
    let n_blocks = 4000u32;
    let mut offsets: Vec<u32> = (0..=n_blocks).map(|b| 1_000_000 + 10 * b).chain([7, 8, 9]).collect();
    let mut touched: Vec<[u32; 2]> = Vec::new();
    let mut shift = 0i32;
    for t in 0..n_blocks {
        if rng.next() < 0.05 {
            shift += rng.below(9) as i32 - 4;
            touched.push([t, shift as u32]);
        }
    }
    touched.push([n_blocks + 1, 0]);
    let shifted = run_kernel(
        dev,
        "splice_adjacency",
        "",
        "shift_offsets",
        n_blocks as usize + 1,
        &[(5, bytemuck::cast_slice(&offsets).to_vec(), true), (6, bytemuck::cast_slice(&touched).to_vec(), false)],
    );
    shift_offsets(&mut offsets, &touched);
    assert_eq!(&offsets[n_blocks as usize + 1..], [7, 8, 9]);
    assert_eq!(bytemuck::cast_slice::<u32, u8>(&offsets), &shifted[0][..], "offsets");
}

/// `list_blocks.wgsl` against `gpu::partial::list_blocks` and `list_contacts` on random blocks
/// (some near their update threshold, some strayed from a random grid reference, some fixed) and
/// random contacts. f64: the same lists and the same fewest cycles. f32: a block or contact
/// within round-off of a threshold may be listed by one and not the other (the CPU applies its
/// exact test to what is listed, and the lists are loosened by 1% for that): at most 1% of the
/// cases; the fewest cycles to within 1 (⌊room / s⌋ at a rounding edge) and 1e-5 relative.
fn update_lists_match_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_0000_0000_0005);
    let r = |x: f64| R::from_f64(x);
    let (nb, nk) = (3000usize, 8000usize);
    let mut blocks: Vec<GBlock<R>> = Vec::with_capacity(nb);
    let mut reference: Vec<GridReference<R>> = Vec::with_capacity(nb);
    for _ in 0..nb {
        let mut b: GBlock<R> = bytemuck::Zeroable::zeroed();
        let (x, y) = (rng.range(-50.0, 50.0), rng.range(0.0, 12.0));
        (b.cx, b.cy, b.cx_lo, b.cy_lo) = (r(x), r(y), r(rng.range(-1e-7, 1e-7)), r(rng.range(-1e-7, 1e-7)));
        b.rotation = r(rng.range(-0.1, 0.1));
        let fast = rng.next() < 0.3;
        let speed = if fast { 50.0 } else { 0.1 };
        (b.vx, b.vy, b.w) = (r(rng.range(-speed, speed)), r(rng.range(-speed, speed)), r(rng.range(-1.0, 1.0)));
        if rng.next() < 0.1 {
            (b.vx, b.vy, b.w) = (r(0.0), r(0.0), r(0.0));
        }
        b.radius = r(rng.range(0.3, 1.0));
        b.update_margin = r(if fast { rng.range(0.0, 0.2) } else { 0.0 });
        b.moved = r(rng.range(0.0, 0.06));
        b.fixed = (rng.next() < 0.1) as u32;
        let d = rng.range(0.0, 0.06);
        let a = rng.range(0.0, std::f64::consts::TAU);
        let (rx, ry) = (x + d * a.cos(), y + d * a.sin());
        let split = |v: f64| (r(v), r(v - r(v).to_f64()));
        let ((x_hi, x_lo), (y_hi, y_lo)) = (split(rx), split(ry));
        let margin = if rng.next() < 0.5 { b.update_margin } else { r(rng.range(0.0, 0.2)) };
        reference.push(GridReference {
            x: x_hi,
            y: y_hi,
            x_lo,
            y_lo,
            rotation: r(b.rotation.to_f64() + rng.range(-0.02, 0.02)),
            reach: b.radius,
            margin,
            _r: R::default(),
        });
        blocks.push(b);
    }
    let contacts: Vec<GContact<R>> = (0..nk)
        .map(|_| {
            let mut c: GContact<R> = bytemuck::Zeroable::zeroed();
            c.gap = r(rng.range(-0.01, 0.5));
            (c.block1, c.block2) = (rng.below(nb as u32), rng.below(nb as u32));
            c
        })
        .collect();
    let lp =
        ListParams::<R> { dt: r(1e-4), etol: r(0.025), btol: r(0.15), stray_limit: r(0.05), n_blocks: nb as u32, n_contacts: nk as u32, grid_kept: 1, _pad: 0 };
    let header = bytemuck::cast_slice(&[0u32, 0, u32::MAX, 0]).to_vec();
    let out = run_kernel(
        dev,
        "list_blocks",
        "",
        "list_blocks",
        nb,
        &[
            (0, bytemuck::bytes_of(&lp).to_vec(), false),
            (1, bytemuck::cast_slice(&blocks).to_vec(), false),
            (3, bytemuck::cast_slice(&reference).to_vec(), false),
            (4, header.clone(), true),
            (5, vec![0; nb * 4], true),
        ],
    );
    let (want, want_fewest) = blockdem::udec::gpu::partial::list_blocks(&blocks, &reference, &lp);
    let head: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
    let mut got: Vec<u32> = bytemuck::pod_collect_to_vec::<u8, u32>(&out[1])[..head[0] as usize].to_vec();
    got.sort_unstable();
    let differ = |a: &[u32], b: &[u32]| a.iter().filter(|x| b.binary_search(x).is_err()).count() + b.iter().filter(|x| a.binary_search(x).is_err()).count();
    assert!(want.len() > nb / 10 && want.len() < nb * 9 / 10, "a mixed case: {} of {nb} blocks listed", want.len());
    let off = differ(&want, &got);
    if f32_kernel {
        assert!(off <= nb / 100, "{off} blocks listed by one only");
        let (a, b) = (head[2] as f64, want_fewest as f64);
        assert!((a - b).abs() <= 1.0 + 1e-5 * b, "fewest cycles {a} against {b}");
    } else {
        assert!(off == 0 && head[2] == want_fewest, "{off} blocks listed by one only; fewest cycles {} against {want_fewest}", head[2]);
    }

    let out = run_kernel(
        dev,
        "list_blocks",
        "",
        "list_contacts",
        nk,
        &[
            (0, bytemuck::bytes_of(&lp).to_vec(), false),
            (1, bytemuck::cast_slice(&blocks).to_vec(), false),
            (2, bytemuck::cast_slice(&contacts).to_vec(), false),
            (4, header, true),
            (6, vec![0; nk * 4], true),
        ],
    );
    let want = blockdem::udec::gpu::partial::list_contacts(&blocks, &contacts, &lp);
    let head: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
    let mut got: Vec<u32> = bytemuck::pod_collect_to_vec::<u8, u32>(&out[1])[..head[1] as usize].to_vec();
    got.sort_unstable();
    assert!(want.len() > nk / 10 && want.len() < nk * 9 / 10, "a mixed case: {} of {nk} contacts listed", want.len());
    let off = differ(&want, &got);
    assert!(if f32_kernel { off <= nk / 100 } else { off == 0 }, "{off} contacts listed by one only");
}

macro_rules! on_adapters {
    ($($name:ident => $check:ident),* $(,)?) => {
        $(
            mod $name {
                #[test]
                fn vulkan_f32() {
                    if let Some(d) = super::device("vulkan", blockdem::udec::gpu::Precision::F32) { super::$check::<f32>(&d) }
                }
                #[test]
                fn vulkan_f64() {
                    if let Some(d) = super::device("vulkan", blockdem::udec::gpu::Precision::F64) { super::$check::<f64>(&d) }
                }
                #[test]
                fn gl_f32() {
                    if let Some(d) = super::device("gl", blockdem::udec::gpu::Precision::F32) { super::$check::<f32>(&d) }
                }
            }
        )*
    };
}

on_adapters!(
    track_feature_and_counts_force => track_feature_matches_rust,
    contact_force_law => contact_force_law_matches_rust,
    mass_damping_work => mass_damping_work_matches_rust,
    force_sum => force_sum_matches_rust,
    law_of_motion => law_of_motion_matches_rust,
    sin_cos => sin_cos_matches_rust,
    two_sum => two_sum_is_exact,
    splice => splice_contacts_matches_rust,
    splice_adjacency => splice_adjacency_matches_rust,
    update_lists => update_lists_match_rust,
    zones => zones_match_rust,
    gather_gridpoints => gather_gridpoints_matches_rust,
);

/// A zoned irregular pentagon as the device holds it (positions and velocities rounded to the
/// kernel precision, so the CPU twin sees the GPU's inputs), with random stresses and
/// velocities: the model's extension and the FDEF slots' records (one block, its λ and G).
struct ZonedPatch<R: Real> {
    fdef: blockdem::udec::model::fdef::Fdef,
    gridpoints: Vec<blockdem::udec::gpu::layout::GridPoint<R>>,
    zones: Vec<blockdem::udec::gpu::layout::Zone<R>>,
    block: blockdem::udec::gpu::layout::FdefBlock<R>,
    csr: Vec<u32>,
    lambda: f64,
    shear: f64,
}

fn zoned_patch<R: Real>(rng: &mut Rng) -> ZonedPatch<R> {
    use blockdem::udec::gpu::layout::{FdefBlock, GridPoint, Zone};
    let outline = [[0.0, 0.0], [3.1, 0.4], [3.6, 2.3], [1.2, 3.4], [-0.7, 1.9]];
    let mesh = blockdem::udec::model::zoning::auto_mesh(&outline, 0.4).unwrap();
    let mut fdef = blockdem::udec::model::fdef::Fdef::from_mesh(&mesh, 2000.0);
    for g in &mut fdef.gridpoints {
        g.position = g.position.map(|x| q::<R>(x + rng.range(-1e-3, 1e-3)));
        g.velocity = [q::<R>(rng.range(-0.1, 0.1)), q::<R>(rng.range(-0.1, 0.1))];
        g.mass = q::<R>(g.mass);
    }
    for z in &mut fdef.zones {
        z.stress = [q::<R>(rng.range(-1e6, 1e6)), q::<R>(rng.range(-1e6, 1e6)), q::<R>(rng.range(-1e6, 1e6))];
    }
    let (lambda, shear) = (q::<R>(1e9 - 2.0 * 6e8 / 3.0), q::<R>(6e8));
    let r = R::from_f64;
    let gridpoints = fdef
        .gridpoints
        .iter()
        .enumerate()
        .map(|(k, g)| GridPoint::<R> {
            x: r(g.position[0]),
            y: r(g.position[1]),
            vx: r(g.velocity[0]),
            vy: r(g.velocity[1]),
            mass: r(g.mass),
            ux: r(g.position[0]),
            uy: r(g.position[1]),
            boundary: ((k as u32) < fdef.boundary) as u32,
            ..bytemuck::Zeroable::zeroed()
        })
        .collect();
    let zones: Vec<Zone<R>> =
        fdef.zones.iter().map(|z| Zone { stress: z.stress.map(r), g0: z.gridpoints[0], g1: z.gridpoints[1], g2: z.gridpoints[2], block: 0 }).collect();
    let n = fdef.gridpoints.len();
    let mut lists = vec![Vec::new(); n];
    for (z, zone) in fdef.zones.iter().enumerate() {
        for (place, g) in zone.gridpoints.iter().enumerate() {
            lists[*g as usize].push(((z as u32) << 2) | place as u32);
        }
    }
    let mut csr = Vec::new();
    let mut at = (n + 1) as u32;
    for l in &lists {
        csr.push(at);
        at += l.len() as u32;
    }
    csr.push(at);
    csr.extend(lists.into_iter().flatten());
    let block = FdefBlock::<R> {
        lambda: r(lambda),
        shear: r(shear),
        gp_start: 0,
        gp_count: n as u32,
        boundary: fdef.boundary,
        zone_start: 0,
        zone_count: fdef.zones.len() as u32,
        fixed: 0,
    };
    ZonedPatch { fdef, gridpoints, zones, block, csr, lambda, shear }
}

fn fdef_params<R: Real>(dt: f64, gravity: [f64; 2]) -> GParams<R> {
    let r = R::from_f64;
    GParams::<R> { dt: r(dt), gx: r(gravity[0]), gy: r(gravity[1]), fast_limit: r(1e9), one: 1, ..bytemuck::Zeroable::zeroed() }
}

/// zones.wgsl's `zones` (each zone's stress increment from its grid points' velocities, and the
/// inverted-zone flag) against `cpu::zones::zones` on the same zoned pentagon, with one zone
/// turned inside out: the same stresses (f64 to 1e-9 of the largest; f32 to 1e-5: gradients of
/// f32 positions a zone apart) and the same zone flagged, left unstressed.
fn zones_match_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_0000_0000_0029);
    let mut p = zoned_patch::<R>(&mut rng);
    // Zone 5 turned inside out: its first two corners swapped in its record.
    let bad = 5;
    let zg = &mut p.fdef.zones[bad].gridpoints;
    zg.swap(0, 1);
    (p.zones[bad].g0, p.zones[bad].g1) = (zg[0], zg[1]);
    let dt = q::<R>(1e-4);
    let mut want = p.fdef.clone();
    let inverted = blockdem::udec::cpu::zones::zones(&mut want, p.lambda, p.shear, dt);
    assert_eq!(inverted, Some(bad as u32));
    let flags = blockdem::udec::gpu::layout::Flags::cleared();
    let out = run_kernel(
        dev,
        "zones",
        "",
        "zones",
        p.zones.len(),
        &[
            (0, bytemuck::bytes_of(&fdef_params::<R>(dt, [0.0, 0.0])).to_vec(), false),
            (7, bytemuck::bytes_of(&flags).to_vec(), true),
            (12, bytemuck::cast_slice(&p.gridpoints).to_vec(), false),
            (13, bytemuck::cast_slice(&p.zones).to_vec(), true),
            (14, bytemuck::bytes_of(&p.block).to_vec(), false),
        ],
    );
    let flags: blockdem::udec::gpu::layout::Flags = bytemuck::pod_read_unaligned(&out[0]);
    assert_eq!(
        (flags.errors & blockdem::udec::gpu::layout::ERR_ZONE_INVERTED, flags.inverted_zone),
        (blockdem::udec::gpu::layout::ERR_ZONE_INVERTED, bad as u32)
    );
    let got: Vec<blockdem::udec::gpu::layout::Zone<R>> = bytemuck::pod_collect_to_vec(&out[1]);
    let top = want.zones.iter().flat_map(|z| z.stress).fold(0.0f64, |a, s| a.max(s.abs()));
    let tol = if f32_kernel { 1e-5 } else { 1e-9 } * top;
    for (z, (g, w)) in got.iter().zip(&want.zones).enumerate() {
        for i in 0..3 {
            assert!((g.stress[i].to_f64() - w.stress[i]).abs() <= tol, "zone {z}: {:?} against {:?}", g.stress, w.stress);
        }
    }
    assert_eq!(got[bad].stress.map(|s| s.to_f64()), p.fdef.zones[bad].stress, "the inverted zone keeps its stress");
}

/// zones.wgsl's `gather_gridpoints` (gravity and each grid point's zones in ascending order)
/// against `cpu::zones::gather_fdef` on the same zoned pentagon without contacts: f64 bit for
/// bit but for the compiler's fused multiply–adds (1e-12 of the largest force), f32 to 1e-5.
fn gather_gridpoints_matches_rust<R: Real>(dev: &GpuDevice) {
    let f32_kernel = std::mem::size_of::<R>() == 4;
    let mut rng = Rng(0x5eed_0000_0000_002a);
    let p = zoned_patch::<R>(&mut rng);
    let gravity = [q::<R>(0.3), q::<R>(-9.81)];
    let mut want = p.fdef.clone();
    let square = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nSTOP\n";
    let mut block = blockdem::scenes::run_deck_on(square, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap().blocks[0].clone();
    block.mass = want.gridpoints.iter().map(|g| g.mass).sum();
    blockdem::udec::cpu::zones::gather_fdef(&mut block, &mut want, &[], &[], &[], &[], gravity, None);
    let words = |x: &[u32]| bytemuck::cast_slice::<u32, u8>(x).to_vec();
    let out = run_kernel(
        dev,
        "zones",
        "",
        "gather_gridpoints",
        p.gridpoints.len(),
        &[
            (0, bytemuck::bytes_of(&fdef_params::<R>(1e-4, gravity)).to_vec(), false),
            (5, words(&[0, 0]), false),
            (6, words(&[0]), false),
            (8, vec![0; 4 * std::mem::size_of::<R>()], false),
            (12, bytemuck::cast_slice(&p.gridpoints).to_vec(), true),
            (13, bytemuck::cast_slice(&p.zones).to_vec(), false),
            (16, words(&p.csr), false),
            (17, vec![0; 32], false),
        ],
    );
    let got: Vec<blockdem::udec::gpu::layout::GridPoint<R>> = bytemuck::pod_collect_to_vec(&out[0]);
    let top = want.gridpoints.iter().flat_map(|g| g.force).fold(0.0f64, |a, f| a.max(f.abs()));
    let tol = if f32_kernel { 1e-5 } else { 1e-12 } * top;
    for (k, (g, w)) in got.iter().zip(&want.gridpoints).enumerate() {
        let f = [g.fx.to_f64(), g.fy.to_f64()];
        assert!((f[0] - w.force[0]).abs() <= tol && (f[1] - w.force[1]).abs() <= tol, "grid point {k}: {f:?} against {:?}", w.force);
    }
}

/// The device's energy sums against `Model::energies` on the same state: a brick wall settling
/// under gravity (kinetic and strain energy of a thousand blocks and four thousand contacts, so
/// both span several of the check's workgroups). f64 sums differ only in the order of addition
/// (each invocation's serial sum of ENERGY_ITEMS terms, then a workgroup tree, against one serial
/// sum): 1e-12 relative. In f32 each term carries ~1e-7 relative round-off and the sums add
/// ~(ENERGY_ITEMS + log2(64))·1e-7, so 1e-5 of the total leaves a margin while a missing or
/// doubled term (≥ 1e-4 of it) fails.
fn energy_sums_match_the_model(adapter: &str, precision: Precision) {
    let Some(common::Target::Gpu(options)) = Target::gpu(adapter, precision) else { return };
    let deck = format!("{}CYCLE 0\n", blockdem::scenes::brick_wall_deck(25, 45, 1.0, 0.5, 1e9, 0.6));
    let mut model = blockdem::scenes::run_deck_on(&deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    let per_workgroup = (shaders::workgroup_size() * shaders::ENERGY_ITEMS) as usize;
    assert!(model.blocks.len() > per_workgroup && model.contacts.len() > 2 * per_workgroup, "blocks and contacts over several workgroups");
    let mut gpu = blockdem::udec::gpu::GpuBackend::new(&options).unwrap();
    use blockdem::udec::backend::Backend;
    gpu.run(&mut model, 150, &mut |_| true).unwrap();
    let (kinetic, strain, work) = gpu.energy_sums().unwrap();
    let e = model.energies();
    assert!(e.kinetic > 0.0 && e.strain > 0.0 && e.external_work > 0.0, "a moving, loaded wall: {e:?}");
    let tol = if precision == Precision::F32 { 1e-5 } else { 1e-12 };
    let scale = e.kinetic + e.strain + e.external_work;
    for (name, gpu, cpu) in [("kinetic", kinetic, e.kinetic), ("strain", strain, e.strain), ("external work", work, e.external_work)] {
        assert!((gpu - cpu).abs() <= tol * scale, "{name} on {adapter} {precision}: device {gpu:e}, model {cpu:e}");
    }
}

#[test]
fn energy_sums_vulkan_f32() {
    energy_sums_match_the_model("vulkan", Precision::F32);
}

#[test]
fn energy_sums_vulkan_f64() {
    energy_sums_match_the_model("vulkan", Precision::F64);
}

#[test]
fn energy_sums_gl_f32() {
    energy_sums_match_the_model("gl", Precision::F32);
}

/// `end_cycle` counts a cycle and, when a kernel raised a flag the CPU must act on, halts the
/// batch and zeroes every grid of `dispatch_args`, so the batch's later cycles launch nothing;
/// once halted it changes nothing (the flags are [halted, cycles_done, update_due, errors, …,
/// inverted_zone]).
fn end_cycle_halts_by_zeroing_the_grids(adapter: &str) {
    let Some(dev) = device(adapter, Precision::F32) else { return };
    let grids: Vec<u32> = vec![3, 1, 1, 7, 1, 1, 65535, 2, 1, 0, 1, 1];
    let words = |w: &[u32]| bytemuck::cast_slice::<u32, u8>(w).to_vec();
    let run = |flags: [u32; 9]| {
        let out = run_kernel(&dev, "end_cycle", "", "end_cycle", 1, &[(7, words(&flags), true), (15, words(&grids), true)]);
        (bytemuck::pod_collect_to_vec::<u8, u32>(&out[0]), bytemuck::pod_collect_to_vec::<u8, u32>(&out[1]))
    };
    let none = u32::MAX;
    // Nothing raised: the cycle is counted, the grids stay.
    let (flags, args) = run([0, 4, 0, 0, none, none, none, 0, none]);
    assert_eq!((flags[0], flags[1], &args[..]), (0, 5, &grids[..]), "a quiet cycle on {adapter}");
    // A contact update due, or an error: halted, and nothing more is launched.
    for (due, errors) in [(1, 0), (0, 4)] {
        let (flags, args) = run([0, 4, due, errors, none, none, none, 0, none]);
        assert_eq!((flags[0], flags[1]), (1, 5), "halt on {adapter} (due {due}, errors {errors})");
        assert!(args.iter().all(|&a| a == 0), "grids after a halt on {adapter}: {args:?}");
    }
    // Already halted: not counted, nothing written.
    let (flags, args) = run([1, 4, 1, 0, none, none, none, 0, none]);
    assert_eq!((flags[0], flags[1], &args[..]), (1, 4, &grids[..]), "a halted cycle on {adapter}");
}

#[test]
fn end_cycle_halts_vulkan() {
    end_cycle_halts_by_zeroing_the_grids("vulkan");
}

#[test]
fn end_cycle_halts_gl() {
    end_cycle_halts_by_zeroing_the_grids("gl");
}
