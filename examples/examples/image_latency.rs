//! The Rust path of the Python image benchmark (`shm-python/bench/images.py`):
//! the same frames, taken into a message the same way and timed the same way,
//! between two Rust nodes. The publisher copies each frame into a loan (the
//! one copy a frame from elsewhere costs) and publishes it; the subscriber
//! reads the data as a slice borrowed where it arrived, then stamps its arrival.
//!
//! ```sh
//! cargo build --release -p shm-cdr-examples --example image_latency
//! image_latency sub <Image|PointCloud2> <bytes> <rounds>   # prints "ready", then JSON
//! image_latency pub <Image|PointCloud2> <bytes> <rounds>
//! ```
//!
//! Sessions are configured as rmw_zenoh_cpp's (`ZENOH_CONFIG_OVERRIDE`, ...),
//! the pool from `ZENOH_SHM_ALLOC_SIZE`. Latency is the subscriber's
//! `CLOCK_REALTIME` at arrival minus the publisher's before the copy, carried
//! in the header's stamp; one line of JSON: `[[nanoseconds, in shared memory], ...]`.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::sensor_msgs::{
    Image, ImageLens, ImageRef, PointCloud2, PointCloud2Lens, PointCloud2Ref,
};
use shm_cdr::RosMessage;
use shm_runtime::rmw::config;
use shm_runtime::{RosNode, RosSample, ShmConfig, ShmContext};
use zenoh::Wait;

const USAGE: &str = "usage: image_latency pub|sub Image|PointCloud2 <bytes> <rounds>";
const PERIOD: Duration = Duration::from_millis(50);

fn now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as i64)
}

type Error = Box<dyn std::error::Error + Send + Sync>;

/// What the subscriber reads of a message where it lies: its stamp, the
/// length of its data and the data's last byte.
type Read = (Time, usize, Option<u8>);

/// Receive `rounds + 1` messages of `T`, each read by `read`; print the
/// latencies of all but the first as JSON.
fn receive<T: RosMessage>(
    node: &RosNode,
    frame: &[u8],
    rounds: usize,
    read: impl Fn(&RosSample) -> Result<Read, Error>,
) -> Result<(), Error> {
    let subscriber = node.declare_subscriber::<T>("/bench").wait()?;
    println!("ready");
    let mut rows = Vec::with_capacity(rounds);
    for round in 0..=rounds {
        let sample = subscriber.recv()?;
        let (stamp, len, last) = read(&sample)?;
        let now = now_ns();
        if len != frame.len() || last != frame.last().copied() {
            return Err(format!("a message of {len} bytes, not the frame").into());
        }
        let sent = i64::from(stamp.sec) * 1_000_000_000 + i64::from(stamp.nanosec);
        // The first may go by the network while the pool is probed.
        if round > 0 {
            rows.push(format!("[{}, {}]", now - sent, sample.is_shm()));
        }
    }
    println!("[{}]", rows.join(", "));
    Ok(())
}

fn main() -> Result<(), Error> {
    shm_runtime::init_logging();
    let args: Vec<String> = std::env::args().collect();
    let (Some(role), Some(kind), Some(size), Some(rounds)) =
        (args.get(1), args.get(2), args.get(3), args.get(4))
    else {
        return Err(USAGE.into());
    };
    let size: usize = size.parse().map_err(|_| USAGE)?;
    let rounds: usize = rounds.parse().map_err(|_| USAGE)?;
    let session = zenoh::open(config::session_config()?).wait()?;
    let shm = ShmContext::new(ShmConfig::enabled().with_env()?)?;
    let node = RosNode::builder(&session, role).shm(&shm).wait()?;
    // The same bytes as the Python side's frame.
    let frame: Vec<u8> = (0..size).map(|i| i as u8).collect();
    match (role.as_str(), kind.as_str()) {
        ("pub", "Image") => {
            let publisher = node.declare_publisher::<Image>("/bench").wait()?;
            publisher.wait_for_subscribers(Duration::from_secs(30));
            for _ in 0..=rounds {
                let t = now_ns();
                let mut loan = publisher.loan(ImageLens {
                    data: size,
                    ..Default::default()
                })?;
                let image = loan.fields()?;
                image.header.frame_id.write("")?;
                image.encoding.write("")?;
                image.data.write_slice(&frame)?;
                *image.header.stamp.sec = (t / 1_000_000_000) as i32;
                *image.header.stamp.nanosec = (t % 1_000_000_000) as u32;
                loan.publish().wait()?;
                std::thread::sleep(PERIOD);
            }
        }
        ("pub", "PointCloud2") => {
            let publisher = node.declare_publisher::<PointCloud2>("/bench").wait()?;
            publisher.wait_for_subscribers(Duration::from_secs(30));
            for _ in 0..=rounds {
                let t = now_ns();
                let mut loan = publisher.loan(PointCloud2Lens {
                    data: size,
                    ..Default::default()
                })?;
                let cloud = loan.fields()?;
                cloud.header.frame_id.write("")?;
                cloud.fields.write_slice(&[])?;
                cloud.data.write_slice(&frame)?;
                *cloud.header.stamp.sec = (t / 1_000_000_000) as i32;
                *cloud.header.stamp.nanosec = (t % 1_000_000_000) as u32;
                loan.publish().wait()?;
                std::thread::sleep(PERIOD);
            }
        }
        ("sub", "Image") => receive::<Image>(&node, &frame, rounds, |sample| {
            let view: ImageRef = sample.decode()?;
            Ok((
                view.header.stamp,
                view.data.len(),
                view.data.last().copied(),
            ))
        })?,
        ("sub", "PointCloud2") => receive::<PointCloud2>(&node, &frame, rounds, |sample| {
            let view: PointCloud2Ref = sample.decode()?;
            Ok((
                view.header.stamp,
                view.data.len(),
                view.data.last().copied(),
            ))
        })?,
        _ => return Err(USAGE.into()),
    }
    Ok(())
}
