//! The rigid-block engine against closed-form solutions, on the f64 CPU backend. Each test states
//! its tolerance and why.

use blockdem::cpu::CpuBackend;
use blockdem::model::Model;
use blockdem::scenes::run_deck_on;

fn run(deck: &str) -> Model {
    match run_deck_on(deck, Box::new(CpuBackend::new())) {
        Ok(m) => m,
        Err(e) => panic!("deck failed: {e}"),
    }
}

/// Sum of the normal forces of all contacts between the blocks with ids a and b.
fn interface_force(m: &Model, a: u32, b: u32) -> f64 {
    let (ia, ib) = (m.block_index(a).unwrap() as u32, m.block_index(b).unwrap() as u32);
    m.contacts.iter().filter(|c| (c.block1 == ia && c.block2 == ib) || (c.block1 == ib && c.block2 == ia)).map(|c| c.normal_force).sum()
}

#[test]
fn free_flight_follows_the_parabola() {
    // A lone block thrown at (3, 4) m/s under g = (0, −10) for 200 cycles.
    let m = run("START\nPROP MAT=1 D=1000 KN=1E8 KS=1E8\nBLOCK 0,0 0,1 1,1 1,0\nGRAV 0 -10\nVELOCITY 0 1 0 1 3 4\nCYCLE 200\n");
    let b = &m.blocks[0];
    let t = m.time;
    let dt = m.timestep;
    // Central differences: the given velocity is v(−Δt/2), so after n steps v(t−Δt/2) = v0 + g t
    // exactly, and x(t) = x0 + v0 t + ½ g t² + ½ g t Δt (the O(Δt) offset of the half-step
    // velocity, known in closed form). Both are checked to round-off (1e-9 relative).
    assert!((b.velocity[0] - 3.0).abs() < 1e-12);
    assert!((b.velocity[1] - (4.0 - 10.0 * t)).abs() < 1e-9 * 10.0 * t);
    let x = 0.5 + 3.0 * t;
    let y = 0.5 + 4.0 * t - 5.0 * t * t - 5.0 * t * dt;
    assert!((b.centroid[0] - x).abs() < 1e-9 * x, "x {} vs {}", b.centroid[0], x);
    assert!((b.centroid[1] - y).abs() < 1e-9 * (1.0 + y.abs()), "y {} vs {}", b.centroid[1], y);
}

#[test]
fn timestep_follows_the_udec_rule() {
    // Δt = FRAC · 2√(m_min / k_max): the lighter block is 0.5 × 1 m at 2000 kg/m³ = 1000 kg, and
    // k_max = 4e8 from the stiffer material. Exact to round-off.
    let m = run("START\nPROP MAT=1 D=2000 KN=1E8 KS=2E8\nPROP MAT=2 D=2000 KN=4E8 KS=1E8\nFRAC 0.2\nBLOCK 0,0 0,1 2,1 2,0\nBLOCK MAT=2 0,5 0,6 0.5,6 0.5,5\nCYCLE 0\n");
    let expected = 0.2 * 2.0 * (1000.0f64 / 4e8).sqrt();
    assert!((m.timestep - expected).abs() < 1e-15, "{} vs {}", m.timestep, expected);
}

/// A 2 × 0.5 m block on a fixed 10 m base under gravity tilted by ψ, friction tan φ, for 1 s.
fn sliding_deck(psi_deg: f64, tan_phi: f64, cycles: u64) -> String {
    let psi = psi_deg.to_radians();
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F={tan_phi}\nROUND 0.05\nBLOCK 0,0 0,1 10,1 10,0\nBLOCK 1,1 1,1.5 3,1.5 3,1\n\
         FIX 0 10 0 0.9\nGRAV {} {}\nCYCLE {cycles}\n",
        10.0 * psi.sin(),
        -10.0 * psi.cos()
    )
}

