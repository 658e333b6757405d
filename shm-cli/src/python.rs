//! Values as Python prints them, for the verbs whose output is Python's
//! `repr` (`ros2 param get`, `ros2 service call`).

use std::borrow::Cow;

use shm_cdr::describe::Container;
use shm_cdr::dynamic::{python_float, DynamicType, Element, Field, FieldDef, MessageRef, Value};
use shm_interface::python::string_repr;

/// Python's `repr` of a one-byte `bytes`.
pub(crate) fn bytes_repr(b: u8) -> String {
    match b {
        b'\\' => "b'\\\\'".into(),
        b'\'' => "b\"'\"".into(),
        b'\t' => "b'\\t'".into(),
        b'\n' => "b'\\n'".into(),
        b'\r' => "b'\\r'".into(),
        0x20..=0x7e => format!("b'{}'", char::from(b)),
        _ => format!("b'\\x{b:02x}'"),
    }
}

/// rclpy's `repr` of a message (rosidl_generator_py's `__repr__`):
/// `pkg.msg.Name(field=value, …)`.
pub(crate) fn message_repr(message: MessageRef<'_, '_>, ty: &DynamicType) -> String {
    let name = message.type_name().replace('/', ".");
    let Some(def) = ty.structs().iter().find(|s| s.name == message.type_name()) else {
        return format!("{name}()");
    };
    let fields: Vec<String> = def
        .fields
        .iter()
        .filter(|f| f.name != shm_interface::PLACEHOLDER_MEMBER)
        .filter_map(|f| {
            let text = match message.get(&f.name)? {
                Field::Value(value) => value_repr(f, value, ty),
                Field::Message(nested) => message_repr(nested, ty),
            };
            Some(format!("{}={text}", f.name))
        })
        .collect();
    format!("{name}({})", fields.join(", "))
}

fn value_repr(field: &FieldDef, value: &Value<'_>, ty: &DynamicType) -> String {
    // A fixed array of numbers is a numpy array in rclpy, printed as numpy
    // prints it. A sequence of them is an `array.array`, which rclpy's
    // `__repr__` prints as the list it holds.
    if let (Container::Array(_), Some(numbers)) = (field.container, numbers(field, value)) {
        return numpy_repr(&numbers);
    }
    let list = |items: Vec<String>| format!("[{}]", items.join(", "));
    match value {
        Value::Bool(b) => bool_repr(*b).to_owned(),
        Value::U8(b) if field.element == Element::Byte => bytes_repr(*b),
        Value::U8(v) => v.to_string(),
        Value::I8(v) => v.to_string(),
        Value::I16(v) => v.to_string(),
        Value::U16(v) => v.to_string(),
        Value::I32(v) => v.to_string(),
        Value::U32(v) => v.to_string(),
        Value::I64(v) => v.to_string(),
        Value::U64(v) => v.to_string(),
        Value::F32(v) => python_float(f64::from(*v)),
        Value::F64(v) => python_float(*v),
        Value::String(s) => string_repr(s),
        Value::WString(s) => string_repr(s),
        Value::Message(m) => message_repr(m.as_message_ref(), ty),
        Value::Bools(v) => list(v.iter().map(|b| bool_repr(*b).to_owned()).collect()),
        Value::U8s(v) if field.element == Element::Byte => {
            list(v.iter().map(|b| bytes_repr(*b)).collect())
        }
        Value::U8s(v) => list(v.iter().map(u8::to_string).collect()),
        Value::I8s(v) => list(v.iter().map(i8::to_string).collect()),
        Value::I16s(v) => list(v.iter().map(|x| x.to_string()).collect()),
        Value::U16s(v) => list(v.iter().map(|x| x.to_string()).collect()),
        Value::I32s(v) => list(v.iter().map(|x| x.to_string()).collect()),
        Value::U32s(v) => list(v.iter().map(|x| x.to_string()).collect()),
        Value::I64s(v) => list(v.iter().map(|x| x.to_string()).collect()),
        Value::U64s(v) => list(v.iter().map(|x| x.to_string()).collect()),
        Value::F32s(v) => list(v.iter().map(|x| python_float(f64::from(x))).collect()),
        Value::F64s(v) => list(v.iter().map(python_float).collect()),
        Value::Strings(v) => list(v.iter().map(|s| string_repr(s)).collect()),
        Value::WStrings(v) => list(v.iter().map(|s| string_repr(s)).collect()),
        Value::Messages(v) => list(v.iter().map(|m| message_repr(m, ty)).collect()),
    }
}

