//! The three shared-memory patterns of the ROS-Z SHM design, each published and
//! received in this process over TCP loopback:
//!
//! 1. user-managed SHM field: the application writes the points straight into a
//!    shared-memory buffer; publishing splices it in without a copy;
//! 2. automatic threshold: an ordinary `Vec` cloud is serialized straight into a
//!    shared-memory buffer of exactly its size;
//! 3. per-publisher override: the same message from a publisher with SHM off.
//!
//! `cargo run --release -p shm-cdr-examples --example pointcloud_shm`

use std::time::{Duration, Instant};

use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::sensor_msgs::{PointCloud2, PointCloud2Ref};
use shm_cdr::msgs::std_msgs::Header;
use shm_cdr_examples::loopback_pair;
use shm_runtime::msgs::sensor_msgs::PointCloud2Shm;
use shm_runtime::ShmOptions;
use shm_runtime::{RosSample, RosSubscriber, SessionExt, ShmBytes, ShmConfig, ShmContext};
use zenoh::Wait;

const POINTS: u32 = 65_536; // 16-byte points: 1 MiB of point data
const POINT_STEP: u32 = 16;

fn header() -> Header {
    Header {
        stamp: Time {
            sec: 1_700_000_000,
            nanosec: 0,
        },
        frame_id: "lidar".into(),
    }
}

/// Write `POINTS` points (x, y, z, intensity as f32) into `out`.
fn fill_points(out: &mut [u8]) {
    for (i, point) in out.chunks_exact_mut(POINT_STEP as usize).enumerate() {
        let a = i as f32 * 0.001;
        for (j, v) in [a.cos(), a.sin(), 0.5, i as f32].iter().enumerate() {
            point[4 * j..4 * j + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
}

const ROUNDS: usize = 20;

/// Publish `msg` `ROUNDS` times, one in flight; after each, receive and decode it
/// borrowed. Prints medians.
fn run<T: shm_cdr::RosMessage>(
    pattern: &str,
    publisher: &shm_runtime::RosPublisher<T>,
    subscriber: &RosSubscriber<PointCloud2>,
    msg: &T,
) -> zenoh::Result<()> {
    publisher.wait_for_subscribers(Duration::from_secs(5));
    let (mut publish, mut total) = (Vec::new(), Vec::new());
    let mut last = None;
    for _ in 0..ROUNDS {
        let started = Instant::now();
        let outcome = publisher.publish(msg).wait()?;
        publish.push(started.elapsed());
        let sample = subscriber
            .recv_timeout(Duration::from_secs(5))?
            .ok_or("no message within 5 s")?;
        let cloud: PointCloud2Ref = sample.decode()?; // borrows the points
        total.push(started.elapsed());
        assert_eq!(cloud.data.len(), (POINTS * POINT_STEP) as usize);
        last = Some((outcome, describe(&sample)));
    }
    let (outcome, received) = last.ok_or("no rounds")?;
    println!(
        "{pattern:<27} {:>8} B  sent as {:<8}  received as {received:<34}  publish {:>7.1} µs  publish→decoded {:>7.1} µs",
        outcome.size,
        format!("{:?}", outcome.kind),
        median_us(&mut publish),
        median_us(&mut total),
    );
    Ok(())
}

fn describe(sample: &RosSample) -> String {
    match (sample.shm_len(), sample.fragments()) {
        (0, n) => format!("{n} heap fragments"),
        (_, 1) => "one shared-memory buffer".into(),
        (shm, n) => format!("{n} fragments, {shm} B in shared memory"),
    }
}

fn median_us(samples: &mut [Duration]) -> f64 {
    samples.sort();
    samples[samples.len() / 2].as_secs_f64() * 1e6
}

fn main() -> zenoh::Result<()> {
    // Warnings (a pool that fell back to the heap, a message missed) reach
    // stderr only through a logger: `RUST_LOG=info` shows more.
    shm_runtime::init_logging();
    let (a, b) = loopback_pair(7457)?;
    // The default: a pool of up to 10 MiB that fits the process's memory-lock
    // limit (`ulimit -l`), rmw_zenoh's 512-byte threshold.
    let shm = ShmContext::new(ShmConfig::enabled())?;
    match shm.pool_size() {
        Some(bytes) => println!("shared-memory pool: {bytes} bytes ({})", shm.memlock()),
        None => println!(
            "no shared-memory pool, publishing from the heap ({})",
            shm.memlock()
        ),
    }
    let subscriber = b
        .declare_ros_subscriber::<PointCloud2>("demo/points")
        .wait()?;

    println!(
        "{} points of {} bytes, {ROUNDS} rounds each, medians:",
        POINTS, POINT_STEP
    );

    // 1. User-managed SHM field: the points are written once, into shared memory.
    let spliced = a
        .declare_ros_publisher::<PointCloud2Shm>("demo/points")
        .shm(&shm)
        .wait()?;
    match shm.alloc((POINTS * POINT_STEP) as usize) {
        Some(mut block) => {
            fill_points(&mut block);
            let cloud = PointCloud2Shm {
                header: header(),
                height: 1,
                width: POINTS,
                fields: shm_cdr_examples::xyzi_fields(),
                is_bigendian: false,
                point_step: POINT_STEP,
                row_step: POINTS * POINT_STEP,
                data: ShmBytes::from(block),
                is_dense: true,
            };
            run("1. user-managed SHM field", &spliced, &subscriber, &cloud)?;
        }
        None => println!("1. user-managed SHM field  skipped: no shared memory to write into"),
    }
    drop(spliced);

    // 2. Automatic threshold: a Vec cloud serialized straight into SHM.
    let automatic = a
        .declare_ros_publisher::<PointCloud2>("demo/points")
        .shm(&shm)
        .wait()?;
    let mut data = vec![0u8; (POINTS * POINT_STEP) as usize];
    fill_points(&mut data);
    let cloud = PointCloud2 {
        header: header(),
        height: 1,
        width: POINTS,
        fields: shm_cdr_examples::xyzi_fields(),
        is_bigendian: false,
        point_step: POINT_STEP,
        row_step: POINTS * POINT_STEP,
        data,
        is_dense: true,
    };
    run("2. automatic threshold", &automatic, &subscriber, &cloud)?;
    drop(automatic);

    // 3. Per-publisher override: this publisher never uses SHM.
    let heap = a
        .declare_ros_publisher::<PointCloud2>("demo/points")
        .shm(&shm)
        .without_shm()
        .wait()?;
    run("3. publisher without_shm()", &heap, &subscriber, &cloud)?;

    let stats = shm.stats();
    println!("pool: {stats:?}");
    let above_threshold = stats.shm + stats.fallbacks + stats.too_large + stats.unavailable;
    println!(
        "{} of {above_threshold} messages above the threshold went through shared memory",
        stats.shm
    );
    Ok(())
}
