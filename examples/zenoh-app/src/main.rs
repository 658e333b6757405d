//! An existing Zenoh application, on Zenoh 1.10, that adds ROS 2 typed topics
//! through `shm-runtime` on the session it already has.
//!
//! The application before ROS 2: a Zenoh session, a queryable answering its
//! status on `myapp/status`, and a heartbeat put on `myapp/heartbeat`. What
//! it adds: a ROS 2 node on that same session, publishing `sensor_msgs/Image`
//! on `/camera/image`, written straight into a shared-memory pool (the
//! `camera` side), and subscribing to it (the `viewer` side). ROS 2 nodes see
//! the topic and its node like any other (`ros2 topic list`,
//! `shm-ros2 node list`).
//!
//! ```text
//! zenoh-app camera [count]    listens on tcp/127.0.0.1:7451 (ZENOH_APP_ENDPOINT)
//! zenoh-app viewer [count]    connects to it
//! ```
//!
//! The viewer checks every pixel of every image, counts those that arrived in
//! shared memory, asks the camera's status through the application's own
//! queryable, and exits with 1 if anything is missing or wrong. On Zenoh 1.10
//! both sides share memory with each other; with ROS 2 nodes (Zenoh 1.8) the
//! camera's images travel as copies, and its report says so
//! (docs/src/zenoh-lines.md).

use std::time::{Duration, Instant};

use shm_runtime::shm_cdr::msgs::sensor_msgs::{Image, ImageRef};
use shm_runtime::shm_cdr::msgs::std_msgs::Header;
use shm_runtime::{Reach, RosNode, ShmConfig, ShmContext, ZenohLine};
use zenoh::{Config, Session, Wait};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error + Send + Sync>>;

const WIDTH: u32 = 640;
const HEIGHT: u32 = 480;

/// The application's own session: a peer that listens (camera) or connects
/// (viewer) on one endpoint, without multicast scouting, so that it joins no
/// other system by accident.
fn open_session(listen: bool) -> Result<Session> {
    let endpoint =
        std::env::var("ZENOH_APP_ENDPOINT").unwrap_or_else(|_| "tcp/127.0.0.1:7451".into());
    let mut config = Config::default();
    config.insert_json5("mode", r#""peer""#)?;
    config.insert_json5("scouting/multicast/enabled", "false")?;
    let key = if listen {
        "listen/endpoints"
    } else {
        "connect/endpoints"
    };
    config.insert_json5(key, &format!(r#"["{endpoint}"]"#))?;
    Ok(zenoh::open(config).wait()?)
}

/// The value of pixel `i` of image `seq`.
fn pixel(seq: u32, i: usize) -> u8 {
    (i as u32).wrapping_mul(7).wrapping_add(seq) as u8
}

fn camera(count: u32) -> Result<()> {
    // The application as it was.
    let session = open_session(true)?;
    let status = session
        .declare_queryable("myapp/status")
        .callback(|query| {
            let _ = query.reply("myapp/status", "camera: running").wait();
        })
        .wait()?;
    let heartbeat = session.declare_publisher("myapp/heartbeat").wait()?;

    // What shm-runtime adds: a ROS 2 node on the same session, its messages
    // written straight into shared memory.
    let shm = ShmContext::new(ShmConfig::enabled())?;
    let node = RosNode::builder(&session, "camera").shm(&shm).wait()?;
    let images = node.declare_publisher::<Image>("camera/image").wait()?;

    // Wait for a subscriber, and for the runtime to know how it receives
    // (in place, or as copies over a link without shared memory).
    let deadline = Instant::now() + Duration::from_secs(30);
    let reach = loop {
        let settled: Vec<String> = images
            .receivers()
            .iter()
            .filter(|r| r.reach != Reach::Checking)
            .map(|r| format!("{:?}", r.reach))
            .collect();
        if images.has_subscribers() && !settled.is_empty() {
            break settled;
        }
        if Instant::now() > deadline {
            return Err("no subscriber to /camera/image within 30 s".into());
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut copied = 0;
    let mut image = Image {
        header: Header {
            frame_id: "camera".into(),
            ..Default::default()
        },
        height: HEIGHT,
        width: WIDTH,
        encoding: "mono8".into(),
        step: WIDTH,
        data: vec![0; (WIDTH * HEIGHT) as usize],
        ..Default::default()
    };
    for seq in 0..count {
        image.header.stamp.sec = seq as i32;
        for (i, byte) in image.data.iter_mut().enumerate() {
            *byte = pixel(seq, i);
        }
        let outcome = images.publish(&image).wait()?;
        copied += outcome.copied_to;
        heartbeat.put(seq.to_string()).wait()?;
        std::thread::sleep(Duration::from_millis(30));
    }
    println!(
        "camera: Zenoh {} (shared-memory protocol {}), {count} images published, {} in shared memory, \
         {copied} copies into links without it; subscribers: {}",
        ZenohLine::BUILT,
        ZenohLine::BUILT_SHM_PROTOCOL,
        shm.stats().shm,
        reach.join(", ")
    );
    // Serve the status until the viewer has asked for it.
    std::thread::sleep(Duration::from_secs(2));
    drop(status);
    Ok(())
}

fn viewer(count: u32) -> Result<()> {
    let session = open_session(false)?;
    let node = RosNode::builder(&session, "viewer").wait()?;
    let images = node.declare_subscriber::<Image>("camera/image").wait()?;

    let (mut received, mut in_shm, mut exact) = (0u32, 0u32, 0u32);
    let deadline = Instant::now() + Duration::from_secs(60);
    while received < count {
        let left = deadline.saturating_duration_since(Instant::now());
        let Some(sample) = images.recv_timeout(left)? else {
            break;
        };
        received += 1;
        in_shm += u32::from(sample.is_shm());
        // Borrowed: the pixels are read where they lie, in shared memory.
        let image: ImageRef = sample.decode()?;
        let seq = image.header.stamp.sec as u32;
        let right = image.data.len() == (WIDTH * HEIGHT) as usize
            && image
                .data
                .iter()
                .enumerate()
                .all(|(i, &b)| b == pixel(seq, i));
        exact += u32::from(right);
    }

    // The application's own query, on the same session.
    let status = session
        .get("myapp/status")
        .timeout(Duration::from_secs(5))
        .wait()?
        .recv()
        .ok()
        .and_then(|reply| {
            reply
                .result()
                .ok()
                .map(|s| s.payload().to_bytes().into_owned())
        })
        .map(|bytes| String::from_utf8_lossy(&bytes).into_owned())
        .unwrap_or_else(|| "no reply".into());
    println!(
        "viewer: Zenoh {}, {received}/{count} images, {in_shm} in shared memory, {exact} exact; status: {status}",
        ZenohLine::BUILT
    );
    if received == count && exact == count {
        Ok(())
    } else {
        Err("images missing or wrong".into())
    }
}

fn main() -> Result<()> {
    shm_runtime::init_logging();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count = match args.get(1) {
        Some(n) => n.parse()?,
        None => 50,
    };
    match args.first().map(String::as_str) {
        Some("camera") => camera(count),
        Some("viewer") => viewer(count),
        _ => Err("usage: zenoh-app camera|viewer [count]".into()),
    }
}
