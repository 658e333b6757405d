//! A node whose session connects somewhere that nobody answers says so once,
//! as rmw_zenoh_cpp's nodes do, and goes on.

use std::io::Write;
use std::sync::{Arc, Mutex};

use shm_runtime::testing::{free_port, peer_config};
use shm_runtime::RosNode;
use zenoh::Wait;

/// The log, as the default format writes it.
#[derive(Clone, Default)]
struct Log(Arc<Mutex<Vec<u8>>>);

impl Write for Log {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Log {
    fn text(&self) -> String {
        String::from_utf8_lossy(&self.0.lock().unwrap()).into_owned()
    }
}

#[test]
fn a_node_that_reaches_nobody_says_what_to_start_once() {
    let log = Log::default();
    let writer = log.clone();
    tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_ansi(false)
        .init();
    std::env::remove_var("ZENOH_ROUTER_CHECK_ATTEMPTS");

    // Connected to a peer: nothing said.
    let port = free_port().unwrap();
    let listener = zenoh::open(peer_config(port, true).unwrap())
        .wait()
        .unwrap();
    let connected = zenoh::open(peer_config(port, false).unwrap())
        .wait()
        .unwrap();
    let _node = RosNode::builder(&connected, "fine").wait().unwrap();
    assert!(!log.text().contains("No Zenoh router"), "{}", log.text());
    drop(listener);

    // Connecting to a port nobody listens on: said once, naming it.
    let nobody = free_port().unwrap();
    let alone = zenoh::open(peer_config(nobody, false).unwrap())
        .wait()
        .unwrap();
    let _first = RosNode::builder(&alone, "first").wait().unwrap();
    let _second = RosNode::builder(&alone, "second").wait().unwrap();
    let text = log.text();
    let said: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("No Zenoh router or peer reached"))
        .collect();
    assert_eq!(said.len(), 1, "{text}");
    assert!(
        said[0].contains(&format!("tcp/127.0.0.1:{nobody}")),
        "{text}"
    );
    assert!(said[0].contains("shm-ros2 router"), "{text}");
}
