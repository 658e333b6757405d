//! Loans and typed borrows without Zenoh: what a writer may and may not do, and
//! that a reader borrows only what lies aligned in the host's byte order. These
//! run under Miri (`cargo +nightly miri test -p shm-cdr --lib loan`), which
//! would report any misaligned or out-of-bounds reference.

use std::borrow::Cow;

use super::*;
use crate::msgs::builtin_interfaces::Time;
use crate::msgs::geometry_msgs::{Point, Pose, PoseArray, PoseArrayRef, Quaternion};
use crate::msgs::sensor_msgs::{
    JointState, JointStateLens, JointStateRef, LaserScan, LaserScanLens, PointCloud2,
    PointCloud2Lens, PointField,
};
use crate::msgs::std_msgs::{Header, HeaderLens};

fn joint_state(n: usize) -> JointState {
    JointState {
        header: Header {
            stamp: Time { sec: 3, nanosec: 4 },
            frame_id: "base".into(),
        },
        name: (0..n).map(|i| format!("joint{i}")).collect(),
        position: (0..n).map(|i| i as f64 * 0.5).collect(),
        velocity: (0..n).map(|i| -(i as f64)).collect(),
        effort: vec![],
    }
}

/// A copy of `bytes` placed `shift` bytes past an 8-aligned address.
fn placed(bytes: &[u8], shift: usize) -> (Vec<u64>, std::ops::Range<usize>) {
    let mut storage = vec![0u64; bytes.len() / 8 + 2];
    let range = shift..shift + bytes.len();
    bytemuck_bytes(&mut storage)[range.clone()].copy_from_slice(bytes);
    (storage, range)
}

fn bytemuck_bytes(words: &mut [u64]) -> &mut [u8] {
    bytemuck::cast_slice_mut(words)
}

#[test]
fn a_joint_state_built_in_place_is_to_vec_and_reads_back_borrowed() {
    let expected = joint_state(6);
    let lens = JointStateLens {
        header: HeaderLens {
            frame_id: 4,
            ..Default::default()
        },
        name: (0..6).map(|i| format!("joint{i}").len()).collect(),
        position: 6,
        velocity: 6,
        effort: 0,
    };
    assert_eq!(lens, expected.lens());
    let size = encoded_size::<JointState>(&lens).unwrap();
    assert_eq!(size, crate::encoded_size(&expected));

    let mut buffer = AlignedBuffer::new(size);
    buffer.as_mut_slice().fill(0xEE);
    let written = Written::new();
    let js = carve::<JointState>(&lens, buffer.as_mut_slice(), &written).unwrap();
    // 4 name strings… 6 of them, the frame id, two runs: nothing written yet.
    assert_eq!(written.pending(), 6 + 1 + 2);
    *js.header.stamp.sec = 3;
    *js.header.stamp.nanosec = 4;
    js.header.frame_id.write("base").unwrap();
    for (i, slot) in js.name.into_iter().enumerate() {
        slot.write(&format!("joint{i}")).unwrap();
    }
    let position = js.position.write_with(|i| i as f64 * 0.5);
    // The run lies in the buffer, 8-aligned: a real `&mut [f64]`.
    assert_eq!(position.as_ptr() as usize % 8, 0);
    js.velocity.write_iter((0..6).map(|i| -(i as f64))).unwrap();
    assert!(js.effort.is_empty());
    written.check().unwrap();
    if cfg!(target_endian = "little") {
        assert_eq!(buffer.as_slice(), crate::to_vec(&expected).unwrap());
    }

    let view: JointStateRef = crate::from_bytes(buffer.as_slice()).unwrap();
    let Cow::Borrowed(position) = &view.position else {
        panic!("an aligned float64[] in host order is borrowed");
    };
    assert!(buffer
        .as_slice()
        .as_ptr_range()
        .contains(&position.as_ptr().cast::<u8>()));
    assert_eq!(*position, &expected.position[..]);
    assert_eq!(&*view.velocity, &expected.velocity[..]);
}

#[test]
fn misaligned_or_foreign_order_runs_are_copied_never_referenced() {
    let msg = joint_state(5);
    let bytes = crate::to_vec(&msg).unwrap();
    for shift in 0..8 {
        let (mut storage, range) = placed(&bytes, shift);
        let input = &bytemuck_bytes(&mut storage)[range];
        let view: JointStateRef = crate::from_bytes(input).unwrap();
        // The body starts at shift + 4: f64s are aligned only when that is 0 mod 8.
        let aligned = (shift + 4) % 8 == 0;
        assert_eq!(
            matches!(view.position, Cow::Borrowed(_)),
            aligned && cfg!(target_endian = "little"),
            "shift {shift}"
        );
        assert_eq!(&*view.position, &msg.position[..], "shift {shift}");
        assert_eq!(&*view.velocity, &msg.velocity[..], "shift {shift}");
    }
    let big = crate::to_vec_with(&msg, Endianness::Big).unwrap();
    let (mut storage, range) = placed(&big, 4);
    let view: JointStateRef = crate::from_bytes(&bytemuck_bytes(&mut storage)[range]).unwrap();
    assert_eq!(
        matches!(view.position, Cow::Owned(_)),
        cfg!(target_endian = "little"),
        "a big-endian payload is swapped into a copy"
    );
    assert_eq!(&*view.position, &msg.position[..]);
}

