//! A managed node for an independent lifecycle manager
//! (`tests/ros2/lifecycle.py`: Python eclipse-zenoh and rclpy's
//! serialization), which drives this node and an rclpy lifecycle node with
//! the same callbacks through the same transitions and compares the replies
//! and the transition events.
//!
//! `interop_lifecycle <listen endpoint>`: node `/demo/lc_node` whose
//! `on_configure` fails the first time, `on_activate` errs the first time
//! (and `on_error` recovers), `on_cleanup` panics the first time; a
//! lifecycle publisher on `/demo/heartbeat` publishes every 50 ms while
//! active. Prints `ready`, serves until stdin closes, then prints how many
//! heartbeats went out.

use std::io::BufRead;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use shm_cdr::msgs::std_msgs::String as Text;
use shm_cdr_examples::peer_session;
use shm_runtime::lifecycle::{CallbackReturn, Managed, State};
use shm_runtime::RosNode;
use zenoh::Wait;

/// Counts the calls of each callback: the first `on_configure` fails, the
/// first `on_activate` errs, the first `on_cleanup` panics.
#[derive(Default)]
struct Driver {
    configured: usize,
    activated: usize,
    cleaned: usize,
}

impl Managed for Driver {
    fn on_configure(&mut self, _previous: State) -> CallbackReturn {
        self.configured += 1;
        match self.configured {
            1 => CallbackReturn::Failure,
            _ => CallbackReturn::Success,
        }
    }
    fn on_activate(&mut self, _previous: State) -> CallbackReturn {
        self.activated += 1;
        match self.activated {
            1 => CallbackReturn::Error,
            _ => CallbackReturn::Success,
        }
    }
    fn on_cleanup(&mut self, _previous: State) -> CallbackReturn {
        self.cleaned += 1;
        if self.cleaned == 1 {
            panic!("the first cleanup fails");
        }
        CallbackReturn::Success
    }
}

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let endpoint = std::env::args()
        .nth(1)
        .ok_or("usage: interop_lifecycle <listen endpoint>")?;
    // The panic of the first cleanup is expected: keep its report short.
    std::panic::set_hook(Box::new(|info| eprintln!("interop_lifecycle: {info}")));
    let session = peer_session(&endpoint, true)?;
    let node = RosNode::builder(&session, "lc_node")
        .namespace("/demo")
        .domain_id(0)
        .wait()?;
    let lifecycle = node.lifecycle(Driver::default())?;
    let heartbeat = lifecycle.publisher(node.declare_publisher::<Text>("heartbeat").wait()?);
    let running = Arc::new(AtomicBool::new(true));
    let sent = Arc::new(AtomicUsize::new(0));
    let beat = {
        let (running, sent) = (running.clone(), sent.clone());
        std::thread::spawn(move || {
            while running.load(Ordering::Relaxed) {
                let message = Text {
                    data: "alive".into(),
                };
                if let Ok(Some(_)) = heartbeat.publish(&message).wait() {
                    sent.fetch_add(1, Ordering::Relaxed);
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        })
    };
    println!("ready");
    for line in std::io::stdin().lock().lines() {
        line?;
    }
    running.store(false, Ordering::Relaxed);
    beat.join().map_err(|_| "the heartbeat thread panicked")?;
    println!(
        "state {}, {} heartbeats sent while active",
        lifecycle.state(),
        sent.load(Ordering::Relaxed)
    );
    Ok(())
}
