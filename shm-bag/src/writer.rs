//! A recording on disk as rosbag2 writes it with its MCAP storage: a
//! directory with `metadata.yaml` and one or more MCAP files, profile `ros2`,
//! a `ros2msg` schema per type with the full definition, a `cdr` channel per
//! topic with its QoS profiles and type hash, chunked (optionally compressed)
//! and indexed, split by size or duration.
//!
//! A recording is meant to survive its process: chunks close on a time bound
//! as well as a size bound and go to the OS then, and `metadata.yaml` is
//! written when the bag is created and again at each chunk, so after a crash
//! or `kill -9` the directory is a bag whose last file lacks only its
//! summary (`shm-ros2 bag reindex` rebuilds it) and at most the last interval
//! of messages.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::metadata::{
    BagMetadata, FileInformation, Nanoseconds, NanosecondsSinceEpoch, TopicMetadata,
    TopicWithMessageCount, VERSION,
};
use crate::qos;
use crate::Error;
use shm_runtime::types::definition;

/// How chunks are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Zstandard (rosbag2's `zstd_fast` preset uses it).
    Zstd,
    /// LZ4 frames.
    Lz4,
}

/// How a recording is written.
#[derive(Debug, Clone)]
pub struct WriteOptions {
    /// Chunk compression; `None` (the default) keeps chunks as they are, so
    /// each message goes from its buffer to the file in one write.
    pub compression: Option<Compression>,
    /// Chunks close once they hold this many bytes (default 1 MiB); a larger
    /// message makes a chunk of its own.
    pub chunk_size: u64,
    /// Start a new file once the current one holds this many bytes.
    pub max_bag_size: Option<u64>,
    /// Start a new file once the current one spans this long.
    pub max_bag_duration: Option<Duration>,
    /// Close the open chunk once it is this old (default 1 s), hand it to the
    /// OS and refresh `metadata.yaml`: what a crash can lose. `None` closes
    /// chunks by size only.
    pub chunk_interval: Option<Duration>,
    /// A CRC-32 in each chunk (default on), so that readers detect a damaged
    /// chunk; off saves one pass over the bytes (rosbag2 leaves it off).
    pub chunk_crcs: bool,
    /// At each [`chunk_interval`](Self::chunk_interval), when a file is
    /// closed and when `metadata.yaml` is written, wait until the bytes are
    /// on the disk (`fsync`), so that a power cut loses no more than a
    /// crash does (default on). Off, they are only handed to the OS, which
    /// writes them when it chooses (rosbag2 does not sync).
    pub sync: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        Self {
            compression: None,
            chunk_size: 1024 * 1024,
            max_bag_size: None,
            max_bag_duration: None,
            chunk_interval: Some(Duration::from_secs(1)),
            chunk_crcs: true,
            sync: true,
        }
    }
}

/// Which topic a message is on: returned by [`BagWriter::add_topic`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TopicId(usize);

struct Topic {
    metadata: TopicMetadata,
    definition: String,
    count: u64,
}

/// The file being written.
struct Current {
    writer: mcap::Writer<BufWriter<File>>,
    /// The same open file, to sync it (the MCAP writer owns the other).
    file: File,
    path: String,
    channels: BTreeMap<usize, u16>,
    first: Option<u64>,
    last: u64,
    count: u64,
    bytes: u64,
}

/// A recording moved on from one file to the next.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileSplit {
    /// The file finished and closed.
    pub closed: PathBuf,
    /// The file the recording continues in.
    pub opened: PathBuf,
}

/// Writes a recording: a bag directory of MCAP files and `metadata.yaml`.
pub struct BagWriter {
    dir: PathBuf,
    base: String,
    options: WriteOptions,
    topics: Vec<Topic>,
    current: Option<Current>,
    files: Vec<FileInformation>,
    first: Option<u64>,
    last: u64,
    count: u64,
    /// Splits not yet taken by [`BagWriter::take_splits`].
    splits: Vec<FileSplit>,
    /// When the open chunk got its first message.
    chunk_opened: Option<Instant>,
    /// `metadata.yaml` is written when finished (also when dropped).
    finished: bool,
    /// The distribution `metadata.yaml` names (`ros_distro`).
    ros_distro: String,
}

