//! `shm-ros2` end to end: nodes of this project on a local Zenoh endpoint, the
//! command run against them as a user runs it, its output compared with what
//! ros2cli prints for the same graph.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use shm_cdr::msgs::std_msgs::String as RosString;
use shm_cdr::RosMessage;
use shm_runtime::parameters::ParameterValue;
use shm_runtime::{testing, RosNode};
use zenoh::{Session, Wait};

/// A message type the binary was not built with: its type is read from the
/// publishing node's `~/get_type_description`.
#[derive(Debug, Clone, Default, PartialEq, RosMessage)]
#[ros(type_name = "robot_msgs/msg/Battery")]
struct Battery {
    voltage: f32,
    cells: Vec<u16>,
    label: String,
}

const TIMEOUT: Duration = Duration::from_secs(15);

/// A session listening on a local port, as a router would for the command.
fn listening_session() -> (Session, u16) {
    let port = testing::free_port().unwrap();
    let config = testing::peer_config(port, true).unwrap();
    (zenoh::open(config).wait().unwrap(), port)
}

fn cli(port: u16, args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_shm-ros2"));
    command
        .args([
            "--connect",
            &format!("tcp/127.0.0.1:{port}"),
            "--domain-id",
            "0",
            "--timeout",
            "5",
        ])
        .args(args)
        .env_remove("ZENOH_SESSION_CONFIG_URI")
        .env_remove("ROS_DISTRO")
        .env("RUST_LOG", "error");
    command
}

fn run(port: u16, args: &[&str]) -> Output {
    cli(port, args).output().unwrap()
}

fn stdout(output: &Output) -> String {
    assert!(
        output.status.success(),
        "failed: {}\n{}",
        String::from_utf8_lossy(&output.stderr),
        String::from_utf8_lossy(&output.stdout)
    );
    String::from_utf8(output.stdout.clone()).unwrap()
}

/// A running command whose output lines arrive on a channel.
struct Running {
    child: Child,
    lines: mpsc::Receiver<String>,
}

impl Running {
    fn start(port: u16, args: &[&str]) -> Self {
        let mut child = cli(port, args).stdout(Stdio::piped()).spawn().unwrap();
        let out = child.stdout.take().unwrap();
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Self { child, lines }
    }

    fn line(&self) -> String {
        self.lines.recv_timeout(TIMEOUT).expect("a line of output")
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Publish `message` every 50 ms from a thread until the returned flag drops.
fn keep_publishing<T: RosMessage + Send + Sync + 'static>(
    node: &RosNode,
    topic: &str,
    message: T,
) -> std::sync::Arc<()> {
    let publisher = node.declare_publisher::<T>(topic).wait().unwrap();
    let alive = std::sync::Arc::new(());
    let weak = std::sync::Arc::downgrade(&alive);
    std::thread::spawn(move || {
        while weak.upgrade().is_some() {
            publisher.publish(&message).wait().unwrap();
            std::thread::sleep(Duration::from_millis(50));
        }
    });
    alive
}

#[test]
fn lists_and_infos_read_as_ros2cli_prints_them() {
    let (session, port) = listening_session();
    let talker = RosNode::builder(&session, "talker")
        .domain_id(0)
        .wait()
        .unwrap();
    let _chatter = talker
        .declare_publisher::<RosString>("/chatter")
        .wait()
        .unwrap();
    let _hidden = talker
        .declare_publisher::<RosString>("/_internal")
        .wait()
        .unwrap();

    let list = stdout(&run(port, &["topic", "list", "-t"]));
    assert!(
        list.lines().any(|l| l == "/chatter [std_msgs/msg/String]"),
        "{list}"
    );
    assert!(
        list.lines()
            .any(|l| l == "/parameter_events [rcl_interfaces/msg/ParameterEvent]"),
        "{list}"
    );
    assert!(
        !list.contains("/_internal"),
        "hidden topics are left out: {list}"
    );
    let hidden = stdout(&run(port, &["topic", "list", "--include-hidden-topics"]));
    assert!(hidden.lines().any(|l| l == "/_internal"), "{hidden}");

    assert_eq!(
        stdout(&run(port, &["topic", "info", "/chatter"])),
        "Type: std_msgs/msg/String\nPublisher count: 1\nSubscription count: 0\n"
    );
    assert_eq!(
        stdout(&run(port, &["topic", "type", "/chatter"])),
        "std_msgs/msg/String\n"
    );
    assert_eq!(stdout(&run(port, &["node", "list"])), "/talker\n");

    let info = stdout(&run(port, &["node", "info", "/talker"]));
    let expected_start = "/talker\n  Subscribers:\n\n  Publishers:\n    /chatter: std_msgs/msg/String\n    /parameter_events: rcl_interfaces/msg/ParameterEvent\n";
    assert!(info.starts_with(expected_start), "{info}");
    assert!(
        info.contains("  Service Servers:\n    /talker/describe_parameters: rcl_interfaces/srv/DescribeParameters\n"),
        "{info}"
    );
    assert!(
        info.ends_with("  Action Servers:\n\n  Action Clients:\n\n"),
        "{info}"
    );

    let services = stdout(&run(port, &["service", "list", "-t"]));
    assert!(
        services
            .lines()
            .any(|l| l == "/talker/get_parameters [rcl_interfaces/srv/GetParameters]"),
        "{services}"
    );
    assert_eq!(
        stdout(&run(port, &["service", "type", "/talker/set_parameters"])),
        "rcl_interfaces/srv/SetParameters\n"
    );

    // An action server: its services are hidden, the action is listed.
    let _fibonacci = talker
        .declare_action_server::<shm_cdr::msgs::test_msgs::action::Fibonacci>("/fibonacci")
        .wait()
        .unwrap();
    assert_eq!(
        stdout(&run(port, &["action", "list", "-t"])),
        "/fibonacci [test_msgs/action/Fibonacci]\n"
    );
    assert_eq!(
        stdout(&run(port, &["action", "info", "/fibonacci", "-t"])),
        "Action: /fibonacci\nAction clients: 0\nAction servers: 1\n    /talker [test_msgs/action/Fibonacci]\n"
    );
    let services = stdout(&run(port, &["service", "list"]));
    assert!(!services.contains("_action"), "{services}");

    // A node that is not there: the message ros2cli gives, and a failure.
    let missing = run(port, &["node", "info", "/nobody"]);
    assert!(!missing.status.success());
    assert_eq!(
        String::from_utf8_lossy(&missing.stderr).trim(),
        "Unable to find node '/nobody'"
    );
}

#[test]
fn echo_reads_standard_types_and_types_it_was_never_built_with() {
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "driver")
        .domain_id(0)
        .wait()
        .unwrap();
    let _chatter = keep_publishing(
        &node,
        "/chatter",
        RosString {
            data: "hello: world".into(),
        },
    );
    let _battery = keep_publishing(
        &node,
        "/battery",
        Battery {
            voltage: 12.5,
            cells: vec![3300, 3310, 3290],
            label: "main".into(),
        },
    );

