//! Loaned messages between two peer sessions over TCP loopback: built in place in
//! one exact-size shared-memory chunk, received as that chunk, read as typed
//! slices borrowed from it; unwritten loans refused; dropped loans give their
//! chunk back; a small pool under loans from several threads ends in heap
//! fallbacks, never a block.

use std::borrow::Cow;
use std::sync::mpsc;
use std::time::Duration;

use shm_cdr::loan::InPlace;
use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::sensor_msgs::{LaserScan, LaserScanLens, LaserScanRef};
use shm_cdr::msgs::std_msgs::{Header, HeaderLens};
use shm_runtime::ShmOptions;
use shm_runtime::{PayloadKind, PublishError, SessionExt, ShmConfig, ShmContext};
use zenoh::Wait;

mod common;
use common::loopback_sessions;

const TIMEOUT: Duration = Duration::from_secs(10);

fn scan(n: usize, seed: f32) -> LaserScan {
    LaserScan {
        header: Header {
            stamp: Time { sec: 1, nanosec: 2 },
            frame_id: "laser".into(),
        },
        angle_min: -1.5,
        angle_max: 1.5,
        angle_increment: 3.0 / n as f32,
        time_increment: 0.0,
        scan_time: 0.1,
        range_min: 0.1,
        range_max: 30.0,
        ranges: (0..n).map(|i| seed + i as f32 * 0.01).collect(),
        intensities: (0..n).map(|i| (i % 7) as f32).collect(),
    }
}

/// Fill a loan's fields from `msg`, the way an application writes them.
fn fill(loan: &mut shm_runtime::Loan<'_, LaserScan>, msg: &LaserScan) {
    let fields = loan.fields().unwrap();
    *fields.header.stamp.sec = msg.header.stamp.sec;
    *fields.header.stamp.nanosec = msg.header.stamp.nanosec;
    fields.header.frame_id.write(&msg.header.frame_id).unwrap();
    *fields.angle_min = msg.angle_min;
    *fields.angle_max = msg.angle_max;
    *fields.angle_increment = msg.angle_increment;
    *fields.scan_time = msg.scan_time;
    *fields.range_min = msg.range_min;
    *fields.range_max = msg.range_max;
    fields.ranges.write_with(|i| msg.ranges[i]);
    fields.intensities.write_slice(&msg.intensities).unwrap();
}

#[test]
fn a_loaned_scan_is_one_shm_chunk_equal_to_to_vec_and_read_as_borrowed_floats() {
    let _shm = common::shm_serial();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(4096)).unwrap();
    let publisher = a
        .declare_ros_publisher::<LaserScan>("loans/scan")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<LaserScan>("loans/scan")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    for (n, kind) in [(100_000, PayloadKind::Shm), (10, PayloadKind::Heap)] {
        let msg = scan(n, 0.25);
        let mut loan = publisher.loan(msg.lens()).unwrap();
        assert_eq!(loan.kind(), kind);
        assert_eq!(loan.size(), shm_cdr::encoded_size(&msg));
        assert_eq!(loan.unwritten(), 3, "frame_id, ranges, intensities");
        fill(&mut loan, &msg);
        let outcome = loan.publish().wait().unwrap();
        assert_eq!(outcome.kind, kind);
        assert_eq!(outcome.size, shm_cdr::encoded_size(&msg));

        let sample = subscriber.recv_timeout(TIMEOUT).unwrap().expect("lost");
        assert_eq!(sample.is_shm(), kind == PayloadKind::Shm, "{n}");
        assert_eq!(
            sample.payload().slices().count(),
            1,
            "one contiguous payload"
        );
        assert_eq!(
            &*sample.payload().to_bytes(),
            shm_cdr::to_vec(&msg).unwrap().as_slice(),
            "{n} points: byte for byte to_vec's"
        );
        let view: LaserScanRef = sample.decode().unwrap();
        if kind == PayloadKind::Shm {
            let Cow::Borrowed(ranges) = &view.ranges else {
                panic!("float32[] in a shared-memory payload is borrowed");
            };
            let payload = sample.payload().slices().next().unwrap().as_ptr_range();
            assert!(payload.contains(&ranges.as_ptr().cast()));
        }
        assert_eq!(&*view.ranges, &msg.ranges[..]);
        assert_eq!(&*view.intensities, &msg.intensities[..]);
        assert_eq!(view.header.frame_id, "laser");
    }
    assert_eq!((shm.stats().shm, shm.stats().heap), (1, 1));
}

