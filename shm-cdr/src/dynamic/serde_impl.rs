//! `serde::Serialize` for run-time typed messages: a message is a map of its
//! fields in order, numbers are numbers (`byte` and `char` too), arrays and
//! sequences are sequences. A `float32` is written as the `float64` of the
//! same value, as rclpy (and so `ros2 topic echo`) holds it. With serde_json
//! this gives JSON; non-finite floats become `null` there, as JSON has no other
//! way to write them.

use std::cell::RefCell;

use serde::ser::{Error as _, SerializeMap, SerializeSeq};
use serde::{Serialize, Serializer};

use super::codec::read_len;
use super::model::DynamicType;
use super::structs::{Check, Element};
use super::value::{Field, Message, MessageRef, Messages, Value};
use crate::decode::Reader;
use crate::endian::{BigEndian, ByteOrder, Endianness, LittleEndian};
use crate::error::DecodeError;

impl Serialize for Message<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.as_message_ref().serialize(serializer)
    }
}

impl Serialize for MessageRef<'_, '_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let def = self.def();
        // rclpy leaves the placeholder of an empty message out.
        let placeholder =
            def.fields.len() == 1 && def.fields[0].name == crate::describe::PLACEHOLDER_MEMBER;
        let fields = if placeholder { 0 } else { def.fields.len() };
        let mut map = serializer.serialize_map(Some(fields))?;
        for (name, field) in self.fields().take(fields) {
            match field {
                Field::Value(value) => map.serialize_entry(name, value)?,
                Field::Message(message) => map.serialize_entry(name, &message)?,
            }
        }
        map.end()
    }
}

impl Serialize for Messages<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.len()))?;
        for message in self.iter() {
            seq.serialize_element(&message)?;
        }
        seq.end()
    }
}

impl Serialize for Value<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        fn seq<S: Serializer, T: Serialize>(
            serializer: S,
            items: impl ExactSizeIterator<Item = T>,
        ) -> Result<S::Ok, S::Error> {
            let mut seq = serializer.serialize_seq(Some(items.len()))?;
            for item in items {
                seq.serialize_element(&item)?;
            }
            seq.end()
        }
        match self {
            Self::Bool(v) => serializer.serialize_bool(*v),
            Self::U8(v) => serializer.serialize_u8(*v),
            Self::I8(v) => serializer.serialize_i8(*v),
            Self::I16(v) => serializer.serialize_i16(*v),
            Self::U16(v) => serializer.serialize_u16(*v),
            Self::I32(v) => serializer.serialize_i32(*v),
            Self::U32(v) => serializer.serialize_u32(*v),
            Self::I64(v) => serializer.serialize_i64(*v),
            Self::U64(v) => serializer.serialize_u64(*v),
            Self::F32(v) => serializer.serialize_f64(f64::from(*v)),
            Self::F64(v) => serializer.serialize_f64(*v),
            Self::String(v) => serializer.serialize_str(v),
            Self::WString(v) => serializer.serialize_str(v),
            Self::Message(m) => m.serialize(serializer),
            Self::Bools(v) => seq(serializer, v.iter()),
            Self::U8s(v) => seq(serializer, v.iter()),
            Self::I8s(v) => seq(serializer, v.iter()),
            Self::I16s(v) => seq(serializer, v.iter()),
            Self::U16s(v) => seq(serializer, v.iter()),
            Self::I32s(v) => seq(serializer, v.iter()),
            Self::U32s(v) => seq(serializer, v.iter()),
            Self::I64s(v) => seq(serializer, v.iter()),
            Self::U64s(v) => seq(serializer, v.iter()),
            Self::F32s(v) => seq(serializer, v.iter().map(f64::from)),
            Self::F64s(v) => seq(serializer, v.iter()),
            Self::Strings(v) => seq(serializer, v.iter()),
            Self::WStrings(v) => seq(serializer, v.iter()),
            Self::Messages(v) => v.serialize(serializer),
        }
    }
}

/// A CDR payload of a run-time type, serialized as its decoded [`Message`]
/// is, but read field by field while the serializer writes: no message is
/// built, so a serializer that writes as it goes (`serde_json::to_writer`
/// into a buffered writer) takes memory independent of the message's size
/// and shape (at most one array of numbers is held, borrowed where the
/// bytes allow). Made by [`DynamicType::serialize_cdr`].
pub struct SerializeCdr<'a> {
    ty: &'a DynamicType,
    bytes: &'a [u8],
    shared: bool,
}

