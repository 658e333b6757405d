//! Byte vectors and type hashes produced by independent ROS 2 tooling (rosbags
//! 0.11.9, cross-checked with pycdr2, mcap-ros2-support and rosidl), in both
//! directions and, for decoding, both byte orders.

use shm_cdr::{from_bytes, to_vec, to_vec_with, Endianness, RosMessage};
use shm_cdr_tests::msgs::*;

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("test vector is hex"))
        .collect()
}

/// Encodes to exactly `expected`, reports that size, and decodes back to `msg`.
fn assert_golden<T>(msg: &T, expected_hex: &str)
where
    T: RosMessage + shm_cdr::DecodeOwned + PartialEq + std::fmt::Debug,
{
    let expected = hex(expected_hex);
    assert_eq!(to_vec(msg).unwrap(), expected, "encoding of {msg:?}");
    assert_eq!(shm_cdr::encoded_size(msg), expected.len());
    assert_eq!(&from_bytes::<T>(&expected).unwrap(), msg);
}

fn header_map() -> Header {
    Header {
        stamp: Time { sec: 1, nanosec: 2 },
        frame_id: "map".into(),
    }
}

#[test]
fn string_hello() {
    let msg = StringMsg {
        data: "hello".into(),
    };
    assert_golden(&msg, "000100000600000068656c6c6f00");
    let be = hex("000000000000000668656c6c6f00");
    assert_eq!(to_vec_with(&msg, Endianness::Big).unwrap(), be);
    assert_eq!(from_bytes::<StringMsg>(&be).unwrap(), msg);
}

#[test]
fn header() {
    assert_golden(&header_map(), "000100000100000002000000040000006d617000");
}

#[derive(RosMessage, Debug, PartialEq)]
#[ros(type_name = "test_msgs/msg/U8F64")]
struct U8F64 {
    a: u8,
    b: f64,
}

#[test]
fn u8_then_f64_pads_to_eight() {
    assert_golden(
        &U8F64 { a: 7, b: 1.5 },
        "000100000700000000000000000000000000f83f",
    );
}

#[derive(RosMessage, Debug, PartialEq)]
#[ros(type_name = "test_msgs/msg/EmptySeqThenU32")]
struct EmptySeqThenU32 {
    values: Vec<f64>,
    after: u32,
}

#[test]
fn empty_f64_sequence_adds_no_alignment() {
    assert_golden(
        &EmptySeqThenU32 {
            values: vec![],
            after: 7,
        },
        "000100000000000007000000",
    );
}

fn image_2x2() -> Image {
    Image {
        header: header_map(),
        height: 2,
        width: 2,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: 6,
        data: (0..12).collect(),
    }
}

const IMAGE_2X2: &str = "000100000100000002000000040000006d6170000200000002000000050000007267623800000000060000000c000000000102030405060708090a0b";

#[test]
fn image() {
    assert_golden(&image_2x2(), IMAGE_2X2);
}

#[test]
fn image_borrowed_points_into_the_input() {
    let bytes = hex(IMAGE_2X2);
    let image: ImageRef = from_bytes(&bytes).unwrap();
    assert_eq!(image.header.frame_id, "map");
    assert_eq!(image.encoding, "rgb8");
    assert_eq!(image.data, (0..12).collect::<Vec<u8>>());
    let input = bytes.as_ptr_range();
    assert!(
        input.contains(&image.encoding.as_ptr()),
        "strings must borrow"
    );
    assert!(
        input.contains(&image.data.as_ptr()),
        "data must borrow, not copy"
    );
    assert!(input.contains(&image.header.frame_id.as_ptr()));
    // The borrowed form encodes to the same bytes.
    assert_eq!(to_vec(&image).unwrap(), bytes);
}

#[test]
fn empty_message() {
    assert_golden(&Empty, "0001000000");
    assert_eq!(Empty::ENCODED_SIZE, Some(5));
}

#[test]
fn big_endian_image_decodes_and_reencodes() {
    let msg = image_2x2();
    let be = to_vec_with(&msg, Endianness::Big).unwrap();
    assert_eq!(&be[..4], [0, 0, 0, 0]);
    // Same layout, every multi-byte number reversed: sec 1 → 00 00 00 01.
    assert_eq!(&be[4..8], [0, 0, 0, 1]);
    assert_eq!(from_bytes::<Image>(&be).unwrap(), msg);
}

#[test]
fn reference_type_hashes() {
    assert_eq!(
        StringMsg::type_hash(),
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    );
    assert_eq!(
        Time::type_hash(),
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197"
    );
    assert_eq!(
        Header::type_hash(),
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"
    );
    assert_eq!(
        Char::type_hash(),
        "RIHS01_3ad2d04dd29ba19d04b16659afa3ccaedd691914b02a64e82e252f2fa6a586a9"
    );
    assert_eq!(
        PointCloud2::type_hash(),
        "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5"
    );
    assert_eq!(
        Image::type_hash(),
        "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47"
    );
    assert_eq!(
        shm_cdr::msgs::geometry_msgs::Twist::type_hash(),
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"
    );
    // Borrowed variants describe the same ROS type.
    assert_eq!(HeaderRef::type_hash(), Header::type_hash());
    assert_eq!(ImageRef::type_hash(), Image::type_hash());
}

#[test]
fn header_description_text_matches_rosidl() {
    let expected = r#"{"type_description": {"type_name": "std_msgs/msg/Header", "fields": [{"name": "stamp", "type": {"type_id": 1, "capacity": 0, "string_capacity": 0, "nested_type_name": "builtin_interfaces/msg/Time"}}, {"name": "frame_id", "type": {"type_id": 17, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}]}, "referenced_type_descriptions": [{"type_name": "builtin_interfaces/msg/Time", "fields": [{"name": "sec", "type": {"type_id": 6, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}, {"name": "nanosec", "type": {"type_id": 7, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}]}]}"#;
    assert_eq!(
        shm_cdr::describe::message_description_json::<Header>(),
        expected
    );
}

#[test]
fn names() {
    assert_eq!(PointCloud2::TYPE_NAME, "sensor_msgs/msg/PointCloud2");
    assert_eq!(
        PointCloud2::DDS_TYPE_NAME,
        "sensor_msgs::msg::dds_::PointCloud2_"
    );
}

#[test]
fn fixed_sizes_are_compile_time_constants() {
    const POSE: Option<usize> = Pose::ENCODED_SIZE;
    assert_eq!(POSE, Some(4 + 56));
    assert_eq!(Time::ENCODED_SIZE, Some(12));
    assert_eq!(U8F64::ENCODED_SIZE, Some(20));
    assert_eq!(Header::ENCODED_SIZE, None);
}