    let out = stdout(&run(port, &["topic", "echo", "/chatter", "--once"]));
    assert_eq!(out, "data: 'hello: world'\n---\n");

    // Not a standard type: asked of /driver's ~/get_type_description.
    let out = stdout(&run(port, &["topic", "echo", "/battery", "--once"]));
    assert_eq!(
        out,
        "voltage: 12.5\ncells:\n- 3300\n- 3310\n- 3290\nlabel: main\n---\n"
    );
    let out = stdout(&run(
        port,
        &[
            "topic",
            "echo",
            "/battery",
            "--once",
            "--flow-style",
            "-l",
            "2",
        ],
    ));
    assert_eq!(
        out,
        "voltage: 12.5\ncells: [3300, 3310, '...']\nlabel: ma...\n---\n"
    );
    let out = stdout(&run(
        port,
        &["topic", "echo", "/battery", "--once", "--json"],
    ));
    assert_eq!(
        out,
        "{\"voltage\":12.5,\"cells\":[3300,3310,3290],\"label\":\"main\"}\n"
    );

    // One field, as ros2topic prints it: Python's `str` of rclpy's value.
    let field = |name: &str| {
        stdout(&run(
            port,
            &["topic", "echo", "/battery", "--once", "--field", name],
        ))
    };
    assert_eq!(field("cells"), "array('H', [3300, 3310, 3290])\n---\n");
    assert_eq!(field("label"), "main\n---\n");
    assert_eq!(field("voltage"), "12.5\n---\n");
    let wrong = run(
        port,
        &["topic", "echo", "/battery", "--once", "--field", "label.x"],
    );
    assert!(!wrong.status.success());
    assert!(
        String::from_utf8_lossy(&wrong.stderr)
            .contains("Invalid field 'label.x': 'str' object has no attribute 'x'"),
        "{}",
        String::from_utf8_lossy(&wrong.stderr)
    );

    // A topic nobody publishes, without a type: what to do.
    let nothing = run(port, &["topic", "echo", "/nothing", "--once"]);
    assert!(!nothing.status.success());
    assert!(
        String::from_utf8_lossy(&nothing.stderr)
            .contains("give its type: shm-ros2 topic echo /nothing <pkg/msg/Type>"),
        "{}",
        String::from_utf8_lossy(&nothing.stderr)
    );
}

#[test]
fn humble_topics_are_read_and_written_with_humbles_conventions_and_definitions() {
    use shm_cdr::distro_msgs::humble::sensor_msgs::msg::Range;
    use shm_runtime::rmw::Distro;
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "ranger")
        .domain_id(0)
        .distro(Distro::Humble)
        .wait()
        .unwrap();
    let _range = keep_publishing(
        &node,
        "/range",
        Range {
            radiation_type: Range::INFRARED,
            range: 1.5,
            ..Default::default()
        },
    );
    // Humble's Range has no `variance`; its topics carry no type hash.
    let out = stdout(&run(
        port,
        &["--distro", "humble", "topic", "echo", "/range", "--once"],
    ));
    assert!(
        out.contains("radiation_type: 1\n") && out.contains("range: 1.5\n"),
        "{out}"
    );
    assert!(!out.contains("variance"), "{out}");
    let out = stdout(
        &cli(port, &["topic", "echo", "/range", "--once"])
            .env("ROS_DISTRO", "humble")
            .output()
            .unwrap(),
    );
    assert!(out.contains("range: 1.5\n"), "{out}");

    // Told another distribution, the tool says what to set.
    let output = run(port, &["topic", "echo", "/range", "--once"]);
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        err.contains("TypeHashNotSupported")
            && err.contains("ROS_DISTRO")
            && err.contains("humble"),
        "{err}"
    );
    let output = run(port, &["--distro", "iron", "topic", "list"]);
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        err.contains("humble, jazzy, kilted, lyrical, rolling"),
        "{err}"
    );

    // Written in Humble's definition, read by a Humble subscriber.
    let subscriber = node
        .declare_subscriber::<Range>("/set_range")
        .wait()
        .unwrap();
    let _pub = Running::start(
        port,
        &[
            "--distro",
            "humble",
            "topic",
            "pub",
            "/set_range",
            "sensor_msgs/msg/Range",
            "{range: 2.5, max_range: 4.0}",
        ],
    );
    let sample = subscriber
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("a Range from shm-ros2");
    let range: Range = sample.decode().unwrap();
    assert_eq!((range.range, range.max_range), (2.5, 4.0));
    // Exactly Humble's bytes: no `variance` after `range`.
    assert_eq!(sample.payload().len(), shm_cdr::encoded_size(&range));
}

#[test]
fn hz_and_bw_report_every_second() {
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "talker")
        .domain_id(0)
        .wait()
        .unwrap();
    let _chatter = keep_publishing(
        &node,
        "/chatter",
        RosString {
            data: "x".repeat(100),
        },
    );

    let hz = Running::start(port, &["topic", "hz", "/chatter"]);
    let first = hz.line();
    assert!(first.starts_with("average rate: "), "{first}");
    let rate: f64 = first["average rate: ".len()..].parse().unwrap();
    // Published every 50 ms plus the publish itself: a rate below 20 Hz.
    assert!(rate > 5.0 && rate <= 21.0, "{first}");
    let stats = hz.line();
    assert!(
        stats.starts_with("\tmin: ") && stats.contains(" window: "),
        "{stats}"
    );

    let bw = Running::start(port, &["topic", "bw", "/chatter"]);
    assert_eq!(bw.line(), "Subscribed to [/chatter]");
    let report = bw.line();
    assert!(
        report.contains(" from ") && report.contains(" messages"),
        "{report}"
    );
    let sizes = bw.line();
    // 4 bytes of header, 4 of length, 100 characters and the NUL; in the
    // unit of the rate (about 2 KB/s), as ros2cli writes them.
    assert!(
        sizes.contains("mean: 0.11 KB min: 0.11 KB max: 0.11 KB"),
        "{sizes}"
    );
}

#[test]
fn pub_publishes_yaml_values_with_the_topics_type() {
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "listener")
        .domain_id(0)
        .wait()
        .unwrap();
    let subscriber = node
        .declare_subscriber::<RosString>("/chatter")
        .wait()
        .unwrap();

    let out = stdout(&run(
        port,
        &[
            "topic",
            "pub",
            "--once",
            "/chatter",
            "std_msgs/String",
            "data: hi there",
        ],
    ));
    assert!(
        out.starts_with("publisher: beginning loop\npublishing #1: data: hi there"),
        "{out}"
    );
    let sample = subscriber
        .recv_timeout(TIMEOUT)
        .unwrap()
        .expect("the published message");
    let message: RosString = sample.decode().unwrap();
    assert_eq!(message.data, "hi there");

    // Values that are not the type's: said before anything is published.
    let bad = run(
        port,
        &[
            "topic",
            "pub",
            "--once",
            "/chatter",
            "std_msgs/msg/String",
            "datum: 1",
        ],
    );
    assert!(!bad.status.success());
    assert!(
        String::from_utf8_lossy(&bad.stderr)
            .contains("Failed to populate field: datum: std_msgs/msg/String has no field `datum` (its fields: data)"),
        "{}",
        String::from_utf8_lossy(&bad.stderr)
    );
}

