//! How fast the recorder keeps up with shared memory: two publisher
//! processes send 8 MiB images as fast as they can, for a few seconds, and
//! the recorder (this process) writes them to a tmpfs and to a disk. Beside
//! each: the write speed of the same target measured in the same run with
//! `dd` (8 MiB blocks of the same total; `conv=fdatasync` where the recording
//! is synced too), and what was published, written, dropped and missed.
//!
//! Then small messages at their highest rate: two publisher processes send
//! 64-character `std_msgs/String`s as fast as they can, over two links at
//! once, and the recorder writes them to the tmpfs; beside it, in the same
//! run, a node in the recorder's place subscribes to both topics with
//! callbacks on Zenoh's threads that only count (the floor a recorder in
//! this process can reach).
//!
//! ```text
//! cargo bench -p shm-bag --bench record_throughput
//! SHM_BAG_BENCH_TMPFS=/dev/shm SHM_BAG_BENCH_DISK=/var/tmp SHM_BAG_BENCH_SECONDS=4 cargo bench -p shm-bag --bench record_throughput
//! ```

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use shm_bag::{RecordOptions, Recorder, Selection};
use shm_cdr::msgs::sensor_msgs::msg::Image;
use shm_cdr::msgs::std_msgs::msg::String as Text;
use shm_runtime::rmw::Qos;
use shm_runtime::{RosNode, ShmConfig, ShmContext};
use zenoh::Wait;

const IMAGE_BYTES: usize = 8 * 1024 * 1024;
const PUBLISHERS: usize = 2;
const ROLE: &str = "SHM_BAG_BENCH_ROLE";
/// The characters of each small message.
const TEXT_CHARS: usize = 64;

/// What the publisher processes send.
#[derive(Clone, Copy)]
enum Traffic {
    Images,
    Texts,
}

impl Traffic {
    fn name(self) -> &'static str {
        match self {
            Traffic::Images => "images",
            Traffic::Texts => "texts",
        }
    }

    fn topic(self, i: usize) -> String {
        match self {
            Traffic::Images => format!("/camera{i}"),
            Traffic::Texts => format!("/small/talker{i}"),
        }
    }
}

fn config(port: u16, listen: bool) -> zenoh::Config {
    shm_runtime::testing::peer_config(port, listen).expect("a peer configuration")
}

/// A camera: 8 MiB `rgba8` images from its own pool of 8 of them, as fast
/// as the recorder frees buffers, for `seconds`; prints how many it sent.
fn publisher(port: u16, topic: &str, seconds: f64) {
    let session = zenoh::open(config(port, false)).wait().expect("a session");
    let pool = ShmContext::new(
        ShmConfig::enabled()
            .pool_size(8 * (IMAGE_BYTES + 4096))
            .alloc_timeout(Duration::from_secs(2)),
    )
    .expect("a pool");
    let node = RosNode::builder(&session, &format!("camera{}", topic.len()))
        .domain_id(0)
        .shm(&pool)
        .wait()
        .expect("a node");
    let publisher = node
        .declare_publisher_with_qos::<Image>(topic, Qos::default())
        .wait()
        .expect("a publisher");
    assert!(publisher.wait_for_subscribers(Duration::from_secs(30)));
    let mut image = Image {
        height: 1024,
        width: 2048,
        encoding: "rgba8".into(),
        step: 2048 * 4,
        data: vec![0x5a; IMAGE_BYTES],
        ..Image::default()
    };
    let start = Instant::now();
    let (mut sent, mut shm) = (0u64, 0u64);
    while start.elapsed().as_secs_f64() < seconds {
        image.header.stamp.nanosec = sent as u32;
        let outcome = publisher.publish(&image).wait().expect("a publish");
        sent += 1;
        shm += u64::from(outcome.kind.is_shm());
    }
    // Close the session before exiting, so that the last messages queued
    // for the network go out instead of dying with the process.
    drop(publisher);
    drop(node);
    session.close().wait().expect("the session closes");
    println!("{sent} {shm}");
}

/// A talker: 64-character strings (heap, below the shared-memory
/// threshold), as fast as `publish` returns, for `seconds`; prints how many
/// it sent.
fn text_publisher(port: u16, topic: &str, seconds: f64) {
    let session = zenoh::open(config(port, false)).wait().expect("a session");
    let node = RosNode::builder(&session, &format!("talker{}", topic.len()))
        .domain_id(0)
        .wait()
        .expect("a node");
    let publisher = node
        .declare_publisher_with_qos::<Text>(topic, Qos::default())
        .wait()
        .expect("a publisher");
    assert!(publisher.wait_for_subscribers(Duration::from_secs(30)));
    let text = Text {
        data: "x".repeat(TEXT_CHARS),
    };
    let start = Instant::now();
    let mut sent = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        publisher.publish(&text).wait().expect("a publish");
        sent += 1;
    }
    drop(publisher);
    drop(node);
    session.close().wait().expect("the session closes");
    println!("{sent} 0");
}

