//! Helpers for tests of programs built on shm-runtime: Zenoh peers on the
//! loopback interface, as two processes of one machine would be, without
//! multicast scouting (which would find every other test's peers).
//!
//! ```
//! use shm_runtime::testing::{free_port, peer_config};
//! use zenoh::Wait;
//!
//! let port = free_port()?;
//! let listener = zenoh::open(peer_config(port, true)?).wait()?;
//! let other = zenoh::open(peer_config(port, false)?).wait()?;
//! # drop((listener, other));
//! # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
//! ```

use zenoh::Config;

/// A TCP port on loopback that nothing is bound to right now, chosen by the
/// kernel (a fixed or derived port collides with the kernel's ephemeral
/// ports, which outgoing connections hold).
pub fn free_port() -> std::io::Result<u16> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|listener| listener.local_addr())
        .map(|addr| addr.port())
}

/// A peer on TCP loopback with multicast scouting off, listening on `port`
/// (`listen`) or connecting to it.
pub fn peer_config(port: u16, listen: bool) -> zenoh::Result<Config> {
    let mut config = Config::default();
    config.insert_json5("mode", "\"peer\"")?;
    config.insert_json5("scouting/multicast/enabled", "false")?;
    let key = if listen {
        "listen/endpoints"
    } else {
        "connect/endpoints"
    };
    config.insert_json5(key, &format!("[\"tcp/127.0.0.1:{port}\"]"))?;
    Ok(config)
}
