//! Views decoded from shared memory stay sound when the memory is rewritten:
//! any process that maps a segment (every subscriber does, read-write) can
//! write it while a reader still holds what it decoded. Strings are copied
//! out of shared memory and checked in the copy, so no rewrite can make a
//! `str` the application holds invalid; byte and number slices still borrow
//! (every bit pattern is a valid value of them).
//!
//! The rewrite goes through `/proc/self/mem`, as another process's write
//! would: outside anything this program holds a reference to.

mod common;

use std::borrow::Cow;
use std::io::{Seek, SeekFrom, Write};
use std::time::Duration;

use common::{loopback_sessions, shm_serial};
use shm_cdr::msgs::std_msgs::{String as RosString, UInt8MultiArray};
use shm_cdr::msgs::std_msgs::{StringRef, UInt8MultiArrayRef};
use shm_cdr::{DecodeErrorKind, RosMessage};
use shm_runtime::ShmOptions;
use shm_runtime::{SessionExt, ShmConfig, ShmContext};
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

/// Write `bytes` at `address` the way another process would: not through a
/// reference of this program's.
fn rewrite(address: *const u8, bytes: &[u8]) {
    let mut memory = std::fs::OpenOptions::new()
        .write(true)
        .open("/proc/self/mem")
        .unwrap();
    memory.seek(SeekFrom::Start(address as u64)).unwrap();
    memory.write_all(bytes).unwrap();
}

/// A hand-written message with a `&str` field.
#[derive(RosMessage, Debug)]
#[ros(type_name = "std_msgs/msg/String")]
struct BorrowedString<'a> {
    data: &'a str,
}

#[test]
fn a_string_view_of_shared_memory_stays_valid_when_the_segment_is_rewritten() {
    let _shm = shm_serial();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(0)).unwrap();
    let publisher = a
        .declare_ros_publisher::<RosString>("views/string")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<RosString>("views/string")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    publisher
        .publish(&RosString {
            data: "hello, shared memory".into(),
        })
        .wait()
        .unwrap();
    let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
    assert!(
        sample.is_shm(),
        "the message did not come through shared memory"
    );

    let view: StringRef = sample.decode().unwrap();
    assert!(
        matches!(view.data, Cow::Owned(_)),
        "a string borrowed from shared memory"
    );
    // A `&str` field cannot be read from shared memory; the error says what can.
    let refused = sample.decode::<BorrowedString>().unwrap_err();
    assert_eq!(refused.kind(), &DecodeErrorKind::SharedBorrow);
    assert!(refused.to_string().contains("Cow<str>"), "{refused}");

    // Another process writes bytes that are not UTF-8 over the string.
    let payload = sample.payload().slices().next().unwrap();
    let at = payload.windows(5).position(|w| w == b"hello").unwrap();
    rewrite(payload[at..].as_ptr(), &[0xff, 0xfe]);
    // What was decoded is what was checked: still the string sent.
    assert_eq!(view.data, "hello, shared memory");
    assert!(std::str::from_utf8(view.data.as_bytes()).is_ok());
    // Decoding again sees the rewrite, and reports it.
    let again = sample.decode::<StringRef>().unwrap_err();
    assert!(
        matches!(again.kind(), DecodeErrorKind::InvalidUtf8 { .. }),
        "{again}"
    );
}

#[test]
fn byte_views_still_borrow_shared_memory_and_read_what_is_there() {
    let _shm = shm_serial();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(0)).unwrap();
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>("views/bytes")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<UInt8MultiArray>("views/bytes")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    publisher
        .publish(&UInt8MultiArray {
            data: vec![1; 4096],
            ..Default::default()
        })
        .wait()
        .unwrap();
    let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
    assert!(sample.is_shm());
    let view: UInt8MultiArrayRef = sample.decode().unwrap();
    let payload = sample.payload().slices().next().unwrap();
    assert!(
        payload.as_ptr_range().contains(&view.data.as_ptr()),
        "bytes were copied"
    );
    // Any value is a valid byte: a rewrite changes what is read, nothing more.
    rewrite(view.data.as_ptr(), &[9]);
    // SAFETY: a volatile read of a byte the view points to, which the write
    // above changed outside this program's references.
    let now = unsafe { std::ptr::read_volatile(view.data.as_ptr()) };
    assert_eq!(now, 9);
}
