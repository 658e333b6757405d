//! Messages typed at run time (`shm_cdr::dynamic`) against the generated
//! types: the same bytes, the same hashes, the same defaults, and the same
//! refusal of bad input. (`tests/ros2/check.py` runs the same comparison on
//! rclpy's encodings of random values of every standard type.)

use std::borrow::Cow;

use shm_cdr::describe::FullDescription;
use shm_cdr::describe::{Field, FieldType, TypeDescription, TypeSource};
use shm_cdr::dynamic::{DynamicType, FieldView, Value};
use shm_cdr::msgs::{sensor_msgs, std_msgs, test_msgs};
use shm_cdr::{DecodeErrorKind, Endianness, RosMessage};

fn dynamic<T: RosMessage>() -> DynamicType {
    DynamicType::from_description(&T::full_description()).unwrap()
}

#[test]
fn defaults_from_the_description_are_the_generated_defaults() {
    fn same<T: RosMessage + Default>() {
        let ours = dynamic::<T>().default_message();
        assert_eq!(
            shm_cdr::to_vec(&ours).unwrap(),
            shm_cdr::to_vec(&T::default()).unwrap(),
            "{}",
            T::TYPE_NAME
        );
    }
    // Numbers, bools, strings with quotes, arrays and bounded sequences of
    // each, nested messages.
    same::<test_msgs::msg::Defaults>();
    same::<test_msgs::msg::Arrays>();
    same::<test_msgs::msg::BoundedSequences>();
    same::<test_msgs::msg::UnboundedSequences>();
    same::<test_msgs::msg::Strings>();
    same::<test_msgs::msg::WStrings>();
    same::<test_msgs::msg::MultiNested>();
    same::<sensor_msgs::msg::Imu>();
}

#[test]
fn byte_and_number_arrays_borrow_from_the_input() {
    let image = sensor_msgs::msg::Image {
        encoding: "mono8".into(),
        data: vec![7; 4096],
        ..Default::default()
    };
    let bytes = shm_cdr::to_vec(&image).unwrap();
    let message = dynamic::<sensor_msgs::msg::Image>().decode(&bytes).unwrap();
    match message.value("data") {
        Some(Value::U8s(Cow::Borrowed(data))) => assert_eq!(data.len(), 4096),
        other => panic!("data not borrowed: {other:?}"),
    }
    match message.value("encoding") {
        Some(Value::String(Cow::Borrowed(text))) => assert_eq!(*text, "mono8"),
        other => panic!("encoding not borrowed: {other:?}"),
    }
    // From shared memory, strings are copied before they are checked.
    let shared = dynamic::<sensor_msgs::msg::Image>()
        .decode_shared(&bytes)
        .unwrap();
    assert!(matches!(
        shared.value("encoding"),
        Some(Value::String(Cow::Owned(_)))
    ));
}

/// CDR puts an `f64` 4 bytes off the alignment of the buffer it is in: the
/// numbers are read where they lie, in either byte order, never copied, and
/// they encode back to the same bytes.
#[test]
fn number_arrays_borrow_the_wire_at_any_alignment_in_either_byte_order() {
    let mut imu = sensor_msgs::msg::Imu::default();
    imu.header.frame_id = "imu".into();
    imu.orientation_covariance = std::array::from_fn(|i| i as f64 * 0.5 - 1.0);
    imu.linear_acceleration_covariance[8] = f64::MAX;
    let ty = dynamic::<sensor_msgs::msg::Imu>();
    for order in [Endianness::Little, Endianness::Big] {
        let bytes = shm_cdr::to_vec_with(&imu, order).unwrap();
        // Every start within a word: the covariances at every alignment.
        let mut storage = vec![0u8; bytes.len() + 8];
        for shift in 0..8 {
            let input = &mut storage[shift..shift + bytes.len()];
            input.copy_from_slice(&bytes);
            let message = ty.decode(input).unwrap();
            let Some(Value::F64s(covariance)) = message.value("orientation_covariance") else {
                panic!("not an array of float64");
            };
            let (wire, wire_order) = covariance.wire().expect("borrowed, not copied");
            assert_eq!(wire_order, order);
            assert_eq!(wire.len(), 9 * 8);
            assert_eq!(covariance.to_vec(), imu.orientation_covariance);
            assert_eq!(covariance.get(8), Some(3.0));
            let Some(Value::F64s(acceleration)) = message.value("linear_acceleration_covariance")
            else {
                panic!("not an array of float64");
            };
            assert_eq!(acceleration.iter().next_back(), Some(f64::MAX));
            assert_eq!(shm_cdr::to_vec_with(&message, order).unwrap(), bytes);
            // The other order: each number swapped as it is written.
            let other = match order {
                Endianness::Little => Endianness::Big,
                Endianness::Big => Endianness::Little,
            };
            assert_eq!(
                shm_cdr::to_vec_with(&message, other).unwrap(),
                shm_cdr::to_vec_with(&imu, other).unwrap()
            );
            // Owned, the message compares equal and encodes the same.
            let owned = message.clone().into_owned();
            assert_eq!(owned, message);
            assert_eq!(shm_cdr::to_vec_with(&owned, order).unwrap(), bytes);
        }
    }
}

