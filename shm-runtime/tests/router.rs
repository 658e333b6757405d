//! ROS 2's default topology, as rmw_zenoh_cpp deploys it: every node a Zenoh
//! *client* of a router (`rmw_zenohd`) on TCP. Three processes: a Zenoh router,
//! a server process (a service, an action, a latched topic, a large-message
//! publisher), and this test as the client. Everything goes through the router:
//! the graph, the latched history, services, actions, and shared memory, which
//! two processes on one host must still use with the router in the middle.
//!
//! The child processes are this test binary run again with a role in
//! `SHM_RUNTIME_ROUTER_ROLE` (the `role` test does nothing without it).

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use shm_cdr::msgs::rcl_interfaces::msg::{Parameter, ParameterValue, SetParametersResult};
use shm_cdr::msgs::rcl_interfaces::srv::{
    SetParameters, SetParameters_Request, SetParameters_RequestRef, SetParameters_Response,
};
use shm_cdr::msgs::sensor_msgs::Image;
use shm_cdr::msgs::std_msgs;
use shm_cdr::msgs::test_msgs::action::{
    Fibonacci, Fibonacci_Feedback, Fibonacci_Goal, Fibonacci_Result,
};
use shm_runtime::action::GoalStatus;
use shm_runtime::rmw::Qos;
use shm_runtime::{RosNode, ShmConfig, ShmContext};
use zenoh::{Config, Wait};

mod common;

const ROLE: &str = "SHM_RUNTIME_ROUTER_ROLE";
const ENDPOINT: &str = "SHM_RUNTIME_ROUTER_ENDPOINT";
const TIMEOUT: Duration = Duration::from_secs(10);
const BLOB: usize = 1 << 20;

fn router_config(endpoint: &str) -> Config {
    let mut c = Config::default();
    c.insert_json5("mode", "\"router\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    c.insert_json5("listen/endpoints", &format!("[\"{endpoint}\"]"))
        .unwrap();
    c
}

/// A client of the router, as rmw_zenoh_cpp's nodes are by default.
fn client_config(endpoint: &str) -> Config {
    let mut c = Config::default();
    c.insert_json5("mode", "\"client\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    c.insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))
        .unwrap();
    common::without_implicit_shm_copy(c)
}

/// Runs a child's role; does nothing when run as a plain test.
#[test]
fn role() {
    let (Ok(role), Ok(endpoint)) = (std::env::var(ROLE), std::env::var(ENDPOINT)) else {
        return;
    };
    match role.as_str() {
        "router" => {
            let _router = common::open(router_config(&endpoint)).wait().unwrap();
            println!("ready");
            wait_for_stdin_lines(|_| {});
        }
        "server" => serve(&endpoint),
        other => panic!("unknown role {other}"),
    }
}

fn wait_for_stdin_lines(mut on_line: impl FnMut(&str)) {
    for line in std::io::stdin().lock().lines() {
        on_line(&line.unwrap());
    }
}

/// The server process: one node with a service, an action, a latched topic
/// (5 messages published before anyone listens, depth 3) and a publisher of
/// 1 MiB images that sends one per `blob` line on stdin.
fn serve(endpoint: &str) {
    let session = common::open(client_config(endpoint)).wait().unwrap();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(64 * 1024)).unwrap();
    let node = RosNode::builder(&session, "router_server")
        .namespace("/behind_router")
        .domain_id(0)
        .shm(&shm)
        .wait()
        .unwrap();
    let _service = node
        .declare_service::<SetParameters>("parameters")
        .callback(|request| {
            // Borrowed in place; the reason says where the request lay.
            let view: SetParameters_RequestRef = request.decode().unwrap();
            let ok = view.parameters[0]
                .value
                .byte_array_value
                .iter()
                .enumerate()
                .all(|(i, &b)| b == (i % 251) as u8);
            let reason = format!(
                "shm={} ok={ok} {}",
                request.is_shm(),
                "x".repeat(200 * 1024)
            );
            let response = SetParameters_Response {
                results: vec![SetParametersResult {
                    successful: ok,
                    reason,
                }],
            };
            request.reply(&response).wait().unwrap();
        })
        .wait()
        .unwrap();
    let actions = node
        .declare_action_server::<Fibonacci>("fibonacci")
        .wait()
        .unwrap();
    std::thread::spawn(move || {
        while let Ok(accepted) = actions.recv() {
            let goal = accepted.execute();
            let mut sequence = vec![0, 1];
            for i in 1..goal.goal().order as usize {
                sequence.push(sequence[i] + sequence[i - 1]);
                goal.publish_feedback(Fibonacci_Feedback {
                    sequence: sequence.clone(),
                })
                .unwrap();
            }
            goal.succeed(Fibonacci_Result { sequence }).unwrap();
        }
    });
    let latched = node
        .declare_publisher_with_qos::<std_msgs::String>("latched", Qos::transient_local(3))
        .wait()
        .unwrap();
    for i in 1..=5 {
        latched
            .publish(&std_msgs::String {
                data: format!("m{i}"),
            })
            .wait()
            .unwrap();
    }
    let images = node.declare_publisher::<Image>("images").wait().unwrap();
    println!("ready");
    std::io::stdout().flush().unwrap();
    wait_for_stdin_lines(|line| match line {
        "blob" => {
            let image = Image {
                encoding: "mono8".into(),
                height: 1024,
                width: 1024,
                step: 1024,
                data: (0..BLOB).map(|i| (i % 253) as u8).collect(),
                ..Default::default()
            };
            let outcome = images.publish(&image).wait().unwrap();
            println!("published {:?}", outcome.kind);
        }
        "live" => {
            latched
                .publish(&std_msgs::String { data: "m6".into() })
                .wait()
                .unwrap();
        }
        _ => {}
    });
}

