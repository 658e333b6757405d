//! The storages a recording is kept in, behind one reader interface as
//! rosbag2's storage plugins are: MCAP (what this crate writes, and
//! rosbag2's default since Iron) and sqlite3 (`.db3`, rosbag2's default
//! through Humble). A [`Bag`](crate::Bag) opens each of its files through
//! [`Storage::open`] and merges what they give into one stream in log-time
//! order.

use std::collections::BTreeMap;
use std::path::Path;

use shm_runtime::rmw::Qos;

use crate::Error;

/// One topic of a recording, as its files describe it.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedTopic {
    /// The topic name.
    pub name: String,
    /// `pkg/msg/Name`.
    pub type_name: String,
    /// The RIHS01 hash recorded (`topic_type_hash`), or empty.
    pub type_hash: String,
    /// The recorded publishers' QoS.
    pub offered_qos: Vec<Qos>,
    /// The message encoding (`cdr`).
    pub message_encoding: String,
    /// Its messages in all files.
    pub message_count: u64,
}

mod mcap_file;
pub(crate) use mcap_file::map as map_file;
mod sqlite3;

/// A storage format of rosbag2.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// MCAP, profile `ros2` (`storage_identifier: mcap`).
    Mcap,
    /// rosbag2's SQLite database (`storage_identifier: sqlite3`, `.db3`).
    Sqlite3,
}

/// The first bytes of every SQLite database file.
const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";

impl Storage {
    /// The name `metadata.yaml` gives it (`storage_identifier`).
    pub fn identifier(self) -> &'static str {
        match self {
            Self::Mcap => "mcap",
            Self::Sqlite3 => "sqlite3",
        }
    }

    /// The storage `metadata.yaml` names, if it is one this crate reads.
    pub fn from_identifier(identifier: &str) -> Option<Self> {
        match identifier {
            "mcap" => Some(Self::Mcap),
            "sqlite3" => Some(Self::Sqlite3),
            _ => None,
        }
    }

    /// The storage of the file `path`, from its first bytes.
    pub(crate) fn of_file(path: &Path) -> Result<Self, Error> {
        use std::io::Read;
        let mut head = [0u8; SQLITE_MAGIC.len()];
        let mut file = std::fs::File::open(path)
            .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        let mut read = 0;
        while read < head.len() {
            match file.read(&mut head[read..]) {
                Ok(0) => break,
                Ok(n) => read += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(format!("cannot read {}: {e}", path.display()).into()),
            }
        }
        Ok(if head[..read] == *SQLITE_MAGIC {
            Self::Sqlite3
        } else {
            Self::Mcap
        })
    }

    /// Open one file of a recording in this storage.
    pub(crate) fn open(self, path: &Path) -> Result<Box<dyn StorageFile>, Error> {
        Ok(match self {
            Self::Mcap => Box::new(mcap_file::McapFile::open(path)?),
            Self::Sqlite3 => Box::new(sqlite3::Sqlite3File::open(path)?),
        })
    }
}

/// rosbag2's own compression (`compression_mode` in `metadata.yaml`), on top
/// of the storage: each whole file, or each message's bytes, in zstd.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Compressed {
    /// Neither (MCAP may still compress its chunks itself).
    No,
    /// Each file is a zstd stream of the storage file (`bag_0.db3.zstd`).
    File,
    /// Each message's bytes are a zstd frame.
    Message,
}

/// The most bytes a compressed message or file may decompress to (a message:
/// more than any a ROS 2 transport carries).
const MAX_MESSAGE: u64 = crate::chunk::MAX_CHUNK_SIZE;

impl Compressed {
    /// The compression `metadata.yaml` gives (`compression_mode`,
    /// `compression_format`), if it is one this crate reads.
    pub(crate) fn of(mode: &str, format: &str) -> Result<Self, String> {
        let mode = mode.to_ascii_lowercase();
        let compressed = match mode.as_str() {
            "" | "none" => return Ok(Self::No),
            "file" => Self::File,
            "message" => Self::Message,
            _ => {
                return Err(format!(
                    "compression_mode `{}` is not one of rosbag2's (none, file, message)",
                    shm_cdr::text_limits::quoted(&mode)
                ))
            }
        };
        if !format.eq_ignore_ascii_case("zstd") {
            return Err(format!(
                "compression_format `{}` is not read (rosbag2 compresses with zstd)",
                shm_cdr::text_limits::quoted(format)
            ));
        }
        Ok(compressed)
    }
}