impl DynamicType {
    /// `bytes`, a CDR payload of this type (encapsulation header included),
    /// checked whole first as [`decode`](Self::decode) checks it (or,
    /// `shared`, as [`decode_shared`](Self::decode_shared)), ready to be
    /// serialized as the decoded message would be.
    ///
    /// ```
    /// use shm_cdr::dynamic::DynamicType;
    /// use shm_cdr::msgs::std_msgs::Header;
    /// use shm_cdr::RosMessage;
    ///
    /// let header = Header { frame_id: "map".into(), ..Default::default() };
    /// let bytes = shm_cdr::to_vec(&header)?;
    /// let ty = DynamicType::from_description(&Header::full_description())?;
    /// let mut out = Vec::new();
    /// serde_json::to_writer(&mut out, &ty.serialize_cdr(&bytes, false)?)?;
    /// assert_eq!(out, serde_json::to_vec(&ty.decode(&bytes)?)?);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn serialize_cdr<'a>(
        &'a self,
        bytes: &'a [u8],
        shared: bool,
    ) -> Result<SerializeCdr<'a>, DecodeError> {
        // Checked first with one element of each sequence kept, so that
        // what is written is never cut short by bad input.
        self.decode_truncated(bytes, shared, 0)?;
        Ok(SerializeCdr {
            ty: self,
            bytes,
            shared,
        })
    }
}

impl Serialize for SerializeCdr<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        fn root<B: ByteOrder, S: Serializer>(
            ty: &DynamicType,
            r: Reader<'_, B>,
            shared: bool,
            serializer: S,
        ) -> Result<S::Ok, S::Error> {
            let r = RefCell::new(if shared { r.shared() } else { r });
            Streamed {
                ty,
                index: 0,
                r: &r,
            }
            .serialize(serializer)
        }
        let body = self.bytes.get(4..).unwrap_or_default();
        match crate::read_header(self.bytes).map_err(S::Error::custom)? {
            Endianness::Little => root(
                self.ty,
                Reader::<LittleEndian>::new(body),
                self.shared,
                serializer,
            ),
            Endianness::Big => root(
                self.ty,
                Reader::<BigEndian>::new(body),
                self.shared,
                serializer,
            ),
        }
    }
}

/// One message of struct `index`, read from `r` as it is serialized.
struct Streamed<'t, 'r, 'de, B: ByteOrder> {
    ty: &'t DynamicType,
    index: usize,
    r: &'r RefCell<Reader<'de, B>>,
}

/// `n` strings, or messages of struct `index`, read from `r` as they are
/// serialized.
struct StreamedMany<'t, 'r, 'de, B: ByteOrder> {
    ty: &'t DynamicType,
    element: Element,
    n: usize,
    r: &'r RefCell<Reader<'de, B>>,
}

impl<B: ByteOrder> Serialize for Streamed<'_, '_, '_, B> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let (ty, r) = (self.ty, self.r);
        let def = ty
            .inner
            .structs
            .get(self.index)
            .ok_or_else(|| S::Error::custom("no such struct"))?;
        let checks = ty
            .inner
            .checks
            .get(self.index)
            .map_or(&[][..], Vec::as_slice);
        let placeholder =
            def.fields.len() == 1 && def.fields[0].name == crate::describe::PLACEHOLDER_MEMBER;
        let mut map =
            serializer.serialize_map(Some(if placeholder { 0 } else { def.fields.len() }))?;
        for (field, check) in def.fields.iter().zip(checks) {
            match *check {
                Check::Message { index, .. } => {
                    map.serialize_entry(&field.name, &Streamed { ty, index, r })?;
                }
                Check::Many {
                    element,
                    container,
                    min,
                } => {
                    let n =
                        read_len(&mut r.borrow_mut(), container, min).map_err(S::Error::custom)?;
                    match element {
                        Element::Message(_) | Element::String(_) | Element::WString(_) => {
                            map.serialize_entry(&field.name, &StreamedMany { ty, element, n, r })?;
                        }
                        _ => {
                            let numbers = ty
                                .decode_elements_kept(&mut r.borrow_mut(), element, n, 0)
                                .map_err(S::Error::custom)?;
                            map.serialize_entry(&field.name, &numbers)?;
                        }
                    }
                }
                _ => {
                    let value = ty
                        .decode_single(&mut r.borrow_mut(), field.element)
                        .map_err(S::Error::custom)?;
                    // rclpy leaves the placeholder of an empty message out.
                    if !placeholder {
                        map.serialize_entry(&field.name, &value)?;
                    }
                }
            }
        }
        map.end()
    }
}

impl<B: ByteOrder> Serialize for StreamedMany<'_, '_, '_, B> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let (ty, r) = (self.ty, self.r);
        let mut seq = serializer.serialize_seq(Some(self.n))?;
        for _ in 0..self.n {
            match self.element {
                Element::Message(index) => seq.serialize_element(&Streamed { ty, index, r })?,
                element => {
                    let value = ty
                        .decode_single(&mut r.borrow_mut(), element)
                        .map_err(S::Error::custom)?;
                    seq.serialize_element(&value)?;
                }
            }
        }
        seq.end()
    }
}
