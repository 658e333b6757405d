//! A subscriber that answers no probe, as rmw_zenoh_cpp's do: a node's
//! publisher finds it through its graph token and tells how it receives from
//! the transport Zenoh opened to its session. Over a transport without
//! shared memory (here the peer has it off; a Zenoh 1.10 peer does the same,
//! which `tests/zenoh-lines/check.py` runs), every message written into the
//! pool is reported as copied to it, and it does get them as copies.

use std::time::{Duration, Instant};

use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::rmw::{Distro, EntityKind, NodeInfo, Qos};
use shm_runtime::testing::{free_port, peer_config};
use shm_runtime::{PayloadKind, Reach, RosNode, ShmConfig, ShmContext};
use zenoh::Wait;

const MESSAGES: usize = 5;

/// What the publisher and a plain subscriber saw.
struct Seen {
    reach: Reach,
    kinds: Vec<PayloadKind>,
    copied_to: usize,
    stats_copied: u64,
    received: usize,
    received_in_shm: usize,
}

fn run(peer_has_shm: bool) -> Seen {
    let port = free_port().unwrap();
    let mut config = peer_config(port, true).unwrap();
    config
        .insert_json5("transport/shared_memory/enabled", "true")
        .unwrap();
    let ours = zenoh::open(config).wait().unwrap();
    let mut config = peer_config(port, false).unwrap();
    config
        .insert_json5("transport/shared_memory/enabled", &peer_has_shm.to_string())
        .unwrap();
    let peer = zenoh::open(config).wait().unwrap();

    let shm = ShmContext::new(ShmConfig::enabled().pool_size(1 << 20)).unwrap();
    let node = RosNode::builder(&ours, "camera").shm(&shm).wait().unwrap();
    let publisher = node
        .declare_publisher::<UInt8MultiArray>("blobs")
        .wait()
        .unwrap();

    // The peer: a plain Zenoh subscriber with the token rmw_zenoh_cpp
    // declares for it, and no probe responder.
    let subscriber = peer
        .declare_subscriber(publisher.key_expr().to_owned())
        .wait()
        .unwrap();
    let token = NodeInfo {
        domain_id: 0,
        zid: peer.zid().to_string(),
        node_id: 0,
        enclave: "/".into(),
        namespace: "/".into(),
        name: "listener".into(),
        distro: Distro::Kilted,
    }
    .topic_token::<UInt8MultiArray>(1, EntityKind::Subscriber, "/blobs", &Qos::default());
    let _token = peer.liveliness().declare_token(token).wait().unwrap();

    let deadline = Instant::now() + Duration::from_secs(10);
    let reach = loop {
        let receivers = publisher.receivers();
        if let Some(r) = receivers.iter().find(|r| r.session == peer.zid()) {
            if r.reach != Reach::Checking && publisher.has_subscribers() {
                break r.reach;
            }
        }
        assert!(
            Instant::now() < deadline,
            "the peer's subscriber never showed: {receivers:?}"
        );
        std::thread::sleep(Duration::from_millis(10));
    };

    let mut kinds = Vec::new();
    let mut copied_to = 0;
    for i in 0..MESSAGES {
        let msg = UInt8MultiArray {
            data: vec![i as u8; 64 * 1024],
            ..Default::default()
        };
        let outcome = publisher.publish(&msg).wait().unwrap();
        kinds.push(outcome.kind);
        copied_to += outcome.copied_to;
    }
    let (mut received, mut received_in_shm) = (0, 0);
    while received < MESSAGES {
        let Ok(Some(sample)) = subscriber.recv_timeout(Duration::from_secs(10)) else {
            break;
        };
        received += 1;
        received_in_shm += usize::from(sample.payload().as_shm().is_some());
    }
    Seen {
        reach,
        kinds,
        copied_to,
        stats_copied: shm.stats().copied,
        received,
        received_in_shm,
    }
}

#[test]
fn a_subscriber_over_a_link_without_shared_memory_is_reported_as_getting_copies() {
    shm_runtime::init_logging();
    let seen = run(false);
    assert_eq!(seen.reach, Reach::Bytes);
    assert_eq!(seen.kinds, vec![PayloadKind::Shm; MESSAGES]);
    assert_eq!(seen.copied_to, MESSAGES);
    assert_eq!(seen.stats_copied, MESSAGES as u64);
    assert_eq!(seen.received, MESSAGES);
    assert_eq!(seen.received_in_shm, 0);
}

#[test]
fn a_subscriber_over_a_link_with_shared_memory_gets_the_pool_in_place() {
    shm_runtime::init_logging();
    let seen = run(true);
    assert_eq!(seen.reach, Reach::SharedMemoryUnprobed);
    assert_eq!(seen.kinds, vec![PayloadKind::Shm; MESSAGES]);
    assert_eq!(seen.copied_to, 0);
    assert_eq!(seen.stats_copied, 0);
    assert_eq!(seen.received, MESSAGES);
    assert_eq!(seen.received_in_shm, MESSAGES);
}
