//! Reading a recording: a bag directory (its `metadata.yaml` and files) or
//! one MCAP or sqlite3 file, whatever the storage, in log-time order.

use std::collections::{BTreeMap, BinaryHeap, HashMap};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::metadata::BagMetadata;
use crate::qos;
use crate::storage::{BagMessage, Compressed, MessageCursor, RecordedTopic, Storage, StorageFile};
use crate::Error;

/// A recording on disk: a bag directory (with `metadata.yaml`) of MCAP or
/// sqlite3 files, or one such file.
///
/// ```no_run
/// use std::ops::ControlFlow;
///
/// let bag = shm_bag::Bag::open("my_bag".as_ref())?;
/// for topic in bag.topics()? {
///     println!("{}: {} ({} messages)", topic.name, topic.type_name, topic.message_count);
/// }
/// // Every message in log-time order, whatever the storage.
/// bag.read(0, |_file| {}, |message| {
///     println!("{} {} {} bytes", message.log_time, message.topic, message.data.len());
///     ControlFlow::<()>::Continue(())
/// })?;
/// # Ok::<(), shm_bag::Error>(())
/// ```
#[derive(Debug)]
pub struct Bag {
    pub(crate) files: Vec<PathBuf>,
    /// Each file's storage.
    storages: Vec<Storage>,
    /// Each file's compression by rosbag2 (whole file, or each message).
    compressions: Vec<Compressed>,
    metadata: Option<BagMetadata>,
    /// Whole-file-compressed files, decompressed when first read: file index
    /// → its decompressed copy, in a directory removed with the `Bag`.
    decompressed: Mutex<Decompressed>,
}

#[derive(Debug, Default)]
struct Decompressed {
    dir: Option<tempfile::TempDir>,
    paths: HashMap<usize, PathBuf>,
}

impl Bag {
    /// Open `path`: a bag directory, or one `.mcap` or `.db3` file.
    pub fn open(path: &Path) -> Result<Self, Error> {
        if path.is_dir() {
            let listing = path.join(crate::metadata::FILE_NAME);
            if listing.exists() {
                regular_file_inside(path, &listing)?;
            }
            let metadata = BagMetadata::read(path)?;
            let Some(storage) = Storage::from_identifier(&metadata.storage_identifier) else {
                return Err(format!(
                    "{}: its storage is `{}`; this tool reads rosbag2's `mcap` and `sqlite3` \
                     storages: convert it to one of them first",
                    path.display(),
                    shm_cdr::text_limits::quoted(&metadata.storage_identifier)
                )
                .into());
            };
            let compressed =
                Compressed::of(&metadata.compression_mode, &metadata.compression_format)
                    .map_err(|e| format!("{}: {e}", path.display()))?;
            let mut files = Vec::with_capacity(metadata.relative_file_paths.len());
            for file in &metadata.relative_file_paths {
                // A recording names its files inside its directory: a path
                // that leads out of it is not one of its files.
                let inside = std::path::Path::new(file).components().all(|c| {
                    matches!(
                        c,
                        std::path::Component::Normal(_) | std::path::Component::CurDir
                    )
                });
                if !inside {
                    return Err(format!(
                        "{}: {} lists `{}`, which is not inside the bag directory",
                        path.display(),
                        crate::metadata::FILE_NAME,
                        shm_cdr::text_limits::quoted(file)
                    )
                    .into());
                }
                files.push(regular_file_inside(path, &path.join(file))?);
            }
            return Ok(Self {
                storages: vec![storage; files.len()],
                compressions: vec![compressed; files.len()],
                files,
                metadata: Some(metadata),
                decompressed: Mutex::default(),
            });
        }
        if path.exists() {
            regular_file(path)?;
            return Ok(Self {
                files: vec![path.to_owned()],
                storages: vec![Storage::of_file(path)?],
                compressions: vec![Compressed::No],
                metadata: None,
                decompressed: Mutex::default(),
            });
        }
        Err(format!(
            "{}: no such bag directory, MCAP or sqlite3 file",
            path.display()
        )
        .into())
    }

