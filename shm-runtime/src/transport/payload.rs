//! Turning a message into a Zenoh payload (exact size first, then one write into
//! shared memory at or above the threshold, or the heap) and a received payload
//! back into a message (borrowing from it wherever it can).

use std::sync::{Arc, OnceLock};

use shm_cdr::{CdrDecode, CdrEncode, DecodeError, DecodeErrorKind, EncodeError, EncodeErrorKind};
use zenoh::bytes::ZBytes;
use zenoh_buffers::{ZBuf, ZSlice, ZSliceBuffer};

use crate::rmw::ATTACHMENT_LEN;
use crate::transport::encoded::{EncodedPayload, PayloadKind};
use crate::transport::pool::ShmContext;
use crate::transport::reach::Receivers;
use crate::transport::shm_bytes::{self, Splice};

/// How a publisher encodes: with a pool and threshold, or heap only.
#[derive(Clone)]
pub(crate) struct ShmPolicy {
    pub(crate) context: ShmContext,
    pub(crate) threshold: usize,
    /// The sessions subscribing to a publisher, which must map the pool
    /// before its messages go through it (publishers only).
    pub(crate) receivers: Option<Arc<Receivers>>,
}

impl std::fmt::Debug for ShmPolicy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShmPolicy")
            .field("context", &self.context)
            .field("threshold", &self.threshold)
            .finish_non_exhaustive()
    }
}

impl ShmPolicy {
    /// Why a message above the threshold must go from the heap now, if it
    /// must (see [`Receivers::gate`]). A session still being checked is
    /// waited for as a full pool is, up to the pool's `alloc_timeout`: the
    /// check takes two round trips, and the message then takes its final path.
    pub(crate) fn gate(&self) -> Option<PayloadKind> {
        let receivers = self.receivers.as_ref()?;
        let mut gate = receivers.gate();
        if gate == Some(PayloadKind::ReceiverPending) {
            let deadline = std::time::Instant::now() + self.context.config().alloc_timeout;
            while gate == Some(PayloadKind::ReceiverPending) && std::time::Instant::now() < deadline
            {
                std::thread::sleep(std::time::Duration::from_micros(50));
                gate = receivers.gate();
            }
        }
        gate
    }

    /// How many subscribing sessions get a message sent through the pool as
    /// a copy, counted in the pool's stats when any does.
    pub(crate) fn copied_to(&self) -> usize {
        let copied = self.receivers.as_ref().map_or(0, |r| r.copied_to());
        if copied > 0 {
            self.context.count_copied();
        }
        copied
    }
}

/// Encode `msg` for publishing under `policy`.
#[inline]
pub(crate) fn encode_payload<T: CdrEncode + ?Sized>(
    msg: &T,
    policy: Option<&ShmPolicy>,
) -> Result<EncodedPayload, EncodeError> {
    match splice_or_size(msg, policy)? {
        Splice::Done(spliced) => Ok(spliced),
        Splice::NotNeeded(size) => encode_sized(msg, size, policy),
    }
}

/// A message that holds shared-memory fields, assembled around them and
/// counted; else its exact encoded size.
#[inline]
pub(crate) fn splice_or_size<T: CdrEncode + ?Sized>(
    msg: &T,
    policy: Option<&ShmPolicy>,
) -> Result<Splice, EncodeError> {
    let spliced = match shm_bytes::encode_spliced(msg)? {
        Splice::Done(spliced) => spliced,
        sized @ Splice::NotNeeded(_) => return Ok(sized),
    };
    let Some(policy) = policy else {
        return Ok(Splice::Done(spliced));
    };
    let spliced = routed(spliced, policy);
    policy.context.count(spliced.kind, spliced.size);
    Ok(Splice::Done(spliced))
}

/// Encode `msg`, whose exact size is `size`, for publishing under `policy`.
#[inline]
pub(crate) fn encode_sized<T: CdrEncode + ?Sized>(
    msg: &T,
    size: usize,
    policy: Option<&ShmPolicy>,
) -> Result<EncodedPayload, EncodeError> {
    write_payload(size, policy, |buffer| {
        shm_cdr::encode_into(msg, buffer).map(|_| ())
    })
}

