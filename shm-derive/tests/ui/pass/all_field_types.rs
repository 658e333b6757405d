use std::borrow::Cow;

use shm_cdr::{BoundedString, BoundedVec, BoundedWString, RosMessage, WString};

#[derive(RosMessage)]
#[ros(package = "ui_msgs")]
struct Inner {
    x: f64,
}

#[derive(RosMessage)]
#[ros(type_name = "ui_msgs/msg/Everything")]
struct Everything<'a> {
    flag: bool,
    a: u8,
    b: i8,
    c: u16,
    d: i16,
    e: u32,
    f: i32,
    g: u64,
    h: i64,
    i: f32,
    j: f64,
    #[ros(char)]
    k: u8,
    #[ros(byte)]
    l: u8,
    #[ros(byte)]
    blob: Vec<u8>,
    text: String,
    bounded_text: BoundedString<8>,
    wide: WString,
    bounded_wide: BoundedWString<8>,
    seq: Vec<Inner>,
    bounded_seq: BoundedVec<Inner, 3>,
    array: [Inner; 2],
    strings: Vec<String>,
    array_of_strings: [String; 2],
    bytes: bytes::Bytes,
    borrowed_text: &'a str,
    borrowed_bytes: &'a [u8],
    cow_text: Cow<'a, str>,
    cow_floats: Cow<'a, [f64]>,
    #[ros(rename = "renamed_field")]
    other_name: u8,
    r#type: u8,
}

#[derive(RosMessage)]
#[ros(package = "ui_msgs")]
struct Unit;

#[derive(RosMessage)]
#[ros(package = "ui_msgs")]
struct NoFields {}

mod reexport {
    pub use shm_cdr as wire;
}

#[derive(reexport::wire::RosMessage)]
#[ros(type_name = "ui_msgs/msg/ViaReexport", crate = "reexport::wire")]
struct ViaReexport {
    v: u32,
}

fn main() {
    assert_eq!(Everything::TYPE_NAME, "ui_msgs/msg/Everything");
    assert_eq!(Unit::ENCODED_SIZE, Some(5));
    assert_eq!(NoFields::ENCODED_SIZE, Some(5));
    assert_eq!(ViaReexport::DDS_TYPE_NAME, "ui_msgs::msg::dds_::ViaReexport_");
    let names: Vec<&str> = Everything::FIELDS.iter().map(|f| f.name).collect();
    assert_eq!(names[names.len() - 2..], ["renamed_field", "type"]);
}
