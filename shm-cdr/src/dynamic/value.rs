//! Values of run-time types: a message is its type and one [`Value`] per field.

use std::borrow::Cow;
use std::fmt;

use super::limits::{MESSAGE_BYTES, VALUE_BYTES};
use super::model::DynamicType;
use super::numbers::Numbers;
use super::plan::StructPlan;
use super::structs::{Element, StructDef};
use crate::describe::Container;

/// The value of one field. Strings, byte and number arrays borrow from the
/// input they were decoded from where the generated types borrow (`'a`).
#[derive(Debug, Clone, PartialEq)]
#[allow(missing_docs)] // The variants are the ROS types they name.
pub enum Value<'a> {
    Bool(bool),
    /// `byte`, `char` and `uint8`.
    U8(u8),
    I8(i8),
    I16(i16),
    U16(u16),
    I32(i32),
    U32(u32),
    I64(i64),
    U64(u64),
    F32(f32),
    F64(f64),
    String(Cow<'a, str>),
    WString(String),
    /// A message nested by value, standalone: what
    /// [`Field::to_value`] and [`FieldView::read`](super::FieldView::read)
    /// give for one, and what [`Message::set`] takes. Inside a [`Message`]
    /// its values lie in their parent's, read through [`Field::Message`].
    Message(Box<Message<'a>>),
    Bools(Vec<bool>),
    /// Arrays and sequences of `byte`, `char` and `uint8`.
    U8s(Cow<'a, [u8]>),
    I8s(Cow<'a, [i8]>),
    /// Arrays and sequences of wider numbers: borrowed from the payload in
    /// its alignment and byte order, or owned.
    I16s(Numbers<'a, i16>),
    U16s(Numbers<'a, u16>),
    I32s(Numbers<'a, i32>),
    U32s(Numbers<'a, u32>),
    I64s(Numbers<'a, i64>),
    U64s(Numbers<'a, u64>),
    F32s(Numbers<'a, f32>),
    F64s(Numbers<'a, f64>),
    Strings(Vec<Cow<'a, str>>),
    WStrings(Vec<String>),
    /// An array or sequence of messages, their values in one table.
    Messages(Box<Messages<'a>>),
}

impl Value<'_> {
    /// The number of elements of an array or sequence value; `None` for a
    /// single one.
    pub fn len(&self) -> Option<usize> {
        Some(match self {
            Self::Bools(v) => v.len(),
            Self::U8s(v) => v.len(),
            Self::I8s(v) => v.len(),
            Self::I16s(v) => v.len(),
            Self::U16s(v) => v.len(),
            Self::I32s(v) => v.len(),
            Self::U32s(v) => v.len(),
            Self::I64s(v) => v.len(),
            Self::U64s(v) => v.len(),
            Self::F32s(v) => v.len(),
            Self::F64s(v) => v.len(),
            Self::Strings(v) => v.len(),
            Self::WStrings(v) => v.len(),
            Self::Messages(v) => v.len(),
            _ => return None,
        })
    }

    /// What kind of value this is, for messages (`int32`, `string[]`, …).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Self::Bool(_) => "bool",
            Self::U8(_) => "uint8",
            Self::I8(_) => "int8",
            Self::I16(_) => "int16",
            Self::U16(_) => "uint16",
            Self::I32(_) => "int32",
            Self::U32(_) => "uint32",
            Self::I64(_) => "int64",
            Self::U64(_) => "uint64",
            Self::F32(_) => "float32",
            Self::F64(_) => "float64",
            Self::String(_) => "string",
            Self::WString(_) => "wstring",
            Self::Message(_) => "message",
            Self::Bools(_) => "bool[]",
            Self::U8s(_) => "uint8[]",
            Self::I8s(_) => "int8[]",
            Self::I16s(_) => "int16[]",
            Self::U16s(_) => "uint16[]",
            Self::I32s(_) => "int32[]",
            Self::U32s(_) => "uint32[]",
            Self::I64s(_) => "int64[]",
            Self::U64s(_) => "uint64[]",
            Self::F32s(_) => "float32[]",
            Self::F64s(_) => "float64[]",
            Self::Strings(_) => "string[]",
            Self::WStrings(_) => "wstring[]",
            Self::Messages(_) => "message[]",
        }
    }

    /// Whether dropping the value frees nothing: a number, or a string or
    /// array borrowed from the payload.
    #[inline(always)]
    pub(crate) fn holds_nothing(&self) -> bool {
        match self {
            Self::Bool(_)
            | Self::U8(_)
            | Self::I8(_)
            | Self::I16(_)
            | Self::U16(_)
            | Self::I32(_)
            | Self::U32(_)
            | Self::I64(_)
            | Self::U64(_)
            | Self::F32(_)
            | Self::F64(_) => true,
            Self::String(s) => matches!(s, Cow::Borrowed(_)),
            Self::U8s(v) => matches!(v, Cow::Borrowed(_)),
            Self::I8s(v) => matches!(v, Cow::Borrowed(_)),
            Self::I16s(v) => v.wire().is_some(),
            Self::U16s(v) => v.wire().is_some(),
            Self::I32s(v) => v.wire().is_some(),
            Self::U32s(v) => v.wire().is_some(),
            Self::I64s(v) => v.wire().is_some(),
            Self::U64s(v) => v.wire().is_some(),
            Self::F32s(v) => v.wire().is_some(),
            Self::F64s(v) => v.wire().is_some(),
            Self::WString(_)
            | Self::Message(_)
            | Self::Bools(_)
            | Self::Strings(_)
            | Self::WStrings(_)
            | Self::Messages(_) => false,
        }
    }

    /// Whether an array or sequence value is empty (`false` for a single one).
    pub fn is_empty(&self) -> bool {
        self.len() == Some(0)
    }

    /// The value with everything it borrows copied.
    pub fn into_owned(self) -> Value<'static> {
        match self {
            Self::Bool(v) => Value::Bool(v),
            Self::U8(v) => Value::U8(v),
            Self::I8(v) => Value::I8(v),
            Self::I16(v) => Value::I16(v),
            Self::U16(v) => Value::U16(v),
            Self::I32(v) => Value::I32(v),
            Self::U32(v) => Value::U32(v),
            Self::I64(v) => Value::I64(v),
            Self::U64(v) => Value::U64(v),
            Self::F32(v) => Value::F32(v),
            Self::F64(v) => Value::F64(v),
            Self::String(v) => Value::String(Cow::Owned(v.into_owned())),
            Self::WString(v) => Value::WString(v),
            Self::Message(v) => Value::Message(Box::new(v.into_owned())),
            Self::Bools(v) => Value::Bools(v),
            Self::U8s(v) => Value::U8s(Cow::Owned(v.into_owned())),
            Self::I8s(v) => Value::I8s(Cow::Owned(v.into_owned())),
            Self::I16s(v) => Value::I16s(v.into_owned()),
            Self::U16s(v) => Value::U16s(v.into_owned()),
            Self::I32s(v) => Value::I32s(v.into_owned()),
            Self::U32s(v) => Value::U32s(v.into_owned()),
            Self::I64s(v) => Value::I64s(v.into_owned()),
            Self::U64s(v) => Value::U64s(v.into_owned()),
            Self::F32s(v) => Value::F32s(v.into_owned()),
            Self::F64s(v) => Value::F64s(v.into_owned()),
            Self::Strings(v) => {
                Value::Strings(v.into_iter().map(|s| Cow::Owned(s.into_owned())).collect())
            }
            Self::WStrings(v) => Value::WStrings(v),
            Self::Messages(v) => Value::Messages(Box::new(v.into_owned())),
        }
    }
}

/// The values of a [`Message`] or [`Messages`], in slot order.
///
/// Dropping a `Vec<Value>` calls a drop per value; a decoded message's
/// values mostly borrow from the payload and hold nothing to free, and those
/// calls were a third of the cost of decoding a small message. So a table
/// that decoding found to hold nothing says so (`plain`, cleared by any
/// change), and any other looks first, a compare per value, before it drops
/// them one by one.
#[derive(Clone, Default)]
pub(crate) struct Slots<'a> {
    values: Vec<Value<'a>>,
    /// Every value holds nothing to free (see [`Value::holds_nothing`]).
    plain: bool,
}

impl<'a> Slots<'a> {
    /// Values decoded from a payload; `plain` if decoding saw that none
    /// holds anything to free.
    pub(crate) fn decoded(values: Vec<Value<'a>>, plain: bool) -> Self {
        debug_assert!(!plain || values.iter().all(Value::holds_nothing));
        Self { values, plain }
    }

    /// The values, leaving the table empty.
    pub(crate) fn take(&mut self) -> Vec<Value<'a>> {
        std::mem::take(&mut self.values)
    }

    /// The values with everything they borrow copied.
    fn into_owned(mut self) -> Slots<'static> {
        Slots::from(
            self.take()
                .into_iter()
                .map(Value::into_owned)
                .collect::<Vec<_>>(),
        )
    }
}

impl<'a> From<Vec<Value<'a>>> for Slots<'a> {
    fn from(values: Vec<Value<'a>>) -> Self {
        Self {
            values,
            plain: false,
        }
    }
}

impl<'a> std::ops::Deref for Slots<'a> {
    type Target = Vec<Value<'a>>;

    fn deref(&self) -> &Vec<Value<'a>> {
        &self.values
    }
}

/// A change may put in a value that holds memory: the table is no longer
/// known to be plain.
impl std::ops::DerefMut for Slots<'_> {
    fn deref_mut(&mut self) -> &mut Self::Target {
        self.plain = false;
        &mut self.values
    }
}

/// Equal when they hold equal values.
impl PartialEq for Slots<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.values == other.values
    }
}

impl Drop for Slots<'_> {
    #[allow(unsafe_code)]
    fn drop(&mut self) {
        let len = self.values.len();
        let values = self.values.as_mut_ptr();
        // SAFETY: 0 is within the capacity. From here the `Vec` owns no
        // value, so if a value's drop below panics, the `Vec`'s own drop
        // (which frees the buffer after this) cannot drop one twice: the
        // values not yet dropped leak instead.
        unsafe { self.values.set_len(0) }
        if self.plain {
            // Decoding saw every value hold nothing (no heap memory, nothing
            // with a drop of its own) and every change clears `plain`: there
            // is nothing to drop.
            return;
        }
        for i in 0..len {
            // SAFETY: `i < len`, the number of initialized values the `Vec`
            // held; each is visited once and dropped at most once. A value
            // that holds nothing has a drop that does nothing: skipping it
            // only saves the call.
            let value = unsafe { &mut *values.add(i) };
            if !value.holds_nothing() {
                // SAFETY: `value` is initialized, dropped here once and never
                // used again (the `Vec`'s length is 0).
                unsafe { std::ptr::drop_in_place(value) }
            }
        }
    }
}

