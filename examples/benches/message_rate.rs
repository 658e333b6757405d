//! Messages per second of a stream of `std_msgs/String`s, one process to
//! another: a node's publisher and subscriber against raw Zenoh on the same
//! session configuration, for 64 B, 1 KiB and 16 KiB messages.
//!
//! `cargo bench -p shm-cdr-examples --bench message_rate` (`-- --quick`: three
//! rounds instead of nine; `-- --paths node-inline,zenoh-callback`: only
//! those paths, named as in the table below; `-- --sizes 64,1024`: only those
//! sizes; `-- --burst N`: N messages a burst).
//!
//! This process publishes; it starts one child of this same binary that
//! subscribes, over TCP loopback. Every path has its own key:
//!
//! | path | publisher | subscriber |
//! |---|---|---|
//! | `zenoh-bare` | Zenoh `put` of the bytes alone | Zenoh callback |
//! | `zenoh-rmw-callback` | Zenoh `put` with the rmw attachment | Zenoh callback |
//! | `node-inline` | `RosPublisher::publish` | `callback_inline` |
//! | `zenoh-rmw-queue` | Zenoh `put` with the rmw attachment | Zenoh's default channel, `recv()` in a thread |
//! | `node-queue` | `RosPublisher::publish` | a `RosSubscriber`, `recv()` in a thread |
//! | `node-callback` | `RosPublisher::publish` | `callback` (queue, then an executor thread) |
//! | `node-zenoh` | `RosPublisher::publish` | Zenoh callback on the topic's key, as a Zenoh-only program subscribes |
//!
//! A node's path is compared with raw Zenoh sending the same wire message:
//! the bytes and the 33-byte attachment (sequence number, time, GID) that
//! rmw_zenoh_cpp puts on every message and its subscribers require, built per
//! message as rmw_zenoh_cpp builds it. `zenoh-bare` shows what that attachment
//! costs Zenoh itself. Each Zenoh put carries a fresh buffer holding the
//! message's bytes, of the kind a node publisher uses for that size: the heap
//! below the node's shared-memory threshold (512 B), a chunk of the same pool
//! at or above it. So both sides write each message once into a new buffer,
//! and a ratio measures what the node adds. Every subscriber does the same
//! work per message: it makes the payload contiguous and checks its length
//! and last byte.
//!
//! A burst is `n` messages as fast as `publish`/`put` returns (reliable,
//! congestion control `Block` on both), then a fence: an empty string on the
//! same key, behind them in order. The rate is the messages received over the
//! time from the first send to the fence's arrival (CLOCK_MONOTONIC, one clock
//! for both processes). The node's queues keep everything (`History::KeepAll`),
//! as Zenoh's channel does; a node subscriber's default QoS keeps the last 10,
//! so under a flood it drops the oldest by design. Messages that never reached
//! the application are reported as lost, with how many of them the node
//! subscriber counted (`lost()` + `missed()`). The CPU time per message is
//! each process's, all threads. The paths take turns in a new order every
//! round; the table gives medians and the median of per-round ratios.

mod common;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use common::{cpu_ns, list_arg, median, now_ns, spawn_ready, Publishing};
use shm_cdr::msgs::std_msgs::String as RosString;
use shm_cdr_examples::peer_session;
use shm_runtime::rmw::{topic_key_expr, Attachment, Distro, Gid};
use shm_runtime::{History, RosNode, ShmContext};
use zenoh::bytes::ZBytes;
use zenoh::qos::{CongestionControl, Reliability};
use zenoh::sample::Sample;
use zenoh::Wait;

/// The whole serialized message (CDR header included), and how many messages
/// a burst holds at that size: about a quarter of a second each.
const SIZES: [(usize, &str, u64); 3] = [
    (64, "64 B", 200_000),
    (1 << 10, "1 KiB", 50_000),
    (16 << 10, "16 KiB", 20_000),
];
/// A node publisher's default shared-memory threshold ([`ShmConfig`]).
const THRESHOLD: usize = 512;
const POOL: usize = 64 << 20;
/// CDR of an empty `std_msgs/String`: header, length, NUL.
const FENCE_LEN: usize = 9;
const REPORT_KEY: &str = "rate/report";
const DONE_KEY: &str = "rate/done";
const REPORT_TIMEOUT: Duration = Duration::from_secs(20);

