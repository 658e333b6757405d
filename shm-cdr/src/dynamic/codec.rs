//! Reading and writing [`Message`]s: the same readers and writers the generated
//! types use, chosen per field at run time, with the same checks (every length
//! checked against the input before anything is allocated, bounds enforced both
//! ways, padding zeroed).

use std::borrow::Cow;

use super::model::DynamicType;
use super::numbers::Numbers;
use super::plan::{Bits, Copies, Entry, Load, Member, Step};
use super::structs::{Check, Element, FieldDef};
use super::value::{Message, Messages, Slots, Value};
use crate::decode::{CdrDecode, Reader};
use crate::describe::Container;
use crate::encode::{CdrEncode, Writer};
use crate::endian::{BigEndian, ByteOrder, Endianness, LittleEndian};
use crate::error::{DecodeError, DecodeErrorKind, EncodeError, EncodeErrorKind};
use crate::layout::align_up;
use crate::wire::string::{string_end, strings_end, write_string, write_strings};
use crate::wire::wstring::{read_wstring, write_wstring, wstring_end};

impl DynamicType {
    /// Decode a CDR payload (encapsulation header included) as this type,
    /// borrowing strings, byte and number arrays from `bytes` where the
    /// generated types would (bytes after the message are ignored, as
    /// rclpy's and Fast-CDR's readers ignore them).
    pub fn decode<'de>(&self, bytes: &'de [u8]) -> Result<Message<'de>, DecodeError> {
        self.decode_from(bytes, false)
    }

    /// [`decode`](Self::decode) for input other processes may write (shared
    /// memory): strings are copied before they are checked.
    pub fn decode_shared<'de>(&self, bytes: &'de [u8]) -> Result<Message<'de>, DecodeError> {
        self.decode_from(bytes, true)
    }

    /// [`decode`](Self::decode) (or, `shared`, [`decode_shared`](Self::decode_shared))
    /// for printing with a truncation of `keep` elements: of each array or
    /// sequence of strings or nested messages, only the first `keep + 1` are
    /// kept (enough to show that more follow); the others are checked and
    /// skipped. Memory then follows what is printed, not the message's
    /// shape: a sequence of millions of one-byte messages costs `keep + 1`
    /// of them. Arrays of numbers are borrowed from `bytes` as in `decode`.
    /// The message remembers each length it cut, so that printing it with
    /// [`YamlOptions::no_arr`](super::YamlOptions::no_arr), which shows no
    /// element but every length, needs only `keep` 0.
    pub fn decode_truncated<'de>(
        &self,
        bytes: &'de [u8],
        shared: bool,
        keep: usize,
    ) -> Result<Message<'de>, DecodeError> {
        let body = bytes.get(4..).unwrap_or_default();
        match crate::read_header(bytes)? {
            Endianness::Little => {
                let r = Reader::<LittleEndian>::new(body);
                self.decode_message_kept(&mut if shared { r.shared() } else { r }, 0, keep)
            }
            Endianness::Big => {
                let r = Reader::<BigEndian>::new(body);
                self.decode_message_kept(&mut if shared { r.shared() } else { r }, 0, keep)
            }
        }
    }

    /// The field at `path` (the names of nested message fields, then the
    /// field's own) of a CDR payload of this type, decoded alone; the rest of
    /// the payload is checked as [`decode`](Self::decode) checks it (or,
    /// `shared`, [`decode_shared`](Self::decode_shared)) and skipped, one
    /// element of each sequence at a time. `None` if the type has no such
    /// field. Memory follows the field, not the message: what
    /// `shm-ros2 topic echo --field` prints.
    ///
    /// ```
    /// use shm_cdr::dynamic::{DynamicType, Value};
    /// use shm_cdr::msgs::geometry_msgs::msg::PoseStamped;
    /// use shm_cdr::RosMessage;
    ///
    /// let mut pose = PoseStamped::default();
    /// pose.pose.position.x = 1.5;
    /// let bytes = shm_cdr::to_vec(&pose)?;
    /// let ty = DynamicType::from_description(&PoseStamped::full_description())?;
    /// let x = ty.decode_field(&bytes, false, &["pose", "position", "x"])?;
    /// assert_eq!(x, Some(Value::F64(1.5)));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn decode_field<'de>(
        &self,
        bytes: &'de [u8],
        shared: bool,
        path: &[&str],
    ) -> Result<Option<Value<'de>>, DecodeError> {
        let body = bytes.get(4..).unwrap_or_default();
        let mut found = None;
        match crate::read_header(bytes)? {
            Endianness::Little => {
                let r = Reader::<LittleEndian>::new(body);
                let mut r = if shared { r.shared() } else { r };
                self.decode_field_in(&mut r, 0, path, &mut found)?;
            }
            Endianness::Big => {
                let r = Reader::<BigEndian>::new(body);
                let mut r = if shared { r.shared() } else { r };
                self.decode_field_in(&mut r, 0, path, &mut found)?;
            }
        }
        Ok(found)
    }

    /// Read one message of struct `index`, keeping into `found` only the
    /// field at `path` (`None` or empty: nothing).
    fn decode_field_in<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        index: usize,
        path: &[&str],
        found: &mut Option<Value<'de>>,
    ) -> Result<(), DecodeError> {
        let def = &self.inner.structs[index];
        let checks = self.inner.checks.get(index).map_or(&[][..], Vec::as_slice);
        for (field, check) in def.fields.iter().zip(checks) {
            let (on_path, rest) = match path.split_first() {
                Some((name, rest)) if *name == field.name => (true, rest),
                _ => (false, &[][..]),
            };
            let wanted = on_path && rest.is_empty();
            match *check {
                Check::Message { index, .. } if on_path && !rest.is_empty() => {
                    self.decode_field_in(r, index, rest, found)?;
                }
                _ => {
                    let keep = if wanted { usize::MAX } else { 0 };
                    let (value, _) = self.decode_field_kept(r, field, check, keep)?;
                    if wanted {
                        *found = Some(value);
                    }
                }
            }
        }
        Ok(())
    }

    fn decode_from<'de>(
        &self,
        bytes: &'de [u8],
        shared: bool,
    ) -> Result<Message<'de>, DecodeError> {
        self.decode_truncated(bytes, shared, usize::MAX)
    }

    /// Read one message of struct `index` at the reader's position.
    pub fn decode_message<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        index: usize,
    ) -> Result<Message<'de>, DecodeError> {
        self.decode_message_kept(r, index, usize::MAX)
    }

    /// [`decode_message`](Self::decode_message), keeping `keep + 1` elements
    /// of each array or sequence of strings or messages (see
    /// [`decode_truncated`](Self::decode_truncated)).
    fn decode_message_kept<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        index: usize,
        keep: usize,
    ) -> Result<Message<'de>, DecodeError> {
        let block = self.inner.plans.get(index).map_or(0, |p| p.block);
        let mut slots = Vec::with_capacity(block);
        let mut cut = Vec::new();
        let mut holds = false;
        self.decode_struct(r, index, &mut slots, &mut cut, keep, &mut holds)?;
        let mut message = Message::from_slots(self.clone(), index, Slots::decoded(slots, !holds));
        message.cut = cut;
        Ok(message)
    }

    /// Read one message of struct `index`, pushing its values onto `slots`
    /// in slot order and noting each field decoded cut short in `cut`. Its
    /// plan's runs of fixed-size fields are read with one bounds check each;
    /// where one fails (or the input is in segments), field by field, for
    /// the exact error. `holds` is set unless every value pushed is known
    /// to hold nothing to free ([`Value::holds_nothing`]): numbers, and
    /// strings and arrays borrowed from the input.
    fn decode_struct<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        index: usize,
        slots: &mut Vec<Value<'de>>,
        cut: &mut Vec<(usize, usize)>,
        keep: usize,
        holds: &mut bool,
    ) -> Result<(), DecodeError> {
        let Some(plan) = self.inner.plans.get(index) else {
            return Ok(());
        };
        if !r.is_contiguous() {
            *holds = true;
            return self.decode_entries(r, &plan.entries, slots, cut, keep);
        }
        self.decode_steps(r, &plan.steps, slots, cut, keep, holds)
    }

    /// [`decode_struct`](Self::decode_struct) of a contiguous input, by
    /// its plan's `steps`: inlined where messages are read one after
    /// another, so that an array of small messages costs no call per
    /// element.
    #[inline(always)]
    fn decode_steps<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        steps: &[Step],
        slots: &mut Vec<Value<'de>>,
        cut: &mut Vec<(usize, usize)>,
        keep: usize,
        holds: &mut bool,
    ) -> Result<(), DecodeError> {
        for step in steps {
            match step {
                Step::Run {
                    align,
                    len,
                    members,
                    checks,
                    loads,
                    ..
                } => {
                    let at = r.position();
                    let filled = slots.len();
                    let read = match r.read_aligned_bytes(*align, *len) {
                        Ok(bytes) => load_run::<B>(bytes, loads, slots),
                        Err(_) => false,
                    };
                    if !read {
                        *holds = true;
                        r.rewind(at);
                        slots.truncate(filled);
                        for (m, &check) in members.iter().zip(checks.iter()) {
                            self.decode_check(r, check, Some(m.element), slots, cut, keep)?;
                            if m.placeholder {
                                if let Some(last) = slots.last_mut() {
                                    *last = Value::U8(0);
                                }
                            }
                        }
                    }
                }
                &Step::String { bound, .. } => {
                    let s = decode_string(r, bound)?;
                    *holds |= matches!(s, Cow::Owned(_));
                    push_with(slots, || Value::String(s))
                }
                &Step::Numbers {
                    container,
                    size,
                    check,
                    ..
                } => {
                    // Borrowed in bulk, as `Numbers::decode` reads it; an empty
                    // one (not aligned to) as any other field.
                    let at = r.position();
                    let n = read_len(r, container, size)?;
                    let element = match check {
                        Check::Many { element, .. } if n > 0 => Some(element),
                        _ => None,
                    };
                    let borrowed = match element {
                        Some(element) => match r.read_aligned_bytes(size, n.saturating_mul(size)) {
                            Ok(raw) => array_at::<B>(raw, 0, element, n, slots),
                            Err(_) => false,
                        },
                        None => false,
                    };
                    if !borrowed {
                        r.rewind(at);
                        self.decode_check(r, check, None, slots, cut, keep)?;
                        *holds |= slots.last().is_some_and(|v| !v.holds_nothing());
                    }
                }
                &Step::Value { check, element, .. } => {
                    self.decode_check(r, check, Some(element), slots, cut, keep)?;
                    *holds |= slots.last().is_some_and(|v| !v.holds_nothing());
                }
                &Step::Nested { index, .. } => {
                    self.decode_struct(r, index, slots, cut, keep, holds)?
                }
                &Step::Messages {
                    index,
                    container,
                    min,
                    ..
                } => {
                    *holds = true;
                    let n = read_len(r, container, min)?;
                    let kept = n.min(keep.saturating_add(1));
                    let messages = self.decode_messages(r, index, n, kept, keep)?;
                    if kept < n {
                        cut.push((slots.len(), n));
                    }
                    push_with(slots, || Value::Messages(messages))
                }
            }
        }
        Ok(())
    }

    /// [`decode_struct`](Self::decode_struct) field by field, as its plan's
    /// entries list them.
    fn decode_entries<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        entries: &[Entry],
        slots: &mut Vec<Value<'de>>,
        cut: &mut Vec<(usize, usize)>,
        keep: usize,
    ) -> Result<(), DecodeError> {
        for entry in entries {
            match entry {
                Entry::Field(leaf) if leaf.placeholder => {
                    // rosidl's placeholder member of an empty message carries
                    // no value: read as 0 whatever the byte, as the generated
                    // types read it.
                    self.decode_single(r, leaf.element)?;
                    slots.push(Value::U8(0));
                }
                Entry::Field(leaf) => {
                    self.decode_check(r, leaf.check, Some(leaf.element), slots, cut, keep)?
                }
                &Entry::Nested { index, .. } => {
                    self.decode_struct(r, index, slots, cut, keep, &mut true)?
                }
            }
        }
        Ok(())
    }

    /// Read one field that is not a message nested by value, as `check`
    /// says (a single value's `element` given), and push it.
    #[inline]
    fn decode_check<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        check: Check,
        element: Option<Element>,
        slots: &mut Vec<Value<'de>>,
        cut: &mut Vec<(usize, usize)>,
        keep: usize,
    ) -> Result<(), DecodeError> {
        match (check, element) {
            (
                Check::Many {
                    element,
                    container,
                    min,
                },
                _,
            ) => {
                let n = read_len(r, container, min)?;
                let at = slots.len();
                self.put_elements_kept(r, element, n, keep, slots)?;
                if slots
                    .get(at)
                    .and_then(Value::len)
                    .is_some_and(|kept| kept < n)
                {
                    cut.push((at, n));
                }
            }
            (Check::String(bound), _) => {
                let s = decode_string(r, bound)?;
                push_with(slots, || Value::String(s))
            }
            (Check::WString(bound), _) => {
                let s = read_wstring(r, bound)?;
                push_with(slots, || Value::WString(s))
            }
            (_, Some(element)) => {
                let value = self.decode_single(r, element)?;
                push_with(slots, || value)
            }
            // A single number or bool always comes with its element; a
            // message nested by value is a plan entry of its own.
            (Check::Number(_) | Check::Bool | Check::Message { .. }, None) => {}
        }
        Ok(())
    }

    /// One field's value at the reader, keeping `keep + 1` elements of each
    /// array or sequence of strings or messages; with the count on the wire
    /// when fewer were kept.
    #[inline]
    fn decode_field_kept<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        field: &FieldDef,
        check: &Check,
        keep: usize,
    ) -> Result<(Value<'de>, Option<usize>), DecodeError> {
        Ok(match *check {
            Check::Message { index, .. } => (
                Value::Message(Box::new(self.decode_message_kept(r, index, keep)?)),
                None,
            ),
            Check::Many {
                element,
                container,
                min,
            } => {
                let n = read_len(r, container, min)?;
                let value = self.decode_elements_kept(r, element, n, keep)?;
                let cut_from = value.len().is_some_and(|kept| kept < n).then_some(n);
                (value, cut_from)
            }
            _ => (self.decode_single(r, field.element)?, None),
        })
    }

    /// Read `n` elements (of an array or sequence whose count is read).
    #[inline]
    pub(crate) fn decode_elements<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        element: Element,
        n: usize,
    ) -> Result<Value<'de>, DecodeError> {
        self.decode_elements_kept(r, element, n, usize::MAX)
    }

    /// [`decode_elements`](Self::decode_elements), keeping the first
    /// `keep + 1` strings or messages and checking the others.
    #[inline]
    pub(crate) fn decode_elements_kept<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        element: Element,
        n: usize,
        keep: usize,
    ) -> Result<Value<'de>, DecodeError> {
        let mut out = None;
        self.put_elements_kept(r, element, n, keep, &mut out)?;
        // Every element kind puts one value.
        Ok(out.unwrap_or(Value::Bools(Vec::new())))
    }

    /// [`decode_elements_kept`](Self::decode_elements_kept), the value put
    /// into `out`: built in a table's own memory (see [`push_with`]).
    #[inline]
    fn put_elements_kept<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        element: Element,
        n: usize,
        keep: usize,
        out: &mut impl Put<'de>,
    ) -> Result<(), DecodeError> {
        let kept = n.min(keep.saturating_add(1));
        macro_rules! numbers {
            ($variant:ident) => {{
                let numbers = Numbers::decode(r, n)?;
                out.put(|| Value::$variant(numbers))
            }};
        }
        match element {
            Element::Bool => {
                let bools = bool::decode_vec(r, n)?;
                out.put(|| Value::Bools(bools))
            }
            Element::Byte | Element::Char | Element::U8 => {
                let bytes = u8::decode_cow_slice(r, n)?;
                out.put(|| Value::U8s(bytes))
            }
            Element::I8 => {
                let bytes = i8::decode_cow_slice(r, n)?;
                out.put(|| Value::I8s(bytes))
            }
            Element::I16 => numbers!(I16s),
            Element::U16 => numbers!(U16s),
            Element::I32 => numbers!(I32s),
            Element::U32 => numbers!(U32s),
            Element::I64 => numbers!(I64s),
            Element::U64 => numbers!(U64s),
            Element::F32 => numbers!(F32s),
            Element::F64 => numbers!(F64s),
            Element::String(bound) => {
                let mut strings = Vec::with_capacity(kept);
                for _ in 0..kept {
                    strings.push(decode_string(r, bound)?);
                }
                for _ in kept..n {
                    decode_string(r, bound)?;
                }
                out.put(|| Value::Strings(strings))
            }
            Element::WString(bound) => {
                let mut strings = Vec::with_capacity(kept);
                for _ in 0..kept {
                    strings.push(read_wstring(r, bound)?);
                }
                for _ in kept..n {
                    read_wstring(r, bound)?;
                }
                out.put(|| Value::WStrings(strings))
            }
            Element::Message(index) => {
                let messages = self.decode_messages(r, index, n, kept, keep)?;
                out.put(|| Value::Messages(messages))
            }
        }
        Ok(())
    }

    /// `n` messages of struct `index`, the first `kept` kept.
    fn decode_messages<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        index: usize,
        n: usize,
        kept: usize,
        keep: usize,
    ) -> Result<Box<Messages<'de>>, DecodeError> {
        let block = self.inner.plans.get(index).map_or(0, |p| p.block);
        // The count was checked against the input, but a message may
        // take many slots for few bytes: the table grows as they are
        // read, from a start that a bad count cannot inflate.
        let mut slots = Vec::with_capacity(kept.saturating_mul(block).min(1 << 12));
        let mut cut = Vec::new();
        let mut holds = false;
        match self.inner.plans.get(index) {
            Some(plan) if r.is_contiguous() => {
                for _ in 0..kept {
                    self.decode_steps(r, &plan.steps, &mut slots, &mut cut, keep, &mut holds)?;
                }
            }
            _ => {
                for _ in 0..kept {
                    self.decode_struct(r, index, &mut slots, &mut cut, keep, &mut holds)?;
                }
            }
        }
        let mut skipped = Vec::new();
        for _ in kept..n {
            self.decode_struct(r, index, &mut skipped, &mut Vec::new(), keep, &mut true)?;
            skipped.clear();
        }
        let slots = Slots::decoded(slots, !holds);
        let mut messages = Messages::from_slots(self.clone(), index, kept, slots);
        messages.cut = cut;
        Ok(Box::new(messages))
    }

    #[inline]
    pub(crate) fn decode_single<'de, B: ByteOrder>(
        &self,
        r: &mut Reader<'de, B>,
        element: Element,
    ) -> Result<Value<'de>, DecodeError> {
        Ok(match element {
            Element::Bool => Value::Bool(bool::decode(r)?),
            Element::Byte | Element::Char | Element::U8 => Value::U8(u8::decode(r)?),
            Element::I8 => Value::I8(i8::decode(r)?),
            Element::I16 => Value::I16(i16::decode(r)?),
            Element::U16 => Value::U16(u16::decode(r)?),
            Element::I32 => Value::I32(i32::decode(r)?),
            Element::U32 => Value::U32(u32::decode(r)?),
            Element::I64 => Value::I64(i64::decode(r)?),
            Element::U64 => Value::U64(u64::decode(r)?),
            Element::F32 => Value::F32(f32::decode(r)?),
            Element::F64 => Value::F64(f64::decode(r)?),
            Element::String(bound) => Value::String(decode_string(r, bound)?),
            Element::WString(bound) => Value::WString(read_wstring(r, bound)?),
            Element::Message(index) => Value::Message(Box::new(self.decode_message(r, index)?)),
        })
    }
}

