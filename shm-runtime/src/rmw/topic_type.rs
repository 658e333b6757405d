//! The message type of a publisher or subscriber, as its key expression and
//! liveliness token name it.

use shm_cdr::RosMessage;

/// The message type of a publisher or subscriber: its name (`pkg/msg/Name`)
/// and RIHS01 hash, from a compiled type or from a
/// [`DynamicType`](shm_cdr::dynamic::DynamicType) given at run time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TopicType {
    pub(crate) name: std::sync::Arc<str>,
    pub(crate) hash: std::sync::Arc<str>,
    /// Whether the type has a `uint8[]` field of its own, which C++ code
    /// generated on Lyrical and later holds as a `rosidl::Buffer` (see
    /// [`crate::rmw::buffer_key_expr`]).
    pub(crate) has_buffer_fields: bool,
}

impl TopicType {
    pub(crate) fn of<T: RosMessage>() -> Self {
        let description = T::type_description();
        Self {
            name: T::TYPE_NAME.into(),
            hash: T::type_hash().into(),
            has_buffer_fields: description.fields.iter().any(|f| {
                f.field_type.element == shm_cdr::describe::TypeId::Uint8
                    && f.field_type.container == shm_cdr::describe::Container::Sequence
            }),
        }
    }

    pub(crate) fn of_dynamic(ty: &shm_cdr::dynamic::DynamicType) -> Self {
        use shm_cdr::dynamic::Element;
        Self {
            name: ty.name().into(),
            hash: ty.type_hash().into(),
            has_buffer_fields: ty.root().fields.iter().any(|f| {
                f.element == Element::U8 && f.container == shm_cdr::describe::Container::Sequence
            }),
        }
    }

    /// rmw_zenoh's (DDS's) name of the type: `pkg::msg::dds_::Name_`.
    pub(crate) fn dds_name(&self) -> String {
        let mut parts = self.name.splitn(3, '/');
        match (parts.next(), parts.next(), parts.next()) {
            (Some(pkg), Some(kind), Some(name)) => format!("{pkg}::{kind}::dds_::{name}_"),
            _ => self.name.to_string(),
        }
    }
}
