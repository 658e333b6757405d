//! The Zenoh lines the shared-memory proof (`tests/zenoh-lines/check.py`)
//! runs against follow what rmw_zenoh_cpp ships.

use shm_runtime::rmw::DISTRIBUTIONS;

/// The version a Cargo.lock pins for `zenoh`.
fn locked_zenoh(lock_file: &str) -> String {
    let path = format!("{}/../{lock_file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let at = text
        .find("name = \"zenoh\"\nversion = \"")
        .unwrap_or_else(|| panic!("{path}: no zenoh"));
    let rest = &text[at + "name = \"zenoh\"\nversion = \"".len()..];
    rest[..rest.find('"').unwrap()].to_owned()
}

#[test]
fn the_zenoh_peer_of_rmw_zenoh_cpp_is_pinned_to_what_every_distribution_ships() {
    let peer = locked_zenoh("tests/zenoh-lines/1.8/Cargo.lock");
    for distribution in DISTRIBUTIONS {
        assert_eq!(distribution.zenoh_version, peer, "{}", distribution.name);
    }
    // The workspace is on a line whose shared memory is 1.8's: 1.9.
    let ours = locked_zenoh("Cargo.lock");
    assert!(
        ours.starts_with("1.9."),
        "the workspace's Zenoh is {ours}: \
        check tests/zenoh-lines/check.py against rmw_zenoh_cpp's 1.8 before moving"
    );
}
