//! Recording live topics: discovered on the graph and subscribed at once by
//! their announced type name and hash, received in place (a shared-memory
//! sample is written from where it lies) and written by one thread, with
//! memory bounded and every message that could not be kept counted, per
//! topic.
//!
//! A type's definition (the schema a recording keeps) comes from what is
//! known without asking anyone first: the standard set, the interface files
//! given. Any other is asked of a node that announces it
//! (`~/get_type_description`), each node on its own thread and within the
//! recorder's timeout, so that no node's silence holds up another's topics.
//! Messages that arrive meanwhile are held (copied, within the budget) and
//! written once the definition is known; a type never learned is recorded by
//! name and hash without a definition, as rosbag2 records a type it has none
//! of. Each topic and type is a channel of its own, so a second type on a
//! topic is recorded beside the first.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use regex::Regex;
use shm_runtime::graph::{Entity, GraphCache};
use shm_runtime::rmw::{Distro, Durability, History, Qos, Reliability, TYPE_HASH_NOT_SUPPORTED};
use shm_runtime::{CallbackSubscriber, RosNode, RosSample, Serialized};
use zenoh::Wait;

use crate::interfaces::rosbag2_interfaces::msg::WriteSplitEvent;
use crate::metadata::{BagMetadata, TopicMetadata};
use crate::qos::QosProfile;
use crate::split_events::SplitEvents;
use crate::writer::{BagWriter, FileSplit, TopicId, WriteOptions};
use crate::Error;
use shm_runtime::types;
use shm_runtime::types::local::LocalInterfaces;

/// Which topics to record.
#[derive(Debug, Clone, Default)]
pub struct Selection {
    /// Every topic (`-a`).
    pub all: bool,
    /// These topics, by name (`/chatter`; a name without `/` is taken from
    /// the root namespace).
    pub topics: Vec<String>,
    /// Topics whose name this matches (`-e`).
    pub regex: Option<Regex>,
    /// Not the topics whose name this matches (`-x`), whatever else says.
    pub exclude: Option<Regex>,
    /// Also hidden topics (a name part starting with `_`, such as an
    /// action's or a service's events), which `all` and `regex` leave out
    /// otherwise.
    pub include_hidden: bool,
    /// Every service's events (`--all-services`): the
    /// `<service>/_service_event` topics that services and clients with
    /// introspection on publish (since Iron), as rosbag2 records them.
    pub all_services: bool,
    /// These services' events (`--services`), by service name.
    pub services: Vec<String>,
}

/// The topic a service's events are published on (service introspection).
pub const SERVICE_EVENT_SUFFIX: &str = "/_service_event";

/// The service whose events `topic` carries, if it is a service event
/// topic (`/add_two_ints/_service_event` → `/add_two_ints`).
pub fn service_of_event_topic(topic: &str) -> Option<&str> {
    topic
        .strip_suffix(SERVICE_EVENT_SUFFIX)
        .filter(|service| !service.is_empty())
}

impl Selection {
    /// Whether `topic` is to be recorded.
    pub fn matches(&self, topic: &str) -> bool {
        if self.exclude.as_ref().is_some_and(|x| x.is_match(topic)) {
            return false;
        }
        if self.topics.iter().any(|t| qualified(t) == topic) {
            return true;
        }
        if let Some(service) = service_of_event_topic(topic) {
            if self.all_services || self.services.iter().any(|s| qualified(s) == service) {
                return true;
            }
        }
        let hidden = topic.split('/').any(|part| part.starts_with('_'));
        if hidden && !self.include_hidden {
            return false;
        }
        self.all || self.regex.as_ref().is_some_and(|r| r.is_match(topic))
    }

    fn is_empty(&self) -> bool {
        !self.all
            && self.topics.is_empty()
            && self.regex.is_none()
            && !self.all_services
            && self.services.is_empty()
    }
}

fn qualified(topic: &str) -> String {
    if topic.starts_with('/') {
        topic.to_owned()
    } else {
        format!("/{topic}")
    }
}

/// How to record.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// The bag directory to create.
    pub output: PathBuf,
    /// Which topics.
    pub selection: Selection,
    /// How the files are written.
    pub write: WriteOptions,
    /// The most bytes of received messages waiting for the writer (default
    /// 512 MiB). A message that would go past it is dropped and counted in
    /// [`RecordStats::dropped`]: memory stays bounded when the disk is
    /// slower than the topics, and nothing is lost silently.
    pub max_queued_bytes: usize,
    /// How often the graph is looked at for new topics (default 100 ms).
    pub discovery_period: Duration,
    /// How long a node may take to describe a type (default 5 s).
    pub type_timeout: Duration,
    /// The ROS domain (default `ROS_DOMAIN_ID`, else 0).
    pub domain_id: Option<u32>,
    /// The distribution whose conventions the node speaks (default
    /// `ROS_DISTRO`, else [`Distro::DEFAULT`]).
    pub distro: Option<Distro>,
    /// The recorder's node name (default `rosbag2_recorder`).
    pub node_name: String,
    /// Interface files whose types (and definition text) are used for a
    /// topic whose announced hash they match, before asking its node.
    pub interfaces: LocalInterfaces,
    /// Start paused: topics are discovered and subscribed, but nothing is
    /// written until [`RecorderControl::resume`] (default: record at once).
    pub start_paused: bool,
    /// Snapshot mode, as rosbag2's: keep the newest messages in memory, up
    /// to [`max_queued_bytes`](Self::max_queued_bytes), and write them only
    /// on [`RecorderControl::snapshot`] (or the `~/snapshot` service). At
    /// most as much again may wait for the writer meanwhile.
    pub snapshot: bool,
}

impl RecordOptions {
    /// Record `selection` into the new bag directory `output`, with the
    /// defaults.
    pub fn new(output: impl Into<PathBuf>, selection: Selection) -> Self {
        Self {
            output: output.into(),
            selection,
            write: WriteOptions::default(),
            max_queued_bytes: 512 * 1024 * 1024,
            discovery_period: Duration::from_millis(100),
            type_timeout: Duration::from_secs(5),
            domain_id: None,
            distro: None,
            node_name: "rosbag2_recorder".to_owned(),
            interfaces: LocalInterfaces::default(),
            start_paused: false,
            snapshot: false,
        }
    }
}

