//! Rebuilding a recording whose writer did not finish (a crash, `kill -9`, a
//! power cut, a full disk), as `ros2 bag reindex` does for rosbag2's bags:
//! each MCAP file without a summary is written anew from its complete
//! records (a chunk cut off or failing its CRC is left out and counted), the
//! unfinished file is kept beside it as `<name>.unfinished`, and
//! `metadata.yaml` is rebuilt from the files.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use mcap::records::{MessageHeader, Record};

use crate::bag::Bag;
use crate::metadata::{
    BagMetadata, FileInformation, Nanoseconds, NanosecondsSinceEpoch, FILE_NAME,
};
use crate::writer::ChannelCopy;
use crate::Error;

/// What [`reindex`] did to one file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileReport {
    /// The file.
    pub path: PathBuf,
    /// Whether it was written anew (it had no summary); the unfinished file
    /// is kept as `<name>.unfinished`.
    pub rewritten: bool,
    /// Messages it holds now.
    pub messages: u64,
    /// Chunks left out because their CRC or their compressed data was wrong.
    pub damaged_chunks: u64,
    /// Where each damaged chunk lay (its offset, log times) and what was
    /// wrong with it.
    pub damage: Vec<String>,
    /// Why reading stopped before the end of the file, if it did: the end
    /// of a file cut off mid-record (all that follows is lost).
    pub cut: Option<String>,
}

/// What [`reindex`] did.
#[derive(Debug, Clone)]
pub struct Reindexed {
    /// Each file, in order.
    pub files: Vec<FileReport>,
    /// The `metadata.yaml` written.
    pub metadata: BagMetadata,
}

/// Make the bag directory `dir` whole again: rewrite each MCAP file that has
/// no summary from the records it holds, and `metadata.yaml` from the files.
/// Files that are whole are left as they are. The files are those
/// `metadata.yaml` lists, or, without a readable one, every `*.mcap` in the
/// directory.
pub fn reindex(dir: &Path) -> Result<Reindexed, Error> {
    if !dir.is_dir() {
        return Err(format!("{}: not a bag directory", dir.display()).into());
    }
    let old = BagMetadata::read(dir).ok();
    let names = match &old {
        Some(metadata) => {
            // `Bag::open` checks that the names stay inside the directory.
            Bag::open(dir)?;
            metadata.relative_file_paths.clone()
        }
        None => mcap_files(dir)?,
    };
    if names.is_empty() {
        return Err(format!("{}: no MCAP files to reindex", dir.display()).into());
    }
    let mut reports = Vec::with_capacity(names.len());
    let mut files = Vec::with_capacity(names.len());
    for name in &names {
        let path = dir.join(name);
        let report = recover(&path)?;
        files.push(file_information(name, &path)?);
        reports.push(report);
    }
    let lone = Bag::from_files(names.iter().map(|n| dir.join(n)).collect());
    let mut metadata = lone.describe()?;
    metadata.relative_file_paths = names;
    metadata.files = files;
    if let Some(old) = old {
        metadata.ros_distro = old.ros_distro;
        metadata.custom_data = old.custom_data;
    }
    // Written beside it and moved over it: a full disk leaves the old one.
    let path = dir.join(FILE_NAME);
    let partial = sibling(&path, ".reindex-partial");
    let written = std::fs::write(&partial, metadata.to_yaml())
        .and_then(|()| File::open(&partial)?.sync_all())
        .and_then(|()| std::fs::rename(&partial, &path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&partial);
        return Err(format!("cannot write {}: {e}", path.display()).into());
    }
    Ok(Reindexed {
        files: reports,
        metadata,
    })
}

/// The `*.mcap` files of `dir` in recording order (`<base>_<n>.mcap` by `n`).
fn mcap_files(dir: &Path) -> Result<Vec<String>, Error> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map_err(|e| format!("cannot list {}: {e}", dir.display()))?
        .filter_map(Result::ok)
        .filter(|e| e.path().is_file())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|n| n.ends_with(".mcap"))
        .collect();
    names.sort_by_key(|n| (n.len(), n.clone()));
    Ok(names)
}