#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug)]
#[repr(u8)]
enum Path {
    ZenohBare,
    ZenohRmwCallback,
    NodeInline,
    ZenohRmwQueue,
    NodeQueue,
    NodeCallback,
    NodeZenoh,
}

impl Path {
    const ALL: [Path; 7] = [
        Path::ZenohBare,
        Path::ZenohRmwCallback,
        Path::NodeInline,
        Path::ZenohRmwQueue,
        Path::NodeQueue,
        Path::NodeCallback,
        Path::NodeZenoh,
    ];

    fn label(self) -> &'static str {
        match self {
            Path::ZenohBare => "zenoh put, bytes alone → callback",
            Path::ZenohRmwCallback => "zenoh put + rmw attachment → callback",
            Path::NodeInline => "node publish → callback_inline",
            Path::ZenohRmwQueue => "zenoh put + rmw attachment → channel, recv()",
            Path::NodeQueue => "node publish → RosSubscriber, recv()",
            Path::NodeCallback => "node publish → callback (executor)",
            Path::NodeZenoh => "node publish → zenoh callback",
        }
    }

    /// The name `--paths` takes, and the topic (or key) of the path.
    fn name(self) -> &'static str {
        match self {
            Path::ZenohBare => "zenoh-bare",
            Path::ZenohRmwCallback => "zenoh-rmw-callback",
            Path::NodeInline => "node-inline",
            Path::ZenohRmwQueue => "zenoh-rmw-queue",
            Path::NodeQueue => "node-queue",
            Path::NodeCallback => "node-callback",
            Path::NodeZenoh => "node-zenoh",
        }
    }

    /// A node's topic, or a raw Zenoh key.
    fn topic(self) -> String {
        match self.is_node() {
            true => format!("rate_{}", self.name().replace('-', "_")),
            false => format!("rate/{}", self.name()),
        }
    }

    fn is_node(self) -> bool {
        matches!(
            self,
            Path::NodeInline | Path::NodeQueue | Path::NodeCallback | Path::NodeZenoh
        )
    }

    /// Whether a node's subscriber receives it (and counts what it lost).
    fn node_subscribes(self) -> bool {
        matches!(
            self,
            Path::NodeInline | Path::NodeQueue | Path::NodeCallback
        )
    }

    /// The raw Zenoh path this one is compared with: the same wire message
    /// (bytes and attachment) with the same kind of subscriber.
    fn reference(self) -> Option<Path> {
        match self {
            Path::ZenohBare | Path::ZenohRmwQueue => None,
            Path::ZenohRmwCallback => Some(Path::ZenohBare),
            Path::NodeInline | Path::NodeZenoh => Some(Path::ZenohRmwCallback),
            Path::NodeQueue | Path::NodeCallback => Some(Path::ZenohRmwQueue),
        }
    }

    fn from_u8(byte: u8) -> Option<Path> {
        Path::ALL.into_iter().find(|p| *p as u8 == byte)
    }
}

fn message(size: usize) -> RosString {
    RosString {
        data: "x".repeat(size - FENCE_LEN),
    }
}

/// The subscribing process's CPU time at the previous fence.
static CPU_AT_FENCE: AtomicU64 = AtomicU64::new(0);

/// Subscriber → publisher, once a path's fence arrived: how many messages
/// came before it, when it came and the CPU time the subscribing process
/// used since the previous fence.
struct Report {
    path: Path,
    received: u64,
    fence_ns: u64,
    cpu_ns: u64,
    /// Of a node subscriber: the messages it counted as dropped from its
    /// queue ([`lost`](shm_runtime::RosSubscriber::lost)) or as never arrived
    /// ([`missed`](shm_runtime::RosSubscriber::missed)).
    dropped: u64,
}

