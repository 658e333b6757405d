//! Session helpers shared by the integration tests.

use zenoh::Config;

/// A peer on TCP loopback with multicast scouting off, listening on or
/// connecting to `port`.
pub fn peer_config(port: u16, listen: bool) -> Config {
    let mut c = Config::default();
    c.insert_json5("mode", "\"peer\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    let key = if listen {
        "listen/endpoints"
    } else {
        "connect/endpoints"
    };
    c.insert_json5(key, &format!("[\"tcp/127.0.0.1:{port}\"]"))
        .unwrap();
    c
}
