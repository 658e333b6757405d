//! A crate that forbids unsafe code can still derive (the bulk-copy proof the
//! derive emits is `unsafe` at the macro's call site, not in user code).
#![forbid(unsafe_code)]

use shm_cdr::RosMessage;

#[derive(RosMessage, Debug, PartialEq)]
#[ros(package = "ui_msgs")]
#[repr(C)]
struct Packed {
    a: f64,
    b: f64,
}

fn main() {
    assert!(<Packed as shm_cdr::CdrEncode>::PLAIN.is_some());
    let bytes = shm_cdr::to_vec(&vec![Packed { a: 1.0, b: 2.0 }]).unwrap();
    let back: Vec<Packed> = shm_cdr::from_bytes(&bytes).unwrap();
    assert_eq!(back, vec![Packed { a: 1.0, b: 2.0 }]);
}
