//! A checked view of a CDR payload of a run-time type: one pass checks the
//! whole payload as [`DynamicType::decode`] does and notes where each field
//! starts, in one table; fields are read when asked for. No value is built
//! and no nested message is allocated, so viewing a message costs about what
//! the generated borrowed decoder costs.

use std::cell::Cell;
use std::fmt;

use super::codec::{decode_string, read_len};
use super::model::{DynamicType, Types};
use super::plan::{bools_valid, Step};
use super::structs::{Check, Element, FieldDef, StructDef};
use super::value::{Message, Messages, Value};
use crate::decode::{CdrDecode, Reader};
use crate::describe::Container;
use crate::describe::PLACEHOLDER_MEMBER;
use crate::endian::{BigEndian, ByteOrder, Endianness, LittleEndian};
use crate::error::DecodeError;
use crate::wire::wstring::read_wstring;

/// Where one field of one message lies in the body, as the check found it.
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    /// A number, bool, string, or array or sequence of them: the body
    /// position to read it from (a sequence's after its count). An array or
    /// sequence of messages: how many there are.
    at: usize,
    /// A sequence of values: how many there are (an array's length is its
    /// type's). An array or sequence of messages: the slot of the first
    /// field of the first message; elements follow one another.
    aux: usize,
}

/// A payload of a [`DynamicType`], checked once in full and read field by
/// field: [`DynamicType::view`]. Everything [`DynamicType::decode`] refuses,
/// it refuses with the same error; what it reads is what `decode` gives.
///
/// ```
/// use shm_cdr::dynamic::{DynamicType, FieldView, Value};
/// use shm_cdr::msgs::sensor_msgs::{PointCloud2, PointField};
/// use shm_cdr::RosMessage;
///
/// let cloud = PointCloud2 {
///     fields: vec![PointField { name: "x".into(), offset: 0, datatype: 7, count: 1 }],
///     data: vec![0; 1 << 20],
///     ..Default::default()
/// };
/// let bytes = shm_cdr::to_vec(&cloud)?;
/// let ty = DynamicType::from_description(&PointCloud2::full_description())?;
///
/// let view = ty.view(&bytes)?;
/// let Some(FieldView::Messages(fields)) = view.get("fields") else { unreachable!() };
/// let first = fields.get(0).and_then(|f| f.get("name")).map(|n| n.read()).transpose()?;
/// assert_eq!(first, Some(Value::String("x".into())));
/// // The megabyte of points is borrowed from `bytes`, not copied.
/// let Some(Value::U8s(data)) = view.get("data").map(|d| d.read()).transpose()? else {
///     unreachable!()
/// };
/// assert!(matches!(data, std::borrow::Cow::Borrowed(_)));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct MessageView<'t, 'de> {
    ty: &'t DynamicType,
    types: &'t Types,
    body: &'de [u8],
    order: Endianness,
    shared: bool,
    slots: Vec<Slot>,
}

thread_local! {
    /// The table of the last view dropped on this thread, kept for the next
    /// view: a view that reads one message after another allocates nothing.
    static SPARE_SLOTS: Cell<Vec<Slot>> = const { Cell::new(Vec::new()) };
}

/// Tables above this many slots are freed, not kept.
const KEPT_SLOTS: usize = 1 << 12;

impl Drop for MessageView<'_, '_> {
    fn drop(&mut self) {
        if self.slots.capacity() <= KEPT_SLOTS {
            let mut slots = std::mem::take(&mut self.slots);
            slots.clear();
            // During thread teardown the spare may be gone: then it is freed.
            let _ = SPARE_SLOTS.try_with(|spare| spare.set(slots));
        }
    }
}

impl fmt::Debug for MessageView<'_, '_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MessageView")
            .field("type", &self.ty.name())
            .field("body_len", &self.body.len())
            .field("shared", &self.shared)
            .finish_non_exhaustive()
    }
}

/// One message inside a [`MessageView`]: the whole payload, or one it nests.
#[derive(Clone, Copy)]
pub struct StructView<'v, 'de> {
    view: &'v MessageView<'v, 'de>,
    index: usize,
    first: usize,
}