impl std::fmt::Debug for BagWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagWriter")
            .field("dir", &self.dir)
            .field("files", &self.files.len())
            .field("count", &self.count)
            .finish_non_exhaustive()
    }
}

/// The MCAP library string of our files.
const LIBRARY: &str = concat!("shm-bag ", env!("CARGO_PKG_VERSION"));

impl BagWriter {
    /// Create the bag directory `dir` (it must not exist, as for rosbag2)
    /// and its first file.
    pub fn create(dir: &Path, options: WriteOptions) -> Result<Self, Error> {
        if dir.exists() {
            return Err(format!(
                "{} exists already: give another output directory (-o)",
                dir.display()
            )
            .into());
        }
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let base = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "bag".to_owned());
        let mut writer = Self {
            dir: dir.to_owned(),
            base,
            options,
            topics: Vec::new(),
            current: None,
            files: Vec::new(),
            first: None,
            last: 0,
            count: 0,
            splits: Vec::new(),
            chunk_opened: None,
            finished: false,
            ros_distro: std::env::var("ROS_DISTRO").unwrap_or_default(),
        };
        writer.open_file()?;
        // The directory is a bag from the start.
        writer.write_metadata()?;
        Ok(writer)
    }

    /// The bag directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The ROS 2 distribution `metadata.yaml` names as the recording's
    /// (`ros_distro`, as `ros2 bag info` shows it): the one the recorded
    /// nodes speak. Without it, `ROS_DISTRO` at creation, if set.
    pub fn set_ros_distro(&mut self, name: &str) {
        self.ros_distro = name.to_owned();
    }

    /// Add a topic: its metadata (name, type, QoS, hash) and its complete
    /// definition in `ros2msg` form (see [`definition`]).
    pub fn add_topic(
        &mut self,
        metadata: TopicMetadata,
        definition: String,
    ) -> Result<TopicId, Error> {
        let id = self.topics.len();
        self.topics.push(Topic {
            metadata,
            definition,
            count: 0,
        });
        if let Some(current) = self.current.as_mut() {
            add_channel(current, id, &self.topics[id])?;
        }
        Ok(TopicId(id))
    }

    /// Write one message: its CDR bytes as received, the time it was
    /// received (`log_time`) and sent (`publish_time`), in nanoseconds since
    /// the Unix epoch, and the publisher's sequence number.
    pub fn write(
        &mut self,
        topic: TopicId,
        log_time: u64,
        publish_time: u64,
        sequence: u32,
        data: &[u8],
    ) -> Result<(), Error> {
        if topic.0 >= self.topics.len() {
            return Err(format!("no topic {} in this recording", topic.0).into());
        }
        self.split_if_due(log_time)?;
        let Some(current) = self.current.as_mut() else {
            return Err("the recording is finished".into());
        };
        let channel_id = match current.channels.get(&topic.0) {
            Some(&id) => id,
            None => add_channel(current, topic.0, &self.topics[topic.0])?,
        };
        current
            .writer
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id,
                    sequence,
                    log_time,
                    publish_time,
                },
                data,
            )
            .map_err(|e| format!("writing {}: {}", current.path, mcap_error(e)))?;
        // Not necessarily the first written: a message held while its type
        // was learned is written after later ones.
        current.first = Some(current.first.map_or(log_time, |t| t.min(log_time)));
        current.last = current.last.max(log_time);
        current.count += 1;
        current.bytes += data.len() as u64;
        self.first = Some(self.first.map_or(log_time, |t| t.min(log_time)));
        self.last = self.last.max(log_time);
        self.count += 1;
        self.topics[topic.0].count += 1;
        self.chunk_opened.get_or_insert_with(Instant::now);
        self.flush_if_due()?;
        Ok(())
    }

    /// Close the open chunk if it is older than
    /// [`WriteOptions::chunk_interval`] (see [`flush`](Self::flush)); returns
    /// whether it did. A program writing rarely calls this now and then, as
    /// the recorder does, so that a quiet topic's last message reaches the
    /// disk too.
    pub fn flush_if_due(&mut self) -> Result<bool, Error> {
        let due = match (self.options.chunk_interval, self.chunk_opened) {
            (Some(interval), Some(opened)) => opened.elapsed() >= interval,
            _ => false,
        };
        if due {
            self.flush()?;
        }
        Ok(due)
    }

    /// Close the open chunk, hand the file's bytes to the OS and rewrite
    /// `metadata.yaml`: everything written so far survives the process.
    pub fn flush(&mut self) -> Result<(), Error> {
        self.chunk_opened = None;
        let Some(current) = self.current.as_mut() else {
            return Ok(());
        };
        current
            .writer
            .flush()
            .map_err(|e| format!("writing {}: {}", current.path, mcap_error(e)))?;
        if self.options.sync {
            current
                .file
                .sync_data()
                .map_err(|e| format!("writing {}: {e}", current.path))?;
        }
        self.write_metadata()
    }

    /// Write `metadata.yaml` as the recording stands, in one rename, so a
    /// reader never sees half of it.
    fn write_metadata(&self) -> Result<(), Error> {
        let path = self.dir.join(crate::metadata::FILE_NAME);
        let partial = self
            .dir
            .join(format!(".{}.partial", crate::metadata::FILE_NAME));
        let sync = self.options.sync;
        let write = || -> std::io::Result<()> {
            let mut file = File::create(&partial)?;
            std::io::Write::write_all(&mut file, self.metadata().to_yaml().as_bytes())?;
            if sync {
                file.sync_data()?;
            }
            std::fs::rename(&partial, &path)
        };
        write().map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        if sync {
            sync_dir(&self.dir)?;
        }
        Ok(())
    }

    /// Close the current file now and continue in a new one, as rosbag2's
    /// `~/split_bagfile` does (an empty file is closed too).
    pub fn split(&mut self) -> Result<FileSplit, Error> {
        if self.current.is_none() {
            return Err("the recording is finished".into());
        }
        self.split_file()
    }

    /// The splits since the last call, by size, by duration or by
    /// [`split`](Self::split), oldest first.
    pub fn take_splits(&mut self) -> Vec<FileSplit> {
        std::mem::take(&mut self.splits)
    }

    /// Messages written so far.
    pub fn message_count(&self) -> u64 {
        self.count
    }

    /// Close the last file and write `metadata.yaml`; returns what it says.
    /// (Dropping the writer does the same, without the answer.)
    pub fn finish(mut self) -> Result<BagMetadata, Error> {
        self.finish_in_place()
    }

    fn finish_in_place(&mut self) -> Result<BagMetadata, Error> {
        self.finished = true;
        let closed = self.close_file();
        // metadata.yaml is written even if the file could not be finished:
        // what reached the disk before is found through it.
        self.write_metadata()?;
        closed?;
        Ok(self.metadata())
    }

    /// The recording's metadata as it stands.
    pub fn metadata(&self) -> BagMetadata {
        let first = self.first.unwrap_or(0);
        BagMetadata {
            version: VERSION,
            storage_identifier: "mcap".to_owned(),
            duration: Nanoseconds {
                nanoseconds: self.last.saturating_sub(first),
            },
            starting_time: NanosecondsSinceEpoch {
                nanoseconds_since_epoch: first,
            },
            message_count: self.count,
            topics_with_message_count: self
                .topics
                .iter()
                .map(|t| TopicWithMessageCount {
                    topic_metadata: t.metadata.clone(),
                    message_count: t.count,
                })
                .collect(),
            compression_format: String::new(),
            compression_mode: String::new(),
            relative_file_paths: self.files.iter().map(|f| f.path.clone()).collect(),
            files: self.file_information(),
            custom_data: None,
            ros_distro: self.ros_distro.clone(),
        }
    }

    /// Each file's facts; the open file's as written so far.
    fn file_information(&self) -> Vec<FileInformation> {
        let mut files = self.files.clone();
        if let (Some(current), Some(info)) = (self.current.as_ref(), files.last_mut()) {
            let first = current.first.unwrap_or(0);
            info.starting_time.nanoseconds_since_epoch = first;
            info.duration.nanoseconds = current.last.saturating_sub(first);
            info.message_count = current.count;
        }
        files
    }

    fn split_if_due(&mut self, log_time: u64) -> Result<(), Error> {
        let Some(current) = self.current.as_ref() else {
            return Ok(());
        };
        if current.count == 0 {
            return Ok(());
        }
        let by_size = self
            .options
            .max_bag_size
            .is_some_and(|max| current.bytes >= max);
        let by_duration = self.options.max_bag_duration.is_some_and(|max| {
            current.first.is_some_and(|first| {
                log_time.saturating_sub(first) >= u64::try_from(max.as_nanos()).unwrap_or(u64::MAX)
            })
        });
        if by_size || by_duration {
            self.split_file()?;
        }
        Ok(())
    }

    fn split_file(&mut self) -> Result<FileSplit, Error> {
        let closed = self.current_path();
        self.close_file()?;
        self.open_file()?;
        self.write_metadata()?;
        let split = FileSplit {
            closed,
            opened: self.current_path(),
        };
        self.splits.push(split.clone());
        Ok(split)
    }

    /// The path of the file being written (the last one once finished).
    fn current_path(&self) -> PathBuf {
        let name = self.files.last().map_or("", |f| f.path.as_str());
        self.dir.join(name)
    }

    fn open_file(&mut self) -> Result<(), Error> {
        let name = format!("{}_{}.mcap", self.base, self.files.len());
        let path = self.dir.join(&name);
        let file =
            File::create(&path).map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        let handle = file
            .try_clone()
            .map_err(|e| format!("cannot open {} twice: {e}", path.display()))?;
        if self.options.sync {
            // The new file's name reaches the disk with the directory.
            sync_dir(&self.dir)?;
        }
        let compression = self.options.compression.map(|c| match c {
            Compression::Zstd => mcap::Compression::Zstd,
            Compression::Lz4 => mcap::Compression::Lz4,
        });
        // No data-section CRC: it would read every byte once more, and the
        // chunks' CRCs cover the messages.
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(LIBRARY)
            .compression(compression)
            .chunk_size(Some(self.options.chunk_size))
            .calculate_chunk_crcs(self.options.chunk_crcs)
            .calculate_data_section_crc(false)
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|e| format!("cannot start {}: {}", path.display(), mcap_error(e)))?;
        let mut current = Current {
            writer,
            file: handle,
            path: path.display().to_string(),
            channels: BTreeMap::new(),
            first: None,
            last: 0,
            count: 0,
            bytes: 0,
        };
        for (id, topic) in self.topics.iter().enumerate() {
            add_channel(&mut current, id, topic)?;
        }
        self.files.push(FileInformation {
            path: name,
            starting_time: NanosecondsSinceEpoch::default(),
            duration: Nanoseconds::default(),
            message_count: 0,
        });
        self.current = Some(current);
        Ok(())
    }

    fn close_file(&mut self) -> Result<(), Error> {
        let Some(mut current) = self.current.take() else {
            return Ok(());
        };
        self.chunk_opened = None;
        let first = current.first.unwrap_or(0);
        if let Some(info) = self.files.last_mut() {
            info.starting_time.nanoseconds_since_epoch = first;
            info.duration.nanoseconds = current.last.saturating_sub(first);
            info.message_count = current.count;
        }
        // rosbag2 keeps the bag's metadata in each file too.
        let metadata = mcap::records::Metadata {
            name: "rosbag2".to_owned(),
            metadata: BTreeMap::from([(
                "serialized_metadata".to_owned(),
                self.metadata().to_serialized_metadata(),
            )]),
        };
        current
            .writer
            .write_metadata(&metadata)
            .and_then(|_| current.writer.finish().map(|_| ()))
            .map_err(|e| format!("finishing {}: {}", current.path, mcap_error(e)))?;
        let mut file = current.writer.into_inner();
        std::io::Write::flush(&mut file).map_err(|e| format!("{}: {e}", current.path))?;
        if self.options.sync {
            current
                .file
                .sync_all()
                .map_err(|e| format!("writing {}: {e}", current.path))?;
        }
        Ok(())
    }
}

