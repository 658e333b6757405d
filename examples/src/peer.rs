//! Sessions and graph tokens of the examples' peers. Also compiled into the
//! `zenoh_lines` example where it is built outside this workspace, on another
//! Zenoh line (`tests/zenoh-lines/<line>/`), so it names only `zenoh` and
//! `shm_runtime`.

use zenoh::{Config, Session, Wait};

/// A peer session on `endpoint` with multicast scouting off: listening on it,
/// or connecting to it. Zenoh's implicit copy of large heap payloads into a
/// shared-memory pool of its own is off, as the guide recommends beside
/// shm-runtime: what travels in shared memory is what a publisher put there.
pub fn peer_session(endpoint: &str, listen: bool) -> zenoh::Result<Session> {
    let mut config = Config::default();
    config.insert_json5("mode", "\"peer\"")?;
    config.insert_json5("scouting/multicast/enabled", "false")?;
    config.insert_json5(
        "transport/shared_memory/transport_optimization/enabled",
        "false",
    )?;
    let key = if listen {
        "listen/endpoints"
    } else {
        "connect/endpoints"
    };
    config.insert_json5(key, &format!("[\"{endpoint}\"]"))?;
    zenoh::open(config).wait()
}

/// The liveliness token an rmw_zenoh_cpp endpoint of `kind` on `topic` (a
/// `T`) declares for a plain Zenoh peer named `zenoh_peer` (`examples/examples/zenoh_peer.rs`),
/// its session left as `{zid}` for the peer to fill in: with it, a node's
/// graph sees the peer as it would see an rmw_zenoh_cpp node.
pub fn zenoh_peer_token<T: shm_runtime::shm_cdr::RosMessage>(
    topic: &str,
    kind: shm_runtime::rmw::EntityKind,
) -> String {
    use shm_runtime::rmw::{Distro, NodeInfo, Qos};
    NodeInfo {
        domain_id: 0,
        zid: "{zid}".into(),
        node_id: 0,
        enclave: "/".into(),
        namespace: "/".into(),
        name: "zenoh_peer".into(),
        distro: Distro::Kilted,
    }
    .topic_token::<T>(1, kind, topic, &Qos::default())
}
