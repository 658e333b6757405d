//! A node speaks the conventions and interfaces of the distribution it is
//! told: Humble's keys and tokens without type hashes and its node without
//! the services Humble does not have; Lyrical's `TransitionEvent`. (The same
//! is compared with models of each release's rmw_zenoh_cpp and with rosbags'
//! per-distribution type stores in `tests/ros2/distros.py`.)

mod common;

use std::time::Duration;

use common::loopback_sessions;
use shm_cdr::distro_msgs::lyrical::lifecycle_msgs::msg::TransitionEvent as StampedTransitionEvent;
use shm_cdr::msgs::lifecycle_msgs::msg::{
    State as StateMsg, Transition as TransitionMsg, TransitionEvent,
};
use shm_cdr::msgs::lifecycle_msgs::srv::{ChangeState, ChangeState_Request};
use shm_cdr::msgs::std_msgs::String as Text;
use shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Request, Trigger_Response};
use shm_cdr::RosMessage;
use shm_runtime::lifecycle::{Managed, State};
use shm_runtime::rmw::{topic_key_expr, Distro, TYPE_HASH_NOT_SUPPORTED};
use shm_runtime::RosNode;
use zenoh::{Session, Wait};

const TIMEOUT: Duration = Duration::from_secs(10);

fn node(session: &Session, name: &str, distro: Distro) -> RosNode {
    RosNode::builder(session, name)
        .domain_id(0)
        .distro(distro)
        .wait()
        .unwrap()
}

#[test]
fn humble_nodes_talk_without_type_hashes() {
    let (a, b, _) = loopback_sessions();
    let talker = node(&a, "talker", Distro::Humble);
    let listener = node(&b, "listener", Distro::Humble);
    let kilted = node(&b, "kilted_listener", Distro::Kilted);

    let publisher = talker.declare_publisher::<Text>("/chatter").wait().unwrap();
    assert_eq!(
        publisher.key_expr(),
        "0/chatter/std_msgs::msg::dds_::String_/TypeHashNotSupported"
    );
    assert_eq!(
        publisher.key_expr(),
        topic_key_expr::<Text>(Distro::Humble, 0, "/chatter")
    );
    let token = publisher.liveliness_token().unwrap();
    assert!(
        token.contains("/%chatter/std_msgs::msg::dds_::String_/TypeHashNotSupported/::,10:,:,:,,"),
        "{token}"
    );

    let humble_sub = listener
        .declare_subscriber::<Text>("/chatter")
        .wait()
        .unwrap();
    let kilted_sub = kilted
        .declare_subscriber::<Text>("/chatter")
        .wait()
        .unwrap();
    assert!(humble_sub.wait_for_publishers(TIMEOUT) && publisher.wait_for_subscribers(TIMEOUT));
    let message = Text {
        data: "hello humble".into(),
    };
    publisher.publish(&message).wait().unwrap();
    let got = humble_sub.recv_timeout(TIMEOUT).unwrap().unwrap();
    assert_eq!(got.decode::<Text>().unwrap(), message);
    // A Kilted subscriber's key carries the hash: it is another topic to
    // Zenoh, as between rmw_zenoh_cpp on Humble and on Kilted.
    assert!(kilted_sub
        .recv_timeout(Duration::from_millis(300))
        .unwrap()
        .is_none());

    // The graph shows the Humble endpoints with Humble's hash field.
    let graph = listener.graph(TIMEOUT).unwrap();
    let publishers = graph.publishers("/chatter");
    let endpoint = publishers
        .iter()
        .find_map(|p| p.endpoint.as_ref())
        .expect("the talker's publisher is on the graph");
    assert_eq!(endpoint.type_hash, TYPE_HASH_NOT_SUPPORTED);

    // Services, and no type-description or logger services: Humble's nodes
    // have none.
    let server = talker
        .declare_service::<Trigger>("/trigger")
        .handler(|_: Trigger_Request| Trigger_Response {
            success: true,
            message: "humble".into(),
        })
        .wait()
        .unwrap();
    assert!(server.key_expr().ends_with("/TypeHashNotSupported"));
    let client = listener
        .declare_client::<Trigger>("/trigger")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let reply = client.call(&Trigger_Request).wait().unwrap();
    assert_eq!(reply.message, "humble");
    let graph = listener.graph(TIMEOUT).unwrap();
    let services = graph.services();
    assert!(
        services.contains_key("/talker/get_parameters"),
        "{services:?}"
    );
    assert!(
        !services.contains_key("/talker/get_type_description"),
        "{services:?}"
    );
    assert!(!services.contains_key("/talker/get_logger_levels"));
}

#[derive(Default)]
struct Plain;

impl Managed for Plain {}