/// A message of a [`DynamicType`]: one value per field, each of its field's
/// kind. Made by [`DynamicType::decode`] or [`DynamicType::default_message`]
/// and changed with [`set`](Self::set), which keeps every value of its
/// field's kind; it encodes with [`crate::to_vec`] and the rest of the
/// encoding API, sized exactly.
///
/// The values of the messages it nests by value lie in its own table, each
/// nested message's in its place, and an array or sequence of messages is
/// one table of them all ([`Messages`]): decoding a message allocates once,
/// and once per such array, not once per message.
///
/// ```
/// use shm_cdr::dynamic::{DynamicType, Field, Value};
/// use shm_cdr::msgs::std_msgs::Header;
/// use shm_cdr::RosMessage;
///
/// let ty = DynamicType::from_description(&Header::full_description())?;
/// let mut header = ty.default_message();
/// header.set("frame_id", Value::String("map".into()))?;
/// let Some(Field::Message(stamp)) = header.get("stamp") else { unreachable!() };
/// assert_eq!(stamp.type_name(), "builtin_interfaces/msg/Time");
/// assert_eq!(stamp.value("sec"), Some(&Value::I32(0)));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, PartialEq)]
pub struct Message<'a> {
    pub(crate) ty: DynamicType,
    /// Which of the type's structs this is.
    pub(crate) index: usize,
    /// The values, one per field that is not a message nested by value,
    /// in field order with each nested message's values in its place.
    pub(crate) slots: Slots<'a>,
    /// The fields decoded cut short for printing
    /// ([`DynamicType::decode_truncated`]), with how many elements each
    /// holds on the wire: `(slot, length)`.
    pub(crate) cut: Vec<(usize, usize)>,
}

