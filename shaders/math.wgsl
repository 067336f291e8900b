// Dimension-free helpers every engine's kernels share (src/gpu/wgsl.rs puts this file after an
// engine's prelude, which defines `real`, FINITE_MAX and PIO2_1..3: `gpu::wgsl::math_constants`).

// Finite test without isnan/isinf (which compilers may fold away): false for NaN and ±inf.
// (`exponent_finite`, from the prelude: in f32 the exponent's bits, which a compiler that takes
// NaN for impossible cannot fold; `gpu::wgsl::math_constants`.)
fn is_finite(x: real) -> bool {
    return exponent_finite(x) && abs(x) <= FINITE_MAX;
}

// Exact sum of two reals as (sum, rounding error): Knuth's TwoSum, six additions. Shader
// compilers may rewrite floating point as if it were real arithmetic (no WGSL qualifier forbids
// it): Mesa folds (a + b) − a to b, and the error term to 0, so in f32 every position step lost
// the bits below the coordinate's ulp (at 10 m, 1e-6 m a step) and a wave in a chain of stiff
// contacts gained 40% energy in 120 cycles. Multiplying by `one` (= 1, exact, read from the
// params at run time) hides the identities from the compiler. Twin test: tests/suite/gpu_kernels.rs.
fn two_sum(a: real, b: real, one: real) -> vec2<real> {
    let s = (a + b) * one;
    let bb = (s - a) * one;
    let err = (a - (s - bb)) + (b - bb);
    return vec2<real>(s, err);
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
