//! Playing a recording back: every selected topic published with its
//! recorded type and QoS, each message at its recorded time (scaled by a
//! rate), from an exact-size shared-memory buffer when it is large.

use std::collections::{BTreeMap, BinaryHeap, HashMap};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::builtin_interfaces::msg::Time;
use shm_cdr::msgs::rosgraph_msgs::msg::Clock;
use shm_runtime::rmw::{Distro, Qos};
use shm_runtime::{
    PayloadKind, PublishError, PublishOutcome, RosNode, RosPublisher, Serialized, ShmConfig,
    ShmContext,
};
use zenoh::Wait;

use crate::control::{Due, PlayerControl};
use crate::definition;
use crate::interfaces::rosbag2_interfaces::msg::ReadSplitEvent;
use crate::local::LocalInterfaces;
use crate::metadata::BagMetadata;
use crate::qos;
use crate::split_events::SplitEvents;
use crate::storage::{BagMessage, Compressed, MessageCursor, Storage, StorageFile};
use crate::types;
use crate::writer::FileSplit;
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
    files: Vec<PathBuf>,
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

    fn open_files(&self) -> impl Iterator<Item = Result<Box<dyn StorageFile>, Error>> + '_ {
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

/// How to play.
#[derive(Debug, Clone)]
pub struct PlayOptions {
    /// Time runs this much faster than recorded (default 1).
    pub rate: f64,
    /// Start again at the end, until stopped.
    pub loop_playback: bool,
    /// Only these topics (default: all).
    pub topics: Vec<String>,
    /// Wait this long after declaring the publishers before the first
    /// message, so that subscribers can match them (default 0).
    pub delay: Duration,
    /// The ROS domain (default `ROS_DOMAIN_ID`, else 0).
    pub domain_id: Option<u32>,
    /// The distribution whose conventions the node speaks (default
    /// `ROS_DISTRO`, else [`Distro::DEFAULT`]).
    pub distro: Option<Distro>,
    /// The player's node name (default `rosbag2_player`, as `ros2 bag play`'s).
    pub node_name: String,
    /// Before the first message, wait up to this long until every topic's
    /// publisher has a subscriber (default: do not wait).
    pub wait_for_subscribers: Option<Duration>,
    /// Publish the playback's time on `/clock` this many times a second (a
    /// ROS time source for nodes with `use_sim_time`); recorded `/clock`
    /// messages are then not played (default: do not publish).
    pub clock_hz: Option<f64>,
    /// Publish the time on `/clock` just before each message of these topics.
    pub clock_on: ClockTrigger,
    /// Start this far into the recording (default 0): earlier messages are
    /// skipped, and the playback's time starts there.
    pub start_offset: Duration,
    /// Play this much of the recording from the start (after the offset),
    /// then stop (default: all of it).
    pub duration: Option<Duration>,
    /// Start paused, to be resumed or stepped through the
    /// [`PlayerControl`] (default: play at once).
    pub start_paused: bool,
}

/// Which played messages the playback's time is published on `/clock`
/// before ([`PlayOptions::clock_on`]), as `ros2 bag play --clock-topics`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum ClockTrigger {
    /// None (the default).
    #[default]
    Never,
    /// Every one.
    AllTopics,
    /// Those of these topics.
    Topics(Vec<String>),
}

impl ClockTrigger {
    fn fires_on(&self, topic: &str) -> bool {
        match self {
            Self::Never => false,
            Self::AllTopics => true,
            Self::Topics(topics) => topics.iter().any(|t| t == topic),
        }
    }
}

impl Default for PlayOptions {
    fn default() -> Self {
        Self {
            rate: 1.0,
            loop_playback: false,
            topics: Vec::new(),
            delay: Duration::ZERO,
            domain_id: None,
            distro: None,
            node_name: "rosbag2_player".to_owned(),
            wait_for_subscribers: None,
            clock_hz: None,
            clock_on: ClockTrigger::Never,
            start_offset: Duration::ZERO,
            duration: None,
            start_paused: false,
        }
    }
}

/// What a playback did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PlayStats {
    /// Messages published.
    pub published: u64,
    /// Their bytes.
    pub bytes: u64,
    /// Of them, published from shared memory.
    pub shm: u64,
    /// Messages whose publish failed.
    pub failed: u64,
}