/// How many elements an array or sequence field holds whose elements take at
/// least `min` bytes each: a sequence's count is read; either way, so many
/// must fit in the rest of the input, and a bounded sequence's count within
/// its bound.
#[inline(always)]
pub(crate) fn read_len<B: ByteOrder>(
    r: &mut Reader<'_, B>,
    container: Container,
    min: usize,
) -> Result<usize, DecodeError> {
    match container {
        Container::Array(n) => {
            let needed = n.saturating_mul(min);
            if needed > r.remaining() {
                return Err(r.error_at(
                    r.position(),
                    DecodeErrorKind::UnexpectedEof {
                        needed,
                        remaining: r.remaining(),
                    },
                ));
            }
            Ok(n)
        }
        Container::BoundedSequence(bound) => {
            let at = r.position();
            let n = r.read_count(min)?;
            if n > bound {
                return Err(r.error_at(at, DecodeErrorKind::BoundExceeded { len: n, bound }));
            }
            Ok(n)
        }
        // A single value is never read as many (`Check::Many` is not made for it).
        Container::Sequence | Container::Single => r.read_count(min),
    }
}

/// The values of a run of fixed-size fields from its bytes, pushed onto
/// `slots`; `false` (some pushed) if a value cannot be read from where the
/// run says it lies or a bool is neither 0 nor 1: then the run is read
/// again field by field, for the exact error.
#[inline(always)]
fn load_run<'de, B: ByteOrder>(
    bytes: &'de [u8],
    loads: &[Load],
    slots: &mut Vec<Value<'de>>,
) -> bool {
    macro_rules! number {
        ($t:ty, $variant:ident, $at:expr) => {{
            let Some(wire) = bytes
                .get($at..)
                .and_then(|rest| rest.first_chunk::<{ std::mem::size_of::<$t>() }>())
            else {
                return false;
            };
            let number = if B::LITTLE {
                <$t>::from_le_bytes(*wire)
            } else {
                <$t>::from_be_bytes(*wire)
            };
            push_with(slots, || Value::$variant(number))
        }};
    }
    for load in loads {
        match *load {
            Load::U8(at) => number!(u8, U8, at),
            Load::I8(at) => number!(i8, I8, at),
            Load::I16(at) => number!(i16, I16, at),
            Load::U16(at) => number!(u16, U16, at),
            Load::I32(at) => number!(i32, I32, at),
            Load::U32(at) => number!(u32, U32, at),
            Load::I64(at) => number!(i64, I64, at),
            Load::U64(at) => number!(u64, U64, at),
            Load::F32(at) => number!(f32, F32, at),
            Load::F64(at) => number!(f64, F64, at),
            Load::Bool(at) => match bytes.get(at) {
                Some(&b) if b <= 1 => push_with(slots, || Value::Bool(b != 0)),
                _ => return false,
            },
            Load::Singles {
                element,
                offset,
                count,
            } => {
                if !singles_at::<B>(bytes, offset, element, count, slots) {
                    return false;
                }
            }
            Load::Array { element, offset, n } => {
                if !array_at::<B>(bytes, offset, element, n, slots) {
                    return false;
                }
            }
            Load::Placeholder => push_with(slots, || Value::U8(0)),
        }
    }
    true
}