/// Make the names in directory `dir` (a file created, one renamed) durable.
fn sync_dir(dir: &Path) -> Result<(), Error> {
    File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| format!("cannot sync {}: {e}", dir.display()).into())
}

impl Drop for BagWriter {
    fn drop(&mut self) {
        // A writer dropped without `finish` (an early return, a panic
        // unwinding) still leaves a finished bag.
        if !self.finished {
            let _ = self.finish_in_place();
        }
    }
}

/// An MCAP error in words, with the OS's for an I/O error ("No space left on
/// device"), which the MCAP error's own text leaves out.
pub(crate) fn mcap_error(e: mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) => io.to_string(),
        other => other.to_string(),
    }
}

fn add_channel(current: &mut Current, id: usize, topic: &Topic) -> Result<u16, Error> {
    // A type recorded without its definition has an empty schema, encoding
    // and text both, as rosbag2 writes one.
    let schema_encoding = if topic.definition.is_empty() {
        ""
    } else {
        definition::ENCODING
    };
    let schema = current
        .writer
        .add_schema(
            &topic.metadata.type_name,
            schema_encoding,
            topic.definition.as_bytes(),
        )
        .map_err(|e| format!("{}: {}", current.path, mcap_error(e)))?;
    let metadata = BTreeMap::from([
        (
            "offered_qos_profiles".to_owned(),
            qos::to_yaml(&topic.metadata.offered_qos_profiles),
        ),
        (
            "topic_type_hash".to_owned(),
            topic.metadata.type_description_hash.clone(),
        ),
    ]);
    let channel = current
        .writer
        .add_channel(
            schema,
            &topic.metadata.name,
            &topic.metadata.serialization_format,
            &metadata,
        )
        .map_err(|e| format!("{}: {}", current.path, mcap_error(e)))?;
    // Outside any chunk as well: recovery finds the channel even when the
    // chunk holding its records is damaged.
    current
        .writer
        .write_metadata(&ChannelCopy::describe(
            channel,
            schema,
            &topic.metadata.name,
            &topic.metadata.serialization_format,
            &metadata,
            &topic.metadata.type_name,
            schema_encoding,
            topic.definition.as_bytes(),
        ))
        .map_err(|e| format!("{}: {}", current.path, mcap_error(e)))?;
    current.channels.insert(id, channel);
    Ok(channel)
}