/// Decompress the zstd file `compressed` into `dir`, under its name without
/// the `.zstd`; returns that path.
pub(crate) fn decompress_file(compressed: &Path, dir: &Path) -> Result<std::path::PathBuf, Error> {
    let name = compressed
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = name.strip_suffix(".zstd").unwrap_or(&name);
    let path = dir.join(name);
    let input = std::fs::File::open(compressed)
        .map_err(|e| format!("cannot open {}: {e}", compressed.display()))?;
    let mut output = std::fs::File::create(&path)
        .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
    let mut decoder = zstd::stream::read::Decoder::new(input)
        .map_err(|e| format!("{}: {e}", compressed.display()))?;
    std::io::copy(&mut decoder, &mut output).map_err(|e| {
        format!(
            "decompressing {} into {}: {e}",
            compressed.display(),
            path.display()
        )
    })?;
    Ok(path)
}

/// Decompress one message's zstd frame into `scratch`.
pub(crate) fn decompress_message<'a>(
    data: &[u8],
    scratch: &'a mut Vec<u8>,
) -> Result<&'a [u8], String> {
    use std::io::Read;
    scratch.clear();
    zstd::stream::read::Decoder::new(data)
        .and_then(|d| d.take(MAX_MESSAGE + 1).read_to_end(scratch))
        .map_err(|e| format!("a compressed message does not decompress: {e}"))?;
    if scratch.len() as u64 > MAX_MESSAGE {
        return Err(format!(
            "a compressed message decompresses to more than {MAX_MESSAGE} bytes"
        ));
    }
    Ok(scratch)
}

/// One message of a recording, as its storage gives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BagMessage<'a> {
    /// Its topic.
    pub topic: &'a str,
    /// Its type, `pkg/msg/Name` (a topic may be recorded with several).
    pub type_name: &'a str,
    /// When it was recorded, in nanoseconds since the Unix epoch.
    pub log_time: u64,
    /// When it was sent, where the storage keeps it (MCAP); else its log
    /// time.
    pub publish_time: u64,
    /// Its publisher's sequence number, where the storage keeps it (MCAP);
    /// else 0.
    pub sequence: u32,
    /// Its serialized bytes (CDR).
    pub data: &'a [u8],
}

/// A file's first and last log time and its message count (times are 0
/// when it holds none).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct FileStats {
    pub start: u64,
    pub end: u64,
    pub count: u64,
}

/// One file of a recording, open for reading.
pub(crate) trait StorageFile {
    /// Its topics, each with the number of its messages in this file.
    fn topics(&self) -> Result<Vec<RecordedTopic>, Error>;
    /// Its first and last log time and message count.
    fn stats(&self) -> Result<FileStats, Error>;
    /// A bound on the size of its largest message.
    fn largest_message(&self) -> Result<u64, Error>;
    /// The `ros2msg` definition of each type it keeps one of, by type name.
    fn definitions(&self) -> Result<BTreeMap<String, String>, Error>;
    /// Its messages of log time `from` or later, in log-time order (in
    /// file order where times are equal).
    fn messages(&self, from: u64) -> Result<Box<dyn MessageCursor>, Error>;
}

/// A position in a file's messages.
pub(crate) trait MessageCursor {
    /// The message at the position, or `None` past the last.
    fn current(&self) -> Option<BagMessage<'_>>;
    /// Move to the next message.
    fn advance(&mut self) -> Result<(), Error>;
}

#[cfg(test)]
mod tests {
    use std::ops::ControlFlow;
    use std::path::PathBuf;