/// An array or sequence of messages of one type: the values of all of
/// them in one table, each message's block after the one before.
#[derive(Clone, PartialEq)]
pub struct Messages<'a> {
    pub(crate) ty: DynamicType,
    /// Which of the type's structs the elements are.
    pub(crate) index: usize,
    pub(crate) len: usize,
    pub(crate) slots: Slots<'a>,
    /// As [`Message`]'s, `(slot, length)` in `slots`.
    pub(crate) cut: Vec<(usize, usize)>,
}

/// A message inside a [`Message`] (itself, one it nests, or an element of
/// a [`Messages`]), borrowed.
#[derive(Clone, Copy)]
pub struct MessageRef<'m, 'a> {
    ty: &'m DynamicType,
    index: usize,
    /// The table the message lies in, and where its block starts.
    slots: &'m [Value<'a>],
    first: usize,
    cut: &'m [(usize, usize)],
}

/// One field of a message, borrowed: a value, or a message nested by value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Field<'m, 'a> {
    /// Any field that is not a message nested by value (an array or
    /// sequence of messages is a [`Value::Messages`]).
    Value(&'m Value<'a>),
    /// A message nested by value.
    Message(MessageRef<'m, 'a>),
}

impl<'a> Field<'_, 'a> {
    /// The field's value, standalone: a nested message's values copied
    /// into a [`Value::Message`] of its own.
    pub fn to_value(&self) -> Value<'a> {
        match self {
            Self::Value(value) => (*value).clone(),
            Self::Message(message) => Value::Message(Box::new(message.to_message())),
        }
    }

    /// The value, if the field is not a message nested by value.
    pub fn as_value(&self) -> Option<&Value<'a>> {
        match self {
            Self::Value(value) => Some(value),
            Self::Message(_) => None,
        }
    }
}

