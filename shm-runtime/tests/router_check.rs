//! What a node logs: a session that connects somewhere that nobody answers
//! says so once, as rmw_zenoh_cpp's nodes do, and goes on; a call that works
//! logs nothing at error level.

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

/// Everything logged in this process, from the first call on.
fn log() -> &'static Log {
    static LOG: std::sync::OnceLock<Log> = std::sync::OnceLock::new();
    LOG.get_or_init(|| {
        let log = Log::default();
        let writer = log.clone();
        tracing_subscriber::fmt()
            .with_writer(move || writer.clone())
            .with_ansi(false)
            .init();
        log
    })
}

#[test]
fn a_node_that_reaches_nobody_says_what_to_start_once() {
    let log = log();
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

/// Two servers answer every call (the caller takes the first): the late
/// answer is dropped without Zenoh's "sending on a closed channel" ERROR.
#[test]
fn calls_answered_twice_log_no_error() {
    use shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Request, Trigger_Response};

    let log = log();
    let port = free_port().unwrap();
    let a = zenoh::open(peer_config(port, true).unwrap())
        .wait()
        .unwrap();
    let b = zenoh::open(peer_config(port, false).unwrap())
        .wait()
        .unwrap();
    let first = RosNode::builder(&a, "first")
        .router_check(false)
        .wait()
        .unwrap();
    let second = RosNode::builder(&b, "second")
        .router_check(false)
        .wait()
        .unwrap();
    let servers: Vec<_> = [&first, &second]
        .into_iter()
        .map(|node| {
            node.declare_service::<Trigger>("/twice")
                .handler(|_| Trigger_Response {
                    success: true,
                    message: String::new(),
                })
                .wait()
                .unwrap()
        })
        .collect();
    let client = first.declare_client::<Trigger>("/twice").wait().unwrap();
    assert!(client.wait_for_service(std::time::Duration::from_secs(5)));
    for _ in 0..20 {
        assert!(client.call(&Trigger_Request).wait().unwrap().success);
    }
    // The late answers arrive after their calls returned.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let text = log.text();
    assert!(!text.contains("closed channel"), "{text}");
    drop(servers);
}
