//! Message definitions shared by the golden tests, property tests, fuzz corpus
//! replay and benchmarks. They mirror the ROS 2 interfaces field for field, so their
//! bytes and type hashes can be compared with rosidl / rosbags output.

pub mod msgs {
    //! The library's standard messages under the names the tests use.
    pub use shm_cdr::msgs::builtin_interfaces::Time;
    pub use shm_cdr::msgs::geometry_msgs::{Point, Pose, PoseArray, Quaternion};
    pub use shm_cdr::msgs::sensor_msgs::{
        Image, ImageRef, JointState, JointStateRef, PointCloud2, PointCloud2Ref, PointField,
    };
    pub use shm_cdr::msgs::std_msgs::{Byte, Char, Empty, Header, HeaderRef, String as StringMsg};
    use shm_cdr::RosMessage;

    /// A string-heavy message: a header and many short strings.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "bench_msgs/msg/StringList", loan)]
    pub struct StringList {
        /// Header.
        pub header: Header,
        /// The strings.
        pub names: Vec<String>,
    }

    /// [`StringList`] with its strings kept inline (`compact_str`): an owned
    /// decode allocates once, for the sequence.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "bench_msgs/msg/StringList", loan)]
    pub struct StringListCompact {
        /// Header.
        pub header: Header,
        /// The strings.
        pub names: Vec<compact_str::CompactString>,
    }

    /// [`StringList`] borrowing every string from the input.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "bench_msgs/msg/StringList")]
    pub struct StringListRef<'a> {
        /// Header.
        pub header: HeaderRef<'a>,
        /// The strings.
        pub names: Vec<&'a str>,
    }
}

pub mod samples {
    //! Deterministic sample messages of realistic sizes, for benchmarks and tests.
    use crate::msgs::*;

    fn header(frame_id: &str) -> Header {
        Header {
            stamp: Time {
                sec: 1_700_000_000,
                nanosec: 123_456_789,
            },
            frame_id: frame_id.into(),
        }
    }

    /// An XYZ+intensity cloud (16-byte points) of about `bytes` bytes of point data.
    pub fn point_cloud(bytes: usize) -> PointCloud2 {
        let point_step = 16;
        let width = (bytes / point_step) as u32;
        let field = |name: &str, offset| PointField {
            name: name.into(),
            offset,
            datatype: 7, // FLOAT32
            count: 1,
        };
        PointCloud2 {
            header: header("lidar"),
            height: 1,
            width,
            fields: vec![
                field("x", 0),
                field("y", 4),
                field("z", 8),
                field("intensity", 12),
            ],
            is_bigendian: false,
            point_step: point_step as u32,
            row_step: width * point_step as u32,
            data: (0..width as usize * point_step)
                .map(|i| (i * 31 % 251) as u8)
                .collect(),
            is_dense: true,
        }
    }

    /// A robot arm's joint state with `joints` joints.
    pub fn joint_state(joints: usize) -> JointState {
        JointState {
            header: header("base_link"),
            name: (0..joints).map(|i| format!("arm_joint_{i}")).collect(),
            position: (0..joints).map(|i| i as f64 * 0.1).collect(),
            velocity: (0..joints).map(|i| i as f64 * -0.01).collect(),
            effort: (0..joints).map(|i| i as f64 * 2.5).collect(),
        }
    }

    /// `n` short strings (`sensor/0`, `sensor/1`, …).
    pub fn string_list(n: usize) -> StringList {
        StringList {
            header: header("names"),
            names: (0..n).map(|i| format!("sensor/{i}")).collect(),
        }
    }

    /// An IMU reading with every covariance given.
    pub fn imu() -> shm_cdr::msgs::sensor_msgs::Imu {
        use shm_cdr::msgs::geometry_msgs::Vector3;
        shm_cdr::msgs::sensor_msgs::Imu {
            header: header("imu_link"),
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.38,
                w: 0.92,
            },
            orientation_covariance: [0.01; 9],
            angular_velocity: Vector3 {
                x: 0.1,
                y: -0.2,
                z: 0.3,
            },
            angular_velocity_covariance: [0.02; 9],
            linear_acceleration: Vector3 {
                x: 0.0,
                y: 0.0,
                z: 9.81,
            },
            linear_acceleration_covariance: [0.03; 9],
        }
    }

    /// A pose array of `n` poses.
    pub fn pose_array(n: usize) -> PoseArray {
        PoseArray {
            header: header("map"),
            poses: (0..n)
                .map(|i| Pose {
                    position: Point {
                        x: i as f64,
                        y: i as f64 * 2.0,
                        z: 0.5,
                    },
                    orientation: Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: (i as f64).sin(),
                        w: (i as f64).cos(),
                    },
                })
                .collect(),
        }
    }
}

pub mod fuzzing {
    //! The bodies of the cargo-fuzz targets in `fuzz/`, kept here so that
    //! `cargo test` replays the committed corpus through exactly the same code.
    use arbitrary::Arbitrary;
    use shm_cdr::testing::{check_decode_into, check_roundtrip};
    use shm_cdr::{from_bytes, BoundedString, BoundedVec, BoundedWString, RosMessage, WString};

