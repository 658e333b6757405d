//! Our side of `tests/zenoh-lines/check.py`: a `RosNode` publishing or
//! receiving `sensor_msgs/Image` on `camera/image` with a shared-memory
//! pool, against `zenoh_peer` built on another Zenoh line.
//!
//! ```text
//! zenoh_lines publish <endpoint> <data bytes> <count>
//! zenoh_lines subscribe <endpoint> <data bytes> <count> <timeout s>
//! ```
//!
//! The endpoint is listened on, or connected to if written
//! `connect:<endpoint>`, so that two of ours (on two Zenoh lines, say) can
//! pair up.
//!
//! Both first print `KEY <key expression>` and `PEER_TOKEN <template>`: the
//! rmw_zenoh key of the topic and the liveliness token the peer declares
//! (`{zid}` standing for its session), as an rmw_zenoh_cpp endpoint of the
//! other kind on the same topic would. Then `publish` waits until it sees
//! the peer's subscriber, publishes, and prints what its publisher reported
//! (payload kinds, `copied_to`, the peer's `Reach`, the pool's stats);
//! `subscribe` prints how many images arrived, how many in shared memory
//! (`RosSample::is_shm`) and how many equal to the peer's, field by field.
//! Each report is one JSON line.
//!
//! It names only `zenoh` and `shm_runtime` (and `shm_cdr` through it), so the
//! same file builds outside this workspace on each Zenoh line the runtime
//! accepts (`tests/zenoh-lines/<line>/`).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

#[path = "../src/peer.rs"]
mod peer;

use shm_runtime::shm_cdr;

use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::sensor_msgs::Image;
use shm_cdr::msgs::std_msgs::Header;
use shm_runtime::rmw::EntityKind;
use shm_runtime::{History, Reach, RosNode, ShmConfig, ShmContext, ZenohLine};
use zenoh::Wait;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error + Send + Sync>>;

const TOPIC: &str = "camera/image";
/// Room for every image of the largest run (10 of 8 MiB) at once: a receiver
/// may hold them all before it releases one (a peer built without
/// optimization checks slower than images arrive), and the check counts each
/// image in shared memory.
const POOL: usize = 96 << 20;

/// The image `zenoh_peer` writes as number `seq`.
fn image(seq: u32, data: usize) -> Image {
    Image {
        header: Header {
            stamp: Time {
                sec: seq as i32,
                nanosec: 0,
            },
            frame_id: "peer".into(),
        },
        height: 1,
        width: data as u32,
        encoding: "mono8".into(),
        is_bigendian: 0,
        step: data as u32,
        data: (0..data)
            .map(|i| (i as u32).wrapping_mul(31).wrapping_add(seq) as u8)
            .collect(),
    }
}

/// The token of the peer's endpoint of `kind` on the topic.
fn peer_token(kind: EntityKind) -> String {
    peer::zenoh_peer_token::<Image>(&format!("/{TOPIC}"), kind)
}

/// `endpoint` is listened on, or connected to when written `connect:<endpoint>`
/// (two of our processes on one endpoint).
fn node(endpoint: &str, name: &str) -> Result<(zenoh::Session, ShmContext, RosNode)> {
    let session = match endpoint.strip_prefix("connect:") {
        Some(endpoint) => peer::peer_session(endpoint, false)?,
        None => peer::peer_session(endpoint, true)?,
    };
    let shm = ShmContext::new(ShmConfig::enabled().pool_size(POOL))?;
    let node = RosNode::builder(&session, name).shm(&shm).wait()?;
    Ok((session, shm, node))
}

fn publish(endpoint: &str, data: usize, count: u32) -> Result<()> {
    let (_session, shm, node) = node(endpoint, "zenoh_lines_publisher")?;
    let publisher = node.declare_publisher::<Image>(TOPIC).wait()?;
    println!("KEY {}", publisher.key_expr());
    println!("PEER_TOKEN {}", peer_token(EntityKind::Subscriber));
    // The peer's subscriber, seen through its graph token, with its link.
    let deadline = Instant::now() + Duration::from_secs(20);
    let peer = loop {
        let settled = publisher
            .receivers()
            .into_iter()
            .find(|r| r.reach != Reach::Checking);
        if let Some(peer) = settled.filter(|_| publisher.has_subscribers()) {
            break peer;
        }
        if Instant::now() > deadline {
            return Err("the peer's subscriber did not show within 20 s".into());
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut kinds: BTreeMap<String, u32> = BTreeMap::new();
    let mut copied_to = 0;
    for seq in 0..count {
        let outcome = publisher.publish(&image(seq, data)).wait()?;
        *kinds.entry(format!("{:?}", outcome.kind)).or_default() += 1;
        copied_to += outcome.copied_to;
        std::thread::sleep(Duration::from_millis(5));
    }
    let stats = shm.stats();
    println!(
        r#"{{"published": {count}, "kinds": {}, "copied_to": {copied_to}, "reach": "{:?}", "stats_shm": {}, "stats_copied": {}, "zenoh_line": "{}", "shm_protocol": {}}}"#,
        json_object(&kinds),
        peer.reach,
        stats.shm,
        stats.copied,
        ZenohLine::BUILT,
        ZenohLine::BUILT_SHM_PROTOCOL,
    );
    // Let the last images leave before the session closes.
    std::thread::sleep(Duration::from_millis(500));
    Ok(())
}

/// `{"Shm": 20}`: payload kinds are plain identifiers.
fn json_object(counts: &BTreeMap<String, u32>) -> String {
    let fields: Vec<String> = counts
        .iter()
        .map(|(k, v)| format!("\"{k}\": {v}"))
        .collect();
    format!("{{{}}}", fields.join(", "))
}

fn subscribe(endpoint: &str, data: usize, count: usize, timeout: Duration) -> Result<()> {
    let (_session, _shm, node) = node(endpoint, "zenoh_lines_subscriber")?;
    // Every image kept until read: the check counts each one, and a subscriber
    // built without optimization checks slower than images arrive (ROS 2's
    // default keep-last 10 would drop the oldest).
    let subscriber = node
        .declare_subscriber::<Image>(TOPIC)
        .history(History::KeepAll)
        .wait()?;
    println!("KEY {}", subscriber.key_expr());
    println!("PEER_TOKEN {}", peer_token(EntityKind::Publisher));
    let (mut received, mut shm, mut exact) = (0, 0, 0);
    let deadline = Instant::now() + timeout;
    while received < count {
        let left = deadline.saturating_duration_since(Instant::now());
        let Some(sample) = subscriber.recv_timeout(left)? else {
            break;
        };
        received += 1;
        shm += usize::from(sample.is_shm());
        let got: Image = sample.decode()?;
        exact += usize::from(got == image(got.header.stamp.sec as u32, data));
    }
    println!(r#"{{"received": {received}, "shm": {shm}, "exact": {exact}}}"#);
    Ok(())
}

fn main() -> Result<()> {
    shm_runtime::init_logging();
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["publish", endpoint, data, count] => publish(endpoint, data.parse()?, count.parse()?),
        ["subscribe", endpoint, data, count, timeout] => subscribe(
            endpoint,
            data.parse()?,
            count.parse()?,
            Duration::from_secs(timeout.parse()?),
        ),
        _ => Err("usage: zenoh_lines publish <endpoint> <data bytes> <count> | zenoh_lines subscribe <endpoint> <data bytes> <count> <timeout s>".into()),
    }
}
