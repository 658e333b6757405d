//! MCAP files: read from a memory map through their summary, their messages
//! merged across chunks into log-time order, as a chunk's time range says
//! when it is needed. A chunk is decompressed only when its first message
//! is due, and a file written in order (as rosbag2 writes) has one chunk
//! open at a time; messages in an uncompressed chunk are given from the
//! map itself.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use mcap::records::{op, ChunkHeader, ChunkIndex, Record};

use super::{BagMessage, FileStats, MessageCursor, RecordedTopic, StorageFile};
use crate::{qos, Error};

/// One MCAP file, mapped, with its summary.
pub(crate) struct McapFile {
    path: PathBuf,
    map: Arc<memmap2::Mmap>,
    summary: mcap::Summary,
}

impl McapFile {
    pub(crate) fn open(path: &Path) -> Result<Self, Error> {
        let map = map(path)?;
        let summary = summary(path, &map)?;
        Ok(Self {
            path: path.to_owned(),
            map: Arc::new(map),
            summary,
        })
    }
}

impl StorageFile for McapFile {
    fn topics(&self) -> Result<Vec<RecordedTopic>, Error> {
        let counts = self
            .summary
            .stats
            .as_ref()
            .map(|s| &s.channel_message_counts);
        Ok(self
            .summary
            .channels
            .iter()
            .map(|(id, channel)| {
                let mut topic = recorded_topic(channel);
                topic.message_count = counts.and_then(|c| c.get(id)).copied().unwrap_or(0);
                topic
            })
            .collect())
    }

    fn stats(&self) -> Result<FileStats, Error> {
        Ok(match &self.summary.stats {
            Some(stats) if stats.message_count > 0 => FileStats {
                start: stats.message_start_time,
                end: stats.message_end_time,
                count: stats.message_count,
            },
            _ => FileStats::default(),
        })
    }

    fn largest_message(&self) -> Result<u64, Error> {
        // A chunk holds whole messages, and a message larger than the chunk
        // size has a chunk of its own.
        Ok(self
            .summary
            .chunk_indexes
            .iter()
            .map(|c| c.uncompressed_size)
            .max()
            .unwrap_or_else(|| self.map.len() as u64))
    }

    fn definitions(&self) -> Result<BTreeMap<String, String>, Error> {
        Ok(self
            .summary
            .schemas
            .values()
            .filter(|s| s.encoding == "ros2msg")
            .map(|s| {
                (
                    s.name.clone(),
                    String::from_utf8_lossy(&s.data).into_owned(),
                )
            })
            .collect())
    }

    fn messages(&self, from: u64) -> Result<Box<dyn MessageCursor>, Error> {
        Ok(Box::new(McapMessages::new(self, from)?))
    }
}

/// Where a chunk's records come from.
enum Source {
    /// A chunk the summary's index points at.
    Indexed(ChunkIndex),
    /// A chunk found by reading a file that has no chunk index: its header
    /// and where its data lies in the map.
    Found {
        header: ChunkHeader,
        data: std::ops::Range<usize>,
    },
}

/// A chunk not yet read: it is read when its first message is due.
struct Unit {
    start: u64,
    order: usize,
    source: Source,
}

/// One message of a loaded chunk: where its bytes lie in the chunk's buffer.
struct Entry {
    time: u64,
    publish_time: u64,
    sequence: u32,
    topic: usize,
    data: std::ops::Range<usize>,
}

/// The bytes a loaded chunk's messages lie in.
enum Buffer {
    /// The map itself (uncompressed chunks, messages outside chunks).
    Map,
    /// Decompressed records.
    Owned(Vec<u8>),
}

struct Loaded {
    buffer: Buffer,
    entries: Vec<Entry>,
    next: usize,
    order: usize,
}

struct McapMessages {
    path: PathBuf,
    /// Messages given so far, and how many the summary says a reading from
    /// the start gives: they are compared at the end.
    given: u64,
    expected: Option<u64>,
    map: Arc<memmap2::Mmap>,
    /// Channel id → index into `topics`.
    channels: HashMap<u16, usize>,
    /// Each channel's topic and type.
    topics: Vec<(String, String)>,
    from: u64,
    /// Chunks to read, the earliest last.
    pending: Vec<Unit>,
    loaded: Vec<Option<Loaded>>,
    /// Loaded chunks by their next message's (time, file order).
    heap: BinaryHeap<Reverse<(u64, usize, usize)>>,
    /// Buffers of chunks played out, to decompress the next ones into.
    spare: Vec<Vec<u8>>,
}

