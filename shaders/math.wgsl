// Dimension-free helpers every engine's kernels share (src/gpu/wgsl.rs puts this file after an
// engine's prelude, which defines `real`, FINITE_MAX and PIO2_1..3: `gpu::wgsl::math_constants`).

// Finite test without isnan/isinf (which compilers may fold away): false for NaN and ±inf.
fn is_finite(x: real) -> bool {
    return abs(x) <= FINITE_MAX;
}

// (cos θ, sin θ) with + − × only (f64 kernels have no sin/cos): θ is reduced by the nearest
// multiple k of π/2 (k found in f32, any nearby integer works; π/2 split Cody–Waite style into
// PIO2_1 + PIO2_2 + PIO2_3 for the precision, see the prelude, so k·π/2 is subtracted almost
// exactly), then Taylor series to r¹⁷ / r¹⁶, whose truncation error on |r| ≤ π/4 is below 1e-19,
// and the quadrant of k. Rust twin: `gpu::kernels::sin_cos`.
fn sin_cos(theta: real) -> vec2<real> {
    let k = i32(round(f32(theta) * 0.636619772367581343));
    let kr = real(k);
    let r = ((theta - kr * PIO2_1) - kr * PIO2_2) - kr * PIO2_3;
    let r2 = r * r;
    let s = r * (1.0 + r2 * (-1.0 / 6.0 + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362880.0
        + r2 * (-1.0 / 39916800.0 + r2 * (1.0 / 6227020800.0 + r2 * (-1.0 / 1307674368000.0
        + r2 * (1.0 / 355687428096000.0)))))))));
    let c = 1.0 + r2 * (-0.5 + r2 * (1.0 / 24.0 + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40320.0
        + r2 * (-1.0 / 3628800.0 + r2 * (1.0 / 479001600.0 + r2 * (-1.0 / 87178291200.0
        + r2 * (1.0 / 20922789888000.0))))))));
    switch (k & 3) {
        case 0: { return vec2<real>(c, s); }
        case 1: { return vec2<real>(-s, c); }
        case 2: { return vec2<real>(-c, -s); }
        default: { return vec2<real>(s, -c); }
    }
}