/// A channel and its schema as a metadata record of their own, written
/// outside the chunks when the channel is added: MCAP keeps channel and
/// schema records in the chunk where they are first used, and when that
/// chunk is damaged, `bag reindex` finds them here. Readers that do not know
/// the name skip it.
pub(crate) struct ChannelCopy {
    pub(crate) channel_id: u16,
    pub(crate) schema_id: u16,
    pub(crate) topic: String,
    pub(crate) message_encoding: String,
    pub(crate) channel_metadata: BTreeMap<String, String>,
    pub(crate) schema_name: String,
    pub(crate) schema_encoding: String,
    pub(crate) schema_data: Vec<u8>,
}

impl ChannelCopy {
    /// The metadata record's name.
    pub(crate) const NAME: &'static str = "shm_bag_channel";
    /// The prefix of the channel's own metadata keys within it.
    const CHANNEL_KEY: &'static str = "channel.";

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn describe(
        channel_id: u16,
        schema_id: u16,
        topic: &str,
        message_encoding: &str,
        channel_metadata: &BTreeMap<String, String>,
        schema_name: &str,
        schema_encoding: &str,
        schema_data: &[u8],
    ) -> mcap::records::Metadata {
        let mut metadata = BTreeMap::from([
            ("channel_id".to_owned(), channel_id.to_string()),
            ("schema_id".to_owned(), schema_id.to_string()),
            ("topic".to_owned(), topic.to_owned()),
            ("message_encoding".to_owned(), message_encoding.to_owned()),
            ("schema_name".to_owned(), schema_name.to_owned()),
            ("schema_encoding".to_owned(), schema_encoding.to_owned()),
            (
                "schema_data".to_owned(),
                String::from_utf8_lossy(schema_data).into_owned(),
            ),
        ]);
        for (key, value) in channel_metadata {
            metadata.insert(format!("{}{key}", Self::CHANNEL_KEY), value.clone());
        }
        mcap::records::Metadata {
            name: Self::NAME.to_owned(),
            metadata,
        }
    }

