//! The Zenoh line the runtime reports is the one linked. CI runs this file on
//! every supported line (tests/zenoh-lines/<line>), so a line whose
//! shared-memory protocol changed is caught before it is reported wrongly.

use shm_runtime::ZenohLine;

#[test]
fn the_built_line_is_a_supported_one_with_its_real_protocol() {
    let built = ZenohLine::BUILT;
    assert!(
        ZenohLine::SUPPORTED.contains(&built),
        "Zenoh {built} is linked but not in ZenohLine::SUPPORTED"
    );
    assert!(
        zenoh::GIT_VERSION.starts_with(&format!("v{built}.")),
        "{} is not on line {built}",
        zenoh::GIT_VERSION
    );
    // The protocol the table gives this line is the one its zenoh-shm speaks.
    assert_eq!(
        built.shm_protocol(),
        Some(ZenohLine::BUILT_SHM_PROTOCOL),
        "the table's protocol for Zenoh {built}"
    );
    // A line shares memory with itself and with exactly the supported lines of
    // its protocol.
    for line in ZenohLine::SUPPORTED {
        assert_eq!(
            built.shares_memory_with(line),
            Some(line.shm_protocol() == Some(ZenohLine::BUILT_SHM_PROTOCOL)),
            "{built} with {line}"
        );
    }
}