#[test]
fn poses_borrow_as_structs_in_o1() {
    let msg = PoseArray {
        header: Header::default(),
        poses: (0..50)
            .map(|i| Pose {
                position: Point {
                    x: i as f64,
                    y: 1.0,
                    z: 2.0,
                },
                orientation: Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                },
            })
            .collect(),
    };
    let mut buffer = AlignedBuffer::new(crate::encoded_size(&msg));
    crate::encode_into(&msg, buffer.as_mut_slice()).unwrap();
    let view: PoseArrayRef = crate::from_bytes(buffer.as_slice()).unwrap();
    assert!(matches!(view.poses, Cow::Borrowed(_)) || cfg!(target_endian = "big"));
    assert_eq!(&*view.poses, &msg.poses[..]);

    // And written in place as one run of `Pose`.
    let mut again = AlignedBuffer::new(crate::encoded_size(&msg));
    let written = Written::new();
    let place = carve::<PoseArray>(&msg.lens(), again.as_mut_slice(), &written).unwrap();
    let Run::Plain(poses) = place.poses else {
        panic!("Pose[] after a header is one plain run");
    };
    poses.write_plain(&msg.poses).unwrap();
    written.check().unwrap();
    let frame = place.header.frame_id;
    assert!(frame.is_empty());
    if cfg!(target_endian = "little") {
        assert_eq!(again.as_slice(), buffer.as_slice());
    }
}

/// `SeqLens::Count` lays out elements with empty strings: a name written
/// into one is refused with the field's name, both lengths and the fix.
#[test]
fn a_count_of_elements_with_strings_is_refused_naming_the_field_and_the_fix() {
    let lens = PointCloud2Lens {
        fields: SeqLens::Count(1),
        data: 16,
        ..Default::default()
    };
    let mut buffer = AlignedBuffer::new(encoded_size::<PointCloud2>(&lens).unwrap());
    let written = Written::new();
    let cloud = carve::<PointCloud2>(&lens, buffer.as_mut_slice(), &written).unwrap();
    let Run::Each(mut fields) = cloud.fields else {
        panic!("PointField[] has strings: one place per element");
    };
    let err = fields.remove(0).name.write("x").unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(
            err,
            LoanError::LengthMismatch {
                field: "name",
                expected: 0,
                got: 1,
                ..
            }
        ),
        "{text}"
    );
    for needed in [
        "field `name`",
        "length 1",
        "0 was laid out",
        "SeqLens::Each",
    ] {
        assert!(text.contains(needed), "{needed:?} in {text}");
    }
}

#[test]
fn unwritten_and_wrongly_sized_writes_are_refused() {
    let lens = LaserScanLens {
        header: HeaderLens {
            frame_id: 5,
            ..Default::default()
        },
        ranges: 10,
        intensities: 10,
        ..Default::default()
    };
    let mut buffer = AlignedBuffer::new(encoded_size::<LaserScan>(&lens).unwrap());
    let written = Written::new();
    let scan = carve::<LaserScan>(&lens, buffer.as_mut_slice(), &written).unwrap();
    let err = scan.header.frame_id.write("lidar0").unwrap_err();
    assert!(
        matches!(
            err,
            LoanError::LengthMismatch {
                field: "frame_id",
                expected: 5,
                got: 6,
                ..
            }
        ),
        "{err}"
    );
    assert!(
        err.to_string().starts_with("field `frame_id` at byte"),
        "{err}"
    );
    let err = scan.ranges.write_slice(&[1.0; 9]).unwrap_err();
    assert!(matches!(
        err,
        LoanError::LengthMismatch {
            field: "ranges",
            expected: 10,
            got: 9,
            ..
        }
    ));
    let err = scan
        .intensities
        .write_iter((0..11).map(|i| i as f32))
        .unwrap_err();
    assert!(matches!(
        err,
        LoanError::LengthMismatch {
            expected: 10,
            got: 11,
            ..
        }
    ));
    // All three refused writes left their places unwritten.
    assert_eq!(written.check(), Err(LoanError::Unwritten { pending: 3 }));
    assert!(written
        .check()
        .unwrap_err()
        .to_string()
        .contains("never written"));

    // A buffer of another size, or whose body is not 8-aligned, is refused.
    let size = encoded_size::<LaserScan>(&lens).unwrap();
    let mut short = AlignedBuffer::new(size - 1);
    assert!(matches!(
        carve::<LaserScan>(&lens, short.as_mut_slice(), &written),
        Err(LoanError::SizeMismatch { .. })
    ));
    let mut storage = vec![0u64; size / 8 + 2];
    let off = &mut bytemuck_bytes(&mut storage)[1..1 + size];
    assert!(matches!(
        carve::<LaserScan>(&lens, off, &written),
        Err(LoanError::Misaligned { .. })
    ));
    // Lengths that cannot be laid out.
    let huge = LaserScanLens {
        ranges: usize::MAX / 2,
        ..Default::default()
    };
    assert_eq!(encoded_size::<LaserScan>(&huge), Err(LoanError::TooLarge));
}

