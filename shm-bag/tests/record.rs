//! Recording and playing back live topics between processes' sessions: the
//! files read back with the `mcap` reader hold every message byte for byte,
//! with rosbag2's schemas, channel metadata and `metadata.yaml`; playing
//! them back delivers the same bytes, large ones through shared memory.

use std::collections::BTreeMap;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use shm_bag::{metadata, Bag, PlayOptions, Player, RecordOptions, Recorder, Selection};
use shm_cdr::msgs::builtin_interfaces::msg::Time;
use shm_cdr::msgs::rosgraph_msgs::msg::Clock;
use shm_cdr::msgs::sensor_msgs::msg::Image;
use shm_cdr::msgs::std_msgs::msg::String as RosString;
use shm_cdr::RosMessage;
use shm_runtime::rmw::Qos;
use shm_runtime::{RosNode, ShmConfig, ShmContext};
use zenoh::{Session, Wait};

mod common;
use common::{peer, recording, sessions, wait_until, TIMEOUT};

/// A type the recorder was not built with: described by its publisher's
/// `~/get_type_description`.
#[derive(Debug, Clone, Default, PartialEq, RosMessage)]
#[ros(type_name = "robot_msgs/msg/Battery")]
struct Battery {
    voltage: f32,
    cells: Vec<u16>,
    label: String,
}

/// Whether this process may lock all the shared memory it maps (root,
/// `CAP_IPC_LOCK`, no limit): only then are the pools below sure to be made
/// and mapped. Under a memory-lock limit messages go from the heap instead,
/// and everything else holds the same.
fn unlimited() -> bool {
    let budget = shm_runtime::MemlockBudget::read();
    budget.exempt || budget.limit.is_none()
}
const COUNT: usize = 20;

/// A profile of its own, to see it recorded and played back.
fn image_qos() -> Qos {
    Qos::with_history(
        shm_runtime::rmw::Reliability::Reliable,
        shm_runtime::rmw::Durability::Volatile,
        shm_runtime::rmw::History::KeepLast(7),
    )
    .deadline(Duration::from_millis(250))
}

fn image(i: usize) -> Image {
    Image {
        height: 512,
        width: 512,
        encoding: "mono8".into(),
        step: 512,
        data: (0..512 * 512).map(|j| (i * 7 + j) as u8).collect(),
        ..Image::default()
    }
}