    /// The channel and schema a metadata record describes, if it is one.
    pub(crate) fn read(record: &mcap::records::Metadata) -> Option<Self> {
        if record.name != Self::NAME {
            return None;
        }
        let field = |key: &str| record.metadata.get(key).cloned();
        Some(Self {
            channel_id: field("channel_id")?.parse().ok()?,
            schema_id: field("schema_id")?.parse().ok()?,
            topic: field("topic")?,
            message_encoding: field("message_encoding")?,
            channel_metadata: record
                .metadata
                .iter()
                .filter_map(|(k, v)| {
                    Some((k.strip_prefix(Self::CHANNEL_KEY)?.to_owned(), v.clone()))
                })
                .collect(),
            schema_name: field("schema_name")?,
            schema_encoding: field("schema_encoding")?,
            schema_data: field("schema_data")?.into_bytes(),
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::metadata::TopicMetadata;

    /// A `std_msgs/msg/String` topic called `name`.
    pub(crate) fn topic(name: &str) -> TopicMetadata {
        TopicMetadata {
            name: name.to_owned(),
            type_name: "std_msgs/msg/String".to_owned(),
            serialization_format: "cdr".to_owned(),
            offered_qos_profiles: Vec::new(),
            type_description_hash: String::new(),
        }
    }

    /// Every message of every file, by topic, as the mcap crate reads them.
    fn read_back(dir: &Path, metadata: &BagMetadata) -> Vec<(String, u64, Vec<u8>)> {
        let mut out = Vec::new();
        for file in &metadata.relative_file_paths {
            let bytes = std::fs::read(dir.join(file)).unwrap();
            for message in mcap::MessageStream::new(&bytes).unwrap() {
                let message = message.unwrap();
                out.push((
                    message.channel.topic.clone(),
                    message.log_time,
                    message.data.into_owned(),
                ));
            }
        }
        out
    }

    fn message(i: u64) -> Vec<u8> {
        let mut cdr = vec![0, 1, 0, 0];
        cdr.extend((0..1000u64).map(|j| ((i * 31 + j) % 251) as u8));
        cdr
    }

    fn write_all(dir: &Path, options: WriteOptions) -> (BagMetadata, Vec<(String, u64, Vec<u8>)>) {
        let mut writer = BagWriter::create(dir, options).unwrap();
        let a = writer.add_topic(topic("/a"), "string data".into()).unwrap();
        let mut expected = Vec::new();
        for i in 0..100u64 {
            if i == 40 {
                // A topic that appears while recording.
                let b = writer.add_topic(topic("/b"), "string data".into()).unwrap();
                writer.write(b, 1_000 + i * 10, 0, 0, &message(i)).unwrap();
                expected.push(("/b".to_owned(), 1_000 + i * 10, message(i)));
            }
            writer
                .write(a, 1_000 + i * 10, 0, i as u32, &message(i))
                .unwrap();
            expected.push(("/a".to_owned(), 1_000 + i * 10, message(i)));
        }
        (writer.finish().unwrap(), expected)
    }

    #[test]
    fn a_recording_splits_by_size_and_by_duration_and_loses_nothing() {
        let root = std::env::temp_dir().join(format!("shm_bag_split_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        for (name, options) in [
            (
                "by_size",
                WriteOptions {
                    max_bag_size: Some(30_000),
                    ..WriteOptions::default()
                },
            ),
            (
                "by_duration",
                WriteOptions {
                    max_bag_duration: Some(Duration::from_nanos(250)),
                    ..WriteOptions::default()
                },
            ),
        ] {
            let dir = root.join(name);
            let (metadata, expected) = write_all(&dir, options);
            assert_eq!(metadata.relative_file_paths.len(), 4, "{name}");
            assert_eq!(
                metadata.files.iter().map(|f| f.message_count).sum::<u64>(),
                101
            );
            assert_eq!(metadata.message_count, 101);
            assert_eq!(read_back(&dir, &metadata), expected, "{name}");
            assert_eq!(BagMetadata::read(&dir).unwrap(), metadata);
        }
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn a_message_written_after_later_ones_starts_the_recording_and_its_file() {
        let dir = std::env::temp_dir().join(format!("shm_bag_late_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut writer = BagWriter::create(&dir, WriteOptions::default()).unwrap();
        let a = writer.add_topic(topic("/a"), "string data".into()).unwrap();
        let b = writer.add_topic(topic("/b"), "string data".into()).unwrap();
        // /b's first message was held while its type was learned: written
        // after /a's, though received before them.
        for (topic, time) in [(a, 2_000), (a, 3_000), (b, 1_500), (a, 4_000)] {
            writer.write(topic, time, 0, 0, &message(time)).unwrap();
        }
        let metadata = writer.finish().unwrap();
        assert_eq!(metadata.starting_time.nanoseconds_since_epoch, 1_500);
        assert_eq!(metadata.duration.nanoseconds, 2_500);
        let file = &metadata.files[0];
        assert_eq!(file.starting_time.nanoseconds_since_epoch, 1_500);
        assert_eq!(file.duration.nanoseconds, 2_500);
        assert_eq!(BagMetadata::read(&dir).unwrap(), metadata);
        let bytes = std::fs::read(dir.join(&metadata.relative_file_paths[0])).unwrap();
        let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
        let stats = summary.stats.unwrap();
        assert_eq!(
            (stats.message_start_time, stats.message_end_time),
            (1_500, 4_000)
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn compressed_chunks_read_back_to_the_same_bytes() {
        let root = std::env::temp_dir().join(format!("shm_bag_compress_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        for compression in [Compression::Zstd, Compression::Lz4] {
            let dir = root.join(format!("{compression:?}"));
            let (metadata, expected) = write_all(
                &dir,
                WriteOptions {
                    compression: Some(compression),
                    chunk_size: 16 * 1024,
                    ..WriteOptions::default()
                },
            );
            assert_eq!(read_back(&dir, &metadata), expected);
            let bytes = std::fs::read(dir.join(&metadata.relative_file_paths[0])).unwrap();
            let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
            let want = match compression {
                Compression::Zstd => "zstd",
                Compression::Lz4 => "lz4",
            };
            assert!(summary.chunk_indexes.iter().all(|c| c.compression == want));
            // The messages compress: the file is smaller than what it holds.
            assert!((bytes.len() as u64) < 101 * 1004);
        }
        let _ = std::fs::remove_dir_all(&root);
    }
}
