//! The two error types: [`EncodeError`] (writing) and [`DecodeError`] (reading).
//!
//! Both are a single boxed pointer so that `Result<T, _>` costs nothing extra on the
//! success path; the path of struct fields leading to the failure is recorded only
//! while an error propagates.

use std::fmt;

/// The struct fields (outermost first) that lead to the value an error is about.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct FieldPath(Vec<(&'static str, &'static str)>);

impl FieldPath {
    fn push(&mut self, type_name: &'static str, field: &'static str) {
        // Errors propagate from the innermost field outwards; store in that order and
        // print reversed.
        self.0.push((type_name, field));
    }
}

impl fmt::Display for FieldPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut iter = self.0.iter().rev();
        if let Some((ty, field)) = iter.next() {
            write!(f, " (in {ty}.{field}")?;
            for (_, field) in iter {
                write!(f, ".{field}")?;
            }
            f.write_str(")")?;
        }
        Ok(())
    }
}

/// Why decoding failed.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum DecodeErrorKind {
    /// The input ended before a value that needs `needed` more bytes.
    UnexpectedEof {
        /// Bytes the value needs (including alignment padding).
        needed: usize,
        /// Bytes left in the input.
        remaining: usize,
    },
    /// A length prefix announces more elements than the rest of the input can hold.
    LengthExceedsInput {
        /// The element count read from the prefix.
        count: u32,
        /// The smallest number of bytes one element can take on the wire.
        min_element_size: usize,
        /// Bytes left in the input after the prefix.
        remaining: usize,
    },
    /// A bounded string or sequence is longer than its bound.
    BoundExceeded {
        /// The length on the wire.
        len: usize,
        /// The bound of the type.
        bound: usize,
    },
    /// A string's bytes are not UTF-8.
    InvalidUtf8 {
        /// Offset of the first invalid byte within the string.
        valid_up_to: usize,
    },
    /// A string's length includes a terminator, but its last byte is not NUL.
    MissingNul {
        /// The byte found where the NUL should be.
        found: u8,
    },
    /// A wide string holds a code unit above 0xFFFF or an unpaired surrogate.
    InvalidUtf16 {
        /// The offending 32-bit value.
        unit: u32,
    },
    /// A `bool` byte other than 0 or 1.
    InvalidBool(u8),
    /// The encapsulation header names a representation other than classic CDR.
    UnknownEncapsulation([u8; 2]),
    /// A value of `len` bytes straddles two segments of a fragmented input (see
    /// [`Reader::from_segments`](crate::Reader::from_segments)); decode a contiguous
    /// copy instead.
    Fragmented {
        /// The value's length.
        len: usize,
    },
    /// A `&str` field cannot borrow from [shared](crate::Reader::shared)
    /// input: another process could rewrite its bytes after the UTF-8 check.
    /// `Cow<str>` (copied from shared memory, borrowed elsewhere) or `String`
    /// read it.
    SharedBorrow,
    /// More than 3 bytes follow the message, in [`from_bytes_strict`](crate::from_bytes_strict).
    TrailingBytes {
        /// How many bytes follow the message.
        count: usize,
    },
}

impl fmt::Display for DecodeErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::SharedBorrow => f.write_str(
                "a `&str` cannot borrow from shared memory, which another process may rewrite after the UTF-8 check: use `Cow<str>` (copied from shared memory, borrowed elsewhere) or `String`",
            ),
            Self::UnexpectedEof { needed, remaining } => write!(
                f,
                "input ends early: {needed} more bytes needed, {remaining} left"
            ),
            Self::LengthExceedsInput {
                count,
                min_element_size,
                remaining,
            } => write!(
                f,
                "length prefix {count} needs at least {} bytes, only {remaining} left",
                u64::from(*count) * *min_element_size as u64
            ),
            Self::BoundExceeded { len, bound } => {
                write!(f, "length {len} exceeds the type's bound of {bound}")
            }
            Self::InvalidUtf8 { valid_up_to } => write!(
                f,
                "string is not valid UTF-8 (first bad byte {valid_up_to} bytes into it)"
            ),
            Self::MissingNul { found } => {
                write!(f, "string is not NUL-terminated (last byte is {found:#04x})")
            }
            Self::InvalidUtf16 { unit } => {
                write!(f, "wide string holds an invalid UTF-16 code unit {unit:#x}")
            }
            Self::InvalidBool(b) => write!(f, "bool byte is {b:#04x}, expected 0 or 1"),
            Self::UnknownEncapsulation([a, b]) => write!(
                f,
                "encapsulation {a:02x} {b:02x} is not classic CDR (00 00 big-endian or 00 01 little-endian)"
            ),
            Self::Fragmented { len } => write!(
                f,
                "a {len}-byte value straddles two fragments of the input (decode a contiguous copy)"
            ),
            Self::TrailingBytes { count } => write!(
                f,
                "{count} bytes follow the end of the message (at most 3 padding bytes are allowed)"
            ),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct DecodeErrorInner {
    kind: DecodeErrorKind,
    offset: usize,
    path: FieldPath,
}