#[test]
fn an_unwritten_loan_is_refused_and_nothing_is_sent() {
    let _shm = common::shm_serial();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(0)).unwrap();
    let publisher = a
        .declare_ros_publisher::<LaserScan>("loans/unwritten")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<LaserScan>("loans/unwritten")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    let lens = LaserScanLens {
        header: HeaderLens {
            frame_id: 5,
            ..Default::default()
        },
        ranges: 1000,
        intensities: 0,
        ..Default::default()
    };
    let mut loan = publisher.loan(lens.clone()).unwrap();
    let fields = loan.fields().unwrap();
    fields.header.frame_id.write("laser").unwrap();
    // `ranges` never written.
    match loan.publish().wait() {
        Err(PublishError::Loan(e)) => assert!(e.to_string().contains("never written"), "{e}"),
        other => panic!("an unwritten loan was published: {other:?}"),
    }
    // A later complete one arrives, and is the first thing that does.
    let mut loan = publisher.loan(lens).unwrap();
    let fields = loan.fields().unwrap();
    fields.header.frame_id.write("first").unwrap();
    fields.ranges.fill(1.0);
    loan.publish().wait().unwrap();
    let first: LaserScan = subscriber
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("lost")
        .decode()
        .unwrap();
    assert_eq!(first.header.frame_id, "first");
    assert_eq!(shm.stats().shm, 1, "the refused loan was not counted");
}

#[test]
fn a_dropped_loan_gives_its_chunk_back() {
    let _shm = common::shm_serial();
    let (a, _b, _) = loopback_sessions();
    let pool_size = 4 << 20;
    let shm = ShmContext::new(
        ShmConfig::enabled()
            .pool_size(pool_size)
            .threshold(0)
            .alloc_timeout(Duration::from_millis(50)),
    )
    .unwrap();
    let publisher = a
        .declare_ros_publisher::<LaserScan>("loans/dropped")
        .shm(&shm)
        .wait()
        .unwrap();
    // Three quarters of the pool: a second one fits only if the first came back.
    let lens = LaserScanLens {
        ranges: pool_size * 3 / 4 / 4,
        ..Default::default()
    };
    for round in 0..5 {
        let loan = publisher.loan(lens.clone()).unwrap();
        assert_eq!(loan.kind(), PayloadKind::Shm, "round {round}");
        drop(loan);
    }
    let held = publisher.loan(lens.clone()).unwrap();
    let second = publisher.loan(lens).unwrap();
    assert_eq!(held.kind(), PayloadKind::Shm);
    assert_eq!(second.kind(), PayloadKind::HeapFallback, "the pool is full");
}

#[test]
fn loans_from_many_threads_on_a_small_pool_end_in_fallbacks_not_a_block() {
    let _shm = common::shm_serial();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(
        ShmConfig::enabled()
            .pool_size(1 << 20)
            .threshold(0)
            .alloc_timeout(Duration::from_millis(20)),
    )
    .unwrap();
    let publisher = a
        .declare_ros_publisher::<LaserScan>("loans/threads")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<LaserScan>("loans/threads")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    let threads = 6;
    let per_thread = 10;
    let (done, finished) = mpsc::channel();
    std::thread::scope(|s| {
        for t in 0..threads {
            let publisher = &publisher;
            let done = done.clone();
            s.spawn(move || {
                for i in 0..per_thread {
                    // 400 KiB each: at most two fit in the pool at once.
                    let msg = scan(100_000, (t * 100 + i) as f32);
                    let mut loan = publisher.loan(msg.lens()).unwrap();
                    fill(&mut loan, &msg);
                    // Hold it a moment, as a slow writer would.
                    std::thread::sleep(Duration::from_millis(5));
                    loan.publish().wait().unwrap();
                }
                done.send(t).unwrap();
            });
        }
        for _ in 0..threads {
            // Each thread finishes: a full pool means a bounded wait, then the heap.
            finished
                .recv_timeout(Duration::from_secs(60))
                .expect("a loan blocked");
        }
    });
    let stats = shm.stats();
    assert_eq!(stats.shm + stats.fallbacks, (threads * per_thread) as u64);
    assert!(stats.fallbacks > 0, "{stats:?}");
    assert!(stats.shm > 0, "{stats:?}");
    let mut received = 0;
    while let Ok(Some(sample)) = subscriber.recv_timeout(Duration::from_secs(2)) {
        let msg: LaserScan = sample.decode().unwrap();
        let seed = msg.ranges[0];
        assert_eq!(msg, scan(100_000, seed), "every loan arrives intact");
        received += 1;
        if received == threads * per_thread {
            break;
        }
    }
    assert_eq!(received, threads * per_thread);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_loan_publishes_with_await() {
    let _shm = common::shm_serial();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(0)).unwrap();
    let publisher = a
        .declare_ros_publisher::<LaserScan>("loans/async")
        .shm(&shm)
        .await
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<LaserScan>("loans/async")
        .await
        .unwrap();
    tokio::time::timeout(TIMEOUT, publisher.subscribers_matched())
        .await
        .unwrap()
        .unwrap();
    let msg = scan(1000, 3.0);
    let mut loan = publisher.loan(msg.lens()).unwrap();
    fill(&mut loan, &msg);
    assert_eq!(loan.publish().await.unwrap().kind, PayloadKind::Shm);
    let sample = tokio::time::timeout(TIMEOUT, subscriber.recv_async())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(sample.decode::<LaserScan>().unwrap(), msg);
}

