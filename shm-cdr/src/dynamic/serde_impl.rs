//! `serde::Serialize` for run-time typed messages: a message is a map of its
//! fields in order, numbers are numbers (`byte` and `char` too), arrays and
//! sequences are sequences. A `float32` is written as the `float64` of the
//! same value, as rclpy (and so `ros2 topic echo`) holds it. With serde_json
//! this gives JSON; non-finite floats become `null` there, as JSON has no other
//! way to write them.

use serde::ser::{SerializeMap, SerializeSeq};
use serde::{Serialize, Serializer};

use super::value::{Message, Value};

impl Serialize for Message<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let def = self.def();
        // rclpy leaves the placeholder of an empty message out.
        let placeholder =
            def.fields.len() == 1 && def.fields[0].name == "structure_needs_at_least_one_member";
        let fields = if placeholder { 0 } else { def.fields.len() };
        let mut map = serializer.serialize_map(Some(fields))?;
        for (field, value) in def.fields.iter().zip(&self.values).take(fields) {
            map.serialize_entry(&field.name, value)?;
        }
        map.end()
    }
}

impl Serialize for Value<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        fn seq<S: Serializer, T: Serialize>(serializer: S, items: &[T]) -> Result<S::Ok, S::Error> {
            let mut seq = serializer.serialize_seq(Some(items.len()))?;
            for item in items {
                seq.serialize_element(item)?;
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
            Self::Bools(v) => seq(serializer, v),
            Self::U8s(v) => seq(serializer, v),
            Self::I8s(v) => seq(serializer, v),
            Self::I16s(v) => seq(serializer, v),
            Self::U16s(v) => seq(serializer, v),
            Self::I32s(v) => seq(serializer, v),
            Self::U32s(v) => seq(serializer, v),
            Self::I64s(v) => seq(serializer, v),
            Self::U64s(v) => seq(serializer, v),
            Self::F32s(v) => {
                let mut seq = serializer.serialize_seq(Some(v.len()))?;
                for x in v.iter() {
                    seq.serialize_element(&f64::from(*x))?;
                }
                seq.end()
            }
            Self::F64s(v) => seq(serializer, v),
            Self::Strings(v) => seq(serializer, v),
            Self::WStrings(v) => seq(serializer, v),
            Self::Messages(v) => seq(serializer, v),
        }
    }
}