    /// The MCAP files `files`, without a `metadata.yaml`.
    pub(crate) fn from_files(files: Vec<PathBuf>) -> Self {
        Self {
            storages: vec![Storage::Mcap; files.len()],
            compressions: vec![Compressed::No; files.len()],
            files,
            metadata: None,
            decompressed: Mutex::default(),
        }
    }

    /// The recording's files, in order.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// The storage of its files (of its first, for recordings
    /// [merged](Self::merge) from several storages).
    pub fn storage(&self) -> Storage {
        self.storages.first().copied().unwrap_or(Storage::Mcap)
    }

    /// One recording of all of `bags`' files: read, they give the messages
    /// of all in log-time order, as `ros2 bag convert` merges its inputs.
    pub fn merge(bags: impl IntoIterator<Item = Bag>) -> Self {
        let mut merged = Self {
            files: Vec::new(),
            storages: Vec::new(),
            compressions: Vec::new(),
            metadata: None,
            decompressed: Mutex::default(),
        };
        for bag in bags {
            merged.files.extend(bag.files);
            merged.storages.extend(bag.storages);
            merged.compressions.extend(bag.compressions);
        }
        merged
    }

    /// `metadata.yaml`, for a bag directory.
    pub fn metadata(&self) -> Option<&BagMetadata> {
        self.metadata.as_ref()
    }

