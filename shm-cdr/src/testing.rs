//! Checks of the encoding invariants for your own message types, for use in
//! property tests (`proptest`, `quickcheck`) and fuzz targets.
//!
//! ```
//! # use shm_cdr::RosMessage;
//! #[derive(RosMessage, Debug)]
//! #[ros(type_name = "my_pkg/msg/Sample")]
//! struct Sample { id: u8, values: Vec<f64> }
//!
//! shm_cdr::testing::check_roundtrip(&Sample { id: 1, values: vec![2.0] }).unwrap();
//! ```

use crate::{
    encode_into_with, encoded_size, from_bytes, from_bytes_into, to_vec_with, CdrEncode,
    DecodeOwned, Endianness,
};

/// Verify, in both byte orders, that:
/// - [`encoded_size`] equals the length [`to_vec_with`] produces;
/// - [`encode_into_with`] into a buffer of exactly that size, pre-filled with
///   garbage, succeeds and produces the same bytes (so every padding byte is written);
/// - a buffer one byte shorter fails cleanly without writing past its end;
/// - decoding gives a value that prints the same (`Debug`) and re-encodes to the
///   same bytes;
/// - decoding into a value that already holds the message (see
///   [`CdrDecode::decode_into`](crate::CdrDecode::decode_into)) gives it again.
///
/// [`check_decode_into`] covers decoding over a *different* earlier message.
///
/// Returns a description of the first violation.
pub fn check_roundtrip<T>(msg: &T) -> Result<(), String>
where
    T: CdrEncode + DecodeOwned + std::fmt::Debug,
{
    for endianness in [Endianness::Little, Endianness::Big] {
        let bytes = to_vec_with(msg, endianness).map_err(|e| format!("to_vec: {e}"))?;
        let size = encoded_size(msg);
        if bytes.len() != size {
            return Err(format!(
                "encoded_size {size} but to_vec produced {} bytes",
                bytes.len()
            ));
        }
        for garbage in [0x00, 0xA5, 0xFF] {
            let mut buf = vec![garbage; size + 1];
            let n = encode_into_with(msg, &mut buf[..size], endianness)
                .map_err(|e| format!("encode_into an exact buffer: {e}"))?;
            if n != size || buf[..size] != bytes[..] {
                return Err(format!(
                    "encode_into over {garbage:#04x} differs from to_vec"
                ));
            }
            if buf[size] != garbage {
                return Err("encode_into wrote past the buffer".into());
            }
        }
        if size > 0 {
            let mut short = vec![0x5A; size];
            if encode_into_with(msg, &mut short[..size - 1], endianness).is_ok() {
                return Err("encode_into succeeded in a buffer one byte short".into());
            }
            if short[size - 1] != 0x5A {
                return Err("encode_into wrote past a short buffer".into());
            }
        }
        let decoded: T = from_bytes(&bytes).map_err(|e| format!("decode: {e}"))?;
        let (before, after) = (format!("{msg:?}"), format!("{decoded:?}"));
        if before != after {
            return Err(format!(
                "decoded value differs:\n  sent {before}\n  got  {after}"
            ));
        }
        let again = to_vec_with(&decoded, endianness).map_err(|e| format!("re-encode: {e}"))?;
        if again != bytes {
            return Err("re-encoding the decoded value gives other bytes".into());
        }
        let mut reused = decoded;
        from_bytes_into(&bytes, &mut reused).map_err(|e| format!("decode_into: {e}"))?;
        if format!("{reused:?}") != before {
            return Err(format!(
                "decoding into the decoded value changed it:\n  sent {before}\n  got  {reused:?}"
            ));
        }
    }
    Ok(())
}

/// Verify, in both byte orders, that decoding `msg` into a value that holds
/// `previous` (with [`from_bytes_into`], which reuses its strings and vectors)
/// gives exactly `msg` (`Debug`): nothing of `previous` is left over, whichever
/// of the two is longer anywhere.
pub fn check_decode_into<T>(previous: &T, msg: &T) -> Result<(), String>
where
    T: CdrEncode + DecodeOwned + std::fmt::Debug,
{
    for endianness in [Endianness::Little, Endianness::Big] {
        let old = to_vec_with(previous, endianness).map_err(|e| format!("to_vec: {e}"))?;
        let new = to_vec_with(msg, endianness).map_err(|e| format!("to_vec: {e}"))?;
        let mut value: T = from_bytes(&old).map_err(|e| format!("decode: {e}"))?;
        from_bytes_into(&new, &mut value).map_err(|e| format!("decode_into: {e}"))?;
        let (expected, got) = (format!("{msg:?}"), format!("{value:?}"));
        if expected != got {
            return Err(format!(
                "decoding into a used value differs:\n  sent {expected}\n  got  {got}"
            ));
        }
    }
    Ok(())
}

/// Verify that `msg` built in place ([`crate::loan`]) is byte for byte what
/// [`to_vec`](crate::to_vec) writes (in the host's byte order):
/// - the size computed from `msg.lens()` is [`encoded_size`];
/// - carving those lengths into a buffer pre-filled with garbage and writing every
///   field of `msg` through the places leaves exactly `to_vec`'s bytes (so every
///   padding byte, count and terminator is written), with nothing left unwritten;
/// - carving again leaves every string and non-empty run counted as unwritten
///   until it is written.
///
/// Returns a description of the first violation.
pub fn check_in_place<T>(msg: &T) -> Result<(), String>
where
    T: crate::loan::InPlace + std::fmt::Debug,
{
    use crate::loan::{self, AlignedBuffer, Written};

    let expected = to_vec_with(msg, loan::HOST_ORDER).map_err(|e| format!("to_vec: {e}"))?;
    let lens = msg.lens();
    let size = loan::encoded_size::<T>(&lens).map_err(|e| format!("size: {e}"))?;
    if size != encoded_size(msg) {
        return Err(format!(
            "in-place size {size} but encoded_size {}",
            encoded_size(msg)
        ));
    }
    for garbage in [0xA5, 0xFF] {
        let mut buffer = AlignedBuffer::new(size);
        buffer.as_mut_slice().fill(garbage);
        let written = Written::new();
        let place = loan::carve::<T>(&lens, buffer.as_mut_slice(), &written)
            .map_err(|e| format!("carve: {e}"))?;
        msg.write_in_place(place)
            .map_err(|e| format!("write_in_place: {e}"))?;
        written
            .check()
            .map_err(|e| format!("after writing every field: {e}"))?;
        if buffer.as_slice() != expected.as_slice() {
            let at = buffer
                .as_slice()
                .iter()
                .zip(&expected)
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            return Err(format!(
                "built in place over {garbage:#04x}, the bytes differ from to_vec first at byte {at}"
            ));
        }
    }
    Ok(())
}