#[test]
fn params_are_listed_read_and_set_as_ros2_param_does() {
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "controller")
        .domain_id(0)
        .wait()
        .unwrap();
    node.declare_parameter("gain", 1.5).unwrap();
    node.declare_parameter("names", vec!["a".to_owned(), "it's".to_owned()])
        .unwrap();

    assert_eq!(
        stdout(&run(port, &["param", "list", "/controller"])),
        "  gain\n  names\n  start_type_description_service\n  use_sim_time\n"
    );
    assert_eq!(
        stdout(&run(port, &["param", "list", "-t", "/controller"])),
        "  gain (type: double)\n  names (type: string array)\n  start_type_description_service (type: boolean)\n  use_sim_time (type: boolean)\n"
    );
    assert_eq!(
        stdout(&run(port, &["param", "get", "/controller", "gain"])),
        "Double value is: 1.5\n"
    );
    assert_eq!(
        stdout(&run(port, &["param", "get", "/controller", "names"])),
        "String values are: ['a', \"it's\"]\n"
    );
    assert_eq!(
        stdout(&run(port, &["param", "set", "/controller", "gain", "2.25"])),
        "Set parameter successful\n"
    );
    assert_eq!(node.parameter("gain"), Some(ParameterValue::Double(2.25)));
    assert_eq!(
        stdout(&run(
            port,
            &["param", "get", "/controller", "use_sim_time", "--hide-type"]
        )),
        "False\n"
    );
    // rclpy holds integer and double arrays as Python arrays.
    node.declare_parameter("counts", vec![1i64, 2, 3]).unwrap();
    node.declare_parameter("weights", vec![1.5, -2.0]).unwrap();
    assert_eq!(
        stdout(&run(port, &["param", "get", "/controller", "counts"])),
        "Integer values are: array('q', [1, 2, 3])\n"
    );
    assert_eq!(
        stdout(&run(port, &["param", "get", "/controller", "weights"])),
        "Double values are: array('d', [1.5, -2.0])\n"
    );
    // Refused: the node's reason on stderr, and exit 0, as ros2param.
    let refused = run(port, &["param", "set", "/controller", "gain", "fast"]);
    assert!(refused.status.success());
    assert!(
        String::from_utf8_lossy(&refused.stderr).starts_with("Setting parameter failed"),
        "{}",
        String::from_utf8_lossy(&refused.stderr)
    );
    let missing = run(port, &["param", "get", "/nobody", "gain"]);
    assert_eq!(
        String::from_utf8_lossy(&missing.stderr).trim(),
        "Node not found"
    );
}

#[test]
fn param_dump_and_service_call_print_as_ros2cli_does() {
    use shm_cdr::msgs::std_srvs::srv::{SetBool, SetBool_Response};
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "arm")
        .domain_id(0)
        .wait()
        .unwrap();
    node.declare_parameter("limits.speed", 0.5).unwrap();
    node.declare_parameter("limits.names", vec!["yes".to_owned()])
        .unwrap();
    node.declare_parameter("mode", "auto".to_owned()).unwrap();
    assert_eq!(
        stdout(&run(port, &["param", "dump", "/arm"])),
        "/arm:\n  ros__parameters:\n    limits:\n      names:\n      - 'yes'\n      speed: 0.5\n    mode: auto\n    \
         start_type_description_service: true\n    use_sim_time: false\n\n"
    );

    let _server = node
        .declare_service::<SetBool>("/arm/enable")
        .handler(|request| SetBool_Response {
            success: request.data,
            message: format!("it's {}", request.data),
        })
        .wait()
        .unwrap();
    assert_eq!(
        stdout(&run(
            port,
            &[
                "service",
                "call",
                "/arm/enable",
                "std_srvs/srv/SetBool",
                "{data: true}"
            ]
        )),
        "requester: making request: std_srvs.srv.SetBool_Request(data=True)\n\n\
         response:\nstd_srvs.srv.SetBool_Response(success=True, message=\"it's true\")\n\n"
    );
    let refused = run(
        port,
        &[
            "service",
            "call",
            "/arm/enable",
            "std_srvs/srv/SetBool",
            "{speed: 3}",
        ],
    );
    assert!(!refused.status.success());
    assert!(
        String::from_utf8_lossy(&refused.stderr).starts_with("Failed to populate field"),
        "{}",
        String::from_utf8_lossy(&refused.stderr)
    );
}

/// The tutorials' interfaces (`example_interfaces`, which `ros2 run
/// demo_nodes_cpp add_two_ints_server` serves) are known to the tool.
#[test]
fn the_tutorials_add_two_ints_is_called_as_ros2_service_call_does() {
    use shm_cdr::msgs::example_interfaces::srv::{AddTwoInts, AddTwoInts_Response};
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "add_two_ints_server")
        .domain_id(0)
        .wait()
        .unwrap();
    let _server = node
        .declare_service::<AddTwoInts>("add_two_ints")
        .handler(|request| AddTwoInts_Response {
            sum: request.a + request.b,
        })
        .wait()
        .unwrap();
    assert_eq!(
        stdout(&run(
            port,
            &[
                "service",
                "call",
                "/add_two_ints",
                "example_interfaces/srv/AddTwoInts",
                "{a: 2, b: 3}"
            ]
        )),
        "requester: making request: example_interfaces.srv.AddTwoInts_Request(a=2, b=3)\n\n\
         response:\nexample_interfaces.srv.AddTwoInts_Response(sum=5)\n\n"
    );
    let shown = stdout(&run(
        port,
        &["interface", "show", "example_interfaces/srv/AddTwoInts"],
    ));
    assert!(
        shown.contains("int64 a\nint64 b\n---\nint64 sum"),
        "{shown}"
    );
}