impl McapMessages {
    fn new(file: &McapFile, from: u64) -> Result<Self, Error> {
        let mut topics = Vec::new();
        let mut channels = HashMap::new();
        for (id, channel) in &file.summary.channels {
            channels.insert(*id, topics.len());
            let type_name = channel.schema.as_ref().map(|s| s.name.clone());
            topics.push((channel.topic.clone(), type_name.unwrap_or_default()));
        }
        let mut cursor = Self {
            path: file.path.clone(),
            given: 0,
            expected: file
                .summary
                .stats
                .as_ref()
                .filter(|_| from == 0)
                .map(|s| s.message_count),
            map: Arc::clone(&file.map),
            channels,
            topics,
            from,
            pending: Vec::new(),
            loaded: Vec::new(),
            heap: BinaryHeap::new(),
            spare: Vec::new(),
        };
        if file.summary.chunk_indexes.is_empty() {
            cursor.find_units()?;
        } else {
            let mut indexes: Vec<&ChunkIndex> = file.summary.chunk_indexes.iter().collect();
            indexes.sort_by_key(|c| c.chunk_start_offset);
            cursor.pending = indexes
                .into_iter()
                .enumerate()
                .filter(|(_, c)| c.message_end_time >= from)
                .map(|(order, c)| Unit {
                    start: c.message_start_time,
                    order,
                    source: Source::Indexed(c.clone()),
                })
                .collect();
        }
        // The earliest last, ties in file order.
        cursor.pending.sort_by_key(|u| Reverse((u.start, u.order)));
        cursor.load_due()?;
        Ok(cursor)
    }

    /// Without a chunk index: go through the file's records once, loading
    /// the messages outside chunks and noting each chunk to read later.
    fn find_units(&mut self) -> Result<(), Error> {
        let map = Arc::clone(&self.map);
        let within = map.get(mcap::MAGIC.len()..).unwrap_or_default();
        let mut loose = Vec::new();
        for record in Records(within) {
            let (opcode, body) = record.map_err(|e| format!("{}: {e}", self.path.display()))?;
            match opcode {
                op::MESSAGE => {
                    if let Some(entry) = self.entry(body)? {
                        if let Some(data) = range_in(&map, &body[entry.data.clone()]) {
                            loose.push(Entry { data, ..entry });
                        }
                    }
                }
                op::CHUNK => {
                    let Ok(Record::Chunk { header, data }) = mcap::parse_record(op::CHUNK, body)
                    else {
                        return Err(format!(
                            "{}: a chunk that does not parse",
                            self.path.display()
                        )
                        .into());
                    };
                    if header.message_end_time < self.from {
                        continue;
                    }
                    let data = range_in(&map, &data).ok_or_else(|| {
                        format!("{}: a chunk outside the file", self.path.display())
                    })?;
                    self.pending.push(Unit {
                        start: header.message_start_time,
                        order: self.pending.len() + 1,
                        source: Source::Found { header, data },
                    });
                }
                // The summary and footer follow the data.
                op::DATA_END | op::FOOTER => break,
                _ => {}
            }
        }
        if !loose.is_empty() {
            loose.sort_by_key(|e| e.time);
            self.insert(Loaded {
                buffer: Buffer::Map,
                entries: loose,
                next: 0,
                order: 0,
            });
        }
        Ok(())
    }

    /// A message record's body as an entry (its data range within `body`),
    /// or `None` for a channel this file does not describe or a time before
    /// the start.
    fn entry(&self, body: &[u8]) -> Result<Option<Entry>, Error> {
        // channel id (2), sequence (4), log time (8), publish time (8).
        const HEADER: usize = 22;
        let short = || {
            format!(
                "{}: a message record of {} bytes",
                self.path.display(),
                body.len()
            )
        };
        let header = body.get(..HEADER).ok_or_else(short)?;
        let field = |at: usize| {
            let mut bytes = [0u8; 8];
            bytes.copy_from_slice(&header[at..at + 8]);
            u64::from_le_bytes(bytes)
        };
        let channel = u16::from_le_bytes([header[0], header[1]]);
        let sequence = u32::from_le_bytes([header[2], header[3], header[4], header[5]]);
        let (time, publish_time) = (field(6), field(14));
        let Some(&topic) = self.channels.get(&channel) else {
            return Ok(None);
        };
        if time < self.from {
            return Ok(None);
        }
        Ok(Some(Entry {
            time,
            publish_time,
            sequence,
            topic,
            data: HEADER..body.len(),
        }))
    }

