//! A node using every generated interface type, for `tests/ros2/type_description.py`
//! (Python eclipse-zenoh and rclpy), which asks its `~/get_type_description` and
//! that of an rclpy node using the same types, and compares the replies.
//!
//! `interop_type_description <listen endpoint>`: node `/demo/td_node` with a
//! publisher of every message type, a server of every service type and an
//! action server of every action type. Prints `<kind> <type name> <hash>` for
//! each, then `ready`, and serves until stdin closes.

use std::io::{BufRead, Write};

use shm_cdr::{RosAction, RosMessage, RosService};
use shm_cdr_examples::peer_session;
use shm_runtime::RosNode;
use zenoh::Wait;

macro_rules! declare_all {
    (messages: [$($m:path,)*], borrowed: [$(($o:path, $r:path),)*], services: [$($s:path,)*], actions: [$($a:path,)*],) => {
        fn declare_all(
            node: &RosNode,
            out: &mut impl Write,
        ) -> zenoh::Result<Vec<Box<dyn std::any::Any>>> {
            let mut keep: Vec<Box<dyn std::any::Any>> = Vec::new();
            let mut n = 0;
            $(
                n += 1;
                keep.push(Box::new(node.declare_publisher::<$m>(&format!("/td/topic_{n}")).wait()?));
                writeln!(out, "message {} {}", <$m as RosMessage>::TYPE_NAME, <$m as RosMessage>::type_hash())?;
            )*
            $(
                n += 1;
                keep.push(Box::new(node.declare_service::<$s>(&format!("/td/service_{n}")).wait()?));
                writeln!(out, "service {} {}", <$s as RosService>::TYPE_NAME, <$s as RosService>::type_hash())?;
            )*
            $(
                n += 1;
                keep.push(Box::new(node.declare_action_server::<$a>(&format!("/td/action_{n}")).wait()?));
                writeln!(out, "action {} {}", <$a as RosAction>::TYPE_NAME, <$a as RosAction>::type_hash())?;
            )*
            Ok(keep)
        }
    };
}

shm_cdr::for_each_interface!(declare_all);

fn main() -> zenoh::Result<()> {
    let endpoint = std::env::args()
        .nth(1)
        .ok_or("usage: interop_type_description <listen endpoint>")?;
    let session = peer_session(&endpoint, true)?;
    let node = RosNode::builder(&session, "td_node")
        .namespace("/demo")
        .wait()?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let _entities = declare_all(&node, &mut out)?;
    writeln!(out, "ready")?;
    out.flush()?;
    drop(out);
    // Serve until the driver closes stdin.
    for _ in std::io::stdin().lock().lines() {}
    Ok(())
}