#[test]
fn action_send_goal_prints_feedback_and_result_as_ros2_action_does() {
    use shm_cdr::msgs::test_msgs::action::{Fibonacci, Fibonacci_Feedback, Fibonacci_Result};
    use shm_runtime::action::GoalDecision;
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "fib")
        .domain_id(0)
        .wait()
        .unwrap();
    let server = node
        .declare_action_server::<Fibonacci>("/fibonacci")
        .on_goal(|_, goal| {
            if goal.order < 10 {
                GoalDecision::Accept
            } else {
                GoalDecision::Reject
            }
        })
        .wait()
        .unwrap();
    std::thread::spawn(move || {
        while let Ok(accepted) = server.recv() {
            let goal = accepted.execute();
            let mut sequence = vec![0, 1];
            for i in 1..goal.goal().order as usize {
                sequence.push(sequence[i] + sequence[i - 1]);
                let _ = goal.publish_feedback(Fibonacci_Feedback {
                    sequence: sequence.clone(),
                });
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = goal.succeed(Fibonacci_Result { sequence });
        }
    });
    let out = stdout(&run(
        port,
        &[
            "action",
            "send_goal",
            "-f",
            "/fibonacci",
            "test_msgs/action/Fibonacci",
            "{order: 3}",
        ],
    ));
    let id = out
        .lines()
        .find_map(|l| l.strip_prefix("Goal accepted with ID: "))
        .expect("an accepted goal");
    assert_eq!(id.len(), 32, "{out}");
    let expected = format!(
        "Waiting for an action server to become available...\nSending goal:\n     order: 3\n\n\
         Goal accepted with ID: {id}\n\n\
         Feedback:\n    sequence:\n- 0\n- 1\n- 1\n\n\
         Feedback:\n    sequence:\n- 0\n- 1\n- 1\n- 2\n\n\
         Result:\n    sequence:\n- 0\n- 1\n- 1\n- 2\n\n\
         Goal finished with status: SUCCEEDED\n"
    );
    assert_eq!(out, expected);
    let rejected = stdout(&run(
        port,
        &[
            "action",
            "send_goal",
            "/fibonacci",
            "test_msgs/action/Fibonacci",
            "{order: 50}",
        ],
    ));
    assert!(rejected.ends_with("Goal was rejected.\n"), "{rejected}");
}

#[test]
fn action_send_goal_cancels_the_goal_at_ctrl_c_as_ros2_action_does() {
    use shm_cdr::msgs::test_msgs::action::{Fibonacci, Fibonacci_Result};
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "slow")
        .domain_id(0)
        .wait()
        .unwrap();
    let server = node
        .declare_action_server::<Fibonacci>("/slow")
        .wait()
        .unwrap();
    let (ended, how) = mpsc::channel();
    std::thread::spawn(move || {
        while let Ok(accepted) = server.recv() {
            let goal = accepted.execute();
            // Runs until asked to cancel.
            while !goal.is_cancel_requested() {
                std::thread::sleep(Duration::from_millis(20));
            }
            let id = goal.id();
            let _ = goal.canceled(Fibonacci_Result::default());
            let _ = ended.send(id);
        }
    });
    let running = Running::start(
        port,
        &[
            "action",
            "send_goal",
            "/slow",
            "test_msgs/action/Fibonacci",
            "{order: 3}",
        ],
    );
    let id = loop {
        if let Some(id) = running.line().strip_prefix("Goal accepted with ID: ") {
            break id.to_owned();
        }
    };
    assert_eq!(running.line(), "");
    let interrupt = Command::new("kill")
        .args(["-INT", &running.child.id().to_string()])
        .status()
        .unwrap();
    assert!(interrupt.success());
    assert_eq!(running.line(), "Canceling goal...");
    assert_eq!(running.line(), "Goal canceled.");
    // The server ended the very goal the command sent.
    let canceled = how
        .recv_timeout(TIMEOUT)
        .expect("the server saw the cancel");
    let hex: String = canceled.iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(hex, id);
}

#[test]
fn types_come_from_interface_files_when_the_node_does_not_describe_them() {
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "quiet")
        .domain_id(0)
        .type_description_service(false)
        .wait()
        .unwrap();
    let _battery = keep_publishing(
        &node,
        "/battery",
        Battery {
            voltage: 11.5,
            cells: vec![3300],
            label: "spare".into(),
        },
    );
    let dir = std::env::temp_dir().join(format!("shm_cli_interfaces_{}", std::process::id()));
    std::fs::create_dir_all(dir.join("robot_msgs/msg")).unwrap();
    std::fs::write(
        dir.join("robot_msgs/msg/Battery.msg"),
        "# A pack.\nfloat32 voltage\nuint16[] cells # mV\nstring label\n",
    )
    .unwrap();
    // The node does not answer ~/get_type_description: the error says so.
    let unknown = run(port, &["topic", "echo", "/battery", "--once"]);
    assert!(!unknown.status.success());
    assert!(
        String::from_utf8_lossy(&unknown.stderr).contains("offers no /quiet/get_type_description"),
        "{}",
        String::from_utf8_lossy(&unknown.stderr)
    );
    let dir_arg = dir.display().to_string();
    let out = stdout(&run(
        port,
        &[
            "--interfaces",
            &dir_arg,
            "topic",
            "echo",
            "/battery",
            "--once",
        ],
    ));
    assert_eq!(out, "voltage: 11.5\ncells:\n- 3300\nlabel: spare\n---\n");

    // Humble's nodes announce no hash and describe no types: the files are
    // taken by name, and without them the error says to give them.
    let humble = RosNode::builder(&session, "humble_pack")
        .domain_id(0)
        .distro(shm_runtime::rmw::Distro::Humble)
        .wait()
        .unwrap();
    let _humble_battery = keep_publishing(
        &humble,
        "/humble_battery",
        Battery {
            voltage: 12.0,
            cells: vec![3400],
            label: "old".into(),
        },
    );
    let without = run(
        port,
        &[
            "--distro",
            "humble",
            "topic",
            "echo",
            "/humble_battery",
            "--once",
        ],
    );
    let err = String::from_utf8_lossy(&without.stderr);
    assert!(
        !without.status.success() && err.contains("--interfaces"),
        "{err}"
    );
    let out = stdout(&run(
        port,
        &[
            "--distro",
            "humble",
            "--interfaces",
            &dir_arg,
            "topic",
            "echo",
            "/humble_battery",
            "--once",
        ],
    ));
    assert_eq!(out, "voltage: 12.0\ncells:\n- 3400\nlabel: old\n---\n");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn interface_show_expands_nested_types_as_ros2_interface_does() {
    let out = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
        .args(["interface", "show", "geometry_msgs/msg/PoseStamped"])
        .output()
        .unwrap();
    let text = stdout(&out);
    assert!(
        text.starts_with("# A Pose with reference coordinate frame and timestamp\n\nstd_msgs/Header header\n\tbuiltin_interfaces/Time stamp\n\t\tint32 sec\n\t\tuint32 nanosec\n\tstring frame_id\nPose pose\n\tPoint position\n\t\tfloat64 x\n"),
        "{text}"
    );
    let list = stdout(
        &Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
            .args(["interface", "list"])
            .output()
            .unwrap(),
    );
    assert!(
        list.starts_with("Messages:\n    action_msgs/msg/GoalInfo\n"),
        "{list}"
    );
    assert!(
        list.contains("Services:\n    action_msgs/srv/CancelGoal\n"),
        "{list}"
    );
    assert!(
        !list.contains("_Request"),
        "derived types are not interface files"
    );
}