#[test]
fn a_view_reads_fields_where_they_lie_and_builds_nothing_else() {
    let cloud = sensor_msgs::msg::PointCloud2 {
        header: std_msgs::msg::Header {
            frame_id: "lidar".into(),
            ..Default::default()
        },
        fields: ["x", "y", "z"]
            .iter()
            .zip(0u32..)
            .map(|(name, i)| sensor_msgs::msg::PointField {
                name: (*name).into(),
                offset: 4 * i,
                datatype: 7,
                count: 1,
            })
            .collect(),
        data: vec![3; 4096],
        ..Default::default()
    };
    let bytes = shm_cdr::to_vec(&cloud).unwrap();
    let ty = dynamic::<sensor_msgs::msg::PointCloud2>();
    let view = ty.view(&bytes).unwrap();
    assert_eq!(view.root().type_name(), "sensor_msgs/msg/PointCloud2");
    let Some(FieldView::Message(header)) = view.get("header") else {
        panic!("header is a message");
    };
    assert_eq!(header.type_name(), "std_msgs/msg/Header");
    match header.get("frame_id").map(|f| f.read().unwrap()) {
        Some(Value::String(Cow::Borrowed("lidar"))) => {}
        other => panic!("frame_id not borrowed: {other:?}"),
    }
    let Some(FieldView::Messages(fields)) = view.get("fields") else {
        panic!("fields is a sequence of messages");
    };
    assert_eq!(fields.len(), 3);
    let offsets: Vec<Value> = fields
        .iter()
        .map(|f| f.get("offset").unwrap().read().unwrap())
        .collect();
    assert_eq!(offsets, [Value::U32(0), Value::U32(4), Value::U32(8)]);
    assert!(fields.get(3).is_none());
    match view.get("data").map(|f| f.read().unwrap()) {
        Some(Value::U8s(Cow::Borrowed(data))) => assert_eq!(data, &cloud.data[..]),
        other => panic!("data not borrowed: {other:?}"),
    }
    assert!(view.get("no_such_field").is_none());
    // Built in full, it is what `decode` gives.
    assert_eq!(view.to_message().unwrap(), ty.decode(&bytes).unwrap());

    // From shared memory, strings are copied when read, as `decode_shared` copies them.
    let shared = ty.view_shared(&bytes).unwrap();
    let Some(FieldView::Message(header)) = shared.get("header") else {
        panic!("header is a message");
    };
    assert!(matches!(
        header.get("frame_id").map(|f| f.read().unwrap()),
        Some(Value::String(Cow::Owned(_)))
    ));
    assert_eq!(
        shared.to_message().unwrap(),
        ty.decode_shared(&bytes).unwrap()
    );
}

