//! Interop of services with an independent implementation of rmw_zenoh_cpp's
//! conventions (`tests/ros2/services.py`: Python eclipse-zenoh, rclpy's
//! serialization, rosidl's hashes). `test_msgs/srv/BasicTypes` both ways:
//!
//! - `interop_service client <connect endpoint> <calls>`: call the Python
//!   server's `/py_echo` `calls` times with the requests [`request`] makes; every
//!   response must be the request with `int64_value + 1`. Prints `ok <calls>`.
//! - `interop_service server <listen endpoint>`: serve `/rust_echo` the same way
//!   until stdin closes, then print `served <n> malformed <m>`.

use std::io::{BufRead, Write};
use std::time::Duration;

use shm_cdr::msgs::test_msgs::srv::{BasicTypes, BasicTypes_Request, BasicTypes_Response};
use shm_cdr_examples::peer_session;
use shm_runtime::RosNode;
use zenoh::Wait;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// Call `i`'s request (the Python side builds the same).
fn request(i: i64) -> BasicTypes_Request {
    BasicTypes_Request {
        bool_value: i % 2 == 1,
        float64_value: i as f64 * 0.5,
        uint8_value: (i % 256) as u8,
        int16_value: -(i as i16),
        uint32_value: i as u32 * 7,
        int64_value: i * 1000 - 7,
        string_value: format!("call {i} ハロー"),
        ..Default::default()
    }
}

/// The echo both servers give: the request, `int64_value + 1`.
fn echo(request: BasicTypes_Request) -> BasicTypes_Response {
    BasicTypes_Response {
        bool_value: request.bool_value,
        byte_value: request.byte_value,
        char_value: request.char_value,
        float32_value: request.float32_value,
        float64_value: request.float64_value,
        int8_value: request.int8_value,
        uint8_value: request.uint8_value,
        int16_value: request.int16_value,
        uint16_value: request.uint16_value,
        int32_value: request.int32_value,
        uint32_value: request.uint32_value,
        int64_value: request.int64_value + 1,
        uint64_value: request.uint64_value,
        string_value: request.string_value,
    }
}

fn main() -> Result<(), BoxError> {
    let args: Vec<String> = std::env::args().collect();
    match args
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>()
        .as_slice()
    {
        [_, "client", endpoint, calls] => client(endpoint, calls.parse()?),
        [_, "server", endpoint] => server(endpoint),
        _ => Err(
            "usage: interop_service client <connect endpoint> <calls> | server <listen endpoint>"
                .into(),
        ),
    }
}

fn client(endpoint: &str, calls: i64) -> Result<(), BoxError> {
    let session = peer_session(endpoint, false)?;
    let node = RosNode::builder(&session, "rust_client")
        .domain_id(0)
        .wait()?;
    let client = node.declare_client::<BasicTypes>("/py_echo").wait()?;
    if !client.wait_for_service(Duration::from_secs(20)) {
        return Err("the Python server never appeared".into());
    }
    for i in 0..calls {
        let response = client.call(&request(i)).wait()?;
        if response != echo(request(i)) {
            return Err(format!("call {i}: got {response:?}").into());
        }
    }
    println!("ok {calls}");
    Ok(())
}

fn server(endpoint: &str) -> Result<(), BoxError> {
    let session = peer_session(endpoint, true)?;
    let node = RosNode::builder(&session, "rust_server")
        .domain_id(0)
        .wait()?;
    let served = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let counter = served.clone();
    let server = node
        .declare_service::<BasicTypes>("/rust_echo")
        .handler(move |request| {
            counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            echo(request)
        })
        .wait()?;
    println!("ready");
    std::io::stdout().flush()?;
    for line in std::io::stdin().lock().lines() {
        line?;
    }
    println!(
        "served {} malformed {}",
        served.load(std::sync::atomic::Ordering::Relaxed),
        server.malformed()
    );
    Ok(())
}
