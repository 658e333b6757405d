//! A node speaking one distribution's conventions, for `tests/ros2/distros.py`,
//! which checks its tokens, keys, QoS text and attachments against a model of
//! that distribution's rmw_zenoh_cpp release and talks to it.
//!
//! `distro_node <listen endpoint> <distro>`: node `/demo/distro_node` with a
//! publisher on `/chatter` (`std_msgs/String`, transient local, keep last 7,
//! a message every 50 ms), a publisher of 4×2 `mono8` `sensor_msgs/Image`s
//! on `/camera` (every 50 ms, each pixel the message's number), a subscriber
//! on `/echo` (sensor-data QoS), a
//! `std_srvs/Trigger` server on `/trigger` answering with the distribution's
//! name, a `test_msgs/Fibonacci` action server on `/fibonacci` (accepts
//! every goal, answers `[0, 1, …]` of the goal's order without feedback), and
//! a lifecycle (its services and `~/transition_event`). Each
//! message received on `/echo` is printed as `echo <text>`. Prints `ready`,
//! serves until stdin closes.

use std::io::BufRead;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use shm_cdr::msgs::sensor_msgs::msg::Image;
use shm_cdr::msgs::std_msgs::String as Text;
use shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Request, Trigger_Response};
use shm_cdr::msgs::test_msgs::action::{Fibonacci, Fibonacci_Result};
use shm_cdr_examples::peer_session;
use shm_runtime::lifecycle::Managed;
use shm_runtime::rmw::{Distro, Qos};
use shm_runtime::RosNode;
use zenoh::Wait;

struct Plain;

impl Managed for Plain {}

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let mut args = std::env::args().skip(1);
    let (Some(endpoint), Some(distro)) = (args.next(), args.next()) else {
        return Err("usage: distro_node <listen endpoint> <distro>".into());
    };
    let distro: Distro = distro.parse()?;
    let session = peer_session(&endpoint, true)?;
    let node = RosNode::builder(&session, "distro_node")
        .namespace("/demo")
        .domain_id(0)
        .distro(distro)
        .wait()?;
    let publisher = node
        .declare_publisher_with_qos::<Text>("/chatter", Qos::transient_local(7))
        .wait()?;
    let camera = node.declare_publisher::<Image>("/camera").wait()?;
    let _echo = node
        .declare_subscriber_with_qos::<Text>("/echo", Qos::sensor_data())
        .callback(|sample| match sample.decode::<Text>() {
            Ok(text) => println!("echo {}", text.data),
            Err(e) => println!("echo undecodable: {e}"),
        })
        .wait()?;
    let _trigger = node
        .declare_service::<Trigger>("/trigger")
        .handler(move |_: Trigger_Request| Trigger_Response {
            success: true,
            message: distro.name().to_owned(),
        })
        .wait()?;
    let fibonacci = node
        .declare_action_server::<Fibonacci>("/fibonacci")
        .wait()?;
    std::thread::spawn(move || {
        while let Ok(accepted) = fibonacci.recv() {
            let goal = accepted.execute();
            let mut sequence = vec![0, 1];
            while sequence.len() <= goal.goal().order.max(1) as usize {
                let next = sequence[sequence.len() - 1] + sequence[sequence.len() - 2];
                sequence.push(next);
            }
            let _ = goal.succeed(Fibonacci_Result { sequence });
        }
    });
    let _lifecycle = node.lifecycle(Plain)?;
    let running = Arc::new(AtomicBool::new(true));
    let talk = {
        let running = running.clone();
        std::thread::spawn(move || {
            let mut n = 0u32;
            while running.load(Ordering::Relaxed) {
                n += 1;
                let message = Text {
                    data: format!("{distro} {n}"),
                };
                if let Err(e) = publisher.publish(&message).wait() {
                    eprintln!("distro_node: {e}");
                }
                let image = Image {
                    height: 2,
                    width: 4,
                    encoding: "mono8".into(),
                    step: 4,
                    data: vec![n as u8; 8],
                    ..Default::default()
                };
                if let Err(e) = camera.publish(&image).wait() {
                    eprintln!("distro_node: {e}");
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
    talk.join().map_err(|_| "the publishing thread panicked")?;
    Ok(())
}