    pub(crate) fn open_files(
        &self,
    ) -> impl Iterator<Item = Result<Box<dyn StorageFile>, Error>> + '_ {
        (0..self.files.len()).map(|index| self.open_file(index))
    }

    /// Open file `index` through its storage; a whole-file-compressed one is
    /// decompressed first (once), beside the bag where there is room to, as
    /// rosbag2 does, else in the temporary directory.
    fn open_file(&self, index: usize) -> Result<Box<dyn StorageFile>, Error> {
        let path = &self.files[index];
        if self.compressions[index] != Compressed::File {
            return self.storages[index].open(path);
        }
        let mut decompressed = self
            .decompressed
            .lock()
            .map_err(|_| "a thread reading the bag panicked")?;
        if let Some(copy) = decompressed.paths.get(&index) {
            return self.storages[index].open(copy);
        }
        if decompressed.dir.is_none() {
            let beside = path.parent().filter(|p| !p.as_os_str().is_empty());
            let dir = beside
                .and_then(|dir| {
                    tempfile::Builder::new()
                        .prefix(".decompressed-")
                        .tempdir_in(dir)
                        .ok()
                })
                .map_or_else(|| tempfile::Builder::new().prefix("shm-bag-").tempdir(), Ok)
                .map_err(|e| format!("no directory to decompress {} into: {e}", path.display()))?;
            decompressed.dir = Some(dir);
        }
        let Some(dir) = decompressed.dir.as_ref() else {
            return Err("no directory to decompress into".into());
        };
        let copy = crate::storage::decompress_file(path, dir.path())?;
        decompressed.paths.insert(index, copy.clone());
        self.storages[index].open(&copy)
    }

    /// What the recording holds: its `metadata.yaml`, or for a lone file the
    /// same facts read from the file.
    pub fn describe(&self) -> Result<BagMetadata, Error> {
        if let Some(metadata) = &self.metadata {
            return Ok(metadata.clone());
        }
        let mut start = u64::MAX;
        let mut end = 0;
        let mut count = 0;
        for file in self.open_files() {
            let stats = file?.stats()?;
            if stats.count > 0 {
                start = start.min(stats.start);
                end = end.max(stats.end);
                count += stats.count;
            }
        }
        let start = if count == 0 { 0 } else { start };
        let topics = self.topics()?;
        Ok(BagMetadata {
            version: crate::metadata::VERSION,
            storage_identifier: self.storage().identifier().to_owned(),
            duration: crate::metadata::Nanoseconds {
                nanoseconds: end.saturating_sub(start),
            },
            starting_time: crate::metadata::NanosecondsSinceEpoch {
                nanoseconds_since_epoch: start,
            },
            message_count: count,
            topics_with_message_count: topics
                .into_iter()
                .map(|t| crate::metadata::TopicWithMessageCount {
                    message_count: t.message_count,
                    topic_metadata: crate::metadata::TopicMetadata {
                        name: t.name,
                        type_name: t.type_name,
                        serialization_format: t.message_encoding,
                        offered_qos_profiles: t
                            .offered_qos
                            .iter()
                            .map(qos::QosProfile::from)
                            .collect(),
                        type_description_hash: t.type_hash,
                    },
                })
                .collect(),
            compression_format: String::new(),
            compression_mode: String::new(),
            relative_file_paths: self
                .files
                .iter()
                .map(|p| {
                    p.file_name()
                        .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
                })
                .collect(),
            files: Vec::new(),
            custom_data: None,
            ros_distro: String::new(),
        })
    }

    /// The size of the recording's files in bytes.
    pub fn size(&self) -> u64 {
        self.files
            .iter()
            .filter_map(|p| std::fs::metadata(p).ok())
            .map(|m| m.len())
            .sum()
    }

    /// Read the messages of log time `from` or later, in log-time order
    /// across all files, as `ros2 bag play` does, whatever order the files
    /// hold them in: `on_file` is told of each file when its first message
    /// is given, `each` is given every message, and may stop the reading
    /// with what it breaks with. A file is opened when its first message may
    /// be due, and in MCAP a chunk is read when its first message is due: a
    /// seek or a start offset costs no decompression of what it skips, and a
    /// recording in order has one file and one chunk open at a time.
    pub fn read<T>(
        &self,
        from: u64,
        mut on_file: impl FnMut(&Path),
        mut each: impl FnMut(&BagMessage<'_>) -> ControlFlow<T>,
    ) -> Result<Option<T>, Error> {
        // Each file's first message time, the earliest last.
        let mut pending = Vec::with_capacity(self.files.len());
        for (index, file) in self.open_files().enumerate() {
            let stats = file?.stats()?;
            if stats.count > 0 && stats.end >= from {
                pending.push((stats.start, index));
            }
        }
        pending.sort_by_key(|&(start, index)| std::cmp::Reverse((start, index)));
        let mut cursors: Vec<Option<Box<dyn MessageCursor>>> =
            (0..self.files.len()).map(|_| None).collect();
        let mut entered = vec![false; self.files.len()];
        let mut heap = BinaryHeap::new();
        let mut scratch = Vec::new();
        loop {
            while let Some(&(start, index)) = pending.last() {
                if heap
                    .peek()
                    .is_some_and(|&std::cmp::Reverse((time, _))| start > time)
                {
                    break;
                }
                pending.pop();
                let cursor = self.open_file(index)?.messages(from)?;
                if let Some(message) = cursor.current() {
                    heap.push(std::cmp::Reverse((message.log_time, index)));
                    cursors[index] = Some(cursor);
                }
            }
            let Some(std::cmp::Reverse((_, index))) = heap.pop() else {
                return Ok(None);
            };
            let Some(cursor) = cursors[index].as_mut() else {
                continue;
            };
            if !entered[index] {
                entered[index] = true;
                on_file(&self.files[index]);
            }
            if let Some(message) = cursor.current() {
                let ended = if self.compressions[index] == Compressed::Message {
                    let data = crate::storage::decompress_message(message.data, &mut scratch)
                        .map_err(|e| format!("{}: {e}", self.files[index].display()))?;
                    each(&BagMessage { data, ..message })
                } else {
                    each(&message)
                };
                if let ControlFlow::Break(ended) = ended {
                    return Ok(Some(ended));
                }
            }
            cursor.advance()?;
            match cursor.current() {
                Some(next) => heap.push(std::cmp::Reverse((next.log_time, index))),
                None => cursors[index] = None,
            }
        }
    }

    /// [`read`](Self::read), each message as its topic, log time and bytes.
    pub fn read_messages<T>(
        &self,
        from: u64,
        on_file: impl FnMut(&Path),
        mut each: impl FnMut(&str, u64, &[u8]) -> ControlFlow<T>,
    ) -> Result<Option<T>, Error> {
        self.read(from, on_file, |m| each(m.topic, m.log_time, m.data))
    }

    /// The topics in all files, each with its type, by name and then type:
    /// a topic recorded with several types is listed once with each.
    pub fn topics(&self) -> Result<Vec<RecordedTopic>, Error> {
        let mut out: BTreeMap<(String, String), RecordedTopic> = BTreeMap::new();
        for file in self.open_files() {
            for topic in file?.topics()? {
                let key = (topic.name.clone(), topic.type_name.clone());
                match out.get_mut(&key) {
                    Some(known) => known.message_count += topic.message_count,
                    None => {
                        out.insert(key, topic);
                    }
                }
            }
        }
        Ok(out.into_values().collect())
    }

    /// The `ros2msg` definition of each type a file keeps one of (all MCAP
    /// files do; sqlite3 files since Iron), by type name.
    pub fn definitions(&self) -> Result<BTreeMap<String, String>, Error> {
        let mut out = BTreeMap::new();
        for file in self.open_files() {
            for (name, definition) in file?.definitions()? {
                out.entry(name).or_insert(definition);
            }
        }
        Ok(out)
    }
}