/// An array or sequence of nested messages inside a [`MessageView`].
#[derive(Clone, Copy)]
pub struct SequenceView<'v, 'de> {
    view: &'v MessageView<'v, 'de>,
    index: usize,
    first: usize,
    len: usize,
}

/// A field that is not a nested message, read with [`read`](Self::read).
#[derive(Clone, Copy)]
pub struct ValueView<'v, 'de> {
    view: &'v MessageView<'v, 'de>,
    field: &'v FieldDef,
    slot: Slot,
}

/// One field of a [`StructView`].
#[derive(Clone, Copy, Debug)]
pub enum FieldView<'v, 'de> {
    /// A number, string, or an array or sequence of them.
    Value(ValueView<'v, 'de>),
    /// A nested message.
    Message(StructView<'v, 'de>),
    /// An array or sequence of nested messages.
    Messages(SequenceView<'v, 'de>),
}

impl DynamicType {
    /// Check a CDR payload (encapsulation header included) as this type and
    /// view it: as [`decode`](Self::decode), without building the values.
    pub fn view<'t, 'de>(&'t self, bytes: &'de [u8]) -> Result<MessageView<'t, 'de>, DecodeError> {
        self.view_from(bytes, false)
    }

    /// [`view`](Self::view) for input other processes may write (shared
    /// memory): strings are copied before they are checked, when checked and
    /// when read.
    pub fn view_shared<'t, 'de>(
        &'t self,
        bytes: &'de [u8],
    ) -> Result<MessageView<'t, 'de>, DecodeError> {
        self.view_from(bytes, true)
    }

    fn view_from<'t, 'de>(
        &'t self,
        bytes: &'de [u8],
        shared: bool,
    ) -> Result<MessageView<'t, 'de>, DecodeError> {
        let order = crate::read_header(bytes)?;
        let body = bytes.get(4..).unwrap_or_default();
        let types = &*self.inner;
        let root = types.plans.first().map_or(0, |p| p.block);
        let mut slots = SPARE_SLOTS.with(Cell::take);
        if slots.capacity() == 0 {
            // Room for the root's slots and a few sequences of messages, so
            // that most views allocate once, and little.
            slots.reserve(root.min(1 << 12) + 32);
        }
        slots.resize(root, Slot::default());
        let mut checker = Checker { types, slots };
        match order {
            Endianness::Little => {
                checker.check_struct(&mut Reader::<LittleEndian>::at(body, 0, shared), 0, 0)?
            }
            Endianness::Big => {
                checker.check_struct(&mut Reader::<BigEndian>::at(body, 0, shared), 0, 0)?
            }
        }
        Ok(MessageView {
            ty: self,
            types,
            body,
            order,
            shared,
            slots: checker.slots,
        })
    }
}

/// The one pass of [`DynamicType::view`]: checks a payload step by step,
/// noting where each field lies.
struct Checker<'t> {
    types: &'t Types,
    slots: Vec<Slot>,
}

