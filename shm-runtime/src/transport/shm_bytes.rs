//! [`ShmBytes`]: a `uint8[]` field whose bytes the application already wrote into
//! shared memory. Publishing splices that block into the payload as its own
//! fragment instead of copying it.
//!
//! How the splice keeps CDR intact: while a publisher encodes, a shared-memory
//! `ShmBytes` of `len` bytes writes its length prefix and then only `len % 8`
//! filler bytes, and records where its data belongs. Everything after it is thus
//! shifted by a multiple of 8 bytes, so every later alignment is unchanged. The
//! payload is then assembled as: metadata before, the application's block, the
//! metadata after (filler dropped). Sizing and writing are `shm_cdr::splice`'s:
//! what they tally and collect is passed to them, nothing is kept per thread.

use std::any::Any;
use std::ops::Deref;

use shm_cdr::describe::{FieldType, OctetType, TypeId};
use shm_cdr::loan::{Carver, InPlace, LoanError, Uninit};
use shm_cdr::splice::{SpliceSink, SpliceSizing};
use shm_cdr::{ByteOrder, CdrDecode, CdrEncode, DecodeError, EncodeError, Reader, RosType, Writer};
use zenoh::bytes::ZBytes;
use zenoh::shm::{zshm, ZShm, ZShmMut};

use crate::transport::encoded::{EncodedPayload, PayloadKind};

/// Bytes of a `uint8[]` field, in shared memory (published without a copy) or on
/// the heap (e.g. after decoding). Build it with `From`: a [`ZShmMut`] or [`ZShm`]
/// the application wrote, or a `Vec<u8>` / [`bytes::Bytes`].
///
/// The `*Shm` forms of the standard messages (`msgs::sensor_msgs::PointCloud2Shm`,
/// `ImageShm`, …) carry their data in one: points written by the application
/// straight into the pool are published without being copied again
/// ([`PayloadKind::Spliced`]).
///
/// # Example
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
/// use shm_runtime::msgs::sensor_msgs::PointCloud2Shm;
/// use shm_runtime::{RosNode, ShmBytes, ShmConfig, ShmContext};
/// use zenoh::Wait;
///
/// let session = zenoh::open(shm_runtime::rmw::config::session_config()?).wait()?;
/// let shm = ShmContext::new(ShmConfig::enabled())?;
/// let node = RosNode::builder(&session, "lidar").shm(&shm).wait()?;
/// let publisher = node.declare_publisher::<PointCloud2Shm>("points").wait()?;
///
/// // The driver writes its points into the pool, once.
/// let mut block = shm.alloc(1024 * 16).ok_or("no room in the pool")?;
/// block.fill(0);
/// let cloud = PointCloud2Shm {
///     height: 1,
///     width: 1024,
///     point_step: 16,
///     row_step: 1024 * 16,
///     data: ShmBytes::from(zenoh::shm::ZShm::from(block)),
///     ..Default::default()
/// };
/// let outcome = publisher.publish(&cloud).wait()?;
/// println!("{:?}", outcome.kind); // Spliced: the block went as it lies
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, Default)]
pub struct ShmBytes(Repr);

#[derive(Clone, Debug)]
enum Repr {
    /// A shared-memory block written by the application, held as a one-slice
    /// [`ZBytes`]: splicing it into a payload clones an `Arc`, where cloning the
    /// `ZShm` itself would take a reference in the shared segment and go through
    /// Zenoh's watchdog confirmator (twice per publish, clone and drop).
    Shm(ZBytes),
    /// Ordinary bytes.
    Heap(bytes::Bytes),
}

impl Default for Repr {
    fn default() -> Self {
        Self::Heap(bytes::Bytes::new())
    }
}

impl ShmBytes {
    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        match &self.0 {
            // One slice by construction (`From<ZShm>`); an empty block has none.
            Repr::Shm(block) => block.slices().next().unwrap_or_default(),
            Repr::Heap(bytes) => bytes,
        }
    }

    /// Whether the bytes are in shared memory.
    pub fn is_shm(&self) -> bool {
        matches!(self.0, Repr::Shm(_))
    }

    /// The shared-memory block, if the bytes are in one.
    pub fn as_shm(&self) -> Option<&zshm> {
        match &self.0 {
            Repr::Shm(block) => block.as_shm(),
            Repr::Heap(_) => None,
        }
    }
}

impl Deref for ShmBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.as_slice()
    }
}

