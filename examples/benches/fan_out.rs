//! One publisher of 8 MiB `sensor_msgs/Image`s in shared memory, and 1, 4 and
//! 8 subscriber processes: the latency to the last subscriber and what
//! publishing costs the publisher, for a node against raw Zenoh putting a
//! shared-memory buffer to the same number of subscribers.
//!
//! `cargo bench -p shm-cdr-examples --bench fan_out` (`-- --quick`: 12
//! messages a path instead of 40; `-- --subscribers 1,8`: only those counts).
//!
//! This process publishes; for each count it starts that many children of
//! this same binary, each its own Zenoh peer connecting to it over TCP
//! loopback, each subscribing to every path:
//!
//! | path | publisher, per message | subscriber |
//! |---|---|---|
//! | `floor` | Zenoh `put` of a pool chunk filled before the clock starts | Zenoh callback |
//! | `loan` | a node's loan, built in place before the clock starts, then `publish()` | `callback_inline`, borrowed decode |
//! | `publish` | a node's `publish(&Image)` of an owned image: written once into the pool | `callback_inline`, borrowed decode |
//!
//! One message is in flight at a time: the publisher notes the time, sends,
//! and waits until every subscriber has reported when it got the message
//! (CLOCK_MONOTONIC, one clock for all processes) and whether it lay in
//! shared memory. Each subscriber checks the message's sequence number and
//! the last byte of its data, so none reads the 8 MiB (each would, alike,
//! on every path). The paths take turns in a new order for every message; the
//! table gives medians, p90s, and the median of per-turn ratios to the floor.
//! The publisher's CPU time is its process's, all threads, per message.

mod common;

use std::collections::BTreeMap;
use std::process::Child;
use std::time::Duration;

use common::{cpu_ns, list_arg, median, now_ns, spawn_ready, Publishing};
use shm_cdr::loan::InPlace;
use shm_cdr::msgs::sensor_msgs::{Image, ImageLens, ImageRef};
use shm_cdr::msgs::std_msgs::Header;
use shm_cdr_examples::peer_session;
use shm_runtime::{Reach, RosNode, RosPublisher, ShmContext};
use zenoh::qos::{CongestionControl, Reliability};
use zenoh::sample::Sample;
use zenoh::Wait;

/// The image's data: 2048 × 1024 rgba8.
const WIDTH: u32 = 2048;
const HEIGHT: u32 = 1024;
const DATA: usize = (WIDTH * HEIGHT * 4) as usize;
const COUNTS: [usize; 3] = [1, 4, 8];
/// Room for a message in flight, the next one being built and the loan.
const POOL: usize = 64 << 20;
const REPORT_KEY: &str = "fan_out/report";
const DONE_KEY: &str = "fan_out/done";
const FLOOR_KEY: &str = "fan_out/floor";
const TIMEOUT: Duration = Duration::from_secs(20);

#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug)]
#[repr(u8)]
enum Path {
    Floor,
    Loan,
    Publish,
}

impl Path {
    const ALL: [Path; 3] = [Path::Floor, Path::Loan, Path::Publish];

    fn label(self) -> &'static str {
        match self {
            Path::Floor => "floor: zenoh put of a filled pool chunk",
            Path::Loan => "node: loan, built in place, publish()",
            Path::Publish => "node: publish(&Image), written into the pool",
        }
    }

    fn topic(self) -> &'static str {
        match self {
            Path::Floor => FLOOR_KEY,
            Path::Loan => "fan_out_loan",
            Path::Publish => "fan_out_publish",
        }
    }

    fn from_u8(byte: u8) -> Option<Path> {
        Path::ALL.into_iter().find(|p| *p as u8 == byte)
    }
}

/// The last byte of message `seq`'s data.
fn fill_byte(seq: u64) -> u8 {
    (seq % 251) as u8
}

/// Subscriber → publisher: message `seq` of `path` arrived at `at_ns`.
struct Report {
    path: Path,
    seq: u64,
    at_ns: u64,
    shm: bool,
}

impl Report {
    fn to_bytes(&self) -> Vec<u8> {
        let mut out = vec![self.path as u8, self.shm as u8];
        out.extend_from_slice(&self.seq.to_le_bytes());
        out.extend_from_slice(&self.at_ns.to_le_bytes());
        out
    }

