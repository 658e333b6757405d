//! A checked view of a CDR payload of a run-time type: one pass checks the
//! whole payload as [`DynamicType::decode`] does and notes where each field
//! starts, in one table; fields are read when asked for. No value is built
//! and no nested message is allocated, so viewing a message costs about what
//! the generated borrowed decoder costs.

use std::fmt;

use super::codec::EMPTY_MESSAGE_MEMBER;
use super::model::{Check, DynamicType, Element, FieldDef, StructDef};
use super::value::{Message, Value};
use crate::decode::{CdrDecode, Reader};
use crate::describe::Container;
use crate::endian::{BigEndian, ByteOrder, Endianness, LittleEndian};
use crate::error::DecodeError;
use crate::wire::wstring::read_wstring;

/// Where one field of one message lies in the body.
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    /// The body position to read the field from: before its alignment, after
    /// a sequence's count.
    at: usize,
    /// The number of elements of an array or sequence (1 for a single field).
    count: usize,
    /// For a nested message, or an array or sequence of them, the slot of the
    /// first field of the first element; elements follow one another.
    child: usize,
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
pub struct MessageView<'de> {
    ty: DynamicType,
    body: &'de [u8],
    order: Endianness,
    shared: bool,
    slots: Vec<Slot>,
}

impl fmt::Debug for MessageView<'_> {
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
    view: &'v MessageView<'de>,
    index: usize,
    first: usize,
}

/// An array or sequence of nested messages inside a [`MessageView`].
#[derive(Clone, Copy)]
pub struct SequenceView<'v, 'de> {
    view: &'v MessageView<'de>,
    index: usize,
    first: usize,
    len: usize,
}

/// A field that is not a nested message, read with [`read`](Self::read).
#[derive(Clone, Copy)]
pub struct ValueView<'v, 'de> {
    view: &'v MessageView<'de>,
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
    pub fn view<'de>(&self, bytes: &'de [u8]) -> Result<MessageView<'de>, DecodeError> {
        self.view_from(bytes, false)
    }

    /// [`view`](Self::view) for input other processes may write (shared
    /// memory): strings are copied before they are checked, when checked and
    /// when read.
    pub fn view_shared<'de>(&self, bytes: &'de [u8]) -> Result<MessageView<'de>, DecodeError> {
        self.view_from(bytes, true)
    }

    fn view_from<'de>(
        &self,
        bytes: &'de [u8],
        shared: bool,
    ) -> Result<MessageView<'de>, DecodeError> {
        let order = crate::read_header(bytes)?;
        let body = bytes.get(4..).unwrap_or_default();
        let mut view = MessageView {
            ty: self.clone(),
            body,
            order,
            shared,
            slots: Vec::new(),
        };
        let root = self.inner.structs[0].fields.len();
        // Room for a message whose sequences are short, so that most views
        // allocate once.
        let least = self.inner.least_slots.first().copied().unwrap_or(root);
        view.slots.reserve(least.min(1 << 12) + 32);
        view.slots.resize(root, Slot::default());
        match order {
            Endianness::Little => {
                let mut r = Reader::<LittleEndian>::at(body, 0, shared);
                self.check_struct(&mut r, 0, 0, &mut view.slots)?;
            }
            Endianness::Big => {
                let mut r = Reader::<BigEndian>::at(body, 0, shared);
                self.check_struct(&mut r, 0, 0, &mut view.slots)?;
            }
        }
        Ok(view)
    }

    /// Check one message of struct `index` at the reader's position, noting
    /// its fields in `slots[first..]` (already made).
    fn check_struct<B: ByteOrder>(
        &self,
        r: &mut Reader<'_, B>,
        index: usize,
        first: usize,
        slots: &mut Vec<Slot>,
    ) -> Result<(), DecodeError> {
        let types = &*self.inner;
        let Some(checks) = types.checks.get(index) else {
            return Ok(());
        };
        for (i, check) in checks.iter().enumerate() {
            let mut slot = Slot {
                at: r.position(),
                count: 1,
                child: 0,
            };
            match *check {
                Check::Number(size) => {
                    r.read_aligned_bytes(size, size)?;
                }
                Check::Bool => {
                    bool::decode(r)?;
                }
                Check::String(bound) => {
                    super::codec::decode_string(r, bound)?;
                }
                Check::WString(bound) => {
                    read_wstring(r, bound)?;
                }
                Check::Message { index, width } => {
                    slot.child = slots.len();
                    slots.resize(slot.child + width, Slot::default());
                    self.check_struct(r, index, slot.child, slots)?;
                }
                Check::Many {
                    element,
                    container,
                    min,
                } => {
                    let count = super::codec::read_len(r, container, min)?;
                    slot.at = r.position();
                    slot.count = count;
                    if let Element::Message(nested) = element {
                        // The count was checked against the input: so many fit.
                        let width = types.structs.get(nested).map_or(0, |s| s.fields.len());
                        slot.child = slots.len();
                        slots.resize(slot.child + count.saturating_mul(width), Slot::default());
                        for k in 0..count {
                            self.check_struct(r, nested, slot.child + k * width, slots)?;
                        }
                    } else {
                        skip_elements(r, element, count)?;
                    }
                }
            }
            if let Some(place) = slots.get_mut(first + i) {
                *place = slot;
            }
        }
        Ok(())
    }
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
        Element::String(bound) => {
            (0..n).try_for_each(|_| super::codec::decode_string(r, bound).map(drop))
        }
        Element::WString(bound) => (0..n).try_for_each(|_| read_wstring(r, bound).map(drop)),
        Element::Message(_) => Ok(()),
    }
}

impl<'de> MessageView<'de> {
    /// The type viewed.
    pub fn ty(&self) -> &DynamicType {
        &self.ty
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
        &self.view.ty.inner.structs[self.index]
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
        let slot = *self.view.slots.get(self.first + i)?;
        Some(match (field.element, field.container) {
            (Element::Message(index), Container::Single) => FieldView::Message(StructView {
                view: self.view,
                index,
                first: slot.child,
            }),
            (Element::Message(index), _) => FieldView::Messages(SequenceView {
                view: self.view,
                index,
                first: slot.child,
                len: slot.count,
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
        let values = self
            .fields()
            .map(|(_, field)| field.read())
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Message {
            ty: self.view.ty.clone(),
            index: self.index,
            values,
        })
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
            first: self.first + i * self.view.ty.inner.structs[self.index].fields.len(),
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
        if self.field.name == EMPTY_MESSAGE_MEMBER {
            // rosidl's placeholder member reads as 0, as `decode` reads it.
            return Ok(Value::U8(0));
        }
        let mut r = Reader::<B>::at(view.body, self.slot.at, view.shared);
        match self.field.container {
            Container::Single => view.ty.decode_single(&mut r, self.field.element),
            _ => view
                .ty
                .decode_elements(&mut r, self.field.element, self.slot.count),
        }
    }
}

impl<'de> FieldView<'_, 'de> {
    /// The field's value, nested messages built: what
    /// [`DynamicType::decode`] gives for it.
    pub fn read(&self) -> Result<Value<'de>, DecodeError> {
        match self {
            Self::Value(value) => value.read(),
            Self::Message(message) => message.to_message().map(Value::Message),
            Self::Messages(messages) => messages
                .iter()
                .map(|m| m.to_message())
                .collect::<Result<_, _>>()
                .map(Value::Messages),
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