/// Whether a message of `size` bytes goes on the heap under `policy`.
#[inline]
pub(crate) fn on_heap(size: usize, policy: Option<&ShmPolicy>) -> bool {
    policy.is_none_or(|p| size < p.threshold)
}

/// The largest message [`packed`] takes, with its attachment behind it.
const PACKED_MAX: usize = 576;

/// A small heap message with its attachment behind it. Zenoh takes each
/// payload and attachment as a reference-counted buffer: two of their own are
/// four allocations and four frees per message, a cost as large as a small
/// message's encoding; packed they are one of each.
#[derive(Debug)]
struct Packed<const N: usize>([u8; N]);

impl<const N: usize> ZSliceBuffer for Packed<N> {
    fn as_slice(&self) -> &[u8] {
        &self.0
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}

/// A heap message of `len` bytes and the attachment behind it, in one
/// allocation: `write` fills both (the message first, as it may fail), and
/// gets back the message and attachment as Zenoh takes them, with what
/// `write` returned. `None`, with nothing written, if the two are larger than
/// [`PACKED_MAX`].
#[inline]
pub(crate) fn packed<R, E: From<EncodeError>>(
    len: usize,
    write: impl FnOnce(&mut [u8], &mut [u8; ATTACHMENT_LEN]) -> Result<R, E>,
) -> Option<Result<(ZBytes, ZBytes, R), E>> {
    match len.checked_add(ATTACHMENT_LEN)? {
        0..=128 => packed_in::<128, _, _>(len, write),
        129..=256 => packed_in::<256, _, _>(len, write),
        257..=PACKED_MAX => packed_in::<PACKED_MAX, _, _>(len, write),
        _ => None,
    }
}

/// [`packed`] in a buffer of `N` bytes, which holds `len + ATTACHMENT_LEN`.
#[inline]
fn packed_in<const N: usize, R, E: From<EncodeError>>(
    len: usize,
    write: impl FnOnce(&mut [u8], &mut [u8; ATTACHMENT_LEN]) -> Result<R, E>,
) -> Option<Result<(ZBytes, ZBytes, R), E>> {
    let mut buffer = Arc::new(Packed([0u8; N]));
    let (body, rest) = Arc::get_mut(&mut buffer)?.0.split_at_mut_checked(len)?;
    let tail = rest.first_chunk_mut::<ATTACHMENT_LEN>()?;
    let written = match write(body, tail) {
        Ok(written) => written,
        Err(e) => return Some(Err(e)),
    };
    let buffer: Arc<dyn ZSliceBuffer> = buffer;
    let slices = ZSlice::new(buffer.clone(), 0, len)
        .and_then(|body| Ok((body, ZSlice::new(buffer, len, len + ATTACHMENT_LEN)?)));
    Some(match slices {
        Ok((body, tail)) => Ok((
            ZBytes::from(ZBuf::from(body)),
            ZBytes::from(ZBuf::from(tail)),
            written,
        )),
        // Not reached: the buffer was split at these bounds above.
        Err(_) => Err(E::from(EncodeError::new(EncodeErrorKind::BufferTooSmall {
            needed: len + ATTACHMENT_LEN,
            available: N,
        }))),
    })
}

/// `size` bytes that `write` fills, in an exact-size shared-memory buffer
/// under `policy` at or above its threshold (the provider hands out exactly
/// `size` bytes, so the payload is what `write` wrote and nothing else), else
/// in a heap buffer of exactly `size` bytes: written once either way.
#[inline]
#[expect(
    clippy::slow_vector_initialization,
    reason = "`vec![0; size]` is calloc, which skips the allocator's per-thread cache"
)]
fn write_payload<E>(
    size: usize,
    policy: Option<&ShmPolicy>,
    write: impl FnOnce(&mut [u8]) -> Result<(), E>,
) -> Result<EncodedPayload, E> {
    let mut kind = PayloadKind::Heap;
    if let Some(policy) = policy {
        if size >= policy.threshold {
            match policy
                .gate()
                .map_or_else(|| policy.context.place(size), Err)
            {
                Ok(mut buffer) => {
                    write(&mut buffer)?;
                    policy.context.count(PayloadKind::Shm, size);
                    return Ok(EncodedPayload {
                        bytes: ZBytes::from(buffer),
                        kind: PayloadKind::Shm,
                        size,
                        inline: 0,
                    });
                }
                Err(heap) => kind = heap,
            }
        }
        policy.context.count(kind, size);
    }
    let mut buffer = Vec::with_capacity(size);
    buffer.resize(size, 0u8);
    write(&mut buffer)?;
    Ok(EncodedPayload {
        bytes: ZBytes::from(buffer),
        kind,
        size,
        inline: size,
    })
}

