//! The graph at a realistic size: far more liveliness tokens than Zenoh's
//! default channel holds (256), peer to peer and through a router, must
//! neither hang a graph query nor a wait for publishers, and the live cache
//! must follow every token coming and going, with an event for each change
//! (rclcpp nodes announce about ten endpoints each, so 26 nodes pass 256).

mod common;

use std::collections::HashSet;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::loopback_sessions;
use shm_cdr::msgs::std_msgs::String as RosString;
use shm_cdr::msgs::std_srvs::srv::Trigger;
use shm_runtime::graph::{GraphCache, GraphEvent};
use shm_runtime::rmw::EntityKind;
use shm_runtime::RosNode;
use zenoh::{Config, Session, Wait};

const TIMEOUT: Duration = Duration::from_secs(20);

/// The large systems are built one at a time: on a 2-core machine two of them
/// at once starve each other's sessions, and a late joiner's history query
/// (Zenoh's 10 s query timeout) returns part of the graph.
static ONE_SYSTEM_AT_A_TIME: Mutex<()> = Mutex::new(());

fn one_system_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    ONE_SYSTEM_AT_A_TIME
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The endpoints [`system`] declares on each node.
const EXPLICIT: usize = 4;
/// What every node declares itself: the six parameter services,
/// `~/get_type_description` and the `/parameter_events` publisher.
const AUTOMATIC: usize = 8;
/// The services among them.
const AUTOMATIC_SERVICES: usize = 7;
/// A node's tokens: its own, the automatic and the explicit endpoints.
const TOKENS_PER_NODE: usize = 1 + AUTOMATIC + EXPLICIT;

/// Nodes on `session`, each with a publisher on `/rosout` and on `/chatter`,
/// a subscriber and a service ([`EXPLICIT`]), besides what every node
/// declares ([`AUTOMATIC`]): [`TOKENS_PER_NODE`] in all, as many as an
/// rclcpp node with a few endpoints.
struct System {
    nodes: Vec<RosNode>,
    endpoints: Vec<Box<dyn std::any::Any>>,
}

fn system(session: &Session, prefix: &str, count: usize) -> System {
    let nodes: Vec<RosNode> = (0..count)
        .map(|i| common::node(session, &format!("{prefix}_{i}")))
        .collect();
    let mut endpoints: Vec<Box<dyn std::any::Any>> = Vec::new();
    for node in &nodes {
        for topic in ["/rosout", "/chatter"] {
            endpoints.push(Box::new(
                node.declare_publisher::<RosString>(topic).wait().unwrap(),
            ));
        }
        endpoints.push(Box::new(
            node.declare_subscriber::<RosString>("/parameter_events")
                .wait()
                .unwrap(),
        ));
        endpoints.push(Box::new(
            node.declare_service::<Trigger>("~/reset").wait().unwrap(),
        ));
    }
    System { nodes, endpoints }
}

/// `count` nodes named `<prefix>_<i>`, each with the four endpoints of
/// [`system`], seen by `cache`.
fn sees_all(cache: &GraphCache, prefix: &str, count: usize) -> bool {
    let named = format!("/{prefix}_");
    cache.wait_until(TIMEOUT, |graph| {
        // Asked at every change of the graph, thousands of times: the counts
        // (kept by the graph) first, the names once they add up.
        let servers_each = AUTOMATIC_SERVICES + 1;
        if graph.count(EntityKind::Node) < count
            || graph.count(EntityKind::ServiceServer) < count * servers_each
            || graph.count(EntityKind::Publisher) < count * 3
            || graph.count(EntityKind::Subscriber) < count
        {
            return false;
        }
        let nodes = graph
            .nodes()
            .iter()
            .filter(|n| n.starts_with(&named))
            .count();
        let servers = graph
            .services()
            .keys()
            .filter(|s| s.starts_with(&named) && s.ends_with("/reset"))
            .count();
        nodes == count
            && servers == count
            && graph.publishers("/rosout").len() >= count
            && graph.publishers("/chatter").len() >= count
            && graph.subscribers("/parameter_events").len() >= count
    })
}

