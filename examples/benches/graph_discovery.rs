//! What the live graph cache costs: how long a newly started session takes
//! to see every one of N liveliness tokens, what a query of the cache costs,
//! and how much memory the graph takes, for N = 100, 1 000 and 10 000 tokens,
//! peer to peer and through a router.
//!
//! The tokens are a system of nodes as rclcpp announces them: per node, its
//! own token, `/rosout` and `/parameter_events` publishers, the six parameter
//! services, and one application topic (ten tokens). They are declared on one
//! session (in this process, over TCP loopback). Each round opens a fresh
//! session, as a starting process would, and times it from `zenoh::open`
//! until its [`GraphCache`] holds all N. The reference, measured in the same
//! rounds: a fresh session's plain Zenoh liveliness query (replies counted
//! in a callback) until it has all N replies.
//!
//! The graph's memory is counted by this benchmark's allocator: the bytes
//! alive after building the graph of N tokens.
//!
//! `cargo bench -p shm-cdr-examples --bench graph_discovery` prints the
//! tables (medians).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use shm_cdr::msgs::rcl_interfaces::msg::{Log, ParameterEvent};
use shm_cdr::msgs::rcl_interfaces::srv::{
    DescribeParameters, GetParameterTypes, GetParameters, ListParameters, SetParameters,
    SetParametersAtomically,
};
use shm_cdr::msgs::std_msgs::String as RosString;
use shm_runtime::graph::{Graph, GraphCache};
use shm_runtime::rmw::{Distro, EntityKind, NodeInfo, Qos};
use zenoh::{Config, Wait};

#[global_allocator]
static ALLOCATOR: shm_cdr_examples::heap::Counting = shm_cdr_examples::heap::Counting;

const TIMEOUT: Duration = Duration::from_secs(30);
const SIZES: [usize; 3] = [100, 1_000, 10_000];

fn config(mode: &str, key: &str, port: u16) -> Config {
    let mut c = Config::default();
    for (k, v) in [
        ("mode", format!("\"{mode}\"")),
        ("scouting/multicast/enabled", "false".into()),
        ("transport/shared_memory/enabled", "false".into()),
        (key, format!("[\"tcp/127.0.0.1:{port}\"]")),
    ] {
        c.insert_json5(k, &v).expect("config");
    }
    c
}

/// The tokens of `tokens / 10` nodes of ten tokens each, as rclcpp's nodes
/// announce them.
fn system_tokens(zid: &str, tokens: usize) -> Vec<String> {
    let mut out = Vec::with_capacity(tokens);
    let qos = Qos::default();
    let services = Qos::services_default();
    for n in 0..tokens / 10 {
        let base = (n as u64) * 10;
        let node = NodeInfo {
            domain_id: 0,
            zid: zid.to_owned(),
            node_id: base,
            enclave: "/".into(),
            namespace: "/robot".into(),
            name: format!("node_{n}"),
            distro: Distro::Kilted,
        };
        let fqn = format!("/robot/node_{n}");
        out.push(node.node_token());
        out.push(node.topic_token::<Log>(base + 1, EntityKind::Publisher, "/rosout", &qos));
        out.push(node.topic_token::<ParameterEvent>(
            base + 2,
            EntityKind::Publisher,
            "/parameter_events",
            &qos,
        ));
        out.push(node.topic_token::<RosString>(
            base + 3,
            EntityKind::Publisher,
            &format!("{fqn}/status"),
            &qos,
        ));
        let kind = EntityKind::ServiceServer;
        let id = |i| base + 3 + i;
        out.push(node.service_token::<DescribeParameters>(
            id(1),
            kind,
            &format!("{fqn}/describe_parameters"),
            &services,
        ));
        out.push(node.service_token::<GetParameterTypes>(
            id(2),
            kind,
            &format!("{fqn}/get_parameter_types"),
            &services,
        ));
        out.push(node.service_token::<GetParameters>(
            id(3),
            kind,
            &format!("{fqn}/get_parameters"),
            &services,
        ));
        out.push(node.service_token::<ListParameters>(
            id(4),
            kind,
            &format!("{fqn}/list_parameters"),
            &services,
        ));
        out.push(node.service_token::<SetParameters>(
            id(5),
            kind,
            &format!("{fqn}/set_parameters"),
            &services,
        ));
        out.push(node.service_token::<SetParametersAtomically>(
            id(6),
            kind,
            &format!("{fqn}/set_parameters_atomically"),
            &services,
        ));
    }
    out
}