/// Equal messages are of one struct and hold equal values: their blocks,
/// which hold the values of the messages they nest by value too.
impl PartialEq for MessageRef<'_, '_> {
    fn eq(&self, other: &Self) -> bool {
        self.ty == other.ty && self.index == other.index && self.block() == other.block()
    }
}

impl fmt::Debug for Message<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.as_message_ref().fmt(f)
    }
}

impl fmt::Debug for MessageRef<'_, '_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut s = f.debug_struct(self.type_name());
        for (name, field) in self.fields() {
            match field {
                Field::Value(value) => s.field(name, value),
                Field::Message(message) => s.field(name, &message),
            };
        }
        s.finish()
    }
}

impl fmt::Debug for Messages<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// Why [`Message::set`] refused a value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ValueError {
    /// The message type.
    pub type_name: String,
    /// The field.
    pub field: String,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for ValueError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}: {}", self.type_name, self.field, self.reason)
    }
}

impl std::error::Error for ValueError {}

impl<'m, 'a> MessageRef<'m, 'a> {
    pub(crate) fn def(&self) -> &'m StructDef {
        &self.ty.inner.structs[self.index]
    }

    fn plan(&self) -> &'m StructPlan {
        &self.ty.inner.plans[self.index]
    }

    /// This message's own values.
    fn block(&self) -> &'m [Value<'a>] {
        let end = self.first.saturating_add(self.plan().block);
        self.slots.get(self.first..end).unwrap_or_default()
    }

    /// The message's type (`pkg/msg/Name`).
    pub fn type_name(&self) -> &'m str {
        &self.def().name
    }

    /// The run-time type the message is of (or nested in).
    pub fn ty(&self) -> &'m DynamicType {
        self.ty
    }

    /// Field `i`, in the type's field order.
    pub(crate) fn field(&self, i: usize) -> Option<Field<'m, 'a>> {
        let field = self.def().fields.get(i)?;
        let at = self.first + self.plan().offsets.get(i)?;
        Some(match (field.element, field.container) {
            (Element::Message(index), Container::Single) => Field::Message(MessageRef {
                index,
                first: at,
                ..*self
            }),
            _ => Field::Value(self.slots.get(at)?),
        })
    }

    /// The field names and values, in order.
    pub fn fields(&self) -> impl Iterator<Item = (&'m str, Field<'m, 'a>)> + use<'m, 'a> {
        let this = *self;
        let def = this.def();
        def.fields
            .iter()
            .enumerate()
            .filter_map(move |(i, f)| Some((f.name.as_str(), this.field(i)?)))
    }

    /// The field `name`.
    pub fn get(&self, name: &str) -> Option<Field<'m, 'a>> {
        self.field(self.def().field_index(name)?)
    }

    /// The value of field `name`, if it is not a message nested by value
    /// (that one is [`get`](Self::get)'s [`Field::Message`]).
    pub fn value(&self, name: &str) -> Option<&'m Value<'a>> {
        match self.get(name)? {
            Field::Value(value) => Some(value),
            Field::Message(_) => None,
        }
    }

    /// The message nested by value in field `name`.
    pub fn message(&self, name: &str) -> Option<MessageRef<'m, 'a>> {
        match self.get(name)? {
            Field::Message(message) => Some(message),
            Field::Value(_) => None,
        }
    }

    /// How many elements field `i` holds on the wire: its value's length, or
    /// for a field decoded cut short, the length it was cut from.
    pub(crate) fn wire_len(&self, i: usize) -> Option<usize> {
        let at = self.first + self.plan().offsets.get(i)?;
        match self.cut.iter().find(|(slot, _)| *slot == at) {
            Some((_, len)) => Some(*len),
            None => self.slots.get(at)?.len(),
        }
    }

    /// The message, standalone: its values copied into a [`Message`] of
    /// its own.
    pub fn to_message(&self) -> Message<'a> {
        let end = self.first.saturating_add(self.plan().block);
        Message {
            ty: self.ty.clone(),
            index: self.index,
            slots: Slots::from(self.block().to_vec()),
            cut: self
                .cut
                .iter()
                .filter(|(slot, _)| (self.first..end).contains(slot))
                .map(|&(slot, len)| (slot - self.first, len))
                .collect(),
        }
    }
}