/// A run-time typed message laid out around its pixels in a lent buffer:
/// the pixels written where they lie, the rest around them, sent as the one
/// chunk, received byte for byte as the whole message encodes; a buffer from
/// another pool is refused.
#[test]
fn a_buffer_loan_laid_out_in_place_arrives_as_the_whole_message_encodes() {
    use shm_cdr::dynamic::{DynamicType, Value};
    use shm_cdr::msgs::sensor_msgs::Image;
    use shm_cdr::RosMessage;

    let _shm = common::shm_serial();
    let (a, b, _) = loopback_sessions();
    // Two pools of 1 MiB: room for both under an ordinary user's 8 MiB
    // memory-lock limit.
    let pool = ShmConfig::enabled()
        .threshold(4096)
        .pool_size_at_most(1 << 20);
    let shm = ShmContext::new(pool).unwrap();
    let publisher = a
        .declare_ros_publisher::<Image>("loans/image")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<Image>("loans/image")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    let ty = DynamicType::from_description(&Image::full_description()).unwrap();
    for (pixels, kind) in [(100_000usize, PayloadKind::Shm), (12, PayloadKind::Heap)] {
        let mut image = ty.default_message();
        image
            .set("encoding", Value::String("mono8".into()))
            .unwrap();
        image.set("width", Value::U32(pixels as u32)).unwrap();
        let layout = ty.lay_out_in_place(&image, &[(&["data"], pixels)]).unwrap();
        let mut loan = publisher.loan_buffer(layout.size());
        assert_eq!((loan.kind(), loan.size()), (kind, layout.size()));
        let data: Vec<u8> = (0..pixels).map(|i| (i % 253) as u8).collect();
        loan.as_mut_slice()[layout.arrays()[0].range()].copy_from_slice(&data);
        layout.write_around(&image, loan.as_mut_slice()).unwrap();
        let payload = loan.freeze();
        let kept = payload.clone();
        let outcome = publisher.publish_loaned(payload).unwrap();
        assert_eq!((outcome.kind, outcome.size), (kind, layout.size()));
        assert_eq!(kept.size(), layout.size());

        let sample = subscriber.recv_timeout(TIMEOUT).unwrap().expect("lost");
        assert_eq!(sample.is_shm(), kind == PayloadKind::Shm, "{pixels}");
        image.set("data", Value::U8s(data.into())).unwrap();
        assert_eq!(
            &*sample.payload().to_bytes(),
            shm_cdr::to_vec(&image).unwrap().as_slice(),
            "{pixels} pixels"
        );
    }

    // A chunk of another pool cannot go out on this publisher's.
    let other = ShmContext::new(pool).unwrap();
    let elsewhere = a
        .declare_ros_publisher::<Image>("loans/elsewhere")
        .shm(&other)
        .wait()
        .unwrap();
    let mut loan = elsewhere.loan_buffer(8192);
    assert_eq!(loan.kind(), PayloadKind::Shm);
    loan.as_mut_slice()[..4].copy_from_slice(&[0, 1, 0, 0]);
    assert!(matches!(
        publisher.publish_loaned(loan.freeze()),
        Err(PublishError::OtherPool)
    ));
    // Bytes that are no CDR are refused too.
    let mut loan = publisher.loan_buffer(16);
    loan.as_mut_slice().fill(0xff);
    assert!(matches!(
        publisher.publish_loaned(loan.freeze()),
        Err(PublishError::NotCdr { len: 16 })
    ));
}