/// Descriptions a hostile node serves for its topics: a chain of types nested
/// deeper than any real type, and a fan-out whose message would hold 100^4
/// fields (each type's description is small; what it would build is not).
mod hostile {
    use shm_cdr::dynamic::{DynamicType, TypeLimits};
    use shm_cdr::msgs::type_description_interfaces::msg::{
        Field, FieldType, IndividualTypeDescription, TypeDescription,
    };

    fn field(name: String, type_id: u8, nested: &str) -> Field {
        Field {
            name,
            r#type: FieldType {
                type_id,
                capacity: 0,
                string_capacity: 0,
                nested_type_name: nested.to_owned().into(),
            },
            default_value: String::new(),
        }
    }

    /// `depth` types named `pkg/msg/{stem}{i}` of `width` fields each, every
    /// field nesting the next type; the last type's fields are bytes.
    pub fn nest(stem: &str, depth: usize, width: usize) -> TypeDescription {
        let name = |i: usize| format!("hostile_msgs/msg/{stem}{i}");
        let mut types: Vec<IndividualTypeDescription> = (0..depth)
            .map(|i| IndividualTypeDescription {
                type_name: name(i).into(),
                fields: (0..width)
                    .map(|k| match i + 1 < depth {
                        true => field(format!("f{k}"), 1, &name(i + 1)),
                        false => field(format!("f{k}"), 3, ""),
                    })
                    .collect(),
            })
            .collect();
        let root = types.remove(0);
        TypeDescription {
            type_description: root,
            referenced_type_descriptions: types,
        }
    }

    /// The type as its sender builds it, within no practical limit: what it
    /// announces (its hash) and publishes (its default).
    pub fn as_sent(description: &TypeDescription) -> DynamicType {
        let mut limits = TypeLimits::default();
        limits.max_depth = usize::MAX;
        limits.max_message_fields = usize::MAX;
        DynamicType::from_type_description_msg_with(description, &limits).unwrap()
    }
}

