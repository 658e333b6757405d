//! Values as Python writes them, where ROS 2's Python tools are the
//! reference: rosidl stores `str()` of an interface file's default values in a
//! type description (`1.0`, `True`, `(0, 127, -128)`, `('', 'max value')`, a
//! string as its plain text: [`Value::description_default`](crate::ast::Value::description_default)), and `ros2 topic echo`, `ros2 param get` print
//! `repr()`.

use std::fmt::Write as _;

/// A float as Python's `repr` (and `str`, and so ROS 2's Python tools) writes
/// it: the shortest digits that read back to it, in positional notation when
/// the decimal exponent is from -4 to 15, else in scientific notation with a
/// signed exponent of at least two digits; `inf`, `-inf`, `nan`.
///
/// ```
/// use shm_interface::python::python_float;
///
/// assert_eq!(python_float(1.0), "1.0");
/// assert_eq!(python_float(1e-5), "1e-05");
/// assert_eq!(python_float(f64::from(0.1f32)), "0.10000000149011612");
/// ```
pub fn python_float(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf" } else { "-inf" }.into();
    }
    python_repr(x)
}

/// [`python_float`] of a finite float.
fn python_repr(x: f64) -> String {
    // Rust's `{:e}` finds how many digits read back to `x`; of the strings
    // of that many digits, Python takes the one nearest to `x`, a tie to the
    // even digit, which is Rust's exact formatting at that precision.
    let shortest = format!("{:e}", x.abs());
    let count = shortest
        .split('e')
        .next()
        .map_or(1, |m| m.chars().filter(char::is_ascii_digit).count());
    let sci = format!("{:.*e}", count.saturating_sub(1), x.abs());
    let (mantissa, exponent) = sci.split_once('e').unwrap_or((sci.as_str(), "0"));
    let exponent: i32 = exponent.parse().unwrap_or(0);
    let digits: String = mantissa.chars().filter(|c| *c != '.').collect();
    let sign = if x.is_sign_negative() { "-" } else { "" };
    // The position of the decimal point after the first digit.
    let point = exponent + 1;
    if !(-3..=16).contains(&point) {
        let (first, rest) = digits.split_at(1);
        let fraction = if rest.is_empty() {
            String::new()
        } else {
            format!(".{rest}")
        };
        let exp_sign = if exponent < 0 { '-' } else { '+' };
        return format!("{sign}{first}{fraction}e{exp_sign}{:02}", exponent.abs());
    }
    let len = digits.len() as i32;
    if point <= 0 {
        format!("{sign}0.{}{digits}", "0".repeat((-point) as usize))
    } else if point >= len {
        format!("{sign}{digits}{}.0", "0".repeat((point - len) as usize))
    } else {
        let (int, frac) = digits.split_at(point as usize);
        format!("{sign}{int}.{frac}")
    }
}

/// Python's `repr()` of a `str`: single quotes unless the text holds a single
/// quote and no double quote; backslashes, the quote and control characters
/// escaped. (What ROS 2's Python tools print for a string in a list.)
///
/// ```
/// assert_eq!(shm_interface::python::string_repr("it's"), "\"it's\"");
/// assert_eq!(shm_interface::python::string_repr("a\tb"), "'a\\tb'");
/// ```
pub fn string_repr(text: &str) -> String {
    let quote = if text.contains('\'') && !text.contains('"') {
        '"'
    } else {
        '\''
    };
    let mut out = String::with_capacity(text.len() + 2);
    out.push(quote);
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if c == quote => {
                out.push('\\');
                out.push(c);
            }
            c if (c as u32) < 0x20 || (0x7f..0xa0).contains(&(c as u32)) => {
                let _ = write!(out, "\\x{:02x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push(quote);
    out
}

/// The items of a list's or tuple's inside (`1, 'a,b', "it's"`), split at
/// the commas outside single- or double-quoted strings (which may escape
/// their quote with a backslash) and trimmed: how a `.msg` file writes an
/// array's default and how rosidl's `str()` of a tuple writes one back. An
/// inside of only blanks has no items; otherwise a trailing comma leaves an
/// empty last item, which the caller judges. `None` if a string is not
/// closed.
///
/// ```
/// use shm_interface::python::split_list;
///
/// assert_eq!(split_list("1, 'a,b', \"it's\""), Some(vec!["1", "'a,b'", "\"it's\""]));
/// assert_eq!(split_list("3,"), Some(vec!["3", ""]));
/// assert_eq!(split_list(" "), Some(vec![]));
/// assert_eq!(split_list("'open"), None);
/// ```
pub fn split_list(inner: &str) -> Option<Vec<&str>> {
    let mut items = Vec::new();
    let mut start = 0;
    let mut chars = Unquoted::new(inner);
    for (i, c) in chars.by_ref() {
        if c == ',' {
            items.push(inner[start..i].trim());
            start = i + 1;
        }
    }
    if chars.in_string() {
        return None;
    }
    let last = inner[start..].trim();
    if !last.is_empty() || !items.is_empty() {
        items.push(last);
    }
    Some(items)
}

/// The characters of a text outside its single- or double-quoted strings
/// (which may escape their quote with a backslash), with their byte
/// offsets; the quotes themselves are not among them.
pub(crate) struct Unquoted<'a> {
    chars: std::str::CharIndices<'a>,
    quote: Option<char>,
    escaped: bool,
}

impl<'a> Unquoted<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        Self {
            chars: text.char_indices(),
            quote: None,
            escaped: false,
        }
    }

    /// Whether the text read so far ends inside a string.
    pub(crate) fn in_string(&self) -> bool {
        self.quote.is_some()
    }
}

impl Iterator for Unquoted<'_> {
    type Item = (usize, char);

    fn next(&mut self) -> Option<(usize, char)> {
        loop {
            let (i, c) = self.chars.next()?;
            match self.quote {
                Some(q) => {
                    if self.escaped {
                        self.escaped = false;
                    } else if c == '\\' {
                        self.escaped = true;
                    } else if c == q {
                        self.quote = None;
                    }
                }
                None if c == '"' || c == '\'' => self.quote = Some(c),
                None => return Some((i, c)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_print_as_python_repr_prints_them() {
        for (v, text) in [
            (1.0, "1.0"),
            (0.1, "0.1"),
            (-2.5, "-2.5"),
            (1e-5, "1e-05"),
            (0.0001, "0.0001"),
            (1e16, "1e+16"),
            (123456789012345.0, "123456789012345.0"),
            (1.5e300, "1.5e+300"),
            (-0.0, "-0.0"),
            (f64::from(0.1f32), "0.10000000149011612"),
            (f64::NAN, "nan"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(python_float(v), text);
        }
    }

    #[test]
    fn strings_print_as_python_repr_prints_them() {
        for (text, repr) in [
            ("", "''"),
            ("it's", "\"it's\""),
            ("a\"b'c", "'a\"b\\'c'"),
            ("a\\b\n", "'a\\\\b\\n'"),
            ("\u{7f}é", "'\\x7fé'"),
        ] {
            assert_eq!(string_repr(text), repr, "{text:?}");
        }
    }
}