#[test]
fn bad_input_is_an_error_never_a_panic() {
    let ty = dynamic::<test_msgs::msg::MultiNested>();
    let bytes = shm_cdr::to_vec(&test_msgs::msg::MultiNested::default()).unwrap();
    for end in 0..bytes.len() {
        // Every cut short either fails or (inside trailing padding) reads the same.
        if let Ok(m) = ty.decode(&bytes[..end]) {
            assert_eq!(shm_cdr::to_vec(&m).unwrap(), bytes);
        }
        // A view refuses what `decode` refuses, with the same error.
        assert_eq!(
            ty.view(&bytes[..end]).and_then(|v| v.to_message()),
            ty.decode(&bytes[..end])
        );
    }
    // A length prefix far beyond the input is refused before anything is
    // allocated for it.
    let strings = dynamic::<std_msgs::msg::Header>();
    let mut hostile = shm_cdr::to_vec(&std_msgs::msg::Header::default()).unwrap();
    hostile[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(strings.decode(&hostile).is_err());
    assert!(strings.view(&hostile).is_err());
    // Bounds are enforced on decode as the generated types enforce them.
    let bounded = dynamic::<test_msgs::msg::BoundedPlainSequences>();
    let value = test_msgs::msg::BoundedPlainSequences {
        bool_values: vec![true; 3].into(),
        ..Default::default()
    };
    let mut bytes = shm_cdr::to_vec(&value).unwrap();
    let at = 4; // the first field's count
    bytes[at..at + 4].copy_from_slice(&4u32.to_le_bytes());
    bytes.insert(at + 4 + 3, 1);
    assert_eq!(
        bounded.view(&bytes).unwrap_err(),
        bounded.decode(&bytes).unwrap_err()
    );
    let e = bounded.decode(&bytes).unwrap_err();
    assert!(
        matches!(
            e.kind(),
            DecodeErrorKind::BoundExceeded { len: 4, bound: 3 }
        ),
        "{e}"
    );
}

#[derive(shm_cdr::RosMessage, Debug, Default)]
#[ros(type_name = "test_msgs/msg/ShortNames")]
struct ShortNames {
    names: Vec<shm_cdr::BoundedString<3>>,
    tail: u16,
}

#[test]
fn sequences_of_strings_encode_as_the_generated_code_and_keep_their_bound() {
    let ty = dynamic::<ShortNames>();
    let names = ["", "a", "ab", "abc", "b", "cd"];
    for n in 0..names.len() {
        let value = ShortNames {
            names: names[..n].iter().map(|s| (*s).into()).collect(),
            tail: 0xbeef,
        };
        let bytes = shm_cdr::to_vec(&value).unwrap();
        let message = ty.decode(&bytes).unwrap();
        assert_eq!(shm_cdr::encoded_size(&message), bytes.len());
        assert_eq!(shm_cdr::to_vec(&message).unwrap(), bytes, "{n} names");
    }
    // A string over its bound is refused, wherever it lies in the sequence.
    let mut message = ty.default_message();
    let long = vec!["a".into(), "abcd".into(), "b".into()];
    let e = message.set("names", Value::Strings(long)).unwrap_err();
    assert!(
        e.to_string().contains("longer than the field's bound"),
        "{e}"
    );
    assert_eq!(message, ty.default_message());
}

/// `len` bytes of xorshift noise from `seed`: the same each run.
fn noise(mut seed: u64, len: usize) -> Vec<u8> {
    (0..len)
        .map(|_| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed as u8
        })
        .collect()
}

/// Every cut, and every byte of the payload replaced by values that break
/// bools, counts and strings, of arbitrary values of `T`: the view (which
/// checks runs of fixed-size fields, and sequences of numbers, at once)
/// accepts and refuses exactly as `decode` does, field by field.
fn view_agrees_with_decode_on_damaged_payloads<T>(values: usize)
where
    T: shm_cdr::DecodeOwned + RosMessage + for<'a> arbitrary::Arbitrary<'a>,
{
    let noise = noise(0x9e37_79b9_7f4a_7c15, 4096);
    for start in (0..values).map(|k| k * 512) {
        let Ok(value) = T::arbitrary(&mut arbitrary::Unstructured::new(
            &noise[start..start + 400],
        )) else {
            continue;
        };
        let bytes = shm_cdr::to_vec(&value).unwrap();
        for end in 0..bytes.len() {
            shm_cdr_tests::fuzzing::decode_dynamic_as::<T>(&bytes[..end]);
        }
        let ty = dynamic::<T>();
        for at in 4..bytes.len() {
            for damage in [2u8, 0x80, 0xff] {
                let mut damaged = bytes.clone();
                damaged[at] = damage;
                shm_cdr_tests::fuzzing::decode_dynamic_as::<T>(&damaged);
                // Input other processes write takes the other road for strings.
                let shared = ty.view_shared(&damaged).and_then(|v| v.to_message());
                match (shared, ty.decode_shared(&damaged)) {
                    (Ok(a), Ok(b)) => assert_eq!(shm_cdr::to_vec(&a), shm_cdr::to_vec(&b)),
                    (a, b) => assert_eq!(a.err(), b.err(), "{}", T::TYPE_NAME),
                };
            }
        }
    }
}

#[test]
fn views_check_at_once_what_decode_checks_field_by_field() {
    view_agrees_with_decode_on_damaged_payloads::<test_msgs::msg::BasicTypes>(4);
    view_agrees_with_decode_on_damaged_payloads::<test_msgs::msg::Arrays>(4);
    // 2.7 KB a value: one is enough.
    view_agrees_with_decode_on_damaged_payloads::<test_msgs::msg::MultiNested>(1);
    view_agrees_with_decode_on_damaged_payloads::<test_msgs::msg::BoundedSequences>(4);
    view_agrees_with_decode_on_damaged_payloads::<test_msgs::msg::UnboundedSequences>(4);
    view_agrees_with_decode_on_damaged_payloads::<sensor_msgs::msg::PointCloud2>(4);
    view_agrees_with_decode_on_damaged_payloads::<sensor_msgs::msg::Imu>(4);
}