impl Report {
    fn to_bytes(&self) -> Vec<u8> {
        let mut out = vec![self.path as u8];
        out.extend_from_slice(&self.received.to_le_bytes());
        out.extend_from_slice(&self.fence_ns.to_le_bytes());
        out.extend_from_slice(&self.cpu_ns.to_le_bytes());
        out.extend_from_slice(&self.dropped.to_le_bytes());
        out
    }

    fn parse(bytes: &[u8]) -> Option<Report> {
        let (path, rest) = bytes.split_first()?;
        let (received, rest) = rest.split_first_chunk::<8>()?;
        let (fence, rest) = rest.split_first_chunk::<8>()?;
        let (cpu, rest) = rest.split_first_chunk::<8>()?;
        let dropped: &[u8; 8] = rest.try_into().ok()?;
        Some(Report {
            path: Path::from_u8(*path)?,
            received: u64::from_le_bytes(*received),
            fence_ns: u64::from_le_bytes(*fence),
            cpu_ns: u64::from_le_bytes(*cpu),
            dropped: u64::from_le_bytes(*dropped),
        })
    }
}

fn main() {
    let outcome = match std::env::var("RATE_ROLE").as_deref() {
        Ok("subscriber") => subscriber_side(),
        _ => publisher_side(),
    };
    if let Err(e) = outcome {
        eprintln!("message_rate: {e}");
        std::process::exit(1);
    }
}

/// Counts one path's messages; hands the report over at the fence.
struct Counter {
    path: Path,
    received: AtomicU64,
    reports: mpsc::Sender<Report>,
}

impl Counter {
    /// The same work on every path: the payload made contiguous, its length
    /// and its NUL checked.
    fn count(&self, payload: &ZBytes) {
        let bytes = payload.to_bytes();
        if bytes.len() == FENCE_LEN {
            let fence_ns = now_ns();
            let cpu = cpu_ns();
            let _ = self.reports.send(Report {
                path: self.path,
                received: self.received.swap(0, Ordering::Relaxed),
                fence_ns,
                cpu_ns: cpu - CPU_AT_FENCE.swap(cpu, Ordering::Relaxed).min(cpu),
                dropped: 0,
            });
        } else if bytes.len() >= 64 && bytes.last() == Some(&0) {
            self.received.fetch_add(1, Ordering::Relaxed);
        }
    }
}