impl PartialEq for ShmBytes {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl From<ZShmMut> for ShmBytes {
    fn from(buffer: ZShmMut) -> Self {
        Self(Repr::Shm(ZBytes::from(buffer)))
    }
}

impl From<ZShm> for ShmBytes {
    fn from(buffer: ZShm) -> Self {
        Self(Repr::Shm(ZBytes::from(buffer)))
    }
}

impl From<Vec<u8>> for ShmBytes {
    fn from(bytes: Vec<u8>) -> Self {
        Self(Repr::Heap(bytes.into()))
    }
}

impl From<bytes::Bytes> for ShmBytes {
    fn from(bytes: bytes::Bytes) -> Self {
        Self(Repr::Heap(bytes))
    }
}

impl CdrEncode for ShmBytes {
    const SPLICES: bool = true;

    fn encoded_end(&self, start: usize) -> usize {
        shm_cdr::layout::align_up(start, 4) + 4 + self.len()
    }

    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        w.write_len(self.len())?;
        w.write_bytes(self)
    }

    /// A block in shared memory is left out of the buffer, filler of its
    /// length modulo 8 in its place.
    fn spliced_end(&self, start: usize, sizing: &mut SpliceSizing) -> usize {
        let data_start = shm_cdr::layout::align_up(start, 4) + 4;
        if self.is_shm() {
            data_start + sizing.leave_out(self.len())
        } else {
            data_start + self.len()
        }
    }

    fn encode_spliced<B: ByteOrder>(
        &self,
        w: &mut Writer<'_, B>,
        sink: &mut dyn SpliceSink,
    ) -> Result<(), EncodeError> {
        w.write_len(self.len())?;
        if let Repr::Shm(block) = &self.0 {
            if sink.splice(w.position(), block) {
                // Filler with the data's length modulo 8 keeps later alignment.
                return w.write_bytes(&[0u8; 8][..self.len() % 8]);
            }
        }
        w.write_bytes(self)
    }
}

/// In place, a `uint8[]` run written straight into the loaned buffer (a loan has
/// no need to splice: its bytes are already in shared memory).
impl InPlace for ShmBytes {
    type Lens = usize;
    type Mut<'a> = Uninit<'a, u8>;

    fn lens(&self) -> usize {
        self.len()
    }

    fn end_in_place(lens: &usize, start: usize) -> Option<usize> {
        <Vec<u8> as InPlace>::end_in_place(lens, start)
    }

    fn carve<'a>(lens: &usize, c: &mut Carver<'a>) -> Result<Uninit<'a, u8>, LoanError> {
        <Vec<u8> as InPlace>::carve(lens, c)
    }

    fn write_in_place(&self, place: Uninit<'_, u8>) -> Result<(), LoanError> {
        place.write_slice(self).map(drop)
    }
}

/// Decoding copies onto the heap; to borrow the bytes of a received sample
/// (shared memory included) decode into a type with a `&[u8]` field instead.
impl<'de> CdrDecode<'de> for ShmBytes {
    const MIN_WIRE_SIZE: usize = 4;

    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        <&[u8]>::decode(r).map(|bytes| Self(Repr::Heap(bytes::Bytes::copy_from_slice(bytes))))
    }
}

impl RosType for ShmBytes {
    const FIELD_TYPE: FieldType = FieldType::scalar(TypeId::Uint8).unbounded_sequence();
}

impl OctetType for ShmBytes {}

/// The result of [`encode_spliced`].
pub(crate) enum Splice {
    /// The message holds shared-memory fields: here is the assembled payload.
    Done(EncodedPayload),
    /// It holds none; its exact encoded size, for the ordinary paths.
    NotNeeded(usize),
}

/// The shared-memory blocks a splicing write leaves out, with the body
/// position each belongs at, in stream order.
#[derive(Default)]
struct Splices(Vec<(usize, ZBytes)>);

impl SpliceSink for Splices {
    fn splice(&mut self, at: usize, run: &dyn Any) -> bool {
        match run.downcast_ref::<ZBytes>() {
            Some(block) => {
                self.0.push((at, block.clone()));
                true
            }
            None => false,
        }
    }
}