/// Plays a [`Bag`] back through a node of its own.
///
/// The node answers rosbag2's player services under its name (`~/pause`,
/// `~/resume`, `~/toggle_paused`, `~/is_paused`, `~/get_rate`, `~/set_rate`,
/// `~/play_next`, `~/burst`, `~/seek`, `~/stop`; types in
/// [`interfaces`](crate::interfaces)), as `ros2 bag play` does; code in the
/// same process steers it through [`control`](Self::control). Moving on from
/// one file of the recording to the next, it says so on
/// `/events/read_split`.
///
/// ```no_run
/// use std::sync::atomic::AtomicBool;
/// use shm_bag::{Bag, PlayOptions, Player};
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let bag = Bag::open("my_bag".as_ref())?;
/// let player = Player::new(&session, bag, PlayOptions::default())?;
/// let stats = player.play(&AtomicBool::new(false))?;
/// println!("{} messages", stats.published);
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
pub struct Player {
    bag: Bag,
    options: PlayOptions,
    _node: RosNode,
    /// By topic, then type: a topic may be recorded with several.
    publishers: HashMap<String, Vec<(String, PlayedPublisher)>>,
    clock: Option<RosPublisher<Clock>>,
    /// Where the playback starts: the recording's first message time (ns
    /// since the Unix epoch), plus the start offset.
    begin: u64,
    control: PlayerControl,
    _services: ControlServices,
    read_splits: SplitEvents<ReadSplitEvent>,
}

impl std::fmt::Debug for Player {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Player")
            .field("files", &self.bag.files)
            .field("topics", &self.publishers.len())
            .finish_non_exhaustive()
    }
}

impl Player {
    /// Declare a publisher for each selected topic of `bag`, with its
    /// recorded type and QoS, in a node of its own in `session`, with a
    /// shared-memory pool that holds the recording's largest messages.
    pub fn new(session: &zenoh::Session, bag: Bag, options: PlayOptions) -> Result<Self, Error> {
        if !(options.rate > 0.0 && options.rate.is_finite()) {
            return Err(format!("rate {}: give a number above 0", options.rate).into());
        }
        if let Some(hz) = options.clock_hz {
            if !(hz > 0.0 && hz.is_finite()) || Duration::try_from_secs_f64(1.0 / hz).is_err() {
                return Err(format!("clock rate {hz} Hz: give a number above 0").into());
            }
        }
        let publishes_clock = options.clock_hz.is_some() || options.clock_on != ClockTrigger::Never;
        let topics = bag.topics()?;
        for wanted in &options.topics {
            if !topics.iter().any(|t| &t.name == wanted) {
                let mut list: Vec<&str> = topics.iter().map(|t| t.name.as_str()).collect();
                list.dedup();
                return Err(format!(
                    "the recording has no topic {wanted}; it has {}",
                    list.join(", ")
                )
                .into());
            }
        }
        let largest = largest_message(&bag)?;
        let pool = (largest.saturating_mul(4)).clamp(ShmConfig::DEFAULT_POOL_SIZE, 1 << 30);
        let shm = ShmContext::new(ShmConfig::enabled().pool_size_at_most(pool))?;
        let mut builder = RosNode::builder(session, &options.node_name).shm(&shm);
        if let Some(domain_id) = options.domain_id {
            builder = builder.domain_id(domain_id);
        }
        if let Some(distro) = options.distro {
            builder = builder.distro(distro);
        }
        let node = builder.wait()?;
        let definitions = bag.definitions()?;
        let mut publishers = HashMap::new();
        for topic in &topics {
            if !options.topics.is_empty() && !options.topics.contains(&topic.name) {
                continue;
            }
            // The playback's own clock replaces the recorded one.
            if publishes_clock && topic.name == "/clock" {
                continue;
            }
            let recorded = recorded_type(topic, &definitions, node.info().distro);
            let hash = if topic.type_hash.is_empty() {
                // Recorded without a hash (an older rosbag2): the type's
                // definition, else the standard type of that name, gives it.
                recorded.as_ref().map(|t| t.ty.type_hash()).ok_or_else(|| {
                    format!(
                        "{}: the recording gives no type hash for {}, keeps no definition of it, \
                         and it is not a standard type",
                        topic.name, topic.type_name
                    )
                })?
            } else {
                topic.type_hash.clone()
            };
            let qos = playback_qos(&topic.offered_qos);
            // A type the recording defines is described by the player's
            // node, as the recorded node did, so that tools (and a recorder)
            // can read the played messages.
            let publisher = match recorded.filter(|t| t.ty.type_hash() == hash) {
                Some(recorded) => node
                    .declare_dynamic_publisher(&topic.name, &recorded.ty, qos)
                    .type_sources(definition::split(&topic.type_name, &recorded.definition))
                    .wait()
                    .map(PlayedPublisher::Described)?,
                None => node
                    .declare_serialized_publisher(&topic.name, &topic.type_name, &hash, qos)
                    .wait()
                    .map(PlayedPublisher::Bytes)?,
            };
            publishers
                .entry(topic.name.clone())
                .or_insert_with(Vec::new)
                .push((topic.type_name.clone(), publisher));
        }
        let clock = publishes_clock
            .then(|| {
                node.declare_publisher_with_qos::<Clock>("/clock", Qos::clock())
                    .wait()
            })
            .transpose()?;
        let (bag_start, bag_end) = bag_bounds(&bag)?;
        let begin = bag_start
            .saturating_add(u64::try_from(options.start_offset.as_nanos()).unwrap_or(u64::MAX));
        let control = PlayerControl::new(
            bag_start,
            bag_end,
            begin,
            options.rate,
            options.start_paused,
        );
        let services = ControlServices::declare(&node, &control)?;
        let read_splits = SplitEvents::declare(&node)?;
        Ok(Self {
            bag,
            options,
            _node: node,
            publishers,
            clock,
            begin,
            control,
            _services: services,
            read_splits,
        })
    }

