//! Playing a recording back: every selected topic published with its
//! recorded type and QoS, each message at its recorded time (scaled by a
//! rate), from an exact-size shared-memory buffer when it is large.

use std::collections::{BTreeMap, HashMap};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
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

use crate::bag::Bag;
use crate::control::{Due, PlayerControl};
use crate::interfaces::rosbag2_interfaces::msg::ReadSplitEvent;
use crate::split_events::SplitEvents;
use crate::storage::RecordedTopic;
use crate::writer::FileSplit;
use crate::Error;
use shm_runtime::types;
use shm_runtime::types::definition;

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

/// The type of a recorded topic, as type resolution reads a recording.
fn recorded_type(
    topic: &RecordedTopic,
    definitions: &BTreeMap<String, String>,
    distro: Distro,
) -> Option<types::ResolvedType> {
    let definition = definitions.get(&topic.type_name).map(String::as_str);
    types::of_recording(&topic.type_name, &topic.type_hash, definition, distro)
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
