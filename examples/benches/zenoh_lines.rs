//! Round trip of a `sensor_msgs/Image` loaned from a `RosNode` publisher's pool
//! to a plain Zenoh peer in another process and back, for the peer built on
//! each Zenoh line: 1.8.0 (what every rmw_zenoh_cpp release ships), the
//! workspace's own line (the floor: same version on both sides) and 1.10.2
//! (whose shared memory differs, so the image crosses as a copy).
//!
//! ```sh
//! cargo build --release -p shm-cdr-examples --example zenoh_peer
//! for line in 1.8 1.10; do
//!     cargo build --release --locked --manifest-path tests/zenoh-lines/$line/Cargo.toml \
//!         --target-dir target/zenoh-lines/$line
//! done
//! cargo bench -p shm-cdr-examples --bench zenoh_lines     # -- --quick: a fifth of the rounds
//! ```
//!
//! Each peer (`zenoh_peer echo`) subscribes to a topic of its own with an
//! rmw_zenoh_cpp liveliness token, checks every byte of each image where it
//! arrived, and answers with 6 bytes: the sequence number, whether the image
//! came in shared memory, whether it was exact. The clock runs from just
//! before `publish` (the loan already filled) until the answer is in hand, one
//! image in flight. The peers take turns in a fresh random order every round,
//! so drift hits them alike; the last column is the median over rounds of
//! each round's ratio to the floor. A wrong or lost image fails the run.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use shm_cdr::msgs::sensor_msgs::{Image, ImageLens};
use shm_cdr::msgs::std_msgs::HeaderLens;
use shm_runtime::rmw::EntityKind;
use shm_runtime::{Reach, RosNode, RosPublisher, ShmConfig, ShmContext};
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::Wait;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error + Send + Sync>>;

const ENDPOINT: &str = "tcp/127.0.0.1:17640";
const POOL: usize = 96 << 20;
const WARMUP: usize = 20;
const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);
const SIZES: [(&str, usize, usize); 3] = [
    ("1 KiB", 1 << 10, 500),
    ("1 MiB", 1 << 20, 300),
    ("8 MiB", 8 << 20, 100),
];

/// A peer build: its Zenoh version, who ships that line, its binary.
struct Line {
    version: String,
    shipped_by: &'static str,
    binary: PathBuf,
}

/// The version a Cargo.lock pins for `zenoh`.
fn locked_zenoh(lock_file: &PathBuf) -> Result<String> {
    let text =
        std::fs::read_to_string(lock_file).map_err(|e| format!("{}: {e}", lock_file.display()))?;
    let marker = "name = \"zenoh\"\nversion = \"";
    let rest = text
        .find(marker)
        .map(|at| &text[at + marker.len()..])
        .ok_or_else(|| format!("{}: no zenoh package", lock_file.display()))?;
    Ok(rest[..rest.find('"').unwrap_or(0)].to_owned())
}

fn lines() -> Result<Vec<Line>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root.join("target"), PathBuf::from);
    let lines = vec![
        Line {
            version: locked_zenoh(&root.join("Cargo.lock"))?,
            shipped_by: "this workspace (floor)",
            binary: target.join("release/examples/zenoh_peer"),
        },
        Line {
            version: locked_zenoh(&root.join("tests/zenoh-lines/1.8/Cargo.lock"))?,
            shipped_by: "rmw_zenoh_cpp, every distribution",
            binary: target.join("zenoh-lines/1.8/release/zenoh_peer"),
        },
        Line {
            version: locked_zenoh(&root.join("tests/zenoh-lines/1.10/Cargo.lock"))?,
            shipped_by: "newer Zenoh",
            binary: target.join("zenoh-lines/1.10/release/zenoh_peer"),
        },
    ];
    for line in &lines {
        if !line.binary.exists() {
            return Err(format!(
                "{} is missing: build the peers first (see this bench's header)",
                line.binary.display()
            )
            .into());
        }
    }
    Ok(lines)
}

/// The value every image carries at `i` of its data, for image `seq`, as
/// `zenoh_peer` checks it.
fn pixel(seq: u32, i: usize) -> u8 {
    (i as u32).wrapping_mul(31).wrapping_add(seq) as u8
}

/// One peer at work: its process, our publisher to it, its answers.
struct Peer {
    child: Child,
    publisher: RosPublisher<Image>,
    answers: Subscriber<FifoChannelHandler<Sample>>,
}

impl Peer {
    fn start(
        node: &RosNode,
        session: &zenoh::Session,
        line: &Line,
        index: usize,
        data: usize,
        count: usize,
    ) -> Result<Self> {
        let topic = format!("/bench/line{index}");
        let publisher = node.declare_publisher::<Image>(topic.as_str()).wait()?;
        let pong_key = format!("bench/pong{index}");
        let answers = session.declare_subscriber(pong_key.as_str()).wait()?;
        let token = shm_cdr_examples::zenoh_peer_token::<Image>(&topic, EntityKind::Subscriber);
        let mut child = Command::new(&line.binary)
            .args(["echo", ENDPOINT, publisher.key_expr(), &token])
            .args([count.to_string(), data.to_string(), "600".into(), pong_key])
            .stdout(Stdio::piped())
            .spawn()?;
        let stdout = child.stdout.take().ok_or("no stdout")?;
        let mut ready = String::new();
        BufReader::new(stdout).read_line(&mut ready)?;
        if !ready.starts_with("READY") {
            let _ = child.kill();
            return Err(format!("{}: {ready:?}", line.binary.display()).into());
        }
        Ok(Self {
            child,
            publisher,
            answers,
        })
    }