    /// A handle to pause, resume, step, seek or stop the playback from
    /// another thread.
    pub fn control(&self) -> PlayerControl {
        self.control.clone()
    }

    /// Publish the recording, each message at its recorded time from the
    /// start (divided by the rate), until its end (or, looping, until `stop`
    /// is set or the [`PlayerControl`] stops it). Messages come from the file
    /// as mapped: from the page cache into the publisher's buffer is their
    /// one copy. With a clock ([`PlayOptions::clock_hz`]), the playback's time
    /// goes out on `/clock` from the first call on, the start's until the
    /// first message is due.
    pub fn play(&self, stop: &AtomicBool) -> Result<PlayStats, Error> {
        let begin = self.begin;
        let end = self
            .options
            .duration
            .map(|d| begin.saturating_add(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)));
        let finished = AtomicBool::new(false);
        let played = std::thread::scope(|scope| {
            if let (Some(clock), Some(hz)) = (&self.clock, self.options.clock_hz) {
                // Checked when the player was made.
                let period = Duration::try_from_secs_f64(1.0 / hz).unwrap_or(Duration::MAX);
                let (control, finished) = (&self.control, &finished);
                scope.spawn(move || {
                    let mut next = Instant::now();
                    while !finished.load(Ordering::Relaxed)
                        && !stop.load(Ordering::Relaxed)
                        && !control.is_stopped()
                    {
                        publish_clock(clock, control.time());
                        next += period;
                        let now = Instant::now();
                        if next > now {
                            std::thread::sleep(next - now);
                        } else {
                            next = now;
                        }
                    }
                });
            }
            let played = self.play_passes(stop, begin, end);
            finished.store(true, Ordering::Relaxed);
            played
        });
        self.control.finish();
        played
    }

    fn play_passes(
        &self,
        stop: &AtomicBool,
        begin: u64,
        end: Option<u64>,
    ) -> Result<PlayStats, Error> {
        if let Some(timeout) = self.options.wait_for_subscribers {
            let deadline = Instant::now() + timeout;
            for (_, publisher) in self.publishers.values().flatten() {
                publisher.wait_for_subscribers(deadline.saturating_duration_since(Instant::now()));
            }
            if let Some(clock) = &self.clock {
                clock.wait_for_subscribers(deadline.saturating_duration_since(Instant::now()));
            }
        }
        std::thread::sleep(self.options.delay);
        let mut stats = PlayStats::default();
        let mut from = self.control.start_pass(begin);
        loop {
            match self.play_pass(stop, from, end, &mut stats)? {
                PassEnd::Stopped => return Ok(stats),
                PassEnd::Seek(to) => from = to,
                PassEnd::Finished => {
                    if !self.options.loop_playback || stop.load(Ordering::Relaxed) {
                        return Ok(stats);
                    }
                    from = self.control.start_pass(begin);
                }
            }
        }
    }

    /// Play the messages from the recording's time `from` to `end`. With a
    /// chunk index (rosbag2 and this crate write one), chunks wholly before
    /// `from` or after `end` are not read at all: a seek or a start offset
    /// costs no decompression of what it skips.
    fn play_pass(
        &self,
        stop: &AtomicBool,
        from: u64,
        end: Option<u64>,
        stats: &mut PlayStats,
    ) -> Result<PassEnd, Error> {
        let mut previous: Option<PathBuf> = None;
        let ended = self.bag.read(
            from,
            |path| {
                if let Some(closed) = previous.replace(path.to_owned()) {
                    self.read_splits.publish(&FileSplit {
                        closed,
                        opened: path.to_owned(),
                    });
                }
            },
            |message| {
                let (topic, time, data) = (message.topic, message.log_time, message.data);
                let publisher = self.publishers.get(topic).and_then(|by_type| {
                    by_type
                        .iter()
                        .find(|(type_name, _)| type_name == message.type_name)
                        .map(|(_, publisher)| publisher)
                });
                let Some(publisher) = publisher else {
                    return ControlFlow::Continue(());
                };
                if time < from {
                    return ControlFlow::Continue(());
                }
                if end.is_some_and(|end| time > end) {
                    // Files hold messages in time order: none is due after.
                    return ControlFlow::Break(PassEnd::Finished);
                }
                match self.play_message(stop, topic, publisher, time, data, stats) {
                    Some(ended) => ControlFlow::Break(ended),
                    None => ControlFlow::Continue(()),
                }
            },
        )?;
        Ok(ended.unwrap_or(PassEnd::Finished))
    }

    /// Publish one message of `topic` when it is due; what ends the pass
    /// instead, if anything.
    fn play_message(
        &self,
        stop: &AtomicBool,
        topic: &str,
        publisher: &PlayedPublisher,
        time: u64,
        data: &[u8],
        stats: &mut PlayStats,
    ) -> Option<PassEnd> {
        let due = self.control.wait_due(time, stop);
        match due {
            Due::Stop => return Some(PassEnd::Stopped),
            Due::Seek(to) => return Some(PassEnd::Seek(to)),
            Due::Play | Due::Step => {}
        }
        if let Some(clock) = &self.clock {
            if self.options.clock_on.fires_on(topic) {
                publish_clock(clock, time);
            }
        }
        let published = match publisher.publish_serialized(data) {
            Ok(outcome) => {
                stats.published += 1;
                stats.bytes += data.len() as u64;
                if outcome.kind == PayloadKind::Shm {
                    stats.shm += 1;
                }
                true
            }
            Err(e) => {
                stats.failed += 1;
                tracing::warn!("publishing a recorded message failed: {e}");
                false
            }
        };
        if due == Due::Step {
            self.control.stepped(time, published);
        }
        None
    }
}