/// Push the value `make` builds, built in the table's own memory. A value
/// built first and pushed after is stored to the stack in parts (its tag,
/// then its number) and loaded back whole to be copied: the processor cannot
/// forward such stores to the load, and that stall of a dozen cycles per
/// value was most of the time of decoding a small message. Extending by an
/// iterator of known length reserves first and builds the value in place.
#[inline(always)]
fn push_with<'de>(slots: &mut Vec<Value<'de>>, make: impl FnOnce() -> Value<'de>) {
    slots.extend(std::iter::once_with(make));
}

/// Where a decoded value goes: the end of a table, or a single place.
trait Put<'de> {
    fn put(&mut self, make: impl FnOnce() -> Value<'de>);
}

impl<'de> Put<'de> for Vec<Value<'de>> {
    #[inline(always)]
    fn put(&mut self, make: impl FnOnce() -> Value<'de>) {
        push_with(self, make)
    }
}

impl<'de> Put<'de> for Option<Value<'de>> {
    #[inline(always)]
    fn put(&mut self, make: impl FnOnce() -> Value<'de>) {
        *self = Some(make())
    }
}

/// The bytes of `count` numbers (or bools) of kind `element` at
/// `bytes[offset..]`, if they are all there.
#[inline(always)]
fn numbers_at(bytes: &[u8], offset: usize, element: Element, count: usize) -> Option<&[u8]> {
    let len = count.checked_mul(element.fixed_size()?)?;
    bytes.get(offset..offset.checked_add(len)?)
}