/// One file's facts for `metadata.yaml`, from its summary.
fn file_information(name: &str, path: &Path) -> Result<FileInformation, Error> {
    let stats = read_summary(path)?.and_then(|s| s.stats);
    let (start, end, count) = stats.map_or((0, 0, 0), |s| {
        (s.message_start_time, s.message_end_time, s.message_count)
    });
    Ok(FileInformation {
        path: name.to_owned(),
        starting_time: NanosecondsSinceEpoch {
            nanoseconds_since_epoch: start,
        },
        duration: Nanoseconds {
            nanoseconds: end.saturating_sub(start),
        },
        message_count: count,
    })
}

/// The file's summary, if it has one: read from the map, which touches only
/// the file's end.
fn read_summary(path: &Path) -> Result<Option<mcap::Summary>, Error> {
    let map = crate::storage::map_file(path)?;
    Ok(mcap::Summary::read(&map).unwrap_or(None))
}

/// The most bytes one record of a file may hold: a chunk at the read limit
/// with its header and a compression that did not shrink it.
const MAX_RECORD: u64 = crate::chunk::MAX_CHUNK_SIZE + (1 << 20);

/// A file's records one at a time, read from the file in order: memory holds
/// one record (a chunk at most), whatever the file's size.
struct RecordStream {
    reader: std::io::BufReader<File>,
    /// Where the next record starts, and where the file ends.
    offset: u64,
    len: u64,
}

