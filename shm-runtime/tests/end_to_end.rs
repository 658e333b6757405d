//! End to end over TCP loopback between two peer sessions in one process: where
//! the bytes go (shared memory or heap), that they are exactly `to_vec`'s, that a
//! spliced shared-memory field is never copied, that a full pool loses nothing,
//! and that rmw_zenoh's key expressions and attachments are on the wire.

use std::time::Duration;

use shm_cdr::msgs::sensor_msgs::{Image, ImageRef, PointCloud2, PointCloud2Ref, PointField};
use shm_cdr::msgs::std_msgs::{self, Header};
use shm_cdr::RosMessage;
use shm_runtime::rmw::{topic_key_expr, Gid};
use shm_runtime::ShmOptions;
use shm_runtime::{PayloadKind, RosNode, SessionExt, ShmBytes, ShmConfig, ShmContext};
use zenoh::shm::ShmBufUnsafeMut;
use zenoh::{Session, Wait};

mod common;
use common::{free_port, peer_config, without_implicit_shm_copy};

const TIMEOUT: Duration = Duration::from_secs(10);

/// Two peer sessions connected over TCP on loopback, no multicast scouting.
fn session_pair() -> (Session, Session) {
    session_pair_with(|config| config)
}

/// [`session_pair`] with `adjust` applied to both configurations.
fn session_pair_with(adjust: impl Fn(zenoh::Config) -> zenoh::Config) -> (Session, Session) {
    let port = free_port();
    let clients = common::shm_clients();
    let a = common::open_with(adjust(peer_config(port, true)), &clients)
        .wait()
        .unwrap();
    let b = common::open_with(adjust(peer_config(port, false)), &clients)
        .wait()
        .unwrap();
    (a, b)
}

fn header() -> Header {
    Header {
        stamp: shm_cdr::msgs::builtin_interfaces::Time { sec: 7, nanosec: 8 },
        frame_id: "camera".into(),
    }
}

fn image(bytes: usize) -> Image {
    Image {
        header: header(),
        height: 1,
        width: bytes as u32 / 3,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: bytes as u32,
        data: (0..bytes).map(|i| (i % 253) as u8).collect(),
    }
}

#[test]
fn above_threshold_is_shared_memory_below_is_heap_and_bytes_are_exact() {
    let _shm = common::shm_serial();
    let (a, b) = session_pair();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(4096)).unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("e2e/image")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<Image>("e2e/image")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    for (size, expected) in [
        (100_000, PayloadKind::Shm),
        (300, PayloadKind::Heap),
        (4200, PayloadKind::Shm),
    ] {
        let msg = image(size);
        let outcome = publisher.publish(&msg).wait().unwrap();
        assert_eq!(outcome.kind, expected, "{size}-byte image");
        assert_eq!(outcome.size, shm_cdr::encoded_size(&msg));

        let sample = subscriber
            .recv_timeout(TIMEOUT)
            .unwrap()
            .expect("message lost");
        assert_eq!(
            sample.is_shm(),
            expected == PayloadKind::Shm,
            "{size}-byte image"
        );
        assert_eq!(
            &*sample.payload().to_bytes(),
            shm_cdr::to_vec(&msg).unwrap().as_slice()
        );
        let owned: Image = sample.decode().unwrap();
        assert_eq!(owned, msg);
        // Decoding over an image held from before (larger and smaller fields).
        let mut reused = image(size / 2 + 7);
        reused.encoding = "bayer_rggb16".into();
        sample.decode_into(&mut reused).unwrap();
        assert_eq!(reused, msg);
        let view: ImageRef = sample.decode().unwrap();
        assert_eq!(view.data, msg.data.as_slice());
        if sample.is_shm() {
            // Borrowed straight from the shared-memory buffer.
            let payload = sample.payload().slices().next().unwrap().as_ptr_range();
            assert!(payload.contains(&view.data.as_ptr()));
            // One contiguous chunk whose CDR body (after the 4-byte header) is
            // 8-aligned in the reader's mapping too: `f64`s are naturally aligned.
            assert_eq!(sample.payload().slices().count(), 1);
            assert_eq!(payload.start as usize % 8, 4, "{size}-byte image");
        }
    }
    assert_eq!(shm.stats().shm, 2);
    assert_eq!(shm.stats().heap, 1);
    assert_eq!(shm.stats().fallbacks, 0);
}

