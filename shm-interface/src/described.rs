//! One field as a type description states it, whoever holds the description:
//! what the JSON, the hash and the `.msg` text are written from.

/// One field as a type description states it, whoever holds the description
/// (a compiled type's [`Field`](crate::Field), a `type_description_interfaces/Field`
/// message, a type built at run time): what the JSON, the hash and the `.msg`
/// text are written from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DescribedField<'a> {
    /// The field's name.
    pub name: &'a str,
    /// Its numeric type ([`crate::type_id`]).
    pub type_id: u8,
    /// The array size or sequence bound, else 0.
    pub capacity: u64,
    /// The bound of a bounded (w)string element, else 0.
    pub string_capacity: u64,
    /// The `pkg/msg/Name` of a nested message element, else empty.
    pub nested_type_name: &'a str,
    /// The default value as rosidl writes it ([`Field::default_value`](crate::Field::default_value)), or
    /// empty.
    pub default_value: &'a str,
}

/// A [`DescribedField`] that owns its text: a field described at run time
/// (from an interface file, a recording, a node), kept until the type is
/// built from it.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct DescribedFieldBuf {
    /// The field's name.
    pub name: String,
    /// Its numeric type ([`crate::type_id`]).
    pub type_id: u8,
    /// The array size or sequence bound, else 0.
    pub capacity: u64,
    /// The bound of a bounded (w)string element, else 0.
    pub string_capacity: u64,
    /// The `pkg/msg/Name` of a nested message element, else empty.
    pub nested_type_name: String,
    /// The default value as rosidl writes it, or empty.
    pub default_value: String,
}

impl DescribedFieldBuf {
    /// The field, borrowed.
    pub fn as_described(&self) -> DescribedField<'_> {
        DescribedField {
            name: &self.name,
            type_id: self.type_id,
            capacity: self.capacity,
            string_capacity: self.string_capacity,
            nested_type_name: &self.nested_type_name,
            default_value: &self.default_value,
        }
    }
}

impl From<DescribedField<'_>> for DescribedFieldBuf {
    fn from(field: DescribedField<'_>) -> Self {
        Self {
            name: field.name.to_owned(),
            type_id: field.type_id,
            capacity: field.capacity,
            string_capacity: field.string_capacity,
            nested_type_name: field.nested_type_name.to_owned(),
            default_value: field.default_value.to_owned(),
        }
    }
}