impl<'a> Message<'a> {
    /// A message of struct `index` of `ty` from its values in slot order.
    pub(crate) fn from_slots(ty: DynamicType, index: usize, slots: impl Into<Slots<'a>>) -> Self {
        Self {
            ty,
            index,
            slots: slots.into(),
            cut: Vec::new(),
        }
    }

    /// The message, borrowed: what reads it.
    pub fn as_message_ref(&self) -> MessageRef<'_, 'a> {
        MessageRef {
            ty: &self.ty,
            index: self.index,
            slots: &self.slots,
            first: 0,
            cut: &self.cut,
        }
    }

    /// The message's type (a nested message's own type, for a field's value).
    pub fn type_name(&self) -> &str {
        &self.def().name
    }

    pub(crate) fn def(&self) -> &StructDef {
        &self.ty.inner.structs[self.index]
    }

    /// Whether this is a message of type `ty` itself (not one of the types
    /// it nests).
    pub fn is_of(&self, ty: &DynamicType) -> bool {
        self.index == 0 && self.ty == *ty
    }

    /// The field names and values, in order.
    pub fn fields(&self) -> impl Iterator<Item = (&str, Field<'_, 'a>)> {
        self.as_message_ref().fields()
    }

    /// The field `name`.
    pub fn get(&self, name: &str) -> Option<Field<'_, 'a>> {
        self.as_message_ref().get(name)
    }