#[test]
#[cfg(feature = "test_msgs")]
fn bounds_and_array_lengths_are_checked() {
    use crate::msgs::test_msgs::{Arrays, ArraysLens, BoundedSequences, BoundedSequencesLens};
    let lens = BoundedSequencesLens {
        int32_values: 4,
        ..Default::default()
    };
    let size = encoded_size::<BoundedSequences>(&lens).unwrap();
    let mut buffer = AlignedBuffer::new(size);
    let written = Written::new();
    assert_eq!(
        carve::<BoundedSequences>(&lens, buffer.as_mut_slice(), &written).err(),
        Some(LoanError::BoundExceeded { len: 4, bound: 3 })
    );
    // A `string[3]` with lengths for 2 strings.
    let lens = ArraysLens {
        string_values: vec![1, 2],
        ..Default::default()
    };
    assert!(
        encoded_size::<Arrays>(&lens).is_err() || {
            let mut buffer = AlignedBuffer::new(encoded_size::<Arrays>(&lens).unwrap());
            carve::<Arrays>(&lens, buffer.as_mut_slice(), &written).is_err()
        }
    );
}

#[derive(crate::RosMessage, Debug, Clone, Copy, PartialEq, Default)]
#[ros(type_name = "test/msg/PointXyzi", crate = "crate")]
#[repr(C)]
struct PointXyzi {
    x: f32,
    y: f32,
    z: f32,
    intensity: f32,
}

#[test]
fn a_cloud_of_typed_points_is_written_in_place() {
    let points: Vec<PointXyzi> = (0..100)
        .map(|i| PointXyzi {
            x: i as f32,
            y: 0.5,
            z: -1.0,
            intensity: 7.0,
        })
        .collect();
    let field = |name: &str, offset: u32| PointField {
        name: name.into(),
        offset,
        datatype: PointField::FLOAT32,
        count: 1,
    };
    let fields = vec![
        field("x", 0),
        field("y", 4),
        field("z", 8),
        field("intensity", 12),
    ];
    let expected = PointCloud2 {
        header: Header::default(),
        height: 1,
        width: 100,
        fields: fields.clone(),
        is_bigendian: false,
        point_step: 16,
        row_step: 1600,
        data: points
            .iter()
            .flat_map(|p| [p.x, p.y, p.z, p.intensity])
            .flat_map(f32::to_le_bytes)
            .collect(),
        is_dense: true,
    };
    let lens = PointCloud2Lens {
        fields: fields.iter().map(|f| f.lens()).collect::<Vec<_>>().into(),
        data: 1600,
        ..Default::default()
    };
    let mut buffer = AlignedBuffer::new(encoded_size::<PointCloud2>(&lens).unwrap());
    let written = Written::new();
    let cloud = carve::<PointCloud2>(&lens, buffer.as_mut_slice(), &written).unwrap();
    *cloud.height = 1;
    *cloud.width = 100;
    *cloud.point_step = 16;
    *cloud.row_step = 1600;
    cloud.is_dense.set(true);
    cloud.fields.write_slice(&fields).unwrap();
    let data = cloud.data.cast::<PointXyzi>().unwrap();
    // 1600 bytes are not a whole number of 24-byte `Pose`s.
    let mut odd = AlignedBuffer::new(encoded_size::<PointCloud2>(&lens).unwrap());
    let again = Written::new();
    let other = carve::<PointCloud2>(&lens, odd.as_mut_slice(), &again).unwrap();
    let err = other.data.cast::<Point>().unwrap_err();
    assert!(
        matches!(
            err,
            LoanError::NotWhole {
                bytes: 1600,
                element: 24,
                ..
            }
        ),
        "{err}"
    );
    assert_eq!(data.len(), 100);
    data.write_slice(&points).unwrap();
    written.check().unwrap();
    if cfg!(target_endian = "little") {
        assert_eq!(buffer.as_slice(), crate::to_vec(&expected).unwrap());
    }
}
