//! Scalars as PyYAML writes and reads them: a float's text, and the strings
//! its resolver (YAML 1.1's implicit types) would read as something other
//! than a string, which the emitter therefore quotes.

use shm_interface::python::python_float;

/// A float as PyYAML writes it: Python's `repr`, lower case, with `.0` added
/// to a mantissa without a point, `.inf`, `-.inf` and `.nan`.
pub(super) fn yaml_float(x: f64) -> String {
    if x.is_nan() {
        return ".nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { ".inf" } else { "-.inf" }.into();
    }
    // Finite here: Python's repr of it.
    let mut out = python_float(x);
    if !out.contains('.') {
        if let Some(e) = out.find('e') {
            out.insert_str(e, ".0");
        }
    }
    out
}

/// Whether PyYAML's resolver would read `s`, written plain, as something
/// other than a string (a bool, int, float, null, timestamp, merge or value
/// key, by YAML 1.1's patterns): such strings are quoted.
pub(super) fn resolves_to_non_string(s: &str) -> bool {
    let b = s.as_bytes();
    is_yaml11_bool(s)
        || is_yaml11_int(b)
        || is_yaml11_float(b)
        || matches!(s, "~" | "null" | "Null" | "NULL" | "" | "<<" | "=")
        || is_yaml11_timestamp(b)
}

fn is_yaml11_bool(s: &str) -> bool {
    matches!(
        s,
        "yes"
            | "Yes"
            | "YES"
            | "no"
            | "No"
            | "NO"
            | "true"
            | "True"
            | "TRUE"
            | "false"
            | "False"
            | "FALSE"
            | "on"
            | "On"
            | "ON"
            | "off"
            | "Off"
            | "OFF"
    )
}

/// The number of leading bytes of `b` from `from` on that satisfy `f`.
fn run(b: &[u8], from: usize, f: impl Fn(u8) -> bool) -> usize {
    b.get(from..)
        .map_or(0, |rest| rest.iter().take_while(|c| f(**c)).count())
}

fn skip_sign(b: &[u8]) -> usize {
    usize::from(matches!(b.first(), Some(b'-' | b'+')))
}

fn digit_or_underscore(c: u8) -> bool {
    c.is_ascii_digit() || c == b'_'
}

/// `(:[0-5]?[0-9])+` from `i`: the index after it, if there is one.
fn sexagesimal(b: &[u8], mut i: usize) -> Option<usize> {
    let mut groups = 0;
    while b.get(i) == Some(&b':') {
        let n = run(b, i + 1, |c| c.is_ascii_digit());
        let ok = match n {
            1 => true,
            2 => b[i + 1] <= b'5',
            _ => false,
        };
        if !ok {
            break;
        }
        i += 1 + n;
        groups += 1;
    }
    (groups > 0).then_some(i)
}

fn is_yaml11_int(b: &[u8]) -> bool {
    let s = skip_sign(b);
    let body = &b[s..];
    if let Some(rest) = body.strip_prefix(b"0b") {
        return !rest.is_empty() && rest.iter().all(|c| matches!(c, b'0' | b'1' | b'_'));
    }
    if let Some(rest) = body.strip_prefix(b"0x") {
        return !rest.is_empty() && rest.iter().all(|c| c.is_ascii_hexdigit() || *c == b'_');
    }
    if body == b"0" {
        return true;
    }
    if let Some(rest) = body.strip_prefix(b"0") {
        return !rest.is_empty() && rest.iter().all(|c| matches!(c, b'0'..=b'7' | b'_'));
    }
    match body.first() {
        Some(b'1'..=b'9') => {
            let end = 1 + run(body, 1, digit_or_underscore);
            end == body.len() || sexagesimal(body, end) == Some(body.len())
        }
        _ => false,
    }
}

fn is_yaml11_float(b: &[u8]) -> bool {
    let s = skip_sign(b);
    let body = &b[s..];
    if matches!(body, b".inf" | b".Inf" | b".INF") {
        return true;
    }
    if s == 0 && matches!(body, b".nan" | b".NaN" | b".NAN") {
        return true;
    }
    // `\.[0-9][0-9_]*` exponent?, without a sign.
    if s == 0 && body.first() == Some(&b'.') {
        if !body.get(1).is_some_and(u8::is_ascii_digit) {
            return false;
        }
        let end = 2 + run(body, 2, digit_or_underscore);
        return exponent_to_end(body, end);
    }
    if !body.first().is_some_and(u8::is_ascii_digit) {
        return false;
    }
    let int_end = 1 + run(body, 1, digit_or_underscore);
    // `[0-9][0-9_]*\.[0-9_]*` exponent?
    if body.get(int_end) == Some(&b'.') {
        let end = int_end + 1 + run(body, int_end + 1, digit_or_underscore);
        if exponent_to_end(body, end) {
            return true;
        }
    }
    // `[0-9][0-9_]*(:[0-5]?[0-9])+\.[0-9_]*`
    if let Some(end) = sexagesimal(body, int_end) {
        if body.get(end) == Some(&b'.') {
            let rest = end + 1 + run(body, end + 1, digit_or_underscore);
            return rest == body.len();
        }
    }
    false
}

