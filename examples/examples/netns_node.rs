//! One end of the cross-host check (`tests/netns/check.py` runs it inside
//! network namespaces):
//!
//! - `netns_node pub <listen endpoint> <count> <subscribers>`: waits until
//!   `<subscribers>` subscribers have said hello, then publishes `count` point
//!   clouds of 256 KiB through a shared-memory pool (threshold 512 B) and prints
//!   `sent <i> <len> <kind> <sha256>` for each;
//! - `netns_node sub <connect endpoint> <count> <name>`: prints
//!   `got <i> <len> shm=<0|1> <sha256>` for each message received.
//!
//! Whether a payload travels as shared memory or as bytes on the wire is
//! Zenoh's decision per link; this program only reports what it saw.

use std::io::Write;
use std::time::Duration;

use sha2::{Digest, Sha256};
use shm_cdr::msgs::sensor_msgs::PointCloud2;
use shm_cdr::msgs::std_msgs::Header;
use shm_cdr_examples::{peer_session, xyzi_fields};
use shm_runtime::ShmOptions;
use shm_runtime::{SessionExt, ShmConfig, ShmContext};
use zenoh::Wait;

type Error = Box<dyn std::error::Error + Send + Sync>;

const TOPIC: &str = "netns/cloud";
const HELLO: &str = "netns/hello";

fn hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn cloud(i: u32) -> PointCloud2 {
    let points = 16 * 1024;
    PointCloud2 {
        header: Header {
            stamp: shm_cdr::msgs::builtin_interfaces::Time { sec: 1, nanosec: i },
            frame_id: "lidar".into(),
        },
        height: 1,
        width: points,
        fields: xyzi_fields(),
        is_bigendian: false,
        point_step: 16,
        row_step: 16 * points,
        data: (0..16 * points as usize)
            .map(|k| (k as u32).wrapping_mul(31) as u8 ^ i as u8)
            .collect(),
        is_dense: true,
    }
}

fn publish(endpoint: &str, count: u32, subscribers: usize) -> Result<(), Error> {
    let session = peer_session(endpoint, true)?;
    let hellos = session.declare_subscriber(HELLO).wait()?;
    let shm = ShmContext::new(ShmConfig::enabled().pool_size_at_most(8 << 20))?;
    let publisher = session
        .declare_ros_publisher::<PointCloud2>(TOPIC)
        .shm(&shm)
        .wait()?;
    let mut seen = std::collections::BTreeSet::new();
    while seen.len() < subscribers {
        let hello = hellos
            .recv_timeout(Duration::from_secs(30))?
            .ok_or("subscribers did not say hello")?;
        seen.insert(hello.payload().try_to_string()?.into_owned());
    }
    // Each subscriber says hello after declaring its subscription, and both
    // travel on the same link, in order: every subscriber is matched now.
    // Wait for their sessions' answers to the pool's probe, so that the first
    // message takes its final path too.
    publisher.wait_for_subscribers(Duration::from_secs(30));
    let mut out = std::io::stdout();
    for i in 0..count {
        let msg = cloud(i);
        let outcome = publisher.publish(&msg).wait()?;
        let bytes = shm_cdr::to_vec(&msg)?;
        writeln!(
            out,
            "sent {i} {} {:?} {}",
            bytes.len(),
            outcome.kind,
            hex(&bytes)
        )?;
        out.flush()?;
        std::thread::sleep(Duration::from_millis(20));
    }
    // Let the last samples drain before the session closes.
    std::thread::sleep(Duration::from_secs(1));
    Ok(())
}

fn subscribe(endpoint: &str, count: u32, name: &str) -> Result<(), Error> {
    let session = peer_session(endpoint, false)?;
    let subscriber = session
        .declare_ros_subscriber::<PointCloud2>(TOPIC)
        .wait()?;
    let hello = session.declare_publisher(HELLO).wait()?;
    let mut out = std::io::stdout();
    let mut received = 0;
    let mut last_hello = std::time::Instant::now() - Duration::from_secs(1);
    while received < count {
        // Say hello until the first message arrives (the publisher may start later).
        if received == 0 && last_hello.elapsed() >= Duration::from_millis(200) {
            hello.put(name).wait()?;
            last_hello = std::time::Instant::now();
        }
        let Some(sample) = subscriber.recv_timeout(Duration::from_millis(200))? else {
            continue;
        };
        let msg: PointCloud2 = sample.decode()?;
        let bytes = sample.payload().to_bytes();
        writeln!(
            out,
            "got {} {} shm={} {}",
            msg.header.stamp.nanosec,
            bytes.len(),
            u8::from(sample.is_shm()),
            hex(&bytes)
        )?;
        out.flush()?;
        received += 1;
    }
    Ok(())
}

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().collect();
    match args.as_slice() {
        [_, role, endpoint, count, extra] if role == "pub" => {
            publish(endpoint, count.parse()?, extra.parse()?)
        }
        [_, role, endpoint, count, name] if role == "sub" => {
            subscribe(endpoint, count.parse()?, name)
        }
        _ => Err(
            "usage: netns_node pub <listen> <count> <subscribers> | sub <connect> <count> <name>"
                .into(),
        ),
    }
}