/// How a pass through the recording ended.
enum PassEnd {
    Finished,
    Seek(u64),
    Stopped,
}

/// rosbag2's player services on the player's node, each steering its
/// [`PlayerControl`].
struct ControlServices {
    _servers: Vec<Box<dyn std::any::Any + Send + Sync>>,
}

impl ControlServices {
    fn declare(node: &RosNode, control: &PlayerControl) -> Result<Self, Error> {
        fn serve<S, F>(
            node: &RosNode,
            servers: &mut Vec<Box<dyn std::any::Any + Send + Sync>>,
            name: &str,
            control: &PlayerControl,
            answer: F,
        ) -> Result<(), Error>
        where
            S: shm_cdr::RosService,
            F: Fn(&PlayerControl, S::Request) -> S::Response + Send + 'static,
        {
            let control = control.clone();
            let server = node
                .declare_service::<S>(name)
                .handler(move |request| answer(&control, request))
                .wait()?;
            servers.push(Box::new(server));
            Ok(())
        }
        use crate::interfaces::rosbag2_interfaces::srv as s;
        let mut servers = Vec::new();
        let v = &mut servers;
        serve::<s::Pause, _>(node, v, "~/pause", control, |c, _| {
            c.pause();
            s::Pause_Response
        })?;
        serve::<s::Resume, _>(node, v, "~/resume", control, |c, _| {
            c.resume();
            s::Resume_Response
        })?;
        serve::<s::TogglePaused, _>(node, v, "~/toggle_paused", control, |c, _| {
            c.toggle_paused();
            s::TogglePaused_Response
        })?;
        serve::<s::IsPaused, _>(node, v, "~/is_paused", control, |c, _| {
            s::IsPaused_Response {
                paused: c.is_paused(),
            }
        })?;
        serve::<s::GetRate, _>(node, v, "~/get_rate", control, |c, _| s::GetRate_Response {
            rate: c.rate(),
        })?;
        serve::<s::SetRate, _>(node, v, "~/set_rate", control, |c, r| s::SetRate_Response {
            success: c.set_rate(r.rate),
        })?;
        serve::<s::PlayNext, _>(node, v, "~/play_next", control, |c, _| {
            s::PlayNext_Response {
                success: c.play_next(),
            }
        })?;
        serve::<s::Burst, _>(node, v, "~/burst", control, |c, r| s::Burst_Response {
            actually_burst: c.burst(r.num_messages),
        })?;
        serve::<s::Seek, _>(node, v, "~/seek", control, |c, r| {
            // A time before 1970 is before the recording: its start.
            let sec = u64::try_from(r.time.sec).unwrap_or(0);
            s::Seek_Response {
                success: c.seek(sec * 1_000_000_000 + u64::from(r.time.nanosec)),
            }
        })?;
        serve::<s::Stop, _>(node, v, "~/stop", control, |c, _| {
            c.stop();
            s::Stop_Response
        })?;
        Ok(Self { _servers: servers })
    }
}

