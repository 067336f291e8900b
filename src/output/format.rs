//! Number formatting in the style of the 1985 listings (print-formats.md: "Numbers were printed in
//! `1.234E+05` form").

use std::fmt::Write as _;

/// Width of one numeric column in the PRINT tables: room for `-1.234E+05` (10 characters) and one
/// space of separation. Three-digit exponents (|exp| ≥ 100) take one more character and push the
/// rest of the line right (a column always keeps one space before its number); they are rare
/// enough in a PRINT table not to cost a column.
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
    let mut s = String::with_capacity(NUMBER_WIDTH);
    push_e(&mut s, x);
    s
}

/// A number as a person typed it, for messages: Rust's shortest round-trip form (`0.1`, `1.5`,
/// `25`) between 1e-4 and 1e6, exponent form (`1e300`, `2.5e-7`) outside, where the plain form
/// would run to hundreds of digits.
///
/// ```
/// use blockdem::output::format::fmt_short;
/// assert_eq!(fmt_short(0.1), "0.1");
/// assert_eq!(fmt_short(1e300), "1e300");
/// assert_eq!(fmt_short(-2.5e-7), "-2.5e-7");
/// ```
pub fn fmt_short(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Appends [`fmt_e`]`(x)` to `out` (a table of 10⁶ rows formats 10⁷ numbers: no string each).
pub(crate) fn push_e(out: &mut String, x: f64) {
    if x.is_nan() {
        return out.push_str("NaN");
    }
    if x.is_infinite() {
        return out.push_str(if x > 0.0 { "Inf" } else { "-Inf" });
    }
    if x == 0.0 {
        // Also catches −0.0, which the 1985 listings never showed.
        return out.push_str("0.000E+00");
    }
    // Rust's `{:.3E}` rounds correctly (including 9.9995 → 1.000E1) but writes the exponent
    // bare ("1.234E5", "9.500E-3"); only the exponent needs rewriting.
    let start = out.len();
    let _ = write!(out, "{x:.3E}");
    let e = start + out[start..].find('E').expect("{:E} always writes an exponent");
    let exp: i32 = out[e + 1..].parse().expect("{:E} writes a decimal exponent");
    out.truncate(e + 1);
    out.push(if exp < 0 { '-' } else { '+' });
    let _ = write!(out, "{:02}", exp.unsigned_abs());
}

/// Appends [`fmt_e`]`(x)` right-aligned in a column of `NUMBER_WIDTH` characters to `out`.
pub(crate) fn push_col_e(out: &mut String, x: f64) {
    let start = out.len();
    push_e(out, x);
    let written = out.len() - start;
    // At least one space of separation, even for `-1.000E+100` (11 characters), so columns
    // never run together.
    let pad = NUMBER_WIDTH.saturating_sub(written).max(1);
    out.insert_str(start, &"           "[..pad]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Columns stay NUMBER_WIDTH wide and always keep a space before their number, so a row with
    /// three-digit exponents still reads as separate numbers.
    #[test]
    fn columns_never_run_together() {
        let mut row = String::new();
        for x in [1.0, -2.5e-3, -1e100, -1e-100, 1e300] {
            push_col_e(&mut row, x);
        }
        assert_eq!(row, "  1.000E+00 -2.500E-03 -1.000E+100 -1.000E-100 1.000E+300");
        let parsed: Vec<f64> = row.split_whitespace().map(|t| t.parse().unwrap()).collect();
        assert_eq!(parsed, [1.0, -2.5e-3, -1e100, -1e-100, 1e300]);
    }
}