#[test]
fn a_hostile_nodes_descriptions_are_refused_and_the_tools_keep_running() {
    use shm_cdr::msgs::type_description_interfaces::srv::{
        GetTypeDescription, GetTypeDescription_Response,
    };
    use shm_runtime::rmw::Qos;

    let (session, port) = listening_session();
    // Its own description service off: the hostile one answers instead.
    let node = RosNode::builder(&session, "hostile")
        .domain_id(0)
        .type_description_service(false)
        .wait()
        .unwrap();
    let deep = hostile::nest("Deep", 40, 1);
    let wide = hostile::nest("Wide", 4, 100);
    let deep_type = hostile::as_sent(&deep);
    // The fan-out is refused even by its sender's build (100^4 fields): it
    // announces a hash of its own making, as a hostile node would.
    let wide_hash = "RIHS01_".to_owned() + &"ab".repeat(32);
    let served = [
        (deep_type.type_hash(), deep.clone()),
        (wide_hash.clone(), wide),
    ];
    let _server = node
        .declare_service::<GetTypeDescription>("~/get_type_description")
        .handler(
            move |request| match served.iter().find(|(hash, _)| *hash == request.type_hash) {
                Some((_, description)) => GetTypeDescription_Response {
                    successful: true,
                    type_description: description.clone(),
                    ..Default::default()
                },
                None => GetTypeDescription_Response::default(),
            },
        )
        .wait()
        .unwrap();
    let deep_bytes = shm_cdr::to_vec(&deep_type.default_message()).unwrap();
    let publishers = [
        ("/deep", deep_type.name().to_owned(), deep_type.type_hash()),
        ("/wide", "hostile_msgs/msg/Wide0".to_owned(), wide_hash),
    ]
    .map(|(topic, name, hash)| {
        node.declare_serialized_publisher(topic, &name, &hash, Qos::default())
            .wait()
            .unwrap()
    });
    let _chatter = keep_publishing(&node, "/chatter", RosString { data: "ok".into() });
    let alive = std::sync::Arc::new(());
    let weak = std::sync::Arc::downgrade(&alive);
    std::thread::spawn(move || {
        while weak.upgrade().is_some() {
            for publisher in &publishers {
                let _ = publisher.publish_serialized(&deep_bytes);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    });

    let refusal = |output: &Output, limit: &str| {
        let stderr = String::from_utf8_lossy(&output.stderr);
        println!("{stderr}");
        assert_eq!(output.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains(limit), "{stderr}");
        assert!(stderr.len() < 2000, "{stderr}");
    };
    refusal(
        &run(port, &["topic", "echo", "/deep", "--once"]),
        "max_depth",
    );
    refusal(
        &run(port, &["topic", "echo", "/wide", "--once"]),
        "max_message_fields",
    );
    refusal(
        &run(port, &["topic", "pub", "--once", "/deep", "{}"]),
        "max_depth",
    );
    refusal(&run(port, &["topic", "hz", "/wide"]), "max_message_fields");

    // The recorder records every topic, these two without the definitions
    // their node gives (refused), and says why.
    let dir = std::env::temp_dir().join(format!("shm_cli_hostile_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let bag = dir.join("bag");
    let output = run(
        port,
        &[
            "bag",
            "record",
            "-o",
            bag.to_str().unwrap(),
            "--duration",
            "4",
            "--no-progress",
            "--disable-keyboard-controls",
            "/chatter",
            "/deep",
            "/wide",
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    let said = |topic: &str, limit: &str| {
        stderr.lines().any(|line| {
            line.starts_with(&format!("{topic} ("))
                && line.contains("recorded without its definition")
                && line.contains(limit)
        })
    };
    assert!(said("/deep", "max_depth"), "{stderr}");
    assert!(said("/wide", "max_message_fields"), "{stderr}");
    let recorded = shm_bag::Bag::open(&bag).unwrap();
    let counts: std::collections::BTreeMap<String, u64> = recorded
        .topics()
        .unwrap()
        .into_iter()
        .map(|t| (t.name, t.message_count))
        .collect();
    for topic in ["/chatter", "/deep", "/wide"] {
        assert!(counts.get(topic).is_some_and(|n| *n > 0), "{counts:?}");
    }
    // Their schemas are empty, as rosbag2 writes a type it has no definition of.
    let definitions = recorded.definitions().unwrap();
    assert!(
        definitions.contains_key("std_msgs/msg/String"),
        "{definitions:?}"
    );
    assert!(
        !definitions.contains_key(deep_type.name()),
        "{definitions:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    drop(alive);
}

/// A node `talker` publishing "hi" on `/chatter` every 50 ms while the flag
/// lives, and an empty directory `<temp>/<name>_<pid>`.
fn chattering(session: &Session, name: &str) -> (RosNode, std::sync::Arc<()>, std::path::PathBuf) {
    let node = RosNode::builder(session, "talker")
        .domain_id(0)
        .wait()
        .unwrap();
    let alive = keep_publishing(&node, "/chatter", RosString { data: "hi".into() });
    let dir = std::env::temp_dir().join(format!("{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    (node, alive, dir)
}

/// `bag record` of `/chatter` into `bag`, with `extra` options.
fn record_chatter(port: u16, bag: &std::path::Path, extra: &[&str]) -> Command {
    let bag = bag.to_str().unwrap();
    let mut args = vec![
        "bag",
        "record",
        "-o",
        bag,
        "--no-progress",
        "--disable-keyboard-controls",
    ];
    args.extend_from_slice(extra);
    args.push("/chatter");
    cli(port, &args)
}

/// What `docker stop`, systemd, launch and a closed terminal send stops a
/// recording as Ctrl-C does: the files finished, `metadata.yaml` written,
/// the totals printed, exit status 0.
#[test]
fn bag_record_finishes_its_files_on_sigterm_sighup_and_sigint() {
    let (session, port) = listening_session();
    let (_talker, alive, dir) = chattering(&session, "shm_cli_signals");
    for signal in ["TERM", "HUP", "INT"] {
        let bag = dir.join(signal);
        let mut child = record_chatter(port, &bag, &[])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Until metadata.yaml counts a message on disk (chunks close every
        // second).
        let deadline = std::time::Instant::now() + TIMEOUT;
        while shm_bag::BagMetadata::read(&bag).map_or(true, |m| m.message_count == 0) {
            if std::time::Instant::now() > deadline {
                let _ = child.kill();
                panic!("nothing recorded");
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let sent = Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let output = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            output.status.success(),
            "SIG{signal}: {:?} {stderr}",
            output.status
        );
        assert!(stderr.contains("Recorded "), "SIG{signal}: {stderr}");
        let metadata = shm_bag::BagMetadata::read(&bag).unwrap();
        assert!(metadata.message_count > 0, "SIG{signal}");
        let recorded = shm_bag::Bag::open(&bag).unwrap();
        assert_eq!(
            recorded
                .topics()
                .unwrap()
                .iter()
                .map(|t| t.message_count)
                .sum::<u64>(),
            metadata.message_count
        );
    }

    // Played on a terminal, a progress line shows where the playback is in
    // the recording; off a terminal, nothing of it.
    let bag = dir.join("INT");
    let play = format!(
        "'{}' --connect tcp/127.0.0.1:{port} --domain-id 0 bag play '{}' \
         --disable-keyboard-controls",
        env!("CARGO_BIN_EXE_shm-ros2"),
        bag.display()
    );
    let on_terminal = Command::new("script")
        .args(["-qec", &play, "/dev/null"])
        .env("RUST_LOG", "error")
        .output()
        .unwrap();
    let shown = String::from_utf8_lossy(&on_terminal.stdout);
    assert!(on_terminal.status.success(), "{shown}");
    assert!(
        shown.contains(" at 1x [RUNNING]") && shown.contains("Played "),
        "{shown}"
    );
    let off_terminal = run(port, &["bag", "play", bag.to_str().unwrap()]);
    let said = String::from_utf8_lossy(&off_terminal.stderr);
    assert!(off_terminal.status.success(), "{said}");
    assert!(
        !said.contains("[RUNNING]") && said.contains("Played "),
        "{said}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    drop(alive);
}

/// `kill -9` of a recording loses at most the last chunk interval: the
/// player says how to recover, `bag reindex` rewrites the unfinished file,
/// and every message `metadata.yaml` counted before the kill reads back.
#[test]
fn a_killed_recording_is_reindexed_with_all_but_its_last_second() {
    let (session, port) = listening_session();
    let (_talker, alive, dir) = chattering(&session, "shm_cli_kill9");
    let bag = dir.join("bag");
    let mut child = record_chatter(port, &bag, &["--compression-format", "zstd"])
        .spawn()
        .unwrap();
    // Until metadata.yaml has counted messages on disk twice.
    let deadline = std::time::Instant::now() + TIMEOUT;
    let mut counted = Vec::new();
    while counted.len() < 2 {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("nothing recorded");
        }
        if let Ok(m) = shm_bag::BagMetadata::read(&bag) {
            if m.message_count > counted.last().copied().unwrap_or(0) {
                counted.push(m.message_count);
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let before = shm_bag::BagMetadata::read(&bag).unwrap().message_count;
    assert!(before >= counted[1]);

    let unfinished = shm_bag::Bag::open(&bag).unwrap().topics().unwrap_err();
    assert!(
        unfinished.to_string().contains("bag reindex"),
        "{unfinished}"
    );
    // `bag info` shows what metadata.yaml holds, with the distribution the
    // recorder spoke, and says that the file was not finished.
    let info = run(port, &["bag", "info", bag.to_str().unwrap()]);
    let shown = stdout(&info);
    assert!(shown.contains("ROS Distro:        kilted"), "{shown}");
    let said = String::from_utf8_lossy(&info.stderr);
    assert!(
        said.starts_with("WARNING: ")
            && said.contains("was not finished")
            && said.contains("bag reindex"),
        "{said}"
    );
    let out = stdout(&run(port, &["bag", "reindex", bag.to_str().unwrap()]));
    assert!(out.contains("rewritten with"), "{out}");
    assert!(bag.join("bag_0.mcap.unfinished").exists());

    let recorded = shm_bag::Bag::open(&bag).unwrap();
    let metadata = recorded.metadata().unwrap().clone();
    assert!(
        metadata.message_count >= before,
        "{} < {before}",
        metadata.message_count
    );
    let mut read = 0u64;
    recorded
        .read_messages(
            0,
            |_| {},
            |topic, _, data| {
                assert_eq!(topic, "/chatter");
                let text: RosString = shm_cdr::from_bytes(data).unwrap();
                assert_eq!(text.data, "hi");
                read += 1;
                std::ops::ControlFlow::<()>::Continue(())
            },
        )
        .unwrap();
    assert_eq!(read, metadata.message_count);
    assert_eq!(
        recorded.topics().unwrap()[0].message_count,
        metadata.message_count
    );
    let info = run(port, &["bag", "info", bag.to_str().unwrap()]);
    assert!(stdout(&info).contains("ROS Distro:        kilted"));
    assert_eq!(
        String::from_utf8_lossy(&info.stderr),
        "",
        "reindexed: nothing to say"
    );
    let _ = std::fs::remove_dir_all(&dir);
    drop(alive);
}

/// Record `topic` into `bag` until `metadata.yaml` counts a message on disk,
/// then stop the recorder as Ctrl-C does.
fn record_a_while(port: u16, bag: &std::path::Path, topic: &str) {
    let mut child = cli(
        port,
        &[
            "bag",
            "record",
            "-o",
            bag.to_str().unwrap(),
            "--no-progress",
            "--disable-keyboard-controls",
            topic,
        ],
    )
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    let deadline = std::time::Instant::now() + TIMEOUT;
    while shm_bag::BagMetadata::read(bag).map_or(true, |m| m.message_count == 0) {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("nothing recorded of {topic}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let output = child.wait_with_output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// A recording of a type no tool was built with plays back as it was
/// recorded: the player's node describes the type from the definition the
/// recording keeps, so `topic echo` reads the played messages and a second
/// recording keeps the same definition.
#[test]
fn a_played_type_of_its_own_is_echoed_and_recorded_again() {
    let (session, port) = listening_session();
    let dir = std::env::temp_dir().join(format!("shm_cli_replayed_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (first, second) = (dir.join("first"), dir.join("second"));
    let battery = Battery {
        voltage: 12.5,
        cells: vec![3300, 3310, 3290],
        label: "main".into(),
    };
    {
        let driver = RosNode::builder(&session, "driver")
            .domain_id(0)
            .wait()
            .unwrap();
        let _alive = keep_publishing(&driver, "/battery", battery.clone());
        record_a_while(port, &first, "/battery");
    }
    let recorded = shm_bag::Bag::open(&first).unwrap().definitions().unwrap();
    let definition = &recorded[Battery::TYPE_NAME];
    assert!(definition.contains("uint16[] cells"), "{definition}");

    // The driver is gone: only the player knows the type now.
    let graph = RosNode::builder(&session, "watch")
        .domain_id(0)
        .wait()
        .unwrap()
        .graph_cache()
        .unwrap();
    assert!(graph.wait_until(TIMEOUT, |g| g.publishers("/battery").is_empty()));
    let _player = Running::start(port, &["bag", "play", "--loop", first.to_str().unwrap()]);
    let out = stdout(&run(port, &["topic", "echo", "/battery", "--once"]));
    assert_eq!(
        out,
        "voltage: 12.5\ncells:\n- 3300\n- 3310\n- 3290\nlabel: main\n---\n"
    );

    record_a_while(port, &second, "/battery");
    let again = shm_bag::Bag::open(&second).unwrap();
    assert_eq!(
        &again.definitions().unwrap()[Battery::TYPE_NAME],
        definition
    );
    let topics = again.topics().unwrap();
    assert_eq!(topics[0].type_hash, Battery::type_hash());
    let mut read = 0;
    again
        .read_messages(
            0,
            |_| {},
            |_, _, data| {
                let played: Battery = shm_cdr::from_bytes(data).unwrap();
                assert_eq!(played, battery);
                read += 1;
                std::ops::ControlFlow::<()>::Continue(())
            },
        )
        .unwrap();
    assert!(read > 0);
    let info = stdout(&run(port, &["bag", "info", second.to_str().unwrap()]));
    assert!(!info.contains("without its definition"), "{info}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `topic shm` counts how a topic's messages reached the tool, by
/// publisher: in shared memory when the publisher's pool holds them (where
/// the memory-lock limit leaves it one), copied below its threshold.
#[test]
fn topic_shm_counts_what_arrived_in_shared_memory_by_publisher() {
    use shm_cdr::msgs::sensor_msgs::Image;
    use shm_runtime::{ShmConfig, ShmContext};
    let (session, port) = listening_session();
    let shm = ShmContext::new(ShmConfig::enabled()).unwrap();
    let node = RosNode::builder(&session, "camera")
        .domain_id(0)
        .shm(&shm)
        .wait()
        .unwrap();
    let image = Image {
        data: vec![7; 64 << 10],
        ..Default::default()
    };
    let _images = keep_publishing(&node, "/image", image.clone());
    let _chatter = keep_publishing(&node, "/chatter", RosString { data: "hi".into() });
    // What the publisher does with each image: a pool, or none to be had.
    let probe = node.declare_publisher::<Image>("/probe").wait().unwrap();
    let pooled = probe.publish(&image).wait().unwrap().kind.is_shm();

    let counts = |topic: &str| {
        let out = stdout(&run(port, &["topic", "shm", topic, "-n", "20"]));
        let mut lines = out.lines();
        let total = lines.next().unwrap_or_default().to_owned();
        let from = lines.next().unwrap_or_default().to_owned();
        let number = |after: &str| -> u64 {
            let (_, rest) = total.split_once(after).unwrap_or_else(|| panic!("{out}"));
            rest.split_whitespace().next().unwrap().parse().unwrap()
        };
        (number(": "), number("messages: "), from, out.clone())
    };
    let (messages, in_shm, from, out) = counts("/chatter");
    assert_eq!((messages, in_shm), (20, 0), "{out}");
    assert!(
        from.starts_with("  from /camera: 20 messages: 0 in shared memory"),
        "{out}"
    );
    let (messages, in_shm, from, out) = counts("/image");
    assert_eq!(messages, 20, "{out}");
    if pooled {
        assert!(in_shm > 0, "{out}");
    } else {
        assert_eq!(in_shm, 0, "{out}");
    }
    assert!(from.starts_with("  from /camera: 20 messages"), "{out}");
}

#[test]
fn version_names_the_zenoh_line_and_who_shares_memory_with_it() {
    let out = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
        .arg("--version")
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = stdout(&out);
    let line = shm_runtime::ZenohLine::BUILT;
    let protocol = shm_runtime::ZenohLine::BUILT_SHM_PROTOCOL;
    assert!(
        text.contains(&format!(
            "\nZenoh {line} (shared-memory protocol {protocol})\n"
        )),
        "{text}"
    );
    // The workspace's line shares memory with every distribution's nodes.
    assert!(
        text.contains(
            "shared memory with rmw_zenoh_cpp nodes of: humble, jazzy, kilted, lyrical, rolling"
        ),
        "{text}"
    );
    // -V stays short, as clap prints it.
    let short = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
        .arg("-V")
        .output()
        .unwrap();
    assert_eq!(stdout(&short).lines().count(), 1);
}

#[test]
fn output_into_a_closed_pipe_ends_quietly() {
    // `shm-ros2 interface list | head -1`, with the reader gone before the
    // first line: every write fails with EPIPE.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
        .args(["interface", "list"])
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    assert!(stderr.is_empty(), "{stderr}");
}

#[test]
fn a_misspelt_type_is_named_with_the_type_meant() {
    let (_session, port) = listening_session();
    // Nothing on /x: the type cannot be asked of a node either.
    let output = run(
        port,
        &["topic", "pub", "--once", "/x", "std_msgs/msg/Strin", "{}"],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("std_msgs/msg/Strin is not a standard type")
            && stderr.contains("(did you mean std_msgs/msg/String?)")
            && stderr.contains("no node on /x"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("topic echo"),
        "another verb's advice: {stderr}"
    );
    // echo with the type given says the same.
    let output = run(port, &["topic", "echo", "/x", "std_msgs/Strin", "--once"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("(did you mean std_msgs/msg/String?)"),
        "{stderr}"
    );
    // Nothing near: no guess.
    let output = run(
        port,
        &["topic", "pub", "--once", "/x", "my_robot/msg/Scan", "{}"],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("did you mean"), "{stderr}");
}

#[test]
fn hz_on_a_topic_not_yet_published_warns_and_waits_for_it() {
    let (session, port) = listening_session();
    let hz = Running::start(port, &["topic", "hz", "/later"]);
    // ros2topic's words, after --timeout (5 s) without the topic.
    assert_eq!(
        hz.line(),
        "WARNING: topic [/later] does not appear to be published yet"
    );
    let node = RosNode::builder(&session, "late_talker")
        .domain_id(0)
        .wait()
        .unwrap();
    let _later = keep_publishing(
        &node,
        "/later",
        RosString {
            data: "late".into(),
        },
    );
    let first = hz.line();
    assert!(first.starts_with("average rate: "), "{first}");
}

#[test]
fn echo_and_pub_of_another_type_than_the_topics_say_so() {
    let (session, port) = listening_session();
    let node = RosNode::builder(&session, "typed")
        .domain_id(0)
        .wait()
        .unwrap();
    let _talking = keep_publishing(
        &node,
        "/typed",
        RosString {
            data: "text".into(),
        },
    );
    let _listening = node
        .declare_subscriber::<RosString>("/typed_in")
        .wait()
        .unwrap();

    // echo says at once what the publishers send, and keeps waiting.
    let mut echo = cli(port, &["topic", "echo", "/typed", "std_msgs/msg/Int32"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let err = echo.stderr.take().unwrap();
    let (tx, lines) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let warning = lines.recv_timeout(TIMEOUT).expect("a warning");
    assert_eq!(
        warning,
        "WARNING: /typed has 1 publisher, of std_msgs/msg/String, not std_msgs/msg/Int32: \
         this command hears none of them. Without a type, `shm-ros2 topic echo /typed` \
         takes the one its publishers announce. Still waiting."
    );
    assert!(echo.try_wait().unwrap().is_none(), "echo stopped");
    let _ = echo.kill();
    let _ = echo.wait();

    // pub says that no subscriber receives what it sends.
    let publish_once = |type_name: &str, value: &str| {
        run(
            port,
            &[
                "topic",
                "pub",
                "--times",
                "1",
                "/typed_in",
                type_name,
                value,
            ],
        )
    };
    let out = publish_once("std_msgs/msg/Int32", "{data: 7}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains(
            "WARNING: /typed_in has 1 subscriber, of std_msgs/msg/String, not \
             std_msgs/msg/Int32: none of them receives these messages."
        ),
        "{err}"
    );

    // The topic's own type: not a word.
    let out = publish_once("std_msgs/msg/String", "{data: x}");
    assert!(out.status.success());
    assert_eq!(String::from_utf8_lossy(&out.stderr), "");
}

/// A configuration mistake is one line naming what to change, never Zenoh's
/// source paths or debug text, and the status is 1.
#[test]
fn configuration_mistakes_say_what_to_write() {
    let check = |args: &[&str], overrides: Option<&str>, expected: &str| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_shm-ros2"));
        command
            .args(args)
            .env_remove("ZENOH_SESSION_CONFIG_URI")
            .env_remove("ZENOH_ROUTER_CONFIG_URI")
            .env_remove("ZENOH_CONFIG_OVERRIDE")
            .env("RUST_LOG", "error");
        if let Some(overrides) = overrides {
            command.env("ZENOH_CONFIG_OVERRIDE", overrides);
        }
        let out = command.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(err.trim_end(), expected, "{args:?}");
    };
    check(
        &["--connect", "127.0.0.1:7447", "topic", "list"],
        None,
        "--connect 127.0.0.1:7447: an endpoint is <protocol>/<address>; write \
         tcp/127.0.0.1:7447 (or tls/, quic/, udp/, unixsock-stream/)",
    );
    check(
        &["router", "--listen", "0.0.0.0:7447"],
        None,
        "--listen 0.0.0.0:7447: an endpoint is <protocol>/<address>; write tcp/0.0.0.0:7447 \
         (or tls/, quic/, udp/, unixsock-stream/)",
    );
    check(
        &["topic", "list"],
        Some("scouting/multicst/enabled=true"),
        "ZENOH_CONFIG_OVERRIDE: `scouting/multicst/enabled=true` cannot be set (no such key \
         in Zenoh's configuration); write `key=value` pairs separated by `;`, each key a path \
         in the Zenoh configuration (`connect/endpoints`) and each value JSON5 \
         (`[\"tls/host:7447\"]`, `\"client\"`)",
    );
    check(
        &[
            "--zenoh-config",
            "/nonexistent/zenoh.json5",
            "topic",
            "list",
        ],
        None,
        "--zenoh-config /nonexistent/zenoh.json5: not a Zenoh configuration (No such file or \
         directory (os error 2)); give the path of a JSON5 Zenoh configuration file",
    );
}

/// `completions bash` gives a script with which bash completes verbs and
/// their options at every level (the hyphen in the name included).
#[test]
fn bash_completes_verbs_and_options_at_every_level() {
    let out = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
        .args(["completions", "bash"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let script = std::env::temp_dir().join(format!("shm-ros2-{}.bash", std::process::id()));
    std::fs::write(&script, &out.stdout).unwrap();
    let complete = |words: &[&str]| -> String {
        let cword = words.len() - 1;
        let prev = if cword > 0 { words[cword - 1] } else { "" };
        let program = format!(
            "source '{}'; COMP_WORDS=({}); COMP_CWORD={cword}; _shm__ros2 shm-ros2 '{}' '{prev}'; \
             echo \"${{COMPREPLY[*]}}\"",
            script.display(),
            words
                .iter()
                .map(|w| format!("'{w}'"))
                .collect::<Vec<_>>()
                .join(" "),
            words[cword],
        );
        let out = Command::new("bash")
            .args(["-c", &program])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap().trim().to_owned()
    };
    assert_eq!(complete(&["shm-ros2", "to"]), "topic");
    assert_eq!(complete(&["shm-ros2", "topic", "ec"]), "echo");
    assert_eq!(complete(&["shm-ros2", "topic", "echo", "--on"]), "--once");
    assert_eq!(complete(&["shm-ros2", "bag", "rei"]), "reindex");
    let _ = std::fs::remove_file(script);
}

/// The interfaces of rosbag2 that `bag play` serves and `bag record`
/// publishes are shown and listed like every other.
#[test]
fn rosbag2s_own_interfaces_are_shown() {
    let show = |name: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
            .args(["interface", "show", name])
            .output()
            .unwrap();
        stdout(&out)
    };
    let seek = show("rosbag2_interfaces/srv/Seek");
    assert!(
        seek.contains(
            "builtin_interfaces/Time time\n\tint32 sec\n\tuint32 nanosec\n---\nbool success"
        ),
        "{seek}"
    );
    let event = show("rosbag2_interfaces/msg/WriteSplitEvent");
    assert!(
        event.contains("string closed_file") && event.contains("string opened_file"),
        "{event}"
    );
    let list = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
        .args(["interface", "list"])
        .output()
        .unwrap();
    let list = stdout(&list);
    assert!(
        list.contains("    rosbag2_interfaces/srv/TogglePaused\n"),
        "{list}"
    );
}