/// `file`, listed by the bag directory `dir`, if it is a regular file inside
/// the directory once links are resolved. A file not there yet is let
/// through: reading it says it is missing.
fn regular_file_inside(dir: &Path, file: &Path) -> Result<PathBuf, Error> {
    if std::fs::symlink_metadata(file).is_err() {
        return Ok(file.to_owned());
    }
    let resolved = std::fs::canonicalize(file)
        .map_err(|e| format!("{}: cannot resolve it: {e}", file.display()))?;
    let dir_resolved = std::fs::canonicalize(dir)
        .map_err(|e| format!("{}: cannot resolve it: {e}", dir.display()))?;
    if !resolved.starts_with(&dir_resolved) {
        return Err(format!(
            "{}: a link to {}, outside the bag directory: a recording's files are inside it",
            file.display(),
            resolved.display()
        )
        .into());
    }
    regular_file(&resolved)?;
    Ok(file.to_owned())
}

/// Refuse anything but a regular file (a FIFO, a device or a directory
/// would block or mislead the reader), naming what it is.
fn regular_file(path: &Path) -> Result<(), Error> {
    let kind = std::fs::metadata(path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .file_type();
    if kind.is_file() {
        return Ok(());
    }
    let what = if kind.is_dir() {
        "a directory without metadata.yaml"
    } else {
        special_file(&kind)
    };
    Err(format!(
        "{}: {what}; a bag is a directory with metadata.yaml, or one .mcap or .db3 file",
        path.display()
    )
    .into())
}

/// What a file that is neither regular nor a directory is.
#[cfg(unix)]
fn special_file(kind: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if kind.is_fifo() {
        "a FIFO"
    } else if kind.is_socket() {
        "a socket"
    } else if kind.is_block_device() || kind.is_char_device() {
        "a device"
    } else {
        "not a regular file"
    }
}

#[cfg(not(unix))]
fn special_file(_: &std::fs::FileType) -> &'static str {
    "not a regular file"
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::writer::tests::topic;
    use crate::{BagWriter, WriteOptions};

    #[test]
    fn a_bag_naming_files_outside_its_directory_or_a_storage_not_read_is_refused() {
        let dir = std::env::temp_dir().join(format!("shm-bag-outside-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut writer = BagWriter::create(&dir, WriteOptions::default()).unwrap();
        writer.add_topic(topic("/chatter"), String::new()).unwrap();
        let mut metadata = writer.finish().unwrap();
        assert!(Bag::open(&dir).is_ok());
        for outside in ["../../etc/passwd", "/etc/passwd", "a/../../b.mcap"] {
            metadata.relative_file_paths = vec![outside.to_owned()];
            let path = dir.join(crate::metadata::FILE_NAME);
            std::fs::write(&path, metadata.to_yaml()).unwrap();
            let error = Bag::open(&dir).unwrap_err().to_string();
            assert!(error.contains("not inside the bag directory"), "{error}");
        }
        // A storage this crate does not read is named.
        metadata.relative_file_paths = vec!["bag_0.bag".to_owned()];
        metadata.storage_identifier = "rosbag_v2".to_owned();
        std::fs::write(dir.join(crate::metadata::FILE_NAME), metadata.to_yaml()).unwrap();
        let error = Bag::open(&dir).unwrap_err().to_string();
        assert!(error.contains("its storage is `rosbag_v2`"), "{error}");
        // So is a compression rosbag2 does not write.
        metadata.storage_identifier = "sqlite3".to_owned();
        metadata.compression_mode = "FILE".to_owned();
        metadata.compression_format = "bz2".to_owned();
        std::fs::write(dir.join(crate::metadata::FILE_NAME), metadata.to_yaml()).unwrap();
        let error = Bag::open(&dir).unwrap_err().to_string();
        assert!(
            error.contains("compression_format `bz2` is not read"),
            "{error}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A bag directory's files are regular files inside it once links are
    /// resolved: a link out of it, a FIFO (which would block the reader) or
    /// a directory is refused, naming it; a link within it is followed.
    #[cfg(unix)]
    #[test]
    fn a_bag_file_that_links_out_or_is_not_a_regular_file_is_refused_by_name() {
        let root = std::env::temp_dir().join(format!("shm-bag-links-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = root.join("bag");
        let mut writer = BagWriter::create(&dir, WriteOptions::default()).unwrap();
        writer.add_topic(topic("/chatter"), String::new()).unwrap();
        let mut metadata = writer.finish().unwrap();
        let recorded = dir.join(&metadata.relative_file_paths[0]);
        let outside = root.join("outside.mcap");
        std::fs::copy(&recorded, &outside).unwrap();
        let listing = dir.join(crate::metadata::FILE_NAME);
        let open_with = |name: &str, metadata: &mut BagMetadata| {
            metadata.relative_file_paths = vec![name.to_owned()];
            std::fs::write(&listing, metadata.to_yaml()).unwrap();
            Bag::open(&dir).map(|_| ()).map_err(|e| e.to_string())
        };
        std::os::unix::fs::symlink(&outside, dir.join("out.mcap")).unwrap();
        let error = open_with("out.mcap", &mut metadata).unwrap_err();
        assert!(error.contains("outside the bag directory"), "{error}");
        assert!(error.contains("out.mcap"), "{error}");
        std::os::unix::fs::symlink(&recorded, dir.join("in.mcap")).unwrap();
        open_with("in.mcap", &mut metadata).unwrap();
        let fifo = dir.join("fifo.mcap");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let error = open_with("fifo.mcap", &mut metadata).unwrap_err();
            assert!(error.contains("a FIFO"), "{error}");
            let error = Bag::open(&fifo).unwrap_err().to_string();
            assert!(error.contains("a FIFO"), "{error}");
        }
        std::fs::create_dir(dir.join("sub.mcap")).unwrap();
        let error = open_with("sub.mcap", &mut metadata).unwrap_err();
        assert!(error.contains("a directory"), "{error}");
        let _ = std::fs::remove_dir_all(&root);
    }
}