/// Bytes that do not start with a CDR encapsulation header.
pub(crate) struct NotCdr;

/// A message already in CDR (its 4-byte encapsulation header first, as a
/// recording keeps it) as a payload under `policy`: copied once, into an
/// exact-size shared-memory buffer at or above the threshold, else the heap.
pub(crate) fn serialized_payload(
    cdr: &[u8],
    policy: Option<&ShmPolicy>,
) -> Result<EncodedPayload, NotCdr> {
    if !matches!(cdr, [0, 0 | 1, _, _, ..]) {
        return Err(NotCdr);
    }
    write_payload(cdr.len(), policy, |buffer| {
        buffer.copy_from_slice(cdr);
        Ok(())
    })
}

/// `encoded` as it may go out under `policy`: a payload in shared memory
/// (spliced or loaned) is copied to the heap while a subscribing session
/// has not shown it maps the pool, or cannot (see [`ShmPolicy::gate`]).
pub(crate) fn routed(encoded: EncodedPayload, policy: &ShmPolicy) -> EncodedPayload {
    if !encoded.kind.is_shm() {
        return encoded;
    }
    match policy.gate() {
        None => encoded,
        Some(kind) => EncodedPayload {
            bytes: ZBytes::from(encoded.bytes.to_bytes().into_owned()),
            kind,
            size: encoded.size,
            inline: encoded.size,
        },
    }
}

/// How many bytes of a received `payload` lie in shared memory: all of them
/// for a message encoded into a pool (or loaned), the block of each spliced
/// `ShmBytes` field, 0 for a payload that travelled as bytes.
pub(crate) fn shm_len(payload: &ZBytes) -> usize {
    if let Some(shm) = payload.as_shm() {
        return shm.len();
    }
    // Several slices: Zenoh tells shared memory apart only for a one-slice
    // ZBytes, so ask about each slice on its own (clones of reference-counted
    // handles, no copy of the bytes).
    let buffer: ZBuf = payload.clone().into();
    buffer
        .zslices()
        .filter(|slice| {
            ZBytes::from(ZBuf::from((*slice).clone()))
                .as_shm()
                .is_some()
        })
        .map(|slice| slice.len())
        .sum()
}

/// Decode a received `payload` as `M`, borrowing from it: from its single slice,
/// else from its fragments (a spliced shared-memory field stays where it is),
/// else (a value straddles two fragments, or there are too many) from one
/// contiguous copy, made at most once into `copy`.
pub(crate) fn decode<'a, M: CdrDecode<'a>>(
    payload: &'a ZBytes,
    copy: &'a OnceLock<Vec<u8>>,
) -> Result<M, DecodeError> {
    read_payload(payload, copy, |body| match body {
        Body::Contiguous(bytes) => shm_cdr::from_bytes(bytes),
        Body::Shared(bytes) => shm_cdr::from_shared_bytes(bytes),
        Body::Fragments(segments, false) => shm_cdr::from_segments(segments),
        Body::Fragments(segments, true) => shm_cdr::from_shared_segments(segments),
    })
}