/// Decoding failed: what went wrong and at which byte of the input (counted from the
/// start of the 4-byte encapsulation header).
#[derive(Clone, PartialEq, Eq)]
pub struct DecodeError(Box<DecodeErrorInner>);

impl DecodeError {
    /// An error of `kind` at byte `offset` of the input.
    #[cold]
    pub fn new(kind: DecodeErrorKind, offset: usize) -> Self {
        Self(Box::new(DecodeErrorInner {
            kind,
            offset,
            path: FieldPath::default(),
        }))
    }

    /// What went wrong.
    pub fn kind(&self) -> &DecodeErrorKind {
        &self.0.kind
    }

    /// Offset of the offending bytes from the start of the input (header included).
    pub fn offset(&self) -> usize {
        self.0.offset
    }

    /// The field names from the outermost message down to the failing value,
    /// e.g. `["header", "frame_id"]`.
    pub fn field_path(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.0.path.0.iter().rev().map(|(_, field)| *field)
    }

    /// Record that the error happened inside `type_name.field` (called by derived code
    /// while the error propagates).
    #[cold]
    pub fn in_field(mut self, type_name: &'static str, field: &'static str) -> Self {
        self.0.path.push(type_name, field);
        self
    }
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CDR decode error at byte {}", self.0.offset)?;
        self.0.path.fmt(f)?;
        write!(f, ": {}", self.0.kind)
    }
}

impl fmt::Debug for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for DecodeError {}

/// Why encoding failed.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum EncodeErrorKind {
    /// The output buffer is shorter than the encoded message.
    BufferTooSmall {
        /// Exact encoded size of the message, header included.
        needed: usize,
        /// Length of the buffer given.
        available: usize,
    },
    /// A bounded string or sequence holds more than its bound.
    BoundExceeded {
        /// The value's length.
        len: usize,
        /// The bound of the type.
        bound: usize,
    },
    /// A length does not fit the 32-bit length prefix of CDR.
    LengthOverflow {
        /// The value's length.
        len: usize,
    },
}

impl fmt::Display for EncodeErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BufferTooSmall { needed, available } => write!(
                f,
                "buffer of {available} bytes is too small, the message needs {needed}"
            ),
            Self::BoundExceeded { len, bound } => {
                write!(f, "length {len} exceeds the type's bound of {bound}")
            }
            Self::LengthOverflow { len } => {
                write!(f, "length {len} does not fit CDR's 32-bit length prefix")
            }
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct EncodeErrorInner {
    kind: EncodeErrorKind,
    path: FieldPath,
}

/// Encoding failed. Nothing was written outside the buffer given.
#[derive(Clone, PartialEq, Eq)]
pub struct EncodeError(Box<EncodeErrorInner>);

impl EncodeError {
    /// An error of `kind`.
    #[cold]
    pub fn new(kind: EncodeErrorKind) -> Self {
        Self(Box::new(EncodeErrorInner {
            kind,
            path: FieldPath::default(),
        }))
    }

    /// What went wrong.
    pub fn kind(&self) -> &EncodeErrorKind {
        &self.0.kind
    }

    /// The field names from the outermost message down to the failing value.
    pub fn field_path(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.0.path.0.iter().rev().map(|(_, field)| *field)
    }

    /// Record that the error happened inside `type_name.field`.
    #[cold]
    pub fn in_field(mut self, type_name: &'static str, field: &'static str) -> Self {
        self.0.path.push(type_name, field);
        self
    }

    pub(crate) fn set_kind(&mut self, kind: EncodeErrorKind) {
        self.0.kind = kind;
    }
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("CDR encode error")?;
        self.0.path.fmt(f)?;
        write!(f, ": {}", self.0.kind)
    }
}

impl fmt::Debug for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for EncodeError {}