/// Encode a message that holds shared-memory [`ShmBytes`] as heap metadata around
/// the untouched blocks. Sizes the message once either way.
pub(crate) fn encode_spliced<T: CdrEncode + ?Sized>(msg: &T) -> Result<Splice, EncodeError> {
    if !T::SPLICES {
        return Ok(Splice::NotNeeded(shm_cdr::encoded_size(msg)));
    }
    let (reduced, sizing) = shm_cdr::splice::spliced_size(msg);
    if sizing.runs == 0 {
        return Ok(Splice::NotNeeded(reduced));
    }
    let mut buffer = vec![0u8; reduced];
    let mut splices = Splices::default();
    let written = shm_cdr::splice::encode_spliced_into(msg, &mut buffer, &mut splices)?;
    let metadata = bytes::Bytes::from(buffer);
    let mut payload = ZBytes::writer();
    let mut cursor = 0;
    for (body_pos, block) in splices.0 {
        let at = shm_cdr::HEADER_LEN + body_pos;
        payload.append(ZBytes::from(metadata.slice(cursor..at)));
        cursor = at + block.len() % 8;
        payload.append(block);
    }
    payload.append(ZBytes::from(metadata.slice(cursor..written)));
    Ok(Splice::Done(EncodedPayload {
        bytes: payload.finish(),
        kind: PayloadKind::Spliced,
        size: reduced + sizing.left_out,
        inline: written,
    }))
}

#[cfg(test)]
mod tests {
    use arbitrary::{Arbitrary, Unstructured};
    use shm_cdr::{msgs, RosMessage};

    use super::{encode_spliced, Splice};
    use crate::msgs::{sensor_msgs, std_msgs};

