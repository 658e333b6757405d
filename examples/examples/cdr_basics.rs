//! Define a message, encode it into an exactly-sized buffer, decode it back with
//! and without copies, and see what hostile input gets you.
//!
//! `cargo run -p shm-cdr-examples --example cdr_basics`

use shm_cdr::{BoundedVec, Endianness, RosMessage};

#[derive(RosMessage, Debug, Clone, Copy, PartialEq)]
#[ros(type_name = "builtin_interfaces/msg/Time")]
struct Time {
    sec: i32,
    nanosec: u32,
}

/// A hand-written message: no .msg file, no ROS installation.
#[derive(RosMessage, Debug, PartialEq)]
#[ros(type_name = "robot_msgs/msg/Scan")]
struct Scan {
    stamp: Time,
    frame_id: String,
    ranges: Vec<f32>,
    #[ros(byte)]
    status: u8,
    labels: BoundedVec<String, 4>,
}

/// The same type, borrowing its strings from the received bytes.
#[derive(RosMessage, Debug)]
#[ros(type_name = "robot_msgs/msg/Scan")]
struct ScanView<'a> {
    stamp: Time,
    frame_id: &'a str,
    ranges: Vec<f32>,
    #[ros(byte)]
    status: u8,
    labels: BoundedVec<&'a str, 4>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scan = Scan {
        stamp: Time {
            sec: 1_700_000_000,
            nanosec: 5,
        },
        frame_id: "laser".into(),
        ranges: vec![1.0, 1.5, 2.25],
        status: 0x2a,
        labels: vec!["near".to_string()].into(),
    };

    println!("type      {}", Scan::TYPE_NAME);
    println!("dds name  {}", Scan::DDS_TYPE_NAME);
    println!("hash      {}", Scan::type_hash());
    println!("fixed size of Time: {:?} bytes", Time::ENCODED_SIZE);

    // Exact size first, then one write into a buffer of exactly that size.
    let size = shm_cdr::encoded_size(&scan);
    let mut buf = vec![0u8; size];
    let written = shm_cdr::encode_into(&scan, &mut buf)?;
    println!("encoded   {written} of {size} bytes: {}", hex(&buf));

    let back: Scan = shm_cdr::from_bytes(&buf)?;
    assert_eq!(back, scan);
    let view: ScanView = shm_cdr::from_bytes(&buf)?;
    println!(
        "borrowed  frame_id {:?} points into the buffer: {}",
        view.frame_id,
        buf.as_ptr_range().contains(&view.frame_id.as_ptr())
    );

    let big = shm_cdr::to_vec_with(&scan, Endianness::Big)?;
    assert_eq!(shm_cdr::from_bytes::<Scan>(&big)?, scan);
    println!("big-endian {}", hex(&big));

    // A 4-billion-element length prefix is refused before anything is allocated.
    let hostile = [
        0x00, 0x01, 0x00, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff,
    ];
    println!(
        "hostile   {}",
        shm_cdr::from_bytes::<Scan>(&hostile).unwrap_err()
    );
    let short = &buf[..size - 1];
    println!(
        "truncated {}",
        shm_cdr::from_bytes::<Scan>(short).unwrap_err()
    );
    Ok(())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