    /// Read every chunk whose first message is not after the earliest
    /// message of those already read.
    fn load_due(&mut self) -> Result<(), Error> {
        while let Some(unit) = self.pending.last() {
            if let Some(Reverse((time, _, _))) = self.heap.peek() {
                if unit.start > *time {
                    break;
                }
            }
            let Some(unit) = self.pending.pop() else {
                break;
            };
            self.load(unit)?;
        }
        Ok(())
    }

    fn load(&mut self, unit: Unit) -> Result<(), Error> {
        let map = Arc::clone(&self.map);
        let mut scratch = self.spare.pop().unwrap_or_default();
        let (entries, in_map) = {
            let records = match &unit.source {
                Source::Indexed(index) => crate::chunk::records(&map, index, &mut scratch),
                Source::Found { header, data } => match map.get(data.clone()) {
                    Some(data) => crate::chunk::contents(header, data, &mut scratch),
                    None => Err("a chunk outside the file".to_owned()),
                },
            }
            .map_err(|e| format!("{}: {e}", self.path.display()))?;
            let mut entries = Vec::new();
            for record in Records(records) {
                let (opcode, body) = record.map_err(|e| format!("{}: {e}", self.path.display()))?;
                if opcode != op::MESSAGE {
                    continue;
                }
                if let Some(entry) = self.entry(body)? {
                    let data = range_in(records, &body[entry.data.clone()]).ok_or_else(|| {
                        format!("{}: a message outside its chunk", self.path.display())
                    })?;
                    entries.push(Entry { data, ..entry });
                }
            }
            // Uncompressed records lie in the map: their messages are given
            // from there.
            (entries, range_in(&map, records).map(|r| r.start))
        };
        let (buffer, mut entries) = match in_map {
            Some(base) => {
                self.spare.push(scratch);
                let mut entries = entries;
                for entry in &mut entries {
                    entry.data = entry.data.start + base..entry.data.end + base;
                }
                (Buffer::Map, entries)
            }
            None => (Buffer::Owned(scratch), entries),
        };
        if entries.is_empty() {
            if let Buffer::Owned(buffer) = buffer {
                self.spare.push(buffer);
            }
            return Ok(());
        }
        // Stable: messages of equal time stay in file order.
        entries.sort_by_key(|e| e.time);
        self.insert(Loaded {
            buffer,
            entries,
            next: 0,
            order: unit.order,
        });
        Ok(())
    }

    fn insert(&mut self, loaded: Loaded) {
        let slot = match self.loaded.iter().position(Option::is_none) {
            Some(slot) => slot,
            None => {
                self.loaded.push(None);
                self.loaded.len() - 1
            }
        };
        let Some(first) = loaded.entries.first() else {
            return;
        };
        self.heap.push(Reverse((first.time, loaded.order, slot)));
        self.loaded[slot] = Some(loaded);
    }
}

impl MessageCursor for McapMessages {
    fn current(&self) -> Option<BagMessage<'_>> {
        let Reverse((_, _, slot)) = self.heap.peek()?;
        let loaded = self.loaded.get(*slot)?.as_ref()?;
        let entry = loaded.entries.get(loaded.next)?;
        let buffer: &[u8] = match &loaded.buffer {
            Buffer::Map => &self.map,
            Buffer::Owned(bytes) => bytes,
        };
        // The ranges were taken from slices of this very buffer.
        let (topic, type_name) = self.topics.get(entry.topic)?;
        Some(BagMessage {
            topic,
            type_name,
            log_time: entry.time,
            publish_time: entry.publish_time,
            sequence: entry.sequence,
            data: buffer.get(entry.data.clone())?,
        })
    }

    fn advance(&mut self) -> Result<(), Error> {
        let Some(Reverse((_, order, slot))) = self.heap.pop() else {
            return Ok(());
        };
        self.given += 1;
        if let Some(entry) = self.loaded.get_mut(slot) {
            if let Some(loaded) = entry {
                loaded.next += 1;
                if let Some(next) = loaded.entries.get(loaded.next) {
                    self.heap.push(Reverse((next.time, order, slot)));
                } else if let Some(Loaded {
                    buffer: Buffer::Owned(bytes),
                    ..
                }) = entry.take()
                {
                    self.spare.push(bytes);
                }
            }
        }
        self.load_due()?;
        if self.heap.is_empty() && self.pending.is_empty() {
            if let Some(expected) = self.expected.take() {
                if expected != self.given {
                    tracing::warn!(
                        "{}: its summary counts {expected} messages, and {} were read: the \
                         summary does not describe the data (`bag info` and the counts of \
                         metadata.yaml come from it)",
                        self.path.display(),
                        self.given
                    );
                }
            }
        }
        Ok(())
    }
}

