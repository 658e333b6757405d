//! A service (`std_srvs/srv/Trigger`, and `rcl_interfaces/srv/SetParameters`
//! with a 1 MiB byte array that travels in shared memory and is read in place)
//! and a latched (transient-local) topic that a late subscriber still receives,
//! between two rmw_zenoh_cpp-compatible nodes.
//!
//! `cargo run -p shm-cdr-examples --example services_and_latched`

use std::time::{Duration, Instant};

use shm_cdr::msgs::rcl_interfaces::msg::{Parameter, ParameterValue, SetParametersResult};
use shm_cdr::msgs::rcl_interfaces::srv::{
    SetParameters, SetParameters_Request, SetParameters_RequestRef, SetParameters_Response,
};
use shm_cdr::msgs::std_msgs;
use shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Request, Trigger_Response};
use shm_cdr_examples::loopback_pair;
use shm_runtime::rmw::Qos;
use shm_runtime::{RosNode, ShmConfig, ShmContext};
use zenoh::Wait;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    // Warnings (a pool that fell back to the heap, a message missed) reach
    // stderr only through a logger: `RUST_LOG=info` shows more.
    shm_runtime::init_logging();
    let (a, b) = loopback_pair(7451)?;
    let shm = ShmContext::new(ShmConfig::enabled())?;
    let server = RosNode::builder(&a, "server").shm(&shm).wait()?;
    let client = RosNode::builder(&b, "client").shm(&shm).wait()?;

    // A service answered on Zenoh's thread by a plain function.
    let _trigger = server
        .declare_service::<Trigger>("/trigger")
        .handler(|_request| Trigger_Response {
            success: true,
            message: "triggered".into(),
        })
        .wait()?;
    let trigger = client.declare_client::<Trigger>("/trigger").wait()?;
    trigger.wait_for_service(Duration::from_secs(5));
    let started = Instant::now();
    let response = trigger.call(&Trigger_Request).wait()?;
    println!(
        "service  {}  -> {response:?} in {:?}",
        trigger.key_expr(),
        started.elapsed()
    );

    // A large request: in shared memory, read in place by the server (a response
    // at or above the threshold would go back the same way).
    let _parameters = server
        .declare_service::<SetParameters>("~/upload_blob")
        .callback(|request| {
            let shm = request.is_shm();
            let view: SetParameters_RequestRef = match request.decode() {
                Ok(view) => view,
                Err(_) => return, // the client already got an error reply
            };
            let bytes = view
                .parameters
                .first()
                .map_or(0, |p| p.value.byte_array_value.len());
            let response = SetParameters_Response {
                results: vec![SetParametersResult {
                    successful: true,
                    reason: format!("{bytes} bytes read in place (shm = {shm})"),
                }],
            };
            if let Err(e) = request.reply(&response).wait() {
                eprintln!("reply failed: {e}");
            }
        })
        .wait()?;
    let parameters = client
        .declare_client::<SetParameters>("/server/upload_blob")
        .wait()?;
    parameters.wait_for_service(Duration::from_secs(5));
    let request = SetParameters_Request {
        parameters: vec![Parameter {
            name: "blob".into(),
            value: ParameterValue {
                r#type: 5, // PARAMETER_BYTE_ARRAY
                byte_array_value: vec![7; 1 << 20],
                ..Default::default()
            },
        }],
    };
    let started = Instant::now();
    let reply = parameters.call_reply(&request).wait()?;
    let response = reply.response()?;
    println!(
        "service  {}  -> {:?} (response shm = {}) in {:?}",
        parameters.key_expr(),
        response.results[0].reason,
        reply.is_shm(),
        started.elapsed()
    );

    // A latched topic: published before anyone listens, depth 3.
    let latched = server
        .declare_publisher_with_qos::<std_msgs::String>(
            "/robot_description",
            Qos::transient_local(3),
        )
        .wait()?;
    for i in 1..=5 {
        latched
            .publish(&std_msgs::String {
                data: format!("version {i}"),
            })
            .wait()?;
    }
    let late = client
        .declare_subscriber_with_qos::<std_msgs::String>(
            "/robot_description",
            Qos::transient_local(3),
        )
        .wait()?;
    while let Some(sample) = late.recv_timeout(Duration::from_secs(1))? {
        let msg: std_msgs::String = sample.decode()?;
        let seq = sample
            .attachment()
            .and_then(Result::ok)
            .map(|a| a.sequence_number);
        println!(
            "latched  late subscriber got {:?} (sequence number {seq:?})",
            msg.data
        );
    }
    println!(
        "token    {}",
        latched.liveliness_token().unwrap_or_default()
    );
    println!("pool     {:?}", shm.stats());
    Ok(())
}