/// A child process running `role`, killed when dropped.
struct ChildRole {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: mpsc::Receiver<String>,
}

impl ChildRole {
    fn spawn(role: &str, endpoint: &str) -> Self {
        let mut child = Command::new(std::env::current_exe().unwrap())
            .args(["role", "--exact", "--nocapture", "--test-threads=1"])
            .env(ROLE, role)
            .env(ENDPOINT, endpoint)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take();
        let stdout = BufReader::new(child.stdout.take().unwrap());
        let (sender, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in stdout.lines() {
                let Ok(line) = line else { break };
                if sender.send(line).is_err() {
                    break;
                }
            }
        });
        let role = Self {
            child,
            stdin,
            lines,
        };
        role.expect_line("ready");
        role
    }

    fn expect_line(&self, wanted: &str) -> String {
        loop {
            let line = self
                .lines
                .recv_timeout(Duration::from_secs(60))
                .unwrap_or_else(|_| panic!("no {wanted:?} from the child"));
            // libtest prints `test role ... ` before the child's first line.
            if let Some(at) = line.find(wanted) {
                return line[at..].to_owned();
            }
        }
    }

    fn send(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().unwrap();
        writeln!(stdin, "{line}").unwrap();
        stdin.flush().unwrap();
    }
}

impl Drop for ChildRole {
    fn drop(&mut self) {
        drop(self.stdin.take());
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn services_actions_latched_topics_graph_and_shared_memory_through_a_router() {
    let _shm = common::shm_serial();
    let endpoint = format!("tcp/127.0.0.1:{}", common::free_port());
    let _router = ChildRole::spawn("router", &endpoint);
    let mut server = ChildRole::spawn("server", &endpoint);

    let session = common::open(client_config(&endpoint)).wait().unwrap();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(64 * 1024)).unwrap();
    let node = RosNode::builder(&session, "router_client")
        .domain_id(0)
        .shm(&shm)
        .wait()
        .unwrap();

    // The graph, from the tokens the router forwards.
    let graph = node.graph(Duration::from_secs(2)).unwrap();
    assert!(
        graph
            .nodes()
            .contains(&"/behind_router/router_server".to_owned()),
        "{:?}",
        graph.nodes()
    );
    assert!(graph.actions().contains_key("/behind_router/fibonacci"));
    assert!(graph.services().contains_key("/behind_router/parameters"));
    assert_eq!(graph.publishers("/behind_router/latched").len(), 1);

    // The latched topic: exactly the last 3 of 5, then live ones.
    let latched = node
        .declare_subscriber_with_qos::<std_msgs::String>(
            "/behind_router/latched",
            Qos::transient_local(3),
        )
        .wait()
        .unwrap();
    let mut history = Vec::new();
    while let Some(sample) = latched.recv_timeout(Duration::from_secs(2)).unwrap() {
        history.push(sample.decode::<std_msgs::String>().unwrap().data);
    }
    assert_eq!(history, ["m3", "m4", "m5"]);
    server.send("live");
    let live = latched
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("live message");
    assert_eq!(live.decode::<std_msgs::String>().unwrap().data, "m6");

    // A 1 MiB request and a 200 KiB response, both in shared memory.
    let client = node
        .declare_client::<SetParameters>("/behind_router/parameters")
        .wait()
        .unwrap();
    assert!(client.wait_for_service(TIMEOUT));
    let request = SetParameters_Request {
        parameters: vec![Parameter {
            name: "blob".into(),
            value: ParameterValue {
                r#type: 5,
                byte_array_value: (0..BLOB).map(|i| (i % 251) as u8).collect(),
                ..Default::default()
            },
        }],
    };
    let reply = client.call_reply(&request).wait().unwrap();
    let response: SetParameters_Response = reply.response().unwrap();
    assert!(
        response.results[0].reason.starts_with("shm=true ok=true"),
        "the request should cross the router in shared memory: {}",
        &response.results[0].reason[..20]
    );
    assert!(
        reply.is_shm(),
        "the response should cross the router in shared memory"
    );

    // An action: feedback, then the result.
    let actions = node
        .declare_action_client::<Fibonacci>("/behind_router/fibonacci")
        .wait()
        .unwrap();
    assert!(actions.wait_for_server(TIMEOUT));
    let goal = actions
        .send_goal(Fibonacci_Goal { order: 10 })
        .wait()
        .unwrap();
    let mut feedback = 0;
    while goal.recv_feedback().is_some() {
        feedback += 1;
    }
    assert_eq!(feedback, 9);
    let result = goal.result().wait().unwrap();
    assert_eq!(result.status, GoalStatus::Succeeded);
    assert_eq!(result.result.sequence.len(), 11);

    // A published 1 MiB image arrives as shared memory, every byte right.
    let images = node
        .declare_subscriber::<Image>("/behind_router/images")
        .wait()
        .unwrap();
    std::thread::sleep(Duration::from_millis(300)); // the router learns of the subscriber
    server.send("blob");
    assert_eq!(server.expect_line("published"), "published Shm");
    let sample = images.recv_timeout(TIMEOUT).unwrap().expect("the image");
    assert!(
        sample.is_shm(),
        "the image should cross the router in shared memory"
    );
    let image: Image = sample.decode().unwrap();
    assert_eq!(image.data.len(), BLOB);
    assert!(image
        .data
        .iter()
        .enumerate()
        .all(|(i, &b)| b == (i % 253) as u8));
}