/// Python's `str` of a field's value as rclpy holds it, which `print`
/// shows (`ros2 topic echo --field` of a field that is not a message).
pub(crate) fn value_str(field: &FieldDef, value: &Value<'_>, ty: &DynamicType) -> String {
    match (value, field.container) {
        (Value::String(s), _) => s.to_string(),
        (Value::WString(s), _) => s.clone(),
        (_, Container::Array(_)) => match numbers(field, value) {
            Some(numbers) => numpy_str(&numbers),
            None => value_repr(field, value, ty),
        },
        (_, Container::Sequence | Container::BoundedSequence(_)) => {
            match (numbers(field, value), typecode(field.element)) {
                (Some(_), Some(code)) => {
                    // An `array.array`: `array('d', [1.0, 2.0])`, or
                    // `array('d')` when empty.
                    let list = value_repr(field, value, ty);
                    if list == "[]" {
                        format!("array('{code}')")
                    } else {
                        format!("array('{code}', {list})")
                    }
                }
                _ => value_repr(field, value, ty),
            }
        }
        // For the rest (numbers, bools, bytes, lists, messages) `str` is `repr`.
        _ => value_repr(field, value, ty),
    }
}

/// The `array.array` type code rclpy keeps a sequence of these numbers in.
fn typecode(element: Element) -> Option<char> {
    Some(match element {
        Element::I8 => 'b',
        Element::U8 => 'B',
        Element::I16 => 'h',
        Element::U16 => 'H',
        Element::I32 => 'i',
        Element::U32 => 'I',
        Element::I64 => 'q',
        Element::U64 => 'Q',
        Element::F32 => 'f',
        Element::F64 => 'd',
        _ => return None,
    })
}

/// The numbers of a value rclpy holds in a numpy array when the field is a
/// fixed array: every number type but `byte` (a list of `bytes`).
fn numbers<'a>(field: &FieldDef, value: &'a Value<'_>) -> Option<Numbers<'a>> {
    Some(match value {
        Value::U8s(_) if field.element == Element::Byte => return None,
        Value::U8s(v) => Numbers::U8(Cow::Borrowed(v)),
        Value::I8s(v) => Numbers::I8(Cow::Borrowed(v)),
        Value::I16s(v) => Numbers::I16(v.to_cow()),
        Value::U16s(v) => Numbers::U16(v.to_cow()),
        Value::I32s(v) => Numbers::I32(v.to_cow()),
        Value::U32s(v) => Numbers::U32(v.to_cow()),
        Value::I64s(v) => Numbers::I64(v.to_cow()),
        Value::U64s(v) => Numbers::U64(v.to_cow()),
        Value::F32s(v) => Numbers::F32(v.to_cow()),
        Value::F64s(v) => Numbers::F64(v.to_cow()),
        _ => return None,
    })
}

fn bool_repr(b: bool) -> &'static str {
    if b {
        "True"
    } else {
        "False"
    }
}

