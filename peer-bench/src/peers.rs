//! Each Rust peer's public API, wrapped to the same four operations, each used
//! the way that library's documentation and its own runtime use it. Every
//! encoder writes the 4-byte encapsulation header, so all outputs compare with
//! shm-cdr's whole payload.

use byteorder::LittleEndian;
use hiroz_cdr::{CdrDeserialize, CdrReader, CdrSerialize, CdrSerializedSize, CdrWriter};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// CDR, little-endian, no options.
pub const ENCAPSULATION_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

fn body(bytes: &[u8]) -> Result<&[u8], String> {
    match bytes.split_first_chunk::<4>() {
        Some((&ENCAPSULATION_LE, body)) => Ok(body),
        _ => Err("not a little-endian CDR payload".into()),
    }
}

/// `hiroz-cdr` through its `CdrSerialize` traits (its fast path).
pub mod hiroz {
    use super::*;

    /// Encode into `buf`, reusing its capacity (hiroz's `to_vec_reuse` pattern).
    /// The writer's alignment origin is where it was created: after the header.
    pub fn encode_reuse<T: CdrSerialize>(msg: &T, buf: &mut Vec<u8>) {
        buf.clear();
        buf.extend_from_slice(&ENCAPSULATION_LE);
        let mut writer = CdrWriter::<LittleEndian>::new(buf);
        msg.cdr_serialize(&mut writer);
    }

    /// Encode into a new `Vec` sized by hiroz's own size function.
    pub fn to_vec<T: CdrSerialize + CdrSerializedSize>(msg: &T) -> Vec<u8> {
        let mut buf = Vec::with_capacity(size(msg));
        encode_reuse(msg, &mut buf);
        buf
    }

    /// hiroz's `CdrSerializedSize`, plus the header.
    pub fn size<T: CdrSerializedSize>(msg: &T) -> usize {
        ENCAPSULATION_LE.len() + msg.cdr_serialized_size(0)
    }

    /// Decode an owned value.
    pub fn decode<T: CdrDeserialize>(bytes: &[u8]) -> Result<T, String> {
        let mut reader = CdrReader::<LittleEndian>::new(body(bytes)?);
        T::cdr_deserialize(&mut reader).map_err(|e| e.to_string())
    }
}

/// The `cdr` crate (serde).
pub mod cdr_crate {
    use super::*;
    use cdr::{CdrLe, Infinite};

    /// `serialize_into` a reused `Vec`.
    pub fn encode_reuse<T: Serialize>(msg: &T, buf: &mut Vec<u8>) -> Result<(), String> {
        buf.clear();
        cdr::serialize_into::<_, _, _, CdrLe>(&mut *buf, msg, Infinite).map_err(|e| e.to_string())
    }

    /// `serialize` (sizes the `Vec` with `calc_serialized_size` first).
    pub fn to_vec<T: Serialize>(msg: &T) -> Result<Vec<u8>, String> {
        cdr::serialize::<_, _, CdrLe>(msg, Infinite).map_err(|e| e.to_string())
    }

    /// `calc_serialized_size`, header included.
    pub fn size<T: Serialize>(msg: &T) -> usize {
        cdr::calc_serialized_size(msg) as usize
    }

    /// `deserialize`.
    pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
        cdr::deserialize(bytes).map_err(|e| e.to_string())
    }
}

/// The `cdr-encoding` crate (serde; RustDDS). It has no size function.
pub mod cdr_encoding {
    use super::*;

    /// `to_writer` into a reused `Vec` after the header.
    pub fn encode_reuse<T: Serialize>(msg: &T, buf: &mut Vec<u8>) -> Result<(), String> {
        buf.clear();
        buf.extend_from_slice(&ENCAPSULATION_LE);
        ::cdr_encoding::to_writer::<T, LittleEndian, _>(&mut *buf, msg).map_err(|e| e.to_string())
    }

    /// `to_vec` (its capacity hint is `2 * size_of_val`), then the header.
    pub fn to_vec<T: Serialize>(msg: &T) -> Result<Vec<u8>, String> {
        let body = ::cdr_encoding::to_vec::<T, LittleEndian>(msg).map_err(|e| e.to_string())?;
        let mut out = Vec::with_capacity(ENCAPSULATION_LE.len() + body.len());
        out.extend_from_slice(&ENCAPSULATION_LE);
        out.extend_from_slice(&body);
        Ok(out)
    }

    /// `from_bytes`.
    pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
        ::cdr_encoding::from_bytes::<T, LittleEndian>(body(bytes)?)
            .map(|(msg, _)| msg)
            .map_err(|e| e.to_string())
    }
}
