//! A peer on the same Zenoh network tries to take a topic off shared memory
//! with the publisher's own handshake: receiver tokens naming sessions that
//! are not there, answers to probes meant for other sessions, tokens it
//! never confirms, a flood of them. A token counts only once the session it
//! names confirms it (Zenoh's replier id), so the real subscriber keeps
//! receiving through shared memory; a linked session that never confirms
//! holds messages back once, for at most `PROBE_TIMEOUT`.

mod common;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{connect_to, loopback_sessions, shm_serial};
use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::ShmOptions;
use shm_runtime::{
    PayloadKind, Reach, RosPublisher, RosSubscriber, SessionExt, ShmConfig, ShmContext,
    PROBE_TIMEOUT,
};
use zenoh::query::Query;
use zenoh::session::ZenohId;
use zenoh::Wait;

const MESSAGES: usize = 20;
const TIMEOUT: Duration = Duration::from_secs(10);

fn message(i: usize) -> UInt8MultiArray {
    UInt8MultiArray {
        data: vec![i as u8; 16 * 1024],
        ..Default::default()
    }
}

/// A publisher on `a` with a pool, and a subscriber on `b`, matched and
/// checked.
fn topic(
    a: &zenoh::Session,
    b: &zenoh::Session,
    name: &str,
) -> (
    RosPublisher<UInt8MultiArray>,
    RosSubscriber<UInt8MultiArray>,
) {
    // 1 MiB: every test of this binary's pool fits an ordinary user's
    // 8 MiB memory-lock limit, one test at a time.
    let shm = ShmContext::new(ShmConfig::enabled().pool_size(1 << 20).threshold(1024)).unwrap();
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>(name)
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<UInt8MultiArray>(name)
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    (publisher, subscriber)
}

/// A receiver token on `publisher`'s key naming `session`, as a subscriber
/// of this project declares it.
fn token_key(publisher: &RosPublisher<UInt8MultiArray>, session: ZenohId, n: u32) -> String {
    format!("{}/@shm_cdr_rx/{session}/{n}", publisher.key_expr())
}