#[test]
fn set_keeps_every_value_of_its_fields_kind() {
    let ty = dynamic::<test_msgs::msg::BoundedSequences>();
    let mut m = ty.default_message();
    assert!(m
        .set("int32_values", Value::I32s(vec![1, 2, 3].into()))
        .is_ok());
    let too_many = m.set("int32_values", Value::I32s(vec![1, 2, 3, 4].into()));
    assert!(too_many.unwrap_err().reason.contains("at most 3"));
    let wrong = m
        .set("int32_values", Value::String("x".into()))
        .unwrap_err();
    assert!(wrong.reason.contains("a string is not"), "{wrong}");
    assert!(m.set("no_such_field", Value::Bool(true)).is_err());
    let arrays = dynamic::<test_msgs::msg::Arrays>();
    let mut a = arrays.default_message();
    let short = a
        .set("int32_values", Value::I32s(vec![1].into()))
        .unwrap_err();
    assert!(short.reason.contains("array of 3"), "{short}");
    // A nested message must be of the field's type.
    let header = dynamic::<std_msgs::msg::Header>().default_message();
    let mut image = dynamic::<sensor_msgs::msg::Image>().default_message();
    assert!(image
        .set("header", Value::Message(Box::new(header)))
        .is_err());

    // What set wrote encodes as the generated type with the same values.
    let generated = test_msgs::msg::BoundedSequences {
        int32_values: vec![1, 2, 3].into(),
        ..Default::default()
    };
    assert_eq!(
        shm_cdr::to_vec(&m).unwrap(),
        shm_cdr::to_vec(&generated).unwrap()
    );
}

#[test]
fn descriptions_that_cannot_be_types_say_why() {
    let header = std_msgs::msg::Header::full_description();
    // A nested type missing from the description.
    let missing = FullDescription {
        own: header.own,
        referenced: Vec::new(),
    };
    let e = DynamicType::from_description(&missing).unwrap_err();
    assert!(e.reason.contains("builtin_interfaces/msg/Time"), "{e}");
    assert_eq!(e.field.as_deref(), Some("stamp"));

    // A type that contains itself (through a sequence, too) is refused: a
    // decoder of it would recurse as deep as the input lets it.
    static A: [Field; 1] = [Field::new(
        "b",
        FieldType::nested("t/msg/B").unbounded_sequence(),
    )];
    static B: [Field; 1] = [Field::new("a", FieldType::nested("t/msg/A"))];
    let cycle = FullDescription {
        own: TypeDescription::new("t/msg/A", &A, TypeSource::NONE),
        referenced: vec![TypeDescription::new("t/msg/B", &B, TypeSource::NONE)],
    };
    let e = DynamicType::from_description(&cycle).unwrap_err();
    assert!(e.reason.contains("contains itself"), "{e}");

    // An array larger than any message can carry.
    static HUGE: [Field; 1] = [Field::new(
        "values",
        FieldType::scalar(shm_cdr::describe::TypeId::Int32).array(1 << 40),
    )];
    let huge = FullDescription {
        own: TypeDescription::new("t/msg/Huge", &HUGE, TypeSource::NONE),
        referenced: Vec::new(),
    };
    let e = DynamicType::from_description(&huge).unwrap_err();
    assert!(e.reason.contains("more than any ROS 2 message"), "{e}");
}

#[test]
fn the_hash_of_every_type_built_at_run_time_is_rosidls() {
    for description in [
        sensor_msgs::msg::PointCloud2::full_description(),
        test_msgs::msg::MultiNested::full_description(),
        test_msgs::msg::WStrings::full_description(),
    ] {
        let ty = DynamicType::from_description(&description).unwrap();
        assert_eq!(ty.type_hash(), description.type_hash());
        assert_eq!(ty.name(), description.own.type_name);
    }
}

