//! One MCAP chunk's records, read within bounds. A chunk index and a chunk
//! header are what the file says: the offsets are checked against the file,
//! the declared size against [`MAX_CHUNK_SIZE`], and a compressed chunk is
//! decompressed into memory that grows with what actually comes out, so a
//! damaged or hostile file costs at most its real contents.

use std::borrow::Cow;
use std::io::Read;
#[cfg(test)]
use std::ops::ControlFlow;

use mcap::records::{op, ChunkHeader, ChunkIndex, Record};

/// The most bytes a chunk may hold decompressed: more than any message a
/// ROS 2 transport carries (Zenoh's default limit is 1 GiB).
pub(crate) const MAX_CHUNK_SIZE: u64 = 1 << 30;

/// The records of the chunk `index` points at in `file`, decompressed into
/// `scratch` if they are compressed, their CRC checked where it is given.
pub(crate) fn records<'a>(
    file: &'a [u8],
    index: &ChunkIndex,
    scratch: &'a mut Vec<u8>,
) -> Result<&'a [u8], String> {
    let record = usize::try_from(index.chunk_start_offset)
        .ok()
        .zip(
            index
                .chunk_start_offset
                .checked_add(index.chunk_length)
                .and_then(|end| usize::try_from(end).ok()),
        )
        .and_then(|(start, end)| file.get(start..end))
        .ok_or_else(|| {
            format!(
                "a chunk index points past the file's end (offset {}, length {})",
                index.chunk_start_offset, index.chunk_length
            )
        })?;
    let not_a_chunk = || format!("no chunk at offset {}", index.chunk_start_offset);
    let (&opcode, rest) = record.split_first().ok_or_else(not_a_chunk)?;
    let (len, body) = rest.split_first_chunk::<8>().ok_or_else(not_a_chunk)?;
    let body = usize::try_from(u64::from_le_bytes(*len))
        .ok()
        .and_then(|len| body.get(..len))
        .filter(|_| opcode == op::CHUNK)
        .ok_or_else(not_a_chunk)?;
    let (header, data) = match mcap::parse_record(op::CHUNK, body) {
        Ok(Record::Chunk {
            header,
            data: Cow::Borrowed(data),
        }) => (header, data),
        Ok(_) => return Err(not_a_chunk()),
        Err(e) => return Err(format!("chunk at offset {}: {e}", index.chunk_start_offset)),
    };
    contents(&header, data, scratch)
}

/// The records a chunk holds: `data` itself, or decompressed into `scratch`;
/// checked against the size and CRC its header declares.
pub(crate) fn contents<'a>(
    header: &ChunkHeader,
    data: &'a [u8],
    scratch: &'a mut Vec<u8>,
) -> Result<&'a [u8], String> {
    let size = header.uncompressed_size;
    if size > MAX_CHUNK_SIZE {
        return Err(format!(
            "a chunk declares {size} bytes decompressed, more than {MAX_CHUNK_SIZE} are read"
        ));
    }
    let records: &[u8] = match header.compression.as_str() {
        "" => data,
        compression => {
            scratch.clear();
            let read = match compression {
                "zstd" => zstd::stream::read::Decoder::new(data)
                    .and_then(|d| d.take(size + 1).read_to_end(scratch)),
                "lz4" => {
                    lz4::Decoder::new(data).and_then(|d| d.take(size + 1).read_to_end(scratch))
                }
                other => return Err(format!("chunk compression `{other}` is not read")),
            };
            read.map_err(|e| format!("a {compression} chunk does not decompress: {e}"))?;
            scratch
        }
    };
    if records.len() as u64 != size {
        return Err(format!(
            "a chunk holds {} bytes of records, not the {size} it declares",
            records.len()
        ));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(records);
        if crc != header.uncompressed_crc {
            return Err(format!(
                "a chunk's CRC is {crc:#010x}, not the {:#010x} it declares: the file is damaged",
                header.uncompressed_crc
            ));
        }
    }
    Ok(records)
}