#[test]
fn a_cache_follows_400_nodes_and_their_5200_tokens_coming_and_going_with_an_event_for_each() {
    let _one = one_system_at_a_time();
    let (a, b, _) = loopback_sessions();
    let observer = common::node(&b, "observer");
    let cache = observer.graph_cache().unwrap();
    assert!(cache.wait_synced(TIMEOUT));
    let events = cache.events_with_capacity(10_000);
    let before = cache.read().len();

    let started = Instant::now();
    let system = system(&a, "node", 400);
    assert!(sees_all(&cache, "node", 400), "not all 400 nodes seen");
    println!(
        "400 nodes, {} tokens seen in {:?}",
        400 * TOKENS_PER_NODE,
        started.elapsed()
    );
    let graph = cache.snapshot();
    assert_eq!(graph.len(), before + 400 * TOKENS_PER_NODE);
    // Each node's and the observer's automatic ones, and each node's `~/reset`.
    assert_eq!(
        graph.count(EntityKind::ServiceServer),
        401 * AUTOMATIC_SERVICES + 400
    );
    assert_eq!(graph.node_endpoints("/node_17").len(), AUTOMATIC + EXPLICIT);
    assert_eq!(graph.unreadable().len(), 0);
    // Every node shares the session's cache.
    assert_eq!(
        common::node(&b, "second")
            .graph(TIMEOUT)
            .unwrap()
            .count(EntityKind::Node),
        402
    );

    // Half the nodes leave (their endpoints with them); the rest stay.
    let System {
        nodes,
        mut endpoints,
    } = system;
    let mut kept = Vec::new();
    for (i, node) in nodes.into_iter().enumerate() {
        let own: Vec<_> = endpoints.drain(..EXPLICIT).collect();
        if i % 2 == 0 {
            drop(own);
            drop(node);
        } else {
            kept.push((node, own));
        }
    }
    assert!(
        cache.wait_until(TIMEOUT, |graph| graph.publishers("/rosout").len() == 200
            && graph
                .nodes()
                .iter()
                .filter(|n| n.starts_with("/node_"))
                .count()
                == 200),
        "the nodes that left stayed on the graph"
    );
    assert!(!cache.read().contains_node("/node_0"));
    assert!(cache.read().contains_node("/node_1"));
    assert!(cache.read().node_endpoints("/node_0").is_empty());

    // One event per change, in order: each token appeared once, and the
    // tokens that left, left after they appeared.
    let mut appeared = HashSet::new();
    let mut left = HashSet::new();
    let deadline = Instant::now() + TIMEOUT;
    while left.len() < 200 * TOKENS_PER_NODE && Instant::now() < deadline {
        match events.recv_timeout(Duration::from_secs(1)) {
            Some(GraphEvent::Appeared(e)) if e.node_name.starts_with("node_") => {
                assert!(
                    appeared.insert(e.token.clone()),
                    "appeared twice: {}",
                    e.token
                )
            }
            Some(GraphEvent::Left(e)) if e.node_name.starts_with("node_") => {
                assert!(appeared.contains(&e.token), "left before it appeared");
                assert!(left.insert(e.token.clone()), "left twice: {}", e.token)
            }
            Some(GraphEvent::Missed) => panic!("a queue of 10 000 missed events"),
            _ => {}
        }
    }
    assert_eq!(
        (appeared.len(), left.len()),
        (400 * TOKENS_PER_NODE, 200 * TOKENS_PER_NODE)
    );
    assert_eq!(events.missed(), 0);
    drop(kept);
}

#[test]
fn a_graph_query_past_256_tokens_returns_within_its_timeout() {
    let _one = one_system_at_a_time();
    let (a, b, _) = loopback_sessions();
    let system = system(&a, "node", 300);
    let observer = common::node(&b, "observer");
    let started = Instant::now();
    observer.graph(Duration::from_secs(5)).unwrap();
    assert!(
        started.elapsed() < Duration::from_secs(6),
        "graph() ran past its timeout"
    );
    // Tokens still travelling when the first query was answered arrive later.
    let cache = observer.graph_cache().unwrap();
    assert!(sees_all(&cache, "node", 300), "not all 300 nodes seen");
    assert_eq!(cache.read().count(EntityKind::Node), 301);
    // Tokens that were there before the cache leave it too.
    drop(system);
    assert!(
        cache.wait_until(TIMEOUT, |graph| graph.count(EntityKind::Node) == 1
            && graph.publishers("/rosout").is_empty()),
        "nodes that were there first stayed on the graph after leaving"
    );
}