/// What a recording has done so far.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct RecordStats {
    /// Topics being recorded.
    pub topics: usize,
    /// Messages received.
    pub received: u64,
    /// Messages written.
    pub written: u64,
    /// Bytes of messages written.
    pub bytes: u64,
    /// Messages received but not written because the writer was
    /// [`max_queued_bytes`](RecordOptions::max_queued_bytes) behind, or a
    /// write had failed.
    pub dropped: u64,
    /// Messages that never arrived: gaps in a publisher's sequence numbers.
    pub missed: u64,
    /// Bytes received and not yet written.
    pub queued_bytes: usize,
    /// Topics selected but not recorded, with why (announced with another
    /// distribution's conventions, say).
    pub skipped: BTreeMap<String, String>,
    /// In snapshot mode, the messages held for the next snapshot.
    pub buffered: u64,
    /// The write failure that stopped the recording's writing (a full disk,
    /// say), in the OS's words with the file's path; nothing is written after
    /// it and what was written before stays readable.
    pub failure: Option<String>,
    /// Each topic and type recorded (an MCAP channel each), in the order
    /// they were found, with its own counts: every message received is
    /// written, held, dropped or (with a write failure) lost in one of them.
    pub channels: Vec<ChannelStats>,
}

/// What a recording knows of a recorded type's definition (the schema kept
/// in the file).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TypeDefinition {
    /// Being learned from a node: the channel's messages are held in memory
    /// (within the budget) until it is.
    Learning,
    /// Known, and from where: the standard set, the interface files, or the
    /// node that described it.
    Known(String),
    /// Never learned, and why: the channel is recorded by type name and hash
    /// with an empty definition, as rosbag2 records a type it has no
    /// definition of. Its messages are all there; a reader needs the type
    /// from elsewhere to decode them.
    Missing(String),
}

/// One topic recorded with one type: an MCAP channel, with its counts.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct ChannelStats {
    /// The topic.
    pub topic: String,
    /// Its type, `pkg/msg/Name`.
    pub type_name: String,
    /// The type's RIHS01 hash as announced.
    pub type_hash: String,
    /// Where its definition comes from.
    pub definition: TypeDefinition,
    /// Messages received.
    pub received: u64,
    /// Messages written.
    pub written: u64,
    /// Messages received and not written: over the budget, or after a write
    /// failure.
    pub dropped: u64,
    /// Gaps in its publishers' sequence numbers.
    pub missed: u64,
    /// Messages held in memory until the definition is known.
    pub held: u64,
}

/// One channel's counters, shared by its subscriber's callback, the writer
/// and the lookups.
struct Channel {
    topic: String,
    type_name: String,
    type_hash: String,
    definition: Mutex<TypeDefinition>,
    received: AtomicU64,
    written: AtomicU64,
    dropped: AtomicU64,
    missed: AtomicU64,
    held: AtomicU64,
}

impl Channel {
    fn new(topic: &str, type_name: &str, type_hash: &str) -> Self {
        Self {
            topic: topic.to_owned(),
            type_name: type_name.to_owned(),
            type_hash: type_hash.to_owned(),
            definition: Mutex::new(TypeDefinition::Learning),
            received: AtomicU64::new(0),
            written: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
            missed: AtomicU64::new(0),
            held: AtomicU64::new(0),
        }
    }

    fn stats(&self) -> ChannelStats {
        ChannelStats {
            topic: self.topic.clone(),
            type_name: self.type_name.clone(),
            type_hash: self.type_hash.clone(),
            definition: self
                .definition
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .clone(),
            received: self.received.load(Ordering::Relaxed),
            written: self.written.load(Ordering::Relaxed),
            dropped: self.dropped.load(Ordering::Relaxed),
            missed: self.missed.load(Ordering::Relaxed),
            held: self.held.load(Ordering::Relaxed),
        }
    }

    fn set_definition(&self, definition: TypeDefinition) {
        *self.definition.lock().unwrap_or_else(|e| e.into_inner()) = definition;
    }
}

#[derive(Default)]
struct Shared {
    stop: AtomicBool,
    paused: AtomicBool,
    buffered: AtomicU64,
    topics: AtomicUsize,
    received: AtomicU64,
    written: AtomicU64,
    bytes: AtomicU64,
    dropped: AtomicU64,
    missed: AtomicU64,
    queued_bytes: AtomicUsize,
    skipped: Mutex<BTreeMap<String, String>>,
    failure: Mutex<Option<String>>,
    channels: Mutex<Vec<Arc<Channel>>>,
    /// Held while a sample is stamped and queued: samples of different
    /// publishers arrive on different threads, and the writer writes them
    /// in queue order, so the queue must be in log-time order too.
    arrival: Mutex<()>,
}

impl Shared {
    fn stats(&self) -> RecordStats {
        let s = self;
        RecordStats {
            topics: s.topics.load(Ordering::Relaxed),
            received: s.received.load(Ordering::Relaxed),
            written: s.written.load(Ordering::Relaxed),
            bytes: s.bytes.load(Ordering::Relaxed),
            dropped: s.dropped.load(Ordering::Relaxed),
            missed: s.missed.load(Ordering::Relaxed),
            queued_bytes: s.queued_bytes.load(Ordering::Relaxed),
            skipped: s.skipped.lock().unwrap_or_else(|e| e.into_inner()).clone(),
            buffered: s.buffered.load(Ordering::Relaxed),
            failure: s.failure.lock().unwrap_or_else(|e| e.into_inner()).clone(),
            channels: s
                .channels
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .iter()
                .map(|c| c.stats())
                .collect(),
        }
    }

    fn skip(&self, topic: &str, why: String) {
        self.skipped
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(topic.to_owned(), why);
    }
}

enum Event {
    /// A channel is subscribed: its metadata, before any of its messages.
    Channel {
        index: usize,
        channel: Arc<Channel>,
        metadata: TopicMetadata,
    },
    /// The channel's definition: known (`ros2msg` text) or, empty, never
    /// learned. Its held messages are written after it.
    Definition {
        index: usize,
        definition: String,
    },
    /// The channel's subscription failed: it has no messages, and is not
    /// written.
    Forget {
        index: usize,
    },
    Sample {
        index: usize,
        sample: RosSample,
        log_time: u64,
    },
    /// A message received but not written (while paused, or dropped over
    /// the budget): its sequence number is no gap.
    Unrecorded {
        gid: [u8; 16],
        sequence: i64,
    },
    /// Move on to a new file now; the answer goes back on `reply`.
    Split {
        reply: flume::Sender<Result<FileSplit, Error>>,
    },
    /// Write the snapshot buffer; how many messages, back on `reply`.
    Snapshot {
        reply: flume::Sender<Result<u64, Error>>,
    },
    Stop,
}