/// Start the publisher processes of `traffic` against a listener on `port`.
fn spawn_publishers(port: u16, traffic: Traffic, seconds: f64) -> Vec<std::process::Child> {
    let exe = std::env::current_exe().expect("this benchmark's path");
    (0..PUBLISHERS)
        .map(|i| {
            Command::new(&exe)
                .env(
                    ROLE,
                    format!("{port} {} {seconds} {}", traffic.topic(i), traffic.name()),
                )
                .stdout(Stdio::piped())
                .spawn()
                .expect("a publisher process")
        })
        .collect()
}

/// What the publishers printed: how many they sent, and of those through
/// shared memory.
fn published(children: Vec<std::process::Child>) -> (u64, u64) {
    let mut totals = (0, 0);
    for child in children {
        let out = child.wait_with_output().expect("a publisher's count");
        // Its panic is on its standard error, above.
        assert!(
            out.status.success(),
            "a publisher process failed: {}",
            out.status
        );
        let text = String::from_utf8_lossy(&out.stdout);
        let mut numbers = text
            .split_whitespace()
            .map(|n| n.parse::<u64>().unwrap_or(0));
        totals.0 += numbers.next().unwrap_or(0);
        totals.1 += numbers.next().unwrap_or(0);
    }
    totals
}

/// The small messages that counting subscribers in the recorder's place
/// receive from the publishers: (published, received).
fn counting_receiver(seconds: f64) -> (u64, u64) {
    let port = shm_runtime::testing::free_port().expect("a free port");
    let session = zenoh::open(config(port, true)).wait().expect("a session");
    let node = RosNode::builder(&session, "counter")
        .domain_id(0)
        .wait()
        .expect("a node");
    let received = Arc::new(AtomicU64::new(0));
    let subscribers: Vec<_> = (0..PUBLISHERS)
        .map(|i| {
            let counter = Arc::clone(&received);
            node.declare_subscriber::<Text>(&Traffic::Texts.topic(i))
                .callback_inline(move |_sample| {
                    counter.fetch_add(1, Ordering::Relaxed);
                })
                .wait()
                .expect("a subscriber")
        })
        .collect();
    let (sent, _) = published(spawn_publishers(port, Traffic::Texts, seconds));
    // What is still on its way arrives within this.
    std::thread::sleep(Duration::from_millis(300));
    drop(subscribers);
    (sent, received.load(Ordering::Relaxed))
}

/// Seconds `dd` takes to write `count` 8 MiB blocks into `dir`.
fn dd_seconds(dir: &Path, count: u64, sync: bool) -> f64 {
    let file = dir.join("shm_bag_bench_dd.bin");
    let start = Instant::now();
    let mut dd = Command::new("dd");
    dd.arg("if=/dev/zero")
        .arg(format!("of={}", file.display()))
        .arg("bs=8M")
        .arg(format!("count={count}"))
        .stderr(Stdio::null());
    if sync {
        dd.arg("conv=fdatasync");
    }
    let status = dd.status().expect("dd runs");
    let seconds = start.elapsed().as_secs_f64();
    assert!(status.success(), "dd failed");
    let _ = std::fs::remove_file(&file);
    seconds
}

struct Run {
    published: u64,
    published_shm: u64,
    written: u64,
    bytes: u64,
    dropped: u64,
    missed: u64,
    seconds: f64,
}

fn record(dir: &Path, seconds: f64, sync: bool, traffic: Traffic) -> Run {
    let port = shm_runtime::testing::free_port().expect("a free port");
    let session = zenoh::open(config(port, true)).wait().expect("a session");
    let bag = dir.join("shm_bag_bench");
    let _ = std::fs::remove_dir_all(&bag);
    let topics = match traffic {
        Traffic::Images => "^/camera",
        Traffic::Texts => "^/small/",
    };
    let selection = Selection {
        regex: Some(regex::Regex::new(topics).expect("a regex")),
        ..Selection::default()
    };
    let mut options = RecordOptions::new(&bag, selection);
    options.domain_id = Some(0);
    let recorder = Recorder::start(&session, options).expect("a recorder");
    let children = spawn_publishers(port, traffic, seconds);
    let deadline = Instant::now() + Duration::from_secs(60);
    while recorder.stats().written == 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_micros(200));
    }
    let start = Instant::now();
    let (published, published_shm) = published(children);
    // Every received message written (or counted as dropped).
    loop {
        let s = recorder.stats();
        if s.written + s.dropped >= s.received && s.queued_bytes == 0 {
            break;
        }
        std::thread::sleep(Duration::from_micros(200));
    }
    let stats = recorder.stats();
    let metadata = recorder.stop().expect("the recording closes");
    if sync {
        for file in &metadata.relative_file_paths {
            std::fs::File::open(bag.join(file))
                .and_then(|f| f.sync_all())
                .expect("the recording syncs");
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&bag);
    Run {
        published,
        published_shm,
        written: stats.written,
        bytes: stats.bytes,
        dropped: stats.dropped,
        missed: stats.missed,
        seconds,
    }
}

