//! [`CdrEncode`](crate::CdrEncode) / [`CdrDecode`](crate::CdrDecode) /
//! [`RosType`](crate::RosType) for every supported field type, one module per
//! wire kind.

mod array;
#[cfg(feature = "bytes")]
mod bytes;
mod primitive;
mod sequence;
mod string;
mod wstring;
