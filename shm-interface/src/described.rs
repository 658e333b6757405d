//! One field as a type description states it, whoever holds the description:
//! what the JSON, the hash and the `.msg` text are written from.

/// One field as a type description states it, whoever holds the description
/// (a compiled type's [`Field`], a `type_description_interfaces/Field`
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
    /// The default value as rosidl writes it ([`Field::default_value`]), or
    /// empty.
    pub default_value: &'a str,
}