#[test]
fn yaml_text_reads_as_ros2_topic_pub_reads_it() {
    use shm_cdr::msgs::sensor_msgs::JointState;
    let ty = dynamic::<JointState>();
    let message = ty
        .message_from_yaml("{header: {frame_id: base}, name: [a, b], position: [1, 2.5]}")
        .unwrap();
    let state: JointState = shm_cdr::from_bytes(&shm_cdr::to_vec(&message).unwrap()).unwrap();
    assert_eq!(state.header.frame_id, "base");
    assert_eq!(state.name, ["a", "b"]);
    assert_eq!(state.position, [1.0, 2.5]);
    assert!(state.velocity.is_empty());

    // Empty text and an empty mapping are the defaults.
    assert_eq!(ty.message_from_yaml("").unwrap(), ty.default_message());
    assert_eq!(ty.message_from_yaml("{}").unwrap(), ty.default_message());

    // A string field keeps any scalar as written, as PyYAML reads it.
    let header = dynamic::<shm_cdr::msgs::std_msgs::Header>();
    for text in ["1e5", "0o17", "yes", "~x", "12:30"] {
        let m = header
            .message_from_yaml(&format!("frame_id: {text}"))
            .unwrap();
        assert_eq!(
            m.value("frame_id"),
            Some(&Value::String(text.into())),
            "{text}"
        );
    }

    // `auto` and `now`, with the time given.
    let stamped = dynamic::<shm_cdr::msgs::geometry_msgs::PointStamped>();
    let m = stamped
        .message_from_yaml_at("{header: auto, point: {x: 1}}", (12, 34))
        .unwrap();
    let Some(h) = m.message("header") else {
        panic!("no header")
    };
    let Some(stamp) = h.message("stamp") else {
        panic!("no stamp")
    };
    assert_eq!(stamp.value("sec"), Some(&Value::I32(12)));
    assert_eq!(stamp.value("nanosec"), Some(&Value::U32(34)));
    assert!(stamped.message_from_yaml("header: auto").is_err());
}

#[test]
fn yaml_text_that_is_not_a_value_of_the_type_says_where_and_why() {
    use shm_cdr::msgs::sensor_msgs::JointState;
    let ty = dynamic::<JointState>();
    let cases = [
        (
            "velocity: [1, x]",
            "velocity[1]",
            "a number, not the string \"x\"",
        ),
        (
            "header: {stamp: {sec: 3000000000}}",
            "header.stamp.sec",
            "an integer from -2147483648 to 2147483647 (int32), not `3000000000`",
        ),
        (
            "header: {stamp: {nanosec: -1}}",
            "header.stamp.nanosec",
            "an integer from 0 to 4294967295 (uint32), not `-1`",
        ),
        (
            "header: {frame: x}",
            "header.frame",
            "std_msgs/msg/Header has no field `frame` (its fields: stamp, frame_id)",
        ),
        ("name: x", "name", "invalid type"),
        ("header: 5", "header", "invalid type"),
    ];
    for (text, path, reason) in cases {
        let e = ty.message_from_yaml(text).unwrap_err();
        assert_eq!(e.path, path, "{text}: {e}");
        assert!(e.reason.contains(reason), "{text}: {e}");
    }
    let e = ty.message_from_yaml("name: [a").unwrap_err();
    assert!(e.reason.contains("did not find expected ',' or ']'"), "{e}");

    // Arrays must have their length, bounded sequences and strings stay within
    // their bounds.
    let arrays = dynamic::<shm_cdr::msgs::test_msgs::Arrays>();
    let e = arrays
        .message_from_yaml("int32_values: [1, 2]")
        .unwrap_err();
    assert_eq!(
        (e.path.as_str(), e.reason.as_str()),
        ("int32_values", "2 elements for an array of 3")
    );
    let bounded = dynamic::<shm_cdr::msgs::test_msgs::BoundedSequences>();
    let e = bounded
        .message_from_yaml("int32_values: [1, 2, 3, 4]")
        .unwrap_err();
    assert_eq!(e.reason, "4 elements for a sequence of at most 3");
    let strings = dynamic::<shm_cdr::msgs::test_msgs::Strings>();
    let e = strings
        .message_from_yaml("bounded_string_value: abcdefghijklmnopqrstuvw")
        .unwrap_err();
    assert_eq!(
        e.reason,
        "a string longer than the field's bound of 22 bytes"
    );
    // float32's range.
    let basic = dynamic::<shm_cdr::msgs::test_msgs::BasicTypes>();
    let e = basic.message_from_yaml("float32_value: 1e39").unwrap_err();
    assert_eq!(e.reason, "1e39 is beyond float32's range");
    assert!(basic.message_from_yaml("float32_value: .inf").is_ok());
    // Bytes as numbers or one character up to U+00FF.
    let m = basic
        .message_from_yaml("{byte_value: 'é', char_value: 65}")
        .unwrap();
    assert_eq!(m.value("byte_value"), Some(&Value::U8(0xE9)));
    assert!(basic.message_from_yaml("byte_value: 'ab'").is_err());
    assert!(basic.message_from_yaml("byte_value: 256").is_err());
}