/// The records of an MCAP byte range, each its opcode and body, every
/// length checked against the range.
struct Records<'a>(&'a [u8]);

impl<'a> Iterator for Records<'a> {
    type Item = Result<(u8, &'a [u8]), String>;

    fn next(&mut self) -> Option<Self::Item> {
        let (&opcode, rest) = self.0.split_first()?;
        let Some((length, rest)) = rest.split_first_chunk::<8>() else {
            self.0 = &[];
            return Some(Err("a record cut off in its header".to_owned()));
        };
        let length = u64::from_le_bytes(*length);
        let Some(body) = usize::try_from(length).ok().and_then(|l| rest.get(..l)) else {
            self.0 = &[];
            return Some(Err(format!(
                "a record of {length} bytes where {} are left",
                rest.len()
            )));
        };
        self.0 = &rest[body.len()..];
        Some(Ok((opcode, body)))
    }
}

/// Where `inner` lies in `outer`, if it is a part of it.
fn range_in(outer: &[u8], inner: &[u8]) -> Option<std::ops::Range<usize>> {
    let start = (inner.as_ptr() as usize).checked_sub(outer.as_ptr() as usize)?;
    let end = start.checked_add(inner.len())?;
    (end <= outer.len()).then_some(start..end)
}

fn recorded_topic(channel: &mcap::Channel<'_>) -> RecordedTopic {
    let offered_qos = channel
        .metadata
        .get("offered_qos_profiles")
        .and_then(|text| qos::from_yaml(text).ok())
        .unwrap_or_default()
        .iter()
        .map(qos::QosProfile::to_qos)
        .collect();
    RecordedTopic {
        name: channel.topic.clone(),
        type_name: channel
            .schema
            .as_ref()
            .map(|s| s.name.clone())
            .unwrap_or_default(),
        type_hash: channel
            .metadata
            .get("topic_type_hash")
            .cloned()
            .unwrap_or_default(),
        offered_qos,
        message_encoding: channel.message_encoding.clone(),
        message_count: 0,
    }
}

pub(crate) fn map(path: &Path) -> Result<memmap2::Mmap, Error> {
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
    // SAFETY: the map is only read, and only while this process holds it; a
    // recording being rewritten under a player is outside what a player can
    // guard against (as for any reader of files), and MCAP parsing checks
    // every length against the map's end, so a change cannot make it read
    // out of bounds.
    unsafe { memmap2::Mmap::map(&file) }
        .map_err(|e| format!("cannot map {}: {e}", path.display()).into())
}

fn summary(path: &Path, file: &[u8]) -> Result<mcap::Summary, Error> {
    let unfinished = || {
        format!(
            "{} was not finished: it is still being recorded, or its recording was killed \
             or ran out of disk; then `shm-ros2 bag reindex <bag directory>` makes it readable",
            path.display()
        )
    };
    match mcap::Summary::read(file) {
        Ok(Some(summary)) => {
            check_summary(path, file, &summary)?;
            Ok(summary)
        }
        Ok(None) => Err(unfinished().into()),
        // It starts as an MCAP file and does not end as one.
        Err(_) if file.starts_with(mcap::MAGIC) && !file.ends_with(mcap::MAGIC) => {
            Err(unfinished().into())
        }
        Err(e) => Err(format!("{}: not a readable MCAP file: {e}", path.display()).into()),
    }
}

/// Refuse a summary whose chunk index points outside the file or declares
/// chunks larger than are read, before anything is sized from it (a player's
/// shared-memory pool is sized from the largest chunk).
fn check_summary(path: &Path, file: &[u8], summary: &mcap::Summary) -> Result<(), Error> {
    for index in &summary.chunk_indexes {
        let end = index.chunk_start_offset.checked_add(index.chunk_length);
        if end.is_none_or(|end| end > file.len() as u64) {
            return Err(format!(
                "{}: its chunk index points past the file's end (offset {}, length {}): \
                 the summary is damaged",
                path.display(),
                index.chunk_start_offset,
                index.chunk_length
            )
            .into());
        }
        if index.uncompressed_size > crate::chunk::MAX_CHUNK_SIZE {
            return Err(format!(
                "{}: its chunk index declares a chunk of {} bytes, more than the {} read: \
                 the summary is damaged",
                path.display(),
                index.uncompressed_size,
                crate::chunk::MAX_CHUNK_SIZE
            )
            .into());
        }
    }
    Ok(())
}