fn subscriber_side() -> zenoh::Result<()> {
    let endpoint = std::env::var("RATE_ENDPOINT")?;
    let session = peer_session(&endpoint, false)?;
    let node = RosNode::builder(&session, "rate_subscriber").wait()?;
    let (reports, reported) = mpsc::channel();
    let counter = |path| {
        Arc::new(Counter {
            path,
            received: AtomicU64::new(0),
            reports: reports.clone(),
        })
    };

    let mut keep = Vec::new();
    for path in [Path::ZenohBare, Path::ZenohRmwCallback] {
        let c = counter(path);
        keep.push(
            session
                .declare_subscriber(path.topic())
                .callback(move |s: Sample| c.count(s.payload()))
                .wait()?,
        );
    }
    // A Zenoh-only subscriber of a node's topic, on the key rmw_zenoh_cpp
    // publishes it on.
    let c = counter(Path::NodeZenoh);
    keep.push(
        session
            .declare_subscriber(topic_key_expr::<RosString>(
                Distro::default(),
                0,
                &Path::NodeZenoh.topic(),
            ))
            .callback(move |s: Sample| c.count(s.payload()))
            .wait()?,
    );
    let zenoh_queue = session
        .declare_subscriber(Path::ZenohRmwQueue.topic())
        .wait()?;
    let c = counter(Path::ZenohRmwQueue);
    std::thread::spawn(move || {
        while let Ok(sample) = zenoh_queue.recv() {
            c.count(sample.payload());
        }
    });
    // The node's queues keep everything, as Zenoh's channel does: with the
    // default QoS (keep the last 10) a subscriber that falls behind a flood
    // drops the oldest by design, and a rate would count what it dropped.
    let c = counter(Path::NodeInline);
    let node_inline = node
        .declare_subscriber::<RosString>(&Path::NodeInline.topic())
        .callback_inline(move |s| c.count(s.payload()))
        .wait()?;
    let c = counter(Path::NodeCallback);
    let node_callback = node
        .declare_subscriber::<RosString>(&Path::NodeCallback.topic())
        .history(History::KeepAll)
        .callback(move |s| c.count(s.payload()))
        .wait()?;
    let node_queue = Arc::new(
        node.declare_subscriber::<RosString>(&Path::NodeQueue.topic())
            .history(History::KeepAll)
            .wait()?,
    );
    let c = counter(Path::NodeQueue);
    let queue = node_queue.clone();
    std::thread::spawn(move || {
        while let Ok(sample) = queue.recv() {
            c.count(sample.payload());
        }
    });

    let done = session.declare_subscriber(DONE_KEY).wait()?;
    let report_publisher = session
        .declare_publisher(REPORT_KEY)
        .reliability(Reliability::Reliable)
        .congestion_control(CongestionControl::Block)
        .wait()?;
    let mut dropped = BTreeMap::new();
    println!("READY");
    loop {
        if done.try_recv()?.is_some() {
            return Ok(());
        }
        if let Ok(mut report) = reported.recv_timeout(Duration::from_millis(50)) {
            // What a node subscriber counted as dropped from its queue or
            // never arrived, since the previous report of its path.
            let counted = match report.path {
                Path::NodeInline => node_inline.lost() + node_inline.missed(),
                Path::NodeCallback => node_callback.lost() + node_callback.missed(),
                Path::NodeQueue => node_queue.lost() + node_queue.missed(),
                _ => 0,
            };
            let previous = dropped.insert(report.path, counted).unwrap_or(0);
            report.dropped = counted - previous.min(counted);
            report_publisher.put(report.to_bytes()).wait()?;
        }
    }
}

/// The publishing end of every path.
enum Sender<'a> {
    /// A raw Zenoh publisher; with an rmw attachment, its GID and the
    /// sequence number of the next message.
    Zenoh(zenoh::pubsub::Publisher<'a>, Option<(Gid, AtomicI64)>),
    Node(Box<shm_runtime::RosPublisher<RosString>>),
}

