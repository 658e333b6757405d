//! A compiled type's description as the message a type-description service
//! answers with (`type_description_interfaces/msg/TypeDescription`).

use crate::describe::{FullDescription, TypeDescription};
use crate::msgs::type_description_interfaces::msg as td;

/// The description as `type_description_interfaces/msg/TypeDescription`: what
/// a node's `~/get_type_description` answers with.
impl From<&FullDescription> for td::TypeDescription {
    fn from(full: &FullDescription) -> Self {
        let individual = |description: &TypeDescription| td::IndividualTypeDescription {
            type_name: description.type_name.into(),
            fields: description
                .fields
                .iter()
                .map(|field| {
                    let t = &field.field_type;
                    td::Field {
                        name: field.name.to_owned(),
                        r#type: td::FieldType {
                            type_id: t.type_id(),
                            capacity: t.capacity() as u64,
                            string_capacity: t.string_capacity as u64,
                            nested_type_name: t.nested_type_name.into(),
                        },
                        default_value: field.default_value.to_owned(),
                    }
                })
                .collect(),
        };
        td::TypeDescription {
            type_description: individual(&full.own),
            referenced_type_descriptions: full.referenced.iter().map(individual).collect(),
        }
    }
}
