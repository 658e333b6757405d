//! Splicing: a write that leaves some byte runs out of the buffer it fills,
//! for the caller to put into the payload as fragments of their own (a
//! publisher splicing the shared-memory blocks an application already wrote,
//! without copying them).
//!
//! A run left out is replaced in the buffer by filler of its length modulo 8,
//! so every later field keeps its alignment: the payload is the buffer's
//! bytes up to the run's place, the run, then the buffer's bytes after the
//! filler. Only a type that splices ([`CdrEncode::SPLICES`]) and what holds
//! one take part; every other type sizes and writes as
//! [`encoded_end`](CdrEncode::encoded_end) and [`encode`](CdrEncode::encode)
//! do. Sizing and writing take what they tally or collect as an argument.

use std::any::Any;

use crate::encode::{CdrEncode, Writer};
use crate::endian::LittleEndian;
use crate::error::EncodeError;
use crate::HEADER_LEN;

/// What sizing a splicing write met: how many runs it leaves out, and how
/// many of their bytes the buffer does not hold.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SpliceSizing {
    /// Runs left out.
    pub runs: usize,
    /// Their bytes not in the buffer (each run's length less its filler).
    pub left_out: usize,
}

impl SpliceSizing {
    /// A run of `len` bytes left out: the filler the buffer holds in its place.
    pub fn leave_out(&mut self, len: usize) -> usize {
        self.runs += 1;
        self.left_out += len - len % 8;
        len % 8
    }
}

/// Where a splicing write hands each run it leaves out.
pub trait SpliceSink {
    /// Take `run`, whose data belongs at body position `at`; `false` leaves
    /// it in the buffer instead (a run this sink does not know).
    fn splice(&mut self, at: usize, run: &dyn Any) -> bool;
}

/// `msg`'s size as a splicing write lays it out, header included, and what it
/// leaves out. With no run left out, the size is [`encoded_size`](crate::encoded_size).
#[inline]
pub fn spliced_size<T: CdrEncode + ?Sized>(msg: &T) -> (usize, SpliceSizing) {
    let mut sizing = SpliceSizing::default();
    let end = msg.spliced_end(0, &mut sizing);
    (HEADER_LEN + end, sizing)
}

/// Encode `msg` as little-endian CDR into the start of `buf` (of at least
/// [`spliced_size`] bytes), handing every run left out to `sink`; the number
/// of bytes written.
#[inline]
pub fn encode_spliced_into<T: CdrEncode + ?Sized>(
    msg: &T,
    buf: &mut [u8],
    sink: &mut dyn SpliceSink,
) -> Result<usize, EncodeError> {
    let (header, body) = crate::split_header(buf)?;
    *header = crate::Endianness::Little.header();
    let mut w = Writer::<LittleEndian>::new(body);
    msg.encode_spliced(&mut w, sink)?;
    Ok(HEADER_LEN + w.position())
}