impl Checker<'_> {
    /// Check one message of struct `index` at the reader's position, noting
    /// its fields in `slots[first..]` (already made).
    fn check_struct<B: ByteOrder>(
        &mut self,
        r: &mut Reader<'_, B>,
        index: usize,
        first: usize,
    ) -> Result<(), DecodeError> {
        let types = self.types;
        let Some(plan) = types.plans.get(index) else {
            return Ok(());
        };
        for step in &plan.steps {
            match step {
                Step::Run {
                    align,
                    len,
                    members,
                    checks,
                    bools,
                    ..
                } => {
                    let at = r.position();
                    let fits = r
                        .read_aligned_bytes(*align, *len)
                        .is_ok_and(|bytes| !*bools || bools_valid(members, bytes));
                    if fits {
                        let start = r.position() - len;
                        // An array's length is its type's: only `at` is noted.
                        for m in members.iter() {
                            if let Some(slot) = self.slots.get_mut(first + m.slot) {
                                slot.at = start + m.offset;
                            }
                        }
                    } else {
                        // Field by field, for the error `decode` gives.
                        r.rewind(at);
                        for (m, &check) in members.iter().zip(checks.iter()) {
                            let slot = check_value(r, check)?;
                            if let Some(place) = self.slots.get_mut(first + m.slot) {
                                *place = slot;
                            }
                        }
                    }
                }
                &Step::String { slot, bound } => {
                    let at = check_string(r, bound)?;
                    if let Some(place) = self.slots.get_mut(first + slot) {
                        *place = Slot { at, aux: 1 };
                    }
                }
                &Step::Numbers {
                    slot,
                    container,
                    size,
                    check,
                } => {
                    let at = r.position();
                    // The count is checked against the input by `read_len`;
                    // an empty sequence is not aligned to, as `decode` reads it.
                    let fits = read_len(r, container, size).ok().and_then(|count| {
                        let first = r.position();
                        (count == 0 || r.read_aligned_bytes(size, count * size).is_ok()).then_some(
                            Slot {
                                at: first,
                                aux: count,
                            },
                        )
                    });
                    let value = match fits {
                        Some(value) => value,
                        None => {
                            r.rewind(at);
                            check_value(r, check)?
                        }
                    };
                    if let Some(place) = self.slots.get_mut(first + slot) {
                        *place = value;
                    }
                }
                &Step::Value { slot, check, .. } => {
                    let value = check_value(r, check)?;
                    if let Some(place) = self.slots.get_mut(first + slot) {
                        *place = value;
                    }
                }
                &Step::Nested { first: at, index } => {
                    self.check_struct(r, index, first + at)?;
                }
                &Step::Messages {
                    slot,
                    index,
                    container,
                    min,
                } => {
                    let count = read_len(r, container, min)?;
                    let width = types.plans.get(index).map_or(0, |p| p.block);
                    // The count was checked against the input: so many fit.
                    let child = self.slots.len();
                    self.slots
                        .resize(child + count.saturating_mul(width), Slot::default());
                    if let Some(place) = self.slots.get_mut(first + slot) {
                        *place = Slot {
                            at: count,
                            aux: child,
                        };
                    }
                    for k in 0..count {
                        self.check_struct(r, index, child + k * width)?;
                    }
                }
            }
        }
        Ok(())
    }
}

/// Check a string as [`decode_string`] reads it, without building it, and
/// give where it starts. Input other processes write, and any fault, go
/// through `decode_string` itself: it copies what it checks, and its error
/// is the one `decode` gives.
#[inline(always)]
fn check_string<B: ByteOrder>(
    r: &mut Reader<'_, B>,
    bound: Option<usize>,
) -> Result<usize, DecodeError> {
    let at = r.position();
    if !r.is_shared() {
        if let Ok(bytes) = r.read_count(1).and_then(|n| r.read_bytes(n)) {
            let contents = match bytes.split_last() {
                None => Some(&[][..]),
                Some((0, contents)) => Some(contents),
                Some(_) => None,
            };
            if let Some(contents) = contents {
                let within = match bound {
                    Some(bound) => contents.len() <= bound,
                    None => true,
                };
                if within && (contents.is_ascii() || std::str::from_utf8(contents).is_ok()) {
                    return Ok(at);
                }
            }
        }
        r.rewind(at);
    }
    decode_string(r, bound)?;
    Ok(at)
}

/// Check one field that is not a message as `decode` reads it, and note
/// where it lies.
fn check_value<B: ByteOrder>(r: &mut Reader<'_, B>, check: Check) -> Result<Slot, DecodeError> {
    let at = r.position();
    match check {
        Check::Number(size) => {
            r.read_aligned_bytes(size, size)?;
        }
        Check::Bool => {
            bool::decode(r)?;
        }
        Check::String(bound) => {
            check_string(r, bound)?;
        }
        Check::WString(bound) => {
            read_wstring(r, bound)?;
        }
        Check::Many {
            element,
            container,
            min,
        } => {
            let count = read_len(r, container, min)?;
            let at = r.position();
            skip_elements(r, element, count)?;
            return Ok(Slot { at, aux: count });
        }
        // Messages are steps of their own.
        Check::Message { .. } => {}
    }
    Ok(Slot { at, aux: 1 })
}

