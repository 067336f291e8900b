//! Number formatting in the style of the 1985 listings (print-formats.md: "Numbers were printed in
//! `1.234E+05` form").

/// Width of one numeric column in the PRINT tables: room for `-1.234E+05` (10 characters) and one
/// space of separation. Three-digit exponents (|exp| ≥ 100) take one more character and simply push
/// the rest of the line right by one; they are rare enough in a PRINT table not to cost a column.
pub const NUMBER_WIDTH: usize = 11;

/// Formats `x` as FORTRAN's `1PE10.3` would: one digit before the point, three after, an `E`, the
/// sign of the exponent always written and at least two exponent digits.
///
/// ```
/// use blockdem::output::fmt_e;
/// assert_eq!(fmt_e(123_400.0), "1.234E+05");
/// assert_eq!(fmt_e(-0.0095), "-9.500E-03");
/// assert_eq!(fmt_e(0.0), "0.000E+00");
/// assert_eq!(fmt_e(1e300), "1.000E+300");
/// ```
///
/// Zero of either sign prints as `0.000E+00`. Non-finite values print as `NaN`, `Inf` or `-Inf`
/// so that a diverging run still produces a readable table.
pub fn fmt_e(x: f64) -> String {
    if x.is_nan() {
        return "NaN".to_string();
    }
    if x.is_infinite() {
        return if x > 0.0 { "Inf" } else { "-Inf" }.to_string();
    }
    if x == 0.0 {
        // Also catches −0.0, which the 1985 listings never showed.
        return "0.000E+00".to_string();
    }
    // Rust's `{:.3E}` rounds correctly (including 9.9995 → 1.000E1) but writes the exponent
    // bare ("1.234E5", "9.500E-3"); only the exponent needs rewriting.
    let s = format!("{x:.3E}");
    let (mantissa, exp) = s.split_once('E').expect("{:E} always writes an exponent");
    let exp: i32 = exp.parse().expect("{:E} writes a decimal exponent");
    let sign = if exp < 0 { '-' } else { '+' };
    format!("{mantissa}E{sign}{:02}", exp.unsigned_abs())
}

/// `fmt_e` right-aligned in a column of `NUMBER_WIDTH` characters.
pub(crate) fn col_e(x: f64) -> String {
    format!("{:>width$}", fmt_e(x), width = NUMBER_WIDTH)
}