#[test]
fn block_slides_down_a_plane_as_coulomb_says() {
    let (psi, tan_phi) = (30.0f64, 0.3);
    let m = run(&sliding_deck(psi, tan_phi, 3500));
    let t = m.time;
    let psi = psi.to_radians();
    let expected = 0.5 * 10.0 * t * t * (psi.sin() - psi.cos() * tan_phi);
    let slid = m.blocks[1].centroid[0] - 2.0;
    // 2%: the normal force starts from zero and rings (no damping) at the contact frequency, so
    // friction is briefly below μ m g cos ψ at the start; that transient is well under 2% of a
    // metre-scale slide.
    assert!((slid - expected).abs() < 0.02 * expected, "slid {slid} m, expected {expected} m at t = {t}");
    assert!(m.blocks[1].angular_velocity.abs() < 1e-3, "a flat block slides without tipping");
}

#[test]
fn block_sticks_when_the_plane_is_flatter_than_the_friction_angle() {
    // tan 10° = 0.176 < 0.3: the block stays. What moves it is the elastic shear of its contacts
    // (m g sin ψ / 2ks ≈ 2e-6 m) and, because the block is dropped onto unstressed springs with no
    // damping, the ringing of the normal force: each time it swings near zero the friction limit
    // does too and the block creeps (~1e-4 m in 1 s here). Sticking means far below the
    // frictionless slide (0.87 m): under 0.1% of it.
    let m = run(&sliding_deck(10.0, 0.3, 3500));
    let slid = (m.blocks[1].centroid[0] - 2.0).abs();
    let frictionless = 0.5 * 10.0 * m.time * m.time * 10f64.to_radians().sin();
    assert!(slid < 1e-3 * frictionless, "moved {slid} m of a frictionless {frictionless} m");
}

#[test]
fn column_at_rest_carries_the_weight_above() {
    // Four 1 × 1 m blocks stacked on a fixed base, settled with heavy mass damping. Each interface
    // carries the weight of the blocks above it (2000 kg each, g = 10): within 1%, the residual
    // of the damped vibration after 3000 cycles (~e^(−αt) ≈ 0).
    let m = run("START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\nBLOCK 0,0 0,1 4,1 4,0\n\
         BLOCK 1,1 1,2 2,2 2,1\nBLOCK 1,2 1,3 2,3 2,2\nBLOCK 1,3 1,4 2,4 2,3\nBLOCK 1,4 1,5 2,5 2,4\n\
         FIX 0 4 0 0.9\nGRAV 0 -10\nDAMP 0.5 50 MASS\nCYCLE 3000\n");
    let w = 2000.0 * 10.0;
    for (k, (lower, upper)) in [(1u32, 2u32), (2, 3), (3, 4), (4, 5)].iter().enumerate() {
        let above = (4 - k) as f64 * w;
        let f = interface_force(&m, *lower, *upper);
        assert!((f - above).abs() < 0.01 * above, "interface {lower}-{upper}: {f} N, weight above {above} N");
    }
}

#[test]
fn undamped_bounce_keeps_its_energy() {
    // A 1 × 1 m block dropped 1 m onto a fixed base, no damping. Rebound height within 2%
    // (central differences conserve a shadow energy; the contact lasts ~10 steps of the ~450 in
    // the flight, which is where the 2% budget goes).
    let deck = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,2 1,3 2,3 2,2\n\
         FIX 0 4 0 0.9\nGRAV 0 -10\nCYCLE 500\n";
    let first = run(deck);
    // Fall time √(2h/g) = 0.447 s; the rebound peak comes at twice that.
    let dt = first.timestep;
    let peak_cycle = (2.0 * (0.2f64).sqrt() / dt).round() as u64;
    let mut best: f64 = 0.0;
    for extra in [peak_cycle - 40, peak_cycle - 20, peak_cycle, peak_cycle + 20, peak_cycle + 40] {
        let m = run(&deck.replace("CYCLE 500", &format!("CYCLE {extra}")));
        best = best.max(m.blocks[1].centroid[1]);
    }
    // Start at y = 2.5; the peak sampled near the apex (within ±40 steps of 2.9e-4 s, where the
    // height differs from the apex by < ½ g (0.012 s)² ≈ 0.7 mm).
    assert!((best - 2.5).abs() < 0.02 * 1.0, "rebound centroid height {best}, dropped from 2.5");
}