    /// The value of field `name`, if it is not a message nested by value
    /// (that one is [`get`](Self::get)'s [`Field::Message`]).
    pub fn value(&self, name: &str) -> Option<&Value<'a>> {
        self.as_message_ref().value(name)
    }

    /// The message nested by value in field `name`.
    pub fn message(&self, name: &str) -> Option<MessageRef<'_, 'a>> {
        self.as_message_ref().message(name)
    }

    /// Set field `name` to `value`, if it is of the field's kind and within its
    /// bounds (an array's length, a sequence's or string's bound); nested
    /// messages must be of the field's type.
    pub fn set(&mut self, name: &str, value: Value<'a>) -> Result<(), ValueError> {
        self.set_path(&[name], value)
    }

    /// Set the field at `path`, the names of messages nested by value and
    /// then the field's own (`["header", "stamp", "sec"]`), as
    /// [`set`](Self::set) sets one of this message's: in its place, without
    /// copying the messages on the way.
    ///
    /// ```
    /// use shm_cdr::dynamic::{DynamicType, Value};
    /// use shm_cdr::msgs::geometry_msgs::PoseStamped;
    /// use shm_cdr::RosMessage;
    ///
    /// let ty = DynamicType::from_description(&PoseStamped::full_description())?;
    /// let mut pose = ty.default_message();
    /// pose.set_path(&["header", "stamp", "sec"], Value::I32(7))?;
    /// pose.set_path(&["pose", "position", "x"], Value::F64(1.5))?;
    /// let stamp = pose.message("header").and_then(|h| h.message("stamp"));
    /// assert_eq!(stamp.and_then(|s| s.value("sec")), Some(&Value::I32(7)));
    /// assert!(pose.set_path(&["header", "stamp", "sec"], Value::F64(1.0)).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn set_path(&mut self, path: &[&str], value: Value<'a>) -> Result<(), ValueError> {
        let Some((name, nested)) = path.split_last() else {
            return Err(ValueError {
                type_name: self.type_name().to_owned(),
                field: String::new(),
                reason: "no field named: give the path's names".into(),
            });
        };
        let structs = &self.ty.inner.structs;
        let (mut index, mut first) = (self.index, 0);
        for (depth, step) in nested.iter().enumerate() {
            let def = &structs[index];
            let field = def.field_index(step).map(|i| (i, &def.fields[i]));
            match field {
                Some((i, f)) if matches!(f.container, Container::Single) => match f.element {
                    Element::Message(inner) => {
                        first += self.ty.inner.plans[index]
                            .offsets
                            .get(i)
                            .copied()
                            .unwrap_or(0);
                        index = inner;
                    }
                    _ => {
                        return Err(ValueError {
                            type_name: def.name.clone(),
                            field: path[..=depth].join("."),
                            reason: "not a message nested by value".into(),
                        })
                    }
                },
                Some(_) => {
                    return Err(ValueError {
                        type_name: def.name.clone(),
                        field: path[..=depth].join("."),
                        reason: "not a message nested by value (an array: set it whole)".into(),
                    })
                }
                None => {
                    return Err(ValueError {
                        type_name: def.name.clone(),
                        field: path[..=depth].join("."),
                        reason: "no such field".into(),
                    })
                }
            }
        }
        let def = &structs[index];
        let error = |reason: String| ValueError {
            type_name: def.name.clone(),
            field: path.join("."),
            reason,
        };
        let i = def
            .field_index(name)
            .ok_or_else(|| error("no such field".into()))?;
        let field = &def.fields[i];
        check(&self.ty, field.element, field.container, &value).map_err(error)?;
        self.store_in(index, first, i, value);
        Ok(())
    }

    /// Put `value`, of field `i`'s kind, in field `i`: a nested message's
    /// values in its place.
    #[cfg(feature = "yaml")]
    pub(crate) fn store(&mut self, i: usize, value: Value<'a>) {
        self.store_in(self.index, 0, i, value)
    }

    /// [`store`](Self::store) into field `i` of the message of struct
    /// `index` nested by value whose values start at slot `first`.
    fn store_in(&mut self, index: usize, first: usize, i: usize, value: Value<'a>) {
        let Some(&at) = self.ty.inner.plans[index].offsets.get(i) else {
            return;
        };
        let at = first + at;
        match value {
            Value::Message(mut nested) => {
                let width = nested.slots.len();
                let end = at + width;
                self.cut.retain(|(slot, _)| !(at..end).contains(slot));
                self.cut
                    .extend(nested.cut.iter().map(|&(slot, len)| (slot + at, len)));
                let places = self.slots.get_mut(at..end).unwrap_or_default();
                for (place, value) in places.iter_mut().zip(nested.slots.take()) {
                    *place = value;
                }
            }
            value => {
                if let Some(place) = self.slots.get_mut(at) {
                    *place = value;
                }
                self.cut.retain(|(slot, _)| *slot != at);
            }
        }
    }

    /// The message with everything it borrows copied.
    pub fn into_owned(self) -> Message<'static> {
        Message {
            ty: self.ty,
            index: self.index,
            slots: self.slots.into_owned(),
            cut: self.cut,
        }
    }
}