    fn parse(bytes: &[u8]) -> Option<Report> {
        let (&[path, shm], rest) = bytes.split_first_chunk::<2>()?;
        let (seq, rest) = rest.split_first_chunk::<8>()?;
        let at: &[u8; 8] = rest.try_into().ok()?;
        Some(Report {
            path: Path::from_u8(path)?,
            seq: u64::from_le_bytes(*seq),
            at_ns: u64::from_le_bytes(*at),
            shm: shm == 1,
        })
    }
}

fn main() {
    let outcome = match std::env::var("FAN_OUT_ROLE").as_deref() {
        Ok("subscriber") => subscriber_side(),
        _ => publisher_side(),
    };
    if let Err(e) = outcome {
        eprintln!("fan_out: {e}");
        std::process::exit(1);
    }
}

fn subscriber_side() -> zenoh::Result<()> {
    let endpoint = std::env::var("FAN_OUT_ENDPOINT")?;
    let name = std::env::var("FAN_OUT_NAME")?;
    let session = peer_session(&endpoint, false)?;
    let node = RosNode::builder(&session, &name).wait()?;
    let reports = session
        .declare_publisher(REPORT_KEY)
        .reliability(Reliability::Reliable)
        .congestion_control(CongestionControl::Block)
        .wait()?;
    let reports = std::sync::Arc::new(reports);

    let out = reports.clone();
    let _floor = session
        .declare_subscriber(FLOOR_KEY)
        .callback(move |sample: Sample| {
            let at_ns = now_ns();
            let payload = sample.payload();
            let Some(shm) = payload.as_shm() else {
                return report(&out, Path::Floor, u64::MAX, at_ns, false);
            };
            let bytes: &[u8] = shm;
            let seq = bytes
                .first_chunk::<8>()
                .map_or(u64::MAX, |s| u64::from_le_bytes(*s));
            let seq = match bytes.len() == DATA && bytes.last() == Some(&fill_byte(seq)) {
                true => seq,
                false => u64::MAX,
            };
            report(&out, Path::Floor, seq, at_ns, true);
        })
        .wait()?;
    let mut keep = Vec::new();
    for path in [Path::Loan, Path::Publish] {
        let out = reports.clone();
        keep.push(
            node.declare_subscriber::<Image>(path.topic())
                .callback_inline(move |sample| {
                    let at_ns = now_ns();
                    let seq = match sample.decode::<ImageRef>() {
                        Ok(image)
                            if image.data.len() == DATA
                                && image.data.last()
                                    == Some(&fill_byte(image.header.stamp.sec as u64)) =>
                        {
                            image.header.stamp.sec as u64
                        }
                        _ => u64::MAX,
                    };
                    report(&out, path, seq, at_ns, sample.is_shm());
                })
                .wait()?,
        );
    }
    let done = session.declare_subscriber(DONE_KEY).wait()?;
    println!("READY");
    // Until the publisher is done, or gone.
    let _ = done.recv_timeout(Duration::from_secs(3600));
    Ok(())
}

fn report(out: &zenoh::pubsub::Publisher<'_>, path: Path, seq: u64, at_ns: u64, shm: bool) {
    let report = Report {
        path,
        seq,
        at_ns,
        shm,
    };
    if let Err(e) = out.put(report.to_bytes()).wait() {
        eprintln!("fan_out subscriber: could not report: {e}");
    }
}

fn header(seq: u64) -> Header {
    let mut header = Header::default();
    header.stamp.sec = seq as i32;
    header.frame_id = "camera".into();
    header
}

/// Image `seq` without its data.
fn template(seq: u64) -> Image {
    Image {
        header: header(seq),
        height: HEIGHT,
        width: WIDTH,
        encoding: "rgba8".into(),
        is_bigendian: 0,
        step: WIDTH * 4,
        data: Vec::new(),
    }
}

fn image(seq: u64) -> Image {
    let mut data = vec![0u8; DATA];
    if let Some(last) = data.last_mut() {
        *last = fill_byte(seq);
    }
    Image {
        data,
        ..template(seq)
    }
}

/// One message of `path`, ready to send: what the clock leaves out.
enum Ready<'p> {
    Floor(zenoh::shm::ZShmMut),
    Loan(shm_runtime::Loan<'p, Image>),
    Publish(Box<Image>),
}

struct Publishers {
    floor: zenoh::pubsub::Publisher<'static>,
    loan: RosPublisher<Image>,
    publish: RosPublisher<Image>,
}

