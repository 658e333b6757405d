//! The model of a ROS 2 interface, below everything that reads or writes
//! one: what protobuf's descriptor model is to prost-build and to reflection
//! alike.
//!
//! A message type is described as REP 2011 describes it
//! ([`TypeDescription`], [`FullDescription`]): named fields, each of a
//! [`FieldType`] numbered as `type_description_interfaces/FieldType` numbers
//! it ([`type_id`], [`split_type_id`]). From a description come the text
//! rosidl hashes and its `RIHS01` hash ([`FullDescription::type_hash`]),
//! the `.msg` text it could be read from ([`msg_text`]), and default values
//! as rosidl writes them ([`python`]). Interface files are read as
//! rosidl_adapter reads them ([`parse`], into the tree of [`ast`]), with an
//! error that names the file, the line and what to write.
//!
//! ```
//! use shm_interface::{Field, FieldType, FullDescription, TypeDescription, TypeId, TypeSource};
//!
//! static FIELDS: [Field; 2] = [
//!     Field::new("sec", FieldType::scalar(TypeId::Int32)),
//!     Field::new("nanosec", FieldType::scalar(TypeId::Uint32)),
//! ];
//! let time = TypeDescription::new("builtin_interfaces/msg/Time", &FIELDS, TypeSource::NONE);
//! let full = FullDescription::collect(time, |_| {});
//! // rosidl's hash of builtin_interfaces/msg/Time.
//! assert_eq!(
//!     full.type_hash(),
//!     "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197"
//! );
//! assert_eq!(time.source_text().1, "int32 sec\nuint32 nanosec");
//! ```
//!
//! It has no dependency on the wire format or on Zenoh: `shm-cdr`'s derive
//! and generated types hold their descriptions in these forms, `shm-codegen`
//! writes them, and run-time types (`shm_cdr::dynamic`) are built from them.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod ast;
mod described;
mod description;
mod json;
mod msg_text;
pub mod parse;
pub mod python;
mod type_id;

pub use described::{DescribedField, DescribedFieldBuf};
pub use description::{
    type_description_json, Field, FieldType, FullDescription, TypeDescription, TypeRegistry,
    TypeSource, PLACEHOLDER_MEMBER,
};
pub use json::{description_json, rihs01_of_json, write_individual_json};
pub use msg_text::msg_text;
pub use type_id::{split_type_id, type_id, Container, ContainerKind, TypeId};