/// A handle to pause, resume, split or snapshot a [`Recorder`]'s recording
/// from any thread, as `ros2 bag record`'s keyboard and services do.
///
/// ```no_run
/// use shm_bag::{RecordOptions, Recorder, Selection};
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let selection = Selection { all: true, ..Selection::default() };
/// let options = RecordOptions { start_paused: true, ..RecordOptions::new("my_bag", selection) };
/// let recorder = Recorder::start(&session, options)?;
/// let control = recorder.control();
/// control.resume(); // from here on, messages are written
/// let split = control.split()?; // a new file from here on
/// println!("closed {}", split.closed.display());
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
#[derive(Clone)]
pub struct RecorderControl {
    shared: Arc<Shared>,
    events: flume::Sender<Event>,
}

impl std::fmt::Debug for RecorderControl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecorderControl")
            .field("paused", &self.is_paused())
            .finish_non_exhaustive()
    }
}

impl RecorderControl {
    /// Pause: messages received from now on are not written (nor counted as
    /// received, dropped or missed).
    pub fn pause(&self) {
        self.shared.paused.store(true, Ordering::Relaxed);
    }

    /// Resume writing.
    pub fn resume(&self) {
        self.shared.paused.store(false, Ordering::Relaxed);
    }

    /// Pause a running recording, resume a paused one.
    pub fn toggle_paused(&self) {
        self.shared.paused.fetch_xor(true, Ordering::Relaxed);
    }

    /// Whether the recording is paused.
    pub fn is_paused(&self) -> bool {
        self.shared.paused.load(Ordering::Relaxed)
    }

    /// What the recording has done so far (and, once stopped, in all).
    pub fn stats(&self) -> RecordStats {
        self.shared.stats()
    }

    /// In snapshot mode, write the messages held in memory (the newest,
    /// oldest first) into the current file, and start holding anew; how
    /// many were written. An error when not in snapshot mode.
    pub fn snapshot(&self) -> Result<u64, Error> {
        let (reply, answer) = flume::bounded(1);
        self.events
            .send(Event::Snapshot { reply })
            .map_err(|_| "the recording is finished")?;
        answer
            .recv()
            .map_err(|_| "the recording finished before the snapshot")?
    }

    /// Close the current file once the messages received before are
    /// written, and continue in a new one; which files, once done.
    pub fn split(&self) -> Result<FileSplit, Error> {
        let (reply, answer) = flume::bounded(1);
        self.events
            .send(Event::Split { reply })
            .map_err(|_| "the recording is finished")?;
        answer
            .recv()
            .map_err(|_| "the recording finished before the split")?
    }
}

/// A recording in progress: topics are discovered and written until
/// [`stop`](Self::stop).
///
/// ```no_run
/// use shm_bag::{RecordOptions, Recorder, Selection};
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let selection = Selection { all: true, ..Selection::default() };
/// let recorder = Recorder::start(&session, RecordOptions::new("my_bag", selection))?;
/// std::thread::sleep(std::time::Duration::from_secs(10));
/// let metadata = recorder.stop()?;
/// println!("{} messages", metadata.message_count);
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
pub struct Recorder {
    shared: Arc<Shared>,
    events: flume::Sender<Event>,
    discovery: Option<JoinHandle<()>>,
    writer: Option<JoinHandle<Result<BagMetadata, Error>>>,
    _services: Vec<Box<dyn std::any::Any + Send + Sync>>,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("stats", &self.stats())
            .finish_non_exhaustive()
    }
}

impl Recorder {
    /// Create the bag directory and start recording what `options` selects,
    /// through a node of its own in `session`.
    pub fn start(session: &zenoh::Session, options: RecordOptions) -> Result<Self, Error> {
        if options.selection.is_empty() {
            return Err(
                "nothing to record: name topics, or give -a (all topics), --all-services, \
                 --all (both), --services or -e (a regular expression)"
                    .into(),
            );
        }
        let mut builder = RosNode::builder(session, &options.node_name);
        if let Some(domain_id) = options.domain_id {
            builder = builder.domain_id(domain_id);
        }
        if let Some(distro) = options.distro {
            builder = builder.distro(distro);
        }
        let node = Arc::new(builder.wait()?);
        let mut writer = BagWriter::create(&options.output, options.write.clone())?;
        writer.set_ros_distro(node.info().distro.name());
        let shared = Arc::new(Shared::default());
        shared.paused.store(options.start_paused, Ordering::Relaxed);
        let (events, receiver) = flume::unbounded();
        let control = RecorderControl {
            shared: shared.clone(),
            events: events.clone(),
        };
        let services = declare_services(&node, &control, options.snapshot)?;
        let split_events = SplitEvents::<WriteSplitEvent>::declare(&node)?;
        let budgets = Budgets {
            snapshot: options.snapshot.then_some(options.max_queued_bytes),
            // Messages held while their type is learned take at most half
            // of what may wait, so known topics keep the rest.
            held: options.max_queued_bytes / 2,
        };
        let writer = {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("shm-bag writer".into())
                .spawn(move || write_loop(writer, &receiver, &shared, &split_events, budgets))?
        };
        let discovery = {
            let shared = shared.clone();
            let events = events.clone();
            std::thread::Builder::new()
                .name("shm-bag discovery".into())
                .spawn(move || discover(&node, &options, &shared, &events))?
        };
        Ok(Self {
            shared,
            events,
            discovery: Some(discovery),
            writer: Some(writer),
            _services: services,
        })
    }

    /// A handle to pause, resume, split or snapshot the recording from
    /// another thread.
    pub fn control(&self) -> RecorderControl {
        RecorderControl {
            shared: self.shared.clone(),
            events: self.events.clone(),
        }
    }

    /// What the recording has done so far.
    pub fn stats(&self) -> RecordStats {
        self.shared.stats()
    }

    /// Stop subscribing, write what was received, close the files and write
    /// `metadata.yaml`; returns what it says.
    pub fn stop(mut self) -> Result<BagMetadata, Error> {
        self.finish()
    }