#[test]
fn without_shm_and_threshold_override() {
    let _shm = common::shm_serial();
    // Zenoh's implicit copy would move our heap payloads into its own SHM once
    // its lazily created pool is ready (seen under load); this test is about
    // what *our* publisher sends.
    let (a, b) = session_pair_with(without_implicit_shm_copy);
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let off = a
        .declare_ros_publisher::<Image>("e2e/off")
        .shm(&shm)
        .without_shm()
        .wait()
        .unwrap();
    let high = a
        .declare_ros_publisher::<Image>("e2e/high")
        .shm(&shm)
        .shm_threshold(1 << 20)
        .wait()
        .unwrap();
    let sub_off = b.declare_ros_subscriber::<Image>("e2e/off").wait().unwrap();
    let sub_high = b
        .declare_ros_subscriber::<Image>("e2e/high")
        .wait()
        .unwrap();
    assert!(off.wait_for_subscribers(TIMEOUT) && high.wait_for_subscribers(TIMEOUT));
    let msg = image(64 * 1024);
    assert_eq!(off.publish(&msg).wait().unwrap().kind, PayloadKind::Heap);
    assert_eq!(high.publish(&msg).wait().unwrap().kind, PayloadKind::Heap);
    for sub in [&sub_off, &sub_high] {
        let sample = sub.recv_timeout(TIMEOUT).unwrap().expect("message lost");
        assert!(!sample.is_shm());
        assert_eq!(sample.decode::<Image>().unwrap(), msg);
    }
}

/// Outcomes say what went out: a session with SHM transport off publishes from
/// the heap (not "Shm" while the receiver gets a copy), and a message larger
/// than the whole pool is `TooLargeForPool`, counted apart from fallbacks.
#[test]
fn outcomes_report_what_actually_went_out() {
    let _shm = common::shm_serial();
    let (a, b) = session_pair_with(|config| {
        let mut config = without_implicit_shm_copy(config);
        config
            .insert_json5("transport/shared_memory/enabled", "false")
            .unwrap();
        config
    });
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("e2e/session_off")
        .shm(&shm)
        .wait()
        .unwrap();
    assert!(publisher.shm_context().is_none());
    let subscriber = b
        .declare_ros_subscriber::<Image>("e2e/session_off")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    let msg = image(64 * 1024);
    assert_eq!(
        publisher.publish(&msg).wait().unwrap().kind,
        PayloadKind::Heap
    );
    let sample = subscriber.recv_timeout(TIMEOUT).unwrap().expect("lost");
    assert!(!sample.is_shm());
    assert_eq!(sample.decode::<Image>().unwrap(), msg);

    let (a, b) = session_pair_with(without_implicit_shm_copy);
    let small = ShmContext::new(ShmConfig::enabled().pool_size(64 * 1024)).unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("e2e/too_large")
        .shm(&small)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<Image>("e2e/too_large")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    for _ in 0..3 {
        let outcome = publisher.publish(&image(100 * 1024)).wait().unwrap();
        assert_eq!(outcome.kind, PayloadKind::TooLargeForPool);
        let sample = subscriber.recv_timeout(TIMEOUT).unwrap().expect("lost");
        assert_eq!(sample.decode::<Image>().unwrap(), image(100 * 1024));
    }
    let stats = small.stats();
    assert_eq!((stats.too_large, stats.fallbacks, stats.shm), (3, 0, 0));
}

/// `Time` and `Duration` have the same layout: a `Time` subscriber on a raw key
/// must not decode `Duration` samples as garbage. Our samples name their type
/// in the encoding, and the subscriber drops (and counts) the wrong one.
#[test]
fn a_subscriber_drops_samples_of_another_type_and_says_which() {
    use shm_cdr::msgs::builtin_interfaces::{Duration as RosDuration, Time};
    let (a, b) = session_pair();
    let wrong = a
        .declare_ros_publisher::<RosDuration>("e2e/typed")
        .wait()
        .unwrap();
    let right = a.declare_ros_publisher::<Time>("e2e/typed").wait().unwrap();
    let subscriber = b
        .declare_ros_subscriber::<Time>("e2e/typed")
        .wait()
        .unwrap();
    assert!(wrong.wait_for_subscribers(TIMEOUT) && right.wait_for_subscribers(TIMEOUT));
    wrong
        .publish(&RosDuration { sec: 1, nanosec: 2 })
        .wait()
        .unwrap();
    right.publish(&Time { sec: 3, nanosec: 4 }).wait().unwrap();
    let sample = subscriber.recv_timeout(TIMEOUT).unwrap().expect("lost");
    assert_eq!(
        sample.decode::<Time>().unwrap(),
        Time { sec: 3, nanosec: 4 }
    );
    assert_eq!(
        sample.message_type(),
        Some((Time::TYPE_NAME.to_owned(), Time::type_hash().to_owned()))
    );
    assert_eq!(subscriber.wrong_type(), 1);
    assert!(subscriber.try_recv().unwrap().is_none());
}

