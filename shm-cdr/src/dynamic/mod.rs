//! Messages typed at run time: a [`DynamicType`] built from a type description
//! (what a node's `~/get_type_description` returns, or a compiled type's
//! [`full_description`](crate::RosMessage::full_description)) decodes any CDR
//! payload of that type into a [`Message`] of [`Value`]s and encodes one back,
//! sized exactly, with the guarantees of the generated code: bad input is an
//! error, never a panic, nothing is allocated on the word of a length prefix,
//! strings and arrays borrow from the input (number arrays in any alignment,
//! as [`Numbers`]), padding is zeroed. Its RIHS01 hash, computed from the model, is
//! rosidl's.
//!
//! ```
//! use shm_cdr::dynamic::{DynamicType, Value};
//! use shm_cdr::msgs::std_msgs::Header;
//! use shm_cdr::msgs::builtin_interfaces::Time;
//! use shm_cdr::RosMessage;
//!
//! let header = Header { stamp: Time { sec: 7, nanosec: 0 }, frame_id: "map".into() };
//! let bytes = shm_cdr::to_vec(&header)?;
//!
//! let ty = DynamicType::from_description(&Header::full_description())?;
//! let message = ty.decode(&bytes)?;
//! assert_eq!(message.value("frame_id"), Some(&Value::String("map".into())));
//! // Encoded again: the same bytes, sized exactly.
//! assert_eq!(shm_cdr::to_vec(&message)?, bytes);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod codec;
mod defaults;
mod in_place;
mod limits;
mod model;
mod numbers;
mod plan;
#[cfg(feature = "serde")]
mod serde_impl;
mod structs;
mod value;
mod view;
#[cfg(feature = "yaml")]
mod yaml_in;
mod yaml_out;

pub use in_place::{InPlaceArray, InPlaceError, InPlaceLayout};
pub use limits::TypeLimits;
pub use model::{DynamicType, TypeError};
pub use numbers::{Iter as NumbersIter, Number, Numbers};
#[cfg(feature = "serde")]
pub use serde_impl::SerializeCdr;
pub use shm_interface::python::python_float;
pub use structs::{Element, FieldDef, StructDef};
pub use value::{Field, Message, MessageRef, Messages, Value, ValueError};
pub use view::{FieldView, MessageView, SequenceView, StructView, ValueView};
#[cfg(feature = "yaml")]
pub use yaml_in::TextError;
pub use yaml_out::{YamlOptions, YamlValue};