impl<'a> Messages<'a> {
    /// Messages of struct `index` of `ty` from their values in slot order,
    /// one block after another.
    pub(crate) fn from_slots(
        ty: DynamicType,
        index: usize,
        len: usize,
        slots: impl Into<Slots<'a>>,
    ) -> Self {
        Self {
            ty,
            index,
            len,
            slots: slots.into(),
            cut: Vec::new(),
        }
    }

    fn block(&self) -> usize {
        self.ty.inner.plans[self.index].block
    }

    /// The messages' type (`pkg/msg/Name`).
    pub fn type_name(&self) -> &str {
        &self.ty.inner.structs[self.index].name
    }

    /// How many messages there are.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The message at `i`.
    pub fn get(&self, i: usize) -> Option<MessageRef<'_, 'a>> {
        (i < self.len).then(|| MessageRef {
            ty: &self.ty,
            index: self.index,
            slots: &self.slots,
            first: i * self.block(),
            cut: &self.cut,
        })
    }

    /// The messages, in order.
    pub fn iter(&self) -> impl Iterator<Item = MessageRef<'_, 'a>> {
        (0..self.len).filter_map(move |i| self.get(i))
    }

    /// A message of the elements' type with every field at its default, to
    /// fill and [`push`](Self::push).
    pub fn default_element(&self) -> Message<'static> {
        self.ty.default_struct(self.index)
    }

    /// Append `message`, if it is of the elements' type. (The field's
    /// bounds are checked when the whole is [set](Message::set).)
    ///
    /// ```
    /// use shm_cdr::dynamic::{DynamicType, Value};
    /// use shm_cdr::msgs::sensor_msgs::{PointCloud2, PointField};
    /// use shm_cdr::RosMessage;
    ///
    /// let ty = DynamicType::from_description(&PointCloud2::full_description())?;
    /// let mut cloud = ty.default_message();
    /// let Some(Value::Messages(fields)) = cloud.value("fields") else { unreachable!() };
    /// let mut fields = fields.clone();
    /// let mut x = fields.default_element();
    /// x.set("name", Value::String("x".into()))?;
    /// x.set("datatype", Value::U8(7))?;
    /// fields.push(x)?;
    /// cloud.set("fields", Value::Messages(fields))?;
    ///
    /// let expected = PointCloud2 {
    ///     fields: vec![PointField { name: "x".into(), datatype: 7, ..Default::default() }],
    ///     ..Default::default()
    /// };
    /// assert_eq!(shm_cdr::to_vec(&cloud)?, shm_cdr::to_vec(&expected)?);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn push(&mut self, mut message: Message<'a>) -> Result<(), ValueError> {
        if message.ty != self.ty || message.index != self.index {
            return Err(ValueError {
                type_name: self.type_name().to_owned(),
                field: String::new(),
                reason: format!(
                    "a {} is not an element of this sequence",
                    message.type_name()
                ),
            });
        }
        let base = self.slots.len();
        self.cut
            .extend(message.cut.iter().map(|&(slot, len)| (slot + base, len)));
        self.slots.extend(message.slots.take());
        self.len += 1;
        Ok(())
    }

    /// Remove every message.
    pub fn clear(&mut self) {
        self.slots.clear();
        self.cut.clear();
        self.len = 0;
    }

    /// The messages with everything they borrow copied.
    pub fn into_owned(self) -> Messages<'static> {
        Messages {
            ty: self.ty,
            index: self.index,
            len: self.len,
            slots: self.slots.into_owned(),
            cut: self.cut,
        }
    }
}