    use crate::writer::tests::topic;
    use crate::{Bag, BagWriter, Compression, WriteOptions};

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("shm-bag-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    /// A CDR `std_msgs/msg/String` holding `i`.
    fn cdr(i: u64) -> Vec<u8> {
        let text = format!("m{i}\0");
        let mut out = vec![0, 1, 0, 0];
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(text.as_bytes());
        out
    }

    /// Every message of `bag` from `from` on: (topic, time, bytes).
    fn played(bag: &Bag, from: u64) -> Vec<(String, u64, Vec<u8>)> {
        let mut out = Vec::new();
        bag.read_messages(
            from,
            |_| {},
            |topic, time, data| {
                out.push((topic.to_owned(), time, data.to_vec()));
                ControlFlow::<()>::Continue(())
            },
        )
        .unwrap();
        out
    }

    /// Times in a scrambled order: a permutation of 0..n (n prime to 37).
    fn scrambled(n: u64) -> Vec<u64> {
        (0..n).map(|i| (i * 37 + 11) % n).collect()
    }

    #[test]
    fn messages_written_out_of_order_are_read_in_time_order_across_chunks_and_files() {
        for compression in [None, Some(Compression::Zstd), Some(Compression::Lz4)] {
            let dir = temp(&format!("order-{compression:?}"));
            let options = WriteOptions {
                compression,
                // A few messages per chunk: chunks overlap in time.
                chunk_size: 64,
                ..Default::default()
            };
            let mut writer = BagWriter::create(&dir, options).unwrap();
            let a = writer.add_topic(topic("/a"), String::new()).unwrap();
            let b = writer.add_topic(topic("/b"), String::new()).unwrap();
            let times = scrambled(101);
            for (k, &t) in times.iter().enumerate() {
                let topic = if t % 2 == 0 { a } else { b };
                writer.write(topic, 1000 + t, 0, k as u32, &cdr(t)).unwrap();
                if k == 50 {
                    // A second file overlapping the first in time.
                    writer.split().unwrap();
                }
            }
            let metadata = writer.finish().unwrap();
            assert_eq!(metadata.relative_file_paths.len(), 2);
            let bag = Bag::open(&dir).unwrap();
            let got = played(&bag, 0);
            let expected: Vec<(String, u64, Vec<u8>)> = (0..101)
                .map(|t| {
                    let topic = if t % 2 == 0 { "/a" } else { "/b" };
                    (topic.to_owned(), 1000 + t, cdr(t))
                })
                .collect();
            assert_eq!(got, expected, "{compression:?}");
            // From a time on: exactly the messages at or after it.
            assert_eq!(played(&bag, 1060), expected[60..].to_vec());
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    /// A finished bag `name` of five messages without chunk CRCs: its
    /// directory, its file and the file's bytes, to damage.
    fn five_messages(name: &str) -> (PathBuf, PathBuf, Vec<u8>) {
        let dir = temp(name);
        let options = WriteOptions {
            chunk_crcs: false,
            ..Default::default()
        };
        let mut writer = BagWriter::create(&dir, options).unwrap();
        let a = writer.add_topic(topic("/a"), String::new()).unwrap();
        for t in 0..5 {
            writer.write(a, 1000 + t, 0, t as u32, &cdr(t)).unwrap();
        }
        let metadata = writer.finish().unwrap();
        let path = dir.join(&metadata.relative_file_paths[0]);
        let bytes = std::fs::read(&path).unwrap();
        (dir, path, bytes)
    }

    /// A summary whose message count is not the file's: reading the file
    /// gives every message, and says that the summary disagrees.
    #[test]
    fn a_summary_whose_count_lies_is_said_to_disagree() {
        use std::sync::{Arc, Mutex};
        let (dir, path, mut bytes) = five_messages("lying-count");
        // The statistics record: opcode, length, then its message count.
        let at = (0..bytes.len() - 17)
            .rev()
            .find(|&i| bytes[i] == 0x0b && bytes[i + 9..i + 17] == 5u64.to_le_bytes())
            .unwrap();
        bytes[at + 9..at + 17].copy_from_slice(&3u64.to_le_bytes());
        let crc_at = bytes.len() - mcap::MAGIC.len() - 4;
        bytes[crc_at..crc_at + 4].fill(0);
        std::fs::write(&path, &bytes).unwrap();

        #[derive(Clone, Default)]
        struct Said(Arc<Mutex<Vec<u8>>>);
        impl std::io::Write for Said {
            fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
                self.0.lock().unwrap().extend_from_slice(buf);
                Ok(buf.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let said = Said::default();
        let writer = said.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_writer(move || writer.clone())
            .with_ansi(false)
            .finish();
        let read =
            tracing::subscriber::with_default(subscriber, || played(&Bag::open(&dir).unwrap(), 0));
        assert_eq!(read.len(), 5);
        let text = String::from_utf8(said.0.lock().unwrap().clone()).unwrap();
        assert!(
            text.contains("its summary counts 3 messages, and 5 were read"),
            "{text}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A chunk index declaring a chunk of 2^40 bytes is refused when the
    /// file is opened, before a reader or a player sizes anything from it.
    #[test]
    fn a_chunk_index_that_lies_about_its_size_is_refused_at_open() {
        let (dir, path, mut bytes) = five_messages("lying-index");
        let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
        let index = &summary.chunk_indexes[0];
        // An uncompressed chunk's index ends with its compressed and its
        // uncompressed size, the same number.
        let mut sizes = index.compressed_size.to_le_bytes().to_vec();
        sizes.extend_from_slice(&index.uncompressed_size.to_le_bytes());
        let at = bytes
            .windows(16)
            .rposition(|w| w == sizes.as_slice())
            .unwrap();
        bytes[at + 8..at + 16].copy_from_slice(&(1u64 << 40).to_le_bytes());
        // No summary CRC, so that only the lie is to be found.
        let crc_at = bytes.len() - mcap::MAGIC.len() - 4;
        bytes[crc_at..crc_at + 4].fill(0);
        std::fs::write(&path, &bytes).unwrap();
        let error = Bag::open(&dir).unwrap().topics().unwrap_err().to_string();
        assert!(
            error.contains("declares a chunk of 1099511627776 bytes"),
            "{error}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_file_without_chunk_index_or_chunks_is_read_in_time_order() {
        for use_chunks in [true, false] {
            let dir = temp(&format!("unindexed-{use_chunks}"));
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join("plain.mcap");
            let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
            let mut writer = mcap::WriteOptions::new()
                .profile("ros2")
                .use_chunks(use_chunks)
                .chunk_size(Some(40))
                .emit_chunk_indexes(false)
                .emit_message_indexes(false)
                .create(file)
                .unwrap();
            let schema = writer
                .add_schema("std_msgs/msg/String", "ros2msg", b"string data")
                .unwrap();
            let channel = writer
                .add_channel(schema, "/c", "cdr", &Default::default())
                .unwrap();
            for (k, t) in scrambled(23).into_iter().enumerate() {
                let header = mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: k as u32,
                    log_time: t,
                    publish_time: t,
                };
                writer.write_to_known_channel(&header, &cdr(t)).unwrap();
            }
            writer.finish().unwrap();
            let bag = Bag::open(&path).unwrap();
            let times: Vec<u64> = played(&bag, 0).into_iter().map(|m| m.1).collect();
            assert_eq!(times, (0..23).collect::<Vec<_>>(), "chunks: {use_chunks}");
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    /// A rosbag2 sqlite3 file as `schema` creates its tables.
    fn sqlite_bag(path: &std::path::Path, schema: &str, times: &[u64]) {
        let db = rusqlite::Connection::open(path).unwrap();
        db.execute_batch(schema).unwrap();
        let columns: Vec<String> = db
            .prepare("PRAGMA table_info(topics)")
            .unwrap()
            .query_map([], |r| r.get(1))
            .unwrap()
            .map(Result::unwrap)
            .collect();
        let values = match columns.len() {
            4 => "(1, '/t', 'std_msgs/msg/String', 'cdr')",
            5 => "(1, '/t', 'std_msgs/msg/String', 'cdr', '')",
            _ => "(1, '/t', 'std_msgs/msg/String', 'cdr', '', 'RIHS01_df66')",
        };
        db.execute(&format!("INSERT INTO topics VALUES {values}"), [])
            .unwrap();
        for &t in times {
            db.execute(
                "INSERT INTO messages (topic_id, timestamp, data) VALUES (1, ?1, ?2)",
                rusqlite::params![t as i64, cdr(t)],
            )
            .unwrap();
        }
    }

    #[test]
    fn sqlite3_files_of_each_schema_are_read_in_time_order() {
        let messages = "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, \
                        timestamp INTEGER NOT NULL, data BLOB NOT NULL); \
                        CREATE INDEX timestamp_idx ON messages (timestamp ASC);";
        let schemas = [
            // Eloquent: no QoS.
            "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
             serialization_format TEXT NOT NULL);",
            // Foxy to Humble: QoS as YAML text.
            "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);",
            // Iron on: a type hash and the definitions.
            "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL, \
             type_description_hash TEXT NOT NULL); \
             CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, \
             encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL, \
             type_description_hash TEXT NOT NULL); \
             INSERT INTO message_definitions VALUES \
             (1, 'std_msgs/msg/String', 'ros2msg', 'string data', 'RIHS01_df66');",
        ];
        // More than a batch, with equal times.
        let mut times: Vec<u64> = scrambled(601).into_iter().map(|t| t / 2).collect();
        times.push(7);
        for (n, schema) in schemas.iter().enumerate() {
            let dir = temp(&format!("sqlite-{n}"));
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join("bag_0.db3");
            sqlite_bag(&path, &format!("{schema} {messages}"), &times);
            let bag = Bag::open(&path).unwrap();
            assert_eq!(bag.storage(), super::Storage::Sqlite3);
            let mut sorted = times.clone();
            sorted.sort_unstable();
            let got = played(&bag, 0);
            assert_eq!(got.iter().map(|m| m.1).collect::<Vec<_>>(), sorted);
            assert!(got
                .iter()
                .all(|(topic, t, data)| topic == "/t" && *data == cdr(*t)));
            let from: Vec<u64> = played(&bag, 100).into_iter().map(|m| m.1).collect();
            assert_eq!(
                from,
                sorted
                    .iter()
                    .copied()
                    .filter(|&t| t >= 100)
                    .collect::<Vec<_>>()
            );
            let topics = bag.topics().unwrap();
            assert_eq!(topics.len(), 1);
            assert_eq!(topics[0].name, "/t");
            assert_eq!(topics[0].message_count, times.len() as u64);
            assert_eq!(topics[0].type_name, "std_msgs/msg/String");
            assert_eq!(topics[0].type_hash.is_empty(), n < 2);
            assert_eq!(bag.definitions().unwrap().len(), usize::from(n == 2));
            let described = bag.describe().unwrap();
            assert_eq!(described.storage_identifier, "sqlite3");
            assert_eq!(described.message_count, times.len() as u64);
            assert_eq!(described.duration.nanoseconds, 300);
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    #[test]
    fn bags_compressed_by_rosbag2_per_file_or_per_message_are_read() {
        let messages = "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, \
                        type TEXT NOT NULL, serialization_format TEXT NOT NULL, \
                        offered_qos_profiles TEXT NOT NULL); \
                        CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, \
                        timestamp INTEGER NOT NULL, data BLOB NOT NULL);";
        let times: Vec<u64> = scrambled(50);
        for mode in ["FILE", "message"] {
            let dir = temp(&format!("compressed-{mode}"));
            std::fs::create_dir_all(&dir).unwrap();
            let db = dir.join("bag_0.db3");
            sqlite_bag(&db, messages, &times);
            let name = if mode == "FILE" {
                let compressed = zstd::encode_all(&std::fs::read(&db).unwrap()[..], 3).unwrap();
                std::fs::write(dir.join("bag_0.db3.zstd"), compressed).unwrap();
                std::fs::remove_file(&db).unwrap();
                "bag_0.db3.zstd"
            } else {
                let conn = rusqlite::Connection::open(&db).unwrap();
                for t in &times {
                    let packed = zstd::encode_all(&cdr(*t)[..], 3).unwrap();
                    conn.execute(
                        "UPDATE messages SET data = ?1 WHERE timestamp = ?2",
                        rusqlite::params![packed, *t as i64],
                    )
                    .unwrap();
                }
                "bag_0.db3"
            };
            let metadata = format!(
                "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n  \
                 relative_file_paths: [{name}]\n  duration: {{nanoseconds: 49}}\n  \
                 starting_time: {{nanoseconds_since_epoch: 0}}\n  message_count: 50\n  \
                 topics_with_message_count: []\n  compression_format: zstd\n  \
                 compression_mode: {mode}\n"
            );
            std::fs::write(dir.join(crate::metadata::FILE_NAME), metadata).unwrap();
            let bag = Bag::open(&dir).unwrap();
            let got = played(&bag, 0);
            assert_eq!(
                got.iter().map(|m| m.1).collect::<Vec<_>>(),
                (0..50).collect::<Vec<_>>()
            );
            assert!(got.iter().all(|(_, t, data)| *data == cdr(*t)), "{mode}");
            if mode == "FILE" {
                // The decompressed copy lives beside the bag while it is open
                // and is removed with it.
                let copies = || {
                    std::fs::read_dir(&dir)
                        .unwrap()
                        .filter(|e| {
                            e.as_ref()
                                .unwrap()
                                .file_name()
                                .to_string_lossy()
                                .starts_with(".decompressed-")
                        })
                        .count()
                };
                assert_eq!(copies(), 1);
                drop(bag);
                assert_eq!(copies(), 0);
            }
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    #[test]
    fn a_sqlite_database_that_is_not_a_bag_is_refused_naming_the_table() {
        let dir = temp("sqlite-other");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("other.db3");
        rusqlite::Connection::open(&path)
            .unwrap()
            .execute_batch("CREATE TABLE things(id INTEGER PRIMARY KEY);")
            .unwrap();
        let error = Bag::open(&path).unwrap().topics().unwrap_err().to_string();
        assert!(
            error.contains("without rosbag2's `topics` table"),
            "{error}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