/// A played topic's publisher: of a type the player's node describes, or of
/// bytes alone.
enum PlayedPublisher {
    Described(RosPublisher<DynamicType>),
    Bytes(RosPublisher<Serialized>),
}

impl PlayedPublisher {
    fn publish_serialized(&self, cdr: &[u8]) -> Result<PublishOutcome, PublishError> {
        match self {
            Self::Described(publisher) => publisher.publish_serialized(cdr),
            Self::Bytes(publisher) => publisher.publish_serialized(cdr),
        }
    }

    fn wait_for_subscribers(&self, timeout: Duration) -> bool {
        match self {
            Self::Described(publisher) => publisher.wait_for_subscribers(timeout),
            Self::Bytes(publisher) => publisher.wait_for_subscribers(timeout),
        }
    }
}

/// The type of a recorded topic, from the definition the recording keeps,
/// else the standard type of that name.
fn recorded_type(
    topic: &RecordedTopic,
    definitions: &BTreeMap<String, String>,
    distro: Distro,
) -> Option<types::ResolvedType> {
    let from_definition = definitions
        .get(&topic.type_name)
        .filter(|text| !text.is_empty())
        .and_then(|text| LocalInterfaces::from_definition(&topic.type_name, text).ok())
        .and_then(|local| local.resolve(&topic.type_name))
        .and_then(Result::ok);
    match from_definition {
        Some(resolved)
            if topic.type_hash.is_empty() || resolved.ty.type_hash() == topic.type_hash =>
        {
            Some(resolved)
        }
        _ => types::standard_message(&topic.type_name, distro),
    }
}

/// Publish `time` (ns since the Unix epoch) on `/clock`.
fn publish_clock(clock: &RosPublisher<Clock>, time: u64) {
    const NANOS: u64 = 1_000_000_000;
    let msg = Clock {
        clock: Time {
            sec: i32::try_from(time / NANOS).unwrap_or(i32::MAX),
            nanosec: (time % NANOS) as u32,
        },
    };
    if let Err(e) = clock.publish(&msg).wait() {
        tracing::warn!("publishing /clock failed: {e}");
    }
}

/// The times of the recording's first and last messages.
fn bag_bounds(bag: &Bag) -> Result<(u64, u64), Error> {
    let mut bounds = None::<(u64, u64)>;
    for file in bag.open_files() {
        let stats = file?.stats()?;
        if stats.count > 0 {
            let (first, last) = (stats.start, stats.end);
            bounds = Some(bounds.map_or((first, last), |(f, l)| (f.min(first), l.max(last))));
        }
    }
    Ok(bounds.unwrap_or((0, 0)))
}

/// The QoS to publish a recorded topic with: the recorded publishers'
/// (transient local only when all were, best effort when one was).
fn playback_qos(offered: &[Qos]) -> Qos {
    match offered {
        [] => Qos::default(),
        [one] => *one,
        many => {
            let mut qos = many[0];
            if many
                .iter()
                .any(|q| q.durability != shm_runtime::rmw::Durability::TransientLocal)
            {
                qos.durability = shm_runtime::rmw::Durability::Volatile;
            }
            if many
                .iter()
                .any(|q| q.reliability == shm_runtime::rmw::Reliability::BestEffort)
            {
                qos.reliability = shm_runtime::rmw::Reliability::BestEffort;
            }
            qos
        }
    }
}

/// A bound on the largest message's size, from each file.
fn largest_message(bag: &Bag) -> Result<usize, Error> {
    let mut largest = 0u64;
    for file in bag.open_files() {
        largest = largest.max(file?.largest_message()?);
    }
    Ok(usize::try_from(largest).unwrap_or(usize::MAX))
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
