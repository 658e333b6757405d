//! Type descriptions and the REP 2011 `RIHS01` type hash.
//!
//! The model of a description is `shm_interface`'s, re-exported here: every
//! field type knows its [`FieldType`] at compile time ([`RosType`]); derived
//! messages list their [`Field`]s and register the messages they reference.
//! The hash is computed as rosidl's `calculate_type_hash` does: the JSON of
//! the type and of every referenced type (sorted by name), separators `", "`
//! and `": "`, SHA-256.

pub use crate::message::{
    compute_type_hash, message_description_json, OctetType, RosElement, RosType,
};
pub use shm_interface::{
    description_json, msg_text, rihs01_of_json, split_type_id, type_description_json, type_id,
    write_individual_json, Container, ContainerKind, DescribedField, DescribedFieldBuf, Field,
    FieldType, FullDescription, TypeDescription, TypeId, TypeRegistry, TypeSource,
    PLACEHOLDER_MEMBER,
};