/// Check `n` elements without keeping them: the readers `decode` uses, so
/// alignment, bounds and validity are checked alike.
fn skip_elements<B: ByteOrder>(
    r: &mut Reader<'_, B>,
    element: Element,
    n: usize,
) -> Result<(), DecodeError> {
    match element {
        Element::Bool => bool::decode_vec(r, n).map(drop),
        Element::Byte | Element::Char | Element::U8 => u8::decode_cow_slice(r, n).map(drop),
        Element::I8 => i8::decode_cow_slice(r, n).map(drop),
        Element::I16 => i16::decode_cow_slice(r, n).map(drop),
        Element::U16 => u16::decode_cow_slice(r, n).map(drop),
        Element::I32 => i32::decode_cow_slice(r, n).map(drop),
        Element::U32 => u32::decode_cow_slice(r, n).map(drop),
        Element::I64 => i64::decode_cow_slice(r, n).map(drop),
        Element::U64 => u64::decode_cow_slice(r, n).map(drop),
        Element::F32 => f32::decode_cow_slice(r, n).map(drop),
        Element::F64 => f64::decode_cow_slice(r, n).map(drop),
        Element::String(bound) => (0..n).try_for_each(|_| decode_string(r, bound).map(drop)),
        Element::WString(bound) => (0..n).try_for_each(|_| read_wstring(r, bound).map(drop)),
        Element::Message(_) => Ok(()),
    }
}

impl<'t, 'de> MessageView<'t, 'de> {
    /// The type viewed.
    pub fn ty(&self) -> &'t DynamicType {
        self.ty
    }

    /// The payload's message itself.
    pub fn root(&self) -> StructView<'_, 'de> {
        StructView {
            view: self,
            index: 0,
            first: 0,
        }
    }

    /// The field `name` of the payload's message.
    pub fn get(&self, name: &str) -> Option<FieldView<'_, 'de>> {
        self.root().get(name)
    }

    /// Every field of the payload's message, in order, with its name.
    pub fn fields(&self) -> impl Iterator<Item = (&str, FieldView<'_, 'de>)> {
        self.root().fields()
    }

    /// The whole message, built: what [`DynamicType::decode`] gives.
    pub fn to_message(&self) -> Result<Message<'de>, DecodeError> {
        self.root().to_message()
    }
}

impl<'v, 'de> StructView<'v, 'de> {
    fn def(&self) -> &'v StructDef {
        &self.view.types.structs[self.index]
    }

    /// The message's type name (`pkg/msg/Name`).
    pub fn type_name(&self) -> &'v str {
        &self.def().name
    }

    /// The field `name`, if the message has one.
    pub fn get(&self, name: &str) -> Option<FieldView<'v, 'de>> {
        let def = self.def();
        def.field_index(name).and_then(|i| self.field(def, i))
    }

    /// Every field, in order, with its name.
    pub fn fields(&self) -> impl Iterator<Item = (&'v str, FieldView<'v, 'de>)> + 'v {
        let this = *self;
        let def = this.def();
        def.fields
            .iter()
            .enumerate()
            .filter_map(move |(i, field)| Some((field.name.as_str(), this.field(def, i)?)))
    }

    fn field(&self, def: &'v StructDef, i: usize) -> Option<FieldView<'v, 'de>> {
        let field = def.fields.get(i)?;
        let at = self.first + self.view.types.plans.get(self.index)?.offsets.get(i)?;
        if let (Element::Message(index), Container::Single) = (field.element, field.container) {
            return Some(FieldView::Message(StructView {
                view: self.view,
                index,
                first: at,
            }));
        }
        let slot = *self.view.slots.get(at)?;
        Some(match (field.element, field.container) {
            (Element::Message(index), _) => FieldView::Messages(SequenceView {
                view: self.view,
                index,
                first: slot.aux,
                len: slot.at,
            }),
            _ => FieldView::Value(ValueView {
                view: self.view,
                field,
                slot,
            }),
        })
    }

    /// This message, built: what [`DynamicType::decode`] gives for it.
    pub fn to_message(&self) -> Result<Message<'de>, DecodeError> {
        let mut slots =
            Vec::with_capacity(self.view.types.plans.get(self.index).map_or(0, |p| p.block));
        self.push_slots(&mut slots)?;
        Ok(Message::from_slots(self.view.ty.clone(), self.index, slots))
    }

    /// Push this message's values onto `slots`, in slot order.
    fn push_slots(&self, slots: &mut Vec<Value<'de>>) -> Result<(), DecodeError> {
        for (_, field) in self.fields() {
            match field {
                FieldView::Message(nested) => nested.push_slots(slots)?,
                FieldView::Messages(nested) => slots.push(nested.read()?),
                FieldView::Value(value) => slots.push(value.read()?),
            }
        }
        Ok(())
    }
}

