//! The node examples the guide points to, run as a user would run them.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The example built next to this test (`cargo test` builds examples).
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().and_then(Path::parent).unwrap();
    dir.join("examples").join(name)
}

fn run(name: &str, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(example(name))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_parameter_node_takes_its_file_and_the_command_line_and_refuses_a_value_out_of_range() {
    let (ok, out, err) = run(
        "param_node",
        &[
            "0",
            "--ros-args",
            "--params-file",
            "config/driver.yaml",
            "-p",
            "max_speed:=1.2",
        ],
    );
    assert!(ok, "{err}");
    // frame_id from `/**`, the wheels from the node's own section, max_speed from -p.
    assert!(
        out.contains("frame_id=base_link max_speed=1.2 wheels.radius=0.05 wheels.separation=0.3"),
        "{out}"
    );
    let (ok, _, err) = run("param_node", &["0", "--ros-args", "-p", "max_speed:=3.5"]);
    assert!(!ok);
    assert!(
        err.contains("max_speed") && err.contains("out of range"),
        "{err}"
    );
}

#[test]
fn the_simulated_time_node_steps_with_the_simulation() {
    let (ok, out, err) = run("sim_time_node", &[]);
    assert!(ok, "{err}");
    let steps = out
        .lines()
        .filter(|l| l.starts_with("control step"))
        .count();
    // Five simulated seconds in about one real second: a timer of one
    // simulated second fires four or five times (never once per real second).
    assert!((3..=5).contains(&steps), "{out}");
    // None fires while the simulation is paused: the step after the pause is
    // at the third simulated second at the earliest.
    let after_pause = out
        .lines()
        .skip_while(|l| !l.starts_with("paused"))
        .find(|l| l.starts_with("control step"));
    if let Some(line) = after_pause {
        let t: f64 = line
            .rsplit("t = ")
            .next()
            .unwrap()
            .trim_end_matches(" s")
            .parse()
            .unwrap();
        assert!(t >= 2.99, "{out}");
    }
}

/// The parameter node is configured as ROS 2's nodes are: started beside a
/// router, a parameter client at the router reaches it (as `shm-ros2 param
/// get /robot/driver max_speed` does).
#[test]
fn the_parameter_node_is_reached_through_the_router_a_ros_tool_uses() {
    use shm_runtime::parameters::ParameterValue;
    use shm_runtime::rmw::config;
    use std::time::Duration;
    use zenoh::Wait;

    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let endpoint = format!(r#"["tcp/127.0.0.1:{port}"]"#);
    let mut router = config::default_router_config();
    router.insert_json5("listen/endpoints", &endpoint).unwrap();
    let _router = zenoh::open(router).wait().unwrap();

    let mut node = Command::new(example("param_node"))
        .args(["20", "--ros-args", "-p", "max_speed:=1.25"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "off")
        .env_remove("ZENOH_SESSION_CONFIG_URI")
        .env(
            "ZENOH_CONFIG_OVERRIDE",
            format!("connect/endpoints={endpoint}"),
        )
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // As in ROS 2, the parameter services exist from the node's creation and
    // the parameters from their declaration a moment later: the node prints
    // its configuration once every one is declared.
    let mut stdout = std::io::BufReader::new(node.stdout.take().unwrap());
    struct Kill(std::process::Child);
    impl Drop for Kill {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let _node = Kill(node);
    let configured = std::io::BufRead::lines(&mut stdout)
        .map_while(Result::ok)
        .find(|line| line.starts_with("frame_id="))
        .expect("the node exited before printing its configuration");
    assert!(configured.contains("max_speed=1.25"), "{configured:?}");

    let mut tool = config::default_session_config();
    tool.insert_json5("connect/endpoints", &endpoint).unwrap();
    let session = zenoh::open(tool).wait().unwrap();
    let tool = shm_runtime::RosNode::builder(&session, "tool")
        .wait()
        .unwrap();
    let driver = tool.parameter_client("/robot/driver").unwrap();
    assert!(
        driver.wait_for_services(Duration::from_secs(20)),
        "the node's parameter services never appeared at the router"
    );
    let values = driver.get(&["max_speed"]).unwrap();
    assert_eq!(values, vec![ParameterValue::Double(1.25)]);
}

/// The services and latched-topic example says what it did and logs nothing
/// at warning level or above: it works.
#[test]
fn the_services_example_works_without_a_warning() {
    let out = Command::new(example("services_and_latched"))
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(
        stdout.contains("1048576 bytes read in place (shm = true)")
            && stdout.contains("late subscriber got \"version 5\""),
        "{stdout}"
    );
    let loud: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains(" WARN ") || l.contains(" ERROR "))
        .collect();
    assert_eq!(loud, Vec::<&str>::new());
}