#[test]
fn a_lyrical_lifecycle_node_announces_transitions_with_a_stamp() {
    let (a, b, _) = loopback_sessions();
    let managed = node(&a, "lc", Distro::Lyrical);
    let lifecycle = managed.lifecycle(Plain).unwrap();
    let observer = node(&b, "observer", Distro::Lyrical);
    let events = observer
        .declare_subscriber::<StampedTransitionEvent>("/lc/transition_event")
        .wait()
        .unwrap();
    assert!(events.wait_for_publishers(TIMEOUT));
    // Kilted's definition has another hash: no Kilted-typed publisher.
    assert_ne!(
        StampedTransitionEvent::type_hash(),
        TransitionEvent::type_hash()
    );
    let graph = observer.graph(TIMEOUT).unwrap();
    let announced: Vec<String> = graph
        .publishers("/lc/transition_event")
        .iter()
        .filter_map(|p| p.endpoint.as_ref().map(|e| e.type_hash.clone()))
        .collect();
    assert_eq!(announced, [StampedTransitionEvent::type_hash()]);

    // Asked through `~/change_state` from the observer's session, as a
    // lifecycle manager does: the request follows the subscription on the
    // same link, so the event that the transition publishes reaches it.
    let change = observer
        .declare_client::<ChangeState>("/lc/change_state")
        .wait()
        .unwrap();
    assert!(change.wait_for_service(TIMEOUT));
    let reply = change
        .call(&ChangeState_Request {
            transition: TransitionMsg {
                id: TransitionMsg::TRANSITION_CONFIGURE,
                label: String::new(),
            },
        })
        .wait()
        .unwrap();
    assert!(reply.success);
    assert_eq!(lifecycle.state(), State::Inactive);
    let event = events.recv_timeout(TIMEOUT).unwrap().unwrap();
    let event: StampedTransitionEvent = event.decode().unwrap();
    assert_eq!(
        (event.start_state.id, event.goal_state.id),
        (
            StateMsg::PRIMARY_STATE_UNCONFIGURED,
            StateMsg::TRANSITION_STATE_CONFIGURING
        )
    );
}

/// What a buffer-aware publisher of rmw_zenoh_cpp 0.10.5 does with a
/// subscriber it has discovered: it sends the subscriber's messages to
/// `<topic key>/_buf/<the subscriber's GID in hex>`, computed from its token.
#[test]
fn a_lyrical_subscriber_of_a_buffer_type_reads_its_own_key_too() {
    use shm_cdr::msgs::sensor_msgs::msg::Image;
    use shm_runtime::rmw::{buffer_key_expr, Gid};
    let (a, b, _) = loopback_sessions();
    let listener = node(&a, "viewer", Distro::Lyrical);
    let images = listener
        .declare_subscriber::<Image>("/camera")
        .wait()
        .unwrap();
    let base = images.key_expr().to_owned();
    // The peer learns the key from the subscriber's token alone, as 0.10.5
    // does: here through a graph of its own.
    let peer = node(&b, "camera", Distro::Lyrical);
    let graph = peer.graph_cache().unwrap();
    assert!(graph.wait_until(TIMEOUT, |g| !g.subscribers("/camera").is_empty()));
    let token = graph
        .snapshot()
        .subscribers("/camera")
        .first()
        .map(|e| e.token.to_string());
    let seen = token.expect("the subscriber's token on the graph");
    assert_eq!(
        buffer_key_expr(Distro::Lyrical, &base, &seen, true),
        Some(format!("{base}/_buf/{:?}", Gid::from_token(&seen)))
    );
    // Kilted's and Jazzy's publishers have no such keys; types without a
    // `uint8[]` field of their own none either.
    assert_eq!(buffer_key_expr(Distro::Kilted, &base, &seen, true), None);
    assert_eq!(buffer_key_expr(Distro::Rolling, &base, &seen, false), None);
    let key = format!("{base}/_buf/{:?}", Gid::from_token(&seen));
    let image = Image {
        height: 2,
        width: 3,
        encoding: "mono8".into(),
        step: 3,
        data: vec![1, 2, 3, 4, 5, 6],
        ..Default::default()
    };
    let publisher = b.declare_publisher(key).wait().unwrap();
    let mut got = None;
    for _ in 0..100 {
        publisher
            .put(shm_cdr::to_vec(&image).unwrap())
            .wait()
            .unwrap();
        if let Some(sample) = images.recv_timeout(Duration::from_millis(100)).unwrap() {
            got = Some(sample.decode::<Image>().unwrap());
            break;
        }
    }
    assert_eq!(got, Some(image));
}