/// [`decode`] into an existing value, reusing the memory it owns.
pub(crate) fn decode_into<'a, M: CdrDecode<'a>>(
    payload: &'a ZBytes,
    copy: &'a OnceLock<Vec<u8>>,
    out: &mut M,
) -> Result<(), DecodeError> {
    read_payload(payload, copy, |body| match body {
        Body::Contiguous(bytes) => shm_cdr::from_bytes_into(bytes, out),
        Body::Shared(bytes) => shm_cdr::from_shared_bytes_into(bytes, out),
        Body::Fragments(segments, false) => shm_cdr::from_segments_into(segments, out),
        Body::Fragments(segments, true) => shm_cdr::from_shared_segments_into(segments, out),
    })
}

/// Hand `payload` to `read` in the cheapest form it can be read from.
fn read_payload<'a, R>(
    payload: &'a ZBytes,
    copy: &'a OnceLock<Vec<u8>>,
    mut read: impl FnMut(Body<'a, '_>) -> Result<R, DecodeError>,
) -> Result<R, DecodeError> {
    let mut slices = payload.slices();
    match (slices.next(), slices.next()) {
        (Some(only), None) if payload.as_shm().is_some() => return read(Body::Shared(only)),
        (Some(only), None) => return read(Body::Contiguous(only)),
        (None, _) => return read(Body::Contiguous(&[])),
        _ => {}
    }
    if copy.get().is_none() && payload.slices().count() <= shm_cdr::MAX_SEGMENTS {
        let segments: Vec<&'a [u8]> = payload.slices().collect();
        match read(Body::Fragments(&segments, shm_len(payload) > 0)) {
            Err(e) if matches!(e.kind(), DecodeErrorKind::Fragmented { .. }) => {}
            done => return done,
        }
    }
    read(Body::Contiguous(
        copy.get_or_init(|| payload.to_bytes().into_owned()),
    ))
}

/// A payload as [`read_payload`] hands it over. What lies in shared memory,
/// which any process that maps it can rewrite, is decoded as shared input
/// (see [`shm_cdr::from_shared_bytes`]): no rewrite can make a decoded value
/// invalid.
enum Body<'a, 's> {
    /// Private memory: this process's own.
    Contiguous(&'a [u8]),
    /// One shared-memory buffer.
    Shared(&'a [u8]),
    /// Fragments; `true` if any lies in shared memory.
    Fragments(&'s [&'a [u8]], bool),
}

#[cfg(test)]
mod tests {
    use shm_cdr::{EncodeError, EncodeErrorKind};

    use super::{packed, ATTACHMENT_LEN, PACKED_MAX};

    /// Every length that packs gets back exactly what was written, message
    /// and attachment, each at its own length, in each size class; longer
    /// messages are not packed and nothing is written.
    #[test]
    fn a_packed_message_and_attachment_are_what_was_written() {
        let largest = PACKED_MAX - ATTACHMENT_LEN;
        for len in [0, 1, 95, 96, 97, 223, 224, 225, largest] {
            let (body, tail, written) = packed(len, |body, tail| {
                for (i, b) in body.iter_mut().enumerate() {
                    *b = i as u8 ^ 0x5a;
                }
                *tail = [len as u8; ATTACHMENT_LEN];
                Ok::<_, EncodeError>(body.len())
            })
            .expect("small enough to pack")
            .expect("written");
            assert_eq!(written, len);
            let expected: Vec<u8> = (0..len).map(|i| i as u8 ^ 0x5a).collect();
            assert_eq!(body.to_bytes().as_ref(), expected.as_slice(), "len {len}");
            assert_eq!(tail.to_bytes().as_ref(), &[len as u8; ATTACHMENT_LEN]);
        }
        let mut called = false;
        let too_long = packed(largest + 1, |_, _| {
            called = true;
            Ok::<_, EncodeError>(())
        });
        assert!(too_long.is_none());
        assert!(!called);
    }

    /// A write that fails gives its error back.
    #[test]
    fn a_failed_write_is_returned() {
        let failed = packed(10, |_, _| {
            Err::<(), _>(EncodeError::new(EncodeErrorKind::LengthOverflow { len: 7 }))
        });
        match failed {
            Some(Err(e)) => assert!(matches!(
                e.kind(),
                EncodeErrorKind::LengthOverflow { len: 7 }
            )),
            _ => panic!("expected the write's error"),
        }
    }
}
