//! What recovery costs per message: a plain reliable Zenoh publisher
//! (`Block`) and subscriber against the zenoh-ext pair that shm-runtime's
//! `PublisherBuilder::recovery` / `SubscriberBuilder::recovery` declare: an
//! `AdvancedPublisher` with a sample cache, periodic heartbeats and congestion
//! control `Drop`, and an `AdvancedSubscriber` with heartbeat recovery.
//!
//! Two peer sessions in this process over TCP loopback, one message in flight,
//! the two pairs interleaved round by round so both see the same machine. Each
//! round builds its payload before the clock; the clock covers `put` until the
//! subscriber's callback has handed the sample over. `put` alone is timed too.
//!
//! `cargo bench -p shm-cdr-examples --bench recovery_cost` prints a table of
//! medians and p90s.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use zenoh::bytes::ZBytes;
use zenoh::qos::{CongestionControl, Reliability};
use zenoh::sample::Sample;
use zenoh::{Config, Session, Wait};
use zenoh_ext::{
    AdvancedPublisherBuilderExt, AdvancedSubscriberBuilderExt, CacheConfig, MissDetectionConfig,
    RecoveryConfig,
};

const SIZES: [(usize, &str); 4] = [
    (64, "64 B"),
    (4 << 10, "4 KiB"),
    (64 << 10, "64 KiB"),
    (1 << 20, "1 MiB"),
];
const TIMEOUT: Duration = Duration::from_secs(10);
/// The depth of ROS 2's default profile (keep last 10).
const CACHE: usize = 10;
const HEARTBEAT: Duration = Duration::from_millis(500);

fn sessions() -> (Session, Session) {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port();
    let config = |key: &str| {
        let mut c = Config::default();
        for (k, v) in [
            ("mode", "\"peer\""),
            ("scouting/multicast/enabled", "false"),
            ("transport/shared_memory/enabled", "false"),
            (key, &format!("[\"tcp/127.0.0.1:{port}\"]")),
        ] {
            c.insert_json5(k, v).expect("config");
        }
        c
    };
    let a = zenoh::open(config("listen/endpoints"))
        .wait()
        .expect("open");
    let b = zenoh::open(config("connect/endpoints"))
        .wait()
        .expect("open");
    (a, b)
}

fn rounds(bytes: usize) -> usize {
    match bytes {
        0..=65536 => 3000,
        _ => 600,
    }
}

/// Median and p90 in µs.
fn stats(mut samples: Vec<Duration>) -> (f64, f64) {
    samples.sort_unstable();
    let at = |q: f64| samples[((samples.len() - 1) as f64 * q) as usize].as_secs_f64() * 1e6;
    (at(0.5), at(0.9))
}

struct Pair {
    put: Box<dyn Fn(ZBytes)>,
    received: mpsc::Receiver<Sample>,
    /// Keeps the subscriber declared.
    _subscriber: Box<dyn std::any::Any>,
    round: Vec<Duration>,
    put_only: Vec<Duration>,
}

impl Pair {
    fn new(
        put: Box<dyn Fn(ZBytes)>,
        received: mpsc::Receiver<Sample>,
        subscriber: Box<dyn std::any::Any>,
    ) -> Pair {
        Pair {
            put,
            received,
            _subscriber: subscriber,
            round: Vec::new(),
            put_only: Vec::new(),
        }
    }

    fn measure(&mut self, payload: ZBytes) {
        let t = Instant::now();
        (self.put)(payload);
        let put = t.elapsed();
        let sample = self.received.recv_timeout(TIMEOUT).expect("a sample");
        let round = t.elapsed();
        std::hint::black_box(sample.payload().len());
        self.put_only.push(put);
        self.round.push(round);
    }
}

fn main() {
    let (a, b) = sessions();
    let (plain_tx, plain_rx) = mpsc::channel();
    let plain_sub = b
        .declare_subscriber("bench/plain")
        .callback(move |s| {
            let _ = plain_tx.send(s);
        })
        .wait()
        .expect("subscriber");
    let plain_pub = a
        .declare_publisher("bench/plain")
        .reliability(Reliability::Reliable)
        .congestion_control(CongestionControl::Block)
        .wait()
        .expect("publisher");
    let (adv_tx, adv_rx) = mpsc::channel();
    let adv_sub = b
        .declare_subscriber("bench/advanced")
        .callback(move |s| {
            let _ = adv_tx.send(s);
        })
        .recovery(RecoveryConfig::default().heartbeat())
        .wait()
        .expect("advanced subscriber");
    let adv_pub = a
        .declare_publisher("bench/advanced")
        .reliability(Reliability::Reliable)
        .congestion_control(CongestionControl::Drop)
        .cache(CacheConfig::default().max_samples(CACHE))
        .sample_miss_detection(MissDetectionConfig::default().heartbeat(HEARTBEAT))
        .wait()
        .expect("advanced publisher");
    // Both publishers see their subscriber before the first round.
    let deadline = Instant::now() + TIMEOUT;
    while !(plain_pub
        .matching_status()
        .wait()
        .is_ok_and(|s| s.matching())
        && adv_pub.matching_status().wait().is_ok_and(|s| s.matching()))
    {
        assert!(Instant::now() < deadline, "no subscriber matched");
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(300));

    let mut plain = Pair::new(
        Box::new(move |p| plain_pub.put(p).wait().expect("put")),
        plain_rx,
        Box::new(plain_sub),
    );
    let mut advanced = Pair::new(
        Box::new(move |p| adv_pub.put(p).wait().expect("put")),
        adv_rx,
        Box::new(adv_sub),
    );

    println!(
        "plain reliable publisher/subscriber (Block) against recovery's zenoh-ext pair \
         (cache {CACHE}, heartbeat every {HEARTBEAT:?}, Drop, subscriber recovery), \
         TCP loopback, heap payloads; µs"
    );
    println!();
    println!(
        "| size | plain: put → received, median (p90) | advanced | ratio | put alone: plain | advanced |"
    );
    println!("|---|---|---|---|---|---|");
    for (bytes, label) in SIZES {
        let data = vec![0x5au8; bytes];
        // Warm-up rounds, not kept.
        for _ in 0..50 {
            plain.measure(ZBytes::from(data.clone()));
            advanced.measure(ZBytes::from(data.clone()));
        }
        for pair in [&mut plain, &mut advanced] {
            pair.round.clear();
            pair.put_only.clear();
        }
        for i in 0..rounds(bytes) {
            // Alternate which goes first, so neither always follows the other.
            if i % 2 == 0 {
                plain.measure(ZBytes::from(data.clone()));
                advanced.measure(ZBytes::from(data.clone()));
            } else {
                advanced.measure(ZBytes::from(data.clone()));
                plain.measure(ZBytes::from(data.clone()));
            }
        }
        let (p50, p90) = stats(std::mem::take(&mut plain.round));
        let (a50, a90) = stats(std::mem::take(&mut advanced.round));
        let (pp, _) = stats(std::mem::take(&mut plain.put_only));
        let (ap, _) = stats(std::mem::take(&mut advanced.put_only));
        println!(
            "| {label} | {p50:.1} ({p90:.1}) | {a50:.1} ({a90:.1}) | {:.2}× | {pp:.1} | {ap:.1} |",
            a50 / p50
        );
    }
}