/// `node`'s conflicts on `/chatter`, once there are at least `count` or
/// `TIMEOUT` has passed.
fn chatter_conflicts(node: &RosNode, count: usize) -> Vec<shm_runtime::TypeConflict> {
    let deadline = std::time::Instant::now() + TIMEOUT;
    loop {
        let conflicts: Vec<_> = node
            .topic_type_conflicts()
            .into_iter()
            .filter(|c| c.topic == "/chatter")
            .collect();
        if conflicts.len() >= count || std::time::Instant::now() > deadline {
            return conflicts;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The nodes of one session follow the graph together: each still names
/// only the conflicts on its own topics, and one that leaves takes nothing
/// from the others.
#[test]
fn nodes_of_one_session_each_name_their_own_conflicts() {
    use shm_cdr::msgs::std_msgs::Int32;
    let (a, b, _) = loopback_sessions();
    let first = node(&b, "first_listener", Distro::Kilted);
    let _first_chatter = first.declare_subscriber::<Text>("/chatter").wait().unwrap();
    let second = node(&b, "second_listener", Distro::Kilted);
    let _second_numbers = second
        .declare_subscriber::<Text>("/numbers")
        .wait()
        .unwrap();
    let third = node(&b, "third_listener", Distro::Kilted);
    let _third_chatter = third.declare_subscriber::<Text>("/chatter").wait().unwrap();

    let talker = node(&a, "int_talker", Distro::Kilted);
    let _ints = talker
        .declare_publisher::<Int32>("/chatter")
        .wait()
        .unwrap();
    for listener in [&first, &third] {
        let conflicts = chatter_conflicts(listener, 1);
        assert_eq!(conflicts.len(), 1, "{conflicts:?}");
        assert_eq!(conflicts[0].node, "/int_talker");
    }
    assert!(
        second
            .topic_type_conflicts()
            .iter()
            .all(|c| c.topic != "/chatter"),
        "a node without /chatter named a conflict there"
    );

    // The first node leaves; the third still follows the graph.
    drop(first);
    let _more = talker
        .declare_publisher::<Int32>("/numbers")
        .wait()
        .unwrap();
    let deadline = std::time::Instant::now() + TIMEOUT;
    while !second
        .topic_type_conflicts()
        .iter()
        .any(|c| c.topic == "/numbers")
    {
        assert!(
            std::time::Instant::now() < deadline,
            "a conflict after another node of the session left was never named"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_node_names_the_endpoints_it_cannot_hear() {
    use shm_cdr::msgs::std_msgs::{Float64, Int32};
    let (a, b, _) = loopback_sessions();
    let humble = node(&a, "old_talker", Distro::Humble);
    let _old = humble.declare_publisher::<Text>("/chatter").wait().unwrap();
    let kilted = node(&b, "listener", Distro::Kilted);
    let chatter = kilted
        .declare_subscriber::<Text>("/chatter")
        .wait()
        .unwrap();

    let conflicts = chatter_conflicts(&kilted, 1);
    assert_eq!(conflicts.len(), 1, "{conflicts:?}");
    let conflict = &conflicts[0];
    assert_eq!(
        (conflict.node.as_str(), conflict.kind),
        ("/old_talker", shm_runtime::rmw::EntityKind::Publisher)
    );
    assert_eq!(
        conflict.theirs,
        (
            Text::TYPE_NAME.to_owned(),
            TYPE_HASH_NOT_SUPPORTED.to_owned()
        )
    );
    assert_eq!(conflict.ours.1, Text::type_hash());
    // Every node's /parameter_events publisher differs the same way.
    assert!(kilted
        .topic_type_conflicts()
        .iter()
        .any(|c| c.topic == "/parameter_events" && c.theirs.1 == TYPE_HASH_NOT_SUPPORTED));
    // The Humble node sees the Kilted subscriber the same way.
    let seen_by_humble = chatter_conflicts(&humble, 1);
    assert_eq!(seen_by_humble[0].theirs.1, Text::type_hash());
    assert_eq!(
        seen_by_humble[0].kind,
        shm_runtime::rmw::EntityKind::Subscriber
    );

    // Another type on a topic of the node's: named too, once.
    let numbers = node(&a, "numbers", Distro::Kilted);
    let _wrong = numbers
        .declare_publisher::<Int32>("/chatter")
        .wait()
        .unwrap();
    let conflicts = chatter_conflicts(&kilted, 2);
    assert_eq!(conflicts.len(), 2, "{conflicts:?}");
    assert_eq!(
        conflicts[1].theirs,
        (Int32::TYPE_NAME.to_owned(), Int32::type_hash().to_owned())
    );
    // A matching endpoint is no conflict; a topic no longer used is not followed.
    let same = node(&a, "talker", Distro::Kilted);
    let _same = same.declare_publisher::<Text>("/chatter").wait().unwrap();
    drop(chatter);
    let late = node(&a, "late", Distro::Kilted);
    let _late = late
        .declare_publisher::<Float64>("/chatter")
        .wait()
        .unwrap();
    assert!(kilted
        .graph_cache()
        .unwrap()
        .wait_until(TIMEOUT, |g| g.publishers("/chatter").len() == 4));
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(
        kilted
            .topic_type_conflicts()
            .iter()
            .filter(|c| c.topic == "/chatter")
            .count(),
        2
    );
}