fn publisher_side() -> zenoh::Result<()> {
    let quick = std::env::args().any(|a| a == "--quick");
    let rounds = if quick { 3 } else { 9 };
    let args: Vec<String> = std::env::args().collect();
    let paths: Vec<Path> = match list_arg::<String>("--paths")? {
        Some(names) => names
            .iter()
            .map(|name| {
                Path::ALL
                    .into_iter()
                    .find(|p| p.name() == name)
                    .ok_or_else(|| format!("no path named {name:?}"))
            })
            .collect::<Result<_, _>>()?,
        None => Path::ALL.to_vec(),
    };
    let burst_override: Option<u64> = match args.iter().position(|a| a == "--burst") {
        Some(i) => Some(args.get(i + 1).ok_or("--burst needs a number")?.parse()?),
        None => None,
    };
    let sizes: Vec<usize> =
        list_arg("--sizes")?.unwrap_or_else(|| SIZES.iter().map(|s| s.0).collect());
    let Publishing {
        endpoint,
        session,
        shm,
        node,
    } = Publishing::open("rate_publisher", POOL)?;
    let mut senders: BTreeMap<Path, Sender> = BTreeMap::new();
    for path in Path::ALL {
        let sender = if path.is_node() {
            Sender::Node(Box::new(
                node.declare_publisher::<RosString>(&path.topic()).wait()?,
            ))
        } else {
            let publisher = session
                .declare_publisher(path.topic())
                .reliability(Reliability::Reliable)
                .congestion_control(CongestionControl::Block)
                .wait()?;
            let rmw = (path != Path::ZenohBare).then(|| {
                let mut gid = [0u8; 16];
                gid[0] = path as u8 + 1;
                (Gid(gid), AtomicI64::new(1))
            });
            Sender::Zenoh(publisher, rmw)
        };
        senders.insert(path, sender);
    }
    let reports = session.declare_subscriber(REPORT_KEY).wait()?;

    let mut child = spawn_ready(&[("RATE_ROLE", "subscriber"), ("RATE_ENDPOINT", &endpoint)])?;
    for (path, sender) in &senders {
        let matched = match sender {
            Sender::Zenoh(p, _) => {
                wait_matched(|| p.matching_status().wait().is_ok_and(|s| s.matching()))
            }
            Sender::Node(p) => p.wait_for_subscribers(Duration::from_secs(10)),
        };
        if !matched {
            let _ = child.kill();
            return Err(format!("{} never matched", path.label()).into());
        }
    }

    let mut rates: BTreeMap<(usize, Path), Vec<Round>> = BTreeMap::new();
    let outcome = (|| -> zenoh::Result<()> {
        for &(size, _, n) in SIZES.iter().filter(|s| sizes.contains(&s.0)) {
            let n = burst_override.unwrap_or(n);
            let bytes = shm_cdr::to_vec(&message(size))?;
            let fence = shm_cdr::to_vec(&message(FENCE_LEN))?;
            let msg = message(size);
            let fence_msg = message(FENCE_LEN);
            if bytes.len() != size || fence.len() != FENCE_LEN {
                return Err("a message of another size than planned".into());
            }
            for &path in &paths {
                burst(
                    &senders[&path],
                    &shm,
                    &msg,
                    &fence_msg,
                    &bytes,
                    &fence,
                    n / 10,
                )?;
                wait_report(&reports, path)?;
            }
            for round in 0..rounds {
                let mut order = paths.clone();
                fastrand::shuffle(&mut order);
                for path in order {
                    let start = now_ns();
                    let cpu_start = cpu_ns();
                    burst(&senders[&path], &shm, &msg, &fence_msg, &bytes, &fence, n)?;
                    let report = wait_report(&reports, path)?;
                    let publisher_cpu = cpu_ns() - cpu_start;
                    let secs = report.fence_ns.saturating_sub(start) as f64 / 1e9;
                    rates.entry((size, path)).or_default().push(Round {
                        rate: report.received as f64 / secs,
                        lost: n - report.received.min(n),
                        counted: report.dropped,
                        publisher_cpu_ns: publisher_cpu as f64 / n as f64,
                        subscriber_cpu_ns: report.cpu_ns as f64 / n as f64,
                    });
                }
                eprintln!("{size} B: round {} of {rounds}", round + 1);
            }
        }
        Ok(())
    })();
    let _ = session.put(DONE_KEY, "done").wait();
    let _ = child.wait();
    outcome?;
    print_table(&rates);
    Ok(())
}

/// One burst of one path, as measured.
struct Round {
    /// Messages received per second.
    rate: f64,
    /// Messages sent that never reached the application.
    lost: u64,
    /// Of those, the ones the node subscriber counted.
    counted: u64,
    /// CPU time per message sent, of each process (all its threads).
    publisher_cpu_ns: f64,
    subscriber_cpu_ns: f64,
}