impl RecordStream {
    fn open(path: &Path) -> Result<Self, Error> {
        use std::io::Read;
        let file = File::open(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        let len = file
            .metadata()
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?
            .len();
        let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
        let mut magic = [0u8; 8];
        let magic_ok = reader.read_exact(&mut magic).is_ok() && magic[..] == *mcap::MAGIC;
        if !magic_ok {
            return Err(format!("{}: not an MCAP file (no MCAP magic)", path.display()).into());
        }
        Ok(Self {
            reader,
            offset: mcap::MAGIC.len() as u64,
            len,
        })
    }

    /// The next record's opcode, its body in `body`; `Ok(None)` at the end of
    /// the data (the file's end, a footer or the end of data); `Err` with
    /// where and why for a file cut inside a record.
    fn next(&mut self, body: &mut Vec<u8>) -> Result<Option<u8>, String> {
        use std::io::Read;
        let left = self.len.saturating_sub(self.offset);
        if left == 0 {
            return Ok(None);
        }
        let at = self.offset;
        if left < 9 {
            return Err(format!(
                "{left} bytes at offset {at}, less than a record header"
            ));
        }
        let mut header = [0u8; 9];
        self.reader
            .read_exact(&mut header)
            .map_err(|e| format!("at offset {at}: {e}"))?;
        let opcode = header[0];
        let mut length = [0u8; 8];
        length.copy_from_slice(&header[1..]);
        let length = u64::from_le_bytes(length);
        // Checked before anything is allocated from it.
        if length > left - 9 {
            return Err(format!(
                "a record at offset {at} declares {length} bytes, and the file ends {} bytes on",
                left - 9
            ));
        }
        if length > MAX_RECORD {
            return Err(format!(
                "a record at offset {at} declares {length} bytes, more than the {MAX_RECORD} read"
            ));
        }
        body.clear();
        let read = (&mut self.reader)
            .take(length)
            .read_to_end(body)
            .map_err(|e| format!("at offset {at}: {e}"))?;
        if read as u64 != length {
            return Err(format!("a record at offset {at} is cut short"));
        }
        self.offset = at + 9 + length;
        if matches!(
            opcode,
            mcap::records::op::FOOTER | mcap::records::op::DATA_END
        ) {
            return Ok(None);
        }
        Ok(Some(opcode))
    }
}

/// Rewrite `path` from its intact records if it has no summary or a chunk
/// of it is damaged; a file that is whole is left as it is. The file is read
/// as a stream: memory holds a chunk at a time, not the file.
fn recover(path: &Path) -> Result<FileReport, Error> {
    if let Some(summary) = read_summary(path)? {
        let damaged = damaged_chunks(path)?;
        if damaged.is_empty() {
            return Ok(FileReport {
                path: path.to_owned(),
                rewritten: false,
                messages: summary.stats.map_or(0, |s| s.message_count),
                damaged_chunks: 0,
                damage: Vec::new(),
                cut: None,
            });
        }
    }
    // The file's profile and its chunks' compression carry over.
    let mut profile = String::from("ros2");
    let mut compression = None;
    let mut stream = RecordStream::open(path)?;
    let mut body = Vec::new();
    while let Ok(Some(opcode)) = stream.next(&mut body) {
        match mcap::parse_record(opcode, &body) {
            Ok(Record::Header(header)) => profile = header.profile,
            Ok(Record::Chunk { header, .. }) => {
                compression = match header.compression.as_str() {
                    "zstd" => Some(mcap::Compression::Zstd),
                    "lz4" => Some(mcap::Compression::Lz4),
                    _ => None,
                };
                break;
            }
            _ => {}
        }
    }
    let partial = sibling(path, ".reindex-partial");
    let written = write_recovered(path, &partial, profile, compression);
    let report = match written {
        Ok(report) => report,
        Err(e) => {
            // The original stays as it was, and no partial copy is left.
            let _ = std::fs::remove_file(&partial);
            return Err(e);
        }
    };
    let unfinished = sibling(path, ".unfinished");
    std::fs::rename(path, &unfinished)
        .and_then(|()| std::fs::rename(&partial, path))
        .map_err(|e| format!("cannot replace {}: {e}", path.display()))?;
    Ok(report)
}

/// Where each damaged chunk of a finished file lies: the chunks its CRC or
/// its compressed data disowns, read one at a time.
fn damaged_chunks(path: &Path) -> Result<Vec<String>, Error> {
    let mut stream = RecordStream::open(path)?;
    let (mut body, mut scratch) = (Vec::new(), Vec::new());
    let mut damaged = Vec::new();
    loop {
        let at = stream.offset;
        match stream.next(&mut body) {
            Ok(Some(mcap::records::op::CHUNK)) => {}
            Ok(Some(_)) => continue,
            Ok(None) => break,
            Err(e) => {
                damaged.push(e);
                break;
            }
        }
        let why = match mcap::parse_record(mcap::records::op::CHUNK, &body) {
            Ok(Record::Chunk { header, data }) => {
                match crate::chunk::contents(&header, &data, &mut scratch) {
                    Ok(_) => continue,
                    Err(e) => format!(
                        "{e} (log times {} to {})",
                        header.message_start_time, header.message_end_time
                    ),
                }
            }
            Ok(_) => continue,
            Err(e) => e.to_string(),
        };
        damaged.push(format!("chunk at offset {at}: {why}"));
    }
    Ok(damaged)
}

/// Write the intact records of `path` into the new file `partial`: flushed
/// and synced, so that every write error (a full disk) is seen here, in the
/// OS's words, before the original is replaced.
fn write_recovered(
    path: &Path,
    partial: &Path,
    profile: String,
    compression: Option<mcap::Compression>,
) -> Result<FileReport, Error> {
    let where_ = |e: &dyn std::fmt::Display| format!("{}: {e}", partial.display());
    let file =
        File::create(partial).map_err(|e| format!("cannot create {}: {e}", partial.display()))?;
    let mut writer = mcap::WriteOptions::new()
        .profile(profile)
        .library(concat!(
            "shm-bag ",
            env!("CARGO_PKG_VERSION"),
            " (reindexed)"
        ))
        .compression(compression)
        .create(BufWriter::new(file))
        .map_err(|e| where_(&crate::writer::mcap_error(e)))?;
    let mut copy = Copy::default();
    let mut report = FileReport {
        path: path.to_owned(),
        rewritten: true,
        messages: 0,
        damaged_chunks: 0,
        damage: Vec::new(),
        cut: None,
    };
    let mut stream = RecordStream::open(path)?;
    let (mut body, mut scratch) = (Vec::new(), Vec::new());
    loop {
        let at = stream.offset;
        let opcode = match stream.next(&mut body) {
            Ok(Some(opcode)) => opcode,
            Ok(None) => break,
            Err(e) => {
                report.cut = Some(e);
                break;
            }
        };
        let record = match mcap::parse_record(opcode, &body) {
            Ok(record) => record,
            Err(e) => {
                report.cut = Some(format!("a record at offset {at} does not parse: {e}"));
                break;
            }
        };
        match record {
            Record::Chunk { header, data } => {
                let contents = match crate::chunk::contents(&header, &data, &mut scratch) {
                    Ok(contents) => contents,
                    Err(e) => {
                        report.damaged_chunks += 1;
                        report.damage.push(format!("chunk at offset {at}: {e}"));
                        continue;
                    }
                };
                // A chunk is kept whole or not at all.
                let inner: Result<Vec<Record<'_>>, _> =
                    mcap::read::LinearReader::sans_magic(contents).collect();
                match inner {
                    Ok(inner) => {
                        for record in inner {
                            report.messages += copy.record(&mut writer, record, partial)?;
                        }
                    }
                    Err(e) => {
                        report.damaged_chunks += 1;
                        report.damage.push(format!("chunk at offset {at}: {e}"));
                    }
                }
            }
            other => report.messages += copy.record(&mut writer, other, partial)?,
        }
    }
    writer
        .finish()
        .map_err(|e| where_(&crate::writer::mcap_error(e)))?;
    let file = writer
        .into_inner()
        .into_inner()
        .map_err(|e| where_(&e.into_error()))?;
    file.sync_all().map_err(|e| where_(&e))?;
    Ok(report)
}

/// `path` with `suffix` added to its file name.
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(suffix);
    path.with_file_name(name)
}