fn main() {
    if let Ok(role) = std::env::var(ROLE) {
        let mut parts = role.split(' ');
        let port = parts.next().and_then(|p| p.parse().ok()).expect("a port");
        let topic = parts.next().expect("a topic").to_owned();
        let seconds = parts.next().and_then(|s| s.parse().ok()).expect("seconds");
        match parts.next() {
            Some("texts") => text_publisher(port, &topic, seconds),
            _ => publisher(port, &topic, seconds),
        }
        return;
    }
    if std::env::args().any(|a| a == "--list") {
        return; // cargo bench --list
    }
    let seconds: f64 = std::env::var("SHM_BAG_BENCH_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3.0);
    let targets: Vec<(&str, PathBuf, bool)> = vec![
        (
            "tmpfs",
            std::env::var("SHM_BAG_BENCH_TMPFS").map_or_else(|_| "/dev/shm".into(), PathBuf::from),
            false,
        ),
        (
            "disk",
            std::env::var("SHM_BAG_BENCH_DISK").map_or_else(|_| "/var/tmp".into(), PathBuf::from),
            true,
        ),
    ];
    println!(
        "{PUBLISHERS} publishers of 8 MiB images for {seconds} s a run; medians of {ROUNDS} rounds, dd and the recorder alternating; \
         MB = 10^6 bytes; rosbag2 is published near 110-120 MB/s"
    );
    println!(
        "| target | dd MB/s | recorded MB/s | recorded / dd | published (through SHM) | written | dropped | missed |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, dir, sync) in targets {
        let mut dd_rates = Vec::new();
        let mut rates = Vec::new();
        let mut totals = (0, 0, 0, 0, 0);
        for _ in 0..ROUNDS {
            let run = record(&dir, seconds, sync, Traffic::Images);
            let blocks = run.written.max(1);
            dd_rates
                .push((blocks * IMAGE_BYTES as u64) as f64 / dd_seconds(&dir, blocks, sync) / 1e6);
            rates.push(run.bytes as f64 / run.seconds / 1e6);
            totals.0 += run.published;
            totals.1 += run.published_shm;
            totals.2 += run.written;
            totals.3 += run.dropped;
            totals.4 += run.missed;
        }
        let (dd_rate, rate) = (median(&mut dd_rates), median(&mut rates));
        println!(
            "| {name} ({}) | {dd_rate:.0} | {rate:.0} | {:.2} | {} ({}) | {} | {} | {} |",
            dir.display(),
            rate / dd_rate,
            totals.0,
            totals.1,
            totals.2,
            totals.3,
            totals.4
        );
    }
    small_messages(seconds);
}

/// The second table: small messages over two links at once, recorded to
/// the tmpfs, against counting subscribers of the same traffic; medians of
/// the rates, totals of the counts.
fn small_messages(seconds: f64) {
    let dir =
        std::env::var("SHM_BAG_BENCH_TMPFS").map_or_else(|_| "/dev/shm".into(), PathBuf::from);
    println!();
    println!(
        "{PUBLISHERS} publishers of {TEXT_CHARS}-character std_msgs/String for {seconds} s a run, \
         recorded to {}; medians of {ROUNDS} rounds, the recorder and counting subscribers alternating",
        dir.display()
    );
    println!(
        "| receiver | messages/s | / counting subscribers | published | received or written | dropped | missed |"
    );
    println!("|---|---|---|---|---|---|---|");
    let (mut counted_rates, mut recorded_rates) = (Vec::new(), Vec::new());
    let (mut counted, mut recorded) = ((0, 0), (0, 0, 0, 0));
    for _ in 0..ROUNDS {
        let (sent, received) = counting_receiver(seconds);
        counted_rates.push(received as f64 / seconds);
        counted.0 += sent;
        counted.1 += received;
        let run = record(&dir, seconds, false, Traffic::Texts);
        recorded_rates.push(run.written as f64 / seconds);
        recorded.0 += run.published;
        recorded.1 += run.written;
        recorded.2 += run.dropped;
        recorded.3 += run.missed;
    }
    let (counted_rate, recorded_rate) = (median(&mut counted_rates), median(&mut recorded_rates));
    println!(
        "| counting subscribers (callback_inline) | {counted_rate:.0} | 1.00 | {} | {} | | |",
        counted.0, counted.1
    );
    println!(
        "| recorder | {recorded_rate:.0} | {:.2} | {} | {} | {} | {} |",
        recorded_rate / counted_rate,
        recorded.0,
        recorded.1,
        recorded.2,
        recorded.3
    );
}

const ROUNDS: usize = 3;

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}