/// The `count` numbers of kind `element` back to back from
/// `bytes[offset..]`, one value each pushed onto `slots`; `false` (none
/// pushed) if they are not all there or not numbers.
#[inline(always)]
fn singles_at<B: ByteOrder>(
    bytes: &[u8],
    offset: usize,
    element: Element,
    count: usize,
    slots: &mut Vec<Value<'_>>,
) -> bool {
    let Some(raw) = numbers_at(bytes, offset, element, count) else {
        return false;
    };
    macro_rules! read {
        ($t:ty, $variant:ident) => {{
            for chunk in raw.chunks_exact(std::mem::size_of::<$t>()) {
                let mut wire = [0u8; std::mem::size_of::<$t>()];
                wire.copy_from_slice(chunk);
                push_with(slots, || {
                    Value::$variant(if B::LITTLE {
                        <$t>::from_le_bytes(wire)
                    } else {
                        <$t>::from_be_bytes(wire)
                    })
                })
            }
        }};
    }
    match element {
        Element::Byte | Element::Char | Element::U8 => {
            // A push per byte, as for the wider kinds: extending by an
            // iterator inlines a second, larger loop, which cost every decode
            // instructions (3 % of an Imu's, which has no bytes at all).
            for &b in raw {
                push_with(slots, || Value::U8(b))
            }
        }
        Element::I8 => read!(i8, I8),
        Element::I16 => read!(i16, I16),
        Element::U16 => read!(u16, U16),
        Element::I32 => read!(i32, I32),
        Element::U32 => read!(u32, U32),
        Element::I64 => read!(i64, I64),
        Element::U64 => read!(u64, U64),
        Element::F32 => read!(f32, F32),
        Element::F64 => read!(f64, F64),
        Element::Bool | Element::String(_) | Element::WString(_) | Element::Message(_) => {
            return false
        }
    }
    true
}