#[test]
fn waiting_for_the_publishers_of_a_topic_with_300_of_them_returns() {
    let _one = one_system_at_a_time();
    let (a, b, _) = loopback_sessions();
    let nodes: Vec<RosNode> = (0..300)
        .map(|i| common::node(&a, &format!("talker_{i}")))
        .collect();
    let _publishers: Vec<_> = nodes
        .iter()
        .map(|node| {
            node.declare_publisher::<RosString>("/rosout")
                .wait()
                .unwrap()
        })
        .collect();
    let listener = common::node(&b, "listener")
        .declare_subscriber::<RosString>("/rosout")
        .wait()
        .unwrap();
    let started = Instant::now();
    assert!(listener.wait_for_publishers(TIMEOUT));
    assert!(started.elapsed() < TIMEOUT);
}

fn router_config(port: u16) -> Config {
    let mut c = Config::default();
    c.insert_json5("mode", "\"router\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    c.insert_json5("listen/endpoints", &format!("[\"tcp/127.0.0.1:{port}\"]"))
        .unwrap();
    c
}

fn client_config(port: u16) -> Config {
    let mut c = Config::default();
    c.insert_json5("mode", "\"client\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    c.insert_json5("connect/endpoints", &format!("[\"tcp/127.0.0.1:{port}\"]"))
        .unwrap();
    c
}

/// rmw_zenoh_cpp's default topology: every process a client of a router.
/// The cache sees the same through it, a process that joins late sees what
/// was there before it, and leaving reaches it through the router too.
#[test]
fn through_a_router_a_late_joiner_sees_300_nodes_and_follows_them_leaving() {
    let _one = one_system_at_a_time();
    let port = common::free_port();
    let _router = zenoh::open(router_config(port)).wait().unwrap();
    let early = zenoh::open(client_config(port)).wait().unwrap();
    let system = system(&early, "routed", 300);

    let late = zenoh::open(client_config(port)).wait().unwrap();
    let observer = common::node(&late, "late_joiner");
    let started = Instant::now();
    let graph = observer.graph(TIMEOUT).unwrap();
    println!(
        "late joiner: {} entities in {:?}",
        graph.len(),
        started.elapsed()
    );
    let cache = observer.graph_cache().unwrap();
    assert!(
        sees_all(&cache, "routed", 300),
        "not all 300 routed nodes seen"
    );
    assert_eq!(cache.read().count(EntityKind::Node), 301);

    let left = Arc::new(Mutex::new(0usize));
    let counter = left.clone();
    let _callback = cache
        .on_change(move |event| {
            if matches!(event, GraphEvent::Left(_)) {
                *counter.lock().unwrap() += 1;
            }
        })
        .unwrap();
    drop(system);
    assert!(
        cache.wait_until(TIMEOUT, |graph| graph.count(EntityKind::Node) == 1
            && graph.publishers("/rosout").is_empty()),
        "the routed nodes stayed on the graph"
    );
    let deadline = Instant::now() + TIMEOUT;
    while *left.lock().unwrap() < 300 * TOKENS_PER_NODE && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(*left.lock().unwrap(), 300 * TOKENS_PER_NODE);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_program_awaits_a_node_and_streams_the_changes() {
    use futures::StreamExt;

    let (a, b, _) = loopback_sessions();
    let cache = GraphCache::of(&b, 0).unwrap();
    cache.synced().await;
    let mut events = cache.events();
    let waiting = {
        let cache = cache.clone();
        tokio::spawn(async move { cache.until(|graph| graph.contains_node("/late")).await })
    };
    tokio::time::sleep(Duration::from_millis(50)).await;
    let node = common::node(&a, "late");
    tokio::time::timeout(TIMEOUT, waiting)
        .await
        .unwrap()
        .unwrap();
    // The node and what it declares itself appear, then leave.
    for _ in 0..1 + AUTOMATIC {
        let appeared = tokio::time::timeout(TIMEOUT, events.next()).await.unwrap();
        assert!(matches!(appeared, Some(GraphEvent::Appeared(e)) if e.node_fqn() == "/late"));
    }
    drop(node);
    for _ in 0..1 + AUTOMATIC {
        let left = tokio::time::timeout(TIMEOUT, events.next()).await.unwrap();
        assert!(matches!(left, Some(GraphEvent::Left(e)) if e.node_fqn() == "/late"));
    }
}
