//! D3's law of motion (SL-85-1 ¶17): central differences for the centroid, and for the angular
//! momentum with the full inertia tensor, the orientation a unit quaternion. A free 1 × 2 × 3 box
//! keeps its angular momentum and energy; spun about its intermediate axis it flips (the tennis
//! racket), about the others it stays.

use blockdem::d3::geometry::{box_faces, shape_from_faces};
use blockdem::d3::model::Block;
use blockdem::d3::motion::law_of_motion;
use glam::DVec3;

/// A free 1 × 2 × 3 box of density 1 (axes x, y, z), spinning at `omega`.
fn spinning_box(omega: DVec3) -> Block {
    let (shape, props) = shape_from_faces(&box_faces([0.0; 3], [1.0, 2.0, 3.0])).unwrap();
    let mut b = Block::new(1, 1, 1, shape, &props, 1.0);
    b.angular_momentum = b.inertia() * omega;
    b.angular_velocity = omega;
    b
}

/// Steps the block `steps` times of `dt` with no force; calls `each` after each step.
fn tumble(b: &mut Block, steps: usize, dt: f64, mut each: impl FnMut(&Block)) {
    for _ in 0..steps {
        b.force = DVec3::ZERO;
        b.moment = DVec3::ZERO;
        law_of_motion(b, DVec3::ZERO, 0.0, dt);
        each(b);
    }
}

#[test]
fn torque_free_rotation_keeps_angular_momentum_and_energy() {
    let mut b = spinning_box(DVec3::new(0.3, 1.0, 0.2));
    let l0 = b.angular_momentum;
    let e0 = 0.5 * b.angular_velocity.dot(l0);
    let dt = 2e-3;
    let mut worst_e: f64 = 0.0;
    let mut worst_norm: f64 = 0.0;
    tumble(&mut b, 20_000, dt, |b| {
        worst_e = worst_e.max((0.5 * b.angular_velocity.dot(b.angular_momentum) - e0).abs() / e0);
        worst_norm = worst_norm.max((b.orientation.length() - 1.0).abs());
    });
    // L is stepped by ΔL = MΔt = 0: kept to the last bit.
    assert_eq!(b.angular_momentum, l0);
    assert!(worst_e < 1e-5, "energy drifts by {worst_e:e}");
    assert!(worst_norm < 1e-14, "the quaternion stays unit: {worst_norm:e}");
    // The vertices stay where the rigid body puts them: the block keeps its size.
    let d = b.vertices.iter().flat_map(|p| b.vertices.iter().map(move |q| (*p - *q).length())).fold(0.0, f64::max);
    assert!((d - 14f64.sqrt()).abs() < 1e-12, "{d}");
}

/// The largest |cos| between the body axis `axis` and its starting direction over a run, and
/// the least.
fn axis_excursion(omega: DVec3, axis: DVec3) -> (f64, f64) {
    let mut b = spinning_box(omega);
    let start = b.orientation * axis;
    let (mut least, mut most): (f64, f64) = (1.0, -1.0);
    tumble(&mut b, 40_000, 1e-3, |b| {
        let c = (b.orientation * axis).dot(start);
        least = least.min(c);
        most = most.max(c);
    });
    (least, most)
}

#[test]
fn spin_about_the_intermediate_axis_flips_about_the_others_stays() {
    // Moments (per unit mass ×12): about x 13, about y 10, about z 5; y is the intermediate
    // axis. A spin of 2 rad/s with a small wobble: over 40 s the y axis turns right over (its
    // direction reverses) while the x and z axes stay within a few degrees.
    let wobble = 1e-3;
    let (least_y, _) = axis_excursion(DVec3::new(wobble, 2.0, wobble), DVec3::Y);
    assert!(least_y < -0.99, "the intermediate axis flips: cos reaches {least_y}");
    let (least_x, _) = axis_excursion(DVec3::new(2.0, wobble, wobble), DVec3::X);
    assert!(least_x > 0.999, "about the largest moment it stays: cos ≥ {least_x}");
    let (least_z, _) = axis_excursion(DVec3::new(wobble, wobble, 2.0), DVec3::Z);
    assert!(least_z > 0.999, "about the least moment it stays: cos ≥ {least_z}");
}

#[test]
fn free_fall_and_mass_damping() {
    // Central differences are exact for a constant force: x = x0 + ½gt² at the whole steps
    // (the velocity starting at −gΔt/2 at t = −Δt/2 gives the exact parabola).
    let mut b = spinning_box(DVec3::ZERO);
    let g = DVec3::new(0.0, 0.0, -9.81);
    let dt = 1e-3;
    let z0 = b.centroid.z;
    b.velocity = -0.5 * g * dt;
    for _ in 0..1000 {
        b.force = b.mass * g;
        b.moment = DVec3::ZERO;
        law_of_motion(&mut b, g, 0.0, dt);
    }
    let t: f64 = 1.0;
    assert!((b.centroid.z - (z0 - 0.5 * 9.81 * t * t)).abs() < 1e-9, "{}", b.centroid.z - z0);
    // Mass damping: a free block's velocity decays as ((1 − αΔt/2)/(1 + αΔt/2))ⁿ, and so does
    // its angular momentum.
    let mut b = spinning_box(DVec3::new(0.0, 0.0, 1.0));
    b.velocity = DVec3::X;
    let alpha = 2.0;
    let l0 = b.angular_momentum;
    for _ in 0..500 {
        b.force = DVec3::ZERO;
        b.moment = DVec3::ZERO;
        law_of_motion(&mut b, DVec3::ZERO, alpha, dt);
    }
    let factor = ((1.0 - alpha * dt / 2.0) / (1.0 + alpha * dt / 2.0)).powi(500);
    assert!((b.velocity.x - factor).abs() < 1e-12);
    assert!((b.angular_momentum - l0 * factor).length() < 1e-12 * l0.length());
}

#[test]
fn a_fixed_block_does_not_move() {
    let mut b = spinning_box(DVec3::new(1.0, 0.0, 0.0));
    b.fixed = true;
    let c = b.centroid;
    b.force = DVec3::new(1e3, 0.0, 0.0);
    law_of_motion(&mut b, DVec3::new(0.0, 0.0, -10.0), 0.0, 1e-3);
    assert_eq!(b.centroid, c);
    assert_eq!(b.angular_velocity, DVec3::ZERO);
}