    fn finish(&mut self) -> Result<BagMetadata, Error> {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(discovery) = self.discovery.take() {
            let _ = discovery.join();
        }
        let _ = self.events.send(Event::Stop);
        match self.writer.take() {
            Some(writer) => writer
                .join()
                .unwrap_or_else(|_| Err("the writer thread panicked".into())),
            None => Err("the recording was stopped already".into()),
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if self.writer.is_some() {
            let _ = self.finish();
        }
    }
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// The discovery thread: subscribe to each selected topic and type once it
/// has a publisher, until told to stop; the subscriptions end with it.
fn discover(
    node: &Arc<RosNode>,
    options: &RecordOptions,
    shared: &Arc<Shared>,
    events: &flume::Sender<Event>,
) {
    let cache = match node.graph_cache() {
        Ok(cache) => cache,
        Err(e) => {
            shared.skip("*", format!("no graph: {e}"));
            return;
        }
    };
    cache.wait_synced(Duration::from_secs(1));
    let lookups = Lookups {
        node: node.clone(),
        cache: cache.clone(),
        timeout: options.type_timeout,
        shared: shared.clone(),
        events: events.clone(),
        nodes: Arc::new(Mutex::new(HashMap::new())),
        given: Arc::new(Mutex::new(HashMap::new())),
    };
    let mut subscribers: Vec<CallbackSubscriber<Serialized>> = Vec::new();
    // (topic, type name, type hash) → channel index.
    let mut recorded: HashMap<(String, String, String), usize> = HashMap::new();
    let mut next_index = 0;
    let mut retry: HashMap<(String, String, String), Instant> = HashMap::new();
    let distro = node.info().distro;
    while !shared.stop.load(Ordering::Relaxed) {
        let graph = cache.snapshot();
        for topic in graph.topics().into_keys() {
            if !options.selection.matches(&topic) {
                continue;
            }
            // The recorder's own (its split events) are not recorded.
            let own =
                |p: &Arc<Entity>| p.zid == node.info().zid && p.node_id == node.info().node_id;
            let publishers: Vec<Arc<Entity>> = graph
                .publishers(&topic)
                .into_iter()
                .filter(|p| !own(p))
                .collect();
            let mut types: BTreeMap<(String, String), Vec<Arc<Entity>>> = BTreeMap::new();
            for publisher in publishers {
                if let Some(endpoint) = publisher.endpoint.as_ref() {
                    let key = (endpoint.type_name.clone(), endpoint.type_hash.clone());
                    types.entry(key).or_default().push(publisher);
                }
            }
            for ((type_name, type_hash), publishers) in types {
                let key = (topic.clone(), type_name, type_hash);
                if recorded.contains_key(&key)
                    || retry.get(&key).is_some_and(|at| Instant::now() < *at)
                {
                    continue;
                }
                let (_, type_name, type_hash) = &key;
                if (type_hash == TYPE_HASH_NOT_SUPPORTED) == distro.has_type_hashes() {
                    shared.skip(
                        &topic,
                        format!(
                            "announced as {type_name} with type hash {type_hash}, and the recorder \
                             speaks {distro}'s conventions: set ROS_DISTRO (or --distro) to the \
                             distribution of the nodes on it{}",
                            if distro.has_type_hashes() {
                                " (humble: its nodes have no type hashes)"
                            } else {
                                ""
                            }
                        ),
                    );
                    retry.insert(key, Instant::now() + Duration::from_secs(10));
                    continue;
                }
                let index = next_index;
                next_index += 1;
                // What is known locally is known before the first message.
                let local = known_locally(distro, options, type_name, type_hash);
                let channel = Channel::new(&topic, type_name, type_hash);
                if let Ok((_, how)) = &local {
                    channel.set_definition(how.clone());
                }
                let channel = Arc::new(channel);
                match subscribe(
                    node,
                    options,
                    &publishers,
                    index,
                    &channel,
                    local
                        .as_ref()
                        .ok()
                        .map(|(definition, _)| definition.clone()),
                    shared,
                    events,
                ) {
                    Ok(subscriber) => {
                        subscribers.push(subscriber);
                        recorded.insert(key.clone(), index);
                        let topics: std::collections::BTreeSet<&str> =
                            recorded.keys().map(|(t, _, _)| t.as_str()).collect();
                        shared.topics.store(topics.len(), Ordering::Relaxed);
                        shared
                            .skipped
                            .lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .remove(&topic);
                        if let Err(why_not_local) = local {
                            learn(&lookups, index, &channel, &publishers, why_not_local);
                        }
                    }
                    Err(e) => {
                        tracing::warn!(topic, "not recorded for now: {e}");
                        shared.skip(&topic, e.to_string());
                        retry.insert(key, Instant::now() + Duration::from_secs(10));
                    }
                }
            }
        }
        std::thread::sleep(options.discovery_period);
    }
    drop(subscribers);
}

/// The definition of a type from what is known without asking any node (the
/// standard set, the interface files), and where it comes from; else why
/// not, if something was wrong with what is known.
fn known_locally(
    distro: Distro,
    options: &RecordOptions,
    type_name: &str,
    type_hash: &str,
) -> Result<(String, TypeDefinition), Option<String>> {
    match types::resolve_locally(distro, type_name, type_hash, &options.interfaces) {
        Some(Ok(resolved)) => {
            let from = if types::standard().contains_key(type_name) {
                "the standard set"
            } else {
                "the interface files"
            };
            Ok((resolved.definition, TypeDefinition::Known(from.to_owned())))
        }
        Some(Err(e)) => Err(Some(e.to_string())),
        None => Err(None),
    }
}

/// Learn the definition of `channel`'s type, not known locally, from a node
/// announcing it, on that node's lookup thread.
fn learn(
    lookups: &Lookups,
    index: usize,
    channel: &Arc<Channel>,
    publishers: &[Arc<Entity>],
    why_not_local: Option<String>,
) {
    let distro = lookups.node.info().distro;
    if !distro.has_type_hashes() {
        let why = why_not_local.unwrap_or_else(|| {
            format!(
                "not a standard type, and {distro}'s nodes describe no types: give its \
                 interface files (--interfaces)"
            )
        });
        lookups.define(index, channel, String::new(), TypeDefinition::Missing(why));
        return;
    }
    let mut nodes: Vec<String> = publishers.iter().map(|p| p.node_fqn()).collect();
    nodes.sort();
    nodes.dedup();
    lookups.ask(Lookup {
        index,
        channel: channel.clone(),
        nodes,
        why: None,
    });
}

/// A type to ask of the nodes that announce it.
struct Lookup {
    index: usize,
    channel: Arc<Channel>,
    /// The nodes publishing it, by full name: asked in turn.
    nodes: Vec<String>,
    /// Why the last node asked gave no definition.
    why: Option<String>,
}

/// The type lookups of a recording: one thread per node asked, so that a
/// silent node holds up only its own types, each question bounded by the
/// recorder's timeout. A node that let one question time out is not asked
/// again: its other types are recorded without definitions at once.
#[derive(Clone)]
struct Lookups {
    node: Arc<RosNode>,
    cache: GraphCache,
    timeout: Duration,
    shared: Arc<Shared>,
    events: flume::Sender<Event>,
    /// Each node's queue of lookups (its thread's), and why a node is not
    /// asked any more.
    nodes: Arc<Mutex<HashMap<String, NodeLookups>>>,
    /// The bytes of definitions each node has given.
    given: Arc<Mutex<HashMap<String, usize>>>,
}

/// The most bytes of one type's definition taken from a node: a definition
/// of hundreds of types with their comments is well within it.
pub const MAX_DEFINITION: usize = 1 << 20;

/// The most bytes of definitions taken from one node in a recording: a node
/// cannot fill a recording (or the recorder's memory) with text.
pub const MAX_NODE_DEFINITIONS: usize = 8 << 20;

enum NodeLookups {
    Asking(flume::Sender<Lookup>),
    Silent(String),
}

impl Lookups {
    /// Record the channel's definition, known or (empty) missing.
    fn define(&self, index: usize, channel: &Channel, definition: String, how: TypeDefinition) {
        if let TypeDefinition::Missing(why) = &how {
            tracing::warn!(
                topic = channel.topic,
                "{} is recorded without its definition: {why}",
                channel.type_name
            );
        }
        channel.set_definition(how);
        let _ = self.events.send(Event::Definition { index, definition });
    }

    /// Ask the first of the lookup's nodes, on its thread.
    fn ask(&self, mut lookup: Lookup) {
        if lookup.nodes.is_empty() {
            let why = lookup
                .why
                .take()
                .unwrap_or_else(|| "no node announcing it describes it".to_owned());
            self.define(
                lookup.index,
                &lookup.channel,
                String::new(),
                TypeDefinition::Missing(why),
            );
            return;
        }
        let fqn = lookup.nodes[0].clone();
        let mut nodes = self.nodes.lock().unwrap_or_else(|e| e.into_inner());
        match nodes.get(&fqn) {
            Some(NodeLookups::Silent(why)) => {
                lookup.why = Some(why.clone());
                drop(nodes);
                lookup.nodes.remove(0);
                self.ask(lookup);
                return;
            }
            Some(NodeLookups::Asking(queue)) => match queue.send(lookup) {
                Ok(()) => return,
                // Its thread has just finished: start another.
                Err(flume::SendError(back)) => lookup = back,
            },
            None => {}
        }
        let (queue, work) = flume::unbounded();
        let _ = queue.send(lookup);
        nodes.insert(fqn.clone(), NodeLookups::Asking(queue));
        drop(nodes);
        let lookups = self.clone();
        let spawned = std::thread::Builder::new()
            .name("shm-bag type lookup".into())
            .stack_size(256 * 1024)
            .spawn(move || lookups.serve(&fqn, &work));
        if let Err(e) = spawned {
            tracing::warn!("no thread to ask a node for a type: {e}");
        }
    }

    /// A node's lookup thread: its questions one after another, until none
    /// is left.
    fn serve(&self, fqn: &str, work: &flume::Receiver<Lookup>) {
        loop {
            let lookup = {
                let mut nodes = self.nodes.lock().unwrap_or_else(|e| e.into_inner());
                match work.try_recv() {
                    Ok(lookup) => lookup,
                    Err(_) => {
                        // Nothing more: this thread ends, and the next
                        // lookup for the node starts another.
                        if matches!(nodes.get(fqn), Some(NodeLookups::Asking(_))) {
                            nodes.remove(fqn);
                        }
                        return;
                    }
                }
            };
            if self.shared.stop.load(Ordering::Relaxed) {
                continue;
            }
            match self.describe(fqn, &lookup.channel) {
                Ok(definition) => self.define(
                    lookup.index,
                    &lookup.channel,
                    definition,
                    TypeDefinition::Known(fqn.to_owned()),
                ),
                Err((why, silent)) => {
                    if silent {
                        // Its other questions are not asked: they would wait as long.
                        let mut nodes = self.nodes.lock().unwrap_or_else(|e| e.into_inner());
                        nodes.insert(fqn.to_owned(), NodeLookups::Silent(why.clone()));
                        drop(nodes);
                        for mut other in work.drain() {
                            other.nodes.retain(|n| n != fqn);
                            other.why = Some(why.clone());
                            self.ask(other);
                        }
                    }
                    let mut rest = lookup;
                    rest.nodes.retain(|n| n != fqn);
                    rest.why = Some(why);
                    self.ask(rest);
                    if silent {
                        return;
                    }
                }
            }
        }
    }

    /// The definition `fqn` gives of the channel's type, or why not and
    /// whether the node is to be taken as silent.
    fn describe(&self, fqn: &str, channel: &Channel) -> Result<String, (String, bool)> {
        let service = format!("{}/get_type_description", fqn.trim_end_matches('/'));
        // A node's service is announced with it, but its token may come a
        // moment after the publisher's.
        let offered = self
            .cache
            .wait_until(self.timeout.min(Duration::from_secs(1)), |g| {
                !g.servers(&service).is_empty()
            });
        if !offered {
            return Err((
                format!(
                    "{fqn} offers no {service} (Humble's nodes have none, and a node can be \
                     started without it): give the type's interface files (--interfaces)"
                ),
                true,
            ));
        }
        let asked = Instant::now();
        let definition = types::ask_node(
            &self.node,
            self.timeout,
            fqn,
            &channel.type_name,
            &channel.type_hash,
        )
        .map(|resolved| resolved.definition)
        .map_err(|e| {
            // A question that took the whole timeout went unanswered: the
            // node's other questions would wait as long.
            (e.to_string(), asked.elapsed() >= self.timeout)
        })?;
        if definition.len() > MAX_DEFINITION {
            return Err((
                format!(
                    "{fqn}'s definition of {} is {} bytes, more than the {MAX_DEFINITION} kept \
                     for one type: give the type's interface files",
                    channel.type_name,
                    definition.len()
                ),
                false,
            ));
        }
        let mut given = self.given.lock().unwrap_or_else(|e| e.into_inner());
        let total = given.entry(fqn.to_owned()).or_insert(0);
        if total.saturating_add(definition.len()) > MAX_NODE_DEFINITIONS {
            return Err((
                format!(
                    "{fqn}'s definitions pass the {MAX_NODE_DEFINITIONS} bytes kept from one \
                     node: give the types' interface files"
                ),
                false,
            ));
        }
        *total += definition.len();
        Ok(definition)
    }
}

/// The QoS to record a topic with, from its publishers' (as rosbag2
/// adapts): reliable unless one publisher is best effort, so that all are
/// heard; transient local when every publisher is, so that their kept
/// messages are recorded too.
fn recording_qos(offered: &[Qos]) -> Qos {
    // A BEST_AVAILABLE publisher puts best effort, as rmw_zenoh_cpp's does.
    let reliability = if offered.iter().any(|q| {
        matches!(
            q.reliability,
            Reliability::BestEffort | Reliability::BestAvailable
        )
    }) {
        Reliability::BestEffort
    } else {
        Reliability::Reliable
    };
    let transient = !offered.is_empty()
        && offered
            .iter()
            .all(|q| q.durability == Durability::TransientLocal);
    if transient {
        let depth = offered
            .iter()
            .map(|q| match q.history {
                History::KeepLast(depth) => depth,
                History::KeepAll => usize::MAX,
            })
            .max()
            .unwrap_or(1);
        Qos::with_history(
            reliability,
            Durability::TransientLocal,
            History::KeepLast(depth),
        )
    } else {
        Qos::with_history(reliability, Durability::Volatile, History::KeepLast(10))
    }
}

/// Subscribe to the channel's topic and type as its `publishers` announce
/// them, as bytes: nothing about the type beyond its name and hash is needed
/// to receive. The writer is told of the channel (and of its `definition`,
/// when known) before any of its messages.
#[allow(clippy::too_many_arguments)]
fn subscribe(
    node: &RosNode,
    options: &RecordOptions,
    publishers: &[Arc<Entity>],
    index: usize,
    channel: &Arc<Channel>,
    definition: Option<String>,
    shared: &Arc<Shared>,
    events: &flume::Sender<Event>,
) -> Result<CallbackSubscriber<Serialized>, Error> {
    let offered: Vec<Qos> = publishers
        .iter()
        .filter_map(|p| p.endpoint.as_ref().map(|e| e.qos))
        .collect();
    let (topic, type_name, type_hash) = (&channel.topic, &channel.type_name, &channel.type_hash);
    let metadata = TopicMetadata {
        name: topic.clone(),
        type_name: type_name.clone(),
        serialization_format: "cdr".to_owned(),
        offered_qos_profiles: offered.iter().map(QosProfile::from).collect(),
        type_description_hash: type_hash.clone(),
    };
    events
        .send(Event::Channel {
            index,
            channel: channel.clone(),
            metadata,
        })
        .map_err(|_| "the writer has stopped")?;
    if let Some(definition) = definition {
        events
            .send(Event::Definition { index, definition })
            .map_err(|_| "the writer has stopped")?;
    }
    let budget = options.max_queued_bytes;
    let shared_cb = shared.clone();
    let channel_cb = channel.clone();
    let events_cb = events.clone();
    let subscribed = node
        .declare_serialized_subscriber(topic, type_name, type_hash, recording_qos(&offered))
        // Zenoh's thread only hands the sample over: the writer's pace never
        // reaches the network, and the budget bounds what waits.
        .callback_inline(move |sample| {
            let (shared, channel) = (&shared_cb, &channel_cb);
            if shared.paused.load(Ordering::Relaxed) {
                if let Some(Ok(attachment)) = sample.attachment() {
                    let _ = events_cb.send(Event::Unrecorded {
                        gid: attachment.gid.0,
                        sequence: attachment.sequence_number,
                    });
                }
                return;
            }
            shared.received.fetch_add(1, Ordering::Relaxed);
            channel.received.fetch_add(1, Ordering::Relaxed);
            let len = sample.payload().len();
            let queued = shared.queued_bytes.fetch_add(len, Ordering::Relaxed);
            if queued.saturating_add(len) > budget {
                shared.queued_bytes.fetch_sub(len, Ordering::Relaxed);
                shared.dropped.fetch_add(1, Ordering::Relaxed);
                channel.dropped.fetch_add(1, Ordering::Relaxed);
                // Counted as dropped, so not as missed too.
                if let Some(Ok(attachment)) = sample.attachment() {
                    let _ = events_cb.send(Event::Unrecorded {
                        gid: attachment.gid.0,
                        sequence: attachment.sequence_number,
                    });
                }
                return;
            }
            let queued = {
                let _arrival = shared.arrival.lock().unwrap_or_else(|e| e.into_inner());
                events_cb.send(Event::Sample {
                    index,
                    sample,
                    log_time: now_ns(),
                })
            };
            if queued.is_err() {
                shared.queued_bytes.fetch_sub(len, Ordering::Relaxed);
                shared.dropped.fetch_add(1, Ordering::Relaxed);
                channel.dropped.fetch_add(1, Ordering::Relaxed);
            }
        })
        .wait();
    match subscribed {
        Ok(subscriber) => {
            shared
                .channels
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(channel.clone());
            Ok(subscriber)
        }
        Err(e) => {
            // The writer forgets the channel: it had no messages.
            let _ = events.send(Event::Forget { index });
            Err(e)
        }
    }
}

/// Each publisher's last sequence number, and the gaps between them.
#[derive(Default)]
struct Sequences(HashMap<[u8; 16], i64>);

impl Sequences {
    /// Note `sequence` from publisher `gid`; how many messages are missing
    /// before it.
    fn gap(&mut self, gid: [u8; 16], sequence: i64) -> u64 {
        match self.0.insert(gid, sequence) {
            Some(previous) if sequence > previous + 1 => {
                u64::try_from(sequence - previous - 1).unwrap_or(0)
            }
            Some(previous) if sequence <= previous => {
                // A kept message replayed: not a gap.
                self.0.insert(gid, previous);
                0
            }
            _ => 0,
        }
    }
}

/// rosbag2's recorder services on the recorder's node.
fn declare_services(
    node: &RosNode,
    control: &RecorderControl,
    snapshot: bool,
) -> Result<Vec<Box<dyn std::any::Any + Send + Sync>>, Error> {
    use crate::interfaces::rosbag2_interfaces::srv as s;
    let mut servers: Vec<Box<dyn std::any::Any + Send + Sync>> = Vec::new();
    if snapshot {
        let c = control.clone();
        servers.push(Box::new(
            node.declare_service::<s::Snapshot>("~/snapshot")
                .handler(move |_| s::Snapshot_Response {
                    success: c
                        .snapshot()
                        .map_err(|e| tracing::warn!("snapshot: {e}"))
                        .is_ok(),
                })
                .wait()?,
        ));
    }
    let c = control.clone();
    servers.push(Box::new(
        node.declare_service::<s::Pause>("~/pause")
            .handler(move |_| {
                c.pause();
                s::Pause_Response
            })
            .wait()?,
    ));
    let c = control.clone();
    servers.push(Box::new(
        node.declare_service::<s::Resume>("~/resume")
            .handler(move |_| {
                c.resume();
                s::Resume_Response
            })
            .wait()?,
    ));
    let c = control.clone();
    servers.push(Box::new(
        node.declare_service::<s::IsPaused>("~/is_paused")
            .handler(move |_| s::IsPaused_Response {
                paused: c.is_paused(),
            })
            .wait()?,
    ));
    let c = control.clone();
    servers.push(Box::new(
        node.declare_service::<s::SplitBagfile>("~/split_bagfile")
            .handler(move |_| {
                if let Err(e) = c.split() {
                    tracing::warn!("split_bagfile: {e}");
                }
                s::SplitBagfile_Response
            })
            .wait()?,
    ));
    Ok(servers)
}

/// How much memory the writer may hold messages in.
struct Budgets {
    /// In snapshot mode, the bytes of the newest messages kept.
    snapshot: Option<usize>,
    /// The bytes of messages held while their types are learned.
    held: usize,
}

/// The writer thread: channels and messages in arrival order, until `Stop`.
fn write_loop(
    writer: BagWriter,
    events: &flume::Receiver<Event>,
    shared: &Shared,
    split_events: &SplitEvents<WriteSplitEvent>,
    budgets: Budgets,
) -> Result<BagMetadata, Error> {
    let mut writing = Writing {
        writer,
        shared,
        split_events,
        channels: HashMap::new(),
        held_bytes: 0,
        held_budget: budgets.held,
        sequences: Sequences::default(),
        failure: None,
        snapshot: budgets.snapshot.map(|budget| SnapshotBuffer {
            messages: VecDeque::new(),
            bytes: 0,
            budget,
        }),
    };
    loop {
        let event = match events.recv_timeout(FLUSH_TICK) {
            Ok(event) => event,
            Err(flume::RecvTimeoutError::Timeout) => {
                writing.flush_if_due();
                continue;
            }
            Err(flume::RecvTimeoutError::Disconnected) => break,
        };
        match event {
            Event::Stop => break,
            event => writing.handle(event),
        }
    }
    // Whatever a callback still handed over after the stop is counted.
    for event in events.try_iter() {
        match event {
            Event::Sample { index, sample, .. } => {
                shared
                    .queued_bytes
                    .fetch_sub(sample.payload().len(), Ordering::Relaxed);
                shared.dropped.fetch_add(1, Ordering::Relaxed);
                if let Some(channel) = writing.channels.get(&index) {
                    channel.counts.dropped.fetch_add(1, Ordering::Relaxed);
                }
            }
            // A definition learned as the recording stopped still names
            // its held messages.
            event @ Event::Definition { .. } => writing.handle(event),
            _ => {}
        }
    }
    // Messages still held for a type being learned are written under the
    // name and hash alone: in the file rather than lost.
    let waiting: Vec<usize> = writing
        .channels
        .iter()
        .filter(|(_, c)| matches!(c.state, State::Held(_)))
        .map(|(index, _)| *index)
        .collect();
    for index in waiting {
        if let Some(channel) = writing.channels.get(&index) {
            channel.counts.set_definition(TypeDefinition::Missing(
                "the recording stopped before a node described it".to_owned(),
            ));
        }
        writing.define(index, String::new());
    }
    let finished = writing.writer.finish();
    match writing.failure {
        Some(e) => Err(e),
        None => finished,
    }
}

/// How often the writer thread, with nothing to write, closes a chunk that
/// has grown old (see [`WriteOptions::chunk_interval`]).
const FLUSH_TICK: Duration = Duration::from_millis(100);

/// The writer thread's state.
struct Writing<'a> {
    writer: BagWriter,
    shared: &'a Shared,
    split_events: &'a SplitEvents<WriteSplitEvent>,
    channels: HashMap<usize, WriterChannel>,
    /// Bytes of messages held for types being learned, and the most.
    held_bytes: usize,
    held_budget: usize,
    sequences: Sequences,
    /// The first write failure: nothing is written after it.
    failure: Option<Error>,
    /// In snapshot mode, the messages held for the next snapshot.
    snapshot: Option<SnapshotBuffer>,
}

/// A channel as the writer has it.
struct WriterChannel {
    counts: Arc<Channel>,
    metadata: TopicMetadata,
    state: State,
}

enum State {
    /// Its definition is being learned: its messages, copied (a
    /// shared-memory sample is not held: its publisher's pool needs it
    /// back), oldest first.
    Held(VecDeque<Held>),
    /// In the file.
    Open(TopicId),
}

/// The newest messages received, up to a byte budget, as copies (a
/// shared-memory sample is not held: its publisher's pool needs it back).
struct SnapshotBuffer {
    messages: VecDeque<Held>,
    bytes: usize,
    budget: usize,
}

/// A message held in memory.
struct Held {
    index: usize,
    log_time: u64,
    publish_time: u64,
    sequence: u32,
    data: Vec<u8>,
}

impl Writing<'_> {
    fn handle(&mut self, event: Event) {
        match event {
            Event::Channel {
                index,
                channel,
                metadata,
            } => {
                self.channels.insert(
                    index,
                    WriterChannel {
                        counts: channel,
                        metadata,
                        state: State::Held(VecDeque::new()),
                    },
                );
            }
            Event::Definition { index, definition } => self.define(index, definition),
            Event::Forget { index } => {
                self.channels.remove(&index);
            }
            Event::Sample {
                index,
                sample,
                log_time,
            } => self.sample(index, &sample, log_time),
            Event::Unrecorded { gid, sequence } => {
                self.sequences.gap(gid, sequence);
            }
            Event::Split { reply } => {
                let split = self.split();
                let _ = reply.send(split);
            }
            Event::Snapshot { reply } => {
                let _ = reply.send(self.snapshot());
            }
            Event::Stop => {}
        }
    }

