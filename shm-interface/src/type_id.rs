//! How `type_description_interfaces/FieldType` numbers a field's type: an
//! element kind from 1 to 48, plus 48 for each container kind after a single
//! value (array, bounded sequence, sequence). The one definition of that
//! numbering: everything that writes or reads a `type_id` goes through here.

/// The element kind of a field, as numbered by `type_description_interfaces/FieldType`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
#[allow(missing_docs)] // The variant names are the rosidl names.
pub enum TypeId {
    Nested = 1,
    Int8 = 2,
    Uint8 = 3,
    Int16 = 4,
    Uint16 = 5,
    Int32 = 6,
    Uint32 = 7,
    Int64 = 8,
    Uint64 = 9,
    Float32 = 10,
    Float64 = 11,
    /// IDL `char` (not .msg `char`, which is `Uint8`).
    Char = 13,
    WChar = 14,
    Boolean = 15,
    /// .msg `byte`, IDL `octet`.
    Byte = 16,
    String = 17,
    WString = 18,
    BoundedString = 21,
    BoundedWString = 22,
}

/// Element ids rosidl numbers that no ROS 2 message carries over CDR here:
/// `long double` (12), and IDL's fixed-size strings (19, 20).
const UNMAPPED: [(u8, &str); 3] = [
    (12, "long double (type_id 12) has no CDR mapping in ROS 2"),
    (19, "fixed-size strings (IDL) are not supported"),
    (20, "fixed-size strings (IDL) are not supported"),
];

impl TypeId {
    /// Every element kind, in the order of their ids.
    pub const ALL: [TypeId; 19] = [
        Self::Nested,
        Self::Int8,
        Self::Uint8,
        Self::Int16,
        Self::Uint16,
        Self::Int32,
        Self::Uint32,
        Self::Int64,
        Self::Uint64,
        Self::Float32,
        Self::Float64,
        Self::Char,
        Self::WChar,
        Self::Boolean,
        Self::Byte,
        Self::String,
        Self::WString,
        Self::BoundedString,
        Self::BoundedWString,
    ];

    /// The element kind numbered `id` (1 to 48, without a container's
    /// offset), or why there is none.
    pub fn from_element_id(id: u8) -> Result<Self, String> {
        if let Some(kind) = Self::ALL.into_iter().find(|kind| *kind as u8 == id) {
            return Ok(kind);
        }
        match UNMAPPED.iter().find(|(unmapped, _)| *unmapped == id) {
            Some((_, why)) => Err((*why).to_owned()),
            None => Err(format!("unknown element type_id {id}")),
        }
    }

    /// The element's name in a `.msg` file (`int8`, `float64`, `string`,
    /// `bool`, …); empty for a nested message, whose name is its type's.
    pub const fn msg_name(self) -> &'static str {
        match self {
            Self::Nested => "",
            Self::Int8 => "int8",
            Self::Uint8 => "uint8",
            Self::Int16 => "int16",
            Self::Uint16 => "uint16",
            Self::Int32 => "int32",
            Self::Uint32 => "uint32",
            Self::Int64 => "int64",
            Self::Uint64 => "uint64",
            Self::Float32 => "float32",
            Self::Float64 => "float64",
            Self::Char => "char",
            Self::WChar => "wchar",
            Self::Boolean => "bool",
            Self::Byte => "byte",
            Self::String | Self::BoundedString => "string",
            Self::WString | Self::BoundedWString => "wstring",
        }
    }

    /// Whether the element is text (a string or wstring, bounded or not).
    pub const fn is_text(self) -> bool {
        matches!(
            self,
            Self::String | Self::WString | Self::BoundedString | Self::BoundedWString
        )
    }
}

/// How a field holds its elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Container {
    /// One element.
    Single,
    /// A fixed array of this many elements.
    Array(usize),
    /// A sequence of at most this many elements.
    BoundedSequence(usize),
    /// A sequence of any length.
    Sequence,
}

/// The kind of a [`Container`] without its size: what a `type_id` says of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ContainerKind {
    /// One element.
    Single,
    /// A fixed array; its size is the description's `capacity`.
    Array,
    /// A bounded sequence; its bound is the description's `capacity`.
    BoundedSequence,
    /// A sequence of any length.
    Sequence,
}

/// How far apart the id ranges of the container kinds are.
const CONTAINER_STRIDE: u8 = 48;

impl ContainerKind {
    /// The kinds in the order of their id ranges.
    const ALL: [ContainerKind; 4] = [
        Self::Single,
        Self::Array,
        Self::BoundedSequence,
        Self::Sequence,
    ];

    /// What the kind adds to an element's id.
    pub const fn offset(self) -> u8 {
        CONTAINER_STRIDE
            * match self {
                Self::Single => 0,
                Self::Array => 1,
                Self::BoundedSequence => 2,
                Self::Sequence => 3,
            }
    }

    /// The container of this kind with `capacity` (an array's size or a
    /// bounded sequence's bound; unused by the other kinds).
    pub const fn with_capacity(self, capacity: usize) -> Container {
        match self {
            Self::Single => Container::Single,
            Self::Array => Container::Array(capacity),
            Self::BoundedSequence => Container::BoundedSequence(capacity),
            Self::Sequence => Container::Sequence,
        }
    }
}

impl Container {
    /// Its kind, without its size.
    pub const fn kind(self) -> ContainerKind {
        match self {
            Self::Single => ContainerKind::Single,
            Self::Array(_) => ContainerKind::Array,
            Self::BoundedSequence(_) => ContainerKind::BoundedSequence,
            Self::Sequence => ContainerKind::Sequence,
        }
    }

    /// The array size or sequence bound, else 0: the description's
    /// `capacity`.
    pub const fn capacity(self) -> usize {
        match self {
            Self::Array(n) | Self::BoundedSequence(n) => n,
            Self::Single | Self::Sequence => 0,
        }
    }
}

/// The numeric `type_id` of `element` held by `container`.
pub const fn type_id(element: TypeId, container: ContainerKind) -> u8 {
    element as u8 + container.offset()
}

/// A numeric `type_id` split into its element id (1 to 48) and container
/// kind; `None` for 0 (not set) and for ids past the last range.
pub const fn split_type_id(type_id: u8) -> Option<(u8, ContainerKind)> {
    if type_id == 0 {
        return None;
    }
    let range = ((type_id - 1) / CONTAINER_STRIDE) as usize;
    if range >= ContainerKind::ALL.len() {
        return None;
    }
    Some((
        (type_id - 1) % CONTAINER_STRIDE + 1,
        ContainerKind::ALL[range],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_id_splits_into_what_made_it() {
        for element in TypeId::ALL {
            for container in ContainerKind::ALL {
                let id = type_id(element, container);
                assert_eq!(split_type_id(id), Some((element as u8, container)));
                assert_eq!(TypeId::from_element_id(element as u8), Ok(element));
            }
        }
    }

    #[test]
    fn ids_outside_the_numbering_have_no_kind() {
        assert_eq!(split_type_id(0), None);
        assert_eq!(split_type_id(193), None);
        assert_eq!(split_type_id(255), None);
        assert_eq!(split_type_id(192), Some((48, ContainerKind::Sequence)));
        assert_eq!(type_id(TypeId::Float64, ContainerKind::Array), 59);
        assert!(TypeId::from_element_id(12)
            .unwrap_err()
            .contains("long double"));
        assert!(TypeId::from_element_id(48)
            .unwrap_err()
            .contains("unknown element type_id 48"));
    }
}
