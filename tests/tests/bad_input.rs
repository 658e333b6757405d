//! Hostile and malformed input: every case is a `DecodeError` naming what and
//! where; encoding errors likewise. Nothing panics, nothing allocates from an
//! unchecked length prefix.

use shm_cdr::{
    encode_into, from_bytes, from_bytes_into, from_bytes_strict, take_from_bytes, to_vec,
    BoundedString, BoundedVec, BoundedWString, DecodeErrorKind, EncodeErrorKind, RosMessage,
    WString,
};
use shm_cdr_tests::msgs::*;

#[derive(RosMessage, Debug, PartialEq)]
#[ros(type_name = "test_msgs/msg/Flag")]
struct Flag {
    on: bool,
}

#[derive(RosMessage, Debug, PartialEq)]
#[ros(type_name = "test_msgs/msg/Names")]
struct Names {
    names: Vec<String>,
}

#[derive(RosMessage, Debug, PartialEq)]
#[ros(type_name = "test_msgs/msg/Limited")]
struct Limited {
    label: BoundedString<3>,
    values: BoundedVec<u16, 2>,
}

#[derive(RosMessage, Debug, PartialEq)]
#[ros(type_name = "test_msgs/msg/Wide")]
struct Wide {
    text: WString,
    short: BoundedWString<2>,
}

