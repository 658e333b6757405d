//! Shared memory under the process's memory-lock limit (`ulimit -l`), as an
//! ordinary user meets it. Under root (`CAP_IPC_LOCK`) no limit applies and
//! the default pool is 10 MiB; `.ci/unprivileged` runs this binary as an
//! ordinary user under 8 MiB (a pool that fits beside a peer's) and 64 KiB (no
//! pool: publishing goes on from the heap).

mod common;

use std::time::Duration;

use common::{loopback_sessions, shm_serial};
use shm_cdr::msgs::sensor_msgs::Image;
use shm_runtime::ShmOptions;
use shm_runtime::{
    MemlockBudget, PayloadKind, SessionExt, ShmConfig, ShmContext, ZENOH_METADATA_SEGMENT,
};
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn the_default_pool_fits_the_limit_and_every_message_arrives_either_way() {
    let _shm = shm_serial();
    let before = MemlockBudget::read();
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let after = MemlockBudget::read();
    match (before.available(), shm.pool_size()) {
        (None, size) => assert_eq!(size, Some(ShmConfig::DEFAULT_POOL_SIZE)),
        (Some(available), Some(size)) => {
            // Room is left for a peer's pool of the same size and its metadata.
            let both = 2 * (size as u64 + ZENOH_METADATA_SEGMENT);
            assert!(both <= available, "{size}-byte pool under {before}");
            assert!(size >= ShmConfig::MIN_FIT_POOL_SIZE);
            assert!(after.locked <= after.limit.unwrap_or(u64::MAX), "{after}");
        }
        (Some(available), None) => assert!(
            available < 2 * (ZENOH_METADATA_SEGMENT + ShmConfig::MIN_FIT_POOL_SIZE as u64),
            "no pool, though {before}"
        ),
    }
    println!("{before}: pool {:?}", shm.pool_size());

    let (a, b, _) = loopback_sessions();
    let publisher = a
        .declare_ros_publisher::<Image>("memlock/images")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<Image>("memlock/images")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    let expected_kind = match shm.pool_size() {
        Some(_) => PayloadKind::Shm,
        None => PayloadKind::PoolUnavailable,
    };
    for i in 0..5u8 {
        let image = Image {
            data: vec![i; 48 * 1024],
            ..Default::default()
        };
        let outcome = publisher.publish(&image).wait().unwrap();
        assert_eq!(outcome.kind, expected_kind, "message {i}");
        let sample = subscriber
            .recv_timeout(TIMEOUT)
            .unwrap()
            .unwrap_or_else(|| panic!("message {i} lost"));
        assert_eq!(sample.is_shm(), shm.pool_size().is_some(), "message {i}");
        assert_eq!(sample.decode::<Image>().unwrap(), image);
    }
    let stats = shm.stats();
    match shm.pool_size() {
        Some(_) => assert_eq!((stats.shm, stats.unavailable), (5, 0)),
        None => assert_eq!((stats.shm, stats.unavailable), (0, 5)),
    }
    assert_eq!(subscriber.missed(), 0);
}

#[test]
fn an_exact_pool_beyond_the_limit_is_an_error_naming_the_limit_and_the_fix() {
    let _shm = shm_serial();
    let budget = MemlockBudget::read();
    let Some(available) = budget.available() else {
        println!("no memory-lock limit applies here ({budget}): nothing to refuse");
        return;
    };
    let too_large = (available as usize + (1 << 20)).next_multiple_of(4096);
    let err = ShmContext::new(ShmConfig::enabled().pool_size(too_large)).unwrap_err();
    let text = format!("{err:?}");
    assert_eq!(err.setting, "ShmConfig::pool_size");
    for needed in ["memory-lock limit", "ulimit -l", "--ulimit memlock="] {
        assert!(text.contains(needed), "{needed:?} in {text}");
    }
    println!("{text}");
}

/// A pool larger than the room in `/dev/shm` (Docker gives a container
/// 64 MiB) is an error naming the room, never Zenoh's panic, even when the
/// pool alone would fit and only Zenoh's metadata segment would not.
#[test]
fn a_pool_beyond_the_room_in_dev_shm_is_an_error_naming_it() {
    let _shm = shm_serial();
    let stats = nix::sys::statvfs::statvfs("/dev/shm").unwrap();
    #[allow(clippy::useless_conversion)] // the field types differ between targets
    let free = u64::from(stats.blocks_available()) * u64::from(stats.fragment_size());
    let pool = (free as usize).saturating_sub(512 * 1024) & !4095;
    if pool > ShmConfig::MAX_POOL_SIZE {
        println!("/dev/shm has {free} bytes free, more than a pool can be: nothing to refuse");
        return;
    }
    let err = ShmContext::new(ShmConfig::enabled().pool_size(pool).prefault(false)).unwrap_err();
    assert_eq!(err.setting, "ShmConfig::pool_size");
    assert!(err.reason.contains("/dev/shm has"), "{err}");
    assert!(err.reason.contains("--shm-size"), "{err}");
    println!("{err}");
}