impl Publishers {
    fn prepare(&self, shm: &ShmContext, path: Path, seq: u64) -> zenoh::Result<Ready<'_>> {
        Ok(match path {
            Path::Floor => {
                let deadline = std::time::Instant::now() + TIMEOUT;
                let mut chunk = loop {
                    if let Some(chunk) = shm.alloc(DATA) {
                        break chunk;
                    }
                    if std::time::Instant::now() > deadline {
                        return Err("the pool never had room for the floor's chunk".into());
                    }
                    std::thread::sleep(Duration::from_millis(1));
                };
                chunk.fill(0);
                chunk[..8].copy_from_slice(&seq.to_le_bytes());
                if let Some(last) = chunk.last_mut() {
                    *last = fill_byte(seq);
                }
                Ready::Floor(chunk)
            }
            Path::Loan => {
                let lens = ImageLens {
                    data: DATA,
                    ..InPlace::lens(&template(seq))
                };
                let mut loan = self.loan.loan(lens)?;
                let fields = loan.fields()?;
                *fields.header.stamp.sec = seq as i32;
                fields.header.frame_id.write("camera")?;
                *fields.height = HEIGHT;
                *fields.width = WIDTH;
                fields.encoding.write("rgba8")?;
                *fields.is_bigendian = 0;
                *fields.step = WIDTH * 4;
                let data = fields.data.fill(0);
                if let Some(last) = data.last_mut() {
                    *last = fill_byte(seq);
                }
                Ready::Loan(loan)
            }
            Path::Publish => Ready::Publish(Box::new(image(seq))),
        })
    }

    fn send(&self, ready: Ready<'_>) -> zenoh::Result<()> {
        match ready {
            Ready::Floor(chunk) => self.floor.put(chunk).wait()?,
            Ready::Loan(loan) => {
                loan.publish().wait()?;
            }
            Ready::Publish(image) => {
                self.publish.publish(&image).wait()?;
            }
        }
        Ok(())
    }
}

/// One message of one path, as measured.
struct Turn {
    /// From just before sending to the last subscriber's arrival, and to the first's.
    last_ns: u64,
    first_ns: u64,
    /// How long the send call took.
    send_ns: u64,
    /// The publishing process's CPU time from just before sending to the
    /// last arrival.
    cpu_ns: u64,
    /// How many subscribers got it in shared memory.
    in_shm: usize,
}

fn publisher_side() -> zenoh::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let messages = if quick { 12 } else { 40 };
    let counts: Vec<usize> = list_arg("--subscribers")?.unwrap_or_else(|| COUNTS.to_vec());
    let Publishing {
        endpoint,
        session,
        shm,
        node,
    } = Publishing::open("fan_out_publisher", POOL)?;
    let publishers = Publishers {
        floor: session
            .declare_publisher(FLOOR_KEY)
            .reliability(Reliability::Reliable)
            .congestion_control(CongestionControl::Block)
            .wait()?,
        loan: node.declare_publisher::<Image>(Path::Loan.topic()).wait()?,
        publish: node
            .declare_publisher::<Image>(Path::Publish.topic())
            .wait()?,
    };
    let reports = session.declare_subscriber(REPORT_KEY).wait()?;

    let mut turns: BTreeMap<(usize, Path), Vec<Turn>> = BTreeMap::new();
    let mut seq = 0u64;
    for &count in &counts {
        let mut children = Vec::new();
        let outcome = (|| -> zenoh::Result<()> {
            for i in 0..count {
                children.push(spawn_subscriber(&endpoint, i)?);
            }
            for path in [Path::Loan, Path::Publish] {
                let publisher = match path {
                    Path::Loan => &publishers.loan,
                    _ => &publishers.publish,
                };
                wait_for_receivers(publisher, count)?;
            }
            // Every subscriber reached on every path before the clock.
            for path in Path::ALL {
                seq += 1;
                one_message(&publishers, &shm, &reports, path, seq, count)?;
            }
            for turn in 0..messages {
                let mut order = Path::ALL.to_vec();
                fastrand::shuffle(&mut order);
                for path in order {
                    seq += 1;
                    let measured = one_message(&publishers, &shm, &reports, path, seq, count)?;
                    turns.entry((count, path)).or_default().push(measured);
                }
                if (turn + 1) % 10 == 0 {
                    eprintln!("{count} subscribers: {} of {messages}", turn + 1);
                }
            }
            Ok(())
        })();
        let _ = session.put(DONE_KEY, "done").wait();
        for mut child in children {
            if !matches!(child.wait(), Ok(status) if status.success()) {
                eprintln!("fan_out: a subscriber process failed");
            }
        }
        outcome?;
    }
    print_table(&turns, messages);
    Ok(())
}