/// Names resolve as rcl resolves them (relative to the namespace, `~` to the
/// node), and names ROS 2 refuses are refused with the rule they break, before
/// Zenoh sees them.
#[test]
fn node_names_resolve_and_bad_names_are_refused() {
    use shm_cdr::msgs::std_msgs::String as StringMsg;
    let (a, b) = session_pair();
    let node = RosNode::builder(&a, "talker")
        .namespace("/demo")
        .domain_id(0)
        .wait()
        .unwrap();
    let relative = node.declare_publisher::<StringMsg>("rel").wait().unwrap();
    assert!(relative
        .key_expr()
        .starts_with("0/demo/rel/std_msgs::msg::dds_::String_/"));
    assert!(relative.liveliness_token().unwrap().contains("/%demo%rel/"));
    let private = node
        .declare_publisher::<StringMsg>("~/private")
        .wait()
        .unwrap();
    assert!(private.key_expr().starts_with("0/demo/talker/private/"));

    // The same topic by its absolute name, from another node: they match.
    let listener = RosNode::builder(&b, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let subscriber = listener
        .declare_subscriber::<StringMsg>("/demo/rel")
        .wait()
        .unwrap();
    assert!(relative.wait_for_subscribers(TIMEOUT));
    relative
        .publish(&StringMsg { data: "hi".into() })
        .wait()
        .unwrap();
    let got: StringMsg = subscriber.recv_message().unwrap();
    assert_eq!(got.data, "hi");

    let err = node
        .declare_publisher::<StringMsg>("a*b")
        .wait()
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().contains("'*' is not allowed"), "{err}");
    let err = node
        .declare_subscriber::<StringMsg>("a//b")
        .wait()
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().contains("empty part"), "{err}");
    for bad in ["", "a b"] {
        let err = RosNode::builder(&a, bad).wait().map(|_| ()).unwrap_err();
        assert!(err.to_string().starts_with("invalid node name"), "{err}");
    }
    let err = RosNode::builder(&a, "ok")
        .namespace("/x/")
        .wait()
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().starts_with("invalid namespace"), "{err}");
}

/// Remapping rules from a launch-style command line rename the node, move it
/// and rename its topics, services and actions, as rcl does; a bad rule is
/// refused when the node is declared.
#[test]
fn remapping_rules_from_ros_args_apply_like_rcl() {
    use shm_cdr::msgs::std_msgs::String as StringMsg;
    use shm_cdr::msgs::std_srvs::srv::Trigger;
    use shm_cdr::msgs::test_msgs::action::Fibonacci;
    let (a, _b) = session_pair();
    let args = [
        "my_node",
        "--ros-args",
        "-r",
        "__node:=renamed",
        "-r",
        "__ns:=/robot1",
        "-r",
        "chatter:=talk",
        "-r",
        "other:chatter:=never",
        "-r",
        "rosservice://reset:=~/reset_now",
        "-r",
        "fib:=/shared/fibonacci",
        "-p",
        "rate:=10",
        "--",
    ];
    let node = RosNode::builder(&a, "talker")
        .namespace("/ignored")
        .domain_id(0)
        .ros_args(args)
        .wait()
        .unwrap();
    assert_eq!(
        (node.info().name.as_str(), node.info().namespace.as_str()),
        ("renamed", "/robot1")
    );
    let publisher = node
        .declare_publisher::<StringMsg>("chatter")
        .wait()
        .unwrap();
    assert!(
        publisher.key_expr().starts_with("0/robot1/talk/"),
        "{}",
        publisher.key_expr()
    );
    assert!(publisher
        .liveliness_token()
        .unwrap()
        .contains("/%robot1/renamed/%robot1%talk/"));
    // A `rosservice://` rule leaves topics of that name alone.
    let topic = node.declare_publisher::<StringMsg>("reset").wait().unwrap();
    assert!(topic.key_expr().starts_with("0/robot1/reset/"));
    let server = node.declare_service::<Trigger>("reset").wait().unwrap();
    assert!(
        server.key_expr().starts_with("0/robot1/renamed/reset_now/"),
        "{}",
        server.key_expr()
    );
    assert_eq!(
        node.resolve_service_name("reset").unwrap(),
        "/robot1/renamed/reset_now"
    );
    let action = node
        .declare_action_server::<Fibonacci>("fib")
        .wait()
        .unwrap();
    assert_eq!(action.name(), "/shared/fibonacci");

    let err = RosNode::builder(&a, "talker")
        .remap("chatter:=a*b")
        .wait()
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().contains("invalid remapping rule"), "{err}");
    let err = RosNode::builder(&a, "talker")
        .ros_args(["--ros-args", "--unknown"])
        .wait()
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().contains("unknown"), "{err}");
}