/// The array of `n` numbers of kind `element` at `bytes[offset..]`,
/// borrowed, pushed onto `slots`; `false` (nothing pushed) if it is not all
/// there or not of numbers.
#[inline]
fn array_at<'de, B: ByteOrder>(
    bytes: &'de [u8],
    offset: usize,
    element: Element,
    n: usize,
    slots: &mut Vec<Value<'de>>,
) -> bool {
    let Some(raw) = numbers_at(bytes, offset, element, n) else {
        return false;
    };
    if !element.is_number() {
        return false;
    }
    let order = B::ENDIANNESS;
    // One place that builds the value in the table: ten would each inline
    // a push, and together be called out of line.
    push_with(slots, || match element {
        Element::I8 => Value::I8s(Cow::Borrowed(bytemuck::cast_slice(raw))),
        Element::I16 => Value::I16s(Numbers::on_wire(raw, order)),
        Element::U16 => Value::U16s(Numbers::on_wire(raw, order)),
        Element::I32 => Value::I32s(Numbers::on_wire(raw, order)),
        Element::U32 => Value::U32s(Numbers::on_wire(raw, order)),
        Element::I64 => Value::I64s(Numbers::on_wire(raw, order)),
        Element::U64 => Value::U64s(Numbers::on_wire(raw, order)),
        Element::F32 => Value::F32s(Numbers::on_wire(raw, order)),
        Element::F64 => Value::F64s(Numbers::on_wire(raw, order)),
        // `byte`, `char` and `uint8` (the others are not numbers).
        _ => Value::U8s(Cow::Borrowed(raw)),
    });
    true
}

#[inline(always)]
pub(crate) fn decode_string<'de, B: ByteOrder>(
    r: &mut Reader<'de, B>,
    bound: Option<usize>,
) -> Result<Cow<'de, str>, DecodeError> {
    let at = r.position();
    let s = Cow::<str>::decode(r)?;
    match bound {
        Some(bound) if s.len() > bound => Err(r.error_at(
            at,
            DecodeErrorKind::BoundExceeded {
                len: s.len(),
                bound,
            },
        )),
        _ => Ok(s),
    }
}