fn wait_matched(matched: impl Fn() -> bool) -> bool {
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    while std::time::Instant::now() < deadline {
        if matched() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    false
}

/// `n` messages as fast as they go, then the fence.
fn burst(
    sender: &Sender,
    shm: &ShmContext,
    msg: &RosString,
    fence_msg: &RosString,
    bytes: &[u8],
    fence: &[u8],
    n: u64,
) -> zenoh::Result<()> {
    match sender {
        Sender::Node(p) => {
            for _ in 0..n {
                p.publish(msg).wait()?;
            }
            p.publish(fence_msg).wait()?;
        }
        Sender::Zenoh(p, None) => {
            for _ in 0..n {
                p.put(fresh_buffer(shm, bytes)).wait()?;
            }
            p.put(fence.to_vec()).wait()?;
        }
        Sender::Zenoh(p, Some((gid, sequence))) => {
            // What rmw_zenoh_cpp attaches to every message, and every
            // subscriber of it requires: sequence number, time, GID.
            let attachment = || {
                let attachment = Attachment {
                    sequence_number: sequence.fetch_add(1, Ordering::Relaxed),
                    source_timestamp: std::time::SystemTime::now()
                        .duration_since(std::time::UNIX_EPOCH)
                        .map_or(0, |d| d.as_nanos() as i64),
                    gid: *gid,
                };
                ZBytes::from(attachment.to_bytes())
            };
            for _ in 0..n {
                p.put(fresh_buffer(shm, bytes))
                    .attachment(attachment())
                    .wait()?;
            }
            p.put(fence.to_vec()).attachment(attachment()).wait()?;
        }
    }
    Ok(())
}

/// The message's bytes in a new buffer of the kind a node publisher uses for
/// them: the heap below the threshold, else a chunk of the pool (waiting for
/// one if every chunk is in flight).
fn fresh_buffer(shm: &ShmContext, bytes: &[u8]) -> ZBytes {
    if bytes.len() < THRESHOLD {
        return ZBytes::from(bytes.to_vec());
    }
    loop {
        if let Some(mut chunk) = shm.alloc(bytes.len()) {
            chunk.copy_from_slice(bytes);
            return chunk.into();
        }
        std::thread::yield_now();
    }
}

fn wait_report(
    reports: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<Sample>>,
    path: Path,
) -> zenoh::Result<Report> {
    let sample = reports
        .recv_timeout(REPORT_TIMEOUT)?
        .ok_or_else(|| format!("{}: the fence never arrived", path.label()))?;
    let report =
        Report::parse(&sample.payload().to_bytes()).ok_or("a report that does not parse")?;
    if report.path != path {
        return Err(format!(
            "{}: a report for {} arrived instead",
            path.label(),
            report.path.label()
        )
        .into());
    }
    Ok(report)
}

fn print_table(rates: &BTreeMap<(usize, Path), Vec<Round>>) {
    println!(
        "\n| size | path | messages/s | min–max | × its Zenoh reference | CPU per message: publisher + subscriber | lost |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|");
    for &(size, label, _) in &SIZES {
        for path in Path::ALL {
            let Some(rounds) = rates.get(&(size, path)) else {
                continue;
            };
            let values: Vec<f64> = rounds.iter().map(|r| r.rate).collect();
            let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = values.iter().copied().fold(0.0, f64::max);
            let lost: u64 = rounds.iter().map(|r| r.lost).sum();
            let counted: u64 = rounds.iter().map(|r| r.counted).sum();
            let lost = match path.node_subscribes() {
                true => format!("{lost} ({counted} counted)"),
                false => lost.to_string(),
            };
            let ratio = match path.reference().and_then(|r| rates.get(&(size, r))) {
                Some(reference) => format!(
                    "**{:.2}×**",
                    median(
                        rounds
                            .iter()
                            .zip(reference)
                            .map(|(ours, theirs)| ours.rate / theirs.rate)
                            .collect()
                    )
                ),
                None => "1".into(),
            };
            let publisher = median(rounds.iter().map(|r| r.publisher_cpu_ns).collect());
            let subscriber = median(rounds.iter().map(|r| r.subscriber_cpu_ns).collect());
            println!(
                "| {label} | {} | {} | {}–{} | {ratio} | {:.2} + {:.2} µs | {lost} |",
                path.label(),
                rate(median(values)),
                rate(lo),
                rate(hi),
                publisher / 1e3,
                subscriber / 1e3,
            );
        }
    }
}

fn rate(per_second: f64) -> String {
    if per_second >= 1e6 {
        format!("{:.2} M", per_second / 1e6)
    } else {
        format!("{:.0} k", per_second / 1e3)
    }
}