    /// Wait until the peer's subscriber is matched and its path settled.
    fn settle(&self) -> Result<Reach> {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let settled = self
                .publisher
                .receivers()
                .into_iter()
                .find(|r| r.reach != Reach::Checking);
            if let Some(peer) = settled.filter(|_| self.publisher.has_subscribers()) {
                return Ok(peer.reach);
            }
            if Instant::now() > deadline {
                return Err("a peer's subscriber did not show within 20 s".into());
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Publish image `seq` from a loan and wait for the answer: the time
    /// from the publish call to the answer, and whether it came in shared
    /// memory.
    fn round_trip(&self, seq: u32, data: usize) -> Result<(Duration, bool)> {
        let mut loan = self.publisher.loan(ImageLens {
            header: HeaderLens {
                frame_id: "peer".len(),
                ..Default::default()
            },
            encoding: "mono8".len(),
            data,
            ..Default::default()
        })?;
        let image = loan.fields()?;
        *image.header.stamp.sec = seq as i32;
        *image.header.stamp.nanosec = 0;
        image.header.frame_id.write("peer")?;
        *image.height = 1;
        *image.width = data as u32;
        image.encoding.write("mono8")?;
        *image.is_bigendian = 0;
        *image.step = data as u32;
        image.data.write_with(|i| pixel(seq, i));
        let start = Instant::now();
        loan.publish().wait()?;
        let answer = self
            .answers
            .recv_timeout(ANSWER_TIMEOUT)?
            .ok_or("no answer within 10 s: an image was lost")?;
        let elapsed = start.elapsed();
        let answer = answer.payload().to_bytes();
        let (Some(echoed), Some(&shm), Some(&exact)) =
            (answer.get(..4), answer.get(4), answer.get(5))
        else {
            return Err(format!("malformed answer {answer:?}").into());
        };
        if echoed != seq.to_le_bytes() || exact != 1 {
            return Err(
                format!("image {seq} of {data} bytes arrived wrong: answer {answer:?}").into(),
            );
        }
        Ok((elapsed, shm == 1))
    }
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    percentile(values, 0.5)
}

fn main() -> Result<()> {
    let quick = std::env::args().any(|a| a == "--quick");
    let lines = lines()?;
    let session = shm_cdr_examples::peer_session(ENDPOINT, true)?;
    let shm = ShmContext::new(ShmConfig::enabled().pool_size(POOL))?;
    let node = RosNode::builder(&session, "zenoh_lines_bench")
        .shm(&shm)
        .wait()?;
    println!("| image | peer's Zenoh | shipped by | reach | in shared memory | median µs | p90 µs | vs floor |");
    println!("|---|---|---|---|---|---:|---:|---:|");
    for (label, data, full_rounds) in SIZES {
        let rounds = if quick { full_rounds / 5 } else { full_rounds };
        let peers = lines
            .iter()
            .enumerate()
            .map(|(i, line)| Peer::start(&node, &session, line, i, data, WARMUP + rounds))
            .collect::<Result<Vec<_>>>()?;
        let reaches = peers.iter().map(Peer::settle).collect::<Result<Vec<_>>>()?;
        let mut seq = 0u32;
        for _ in 0..WARMUP {
            for peer in &peers {
                peer.round_trip(seq, data)?;
                seq += 1;
            }
        }
        // Per peer: each round's time (µs) and how many came in shared memory.
        let mut times = vec![Vec::with_capacity(rounds); peers.len()];
        let mut in_shm = vec![0usize; peers.len()];
        let mut order: Vec<usize> = (0..peers.len()).collect();
        for _ in 0..rounds {
            fastrand::shuffle(&mut order);
            for &i in &order {
                let (elapsed, shm) = peers[i].round_trip(seq, data)?;
                seq += 1;
                times[i].push(elapsed.as_secs_f64() * 1e6);
                in_shm[i] += usize::from(shm);
            }
        }
        for (i, line) in lines.iter().enumerate() {
            let mut ratios: Vec<f64> = times[i].iter().zip(&times[0]).map(|(t, f)| t / f).collect();
            let mut sorted = times[i].clone();
            sorted.sort_by(f64::total_cmp);
            println!(
                "| {label} | {} | {} | {:?} | {}/{rounds} | {:.1} | {:.1} | {:.2}× |",
                line.version,
                line.shipped_by,
                reaches[i],
                in_shm[i],
                percentile(&sorted, 0.5),
                percentile(&sorted, 0.9),
                median(&mut ratios),
            );
        }
        for mut peer in peers {
            let status = peer.child.wait()?;
            if !status.success() {
                return Err(format!("a peer exited with {status}").into());
            }
        }
    }
    Ok(())
}