#[test]
fn yaml_text_written_reads_back_to_the_same_message() {
    use shm_cdr::dynamic::YamlOptions;
    let ty = dynamic::<shm_cdr::msgs::test_msgs::UnboundedSequences>();
    let text = "bool_values: [true, false]\nbyte_values: [\"\\x00\", é, ' ']\nfloat32_values: [0.1, .inf]\nstring_values: ['1e5', 'yes', \"a\\nb\", '']\n";
    let message = ty.message_from_yaml(text).unwrap();
    for options in [YamlOptions::full(), YamlOptions::full().flow_style(true)] {
        let written = message.to_yaml_with(&options);
        assert_eq!(
            ty.message_from_yaml(&written).unwrap(),
            message,
            "{written}"
        );
    }
    let json = serde_json::to_string(&message).unwrap();
    assert!(json.contains("\"byte_values\":[0,233,32]"), "{json}");
    assert!(
        json.contains("\"float32_values\":[0.10000000149011612,null]"),
        "{json}"
    );
    // JSON is YAML: it reads back, but for the non-finite floats it has no
    // number for.
    let e = ty.message_from_yaml(&json).unwrap_err();
    assert_eq!(e.path, "float32_values[1]");
    let finite = ty.message_from_yaml(&text.replace(".inf", "-2.5")).unwrap();
    let json = serde_json::to_string(&finite).unwrap();
    assert_eq!(ty.message_from_yaml(&json).unwrap(), finite);
}

/// A message decoded for printing with a truncation keeps only what is
/// printed: the same text as the whole message printed with that
/// truncation, from `keep + 1` elements of each sequence of strings or
/// messages however long it is.
#[test]
fn a_truncated_decode_prints_as_the_whole_message_and_keeps_only_what_is_printed() {
    use shm_cdr::dynamic::YamlOptions;

    #[derive(Debug, Clone, Default, PartialEq, RosMessage)]
    #[ros(type_name = "grid_msgs/msg/Cell")]
    struct Cell {
        v: u8,
        tags: Vec<String>,
    }

    #[derive(Debug, Clone, Default, PartialEq, RosMessage)]
    #[ros(type_name = "grid_msgs/msg/Grid")]
    struct Grid {
        cells: Vec<Cell>,
        names: Vec<String>,
        fixed: [Cell; 3],
        data: Vec<u8>,
        label: String,
    }

    let cell = |i: usize| Cell {
        v: i as u8,
        tags: (0..i % 7).map(|t| format!("t{t}")).collect(),
    };
    let grid = Grid {
        cells: (0..100_000).map(cell).collect(),
        names: (0..50_000).map(|i| format!("n{i}")).collect(),
        fixed: [cell(1), cell(2), cell(3)],
        data: vec![9; 10_000],
        label: "a label longer than the truncation".into(),
    };
    let bytes = shm_cdr::to_vec(&grid).unwrap();
    let ty = dynamic::<Grid>();
    for keep in [0, 1, 2, 5, 128] {
        let options = YamlOptions::echo().truncate_length(Some(keep));
        let whole = ty.decode(&bytes).unwrap().to_yaml_with(&options);
        let cut = ty.decode_truncated(&bytes, false, keep).unwrap();
        assert_eq!(cut.to_yaml_with(&options), whole, "keep {keep}");
        assert_eq!(ty.decode_truncated(&bytes, true, keep).unwrap(), cut);
        match cut.value("cells") {
            Some(Value::Messages(cells)) => assert_eq!(cells.len(), keep + 1),
            other => panic!("{other:?}"),
        }
        match cut.value("names") {
            Some(Value::Strings(names)) => assert_eq!(names.len(), keep + 1),
            other => panic!("{other:?}"),
        }
    }
    // Printed without arrays, a message cut to one element of each prints
    // every length it had.
    let options = YamlOptions::echo().no_arr(true);
    let whole = ty.decode(&bytes).unwrap().to_yaml_with(&options);
    assert!(whole.contains("length: 100000"), "{whole}");
    let mut cut = ty.decode_truncated(&bytes, false, 0).unwrap();
    assert_eq!(cut.to_yaml_with(&options), whole);
    // A field set anew has the length of its new value.
    cut.set("names", Value::Strings(vec!["only".into()]))
        .unwrap();
    assert!(
        cut.to_yaml_with(&options)
            .contains("names: '<sequence type: string, length: 1>'"),
        "{}",
        cut.to_yaml_with(&options)
    );
    // Untruncated, it is the whole message; damage past the kept elements
    // is still found.
    assert_eq!(
        ty.decode_truncated(&bytes, false, usize::MAX).unwrap(),
        ty.decode(&bytes).unwrap()
    );
    let short = &bytes[..bytes.len() - 20];
    assert!(ty.decode_truncated(short, false, 1).is_err());
}