impl<'v, 'de> SequenceView<'v, 'de> {
    /// How many messages there are.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The message at `i`.
    pub fn get(&self, i: usize) -> Option<StructView<'v, 'de>> {
        (i < self.len).then(|| StructView {
            view: self.view,
            index: self.index,
            first: self.first + i * self.view.types.plans[self.index].block,
        })
    }

    /// The messages, in order.
    pub fn iter(&self) -> impl Iterator<Item = StructView<'v, 'de>> + 'v {
        let this = *self;
        (0..this.len).filter_map(move |i| this.get(i))
    }
}

impl<'de> ValueView<'_, 'de> {
    /// The field's value, borrowed from the input where
    /// [`DynamicType::decode`] borrows. The payload was checked when viewed:
    /// this fails only where input other processes write
    /// ([`DynamicType::view_shared`]) changed since.
    pub fn read(&self) -> Result<Value<'de>, DecodeError> {
        match self.view.order {
            Endianness::Little => self.read_as::<LittleEndian>(),
            Endianness::Big => self.read_as::<BigEndian>(),
        }
    }

    fn read_as<B: ByteOrder>(&self) -> Result<Value<'de>, DecodeError> {
        let view = self.view;
        if self.field.name == PLACEHOLDER_MEMBER {
            // rosidl's placeholder member reads as 0, as `decode` reads it.
            return Ok(Value::U8(0));
        }
        let mut r = Reader::<B>::at(view.body, self.slot.at, view.shared);
        match self.field.container {
            Container::Single => view.ty.decode_single(&mut r, self.field.element),
            Container::Array(n) => view.ty.decode_elements(&mut r, self.field.element, n),
            _ => view
                .ty
                .decode_elements(&mut r, self.field.element, self.slot.aux),
        }
    }
}

impl<'de> SequenceView<'_, 'de> {
    /// The messages, built: what [`DynamicType::decode`] gives for them.
    pub fn read(&self) -> Result<Value<'de>, DecodeError> {
        let block = self.view.types.plans.get(self.index).map_or(0, |p| p.block);
        let mut slots = Vec::with_capacity(self.len.saturating_mul(block).min(1 << 12));
        for message in self.iter() {
            message.push_slots(&mut slots)?;
        }
        Ok(Value::Messages(Box::new(Messages::from_slots(
            self.view.ty.clone(),
            self.index,
            self.len,
            slots,
        ))))
    }
}

impl<'de> FieldView<'_, 'de> {
    /// The field's value, nested messages built: what
    /// [`DynamicType::decode`] gives for it.
    pub fn read(&self) -> Result<Value<'de>, DecodeError> {
        match self {
            Self::Value(value) => value.read(),
            Self::Message(message) => message.to_message().map(|m| Value::Message(Box::new(m))),
            Self::Messages(messages) => messages.read(),
        }
    }
}

impl fmt::Debug for StructView<'_, '_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut s = f.debug_struct(self.type_name());
        for (name, field) in self.fields() {
            s.field(name, &field);
        }
        s.finish()
    }
}

impl fmt::Debug for SequenceView<'_, '_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl fmt::Debug for ValueView<'_, '_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.read() {
            Ok(value) => value.fmt(f),
            Err(e) => write!(f, "<{e}>"),
        }
    }
}
