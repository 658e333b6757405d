//! Recording beside nodes that never describe their types: nodes whose
//! `~/get_type_description` never answers, nodes without the service (as
//! every Humble node is), and a second type on a recorded topic. A topic of
//! a known type is recorded whole however many such nodes are there, and
//! every message that reaches the recorder is in the file or in a count.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use shm_bag::{Bag, PlayOptions, Player, RecordOptions, Recorder, Selection, TypeDefinition};
use shm_cdr::msgs::std_msgs::msg::String as RosString;
use shm_cdr::msgs::type_description_interfaces::srv::GetTypeDescription;
use shm_cdr::RosMessage;
use shm_runtime::rmw::Qos;
use shm_runtime::service::ServiceRequest;
use shm_runtime::RosNode;
use zenoh::{Session, Wait};

mod common;
use common::{recording, sessions, wait_until, TIMEOUT};

/// A type the recorder was not built with, described by its publisher.
#[derive(Debug, Clone, Default, PartialEq, RosMessage)]
#[ros(type_name = "robot_msgs/msg/Battery")]
struct Battery {
    voltage: f32,
    cells: Vec<u16>,
}

fn temp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A RIHS01 hash of its own for type number `i` (the recorder never decodes
/// these messages: a name and a hash is all a subscription needs).
fn fake_hash(i: usize) -> String {
    format!("RIHS01_{i:064x}")
}

/// Where the recording found the definition of `topic`'s type.
fn definition_of(stats: &shm_bag::RecordStats, topic: &str) -> TypeDefinition {
    stats
        .channels
        .iter()
        .find(|c| c.topic == topic)
        .map(|c| c.definition.clone())
        .unwrap_or_else(|| panic!("{topic} is recorded"))
}

/// Each recorded topic and type with its message count, as the file says.
fn counts(bag: &Bag) -> Vec<(String, String, u64)> {
    bag.topics()
        .unwrap()
        .into_iter()
        .map(|t| (t.name, t.type_name, t.message_count))
        .collect()
}

#[test]
fn silent_and_serviceless_nodes_hold_up_no_other_topic_and_lose_nothing() {
    let (a, b) = sessions();
    // A node whose type-description service takes every request and never
    // answers, announcing many topics of its own types.
    let silent = RosNode::builder(&a, "silent")
        .domain_id(0)
        .type_description_service(false)
        .wait()
        .unwrap();
    let unanswered: Arc<Mutex<Vec<ServiceRequest<GetTypeDescription>>>> = Arc::default();
    let kept = unanswered.clone();
    let _never = silent
        .declare_service::<GetTypeDescription>("~/get_type_description")
        .callback(move |request| kept.lock().unwrap().push(request))
        .wait()
        .unwrap();
    const SILENT_TOPICS: usize = 50;
    let silent_publishers: Vec<_> = (0..SILENT_TOPICS)
        .map(|i| {
            silent
                .declare_serialized_publisher(
                    &format!("/silent/t{i}"),
                    &format!("silent_msgs/msg/T{i}"),
                    &fake_hash(i),
                    Qos::default(),
                )
                .wait()
                .unwrap()
        })
        .collect();
    // A node without the service at all, as every Humble node is.
    let serviceless = RosNode::builder(&a, "serviceless")
        .domain_id(0)
        .type_description_service(false)
        .wait()
        .unwrap();
    let scan = serviceless
        .declare_serialized_publisher(
            "/old/scan",
            "old_msgs/msg/Scan",
            &fake_hash(1000),
            Qos::default(),
        )
        .wait()
        .unwrap();
    // A node that describes its own type.
    let robot = RosNode::builder(&a, "robot").domain_id(0).wait().unwrap();
    let battery = robot
        .declare_publisher::<Battery>("/battery")
        .wait()
        .unwrap();

    let dir = temp("shm_bag_silent");
    // Every topic but the nodes' own parameter events, which they publish
    // when they choose.
    let selection = Selection {
        all: true,
        exclude: Some(regex::Regex::new("^/parameter_events$").unwrap()),
        ..Selection::default()
    };
    let mut options = RecordOptions::new(dir.join("bag"), selection);
    options.domain_id = Some(0);
    options.type_timeout = Duration::from_secs(2);
    let recorder = Recorder::start(&b, options).unwrap();
    // A publisher of a standard type, started beside the recorder.
    let talker = RosNode::builder(&a, "talker").domain_id(0).wait().unwrap();
    let chatter = talker
        .declare_publisher::<RosString>("/chatter")
        .wait()
        .unwrap();
    assert!(
        chatter.wait_for_subscribers(TIMEOUT),
        "/chatter is subscribed at once"
    );
    assert!(battery.wait_for_subscribers(TIMEOUT));
    assert!(scan.wait_for_subscribers(TIMEOUT));
    for publisher in &silent_publishers {
        assert!(publisher.wait_for_subscribers(TIMEOUT));
    }

    // Published while the silent nodes' types are still being asked for.
    const EACH: u64 = 20;
    let bytes = [0u8, 1, 0, 0, 7, 7, 7, 7];
    for i in 0..EACH {
        chatter
            .publish(&RosString {
                data: format!("m{i}"),
            })
            .wait()
            .unwrap();
        battery
            .publish(&Battery {
                voltage: i as f32,
                cells: vec![i as u16; 3],
            })
            .wait()
            .unwrap();
    }
    for publisher in silent_publishers.iter().chain([&scan]) {
        publisher.publish_serialized(&bytes).unwrap();
        publisher.publish_serialized(&bytes).unwrap();
    }
    let expected = 2 * EACH + 2 * (SILENT_TOPICS as u64 + 1);
    wait_until("every message written", || {
        recorder.stats().written == expected
    });
    let stats = recorder.stats();
    assert!(
        !unanswered.lock().unwrap().is_empty(),
        "the silent node was asked"
    );
    assert_eq!((stats.dropped, stats.missed), (0, 0), "{stats:?}");
    let definition = |topic: &str| definition_of(&stats, topic);
    assert_eq!(
        definition("/chatter"),
        TypeDefinition::Known("the standard set".into())
    );
    assert_eq!(
        definition("/battery"),
        TypeDefinition::Known("/robot".into())
    );
    for i in 0..SILENT_TOPICS {
        match definition(&format!("/silent/t{i}")) {
            TypeDefinition::Missing(why) => assert!(why.contains("/silent"), "{why}"),
            other => panic!("/silent/t{i}: {other:?}"),
        }
    }
    match definition("/old/scan") {
        TypeDefinition::Missing(why) => assert!(why.contains("offers no"), "{why}"),
        other => panic!("/old/scan: {other:?}"),
    }
    for channel in &stats.channels {
        assert_eq!(channel.received, channel.written, "{channel:?}");
        assert_eq!(channel.held, 0, "{channel:?}");
    }
    let metadata = recorder.stop().unwrap();
    assert_eq!(metadata.message_count, expected);

    let bag = Bag::open(&dir.join("bag")).unwrap();
    let counts = counts(&bag);
    assert_eq!(counts.len(), SILENT_TOPICS + 3, "{counts:?}");
    for (topic, _, count) in &counts {
        let want = if topic == "/chatter" || topic == "/battery" {
            EACH
        } else {
            2
        };
        assert_eq!(*count, want, "{topic}");
    }
    // The standard and the described types have their definitions; the
    // others an empty schema, as rosbag2 records a type it has none of.
    let definitions = bag.definitions().unwrap();
    assert!(definitions.contains_key(RosString::TYPE_NAME));
    assert!(definitions["robot_msgs/msg/Battery"].contains("uint16[] cells"));
    assert_eq!(definitions.len(), 2, "{:?}", definitions.keys());
    let mut chatter_read = Vec::new();
    bag.read(
        0,
        |_| {},
        |m| {
            if m.topic == "/chatter" {
                chatter_read.push(shm_cdr::from_bytes::<RosString>(m.data).unwrap().data);
            }
            std::ops::ControlFlow::<()>::Continue(())
        },
    )
    .unwrap();
    let sent: Vec<String> = (0..EACH).map(|i| format!("m{i}")).collect();
    assert_eq!(chatter_read, sent);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_second_type_on_a_topic_is_a_channel_of_its_own_recorded_and_played() {
    let (a, b) = sessions();
    let talker = RosNode::builder(&a, "talker").domain_id(0).wait().unwrap();
    let text = talker.declare_publisher::<RosString>("/x").wait().unwrap();
    let robot = RosNode::builder(&a, "robot").domain_id(0).wait().unwrap();
    let battery = robot.declare_publisher::<Battery>("/x").wait().unwrap();

    let (dir, options) = recording("shm_bag_two_types", vec!["/x".into()]);
    let recorder = Recorder::start(&b, options).unwrap();
    assert!(text.wait_for_subscribers(TIMEOUT));
    assert!(battery.wait_for_subscribers(TIMEOUT));
    const EACH: u64 = 10;
    for i in 0..EACH {
        text.publish(&RosString {
            data: format!("t{i}"),
        })
        .wait()
        .unwrap();
        battery
            .publish(&Battery {
                voltage: i as f32,
                cells: vec![1, 2],
            })
            .wait()
            .unwrap();
    }
    wait_until("both types written", || {
        recorder.stats().written == 2 * EACH
    });
    let stats = recorder.stats();
    assert_eq!(stats.topics, 1);
    assert_eq!(stats.channels.len(), 2, "{stats:?}");
    recorder.stop().unwrap();

    let bag = Bag::open(&dir.join("bag")).unwrap();
    assert_eq!(
        counts(&bag),
        [
            ("/x".to_owned(), Battery::TYPE_NAME.to_owned(), EACH),
            ("/x".to_owned(), RosString::TYPE_NAME.to_owned(), EACH),
        ]
    );
    let listed = bag.describe().unwrap().topics_with_message_count;
    assert_eq!(listed.len(), 2, "metadata.yaml lists /x with each type");

    // Played back, each type goes to its own subscribers.
    drop((text, battery));
    let listener = RosNode::builder(&a, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let texts = listener
        .declare_subscriber::<RosString>("/x")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    let batteries = listener
        .declare_subscriber::<Battery>("/x")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    let play = PlayOptions {
        domain_id: Some(0),
        wait_for_subscribers: Some(TIMEOUT),
        ..PlayOptions::default()
    };
    let player = Player::new(&b, bag, play).unwrap();
    let played = player
        .play(&std::sync::atomic::AtomicBool::new(false))
        .unwrap();
    assert_eq!(played.published, 2 * EACH);
    let mut got_texts = Vec::new();
    while got_texts.len() < EACH as usize {
        let sample = texts
            .recv_timeout(TIMEOUT)
            .unwrap()
            .expect("a played message");
        got_texts.push(sample.decode::<RosString>().unwrap().data);
    }
    let expected: Vec<String> = (0..EACH).map(|i| format!("t{i}")).collect();
    assert_eq!(got_texts, expected);
    for i in 0..EACH {
        let sample = batteries
            .recv_timeout(TIMEOUT)
            .unwrap()
            .expect("a played message");
        assert_eq!(sample.decode::<Battery>().unwrap().voltage, i as f32);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A node that serves megabytes of source text with a small type: the
/// recording keeps text written back from the description instead, and the
/// file stays the size of its messages.
#[test]
fn a_type_source_of_megabytes_is_not_kept() {
    use shm_cdr::msgs::type_description_interfaces::msg::TypeSource;
    use shm_cdr::msgs::type_description_interfaces::srv::GetTypeDescription_Response;

    /// A node `name` publishing Battery on `topic`, whose
    /// `~/get_type_description` answers with `source` as the type's text.
    fn verbose_node(
        session: &Session,
        name: &str,
        topic: &str,
        source: String,
    ) -> (RosNode, impl Sized, shm_runtime::RosPublisher<Battery>) {
        let node = RosNode::builder(session, name)
            .domain_id(0)
            .type_description_service(false)
            .wait()
            .unwrap();
        let server = node
            .declare_service::<GetTypeDescription>("~/get_type_description")
            .handler(move |_| GetTypeDescription_Response {
                successful: true,
                failure_reason: String::new(),
                type_description: (&Battery::full_description()).into(),
                type_sources: vec![TypeSource {
                    type_name: Battery::TYPE_NAME.into(),
                    encoding: "msg".into(),
                    raw_file_contents: source.clone(),
                }],
                extra_information: Vec::new(),
            })
            .wait()
            .unwrap();
        let publisher = node.declare_publisher::<Battery>(topic).wait().unwrap();
        (node, server, publisher)
    }

    let (a, b) = sessions();
    let huge = "# padding\n".repeat(400_000) + "float32 voltage\nuint16[] cells\n";
    let (_robot, _server, battery) = verbose_node(&a, "verbose", "/battery", huge);
    // A reply past what is read at all: 20 MiB of text.
    let (_flood, _flood_server, flooded) =
        verbose_node(&a, "flood", "/flooded", "#".repeat(20 << 20));
    let (dir, options) = recording(
        "shm_bag_verbose",
        vec!["/battery".into(), "/flooded".into()],
    );
    let recorder = Recorder::start(&b, options).unwrap();
    assert!(battery.wait_for_subscribers(TIMEOUT));
    assert!(flooded.wait_for_subscribers(TIMEOUT));
    battery.publish(&Battery::default()).wait().unwrap();
    flooded.publish(&Battery::default()).wait().unwrap();
    wait_until("the messages written", || recorder.stats().written == 2);
    let stats = recorder.stats();
    let definition = |topic: &str| definition_of(&stats, topic);
    assert_eq!(
        definition("/battery"),
        TypeDefinition::Known("/verbose".into())
    );
    match definition("/flooded") {
        TypeDefinition::Missing(why) => {
            assert!(why.contains("more than the 16777216 read"), "{why}")
        }
        other => panic!("{other:?}"),
    }
    recorder.stop().unwrap();
    let bag = Bag::open(&dir.join("bag")).unwrap();
    let definition = &bag.definitions().unwrap()[Battery::TYPE_NAME];
    assert!(definition.contains("uint16[] cells"), "{definition}");
    assert!(definition.len() <= shm_bag::definition::MAX_SOURCE_TEXT);
    assert!(bag.size() < 1 << 20, "{} bytes", bag.size());
    assert_eq!(bag.topics().unwrap().len(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}