    use crate::msgs::*;

    mod outside;
    pub use outside::{
        bag, join, liveliness_tokens, message_text, parameter_text, split, type_description,
    };

    /// Decode `data` as `T`; if that succeeds, the value must satisfy every
    /// invariant of `check_roundtrip`.
    fn decode_as<T>(data: &[u8])
    where
        T: shm_cdr::DecodeOwned + shm_cdr::CdrEncode + std::fmt::Debug,
    {
        let Ok(value) = from_bytes::<T>(data) else {
            return;
        };
        if let Err(why) = check_roundtrip(&value) {
            panic!("decoded {value:?}: {why}");
        }
    }

    /// Decode `data` as a borrowing `T`; if that succeeds, it must re-encode to
    /// exactly `encoded_size` bytes.
    fn decode_borrowed_as<'a, T>(data: &'a [u8])
    where
        T: shm_cdr::CdrDecode<'a> + shm_cdr::CdrEncode,
    {
        let Ok(value) = from_bytes::<T>(data) else {
            return;
        };
        let bytes = shm_cdr::to_vec(&value).expect("a decoded value re-encodes");
        assert_eq!(bytes.len(), shm_cdr::encoded_size(&value));
    }

    /// Decode `data` as `T`, as the run-time type built from `T`'s
    /// description and through a view of it: all must fail (the dynamic two
    /// with the same error), or all succeed and give the same message, encoded
    /// to the same bytes (also over a buffer full of another byte: every byte
    /// written, padding too), the dynamic message sized exactly.
    pub fn decode_dynamic_as<T>(data: &[u8])
    where
        T: shm_cdr::DecodeOwned + RosMessage,
    {
        let ty = shm_cdr::dynamic::DynamicType::from_description(&T::full_description())
            .expect("every generated type is a valid dynamic type");
        let generated = from_bytes::<T>(data).map(|v| shm_cdr::to_vec(&v));
        let dynamic = ty.decode(data);
        view_agrees(&ty, data, &dynamic);
        match (generated, dynamic) {
            (Ok(Ok(expected)), Ok(message)) => {
                let bytes =
                    shm_cdr::to_vec(&message).expect("a decoded dynamic message re-encodes");
                assert_eq!(bytes, expected, "{}: dynamic bytes differ", T::TYPE_NAME);
                assert_eq!(bytes.len(), shm_cdr::encoded_size(&message));
                for fill in [0x00, 0xa5, 0xff] {
                    let mut over = vec![fill; bytes.len()];
                    let written = shm_cdr::encode_into(&message, &mut over)
                        .expect("a decoded dynamic message encodes into its exact size");
                    assert_eq!(written, bytes.len());
                    assert_eq!(over, expected, "{}: over {fill:#04x}", T::TYPE_NAME);
                }
            }
            (Err(_), Err(_)) | (Ok(Err(_)), _) => {}
            (Ok(_), Err(e)) => panic!("{}: only the dynamic decoder refused: {e}", T::TYPE_NAME),
            (Err(e), Ok(_)) => panic!("{}: only the generated decoder refused: {e}", T::TYPE_NAME),
        }
    }

    /// The view of `data` as `ty` checks what `decode` checks (`decoded`) and
    /// reads what it gives.
    pub(crate) fn view_agrees(
        ty: &shm_cdr::dynamic::DynamicType,
        data: &[u8],
        decoded: &Result<shm_cdr::dynamic::Message<'_>, shm_cdr::DecodeError>,
    ) {
        let name = ty.name();
        match (ty.view(data), decoded) {
            (Ok(view), Ok(message)) => {
                let read = view.to_message().expect("a checked view reads");
                // Compared as bytes: NaN is not equal to itself.
                assert_eq!(
                    shm_cdr::to_vec(&read).ok(),
                    shm_cdr::to_vec(message).ok(),
                    "{name}: the view reads otherwise",
                );
            }
            (Err(a), Err(b)) => assert_eq!(a, *b, "{name}: the view refuses otherwise"),
            (Ok(_), Err(e)) => panic!("{name}: only the view accepted: {e}"),
            (Err(e), Ok(_)) => panic!("{name}: only the view refused: {e}"),
        }
    }

    /// Target `decode`: arbitrary bytes into several message types, owned and
    /// borrowed. Must never panic, hang or over-allocate.
    pub fn decode(data: &[u8]) {
        decode_as::<Image>(data);
        decode_borrowed_as::<ImageRef>(data);
        decode_as::<PointCloud2>(data);
        decode_borrowed_as::<PointCloud2Ref>(data);
        decode_as::<JointState>(data);
        decode_borrowed_as::<JointStateRef>(data);
        decode_as::<PoseArray>(data);
        decode_as::<Everything>(data);
        decode_as::<Empty>(data);
        // Generated from the ROS 2 interface files: every field kind rosidl has.
        use shm_cdr::msgs::{nav_msgs, test_msgs, tf2_msgs, visualization_msgs};
        decode_as::<test_msgs::Arrays>(data);
        decode_as::<test_msgs::BoundedSequences>(data);
        decode_as::<test_msgs::UnboundedSequences>(data);
        decode_as::<test_msgs::WStrings>(data);
        decode_as::<test_msgs::MultiNested>(data);
        decode_borrowed_as::<test_msgs::MultiNestedRef>(data);
        decode_as::<nav_msgs::Odometry>(data);
        decode_as::<tf2_msgs::TFMessage>(data);
        decode_borrowed_as::<visualization_msgs::MarkerArrayRef>(data);
    }

    /// One generated type under the fuzzer: `data` decoded as it (owned and
    /// borrowed, via `BorrowedForm`) must not panic and must re-encode
    /// consistently; then an arbitrary value built from `data` must round-trip
    /// and decode over another.
    fn generated_case<T>(data: &[u8])
    where
        T: shm_cdr::BorrowedForm
            + shm_cdr::DecodeOwned
            + shm_cdr::loan::InPlace
            + for<'a> Arbitrary<'a>
            + std::fmt::Debug,
    {
        decode_as::<T>(data);
        decode_borrowed_as::<T::Ref<'_>>(data);
        decode_dynamic_as::<T>(data);
        let mut u = arbitrary::Unstructured::new(data);
        if let Ok(msg) = T::arbitrary(&mut u) {
            if let Err(why) = check_roundtrip(&msg) {
                panic!("{why}");
            }
            let bytes = shm_cdr::to_vec(&msg).expect("an arbitrary value encodes");
            decode_dynamic_as::<T>(&bytes);
            if let Err(why) = shm_cdr::testing::check_in_place(&msg) {
                panic!("in place: {why}");
            }
            if let Ok(previous) = T::arbitrary(&mut u) {
                if let Err(why) = check_decode_into(&previous, &msg) {
                    panic!("{why}");
                }
            }
        }
    }

    macro_rules! generated_table {
        (messages: [$($m:path,)*], borrowed: [$(($o:path, $r:path),)*], services: [$($s:path,)*], actions: [$($a:path,)*],) => {
            /// [`generated_case`] of every message type in `shm_cdr::msgs`.
            pub const GENERATED_CASES: &[fn(&[u8])] = &[$(generated_case::<$m>,)*];
        };
    }

    shm_cdr::for_each_interface!(generated_table);

    /// Target `roundtrip_generated`: for the generated standard type chosen by
    /// the first two bytes (all of `shm_cdr::msgs`), the rest decoded as it and
    /// turned into an arbitrary value of it ([`GENERATED_CASES`]).
    pub fn roundtrip_generated(data: &[u8]) {
        let [a, b, rest @ ..] = data else {
            return;
        };
        let which = usize::from(u16::from_le_bytes([*a, *b])) % GENERATED_CASES.len();
        GENERATED_CASES[which](rest);
    }

    /// Time + value; `#[repr(C)]` so sequences of it take the bulk path at phase 0.
    #[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
    #[ros(type_name = "fuzz_msgs/msg/Stamped", loan)]
    #[repr(C)]
    pub struct Stamped {
        pub stamp: Time,
        pub value: f64,
    }

    /// Every kind of field, with mixed alignment.
    #[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
    #[ros(type_name = "fuzz_msgs/msg/Everything", loan)]
    pub struct Everything {
        pub flag: bool,
        pub lead: u8,
        pub stamped: Vec<Stamped>,
        pub small: i16,
        pub text: String,
        pub texts: Vec<String>,
        pub bounded: BoundedString<6>,
        pub bounded_seq: BoundedVec<Stamped, 3>,
        pub wide: WString,
        pub wide_bounded: BoundedWString<3>,
        pub floats: Vec<f64>,
        pub bools: Vec<bool>,
        pub fixed: [Stamped; 2],
        pub odd: [u16; 3],
        pub poses: Vec<Pose>,
        pub bytes: Vec<u8>,
        pub tail: u8,
    }

    /// Target `roundtrip`: an arbitrary message must satisfy every invariant of
    /// `shm_cdr::testing::check_roundtrip` (exact size, garbage-proof padding, one
    /// byte short fails, decode(encode(x)) == x, both byte orders) and be built in
    /// place byte for byte (`check_in_place`); decoded over a
    /// second arbitrary message from the rest of the input, it must come out
    /// unchanged (`check_decode_into`).
    pub fn roundtrip(data: &[u8]) {
        let mut u = arbitrary::Unstructured::new(data);
        if let Ok(msg) = Everything::arbitrary(&mut u) {
            if let Err(why) = check_roundtrip(&msg) {
                panic!("{why}");
            }
            if let Err(why) = shm_cdr::testing::check_in_place(&msg) {
                panic!("in place: {why}");
            }
            if let Ok(previous) = Everything::arbitrary(&mut u) {
                if let Err(why) = check_decode_into(&previous, &msg) {
                    panic!("{why}");
                }
            }
        }
    }
}
