//! A node on simulated time: a simulator publishes `/clock` ten times faster
//! than real time, and a controller node with `use_sim_time` runs a timer of
//! one simulated second, which therefore fires every tenth of a real second,
//! and pauses when the simulation pauses.
//!
//! ```text
//! cargo run -p shm-cdr-examples --example sim_time_node
//! ```
//!
//! Both nodes run in this process on their own sessions, as they would in
//! two; the controller's clock reads only what `/clock` says.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::rosgraph_msgs::Clock;
use shm_cdr_examples::loopback_pair;
use shm_runtime::rmw::Qos;
use shm_runtime::RosNode;
use zenoh::Wait;

/// Simulated milliseconds per real millisecond: ten times real time.
const SPEEDUP: i64 = 10;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let (simulator_session, controller_session) = loopback_pair(7461)?;
    let simulator = RosNode::builder(&simulator_session, "simulator").wait()?;
    let clock = simulator
        .declare_publisher_with_qos::<Clock>("/clock", Qos::sensor_data())
        .wait()?;
    let controller = RosNode::builder(&controller_session, "controller")
        .use_sim_time(true)
        .wait()?;

    let ticks = Arc::new(AtomicU64::new(0));
    let counted = ticks.clone();
    let controller_clock = controller.clock().clone();
    let _control = controller.create_timer(Duration::from_secs(1), move || {
        let n = counted.fetch_add(1, Ordering::Relaxed) + 1;
        let now = controller_clock.now().to_msg();
        println!(
            "control step {n} at simulated t = {}.{:03} s",
            now.sec,
            now.nanosec / 1_000_000
        );
    })?;

    clock.wait_for_subscribers(Duration::from_secs(5));
    let started = Instant::now();
    let mut simulated_ms: i64 = 0;
    // 3 simulated seconds, a pause of half a real second, 2 simulated seconds more.
    for (phase, real) in [("running", 300), ("paused", 500), ("running", 200)] {
        let (phase_start, base) = (Instant::now(), simulated_ms);
        while phase_start.elapsed() < Duration::from_millis(real) {
            if phase == "running" {
                simulated_ms = base + phase_start.elapsed().as_millis() as i64 * SPEEDUP;
            }
            let stamp = Time {
                sec: (simulated_ms / 1000) as i32,
                nanosec: ((simulated_ms % 1000) * 1_000_000) as u32,
            };
            clock.publish(&Clock { clock: stamp }).wait()?;
            std::thread::sleep(Duration::from_millis(1));
        }
        println!(
            "{phase} until simulated t = {:.3} s",
            simulated_ms as f64 / 1000.0
        );
    }
    // Let the last clock message reach the controller.
    std::thread::sleep(Duration::from_millis(100));
    println!(
        "{} control steps in {:.1} s of real time for {:.1} s of simulated time",
        ticks.load(Ordering::Relaxed),
        started.elapsed().as_secs_f64(),
        simulated_ms as f64 / 1000.0
    );
    Ok(())
}