/// A node subscriber waits for publishers of its topic and type on the ROS
/// graph, as a publisher waits for subscribers.
#[test]
fn a_subscriber_waits_for_its_publishers() {
    use shm_cdr::msgs::std_msgs::String as StringMsg;
    let (a, b) = session_pair();
    let listener = RosNode::builder(&a, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let subscriber = listener
        .declare_subscriber::<StringMsg>("/waited")
        .wait()
        .unwrap();
    assert!(!subscriber.wait_for_publishers(Duration::from_millis(200)));
    let talker = RosNode::builder(&b, "talker").domain_id(0).wait().unwrap();
    // Another type on the same topic does not match.
    let _other = talker
        .declare_publisher::<Header>("/waited")
        .wait()
        .unwrap();
    assert!(!subscriber.wait_for_publishers(Duration::from_millis(300)));
    std::thread::scope(|scope| {
        let waiting = scope.spawn(|| subscriber.wait_for_publishers(TIMEOUT));
        std::thread::sleep(Duration::from_millis(100));
        let publisher = talker
            .declare_publisher::<StringMsg>("waited")
            .wait()
            .unwrap();
        assert!(waiting.join().unwrap());
        drop(publisher);
    });
    let raw = a
        .declare_ros_subscriber::<StringMsg>("raw/key")
        .wait()
        .unwrap();
    assert!(!raw.wait_for_publishers(Duration::from_millis(10)));
}

fn cloud_with(data: ShmBytes, points: u32) -> shm_runtime::msgs::sensor_msgs::PointCloud2Shm {
    shm_runtime::msgs::sensor_msgs::PointCloud2Shm {
        header: header(),
        height: 1,
        width: points,
        fields: vec![PointField {
            name: "xyzi".into(),
            offset: 0,
            datatype: PointField::FLOAT32,
            count: 4,
        }],
        is_bigendian: false,
        point_step: 16,
        row_step: 16 * points,
        data,
        is_dense: true,
    }
}

#[test]
fn user_managed_shared_memory_field_is_spliced_without_a_copy() {
    let _shm = common::shm_serial();
    let (a, b) = session_pair();
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let publisher = a
        .declare_ros_publisher::<shm_runtime::msgs::sensor_msgs::PointCloud2Shm>("e2e/cloud")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<PointCloud2>("e2e/cloud")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    // The application writes its points straight into shared memory.
    let points = 65_537u32; // an odd size, so later fields are realigned
    let mut block = shm.alloc(points as usize * 16).unwrap();
    for (i, b) in block.iter_mut().enumerate() {
        *b = (i % 241) as u8;
    }
    let block: zenoh::shm::ZShm = block.into();
    let mut writer_view = block.clone(); // the publisher keeps a handle on the block
    let msg = cloud_with(ShmBytes::from(block), points);

    // A plain Vec encoding copies the bytes, and is what the wire must carry.
    let expected = shm_cdr::to_vec(&msg).unwrap();
    let outcome = publisher.publish(&msg).wait().unwrap();
    assert_eq!(outcome.kind, PayloadKind::Spliced);
    assert_eq!(outcome.size, expected.len());

    let sample = subscriber
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("message lost");
    assert_eq!(
        sample.fragments(),
        3,
        "metadata, the shared block, metadata"
    );
    // In shared memory: the block, not the metadata around it.
    assert!(sample.is_shm());
    assert_eq!(sample.shm_len(), points as usize * 16);
    assert_eq!(&*sample.payload().to_bytes(), expected.as_slice());
    let view: PointCloud2Ref = sample.decode().unwrap();
    assert_eq!(view.width, points);
    assert_eq!(view.data, &writer_view[..]);
    assert!(
        view.is_dense,
        "fields after the splice decode at the right alignment"
    );
    let block_slice = sample.payload().slices().nth(1).unwrap();
    assert_eq!(
        view.data.as_ptr_range(),
        block_slice.as_ptr_range(),
        "borrowed, not copied"
    );

    // Proof that the received bytes are the publisher's memory, not a copy: write
    // through the publisher's handle and read the change at the subscriber.
    // SAFETY: both handles are in this thread; nothing reads the block while we
    // write, and no other process maps it.
    unsafe { writer_view.as_mut_unchecked()[0] = 0xEE };
    assert_eq!(
        view.data[0], 0xEE,
        "the subscriber sees the publisher's write"
    );

    // The owned decode copies the (now modified) block out.
    let owned: PointCloud2 = sample.decode().unwrap();
    assert_eq!(owned.data, writer_view.to_vec());
    assert_eq!(owned.row_step, 16 * points);
    assert!(owned.is_dense);
    // Into a cloud held from before, across the three fragments.
    let mut reused = PointCloud2 {
        fields: vec![PointField::default(); 7],
        data: vec![1; 5],
        ..Default::default()
    };
    sample.decode_into(&mut reused).unwrap();
    assert_eq!(reused, owned);
}

#[test]
fn tiny_pool_under_a_burst_loses_nothing_and_counts_fallbacks() {
    let _shm = common::shm_serial();
    let (a, b) = session_pair();
    // 256 KiB pool, 64 KiB messages, 4 publishing threads × 25 messages.
    let shm = ShmContext::new(
        ShmConfig::enabled()
            .pool_size(256 * 1024)
            .alloc_timeout(Duration::from_micros(200)),
    )
    .unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("e2e/burst")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<Image>("e2e/burst")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    let per_thread = 25;
    std::thread::scope(|s| {
        for t in 0..4u32 {
            let publisher = &publisher;
            s.spawn(move || {
                for i in 0..per_thread {
                    let mut msg = image(64 * 1024);
                    msg.header.stamp.sec = t as i32;
                    msg.header.stamp.nanosec = i;
                    publisher.publish(&msg).wait().unwrap();
                }
            });
        }
    });
    let mut seen = std::collections::HashSet::new();
    while seen.len() < 4 * per_thread as usize {
        let sample = subscriber
            .recv_timeout(TIMEOUT)
            .unwrap()
            .expect("a message was lost");
        let msg: Image = sample.decode().unwrap();
        assert_eq!(msg.data, image(64 * 1024).data, "payload intact");
        assert!(
            seen.insert((msg.header.stamp.sec, msg.header.stamp.nanosec)),
            "duplicate"
        );
    }
    let stats = shm.stats();
    assert_eq!(stats.shm + stats.fallbacks, 100);
    assert!(
        stats.fallbacks > 0,
        "the burst must overflow a 256 KiB pool: {stats:?}"
    );
    println!("burst: {stats:?}");

    // Every sample is dropped now: garbage collection gives the pool back.
    for _ in 0..10 {
        let msg = image(64 * 1024);
        assert_eq!(
            publisher.publish(&msg).wait().unwrap().kind,
            PayloadKind::Shm
        );
        let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
        assert!(sample.is_shm());
    }
}

#[test]
fn rmw_zenoh_key_expression_attachment_and_liveliness() {
    let (a, b) = session_pair();
    let node = RosNode::builder(&a, "talker").domain_id(0).wait().unwrap();
    let publisher = node
        .declare_publisher::<std_msgs::String>("/chatter")
        .wait()
        .unwrap();
    assert_eq!(
        publisher.key_expr(),
        "0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    );
    assert_eq!(
        publisher.key_expr(),
        topic_key_expr::<std_msgs::String>(node.info().distro, 0, "/chatter")
    );
    let token = publisher.liveliness_token().unwrap().to_owned();
    assert!(
        token.starts_with(&format!("@ros2_lv/0/{}/", a.zid())),
        "{token}"
    );
    assert!(
        token.contains("/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_"),
        "{token}"
    );
    assert_eq!(publisher.gid(), Some(Gid::from_token(&token)));

    // A node subscriber on the other session announces itself with an `MS` token.
    let listener = RosNode::builder(&b, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let _node_subscriber = listener
        .declare_subscriber::<std_msgs::String>("/chatter")
        .wait()
        .unwrap();

    // A raw subscriber on the other session sees the key and the attachment.
    let subscriber = b
        .declare_ros_subscriber::<std_msgs::String>("0/chatter/**")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    for seq in 1..=3 {
        let msg = std_msgs::String {
            data: format!("hello {seq}"),
        };
        assert_eq!(
            publisher.publish(&msg).wait().unwrap().sequence_number,
            Some(seq)
        );
        let sample = subscriber
            .recv_timeout(TIMEOUT)
            .unwrap()
            .expect("message lost");
        assert_eq!(sample.key_expr(), publisher.key_expr());
        let attachment = sample.attachment().unwrap().unwrap();
        assert_eq!(attachment.sequence_number, seq);
        assert_eq!(Some(attachment.gid), publisher.gid());
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos() as i64;
        assert!((now - attachment.source_timestamp).abs() < 60_000_000_000);
        assert_eq!(sample.decode::<std_msgs::String>().unwrap(), msg);
    }

    // The liveliness tokens are visible to the other session, as rmw_zenoh's graph
    // cache would see them.
    let replies = b.liveliness().get("@ros2_lv/0/**").wait().unwrap();
    let mut keys = Vec::new();
    while let Ok(reply) = replies.recv_timeout(Duration::from_secs(2)) {
        match reply {
            Some(reply) => keys.push(reply.result().unwrap().key_expr().to_string()),
            None => break,
        }
    }
    assert!(keys.contains(&token), "{keys:?}");
    assert!(keys.contains(&node.info().node_token()), "{keys:?}");
    let ms = "/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/RIHS01_";
    assert!(keys.iter().any(|k| k.contains(ms)), "{keys:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn async_publish_and_receive() {
    let _shm = common::shm_serial();
    let (a, b) = session_pair();
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("e2e/async")
        .shm(&shm)
        .await
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<Image>("e2e/async")
        .await
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    let msg = image(32 * 1024);
    assert_eq!(
        publisher.publish(&msg).await.unwrap().kind,
        PayloadKind::Shm
    );
    let sample = tokio::time::timeout(TIMEOUT, subscriber.recv_async())
        .await
        .expect("message lost")
        .unwrap();
    assert!(sample.is_shm());
    assert_eq!(sample.decode::<Image>().unwrap(), msg);
    assert_eq!(Image::TYPE_NAME, "sensor_msgs/msg/Image");
}

/// The next item of a stream (no futures-util needed).
async fn next<S: futures_core::Stream + Unpin>(stream: &mut S) -> Option<S::Item> {
    std::future::poll_fn(|cx| std::pin::Pin::new(&mut *stream).poll_next(cx)).await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn streams_of_samples_and_messages_with_async_matching() {
    let _shm = common::shm_serial();
    let (a, b) = session_pair();
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("e2e/stream")
        .shm(&shm)
        .await
        .unwrap();
    assert!(!publisher.has_subscribers());
    let subscriber = b
        .declare_ros_subscriber::<Image>("e2e/stream")
        .await
        .unwrap();
    tokio::time::timeout(TIMEOUT, publisher.subscribers_matched())
        .await
        .expect("no match")
        .unwrap();
    // Resolves at once when already matched.
    tokio::time::timeout(Duration::from_millis(500), publisher.subscribers_matched())
        .await
        .expect("already matched")
        .unwrap();

    // A receive cancelled before anything arrived loses nothing.
    assert!(
        tokio::time::timeout(Duration::from_millis(50), subscriber.recv_async())
            .await
            .is_err()
    );
    for i in 0..6 {
        publisher.publish(&image(32 * 1024 + i)).await.unwrap();
    }
    let mut samples = subscriber.stream();
    for i in 0..3 {
        let sample = tokio::time::timeout(TIMEOUT, next(&mut samples))
            .await
            .expect("message lost")
            .expect("stream ended");
        // Borrow within the item's lifetime.
        let view: ImageRef = sample.decode().unwrap();
        assert_eq!(view.data.len(), 32 * 1024 + i);
        assert!(sample.is_shm());
    }
    drop(samples);
    let mut messages = subscriber.messages();
    for i in 3..6 {
        let msg = tokio::time::timeout(TIMEOUT, next(&mut messages))
            .await
            .expect("message lost")
            .expect("stream ended")
            .unwrap();
        assert_eq!(msg, image(32 * 1024 + i));
    }
    assert_eq!(subscriber.queued(), 0);
}

#[test]
fn callback_subscriber_decodes_borrowed_inside_the_callback() {
    let _shm = common::shm_serial();
    let (a, b) = session_pair();
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("e2e/callback")
        .shm(&shm)
        .wait()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let _subscriber = b
        .declare_ros_subscriber::<Image>("e2e/callback")
        .callback(move |sample| {
            // Borrow from the sample inside the callback: no copy of the pixels.
            let view: ImageRef = sample.decode().unwrap();
            let first = sample.payload().slices().next().unwrap().as_ptr_range();
            let _ = tx.send((
                view.data.len(),
                first.contains(&view.data.as_ptr()),
                sample.is_shm(),
            ));
        })
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    let msg = image(128 * 1024);
    publisher.publish(&msg).wait().unwrap();
    let (len, borrowed, shm_seen) = rx.recv_timeout(TIMEOUT).unwrap();
    assert_eq!(len, msg.data.len());
    assert!(borrowed && shm_seen);
}

/// Zenoh's lowlatency transport cannot fragment. What would travel inline above
/// one batch is refused with `Unfragmentable` (nothing sent, no sequence number
/// taken), by `publish` and by a loan's `publish`; shared memory goes through at
/// any size, and so do small heap messages. Last, the failure the guard
/// prevents: a plain Zenoh put of the same size returns `Ok` and never arrives.
#[test]
fn lowlatency_refuses_inline_messages_it_cannot_carry() {
    let _shm = common::shm_serial();
    use shm_cdr::loan::InPlace;
    use shm_runtime::{PublishError, Unfragmentable};
    let (a, b) = session_pair_with(common::lowlatency);
    let shm = ShmContext::new(ShmConfig::enabled().pool_size(2 << 20)).unwrap();
    let node = RosNode::builder(&a, "lowlatency")
        .domain_id(0)
        .wait()
        .unwrap();
    let heap = node
        .declare_publisher::<Image>("heap")
        .without_shm()
        .wait()
        .unwrap();
    let in_shm = a
        .declare_ros_publisher::<Image>("lowlatency/shm")
        .shm(&shm)
        .wait()
        .unwrap();
    let heap_sub = RosNode::builder(&b, "reader")
        .domain_id(0)
        .wait()
        .unwrap()
        .declare_subscriber::<Image>("heap")
        .wait()
        .unwrap();
    let shm_sub = b
        .declare_ros_subscriber::<Image>("lowlatency/shm")
        .wait()
        .unwrap();
    assert!(heap.wait_for_subscribers(TIMEOUT) && in_shm.wait_for_subscribers(TIMEOUT));

    let big = image(100 * 1024);
    let size = shm_cdr::encoded_size(&big);
    match heap.publish(&big).wait() {
        Err(PublishError::Unfragmentable(Unfragmentable { inline, limit })) => {
            assert_eq!(inline, size);
            assert!((60_000..65_535).contains(&limit), "limit {limit}");
            let text = PublishError::Unfragmentable(Unfragmentable { inline, limit }).to_string();
            assert!(
                text.contains("lowlatency") && text.contains(&size.to_string()),
                "{text}"
            );
        }
        other => panic!("a 100 KiB heap message under lowlatency: {other:?}"),
    }
    let mut loan = heap.loan(big.lens()).unwrap();
    assert_eq!(loan.kind(), PayloadKind::Heap);
    big.write_in_place(loan.fields().unwrap()).unwrap();
    assert!(matches!(
        loan.publish().wait(),
        Err(PublishError::Unfragmentable(_))
    ));

    // The refused messages took no sequence number: the first one sent is 1.
    let small = image(1024);
    assert_eq!(
        heap.publish(&small).wait().unwrap().sequence_number,
        Some(1)
    );
    let sample = heap_sub
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("small message lost");
    assert_eq!(sample.decode::<Image>().unwrap(), small);
    assert_eq!(
        sample
            .attachment()
            .and_then(Result::ok)
            .map(|a| a.sequence_number),
        Some(1)
    );

    let huge = image(1 << 20);
    assert_eq!(in_shm.publish(&huge).wait().unwrap().kind, PayloadKind::Shm);
    let sample = shm_sub
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("SHM message lost");
    assert!(sample.is_shm());
    assert_eq!(sample.decode::<Image>().unwrap(), huge);

    // Without the guard: Zenoh accepts the put and the message never arrives.
    let raw = b.declare_subscriber("lowlatency/raw").wait().unwrap();
    let put = a.declare_publisher("lowlatency/raw").wait().unwrap();
    assert!(common::raw_publisher_matched(&put, TIMEOUT));
    put.put(vec![7u8; size]).wait().unwrap();
    assert!(
        raw.recv_timeout(Duration::from_secs(2)).unwrap().is_none(),
        "Zenoh's lowlatency transport carried a {size}-byte inline message: the guard may be relaxed"
    );
}

/// A type whose name is too long for Zenoh's encoding schema (255 bytes with
/// its hash: more than 183 characters) travels without it: Zenoh panicked on
/// the first publish of such a message, taking the process down.
#[test]
fn a_type_name_too_long_for_zenohs_encoding_schema_is_published_and_received() {
    #[derive(shm_cdr::RosMessage, Debug, PartialEq)]
    #[ros(
        type_name = "a_package_with_a_rather_long_name_for_its_interfaces/msg/AMessageTypeWhoseNameGoesOnAndOnToMakeTheEncodingSchemaLongerThanZenohCanCarryInOneByteOfLengthWhichIsTwoHundredAndFiftyFiveBytes"
    )]
    struct Long {
        value: u32,
    }
    assert!(<Long as shm_cdr::RosMessage>::TYPE_NAME.len() > 183);
    let (a, b) = session_pair();
    let node = RosNode::builder(&a, "long").domain_id(0).wait().unwrap();
    let publisher = node.declare_publisher::<Long>("long").wait().unwrap();
    let subscriber = RosNode::builder(&b, "reader")
        .domain_id(0)
        .wait()
        .unwrap()
        .declare_subscriber::<Long>("long")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    publisher.publish(&Long { value: 7 }).wait().unwrap();
    let sample = subscriber
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("message lost");
    assert_eq!(sample.decode::<Long>().unwrap(), Long { value: 7 });
}

/// A node's samples carry what rmw_zenoh_cpp's carry and no more: the rmw
/// attachment (sequence number, time, GID), no `SourceInfo`, no encoding
/// schema (the key names the type). Gaps are still counted, from the
/// attachment's sequence numbers.
#[test]
fn a_node_s_samples_carry_the_rmw_attachment_alone_and_gaps_still_count() {
    use shm_cdr::msgs::builtin_interfaces::Time;
    use shm_runtime::rmw::Attachment;
    let (a, b) = session_pair();
    let talker = RosNode::builder(&a, "talker").domain_id(0).wait().unwrap();
    let listener = RosNode::builder(&b, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let publisher = talker.declare_publisher::<Time>("stamps").wait().unwrap();
    let raw = b
        .declare_subscriber(publisher.key_expr().to_owned())
        .wait()
        .unwrap();
    let subscriber = listener
        .declare_subscriber::<Time>("stamps")
        .history(shm_runtime::History::KeepAll)
        .wait()
        .unwrap();
    let (inline_tx, inline_rx) = std::sync::mpsc::channel();
    let inline = listener
        .declare_subscriber::<Time>("stamps")
        .callback_inline(move |s| {
            let _ = inline_tx.send(s.decode::<Time>().map(|t| t.sec));
        })
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    std::thread::sleep(Duration::from_millis(200));
    for sec in 1..=3 {
        publisher.publish(&Time { sec, nanosec: 0 }).wait().unwrap();
    }
    let gid = publisher.gid().unwrap();
    for expected in 1..=3 {
        let sample = raw.recv_timeout(TIMEOUT).unwrap().expect("lost");
        assert!(sample.source_info().is_none(), "no SourceInfo");
        assert!(sample.encoding().schema().is_none(), "no schema");
        let attachment = Attachment::parse(&sample.attachment().unwrap().to_bytes()).unwrap();
        assert_eq!(attachment.sequence_number, expected);
        assert_eq!(attachment.gid, gid);
    }
    for _ in 1..=3 {
        let sample = subscriber.recv_timeout(TIMEOUT).unwrap().expect("lost");
        assert_eq!(sample.message_type(), None);
    }
    // Message 4 of that publisher never arrives; 5 does.
    let forged = Attachment {
        sequence_number: 5,
        source_timestamp: 0,
        gid,
    };
    a.put(
        publisher.key_expr().to_owned(),
        shm_cdr::to_vec(&Time { sec: 5, nanosec: 0 }).unwrap(),
    )
    .attachment(forged.to_bytes().to_vec())
    .wait()
    .unwrap();
    let fifth = subscriber.recv_timeout(TIMEOUT).unwrap().expect("lost");
    assert_eq!(fifth.decode::<Time>().unwrap().sec, 5);
    assert_eq!(subscriber.missed(), 1);
    assert_eq!(subscriber.lost(), 0);
    // An inline callback counts the same gap.
    let inline_secs: Vec<i32> = (0..4)
        .map(|_| inline_rx.recv_timeout(TIMEOUT).unwrap().unwrap())
        .collect();
    assert_eq!(inline_secs, [1, 2, 3, 5]);
    assert_eq!(inline.missed(), 1);
    assert_eq!(inline.lost(), 0);
}