#[test]
fn nested_messages_are_read_where_they_lie_and_set_in_place() {
    use shm_cdr::dynamic::Field as DynamicField;
    use shm_cdr::msgs::nav_msgs::Odometry;

    let mut odometry = Odometry {
        child_frame_id: "base_link".into(),
        ..Default::default()
    };
    odometry.header.frame_id = "odom".into();
    odometry.pose.pose.position.x = 1.5;
    odometry.twist.covariance[35] = 0.25;
    let bytes = shm_cdr::to_vec(&odometry).unwrap();
    let ty = dynamic::<Odometry>();
    let mut message = ty.decode(&bytes).unwrap();

    // Every field reads as the view reads it, nested messages included.
    let view = ty.view(&bytes).unwrap();
    for ((name, field), (view_name, view_field)) in message.fields().zip(view.fields()) {
        assert_eq!(name, view_name);
        assert_eq!(field.to_value(), view_field.read().unwrap(), "{name}");
    }
    let position = message
        .message("pose")
        .and_then(|p| p.message("pose"))
        .and_then(|p| p.message("position"))
        .unwrap();
    assert_eq!(position.value("x"), Some(&Value::F64(1.5)));
    assert!(matches!(
        message.get("header"),
        Some(DynamicField::Message(h)) if h.value("frame_id") == Some(&Value::String("odom".into()))
    ));

    // A nested message taken out, changed and set back: the generated type
    // with the same change has the same bytes.
    let mut pose = message.message("pose").unwrap().to_message();
    let mut inner = pose.message("pose").unwrap().to_message();
    let mut point = inner.message("position").unwrap().to_message();
    point.set("y", Value::F64(-2.0)).unwrap();
    inner
        .set("position", Value::Message(Box::new(point)))
        .unwrap();
    pose.set("pose", Value::Message(Box::new(inner))).unwrap();
    message.set("pose", Value::Message(Box::new(pose))).unwrap();
    odometry.pose.pose.position.y = -2.0;
    assert_eq!(
        shm_cdr::to_vec(&message).unwrap(),
        shm_cdr::to_vec(&odometry).unwrap()
    );
    // The fields after it are where they were.
    assert_eq!(
        message.value("child_frame_id"),
        Some(&Value::String("base_link".into()))
    );
    // A nested message is not the message's type, nor its own field's.
    let header = message.message("header").unwrap().to_message();
    assert!(!header.is_of(&ty));
    assert!(message
        .set("pose", Value::Message(Box::new(header)))
        .is_err());
}

#[test]
fn a_body_in_segments_decodes_as_the_whole_or_says_it_is_fragmented() {
    use shm_cdr::{LittleEndian, Reader};

    let imu = sensor_msgs::msg::Imu {
        header: std_msgs::msg::Header {
            frame_id: "imu_link".into(),
            ..Default::default()
        },
        orientation_covariance: [0.5; 9],
        ..Default::default()
    };
    let bytes = shm_cdr::to_vec(&imu).unwrap();
    let ty = dynamic::<sensor_msgs::msg::Imu>();
    let whole = ty.decode(&bytes).unwrap();
    let body = &bytes[4..];
    let mut whole_from_segments = 0;
    for split in 1..body.len() {
        let (a, b) = body.split_at(split);
        let mut r = Reader::<LittleEndian>::from_segments(&[a, b]).unwrap();
        match ty.decode_message(&mut r, 0) {
            Ok(message) => {
                assert_eq!(message, whole, "split at {split}");
                whole_from_segments += 1;
            }
            Err(e) => assert!(
                matches!(e.kind(), DecodeErrorKind::Fragmented { .. }),
                "split at {split}: {e}"
            ),
        }
    }
    // Between two fields, or inside a run of them, the segments hold whole
    // values: those splits decode.
    assert!(whole_from_segments > 10, "{whole_from_segments}");
}

/// The little-endian bytes of a sequence of numbers, from its values.
fn le_bytes(value: &Value<'_>) -> Option<Vec<u8>> {
    macro_rules! each {
        ($numbers:expr) => {
            $numbers.iter().flat_map(|x| x.to_le_bytes()).collect()
        };
    }
    Some(match value {
        Value::U8s(v) => v.to_vec(),
        Value::I8s(v) => v.iter().map(|&x| x as u8).collect(),
        Value::I16s(v) => each!(v),
        Value::U16s(v) => each!(v),
        Value::I32s(v) => each!(v),
        Value::U32s(v) => each!(v),
        Value::I64s(v) => each!(v),
        Value::U64s(v) => each!(v),
        Value::F32s(v) => each!(v),
        Value::F64s(v) => each!(v),
        _ => return None,
    })
}