#[test]
fn huge_length_prefix_is_rejected_before_allocating() {
    let input = [0x00, 0x01, 0x00, 0x00, 0xff, 0xff, 0xff, 0xff];
    let err = from_bytes::<PointCloud2>(&input).unwrap_err();
    // The first field is the header's stamp; the first length is frame_id's.
    assert!(
        matches!(err.kind(), DecodeErrorKind::UnexpectedEof { .. }),
        "{err}"
    );

    let err = from_bytes::<StringMsg>(&input).unwrap_err();
    assert_eq!(
        err.kind(),
        &DecodeErrorKind::LengthExceedsInput {
            count: u32::MAX,
            min_element_size: 1,
            remaining: 0
        }
    );
    assert_eq!(err.offset(), 4);
    assert_eq!(err.field_path().collect::<Vec<_>>(), ["data"]);

    // A sequence of strings: each needs at least 4 bytes, so 3 claimed elements
    // in 8 remaining bytes are refused up front.
    let input = [0, 1, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    let err = from_bytes::<Names>(&input).unwrap_err();
    assert_eq!(
        err.kind(),
        &DecodeErrorKind::LengthExceedsInput {
            count: 3,
            min_element_size: 4,
            remaining: 8
        }
    );
}

#[test]
fn truncated_input_reports_offset() {
    let full = to_vec(&Header {
        stamp: Time { sec: 1, nanosec: 2 },
        frame_id: "map".into(),
    })
    .unwrap();
    for cut in 0..full.len() {
        let err = from_bytes::<Header>(&full[..cut]).unwrap_err();
        assert!(
            matches!(
                err.kind(),
                DecodeErrorKind::UnexpectedEof { .. } | DecodeErrorKind::LengthExceedsInput { .. }
            ),
            "cut at {cut}: {err}"
        );
        assert!(
            err.offset() <= cut.max(4),
            "cut at {cut}: offset {}",
            err.offset()
        );
    }
}

#[test]
fn invalid_utf8() {
    let input = [0, 1, 0, 0, 3, 0, 0, 0, b'a', 0xff, 0];
    let err = from_bytes::<StringMsg>(&input).unwrap_err();
    assert_eq!(err.kind(), &DecodeErrorKind::InvalidUtf8 { valid_up_to: 1 });
    assert_eq!(err.offset(), 9);
    assert!(err.to_string().contains("at byte 9"), "{err}");
    assert!(err.to_string().contains("(in String.data)"), "{err}");
}

#[test]
fn string_without_nul() {
    let input = [0, 1, 0, 0, 2, 0, 0, 0, b'a', b'b'];
    let err = from_bytes::<StringMsg>(&input).unwrap_err();
    assert_eq!(err.kind(), &DecodeErrorKind::MissingNul { found: b'b' });
    assert_eq!(err.offset(), 9);
}

#[test]
fn zero_length_string_reads_as_empty() {
    // Some writers send length 0 for "" (no NUL); Fast-CDR reads it as empty too.
    let msg: StringMsg = from_bytes(&[0, 1, 0, 0, 0, 0, 0, 0]).unwrap();
    assert_eq!(msg.data, "");
}

#[test]
fn bool_of_two() {
    let err = from_bytes::<Flag>(&[0, 1, 0, 0, 2]).unwrap_err();
    assert_eq!(err.kind(), &DecodeErrorKind::InvalidBool(2));
    assert_eq!(err.offset(), 4);
}

#[test]
fn unknown_encapsulation() {
    for id in [[0x00, 0x02], [0x00, 0x07], [0x01, 0x01]] {
        let input = [id[0], id[1], 0, 0, 0];
        let err = from_bytes::<Flag>(&input).unwrap_err();
        assert_eq!(err.kind(), &DecodeErrorKind::UnknownEncapsulation(id));
        assert_eq!(err.offset(), 0);
    }
    let err = from_bytes::<Flag>(&[0, 1]).unwrap_err();
    assert!(matches!(err.kind(), DecodeErrorKind::UnexpectedEof { .. }));
}

#[test]
fn header_option_bytes_are_ignored() {
    assert_eq!(
        from_bytes::<Flag>(&[0, 1, 0xaa, 0xbb, 1]).unwrap(),
        Flag { on: true }
    );
}

#[test]
fn bytes_after_the_message_are_ignored_and_counted() {
    // What rclpy's serialize_message sends: the message, then slack with stale bytes.
    for extra in 0..=9 {
        let mut input = vec![0, 1, 0, 0, 1];
        input.extend((0..extra).map(|i| 0xa0 + i as u8));
        assert_eq!(from_bytes::<Flag>(&input).unwrap(), Flag { on: true });
        let (flag, rest) = take_from_bytes::<Flag>(&input).unwrap();
        assert_eq!(flag, Flag { on: true });
        assert_eq!(rest, &input[5..]);
        let mut kept = Flag { on: false };
        from_bytes_into(&input, &mut kept).unwrap();
        assert!(kept.on);
    }
}

#[test]
fn strict_decoding_allows_three_bytes_of_padding_only() {
    for pad in 0..=3 {
        let mut input = vec![0, 1, 0, 0, 1];
        input.extend(std::iter::repeat_n(0, pad));
        assert_eq!(
            from_bytes_strict::<Flag>(&input).unwrap(),
            Flag { on: true }
        );
    }
    let err = from_bytes_strict::<Flag>(&[0, 1, 0, 0, 1, 0, 0, 0, 0]).unwrap_err();
    assert_eq!(err.kind(), &DecodeErrorKind::TrailingBytes { count: 4 });
    assert_eq!(err.offset(), 5);
}

#[test]
fn bounds_are_enforced_both_ways() {
    let over_label = Limited {
        label: "four".into(),
        values: vec![1].into(),
    };
    let err = to_vec(&over_label).unwrap_err();
    assert_eq!(
        err.kind(),
        &EncodeErrorKind::BoundExceeded { len: 4, bound: 3 }
    );
    assert_eq!(err.field_path().collect::<Vec<_>>(), ["label"]);

    let over_values = Limited {
        label: "abc".into(),
        values: vec![1, 2, 3].into(),
    };
    let err = to_vec(&over_values).unwrap_err();
    assert_eq!(
        err.kind(),
        &EncodeErrorKind::BoundExceeded { len: 3, bound: 2 }
    );

    // Bytes of an over-bound value, as an unbounded writer would send them.
    #[derive(RosMessage)]
    #[ros(type_name = "test_msgs/msg/Limited")]
    struct Unlimited {
        label: String,
        values: Vec<u16>,
    }
    let bytes = to_vec(&Unlimited {
        label: "four".into(),
        values: vec![1],
    })
    .unwrap();
    let err = from_bytes::<Limited>(&bytes).unwrap_err();
    assert_eq!(
        err.kind(),
        &DecodeErrorKind::BoundExceeded { len: 4, bound: 3 }
    );
    assert_eq!(err.offset(), 4);
    let bytes = to_vec(&Unlimited {
        label: "abc".into(),
        values: vec![1, 2, 3],
    })
    .unwrap();
    let err = from_bytes::<Limited>(&bytes).unwrap_err();
    assert_eq!(
        err.kind(),
        &DecodeErrorKind::BoundExceeded { len: 3, bound: 2 }
    );
    assert_eq!(err.field_path().collect::<Vec<_>>(), ["values"]);
}

#[test]
fn wstring_layout_and_errors() {
    let msg = Wide {
        text: "a𝄞".into(), // 'a' + a surrogate pair: 3 UTF-16 units
        short: "hi".into(),
    };
    let bytes = to_vec(&msg).unwrap();
    let expected: Vec<u8> = [
        &[0u8, 1, 0, 0][..],
        &3u32.to_le_bytes(),
        &0x61u32.to_le_bytes(),
        &0xD834u32.to_le_bytes(),
        &0xDD1Eu32.to_le_bytes(),
        &2u32.to_le_bytes(),
        &(b'h' as u32).to_le_bytes(),
        &(b'i' as u32).to_le_bytes(),
    ]
    .concat();
    assert_eq!(bytes, expected);
    assert_eq!(shm_cdr::encoded_size(&msg), expected.len());
    assert_eq!(from_bytes::<Wide>(&bytes).unwrap(), msg);

    let mut bad = expected.clone();
    bad[8..12].copy_from_slice(&0x1_0000u32.to_le_bytes());
    let err = from_bytes::<Wide>(&bad).unwrap_err();
    assert_eq!(
        err.kind(),
        &DecodeErrorKind::InvalidUtf16 { unit: 0x1_0000 }
    );
    assert_eq!(err.offset(), 8);

    let mut lone = expected.clone();
    lone[16..20].copy_from_slice(&0x62u32.to_le_bytes()); // high surrogate then 'b'
    let err = from_bytes::<Wide>(&lone).unwrap_err();
    assert!(
        matches!(err.kind(), DecodeErrorKind::InvalidUtf16 { .. }),
        "{err}"
    );

    let too_long = Wide {
        text: "".into(),
        short: "abc".into(),
    };
    assert_eq!(
        to_vec(&too_long).unwrap_err().kind(),
        &EncodeErrorKind::BoundExceeded { len: 3, bound: 2 }
    );
}

#[test]
fn buffer_too_small_reports_exact_need_and_never_writes_past() {
    let msg = Image {
        data: vec![7; 100],
        ..Default::default()
    };
    let size = shm_cdr::encoded_size(&msg);
    for len in [0, 3, 4, 10, size - 1] {
        let mut buf = vec![0xEE; size + 8];
        let err = encode_into(&msg, &mut buf[..len]).unwrap_err();
        assert_eq!(
            err.kind(),
            &EncodeErrorKind::BufferTooSmall {
                needed: size,
                available: len
            }
        );
        assert!(buf[len..].iter().all(|&b| b == 0xEE), "wrote past {len}");
    }
}

#[test]
fn padding_is_zeroed_in_reused_buffers() {
    let msg = Image {
        header: Header {
            stamp: Time::default(),
            frame_id: "ab".into(), // leaves padding before `height`
        },
        encoding: "x".into(),
        ..Default::default()
    };
    let mut buf = vec![0xAA; shm_cdr::encoded_size(&msg)];
    let n = encode_into(&msg, &mut buf).unwrap();
    assert_eq!(&buf[..n], to_vec(&msg).unwrap());
    assert!(!buf.contains(&0xAA));
}