/// The numbers of a fixed-size array, which rclpy holds as a numpy array.
enum Numbers<'a> {
    U8(Cow<'a, [u8]>),
    I8(Cow<'a, [i8]>),
    I16(Cow<'a, [i16]>),
    U16(Cow<'a, [u16]>),
    I32(Cow<'a, [i32]>),
    U32(Cow<'a, [u32]>),
    I64(Cow<'a, [i64]>),
    U64(Cow<'a, [u64]>),
    F32(Cow<'a, [f32]>),
    F64(Cow<'a, [f64]>),
}

/// Arrays longer than this print their first and last [`EDGE_ITEMS`] only
/// (numpy's `threshold`).
const THRESHOLD: usize = 1000;
const EDGE_ITEMS: usize = 3;
/// numpy's `linewidth`.
const LINE_WIDTH: usize = 75;

impl Numbers<'_> {
    fn len(&self) -> usize {
        match self {
            Self::U8(v) => v.len(),
            Self::I8(v) => v.len(),
            Self::I16(v) => v.len(),
            Self::U16(v) => v.len(),
            Self::I32(v) => v.len(),
            Self::U32(v) => v.len(),
            Self::I64(v) => v.len(),
            Self::U64(v) => v.len(),
            Self::F32(v) => v.len(),
            Self::F64(v) => v.len(),
        }
    }

    /// The dtype numpy names after the values, unless the values imply it.
    fn dtype(&self) -> Option<&'static str> {
        match self {
            Self::U8(_) => Some("uint8"),
            Self::I8(_) => Some("int8"),
            Self::I16(_) => Some("int16"),
            Self::U16(_) => Some("uint16"),
            Self::I32(_) => Some("int32"),
            Self::U32(_) => Some("uint32"),
            Self::U64(_) => Some("uint64"),
            Self::F32(_) => Some("float32"),
            Self::I64(_) | Self::F64(_) => None,
        }
    }

    /// Each value printed, as wide as the widest: of the first and last
    /// [`EDGE_ITEMS`] only when the array is summarized.
    fn words(&self, summarized: bool) -> Vec<String> {
        fn shown<T: Copy>(v: &[T], summarized: bool) -> Vec<T> {
            if summarized {
                let tail = v.len().saturating_sub(EDGE_ITEMS);
                v.iter()
                    .take(EDGE_ITEMS)
                    .chain(v.iter().skip(tail))
                    .copied()
                    .collect()
            } else {
                v.to_vec()
            }
        }
        fn integers<T: Copy + Ord + ToString>(v: &[T], summarized: bool) -> Vec<String> {
            let v = shown(v, summarized);
            let words: Vec<String> = v.iter().map(T::to_string).collect();
            // numpy's width is that of the largest and of the smallest value.
            let width = [v.iter().max(), v.iter().min()]
                .into_iter()
                .flatten()
                .map(|x| x.to_string().len())
                .max()
                .unwrap_or(0);
            words.into_iter().map(|w| format!("{w:>width$}")).collect()
        }
        match self {
            Self::U8(v) => integers(v, summarized),
            Self::I8(v) => integers(v, summarized),
            Self::I16(v) => integers(v, summarized),
            Self::U16(v) => integers(v, summarized),
            Self::I32(v) => integers(v, summarized),
            Self::U32(v) => integers(v, summarized),
            Self::I64(v) => integers(v, summarized),
            Self::U64(v) => integers(v, summarized),
            Self::F32(v) => floats(&shown(v, summarized)),
            Self::F64(v) => floats(&shown(v, summarized)),
        }
    }
}

/// numpy's `repr` of a one-dimensional array (`array([…], dtype=…)`), its
/// lines wrapped at 75 columns as numpy wraps them.
fn numpy_repr(numbers: &Numbers<'_>) -> String {
    const PREFIX: &str = "array(";
    let len = numbers.len();
    // One column less for the closing parenthesis.
    let list = numpy_list(numbers, ", ", PREFIX.len(), LINE_WIDTH - 1);
    let mut extras = Vec::new();
    if len > THRESHOLD {
        extras.push(format!("shape=({len},)"));
    }
    if let Some(dtype) = numbers.dtype() {
        extras.push(format!("dtype={dtype}"));
    }
    if extras.is_empty() {
        return format!("{PREFIX}{list})");
    }
    let head = format!("{PREFIX}{list},");
    let extra = format!("{})", extras.join(", "));
    let last_line = head.len() - head.rfind('\n').map_or(0, |at| at + 1);
    let spacer = if last_line + extra.len() + 1 > LINE_WIDTH {
        format!("\n{}", " ".repeat(PREFIX.len()))
    } else {
        " ".to_owned()
    };
    format!("{head}{spacer}{extra}")
}

/// numpy's `str` of a one-dimensional array (`[1. 2. 3.]`), as `print`
/// shows it.
fn numpy_str(numbers: &Numbers<'_>) -> String {
    numpy_list(numbers, " ", 0, LINE_WIDTH)
}

/// numpy's `[…]` of an array after `prefix_len` columns of prefix: words
/// between `separator`s, lines wrapped before `width` columns and indented
/// under the first word.
fn numpy_list(numbers: &Numbers<'_>, separator: &str, prefix_len: usize, width: usize) -> String {
    let summarized = numbers.len() > THRESHOLD;
    let words = numbers.words(summarized);
    let Some(last) = words.len().checked_sub(1) else {
        return "[]".to_owned();
    };
    // One column for the separator or bracket after each word.
    let width = width - separator.trim_end().len().max(1);
    let indent = " ".repeat(prefix_len + 1);
    let (mut text, mut line) = (String::new(), indent.clone());
    let extend = |text: &mut String, line: &mut String, word: &str| {
        if line.len() + word.len() > width && line.len() > indent.len() {
            text.push_str(line.trim_end());
            text.push('\n');
            line.clone_from(&indent);
        }
        line.push_str(word);
    };
    for (i, word) in words.iter().enumerate() {
        extend(&mut text, &mut line, word);
        if i < last {
            line.push_str(separator);
        }
        if summarized && i + 1 == EDGE_ITEMS {
            extend(&mut text, &mut line, "...");
            line.push_str(separator);
        }
    }
    text.push_str(&line);
    format!("[{}]", &text[indent.len()..])
}

/// A float type as numpy prints it.
trait NumpyFloat: Copy + PartialOrd + std::fmt::LowerExp + std::fmt::Display {
    /// `10 ** min(8, finfo.precision)`: from here up, scientific notation.
    const EXP_CUTOFF: Self;
    const SMALL: Self;
    const RATIO: Self;
    const ZERO: Self;
    fn finite(self) -> bool;
    fn abs(self) -> Self;
    fn div(self, other: Self) -> Self;
    fn negative(self) -> bool;
    fn nan(self) -> bool;
}

macro_rules! numpy_float {
    ($t:ty, $cutoff:expr) => {
        impl NumpyFloat for $t {
            const EXP_CUTOFF: Self = $cutoff;
            const SMALL: Self = 0.0001;
            const RATIO: Self = 1000.0;
            const ZERO: Self = 0.0;
            fn finite(self) -> bool {
                self.is_finite()
            }
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            fn div(self, other: Self) -> Self {
                self / other
            }
            fn negative(self) -> bool {
                self.is_sign_negative()
            }
            fn nan(self) -> bool {
                self.is_nan()
            }
        }
    };
}
numpy_float!(f32, 1e6);
numpy_float!(f64, 1e8);

/// The fewest significant digits that read back to `x` (the nearest such,
/// as Dragon4 gives them: Rust's exact formatting at that many digits), and
/// the power of ten of the first.
fn shortest<T: NumpyFloat>(x: T) -> (String, i32) {
    let count = split_exp(&format!("{x:e}")).0.len();
    split_exp(&format!("{:.*e}", count.saturating_sub(1), x))
}

/// The digits and exponent of Rust's `{:e}` text of a non-negative number.
fn split_exp(text: &str) -> (String, i32) {
    let (mantissa, exponent) = text.split_once('e').unwrap_or((text, "0"));
    let digits = mantissa.chars().filter(char::is_ascii_digit).collect();
    (digits, exponent.parse().unwrap_or(0))
}

/// `|x|` positionally, as numpy's Dragon4 with `unique` and at most
/// `max_fraction` decimals: (integer part, fraction without trailing zeros).
fn positional<T: NumpyFloat>(x: T, max_fraction: usize) -> (String, String) {
    let (digits, exponent) = shortest(x);
    if digits.len() as i64 - 1 - i64::from(exponent) > max_fraction as i64 {
        // Too many decimals: the exact value rounded, half to even.
        let fixed = format!("{:.*}", max_fraction, x);
        let (int, frac) = fixed.split_once('.').unwrap_or((fixed.as_str(), ""));
        return (int.to_owned(), frac.trim_end_matches('0').to_owned());
    }
    let point = exponent + 1;
    if point <= 0 {
        let zeros = "0".repeat(point.unsigned_abs() as usize);
        return ("0".to_owned(), format!("{zeros}{digits}"));
    }
    let point = point as usize;
    if digits.len() <= point {
        return (format!("{digits:0<point$}"), String::new());
    }
    let (int, frac) = digits.split_at(point);
    (int.to_owned(), frac.trim_end_matches('0').to_owned())
}

/// `|x|` in scientific notation, as numpy's Dragon4 with `unique` and at
/// most `max_fraction` decimals after the first digit: (digits without
/// trailing zeros, exponent).
fn exponential<T: NumpyFloat>(x: T, max_fraction: usize) -> (String, i32) {
    let (mut digits, mut exponent) = shortest(x);
    if digits.len() > 1 + max_fraction {
        (digits, exponent) = split_exp(&format!("{:.*e}", max_fraction, x));
    }
    while digits.len() > 1 && digits.ends_with('0') {
        digits.pop();
    }
    (digits, exponent)
}

/// numpy's `FloatingFormat` with its defaults (precision 8, `maxprec`):
/// every value positional, or all scientific, aligned on the point.
fn floats<T: NumpyFloat>(values: &[T]) -> Vec<String> {
    const PRECISION: usize = 8;
    let finite: Vec<T> = values.iter().copied().filter(|x| x.finite()).collect();
    let nonzero = finite.iter().map(|x| x.abs()).filter(|x| *x != T::ZERO);
    let (min, max) = nonzero.fold((None::<T>, None::<T>), |(lo, hi), x| {
        (
            Some(lo.map_or(x, |lo| if x < lo { x } else { lo })),
            Some(hi.map_or(x, |hi| if x > hi { x } else { hi })),
        )
    });
    let scientific = match (min, max) {
        (Some(min), Some(max)) => max >= T::EXP_CUTOFF || min < T::SMALL || max.div(min) > T::RATIO,
        _ => false,
    };
    let sign = |x: T| if x.negative() { "-" } else { "" };
    // Each finite value as (integer part with its sign, fraction, exponent).
    let parts: Vec<(String, String, String)> = finite
        .iter()
        .map(|&x| {
            let magnitude = x.abs();
            if scientific {
                let (digits, exponent) = exponential(magnitude, PRECISION);
                let (first, rest) = digits.split_at(1.min(digits.len()));
                let exp_sign = if exponent < 0 { '-' } else { '+' };
                (
                    format!("{}{first}", sign(x)),
                    rest.to_owned(),
                    format!("{exp_sign}{:02}", exponent.unsigned_abs()),
                )
            } else {
                let (int, frac) = positional(magnitude, PRECISION);
                (format!("{}{int}", sign(x)), frac, String::new())
            }
        })
        .collect();
    let pad_left = parts.iter().map(|p| p.0.len()).max().unwrap_or(0);
    let frac_width = parts.iter().map(|p| p.1.len()).max().unwrap_or(0);
    let exp_width = parts
        .iter()
        .map(|p| p.2.len())
        .max()
        .unwrap_or(1)
        .saturating_sub(1);
    let pad_right = if scientific {
        exp_width + 2 + frac_width
    } else {
        frac_width
    };
    // Room for `nan`, `inf` and `-inf` beside the numbers.
    let neginf = values
        .iter()
        .any(|x| !x.finite() && !x.nan() && x.negative());
    let pad_left = if finite.len() < values.len() {
        let offset = pad_right + 1;
        pad_left
            .max(3usize.saturating_sub(offset))
            .max((3 + usize::from(neginf)).saturating_sub(offset))
    } else {
        pad_left
    };
    let mut parts = parts.into_iter();
    values
        .iter()
        .map(|&x| {
            if !x.finite() {
                let text = if x.nan() {
                    "nan"
                } else if x.negative() {
                    "-inf"
                } else {
                    "inf"
                };
                return format!("{text:>width$}", width = pad_left + pad_right + 1);
            }
            let (int, frac, _) = parts.next().unwrap_or_default();
            if scientific {
                // Every value gets as many decimals as the one needing most:
                // the exact value's next digits, not zeros, as Dragon4's
                // `min_digits` gives them.
                let (digits, exponent) = split_exp(&format!("{:.*e}", frac_width, x.abs()));
                let (first, rest) = digits.split_at(1.min(digits.len()));
                let int = format!("{}{first}", sign(x));
                let exp_sign = if exponent < 0 { '-' } else { '+' };
                let exp_digits = exponent.unsigned_abs();
                format!("{int:>pad_left$}.{rest}e{exp_sign}{exp_digits:0>exp_width$}")
            } else {
                format!("{int:>pad_left$}.{frac:<pad_right$}")
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::borrow::Cow;

    use super::{numpy_repr, Numbers};

    /// What numpy 2.4's `repr` prints for these arrays (`tests/ros2/cli.py`
    /// compares with numpy itself, through rclpy).
    #[test]
    fn fixed_arrays_print_as_numpy_prints_them() {
        let wrapped: Vec<f64> = (0..30).map(|i| f64::from(i) * 1.1).collect();
        let cases: [(Numbers<'_>, &str); 8] = [
            (
                Numbers::F64(Cow::Borrowed(&[1.0, 2.5, -3.0])),
                "array([ 1. ,  2.5, -3. ])",
            ),
            (
                Numbers::F64(Cow::Borrowed(&[1e-5, 1.5e10])),
                "array([1.0e-05, 1.5e+10])",
            ),
            (
                Numbers::F64(Cow::Borrowed(&[0.1, f64::NAN, f64::NEG_INFINITY])),
                "array([ 0.1,  nan, -inf])",
            ),
            (
                Numbers::I32(Cow::Borrowed(&[1, -20, 3])),
                "array([  1, -20,   3], dtype=int32)",
            ),
            (
                Numbers::F64(Cow::Borrowed(&[0.001953125])),
                "array([0.00195312])",
            ),
            (
                Numbers::F32(Cow::Borrowed(&[1.5])),
                "array([1.5], dtype=float32)",
            ),
            (
                Numbers::F64(Cow::Borrowed(&wrapped)),
                "array([ 0. ,  1.1,  2.2,  3.3,  4.4,  5.5,  6.6,  7.7,  8.8,  9.9, 11. ,\n       \
                 12.1, 13.2, 14.3, 15.4, 16.5, 17.6, 18.7, 19.8, 20.9, 22. , 23.1,\n       \
                 24.2, 25.3, 26.4, 27.5, 28.6, 29.7, 30.8, 31.9])",
            ),
            (
                Numbers::F64(Cow::Borrowed(&[0.0; 1001])),
                "array([0., 0., 0., ..., 0., 0., 0.], shape=(1001,))",
            ),
        ];
        for (numbers, numpy) in cases {
            assert_eq!(numpy_repr(&numbers), numpy);
        }
    }
}