    /// Deterministic pseudo-random input for `Arbitrary`.
    fn noise(seed: u64, len: usize) -> Vec<u8> {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..len)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state as u8
            })
            .collect()
    }

    /// Every generated `…Shm` form is its owned form on the wire: same name, same
    /// hash, same fields, same exact size and bytes, and it decodes back.
    fn same_as_owned<Owned, Shm>()
    where
        Owned: RosMessage + for<'a> Arbitrary<'a> + Clone,
        Shm: RosMessage + From<Owned> + shm_cdr::DecodeOwned + PartialEq + std::fmt::Debug,
    {
        assert_eq!(Owned::TYPE_NAME, Shm::TYPE_NAME);
        assert_eq!(Owned::type_hash(), Shm::type_hash(), "{}", Owned::TYPE_NAME);
        assert_eq!(Owned::FIELDS, Shm::FIELDS);
        let mut checked = 0;
        for seed in 0..200 {
            let input = noise(seed, 64 + seed as usize * 40);
            let Ok(owned) = Owned::arbitrary(&mut Unstructured::new(&input)) else {
                continue;
            };
            let shm = Shm::from(owned.clone());
            let bytes = shm_cdr::to_vec(&owned).expect("encodes");
            assert_eq!(shm_cdr::to_vec(&shm).expect("encodes"), bytes);
            assert_eq!(shm_cdr::encoded_size(&shm), bytes.len());
            assert_eq!(shm_cdr::from_bytes::<Shm>(&bytes).expect("decodes"), shm);
            checked += 1;
        }
        assert!(checked > 100, "{}: only {checked} values", Owned::TYPE_NAME);
    }

    #[test]
    fn shm_forms_match_their_owned_forms() {
        same_as_owned::<msgs::sensor_msgs::Image, sensor_msgs::ImageShm>();
        same_as_owned::<msgs::sensor_msgs::CompressedImage, sensor_msgs::CompressedImageShm>();
        same_as_owned::<msgs::sensor_msgs::PointCloud2, sensor_msgs::PointCloud2Shm>();
        same_as_owned::<msgs::std_msgs::ByteMultiArray, std_msgs::ByteMultiArrayShm>();
        same_as_owned::<msgs::std_msgs::UInt8MultiArray, std_msgs::UInt8MultiArrayShm>();
    }

    /// A block held by `ShmBytes` is the application's chunk itself: reading,
    /// cloning and splicing it never copy, and the spliced payload is byte for
    /// byte the message's CDR.
    #[test]
    fn shared_memory_block_is_read_cloned_and_spliced_in_place() {
        use crate::{ShmConfig, ShmContext};

        let shm = ShmContext::new(ShmConfig::enabled()).expect("pool");
        let mut block = shm.alloc(1001).expect("chunk");
        for (i, b) in block.iter_mut().enumerate() {
            *b = i as u8;
        }
        let chunk = block.as_ptr_range();
        let data = crate::ShmBytes::from(block);
        assert!(data.is_shm());
        assert_eq!(data.as_slice().as_ptr_range(), chunk);
        assert_eq!(data.as_shm().map(|b| b.as_ptr()), Some(chunk.start));
        assert_eq!(data.clone().as_slice().as_ptr_range(), chunk);
        assert!(crate::ShmBytes::from(vec![1, 2]).as_shm().is_none());

        let msg = std_msgs::UInt8MultiArrayShm {
            data: data.clone(),
            ..Default::default()
        };
        let Splice::Done(payload) = encode_spliced(&msg).expect("encodes") else {
            panic!("a shared-memory field must be spliced");
        };
        let slices: Vec<&[u8]> = payload.bytes.slices().collect();
        // Metadata, then the block (the data is the last field: no tail).
        assert_eq!(slices.len(), 2);
        assert_eq!(slices[1].as_ptr_range(), chunk);
        let owned = msgs::std_msgs::UInt8MultiArray {
            data: data.to_vec(),
            ..Default::default()
        };
        assert_eq!(slices.concat(), shm_cdr::to_vec(&owned).expect("encodes"));
        assert_eq!(payload.size, slices.concat().len());
    }

    /// One block per field, in a struct, in a sequence of structs, beside
    /// heap bytes, at every length modulo 8: the spliced payload is byte for
    /// byte the ordinary encoding, and each block goes in as itself.
    #[test]
    fn blocks_anywhere_in_a_message_splice_into_its_encoding() {
        use crate::{ShmBytes, ShmConfig, ShmContext};

        #[derive(shm_cdr::RosMessage, Clone, Debug, PartialEq, Default)]
        #[ros(type_name = "test_msgs/msg/SplicedPart")]
        struct Part {
            tag: u8,
            data: ShmBytes,
        }

        #[derive(shm_cdr::RosMessage, Clone, Debug, PartialEq, Default)]
        #[ros(type_name = "test_msgs/msg/SplicedWhole")]
        struct Whole {
            head: u8,
            first: ShmBytes,
            stamp: f64,
            parts: Vec<Part>,
            tail: u16,
        }

        let shm = ShmContext::new(ShmConfig::enabled()).expect("pool");
        let block = |len: usize, seed: u8| -> ShmBytes {
            let mut chunk = shm.alloc(len).expect("chunk");
            for (i, b) in chunk.iter_mut().enumerate() {
                *b = seed.wrapping_add(i as u8);
            }
            ShmBytes::from(chunk)
        };
        for first_len in [1, 7, 8, 13] {
            for part_len in [3, 8, 9, 16] {
                let msg = Whole {
                    head: 0xA5,
                    first: block(first_len, 1),
                    stamp: 1.5,
                    parts: vec![
                        Part {
                            tag: 1,
                            data: block(part_len, 2),
                        },
                        Part {
                            tag: 2,
                            data: ShmBytes::from(vec![9; part_len]),
                        },
                        Part {
                            tag: 3,
                            data: block(part_len + 5, 3),
                        },
                    ],
                    tail: 0xBEEF,
                };
                let expected = shm_cdr::to_vec(&msg).expect("encodes");
                let Splice::Done(payload) = encode_spliced(&msg).expect("encodes") else {
                    panic!("shared-memory fields must be spliced");
                };
                assert_eq!(payload.kind, crate::PayloadKind::Spliced);
                let slices: Vec<&[u8]> = payload.bytes.slices().collect();
                assert_eq!(slices.concat(), expected, "{first_len} {part_len}");
                assert_eq!(payload.size, expected.len());
                let blocks = [&msg.first, &msg.parts[0].data, &msg.parts[2].data];
                for data in blocks {
                    let range = data.as_slice().as_ptr_range();
                    assert!(
                        slices.iter().any(|s| s.as_ptr_range() == range),
                        "a block was copied ({first_len} {part_len})"
                    );
                }
                assert_eq!(
                    payload.inline,
                    expected.len() - blocks.iter().map(|b| b.len() - b.len() % 8).sum::<usize>()
                );
            }
        }

        // Without a block in shared memory, nothing is spliced.
        let heap = Whole {
            first: ShmBytes::from(vec![1, 2, 3]),
            ..Default::default()
        };
        assert!(matches!(
            encode_spliced(&heap).expect("encodes"),
            Splice::NotNeeded(n) if n == shm_cdr::encoded_size(&heap)
        ));
    }
}