    /// The channel's definition is known (or, empty, never will be): add it
    /// to the file and write what it held.
    fn define(&mut self, index: usize, definition: String) {
        let Some(channel) = self.channels.get_mut(&index) else {
            return;
        };
        if matches!(channel.state, State::Open(_)) {
            return;
        }
        let metadata = channel.metadata.clone();
        let held = match self.failure.is_none() {
            true => match self.writer.add_topic(metadata, definition) {
                Ok(id) => std::mem::replace(&mut channel.state, State::Open(id)),
                Err(e) => {
                    self.fail(e);
                    return self.drop_held(index);
                }
            },
            false => return self.drop_held(index),
        };
        if let State::Held(messages) = held {
            for message in messages {
                let len = message.data.len();
                self.held_bytes -= len;
                if let Some(channel) = self.channels.get(&index) {
                    channel.counts.held.fetch_sub(1, Ordering::Relaxed);
                }
                self.take(message);
            }
        }
    }

    /// Count a channel's held messages as dropped (the file could not take
    /// the channel).
    fn drop_held(&mut self, index: usize) {
        let Some(channel) = self.channels.get_mut(&index) else {
            return;
        };
        if let State::Held(messages) = &mut channel.state {
            for message in messages.drain(..) {
                self.held_bytes -= message.data.len();
                self.shared
                    .queued_bytes
                    .fetch_sub(message.data.len(), Ordering::Relaxed);
                self.shared.dropped.fetch_add(1, Ordering::Relaxed);
                channel.counts.held.fetch_sub(1, Ordering::Relaxed);
                channel.counts.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    fn sample(&mut self, index: usize, sample: &RosSample, log_time: u64) {
        let payload = sample.payload().to_bytes();
        let len = payload.len();
        let (publish_time, sequence) = match sample.attachment() {
            Some(Ok(attachment)) => {
                let seq = attachment.sequence_number;
                let missed = self.sequences.gap(attachment.gid.0, seq);
                self.shared.missed.fetch_add(missed, Ordering::Relaxed);
                if let Some(channel) = self.channels.get(&index) {
                    channel.counts.missed.fetch_add(missed, Ordering::Relaxed);
                }
                (
                    u64::try_from(attachment.source_timestamp).unwrap_or(log_time),
                    seq as u32,
                )
            }
            _ => (log_time, 0),
        };
        let Some(channel) = self.channels.get_mut(&index) else {
            // A channel the writer was never told of: cannot happen, but
            // counted all the same.
            self.shared.queued_bytes.fetch_sub(len, Ordering::Relaxed);
            self.shared.dropped.fetch_add(1, Ordering::Relaxed);
            return;
        };
        match &mut channel.state {
            State::Held(held) => {
                if self.held_bytes.saturating_add(len) > self.held_budget {
                    self.shared.queued_bytes.fetch_sub(len, Ordering::Relaxed);
                    self.shared.dropped.fetch_add(1, Ordering::Relaxed);
                    channel.counts.dropped.fetch_add(1, Ordering::Relaxed);
                    return;
                }
                self.held_bytes += len;
                channel.counts.held.fetch_add(1, Ordering::Relaxed);
                held.push_back(Held {
                    index,
                    log_time,
                    publish_time,
                    sequence,
                    data: payload.to_vec(),
                });
            }
            State::Open(_) if self.snapshot.is_some() => {
                self.take(Held {
                    index,
                    log_time,
                    publish_time,
                    sequence,
                    data: payload.to_vec(),
                });
            }
            State::Open(_) => {
                let written = self.write(index, log_time, publish_time, sequence, &payload);
                drop(payload);
                self.shared.queued_bytes.fetch_sub(len, Ordering::Relaxed);
                self.count(index, written, len);
            }
        }
    }

    /// A message of an open channel, held in memory: into the snapshot
    /// buffer in snapshot mode, else into the file.
    fn take(&mut self, message: Held) {
        let len = message.data.len();
        if let Some(buffer) = self.snapshot.as_mut() {
            buffer.bytes += len;
            buffer.messages.push_back(message);
            // The oldest make room: a snapshot holds the newest messages.
            while buffer.bytes > buffer.budget {
                match buffer.messages.pop_front() {
                    Some(old) => buffer.bytes -= old.data.len(),
                    None => break,
                }
            }
            self.shared
                .buffered
                .store(buffer.messages.len() as u64, Ordering::Relaxed);
            self.shared.queued_bytes.fetch_sub(len, Ordering::Relaxed);
            return;
        }
        let written = self.write(
            message.index,
            message.log_time,
            message.publish_time,
            message.sequence,
            &message.data,
        );
        self.shared.queued_bytes.fetch_sub(len, Ordering::Relaxed);
        self.count(message.index, written, len);
    }

    fn write(
        &mut self,
        index: usize,
        log_time: u64,
        publish_time: u64,
        sequence: u32,
        data: &[u8],
    ) -> bool {
        let topic = match self.channels.get(&index).map(|c| &c.state) {
            Some(State::Open(id)) => Some(*id),
            _ => None,
        };
        let written = match (self.failure.is_none(), topic) {
            (true, Some(id)) => {
                match self
                    .writer
                    .write(id, log_time, publish_time, sequence, data)
                {
                    Ok(()) => true,
                    Err(e) => {
                        self.fail(e);
                        false
                    }
                }
            }
            _ => false,
        };
        for split in self.writer.take_splits() {
            self.split_events.publish(&split);
        }
        written
    }

    /// Close the open chunk if it has grown old.
    fn flush_if_due(&mut self) {
        if self.failure.is_none() {
            if let Err(e) = self.writer.flush_if_due() {
                self.fail(e);
            }
        }
    }

    /// Keep the first write failure; nothing is written after it.
    fn fail(&mut self, e: Error) {
        if self.failure.is_some() {
            return;
        }
        tracing::error!("recording stops writing: {e}");
        *self
            .shared
            .failure
            .lock()
            .unwrap_or_else(|e| e.into_inner()) = Some(e.to_string());
        self.failure = Some(e);
    }

    fn count(&self, index: usize, written: bool, len: usize) {
        let channel = self.channels.get(&index).map(|c| &c.counts);
        if written {
            self.shared.written.fetch_add(1, Ordering::Relaxed);
            self.shared.bytes.fetch_add(len as u64, Ordering::Relaxed);
            if let Some(channel) = channel {
                channel.written.fetch_add(1, Ordering::Relaxed);
            }
        } else {
            self.shared.dropped.fetch_add(1, Ordering::Relaxed);
            if let Some(channel) = channel {
                channel.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    fn split(&mut self) -> Result<FileSplit, Error> {
        let split = match &self.failure {
            Some(e) => Err(format!("the recording stopped writing: {e}").into()),
            None => self.writer.split().map_err(|e| {
                let said = e.to_string();
                self.fail(e);
                said.into()
            }),
        };
        for split in self.writer.take_splits() {
            self.split_events.publish(&split);
        }
        split
    }

    /// Write the snapshot buffer's messages, oldest first, and empty it.
    fn snapshot(&mut self) -> Result<u64, Error> {
        let Some(buffer) = self.snapshot.as_mut() else {
            return Err("not in snapshot mode: record with --snapshot-mode".into());
        };
        let held = std::mem::take(&mut buffer.messages);
        buffer.bytes = 0;
        self.shared.buffered.store(0, Ordering::Relaxed);
        let mut written = 0;
        for message in held {
            let ok = self.write(
                message.index,
                message.log_time,
                message.publish_time,
                message.sequence,
                &message.data,
            );
            self.count(message.index, ok, message.data.len());
            written += u64::from(ok);
        }
        match &self.failure {
            Some(e) => Err(format!("the recording stopped writing: {e}").into()),
            None => Ok(written),
        }
    }
}