/// Arbitrary values of `T` laid out with every sequence of numbers of the
/// message filled in place: each sequence's values written at the range the
/// layout gives, the rest written around them over stale bytes, give the
/// bytes of the whole message.
fn filled_in_place_is_the_whole_message<T>(values: usize)
where
    T: RosMessage + for<'a> arbitrary::Arbitrary<'a>,
{
    use shm_cdr::describe::Container;

    let ty = dynamic::<T>();
    let noise = noise(0x2545_f491_4f6c_dd1d, values * 512 + 512);
    let mut laid = 0;
    for start in (0..values).map(|k| k * 512) {
        let Ok(value) = T::arbitrary(&mut arbitrary::Unstructured::new(
            &noise[start..start + 512],
        )) else {
            continue;
        };
        let bytes = shm_cdr::to_vec(&value).unwrap();
        let message = ty.decode(&bytes).unwrap();
        let names: Vec<&str> = ty
            .root()
            .fields
            .iter()
            .filter(|f| {
                f.element.is_number()
                    && matches!(
                        f.container,
                        Container::Sequence | Container::BoundedSequence(_)
                    )
            })
            .map(|f| f.name.as_str())
            .collect();
        let paths: Vec<[&str; 1]> = names.iter().map(|name| [*name]).collect();
        let arrays: Vec<(&[&str], usize)> = paths
            .iter()
            .map(|path| {
                (
                    &path[..],
                    message.value(path[0]).and_then(Value::len).unwrap(),
                )
            })
            .collect();
        let layout = ty.lay_out_in_place(&message, &arrays).unwrap();
        assert_eq!(layout.size(), bytes.len(), "{}", T::TYPE_NAME);
        let mut buffer = vec![0xa5u8; layout.size()];
        for array in layout.arrays() {
            let values = le_bytes(message.value(&array.path()[0]).unwrap()).unwrap();
            buffer[array.range()].copy_from_slice(&values);
        }
        layout.write_around(&message, &mut buffer).unwrap();
        assert_eq!(buffer, bytes, "{}", T::TYPE_NAME);
        laid += 1;
    }
    assert!(laid > 0, "no arbitrary {} was made", T::TYPE_NAME);
}

#[test]
fn every_sequence_of_numbers_filled_in_place_gives_the_whole_message() {
    filled_in_place_is_the_whole_message::<test_msgs::msg::UnboundedSequences>(8);
    filled_in_place_is_the_whole_message::<test_msgs::msg::BoundedSequences>(8);
    filled_in_place_is_the_whole_message::<sensor_msgs::msg::PointCloud2>(8);
    filled_in_place_is_the_whole_message::<sensor_msgs::msg::LaserScan>(8);
    filled_in_place_is_the_whole_message::<sensor_msgs::msg::Image>(8);
}

#[test]
fn a_field_set_by_its_path_is_set_in_place_as_the_generated_message_holds_it() {
    use shm_cdr::msgs::geometry_msgs::PoseWithCovarianceStamped;
    let ty = dynamic::<PoseWithCovarianceStamped>();
    let mut ours = ty.default_message();
    ours.set_path(&["header", "stamp", "nanosec"], Value::U32(17))
        .unwrap();
    ours.set_path(&["header", "frame_id"], Value::String("map".into()))
        .unwrap();
    ours.set_path(&["pose", "pose", "orientation", "w"], Value::F64(0.5))
        .unwrap();
    ours.set_path(&["pose", "covariance"], Value::F64s(vec![2.0; 36].into()))
        .unwrap();
    let mut expected = PoseWithCovarianceStamped::default();
    expected.header.stamp.nanosec = 17;
    expected.header.frame_id = "map".into();
    expected.pose.pose.orientation.w = 0.5;
    expected.pose.covariance = [2.0; 36];
    assert_eq!(
        shm_cdr::to_vec(&ours).unwrap(),
        shm_cdr::to_vec(&expected).unwrap()
    );

    // Refused, the message left as it was: a wrong kind, a field that is
    // not there, a step through a number, an empty path, an array too short.
    let before = ours.clone();
    for (path, value) in [
        (&["header", "stamp", "nanosec"][..], Value::I32(1)),
        (&["header", "stamp", "minutes"][..], Value::U32(1)),
        (&["header", "stamp", "sec", "x"][..], Value::U32(1)),
        (&[][..], Value::U32(1)),
        (
            &["pose", "covariance"][..],
            Value::F64s(vec![1.0; 35].into()),
        ),
    ] {
        let error = ours.set_path(path, value).unwrap_err();
        assert!(!error.to_string().is_empty());
        assert_eq!(ours, before, "{path:?}");
    }

    // A step through an array of messages names the array.
    let cloud = dynamic::<sensor_msgs::PointCloud2>();
    let mut message = cloud.default_message();
    let error = message
        .set_path(&["fields", "name"], Value::String("x".into()))
        .unwrap_err();
    assert!(error.to_string().contains("fields"), "{error}");
}
