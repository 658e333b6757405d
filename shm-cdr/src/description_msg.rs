//! A compiled type's description as the message a type-description service
//! answers with (`type_description_interfaces/msg/TypeDescription`).

use crate::describe::{DescribedField, FullDescription, TypeDescription};
use crate::msgs::type_description_interfaces::msg as td;

/// One field as the message states it.
impl From<DescribedField<'_>> for td::Field {
    fn from(field: DescribedField<'_>) -> Self {
        td::Field {
            name: field.name.to_owned(),
            r#type: td::FieldType {
                type_id: field.type_id,
                capacity: field.capacity,
                string_capacity: field.string_capacity,
                nested_type_name: field.nested_type_name.into(),
            },
            default_value: field.default_value.to_owned(),
        }
    }
}

/// The description as `type_description_interfaces/msg/TypeDescription`: what
/// a node's `~/get_type_description` answers with.
impl From<&FullDescription> for td::TypeDescription {
    fn from(full: &FullDescription) -> Self {
        let individual = |description: &TypeDescription| td::IndividualTypeDescription {
            type_name: description.type_name.into(),
            fields: description
                .fields
                .iter()
                .map(|field| DescribedField::of(field).into())
                .collect(),
        };
        td::TypeDescription {
            type_description: individual(&full.own),
            referenced_type_descriptions: full.referenced.iter().map(individual).collect(),
        }
    }
}