fn median(mut samples: Vec<Duration>) -> Duration {
    samples.sort_unstable();
    samples[samples.len() / 2]
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// From `zenoh::open` until a fresh session's cache holds `n` entities.
fn discover_with_cache(observer: &Config, n: usize) -> Duration {
    let started = Instant::now();
    let session = zenoh::open(observer.clone()).wait().expect("open");
    let cache = GraphCache::of(&session, 0).expect("cache");
    assert!(
        cache.wait_until(TIMEOUT, |graph| graph.len() >= n),
        "the cache saw {} of {n}",
        cache.read().len()
    );
    let took = started.elapsed();
    drop(cache);
    session.close().wait().expect("close");
    took
}

/// From `zenoh::open` until a fresh session's liveliness query has `n`
/// replies: the reference.
fn discover_with_query(observer: &Config, n: usize) -> Duration {
    let started = Instant::now();
    let session = zenoh::open(observer.clone()).wait().expect("open");
    let replies = Arc::new(AtomicUsize::new(0));
    let took = loop {
        let counted = replies.clone();
        counted.store(0, Ordering::Relaxed);
        session
            .liveliness()
            .get("@ros2_lv/0/**")
            .timeout(TIMEOUT)
            .callback(move |_| {
                counted.fetch_add(1, Ordering::Relaxed);
            })
            .wait()
            .expect("query");
        // The callback is dropped at the final reply; wait for that.
        while Arc::strong_count(&replies) > 1 {
            std::thread::sleep(Duration::from_micros(100));
        }
        if replies.load(Ordering::Relaxed) >= n {
            break started.elapsed();
        }
        assert!(
            started.elapsed() < TIMEOUT,
            "the query saw {} of {n}",
            replies.load(Ordering::Relaxed)
        );
    };
    session.close().wait().expect("close");
    took
}

fn time_query<R>(rounds: usize, mut query: impl FnMut() -> R) -> Duration {
    let samples = (0..rounds)
        .map(|_| {
            let started = Instant::now();
            std::hint::black_box(query());
            started.elapsed()
        })
        .collect();
    median(samples)
}

fn main() {
    let rounds = |n: usize| match n {
        0..=1_000 => 11,
        _ => 5,
    };
    println!("| topology | tokens | cache: open → all seen | reference: open → liveliness query has all | rounds |");
    println!("|---|---:|---:|---:|---:|");
    for topology in ["peer to peer", "through a router"] {
        for n in SIZES {
            let port = shm_runtime::testing::free_port().expect("a free port");
            let (_router, system, observer) = match topology {
                "peer to peer" => (
                    None,
                    zenoh::open(config("peer", "listen/endpoints", port))
                        .wait()
                        .expect("open"),
                    config("peer", "connect/endpoints", port),
                ),
                _ => (
                    Some(
                        zenoh::open(config("router", "listen/endpoints", port))
                            .wait()
                            .expect("open"),
                    ),
                    zenoh::open(config("client", "connect/endpoints", port))
                        .wait()
                        .expect("open"),
                    config("client", "connect/endpoints", port),
                ),
            };
            let tokens: Vec<_> = system_tokens(&system.zid().to_string(), n)
                .into_iter()
                .map(|t| system.liveliness().declare_token(t).wait().expect("token"))
                .collect();
            let mut cache = Vec::new();
            let mut reference = Vec::new();
            for _ in 0..rounds(n) {
                cache.push(discover_with_cache(&observer, n));
                reference.push(discover_with_query(&observer, n));
            }
            println!(
                "| {topology} | {n} | {} | {} | {} |",
                ms(median(cache)),
                ms(median(reference)),
                rounds(n)
            );
            drop(tokens);
        }
    }

    println!();
    println!("| tokens | graph memory | per token | publishers(\"/rosout\") | node_endpoints | nodes() | topics() | snapshot() |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for n in SIZES {
        let tokens = system_tokens("0123456789abcdef0123456789abcdef", n);
        let before = shm_cdr_examples::heap::live_bytes();
        let graph = Graph::from_tokens(tokens.iter().map(String::as_str));
        let bytes = shm_cdr_examples::heap::live_bytes() - before;
        assert_eq!(graph.len(), n);
        let node = format!("/robot/node_{}", n / 20);
        let us = |d: Duration| format!("{:.1} µs", d.as_secs_f64() * 1e6);
        println!(
            "| {n} | {:.2} MiB | {} B | {} | {} | {} | {} | {} |",
            bytes as f64 / (1 << 20) as f64,
            bytes / n as isize,
            us(time_query(1001, || graph.publishers("/rosout").len())),
            us(time_query(1001, || graph.node_endpoints(&node).len())),
            us(time_query(1001, || graph.nodes().len())),
            us(time_query(101, || graph.topics().len())),
            us(time_query(101, || graph.clone().len())),
        );
    }
}