/// How `session` shows among `publisher`'s receivers, once it shows as
/// something other than `Checking`.
fn settled_reach(publisher: &RosPublisher<UInt8MultiArray>, session: ZenohId) -> Reach {
    let deadline = Instant::now() + 3 * PROBE_TIMEOUT;
    loop {
        let receivers = publisher.receivers();
        if let Some(r) = receivers.iter().find(|r| r.session == session) {
            if r.reach != Reach::Checking {
                return r.reach;
            }
        }
        assert!(
            Instant::now() < deadline,
            "{session} never settled: {receivers:?}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Publish `MESSAGES` messages; every one must reach `subscriber` mapped in
/// place. The kinds the publisher chose.
fn publish_and_receive_in_place(
    publisher: &RosPublisher<UInt8MultiArray>,
    subscriber: &RosSubscriber<UInt8MultiArray>,
) -> Vec<PayloadKind> {
    let kinds: Vec<PayloadKind> = (0..MESSAGES)
        .map(|i| publisher.publish(&message(i)).wait().unwrap().kind)
        .collect();
    for i in 0..MESSAGES {
        let sample = subscriber
            .recv_timeout(TIMEOUT)
            .unwrap()
            .unwrap_or_else(|| panic!("message {i} of {MESSAGES} lost"));
        assert!(sample.is_shm(), "message {i} came as a copy");
        assert_eq!(
            sample.decode::<UInt8MultiArray>().unwrap().data,
            message(i).data
        );
    }
    kinds
}

#[test]
fn a_token_naming_a_session_that_is_not_there_holds_nothing_back() {
    shm_runtime::init_logging();
    let _one_at_a_time = shm_serial();
    let (a, b, port) = loopback_sessions();
    let attacker = connect_to(port);
    let (publisher, subscriber) = topic(&a, &b, "forged/absent");

    let ghost: ZenohId = "5a5a5a5a5a5a5a5a5a5a5a5a5a5a5a5a".parse().unwrap();
    let _forged = attacker
        .liveliness()
        .declare_token(token_key(&publisher, ghost, 0))
        .wait()
        .unwrap();
    // From the moment the token is seen: the ghost is linked to nobody, so
    // its token holds nothing back while it is being confirmed.
    let deadline = Instant::now() + TIMEOUT;
    while !publisher.receivers().iter().any(|r| r.session == ghost) {
        assert!(Instant::now() < deadline, "the forged token never showed");
        std::thread::sleep(Duration::from_millis(5));
    }
    let kinds = publish_and_receive_in_place(&publisher, &subscriber);
    assert_eq!(kinds, vec![PayloadKind::Shm; MESSAGES]);

    assert_eq!(settled_reach(&publisher, ghost), Reach::Unconfirmed);
    assert_eq!(settled_reach(&publisher, b.zid()), Reach::SharedMemory);
    let kinds = publish_and_receive_in_place(&publisher, &subscriber);
    assert_eq!(kinds, vec![PayloadKind::Shm; MESSAGES]);
}

#[test]
fn answers_given_for_another_session_are_not_believed() {
    shm_runtime::init_logging();
    let _one_at_a_time = shm_serial();
    let (a, b, port) = loopback_sessions();
    let attacker = connect_to(port);
    let ghost: ZenohId = "6b6b6b6b6b6b6b6b6b6b6b6b6b6b6b6b".parse().unwrap();

    // The attacker answers every confirmation and probe, for the ghost it
    // invents and for the real subscriber's session: "I hold it", "as bytes".
    let forge = |session: ZenohId| {
        attacker
            .declare_queryable(format!("@shm_cdr/probe/{session}"))
            .callback(|query| {
                let answer: &[u8] = match query.parameters().contains_key("confirm") {
                    true => b"holds",
                    false => b"bytes",
                };
                let _ = query.reply(query.key_expr().clone(), answer).wait();
            })
            .wait()
            .unwrap()
    };
    let _for_ghost = forge(ghost);
    let _for_subscriber = forge(b.zid());

    let (publisher, subscriber) = topic(&a, &b, "forged/answers");
    let _forged = attacker
        .liveliness()
        .declare_token(token_key(&publisher, ghost, 0))
        .wait()
        .unwrap();

    assert_eq!(settled_reach(&publisher, ghost), Reach::Unconfirmed);
    assert_eq!(settled_reach(&publisher, b.zid()), Reach::SharedMemory);
    let kinds = publish_and_receive_in_place(&publisher, &subscriber);
    assert_eq!(kinds, vec![PayloadKind::Shm; MESSAGES]);
    assert_eq!(publisher.shm_context().unwrap().stats().copied, 0);
}

#[test]
fn a_linked_session_that_never_confirms_holds_messages_back_once_and_only_until_the_timeout() {
    shm_runtime::init_logging();
    let _one_at_a_time = shm_serial();
    let (a, b, port) = loopback_sessions();
    let attacker = connect_to(port);
    // Linked to the publisher's session, so its token is waited for while
    // being confirmed; it keeps every query open and never answers.
    let held: Arc<Mutex<Vec<Query>>> = Arc::default();
    let keep = Arc::clone(&held);
    let _silent = attacker
        .declare_queryable(format!("@shm_cdr/probe/{}", attacker.zid()))
        .callback(move |query| keep.lock().unwrap().push(query))
        .wait()
        .unwrap();
    let (publisher, subscriber) = topic(&a, &b, "forged/silent");

    let _first = attacker
        .liveliness()
        .declare_token(token_key(&publisher, attacker.zid(), 0))
        .wait()
        .unwrap();
    let deadline = Instant::now() + TIMEOUT;
    while held.lock().unwrap().is_empty() {
        assert!(Instant::now() < deadline, "no confirmation was asked");
        std::thread::sleep(Duration::from_millis(5));
    }
    // While it is being confirmed, messages wait for it, then go from the
    // heap: nothing is lost either way.
    let kind = publisher.publish(&message(0)).wait().unwrap().kind;
    assert_eq!(kind, PayloadKind::ReceiverPending);
    let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
    assert_eq!(
        sample.decode::<UInt8MultiArray>().unwrap().data,
        message(0).data
    );

    // Past the timeout it is ignored, and the topic is back on shared memory.
    assert_eq!(
        settled_reach(&publisher, attacker.zid()),
        Reach::Unconfirmed
    );
    let kinds = publish_and_receive_in_place(&publisher, &subscriber);
    assert_eq!(kinds, vec![PayloadKind::Shm; MESSAGES]);

    // Its next tokens are asked about, but hold nothing back.
    let asked = held.lock().unwrap().len();
    let more: Vec<_> = (1..=3)
        .map(|n| {
            attacker
                .liveliness()
                .declare_token(token_key(&publisher, attacker.zid(), n))
                .wait()
                .unwrap()
        })
        .collect();
    let deadline = Instant::now() + TIMEOUT;
    while held.lock().unwrap().len() < asked + more.len() {
        assert!(
            Instant::now() < deadline,
            "the new tokens were not asked about"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let kinds = publish_and_receive_in_place(&publisher, &subscriber);
    assert_eq!(kinds, vec![PayloadKind::Shm; MESSAGES]);
}

#[test]
fn a_flood_of_forged_tokens_leaves_the_topic_on_shared_memory() {
    shm_runtime::init_logging();
    let _one_at_a_time = shm_serial();
    let (a, b, port) = loopback_sessions();
    let attacker = connect_to(port);
    let (publisher, subscriber) = topic(&a, &b, "forged/flood");

    // A new token every few milliseconds, each naming a session that does
    // not exist, while the publisher publishes.
    let mut tokens = Vec::new();
    let mut kinds = Vec::new();
    for i in 0..200 {
        let ghost: ZenohId = format!("f00d{i:028x}").parse().unwrap();
        tokens.push(
            attacker
                .liveliness()
                .declare_token(token_key(&publisher, ghost, 0))
                .wait()
                .unwrap(),
        );
        if i % 10 == 0 {
            kinds.push(publisher.publish(&message(i)).wait().unwrap().kind);
        }
    }
    assert_eq!(kinds, vec![PayloadKind::Shm; kinds.len()]);
    for (i, _) in kinds.iter().enumerate() {
        let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
        assert!(sample.is_shm(), "message {i} came as a copy");
    }
    let kinds = publish_and_receive_in_place(&publisher, &subscriber);
    assert_eq!(kinds, vec![PayloadKind::Shm; MESSAGES]);
    let receivers = publisher.receivers();
    assert_eq!(
        receivers
            .iter()
            .filter(|r| r.reach == Reach::SharedMemory)
            .count(),
        1,
        "{receivers:?}"
    );
}