/// A message's size and bytes follow its values; [`Message::set`] keeps each
/// value of its field's kind, so the two always agree.
impl CdrEncode for Message<'_> {
    fn encoded_end(&self, start: usize) -> usize {
        struct_end(&self.ty, self.index, &self.slots, 0, start, &mut NoHoles)
    }

    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        encode_struct(w, &self.ty, self.index, &self.slots, 0, &mut NoHoles)
    }
}

/// Whether a field's elements follow a count (a sequence's do; an array's,
/// or a single value, not).
fn counted(container: Container) -> bool {
    !matches!(container, Container::Array(_) | Container::Single)
}

/// The position after the message of struct `index` whose values start at
/// `slots[first]`, written at `start`: a run of fixed-size fields by its
/// length alone. A sequence `holes` holds is sized by the length it gives,
/// not by its slot's value, and told where its elements lie.
pub(crate) fn struct_end<H: Holes>(
    ty: &DynamicType,
    index: usize,
    slots: &[Value<'_>],
    first: usize,
    start: usize,
    holes: &mut H,
) -> usize {
    let Some(plan) = ty.inner.plans.get(index) else {
        return start;
    };
    let at = |slot: usize| slots.get(first + slot);
    let mut pos = start;
    for step in &plan.steps {
        pos = match *step {
            Step::Run { align, len, .. } => align_up(pos, align) + len,
            Step::String { slot, .. } => at(slot).map_or(pos, |v| value_end(v, pos, false)),
            Step::Numbers { slot, size, .. } if H::ANY => match holes.len(first + slot) {
                Some(n) => {
                    let elements = hole_start(pos, size, n);
                    let end = elements + n * size;
                    holes.lies(first + slot, elements..end);
                    end
                }
                None => at(slot).map_or(pos, |v| value_end(v, pos, true)),
            },
            Step::Numbers {
                slot, container, ..
            }
            | Step::Messages {
                slot, container, ..
            } => at(slot).map_or(pos, |v| value_end(v, pos, counted(container))),
            Step::Value { slot, check, .. } => {
                at(slot).map_or(pos, |v| value_end(v, pos, counted(check_container(check))))
            }
            Step::Nested {
                first: nested,
                index,
            } => struct_end(ty, index, slots, first + nested, pos, holes),
        };
    }
    pos
}

/// Where the elements of a sequence of `n` numbers of `size` bytes each
/// start when its count is written at `pos`: after the count, aligned to
/// the element (an empty sequence is not aligned to).
fn hole_start(pos: usize, size: usize, n: usize) -> usize {
    let after_count = align_up(pos, 4) + 4;
    if n == 0 {
        after_count
    } else {
        align_up(after_count, size)
    }
}

/// Sequences of numbers left out of a message's encoding, for their
/// elements to be written where they lie ([`InPlaceLayout`](super::InPlaceLayout)),
/// by absolute slot. Sizing and encoding are generic over it, so that
/// [`NoHoles`], every other message's, costs nothing.
pub(crate) trait Holes {
    /// Whether any sequence may be a hole (`false`: `len` is never asked).
    const ANY: bool;
    /// The number of elements of the sequence at `slot`, if it is a hole.
    fn len(&self, slot: usize) -> Option<usize>;
    /// The hole at `slot` has its elements at `range` (body positions).
    fn lies(&mut self, slot: usize, range: std::ops::Range<usize>);
}

/// No holes: a message encoded whole.
pub(crate) struct NoHoles;

impl Holes for NoHoles {
    const ANY: bool = false;
    #[inline(always)]
    fn len(&self, _: usize) -> Option<usize> {
        None
    }
    #[inline(always)]
    fn lies(&mut self, _: usize, _: std::ops::Range<usize>) {}
}

/// Write the message of struct `index` whose values start at
/// `slots[first]`: a run of fixed-size fields into one slot of the output.
/// A sequence `holes` holds gets its count and alignment, and its elements'
/// bytes are stepped over as they lie (see [`Writer::skip_in_place`]).
pub(crate) fn encode_struct<B: ByteOrder, H: Holes>(
    w: &mut Writer<'_, B>,
    ty: &DynamicType,
    index: usize,
    slots: &[Value<'_>],
    first: usize,
    holes: &mut H,
) -> Result<(), EncodeError> {
    let Some(plan) = ty.inner.plans.get(index) else {
        return Ok(());
    };
    let at = |slot: usize| slots.get(first + slot);
    for step in &plan.steps {
        match *step {
            Step::Run {
                align,
                len,
                first: run_first,
                ref members,
                ref copies,
                ..
            } => {
                let run = w.aligned_slot(align, len)?;
                let values = slots.get(first + run_first..).unwrap_or_default();
                let stored = copies
                    .as_ref()
                    .is_some_and(|copies| store_copies::<B>(run, copies, values));
                if !stored {
                    for m in members.iter() {
                        if let Some(value) = at(m.slot) {
                            write_member::<B>(run, m, value)?;
                        }
                    }
                }
            }
            Step::String { slot, bound } => {
                if let Some(value) = at(slot) {
                    encode_value(w, Element::String(bound), Container::Single, value)?;
                }
            }
            Step::Numbers {
                slot,
                container,
                size,
                ..
            } if H::ANY && holes.len(first + slot).is_some() => {
                let n = holes.len(first + slot).unwrap_or(0);
                write_count(w, container, n)?;
                let elements = if n == 0 {
                    w.position()
                } else {
                    // SAFETY: `holes` are only given to the encoding of
                    // `InPlaceLayout::write_around`, whose writer is over
                    // a caller's `&mut [u8]`: every byte is initialized.
                    #[allow(unsafe_code)]
                    unsafe {
                        w.skip_in_place(size, n * size)?
                    }
                };
                holes.lies(first + slot, elements..w.position());
            }
            Step::Numbers {
                slot,
                container,
                check,
                ..
            } => {
                if let (Some(value), Check::Many { element, .. }) = (at(slot), check) {
                    encode_value(w, element, container, value)?;
                }
            }
            Step::Value {
                slot,
                check,
                element,
            } => {
                if let Some(value) = at(slot) {
                    encode_value(w, element, check_container(check), value)?;
                }
            }
            Step::Messages {
                slot,
                index,
                container,
                ..
            } => {
                if let Some(value) = at(slot) {
                    encode_value(w, Element::Message(index), container, value)?;
                }
            }
            Step::Nested {
                first: nested,
                index,
            } => encode_struct(w, ty, index, slots, first + nested, holes)?,
        }
    }
    Ok(())
}

/// The bytes of an array of numbers borrowed from a payload in `order`, as
/// they are written in that order.
#[inline]
fn wire_bytes<'v>(value: &'v Value<'_>, order: Endianness) -> Option<&'v [u8]> {
    let (bytes, from) = match value {
        Value::U8s(v) => return Some(v),
        Value::I8s(v) => return Some(bytemuck::cast_slice(v)),
        Value::I16s(v) => v.wire()?,
        Value::U16s(v) => v.wire()?,
        Value::I32s(v) => v.wire()?,
        Value::U32s(v) => v.wire()?,
        Value::I64s(v) => v.wire()?,
        Value::U64s(v) => v.wire()?,
        Value::F32s(v) => v.wire()?,
        Value::F64s(v) => v.wire()?,
        _ => return None,
    };
    (from == order).then_some(bytes)
}

/// The container of a field as its check states it (single unless many).
fn check_container(check: Check) -> Container {
    match check {
        Check::Many { container, .. } => container,
        _ => Container::Single,
    }
}

/// Write a run's values, its slots' from the first on, into its zeroed
/// bytes `run` as its plan's [`Copies`] lay them: each group of one size in
/// a loop, an array in bulk. `false` if a value is missing, or is not a
/// number of its field's size or an array of numbers (which `Message::set`
/// rules out): then the run is written member by member.
#[inline]
fn store_copies<B: ByteOrder>(run: &mut [u8], copies: &Copies, values: &[Value<'_>]) -> bool {
    let Some(values) = values.get(..copies.count) else {
        return false;
    };
    macro_rules! copy {
        ($group:expr) => {
            for c in $group.iter() {
                let (Some(bits), Some(out)) = (
                    values.get(c.slot).and_then(|v| c.bits(v)),
                    run.get_mut(c.at..),
                ) else {
                    return false;
                };
                if !bits.write(out, B::LITTLE) {
                    return false;
                }
            }
        };
    }
    copy!(copies.ones);
    copy!(copies.twos);
    copy!(copies.fours);
    copy!(copies.eights);
    for &(slot, offset) in copies.arrays.iter() {
        let (Some(value), Some(place)) = (values.get(slot), run.get_mut(offset..)) else {
            return false;
        };
        if !store_array::<B>(place, value) {
            return false;
        }
    }
    true
}

/// Write an array of numbers from the start of `place` (its own aligned
/// start: no padding); `false` if it is not an array of numbers or does
/// not fit.
#[inline]
fn store_array<B: ByteOrder>(place: &mut [u8], value: &Value<'_>) -> bool {
    // Borrowed from a payload in this byte order (a decoded message
    // re-encoded): one copy, no writer.
    if let Some(wire) = wire_bytes(value, B::ENDIANNESS) {
        let Some(out) = place.get_mut(..wire.len()) else {
            return false;
        };
        out.copy_from_slice(wire);
        return true;
    }
    let mut w = Writer::<B>::new(place);
    let written = match value {
        Value::U8s(v) => u8::encode_slice(v, &mut w),
        Value::I8s(v) => i8::encode_slice(v, &mut w),
        Value::I16s(v) => v.encode(&mut w),
        Value::U16s(v) => v.encode(&mut w),
        Value::I32s(v) => v.encode(&mut w),
        Value::U32s(v) => v.encode(&mut w),
        Value::I64s(v) => v.encode(&mut w),
        Value::U64s(v) => v.encode(&mut w),
        Value::F32s(v) => v.encode(&mut w),
        Value::F64s(v) => v.encode(&mut w),
        _ => return false,
    };
    written.is_ok()
}

/// Write a member of a run into the run's zeroed bytes `run`, where the
/// plan lays it: a single number directly, an array as a message of its own
/// would write it (from its aligned start, so with no padding).
#[inline]
fn write_member<B: ByteOrder>(
    run: &mut [u8],
    m: &Member,
    value: &Value<'_>,
) -> Result<(), EncodeError> {
    // The plan sizes each run for its members: a value of its field's kind
    // always fits (`Message::set` keeps only such values).
    let available = run.len();
    let too_small = || {
        EncodeError::new(EncodeErrorKind::BufferTooSmall {
            needed: m.offset + 1,
            available,
        })
    };
    macro_rules! put {
        ($v:expr) => {{
            let bytes = if B::LITTLE {
                $v.to_le_bytes()
            } else {
                $v.to_be_bytes()
            };
            run.get_mut(m.offset..m.offset + bytes.len())
                .ok_or_else(too_small)?
                .copy_from_slice(&bytes);
        }};
    }
    match value {
        Value::Bool(v) => put!(u8::from(*v)),
        Value::U8(v) => put!(v),
        Value::I8(v) => put!(v),
        Value::I16(v) => put!(v),
        Value::U16(v) => put!(v),
        Value::I32(v) => put!(v),
        Value::U32(v) => put!(v),
        Value::I64(v) => put!(v),
        Value::U64(v) => put!(v),
        Value::F32(v) => put!(v),
        Value::F64(v) => put!(v),
        value => {
            let place = run.get_mut(m.offset..).ok_or_else(too_small)?;
            encode_value(&mut Writer::<B>::new(place), m.element, m.container, value)?;
        }
    }
    Ok(())
}

impl Messages<'_> {
    /// Where each message's values start.
    fn firsts(&self) -> impl Iterator<Item = usize> {
        let block = self.ty.inner.plans.get(self.index).map_or(0, |p| p.block);
        (0..self.len).map(move |k| k * block)
    }
}

/// The position after `value` at `start`; `counted` for a sequence, whose
/// elements follow a count (an array's do not).
fn value_end(value: &Value<'_>, start: usize, counted: bool) -> usize {
    let first = if counted {
        align_up(start, 4) + 4
    } else {
        start
    };
    fn elements<T: CdrEncode>(items: &[T], first: usize) -> usize {
        T::slice_encoded_end(items, first)
    }
    match value {
        Value::Bool(v) => v.encoded_end(start),
        Value::U8(v) => v.encoded_end(start),
        Value::I8(v) => v.encoded_end(start),
        Value::I16(v) => v.encoded_end(start),
        Value::U16(v) => v.encoded_end(start),
        Value::I32(v) => v.encoded_end(start),
        Value::U32(v) => v.encoded_end(start),
        Value::I64(v) => v.encoded_end(start),
        Value::U64(v) => v.encoded_end(start),
        Value::F32(v) => v.encoded_end(start),
        Value::F64(v) => v.encoded_end(start),
        Value::String(s) => string_end(start, s.len()),
        Value::WString(s) => wstring_end(start, s),
        Value::Message(m) => m.encoded_end(start),
        Value::Bools(v) => elements(v, first),
        Value::U8s(v) => elements(v, first),
        Value::I8s(v) => elements(v, first),
        Value::I16s(v) => v.encoded_end(first),
        Value::U16s(v) => v.encoded_end(first),
        Value::I32s(v) => v.encoded_end(first),
        Value::U32s(v) => v.encoded_end(first),
        Value::I64s(v) => v.encoded_end(first),
        Value::U64s(v) => v.encoded_end(first),
        Value::F32s(v) => v.encoded_end(first),
        Value::F64s(v) => v.encoded_end(first),
        Value::Strings(v) => strings_end(first, v),
        Value::WStrings(v) => v.iter().fold(first, |pos, s| wstring_end(pos, s)),
        Value::Messages(v) => v.firsts().fold(first, |pos, at| {
            struct_end(&v.ty, v.index, &v.slots, at, pos, &mut NoHoles)
        }),
    }
}

fn write_count<B: ByteOrder>(
    w: &mut Writer<'_, B>,
    container: Container,
    len: usize,
) -> Result<(), EncodeError> {
    match container {
        Container::Array(_) | Container::Single => Ok(()),
        Container::BoundedSequence(bound) if len > bound => {
            Err(EncodeError::new(EncodeErrorKind::BoundExceeded {
                len,
                bound,
            }))
        }
        Container::BoundedSequence(_) | Container::Sequence => w.write_len(len),
    }
}

fn encode_value<B: ByteOrder>(
    w: &mut Writer<'_, B>,
    element: Element,
    container: Container,
    value: &Value<'_>,
) -> Result<(), EncodeError> {
    if let Some(len) = value.len() {
        write_count(w, container, len)?;
    }
    let bound = match element {
        Element::String(b) | Element::WString(b) => b,
        _ => None,
    };
    let check_str = |len: usize| match bound {
        Some(bound) if len > bound => Err(EncodeError::new(EncodeErrorKind::BoundExceeded {
            len,
            bound,
        })),
        _ => Ok(()),
    };
    match value {
        Value::Bool(v) => v.encode(w),
        Value::U8(v) => v.encode(w),
        Value::I8(v) => v.encode(w),
        Value::I16(v) => v.encode(w),
        Value::U16(v) => v.encode(w),
        Value::I32(v) => v.encode(w),
        Value::U32(v) => v.encode(w),
        Value::I64(v) => v.encode(w),
        Value::U64(v) => v.encode(w),
        Value::F32(v) => v.encode(w),
        Value::F64(v) => v.encode(w),
        Value::String(s) => {
            check_str(s.len())?;
            write_string(w, s)
        }
        Value::WString(s) => write_wstring(w, s, bound),
        Value::Message(m) => m.encode(w),
        Value::Bools(v) => bool::encode_slice(v, w),
        Value::U8s(v) => u8::encode_slice(v, w),
        Value::I8s(v) => i8::encode_slice(v, w),
        Value::I16s(v) => v.encode(w),
        Value::U16s(v) => v.encode(w),
        Value::I32s(v) => v.encode(w),
        Value::U32s(v) => v.encode(w),
        Value::I64s(v) => v.encode(w),
        Value::U64s(v) => v.encode(w),
        Value::F32s(v) => v.encode(w),
        Value::F64s(v) => v.encode(w),
        Value::Strings(v) => {
            // Bounds first, then the whole run with one bounds check of the
            // output, as a generated sequence of strings is written.
            if bound.is_some() {
                v.iter().try_for_each(|s| check_str(s.len()))?;
            }
            write_strings(w, v)
        }
        Value::WStrings(v) => v.iter().try_for_each(|s| write_wstring(w, s, bound)),
        Value::Messages(v) => v
            .firsts()
            .try_for_each(|at| encode_struct(w, &v.ty, v.index, &v.slots, at, &mut NoHoles)),
    }
}