/// Whether `b[i..]` is empty or `[eE][-+][0-9]+`.
fn exponent_to_end(b: &[u8], i: usize) -> bool {
    if i == b.len() {
        return true;
    }
    matches!(b.get(i), Some(b'e' | b'E')) && matches!(b.get(i + 1), Some(b'-' | b'+')) && {
        let n = run(b, i + 2, |c| c.is_ascii_digit());
        n > 0 && i + 2 + n == b.len()
    }
}

fn is_yaml11_timestamp(b: &[u8]) -> bool {
    let digits = |from: usize, n: usize| {
        b.get(from..from + n)
            .is_some_and(|d| d.iter().all(u8::is_ascii_digit))
    };
    if !(digits(0, 4) && b.get(4) == Some(&b'-')) {
        return false;
    }
    // `YYYY-MM-DD` alone.
    if b.len() == 10 && digits(5, 2) && b.get(7) == Some(&b'-') && digits(8, 2) {
        return true;
    }
    // `YYYY-M?M-D?D(T|t|[ \t]+)H?H:MM:SS(.f*)?([ \t]*(Z|[-+]H?H(:MM)?))?`
    let mut i = 5;
    let one_or_two = |i: usize| run(b, i, |c| c.is_ascii_digit()).min(2);
    let n = one_or_two(i);
    if n == 0 || b.get(i + n) != Some(&b'-') {
        return false;
    }
    i += n + 1;
    let n = one_or_two(i);
    if n == 0 {
        return false;
    }
    i += n;
    match b.get(i) {
        Some(b'T' | b't') => i += 1,
        Some(b' ' | b'\t') => i += run(b, i, |c| c == b' ' || c == b'\t'),
        _ => return false,
    }
    let n = one_or_two(i);
    if n == 0 {
        return false;
    }
    i += n;
    for _ in 0..2 {
        if b.get(i) != Some(&b':') || !digits(i + 1, 2) {
            return false;
        }
        i += 3;
    }
    if b.get(i) == Some(&b'.') {
        i += 1 + run(b, i + 1, |c| c.is_ascii_digit());
    }
    if i == b.len() {
        return true;
    }
    i += run(b, i, |c| c == b' ' || c == b'\t');
    match b.get(i) {
        Some(b'Z') => i + 1 == b.len(),
        Some(b'-' | b'+') => {
            let n = one_or_two(i + 1);
            if n == 0 {
                return false;
            }
            let j = i + 1 + n;
            j == b.len() || (b.get(j) == Some(&b':') && digits(j + 1, 2) && j + 3 == b.len())
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    // The ties below are written as the exact binary values they are.
    #[allow(clippy::excessive_precision)]
    fn floats_are_written_as_python_and_pyyaml_write_them() {
        for (x, text) in [
            (0.0, "0.0"),
            (-0.0, "-0.0"),
            (1.5, "1.5"),
            (100.0, "100.0"),
            (0.0001, "0.0001"),
            (0.00001, "1.0e-05"),
            (1e15, "1000000000000000.0"),
            (1e16, "1.0e+16"),
            (1.7976931348623157e308, "1.7976931348623157e+308"),
            (5e-324, "5.0e-324"),
            (f64::from(0.1f32), "0.10000000149011612"),
            (-123456.789, "-123456.789"),
            // Two shortest strings, equally near: Python takes the even digit.
            (-654701260200.65625, "-654701260200.6562"),
            (163058953422.390625, "163058953422.39062"),
            (f64::INFINITY, ".inf"),
            (f64::NEG_INFINITY, "-.inf"),
            (f64::NAN, ".nan"),
        ] {
            assert_eq!(yaml_float(x), text, "{x:e}");
        }
    }

    #[test]
    fn strings_that_read_as_other_types_are_recognized() {
        for s in [
            "yes",
            "Off",
            "1",
            "-1_000",
            "0b101",
            "0x1F",
            "017",
            "1:30",
            "1.",
            ".5",
            "1.5e-03",
            "-.inf",
            ".NaN",
            "1:20.5",
            "~",
            "null",
            "",
            "<<",
            "=",
            "2001-12-14",
            "2001-12-14t21:59:43.10-05:00",
            "2001-12-14 21:59:43.10 -5",
            "2002-12-14T1:02:03Z",
        ] {
            assert!(resolves_to_non_string(s), "{s:?} reads as a non-string");
        }
        for s in [
            "y", "n", "09", "0o7", "1e5", ".", "+.nan", "abc", "1.5e3", "2001-1-1", "12:61", "-",
            "0b", "0x", "nil",
        ] {
            assert!(!resolves_to_non_string(s), "{s:?} reads as a string");
        }
    }
}