/// Schemas and channels carried from the old file to the new one.
#[derive(Default)]
struct Copy {
    /// Old schema id → its record.
    schemas: BTreeMap<u16, (String, String, Vec<u8>)>,
    /// Old channel id → its record.
    channels: BTreeMap<u16, (u16, String, String, BTreeMap<String, String>)>,
    /// Old channel id → the new one, once a message needed it.
    added: BTreeMap<u16, u16>,
}

impl Copy {
    /// Carry `record` over; returns 1 for a message written.
    fn record(
        &mut self,
        writer: &mut mcap::Writer<BufWriter<File>>,
        record: Record<'_>,
        path: &Path,
    ) -> Result<u64, Error> {
        let bad =
            |e: mcap::McapError| format!("{}: {}", path.display(), crate::writer::mcap_error(e));
        match record {
            Record::Schema { header, data } => {
                self.schemas
                    .insert(header.id, (header.name, header.encoding, data.into_owned()));
            }
            Record::Channel(channel) => {
                self.channels.insert(
                    channel.id,
                    (
                        channel.schema_id,
                        channel.topic,
                        channel.message_encoding,
                        channel.metadata,
                    ),
                );
            }
            Record::Metadata(metadata) => match ChannelCopy::read(&metadata) {
                // Kept only where its own records are lost; the new file
                // gets its own copy when the channel is added to it.
                Some(described) => {
                    self.schemas.entry(described.schema_id).or_insert((
                        described.schema_name,
                        described.schema_encoding,
                        described.schema_data,
                    ));
                    self.channels.entry(described.channel_id).or_insert((
                        described.schema_id,
                        described.topic,
                        described.message_encoding,
                        described.channel_metadata,
                    ));
                }
                None => writer.write_metadata(&metadata).map_err(bad)?,
            },
            Record::Message { header, data } => {
                let channel_id = match self.added.get(&header.channel_id) {
                    Some(&id) => id,
                    None => {
                        // A message on a channel the file never declared is
                        // no message of the recording.
                        let Some((schema_id, topic, encoding, metadata)) =
                            self.channels.get(&header.channel_id)
                        else {
                            return Ok(0);
                        };
                        let described = self.schemas.get(schema_id);
                        let schema = match described {
                            Some((name, encoding, data)) => {
                                writer.add_schema(name, encoding, data).map_err(bad)?
                            }
                            None => 0,
                        };
                        let id = writer
                            .add_channel(schema, topic, encoding, metadata)
                            .map_err(bad)?;
                        if let Some((name, schema_encoding, data)) = described {
                            writer
                                .write_metadata(&ChannelCopy::describe(
                                    id,
                                    schema,
                                    topic,
                                    encoding,
                                    metadata,
                                    name,
                                    schema_encoding,
                                    data,
                                ))
                                .map_err(bad)?;
                        }
                        self.added.insert(header.channel_id, id);
                        id
                    }
                };
                writer
                    .write_to_known_channel(
                        &MessageHeader {
                            channel_id,
                            ..header
                        },
                        &data,
                    )
                    .map_err(bad)?;
                return Ok(1);
            }
            _ => {}
        }
        Ok(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::writer::tests::topic;
    use crate::{BagWriter, Compression, WriteOptions};

    fn message(i: u32) -> Vec<u8> {
        let mut cdr = vec![0, 1, 0, 0, 9, 0, 0, 0];
        cdr.extend(format!("msg {i:04}").bytes());
        cdr.push(0);
        cdr
    }

    /// A recording whose process died: `flushed` messages reached the OS in
    /// chunks of 10, `more` were still in the open chunk.
    fn crashed(dir: &Path, compression: Option<Compression>, flushed: u32, more: u32) {
        let mut writer = BagWriter::create(
            dir,
            WriteOptions {
                compression,
                chunk_size: 256,
                ..WriteOptions::default()
            },
        )
        .unwrap();
        let id = writer.add_topic(topic("/chatter"), String::new()).unwrap();
        for i in 0..flushed {
            writer
                .write(id, 1_000 + u64::from(i), 0, i, &message(i))
                .unwrap();
        }
        writer.flush().unwrap();
        for i in flushed..flushed + more {
            writer
                .write(id, 1_000 + u64::from(i), 0, i, &message(i))
                .unwrap();
        }
        // What the process had in memory dies with it.
        std::mem::forget(writer);
    }

    fn read_all(dir: &Path) -> Vec<(u64, Vec<u8>)> {
        let mut out = Vec::new();
        Bag::open(dir)
            .unwrap()
            .read_messages(
                0,
                |_| {},
                |_, time, data| {
                    out.push((time, data.to_vec()));
                    std::ops::ControlFlow::<()>::Continue(())
                },
            )
            .unwrap();
        out
    }

    #[test]
    fn an_unfinished_file_is_rewritten_from_its_complete_chunks() {
        let root = std::env::temp_dir().join(format!("shm_bag_reindex_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        for compression in [None, Some(Compression::Zstd), Some(Compression::Lz4)] {
            let dir = root.join(format!("{compression:?}"));
            crashed(&dir, compression, 40, 3);
            let before = BagMetadata::read(&dir).unwrap();
            assert_eq!(before.message_count, 40, "refreshed at the flush");
            let refused = Bag::open(&dir).unwrap().topics().unwrap_err().to_string();
            assert!(refused.contains("bag reindex"), "{refused}");

            let done = reindex(&dir).unwrap();
            assert!(done.files[0].rewritten);
            assert_eq!(done.files[0].messages, 40);
            assert_eq!(done.metadata.message_count, 40);
            assert_eq!(done.metadata.files[0].message_count, 40);
            assert_eq!(done.metadata.topics_with_message_count[0].message_count, 40);
            let read = read_all(&dir);
            let want: Vec<(u64, Vec<u8>)> = (0..40)
                .map(|i| (1_000 + u64::from(i), message(i)))
                .collect();
            assert_eq!(read, want);
            assert!(
                dir.join("bag_0.mcap.unfinished").exists() || {
                    let name = dir.file_name().unwrap().to_string_lossy().into_owned();
                    dir.join(format!("{name}_0.mcap.unfinished")).exists()
                }
            );
            // A second run finds the files whole.
            let again = reindex(&dir).unwrap();
            assert!(!again.files[0].rewritten);
            assert_eq!(read_all(&dir), want);
        }
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn a_damaged_chunk_is_refused_by_the_reader_and_left_out_by_reindex() {
        let root = std::env::temp_dir().join(format!("shm_bag_crc_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = root.join("bag");
        crashed(&dir, None, 40, 0);
        let file = mcap_files(&dir).unwrap().remove(0);
        let path = dir.join(&file);
        let mut bytes = std::fs::read(&path).unwrap();
        // One byte of the first message's text, inside the first chunk.
        let at = bytes.windows(8).position(|w| w == b"msg 0020").unwrap();
        bytes[at + 4] ^= 0x01;
        std::fs::write(&path, &bytes).unwrap();
        let done = reindex(&dir).unwrap();
        assert_eq!(done.files[0].damaged_chunks, 1, "{:?}", done.files);
        // The chunk of message 20 and its neighbours (6 messages) are gone.
        let kept = done.files[0].messages;
        assert!((30..40).contains(&kept), "{kept}");
        let read = read_all(&dir);
        assert_eq!(read.len() as u64, kept);
        assert!(read.iter().all(|(_, data)| !data.ends_with(b"msg 0020\0")));
        assert!(read.iter().any(|(_, data)| data.ends_with(b"msg 0039\0")));

        // A finished file with a damaged chunk: the reader says so.
        let whole = root.join("whole");
        let mut writer = BagWriter::create(&whole, WriteOptions::default()).unwrap();
        let id = writer.add_topic(topic("/chatter"), String::new()).unwrap();
        for i in 0..10 {
            writer.write(id, u64::from(i), 0, i, &message(i)).unwrap();
        }
        let metadata = writer.finish().unwrap();
        let path = whole.join(&metadata.relative_file_paths[0]);
        let mut bytes = std::fs::read(&path).unwrap();
        let at = bytes.windows(8).position(|w| w == b"msg 0005").unwrap();
        bytes[at + 7] ^= 0x01;
        std::fs::write(&path, &bytes).unwrap();
        let mut seen = 0;
        let refused = Bag::open(&whole).unwrap().read_messages(
            0,
            |_| {},
            |_, _, _| {
                seen += 1;
                std::ops::ControlFlow::<()>::Continue(())
            },
        );
        let refused = refused.unwrap_err().to_string();
        assert!(refused.to_lowercase().contains("crc"), "{refused}");
        let _ = std::fs::remove_dir_all(&root);
    }

    /// The schema and channel records live in the first chunk: when that
    /// chunk is damaged, their copies outside the chunks still name the
    /// channel, and every other chunk is recovered.
    #[test]
    fn a_damaged_first_chunk_loses_only_its_own_messages() {
        let root = std::env::temp_dir().join(format!("shm_bag_first_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = root.join("bag");
        crashed(&dir, None, 40, 0);
        let path = dir.join(mcap_files(&dir).unwrap().remove(0));
        let mut bytes = std::fs::read(&path).unwrap();
        let at = bytes.windows(8).position(|w| w == b"msg 0000").unwrap();
        bytes[at + 4] ^= 0x01;
        std::fs::write(&path, &bytes).unwrap();
        let done = reindex(&dir).unwrap();
        let report = &done.files[0];
        assert_eq!(report.damaged_chunks, 1, "{report:?}");
        assert!(report.damage[0].contains("CRC"), "{report:?}");
        let read = read_all(&dir);
        assert_eq!(read.len() as u64, report.messages);
        // The first chunk's few messages are gone, the rest are all there.
        assert!((30..40).contains(&report.messages), "{report:?}");
        assert!(read.iter().all(|(_, data)| !data.ends_with(b"msg 0000\0")));
        let last: Vec<(u64, Vec<u8>)> = (40 - report.messages as u32..40)
            .map(|i| (1_000 + u64::from(i), message(i)))
            .collect();
        assert_eq!(read, last);
        let _ = std::fs::remove_dir_all(&root);
    }

    /// A finished file with a damaged chunk is reported as damaged, with
    /// where, and rewritten with every intact chunk: it reads to its end.
    #[test]
    fn a_finished_file_with_a_damaged_chunk_is_reported_and_rewritten() {
        let root = std::env::temp_dir().join(format!("shm_bag_finished_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = root.join("bag");
        let mut writer = BagWriter::create(
            &dir,
            WriteOptions {
                chunk_size: 256,
                ..WriteOptions::default()
            },
        )
        .unwrap();
        let id = writer.add_topic(topic("/chatter"), String::new()).unwrap();
        for i in 0..40 {
            writer
                .write(id, 1_000 + u64::from(i), 0, i, &message(i))
                .unwrap();
        }
        writer.finish().unwrap();
        let path = dir.join(mcap_files(&dir).unwrap().remove(0));
        let mut bytes = std::fs::read(&path).unwrap();
        let at = bytes.windows(8).position(|w| w == b"msg 0021").unwrap();
        bytes[at + 4] ^= 0x01;
        std::fs::write(&path, &bytes).unwrap();
        let done = reindex(&dir).unwrap();
        let report = &done.files[0];
        assert!(report.rewritten, "{report:?}");
        assert_eq!(report.damaged_chunks, 1, "{report:?}");
        assert!(
            report.damage[0].starts_with("chunk at offset "),
            "{report:?}"
        );
        let read = read_all(&dir);
        assert_eq!(read.len() as u64, report.messages);
        assert!((30..40).contains(&report.messages), "{report:?}");
        assert!(read.iter().any(|(_, data)| data.ends_with(b"msg 0039\0")));
        assert_eq!(done.metadata.message_count, report.messages);
        let _ = std::fs::remove_dir_all(&root);
    }

    /// On a full disk (a small tmpfs, where this process may mount one),
    /// reindex names the OS error and leaves the unfinished file as it was,
    /// with no partial copy beside it.
    #[test]
    fn reindex_on_a_full_disk_names_the_error_and_leaves_the_original() {
        let root = std::env::temp_dir().join(format!("shm_bag_full_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).unwrap();
        let mounted = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=1m", "tmpfs"])
            .arg(&root)
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !mounted {
            eprintln!("no tmpfs could be mounted here (not root): the full-disk case is not run");
            let _ = std::fs::remove_dir_all(&root);
            return;
        }
        // Cut on the ordinary disk (the dead writer's file stays open in this
        // process), then copied in: about 600 KiB in a 1 MiB file system,
        // no room for a second copy.
        let cut = std::env::temp_dir().join(format!("shm_bag_cut_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&cut);
        let mut writer = BagWriter::create(
            &cut,
            WriteOptions {
                chunk_size: 64 * 1024,
                chunk_crcs: false,
                ..WriteOptions::default()
            },
        )
        .unwrap();
        let id = writer.add_topic(topic("/chatter"), String::new()).unwrap();
        let big = vec![7u8; 8 * 1024];
        for i in 0..75 {
            writer.write(id, 1_000 + u64::from(i), 0, i, &big).unwrap();
        }
        writer.flush().unwrap();
        std::mem::forget(writer);
        let dir = root.join("bag");
        std::fs::create_dir(&dir).unwrap();
        for entry in std::fs::read_dir(&cut).unwrap() {
            let entry = entry.unwrap();
            std::fs::copy(entry.path(), dir.join(entry.file_name())).unwrap();
        }
        let _ = std::fs::remove_dir_all(&cut);
        let file = dir.join(mcap_files(&dir).unwrap().remove(0));
        let before = std::fs::read(&file).unwrap();
        let error = reindex(&dir).unwrap_err().to_string();
        let after = std::fs::read(&file);
        let listing: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .collect();
        let _ = std::process::Command::new("umount").arg(&root).status();
        let _ = std::fs::remove_dir_all(&root);
        assert!(error.contains("No space left on device"), "{error}");
        assert_eq!(after.unwrap(), before, "the unfinished file is untouched");
        assert!(
            !listing.iter().any(|n| n.contains("partial")),
            "{listing:?}"
        );
    }
}
