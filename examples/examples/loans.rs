//! Loaned messages: a LaserScan and a PointCloud2 of typed points, each built in
//! place in one exact-size shared-memory chunk and published as it lies, then
//! received in this process over TCP loopback and read as slices borrowed from
//! that chunk.
//!
//! `cargo run --release -p shm-cdr-examples --example loans`

use std::borrow::Cow;
use std::time::Duration;

use shm_cdr::msgs::sensor_msgs::{
    LaserScan, LaserScanLens, LaserScanRef, PointCloud2, PointCloud2Lens, PointCloud2Ref,
};
use shm_cdr::msgs::std_msgs::HeaderLens;
use shm_cdr_examples::{loopback_pair, xyzi_fields};
// The derive, the loan traits (`lens()`), `.wait()` and the runtime's types.
use shm_runtime::prelude::*;

/// A point as the cloud's fields describe it: x, y, z, intensity.
#[derive(RosMessage, Debug, Clone, Copy, PartialEq)]
#[ros(type_name = "example/msg/PointXyzi")]
#[repr(C)]
struct PointXyzi {
    x: f32,
    y: f32,
    z: f32,
    intensity: f32,
}

const BEAMS: usize = 1080;
const POINTS: usize = 65_536; // 16-byte points: 1 MiB of point data

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    // Warnings (a pool that fell back to the heap, a message missed) reach
    // stderr only through a logger: `RUST_LOG=info` shows more.
    shm_runtime::init_logging();
    let (a, b) = loopback_pair(27_610)?;
    let shm = ShmContext::new(ShmConfig::enabled().threshold(4096))?;

    // --- LaserScan: the lengths, then every field at its place. ---------------
    let scans = a
        .declare_ros_publisher::<LaserScan>("loans/scan")
        .shm(&shm)
        .wait()?;
    let scan_sub = b.declare_ros_subscriber::<LaserScan>("loans/scan").wait()?;
    scans.wait_for_subscribers(Duration::from_secs(5));

    let mut loan = scans.loan(LaserScanLens {
        header: HeaderLens {
            frame_id: "laser".len(),
            ..Default::default()
        },
        ranges: BEAMS,
        intensities: BEAMS,
        ..Default::default()
    })?;
    println!(
        "LaserScan loan: {} bytes in {:?}, {} strings/sequences to write",
        loan.size(),
        loan.kind(),
        loan.unwritten()
    );
    let scan = loan.fields()?;
    scan.header.frame_id.write("laser")?;
    *scan.header.stamp.sec = 1_700_000_000;
    *scan.angle_min = -std::f32::consts::FRAC_PI_2;
    *scan.angle_max = std::f32::consts::FRAC_PI_2;
    *scan.angle_increment = std::f32::consts::PI / BEAMS as f32;
    *scan.range_max = 30.0;
    // Straight into shared memory: `ranges` is a `&mut [f32]` in the chunk.
    let ranges = scan.ranges.write_with(|i| 2.0 + (i as f32 * 0.01).sin());
    ranges[BEAMS / 2] = 0.25; // something in front
    scan.intensities.fill(100.0);
    let outcome = loan.publish().wait()?;
    println!("published: {outcome:?}");

    let sample = scan_sub
        .recv_timeout(Duration::from_secs(5))?
        .ok_or("scan lost")?;
    let view: LaserScanRef = sample.decode()?;
    println!(
        "received: shm={} frame={:?} ranges borrowed={} closest={:.2} m",
        sample.is_shm(),
        view.header.frame_id,
        matches!(view.ranges, Cow::Borrowed(_)),
        view.ranges.iter().copied().fold(f32::INFINITY, f32::min),
    );

    // --- PointCloud2: `uint8[] data` written as typed points. ------------------
    let clouds = a
        .declare_ros_publisher::<PointCloud2>("loans/cloud")
        .shm(&shm)
        .wait()?;
    let cloud_sub = b
        .declare_ros_subscriber::<PointCloud2>("loans/cloud")
        .wait()?;
    clouds.wait_for_subscribers(Duration::from_secs(5));

    let fields = xyzi_fields();
    let mut loan = clouds.loan(PointCloud2Lens {
        header: HeaderLens {
            frame_id: "lidar".len(),
            ..Default::default()
        },
        fields: fields.iter().map(|f| f.lens()).collect::<Vec<_>>().into(),
        data: POINTS * 16,
        ..Default::default()
    })?;
    let cloud = loan.fields()?;
    cloud.header.frame_id.write("lidar")?;
    *cloud.height = 1;
    *cloud.width = POINTS as u32;
    *cloud.point_step = 16;
    *cloud.row_step = POINTS as u32 * 16;
    cloud.is_dense.set(true);
    cloud.fields.write_slice(&fields)?;
    let points = cloud.data.cast::<PointXyzi>()?.write_with(|i| {
        let a = i as f32 * 0.001;
        PointXyzi {
            x: a.cos(),
            y: a.sin(),
            z: 0.5,
            intensity: i as f32,
        }
    });
    points[0].intensity = -1.0;
    let outcome = loan.publish().wait()?;
    println!("published: {outcome:?}");

    let sample = cloud_sub
        .recv_timeout(Duration::from_secs(5))?
        .ok_or("cloud lost")?;
    let view: PointCloud2Ref = sample.decode()?;
    let first = &view.data[..16];
    println!(
        "received: shm={} {} points, data borrowed from the chunk={}, first point x={:.1} intensity={:.1}",
        sample.is_shm(),
        view.width,
        sample
            .payload()
            .slices()
            .next()
            .is_some_and(|s| s.as_ptr_range().contains(&view.data.as_ptr())),
        f32::from_le_bytes(first[0..4].try_into()?),
        f32::from_le_bytes(first[12..16].try_into()?),
    );
    Ok(())
}
