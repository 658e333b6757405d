//! Your own interface package, generated at build time with no ROS tooling:
//! `examples/build.rs` runs shm-codegen on `examples/interfaces/robot_interfaces`
//! (`msg/Battery.msg`, `msg/CellHistory.msg`, `srv/SetSpeed.srv`,
//! `action/Dock.action`).
//!
//! ```sh
//! cargo run -p shm-cdr-examples --example generated_interfaces
//! ```

use shm_cdr::{RosAction, RosMessage, RosService};
use shm_cdr_examples::generated::robot_interfaces::{action, msg, srv};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Defaults and constants come from the .msg file.
    let mut battery = msg::Battery::default();
    println!(
        "Battery::default(): status {} label {:?} grade {:?} (STATUS_CHARGING = {})",
        battery.status,
        battery.label.as_str(),
        battery.grade as char,
        msg::Battery::STATUS_CHARGING
    );
    battery.header.frame_id = "base_link".into();
    battery.location = "rear bay".into();
    battery.voltage = 24.6;
    battery.cells = vec![4.1, 4.1, 4.09].into();
    battery.history.push(msg::CellHistory::default());

    let bytes = shm_cdr::to_vec(&battery)?;
    println!("{} {}", msg::Battery::TYPE_NAME, msg::Battery::type_hash());
    println!(
        "encoded   {} bytes (encoded_size says {})",
        bytes.len(),
        shm_cdr::encoded_size(&battery)
    );
    // The borrowing form reads the same bytes without copying the strings, also
    // those of nested standard types (`std_msgs/Header`'s `frame_id`).
    let view: msg::BatteryRef = shm_cdr::from_bytes(&bytes)?;
    let inside = |s: &str| bytes.as_ptr_range().contains(&s.as_ptr());
    println!(
        "borrowed  location {:?} and header.frame_id {:?} point into the buffer: {}",
        view.location,
        view.header.frame_id,
        inside(&view.location) && inside(&view.header.frame_id)
    );

    // A service: request, response and event types, and the service's own hash.
    let request = srv::SetSpeed_Request {
        meters_per_second: 0.5,
        ..Default::default()
    };
    println!(
        "{} {} (request ramp defaults to {})",
        srv::SetSpeed::TYPE_NAME,
        srv::SetSpeed::type_hash(),
        request.ramp
    );

    // An action: goal/result/feedback and the SendGoal/GetResult/FeedbackMessage types.
    let goal = action::Dock_Goal {
        station: "dock-3".into(),
    };
    let send = action::Dock_SendGoal_Request {
        goal_id: Default::default(),
        goal,
    };
    println!("{} {}", action::Dock::TYPE_NAME, action::Dock::type_hash());
    println!(
        "SendGoal request {} bytes; service {}",
        shm_cdr::encoded_size(&send),
        <action::Dock_SendGoal as RosService>::DDS_TYPE_NAME
    );
    Ok(())
}