fn spawn_subscriber(endpoint: &str, i: usize) -> zenoh::Result<Child> {
    spawn_ready(&[
        ("FAN_OUT_ROLE", "subscriber"),
        ("FAN_OUT_ENDPOINT", endpoint),
        ("FAN_OUT_NAME", &format!("fan_out_subscriber_{i}")),
    ])
}

/// Wait until `count` sessions subscribe to `publisher`, each mapping its pool.
fn wait_for_receivers(publisher: &RosPublisher<Image>, count: usize) -> zenoh::Result<()> {
    let deadline = std::time::Instant::now() + TIMEOUT;
    loop {
        let receivers = publisher.receivers();
        if receivers.len() == count && receivers.iter().all(|r| r.reach == Reach::SharedMemory) {
            return Ok(());
        }
        if std::time::Instant::now() > deadline {
            return Err(format!(
                "{}: {count} subscribing sessions mapping the pool expected, found {receivers:?}",
                publisher.key_expr()
            )
            .into());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Send message `seq` of `path` and wait for every subscriber's report.
fn one_message(
    publishers: &Publishers,
    shm: &ShmContext,
    reports: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<Sample>>,
    path: Path,
    seq: u64,
    count: usize,
) -> zenoh::Result<Turn> {
    let ready = publishers.prepare(shm, path, seq)?;
    let cpu_start = cpu_ns();
    let start = now_ns();
    publishers.send(ready)?;
    let sent = now_ns();
    let mut arrivals = Vec::with_capacity(count);
    let mut in_shm = 0;
    let deadline = std::time::Instant::now() + TIMEOUT;
    while arrivals.len() < count {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        let sample = reports.recv_timeout(left)?.ok_or_else(|| {
            format!(
                "{}: {} of {count} subscribers reported message {seq}",
                path.label(),
                arrivals.len()
            )
        })?;
        let report =
            Report::parse(&sample.payload().to_bytes()).ok_or("a report that does not parse")?;
        if report.path != path || report.seq != seq {
            return Err(format!(
                "{}: message {seq} expected, a subscriber reported {} of {} (a wrong or damaged message)",
                path.label(),
                report.seq,
                report.path.label()
            )
            .into());
        }
        arrivals.push(report.at_ns);
        in_shm += usize::from(report.shm);
    }
    let cpu = cpu_ns() - cpu_start;
    let first = arrivals.iter().copied().min().unwrap_or(start);
    let last = arrivals.iter().copied().max().unwrap_or(start);
    Ok(Turn {
        last_ns: last.saturating_sub(start),
        first_ns: first.saturating_sub(start),
        send_ns: sent - start,
        cpu_ns: cpu,
        in_shm,
    })
}

fn percentile(mut values: Vec<f64>, p: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    match values.len() {
        0 => f64::NAN,
        n => values[((n - 1) as f64 * p).round() as usize],
    }
}

fn print_table(turns: &BTreeMap<(usize, Path), Vec<Turn>>, messages: usize) {
    println!(
        "\n| subscribers | path | to the last | × floor | to the first | send call | publisher CPU per message | in shared memory |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|");
    for (&(count, path), rounds) in turns {
        let us = |f: fn(&Turn) -> u64| -> Vec<f64> {
            rounds.iter().map(|t| f(t) as f64 / 1e3).collect()
        };
        let ratio = match (path, turns.get(&(count, Path::Floor))) {
            (Path::Floor, _) | (_, None) => String::new(),
            (_, Some(floor)) => format!(
                "**{:.2}×**",
                median(
                    rounds
                        .iter()
                        .zip(floor)
                        .map(|(ours, floor)| ours.last_ns as f64 / floor.last_ns as f64)
                        .collect()
                )
            ),
        };
        let in_shm: usize = rounds.iter().map(|t| t.in_shm).sum();
        println!(
            "| {count} | {} | {:.0} µs (p90 {:.0}) | {ratio} | {:.0} µs | {:.0} µs | {:.0} µs | {in_shm} of {} |",
            path.label(),
            median(us(|t| t.last_ns)),
            percentile(us(|t| t.last_ns), 0.9),
            median(us(|t| t.first_ns)),
            median(us(|t| t.send_ns)),
            median(us(|t| t.cpu_ns)),
            messages * count,
        );
    }
}