#[test]
fn a_recording_holds_every_message_byte_for_byte_and_plays_back() {
    let (a, b) = sessions();
    let pool = ShmContext::new(ShmConfig::enabled().pool_size_at_most(16 << 20)).unwrap();
    let camera = RosNode::builder(&a, "camera")
        .domain_id(0)
        .shm(&pool)
        .wait()
        .unwrap();
    let chatter = camera
        .declare_publisher::<RosString>("/chatter")
        .wait()
        .unwrap();
    let images = camera
        .declare_publisher_with_qos::<Image>("/image", image_qos())
        .wait()
        .unwrap();
    let battery = camera
        .declare_publisher::<Battery>("/battery")
        .wait()
        .unwrap();
    let latched = camera
        .declare_publisher_with_qos::<RosString>("/latched", Qos::transient_local(1))
        .wait()
        .unwrap();
    // Published before the recording starts: a transient-local topic's
    // kept message is recorded when the recorder joins.
    latched
        .publish(&RosString {
            data: "kept".into(),
        })
        .wait()
        .unwrap();

    let dir = std::env::temp_dir().join(format!("shm_bag_test_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let selection = Selection {
        topics: vec!["/chatter".into(), "image".into(), "/latched".into()],
        regex: Some(regex::Regex::new("^/bat").unwrap()),
        ..Selection::default()
    };
    let mut options = RecordOptions::new(dir.join("bag"), selection);
    options.domain_id = Some(0);
    let recorder = Recorder::start(&b, options).unwrap();
    wait_until("four topics", || recorder.stats().topics == 4);
    assert!(chatter.wait_for_subscribers(TIMEOUT));
    assert!(images.wait_for_subscribers(TIMEOUT));
    assert!(battery.wait_for_subscribers(TIMEOUT));

    let mut expected: BTreeMap<&str, Vec<Vec<u8>>> = BTreeMap::new();
    expected.insert(
        "/latched",
        vec![shm_cdr::to_vec(&RosString {
            data: "kept".into(),
        })
        .unwrap()],
    );
    for i in 0..COUNT {
        let text = RosString {
            data: format!("hello {i}"),
        };
        chatter.publish(&text).wait().unwrap();
        expected
            .entry("/chatter")
            .or_default()
            .push(shm_cdr::to_vec(&text).unwrap());
        let img = image(i);
        let outcome = images.publish(&img).wait().unwrap();
        assert!(outcome.kind.is_shm() || !unlimited(), "{outcome:?}");
        expected
            .entry("/image")
            .or_default()
            .push(shm_cdr::to_vec(&img).unwrap());
        let b = Battery {
            voltage: 11.5 + i as f32,
            cells: vec![i as u16; 3],
            label: "pack".into(),
        };
        battery.publish(&b).wait().unwrap();
        expected
            .entry("/battery")
            .or_default()
            .push(shm_cdr::to_vec(&b).unwrap());
    }
    let total = (3 * COUNT + 1) as u64;
    wait_until("every message written", || {
        recorder.stats().written == total
    });
    let stats = recorder.stats();
    assert_eq!((stats.dropped, stats.missed), (0, 0), "{stats:?}");
    let written = recorder.stop().unwrap();
    assert_eq!(written.message_count, total);

    // metadata.yaml, as rosbag2 reads it.
    let meta = metadata::BagMetadata::read(&dir.join("bag")).unwrap();
    assert_eq!(meta, written);
    assert_eq!(meta.version, 9);
    assert_eq!(meta.storage_identifier, "mcap");
    assert_eq!(meta.relative_file_paths, ["bag_0.mcap"]);
    let counts: BTreeMap<&str, (u64, &str, &str)> = meta
        .topics_with_message_count
        .iter()
        .map(|t| {
            (
                t.topic_metadata.name.as_str(),
                (
                    t.message_count,
                    t.topic_metadata.type_name.as_str(),
                    t.topic_metadata.type_description_hash.as_str(),
                ),
            )
        })
        .collect();
    assert_eq!(
        counts,
        BTreeMap::from([
            (
                "/battery",
                (COUNT as u64, Battery::TYPE_NAME, Battery::type_hash())
            ),
            (
                "/chatter",
                (COUNT as u64, RosString::TYPE_NAME, RosString::type_hash())
            ),
            (
                "/image",
                (COUNT as u64, Image::TYPE_NAME, Image::type_hash())
            ),
            (
                "/latched",
                (1, RosString::TYPE_NAME, RosString::type_hash())
            ),
        ])
    );

    // The MCAP file, through the mcap crate's reader.
    let bytes = std::fs::read(dir.join("bag").join("bag_0.mcap")).unwrap();
    let mut seen: BTreeMap<String, Vec<Vec<u8>>> = BTreeMap::new();
    // The file is in receiving order: log-time order, but for /battery's
    // first messages, held while its type was asked of the camera node and
    // written once it answered.
    let mut last_log_time: BTreeMap<String, u64> = BTreeMap::new();
    let (mut earliest, mut latest) = (u64::MAX, 0);
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        let channel = &message.channel;
        let schema = channel.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "ros2msg");
        assert_eq!(channel.message_encoding, "cdr");
        let hash = &channel.metadata["topic_type_hash"];
        assert_eq!(hash, &counts[channel.topic.as_str()].2);
        let qos = shm_bag::qos::from_yaml(&channel.metadata["offered_qos_profiles"]).unwrap();
        assert_eq!(qos.len(), 1, "{}", channel.topic);
        if channel.topic == "/image" {
            assert_eq!(qos[0].to_qos(), image_qos());
        }
        let definition = std::str::from_utf8(&schema.data).unwrap();
        if channel.topic == "/battery" {
            assert_eq!(definition, "float32 voltage\nuint16[] cells\nstring label");
        }
        if channel.topic == "/image" {
            assert!(
                definition.contains("\nMSG: std_msgs/msg/Header\n"),
                "{definition}"
            );
        }
        let order = if channel.topic == "/battery" {
            "/battery"
        } else {
            "never held"
        };
        let last = last_log_time.entry(order.to_owned()).or_default();
        assert!(message.log_time >= *last, "{}", channel.topic);
        *last = message.log_time;
        assert!(message.publish_time <= message.log_time);
        earliest = earliest.min(message.log_time);
        latest = latest.max(message.log_time);
        seen.entry(channel.topic.clone())
            .or_default()
            .push(message.data.into_owned());
    }
    for (topic, messages) in &expected {
        assert!(
            seen[*topic] == *messages,
            "{topic}: the recorded bytes differ"
        );
    }
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert_eq!(summary.stats.unwrap().message_count, total);
    assert_eq!(meta.starting_time.nanoseconds_since_epoch, earliest);
    assert_eq!(meta.duration.nanoseconds, latest - earliest);
    // Read back in log-time order, whatever order the file holds.
    let bag = Bag::open(&dir.join("bag")).unwrap();
    let mut read = Vec::new();
    bag.read(
        0,
        |_| {},
        |m| {
            read.push(m.log_time);
            std::ops::ControlFlow::<()>::Continue(())
        },
    )
    .unwrap();
    assert_eq!(read.len() as u64, total);
    assert!(read.is_sorted());

    // Played back: the same bytes, in order, the images through shared memory.
    let listener = RosNode::builder(&a, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let played_images = listener
        .declare_subscriber_with_qos::<Image>("/image", image_qos())
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    let played_batteries = listener
        .declare_subscriber::<Battery>("/battery")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    let options = PlayOptions {
        rate: 10.0,
        topics: vec!["/image".into(), "/battery".into()],
        domain_id: Some(0),
        wait_for_subscribers: Some(TIMEOUT),
        ..PlayOptions::default()
    };
    let player = Player::new(&b, Bag::open(&dir.join("bag")).unwrap(), options).unwrap();
    let played = player.play(&AtomicBool::new(false)).unwrap();
    assert_eq!(played.published, 2 * COUNT as u64);
    if unlimited() {
        assert_eq!(played.shm, COUNT as u64, "every image from shared memory");
    }
    for (i, want) in expected["/battery"].iter().enumerate() {
        let sample = played_batteries.recv_timeout(TIMEOUT).unwrap().unwrap();
        assert_eq!(&sample.payload().to_bytes()[..], &want[..], "battery {i}");
    }
    for (i, want) in expected["/image"].iter().enumerate() {
        let sample = played_images.recv_timeout(TIMEOUT).unwrap().unwrap();
        assert!(
            sample.is_shm() || !unlimited(),
            "image {i} through shared memory"
        );
        assert!(sample.payload().to_bytes()[..] == want[..], "image {i}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A bag of 20 `/battery` messages 50 ms apart from `T0` (each labelled
/// with its number), and one recorded `/clock` message far from them.
const T0: u64 = 1_700_000_000_000_000_000;
const STEP: u64 = 50_000_000;

fn timed_bag(dir: &std::path::Path, options: shm_bag::WriteOptions) {
    use shm_bag::metadata::TopicMetadata;
    let mut writer = shm_bag::BagWriter::create(dir, options).unwrap();
    let topic = |name: &str, type_name: &str, hash: &str| TopicMetadata {
        name: name.into(),
        type_name: type_name.into(),
        serialization_format: "cdr".into(),
        offered_qos_profiles: Vec::new(),
        type_description_hash: hash.into(),
    };
    let battery = writer
        .add_topic(
            topic("/battery", Battery::TYPE_NAME, Battery::type_hash()),
            shm_bag::definition::of_description(&Battery::full_description()),
        )
        .unwrap();
    let clock = writer
        .add_topic(
            topic("/clock", Clock::TYPE_NAME, Clock::type_hash()),
            shm_bag::definition::of_description(&Clock::full_description()),
        )
        .unwrap();
    let recorded_clock = Clock {
        clock: Time {
            sec: 42,
            nanosec: 0,
        },
    };
    writer
        .write(clock, T0, T0, 0, &shm_cdr::to_vec(&recorded_clock).unwrap())
        .unwrap();
    for k in 0..20u64 {
        let msg = Battery {
            label: k.to_string(),
            ..Battery::default()
        };
        let time = T0 + k * STEP;
        writer
            .write(
                battery,
                time,
                time,
                k as u32,
                &shm_cdr::to_vec(&msg).unwrap(),
            )
            .unwrap();
    }
    writer.finish().unwrap();
}

fn nanos(time: &Time) -> u64 {
    time.sec as u64 * 1_000_000_000 + u64::from(time.nanosec)
}

#[test]
fn playback_publishes_its_time_on_clock_from_the_start_offset_for_the_duration() {
    let (a, b) = sessions();
    let dir = std::env::temp_dir().join(format!("shm_bag_clock_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    timed_bag(&dir, shm_bag::WriteOptions::default());
    let (listener, batteries) = battery_listener(&a);
    let clocks = listener
        .declare_subscriber_with_qos::<Clock>("/clock", Qos::clock())
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    let drain = |clocks: &shm_runtime::RosSubscriber<Clock>| {
        let mut times = Vec::new();
        while let Some(sample) = clocks.recv_timeout(Duration::from_millis(300)).unwrap() {
            times.push(nanos(&sample.decode::<Clock>().unwrap().clock));
        }
        times
    };

    // From 200 ms in, 500 ms of the bag, twice as fast, /clock at 100 Hz.
    let options = PlayOptions {
        rate: 2.0,
        domain_id: Some(0),
        wait_for_subscribers: Some(TIMEOUT),
        clock_hz: Some(100.0),
        start_offset: Duration::from_millis(200),
        duration: Some(Duration::from_millis(500)),
        ..PlayOptions::default()
    };
    let player = Player::new(&b, Bag::open(&dir).unwrap(), options).unwrap();
    let played = player.play(&AtomicBool::new(false)).unwrap();
    // Messages 4 (200 ms) to 14 (700 ms); the recorded /clock is not played.
    assert_eq!(played.published, 11);
    for k in 4..=14 {
        let sample = batteries.recv_timeout(TIMEOUT).unwrap().unwrap();
        assert_eq!(sample.decode::<Battery>().unwrap().label, k.to_string());
    }
    let times = drain(&clocks);
    // 250 ms of playback at 100 Hz: some ticks, all on the bag's timeline
    // from the offset on, never going back, and the recorded /clock absent.
    assert!(times.len() >= 5, "{} /clock ticks", times.len());
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
    let (begin, end) = (T0 + 4 * STEP, T0 + 14 * STEP);
    assert!(
        times.iter().all(|&t| (begin..=end + 2 * STEP).contains(&t)),
        "{times:?} outside {begin}..{end}"
    );
    assert!(
        times.iter().any(|&t| t > begin),
        "the clock runs: {times:?}"
    );

    // Before each message: its own time, exactly.
    let options = PlayOptions {
        rate: 4.0,
        domain_id: Some(0),
        wait_for_subscribers: Some(TIMEOUT),
        clock_on: shm_bag::ClockTrigger::AllTopics,
        duration: Some(Duration::from_millis(250)),
        ..PlayOptions::default()
    };
    let player = Player::new(&b, Bag::open(&dir).unwrap(), options).unwrap();
    assert_eq!(player.play(&AtomicBool::new(false)).unwrap().published, 6);
    let times = drain(&clocks);
    let expected: Vec<u64> = (0..=5).map(|k| T0 + k * STEP).collect();
    assert_eq!(times, expected);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_existing_output_directory_is_refused_with_what_to_do() {
    let (_a, b) = sessions();
    let dir = std::env::temp_dir();
    let selection = Selection {
        all: true,
        ..Selection::default()
    };
    let err = Recorder::start(&b, RecordOptions::new(&dir, selection)).unwrap_err();
    assert!(err.to_string().contains("exists already"), "{err}");
    let err =
        Recorder::start(&b, RecordOptions::new(dir.join("x"), Selection::default())).unwrap_err();
    assert!(err.to_string().contains("nothing to record"), "{err}");
}

#[test]
fn a_paused_playback_steps_bursts_seeks_and_changes_rate_through_rosbag2s_services() {
    use shm_bag::interfaces::rosbag2_interfaces::srv::*;
    let (a, b) = sessions();
    let dir = std::env::temp_dir().join(format!("shm_bag_control_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // A chunk per message, compressed: seeking skips whole chunks by their
    // index, and reads compressed ones.
    let options = shm_bag::WriteOptions {
        chunk_size: 1,
        compression: Some(shm_bag::Compression::Zstd),
        ..shm_bag::WriteOptions::default()
    };
    timed_bag(&dir, options);
    let (listener, batteries) = battery_listener(&a);
    let next_label = || {
        let sample = batteries.recv_timeout(TIMEOUT).unwrap();
        sample.map(|s| s.decode::<Battery>().unwrap().label)
    };
    let quiet = || {
        batteries
            .recv_timeout(Duration::from_millis(300))
            .unwrap()
            .is_none()
    };
    macro_rules! client {
        ($srv:ty, $name:literal) => {{
            let client = listener
                .declare_client::<$srv>(concat!("/rosbag2_player/", $name))
                .wait()
                .unwrap();
            assert!(client.wait_for_service(TIMEOUT), "{} not found", $name);
            client
        }};
    }
    let time = |t: u64| Time {
        sec: (t / 1_000_000_000) as i32,
        nanosec: (t % 1_000_000_000) as u32,
    };

    let options = PlayOptions {
        domain_id: Some(0),
        topics: vec!["/battery".into()],
        wait_for_subscribers: Some(TIMEOUT),
        start_paused: true,
        ..PlayOptions::default()
    };
    let player = Player::new(&b, Bag::open(&dir).unwrap(), options).unwrap();
    let control = player.control();
    let is_paused = client!(IsPaused, "is_paused");
    let play_next = client!(PlayNext, "play_next");
    let burst = client!(Burst, "burst");
    let seek = client!(Seek, "seek");
    let set_rate = client!(SetRate, "set_rate");
    let get_rate = client!(GetRate, "get_rate");
    let toggle_paused = client!(TogglePaused, "toggle_paused");
    let stop = AtomicBool::new(false);
    let played = std::thread::scope(|s| {
        let playing = s.spawn(|| player.play(&stop));
        assert!(is_paused.call(&IsPaused_Request).wait().unwrap().paused);
        // Refused until the playback runs; then the first message, at once.
        wait_until("the playback to start", || {
            play_next.call(&PlayNext_Request).wait().unwrap().success
        });
        assert_eq!(next_label().as_deref(), Some("0"));
        assert_eq!(control.time(), T0, "the time jumps to the message's");
        assert!(quiet(), "paused: nothing more");
        let burst_3 = Burst_Request { num_messages: 3 };
        assert_eq!(burst.call(&burst_3).wait().unwrap().actually_burst, 3);
        for k in 1..=3 {
            assert_eq!(next_label(), Some(k.to_string()));
        }
        assert_eq!(control.time(), T0 + 3 * STEP);
        assert!(quiet());

        // Forward, back to before the start, past the end (refused).
        let to = |t| Seek_Request { time: time(t) };
        assert!(seek.call(&to(T0 + 10 * STEP)).wait().unwrap().success);
        assert!(play_next.call(&PlayNext_Request).wait().unwrap().success);
        assert_eq!(next_label().as_deref(), Some("10"));
        assert!(seek.call(&to(0)).wait().unwrap().success);
        assert!(play_next.call(&PlayNext_Request).wait().unwrap().success);
        assert_eq!(next_label().as_deref(), Some("0"));
        assert!(!seek.call(&to(T0 + 100 * STEP)).wait().unwrap().success);
        assert!(quiet());

        let rate = |rate| SetRate_Request { rate };
        assert!(!set_rate.call(&rate(0.0)).wait().unwrap().success);
        assert!(!set_rate.call(&rate(f64::NAN)).wait().unwrap().success);
        assert!(set_rate.call(&rate(4.0)).wait().unwrap().success);
        assert_eq!(get_rate.call(&GetRate_Request).wait().unwrap().rate, 4.0);

        // Resumed: the rest, from message 1, at four times the recorded pace.
        toggle_paused.call(&TogglePaused_Request).wait().unwrap();
        assert!(!is_paused.call(&IsPaused_Request).wait().unwrap().paused);
        let resumed = Instant::now();
        for k in 1..20 {
            assert_eq!(next_label(), Some(k.to_string()));
        }
        let took = resumed.elapsed();
        assert!(
            took >= Duration::from_millis(19 * 50 / 4 - 20),
            "19 gaps of 50 ms at rate 4 took {took:?}"
        );
        playing.join().unwrap().unwrap()
    });
    assert_eq!(played.published, 1 + 3 + 1 + 1 + 19);
    assert!(!control.play_next(), "over: nothing to step to");
    drop(player);

    // Stopped by the service in the middle of a slow playback.
    let options = PlayOptions {
        domain_id: Some(0),
        topics: vec!["/battery".into()],
        wait_for_subscribers: Some(TIMEOUT),
        rate: 0.1,
        ..PlayOptions::default()
    };
    let player = Player::new(&b, Bag::open(&dir).unwrap(), options).unwrap();
    let stop_service = client!(Stop, "stop");
    let pause = client!(Pause, "pause");
    let resume = client!(Resume, "resume");
    let played = std::thread::scope(|s| {
        let playing = s.spawn(|| player.play(&stop));
        assert_eq!(next_label().as_deref(), Some("0"));
        pause.call(&Pause_Request).wait().unwrap();
        assert!(is_paused.call(&IsPaused_Request).wait().unwrap().paused);
        resume.call(&Resume_Request).wait().unwrap();
        assert!(!is_paused.call(&IsPaused_Request).wait().unwrap().paused);
        stop_service.call(&Stop_Request).wait().unwrap();
        playing.join().unwrap().unwrap()
    });
    // The second message is due 500 ms after the first.
    assert!(played.published <= 2, "{played:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_paused_recording_writes_nothing_and_splits_on_request_announcing_it() {
    use shm_bag::interfaces::rosbag2_interfaces::msg::{ReadSplitEvent, WriteSplitEvent};
    use shm_bag::interfaces::rosbag2_interfaces::srv::*;
    let (a, b) = sessions();
    let (talker, chatter) = chatter_talker(&a);
    let splits = talker
        .declare_subscriber::<WriteSplitEvent>("/events/write_split")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    macro_rules! client {
        ($srv:ty, $name:literal) => {{
            let client = talker
                .declare_client::<$srv>(concat!("/rosbag2_recorder/", $name))
                .wait()
                .unwrap();
            assert!(client.wait_for_service(TIMEOUT), "{} not found", $name);
            client
        }};
    }

    let (dir, mut options) = recording(
        "shm_bag_pause",
        vec!["/chatter".into(), "/events/write_split".into()],
    );
    options.start_paused = true;
    let recorder = Recorder::start(&b, options).unwrap();
    let (_probe_node, probe) = chatter_probe(&b);
    let delivered = |n: usize| {
        for _ in 0..n {
            assert!(probe.recv_timeout(TIMEOUT).unwrap().is_some());
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let is_paused = client!(IsPaused, "is_paused");
    let pause = client!(Pause, "pause");
    let resume = client!(Resume, "resume");
    let split = client!(SplitBagfile, "split_bagfile");
    wait_until("the recorder to subscribe", || recorder.stats().topics == 1);
    assert!(chatter.wait_for_subscribers(TIMEOUT));
    assert!(splits.wait_for_publishers(TIMEOUT));
    let mut sent = 0;
    let mut say = |n: usize| {
        for _ in 0..n {
            let text = RosString {
                data: format!("message {sent}"),
            };
            chatter.publish(&text).wait().unwrap();
            sent += 1;
        }
    };

    assert!(is_paused.call(&IsPaused_Request).wait().unwrap().paused);
    say(5); // 0..5, paused: not written
    delivered(5);
    assert_eq!(recorder.stats().written, 0);
    resume.call(&Resume_Request).wait().unwrap();
    assert!(!is_paused.call(&IsPaused_Request).wait().unwrap().paused);
    say(5); // 5..10 into the first file
    delivered(5);
    wait_until("five written", || recorder.stats().written == 5);

    split.call(&SplitBagfile_Request).wait().unwrap();
    let event = splits
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("a split event");
    let event = event.decode::<WriteSplitEvent>().unwrap();
    let bag = std::path::absolute(dir.join("bag")).unwrap();
    assert_eq!(
        event.closed_file,
        bag.join("bag_0.mcap").display().to_string()
    );
    assert_eq!(
        event.opened_file,
        bag.join("bag_1.mcap").display().to_string()
    );
    assert_eq!(event.node_name, "/rosbag2_recorder");

    say(3); // 10..13 into the second file
    delivered(3);
    wait_until("eight written", || recorder.stats().written == 8);
    pause.call(&Pause_Request).wait().unwrap();
    say(2); // 13..15, paused
    delivered(2);
    resume.call(&Resume_Request).wait().unwrap();
    say(1); // 15: the paused ones are no gap
    delivered(1);
    wait_until("nine written", || recorder.stats().written == 9);
    let stats = recorder.stats();
    assert_eq!(
        (stats.received, stats.dropped, stats.missed),
        (9, 0, 0),
        "{stats:?}"
    );
    let refused = recorder.control().snapshot().unwrap_err().to_string();
    assert!(refused.contains("--snapshot-mode"), "{refused}");
    let written = recorder.stop().unwrap();
    assert_eq!(written.relative_file_paths, ["bag_0.mcap", "bag_1.mcap"]);
    assert_eq!(
        written.topics_with_message_count.len(),
        1,
        "the recorder's own split events are not recorded"
    );

    let texts = |file: &str| -> Vec<String> {
        let bytes = std::fs::read(dir.join("bag").join(file)).unwrap();
        mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| {
                shm_cdr::from_bytes::<RosString>(&m.unwrap().data)
                    .unwrap()
                    .data
            })
            .collect()
    };
    let numbered = |range: std::ops::Range<usize>| -> Vec<String> {
        range.map(|k| format!("message {k}")).collect()
    };
    assert_eq!(texts("bag_0.mcap"), numbered(5..10));
    let mut second = numbered(10..13);
    second.extend(numbered(15..16));
    assert_eq!(texts("bag_1.mcap"), second);

    // Played back: the move from one file to the next is announced.
    let read_splits = talker
        .declare_subscriber::<ReadSplitEvent>("/events/read_split")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    let options = PlayOptions {
        domain_id: Some(0),
        rate: 100.0,
        ..PlayOptions::default()
    };
    let player = Player::new(&b, Bag::open(&dir.join("bag")).unwrap(), options).unwrap();
    assert!(read_splits.wait_for_publishers(TIMEOUT));
    assert_eq!(player.play(&AtomicBool::new(false)).unwrap().published, 9);
    let event = read_splits
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("a read split event");
    let event = event.decode::<ReadSplitEvent>().unwrap();
    assert_eq!(
        (event.closed_file.as_str(), event.opened_file.as_str()),
        (
            bag.join("bag_0.mcap").display().to_string().as_str(),
            bag.join("bag_1.mcap").display().to_string().as_str()
        )
    );
    assert_eq!(event.node_name, "/rosbag2_player");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_snapshot_recording_writes_the_newest_messages_when_asked() {
    use shm_bag::interfaces::rosbag2_interfaces::srv::*;
    let (a, b) = sessions();
    let (talker, chatter) = chatter_talker(&a);
    let (_probe_node, probe) = chatter_probe(&b);
    let message = |k: usize| RosString {
        data: format!("message {k:02}"),
    };
    let size = shm_cdr::to_vec(&message(0)).unwrap().len();

    let (dir, mut options) = recording("shm_bag_snapshot", vec!["/chatter".into()]);
    options.snapshot = true;
    options.max_queued_bytes = 5 * size; // the newest five
    let recorder = Recorder::start(&b, options).unwrap();
    let snapshot = talker
        .declare_client::<Snapshot>("/rosbag2_recorder/snapshot")
        .wait()
        .unwrap();
    assert!(snapshot.wait_for_service(TIMEOUT));
    wait_until("the recorder to subscribe", || recorder.stats().topics == 1);
    assert!(chatter.wait_for_subscribers(TIMEOUT));
    let mut sent = 0;
    // One at a time, each in the buffer before the next: what waits for the
    // writer stays within the budget too.
    let mut say = |n: usize| {
        for _ in 0..n {
            chatter.publish(&message(sent)).wait().unwrap();
            sent += 1;
            assert!(probe.recv_timeout(TIMEOUT).unwrap().is_some());
            wait_until("the writer to take it", || {
                recorder.stats().queued_bytes == 0
            });
        }
    };

    say(12);
    wait_until("five held", || recorder.stats().buffered == 5);
    assert_eq!(recorder.stats().written, 0);
    assert!(snapshot.call(&Snapshot_Request).wait().unwrap().success);
    assert_eq!(recorder.stats().written, 5);
    say(2);
    wait_until("two held", || recorder.stats().buffered == 2);
    assert_eq!(recorder.control().snapshot().unwrap(), 2);
    say(1);
    wait_until("one held", || recorder.stats().buffered == 1);
    let stats = recorder.stats();
    assert_eq!((stats.dropped, stats.missed), (0, 0), "{stats:?}");
    let written = recorder.stop().unwrap();
    assert_eq!(written.message_count, 7);

    let bytes = std::fs::read(dir.join("bag").join("bag_0.mcap")).unwrap();
    let texts: Vec<String> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            shm_cdr::from_bytes::<RosString>(&m.unwrap().data)
                .unwrap()
                .data
        })
        .collect();
    let expected: Vec<String> = (7..14).map(|k| message(k).data).collect();
    assert_eq!(texts, expected, "the newest five, then the next two");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_message_over_the_budget_is_counted_as_dropped_and_not_as_missed() {
    let (a, b) = sessions();
    let (_talker, chatter) = chatter_talker(&a);
    let (dir, mut options) = recording("shm_bag_budget", vec!["/chatter".into()]);
    let text = |data: &str| RosString { data: data.into() };
    // Room for a short message, not for a long one.
    options.max_queued_bytes = shm_cdr::to_vec(&text("short")).unwrap().len();
    let recorder = Recorder::start(&b, options).unwrap();
    wait_until("the recorder to subscribe", || recorder.stats().topics == 1);
    assert!(chatter.wait_for_subscribers(TIMEOUT));
    for (k, data) in ["short", "much too long", "much too long", "short"]
        .into_iter()
        .enumerate()
    {
        chatter.publish(&text(data)).wait().unwrap();
        wait_until("the writer to take it", || {
            let stats = recorder.stats();
            stats.received == k as u64 + 1 && stats.written + stats.dropped == stats.received
        });
    }
    let stats = recorder.stats();
    assert_eq!(
        (stats.written, stats.dropped, stats.missed),
        (2, 2, 0),
        "{stats:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn messages_arriving_over_two_links_at_once_are_written_in_log_time_order() {
    // Two publishing sessions, each with its own link to the recorder's:
    // their samples reach it on two threads at once.
    let port = shm_runtime::testing::free_port().unwrap();
    let recording_session = peer(port, true);
    let (dir, options) = recording("shm_bag_links", vec!["/left".into(), "/right".into()]);
    let recorder = Recorder::start(&recording_session, options).unwrap();
    let keep_all = Qos::with_history(
        shm_runtime::rmw::Reliability::Reliable,
        shm_runtime::rmw::Durability::Volatile,
        shm_runtime::rmw::History::KeepAll,
    );
    let talkers = ["/left", "/right"].map(|topic| {
        let session = peer(port, false);
        let node = RosNode::builder(&session, "talker")
            .domain_id(0)
            .wait()
            .unwrap();
        let publisher = node
            .declare_publisher_with_qos::<RosString>(topic, keep_all)
            .wait()
            .unwrap();
        assert!(publisher.wait_for_subscribers(TIMEOUT), "{topic}");
        (session, node, publisher)
    });
    const EACH: u64 = 5_000;
    std::thread::scope(|scope| {
        for (_, _, publisher) in &talkers {
            scope.spawn(move || {
                for i in 0..EACH {
                    let text = RosString {
                        data: i.to_string(),
                    };
                    publisher.publish(&text).wait().unwrap();
                }
            });
        }
    });
    wait_until("every message written", || {
        recorder.stats().written == 2 * EACH
    });
    let stats = recorder.stats();
    assert_eq!((stats.dropped, stats.missed), (0, 0), "{stats:?}");
    let written = recorder.stop().unwrap();

    let bytes = std::fs::read(dir.join("bag").join(&written.relative_file_paths[0])).unwrap();
    let mut times = Vec::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        times.push(message.unwrap().log_time);
    }
    assert_eq!(times.len() as u64, 2 * EACH);
    let behind = times.windows(2).filter(|w| w[1] < w[0]).count();
    assert_eq!(behind, 0, "messages written after a later one");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A node of `session` publishing `/chatter`.
fn chatter_talker(session: &Session) -> (RosNode, shm_runtime::RosPublisher<RosString>) {
    let talker = RosNode::builder(session, "talker")
        .domain_id(0)
        .wait()
        .unwrap();
    let chatter = talker
        .declare_publisher::<RosString>("/chatter")
        .wait()
        .unwrap();
    (talker, chatter)
}

/// A subscriber of `/chatter` in the recorder's `session`: once it has a
/// message, so has the recorder.
fn chatter_probe(session: &Session) -> (RosNode, shm_runtime::RosSubscriber<RosString>) {
    let node = RosNode::builder(session, "probe")
        .domain_id(0)
        .wait()
        .unwrap();
    let probe = node
        .declare_subscriber::<RosString>("/chatter")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    (node, probe)
}

/// A node of `session` keeping every `/battery` message it receives.
fn battery_listener(session: &Session) -> (RosNode, shm_runtime::RosSubscriber<Battery>) {
    let listener = RosNode::builder(session, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let batteries = listener
        .declare_subscriber::<Battery>("/battery")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    (listener, batteries)
}