/// Whether `value` is a value of a field of `element` in `container`.
fn check(
    ty: &DynamicType,
    element: Element,
    container: Container,
    value: &Value<'_>,
) -> Result<(), String> {
    let nested_ok = |m: &Message<'_>, index: usize| m.ty == *ty && m.index == index;
    let elements_ok = |ms: &Messages<'_>, index: usize| ms.ty == *ty && ms.index == index;
    let kind_ok = match (container, element, value) {
        (Container::Single, Element::Bool, Value::Bool(_))
        | (Container::Single, Element::Byte | Element::Char | Element::U8, Value::U8(_))
        | (Container::Single, Element::I8, Value::I8(_))
        | (Container::Single, Element::I16, Value::I16(_))
        | (Container::Single, Element::U16, Value::U16(_))
        | (Container::Single, Element::I32, Value::I32(_))
        | (Container::Single, Element::U32, Value::U32(_))
        | (Container::Single, Element::I64, Value::I64(_))
        | (Container::Single, Element::U64, Value::U64(_))
        | (Container::Single, Element::F32, Value::F32(_))
        | (Container::Single, Element::F64, Value::F64(_))
        | (Container::Single, Element::String(_), Value::String(_))
        | (Container::Single, Element::WString(_), Value::WString(_)) => true,
        (Container::Single, Element::Message(index), Value::Message(m)) => nested_ok(m, index),
        (Container::Single, _, _) => false,
        (_, Element::Bool, Value::Bools(_))
        | (_, Element::Byte | Element::Char | Element::U8, Value::U8s(_))
        | (_, Element::I8, Value::I8s(_))
        | (_, Element::I16, Value::I16s(_))
        | (_, Element::U16, Value::U16s(_))
        | (_, Element::I32, Value::I32s(_))
        | (_, Element::U32, Value::U32s(_))
        | (_, Element::I64, Value::I64s(_))
        | (_, Element::U64, Value::U64s(_))
        | (_, Element::F32, Value::F32s(_))
        | (_, Element::F64, Value::F64s(_))
        | (_, Element::String(_), Value::Strings(_))
        | (_, Element::WString(_), Value::WStrings(_)) => true,
        (_, Element::Message(index), Value::Messages(ms)) => elements_ok(ms, index),
        _ => false,
    };
    if !kind_ok {
        return Err(format!(
            "a {} is not a value of this field's type",
            value.kind_name()
        ));
    }
    let len = value.len().unwrap_or(0);
    match container {
        Container::Array(n) if len != n => {
            return Err(format!("{len} elements for an array of {n}"))
        }
        Container::BoundedSequence(n) if len > n => {
            return Err(format!("{len} elements for a sequence of at most {n}"))
        }
        _ => {}
    }
    let within = |s: &str, bound: Option<usize>, utf16: bool| match bound {
        Some(bound) => {
            let n = if utf16 {
                s.encode_utf16().count()
            } else {
                s.len()
            };
            n <= bound
        }
        None => true,
    };
    let strings_ok = match (element, value) {
        (Element::String(b), Value::String(s)) => within(s, b, false),
        (Element::String(b), Value::Strings(v)) => v.iter().all(|s| within(s, b, false)),
        (Element::WString(b), Value::WString(s)) => within(s, b, true),
        (Element::WString(b), Value::WStrings(v)) => v.iter().all(|s| within(s, b, true)),
        _ => true,
    };
    if strings_ok {
        Ok(())
    } else {
        Err("a string is longer than the field's bound".into())
    }
}

// The memory a type's messages are counted in when it is built: never less
// than they take, and on 64-bit targets exactly.
const _: () = {
    let (value, message) = (size_of::<Value<'static>>(), size_of::<Message<'static>>());
    assert!(value <= VALUE_BYTES && message <= MESSAGE_BYTES);
    #[cfg(target_pointer_width = "64")]
    assert!(value == VALUE_BYTES && message == MESSAGE_BYTES);
};