#[cfg(test)]
/// Give `each` every message among `records` (a chunk's contents): its
/// channel, log time and bytes, until it breaks.
pub(crate) fn each_message<T>(
    records: &[u8],
    each: &mut impl FnMut(u16, u64, &[u8]) -> ControlFlow<T>,
) -> Result<Option<T>, mcap::McapError> {
    for record in mcap::read::LinearReader::sans_magic(records) {
        if let Record::Message { header, data } = record? {
            if let ControlFlow::Break(ended) = each(header.channel_id, header.log_time, &data) {
                return Ok(Some(ended));
            }
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::writer::tests::topic;
    use crate::{BagWriter, Compression, WriteOptions};

    /// A recording of a few messages in small chunks, as file bytes.
    fn recording(compression: Option<Compression>) -> Vec<u8> {
        let dir = std::env::temp_dir().join(format!(
            "shm-bag-chunk-{}-{compression:?}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        let options = WriteOptions {
            compression,
            chunk_size: 64,
            ..Default::default()
        };
        let mut writer = BagWriter::create(&dir, options).unwrap();
        let topic = writer.add_topic(topic("/chatter"), String::new()).unwrap();
        for i in 0..4u32 {
            let data = [0, 1, 0, 0, 2, 0, 0, 0, b'a' + i as u8, 0];
            writer
                .write(topic, u64::from(i), u64::from(i), i, &data)
                .unwrap();
        }
        let metadata = writer.finish().unwrap();
        let bytes = std::fs::read(dir.join(&metadata.relative_file_paths[0])).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        bytes
    }

    fn messages(file: &[u8], index: &ChunkIndex) -> Result<usize, String> {
        let mut scratch = Vec::new();
        let records = records(file, index, &mut scratch)?;
        let mut count = 0;
        each_message(records, &mut |_, _, _| {
            count += 1;
            ControlFlow::<()>::Continue(())
        })
        .map_err(|e| e.to_string())?;
        Ok(count)
    }

    #[test]
    fn chunks_are_read_and_damage_is_refused_with_the_reason() {
        for compression in [None, Some(Compression::Zstd), Some(Compression::Lz4)] {
            let file = recording(compression);
            let summary = mcap::Summary::read(&file).unwrap().unwrap();
            let total: usize = summary
                .chunk_indexes
                .iter()
                .map(|index| messages(&file, index).unwrap())
                .sum();
            assert_eq!(total, 4, "{compression:?}");
            let index = summary.chunk_indexes.last().unwrap().clone();

            // An index that points past the end, or overflows.
            let mut past = index.clone();
            past.chunk_length = file.len() as u64;
            assert!(messages(&file, &past)
                .unwrap_err()
                .contains("past the file's end"));
            past.chunk_start_offset = u64::MAX;
            assert!(messages(&file, &past)
                .unwrap_err()
                .contains("past the file's end"));
        }
    }

    #[test]
    fn a_chunk_whose_crc_differs_is_refused() {
        let data = [1u8, 2, 3, 4];
        let header = ChunkHeader {
            message_start_time: 0,
            message_end_time: 0,
            uncompressed_size: 4,
            uncompressed_crc: crc32fast::hash(&data),
            compression: String::new(),
            compressed_size: 4,
        };
        assert_eq!(contents(&header, &data, &mut Vec::new()), Ok(&data[..]));
        let damaged = [1u8, 2, 3, 5];
        let error = contents(&header, &damaged, &mut Vec::new()).unwrap_err();
        assert!(error.contains("CRC"), "{error}");
    }

    #[test]
    fn a_declared_size_past_the_limit_is_refused_before_anything_is_read() {
        let header = ChunkHeader {
            message_start_time: 0,
            message_end_time: 0,
            uncompressed_size: MAX_CHUNK_SIZE + 1,
            uncompressed_crc: 0,
            compression: "zstd".into(),
            compressed_size: 4,
        };
        let error = contents(&header, &[0; 4], &mut Vec::new()).unwrap_err();
        assert!(error.contains("more than 1073741824"), "{error}");
        // A size declared smaller than what comes out.
        let data = zstd::encode_all(&[7u8; 1000][..], 0).unwrap();
        let header = ChunkHeader {
            uncompressed_size: 10,
            compressed_size: data.len() as u64,
            ..header
        };
        let error = contents(&header, &data, &mut Vec::new()).unwrap_err();
        assert!(error.contains("not the 10"), "{error}");
    }
}
