//! Type descriptions beyond the hash: default values and type sources, as a
//! type-description service reports them (compared with rosidl's `.json` files
//! and interface files in `tests/ros2/check.py`).

use shm_cdr::describe::TypeSource;
use shm_cdr::msgs::{geometry_msgs, std_msgs, std_srvs, test_msgs};
use shm_cdr::{BoundedString, BoundedVec, RosMessage, RosService};

/// A type declared in Rust, with the field kinds a `.msg` text must spell.
#[derive(RosMessage, Debug, Clone, PartialEq, Default)]
#[ros(type_name = "my_robot/msg/Arm")]
struct Arm {
    header: std_msgs::msg::Header,
    #[ros(default_value = "3")]
    joints: u32,
    #[ros(default_value = "(0.0, 1.5)")]
    limits: [f64; 2],
    names: Vec<String>,
    #[ros(default_value = "say \"hi\"")]
    label: BoundedString<8>,
    #[ros(byte)]
    raw: BoundedVec<u8, 4>,
    #[ros(default_value = "True")]
    enabled: bool,
}

#[test]
fn a_type_declared_in_rust_gets_a_msg_text_written_from_its_fields() {
    assert_eq!(Arm::SOURCE, TypeSource::NONE);
    let (encoding, text) = Arm::type_description().source_text();
    assert_eq!(encoding, "msg");
    assert_eq!(
        text,
        "std_msgs/Header header\nuint32 joints 3\nfloat64[2] limits [0.0, 1.5]\nstring[] names\n\
         string<=8 label \"say \\\"hi\\\"\"\nbyte[<=4] raw\nbool enabled true"
    );
    let defaults: Vec<_> = Arm::FIELDS.iter().map(|f| f.default_value).collect();
    assert_eq!(
        defaults,
        ["", "3", "(0.0, 1.5)", "", "say \"hi\"", "", "True"]
    );
}

#[test]
fn generated_types_carry_their_file_and_every_form_the_same() {
    let quaternion = geometry_msgs::msg::Quaternion::type_description();
    assert_eq!(quaternion.source.encoding, "msg");
    assert!(quaternion.source.raw_file_contents.ends_with("float64 w 1"));
    let w = quaternion.fields.iter().find(|f| f.name == "w");
    assert_eq!(w.map(|f| f.default_value), Some("1.0"));

    // The borrowing form names the owned form's source: same full description.
    assert_eq!(
        std_msgs::msg::HeaderRef::<'static>::full_description(),
        std_msgs::msg::Header::full_description()
    );
    assert_eq!(
        test_msgs::msg::StringsRef::full_description(),
        test_msgs::msg::Strings::full_description()
    );
}

#[test]
fn service_parts_are_implicit_and_sources_follow_rosidls_order() {
    let full = std_srvs::srv::SetBool::full_description();
    let sources: Vec<_> = full
        .sources()
        .map(|(name, encoding, _)| (name, encoding))
        .collect();
    assert_eq!(
        sources,
        [
            ("std_srvs/srv/SetBool", "srv"),
            ("builtin_interfaces/msg/Time", "msg"),
            ("service_msgs/msg/ServiceEventInfo", "msg"),
            ("std_srvs/srv/SetBool_Event", "implicit"),
            ("std_srvs/srv/SetBool_Request", "implicit"),
            ("std_srvs/srv/SetBool_Response", "implicit"),
        ]
    );
    assert!(full
        .sources()
        .all(|(_, encoding, text)| (encoding == "implicit") == text.is_empty()));
    // Default values stay out of the hash.
    assert_eq!(full.type_hash(), std_srvs::srv::SetBool::type_hash());
    let defaults = test_msgs::msg::Defaults::full_description();
    assert_ne!(defaults.json(), defaults.hashed_json());
    assert_eq!(defaults.type_hash(), test_msgs::msg::Defaults::type_hash());
}
